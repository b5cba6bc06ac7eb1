/* Integration level 1: the whole pipeline in the caller's process, on a
 * fork-join pool of k threads. Each stage is split k ways: bounds, then
 * encode+sort of n/k objects per thread (the paper's slaves), then a merge
 * split by rank, then a sweep in slices by position that the threads take
 * in turn (task_sweep). The result does not depend
 * on k: runs hold contiguous object ranges, entries are unique, and each
 * sweep slice rebuilds the exact state a serial sweep would have. */
#include "levels/levels.h"

/* Below this many objects one thread beats waking the others. */
#define LC_PARALLEL_MIN_OBJECTS 4096
/* With a stop hook (engine.h, lc_stop: the service's runners) the sweep
 * runs in blocks of at least this many entries, at most LC_STOP_BLOCKS a
 * slice, and asks the hook between them. A block boundary moves forward to
 * the next cell start, as a thread's slice does, so the pairs and their
 * order are those of one sweep; each block rebuilds its ancestors' records,
 * hence the cap on their number (cancelling needs no block: the sweep
 * polls lc_stop.flag itself). */
#define LC_STOP_BLOCK ((size_t)1 << 15)
#define LC_STOP_BLOCKS 16
/* The sweep is cut into slices that the threads take in turn, each about
 * 1/(2k) of the entries left (at least LC_SLICE_MIN, and at least a
 * LC_MAX_SLICES / 2-th of all, which keeps the slices of 64 threads below
 * LC_MAX_SLICES; the last one possible takes the rest): large ones first,
 * smaller ones towards the end, so that a thread that falls behind (a
 * slower core of a hybrid CPU, a core another process takes, a virtual CPU
 * its host stops) leaves the rest to the others and no thread is left
 * with a large slice while the others wait. The pairs keep the order of
 * one serial sweep: each slice's go to their place in the result.
 * LC_SLICE_MIN is small enough that 10^4 boxes (about 17,000 entries) make
 * six slices, not three: 2 threads there took 0.88-0.97 of the time they
 * took with 8,192 (a slice's own cost, its ancestors' records rebuilt, is
 * a few searches); from 10^6 boxes the LC_MAX_SLICES bound decides. */
#define LC_SLICE_MIN ((size_t)1 << 11)
#define LC_MAX_SLICES 512
#define LC_SLICE_POS_BITS 40 /* the cursor: slices taken above, next entry below */

typedef struct lc_inproc {
    lc_pool *pool;
    lc_buf ent, scr; /* uint64 entries: thread regions, then merge output */
    lc_buf qbox;     /* 2 uint64 per object: packed sweep boxes (lc_pack_qbox), reused by the sweep */
    lc_sweep_out sw[LC_MAX_THREADS];
    double per_object; /* entries per object seen last time */
    int kernel;        /* LC_KERNEL_*, chosen when the engine is created */
    uint64_t qbox_epoch; /* finds and lc_inproc_qbox calls so far: qbox's writers (lc_inproc_qbox_epoch) */
} lc_inproc;

typedef struct lc_job_ctx {
    const locd_engine *e;
    lc_inproc *ip;
    const void *boxes;
    size_t n;
    size_t split; /* two-set query: first object of set b (0: one set) */
    int f64;
    double mark; /* lc_now_ms() when the last timed stage ended */
    locd_grid grid;
    lc_bounds bounds[LC_MAX_THREADS];
    lc_plan plan; /* thread t's share, entry region and sorted run */
    size_t need[LC_MAX_THREADS];
    int overflow[LC_MAX_THREADS];
    const uint64_t *sorted;
    const uint64_t *qbox; /* the packed boxes the sweep reads: ip->qbox's, or the caller's */
    locd_status status[LC_MAX_THREADS];
    uint64_t cursor;  /* slices taken << LC_SLICE_POS_BITS | next entry (atomic) */
    uint32_t nslices; /* taken, once the sweep is over */
    int failed;       /* a slice failed: the others stop taking slices (atomic) */
    struct {
        uint32_t thread;     /* the thread that swept it */
        size_t first, count; /* its pairs in that thread's buffer */
        size_t at;           /* and their place in the result */
    } slice[LC_MAX_SLICES];
    size_t npairs;
    uint32_t *dst;
    const lc_pair_sink *sink; /* NULL: the pairs are handed over */
    size_t sunk[LC_MAX_THREADS]; /* pairs each thread gave the sink */
    uint64_t swept; /* pairs found so far by all sweep threads (atomic; with a stop hook) */
    int stopped;    /* the stop hook's status (atomic), 0 while going on */
} lc_job_ctx;

