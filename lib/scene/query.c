/* Queries: the objects whose box overlaps a box, contains a point, or meets
 * a ray segment, filtered by category & mask. Candidates come from the
 * entry lists (the cells the query's box covers) or, when that would cost
 * more, a scan; each is tested exactly. Queries only read the scene
 * (several threads may query at once); their scratch comes from the
 * engine's allocator. */
#include "scene/scene.h"

#include <math.h>
#include <stdlib.h>

/* A hit: id and entry parameter (0 for box and point queries). */
typedef struct lc_hit {
    double t;
    locd_id id;
} lc_hit;

static int cmp_hit(const void *pa, const void *pb)
{
    const lc_hit *a = pa, *b = pb;
    if (a->t != b->t)
        return a->t < b->t ? -1 : 1;
    return (a->id > b->id) - (a->id < b->id);
}

/* The slab test of docs/scene.md: t runs from 0 to max_t; per axis the
 * segment is clipped to [lo, hi] in float64; a zero direction component
 * needs the origin inside the slab. 1 and *t_enter on a hit. */
static int lc_ray_box(const double *b, const double *o, const double *d, double max_t, double *t_enter)
{
    double t0 = 0.0, t1 = max_t;
    int a;
    for (a = 0; a < 3; a++) {
        if (d[a] == 0.0) {
            if (o[a] < b[a] || o[a] > b[a + 3])
                return 0;
        } else {
            double u = (b[a] - o[a]) / d[a], v = (b[a + 3] - o[a]) / d[a];
            if (u > v) {
                double w = u;
                u = v;
                v = w;
            }
            if (u > t0)
                t0 = u;
            if (v < t1)
                t1 = v;
            if (t0 > t1)
                return 0;
        }
    }
    *t_enter = t0;
    return 1;
}

/* What a query asks: a box (point: lo == hi) or a ray. */
typedef struct lc_ask {
    int ray;
    double box[6];
    double o[3], d[3], max_t;
    uint64_t mask;
} lc_ask;

static int hit_one(const locd_scene *s, const lc_ask *q, size_t k, double *t)
{
    double tmp[6];
    if (!(s->slots.cat[k] & q->mask))
        return 0;
    if (q->ray)
        return lc_ray_box(lc_slot_box(&s->slots, k, tmp), q->o, q->d, q->max_t, t);
    *t = 0.0;
    return lc_box_overlap(lc_slot_box(&s->slots, k, tmp), q->box);
}

/* The hits gathered so far. */
typedef struct lc_hits {
    const locd_allocator *a;
    lc_hit *h;
    size_t n, cap;
    int failed;
} lc_hits;

static void add_hit(lc_hits *hs, double t, locd_id id)
{
    if (hs->failed)
        return;
    if (hs->n == hs->cap) {
        size_t nc = lc_grow_cap(hs->cap, hs->n + 1);
        lc_hit *h = lc_alloc(hs->a, nc * sizeof *h);
        if (!h) {
            hs->failed = 1;
            return;
        }
        if (hs->h)
            memcpy(h, hs->h, hs->n * sizeof *h);
        lc_free(hs->a, hs->h, hs->cap * sizeof *hs->h);
        hs->h = h, hs->cap = nc;
    }
    hs->h[hs->n].t = t;
    hs->h[hs->n].id = id;
    hs->n++;
}

static void try_slot(const locd_scene *s, const lc_ask *q, size_t k, lc_hits *hs)
{
    double t;
    if (hit_one(s, q, k, &t))
        add_hit(hs, t, s->slots.id[k]);
}

/* Above this many cells per object of the scene, a scan is cheaper. */
#define LC_QUERY_CELLS_PER_OBJECT 0.05

/* The query's box (for a ray, its segment's box widened by a margin far
 * above the rounding of o + max_t * d: candidates may only be too many),
 * or 0 when it has none (an unbounded ray). */
