/* The service, one client connection: accepting it (within max_clients),
 * naming the peer, the HELLO/WELCOME handshake, then reading its messages
 * on its own thread until it goes away. The handshake must be over within
 * the auth deadline from accept, and a message that starts must finish
 * within the message deadline, each in total (a byte now and then does not
 * stretch them). Every header is checked before anything is allocated for
 * it; a bad one drops this connection with a logged reason. A connection
 * that goes away cancels its jobs, running ones included. */
#define _GNU_SOURCE /* struct ucred, SO_PEERCRED */
#include "service/service.h"

#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <unistd.h>

/* ---- the handshake ---- */

/* Reads HELLO's payload into pl, the secret's length into *slen (the
 * secret follows it at pl + 4): 1, or 0 (why). */
static int read_hello_secret(lc_srv_conn *c, uint8_t *pl, uint32_t *slen, char *why, size_t wl)
{
    uint8_t hb[LC_PROTO_HEADER];
    lc_msg_header h;
    if (lc_proto_read_by(c->fd, hb, sizeof hb, c->deadline, why, wl) != 1)
        return 0;
    if (!lc_proto_get_header(hb, 4 + LC_PROTO_MAX_SECRET, &h, why, wl))
        return 0;
    if (h.type != LC_MSG_HELLO || h.length < 4) {
        snprintf(why, wl, "expected HELLO, got message type %u", h.type);
        return 0;
    }
    if (lc_proto_read_by(c->fd, pl, (size_t)h.length, c->deadline, why, wl) != 1)
        return 0;
    *slen = lc_get_u32(pl);
    if ((uint64_t)*slen + 4 != h.length) {
        snprintf(why, wl, "malformed HELLO");
        return 0;
    }
    return 1;
}

/* HELLO: the secret, when the service has one; then WELCOME. 1, or 0 to
 * drop the connection (why). */
static int handshake(lc_srv_conn *c, char *why, size_t wl)
{
    lc_server *s = c->s;
    uint8_t pl[4 + LC_PROTO_MAX_SECRET], reply[LC_PROTO_HEADER + 4];
    uint32_t slen;
    int auth;
    c->deadline = c->since + (double)s->cfg.auth_timeout_ms;
    if (!read_hello_secret(c, pl, &slen, why, wl)) {
        if (strstr(why, "deadline"))
            snprintf(why, wl, "no HELLO within %u ms", s->cfg.auth_timeout_ms);
        return 0;
    }
    if ((auth = lc_srv_auth_check(s, pl + 4, (size_t)slen)) != LC_AUTH_OK) {
        snprintf(why, wl, "%s", auth == LC_AUTH_THROTTLED ? "too many wrong secrets (not checked)"
                                : slen                    ? "wrong secret"
                                                          : "no secret given");
        if (auth == LC_AUTH_THROTTLED)
            lc_srv_send_error(c->fd, LOCD_ERR_BUSY, "too many failed authentications; try again in a second");
        else
            lc_srv_send_error(c->fd, LOCD_ERR_AUTH, "a valid shared secret is required");
        return 0;
    }
    lc_proto_put_header(reply, LC_MSG_WELCOME, 0, 4);
    lc_put_u32(reply + LC_PROTO_HEADER, (uint32_t)c->shm_ok);
    if (!lc_srv_send(c, reply, sizeof reply, NULL, 0)) {
        snprintf(why, wl, "write failed");
        return 0;
    }
    pthread_mutex_lock(&s->mu);
    c->authed = 1;
    pthread_mutex_unlock(&s->mu);
    return 1;
}

/* ---- the messages ---- */

/* Reads the next header. 1: h is valid; 0: the client left cleanly; -1:
 * drop (why). Three values, as lc_proto_read_all's: the caller logs a
 * client that left apart from one that broke. */
static int read_header(lc_srv_conn *c, lc_msg_header *h, char *why, size_t wl)
{
    uint8_t hb[LC_PROTO_HEADER];
    int r = lc_proto_read_by(c->fd, hb, 1, -1, why, wl); /* idle clients may wait forever */
    c->deadline = lc_now_ms() + (double)c->s->cfg.message_timeout_ms; /* for the whole message */
    if (r == 1)
        r = lc_proto_read_by(c->fd, hb + 1, sizeof hb - 1, c->deadline, why, wl);
    if (r == 1 && !lc_proto_get_header(hb, c->s->cfg.max_message, h, why, wl))
        r = -1;
    return r;
}

