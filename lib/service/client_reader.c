/* Level 3 client: the reader thread of a connection. It receives the
 * service's RESULT messages, whatever their order, and finishes the
 * matching jobs. A RESULT that is truncated or inconsistent finishes its
 * job with LOCD_ERR_PROTOCOL and closes the connection; when the
 * connection ends, every job still pending finishes with
 * LOCD_ERR_CONNECTION. No job is left unfinished.
 *
 * Between messages the thread also keeps the jobs' deadlines: a job with
 * no result by its deadline (a stopped or hung service) finishes with
 * LOCD_ERR_TIMEOUT and the service is asked to cancel it; a RESULT that
 * comes later is dropped like any result of a job no longer pending. */
#define _GNU_SOURCE
#include "service/service.h"

#include <errno.h>
#include <limits.h>
#include <poll.h>
#include <stdio.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <unistd.h>

#define LC_RESULT_MAX_BYTES (1ull << 37)

/* Removes job `id` from the pending list; the caller gets its reference. */
lc_svc_job *lc_svc_take_pending(lc_svc_conn *c, uint64_t id)
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

void lc_svc_job_done(lc_svc_job *j, locd_status st, const char *msg, int64_t index)
{
    drop_segment(j);
    lc_job_finish_unref(&j->job, st, msg, index);
}

/* A RESULT payload up to its pairs. */
typedef struct lc_result_head {
    int32_t status;
    int64_t index;
    char msg[LC_PROTO_MAX_TEXT + 1];
    locd_stats stats;
    uint64_t count;
} lc_result_head;

/* Reads a RESULT payload (after its header) up to its pairs and checks its
 * length against their count. 1, or 0 with the reason in why. */
static int read_head(lc_svc_conn *c, const lc_msg_header *h, lc_result_head *r, char *why, size_t wl)
{
    uint8_t fixed[16], sbuf[LC_PROTO_STATS_BYTES], cbuf[8];
    uint32_t mlen;
    if (h->length < 16 + LC_PROTO_STATS_BYTES + 8) {
        snprintf(why, wl, "short result message");
        return 0;
    }
    if (lc_proto_read_all(c->fd, fixed, 16, c->msg_timeout, why, wl) != 1)
        return 0;
    r->status = (int32_t)lc_get_u32(fixed);
    r->index = (int64_t)lc_get_u64(fixed + 4);
    mlen = lc_get_u32(fixed + 12);
    if (mlen > LC_PROTO_MAX_TEXT || h->length < 16 + (uint64_t)mlen + LC_PROTO_STATS_BYTES + 8) {
        snprintf(why, wl, "bad result message");
        return 0;
    }
    if (lc_proto_read_all(c->fd, r->msg, mlen, c->msg_timeout, why, wl) != 1 ||
        lc_proto_read_all(c->fd, sbuf, sizeof sbuf, c->msg_timeout, why, wl) != 1 ||
        lc_proto_read_all(c->fd, cbuf, 8, c->msg_timeout, why, wl) != 1)
        return 0;
    r->msg[mlen] = '\0';
    r->count = lc_get_u64(cbuf);
    if (r->count > (h->length / 8) || 16 + (uint64_t)mlen + LC_PROTO_STATS_BYTES + 8 + r->count * 8 != h->length) {
        snprintf(why, wl, "result length does not match its pair count");
        return 0;
    }
    lc_proto_get_stats(sbuf, &r->stats);
    return 1;
}

/* What a RESULT says about its job, for finish_taken. */
typedef struct lc_outcome {
    locd_status status;
    int64_t index;
    const char *msg;
} lc_outcome;

/* Reads the pairs of a successful result into j (not finishing it). 1, or
 * 0 when the stream broke. */
static int read_pairs(lc_svc_conn *c, lc_svc_job *j, lc_result_head *r, lc_outcome *o, char *why, size_t wl)
{
    if (lc_pairs_reserve(&j->job.result, (size_t)r->count) != LOCD_OK) {
        if (!lc_proto_skip(c->fd, r->count * 8, c->msg_timeout, why, wl))
            return 0;
        o->status = LOCD_ERR_NO_MEMORY;
        o->msg = "no memory for the service's result";
        return 1;
    }
    if (r->count && lc_proto_read_all(c->fd, j->job.result.data, (size_t)r->count * 8, c->msg_timeout, why, wl) != 1)
        return 0;
    j->job.result.count = (size_t)r->count;
    /* Transfer: what the round trip cost beyond the service's own call. */
    r->stats.ms_transfer = lc_now_ms() - j->job.t_submit - r->stats.ms_total;
    if (r->stats.ms_transfer < 0)
        r->stats.ms_transfer = 0;
    j->job.stats = r->stats;
    o->status = LOCD_OK;
    return 1;
}

