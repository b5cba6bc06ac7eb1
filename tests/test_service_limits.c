/* The service under a hostile client (issue 18, the server's side): each
 * test runs one attack against a real `locd serve` process, with small
 * limits and deadlines given on its command line, and then checks that
 * the service is still up, still exact for another client, and that
 * nothing is left in /dev/shm.
 *   - a client shrinks its shared-memory segment after submitting it (SIGBUS)
 *   - slow-loris clients that never finish authenticating, or a message
 *     (UNIX and TCP)
 *   - a client that reads its result a byte at a time
 *   - jobs over the per-job and per-client limits; cancel, disconnect and
 *     SIGTERM reaching a running job
 *   - more jobs in flight on one connection than the service allows
 *   - the service out of file descriptors; a forged segment name for the log */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>
#include <netdb.h>

#include "runner.h"

#include "levels_util.h"
#include "support.h"

static char g_dir[256];

/* ---- a service with its own flags ---- */

typedef struct svc {
    pid_t pid;
    char addr[300], log[300];
} svc;

/* Starts `locd serve --listen LISTEN --threads 1 [flags...]` (NULL-ended),
 * with at most nofile descriptors when nofile > 0. 1 when it listens. */
static int serve(svc *v, const char *listen, int nofile, ...)
{
    const char *argv[40];
    const char *cli = lu_setup();
    va_list ap;
    int a = 0;
    double until;
    static int count;
    argv[a++] = cli;
    argv[a++] = "serve";
    argv[a++] = "--listen";
    argv[a++] = listen;
    argv[a++] = "--threads";
    argv[a++] = "1";
    va_start(ap, nofile);
    while (a < 38 && (argv[a] = va_arg(ap, const char *)) != NULL)
        a++;
    va_end(ap);
    argv[a] = NULL;
    snprintf(v->log, sizeof v->log, "%s/serve-%d.log", g_dir, ++count);
    v->addr[0] = '\0';
    v->pid = fork();
    if (v->pid == 0) {
        int fd = open(v->log, O_WRONLY | O_CREAT | O_TRUNC, 0600), nul = open("/dev/null", O_RDWR);
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        dup2(fd, 2);
        dup2(nul, 0);
        dup2(nul, 1);
        close(fd);
        close(nul);
        if (nofile > 0) {
            struct rlimit rl;
            rl.rlim_cur = rl.rlim_max = (rlim_t)nofile;
            setrlimit(RLIMIT_NOFILE, &rl);
        }
        execv(cli, (char *const *)argv);
        _exit(127);
    }
    until = lu_now_ms() + 10000;
    while (lu_now_ms() < until) {
        FILE *f = fopen(v->log, "r");
        char line[512];
        if (f) {
            while (fgets(line, sizeof line, f)) {
                char *p = strstr(line, "listening on ");
                if (p) {
                    p += strlen("listening on ");
                    p[strcspn(p, " \n")] = '\0';
                    snprintf(v->addr, sizeof v->addr, "%s", p);
                    fclose(f);
                    return 1;
                }
            }
            fclose(f);
        }
        if (waitpid(v->pid, NULL, WNOHANG) == v->pid) {
            v->pid = -1;
            return 0;
        }
        lu_sleep_ms(20);
    }
    return 0;
}

/* 1 while the service process runs (it was not killed by a signal). */
static int alive(const svc *v)
{
    int status;
    return v->pid > 0 && waitpid(v->pid, &status, WNOHANG) == 0;
}

/* SIGTERM; then the service's log must hold no sanitizer report (a
 * sanitizer build of `locd serve` reports there, not in this process). */
static void stop(svc *v)
{
    if (v->pid > 0)
        lu_stop_service(v->pid, SIGTERM);
    v->pid = -1;
    TEST_ASSERT_FALSE_MESSAGE(lu_file_contains(v->log, "Sanitizer"), "the service's log has a sanitizer report");
}

static void unix_listen(char *out, size_t len, const char *name)
{
    snprintf(out, len, "unix:%s/%s.sock", g_dir, name);
}

static locd_status make_engine(const char *addr, const char *secret, locd_engine **e)
{
    locd_engine_config cfg;
    locd_engine_config_init(&cfg);
    cfg.level = LOCD_LEVEL_SERVICE;
    cfg.service_address = addr;
    cfg.service_secret = secret;
    return locd_engine_create(&cfg, e);
}

/* One small scene (and one through shared memory) through the service,
 * checked against brute force. */
