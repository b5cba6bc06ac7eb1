/* The public contract that every function shares (locd.h, docs/abi.md):
 * every call that succeeds clears the last error; versioned structs are read
 * and written no further than their `size`; a running job's take and stats
 * say LOCD_PENDING; an error passed on by a job or the service reads like
 * the direct call's; and the memory locd itself allocates comes from the
 * caller's allocator, except where locd.h says otherwise.
 *
 * This suite links the library's objects and wraps malloc, calloc and
 * realloc (-Wl,--wrap), so it sees exactly the calls made by locd's own
 * code: not those libccd, FCL or libc make for it. */
#include <locd/pipeline.h>
#include <locd/service.h>
#include <math.h>
#include <pthread.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "runner.h"

#include "fail_alloc.h"
#include "levels_util.h"
#include "support.h"

/* ---- malloc as locd's code calls it ---- */

void *__real_malloc(size_t size);
void *__real_calloc(size_t n, size_t size);
void *__real_realloc(void *p, size_t size);
static uint64_t g_mallocs; /* malloc/calloc/realloc calls from the wrapped objects */

void *__wrap_malloc(size_t size)
{
    __atomic_add_fetch(&g_mallocs, 1, __ATOMIC_RELAXED);
    return __real_malloc(size);
}

void *__wrap_calloc(size_t n, size_t size)
{
    __atomic_add_fetch(&g_mallocs, 1, __ATOMIC_RELAXED);
    return __real_calloc(n, size);
}

void *__wrap_realloc(void *p, size_t size)
{
    __atomic_add_fetch(&g_mallocs, 1, __ATOMIC_RELAXED);
    return __real_realloc(p, size);
}

static uint64_t mallocs(void)
{
    return __atomic_load_n(&g_mallocs, __ATOMIC_RELAXED);
}

static int narrow_built(void)
{
    locd_shape *s = NULL;
    locd_status st = locd_shape_sphere(1.0, &s);
    locd_shape_destroy(s);
    return st == LOCD_OK;
}

/* Raises a box error (message and index set) on the calling thread; 1 when
 * it reads as expected. It asserts nothing, so that a thread other than the
 * test's can call it (a failed Unity assertion must happen on the test's). */
static int raise_error(void)
{
    float bad[6] = {0, 0, 0, 1, NAN, 1};
    locd_grid g;
    return locd_grid_fit_f32(bad, 1, 0, LOCD_DEFAULT_CELL_BIAS, 0, &g) == LOCD_ERR_NONFINITE &&
           locd_last_error_index() == 0 && locd_last_error()[0] != '\0';
}

/* raise_error on the test's thread, each part checked. */
static void provoke_error(void)
{
    float bad[6] = {0, 0, 0, 1, NAN, 1};
    locd_grid g;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_grid_fit_f32(bad, 1, 0, LOCD_DEFAULT_CELL_BIAS, 0, &g));
    TEST_ASSERT_EQUAL_INT64(0, locd_last_error_index());
    TEST_ASSERT_TRUE(locd_last_error()[0] != '\0');
}

/* The call succeeded and left no last error; a failure is reported at the
 * caller's line. */
#define assert_cleared(what, st) assert_cleared_(__LINE__, (what), (st))
static void assert_cleared_(int line, const char *what, locd_status st)
{
    if (st < 0)
        lt_fail_(line, "%s failed: %s", what, locd_last_error());
    if (locd_last_error()[0] != '\0' || locd_last_error_index() != -1)
        lt_fail_(line, "%s succeeded (%d) but left the last error \"%s\" (index %lld)", what, (int)st,
                 locd_last_error(), (long long)locd_last_error_index());
}

/* ---- every successful call clears the last error ---- */

#define SCENE_N 300

typedef struct ctx {
    locd_engine *e;
    locd_pairs *p;
    float *f;
    double *d;
    locd_grid grid;
    uint64_t *entries, *scratch, *merged;
    size_t nentries, count;
    const uint32_t *last;
    locd_job *job;
    locd_shape *sphere, *box;
    locd_world *world;
    locd_contacts *contacts;
    locd_stats stats;
} ctx;

static const double g_pose[7] = {0, 0, 0, 0, 0, 0, 1};
static const double g_pose2[7] = {0.5, 0, 0, 0, 0, 0, 1};
static const double g_vel[6] = {0.1, 0, 0, 0, 0, 0};

