/* The pairs of the moved objects (search.c): an object that searches (new,
 * re-filtered, or out of its fat box) searches the entry lists; one that
 * stays in its fat box takes its partner list. docs/scene.md, "One update". */
#ifndef LOCD_SCENE_SEARCH_H
#define LOCD_SCENE_SEARCH_H

#include "scene/pair_set.h"
#include "scene/partner_lists.h"

/* What lc_search_moved finds. LC_SEARCH_ROWS: the moved objects' rows
 * (sorted). LC_SEARCH_EVENTS: the search's fat partners, uint32 (m, o |
 * LC_PAIRED when their boxes meet), each pair once; and the changes the
 * partner-list pass found, uint32 (m, k, o | LC_PAIRED now), k being o's
 * place in m's list: the pairs whose PAIRED bit is wrong now. */
enum { LC_SEARCH_ROWS, LC_SEARCH_EVENTS };
typedef struct lc_search_out {
    lc_pair_list rows;
    lc_buf fat, ev;
    size_t nfat, nev;
    uint64_t candidates; /* added to */
} lc_search_out;

/* The objects that search (their entries q[0, nq), sorted, searched in the
 * lists dyn and sta) and those that stay (dense indices stay[0, nstay),
 * from their partner lists). */
typedef struct lc_moved {
    const lc_entry_list *dyn, *sta;
    const uint64_t *q;
    size_t nq;
    const uint32_t *stay;
    size_t nstay;
} lc_moved;

/* The pairs of the moved objects, as mode asks. */
locd_status lc_search_moved(const locd_scene *s, const lc_moved *m, int mode, lc_search_out *out);
void lc_search_out_fini(const locd_allocator *a, lc_search_out *o);

#endif
