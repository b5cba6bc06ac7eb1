/* lib/scene: the persistent scene of include/locd/scene.h (docs/scene.md).
 * It sits above levels/: it runs its big steps on the level-1 engine's
 * thread pool (lc_inproc_pool) and uses the octree's encode and sweep
 * coordinates. Private; not installed.
 *
 * Files: slots.c (ids, slots), validate.c (batch checks), scene.c (create,
 * the changes), move.c (large moves on the pool), tree.c (cells, the two entry lists: tombstones, overflow,
 * compaction, directory; fat boxes), find.c (pairs of the moved objects:
 * the search, the partner lists' pass), adj.c (partner lists), rebuild.c
 * (everything from scratch, the numbering), pairset.c (sorted pair lists),
 * carry.c (the new set: the carry pass, the patch), kept_list.c (the
 * from-scratch path's kept entries), pair_order.c (its pair order),
 * near_list.c (the near-pair list: most objects moving a little),
 * update.c (the update: its paths, undo, the changes), query.c, stats.c.
 * docs/scene.md explains the design. */
#ifndef LOCD_SCENE_IMPL_H
#define LOCD_SCENE_IMPL_H

#include "levels/levels.h"
#include "locd/scene.h"
#include "octree/octree.h"

#include <float.h>
#include <math.h>

/* Slot flags. */
#define LC_SLOT_LIVE 0x1u    /* holds an object */
#define LC_SLOT_STATIC 0x2u  /* the object is static */
#define LC_SLOT_DIRTY 0x4u   /* added, moved or re-filtered since the last update (in scene->dirty) */
#define LC_SLOT_REMOVED 0x8u /* removed since the last update; freed by the next one */
#define LC_SLOT_INTREE 0x10u /* has entries in a tree list (its cells are in slot->cell) */
#define LC_SLOT_REFILTER 0x20u /* its filter changed since the last update (its record is written again) */
#define LC_SLOT_INEXACT 0x40u  /* live, and its box is not floats exactly (fbox holds it rounded) */
/* A record flag only (lc_hot.flags), while an update runs: the object's
 * pairs are searched in the entry lists this update (it is new, re-filtered,
 * or left its fat box); a moved object without it takes its pairs from its
 * partner list (adj.c). */
#define LC_HOT_SEARCH 0x100u
/* A record flag only: the object was removed (set by the update that takes
 * the removal in; its dense index is never given again before a rebuild of
 * the lists). Its partners skip it. */
#define LC_HOT_GONE 0x200u

/* An id: the serial number of the add (1, 2, ...: never reused) in the high
 * 32 bits, the slot in the low 32. Serials grow with every add, so sorting
 * ids sorts by serial: a pair's order key is serial_a << 32 | serial_b. */
#define LC_ID_SLOT(id) ((uint32_t)((id)&0xffffffffu))
#define LC_ID_SERIAL(id) ((uint32_t)((id) >> 32))
#define LC_MAX_SERIAL 0xffffffffu
/* The id of index i when the slots are in id order and their serials
 * consecutive from serial0 (lc_scene_slots_in_id_order's 2): no read of
 * the per-slot ids, each a cache miss in a pass over pairs. */
#define LC_ID_AFFINE(serial0, i) ((locd_id)((((uint64_t)(serial0) + (i)) << 32) | (i)))

/* The cells an object's entries were made from: its level, the first cell
 * per axis and whether it spans a second one (bit a of span). Enough to
 * write its entries again, so the old entries of a moved object can be
 * found and removed without keeping them. */
typedef struct lc_cells {
    uint32_t c0[3];
    uint8_t level, span, pad[2];
} lc_cells;

/* What the search reads of a candidate once its fat box passed (hq), and
 * all a partner list's pass reads of a partner, one cache line: the packed
 * sweep box (lc_pack_qbox) of the object's box, the filter, the id (a found
 * pair's row needs no read of the per-slot ids, a cache miss each), the
 * slot and the flags. The records are indexed by a dense index that the
 * entries carry instead of the slot: a rebuild numbers the objects in the
 * order of the sorted entry lists, so the objects of one cell have
 * neighbouring records and a search reads them in a few cache lines.
 * Objects added later take the next indices. */
typedef struct lc_hot {
    uint64_t qlo, qhi;
    uint64_t cat, mask, group;
    locd_id id;
    uint32_t slot;
    uint32_t flags; /* LC_SLOT_STATIC; LC_SLOT_DIRTY, LC_HOT_SEARCH, LC_HOT_GONE while an update runs */
    uint64_t pad;   /* to 64 bytes: a large array of them starts on a cache line (lc_alloc) */
} lc_hot;

