/* The encode step's vector bodies (lib/octree/encode_impl.h: AVX2, four
 * boxes a step; AVX-512, eight) against its scalar body: the same entries in
 * the same order and the same packed sweep boxes, byte for byte, for every
 * kernel this CPU has. The scenes put boxes on cell edges, make them zero
 * size or as wide as the scene, give them one to eight cells, and end with
 * a count that is not a multiple of a step (the scalar body finishes it);
 * each runs in both precisions, with and without bounding cubes, over
 * biases 0 to 3 and several depths, and from an offset (`first`) that is
 * not a multiple of a step either. A failure names the case. The level rule
 * itself (lc_level_of) is checked against exact integer arithmetic. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "core/core.h"
#include "octree/octree.h"
#include "support.h"

/* Kind 0: uniform boxes of one size; 1: sizes over three orders of
 * magnitude; 2: integer coordinates (ends on cell edges), some of zero size;
 * 3: a few boxes as wide as the scene among small ones; 4: points (the
 * deepest level: cell coordinates up to 2^depth, every bit of the Morton
 * spread in use); 5: a triangle's boxes (one axis flat, the others of
 * different lengths) and needles, which lc_level_of puts deeper than their
 * largest extent alone would. */
static void make_scene(int kind, size_t n, uint64_t seed, double *b)
{
    ts_rng r;
    size_t i;
    int a;
    ts_seed(&r, seed);
    for (i = 0; i < n; i++) {
        double *x = b + 6 * i;
        for (a = 0; a < 3; a++) {
            double lo, ext;
            switch (kind) {
            case 0:
                lo = ts_uniform(&r) * 100.0, ext = 1.5;
                break;
            case 1:
                lo = ts_uniform(&r) * 100.0, ext = 0.01 * (double)(1u << (ts_next(&r) % 11));
                break;
            case 2:
                lo = (double)(ts_next(&r) % 64), ext = (double)(ts_next(&r) % 3);
                break;
            case 3:
                lo = ts_uniform(&r) * 100.0, ext = i % 97 == 0 ? 100.0 : 0.5;
                break;
            case 4:
                lo = ts_uniform(&r) * 100.0, ext = 0.0;
                break;
            default:
                lo = ts_uniform(&r) * 100.0;
                ext = a == (int)(i % 3) ? 0.0 : a == (int)((i + 1) % 3) ? 3.0 : 3.0 * ts_uniform(&r) * (i % 2);
                break;
            }
            x[a] = lo - 50.0;
            x[a + 3] = lo - 50.0 + ext;
        }
    }
}

/* Encodes boxes [first, first + count) with `kernel` into out and qbox
 * (zeroed first); returns the entries written. */
static size_t encode_with(int kernel, int f64, const locd_grid *g, const double *d, const float *f, size_t first,
                          size_t count, uint64_t *out, size_t cap, uint64_t *qbox, size_t n)
{
    size_t needed = 0, w;
    memset(out, 0, cap * sizeof *out);
    memset(qbox, 0, 2 * n * sizeof *qbox);
    w = f64 ? lc_encode_f64(g, d, first, count, out, cap, &needed, qbox, kernel)
            : lc_encode_f32(g, f, first, count, out, cap, &needed, qbox, kernel);
    TEST_ASSERT_TRUE(w != (size_t)-1);
    return w;
}

static void every_kernel_encodes_the_scalar_bytes(void)
{
    const size_t n = 1003, first = 5, count = n - first; /* 998: not a multiple of 4 or 8 */
    const uint32_t depths[] = {0, 2, 6, 8, 9, 12, 16, 17, 21};
    const int best = lc_kernel_choose();
    double *d = malloc(n * 6 * sizeof *d);
    float *f = malloc(n * 6 * sizeof *f);
    uint64_t *ref = malloc(8 * n * sizeof *ref), *got = malloc(8 * n * sizeof *got);
    uint64_t *qref = malloc(2 * n * sizeof *qref), *qgot = malloc(2 * n * sizeof *qgot);
    int kind, f64, cubes, bias, kernel, compared = 0;
    size_t di, i;
    TEST_ASSERT_TRUE(d && f && ref && got && qref && qgot);
    for (kind = 0; kind < 6; kind++) {
        make_scene(kind, n, 90 + (uint64_t)kind, d);
        for (i = 0; i < 6 * n; i++) /* the float scene's boxes, widened exactly: the same boxes */
            f[i] = (float)d[i], d[i] = (double)f[i];
        for (f64 = 0; f64 < 2; f64++)
            for (cubes = 0; cubes < 2; cubes++)
                for (bias = 0; bias <= 3; bias++)
                    for (di = 0; di < sizeof depths / sizeof *depths; di++) {
                        locd_grid g;
                        size_t wref;
                        char what[128];
                        memset(&g, 0, sizeof g);
                        g.size = sizeof g;
                        TEST_ASSERT_EQUAL_INT(LOCD_OK, f64 ? locd_grid_fit_f64(d, n, depths[di], bias,
                                                                               cubes ? LOCD_CONFIG_CUBES : 0, &g)
                                                           : locd_grid_fit_f32(f, n, depths[di], bias,
                                                                               cubes ? LOCD_CONFIG_CUBES : 0, &g));
                        wref = encode_with(LC_KERNEL_SCALAR, f64, &g, d, f, first, count, ref, 8 * n, qref, n);
                        for (kernel = LC_KERNEL_SCALAR + 1; kernel <= best; kernel++) {
                            size_t w = encode_with(kernel, f64, &g, d, f, first, count, got, 8 * n, qgot, n);
                            snprintf(what, sizeof what, "kind %d f64 %d cubes %d bias %d depth %u kernel %d", kind,
                                     f64, cubes, bias, g.depth, kernel);
                            TEST_ASSERT_EQUAL_UINT64_MESSAGE(wref, w, what);
                            TEST_ASSERT_EQUAL_MEMORY_MESSAGE(ref, got, wref * sizeof *ref, what);
                            TEST_ASSERT_EQUAL_MEMORY_MESSAGE(qref, qgot, 2 * n * sizeof *qref, what);
                            compared++;
                        }
                    }
    }
    if (best > LC_KERNEL_SCALAR && best != LC_KERNEL_NEON) /* an x86-64 CPU with AVX2: something was compared */
        TEST_ASSERT_TRUE(compared > 0);
    free(d), free(f), free(ref), free(got), free(qref), free(qgot);
}

