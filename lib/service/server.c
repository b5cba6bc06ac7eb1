/* Integration level 3, server side (what `locd serve` runs).
 *
 * One accept loop; one thread per connection reading its messages; a fixed
 * set of runner threads, each with its own level-1 engine, taking jobs from
 * one FIFO queue and writing each result back on its connection. Every
 * message is checked before anything is allocated for it (magic, version,
 * type, length limit, payload consistency); a bad one drops that connection
 * with a logged reason and nobody else notices. A message that starts must
 * finish within LC_MSG_TIMEOUT_MS. A connection that goes away cancels its
 * jobs: queued ones are dropped unrun, running ones are discarded when they
 * end. Memory is bounded by max_clients x max_jobs x max_message. */
#define _GNU_SOURCE /* struct ucred, SO_PEERCRED */
#include "service/service.h"

#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <sys/un.h>
#include <unistd.h>

#define LC_MSG_TIMEOUT_MS 30000
#define LC_HELLO_TIMEOUT_MS 5000

typedef struct srv_conn srv_conn;

typedef struct srv_job {
    struct srv_job *qnext;        /* run queue */
    struct srv_job *cnext, *cprev; /* the connection's jobs */
    srv_conn *c;
    uint64_t id;
    int cancelled;
    lc_submit_fixed f;
    void *boxes;
    size_t bytes;
    int mapped; /* boxes is an mmap of the client's segment */
} srv_job;

struct srv_conn {
    locd_service *s;
    int fd;
    int refs;   /* under s->mu: the connection thread + each job */
    int closed; /* under wmu: no more writes */
    pthread_mutex_t wmu;
    srv_job *jobs; /* under s->mu */
    uint32_t njobs;
    int shm_ok;
    char peer[96];
    srv_conn *next; /* s->conns */
};

struct locd_service {
    uint32_t magic;
    locd_service_config cfg;
    char *secret;
    char address[300];
    char unix_path[108];
    int lfd;
    int wake[2];
    pthread_mutex_t mu;
    pthread_cond_t cv;       /* queue not empty / stopping */
    pthread_cond_t conns_cv; /* a connection ended */
    srv_job *qhead, *qtail;
    srv_conn *conns;
    uint32_t nconns;
    int stopping;
    pthread_t *runners;
    uint32_t nrunners;
    uint64_t served;
};

static void slog(const locd_service *s, int32_t sev, const char *fmt, ...) LC_PRINTF(3, 4);
static void slog(const locd_service *s, int32_t sev, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    lc_log_emit(s->cfg.log, s->cfg.log_user, sev, fmt, ap);
    va_end(ap);
}

void locd_service_config_init(locd_service_config *config)
{
    if (!config)
        return;
    memset(config, 0, sizeof *config);
    config->size = sizeof *config;
}

/* ---- jobs and connections ---- */

static void job_free(srv_job *j)
{
    if (j->boxes) {
        if (j->mapped)
            munmap(j->boxes, j->bytes);
        else
            free(j->boxes);
    }
    free(j);
}

/* Under s->mu. */
static void conn_unref_locked(srv_conn *c)
{
    if (--c->refs == 0) {
        pthread_mutex_destroy(&c->wmu);
        free(c);
    }
}

/* Detaches a finished job from its connection and frees it. */
static void job_retire(locd_service *s, srv_job *j)
{
    srv_conn *c = j->c;
    pthread_mutex_lock(&s->mu);
    if (j->cprev)
        j->cprev->cnext = j->cnext;
    else
        c->jobs = j->cnext;
    if (j->cnext)
        j->cnext->cprev = j->cprev;
    c->njobs--;
    conn_unref_locked(c);
    pthread_mutex_unlock(&s->mu);
    job_free(j);
}

static int conn_send(srv_conn *c, const void *a, size_t alen, const void *b, size_t blen)
{
    int rc = -1;
    pthread_mutex_lock(&c->wmu);
    if (!c->closed) {
        rc = lc_proto_write_all(c->fd, a, alen);
        if (!rc && blen)
            rc = lc_proto_write_all(c->fd, b, blen);
        if (rc)
            shutdown(c->fd, SHUT_RDWR); /* the reader thread notices and cleans up */
    }
    pthread_mutex_unlock(&c->wmu);
    return rc;
}

