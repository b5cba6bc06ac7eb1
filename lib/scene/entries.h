/* The entry lists and what they are made of: each object's cells (from
 * its fat box, cells.c), its dense index and record, and the two sorted
 * entry lists (entry_list.c), one of the dynamic objects and one of the
 * static ones; entries.c builds them from every live object and drops
 * them. docs/scene.md, "Glossary". */
#ifndef LOCD_SCENE_ENTRIES_H
#define LOCD_SCENE_ENTRIES_H

#include "scene/slots.h"

/* Record flags beside LC_SLOT_STATIC and LC_SLOT_DIRTY, while an update
 * runs. SEARCH: the object's pairs are searched in the entry lists this
 * update (it is new, re-filtered, or left its fat box); a moved object
 * without it stays, and takes its pairs from its partner list. GONE: the
 * object was removed (set by the update that takes the removal in; its
 * dense index is not given again before the lists are built again): its
 * partners skip it. */
#define LC_REC_SEARCH 0x100u
#define LC_REC_GONE 0x200u

/* The cells an object's entries were made from: its level, the first cell
 * per axis and whether it spans a second one (bit a of span). Enough to
 * write its entries again, so the old entries of a moved object can be
 * found and removed without keeping them. */
typedef struct lc_cells {
    uint32_t c0[3];
    uint8_t level, span, pad[2];
} lc_cells;

/* What the search reads of a candidate once its fat box passed, and all
 * the partner-list pass reads of a partner, one cache line: the packed
 * sweep box (lc_pack_qbox) of the object's box, the filter, the id (a
 * found pair's row needs no read of the per-slot ids, a cache miss each),
 * the slot and the flags. Records are indexed by a dense index that the
 * entries carry instead of the slot: a build numbers the objects in the
 * order of the sorted entry lists, so the objects of one cell have
 * neighbouring records and a search reads them in a few cache lines.
 * Objects added later take the next indices. */
typedef struct lc_record {
    uint64_t qlo, qhi;
    uint64_t cat, mask, group;
    locd_id id;
    uint32_t slot;
    uint32_t flags; /* LC_SLOT_STATIC; LC_SLOT_DIRTY, LC_REC_SEARCH, LC_REC_GONE while an update runs */
    uint64_t pad;   /* to 64 bytes: a large array of them starts on a cache line (lc_alloc) */
} lc_record;
typedef char lc_record_is_64_bytes[sizeof(lc_record) == 64 ? 1 : -1];

/* The packed fat box of dense index d (the one its cells and entries are
 * made from) is qfat[LC_FAT_WORDS * d], qfat[LC_FAT_WORDS * d + 1]. */
#define LC_FAT_WORDS 2
/* lc_cells_of's packed boxes: the fat box's two words, then the box's. */
#define LC_QPAIR 4
/* The fat box's margin on each side: its largest edge >> LC_FAT_SHIFT (in
 * quantized units). An object that moves inside its fat box keeps its
 * cells and its partner list. */
#define LC_FAT_SHIFT 4

/* An entry list: a main array sorted by key (entry >> index_bits), in
 * which a deleted entry is a tombstone (its index bits all set: the key,
 * hence the order of keys, stays), and a small sorted overflow of the
 * entries added since the last compaction. Both are searched; a compaction
 * merges them when the overflow and the tombstones pass a fraction of the
 * main array. per_level counts the live entries of each level (a level
 * with none is never searched). */
typedef struct lc_entry_list {
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
} lc_entry_list;

/* The scene's entry lists. Valid: the lists, cells, dense indices and
 * records are those of the last update's boxes, on grid. Dropped by an
 * update that goes from scratch; built again by the next one that
 * searches (a relist). */
typedef struct lc_entries {
    int valid;
    locd_grid grid;
    lc_entry_list dyn, sta; /* the entries of the dynamic and of the static objects */
    lc_cells *cell;         /* per slot (slot_cap: grown with the slots), valid with LC_SLOT_LISTED */
    uint32_t *dense;        /* per slot, valid with LC_SLOT_LISTED: its dense index */
    lc_record *rec;         /* per dense index (cap of them; ndense issued since the lists were built) */
    uint64_t *qfat;         /* per dense index, LC_FAT_WORDS: the packed fat box, 16 bytes (4 a cache
                               line) for the search's first test */
    size_t cap, ndense;
} lc_entries;

/* The tombstone of an entry, and whether an entry is one. */
#define LC_TOMB(g, e) ((e) | ((((uint64_t)1) << (g)->index_bits) - 1))
#define LC_IS_TOMB(g, e) ((~(e) & ((((uint64_t)1) << (g)->index_bits) - 1)) == 0)

/* ---- cells (cells.c) ---- */
/* An object's cells on grid g (those of its fat box), and the packed sweep
 * boxes (lc_pack_qbox) of its fat box (q[0], q[1]) and of its box (q[2], q[3]). */
