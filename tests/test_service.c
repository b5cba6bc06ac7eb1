/* Level 3 with a real `locd serve` process: garbage, oversized and
 * truncated messages drop only the guilty connection; a killed service
 * gives clear errors and a restarted one is picked up again; 16 concurrent
 * clients x 50 jobs are all correct; TCP needs the shared secret; 1,000
 * engine create/destroy cycles leak no fd and no segment; a malformed
 * RESULT from a fake service finishes every job of the connection. */
#include <signal.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <pthread.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include "runner.h"

#include "levels_util.h"
#include "support.h"

static lu_fixture g_fx = {"", "", "", -1};

static locd_status make_engine(const char *addr, const char *secret, locd_engine **e)
{
    locd_engine_config cfg;
    locd_engine_config_init(&cfg);
    cfg.level = LOCD_LEVEL_SERVICE;
    cfg.service_address = addr;
    cfg.service_secret = secret;
    return locd_engine_create(&cfg, e);
}

/* One small scene through the service, checked against brute force. */
static int service_works(const char *addr, const char *secret)
{
    locd_engine *e = NULL;
    locd_pairs *p = NULL;
    float *b = ts_scene(1, 700, 31);
    int ok = make_engine(addr, secret, &e) == LOCD_OK && locd_pairs_create(NULL, &p) == LOCD_OK &&
             locd_engine_find_pairs_f32(e, b, 700, 0, p) == LOCD_OK && ts_same_as_brute_f32(b, 700, p);
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    free(b);
    return ok;
}

static int raw_connect(const char *addr)
{
    struct sockaddr_un sa;
    int fd = socket(AF_UNIX, SOCK_STREAM, 0);
    memset(&sa, 0, sizeof sa);
    sa.sun_family = AF_UNIX;
    snprintf(sa.sun_path, sizeof sa.sun_path, "%.100s", addr + 5);
    if (connect(fd, (struct sockaddr *)&sa, sizeof sa) != 0) {
        close(fd);
        return -1;
    }
    return fd;
}

/* 1 when the service closes the connection within timeout_ms. */
static int closed_by_peer(int fd, int timeout_ms)
{
    char buf[256];
    double until = lu_now_ms() + timeout_ms;
    while (lu_now_ms() < until) {
        struct pollfd p;
        ssize_t r;
        p.fd = fd;
        p.events = POLLIN;
        if (poll(&p, 1, 100) <= 0)
            continue;
        r = recv(fd, buf, sizeof buf, 0);
        if (r <= 0)
            return 1;
    }
    return 0;
}

static void put_header(uint8_t *h, uint16_t type, uint64_t len)
{
    uint32_t magic = 0x5344434cu;
    uint16_t ver = 1;
    uint64_t id = 1;
    memcpy(h, &magic, 4);
    memcpy(h + 4, &ver, 2);
    memcpy(h + 6, &type, 2);
    memcpy(h + 8, &id, 8);
    memcpy(h + 16, &len, 8);
}

/* Sends an empty-secret HELLO and reads the WELCOME (closing a socket with
 * unread data would reset it instead of closing it cleanly). */
static void hello(int fd)
{
    uint8_t h[24 + 4], w[28];
    size_t got = 0;
    put_header(h, 1, 4);
    memset(h + 24, 0, 4);
    TEST_ASSERT_EQUAL_INT64((ssize_t)sizeof h, send(fd, h, sizeof h, MSG_NOSIGNAL));
    while (got < sizeof w) {
        ssize_t r = recv(fd, w + got, sizeof w - got, 0);
        TEST_ASSERT_TRUE(r > 0);
        got += (size_t)r;
    }
}

