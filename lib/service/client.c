/* Integration level 3, client side: the engine is a connection to a
 * `locd serve` process. Jobs are submitted with an id and go on the
 * connection's pending list; one reader thread per connection receives the
 * results, whatever their order, and finishes the matching jobs. When the
 * connection breaks, every pending job finishes with LOCD_ERR_CONNECTION and
 * the next submit tries to connect again (a restarted service is picked up).
 * A synchronous find is a submit followed by a wait.
 *
 * On a Unix socket the boxes of larger jobs travel through a POSIX shm
 * segment (mode 0600, unique name) that the service unlinks once it has
 * opened it; the client unlinks it too when the job ends, in case the
 * service never got to it. Over TCP the boxes are streamed. */
#define _GNU_SOURCE
#include "service/service.h"

#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdio.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#define LC_CONNECT_TIMEOUT_MS 5000
#define LC_RESULT_MAX_BYTES (1ull << 37)

/* A service job: the common part first (see engine/engine.h), then what
 * the connection needs to match the service's answer. */
typedef struct lc_svc_job {
    locd_job job;
    struct lc_svc_conn *conn;
    uint64_t id;
    char shm_name[64];          /* bulk input segment to unlink when done ("" = none) */
    struct lc_svc_job *next;    /* in the connection's pending list */
} lc_svc_job;

typedef struct lc_svc_conn {
    pthread_mutex_t mu; /* refs, dead, pending, next_id */
    int refs;
    int dead;
    char why[200];
    lc_svc_job *pending;
    uint64_t next_id;
    pthread_mutex_t wmu; /* one writer at a time; fd */
    int fd;
    int shm_ok;
    pthread_t reader;
    locd_allocator alloc;
} lc_svc_conn;

typedef struct lc_svc {
    pthread_mutex_t mu; /* conn replacement */
    lc_svc_conn *conn;
} lc_svc;

static void conn_unref(lc_svc_conn *c)
{
    int left;
    pthread_mutex_lock(&c->mu);
    left = --c->refs;
    pthread_mutex_unlock(&c->mu);
    if (left)
        return;
    if (c->fd >= 0)
        close(c->fd);
    pthread_mutex_destroy(&c->mu);
    pthread_mutex_destroy(&c->wmu);
    lc_free(&c->alloc, c, sizeof *c);
}

/* Removes job `id` from the pending list; the caller gets its reference. */
static lc_svc_job *take_pending(lc_svc_conn *c, uint64_t id)
{
    lc_svc_job **pp, *j = NULL;
    pthread_mutex_lock(&c->mu);
    for (pp = &c->pending; *pp; pp = &(*pp)->next)
        if ((*pp)->id == id) {
            j = *pp;
            *pp = j->next;
            j->next = NULL;
            break;
        }
    pthread_mutex_unlock(&c->mu);
    return j;
}

/* Removes the job's input segment name, if any (it may still be there
 * when the service never opened it). */
static void drop_segment(lc_svc_job *j)
{
    pthread_mutex_lock(&j->job.mu);
    if (j->shm_name[0]) {
        shm_unlink(j->shm_name);
        j->shm_name[0] = '\0';
    }
    pthread_mutex_unlock(&j->job.mu);
}

static void job_done(lc_svc_job *j, locd_status st, const char *msg, int64_t index)
{
    drop_segment(j);
    lc_job_finish_unref(&j->job, st, msg, index);
}

