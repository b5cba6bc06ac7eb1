/* The walks of the query tree. A node's four lanes are tested at once
 * (vector doubles; the lanes' floats convert exactly) by a test that never
 * passes by a lane holding a hit:
 * - boxes, spheres: the objects' own float64 test, monotone in the bounds
 *   (subtractions, products and comparisons round monotonely), so a lane
 *   holding a box is met whenever the box is;
 * - casts: the slab test with the direction's reciprocal instead of a
 *   division, its entry times widened down and its exit times up by 2^-48
 *   of their size and by 2^-1000 (far more than the few roundings by which
 *   a product by the rounded reciprocal and a quotient can differ, even
 *   below the normal range); the exact test on an axis where the direction
 *   is 0, and for a whole cast whose values could overflow.
 * An object is then tested exactly (docs/queries.md). A cast walks front to
 * back: the lanes it meets in order of entry time, a node entered after
 * the best hit so far passed by (closest), the walk stopped at the first
 * hit (any). */
#include "scene/scene.h"
#include "scene/query.h"

#include <stddef.h>
#include <stdlib.h>

/* Four lanes in vectors of GCC's (and clang's) vector extension: two SSE2
 * registers on a baseline x86-64 build, NEON's on ARM. Every function that
 * takes or gives one is inlined, so no vector crosses a call (the ABI note
 * GCC gives for 32-byte vectors without AVX does not apply). */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif
typedef double v4d __attribute__((vector_size(32)));
typedef float v4f __attribute__((vector_size(16)));
typedef int64_t v4l __attribute__((vector_size(32)));

/* The widening of a cast's node entry and exit times. */
#define LC_CAST_DOWN (1.0 - 0x1p-48)
#define LC_CAST_UP (1.0 + 0x1p-48)
#define LC_CAST_SLACK 0x1p-1000
/* Directions within [2^-500, 2^500] (or 0) and a cast within 2^500 of the
 * origin: no product of the node test overflows. */
#define LC_CAST_RANGE 0x1p500

/* ---- the objects' exact tests ---- */

LC_INLINE int box_meets(const lc_shape *q, const double *lo, const double *hi)
{
    return lo[0] <= q->hi[0] && q->lo[0] <= hi[0] && lo[1] <= q->hi[1] && q->lo[1] <= hi[1] && lo[2] <= q->hi[2] &&
           q->lo[2] <= hi[2];
}

/* The distance of c to [lo, hi] on one axis (0 inside). */
LC_INLINE double gap(double c, double lo, double hi)
{
    return c < lo ? lo - c : c > hi ? c - hi : 0.0;
}

LC_INLINE int sphere_meets(const lc_shape *q, const double *lo, const double *hi)
{
    const double dx = gap(q->c[0], lo[0], hi[0]), dy = gap(q->c[1], lo[1], hi[1]), dz = gap(q->c[2], lo[2], hi[2]);
    return (dx * dx + dy * dy) + dz * dz <= q->r2;
}

/* The cast's entry time into [lo, hi]: per axis the box moved by t * d
 * overlaps [lo, hi] while lo - q.hi <= t d <= hi - q.lo (the gaps, then
 * divided by d; a zero d needs the gaps to hold at every t). */
LC_INLINE int cast_meets(const lc_shape *q, const double *lo, const double *hi, double *t)
{
    double t0 = 0.0, t1 = q->max_t;
    int a;
    for (a = 0; a < 3; a++) {
        const double in = lo[a] - q->hi[a], out = hi[a] - q->lo[a];
        double u, v;
        if (q->d[a] == 0.0) {
            if (in > 0.0 || out < 0.0)
                return 0;
            continue;
        }
        u = (q->d[a] > 0.0 ? in : out) / q->d[a];
        v = (q->d[a] > 0.0 ? out : in) / q->d[a];
        t0 = u > t0 ? u : t0;
        t1 = v < t1 ? v : t1;
        if (t0 > t1)
            return 0;
    }
    *t = t0;
    return 1;
}