static void garbage_drops_only_that_connection(void)
{
    ts_rng r;
    uint8_t junk[4096], h[24 + 4];
    locd_engine *e = NULL;
    locd_pairs *p;
    float *b = ts_scene(0, 3000, 4);
    int fd, i;
    ts_seed(&r, 2024);
    /* a client that stays connected through all of it */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, make_engine(g_fx.addr, NULL, &e));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));

    for (i = 0; i < (int)sizeof junk; i++)
        junk[i] = (uint8_t)ts_next(&r);
    fd = raw_connect(g_fx.addr);
    TEST_ASSERT_TRUE(fd >= 0);
    TEST_ASSERT_EQUAL_INT64((ssize_t)sizeof junk, send(fd, junk, sizeof junk, MSG_NOSIGNAL));
    TEST_ASSERT_TRUE(closed_by_peer(fd, 5000));
    close(fd);

    /* valid HELLO, then an oversized SUBMIT header */
    fd = raw_connect(g_fx.addr);
    hello(fd);
    put_header(h, 3, (uint64_t)1 << 50);
    TEST_ASSERT_EQUAL_INT64(24, send(fd, h, 24, MSG_NOSIGNAL));
    TEST_ASSERT_TRUE(closed_by_peer(fd, 5000));
    close(fd);

    /* a truncated message: the header promises more than ever comes */
    fd = raw_connect(g_fx.addr);
    hello(fd);
    put_header(h, 3, 1000);
    TEST_ASSERT_EQUAL_INT64(24, send(fd, h, 24, MSG_NOSIGNAL));
    TEST_ASSERT_EQUAL_INT64(10, send(fd, junk, 10, MSG_NOSIGNAL));
    close(fd);

    /* a SUBMIT whose length does not match its box count */
    fd = raw_connect(g_fx.addr);
    hello(fd);
    {
        uint8_t m[24 + 36];
        uint64_t n = 1000;
        memset(m, 0, sizeof m);
        put_header(m, 3, 36 + 12);
        memcpy(m + 24 + 8, &n, 8);
        TEST_ASSERT_EQUAL_INT64((ssize_t)sizeof m, send(fd, m, sizeof m, MSG_NOSIGNAL));
    }
    TEST_ASSERT_TRUE(closed_by_peer(fd, 5000));
    close(fd);

    /* the well-behaved client and new ones are still served */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, 3000, 0, p));
    TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, 3000, p));
    TEST_ASSERT_TRUE(service_works(g_fx.addr, NULL));
    lu_sleep_ms(100);
    TEST_ASSERT_TRUE(lu_wait_file_contains(g_fx.log, "bad magic", 5000));
    TEST_ASSERT_TRUE(lu_wait_file_contains(g_fx.log, "exceeds the limit", 5000));
    TEST_ASSERT_TRUE(lu_wait_file_contains(g_fx.log, "truncated message", 5000));
    TEST_ASSERT_TRUE(lu_wait_file_contains(g_fx.log, "does not match", 5000));
    locd_engine_destroy(e);
    locd_pairs_destroy(p);
    free(b);
}

typedef struct client_ctx {
    int index;
    int ok, wrong, failed;
} client_ctx;

static void *client_main(void *arg)
{
    client_ctx *c = arg;
    locd_engine *e = NULL;
    locd_pairs *p = NULL;
    locd_job *jobs[10];
    float *scenes[10];
    size_t sizes[10];
    int batch, i;
    if (make_engine(g_fx.addr, NULL, &e) != LOCD_OK || locd_pairs_create(NULL, &p) != LOCD_OK) {
        c->failed = 50;
        return NULL;
    }
    for (batch = 0; batch < 5; batch++) {
        for (i = 0; i < 10; i++) {
            uint64_t seed = (uint64_t)c->index * 1000 + (uint64_t)batch * 10 + (uint64_t)i;
            sizes[i] = 50 + (size_t)(seed * 7919 % 400);
            scenes[i] = ts_scene((int)(seed % TS_SCENE_KINDS), sizes[i], seed);
            if (locd_engine_submit_f32(e, scenes[i], sizes[i], 0, &jobs[i]) != LOCD_OK)
                jobs[i] = NULL;
        }
        for (i = 0; i < 10; i++) {
            if (!jobs[i] || locd_job_wait(jobs[i], 60000) != LOCD_OK || locd_job_take(jobs[i], p) != LOCD_OK)
                c->failed++;
            else if (ts_same_as_brute_f32(scenes[i], sizes[i], p))
                c->ok++;
            else
                c->wrong++;
            locd_job_release(jobs[i]);
            free(scenes[i]);
        }
    }
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    return NULL;
}

