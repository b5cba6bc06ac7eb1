/* Determinism: the pair array (its bytes, not just the set) must not depend
 * on the thread count, the precision of the same values, the entry point
 * (pairs buffer or caller buffer), whether the engine is fresh or has run
 * other scenes, or the run. Scenes are large enough for the work to be split
 * between threads. The CLI-level check across integration levels is in
 * scripts/ci/steps/45-determinism.sh.
 *
 * LOCD_TEST_HEAVY=0 (set by the sanitizer runs) shrinks the scenes. */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "support.h"

#define MAX_THREADS 8

static int heavy(void)
{
    const char *v = getenv("LOCD_TEST_HEAVY");
    return !(v && v[0] == '0');
}

/* The thread count after t: every one to MAX_THREADS, or under TSan 1, 2,
 * 3 and MAX_THREADS (ts_under_tsan). */
static uint32_t next_threads(uint32_t t)
{
    return ts_under_tsan() && t >= 3 && t < MAX_THREADS ? MAX_THREADS : t + 1;
}

/* Above the engine's 4096-object parallel threshold. The clustered, lattice
 * and degenerate kinds have pairs growing as n^2: keep those scenes smaller. */
static size_t scene_n(int kind)
{
    if (!heavy())
        return 4500;
    return (kind == 0 || kind == 2) ? 20000 : 5000;
}

static locd_engine *engine_for(uint32_t threads, int32_t bias, uint32_t depth, uint32_t cfg_flags)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_engine_config_init(&cfg);
    cfg.threads = threads;
    cfg.cell_bias = bias;
    cfg.max_depth = depth;
    cfg.flags = cfg_flags;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
    return e;
}

static double *widen(const float *f, size_t n)
{
    double *d = malloc((n ? n : 1) * 6 * sizeof *d);
    size_t i;
    TEST_ASSERT_NOT_NULL(d);
    for (i = 0; i < 6 * n; i++)
        d[i] = (double)f[i];
    return d;
}

/* Fails with a message naming the first differing pair. */
static void same_bytes(const uint32_t *got, size_t got_n, const uint32_t *want, size_t want_n, const char *what)
{
    size_t i;
    if (got_n != want_n)
        LT_FAIL("%s: %zu pairs, expected %zu", what, got_n, want_n);
    for (i = 0; i < 2 * got_n; i++)
        if (got[i] != want[i])
            LT_FAIL("%s: pair %zu is (%u, %u), expected (%u, %u)", what, i / 2, got[i & ~(size_t)1], got[i | 1],
                    want[i & ~(size_t)1], want[i | 1]);
}

static void same_pairs(const locd_pairs *got, const locd_pairs *want, const char *what)
{
    same_bytes(locd_pairs_data(got), locd_pairs_count(got), locd_pairs_data(want), locd_pairs_count(want), what);
}

/* The float32 and the float64 call on the same values, each with `want`'s
 * bytes; `what` names the case in a failure. */
static void both_precisions_give(locd_engine *e, const float *f, const double *d, size_t n, uint32_t flags,
                                 locd_pairs *p, const locd_pairs *want, const char *what)
{
    char label[160];
    snprintf(label, sizeof label, "%s f32", what);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, f, n, flags, p));
    same_pairs(p, want, label);
    snprintf(label, sizeof label, "%s f64", what);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f64(e, d, n, flags, p));
    same_pairs(p, want, label);
}

/* Every scene kind, threads 1..8, float32 and float64, pairs buffer and
 * caller buffer, first and second call on the engine: one byte sequence. */
