/* From scratch (from_scratch.c): the pairs of every live object by the
 * engine's find, or by the kept entry list, and their pair order
 * (pair_order.c). docs/scene.md, "Glossary". */
#ifndef LOCD_SCENE_FROM_SCRATCH_H
#define LOCD_SCENE_FROM_SCRATCH_H

#include "scene/pair_set.h"

/* What the pair order keeps from one from-scratch update to the next:
 * its scratch (a million-pair order's keys are faulted in again when new)
 * and the last order's pair count per bucket, which sizes the regions of
 * an order that takes its pairs from the sweep. */
typedef struct lc_pair_order_memo {
    lc_buf buf;    /* bytes: the keys by bucket and the counts */
    lc_buf runs;   /* uint64: the per-thread bucket buffers */
    lc_buf last;   /* uint32: the last order's pairs per bucket */
    size_t last_n; /* and its objects (0: none) */
} lc_pair_order_memo;

/* The pairs of the live objects from scratch into *out (sorted). */
locd_status lc_from_scratch_pairs(locd_scene *s, lc_pair_list *out, uint64_t *candidates);

/* ---- the pair order (pair_order.c) ----
 * The engine's pairs (i, j), i < j, of the objects live[0, n) (NULL: the
 * slots in id order) filtered and ordered into the rows of out (ids idl[i],
 * NULL when they are (serial of the first + i) << 32 | i): from pairs
 * p[0, np) gathered, */
locd_status lc_pair_order_rows(locd_scene *s, uint32_t *p, size_t np, const uint32_t *live, const locd_id *idl, size_t n,
                           lc_pair_list *out);
/* or from the sweep as it finds them (slots in id order): an order opened
 * before the sweep gives the sink the sweep writes to, and closed after it
 * writes the rows. It sizes its buckets from the counts of the previous
 * order, so it can open only after an order of as many objects
 * (lc_pair_order_can_sink). Close (or drop, after a failed sweep) frees it.
 * When the pairs outgrow the room, the sink stops the sweep and
 * lc_pair_order_overflowed says so: sweep again into gathered pairs. */
typedef struct lc_pair_order lc_pair_order;
int lc_pair_order_can_sink(const locd_scene *s, size_t n);
locd_status lc_pair_order_open(locd_scene *s, size_t n, const locd_id *idl, lc_pair_order **o, lc_pair_sink *sink);
/* The rows, or *overflow = 1 (nothing written) when the pairs outgrew the room. */
locd_status lc_pair_order_close(lc_pair_order *o, lc_pair_list *out, int *overflow);
/* 1 when the sink stopped the sweep for want of room. */
int lc_pair_order_overflowed(const lc_pair_order *o);
void lc_pair_order_drop(lc_pair_order *o);
void lc_pair_order_memo_fini(const locd_allocator *a, lc_pair_order_memo *m);

#endif
