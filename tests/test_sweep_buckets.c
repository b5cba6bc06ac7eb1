/* The sweep's bucketed dense cells (lib/octree/sweep.c, docs/encoding.md
 * section 6): a cell of 96 or more entries is cut into 16 x 16 (x slab,
 * y slab) buckets, one of 768 or more into 32 x 32, and an entry is tested
 * only against the runs of buckets where an overlapping box can start.
 * These scenes force such cells (a shallow max_depth puts thousands of
 * boxes in one cell) with what could break the window: integer coordinates
 * (ends equal to other ends and to slab edges), zero-size boxes, duplicates,
 * boxes reaching out of their cell, huge boxes next to tiny ones, and
 * dense cells under many narrower ancestors (scanned by x slab). Each
 * must give the brute-force set with the scalar kernel, and the scalar
 * kernel's bytes with every SIMD kernel, 1 and 3 threads, both precisions.
 * A failure names the scene, kernel and thread count. */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "support.h"

static void put(float *b, double x, double y, double z, double ex, double ey, double ez)
{
    b[0] = (float)x;
    b[1] = (float)y;
    b[2] = (float)z;
    b[3] = (float)(x + ex);
    b[4] = (float)(y + ey);
    b[5] = (float)(z + ez);
}

/* Integer boxes (Terdiman's box-pruning scene, smaller): centres in
 * [-c, c)^3, half-extents 0..h per axis. Many equal ends, zero-size boxes. */
static float *integer_boxes(size_t n, int c, int h, uint64_t seed)
{
    ts_rng r;
    float *b = ts_boxes(n, &r, seed);
    size_t i;
    for (i = 0; i < n; i++) {
        double p[3], e[3];
        int a;
        for (a = 0; a < 3; a++)
            p[a] = (double)(int64_t)(ts_next(&r) % (uint64_t)(2 * c)) - c;
        for (a = 0; a < 3; a++)
            e[a] = (double)(ts_next(&r) % (uint64_t)(h + 1));
        put(b + 6 * i, p[0] - e[0], p[1] - e[1], p[2] - e[2], 2 * e[0], 2 * e[1], 2 * e[2]);
    }
    return b;
}

/* Tiny boxes packed on a coarse lattice (every coordinate a multiple of
 * 1/8: on slab edges at any depth), with duplicates, points and planes,
 * beside a few huge boxes, one of which ends exactly where tiny ones start. */
static float *huge_and_tiny(size_t n, uint64_t seed)
{
    ts_rng r;
    float *b = ts_boxes(n, &r, seed);
    size_t i;
    put(b, 0, 0, 0, 64, 64, 64);     /* the whole scene */
    put(b + 6, 0, 0, 0, 16, 64, 8);  /* a slab-shaped giant */
    put(b + 12, 32, 32, 32, 0, 0, 0); /* a point in the middle */
    for (i = 3; i < n; i++) {
        const double x = (double)(ts_next(&r) % 512) / 8, y = (double)(ts_next(&r) % 512) / 8,
                     z = (double)(ts_next(&r) % 512) / 8;
        const uint64_t k = ts_next(&r) % 8;
        if (k == 0 && i > 3) /* a duplicate of the box before */
            memcpy(b + 6 * i, b + 6 * (i - 1), 6 * sizeof *b);
        else if (k == 1) /* starts where the slab-shaped giant ends */
            put(b + 6 * i, 16, y, z, 0.125, 0.125 * (double)(k + 1), 0);
        else
            put(b + 6 * i, x, y, z, 0.125 * (double)(ts_next(&r) % 3), 0.125 * (double)(ts_next(&r) % 3),
                0.125 * (double)(ts_next(&r) % 3));
    }
    return b;
}

static locd_engine *engine_for(uint32_t threads, uint32_t depth)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_engine_config_init(&cfg);
    cfg.threads = threads;
    cfg.max_depth = depth;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
    return e;
}

static void same_bytes(const locd_pairs *got, const locd_pairs *want, const char *what)
{
    const uint32_t *g = locd_pairs_data(got), *w = locd_pairs_data(want);
    size_t i, n = locd_pairs_count(got);
    if (n != locd_pairs_count(want))
        LT_FAIL("%s: %zu pairs, expected %zu", what, n, locd_pairs_count(want));
    for (i = 0; i < 2 * n; i++)
        if (g[i] != w[i])
            LT_FAIL("%s: pair %zu is (%u, %u), expected (%u, %u)", what, i / 2, g[i & ~(size_t)1], g[i | 1],
                    w[i & ~(size_t)1], w[i | 1]);
}

/* Scalar kernel, 1 thread: the brute-force set; every kernel, 1 and 3
 * threads, float32 and float64: the same bytes. */