static int exact_for_another_client(const char *addr, const char *secret)
{
    locd_engine *e = NULL;
    locd_pairs *p = NULL;
    float *b = ts_scene(1, 700, 31), *big = ts_scene(0, 4000, 32); /* 96 KB: a segment on unix */
    int ok = make_engine(addr, secret, &e) == LOCD_OK && locd_pairs_create(NULL, &p) == LOCD_OK &&
             locd_engine_find_pairs_f32(e, b, 700, 0, p) == LOCD_OK && ts_same_as_brute_f32(b, 700, p) &&
             locd_engine_find_pairs_f32(e, big, 4000, 0, p) == LOCD_OK && ts_same_as_brute_f32(big, 4000, p);
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    free(b);
    free(big);
    return ok;
}

/* The service is up, exact for a new client, and no segment is left. */
static void still_serving(const svc *v, const char *secret)
{
    char prefix[64];
    TEST_ASSERT_TRUE_MESSAGE(alive(v), "the service died");
    TEST_ASSERT_TRUE_MESSAGE(exact_for_another_client(v->addr, secret), "another client is not served exactly");
    snprintf(prefix, sizeof prefix, "locd-c%ld-", (long)getpid());
    TEST_ASSERT_EQUAL_INT(0, lu_count_shm(prefix));
    snprintf(prefix, sizeof prefix, "locd-t%ld-", (long)getpid());
    TEST_ASSERT_EQUAL_INT(0, lu_count_shm(prefix));
}

/* ---- raw protocol ---- */

static int raw_connect(const char *addr)
{
    int fd = -1;
    if (!strncmp(addr, "unix:", 5)) {
        struct sockaddr_un sa;
        fd = socket(AF_UNIX, SOCK_STREAM, 0);
        memset(&sa, 0, sizeof sa);
        sa.sun_family = AF_UNIX;
        snprintf(sa.sun_path, sizeof sa.sun_path, "%.100s", addr + 5);
        if (connect(fd, (struct sockaddr *)&sa, sizeof sa) != 0) {
            close(fd);
            return -1;
        }
    } else {
        char host[64], *port;
        struct addrinfo hints, *res;
        snprintf(host, sizeof host, "%s", addr + 4);
        port = strrchr(host, ':');
        *port++ = '\0';
        memset(&hints, 0, sizeof hints);
        hints.ai_socktype = SOCK_STREAM;
        if (getaddrinfo(host, port, &hints, &res) != 0)
            return -1;
        fd = socket(res->ai_family, SOCK_STREAM, 0);
        if (connect(fd, res->ai_addr, res->ai_addrlen) != 0) {
            close(fd);
            fd = -1;
        }
        freeaddrinfo(res);
    }
    return fd;
}

static void put_header(uint8_t *h, uint16_t type, uint64_t id, uint64_t len)
{
    uint32_t magic = 0x5344434cu;
    uint16_t ver = 1;
    memcpy(h, &magic, 4);
    memcpy(h + 4, &ver, 2);
    memcpy(h + 6, &type, 2);
    memcpy(h + 8, &id, 8);
    memcpy(h + 16, &len, 8);
}

static int read_n(int fd, void *buf, size_t len, int timeout_ms)
{
    size_t got = 0;
    double until = lu_now_ms() + timeout_ms;
    while (got < len) {
        struct pollfd p;
        ssize_t r;
        p.fd = fd;
        p.events = POLLIN;
        if (lu_now_ms() > until || poll(&p, 1, 100) < 0)
            return 0;
        if (!(p.revents & (POLLIN | POLLHUP | POLLERR)))
            continue;
        r = recv(fd, (char *)buf + got, len - got, 0);
        if (r <= 0)
            return 0;
        got += (size_t)r;
    }
    return 1;
}

/* HELLO with the secret (may be NULL), then the WELCOME. */
static void hello(int fd, const char *secret)
{
    uint8_t h[24 + 4 + 64], w[28];
    uint32_t sl = secret ? (uint32_t)strlen(secret) : 0;
    put_header(h, 1, 0, 4 + sl);
    memcpy(h + 24, &sl, 4);
    if (sl)
        memcpy(h + 28, secret, sl);
    TEST_ASSERT_EQUAL_INT64((ssize_t)(28 + sl), send(fd, h, 28 + sl, MSG_NOSIGNAL));
    TEST_ASSERT_TRUE(read_n(fd, w, sizeof w, 5000));
}

/* A SUBMIT of n float boxes whose payload is a segment name. */
static int send_shm_submit(int fd, uint64_t id, uint64_t n, const char *name)
{
    uint8_t m[24 + 36 + 4 + 128];
    uint32_t nl = (uint32_t)strlen(name);
    memset(m, 0, sizeof m);
    put_header(m, 3, id, 36 + 4 + nl);
    memcpy(m + 24 + 8, &n, 8);
    m[24 + 28] = 1; /* transport: shared memory */
    memcpy(m + 24 + 36, &nl, 4);
    memcpy(m + 24 + 40, name, nl);
    return send(fd, m, 24 + 40 + nl, MSG_NOSIGNAL) == (ssize_t)(24 + 40 + nl);
}

