/* Private declarations of the filter pipeline (shapes, narrow phase, swept
 * tests). Shared by the C sources and the C++ FCL glue. Not installed. */
#ifndef LOCD_NARROW_H
#define LOCD_NARROW_H

#include "core/core.h" /* the handle magics, among the others' */
#include "locd/pipeline.h"
#include "locd/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct lc_fcl_geom lc_fcl_geom;

struct locd_shape {
    uint32_t magic;
    int32_t kind;
    int32_t refs;         /* world references + the caller's handle */
    double radius;        /* sphere, capsule */
    double half[3];       /* box half extents; capsule: half[2] = half length */
    double *points;       /* convex points or mesh vertices, 3 per point */
    size_t npoints;
    uint32_t *tris;       /* mesh: 3 indices per triangle */
    size_t ntris;
    double *tri_boxes;    /* mesh: local box of each triangle (6 per triangle) */
    double centroid[3];   /* local point inside the shape (libccd's centre) */
    double bound_radius;  /* every point of the shape is within this of the local origin */
    double extent;        /* smallest local box edge: the "size" of the swept threshold */
    double local_box[6];
    lc_fcl_geom *fcl;     /* FCL geometry, NULL for convex hulls or without FCL */
};

/* A shape placed in the world: rotation (row-major) and translation. */
typedef struct lc_placed {
    const locd_shape *s;
    double R[9];
    double t[3];
} lc_placed;

/* One contact: depth, normal from a to b, point. */
typedef struct lc_contact {
    double depth;
    double normal[3];
    double point[3];
} lc_contact;

/* ---- pose math (shape.c) ---- */
/* 1 when the pose is finite with a non-zero quaternion (R and t filled), else 0. */
int lc_pose_to_rt(const double *pose, double *R, double *t);
void lc_place(const locd_shape *s, const double *pose_R, const double *pose_t, lc_placed *out);
/* World box of a placed shape. */
void lc_placed_box(const lc_placed *p, double *box);
locd_status lc_shape_check(const locd_shape *s);
void lc_shape_retain(locd_shape *s);
void lc_shape_release(locd_shape *s);

/* ---- closed forms (closed_form.c): return 1 hit, 0 miss; contact may be NULL ---- */
int lc_closed_supported(int32_t ka, int32_t kb);
int lc_closed_test(const lc_placed *a, const lc_placed *b, lc_contact *c);
/* Swept sphere-sphere: b moves by d relative to a; *toi in [0, 1]. */
int lc_closed_sweep_spheres(const lc_placed *a, const lc_placed *b, const double *d, double *toi);

/* ---- libccd (ccd_glue.c): 1 hit, 0 miss, LOCD_ERR_INTERNAL (raised) for a mesh pair ---- */
int lc_ccd_test(const lc_placed *a, const lc_placed *b, int want_contact, int32_t method, lc_contact *c);
/* b moves by d (world) relative to a during the step; 1 and *toi when they meet. */
int lc_ccd_sweep(const lc_placed *a, const lc_placed *b, const double *d, double *toi);

/* ---- FCL glue (fcl_glue.cpp): no exception crosses these ---- */
/* NULL on failure with err filled. */
lc_fcl_geom *lc_fcl_make(const locd_shape *s, char *err, size_t errlen);
void lc_fcl_free(lc_fcl_geom *g);
/* 1 hit, 0 miss, -1 error (err filled; the caller raises it: this side is
 * C++ and reports through err rather than lc_error). */
int lc_fcl_test(const lc_placed *a, const lc_placed *b, int want_contact, lc_contact *c, char *err, size_t errlen);

/* ---- routing (pair_test.c) ---- */
int32_t lc_route_resolve(int32_t route, int32_t ka, int32_t kb);
/* Runs the pair test through a resolved route; counts go to the stats
 * counters (may be NULL). 1 hit, 0 miss, negative locd_status on error. */
int lc_pair_test(const lc_placed *a, const lc_placed *b, int32_t route, int want_contact, int32_t method,
                 lc_contact *c, uint64_t *counts /* closed, ccd, fcl */);
int lc_pair_sweep(const lc_placed *a, const lc_placed *b, const double *d, int32_t route, double *toi,
                  uint64_t *counts);

/* ---- world and contacts handles (world.c, pipeline.c) ---- */

