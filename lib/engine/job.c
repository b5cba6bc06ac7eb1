/* The job handle, common to every kind of job: its status, result, and
 * the caller's calls on it (poll, wait, take, stats, cancel, release).
 * The kind's own work goes through its lc_job_ops table: the generic job
 * of levels 1 and 2 (submit.c) and the service job of level 3
 * (service/client.c).
 *
 * A job holds two references: the caller's handle (dropped by
 * locd_job_release) and the runner's (the queue thread, or the service
 * connection). Cancel finishes a pending job at once with
 * LOCD_ERR_CANCELLED and tells the runner through ops->cancel; whatever
 * the runner produces afterwards is discarded. */
#include "engine/engine.h"

#include <errno.h>
#include <stdio.h>
#include <time.h>

locd_status lc_job_new(const locd_allocator *a, const lc_job_ops *ops, locd_job **out)
{
    pthread_condattr_t ca;
    locd_job *j = lc_alloc(a, ops->size);
    *out = NULL;
    if (!j)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the job");
    memset(j, 0, ops->size);
    j->alloc = *a;
    j->ops = ops;
    if (pthread_mutex_init(&j->mu, NULL) != 0) {
        lc_free(a, j, ops->size);
        return lc_error(LOCD_ERR_THREAD, "pthread_mutex_init failed");
    }
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC); /* timeouts immune to clock changes */
    if (pthread_cond_init(&j->cv, &ca) != 0) {
        pthread_condattr_destroy(&ca);
        pthread_mutex_destroy(&j->mu);
        lc_free(a, j, ops->size);
        return lc_error(LOCD_ERR_THREAD, "pthread_cond_init failed");
    }
    pthread_condattr_destroy(&ca);
    j->refs = 2;
    j->status = LOCD_PENDING;
    lc_pairs_init_embedded(&j->result, a);
    locd_stats_init(&j->stats);
    j->t_submit = lc_now_ms();
    j->magic = LC_MAGIC_JOB;
    *out = j;
    return LOCD_OK;
}

/* Records the outcome of a job still pending (the first outcome wins); the
 * caller holds j->mu. Returns whether it did. */
static int settle_locked(locd_job *j, locd_status status, const char *message, int64_t index)
{
    if (j->status != LOCD_PENDING)
        return 0;
    j->status = status;
    j->error_index = index;
    if (status < 0)
        snprintf(j->message, sizeof j->message, "%s", message ? message : "");
    return 1;
}

static void job_free(locd_job *j)
{
    locd_allocator a = j->alloc;
    if (j->ops->free)
        j->ops->free(j);
    lc_pairs_fini_embedded(&j->result);
    pthread_cond_destroy(&j->cv);
    pthread_mutex_destroy(&j->mu);
    j->magic = LC_MAGIC_DEAD;
    lc_free(&a, j, j->ops->size);
}

void lc_job_finish_unref(locd_job *j, locd_status status, const char *message, int64_t index)
{
    int left;
    pthread_mutex_lock(&j->mu);
    settle_locked(j, status, message, index);
    left = --j->refs;
    pthread_cond_broadcast(&j->cv);
    pthread_mutex_unlock(&j->mu);
    if (left == 0)
        job_free(j);
}

void lc_job_unref(locd_job *j)
{
    int left;
    pthread_mutex_lock(&j->mu);
    left = --j->refs;
    pthread_mutex_unlock(&j->mu);
    if (left == 0)
        job_free(j);
}

void lc_job_discard(locd_job *j)
{
    j->refs = 1;
    if (j->ops->released)
        j->ops->released(j);
    lc_job_unref(j);
}

/* Raises the job's stored error (a detail, lc_last_error_detail) on the
 * calling thread. */
static locd_status raise_job_error(const locd_job *j, locd_status status)
{
    const char *msg = j->message;
    return lc_error_box(status, j->error_index, "%s", msg[0] ? msg : "job failed");
}

static locd_status job_check(const locd_job *j)
{
    if (!j)
        return lc_error(LOCD_ERR_INVALID_HANDLE, "job is NULL");
    if (j->magic != LC_MAGIC_JOB)
        return lc_error(LOCD_ERR_INVALID_HANDLE, "not a locd_job handle (released?)");
    return LOCD_OK;
}

