/* libFuzzer harness: the level-3 service's message handling, end to end
 * and in-process. One real service (locd_service_create/run, a runner
 * thread, a Unix socket in a private temporary directory) serves every
 * input; the harness connects, writes the input as the client's byte
 * stream, reads what the service answers, then closes its side and waits
 * for the service to close the connection. So the bytes go through the
 * real accept, HELLO/WELCOME, header checks, SUBMIT parsing (inline boxes
 * and shared-memory segments), CANCEL, the run queue and RESULT writing.
 *
 * Input: byte 0 chooses the service (bit 0: the one with a secret, see
 * FUZZ_SECRET); the rest is the client's stream (HELLO first; messages as
 * lib/service/service.h describes them). Seeds: tests/fuzz/corpus/service/,
 * made by tests/fuzz/make_seeds.py.
 *
 * No sleeps: a message the input leaves unfinished ends when the harness
 * shuts its side down (the service reads end-of-stream, not a timeout), and
 * the harness waits for exactly the answers the service owes it. A service
 * that owes an answer and neither sends it nor closes within
 * FUZZ_GUARD_MS is a hang: the harness aborts, and libFuzzer reports it.
 *
 * /dev/shm: when it can (root, CI), the harness runs in its own mount
 * namespace with a private tmpfs on /dev/shm, so nothing it or the service
 * creates there is seen by, or left for, anyone else; it then offers one
 * segment, FUZZ_SEGMENT, for shared-memory SUBMITs to name, and puts the
 * service's sockets there too. Otherwise it creates no segment (such
 * SUBMITs are refused by the service) and the sockets go to a temporary
 * directory in /tmp, removed at exit. */
#define _GNU_SOURCE
#include <locd/locd.h>
#include <locd/service.h>

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/mount.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#define FUZZ_SECRET "fuzz-secret-0123456789abcdef"
#define FUZZ_SEGMENT "/locd-fuzz-segment"
#define FUZZ_GUARD_MS 20000
/* Small limits so that the fuzzer reaches them and no input costs much. */
#define FUZZ_MAX_MESSAGE (64u * 1024u)
#define FUZZ_MAX_JOBS 8

/* The wire format's constants (lib/service/service.h; repeated here so the
 * harness needs only the public API). */
#define HDR 24
#define MAGIC 0x5344434cu
#define MSG_SUBMIT 3
#define MSG_RESULT 5

typedef struct served {
    locd_service *svc;
    pthread_t th;
    char path[160];
} served;

static served g_svc[2];
static char g_dir[64];
static int g_private_shm;
static int g_verbose; /* LOCD_FUZZ_VERBOSE=1: what the service answered */

static uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

static uint64_t get_u64(const uint8_t *p)
{
    return (uint64_t)get_u32(p) | ((uint64_t)get_u32(p + 4) << 32);
}

static void die(const char *what)
{
    fprintf(stderr, "fuzz_service: %s (%s)\n", what, strerror(errno));
    abort();
}

/* The service's log lines are read in full (ASan checks every byte) and
 * dropped. */
static void quiet_log(int32_t severity, const char *message, void *user)
{
    volatile size_t n = strlen(message);
    (void)user;
    (void)n;
    if (g_verbose)
        fprintf(stderr, "  service log %d: %s\n", (int)severity, message);
}

static void *run_service(void *arg)
{
    served *v = arg;
    locd_service_run(v->svc);
    return NULL;
}

static void start_service(served *v, const char *name, const char *secret)
{
    locd_service_config cfg;
    char listen[200];
    snprintf(v->path, sizeof v->path, "%s/%s", g_dir, name);
    snprintf(listen, sizeof listen, "unix:%s", v->path);
    locd_service_config_init(&cfg);
    cfg.listen = listen;
    cfg.secret = secret;
    cfg.threads = 1;
    cfg.engine_threads = 1;
    cfg.max_message = FUZZ_MAX_MESSAGE;
    cfg.max_clients = 4;
    cfg.max_jobs = FUZZ_MAX_JOBS;
    cfg.log = quiet_log;
    if (locd_service_create(&cfg, &v->svc) != LOCD_OK) {
        fprintf(stderr, "fuzz_service: locd_service_create: %s\n", locd_last_error());
        abort();
    }
    if (pthread_create(&v->th, NULL, run_service, v) != 0)
        die("pthread_create");
}

static void stop_services(void)
{
    int i;
    for (i = 0; i < 2; i++) {
        if (!g_svc[i].svc)
            continue;
        locd_service_stop(g_svc[i].svc);
        pthread_join(g_svc[i].th, NULL);
        locd_service_destroy(g_svc[i].svc);
        g_svc[i].svc = NULL;
    }
    if (g_private_shm)
        shm_unlink(FUZZ_SEGMENT);
    if (g_dir[0])
        rmdir(g_dir);
}

/* A private tmpfs on /dev/shm for this process (and the threads it starts
 * from now on); 0 when the system does not allow it. */
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
    g_verbose = getenv("LOCD_FUZZ_VERBOSE") != NULL;
    g_private_shm = private_dev_shm();
    /* The sockets too live in the private tmpfs when there is one: a crash
     * (no atexit) then leaves nothing behind. */
    snprintf(g_dir, sizeof g_dir, "%s/locd-fuzz-XXXXXX", g_private_shm ? "/dev/shm" : "/tmp");
    if (!mkdtemp(g_dir))
        die("mkdtemp");
    start_service(&g_svc[0], "open.sock", NULL);
    start_service(&g_svc[1], "secret.sock", FUZZ_SECRET);
    atexit(stop_services);
    return 0;
}

