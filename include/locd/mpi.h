/*
 * locd/mpi.h: the broad phase across MPI ranks (liblocd_mpi, pkg-config
 * locd-mpi). A library of its own, so that liblocd never depends on MPI;
 * built when Meson finds MPI (-Dmpi=auto|enabled|disabled).
 *
 * Each rank passes only its own boxes. The global index of a box is the sum
 * of the lower ranks' local_n plus its local index, so the ranks together
 * hold one scene of n = sum(local_n) boxes, and the result is exactly that
 * scene's overlapping pairs (closed intervals, i < j, global indices): the
 * pairs `locd pairs` finds on the whole scene, each reported by exactly one
 * rank. docs/cluster.md describes the two strategies, the ownership rule and
 * the measurements; docs/api.md has the reference.
 *
 * Every call is collective over `comm`: every rank must call it, with the
 * same options. An error on any rank (a bad box, no memory, an option that
 * differs between ranks) makes every rank return the same status; a bad box
 * is named on every rank by its global index (locd_last_error_index). No
 * call aborts and none waits forever on a rank that failed inside locd.
 */
#ifndef LOCD_MPI_H
#define LOCD_MPI_H

#include <mpi.h>

#include "locd/locd.h"

#if defined(_WIN32) && defined(LOCD_MPI_BUILD)
#define LOCD_MPI_API __declspec(dllexport)
#elif defined(_WIN32) && !defined(LOCD_STATIC)
#define LOCD_MPI_API __declspec(dllimport)
#elif defined(__GNUC__)
#define LOCD_MPI_API __attribute__((visibility("default")))
#else
#define LOCD_MPI_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* Strategies (locd_mpi_options.strategy). */
#define LOCD_MPI_DISTRIBUTED 0 /* key ranges per rank, all-to-all exchange, every rank sweeps its range */
#define LOCD_MPI_MASTER 1      /* the paper's split: ranks encode and sort, one rank merges and sweeps */

typedef struct locd_mpi_options {
    uint32_t size;        /* sizeof(locd_mpi_options) */
    int32_t strategy;     /* LOCD_MPI_*; default LOCD_MPI_DISTRIBUTED */
    uint32_t threads;     /* threads of this rank's sweep; 0 = 1 (one rank per core is the usual layout) */
    int32_t gather_root;  /* -1 (default): each rank receives the pairs it owns; r >= 0: rank r receives
                             every pair, in the whole scene's sweep order, the others none */
    uint32_t max_depth;   /* as locd_engine_config.max_depth (0 = automatic) */
    int32_t cell_bias;    /* as locd_engine_config.cell_bias; default LOCD_DEFAULT_CELL_BIAS */
    uint32_t flags;       /* LOCD_CONFIG_CUBES or 0 */
    uint32_t find_flags;  /* LOCD_FIND_SORTED: each rank's pairs sorted by (i, j) */
    uint32_t samples;     /* splitter samples per rank (distributed); 0 = 256 */
    uint32_t reserved;    /* 0 */
} locd_mpi_options;

/* Smallest options->size accepted: every field above. */
#define LOCD_MPI_OPTIONS_MIN_SIZE 40u

/* Per-rank statistics of one call. Every figure is this rank's unless said. */
typedef struct locd_mpi_stats {
    uint32_t size;               /* sizeof(locd_mpi_stats) */
    int32_t rank;                /* this rank in comm */
    int32_t ranks;               /* ranks in comm */
    int32_t strategy;            /* LOCD_MPI_* used */
    uint64_t objects;            /* n: the whole scene */
    uint64_t local_objects;      /* this rank's local_n */
    uint64_t first_index;        /* global index of its first box */
    uint64_t entries_encoded;    /* (cell, object) entries encoded from its own boxes */
    uint64_t entries_held;       /* entries it swept over (its key range plus the replicated ones) */
    uint64_t entries_replicated; /* of those, copies of ancestor cells lying in a lower rank's range */
    uint64_t objects_held;       /* boxes it held for its sweep (its own and received ones) */
    uint64_t candidates;         /* object pairs its sweep tested */
    uint64_t pairs_owned;        /* pairs its sweep reported (the pairs it owns) */
    uint64_t pairs;              /* pairs in *out after the call */
    uint64_t bytes_sent;         /* bulk bytes sent to other ranks (entries, boxes, indices, pairs) */
    uint64_t bytes_received;     /* bulk bytes received from other ranks */
    uint32_t depth;              /* octree depth of the global grid */
    uint32_t reserved;
    double imbalance;            /* max over ranks of the sweep work (entries held + candidates) / the mean */
    double ms_total;             /* wall time inside the call */
    double ms_bounds;            /* validation, bounds reduction, grid (and depth sample) */
    double ms_encode;            /* encoding and sorting its own boxes */
    double ms_split;             /* sampling and choosing the key-range splitters (distributed) */
    double ms_exchange;          /* the all-to-all exchange (distributed) or the gather to the master */
    double ms_merge;             /* ordering the received entries */
    double ms_sweep;             /* its sweep */
    double ms_gather;            /* pairs to gather_root, and their (i, j) sort when asked */
} locd_mpi_stats;

/* Smallest stats->size accepted: size and rank. */
#define LOCD_MPI_STATS_MIN_SIZE 8u

/* Fills *options with the defaults (distributed, one thread, each rank its own pairs). */
LOCD_MPI_API void locd_mpi_options_init(locd_mpi_options *options);
LOCD_MPI_API void locd_mpi_stats_init(locd_mpi_stats *stats);

/* Finds every overlapping pair of the scene the ranks of comm hold together
 * (this rank: local_n boxes, 6 * local_n values) into *out (replacing its
 * contents), as global indices (i < j). options NULL = the defaults; stats
 * may be NULL. Collective; on error every rank returns the same status and
 * leaves *out unchanged. The distributed strategy's pairs, concatenated in
 * rank order, are the whole scene's sweep order (gather_root gives that). */
LOCD_MPI_API locd_status locd_mpi_find_pairs_f32(MPI_Comm comm, const float *boxes, size_t local_n,
                                                 const locd_mpi_options *options, locd_pairs *out,
                                                 locd_mpi_stats *stats);
LOCD_MPI_API locd_status locd_mpi_find_pairs_f64(MPI_Comm comm, const double *boxes, size_t local_n,
                                                 const locd_mpi_options *options, locd_pairs *out,
                                                 locd_mpi_stats *stats);

#ifdef __cplusplus
}
#endif

#endif /* LOCD_MPI_H */
