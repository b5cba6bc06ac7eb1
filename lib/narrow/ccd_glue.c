/* The libccd glue (as fcl_glue.cpp is FCL's): support functions of the
 * locd shapes, GJK (yes/no), EPA or MPR (contact data), a translational
 * swept test, and meshes tested one triangle at a time against a convex
 * shape. */
#include "core/core.h"
#include "narrow/narrow.h"

#include <ccd/ccd.h>
#include <math.h>
#include <string.h>

/* What libccd sees: a placed shape, or one triangle of a placed mesh, moved
 * along `sweep` (the Minkowski sum with the segment [0, sweep] is still
 * convex, so GJK on it tells whether the shapes meet during the motion). */
typedef struct ccd_obj {
    const lc_placed *p;
    long tri; /* mesh triangle, or -1 for the whole shape */
    double sweep[3];
} ccd_obj;

static double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void to_world(const lc_placed *p, const double *l, double *w)
{
    int a;
    for (a = 0; a < 3; a++)
        w[a] = p->R[3 * a] * l[0] + p->R[3 * a + 1] * l[1] + p->R[3 * a + 2] * l[2] + p->t[a];
}

static void local_support(const locd_shape *s, long tri, const double *d, double *out)
{
    size_t i, best = 0;
    double n, bestv;
    switch (tri >= 0 ? LOCD_SHAPE_MESH : s->kind) {
    case LOCD_SHAPE_SPHERE:
    case LOCD_SHAPE_CAPSULE:
        n = sqrt(dot3(d, d));
        if (n > 0.0) {
            out[0] = s->radius * d[0] / n;
            out[1] = s->radius * d[1] / n;
            out[2] = s->radius * d[2] / n;
        } else {
            out[0] = s->radius;
            out[1] = out[2] = 0.0;
        }
        if (s->kind == LOCD_SHAPE_CAPSULE)
            out[2] += d[2] >= 0.0 ? s->half[2] : -s->half[2];
        return;
    case LOCD_SHAPE_BOX:
        out[0] = d[0] >= 0.0 ? s->half[0] : -s->half[0];
        out[1] = d[1] >= 0.0 ? s->half[1] : -s->half[1];
        out[2] = d[2] >= 0.0 ? s->half[2] : -s->half[2];
        return;
    case LOCD_SHAPE_MESH: {
        const uint32_t *t = s->tris + 3 * tri;
        int k, bk = 0;
        bestv = -INFINITY;
        for (k = 0; k < 3; k++) {
            double v = dot3(s->points + 3 * t[k], d);
            if (v > bestv) {
                bestv = v;
                bk = k;
            }
        }
        memcpy(out, s->points + 3 * t[bk], 3 * sizeof(double));
        return;
    }
    default: /* convex hull: the farthest point (hulls here are small) */
        bestv = -INFINITY;
        for (i = 0; i < s->npoints; i++) {
            double v = dot3(s->points + 3 * i, d);
            if (v > bestv) {
                bestv = v;
                best = i;
            }
        }
        memcpy(out, s->points + 3 * best, 3 * sizeof(double));
        return;
    }
}

static void support(const void *obj, const ccd_vec3_t *dir, ccd_vec3_t *vec)
{
    const ccd_obj *o = obj;
    const lc_placed *p = o->p;
    double d[3] = {ccdVec3X(dir), ccdVec3Y(dir), ccdVec3Z(dir)}, dl[3], sl[3], w[3];
    int a;
    for (a = 0; a < 3; a++)
        dl[a] = p->R[a] * d[0] + p->R[3 + a] * d[1] + p->R[6 + a] * d[2]; /* R^T d */
    local_support(p->s, o->tri, dl, sl);
    to_world(p, sl, w);
    if (dot3(d, o->sweep) > 0.0)
        for (a = 0; a < 3; a++)
            w[a] += o->sweep[a];
    ccdVec3Set(vec, w[0], w[1], w[2]);
}

