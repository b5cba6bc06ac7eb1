/* libFuzzer harness: the service's session loop on one thread, fast. Each
 * input is a client's byte stream, written whole into a socketpair whose
 * other end is a service connection; then the harness runs, in order and
 * on its own thread, what the service's threads would:
 *   - the connection's session loop (lc_srv_serve: HELLO/WELCOME with or
 *     without a secret, every header check, SUBMIT parsing with inline
 *     boxes or a shared-memory segment, CANCEL, the in-flight limit);
 *   - a runner draining the queue (lc_srv_run_queued: each job is run by
 *     a level-1 engine and its RESULT written, or answered as cancelled);
 *   - the connection's end (closed, its jobs cancelled, its reference
 *     dropped, as conn_main does).
 * No thread, socket listener or timer is involved, so an input takes tens
 * of microseconds and replays identically; fuzz_service.c drives the whole
 * service through a real socket instead (slower, threads and all). Input
 * layout as fuzz_service.c's (byte 0 bit 0: the service with a secret) so
 * the two share seeds. A wrong secret is answered at once here
 * (auth_fail_delay_ms left 0; the service waits 1 s). /dev/shm: as fuzz_service.c (a private tmpfs when
 * the system allows, with one segment offered for shared-memory SUBMITs). */
#define _GNU_SOURCE
#include "service/service.h"

#include <errno.h>
#include <fcntl.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/mount.h>
#include <sys/socket.h>
#include <unistd.h>

#define FUZZ_SECRET "fuzz-secret-0123456789abcdef"
#define FUZZ_SEGMENT "/locd-fuzz-segment"

static lc_server g_srv[2];
static int g_private_shm;

static void die(const char *what)
{
    fprintf(stderr, "fuzz_session: %s (%s)\n", what, strerror(errno));
    abort();
}

static void quiet_log(int32_t severity, const char *message, void *user)
{
    volatile size_t n = strlen(message);
    (void)severity;
    (void)user;
    (void)n;
}

/* A service as locd_service_create makes it, without its listener and
 * threads. */
static void server_init(lc_server *s, const char *secret)
{
    memset(s, 0, sizeof *s);
    locd_service_config_init(&s->cfg);
    s->cfg.threads = 1;
    s->cfg.engine_threads = 1;
    s->cfg.max_message = 64u * 1024u;
    s->cfg.max_clients = 4;
    s->cfg.max_jobs = 8;
    s->cfg.log = quiet_log;
    /* What resolve_config (server.c) fills for a zero field. */
    s->cfg.auth_timeout_ms = LC_HELLO_TIMEOUT_MS;
    s->cfg.message_timeout_ms = LC_SRV_DEFAULT_MESSAGE_MS;
    s->cfg.send_timeout_ms = LC_SRV_DEFAULT_SEND_MS;
    s->cfg.max_job_ms = LC_SRV_DEFAULT_JOB_MS;
    s->cfg.max_job_boxes = LC_SRV_DEFAULT_JOB_BOXES;
    s->cfg.max_job_pairs = LC_SRV_DEFAULT_JOB_PAIRS;
    s->cfg.max_job_memory = LC_SRV_DEFAULT_JOB_MEMORY;
    s->cfg.max_client_boxes = LC_SRV_DEFAULT_CLIENT_BOXES;
    s->cfg.max_client_pairs = LC_SRV_DEFAULT_CLIENT_PAIRS;
    s->cfg.max_client_memory = LC_SRV_DEFAULT_CLIENT_MEMORY;
    if (secret && !(s->secret = strdup(secret)))
        die("strdup");
    s->cfg.secret = s->secret;
    s->lfd = -1;
    s->wake[0] = s->wake[1] = -1;
    pthread_mutex_init(&s->mu, NULL);
    pthread_cond_init(&s->cv, NULL);
    pthread_cond_init(&s->conns_cv, NULL);
    s->magic = LC_MAGIC_SERVICE;
}

static void server_free(void)
{
    int i;
    for (i = 0; i < 2; i++) {
        free(g_srv[i].secret);
        g_srv[i].secret = NULL;
        pthread_cond_destroy(&g_srv[i].cv);
        pthread_cond_destroy(&g_srv[i].conns_cv);
        pthread_mutex_destroy(&g_srv[i].mu);
    }
    if (g_private_shm)
        shm_unlink(FUZZ_SEGMENT);
}

