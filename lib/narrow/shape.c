/* Shapes: constructors with validation, reference counting, poses and
 * world boxes. */
#include "core/core.h"
#include "narrow/narrow.h"

#include <math.h>
#include <stdlib.h>

static locd_shape *shape_new(int32_t kind)
{
    locd_shape *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    s->magic = LC_MAGIC_SHAPE;
    s->kind = kind;
    s->refs = 1;
    return s;
}

static void shape_free(locd_shape *s)
{
    if (s->fcl)
        lc_fcl_free(s->fcl);
    free(s->points);
    free(s->tris);
    free(s->tri_boxes);
    s->magic = LC_MAGIC_DEAD;
    free(s);
}

locd_status lc_shape_check(const locd_shape *s)
{
    if (!s || s->magic != LC_MAGIC_SHAPE)
        return lc_error(LOCD_ERR_INVALID_HANDLE, "not a live locd_shape");
    return LOCD_OK;
}

void lc_shape_retain(locd_shape *s)
{
    __atomic_add_fetch(&s->refs, 1, __ATOMIC_RELAXED);
}

void lc_shape_release(locd_shape *s)
{
    if (__atomic_sub_fetch(&s->refs, 1, __ATOMIC_ACQ_REL) == 0)
        shape_free(s);
}

void locd_shape_destroy(locd_shape *shape)
{
    if (shape && shape->magic == LC_MAGIC_SHAPE)
        lc_shape_release(shape);
}

int32_t locd_shape_kind(const locd_shape *shape)
{
    return shape && shape->magic == LC_MAGIC_SHAPE ? shape->kind : 0;
}

/* Local box, bounding radius and extent from the kind's parameters. */
static void shape_finish_primitive(locd_shape *s)
{
    double h[3];
    int a;
    if (s->kind == LOCD_SHAPE_SPHERE) {
        h[0] = h[1] = h[2] = s->radius;
        s->bound_radius = s->radius;
    } else if (s->kind == LOCD_SHAPE_BOX) {
        h[0] = s->half[0];
        h[1] = s->half[1];
        h[2] = s->half[2];
        s->bound_radius = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    } else { /* capsule */
        h[0] = h[1] = s->radius;
        h[2] = s->radius + s->half[2];
        s->bound_radius = h[2];
    }
    for (a = 0; a < 3; a++) {
        s->local_box[a] = -h[a];
        s->local_box[3 + a] = h[a];
    }
    s->extent = 2.0 * fmin(h[0], fmin(h[1], h[2]));
}

/* Local box, centroid, bounding radius and extent of a point set. */
static void shape_finish_points(locd_shape *s)
{
    size_t i;
    int a;
    double r2 = 0.0;
    for (a = 0; a < 3; a++) {
        s->local_box[a] = INFINITY;
        s->local_box[3 + a] = -INFINITY;
        s->centroid[a] = 0.0;
    }
    for (i = 0; i < s->npoints; i++) {
        const double *p = s->points + 3 * i;
        double d2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
        for (a = 0; a < 3; a++) {
            s->local_box[a] = fmin(s->local_box[a], p[a]);
            s->local_box[3 + a] = fmax(s->local_box[3 + a], p[a]);
            s->centroid[a] += p[a];
        }
        r2 = fmax(r2, d2);
    }
    for (a = 0; a < 3; a++)
        s->centroid[a] /= (double)s->npoints;
    s->bound_radius = sqrt(r2);
    s->extent = INFINITY;
    for (a = 0; a < 3; a++)
        s->extent = fmin(s->extent, s->local_box[3 + a] - s->local_box[a]);
    /* A flat shape (a terrain patch) still has a size: its largest edge. */
    if (s->extent <= 0.0)
        for (a = 0; a < 3; a++)
            s->extent = fmax(s->extent, s->local_box[3 + a] - s->local_box[a]);
}