static void sixteen_clients_fifty_jobs_each(void)
{
    pthread_t th[16];
    client_ctx c[16];
    int i, ok = 0;
    for (i = 0; i < 16; i++) {
        memset(&c[i], 0, sizeof c[i]);
        c[i].index = i;
        TEST_ASSERT_EQUAL_INT64(0, pthread_create(&th[i], NULL, client_main, &c[i]));
    }
    for (i = 0; i < 16; i++) {
        pthread_join(th[i], NULL);
        TEST_ASSERT_EQUAL_INT64(0, c[i].wrong);
        TEST_ASSERT_EQUAL_INT64(0, c[i].failed);
        ok += c[i].ok;
    }
    TEST_ASSERT_EQUAL_INT64(16 * 50, ok);
}

static void client_leaving_with_jobs_in_flight(void)
{
    int i, k;
    size_t nb = lu_heavy() ? 100000 : 20000;
    float *b = ts_scene(0, nb, 12);
    for (k = 0; k < 3; k++) {
        locd_engine *e = NULL;
        locd_job *j[8];
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, make_engine(g_fx.addr, NULL, &e));
        for (i = 0; i < 8; i++)
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_submit_f32(e, b, nb, 0, &j[i]));
        /* destroy first: pending jobs end with LOCD_ERR_CONNECTION */
        locd_engine_destroy(e);
        for (i = 0; i < 8; i++) {
            locd_status s = locd_job_wait(j[i], 10000);
            TEST_ASSERT_TRUE(s == LOCD_OK || s == LOCD_ERR_CONNECTION);
            locd_job_release(j[i]);
        }
    }
    free(b);
    TEST_ASSERT_TRUE(service_works(g_fx.addr, NULL));
}

static void service_killed_then_restarted(void)
{
    char dir[256], listen[300], addr[300], log[300], prefix[64];
    locd_engine *e = NULL;
    locd_job *j = NULL;
    locd_status s;
    size_t nb = lu_heavy() ? 300000 : 50000;
    float *b = ts_scene(0, nb, 6);
    pid_t svc;
    lu_temp_dir(dir, sizeof dir);
    snprintf(listen, sizeof listen, "unix:%s/k.sock", dir);
    snprintf(log, sizeof log, "%s/k.log", dir);
    svc = lu_start_service(listen, NULL, 1, log, addr, sizeof addr);
    TEST_ASSERT_TRUE(svc > 0);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, make_engine(addr, NULL, &e));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_submit_f32(e, b, nb, 0, &j));
    lu_stop_service(svc, SIGKILL);
    s = locd_job_wait(j, 10000);
    TEST_ASSERT_TRUE(s == LOCD_ERR_CONNECTION || s == LOCD_OK); /* it may have finished first */
    locd_job_release(j);
    /* the service is gone: a clear error, not a hang */
    s = locd_engine_submit_f32(e, b, 1000, 0, &j);
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_CONNECTION, s);
    TEST_ASSERT_NULL(j);
    {
        locd_pairs *p;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_CONNECTION, locd_engine_find_pairs_f32(e, b, 1000, 0, p));
        /* a new service on the same path (its stale socket is replaced) */
        svc = lu_start_service(listen, NULL, 1, log, addr, sizeof addr);
        TEST_ASSERT_TRUE(svc > 0);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, 1000, 0, p));
        TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, 1000, p));
        locd_pairs_destroy(p);
    }
    locd_engine_destroy(e);
    lu_stop_service(svc, SIGTERM);
    snprintf(prefix, sizeof prefix, "locd-c%ld-", (long)getpid());
    TEST_ASSERT_EQUAL_INT64(0, lu_count_shm(prefix));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_CONNECTION, make_engine(addr, NULL, &e)); /* nobody listens */
    TEST_ASSERT_NULL(e);
    lu_cleanup_dir(dir);
    free(b);
}