LC_INLINE int meets(const lc_shape *q, const double *lo, const double *hi, double *t)
{
    *t = 0.0;
    if (q->kind == LC_SHAPE_CAST)
        return cast_meets(q, lo, hi, t);
    return q->kind == LC_SHAPE_BOX ? box_meets(q, lo, hi) : sphere_meets(q, lo, hi);
}

/* ---- a node's four lanes at once ---- */

LC_INLINE v4d splat(double x)
{
    const v4d v = {x, x, x, x};
    return v;
}

LC_INLINE v4d lane_lo(const lc_qt_node *nd, int a)
{
    v4f f;
    memcpy(&f, nd->lo[a], sizeof f);
    return __builtin_convertvector(f, v4d);
}

LC_INLINE v4d lane_hi(const lc_qt_node *nd, int a)
{
    v4f f;
    memcpy(&f, nd->hi[a], sizeof f);
    return __builtin_convertvector(f, v4d);
}

LC_INLINE v4d vmax(v4d a, v4d b)
{
    return (v4d)(((v4l)(a > b) & (v4l)a) | (~(v4l)(a > b) & (v4l)b));
}

LC_INLINE v4d vmin(v4d a, v4d b)
{
    return (v4d)(((v4l)(a < b) & (v4l)a) | (~(v4l)(a < b) & (v4l)b));
}

/* The lanes' bits from a mask of all-ones or zero lanes. */
LC_INLINE uint32_t bits_of(v4l m)
{
    return (uint32_t)((m[0] & 1) | (m[1] & 2) | (m[2] & 4) | (m[3] & 8));
}

static uint32_t box_lanes(const lc_shape *q, const lc_qt_node *nd)
{
    v4l ok = {-1, -1, -1, -1};
    int a;
    for (a = 0; a < 3; a++)
        ok &= (v4l)(lane_lo(nd, a) <= splat(q->hi[a])) & (v4l)(splat(q->lo[a]) <= lane_hi(nd, a));
    return bits_of(ok);
}

static uint32_t sphere_lanes(const lc_shape *q, const lc_qt_node *nd)
{
    v4d sum = splat(0.0);
    int a;
    for (a = 0; a < 3; a++) {
        const v4d c = splat(q->c[a]), lo = lane_lo(nd, a), hi = lane_hi(nd, a);
        const v4l below = (v4l)(c < lo), above = (v4l)(c > hi);
        const v4d g = (v4d)((below & (v4l)(lo - c)) | (above & ~below & (v4l)(c - hi)));
        sum = a == 2 ? sum + g * g : sum + g * g; /* (dx*dx + dy*dy) + dz*dz */
    }
    return bits_of((v4l)(sum <= splat(q->r2)));
}

/* The cast's lanes, and a lower bound of each lane's entry time in t. */
static uint32_t cast_lanes(const lc_walk *w, const lc_qt_node *nd, double t[4])
{
    const lc_shape *q = w->q;
    v4d t0 = splat(0.0), t1 = splat(q->max_t);
    v4l ok = {-1, -1, -1, -1};
    int a;
    for (a = 0; a < 3; a++) {
        const v4d in = lane_lo(nd, a) - splat(q->hi[a]), out = lane_hi(nd, a) - splat(q->lo[a]);
        if (q->d[a] == 0.0) {
            ok &= (v4l)(in <= splat(0.0)) & (v4l)(out >= splat(0.0));
            continue;
        }
        t0 = vmax(t0, (q->d[a] > 0.0 ? in : out) * splat(w->inv[a]) * splat(LC_CAST_DOWN) - splat(LC_CAST_SLACK));
        t1 = vmin(t1, (q->d[a] > 0.0 ? out : in) * splat(w->inv[a]) * splat(LC_CAST_UP) + splat(LC_CAST_SLACK));
    }
    ok &= (v4l)(t0 <= t1);
    memcpy(t, &t0, sizeof t0);
    return bits_of(ok);
}