static void task_bounds(void *arg, uint32_t t, uint32_t k)
{
    lc_job_ctx *c = arg;
    size_t b = lc_chunk_begin(c->n, t, k), e = lc_chunk_begin(c->n, t + 1, k);
    lc_bounds_init(&c->bounds[t]);
    if (c->f64)
        lc_bounds_f64(c->boxes, b, e, &c->bounds[t], c->ip->kernel);
    else
        lc_bounds_f32(c->boxes, b, e, &c->bounds[t], c->ip->kernel);
}

static void task_encode(void *arg, uint32_t t, uint32_t k)
{
    lc_job_ctx *c = arg;
    size_t b = lc_chunk_begin(c->n, t, k), e = lc_chunk_begin(c->n, t + 1, k), w;
    uint64_t *ent = (uint64_t *)c->ip->ent.data + c->plan.off[t];
    if (c->f64)
        w = lc_encode_f64(&c->grid, c->boxes, b, e - b, ent, c->plan.cap[t], &c->need[t], c->ip->qbox.data,
                          c->ip->kernel);
    else
        w = lc_encode_f32(&c->grid, c->boxes, b, e - b, ent, c->plan.cap[t], &c->need[t], c->ip->qbox.data,
                          c->ip->kernel);
    if (w == (size_t)-1) {
        c->overflow[t] = 1;
        return;
    }
    c->overflow[t] = 0;
    c->plan.cnt[t] = w;
}

static locd_status sweep_part(lc_job_ctx *c, size_t b, size_t e, lc_sweep_out *o)
{
    if (c->f64)
        return lc_sweep_range_f64(&c->grid, c->boxes, c->qbox, c->sorted, c->plan.total, b, e, o);
    return lc_sweep_range_f32(&c->grid, c->boxes, c->qbox, c->sorted, c->plan.total, b, e, o);
}

/* Asks the engine's stop hook (if any) with the pairs found so far; the
 * first thread told to stop records the status for the others. */
static int stop_requested(lc_job_ctx *c, uint64_t pairs)
{
    const lc_stop *s = &c->e->stop;
    int st = __atomic_load_n(&c->stopped, __ATOMIC_RELAXED);
    if (!st && s->flag && __atomic_load_n(s->flag, __ATOMIC_RELAXED))
        st = LOCD_ERR_CANCELLED;
    if (!st && s->check && (st = s->check(s->user, pairs)) != 0)
        __atomic_store_n(&c->stopped, st, __ATOMIC_RELAXED);
    return st;
}

/* The sweep of [b, e) on thread t in blocks of `step` entries (each end
 * moved forward to a cell start, as a slice's), asking the stop hook
 * between them. With a sink, each block's pairs go to it and are dropped
 * from o: they are handed over while in the caches. */
static locd_status sweep_blocks(lc_job_ctx *c, uint32_t t, size_t b, size_t e, size_t step, lc_sweep_out *o)
{
    size_t p, q;
    for (p = b; p < e; p = q) {
        const size_t before = o->count;
        size_t found;
        locd_status st;
        q = e - p > step ? p + step : e;
        if ((st = sweep_part(c, p, q, o)) != LOCD_OK)
            return st;
        found = o->count - before;
        if (c->sink) {
            st = found ? c->sink->fn(c->sink->arg, t, (uint32_t *)o->pairs.data + 2 * before, found) : LOCD_OK;
            c->sunk[t] += found;
            o->count = before;
            if (st != LOCD_OK)
                return st;
        }
        if (stop_requested(c, __atomic_add_fetch(&c->swept, (uint64_t)found, __ATOMIC_RELAXED)))
            return LOCD_OK; /* the caller sees c->stopped */
    }
    return LOCD_OK;
}

