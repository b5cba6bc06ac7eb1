/* One update (update.c) and what its paths share: the update's context,
 * the incremental path (incremental.c, with the moved objects' encode in
 * encode_moved.c), the relist path (relist.c) and the step both take to
 * the pairs of the moved objects (moved_pairs.c). Each path builds the new
 * lists in buffers of its own and swaps them in at commit; what the
 * incremental path writes early is undone on failure, so a failing update
 * changes nothing: the changes stay pending for the next one. */
#ifndef LOCD_SCENE_UPDATE_H
#define LOCD_SCENE_UPDATE_H

#include "scene/path.h"
#include "scene/search.h"

/* The incremental path's undo of what it writes early: per moved object,
 * its slot, dense index, cells, record, packed fat box and flags as they
 * were. */
typedef struct lc_undo {
    uint32_t *slot, *dense;
    lc_cells *cells;
    lc_record *rec;
    uint64_t *qfat; /* LC_FAT_WORDS a row */
    uint8_t *flags; /* beside the slot's flags (7 low bits): LC_UNDO_RECORD */
    size_t n, cap;
    size_t ndense_before;
    int gone; /* the removed objects' records carry LC_REC_GONE */
} lc_undo;
/* In lc_undo.flags: the row saved the record only (an object that stayed). */
#define LC_UNDO_RECORD 0x80u

typedef struct lc_update {
    locd_scene *s;
    uint32_t flags;              /* LOCD_SCENE_UPDATE_* */
    lc_path path;                /* the path that made the new set */
    lc_pair_list next, cr, lo;   /* the new set and its created and lost rows */
    /* the incremental path */
    lc_entry_edit edit[2];       /* of the dynamic and of the static list */
    lc_undo undo;
    lc_cells *new_cells;         /* the survey's cells and packed boxes (LC_QPAIR) of the dirty objects, for */
    uint64_t *new_q;             /* the write; pad[0] of the cells is 1 for an object that stays */
    uint32_t *stay, *srch;       /* the moved objects that stay (partner lists) and those that search: dense indices */
    size_t nstay, nsrch;
    int events;                  /* the changes come from the partner lists' PAIRED bits (lc_moved_events) */
    int in_place;                /* the set was patched in its own buffer (next is unused) */
    int partners_after;          /* build the partner lists at commit */
    lc_search_out found;         /* what the moved objects' search found */
    uint64_t *buf;               /* deleted, added and query entries */
    size_t buf_cap;
    uint64_t candidates, moved, reencoded;
    double ms_encode, ms_merge, ms_sweep, ms_events;
} lc_update;

/* ---- the incremental path (incremental.c) ---- */
/* The update from the repaired entry lists. *found: what makes the update
 * choose again (nothing written but scratch). */
locd_status lc_incremental(lc_update *u, lc_finding *found);
/* Puts back what a failed incremental update wrote early. */
void lc_incremental_undo(lc_update *u);
/* Makes the incremental update's lists the scene's. */
void lc_incremental_commit(lc_update *u);

/* ---- the moved objects' encode (encode_moved.c) ----
 * Pass 1 (the survey) computes each dirty object's new cells and packed
 * box and counts its entries; pass 2 writes them, with the undo rows. The
 * counts and places are in the parts of lc_encode_plan. */
typedef struct lc_encode_part {
    size_t b, e;                 /* the part of the dirty list */
    size_t nq, ndel[2], nadd[2]; /* pass 1: counts; pass 2: where to write them in u->buf */
    size_t nstay, nsrch;         /* pass 1: counts; pass 2: where to write them in u->stay, u->srch */
    size_t calm;                 /* pass 1: objects that stayed in their fat boxes (partner lists or not) */
    size_t live, fresh;          /* live objects, those new to the lists; pass 2: first undo row, dense index */
    size_t reenc;                /* objects whose cells changed */
    int outside;                 /* pass 1: a box outside the root cube */
} lc_encode_part;
typedef struct lc_encode_plan {
    lc_update *u;
    lc_encode_part part[LC_MAX_THREADS];
    uint32_t k;
    int pass;
} lc_encode_plan;
/* The dirty list split into k parts (several from LC_ENCODE_SPLIT dirty
 * objects on), and a pass over all of them on the pool. */
void lc_encode_plan_init(lc_encode_plan *p, lc_update *u);
void lc_encode_run(lc_encode_plan *p, int pass);

/* ---- the relist path (relist.c) ---- */
locd_status lc_relist(lc_update *u);

/* ---- the pairs of the moved objects (moved_pairs.c) ---- */
/* Their search (m), the carry pass and the events. */
locd_status lc_moved_pairs(lc_update *u, const lc_moved *m);
/* The same when every moved object has a partner list: the events from
 * the PAIRED bits, then the set patched. */
locd_status lc_moved_events(lc_update *u, const lc_moved *m);

/* ---- the update's buffers (update_buffers.c) ---- */
/* Room for n more entries in u->buf at len. */
locd_status lc_update_room(lc_update *u, size_t len, size_t n);
/* Room for the moved objects' rows: stay and srch, the undo, the survey. */
locd_status lc_update_moved_room(lc_update *u, size_t n, int undo);
/* A new update takes the rows and entry buffer the last one kept
 * (lc_update_keep); lc_update_free keeps them again while they are small
 * and frees the rest; lc_update_keep_release frees them (the scene's end). */
void lc_update_adopt(lc_update *u);
void lc_update_free(lc_update *u);
void lc_update_keep_release(locd_scene *s);

#endif
