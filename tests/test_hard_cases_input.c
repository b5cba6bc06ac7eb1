/* Bad input, through every engine (hard_cases_util.h): a NaN, an infinity
 * or an inverted box anywhere is refused with the index of the first bad
 * box, and the output kept; a scene that would give 2^41 pairs, with one
 * bad box, fails at validation before any quadratic work; empty scenes,
 * one box, NULL pointers, unknown flags; bad configuration sizes and
 * values. */
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "runner.h"

#include "hard_cases_util.h"

/* A scene that would give 2^41 pairs, with one bad box: the call fails at
 * validation, before any quadratic work, and names the right box. */
static void huge_scene_with_bad_box_fails_fast(void)
{
    const size_t n = hc_heavy() ? (size_t)1 << 21 : (size_t)1 << 16;
    float *u = malloc(n * 6 * sizeof(float));
    double *d;
    size_t i, bad[3] = {n - 1, n / 2 + 3, 1};
    size_t t;
    static const uint32_t threads[] = {1, 2, 3, 8};
    TEST_ASSERT_NOT_NULL(u);
    for (i = 0; i < n; i++) {
        float b[6] = {1, 2, 3, 4, 5, 6};
        memcpy(u + 6 * i, b, sizeof b);
    }
    for (t = 0; t < 4; t++) {
        hc_counter ce = {0, 0, (size_t)-1, 0};
        locd_engine *e = hc_counted_engine(threads[t], &ce);
        locd_pairs *p;
        size_t k;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
        for (k = 0; k < 3; k++) {
            size_t before = ce.cur;
            double t0;
            locd_status st;
            float save = u[6 * bad[k] + 4];
            float save2 = u[6 * (n - 1) + 2];
            /* bad[k] gets min > max on y; box n-1 also gets a NaN (later index) */
            u[6 * bad[k] + 4] = 1.0f;
            if (bad[k] != n - 1)
                u[6 * (n - 1) + 2] = NAN;
            ce.peak = ce.cur;
            t0 = (double)clock() / CLOCKS_PER_SEC;
            st = locd_engine_find_pairs_f32(e, u, n, 0, p);
            TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVERTED_BOX, st);
            TEST_ASSERT_EQUAL_INT64((int64_t)bad[k], locd_last_error_index());
            TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(p));
            /* No entry buffers were grown for a scene that was refused. */
            TEST_ASSERT_TRUE(ce.peak - before < ((size_t)1 << 20));
            TEST_ASSERT_TRUE((double)clock() / CLOCKS_PER_SEC - t0 < 5.0);
            u[6 * bad[k] + 4] = save;
            u[6 * (n - 1) + 2] = save2;
        }
        locd_pairs_destroy(p);
        locd_engine_destroy(e);
    }
    /* The same in float64, NaN first. */
    d = hc_widen(u, n);
    free(u);
    d[6 * 77 + 5] = NAN;
    d[6 * (n / 2) + 0] = 7.0;
    for (t = 0; t < 4; t++) {
        hc_counter ce = {0, 0, (size_t)-1, 0};
        locd_engine *e = hc_counted_engine(threads[t], &ce);
        locd_pairs *p;
        size_t before = ce.cur;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
        ce.peak = ce.cur;
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_f64(e, d, n, 0, p));
        TEST_ASSERT_EQUAL_INT64(77, locd_last_error_index());
        TEST_ASSERT_TRUE(ce.peak - before < ((size_t)1 << 20));
        locd_pairs_destroy(p);
        locd_engine_destroy(e);
    }
    free(d);
}

/* Puts a known result into p so tests can see that an error keeps it. */
static void prime(locd_engine *e, locd_pairs *p)
{
    float b[18] = {0, 0, 0, 1, 1, 1, 0.5f, 0.5f, 0.5f, 2, 2, 2, 1, 1, 1, 3, 3, 3};
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, 3, LOCD_FIND_SORTED, p));
    TEST_ASSERT_EQUAL_INT64(3, locd_pairs_count(p));
}

static void assert_primed(const locd_pairs *p)
{
    static const uint32_t want[6] = {0, 1, 0, 2, 1, 2};
    TEST_ASSERT_EQUAL_INT64(3, locd_pairs_count(p));
    TEST_ASSERT_EQUAL_MEMORY(want, locd_pairs_data(p), sizeof want);
}