/* Lanes whose entry times are exact (the division): a cast whose
 * reciprocal could overflow. */
static uint32_t exact_lanes(const lc_walk *w, const lc_qt_node *nd, double t[4])
{
    uint32_t k, m = 0;
    int a;
    for (k = 0; k < LC_QT_WIDTH; k++) {
        double lo[3], hi[3];
        for (a = 0; a < 3; a++)
            lo[a] = nd->lo[a][k], hi[a] = nd->hi[a][k];
        m |= (uint32_t)cast_meets(w->q, lo, hi, &t[k]) << k;
    }
    return m;
}

/* The cast's reciprocals, when its node test may take them. */
static void cast_prepare(lc_walk *w)
{
    const lc_shape *q = w->q;
    int a;
    w->fast = q->kind == LC_SHAPE_CAST;
    for (a = 0; a < 3 && w->fast; a++) {
        const double d = fabs(q->d[a]);
        w->inv[a] = q->d[a] != 0.0 ? 1.0 / q->d[a] : 0.0;
        w->fast = (d == 0.0 || (d >= 1.0 / LC_CAST_RANGE && d <= LC_CAST_RANGE)) && fabs(q->lo[a]) <= LC_CAST_RANGE &&
                  fabs(q->hi[a]) <= LC_CAST_RANGE;
    }
}

/* The lanes of nd the shape meets (bits), and their entry times (lower
 * bounds) for a cast. */
static uint32_t lanes_met(const lc_walk *w, const lc_qt_node *nd, double t[4])
{
    uint32_t m;
    switch (w->q->kind) {
    case LC_SHAPE_BOX:
        m = box_lanes(w->q, nd);
        break;
    case LC_SHAPE_SPHERE:
        m = sphere_lanes(w->q, nd);
        break;
    default:
        return w->fast ? cast_lanes(w, nd, t) : exact_lanes(w, nd, t);
    }
    t[0] = t[1] = t[2] = t[3] = 0.0;
    return m;
}

/* ---- hits ---- */

static void put_hit(lc_walk *w, double t, locd_id id)
{
    if (w->nhit == w->hit_cap) {
        const size_t cap = lc_grow_cap(w->hit_cap, w->nhit + 1);
        lc_hit *h = lc_alloc(w->s->alloc, cap * sizeof *h);
        if (!h) {
            w->failed = 1;
            return;
        }
        if (w->nhit)
            memcpy(h, w->hit, w->nhit * sizeof *h);
        if (w->hit != w->hit_in)
            lc_free(w->s->alloc, w->hit, w->hit_cap * sizeof *w->hit);
        w->hit = h, w->hit_cap = cap;
    }
    w->hit[w->nhit].t = t;
    w->hit[w->nhit++].id = id;
}

/* An object the shape met at t: the filter, then the hit. Returns 1 when
 * the walk may stop (the first hit of LOCD_HIT_ANY). */
static int take(lc_walk *w, uint32_t slot, double t)
{
    const lc_slots *sl = &w->s->slots;
    locd_id id;
    if (w->check_cat && !(sl->cat[slot] & w->mask))
        return 0;
    id = sl->id[slot];
    if (w->reject && w->reject(w->user, id, sl->user[slot]))
        return 0;
    if (w->q->kind != LC_SHAPE_CAST || w->mode == LOCD_HIT_ALL) {
        put_hit(w, t, id);
        return w->failed;
    }
    if (t < w->best.t || (t == w->best.t && id < w->best.id))
        w->best.t = t, w->best.id = id;
    return w->mode == LOCD_HIT_ANY;
}

/* The object in `slot`: its box's own test (its doubles, or its floats). */
static int try_object(lc_walk *w, uint32_t slot)
{
    double tmp[6], t;
    const double *b = lc_slot_box(&w->s->slots, slot, tmp);
    return meets(w->q, b, b + 3, &t) && take(w, slot, t);
}

