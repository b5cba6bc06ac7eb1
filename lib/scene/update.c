/* locd_scene_update and the lists it leaves.
 *
 * Incremental path (docs/scene.md): the moved objects' cells are computed
 * again; those whose cells changed have their old entries deleted and new
 * ones added by one merge pass per list; the pairs of the moved objects
 * are found in the repaired lists (find.c); the pairs between unmoved
 * objects are carried over from the previous set. The rebuild path
 * (first update, a box outside the root cube, more index bits needed, or
 * most objects moved) fits a new grid and does everything from scratch.
 *
 * Either path builds the new lists in buffers of their own and swaps them
 * in at the end; the per-slot cells it writes early are restored on
 * failure. So a failing update changes nothing: the pending changes stay
 * pending for the next one. */
#include "scene/scene.h"

/* Find the pairs from scratch when more than this fraction of the objects
 * moved: at 10^6 uniform cubes on 2 threads, 8% moving objects that all
 * search the entry lists cost about what a from-scratch update costs
 * (docs/scene.md). With partner lists, objects that stay in their fat
 * boxes cost a tenth of that: up to LC_REBUILD_FRACTION_ADJ of them moving
 * is cheaper than from scratch (`locd frames u.aabb --moving P`). When the
 * first pass finds that most of the moved objects left their fat boxes,
 * the update goes on as without partner lists (LC_REBUILD past 8%). */
#define LC_REBUILD_FRACTION 0.08
#define LC_REBUILD_FRACTION_ADJ 0.25

/* Partner lists are kept while the moved objects mostly stay in their fat
 * boxes. An update where more of them left than stayed (and at least
 * LC_ADJ_MIN_LEFT left) drops the lists: searching every moved object
 * costs less than searching most of them and keeping the lists. They are
 * built again (at commit, from the final boxes) after LC_CALM_UPDATES
 * updates in a row in which nine in ten moved objects stayed. */
#define LC_ADJ_MIN_LEFT 1024
#define LC_CALM_UPDATES 4

/* A scene with no lists (its last update was from scratch) would go from
 * scratch again at every update where more than 8% of its objects moved,
 * and never get the lists that make up to 25% cheaper. Of such updates in
 * a row with at most 25% moved, the LC_BAND_WAIT-th builds the lists
 * instead (a relist: several from-scratch updates' cost, once). When
 * the lists are then dropped (the objects jump), the wait doubles, up to
 * LC_BAND_WAIT_MAX; an update whose moved objects mostly stayed in their
 * fat boxes sets it back. */
#define LC_BAND_WAIT 2
#define LC_BAND_WAIT_MAX 64

typedef struct upd {
    locd_scene *s;
    uint32_t flags;
    lc_tree dyn, sta;   /* the new lists */
    lc_plist next, cr, lo;
    lc_cells *cells;    /* rebuild: new per-slot cells (slot_cap) */
    lc_hot *hot;        /* rebuild: new records (hot_cap) */
    uint64_t *hq;       /* rebuild: their packed boxes (LC_HQ * hot_cap) */
    size_t hot_cap, ndense;
    uint32_t *dense;    /* rebuild: new per-slot dense indices (slot_cap) */
    locd_grid grid;     /* rebuild: the new grid */
    /* incremental: undo of the per-slot cells written early */
    uint32_t *undo_slot;
    lc_cells *undo_cells;
    lc_hot *undo_hot;
    uint64_t *undo_hq;  /* LC_HQ a row */
    uint32_t *undo_dense;
    lc_cells *new_cells; /* pass 1's cells and packed boxes (LC_QPAIR) of the dirty objects, for pass 2;
                            pad[0] of the cells is 1 for an object that stays in its fat box */
    uint64_t *new_q;
    /* the moved objects that take their pairs from their partner lists
       (coast) and those that search the entry lists (srch): dense indices */
    uint32_t *coast, *srch;
    size_t ncoast, nsrch;
    int events;     /* the changes come from the partner lists' PAIRED bits (moved_events) */
    int in_place;   /* moved_events patched s->pairs itself (u->next is unused) */
    int adj_after;  /* build the partner lists at commit */
    lc_found found; /* what the moved objects' search found */
    size_t ndense_before;
    uint8_t *undo_flags;
    size_t nundo, undo_cap;
    lc_tree_edit edit[2]; /* incremental: of the dynamic and the static list */
    uint64_t *buf; /* del/add/query entries */
    size_t buf_cap;
    uint64_t candidates, moved, reencoded;
    int rebuilt;  /* pairs from scratch, lists dropped */
    int near;     /* pairs from the near-pair list (near_list.c) */
    int relisted; /* lists built again, then the moved objects searched */
    double ms_encode, ms_merge, ms_sweep, ms_events;
} upd;

static void swap_plist(lc_plist *a, lc_plist *b)
{
    lc_plist t = *a;
    *a = *b;
    *b = t;
}

static void swap_tree(lc_tree *a, lc_tree *b)
{
    lc_tree t = *a;
    *a = *b;
    *b = t;
}

/* The update's event buffers come from the scene's spares and go back
 * there (after commit: the events before last's), so that a frame does not
 * fault in two lists sized for a whole pair set. */
static void take_event_buffers(upd *u)
{
    u->cr = u->s->spare_cr, u->lo = u->s->spare_lo;
    u->cr.count = u->cr.first = u->lo.count = u->lo.first = 0;
    memset(&u->s->spare_cr, 0, sizeof u->s->spare_cr);
    memset(&u->s->spare_lo, 0, sizeof u->s->spare_lo);
}

static void keep_event_buffers(upd *u)
{
    u->s->spare_cr = u->cr, u->s->spare_lo = u->lo;
    memset(&u->cr, 0, sizeof u->cr);
    memset(&u->lo, 0, sizeof u->lo);
}

static void upd_free(upd *u)
{
    const locd_allocator *a = u->s->alloc;
    lc_tree_release(a, &u->dyn);
    lc_tree_release(a, &u->sta);
    lc_tree_edit_free(a, &u->edit[0]);
    lc_tree_edit_free(a, &u->edit[1]);
    lc_plist_fini(a, &u->next);
    lc_plist_fini(a, &u->cr);
    lc_plist_fini(a, &u->lo);
    lc_free(a, u->cells, u->s->slot_cap * sizeof *u->cells);
    lc_free(a, u->hot, u->hot_cap * sizeof *u->hot);
    lc_free(a, u->hq, u->hot_cap * LC_HQ * sizeof *u->hq);
    lc_free(a, u->dense, u->s->slot_cap * sizeof *u->dense);
    lc_free(a, u->undo_slot, u->undo_cap * sizeof *u->undo_slot);
    lc_free(a, u->undo_cells, u->undo_cap * sizeof *u->undo_cells);
    lc_free(a, u->undo_hot, u->undo_cap * sizeof *u->undo_hot);
    lc_free(a, u->undo_hq, u->undo_cap * LC_HQ * sizeof *u->undo_hq);
    lc_free(a, u->coast, u->undo_cap * sizeof *u->coast);
    lc_free(a, u->srch, u->undo_cap * sizeof *u->srch);
    lc_plist_fini(a, &u->found.rows);
    lc_buf_release(a, &u->found.fat, 2 * sizeof(uint32_t));
    lc_buf_release(a, &u->found.ev, 3 * sizeof(uint32_t));
    lc_free(a, u->undo_dense, u->undo_cap * sizeof *u->undo_dense);
    lc_free(a, u->new_cells, u->undo_cap * sizeof *u->new_cells);
    lc_free(a, u->new_q, u->undo_cap * LC_QPAIR * sizeof *u->new_q);
    lc_free(a, u->undo_flags, u->undo_cap * sizeof *u->undo_flags);
    lc_free(a, u->buf, u->buf_cap * sizeof *u->buf);
}

