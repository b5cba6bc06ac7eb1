/* Asynchronous jobs at every level.
 *
 * Levels 1 and 2 use the generic job: submit copies the boxes and queues
 * the job on the engine; one thread per engine runs the queued jobs one
 * after another with the level's own `find`, holding the engine meanwhile
 * (a synchronous find on that engine gets LOCD_ERR_BUSY until the queue is
 * empty, and a submit while a find runs on another thread gets
 * LOCD_ERR_BUSY). Level 3 hands the job to the service (service/client.c),
 * which runs many jobs of one engine at once.
 *
 * A job holds two references: the caller's handle (dropped by
 * locd_job_release) and the runner's (the thread, or the service
 * connection). Cancel finishes a pending job at once with
 * LOCD_ERR_CANCELLED; a queued generic job is then skipped, a running one
 * cannot be interrupted inside the engine: the engine stays busy until that
 * call returns, and its result is discarded. */
#include "engine/engine.h"

#include <errno.h>
#include <stdio.h>
#include <time.h>

locd_status lc_job_new(const locd_allocator *a, int kind, locd_job **out)
{
    pthread_condattr_t ca;
    locd_job *j = lc_alloc(a, sizeof *j);
    *out = NULL;
    if (!j)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the job");
    memset(j, 0, sizeof *j);
    j->alloc = *a;
    j->kind = kind;
    if (pthread_mutex_init(&j->mu, NULL) != 0) {
        lc_free(a, j, sizeof *j);
        return lc_error(LOCD_ERR_THREAD, "pthread_mutex_init failed");
    }
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC); /* timeouts immune to clock changes */
    if (pthread_cond_init(&j->cv, &ca) != 0) {
        pthread_condattr_destroy(&ca);
        pthread_mutex_destroy(&j->mu);
        lc_free(a, j, sizeof *j);
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

void lc_job_finish(locd_job *j, locd_status status, const char *message, int64_t index)
{
    pthread_mutex_lock(&j->mu);
    if (settle_locked(j, status, message, index))
        pthread_cond_broadcast(&j->cv);
    pthread_mutex_unlock(&j->mu);
}

static void job_free(locd_job *j)
{
    locd_allocator a = j->alloc;
    lc_pairs_fini_embedded(&j->result);
    if (j->boxes)
        lc_free(&a, j->boxes, j->bytes);
    pthread_cond_destroy(&j->cv);
    pthread_mutex_destroy(&j->mu);
    j->magic = LC_MAGIC_DEAD;
    lc_free(&a, j, sizeof *j);
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

/* Levels 1 and 2: one queue of generic jobs per busy engine, drained by one
 * detached thread that holds the engine (its busy flag) until the queue is
 * empty. The queues live in a small global list: the engine struct has no
 * room for them, and there are only as many as engines with jobs. */
typedef struct lc_job_queue {
    locd_engine *e;
    locd_allocator alloc;
    locd_job *head, *tail;
    struct lc_job_queue *next;
} lc_job_queue;

static pthread_mutex_t g_queues_mu = PTHREAD_MUTEX_INITIALIZER;
static lc_job_queue *g_queues;

/* Under g_queues_mu. */
static lc_job_queue *queue_of(const locd_engine *e)
{
    lc_job_queue *q;
    for (q = g_queues; q; q = q->next)
        if (q->e == e)
            return q;
    return NULL;
}

/* Under g_queues_mu. */
static void queue_unlink(lc_job_queue *q)
{
    lc_job_queue **pp;
    for (pp = &g_queues; *pp; pp = &(*pp)->next)
        if (*pp == q) {
            *pp = q->next;
            return;
        }
}

static void run_generic(locd_job *j, locd_engine *e)
{
    locd_stats st;
    locd_status s;
    int cancelled;
    double t0;
    pthread_mutex_lock(&j->mu);
    cancelled = j->status != LOCD_PENDING;
    pthread_mutex_unlock(&j->mu);
    locd_stats_init(&st);
    if (cancelled) {
        s = LOCD_ERR_CANCELLED;
    } else {
        t0 = lc_now_ms();
        s = e->ops->find(e, j->boxes, j->n, j->f64, j->flags, &j->result, &st);
        st.ms_total = lc_now_ms() - t0;
        st.ms_transfer += t0 - j->t_submit; /* time spent queued */
        if (!s) {
            j->stats = st;
            e->stats = st; /* a job is a call of this engine */
        }
    }
    lc_free(&j->alloc, j->boxes, j->bytes);
    j->boxes = NULL;
    j->status_pending_result = s;
    j->error_pending_index = s ? locd_last_error_index() : -1;
    if (s)
        snprintf(j->run_message, sizeof j->run_message, "%s", lc_last_error_detail());
}

static void *queue_main(void *arg)
{
    lc_job_queue *q = arg;
    locd_engine *e = q->e;
    locd_allocator a = q->alloc;
    for (;;) {
        locd_job *j;
        int last;
        pthread_mutex_lock(&g_queues_mu);
        j = q->head;
        q->head = j->next;
        if (!q->head)
            q->tail = NULL;
        j->next = NULL;
        pthread_mutex_unlock(&g_queues_mu);

        run_generic(j, e);

        /* The last job gives the engine back before it wakes its waiters (a
           waiter may call find at once); the engine is not touched after. */
        pthread_mutex_lock(&g_queues_mu);
        last = q->head == NULL;
        if (last) {
            queue_unlink(q);
            lc_engine_release(e);
        }
        pthread_mutex_unlock(&g_queues_mu);
        if (last)
            lc_free(&a, q, sizeof *q);
        /* Finished and let go in one step: once a waiter wakes, this thread
           holds nothing, so the caller's release frees the job itself. */
        lc_job_finish_unref(j, j->status_pending_result, j->run_message, j->error_pending_index);
        if (last) {
            /* Last touch of the engine: destroy waits for this before it
               frees anything (the allocator is used above). */
            __atomic_sub_fetch(&e->job_threads, 1, __ATOMIC_RELEASE);
            return NULL;
        }
    }
}

static locd_status generic_submit(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags,
                                  locd_job **out)
{
    pthread_attr_t attr;
    pthread_t th;
    lc_job_queue *q;
    locd_job *j;
    locd_status st = LOCD_OK;
    size_t bytes;
    if (!lc_mul_size(n ? n : 1, 6 * (f64 ? sizeof(double) : sizeof(float)), &bytes))
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "%zu boxes do not fit in memory", n);
    if ((st = lc_job_new(&e->alloc, LC_JOB_GENERIC, &j)) != LOCD_OK)
        return st;
    j->boxes = lc_alloc(&e->alloc, bytes);
    if (!j->boxes) {
        j->refs = 1;
        lc_job_unref(j);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not copy %zu bytes of boxes", bytes);
    }
    if (n)
        memcpy(j->boxes, boxes, n * 6 * (f64 ? sizeof(double) : sizeof(float)));
    j->bytes = bytes;
    j->engine = e;
    j->n = n;
    j->f64 = f64;
    j->flags = flags;

    pthread_mutex_lock(&g_queues_mu);
    if ((q = queue_of(e)) != NULL) { /* jobs already running: queue behind them */
        if (q->tail)
            q->tail->next = j;
        else
            q->head = j; /* the thread took the last one and is running it */
        q->tail = j;
        pthread_mutex_unlock(&g_queues_mu);
        *out = j;
        return LOCD_OK;
    }
    if (!lc_engine_acquire(e)) {
        st = lc_error(LOCD_ERR_BUSY, "the engine is inside a find call on another thread");
    } else if ((q = lc_alloc(&e->alloc, sizeof *q)) == NULL) {
        lc_engine_release(e);
        st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the job queue");
    } else {
        memset(q, 0, sizeof *q);
        q->e = e;
        q->alloc = e->alloc;
        q->head = q->tail = j;
        q->next = g_queues;
        g_queues = q;
        pthread_attr_init(&attr);
        pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
        __atomic_add_fetch(&e->job_threads, 1, __ATOMIC_RELAXED);
        if (pthread_create(&th, &attr, queue_main, q) != 0) {
            __atomic_sub_fetch(&e->job_threads, 1, __ATOMIC_RELAXED);
            queue_unlink(q);
            lc_free(&e->alloc, q, sizeof *q);
            lc_engine_release(e);
            st = lc_error(LOCD_ERR_THREAD, "could not start the job thread");
        }
        pthread_attr_destroy(&attr);
    }
    pthread_mutex_unlock(&g_queues_mu);
    if (st) {
        j->refs = 1;
        lc_job_unref(j);
        return st;
    }
    *out = j;
    return LOCD_OK;
}

static locd_status submit_common(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags,
                                 locd_job **out)
{
    locd_status st;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    if ((st = lc_check_request(e, boxes, n, flags)) != LOCD_OK)
        return st;
    st = e->ops->submit ? e->ops->submit(e, boxes, n, f64, flags, out) : generic_submit(e, boxes, n, f64, flags, out);
    if (!st)
        lc_clear_error();
    return st;
}

locd_status locd_engine_submit_f32(locd_engine *engine, const float *boxes, size_t n, uint32_t flags,
                                   locd_job **out)
{
    return submit_common(engine, boxes, n, 0, flags, out);
}

locd_status locd_engine_submit_f64(locd_engine *engine, const double *boxes, size_t n, uint32_t flags,
                                   locd_job **out)
{
    return submit_common(engine, boxes, n, 1, flags, out);
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
        st = lc_pairs_reserve(out, job->result.count);
    if (st == LOCD_OK) {
        if (job->result.count)
            memcpy(out->data, job->result.data, job->result.count * 2 * sizeof(uint32_t));
        out->count = job->result.count;
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

/* Cancels without touching the thread's last error (used by release). */
static void job_cancel(locd_job *job)
{
    int was_pending;
    pthread_mutex_lock(&job->mu);
    was_pending = job->status == LOCD_PENDING;
    job->cancelled = 1;
    pthread_mutex_unlock(&job->mu);
    if (was_pending) {
        lc_job_finish(job, LOCD_ERR_CANCELLED, "cancelled by the caller", -1);
        if (job->kind == LC_JOB_SERVICE)
            lc_service_job_cancel(job);
    }
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
    if (job->kind == LC_JOB_SERVICE)
        lc_service_job_released(job);
    lc_job_unref(job);
}
