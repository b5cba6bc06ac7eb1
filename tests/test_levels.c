/* Integration levels with real processes: level 2 (locd-worker processes)
 * and level 3 (a `locd serve` process) return exactly level 1's pairs, in
 * the same order; jobs work at every level; a worker killed mid-call never
 * yields wrong pairs or a hang; a crashed host leaves nothing behind; 1,000
 * engine create/destroy cycles leak no segment, fd or process. */
#include <signal.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <pthread.h>
#include <sys/wait.h>
#include <unistd.h>

#include "runner.h"

#include "levels_util.h"
#include "support.h"

static lu_fixture g_fx = {"", "", "", -1};

static locd_engine *make_engine(int level, uint32_t threads, const char *addr)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_status st;
    locd_engine_config_init(&cfg);
    cfg.level = level;
    cfg.threads = threads;
    cfg.service_address = addr;
    st = locd_engine_create(&cfg, &e);
    if (st != LOCD_OK)
        LT_FAIL("level %d engine: %s", level, locd_last_error());
    return e;
}

static double *to_f64(const float *b, size_t n)
{
    double *d = malloc((n ? n : 1) * 6 * sizeof *d);
    size_t i;
    for (i = 0; i < 6 * n; i++)
        d[i] = b[i];
    return d;
}

static void levels_give_identical_pairs(void)
{
    static const size_t sizes[] = {0, 1, 2, 17, 900, 5000, 30000};
    size_t nsizes = lu_heavy() ? sizeof sizes / sizeof sizes[0] : 6;
    locd_engine *e1 = make_engine(LOCD_LEVEL_INPROCESS, 2, NULL);
    locd_engine *e2 = make_engine(LOCD_LEVEL_WORKERS, 2, NULL);
    locd_engine *e2b = make_engine(LOCD_LEVEL_WORKERS, 3, NULL);
    locd_engine *e3 = make_engine(LOCD_LEVEL_SERVICE, 0, g_fx.addr);
    locd_engine *others[3];
    locd_pairs *ref, *got;
    int kind, o;
    size_t si;
    others[0] = e2;
    others[1] = e2b;
    others[2] = e3;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &ref));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &got));
    for (kind = 0; kind < TS_SCENE_KINDS; kind++)
        for (si = 0; si < nsizes; si++) {
            size_t n = sizes[si];
            float *b;
            double *d;
            if (n > 1500 && (kind == 1 || kind == 3 || kind == 4))
                continue; /* dense kinds: millions of pairs, nothing more to learn */
            b = ts_scene(kind, n ? n : 1, 77u * (uint64_t)kind + si);
            d = to_f64(b, n);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e1, b, n, 0, ref));
            if (n <= 5000 && !ts_same_as_brute_f32(b, n, ref))
                LT_FAIL("level 1 differs from brute force (kind %d n %zu)", kind, n);
            for (o = 0; o < 3; o++) {
                locd_status st = locd_engine_find_pairs_f32(others[o], b, n, 0, got);
                if (st != LOCD_OK)
                    LT_FAIL("engine %d kind %d n %zu: %s", o, kind, n, locd_last_error());
                if (!lu_same_pairs(ref, got))
                    LT_FAIL("engine %d (level %d) differs from level 1: kind %d n %zu (%zu vs %zu pairs)", o,
                            locd_engine_level(others[o]), kind, n, locd_pairs_count(got), locd_pairs_count(ref));
            }
            /* float64 entry points, sorted order */
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f64(e1, d, n, LOCD_FIND_SORTED, ref));
            for (o = 0; o < 3; o++) {
                TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f64(others[o], d, n, LOCD_FIND_SORTED, got));
                if (!lu_same_pairs(ref, got))
                    LT_FAIL("f64: engine %d differs from level 1: kind %d n %zu", o, kind, n);
            }
            free(b);
            free(d);
        }
    locd_engine_destroy(e1);
    locd_engine_destroy(e2);
    locd_engine_destroy(e2b);
    locd_engine_destroy(e3);
    locd_pairs_destroy(ref);
    locd_pairs_destroy(got);
}

/* The engine's octree settings travel to the workers' grid and to the
 * service's engines: the order stays level 1's for every setting. */