static void center(const void *obj, ccd_vec3_t *c)
{
    const ccd_obj *o = obj;
    const locd_shape *s = o->p->s;
    double l[3] = {0.0, 0.0, 0.0}, w[3];
    int a, k;
    if (o->tri >= 0) {
        for (k = 0; k < 3; k++)
            for (a = 0; a < 3; a++)
                l[a] += s->points[3 * s->tris[3 * o->tri + k] + a] / 3.0;
    } else if (s->kind == LOCD_SHAPE_CONVEX) {
        memcpy(l, s->centroid, sizeof l);
    }
    to_world(o->p, l, w);
    ccdVec3Set(c, w[0] + 0.5 * o->sweep[0], w[1] + 0.5 * o->sweep[1], w[2] + 0.5 * o->sweep[2]);
}

/* Tolerances scale with the shapes: 1e-9 of their size. (libccd's EPA
 * has no iteration limit and converges slowly on curved surfaces: the
 * default routes send spheres and capsules to closed forms or FCL.) */
static void ccd_setup(ccd_t *ccd, const lc_placed *a, const lc_placed *b)
{
    double scale = fmax(a->s->bound_radius, b->s->bound_radius);
    CCD_INIT(ccd);
    ccd->support1 = support;
    ccd->support2 = support;
    ccd->center1 = center;
    ccd->center2 = center;
    ccd->max_iterations = 1000;
    ccd->epa_tolerance = 1e-9 * scale;
    ccd->mpr_tolerance = 1e-9 * scale;
    ccd->dist_tolerance = 1e-9 * scale;
}

/* libccd's direction already points from obj1 toward obj2 (moving obj2 by
 * depth * dir separates them): the tests check it against the closed forms. */
/* Translation of obj2 along unit dir that separates it from obj1:
 * max over obj1 of x.dir minus min over obj2 of x.dir. */
static double overlap_along(const ccd_obj *o1, const ccd_obj *o2, const ccd_vec3_t *dir)
{
    ccd_vec3_t neg, s1, s2;
    ccdVec3Copy(&neg, dir);
    ccdVec3Scale(&neg, CCD_REAL(-1.0));
    support(o1, dir, &s1);
    support(o2, &neg, &s2);
    return ccdVec3Dot(&s1, dir) - ccdVec3Dot(&s2, dir);
}

/* The local normal of the plane through three well-spread points of o (a
 * mesh triangle, or a hull's points): for a flat shape, its own normal. 1,
 * or 0 when the points are collinear. */
static int plane_normal(const ccd_obj *o, double *n)
{
    const locd_shape *s = o->p->s;
    const double *p0, *p1 = NULL, *p2 = NULL;
    double e1[3], best = 0.0, len;
    size_t i, count = o->tri >= 0 ? 3 : s->npoints;
    int a;
#define LC_PT(k) (o->tri >= 0 ? s->points + 3 * s->tris[3 * o->tri + (k)] : s->points + 3 * (k))
    if (count < 3 || (s->kind != LOCD_SHAPE_CONVEX && o->tri < 0))
        return 0;
    p0 = LC_PT(0);
    for (i = 1; i < count; i++) {
        double d[3], q;
        for (a = 0; a < 3; a++)
            d[a] = LC_PT(i)[a] - p0[a];
        if ((q = dot3(d, d)) > best) {
            best = q;
            p1 = LC_PT(i);
        }
    }
    if (!p1)
        return 0;
    for (a = 0; a < 3; a++)
        e1[a] = p1[a] - p0[a];
    best = 0.0;
    for (i = 1; i < count; i++) {
        double d[3], x[3], q;
        for (a = 0; a < 3; a++)
            d[a] = LC_PT(i)[a] - p0[a];
        x[0] = e1[1] * d[2] - e1[2] * d[1];
        x[1] = e1[2] * d[0] - e1[0] * d[2];
        x[2] = e1[0] * d[1] - e1[1] * d[0];
        if ((q = dot3(x, x)) > best) {
            best = q;
            p2 = LC_PT(i);
            memcpy(n, x, sizeof x);
        }
    }
#undef LC_PT
    if (!p2 || !((len = sqrt(best)) > 0.0))
        return 0;
    for (a = 0; a < 3; a++)
        n[a] /= len;
    return 1;
}

