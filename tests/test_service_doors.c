/* Level 3's front doors with a real `locd serve` process: a stopped
 * service cannot hold a find or a wait(-1) past the job's deadline
 * (service_timeout_ms); failed secrets are answered slowly and their rate
 * is capped; a service with its own private /dev/shm (a container sharing
 * only the socket) still gets every job, streamed. */
#define _GNU_SOURCE
#include <locd/service.h>
#include <errno.h>
#include <dirent.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sched.h>
#include <sys/mount.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/un.h>
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

/* SIGSTOP, then waits until every thread of pid is stopped (kill returns
 * before they are: a runner could still be writing a result). */
static void stop_process(pid_t pid)
{
    char dir[64], path[400], buf[512];
    double until = lu_now_ms() + 5000.0;
    kill(pid, SIGSTOP);
    snprintf(dir, sizeof dir, "/proc/%ld/task", (long)pid);
    while (lu_now_ms() < until) {
        DIR *d = opendir(dir);
        struct dirent *de;
        int running = 0;
        if (!d)
            return;
        while ((de = readdir(d)) != NULL) {
            FILE *f;
            char *r;
            if (de->d_name[0] == '.')
                continue;
            snprintf(path, sizeof path, "%s/%s/stat", dir, de->d_name);
            if (!(f = fopen(path, "r")))
                continue;
            if (fgets(buf, sizeof buf, f) && (r = strrchr(buf, ')')) != NULL && r[2] != 'T' && r[2] != 't')
                running = 1;
            fclose(f);
        }
        closedir(d);
        if (!running)
            return;
        lu_sleep_ms(2);
    }
}

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

    stop_process(svc);
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
    stop_process(svc);
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

/* A fake service that answers the handshake, reads one SUBMIT (inline),
 * then sends the first 10 bytes of a RESULT header and stalls: a service
 * stopped in the middle of a message. */
typedef struct stalling_service {
    int lfd;
    int done; /* atomic */
} stalling_service;

static int read_n(int fd, void *buf, size_t n)
{
    size_t got = 0;
    while (got < n) {
        ssize_t r = read(fd, (char *)buf + got, n - got);
        if (r <= 0)
            return 0;
        got += (size_t)r;
    }
    return 1;
}

static void *stalling_main(void *arg)
{
    stalling_service *f = arg;
    uint8_t h[24], welcome[28], *skip;
    uint64_t len;
    uint32_t magic = 0x5344434cu, zero = 0;
    uint16_t ver = 1, type = 2;
    int fd = accept(f->lfd, NULL, NULL);
    if (fd < 0)
        return NULL;
    if (read_n(fd, h, 24) && (memcpy(&len, h + 16, 8), len < 4096) && (skip = malloc(len + 1)) != NULL) {
        read_n(fd, skip, (size_t)len); /* HELLO */
        free(skip);
        len = 4;
        memcpy(welcome, &magic, 4);
        memcpy(welcome + 4, &ver, 2);
        memcpy(welcome + 6, &type, 2);
        memset(welcome + 8, 0, 8);
        memcpy(welcome + 16, &len, 8);
        memcpy(welcome + 24, &zero, 4); /* no shared memory */
        if (write(fd, welcome, sizeof welcome) == (ssize_t)sizeof welcome && read_n(fd, h, 24)) {
            memcpy(&len, h + 16, 8);
            if ((skip = malloc(len)) != NULL && read_n(fd, skip, (size_t)len)) { /* the SUBMIT */
                type = 5; /* RESULT for that id, cut short */
                memcpy(h + 6, &type, 2);
                if (write(fd, h, 10) != 10)
                    __atomic_store_n(&f->done, -1, __ATOMIC_RELEASE);
            }
            free(skip);
        }
    }
    while (!__atomic_load_n(&f->done, __ATOMIC_ACQUIRE)) /* atomic: the test thread sets it (TSan) */
        lu_sleep_ms(10);
    close(fd);
    return NULL;
}