static void octree_settings_reach_every_level(void)
{
    static const struct {
        uint32_t depth;
        int32_t bias;
        uint32_t flags;
    } v[] = {{0, 1, LOCD_CONFIG_CUBES}, {8, 3, 0}, {3, 0, 0}, {21, 8, LOCD_CONFIG_CUBES}};
    size_t i, n = 8000;
    float *b = ts_scene(2, n, 555);
    locd_pairs *ref, *got;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &ref));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &got));
    for (i = 0; i < sizeof v / sizeof v[0]; i++) {
        int level;
        for (level = 1; level <= 3; level++) {
            locd_engine_config cfg;
            locd_engine *e = NULL;
            locd_engine_config_init(&cfg);
            cfg.level = level;
            cfg.threads = 2;
            cfg.max_depth = v[i].depth;
            cfg.cell_bias = v[i].bias;
            cfg.flags = v[i].flags;
            cfg.service_address = g_fx.addr;
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, n, 0, level == 1 ? ref : got));
            if (level > 1 && !lu_same_pairs(ref, got))
                LT_FAIL("level %d differs from level 1 with depth %u bias %d flags %u", level, v[i].depth,
                        (int)v[i].bias, v[i].flags);
            if (level == 1 && !ts_same_as_brute_f32(b, n, ref))
                LT_FAIL("level 1 differs from brute force with depth %u", v[i].depth);
            locd_engine_destroy(e);
        }
    }
    free(b);
    locd_pairs_destroy(ref);
    locd_pairs_destroy(got);
}

static void invalid_boxes_same_error_at_every_level(void)
{
    int level;
    for (level = 1; level <= 3; level++) {
        locd_engine *e = make_engine(level, 2, level == 3 ? g_fx.addr : NULL);
        locd_pairs *p;
        float *b = ts_scene(0, 6000, 5);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
        b[6 * 4321 + 2] = b[6 * 4321 + 5] + 1.0f; /* min > max */
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVERTED_BOX, locd_engine_find_pairs_f32(e, b, 6000, 0, p));
        TEST_ASSERT_EQUAL_INT64(4321, locd_last_error_index());
        b[6 * 100] = 0.0f / 0.0f;
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_f32(e, b, 6000, 0, p));
        TEST_ASSERT_EQUAL_INT64(100, locd_last_error_index());
        free(b);
        locd_pairs_destroy(p);
        locd_engine_destroy(e);
    }
}