/* In undo_flags beside a slot's flags (which use the 7 low bits): the row
 * saved the record only (an object that stayed in its fat box). */
#define LC_UNDO_RECORD 0x80u

/* Puts back what a failed incremental update wrote early: the cells and
 * hot records of the moved objects, the tombstones. */
static void undo(upd *u)
{
    locd_scene *s = u->s;
    size_t k;
    for (k = u->nundo; k-- > 0;) {
        uint32_t slot = u->undo_slot[k];
        uint32_t di = (u->undo_flags[k] & LC_SLOT_INTREE) ? u->undo_dense[k] : s->dense[slot];
        s->hot[di] = u->undo_hot[k];
        if (u->undo_flags[k] & LC_UNDO_RECORD) /* the record was all that changed */
            continue;
        memcpy(s->hq + LC_HQ * (size_t)di, u->undo_hq + LC_HQ * k, LC_HQ * sizeof *s->hq);
        s->cell[slot] = u->undo_cells[k];
        s->dense[slot] = u->undo_dense[k];
        s->flags[slot] = u->undo_flags[k];
    }
    if (u->nundo)
        s->ndense = u->ndense_before;
    u->nundo = 0;
    if (!u->rebuilt && !u->relisted)
        for (k = 0; k < s->nremoved; k++) {
            const uint32_t slot = ((const uint32_t *)s->removed.data)[k];
            if (s->flags[slot] & LC_SLOT_INTREE)
                s->hot[s->dense[slot]].flags &= ~(uint32_t)LC_HOT_GONE;
        }
    lc_tree_edit_undo(&s->dyn, &u->edit[0]);
    lc_tree_edit_undo(&s->sta, &u->edit[1]);
}

/* A wait (in updates) doubled after a cache that did not pay for itself,
 * up to LC_BAND_WAIT_MAX: the band rule's lists, the near-pair list. */
LC_INLINE uint32_t doubled_wait(uint32_t w)
{
    return 2 * w < LC_BAND_WAIT_MAX ? 2 * w : LC_BAND_WAIT_MAX;
}

LC_INLINE uint32_t band_wait(const locd_scene *s)
{
    return s->band_wait ? s->band_wait : LC_BAND_WAIT;
}

/* 1 when a scene with no lists had more than 8% and at most 25% of its
 * objects moved (see LC_BAND_WAIT). */
static int in_band(const locd_scene *s, size_t moved)
{
    return s->have_pairs && !s->have_tree && (double)moved > LC_REBUILD_FRACTION * (double)s->live &&
           (double)moved <= LC_REBUILD_FRACTION_ADJ * (double)s->live && moved > 64;
}

/* 1 when this update should find its pairs from scratch: the first one,
 * or more than LC_REBUILD_FRACTION of the objects moved. */
static int want_rebuild(const locd_scene *s, size_t moved)
{
    if (!s->have_pairs)
        return 1;
    return (double)moved > (s->have_adj ? LC_REBUILD_FRACTION_ADJ : LC_REBUILD_FRACTION) * (double)s->live &&
           moved > 64;
}

/* The entry lists must be built again before the moved objects' search
 * when there are none (the last update found its pairs from scratch), and
 * when a moved box lies outside the root cube or more objects are new than
 * the numbering has room for: the incremental path's first pass finds
 * those two (LC_RELIST). */
#define LC_RELIST 0x52454c /* internal, never returned: not a locd_status */
/* Likewise: the incremental path's first pass found it should not go on. */
#define LC_REBUILD 0x524542

static locd_status events_full(upd *u);
static locd_status rebuild(upd *u);

/* The near-pair list (near_list.c) serves updates in which most objects
 * moved a little: more than LC_REBUILD_FRACTION_ADJ of them. Below that
 * the incremental path serves them, with partner lists from 8% on (the
 * band rule): it searches the few objects that left their fat boxes,
 * where the near-pair list is built again whole as soon as one box left
 * its fat box, which with 10% of 10^6 objects moving a frame happens
 * about every third frame (docs/scene.md). A list that served no update
 * before a box left its fat box cost a build for nothing: the next
 * LC_NEAR_WAIT updates from scratch build none, then twice as many after
 * each such list, up to LC_BAND_WAIT_MAX; a list that served sets it
 * back. */
#define LC_NEAR_WAIT 2

static int near_moved(const locd_scene *s, size_t moved)
{
    return s->have_pairs && (double)moved > LC_REBUILD_FRACTION_ADJ * (double)s->live && moved > 64;
}

/* 1 when this update from scratch should build the near-pair list. */
static int want_near(locd_scene *s, size_t moved)
{
    if (!near_moved(s, moved) || !lc_near_applies(s))
        return 0;
    if (s->near.skip) {
        s->near.skip--;
        return 0;
    }
    return 1;
}

/* An update from the near-pair list; when a box left its fat box, from
 * scratch (which may build the list again). */
static locd_status near_update(upd *u)
{
    locd_scene *s = u->s;
    lc_near *nr = &s->near;
    double t1 = lc_now_ms();
    int left, diff;
    locd_status st = lc_near_frame(s, &u->next, &u->cr, &u->lo, &u->candidates, &left, &diff);
    if (st != LOCD_OK)
        return st;
    if (!left) {
        u->near = 1;
        u->ms_sweep = lc_now_ms() - t1;
        t1 = lc_now_ms();
        if (diff && (u->flags & LOCD_SCENE_UPDATE_EVENTS) && (st = events_full(u)) != LOCD_OK)
            return st;
        u->ms_events = lc_now_ms() - t1;
        return LOCD_OK;
    }
    if (nr->served == 0) {
        nr->wait = nr->wait ? doubled_wait(nr->wait) : LC_NEAR_WAIT;
        nr->skip = nr->wait;
    } else {
        nr->wait = 0;
    }
    u->next.count = u->next.first = 0;
    return rebuild(u);
}

/* Pairs from scratch (the engine's find); the entry lists are dropped and
 * built again only by the next update that searches moved objects
 * (relist): a scene where most objects move every frame never pays for them. */
static locd_status rebuild(upd *u)
{
    locd_scene *s = u->s;
    locd_status st;
    double t1 = lc_now_ms();
    u->rebuilt = 1;
    if (want_near(s, u->moved)) {
        /* the near-pair list, built from these boxes: the next updates
           may take it; the kept entry list is not needed while they do */
        if ((st = lc_near_build(s, &u->next, &u->candidates)) == LOCD_OK) {
            lc_kept_release(s);
            goto events;
        }
        lc_clear_error(); /* a cache: without it, from scratch */
        u->next.count = u->next.first = 0;
    }
    if ((st = lc_scene_pairs_from_scratch(s, &u->next, &u->candidates)) != LOCD_OK)
        return st;
events:
    u->ms_sweep = lc_now_ms() - t1;
    t1 = lc_now_ms();
    if ((u->flags & LOCD_SCENE_UPDATE_EVENTS) && (st = events_full(u)) != LOCD_OK)
        return st;
    u->ms_events = lc_now_ms() - t1;
    return LOCD_OK;
}

