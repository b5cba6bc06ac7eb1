/* The whole call (level 1) against brute force on random scenes of every
 * kind, for every thread count, float32 and float64. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"
#include <math.h>

#include "support.h"

/* LOCD_TEST_HEAVY=0 (the sanitizer runs): smaller scenes, still >= 4096
 * objects so the parallel path runs (tests/README.md). */
static int heavy(void)
{
    const char *v = getenv("LOCD_TEST_HEAVY");
    return !(v && v[0] == '0');
}

static locd_engine *engine_with(uint32_t threads)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_engine_config_init(&cfg);
    cfg.threads = threads;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
    return e;
}

static void random_scenes_match_brute_force(void)
{
    static const size_t sizes[] = {2, 3, 17, 200, 1500, 5000};
    locd_pairs *p;
    uint32_t threads;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    for (threads = ts_under_tsan() ? 2 : 1; threads <= 3; threads++) { /* (1 thread races nothing) */
        locd_engine *e = engine_with(threads);
        int kind;
        size_t si;
        for (kind = 0; kind < TS_SCENE_KINDS; kind++)
            for (si = 0; si < sizeof sizes / sizeof sizes[0]; si++) {
                float *b = ts_scene(kind, sizes[si], 1000u * (uint64_t)kind + si);
                TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, sizes[si], 0, p));
                if (!ts_same_as_brute_f32(b, sizes[si], p))
                    LT_FAIL("kind %d n %zu threads %u differs from brute force", kind, sizes[si], threads);
                free(b);
            }
        locd_engine_destroy(e);
    }
    locd_pairs_destroy(p);
}

/* Byte-identical output (not just the same set) for every thread count. */
static void order_is_the_same_for_every_thread_count(void)
{
    int kind;
    for (kind = 0; kind < TS_SCENE_KINDS; kind++) {
        size_t n = heavy() ? 30000 : 4500;
        float *b = ts_scene(kind, n, 77 + (uint64_t)kind);
        locd_pairs *ref, *p;
        uint32_t t;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &ref));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
        for (t = 1; t <= 8; t++) {
            locd_engine *e = engine_with(t);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, n, 0, t == 1 ? ref : p));
            if (t > 1) {
                TEST_ASSERT_EQUAL_INT64(locd_pairs_count(ref), locd_pairs_count(p));
                LT_ASSERT_EQUAL_MEMORY(locd_pairs_data(ref), locd_pairs_data(p), locd_pairs_count(p) * 8);
            }
            locd_engine_destroy(e);
        }
        locd_pairs_destroy(ref);
        locd_pairs_destroy(p);
        free(b);
    }
}

/* n cubes of the given edge in the unit cube (seeded). */
static float *cubes(size_t n, float edge, uint64_t seed)
{
    ts_rng r;
    float *b = ts_boxes(n, &r, seed);
    size_t i;
    int a;
    for (i = 0; i < n; i++)
        for (a = 0; a < 3; a++) {
            b[6 * i + a] = (float)(ts_uniform(&r) * (1.0 - edge));
            b[6 * i + a + 3] = b[6 * i + a] + edge;
        }
    return b;
}

/* One result passed to call after call, on scenes of different pair counts
 * in turn: the dense ones have more pairs than the engine's spare entry
 * memory (lib/levels/inproc.c, lend_dead_entries), so the sweep threads
 * grow buffers of their own and keep them; the sparse one then writes to
 * those instead of the spare memory. Every answer is the one-thread answer
 * byte for byte. */
