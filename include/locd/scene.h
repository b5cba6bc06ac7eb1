/*
 * locd scene: a persistent broad phase for a world that changes a little each
 * frame (docs/scene.md explains the design and why it stays exact).
 *
 * Objects live in the scene under a stable 64-bit id. They are added, moved,
 * removed and re-filtered in batches; locd_scene_update then gives the full set
 * of overlapping pairs and/or the pairs created and lost since the previous
 * update. Queries (box, point, ray segment) see the scene as it is now,
 * updated or not.
 *
 * A pair (a, b) is reported iff
 *   - the boxes overlap (closed intervals, as in locd.h),
 *   - (category_a & mask_b) != 0 and (category_b & mask_a) != 0,
 *   - not (group_a == group_b && group_a != 0),
 *   - and not both objects are static.
 * Pairs are rows (first, second) of ids with first < second, the rows sorted
 * ascending: the order is the same for every thread count and every run.
 *
 * Ids: never 0 (LOCD_ID_NONE), never reused within a scene's lifetime. A
 * removed or never-issued id is stale: any call naming it fails with
 * LOCD_ERR_STALE_ID. The slot index and a generation are packed in the id;
 * treat it as opaque.
 *
 * Batches: a call that fails changes nothing (the whole batch is rejected);
 * locd_last_error_index() names the first bad position in the batch and
 * locd_last_error() says what is wrong with it. One exception: a batch whose
 * count n no scene could hold (add: beyond 2^32 - 1 objects; move, remove,
 * set_filter, set_user: more ids than the scene has objects, so one must be
 * stale or repeated) fails with LOCD_ERR_TOO_MANY_OBJECTS and index -1
 * before its arrays are read (such an n is usually a caller's bug, and the
 * arrays may not be that long).
 *
 * Threads: one thread at a time may change or update a scene. Queries only
 * read: several threads may query at once while nobody changes the scene.
 * The scene runs its work on its engine's thread pool (level 1). An engine of
 * level 2 or 3 gives LOCD_ERR_UNSUPPORTED (docs/levels.md says why).
 */
#ifndef LOCD_SCENE_H
#define LOCD_SCENE_H

#include "locd/locd.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct locd_scene locd_scene;

typedef uint64_t locd_id;
#define LOCD_ID_NONE ((locd_id)0)

/* ------------------------------------------------------------------ */
/* Creation                                                           */
/* ------------------------------------------------------------------ */

typedef struct locd_scene_config {
    uint32_t size;            /* sizeof(locd_scene_config) */
    uint32_t flags;           /* LOCD_SCENE_* below, or 0 */
    uint64_t capacity_hint;   /* objects to reserve room for; 0 = grow as needed */
} locd_scene_config;

/* config->flags: the scene never builds its near-pair list. When most
 * objects move a little at every update, the list (docs/scene.md) makes
 * most updates a fraction of a from-scratch one, at the price of an update
 * that builds it every few frames and costs more than one from scratch.
 * With this flag each such update goes from scratch: a steadier cost per
 * frame, higher on average. The results are the same either way. */
#define LOCD_SCENE_NO_NEAR_LIST 0x1u

/* Smallest config->size accepted: the three fields above. */
#define LOCD_SCENE_CONFIG_MIN_SIZE 16u

LOCD_API void locd_scene_config_init(locd_scene_config *config);

/* The scene uses the engine's threads, allocator, log, max_depth and
 * cell_bias (its cells one step finer: cell_bias - 1, at least 0). The engine must be level 1 (LOCD_ERR_UNSUPPORTED otherwise) and
 * must outlive the scene; while the scene updates, the engine is busy (a find
 * on it from another thread returns LOCD_ERR_BUSY, and the reverse).
 * config may be NULL for the defaults. On failure *out is set to NULL. */
LOCD_API locd_status locd_scene_create(locd_engine *engine, const locd_scene_config *config, locd_scene **out);
/* NULL is ignored. */
LOCD_API void locd_scene_destroy(locd_scene *scene);

/* Objects in the scene now (static ones included). */
LOCD_API size_t locd_scene_count(const locd_scene *scene);

/* ------------------------------------------------------------------ */
/* Changes, in batches                                                */
/* ------------------------------------------------------------------ */