/* Reads one RESULT payload (after its header) for job j (NULL: discard). */
static int read_result(lc_svc_conn *c, const lc_msg_header *h, lc_svc_job *j, char *why, size_t wl)
{
    uint8_t fixed[16], sbuf[LC_PROTO_STATS_BYTES], cbuf[8];
    char msg[LC_PROTO_MAX_TEXT + 1];
    uint32_t mlen;
    uint64_t count, need;
    int32_t status;
    int64_t index;
    locd_stats st;
    if (h->length < 16 + LC_PROTO_STATS_BYTES + 8) {
        snprintf(why, wl, "short result message");
        return -1;
    }
    if (lc_proto_read_all(c->fd, fixed, 16, 30000, why, wl) != 1)
        return -1;
    status = (int32_t)lc_get_u32(fixed);
    index = (int64_t)lc_get_u64(fixed + 4);
    mlen = lc_get_u32(fixed + 12);
    if (mlen > LC_PROTO_MAX_TEXT || h->length < 16 + (uint64_t)mlen + LC_PROTO_STATS_BYTES + 8) {
        snprintf(why, wl, "bad result message");
        return -1;
    }
    if (lc_proto_read_all(c->fd, msg, mlen, 30000, why, wl) != 1 ||
        lc_proto_read_all(c->fd, sbuf, sizeof sbuf, 30000, why, wl) != 1 ||
        lc_proto_read_all(c->fd, cbuf, 8, 30000, why, wl) != 1)
        return -1;
    msg[mlen] = '\0';
    count = lc_get_u64(cbuf);
    need = 16 + (uint64_t)mlen + LC_PROTO_STATS_BYTES + 8 + count * 8;
    if (count > (h->length / 8) || need != h->length) {
        snprintf(why, wl, "result length does not match its pair count");
        return -1;
    }
    if (!j)
        return lc_proto_skip(c->fd, count * 8, 30000, why, wl) == 1 ? 0 : -1;
    lc_proto_get_stats(sbuf, &st);
    if (status == LOCD_OK) {
        if (lc_pairs_reserve(&j->job.result, (size_t)count) != LOCD_OK) {
            if (lc_proto_skip(c->fd, count * 8, 30000, why, wl) != 1)
                return -1;
            job_done(j, LOCD_ERR_NO_MEMORY, "no memory for the service's result", -1);
            return 0;
        }
        if (count && lc_proto_read_all(c->fd, j->job.result.data, (size_t)count * 8, 30000, why, wl) != 1) {
            job_done(j, LOCD_ERR_CONNECTION, why, -1);
            return -1;
        }
        j->job.result.count = (size_t)count;
        /* Transfer: what the round trip cost beyond the service's own call. */
        st.ms_transfer = lc_now_ms() - j->job.t_submit - st.ms_total;
        if (st.ms_transfer < 0)
            st.ms_transfer = 0;
        j->job.stats = st;
        job_done(j, LOCD_OK, NULL, -1);
        return 0;
    }
    if (count && lc_proto_skip(c->fd, count * 8, 30000, why, wl) != 1)
        return -1;
    if (status >= 0)
        status = LOCD_ERR_PROTOCOL;
    job_done(j, status, msg, index);
    return 0;
}

static void *reader_main(void *arg)
{
    lc_svc_conn *c = arg;
    char why[200] = "connection closed";
    uint8_t hb[LC_PROTO_HEADER];
    lc_msg_header h;
    lc_svc_job *list, *j;
    for (;;) {
        int r = lc_proto_read_all(c->fd, hb, sizeof hb, -1, why, sizeof why);
        if (r != 1)
            break;
        if (lc_proto_get_header(hb, LC_RESULT_MAX_BYTES, &h, why, sizeof why) != 0)
            break;
        if (h.type != LC_MSG_RESULT) {
            snprintf(why, sizeof why, "unexpected message type %u from the service", h.type);
            break;
        }
        j = take_pending(c, h.id);
        if (read_result(c, &h, j, why, sizeof why) != 0)
            break;
    }
    pthread_mutex_lock(&c->mu);
    c->dead = 1;
    snprintf(c->why, sizeof c->why, "%s", why);
    list = c->pending;
    c->pending = NULL;
    pthread_mutex_unlock(&c->mu);
    while ((j = list) != NULL) {
        list = j->next;
        j->next = NULL;
        job_done(j, LOCD_ERR_CONNECTION, c->why, -1);
    }
    return NULL;
}

