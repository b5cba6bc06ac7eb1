/* The near-pair list: the pairs of a scene whose objects all move a little
 * every frame, without a sweep at every frame.
 *
 * When most objects move, an update finds its pairs from scratch
 * (from_scratch.c): a sweep of every box. Objects that move a little stay near
 * where they were, and so do their pairs. The near list holds, per object
 * i, every j > i whose *fat box* meets i's and that may pair with it (the
 * filter), each with a PAIRED bit (the pair is in the current set). A fat
 * box is the box grown on each side by an eighth of its largest edge (a
 * quarter to a sixteenth, after lists that served few or many updates:
 * path.c) when the list is built (the sweep of the fat boxes, then the pair
 * order). While every box stays inside its fat box, any two boxes that
 * meet have fat boxes that meet, so they are in the list: an update then
 * only tests the list's pairs on the boxes now, in order, and a changed
 * PAIRED bit is a created or a lost pair. A molecular-dynamics code calls
 * this a Verlet list with a skin.
 *
 * The pass is in the order of the rows (slots in id order), so the set,
 * created and lost come out sorted; it checks each object's box against
 * its fat box on the way, and a box outside makes the update build the
 * list again (or go from scratch: path.c decides). The test is the
 * float boxes' closed test, exact: every box is a float exactly here.
 *
 * Used when the slots are the engine's input as they are (every slot live,
 * in id order), every box is a float exactly, and only moves happened
 * since the list was built
 * (an add, remove or set_filter makes it unusable: lc_near_usable). */
#include "scene/scene.h"

/* How far ahead the pass loads a partner's box: a cache miss each (the
 * slots are in id order, not in space). */
#define LC_NEAR_AHEAD 16
/* How many objects a thread takes between two looks at whether another
 * thread found a box outside its fat box. */
#define LC_NEAR_POLL 1024

void lc_near_release(locd_scene *s)
{
    lc_near *nr = &s->near;
    lc_free(s->alloc, nr->fat, nr->n_cap * 6 * sizeof *nr->fat);
    lc_free(s->alloc, nr->off, (nr->n_cap + 1) * sizeof *nr->off);
    lc_free(s->alloc, nr->nb, nr->nb_cap * sizeof *nr->nb);
    memset(nr, 0, sizeof *nr);
}

/* ---- the fat boxes ---- */

typedef struct fat_ctx {
    float margin; /* of the largest edge, on each side */
    const float *box;
    float *fat;
    size_t n;
    int bad[LC_MAX_THREADS];
} fat_ctx;

static void task_fat(void *arg, uint32_t t, uint32_t k)
{
    fat_ctx *c = arg;
    size_t i = lc_chunk_begin(c->n, t, k), e = lc_chunk_begin(c->n, t + 1, k);
    int ok = 1;
    for (; i < e; i++) {
        const float *b = c->box + 6 * i;
        float *f = c->fat + 6 * i, m = b[3] - b[0];
        int a;
        m = b[4] - b[1] > m ? b[4] - b[1] : m;
        m = b[5] - b[2] > m ? b[5] - b[2] : m;
        m *= c->margin;
        /* m >= 0: a rounded b - m is at most b, b + m at least b */
        for (a = 0; a < 3; a++) {
            f[a] = b[a] - m;
            f[a + 3] = b[a + 3] + m;
            ok &= fabsf(f[a]) <= FLT_MAX && fabsf(f[a + 3]) <= FLT_MAX;
        }
    }
    c->bad[t] = !ok;
}

/* The pool's threads from LC_PARALLEL_MIN objects; below, one (a small
 * scene's pass takes microseconds, less than waking the pool). */
LC_INLINE uint32_t pool_parts(const locd_scene *s)
{
    return s->threads > 1 && s->slots.nslots >= LC_PARALLEL_MIN ? s->threads : 1;
}

static void run(locd_scene *s, uint32_t k, void (*fn)(void *, uint32_t, uint32_t), void *c)
{
    if (k > 1)
        lc_pool_run(s->pool, k, fn, c);
    else
        fn(c, 0, 1);
}

/* ---- the pass over the list ---- */

