/* Level 3 client: the engine's connection to the service. Connecting
 * (Unix or TCP socket, then the HELLO handshake), the connection's
 * references (the engine's and one per job), and reconnecting when it
 * broke: the next submit tries again, so a restarted service is picked up. */
#define _GNU_SOURCE
#include "service/service.h"

#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdio.h>
#include <sys/eventfd.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/un.h>
#include <unistd.h>

#define LC_CONNECT_TIMEOUT_MS 5000

/* The engine's backend state. */
typedef struct lc_svc {
    pthread_mutex_t mu; /* conn replacement */
    lc_svc_conn *conn;
} lc_svc;

void lc_svc_conn_unref(lc_svc_conn *c)
{
    int left;
    pthread_mutex_lock(&c->mu);
    left = --c->refs;
    pthread_mutex_unlock(&c->mu);
    if (left)
        return;
    if (c->fd >= 0)
        close(c->fd);
    if (c->wake >= 0)
        close(c->wake);
    pthread_mutex_destroy(&c->mu);
    pthread_mutex_destroy(&c->wmu);
    lc_free(&c->alloc, c, sizeof *c);
}

/* Connects to a: 1 with the socket in *out, or 0 (why). */
static int connect_socket(const lc_address *a, int *out, char *why, size_t wl)
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
            return 0;
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
            return 0;
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
            return 0;
        setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    }
    *out = fd;
    return 1;
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
    if (!lc_proto_write_all(c->fd, buf, LC_PROTO_HEADER + 4 + slen))
        return lc_error(LOCD_ERR_CONNECTION, "the service closed the connection: %s", strerror(errno));
    if (lc_proto_read_all(c->fd, hb, sizeof hb, LC_CONNECT_TIMEOUT_MS, why, sizeof why) != 1 ||
        !lc_proto_get_header(hb, 8 + LC_PROTO_MAX_TEXT, &h, why, sizeof why))
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

/* The engine's per-job deadline base in ms (service_timeout_ms, 0 =
 * the default); negative = none. */
int64_t lc_svc_timeout_ms(const locd_engine *e)
{
    int64_t t = e->cfg.service_timeout_ms;
    return t == 0 ? LOCD_DEFAULT_SERVICE_TIMEOUT_MS : t;
}

/* A send that cannot move a byte for this long fails (the job then ends
 * with LOCD_ERR_TIMEOUT): a stopped service must not hold a submit that
 * fills the socket. The deadline base, at most LC_MSG_TIMEOUT_MS; none
 * when the engine has no deadline. */
static void bound_sends(const locd_engine *e, int fd)
{
    int64_t t = lc_svc_timeout_ms(e);
    struct timeval tv;
    if (t < 0)
        return;
    if (t > LC_MSG_TIMEOUT_MS)
        t = LC_MSG_TIMEOUT_MS;
    tv.tv_sec = (time_t)(t / 1000);
    tv.tv_usec = (suseconds_t)((t % 1000) * 1000);
    setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
}

/* Whether the service sees this process's /dev/shm: a service in another
 * mount namespace (a container sharing only the socket) has its own. The
 * probe is a job of no boxes passed through an empty segment; the service
 * removes the segment's name once it opened it, so a name still there
 * after the RESULT means it could not: the connection then streams every
 * job's boxes. 1 (probed), or 0 when the connection broke (why). Runs
 * before the reader thread starts. */