/* An object's collision filter (the scene's rule, locd/scene.h). */
typedef struct lc_filter {
    uint64_t category, mask, group;
} lc_filter;

/* The world's broad phase (world_broad.c): a locd scene holding every live
 * object's box, moved only when the box changed; for an engine of level 2 or 3
 * (no scene there) a from-scratch find on the live boxes each collide. */
typedef struct lc_world_broad {
    locd_scene *scene; /* NULL: the from-scratch path */
    lc_buf ids;        /* locd_id per object index; LOCD_ID_NONE until first in the scene */
    lc_buf held;       /* 6 doubles per object: the box the scene holds */
    /* scene id -> object index: open addressing, key 0 = empty; ids are never
     * reused, so entries are never deleted (removed objects keep theirs) */
    uint64_t *map_keys;
    uint32_t *map_vals;
    size_t map_cap, map_used;
    lc_buf pending;    /* uint8 per object: box recomputed since the scene last took it */
    /* The broad pairs as sorted keys (i << 32 | j), kept up to date from the
     * scene's created and lost lists; resync: rebuild them from its full list. */
    lc_buf keys, keys2, ck, lk, scratch;
    size_t nkeys;
    int resync;
    /* per-collide batches */
    lc_buf b_idx, b_ids, b_boxes, b_cat, b_mask, b_group;
} lc_world_broad;

/* Contact begin/end (world_events.c): sorted (i << 32 | j) keys of the
 * previous collide's contacts, and the lists of the last one. */
typedef struct lc_world_events {
    lc_buf prev, cur, scratch; /* uint64 keys */
    size_t prev_n;
    lc_buf began, ended; /* uint32 pairs */
    size_t began_n, ended_n;
} lc_world_events;

struct locd_world {
    uint32_t magic;
    locd_allocator alloc; /* the config's: every array below and the world itself */
    locd_engine *engine;
    locd_pairs *pairs;
    locd_shape **shapes; /* NULL for a removed object */
    lc_buf filter;       /* lc_filter per object */
    lc_buf dirty;        /* uint8 per object: pose or velocity changed since its box was computed */
    int all_dirty;       /* every box to recompute (scratch regrown, options changed) */
    int32_t box_swept;   /* the options the boxes were computed with */
    double box_dt, box_threshold;
    size_t live;         /* objects not removed */
    lc_world_broad broad;
    lc_world_events events;
    double *poses; /* 7 per object */
    double *vel;   /* 6 per object */
    size_t n, cap;
    /* scratch of the last collide, sized to scratch_n objects */
    double *R;      /* 12 per object: rotation then translation */
    double *boxes;  /* 6 per object */
    uint8_t *fast;  /* 1 = swept */
    uint32_t *work; /* pair indices split by stage */
    size_t scratch_n, work_cap;
};

struct locd_contacts {
    uint32_t magic;
    int has_contact;
    size_t count, cap;
    uint32_t *pairs;
    double *toi, *depth, *normal, *point;
};

locd_status lc_world_check(const locd_world *w);
/* The broad phase on the world's boxes (w->boxes, live objects) into
 * w->pairs, i < j, in a deterministic order ((i, j) on the scene path; the
 * engine's order, or (i, j) with LOCD_FIND_SORTED, on the from-scratch path);
 * *candidates gets the pairs tested. */
locd_status lc_world_broad_open(locd_world *w);
void lc_world_broad_close(locd_world *w);
locd_status lc_world_broad_reserve(locd_world *w, size_t objects);
locd_status lc_world_broad_find(locd_world *w, uint32_t find_flags, uint64_t *candidates);
/* Takes object index out of the scene (if it is there). */
locd_status lc_world_broad_remove(locd_world *w, uint32_t index);
/* Gives the scene the object's new filter (if it is there). */
locd_status lc_world_broad_filter(locd_world *w, uint32_t index, const lc_filter *f);
/* The events of a collide whose contacts are c. */
locd_status lc_world_events_update(locd_world *w, const locd_contacts *c);
void lc_world_events_clear(locd_world *w);
void lc_world_events_free(locd_world *w);
/* Frees the pipeline's per-object scratch (R, boxes, fast). */
void lc_world_free_scratch(locd_world *w);
locd_status lc_contacts_check(const locd_contacts *c);
locd_status lc_contacts_reserve(locd_contacts *c, size_t count);

#ifdef __cplusplus
}
#endif

#endif