/* Builds the FCL geometry where FCL supports the kind. */
static locd_status shape_attach_fcl(locd_shape *s)
{
    char err[160] = "";
    if (s->kind == LOCD_SHAPE_CONVEX)
        return LOCD_OK; /* convex hulls go through libccd (FCL wants hull faces) */
    s->fcl = lc_fcl_make(s, err, sizeof err);
    if (!s->fcl)
        return lc_error(LOCD_ERR_SHAPE, "FCL rejected the shape: %s", err);
    return LOCD_OK;
}

static locd_status shape_done(locd_shape *s, locd_shape **out)
{
    locd_status st = shape_attach_fcl(s);
    if (st != LOCD_OK) {
        shape_free(s);
        return st;
    }
    lc_clear_error();
    *out = s;
    return LOCD_OK;
}

static int positive(double x)
{
    return isfinite(x) && x > 0.0;
}

locd_status locd_shape_sphere(double radius, locd_shape **out)
{
    locd_shape *s;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    if (!positive(radius))
        return lc_error(LOCD_ERR_SHAPE, "sphere radius %g must be finite and > 0", radius);
    if (!(s = shape_new(LOCD_SHAPE_SPHERE)))
        return lc_error(LOCD_ERR_NO_MEMORY, "shape");
    s->radius = radius;
    shape_finish_primitive(s);
    return shape_done(s, out);
}

locd_status locd_shape_box(double half_x, double half_y, double half_z, locd_shape **out)
{
    locd_shape *s;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    if (!positive(half_x) || !positive(half_y) || !positive(half_z))
        return lc_error(LOCD_ERR_SHAPE, "box half extents (%g, %g, %g) must be finite and > 0", half_x, half_y,
                        half_z);
    if (!(s = shape_new(LOCD_SHAPE_BOX)))
        return lc_error(LOCD_ERR_NO_MEMORY, "shape");
    s->half[0] = half_x;
    s->half[1] = half_y;
    s->half[2] = half_z;
    shape_finish_primitive(s);
    return shape_done(s, out);
}

locd_status locd_shape_capsule(double radius, double half_length, locd_shape **out)
{
    locd_shape *s;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    if (!positive(radius) || !isfinite(half_length) || half_length < 0.0)
        return lc_error(LOCD_ERR_SHAPE, "capsule radius %g must be > 0 and half length %g >= 0, both finite", radius,
                        half_length);
    if (!(s = shape_new(LOCD_SHAPE_CAPSULE)))
        return lc_error(LOCD_ERR_NO_MEMORY, "shape");
    s->radius = radius;
    s->half[2] = half_length;
    shape_finish_primitive(s);
    return shape_done(s, out);
}

static locd_status copy_points(locd_shape *s, const double *points, size_t count, const char *what)
{
    size_t i;
    for (i = 0; i < 3 * count; i++)
        if (!isfinite(points[i]))
            return lc_error_box(LOCD_ERR_SHAPE, (int64_t)(i / 3), "%s %zu has a non-finite coordinate", what, i / 3);
    s->points = malloc(3 * count * sizeof(double));
    if (!s->points)
        return lc_error(LOCD_ERR_NO_MEMORY, "shape points");
    memcpy(s->points, points, 3 * count * sizeof(double));
    s->npoints = count;
    return LOCD_OK;
}

locd_status locd_shape_convex(const double *points, size_t count, locd_shape **out)
{
    locd_shape *s;
    locd_status st;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    if (count == 0)
        return lc_error(LOCD_ERR_SHAPE, "convex hull of an empty point set");
    if (!points)
        return lc_error(LOCD_ERR_NULL_POINTER, "points is NULL");
    if (count > (SIZE_MAX / 24))
        return lc_error(LOCD_ERR_SHAPE, "too many points");
    if (!(s = shape_new(LOCD_SHAPE_CONVEX)))
        return lc_error(LOCD_ERR_NO_MEMORY, "shape");
    if ((st = copy_points(s, points, count, "convex hull point")) != LOCD_OK) {
        shape_free(s);
        return st;
    }
    shape_finish_points(s);
    /* One distinct point has no extent at all: a sphere says that better. */
    if (s->local_box[0] == s->local_box[3] && s->local_box[1] == s->local_box[4] &&
        s->local_box[2] == s->local_box[5]) {
        shape_free(s);
        return lc_error(LOCD_ERR_SHAPE, "convex hull of %zu identical points has no extent", count);
    }
    return shape_done(s, out);
}