/* Reads one RESULT: its status, or 1 when the connection closed first. */
static int32_t read_result_status(int fd, int timeout_ms)
{
    uint8_t h[24], *pl;
    uint64_t len;
    int32_t st;
    if (!read_n(fd, h, 24, timeout_ms))
        return 1;
    memcpy(&len, h + 16, 8);
    if (len < 4 || len > ((uint64_t)1 << 30) || !(pl = malloc((size_t)len)))
        return 1;
    if (!read_n(fd, pl, (size_t)len, timeout_ms)) {
        free(pl);
        return 1;
    }
    memcpy(&st, pl, 4);
    free(pl);
    return st;
}

/* 1 when the peer closes fd within timeout_ms (what it sends is dropped). */
static int closed_by_peer(int fd, int timeout_ms)
{
    char buf[4096];
    double until = lu_now_ms() + timeout_ms;
    while (lu_now_ms() < until) {
        struct pollfd p;
        p.fd = fd;
        p.events = POLLIN;
        if (poll(&p, 1, 50) <= 0)
            continue;
        if (recv(fd, buf, sizeof buf, 0) <= 0)
            return 1;
    }
    return 0;
}

/* ---- scenes ---- */

/* n identical unit boxes: n (n - 1) / 2 pairs. */
static float *same_boxes(size_t n)
{
    float *b = malloc(n * 6 * sizeof *b);
    size_t i;
    for (i = 0; i < n; i++) {
        b[6 * i + 0] = b[6 * i + 1] = b[6 * i + 2] = 0;
        b[6 * i + 3] = b[6 * i + 4] = b[6 * i + 5] = 1;
    }
    return b;
}

/* n random boxes of side s in the unit cube. */
static float *cube_boxes(size_t n, float s)
{
    float *b = malloc(n * 6 * sizeof *b);
    ts_rng r;
    size_t i;
    int a;
    ts_seed(&r, 77);
    for (i = 0; i < n; i++)
        for (a = 0; a < 3; a++) {
            b[6 * i + a] = (float)ts_uniform(&r);
            b[6 * i + 3 + a] = b[6 * i + a] + s;
        }
    return b;
}

/* A job that keeps one runner busy for seconds with a small result: n
 * thin sticks (0.3 long on a random axis, 0.002 thick) in the unit cube,
 * billions of candidates and about n * 9 pairs. */
static float *busy_boxes(size_t n)
{
    float *b = cube_boxes(n, 0.002f);
    ts_rng r;
    size_t i;
    ts_seed(&r, 78);
    for (i = 0; i < n; i++)
        b[6 * i + 3 + (int)(ts_next(&r) % 3)] += 0.3f;
    return b;
}

/* (under TSan a tenth still runs for seconds) */
#define BUSY_N ((size_t)(lu_heavy() ? 100000 : ts_under_tsan() ? 10000 : 40000))

/* ---- item 1: a segment shrunk under the service ---- */

static void shrunk_segment_does_not_kill_the_service(void)
{
    char listen[320], name[64], path[128];
    svc v;
    locd_engine *e = NULL;
    locd_job *blocker = NULL;
    float *busy = busy_boxes(BUSY_N), *b = ts_scene(0, 5000, 3);
    size_t bytes = 5000 * 24;
    double until;
    int fd, sfd;
    void *map;
    unix_listen(listen, sizeof listen, "shm");
    TEST_ASSERT_TRUE(serve(&v, listen, 0, NULL));
    /* The one runner is busy: the attacker's job waits in the queue. */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(v.addr, NULL, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, busy, BUSY_N, 0, &blocker));
    snprintf(name, sizeof name, "/locd-t%ld-1", (long)getpid());
    snprintf(path, sizeof path, "/dev/shm%s", name);
    sfd = shm_open(name, O_RDWR | O_CREAT | O_EXCL, 0600);
    TEST_ASSERT_TRUE(sfd >= 0);
    TEST_ASSERT_EQUAL_INT(0, ftruncate(sfd, (off_t)bytes));
    map = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, sfd, 0);
    memcpy(map, b, bytes);
    munmap(map, bytes);
    fd = raw_connect(v.addr);
    hello(fd, NULL);
    TEST_ASSERT_TRUE(send_shm_submit(fd, 7, 5000, name));
    /* The service opened the segment once its name is gone; then shrink it. */
    until = lu_now_ms() + 5000;
    while (access(path, F_OK) == 0 && lu_now_ms() < until)
        lu_sleep_ms(1);
    TEST_ASSERT_EQUAL_INT(0, ftruncate(sfd, 0));
    close(sfd);
    /* The job ends one way or the other, and the service lives. */
    {
        int32_t st = read_result_status(fd, 60000);
        LT_PRINT("shrunk segment: job status %d\n", (int)st);
        TEST_ASSERT_TRUE_MESSAGE(st == LOCD_OK || st == LOCD_ERR_IO, "the job had no result (the service died?)");
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_job_wait(blocker, 60000));
    locd_job_release(blocker);
    locd_engine_destroy(e);
    close(fd);
    shm_unlink(name);
    still_serving(&v, NULL);
    stop(&v);
    free(busy);
    free(b);
}

