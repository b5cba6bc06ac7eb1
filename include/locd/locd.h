/*
 * locd: exact all-pairs collision detection on a linear octree.
 *
 * Public C99 API of liblocd's core: engines, pairs, jobs and the building
 * blocks. The other parts have headers of their own, each including this
 * one: locd/scene.h (the persistent scene) and locd/service.h (hosting the
 * level-3 service), also in liblocd; locd/pipeline.h (shapes, narrow phase:
 * liblocd_narrow) and locd/mpi.h (liblocd_mpi), each a library of its own.
 *
 * Everything that crosses this header is an opaque handle, a
 * plain scalar, a pointer to a buffer, or a pointer to a versioned struct whose
 * first field is `size` (set it with the matching locd_*_init() function).
 * Every fallible call returns a locd_status: 0 is success, negatives are
 * errors (see locd_status_string() and locd_last_error()).
 *
 * Versioned structs (docs/abi.md, "the size rules"): a struct passed in
 * (a config) is read up to its `size`, which must lie between the struct's
 * LOCD_*_MIN_SIZE and the library's own sizeof, and fields past `size` get
 * their defaults; a struct filled in (stats) is written up to its `size`
 * and no further, its size in the same range, and `size` itself is left as
 * it was (locd_grid_fit_* says how it treats the grid's size). A call never
 * writes past the caller's `size`.
 *
 * Semantics (docs/api.md has the full reference):
 *   boxes are n rows of 6 values  minx miny minz maxx maxy maxz;
 *   two boxes overlap iff on every axis a.min <= b.max && b.min <= a.max
 *   (closed intervals); the result is exactly the set of overlapping pairs,
 *   i < j, each once, in an order that does not depend on the thread count,
 *   the integration level or the run.
 */
#ifndef LOCD_LOCD_H
#define LOCD_LOCD_H

#include <stddef.h>
#include <stdint.h>

#include "locd/version.h"

#if defined(_WIN32) && defined(LOCD_SHARED_BUILD)
#define LOCD_API __declspec(dllexport)
#elif defined(_WIN32) && !defined(LOCD_STATIC)
#define LOCD_API __declspec(dllimport)
#elif defined(__GNUC__)
#define LOCD_API __attribute__((visibility("default")))
#else
#define LOCD_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------------ */
/* Version                                                            */
/* ------------------------------------------------------------------ */

/* (major << 16) | (minor << 8) | patch of the library actually loaded. */
LOCD_API uint32_t locd_version(void);
/* "MAJOR.MINOR.PATCH" of the library actually loaded. */
LOCD_API const char *locd_version_string(void);

/* ------------------------------------------------------------------ */
/* Status codes and errors                                            */
/* ------------------------------------------------------------------ */

typedef int32_t locd_status;

#define LOCD_OK 0
#define LOCD_PENDING 1                  /* job not finished yet (locd_job_poll) */
#define LOCD_ERR_INVALID_ARGUMENT (-1)  /* bad option, bad `size` field, n too large */
#define LOCD_ERR_NULL_POINTER (-2)      /* a required pointer was NULL */
#define LOCD_ERR_NONFINITE (-3)         /* a coordinate is NaN or +-Inf (index in locd_last_error_index) */
#define LOCD_ERR_INVERTED_BOX (-4)      /* min > max on some axis (index in locd_last_error_index) */
#define LOCD_ERR_NO_MEMORY (-5)         /* an allocation failed; nothing was changed */
#define LOCD_ERR_TOO_MANY_OBJECTS (-6)  /* n does not fit the 32-bit object index */
#define LOCD_ERR_BUFFER_TOO_SMALL (-7)  /* caller buffer too small; required size reported */
#define LOCD_ERR_INVALID_HANDLE (-8)    /* handle is NULL, destroyed or of the wrong kind */
#define LOCD_ERR_BUSY (-9)              /* the engine is in use by another thread or job */
#define LOCD_ERR_THREAD (-10)           /* a thread could not be started */
#define LOCD_ERR_UNSUPPORTED (-11)      /* feature or level not available in this build */
#define LOCD_ERR_WORKER (-12)           /* a worker process failed or died */
#define LOCD_ERR_IO (-13)               /* shared memory, socket or file operation failed */
#define LOCD_ERR_CONNECTION (-14)       /* the service is unreachable or went away */
#define LOCD_ERR_PROTOCOL (-15)         /* malformed or unexpected message */
#define LOCD_ERR_TIMEOUT (-16)          /* a wait ran out of time (the job is still running), or a level-3
                                           job passed its deadline (then finished, the service told to cancel) */