static int probe_shared_memory(lc_svc_conn *c, char *why, size_t wl)
{
    uint8_t buf[LC_PROTO_HEADER + LC_PROTO_SUBMIT_FIXED + 4 + 64];
    char name[64];
    lc_submit_fixed f;
    lc_msg_header h;
    size_t nl;
    int fd = -1, tries;
    for (tries = 0; tries < 8 && fd < 0; tries++) {
        lc_shm_unique_name(name, sizeof name, "p");
        fd = shm_open(name, O_RDWR | O_CREAT | O_EXCL, 0600);
        if (fd < 0 && errno != EEXIST)
            break;
    }
    if (fd < 0) { /* this side cannot make segments: stream */
        c->shm_ok = 0;
        return 1;
    }
    close(fd);
    nl = strlen(name);
    memset(&f, 0, sizeof f);
    f.transport = 1;
    lc_proto_put_header(buf, LC_MSG_SUBMIT, ++c->next_id, LC_PROTO_SUBMIT_FIXED + 4 + nl);
    lc_proto_put_submit(buf + LC_PROTO_HEADER, &f);
    lc_put_u32(buf + LC_PROTO_HEADER + LC_PROTO_SUBMIT_FIXED, (uint32_t)nl);
    memcpy(buf + LC_PROTO_HEADER + LC_PROTO_SUBMIT_FIXED + 4, name, nl);
    if (!lc_proto_write_all(c->fd, buf, LC_PROTO_HEADER + LC_PROTO_SUBMIT_FIXED + 4 + nl) ||
        lc_proto_read_all(c->fd, buf, LC_PROTO_HEADER, LC_CONNECT_TIMEOUT_MS, why, wl) != 1 ||
        !lc_proto_get_header(buf, 16 + LC_PROTO_MAX_TEXT + LC_PROTO_STATS_BYTES + 8, &h, why, wl) ||
        h.type != LC_MSG_RESULT || h.id != c->next_id ||
        !lc_proto_skip(c->fd, h.length, LC_CONNECT_TIMEOUT_MS, why, wl)) {
        if (!why[0])
            snprintf(why, wl, "no answer to the shared-memory probe");
        shm_unlink(name);
        return 0;
    }
    fd = shm_open(name, O_RDONLY, 0);
    if (fd >= 0) { /* the service never opened it */
        close(fd);
        shm_unlink(name);
        c->shm_ok = 0;
    }
    return 1;
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
    if (!lc_proto_parse_address(e->cfg.service_address, &a, why, sizeof why))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "service_address: %s", why);
    c = lc_alloc(&e->alloc, sizeof *c);
    if (!c)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the connection");
    memset(c, 0, sizeof *c);
    c->alloc = e->alloc;
    c->refs = 1;
    pthread_mutex_init(&c->mu, NULL);
    pthread_mutex_init(&c->wmu, NULL);
    c->fd = -1;
    c->wake = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    if (c->wake < 0) {
        lc_svc_conn_unref(c);
        return lc_error(LOCD_ERR_IO, "eventfd: %s", strerror(errno));
    }
    if (!connect_socket(&a, &c->fd, why, sizeof why)) {
        lc_svc_conn_unref(c);
        return lc_error(LOCD_ERR_CONNECTION, "%s", why);
    }
    if ((st = handshake(c, e->cfg.service_secret)) != LOCD_OK) {
        lc_svc_conn_unref(c);
        return st;
    }
    if (a.tcp)
        c->shm_ok = 0;
    why[0] = '\0';
    if (c->shm_ok && !probe_shared_memory(c, why, sizeof why)) {
        lc_svc_conn_unref(c);
        return lc_error(LOCD_ERR_CONNECTION, "the service did not answer the shared-memory probe: %s", why);
    }
    if (!a.tcp && !c->shm_ok)
        lc_engine_log(e, LOCD_LOG_INFO, "level 3: %s does not share /dev/shm with this process: boxes are streamed",
                      e->cfg.service_address);
    bound_sends(e, c->fd);
    if (pthread_create(&c->reader, NULL, lc_svc_reader_main, c) != 0) {
        lc_svc_conn_unref(c);
        return lc_error(LOCD_ERR_THREAD, "could not start the connection's reader thread");
    }
    *out = c;
    return LOCD_OK;
}

/* Breaks the connection, waits for its reader (which fails pending jobs)
 * and drops the engine's reference. Jobs may still hold the memory. */
static void conn_close(lc_svc_conn *c)
{
    pthread_mutex_lock(&c->mu);
    c->closing = 1;
    pthread_mutex_unlock(&c->mu);
    pthread_mutex_lock(&c->wmu);
    shutdown(c->fd, SHUT_RDWR);
    pthread_mutex_unlock(&c->wmu);
    pthread_join(c->reader, NULL);
    pthread_mutex_lock(&c->wmu);
    close(c->fd);
    c->fd = -1;
    pthread_mutex_unlock(&c->wmu);
    lc_svc_conn_unref(c);
}

static int conn_dead(lc_svc_conn *c)
{
    int d;
    pthread_mutex_lock(&c->mu);
    d = c->dead;
    pthread_mutex_unlock(&c->mu);
    return d;
}

locd_status lc_svc_open(locd_engine *e)
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

void lc_svc_close(locd_engine *e)
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
locd_status lc_svc_get_conn(locd_engine *e, lc_svc_conn **out)
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