/* Builds the entry lists, cells and records of every live object from its
 * current box on a new grid, and makes them the scene's at once. They are a
 * function of the current boxes alone, so installing them before the
 * update's end changes nothing a failing update must undo: the next
 * incremental update finds every changed object's cells unchanged and
 * still searches it. */
static locd_status build_lists(upd *u)
{
    locd_scene *s = u->s;
    const locd_allocator *a = s->alloc;
    locd_status st;
    size_t k;
    u->cells = lc_alloc(a, s->slot_cap * sizeof *u->cells);
    u->hot_cap = lc_scene_dense_room(s->nslots);
    u->hot = lc_alloc(a, u->hot_cap * sizeof *u->hot);
    u->hq = lc_alloc(a, u->hot_cap * LC_HQ * sizeof *u->hq);
    u->dense = lc_alloc(a, s->slot_cap * sizeof *u->dense);
    if (!u->cells || !u->hot || !u->hq || !u->dense)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's cells");
    memset(u->cells, 0, s->slot_cap * sizeof *u->cells);
    if ((st = lc_scene_fit_grid(s, &u->grid)) != LOCD_OK ||
        (st = lc_scene_build_trees(s, &u->grid, u->cells, u->dense, u->hot, u->hq, &u->ndense, &u->dyn,
                                   &u->sta)) != LOCD_OK)
        return st;
    {
        lc_cells *c = s->cell;
        lc_hot *h = s->hot;
        uint32_t *dn = s->dense;
        uint64_t *hq = s->hq;
        size_t hc = s->hot_cap;
        s->cell = u->cells, u->cells = c;
        s->hot = u->hot, u->hot = h;
        s->hq = u->hq, u->hq = hq;
        s->hot_cap = u->hot_cap, u->hot_cap = hc;
        s->dense = u->dense, u->dense = dn;
    }
    s->ndense = u->ndense;
    s->grid = u->grid;
    swap_tree(&s->dyn, &u->dyn);
    swap_tree(&s->sta, &u->sta);
    s->have_tree = 1;
    for (k = 0; k < s->nslots; k++)
        s->flags[k] = (uint8_t)((s->flags[k] & LC_SLOT_LIVE) ? s->flags[k] | LC_SLOT_INTREE
                                                               : s->flags[k] & ~LC_SLOT_INTREE);
    return LOCD_OK;
}

/* What the lists will be after edit e of t, without copying: a view. */
static void view_tree(const lc_tree *t, const lc_tree_edit *e, lc_tree *v)
{
    if (e->compacted) {
        *v = e->out;
        v->ovf.data = NULL, v->novf = 0;
    } else {
        *v = *t;
        if (e->out.novf != (size_t)-1)
            v->ovf = e->out.ovf, v->novf = e->out.novf;
    }
    memcpy(v->per_level, e->out.per_level, sizeof v->per_level);
}

/* Room for n more entries in u->buf at *len. */
static locd_status buf_room(upd *u, size_t len, size_t n)
{
    if (len + n <= u->buf_cap)
        return LOCD_OK;
    {
        size_t cap = lc_grow_cap(u->buf_cap, len + n);
        uint64_t *b = lc_alloc(u->s->alloc, cap * sizeof *b);
        if (!b)
            return lc_error(LOCD_ERR_NO_MEMORY, "could not grow the entry deltas");
        if (len)
            memcpy(b, u->buf, len * sizeof *b);
        lc_free(u->s->alloc, u->buf, u->buf_cap * sizeof *u->buf);
        u->buf = b, u->buf_cap = cap;
    }
    return LOCD_OK;
}

/* created = next \ previous and lost = previous \ next, split over the
 * pool by key range: thread t writes its rows in the part of each output
 * that its input range would fill, and the parts are closed up after. */
typedef struct diff_ctx {
    const locd_id *p, *n;
    size_t pb[LC_MAX_THREADS + 1], nb[LC_MAX_THREADS + 1], ncr[LC_MAX_THREADS], nlo[LC_MAX_THREADS];
    locd_id *cr, *lo;
} diff_ctx;

static void task_diff(void *arg, uint32_t t, uint32_t k)
{
    diff_ctx *c = arg;
    const locd_id *p = c->p + 2 * c->pb[t], *n = c->n + 2 * c->nb[t];
    size_t np = c->pb[t + 1] - c->pb[t], nn = c->nb[t + 1] - c->nb[t];
    (void)k;
    lc_plist_diff(n, nn, p, np, c->cr + 2 * c->nb[t], &c->ncr[t], c->lo + 2 * c->pb[t], &c->nlo[t]);
}

static locd_status events_full(upd *u)
{
    locd_scene *s = u->s;
    locd_status st;
    diff_ctx c;
    uint32_t k = s->threads ? s->threads : 1, t;
    size_t wc = 0, wl = 0;
    if ((st = lc_plist_reserve(s->alloc, &u->cr, u->next.count + 1)) != LOCD_OK ||
        (st = lc_plist_reserve(s->alloc, &u->lo, s->pairs.count + 1)) != LOCD_OK)
        return st;
    if (u->next.count + s->pairs.count < 65536)
        k = 1;
    c.p = lc_plist_rows(&s->pairs), c.n = lc_plist_rows(&u->next), c.cr = u->cr.rows.data, c.lo = u->lo.rows.data;
    for (t = 0; t <= k; t++) {
        c.nb[t] = u->next.count * t / k;
        c.pb[t] = t == 0 ? 0 : t == k ? s->pairs.count
                                      : lc_rows_lower_bound(c.p, s->pairs.count, lc_pair_key(c.n + 2 * c.nb[t]));
    }
    if (k > 1)
        lc_pool_run(s->pool, k, task_diff, &c);
    else
        task_diff(&c, 0, 1);
    for (t = 0; t < k; t++) {
        memmove(c.cr + 2 * wc, c.cr + 2 * c.nb[t], 2 * c.ncr[t] * sizeof(locd_id));
        memmove(c.lo + 2 * wl, c.lo + 2 * c.pb[t], 2 * c.nlo[t] * sizeof(locd_id));
        wc += c.ncr[t], wl += c.nlo[t];
    }
    u->cr.count = wc, u->lo.count = wl;
    return LOCD_OK;
}

/* The moved objects' records lose the update's flags once the search has
 * read them: here, before the pass over the whole set (which evicts them
 * from the caches), rather than at commit. undo() puts the records back
 * whole if the update fails after. */
static void clear_moved_records(upd *u)
{
    lc_hot *hot = u->s->hot;
    size_t k;
    for (k = 0; k < u->ncoast; k++)
        hot[u->coast[k]].flags &= ~(uint32_t)(LC_SLOT_DIRTY | LC_HOT_SEARCH);
    for (k = 0; k < u->nsrch; k++)
        hot[u->srch[k]].flags &= ~(uint32_t)(LC_SLOT_DIRTY | LC_HOT_SEARCH);
}

/* The pairs of the moved objects (query entries q, sorted, searched in the
 * lists dyn and sta; u->coast from their partner lists), the carry pass,
 * and the events. */