#define LOCD_ERR_CANCELLED (-17)        /* the job was cancelled */
#define LOCD_ERR_AUTH (-18)             /* the service refused the shared secret */
#define LOCD_ERR_SHAPE (-19)            /* a shape description is invalid */
#define LOCD_ERR_STALE_ID (-20)         /* a scene id was removed or never issued (index in locd_last_error_index) */
#define LOCD_ERR_DUPLICATE_ID (-21)     /* a scene id appears twice in one batch (index in locd_last_error_index) */
#define LOCD_ERR_LIMIT (-22)            /* the job exceeds a limit of the service (boxes, pairs, memory, time, jobs in flight) */
#define LOCD_ERR_INTERNAL (-100)        /* a bug: please report it */

/* Static English description of a status code; never NULL. */
LOCD_API const char *locd_status_string(locd_status status);

/* The last error raised on the calling thread (thread-local), as
 * "status text: detail" (the status text is locd_status_string()'s); "" when
 * the last call succeeded: every call that returns a status >= 0 (LOCD_OK,
 * LOCD_PENDING) clears it; calls that return no status (counts, pointers,
 * void) leave it as it was. The string stays valid until the next locd call
 * on this thread. */
LOCD_API const char *locd_last_error(void);

/* Index of the first bad box for LOCD_ERR_NONFINITE / LOCD_ERR_INVERTED_BOX
 * raised on the calling thread, or -1. */
LOCD_API int64_t locd_last_error_index(void);

/* ------------------------------------------------------------------ */
/* User hooks: allocator and log                                      */
/* ------------------------------------------------------------------ */

/* All memory an engine uses comes from these functions when they are set.
 * alloc returns memory aligned to at least 16 bytes, or NULL on failure
 * (locd then returns LOCD_ERR_NO_MEMORY and leaks nothing). free receives the
 * size that was asked for. Leave both NULL for malloc/free.
 *
 * Which allocator a handle uses: an engine, its pairs and jobs and the
 * world that owns it use config->allocator; a locd_pairs the one given to
 * locd_pairs_create. The exceptions, which use malloc/free:
 *   - handles whose constructor takes no allocator: shapes (locd_shape_*),
 *     contacts (locd_contacts_create), the service (locd_service_create) and
 *     the engines of its job runners;
 *   - memory libccd and FCL allocate themselves inside a shape test
 *     (operator new, malloc): locd cannot reach it;
 *   - level 2's shared memory segments (shm_open + mmap) and level 3's
 *     sockets are kernel objects, not heap memory. */
typedef struct locd_allocator {
    void *(*alloc)(size_t size, void *user);
    void (*free)(void *ptr, size_t size, void *user);
    void *user;
} locd_allocator;

#define LOCD_LOG_ERROR 0
#define LOCD_LOG_WARNING 1
#define LOCD_LOG_INFO 2
#define LOCD_LOG_DEBUG 3

typedef void (*locd_log_fn)(int32_t severity, const char *message, void *user);

/* ------------------------------------------------------------------ */
/* Engine configuration                                               */
/* ------------------------------------------------------------------ */

#define LOCD_LEVEL_INPROCESS 1 /* threads in the caller's process */
#define LOCD_LEVEL_WORKERS 2   /* worker processes, POSIX shared memory + semaphores */
#define LOCD_LEVEL_SERVICE 3   /* separate service process, asynchronous jobs */