/* Twice the area of triangle t (the cross product's length). */
static double tri_area2(const double *v, const uint32_t *t)
{
    const double *a = v + 3 * t[0], *b = v + 3 * t[1], *c = v + 3 * t[2];
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double x = u[1] * w[2] - u[2] * w[1], y = u[2] * w[0] - u[0] * w[2], z = u[0] * w[1] - u[1] * w[0];
    return sqrt(x * x + y * y + z * z);
}

static locd_status mesh_triangles(locd_shape *s, const uint32_t *triangles, size_t count)
{
    size_t i;
    int k, a;
    double scale = s->bound_radius > 0.0 ? s->bound_radius : 1.0;
    for (i = 0; i < 3 * count; i++)
        if (triangles[i] >= s->npoints)
            return lc_error_box(LOCD_ERR_SHAPE, (int64_t)(i / 3), "mesh triangle %zu uses vertex %u of %zu", i / 3,
                                triangles[i], s->npoints);
    for (i = 0; i < count; i++)
        if (!(tri_area2(s->points, triangles + 3 * i) > 1e-12 * scale * scale))
            return lc_error_box(LOCD_ERR_SHAPE, (int64_t)i, "mesh triangle %zu is degenerate (zero area)", i);
    s->tris = malloc(3 * count * sizeof(uint32_t));
    s->tri_boxes = malloc(6 * count * sizeof(double));
    if (!s->tris || !s->tri_boxes)
        return lc_error(LOCD_ERR_NO_MEMORY, "mesh triangles");
    memcpy(s->tris, triangles, 3 * count * sizeof(uint32_t));
    s->ntris = count;
    for (i = 0; i < count; i++) {
        double *b = s->tri_boxes + 6 * i;
        for (a = 0; a < 3; a++) {
            b[a] = INFINITY;
            b[3 + a] = -INFINITY;
        }
        for (k = 0; k < 3; k++)
            for (a = 0; a < 3; a++) {
                double x = s->points[3 * s->tris[3 * i + k] + a];
                b[a] = fmin(b[a], x);
                b[3 + a] = fmax(b[3 + a], x);
            }
    }
    return LOCD_OK;
}

locd_status locd_shape_mesh(const double *vertices, size_t vertex_count, const uint32_t *triangles,
                            size_t triangle_count, locd_shape **out)
{
    locd_shape *s;
    locd_status st;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    if (triangle_count == 0 || vertex_count < 3)
        return lc_error(LOCD_ERR_SHAPE, "mesh needs at least one triangle and 3 vertices (got %zu, %zu)",
                        triangle_count, vertex_count);
    if (!vertices || !triangles)
        return lc_error(LOCD_ERR_NULL_POINTER, "vertices or triangles is NULL");
    if (vertex_count > UINT32_MAX || triangle_count > (SIZE_MAX / 48))
        return lc_error(LOCD_ERR_SHAPE, "mesh too large");
    if (!(s = shape_new(LOCD_SHAPE_MESH)))
        return lc_error(LOCD_ERR_NO_MEMORY, "shape");
    st = copy_points(s, vertices, vertex_count, "mesh vertex");
    if (st == LOCD_OK) {
        shape_finish_points(s);
        st = mesh_triangles(s, triangles, triangle_count);
    }
    if (st != LOCD_OK) {
        shape_free(s);
        return st;
    }
    return shape_done(s, out);
}

