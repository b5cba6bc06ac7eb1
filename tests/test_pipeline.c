/* The filter pipeline: libccd and FCL paths against the closed forms on
 * random poses, near-touching stability, tunnelling caught by the swept
 * stage, stage skipping seen in the statistics, bad shapes rejected, and the
 * pipeline's result against an O(n^2) loop over the single-pair test. In a
 * build without the narrow phase, checks that every call says so. */
#include <locd/pipeline.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "support.h"

/* Contact data must agree with the closed forms to this relative margin;
 * yes/no answers must agree whenever the answer does not change under a
 * displacement of TOUCH_TOL times the shapes' size (the stated tolerance:
 * docs/pipeline.md). */
#define DEPTH_TOL 2e-3
#define TOUCH_TOL 1e-6

static int narrow_built(void)
{
    locd_shape *s = NULL;
    locd_status st = locd_shape_sphere(1.0, &s);
    locd_shape_destroy(s);
    return st == LOCD_OK;
}

static void random_quat(ts_rng *r, double *q)
{
    double n;
    int k;
    do {
        n = 0.0;
        for (k = 0; k < 4; k++) {
            q[k] = 2.0 * ts_uniform(r) - 1.0;
            n += q[k] * q[k];
        }
    } while (n < 1e-3 || n > 1.0);
    for (k = 0; k < 4; k++)
        q[k] /= sqrt(n);
}

static void random_pose(ts_rng *r, double spread, double *pose)
{
    int k;
    for (k = 0; k < 3; k++)
        pose[k] = spread * (2.0 * ts_uniform(r) - 1.0);
    random_quat(r, pose + 3);
}

static int32_t test_hit(const locd_shape *a, const double *pa, const locd_shape *b, const double *pb, int32_t route)
{
    int32_t hit = -1;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_collide(a, pa, b, pb, route, LOCD_CONTACT_EPA, &hit, NULL));
    return hit;
}

/* 1 when the closed-form answer is the same for b moved by +-eps on each axis. */
static int robust(const locd_shape *a, const double *pa, const locd_shape *b, const double *pb, double eps)
{
    int32_t h0 = test_hit(a, pa, b, pb, LOCD_ROUTE_CLOSED);
    int axis, sgn;
    for (axis = 0; axis < 3; axis++)
        for (sgn = -1; sgn <= 1; sgn += 2) {
            double q[7];
            memcpy(q, pb, sizeof q);
            q[axis] += sgn * eps;
            if (test_hit(a, pa, b, q, LOCD_ROUTE_CLOSED) != h0)
                return 0;
        }
    return 1;
}

/* A contact (depth, normal) is right when pushing b by a little more than
 * depth along the normal separates the shapes (closed form) and depth is not
 * less than the true penetration (which the closed form gives). */
static int check_contact(const locd_shape *a, const double *pa, const locd_shape *b, const double *pb,
                          const double *c, const double *ref, double size, const char *what)
{
    double q[7];
    int k;
    memcpy(q, pb, sizeof q);
    for (k = 0; k < 3; k++)
        q[k] += c[1 + k] * (c[0] * (1.0 + DEPTH_TOL) + 10.0 * TOUCH_TOL * size);
    if (test_hit(a, pa, b, q, LOCD_ROUTE_CLOSED))
        LT_FAIL("%s: pushing by depth along normal (%g %g %g) does not separate", what, c[1], c[2], c[3]);
    if (c[0] < ref[0] * (1.0 - DEPTH_TOL) - TOUCH_TOL * size)
        LT_FAIL("%s: depth %.9g below the true penetration %.9g", what, c[0], ref[0]);
    /* A valid contact that is not the least one: counted by the caller. */
    return c[0] > ref[0] * (1.0 + DEPTH_TOL) + TOUCH_TOL * size;
}

/* sphere-sphere, sphere-box, box-box on random poses: libccd and FCL give
 * the closed form's yes/no answer and a valid contact. */
