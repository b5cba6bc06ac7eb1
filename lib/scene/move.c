/* A large move on the pool. A move of most of the scene (every body of a
 * simulation, each frame) is two passes over the batch, each one split
 * over the threads: check the ids and boxes, then write the dirty list
 * (and the boxes). A batch whose ids ascend (a caller walking its bodies
 * in order) cannot repeat one; any other batch takes two more passes, one
 * that stamps each slot with its position and one that finds a slot
 * stamped from another position. A batch of every object in slot order
 * (the scene's slots all live, ids ascending: the usual simulation frame)
 * copies its boxes to the spare box array while the checks read them, and
 * the arrays are swapped once all passed: the boxes are read once, not
 * twice. Such a batch's first pass goes a chunk at a time through
 * branch-free loops over its ids and floats (check_chunk_in_place), and
 * its copy bypasses the caches; a chunk where any test fails takes the
 * general loop, which finds the failing position. When the scene keeps its
 * from-scratch entry list (kept_list.c), each chunk that passed is also
 * encoded for the next update while it is in the caches
 * (lc_handover_chunk): the update then does not read the boxes again to
 * encode them. The ranges are the ones the update's encode would take
 * (lc_chunk_begin). A scene of one thread takes these passes for such a
 * batch too, on the caller's thread (the pool runs a task of one there).
 * The result is the
 * serial loop's (scene.c): the same boxes, flags and dirty list in batch
 * order; a bad batch changes nothing and its error is the serial checks'
 * own. */
#include "scene/scene.h"
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

typedef struct move_ctx {
    locd_scene *s;
    const locd_id *ids;
    const void *boxes;
    int f64;
    size_t n;
    uint32_t base;                 /* stamp of position k: base + k */
    float *spare;                  /* pass 1 copies box k to spare[6 k, 6 k + 6) (f32 batches of every slot) */
    int pre;                       /* pass 1 also encodes the boxes for the next update (lc_handover_open) */
    int pre_ok[LC_MAX_THREADS];    /* pass 1: every chunk of the range was encoded */
    int swapped;                   /* pass 3: the spare holds the boxes and is fbox now */
    int bad[LC_MAX_THREADS];       /* a stale or repeated id, or a bad box, in the thread's range */
    int ascend[LC_MAX_THREADS];    /* pass 1: the range's ids ascend */
    int in_place[LC_MAX_THREADS];  /* pass 1: the id at position k has slot k, for every k of the range */
    float lo[LC_MAX_THREADS][3], hi[LC_MAX_THREADS][3]; /* pass 1 with a spare: the range's bounds */
    size_t fresh[LC_MAX_THREADS];  /* pass 1: slots not dirty yet (right once no id repeats), then
                                      the dirty list's offset */
    int64_t inexact[LC_MAX_THREADS]; /* change of ninexact */
    int pass;
} move_ctx;

/* Box i passes the batch checks (checks.c's test). */
LC_INLINE int box_ok(const move_ctx *c, size_t i)
{
    int a;
    double b[6];
    for (a = 0; a < 6; a++)
        b[a] = c->f64 ? ((const double *)c->boxes)[6 * i + a] : (double)((const float *)c->boxes)[6 * i + a];
    return lc_scene_box_fault(b, &a) == LOCD_OK;
}

/* What pass 1 finds in a thread's range. */
typedef struct pass1 {
    int bad, ascend, in_place;
    size_t fresh;
    float lo[3], hi[3];
} pass1;

/* Pass 1 over positions [i, e) of a range starting at `first`, one box at
 * a time: any batch. Stops at the first bad position. */
static void check_boxes(const move_ctx *c, size_t first, size_t i, size_t e, pass1 *r)
{
    const locd_scene *s = c->s;
    int a;
    for (; i < e; i++) {
        int64_t slot = lc_scene_slot(s, c->ids[i]);
        if (slot < 0 || !box_ok(c, i)) {
            r->bad = 1;
            return;
        }
        if (c->spare) { /* the box was just read: in the caches */
            const float *b = (const float *)c->boxes + 6 * i;
            memcpy(c->spare + 6 * i, b, 6 * sizeof(float));
            for (a = 0; a < 3; a++) {
                r->lo[a] = b[a] < r->lo[a] ? b[a] : r->lo[a];
                r->hi[a] = b[a + 3] > r->hi[a] ? b[a + 3] : r->hi[a];
            }
        }
        r->ascend &= i == first || c->ids[i] > c->ids[i - 1];
        r->in_place &= (size_t)slot == i;
        r->fresh += !(s->slots.flags[slot] & LC_SLOT_DIRTY);
    }
}

#define LC_MOVE_CHUNK 512

/* n floats from src to dst, past the caches where the target has stores
 * for that: the spare array is read by the next update, after all of it
 * has been written. */
