/*
 * locd filter pipeline: shapes, narrow phase (closed forms, libccd, FCL),
 * swept tests and contact data on top of the broad phase.
 *
 * The API of liblocd_narrow (pkg-config locd-narrow, CMake locd::narrow);
 * includes locd/locd.h. docs/pipeline.md has the full reference. In a build
 * without the narrow phase (meson -Dnarrow=disabled or libccd/FCL missing)
 * every function below exists and returns LOCD_ERR_UNSUPPORTED, except the
 * *_init functions and the destroy functions.
 *
 * Conventions:
 *   a pose is 7 doubles  px py pz qx qy qz qw  (position, then a unit
 *   quaternion with the scalar last; it is normalized on entry);
 *   a velocity is 6 doubles  vx vy vz wx wy wz  (linear, then angular in
 *   rad/s, world frame);
 *   a contact normal points from the pair's first object i toward its second
 *   object j (moving j by depth * normal separates them); depth >= 0.
 */
#ifndef LOCD_PIPELINE_H
#define LOCD_PIPELINE_H

#include "locd/locd.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------------ */
/* Shapes                                                             */
/* ------------------------------------------------------------------ */

typedef struct locd_shape locd_shape;

#define LOCD_SHAPE_SPHERE 1
#define LOCD_SHAPE_BOX 2     /* oriented box: half extents along its local axes */
#define LOCD_SHAPE_CAPSULE 3 /* segment along the local z axis, z in [-half_length, half_length], swept by radius */
#define LOCD_SHAPE_CONVEX 4  /* convex hull of a point set (local frame) */
#define LOCD_SHAPE_MESH 5    /* triangle mesh (local frame), tested through FCL or per triangle */
#define LOCD_SHAPE_KINDS 8   /* size of one row of the route table */

/* Every constructor validates its input: a non-finite or non-positive size,
 * an empty point set, a mesh without triangles, an index out of range or a
 * zero-area triangle give LOCD_ERR_SHAPE and a locd_last_error() naming the
 * problem. *out is NULL on failure. Point and index arrays are copied. */
LOCD_API locd_status locd_shape_sphere(double radius, locd_shape **out);
LOCD_API locd_status locd_shape_box(double half_x, double half_y, double half_z, locd_shape **out);
LOCD_API locd_status locd_shape_capsule(double radius, double half_length, locd_shape **out);
/* points: 3 * count doubles. */
LOCD_API locd_status locd_shape_convex(const double *points, size_t count, locd_shape **out);
/* vertices: 3 * vertex_count doubles; triangles: 3 * triangle_count indices. */
LOCD_API locd_status locd_shape_mesh(const double *vertices, size_t vertex_count, const uint32_t *triangles,
                                     size_t triangle_count, locd_shape **out);
/* Shapes are reference counted: a world keeps the shapes it holds alive, so
 * a caller may destroy its handle right after locd_world_add. NULL is ignored. */
LOCD_API void locd_shape_destroy(locd_shape *shape);
/* LOCD_SHAPE_*, or 0 for an invalid handle. */
LOCD_API int32_t locd_shape_kind(const locd_shape *shape);
/* World axis-aligned box (minx miny minz maxx maxy maxz) of the shape at pose. */
LOCD_API locd_status locd_shape_aabb(const locd_shape *shape, const double *pose, double *box);

/* ------------------------------------------------------------------ */
/* Pipeline options                                                   */
/* ------------------------------------------------------------------ */

/* Stages after the broad phase (which always runs: octree + exact box test). */
#define LOCD_STAGE_SHAPE 0x1u   /* exact shape test (closed form, libccd or FCL) */
#define LOCD_STAGE_CONTACT 0x2u /* depth, normal and point of every colliding pair */

#define LOCD_SWEPT_OFF 0  /* discrete: poses at t0 only */
#define LOCD_SWEPT_ON 1   /* every moving object gets a swept box and a time-of-impact test */
#define LOCD_SWEPT_AUTO 2 /* only objects moving more than swept_threshold times their size in dt */

/* How a pair of shape kinds is tested (route table entries). */
#define LOCD_ROUTE_AUTO 0   /* the default for the pair (docs/pipeline.md) */
#define LOCD_ROUTE_BOX 1    /* accept the broad-phase pair: no shape test for this pair type */
#define LOCD_ROUTE_CLOSED 2 /* closed form (sphere-sphere, sphere-box, box-box only) */
#define LOCD_ROUTE_CCD 3    /* libccd: GJK (yes/no), EPA or MPR (contact); meshes per triangle */
#define LOCD_ROUTE_FCL 4    /* FCL (not for convex hulls: those fall back to libccd) */