static void general_paths_match_closed_forms(void)
{
    ts_rng r;
    int iter, compared = 0, hits = 0, epa_long[4] = {0, 0, 0, 0}, epa_total[4] = {0, 0, 0, 0};
    ts_seed(&r, 9001);
    for (iter = 0; iter < 3000; iter++) {
        locd_shape *a, *b;
        double pa[7], pb[7], size;
        int kinds = iter % 3, route;
        double ra = 0.2 + ts_uniform(&r), rb = 0.2 + ts_uniform(&r);
        if (kinds == 0) {
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_sphere(ra, &a));
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_sphere(rb, &b));
        } else if (kinds == 1) {
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_sphere(ra, &a));
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_box(rb, 0.2 + ts_uniform(&r), 0.3 * rb + 0.1, &b));
        } else {
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_box(ra, 0.2 + ts_uniform(&r), 0.5, &a));
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_box(rb, 0.7, 0.2 + 0.5 * ts_uniform(&r), &b));
        }
        size = ra + rb;
        random_pose(&r, 1.0, pa);
        random_pose(&r, 1.0, pb);
        pb[0] = pa[0] + 1.6 * size * (ts_uniform(&r) - 0.5);
        if (!robust(a, pa, b, pb, TOUCH_TOL * size)) {
            locd_shape_destroy(a);
            locd_shape_destroy(b);
            continue;
        }
        compared++;
        {
            int32_t want = test_hit(a, pa, b, pb, LOCD_ROUTE_CLOSED);
            double ref[7];
            int32_t h;
            hits += want;
            if (want)
                TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_collide(a, pa, b, pb, LOCD_ROUTE_CLOSED, 0, &h, ref));
            for (route = LOCD_ROUTE_CCD; route <= LOCD_ROUTE_FCL; route++) {
                int method;
                if (test_hit(a, pa, b, pb, route) != want)
                    LT_FAIL("iter %d kinds %d route %d: yes/no differs from the closed form (%d)", iter, kinds, route,
                            want);
                for (method = 0; method < (route == LOCD_ROUTE_CCD ? 2 : 1) && want; method++) {
                    double c[7];
                    char what[64];
                    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_collide(a, pa, b, pb, route, method, &h, c));
                    TEST_ASSERT_EQUAL_INT64(1, h);
                    snprintf(what, sizeof what, "iter %d kinds %d route %d method %d", iter, kinds, route, method);
                    /* MPR's depth is along the centre line: exact only for spheres. */
                    if (method == LOCD_CONTACT_MPR && kinds != 0)
                        continue;
                    if (check_contact(a, pa, b, pb, c, ref, size, what)) {
                        /* Only the general paths on polytopes may miss the least depth. */
                        if (kinds == 0)
                            LT_FAIL("%s: depth %.9g above the closed form's %.9g", what, c[0], ref[0]);
                        epa_long[route - LOCD_ROUTE_CCD + (ref[0] > 0.1 * size ? 2 : 0)]++;
                    }
                    if (kinds != 0)
                        epa_total[route - LOCD_ROUTE_CCD + (ref[0] > 0.1 * size ? 2 : 0)]++;
                }
            }
        }
        locd_shape_destroy(a);
        locd_shape_destroy(b);
    }
    TEST_ASSERT_TRUE(compared > 2500);
    TEST_ASSERT_TRUE(hits > 500 && hits < compared - 500);
    /* Stated in docs/pipeline.md: contacts of polytopes by libccd's EPA or by
     * FCL are never shorter than the least penetration and always separate;
     * they may be longer, rarely when shallow (depth < 10% of the size), more
     * often in deep overlaps. The closed forms are the default for boxes. */
    printf("# boxes, shallow: libccd %d of %d, FCL %d of %d contacts longer than the least penetration\n",
           epa_long[0], epa_total[0], epa_long[1], epa_total[1]);
    printf("# boxes, deep: libccd %d of %d, FCL %d of %d\n", epa_long[2], epa_total[2], epa_long[3], epa_total[3]);
    if (epa_long[0] * 100 > 2 * epa_total[0] || epa_long[1] * 100 > 2 * epa_total[1])
        LT_FAIL("general paths too often non-minimal on shallow contacts");
    if (epa_long[2] * 100 > 15 * epa_total[2] || epa_long[3] * 100 > 15 * epa_total[3])
        LT_FAIL("general paths too often non-minimal on deep contacts");
}

/* Capsules, hulls and meshes have no closed form of their own: built to
 * equal a sphere or a box, they must answer like one. */