static void jobs_at_every_level(void)
{
    int level;
    for (level = 1; level <= 3; level++) {
        locd_engine *e = make_engine(level, 2, level == 3 ? g_fx.addr : NULL);
        locd_engine *ref = make_engine(LOCD_LEVEL_INPROCESS, 1, NULL);
        locd_pairs *want, *got;
        locd_job *j = NULL, *j2 = NULL;
        locd_stats st;
        locd_status s;
        size_t n = lu_heavy() ? 40000 : 8000;
        float *b = ts_scene(0, n, 1234 + (uint64_t)level);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &want));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &got));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(ref, b, n, 0, want));

        {
            float *tmp = malloc(n * 6 * sizeof *tmp);
            memcpy(tmp, b, n * 6 * sizeof *tmp);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_submit_f32(e, tmp, n, 0, &j));
            memset(tmp, 0xff, n * 6 * sizeof *tmp); /* NaNs: the job must own a copy */
            free(tmp);
        }
        s = locd_job_poll(j);
        TEST_ASSERT_TRUE(s == LOCD_OK || s == LOCD_PENDING);
        if (level < 3) {
            /* levels 1 and 2 run one job at a time per engine */
            s = locd_engine_find_pairs_f32(e, b, n, 0, got);
            TEST_ASSERT_TRUE(s == LOCD_ERR_BUSY || s == LOCD_OK);
        }
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_wait(j, -1));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_poll(j));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_take(j, got));
        if (!lu_same_pairs(want, got))
            LT_FAIL("level %d job result differs from level 1", level);
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_job_take(j, got)); /* taken once */
        locd_stats_init(&st);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_stats(j, &st));
        TEST_ASSERT_EQUAL_INT64(n, st.objects);
        TEST_ASSERT_EQUAL_INT64(locd_pairs_count(want), st.pairs);
        locd_job_release(j);

        /* cancel: wait reports LOCD_ERR_CANCELLED unless it had finished */
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_submit_f32(e, b, n, 0, &j));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_cancel(j));
        s = locd_job_wait(j, 10000);
        TEST_ASSERT_TRUE(s == LOCD_ERR_CANCELLED || s == LOCD_OK);
        locd_job_release(j);

        /* timeout 0 on a fresh large job, then a bounded wait */
        if (level < 3) {
            double until = lu_now_ms() + 10000;
            while (locd_engine_submit_f32(e, b, n, 0, &j2) == LOCD_ERR_BUSY && lu_now_ms() < until)
                lu_sleep_ms(1); /* the cancelled job's thread is finishing */
        } else {
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_submit_f32(e, b, n, LOCD_FIND_SORTED, &j2));
        }
        TEST_ASSERT_NOT_NULL(j2);
        s = locd_job_wait(j2, 0);
        TEST_ASSERT_TRUE(s == LOCD_ERR_TIMEOUT || s == LOCD_OK);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_wait(j2, 60000));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_take(j2, got));
        TEST_ASSERT_EQUAL_INT64(locd_pairs_count(want), locd_pairs_count(got));
        locd_job_release(j2);

        /* released without waiting: no leak, engine usable afterwards */
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_submit_f32(e, b, n, 0, &j));
        locd_job_release(j);
        {
            double until = lu_now_ms() + 10000;
            while ((s = locd_engine_find_pairs_f32(e, b, n, 0, got)) == LOCD_ERR_BUSY && lu_now_ms() < until)
                lu_sleep_ms(1);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, s);
        }
        /* errors travel through jobs with their index */
        b[6 * 777 + 1] = 1.0f / 0.0f;
        {
            double until = lu_now_ms() + 10000;
            while ((s = locd_engine_submit_f32(e, b, n, 0, &j)) == LOCD_ERR_BUSY && lu_now_ms() < until)
                lu_sleep_ms(1);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, s);
        }
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_job_wait(j, -1));
        TEST_ASSERT_EQUAL_INT64(777, locd_last_error_index());
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_job_take(j, got));
        locd_job_release(j);

        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_HANDLE, locd_job_poll(NULL));
        locd_job_release(NULL);
        free(b);
        locd_pairs_destroy(want);
        locd_pairs_destroy(got);
        locd_engine_destroy(ref);
        locd_engine_destroy(e);
    }
}

/* Levels 1 and 2 queue jobs on the engine and run them one after another;
 * queued jobs can be cancelled or released; all results are right. */
static void queued_jobs_levels_1_and_2(void)
{
    int level;
    for (level = 1; level <= 2; level++) {
        locd_engine *e = make_engine(level, 2, NULL);
        locd_job *j[12];
        float *b[12];
        size_t n[12];
        locd_pairs *p;
        int i;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
        for (i = 0; i < 12; i++) {
            n[i] = 300 + 400 * (size_t)i;
            b[i] = ts_scene(i % 2 ? 2 : 0, n[i], 900 + (uint64_t)i);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK,
                                    locd_engine_submit_f32(e, b[i], n[i], i % 3 ? 0 : LOCD_FIND_SORTED, &j[i]));
        }
        {
            locd_status s = locd_engine_find_pairs_f32(e, b[0], n[0], 0, p); /* busy unless all are done */
            TEST_ASSERT_TRUE(s == LOCD_ERR_BUSY || s == LOCD_OK);
        }
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_cancel(j[7]));
        locd_job_release(j[9]);
        j[9] = NULL;
        for (i = 11; i >= 0; i--) { /* any order */
            locd_status s;
            if (!j[i])
                continue;
            s = locd_job_wait(j[i], 60000);
            if (i == 7) {
                TEST_ASSERT_TRUE(s == LOCD_ERR_CANCELLED || s == LOCD_OK);
            } else {
                TEST_ASSERT_EQUAL_INT64(LOCD_OK, s);
                TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_job_take(j[i], p));
                if (!ts_same_as_brute_f32(b[i], n[i], p))
                    LT_FAIL("level %d queued job %d differs from brute force", level, i);
            }
            locd_job_release(j[i]);
        }
        for (i = 0; i < 12; i++)
            free(b[i]);
        {
            double until = lu_now_ms() + 10000; /* the queue's thread gives the engine back */
            locd_status s;
            float *one = ts_scene(0, 3000, 1);
            while ((s = locd_engine_find_pairs_f32(e, one, 3000, 0, p)) == LOCD_ERR_BUSY && lu_now_ms() < until)
                lu_sleep_ms(1);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, s);
            free(one);
        }
        locd_pairs_destroy(p);
        locd_engine_destroy(e);
    }
}

