/* The pairs of the moved objects, from the repaired entry lists. For each
 * entry (cell c, object m) of a moved object, the objects on a common
 * root-to-leaf path with c are the entries of c's subtree (one range of the
 * sorted list: same cell and descendants) and of c's ancestors (one exact
 * key per level that holds any entry). Each candidate is tested in this
 * order: both moved and not m < o (the other one reports it), the filter
 * (static-static, category/mask, group: filtered pairs are never tested
 * further), the quantized boxes (conservative: they overlap whenever the
 * boxes do), the canonical cell pair, the exact box test. Everything but
 * the exact test reads o's record (lc_hot), and the records of one cell's
 * objects are neighbours (dense indices, scene.h).
 *
 * The canonical cell pair makes each pair come out once however many cells
 * the two objects share paths in: the point p = max(lo_m, lo_o) (sweep
 * coordinates) lies in both quantized boxes when the boxes overlap, so in
 * exactly one cell of each, and those two cells lie on one path; the pair
 * is reported at that cell pair only (docs/scene.md). */
#include "scene/scene.h"

typedef struct find_ctx {
    const locd_scene *s;
    const lc_tree *dyn, *sta;
    const uint64_t *q; /* sorted entries of the moved objects */
    size_t nq;
    lc_buf rows[LC_MAX_THREADS]; /* locd_id, two a row */
    size_t count[LC_MAX_THREADS];
    uint64_t cand[LC_MAX_THREADS];
    locd_status st[LC_MAX_THREADS];
} find_ctx;

/* The point p lies in the cell (pm, level). */
static int cell_holds(const locd_grid *g, uint64_t pm, uint32_t level, const uint32_t *p)
{
    uint64_t m = pm >> (3u * (g->depth - level));
    uint32_t sh = LC_SBITS - level;
    return lc_morton_compact3(m) == (p[0] >> sh) && lc_morton_compact3(m >> 1) == (p[1] >> sh) &&
           lc_morton_compact3(m >> 2) == (p[2] >> sh);
}

#define FIELD(w, a) ((uint32_t)(((w) >> ((a)*LC_SBITS)) & LC_SMASK))

/* Tests the candidate entry eo against the query entry eq (object m, hot
 * record hm). Only o's hot record is read until the exact test. */
static void consider(find_ctx *c, uint32_t t, uint64_t eq, const lc_hot *hm, uint64_t eo)
{
    const locd_scene *s = c->s;
    const locd_grid *g = &s->grid;
    const uint32_t ib = g->index_bits;
    const uint64_t imask = ((uint64_t)1 << ib) - 1;
    uint32_t m = (uint32_t)(eq & imask), o = (uint32_t)(eo & imask);
    uint32_t lm = (uint32_t)(eq >> ib) & 31u, lo = (uint32_t)(eo >> ib) & 31u, p[3], a;
    const lc_hot *ho;
    locd_id *row;
    if (o == m || o == (uint32_t)imask) /* itself, or a tombstone */
        return;
    ho = &s->hot[o];
    c->cand[t]++;
    /* both moved: the one with the smaller id reports the pair */
    if ((ho->flags & LC_SLOT_DIRTY) && s->id[ho->slot] < s->id[hm->slot])
        return;
    /* the filter, before any box test */
    if ((hm->flags & ho->flags & LC_SLOT_STATIC) || !(hm->cat & ho->mask) || !(ho->cat & hm->mask) ||
        (hm->group == ho->group && hm->group != 0))
        return;
    /* the quantized boxes (conservative: they overlap whenever the boxes do),
       then the canonical cell pair */
    for (a = 0; a < 3; a++) {
        uint32_t ml = FIELD(hm->qlo, a), ol = FIELD(ho->qlo, a);
        if (ml > FIELD(ho->qhi, a) || ol > FIELD(hm->qhi, a))
            return;
        p[a] = ml > ol ? ml : ol;
    }
    if (lm >= lo ? !cell_holds(g, eq >> (ib + LC_LEVEL_BITS), lm, p)
                 : !cell_holds(g, eo >> (ib + LC_LEVEL_BITS), lo, p))
        return;
    if (!lc_box_overlap(s->box + 6 * (size_t)hm->slot, s->box + 6 * (size_t)ho->slot))
        return;
    if (c->st[t] == LOCD_OK &&
        lc_buf_reserve(s->alloc, &c->rows[t], 2 * sizeof(locd_id), c->count[t] + 1) != LOCD_OK) {
        c->st[t] = LOCD_ERR_NO_MEMORY;
        return;
    }
    if (c->st[t] != LOCD_OK)
        return;
    row = (locd_id *)c->rows[t].data + 2 * c->count[t]++;
    {
        locd_id im = s->id[hm->slot], io = s->id[ho->slot];
        row[0] = im < io ? im : io;
        row[1] = im < io ? io : im;
    }
}