static void other_shapes_match_their_equivalents(void)
{
    static const uint32_t box_tris[36] = {0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
                                          2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3};
    double corners[24];
    locd_shape *sphere, *cap0, *box, *hull, *mesh, *probe;
    ts_rng r;
    int i, k, compared = 0;
    for (i = 0; i < 8; i++)
        for (k = 0; k < 3; k++)
            corners[3 * i + k] = ((i >> (2 - k)) & 1) ? 0.6 : -0.6;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_sphere(0.5, &sphere));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_capsule(0.5, 0.0, &cap0));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_box(0.6, 0.6, 0.6, &box));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_convex(corners, 8, &hull));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_mesh(corners, 8, box_tris, 12, &mesh));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_sphere(0.3, &probe));
    ts_seed(&r, 77);
    for (i = 0; i < 2000; i++) {
        double pa[7], pb[7], d2 = 0.0;
        int32_t want_s, want_b;
        random_pose(&r, 0.1, pa);
        random_pose(&r, 1.5, pb);
        if (!robust(box, pa, probe, pb, TOUCH_TOL) || !robust(sphere, pa, probe, pb, TOUCH_TOL))
            continue;
        compared++;
        want_s = test_hit(sphere, pa, probe, pb, LOCD_ROUTE_CLOSED);
        want_b = test_hit(box, pa, probe, pb, LOCD_ROUTE_CLOSED);
        TEST_ASSERT_EQUAL_INT64(want_s, test_hit(cap0, pa, probe, pb, LOCD_ROUTE_CCD));
        TEST_ASSERT_EQUAL_INT64(want_s, test_hit(cap0, pa, probe, pb, LOCD_ROUTE_FCL));
        if (want_s) {
            /* Capsule contacts (FCL, the default route) against the sphere's closed form. */
            double ref[7], got[7];
            int32_t h;
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_collide(sphere, pa, probe, pb, LOCD_ROUTE_CLOSED, 0, &h, ref));
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_collide(cap0, pa, probe, pb, LOCD_ROUTE_AUTO, 0, &h, got));
            TEST_ASSERT_EQUAL_INT64(1, h);
            if (fabs(got[0] - ref[0]) > DEPTH_TOL * ref[0] + TOUCH_TOL)
                LT_FAIL("capsule depth %.9g, sphere %.9g", got[0], ref[0]);
            if (ref[0] > 1e-3 && got[1] * ref[1] + got[2] * ref[2] + got[3] * ref[3] < 0.999)
                LT_FAIL("capsule normal differs from the sphere's");
        }
        TEST_ASSERT_EQUAL_INT64(want_b, test_hit(hull, pa, probe, pb, LOCD_ROUTE_CCD));
        /* A mesh is a surface: compare only probes whose centre is outside the box. */
        for (k = 0; k < 3; k++)
            d2 = fmax(d2, fabs(pb[k] - pa[k]));
        if (d2 > 0.6 * sqrt(3.0)) {
            TEST_ASSERT_EQUAL_INT64(want_b, test_hit(mesh, pa, probe, pb, LOCD_ROUTE_CCD));
            TEST_ASSERT_EQUAL_INT64(want_b, test_hit(mesh, pa, probe, pb, LOCD_ROUTE_FCL));
        }
    }
    TEST_ASSERT_TRUE(compared > 1500);
    locd_shape_destroy(sphere);
    locd_shape_destroy(cap0);
    locd_shape_destroy(box);
    locd_shape_destroy(hull);
    locd_shape_destroy(mesh);
    locd_shape_destroy(probe);
}

/* Shapes a hair apart or a hair overlapping: every route gives the same
 * answer on every run (no flip-flop), and the closed form's answer once the
 * gap exceeds the stated tolerance. */