static void a_result_reused_across_scenes_keeps_every_answer(void)
{
    static const int order[] = {0, 1, 0, 2, 1, 1, 0, 2, 0, 1};
    const size_t n = heavy() ? 12000 : 5000;
    float *scene[3];
    locd_pairs *ref[3], *p;
    locd_engine *one = engine_with(1);
    uint32_t threads;
    int k;
    scene[0] = cubes(n, heavy() ? 0.1f : 0.13f, 5);
    scene[1] = cubes(n, heavy() ? 0.13f : 0.17f, 6);
    scene[2] = ts_scene(0, n, 7);
    for (k = 0; k < 3; k++) {
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &ref[k]));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(one, scene[k], n, 0, ref[k]));
    }
    if (locd_pairs_count(ref[0]) < 20 * n || locd_pairs_count(ref[1]) < locd_pairs_count(ref[0]) * 3 / 2)
        LT_FAIL("the dense scenes have %zu and %zu pairs: too few to fill the threads' own buffers",
                locd_pairs_count(ref[0]), locd_pairs_count(ref[1]));
    for (threads = 2; threads <= 3; threads++) {
        locd_engine *e = engine_with(threads);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
        for (k = 0; k < (int)(sizeof order / sizeof order[0]); k++) {
            const int sc = order[k];
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, scene[sc], n, 0, p));
            if (locd_pairs_count(p) != locd_pairs_count(ref[sc]) ||
                memcmp(locd_pairs_data(p), locd_pairs_data(ref[sc]), locd_pairs_count(p) * 8) != 0)
                LT_FAIL("threads %u, call %d (scene %d): %zu pairs, not the one-thread answer (%zu)", threads, k, sc,
                        locd_pairs_count(p), locd_pairs_count(ref[sc]));
        }
        locd_pairs_destroy(p);
        locd_engine_destroy(e);
    }
    for (k = 0; k < 3; k++) {
        locd_pairs_destroy(ref[k]);
        free(scene[k]);
    }
    locd_engine_destroy(one);
}

/* The same values as float32 and float64 give the same pairs in the same order. */
static void f32_and_f64_agree(void)
{
    size_t n = heavy() ? 20000 : 5000, i;
    float *b = ts_scene(2, n, 5);
    double *d = malloc(n * 6 * sizeof *d);
    locd_engine *e = engine_with(2);
    locd_pairs *p32, *p64;
    for (i = 0; i < 6 * n; i++)
        d[i] = b[i];
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p32));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p64));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, n, 0, p32));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f64(e, d, n, 0, p64));
    TEST_ASSERT_EQUAL_INT64(locd_pairs_count(p64), locd_pairs_count(p32));
    LT_ASSERT_EQUAL_MEMORY(locd_pairs_data(p64), locd_pairs_data(p32), locd_pairs_count(p32) * 8);
    TEST_ASSERT_TRUE(ts_same_as_brute_f64(d, n, p64));
    locd_pairs_destroy(p32);
    locd_pairs_destroy(p64);
    locd_engine_destroy(e);
    free(d);
    free(b);
}

/* Touching faces, edges and corners count; a gap of one float ulp does not. */
static void touching_boxes_count_and_ulp_gaps_do_not(void)
{
    locd_engine *e = engine_with(1);
    locd_pairs *p;
    float b[5 * 6] = {
        0, 0, 0, 1, 1, 1, /* 0 */
        1, 0, 0, 2, 1, 1, /* 1: face of 0 */
        1, 1, 0, 2, 2, 1, /* 2: edge of 0, face of 1 */
        1, 1, 1, 2, 2, 2, /* 3: corner of 0, edge of 1, face of 2 */
        0, 0, 0, 0, 0, 0, /* 4: a point on 0's corner */
    };
    float c[12] = {0, 0, 0, 1, 1, 1, 0, 0, 0, 2, 1, 1};
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, 5, LOCD_FIND_SORTED, p));
    TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, 5, p));
    TEST_ASSERT_EQUAL_INT64(7, locd_pairs_count(p)); /* 01 02 03 04 12 13 23 */
    c[6] = nextafterf(1.0f, 2.0f);            /* box 1 starts one ulp past box 0 */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, c, 2, 0, p));
    TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(p));
    c[6] = 1.0f;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, c, 2, 0, p));
    TEST_ASSERT_EQUAL_INT64(1, locd_pairs_count(p));
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
}

/* The stats of a 2-thread engine (automatic depth) on boxes b[0, n), whose
 * pairs must be the brute-force set. */
