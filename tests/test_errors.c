/* Bad input gets a specific status, a useful message, and loses nothing. */
#include <locd/pipeline.h>
#include <locd/service.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "support.h"

typedef struct fixture {
    locd_engine *e;
    locd_pairs *p;
} fixture;

/* The engine and pairs of a test run with setup/teardown (LT_TEST_FIXTURE). */
static fixture fx;

static void setup(void)
{
    locd_engine_config cfg;
    locd_engine_config_init(&cfg);
    cfg.threads = 2;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &fx.e));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &fx.p));
}

static void teardown(void)
{
    locd_pairs_destroy(fx.p);
    locd_engine_destroy(fx.e);
    fx.p = NULL;
    fx.e = NULL;
}

/* Fills p with a known result so tests can see it survive an error. */
static size_t prime(fixture *f)
{
    float b[12] = {0, 0, 0, 1, 1, 1, 0.5f, 0.5f, 0.5f, 2, 2, 2};
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(f->e, b, 2, 0, f->p));
    return locd_pairs_count(f->p);
}

static void bad_box_names_first_index_and_keeps_output(void)
{
    fixture *f = &fx;
    static const size_t sizes[] = {10, 5000, 100000};
    size_t si;
    for (si = 0; si < 3; si++) {
        size_t n = sizes[si], bad1 = n / 3, bad2 = n - 1;
        float *b = ts_scene(0, n, 3);
        int which;
        for (which = 0; which < 4; which++) {
            float *c = malloc(n * 6 * sizeof(float));
            locd_status want;
            memcpy(c, b, n * 6 * sizeof(float));
            switch (which) {
            case 0: c[6 * bad1 + 4] = NAN; want = LOCD_ERR_NONFINITE; break;
            case 1: c[6 * bad1 + 0] = INFINITY; want = LOCD_ERR_NONFINITE; break;
            case 2: c[6 * bad1 + 2] = c[6 * bad1 + 5] + 1.0f; want = LOCD_ERR_INVERTED_BOX; break;
            default: c[6 * bad1 + 1] = -INFINITY; want = LOCD_ERR_NONFINITE; break;
            }
            c[6 * bad2 + 3] = NAN; /* a later bad box must not hide the first */
            TEST_ASSERT_EQUAL_INT64(1, prime(f));
            TEST_ASSERT_EQUAL_INT64(want, locd_engine_find_pairs_f32(f->e, c, n, 0, f->p));
            TEST_ASSERT_EQUAL_INT64((int64_t)bad1, locd_last_error_index());
            TEST_ASSERT_NOT_NULL(strstr(locd_last_error(), "box"));
            TEST_ASSERT_EQUAL_INT64(1, locd_pairs_count(f->p));
            free(c);
        }
        free(b);
    }
}

static void f64_bad_box_too(void)
{
    fixture *f = &fx;
    double b[18] = {0, 0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1};
    b[6 + 5] = -1; /* box 1: min z 0 > max z -1 */
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVERTED_BOX, locd_engine_find_pairs_f64(f->e, b, 3, 0, f->p));
    TEST_ASSERT_EQUAL_INT64(1, locd_last_error_index());
    b[6 + 5] = 1;
    b[12] = NAN;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_f64(f->e, b, 3, 0, f->p));
    TEST_ASSERT_EQUAL_INT64(2, locd_last_error_index());
}

static void zero_and_one_box_give_no_pairs(void)
{
    fixture *f = &fx;
    float one[6] = {0, 0, 0, 1, 1, 1}, nan1[6] = {0, 0, 0, 1, NAN, 1};
    prime(f);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(f->e, NULL, 0, 0, f->p));
    TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(f->p));
    prime(f);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(f->e, one, 1, 0, f->p));
    TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(f->p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_f32(f->e, nan1, 1, 0, f->p));
    TEST_ASSERT_EQUAL_INT64(0, locd_last_error_index());
}

static void null_pointers_and_bad_handles(void)
{
    fixture *f = &fx;
    float b[6] = {0, 0, 0, 1, 1, 1};
    locd_engine_config cfg;
    locd_engine *e = (locd_engine *)1;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f32(f->e, NULL, 5, 0, f->p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f32(f->e, b, 1, 0, NULL));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_HANDLE, locd_engine_find_pairs_f32(NULL, b, 1, 0, f->p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_find_pairs_f32(f->e, b, 1, 0x80, f->p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_create(NULL, NULL));
    locd_engine_config_init(&cfg);
    cfg.size = 3;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create(&cfg, &e));
    TEST_ASSERT_NULL(e);
    locd_engine_config_init(&cfg);
    cfg.level = 7;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create(&cfg, &e));
    locd_engine_config_init(&cfg);
    cfg.cell_bias = -1;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create(&cfg, &e));
    locd_engine_config_init(&cfg);
    cfg.level = LOCD_LEVEL_SERVICE; /* no address */
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create(&cfg, &e));
    TEST_ASSERT_TRUE(strlen(locd_last_error()) > 0);
    locd_engine_destroy(NULL);
    locd_pairs_destroy(NULL);
    TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(NULL));
    TEST_ASSERT_NULL(locd_pairs_data(NULL));
}

