/* Hard inputs never break exactness: the scene's shape. Points,
 * zero-thickness plates and sticks, identical boxes, one box containing
 * all, worlds flat to a plane, a line or a point, sizes across twelve
 * orders of magnitude, and every box in one cell (quadratic output; memory
 * running out for it gives LOCD_ERR_NO_MEMORY and keeps the old result).
 * Every scene through every engine against brute force, and the same pair
 * order within a group of knobs (hard_cases_util.h). */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "hard_cases_util.h"

/* ------------------------------------------------------------------ */
/* Points, identical boxes, one box containing all                    */
/* ------------------------------------------------------------------ */

static void points_and_zero_size_boxes(void)
{
    hc_scene s = {0};
    ts_rng r;
    size_t i;
    float *f;
    ts_seed(&r, 700);
    /* Points on an integer lattice (some repeated), next to unit cubes with
       corners and faces on the same lattice. */
    for (i = 0; i < 3000; i++) {
        double x = (double)hc_rnd(&r, 12), y = (double)hc_rnd(&r, 12), z = (double)hc_rnd(&r, 12);
        hc_scene_add(&s, x, y, z, x, y, z);
    }
    for (i = 0; i < 1500; i++) {
        double x = (double)hc_rnd(&r, 12), y = (double)hc_rnd(&r, 12), z = (double)hc_rnd(&r, 12);
        hc_scene_add(&s, x, y, z, x + 1, y + 1, z + 1);
    }
    for (i = 0; i < 300; i++) { /* zero-thickness plates and sticks */
        double x = (double)hc_rnd(&r, 12), y = (double)hc_rnd(&r, 12), z = (double)hc_rnd(&r, 12);
        if (i % 2)
            hc_scene_add(&s, x, y, z, x + 2, y + 1, z);
        else
            hc_scene_add(&s, x, y, z, x, y, z + 3);
    }
    f = hc_narrow(s.b, s.n);
    hc_check_both(f, s.n, "points, plates, sticks and cubes on a lattice");
    free(f);
    hc_scene_free(&s);
}

static void many_identical_boxes(void)
{
    const size_t n = hc_heavy() ? 4100 : 1500; /* n(n-1)/2 pairs */
    hc_scene s = {0};
    size_t i, m;
    float *f;
    for (i = 0; i < n; i++)
        hc_scene_add(&s, 0.25, -0.5, 3.0, 0.75, 0.5, 3.125);
    f = hc_narrow(s.b, n);
    m = hc_check_f32(f, n, "identical boxes");
    TEST_ASSERT_EQUAL_INT64(n * (n - 1) / 2, m);
    free(f);
    /* Identical boxes among ordinary ones. */
    {
        float *u = ts_scene(0, n, 701);
        for (i = 0; i < n; i += 3)
            memcpy(u + 6 * i, u + 6 * 7, 6 * sizeof(float));
        hc_check_both(u, n, "every third box identical");
        free(u);
    }
    hc_scene_free(&s);
    hc_trim_runners();
}

static void one_box_contains_all(void)
{
    const size_t n = 4500;
    size_t at;
    for (at = 0; at < n; at += 2249) { /* first, middle, last */
        float *u = ts_scene(2, n, 702 + at);
        float big[6] = {-1, -1, -1, 2, 2, 2};
        size_t m;
        memcpy(u + 6 * at, big, sizeof big);
        m = hc_check_f32(u, n, "one box containing all");
        TEST_ASSERT_TRUE(m >= n - 1);
        /* The container exactly equal to the scene's bounds. */
        {
            float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
            size_t i;
            int a;
            for (i = 0; i < n; i++)
                if (i != at)
                    for (a = 0; a < 3; a++) {
                        lo[a] = u[6 * i + a] < lo[a] ? u[6 * i + a] : lo[a];
                        hi[a] = u[6 * i + 3 + a] > hi[a] ? u[6 * i + 3 + a] : hi[a];
                    }
            for (a = 0; a < 3; a++) {
                u[6 * at + a] = lo[a];
                u[6 * at + 3 + a] = hi[a];
            }
            hc_check_both(u, n, "one box equal to the scene's bounds");
        }
        free(u);
    }
}

/* ------------------------------------------------------------------ */
/* Degenerate worlds: one plane, one line, one point                  */
/* ------------------------------------------------------------------ */

static void degenerate_worlds(void)
{
    const size_t n = 4100, npoint = hc_heavy() ? 4100 : 1500; /* the point world has n(n-1)/2 pairs */
    int kind, axis;
    for (kind = 0; kind < 3; kind++)
        for (axis = 0; axis < (kind == 2 || hc_heavy() ? 3 : 1); axis++) { /* light run: axis 0 only */
            const size_t m = kind == 2 ? npoint : n;
            float *u = ts_scene(kind == 2 ? 0 : 2, m, 800 + 3 * (size_t)kind + (size_t)axis);
            size_t i;
            char name[80];
            for (i = 0; i < m; i++) {
                int a;
                for (a = 0; a < 3; a++) {
                    /* kind 0: all on the plane x_axis = 0.5; 1: on a line; 2: one point */
                    int flat = kind == 0 ? a == axis : kind == 1 ? a != axis : 1;
                    if (flat)
                        u[6 * i + a] = u[6 * i + 3 + a] = (kind == 2 && axis == 1) ? -1e20f : 0.5f;
                }
            }
            if (kind == 2 && axis == 2) { /* point worlds: 0.5 (axis 0) and -1e20 (axis 1) are enough */
                free(u);
                continue;
            }
            snprintf(name, sizeof name, "%s world (axis %d)", kind == 0 ? "plane" : kind == 1 ? "line" : "point",
                     axis);
            if (kind == 2) {
                TEST_ASSERT_EQUAL_INT64(m * (m - 1) / 2, hc_check_f32(u, m, name));
            } else {
                hc_check_both(u, m, name);
            }
            free(u);
        }
    hc_trim_runners();
}