/* Lane k of nd, an object's: its exact test (the lane's floats when they
 * are its box, else its doubles), then the filter. */
static int try_lane(lc_walk *w, const lc_qt_node *nd, uint32_t k)
{
    double lo[3], hi[3], t;
    int a;
    if (nd->inexact & (1u << k))
        return try_object(w, nd->child[k]);
    if (w->q->kind != LC_SHAPE_CAST) /* (the lane's test was the object's) */
        return take(w, nd->child[k], 0.0);
    for (a = 0; a < 3; a++)
        lo[a] = nd->lo[a][k], hi[a] = nd->hi[a][k];
    return cast_meets(w->q, lo, hi, &t) && take(w, nd->child[k], t);
}

/* ---- the walk ---- */

/* Room for `more` entries on the stack (the walk's own, then the heap's).
 * 0 on no memory. */
static int stack_room(lc_walk *w, size_t used, size_t more)
{
    size_t cap;
    uint32_t *st;
    double *tt;
    if (used + more <= w->stack_cap)
        return 1;
    cap = lc_grow_cap(w->stack_cap, used + more + 64);
    st = lc_alloc(w->s->alloc, cap * sizeof *st);
    tt = lc_alloc(w->s->alloc, cap * sizeof *tt);
    if (!st || !tt) {
        lc_free(w->s->alloc, st, cap * sizeof *st);
        lc_free(w->s->alloc, tt, cap * sizeof *tt);
        return 0;
    }
    if (used) {
        memcpy(st, w->stack, used * sizeof *st);
        memcpy(tt, w->stack_t, used * sizeof *tt);
    }
    if (w->stack != w->stack_in) {
        lc_free(w->s->alloc, w->stack, w->stack_cap * sizeof *w->stack);
        lc_free(w->s->alloc, w->stack_t, w->stack_cap * sizeof *w->stack_t);
    }
    w->stack = st, w->stack_t = tt, w->stack_cap = cap;
    return 1;
}

/* The best hit's entry time so far (closest): farther nodes are passed by. */
LC_INLINE double bound_t(const lc_walk *w)
{
    return w->q->kind == LC_SHAPE_CAST && w->mode == LOCD_HIT_CLOSEST ? w->best.t : INFINITY;
}

/* Node i pushed, its two lines asked for while the other lanes are seen to. */
LC_INLINE void push(lc_walk *w, size_t *top, uint32_t i, double t)
{
    const char *c = (const char *)&w->s->qtree.node[i];
    __builtin_prefetch(c);
    __builtin_prefetch(c + 64);
    w->stack[*top] = i, w->stack_t[*top] = t;
    ++*top;
}

/* The lanes met in order of entry time (nearest first): objects tested,
 * nodes pushed farthest first. Returns 1 to stop the walk. */
static int visit(lc_walk *w, const lc_qt_node *nd, uint32_t met, const double *t, size_t *top)
{
    uint32_t order[4], n = 0, k, x;
    for (k = 0; k < LC_QT_WIDTH; k++)
        if (met & (1u << k)) {
            for (x = n; x > 0 && t[order[x - 1]] > t[k]; x--)
                order[x] = order[x - 1];
            order[x] = k, n++;
        }
    for (x = 0; x < n; x++) /* the objects, nearest first */
        if ((nd->objects & (1u << order[x])) && t[order[x]] <= bound_t(w) && try_lane(w, nd, order[x]))
            return 1;
    for (x = n; x-- > 0;)
        if (!(nd->objects & (1u << order[x])) && t[order[x]] <= bound_t(w))
            push(w, top, nd->child[order[x]], t[order[x]]);
    return 0;
}