/* The block size of the stop hook's blocks over [b, e): at most
 * LC_STOP_BLOCKS of them, each at least LC_STOP_BLOCK entries. */
static size_t stop_step(size_t b, size_t e)
{
    const size_t step = (e - b) / LC_STOP_BLOCKS + 1;
    return step < LC_STOP_BLOCK ? LC_STOP_BLOCK : step;
}

/* Takes the next slice [*b, *e) of the entries for a pool of k threads,
 * its number in *s; 0 when none is left. */
static int take_slice(lc_job_ctx *c, uint32_t k, uint32_t *s, size_t *b, size_t *e)
{
    const uint64_t pos_mask = ((uint64_t)1 << LC_SLICE_POS_BITS) - 1;
    uint64_t cur = __atomic_load_n(&c->cursor, __ATOMIC_RELAXED), next;
    size_t pos, n;
    uint32_t idx;
    do {
        pos = (size_t)(cur & pos_mask), idx = (uint32_t)(cur >> LC_SLICE_POS_BITS);
        if (pos >= c->plan.total)
            return 0;
        n = (c->plan.total - pos) / (2 * (size_t)k);
        if (n < LC_SLICE_MIN)
            n = LC_SLICE_MIN;
        if (n < c->plan.total / (LC_MAX_SLICES / 2))
            n = c->plan.total / (LC_MAX_SLICES / 2);
        if (k == 1 || n > c->plan.total - pos || idx == LC_MAX_SLICES - 1) /* one thread, or the last slice: the rest */
            n = c->plan.total - pos;
        next = ((uint64_t)(idx + 1) << LC_SLICE_POS_BITS) | (uint64_t)(pos + n);
    } while (!__atomic_compare_exchange_n(&c->cursor, &cur, next, 0, __ATOMIC_RELAXED, __ATOMIC_RELAXED));
    *s = idx, *b = pos, *e = pos + n;
    return 1;
}

/* Thread t takes slices until none is left (or one failed, or the stop hook
 * said stop), appending each one's pairs to its buffer. */
static void task_sweep(void *arg, uint32_t t, uint32_t k)
{
    lc_job_ctx *c = arg;
    lc_sweep_out *o = &c->ip->sw[t];
    uint32_t s;
    size_t b, e;
    o->count = 0;
    o->candidates = o->exact_tests = 0;
    c->status[t] = LOCD_OK;
    while (!__atomic_load_n(&c->failed, __ATOMIC_RELAXED) && !__atomic_load_n(&c->stopped, __ATOMIC_RELAXED) &&
           take_slice(c, k, &s, &b, &e)) {
        const size_t before = o->count;
        const locd_status st = c->sink             ? sweep_blocks(c, t, b, e, LC_SINK_BLOCK, o)
                               : c->e->stop.check ? sweep_blocks(c, t, b, e, stop_step(b, e), o)
                                                  : sweep_part(c, b, e, o);
        c->slice[s].thread = t, c->slice[s].first = before, c->slice[s].count = o->count - before;
        if (st != LOCD_OK) {
            c->status[t] = st;
            __atomic_store_n(&c->failed, 1, __ATOMIC_RELAXED);
        }
    }
}

/* Task t copies the pairs of the result's positions [npairs t / k,
 * npairs (t + 1) / k), from the slices that hold them: an even share of
 * the copy whatever each thread found. */
static void task_gather(void *arg, uint32_t t, uint32_t k)
{
    lc_job_ctx *c = arg;
    const size_t lo = lc_chunk_begin(c->npairs, t, k), hi = lc_chunk_begin(c->npairs, t + 1, k);
    uint32_t s, *dst;
    size_t p;
    if (lo == hi)
        return; /* c->dst is NULL when no task found a pair: no pointer arithmetic on it */
    for (s = 0; s < c->nslices; s++) {
        const size_t a = c->slice[s].at > lo ? c->slice[s].at : lo,
                     e = c->slice[s].at + c->slice[s].count < hi ? c->slice[s].at + c->slice[s].count : hi;
        if (a >= e)
            continue;
        dst = c->dst + 2 * a;
        memcpy(dst, (const uint32_t *)c->ip->sw[c->slice[s].thread].pairs.data + 2 * (c->slice[s].first + (a - c->slice[s].at)),
               (e - a) * 2 * sizeof(uint32_t));
        if (c->split) /* two sets: the sweep wrote (i, split + j) */
            for (p = 0; p < e - a; p++)
                dst[2 * p + 1] -= (uint32_t)c->split;
    }
}