/* An object's partner list (adj.c): off and n of its run in the scene's
 * partner pool, cap the room there. An entry is a partner's dense index,
 * with LC_ADJ_PAIRED when the two are a pair of the current set. */
typedef struct lc_adj {
    uint32_t off, n, cap;
} lc_adj;
#define LC_ADJ_PAIRED 0x80000000u
#define LC_ADJ_INDEX 0x7fffffffu

/* One record a cache line (the partner-list pass reads one a partner). */
typedef char lc_hot_is_64_bytes[sizeof(lc_hot) == 64 ? 1 : -1];

/* The packed fat box of dense index d (the one its cells and entries are
 * made from) is hq[LC_HQ * d], hq[LC_HQ * d + 1]. */
#define LC_HQ 2
/* lc_cells_of's packed boxes: the fat box's two words, then the box's. */
#define LC_QPAIR 4

/* An entry list: a main array sorted by entry, in which a deleted entry is
 * a tombstone (its slot bits all set: the key, hence the order of keys,
 * stays), and a small sorted overflow array of the entries added since the
 * last compaction. Both are searched; a compaction merges them when the
 * overflow and the tombstones pass a fraction of the main array. per_level
 * counts the live entries of each level (a level with none is never
 * searched). */
typedef struct lc_tree {
    lc_buf ent; /* uint64, main */
    size_t count;
    /* A directory of the main array: dir[j] is the first position whose
     * entry has j in its top dir_bits bits (of the bits entries use), so a
     * lookup is a binary search within one bucket. NULL for a small array. */
    uint32_t *dir;
    uint32_t dir_bits, dir_shift;
    lc_buf ovf; /* uint64, overflow */
    size_t novf;
    size_t dead; /* tombstones in main */
    size_t per_level[32];
} lc_tree;

/* The from-scratch path's entry list, kept from one update to the next
 * (kept_list.c): the last update's entries on grid g, in slot order (share
 * t of plan[cur].k, lc_chunk_begin(n, t, k), in its region of reg[cur])
 * and sorted (sorted[cur], plan[cur].total of them); the other buffers are
 * the next update's. */
typedef struct lc_kept {
    int valid;
    locd_grid g;
    size_t n;           /* objects (the slots, all live) */
    int cur;
    lc_buf reg[2];      /* uint64 */
    lc_plan plan[2];
    lc_buf sorted[2];   /* uint64 */
    lc_buf delta;       /* uint64: the changed objects' old and new entries, and their sort's scratch */
    /* A move of every object in slot order encoded the boxes into
       reg[!cur] on g as it read them (lc_kept_pre_*): the next update's
       encode is done, unless the scene changed since (every add, move and
       remove clears pre) or anything else wrote the engine's packed boxes
       (pre_epoch against lc_inproc_qbox_epoch). */
    int pre;
    uint64_t pre_epoch;
    uint64_t *pre_qbox; /* the engine's packed boxes, which that move writes (lc_kept_pre_chunk) */
    double per_object;  /* entries per object to plan the next encode with (0: none yet) */
} lc_kept;

/* The near-pair list (near_list.c): per object i (slots all live, in id
 * order), the objects j > i whose fat boxes (fat: the box grown by its
 * largest edge >> LC_FAT_SHIFT on each side, when the list was built) meet
 * its own and that may pair with it, nb[off[i], off[i + 1]), each with
 * LC_ADJ_PAIRED when the two are a pair of the current set. Valid while
 * only moves happened since it was built and every box stayed inside its
 * fat box. */
typedef struct lc_near {
    int valid;
    size_t n, count;    /* objects, candidates */
    float *fat;         /* 6 per object */
    uint32_t *off;      /* n + 1 */
    uint32_t *nb;
    size_t n_cap, nb_cap;
    uint32_t served;    /* updates that took the list since it was built */
    uint32_t wait, skip; /* update.c: builds to skip after lists that served no update */
} lc_near;

/* A sorted pair list: rows of two ids. */
typedef struct lc_plist {
    lc_buf rows; /* locd_id, two a row */
    size_t count;
    size_t first; /* the list starts at this row of the buffer (the carry pass's output; 0 elsewhere) */
} lc_plist;

/* The first row of a sorted pair list. */
LC_INLINE locd_id *lc_plist_rows(const lc_plist *p)
{
    return (locd_id *)p->rows.data + 2 * p->first;
}