static void send_result(srv_conn *c, uint64_t id, locd_status st, const char *msg, int64_t index,
                        const locd_stats *stats, const uint32_t *pairs, size_t count)
{
    uint8_t buf[LC_PROTO_HEADER + 16 + LC_PROTO_MAX_TEXT + LC_PROTO_STATS_BYTES + 8];
    size_t mlen = msg ? strlen(msg) : 0, off;
    locd_stats empty;
    if (mlen > LC_PROTO_MAX_TEXT)
        mlen = LC_PROTO_MAX_TEXT;
    if (!stats) {
        locd_stats_init(&empty);
        stats = &empty;
    }
    lc_proto_put_header(buf, LC_MSG_RESULT, id, 16 + mlen + LC_PROTO_STATS_BYTES + 8 + (uint64_t)count * 8);
    off = LC_PROTO_HEADER;
    lc_put_u32(buf + off, (uint32_t)st);
    lc_put_u64(buf + off + 4, (uint64_t)index);
    lc_put_u32(buf + off + 12, (uint32_t)mlen);
    off += 16;
    if (mlen)
        memcpy(buf + off, msg, mlen);
    off += mlen;
    lc_proto_put_stats(buf + off, stats);
    off += LC_PROTO_STATS_BYTES;
    lc_put_u64(buf + off, count);
    off += 8;
    conn_send(c, buf, off, pairs, count * 8);
}

static void send_error(int fd, locd_status st, const char *msg)
{
    uint8_t buf[LC_PROTO_HEADER + 8 + LC_PROTO_MAX_TEXT];
    size_t mlen = strlen(msg);
    if (mlen > LC_PROTO_MAX_TEXT)
        mlen = LC_PROTO_MAX_TEXT;
    lc_proto_put_header(buf, LC_MSG_ERROR, 0, 8 + mlen);
    lc_put_u32(buf + LC_PROTO_HEADER, (uint32_t)st);
    lc_put_u32(buf + LC_PROTO_HEADER + 4, (uint32_t)mlen);
    memcpy(buf + LC_PROTO_HEADER + 8, msg, mlen);
    lc_proto_write_all(fd, buf, LC_PROTO_HEADER + 8 + mlen);
}

/* ---- runners ---- */

typedef struct runner {
    locd_service *s;
    locd_engine *engine;
    lc_submit_fixed cfg; /* the config the engine was made with */
    locd_pairs *pairs;
} runner;

static locd_status runner_engine(runner *r, const lc_submit_fixed *f)
{
    locd_engine_config cfg;
    if (r->engine && r->cfg.max_depth == f->max_depth && r->cfg.cell_bias == f->cell_bias &&
        r->cfg.config_flags == f->config_flags)
        return LOCD_OK;
    locd_engine_destroy(r->engine);
    r->engine = NULL;
    locd_engine_config_init(&cfg);
    cfg.level = LOCD_LEVEL_INPROCESS;
    cfg.threads = r->s->cfg.engine_threads ? r->s->cfg.engine_threads : 1;
    cfg.max_depth = f->max_depth;
    cfg.cell_bias = f->cell_bias;
    cfg.flags = f->config_flags;
    r->cfg = *f;
    return locd_engine_create(&cfg, &r->engine);
}

static void run_job(runner *r, srv_job *j)
{
    locd_stats st;
    locd_status rc;
    if (__atomic_load_n(&j->cancelled, __ATOMIC_ACQUIRE)) {
        send_result(j->c, j->id, LOCD_ERR_CANCELLED, "cancelled", -1, NULL, NULL, 0);
        return;
    }
    rc = runner_engine(r, &j->f);
    if (!rc)
        rc = j->f.f64 ? locd_engine_find_pairs_f64(r->engine, j->boxes, (size_t)j->f.n, j->f.flags, r->pairs)
                      : locd_engine_find_pairs_f32(r->engine, j->boxes, (size_t)j->f.n, j->f.flags, r->pairs);
    if (rc) {
        send_result(j->c, j->id, rc, locd_last_error(), locd_last_error_index(), NULL, NULL, 0);
        return;
    }
    if (__atomic_load_n(&j->cancelled, __ATOMIC_ACQUIRE)) { /* cancelled while running: dropped */
        send_result(j->c, j->id, LOCD_ERR_CANCELLED, "cancelled", -1, NULL, NULL, 0);
        return;
    }
    locd_stats_init(&st);
    locd_engine_stats(r->engine, &st);
    send_result(j->c, j->id, LOCD_OK, NULL, -1, &st, locd_pairs_data(r->pairs), locd_pairs_count(r->pairs));
}