/* Per-object attributes of an added batch. For each attribute, the array
 * (n values) is used when it is not NULL, the scalar otherwise. */
typedef struct locd_scene_add_options {
    uint32_t size;               /* sizeof(locd_scene_add_options) */
    uint32_t flags;              /* LOCD_OBJECT_STATIC: the whole batch is static */
    uint64_t category;           /* default 1 */
    uint64_t mask;               /* default all bits set */
    uint64_t group;              /* default 0 (no group) */
    uint64_t user;               /* default 0 */
    const uint64_t *categories;  /* NULL = category for all */
    const uint64_t *masks;       /* NULL = mask for all */
    const uint64_t *groups;      /* NULL = group for all */
    const uint64_t *users;       /* NULL = user for all */
} locd_scene_add_options;

/* Smallest options->size accepted: every field above. */
#define LOCD_SCENE_ADD_OPTIONS_MIN_SIZE 72u

/* Static objects (level geometry) never pair with each other, and cost
 * nothing in a frame where they did not move. They may still be moved. */
#define LOCD_OBJECT_STATIC 0x1u

LOCD_API void locd_scene_add_options_init(locd_scene_add_options *options);

/* Adds n boxes (6*n values, as in locd.h); ids_out receives n ids.
 * options may be NULL for the defaults. Errors: LOCD_ERR_NONFINITE,
 * LOCD_ERR_INVERTED_BOX (index of the box in the batch). */
LOCD_API locd_status locd_scene_add_f32(locd_scene *scene, const float *boxes, size_t n,
                                        const locd_scene_add_options *options, locd_id *ids_out);
LOCD_API locd_status locd_scene_add_f64(locd_scene *scene, const double *boxes, size_t n,
                                        const locd_scene_add_options *options, locd_id *ids_out);

/* Gives objects ids[k] the box boxes[6k..6k+5]. Errors: LOCD_ERR_STALE_ID,
 * LOCD_ERR_DUPLICATE_ID (an id twice in the batch), LOCD_ERR_NONFINITE,
 * LOCD_ERR_INVERTED_BOX. */
LOCD_API locd_status locd_scene_move_f32(locd_scene *scene, const locd_id *ids, const float *boxes, size_t n);
LOCD_API locd_status locd_scene_move_f64(locd_scene *scene, const locd_id *ids, const double *boxes, size_t n);

/* Removes the objects; their pairs are lost pairs at the next update.
 * Errors: LOCD_ERR_STALE_ID, LOCD_ERR_DUPLICATE_ID. */
LOCD_API locd_status locd_scene_remove(locd_scene *scene, const locd_id *ids, size_t n);

/* Sets the filter of the objects: each array (n values) may be NULL to keep
 * that attribute as it is. Errors: LOCD_ERR_STALE_ID, LOCD_ERR_DUPLICATE_ID. */
LOCD_API locd_status locd_scene_set_filter(locd_scene *scene, const locd_id *ids, size_t n,
                                           const uint64_t *categories, const uint64_t *masks,
                                           const uint64_t *groups);

/* User values: set them for n objects, or read them into users_out. */
LOCD_API locd_status locd_scene_set_user(locd_scene *scene, const locd_id *ids, size_t n, const uint64_t *users);
LOCD_API locd_status locd_scene_get_user(const locd_scene *scene, const locd_id *ids, size_t n, uint64_t *users_out);

/* ------------------------------------------------------------------ */
/* Update: pairs, created, lost                                       */
/* ------------------------------------------------------------------ */

#define LOCD_SCENE_UPDATE_PAIRS 0x1u  /* fill the full pair list */
#define LOCD_SCENE_UPDATE_EVENTS 0x2u /* fill the created and lost lists */

/* Brings the pair set up to date with every change since the previous
 * update. Created: pairs now that were not at the previous update (all
 * pairs at the first update). Lost: pairs at the previous update that are
 * not now (those of removed objects included). A list not asked for in
 * flags is empty afterwards. */
LOCD_API locd_status locd_scene_update(locd_scene *scene, uint32_t flags);

/* The lists of the last update: 2 * *count ids, rows (first, second) with
 * first < second, sorted. Owned by the scene, valid until its next change
 * or update. */