/* ------------------------------------------------------------------ */
/* Huge next to tiny: twelve orders of magnitude                      */
/* ------------------------------------------------------------------ */

static void sizes_span_twelve_orders(void)
{
    const size_t n = 5000;
    hc_scene s = {0};
    ts_rng r;
    size_t i;
    float *f;
    ts_seed(&r, 900);
    for (i = 0; i < n; i++) {
        double e = pow(10.0, 12.0 * ts_uniform(&r) - 6.0); /* 1e-6 .. 1e6 */
        double x = 1e6 * ts_uniform(&r), y = 1e6 * ts_uniform(&r), z = 1e6 * ts_uniform(&r);
        if (i % 50 == 0) { /* tiny boxes stuck to a huge one's face */
            x = 5e5;
            e = 1e-6;
        }
        hc_scene_add(&s, x, y, z, x + e * (0.5 + ts_uniform(&r)), y + e * (0.5 + ts_uniform(&r)), z + e);
    }
    hc_scene_add(&s, 0, 0, 0, 5e5, 1e6, 1e6);
    hc_check_f64(s.b, s.n, "sizes 1e-6 .. 1e6, float64");
    f = hc_narrow(s.b, s.n);
    hc_check_both(f, s.n, "sizes 1e-6 .. 1e6, float32");
    free(f);
    hc_scene_free(&s);
}

/* ------------------------------------------------------------------ */
/* Very many boxes in one cell: quadratic output                      */
/* ------------------------------------------------------------------ */

static void many_boxes_in_one_cell(void)
{
    const size_t n = hc_heavy() ? 4100 : 1500; /* n(n-1)/2 pairs */
    float *u = ts_scene(0, n, 1200);
    size_t i, m, want;
    static const uint32_t threads[] = {1, 2, 3, 8};
    /* Every box contains the centre: all n(n-1)/2 pairs, distinct boxes. */
    for (i = 0; i < n; i++) {
        int a;
        for (a = 0; a < 3; a++) {
            u[6 * i + a] = 0.5f - u[6 * i + a] * 0.1f - 0.001f;
            u[6 * i + 3 + a] = 0.5f + u[6 * i + 3 + a] * 0.1f;
        }
    }
    want = n * (n - 1) / 2;
    m = hc_check_f32(u, n, "every box contains the centre");
    TEST_ASSERT_EQUAL_INT64(want, m);

    /* Memory runs out: a clean LOCD_ERR_NO_MEMORY, the old result kept, no
       leak; with enough memory the same engine then succeeds. */
    for (i = 0; i < 4; i++) {
        hc_counter ce = {0, 0, (size_t)-1, 0}, cp = {0, 0, (size_t)-1, 0};
        locd_allocator pa = {hc_count_alloc, hc_count_free, &cp};
        locd_engine *e = hc_counted_engine(threads[i], &ce);
        locd_pairs *p;
        float two[12] = {0, 0, 0, 1, 1, 1, 1, 1, 1, 2, 2, 2};
        locd_status st;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(&pa, &p));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, two, 2, 0, p));
        TEST_ASSERT_EQUAL_INT64(1, locd_pairs_count(p));
        ce.cap = ce.cur + want * 2; /* a quarter of the pairs' 8 bytes each: not enough */
        st = locd_engine_find_pairs_f32(e, u, n, 0, p);
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NO_MEMORY, st);
        TEST_ASSERT_TRUE(ce.refused > 0);
        TEST_ASSERT_EQUAL_INT64(1, locd_pairs_count(p));
        TEST_ASSERT_EQUAL_INT64(0, locd_pairs_data(p)[0]);
        TEST_ASSERT_EQUAL_INT64(1, locd_pairs_data(p)[1]);
        /* Enough for the engine, but not for the caller's buffer. */
        ce.cap = (size_t)-1;
        cp.cap = cp.cur + want * 2;
        st = locd_engine_find_pairs_f32(e, u, n, 0, p);
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NO_MEMORY, st);
        TEST_ASSERT_EQUAL_INT64(1, locd_pairs_count(p));
        TEST_ASSERT_EQUAL_INT64(1, locd_pairs_data(p)[1]);
        cp.cap = (size_t)-1;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, u, n, 0, p));
        TEST_ASSERT_EQUAL_INT64(want, locd_pairs_count(p));
        locd_pairs_destroy(p);
        locd_engine_destroy(e);
        TEST_ASSERT_EQUAL_INT64(0, ce.cur);
        TEST_ASSERT_EQUAL_INT64(0, cp.cur);
    }
    free(u);
    hc_trim_runners();
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(points_and_zero_size_boxes),
        LT_TEST(many_identical_boxes),
        LT_TEST(one_box_contains_all),
        LT_TEST(degenerate_worlds),
        LT_TEST(sizes_span_twelve_orders),
        LT_TEST(many_boxes_in_one_cell),
    };
    return LT_RUN_GROUP(tests, hc_group_setup, hc_group_teardown);
}