static void *runner_main(void *arg)
{
    runner r;
    locd_service *s = arg;
    srv_job *j;
    memset(&r, 0, sizeof r);
    r.s = s;
    if (locd_pairs_create(NULL, &r.pairs) != LOCD_OK)
        return NULL;
    for (;;) {
        pthread_mutex_lock(&s->mu);
        while (!s->qhead && !s->stopping)
            pthread_cond_wait(&s->cv, &s->mu);
        j = s->qhead;
        if (!j) {
            pthread_mutex_unlock(&s->mu);
            break;
        }
        s->qhead = j->qnext;
        if (!s->qhead)
            s->qtail = NULL;
        pthread_mutex_unlock(&s->mu);
        run_job(&r, j);
        job_retire(s, j);
        pthread_mutex_lock(&s->mu);
        s->served++;
        pthread_mutex_unlock(&s->mu);
    }
    locd_engine_destroy(r.engine);
    locd_pairs_destroy(r.pairs);
    return NULL;
}

/* ---- reading a connection ---- */

static int valid_shm_name(const char *n)
{
    size_t i, p = strlen(LC_PROTO_SHM_PREFIX);
    if (strncmp(n, LC_PROTO_SHM_PREFIX, p) != 0 || strlen(n) > 60)
        return 0;
    for (i = p; n[i]; i++)
        if (!((n[i] >= 'a' && n[i] <= 'z') || (n[i] >= 'A' && n[i] <= 'Z') || (n[i] >= '0' && n[i] <= '9') ||
              n[i] == '-'))
            return 0;
    return 1;
}

/* Maps the client's segment, then removes its name: the service is the
 * last party to open it. */
static int map_client_segment(srv_job *j, const char *name, char *why, size_t wl)
{
    struct stat sb;
    int fd = shm_open(name, O_RDONLY, 0);
    if (fd < 0) {
        snprintf(why, wl, "cannot open the job's segment %s: %s", name, strerror(errno));
        return -1;
    }
    shm_unlink(name);
    if (fstat(fd, &sb) != 0 || sb.st_uid != geteuid() || (uint64_t)sb.st_size != (uint64_t)j->bytes) {
        close(fd);
        snprintf(why, wl, "segment %s has the wrong owner or size", name);
        return -1;
    }
    if (j->bytes) {
        j->boxes = mmap(NULL, j->bytes, PROT_READ, MAP_SHARED, fd, 0);
        if (j->boxes == MAP_FAILED) {
            j->boxes = NULL;
            close(fd);
            snprintf(why, wl, "cannot map segment %s", name);
            return -1;
        }
        j->mapped = 1;
    }
    close(fd);
    return 0;
}

/* Reads a SUBMIT payload. Returns 0 and a job, 1 when the job is refused
 * but the connection is fine (an error result was sent), -1 to drop. */