#define LOCD_CONTACT_EPA 0 /* libccd contact data by GJK + EPA (default) */
#define LOCD_CONTACT_MPR 1 /* libccd contact data by MPR (faster, depth along the centre line) */

typedef struct locd_pipeline_options {
    uint32_t size;            /* sizeof(locd_pipeline_options) */
    uint32_t stages;          /* LOCD_STAGE_* bits; default LOCD_STAGE_SHAPE */
    int32_t swept;            /* LOCD_SWEPT_*; default LOCD_SWEPT_OFF */
    int32_t contact_method;   /* LOCD_CONTACT_*; default LOCD_CONTACT_EPA */
    double dt;                /* step length for swept tests (poses move by velocity * dt); default 0 */
    double swept_threshold;   /* LOCD_SWEPT_AUTO: motion / size above which an object is swept; default 0.25 */
    uint32_t find_flags;      /* passed to the broad phase (LOCD_FIND_SORTED); default 0 */
    uint32_t reserved;
    /* route[a * LOCD_SHAPE_KINDS + b] for shape kinds a, b; symmetric (set
     * both entries, or use locd_pipeline_options_route). Default all AUTO. */
    uint8_t route[LOCD_SHAPE_KINDS * LOCD_SHAPE_KINDS];
} locd_pipeline_options;

/* Smallest options->size accepted: the fields up to swept_threshold. */
#define LOCD_PIPELINE_OPTIONS_MIN_SIZE 32u

LOCD_API void locd_pipeline_options_init(locd_pipeline_options *options);
/* Sets route[a][b] and route[b][a]. options->size must reach past the route
 * table (LOCD_ERR_INVALID_ARGUMENT for an older, shorter struct). */
LOCD_API locd_status locd_pipeline_options_route(locd_pipeline_options *options, int32_t kind_a, int32_t kind_b,
                                                 int32_t route);

/* ------------------------------------------------------------------ */
/* Per-stage statistics                                               */
/* ------------------------------------------------------------------ */

typedef struct locd_stage_stats {
    uint64_t calls;     /* times the stage ran (0 when it was not asked for) */
    uint64_t pairs_in;  /* pairs handed to the stage (broad: n(n-1)/2) */
    uint64_t pairs_out; /* pairs it kept */
    uint64_t tests;     /* pair tests it performed */
    double ms;          /* wall time spent in it */
} locd_stage_stats;

typedef struct locd_pipeline_stats {
    uint32_t size; /* sizeof(locd_pipeline_stats) */
    uint32_t objects;
    uint32_t swept_objects;      /* objects that got a swept box */
    uint32_t reserved;
    locd_stage_stats broad;      /* world boxes + octree + exact box test */
    locd_stage_stats shape;      /* exact shape test of discrete pairs */
    locd_stage_stats swept;      /* time-of-impact test of pairs with a swept object */
    locd_stage_stats contact;    /* contact data */
    uint64_t tests_closed;       /* pair tests by closed form */
    uint64_t tests_ccd;          /* ... by libccd */
    uint64_t tests_fcl;          /* ... by FCL */
    double ms_total;
} locd_pipeline_stats;

/* Smallest stats->size accepted: size alone (nothing else is written). */
#define LOCD_PIPELINE_STATS_MIN_SIZE 4u

LOCD_API void locd_pipeline_stats_init(locd_pipeline_stats *stats);

/* ------------------------------------------------------------------ */
/* Results                                                            */
/* ------------------------------------------------------------------ */

/* Colliding pairs of the last locd_world_collide call and, when the contact
 * stage ran, one contact per pair. Reused across calls without allocating in
 * the steady state. Arrays stay valid until the next collide or destroy. */
typedef struct locd_contacts locd_contacts;

