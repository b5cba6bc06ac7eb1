/* Bad input gets a specific status, a useful message, and loses nothing. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "support.h"

typedef struct fixture {
    locd_engine *e;
    locd_pairs *p;
} fixture;

static int setup(void **state)
{
    fixture *f = calloc(1, sizeof *f);
    locd_engine_config cfg;
    locd_engine_config_init(&cfg);
    cfg.threads = 2;
    if (locd_engine_create(&cfg, &f->e) || locd_pairs_create(NULL, &f->p))
        return -1;
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fixture *f = *state;
    locd_pairs_destroy(f->p);
    locd_engine_destroy(f->e);
    free(f);
    return 0;
}

/* Fills p with a known result so tests can see it survive an error. */
static size_t prime(fixture *f)
{
    float b[12] = {0, 0, 0, 1, 1, 1, 0.5f, 0.5f, 0.5f, 2, 2, 2};
    assert_int_equal(locd_engine_find_pairs_f32(f->e, b, 2, 0, f->p), LOCD_OK);
    return locd_pairs_count(f->p);
}

static void bad_box_names_first_index_and_keeps_output(void **state)
{
    fixture *f = *state;
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
            assert_int_equal(prime(f), 1);
            assert_int_equal(locd_engine_find_pairs_f32(f->e, c, n, 0, f->p), want);
            assert_int_equal(locd_last_error_index(), (int64_t)bad1);
            assert_non_null(strstr(locd_last_error(), "box"));
            assert_int_equal(locd_pairs_count(f->p), 1);
            free(c);
        }
        free(b);
    }
}

static void f64_bad_box_too(void **state)
{
    fixture *f = *state;
    double b[18] = {0, 0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1};
    b[6 + 5] = -1; /* box 1: min z 0 > max z -1 */
    assert_int_equal(locd_engine_find_pairs_f64(f->e, b, 3, 0, f->p), LOCD_ERR_INVERTED_BOX);
    assert_int_equal(locd_last_error_index(), 1);
    b[6 + 5] = 1;
    b[12] = NAN;
    assert_int_equal(locd_engine_find_pairs_f64(f->e, b, 3, 0, f->p), LOCD_ERR_NONFINITE);
    assert_int_equal(locd_last_error_index(), 2);
}

static void zero_and_one_box_give_no_pairs(void **state)
{
    fixture *f = *state;
    float one[6] = {0, 0, 0, 1, 1, 1}, nan1[6] = {0, 0, 0, 1, NAN, 1};
    prime(f);
    assert_int_equal(locd_engine_find_pairs_f32(f->e, NULL, 0, 0, f->p), LOCD_OK);
    assert_int_equal(locd_pairs_count(f->p), 0);
    prime(f);
    assert_int_equal(locd_engine_find_pairs_f32(f->e, one, 1, 0, f->p), LOCD_OK);
    assert_int_equal(locd_pairs_count(f->p), 0);
    assert_int_equal(locd_engine_find_pairs_f32(f->e, nan1, 1, 0, f->p), LOCD_ERR_NONFINITE);
    assert_int_equal(locd_last_error_index(), 0);
}