/* Acts on one message: 1, or 0 to drop the connection (why). */
static int handle_message(lc_srv_conn *c, const lc_msg_header *h, char *why, size_t wl)
{
    lc_srv_job *j;
    if (h->type == LC_MSG_SUBMIT) {
        if (!lc_srv_read_submit(c, h, &j, why, wl))
            return 0;
        if (j)
            lc_srv_enqueue(c, j);
        return 1;
    }
    if (h->type == LC_MSG_CANCEL && h->length == 0) {
        lc_srv_cancel(c, h->id);
        return 1;
    }
    snprintf(why, wl, "unexpected message type %u (length %llu)", h->type, (unsigned long long)h->length);
    return 0;
}

static void serve_connection(lc_srv_conn *c)
{
    lc_server *s = c->s;
    char why[300] = "";
    lc_msg_header h;
    int r;
    if (!handshake(c, why, sizeof why)) {
        lc_srv_log(s, LOCD_LOG_WARNING, "dropping connection from %s: %s", c->peer, why);
        return;
    }
    lc_srv_log(s, LOCD_LOG_DEBUG, "client %s connected", c->peer);
    while ((r = read_header(c, &h, why, sizeof why)) == 1)
        if (!handle_message(c, &h, why, sizeof why))
            break;
    if (r == 0)
        lc_srv_log(s, LOCD_LOG_DEBUG, "client %s disconnected", c->peer);
    else
        lc_srv_log(s, LOCD_LOG_WARNING, "dropping connection from %s: %s", c->peer, why);
}

/* ---- a connection's life ---- */

/* Under s->mu. */
static void conn_unlink_locked(lc_server *s, lc_srv_conn *c)
{
    lc_srv_conn **pp;
    for (pp = &s->conns; *pp; pp = &(*pp)->next)
        if (*pp == c) {
            *pp = c->next;
            break;
        }
    s->nconns--;
}

static void *conn_main(void *arg)
{
    lc_srv_conn *c = arg;
    lc_server *s = c->s;
    serve_connection(c);
    /* No more writes; cancel what is left (runners discard it). */
    pthread_mutex_lock(&c->wmu);
    c->closed = 1;
    shutdown(c->fd, SHUT_RDWR);
    close(c->fd);
    c->fd = -1;
    pthread_mutex_unlock(&c->wmu);
    pthread_mutex_lock(&s->mu);
    lc_srv_cancel_all_locked(c);
    conn_unlink_locked(s, c);
    lc_srv_conn_unref_locked(c);
    pthread_cond_broadcast(&s->conns_cv);
    pthread_mutex_unlock(&s->mu);
    return NULL;
}

static void peer_name_unix(lc_srv_conn *c)
{
    struct ucred cr;
    socklen_t cl = sizeof cr;
    if (getsockopt(c->fd, SOL_SOCKET, SO_PEERCRED, &cr, &cl) == 0) {
        snprintf(c->peer, sizeof c->peer, "pid %ld (uid %ld)", (long)cr.pid, (long)cr.uid);
        /* Only a process of the service's own user may hand it a segment. */
        c->shm_ok = cr.uid == geteuid();
    } else {
        snprintf(c->peer, sizeof c->peer, "a local client");
    }
}

static void peer_name_tcp(lc_srv_conn *c, const struct sockaddr_storage *ss, socklen_t sl)
{
    char host[NI_MAXHOST], port[NI_MAXSERV];
    if (getnameinfo((const struct sockaddr *)ss, sl, host, sizeof host, port, sizeof port,
                    NI_NUMERICHOST | NI_NUMERICSERV) == 0)
        snprintf(c->peer, sizeof c->peer, "%.60s:%.16s", host, port);
    else
        snprintf(c->peer, sizeof c->peer, "a TCP client");
}

/* A new connection on fd; NULL when out of memory (fd is then closed). */
static lc_srv_conn *conn_new(lc_server *s, int fd, const struct sockaddr_storage *ss, socklen_t sl)
{
    int one = 1;
    lc_srv_conn *c = calloc(1, sizeof *c);
    if (!c) {
        close(fd);
        return NULL;
    }
    c->s = s;
    c->fd = fd;
    c->refs = 1;
    c->since = lc_now_ms();
    pthread_mutex_init(&c->wmu, NULL);
    if (ss->ss_family != AF_UNIX)
        setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    /* A client that stops reading is dropped by lc_srv_send's deadline. */
    if (ss->ss_family == AF_UNIX)
        peer_name_unix(c);
    else
        peer_name_tcp(c, ss, sl);
    return c;
}