/* The largest max_depth, and the deepest a grid may say it is: the sweep
 * compares cells on 21-bit coordinates, exact for levels up to 21 (see
 * docs/encoding.md). The 64-bit entry also has to hold 3 bits per level,
 * the 5-bit level and the index bits, so a fitted grid is shallower still
 * (at most 19 levels, and fewer as objects grow). */
#define LOCD_MAX_DEPTH 21

typedef struct locd_engine_config {
    uint32_t size;               /* sizeof(locd_engine_config) */
    int32_t level;               /* LOCD_LEVEL_*; default LOCD_LEVEL_INPROCESS */
    uint32_t threads;            /* threads (level 1) or worker processes (level 2); 0 = one per core */
    uint32_t max_depth;          /* octree depth limit, 0..LOCD_MAX_DEPTH; 0 = automatic (as deep as the key allows) */
    int32_t cell_bias;           /* a box goes to the deepest level whose cell edge is >= 2^bias times its
                                    largest extent, a flat or thin box up to bias levels deeper (it spans no
                                    more cells than a cube there); default LOCD_DEFAULT_CELL_BIAS (2; see
                                    docs/encoding.md); 0..8 */
    uint32_t flags;              /* LOCD_CONFIG_* */
    const char *service_address; /* level 3: "unix:/path/to.sock" or "tcp:host:port" */
    const char *service_secret;  /* level 3 over TCP: shared secret; NULL = none */
    const char *worker_path;     /* level 2: locd-worker executable; NULL = installed default */
    locd_allocator allocator;    /* all NULL = malloc/free */
    locd_log_fn log;             /* NULL = silent */
    void *log_user;
    int64_t service_timeout_ms;  /* level 3: the deadline of each job, from its submit to its result:
                                    0 = default (LOCD_DEFAULT_SERVICE_TIMEOUT_MS plus 10 us per box),
                                    > 0 = that many ms plus 10 us per box, < 0 = no deadline. A job past
                                    it finishes with LOCD_ERR_TIMEOUT (docs/levels.md, "Deadlines") */
} locd_engine_config;

/* Smallest config->size accepted: size, level, threads, max_depth, cell_bias
 * and flags (the fields the first configs had). */
#define LOCD_ENGINE_CONFIG_MIN_SIZE 24u

/* Default cell_bias: a cell edge at least 4 times the box's largest extent
 * (docs/accuracy.md measures the alternatives). */
#define LOCD_DEFAULT_CELL_BIAS 2

/* Level 3's default per-job deadline (service_timeout_ms = 0): a stopped
 * or hung service cannot block a find or a wait(-1) for longer than this
 * plus 10 microseconds per box. */
#define LOCD_DEFAULT_SERVICE_TIMEOUT_MS 60000

/* Use bounding cubes (the paper's choice) instead of the boxes' own extents
 * when choosing cells. Exactness is unchanged; only the work differs. */
#define LOCD_CONFIG_CUBES 0x1u

/* Fills *config with the defaults (level 1, one thread per core). */
LOCD_API void locd_engine_config_init(locd_engine_config *config);

/* ------------------------------------------------------------------ */
/* Results                                                            */
/* ------------------------------------------------------------------ */

/* A growable buffer of pairs (i, j), i < j, stored as 2*count uint32 values
 * i0 j0 i1 j1 ... It keeps its capacity across calls, so reusing one per
 * frame allocates nothing in the steady state. */
typedef struct locd_pairs locd_pairs;

/* allocator may be NULL (malloc/free). */
LOCD_API locd_status locd_pairs_create(const locd_allocator *allocator, locd_pairs **out);
LOCD_API void locd_pairs_destroy(locd_pairs *pairs);
LOCD_API size_t locd_pairs_count(const locd_pairs *pairs);
/* 2 * count values; valid until the buffer is next written or destroyed. */
LOCD_API const uint32_t *locd_pairs_data(const locd_pairs *pairs);
/* Sorts the pairs by (i, j). */
LOCD_API locd_status locd_pairs_sort(locd_pairs *pairs);
LOCD_API void locd_pairs_clear(locd_pairs *pairs);

/* ------------------------------------------------------------------ */
/* Statistics of the last call                                        */
/* ------------------------------------------------------------------ */