/* Whether a box of extents e spans on average at most (1 + 2^-bias)^3 cells
 * of level l, within a relative 2^-40 (lc_level_of rounds its product to
 * doubles): (c + e0)(c + e1)(c + e2) 2^(3 bias) <= (2^bias + 1)^3 c^3, c the
 * cell edge 2^(31 - l), in exact 128-bit integers. `slack` 1 allows the
 * rounding one way, -1 the other. */
__extension__ typedef unsigned __int128 u128;

static int spread_within(const uint32_t e[3], int bias, uint32_t l, int slack)
{
    const u128 c = (u128)1 << (LC_QBITS - l), f = ((u128)1 << bias) + 1;
    const u128 lhs = ((c + e[0]) * (c + e[1]) * (c + e[2])) << (3 * bias);
    u128 rhs = f * f * f * c * c * c;
    rhs = slack > 0 ? rhs + (rhs >> 40) : rhs - (rhs >> 40);
    return lhs <= rhs;
}

static void a_box_goes_as_deep_as_its_spread_allows(void)
{
    ts_rng r;
    int k, bias;
    /* By hand, bias 2, depth 21, w = 2^20 - 1 (lc_level_for: 31 - 2 - 20 = 9,
       the deepest with a cell above w: 11). A cube at level 10 would span
       1.5^3 cells, a square 1.5^2, both above 1.953: they stay at 9. A
       triangle's box (w, w/2, 0) spans 1.5 x 1.25 = 1.875 there, and a
       needle 1.5; at level 11 both span about 2: they go to 10. */
    const uint32_t w = (1u << 20) - 1, cube[3] = {w, w, w}, square[3] = {w, w, 0}, tri[3] = {w, w / 2, 0},
                   needle[3] = {0, w, 0};
    TEST_ASSERT_EQUAL_UINT32(9, lc_level_of(cube, 2, 21));
    TEST_ASSERT_EQUAL_UINT32(9, lc_level_of(square, 2, 21));
    TEST_ASSERT_EQUAL_UINT32(10, lc_level_of(tri, 2, 21));
    TEST_ASSERT_EQUAL_UINT32(10, lc_level_of(needle, 2, 21));
    TEST_ASSERT_EQUAL_UINT32(7, lc_level_of(tri, 2, 7)); /* the depth still caps it */
    ts_seed(&r, 4242);
    for (k = 0; k < 200000; k++) {
        uint32_t e[3], m, l, lo, top, depth = (uint32_t)(ts_next(&r) % 22);
        int a;
        bias = (int)(ts_next(&r) % 9);
        for (a = 0; a < 3; a++) { /* lengths from 0 to 2^31 - 1, flat axes and cubes often */
            const uint32_t bits = (uint32_t)(ts_next(&r) % 32);
            e[a] = bits ? (uint32_t)(ts_next(&r) & ((1ull << bits) - 1)) : 0;
        }
        if (k % 4 == 1)
            e[1] = e[2] = e[0];
        else if (k % 4 == 2)
            e[ts_next(&r) % 3] = 0;
        m = lc_max3(e);
        l = lc_level_of(e, bias, depth);
        lo = lc_level_for(m, bias, depth);
        top = lc_level_for(m, 0, depth);
        TEST_ASSERT_TRUE(l >= lo && l <= top); /* the cell's edge stays above the largest extent */
        if (l > lo)
            TEST_ASSERT_TRUE(spread_within(e, bias, l, 1));
        if (l < top)
            TEST_ASSERT_FALSE(spread_within(e, bias, l + 1, -1));
        if (e[1] == e[0] && e[2] == e[0] && (m & (m - 1)) != 0)
            TEST_ASSERT_EQUAL_UINT32(lo, l); /* a cube (not a power of two) keeps the largest extent's level */
    }
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(every_kernel_encodes_the_scalar_bytes),
        LT_TEST(a_box_goes_as_deep_as_its_spread_allows),
    };
    return LT_RUN(tests);
}