/* One live handle of each kind, and the call that checks a handle of that
 * kind; contacts are checked through a world (its first argument). The
 * service comes last: its check (run) would serve forever on a handle it
 * took by mistake, so a clash shows first as another kind's failure. */
enum { K_ENGINE, K_PAIRS, K_JOB, K_SHAPE, K_WORLD, K_CONTACTS, K_SERVICE, K_KINDS };
static const char *const kind_names[K_KINDS] = {"engine", "pairs", "job", "shape", "world", "contacts", "service"};

static locd_status check_as(int kind, void *h, locd_world *world)
{
    const double pose[7] = {0, 0, 0, 1, 0, 0, 0};
    double out[7];
    locd_stats st;
    locd_stats_init(&st);
    switch (kind) {
    case K_ENGINE: return locd_engine_stats((locd_engine *)h, &st);
    case K_PAIRS: return locd_pairs_sort((locd_pairs *)h);
    case K_JOB: return locd_job_poll((locd_job *)h);
    case K_SHAPE: return locd_shape_aabb((const locd_shape *)h, pose, out);
    case K_WORLD: return locd_world_get_pose((const locd_world *)h, 0, out);
    case K_CONTACTS: return locd_world_collide(world, NULL, (locd_contacts *)h, NULL);
    default: return locd_service_run((locd_service *)h);
    }
}

/* Every kind of handle has its own magic: passed where another kind is
 * expected, it is refused (the narrow-phase kinds only when built). */
static void each_handle_kind_is_refused_as_another(void)
{
    fixture *f = &fx;
    void *h[K_KINDS] = {0};
    locd_service_config sc;
    locd_job *job;
    locd_service *svc;
    locd_shape *shape = NULL;
    locd_world *world = NULL;
    locd_contacts *contacts = NULL;
    locd_status st;
    int have, want;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_submit_f32(f->e, NULL, 0, 0, &job));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_wait(job, -1));
    locd_service_config_init(&sc);
    sc.listen = "tcp:127.0.0.1:0";
    sc.secret = "handles";
    sc.threads = 1;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_service_create(&sc, &svc));
    if (locd_shape_sphere(1.0, &shape) == LOCD_OK) {
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_create(NULL, &world));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_contacts_create(&contacts));
    }
    h[K_ENGINE] = f->e, h[K_PAIRS] = f->p, h[K_JOB] = job, h[K_SERVICE] = svc;
    h[K_SHAPE] = shape, h[K_WORLD] = world, h[K_CONTACTS] = contacts;
    for (want = 0; want < K_KINDS; want++)
        for (have = 0; have < K_KINDS; have++) {
            if (have == want || !h[have] || !h[want])
                continue;
            st = check_as(want, h[have], world);
            if (st != LOCD_ERR_INVALID_HANDLE)
                LT_FAIL("a %s passed as a %s gave status %d", kind_names[have], kind_names[want], (int)st);
        }
    locd_contacts_destroy(contacts);
    locd_world_destroy(world);
    locd_shape_destroy(shape);
    locd_service_destroy(svc);
    locd_job_release(job);
}

/* LOCD_MAX_DEPTH is accepted, one more is refused, by the engine and by
 * the grid fit alike, and the message names the limit. */
static void depth_limit_is_checked_everywhere(void)
{
    float b[12] = {0, 0, 0, 1, 1, 1, 0.5f, 0.5f, 0.5f, 2, 2, 2};
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_grid g;
    uint64_t ent[16];
    size_t written = 0;
    locd_engine_config_init(&cfg);
    cfg.threads = 1;
    cfg.max_depth = LOCD_MAX_DEPTH;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
    locd_engine_destroy(e);
    e = NULL;
    cfg.max_depth = LOCD_MAX_DEPTH + 1;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create(&cfg, &e));
    TEST_ASSERT_NULL(e);
    TEST_ASSERT_NOT_NULL(strstr(locd_last_error(), "LOCD_MAX_DEPTH"));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_grid_fit_f32(b, 2, LOCD_MAX_DEPTH, 2, 0, &g));
    TEST_ASSERT_TRUE(g.depth <= LOCD_MAX_DEPTH);
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_grid_fit_f32(b, 2, LOCD_MAX_DEPTH + 1, 2, 0, &g));
    TEST_ASSERT_NOT_NULL(strstr(locd_last_error(), "LOCD_MAX_DEPTH"));
    /* a grid that claims more is refused by the steps that take one */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_grid_fit_f32(b, 2, 0, 2, 0, &g));
    g.depth = LOCD_MAX_DEPTH + 1;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_encode_f32(&g, b, 0, 2, ent, 16, &written));
    TEST_ASSERT_NOT_NULL(strstr(locd_last_error(), "LOCD_MAX_DEPTH"));
}