static int read_submit(srv_conn *c, const lc_msg_header *h, srv_job **out, char *why, size_t wl)
{
    locd_service *s = c->s;
    uint8_t fixed[LC_PROTO_SUBMIT_FIXED];
    srv_job *j;
    size_t es;
    uint64_t bytes;
    *out = NULL;
    if (h->length < LC_PROTO_SUBMIT_FIXED) {
        snprintf(why, wl, "short SUBMIT message");
        return -1;
    }
    if (lc_proto_read_all(c->fd, fixed, sizeof fixed, LC_MSG_TIMEOUT_MS, why, wl) != 1)
        return -1;
    j = calloc(1, sizeof *j);
    if (!j) {
        snprintf(why, wl, "out of memory");
        return -1;
    }
    j->id = h->id;
    lc_proto_get_submit(fixed, &j->f);
    es = j->f.f64 ? sizeof(double) : sizeof(float);
    if (j->f.f64 > 1 || j->f.transport > 1 || j->f.n > (uint64_t)UINT32_MAX + 1u ||
        j->f.n > s->cfg.max_message / (6 * es) + 1) {
        snprintf(why, wl, "bad SUBMIT header (n %llu, f64 %u, transport %u)", (unsigned long long)j->f.n, j->f.f64,
                 j->f.transport);
        free(j);
        return -1;
    }
    bytes = j->f.n * 6 * es;
    j->bytes = (size_t)bytes;
    if (j->f.transport == 0) {
        if (h->length != LC_PROTO_SUBMIT_FIXED + bytes) {
            snprintf(why, wl, "SUBMIT length %llu does not match %llu boxes", (unsigned long long)h->length,
                     (unsigned long long)j->f.n);
            free(j);
            return -1;
        }
        j->boxes = malloc(bytes ? (size_t)bytes : 1);
        if (!j->boxes) {
            snprintf(why, wl, "out of memory for %llu bytes", (unsigned long long)bytes);
            free(j);
            return -1;
        }
        if (bytes && lc_proto_read_all(c->fd, j->boxes, (size_t)bytes, LC_MSG_TIMEOUT_MS, why, wl) != 1) {
            job_free(j);
            return -1;
        }
    } else {
        uint8_t nl[4];
        char name[LC_PROTO_MAX_TEXT + 1];
        uint32_t len;
        if (!c->shm_ok) {
            snprintf(why, wl, "shared-memory SUBMIT on a connection that may not use it");
            free(j);
            return -1;
        }
        if (lc_proto_read_all(c->fd, nl, 4, LC_MSG_TIMEOUT_MS, why, wl) != 1) {
            free(j);
            return -1;
        }
        len = lc_get_u32(nl);
        if (len > 64 || h->length != LC_PROTO_SUBMIT_FIXED + 4 + (uint64_t)len ||
            lc_proto_read_all(c->fd, name, len, LC_MSG_TIMEOUT_MS, why, wl) != 1) {
            if (len > 64 || h->length != LC_PROTO_SUBMIT_FIXED + 4 + (uint64_t)len)
                snprintf(why, wl, "bad segment name in SUBMIT");
            free(j);
            return -1;
        }
        name[len] = '\0';
        if (!valid_shm_name(name)) {
            snprintf(why, wl, "segment name '%s' is not a locd segment", name);
            free(j);
            return -1;
        }
        if (map_client_segment(j, name, why, wl) != 0) {
            /* The client's problem (or a cancelled job): answer, keep serving. */
            send_result(c, j->id, LOCD_ERR_IO, why, -1, NULL, NULL, 0);
            job_free(j);
            return 1;
        }
    }
    *out = j;
    return 0;
}

static int enqueue(srv_conn *c, srv_job *j, char *why, size_t wl)
{
    locd_service *s = c->s;
    pthread_mutex_lock(&s->mu);
    if (c->njobs >= s->cfg.max_jobs) {
        pthread_mutex_unlock(&s->mu);
        snprintf(why, wl, "more than %u jobs in flight", s->cfg.max_jobs);
        return -1;
    }
    j->c = c;
    c->refs++;
    c->njobs++;
    j->cnext = c->jobs;
    if (c->jobs)
        c->jobs->cprev = j;
    c->jobs = j;
    if (s->qtail)
        s->qtail->qnext = j;
    else
        s->qhead = j;
    s->qtail = j;
    pthread_cond_signal(&s->cv);
    pthread_mutex_unlock(&s->mu);
    return 0;
}

static void cancel_job(srv_conn *c, uint64_t id)
{
    srv_job *j;
    pthread_mutex_lock(&c->s->mu);
    for (j = c->jobs; j; j = j->cnext)
        if (j->id == id)
            __atomic_store_n(&j->cancelled, 1, __ATOMIC_RELEASE);
    pthread_mutex_unlock(&c->s->mu);
}

/* HELLO: the secret, when the service has one. */
static int read_hello(srv_conn *c, char *why, size_t wl)
{
    locd_service *s = c->s;
    uint8_t hb[LC_PROTO_HEADER], pl[4 + LC_PROTO_MAX_SECRET], reply[LC_PROTO_HEADER + 4];
    lc_msg_header h;
    uint32_t slen;
    int r = lc_proto_read_all(c->fd, hb, sizeof hb, LC_HELLO_TIMEOUT_MS, why, wl);
    if (r != 1)
        return -1;
    if (lc_proto_get_header(hb, 4 + LC_PROTO_MAX_SECRET, &h, why, wl) != 0)
        return -1;
    if (h.type != LC_MSG_HELLO || h.length < 4) {
        snprintf(why, wl, "expected HELLO, got message type %u", h.type);
        return -1;
    }
    if (lc_proto_read_all(c->fd, pl, (size_t)h.length, LC_HELLO_TIMEOUT_MS, why, wl) != 1)
        return -1;
    slen = lc_get_u32(pl);
    if ((uint64_t)slen + 4 != h.length) {
        snprintf(why, wl, "malformed HELLO");
        return -1;
    }
    if (s->secret && !lc_proto_secret_equal(s->secret, strlen(s->secret), (const char *)pl + 4, slen)) {
        snprintf(why, wl, "%s", slen ? "wrong secret" : "no secret given");
        send_error(c->fd, LOCD_ERR_AUTH, "a valid shared secret is required");
        return -1;
    }
    lc_proto_put_header(reply, LC_MSG_WELCOME, 0, 4);
    lc_put_u32(reply + LC_PROTO_HEADER, (uint32_t)c->shm_ok);
    return conn_send(c, reply, sizeof reply, NULL, 0) ? (snprintf(why, wl, "write failed"), -1) : 0;
}

