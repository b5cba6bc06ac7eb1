/* The query tree: its build, and the sync that brings it up to the boxes
 * now (query_tree.h). A lane's bounds are the object's box as floats
 * rounded outward, so a node's bounds hold every box below it; the tests
 * on them (query_walk.c) are the objects' own float64 tests, which are
 * monotone in the bounds, so a node that holds a hit is never passed by. */
#include "scene/scene.h"

#include <stdlib.h>

/* The extra list may hold this many objects, and an eighth of the tree's,
 * before the tree is built again with them. */
#define LC_QT_EXTRA_MIN 64
/* The leaves' surface area may grow to this many times its size at the
 * build before the tree is built again (objects that moved far make their
 * leaves loose). */
#define LC_QT_LOOSE 2.0
/* From this share of changed objects (1/2^k of the tree's) the sync writes
 * every lane again instead of the changed ones. */
#define LC_QT_FULL_SHIFT 3
/* A full refit asks for the boxes of the node this far ahead. */
#define LC_QT_AHEAD 8

void lc_query_tree_init(lc_query_tree *t)
{
    memset(t, 0, sizeof *t);
    t->root = LC_QT_NONE;
    t->synced = LC_QT_STALE;
    t->lock_made = pthread_mutex_init(&t->lock, NULL) == 0;
}

/* The tree emptied (not valid); its arrays kept for the next build, whose
 * pages are then faulted in already. */
static void empty_tree(lc_query_tree *t)
{
    t->nnodes = t->nextra = 0;
    t->root = LC_QT_NONE;
    t->valid = 0;
}

static void free_tree(const locd_allocator *a, lc_query_tree *t)
{
    lc_free(a, t->node, t->node_cap * sizeof *t->node);
    lc_free(a, t->where, t->where_cap * sizeof *t->where);
    lc_free(a, t->extra, t->extra_cap * sizeof *t->extra);
    t->node = NULL, t->where = NULL, t->extra = NULL;
    t->node_cap = t->where_cap = t->extra_cap = 0;
    empty_tree(t);
}

void lc_query_tree_fini(locd_scene *s)
{
    lc_query_tree *t = &s->qtree;
    free_tree(s->alloc, t);
    lc_free(s->alloc, t->pending, t->pending_cap * sizeof *t->pending);
    t->pending = NULL, t->npending = t->pending_cap = 0;
    if (t->lock_made)
        pthread_mutex_destroy(&t->lock);
    t->lock_made = 0;
}

void lc_query_tree_note_update(locd_scene *s)
{
    lc_query_tree *t = &s->qtree;
    const lc_slots *sl = &s->slots;
    const size_t more = sl->ndirty + sl->nremoved;
    t->synced = LC_QT_STALE;
    if (!t->valid || t->all_pending || !more)
        return;
    if (t->npending + more > t->nbuilt >> LC_QT_FULL_SHIFT) {
        t->all_pending = 1;
        return;
    }
    if (t->npending + more > t->pending_cap) {
        const size_t cap = lc_grow_cap(t->pending_cap, t->npending + more);
        uint32_t *p = lc_alloc(s->alloc, cap * sizeof *p);
        if (!p) { /* the sync writes every lane instead */
            t->all_pending = 1;
            return;
        }
        if (t->npending)
            memcpy(p, t->pending, t->npending * sizeof *p);
        lc_free(s->alloc, t->pending, t->pending_cap * sizeof *t->pending);
        t->pending = p, t->pending_cap = cap;
    }
    if (sl->ndirty) /* (an empty list may have no array) */
        memcpy(t->pending + t->npending, sl->dirty.data, sl->ndirty * sizeof *t->pending);
    if (sl->nremoved)
        memcpy(t->pending + t->npending + sl->ndirty, sl->removed.data, sl->nremoved * sizeof *t->pending);
    t->npending += more;
}

/* ---- lanes and nodes ---- */

