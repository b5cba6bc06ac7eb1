/* The walks of the query tree. A node's four lanes are tested at once, in
 * floats (one SSE or NEON register a bound), by a test that never passes by
 * a lane holding a hit:
 * - boxes: the query's box rounded outward to floats, then the closed
 *   test; exact when the query's values are floats;
 * - spheres: the gaps to the lanes in floats, less a bound of their
 *   rounding errors, against r^2 rounded up;
 * - casts: the slab test with the direction's reciprocal in floats, the
 *   entry times lowered and the exit times raised by a slack (per axis,
 *   2^-19 of the largest time a coordinate of the tree could give, and
 *   2^-100) that bounds the few roundings of the float times, the closed
 *   test on an axis where the direction is 0.
 * Values out of the floats' safe range (beyond 2^60 or 2^100) take each
 * lane's exact test instead. An object is then tested exactly, in float64
 * (docs/queries.md). A cast walks front to back: the lanes it meets in
 * order of entry time, a node entered after the best hit so far passed by
 * (closest), the walk stopped at the first hit (any). */
#include "scene/scene.h"
#include "scene/query.h"

#include <float.h>
#include <stddef.h>
#include <stdlib.h>
#if defined(__SSE__)
#include <xmmintrin.h>
#endif

/* Four lanes in a vector of GCC's (and clang's) vector extension: an SSE
 * register on x86-64, NEON's on ARM. */
typedef float v4f __attribute__((vector_size(16)));
typedef int32_t v4i __attribute__((vector_size(16)));

/* The float test's range: coordinates and radii within 2^60 (a sphere's
 * squares stay finite), cast times within 2^100, reciprocals within
 * [2^-100, 2^100] (normal floats). */
#define LC_F_COORD 0x1p60
#define LC_F_TIME 0x1p100
/* The casts' slack: 2^-19 of the largest time (some 27 float roundings),
 * and 2^-100 per unit of time and of reciprocal (subnormals, flushed or
 * not). The spheres' gaps: 2^-21 of the coordinates' size, and 2^-100. */
#define LC_F_SLACK 0x1p-19
#define LC_F_GAP 0x1p-21
#define LC_F_TINY 0x1p-100

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
        double u, v, enter, leave;
        if (q->d[a] == 0.0) {
            if (in > 0.0 || out < 0.0)
                return 0;
            continue;
        }
        /* (in <= out: the smaller quotient is the entry, whatever d's
         * sign; a min and a max instead of a branch on the sign) */
        u = in / q->d[a], v = out / q->d[a];
        enter = u < v ? u : v, leave = u < v ? v : u;
        t0 = enter > t0 ? enter : t0;
        t1 = leave < t1 ? leave : t1;
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

/* Lane k of nd as doubles (floats widen exactly). */
static void lane_box(const lc_qt_node *nd, uint32_t k, double lo[3], double hi[3])
{
    int a;
    for (a = 0; a < 3; a++)
        lo[a] = nd->lo[a][k], hi[a] = nd->hi[a][k];
}

/* ---- the query in floats ---- */

/* x as a float no larger (up = 0) or no smaller (up = 1), within +-FLT_MAX. */
static float to_float(double x, int up)
{
    float f;
    uint32_t u;
    if (x >= FLT_MAX || x <= -FLT_MAX)
        return x > 0.0 ? FLT_MAX : -FLT_MAX;
    f = (float)x;
    if (up ? (double)f >= x : (double)f <= x)
        return f;
    if (f == 0.0f) /* the smallest subnormal, of the side x is on */
        return up ? 0x1p-149f : -0x1p-149f;
    memcpy(&u, &f, sizeof u); /* the next float away from or toward 0 */
    u = (f > 0.0f) == (up != 0) ? u + 1u : u - 1u;
    memcpy(&f, &u, sizeof f);
    return f;
}