static void ctx_up(ctx *c)
{
    locd_engine_config cfg;
    size_t i;
    memset(c, 0, sizeof *c);
    locd_engine_config_init(&cfg);
    cfg.threads = 1;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &c->e));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &c->p));
    c->f = ts_scene(0, SCENE_N, 5);
    c->d = malloc(6 * SCENE_N * sizeof *c->d);
    for (i = 0; i < 6 * SCENE_N; i++)
        c->d[i] = c->f[i];
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_grid_fit_f32(c->f, SCENE_N, 0, LOCD_DEFAULT_CELL_BIAS, 0, &c->grid));
    c->entries = malloc(LOCD_MAX_ENTRIES_PER_BOX * SCENE_N * sizeof *c->entries);
    c->scratch = malloc(LOCD_MAX_ENTRIES_PER_BOX * SCENE_N * sizeof *c->scratch);
    c->merged = malloc(LOCD_MAX_ENTRIES_PER_BOX * SCENE_N * sizeof *c->merged);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_encode_f32(&c->grid, c->f, 0, SCENE_N, c->entries,
                                                     LOCD_MAX_ENTRIES_PER_BOX * SCENE_N, &c->nentries));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_sort_entries(&c->grid, c->entries, c->scratch, c->nentries));
    locd_stats_init(&c->stats);
    if (narrow_built()) {
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_sphere(1.0, &c->sphere));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_box(1.0, 1.0, 1.0, &c->box));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_create(&cfg, &c->world));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_add(c->world, c->sphere, g_pose, NULL, NULL));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_add(c->world, c->box, g_pose2, NULL, NULL));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_contacts_create(&c->contacts));
    }
}

static void ctx_down(ctx *c)
{
    locd_job_release(c->job);
    locd_contacts_destroy(c->contacts);
    locd_world_destroy(c->world);
    locd_shape_destroy(c->sphere);
    locd_shape_destroy(c->box);
    locd_pairs_destroy(c->p);
    locd_engine_destroy(c->e);
    free(c->f);
    free(c->d);
    free(c->entries);
    free(c->scratch);
    free(c->merged);
}

/* A finished job of c's engine in c->job. */
static locd_status new_job(ctx *c)
{
    locd_status st;
    locd_job_release(c->job);
    c->job = NULL;
    st = locd_engine_submit_f32(c->e, c->f, SCENE_N, 0, &c->job);
    return st ? st : locd_job_wait(c->job, -1);
}

/* Calls that create a handle: the handle is destroyed again at once. */
static locd_status engine_create(ctx *c)
{
    locd_engine *e = NULL;
    locd_status st = locd_engine_create(NULL, &e);
    (void)c;
    locd_engine_destroy(e);
    return st;
}

static locd_status pairs_create(ctx *c)
{
    locd_pairs *p = NULL;
    locd_status st = locd_pairs_create(NULL, &p);
    (void)c;
    locd_pairs_destroy(p);
    return st;
}

/* The job is left to the job rows (new_job waits for or cancels it). */
static locd_status submit(ctx *c, int f64)
{
    locd_job_release(c->job);
    c->job = NULL;
    return f64 ? locd_engine_submit_f64(c->e, c->d, SCENE_N, 0, &c->job)
               : locd_engine_submit_f32(c->e, c->f, SCENE_N, 0, &c->job);
}

static locd_status submit_f32(ctx *c)
{
    return submit(c, 0);
}

static locd_status submit_f64(ctx *c)
{
    return submit(c, 1);
}

static locd_status merge(ctx *c)
{
    const uint64_t *runs[2] = {c->entries, c->entries + c->nentries / 2};
    size_t counts[2] = {c->nentries / 2, c->nentries - c->nentries / 2};
    return locd_merge_entries(runs, counts, 2, c->merged);
}

static locd_status sort_few_pairs(ctx *c)
{
    locd_pairs_clear(c->p);
    return locd_pairs_sort(c->p);
}