static void near_touching_never_flips(void)
{
    static const double gaps[] = {-1e-3, -1e-5, -1e-6, -1e-9, -1e-12, 0.0, 1e-12, 1e-9, 1e-6, 1e-5, 1e-3};
    locd_shape *a, *b;
    ts_rng r;
    size_t g;
    int iter, route, run;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_box(0.5, 0.5, 0.5, &a));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_sphere(0.5, &b));
    ts_seed(&r, 5);
    for (iter = 0; iter < 50; iter++) {
        double pa[7] = {0, 0, 0, 0, 0, 0, 1}, pb[7] = {0, 0, 0, 0, 0, 0, 1}, dir[3], n = 0.0;
        int k;
        /* Sphere centre straight above a face, off-centre. */
        for (k = 0; k < 3; k++) {
            dir[k] = ts_uniform(&r) - 0.5;
            n += dir[k] * dir[k];
        }
        (void)n;
        for (g = 0; g < sizeof gaps / sizeof gaps[0]; g++) {
            pb[0] = 0.8 * dir[0];
            pb[1] = 0.8 * dir[1];
            pb[2] = 1.0 + gaps[g];
            for (route = LOCD_ROUTE_CLOSED; route <= LOCD_ROUTE_FCL; route++) {
                int32_t first = test_hit(a, pa, b, pb, route);
                for (run = 0; run < 3; run++)
                    if (test_hit(a, pa, b, pb, route) != first)
                        LT_FAIL("route %d gap %g flips between runs", route, gaps[g]);
                if (fabs(gaps[g]) >= TOUCH_TOL && first != (gaps[g] < 0.0))
                    LT_FAIL("route %d gap %g: answer %d beyond the tolerance", route, gaps[g], first);
            }
        }
    }
    locd_shape_destroy(a);
    locd_shape_destroy(b);
}

/* The paper's ball that jumps through the floor between two frames. */
static void build_floor_and_ball(locd_world *w, double vz)
{
    locd_shape *floor_, *ball;
    double pf[7] = {0, 0, -0.1, 0, 0, 0, 1}, pball[7] = {0, 0, 1.0, 0, 0, 0, 1}, v[6] = {0, 0, vz, 0, 0, 0};
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_box(10, 10, 0.1, &floor_));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_sphere(0.25, &ball));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_add(w, floor_, pf, NULL, NULL));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_add(w, ball, pball, v, NULL));
    locd_shape_destroy(floor_);
    locd_shape_destroy(ball);
}

static void swept_stage_catches_tunnelling(void)
{
    static const int modes[] = {LOCD_SWEPT_OFF, LOCD_SWEPT_ON, LOCD_SWEPT_AUTO};
    locd_world *w;
    locd_contacts *c;
    locd_pipeline_options o;
    locd_pipeline_stats s;
    size_t mi;
    double dt = 1.0 / 60.0, vz = -300.0; /* 5 m in one step, the floor is 0.2 m thick */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_create(NULL, &w));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_contacts_create(&c));
    build_floor_and_ball(w, vz);
    for (mi = 0; mi < 3; mi++) {
        int contact;
        for (contact = 0; contact < 2; contact++) {
            locd_pipeline_options_init(&o);
            o.dt = dt;
            o.swept = modes[mi];
            o.stages = LOCD_STAGE_SHAPE | (contact ? LOCD_STAGE_CONTACT : 0);
            locd_pipeline_stats_init(&s);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_collide(w, &o, c, &s));
            if (modes[mi] == LOCD_SWEPT_OFF) {
                TEST_ASSERT_EQUAL_INT64(0, locd_contacts_count(c)); /* tunnelled */
                TEST_ASSERT_EQUAL_INT64(0, s.swept.calls);
                continue;
            }
            TEST_ASSERT_EQUAL_INT64(1, locd_contacts_count(c));
            TEST_ASSERT_EQUAL_INT64(1, s.swept.calls);
            TEST_ASSERT_EQUAL_INT64(1, s.swept_objects);
            /* Centre at 1.0 meets the floor top (z = 0) at 0.25: after 0.75 m of 5 m. */
            /* GJK's tolerance: the time of impact is good to 1e-6 of the step. */
            if (fabs(locd_contacts_toi(c)[0] - 0.75 / (-vz * dt)) > 1e-6)
                LT_FAIL("toi %.12g, expected %.12g", locd_contacts_toi(c)[0], 0.75 / (-vz * dt));
            if (contact) {
                const double *n = locd_contacts_normal(c);
                TEST_ASSERT_NOT_NULL(n);
                TEST_ASSERT_TRUE(n[2] > 0.99); /* from the floor (0) up to the ball (1) */
            }
        }
    }
    /* A slow ball in AUTO mode stays discrete: no swept test at all. */
    {
        double v[6] = {0, 0, -1.0, 0, 0, 0};
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_set_velocity(w, 1, v));
        locd_pipeline_options_init(&o);
        o.dt = dt;
        o.swept = LOCD_SWEPT_AUTO;
        locd_pipeline_stats_init(&s);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_collide(w, &o, c, &s));
        TEST_ASSERT_EQUAL_INT64(0, s.swept_objects);
        TEST_ASSERT_EQUAL_INT64(0, s.swept.pairs_in);
    }
    locd_contacts_destroy(c);
    locd_world_destroy(w);
}

