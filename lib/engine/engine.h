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
    /* Asynchronous submit; NULL means the generic job (submit.c), queued on
     * the engine and run with find on a thread of its own. */
    locd_status (*submit)(struct locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags,
                          locd_job **out);
    /* The two-set query on one array: objects [0, split) are set a, [split,
     * n) set b; only pairs (i in a, j in b) are reported, as (i, j - split).
     * Same contract as find otherwise. NULL: the level does not offer it
     * (locd_engine_find_pairs_between_* returns LOCD_ERR_UNSUPPORTED). */
    locd_status (*find_between)(struct locd_engine *e, const void *boxes, size_t n, size_t split, int f64,
                                uint32_t flags, locd_pairs *out, locd_stats *stats);
} lc_backend;

extern const lc_backend lc_inproc_backend;  /* levels/inproc.c */
extern const lc_backend lc_workers_backend; /* levels/workers.c */
extern const lc_backend lc_service_backend; /* service/client.c */

struct lc_queued_job; /* submit.c */

/* A cooperative stop for a running find, set by the service on its
 * runners' engines (NULL check everywhere else: a normal find never looks).
 * check is called from any thread of the find (it must be thread-safe)
 * between stages and between blocks of the sweep, with the pairs found so
 * far by this call; it returns 0 to go on or the status (< 0) the find
 * then fails with. Only level 1 calls it. */
typedef struct lc_stop {
    int (*check)(void *user, uint64_t pairs);
    void *user;
    /* NULL, or a flag raised (by any thread) to stop the find at once: the
       sweep polls it inside its cells too (lc_sweep_out.stop), so a
       dense cell of seconds of work is cut short; the find then fails
       with LOCD_ERR_CANCELLED. */
    const int *flag;
} lc_stop;

/* Levels 1 and 2: the engine's queue of generic jobs (submit.c), drained
 * by one thread at a time. Guarded by the engine's mu. */
typedef struct lc_job_queue {
    struct lc_queued_job *head, *tail;
    int draining; /* a thread holds the engine's busy flag for the queue */
    int threads;  /* queue threads not yet exited: they still use the engine's mu */
} lc_job_queue;

struct locd_engine {
    uint32_t magic;
    locd_allocator alloc;
    locd_engine_config cfg; /* strings point to the owned copies below */
    char *service_address;
    char *service_secret;
    char *worker_path;
    int32_t level;
    uint32_t threads;
    pthread_mutex_t mu;  /* busy and queue */
    pthread_cond_t idle; /* broadcast when busy drops to 0 or a queue thread exits */
    int busy;            /* one call at a time: a find, or the queue while it has jobs */
    lc_job_queue queue;
    locd_stats stats;
    locd_pairs last; /* results of *_into calls */
    const lc_backend *ops;
    void *backend; /* the level's own state */
    lc_stop stop;  /* all NULL unless the service set it */
};

/* ---- helpers the engine shares with its jobs and levels (shared.c) ----
 * shared.c names no backend, so a level calling these never calls back
 * into engine.c, which refers to the levels' tables. */

/* Validates an engine handle. */
locd_status lc_engine_check(const struct locd_engine *e);
/* Validates the arguments every find and submit call shares (handle, boxes,
 * n, flags). */
locd_status lc_check_request(const struct locd_engine *e, const void *boxes, size_t n, uint32_t flags);
/* Takes the engine's busy flag; 0 when another call or the job queue has it. */
int lc_engine_acquire(struct locd_engine *e);
/* Gives the busy flag back and wakes a destroy waiting for it. */
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

/* ---- jobs (job.c) ----
 * A job is a common part (locd_job, below) and its kind's own data: the
 * generic queued job of levels 1 and 2 (submit.c) or a service job
 * (service/client.c). Each kind embeds locd_job as its first member and
 * casts back to its own struct: one allocation and one lifetime for both
 * parts, where a separate kind_data pointer would need a second allocation
 * with its own failure path. job.c reaches the kind only through its
 * lc_job_ops table, so it names no level. */

typedef struct lc_job_ops {
    size_t size; /* of the kind's struct, which starts with a locd_job */
    /* The caller cancelled the job while it was pending (it has already
       finished as LOCD_ERR_CANCELLED): tell the runner. NULL: nothing to tell. */
    void (*cancel)(locd_job *j);
    /* The caller released its handle, or submit failed before the runner
       got the job: drop what the caller's side holds. May be NULL. */
    void (*released)(locd_job *j);
    /* The last reference is gone: free the kind's own buffers (not the job
       itself). May be NULL. */
    void (*free)(locd_job *j);
} lc_job_ops;

struct locd_job {
    uint32_t magic;
    const lc_job_ops *ops;
    locd_allocator alloc;
    pthread_mutex_t mu;
    pthread_cond_t cv;  /* signalled when status leaves LOCD_PENDING */
    int refs;           /* the caller's handle + the thread / connection running it */
    locd_status status; /* LOCD_PENDING until finished */
    int taken;
    char message[256];   /* error detail, raised again on the caller's thread */
    int64_t error_index; /* locd_last_error_index() of that error */
    locd_pairs result;
    locd_stats stats;
    double t_submit; /* lc_now_ms() at submit */
};

/* Allocates a job of ops->size bytes, zeroed, with one reference held by
 * the caller and one by the runner; status LOCD_PENDING. */
locd_status lc_job_new(const locd_allocator *a, const lc_job_ops *ops, locd_job **out);
/* Records the final status (and error message when status < 0) unless the
 * job already finished (e.g. cancelled), wakes waiters and drops the
 * runner's reference, under one lock: the runner holds nothing once a
 * waiter wakes up. */
void lc_job_finish_unref(locd_job *j, locd_status status, const char *message, int64_t index);
/* Drops one reference; the last one frees the job. */
void lc_job_unref(locd_job *j);
/* Frees a job whose submit failed before its runner got it: the kind's
 * released hook, then the memory. */
void lc_job_discard(locd_job *j);

#endif
