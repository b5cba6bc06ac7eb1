/* The kept entry list (kept_list.c): the from-scratch path's entries, kept
 * from one update to the next so that an update where most objects moved
 * a little encodes every box but sorts only the entries that changed.
 * docs/scene.md, "Glossary". */
#ifndef LOCD_SCENE_KEPT_LIST_H
#define LOCD_SCENE_KEPT_LIST_H

#include "scene/slots.h"

/* From this many objects on, a from-scratch update keeps its entries (and
 * a near-pair list may be built). */
#define LC_KEPT_MIN 65536

/* The last update's entries on grid g, in slot order (share t of
 * plan[cur].k, lc_chunk_begin(n, t, k), in its region of reg[cur]) and
 * sorted (sorted[cur], plan[cur].total of them); the other buffers are the
 * next update's. Valid: they are the entries of the boxes of the last
 * update that used the list. */
typedef struct lc_kept {
    int valid;
    locd_grid g;
    size_t n; /* objects (the slots, all live) */
    int cur;
    lc_buf reg[2]; /* uint64 */
    lc_plan plan[2];
    lc_buf sorted[2];  /* uint64 */
    lc_buf delta;      /* uint64: the changed objects' old and new entries, and their sort's scratch */
    double per_object; /* entries per object to plan the next encode with (0: none yet) */
} lc_kept;

/* The pairs of the n boxes slots.fbox (every slot live, in id order, floats
 * exactly) as the engine's find gives them, from the kept entries brought
 * up to date: into out, or to the sink (when not NULL) as the sweep finds
 * them. `given`: what the caller knows of the boxes already. A failure
 * leaves the list to be made again, nothing else; a
 * failure of the sweep alone (a sink that stopped it) leaves it up to date,
 * for lc_kept_sweep. */
typedef struct lc_kept_given {
    int has_bounds;     /* lo, hi bound every box */
    float lo[3], hi[3];
    int encoded;        /* the next regions hold every box's entries (the move's hand-over) */
} lc_kept_given;
locd_status lc_kept_find(locd_scene *s, size_t n, const lc_kept_given *given, const lc_pair_sink *sink, locd_pairs *out,
                         locd_stats *stats);
/* The sweep alone, of the list lc_kept_find brought up to date (the
 * engine's packed boxes untouched since): its pairs to the sink (when not
 * NULL) or to out. */
locd_status lc_kept_sweep(locd_scene *s, size_t n, const lc_pair_sink *sink, locd_pairs *out, locd_stats *stats);
/* The next update's regions, for an encode done ahead (handover.c): 0 when
 * there is no list to go on with for n objects in k shares (the update
 * makes one), or no memory. Then share t's boxes [first, first + count)
 * are encoded as its next ones, their packed boxes into qbox: 0 when the
 * share's region is full. */
int lc_kept_next_open(locd_scene *s, size_t n, uint32_t k);
int lc_kept_next_encode(locd_scene *s, uint32_t t, const float *boxes, size_t first, size_t count, uint64_t *qbox);
/* Frees the list (a scene whose updates no longer go from scratch). */
void lc_kept_release(locd_scene *s);

#endif
