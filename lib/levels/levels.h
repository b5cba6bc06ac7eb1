/* lib/levels: integration levels 1 (inproc.c) and 2 (workers.c, with the
 * locd-worker process in worker_main.c), and the work split both plan with
 * (plan.c). Private; not installed.
 *
 * Level 2: the shared-memory control block between the library (the
 * caller, in its own process) and its locd-worker processes. Private to the
 * library and levels/worker_main.c; both are built from one tree, and the
 * magic + version check refuses a worker from another build.
 *
 * Two segments per engine, both POSIX shm, mode 0600, unique names, unlinked
 * as soon as every worker has mapped them:
 *  - control (this struct): one slot per worker with two process-shared
 *    POSIX semaphores (go: caller -> worker, done: worker -> caller);
 *  - data: the boxes (n rows of 6 floats or doubles, from offset 0), then one
 *    entry region per worker. It is replaced by a larger one when a call
 *    needs more room; data_gen tells the workers to map the new one. */
#ifndef LOCD_LEVELS_H
#define LOCD_LEVELS_H

#include "engine/engine.h"
#include "octree/octree.h"

#include <semaphore.h>
#include <stdint.h>

#define LC_SHM_MAGIC LC_MAGIC_SHM /* valued in core.h, distinct from every handle's */
#define LC_SHM_VERSION 2u
#define LC_SHM_NAME_MAX 64

#define LC_SHM_CMD_RUN 1
#define LC_SHM_CMD_EXIT 2

typedef struct lc_shm_slot {
    sem_t go;
    sem_t done;
    /* caller -> worker */
    uint64_t first, count; /* boxes [first, first+count) */
    uint64_t offset;       /* entry region: byte offset in the data segment */
    uint64_t capacity;     /* entries */
    /* worker -> caller */
    uint64_t written; /* entries written; the needed capacity on overflow */
    int32_t status;   /* LOCD_OK, LOCD_ERR_BUFFER_TOO_SMALL, ... */
    int32_t pid;
    double ms_encode, ms_sort;
    char pad[64];
} lc_shm_slot;

typedef struct lc_shm_ctl {
    uint32_t magic, version;
    uint32_t workers;
    int32_t command; /* LC_SHM_CMD_* for this round */
    uint64_t data_gen;
    uint64_t data_size;
    char data_name[LC_SHM_NAME_MAX];
    char ctl_name[LC_SHM_NAME_MAX];
    locd_grid grid;
    uint64_t n;
    int32_t f64;
    int32_t kernel; /* LC_KERNEL_* the engine chose at creation: its workers use it too */
    lc_shm_slot slot[LC_MAX_THREADS];
} lc_shm_ctl;

/* ---- level 1's pool, lent to the scene (inproc.c) ----
 * The thread pool of a level-1 engine and the kernel it chose; the scene
 * runs its steps on them while it holds the engine's busy flag. */
lc_pool *lc_inproc_pool(struct locd_engine *e, int *kernel);
/* The engine's buffer of packed boxes, room for n objects (NULL: no
 * memory): scratch of each call, which the scene fills for its kept list's
 * sweep (the list's encode, or a move of every object) while it holds the
 * engine. */
uint64_t *lc_inproc_qbox(struct locd_engine *e, size_t n);
/* Counts that buffer's writers: the engine's finds and the calls of
 * lc_inproc_qbox. The same count before and after some work means nobody
 * else could write the buffer in between. */
uint64_t lc_inproc_qbox_epoch(const struct locd_engine *e);
/* Where a sweep's pairs can go instead of the hand-over: fn(arg, t, pairs,
 * count) gets each block of about LC_SINK_BLOCK entries' pairs (i, j),
 * i < j, two uint32 each, on pool thread t right after the block is swept,
 * while they are in the caches; it may overwrite them (the sweep drops them
 * after). A status other than LOCD_OK stops the sweep and is returned as it
 * is (no error is recorded for it). */
typedef struct lc_pair_sink {
    locd_status (*fn)(void *arg, uint32_t t, uint32_t *pairs, size_t count);
    void *arg;
} lc_pair_sink;
#define LC_SINK_BLOCK ((size_t)1 << 15)
/* The sweep and the hand-over of a level-1 find, on entries the caller
 * encoded on grid g and sorted (the scene's kept list): boxes, their packed
 * boxes qbox (2 per object, as the encode writes them; NULL: the engine's
 * buffer, lc_inproc_qbox's) and the entries stay the caller's. The pairs
 * and their order are those of a find whose own encode and sort gave the
 * same entries. With a sink, the pairs go to it, in no set order, and out
 * is untouched (stats->pairs counts them). */
locd_status lc_inproc_sweep_sorted(struct locd_engine *e, const locd_grid *g, const float *boxes,
                                   const uint64_t *qbox, size_t n, const uint64_t *sorted, size_t total,
                                   const lc_pair_sink *sink, locd_pairs *out, locd_stats *stats);

/* ---- planning (plan.c): the work split levels 1 and 2 share ----
 * n objects go in k shares of near-equal size (contiguous, in order: the
 * merged result does not depend on k); share t encodes into region t of an
 * entry buffer, sized from the entries per object of the engine's last call
 * and redone with exact sizes when a region overflows. */
typedef struct lc_plan {
    uint32_t k;                           /* shares */
    size_t cap[LC_MAX_THREADS];           /* region capacity, entries */
    size_t off[LC_MAX_THREADS];           /* region start, entries after the first region's */
    size_t cnt[LC_MAX_THREADS];           /* entries written */
    const uint64_t *runs[LC_MAX_THREADS]; /* sorted runs, cnt[t] entries each */
    size_t total;                         /* entries of all shares */
} lc_plan;
/* Where share t (0..k; t = k gives n) of n items begins. */
size_t lc_chunk_begin(size_t n, uint32_t t, uint32_t k);
/* The entries per object to plan with before a first call. */
double lc_entries_per_object_guess(int32_t cell_bias);
/* Entry capacity for m objects at per_object entries each, with slack,
 * never more than m objects can write (LOCD_MAX_ENTRIES_PER_BOX each). */
size_t lc_region_capacity(size_t m, double per_object);
/* Sizes the region of every share of n objects (p->k shares). */
void lc_plan_regions(lc_plan *p, size_t n, double per_object);
/* Lays the regions out back to back (p->off); returns their total capacity. */
size_t lc_plan_layout(lc_plan *p);
/* Sums the entries written into p->total; returns the entries per object
 * the next call of n objects plans with. */
double lc_plan_finish(lc_plan *p, size_t n);

#endif