static locd_status moved_pairs(upd *u, const lc_tree *dyn, const lc_tree *sta, const uint64_t *q, size_t nq)
{
    locd_scene *s = u->s;
    const locd_allocator *a = s->alloc;
    lc_plist *n = &u->found.rows, dropped = s->spare_drop;
    locd_status st;
    double t0 = lc_now_ms(), t1;
    dropped.count = dropped.first = 0;
    memset(&s->spare_drop, 0, sizeof s->spare_drop);
    st = lc_scene_find_moved(s, dyn, sta, q, nq, u->coast, u->ncoast, LC_FIND_ROWS, &u->found);
    t1 = lc_now_ms();
    u->ms_sweep = t1 - t0;
    t0 = t1;
    if (!u->relisted)
        clear_moved_records(u);
    if (st == LOCD_OK)
        st = lc_scene_carry(s, n, &u->next, &dropped);
    if (st == LOCD_OK && (u->flags & LOCD_SCENE_UPDATE_EVENTS)) {
        /* previous = kept + dropped, now = kept + n, kept disjoint from both */
        if ((st = lc_plist_reserve(a, &u->cr, n->count + 1)) == LOCD_OK &&
            (st = lc_plist_reserve(a, &u->lo, dropped.count + 1)) == LOCD_OK) {
            lc_plist_diff(n->rows.data, n->count, lc_plist_rows(&dropped), dropped.count, u->cr.rows.data,
                          &u->cr.count, u->lo.rows.data, &u->lo.count);
        }
    }
    u->ms_events = lc_now_ms() - t0;
    s->spare_drop = dropped; /* sized for a whole set: kept, as the set's own buffers */
    return st;
}

/* Appends the row of dense indices m and o to p (room made beforehand). */
LC_INLINE void put_pair(const locd_scene *s, lc_plist *p, uint32_t m, uint32_t o)
{
    const locd_id a = s->hot[m].id, b = s->hot[o].id;
    locd_id *r = (locd_id *)p->rows.data + 2 * p->count++;
    r[0] = a < b ? a : b, r[1] = a < b ? b : a;
}

/* Whether m reports its pair with partner o (their records): not when o
 * was removed (o's removal does), nor when both searched and o's id is the
 * smaller (o does). As the search's rule (find.c), for the pairs of
 * before. */
LC_INLINE int reports(const lc_hot *hm, const lc_hot *ho)
{
    return !(ho->flags & LC_HOT_GONE) && !((ho->flags & LC_HOT_SEARCH) && ho->id < hm->id);
}

/* The changes of an update whose moved objects all have partner lists:
 * created and lost from the PAIRED bits (the previous set) against what
 * the objects' boxes give now, then the new set patched from the previous
 * one (lc_scene_patch). The partner-list pass reports its changes itself;
 * a searched object's pairs of before are its list's PAIRED entries, its
 * pairs now what the search found; a removed object's pairs are lost. The
 * bits are brought up to date at commit (relink). */
static locd_status moved_events(upd *u, const lc_tree *dyn, const lc_tree *sta, const uint64_t *q, size_t nq)
{
    locd_scene *s = u->s;
    const locd_allocator *a = s->alloc;
    const uint32_t *r = s->removed.data;
    lc_found *f = &u->found;
    uint64_t *keys = NULL;
    size_t k, x, nold = 0, nnew = 0, room, nkeys = 0;
    locd_status st;
    double t0 = lc_now_ms(), t1;
    st = lc_scene_find_moved(s, dyn, sta, q, nq, u->coast, u->ncoast, LC_FIND_EVENTS, f);
    t1 = lc_now_ms();
    u->ms_sweep = t1 - t0;
    t0 = t1;
    if (st != LOCD_OK)
        return st;
    /* The searched objects' pairs of before and now, as keys m << 32 | o:
       sorted, then merged. */
    for (k = 0; k < u->nsrch; k++)
        nkeys += s->adj[u->srch[k]].n;
    nkeys += f->nfat;
    if (!(keys = lc_alloc(a, (nkeys + 1) * sizeof *keys))) {
        st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the searched objects' pairs");
        goto done;
    }
    for (k = 0; k < u->nsrch; k++) {
        const uint32_t m = u->srch[k];
        const lc_adj *h = &s->adj[m];
        for (x = 0; x < h->n; x++) {
            const uint32_t e = s->adj_pool[h->off + x], o = e & LC_ADJ_INDEX;
            if ((e & LC_ADJ_PAIRED) && reports(&s->hot[m], &s->hot[o]))
                keys[nold++] = (uint64_t)m << 32 | o;
        }
    }
    for (k = 0; k < f->nfat; k++) {
        const uint32_t *e = (const uint32_t *)f->fat.data + 2 * k;
        if (e[1] & LC_ADJ_PAIRED)
            keys[nold + nnew++] = (uint64_t)e[0] << 32 | (e[1] & LC_ADJ_INDEX);
    }
    if ((st = lc_sort_u64_radix(a, keys, nold)) != LOCD_OK || (st = lc_sort_u64_radix(a, keys + nold, nnew)) != LOCD_OK)
        goto done;
    /* room: every change may be a row */
    room = f->nev + nold + nnew + 1;
    for (k = 0; k < s->nremoved; k++)
        if (s->flags[r[k]] & LC_SLOT_INTREE)
            room += s->adj[s->dense[r[k]]].n;
    if ((st = lc_plist_reserve(a, &u->cr, room)) != LOCD_OK || (st = lc_plist_reserve(a, &u->lo, room)) != LOCD_OK)
        goto done;
    u->cr.count = u->lo.count = u->cr.first = u->lo.first = 0;
    for (k = 0; k < f->nev; k++) {
        const uint32_t *e = (const uint32_t *)f->ev.data + 3 * k;
        put_pair(s, (e[2] & LC_ADJ_PAIRED) ? &u->cr : &u->lo, e[0], e[2] & LC_ADJ_INDEX);
    }
    {
        const uint64_t *old = keys, *now = keys + nold;
        size_t i = 0, j = 0;
        while (i < nold || j < nnew) {
            if (j == nnew || (i < nold && old[i] < now[j])) {
                put_pair(s, &u->lo, (uint32_t)(old[i] >> 32), (uint32_t)old[i]), i++;
            } else if (i == nold || now[j] < old[i]) {
                put_pair(s, &u->cr, (uint32_t)(now[j] >> 32), (uint32_t)now[j]), j++;
            } else {
                i++, j++;
            }
        }
    }
    for (k = 0; k < s->nremoved; k++)
        if (s->flags[r[k]] & LC_SLOT_INTREE) {
            const uint32_t m = s->dense[r[k]];
            const lc_adj *h = &s->adj[m];
            for (x = 0; x < h->n; x++) {
                const uint32_t e = s->adj_pool[h->off + x], o = e & LC_ADJ_INDEX;
                /* of two removed objects, the one with the smaller id reports */
                if ((e & LC_ADJ_PAIRED) && !((s->hot[o].flags & LC_HOT_GONE) && s->hot[o].id < s->hot[m].id))
                    put_pair(s, &u->lo, m, o);
            }
        }
    if ((st = lc_pairs_sort_rows(a, u->cr.rows.data, u->cr.count)) != LOCD_OK ||
        (st = lc_pairs_sort_rows(a, u->lo.rows.data, u->lo.count)) != LOCD_OK)
        goto done;
    clear_moved_records(u);
    /* the last step: in place, nothing after it may fail */
    if (!(u->in_place = lc_scene_patch_in_place(s, &u->lo, &u->cr)) &&
        (st = lc_scene_patch(s, &u->lo, &u->cr, &u->next)) != LOCD_OK)
        goto done;
    if (!(u->flags & LOCD_SCENE_UPDATE_EVENTS))
        u->cr.count = u->lo.count = 0;
done:
    lc_free(a, keys, (nkeys + 1) * sizeof *keys);
    u->ms_events = lc_now_ms() - t0;
    return st;
}