/* Where a pass writes. Each thread's rows go to a region sized from the
 * previous set's rows in its range (they change little from frame to
 * frame) plus a slack: thread 0 writes down from the end of its region,
 * thread 1 up from the same place, so their rows are one run; later
 * threads' are moved up to it. The events go to equal regions of their
 * buffers, written and moved together the same way. A region that fills
 * up stops that output's writes (the pass goes on: its PAIRED bits are
 * wanted); the rows
 * are then written again by a pass with room for every candidate, the
 * events found by the diff against the previous set (lc_pair_set_diff). The
 * buffers then keep their size from frame to frame: made larger, each
 * would be faulted in again in the first frames after a build, which is
 * dear on a virtual machine. */
typedef struct pass_ctx {
    locd_scene *s;
    int check;          /* a frame: boxes against fat boxes, and the events */
    const locd_id *idl; /* the ids by index; NULL: (serial0 + i) << 32 | i */
    uint64_t serial0;
    size_t ib[LC_MAX_THREADS + 1]; /* thread t takes objects [ib[t], ib[t + 1]) */
    int back;                      /* thread 0 writes backward, ending where thread 1 starts */
    locd_id *rows, *cr, *lo;
    size_t rbeg[LC_MAX_THREADS], rlim[LC_MAX_THREADS]; /* thread t's rows from rbeg up to rlim (thread 0
                                                          when back: from rbeg down to rlim) */
    size_t ebeg[LC_MAX_THREADS], elim[LC_MAX_THREADS]; /* its events, in cr and in lo */
    size_t nrow[LC_MAX_THREADS], ncr[LC_MAX_THREADS], nlo[LC_MAX_THREADS];
    int rfull[LC_MAX_THREADS], efull[LC_MAX_THREADS];
    int left; /* some box lies outside its fat box (atomic) */
} pass_ctx;

LC_INLINE locd_id near_id(const pass_ctx *c, size_t i)
{
    return c->idl ? c->idl[i] : LC_ID_AFFINE(c->serial0, i);
}

/* 1 when box b lies outside fat box f. */
LC_INLINE int outside(const float *b, const float *f)
{
    return (b[0] < f[0]) | (b[1] < f[1]) | (b[2] < f[2]) | (b[3] > f[3]) | (b[4] > f[4]) | (b[5] > f[5]);
}

/* A frame's check of object i: 1 when its box lies outside its fat box
 * (told to the other threads) or, every LC_NEAR_POLL objects, another
 * thread found one: the pass stops. */
LC_INLINE int stop_here(pass_ctx *c, const float *bi, const float *fat, size_t i)
{
    if (outside(bi, fat + 6 * i)) {
        __atomic_store_n(&c->left, 1, __ATOMIC_RELAXED);
        return 1;
    }
    return (i & (LC_NEAR_POLL - 1)) == 0 && __atomic_load_n(&c->left, __ATOMIC_RELAXED);
}

LC_INLINE void prefetch_partner(const pass_ctx *c, const float *fb, uint32_t e)
{
    const size_t j = e & LC_INDEX_BITS;
    __builtin_prefetch(fb + 6 * j);
    __builtin_prefetch(fb + 6 * j + 5);
    if (c->idl)
        __builtin_prefetch(c->idl + j);
}

/* A row (a, b) at p: forward (then p moves past it) or backward (p moves
 * down to it), unless p is at its limit: then *full is set. */
#define LC_PUT_FWD(p, lim, full, a, b) ((p) != (lim) ? ((p)[0] = (a), (p)[1] = (b), (p) += 2) : ((full) = 1, (p)))
#define LC_PUT_BACK(p, lim, full, a, b) ((p) != (lim) ? ((p) -= 2, (p)[0] = (a), (p)[1] = (b), (p)) : ((full) = 1, (p)))

/* A row (a, b) written at p when `hit`: with the room for it known, no
 * branch on whether the boxes meet (about half the candidates do, in no
 * order a predictor could learn): the row is written always, and p moves
 * past it (forward) or down to it (backward) only when it counts. */
#define LC_ROW_FWD(p, hit, a, b) ((p)[0] = (a), (p)[1] = (b), (p) += 2 * (size_t)(hit))
#define LC_ROW_BACK(p, hit, a, b) ((p)[-2] = (a), (p)[-1] = (b), (p) -= 2 * (size_t)(hit))
#define LC_ROW_CHECKED_FWD(p, hit, a, b) ((hit) ? LC_PUT_FWD(p, w_lim, rfull, a, b) : (p))
#define LC_ROW_CHECKED_BACK(p, hit, a, b) ((hit) ? LC_PUT_BACK(p, w_lim, rfull, a, b) : (p))