/* ---- item 5: total deadlines for authentication and for each message ---- */

/* Sends one byte of a HELLO on each fd every 150 ms for ms milliseconds
 * (each connection sends its 24-byte header a byte at a time, then starts
 * again); counts the fds the service closed. */
static int drip(int *fds, int n, int ms)
{
    uint8_t h[24];
    int sent[64] = {0}, closed = 0, i;
    double until = lu_now_ms() + ms;
    put_header(h, 1, 0, 4);
    while (lu_now_ms() < until) {
        for (i = 0; i < n; i++)
            if (fds[i] >= 0) {
                if (send(fds[i], h + sent[i] % 24, 1, MSG_NOSIGNAL) != 1) {
                    close(fds[i]);
                    fds[i] = -1;
                    closed++;
                } else {
                    sent[i]++;
                }
            }
        lu_sleep_ms(150);
    }
    return closed;
}

static void slow_loris(const char *listen, const char *secret)
{
    char flags_secret[80];
    svc v;
    int fds[12], i, closed;
    double t0;
    locd_engine *e = NULL;
    (void)flags_secret;
    TEST_ASSERT_TRUE(secret ? serve(&v, listen, 0, "--secret", secret, "--max-clients", "8", "--auth-timeout", "500",
                                    "--message-timeout", "700", NULL)
                            : serve(&v, listen, 0, "--max-clients", "8", "--auth-timeout", "500", "--message-timeout",
                                    "700", NULL));
    for (i = 0; i < 12; i++)
        fds[i] = raw_connect(v.addr);
    /* A byte every 150 ms: a per-read timeout never fires. */
    closed = drip(fds, 12, 300);
    /* Everyone else still gets in, at once. */
    t0 = lu_now_ms();
    TEST_ASSERT_EQUAL_INT_MESSAGE(LOCD_OK, make_engine(v.addr, secret, &e), "a client was locked out");
    LT_PRINT("slow loris: a client connected in %.0f ms\n", lu_now_ms() - t0);
    locd_engine_destroy(e);
    closed += drip(fds, 12, 1500);
    LT_PRINT("slow loris: %d of 12 dropped\n", closed);
    TEST_ASSERT_EQUAL_INT_MESSAGE(12, closed, "a connection that never authenticated was kept");
    /* An authenticated client that starts a message and trickles it. */
    {
        int fd = raw_connect(v.addr);
        uint8_t h[24];
        hello(fd, secret);
        put_header(h, 3, 1, 36 + 24 * 100);
        TEST_ASSERT_EQUAL_INT(24, send(fd, h, 24, MSG_NOSIGNAL));
        fds[0] = fd;
        closed = drip(fds, 1, 1500);
        TEST_ASSERT_EQUAL_INT_MESSAGE(1, closed, "a message that trickled in was not cut off");
    }
    TEST_ASSERT_TRUE(lu_file_contains(v.log, "no HELLO within 500 ms"));
    TEST_ASSERT_TRUE(lu_file_contains(v.log, "deadline passed"));
    still_serving(&v, secret);
    stop(&v);
}

static void slow_loris_unix(void)
{
    char listen[320];
    unix_listen(listen, sizeof listen, "loris");
    slow_loris(listen, NULL);
}

static void slow_loris_tcp(void)
{
    slow_loris("tcp:127.0.0.1:0", "a-test-secret-of-some-length");
}

/* ---- item 6: a slow reader does not hold a runner ---- */

typedef struct reader_ctx {
    int fd;
    int stop;   /* atomic */
    int closed; /* read after the join */
} reader_ctx;

/* Reads one byte every 50 ms until told to stop or the service closes. */
static void *slow_reader(void *arg)
{
    reader_ctx *r = arg;
    char c;
    while (!__atomic_load_n(&r->stop, __ATOMIC_ACQUIRE)) {
        struct pollfd p;
        p.fd = r->fd;
        p.events = POLLIN;
        if (poll(&p, 1, 50) > 0 && recv(r->fd, &c, 1, 0) <= 0) {
            r->closed = 1;
            break;
        }
        lu_sleep_ms(50);
    }
    return NULL;
}