/* The dirty objects' part of an incremental update, split over the pool
 * by ranges of the dirty list when it is long: pass 1 computes each
 * object's new cells and packed box and counts its entries (queries,
 * deleted, added), pass 2 writes them at offsets the counts give. Every
 * part writes where the serial loop would have, and takes the next dense
 * indices in dirty-list order, so the lists and the undo are the same for
 * every thread count. */
#define LC_ENCODE_SPLIT 8192

typedef struct enc_part {
    size_t b, e;                 /* the part of the dirty list */
    size_t nq, ndel[2], nadd[2]; /* pass 1: counts; pass 2: where to write them in u->buf */
    size_t ncoast, nsrch;        /* pass 1: counts; pass 2: where to write them in u->coast, u->srch */
    size_t calm;                 /* pass 1: objects that stayed in their fat boxes (partner lists or not) */
    size_t live, fresh;          /* live objects, those new to the lists; pass 2: first undo row, dense index */
    size_t reenc;                /* objects whose cells changed */
    int outside;                 /* pass 1: a box outside the root cube */
} enc_part;

typedef struct enc_ctx {
    upd *u;
    enc_part part[LC_MAX_THREADS];
    int pass;
} enc_ctx;

/* The counts go through a local copy of the part, stored back at the end:
 * the parts of two threads lie side by side (one cache line may hold the
 * end of one and the start of the next), and the loop stores its counts
 * at every step (it cannot keep them in registers past its other stores). */
static void encode_count(upd *u, enc_part *shared)
{
    locd_scene *s = u->s;
    const locd_grid *g = &s->grid;
    const uint32_t *d = s->dirty.data;
    size_t k;
    enc_part part = *shared, *pt = &part;
    for (k = pt->b; k < pt->e; k++) {
        uint32_t slot = d[k], cnt;
        uint8_t f = s->flags[slot];
        int l = (f & LC_SLOT_STATIC) ? 1 : 0;
        lc_cells c;
        uint64_t *q = u->new_q + LC_QPAIR * k;
        if (k + 2 * LC_AHEAD < pt->e) { /* the dirty slots are scattered: a miss each, overlapped */
            uint32_t ahead = d[k + 2 * LC_AHEAD];
            __builtin_prefetch(s->flags + ahead);
            lc_scene_prefetch_box(s, ahead, 0);
            __builtin_prefetch(s->dense + ahead);
        }
        if (k + LC_AHEAD < pt->e) { /* its dense index has come: its packed fat box */
            uint32_t ahead = d[k + LC_AHEAD];
            if (s->flags[ahead] & LC_SLOT_INTREE)
                __builtin_prefetch(s->hq + LC_HQ * (size_t)s->dense[ahead]);
        }
        if (!(f & LC_SLOT_LIVE))
            continue;
        pt->live++;
        pt->fresh += !(f & LC_SLOT_INTREE);
        {
            double box[6];
            const double *b = lc_scene_box(s, slot, box);
            pt->outside |= !lc_grid_holds(g, b);
            lc_cells_of(g, b, &c, q);
        }
        /* Still inside its fat box, with the filter it had: its cells, its
           entries and its partners stay; only its packed box is new. */
        if ((f & (LC_SLOT_INTREE | LC_SLOT_REFILTER)) == LC_SLOT_INTREE &&
            lc_qbox_inside(q + 2, s->hq + LC_HQ * (size_t)s->dense[slot])) {
            pt->calm++;
            if (s->have_adj) {
                c.pad[0] = 1;
                u->new_cells[k] = c;
                pt->ncoast++;
                continue;
            }
        }
        pt->nsrch++;
        u->new_cells[k] = c;
        cnt = lc_cells_count(&c);
        pt->nq += cnt;
        if ((f & LC_SLOT_INTREE) && lc_cells_same(&c, &s->cell[slot]))
            continue;
        if (f & LC_SLOT_INTREE)
            pt->ndel[l] += lc_cells_count(&s->cell[slot]);
        pt->nadd[l] += cnt;
    }
    *shared = part;
}

static void encode_write(upd *u, enc_part *shared)
{
    locd_scene *s = u->s;
    const locd_grid *g = &s->grid;
    const uint32_t *d = s->dirty.data;
    enc_part part = *shared, *pt = &part; /* as in encode_count */
    size_t k, w = pt->live, at_q = pt->nq, at_del[2] = {pt->ndel[0], pt->ndel[1]},
              at_add[2] = {pt->nadd[0], pt->nadd[1]}, at_coast = pt->ncoast, at_srch = pt->nsrch;
    uint32_t fresh = (uint32_t)pt->fresh;
    for (k = pt->b; k < pt->e; k++) {
        uint32_t slot = d[k], cnt;
        uint8_t f = s->flags[slot];
        int l = (f & LC_SLOT_STATIC) ? 1 : 0;
        lc_cells c;
        const uint64_t *q = u->new_q + LC_QPAIR * k;
        uint32_t di;
        if (k + LC_AHEAD < pt->e) {
            uint32_t ahead = d[k + LC_AHEAD];
            if ((s->flags[ahead] & (LC_SLOT_LIVE | LC_SLOT_INTREE)) == (LC_SLOT_LIVE | LC_SLOT_INTREE)) {
                const char *h = (const char *)&s->hot[s->dense[ahead]];
                __builtin_prefetch(h, 1);
                __builtin_prefetch(h + sizeof(lc_hot) - 1, 1);
                __builtin_prefetch(s->hq + LC_HQ * (size_t)s->dense[ahead], 1);
            }
        }
        if (!(f & LC_SLOT_LIVE))
            continue;
        c = u->new_cells[k];
        /* an object new to the lists takes the next dense index */
        di = (f & LC_SLOT_INTREE) ? s->dense[slot] : fresh++;
        u->undo_slot[w] = slot;
        u->undo_dense[w] = s->dense[slot];
        u->undo_hot[w] = s->hot[di];
        if (c.pad[0]) { /* stays in its fat box: only its record changes */
            u->undo_flags[w++] = f | LC_UNDO_RECORD;
            s->hot[di].qlo = q[2], s->hot[di].qhi = q[3];
            s->hot[di].flags |= LC_SLOT_DIRTY;
            u->coast[at_coast++] = di;
            continue;
        }
        u->undo_cells[w] = s->cell[slot];
        memcpy(u->undo_hq + LC_HQ * w, s->hq + LC_HQ * (size_t)di, LC_HQ * sizeof *s->hq);
        u->undo_flags[w] = f;
        w++;
        u->srch[at_srch++] = di;
        cnt = lc_cells_entries(g, &c, di, u->buf + at_q);
        if (!((f & LC_SLOT_INTREE) && lc_cells_same(&c, &s->cell[slot]))) {
            if (f & LC_SLOT_INTREE)
                at_del[l] += lc_cells_entries(g, &s->cell[slot], di, u->buf + at_del[l]);
            memcpy(u->buf + at_add[l], u->buf + at_q, cnt * sizeof(uint64_t));
            at_add[l] += cnt;
            pt->reenc++;
        }
        at_q += cnt;
        s->cell[slot] = c;
        s->dense[slot] = di;
        if ((f & (LC_SLOT_INTREE | LC_SLOT_REFILTER)) == LC_SLOT_INTREE) { /* moved only: the filter is as it was */
            s->hot[di].qlo = q[2], s->hot[di].qhi = q[3];
        } else {
            lc_hot_fill(s, slot, q, &s->hot[di]);
        }
        s->hot[di].flags |= LC_SLOT_DIRTY | LC_HOT_SEARCH;
        memcpy(s->hq + LC_HQ * (size_t)di, q, LC_HQ * sizeof *q);
        s->flags[slot] |= LC_SLOT_INTREE;
    }
    shared->reenc = pt->reenc;
}