static void lane_clear(lc_qt_node *nd, uint32_t lane)
{
    int a;
    for (a = 0; a < 3; a++)
        nd->lo[a][lane] = INFINITY, nd->hi[a][lane] = -INFINITY;
    nd->objects &= (uint8_t) ~(1u << lane);
    nd->inexact &= (uint8_t) ~(1u << lane);
    nd->child[lane] = LC_QT_NONE;
}

/* x as a float no larger (down) or no smaller (up). */
static float round_float(double x, int up)
{
    const float f = (float)x;
    if (up ? (double)f < x : (double)f > x)
        return nextafterf(f, up ? INFINITY : -INFINITY);
    return f;
}

/* Lane `lane` of nd: the object in `slot`, its box as floats (rounded
 * outward when its box is not floats exactly). */
static void lane_set(const lc_slots *sl, lc_qt_node *nd, uint32_t lane, uint32_t slot)
{
    int a;
    nd->child[lane] = slot;
    nd->objects |= (uint8_t)(1u << lane);
    if (!(sl->flags[slot] & LC_SLOT_INEXACT)) {
        const float *f = sl->fbox + 6 * (size_t)slot;
        for (a = 0; a < 3; a++)
            nd->lo[a][lane] = f[a], nd->hi[a][lane] = f[a + 3];
        nd->inexact &= (uint8_t) ~(1u << lane);
        return;
    }
    for (a = 0; a < 3; a++) {
        nd->lo[a][lane] = round_float(sl->box[6 * (size_t)slot + (size_t)a], 0);
        nd->hi[a][lane] = round_float(sl->box[6 * (size_t)slot + 3 + (size_t)a], 1);
    }
    nd->inexact |= (uint8_t)(1u << lane);
}

/* The union of nd's lanes (+inf..-inf when all are empty). */
static void node_union(const lc_qt_node *nd, float lo[3], float hi[3])
{
    int a, k;
    for (a = 0; a < 3; a++) {
        lo[a] = INFINITY, hi[a] = -INFINITY;
        for (k = 0; k < LC_QT_WIDTH; k++) {
            lo[a] = nd->lo[a][k] < lo[a] ? nd->lo[a][k] : lo[a];
            hi[a] = nd->hi[a][k] > hi[a] ? nd->hi[a][k] : hi[a];
        }
    }
}

static double area_of(const float lo[3], const float hi[3])
{
    const double x = (double)hi[0] - lo[0], y = (double)hi[1] - lo[1], z = (double)hi[2] - lo[2];
    return lo[0] <= hi[0] ? 2.0 * (x * y + y * z + z * x) : 0.0;
}

/* Writes node i's union into its parent's lane; returns the change of the
 * lane's area (for the leaves' sum); *changed: whether the lane did. */
static double lift(lc_query_tree *t, uint32_t i, int *changed)
{
    const lc_qt_node *nd = &t->node[i];
    float lo[3], hi[3], olo[3], ohi[3];
    lc_qt_node *p;
    uint32_t lane;
    int a;
    *changed = 0;
    if (nd->parent == LC_QT_NONE)
        return 0.0;
    p = &t->node[nd->parent >> 2], lane = nd->parent & 3u;
    node_union(nd, lo, hi);
    for (a = 0; a < 3; a++) {
        olo[a] = p->lo[a][lane], ohi[a] = p->hi[a][lane];
        *changed |= olo[a] != lo[a] || ohi[a] != hi[a];
        p->lo[a][lane] = lo[a], p->hi[a][lane] = hi[a];
    }
    return area_of(lo, hi) - area_of(olo, ohi);
}

/* Node i's union into its parent, and on up while a lane changes (an
 * ancestor whose lane stayed holds what it held). */
static void lift_up(lc_query_tree *t, uint32_t i)
{
    int changed = 1;
    while (changed && t->node[i].parent != LC_QT_NONE) {
        t->area += lift(t, i, &changed);
        i = t->node[i].parent >> 2;
    }
}