void lc_cells_of(const locd_grid *g, const double *b, lc_cells *c, uint64_t q[LC_QPAIR]);
/* lc_cells_of in two steps: the box's quantized corners k and packed box
 * (q[2], q[3]), returning its largest edge; then its fat box and cells
 * (q[0], q[1], c), which an object that stays in its fat box skips. */
typedef struct lc_qcorners {
    int32_t lo[3], hi[3];
} lc_qcorners;
uint32_t lc_cells_box(const locd_grid *g, const double *b, lc_qcorners *k, uint64_t q[LC_QPAIR]);
void lc_cells_fat(const locd_grid *g, const lc_qcorners *k, uint32_t ext, lc_cells *c, uint64_t q[LC_QPAIR]);
int lc_cells_same(const lc_cells *a, const lc_cells *b);
/* Writes the object's entries (1 to 8) from its cells; returns how many. */
uint32_t lc_cells_entries(const locd_grid *g, const lc_cells *c, uint32_t index, uint64_t *out);
/* How many entries lc_cells_entries writes for c (two cells on each axis it spans). */
LC_INLINE uint32_t lc_cells_count(const lc_cells *c)
{
    return 1u << (((c->span >> 0) & 1u) + ((c->span >> 1) & 1u) + ((c->span >> 2) & 1u));
}
/* A grid fitted to the live boxes with a margin, with index bits for the
 * dense indices a build of the slots makes room for. */
locd_status lc_entries_fit_grid(locd_scene *s, locd_grid *g);
/* 1 if box b quantizes inside the root cube without clamping. */
int lc_grid_holds(const locd_grid *g, const double *b);
/* The dense indices a build of nslots slots makes room for. */
size_t lc_entries_room(size_t nslots);

/* ---- one entry list (entry_list.c) ---- */
void lc_entry_list_release(const locd_allocator *a, lc_entry_list *t);
/* Counts t's entries per level. */
void lc_entry_list_count_levels(const locd_grid *g, lc_entry_list *t);
/* Builds t's directory (none for a small main array; nothing changes on
 * failure, the directory is only a shortcut). */
void lc_entry_list_build_dir(const locd_allocator *a, const locd_grid *g, lc_entry_list *t);
/* The first position of t's main array whose entry is >= v, where v is a
 * key << index_bits (the order of the main array is by key). */
size_t lc_entry_list_lower_bound(const lc_entry_list *t, uint64_t v);
/* Where a change of a list is written: tombstones in place (positions and
 * old values kept for undo), or a new list when the change compacts. */
typedef struct lc_entry_edit {
    int compacted;     /* the new list is `out`; t is untouched */
    lc_entry_list out; /* compacted: the new list; else only its ovf/novf/per_level are new */
    size_t *pos;       /* tombstoned positions of t's main array */
    uint64_t *old;     /* and the entries they held */
    size_t npos, pos_cap;
} lc_entry_edit;
/* Applies del (entries of t, sorted) and add (sorted) to t: tombstones in
 * t's main array (undone by lc_entry_edit_undo) and a new overflow in
 * e->out, or a compacted new list in e->out. */
locd_status lc_entry_edit_apply(const locd_allocator *a, const locd_grid *g, lc_entry_list *t, const uint64_t *del,
                                size_t ndel, const uint64_t *add, size_t nadd, lc_entry_edit *e);
void lc_entry_edit_undo(lc_entry_list *t, lc_entry_edit *e);
/* Makes the edit t's state (t takes e->out's buffers). */
void lc_entry_edit_commit(const locd_allocator *a, lc_entry_list *t, lc_entry_edit *e);
void lc_entry_edit_free(const locd_allocator *a, lc_entry_edit *e);
/* What t will be after edit e, without copying: a view (not to be freed). */
void lc_entry_edit_view(const lc_entry_list *t, const lc_entry_edit *e, lc_entry_list *v);

/* ---- the scene's entry lists (entries.c) ---- */
/* Builds the entry lists, cells, dense indices and records of every live
 * object from its current box on a new grid, and makes them the scene's
 * (valid). They are a function of the current boxes alone, so installing
 * them before an update's end changes nothing a failing update must undo.
 * Nothing changes on failure. */
locd_status lc_entries_build(locd_scene *s);
/* Drops the lists (valid 0; no slot LC_SLOT_LISTED). */
void lc_entries_drop(locd_scene *s);
void lc_entries_fini(locd_scene *s);
/* The record of slot k from its slot arrays and packed boxes (lc_cells_of's). */
void lc_record_fill(const lc_slots *sl, size_t k, const uint64_t qbox[LC_QPAIR], lc_record *r);

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

/* Whether the boxes of records hm and ho overlap: their packed boxes
 * first. Strictly overlapping packed boxes need no exact test: the
 * quantization is monotone, so q(x) < q(y) implies x < y. Only a tie
 * (equal packed ends) may hide boxes that do not overlap. */
LC_INLINE int lc_records_meet(const lc_slots *sl, const lc_record *hm, const lc_record *ho)
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
    return !tie || lc_box_overlap(lc_slot_box(sl, hm->slot, tm), lc_slot_box(sl, ho->slot, to));
}

#endif