/* Candidate x of object i (box bi, id idi): its PAIRED bit set to whether
 * the boxes meet now; its row when they do (row: one of LC_ROW_*), and (a
 * frame) a created or a lost row when the bit changed. */
#define LC_NEAR_VISIT(put, row)                                                                                 \
    do {                                                                                                        \
        const uint32_t v = nb[x], j = v & LC_INDEX_BITS, was = v >> 31;                                          \
        const float *bj = fb + 6 * (size_t)j;                                                                   \
        const uint32_t hit = (uint32_t)((bi[0] <= bj[3]) & (bj[0] <= bi[3]) & (bi[1] <= bj[4]) &               \
                                        (bj[1] <= bi[4]) & (bi[2] <= bj[5]) & (bj[2] <= bi[5]));                \
        if (hit != was) {                                                                                       \
            nb[x] = j | hit << 31;                                                                              \
            if (c->check) {                                                                                     \
                if (hit)                                                                                        \
                    put(cr, cr_lim, efull, idi, near_id(c, j));                                                 \
                else                                                                                            \
                    put(lo, lo_lim, efull, idi, near_id(c, j));                                                 \
            }                                                                                                   \
        }                                                                                                       \
        row(w, hit, idi, near_id(c, j));                                                                        \
    } while (0)

static void task_pass(void *arg, uint32_t t, uint32_t k)
{
    pass_ctx *c = arg;
    lc_near *nr = &c->s->near;
    const float *fb = c->s->slots.fbox, *fat = nr->fat;
    const uint32_t *off = nr->off;
    uint32_t *nb = nr->nb;
    const size_t i0 = c->ib[t], i1 = c->ib[t + 1];
    locd_id *w = c->rows + 2 * c->rbeg[t], *const w_lim = c->rows + 2 * c->rlim[t], *const w0 = w;
    locd_id *cr = c->cr + 2 * c->ebeg[t], *const cr_lim = c->cr + 2 * c->elim[t], *const cr0 = cr;
    locd_id *lo = c->lo + 2 * c->ebeg[t], *const lo_lim = c->lo + 2 * c->elim[t], *const lo0 = lo;
    int rfull = 0, efull = 0;
    size_t i, x;
    (void)k;
    if (c->back && t == 0) {
        /* objects and partners in descending order, the rows written down */
        for (i = i1; i-- > i0;) {
            const float *bi = fb + 6 * i;
            const locd_id idi = near_id(c, i);
            const int room = (size_t)(w - w_lim) >= 2 * (size_t)(off[i + 1] - off[i]);
            if (c->check && stop_here(c, bi, fat, i))
                break;
            for (x = off[i + 1]; x-- > off[i];) {
                if (x >= off[i0] + LC_NEAR_AHEAD)
                    prefetch_partner(c, fb, nb[x - LC_NEAR_AHEAD]);
                if (room)
                    LC_NEAR_VISIT(LC_PUT_BACK, LC_ROW_BACK);
                else
                    LC_NEAR_VISIT(LC_PUT_BACK, LC_ROW_CHECKED_BACK);
            }
        }
    } else {
        const size_t xend = off[i1];
        for (i = i0; i < i1; i++) {
            const float *bi = fb + 6 * i;
            const locd_id idi = near_id(c, i);
            const int room = (size_t)(w_lim - w) >= 2 * (size_t)(off[i + 1] - off[i]);
            if (c->check && stop_here(c, bi, fat, i))
                break;
            for (x = off[i]; x < off[i + 1]; x++) {
                if (x + LC_NEAR_AHEAD < xend)
                    prefetch_partner(c, fb, nb[x + LC_NEAR_AHEAD]);
                if (room)
                    LC_NEAR_VISIT(LC_PUT_FWD, LC_ROW_FWD);
                else
                    LC_NEAR_VISIT(LC_PUT_FWD, LC_ROW_CHECKED_FWD);
            }
        }
    }
    c->nrow[t] = (size_t)(w > w0 ? w - w0 : w0 - w) / 2;
    c->ncr[t] = (size_t)(cr > cr0 ? cr - cr0 : cr0 - cr) / 2;
    c->nlo[t] = (size_t)(lo > lo0 ? lo - lo0 : lo0 - lo) / 2;
    c->rfull[t] = rfull;
    c->efull[t] = efull;
}