lc_pool *lc_inproc_pool(locd_engine *e, int *kernel)
{
    lc_inproc *ip = e->backend;
    *kernel = ip->kernel;
    return ip->pool;
}

uint64_t lc_inproc_qbox_epoch(const locd_engine *e)
{
    return ((const lc_inproc *)e->backend)->qbox_epoch;
}

uint64_t *lc_inproc_qbox(locd_engine *e, size_t n)
{
    lc_inproc *ip = e->backend;
    ip->qbox_epoch++; /* handed out to be written */
    return lc_buf_reserve(&e->alloc, &ip->qbox, 2 * sizeof(uint64_t), n ? n : 1) == LOCD_OK ? ip->qbox.data : NULL;
}

static locd_status inproc_open(locd_engine *e)
{
    lc_inproc *ip = lc_alloc(&e->alloc, sizeof *ip);
    uint32_t t;
    locd_status st;
    if (!ip)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the engine state");
    memset(ip, 0, sizeof *ip);
    if (e->threads > LC_MAX_THREADS)
        e->threads = LC_MAX_THREADS;
    ip->kernel = lc_kernel_choose();
    for (t = 0; t < LC_MAX_THREADS; t++)
        lc_sweep_out_init(&ip->sw[t], &e->alloc, ip->kernel);
    ip->per_object = lc_entries_per_object_guess(e->cfg.cell_bias);
    st = lc_pool_create(&e->alloc, e->threads, &ip->pool);
    if (st) {
        lc_free(&e->alloc, ip, sizeof *ip);
        return st;
    }
    e->backend = ip;
    return LOCD_OK;
}

static void inproc_close(locd_engine *e)
{
    lc_inproc *ip = e->backend;
    uint32_t t;
    if (!ip)
        return;
    lc_pool_destroy(ip->pool);
    for (t = 0; t < LC_MAX_THREADS; t++)
        lc_sweep_out_fini(&ip->sw[t]);
    lc_buf_release(&e->alloc, &ip->ent, sizeof(uint64_t));
    lc_buf_release(&e->alloc, &ip->scr, sizeof(uint64_t));
    lc_buf_release(&e->alloc, &ip->qbox, 2 * sizeof(uint64_t));
    lc_free(&e->alloc, ip, sizeof *ip);
    e->backend = NULL;
}

/* Milliseconds since the last stage ended; the next stage starts now. */
static double lap(lc_job_ctx *c)
{
    double t = lc_now_ms(), ms = t - c->mark;
    c->mark = t;
    return ms;
}

/* Fewer than two objects have no pair; one box is still validated. */
static locd_status find_tiny(const void *boxes, size_t n, int f64, int kernel, locd_pairs *out, locd_stats *stats)
{
    if (n == 1) {
        lc_bounds b1;
        lc_bounds_init(&b1);
        if (f64)
            lc_bounds_f64(boxes, 0, 1, &b1, kernel);
        else
            lc_bounds_f32(boxes, 0, 1, &b1, kernel);
        if (b1.bad >= 0)
            return lc_error_box(b1.bad_status, 0, "box 0");
    }
    out->count = 0;
    stats->threads = 1;
    return LOCD_OK;
}

/* Bounds (k ways, validating every box), then the grid and its depth. */
static locd_status fit_grid(lc_job_ctx *c, locd_stats *stats)
{
    const locd_engine *e = c->e;
    lc_bounds all;
    uint32_t t;
    locd_status st;
    lc_pool_run(c->ip->pool, c->plan.k, task_bounds, c);
    lc_bounds_init(&all);
    for (t = 0; t < c->plan.k; t++)
        lc_bounds_merge(&all, &c->bounds[t]);
    if (all.bad >= 0)
        return lc_error_box(all.bad_status, all.bad, "box %lld", (long long)all.bad);
    st = lc_grid_from_bounds(&all, c->n, e->cfg.max_depth, e->cfg.cell_bias, e->cfg.flags, &c->grid);
    if (st)
        return st;
    if (!e->cfg.max_depth) {
        if (c->f64)
            lc_grid_tune_depth_f64(&c->grid, c->boxes, c->n);
        else
            lc_grid_tune_depth_f32(&c->grid, c->boxes, c->n);
    }
    stats->depth = c->grid.depth;
    stats->ms_bounds = lap(c);
    return LOCD_OK;
}