static void slow_reader_does_not_hold_a_runner(void)
{
    char listen[320];
    svc v;
    reader_ctx rc;
    pthread_t th;
    locd_engine *e = NULL;
    locd_pairs *p = NULL;
    uint64_t n = lu_heavy() ? 3000 : 1500;
    float *same = same_boxes((size_t)n), *b = ts_scene(0, 2000, 5);
    uint8_t m[24 + 36];
    double t0, took;
    unix_listen(listen, sizeof listen, "slow");
    TEST_ASSERT_TRUE(serve(&v, listen, 0, "--send-timeout", "500", NULL));
    /* 3,000 identical boxes: a 36 MB result the reader takes a byte at a time
       (1,500 and 9 MB under the sanitizers: still far more than the socket holds). */
    rc.fd = raw_connect(v.addr);
    rc.stop = 0;
    rc.closed = 0;
    hello(rc.fd, NULL);
    memset(m, 0, sizeof m);
    put_header(m, 3, 1, 36 + n * 24);
    memcpy(m + 24 + 8, &n, 8);
    TEST_ASSERT_EQUAL_INT(24 + 36, send(rc.fd, m, 24 + 36, MSG_NOSIGNAL));
    TEST_ASSERT_EQUAL_INT((int)(n * 24), send(rc.fd, same, (size_t)n * 24, MSG_NOSIGNAL));
    TEST_ASSERT_EQUAL_INT(0, pthread_create(&th, NULL, slow_reader, &rc));
    lu_sleep_ms(200);
    /* A normal job of another client on the service's one runner. */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(v.addr, NULL, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    t0 = lu_now_ms();
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e, b, 2000, 0, p));
    took = lu_now_ms() - t0;
    TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, 2000, p));
    LT_PRINT("slow reader: the other client's job took %.0f ms\n", took);
    /* Without the send deadline it waited for the slow reader: 62 s. */
    TEST_ASSERT_TRUE_MESSAGE(took < 10000, "the slow reader held the runner");
    __atomic_store_n(&rc.stop, 1, __ATOMIC_RELEASE);
    pthread_join(th, NULL);
    TEST_ASSERT_TRUE(rc.closed || closed_by_peer(rc.fd, 2000));
    close(rc.fd);
    TEST_ASSERT_TRUE(lu_file_contains(v.log, "did not read a message"));
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    still_serving(&v, NULL);
    stop(&v);
    free(same);
    free(b);
}

/* ---- item 7: limits per job and per client ---- */

static void job_status(locd_engine *e, const float *b, size_t n, locd_status want, const char *says)
{
    locd_pairs *p = NULL;
    locd_status st;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    st = locd_engine_find_pairs_f32(e, b, n, 0, p);
    LT_PRINT("  %zu boxes: %d (%s)\n", n, st, st ? locd_last_error() : "ok");
    TEST_ASSERT_EQUAL_INT(want, st);
    if (says)
        TEST_ASSERT_NOT_NULL_MESSAGE(strstr(locd_last_error(), says), locd_last_error());
    if (st == LOCD_OK)
        TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, n, p));
    locd_pairs_destroy(p);
}

static void limits_fail_only_that_job(void)
{
    char listen[320];
    svc v;
    locd_engine *e = NULL;
    float *pairs = cube_boxes(20000, 0.057f), *many = cube_boxes(450000, 1e-7f), *b = ts_scene(0, 3000, 8);
    unix_listen(listen, sizeof listen, "limits");
    TEST_ASSERT_TRUE(serve(&v, listen, 0, "--max-job-pairs", "100000", "--max-job-boxes", "500000",
                           "--max-job-mb", "24", NULL));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(v.addr, NULL, &e));
    job_status(e, b, 3000, LOCD_OK, NULL);
    job_status(e, pairs, 20000, LOCD_ERR_LIMIT, "pairs"); /* ~300,000 pairs */
    job_status(e, b, 3000, LOCD_OK, NULL);              /* the same connection goes on */
    job_status(e, many, 450000, LOCD_ERR_LIMIT, "memory");
    job_status(e, b, 3000, LOCD_OK, NULL);
    {
        float *more = cube_boxes(500001, 1e-7f);
        job_status(e, more, 500001, LOCD_ERR_LIMIT, "boxes");
        free(more);
    }
    job_status(e, b, 3000, LOCD_OK, NULL);
    locd_engine_destroy(e);
    still_serving(&v, NULL);
    stop(&v);
    free(pairs);
    free(many);
    free(b);
}