static void task_encode(void *arg, uint32_t t, uint32_t k)
{
    enc_ctx *c = arg;
    (void)k;
    if (c->pass == 1)
        encode_count(c->u, &c->part[t]);
    else
        encode_write(c->u, &c->part[t]);
}

static void encode_run(enc_ctx *c, uint32_t nk, int pass)
{
    c->pass = pass;
    if (nk > 1)
        lc_pool_run(c->u->s->pool, nk, task_encode, c);
    else
        task_encode(c, 0, 1);
}

static locd_status incremental(upd *u)
{
    locd_scene *s = u->s;
    const locd_allocator *a = s->alloc;
    const locd_grid *g = &s->grid;
    const uint32_t *r = s->removed.data;
    size_t k, ndel[2] = {0, 0}, nadd[2] = {0, 0}, nrem[2], nq = 0, off_del[2], off_add[2], off_q;
    locd_status st;
    double t0 = lc_now_ms(), t1;
    enc_ctx ec;
    uint32_t nk, t;
    /* undo room: one per dirty slot */
    u->undo_cap = s->ndirty ? s->ndirty : 1;
    u->undo_slot = lc_alloc(a, u->undo_cap * sizeof *u->undo_slot);
    u->undo_cells = lc_alloc(a, u->undo_cap * sizeof *u->undo_cells);
    u->undo_hot = lc_alloc(a, u->undo_cap * sizeof *u->undo_hot);
    u->undo_hq = lc_alloc(a, u->undo_cap * LC_HQ * sizeof *u->undo_hq);
    u->coast = lc_alloc(a, u->undo_cap * sizeof *u->coast);
    u->srch = lc_alloc(a, u->undo_cap * sizeof *u->srch);
    u->undo_dense = lc_alloc(a, u->undo_cap * sizeof *u->undo_dense);
    u->new_cells = lc_alloc(a, u->undo_cap * sizeof *u->new_cells);
    u->new_q = lc_alloc(a, u->undo_cap * LC_QPAIR * sizeof *u->new_q);
    u->ndense_before = s->ndense;
    u->undo_flags = lc_alloc(a, u->undo_cap * sizeof *u->undo_flags);
    if (!u->undo_slot || !u->undo_cells || !u->undo_hot || !u->undo_flags || !u->undo_dense || !u->new_cells ||
        !u->new_q || !u->undo_hq || !u->coast || !u->srch)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the update's undo list");
    /* Pass 1: the dirty objects' new cells and packed boxes, and the
       counts of the deltas (deleted and added per list, queries). */
    nk = s->threads > 1 && s->ndirty >= LC_ENCODE_SPLIT ? s->threads : 1;
    for (t = 0; t < nk; t++) {
        memset(&ec.part[t], 0, sizeof ec.part[t]);
        ec.part[t].b = s->ndirty * t / nk, ec.part[t].e = s->ndirty * (t + 1) / nk;
    }
    ec.u = u;
    encode_run(&ec, nk, 1);
    {
        size_t fresh = 0, coast = 0, srch = 0, calm = 0;
        int outside = 0;
        for (t = 0; t < nk; t++) {
            fresh += ec.part[t].fresh, outside |= ec.part[t].outside;
            coast += ec.part[t].ncoast, srch += ec.part[t].nsrch, calm += ec.part[t].calm;
        }
        if (outside || s->ndense + fresh > s->hot_cap)
            return LC_RELIST; /* nothing written but scratch */
        if (s->have_adj && srch > coast && srch >= LC_ADJ_MIN_LEFT) {
            lc_adj_drop(s); /* a cache: dropping it changes no result */
            s->calm_updates = 0;
            s->band_wait = doubled_wait(band_wait(s));
            if ((double)u->moved > LC_REBUILD_FRACTION * (double)s->live)
                return LC_REBUILD;
            for (t = 0; t < nk; t++) { /* pass 1 again, every object searching */
                const size_t b = ec.part[t].b, e = ec.part[t].e;
                memset(&ec.part[t], 0, sizeof ec.part[t]);
                ec.part[t].b = b, ec.part[t].e = e;
            }
            encode_run(&ec, nk, 1);
        } else if (!s->have_adj) {
            s->calm_updates = calm * 10 >= (coast + srch) * 9 ? s->calm_updates + 1 : 0;
            u->adj_after = s->calm_updates >= LC_CALM_UPDATES;
        } else if (coast * 10 >= (coast + srch) * 9) {
            s->band_wait = 0;
        }
    }
    for (k = 0; k < s->nremoved; k++)
        if (s->flags[r[k]] & LC_SLOT_INTREE)
            ndel[(s->flags[r[k]] & LC_SLOT_STATIC) ? 1 : 0] += lc_cells_count(&s->cell[r[k]]);
    nrem[0] = ndel[0], nrem[1] = ndel[1];
    for (t = 0; t < nk; t++) {
        ndel[0] += ec.part[t].ndel[0], ndel[1] += ec.part[t].ndel[1];
        nadd[0] += ec.part[t].nadd[0], nadd[1] += ec.part[t].nadd[1];
        nq += ec.part[t].nq;
    }
    off_del[0] = 0, off_del[1] = ndel[0];
    off_add[0] = ndel[0] + ndel[1], off_add[1] = off_add[0] + nadd[0];
    off_q = off_add[1] + nadd[1];
    if ((st = buf_room(u, 0, off_q + nq + 1)) != LOCD_OK)
        return st;

    /* Pass 2: write them, and the new cells (undo kept): the removed
       objects' deletions first, then each part's rows where the serial
       loop would put them. */
    {
        size_t w[2] = {0, 0};
        for (k = 0; k < s->nremoved; k++)
            if (s->flags[r[k]] & LC_SLOT_INTREE) {
                int l = (s->flags[r[k]] & LC_SLOT_STATIC) ? 1 : 0;
                w[l] += lc_cells_entries(g, &s->cell[r[k]], s->dense[r[k]], u->buf + off_del[l] + w[l]);
                s->hot[s->dense[r[k]]].flags |= LC_HOT_GONE; /* undo() clears it */
            }
    }
    {
        size_t at_del[2] = {off_del[0] + nrem[0], off_del[1] + nrem[1]}, at_add[2] = {off_add[0], off_add[1]};
        size_t at_q = off_q, at_undo = 0, at_dense = s->ndense, at_coast = 0, at_srch = 0;
        for (t = 0; t < nk; t++) {
            enc_part *pt = &ec.part[t];
            const size_t c_del[2] = {pt->ndel[0], pt->ndel[1]}, c_add[2] = {pt->nadd[0], pt->nadd[1]};
            const size_t c_q = pt->nq, c_live = pt->live, c_fresh = pt->fresh, c_coast = pt->ncoast,
                         c_srch = pt->nsrch;
            int l;
            for (l = 0; l < 2; l++) {
                pt->ndel[l] = at_del[l], at_del[l] += c_del[l];
                pt->nadd[l] = at_add[l], at_add[l] += c_add[l];
            }
            pt->nq = at_q, at_q += c_q;
            pt->live = at_undo, at_undo += c_live;
            pt->fresh = at_dense, at_dense += c_fresh;
            pt->ncoast = at_coast, at_coast += c_coast;
            pt->nsrch = at_srch, at_srch += c_srch;
        }
        encode_run(&ec, nk, 2);
        u->nundo = at_undo;
        u->ncoast = at_coast, u->nsrch = at_srch;
        s->ndense = at_dense;
        for (t = 0; t < nk; t++)
            u->reencoded += ec.part[t].reenc;
    }
    for (k = 0; k < 2; k++)
        if ((st = lc_sort_u64_radix(a, u->buf + off_del[k], ndel[k])) != LOCD_OK ||
            (st = lc_sort_u64_radix(a, u->buf + off_add[k], nadd[k])) != LOCD_OK)
            return st;
    if ((st = lc_sort_u64_radix(a, u->buf + off_q, nq)) != LOCD_OK)
        return st;
    t1 = lc_now_ms();
    u->ms_encode = t1 - t0;
    t0 = t1;
    if ((st = lc_tree_edit_apply(a, g, &s->dyn, u->buf + off_del[0], ndel[0], u->buf + off_add[0], nadd[0],
                                 &u->edit[0])) != LOCD_OK ||
        (st = lc_tree_edit_apply(a, g, &s->sta, u->buf + off_del[1], ndel[1], u->buf + off_add[1], nadd[1],
                                 &u->edit[1])) != LOCD_OK)
        return st;
    /* The search sees the lists as they will be: a view of each. */
    view_tree(&s->dyn, &u->edit[0], &u->dyn);
    view_tree(&s->sta, &u->edit[1], &u->sta);
    u->ms_merge = lc_now_ms() - t0;
    u->events = s->have_adj;
    st = (u->events ? moved_events : moved_pairs)(u, &u->dyn, &u->sta, u->buf + off_q, nq);
    memset(&u->dyn, 0, sizeof u->dyn); /* views: not ours to free */
    memset(&u->sta, 0, sizeof u->sta);
    return st;
}