static int query_bounds(const lc_ask *q, double *b)
{
    int a;
    if (!q->ray) {
        memcpy(b, q->box, 6 * sizeof *b);
        return 1;
    }
    if (!isfinite(q->max_t))
        return 0;
    for (a = 0; a < 3; a++) {
        double e = q->o[a] + q->max_t * q->d[a];
        double lo = q->o[a] < e ? q->o[a] : e, hi = q->o[a] < e ? e : q->o[a];
        double m = (fabs(lo) + fabs(hi) + fabs(q->max_t * q->d[a])) * 1e-9 + 1e-300;
        b[a] = lo - m;
        b[a + 3] = hi + m;
        if (!isfinite(b[a]) || !isfinite(b[a + 3]))
            return 0;
    }
    return 1;
}

/* The objects in the cells the query's box covers, at every level that
 * holds entries, through the entry lists (their cells are those of the
 * last update: the objects changed since are tried one by one). Returns 0
 * when walking the cells would cost more than a scan. An object overlapping
 * the box has, at its level, the cell that holds max(its low corner, the
 * box's) in the box's cell range (the quantization is monotone), so it is
 * met at least once; duplicates are removed after the sort. */
/* The cells the query's quantized box [lo, hi] covers, over the levels
 * that hold entries. */
static double cells_covered(const lc_entries *en, const uint32_t *lo, const uint32_t *hi)
{
    double cells = 0.0;
    uint32_t l, a;
    for (l = 0; l <= en->grid.depth; l++) {
        double c = 1.0;
        if (!en->dyn.per_level[l] && !en->sta.per_level[l])
            continue;
        for (a = 0; a < 3; a++)
            c *= (double)((hi[a] >> (LC_QBITS - l)) - (lo[a] >> (LC_QBITS - l)) + 1u);
        cells += c;
    }
    return cells;
}

/* The objects with an entry of key in list tr (main array and overflow)
 * that did not change since the lists were made, tried. */
static void key_candidates(const locd_scene *s, const lc_ask *q, const lc_entry_list *tr, uint64_t key, lc_hits *hs)
{
    const uint32_t ib = s->entries.grid.index_bits;
    const uint64_t imask = ((uint64_t)1 << ib) - 1;
    int part;
    for (part = 0; part < 2; part++) {
        const uint64_t *e = part ? tr->ovf.data : tr->ent.data;
        const size_t n = part ? tr->novf : tr->count;
        size_t i = part ? lc_lower_bound(e, n, key << ib) : lc_entry_list_lower_bound(tr, key << ib);
        for (; i < n && (e[i] >> ib) == key; i++) {
            uint32_t slot;
            if ((e[i] & imask) == imask)
                continue; /* a tombstone */
            slot = s->entries.rec[e[i] & imask].slot;
            if ((s->slots.flags[slot] & (LC_SLOT_LIVE | LC_SLOT_DIRTY)) == LC_SLOT_LIVE)
                try_slot(s, q, slot, hs);
        }
    }
}

/* The candidates of list tr at level l in the cells of [lo, hi]. */
static void level_candidates(const locd_scene *s, const lc_ask *q, const lc_entry_list *tr, uint32_t l,
                             const uint32_t *lo, const uint32_t *hi, lc_hits *hs)
{
    const locd_grid *g = &s->entries.grid;
    uint32_t c0[3], c1[3], x, y, z, a;
    for (a = 0; a < 3; a++)
        c0[a] = lo[a] >> (LC_QBITS - l), c1[a] = hi[a] >> (LC_QBITS - l);
    for (z = c0[2]; z <= c1[2]; z++)
        for (y = c0[1]; y <= c1[1]; y++)
            for (x = c0[0]; x <= c1[0]; x++) {
                const uint64_t m = lc_morton_split3(x) | lc_morton_split3(y) << 1 | lc_morton_split3(z) << 2;
                key_candidates(s, q, tr, ((m << (3u * (g->depth - l))) << LC_LEVEL_BITS) | l, hs);
            }
}

