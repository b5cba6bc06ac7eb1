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

/* Rebuild when more than this fraction of the objects moved. */
#define LC_REBUILD_FRACTION 0.25

typedef struct upd {
    locd_scene *s;
    uint32_t flags;
    lc_tree dyn, sta;   /* the new lists */
    lc_plist next, cr, lo;
    lc_cells *cells;    /* rebuild: new per-slot cells (slot_cap) */
    uint64_t *qbox;     /* rebuild: new per-slot sweep corners (2 * slot_cap) */
    locd_grid grid;     /* rebuild: the new grid */
    /* incremental: undo of the per-slot cells written early */
    uint32_t *undo_slot;
    lc_cells *undo_cells;
    uint64_t *undo_q;
    uint8_t *undo_flags;
    size_t nundo, undo_cap;
    uint64_t *buf; /* del/add/query entries */
    size_t buf_cap;
    uint64_t candidates, moved, reencoded;
    int rebuilt;
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

static void upd_free(upd *u)
{
    const locd_allocator *a = u->s->alloc;
    lc_buf_release(a, &u->dyn.ent, sizeof(uint64_t));
    lc_buf_release(a, &u->sta.ent, sizeof(uint64_t));
    lc_plist_fini(a, &u->next);
    lc_plist_fini(a, &u->cr);
    lc_plist_fini(a, &u->lo);
    lc_free(a, u->cells, u->s->slot_cap * sizeof *u->cells);
    lc_free(a, u->qbox, u->s->slot_cap * 2 * sizeof *u->qbox);
    lc_free(a, u->undo_slot, u->undo_cap * sizeof *u->undo_slot);
    lc_free(a, u->undo_cells, u->undo_cap * sizeof *u->undo_cells);
    lc_free(a, u->undo_q, u->undo_cap * 2 * sizeof *u->undo_q);
    lc_free(a, u->undo_flags, u->undo_cap * sizeof *u->undo_flags);
    lc_free(a, u->buf, u->buf_cap * sizeof *u->buf);
}

/* Puts back the cells written early by a failed incremental update. */
static void undo(upd *u)
{
    locd_scene *s = u->s;
    size_t k;
    for (k = u->nundo; k-- > 0;) {
        uint32_t slot = u->undo_slot[k];
        s->cell[slot] = u->undo_cells[k];
        s->qbox[2 * (size_t)slot] = u->undo_q[2 * k];
        s->qbox[2 * (size_t)slot + 1] = u->undo_q[2 * k + 1];
        s->flags[slot] = u->undo_flags[k];
    }
    u->nundo = 0;
}

/* 1 when this update should start from scratch. */
static int want_rebuild(const locd_scene *s, size_t moved)
{
    size_t k;
    const uint32_t *d = s->dirty.data;
    if (!s->have_tree)
        return 1;
    if (s->nslots > ((size_t)1 << s->grid.index_bits))
        return 1;
    if ((double)moved > LC_REBUILD_FRACTION * (double)s->live && moved > 64)
        return 1;
    for (k = 0; k < s->ndirty; k++)
        if ((s->flags[d[k]] & LC_SLOT_LIVE) && !lc_grid_holds(&s->grid, s->box + 6 * (size_t)d[k]))
            return 1;
    return 0;
}

static locd_status events_full(upd *u)
{
    locd_scene *s = u->s;
    locd_status st;
    if ((st = lc_plist_reserve(s->alloc, &u->cr, u->next.count + 1)) != LOCD_OK ||
        (st = lc_plist_reserve(s->alloc, &u->lo, s->pairs.count + 1)) != LOCD_OK)
        return st;
    u->cr.count = lc_plist_minus(u->next.rows.data, u->next.count, s->pairs.rows.data, s->pairs.count, u->cr.rows.data);
    u->lo.count = lc_plist_minus(s->pairs.rows.data, s->pairs.count, u->next.rows.data, u->next.count, u->lo.rows.data);
    return LOCD_OK;
}

static locd_status rebuild(upd *u)
{
    locd_scene *s = u->s;
    const locd_allocator *a = s->alloc;
    locd_status st;
    double t0 = lc_now_ms(), t1;
    u->rebuilt = 1;
    u->cells = lc_alloc(a, s->slot_cap * sizeof *u->cells);
    u->qbox = lc_alloc(a, s->slot_cap * 2 * sizeof *u->qbox);
    if (!u->cells || !u->qbox)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's cells");
    memset(u->cells, 0, s->slot_cap * sizeof *u->cells);
    memset(u->qbox, 0, s->slot_cap * 2 * sizeof *u->qbox);
    if ((st = lc_scene_fit_grid(s, &u->grid)) != LOCD_OK ||
        (st = lc_scene_build_trees(s, &u->grid, u->cells, u->qbox, &u->dyn, &u->sta)) != LOCD_OK)
        return st;
    t1 = lc_now_ms();
    u->ms_encode = t1 - t0;
    u->reencoded = s->live;
    if ((st = lc_scene_pairs_from_scratch(s, &u->next, &u->candidates)) != LOCD_OK)
        return st;
    u->ms_sweep = lc_now_ms() - t1;
    t1 = lc_now_ms();
    if ((u->flags & LOCD_SCENE_UPDATE_EVENTS) && (st = events_full(u)) != LOCD_OK)
        return st;
    u->ms_events = lc_now_ms() - t1;
    return LOCD_OK;
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

/* The rows of the previous set that neither end changed (kept), the others
 * (dropped, into *dropped), merged with the new rows n. */
static locd_status carry(upd *u, const lc_plist *n, lc_plist *dropped)
{
    locd_scene *s = u->s;
    const locd_id *p = s->pairs.rows.data;
    locd_id *out, *dr;
    size_t i, j = 0, w = 0, nd = 0;
    locd_status st;
    if ((st = lc_plist_reserve(s->alloc, &u->next, s->pairs.count + n->count + 1)) != LOCD_OK ||
        (st = lc_plist_reserve(s->alloc, dropped, s->pairs.count + 1)) != LOCD_OK)
        return st;
    out = u->next.rows.data;
    dr = dropped->rows.data;
    for (i = 0; i < s->pairs.count; i++) {
        const locd_id *r = p + 2 * i;
        if ((s->flags[LC_ID_SLOT(r[0])] | s->flags[LC_ID_SLOT(r[1])]) & (LC_SLOT_DIRTY | LC_SLOT_REMOVED)) {
            dr[2 * nd] = r[0], dr[2 * nd + 1] = r[1], nd++;
            continue;
        }
        {
            uint64_t k = lc_pair_key(r);
            const locd_id *nr = n->rows.data;
            while (j < n->count && lc_pair_key(nr + 2 * j) < k) {
                out[2 * w] = nr[2 * j], out[2 * w + 1] = nr[2 * j + 1], w++, j++;
            }
        }
        out[2 * w] = r[0], out[2 * w + 1] = r[1], w++;
    }
    for (; j < n->count; j++) {
        const locd_id *nr = n->rows.data;
        out[2 * w] = nr[2 * j], out[2 * w + 1] = nr[2 * j + 1], w++;
    }
    u->next.count = w;
    dropped->count = nd;
    return LOCD_OK;
}

static locd_status incremental(upd *u)
{
    locd_scene *s = u->s;
    const locd_allocator *a = s->alloc;
    const locd_grid *g = &s->grid;
    const uint32_t *d = s->dirty.data, *r = s->removed.data;
    size_t k, ndel[2] = {0, 0}, nadd[2] = {0, 0}, nq = 0, off_del[2], off_add[2], off_q;
    lc_plist n = {{NULL, 0}, 0}, dropped = {{NULL, 0}, 0};
    locd_status st;
    double t0 = lc_now_ms(), t1;
    uint64_t tmp[8];
    /* undo room: one per dirty slot */
    u->undo_cap = s->ndirty ? s->ndirty : 1;
    u->undo_slot = lc_alloc(a, u->undo_cap * sizeof *u->undo_slot);
    u->undo_cells = lc_alloc(a, u->undo_cap * sizeof *u->undo_cells);
    u->undo_q = lc_alloc(a, u->undo_cap * 2 * sizeof *u->undo_q);
    u->undo_flags = lc_alloc(a, u->undo_cap * sizeof *u->undo_flags);
    if (!u->undo_slot || !u->undo_cells || !u->undo_q || !u->undo_flags)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the update's undo list");
    /* Pass 1: count the deltas (deleted and added per list, queries). */
    for (k = 0; k < s->nremoved; k++)
        if (s->flags[r[k]] & LC_SLOT_INTREE)
            ndel[(s->flags[r[k]] & LC_SLOT_STATIC) ? 1 : 0] += lc_cells_entries(g, &s->cell[r[k]], r[k], tmp);
    for (k = 0; k < s->ndirty; k++) {
        uint32_t slot = d[k], cnt;
        uint8_t f = s->flags[slot];
        int t = (f & LC_SLOT_STATIC) ? 1 : 0;
        lc_cells c;
        uint32_t q[3];
        if (!(f & LC_SLOT_LIVE))
            continue;
        u->moved++;
        lc_cells_of(g, s->box + 6 * (size_t)slot, &c, q);
        cnt = lc_cells_entries(g, &c, slot, tmp);
        nq += cnt;
        if ((f & LC_SLOT_INTREE) && lc_cells_same(&c, &s->cell[slot]))
            continue;
        if (f & LC_SLOT_INTREE)
            ndel[t] += lc_cells_entries(g, &s->cell[slot], slot, tmp);
        nadd[t] += cnt;
    }
    off_del[0] = 0, off_del[1] = ndel[0];
    off_add[0] = ndel[0] + ndel[1], off_add[1] = off_add[0] + nadd[0];
    off_q = off_add[1] + nadd[1];
    if ((st = buf_room(u, 0, off_q + nq + 1)) != LOCD_OK)
        return st;

    ndel[0] = ndel[1] = nadd[0] = nadd[1] = 0;
    nq = 0;
    /* Pass 2: write them, and the new cells (undo kept). */
    for (k = 0; k < s->nremoved; k++)
        if (s->flags[r[k]] & LC_SLOT_INTREE) {
            int t = (s->flags[r[k]] & LC_SLOT_STATIC) ? 1 : 0;
            ndel[t] += lc_cells_entries(g, &s->cell[r[k]], r[k], u->buf + off_del[t] + ndel[t]);
        }
    for (k = 0; k < s->ndirty; k++) {
        uint32_t slot = d[k], cnt;
        uint8_t f = s->flags[slot];
        int t = (f & LC_SLOT_STATIC) ? 1 : 0;
        lc_cells c;
        uint32_t q[3];
        if (!(f & LC_SLOT_LIVE))
            continue;
        lc_cells_of(g, s->box + 6 * (size_t)slot, &c, q);
        u->undo_slot[u->nundo] = slot;
        u->undo_cells[u->nundo] = s->cell[slot];
        u->undo_q[2 * u->nundo] = s->qbox[2 * (size_t)slot];
        u->undo_q[2 * u->nundo + 1] = s->qbox[2 * (size_t)slot + 1];
        u->undo_flags[u->nundo] = f;
        u->nundo++;
        cnt = lc_cells_entries(g, &c, slot, u->buf + off_q + nq);
        if (!((f & LC_SLOT_INTREE) && lc_cells_same(&c, &s->cell[slot]))) {
            if (f & LC_SLOT_INTREE)
                ndel[t] += lc_cells_entries(g, &s->cell[slot], slot, u->buf + off_del[t] + ndel[t]);
            memcpy(u->buf + off_add[t] + nadd[t], u->buf + off_q + nq, cnt * sizeof(uint64_t));
            nadd[t] += cnt;
            u->reencoded++;
        }
        nq += cnt;
        s->cell[slot] = c;
        memcpy(s->qbox + 2 * (size_t)slot, q, sizeof q);
        s->flags[slot] |= LC_SLOT_INTREE;
    }
    for (k = 0; k < 2; k++) {
        lc_sort_u64(u->buf + off_del[k], ndel[k]);
        lc_sort_u64(u->buf + off_add[k], nadd[k]);
    }
    lc_sort_u64(u->buf + off_q, nq);
    t1 = lc_now_ms();
    u->ms_encode = t1 - t0;
    t0 = t1;
    if ((st = lc_tree_repair(a, g, &s->dyn, u->buf + off_del[0], ndel[0], u->buf + off_add[0], nadd[0], &u->dyn)) !=
            LOCD_OK ||
        (st = lc_tree_repair(a, g, &s->sta, u->buf + off_del[1], ndel[1], u->buf + off_add[1], nadd[1], &u->sta)) !=
            LOCD_OK)
        return st;
    t1 = lc_now_ms();
    u->ms_merge = t1 - t0;
    t0 = t1;
    st = lc_scene_find_moved(s, &u->dyn, &u->sta, u->buf + off_q, nq, &n, &u->candidates);
    t1 = lc_now_ms();
    u->ms_sweep = t1 - t0;
    t0 = t1;
    if (st == LOCD_OK)
        st = carry(u, &n, &dropped);
    if (st == LOCD_OK && (u->flags & LOCD_SCENE_UPDATE_EVENTS)) {
        /* previous = kept + dropped, now = kept + n, kept disjoint from both */
        if ((st = lc_plist_reserve(a, &u->cr, n.count + 1)) == LOCD_OK &&
            (st = lc_plist_reserve(a, &u->lo, dropped.count + 1)) == LOCD_OK) {
            u->cr.count = lc_plist_minus(n.rows.data, n.count, dropped.rows.data, dropped.count, u->cr.rows.data);
            u->lo.count = lc_plist_minus(dropped.rows.data, dropped.count, n.rows.data, n.count, u->lo.rows.data);
        }
    }
    u->ms_events = lc_now_ms() - t0;
    lc_plist_fini(a, &n);
    lc_plist_fini(a, &dropped);
    return st;
}

/* Forgets the changes the update has taken in. */
static void clear_changes(locd_scene *s)
{
    size_t k;
    const uint32_t *d = s->dirty.data;
    for (k = 0; k < s->ndirty; k++)
        s->flags[d[k]] &= (uint8_t)~LC_SLOT_DIRTY;
    s->ndirty = 0;
    lc_scene_free_removed(s);
}

static void commit(upd *u)
{
    locd_scene *s = u->s;
    if (u->rebuilt) {
        lc_cells *c = s->cell;
        uint64_t *q = s->qbox;
        size_t k;
        s->cell = u->cells, u->cells = c;
        s->qbox = u->qbox, u->qbox = q;
        s->grid = u->grid;
        s->have_tree = 1;
        for (k = 0; k < s->nslots; k++)
            if (s->flags[k] & LC_SLOT_LIVE)
                s->flags[k] |= LC_SLOT_INTREE;
        u->moved = 0;
        for (k = 0; k < s->ndirty; k++)
            u->moved += (s->flags[((const uint32_t *)s->dirty.data)[k]] & LC_SLOT_LIVE) != 0;
    }
    swap_tree(&s->dyn, &u->dyn);
    swap_tree(&s->sta, &u->sta);
    swap_plist(&s->pairs, &u->next);
    swap_plist(&s->created, &u->cr);
    swap_plist(&s->lost, &u->lo);
    clear_changes(s);
}

locd_status locd_scene_update(locd_scene *s, uint32_t flags)
{
    upd u;
    locd_scene_stats *st_out;
    size_t moved = 0, k;
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
    for (k = 0; k < s->ndirty; k++)
        moved += (s->flags[((const uint32_t *)s->dirty.data)[k]] & LC_SLOT_LIVE) != 0;
    st = want_rebuild(s, moved) ? rebuild(&u) : incremental(&u);
    if (st != LOCD_OK) {
        undo(&u);
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
    st_out->candidates = u.candidates;
    st_out->pairs = s->pairs.count;
    st_out->created = s->created.count;
    st_out->lost = s->lost.count;
    st_out->rebuilt = (uint32_t)u.rebuilt;
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
    *pairs = shown ? p->rows.data : NULL;
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
