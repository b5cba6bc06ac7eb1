/* Routing: which test (closed form, libccd, FCL) a pair of shape kinds
 * goes through, and the single-pair entry point of the public API. */
#include "core/core.h"
#include "narrow/narrow.h"

#include <math.h>

int32_t lc_route_resolve(int32_t route, int32_t ka, int32_t kb)
{
    int hull = ka == LOCD_SHAPE_CONVEX || kb == LOCD_SHAPE_CONVEX;
    int two_meshes = ka == LOCD_SHAPE_MESH && kb == LOCD_SHAPE_MESH;
    switch (route) {
    case LOCD_ROUTE_BOX:
        return LOCD_ROUTE_BOX;
    case LOCD_ROUTE_CLOSED:
        if (lc_closed_supported(ka, kb))
            return LOCD_ROUTE_CLOSED;
        break; /* no closed form: the default below */
    case LOCD_ROUTE_FCL:
        return hull ? LOCD_ROUTE_CCD : LOCD_ROUTE_FCL; /* FCL wants hull faces we do not have */
    case LOCD_ROUTE_CCD:
        return two_meshes ? LOCD_ROUTE_FCL : LOCD_ROUTE_CCD; /* triangle x triangle is FCL's job */
    default:
        break;
    }
    if (lc_closed_supported(ka, kb))
        return LOCD_ROUTE_CLOSED;
    /* Meshes and capsules without a hull: FCL has dedicated tests for them
     * (and libccd's EPA is slow on curved surfaces). Hulls: libccd. */
    if (!hull)
        return LOCD_ROUTE_FCL;
    return LOCD_ROUTE_CCD;
}

int lc_pair_test(const lc_placed *a, const lc_placed *b, int32_t route, int want_contact, int32_t method,
                 lc_contact *c, uint64_t *counts)
{
    lc_contact scratch;
    int r;
    if (!c)
        c = &scratch;
    route = lc_route_resolve(route, a->s->kind, b->s->kind);
    if (route == LOCD_ROUTE_BOX)
        return 1;
    if (route == LOCD_ROUTE_CLOSED) {
        if (counts)
            counts[0]++;
        return lc_closed_test(a, b, want_contact ? c : NULL);
    }
    if (route == LOCD_ROUTE_FCL) {
        char err[160] = "";
        if (counts)
            counts[2]++;
        r = lc_fcl_test(a, b, want_contact, c, err, sizeof err);
        if (r < 0)
            return lc_error(LOCD_ERR_INTERNAL, "FCL: %s", err);
        return r;
    }
    if (counts)
        counts[1]++;
    return lc_ccd_test(a, b, want_contact, method, c);
}

int lc_pair_sweep(const lc_placed *a, const lc_placed *b, const double *d, int32_t route, double *toi,
                  uint64_t *counts)
{
    int32_t ka = a->s->kind, kb = b->s->kind;
    route = lc_route_resolve(route, ka, kb);
    if (route == LOCD_ROUTE_BOX) {
        *toi = 0.0;
        return 1;
    }
    if (ka == LOCD_SHAPE_SPHERE && kb == LOCD_SHAPE_SPHERE && route == LOCD_ROUTE_CLOSED) {
        if (counts)
            counts[0]++;
        return lc_closed_sweep_spheres(a, b, d, toi);
    }
    if (ka == LOCD_SHAPE_MESH && kb == LOCD_SHAPE_MESH) {
        /* No swept mesh-mesh test: FCL at the start and at the end of the step. */
        lc_placed b1 = *b;
        int r;
        if (counts)
            counts[2] += 2;
        r = lc_fcl_test(a, b, 0, NULL, NULL, 0);
        if (r != 0) {
            *toi = 0.0;
            return r < 0 ? lc_error(LOCD_ERR_INTERNAL, "FCL failed on a mesh pair") : 1;
        }
        b1.t[0] += d[0];
        b1.t[1] += d[1];
        b1.t[2] += d[2];
        r = lc_fcl_test(a, &b1, 0, NULL, NULL, 0);
        *toi = 1.0;
        return r < 0 ? lc_error(LOCD_ERR_INTERNAL, "FCL failed on a mesh pair") : r;
    }
    if (counts)
        counts[1]++;
    return lc_ccd_sweep(a, b, d, toi);
}

locd_status locd_shape_collide(const locd_shape *a, const double *pose_a, const locd_shape *b, const double *pose_b,
                               int32_t route, int32_t contact_method, int32_t *hit, double *contact)
{
    double Ra[9], ta[3], Rb[9], tb[3];
    lc_placed pa, pb;
    lc_contact c;
    locd_status st;
    int r;
    if ((st = lc_shape_check(a)) != LOCD_OK || (st = lc_shape_check(b)) != LOCD_OK)
        return st;
    if (!pose_a || !pose_b || !hit)
        return lc_error(LOCD_ERR_NULL_POINTER, "pose or hit is NULL");
    if (route < LOCD_ROUTE_AUTO || route > LOCD_ROUTE_FCL)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "unknown route %d", (int)route);
    if (contact_method != LOCD_CONTACT_EPA && contact_method != LOCD_CONTACT_MPR)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "unknown contact method %d", (int)contact_method);
    if (!lc_pose_to_rt(pose_a, Ra, ta))
        return lc_error_box(LOCD_ERR_SHAPE, 0, "pose of the first shape is non-finite or has a zero quaternion");
    if (!lc_pose_to_rt(pose_b, Rb, tb))
        return lc_error_box(LOCD_ERR_SHAPE, 1, "pose of the second shape is non-finite or has a zero quaternion");
    lc_place(a, Ra, ta, &pa);
    lc_place(b, Rb, tb, &pb);
    if (contact && lc_route_resolve(route, a->kind, b->kind) == LOCD_ROUTE_BOX)
        route = LOCD_ROUTE_AUTO; /* contact data needs a real test */
    r = lc_pair_test(&pa, &pb, route, contact != NULL, contact_method, &c, NULL);
    if (r < 0)
        return r;
    *hit = r;
    if (r && contact) {
        contact[0] = c.depth;
        memcpy(contact + 1, c.normal, 3 * sizeof(double));
        memcpy(contact + 4, c.point, 3 * sizeof(double));
    }
    lc_clear_error();
    return LOCD_OK;
}