/* The lists built again from the current boxes (build_lists) with the
 * partner lists (lc_adj_build); then every moved object, inside the fat
 * box just made from its box, takes its pairs from its partner list. When
 * the partner lists could not be made, the moved objects search the entry
 * lists as in the incremental path. */
static locd_status relist(upd *u)
{
    locd_scene *s = u->s;
    const locd_grid *g;
    const uint32_t *d = s->dirty.data;
    size_t k, nq = 0;
    locd_status st;
    double t0 = lc_now_ms();
    lc_kept_release(s); /* the updates go on incrementally: its memory back, before the lists take theirs */
    lc_near_release(s);
    if ((st = build_lists(u)) != LOCD_OK)
        return st;
    g = &s->grid;
    lc_adj_build(s); /* on failure the scene goes on without partner lists */
    if ((st = buf_room(u, 0, 8 * s->ndirty + 1)) != LOCD_OK)
        return st;
    if (!u->coast) { /* (allocated already when the incremental path turned to this one) */
        u->undo_cap = s->ndirty ? s->ndirty : 1;
        if (!(u->coast = lc_alloc(s->alloc, u->undo_cap * sizeof *u->coast)))
            return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the update's moved list");
    }
    for (k = 0; k < s->ndirty; k++) {
        uint32_t slot = d[k], di;
        if (!(s->flags[slot] & LC_SLOT_LIVE))
            continue;
        di = s->dense[slot];
        if (s->have_adj) {
            u->coast[u->ncoast++] = di;
            s->hot[di].flags |= LC_SLOT_DIRTY;
        } else {
            nq += lc_cells_entries(g, &s->cell[slot], di, u->buf + nq);
            s->hot[di].flags |= LC_SLOT_DIRTY | LC_HOT_SEARCH;
        }
    }
    u->reencoded = s->live;
    st = lc_sort_u64_radix(s->alloc, u->buf, nq);
    u->ms_encode = lc_now_ms() - t0;
    if (st == LOCD_OK)
        st = moved_pairs(u, &s->dyn, &s->sta, u->buf, nq);
    for (k = 0; k < s->ndirty; k++)
        if (s->flags[d[k]] & LC_SLOT_LIVE)
            s->hot[s->dense[d[k]]].flags &= ~(uint32_t)(LC_SLOT_DIRTY | LC_HOT_SEARCH);
    return st;
}

/* A slot is on the dirty list iff its DIRTY flag is set (REFILTER is set
 * only with it). A list of an eighth of the slots or more is walked as the
 * flags of every slot, in order: a pass over one byte a slot, in vector
 * steps, instead of a read at each listed slot, for the count and for the
 * clearing below (docs/scene.md, step 5, has the measurement). */
LC_INLINE int dirty_dense(const locd_scene *s)
{
    return s->ndirty >= s->nslots / 8;
}

/* The live objects of the dirty list. */
static size_t live_dirty(const locd_scene *s)
{
    const uint32_t *d = s->dirty.data;
    const uint8_t both = LC_SLOT_LIVE | LC_SLOT_DIRTY, *f = s->flags;
    const size_t n = s->nslots;
    size_t k, moved = 0;
    if (!dirty_dense(s)) {
        for (k = 0; k < s->ndirty; k++)
            moved += (s->flags[d[k]] & LC_SLOT_LIVE) != 0;
        return moved;
    }
    for (k = 0; k < n;) { /* blocks whose count fits 32 bits: the inner loop vectorizes */
        const size_t e = n - k > 65536 ? k + 65536 : n;
        uint32_t c = 0;
        for (; k < e; k++)
            c += (f[k] & both) == both;
        moved += c;
    }
    return moved;
}

/* Forgets the changes the update has taken in. */
static void clear_changes(locd_scene *s)
{
    size_t k;
    const uint32_t *d = s->dirty.data;
    const uint8_t keep = (uint8_t) ~(LC_SLOT_DIRTY | LC_SLOT_REFILTER);
    if (dirty_dense(s)) {
        uint8_t *f = s->flags; /* in locals: a byte store may alias s's fields, read again at each step */
        const size_t n = s->nslots;
        for (k = 0; k < n; k++)
            f[k] &= keep;
    } else {
        for (k = 0; k < s->ndirty; k++) {
            if (k + 2 * LC_AHEAD < s->ndirty) /* scattered: evicted by the pass over the set */
                __builtin_prefetch(s->flags + d[k + 2 * LC_AHEAD], 1);
            s->flags[d[k]] &= keep;
        }
    }
    s->ndirty = 0;
    lc_scene_free_removed(s);
}