/* The segment a shared-memory SUBMIT may name: 4 float boxes (96 bytes,
 * so also 2 double boxes). The service unlinks what it opens: remade for
 * every input. */
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

/* The SUBMITs among the complete messages of the stream: the answers the
 * service owes unless it drops the connection. */
static size_t submits_in(const uint8_t *p, size_t n)
{
    size_t off = 0, count = 0;
    while (n - off >= HDR) {
        uint64_t len = get_u64(p + off + 16);
        if (len > n - off - HDR)
            break;
        if (get_u32(p + off) == MAGIC && p[off + 6] == MSG_SUBMIT && p[off + 7] == 0)
            count++;
        off += HDR + (size_t)len;
    }
    return count;
}

static long long now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (long long)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

/* What the harness has read of the service's answers. */
typedef struct reply {
    uint8_t hdr[HDR];
    size_t have;    /* bytes of hdr */
    uint64_t skip;  /* payload bytes still to drop */
    size_t results; /* complete RESULT headers */
    int eof;
    int in_result;  /* reading a RESULT's payload */
    uint8_t status[4];
    size_t status_have;
} reply;


static void take(reply *r, const uint8_t *b, size_t n)
{
    while (n) {
        if (r->skip) {
            size_t k = r->skip < n ? (size_t)r->skip : n;
            while (g_verbose && r->in_result && r->status_have < 4 && r->status_have < k)
                r->status[r->status_have] = b[r->status_have], r->status_have++;
            if (g_verbose && r->in_result && r->status_have == 4) {
                fprintf(stderr, "  RESULT status %d\n", (int)get_u32(r->status));
                r->in_result = 0;
            }
            r->skip -= k;
            b += k;
            n -= k;
            continue;
        }
        while (n && r->have < HDR) {
            r->hdr[r->have++] = *b++;
            n--;
        }
        if (r->have == HDR) {
            /* The service must only ever send well-formed headers. */
            if (get_u32(r->hdr) != MAGIC) {
                fprintf(stderr, "fuzz_service: the service sent a bad header\n");
                abort();
            }
            if (r->hdr[6] == MSG_RESULT)
                r->results++;
            if (g_verbose)
                fprintf(stderr, "  message type %u id %llu length %llu\n", r->hdr[6],
                        (unsigned long long)get_u64(r->hdr + 8), (unsigned long long)get_u64(r->hdr + 16));
            r->in_result = r->hdr[6] == MSG_RESULT;
            r->status_have = 0;
            r->skip = get_u64(r->hdr + 16);
            r->have = 0;
        }
    }
}

static void read_some(int fd, reply *r)
{
    uint8_t buf[65536];
    ssize_t got = recv(fd, buf, sizeof buf, MSG_DONTWAIT);
    if (got > 0)
        take(r, buf, (size_t)got);
    else if (got == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR))
        r->eof = 1; /* closed, or reset by a service that dropped us */
}

/* Waits until fd is readable (or writable when want_write); aborts after
 * FUZZ_GUARD_MS without progress. */
static short wait_fd(int fd, int want_write, long long since)
{
    struct pollfd p;
    int pr;
    p.fd = fd;
    p.events = (short)(POLLIN | (want_write ? POLLOUT : 0));
    p.revents = 0;
    for (;;) {
        long long left = since + FUZZ_GUARD_MS - now_ms();
        if (left <= 0) {
            fprintf(stderr, "fuzz_service: the service neither answered nor closed in %d ms\n", FUZZ_GUARD_MS);
            abort();
        }
        pr = poll(&p, 1, (int)left);
        if (pr > 0)
            return p.revents;
        if (pr < 0 && errno != EINTR)
            die("poll");
    }
}

static int connect_to(const char *path)
{
    struct sockaddr_un a;
    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0)
        die("socket");
    memset(&a, 0, sizeof a);
    a.sun_family = AF_UNIX;
    snprintf(a.sun_path, sizeof a.sun_path, "%s", path);
    if (connect(fd, (struct sockaddr *)&a, sizeof a) != 0)
        die("connect");
    return fd;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const uint8_t *stream;
    size_t n, sent = 0, owed;
    reply r;
    int fd, writing = 1;
    long long since;
    if (size < 1)
        return 0;
    stream = data + 1;
    n = size - 1;
    owed = submits_in(stream, n);
    if (g_private_shm)
        offer_segment();
    memset(&r, 0, sizeof r);
    fd = connect_to(g_svc[data[0] & 1].path);
    /* 1: write the stream while reading answers, until every answer owed
     * came or the service closed. */
    since = now_ms();
    for (;;) {
        short ev;
        if (sent == n)
            writing = 0;
        if (r.eof || (!writing && r.results >= owed))
            break;
        ev = wait_fd(fd, writing, since);
        if (ev & (POLLIN | POLLHUP | POLLERR)) {
            read_some(fd, &r);
            since = now_ms();
        }
        if (writing && (ev & POLLOUT)) {
            ssize_t w = send(fd, stream + sent, n - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
            if (w > 0) {
                sent += (size_t)w;
                since = now_ms();
            } else if (w < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
                writing = 0; /* the service dropped us */
                n = sent;
            }
        }
    }
    /* 2: end of stream from this side; the service must close too. */
    shutdown(fd, SHUT_WR);
    since = now_ms();
    while (!r.eof) {
        wait_fd(fd, 0, since);
        read_some(fd, &r);
    }
    close(fd);
    if (g_verbose)
        fprintf(stderr, "  %zu SUBMITs, %zu RESULTs; private /dev/shm %d\n", owed, r.results, g_private_shm);
    return 0;
}