struct locd_scene {
    uint32_t magic;
    locd_engine *engine;
    const locd_allocator *alloc; /* the engine's */
    lc_pool *pool;
    uint32_t threads;
    int kernel;

    /* slots (slots.c) */
    size_t nslots;      /* slots ever used */
    size_t live;        /* objects now */
    size_t live_static; /* static objects now */
    size_t slot_cap;
    locd_id *id;        /* per slot; the current object's id (kept after removal until freed) */
    double *box;        /* 6 per slot, only once keep_f64 is set (else NULL: lc_scene_box reads fbox) */
    float *fbox;        /* 6 per slot: the box as floats, the engine's cheaper input when every live box is floats
                           exactly (ninexact == 0: always so through the f32 entry points) */
    int keep_f64;       /* some box came in as doubles that are not floats exactly: the doubles are kept
                           (set for good). Until then every box is its float copy, and a move writes 24
                           bytes an object, not 72 */
    size_t ninexact;    /* live objects flagged LC_SLOT_INEXACT */
    float *fbox_spare;  /* fbox's twin (fbox_spare_cap slots), made by the first move of every object in
                           slot order (move.c): such a move writes it while it checks the batch and then
                           swaps it with fbox, one pass over the boxes instead of two */
    size_t fbox_spare_cap;
    int fbox_bounds_ok;  /* fbox_lo, fbox_hi bound every box: set by such a move (it reads every box), cleared by
                            any other move or add; the kept entry list's grid check then needs no pass of its own */
    float fbox_lo[3], fbox_hi[3];
    uint64_t *cat, *mask, *group, *user;
    uint8_t *flags;
    uint32_t *stamp;     /* duplicate check of a batch */
    uint32_t stamp_now;
    lc_cells *cell;      /* per slot, valid with LC_SLOT_INTREE */
    uint32_t *dense;     /* per slot: its dense index, valid with LC_SLOT_INTREE */
    lc_hot *hot;         /* per dense index (hot_cap of them; ndense issued since the last rebuild) */
    uint64_t *hq;        /* per dense index, LC_HQ: the packed fat box, 16 bytes (4 a cache line)
                            for the search's first test */
    size_t hot_cap, ndense;
    /* partner lists (adj.c): per dense index (hot_cap), the objects whose fat
       boxes meet its fat box and that may pair with it; valid with have_adj */
    lc_adj *adj;
    size_t adj_heads;    /* headers allocated (the hot_cap of the build) */
    uint32_t *adj_pool;
    size_t adj_used, adj_cap, adj_live; /* pool positions used, allocated; list entries held */
    int have_adj;
    uint32_t calm_updates; /* incremental updates in a row, without lists, whose moved objects stayed in
                              their fat boxes (update.c) */
    uint32_t band_updates; /* from-scratch updates in a row with no lists and 8% to 25% of the objects
                              moved (update.c) */
    uint32_t band_wait;    /* how many of those before the lists are built (0: LC_BAND_WAIT) */
    lc_buf free_slots;   /* uint32 stack */
    size_t nfree;
    uint32_t serial;     /* serials issued */
    lc_buf dirty;        /* uint32 slots flagged LC_SLOT_DIRTY */
    size_t ndirty;
    lc_buf removed;      /* uint32 slots flagged LC_SLOT_REMOVED */
    size_t nremoved;

    /* broad phase (tree.c) */
    int have_tree;  /* the entry lists, cells and records are those of the last update's boxes */
    int have_pairs; /* an update was made: `pairs` is the set of its boxes */
    locd_grid grid;
    lc_tree dyn, sta; /* entries of the dynamic and of the static objects */

    /* pairs (update.c) */
    lc_plist pairs, created, lost; /* the current set and the last events */
    lc_plist spare;                /* the set before last's buffer, the next update's output: a
                                      million-pair list is 16 MB, page-faulted in again when new */
    lc_plist spare_cr, spare_lo;   /* the events before last's buffers, the next update's: sized
                                      for every row of a set, so new ones faulted in each frame */
    lc_plist spare_drop;           /* the carry pass's dropped rows (sized likewise), kept too */
    /* What a from-scratch update reads of every slot, kept until an add,
       remove or set_filter changes it (moves do not): -1 unknown, else
       rebuild.c's slots_in_id_order and filter_passes_all. */
    int order_known, filter_known;
    locd_pairs found;              /* from scratch: the engine's pairs, and the ordering's scratch */
    lc_buf order_buf;              /* (bytes), kept from one from-scratch update to the next for the same reason */
    lc_buf order_runs;             /* uint64: the pair order's per-thread bucket buffers (pair_order.c) */
    lc_buf order_last;             /* uint32: the last order's pairs per bucket (its regions' sizes next time) */
    size_t order_last_n;           /* and its objects (0: none) */
    lc_kept kept;                  /* the from-scratch path's entries, kept (kept_list.c) */
    lc_near near;                  /* the near-pair list (near_list.c) */
    int no_near;                   /* LOCD_SCENE_NO_NEAR_LIST: never built */
    int show_pairs, show_events;   /* the flags of the last update */
    locd_scene_stats stats;
};

