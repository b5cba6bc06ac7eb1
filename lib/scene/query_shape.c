/* The queries' shapes, checked: a NaN or infinite coordinate, min > max,
 * a NaN or negative radius or max_t are errors naming the query. */
#include "scene/scene.h"
#include "scene/query.h"

locd_status lc_check_mode(uint32_t mode)
{
    if (mode > LOCD_HIT_ANY)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "unknown hit mode %u", mode);
    return LOCD_OK;
}

/* The 6 values of a box (or 3 of a point) finite, min <= max. */
static locd_status check_box(const double *v, int point, size_t k, double *lo, double *hi)
{
    int a;
    for (a = 0; a < (point ? 3 : 6); a++)
        if (!isfinite(v[a]))
            return lc_error_box(LOCD_ERR_NONFINITE, (int64_t)k, "query %zu has a NaN or infinite coordinate", k);
    for (a = 0; a < 3; a++) {
        lo[a] = v[a], hi[a] = point ? v[a] : v[a + 3];
        if (lo[a] > hi[a])
            return lc_error_box(LOCD_ERR_INVERTED_BOX, (int64_t)k, "query %zu has min > max on axis %d", k, a);
    }
    return LOCD_OK;
}

locd_status lc_shape_box(lc_shape *q, const double *v, int point, size_t k)
{
    q->kind = LC_SHAPE_BOX; /* (the fields its kind uses: no memset, a query's setup is on its clock) */
    if (!v)
        return lc_error(LOCD_ERR_NULL_POINTER, point ? "point is NULL" : "box is NULL");
    return check_box(v, point, k, q->lo, q->hi);
}

locd_status lc_shape_sphere(lc_shape *q, const double *center, double radius, size_t k)
{
    int a;
    q->kind = LC_SHAPE_SPHERE;
    if (!center)
        return lc_error(LOCD_ERR_NULL_POINTER, "center is NULL");
    for (a = 0; a < 3; a++) {
        if (!isfinite(center[a]))
            return lc_error_box(LOCD_ERR_NONFINITE, (int64_t)k, "query %zu has a NaN or infinite coordinate", k);
        q->c[a] = center[a];
    }
    if (!(radius >= 0.0))
        return lc_error_box(LOCD_ERR_INVALID_ARGUMENT, (int64_t)k, "query %zu: the radius must be >= 0 (not NaN)", k);
    q->r2 = radius * radius;
    return LOCD_OK;
}

locd_status lc_shape_cast(lc_shape *q, const double *v, int box, const double *d, double max_t, size_t k)
{
    locd_status st;
    int a;
    q->kind = LC_SHAPE_CAST;
    if (!v || !d)
        return lc_error(LOCD_ERR_NULL_POINTER, box ? "box or direction is NULL" : "origin or direction is NULL");
    if ((st = check_box(v, !box, k, q->lo, q->hi)) != LOCD_OK)
        return st;
    for (a = 0; a < 3; a++) {
        if (!isfinite(d[a]))
            return lc_error_box(LOCD_ERR_NONFINITE, (int64_t)k, "query %zu: the direction is NaN or infinite", k);
        q->d[a] = d[a];
    }
    if (!(max_t >= 0.0))
        return lc_error_box(LOCD_ERR_INVALID_ARGUMENT, (int64_t)k, "query %zu: max_t must be >= 0 (not NaN)", k);
    q->max_t = max_t;
    return LOCD_OK;
}