static void serve_connection(srv_conn *c)
{
    locd_service *s = c->s;
    char why[300] = "";
    uint8_t hb[LC_PROTO_HEADER];
    lc_msg_header h;
    int r;
    if (read_hello(c, why, sizeof why) != 0) {
        slog(s, LOCD_LOG_WARNING, "dropping connection from %s: %s", c->peer, why);
        return;
    }
    slog(s, LOCD_LOG_DEBUG, "client %s connected", c->peer);
    for (;;) {
        srv_job *j;
        r = lc_proto_read_all(c->fd, hb, 1, -1, why, sizeof why); /* idle clients may wait forever */
        if (r == 1)
            r = lc_proto_read_all(c->fd, hb + 1, sizeof hb - 1, LC_MSG_TIMEOUT_MS, why, sizeof why);
        if (r == 0) {
            slog(s, LOCD_LOG_DEBUG, "client %s disconnected", c->peer);
            return;
        }
        if (r < 0 || lc_proto_get_header(hb, s->cfg.max_message, &h, why, sizeof why) != 0)
            break;
        if (h.type == LC_MSG_SUBMIT) {
            r = read_submit(c, &h, &j, why, sizeof why);
            if (r < 0 || (r == 0 && enqueue(c, j, why, sizeof why) != 0)) {
                if (r == 0)
                    job_free(j);
                break;
            }
        } else if (h.type == LC_MSG_CANCEL && h.length == 0) {
            cancel_job(c, h.id);
        } else {
            snprintf(why, sizeof why, "unexpected message type %u (length %llu)", h.type,
                     (unsigned long long)h.length);
            break;
        }
    }
    slog(s, LOCD_LOG_WARNING, "dropping connection from %s: %s", c->peer, why);
}

static void *conn_main(void *arg)
{
    srv_conn *c = arg;
    locd_service *s = c->s;
    srv_conn **pp;
    srv_job *j;
    serve_connection(c);
    /* No more writes; cancel what is left (runners discard it). */
    pthread_mutex_lock(&c->wmu);
    c->closed = 1;
    shutdown(c->fd, SHUT_RDWR);
    close(c->fd);
    c->fd = -1;
    pthread_mutex_unlock(&c->wmu);
    pthread_mutex_lock(&s->mu);
    for (j = c->jobs; j; j = j->cnext)
        __atomic_store_n(&j->cancelled, 1, __ATOMIC_RELEASE);
    for (pp = &s->conns; *pp; pp = &(*pp)->next)
        if (*pp == c) {
            *pp = c->next;
            break;
        }
    s->nconns--;
    conn_unref_locked(c);
    pthread_cond_broadcast(&s->conns_cv);
    pthread_mutex_unlock(&s->mu);
    return NULL;
}

/* ---- listening ---- */

static locd_status private_dir(const char *path)
{
    char dir[108];
    char *slash;
    struct stat sb;
    snprintf(dir, sizeof dir, "%s", path);
    slash = strrchr(dir, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else if (slash == dir)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "put the socket in a private directory, not in /");
    else
        *slash = '\0';
    if (stat(dir, &sb) != 0) {
        if (errno != ENOENT || mkdir(dir, 0700) != 0 || stat(dir, &sb) != 0)
            return lc_error(LOCD_ERR_IO, "cannot create the socket directory %s: %s", dir, strerror(errno));
    }
    if (!S_ISDIR(sb.st_mode) || sb.st_uid != geteuid() || (sb.st_mode & 077))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT,
                        "the socket directory %s must belong to this user with mode 0700 (others could connect)",
                        dir);
    return LOCD_OK;
}