/* ---- slots (slots.c) ---- */
/* How far ahead the passes over scattered slots (a batch's ids, the dirty
 * list) start loading what they read: a miss each, overlapped. */
#define LC_AHEAD 8

/* Starts loading the id and flags of the slot id names (a batch's checks
 * read them), if it is one of the scene's. */
LC_INLINE void lc_scene_prefetch_slot(const locd_scene *s, locd_id id)
{
    const uint32_t slot = LC_ID_SLOT(id);
    if (slot < s->nslots) {
        __builtin_prefetch(s->id + slot);
        __builtin_prefetch(s->flags + slot);
    }
}

/* Slot's box as doubles: the kept doubles, or (keep_f64 unset) its float
 * copy converted into tmp, the same values. */
LC_INLINE const double *lc_scene_box(const locd_scene *s, size_t slot, double tmp[6])
{
    const float *f = s->fbox + 6 * slot;
    int a;
    if (s->keep_f64)
        return s->box + 6 * slot;
    for (a = 0; a < 6; a++)
        tmp[a] = (double)f[a];
    return tmp;
}

/* Starts loading slot's box (for a write when `write`). */
LC_INLINE void lc_scene_prefetch_box(const locd_scene *s, size_t slot, int write)
{
    if (s->keep_f64) {
        if (write) {
            __builtin_prefetch(s->box + 6 * slot, 1);
            __builtin_prefetch(s->box + 6 * slot + 5, 1);
        } else {
            __builtin_prefetch(s->box + 6 * slot);
            __builtin_prefetch(s->box + 6 * slot + 5);
        }
    }
    if (write)
        __builtin_prefetch(s->fbox + 6 * slot, 1);
    else
        __builtin_prefetch(s->fbox + 6 * slot);
}

/* Before a batch of n double boxes is written: sets keep_f64 (the doubles
 * made from the float copies) if one of them is not floats exactly.
 * LOCD_ERR_NO_MEMORY changes nothing. */
locd_status lc_scene_need_doubles(locd_scene *s, const double *boxes, size_t n);

/* The slot of id if it names a live object, else -1. */
int64_t lc_scene_slot(const locd_scene *s, locd_id id);
/* Makes room for `more` new slots (nothing else changes on failure). */
locd_status lc_scene_reserve(locd_scene *s, size_t more);
/* Takes a free slot (after lc_scene_reserve) for a new object; returns it. */
uint32_t lc_scene_take_slot(locd_scene *s);
/* Sets slot's box (double and float copies, the INEXACT flag and count) from 6 floats or doubles. */
void lc_scene_set_box(locd_scene *s, uint32_t slot, const void *boxes, int f64, size_t i);
/* The same without the count: returns its change (-1, 0 or 1). */
int lc_scene_put_box(locd_scene *s, uint32_t slot, const void *boxes, int f64, size_t i);
/* Marks a slot dirty (in scene->dirty; room reserved beforehand). */
void lc_scene_mark_dirty(locd_scene *s, uint32_t slot);
/* Releases every slot removed since the last update to the free list. */
void lc_scene_free_removed(locd_scene *s);
void lc_scene_slots_fini(locd_scene *s);
/* Room for `more` entries in the dirty and removed lists. */
locd_status lc_scene_reserve_lists(locd_scene *s, size_t more_dirty, size_t more_removed);

/* A move of n objects split over the pool (move.c), when n is large and
 * the scene has threads or the batch may be every object in slot order
 * (one thread: its passes on the caller's thread): returns 1 and the
 * status in *st, else 0 (the caller moves them). */
int lc_scene_move_parallel(locd_scene *s, const locd_id *ids, const void *boxes, int f64, size_t n,
                           locd_status *st);

/* ---- batch checks (validate.c): nothing is changed; errors name the index ---- */
/* What is wrong with one box, as doubles (a float converts exactly):
 * LOCD_ERR_NONFINITE, LOCD_ERR_INVERTED_BOX (*axis set) or LOCD_OK; no
 * error is recorded (the checks below record it, naming the position).
 * Inline: a move of every object checks a million boxes a frame. The
 * common case is one branch: every |x| <= DBL_MAX (false for NaN and
 * infinities) and every min <= max. */
