/* lib/levels: integration levels 1 (inproc.c) and 2 (workers.c, with the
 * locd-worker process in worker_main.c). Private; not installed.
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
#define LC_SHM_VERSION 1u
#define LC_SHM_MAX_WORKERS 64
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
    int32_t reserved;
    lc_shm_slot slot[LC_SHM_MAX_WORKERS];
} lc_shm_ctl;

#endif