static locd_status shape_convex(ctx *c)
{
    static const double pts[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    locd_shape *s = NULL;
    locd_status st = locd_shape_convex(pts, 4, &s);
    (void)c;
    locd_shape_destroy(s);
    return st;
}

static locd_status shape_mesh(ctx *c)
{
    static const double v[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    static const uint32_t t[12] = {0, 1, 2, 0, 1, 3, 0, 2, 3, 1, 2, 3};
    locd_shape *s = NULL;
    locd_status st = locd_shape_mesh(v, 4, t, 4, &s);
    (void)c;
    locd_shape_destroy(s);
    return st;
}

#define PRIMITIVE(name, expr)                                                                                \
    static locd_status name(ctx *c)                                                                          \
    {                                                                                                        \
        locd_shape *s = NULL;                                                                                \
        locd_status st = (expr);                                                                             \
        (void)c;                                                                                             \
        locd_shape_destroy(s);                                                                               \
        return st;                                                                                           \
    }
PRIMITIVE(shape_sphere, locd_shape_sphere(1.0, &s))
PRIMITIVE(shape_box, locd_shape_box(1.0, 2.0, 3.0, &s))
PRIMITIVE(shape_capsule, locd_shape_capsule(1.0, 2.0, &s))
#undef PRIMITIVE

static locd_status world_create(ctx *c)
{
    locd_world *w = NULL;
    locd_status st = locd_world_create(NULL, &w);
    (void)c;
    locd_world_destroy(w);
    return st;
}

static locd_status contacts_create(ctx *c)
{
    locd_contacts *ct = NULL;
    locd_status st = locd_contacts_create(&ct);
    (void)c;
    locd_contacts_destroy(ct);
    return st;
}

/* locd_world_count rows of poses (all at rest) or velocities. */
static locd_status set_all(ctx *c, int poses)
{
    size_t n = locd_world_count(c->world), i;
    double *v = calloc(7 * n, sizeof *v);
    locd_status st;
    for (i = 0; i < n; i++)
        v[7 * i + 6] = 1.0; /* a unit quaternion; as velocities, 6 per row */
    st = poses ? locd_world_set_poses(c->world, v, n) : locd_world_set_velocities(c->world, v, n);
    free(v);
    return st;
}

static locd_status route(ctx *c)
{
    locd_pipeline_options o;
    (void)c;
    locd_pipeline_options_init(&o);
    return locd_pipeline_options_route(&o, LOCD_SHAPE_SPHERE, LOCD_SHAPE_BOX, LOCD_ROUTE_CCD);
}

static locd_status shape_collide(ctx *c)
{
    int32_t hit = 0;
    double contact[7];
    locd_status st = locd_shape_collide(c->sphere, g_pose, c->box, g_pose2, LOCD_ROUTE_AUTO, LOCD_CONTACT_EPA, &hit,
                                        contact);
    return st ? st : (hit ? LOCD_OK : -1);
}

/* Every exported function that returns a status, on a successful path
 * (rows for the service and level 3 are in service_calls_clear_...). */
#define ROWS(X)                                                                                              \
    X(brute_force_f32, 0, 0, locd_brute_force_f32(c->f, SCENE_N, c->p))                                      \
    X(brute_force_f64, 0, 0, locd_brute_force_f64(c->d, SCENE_N, c->p))                                      \
    X(engine_create, 0, 0, engine_create(c))                                                                 \
    X(find_pairs_f32, 0, 0, locd_engine_find_pairs_f32(c->e, c->f, SCENE_N, 0, c->p))                        \
    X(find_pairs_f64, 0, 0, locd_engine_find_pairs_f64(c->e, c->d, SCENE_N, LOCD_FIND_SORTED, c->p))         \
    X(find_pairs_none, 0, 0, locd_engine_find_pairs_f32(c->e, NULL, 0, 0, c->p))                             \
    X(find_pairs_f32_into, 0, 0,                                                                             \
      locd_engine_find_pairs_f32_into(c->e, c->f, SCENE_N, 0, (uint32_t *)c->merged, SCENE_N * 4, &c->count)) \
    X(find_pairs_f64_into, 0, 0,                                                                             \
      locd_engine_find_pairs_f64_into(c->e, c->d, SCENE_N, 0, (uint32_t *)c->merged, SCENE_N * 4, &c->count)) \
    X(engine_last_pairs, 0, 0, locd_engine_last_pairs(c->e, &c->last, &c->count))                            \
    X(engine_stats, 0, 0, locd_engine_stats(c->e, &c->stats))                                                \
    X(grid_fit_f32, 0, 0, locd_grid_fit_f32(c->f, SCENE_N, 0, LOCD_DEFAULT_CELL_BIAS, 0, &c->grid))          \
    X(grid_fit_f64, 0, 0, locd_grid_fit_f64(c->d, SCENE_N, 0, LOCD_DEFAULT_CELL_BIAS, 0, &c->grid))          \
    X(encode_f32, 0, 0,                                                                                      \
      locd_encode_f32(&c->grid, c->f, 0, SCENE_N, c->entries, LOCD_MAX_ENTRIES_PER_BOX * SCENE_N, &c->nentries)) \
    X(encode_f64, 0, 0,                                                                                      \
      locd_encode_f64(&c->grid, c->d, 0, SCENE_N, c->entries, LOCD_MAX_ENTRIES_PER_BOX * SCENE_N, &c->nentries)) \
    X(sort_entries, 0, 0, locd_sort_entries(&c->grid, c->entries, c->merged, c->nentries))                   \
    X(merge_entries, 0, 0, merge(c))                                                                         \
    X(merge_no_runs, 0, 0, locd_merge_entries(NULL, NULL, 0, NULL))                                          \
    X(sweep_f32, 0, 0, locd_sweep_f32(&c->grid, c->f, SCENE_N, c->entries, c->nentries, c->p, &c->stats))    \
    X(sweep_f64, 0, 0, locd_sweep_f64(&c->grid, c->d, SCENE_N, c->entries, c->nentries, c->p, NULL))         \
    X(pairs_create, 0, 0, pairs_create(c))                                                                   \
    X(pairs_sort, 0, 0, locd_pairs_sort(c->p))                                                               \
    X(pairs_sort_few, 0, 0, sort_few_pairs(c))                                                               \
    X(submit_f32, 0, 0, submit_f32(c))                                                                       \
    X(submit_f64, 0, 0, submit_f64(c))                                                                       \
    X(job_poll, 0, 1, locd_job_poll(c->job))                                                                 \
    X(job_wait, 0, 1, locd_job_wait(c->job, 0))                                                              \
    X(job_stats, 0, 1, locd_job_stats(c->job, &c->stats))                                                    \
    X(job_take, 0, 1, locd_job_take(c->job, c->p))                                                           \
    X(job_cancel, 0, 1, locd_job_cancel(c->job))                                                             \
    X(shape_sphere, 1, 0, shape_sphere(c))                                                                   \
    X(shape_box, 1, 0, shape_box(c))                                                                         \
    X(shape_capsule, 1, 0, shape_capsule(c))                                                                 \
    X(shape_convex, 1, 0, shape_convex(c))                                                                   \
    X(shape_mesh, 1, 0, shape_mesh(c))                                                                       \
    X(shape_aabb, 1, 0, locd_shape_aabb(c->box, g_pose, (double *)c->merged))                                \
    X(shape_collide, 1, 0, shape_collide(c))                                                                 \
    X(options_route, 1, 0, route(c))                                                                         \
    X(world_create, 1, 0, world_create(c))                                                                   \
    X(world_add, 1, 0, locd_world_add(c->world, c->sphere, g_pose2, g_vel, NULL))                            \
    X(world_set_pose, 1, 0, locd_world_set_pose(c->world, 0, g_pose))                                        \
    X(world_set_velocity, 1, 0, locd_world_set_velocity(c->world, 0, g_vel))                                 \
    X(world_set_poses, 1, 0, set_all(c, 1))                                                                  \
    X(world_set_velocities, 1, 0, set_all(c, 0))                                                             \
    X(world_get_pose, 1, 0, locd_world_get_pose(c->world, 1, (double *)c->merged))                           \
    X(world_collide, 1, 0, locd_world_collide(c->world, NULL, c->contacts, NULL))                            \
    X(contacts_create, 1, 0, contacts_create(c))

typedef struct row {
    const char *name;
    locd_status (*call)(ctx *c);
    int narrow; /* needs the narrow phase */
    int job;    /* needs a finished job in c->job */
} row;

#define DEFINE_CALL(name, narrow, job, expr)                                                                 \
    static locd_status call_##name(ctx *c)                                                                   \
    {                                                                                                        \
        (void)c;                                                                                             \
        return expr;                                                                                         \
    }
ROWS(DEFINE_CALL)
#undef DEFINE_CALL

static const row g_rows[] = {
#define ROW(name, narrow, job, expr) {"locd_" #name, call_##name, narrow, job},
    ROWS(ROW)
#undef ROW
};

static void every_success_clears_the_last_error(void)
{
    ctx c;
    size_t i;
    int narrow = narrow_built();
    ctx_up(&c);
    for (i = 0; i < sizeof g_rows / sizeof g_rows[0]; i++) {
        const row *r = &g_rows[i];
        if (r->narrow && !narrow)
            continue;
        if (r->job)
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, new_job(&c));
        provoke_error();
        assert_cleared(r->name, r->call(&c));
    }
    ctx_down(&c);
}

/* The service's own calls, and the client's at level 3, on the threads that
 * make them. */
typedef struct svc_run {
    locd_service *s;
    locd_status st;
    int provoked; /* raise_error worked on the service's thread */
    int cleared;
} svc_run;

static void *service_thread(void *arg)
{
    svc_run *r = arg;
    r->provoked = raise_error();
    r->st = locd_service_run(r->s);
    r->cleared = locd_last_error()[0] == '\0' && locd_last_error_index() == -1;
    return NULL;
}

static void service_start(char *dir, size_t dirlen, svc_run *r, pthread_t *th, const locd_allocator *a)
{
    locd_service_config sc;
    char listen[300];
    (void)a;
    snprintf(dir, dirlen, "/tmp/locd-contract-XXXXXX");
    TEST_ASSERT_NOT_NULL(mkdtemp(dir));
    snprintf(listen, sizeof listen, "unix:%s/s.sock", dir);
    locd_service_config_init(&sc);
    sc.listen = listen;
    sc.threads = 1;
    memset(r, 0, sizeof *r);
    provoke_error();
    assert_cleared("locd_service_create", locd_service_create(&sc, &r->s));
    TEST_ASSERT_EQUAL_INT64(0, pthread_create(th, NULL, service_thread, r));
}

static void service_finish(char *dir, svc_run *r, pthread_t th)
{
    char path[300];
    locd_service_stop(r->s);
    TEST_ASSERT_EQUAL_INT64(0, pthread_join(th, NULL));
    locd_service_destroy(r->s);
    snprintf(path, sizeof path, "%s/s.sock", dir);
    unlink(path);
    rmdir(dir);
    TEST_ASSERT_TRUE_MESSAGE(r->provoked, "the service's thread could not raise an error before its run");
}

static locd_engine *service_engine(const char *address, const locd_allocator *a)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_engine_config_init(&cfg);
    cfg.level = LOCD_LEVEL_SERVICE;
    cfg.service_address = address;
    if (a)
        cfg.allocator = *a;
    provoke_error();
    assert_cleared("locd_engine_create (level 3)", locd_engine_create(&cfg, &e));
    return e;
}