locd_status locd_job_poll(locd_job *job)
{
    locd_status st = job_check(job);
    if (st)
        return st;
    pthread_mutex_lock(&job->mu);
    st = job->status;
    pthread_mutex_unlock(&job->mu);
    if (st < 0)
        return raise_job_error(job, st);
    lc_clear_error();
    return st;
}

locd_status locd_job_wait(locd_job *job, int64_t timeout_ms)
{
    struct timespec dl;
    locd_status st = job_check(job);
    if (st)
        return st;
    clock_gettime(CLOCK_MONOTONIC, &dl);
    if (timeout_ms > 0) {
        int64_t cap = timeout_ms > (int64_t)1e12 ? (int64_t)1e12 : timeout_ms; /* no time_t overflow */
        dl.tv_sec += (time_t)(cap / 1000);
        dl.tv_nsec += (long)(cap % 1000) * 1000000L;
        if (dl.tv_nsec >= 1000000000L) {
            dl.tv_sec++;
            dl.tv_nsec -= 1000000000L;
        }
    }
    pthread_mutex_lock(&job->mu);
    while (job->status == LOCD_PENDING) {
        if (timeout_ms < 0)
            pthread_cond_wait(&job->cv, &job->mu);
        else if (timeout_ms == 0 || pthread_cond_timedwait(&job->cv, &job->mu, &dl) == ETIMEDOUT)
            break;
    }
    st = job->status;
    pthread_mutex_unlock(&job->mu);
    if (st == LOCD_PENDING)
        return lc_error(LOCD_ERR_TIMEOUT, "job still running after %lld ms", (long long)timeout_ms);
    if (st < 0)
        return raise_job_error(job, st);
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_job_take(locd_job *job, locd_pairs *out)
{
    locd_status st = job_check(job);
    if (st)
        return st;
    if ((st = lc_pairs_check(out)) != LOCD_OK)
        return st;
    pthread_mutex_lock(&job->mu);
    st = job->status;
    if (st == LOCD_OK && job->taken)
        st = LOCD_ERR_INVALID_ARGUMENT;
    else if (st == LOCD_OK)
        st = lc_pairs_give(&job->result, out);
    if (st == LOCD_OK) { /* the job keeps out's old buffer, if any: free it now */
        job->taken = 1;
        lc_pairs_fini_embedded(&job->result);
        lc_pairs_init_embedded(&job->result, &job->alloc);
    }
    pthread_mutex_unlock(&job->mu);
    if (st == LOCD_PENDING) {
        lc_clear_error();
        return LOCD_PENDING;
    }
    if (st == LOCD_ERR_INVALID_ARGUMENT)
        return lc_error(st, "the job's result was already taken");
    if (st == LOCD_ERR_NO_MEMORY)
        return lc_error(st, "could not grow the pairs buffer");
    if (st < 0)
        return raise_job_error(job, st);
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_job_stats(const locd_job *job, locd_stats *stats)
{
    return locd_job_get_stats(job, stats);
}

locd_status locd_job_get_stats(const locd_job *job, locd_stats *stats)
{
    locd_status st = job_check(job);
    if (st || (st = lc_stats_check_out(stats)) != LOCD_OK)
        return st;
    pthread_mutex_lock((pthread_mutex_t *)&job->mu);
    st = job->status;
    if (st == LOCD_OK)
        lc_stats_copy_out(stats, &job->stats);
    pthread_mutex_unlock((pthread_mutex_t *)&job->mu);
    if (st < 0)
        return raise_job_error(job, st);
    lc_clear_error();
    return st;
}

/* Cancels without touching the thread's last error (used by release):
 * the job finishes as cancelled, if it was still pending, and its runner
 * is told. */
static void job_cancel(locd_job *job)
{
    int settled;
    pthread_mutex_lock(&job->mu);
    settled = settle_locked(job, LOCD_ERR_CANCELLED, "cancelled by the caller", -1);
    if (settled)
        pthread_cond_broadcast(&job->cv);
    pthread_mutex_unlock(&job->mu);
    if (settled && job->ops->cancel)
        job->ops->cancel(job);
}

locd_status locd_job_cancel(locd_job *job)
{
    locd_status st = job_check(job);
    if (st)
        return st;
    job_cancel(job);
    lc_clear_error();
    return LOCD_OK;
}

void locd_job_release(locd_job *job)
{
    if (!job || job->magic != LC_MAGIC_JOB)
        return;
    job_cancel(job);
    if (job->ops->released)
        job->ops->released(job);
    lc_job_unref(job);
}