static int tree_candidates(const locd_scene *s, const lc_ask *q, lc_hits *hs)
{
    const lc_entries *en = &s->entries;
    const uint32_t *d = s->slots.dirty.data;
    uint32_t lo[3], hi[3], l, a;
    double b[6];
    int t;
    size_t k;
    if (!en->valid || !query_bounds(q, b))
        return 0;
    for (a = 0; a < 3; a++) {
        lo[a] = (uint32_t)lc_quantize(&en->grid, (int)a, b[a]);
        hi[a] = (uint32_t)lc_quantize(&en->grid, (int)a, b[a + 3]);
    }
    if (cells_covered(en, lo, hi) > LC_QUERY_CELLS_PER_OBJECT * (double)s->slots.nslots + 64.0)
        return 0;
    for (t = 0; t < 2; t++)
        for (l = 0; l <= en->grid.depth; l++)
            if ((t ? &en->sta : &en->dyn)->per_level[l])
                level_candidates(s, q, t ? &en->sta : &en->dyn, l, lo, hi, hs);
    for (k = 0; k < s->slots.ndirty; k++)
        if (s->slots.flags[d[k]] & LC_SLOT_LIVE)
            try_slot(s, q, d[k], hs);
    return 1;
}

static locd_status run(const locd_scene *s, const lc_ask *q, locd_id *ids_out, double *t_out, size_t capacity,
                       size_t *count)
{
    const locd_allocator *a = s->alloc;
    size_t k, n = 0;
    lc_hits hs;
    if (!count)
        return lc_error(LOCD_ERR_NULL_POINTER, "count is NULL");
    if (capacity && !ids_out)
        return lc_error(LOCD_ERR_NULL_POINTER, "ids_out is NULL");
    if (capacity && q->ray && !t_out)
        return lc_error(LOCD_ERR_NULL_POINTER, "t_out is NULL");
    memset(&hs, 0, sizeof hs);
    hs.a = a;
    if (!tree_candidates(s, q, &hs))
        for (k = 0; k < s->slots.nslots; k++)
            if (s->slots.flags[k] & LC_SLOT_LIVE)
                try_slot(s, q, k, &hs);
    if (hs.failed) {
        lc_free(a, hs.h, hs.cap * sizeof *hs.h);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the query's hits");
    }
    if (hs.n)
        qsort(hs.h, hs.n, sizeof *hs.h, cmp_hit);
    for (k = 0; k < hs.n; k++) /* an object met in several cells: once */
        if (n == 0 || hs.h[k].id != hs.h[n - 1].id)
            hs.h[n++] = hs.h[k];
    *count = n;
    if (n > capacity) {
        lc_free(a, hs.h, hs.cap * sizeof *hs.h);
        return lc_error(LOCD_ERR_BUFFER_TOO_SMALL, "%zu hits do not fit a buffer of %zu", n, capacity);
    }
    for (k = 0; k < n; k++) {
        ids_out[k] = hs.h[k].id;
        if (t_out)
            t_out[k] = hs.h[k].t;
    }
    lc_free(a, hs.h, hs.cap * sizeof *hs.h);
    lc_clear_error();
    return LOCD_OK;
}

/* Fills q->box from 6 (box) or 3 (point) values, checked. */
static locd_status ask_box(lc_ask *q, const double *v, int point)
{
    int a;
    for (a = 0; a < (point ? 3 : 6); a++)
        if (!isfinite(v[a]))
            return lc_error_box(LOCD_ERR_NONFINITE, 0, "the query has a non-finite coordinate");
    for (a = 0; a < 3; a++) {
        q->box[a] = v[a];
        q->box[a + 3] = point ? v[a] : v[a + 3];
        if (q->box[a] > q->box[a + 3])
            return lc_error_box(LOCD_ERR_INVERTED_BOX, 0, "the query box has min > max on axis %d", a);
    }
    return LOCD_OK;
}