static void client_limits_and_job_time(void)
{
    char listen[320];
    svc v;
    locd_engine *e = NULL;
    locd_job *j[3];
    size_t nb = lu_heavy() ? 100000 : ts_under_tsan() ? 15000 : 60000; /* runs for longer than 200 ms everywhere */
    float *busy = busy_boxes(nb), *b = ts_scene(0, 2000, 8);
    char boxes[32];
    int i;
    /* The client may hold the busy job and one more of 2,000 in flight. */
    snprintf(boxes, sizeof boxes, "%zu", nb + 2000 + 10);
    unix_listen(listen, sizeof listen, "client");
    TEST_ASSERT_TRUE(serve(&v, listen, 0, "--max-client-boxes", boxes, "--max-job-ms", "200", NULL));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(v.addr, NULL, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, busy, nb, 0, &j[0]));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, b, 2000, 0, &j[1]));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, b, 2000, 0, &j[2]));
    for (i = 0; i < 3; i++)
        LT_PRINT("  job %d: %d\n", i, locd_job_wait(j[i], 60000));
    /* The busy job runs past 200 ms; the third is over the client's boxes. */
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_LIMIT, locd_job_wait(j[0], 0));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_job_wait(j[1], 0));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_LIMIT, locd_job_wait(j[2], 0));
    for (i = 0; i < 3; i++)
        locd_job_release(j[i]);
    locd_engine_destroy(e);
    still_serving(&v, NULL);
    stop(&v);
    free(busy);
    free(b);
}

/* Resident memory of a process, in KiB. */
static long rss_kib(pid_t pid)
{
    char path[64], line[256];
    long kib = -1;
    FILE *f;
    snprintf(path, sizeof path, "/proc/%ld/status", (long)pid);
    if (!(f = fopen(path, "r")))
        return -1;
    while (fgets(line, sizeof line, f))
        if (sscanf(line, "VmRSS: %ld", &kib) == 1)
            break;
    fclose(f);
    return kib;
}

static void huge_result_is_not_kept(void)
{
    char listen[320];
    svc v;
    locd_engine *e = NULL;
    locd_pairs *p = NULL;
    size_t n = 5000;
    float *same;
    long before, after;
    if (!lu_heavy()) /* the sanitizers' allocators keep freed memory (quarantine): RSS says nothing */
        TEST_IGNORE_MESSAGE("resident memory is not meaningful under the sanitizers");
    same = same_boxes(n);
    unix_listen(listen, sizeof listen, "rss");
    TEST_ASSERT_TRUE(serve(&v, listen, 0, NULL));
    TEST_ASSERT_TRUE(exact_for_another_client(v.addr, NULL));
    before = rss_kib(v.pid);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(v.addr, NULL, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e, same, n, 0, p));
    TEST_ASSERT_EQUAL_UINT64((uint64_t)n * (n - 1) / 2, locd_pairs_count(p));
    lu_sleep_ms(300);
    after = rss_kib(v.pid);
    LT_PRINT("service memory: %ld KiB before, %ld KiB after a job of %zu pairs (%zu MiB)\n", before, after,
             locd_pairs_count(p), locd_pairs_count(p) * 8 >> 20);
    /* A runner keeps at most 64 MiB between jobs; this one had ~2.5x the pairs' size. */
    TEST_ASSERT_TRUE_MESSAGE(after - before < (64 + 16) * 1024, "the service kept a huge job's buffers");
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    still_serving(&v, NULL);
    stop(&v);
    free(same);
}

/* ---- item 7: cancel, disconnect and SIGTERM reach a running job ---- */

/* How long a small job of a second client takes while the first client's
 * busy job (full ms end to end when nobody stops it) runs on the service's
 * only runner and is stopped by `how` (0 cancel, 1 disconnect, 2 nothing:
 * the baseline) an eighth of the way in. */
static int eighth_of(double full)
{
    return full / 8 > 20 ? (int)(full / 8) : 20;
}

static double other_job_ms(const svc *v, int how, double full)
{
    locd_engine *e = NULL, *e2 = NULL;
    locd_job *j = NULL;
    locd_pairs *p = NULL;
    float *busy = busy_boxes(BUSY_N), *b = ts_scene(0, 2000, 5);
    double t0, took;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(v->addr, NULL, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(v->addr, NULL, &e2));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, busy, BUSY_N, 0, &j));
    lu_sleep_ms(eighth_of(full));
    if (how == 0) {
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_job_cancel(j));
    } else if (how == 1) {
        locd_engine_destroy(e);
        e = NULL;
    }
    t0 = lu_now_ms();
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e2, b, 2000, 0, p));
    took = lu_now_ms() - t0;
    TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, 2000, p));
    locd_job_wait(j, 60000);
    locd_job_release(j);
    locd_engine_destroy(e);
    locd_engine_destroy(e2);
    locd_pairs_destroy(p);
    free(busy);
    free(b);
    return took;
}