static locd_stats automatic_depth_stats(const float *b, size_t n)
{
    locd_engine *e = engine_with(2);
    locd_pairs *p;
    locd_stats st;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, n, 0, p));
    TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, n, p));
    locd_stats_init(&st);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_stats(e, &st));
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    return st;
}

/* The automatic depth lowers the octree's depth when small boxes would sit
 * alone in their cells, but must not when they are packed together: 20,000
 * small cubes in 5% of the world, beside a few world-sized boxes. A depth
 * chosen from n or from sizes alone (about 5 here) would put the cluster in
 * a handful of cells, thousands of candidates per object. */
static void automatic_depth_keeps_packed_boxes_apart(void)
{
    const size_t n = 20000;
    ts_rng r;
    float *b = ts_boxes(n, &r, 4242);
    locd_stats st;
    size_t i;
    for (i = 0; i < n; i++) {
        float *o = b + 6 * i;
        if (i % 1000 == 0) { /* a world-sized box now and then */
            o[0] = o[1] = o[2] = 0.0f;
            o[3] = o[4] = o[5] = 1.0f;
            continue;
        }
        o[0] = (float)(0.05 * ts_uniform(&r));
        o[1] = (float)(0.05 * ts_uniform(&r));
        o[2] = (float)(0.05 * ts_uniform(&r));
        o[3] = o[0] + 0.0004f;
        o[4] = o[1] + 0.0004f;
        o[5] = o[2] + 0.0004f;
    }
    st = automatic_depth_stats(b, n);
    if (st.depth < 8 || st.candidates > 64 * (uint64_t)n)
        LT_FAIL("automatic depth %u: %llu candidates for %zu boxes", st.depth, (unsigned long long)st.candidates, n);
    free(b);
}

/* A scene so dense that even the deepest cells hold more than the bound
 * of 16 (equal cubes of edge 1/64 packed into a sixty-fourth of a unit
 * world, about 300 to a cell at the level they stop at): deeper cells are
 * not emptier, so the automatic depth is the level where the cubes stop,
 * not the key's limit (14 here), where no depth met the bound. */
static void automatic_depth_stops_where_dense_cubes_do(void)
{
    const size_t n = 20000;
    ts_rng r;
    float *b = ts_boxes(n, &r, 4343), *o;
    locd_stats st;
    int a;
    for (o = b; o < b + 6 * n; o += 6)
        for (a = 0; a < 3; a++) {
            o[a] = (float)(0.25 * ts_uniform(&r));
            o[a + 3] = o[a] + 1.0f / 64.0f;
        }
    for (a = 0; a < 3; a++) /* a small box at the far corner stretches the world to the unit cube */
        b[a] = 0.99f, b[a + 3] = 1.0f;
    st = automatic_depth_stats(b, n);
    if (st.depth > 6)
        LT_FAIL("automatic depth %u for cubes that stop at level 4 or 5", st.depth);
    free(b);
}

/* A job released while it runs, then its engine destroyed: destroy must
 * wait for the job's thread (the sanitizer build catches a use after free). */
static void destroy_waits_for_a_released_running_job(void)
{
    size_t n = heavy() ? 200000 : 50000;
    float *b = ts_scene(0, n, 4);
    int round;
    for (round = 0; round < 3; round++) {
        locd_engine *e = engine_with(2);
        locd_job *job = NULL;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_submit_f32(e, b, n, 0, &job));
        locd_job_release(job);
        locd_engine_destroy(e);
    }
    free(b);
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(random_scenes_match_brute_force),
        LT_TEST(order_is_the_same_for_every_thread_count),
        LT_TEST(a_result_reused_across_scenes_keeps_every_answer),
        LT_TEST(f32_and_f64_agree),
        LT_TEST(touching_boxes_count_and_ulp_gaps_do_not),
        LT_TEST(automatic_depth_keeps_packed_boxes_apart),
        LT_TEST(automatic_depth_stops_where_dense_cubes_do),
        LT_TEST(destroy_waits_for_a_released_running_job),
    };
    return LT_RUN(tests);
}