static void null_pointers_and_bad_handles(void **state)
{
    fixture *f = *state;
    float b[6] = {0, 0, 0, 1, 1, 1};
    locd_engine_config cfg;
    locd_engine *e = (locd_engine *)1;
    assert_int_equal(locd_engine_find_pairs_f32(f->e, NULL, 5, 0, f->p), LOCD_ERR_NULL_POINTER);
    assert_int_equal(locd_engine_find_pairs_f32(f->e, b, 1, 0, NULL), LOCD_ERR_NULL_POINTER);
    assert_int_equal(locd_engine_find_pairs_f32(NULL, b, 1, 0, f->p), LOCD_ERR_INVALID_HANDLE);
    assert_int_equal(locd_engine_find_pairs_f32(f->e, b, 1, 0x80, f->p), LOCD_ERR_INVALID_ARGUMENT);
    assert_int_equal(locd_engine_create(NULL, NULL), LOCD_ERR_NULL_POINTER);
    locd_engine_config_init(&cfg);
    cfg.size = 3;
    assert_int_equal(locd_engine_create(&cfg, &e), LOCD_ERR_INVALID_ARGUMENT);
    assert_null(e);
    locd_engine_config_init(&cfg);
    cfg.level = 7;
    assert_int_equal(locd_engine_create(&cfg, &e), LOCD_ERR_INVALID_ARGUMENT);
    locd_engine_config_init(&cfg);
    cfg.cell_bias = -1;
    assert_int_equal(locd_engine_create(&cfg, &e), LOCD_ERR_INVALID_ARGUMENT);
    locd_engine_config_init(&cfg);
    cfg.level = LOCD_LEVEL_SERVICE; /* no address */
    assert_int_equal(locd_engine_create(&cfg, &e), LOCD_ERR_INVALID_ARGUMENT);
    assert_true(strlen(locd_last_error()) > 0);
    locd_engine_destroy(NULL);
    locd_pairs_destroy(NULL);
    assert_int_equal(locd_pairs_count(NULL), 0);
    assert_null(locd_pairs_data(NULL));
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
static void each_handle_kind_is_refused_as_another(void **state)
{
    fixture *f = *state;
    void *h[K_KINDS] = {0};
    locd_service_config sc;
    locd_job *job;
    locd_service *svc;
    locd_shape *shape = NULL;
    locd_world *world = NULL;
    locd_contacts *contacts = NULL;
    locd_status st;
    int have, want;
    assert_int_equal(locd_engine_submit_f32(f->e, NULL, 0, 0, &job), LOCD_OK);
    assert_int_equal(locd_job_wait(job, -1), LOCD_OK);
    locd_service_config_init(&sc);
    sc.listen = "tcp:127.0.0.1:0";
    sc.secret = "handles";
    sc.threads = 1;
    assert_int_equal(locd_service_create(&sc, &svc), LOCD_OK);
    if (locd_shape_sphere(1.0, &shape) == LOCD_OK) {
        assert_int_equal(locd_world_create(NULL, &world), LOCD_OK);
        assert_int_equal(locd_contacts_create(&contacts), LOCD_OK);
    }
    h[K_ENGINE] = f->e, h[K_PAIRS] = f->p, h[K_JOB] = job, h[K_SERVICE] = svc;
    h[K_SHAPE] = shape, h[K_WORLD] = world, h[K_CONTACTS] = contacts;
    for (want = 0; want < K_KINDS; want++)
        for (have = 0; have < K_KINDS; have++) {
            if (have == want || !h[have] || !h[want])
                continue;
            st = check_as(want, h[have], world);
            if (st != LOCD_ERR_INVALID_HANDLE)
                fail_msg("a %s passed as a %s gave status %d", kind_names[have], kind_names[want], (int)st);
        }
    locd_contacts_destroy(contacts);
    locd_world_destroy(world);
    locd_shape_destroy(shape);
    locd_service_destroy(svc);
    locd_job_release(job);
}

/* LOCD_MAX_DEPTH is accepted, one more is refused, by the engine and by
 * the grid fit alike, and the message names the limit. */
static void depth_limit_is_checked_everywhere(void **state)
{
    float b[12] = {0, 0, 0, 1, 1, 1, 0.5f, 0.5f, 0.5f, 2, 2, 2};
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_grid g;
    uint64_t ent[16];
    size_t written = 0;
    (void)state;
    locd_engine_config_init(&cfg);
    cfg.threads = 1;
    cfg.max_depth = LOCD_MAX_DEPTH;
    assert_int_equal(locd_engine_create(&cfg, &e), LOCD_OK);
    locd_engine_destroy(e);
    e = NULL;
    cfg.max_depth = LOCD_MAX_DEPTH + 1;
    assert_int_equal(locd_engine_create(&cfg, &e), LOCD_ERR_INVALID_ARGUMENT);
    assert_null(e);
    assert_non_null(strstr(locd_last_error(), "LOCD_MAX_DEPTH"));
    assert_int_equal(locd_grid_fit_f32(b, 2, LOCD_MAX_DEPTH, 2, 0, &g), LOCD_OK);
    assert_true(g.depth <= LOCD_MAX_DEPTH);
    assert_int_equal(locd_grid_fit_f32(b, 2, LOCD_MAX_DEPTH + 1, 2, 0, &g), LOCD_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(locd_last_error(), "LOCD_MAX_DEPTH"));
    /* a grid that claims more is refused by the steps that take one */
    assert_int_equal(locd_grid_fit_f32(b, 2, 0, 2, 0, &g), LOCD_OK);
    g.depth = LOCD_MAX_DEPTH + 1;
    assert_int_equal(locd_encode_f32(&g, b, 0, 2, ent, 16, &written), LOCD_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(locd_last_error(), "LOCD_MAX_DEPTH"));
}

static void too_many_objects(void **state)
{
    fixture *f = *state;
    float b[6] = {0, 0, 0, 1, 1, 1};
    size_t huge = (size_t)UINT32_MAX + 2u;
    assert_int_equal(locd_engine_find_pairs_f32(f->e, b, huge, 0, f->p), LOCD_ERR_TOO_MANY_OBJECTS);
}

static void into_buffer_too_small_keeps_pairs_available(void **state)
{
    fixture *f = *state;
    size_t n = 3000, count = 0, m;
    float *b = ts_scene(0, n, 21);
    uint32_t small[4];
    const uint32_t *last;
    uint32_t *big;
    assert_int_equal(locd_engine_find_pairs_f32_into(f->e, b, n, 0, small, 2, &count), LOCD_ERR_BUFFER_TOO_SMALL);
    assert_true(count > 2);
    assert_int_equal(locd_engine_last_pairs(f->e, &last, &m), LOCD_OK);
    assert_int_equal(m, count);
    big = malloc(count * 2 * sizeof *big);
    assert_int_equal(locd_engine_find_pairs_f32_into(f->e, b, n, 0, big, count, &m), LOCD_OK);
    assert_int_equal(m, count);
    assert_int_equal(locd_engine_find_pairs_f32(f->e, b, n, 0, f->p), LOCD_OK);
    assert_memory_equal(big, locd_pairs_data(f->p), count * 2 * sizeof *big);
    free(big);
    free(b);
}

static void statuses_have_strings_and_version_matches(void **state)
{
    locd_status s;
    (void)state;
    for (s = LOCD_ERR_INTERNAL; s <= LOCD_PENDING; s++)
        assert_non_null(locd_status_string(s));
    assert_string_not_equal(locd_status_string(LOCD_ERR_NONFINITE), locd_status_string(LOCD_ERR_INVERTED_BOX));
    assert_int_equal(locd_version(), LOCD_VERSION);
    assert_string_equal(locd_version_string(), LOCD_VERSION_STRING);
}

static void stats_report_the_last_call(void **state)
{
    fixture *f = *state;
    size_t n = 20000;
    float *b = ts_scene(0, n, 8);
    locd_stats st;
    assert_int_equal(locd_engine_find_pairs_f32(f->e, b, n, 0, f->p), LOCD_OK);
    locd_stats_init(&st);
    assert_int_equal(locd_engine_stats(f->e, &st), LOCD_OK);
    assert_int_equal(st.objects, n);
    assert_int_equal(st.pairs, locd_pairs_count(f->p));
    assert_true(st.entries >= n && st.entries <= 8 * n);
    assert_true(st.candidates >= st.pairs);
    assert_true(st.ms_total > 0);
    assert_int_equal(st.threads, 2);
    st.size = 1;
    assert_int_equal(locd_engine_stats(f->e, &st), LOCD_ERR_INVALID_ARGUMENT);
    free(b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(bad_box_names_first_index_and_keeps_output, setup, teardown),
        cmocka_unit_test_setup_teardown(f64_bad_box_too, setup, teardown),
        cmocka_unit_test_setup_teardown(zero_and_one_box_give_no_pairs, setup, teardown),
        cmocka_unit_test_setup_teardown(null_pointers_and_bad_handles, setup, teardown),
        cmocka_unit_test_setup_teardown(each_handle_kind_is_refused_as_another, setup, teardown),
        cmocka_unit_test(depth_limit_is_checked_everywhere),
        cmocka_unit_test_setup_teardown(too_many_objects, setup, teardown),
        cmocka_unit_test_setup_teardown(into_buffer_too_small_keeps_pairs_available, setup, teardown),
        cmocka_unit_test(statuses_have_strings_and_version_matches),
        cmocka_unit_test_setup_teardown(stats_report_the_last_call, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