LOCD_API locd_status locd_scene_pairs(const locd_scene *scene, const locd_id **pairs, size_t *count);
LOCD_API locd_status locd_scene_created(const locd_scene *scene, const locd_id **pairs, size_t *count);
LOCD_API locd_status locd_scene_lost(const locd_scene *scene, const locd_id **pairs, size_t *count);

typedef struct locd_scene_stats {
    uint32_t size;           /* sizeof(locd_scene_stats) */
    uint32_t threads;
    uint64_t objects;        /* in the scene, static ones included */
    uint64_t static_objects;
    uint64_t moved;          /* objects added, moved or re-filtered since the previous update */
    uint64_t reencoded;      /* objects whose octree cells changed */
    uint64_t entries;        /* (cell, object) entries held (0 after a from-scratch update:
                                the next update that searches builds them) */
    uint64_t candidates;     /* object pairs tested in this update */
    uint64_t pairs;
    uint64_t created;
    uint64_t lost;
    uint32_t rebuilt;        /* 1 if this update found its pairs from scratch (the first one, or
                                too many objects moved: docs/scene.md) */
    uint32_t coasted;        /* moved objects that stayed in their fat boxes and took their pairs from
                                their partner lists or the near-pair list (no search; docs/scene.md) */
    double ms_total;
    double ms_encode;
    double ms_merge;         /* repairing the sorted entry list */
    double ms_sweep;         /* finding the pairs of the moved objects */
    double ms_events;        /* created / lost lists and the full pair list */
} locd_scene_stats;

/* Smallest stats->size accepted: size and threads. */
#define LOCD_SCENE_STATS_MIN_SIZE 8u

LOCD_API void locd_scene_stats_init(locd_scene_stats *stats);
/* Statistics of the last update (only the first stats->size bytes are written). */
LOCD_API locd_status locd_scene_get_stats(const locd_scene *scene, locd_scene_stats *stats);
/* Deprecated: the same as locd_scene_get_stats (kept for the ABI). */
LOCD_API locd_status locd_scene_stats_get(const locd_scene *scene, locd_scene_stats *stats);

/* ------------------------------------------------------------------ */
/* Queries                                                            */
/* ------------------------------------------------------------------ */

/* Each query reports the objects whose category has a bit in `mask`, ids
 * ascending, into ids_out (capacity ids). *count receives the number of hits;
 * if it exceeds capacity nothing is written and LOCD_ERR_BUFFER_TOO_SMALL is
 * returned (call again with a larger buffer). */

/* Objects whose box overlaps box (6 values; closed intervals). */
LOCD_API locd_status locd_scene_query_box_f32(const locd_scene *scene, const float *box, uint64_t mask,
                                              locd_id *ids_out, size_t capacity, size_t *count);
LOCD_API locd_status locd_scene_query_box_f64(const locd_scene *scene, const double *box, uint64_t mask,
                                              locd_id *ids_out, size_t capacity, size_t *count);

/* Objects whose box contains the point (3 values; a point on a face, edge or
 * corner is inside). */
LOCD_API locd_status locd_scene_query_point_f32(const locd_scene *scene, const float *point, uint64_t mask,
                                                locd_id *ids_out, size_t capacity, size_t *count);
LOCD_API locd_status locd_scene_query_point_f64(const locd_scene *scene, const double *point, uint64_t mask,
                                                locd_id *ids_out, size_t capacity, size_t *count);

/* Objects whose box meets the segment origin + t * direction, 0 <= t <= max_t
 * (direction need not be unit length; a zero direction is a point query).
 * t_out receives each hit's entry parameter (0 when the origin is inside the
 * box). Hits are sorted by t, then id. */
LOCD_API locd_status locd_scene_raycast_f32(const locd_scene *scene, const float *origin, const float *direction,
                                            double max_t, uint64_t mask, locd_id *ids_out, double *t_out,
                                            size_t capacity, size_t *count);
LOCD_API locd_status locd_scene_raycast_f64(const locd_scene *scene, const double *origin, const double *direction,
                                            double max_t, uint64_t mask, locd_id *ids_out, double *t_out,
                                            size_t capacity, size_t *count);

/* ------------------------------------------------------------------ */
/* Queries with a filter, sphere and cast queries, hit modes, batches  */
/* ------------------------------------------------------------------ */