static void check_scene(const float *f, size_t n, uint32_t depth, const char *name)
{
    static const char *const kernels[] = TS_KERNELS;
    const char *saved = getenv("LOCD_KERNEL");
    char *keep = saved ? strdup(saved) : NULL;
    double *d = malloc(n * 6 * sizeof *d);
    locd_pairs *ref, *p;
    locd_stats st;
    size_t i;
    int k;
    TEST_ASSERT_NOT_NULL(d);
    for (i = 0; i < 6 * n; i++)
        d[i] = (double)f[i];
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &ref));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    setenv("LOCD_KERNEL", "scalar", 1);
    {
        locd_engine *e = engine_for(1, depth);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, f, n, 0, ref));
        locd_stats_init(&st);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_stats(e, &st));
        LT_PRINT("# %s: %zu boxes, %zu pairs, %.2f candidates per pair\n", name, n, locd_pairs_count(ref),
                 locd_pairs_count(ref) ? (double)st.candidates / (double)locd_pairs_count(ref) : 0.0);
        locd_engine_destroy(e);
    }
    if (!ts_same_as_brute_f32(f, n, ref))
        LT_FAIL("%s: the scalar kernel's pairs are not the brute-force set", name);
    for (k = 0; k < TS_KERNEL_COUNT; k++) {
        uint32_t t;
        setenv("LOCD_KERNEL", kernels[k], 1);
        for (t = 1; t <= 3; t += 2) {
            locd_engine *e = engine_for(t, depth);
            char what[128];
            snprintf(what, sizeof what, "%s, kernel %s, %u threads, float32", name, kernels[k], t);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, f, n, 0, p));
            same_bytes(p, ref, what);
            snprintf(what, sizeof what, "%s, kernel %s, %u threads, float64", name, kernels[k], t);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f64(e, d, n, 0, p));
            same_bytes(p, ref, what);
            locd_engine_destroy(e);
        }
    }
    locd_pairs_destroy(ref);
    locd_pairs_destroy(p);
    free(d);
    if (keep) {
        setenv("LOCD_KERNEL", keep, 1);
        free(keep);
    } else {
        unsetenv("LOCD_KERNEL");
    }
}

/* 6,000 integer boxes under depth 1 (8 cells): cells of 768 or more
 * entries, 32 x 32 buckets. */
static void fine_buckets_integer_boxes(void)
{
    float *b = integer_boxes(6000, 256, 12, 11);
    check_scene(b, 6000, 1, "integer boxes, depth 1");
    free(b);
}

/* The same kind of scene under depth 2 (64 cells, about 300 entries
 * each): 16 x 16 buckets; and under depth 3 (512 cells, about 40): x slabs
 * only. */
static void coarse_buckets_integer_boxes(void)
{
    float *b = integer_boxes(20000, 256, 6, 12);
    check_scene(b, 20000, 2, "integer boxes, depth 2");
    check_scene(b, 20000, 3, "integer boxes, depth 3");
    free(b);
}

/* Equal boxes (edge 2h) on integer centres: every box has the cell's
 * largest extent, and many touch exactly, so the window's low ends
 * (lo - largest extent) fall exactly on other boxes' starts. */
static void equal_boxes_touching(void)
{
    float *b = integer_boxes(12000, 64, 0, 14);
    size_t i;
    for (i = 0; i < 12000; i++) {
        int a;
        for (a = 0; a < 3; a++)
            b[6 * i + 3 + a] = b[6 * i + a] + 2.0f;
    }
    check_scene(b, 12000, 1, "equal touching boxes, depth 1");
    check_scene(b, 12000, 2, "equal touching boxes, depth 2");
    free(b);
}

/* Huge boxes over thousands of tiny ones, on slab edges, with duplicates,
 * points and planes: the huge ones are ancestors of every cell. */
static void huge_next_to_tiny(void)
{
    float *b = huge_and_tiny(8000, 13);
    check_scene(b, 8000, 2, "huge next to tiny, depth 2");
    free(b);
}

/* Medium boxes (level 1 under depth 2: extents 4 to 8 on a 64-wide
 * scene) over small ones (the depth-2 cells, about 125 each): each dense
 * cell has about 80 ancestor records, the most narrower than half its edge
 * and some exactly half (wide), so its entries scan the narrow ones by x
 * slab (lc_anc in lib/octree/sweep.c). Every coordinate is a multiple of
 * 1/8, so window ends fall on slab edges and on other boxes' ends; some
 * medium boxes start left of the cells they reach. Under depth 3 the same
 * boxes are two levels apart. */
static float *medium_over_small(size_t n, size_t medium, uint64_t seed)
{
    ts_rng r;
    float *b = ts_boxes(n, &r, seed);
    size_t i;
    for (i = 0; i < n; i++) {
        const double x = (double)(ts_next(&r) % 480) / 8, y = (double)(ts_next(&r) % 480) / 8,
                     z = (double)(ts_next(&r) % 480) / 8;
        if (i < medium) /* extents 4.125 .. 8 */
            put(b + 6 * i, x, y, z, 4 + 0.125 * (double)(1 + ts_next(&r) % 32), 4 + 0.125 * (double)(ts_next(&r) % 33),
                4 + 0.125 * (double)(ts_next(&r) % 33));
        else /* extents 0 .. 1 */
            put(b + 6 * i, x, y, z, 0.125 * (double)(ts_next(&r) % 9), 0.125 * (double)(ts_next(&r) % 9),
                0.125 * (double)(ts_next(&r) % 9));
    }
    return b;
}

static void narrow_ancestors_by_slab(void)
{
    float *b = medium_over_small(10000, 2000, 15);
    check_scene(b, 10000, 2, "medium over small, depth 2");
    check_scene(b, 10000, 3, "medium over small, depth 3");
    free(b);
}

/* Every box identical: one cell holds them all, every bucket run but one is
 * empty, and every pair ties on every end. */
static void all_identical(void)
{
    const size_t n = 1500;
    float *b = malloc(n * 6 * sizeof *b);
    size_t i;
    TEST_ASSERT_NOT_NULL(b);
    for (i = 0; i < n; i++)
        put(b + 6 * i, 1, 2, 3, 0.5, 0.5, 0.5);
    check_scene(b, n, 0, "identical boxes");
    free(b);
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(fine_buckets_integer_boxes),
        LT_TEST(coarse_buckets_integer_boxes),
        LT_TEST(equal_boxes_touching),
        LT_TEST(huge_next_to_tiny),
        LT_TEST(narrow_ancestors_by_slab),
        LT_TEST(all_identical),
    };
    return LT_RUN(tests);
}