static void service_calls_clear_the_last_error(void)
{
    char dir[64];
    svc_run r;
    pthread_t th;
    locd_engine *e;
    locd_pairs *p;
    locd_job *job;
    float *f = ts_scene(0, SCENE_N, 9);
    service_start(dir, sizeof dir, &r, &th, NULL);
    e = service_engine(locd_service_address(r.s), NULL);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    provoke_error();
    assert_cleared("locd_engine_find_pairs_f32 (level 3)", locd_engine_find_pairs_f32(e, f, SCENE_N, 0, p));
    provoke_error();
    assert_cleared("locd_engine_submit_f32 (level 3)", locd_engine_submit_f32(e, f, SCENE_N, 0, &job));
    provoke_error();
    assert_cleared("locd_job_wait (level 3)", locd_job_wait(job, -1));
    provoke_error();
    assert_cleared("locd_job_take (level 3)", locd_job_take(job, p));
    locd_job_release(job);
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    service_finish(dir, &r, th);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, r.st);
    TEST_ASSERT_TRUE(r.cleared);
    free(f);
}

/* ---- versioned structs ---- */

#define PAD 64
typedef union big {
    unsigned char bytes[1024];
    double align;
} big;

/* True when bytes [from, to) of b all still hold the fill pattern. */
static int untouched(const big *b, size_t from, size_t to)
{
    size_t i;
    for (i = from; i < to; i++)
        if (b->bytes[i] != 0xab)
            return 0;
    return 1;
}