LC_INLINE locd_status lc_scene_box_fault(const double *b, int *axis)
{
    int a, ok = 1;
    for (a = 0; a < 6; a++)
        ok &= fabs(b[a]) <= DBL_MAX;
    for (a = 0; a < 3; a++)
        ok &= b[a] <= b[a + 3];
    if (ok)
        return LOCD_OK;
    for (a = 0; a < 6; a++)
        if (!isfinite(b[a]))
            return LOCD_ERR_NONFINITE;
    for (a = 0; a < 3; a++)
        if (b[a] > b[a + 3]) {
            *axis = a;
            return LOCD_ERR_INVERTED_BOX;
        }
    return LOCD_OK;
}
locd_status lc_scene_check_boxes_f32(const float *boxes, size_t n);
locd_status lc_scene_check_boxes_f64(const double *boxes, size_t n);
/* Every id live and none twice (stamps only). */
locd_status lc_scene_check_ids(locd_scene *s, const locd_id *ids, size_t n);
/* Every id live (duplicates allowed: for reads). */
locd_status lc_scene_check_ids_live(const locd_scene *s, const locd_id *ids, size_t n);
locd_status lc_scene_check_handle(const locd_scene *s);

/* ---- pair filter: may a and b pair at all? ---- */
LC_INLINE int lc_scene_may_pair(const locd_scene *s, uint32_t a, uint32_t b)
{
    if ((s->flags[a] & s->flags[b] & LC_SLOT_STATIC) != 0)
        return 0;
    if (!(s->cat[a] & s->mask[b]) || !(s->cat[b] & s->mask[a]))
        return 0;
    return !(s->group[a] == s->group[b] && s->group[a] != 0);
}
LC_INLINE int lc_box_overlap(const double *a, const double *b)
{
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

/* Whether packed boxes qm and qo miss each other: each axis's fields
 * compared in place (masked, not shifted), the three axes' results or-ed. */
LC_INLINE uint32_t lc_qbox_miss(const uint64_t *qm, const uint64_t *qo)
{
    uint32_t miss = 0, a;
    for (a = 0; a < 3; a++) {
        const uint64_t fm = LC_SMASK << (a * LC_SBITS);
        miss |= (uint32_t)((qm[0] & fm) > (qo[1] & fm)) | (uint32_t)((qo[0] & fm) > (qm[1] & fm));
    }
    return miss;
}

/* Whether the boxes of records hm and ho overlap: their packed boxes
 * first. Strictly overlapping packed boxes need no exact test: the
 * quantization is monotone, so q(x) < q(y) implies x < y. Only a tie
 * (equal packed ends) may hide boxes that do not overlap. */
LC_INLINE int lc_hot_meet(const locd_scene *s, const lc_hot *hm, const lc_hot *ho)
{
    const uint64_t *xm = &hm->qlo, *xo = &ho->qlo;
    uint32_t tie = 0, a;
    double tm[6], to[6];
    if (lc_qbox_miss(xm, xo))
        return 0;
    for (a = 0; a < 3; a++) {
        const uint64_t fm = LC_SMASK << (a * LC_SBITS);
        tie |= (uint32_t)((xm[0] & fm) == (xo[1] & fm)) | (uint32_t)((xo[0] & fm) == (xm[1] & fm));
    }
    return !tie || lc_box_overlap(lc_scene_box(s, hm->slot, tm), lc_scene_box(s, ho->slot, to));
}

/* ---- sorted pair lists (pairset.c) ---- */
locd_status lc_plist_reserve(const locd_allocator *a, lc_plist *p, size_t rows);
void lc_plist_fini(const locd_allocator *a, lc_plist *p);
/* The order key of a row: serial_a << 32 | serial_b. */
LC_INLINE uint64_t lc_pair_key(const locd_id *row)
{
    return (uint64_t)LC_ID_SERIAL(row[0]) << 32 | LC_ID_SERIAL(row[1]);
}
/* Sorts rows[0, n) (scratch: 2 * n locd_id) by key. */
locd_status lc_pairs_sort_rows(const locd_allocator *a, locd_id *rows, size_t n);
/* The first row of sorted rows[0, n) whose key is >= key. */
size_t lc_rows_lower_bound(const locd_id *rows, size_t n, uint64_t key);
/* The carry pass (carry.c): into *next the previous set's rows whose ends
 * did not change (dirty or removed slots) merged with the new rows n
 * (sorted), into *dropped the others. */
locd_status lc_scene_carry(locd_scene *s, const lc_plist *n, lc_plist *next, lc_plist *dropped);
/* Into *next the previous set without the rows lost (sorted, all in it)
 * and with the rows created (sorted, none in it). LOCD_ERR_INTERNAL when a
 * lost row is not in the set. */
locd_status lc_scene_patch(locd_scene *s, const lc_plist *lost, const lc_plist *created, lc_plist *next);
/* The same in the set's own buffer (s->pairs: its start moves toward the
 * buffer's end). 0 when it cannot (no room after the set, no memory, a lost
 * row not in the set): nothing was changed, lc_scene_patch does it. It
 * cannot fail once it starts, so it is an update's last step. */
int lc_scene_patch_in_place(locd_scene *s, const lc_plist *lost, const lc_plist *created);
/* Both differences of sorted a and b in one merge: amb = a \ b (room for
 * na rows), bma = b \ a (room for nb rows). */
void lc_plist_diff(const locd_id *a, size_t na, const locd_id *b, size_t nb, locd_id *amb, size_t *namb, locd_id *bma,
                   size_t *nbma);

/* ---- broad phase (rebuild.c, tree.c, find.c) ---- */
void lc_scene_tree_fini(locd_scene *s);
/* The fat box's margin on each side: its largest edge >> LC_FAT_SHIFT (in
 * quantized units). An object that moves inside its fat box keeps its
 * cells and its partner list (docs/scene.md). */
#define LC_FAT_SHIFT 4
/* An object's cells on grid g (those of its fat box), and the packed sweep
 * boxes (lc_pack_qbox) of its fat box (q[0], q[1]) and of its box (q[2], q[3]). */
void lc_cells_of(const locd_grid *g, const double *b, lc_cells *c, uint64_t q[4]);
/* 1 when packed box x lies inside packed box f (each axis's fields). */
LC_INLINE int lc_qbox_inside(const uint64_t *x, const uint64_t *f)
{
    uint32_t out = 0, a;
    for (a = 0; a < 3; a++) {
        const uint64_t m = LC_SMASK << (a * LC_SBITS);
        out |= (uint32_t)((x[0] & m) < (f[0] & m)) | (uint32_t)((x[1] & m) > (f[1] & m));
    }
    return !out;
}
int lc_cells_same(const lc_cells *a, const lc_cells *b);
/* Writes the object's entries (1 to 8) from its cells; returns how many. */
uint32_t lc_cells_entries(const locd_grid *g, const lc_cells *c, uint32_t slot, uint64_t *out);
/* How many entries lc_cells_entries writes for c (two cells on each axis it spans), without writing them. */
LC_INLINE uint32_t lc_cells_count(const lc_cells *c)
{
    return 1u << (((c->span >> 0) & 1u) + ((c->span >> 1) & 1u) + ((c->span >> 2) & 1u));
}
void lc_sort_u64(uint64_t *v, size_t n);
/* The same with a radix sort past a few hundred values (scratch allocated). */
locd_status lc_sort_u64_radix(const locd_allocator *a, uint64_t *v, size_t n);
/* Counts t's entries per level. */
void lc_tree_count_levels(const locd_grid *g, lc_tree *t);
void lc_tree_release(const locd_allocator *a, lc_tree *t);
/* Builds t's directory (none for a small main array; nothing changes on
 * failure, the directory is only a shortcut). */
void lc_tree_build_dir(const locd_allocator *a, const locd_grid *g, lc_tree *t);
/* The first position of t's main array whose entry is >= v, where v is a
 * key << index_bits (the order of the main array is by key). */
size_t lc_tree_lower_bound(const lc_tree *t, uint64_t v);
/* The tombstone of an entry, and whether an entry is one. */
#define LC_TOMB(g, e) ((e) | ((((uint64_t)1) << (g)->index_bits) - 1))
#define LC_IS_TOMB(g, e) ((~(e) & ((((uint64_t)1) << (g)->index_bits) - 1)) == 0)
/* Where a tree change is written: tombstones in place (positions and old
 * values kept for undo), or a new tree when the change compacts. */
typedef struct lc_tree_edit {
    int compacted;     /* the new tree is `out`; t is untouched */
    lc_tree out;       /* compacted: the new tree; else only its ovf/novf/per_level are new */
    size_t *pos;       /* tombstoned positions of t's main array */
    uint64_t *old;     /* and the entries they held */
    size_t npos, pos_cap;
} lc_tree_edit;
/* Applies del (entries of t, sorted) and add (sorted) to t: tombstones in
 * t's main array (undone by lc_tree_undo) and a new overflow in e->out,
 * or a compacted new tree in e->out. */
locd_status lc_tree_edit_apply(const locd_allocator *a, const locd_grid *g, lc_tree *t, const uint64_t *del,
                               size_t ndel, const uint64_t *add, size_t nadd, lc_tree_edit *e);
void lc_tree_edit_undo(lc_tree *t, lc_tree_edit *e);
/* Makes the edit t's state (t takes e->out's buffers). */
void lc_tree_edit_commit(const locd_allocator *a, lc_tree *t, lc_tree_edit *e);
void lc_tree_edit_free(const locd_allocator *a, lc_tree_edit *e);
/* ---- the from-scratch path's kept entry list (kept_list.c) ---- */
/* From this many objects on, a from-scratch update keeps its entries. */
#define LC_KEPT_MIN 65536
/* The pairs of the n boxes s->fbox (every slot live, in id order, floats
 * exactly) as the engine's find gives them, from the kept entries brought
 * up to date: into out, or to the sink (when not NULL) as the sweep finds
 * them. A failure leaves the list to be made again, nothing else; a
 * failure of the sweep alone (the sink's LC_ORDER_FULL) leaves it up to
 * date, for lc_kept_sweep. */
locd_status lc_kept_find(locd_scene *s, size_t n, const lc_pair_sink *sink, locd_pairs *out, locd_stats *stats);
/* The encode of the next update, done by a move of every object in slot
 * order as it reads the boxes (move.c), in the shares the update's own
 * encode would take. lc_kept_pre_open makes room for n objects in k
 * shares: 0 when there is no list to go on with (the update makes one) or
 * no memory. lc_kept_pre_chunk encodes boxes [first, first + count) of the
 * batch (position = slot) as share t's next ones: 0 when its region is
 * full. lc_kept_pre_close, once every share's boxes were all encoded in
 * order, makes them the next update's (lc_kept_find). */
int lc_kept_pre_open(locd_scene *s, size_t n, uint32_t k);
int lc_kept_pre_chunk(locd_scene *s, uint32_t t, const float *boxes, size_t first, size_t count);
void lc_kept_pre_close(locd_scene *s);
/* The sweep alone, of the list lc_kept_find brought up to date (the
 * engine's packed boxes untouched since): its pairs to the sink (when not
 * NULL) or to out. */
locd_status lc_kept_sweep(locd_scene *s, size_t n, const lc_pair_sink *sink, locd_pairs *out, locd_stats *stats);

/* ---- the pair order of a from-scratch update (pair_order.c) ----
 * The engine's pairs (i, j), i < j, of the objects live[0, n) (NULL: the
 * slots in id order) filtered and ordered into the rows of out (ids idl[i],
 * NULL when they are (serial of the first + i) << 32 | i): from pairs p[0,
 * np) gathered, */
locd_status lc_scene_order_pairs(locd_scene *s, uint32_t *p, size_t np, const uint32_t *live, const locd_id *idl,
                           size_t n, lc_plist *out);
/* or from the sweep as it finds them (slots in id order): an order opened
 * before the sweep gives the sink the sweep writes to, and closed after it
 * writes the rows. It sizes its buckets from the counts of the previous
 * order, so it can open only after an order of as many objects
 * (lc_scene_order_can_sink). Close (or drop, after a failed sweep) frees it.
 * LC_ORDER_FULL, from the sweep or the close: the pairs outgrew the room
 * (nothing written): sweep again into gathered pairs. */
typedef struct lc_order lc_order;
#define LC_ORDER_FULL (-1000)
int lc_scene_order_can_sink(const locd_scene *s, size_t n);
locd_status lc_scene_order_open(locd_scene *s, size_t n, const locd_id *idl, lc_order **o, lc_pair_sink *sink);
locd_status lc_scene_order_close(lc_order *o, lc_plist *out);
void lc_scene_order_drop(lc_order *o);
/* Frees the list (a scene whose updates no longer go from scratch). */
void lc_kept_release(locd_scene *s);

/* ---- the near-pair list (near_list.c) ---- */
/* lc_near_build's answer when the list cannot be built for these boxes (a
 * fat box past the float range, too many candidates): go from scratch. */
#define LC_NEAR_NO (-1001)
/* 1 when a list can be built for the scene as it is: the slots are the
 * engine's input as they are, every box a float exactly, LC_KEPT_MIN
 * objects or more. */
int lc_near_applies(locd_scene *s);
/* 1 when the list is valid and nothing but moves happened since it was built. */
int lc_near_usable(const locd_scene *s);
/* Builds the list from the boxes now and writes their pair set into next
 * (sorted; next->first may be past 0). */
locd_status lc_near_build(locd_scene *s, lc_plist *next, uint64_t *candidates);
/* The pair set of the boxes now into next, created and lost into cr and lo
 * (*diff = 1 when they did not fit: the caller diffs the sets), from the
 * list; *left = 1 (nothing written, the list no longer valid) when a box
 * lies outside its fat box. */
locd_status lc_near_frame(locd_scene *s, lc_plist *next, lc_plist *cr, lc_plist *lo, uint64_t *candidates,
                          int *left, int *diff);
void lc_near_release(locd_scene *s);
/* 1 when the slots [0, nslots) are all live and their serials ascend, 2
 * when the serials are also consecutive (rebuild.c); 0 otherwise. Kept
 * until an add, remove or set_filter. */
int lc_scene_slots_in_id_order(locd_scene *s);

/* A grid fitted to the live boxes with a margin, with index bits for twice the slots. */
locd_status lc_scene_fit_grid(locd_scene *s, locd_grid *g);
/* 1 if box b quantizes inside the root cube without clamping. */
int lc_grid_holds(const locd_grid *g, const double *b);
/* What lc_scene_find_moved finds. LC_FIND_ROWS: the moved objects' rows
 * (sorted). LC_FIND_EVENTS: the search's fat partners, uint32 (m, o |
 * LC_ADJ_PAIRED when their boxes meet), each pair once; and the changes the
 * partner-list pass found, uint32 (m, k, o | LC_ADJ_PAIRED now), k being
 * o's place in m's list, the pairs whose PAIRED bit is wrong now. */
enum { LC_FIND_ROWS, LC_FIND_EVENTS };
typedef struct lc_found {
    lc_plist rows;
    lc_buf fat, ev;
    size_t nfat, nev;
    uint64_t candidates; /* added to */
} lc_found;
/* The pairs of the moved objects: those whose entries are q (sorted),
 * searched in the lists dyn and sta, and the objects coast[0, ncoast) (dense
 * indices), from their partner lists. */
locd_status lc_scene_find_moved(const locd_scene *s, const lc_tree *dyn, const lc_tree *sta, const uint64_t *q,
                                size_t nq, const uint32_t *coast, size_t ncoast, int mode, lc_found *out);
/* Every live object's cells on g into cells, its dense index into dense
 * and its record into hot (numbered in entry order; *ndense receives the
 * count), and both entry lists, sorted by key. */
locd_status lc_scene_build_trees(locd_scene *s, const locd_grid *g, lc_cells *cells, uint32_t *dense, lc_hot *hot,
                                 uint64_t *hq, size_t *ndense, lc_tree *dyn, lc_tree *sta);
/* The dense indices a rebuild of n slots makes room for. */
size_t lc_scene_dense_room(size_t nslots);
/* The hot record of slot k from its slot arrays and packed boxes (lc_cells_of's). */
void lc_hot_fill(const locd_scene *s, size_t k, const uint64_t qbox[LC_QPAIR], lc_hot *h);
/* Computes the pairs of the live objects from scratch into *out (sorted). */
locd_status lc_scene_pairs_from_scratch(locd_scene *s, lc_plist *out, uint64_t *candidates);

/* ---- partner lists (adj.c) ---- */
/* Builds every live object's list from scratch (after lc_scene_build_trees):
 * the engine's find over the packed fat boxes, then the filter. Sets
 * have_adj; on failure (NO_MEMORY) leaves the scene without lists. */
locd_status lc_adj_build(locd_scene *s);
/* Drops the lists (have_adj 0). */
void lc_adj_drop(locd_scene *s);
/* Takes dense index d off the lists of its partners and empties its own. */
void lc_adj_unlink(locd_scene *s, uint32_t d);
/* Makes a and b partners (neither in the other's list before), a pair of
 * the current set when `paired`. On no memory the lists are dropped (the
 * scene then searches every moved object). */
void lc_adj_link(locd_scene *s, uint32_t a, uint32_t b, int paired);
/* Sets or clears the PAIRED bit of a's entry k (partner b) and of b's entry for a. */
void lc_adj_set_paired(locd_scene *s, uint32_t a, uint32_t k, uint32_t b, int paired);

/* ---- queries (query.c) ---- */
/* The ray-box slab test (docs/scene.md); 1 and *t_enter on a hit. */
int lc_ray_box(const double *b, const double *o, const double *d, double max_t, double *t_enter);

#endif