/* Reads one RESULT payload (after its header) into job j (NULL: the job is
 * no longer pending and its result is dropped) and says in o how j ends;
 * it never finishes j itself (see lc_svc_reader_main). 1, or 0 when the
 * message is malformed or the stream broke (why): the connection is then
 * unusable. */
static int read_result(lc_svc_conn *c, const lc_msg_header *h, lc_svc_job *j, lc_result_head *r, lc_outcome *o,
                       char *why, size_t wl)
{
    if (!read_head(c, h, r, why, wl))
        return 0;
    if (r->status > 0) { /* LOCD_PENDING or worse: not an outcome */
        snprintf(why, wl, "result with status %d, which is not final", (int)r->status);
        return 0;
    }
    if (j && r->status == LOCD_OK)
        return read_pairs(c, j, r, o, why, wl);
    if (r->count && !lc_proto_skip(c->fd, r->count * 8, c->msg_timeout, why, wl))
        return 0;
    o->status = r->status;
    o->index = r->index;
    o->msg = r->msg;
    return 1;
}

/* How a job whose RESULT could not be read ends: the service's fault
 * (LOCD_ERR_PROTOCOL), unless this side broke the stream by closing the
 * engine mid-message (LOCD_ERR_CONNECTION, like every other pending job). */
static locd_status broken_status(lc_svc_conn *c)
{
    int closing;
    pthread_mutex_lock(&c->mu);
    closing = c->closing;
    pthread_mutex_unlock(&c->mu);
    return closing ? LOCD_ERR_CONNECTION : LOCD_ERR_PROTOCOL;
}

/* ---- deadlines ---- */

int lc_svc_deadline_added_locked(lc_svc_conn *c, const lc_svc_job *j)
{
    return j->deadline > 0 && (c->reader_next <= 0 || j->deadline < c->reader_next);
}

/* Best effort: a CANCEL for job id, unless a writer is in the middle of a
 * message (the service then runs the job to its end and its result is
 * dropped). A CANCEL that went out only in part breaks the stream. */