static void stopping_reaches_a_running_job(void)
{
    char listen[320];
    svc v;
    double full, held_ms, cancel_ms, gone_ms, t0;
    locd_engine *e = NULL;
    locd_job *j = NULL;
    locd_pairs *p = NULL;
    float *busy = busy_boxes(BUSY_N);
    unix_listen(listen, sizeof listen, "cancel");
    TEST_ASSERT_TRUE(serve(&v, listen, 0, NULL));
    /* How long the busy job runs when nobody stops it; its pairs, swept in
       blocks that ask the stop hook, are level 1's in level 1's order. */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(v.addr, NULL, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    t0 = lu_now_ms();
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e, busy, BUSY_N, 0, p));
    full = lu_now_ms() - t0;
    {
        locd_engine *e1 = NULL;
        locd_pairs *want = NULL;
        locd_engine_config cfg;
        locd_engine_config_init(&cfg);
        cfg.threads = 2;
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_create(&cfg, &e1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &want));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e1, busy, BUSY_N, 0, want));
        TEST_ASSERT_TRUE_MESSAGE(lu_same_pairs(want, p), "the service's pairs differ from level 1's");
        locd_pairs_destroy(want);
        locd_engine_destroy(e1);
    }
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    /* The baseline is the small job's wait behind the busy one left to
       run (comparing with `full` instead, which includes the client's own
       work, let a job that was never stopped pass). */
    held_ms = other_job_ms(&v, 2, full);
    cancel_ms = other_job_ms(&v, 0, full);
    gone_ms = other_job_ms(&v, 1, full);
    LT_PRINT("busy job %.0f ms; the other job took %.0f ms behind it, %.0f ms after a cancel, %.0f ms after a "
             "disconnect\n", full, held_ms, cancel_ms, gone_ms);
    TEST_ASSERT_TRUE_MESSAGE(held_ms >= 40, "the busy job is too short to tell whether it was stopped");
    TEST_ASSERT_TRUE_MESSAGE(cancel_ms < held_ms / 2, "locd_job_cancel did not stop the running job");
    TEST_ASSERT_TRUE_MESSAGE(gone_ms < held_ms / 2, "a client's disconnect did not stop its running job");
    still_serving(&v, NULL);
    /* SIGTERM with the busy job running: the service leaves at once. */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(v.addr, NULL, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, busy, BUSY_N, 0, &j));
    lu_sleep_ms(eighth_of(full));
    t0 = lu_now_ms();
    kill(v.pid, SIGTERM);
    waitpid(v.pid, NULL, 0);
    v.pid = -1;
    LT_PRINT("SIGTERM: the service left in %.0f ms\n", lu_now_ms() - t0);
    TEST_ASSERT_TRUE_MESSAGE(lu_now_ms() - t0 < full / 2, "SIGTERM waited for the running job");
    locd_job_wait(j, 10000);
    locd_job_release(j);
    locd_engine_destroy(e);
    free(busy);
}

/* ---- item 8: more jobs in flight than the service allows ---- */

static void in_flight_past_the_limit(void)
{
    char listen[320];
    svc v;
    locd_engine *e = NULL;
    locd_job *busy_job = NULL, **j;
    float *busy = busy_boxes(BUSY_N / 2), *b = ts_scene(0, 50, 5);
    int i, ok = 0, limit = 0, other = 0, n = 1100;
    unix_listen(listen, sizeof listen, "inflight");
    /* The default limit (1,024): the client library stays below it. */
    TEST_ASSERT_TRUE(serve(&v, listen, 0, NULL));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(v.addr, NULL, &e));
    j = calloc((size_t)n, sizeof *j);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, busy, BUSY_N / 2, 0, &busy_job));
    for (i = 0; i < n; i++)
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, b, 50, 0, &j[i]));
    for (i = 0; i < n; i++) {
        locd_status st = locd_job_wait(j[i], 60000);
        ok += st == LOCD_OK;
        if (st != LOCD_OK)
            LT_PRINT("  job %d: %d %s\n", i, st, locd_last_error());
        locd_job_release(j[i]);
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_job_wait(busy_job, 60000));
    locd_job_release(busy_job);
    TEST_ASSERT_EQUAL_INT_MESSAGE(n, ok, "jobs past the in-flight limit broke the connection");
    locd_engine_destroy(e);
    still_serving(&v, NULL);
    stop(&v);

    /* A service with a lower limit than the client's: only the excess fails. */
    unix_listen(listen, sizeof listen, "inflight4");
    TEST_ASSERT_TRUE(serve(&v, listen, 0, "--max-jobs", "4", NULL));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(v.addr, NULL, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, busy, BUSY_N / 2, 0, &busy_job));
    ok = 0;
    for (i = 0; i < 10; i++)
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, b, 50, 0, &j[i]));
    for (i = 0; i < 10; i++) {
        locd_status st = locd_job_wait(j[i], 60000);
        ok += st == LOCD_OK;
        limit += st == LOCD_ERR_LIMIT;
        other += st != LOCD_OK && st != LOCD_ERR_LIMIT;
        locd_job_release(j[i]);
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_job_wait(busy_job, 60000));
    locd_job_release(busy_job);
    LT_PRINT("max-jobs 4: %d ok, %d over the limit, %d other\n", ok, limit, other);
    TEST_ASSERT_EQUAL_INT(0, other);
    TEST_ASSERT_TRUE(limit > 0 && ok >= 3);
    job_status(e, b, 50, LOCD_OK, NULL); /* the connection goes on */
    locd_engine_destroy(e);
    still_serving(&v, NULL);
    stop(&v);
    free(j);
    free(busy);
    free(b);
}