/* Stalled in the middle of a RESULT: the deadline still holds. */
static void stall_inside_a_result_times_out(void)
{
    char path[300], addr[320];
    struct sockaddr_un sa;
    float *b = ts_scene(0, 300, 9);
    stalling_service f;
    pthread_t t;
    locd_engine *e = NULL;
    locd_pairs *p = NULL;
    double t0, took;
    snprintf(path, sizeof path, "%s/stall.sock", g_fx.dir);
    snprintf(addr, sizeof addr, "unix:%s", path);
    memset(&sa, 0, sizeof sa);
    sa.sun_family = AF_UNIX;
    snprintf(sa.sun_path, sizeof sa.sun_path, "%.100s", path);
    memset(&f, 0, sizeof f);
    f.lfd = socket(AF_UNIX, SOCK_STREAM, 0);
    unlink(path);
    TEST_ASSERT_EQUAL_INT(0, bind(f.lfd, (struct sockaddr *)&sa, sizeof sa));
    TEST_ASSERT_EQUAL_INT(0, listen(f.lfd, 4));
    TEST_ASSERT_EQUAL_INT(0, pthread_create(&t, NULL, stalling_main, &f));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(addr, NULL, 800, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    t0 = lu_now_ms();
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_TIMEOUT, locd_engine_find_pairs_f32(e, b, 300, 0, p));
    took = lu_now_ms() - t0;
    LT_PRINT("# a RESULT cut short by a stalled service: LOCD_ERR_TIMEOUT after %.0f ms\n", took);
    TEST_ASSERT_TRUE_MESSAGE(took < 2000, "a stall inside a RESULT outlived the deadline");
    __atomic_store_n(&f.done, 1, __ATOMIC_RELEASE);
    pthread_join(t, NULL);
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    close(f.lfd);
    unlink(path);
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

/* ---- item 9: secrets ---- */

typedef struct guess {
    const char *addr;
    locd_status st;
} guess;

static void *guess_main(void *arg)
{
    guess *g = arg;
    locd_engine *e = NULL;
    g->st = make_engine(g->addr, "wrong-secret-guess-0000000000", 0, &e);
    locd_engine_destroy(e);
    return NULL;
}

/* A wrong secret is answered after a second, and a flood of guesses gets
 * at most LC_AUTH_MAX_FAILS (10) of them checked per second: the others
 * are refused unchecked with LOCD_ERR_BUSY. The right secret works again
 * once the flood stops. */
static void wrong_secrets_are_slow_and_capped(void)
{
    enum { GUESSES = 40 };
    char dir[256], log[300], actual[300];
    static guess g[GUESSES];
    pthread_t th[GUESSES];
    locd_engine *e = NULL;
    int k, auth = 0, busy = 0;
    double t0, took;
    pid_t svc;
    lu_temp_dir(dir, sizeof dir);
    snprintf(log, sizeof log, "%s/serve.log", dir);
    svc = lu_start_service("tcp:127.0.0.1:0", DOORS_SECRET, 1, log, actual, sizeof actual);
    TEST_ASSERT_TRUE(svc > 0);
    t0 = lu_now_ms();
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_AUTH, make_engine(actual, "not-the-secret-at-all-000000", 0, &e));
    took = lu_now_ms() - t0;
    LT_PRINT("# one wrong secret answered after %.0f ms\n", took);
    TEST_ASSERT_TRUE_MESSAGE(took >= 900, "a wrong secret was answered at once");

    t0 = lu_now_ms();
    for (k = 0; k < GUESSES; k++) {
        g[k].addr = actual;
        TEST_ASSERT_EQUAL_INT(0, pthread_create(&th[k], NULL, guess_main, &g[k]));
    }
    for (k = 0; k < GUESSES; k++) {
        pthread_join(th[k], NULL);
        auth += g[k].st == LOCD_ERR_AUTH;
        busy += g[k].st == LOCD_ERR_BUSY;
    }
    took = lu_now_ms() - t0;
    LT_PRINT("# %d parallel guesses in %.0f ms: %d checked (LOCD_ERR_AUTH), %d refused unchecked (LOCD_ERR_BUSY)\n",
             GUESSES, took, auth, busy);
    TEST_ASSERT_EQUAL_INT(GUESSES, auth + busy);
    TEST_ASSERT_TRUE_MESSAGE(auth <= 10 * (1 + (int)(took / 1000.0)), "more than 10 guesses a second were checked");
    TEST_ASSERT_TRUE(busy > 0);
    TEST_ASSERT_TRUE(lu_wait_file_contains(log, "wrong secrets within a second", 2000));

    lu_sleep_ms(1100); /* the next second: checks again */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(actual, DOORS_SECRET, 0, &e));
    locd_engine_destroy(e);
    lu_stop_service(svc, SIGTERM);
    lu_cleanup_dir(dir);
}

