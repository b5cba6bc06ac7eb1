/* Level 3 client: service jobs and their submit. A job gets an id and goes
 * on the connection's pending list before its SUBMIT message is sent; the
 * reader thread (client_reader.c) finishes it.
 *
 * On a Unix socket the boxes of larger jobs travel through a POSIX shm
 * segment (mode 0600, unique name) that the service unlinks once it has
 * opened it; the client unlinks it too when the job ends, in case the
 * service never got to it. Over TCP the boxes are streamed. */
#define _GNU_SOURCE
#include "service/service.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdio.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* Puts the boxes in a fresh shm segment; the name goes into j->shm_name. */
static locd_status boxes_to_shm(lc_svc_job *j, const void *boxes, size_t bytes)
{
    void *map;
    int fd = -1, tries, rc;
    for (tries = 0; tries < 8 && fd < 0; tries++) {
        lc_shm_unique_name(j->shm_name, sizeof j->shm_name, "c");
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

/* Writes all of buf before deadline (lc_now_ms() clock; 0 = none): 1, or
 * 0 with errno (ETIMEDOUT when the service took too little in time, as a
 * stopped one does once the socket is full). */
static int write_by(int fd, const void *buf, size_t len, double deadline)
{
    const char *p = buf;
    while (len) {
        struct pollfd pfd;
        double left;
        ssize_t w = send(fd, p, len, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (w > 0) {
            p += w;
            len -= (size_t)w;
            continue;
        }
        if (w < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
            return 0;
        left = deadline > 0 ? deadline - lc_now_ms() : -1.0;
        if (deadline > 0 && left <= 0) {
            errno = ETIMEDOUT;
            return 0;
        }
        pfd.fd = fd;
        pfd.events = POLLOUT;
        pfd.revents = 0;
        if (poll(&pfd, 1, deadline > 0 ? (int)(left > 2e9 ? 2e9 : left + 1.0) : -1) < 0 && errno != EINTR)
            return 0;
    }
    return 1;
}

/* Sends the SUBMIT message of job j: f, then the segment name or the
 * boxes themselves. */
static locd_status send_submit(lc_svc_conn *c, lc_svc_job *j, lc_submit_fixed *f, const void *boxes,
                               size_t bytes)
{
    uint8_t buf[LC_PROTO_HEADER + LC_PROTO_SUBMIT_FIXED + 4 + 64];
    char name[sizeof j->shm_name];
    size_t nl, len;
    int ok, stalled;
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
        ok = 0;
    } else if (nl) {
        lc_put_u32(buf + LC_PROTO_HEADER + LC_PROTO_SUBMIT_FIXED, (uint32_t)nl);
        memcpy(buf + LC_PROTO_HEADER + LC_PROTO_SUBMIT_FIXED + 4, name, nl);
        ok = write_by(c->fd, buf, LC_PROTO_HEADER + len, j->deadline);
    } else {
        ok = write_by(c->fd, buf, LC_PROTO_HEADER + LC_PROTO_SUBMIT_FIXED, j->deadline);
        if (ok && bytes)
            ok = write_by(c->fd, boxes, bytes, j->deadline);
    }
    stalled = !ok && errno == ETIMEDOUT;
    if (!ok)
        shutdown(c->fd, SHUT_RDWR); /* half a message was sent: the stream is unusable */
    pthread_mutex_unlock(&c->wmu);
    if (ok)
        return LOCD_OK;
    /* Dead from now on, not only once the reader notices: the next submit
       reconnects instead of failing on this connection too. */
    pthread_mutex_lock(&c->mu);
    if (!c->dead)
        snprintf(c->why, sizeof c->why, "%s", stalled ? "a send to the service stalled past the job's deadline"
                                                      : "the connection broke while sending");
    c->dead = 1;
    pthread_mutex_unlock(&c->mu);
    if (stalled) /* the send timeout of client_conn.c: a stopped or hung service */
        return lc_error(LOCD_ERR_TIMEOUT, "the service did not take the job's boxes before its deadline "
                                          "(service_timeout_ms; a stopped or hung service?); the connection "
                                          "was closed");
    return lc_error(LOCD_ERR_CONNECTION, "the service connection broke while sending");
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
    if (c->fd >= 0 && !lc_proto_write_all(c->fd, hb, sizeof hb))
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
        lc_svc_conn_unref(c);
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

/* Jobs on the pending list (under c->mu). */
static uint32_t pending_count(const lc_svc_conn *c)
{
    const lc_svc_job *p;
    uint32_t n = 0;
    for (p = c->pending; p; p = p->next)
        n++;
    return n;
}

/* Puts j on the connection's pending list under a fresh id, unless the
 * connection is already closed. With LC_CLIENT_MAX_IN_FLIGHT jobs pending
 * it first waits for one to finish: the service refuses jobs past its own
 * limit, and a job stays on this list until its RESULT came, so the
 * service never has more of ours than this list. */
static locd_status register_job(lc_svc_conn *c, lc_svc_job *j)
{
    static const uint64_t one = 1;
    int wake;
    pthread_mutex_lock(&c->mu);
    while (!c->dead && !c->closing && pending_count(c) >= LC_CLIENT_MAX_IN_FLIGHT) {
        /* The reader takes jobs off the list without a signal: look again soon. */
        pthread_mutex_unlock(&c->mu);
        {
            struct timespec ts = {0, 1000000};
            nanosleep(&ts, NULL);
        }
        pthread_mutex_lock(&c->mu);
    }
    if (c->dead) {
        pthread_mutex_unlock(&c->mu);
        return lc_error(LOCD_ERR_CONNECTION, "the service connection is closed");
    }
    j->id = ++c->next_id;
    j->next = c->pending;
    c->pending = j;
    wake = lc_svc_deadline_added_locked(c, j);
    if (wake)
        c->reader_next = j->deadline;
    pthread_mutex_unlock(&c->mu);
    if (wake && write(c->wake, &one, sizeof one) < 0) {
        /* the counter is full: the reader has wake-ups pending anyway */
    }
    return LOCD_OK;
}

/* When job j of n boxes must have its result (lc_now_ms() clock), 0 for
 * no deadline: the engine's base plus 10 us per box (level 2's rule for a
 * round of its workers), counted from the submit. */
static double job_deadline(const locd_engine *e, const lc_svc_job *j, size_t n)
{
    int64_t t = lc_svc_timeout_ms(e);
    if (t < 0)
        return 0;
    return j->job.t_submit + (double)t + (double)n * 0.01;
}

locd_status lc_svc_submit(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags, locd_job **out)
{
    size_t bytes = n * 6 * (f64 ? sizeof(double) : sizeof(float));
    lc_submit_fixed f;
    lc_svc_conn *c;
    lc_svc_job *j;
    locd_job *job;
    locd_status st;
    if ((st = lc_svc_get_conn(e, &c)) != LOCD_OK)
        return st;
    if ((st = lc_job_new(&e->alloc, &svc_job_ops, &job)) != LOCD_OK) {
        lc_svc_conn_unref(c);
        return st;
    }
    j = (lc_svc_job *)job;
    j->conn = c; /* the job keeps the caller's reference on c */
    j->deadline = job_deadline(e, j, n);
    if (c->shm_ok && bytes >= LC_PROTO_SHM_MIN_BYTES && boxes_to_shm(j, boxes, bytes) != LOCD_OK) {
        /* A full /dev/shm (or no segment allowed): the boxes are streamed. */
        lc_engine_log(e, LOCD_LOG_WARNING, "level 3: %s; streaming the boxes instead", lc_last_error_detail());
        lc_clear_error();
    }
    if ((st = register_job(c, j)) != LOCD_OK) {
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
        lc_svc_job *mine = lc_svc_take_pending(c, j->id);
        if (mine)
            lc_svc_job_done(mine, st, lc_last_error_detail(), -1);
        svc_job_released(job);
        lc_job_unref(job);
        if (st == LOCD_ERR_TIMEOUT)
            return lc_error(st, "%s", lc_last_error_detail());
        return lc_error(LOCD_ERR_CONNECTION, "the service connection broke while sending the job");
    }
    *out = job;
    return LOCD_OK;
}