typedef struct locd_stats {
    uint32_t size;        /* sizeof(locd_stats) */
    uint32_t threads;     /* threads or workers that took part */
    uint64_t objects;     /* n */
    uint64_t entries;     /* (cell, object) entries after encoding */
    uint64_t candidates;  /* object pairs met in a shared cell path and tested */
    uint64_t exact_tests; /* candidates the quantized test could not decide (float test run) */
    uint64_t pairs;       /* pairs reported */
    uint32_t depth;       /* octree depth limit used */
    uint32_t reserved;
    double ms_total;      /* wall time inside the call */
    double ms_bounds;     /* validation + root cube */
    double ms_encode;
    double ms_sort;
    double ms_merge;      /* level 2's merge of the workers' sorted runs (0 at level 1) */
    double ms_sweep;
    double ms_order;      /* sorting the pairs by (i, j), when asked for */
    double ms_transfer;   /* levels 2 and 3: shared memory / socket traffic */
} locd_stats;

/* Smallest stats->size accepted: size and threads. */
#define LOCD_STATS_MIN_SIZE 8u

LOCD_API void locd_stats_init(locd_stats *stats);

/* ------------------------------------------------------------------ */
/* Engine (all integration levels)                                    */
/* ------------------------------------------------------------------ */

typedef struct locd_engine locd_engine;

/* config may be NULL for the defaults. On failure *out is set to NULL. */
LOCD_API locd_status locd_engine_create(const locd_engine_config *config, locd_engine **out);
/* Waits until no call or job runs inside the engine (a released job's running
 * call included), then stops threads / workers / connections and frees
 * everything. Job handles stay valid until locd_job_release (a level-3 job
 * still pending fails with LOCD_ERR_CONNECTION). NULL is ignored. */
LOCD_API void locd_engine_destroy(locd_engine *engine);
/* Level and thread count actually in use. */
LOCD_API int32_t locd_engine_level(const locd_engine *engine);
LOCD_API uint32_t locd_engine_threads(const locd_engine *engine);

/* Flags for the find calls. */
#define LOCD_FIND_SORTED 0x1u /* order pairs by (i, j) (costs time; default is the deterministic sweep order) */

/* Finds all overlapping pairs of n boxes (6*n values) into *out (replacing its
 * contents). On error *out is left unchanged. n = 0 and n = 1 give no pairs. */
LOCD_API locd_status locd_engine_find_pairs_f32(locd_engine *engine, const float *boxes, size_t n,
                                                uint32_t flags, locd_pairs *out);
LOCD_API locd_status locd_engine_find_pairs_f64(locd_engine *engine, const double *boxes, size_t n,
                                                uint32_t flags, locd_pairs *out);

/* Two-set query: every pair (i, j) with box i of a (6*na values) and box j of
 * b (6*nb values) overlapping, each pair once, into *out (replacing its
 * contents). i indexes a and j indexes b (two sets: i < j does not apply,
 * and pairs within a or within b are never reported). The order is
 * deterministic; LOCD_FIND_SORTED orders by (i, j). A bad box is reported
 * through locd_last_error_index as its index in a, or as na + j for box j
 * of b. na = 0 or nb = 0 give no pairs (the other set is still validated).
 * Levels 1 and 2 (the same pairs in the same order); level 3 returns
 * LOCD_ERR_UNSUPPORTED. On error *out is left unchanged. */
LOCD_API locd_status locd_engine_find_pairs_between_f32(locd_engine *engine, const float *a, size_t na,
                                                        const float *b, size_t nb, uint32_t flags, locd_pairs *out);
LOCD_API locd_status locd_engine_find_pairs_between_f64(locd_engine *engine, const double *a, size_t na,
                                                        const double *b, size_t nb, uint32_t flags,
                                                        locd_pairs *out);

/* The same into a caller buffer of `capacity` pairs (2*capacity uint32).
 * *count receives the number of pairs found. If it exceeds capacity, nothing
 * is copied, LOCD_ERR_BUFFER_TOO_SMALL is returned and the pairs stay
 * available through locd_engine_last_pairs() until the next call. */