typedef struct log_capture {
    char text[2048];
} log_capture;

static void capture(int32_t severity, const char *message, void *user)
{
    log_capture *c = user;
    size_t used = strlen(c->text);
    if (severity <= LOCD_LOG_WARNING)
        snprintf(c->text + used, sizeof c->text - used, "%s\n", message);
}

/* A short secret and a bind to every interface are logged as warnings by
 * the library itself (locd serve refuses the short secret outright). */
static void short_secret_and_wildcard_bind_are_warned_about(void)
{
    static log_capture cap;
    locd_service_config sc;
    locd_service *svc = NULL;
    locd_service_config_init(&sc);
    sc.listen = "tcp:0.0.0.0:0";
    sc.secret = "short";
    sc.threads = 1;
    sc.log = capture;
    sc.log_user = &cap;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_service_create(&sc, &svc));
    LT_PRINT("# warnings: %s", cap.text);
    TEST_ASSERT_NOT_NULL(strstr(cap.text, "5 bytes; use at least 16"));
    TEST_ASSERT_NOT_NULL(strstr(cap.text, "every network interface"));
    locd_service_destroy(svc);
    memset(&cap, 0, sizeof cap);
    sc.listen = "tcp:127.0.0.1:0";
    sc.secret = DOORS_SECRET;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_service_create(&sc, &svc));
    TEST_ASSERT_EQUAL_STRING("", cap.text);
    locd_service_destroy(svc);
}

/* ---- item 10: no shared /dev/shm ---- */

/* Gives this process its own mount namespace with a fresh tmpfs of
 * `size` on /dev/shm (mounts made private first, so nothing leaks to the
 * host). 0, or -1 when not allowed (not root, no namespaces). */
static int private_dev_shm(const char *size)
{
    char opts[64];
    if (unshare(CLONE_NEWNS) != 0 || mount(NULL, "/", NULL, MS_REC | MS_PRIVATE, NULL) != 0)
        return -1;
    snprintf(opts, sizeof opts, "size=%s,mode=1777", size);
    return mount("tmpfs", "/dev/shm", "tmpfs", MS_NOSUID | MS_NODEV, opts) == 0 ? 0 : -1;
}

/* 1 when this machine lets a child give itself a private /dev/shm. */
static int can_private_shm(void)
{
    int status = 0;
    pid_t pid = fork();
    if (pid == 0)
        _exit(private_dev_shm("1m") == 0 ? 0 : 1);
    if (pid < 0 || waitpid(pid, &status, 0) != pid)
        return 0;
    return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

/* `locd serve --listen addr` in its own mount namespace with a private
 * /dev/shm: the container that shares only the socket. Its stderr goes to
 * log; returns its pid once it listens, or -1. */
static pid_t start_service_private_shm(const char *addr, const char *log)
{
    const char *cli = lu_setup();
    pid_t pid = fork();
    if (pid == 0) {
        int fd = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0600);
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        if (fd >= 0) {
            dup2(fd, 2);
            close(fd);
        }
        if (private_dev_shm("64m") != 0)
            _exit(126);
        execl(cli, cli, "serve", "--listen", addr, "--threads", "1", (char *)NULL);
        _exit(127);
    }
    if (pid < 0 || !lu_wait_file_contains(log, "listening on", 10000)) {
        if (pid > 0)
            lu_stop_service(pid, SIGKILL);
        return -1;
    }
    return pid;
}

/* Every size of job, below and above the shared-memory threshold, f32 and
 * f64, synchronous and asynchronous: all exact through a service that
 * cannot see this process's segments. */