static int connect_socket(const lc_address *a, char *why, size_t wl)
{
    int fd = -1;
    if (!a->tcp) {
        struct sockaddr_un sa;
        memset(&sa, 0, sizeof sa);
        sa.sun_family = AF_UNIX;
        memcpy(sa.sun_path, a->path, strlen(a->path) + 1);
        fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        if (fd < 0 || connect(fd, (struct sockaddr *)&sa, sizeof sa) != 0) {
            snprintf(why, wl, "cannot connect to unix:%s: %s", a->path, strerror(errno));
            if (fd >= 0)
                close(fd);
            return -1;
        }
    } else {
        struct addrinfo hints, *res = NULL, *ai;
        int rc, one = 1;
        memset(&hints, 0, sizeof hints);
        hints.ai_family = AF_UNSPEC;
        hints.ai_socktype = SOCK_STREAM;
        rc = getaddrinfo(a->host, a->port, &hints, &res);
        if (rc != 0) {
            snprintf(why, wl, "cannot resolve %.100s:%.15s: %.60s", a->host, a->port, gai_strerror(rc));
            return -1;
        }
        snprintf(why, wl, "cannot connect to tcp:%.100s:%.15s", a->host, a->port);
        for (ai = res; ai; ai = ai->ai_next) {
            fd = socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol);
            if (fd < 0)
                continue;
            if (connect(fd, ai->ai_addr, ai->ai_addrlen) == 0)
                break;
            snprintf(why, wl, "cannot connect to tcp:%.100s:%.15s: %.50s", a->host, a->port, strerror(errno));
            close(fd);
            fd = -1;
        }
        freeaddrinfo(res);
        if (fd < 0)
            return -1;
        setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    }
    return fd;
}

/* HELLO -> WELCOME or ERROR. */
static locd_status handshake(lc_svc_conn *c, const char *secret)
{
    size_t slen = secret ? strlen(secret) : 0;
    uint8_t buf[LC_PROTO_HEADER + 4 + LC_PROTO_MAX_SECRET], hb[LC_PROTO_HEADER], pl[8];
    char why[200], msg[LC_PROTO_MAX_TEXT + 1];
    lc_msg_header h;
    uint32_t mlen;
    if (slen > LC_PROTO_MAX_SECRET)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "the secret is longer than %d bytes", LC_PROTO_MAX_SECRET);
    lc_proto_put_header(buf, LC_MSG_HELLO, 0, 4 + slen);
    lc_put_u32(buf + LC_PROTO_HEADER, (uint32_t)slen);
    if (slen)
        memcpy(buf + LC_PROTO_HEADER + 4, secret, slen);
    if (lc_proto_write_all(c->fd, buf, LC_PROTO_HEADER + 4 + slen) != 0)
        return lc_error(LOCD_ERR_CONNECTION, "the service closed the connection: %s", strerror(errno));
    if (lc_proto_read_all(c->fd, hb, sizeof hb, LC_CONNECT_TIMEOUT_MS, why, sizeof why) != 1 ||
        lc_proto_get_header(hb, 8 + LC_PROTO_MAX_TEXT, &h, why, sizeof why) != 0)
        return lc_error(LOCD_ERR_CONNECTION, "no welcome from the service: %s", why);
    if (h.type == LC_MSG_WELCOME && h.length == 4) {
        if (lc_proto_read_all(c->fd, pl, 4, LC_CONNECT_TIMEOUT_MS, why, sizeof why) != 1)
            return lc_error(LOCD_ERR_CONNECTION, "no welcome from the service: %s", why);
        c->shm_ok = lc_get_u32(pl) == 1;
        return LOCD_OK;
    }
    if (h.type == LC_MSG_ERROR && h.length >= 8 &&
        lc_proto_read_all(c->fd, pl, 8, LC_CONNECT_TIMEOUT_MS, why, sizeof why) == 1) {
        int32_t st = (int32_t)lc_get_u32(pl);
        mlen = lc_get_u32(pl + 4);
        if (mlen > LC_PROTO_MAX_TEXT || h.length != 8 + (uint64_t)mlen ||
            lc_proto_read_all(c->fd, msg, mlen, LC_CONNECT_TIMEOUT_MS, why, sizeof why) != 1)
            mlen = 0;
        msg[mlen] = '\0';
        return lc_error(st < 0 ? st : LOCD_ERR_PROTOCOL, "the service refused the connection: %s", msg);
    }
    return lc_error(LOCD_ERR_PROTOCOL, "unexpected answer (type %u) to the handshake", h.type);
}