static int finite_unit(const ccd_vec3_t *v)
{
    double l = ccdVec3X(v) * ccdVec3X(v) + ccdVec3Y(v) * ccdVec3Y(v) + ccdVec3Z(v) * ccdVec3Z(v);
    return isfinite(l) && fabs(l - 1.0) < 1e-6;
}

/* libccd's EPA has no face to report when the shapes' Minkowski difference
 * is flat (two coplanar flat hulls: its normal comes out NaN). Then the
 * normal is the candidate direction along which the overlap is least: the
 * planes of both shapes (either sign), the world axes and the centre line.
 * A finite unit normal and its exact overlap, always. */
static double least_overlap_direction(const ccd_obj *oa, const ccd_obj *ob, const ccd_t *ccd, ccd_vec3_t *dir)
{
    double cand[10][3], best = INFINITY;
    int k, m = 0, a;
    ccd_vec3_t ca, cb;
    for (a = 0; a < 3; a++) {
        memset(cand[m], 0, sizeof cand[m]);
        cand[m++][a] = 1.0;
    }
    for (k = 0; k < 2; k++) {
        double n[3];
        const ccd_obj *o = k ? ob : oa;
        if (plane_normal(o, n)) {
            for (a = 0; a < 3; a++)
                cand[m][a] = o->p->R[3 * a] * n[0] + o->p->R[3 * a + 1] * n[1] + o->p->R[3 * a + 2] * n[2];
            m++;
        }
    }
    ccd->center1(oa, &ca);
    ccd->center2(ob, &cb);
    cand[m][0] = ccdVec3X(&cb) - ccdVec3X(&ca);
    cand[m][1] = ccdVec3Y(&cb) - ccdVec3Y(&ca);
    cand[m][2] = ccdVec3Z(&cb) - ccdVec3Z(&ca);
    if (dot3(cand[m], cand[m]) > 0.0 && isfinite(dot3(cand[m], cand[m]))) {
        double l = sqrt(dot3(cand[m], cand[m]));
        for (a = 0; a < 3; a++)
            cand[m][a] /= l;
        m++;
    }
    ccdVec3Set(dir, 0.0, 0.0, 1.0);
    for (k = 0; k < 2 * m; k++) {
        double sgn = k % 2 ? -1.0 : 1.0, v;
        ccd_vec3_t d;
        ccdVec3Set(&d, sgn * cand[k / 2][0], sgn * cand[k / 2][1], sgn * cand[k / 2][2]);
        v = overlap_along(oa, ob, &d);
        if (isfinite(v) && v < best) {
            best = v;
            *dir = d;
        }
    }
    return isfinite(best) ? best : 0.0;
}