/* ---- the build ---- */

/* The bounds of the live boxes' centres (floats: only an order is made of them). */
static void centre_bounds(const lc_slots *sl, float lo[3], float hi[3])
{
    size_t k;
    int a;
    for (a = 0; a < 3; a++)
        lo[a] = INFINITY, hi[a] = -INFINITY;
    for (k = 0; k < sl->nslots; k++)
        if (sl->flags[k] & LC_SLOT_LIVE)
            for (a = 0; a < 3; a++) {
                const float c = 0.5f * sl->fbox[6 * k + (size_t)a] + 0.5f * sl->fbox[6 * k + 3 + (size_t)a];
                lo[a] = c < lo[a] ? c : lo[a];
                hi[a] = c > hi[a] ? c : hi[a];
            }
}

/* The live slots (n of them) in the Morton order of their centres, into
 * order, and their codes, into code: the centres quantized to as many bits
 * per axis as the index leaves free (21 at most), sorted by the radix sort. */
static locd_status morton_order(locd_scene *s, uint32_t *order, uint64_t *code, size_t n)
{
    const lc_slots *sl = &s->slots;
    uint64_t *keys = lc_alloc(s->alloc, 2 * (n ? n : 1) * sizeof *keys), *sorted;
    uint32_t ib = 1, bits, a, *slots;
    double scale[3];
    float lo[3], hi[3];
    size_t k, m = 0;
    if (!keys)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the query tree");
    while (ib < 32 && ((size_t)1 << ib) < n)
        ib++;
    bits = (64u - ib) / 3u > 21u ? 21u : (64u - ib) / 3u;
    centre_bounds(sl, lo, hi);
    for (a = 0; a < 3; a++)
        scale[a] = hi[a] > lo[a] ? (double)(((uint32_t)1 << bits) - 1u) / ((double)hi[a] - lo[a]) : 0.0;
    for (k = 0; k < sl->nslots; k++)
        if (sl->flags[k] & LC_SLOT_LIVE) {
            uint64_t c = 0;
            for (a = 0; a < 3; a++) {
                const float x = 0.5f * sl->fbox[6 * k + a] + 0.5f * sl->fbox[6 * k + 3 + a];
                c |= lc_morton_split3((uint32_t)(((double)x - lo[a]) * scale[a])) << a;
            }
            order[m] = (uint32_t)k;
            keys[m] = c << ib | m;
            m++;
        }
    sorted = lc_radix_sort(keys, keys + n, n, ib);
    slots = (uint32_t *)(sorted == keys ? keys + n : keys); /* the other half is free */
    for (k = 0; k < n; k++) {
        slots[k] = order[sorted[k] & (((uint64_t)1 << ib) - 1)];
        code[k] = sorted[k] >> ib;
    }
    memcpy(order, slots, n * sizeof *order);
    lc_free(s->alloc, keys, 2 * (n ? n : 1) * sizeof *keys);
    return LOCD_OK;
}

/* The objects order[0, n) (codes code) being made into nodes. */
typedef struct builder {
    lc_query_tree *t;
    const lc_slots *sl;
    const uint32_t *order;
    const uint64_t *code;
} builder;

typedef struct bit_at {
    const uint64_t *code;
    uint32_t bit;
} bit_at;

static int has_bit(const void *ctx, uint64_t i)
{
    const bit_at *c = ctx;
    return (int)((c->code[i] >> c->bit) & 1u);
}

/* Where [b, e) splits: at its highest differing code bit (the codes below
 * it have it clear, sorted), or in the middle when every code is the same. */
static size_t split_at(const uint64_t *code, size_t b, size_t e)
{
    const uint64_t x = code[b] ^ code[e - 1];
    bit_at c;
    if (!x)
        return b + (e - b) / 2;
    c.code = code, c.bit = 63u - (uint32_t)__builtin_clzll(x);
    return (size_t)lc_search_first(b, e, has_bit, &c);
}