int lc_pose_to_rt(const double *pose, double *R, double *t)
{
    double x = pose[3], y = pose[4], z = pose[5], w = pose[6], n;
    int i;
    for (i = 0; i < 7; i++)
        if (!isfinite(pose[i]))
            return 0;
    n = sqrt(x * x + y * y + z * z + w * w);
    if (!(n > 1e-12))
        return 0;
    x /= n;
    y /= n;
    z /= n;
    w /= n;
    R[0] = 1 - 2 * (y * y + z * z);
    R[1] = 2 * (x * y - z * w);
    R[2] = 2 * (x * z + y * w);
    R[3] = 2 * (x * y + z * w);
    R[4] = 1 - 2 * (x * x + z * z);
    R[5] = 2 * (y * z - x * w);
    R[6] = 2 * (x * z - y * w);
    R[7] = 2 * (y * z + x * w);
    R[8] = 1 - 2 * (x * x + y * y);
    t[0] = pose[0];
    t[1] = pose[1];
    t[2] = pose[2];
    return 1;
}

void lc_place(const locd_shape *s, const double *R, const double *t, lc_placed *out)
{
    out->s = s;
    memcpy(out->R, R, sizeof out->R);
    memcpy(out->t, t, sizeof out->t);
}

void lc_placed_box(const lc_placed *p, double *box)
{
    const locd_shape *s = p->s;
    const double *R = p->R;
    int a;
    if (s->kind == LOCD_SHAPE_SPHERE) {
        for (a = 0; a < 3; a++) {
            box[a] = p->t[a] - s->radius;
            box[3 + a] = p->t[a] + s->radius;
        }
        return;
    }
    if (s->kind == LOCD_SHAPE_CAPSULE) {
        /* Segment end points +-h R e_z, grown by the radius. */
        for (a = 0; a < 3; a++) {
            double e = fabs(R[3 * a + 2]) * s->half[2] + s->radius;
            box[a] = p->t[a] - e;
            box[3 + a] = p->t[a] + e;
        }
        return;
    }
    if (s->kind == LOCD_SHAPE_CONVEX || s->kind == LOCD_SHAPE_MESH) {
        /* Exact box of the transformed points (tight for rotating rocks). */
        size_t i;
        for (a = 0; a < 3; a++) {
            box[a] = INFINITY;
            box[3 + a] = -INFINITY;
        }
        for (i = 0; i < s->npoints; i++) {
            const double *q = s->points + 3 * i;
            for (a = 0; a < 3; a++) {
                double x = R[3 * a] * q[0] + R[3 * a + 1] * q[1] + R[3 * a + 2] * q[2] + p->t[a];
                box[a] = fmin(box[a], x);
                box[3 + a] = fmax(box[3 + a], x);
            }
        }
        return;
    }
    /* Oriented box: centre +- |R| h. */
    for (a = 0; a < 3; a++) {
        double e = fabs(R[3 * a]) * s->half[0] + fabs(R[3 * a + 1]) * s->half[1] + fabs(R[3 * a + 2]) * s->half[2];
        box[a] = p->t[a] - e;
        box[3 + a] = p->t[a] + e;
    }
}

locd_status locd_shape_aabb(const locd_shape *shape, const double *pose, double *box)
{
    double R[9], t[3];
    lc_placed p;
    locd_status st = lc_shape_check(shape);
    if (st != LOCD_OK)
        return st;
    if (!pose || !box)
        return lc_error(LOCD_ERR_NULL_POINTER, "pose or box is NULL");
    if (!lc_pose_to_rt(pose, R, t))
        return lc_error(LOCD_ERR_SHAPE, "pose is non-finite or has a zero quaternion");
    lc_place(shape, R, t, &p);
    lc_placed_box(&p, box);
    lc_clear_error();
    return LOCD_OK;
}
