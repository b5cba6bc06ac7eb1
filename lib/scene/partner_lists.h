/* Partner lists (partner_lists.c): for each object in the entry lists, the
 * objects whose fat boxes meet its fat box and that may pair with it. A
 * moved object that stays inside its fat box takes its pairs from its list
 * instead of searching the entry lists. docs/scene.md, "Glossary". */
#ifndef LOCD_SCENE_PARTNER_LISTS_H
#define LOCD_SCENE_PARTNER_LISTS_H

#include "scene/entries.h"

/* An entry of a partner list (and of the near-pair list): a dense index,
 * with LC_PAIRED when the two objects are a pair of the current set. */
#define LC_PAIRED 0x80000000u
#define LC_INDEX_BITS 0x7fffffffu

/* One object's list: off and n of its run in the pool, cap the room there. */
typedef struct lc_partner_list {
    uint32_t off, n, cap;
} lc_partner_list;

/* The lists of every dense index (heads of them), runs in one pool. Valid:
 * they are the relation of the entry lists' fat boxes and the filters. */
typedef struct lc_partners {
    int valid;
    lc_partner_list *list;
    size_t heads;                /* headers allocated (the entry lists' cap at the build) */
    uint32_t *pool;
    size_t used, cap, live;      /* pool positions used, allocated; list entries held */
} lc_partners;

/* Builds every live object's list from scratch (after the entry lists are
 * built): the engine's find over the packed fat boxes, then the filter.
 * On failure (NO_MEMORY) leaves the scene without lists (valid 0). */
locd_status lc_partners_build(locd_scene *s);
/* Drops the lists (valid 0). */
void lc_partners_drop(locd_scene *s);
/* Takes dense index d off the lists of its partners and empties its own. */
void lc_partners_unlink(locd_scene *s, uint32_t d);
/* Makes a and b partners (neither in the other's list before), a pair of
 * the current set when `paired`. On no memory the lists are dropped (the
 * scene then searches every moved object). */
void lc_partners_link(locd_scene *s, uint32_t a, uint32_t b, int paired);
/* Sets or clears the PAIRED bit of a's entry k (partner b) and of b's entry for a. */
void lc_partners_set_paired(locd_scene *s, uint32_t a, uint32_t k, uint32_t b, int paired);

#endif