/* Rocks falling onto a mesh terrain at speed: swept tests against triangles. */
static void swept_against_mesh(void)
{
    double v[3 * 16];
    uint32_t t[6 * 9];
    int i, j, nt = 0;
    locd_shape *terrain, *rock;
    locd_world *w;
    locd_contacts *c;
    locd_pipeline_options o;
    double pose[7] = {0, 0, 0, 0, 0, 0, 1}, prock[7] = {1.3, 1.4, 2.0, 0, 0, 0, 1}, vel[6] = {0, 0, -400, 0, 0, 0};
    double pts[3 * 6] = {0.3, 0, 0, -0.3, 0, 0, 0, 0.3, 0, 0, -0.3, 0, 0, 0, 0.3, 0, 0, -0.3};
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++) {
            v[3 * (4 * i + j)] = i;
            v[3 * (4 * i + j) + 1] = j;
            v[3 * (4 * i + j) + 2] = 0.1 * ((i + j) % 2);
        }
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            uint32_t a = (uint32_t)(4 * i + j), b = a + 1, cc = a + 4, d = a + 5;
            t[3 * nt] = a, t[3 * nt + 1] = cc, t[3 * nt + 2] = b, nt++;
            t[3 * nt] = b, t[3 * nt + 1] = cc, t[3 * nt + 2] = d, nt++;
        }
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_mesh(v, 16, t, (size_t)nt, &terrain));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_convex(pts, 6, &rock));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_create(NULL, &w));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_contacts_create(&c));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_add(w, terrain, pose, NULL, NULL));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_add(w, rock, prock, vel, NULL));
    locd_pipeline_options_init(&o);
    o.dt = 0.01; /* 4 m per step */
    o.stages = LOCD_STAGE_SHAPE | LOCD_STAGE_CONTACT;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_collide(w, &o, c, NULL));
    TEST_ASSERT_EQUAL_INT64(0, locd_contacts_count(c));
    o.swept = LOCD_SWEPT_AUTO;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_collide(w, &o, c, NULL));
    TEST_ASSERT_EQUAL_INT64(1, locd_contacts_count(c));
    {
        double toi = locd_contacts_toi(c)[0];
        /* Terrain height under (1.3, 1.4) lies in [0, 0.1]: tip at 1.7 reaches it after 1.6..1.7 m of 4. */
        TEST_ASSERT_TRUE(toi >= 1.6 / 4.0 - 1e-9 && toi <= 1.7 / 4.0 + 1e-9);
        TEST_ASSERT_TRUE(locd_contacts_normal(c)[2] > 0.5);
    }
    locd_contacts_destroy(c);
    locd_world_destroy(w);
    locd_shape_destroy(terrain);
    locd_shape_destroy(rock);
}

static int cmp_pair(const void *a, const void *b)
{
    const uint32_t *x = a, *y = b;
    if (x[0] != y[0])
        return x[0] < y[0] ? -1 : 1;
    return x[1] < y[1] ? -1 : (x[1] > y[1]);
}

/* A random world of mixed shapes: stages asked for run, the others report
 * nothing; the result equals an O(n^2) loop over the pair test; the broad
 * phase alone equals brute force on the world boxes. */