typedef struct kill_ctx {
    locd_engine *e;
    const float *b;
    size_t n;
    const locd_pairs *want;
    int calls, ok, worker_errors, wrong, other, ok_after; /* read across threads with __atomic */
    int stop, kills_done;
} kill_ctx;

static void *call_loop(void *arg)
{
    kill_ctx *k = arg;
    locd_pairs *p;
    locd_pairs_create(NULL, &p);
    while (!__atomic_load_n(&k->stop, __ATOMIC_ACQUIRE)) {
        locd_status s = locd_engine_find_pairs_f32(k->e, k->b, k->n, 0, p);
        __atomic_add_fetch(&k->calls, 1, __ATOMIC_RELEASE);
        if (s == LOCD_OK) {
            k->ok++;
            if (__atomic_load_n(&k->kills_done, __ATOMIC_ACQUIRE))
                __atomic_add_fetch(&k->ok_after, 1, __ATOMIC_RELEASE);
            k->wrong += !lu_same_pairs(k->want, p);
        } else if (s == LOCD_ERR_WORKER) {
            k->worker_errors++;
        } else {
            k->other++;
        }
    }
    locd_pairs_destroy(p);
    return NULL;
}

static void worker_killed_mid_call(void)
{
    locd_engine *e = make_engine(LOCD_LEVEL_WORKERS, 2, NULL);
    locd_engine *ref = make_engine(LOCD_LEVEL_INPROCESS, 1, NULL);
    size_t n = lu_heavy() ? 100000 : 20000;
    float *b = ts_scene(0, n, 99);
    locd_pairs *want, *p;
    kill_ctx k;
    pthread_t th;
    pid_t pids[8];
    int round, got, killed = 0;
    double t0;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &want));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(ref, b, n, 0, want));
    memset(&k, 0, sizeof k);
    k.e = e;
    k.b = b;
    k.n = n;
    k.want = want;
    TEST_ASSERT_EQUAL_INT64(0, pthread_create(&th, NULL, call_loop, &k));
    t0 = lu_now_ms();
    while (__atomic_load_n(&k.calls, __ATOMIC_ACQUIRE) < 1 && lu_now_ms() - t0 < 60000)
        lu_sleep_ms(5);
    for (round = 0; round < 5; round++) {
        lu_sleep_ms(20 + 25 * round);
        got = lu_children_named("locd-worker", pids, 8);
        if (got > 0 && kill(pids[round % got], SIGKILL) == 0)
            killed++;
    }
    __atomic_store_n(&k.kills_done, 1, __ATOMIC_RELEASE);
    t0 = lu_now_ms();
    while (__atomic_load_n(&k.ok_after, __ATOMIC_ACQUIRE) < 2 && lu_now_ms() - t0 < 60000) /* never a hang */
        lu_sleep_ms(5);
    __atomic_store_n(&k.stop, 1, __ATOMIC_RELEASE);
    pthread_join(th, NULL);
    TEST_ASSERT_TRUE(k.ok_after >= 2);
    TEST_ASSERT_TRUE(killed > 0);
    TEST_ASSERT_EQUAL_INT64(0, k.wrong);
    TEST_ASSERT_EQUAL_INT64(0, k.other);
    TEST_ASSERT_TRUE(k.ok > 0);
    /* still usable, with a full set of live workers and no zombies */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, n, 0, p));
    TEST_ASSERT_TRUE(lu_same_pairs(want, p));
    TEST_ASSERT_EQUAL_INT64(2, lu_children_named("locd-worker", NULL, 0));
    locd_engine_destroy(e);
    locd_engine_destroy(ref);
    TEST_ASSERT_EQUAL_INT64(0, lu_children_named("locd-worker", NULL, 0));
    TEST_ASSERT_EQUAL_INT64(1, lu_count_children()); /* the service only */
    {
        char prefix[64];
        snprintf(prefix, sizeof prefix, "locd-%ld-", (long)getpid());
        TEST_ASSERT_EQUAL_INT64(0, lu_count_shm(prefix));
    }
    LT_PRINT("# %d calls: %d ok, %d LOCD_ERR_WORKER, %d workers killed\n", k.calls, k.ok, k.worker_errors, killed);
    free(b);
    locd_pairs_destroy(want);
    locd_pairs_destroy(p);
}