static int private_dev_shm(void)
{
    if (getenv("LOCD_FUZZ_SHARED_SHM"))
        return 0;
    if (unshare(CLONE_NEWNS) != 0)
        return 0;
    if (mount(NULL, "/", NULL, MS_REC | MS_PRIVATE, NULL) != 0)
        return 0;
    return mount("locd-fuzz", "/dev/shm", "tmpfs", MS_NOSUID | MS_NODEV, "size=16m,mode=1777") == 0;
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    g_private_shm = private_dev_shm();
    server_init(&g_srv[0], NULL);
    server_init(&g_srv[1], FUZZ_SECRET);
    atexit(server_free);
    return 0;
}

static void offer_segment(void)
{
    static const float boxes[24] = {0, 0, 0, 1, 1, 1, 0.5f, 0.5f, 0.5f, 2, 2, 2,
                                    3, 3, 3, 4, 4, 4, 1, 1, 1, 3, 3, 3};
    int fd = shm_open(FUZZ_SEGMENT, O_CREAT | O_RDWR | O_TRUNC, 0600);
    if (fd < 0)
        die("shm_open");
    if (write(fd, boxes, sizeof boxes) != (ssize_t)sizeof boxes)
        die("write segment");
    close(fd);
}

/* Reads what the service wrote and checks that it is whole messages with
 * valid headers (the service must never send anything else). */
static void check_answers(int fd)
{
    static uint8_t buf[1 << 16];
    uint8_t hdr[LC_PROTO_HEADER];
    size_t have = 0;
    uint64_t skip = 0;
    for (;;) {
        ssize_t got = recv(fd, buf, sizeof buf, MSG_DONTWAIT);
        size_t i = 0;
        if (got <= 0)
            break;
        while (i < (size_t)got) {
            if (skip) {
                size_t k = (size_t)got - i < skip ? (size_t)got - i : (size_t)skip;
                skip -= k;
                i += k;
                continue;
            }
            hdr[have++] = buf[i++];
            if (have == LC_PROTO_HEADER) {
                lc_msg_header h;
                char why[200];
                if (!lc_proto_get_header(hdr, UINT64_MAX, &h, why, sizeof why)) {
                    fprintf(stderr, "fuzz_session: the service sent a bad header: %s\n", why);
                    abort();
                }
                skip = h.length;
                have = 0;
                if (getenv("LOCD_FUZZ_VERBOSE") && i + 4 <= (size_t)got && h.type == LC_MSG_RESULT)
                    fprintf(stderr, "  RESULT status %d\n", (int)lc_get_u32(buf + i));
            }
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    lc_server *s;
    lc_srv_conn *c;
    int sv[2];
    if (size < 1 || size > 1u << 20)
        return 0;
    s = &g_srv[data[0] & 1];
    if (g_private_shm)
        offer_segment();
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0)
        die("socketpair");
    {
        int big = 4 << 20;
        setsockopt(sv[0], SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
        setsockopt(sv[0], SOL_SOCKET, SO_SNDBUF, &big, sizeof big);
        setsockopt(sv[1], SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
        setsockopt(sv[1], SOL_SOCKET, SO_SNDBUF, &big, sizeof big);
    }
    /* The whole stream, then end of stream: the session never waits. */
    if (size > 1 && !lc_proto_write_all(sv[0], data + 1, size - 1))
        die("write stream");
    shutdown(sv[0], SHUT_WR);
    /* The service's end never blocks: an answer too large for the buffer
     * breaks the connection, as a client that stops reading would. */
    fcntl(sv[1], F_SETFL, O_NONBLOCK);

    c = calloc(1, sizeof *c);
    if (!c)
        die("calloc");
    c->s = s;
    c->fd = sv[1];
    c->refs = 1;
    c->since = lc_now_ms(); /* the auth deadline counts from here */
    c->shm_ok = 1;
    snprintf(c->peer, sizeof c->peer, "fuzz");
    pthread_mutex_init(&c->wmu, NULL);

    lc_srv_serve(c);
    /* A runner takes every queued job and returns when the queue is empty
     * (not by setting stopping, which now cancels running jobs). */
    lc_srv_run_queued(s);
    /* The connection's end, as conn_main. */
    pthread_mutex_lock(&c->wmu);
    c->closed = 1;
    close(c->fd);
    c->fd = -1;
    pthread_mutex_unlock(&c->wmu);
    pthread_mutex_lock(&s->mu);
    lc_srv_cancel_all_locked(c);
    lc_srv_conn_unref_locked(c);
    pthread_mutex_unlock(&s->mu);

    check_answers(sv[0]);
    close(sv[0]);
    return 0;
}