static int walk_tree(lc_walk *w)
{
    const lc_query_tree *qt = &w->s->qtree;
    size_t top = 0;
    if (qt->root == LC_QT_NONE)
        return 1;
    if (!stack_room(w, 0, 4 * (size_t)qt->levels + 8))
        return 0;
    w->stack[top] = qt->root, w->stack_t[top++] = 0.0;
    while (top) {
        const lc_qt_node *nd;
        double t[4];
        uint32_t met;
        --top;
        if (w->stack_t[top] > bound_t(w))
            continue;
        nd = &qt->node[w->stack[top]];
        met = lanes_met(w, nd, t);
        if (met && visit(w, nd, met, t, &top))
            return !w->failed;
    }
    return !w->failed;
}

int lc_walk_run(lc_walk *w)
{
    const lc_query_tree *qt = &w->s->qtree;
    size_t k;
    w->best.t = INFINITY, w->best.id = LOCD_ID_NONE;
    w->nhit = 0, w->failed = 0;
    cast_prepare(w);
    if (!qt->valid) { /* (no memory for the tree): every object */
        for (k = 0; k < w->s->slots.nslots; k++)
            if ((w->s->slots.flags[k] & LC_SLOT_LIVE) && try_object(w, (uint32_t)k))
                break;
        return !w->failed;
    }
    if (!walk_tree(w))
        return 0;
    if (w->q->kind == LC_SHAPE_CAST && w->mode == LOCD_HIT_ANY && w->best.id != LOCD_ID_NONE)
        return 1;
    for (k = 0; k < qt->nextra; k++)
        if (try_object(w, qt->extra[k]))
            break;
    return !w->failed;
}

static int cmp_hit(const void *pa, const void *pb)
{
    const lc_hit *a = pa, *b = pb;
    if (a->t != b->t)
        return a->t < b->t ? -1 : 1;
    return (a->id > b->id) - (a->id < b->id);
}

void lc_walk_sort(lc_walk *w)
{
    if (w->nhit > 1)
        qsort(w->hit, w->nhit, sizeof *w->hit, cmp_hit);
}

void lc_walk_fini(const locd_allocator *a, lc_walk *w)
{
    if (w->hit != w->hit_in)
        lc_free(a, w->hit, w->hit_cap * sizeof *w->hit);
    if (w->stack != w->stack_in) {
        lc_free(a, w->stack, w->stack_cap * sizeof *w->stack);
        lc_free(a, w->stack_t, w->stack_cap * sizeof *w->stack_t);
    }
    w->hit = w->hit_in, w->hit_cap = LC_WALK_HITS;
    w->stack = w->stack_in, w->stack_t = w->stack_tin, w->stack_cap = LC_WALK_STACK;
}

locd_status lc_walk_init(lc_walk *w, const locd_scene *s, const lc_shape *q, uint32_t mode,
                         const locd_query_filter *f, uint64_t mask)
{
    locd_query_filter fl;
    locd_status st;
    memset(w, 0, offsetof(lc_walk, hit_in));
    w->s = s, w->q = q, w->mode = mode, w->mask = mask;
    w->hit = w->hit_in, w->hit_cap = LC_WALK_HITS;
    w->stack = w->stack_in, w->stack_t = w->stack_tin, w->stack_cap = LC_WALK_STACK;
    w->check_cat = mask != ~(uint64_t)0 || s->slots.ncat0;
    if (!f)
        return LOCD_OK;
    locd_query_filter_init(&fl);
    if ((st = lc_struct_in(&fl, sizeof fl, f, LOCD_QUERY_FILTER_MIN_SIZE, "filter")) != LOCD_OK)
        return st;
    w->mask = fl.mask, w->reject = fl.reject, w->user = fl.user;
    w->check_cat = w->mask != ~(uint64_t)0 || s->slots.ncat0;
    return LOCD_OK;
}

void locd_query_filter_init(locd_query_filter *filter)
{
    if (!filter)
        return;
    memset(filter, 0, sizeof *filter);
    filter->size = sizeof *filter;
    filter->mask = ~(uint64_t)0;
}