/* A host that dies (SIGKILL) leaves no segment and no worker behind. */
static void host_crash_leaves_nothing(void)
{
    char prefix[64], pidstr[32];
    int pipefd[2], i;
    pid_t child;
    char c;
    TEST_ASSERT_EQUAL_INT64(0, pipe(pipefd));
    child = fork();
    if (child == 0) {
        locd_engine_config cfg;
        locd_engine *e = NULL;
        locd_pairs *p = NULL;
        float *b = ts_scene(0, 50000, 3);
        locd_engine_config_init(&cfg);
        cfg.level = LOCD_LEVEL_WORKERS;
        cfg.threads = 2;
        if (locd_engine_create(&cfg, &e) || locd_pairs_create(NULL, &p) ||
            locd_engine_find_pairs_f32(e, b, 50000, 0, p))
            _exit(1);
        if (write(pipefd[1], "r", 1) != 1)
            _exit(1);
        for (;;)
            pause();
    }
    close(pipefd[1]);
    TEST_ASSERT_EQUAL_INT64(1, read(pipefd[0], &c, 1));
    close(pipefd[0]);
    snprintf(prefix, sizeof prefix, "locd-%ld-", (long)child);
    snprintf(pidstr, sizeof pidstr, " %ld ", (long)child);
    TEST_ASSERT_EQUAL_INT64(2, lu_count_processes_with("locd-worker", pidstr));
    kill(child, SIGKILL);
    waitpid(child, NULL, 0);
    for (i = 0; i < 400 && (lu_count_processes_with("locd-worker", pidstr) || lu_count_shm(prefix)); i++)
        lu_sleep_ms(10); /* orphaned workers notice within a second */
    TEST_ASSERT_EQUAL_INT64(0, lu_count_processes_with("locd-worker", pidstr));
    TEST_ASSERT_EQUAL_INT64(0, lu_count_shm(prefix));
}

static void create_destroy_cycles_leak_nothing(void)
{
    char prefix[64];
    int fds0 = lu_count_fds(), children0 = lu_count_children(), i;
    float *b = ts_scene(2, 5000, 8);
    locd_pairs *p;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    snprintf(prefix, sizeof prefix, "locd-%ld-", (long)getpid());
    int cycles = lu_heavy() ? 1000 : 100;
    for (i = 0; i < cycles; i++) {
        /* one worker each: process start-up dominates on a loaded CI machine */
        locd_engine *e = make_engine(LOCD_LEVEL_WORKERS, 1, NULL);
        if (i % 50 == 0)
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, 5000, 0, p));
        locd_engine_destroy(e);
    }
    TEST_ASSERT_EQUAL_INT64(0, lu_count_shm(prefix));
    TEST_ASSERT_EQUAL_INT64(fds0, lu_count_fds());
    TEST_ASSERT_EQUAL_INT64(children0, lu_count_children());
    free(b);
    locd_pairs_destroy(p);
}

static void bad_worker_path_is_an_error(void)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_engine_config_init(&cfg);
    cfg.level = LOCD_LEVEL_WORKERS;
    cfg.worker_path = "/nonexistent/locd-worker";
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create(&cfg, &e));
    TEST_ASSERT_NULL(e);
    cfg.worker_path = "/bin/true"; /* exits at once: a worker error, not a hang */
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_WORKER, locd_engine_create(&cfg, &e));
    TEST_ASSERT_NULL(e);
}

static int setup(void)
{
    return lu_fixture_up(&g_fx);
}

static void teardown(void)
{
    lu_fixture_down(&g_fx);
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST_FIXTURE(levels_give_identical_pairs, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(octree_settings_reach_every_level, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(invalid_boxes_same_error_at_every_level, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(jobs_at_every_level, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(queued_jobs_levels_1_and_2, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(worker_killed_mid_call, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(host_crash_leaves_nothing, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(bad_worker_path_is_an_error, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(create_destroy_cycles_leak_nothing, lu_timer_start, lu_timer_print),
    };
    return LT_RUN_GROUP(tests, setup, teardown);
}
