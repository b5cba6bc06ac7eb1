/* lib/scene: the persistent scene of include/locd/scene.h (docs/scene.md).
 * It sits above levels/: it runs its big steps on the level-1 engine's
 * thread pool (lc_inproc_pool) and uses the octree's encode and sweep
 * coordinates. Private; not installed.
 *
 * The scene handle holds one part per mechanism, each declared in the
 * mechanism's header with its own rule of when it is valid; the others
 * reach a mechanism's part through its functions:
 *   slots.h         slots, ids, the change lists (slots.c; checks.c, scene.c, move.c)
 *   entries.h       cells and fat boxes (cells.c), entry lists (entry_list.c), records (entries.c)
 *   partner_lists.h partner lists
 *   pair_set.h      pair lists (pair_list.c), the set (pair_set.c), the carry pass, the patch
 *   from_scratch.h  from scratch (from_scratch.c) and its pair order (pair_order.c)
 *   kept_list.h     the kept entry list
 *   handover.h      the move's hand-over to the next update
 *   near_list.h     the near-pair list
 *   search.h        the pairs of the moved objects: the search and the partner-list pass
 *   path.h          the choice of the update's path and the back-off waits
 *   update.h        the update (update.c, incremental.c, encode_moved.c, relist.c, moved_pairs.c)
 *   query_tree.h    the query tree, kept lazily for the queries
 *   query.h         the queries (query.c, query_shape.c, query_walk.c, query_batch.c)
 * stats.c gives the statistics. */
#ifndef LOCD_SCENE_IMPL_H
#define LOCD_SCENE_IMPL_H

#include "scene/checks.h"
#include "scene/entries.h"
#include "scene/from_scratch.h"
#include "scene/handover.h"
#include "scene/kept_list.h"
#include "scene/move.h"
#include "scene/near_list.h"
#include "scene/pair_set.h"
#include "scene/partner_lists.h"
#include "scene/path.h"
#include "scene/query_tree.h"
#include "scene/search.h"
#include "scene/slots.h"

/* The rows of a small update's moved objects, its entry buffer and its
 * search's output, kept for the next update (update_buffers.c): a game's
 * frame, a few objects moved, then allocates none of them. Typed as the
 * update's (update.h). */
typedef struct lc_update_keep {
    uint32_t *stay, *srch, *slot, *dense;
    lc_cells *cells, *new_cells;
    lc_record *rec;
    uint64_t *qfat, *new_q;
    uint8_t *flags;
    size_t cap; /* rows in each array that is not NULL */
    uint64_t *buf;
    size_t buf_cap;
    lc_search_out found;
} lc_update_keep;

struct locd_scene {
    uint32_t magic;
    locd_engine *engine;
    const locd_allocator *alloc; /* the engine's */
    lc_pool *pool;
    uint32_t threads;
    int kernel;
    uint32_t config_flags; /* locd_scene_config.flags */

    lc_slots slots;
    lc_entries entries;
    lc_partners partners;
    lc_pair_set set;
    lc_pair_order_memo order;
    lc_kept kept;
    lc_handover handover;
    lc_near near;
    lc_backoff backoff;
    lc_query_tree qtree;
    locd_pairs found; /* the engine's pairs of a find (from scratch, the partner and near-pair lists' builds) */
    lc_update_keep keep;
    locd_scene_stats stats;
};

#endif