/* The partner lists after an incremental update: the removed objects and
 * those that searched leave their old partners' lists, then the searched
 * ones are linked to the fat partners they found (adj.c). */
static void relink(upd *u)
{
    locd_scene *s = u->s;
    const uint32_t *r = s->removed.data, *fp = u->found.fat.data, *ev = u->found.ev.data;
    size_t k;
    if (!s->have_adj || !u->events)
        return;
    /* the partner-list pass's changes first: their places k hold until a
       list is unlinked below */
    for (k = 0; k < u->found.nev; k++)
        lc_adj_set_paired(s, ev[3 * k], ev[3 * k + 1], ev[3 * k + 2] & LC_ADJ_INDEX,
                          (ev[3 * k + 2] & LC_ADJ_PAIRED) != 0);
    for (k = 0; k < s->nremoved; k++)
        if (s->flags[r[k]] & LC_SLOT_INTREE)
            lc_adj_unlink(s, s->dense[r[k]]);
    for (k = 0; k < u->nsrch; k++)
        lc_adj_unlink(s, u->srch[k]);
    for (k = 0; k < u->found.nfat && s->have_adj; k++)
        lc_adj_link(s, fp[2 * k], fp[2 * k + 1] & LC_ADJ_INDEX, (fp[2 * k + 1] & LC_ADJ_PAIRED) != 0);
}

static void commit(upd *u)
{
    locd_scene *s = u->s;
    size_t k;
    if (u->rebuilt || u->near) {
        /* the lists are built again by the next update that needs them */
        lc_scene_tree_fini(s);
        lc_adj_drop(s);
        memset(&s->dyn, 0, sizeof s->dyn);
        memset(&s->sta, 0, sizeof s->sta);
        if (s->have_tree) /* else no slot has the flag: the lists were dropped before */
            for (k = 0; k < s->nslots; k++)
                s->flags[k] &= (uint8_t)~LC_SLOT_INTREE;
        s->have_tree = 0;
    } else if (u->relisted) {
        u->nundo = 0;
    } else {
        lc_tree_edit_commit(s->alloc, &s->dyn, &u->edit[0]);
        lc_tree_edit_commit(s->alloc, &s->sta, &u->edit[1]);
        u->nundo = 0;
        relink(u);
        if (u->adj_after && !s->have_adj) {
            lc_adj_build(s); /* from the boxes now, as the set is; on failure the scene goes on without */
            s->calm_updates = 0;
        }
    }
    s->have_pairs = 1;
    if (!u->in_place) /* else s->pairs is the new set already */
        swap_plist(&s->pairs, &u->next);
    s->spare = u->next; /* the previous set's buffer (or the spare, unused): the next update writes into it */
    memset(&u->next, 0, sizeof u->next);
    swap_plist(&s->created, &u->cr);
    swap_plist(&s->lost, &u->lo);
    keep_event_buffers(u);
    clear_changes(s);
}

locd_status locd_scene_update(locd_scene *s, uint32_t flags)
{
    upd u;
    locd_scene_stats *st_out;
    size_t moved;
    double t0 = lc_now_ms();
    locd_status st;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK)
        return st;
    if (flags & ~(LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "unknown update flags 0x%x",
                        flags & ~(LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
    if (!lc_engine_acquire(s->engine))
        return lc_error(LOCD_ERR_BUSY, "the scene's engine is running another call");
    memset(&u, 0, sizeof u);
    u.s = s;
    u.flags = flags;
    u.next = s->spare; /* written from its start (count and first set by the writer) */
    u.next.count = u.next.first = 0;
    memset(&s->spare, 0, sizeof s->spare);
    take_event_buffers(&u);
    u.moved = moved = live_dirty(s); /* every path's count: the live objects of the dirty list */
    if (!lc_near_usable(s) || !near_moved(s, moved))
        s->near.valid = 0; /* only a run of updates in which most objects moved keeps it */
    if (s->near.valid) {
        st = near_update(&u);
    } else if (in_band(s, moved) && s->band_updates + 1 >= band_wait(s)) {
        s->band_updates = 0; /* the lists, at last: the moved objects take them at once */
        u.relisted = 1, st = relist(&u);
    } else if (want_rebuild(s, moved) || (s->have_tree && (st = incremental(&u)) == LC_REBUILD)) {
        s->band_updates = in_band(s, moved) ? s->band_updates + 1 : 0;
        st = rebuild(&u);
    } else if (!s->have_tree || st == LC_RELIST) {
        u.relisted = 1, st = relist(&u);
    }
    if (st != LOCD_OK) {
        s->near.valid = 0; /* its PAIRED bits may be this update's */
        undo(&u);
        keep_event_buffers(&u);
        upd_free(&u);
        lc_engine_release(s->engine);
        return st;
    }
    commit(&u);
    upd_free(&u);
    s->show_pairs = (flags & LOCD_SCENE_UPDATE_PAIRS) != 0;
    s->show_events = (flags & LOCD_SCENE_UPDATE_EVENTS) != 0;
    st_out = &s->stats;
    locd_scene_stats_init(st_out);
    st_out->threads = s->threads;
    st_out->objects = s->live;
    st_out->static_objects = s->live_static;
    st_out->moved = u.moved;
    st_out->reencoded = u.reencoded;
    st_out->entries = s->dyn.count + s->sta.count;
    st_out->candidates = u.candidates + u.found.candidates;
    st_out->pairs = s->pairs.count;
    st_out->created = s->created.count;
    st_out->lost = s->lost.count;
    st_out->rebuilt = (uint32_t)u.rebuilt;
    st_out->coasted = (uint32_t)(u.near ? u.moved : u.ncoast);
    st_out->ms_encode = u.ms_encode;
    st_out->ms_merge = u.ms_merge;
    st_out->ms_sweep = u.ms_sweep;
    st_out->ms_events = u.ms_events;
    st_out->ms_total = lc_now_ms() - t0;
    lc_engine_release(s->engine);
    lc_clear_error();
    return LOCD_OK;
}

/* One of the lists of the last update; empty when not asked for. */
static locd_status give_list(const locd_scene *s, const lc_plist *p, int shown, const locd_id **pairs,
                             size_t *count)
{
    locd_status st;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK)
        return st;
    if (!pairs || !count)
        return lc_error(LOCD_ERR_NULL_POINTER, "pairs or count is NULL");
    *pairs = shown ? lc_plist_rows(p) : NULL;
    *count = shown ? p->count : 0;
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_scene_pairs(const locd_scene *s, const locd_id **pairs, size_t *count)
{
    return give_list(s, s ? &s->pairs : NULL, s && s->show_pairs, pairs, count);
}

locd_status locd_scene_created(const locd_scene *s, const locd_id **pairs, size_t *count)
{
    return give_list(s, s ? &s->created : NULL, s && s->show_events, pairs, count);
}

locd_status locd_scene_lost(const locd_scene *s, const locd_id **pairs, size_t *count)
{
    return give_list(s, s ? &s->lost : NULL, s && s->show_events, pairs, count);
}
