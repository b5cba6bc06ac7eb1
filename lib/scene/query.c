/* Queries: the objects whose box overlaps a box, contains a point, or meets
 * a ray segment, filtered by category & mask. Queries only read the scene
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
int lc_ray_box(const double *b, const double *o, const double *d, double max_t, double *t_enter)
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
    if (!(s->cat[k] & q->mask))
        return 0;
    if (q->ray)
        return lc_ray_box(s->box + 6 * k, q->o, q->d, q->max_t, t);
    *t = 0.0;
    return lc_box_overlap(s->box + 6 * k, q->box);
}

static locd_status run(const locd_scene *s, const lc_ask *q, locd_id *ids_out, double *t_out, size_t capacity,
                       size_t *count)
{
    const locd_allocator *a = s->alloc;
    size_t k, n = 0, cap = 0;
    lc_hit *hits = NULL;
    if (!count)
        return lc_error(LOCD_ERR_NULL_POINTER, "count is NULL");
    if (capacity && !ids_out)
        return lc_error(LOCD_ERR_NULL_POINTER, "ids_out is NULL");
    if (capacity && q->ray && !t_out)
        return lc_error(LOCD_ERR_NULL_POINTER, "t_out is NULL");
    for (k = 0; k < s->nslots; k++) {
        double t;
        if (!(s->flags[k] & LC_SLOT_LIVE) || !hit_one(s, q, k, &t))
            continue;
        if (n == cap) {
            size_t nc = lc_grow_cap(cap, n + 1);
            lc_hit *h = lc_alloc(a, nc * sizeof *h);
            if (!h) {
                lc_free(a, hits, cap * sizeof *hits);
                return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the query's hits");
            }
            if (hits)
                memcpy(h, hits, n * sizeof *h);
            lc_free(a, hits, cap * sizeof *hits);
            hits = h, cap = nc;
        }
        hits[n].t = t;
        hits[n].id = s->id[k];
        n++;
    }
    *count = n;
    if (n > capacity) {
        lc_free(a, hits, cap * sizeof *hits);
        return lc_error(LOCD_ERR_BUFFER_TOO_SMALL, "%zu hits do not fit a buffer of %zu", n, capacity);
    }
    if (n)
        qsort(hits, n, sizeof *hits, cmp_hit);
    for (k = 0; k < n; k++) {
        ids_out[k] = hits[k].id;
        if (t_out)
            t_out[k] = hits[k].t;
    }
    lc_free(a, hits, cap * sizeof *hits);
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

locd_status locd_scene_query_box_f32(const locd_scene *s, const float *box, uint64_t mask, locd_id *ids_out,
                                     size_t capacity, size_t *count)
{
    double v[6];
    int a;
    if (!box)
        return query_box(s, NULL, 0, mask, ids_out, capacity, count);
    for (a = 0; a < 6; a++)
        v[a] = box[a];
    return query_box(s, v, 0, mask, ids_out, capacity, count);
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
    int a;
    if (!point)
        return query_box(s, NULL, 1, mask, ids_out, capacity, count);
    for (a = 0; a < 3; a++)
        v[a] = point[a];
    return query_box(s, v, 1, mask, ids_out, capacity, count);
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
    int a;
    if (!origin || !direction)
        return lc_error(LOCD_ERR_NULL_POINTER, "origin or direction is NULL");
    for (a = 0; a < 3; a++)
        o[a] = origin[a], d[a] = direction[a];
    return raycast(s, o, d, max_t, mask, ids_out, t_out, capacity, count);
}

locd_status locd_scene_raycast_f64(const locd_scene *s, const double *origin, const double *direction, double max_t,
                                   uint64_t mask, locd_id *ids_out, double *t_out, size_t capacity, size_t *count)
{
    if (!origin || !direction)
        return lc_error(LOCD_ERR_NULL_POINTER, "origin or direction is NULL");
    return raycast(s, origin, direction, max_t, mask, ids_out, t_out, capacity, count);
}
