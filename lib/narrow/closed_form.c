/* Closed-form tests: sphere-sphere, sphere-box and box-box (separating axis
 * theorem, Ericson's "Real-Time Collision Detection" 4.4.1). They are the
 * references the libccd and FCL paths are tested against. Touching counts as
 * a hit (closed sets, like the box test of the broad phase). */
#include "narrow/narrow.h"

#include <math.h>
#include <string.h>

static double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Column k of R: the shape's local axis k in world coordinates. */
static void axis_of(const double *R, int k, double *out)
{
    out[0] = R[k];
    out[1] = R[3 + k];
    out[2] = R[6 + k];
}

int lc_closed_supported(int32_t ka, int32_t kb)
{
    int sa = ka == LOCD_SHAPE_SPHERE || ka == LOCD_SHAPE_BOX;
    int sb = kb == LOCD_SHAPE_SPHERE || kb == LOCD_SHAPE_BOX;
    return sa && sb;
}

static int sphere_sphere(const lc_placed *a, const lc_placed *b, lc_contact *c)
{
    double d[3] = {b->t[0] - a->t[0], b->t[1] - a->t[1], b->t[2] - a->t[2]};
    double r = a->s->radius + b->s->radius, dist2 = dot3(d, d), dist;
    int k;
    if (dist2 > r * r)
        return 0;
    if (!c)
        return 1;
    dist = sqrt(dist2);
    c->depth = r - dist;
    if (dist > 0.0)
        for (k = 0; k < 3; k++)
            c->normal[k] = d[k] / dist;
    else {
        c->normal[0] = c->normal[1] = 0.0;
        c->normal[2] = 1.0;
    }
    /* Midway between the two surfaces along the normal. */
    for (k = 0; k < 3; k++)
        c->point[k] = a->t[k] + c->normal[k] * (a->s->radius - 0.5 * c->depth);
    return 1;
}

/* Sphere s against box b; the normal points from the sphere to the box. */
static int sphere_box(const lc_placed *s, const lc_placed *b, lc_contact *c)
{
    const double *h = b->s->half;
    double d[3] = {s->t[0] - b->t[0], s->t[1] - b->t[1], s->t[2] - b->t[2]};
    double p[3], q[3], e[3], dist2 = 0.0, r = s->s->radius;
    int k, inside = 1;
    for (k = 0; k < 3; k++) {
        double ax[3];
        axis_of(b->R, k, ax);
        p[k] = dot3(d, ax); /* sphere centre in box coordinates */
        q[k] = p[k] < -h[k] ? -h[k] : (p[k] > h[k] ? h[k] : p[k]);
        if (q[k] != p[k])
            inside = 0;
        e[k] = p[k] - q[k];
        dist2 += e[k] * e[k];
    }
    if (dist2 > r * r)
        return 0;
    if (!c)
        return 1;
    if (!inside) {
        double dist = sqrt(dist2), nl[3];
        for (k = 0; k < 3; k++)
            nl[k] = -e[k] / dist; /* box-local, sphere toward box */
        c->depth = r - dist;
        for (k = 0; k < 3; k++)
            c->normal[k] = b->R[3 * k] * nl[0] + b->R[3 * k + 1] * nl[1] + b->R[3 * k + 2] * nl[2];
    } else {
        /* Centre inside: leave through the nearest face. */
        int best = 0;
        double gap = INFINITY, nl[3] = {0.0, 0.0, 0.0};
        for (k = 0; k < 3; k++)
            if (h[k] - fabs(p[k]) < gap) {
                gap = h[k] - fabs(p[k]);
                best = k;
            }
        nl[best] = p[best] >= 0.0 ? -1.0 : 1.0;
        c->depth = r + gap;
        for (k = 0; k < 3; k++)
            c->normal[k] = b->R[3 * k] * nl[0] + b->R[3 * k + 1] * nl[1] + b->R[3 * k + 2] * nl[2];
    }
    for (k = 0; k < 3; k++)
        c->point[k] = s->t[k] + c->normal[k] * (r - 0.5 * c->depth);
    return 1;
}

/* Deepest point of box p in direction n (world). */
static void box_support(const lc_placed *p, const double *n, double *out)
{
    int k, a;
    memcpy(out, p->t, 3 * sizeof(double));
    for (k = 0; k < 3; k++) {
        double ax[3], sgn;
        axis_of(p->R, k, ax);
        sgn = dot3(ax, n) >= 0.0 ? 1.0 : -1.0;
        for (a = 0; a < 3; a++)
            out[a] += sgn * p->s->half[k] * ax[a];
    }
}

