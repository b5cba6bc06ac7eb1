/* Asynchronous submit (locd_engine_submit_*). Level 3 hands the job to its
 * backend (service/client.c), which runs many jobs of one engine at once.
 *
 * Levels 1 and 2 use the generic job: submit copies the boxes and queues
 * the job on the engine; one thread at a time runs the queued jobs one
 * after another with the level's own `find`, holding the engine's busy
 * flag meanwhile (a synchronous find on that engine gets LOCD_ERR_BUSY
 * until the queue is empty, and a submit while a find runs on another
 * thread gets LOCD_ERR_BUSY). A cancelled job still queued is skipped; a
 * running one cannot be interrupted inside the engine: the engine stays
 * busy until that call returns, and its result is discarded. */
#include "engine/engine.h"

#include <stdio.h>

/* A generic job: the common part first (see engine.h), then the request
 * and the runner's outcome. */
typedef struct lc_queued_job {
    locd_job job;
    void *boxes; /* private copy, freed once run */
    size_t bytes;
    size_t n;
    int f64;
    uint32_t flags;
    locd_status outcome; /* published by lc_job_finish_unref */
    int64_t outcome_index;
    char outcome_message[256];
    struct lc_queued_job *next; /* in the engine's queue */
} lc_queued_job;

static void queued_free(locd_job *j)
{
    lc_queued_job *q = (lc_queued_job *)j;
    if (q->boxes)
        lc_free(&j->alloc, q->boxes, q->bytes);
}

/* Nothing to tell the queue on cancel: the thread skips a job that is no
 * longer pending, and discards the result of one it is running. */
static const lc_job_ops queued_ops = {sizeof(lc_queued_job), NULL, NULL, queued_free};

/* Runs one job with the level's find into its result (or skips it when
 * cancelled) and keeps the outcome for lc_job_finish_unref. */
static void run_queued(lc_queued_job *q, locd_engine *e)
{
    locd_job *j = &q->job;
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
        s = e->ops->find(e, q->boxes, q->n, q->f64, q->flags, &j->result, &st);
        st.ms_total = lc_now_ms() - t0;
        st.ms_transfer += t0 - j->t_submit; /* time spent queued */
        if (!s) {
            j->stats = st;
            e->stats = st; /* a job is a call of this engine */
        }
    }
    lc_free(&j->alloc, q->boxes, q->bytes);
    q->boxes = NULL;
    q->outcome = s;
    q->outcome_index = s ? locd_last_error_index() : -1;
    if (s)
        snprintf(q->outcome_message, sizeof q->outcome_message, "%s", lc_last_error_detail());
}

/* Takes the next job off the queue, under the engine's lock. */
static lc_queued_job *queue_pop(locd_engine *e)
{
    lc_queued_job *q;
    pthread_mutex_lock(&e->mu);
    q = e->queue.head;
    e->queue.head = q->next;
    if (!e->queue.head)
        e->queue.tail = NULL;
    q->next = NULL;
    pthread_mutex_unlock(&e->mu);
    return q;
}

/* After a job ran: when the queue is empty, gives the engine back (before
 * the job's waiters wake: a waiter may call find at once). Returns whether
 * it did, which ends the thread. */
static int queue_settle(locd_engine *e)
{
    int last;
    pthread_mutex_lock(&e->mu);
    last = e->queue.head == NULL;
    if (last) {
        e->queue.draining = 0;
        e->busy = 0;
        pthread_cond_broadcast(&e->idle);
    }
    pthread_mutex_unlock(&e->mu);
    return last;
}

static void *queue_main(void *arg)
{
    locd_engine *e = arg;
    int last;
    do {
        lc_queued_job *q = queue_pop(e);
        run_queued(q, e);
        last = queue_settle(e);
        /* Finished and let go in one step: once a waiter wakes, this thread
           holds nothing, so the caller's release frees the job itself. */
        lc_job_finish_unref(&q->job, q->outcome, q->outcome_message, q->outcome_index);
    } while (!last);
    /* Last touch of the engine: the job's free above may use the engine's
       allocator, so destroy waits for this before it frees anything. */
    pthread_mutex_lock(&e->mu);
    e->queue.threads--;
    pthread_cond_broadcast(&e->idle);
    pthread_mutex_unlock(&e->mu);
    return NULL;
}

/* Under the engine's lock, with the engine free: takes it for the queue
 * and starts the thread that drains it, beginning with q. */
static locd_status queue_start(locd_engine *e, lc_queued_job *q)
{
    pthread_attr_t attr;
    pthread_t th;
    int rc;
    e->busy = 1;
    e->queue.draining = 1;
    e->queue.threads++;
    e->queue.head = e->queue.tail = q;
    pthread_attr_init(&attr);
    pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
    rc = pthread_create(&th, &attr, queue_main, e);
    pthread_attr_destroy(&attr);
    if (rc == 0)
        return LOCD_OK;
    e->queue.head = e->queue.tail = NULL;
    e->queue.threads--;
    e->queue.draining = 0;
    e->busy = 0;
    pthread_cond_broadcast(&e->idle);
    return lc_error(LOCD_ERR_THREAD, "could not start the job thread");
}

/* Queues q behind the running jobs, or starts the queue when the engine is
 * free; LOCD_ERR_BUSY when a find holds it. */
static locd_status queue_push(locd_engine *e, lc_queued_job *q)
{
    locd_status st = LOCD_OK;
    pthread_mutex_lock(&e->mu);
    if (e->queue.draining) {
        if (e->queue.tail)
            e->queue.tail->next = q;
        else
            e->queue.head = q; /* the thread took the last one and is running it */
        e->queue.tail = q;
    } else if (e->busy) {
        st = lc_error(LOCD_ERR_BUSY, "the engine is inside a find call on another thread");
    } else {
        st = queue_start(e, q);
    }
    pthread_mutex_unlock(&e->mu);
    return st;
}

static locd_status generic_submit(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags,
                                  locd_job **out)
{
    lc_queued_job *q;
    locd_job *j;
    locd_status st;
    size_t bytes;
    if (!lc_mul_size(n ? n : 1, 6 * (f64 ? sizeof(double) : sizeof(float)), &bytes))
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "%zu boxes do not fit in memory", n);
    if ((st = lc_job_new(&e->alloc, &queued_ops, &j)) != LOCD_OK)
        return st;
    q = (lc_queued_job *)j;
    q->boxes = lc_alloc(&e->alloc, bytes);
    if (!q->boxes) {
        lc_job_discard(j);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not copy %zu bytes of boxes", bytes);
    }
    if (n)
        memcpy(q->boxes, boxes, n * 6 * (f64 ? sizeof(double) : sizeof(float)));
    q->bytes = bytes;
    q->n = n;
    q->f64 = f64;
    q->flags = flags;
    if ((st = queue_push(e, q)) != LOCD_OK) {
        lc_job_discard(j);
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