/* ---- small ones: out of descriptors; forged log lines ---- */

/* CPU time (user + system, clock ticks) of a process. */
static long cpu_ticks(pid_t pid)
{
    char path[64], buf[1024], *p;
    long ut = 0, st = 0;
    FILE *f;
    snprintf(path, sizeof path, "/proc/%ld/stat", (long)pid);
    if (!(f = fopen(path, "r")))
        return -1;
    if (!fgets(buf, sizeof buf, f)) {
        fclose(f);
        return -1;
    }
    fclose(f);
    p = strrchr(buf, ')');
    /* after ")": state ppid pgrp session tty tpgid flags minflt cminflt majflt cmajflt utime stime */
    if (!p || sscanf(p + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %ld %ld", &ut, &st) != 2)
        return -1;
    return ut + st;
}

static void out_of_descriptors_backs_off(void)
{
    char listen[320];
    svc v;
    int fds[40], i, n = 0;
    long t0, t1;
    unix_listen(listen, sizeof listen, "emfile");
    TEST_ASSERT_TRUE(serve(&v, listen, 24, "--auth-timeout", "60000", NULL));
    for (i = 0; i < 40; i++)
        if ((fds[n] = raw_connect(v.addr)) >= 0)
            n++;
    lu_sleep_ms(300);
    t0 = cpu_ticks(v.pid);
    lu_sleep_ms(1000);
    t1 = cpu_ticks(v.pid);
    LT_PRINT("out of descriptors: %d connections, %ld ticks of CPU in 1 s\n", n, t1 - t0);
    TEST_ASSERT_TRUE_MESSAGE(t1 - t0 < 5, "the service spins when out of descriptors");
    TEST_ASSERT_TRUE(lu_file_contains(v.log, "cannot accept connections"));
    for (i = 0; i < n; i++)
        close(fds[i]);
    lu_sleep_ms(300);
    still_serving(&v, NULL);
    stop(&v);
    {
        /* The failure was logged once per episode (closing the clients
           may start a second one), not once per try every 100 ms. */
        FILE *f = fopen(v.log, "r");
        char line[512];
        int count = 0;
        while (f && fgets(line, sizeof line, f))
            count += strstr(line, "cannot accept connections") != NULL;
        if (f)
            fclose(f);
        LT_PRINT("out of descriptors: logged %d times\n", count);
        TEST_ASSERT_TRUE(count >= 1 && count <= 3);
    }
}

static void segment_names_are_escaped_in_the_log(void)
{
    char listen[320], line[512];
    svc v;
    FILE *f;
    int fd, forged = 0;
    unix_listen(listen, sizeof listen, "forge");
    TEST_ASSERT_TRUE(serve(&v, listen, 0, NULL));
    fd = raw_connect(v.addr);
    hello(fd, NULL);
    TEST_ASSERT_TRUE(send_shm_submit(fd, 1, 10, "/locd-x\nlocd serve: error: forged"));
    TEST_ASSERT_TRUE(closed_by_peer(fd, 5000));
    close(fd);
    TEST_ASSERT_TRUE(lu_wait_file_contains(v.log, "is not a locd segment", 5000));
    f = fopen(v.log, "r");
    while (f && fgets(line, sizeof line, f))
        forged += strncmp(line, "locd serve: error: forged", 25) == 0;
    if (f)
        fclose(f);
    TEST_ASSERT_EQUAL_INT_MESSAGE(0, forged, "a client wrote a line of the service's log");
    TEST_ASSERT_TRUE(lu_file_contains(v.log, "/locd-x\\x0alocd serve"));
    still_serving(&v, NULL);
    stop(&v);
}

static int setup(void)
{
    lu_setup();
    lu_temp_dir(g_dir, sizeof g_dir);
    signal(SIGPIPE, SIG_IGN);
    return 0;
}

static void teardown(void)
{
    lu_cleanup_dir(g_dir);
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST_FIXTURE(shrunk_segment_does_not_kill_the_service, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(slow_loris_unix, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(slow_loris_tcp, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(slow_reader_does_not_hold_a_runner, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(limits_fail_only_that_job, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(client_limits_and_job_time, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(huge_result_is_not_kept, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(stopping_reaches_a_running_job, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(in_flight_past_the_limit, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(out_of_descriptors_backs_off, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(segment_names_are_escaped_in_the_log, lu_timer_start, lu_timer_print),
    };
    return LT_RUN_GROUP(tests, setup, teardown);
}