static locd_status conn_open(const locd_engine *e, lc_svc_conn **out)
{
    lc_svc_conn *c;
    lc_address a;
    char why[200];
    locd_status st;
    *out = NULL;
    if (!lc_proto_host_ok())
        return lc_error(LOCD_ERR_UNSUPPORTED, "level 3 needs a little-endian machine");
    if (lc_proto_parse_address(e->cfg.service_address, &a, why, sizeof why) != 0)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "service_address: %s", why);
    c = lc_alloc(&e->alloc, sizeof *c);
    if (!c)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the connection");
    memset(c, 0, sizeof *c);
    c->alloc = e->alloc;
    c->refs = 1;
    pthread_mutex_init(&c->mu, NULL);
    pthread_mutex_init(&c->wmu, NULL);
    c->fd = connect_socket(&a, why, sizeof why);
    if (c->fd < 0) {
        conn_unref(c);
        return lc_error(LOCD_ERR_CONNECTION, "%s", why);
    }
    if ((st = handshake(c, e->cfg.service_secret)) != LOCD_OK) {
        conn_unref(c);
        return st;
    }
    if (a.tcp)
        c->shm_ok = 0;
    if (pthread_create(&c->reader, NULL, reader_main, c) != 0) {
        conn_unref(c);
        return lc_error(LOCD_ERR_THREAD, "could not start the connection's reader thread");
    }
    *out = c;
    return LOCD_OK;
}

/* Breaks the connection, waits for its reader (which fails pending jobs)
 * and drops the engine's reference. Jobs may still hold the memory. */
static void conn_close(lc_svc_conn *c)
{
    pthread_mutex_lock(&c->wmu);
    shutdown(c->fd, SHUT_RDWR);
    pthread_mutex_unlock(&c->wmu);
    pthread_join(c->reader, NULL);
    pthread_mutex_lock(&c->wmu);
    close(c->fd);
    c->fd = -1;
    pthread_mutex_unlock(&c->wmu);
    conn_unref(c);
}

static int conn_dead(lc_svc_conn *c)
{
    int d;
    pthread_mutex_lock(&c->mu);
    d = c->dead;
    pthread_mutex_unlock(&c->mu);
    return d;
}

static locd_status service_open(locd_engine *e)
{
    lc_svc *s = lc_alloc(&e->alloc, sizeof *s);
    locd_status st;
    if (!s)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the service state");
    memset(s, 0, sizeof *s);
    pthread_mutex_init(&s->mu, NULL);
    if ((st = conn_open(e, &s->conn)) != LOCD_OK) {
        pthread_mutex_destroy(&s->mu);
        lc_free(&e->alloc, s, sizeof *s);
        return st;
    }
    e->backend = s;
    return LOCD_OK;
}

static void service_close(locd_engine *e)
{
    lc_svc *s = e->backend;
    if (!s)
        return;
    if (s->conn)
        conn_close(s->conn);
    pthread_mutex_destroy(&s->mu);
    lc_free(&e->alloc, s, sizeof *s);
    e->backend = NULL;
}

/* The live connection with a reference for the caller, reconnecting once
 * when the last one broke. */
static locd_status get_conn(locd_engine *e, lc_svc_conn **out)
{
    lc_svc *s = e->backend;
    locd_status st = LOCD_OK;
    pthread_mutex_lock(&s->mu);
    if (!s->conn || conn_dead(s->conn)) {
        lc_svc_conn *fresh;
        char why[200] = "not connected";
        if (s->conn) {
            pthread_mutex_lock(&s->conn->mu);
            snprintf(why, sizeof why, "%s", s->conn->why);
            pthread_mutex_unlock(&s->conn->mu);
            conn_close(s->conn);
            s->conn = NULL;
        }
        st = conn_open(e, &fresh);
        if (st == LOCD_OK) {
            s->conn = fresh;
            lc_engine_log(e, LOCD_LOG_WARNING, "level 3: reconnected to %s (last connection: %s)",
                          e->cfg.service_address, why);
        }
    }
    if (st == LOCD_OK) {
        pthread_mutex_lock(&s->conn->mu);
        s->conn->refs++;
        pthread_mutex_unlock(&s->conn->mu);
        *out = s->conn;
    }
    pthread_mutex_unlock(&s->mu);
    return st;
}