/* Reserves the per-thread regions of the entry buffers (and the packed boxes). */
static locd_status layout(locd_engine *e, lc_job_ctx *c)
{
    size_t total = lc_plan_layout(&c->plan);
    locd_status st;
    if ((st = lc_buf_reserve(&e->alloc, &c->ip->qbox, 2 * sizeof(uint64_t), c->n)) != LOCD_OK)
        return st;
    if ((st = lc_buf_reserve(&e->alloc, &c->ip->ent, sizeof(uint64_t), total)) != LOCD_OK)
        return st;
    return lc_buf_reserve(&e->alloc, &c->ip->scr, sizeof(uint64_t), total);
}

/* Gives each overflowed region the exact size its thread asked for; 1 if any did. */
static int grow_overflowed(lc_job_ctx *c)
{
    int again = 0;
    uint32_t t;
    for (t = 0; t < c->plan.k; t++)
        if (c->overflow[t]) {
            c->plan.cap[t] = c->need[t];
            again = 1;
        }
    return again;
}

/* Each thread encodes its share into its region; regions are sized from
 * the last call's entries per object and redone with exact sizes if one
 * overflows. */
static locd_status encode(locd_engine *e, lc_job_ctx *c, locd_stats *stats)
{
    locd_status st;
    lc_plan_regions(&c->plan, c->n, c->ip->per_object);
    c->ip->qbox_epoch++;
    do {
        if ((st = layout(e, c)) != LOCD_OK)
            return st;
        lc_pool_run(c->ip->pool, c->plan.k, task_encode, c);
    } while (grow_overflowed(c));
    c->ip->per_object = lc_plan_finish(&c->plan, c->n);
    stats->entries = c->plan.total;
    stats->ms_encode = lap(c);
    return LOCD_OK;
}

/* The entries sorted: one thread's region in place (lc_radix_sort), more
 * threads' regions into scr on the pool (lc_psort, which has no merge
 * pass: ms_merge stays 0; the regions are its scratch). */
static locd_status sort_entries(locd_engine *e, lc_job_ctx *c, locd_stats *stats)
{
    lc_psort_in in;
    locd_status st = LOCD_OK;
    uint32_t t;
    if (c->plan.k == 1) {
        c->sorted = lc_radix_sort(c->ip->ent.data, c->ip->scr.data, c->plan.cnt[0], c->grid.index_bits);
        stats->ms_sort = lap(c);
        return st;
    }
    in.k = c->plan.k, in.index_bits = c->grid.index_bits, in.key_bits = LC_LEVEL_BITS + 3 * c->grid.depth;
    for (t = 0; t < c->plan.k; t++)
        in.run[t] = (uint64_t *)c->ip->ent.data + c->plan.off[t], in.count[t] = c->plan.cnt[t];
    st = lc_psort(c->ip->pool, &e->alloc, &in, c->ip->scr.data, c->ip->ent.data);
    c->sorted = c->ip->scr.data;
    stats->ms_sort = lap(c);
    return st;
}

/* The entry buffer the sweep does not read is dead until the next call:
 * each sweep thread writes its pairs to a slice of it first, so that only
 * the result needs memory of its own (8 bytes a pair). */
static void lend_dead_entries(lc_job_ctx *c)
{
    lc_inproc *ip = c->ip;
    uint64_t *dead = c->sorted == (const uint64_t *)ip->ent.data ? ip->scr.data : ip->ent.data;
    const size_t slice = (ip->ent.cap < ip->scr.cap ? ip->ent.cap : ip->scr.cap) / c->plan.k;
    uint32_t t;
    for (t = 0; t < c->plan.k; t++)
        lc_sweep_out_lend(&ip->sw[t], (uint32_t *)(dead + t * slice), 2 * slice);
}