/* Contacts take no allocator: malloc/free (see locd_allocator). */
LOCD_API locd_status locd_contacts_create(locd_contacts **out);
LOCD_API void locd_contacts_destroy(locd_contacts *contacts);
LOCD_API size_t locd_contacts_count(const locd_contacts *contacts);
/* 2 * count object indices i j (i < j). */
LOCD_API const uint32_t *locd_contacts_pairs(const locd_contacts *contacts);
/* count values: time of impact as a fraction of dt in [0, 1] (0 for discrete pairs). */
LOCD_API const double *locd_contacts_toi(const locd_contacts *contacts);
/* count values; NULL when the contact stage did not run. */
LOCD_API const double *locd_contacts_depth(const locd_contacts *contacts);
/* 3 * count values; NULL when the contact stage did not run. */
LOCD_API const double *locd_contacts_normal(const locd_contacts *contacts);
LOCD_API const double *locd_contacts_point(const locd_contacts *contacts);

/* ------------------------------------------------------------------ */
/* World: shapes with poses and velocities                            */
/* ------------------------------------------------------------------ */

typedef struct locd_world locd_world;

/* config (may be NULL) configures the broad-phase engine the world owns;
 * its allocator also serves the world's own memory. */
LOCD_API locd_status locd_world_create(const locd_engine_config *config, locd_world **out);
LOCD_API void locd_world_destroy(locd_world *world);
/* Adds an object; *index (may be NULL) receives its index (0, 1, 2, ...;
 * never reused, see locd_world_remove).
 * pose: 7 doubles; velocity: 6 doubles or NULL for at rest. */
LOCD_API locd_status locd_world_add(locd_world *world, locd_shape *shape, const double *pose, const double *velocity,
                                    uint32_t *index);
/* Indices issued so far (removed objects included). */
LOCD_API size_t locd_world_count(const locd_world *world);
LOCD_API locd_status locd_world_set_pose(locd_world *world, uint32_t index, const double *pose);
LOCD_API locd_status locd_world_set_velocity(locd_world *world, uint32_t index, const double *velocity);
/* All objects at once: 7 * count / 6 * count doubles, count = locd_world_count. */
LOCD_API locd_status locd_world_set_poses(locd_world *world, const double *poses, size_t count);
LOCD_API locd_status locd_world_set_velocities(locd_world *world, const double *velocities, size_t count);
LOCD_API locd_status locd_world_get_pose(const locd_world *world, uint32_t index, double *pose);

/* Removes an object: its index is never reused, its contacts end at the next
 * collide, and every call naming it afterwards gives LOCD_ERR_STALE_ID (an
 * index never issued stays LOCD_ERR_INVALID_ARGUMENT). Indices run on:
 * locd_world_count stays the number of indices issued, and the bulk setters
 * still take that many rows (a removed object's rows are ignored). */
LOCD_API locd_status locd_world_remove(locd_world *world, uint32_t index);
/* Collision filter of an object, as in the scene (locd/scene.h): objects a
 * and b are tested iff (category_a & mask_b) and (category_b & mask_a) are
 * nonzero and not group_a == group_b != 0. Filtered pairs are never
 * generated by the broad phase. Defaults: category 1, mask all bits, group 0. */
LOCD_API locd_status locd_world_set_filter(locd_world *world, uint32_t index, uint64_t category, uint64_t mask,
                                           uint64_t group);

/* Runs the pipeline on the world: broad phase, then the stages in options
 * (NULL = defaults), into *out. stats (may be NULL; set its size) receives
 * per-stage figures. On error *out is left empty. */
LOCD_API locd_status locd_world_collide(locd_world *world, const locd_pipeline_options *options,
                                        locd_contacts *out, locd_pipeline_stats *stats);

/* Contact begin/end events of the last successful locd_world_collide: the
 * pairs in its contacts that were not in the previous collide's (began) and
 * the pairs of the previous collide that are not in this one (ended; those of
 * removed objects included). Each list is 2 * count indices i j (i < j),
 * sorted by (i, j), owned by the world and valid until its next collide or
 * destroy. Every pointer may be NULL when that list is not wanted. */
LOCD_API locd_status locd_world_contact_events(const locd_world *world, const uint32_t **began, size_t *began_count,
                                               const uint32_t **ended, size_t *ended_count);

/* One pair test outside a world (tests, bindings, tools): *hit = 1 when the
 * shapes at their poses intersect; contact (may be NULL) receives depth,
 * normal[3], point[3] (7 doubles) when they do. route: LOCD_ROUTE_*. */
LOCD_API locd_status locd_shape_collide(const locd_shape *a, const double *pose_a, const locd_shape *b,
                                        const double *pose_b, int32_t route, int32_t contact_method,
                                        int32_t *hit, double *contact);

#ifdef __cplusplus
}
#endif

#endif /* LOCD_PIPELINE_H */