static void every_thread_count_precision_and_entry_point(void)
{
    int kind;
    for (kind = 0; kind < TS_SCENE_KINDS; kind++) {
        const size_t n = scene_n(kind);
        float *f = ts_scene(kind, n, 900 + (uint64_t)kind);
        double *d = widen(f, n);
        locd_pairs *ref, *p;
        uint32_t *buf = NULL;
        size_t cap, count;
        uint32_t t;
        char what[96];
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &ref));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
        {
            locd_engine *e1 = engine_for(1, 1, 0, 0);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e1, f, n, 0, ref));
            locd_engine_destroy(e1);
        }
        TEST_ASSERT_TRUE(locd_pairs_count(ref) > 0); /* the set itself is test_engine's job */
        cap = locd_pairs_count(ref);
        buf = malloc(cap * 2 * sizeof(uint32_t) + 8);
        TEST_ASSERT_NOT_NULL(buf);
        for (t = 1; t <= MAX_THREADS; t = next_threads(t)) {
            locd_engine *e = engine_for(t, 1, 0, 0);
            snprintf(what, sizeof what, "kind %d threads %u", kind, t);
            both_precisions_give(e, f, d, n, 0, p, ref, what);
            snprintf(what, sizeof what, "kind %d threads %u f32_into", kind, t);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32_into(e, f, n, 0, buf, cap, &count));
            same_bytes(buf, count, locd_pairs_data(ref), locd_pairs_count(ref), what);
            snprintf(what, sizeof what, "kind %d threads %u f64_into", kind, t);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f64_into(e, d, n, 0, buf, cap, &count));
            same_bytes(buf, count, locd_pairs_data(ref), locd_pairs_count(ref), what);
            TEST_ASSERT_EQUAL_INT64(t, locd_engine_threads(e));
            locd_engine_destroy(e);
        }
        free(buf);
        locd_pairs_destroy(ref);
        locd_pairs_destroy(p);
        free(d);
        free(f);
    }
}

/* Other encodings (cubes, cell bias, a depth limit) change the order but it
 * must still not depend on the thread count. */
static void every_thread_count_for_other_configs(void)
{
    static const struct {
        int32_t bias;
        uint32_t depth, flags;
    } cfgs[] = {{0, 0, 0}, {3, 0, 0}, {1, 4, 0}, {1, 0, LOCD_CONFIG_CUBES}, {8, 2, LOCD_CONFIG_CUBES}};
    const size_t n = scene_n(2);
    float *f = ts_scene(2, n, 4242);
    size_t c;
    for (c = 0; c < sizeof cfgs / sizeof cfgs[0]; c++) {
        locd_pairs *ref, *p;
        uint32_t t;
        char what[96];
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &ref));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
        for (t = 1; t <= MAX_THREADS; t++) {
            locd_engine *e = engine_for(t, cfgs[c].bias, cfgs[c].depth, cfgs[c].flags);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, f, n, 0, t == 1 ? ref : p));
            if (t > 1) {
                snprintf(what, sizeof what, "bias %d depth %u flags %u threads %u", (int)cfgs[c].bias,
                         cfgs[c].depth, cfgs[c].flags, t);
                same_pairs(p, ref, what);
            }
            locd_engine_destroy(e);
        }
        locd_pairs_destroy(ref);
        locd_pairs_destroy(p);
    }
    free(f);
}

/* An engine that has run other (larger, smaller) scenes gives the same bytes
 * as a fresh one: nothing left in its reused buffers leaks into a result. */
static void reused_engine_and_repeated_runs(void)
{
    const size_t n = scene_n(0);
    float *a = ts_scene(0, n, 11), *big = ts_scene(2, 2 * n, 12), *small = ts_scene(3, 4200, 13);
    locd_pairs *ref, *p;
    locd_engine *fresh = engine_for(4, 1, 0, 0), *e = engine_for(4, 1, 0, 0);
    int r;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &ref));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(fresh, a, n, 0, ref));
    for (r = 0; r < 3; r++) {
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, big, 2 * n, 0, p));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, a, n, 0, p));
        same_pairs(p, ref, "after a larger scene");
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, small, 4200, 0, p));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, a, n, 0, p));
        same_pairs(p, ref, "after a smaller scene");
    }
    locd_engine_destroy(fresh);
    locd_engine_destroy(e);
    locd_pairs_destroy(ref);
    locd_pairs_destroy(p);
    free(a);
    free(big);
    free(small);
}

/* Nearly every entry in one corner of the grid: a dense cluster and a few
 * boxes far away, which the root cube must also hold. The threads' sort
 * then finds almost all entries in one bucket of their top bits and
 * merges instead (octree/sort.c); the bytes are still the one-thread
 * bytes, and the set brute force's. */