static void private_shm_service_gets_every_job(void)
{
    char dir[256], log[300], addr[300];
    size_t sizes[] = {100, 3000, 20000}; /* 2.4 KB, 72 KB, 480 KB of float32 */
    locd_engine *e = NULL;
    locd_pairs *p = NULL, *q = NULL;
    locd_job *j = NULL;
    pid_t svc;
    size_t k;
    if (!can_private_shm())
        TEST_IGNORE_MESSAGE("no mount namespaces here (needs root): private /dev/shm not testable");
    lu_temp_dir(dir, sizeof dir);
    snprintf(log, sizeof log, "%s/serve.log", dir);
    snprintf(addr, sizeof addr, "unix:%s/s.sock", dir);
    svc = start_service_private_shm(addr, log);
    TEST_ASSERT_TRUE(svc > 0);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(addr, NULL, 0, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &q));
    for (k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        size_t n = sizes[k], i;
        float *b = ts_scene((int)k, n, 40 + k);
        double *d = malloc(n * 6 * sizeof *d);
        for (i = 0; i < n * 6; i++)
            d[i] = b[i];
        TEST_ASSERT_EQUAL_INT_MESSAGE(LOCD_OK, locd_engine_find_pairs_f32(e, b, n, 0, p), locd_last_error());
        TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, n, p));
        TEST_ASSERT_EQUAL_INT_MESSAGE(LOCD_OK, locd_engine_find_pairs_f64(e, d, n, 0, q), locd_last_error());
        TEST_ASSERT_TRUE(lu_same_pairs(p, q));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, b, n, 0, &j));
        TEST_ASSERT_EQUAL_INT_MESSAGE(LOCD_OK, locd_job_wait(j, -1), locd_last_error());
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_job_take(j, q));
        TEST_ASSERT_TRUE(lu_same_pairs(p, q));
        locd_job_release(j);
        free(d);
        free(b);
    }
    locd_pairs_destroy(p);
    locd_pairs_destroy(q);
    locd_engine_destroy(e);
    lu_stop_service(svc, SIGTERM);
    TEST_ASSERT_EQUAL_INT(0, lu_count_shm("/locd-")); /* no probe or job segment left here */
    lu_cleanup_dir(dir);
}

/* The client's /dev/shm is full (a 64 KiB tmpfs): a 480 KB job cannot get
 * a segment and is streamed instead of failing. Runs in a child, which
 * owns the namespace; the service is the suite's. */
static void full_shm_client_streams(void)
{
    int status = 0;
    pid_t pid;
    if (!can_private_shm())
        TEST_IGNORE_MESSAGE("no mount namespaces here (needs root): full /dev/shm not testable");
    pid = fork();
    if (pid == 0) {
        size_t n = 20000;
        float *b = ts_scene(0, n, 77);
        locd_engine *e = NULL;
        locd_pairs *p = NULL;
        int rc;
        if (private_dev_shm("64k") != 0)
            _exit(3);
        if (make_engine(g_fx.addr, NULL, 0, &e) != LOCD_OK || locd_pairs_create(NULL, &p) != LOCD_OK)
            _exit(4);
        rc = locd_engine_find_pairs_f32(e, b, n, 0, p);
        if (rc != LOCD_OK) {
            fprintf(stderr, "# find with a full /dev/shm: %d %s\n", rc, locd_last_error());
            _exit(5);
        }
        _exit(ts_same_as_brute_f32(b, n, p) ? 0 : 6);
    }
    TEST_ASSERT_TRUE(pid > 0);
    TEST_ASSERT_EQUAL_INT(pid, waitpid(pid, &status, 0));
    TEST_ASSERT_TRUE(WIFEXITED(status));
    TEST_ASSERT_EQUAL_INT_MESSAGE(0, WEXITSTATUS(status), "the job failed with a full /dev/shm (5) or was wrong (6)");
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
        LT_TEST_FIXTURE(stall_inside_a_result_times_out, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(no_deadline_and_default, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(wrong_secrets_are_slow_and_capped, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(short_secret_and_wildcard_bind_are_warned_about, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(private_shm_service_gets_every_job, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(full_shm_client_streams, lu_timer_start, lu_timer_print),
    };
    return LT_RUN_GROUP(tests, setup, teardown);
}
