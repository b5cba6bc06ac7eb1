/* Hard inputs never break exactness: where the faces lie and what numbers
 * they are. Touching faces, edges and corners (at dyadic and decimal
 * values), faces on the octree's cell boundaries at every level, scenes far
 * from the origin (to 1e30) and scaled down (to 1e-300), extents that
 * overflow (+-FLT_MAX, +-DBL_MAX), subnormals and -0, float64 values that
 * float32 cannot hold; then a randomized search mixing them. Every scene
 * through every engine against brute force, and the same pair order within
 * a group of knobs (hard_cases_util.h). The scene's shapes are in
 * test_hard_cases_shapes.c, bad input in test_hard_cases_input.c.
 *
 * Environment: LOCD_HARD_BUDGET_MS (the randomized search's time, default
 * 3000), LOCD_HARD_SEED (its seed); hard_cases_util.h has the others.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "runner.h"

#include "hard_cases_util.h"

/* Table of nv values starting at x0, each the next representable float
 * (or double) after the previous: a lattice in units of the local ulp. */
static void ulp_table_f32(double *v, size_t nv, float x0)
{
    size_t k;
    float x = x0;
    for (k = 0; k < nv; k++) {
        v[k] = x;
        x = nextafterf(x, INFINITY);
    }
}

static void ulp_table_f64(double *v, size_t nv, double x0)
{
    size_t k;
    double x = x0;
    for (k = 0; k < nv; k++) {
        v[k] = x;
        x = nextafter(x, INFINITY);
    }
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* ------------------------------------------------------------------ */
/* Touching faces, edges and corners                                  */
/* ------------------------------------------------------------------ */

static void lattice(hc_scene *s, int m, int parity_mode, double step, double size)
{
    int x, y, z;
    for (z = 0; z < m; z++)
        for (y = 0; y < m; y++)
            for (x = 0; x < m; x++) {
                if (parity_mode == 1 && (x + y + z) % 2) /* checkerboard: edges, no faces */
                    continue;
                if (parity_mode == 2 && !((x % 2 == y % 2) && (y % 2 == z % 2))) /* corners only */
                    continue;
                hc_scene_add(s, x * step, y * step, z * step, x * step + size, y * step + size, z * step + size);
            }
}

static void touching_faces_edges_corners(void)
{
    static const struct {
        int m, mode;
        const char *name;
    } cases[] = {{16, 0, "unit lattice: faces, edges, corners"},
                 {21, 1, "checkerboard: edges and corners only"},
                 {26, 2, "corners only"}};
    size_t c;
    for (c = 0; c < 3; c++) {
        hc_scene s = {0};
        float *f;
        lattice(&s, cases[c].m, cases[c].mode, 1.0, 1.0);
        TEST_ASSERT_TRUE(s.n >= HC_PAR);
        f = hc_narrow(s.b, s.n);
        hc_check_both(f, s.n, cases[c].name);
        free(f);
        hc_scene_free(&s);
    }
}

/* Non-dyadic coordinates: faces meet at values like 0.1 * k, exact in the
 * input precision but not in binary. */
static void touching_at_decimal_values(void)
{
    double v64[48], v32[48], back[48];
    ts_rng r;
    size_t k;
    hc_scene s = {0};
    float *f;
    double *d;
    for (k = 0; k < 48; k++) {
        v64[k] = (double)k * 0.1 - 2.3;
        v32[k] = (float)((float)k * 0.1f - 2.3f);
        back[k] = (double)(float)v64[k]; /* double -> float -> double */
    }
    qsort(v32, 48, sizeof(double), cmp_double);
    ts_seed(&r, 11);
    hc_add_table_boxes(&s, &r, 5000, v64, 48, 2);
    hc_check_f64(s.b, s.n, "decimal faces, float64");
    /* The same scene rounded to float32: touching faces still touch. */
    f = hc_narrow(s.b, s.n);
    hc_check_both(f, s.n, "decimal faces rounded to float32 (and back to float64)");
    free(f);
    hc_scene_free(&s);
    ts_seed(&r, 12);
    hc_add_table_boxes(&s, &r, 5000, v32, 48, 3);
    f = hc_narrow(s.b, s.n);
    hc_check_both(f, s.n, "decimal faces computed in float32");
    free(f);
    hc_scene_free(&s);
    ts_seed(&r, 13);
    hc_add_table_boxes(&s, &r, 5000, back, 48, 1);
    d = s.b;
    hc_check_f64(d, s.n, "float64 -> float32 -> float64 round trip");
    hc_scene_free(&s);
}

/* ------------------------------------------------------------------ */
/* Faces on octree cell boundaries, at every level                    */
/* ------------------------------------------------------------------ */

/* The root cube is fitted to the scene: with the scene spanning exactly
 * [lo, lo + S] on its widest axis, the fraction j / 2^L of S is a cell
 * boundary of level L. Boxes get faces on such fractions for every L. */
static void cell_boundary_scene(hc_scene *s, ts_rng *r, size_t count, double lo, double S, int maxL, double yshrink)
{
    size_t i;
    int a;
    hc_scene_add(s, lo, lo, lo, lo, lo, lo);                      /* pins the root cube's low corner */
    hc_scene_add(s, lo + S, lo + S * yshrink, lo + S, lo + S, lo + S * yshrink, lo + S); /* ... and its far corner */
    for (i = 2; i < count; i++) {
        double bl[3], bh[3];
        for (a = 0; a < 3; a++) {
            int L = (int)hc_rnd(r, (uint64_t)maxL + 1);
            double frac = a == 1 ? yshrink : 1.0; /* the axis spans frac * S */
            double cell = ldexp(S, -L), ext = frac * S;
            uint64_t ncell = (uint64_t)ldexp(frac, L); /* whole cells of level L on the axis */
            uint64_t j = hc_rnd(r, ncell + 1), w = hc_rnd(r, 3);
            bl[a] = lo + (double)j * cell;
            bh[a] = lo + (double)(j + w) * cell;
            if (bh[a] > lo + ext)
                bh[a] = lo + ext;
        }
        hc_scene_add(s, bl[0], bl[1], bl[2], bh[0], bh[1], bh[2]);
    }
}

static void faces_on_cell_boundaries(void)
{
    static const struct {
        double lo, S;
        int maxL;
        double yshrink;
        int f32;
        const char *name;
    } cases[] = {
        {0.0, 2097152.0, 21, 1.0, 1, "float32, root [0, 2^21], levels 0..21"},
        {-1048576.0, 2097152.0, 21, 0.25, 1, "float32, root [-2^20, 2^20], flat y, levels 0..21"},
        {6291456.0, 2097152.0, 21, 1.0, 1, "float32, root [3*2^21, 4*2^21], levels 0..21"},
        {0.0, 1.0, 40, 1.0, 0, "float64, root [0, 1], levels 0..40"},
        {-3.0, 4.0, 30, 0.5, 0, "float64, root [-3, 1], flat y, levels 0..30"},
        {1e6, 1024.0, 45, 1.0, 0, "float64, root [1e6, 1e6 + 1024], levels 0..45"},
    };
    size_t c;
    for (c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        hc_scene s = {0};
        ts_rng r;
        ts_seed(&r, 100 + c);
        cell_boundary_scene(&s, &r, 6000, cases[c].lo, cases[c].S, cases[c].maxL, cases[c].yshrink);
        if (cases[c].f32) {
            float *f = hc_narrow(s.b, s.n);
            size_t k;
            for (k = 0; k < 6 * s.n; k++) /* the fractions are exact in float32 */
                TEST_ASSERT_TRUE((double)f[k] == s.b[k]);
            hc_check_both(f, s.n, cases[c].name);
            free(f);
        } else {
            hc_check_f64(s.b, s.n, cases[c].name);
        }
        hc_scene_free(&s);
    }
}

/* ------------------------------------------------------------------ */
/* Far from the origin, and scaled down                               */
/* ------------------------------------------------------------------ */

static void translated_far_from_origin(void)
{
    static const double offsets[] = {1e3, 1e6, 1e10, 1e20, 1e30, -1e30, -1e7};
    size_t c;
    /* The light run (sanitizers) takes every third offset: 1e3, 1e20, -1e7. */
    for (c = 0; c < sizeof offsets / sizeof offsets[0]; c += hc_heavy() ? 1 : 3) {
        double v[40];
        char name[96];
        hc_scene s = {0};
        ts_rng r;
        float *f;
        size_t k;
        /* A lattice in float32 ulp steps at the offset: exact touching there. */
        ts_seed(&r, 200 + c);
        ulp_table_f32(v, 40, (float)offsets[c]);
        hc_add_table_boxes(&s, &r, 4500, v, 40, 3);
        f = hc_narrow(s.b, s.n);
        snprintf(name, sizeof name, "float32 ulp lattice at %g", offsets[c]);
        hc_check_both(f, s.n, name);
        free(f);
        hc_scene_free(&s);
        /* The same in float64 ulp steps. */
        ts_seed(&r, 300 + c);
        ulp_table_f64(v, 40, offsets[c]);
        hc_add_table_boxes(&s, &r, 4500, v, 40, 3);
        snprintf(name, sizeof name, "float64 ulp lattice at %g", offsets[c]);
        hc_check_f64(s.b, s.n, name);
        hc_scene_free(&s);
        /* A unit-size scene moved there: coordinates round, whatever they
           round to is the input the answer must follow. */
        {
            /* Past ~1e7 (float32) or ~1e15 (float64) the unit scene collapses
               to a few points: every pair overlaps, so keep those small. */
            const size_t m = fabs(offsets[c]) < 1e7 ? 4200 : 600;
            float *u = ts_scene(2, m, 400 + c);
            double *d = hc_widen(u, m);
            for (k = 0; k < 6 * m; k++)
                d[k] += offsets[c];
            snprintf(name, sizeof name, "mixed scene + %g, float64", offsets[c]);
            hc_check_f64(d, m, name);
            f = hc_narrow(d, m);
            snprintf(name, sizeof name, "mixed scene + %g, rounded to float32", offsets[c]);
            hc_check_both(f, m, name);
            free(f);
            free(d);
            free(u);
        }
    }
}

static void scaled_down_to_1e_30(void)
{
    static const double scales[] = {1e-30, 0x1p-100, 1e-300};
    size_t c, k;
    for (c = 0; c < 3; c += hc_heavy() ? 1 : 2) { /* light run: 1e-30 and 1e-300 */
        hc_scene s = {0};
        char name[96];
        float *u = ts_scene(3, 4200, 500 + c); /* touching unit lattice */
        double *d = hc_widen(u, 4200);
        lattice(&s, 16, 0, 1.0, 1.0);
        for (k = 0; k < 6 * s.n; k++)
            s.b[k] *= scales[c];
        for (k = 0; k < 6 * 4200; k++)
            d[k] = d[k] * scales[c] + 3.0 * scales[c];
        snprintf(name, sizeof name, "lattice scaled by %g, float64", scales[c]);
        hc_check_f64(s.b, s.n, name);
        hc_check_f64(d, 4200, name);
        if (scales[c] > 1e-35) {
            float *f = hc_narrow(s.b, s.n), *g = hc_narrow(d, 4200);
            snprintf(name, sizeof name, "lattice scaled by %g, float32", scales[c]);
            hc_check_both(f, s.n, name);
            hc_check_both(g, 4200, name);
            free(f);
            free(g);
        }
        free(d);
        free(u);
        hc_scene_free(&s);
    }
}

/* ------------------------------------------------------------------ */
/* Near the largest finite values: max - min overflows                */
/* ------------------------------------------------------------------ */

static void extent_overflows(void)
{
    double v[24];
    size_t k;
    ts_rng r;
    hc_scene s = {0};
    float *f;
    /* float32: +-FLT_MAX and their neighbours, and a few ordinary values. */
    {
        float x = -FLT_MAX, y = FLT_MAX;
        for (k = 0; k < 8; k++) {
            v[k] = x;
            v[23 - k] = y;
            x = nextafterf(x, 0.0f);
            y = nextafterf(y, 0.0f);
        }
        v[8] = -1e30;
        v[9] = -1.0;
        v[10] = -0.0;
        v[11] = 0.0;
        v[12] = 1e-30;
        v[13] = 1.0;
        v[14] = 3.0e38;
        v[15] = 3.1e38;
        qsort(v, 24, sizeof(double), cmp_double);
    }
    ts_seed(&r, 600);
    hc_add_table_boxes(&s, &r, 4400, v, 24, 4);
    hc_scene_add(&s, -FLT_MAX, -FLT_MAX, -FLT_MAX, FLT_MAX, FLT_MAX, FLT_MAX); /* contains everything */
    f = hc_narrow(s.b, s.n);
    hc_check_both(f, s.n, "float32 near +-FLT_MAX");
    free(f);
    hc_scene_free(&s);
    /* float64: +-DBL_MAX; here even max/2 - min/2 is the largest double. */
    {
        double x = -DBL_MAX, y = DBL_MAX;
        for (k = 0; k < 8; k++) {
            v[k] = x;
            v[23 - k] = y;
            x = nextafter(x, 0.0);
            y = nextafter(y, 0.0);
        }
        v[8] = -1e300;
        v[9] = -FLT_MAX;
        v[10] = -0.0;
        v[11] = 0.0;
        v[12] = 1e-300;
        v[13] = FLT_MAX;
        v[14] = 1e307;
        v[15] = 1.7e308;
        qsort(v, 24, sizeof(double), cmp_double);
    }
    ts_seed(&r, 601);
    hc_add_table_boxes(&s, &r, 4400, v, 24, 4);
    hc_check_f64(s.b, s.n, "float64 near +-DBL_MAX");
    /* One axis spans everything, the others are ordinary. */
    for (k = 0; k < s.n; k++) {
        s.b[6 * k + 1] = s.b[6 * k + 4] = (double)(k % 7);
        s.b[6 * k + 2] = (double)(k % 5);
        s.b[6 * k + 5] = (double)(k % 5) + 1.0;
    }
    hc_check_f64(s.b, s.n, "float64 near +-DBL_MAX on x only");
    hc_scene_free(&s);
}

/* ------------------------------------------------------------------ */
/* Subnormals and negative zero                                       */
/* ------------------------------------------------------------------ */

static void subnormals_and_negative_zero(void)
{
    double v[16];
    ts_rng r;
    int world;
    /* world 0: float32 subnormals only (the scene's extent is subnormal);
       1: float32 subnormals beside ordinary values; 2 and 3: the same in
       float64, where a subnormal extent overflows 2^31 / extent. */
    for (world = 0; world < 4; world++) {
        hc_scene s = {0};
        float *f;
        char name[80];
        size_t k = 0;
        const int f64 = world >= 2, mixed = world % 2;
        const double tm = f64 ? 0x1p-1074 : 0x1p-149, mn = f64 ? DBL_MIN : FLT_MIN;
        const double one = mixed ? 1.0 : tm;
        v[k++] = -3 * tm;
        v[k++] = -tm;
        v[k++] = -0.0;
        v[k++] = 0.0;
        v[k++] = tm;
        v[k++] = 2 * tm;
        v[k++] = 3 * tm;
        v[k++] = mn - tm; /* the largest subnormal */
        v[k++] = -(mn - tm);
        if (mixed) {
            v[k++] = mn;
            v[k++] = -mn;
            v[k++] = 1.0;
            v[k++] = -1.0;
        }
        qsort(v, k, sizeof(double), cmp_double);
        ts_seed(&r, 1000 + (uint64_t)world);
        hc_add_table_boxes(&s, &r, 4400, v, k, hc_heavy() ? 2 : 1); /* light run: fewer pairs */
        /* Explicit -0 / +0 contacts: -0 <= +0 and +0 <= -0 both hold. */
        hc_scene_add(&s, -one, -0.0, -0.0, -0.0, 0.0, 0.0);
        hc_scene_add(&s, 0.0, 0.0, -0.0, one, -0.0, 0.0);
        hc_scene_add(&s, -0.0, -0.0, -0.0, -0.0, -0.0, -0.0);
        hc_scene_add(&s, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        snprintf(name, sizeof name, "subnormals and -0 (%s, %s)", f64 ? "float64" : "float32",
                 mixed ? "beside ordinary values" : "subnormal extent");
        if (f64) {
            hc_check_f64(s.b, s.n, name);
        } else {
            f = hc_narrow(s.b, s.n);
            hc_check_both(f, s.n, name);
            free(f);
        }
        hc_scene_free(&s);
    }
}

/* ------------------------------------------------------------------ */
/* Float64 values that float32 cannot hold                            */
/* ------------------------------------------------------------------ */

static void float64_not_representable_in_float32(void)
{
    static const struct {
        double base, step;
        const char *name;
    } cases[] = {{1.0, 0x1p-40, "1 + k * 2^-40"}, {1e5, 1e-4, "1e5 + k * 1e-4 (the far scene's scale)"},
                 {-3.0, 0x1p-30, "-3 + k * 2^-30"}};
    size_t c;
    for (c = 0; c < 3; c++) {
        double v[32];
        hc_scene s = {0};
        ts_rng r;
        size_t k, m64, m32;
        float *f;
        uint64_t *a, *b;
        for (k = 0; k < 32; k++)
            v[k] = cases[c].base + (double)k * cases[c].step;
        ts_seed(&r, 1100 + c);
        hc_add_table_boxes(&s, &r, 4500, v, 32, 1);
        m64 = hc_check_f64(s.b, s.n, cases[c].name);
        /* The test means something only if float32 rounding changes the answer. */
        f = hc_narrow(s.b, s.n);
        a = hc_reference(s.b, s.n, 1, &m64);
        b = hc_reference(f, s.n, 0, &m32);
        TEST_ASSERT_TRUE(m32 != m64 || memcmp(a, b, m64 * sizeof *a) != 0);
        free(a);
        free(b);
        free(f);
        hc_scene_free(&s);
    }
}

/* ------------------------------------------------------------------ */
/* Randomized search over the ingredients above                       */
/* ------------------------------------------------------------------ */

/* One axis-value table mixing the ingredients: an offset (zero, far,
 * near the largest value, subnormal), a step (ulps, dyadic, decimal,
 * twelve orders of magnitude), -0 and +0. */
static size_t random_table(ts_rng *r, double *v, int f64)
{
    size_t nv = 2 + (size_t)hc_rnd(r, 30), k;
    const double big = f64 ? DBL_MAX : FLT_MAX, tiny = f64 ? 0x1p-1074 : 0x1p-149;
    static const double offs[] = {0.0, 1.0, -1.0, 1e3, -1e6, 1e10, 1e20, 1e30, -1e30, 0.5, 1e-30};
    double off = offs[hc_rnd(r, sizeof offs / sizeof offs[0])];
    uint64_t style = hc_rnd(r, 7);
    for (k = 0; k < nv; k++) {
        switch (style) {
        case 0: /* ulp lattice at the offset */
            v[k] = k ? (f64 ? nextafter(v[k - 1], INFINITY) : nextafterf((float)v[k - 1], INFINITY))
                     : (f64 ? off : (double)(float)off);
            break;
        case 1: /* dyadic fractions */
            v[k] = off + ldexp((double)hc_rnd(r, 64), -(int)hc_rnd(r, 30));
            break;
        case 2: /* decimal steps */
            v[k] = off + 0.1 * (double)hc_rnd(r, 40);
            break;
        case 3: /* twelve orders of magnitude */
            v[k] = off + (hc_rnd(r, 2) ? 1 : -1) * pow(10.0, 12.0 * ts_uniform(r) - 6.0);
            break;
        case 4: /* near the largest values */
            v[k] = (hc_rnd(r, 2) ? big : -big) * (1.0 - ldexp((double)hc_rnd(r, 8), f64 ? -52 : -23));
            break;
        case 5: /* subnormals and zeros */
            v[k] = (hc_rnd(r, 2) ? 1 : -1) * tiny * (double)hc_rnd(r, 6);
            break;
        default: /* a bit of everything */
            v[k] = hc_rnd(r, 4) ? off * (double)hc_rnd(r, 3) + (double)hc_rnd(r, 5) : (hc_rnd(r, 2) ? -0.0 : big * 0.5);
            break;
        }
        if (!f64)
            v[k] = (float)v[k];
        if (!isfinite(v[k]))
            v[k] = 0.0;
    }
    qsort(v, nv, sizeof(double), cmp_double);
    return nv;
}

static void randomized_search(void)
{
    const char *bs = getenv("LOCD_HARD_BUDGET_MS"), *ss = getenv("LOCD_HARD_SEED");
    double budget = bs ? atof(bs) : 3000.0;
    uint64_t seed = ss ? strtoull(ss, NULL, 10) : 20261122u, it;
    struct timespec t0, t1;
    size_t scenes = 0, pairs = 0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (it = 0; it < 1000000; it++) {
        ts_rng r;
        hc_scene s = {0};
        double v[32];
        int f64;
        size_t nv, n, i;
        char name[96];
        double ms;
        clock_gettime(CLOCK_MONOTONIC, &t1);
        ms = (double)(t1.tv_sec - t0.tv_sec) * 1e3 + (double)(t1.tv_nsec - t0.tv_nsec) * 1e-6;
        if (ms > budget)
            break;
        ts_seed(&r, seed * 1000003u + it);
        f64 = (int)hc_rnd(&r, 2);
        /* Every tenth scene is big enough for the parallel path (not in the
           light run: its pair count may be quadratic). */
        n = it % 10 == 9 && hc_heavy() ? HC_PAR + (size_t)hc_rnd(&r, 1000) : 2 + (size_t)hc_rnd(&r, 400);
        if (it % 10 == 4) { /* around a power of two: the index bits and the automatic depth change there */
            static const size_t edges[] = {2, 3, 4, 5, 255, 256, 257, 4096, 4097, 8192, 8193};
            n = edges[hc_rnd(&r, hc_heavy() ? 11 : 7)];
        }
        nv = random_table(&r, v, f64);
        hc_add_table_boxes(&s, &r, n, v, nv, (size_t)hc_rnd(&r, 5));
        /* Extra ingredients: duplicates, a container, a second table. */
        for (i = 0; i < n / 8; i++)
            if (hc_rnd(&r, 4) == 0)
                memmove(s.b + 6 * hc_rnd(&r, n), s.b + 6 * hc_rnd(&r, n), 6 * sizeof(double));
        if (hc_rnd(&r, 4) == 0) {
            size_t at = (size_t)hc_rnd(&r, n);
            s.b[6 * at] = s.b[6 * at + 1] = s.b[6 * at + 2] = v[0];
            s.b[6 * at + 3] = s.b[6 * at + 4] = s.b[6 * at + 5] = v[nv - 1];
        }
        if (hc_rnd(&r, 3) == 0) {
            hc_scene t = {0};
            nv = random_table(&r, v, f64);
            hc_add_table_boxes(&t, &r, n / 3 + 1, v, nv, 2);
            for (i = 0; i < t.n; i++)
                memcpy(s.b + 6 * hc_rnd(&r, n), t.b + 6 * i, 6 * sizeof(double));
            hc_scene_free(&t);
        }
        snprintf(name, sizeof name, "random scene (LOCD_HARD_SEED=%llu, iteration %llu)", (unsigned long long)seed,
                 (unsigned long long)it);
        if (f64) {
            pairs += hc_check_f64(s.b, n, name);
        } else {
            float *f = hc_narrow(s.b, n);
            pairs += hc_check_f32(f, n, name);
            free(f);
        }
        scenes++;
        hc_scene_free(&s);
    }
    LT_PRINT("# randomized search: %zu scenes, %zu pairs, seed %llu, budget %.0f ms\n", scenes, pairs,
             (unsigned long long)seed, budget);
    TEST_ASSERT_TRUE(scenes > 0);
    hc_trim_runners();
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(touching_faces_edges_corners),
        LT_TEST(touching_at_decimal_values),
        LT_TEST(faces_on_cell_boundaries),
        LT_TEST(translated_far_from_origin),
        LT_TEST(scaled_down_to_1e_30),
        LT_TEST(extent_overflows),
        LT_TEST(subnormals_and_negative_zero),
        LT_TEST(float64_not_representable_in_float32),
        LT_TEST(randomized_search),
    };
    return LT_RUN_GROUP(tests, hc_group_setup, hc_group_teardown);
}
