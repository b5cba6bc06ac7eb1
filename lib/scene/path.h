/* The update's path (path.c): one pure function chooses it from the
 * scene's state and the batch, and the back-off waits that keep caches
 * from being built for nothing. docs/scene.md, "The paths" copies the
 * rule of lc_path_choose. */
#ifndef LOCD_SCENE_PATH_H
#define LOCD_SCENE_PATH_H

#include "scene/slots.h"

typedef enum lc_path {
    LC_PATH_FROM_SCRATCH, /* the engine's find (or the kept entry list); the entry lists dropped */
    LC_PATH_NEAR_BUILD,   /* from scratch, building the near-pair list */
    LC_PATH_NEAR,         /* the near-pair list's pass */
    LC_PATH_INCREMENTAL,  /* the entry lists repaired; the moved objects search or stay */
    LC_PATH_RELIST        /* the entry lists and partner lists built again; the moved objects take them */
} lc_path;

/* What a path may find on its way, that makes the update choose again. */
typedef enum lc_finding {
    LC_FOUND_NOTHING,
    LC_FOUND_LEFT_NEAR, /* near: a box left its near-pair list's fat box (the list is no longer valid) */
    LC_FOUND_OUTSIDE,   /* incremental: a box outside the root cube, or more new objects than the numbering holds */
    LC_FOUND_MOST_LEFT  /* incremental: most moved objects left their fat boxes (the partner lists were dropped) */
} lc_finding;

/* The back-off waits: how many updates a cache waits before it is built
 * again after it did not pay for itself. */
typedef struct lc_backoff {
    uint32_t calm_updates; /* incremental updates in a row, without partner lists, whose moved objects
                              stayed in their fat boxes */
    uint32_t band_updates; /* from-scratch updates in a row with no entry lists and 8% to 25% moved */
    uint32_t band_wait;    /* how many of those before a relist (0: LC_BAND_WAIT) */
    uint32_t near_wait;    /* the near-pair list's wait after a list that served no update */
    uint32_t near_skip;    /* from-scratch updates left that do not build the list */
    int32_t near_narrow;   /* the near-pair list's margin is the largest edge >> (LC_NEAR_SHIFT + near_narrow):
                              0 (an eighth) at first, -1 (a quarter) to 1 (a sixteenth) after lists that
                              served few or many updates (path.c) */
} lc_backoff;

#define LC_NEAR_SHIFT 3
#define LC_NEAR_NARROW_MIN (-1)
#define LC_NEAR_NARROW_MAX 1

/* What the choice reads. */
typedef struct lc_path_facts {
    size_t moved, live;    /* live objects added, moved or re-filtered; live objects */
    int has_set;           /* an update was made */
    int has_entries, has_partners;
    int near_usable;       /* the near-pair list is valid and only moves happened since */
    int near_applies;      /* a near-pair list can be built for the scene as it is */
    lc_backoff backoff;
    lc_finding finding;    /* what the path tried last found (LC_FOUND_NOTHING at first) */
} lc_path_facts;

void lc_path_facts_of(locd_scene *s, size_t moved, lc_finding finding, lc_path_facts *f);
lc_path lc_path_choose(const lc_path_facts *f);
/* Whether an incremental update's survey drops the partner lists: `left`
 * of its moved objects left their fat boxes, `stayed` did not, of `live`. */
int lc_path_partners_go(size_t left, size_t stayed, size_t live);

/* The waits after a choice (band_updates, near_skip), and after what the
 * paths found: a near-pair list that a box left (served: the updates it
 * served; also sets the next list's margin), partner lists dropped, and
 * the survey of an incremental update (calm: its moved objects that stayed
 * in their fat boxes, of total; 1 when the partner lists are to be built
 * at its end). */
void lc_backoff_chose(lc_backoff *b, const lc_path_facts *f, lc_path p);
void lc_backoff_near_left(lc_backoff *b, uint32_t served);
void lc_backoff_partners_dropped(lc_backoff *b);
int lc_backoff_survey(lc_backoff *b, int has_partners, size_t calm, size_t total);
void lc_backoff_partners_built(lc_backoff *b);

#endif
