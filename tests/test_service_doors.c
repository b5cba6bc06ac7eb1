/* Level 3's front doors with a real `locd serve` process: a stopped
 * service cannot hold a find or a wait(-1) past the job's deadline
 * (service_timeout_ms); failed secrets are answered slowly and their rate
 * is capped; a service with its own private /dev/shm (a container sharing
 * only the socket) still gets every job, streamed. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include "runner.h"

#include "levels_util.h"
#include "support.h"

static lu_fixture g_fx = {"", "", "", -1};

#define DOORS_SECRET "doors-test-secret-0123456789"

static locd_status make_engine(const char *addr, const char *secret, int64_t timeout_ms, locd_engine **e)
{
    locd_engine_config cfg;
    locd_engine_config_init(&cfg);
    cfg.level = LOCD_LEVEL_SERVICE;
    cfg.service_address = addr;
    cfg.service_secret = secret;
    cfg.service_timeout_ms = timeout_ms;
    return locd_engine_create(&cfg, e);
}

/* ---- item 3: per-call deadlines ---- */

/* A stopped service: a synchronous find and an asynchronous job waited on
 * with -1 both end with LOCD_ERR_TIMEOUT soon after the deadline; once
 * the service runs again the same engine works (the late results are
 * dropped). */
static void stopped_service_find_times_out(void)
{
    char dir[256], log[300], addr[300], actual[300];
    float *b = ts_scene(1, 2000, 5);
    locd_engine *e = NULL;
    locd_pairs *p = NULL;
    locd_job *j = NULL;
    double t0, took;
    pid_t svc;
    lu_temp_dir(dir, sizeof dir);
    snprintf(log, sizeof log, "%s/serve.log", dir);
    snprintf(addr, sizeof addr, "unix:%s/s.sock", dir);
    svc = lu_start_service(addr, NULL, 1, log, actual, sizeof actual);
    TEST_ASSERT_TRUE(svc > 0);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(actual, NULL, 800, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e, b, 2000, 0, p));
    TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, 2000, p));

    kill(svc, SIGSTOP);
    t0 = lu_now_ms();
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_TIMEOUT, locd_engine_find_pairs_f32(e, b, 2000, 0, p));
    took = lu_now_ms() - t0;
    LT_PRINT("# find on a stopped service: LOCD_ERR_TIMEOUT after %.0f ms (deadline 800 ms + 20 ms)\n", took);
    TEST_ASSERT_TRUE_MESSAGE(took >= 790 && took < 3000, "the find did not end at its deadline");
    TEST_ASSERT_NOT_NULL(strstr(locd_last_error(), "deadline"));

    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, b, 2000, 0, &j));
    t0 = lu_now_ms();
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_TIMEOUT, locd_job_wait(j, -1));
    took = lu_now_ms() - t0;
    TEST_ASSERT_TRUE_MESSAGE(took < 3000, "wait(-1) did not end at the job's deadline");
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_TIMEOUT, locd_job_poll(j)); /* finished, not still running */
    locd_job_release(j);

    kill(svc, SIGCONT);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e, b, 2000, LOCD_FIND_SORTED, p));
    TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, 2000, p));
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    lu_stop_service(svc, SIGTERM);
    TEST_ASSERT_EQUAL_INT(0, lu_count_shm("/locd-")); /* the timed-out jobs' segments are gone */
    lu_cleanup_dir(dir);
    free(b);
}

/* A big job streamed over TCP to a stopped service fills the socket: the
 * send must give up too (LOCD_ERR_TIMEOUT, not a hang). */
static void stopped_service_big_send_times_out(void)
{
    char dir[256], log[300], actual[300];
    size_t n = 400000; /* 9.6 MB: more than the socket buffers */
    float *b = ts_scene(0, n, 8);
    locd_engine *e = NULL;
    locd_pairs *p = NULL;
    double t0, took;
    locd_status st;
    pid_t svc;
    lu_temp_dir(dir, sizeof dir);
    snprintf(log, sizeof log, "%s/serve.log", dir);
    svc = lu_start_service("tcp:127.0.0.1:0", DOORS_SECRET, 1, log, actual, sizeof actual);
    TEST_ASSERT_TRUE(svc > 0);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(actual, DOORS_SECRET, 1000, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    kill(svc, SIGSTOP);
    t0 = lu_now_ms();
    st = locd_engine_find_pairs_f32(e, b, n, 0, p);
    took = lu_now_ms() - t0;
    LT_PRINT("# %zu boxes to a stopped service over TCP: status %d after %.0f ms\n", n, (int)st, took);
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_TIMEOUT, st);
    /* the deadline: 1000 ms + 10 us per box */
    TEST_ASSERT_TRUE_MESSAGE(took < 1000 + (double)n * 0.01 + 1500, "the send was not bounded");
    kill(svc, SIGCONT);
    /* The broken connection is replaced on the next call. */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e, b, 3000, 0, p));
    TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, 3000, p));
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    lu_stop_service(svc, SIGTERM);
    lu_cleanup_dir(dir);
    free(b);
}

/* service_timeout_ms < 0: no deadline; the default (0) is generous. A
 * job on a service that answers is never cut short. */
static void no_deadline_and_default(void)
{
    float *b = ts_scene(2, 3000, 12);
    locd_engine *e = NULL;
    locd_pairs *p = NULL;
    locd_engine_config cfg;
    locd_engine_config_init(&cfg);
    TEST_ASSERT_EQUAL_INT64(0, cfg.service_timeout_ms);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(g_fx.addr, NULL, -1, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e, b, 3000, 0, p));
    TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, 3000, p));
    locd_engine_destroy(e);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(g_fx.addr, NULL, 0, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e, b, 3000, 0, p));
    TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, 3000, p));
    locd_engine_destroy(e);
    locd_pairs_destroy(p);
    free(b);
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
        LT_TEST_FIXTURE(stopped_service_find_times_out, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(stopped_service_big_send_times_out, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(no_deadline_and_default, lu_timer_start, lu_timer_print),
    };
    return LT_RUN_GROUP(tests, setup, teardown);
}