static void set_size(big *b, uint32_t size)
{
    memset(b->bytes, 0xab, sizeof b->bytes);
    memcpy(b->bytes, &size, sizeof size);
}

static uint32_t get_size(const big *b)
{
    uint32_t size;
    memcpy(&size, b->bytes, sizeof size);
    return size;
}

static void outputs_stop_at_the_callers_size(void)
{
    ctx c;
    big b;
    ctx_up(&c);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(c.e, c.f, SCENE_N, 0, c.p));
    /* An older caller's short stats: only its bytes are written. */
    set_size(&b, LOCD_STATS_MIN_SIZE);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_stats(c.e, (locd_stats *)b.bytes));
    TEST_ASSERT_EQUAL_INT64(LOCD_STATS_MIN_SIZE, get_size(&b));
    TEST_ASSERT_TRUE(untouched(&b, LOCD_STATS_MIN_SIZE, sizeof b.bytes));
    set_size(&b, LOCD_STATS_MIN_SIZE - 1);
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_stats(c.e, (locd_stats *)b.bytes));
    /* A newer caller's longer stats is refused, untouched. */
    set_size(&b, sizeof(locd_stats) + PAD);
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_stats(c.e, (locd_stats *)b.bytes));
    TEST_ASSERT_TRUE(untouched(&b, sizeof(uint32_t), sizeof b.bytes));
    /* The library's own size: every field. */
    set_size(&b, sizeof(locd_stats));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_stats(c.e, (locd_stats *)b.bytes));
    TEST_ASSERT_EQUAL_INT64(SCENE_N, ((locd_stats *)b.bytes)->objects);
    TEST_ASSERT_TRUE(untouched(&b, sizeof(locd_stats), sizeof b.bytes));
    /* The sweep's stats follow the same rule (it used to want the whole struct). */
    set_size(&b, offsetof(locd_stats, candidates));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK,
                            locd_sweep_f32(&c.grid, c.f, SCENE_N, c.entries, c.nentries, c.p, (locd_stats *)b.bytes));
    TEST_ASSERT_EQUAL_INT64(c.nentries, ((locd_stats *)b.bytes)->entries);
    TEST_ASSERT_TRUE(untouched(&b, offsetof(locd_stats, candidates), sizeof b.bytes));
    /* A job's stats. */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, new_job(&c));
    set_size(&b, LOCD_STATS_MIN_SIZE);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_stats(c.job, (locd_stats *)b.bytes));
    TEST_ASSERT_TRUE(untouched(&b, LOCD_STATS_MIN_SIZE, sizeof b.bytes));
    ctx_down(&c);
}

static void grid_fit_bounds_its_write(void)
{
    ctx c;
    big b;
    size_t w;
    ctx_up(&c);
    /* Uninitialized (here: 0xabababab) or larger than the library's: it
     * writes its own grid and says so in size. */
    set_size(&b, 0xabababab);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK,
                            locd_grid_fit_f32(c.f, SCENE_N, 0, LOCD_DEFAULT_CELL_BIAS, 0, (locd_grid *)b.bytes));
    TEST_ASSERT_EQUAL_INT64(sizeof(locd_grid), get_size(&b));
    TEST_ASSERT_TRUE(untouched(&b, sizeof(locd_grid), sizeof b.bytes));
    TEST_ASSERT_EQUAL_MEMORY(&c.grid, b.bytes, sizeof(locd_grid));
    set_size(&b, 0);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK,
                            locd_grid_fit_f32(c.f, SCENE_N, 0, LOCD_DEFAULT_CELL_BIAS, 0, (locd_grid *)b.bytes));
    TEST_ASSERT_EQUAL_INT64(LOCD_GRID_MIN_SIZE, get_size(&b));
    TEST_ASSERT_TRUE(untouched(&b, LOCD_GRID_MIN_SIZE, sizeof b.bytes));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_encode_f32((locd_grid *)b.bytes, c.f, 0, SCENE_N, c.scratch,
                                     LOCD_MAX_ENTRIES_PER_BOX * SCENE_N, &w));
    TEST_ASSERT_EQUAL_INT64(c.nentries, w);
    /* A grid whose size says it is not one the library wrote. */
    ((locd_grid *)b.bytes)->size = LOCD_GRID_MIN_SIZE - 8;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT,
                            locd_sort_entries((locd_grid *)b.bytes, c.entries, c.scratch, c.nentries));
    ctx_down(&c);
}