static void send_cancel_nowait(lc_svc_conn *c, uint64_t id)
{
    uint8_t hb[LC_PROTO_HEADER];
    ssize_t w;
    lc_proto_put_header(hb, LC_MSG_CANCEL, id, 0);
    if (pthread_mutex_trylock(&c->wmu) != 0)
        return;
    if (c->fd >= 0) {
        w = send(c->fd, hb, sizeof hb, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (w > 0 && (size_t)w < sizeof hb)
            shutdown(c->fd, SHUT_RDWR);
    }
    pthread_mutex_unlock(&c->wmu);
}

/* Finishes every pending job past its deadline with LOCD_ERR_TIMEOUT and
 * returns the earliest deadline still ahead (0 = none), which is also
 * recorded as the reader's next check. */
static double expire_overdue(lc_svc_conn *c)
{
    lc_svc_job **pp, *j, *overdue = NULL;
    double now = lc_now_ms(), next = 0;
    char msg[160];
    pthread_mutex_lock(&c->mu);
    for (pp = &c->pending; (j = *pp) != NULL;) {
        if (j->deadline > 0 && j->deadline <= now) {
            *pp = j->next;
            j->next = overdue;
            overdue = j;
            continue;
        }
        if (j->deadline > 0 && (next <= 0 || j->deadline < next))
            next = j->deadline;
        pp = &j->next;
    }
    c->reader_next = next;
    pthread_mutex_unlock(&c->mu);
    while ((j = overdue) != NULL) {
        overdue = j->next;
        j->next = NULL;
        send_cancel_nowait(c, j->id);
        snprintf(msg, sizeof msg,
                 "no result from the service within %.0f ms (the job's deadline, service_timeout_ms); "
                 "the service was asked to cancel it",
                 j->deadline - j->job.t_submit);
        lc_svc_job_done(j, LOCD_ERR_TIMEOUT, msg, -1);
    }
    return next;
}

/* Waits until a message starts on the connection, finishing overdue jobs
 * meanwhile. 1 when bytes (or the end of the stream) are there, 0 when
 * the wait failed (why). */
static int wait_for_message(lc_svc_conn *c, char *why, size_t wl)
{
    for (;;) {
        struct pollfd pfd[2];
        double next = expire_overdue(c), left;
        int timeout = -1, pr;
        uint64_t drain;
        if (next > 0) {
            left = next - lc_now_ms() + 1.0;
            timeout = left < 1.0 ? 1 : left > (double)INT_MAX ? INT_MAX : (int)left;
        }
        pfd[0].fd = c->fd;
        pfd[0].events = POLLIN;
        pfd[0].revents = 0;
        pfd[1].fd = c->wake;
        pfd[1].events = POLLIN;
        pfd[1].revents = 0;
        pr = poll(pfd, c->wake >= 0 ? 2 : 1, timeout);
        if (pr < 0 && errno != EINTR) {
            snprintf(why, wl, "poll failed: %s", strerror(errno));
            return 0;
        }
        if (pr > 0 && (pfd[1].revents & POLLIN) && read(c->wake, &drain, sizeof drain) < 0)
            drain = 0; /* nothing to drain: another wake-up read it */
        if (pr > 0 && pfd[0].revents)
            return 1;
    }
}

/* How long the rest of a message that has started may stall: 30 s
 * (LC_MSG_TIMEOUT_MS), but no later than the deadline it serves (the
 * RESULT's job, or for a header the earliest pending deadline), with
 * 100 ms of grace for a message that started just before it. */
static int message_timeout(double deadline)
{
    double left;
    if (deadline <= 0)
        return LC_MSG_TIMEOUT_MS;
    left = deadline - lc_now_ms();
    return left < 100.0 ? 100 : left >= LC_MSG_TIMEOUT_MS ? LC_MSG_TIMEOUT_MS : (int)left + 1;
}

/* A job whose RESULT broke off: past its deadline, that is why it ends
 * (LOCD_ERR_TIMEOUT); otherwise broken_status. */
static locd_status cut_off_status(lc_svc_conn *c, const lc_svc_job *j)
{
    if (j->deadline > 0 && lc_now_ms() >= j->deadline - 100.0)
        return LOCD_ERR_TIMEOUT;
    return broken_status(c);
}

void *lc_svc_reader_main(void *arg)
{
    lc_svc_conn *c = arg;
    char why[200] = "connection closed";
    uint8_t hb[LC_PROTO_HEADER];
    lc_msg_header h;
    lc_svc_job *list, *j;
    lc_result_head r;
    lc_outcome o;
    int ok;
    for (;;) {
        int rd;
        if (!wait_for_message(c, why, sizeof why))
            break;
        pthread_mutex_lock(&c->mu);
        c->msg_timeout = message_timeout(c->reader_next);
        pthread_mutex_unlock(&c->mu);
        rd = lc_proto_read_all(c->fd, hb, sizeof hb, c->msg_timeout, why, sizeof why);
        if (rd != 1)
            break;
        if (!lc_proto_get_header(hb, LC_RESULT_MAX_BYTES, &h, why, sizeof why))
            break;
        if (h.type != LC_MSG_RESULT) {
            snprintf(why, sizeof why, "unexpected message type %u from the service", h.type);
            break;
        }
        /* The job leaves the pending list for its RESULT to be read into it
           (a failed submit cannot take it meanwhile); from here this loop
           is its only way out, and every way ends in lc_svc_job_done. */
        j = lc_svc_take_pending(c, h.id);
        o.status = LOCD_ERR_PROTOCOL;
        o.index = -1;
        o.msg = why;
        c->msg_timeout = message_timeout(j ? j->deadline : 0);
        ok = read_result(c, &h, j, &r, &o, why, sizeof why);
        if (j)
            lc_svc_job_done(j, ok ? o.status : cut_off_status(c, j), ok ? o.msg : why, ok ? o.index : -1);
        if (!ok)
            break;
    }
    /* Whatever ended the stream, it cannot be resynchronised: close it, so
       the service sees the client leave and later writes fail at once. */
    pthread_mutex_lock(&c->wmu);
    shutdown(c->fd, SHUT_RDWR);
    pthread_mutex_unlock(&c->wmu);
    expire_overdue(c); /* jobs past their deadline end with LOCD_ERR_TIMEOUT, not the connection's error */
    pthread_mutex_lock(&c->mu);
    c->dead = 1;
    snprintf(c->why, sizeof c->why, "%s", why);
    list = c->pending;
    c->pending = NULL;
    pthread_mutex_unlock(&c->mu);
    while ((j = list) != NULL) {
        list = j->next;
        j->next = NULL;
        lc_svc_job_done(j, LOCD_ERR_CONNECTION, c->why, -1);
    }
    return NULL;
}