static void cluster_and_far_boxes(void)
{
    const size_t n = scene_n(0), far = 5;
    float *f = ts_scene(0, n + far, 31);
    locd_pairs *ref, *p;
    size_t i;
    uint32_t t;
    char what[64];
    for (i = n; i < n + far; i++) { /* unit boxes 1000 away, apart from each other */
        const float x = 1000.0f + 2.0f * (float)(i - n);
        const float b[6] = {x, 1000.0f, 1000.0f, x + 1.0f, 1001.0f, 1001.0f};
        memcpy(f + 6 * i, b, sizeof b);
    }
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &ref));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    for (t = 1; t <= MAX_THREADS; t++) {
        locd_engine *e = engine_for(t, LOCD_DEFAULT_CELL_BIAS, 0, 0);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, f, n + far, 0, t == 1 ? ref : p));
        if (t > 1) {
            snprintf(what, sizeof what, "cluster and far boxes, threads %u", t);
            same_pairs(p, ref, what);
        }
        locd_engine_destroy(e);
    }
    TEST_ASSERT_TRUE(locd_pairs_count(ref) > 0);
    TEST_ASSERT_TRUE(ts_same_as_brute_f32(f, n + far, ref));
    locd_pairs_destroy(ref);
    locd_pairs_destroy(p);
    free(f);
}

/* LOCD_FIND_SORTED gives brute force's (i, j) order byte for byte, at every thread count. */
static void sorted_flag_is_brute_force_order(void)
{
    const size_t n = heavy() ? 8000 : 4500;
    float *f = ts_scene(4, n, 99);
    double *d = widen(f, n);
    locd_pairs *ref, *p;
    uint32_t t;
    char what[64];
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &ref));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_brute_force_f64(d, n, ref));
    for (t = 1; t <= MAX_THREADS; t++) {
        locd_engine *e = engine_for(t, 1, 0, 0);
        snprintf(what, sizeof what, "sorted threads %u", t);
        both_precisions_give(e, f, d, n, LOCD_FIND_SORTED, p, ref, what);
        locd_engine_destroy(e);
    }
    locd_pairs_destroy(ref);
    locd_pairs_destroy(p);
    free(d);
    free(f);
}

/* The SIMD kernels (LOCD_KERNEL caps the choice; a CPU without a kernel
 * falls back to the next one down) give the scalar kernel's bytes, for every
 * scene kind, both precisions, 1 and 3 threads and the default and cube
 * encodings; and the scalar result is the brute-force set. */
static void every_kernel_same_bytes(void)
{
    static const char *const kernels[] = TS_KERNELS;
    const char *saved = getenv("LOCD_KERNEL");
    char *keep = saved ? strdup(saved) : NULL;
    int kind, k, cubes;
    for (kind = 0; kind < TS_SCENE_KINDS; kind++)
        for (cubes = 0; cubes < 2; cubes++) {
            const size_t n = scene_n(kind);
            float *f = ts_scene(kind, n, 700 + (uint64_t)kind);
            double *d = widen(f, n);
            locd_pairs *ref, *p;
            uint32_t t;
            char what[96];
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &ref));
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
            setenv("LOCD_KERNEL", "scalar", 1);
            {
                locd_engine *e1 = engine_for(1, LOCD_DEFAULT_CELL_BIAS, 0, cubes ? LOCD_CONFIG_CUBES : 0);
                TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e1, f, n, 0, ref));
                locd_engine_destroy(e1);
            }
            TEST_ASSERT_TRUE(ts_same_as_brute_f32(f, n, ref));
            for (k = 1; k < TS_KERNEL_COUNT; k++) {
                setenv("LOCD_KERNEL", kernels[k], 1);
                for (t = ts_under_tsan() ? 3 : 1; t <= 3; t += 2) { /* (1 thread races nothing) */
                    locd_engine *e = engine_for(t, LOCD_DEFAULT_CELL_BIAS, 0, cubes ? LOCD_CONFIG_CUBES : 0);
                    snprintf(what, sizeof what, "kind %d cubes %d kernel %s threads %u", kind, cubes, kernels[k], t);
                    both_precisions_give(e, f, d, n, 0, p, ref, what);
                    locd_engine_destroy(e);
                }
            }
            locd_pairs_destroy(ref);
            locd_pairs_destroy(p);
            free(d);
            free(f);
        }
    if (keep) {
        setenv("LOCD_KERNEL", keep, 1);
        free(keep);
    } else {
        unsetenv("LOCD_KERNEL");
    }
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(every_thread_count_precision_and_entry_point),
        LT_TEST(every_thread_count_for_other_configs),
        LT_TEST(reused_engine_and_repeated_runs),
        LT_TEST(cluster_and_far_boxes),
        LT_TEST(sorted_flag_is_brute_force_order),
        LT_TEST(every_kernel_same_bytes),
    };
    return LT_RUN(tests);
}
