/* The query tree (query_tree.c): a 4-wide bounding-volume tree over the
 * live objects, for the queries (query.c). Built from the objects in
 * Morton order of their centres, packed four a node, level by level; kept
 * up to date lazily: the first query after a change brings it up to the
 * boxes now (the changed objects' lanes written again, their nodes refitted,
 * new objects in a short list beside the tree), and builds it again when
 * that list grows long or the refitted nodes have grown loose. So it
 * exists in every state of the scene, and a scene nobody queries never
 * pays for it. docs/queries.md. */
#ifndef LOCD_SCENE_QUERY_TREE_H
#define LOCD_SCENE_QUERY_TREE_H

#include "scene/slots.h"

#include <pthread.h>

#define LC_QT_WIDTH 4
#define LC_QT_NONE 0xffffffffu
/* where[slot] of an object in the extra list: the flag and its place. */
#define LC_QT_EXTRA 0x80000000u

/* A node: the bounds of its four lanes (floats rounded outward, so they
 * hold the boxes; an empty lane +inf..-inf), what each lane holds (a node
 * or, with its bit in `objects`, an object's slot), the parent's lane.
 * Two cache lines. */
typedef struct lc_qt_node {
    float lo[3][LC_QT_WIDTH], hi[3][LC_QT_WIDTH];
    uint32_t child[LC_QT_WIDTH];
    uint32_t parent;  /* parent node << 2 | lane; LC_QT_NONE at the root */
    uint8_t objects;  /* bit k: lane k holds an object */
    uint8_t inexact;  /* bit k: lane k's object's box is not floats exactly (test its doubles) */
    uint8_t level;    /* 0: a leaf (its lanes hold objects) */
    uint8_t pad8;
    uint32_t pad[2];
} lc_qt_node;
typedef char lc_qt_node_is_128_bytes[sizeof(lc_qt_node) == 128 ? 1 : -1];

typedef struct lc_query_tree {
    int valid;              /* built (the changes since are pending or in the scene's change lists) */
    lc_qt_node *node;       /* depth first: a node before its children, the root first */
    size_t nnodes, node_cap;
    uint32_t root;
    uint32_t levels;
    uint32_t *where;        /* per slot (where_cap): node << 2 | lane, LC_QT_EXTRA | place, or LC_QT_NONE */
    size_t where_cap;
    uint32_t *extra;        /* live objects beside the tree (added since it was built) */
    size_t nextra, extra_cap;
    uint32_t *pending;      /* slots that updates took in since the last sync */
    size_t npending, pending_cap;
    int all_pending;        /* too many to list: the sync goes over every lane */
    size_t nbuilt;          /* objects in the tree when it was built */
    double area_built, area; /* the leaves' surface area then, and now */
    double size[3];         /* per axis, the largest magnitude of a root lane's bounds (set by a sync) */
    uint64_t synced;        /* the slots' epoch the tree is up to date with (atomic); LC_QT_STALE: not */
    pthread_mutex_t lock;   /* the sync's, for queries from several threads */
    int lock_made;
} lc_query_tree;
#define LC_QT_STALE UINT64_MAX

void lc_query_tree_init(lc_query_tree *t);
void lc_query_tree_fini(locd_scene *s);
/* An update took its changes in (before it clears the change lists): they
 * become pending for the next sync. */
void lc_query_tree_note_update(locd_scene *s);
/* The tree up to date with the boxes now: a sync under the lock when it is
 * not. Queries call it first; nothing else changes. LOCD_ERR_NO_MEMORY
 * leaves the tree as it was (still to be synced). */
locd_status lc_query_tree_sync(const locd_scene *s);

#endif