static int ccd_pair(const ccd_obj *oa, const ccd_obj *ob, const ccd_t *ccd, int want_contact, int32_t method,
                    lc_contact *c)
{
    ccd_real_t depth;
    ccd_vec3_t dir, pos;
    int r;
    if (!want_contact)
        return ccdGJKIntersect(oa, ob, ccd) ? 1 : 0;
    if (method == LOCD_CONTACT_MPR)
        r = ccdMPRPenetration(oa, ob, ccd, &depth, &dir, &pos);
    else
        r = ccdGJKPenetration(oa, ob, ccd, &depth, &dir, &pos);
    if (r != 0)
        return 0;
    /* libccd's EPA can stop on a face that is not the closest one in deep
     * penetration: measure the overlap along its normal exactly with the
     * support functions (so pushing by depth always separates), and try MPR's
     * direction when EPA's turns out longer than EPA claimed. */
    {
        double v = overlap_along(oa, ob, &dir);
        if (method != LOCD_CONTACT_MPR && v > depth + ccd->epa_tolerance * 10.0 + ccd->dist_tolerance) {
            ccd_real_t d2;
            ccd_vec3_t dir2, pos2;
            if (ccdMPRPenetration(oa, ob, ccd, &d2, &dir2, &pos2) == 0) {
                double v2 = overlap_along(oa, ob, &dir2);
                if (v2 < v) {
                    v = v2;
                    dir = dir2;
                    pos = pos2;
                }
            }
        }
        if (!finite_unit(&dir)) /* a flat Minkowski difference: no face, no normal */
            v = least_overlap_direction(oa, ob, ccd, &dir);
        depth = v > 0.0 ? v : 0.0;
    }
    if (!isfinite(ccdVec3X(&pos)) || !isfinite(ccdVec3Y(&pos)) || !isfinite(ccdVec3Z(&pos))) {
        ccd_vec3_t ca, cb;
        ccd->center1(oa, &ca);
        ccd->center2(ob, &cb);
        ccdVec3Set(&pos, 0.5 * (ccdVec3X(&ca) + ccdVec3X(&cb)), 0.5 * (ccdVec3Y(&ca) + ccdVec3Y(&cb)),
                   0.5 * (ccdVec3Z(&ca) + ccdVec3Z(&cb)));
    }
    c->depth = depth;
    c->normal[0] = ccdVec3X(&dir);
    c->normal[1] = ccdVec3Y(&dir);
    c->normal[2] = ccdVec3Z(&dir);
    c->point[0] = ccdVec3X(&pos);
    c->point[1] = ccdVec3Y(&pos);
    c->point[2] = ccdVec3Z(&pos);
    return 1;
}

/* The box, in the mesh's local frame, of everything `o` covers (its bounding
 * sphere, swept by `sweep`). */
static void local_query_box(const lc_placed *mesh, const lc_placed *o, const double *sweep, double *box)
{
    double d[3], c0[3], c1[3], r = o->s->bound_radius;
    int a;
    for (a = 0; a < 3; a++)
        d[a] = o->t[a] - mesh->t[a];
    for (a = 0; a < 3; a++) {
        c0[a] = mesh->R[a] * d[0] + mesh->R[3 + a] * d[1] + mesh->R[6 + a] * d[2];
        c1[a] = c0[a] + mesh->R[a] * sweep[0] + mesh->R[3 + a] * sweep[1] + mesh->R[6 + a] * sweep[2];
    }
    for (a = 0; a < 3; a++) {
        box[a] = fmin(c0[a], c1[a]) - r;
        box[3 + a] = fmax(c0[a], c1[a]) + r;
    }
}