static void bad_values_name_the_first_bad_box(void)
{
    static const size_t sizes[] = {1, 10, 5000};
    size_t si;
    int r;
    locd_pairs *p;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    for (si = 0; si < 3; si++) {
        size_t n = sizes[si];
        float *u = ts_scene(2, n, 1300 + si);
        double *d = hc_widen(u, n);
        size_t idx[4] = {0, 1, n / 2, n - 1};
        int ii, kind, coord;
        for (r = 0; r < hc_nrunners; r++) {
            if (!hc_runner_wanted(r, n))
                continue;
            for (ii = 0; ii < 4; ii++) {
                size_t at = idx[ii] < n ? idx[ii] : n - 1;
                for (kind = 0; kind < 4; kind++)
                    for (coord = 0; coord < 6; coord++) {
                        float sf = u[6 * at + coord];
                        double sd = d[6 * at + coord];
                        locd_status want = kind < 3 ? LOCD_ERR_NONFINITE : LOCD_ERR_INVERTED_BOX;
                        double bad = kind == 0 ? NAN : kind == 1 ? INFINITY : kind == 2 ? -INFINITY : 0.0;
                        if (kind == 3) /* min > max on this coordinate's axis */
                            bad = coord < 3 ? d[6 * at + coord + 3] + 1.0 : d[6 * at + coord - 3] - 1.0;
                        if (kind != 0 && coord % 2 && n == 5000)
                            continue; /* keep the run short: NaN on all six, the rest on three */
                        u[6 * at + coord] = (float)bad;
                        d[6 * at + coord] = bad;
                        prime(hc_runners[r].e, p);
                        if (locd_engine_find_pairs_f32(hc_runners[r].e, u, n, 0, p) != want ||
                            locd_last_error_index() != (int64_t)at)
                            LT_FAIL("%s: f32 n %zu bad value kind %d at box %zu coord %d: got index %lld (%s)",
                                    hc_runners[r].name, n, kind, at, coord, (long long)locd_last_error_index(),
                                    locd_last_error());
                        assert_primed(p);
                        if (locd_engine_find_pairs_f64(hc_runners[r].e, d, n, 0, p) != want ||
                            locd_last_error_index() != (int64_t)at)
                            LT_FAIL("%s: f64 n %zu bad value kind %d at box %zu coord %d", hc_runners[r].name, n, kind,
                                    at, coord);
                        assert_primed(p);
                        u[6 * at + coord] = sf;
                        d[6 * at + coord] = sd;
                    }
            }
            /* Two bad boxes: the lower index wins whatever its kind. */
            if (n > 2) {
                size_t lo = n > 10 ? n / 3 : 1, hi = n - 1;
                float a = u[6 * lo], b = u[6 * hi + 4];
                u[6 * lo] = u[6 * lo + 3] + 1.0f; /* inverted at lo */
                u[6 * hi + 4] = NAN;              /* NaN at hi */
                prime(hc_runners[r].e, p);
                TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVERTED_BOX, locd_engine_find_pairs_f32(hc_runners[r].e, u, n, 0, p));
                TEST_ASSERT_EQUAL_INT64((int64_t)lo, locd_last_error_index());
                assert_primed(p);
                u[6 * lo] = a;
                u[6 * hi + 4] = b;
                a = u[6 * lo + 2];
                b = u[6 * hi + 1];
                u[6 * lo + 2] = INFINITY;
                u[6 * hi + 1] = u[6 * hi + 4] + 1.0f;
                TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_f32(hc_runners[r].e, u, n, 0, p));
                TEST_ASSERT_EQUAL_INT64((int64_t)lo, locd_last_error_index());
                assert_primed(p);
                u[6 * lo + 2] = a;
                u[6 * hi + 1] = b;
            }
            /* The fixed scene is valid again. */
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(hc_runners[r].e, u, n, 0, p));
        }
        free(u);
        free(d);
    }
    locd_pairs_destroy(p);
}