/* A cast's axis a in floats; 0 when out of the floats' range. */
static int prepare_axis(lc_walk *w, int a, double size)
{
    const lc_shape *q = w->q;
    lc_fquery *f = &w->f;
    const double d = q->d[a], r = 1.0 / d, reach = size + fabs(q->lo[a]) + fabs(q->hi[a]);
    const uint32_t at[2] = {(uint32_t)offsetof(lc_qt_node, lo[a]), (uint32_t)offsetof(lc_qt_node, hi[a])};
    const double ends[2] = {q->lo[a], q->hi[a]};
    const int pos = d > 0.0;
    if (d == 0.0)
        return 1;
    /* (one branch, not four: & evaluates every test; NaN fails them) */
    if (!((fabs(r) >= 1.0 / LC_F_TIME) & (fabs(r) <= LC_F_TIME) & (reach <= LC_F_TIME) & (reach * fabs(r) <= LC_F_TIME)))
        return 0;
    f->moving |= 1u << a;
    f->inv[a] = (float)r;
    /* (raised by 2^-22, then rounded to nearest: no smaller than the
     * double, the slack being a normal float; to_float's branch on the
     * rounding's side mispredicted) */
    f->slack[a] = (float)((LC_F_SLACK * reach * fabs(r) + LC_F_TINY * (1.0 + fabs(r))) * (1.0 + 0x1p-22));
    /* (the ends picked by index: a direction's signs are random, a branch on them mispredicted) */
    f->enter_q[a] = (float)ends[pos], f->leave_q[a] = (float)ends[!pos];
    f->enter_at[a] = at[!pos], f->leave_at[a] = at[pos];
    return 1;
}

/* A sphere in floats; 0 when out of the floats' range. */
static int prepare_sphere(lc_walk *w, const double size[3])
{
    const lc_shape *q = w->q;
    lc_fquery *f = &w->f;
    int a;
    if (!(q->r2 <= LC_F_COORD * LC_F_COORD))
        return 0;
    for (a = 0; a < 3; a++) {
        if (!(size[a] <= LC_F_COORD && fabs(q->c[a]) <= LC_F_COORD))
            return 0;
        f->c[a] = (float)q->c[a];
        f->gap_err[a] = to_float(LC_F_GAP * (size[a] + fabs(q->c[a])) + LC_F_TINY, 1);
    }
    f->r2 = to_float(q->r2 * (1.0 + LC_F_GAP) + LC_F_TINY, 1);
    return 1;
}

/* The walk's query in floats (w->f), for a tree with a root. */
static void prepare(lc_walk *w)
{
    const lc_shape *q = w->q;
    lc_fquery *f = &w->f;
    const double *size = w->s->qtree.size;
    int a;
    f->fast = 1, f->moving = 0, f->exact_box = 0;
    if (q->kind == LC_SHAPE_SPHERE) {
        f->fast = prepare_sphere(w, size);
        return;
    }
    f->exact_box = q->kind == LC_SHAPE_BOX;
    for (a = 0; a < 3; a++) {
        if (q->kind == LC_SHAPE_CAST && q->d[a] != 0.0)
            continue; /* (a cast's moving axes take their bounds from prepare_axis) */
        f->lo[a] = to_float(q->lo[a], 0), f->hi[a] = to_float(q->hi[a], 1);
        f->exact_box &= (double)f->lo[a] == q->lo[a] && (double)f->hi[a] == q->hi[a];
    }
    for (a = 0; a < 3 && q->kind == LC_SHAPE_CAST; a++)
        f->fast &= prepare_axis(w, a, size[a]);
    f->max_t = q->max_t >= FLT_MAX ? INFINITY : to_float(q->max_t, 1);
}

/* ---- a node's four lanes at once ---- */

LC_INLINE v4f splat(float x)
{
    const v4f v = {x, x, x, x};
    return v;
}

/* The four floats at byte `at` of nd (a row of lo or hi). */
LC_INLINE v4f row(const lc_qt_node *nd, uint32_t at)
{
    v4f v;
    memcpy(&v, (const char *)nd + at, sizeof v);
    return v;
}

LC_INLINE v4f vmax(v4f a, v4f b)
{
#if defined(__SSE__)
    return _mm_max_ps(a, b);
#else
    return (v4f)(((v4i)(a > b) & (v4i)a) | (~(v4i)(a > b) & (v4i)b));
#endif
}

LC_INLINE v4f vmin(v4f a, v4f b)
{
#if defined(__SSE__)
    return _mm_min_ps(a, b);
#else
    return (v4f)(((v4i)(a < b) & (v4i)a) | (~(v4i)(a < b) & (v4i)b));
#endif
}