static void stages_run_only_when_asked(void)
{
    enum { N = 300 };
    locd_world *w;
    locd_contacts *c;
    locd_pipeline_options o;
    locd_pipeline_stats s;
    locd_shape *shapes[4];
    double poses[7 * N], boxes[6 * N];
    int kind[N];
    double pts[3 * 7] = {0.2, 0, 0, -0.2, 0.1, 0, 0, 0.25, 0.1, 0, -0.2, 0, 0, 0, 0.2, 0.1, 0, -0.2, -0.1, -0.1, 0.1};
    ts_rng r;
    int i, j, mode;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_sphere(0.2, &shapes[0]));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_box(0.2, 0.1, 0.15, &shapes[1]));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_capsule(0.1, 0.15, &shapes[2]));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_convex(pts, 7, &shapes[3]));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_create(NULL, &w));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_contacts_create(&c));
    ts_seed(&r, 42);
    for (i = 0; i < N; i++) {
        kind[i] = (int)(ts_next(&r) % 4);
        random_pose(&r, 2.0, poses + 7 * i);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_add(w, shapes[kind[i]], poses + 7 * i, NULL, NULL));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_aabb(shapes[kind[i]], poses + 7 * i, boxes + 6 * i));
    }
    for (mode = 0; mode < 3; mode++) {
        size_t m, expect = 0, k;
        uint32_t *got;
        locd_pipeline_options_init(&o);
        o.stages = mode == 0 ? 0u : (mode == 1 ? LOCD_STAGE_SHAPE : LOCD_STAGE_SHAPE | LOCD_STAGE_CONTACT);
        o.find_flags = LOCD_FIND_SORTED;
        locd_pipeline_stats_init(&s);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_collide(w, &o, c, &s));
        TEST_ASSERT_EQUAL_INT64(1, s.broad.calls);
        TEST_ASSERT_EQUAL_INT64(0, s.swept.calls);
        TEST_ASSERT_TRUE(s.swept.ms == 0.0 && s.swept.pairs_in == 0);
        TEST_ASSERT_EQUAL_INT64(mode >= 1, s.shape.calls);
        TEST_ASSERT_EQUAL_INT64(mode == 2, s.contact.calls);
        if (mode == 0) {
            locd_pairs *bp;
            TEST_ASSERT_TRUE(s.shape.ms == 0.0 && s.contact.ms == 0.0);
            TEST_ASSERT_EQUAL_INT64(0, s.tests_closed + s.tests_ccd + s.tests_fcl);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &bp));
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_brute_force_f64(boxes, N, bp));
            TEST_ASSERT_EQUAL_INT64(locd_pairs_count(bp), locd_contacts_count(c));
            LT_ASSERT_EQUAL_MEMORY(locd_pairs_data(bp), locd_contacts_pairs(c), 8 * locd_pairs_count(bp));
            TEST_ASSERT_NULL(locd_contacts_depth(c));
            locd_pairs_destroy(bp);
            continue;
        }
        TEST_ASSERT_EQUAL_INT64(s.broad.pairs_out, s.shape.pairs_in);
        TEST_ASSERT_TRUE(s.shape.pairs_out <= s.shape.pairs_in);
        m = locd_contacts_count(c);
        got = malloc(8 * (m ? m : 1));
        memcpy(got, locd_contacts_pairs(c), 8 * m);
        qsort(got, m, 8, cmp_pair);
        for (i = 0; i < N; i++)
            for (j = i + 1; j < N; j++) {
                if (!test_hit(shapes[kind[i]], poses + 7 * i, shapes[kind[j]], poses + 7 * j, LOCD_ROUTE_AUTO))
                    continue;
                if (expect >= m || got[2 * expect] != (uint32_t)i || got[2 * expect + 1] != (uint32_t)j)
                    LT_FAIL("mode %d: pair (%d, %d) missing", mode, i, j);
                expect++;
            }
        TEST_ASSERT_EQUAL_INT64(m, expect);
        if (mode == 2) {
            TEST_ASSERT_EQUAL_INT64(s.shape.pairs_out, s.contact.pairs_in);
            TEST_ASSERT_NOT_NULL(locd_contacts_depth(c));
            for (k = 0; k < m; k++)
                TEST_ASSERT_TRUE(locd_contacts_depth(c)[k] >= -1e-9);
        }
        free(got);
    }
    for (i = 0; i < 4; i++)
        locd_shape_destroy(shapes[i]);
    locd_contacts_destroy(c);
    locd_world_destroy(w);
}

