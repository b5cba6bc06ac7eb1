/* The single queries: the shape checked, the query tree brought up to date
 * (query_tree.c), its walk (query_walk.c), the hits into the caller's
 * buffers. Queries only read the scene (the tree is a cache, synced under
 * its lock): several threads may query at once. Their scratch comes from
 * the engine's allocator. */
#include "scene/scene.h"
#include "scene/query.h"

/* The walk's hits into ids_out and t_out (when not NULL): every hit, or
 * the best one (casts with LOCD_HIT_CLOSEST or LOCD_HIT_ANY). */
static locd_status give_hits(lc_walk *w, locd_id *ids_out, double *t_out, size_t capacity, size_t *count)
{
    const int one = w->q->kind == LC_SHAPE_CAST && w->mode != LOCD_HIT_ALL;
    const lc_hit *h = one ? &w->best : w->hit;
    const size_t n = one ? (w->best.id != LOCD_ID_NONE) : w->nhit;
    size_t k;
    *count = n;
    if (n > capacity)
        return lc_error(LOCD_ERR_BUFFER_TOO_SMALL, "%zu hits do not fit a buffer of %zu", n, capacity);
    for (k = 0; k < n; k++) {
        ids_out[k] = h[k].id;
        if (t_out)
            t_out[k] = h[k].t;
    }
    return LOCD_OK;
}

static locd_status run(const locd_scene *s, const lc_shape *q, uint32_t mode, const locd_query_filter *filter,
                       uint64_t mask, locd_id *ids_out, double *t_out, size_t capacity, size_t *count)
{
    lc_walk w;
    locd_status st;
    if (!count)
        return lc_error(LOCD_ERR_NULL_POINTER, "count is NULL");
    if (capacity && !ids_out)
        return lc_error(LOCD_ERR_NULL_POINTER, "ids_out is NULL");
    if (capacity && q->kind == LC_SHAPE_CAST && !t_out)
        return lc_error(LOCD_ERR_NULL_POINTER, "t_out is NULL");
    if ((st = lc_check_mode(mode)) != LOCD_OK || (st = lc_walk_init(&w, s, q, mode, filter, mask)) != LOCD_OK)
        return st;
    lc_query_tree_sync(s); /* (on no memory the walk tries every object) */
    if (!lc_walk_run(&w)) {
        lc_walk_fini(s->alloc, &w);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the query's hits");
    }
    lc_walk_sort(&w);
    st = give_hits(&w, ids_out, t_out, capacity, count);
    lc_walk_fini(s->alloc, &w);
    if (st == LOCD_OK)
        lc_clear_error();
    return st;
}

static locd_status overlap_box(const locd_scene *s, const void *v, int f32, int point, const locd_query_filter *f,
                               uint64_t mask, locd_id *ids_out, size_t capacity, size_t *count)
{
    double tmp[6];
    lc_shape q;
    locd_status st;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK ||
        (st = lc_shape_box(&q, lc_widen(v, f32, tmp, point ? 3 : 6), point, 0)) != LOCD_OK)
        return st;
    return run(s, &q, LOCD_HIT_ALL, f, mask, ids_out, NULL, capacity, count);
}

static locd_status overlap_sphere(const locd_scene *s, const void *c, int f32, double radius,
                                  const locd_query_filter *f, locd_id *ids_out, size_t capacity, size_t *count)
{
    double tmp[3];
    lc_shape q;
    locd_status st;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK ||
        (st = lc_shape_sphere(&q, lc_widen(c, f32, tmp, 3), radius, 0)) != LOCD_OK)
        return st;
    return run(s, &q, LOCD_HIT_ALL, f, ~(uint64_t)0, ids_out, NULL, capacity, count);
}

static locd_status cast(const locd_scene *s, const void *v, int box, const void *d, int f32, double max_t,
                        uint32_t mode, const locd_query_filter *f, uint64_t mask, locd_id *ids_out, double *t_out,
                        size_t capacity, size_t *count)
{
    double tv[6], td[3];
    lc_shape q;
    locd_status st;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK ||
        (st = lc_shape_cast(&q, lc_widen(v, f32, tv, box ? 6 : 3), box, lc_widen(d, f32, td, 3), max_t, 0)) !=
            LOCD_OK)
        return st;
    return run(s, &q, mode, f, mask, ids_out, t_out, capacity, count);
}

locd_status locd_scene_prepare_queries(locd_scene *s)
{
    locd_status st;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK || (st = lc_query_tree_sync(s)) != LOCD_OK)
        return st;
    lc_clear_error();
    return LOCD_OK;
}

/* ---- the queries of the first version: a mask, no filter ---- */

locd_status locd_scene_query_box_f32(const locd_scene *s, const float *box, uint64_t mask, locd_id *ids_out,
                                     size_t capacity, size_t *count)
{
    return overlap_box(s, box, 1, 0, NULL, mask, ids_out, capacity, count);
}