static locd_status query_box(const locd_scene *s, const double *v, int point, uint64_t mask, locd_id *ids_out,
                             size_t capacity, size_t *count)
{
    lc_ask q;
    locd_status st;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK)
        return st;
    if (!v)
        return lc_error(LOCD_ERR_NULL_POINTER, point ? "point is NULL" : "box is NULL");
    memset(&q, 0, sizeof q);
    q.mask = mask;
    if ((st = ask_box(&q, v, point)) != LOCD_OK)
        return st;
    return run(s, &q, ids_out, NULL, capacity, count);
}

/* The float entry points widen their input (exactly: every float is a
 * double) and share the double path; NULL stays NULL for its check. */
static const double *widen(const float *src, double *dst, int n)
{
    int a;
    if (!src)
        return NULL;
    for (a = 0; a < n; a++)
        dst[a] = src[a];
    return dst;
}

locd_status locd_scene_query_box_f32(const locd_scene *s, const float *box, uint64_t mask, locd_id *ids_out,
                                     size_t capacity, size_t *count)
{
    double v[6];
    return query_box(s, widen(box, v, 6), 0, mask, ids_out, capacity, count);
}

locd_status locd_scene_query_box_f64(const locd_scene *s, const double *box, uint64_t mask, locd_id *ids_out,
                                     size_t capacity, size_t *count)
{
    return query_box(s, box, 0, mask, ids_out, capacity, count);
}

locd_status locd_scene_query_point_f32(const locd_scene *s, const float *point, uint64_t mask, locd_id *ids_out,
                                       size_t capacity, size_t *count)
{
    double v[3];
    return query_box(s, widen(point, v, 3), 1, mask, ids_out, capacity, count);
}

locd_status locd_scene_query_point_f64(const locd_scene *s, const double *point, uint64_t mask, locd_id *ids_out,
                                       size_t capacity, size_t *count)
{
    return query_box(s, point, 1, mask, ids_out, capacity, count);
}

static locd_status raycast(const locd_scene *s, const double *o, const double *d, double max_t, uint64_t mask,
                           locd_id *ids_out, double *t_out, size_t capacity, size_t *count)
{
    lc_ask q;
    locd_status st;
    int a;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK)
        return st;
    memset(&q, 0, sizeof q);
    for (a = 0; a < 3; a++) {
        if (!isfinite(o[a]) || !isfinite(d[a]))
            return lc_error_box(LOCD_ERR_NONFINITE, 0, "the ray's origin or direction is not finite");
        q.o[a] = o[a];
        q.d[a] = d[a];
    }
    if (isnan(max_t) || max_t < 0.0)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "max_t must be >= 0");
    q.ray = 1;
    q.max_t = max_t;
    q.mask = mask;
    return run(s, &q, ids_out, t_out, capacity, count);
}

locd_status locd_scene_raycast_f32(const locd_scene *s, const float *origin, const float *direction, double max_t,
                                   uint64_t mask, locd_id *ids_out, double *t_out, size_t capacity, size_t *count)
{
    double o[3], d[3];
    if (!origin || !direction)
        return lc_error(LOCD_ERR_NULL_POINTER, "origin or direction is NULL");
    return raycast(s, widen(origin, o, 3), widen(direction, d, 3), max_t, mask, ids_out, t_out, capacity, count);
}

locd_status locd_scene_raycast_f64(const locd_scene *s, const double *origin, const double *direction, double max_t,
                                   uint64_t mask, locd_id *ids_out, double *t_out, size_t capacity, size_t *count)
{
    if (!origin || !direction)
        return lc_error(LOCD_ERR_NULL_POINTER, "origin or direction is NULL");
    return raycast(s, origin, direction, max_t, mask, ids_out, t_out, capacity, count);
}
