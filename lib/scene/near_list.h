/* The near-pair list (near_list.c): the pairs of a scene whose objects all
 * move a little every frame, without a sweep at every frame (a Verlet list
 * with a skin). docs/scene.md, "Glossary". */
#ifndef LOCD_SCENE_NEAR_LIST_H
#define LOCD_SCENE_NEAR_LIST_H

#include "scene/pair_set.h"

/* Per object i (slots all live, in id order), the objects j > i whose fat
 * boxes (the box grown on each side by its largest edge >> (LC_NEAR_SHIFT
 * + backoff.near_narrow) when the list was built) meet its own and that may pair with it,
 * nb[off[i], off[i + 1]), each with LC_PAIRED when the two are a pair of
 * the current set. Valid while only moves happened since it was built and
 * every box stayed inside its fat box. */
typedef struct lc_near {
    int valid;
    size_t n, count; /* objects, candidates */
    float *fat;      /* 6 per object */
    uint32_t *off;   /* n + 1 */
    uint32_t *nb;
    size_t n_cap, nb_cap;
    uint32_t served; /* updates that took the list since it was built */
} lc_near;

/* 1 when a list can be built for the scene as it is: the slots are the
 * engine's input as they are, every box a float exactly (at any size), and
 * the scene was not made with LOCD_SCENE_NO_NEAR_LIST. */
int lc_near_applies(locd_scene *s);
/* 1 when the list is valid and nothing but moves happened since it was built. */
int lc_near_usable(const locd_scene *s);
/* Builds the list from the boxes now and writes their pair set into next
 * (sorted; next->first may be past 0). *built = 0 (next empty) when no
 * list can be made of these boxes (a fat box past the float range, too
 * many candidates): the caller goes from scratch. */
locd_status lc_near_build(locd_scene *s, lc_pair_list *next, uint64_t *candidates, int *built);
/* The pair set of the boxes now into next, created and lost into cr and lo
 * (*diff = 1 when they did not fit: the caller diffs the sets), from the
 * list; *left = 1 (nothing written, the list no longer valid) when a box
 * lies outside its fat box. */
locd_status lc_near_frame(locd_scene *s, lc_pair_list *next, lc_pair_list *cr, lc_pair_list *lo, uint64_t *candidates,
                          int *left, int *diff);
/* The list is no longer the scene's (valid 0; its memory kept). */
void lc_near_forget(locd_scene *s);
void lc_near_release(locd_scene *s);

#endif