static void copy_floats(float *dst, const float *src, size_t n)
{
#if defined(__SSE2__)
    size_t k = 0;
    while (k < n && ((uintptr_t)(dst + k) & 15))
        dst[k] = src[k], k++;
    for (; k + 4 <= n; k += 4)
        _mm_stream_ps(dst + k, _mm_loadu_ps(src + k));
    for (; k < n; k++)
        dst[k] = src[k];
#else
    memcpy(dst, src, n * sizeof *dst);
#endif
}

/* Pass 1 over positions [i, e) of a float batch of every slot (spare set),
 * when each id there is its slot's own in slot order (ids ascending) and
 * each box is finite with min <= max: branch-free loops over ids and
 * floats (a float compares as its double does), which the compiler can
 * vectorize. Returns 0, with *r unchanged, when any position fails a
 * test: check_boxes then takes the chunk and finds out which. */
static int check_chunk_in_place(const move_ctx *c, size_t first, size_t i, size_t e, pass1 *r)
{
    const locd_scene *s = c->s;
    const locd_id *ids = c->ids, *own = s->slots.id;
    const uint8_t *fl = s->slots.flags;
    const float *b = (const float *)c->boxes + 6 * i;
    const size_t m = e - i;
    float lo[3], hi[3];
    size_t k, fresh = 0;
    unsigned ok = 1;
    int a;
    if (s->slots.order_known == 2) { /* every slot live, slot k's id (serial0 + k) << 32 | k: no read of the ids */
        locd_id want = ((uint64_t)(LC_ID_SERIAL(own[0]) + i) << 32) | i;
        const locd_id step = ((uint64_t)1 << 32) | 1;
        for (k = i; k < e; k++, want += step)
            ok &= ids[k] == want;
    } else {
        for (k = i; k < e; k++)
            ok &= (ids[k] == own[k]) & (fl[k] & LC_SLOT_LIVE);
    }
    for (k = i > first ? i : first + 1; k < e; k++)
        ok &= ids[k] > ids[k - 1];
    for (k = 0; k < 6 * m; k++)
        ok &= fabsf(b[k]) <= FLT_MAX;
    for (a = 0; a < 3; a++)
        lo[a] = r->lo[a], hi[a] = r->hi[a];
    for (k = 0; k < m; k++) {
        const float *q = b + 6 * k;
        for (a = 0; a < 3; a++) {
            ok &= q[a] <= q[a + 3];
            lo[a] = q[a] < lo[a] ? q[a] : lo[a];
            hi[a] = q[a + 3] > hi[a] ? q[a + 3] : hi[a];
        }
    }
    if (!ok)
        return 0;
    for (k = i; k < e; k++)
        fresh += !(fl[k] & LC_SLOT_DIRTY);
    copy_floats(c->spare + 6 * i, b, 6 * m);
    for (a = 0; a < 3; a++)
        r->lo[a] = lo[a], r->hi[a] = hi[a];
    r->fresh += fresh;
    return 1;
}

/* Pass 1 over thread t's range [i, e): ids live, boxes valid; chunks of a
 * batch of every slot in place checked branch-free, copied to the spare
 * array and handed over encoded. */
