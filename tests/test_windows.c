/* What a Windows build (scripts/cross/mingw64.ini, run under wine in CI:
 * scripts/ci/steps/35-windows.sh) must do: level 1 gives exactly the
 * closed-interval overlap pairs, synchronously and as a job, on the thread
 * pool (winpthreads); levels 2 and 3 and the service refuse with
 * LOCD_ERR_UNSUPPORTED and a message, leaving nothing behind; the narrow
 * phase, built without libccd and FCL, says it is missing. The reference
 * here is a brute force of this file's own, not the library's. */
#include <locd/pipeline.h>
#include <locd/service.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "support.h"

/* Every (i, j), i < j, whose closed boxes overlap on all three axes. */
static uint32_t *own_brute_force(const float *b, size_t n, size_t *count)
{
    size_t i, j, m = 0, cap = 64;
    uint32_t *p = malloc(cap * 2 * sizeof *p);
    TEST_ASSERT_NOT_NULL(p);
    for (i = 0; i < n; i++)
        for (j = i + 1; j < n; j++) {
            const float *a = b + 6 * i, *c = b + 6 * j;
            if (a[0] <= c[3] && c[0] <= a[3] && a[1] <= c[4] && c[1] <= a[4] && a[2] <= c[5] && c[2] <= a[5]) {
                if (m == cap) {
                    cap *= 2;
                    p = realloc(p, cap * 2 * sizeof *p);
                    TEST_ASSERT_NOT_NULL(p);
                }
                p[2 * m] = (uint32_t)i;
                p[2 * m + 1] = (uint32_t)j;
                m++;
            }
        }
    *count = m;
    return p;
}

static void check_against_own_brute_force(const float *b, size_t n, const locd_pairs *got)
{
    size_t m = 0, k = 0;
    uint32_t *want = own_brute_force(b, n, &m);
    uint32_t *have = ts_sorted_copy(got, &k);
    TEST_ASSERT_EQUAL_UINT64(m, k);
    if (m)
        TEST_ASSERT_EQUAL_UINT32_ARRAY(want, have, 2 * m);
    free(want);
    free(have);
}

static locd_engine *level1_engine(uint32_t threads)
{
    locd_engine_config c;
    locd_engine *e = NULL;
    locd_engine_config_init(&c);
    c.threads = threads;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_create(&c, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_LEVEL_INPROCESS, locd_engine_level(e));
    return e;
}

static void level1_equals_brute_force_every_scene_and_thread_count(void)
{
    static const uint32_t threads[] = {1, 2, 4};
    size_t t;
    int kind;
    for (t = 0; t < sizeof threads / sizeof threads[0]; t++) {
        locd_engine *e = level1_engine(threads[t]);
        locd_pairs *p;
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
        for (kind = 0; kind < TS_SCENE_KINDS; kind++) {
            size_t n = 1500;
            float *b = ts_scene(kind, n, 40u + (uint64_t)kind);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e, b, n, 0, p));
            TEST_ASSERT_TRUE(locd_pairs_count(p) > 0);
            check_against_own_brute_force(b, n, p);
            free(b);
        }
        locd_pairs_destroy(p);
        locd_engine_destroy(e);
    }
}

static void level1_job_equals_brute_force(void)
{
    locd_engine *e = level1_engine(2);
    locd_job *job = NULL;
    locd_pairs *p;
    size_t n = 2000;
    float *b = ts_scene(0, n, 9);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, b, n, 0, &job));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_job_wait(job, -1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_job_take(job, p));
    check_against_own_brute_force(b, n, p);
    locd_job_release(job);
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    free(b);
}

static void level1_reports_bad_box_index(void)
{
    locd_engine *e = level1_engine(2);
    locd_pairs *p;
    float b[18] = {0, 0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1, 2, 2, 2, 1, 3, 3};
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVERTED_BOX, locd_engine_find_pairs_f32(e, b, 3, 0, p));
    TEST_ASSERT_EQUAL_INT64(2, locd_last_error_index());
    TEST_ASSERT_EQUAL_UINT64(0, locd_pairs_count(p));
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
}

/* Creating an engine at `level` fails with LOCD_ERR_UNSUPPORTED, a message
 * naming the level, and no engine. */
static void check_level_unsupported(int32_t level, const char *says)
{
    locd_engine_config c;
    locd_engine *e = (locd_engine *)&c; /* must come back NULL */
    locd_engine_config_init(&c);
    c.level = level;
    c.service_address = "tcp:127.0.0.1:1";
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_UNSUPPORTED, locd_engine_create(&c, &e));
    TEST_ASSERT_NULL(e);
    LT_PRINT("level %d: %s\n", (int)level, locd_last_error());
    TEST_ASSERT_NOT_NULL(strstr(locd_last_error(), says));
}

static void level2_is_unsupported(void)
{
    check_level_unsupported(LOCD_LEVEL_WORKERS, "level 2");
}

static void level3_is_unsupported(void)
{
    check_level_unsupported(LOCD_LEVEL_SERVICE, "level 3");
}

static void service_is_unsupported(void)
{
    locd_service_config c;
    locd_service *s = (locd_service *)&c;
    locd_service_config_init(&c);
    TEST_ASSERT_EQUAL_UINT32(sizeof c, c.size);
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_UNSUPPORTED, locd_service_create(&c, &s));
    TEST_ASSERT_NULL(s);
    TEST_ASSERT_NOT_NULL(strstr(locd_last_error(), "service"));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVALID_HANDLE, locd_service_run(NULL));
    locd_service_stop(NULL);
    locd_service_destroy(NULL);
}

static void narrow_phase_says_it_is_missing(void)
{
    locd_shape *s = (locd_shape *)&s;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_UNSUPPORTED, locd_shape_sphere(1.0, &s));
    TEST_ASSERT_NULL(s);
    TEST_ASSERT_NOT_NULL(strstr(locd_last_error(), "narrow phase"));
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(level1_equals_brute_force_every_scene_and_thread_count),
        LT_TEST(level1_job_equals_brute_force),
        LT_TEST(level1_reports_bad_box_index),
        LT_TEST(level2_is_unsupported),
        LT_TEST(level3_is_unsupported),
        LT_TEST(service_is_unsupported),
        LT_TEST(narrow_phase_says_it_is_missing),
    };
    return LT_RUN(tests);
}