/* A new node (the room was made: count_nodes), its index. */
static uint32_t new_node(builder *bd)
{
    lc_query_tree *t = bd->t;
    uint32_t k;
    memset(&t->node[t->nnodes], 0, sizeof *t->node);
    for (k = 0; k < LC_QT_WIDTH; k++)
        lane_clear(&t->node[t->nnodes], k);
    return (uint32_t)t->nnodes++;
}

/* Room for `need` nodes (the pages of a larger array kept from before
 * stay faulted in). */
static locd_status node_room(const locd_allocator *a, lc_query_tree *t, size_t need)
{
    lc_qt_node *nd;
    need = need ? need : 1;
    if (need <= t->node_cap)
        return LOCD_OK;
    if (!(nd = lc_alloc(a, need * sizeof *nd)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the query tree");
    lc_free(a, t->node, t->node_cap * sizeof *t->node);
    t->node = nd, t->node_cap = need;
    return LOCD_OK;
}

/* Below this many objects a node's parts are runs of four in Morton
 * order: full leaves, a third fewer nodes than splits at the codes' bits
 * make, for the small boxes they hold the same. */
#define LC_QT_RUNS 16

/* The parts of [b, e) a node holds, bounds in cut: four or fewer objects
 * one each; up to LC_QT_RUNS, runs of four; else splits at the codes' bits,
 * the part with the most objects split next, until there are four (a split
 * that leaves one object on a side does not leave a lane empty). Returns how
 * many. */
static uint32_t parts_of(const uint64_t *code, size_t b, size_t e, size_t cut[LC_QT_WIDTH + 1])
{
    uint32_t n = 0, k, big;
    if (e - b <= LC_QT_WIDTH) {
        for (; b <= e; b++)
            cut[n++] = b;
        return n - 1;
    }
    if (e - b <= LC_QT_RUNS) {
        for (; b < e; b += LC_QT_WIDTH)
            cut[n++] = b;
        cut[n++] = e;
        return n - 1;
    }
    cut[0] = b, cut[1] = e, n = 1;
    while (n < LC_QT_WIDTH) {
        for (big = 0, k = 1; k < n; k++)
            big = cut[k + 1] - cut[k] > cut[big + 1] - cut[big] ? k : big;
        if (cut[big + 1] - cut[big] < 2)
            break;
        for (k = n + 1; k > big + 1; k--)
            cut[k] = cut[k - 1];
        cut[big + 1] = split_at(code, cut[big], cut[big + 2]);
        n++;
    }
    return n;
}

/* How many nodes make_node makes for [b, e) (more than one object): the
 * build allocates that many (about 0.4 a object), not the n - 1 it could. */
static size_t count_nodes(const uint64_t *code, size_t b, size_t e)
{
    size_t cut[LC_QT_WIDTH + 1], m = 1;
    const uint32_t n = parts_of(code, b, e, cut);
    uint32_t k;
    for (k = 0; k < n; k++)
        if (cut[k + 1] - cut[k] > 1)
            m += count_nodes(code, cut[k], cut[k + 1]);
    return m;
}

/* The node of objects [b, e) (more than one) and its subtree, below
 * parent's lane (parent << 2 | lane), at depth `depth`. Returns its index. */
static uint32_t make_node(builder *bd, size_t b, size_t e, uint32_t parent, uint32_t depth)
{
    lc_query_tree *t = bd->t;
    size_t cut[LC_QT_WIDTH + 1];
    const uint32_t n = parts_of(bd->code, b, e, cut), i = new_node(bd);
    uint32_t k;
    t->node[i].parent = parent;
    t->node[i].level = (uint8_t)(depth < 255 ? depth : 255);
    t->levels = depth + 1 > t->levels ? depth + 1 : t->levels;
    for (k = 0; k < n; k++) {
        if (cut[k + 1] - cut[k] == 1) {
            lane_set(bd->sl, &t->node[i], k, bd->order[cut[k]]);
            t->where[bd->order[cut[k]]] = i << 2 | k;
        } else {
            const uint32_t c = make_node(bd, cut[k], cut[k + 1], i << 2 | k, depth + 1);
            int changed;
            t->node[i].child[k] = c;
            t->area += lift(t, c, &changed);
        }
    }
    return i;
}

/* Room for where[] of every slot (LC_QT_NONE for the new ones). */
static locd_status where_room(const locd_scene *s, lc_query_tree *t)
{
    const size_t need = s->slots.slot_cap;
    uint32_t *w;
    if (need <= t->where_cap)
        return LOCD_OK;
    if (!(w = lc_alloc(s->alloc, need * sizeof *w)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the query tree");
    if (t->where_cap)
        memcpy(w, t->where, t->where_cap * sizeof *w);
    memset(w + t->where_cap, 0xff, (need - t->where_cap) * sizeof *w);
    lc_free(s->alloc, t->where, t->where_cap * sizeof *t->where);
    t->where = w, t->where_cap = need;
    return LOCD_OK;
}

/* The root of one object (a tree of one lane). */
static uint32_t one_root(builder *bd)
{
    const uint32_t r = new_node(bd);
    bd->t->node[r].parent = LC_QT_NONE;
    bd->t->levels = 1;
    lane_set(bd->sl, &bd->t->node[r], 0, bd->order[0]);
    bd->t->where[bd->order[0]] = r << 2;
    return r;
}

/* The tree built from every live object; the old one is dropped first. */
static locd_status build(locd_scene *s, lc_query_tree *t)
{
    const size_t n = s->slots.live, cap = n ? n : 1;
    uint32_t *order = lc_alloc(s->alloc, cap * sizeof *order);
    uint64_t *code = lc_alloc(s->alloc, cap * sizeof *code);
    builder bd;
    locd_status st;
    empty_tree(t);
    t->npending = 0, t->all_pending = 0, t->area = 0.0, t->levels = 0;
    if (!order || !code)
        st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the query tree");
    else if ((st = where_room(s, t)) == LOCD_OK && (st = morton_order(s, order, code, n)) == LOCD_OK)
        st = node_room(s->alloc, t, n > 1 ? count_nodes(code, 0, n) : 1);
    if (st == LOCD_OK && n) {
        memset(t->where, 0xff, t->where_cap * sizeof *t->where);
        bd.t = t, bd.sl = &s->slots, bd.order = order, bd.code = code;
        t->root = n == 1 ? one_root(&bd) : make_node(&bd, 0, n, LC_QT_NONE, 0);
    }
    lc_free(s->alloc, order, cap * sizeof *order);
    lc_free(s->alloc, code, cap * sizeof *code);
    if (st != LOCD_OK) {
        free_tree(s->alloc, t);
        return st;
    }
    t->nbuilt = n;
    t->area_built = t->area;
    t->valid = 1;
    return LOCD_OK;
}

/* ---- the sync ---- */

/* Room for `more` extra objects. */
static locd_status extra_room(const locd_allocator *a, lc_query_tree *t, size_t more)
{
    size_t cap;
    uint32_t *e;
    if (t->nextra + more <= t->extra_cap)
        return LOCD_OK;
    cap = lc_grow_cap(t->extra_cap, t->nextra + more);
    if (!(e = lc_alloc(a, cap * sizeof *e)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the query tree");
    if (t->nextra)
        memcpy(e, t->extra, t->nextra * sizeof *e);
    lc_free(a, t->extra, t->extra_cap * sizeof *t->extra);
    t->extra = e, t->extra_cap = cap;
    return LOCD_OK;
}

static void extra_add(lc_query_tree *t, uint32_t slot)
{
    t->where[slot] = LC_QT_EXTRA | (uint32_t)t->nextra;
    t->extra[t->nextra++] = slot;
}

static void extra_remove(lc_query_tree *t, uint32_t at)
{
    const uint32_t slot = t->extra[at], last = t->extra[--t->nextra];
    t->extra[at] = last;
    t->where[last] = LC_QT_EXTRA | at;
    t->where[slot] = LC_QT_NONE;
}

LC_INLINE int live(const lc_slots *sl, uint32_t slot)
{
    return slot < sl->nslots && (sl->flags[slot] & LC_SLOT_LIVE);
}

/* One changed slot: its lane written again (cleared when it holds no
 * object now) and lifted into its ancestors, or the extra list told. */
static void take_change(const lc_slots *sl, lc_query_tree *t, uint32_t slot)
{
    const uint32_t w = t->where[slot];
    lc_qt_node *nd;
    if (w == LC_QT_NONE) {
        if (live(sl, slot))
            extra_add(t, slot);
        return;
    }
    if (w & LC_QT_EXTRA) {
        if (!live(sl, slot))
            extra_remove(t, w & ~LC_QT_EXTRA);
        return;
    }
    nd = &t->node[w >> 2];
    if (live(sl, slot)) {
        lane_set(sl, nd, w & 3u, slot);
    } else {
        lane_clear(nd, w & 3u);
        t->where[slot] = LC_QT_NONE;
    }
    lift_up(t, w >> 2);
}

/* How far ahead the sync asks for what it reads: the changed objects'
 * places, boxes and leaves are scattered over arrays far larger than the
 * caches (a sync waited on each in turn). */
#define LC_QT_FAR 16
#define LC_QT_NEAR 8

/* take_change for each slot of list[0, n), each read asked for ahead. */
static void take_changes(const lc_slots *sl, lc_query_tree *t, const uint32_t *list, size_t n)
{
    size_t k;
    for (k = 0; k < n; k++) {
        if (k + LC_QT_FAR < n)
            __builtin_prefetch(&t->where[list[k + LC_QT_FAR]]);
        if (k + LC_QT_NEAR < n) {
            const uint32_t slot = list[k + LC_QT_NEAR], w = t->where[slot];
            __builtin_prefetch(sl->fbox + 6 * (size_t)slot);
            __builtin_prefetch(&sl->flags[slot]);
            if (w != LC_QT_NONE && !(w & LC_QT_EXTRA)) {
                const lc_qt_node *nd = &t->node[w >> 2];
                __builtin_prefetch(nd);
                __builtin_prefetch((const char *)nd + 64);
            }
        }
        take_change(sl, t, list[k]);
    }
}

/* The changes since the last sync: the updates' (pending) and the scene's
 * change lists (moves, adds and removes not yet updated). */
static locd_status refit_changed(locd_scene *s, lc_query_tree *t, size_t changes)
{
    const lc_slots *sl = &s->slots;
    locd_status st;
    if ((st = extra_room(s->alloc, t, changes)) != LOCD_OK)
        return st;
    take_changes(sl, t, t->pending, t->npending);
    take_changes(sl, t, sl->dirty.data, sl->ndirty);
    take_changes(sl, t, sl->removed.data, sl->nremoved);
    return LOCD_OK;
}

/* Every lane written again from the boxes now, the extra list brought up
 * to date (its dead objects out, every live object in neither in), every
 * node refitted. */
static locd_status refit_all(locd_scene *s, lc_query_tree *t)
{
    const lc_slots *sl = &s->slots;
    size_t i, k;
    uint32_t lane;
    locd_status st;
    for (i = 0; i < t->nnodes; i++) {
        if (i + LC_QT_AHEAD < t->nnodes) /* the boxes of a node ahead asked for (they are scattered) */
            for (lane = 0; lane < LC_QT_WIDTH; lane++)
                if (t->node[i + LC_QT_AHEAD].objects & (1u << lane))
                    __builtin_prefetch(sl->fbox + 6 * (size_t)t->node[i + LC_QT_AHEAD].child[lane]);
        for (lane = 0; lane < LC_QT_WIDTH; lane++) {
            lc_qt_node *nd = &t->node[i];
            if (!(nd->objects & (1u << lane)))
                continue;
            if (live(sl, nd->child[lane])) {
                lane_set(sl, nd, lane, nd->child[lane]);
            } else {
                t->where[nd->child[lane]] = LC_QT_NONE;
                lane_clear(nd, lane);
            }
        }
    }
    for (k = t->nextra; k-- > 0;)
        if (!live(sl, t->extra[k]))
            extra_remove(t, (uint32_t)k);
    for (k = 0; k < sl->nslots; k++)
        if (live(sl, (uint32_t)k) && t->where[k] == LC_QT_NONE) {
            if ((st = extra_room(s->alloc, t, 1)) != LOCD_OK)
                return st;
            extra_add(t, (uint32_t)k);
        }
    for (i = t->nnodes; i-- > 0;) { /* a node's children follow it in the array */
        int changed;
        t->area += lift(t, (uint32_t)i, &changed);
    }
    return LOCD_OK;
}

static locd_status sync_locked(locd_scene *s, lc_query_tree *t)
{
    const lc_slots *sl = &s->slots;
    const size_t changes = t->npending + sl->ndirty + sl->nremoved;
    locd_status st;
    if (!t->valid)
        return build(s, t);
    if ((st = where_room(s, t)) != LOCD_OK)
        return st;
    st = t->all_pending || changes > t->nbuilt >> LC_QT_FULL_SHIFT ? refit_all(s, t) : refit_changed(s, t, changes);
    if (st != LOCD_OK)
        return st;
    t->npending = 0, t->all_pending = 0;
    if (t->nextra > LC_QT_EXTRA_MIN + (t->nbuilt >> 3) || (t->area > LC_QT_LOOSE * t->area_built && t->area > 0.0))
        return build(s, t);
    return LOCD_OK;
}

/* t->size: the largest magnitude of a bound of the root's lanes per axis,
 * which bounds the float test's rounding errors (query_walk.c). */
static void note_size(lc_query_tree *t)
{
    uint32_t a, k;
    for (a = 0; a < 3; a++) {
        double m = 0.0;
        for (k = 0; t->root != LC_QT_NONE && k < LC_QT_WIDTH; k++) {
            const lc_qt_node *r = &t->node[t->root];
            if (r->lo[a][k] <= r->hi[a][k]) {
                m = fabs((double)r->lo[a][k]) > m ? fabs((double)r->lo[a][k]) : m;
                m = fabs((double)r->hi[a][k]) > m ? fabs((double)r->hi[a][k]) : m;
            }
        }
        t->size[a] = m;
    }
}

locd_status lc_query_tree_sync(const locd_scene *cs)
{
    locd_scene *s = (locd_scene *)cs; /* the tree is a cache: a query brings it up to date */
    lc_query_tree *t = &s->qtree;
    const uint64_t epoch = s->slots.epoch;
    locd_status st = LOCD_OK;
    if (__atomic_load_n(&t->synced, __ATOMIC_ACQUIRE) == epoch)
        return LOCD_OK;
    if (t->lock_made)
        pthread_mutex_lock(&t->lock);
    if (__atomic_load_n(&t->synced, __ATOMIC_RELAXED) != epoch) {
        if ((st = sync_locked(s, t)) == LOCD_OK)
            note_size(t), __atomic_store_n(&t->synced, epoch, __ATOMIC_RELEASE);
        else
            free_tree(s->alloc, t); /* built again by the next sync */
    }
    if (t->lock_made)
        pthread_mutex_unlock(&t->lock);
    return st;
}