/* Routing a pair type to the box test skips its shape test. */
static void route_box_skips_shape_test(void)
{
    locd_world *w;
    locd_contacts *c;
    locd_pipeline_options o;
    locd_pipeline_stats s;
    locd_shape *ball;
    double p0[7] = {0, 0, 0, 0, 0, 0, 1}, p1[7] = {0.9, 0.9, 0, 0, 0, 0, 1}; /* boxes overlap, balls do not */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_sphere(0.5, &ball));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_create(NULL, &w));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_contacts_create(&c));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_add(w, ball, p0, NULL, NULL));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_add(w, ball, p1, NULL, NULL));
    locd_pipeline_options_init(&o);
    locd_pipeline_stats_init(&s);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_collide(w, &o, c, &s));
    TEST_ASSERT_EQUAL_INT64(0, locd_contacts_count(c));
    TEST_ASSERT_EQUAL_INT64(1, s.tests_closed);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK,
                            locd_pipeline_options_route(&o, LOCD_SHAPE_SPHERE, LOCD_SHAPE_SPHERE, LOCD_ROUTE_BOX));
    locd_pipeline_stats_init(&s);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_collide(w, &o, c, &s));
    TEST_ASSERT_EQUAL_INT64(1, locd_contacts_count(c));
    TEST_ASSERT_EQUAL_INT64(0, s.tests_closed + s.tests_ccd + s.tests_fcl);
    locd_shape_destroy(ball);
    locd_contacts_destroy(c);
    locd_world_destroy(w);
}

/* The call failed with LOCD_ERR_SHAPE and a message that mentions needle; a
 * failure is reported at the caller's line. */
#define expect_shape_error(st, needle) expect_shape_error_(__LINE__, (st), (needle))
static void expect_shape_error_(int line, locd_status st, const char *needle)
{
    UNITY_TEST_ASSERT_EQUAL_INT64(LOCD_ERR_SHAPE, st, line, NULL);
    if (!strstr(locd_last_error(), needle))
        lt_fail_(line, "last error '%s' does not mention '%s'", locd_last_error(), needle);
}

static void bad_shapes_rejected(void)
{
    static const double tri[9] = {0, 0, 0, 1, 0, 0, 2, 0, 0}; /* collinear */
    static const double ok_tri[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    static const uint32_t idx[3] = {0, 1, 2}, bad_idx[3] = {0, 1, 5};
    double nan_pose[7] = {0, 0, NAN, 0, 0, 0, 1}, zero_quat[7] = {0, 0, 0, 0, 0, 0, 0};
    double pose[7] = {0, 0, 0, 0, 0, 0, 1}, bad_v[6] = {0, 0, INFINITY, 0, 0, 0}, same[6] = {1, 1, 1, 1, 1, 1};
    double nan_pts[6] = {0, 0, 0, 1, NAN, 0};
    locd_shape *s = (locd_shape *)1, *ball;
    locd_world *w;
    expect_shape_error(locd_shape_convex(NULL, 0, &s), "empty");
    TEST_ASSERT_NULL(s);
    expect_shape_error(locd_shape_convex(same, 2, &s), "identical");
    expect_shape_error(locd_shape_convex(nan_pts, 2, &s), "non-finite");
    expect_shape_error(locd_shape_mesh(tri, 3, idx, 1, &s), "degenerate");
    expect_shape_error(locd_shape_mesh(ok_tri, 3, idx, 0, &s), "at least one triangle");
    expect_shape_error(locd_shape_mesh(ok_tri, 3, bad_idx, 1, &s), "vertex 5");
    expect_shape_error(locd_shape_sphere(-1.0, &s), "radius");
    expect_shape_error(locd_shape_sphere(NAN, &s), "radius");
    expect_shape_error(locd_shape_box(1, 0, 1, &s), "half extents");
    expect_shape_error(locd_shape_capsule(1, -1, &s), "capsule");
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_sphere(1.0, &ball));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_create(NULL, &w));
    expect_shape_error(locd_world_add(w, ball, nan_pose, NULL, NULL), "pose");
    expect_shape_error(locd_world_add(w, ball, zero_quat, NULL, NULL), "quaternion");
    expect_shape_error(locd_world_add(w, ball, pose, bad_v, NULL), "velocity");
    TEST_ASSERT_EQUAL_INT64(0, locd_world_count(w));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_add(w, ball, pose, NULL, NULL));
    expect_shape_error(locd_world_set_pose(w, 0, nan_pose), "object 0");
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_HANDLE, locd_world_collide(NULL, NULL, NULL, NULL));
    locd_shape_destroy(ball);
    locd_world_destroy(w);
}