static locd_status listen_unix(locd_service *s, const char *path)
{
    struct sockaddr_un sa;
    struct stat sb;
    locd_status st;
    int fd;
    if ((st = private_dir(path)) != LOCD_OK)
        return st;
    memset(&sa, 0, sizeof sa);
    sa.sun_family = AF_UNIX;
    memcpy(sa.sun_path, path, strlen(path) + 1);
    if (lstat(path, &sb) == 0) {
        /* A leftover socket of a dead service is replaced; a live one is not. */
        int probe;
        if (!S_ISSOCK(sb.st_mode))
            return lc_error(LOCD_ERR_IO, "%s exists and is not a socket", path);
        probe = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        if (probe >= 0 && connect(probe, (struct sockaddr *)&sa, sizeof sa) == 0) {
            close(probe);
            return lc_error(LOCD_ERR_IO, "a service is already listening on %s", path);
        }
        if (probe >= 0)
            close(probe);
        unlink(path);
    }
    fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0 || bind(fd, (struct sockaddr *)&sa, sizeof sa) != 0 || chmod(path, 0600) != 0 || listen(fd, 128) != 0) {
        int err = errno;
        if (fd >= 0)
            close(fd);
        return lc_error(LOCD_ERR_IO, "cannot listen on unix:%s: %s", path, strerror(err));
    }
    s->lfd = fd;
    snprintf(s->unix_path, sizeof s->unix_path, "%s", path);
    snprintf(s->address, sizeof s->address, "unix:%s", path);
    return LOCD_OK;
}

static locd_status listen_tcp(locd_service *s, const lc_address *a)
{
    struct addrinfo hints, *res = NULL, *ai;
    struct sockaddr_storage ss;
    socklen_t sl = sizeof ss;
    char host[NI_MAXHOST], port[NI_MAXSERV];
    int fd = -1, one = 1, rc;
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_PASSIVE;
    if ((rc = getaddrinfo(a->host, a->port, &hints, &res)) != 0)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "tcp:%s:%s: %s", a->host, a->port, gai_strerror(rc));
    for (ai = res; ai; ai = ai->ai_next) {
        fd = socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol);
        if (fd < 0)
            continue;
        setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
        if (bind(fd, ai->ai_addr, ai->ai_addrlen) == 0 && listen(fd, 128) == 0)
            break;
        close(fd);
        fd = -1;
    }
    freeaddrinfo(res);
    if (fd < 0)
        return lc_error(LOCD_ERR_IO, "cannot listen on tcp:%s:%s: %s", a->host, a->port, strerror(errno));
    getsockname(fd, (struct sockaddr *)&ss, &sl);
    getnameinfo((struct sockaddr *)&ss, sl, host, sizeof host, port, sizeof port, NI_NUMERICHOST | NI_NUMERICSERV);
    s->lfd = fd;
    snprintf(s->address, sizeof s->address, "tcp:%.200s:%.16s", host, port);
    return LOCD_OK;
}