/* Every entry of e[0, n) on a common path with the cell of entry eq. */
static void search_array(find_ctx *c, uint32_t t, const size_t *per_level, const uint64_t *e, size_t n, uint64_t eq,
                         const lc_hot *hm)
{
    const locd_grid *g = &c->s->grid;
    const uint32_t ib = g->index_bits;
    const uint64_t key = eq >> ib, pm = key >> LC_LEVEL_BITS;
    const uint32_t level = (uint32_t)key & 31u;
    size_t i;
    uint32_t l;
    if (!n)
        return;
    /* the cell itself and its descendants: keys in [key, (pm + span) << 5) */
    {
        const uint64_t end = (pm + ((uint64_t)1 << (3u * (g->depth - level)))) << LC_LEVEL_BITS;
        for (i = lc_lower_bound(e, n, key << ib); i < n && (e[i] >> ib) < end; i++)
            consider(c, t, eq, hm, e[i]);
    }
    /* its ancestors, at the levels that hold entries */
    for (l = 0; l < level; l++) {
        uint64_t ka;
        if (!per_level[l])
            continue;
        ka = ((pm & ~(((uint64_t)1 << (3u * (g->depth - l))) - 1)) << LC_LEVEL_BITS) | l;
        for (i = lc_lower_bound(e, n, ka << ib); i < n && (e[i] >> ib) == ka; i++)
            consider(c, t, eq, hm, e[i]);
    }
}

static void search(find_ctx *c, uint32_t t, const lc_tree *tr, uint64_t eq, const lc_hot *hm)
{
    search_array(c, t, tr->per_level, tr->ent.data, tr->count, eq, hm);
    search_array(c, t, tr->per_level, tr->ovf.data, tr->novf, eq, hm);
}

static void task_find(void *arg, uint32_t t, uint32_t k)
{
    find_ctx *c = arg;
    const uint64_t imask = ((uint64_t)1 << c->s->grid.index_bits) - 1;
    size_t b = c->nq * t / k, e = c->nq * (t + 1) / k, i;
    for (i = b; i < e; i++) {
        const lc_hot *hm = &c->s->hot[c->q[i] & imask];
        search(c, t, c->dyn, c->q[i], hm);
        if (!(hm->flags & LC_SLOT_STATIC))
            search(c, t, c->sta, c->q[i], hm);
    }
}

locd_status lc_scene_find_moved(const locd_scene *s, const lc_tree *dyn, const lc_tree *sta, const uint64_t *q,
                                size_t nq, lc_plist *out, uint64_t *candidates)
{
    find_ctx *c = lc_alloc(s->alloc, sizeof *c);
    uint32_t k = s->threads, t;
    size_t total = 0;
    locd_status st = LOCD_OK;
    if (!c)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the search state");
    memset(c, 0, sizeof *c);
    c->s = s, c->dyn = dyn, c->sta = sta, c->q = q, c->nq = nq;
    if (k < 1)
        k = 1;
    if (nq < 2048)
        k = 1;
    if (k > 1)
        lc_pool_run(s->pool, k, task_find, c);
    else
        task_find(c, 0, 1);
    for (t = 0; t < k; t++) {
        if (c->st[t] != LOCD_OK)
            st = lc_error(LOCD_ERR_NO_MEMORY, "could not grow the new pairs");
        total += c->count[t];
        *candidates += c->cand[t];
    }
    if (st == LOCD_OK)
        st = lc_plist_reserve(s->alloc, out, total ? total : 1);
    if (st == LOCD_OK) {
        size_t w = 0;
        for (t = 0; t < k; t++) {
            if (c->count[t])
                memcpy((locd_id *)out->rows.data + 2 * w, c->rows[t].data, 2 * c->count[t] * sizeof(locd_id));
            w += c->count[t];
        }
        out->count = w;
        st = lc_pairs_sort_rows(s->alloc, out->rows.data, w);
    }
    for (t = 0; t < k; t++)
        lc_buf_release(s->alloc, &c->rows[t], 2 * sizeof(locd_id));
    lc_free(s->alloc, c, sizeof *c);
    return st;
}