static int boxes_meet(const double *a, const double *b)
{
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

/* Mesh `m` (first) against convex `o` (second), one triangle at a time; the
 * deepest contact wins. */
static int mesh_vs_convex(const lc_placed *m, const lc_placed *o, const ccd_t *ccd, int want_contact, int32_t method,
                          lc_contact *c)
{
    static const double zero[3] = {0.0, 0.0, 0.0};
    ccd_obj om = {m, 0, {0.0, 0.0, 0.0}}, oo = {o, -1, {0.0, 0.0, 0.0}};
    double q[6];
    size_t i;
    int hit = 0;
    local_query_box(m, o, zero, q);
    for (i = 0; i < m->s->ntris; i++) {
        lc_contact ci;
        if (!boxes_meet(q, m->s->tri_boxes + 6 * i))
            continue;
        om.tri = (long)i;
        if (!ccd_pair(&om, &oo, ccd, want_contact, method, &ci))
            continue;
        if (!want_contact)
            return 1;
        if (!hit || ci.depth > c->depth)
            *c = ci;
        hit = 1;
    }
    return hit;
}

static void flip(lc_contact *c)
{
    c->normal[0] = -c->normal[0];
    c->normal[1] = -c->normal[1];
    c->normal[2] = -c->normal[2];
}

int lc_ccd_test(const lc_placed *a, const lc_placed *b, int want_contact, int32_t method, lc_contact *c)
{
    ccd_t ccd;
    ccd_setup(&ccd, a, b);
    if (a->s->kind == LOCD_SHAPE_MESH && b->s->kind == LOCD_SHAPE_MESH) /* the router sends those to FCL */
        return lc_error(LOCD_ERR_INTERNAL, "libccd route got a mesh pair");
    if (a->s->kind == LOCD_SHAPE_MESH)
        return mesh_vs_convex(a, b, &ccd, want_contact, method, c);
    if (b->s->kind == LOCD_SHAPE_MESH) {
        int hit = mesh_vs_convex(b, a, &ccd, want_contact, method, c);
        if (hit == 1 && want_contact)
            flip(c);
        return hit;
    }
    {
        ccd_obj oa = {a, -1, {0.0, 0.0, 0.0}}, ob = {b, -1, {0.0, 0.0, 0.0}};
        return ccd_pair(&oa, &ob, &ccd, want_contact, method, c);
    }
}

/* Smallest s in [0, 1] at which `moving` (swept by s * d) meets `fixed`;
 * bisection to 2^-40 of the step: the returned time is on the meeting side. */
static int sweep_pair(ccd_obj *fixed, ccd_obj *moving, const double *d, const ccd_t *ccd, double *toi)
{
    double lo = 0.0, hi = 1.0;
    int it, a;
    for (a = 0; a < 3; a++)
        moving->sweep[a] = d[a];
    if (!ccdGJKIntersect(fixed, moving, ccd))
        return 0;
    for (a = 0; a < 3; a++)
        moving->sweep[a] = 0.0;
    if (ccdGJKIntersect(fixed, moving, ccd)) {
        *toi = 0.0;
        return 1;
    }
    for (it = 0; it < 40; it++) {
        double mid = 0.5 * (lo + hi);
        for (a = 0; a < 3; a++)
            moving->sweep[a] = mid * d[a];
        if (ccdGJKIntersect(fixed, moving, ccd))
            hi = mid;
        else
            lo = mid;
    }
    *toi = hi;
    return 1;
}

static int mesh_sweep(const lc_placed *m, const lc_placed *o, const double *d, const ccd_t *ccd, double *toi)
{
    ccd_obj om = {m, 0, {0.0, 0.0, 0.0}}, oo = {o, -1, {0.0, 0.0, 0.0}};
    double q[6], best = INFINITY;
    size_t i;
    local_query_box(m, o, d, q);
    for (i = 0; i < m->s->ntris; i++) {
        double t;
        if (!boxes_meet(q, m->s->tri_boxes + 6 * i))
            continue;
        om.tri = (long)i;
        if (sweep_pair(&om, &oo, d, ccd, &t) && t < best)
            best = t;
    }
    if (best == INFINITY)
        return 0;
    *toi = best;
    return 1;
}

int lc_ccd_sweep(const lc_placed *a, const lc_placed *b, const double *d, double *toi)
{
    ccd_t ccd;
    double nd[3] = {-d[0], -d[1], -d[2]};
    ccd_setup(&ccd, a, b);
    if (a->s->kind == LOCD_SHAPE_MESH && b->s->kind == LOCD_SHAPE_MESH)
        return lc_error(LOCD_ERR_INTERNAL, "libccd route got a mesh pair");
    if (a->s->kind == LOCD_SHAPE_MESH)
        return mesh_sweep(a, b, d, &ccd, toi);
    if (b->s->kind == LOCD_SHAPE_MESH)
        return mesh_sweep(b, a, nd, &ccd, toi); /* a moves by -d relative to b */
    {
        ccd_obj oa = {a, -1, {0.0, 0.0, 0.0}}, ob = {b, -1, {0.0, 0.0, 0.0}};
        return sweep_pair(&oa, &ob, d, &ccd, toi);
    }
}