/* Sweeps the merged entries in slices on k threads; *npairs gets the pairs
 * found, each slice's place in the result goes to c->slice[].at. */
static locd_status sweep(lc_job_ctx *c, locd_stats *stats, size_t *npairs)
{
    locd_status st = LOCD_OK;
    uint32_t t, s;
    lend_dead_entries(c);
    if (!c->qbox)
        c->qbox = c->ip->qbox.data;
    for (t = 0; t < c->plan.k; t++) {
        c->ip->sw[t].split = (uint32_t)c->split;
        c->ip->sw[t].stop = c->e->stop.flag;
    }
    c->cursor = 0;
    lc_pool_run(c->ip->pool, c->plan.k, task_sweep, c);
    c->nslices = (uint32_t)(c->cursor >> LC_SLICE_POS_BITS);
    for (t = 0; t < c->plan.k; t++) {
        const lc_sweep_out *o = &c->ip->sw[t];
        if (c->status[t] && !st)
            st = c->status[t];
        stats->candidates += o->candidates;
        stats->exact_tests += o->exact_tests;
    }
    *npairs = 0;
    for (s = 0; s < c->nslices; s++) {
        c->slice[s].at = *npairs;
        *npairs += c->slice[s].count;
    }
    return st;
}

/* Copies every slice's pairs into *out (k ways) and orders them if asked.
 * Everything that can fail happens before *out is touched. */
static locd_status hand_over(locd_engine *e, lc_job_ctx *c, uint32_t flags, size_t npairs, locd_pairs *out,
                             locd_stats *stats)
{
    uint64_t *order_tmp = NULL;
    size_t order_bytes = 0;
    locd_status st;
    if ((flags & LOCD_FIND_SORTED) && npairs > 1) {
        if (!lc_mul_size(npairs, sizeof(uint64_t), &order_bytes) ||
            !(order_tmp = lc_alloc(&e->alloc, order_bytes)))
            return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the buffer to sort %zu pairs", npairs);
    }
    if ((st = lc_pairs_reserve(out, npairs)) != LOCD_OK) {
        lc_free(&e->alloc, order_tmp, order_bytes);
        return st;
    }
    c->dst = out->data;
    c->npairs = npairs;
    lc_pool_run(c->ip->pool, c->plan.k, task_gather, c);
    out->count = npairs;
    stats->pairs = npairs;
    stats->ms_sweep = lap(c);
    if (order_tmp) {
        lc_sort_pair_array(out->data, npairs, order_tmp);
        stats->ms_order = lap(c);
        lc_free(&e->alloc, order_tmp, order_bytes);
    }
    return LOCD_OK;
}

static lc_job_ctx *new_job(locd_engine *e, const void *boxes, size_t n, size_t split, int f64)
{
    lc_job_ctx *c = lc_alloc(&e->alloc, sizeof *c);
    if (!c)
        return NULL;
    memset(c, 0, sizeof *c);
    c->e = e;
    c->ip = e->backend;
    c->boxes = boxes;
    c->n = n;
    c->split = split;
    c->f64 = f64;
    c->plan.k = n < LC_PARALLEL_MIN_OBJECTS ? 1 : e->threads;
    c->mark = lc_now_ms();
    return c;
}

/* Validates every box (k ways) where there is nothing to pair: one set of
 * a two-set query is empty. */