/* The lanes' bits from a mask of all-ones or zero lanes. */
LC_INLINE uint32_t bits_of(v4i m)
{
#if defined(__SSE__)
    return (uint32_t)_mm_movemask_ps((__m128)m);
#else
    return (uint32_t)((m[0] & 1) | (m[1] & 2) | (m[2] & 4) | (m[3] & 8));
#endif
}

/* The lanes the query's box (rounded outward) meets. */
LC_INLINE v4i box_mask(const lc_fquery *f, const lc_qt_node *nd)
{
    v4i ok = (v4i)(row(nd, offsetof(lc_qt_node, lo[0])) <= splat(f->hi[0])) &
             (v4i)(splat(f->lo[0]) <= row(nd, offsetof(lc_qt_node, hi[0])));
    ok &= (v4i)(row(nd, offsetof(lc_qt_node, lo[1])) <= splat(f->hi[1])) &
          (v4i)(splat(f->lo[1]) <= row(nd, offsetof(lc_qt_node, hi[1])));
    ok &= (v4i)(row(nd, offsetof(lc_qt_node, lo[2])) <= splat(f->hi[2])) &
          (v4i)(splat(f->lo[2]) <= row(nd, offsetof(lc_qt_node, hi[2])));
    return ok;
}

static uint32_t sphere_lanes(const lc_fquery *f, const lc_qt_node *nd)
{
    v4f sum = splat(0.0f);
    int a;
    for (a = 0; a < 3; a++) {
        const v4f c = splat(f->c[a]), lo = row(nd, (uint32_t)offsetof(lc_qt_node, lo[a])),
                  hi = row(nd, (uint32_t)offsetof(lc_qt_node, hi[a]));
        const v4f g = vmax(vmax(lo - c, c - hi) - splat(f->gap_err[a]), splat(0.0f));
        sum += g * g;
    }
    /* (an empty lane's gap is +inf: it fails) */
    return bits_of((v4i)(sum <= splat(f->r2)));
}

/* The cast's lanes, and a lower bound of each lane's entry time in t.
 * `all`, a constant where it is inlined: the direction moves on every
 * axis (most rays), and the test asks no axis whether it moves. */
LC_INLINE uint32_t cast_lanes(const lc_fquery *f, const lc_qt_node *nd, float t[4], int all)
{
    v4f t0 = splat(0.0f), t1 = splat(f->max_t);
    v4i ok = {-1, -1, -1, -1};
    int a;
    for (a = 0; a < 3; a++) {
        const uint32_t lo_at = (uint32_t)offsetof(lc_qt_node, lo[a]), hi_at = (uint32_t)offsetof(lc_qt_node, hi[a]);
        if (!all && !(f->moving & (1u << a))) { /* the box stays within its slab on this axis */
            ok &= (v4i)(row(nd, lo_at) <= splat(f->hi[a])) & (v4i)(splat(f->lo[a]) <= row(nd, hi_at));
            continue;
        }
        t0 = vmax(t0, (row(nd, f->enter_at[a]) - splat(f->enter_q[a])) * splat(f->inv[a]) - splat(f->slack[a]));
        t1 = vmin(t1, (row(nd, f->leave_at[a]) - splat(f->leave_q[a])) * splat(f->inv[a]) + splat(f->slack[a]));
    }
    ok &= (v4i)(t0 <= t1);
    memcpy(t, &t0, sizeof t0);
    return bits_of(ok);
}

/* The lanes by each one's exact test (the query out of the floats' range). */
static uint32_t exact_lanes(const lc_walk *w, const lc_qt_node *nd, float t[4])
{
    uint32_t k, m = 0;
    for (k = 0; k < LC_QT_WIDTH; k++) {
        double lo[3], hi[3], tk = 0.0;
        lane_box(nd, k, lo, hi);
        if (lo[0] <= hi[0] && meets(w->q, lo, hi, &tk))
            m |= 1u << k;
        t[k] = to_float(tk, 0);
    }
    return m;
}

/* How a walk tests its nodes' lanes (a walk is compiled for each). */
enum { LANES_BOX, LANES_SPHERE, LANES_CAST, LANES_CAST3, LANES_EXACT };