static void inputs_accept_the_minimum_and_reject_outside(void)
{
    big b;
    locd_engine *e = NULL;
    locd_engine_config cfg;
    locd_service_config sc;
    locd_service *s = NULL;
    locd_engine_config_init(&cfg);
    cfg.threads = 1;
    memset(b.bytes, 0, sizeof b.bytes);
    memcpy(b.bytes, &cfg, sizeof cfg);
    ((locd_engine_config *)b.bytes)->size = LOCD_ENGINE_CONFIG_MIN_SIZE;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create((locd_engine_config *)b.bytes, &e));
    TEST_ASSERT_EQUAL_INT64(1, locd_engine_threads(e));
    locd_engine_destroy(e);
    ((locd_engine_config *)b.bytes)->size = LOCD_ENGINE_CONFIG_MIN_SIZE - 1;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create((locd_engine_config *)b.bytes, &e));
    ((locd_engine_config *)b.bytes)->size = sizeof cfg + PAD;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create((locd_engine_config *)b.bytes, &e));
    TEST_ASSERT_NOT_NULL(strstr(locd_last_error(), "config->size"));
    locd_service_config_init(&sc);
    sc.size = LOCD_SERVICE_CONFIG_MIN_SIZE - 1;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_service_create(&sc, &s));
    sc.size = sizeof sc + 1;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_service_create(&sc, &s));
    TEST_ASSERT_NULL(s);
}

static void pipeline_structs_follow_the_rules(void)
{
    locd_world *w;
    locd_shape *sp;
    locd_contacts *ct;
    locd_pipeline_options o;
    big b;
    if (!narrow_built())
        TEST_IGNORE_MESSAGE("no narrow phase in this build");
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_sphere(1.0, &sp));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_create(NULL, &w));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_contacts_create(&ct));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_add(w, sp, g_pose, NULL, NULL));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_add(w, sp, g_pose2, NULL, NULL));
    locd_pipeline_options_init(&o);
    o.size = LOCD_PIPELINE_OPTIONS_MIN_SIZE;
    /* A short struct has no route table to write into. */
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT,
                            locd_pipeline_options_route(&o, LOCD_SHAPE_SPHERE, LOCD_SHAPE_BOX, LOCD_ROUTE_CLOSED));
    set_size(&b, LOCD_PIPELINE_STATS_MIN_SIZE + 4);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_collide(w, &o, ct, (locd_pipeline_stats *)b.bytes));
    TEST_ASSERT_EQUAL_INT64(1, locd_contacts_count(ct));
    TEST_ASSERT_EQUAL_INT64(2, ((locd_pipeline_stats *)b.bytes)->objects);
    TEST_ASSERT_TRUE(untouched(&b, LOCD_PIPELINE_STATS_MIN_SIZE + 4, sizeof b.bytes));
    set_size(&b, sizeof(locd_pipeline_stats));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_collide(w, NULL, ct, (locd_pipeline_stats *)b.bytes));
    TEST_ASSERT_TRUE(untouched(&b, sizeof(locd_pipeline_stats), sizeof b.bytes));
    set_size(&b, sizeof(locd_pipeline_stats) + PAD);
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_world_collide(w, NULL, ct, (locd_pipeline_stats *)b.bytes));
    o.size = LOCD_PIPELINE_OPTIONS_MIN_SIZE - 1;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_world_collide(w, &o, ct, NULL));
    set_size(&b, 0);
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_world_collide(w, NULL, ct, (locd_pipeline_stats *)b.bytes));
    locd_contacts_destroy(ct);
    locd_world_destroy(w);
    locd_shape_destroy(sp);
}

/* ---- jobs: LOCD_PENDING while running ---- */

static void take_and_stats_say_pending_while_the_job_runs(void)
{
    locd_engine_config cfg;
    locd_engine *e;
    locd_pairs *p;
    locd_job *first, *second;
    locd_stats st;
    size_t n = 1000000;
    float *f = ts_scene(0, n, 13), one[12] = {0, 0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1};
    locd_engine_config_init(&cfg);
    cfg.threads = 1;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, one, 2, 0, p));
    /* The second job waits in the engine's queue behind a long first one. */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_submit_f32(e, f, n, 0, &first));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_submit_f32(e, one, 2, 0, &second));
    locd_stats_init(&st);
    st.objects = 12345;
    provoke_error();
    TEST_ASSERT_EQUAL_INT64(LOCD_PENDING, locd_job_take(second, p));
    assert_cleared("locd_job_take (pending)", LOCD_PENDING);
    TEST_ASSERT_EQUAL_INT64(1, locd_pairs_count(p)); /* unchanged */
    provoke_error();
    TEST_ASSERT_EQUAL_INT64(LOCD_PENDING, locd_job_stats(second, &st));
    assert_cleared("locd_job_stats (pending)", LOCD_PENDING);
    TEST_ASSERT_EQUAL_INT64(12345, st.objects); /* unchanged */
    provoke_error();
    TEST_ASSERT_EQUAL_INT64(LOCD_PENDING, locd_job_poll(second));
    assert_cleared("locd_job_poll (pending)", LOCD_PENDING);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_wait(second, -1));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_stats(second, &st));
    TEST_ASSERT_EQUAL_INT64(2, st.objects);
    locd_job_release(first);
    locd_job_release(second);
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    free(f);
}