/* The rows' regions: room for est[t] rows in thread t's range (the
 * previous set's there, or every candidate's), plus a slack. Returns the
 * rows they need. */
static size_t plan_rows(pass_ctx *c, uint32_t k, const size_t *est)
{
    size_t t, end;
    const size_t r0 = est[0] + est[0] / 32 + 1024;
    if (!c->back) {
        c->rbeg[0] = 0, c->rlim[0] = r0;
        return r0;
    }
    c->rbeg[0] = r0, c->rlim[0] = 0;
    end = r0;
    for (t = 1; t < k; t++) {
        c->rbeg[t] = end;
        end += est[t] + est[t] / 32 + 1024;
        c->rlim[t] = end;
    }
    return end;
}

/* Closes up the threads' rows (or events: cnt) into one run: its first row
 * into *first, its length returned. */
static size_t close_up(uint32_t k, locd_id *buf, const size_t *beg, const size_t *cnt, int back, size_t *first)
{
    size_t total, t;
    if (back) {
        *first = beg[0] - cnt[0];
        total = cnt[0] + cnt[1];
        t = 2;
    } else {
        *first = beg[0];
        total = cnt[0];
        t = 1;
    }
    for (; t < k; t++) {
        memmove(buf + 2 * (*first + total), buf + 2 * beg[t], 2 * cnt[t] * sizeof *buf);
        total += cnt[t];
    }
    return total;
}

/* The pass's threads' object ranges (about equal candidates each) and
 * rows' regions, sized from the previous set's rows in each range. */
static size_t plan_pass(locd_scene *s, pass_ctx *c, uint32_t k)
{
    const lc_near *nr = &s->near;
    const locd_id *prev = lc_pair_list_rows(&s->set.pairs);
    size_t est[LC_MAX_THREADS], rr[LC_MAX_THREADS + 1];
    uint32_t t;
    for (t = 0; t <= k; t++) {
        c->ib[t] = t == k ? nr->n : lc_lower_bound_u32(nr->off, nr->n, (uint32_t)(nr->count * t / k));
        rr[t] = c->ib[t] == nr->n ? s->set.pairs.count /* (the last objects may have no candidates) */
                                  : lc_pair_rows_lower_bound(prev, s->set.pairs.count,
                                                             (uint64_t)LC_ID_SERIAL(s->slots.id[c->ib[t]]) << 32);
    }
    for (t = 0; t < k; t++)
        est[t] = rr[t + 1] - rr[t];
    return plan_rows(c, k, est);
}

/* A frame's event regions: equal shares of the smaller buffer's room (at
 * least 4096 rows a thread), thread 0 from its region's end down when the
 * rows go back. */
static locd_status plan_events(locd_scene *s, pass_ctx *c, uint32_t k, lc_pair_list *cr, lc_pair_list *lo)
{
    size_t ecap = cr->rows.cap < lo->rows.cap ? cr->rows.cap : lo->rows.cap;
    uint32_t t;
    locd_status st;
    ecap = ecap > 4096 * (size_t)k ? ecap : 4096 * (size_t)k;
    if ((st = lc_pair_list_reserve(s->alloc, cr, ecap)) != LOCD_OK ||
        (st = lc_pair_list_reserve(s->alloc, lo, ecap)) != LOCD_OK)
        return st;
    for (t = 0; t < k; t++)
        c->ebeg[t] = ecap * t / k, c->elim[t] = ecap * (t + 1) / k;
    if (c->back)
        c->ebeg[0] = c->elim[0], c->elim[0] = 0;
    return LOCD_OK;
}

/* More rows than the regions held: every object's rows again, with room
 * for every candidate (the PAIRED bits are right already). */
static locd_status pass_again(locd_scene *s, pass_ctx *c, uint32_t k, lc_pair_list *next)
{
    const lc_near *nr = &s->near;
    size_t est[LC_MAX_THREADS];
    uint32_t t;
    locd_status st;
    for (t = 0; t < k; t++)
        est[t] = nr->off[c->ib[t + 1]] - nr->off[c->ib[t]];
    if ((st = lc_pair_list_reserve(s->alloc, next, plan_rows(c, k, est))) != LOCD_OK)
        return st; /* (the caller drops the list) */
    c->rows = c->cr = c->lo = next->rows.data;
    c->check = 0;
    run(s, k, task_pass, c);
    return LOCD_OK;
}