static int lanes_of(const lc_walk *w)
{
    if (!w->f.fast)
        return LANES_EXACT;
    if (w->q->kind == LC_SHAPE_CAST)
        return w->f.moving == 7u ? LANES_CAST3 : LANES_CAST;
    return w->q->kind == LC_SHAPE_BOX ? LANES_BOX : LANES_SPHERE;
}

/* The lanes of nd the shape may meet (bits), and lower bounds of their
 * entry times in t (casts; 0 else). `how` is a constant where it is
 * inlined. */
LC_INLINE uint32_t lanes_met(const lc_walk *w, const lc_qt_node *nd, float t[4], int how)
{
    switch (how) {
    case LANES_CAST:
    case LANES_CAST3:
        return cast_lanes(&w->f, nd, t, how == LANES_CAST3);
    case LANES_EXACT:
        return exact_lanes(w, nd, t);
    default:
        t[0] = t[1] = t[2] = t[3] = 0.0f;
        return how == LANES_BOX ? bits_of(box_mask(&w->f, nd)) : sphere_lanes(&w->f, nd);
    }
}

/* ---- hits ---- */

/* Room for `more` hits. 0 on no memory (the walk failed). */
static int hit_room(lc_walk *w, size_t more)
{
    size_t cap;
    lc_hit *h;
    if (w->nhit + more <= w->hit_cap)
        return 1;
    cap = lc_grow_cap(w->hit_cap, w->nhit + more);
    if (!(h = lc_alloc(w->s->alloc, cap * sizeof *h))) {
        w->failed = 1;
        return 0;
    }
    if (w->nhit)
        memcpy(h, w->hit, w->nhit * sizeof *h);
    if (w->hit != w->hit_in)
        lc_free(w->s->alloc, w->hit, w->hit_cap * sizeof *w->hit);
    w->hit = h, w->hit_cap = cap;
    return 1;
}

static void put_hit(lc_walk *w, double t, locd_id id)
{
    if (!hit_room(w, 1))
        return;
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
    /* (the first hit is taken even at t = +inf: a time can overflow) */
    if (w->best.id == LOCD_ID_NONE || t < w->best.t || (t == w->best.t && id < w->best.id)) {
        w->best.t = t, w->best.id = id;
        w->best_tf = t >= FLT_MAX ? INFINITY : to_float(t, 1);
    }
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
    if (nd->inexact & (1u << k))
        return try_object(w, nd->child[k]);
    if (w->f.exact_box) /* (the lane's test was the object's) */
        return take(w, nd->child[k], 0.0);
    lane_box(nd, k, lo, hi);
    return meets(w->q, lo, hi, &t) && take(w, nd->child[k], t);
}

/* ---- the walk ---- */

/* Room for `more` entries on the stack (the walk's own, then the heap's).
 * 0 on no memory. */