static void tcp_needs_the_secret(void)
{
    char dir[256], log[300], addr[300];
    locd_engine *e = NULL;
    pid_t svc;
    lu_temp_dir(dir, sizeof dir);
    snprintf(log, sizeof log, "%s/t.log", dir);
    /* refused without a secret */
    TEST_ASSERT_TRUE(lu_start_service("tcp:127.0.0.1:0", NULL, 1, log, addr, sizeof addr) < 0);
    TEST_ASSERT_TRUE(lu_wait_file_contains(log, "secret", 5000));
    svc = lu_start_service("tcp:127.0.0.1:0", "s3cret-tcp-test-secret", 2, log, addr, sizeof addr);
    TEST_ASSERT_TRUE(svc > 0);
    TEST_ASSERT_TRUE(strncmp(addr, "tcp:127.0.0.1:", 14) == 0);
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_AUTH, make_engine(addr, NULL, &e));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_AUTH, make_engine(addr, "wrong", &e));
    TEST_ASSERT_TRUE(service_works(addr, "s3cret-tcp-test-secret"));
    {
        /* large boxes stream over TCP */
        locd_engine *e1 = NULL;
        locd_pairs *want, *got;
        float *b = ts_scene(2, 60000, 17);
        locd_engine_config cfg;
        locd_engine_config_init(&cfg);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e1));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, make_engine(addr, "s3cret-tcp-test-secret", &e));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &want));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &got));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e1, b, 60000, 0, want));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, 60000, 0, got));
        TEST_ASSERT_TRUE(lu_same_pairs(want, got));
        locd_engine_destroy(e1);
        locd_engine_destroy(e);
        locd_pairs_destroy(want);
        locd_pairs_destroy(got);
        free(b);
    }
    lu_stop_service(svc, SIGTERM);
    lu_cleanup_dir(dir);
}

static void socket_directory_must_be_private(void)
{
    char dir[256], listen[300], log[300], addr[300];
    lu_temp_dir(dir, sizeof dir);
    snprintf(log, sizeof log, "%s/p.log", dir);
    chmod(dir, 0755);
    snprintf(listen, sizeof listen, "unix:%s/p.sock", dir);
    TEST_ASSERT_TRUE(lu_start_service(listen, NULL, 1, log, addr, sizeof addr) < 0);
    TEST_ASSERT_TRUE(lu_wait_file_contains(log, "0700", 5000));
    lu_cleanup_dir(dir);
}

static void create_destroy_cycles_leak_nothing(void)
{
    char prefix[64];
    int fds0 = lu_count_fds(), children0 = lu_count_children(), i, cycles = lu_heavy() ? 1000 : 100;
    float *b = ts_scene(0, 20000, 8);
    locd_pairs *p;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    for (i = 0; i < cycles; i++) {
        locd_engine *e = NULL;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, make_engine(g_fx.addr, NULL, &e));
        if (i % 50 == 0) /* 20000 boxes go through shared memory */
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, 20000, 0, p));
        locd_engine_destroy(e);
    }
    snprintf(prefix, sizeof prefix, "locd-c%ld-", (long)getpid());
    TEST_ASSERT_EQUAL_INT64(0, lu_count_shm(prefix));
    TEST_ASSERT_EQUAL_INT64(fds0, lu_count_fds());
    TEST_ASSERT_EQUAL_INT64(children0, lu_count_children());
    free(b);
    locd_pairs_destroy(p);
}

/* ---- A fake service that answers a job with a malformed RESULT ----
 * The client's reader must finish the job with LOCD_ERR_PROTOCOL, fail the
 * connection's other jobs and close the connection, whether or not the
 * service closes its end; a wait that ran into its bound is the bug. */

enum { BAD_SHORT, BAD_TEXT_LENGTH, BAD_COUNT, BAD_HUGE_COUNT, BAD_LYING_LENGTH, BAD_STATUS, BAD_KINDS };