/* The queries below see the scene as it is now, like those above. They
 * walk a bounding-volume tree over the objects, which the first query after
 * a change brings up to date (docs/queries.md); locd_scene_prepare_queries
 * does it ahead, on the calling thread. Several threads may query at once. */
LOCD_API locd_status locd_scene_prepare_queries(locd_scene *scene);

/* A per-candidate callback: return nonzero to reject the object (its id
 * and its user value, locd_scene_set_user). Called only for objects that
 * the query's shape meets and whose category passes the mask; a batch calls
 * it from the engine's threads at once (it must be thread-safe). */
typedef int (*locd_query_reject_fn)(void *user, locd_id id, uint64_t user_value);

/* Which objects a query reports: category & mask != 0, and not rejected
 * by the callback (when not NULL). NULL for a filter: every object. */
typedef struct locd_query_filter {
    uint32_t size;                /* sizeof(locd_query_filter) */
    uint32_t reserved;            /* 0 */
    uint64_t mask;                /* default all bits set */
    locd_query_reject_fn reject;  /* default NULL */
    void *user;                   /* passed to reject */
} locd_query_filter;
#define LOCD_QUERY_FILTER_MIN_SIZE 16u
LOCD_API void locd_query_filter_init(locd_query_filter *filter);

/* The casts' hit modes: every hit sorted by (t, id); the closest (the
 * smallest (t, id)); any one hit (the first found: a line of sight). */
#define LOCD_HIT_ALL 0u
#define LOCD_HIT_CLOSEST 1u
#define LOCD_HIT_ANY 2u

/* Overlaps: objects whose box overlaps the box, contains the point, or
 * lies within `radius` of center (with d the distance from center to the
 * box per axis, 0 inside: (dx*dx + dy*dy) + dz*dz <= radius*radius, in
 * float64). Ids ascending into ids_out (capacity ids); *count the hits;
 * LOCD_ERR_BUFFER_TOO_SMALL (nothing written) when they do not fit. */
LOCD_API locd_status locd_scene_overlap_box_f32(const locd_scene *scene, const float *box,
                                                const locd_query_filter *filter, locd_id *ids_out,
                                                size_t capacity, size_t *count);
LOCD_API locd_status locd_scene_overlap_box_f64(const locd_scene *scene, const double *box,
                                                const locd_query_filter *filter, locd_id *ids_out,
                                                size_t capacity, size_t *count);
LOCD_API locd_status locd_scene_overlap_point_f32(const locd_scene *scene, const float *point,
                                                  const locd_query_filter *filter, locd_id *ids_out,
                                                  size_t capacity, size_t *count);
LOCD_API locd_status locd_scene_overlap_point_f64(const locd_scene *scene, const double *point,
                                                  const locd_query_filter *filter, locd_id *ids_out,
                                                  size_t capacity, size_t *count);
LOCD_API locd_status locd_scene_overlap_sphere_f32(const locd_scene *scene, const float *center, double radius,
                                                   const locd_query_filter *filter, locd_id *ids_out,
                                                   size_t capacity, size_t *count);
LOCD_API locd_status locd_scene_overlap_sphere_f64(const locd_scene *scene, const double *center, double radius,
                                                   const locd_query_filter *filter, locd_id *ids_out,
                                                   size_t capacity, size_t *count);

/* Casts: a ray (the segment origin + t * direction, 0 <= t <= max_t) or a
 * box moved along a segment (box + t * direction), and each object's entry
 * time t (0 when they touch at the start; the slab test in float64,
 * docs/queries.md). max_t may be +inf. LOCD_HIT_ALL: every hit, sorted by
 * (t, id); LOCD_HIT_CLOSEST and LOCD_HIT_ANY: *count is 0 or 1. */
LOCD_API locd_status locd_scene_cast_ray_f32(const locd_scene *scene, const float *origin, const float *direction,
                                             double max_t, uint32_t mode, const locd_query_filter *filter,
                                             locd_id *ids_out, double *t_out, size_t capacity, size_t *count);
LOCD_API locd_status locd_scene_cast_ray_f64(const locd_scene *scene, const double *origin, const double *direction,
                                             double max_t, uint32_t mode, const locd_query_filter *filter,
                                             locd_id *ids_out, double *t_out, size_t capacity, size_t *count);