/* Without the narrow phase, every pipeline call says so. */
static void unsupported_without_narrow(void)
{
    locd_shape *s = (locd_shape *)1;
    locd_world *w = (locd_world *)1;
    locd_contacts *c = (locd_contacts *)1;
    locd_pipeline_options o;
    locd_pipeline_options_init(&o);
    TEST_ASSERT_EQUAL_INT64(sizeof o, o.size);
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_UNSUPPORTED, locd_shape_sphere(1.0, &s));
    TEST_ASSERT_NULL(s);
    TEST_ASSERT_NOT_NULL(strstr(locd_last_error(), "narrow"));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_UNSUPPORTED, locd_world_create(NULL, &w));
    TEST_ASSERT_NULL(w);
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_UNSUPPORTED, locd_contacts_create(&c));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_UNSUPPORTED, locd_world_collide(NULL, &o, NULL, NULL));
}

/* Two coplanar flat hulls (issue 18): libccd's EPA found no face and the
 * normal came out NaN. Every route and contact method must give a finite
 * unit normal, and the EPA one is the planes' normal with depth 0 (they
 * touch along it), whatever the plane's orientation. */
static void coplanar_flat_hulls_give_a_finite_normal(void)
{
    static const double square[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    static const int32_t routes[] = {LOCD_ROUTE_AUTO, LOCD_ROUTE_CCD, LOCD_ROUTE_FCL};
    static const int32_t methods[] = {LOCD_CONTACT_EPA, LOCD_CONTACT_MPR};
    locd_shape *a = NULL;
    const double pi = 3.14159265358979323846;
    double s30 = sin(pi / 12.0), c30 = cos(pi / 12.0); /* a 30 degree turn about x */
    int tilt, r, m;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_convex(square, 4, &a));
    for (tilt = 0; tilt < 2; tilt++) {
        double qa[7] = {0, 0, 0, tilt ? s30 : 0, 0, 0, tilt ? c30 : 1};
        double qb[7] = {0.5, tilt ? 0.5 * cos(pi / 6.0) : 0.5, tilt ? 0.5 * sin(pi / 6.0) : 0, qa[3], 0, 0, qa[6]};
        /* the plane's normal: z turned by 30 degrees about x */
        double plane[3] = {0.0, tilt ? -sin(pi / 6.0) : 0.0, tilt ? cos(pi / 6.0) : 1.0};
        for (r = 0; r < 3; r++)
            for (m = 0; m < 2; m++) {
                int32_t hit = 0;
                double c[7], len, along;
                TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_collide(a, qa, a, qb, routes[r], methods[m], &hit, c));
                TEST_ASSERT_EQUAL_INT(1, hit);
                len = sqrt(c[1] * c[1] + c[2] * c[2] + c[3] * c[3]);
                if (!(isfinite(len) && fabs(len - 1.0) < 1e-9 && isfinite(c[0]) && isfinite(c[4]) &&
                      isfinite(c[5]) && isfinite(c[6])))
                    LT_FAIL("tilt %d route %d method %d: normal %g %g %g depth %g", tilt, (int)routes[r],
                            (int)methods[m], c[1], c[2], c[3], c[0]);
                if (methods[m] == LOCD_CONTACT_EPA) {
                    along = fabs(c[1] * plane[0] + c[2] * plane[1] + c[3] * plane[2]);
                    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 1.0, along);
                    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 0.0, c[0]);
                }
            }
    }
    locd_shape_destroy(a);
}

int main(void)
{
    static const lt_test full[] = {
        LT_TEST(general_paths_match_closed_forms),
        LT_TEST(other_shapes_match_their_equivalents),
        LT_TEST(near_touching_never_flips),
        LT_TEST(swept_stage_catches_tunnelling),
        LT_TEST(swept_against_mesh),
        LT_TEST(stages_run_only_when_asked),
        LT_TEST(route_box_skips_shape_test),
        LT_TEST(bad_shapes_rejected),
        LT_TEST(coplanar_flat_hulls_give_a_finite_normal),
    };
    static const lt_test stub[] = {
        LT_TEST(unsupported_without_narrow),
    };
    if (!narrow_built())
        return LT_RUN(stub);
    return LT_RUN(full);
}