locd_status locd_scene_query_box_f64(const locd_scene *s, const double *box, uint64_t mask, locd_id *ids_out,
                                     size_t capacity, size_t *count)
{
    return overlap_box(s, box, 0, 0, NULL, mask, ids_out, capacity, count);
}

locd_status locd_scene_query_point_f32(const locd_scene *s, const float *point, uint64_t mask, locd_id *ids_out,
                                       size_t capacity, size_t *count)
{
    return overlap_box(s, point, 1, 1, NULL, mask, ids_out, capacity, count);
}

locd_status locd_scene_query_point_f64(const locd_scene *s, const double *point, uint64_t mask, locd_id *ids_out,
                                       size_t capacity, size_t *count)
{
    return overlap_box(s, point, 0, 1, NULL, mask, ids_out, capacity, count);
}

locd_status locd_scene_raycast_f32(const locd_scene *s, const float *origin, const float *direction, double max_t,
                                   uint64_t mask, locd_id *ids_out, double *t_out, size_t capacity, size_t *count)
{
    return cast(s, origin, 0, direction, 1, max_t, LOCD_HIT_ALL, NULL, mask, ids_out, t_out, capacity, count);
}

locd_status locd_scene_raycast_f64(const locd_scene *s, const double *origin, const double *direction, double max_t,
                                   uint64_t mask, locd_id *ids_out, double *t_out, size_t capacity, size_t *count)
{
    return cast(s, origin, 0, direction, 0, max_t, LOCD_HIT_ALL, NULL, mask, ids_out, t_out, capacity, count);
}

/* ---- with a filter ---- */

locd_status locd_scene_overlap_box_f32(const locd_scene *s, const float *box, const locd_query_filter *filter,
                                       locd_id *ids_out, size_t capacity, size_t *count)
{
    return overlap_box(s, box, 1, 0, filter, ~(uint64_t)0, ids_out, capacity, count);
}

locd_status locd_scene_overlap_box_f64(const locd_scene *s, const double *box, const locd_query_filter *filter,
                                       locd_id *ids_out, size_t capacity, size_t *count)
{
    return overlap_box(s, box, 0, 0, filter, ~(uint64_t)0, ids_out, capacity, count);
}

locd_status locd_scene_overlap_point_f32(const locd_scene *s, const float *point, const locd_query_filter *filter,
                                         locd_id *ids_out, size_t capacity, size_t *count)
{
    return overlap_box(s, point, 1, 1, filter, ~(uint64_t)0, ids_out, capacity, count);
}

locd_status locd_scene_overlap_point_f64(const locd_scene *s, const double *point, const locd_query_filter *filter,
                                         locd_id *ids_out, size_t capacity, size_t *count)
{
    return overlap_box(s, point, 0, 1, filter, ~(uint64_t)0, ids_out, capacity, count);
}

locd_status locd_scene_overlap_sphere_f32(const locd_scene *s, const float *center, double radius,
                                          const locd_query_filter *filter, locd_id *ids_out, size_t capacity,
                                          size_t *count)
{
    return overlap_sphere(s, center, 1, radius, filter, ids_out, capacity, count);
}

locd_status locd_scene_overlap_sphere_f64(const locd_scene *s, const double *center, double radius,
                                          const locd_query_filter *filter, locd_id *ids_out, size_t capacity,
                                          size_t *count)
{
    return overlap_sphere(s, center, 0, radius, filter, ids_out, capacity, count);
}

locd_status locd_scene_cast_ray_f32(const locd_scene *s, const float *origin, const float *direction, double max_t,
                                    uint32_t mode, const locd_query_filter *filter, locd_id *ids_out, double *t_out,
                                    size_t capacity, size_t *count)
{
    return cast(s, origin, 0, direction, 1, max_t, mode, filter, ~(uint64_t)0, ids_out, t_out, capacity, count);
}

locd_status locd_scene_cast_ray_f64(const locd_scene *s, const double *origin, const double *direction,
                                    double max_t, uint32_t mode, const locd_query_filter *filter, locd_id *ids_out,
                                    double *t_out, size_t capacity, size_t *count)
{
    return cast(s, origin, 0, direction, 0, max_t, mode, filter, ~(uint64_t)0, ids_out, t_out, capacity, count);
}

locd_status locd_scene_cast_box_f32(const locd_scene *s, const float *box, const float *direction, double max_t,
                                    uint32_t mode, const locd_query_filter *filter, locd_id *ids_out, double *t_out,
                                    size_t capacity, size_t *count)
{
    return cast(s, box, 1, direction, 1, max_t, mode, filter, ~(uint64_t)0, ids_out, t_out, capacity, count);
}

locd_status locd_scene_cast_box_f64(const locd_scene *s, const double *box, const double *direction, double max_t,
                                    uint32_t mode, const locd_query_filter *filter, locd_id *ids_out, double *t_out,
                                    size_t capacity, size_t *count)
{
    return cast(s, box, 1, direction, 0, max_t, mode, filter, ~(uint64_t)0, ids_out, t_out, capacity, count);
}