LOCD_API locd_status locd_scene_cast_box_f32(const locd_scene *scene, const float *box, const float *direction,
                                             double max_t, uint32_t mode, const locd_query_filter *filter,
                                             locd_id *ids_out, double *t_out, size_t capacity, size_t *count);
LOCD_API locd_status locd_scene_cast_box_f64(const locd_scene *scene, const double *box, const double *direction,
                                             double max_t, uint32_t mode, const locd_query_filter *filter,
                                             locd_id *ids_out, double *t_out, size_t capacity, size_t *count);

/* A batch's hits: for query k, ids[offsets[k], offsets[k + 1]) and (casts)
 * t likewise; a query's ids ascending (overlaps) or by (t, id) (casts).
 * With LOCD_HIT_CLOSEST or LOCD_HIT_ANY every query has one entry:
 * offsets[k] = k, and LOCD_ID_NONE with t = +inf when it hit nothing.
 * Owned by the caller; a batch replaces its contents. */
typedef struct locd_hits locd_hits;
LOCD_API locd_status locd_hits_create(const locd_allocator *allocator, locd_hits **out);
LOCD_API void locd_hits_destroy(locd_hits *hits);
LOCD_API size_t locd_hits_queries(const locd_hits *hits);
LOCD_API size_t locd_hits_count(const locd_hits *hits);
LOCD_API const uint64_t *locd_hits_offsets(const locd_hits *hits); /* queries + 1 */
LOCD_API const locd_id *locd_hits_ids(const locd_hits *hits);      /* count */
LOCD_API const double *locd_hits_t(const locd_hits *hits);         /* count; NULL after an overlap batch */

/* Batches: n queries of one kind in one call, run on the engine's threads
 * (on the calling thread when the engine is busy); the hits do not depend
 * on the thread count. Arrays hold n queries: 3 values a point, origin,
 * direction or center, 6 a box; max_t and radii n doubles. A bad query
 * fails the batch (locd_last_error_index names it); *hits is then empty. */
LOCD_API locd_status locd_scene_cast_ray_batch_f32(const locd_scene *scene, const float *origins,
                                                   const float *directions, const double *max_t, size_t n,
                                                   uint32_t mode, const locd_query_filter *filter, locd_hits *hits);
LOCD_API locd_status locd_scene_cast_ray_batch_f64(const locd_scene *scene, const double *origins,
                                                   const double *directions, const double *max_t, size_t n,
                                                   uint32_t mode, const locd_query_filter *filter, locd_hits *hits);
LOCD_API locd_status locd_scene_cast_box_batch_f32(const locd_scene *scene, const float *boxes,
                                                   const float *directions, const double *max_t, size_t n,
                                                   uint32_t mode, const locd_query_filter *filter, locd_hits *hits);
LOCD_API locd_status locd_scene_cast_box_batch_f64(const locd_scene *scene, const double *boxes,
                                                   const double *directions, const double *max_t, size_t n,
                                                   uint32_t mode, const locd_query_filter *filter, locd_hits *hits);
LOCD_API locd_status locd_scene_overlap_box_batch_f32(const locd_scene *scene, const float *boxes, size_t n,
                                                      const locd_query_filter *filter, locd_hits *hits);
LOCD_API locd_status locd_scene_overlap_box_batch_f64(const locd_scene *scene, const double *boxes, size_t n,
                                                      const locd_query_filter *filter, locd_hits *hits);
LOCD_API locd_status locd_scene_overlap_point_batch_f32(const locd_scene *scene, const float *points, size_t n,
                                                        const locd_query_filter *filter, locd_hits *hits);
LOCD_API locd_status locd_scene_overlap_point_batch_f64(const locd_scene *scene, const double *points, size_t n,
                                                        const locd_query_filter *filter, locd_hits *hits);
LOCD_API locd_status locd_scene_overlap_sphere_batch_f32(const locd_scene *scene, const float *centers,
                                                         const double *radii, size_t n,
                                                         const locd_query_filter *filter, locd_hits *hits);
LOCD_API locd_status locd_scene_overlap_sphere_batch_f64(const locd_scene *scene, const double *centers,
                                                         const double *radii, size_t n,
                                                         const locd_query_filter *filter, locd_hits *hits);

#ifdef __cplusplus
}
#endif

#endif