static void empty_single_and_null_arguments(void)
{
    locd_pairs *p;
    int r;
    float one[6] = {0, 0, 0, 1, 1, 1}, nanbox[6] = {0, 0, 0, 1, NAN, 1};
    double one64[6] = {-1, -1, -1, 1e300, 1e300, 1e300};
    uint32_t buf[8];
    size_t count;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    for (r = 0; r < hc_nrunners; r++) {
        locd_engine *e = hc_runners[r].e;
        if (!hc_runner_wanted(r, 1))
            continue;
        prime(e, p);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, NULL, 0, 0, p));
        TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(p));
        prime(e, p);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f64(e, NULL, 0, LOCD_FIND_SORTED, p));
        TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(p));
        prime(e, p);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, one, 1, 0, p));
        TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(p));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f64(e, one64, 1, 0, p));
        TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(p));
        prime(e, p);
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_f32(e, nanbox, 1, 0, p));
        TEST_ASSERT_EQUAL_INT64(0, locd_last_error_index());
        assert_primed(p);
        /* NULL pointers. */
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f32(e, NULL, 3, 0, p));
        assert_primed(p);
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f64(e, NULL, 3, 0, p));
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f32(e, one, 1, 0, NULL));
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f32_into(e, one, 1, 0, NULL, 4, &count));
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f32_into(e, one, 1, 0, buf, 4, NULL));
        count = 99;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32_into(e, NULL, 0, 0, NULL, 0, &count));
        TEST_ASSERT_EQUAL_INT64(0, count);
        /* Unknown flags are refused, and the output kept. */
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_find_pairs_f32(e, one, 1, 0x80u, p));
    }
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_HANDLE, locd_engine_find_pairs_f32(NULL, one, 1, 0, p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_HANDLE, locd_engine_find_pairs_f64(NULL, one64, 1, 0, p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_brute_force_f32(NULL, 2, p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_brute_force_f32(one, 1, NULL));
    locd_pairs_destroy(p);
}

static void bad_config_sizes_and_values(void)
{
    locd_engine_config cfg;
    locd_engine *e = (locd_engine *)&cfg; /* must be reset to NULL on failure */
    locd_stats stats;
    locd_grid g;
    float one[12] = {0, 0, 0, 1, 1, 1, 1, 1, 1, 2, 2, 2};
    locd_engine_config_init(&cfg);
    cfg.size = 0;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create(&cfg, &e));
    TEST_ASSERT_NULL(e);
    cfg.size = (uint32_t)sizeof cfg + 8; /* a newer struct than this library knows */
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create(&cfg, &e));
    cfg.size = 3;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create(&cfg, &e));
    /* An older, shorter struct (up to `flags`) keeps the defaults for the rest. */
    locd_engine_config_init(&cfg);
    cfg.size = (uint32_t)(offsetof(locd_engine_config, flags) + sizeof cfg.flags);
    cfg.threads = 2;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
    TEST_ASSERT_EQUAL_INT64(2, locd_engine_threads(e));
    locd_engine_destroy(e);
    {
        static const struct {
            int32_t level, bias;
            uint32_t threads, depth;
        } bad[] = {{0, 1, 1, 0}, {4, 1, 1, 0}, {1, -1, 1, 0}, {1, 9, 1, 0}, {1, 1, 65, 0}, {1, 1, 1, 22}, {3, 1, 1, 0}};
        size_t k;
        for (k = 0; k < sizeof bad / sizeof bad[0]; k++) {
            locd_engine_config_init(&cfg);
            cfg.level = bad[k].level;
            cfg.cell_bias = bad[k].bias;
            cfg.threads = bad[k].threads;
            cfg.max_depth = bad[k].depth;
            e = (locd_engine *)&cfg;
            TEST_ASSERT_NOT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
            TEST_ASSERT_NULL(e);
        }
    }
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_create(NULL, NULL));
    /* Stats with a bad size. */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(NULL, &e));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f32(e, one, 2, 0, NULL));
    stats.size = 0;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_stats(e, &stats));
    stats.size = (uint32_t)sizeof stats + 4;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_stats(e, &stats));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_stats(e, NULL));
    locd_engine_destroy(e);
    /* The building blocks refuse bad knobs too. */
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_grid_fit_f32(one, 2, 0, 9, 0, &g));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_grid_fit_f32(one, 2, 0, -1, 0, &g));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_grid_fit_f32(one, 2, 0, 1, 0, NULL));
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(huge_scene_with_bad_box_fails_fast),
        LT_TEST(bad_values_name_the_first_bad_box),
        LT_TEST(empty_single_and_null_arguments),
        LT_TEST(bad_config_sizes_and_values),
    };
    return LT_RUN_GROUP(tests, hc_group_setup, hc_group_teardown);
}