static void too_many_objects(void)
{
    fixture *f = &fx;
    float b[6] = {0, 0, 0, 1, 1, 1};
    size_t huge = (size_t)UINT32_MAX + 2u;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_TOO_MANY_OBJECTS, locd_engine_find_pairs_f32(f->e, b, huge, 0, f->p));
}

static void into_buffer_too_small_keeps_pairs_available(void)
{
    fixture *f = &fx;
    size_t n = 3000, count = 0, m;
    float *b = ts_scene(0, n, 21);
    uint32_t small[4];
    const uint32_t *last;
    uint32_t *big;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_BUFFER_TOO_SMALL,
                            locd_engine_find_pairs_f32_into(f->e, b, n, 0, small, 2, &count));
    TEST_ASSERT_TRUE(count > 2);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_last_pairs(f->e, &last, &m));
    TEST_ASSERT_EQUAL_INT64(count, m);
    big = malloc(count * 2 * sizeof *big);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32_into(f->e, b, n, 0, big, count, &m));
    TEST_ASSERT_EQUAL_INT64(count, m);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(f->e, b, n, 0, f->p));
    LT_ASSERT_EQUAL_MEMORY(locd_pairs_data(f->p), big, count * 2 * sizeof *big);
    free(big);
    free(b);
}

static void statuses_have_strings_and_version_matches(void)
{
    locd_status s;
    for (s = LOCD_ERR_INTERNAL; s <= LOCD_PENDING; s++)
        TEST_ASSERT_NOT_NULL(locd_status_string(s));
    TEST_ASSERT_NOT_NULL(locd_status_string(LOCD_ERR_NONFINITE));
    TEST_ASSERT_NOT_NULL(locd_status_string(LOCD_ERR_INVERTED_BOX));
    TEST_ASSERT_TRUE_MESSAGE(
        strcmp(locd_status_string(LOCD_ERR_NONFINITE), locd_status_string(LOCD_ERR_INVERTED_BOX)) != 0,
        "two statuses share a string");
    TEST_ASSERT_EQUAL_INT64(LOCD_VERSION, locd_version());
    TEST_ASSERT_EQUAL_STRING(LOCD_VERSION_STRING, locd_version_string());
}

static void stats_report_the_last_call(void)
{
    fixture *f = &fx;
    size_t n = 20000;
    float *b = ts_scene(0, n, 8);
    locd_stats st;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(f->e, b, n, 0, f->p));
    locd_stats_init(&st);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_stats(f->e, &st));
    TEST_ASSERT_EQUAL_INT64(n, st.objects);
    TEST_ASSERT_EQUAL_INT64(locd_pairs_count(f->p), st.pairs);
    TEST_ASSERT_TRUE(st.entries >= n && st.entries <= 8 * n);
    TEST_ASSERT_TRUE(st.candidates >= st.pairs);
    TEST_ASSERT_TRUE(st.ms_total > 0);
    TEST_ASSERT_EQUAL_INT64(2, st.threads);
    st.size = 1;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_stats(f->e, &st));
    free(b);
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST_FIXTURE(bad_box_names_first_index_and_keeps_output, setup, teardown),
        LT_TEST_FIXTURE(f64_bad_box_too, setup, teardown),
        LT_TEST_FIXTURE(zero_and_one_box_give_no_pairs, setup, teardown),
        LT_TEST_FIXTURE(null_pointers_and_bad_handles, setup, teardown),
        LT_TEST_FIXTURE(each_handle_kind_is_refused_as_another, setup, teardown),
        LT_TEST(depth_limit_is_checked_everywhere),
        LT_TEST_FIXTURE(too_many_objects, setup, teardown),
        LT_TEST_FIXTURE(into_buffer_too_small_keeps_pairs_available, setup, teardown),
        LT_TEST(statuses_have_strings_and_version_matches),
        LT_TEST_FIXTURE(stats_report_the_last_call, setup, teardown),
    };
    return LT_RUN(tests);
}
