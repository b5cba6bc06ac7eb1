/* Slots and ids (slots.c): one object a slot, its box, filter and user
 * value in arrays indexed by slot; the change lists the next update reads.
 * docs/scene.md, "Glossary". */
#ifndef LOCD_SCENE_SLOTS_H
#define LOCD_SCENE_SLOTS_H

#include "levels/levels.h"
#include "locd/scene.h"
#include "octree/octree.h"

#include <float.h>
#include <math.h>

/* Slot flags. */
#define LC_SLOT_LIVE 0x1u      /* holds an object */
#define LC_SLOT_STATIC 0x2u    /* the object is static */
#define LC_SLOT_DIRTY 0x4u     /* added, moved or re-filtered since the last update (on the dirty list) */
#define LC_SLOT_REMOVED 0x8u   /* removed since the last update; freed by the next one */
#define LC_SLOT_LISTED 0x10u   /* has entries in the entry lists (its cells are entries.cell[slot]) */
#define LC_SLOT_REFILTER 0x20u /* its filter changed since the last update (its record is written again) */
#define LC_SLOT_INEXACT 0x40u  /* live, and its box is not floats exactly (fbox holds it rounded) */

/* An id: the serial number of the add (1, 2, ...: never reused) in the high
 * 32 bits, the slot in the low 32. Serials grow with every add, so sorting
 * ids sorts by serial: a pair's order key is serial_a << 32 | serial_b. */
#define LC_ID_SLOT(id) ((uint32_t)((id)&0xffffffffu))
#define LC_ID_SERIAL(id) ((uint32_t)((id) >> 32))
#define LC_MAX_SERIAL 0xffffffffu
/* The id of index i when the slots are in id order and their serials
 * consecutive from serial0 (lc_slots_in_id_order's 2): no read of the
 * per-slot ids, each a cache miss in a pass over pairs. */
#define LC_ID_AFFINE(serial0, i) ((locd_id)((((uint64_t)(serial0) + (i)) << 32) | (i)))

/* How far ahead the passes over scattered slots (a batch's ids, the dirty
 * list) start loading what they read: a miss each, overlapped. */
#define LC_AHEAD 8

/* Batches of this many objects or more, and passes over this many rows
 * or more, run on the pool's threads (below, a pool run costs more than
 * it saves). */
#define LC_PARALLEL_MIN 65536

typedef struct lc_slots {
    size_t nslots;      /* slots ever used */
    size_t live;        /* objects now */
    size_t live_static; /* static objects now */
    size_t slot_cap;
    locd_id *id;        /* the current object's id (kept after removal until freed) */
    double *box;        /* 6 a slot, only once keep_f64 is set (else NULL: lc_slot_box reads fbox) */
    float *fbox;        /* 6 a slot: the box as floats, the engine's cheaper input when every live box is
                           floats exactly (ninexact == 0: always so through the f32 entry points) */
    int keep_f64;       /* some box came in as doubles that are not floats exactly: the doubles are kept
                           (for good). Until then every box is its float copy, and a move writes 24 bytes
                           an object, not 72 */
    size_t ninexact;    /* live objects flagged LC_SLOT_INEXACT */
    float *fbox_spare;  /* fbox's twin (fbox_spare_cap slots), made by the first move of every object in
                           slot order (move.c): such a move writes it while it checks the batch and then
                           swaps it with fbox, one pass over the boxes instead of two */
    size_t fbox_spare_cap;
    uint64_t *cat, *mask, *group, *user;
    uint8_t *flags;
    uint32_t *stamp; /* duplicate check of a batch */
    uint32_t stamp_now;
    lc_buf free_slots; /* uint32 stack */
    size_t nfree;
    uint32_t serial; /* serials issued */
    size_t ncat0;    /* live objects of category 0 (no query mask passes them) */
    /* the changes since the last update */
    lc_buf dirty; /* uint32 slots flagged LC_SLOT_DIRTY */
    size_t ndirty;
    lc_buf removed; /* uint32 slots flagged LC_SLOT_REMOVED */
    size_t nremoved;
    /* Advanced by every add, move and remove: what was made from the boxes
       at one epoch (the move's hand-over) holds while the epoch does. */
    uint64_t epoch;
    /* What a from-scratch update reads of every slot, kept until an add,
       remove or set_filter changes it (moves do not): -1 unknown, else
       lc_slots_in_id_order's and lc_slots_filter_passes_all's answers. */
    int order_known, filter_known;
} lc_slots;

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
/* Marks a slot dirty (on the dirty list; room reserved beforehand). */
void lc_scene_mark_dirty(locd_scene *s, uint32_t slot);
/* Releases every slot removed since the last update to the free list. */
void lc_scene_free_removed(locd_scene *s);
void lc_scene_slots_fini(locd_scene *s);
/* Room for `more` entries in the dirty and removed lists. */
locd_status lc_scene_reserve_lists(locd_scene *s, size_t more_dirty, size_t more_removed);
/* Before a batch of n double boxes is written: sets keep_f64 (the doubles
 * made from the float copies) if one of them is not floats exactly.
 * LOCD_ERR_NO_MEMORY changes nothing. */