/* Under s->mu, when the service is full: breaks the oldest connection
 * still in its handshake, whose slot the new one then takes. Connections
 * that never authenticate cannot keep clients out this way: each new
 * arrival pushes the oldest of them out (and the auth deadline ends them
 * anyway). 1 when one was broken. */
static int evict_unauthenticated_locked(lc_server *s)
{
    lc_srv_conn *c, *oldest = NULL;
    for (c = s->conns; c; c = c->next)
        if (!c->authed && (!oldest || c->since < oldest->since))
            oldest = c;
    if (!oldest)
        return 0;
    pthread_mutex_lock(&oldest->wmu);
    if (oldest->fd >= 0)
        shutdown(oldest->fd, SHUT_RDWR);
    pthread_mutex_unlock(&oldest->wmu);
    oldest->authed = 1; /* not chosen twice */
    return 1;
}

/* 1 when the service already serves max_clients (fd is then refused). */
static int refuse_if_full(lc_server *s, int fd)
{
    int full, evicted = 0;
    pthread_mutex_lock(&s->mu);
    full = s->nconns >= s->cfg.max_clients;
    if (full && s->nconns < s->cfg.max_clients + LC_SRV_MAX_EVICTING)
        full = !(evicted = evict_unauthenticated_locked(s));
    pthread_mutex_unlock(&s->mu);
    if (evicted)
        lc_srv_log(s, LOCD_LOG_WARNING, "%u clients: broke the oldest connection that had not authenticated",
                   s->cfg.max_clients);
    if (full) {
        lc_srv_log(s, LOCD_LOG_WARNING, "refusing a connection: %u clients already", s->cfg.max_clients);
        lc_srv_send_error(fd, LOCD_ERR_BUSY, "too many clients");
        close(fd);
    }
    return full;
}

/* Registers c and starts its thread (detached: it cleans up after itself). */
static void conn_start(lc_server *s, lc_srv_conn *c)
{
    pthread_attr_t attr;
    pthread_t th;
    pthread_mutex_lock(&s->mu);
    c->next = s->conns;
    s->conns = c;
    s->nconns++;
    pthread_mutex_unlock(&s->mu);
    pthread_attr_init(&attr);
    pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
    if (pthread_create(&th, &attr, conn_main, c) != 0) {
        lc_srv_log(s, LOCD_LOG_ERROR, "could not start a connection thread");
        pthread_mutex_lock(&s->mu);
        conn_unlink_locked(s, c);
        pthread_mutex_unlock(&s->mu);
        close(c->fd);
        pthread_mutex_destroy(&c->wmu);
        free(c);
    }
    pthread_attr_destroy(&attr);
}

int lc_srv_accept(lc_server *s)
{
    struct sockaddr_storage ss;
    socklen_t sl = sizeof ss;
    lc_srv_conn *c;
    int fd = accept(s->lfd, (struct sockaddr *)&ss, &sl);
    if (fd < 0) {
        int e = errno;
        if (e != EMFILE && e != ENFILE && e != ENOBUFS && e != ENOMEM)
            return 1; /* the peer left first, a signal: try again */
        if (!s->accept_failing) /* once per episode, not once per try */
            lc_srv_log(s, LOCD_LOG_ERROR, "cannot accept connections: %s (retrying every %d ms)", strerror(e),
                       LC_SRV_ACCEPT_BACKOFF_MS);
        s->accept_failing = 1;
        return 0;
    }
    if (s->accept_failing) {
        lc_srv_log(s, LOCD_LOG_WARNING, "accepting connections again");
        s->accept_failing = 0;
    }
    fcntl(fd, F_SETFD, FD_CLOEXEC);
    if (refuse_if_full(s, fd))
        return 1;
    c = conn_new(s, fd, &ss, sl);
    if (c)
        conn_start(s, c);
    return 1;
}

/* The session loop (handshake, then messages until the client leaves or
 * breaks) on a connection the caller set up, on the caller's thread: what
 * conn_main runs, for tests/fuzz/fuzz_session.c. */
void lc_srv_serve(lc_srv_conn *c)
{
    serve_connection(c);
}