typedef struct fake_service {
    int lfd, kind, jobs;  /* jobs to read before answering the first */
    int client_closed;    /* the client closed its end within 5 s */
} fake_service;

static int read_n(int fd, void *buf, size_t len)
{
    size_t got = 0;
    while (got < len) {
        ssize_t r = recv(fd, (char *)buf + got, len - got, 0);
        if (r <= 0)
            return 0;
        got += (size_t)r;
    }
    return 1;
}

/* Reads one message and drops its payload; its id in *id. */
static int read_message(int fd, uint64_t *id)
{
    uint8_t h[24], junk[4096];
    uint64_t len;
    if (!read_n(fd, h, sizeof h))
        return 0;
    memcpy(id, h + 8, 8);
    memcpy(&len, h + 16, 8);
    while (len) {
        size_t k = len < sizeof junk ? (size_t)len : sizeof junk;
        if (!read_n(fd, junk, k))
            return 0;
        len -= k;
    }
    return 1;
}

static void put_message_header(uint8_t *h, uint16_t type, uint64_t id, uint64_t len)
{
    put_header(h, type, len);
    memcpy(h + 8, &id, 8);
}

/* The RESULT of kind k for job id: header and payload in out, their size
 * in *n. Every one is malformed or inconsistent. */
static void bad_result(int k, uint64_t id, uint8_t *out, size_t *n)
{
    uint8_t *p = out + 24;
    int32_t status = 0;
    int64_t index = -1;
    uint32_t mlen = 0;
    uint64_t count = 0, length = 16 + 112 + 8;
    size_t body = 16 + 112 + 8;
    memset(out, 0, 24 + 16 + 112 + 8 + 64);
    if (k == BAD_SHORT) {
        length = body = 20; /* shorter than the fixed part */
    } else if (k == BAD_TEXT_LENGTH) {
        mlen = 5000; /* over the message limit */
    } else if (k == BAD_COUNT) {
        count = 5; /* length says one pair */
        length = body = 16 + 112 + 8 + 8;
    } else if (k == BAD_HUGE_COUNT) {
        count = UINT64_MAX / 4; /* count * 8 wraps */
    } else if (k == BAD_LYING_LENGTH) {
        count = 10; /* 10 pairs announced, 1 sent, then the service closes */
        length = 16 + 112 + 8 + 80;
        body = 16 + 112 + 8 + 8;
    } else {
        status = LOCD_PENDING; /* not a final status */
    }
    put_message_header(out, 5, id, length);
    memcpy(p, &status, 4);
    memcpy(p + 4, &index, 8);
    memcpy(p + 12, &mlen, 4);
    if (body >= 16 + 112 + 8)
        memcpy(p + 16 + 112, &count, 8);
    *n = 24 + body;
}

static void *fake_service_main(void *arg)
{
    fake_service *f = arg;
    uint8_t welcome[28], res[24 + 16 + 112 + 8 + 64];
    uint64_t id, first = 0;
    size_t n;
    int fd = accept(f->lfd, NULL, NULL), i;
    if (fd < 0)
        return NULL;
    if (!read_message(fd, &id)) /* HELLO */
        goto out;
    put_message_header(welcome, 2, 0, 4);
    memset(welcome + 24, 0, 4); /* no shared memory: the boxes are streamed */
    if (send(fd, welcome, sizeof welcome, MSG_NOSIGNAL) != (ssize_t)sizeof welcome)
        goto out;
    for (i = 0; i < f->jobs; i++) {
        if (!read_message(fd, &id))
            goto out;
        if (i == 0)
            first = id;
    }
    bad_result(f->kind, first, res, &n);
    if (send(fd, res, n, MSG_NOSIGNAL) != (ssize_t)n)
        goto out;
    if (f->kind == BAD_LYING_LENGTH)
        goto out; /* the rest never comes: the connection closes */
    /* Otherwise the service stays: the client has to see the error itself
       and close the connection. */
    f->client_closed = closed_by_peer(fd, 5000);
out:
    close(fd);
    return NULL;
}