locd_status locd_service_create(const locd_service_config *config, locd_service **out)
{
    locd_service_config cfg;
    locd_service *s;
    lc_address a;
    char why[200], def[108];
    locd_status st;
    uint32_t i;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    locd_service_config_init(&cfg);
    if (config) {
        if (config->size < 2 * sizeof(uint32_t) || config->size > sizeof cfg)
            return lc_error(LOCD_ERR_INVALID_ARGUMENT, "config->size is %u; use locd_service_config_init()",
                            config->size);
        memcpy(&cfg, config, config->size);
        cfg.size = sizeof cfg;
    }
    if (!cfg.listen) {
        const char *xdg = getenv("XDG_RUNTIME_DIR");
        if (xdg && xdg[0] && strlen(xdg) < 80)
            snprintf(def, sizeof def, "unix:%s/locd/locd.sock", xdg);
        else
            snprintf(def, sizeof def, "unix:/tmp/locd-%ld/locd.sock", (long)geteuid());
        cfg.listen = def;
    }
    if (lc_proto_parse_address(cfg.listen, &a, why, sizeof why) != 0)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "listen: %s", why);
    if (a.tcp && (!cfg.secret || !cfg.secret[0]))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "a TCP service needs a shared secret (--secret)");
    if (cfg.secret && strlen(cfg.secret) > LC_PROTO_MAX_SECRET)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "the secret is longer than %d bytes", LC_PROTO_MAX_SECRET);
    if (!lc_proto_host_ok())
        return lc_error(LOCD_ERR_UNSUPPORTED, "the service needs a little-endian machine");
    if (!cfg.threads)
        cfg.threads = lc_cpu_count();
    if (cfg.threads > 256)
        cfg.threads = 256;
    if (!cfg.max_message)
        cfg.max_message = 1ull << 30;
    if (!cfg.max_clients)
        cfg.max_clients = 256;
    if (!cfg.max_jobs)
        cfg.max_jobs = 1024;
    s = calloc(1, sizeof *s);
    if (!s)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the service");
    s->cfg = cfg;
    s->lfd = -1;
    s->wake[0] = s->wake[1] = -1;
    if (cfg.secret && !(s->secret = strdup(cfg.secret))) {
        free(s);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not copy the secret");
    }
    s->cfg.secret = s->secret;
    s->cfg.listen = NULL;
    pthread_mutex_init(&s->mu, NULL);
    pthread_cond_init(&s->cv, NULL);
    pthread_cond_init(&s->conns_cv, NULL);
    s->magic = LC_MAGIC_SERVICE;
    st = a.tcp ? listen_tcp(s, &a) : listen_unix(s, a.path);
    if (!st && pipe(s->wake) != 0)
        st = lc_error(LOCD_ERR_IO, "pipe: %s", strerror(errno));
    if (!st) {
        fcntl(s->wake[0], F_SETFD, FD_CLOEXEC);
        fcntl(s->wake[1], F_SETFD, FD_CLOEXEC);
        fcntl(s->wake[1], F_SETFL, O_NONBLOCK);
        s->runners = calloc(cfg.threads, sizeof *s->runners);
        if (!s->runners)
            st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the runners");
    }
    for (i = 0; !st && i < cfg.threads; i++) {
        if (pthread_create(&s->runners[i], NULL, runner_main, s) != 0)
            st = lc_error(LOCD_ERR_THREAD, "could not start runner %u", i);
        else
            s->nrunners++;
    }
    if (st) {
        locd_service_destroy(s);
        return st;
    }
    *out = s;
    lc_clear_error();
    return LOCD_OK;
}

const char *locd_service_address(const locd_service *s)
{
    return (s && s->magic == LC_MAGIC_SERVICE) ? s->address : "";
}

static void peer_name(srv_conn *c, const struct sockaddr_storage *ss, socklen_t sl, int is_unix)
{
    if (is_unix) {
        struct ucred cr;
        socklen_t cl = sizeof cr;
        if (getsockopt(c->fd, SOL_SOCKET, SO_PEERCRED, &cr, &cl) == 0) {
            snprintf(c->peer, sizeof c->peer, "pid %ld (uid %ld)", (long)cr.pid, (long)cr.uid);
            c->shm_ok = cr.uid == geteuid();
        } else {
            snprintf(c->peer, sizeof c->peer, "a local client");
        }
    } else {
        char host[NI_MAXHOST], port[NI_MAXSERV];
        if (getnameinfo((const struct sockaddr *)ss, sl, host, sizeof host, port, sizeof port,
                        NI_NUMERICHOST | NI_NUMERICSERV) == 0)
            snprintf(c->peer, sizeof c->peer, "%.60s:%.16s", host, port);
        else
            snprintf(c->peer, sizeof c->peer, "a TCP client");
    }
}

