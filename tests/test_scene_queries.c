/* The scene's queries beyond those every other suite checks against the
 * brute-force model: the float32 entry points (queries, moves and pairs)
 * give what the float64 ones give for the same values, and two threads
 * querying one scene at once each get what one thread alone gets. */
#include <pthread.h>
#include <string.h>

#include "runner.h"

#include "scene_util.h"

/* Queries only read: two threads query one scene at once (TSan watches),
 * each getting what one thread alone gets. */
typedef struct query_job {
    const locd_scene *s;
    uint64_t hash;
    int failed;
} query_job;

static void *query_thread(void *arg)
{
    query_job *j = arg;
    locd_id ids[512];
    double t[512];
    size_t n, i;
    int k;
    uint64_t h = 1469598103934665603ull;
    for (k = 0; k < 300; k++) {
        double q[6], o[3], d[3];
        int a;
        for (a = 0; a < 3; a++) {
            q[a] = (k * 7 % 50) + a, q[a + 3] = q[a] + 5.0;
            o[a] = q[a], d[a] = (a == k % 3) ? 10.0 : 0.5;
        }
        if (locd_scene_query_box_f64(j->s, q, ~(uint64_t)0, ids, 512, &n) != LOCD_OK)
            j->failed = 1;
        for (i = 0; i < n && !j->failed; i++)
            h = (h ^ ids[i]) * 1099511628211ull;
        if (locd_scene_raycast_f64(j->s, o, d, 3.0, ~(uint64_t)0, ids, t, 512, &n) != LOCD_OK)
            j->failed = 1;
        for (i = 0; i < n && !j->failed; i++)
            h = (h ^ ids[i]) * 1099511628211ull;
    }
    j->hash = h;
    return NULL;
}

static void queries_from_two_threads(void)
{
    locd_engine *e = su_new_engine(2, NULL);
    locd_scene *s = NULL;
    su_world w;
    double b[6 * 2000];
    locd_id ids[2000];
    query_job j0, j1, j2;
    pthread_t t1, t2;
    int i;
    memset(&w, 0, sizeof w);
    ts_seed(&w.r, 11);
    w.extent = 60.0, w.size = 2.0;
    for (i = 0; i < 2000; i++)
        su_random_box(&w, b + 6 * i);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, 1500, NULL, ids));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS));
    /* some changed since the update: the queries also try those one by one */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b + 6 * 1500, 500, NULL, ids + 1500));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, ids, b + 6 * 1000, 100));
    memset(&j0, 0, sizeof j0);
    j0.s = s;
    j1 = j0, j2 = j0;
    query_thread(&j0);
    TEST_ASSERT_EQUAL_INT(0, pthread_create(&t1, NULL, query_thread, &j1));
    TEST_ASSERT_EQUAL_INT(0, pthread_create(&t2, NULL, query_thread, &j2));
    pthread_join(t1, NULL);
    pthread_join(t2, NULL);
    TEST_ASSERT_FALSE(j0.failed || j1.failed || j2.failed);
    TEST_ASSERT_EQUAL_UINT64(j0.hash, j1.hash);
    TEST_ASSERT_EQUAL_UINT64(j0.hash, j2.hash);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
}

/* The float32 entry points give what the float64 ones give for the same
 * (float-representable) values. */
static void f32_entry_points_match_f64(void)
{
    locd_engine *e = su_new_engine(1, NULL);
    locd_scene *s32 = NULL, *s64 = NULL;
    su_world w;
    float f[6 * 200], q32[6], o32[3], d32[3];
    double b[6 * 200], q64[6], o64[3], d64[3];
    locd_id ids32[200], ids64[200], h32[200], h64[200];
    double t32[200], t64[200];
    size_t n32, n64, i;
    int k, a;
    memset(&w, 0, sizeof w);
    ts_seed(&w.r, 77);
    w.extent = 30.0, w.size = 3.0;
    for (i = 0; i < 6 * 200; i++) {
        if (i % 6 == 0)
            su_random_box(&w, b + i);
    }
    for (i = 0; i < 6 * 200; i++)
        f[i] = su_to_float(b[i]), b[i] = f[i];
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s32));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s64));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s32, f, 200, NULL, ids32));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s64, b, 200, NULL, ids64));
    TEST_ASSERT_EQUAL_MEMORY(ids32, ids64, sizeof ids32);
    for (k = 0; k < 40; k++) {
        if (k == 20) { /* moved through both entry points, updated */
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s32, ids32, f + 6 * 100, 100));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s64, ids64, b + 6 * 100, 100));
        }
        if (k % 10 == 0) {
            const locd_id *p32, *p64;
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s32, LOCD_SCENE_UPDATE_PAIRS));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s64, LOCD_SCENE_UPDATE_PAIRS));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s32, &p32, &n32));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s64, &p64, &n64));
            su_same_rows("f32 against f64", p64, n64, p32, n32);
        }
        su_random_box(&w, q64);
        for (a = 0; a < 6; a++)
            q32[a] = su_to_float(q64[a]), q64[a] = q32[a];
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_box_f32(s32, q32, ~(uint64_t)0, h32, 200, &n32));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_box_f64(s64, q64, ~(uint64_t)0, h64, 200, &n64));
        TEST_ASSERT_EQUAL_UINT64(n64, n32);
        if (n64)
            TEST_ASSERT_EQUAL_MEMORY(h64, h32, n64 * sizeof *h64);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_point_f32(s32, q32, 3, h32, 200, &n32));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_point_f64(s64, q64, 3, h64, 200, &n64));
        TEST_ASSERT_EQUAL_UINT64(n64, n32);
        if (n64)
            TEST_ASSERT_EQUAL_MEMORY(h64, h32, n64 * sizeof *h64);
        for (a = 0; a < 3; a++) {
            o32[a] = q32[a], o64[a] = q64[a];
            d32[a] = su_to_float((ts_uniform(&w.r) - 0.5) * 20.0), d64[a] = d32[a];
        }
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_raycast_f32(s32, o32, d32, 2.0, ~(uint64_t)0, h32, t32, 200, &n32));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_raycast_f64(s64, o64, d64, 2.0, ~(uint64_t)0, h64, t64, 200, &n64));
        TEST_ASSERT_EQUAL_UINT64(n64, n32);
        if (n64) {
            TEST_ASSERT_EQUAL_MEMORY(h64, h32, n64 * sizeof *h64);
            TEST_ASSERT_EQUAL_MEMORY(t64, t32, n64 * sizeof *t64);
        }
    }
    locd_scene_destroy(s32);
    locd_scene_destroy(s64);
    locd_engine_destroy(e);
}

static const lt_test tests[] = {
    LT_TEST(queries_from_two_threads),
    LT_TEST(f32_entry_points_match_f64),
};

int main(void)
{
    return LT_RUN(tests);
}