LOCD_API locd_status locd_engine_find_pairs_f32_into(locd_engine *engine, const float *boxes, size_t n,
                                                     uint32_t flags, uint32_t *pairs, size_t capacity,
                                                     size_t *count);
LOCD_API locd_status locd_engine_find_pairs_f64_into(locd_engine *engine, const double *boxes, size_t n,
                                                     uint32_t flags, uint32_t *pairs, size_t capacity,
                                                     size_t *count);

/* Pairs of the engine's last successful *_into call (2 * *count values), owned
 * by the engine, valid until its next call. */
LOCD_API locd_status locd_engine_last_pairs(locd_engine *engine, const uint32_t **pairs, size_t *count);

/* Statistics of the engine's last successful call. Set stats->size first
 * (locd_stats_init); only the first stats->size bytes are written. Every
 * handle's statistics are read by locd_<handle>_get_stats. */
LOCD_API locd_status locd_engine_get_stats(const locd_engine *engine, locd_stats *stats);
/* Deprecated: the same as locd_engine_get_stats (kept for the ABI). */
LOCD_API locd_status locd_engine_stats(const locd_engine *engine, locd_stats *stats);

/* ------------------------------------------------------------------ */
/* Asynchronous jobs (every level; level 3 runs them in the service)   */
/* ------------------------------------------------------------------ */

typedef struct locd_job locd_job;

/* Copies the boxes and returns at once; the caller may reuse its buffer. */
/* Levels 1 and 2 queue the jobs of an engine and run them one after another
 * on a thread of the library (a find on that engine meanwhile returns
 * LOCD_ERR_BUSY); level 3 runs them in the service, several at once
 * (docs/levels.md). */
LOCD_API locd_status locd_engine_submit_f32(locd_engine *engine, const float *boxes, size_t n,
                                            uint32_t flags, locd_job **out);
LOCD_API locd_status locd_engine_submit_f64(locd_engine *engine, const double *boxes, size_t n,
                                            uint32_t flags, locd_job **out);
/* LOCD_OK when finished successfully, LOCD_PENDING while running, or the job's error. */
LOCD_API locd_status locd_job_poll(locd_job *job);
/* Waits up to timeout_ms (negative = forever). LOCD_ERR_TIMEOUT if still running. */
LOCD_API locd_status locd_job_wait(locd_job *job, int64_t timeout_ms);
/* Moves the result into *out (after a successful wait/poll). While the job
 * runs it returns LOCD_PENDING and leaves *out unchanged; once it failed, the
 * job's error. A second take is LOCD_ERR_INVALID_ARGUMENT. */
LOCD_API locd_status locd_job_take(locd_job *job, locd_pairs *out);
/* Statistics of the finished job (set stats->size first, as for
 * locd_engine_get_stats). While the job runs it returns LOCD_PENDING and leaves
 * *stats unchanged; once it failed, the job's error. */
LOCD_API locd_status locd_job_get_stats(const locd_job *job, locd_stats *stats);
/* Deprecated: the same as locd_job_get_stats (kept for the ABI). */
LOCD_API locd_status locd_job_stats(const locd_job *job, locd_stats *stats);
/* Asks the job to stop; a later wait returns LOCD_ERR_CANCELLED unless it had finished. */
LOCD_API locd_status locd_job_cancel(locd_job *job);
/* Frees the job (cancelling it if it still runs). NULL is ignored. */
LOCD_API void locd_job_release(locd_job *job);

/* ------------------------------------------------------------------ */
/* Building blocks: the paper's four steps                            */
/* ------------------------------------------------------------------ */

/*
 * An entry is a uint64_t: (octree key << index_bits) | object index.
 * The key is (Morton code of the cell, padded to `depth` levels) << 5 | level,
 * so ascending entries are a pre-order traversal of the octree. See
 * docs/encoding.md. The grid says how boxes map to cells; it is fitted to a
 * scene by locd_grid_fit_* and must be the same for encode and sweep.
 */