static void check_range(move_ctx *c, uint32_t t, size_t i, size_t e)
{
    const size_t first = i;
    pass1 r = {0, 1, 1, 0, {INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    int pre = c->pre;
    while (i < e && !r.bad) {
        const size_t end = e - i > LC_MOVE_CHUNK ? i + LC_MOVE_CHUNK : e;
        if (c->spare && r.in_place && r.ascend && check_chunk_in_place(c, first, i, end, &r)) {
            /* the chunk's boxes are in the caches: encode them now */
            pre = pre && lc_handover_chunk(c->s, t, (const float *)c->boxes, i, end - i);
        } else {
            check_boxes(c, first, i, end, &r);
            pre = 0;
        }
        i = end;
    }
    c->pre_ok[t] = pre;
#if defined(__SSE2__)
    _mm_sfence();
#endif
    c->bad[t] = r.bad;
    c->ascend[t] = r.ascend;
    c->in_place[t] = r.in_place;
    c->fresh[t] = r.fresh;
    memcpy(c->lo[t], r.lo, sizeof r.lo);
    memcpy(c->hi[t], r.hi, sizeof r.hi);
}

/* Pass 2: a slot whose stamp is not its own position's is repeated. */
static void find_repeats(move_ctx *c, uint32_t t, size_t i, size_t e)
{
    const lc_slots *sl = &c->s->slots;
    int bad = 0;
    for (; i < e; i++) {
        const uint32_t slot = LC_ID_SLOT(c->ids[i]);
        if (__atomic_load_n(&sl->stamp[slot], __ATOMIC_RELAXED) != c->base + (uint32_t)i) {
            bad = 1;
            break;
        }
    }
    c->bad[t] = bad;
}

/* Pass 3 after the spare array was swapped in (position k is slot k): the
 * flags, and the slots new to the dirty list at the thread's offset. */
static void mark_in_place(move_ctx *c, uint32_t t, size_t i, size_t e)
{
    lc_slots *sl = &c->s->slots;
    uint32_t *dirty = (uint32_t *)sl->dirty.data + c->fresh[t];
    uint8_t *fl = sl->flags;
    int64_t inexact = 0;
    for (; i < e; i++) {
        const uint8_t f = fl[i];
        inexact -= (f & LC_SLOT_INEXACT) != 0; /* float boxes: exact */
        fl[i] = (uint8_t)((f & ~LC_SLOT_INEXACT) | LC_SLOT_DIRTY);
        if (!(f & LC_SLOT_DIRTY)) /* (a store past the thread's part would be the next thread's) */
            *dirty++ = (uint32_t)i;
    }
    c->inexact[t] = inexact;
}

/* Pass 3 otherwise: the boxes written, and the dirty list as above. */
static void write_boxes(move_ctx *c, uint32_t t, size_t i, size_t e)
{
    locd_scene *s = c->s;
    uint32_t *dirty = (uint32_t *)s->slots.dirty.data + c->fresh[t];
    int64_t inexact = 0;
    for (; i < e; i++) {
        const uint32_t slot = LC_ID_SLOT(c->ids[i]);
        inexact += lc_scene_put_box(s, slot, c->boxes, c->f64, i);
        if (!(s->slots.flags[slot] & LC_SLOT_DIRTY)) {
            s->slots.flags[slot] |= LC_SLOT_DIRTY;
            *dirty++ = slot;
        }
    }
    c->inexact[t] = inexact;
}

static void task_move(void *arg, uint32_t t, uint32_t k)
{
    move_ctx *c = arg;
    size_t i = lc_chunk_begin(c->n, t, k), e = lc_chunk_begin(c->n, t + 1, k);
    if (c->pass == 1) {
        check_range(c, t, i, e);
    } else if (c->pass == 4) { /* each slot stamped with its position */
        for (; i < e; i++) /* a repeated id stamps one slot from two threads: relaxed atomics, no race */
            __atomic_store_n(&c->s->slots.stamp[LC_ID_SLOT(c->ids[i])], c->base + (uint32_t)i, __ATOMIC_RELAXED);
    } else if (c->pass == 2) {
        find_repeats(c, t, i, e);
    } else if (c->swapped) {
        mark_in_place(c, t, i, e);
    } else {
        write_boxes(c, t, i, e);
    }
}

/* 1 when the whole batch's ids ascend (pass 1's ranges, and across their
 * ends: every range holds ids, n >= LC_PARALLEL_MIN): then no id
 * repeats. */
static int batch_ascends(const move_ctx *c, uint32_t k)
{
    uint32_t t;
    for (t = 0; t < k; t++) {
        const size_t first = lc_chunk_begin(c->n, t, k);
        if (!c->ascend[t] || (t && c->ids[first] <= c->ids[first - 1]))
            return 0;
    }
    return 1;
}

/* 1 when every position k of the batch holds an id of slot k. */
static int batch_in_place(const move_ctx *c, uint32_t k)
{
    uint32_t t;
    for (t = 0; t < k; t++)
        if (!c->in_place[t])
            return 0;
    return 1;
}

/* 1 when a batch of n boxes may be a move of every object in slot order
 * with float boxes (the ids are checked in pass 1): the spare array's
 * case. */
static int every_slot_f32(const locd_scene *s, int f64, size_t n)
{
    return !f64 && !s->slots.keep_f64 && n == s->slots.nslots && s->slots.live == s->slots.nslots;
}

/* The spare box array for a move of every object in slot order, or NULL
 * (another batch; doubles kept; no memory: the move then writes the boxes
 * in its last pass, as any other). */
static float *spare_boxes(locd_scene *s, int f64, size_t n)
{
    if (!every_slot_f32(s, f64, n))
        return NULL;
    if (s->slots.fbox_spare_cap != s->slots.slot_cap) {
        lc_free(s->alloc, s->slots.fbox_spare, s->slots.fbox_spare_cap * 6 * sizeof(float));
        s->slots.fbox_spare = lc_alloc(s->alloc, s->slots.slot_cap * 6 * sizeof(float));
        s->slots.fbox_spare_cap = s->slots.fbox_spare ? s->slots.slot_cap : 0;
    }
    return s->slots.fbox_spare;
}

/* 1 when any thread's range failed the pass just run. */
static int any_bad(const move_ctx *c, uint32_t k)
{
    uint32_t t;
    for (t = 0; t < k; t++)
        if (c->bad[t])
            return 1;
    return 0;
}

/* The batch takes n stamps, so no later batch's stamp equals one of them. */
static void take_stamps(lc_slots *sl, move_ctx *c, size_t n)
{
    if ((uint64_t)sl->stamp_now + n >= UINT32_MAX) {
        memset(sl->stamp, 0, sl->slot_cap * sizeof *sl->stamp);
        sl->stamp_now = 0;
    }
    c->base = sl->stamp_now + 1;
    sl->stamp_now += (uint32_t)n;
}

/* The checks' passes: 1, then (ids that do not ascend) the stamps. When
 * the batch is bad, the serial checks name its first bad position. */
static locd_status check_batch(locd_scene *s, move_ctx *c, uint32_t k)
{
    locd_status st;
    c->pass = 1;
    lc_pool_run(s->pool, k, task_move, c);
    if (!any_bad(c, k) && !batch_ascends(c, k)) {
        c->pass = 4;
        lc_pool_run(s->pool, k, task_move, c);
        c->pass = 2;
        lc_pool_run(s->pool, k, task_move, c);
    }
    if (!any_bad(c, k))
        return LOCD_OK;
    st = lc_scene_check_batch(s, c->ids, c->boxes, c->f64, c->n);
    if (st == LOCD_OK) /* cannot happen: the passes and the checks test the same */
        st = lc_error(LOCD_ERR_INTERNAL, "the move's checks disagree");
    return st;
}

/* A batch of every slot in place: the spare array, which holds the boxes,
 * becomes the boxes; what pass 1 found is handed over to the next update. */
static void swap_in_spare(locd_scene *s, move_ctx *c, uint32_t k)
{
    float lo[3], hi[3];
    uint32_t t;
    int a, pre = c->pre;
    s->slots.fbox_spare = s->slots.fbox; /* the old boxes: the next such move's spare */
    s->slots.fbox = c->spare;
    c->swapped = 1;
    for (a = 0; a < 3; a++) { /* every box was read: their bounds */
        lo[a] = c->lo[0][a], hi[a] = c->hi[0][a];
        for (t = 1; t < k; t++) {
            lo[a] = c->lo[t][a] < lo[a] ? c->lo[t][a] : lo[a];
            hi[a] = c->hi[t][a] > hi[a] ? c->hi[t][a] : hi[a];
        }
    }
    for (t = 0; t < k && pre; t++)
        pre = c->pre_ok[t];
    lc_handover_close(s, lo, hi, pre);
}

static locd_status move_on_pool(locd_scene *s, const locd_id *ids, const void *boxes, int f64, size_t n)
{
    move_ctx c;
    uint32_t k = s->threads, t;
    size_t off;
    int64_t inexact = 0;
    locd_status st;
    if ((st = lc_scene_reserve_lists(s, n, 0)) != LOCD_OK)
        return st;
    memset(&c, 0, sizeof c);
    c.s = s, c.ids = ids, c.boxes = boxes, c.f64 = f64, c.n = n;
    take_stamps(&s->slots, &c, n);
    c.spare = spare_boxes(s, f64, n);
    c.pre = c.spare && lc_handover_open(s, n, k);
    if ((st = check_batch(s, &c, k)) != LOCD_OK)
        return st;
    if (f64 && (st = lc_scene_need_doubles(s, boxes, n)) != LOCD_OK)
        return st;
    for (t = 0, off = s->slots.ndirty; t < k; t++) {
        size_t f = c.fresh[t];
        c.fresh[t] = off;
        off += f;
    }
    if (c.spare && batch_in_place(&c, k))
        swap_in_spare(s, &c, k);
    c.pass = 3;
    lc_pool_run(s->pool, k, task_move, &c);
    for (t = 0; t < k; t++)
        inexact += c.inexact[t];
    s->slots.ninexact = (size_t)((int64_t)s->slots.ninexact + inexact);
    s->slots.ndirty = off;
    return LOCD_OK;
}

int lc_scene_move_parallel(locd_scene *s, const locd_id *ids, const void *boxes, int f64, size_t n,
                           locd_status *st)
{
    if (n < LC_PARALLEL_MIN || n >= UINT32_MAX || !ids || !boxes)
        return 0;
    /* One thread: the passes run on the caller's thread, which pays only
       for a move of every object in slot order (one read of the boxes that
       checks, copies and encodes them); the serial loop takes the rest. */
    if (s->threads < 2 && !every_slot_f32(s, f64, n))
        return 0;
    /* The pool is the engine's: while a call runs on the engine it has the
       pool, and the caller's thread moves the objects itself. */
    if (!lc_engine_acquire(s->engine))
        return 0;
    *st = move_on_pool(s, ids, boxes, f64, n);
    lc_engine_release(s->engine);
    return 1;
}