/* Puts the boxes in a fresh shm segment; the name goes into j->shm_name. */
static locd_status boxes_to_shm(lc_svc_job *j, const void *boxes, size_t bytes)
{
    static unsigned counter;
    struct timespec ts;
    void *map;
    int fd = -1, tries, rc;
    for (tries = 0; tries < 8 && fd < 0; tries++) {
        clock_gettime(CLOCK_MONOTONIC, &ts);
        snprintf(j->shm_name, sizeof j->shm_name, "%sc%ld-%u-%lx", LC_PROTO_SHM_PREFIX, (long)getpid(),
                 __atomic_add_fetch(&counter, 1u, __ATOMIC_RELAXED), (unsigned long)ts.tv_nsec);
        fd = shm_open(j->shm_name, O_RDWR | O_CREAT | O_EXCL, 0600);
        if (fd < 0 && errno != EEXIST)
            break;
    }
    if (fd < 0) {
        j->shm_name[0] = '\0';
        return lc_error(LOCD_ERR_IO, "shm_open: %s", strerror(errno));
    }
    if (ftruncate(fd, (off_t)bytes) != 0 ||
        ((rc = posix_fallocate(fd, 0, (off_t)bytes)) != 0 && rc != EINVAL && rc != EOPNOTSUPP) ||
        (map = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0)) == MAP_FAILED) {
        close(fd);
        shm_unlink(j->shm_name);
        j->shm_name[0] = '\0';
        return lc_error(LOCD_ERR_IO, "shared memory for %zu bytes of boxes failed", bytes);
    }
    close(fd);
    memcpy(map, boxes, bytes);
    munmap(map, bytes);
    return LOCD_OK;
}

/* Sends the SUBMIT message of job j: f, then the segment name or the
 * boxes themselves. */
static locd_status send_submit(lc_svc_conn *c, lc_svc_job *j, lc_submit_fixed *f, const void *boxes, size_t bytes)
{
    uint8_t buf[LC_PROTO_HEADER + LC_PROTO_SUBMIT_FIXED + 4 + 64];
    char name[sizeof j->shm_name];
    size_t nl, len;
    int rc;
    /* The reader thread may fail the job (and clear its segment name) as
       soon as it is registered: read the name under the job's lock. */
    pthread_mutex_lock(&j->job.mu);
    memcpy(name, j->shm_name, sizeof name);
    pthread_mutex_unlock(&j->job.mu);
    name[sizeof name - 1] = '\0';
    nl = name[0] ? strlen(name) : 0;
    f->transport = nl ? 1u : 0u;
    len = LC_PROTO_SUBMIT_FIXED + (nl ? 4 + nl : bytes);
    lc_proto_put_header(buf, LC_MSG_SUBMIT, j->id, len);
    lc_proto_put_submit(buf + LC_PROTO_HEADER, f);
    pthread_mutex_lock(&c->wmu);
    if (c->fd < 0) {
        rc = -1;
    } else if (nl) {
        lc_put_u32(buf + LC_PROTO_HEADER + LC_PROTO_SUBMIT_FIXED, (uint32_t)nl);
        memcpy(buf + LC_PROTO_HEADER + LC_PROTO_SUBMIT_FIXED + 4, name, nl);
        rc = lc_proto_write_all(c->fd, buf, LC_PROTO_HEADER + len);
    } else {
        rc = lc_proto_write_all(c->fd, buf, LC_PROTO_HEADER + LC_PROTO_SUBMIT_FIXED);
        if (!rc && bytes)
            rc = lc_proto_write_all(c->fd, boxes, bytes);
    }
    if (rc)
        shutdown(c->fd, SHUT_RDWR); /* half a message was sent: the stream is unusable */
    pthread_mutex_unlock(&c->wmu);
    return rc ? lc_error(LOCD_ERR_CONNECTION, "the service connection broke while sending") : LOCD_OK;
}

/* lc_job_ops.cancel: asks the service to drop the job. */
static void svc_job_cancel(locd_job *job)
{
    lc_svc_job *j = (lc_svc_job *)job;
    lc_svc_conn *c = j->conn;
    uint8_t hb[LC_PROTO_HEADER];
    if (!c)
        return;
    lc_proto_put_header(hb, LC_MSG_CANCEL, j->id, 0);
    pthread_mutex_lock(&c->wmu);
    if (c->fd >= 0 && lc_proto_write_all(c->fd, hb, sizeof hb) != 0)
        shutdown(c->fd, SHUT_RDWR);
    pthread_mutex_unlock(&c->wmu);
}

/* lc_job_ops.released: the caller let go of the job. Its input segment
 * can go once the job is finished (the reader removes it otherwise), and
 * the job's reference on the connection goes now, on the caller's thread:
 * dropped by the reader, the last one would free the connection under it. */