typedef struct locd_grid {
    uint32_t size;        /* sizeof(locd_grid) */
    uint32_t depth;       /* deepest octree level used (<= LOCD_MAX_DEPTH) */
    int32_t cell_bias;    /* see locd_engine_config.cell_bias */
    uint32_t index_bits;  /* low bits of an entry holding the object index */
    uint32_t flags;       /* LOCD_CONFIG_CUBES or 0 */
    uint32_t reserved;
    double origin[3];     /* half the root cube's low corner */
    double scale_a;       /* quantization: q = floor(((x/2 - origin) * scale_a) * scale_b) */
    double scale_b;
} locd_grid;

/* Smallest grid->size accepted: every field above (encode, sort and sweep
 * need them all). */
#define LOCD_GRID_MIN_SIZE 64u

/* Validates the boxes and fits the root cube. max_depth 0 = automatic,
 * at most LOCD_MAX_DEPTH;
 * cell_bias as in the config; flags LOCD_CONFIG_CUBES or 0. On a bad box
 * returns LOCD_ERR_NONFINITE / LOCD_ERR_INVERTED_BOX with its index.
 * *grid is output only; its size is read only to bound the write: the call
 * writes grid->size bytes, clamped to LOCD_GRID_MIN_SIZE..sizeof(locd_grid)
 * (every caller's grid has at least LOCD_GRID_MIN_SIZE bytes, so a grid left
 * uninitialized works), and sets grid->size to the number written, which
 * encode, sort and sweep then read. */
LOCD_API locd_status locd_grid_fit_f32(const float *boxes, size_t n, uint32_t max_depth, int32_t cell_bias,
                                       uint32_t flags, locd_grid *grid);
LOCD_API locd_status locd_grid_fit_f64(const double *boxes, size_t n, uint32_t max_depth, int32_t cell_bias,
                                       uint32_t flags, locd_grid *grid);

/* Most entries one box can produce (8): size entry buffers as 8 * count. */
#define LOCD_MAX_ENTRIES_PER_BOX 8

/* Encodes boxes [first, first + count) of the scene into entries (object
 * indices are global). capacity is in entries; *written receives the number
 * written. The boxes must have been validated by locd_grid_fit_*. */
LOCD_API locd_status locd_encode_f32(const locd_grid *grid, const float *boxes, size_t first, size_t count,
                                     uint64_t *entries, size_t capacity, size_t *written);
LOCD_API locd_status locd_encode_f64(const locd_grid *grid, const double *boxes, size_t first, size_t count,
                                     uint64_t *entries, size_t capacity, size_t *written);

/* Sorts entries ascending (radix sort on the bits that vary). scratch holds
 * count entries. The sorted result is in `entries`. */
LOCD_API locd_status locd_sort_entries(const locd_grid *grid, uint64_t *entries, uint64_t *scratch, size_t count);

/* Merges k ascending runs into out (sum of counts entries). */
LOCD_API locd_status locd_merge_entries(const uint64_t *const *runs, const size_t *counts, size_t k, uint64_t *out);

/* One pass over ascending entries of the whole scene: appends exactly the
 * overlapping pairs to *out (after clearing it), in sweep order. stats may be
 * NULL; else (size set, as for locd_engine_get_stats) it receives objects,
 * entries, candidates, exact_tests and pairs, and its other fields are left
 * as they were. */
LOCD_API locd_status locd_sweep_f32(const locd_grid *grid, const float *boxes, size_t n, const uint64_t *entries,
                                    size_t count, locd_pairs *out, locd_stats *stats);
LOCD_API locd_status locd_sweep_f64(const locd_grid *grid, const double *boxes, size_t n, const uint64_t *entries,
                                    size_t count, locd_pairs *out, locd_stats *stats);

/* Reference: O(n^2) exact test of every pair (for tests and tiny scenes);
 * pairs sorted by (i, j). */
LOCD_API locd_status locd_brute_force_f32(const float *boxes, size_t n, locd_pairs *out);
LOCD_API locd_status locd_brute_force_f64(const double *boxes, size_t n, locd_pairs *out);

#ifdef __cplusplus
}
#endif

#endif /* LOCD_LOCD_H */