static locd_status validate_only(locd_engine *e, const void *boxes, size_t n, int f64, locd_pairs *out,
                                 locd_stats *stats)
{
    lc_job_ctx *c;
    lc_bounds all;
    uint32_t t;
    if (!(c = new_job(e, boxes, n, 0, f64)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the call state");
    lc_pool_run(c->ip->pool, c->plan.k, task_bounds, c);
    lc_bounds_init(&all);
    for (t = 0; t < c->plan.k; t++)
        lc_bounds_merge(&all, &c->bounds[t]);
    stats->threads = c->plan.k;
    lc_free(&e->alloc, c, sizeof *c);
    if (all.bad >= 0)
        return lc_error_box(all.bad_status, all.bad, "box %lld", (long long)all.bad);
    out->count = 0;
    return LOCD_OK;
}

/* Ends a call: its status (a stop or a cancel named), the sweep
 * buffers' loans and flags undone, its state freed. */
static locd_status end_job(locd_engine *e, lc_job_ctx *c, locd_status st)
{
    uint32_t t;
    if (st == LOCD_OK && c->stopped) /* *out is untouched: hand_over did not run */
        st = lc_error(c->stopped, "the find was stopped before it finished");
    else if (st == LOCD_ERR_CANCELLED) /* the sweep saw the stop flag (on a pool thread) */
        st = lc_error(st, "the find was stopped before it finished");
    for (t = 0; t < c->plan.k; t++) {
        lc_sweep_out_lend(&c->ip->sw[t], NULL, 0);
        c->ip->sw[t].split = 0;
        c->ip->sw[t].stop = NULL;
    }
    lc_free(&e->alloc, c, sizeof *c);
    return st;
}

/* One octree over all n objects; with split > 0 the sweep keeps only the
 * pairs across [0, split) and [split, n) (lc_sweep_out.split). */
static locd_status inproc_run(locd_engine *e, const void *boxes, size_t n, size_t split, int f64, uint32_t flags,
                              locd_pairs *out, locd_stats *stats)
{
    lc_job_ctx *c;
    locd_status st;
    size_t npairs = 0;

    stats->objects = n;
    if (n < 2)
        return find_tiny(boxes, n, f64, ((const lc_inproc *)e->backend)->kernel, out, stats);
    if (!(c = new_job(e, boxes, n, split, f64)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the call state");
    stats->threads = c->plan.k;
    if ((st = fit_grid(c, stats)) == LOCD_OK && !stop_requested(c, 0) && (st = encode(e, c, stats)) == LOCD_OK &&
        !stop_requested(c, 0) && (st = sort_entries(e, c, stats)) == LOCD_OK && !stop_requested(c, 0) &&
        (st = sweep(c, stats, &npairs)) == LOCD_OK && !stop_requested(c, npairs))
        st = hand_over(e, c, flags, npairs, out, stats);
    return end_job(e, c, st);
}

locd_status lc_inproc_sweep_sorted(locd_engine *e, const locd_grid *g, const float *boxes, const uint64_t *qbox,
                                   size_t n, const uint64_t *sorted, size_t total, const lc_pair_sink *sink,
                                   locd_pairs *out, locd_stats *stats)
{
    lc_job_ctx *c;
    locd_status st;
    size_t npairs = 0;
    stats->objects = n;
    if (!(c = new_job(e, boxes, n, 0, 0)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the call state");
    stats->threads = c->plan.k;
    stats->entries = total;
    stats->depth = g->depth;
    c->grid = *g;
    c->qbox = qbox; /* NULL: the engine's own (sweep) */
    c->sorted = sorted;
    c->plan.total = total;
    c->sink = sink;
    if ((st = sweep(c, stats, &npairs)) == LOCD_OK && !stop_requested(c, npairs)) {
        if (sink) {
            uint32_t t;
            for (t = 0; t < c->plan.k; t++)
                stats->pairs += c->sunk[t];
        } else {
            st = hand_over(e, c, 0, npairs, out, stats);
        }
    }
    return end_job(e, c, st);
}

static locd_status inproc_find(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags,
                               locd_pairs *out, locd_stats *stats)
{
    return inproc_run(e, boxes, n, 0, f64, flags, out, stats);
}

static locd_status inproc_find_between(locd_engine *e, const void *boxes, size_t n, size_t split, int f64,
                                       uint32_t flags, locd_pairs *out, locd_stats *stats)
{
    if (split == 0 || split >= n) {
        stats->objects = n;
        return n ? validate_only(e, boxes, n, f64, out, stats) : find_tiny(boxes, 0, f64, 0, out, stats);
    }
    return inproc_run(e, boxes, n, split, f64, flags, out, stats);
}

const lc_backend lc_inproc_backend = {"in-process", inproc_open, inproc_close, inproc_find, NULL,
                                      inproc_find_between};
