/* The asynchronous job handle shared by job.c (generic jobs of levels 1 and
 * 2) and service_client.c (level-3 jobs run by the service). */
#ifndef LOCD_JOB_INTERNAL_H
#define LOCD_JOB_INTERNAL_H

#include "engine_internal.h"

#include <pthread.h>

#define LC_JOB_GENERIC 1
#define LC_JOB_SERVICE 2

struct lc_svc_conn; /* service_client.c */

struct locd_job {
    uint32_t magic;
    int kind;
    locd_allocator alloc;
    pthread_mutex_t mu;
    pthread_cond_t cv; /* signalled when status leaves LOCD_PENDING */
    int refs;          /* the caller's handle + the thread / connection running it */
    locd_status status; /* LOCD_PENDING until finished */
    int cancelled;
    int taken;
    char message[256]; /* error detail, raised again on the caller's thread */
    int64_t error_index; /* locd_last_error_index() of that error */
    locd_pairs result;
    locd_stats stats;
    double t_submit; /* lc_now_ms() at submit */

    /* generic jobs */
    locd_engine *engine;
    void *boxes; /* private copy */
    size_t bytes;
    size_t n;
    int f64;
    uint32_t flags;
    locd_status status_pending_result; /* the runner's outcome, published by lc_job_finish */
    int64_t error_pending_index;
    char run_message[256];

    /* service jobs */
    struct lc_svc_conn *conn;
    uint64_t id;
    char shm_name[64]; /* bulk input segment to unlink when done ("" = none) */
    struct locd_job *next; /* in the connection's pending list, or the engine's job queue */
};

/* Allocates a job with one reference held by the caller and one by the
 * runner; status LOCD_PENDING. */
locd_status lc_job_new(const locd_allocator *a, int kind, locd_job **out);
/* Records the final status (and error message when status < 0) unless the
 * job already finished (e.g. cancelled); wakes waiters. */
void lc_job_finish(locd_job *j, locd_status status, const char *message, int64_t index);
/* lc_job_finish and lc_job_unref under one lock: the runner holds nothing
 * once a waiter wakes up. */
void lc_job_finish_unref(locd_job *j, locd_status status, const char *message, int64_t index);
/* Drops one reference; the last one frees the job. */
void lc_job_unref(locd_job *j);

/* Level 3: service_client.c */
void lc_service_job_cancel(locd_job *j);
void lc_service_job_released(locd_job *j);

#endif