static void svc_job_released(locd_job *job)
{
    lc_svc_job *j = (lc_svc_job *)job;
    lc_svc_conn *c = j->conn;
    pthread_mutex_lock(&job->mu);
    if (j->shm_name[0] && job->status != LOCD_PENDING) {
        shm_unlink(j->shm_name);
        j->shm_name[0] = '\0';
    }
    pthread_mutex_unlock(&job->mu);
    j->conn = NULL;
    if (c)
        conn_unref(c);
}

/* lc_job_ops.free: a job discarded before it was sent still names its
 * segment. */
static void svc_job_free(locd_job *job)
{
    lc_svc_job *j = (lc_svc_job *)job;
    if (j->shm_name[0])
        shm_unlink(j->shm_name);
}

static const lc_job_ops svc_job_ops = {sizeof(lc_svc_job), svc_job_cancel, svc_job_released, svc_job_free};

/* Puts j on the connection's pending list under a fresh id, unless the
 * connection is already closed. */
static locd_status register_job(lc_svc_conn *c, lc_svc_job *j)
{
    pthread_mutex_lock(&c->mu);
    if (c->dead) {
        pthread_mutex_unlock(&c->mu);
        return lc_error(LOCD_ERR_CONNECTION, "the service connection is closed");
    }
    j->id = ++c->next_id;
    j->next = c->pending;
    c->pending = j;
    pthread_mutex_unlock(&c->mu);
    return LOCD_OK;
}

static locd_status service_submit(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags,
                                  locd_job **out)
{
    size_t bytes = n * 6 * (f64 ? sizeof(double) : sizeof(float));
    lc_submit_fixed f;
    lc_svc_conn *c;
    lc_svc_job *j;
    locd_job *job;
    locd_status st;
    if ((st = get_conn(e, &c)) != LOCD_OK)
        return st;
    if ((st = lc_job_new(&e->alloc, &svc_job_ops, &job)) != LOCD_OK) {
        conn_unref(c);
        return st;
    }
    j = (lc_svc_job *)job;
    j->conn = c; /* the job keeps the caller's reference on c */
    if ((c->shm_ok && bytes >= LC_PROTO_SHM_MIN_BYTES && (st = boxes_to_shm(j, boxes, bytes)) != LOCD_OK) ||
        (st = register_job(c, j)) != LOCD_OK) {
        lc_job_discard(job);
        return st;
    }
    f.flags = flags;
    f.f64 = (uint32_t)f64;
    f.n = n;
    f.max_depth = e->cfg.max_depth;
    f.cell_bias = e->cfg.cell_bias;
    f.config_flags = e->cfg.flags;
    if ((st = send_submit(c, j, &f, boxes, bytes)) != LOCD_OK) {
        lc_svc_job *mine = take_pending(c, j->id);
        if (mine)
            job_done(mine, st, locd_last_error(), -1);
        svc_job_released(job);
        lc_job_unref(job);
        return lc_error(LOCD_ERR_CONNECTION, "the service connection broke while sending the job");
    }
    *out = job;
    return LOCD_OK;
}

static locd_status service_find(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags,
                                locd_pairs *out, locd_stats *stats)
{
    locd_job *j;
    locd_status st = service_submit(e, boxes, n, f64, flags, &j);
    if (st)
        return st;
    st = locd_job_wait(j, -1);
    if (!st) {
        /* The job is finished: nobody else touches its buffer. Swap it with
           out (same allocator: both belong to the engine's caller... or not:
           copy to be safe). */
        st = lc_pairs_reserve(out, j->result.count);
        if (!st) {
            if (j->result.count)
                memcpy(out->data, j->result.data, j->result.count * 2 * sizeof(uint32_t));
            out->count = j->result.count;
            *stats = j->stats;
        }
    }
    if (st) {
        char msg[256];
        int64_t idx = locd_last_error_index();
        snprintf(msg, sizeof msg, "%s", locd_last_error());
        locd_job_release(j);
        return lc_error_box(st, idx, "%s", msg + (strchr(msg, ':') ? (size_t)(strchr(msg, ':') - msg) + 2 : 0));
    }
    locd_job_release(j);
    return LOCD_OK;
}

const lc_backend lc_service_backend = {"service", service_open, service_close, service_find, service_submit};