static void accept_one(locd_service *s)
{
    struct sockaddr_storage ss;
    socklen_t sl = sizeof ss;
    pthread_attr_t attr;
    pthread_t th;
    srv_conn *c;
    int fd = accept(s->lfd, (struct sockaddr *)&ss, &sl), one = 1;
    if (fd < 0)
        return;
    fcntl(fd, F_SETFD, FD_CLOEXEC);
    pthread_mutex_lock(&s->mu);
    if (s->nconns >= s->cfg.max_clients) {
        pthread_mutex_unlock(&s->mu);
        slog(s, LOCD_LOG_WARNING, "refusing a connection: %u clients already", s->cfg.max_clients);
        send_error(fd, LOCD_ERR_BUSY, "too many clients");
        close(fd);
        return;
    }
    pthread_mutex_unlock(&s->mu);
    c = calloc(1, sizeof *c);
    if (!c) {
        close(fd);
        return;
    }
    c->s = s;
    c->fd = fd;
    c->refs = 1;
    pthread_mutex_init(&c->wmu, NULL);
    if (ss.ss_family != AF_UNIX)
        setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    {
        /* A client that stops reading must not hold a runner forever: a
           result that cannot be written in time drops the connection. */
        struct timeval tv;
        tv.tv_sec = LC_MSG_TIMEOUT_MS / 1000;
        tv.tv_usec = 0;
        setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    }
    peer_name(c, &ss, sl, ss.ss_family == AF_UNIX);
    pthread_mutex_lock(&s->mu);
    c->next = s->conns;
    s->conns = c;
    s->nconns++;
    pthread_mutex_unlock(&s->mu);
    pthread_attr_init(&attr);
    pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
    if (pthread_create(&th, &attr, conn_main, c) != 0) {
        slog(s, LOCD_LOG_ERROR, "could not start a connection thread");
        pthread_mutex_lock(&s->mu);
        s->conns = c->next;
        s->nconns--;
        pthread_mutex_unlock(&s->mu);
        close(fd);
        pthread_mutex_destroy(&c->wmu);
        free(c);
    }
    pthread_attr_destroy(&attr);
}

locd_status locd_service_run(locd_service *s)
{
    srv_conn *c;
    uint32_t i;
    if (!s || s->magic != LC_MAGIC_SERVICE)
        return lc_error(LOCD_ERR_INVALID_HANDLE, "not a locd_service handle");
    slog(s, LOCD_LOG_INFO, "listening on %s (%u runners)", s->address, s->nrunners);
    for (;;) {
        struct pollfd p[2];
        p[0].fd = s->lfd;
        p[0].events = POLLIN;
        p[1].fd = s->wake[0];
        p[1].events = POLLIN;
        p[0].revents = p[1].revents = 0;
        if (poll(p, 2, -1) < 0) {
            if (errno == EINTR)
                continue;
            break;
        }
        if (p[1].revents)
            break;
        if (p[0].revents & POLLIN)
            accept_one(s);
    }
    slog(s, LOCD_LOG_INFO, "stopping");
    close(s->lfd);
    s->lfd = -1;
    if (s->unix_path[0]) {
        unlink(s->unix_path);
        s->unix_path[0] = '\0';
    }
    /* Break every connection and wait for their threads to leave. */
    pthread_mutex_lock(&s->mu);
    for (c = s->conns; c; c = c->next) {
        pthread_mutex_lock(&c->wmu);
        if (c->fd >= 0)
            shutdown(c->fd, SHUT_RDWR);
        pthread_mutex_unlock(&c->wmu);
    }
    while (s->nconns)
        pthread_cond_wait(&s->conns_cv, &s->mu);
    s->stopping = 1;
    pthread_cond_broadcast(&s->cv);
    pthread_mutex_unlock(&s->mu);
    for (i = 0; i < s->nrunners; i++)
        pthread_join(s->runners[i], NULL);
    s->nrunners = 0;
    slog(s, LOCD_LOG_INFO, "stopped after %llu jobs", (unsigned long long)s->served);
    return LOCD_OK;
}

void locd_service_stop(locd_service *s)
{
    char x = 'x';
    if (s && s->magic == LC_MAGIC_SERVICE && s->wake[1] >= 0) {
        ssize_t w = write(s->wake[1], &x, 1);
        (void)w;
    }
}

void locd_service_destroy(locd_service *s)
{
    uint32_t i;
    if (!s || s->magic != LC_MAGIC_SERVICE)
        return;
    if (s->nrunners) { /* never ran: stop the runners */
        pthread_mutex_lock(&s->mu);
        s->stopping = 1;
        pthread_cond_broadcast(&s->cv);
        pthread_mutex_unlock(&s->mu);
        for (i = 0; i < s->nrunners; i++)
            pthread_join(s->runners[i], NULL);
    }
    if (s->lfd >= 0)
        close(s->lfd);
    if (s->unix_path[0])
        unlink(s->unix_path);
    if (s->wake[0] >= 0)
        close(s->wake[0]);
    if (s->wake[1] >= 0)
        close(s->wake[1]);
    free(s->runners);
    free(s->secret);
    pthread_cond_destroy(&s->cv);
    pthread_cond_destroy(&s->conns_cv);
    pthread_mutex_destroy(&s->mu);
    s->magic = LC_MAGIC_DEAD;
    free(s);
}