static int fake_listen(const char *path)
{
    struct sockaddr_un sa;
    int fd = socket(AF_UNIX, SOCK_STREAM, 0);
    memset(&sa, 0, sizeof sa);
    sa.sun_family = AF_UNIX;
    snprintf(sa.sun_path, sizeof sa.sun_path, "%s", path);
    unlink(path);
    TEST_ASSERT_EQUAL_INT(0, bind(fd, (struct sockaddr *)&sa, sizeof sa));
    TEST_ASSERT_EQUAL_INT(0, listen(fd, 4));
    return fd;
}

static void malformed_result_finishes_every_job(void)
{
    char path[300], addr[320];
    float *b = ts_scene(0, 200, 9);
    int k;
    snprintf(path, sizeof path, "%s/fake.sock", g_fx.dir);
    snprintf(addr, sizeof addr, "unix:%s", path);
    for (k = 0; k < BAD_KINDS; k++) {
        fake_service f;
        pthread_t t;
        locd_engine *e = NULL;
        locd_job *j1 = NULL, *j2 = NULL;
        locd_status s1, s2;
        memset(&f, 0, sizeof f);
        f.lfd = fake_listen(path);
        f.kind = k;
        f.jobs = 2;
        TEST_ASSERT_EQUAL_INT(0, pthread_create(&t, NULL, fake_service_main, &f));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(addr, NULL, &e));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, b, 200, 0, &j1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_submit_f32(e, b, 200, 0, &j2));
        s1 = locd_job_wait(j1, 5000);
        s2 = locd_job_wait(j2, 5000);
        LT_PRINT("malformed result %d: %d, other job %d\n", k, s1, s2);
        /* A bounded wait: the unfixed reader left the job pending forever. */
        TEST_ASSERT_EQUAL_INT_MESSAGE(LOCD_ERR_PROTOCOL, s1, "the job with the malformed result");
        TEST_ASSERT_TRUE_MESSAGE(s2 == LOCD_ERR_CONNECTION || s2 == LOCD_ERR_PROTOCOL, "the other job");
        pthread_join(t, NULL); /* the fake service waits up to 5 s for the client to close */
        if (k != BAD_LYING_LENGTH)
            TEST_ASSERT_TRUE_MESSAGE(f.client_closed, "the client did not close the connection");
        locd_job_release(j1);
        locd_job_release(j2);
        locd_engine_destroy(e);
        close(f.lfd);
        unlink(path);
    }
    free(b);
}

/* The synchronous find is a submit and a wait without a bound: it must
 * return too. */
static void malformed_result_ends_a_find(void)
{
    char path[300], addr[320];
    float *b = ts_scene(0, 200, 9);
    fake_service f;
    pthread_t t;
    locd_engine *e = NULL;
    locd_pairs *p = NULL;
    snprintf(path, sizeof path, "%s/fake.sock", g_fx.dir);
    snprintf(addr, sizeof addr, "unix:%s", path);
    memset(&f, 0, sizeof f);
    f.lfd = fake_listen(path);
    f.kind = BAD_COUNT;
    f.jobs = 1;
    TEST_ASSERT_EQUAL_INT(0, pthread_create(&t, NULL, fake_service_main, &f));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, make_engine(addr, NULL, &e));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_PROTOCOL, locd_engine_find_pairs_f32(e, b, 200, 0, p));
    pthread_join(t, NULL);
    TEST_ASSERT_TRUE(f.client_closed);
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    close(f.lfd);
    unlink(path);
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
        LT_TEST_FIXTURE(garbage_drops_only_that_connection, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(sixteen_clients_fifty_jobs_each, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(client_leaving_with_jobs_in_flight, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(service_killed_then_restarted, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(tcp_needs_the_secret, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(socket_directory_must_be_private, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(create_destroy_cycles_leak_nothing, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(malformed_result_finishes_every_job, lu_timer_start, lu_timer_print),
        LT_TEST_FIXTURE(malformed_result_ends_a_find, lu_timer_start, lu_timer_print),
    };
    return LT_RUN_GROUP(tests, setup, teardown);
}
