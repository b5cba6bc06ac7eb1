/* The pair set: sorted pair lists (pair_list.c), the set of the last
 * update with its created and lost rows and the spare buffers the next
 * update writes into (pair_set.c), the carry pass (carry.c) and the patch
 * (patch.c). docs/scene.md, "Glossary". */
#ifndef LOCD_SCENE_PAIR_SET_H
#define LOCD_SCENE_PAIR_SET_H

#include "scene/slots.h"

/* A sorted pair list: rows of two ids, first < second, sorted by
 * (first, second), which is the order of the key serial_a << 32 | serial_b. */
typedef struct lc_pair_list {
    lc_buf rows; /* locd_id, two a row */
    size_t count;
    size_t first; /* the list starts at this row of the buffer (a pass that writes from the middle) */
} lc_pair_list;

/* The set of the last update and its events. The spares are the buffers
 * of the set and the events before last: the next update writes into
 * them, so that a frame does not fault in lists sized for a whole set (a
 * million-pair list is 16 MB, faulted in again when new). */
typedef struct lc_pair_set {
    int valid;                          /* an update was made: pairs is the set of its boxes */
    lc_pair_list pairs, created, lost;  /* the current set and the last events */
    lc_pair_list spare;                 /* the set before last's buffer */
    lc_pair_list spare_created, spare_lost;
    lc_pair_list spare_dropped;         /* the carry pass's dropped rows (sized for a set), kept too */
    int show_pairs, show_events;        /* the flags of the last update */
} lc_pair_set;

/* The first row of a sorted pair list. */
LC_INLINE locd_id *lc_pair_list_rows(const lc_pair_list *p)
{
    return (locd_id *)p->rows.data + 2 * p->first;
}
/* The order key of a row: serial_a << 32 | serial_b. */
LC_INLINE uint64_t lc_pair_key(const locd_id *row)
{
    return (uint64_t)LC_ID_SERIAL(row[0]) << 32 | LC_ID_SERIAL(row[1]);
}

/* ---- sorted pair lists (pair_list.c) ---- */
locd_status lc_pair_list_reserve(const locd_allocator *a, lc_pair_list *p, size_t rows);
void lc_pair_list_fini(const locd_allocator *a, lc_pair_list *p);
/* Sorts rows[0, n) by key (scratch: 2 * n locd_id). */
locd_status lc_pair_rows_sort(const locd_allocator *a, locd_id *rows, size_t n);
/* The first row of sorted rows[0, n) whose key is >= key. */
size_t lc_pair_rows_lower_bound(const locd_id *rows, size_t n, uint64_t key);
/* Both differences of sorted a and b in one merge: amb = a \ b (room for
 * na rows), bma = b \ a (room for nb rows). */
void lc_pair_rows_diff(const locd_id *a, size_t na, const locd_id *b, size_t nb, locd_id *amb, size_t *namb,
                       locd_id *bma, size_t *nbma);

/* ---- the set (pair_set.c) ---- */
/* The spare buffers, lent to an update for its new set and its events (each
 * emptied), and given back when it fails. */
void lc_pair_set_lend(lc_pair_set *ps, lc_pair_list *next, lc_pair_list *created, lc_pair_list *lost);
void lc_pair_set_give_back(lc_pair_set *ps, lc_pair_list *next, lc_pair_list *created, lc_pair_list *lost);
/* Makes next (unless in_place: the set was patched in its own buffer),
 * created and lost the set's; the buffers they replace become the spares. */
void lc_pair_set_take(lc_pair_set *ps, lc_pair_list *next, int in_place, lc_pair_list *created, lc_pair_list *lost);
/* created = next \ set and lost = set \ next, split over the pool. */
locd_status lc_pair_set_diff(locd_scene *s, const lc_pair_list *next, lc_pair_list *created, lc_pair_list *lost);
void lc_pair_set_fini(const locd_allocator *a, lc_pair_set *ps);

/* ---- the carry pass (carry.c) ---- */
/* Into *next the set's rows whose ends did not change (dirty or removed
 * slots) merged with the new rows n (sorted), into *dropped the others. */
locd_status lc_carry(locd_scene *s, const lc_pair_list *n, lc_pair_list *next, lc_pair_list *dropped);

/* ---- the patch (patch.c) ---- */
/* Into *next the set without the rows lost (sorted, all in it) and with
 * the rows created (sorted, none in it). LOCD_ERR_INTERNAL when a lost row
 * is not in the set. */
locd_status lc_patch(locd_scene *s, const lc_pair_list *lost, const lc_pair_list *created, lc_pair_list *next);
/* The same in the set's own buffer (its start moves toward the buffer's
 * end). 0 when it cannot (no room after the set, no memory, a lost row not
 * in the set): nothing was changed, lc_patch does it. It cannot fail once
 * it starts, so it is an update's last step. */
int lc_patch_in_place(locd_scene *s, const lc_pair_list *lost, const lc_pair_list *created);

#endif
