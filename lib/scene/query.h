/* Queries: their shapes, checked (query_shape.c); the walks over the
 * query tree (query_walk.c): a node's four lanes tested at once in floats,
 * bounds that never pass by a hit, then each object's exact test in
 * float64; the single queries (query.c) and the batches (query_batch.c).
 * docs/queries.md. */
#ifndef LOCD_SCENE_QUERY_H
#define LOCD_SCENE_QUERY_H

#include "scene/slots.h"

enum { LC_SHAPE_BOX, LC_SHAPE_SPHERE, LC_SHAPE_CAST };

/* What a query asks. A box (a point: lo == hi); a sphere; a cast: box
 * [lo, hi] moved by t * d, 0 <= t <= max_t (a ray: lo == hi, the origin). */
typedef struct lc_shape {
    int kind;
    double lo[3], hi[3];
    double c[3], r2;
    double d[3], max_t;
} lc_shape;

/* A hit: the object's id and the cast's entry time (0 for the overlaps). */
typedef struct lc_hit {
    double t;
    locd_id id;
} lc_hit;

/* The query in floats, for the node tests (query_walk.c): its box rounded
 * outward; for a cast, per axis, the reciprocal of the direction, the
 * query's side and the lanes' bounds the cast enters and leaves by, and
 * the slack that makes the float times bounds of the exact ones. */
typedef struct lc_fquery {
    float lo[3], hi[3];         /* the box, rounded outward, within +-FLT_MAX */
    float enter_q[3], leave_q[3], inv[3], slack[3], max_t;
    uint32_t enter_at[3], leave_at[3]; /* byte offsets of the lanes' bounds in a node */
    float c[3], gap_err[3], r2; /* a sphere: its centre, a bound of the gaps' error, r^2 rounded up */
    uint32_t moving;            /* cast: bit a: d[a] != 0 */
    int exact_box;              /* a box whose floats are its values: a leaf's node test is the object's */
    int fast;                   /* the float test holds (values in range); else each lane's exact test */
} lc_fquery;

/* A walk's own room for its stack and hits (the heap's beyond). */
#define LC_WALK_STACK 256
#define LC_WALK_HITS 32

/* One walk: the query, its filter and mode, its hits or its best hit. */
typedef struct lc_walk {
    const locd_scene *s;
    const lc_shape *q;
    uint64_t mask;
    int check_cat;        /* some live object's category may fail the mask (else no read of it) */
    locd_query_reject_fn reject;
    void *user;
    uint32_t mode;        /* LOCD_HIT_* (casts); overlaps take every hit */
    lc_fquery f;          /* the query in floats, for the node tests */
    lc_hit *hit;          /* every hit (LOCD_HIT_ALL, overlaps): hit_in, or the heap's */
    size_t nhit, hit_cap;
    lc_hit best;          /* the closest or the first (t +inf, id LOCD_ID_NONE: none) */
    float best_tf;        /* best.t as a float no smaller (+inf: none), for the node tests */
    int failed;           /* no memory for the hits */
    uint32_t *stack;      /* the walk's nodes to see, and their entry times (casts) */
    float *stack_t;
    size_t stack_cap;
    lc_hit hit_in[LC_WALK_HITS];
    uint32_t stack_in[LC_WALK_STACK];
    float stack_tin[LC_WALK_STACK];
} lc_walk;

/* A walk of query q with filter f (NULL: every object; mask as given). */
locd_status lc_walk_init(lc_walk *w, const locd_scene *s, const lc_shape *q, uint32_t mode,
                         const locd_query_filter *f, uint64_t mask);
/* The walk of its query over the scene's tree (synced) and extra list;
 * the hits in w. 0 on no memory. */
int lc_walk_run(lc_walk *w);
/* The walk's scratch (hits, stack) back to the allocator. */
void lc_walk_fini(const locd_allocator *a, lc_walk *w);
/* The hits sorted by (t, id), each object once. */
void lc_walk_sort(lc_walk *w);

/* ---- the shapes (query_shape.c), each checked: an error names query k ---- */
/* A box (6 values) or a point (3). */
locd_status lc_shape_box(lc_shape *q, const double *v, int point, size_t k);
locd_status lc_shape_sphere(lc_shape *q, const double *center, double radius, size_t k);
/* A cast of a box (6 values) or a ray's origin (3) along direction d to max_t. */
locd_status lc_shape_cast(lc_shape *q, const double *v, int box, const double *d, double max_t, size_t k);
/* v[0, n) as doubles into out (floats widen exactly); v itself when NULL or already doubles.
 * (Inline: the call and its loop were 3% of a short ray's instructions.) */
LC_INLINE const double *lc_widen(const void *v, int f32, double *out, int n)
{
    int a;
    if (!v || !f32)
        return v;
    for (a = 0; a < n; a++)
        out[a] = ((const float *)v)[a];
    return out;
}
locd_status lc_check_mode(uint32_t mode);

#endif