static int stack_room(lc_walk *w, size_t used, size_t more)
{
    size_t cap;
    uint32_t *st;
    float *tt;
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

/* Node i's two lines asked for while the other lanes are seen to. */
LC_INLINE void prefetch_node(const lc_walk *w, uint32_t i)
{
    const char *c = (const char *)&w->s->qtree.node[i];
    __builtin_prefetch(c);
    __builtin_prefetch(c + 64);
}

/* Node i pushed (and asked for). */
LC_INLINE void push(lc_walk *w, size_t *top, uint32_t i, float t)
{
    prefetch_node(w, i);
    w->stack[*top] = i, w->stack_t[*top] = t;
    ++*top;
}

/* Two keys in order (branch free). */
LC_INLINE void order2(uint32_t *a, uint32_t *b)
{
    const uint32_t lo = *a < *b ? *a : *b, hi = *a < *b ? *b : *a;
    *a = lo, *b = hi;
}

/* The lanes whose entry time t[k] is at most `bound`. */
LC_INLINE uint32_t lanes_before(const float *t, float bound)
{
    v4f v;
    memcpy(&v, t, sizeof v);
    return bits_of((v4i)(v <= splat(bound)));
}

/* A cast's node: its objects met tested (those entered before the best
 * hit so far), its nodes met pushed farthest first (those entered before
 * the best hit). Returns 1 to stop the walk. A node's sort key is its
 * lane's time's bits (times are >= 0, or -0: their bits order as they do)
 * with the lane in the two lowest; the time pushed is the key's, lowered
 * by at most 3 units in the last place (still a lower bound); a lane not
 * pushed sorts last. A push of two or more nodes is branch free: which
 * lanes a ray meets is as good as random, and branches on it were a third
 * of a short ray's mispredictions; its four entries are written whatever
 * their count (the stack has room: walk_tree). One node is pushed by
 * itself (cheaper than the sort, though its branch mispredicts). */
LC_INLINE int visit(lc_walk *w, const lc_qt_node *nd, uint32_t met, const float *t, size_t *top)
{
    const uint32_t near = met & lanes_before(t, w->best_tf), kids = near & ~(uint32_t)nd->objects;
    uint32_t objs = near & nd->objects, k, n, key[4];
    for (; objs; objs &= objs - 1) {
        k = (uint32_t)__builtin_ctz(objs);
        if (t[k] <= w->best_tf && try_lane(w, nd, k))
            return 1;
    }
    if (!(kids & (kids - 1))) { /* one node or none (a leaf) */
        if (kids) {
            k = (uint32_t)__builtin_ctz(kids);
            push(w, top, nd->child[k], t[k]);
        }
        return 0;
    }
    for (k = 0; k < LC_QT_WIDTH; k++) {
        memcpy(&key[k], &t[k], sizeof key[k]);
        key[k] = (key[k] & ~3u) | k | (0u - (~kids >> k & 1u));
    }
    order2(&key[0], &key[1]), order2(&key[2], &key[3]);
    order2(&key[0], &key[2]), order2(&key[1], &key[3]);
    order2(&key[1], &key[2]);
    n = (uint32_t)__builtin_popcount(kids);
    for (k = 0; k < LC_QT_WIDTH; k++) { /* the nearest on top */
        const uint32_t kk = key[(n - 1 - k) & 3u], lane = kk & 3u, bits = kk & ~3u;
        w->stack[*top + k] = nd->child[lane];
        memcpy(&w->stack_t[*top + k], &bits, sizeof bits);
    }
    for (k = 0; k < LC_QT_WIDTH; k++) /* (past n the first again: no branch on n) */
        prefetch_node(w, w->stack[*top + (k & (0u - (k < n)))]);
    *top += n;
    return 0;
}

/* The objects of nd's lanes `objs`, each a hit (a box query whose node
 * test is the objects' own, with no filter to ask). Written four and
 * counted, with no branch on which lanes met: the loops over them were
 * half of a box query's mispredictions. Returns 0 on no memory. */
LC_INLINE int take_lanes(lc_walk *w, const lc_qt_node *nd, uint32_t objs)
{
    const locd_id *id = w->s->slots.id;
    const uint32_t first = nd->child[__builtin_ctz(objs)];
    uint32_t k;
    if (!hit_room(w, LC_QT_WIDTH))
        return 0;
    for (k = 0; k < LC_QT_WIDTH; k++) {
        const uint32_t on = 0u - (objs >> k & 1u), slot = (nd->child[k] & on) | (first & ~on);
        w->hit[w->nhit].t = 0.0, w->hit[w->nhit].id = id[slot];
        w->nhit += on & 1u;
    }
    return 1;
}

/* The walk of an overlap, or of a cast after all its hits or any one: the
 * lanes met in no order (the hits are sorted after). */
LC_INLINE void walk_overlap(lc_walk *w, int how)
{
    const lc_qt_node *node = w->s->qtree.node;
    const int plain = how == LANES_BOX && w->f.exact_box && !w->check_cat && !w->reject;
    size_t top = 1;
    while (top) {
        const lc_qt_node *nd = &node[w->stack[--top]];
        float t[4];
        const uint32_t met = lanes_met(w, nd, t, how);
        uint32_t objs = met & nd->objects, kids;
        if (objs && plain && !(objs & nd->inexact)) {
            if (!take_lanes(w, nd, objs))
                return;
        } else
            for (; objs; objs &= objs - 1)
                if (try_lane(w, nd, (uint32_t)__builtin_ctz(objs)))
                    return;
        for (kids = met & ~(uint32_t)nd->objects; kids; kids &= kids - 1)
            push(w, &top, nd->child[__builtin_ctz(kids)], 0.0f);
    }
}

/* The walk of a cast after its closest hit: front to back, nodes entered
 * after the best hit so far passed by. */
LC_INLINE void walk_cast(lc_walk *w, int how)
{
    const lc_qt_node *node = w->s->qtree.node;
    size_t top = 1;
    while (top) {
        const lc_qt_node *nd;
        float t[4];
        uint32_t met;
        --top;
        if (w->stack_t[top] > w->best_tf)
            continue;
        nd = &node[w->stack[top]];
        met = lanes_met(w, nd, t, how);
        if (met && visit(w, nd, met, t, &top))
            return;
    }
}

/* The walks, one compiled for each node test. */
static void walk_box(lc_walk *w) { walk_overlap(w, LANES_BOX); }
static void walk_sphere(lc_walk *w) { walk_overlap(w, LANES_SPHERE); }
static void walk_cast_all(lc_walk *w) { walk_overlap(w, LANES_CAST); }
static void walk_cast3_all(lc_walk *w) { walk_overlap(w, LANES_CAST3); }
static void walk_exact(lc_walk *w) { walk_overlap(w, LANES_EXACT); }
static void walk_closest(lc_walk *w) { walk_cast(w, LANES_CAST); }
static void walk_closest3(lc_walk *w) { walk_cast(w, LANES_CAST3); }
static void walk_closest_exact(lc_walk *w) { walk_cast(w, LANES_EXACT); }

static int walk_tree(lc_walk *w)
{
    const lc_query_tree *qt = &w->s->qtree;
    if (qt->root == LC_QT_NONE)
        return 1;
    /* (a walk holds at most 3 nodes a level and the root; visit writes 4
     * entries past the top) */
    if (!stack_room(w, 0, 4 * (size_t)qt->levels + 8))
        return 0;
    prepare(w);
    w->stack[0] = qt->root, w->stack_t[0] = 0.0f;
    if (w->q->kind == LC_SHAPE_CAST && w->mode == LOCD_HIT_CLOSEST)
        switch (lanes_of(w)) {
        case LANES_CAST3: walk_closest3(w); break;
        case LANES_CAST: walk_closest(w); break;
        default: walk_closest_exact(w); break;
        }
    else
        switch (lanes_of(w)) {
        case LANES_BOX: walk_box(w); break;
        case LANES_SPHERE: walk_sphere(w); break;
        case LANES_CAST3: walk_cast3_all(w); break;
        case LANES_CAST: walk_cast_all(w); break;
        default: walk_exact(w); break;
        }
    return !w->failed;
}

int lc_walk_run(lc_walk *w)
{
    const lc_query_tree *qt = &w->s->qtree;
    size_t k;
    w->best.t = INFINITY, w->best.id = LOCD_ID_NONE, w->best_tf = INFINITY;
    w->nhit = 0, w->failed = 0;
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

LC_INLINE int hit_before(const lc_hit *a, const lc_hit *b)
{
    return a->t < b->t || (a->t == b->t && a->id < b->id);
}

static int cmp_hit(const void *pa, const void *pb)
{
    const lc_hit *a = pa, *b = pb;
    return hit_before(a, b) ? -1 : hit_before(b, a);
}

/* Below this many hits an insertion sort: a query's few hits sorted
 * by qsort's calls through a pointer took a third of a box query's time. */
#define LC_SORT_SMALL 48

void lc_walk_sort(lc_walk *w)
{
    size_t k, x;
    if (w->nhit > LC_SORT_SMALL) {
        qsort(w->hit, w->nhit, sizeof *w->hit, cmp_hit);
        return;
    }
    for (k = 1; k < w->nhit; k++) {
        const lc_hit h = w->hit[k];
        for (x = k; x > 0 && hit_before(&h, &w->hit[x - 1]); x--)
            w->hit[x] = w->hit[x - 1];
        w->hit[x] = h;
    }
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
    /* (field by field: the walk is set up once a query, and a memset of
     * it was a tenth of a small query's time) */
    w->s = s, w->q = q, w->mode = mode, w->mask = mask;
    w->reject = NULL, w->user = NULL;
    w->nhit = 0, w->failed = 0;
    w->best.t = INFINITY, w->best.id = LOCD_ID_NONE, w->best_tf = INFINITY;
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
