/* The engine handle and the interface each integration level implements. */
#ifndef LOCD_ENGINE_INTERNAL_H
#define LOCD_ENGINE_INTERNAL_H

#include "internal.h"

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

extern const lc_backend lc_inproc_backend;  /* inproc.c */
extern const lc_backend lc_workers_backend; /* shm_workers.c */
extern const lc_backend lc_service_backend; /* service_client.c */

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

#endif