locd_status lc_scene_need_doubles(locd_scene *s, const double *boxes, size_t n);
/* 1 when the slots [0, nslots) are all live and their serials ascend, 2
 * when the serials are also consecutive; 0 otherwise. Kept until an add,
 * remove or set_filter. */
int lc_slots_in_id_order(locd_scene *s);
/* 1 when no two of the objects live[0, n) (NULL: the slots in order) can
 * be filtered out: none static, no group, every category meets the AND of
 * all masks. Kept as lc_slots_in_id_order's answer. */
int lc_slots_filter_passes_all(locd_scene *s, const uint32_t *live, size_t n);
/* The live objects of the dirty list (stats.moved). */
size_t lc_slots_live_dirty(const locd_scene *s);
/* Forgets the changes an update has taken in: the dirty list and flags,
 * the removed slots (freed). */
void lc_slots_clear_changes(locd_scene *s);
/* Forgets the kept answers (an add, remove or set_filter changed them). */
void lc_slots_forget_order(lc_slots *sl);
void lc_slots_forget_filter(lc_slots *sl);

/* The slot of index i of a list of slots (live NULL: i itself). */
LC_INLINE uint32_t lc_slot_at(const uint32_t *live, size_t i)
{
    return live ? live[i] : (uint32_t)i;
}

/* Starts loading the id and flags of the slot id names (a batch's checks
 * read them), if it is one of the scene's. */
LC_INLINE void lc_slot_prefetch(const lc_slots *sl, locd_id id)
{
    const uint32_t slot = LC_ID_SLOT(id);
    if (slot < sl->nslots) {
        __builtin_prefetch(sl->id + slot);
        __builtin_prefetch(sl->flags + slot);
    }
}

/* Slot's box as doubles: the kept doubles, or (keep_f64 unset) its float
 * copy converted into tmp, the same values. */
LC_INLINE const double *lc_slot_box(const lc_slots *sl, size_t slot, double tmp[6])
{
    const float *f = sl->fbox + 6 * slot;
    int a;
    if (sl->keep_f64)
        return sl->box + 6 * slot;
    for (a = 0; a < 6; a++)
        tmp[a] = (double)f[a];
    return tmp;
}

/* Starts loading slot's box (for a write when `write`). */
LC_INLINE void lc_slot_prefetch_box(const lc_slots *sl, size_t slot, int write)
{
    if (sl->keep_f64) {
        if (write) {
            __builtin_prefetch(sl->box + 6 * slot, 1);
            __builtin_prefetch(sl->box + 6 * slot + 5, 1);
        } else {
            __builtin_prefetch(sl->box + 6 * slot);
            __builtin_prefetch(sl->box + 6 * slot + 5);
        }
    }
    if (write)
        __builtin_prefetch(sl->fbox + 6 * slot, 1);
    else
        __builtin_prefetch(sl->fbox + 6 * slot);
}

/* The pair filter: may slots a and b pair at all? */
LC_INLINE int lc_slots_may_pair(const lc_slots *sl, uint32_t a, uint32_t b)
{
    if ((sl->flags[a] & sl->flags[b] & LC_SLOT_STATIC) != 0)
        return 0;
    if (!(sl->cat[a] & sl->mask[b]) || !(sl->cat[b] & sl->mask[a]))
        return 0;
    return !(sl->group[a] == sl->group[b] && sl->group[a] != 0);
}

/* Closed boxes a and b overlap. */
LC_INLINE int lc_box_overlap(const double *a, const double *b)
{
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

#endif
