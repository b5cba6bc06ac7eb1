/* lib/engine: the engine handle, the interface each integration level
 * implements (lc_backend), and the asynchronous job handle. Private; not
 * installed. */
#ifndef LOCD_ENGINE_H
#define LOCD_ENGINE_H

#include "core/core.h"

#include <pthread.h>

struct locd_engine;

typedef struct lc_backend {
    const char *name;
    /* Starts the level's resources (threads, worker processes, connection). */
    locd_status (*open)(struct locd_engine *e);
    void (*close)(struct locd_engine *e);
    /* Finds the pairs of boxes (float or double, per f64) into *out, replacing
     * its contents, and fills *stats. On error *out must be left unchanged.
     * Honors LOCD_FIND_SORTED. */
    locd_status (*find)(struct locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags, locd_pairs *out,
                        locd_stats *stats);
    /* Asynchronous submit; NULL means the generic job (job.c) that runs find
     * on a thread of its own. */
    locd_status (*submit)(struct locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags,
                          locd_job **out);
} lc_backend;

extern const lc_backend lc_inproc_backend;  /* levels/inproc.c */
extern const lc_backend lc_workers_backend; /* levels/workers.c */
extern const lc_backend lc_service_backend; /* service/client.c */

struct locd_engine {
    uint32_t magic;
    locd_allocator alloc;
    locd_engine_config cfg; /* strings point to the owned copies below */
    char *service_address;
    char *service_secret;
    char *worker_path;
    int32_t level;
    uint32_t threads;
    int busy; /* taken with __atomic builtins: one call at a time */
    int job_threads; /* job queue threads still alive (job.c); destroy waits for 0 */
    locd_stats stats;
    locd_pairs last; /* results of *_into calls */
    const lc_backend *ops;
    void *backend; /* the level's own state */
};

/* Validates an engine handle. */
locd_status lc_engine_check(const struct locd_engine *e);
/* Validates the arguments every find and submit call shares (handle, boxes,
 * n, flags). */
locd_status lc_check_request(const struct locd_engine *e, const void *boxes, size_t n, uint32_t flags);
int lc_engine_acquire(struct locd_engine *e);
void lc_engine_release(struct locd_engine *e);
/* Emits a log line through the engine's log hook, if any. */
void lc_engine_log(const struct locd_engine *e, int32_t severity, const char *fmt, ...) LC_PRINTF(3, 4);
/* Checks a caller's locd_stats (NULL, size) before anything is copied into it. */
locd_status lc_stats_check_out(const locd_stats *stats);
/* Copies src into a checked caller struct, keeping the caller's size: an
 * older, shorter locd_stats gets only the fields it has. */
void lc_stats_copy_out(locd_stats *dst, const locd_stats *src);
/* Sorts the first `count` pairs of p by (i, j), timing it into stats->ms_order. */
locd_status lc_order_pairs(locd_pairs *p, locd_stats *stats);

/* ---- jobs (job.c) ---- */
#define LC_JOB_GENERIC 1
#define LC_JOB_SERVICE 2

struct lc_svc_conn; /* service/client.c */

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

/* Level 3: service/client.c */
void lc_service_job_cancel(locd_job *j);
void lc_service_job_released(locd_job *j);

#endif