/* Runs the pass into next (and, for a frame, cr and lo; *diff = 1 when
 * they did not fit: the caller diffs the sets). *left = 1 when a box lies
 * outside its fat box (a frame only): nothing is written, the PAIRED bits
 * are partly this frame's and the list is no longer valid. */
static locd_status pass(locd_scene *s, int check, lc_pair_list *next, lc_pair_list *cr, lc_pair_list *lo, int *left,
                        int *diff)
{
    const uint32_t k = pool_parts(s);
    pass_ctx c;
    uint32_t t;
    int full = 0;
    locd_status st;
    *left = *diff = 0;
    memset(&c, 0, sizeof c);
    c.s = s;
    c.check = check;
    c.idl = lc_slots_in_id_order(s) == 2 ? NULL : s->slots.id;
    c.serial0 = LC_ID_SERIAL(s->slots.id[0]);
    c.back = k > 1;
    if ((st = lc_pair_list_reserve(s->alloc, next, plan_pass(s, &c, k))) != LOCD_OK ||
        (check && (st = plan_events(s, &c, k, cr, lo)) != LOCD_OK))
        return st;
    c.rows = next->rows.data;
    c.cr = check ? cr->rows.data : c.rows; /* (a build writes no events) */
    c.lo = check ? lo->rows.data : c.rows;
    run(s, k, task_pass, &c);
    if (c.left) {
        s->near.valid = 0;
        *left = 1;
        return LOCD_OK;
    }
    for (t = 0; t < k; t++)
        full |= c.rfull[t], *diff |= c.efull[t];
    if (check && !*diff) {
        cr->count = close_up(k, cr->rows.data, c.ebeg, c.ncr, c.back, &cr->first);
        lo->count = close_up(k, lo->rows.data, c.ebeg, c.nlo, c.back, &lo->first);
    }
    if (full && (st = pass_again(s, &c, k, next)) != LOCD_OK)
        return st;
    next->count = close_up(k, next->rows.data, c.rbeg, c.nrow, c.back, &next->first);
    return LOCD_OK;
}

int lc_near_usable(const locd_scene *s)
{
    const lc_near *nr = &s->near;
    return nr->valid && s->slots.live == nr->n && s->slots.nslots == nr->n && s->slots.nremoved == 0 && s->slots.ninexact == 0 &&
           s->slots.order_known > 0 && s->slots.filter_known >= 0;
}

locd_status lc_near_frame(locd_scene *s, lc_pair_list *next, lc_pair_list *cr, lc_pair_list *lo, uint64_t *candidates, int *left,
                          int *diff)
{
    locd_status st = pass(s, 1, next, cr, lo, left, diff);
    if (st == LOCD_OK && !*left) {
        *candidates = s->near.count;
        s->near.served++;
    }
    return st;
}

/* Room for n objects and nc candidates. */
static locd_status near_room(locd_scene *s, size_t n, size_t nc)
{
    lc_near *nr = &s->near;
    if (n > nr->n_cap) {
        float *fat = lc_alloc(s->alloc, n * 6 * sizeof *fat);
        uint32_t *off = lc_alloc(s->alloc, (n + 1) * sizeof *off);
        if (!fat || !off) {
            lc_free(s->alloc, fat, n * 6 * sizeof *fat);
            lc_free(s->alloc, off, (n + 1) * sizeof *off);
            return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the near-pair list");
        }
        lc_free(s->alloc, nr->fat, nr->n_cap * 6 * sizeof *nr->fat);
        lc_free(s->alloc, nr->off, (nr->n_cap + 1) * sizeof *nr->off);
        nr->fat = fat, nr->off = off, nr->n_cap = n;
    }
    if (nc > nr->nb_cap) {
        const size_t cap = lc_grow_cap(nr->nb_cap, nc);
        uint32_t *nb = lc_alloc(s->alloc, cap * sizeof *nb);
        if (!nb)
            return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the near-pair list");
        lc_free(s->alloc, nr->nb, nr->nb_cap * sizeof *nr->nb);
        nr->nb = nb, nr->nb_cap = cap;
    }
    return LOCD_OK;
}

int lc_near_applies(locd_scene *s)
{
    return !(s->config_flags & LOCD_SCENE_NO_NEAR_LIST) && !s->slots.ninexact && lc_slots_in_id_order(s) > 0 &&
           s->slots.nslots < LC_INDEX_BITS;
}