/* ---- errors passed on read like the direct call's ---- */

/* An engine's error read directly, through a job's wait and through its
 * take: the same text and index. Failures are reported at the caller's line. */
#define expect_same_error(e, bad, n) expect_same_error_(__LINE__, (e), (bad), (n))
static void expect_same_error_(int line, locd_engine *e, const float *bad, size_t n)
{
    char direct[256];
    locd_pairs *p;
    locd_job *job;
    int64_t index;
    UNITY_TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p), line, "locd_pairs_create");
    UNITY_TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVERTED_BOX, locd_engine_find_pairs_f32(e, bad, n, 0, p), line,
                                  "direct call");
    snprintf(direct, sizeof direct, "%s", locd_last_error());
    index = locd_last_error_index();
    UNITY_TEST_ASSERT_EQUAL_STRING("box with min > max: box 3", direct, line, "direct call's message");
    UNITY_TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_submit_f32(e, bad, n, 0, &job), line, "submit");
    UNITY_TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVERTED_BOX, locd_job_wait(job, -1), line, "job wait");
    UNITY_TEST_ASSERT_EQUAL_STRING(direct, locd_last_error(), line, "job wait's message");
    UNITY_TEST_ASSERT_EQUAL_INT64(index, locd_last_error_index(), line, "job wait's index");
    UNITY_TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVERTED_BOX, locd_job_take(job, p), line, "job take");
    UNITY_TEST_ASSERT_EQUAL_STRING(direct, locd_last_error(), line, "job take's message");
    locd_job_release(job);
    locd_pairs_destroy(p);
}

static void errors_passed_on_keep_their_text(void)
{
    char dir[64];
    svc_run r;
    pthread_t th;
    locd_engine *e;
    locd_engine_config cfg;
    float bad[30] = {0};
    size_t i;
    for (i = 0; i < 5; i++)
        bad[6 * i + 3] = bad[6 * i + 4] = bad[6 * i + 5] = 1;
    bad[6 * 3 + 1] = 2; /* box 3: min y 2 > max y 1 */
    locd_engine_config_init(&cfg);
    cfg.threads = 1;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
    expect_same_error(e, bad, 5);
    locd_engine_destroy(e);
    service_start(dir, sizeof dir, &r, &th, NULL);
    e = service_engine(locd_service_address(r.s), NULL);
    expect_same_error(e, bad, 5);
    locd_engine_destroy(e);
    service_finish(dir, &r, th);
}

/* ---- the caller's allocator ---- */

typedef struct alloc_window {
    fa_counts before;
    uint64_t mallocs;
} alloc_window;

static void window_open(alloc_window *w)
{
    fa_counts_get(&w->before);
    w->mallocs = mallocs();
}

/* Hook allocations and malloc calls by locd's code since window_open. */
static void window_close(const alloc_window *w, uint64_t *hooked, uint64_t *mallocd, int64_t *live)
{
    fa_counts now;
    fa_counts_get(&now);
    *hooked = now.calls - w->before.calls;
    *mallocd = mallocs() - w->mallocs;
    *live = (int64_t)now.live_blocks - (int64_t)w->before.live_blocks;
    TEST_ASSERT_EQUAL_INT64(w->before.bad_frees, now.bad_frees);
}

/* The world's life: create, add, move, collide (closed forms only: the
 * routes through libccd and FCL allocate inside those libraries). */
static void world_life(const locd_allocator *a, locd_shape *const *shapes, size_t nshapes, locd_contacts *ct)
{
    locd_engine_config cfg;
    locd_pipeline_options o;
    locd_pipeline_stats ps;
    locd_world *w;
    double pose[7] = {0, 0, 0, 0, 0, 0, 1};
    size_t i;
    locd_engine_config_init(&cfg);
    cfg.threads = 1;
    if (a)
        cfg.allocator = *a;
    locd_pipeline_options_init(&o);
    o.stages = LOCD_STAGE_SHAPE | LOCD_STAGE_CONTACT;
    o.swept = LOCD_SWEPT_ON;
    o.dt = 0.1;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK,
                            locd_pipeline_options_route(&o, LOCD_SHAPE_BOX, LOCD_SHAPE_BOX, LOCD_ROUTE_CLOSED));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK,
                            locd_pipeline_options_route(&o, LOCD_SHAPE_SPHERE, LOCD_SHAPE_BOX, LOCD_ROUTE_CLOSED));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK,
                            locd_pipeline_options_route(&o, LOCD_SHAPE_SPHERE, LOCD_SHAPE_SPHERE, LOCD_ROUTE_CLOSED));
    locd_pipeline_stats_init(&ps);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_create(&cfg, &w));
    for (i = 0; i < 200; i++) {
        pose[0] = 1.5 * (double)(i % 20);
        pose[1] = 1.5 * (double)(i / 20);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_add(w, shapes[i % nshapes], pose, i % 2 ? g_vel : NULL, NULL));
    }
    pose[0] = 0.5;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_set_pose(w, 1, pose));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_world_collide(w, &o, ct, &ps));
    TEST_ASSERT_TRUE(locd_contacts_count(ct) > 0);
    locd_world_destroy(w);
}

