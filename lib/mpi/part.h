/* lib/mpi: the broad phase across MPI ranks (include/locd/mpi.h), built as
 * liblocd_mpi, a library of its own above liblocd: it uses liblocd's public
 * functions and the few LC_SHARED helpers of core/ and octree/ (the
 * private node of lib/locd.map.in), never MPI inside liblocd.
 * docs/cluster.md describes the strategies. Private; not installed. */
#ifndef LOCD_MPI_PART_H
#define LOCD_MPI_PART_H

#include "locd/mpi.h"
#include "octree/octree.h"

/* One call's state on one rank. */
typedef struct lm_ctx {
    MPI_Comm comm;
    int rank, ranks;
    int f64;
    size_t es; /* bytes of one box: 6 floats or 6 doubles */
    const void *boxes;
    size_t local_n;
    locd_mpi_options opt;
    uint64_t *offsets; /* ranks + 1: rank r's first global index, offsets[ranks] = n */
    uint64_t n;
    locd_grid grid;
    int kernel;
    uint64_t *ent; /* this rank's sorted entries (local indices) */
    size_t nent;
    locd_mpi_stats st; /* the figures, filled as the stages run */
    double lap;        /* lc_now_ms() at the end of the last stage */
} lm_ctx;

/* What a rank sweeps: entries (indices into boxes), the boxes and, for
 * the distributed strategy, each box's global index. */
typedef struct lm_held {
    uint64_t *ent;
    size_t count, begin; /* entries [0, begin) are context (ancestors), [begin, count) its range */
    void *boxes;
    uint32_t *gidx; /* NULL: the boxes are the whole scene in global order */
    size_t nobj;
    int borrowed; /* boxes are the caller's (one rank: nothing moved), not freed */
} lm_held;

/* ---- comm.c ---- */
/* Every rank learns the most negative status any rank has (the lowest rank
 * with it names it); every rank then returns that one status. */
locd_status lm_agree(lm_ctx *c, locd_status st);
/* ms since the last lap. */
double lm_lap(lm_ctx *c);
/* One round of an exchange: scount elements to rank `to` while rcount
 * arrive from rank `from` (nonblocking chunks: no int count limit).
 * Counts the bytes into the stats. */
void lm_sendrecv(lm_ctx *c, int to, const void *send, uint64_t scount, int from, void *recv, uint64_t rcount,
                 MPI_Datatype type, size_t esize);
/* Rank root receives every rank's `count` elements, back to back in rank
 * order, at recv (counts: every rank's count, known on every rank). */
void lm_gather(lm_ctx *c, int root, const void *send, const uint64_t *counts, void *recv, MPI_Datatype type,
               size_t esize);
/* MPI_Allgather of one uint64 per rank into out[ranks]. */
void lm_allgather_u64(lm_ctx *c, uint64_t mine, uint64_t *out);

/* ---- setup.c ---- */
/* The first collective: every rank's local status, size and options;
 * agrees on them and fills offsets and n. */
locd_status lm_setup(lm_ctx *c, locd_status local);

/* ---- grid.c ---- */
/* Validates this rank's boxes, reduces the bounds, fits the grid level 1
 * would fit on the whole scene (with its depth sample gathered). */
locd_status lm_fit_grid(lm_ctx *c);

/* ---- encode.c ---- */
/* Encodes and sorts this rank's boxes into c->ent (local indices). */
locd_status lm_encode(lm_ctx *c);

/* ---- split.c ---- */
/* split[0..ranks]: rank r owns the keys [split[r], split[r + 1]). */
locd_status lm_splitters(lm_ctx *c, uint64_t *split);
/* The last key inside the cell of `key` (its subtree in pre-order). */
uint64_t lm_key_last(uint64_t key, uint32_t depth);

/* ---- exchange.c ---- */
/* Sends each entry to the rank owning its key and to every rank whose
 * range starts inside its cell, with the boxes they name; fills h with
 * what this rank received (sorted, local indices). Frees c->ent. */
locd_status lm_exchange(lm_ctx *c, const uint64_t *split, lm_held *h);

/* ---- master.c ---- */
/* The paper's split: entries and boxes gathered on root, which merges. */
locd_status lm_master_gather(lm_ctx *c, int root, lm_held *h);

/* ---- sweep.c ---- */
/* Sweeps h's range (opt.threads slices) into out as global indices. */
locd_status lm_sweep(lm_ctx *c, const lm_held *h, locd_pairs *out);
void lm_held_free(lm_held *h);

#endif