/* The lists from the fat boxes' rows (sorted): thread t takes rows
 * [rb[t], rb[t + 1]), whole runs of one object, and writes their partners
 * and the offsets of the objects after the last object of the rows before
 * up to its own last. */
typedef struct csr_ctx {
    lc_near *nr;
    const locd_id *r;
    size_t count;
    size_t rb[LC_MAX_THREADS + 1];
} csr_ctx;

static void task_csr(void *arg, uint32_t t, uint32_t k)
{
    csr_ctx *c = arg;
    uint32_t *off = c->nr->off, *nb = c->nr->nb;
    const locd_id *r = c->r;
    const size_t b = c->rb[t], e = c->rb[t + 1];
    size_t x, cur = b ? (size_t)LC_ID_SLOT(r[2 * (b - 1)]) + 1 : 0; /* the first object not done before */
    for (x = b; x < e; x++) {
        const size_t i = LC_ID_SLOT(r[2 * x]);
        while (cur <= i)
            off[cur++] = (uint32_t)x;
        nb[x] = LC_ID_SLOT(r[2 * x + 1]);
    }
    if (t + 1 == k)
        while (cur <= c->nr->n)
            off[cur++] = (uint32_t)c->count;
}

static void make_lists(locd_scene *s, const lc_pair_list *rows)
{
    csr_ctx c;
    const uint32_t k = pool_parts(s);
    uint32_t t;
    c.nr = &s->near;
    c.r = lc_pair_list_rows(rows);
    c.count = rows->count;
    for (t = 0; t <= k; t++) {
        size_t x = c.count * t / k;
        /* to the start of a run (the rows of one object) */
        while (t && t < k && x > 0 && x < c.count && LC_ID_SLOT(c.r[2 * x]) == LC_ID_SLOT(c.r[2 * (x - 1)]))
            x++;
        c.rb[t] = t == k ? c.count : x;
    }
    for (t = 1; t <= k; t++) /* (a run longer than a share: a later bound may lie before an earlier one) */
        c.rb[t] = c.rb[t] < c.rb[t - 1] ? c.rb[t - 1] : c.rb[t];
    run(s, k, task_csr, &c);
}

locd_status lc_near_build(locd_scene *s, lc_pair_list *next, uint64_t *candidates, int *built)
{
    lc_near *nr = &s->near;
    const size_t n = s->slots.nslots;
    const int ordered = lc_slots_in_id_order(s);
    fat_ctx fc;
    locd_stats st_find;
    locd_status st;
    uint32_t t, k = pool_parts(s);
    int left, diff;
    nr->valid = 0;
    *built = 0;
    if ((st = near_room(s, n, 0)) != LOCD_OK)
        return st;
    memset(&fc, 0, sizeof fc);
    fc.box = s->slots.fbox, fc.fat = nr->fat, fc.n = n;
    fc.margin = 1.0f / (float)(1u << (LC_NEAR_SHIFT + s->backoff.near_narrow)); /* (path.c) */
    run(s, k, task_fat, &fc);
    for (t = 0; t < k; t++)
        if (fc.bad[t]) /* a fat box past the float range: the caller goes from scratch */
            return LOCD_OK;
    locd_stats_init(&st_find);
    if ((st = s->engine->ops->find(s->engine, nr->fat, n, 0, 0, &s->found, &st_find)) != LOCD_OK)
        return st;
    if (s->found.count > LC_INDEX_BITS) /* too many candidates for the list's indices */
        return LOCD_OK;
    /* The fat boxes' pairs filtered and sorted as rows, in next (the pass
       below reads the lists only, and writes the pair set there), then as
       the lists. */
    if ((st = lc_pair_order_rows(s, s->found.data, s->found.count, NULL, ordered == 2 ? NULL : s->slots.id, n,
                                   next)) != LOCD_OK ||
        (st = near_room(s, n, next->count + 1)) != LOCD_OK)
        return st;
    nr->n = n;
    nr->count = next->count;
    make_lists(s, next);
    next->count = next->first = 0;
    if ((st = pass(s, 0, next, NULL, NULL, &left, &diff)) != LOCD_OK)
        return st;
    nr->valid = 1;
    nr->served = 0;
    *built = 1;
    *candidates = st_find.pairs + nr->count;
    return LOCD_OK;
}

void lc_near_forget(locd_scene *s)
{
    s->near.valid = 0;
}