static void world_memory_comes_from_the_hook(void)
{
    locd_shape *shapes[2];
    locd_contacts *ct;
    alloc_window win;
    uint64_t hooked, mallocd;
    int64_t live;
    if (!narrow_built())
        TEST_IGNORE_MESSAGE("no narrow phase in this build");
    /* Stated exceptions: shapes and contacts have no allocator; the test
     * sees their malloc calls (if it no longer does, update locd.h). */
    window_open(&win);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_sphere(0.6, &shapes[0]));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_shape_box(0.5, 0.5, 0.5, &shapes[1]));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_contacts_create(&ct));
    window_close(&win, &hooked, &mallocd, &live);
    TEST_ASSERT_TRUE(mallocd >= 3);
    /* Without a hook the world's life calls malloc (the test can see it)... */
    window_open(&win);
    world_life(NULL, shapes, 2, ct); /* also grows the contacts (malloc) once */
    window_close(&win, &hooked, &mallocd, &live);
    TEST_ASSERT_TRUE(mallocd > 0);
    /* ...with one, only the hook, and everything is given back. */
    window_open(&win);
    world_life(fa_allocator(), shapes, 2, ct);
    window_close(&win, &hooked, &mallocd, &live);
    TEST_ASSERT_TRUE(hooked > 0);
    TEST_ASSERT_EQUAL_INT64(0, mallocd);
    TEST_ASSERT_EQUAL_INT64(0, live);
    locd_contacts_destroy(ct);
    locd_shape_destroy(shapes[0]);
    locd_shape_destroy(shapes[1]);
}

static void engine_levels_memory_comes_from_the_hook(void)
{
    char dir[64];
    svc_run r;
    pthread_t th;
    lu_fixture fx;
    alloc_window win;
    uint64_t hooked, mallocd;
    int64_t live;
    locd_engine *e;
    locd_pairs *p;
    locd_job *job;
    float *f = ts_scene(0, SCENE_N, 17);
    int level;
    /* Stated exception: the service has no allocator (nor its runners). */
    window_open(&win);
    service_start(dir, sizeof dir, &r, &th, NULL);
    service_finish(dir, &r, th);
    window_close(&win, &hooked, &mallocd, &live);
    TEST_ASSERT_TRUE(mallocd > 0);
    /* An engine at level 1 and at level 3 (the client side; the service in
     * its own process): only the hook. */
    TEST_ASSERT_EQUAL_INT64(0, lu_fixture_up(&fx));
    for (level = LOCD_LEVEL_INPROCESS; level <= LOCD_LEVEL_SERVICE; level += 2) {
        window_open(&win);
        if (level == LOCD_LEVEL_SERVICE) {
            e = service_engine(fx.addr, fa_allocator());
        } else {
            locd_engine_config cfg;
            locd_engine_config_init(&cfg);
            cfg.threads = 2;
            cfg.allocator = *fa_allocator();
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
        }
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(fa_allocator(), &p));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, f, SCENE_N, LOCD_FIND_SORTED, p));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_submit_f32(e, f, SCENE_N, 0, &job));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_wait(job, -1));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_take(job, p));
        locd_job_release(job);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_sort(p));
        locd_pairs_destroy(p);
        locd_engine_destroy(e);
        window_close(&win, &hooked, &mallocd, &live);
        TEST_ASSERT_TRUE(hooked > 0);
        TEST_ASSERT_EQUAL_INT64(0, mallocd);
        TEST_ASSERT_EQUAL_INT64(0, live);
    }
    lu_fixture_down(&fx);
    free(f);
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(every_success_clears_the_last_error),
        LT_TEST(service_calls_clear_the_last_error),
        LT_TEST(outputs_stop_at_the_callers_size),
        LT_TEST(grid_fit_bounds_its_write),
        LT_TEST(inputs_accept_the_minimum_and_reject_outside),
        LT_TEST(pipeline_structs_follow_the_rules),
        LT_TEST(take_and_stats_say_pending_while_the_job_runs),
        LT_TEST(errors_passed_on_keep_their_text),
        LT_TEST(world_memory_comes_from_the_hook),
        LT_TEST(engine_levels_memory_comes_from_the_hook),
    };
    return LT_RUN(tests);
}