/* Box-box by the 15 separating axes. The least overlap over all axes is the
 * penetration depth of two boxes (their Minkowski difference has no other
 * face directions), so depth and normal are exact; the point is midway
 * between the two boxes' deepest points along the normal. */
static int box_box(const lc_placed *a, const lc_placed *b, lc_contact *c)
{
    double A[3][3], B[3][3], T[3], L[15][3];
    int nl = 0, i, j, k, best = -1;
    double best_overlap = INFINITY;
    for (k = 0; k < 3; k++) {
        axis_of(a->R, k, A[k]);
        axis_of(b->R, k, B[k]);
        T[k] = b->t[k] - a->t[k];
    }
    for (i = 0; i < 3; i++) {
        memcpy(L[nl++], A[i], sizeof A[i]);
        memcpy(L[nl++], B[i], sizeof B[i]);
    }
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            double *l = L[nl];
            l[0] = A[i][1] * B[j][2] - A[i][2] * B[j][1];
            l[1] = A[i][2] * B[j][0] - A[i][0] * B[j][2];
            l[2] = A[i][0] * B[j][1] - A[i][1] * B[j][0];
            /* Parallel edges give no new axis: the face axes cover them. */
            if (dot3(l, l) > 1e-12)
                nl++;
        }
    for (i = 0; i < nl; i++) {
        double len = sqrt(dot3(L[i], L[i])), ra = 0.0, rb = 0.0, dist, overlap;
        for (k = 0; k < 3; k++) {
            ra += a->s->half[k] * fabs(dot3(A[k], L[i]));
            rb += b->s->half[k] * fabs(dot3(B[k], L[i]));
        }
        dist = fabs(dot3(T, L[i]));
        if (dist > ra + rb)
            return 0;
        overlap = (ra + rb - dist) / len;
        if (overlap < best_overlap) {
            best_overlap = overlap;
            best = i;
        }
    }
    if (!c)
        return 1;
    {
        double len = sqrt(dot3(L[best], L[best])), sa[3], sb[3], neg[3];
        for (k = 0; k < 3; k++)
            c->normal[k] = L[best][k] / len;
        if (dot3(c->normal, T) < 0.0)
            for (k = 0; k < 3; k++)
                c->normal[k] = -c->normal[k];
        c->depth = best_overlap;
        for (k = 0; k < 3; k++)
            neg[k] = -c->normal[k];
        box_support(a, c->normal, sa);
        box_support(b, neg, sb);
        for (k = 0; k < 3; k++)
            c->point[k] = 0.5 * (sa[k] + sb[k]);
    }
    return 1;
}

int lc_closed_test(const lc_placed *a, const lc_placed *b, lc_contact *c)
{
    int32_t ka = a->s->kind, kb = b->s->kind;
    if (ka == LOCD_SHAPE_SPHERE && kb == LOCD_SHAPE_SPHERE)
        return sphere_sphere(a, b, c);
    if (ka == LOCD_SHAPE_BOX && kb == LOCD_SHAPE_BOX)
        return box_box(a, b, c);
    if (ka == LOCD_SHAPE_SPHERE)
        return sphere_box(a, b, c);
    {
        int hit = sphere_box(b, a, c);
        if (hit && c) {
            int k;
            for (k = 0; k < 3; k++)
                c->normal[k] = -c->normal[k];
        }
        return hit;
    }
}

int lc_closed_sweep_spheres(const lc_placed *a, const lc_placed *b, const double *d, double *toi)
{
    /* |p + t d| = r for the smallest t in [0, 1]. */
    double p[3] = {b->t[0] - a->t[0], b->t[1] - a->t[1], b->t[2] - a->t[2]};
    double r = a->s->radius + b->s->radius;
    double qa = dot3(d, d), qb = 2.0 * dot3(p, d), qc = dot3(p, p) - r * r, disc, t;
    if (qc <= 0.0) {
        *toi = 0.0;
        return 1;
    }
    if (qa <= 0.0 || qb >= 0.0)
        return 0; /* not moving, or moving apart */
    disc = qb * qb - 4.0 * qa * qc;
    if (disc < 0.0)
        return 0;
    t = (-qb - sqrt(disc)) / (2.0 * qa);
    if (t > 1.0)
        return 0;
    *toi = t < 0.0 ? 0.0 : t;
    return 1;
}
