/* Integration level 1: the whole pipeline in the caller's process, on a
 * fork-join pool of k threads. Each stage is split k ways: bounds, then
 * encode+sort of n/k objects per thread (the paper's slaves), then a merge
 * split by rank, then a sweep split by position. The result does not depend
 * on k: runs hold contiguous object ranges, entries are unique, and each
 * sweep slice rebuilds the exact state a serial sweep would have. */
#include "levels/levels.h"

#include <math.h>

#define LC_MAX_THREADS 64
/* Below this many objects one thread beats waking the others. */
#define LC_PARALLEL_MIN_OBJECTS 4096

typedef struct lc_inproc {
    lc_pool *pool;
    lc_buf ent, scr; /* uint64 entries: thread regions, then merge output */
    lc_buf qbox;     /* 2 uint64 per object: packed sweep boxes (lc_pack_qbox), reused by the sweep */
    lc_sweep_out sw[LC_MAX_THREADS];
    double per_object; /* entries per object seen last time */
    int kernel;        /* LC_KERNEL_*, chosen when the engine is created */
} lc_inproc;

typedef struct lc_job_ctx {
    const locd_engine *e;
    lc_inproc *ip;
    const void *boxes;
    size_t n;
    int f64;
    uint32_t k;
    locd_grid grid;
    lc_bounds bounds[LC_MAX_THREADS];
    size_t off[LC_MAX_THREADS], cap[LC_MAX_THREADS], cnt[LC_MAX_THREADS], need[LC_MAX_THREADS];
    int overflow[LC_MAX_THREADS];
    const uint64_t *runs[LC_MAX_THREADS];
    const uint64_t *sorted;
    size_t total;
    locd_status status[LC_MAX_THREADS];
    size_t pair_off[LC_MAX_THREADS];
    double ms_enc[LC_MAX_THREADS], ms_sort[LC_MAX_THREADS];
    uint32_t *dst;
} lc_job_ctx;

static size_t chunk_begin(size_t n, uint32_t t, uint32_t k)
{
    size_t q = n / k, r = n % k;
    return q * t + (t < r ? t : r);
}

static void task_bounds(void *arg, uint32_t t, uint32_t k)
{
    lc_job_ctx *c = arg;
    size_t b = chunk_begin(c->n, t, k), e = chunk_begin(c->n, t + 1, k);
    lc_bounds_init(&c->bounds[t]);
    if (c->f64)
        lc_bounds_f64(c->boxes, b, e, &c->bounds[t], c->ip->kernel);
    else
        lc_bounds_f32(c->boxes, b, e, &c->bounds[t], c->ip->kernel);
}

static void task_encode_sort(void *arg, uint32_t t, uint32_t k)
{
    lc_job_ctx *c = arg;
    size_t b = chunk_begin(c->n, t, k), e = chunk_begin(c->n, t + 1, k), w;
    uint64_t *ent = (uint64_t *)c->ip->ent.data + c->off[t];
    uint64_t *scr = (uint64_t *)c->ip->scr.data + c->off[t];
    uint64_t *res;
    double t0 = lc_now_ms(), t1;
    if (c->f64)
        w = lc_encode_f64(&c->grid, c->boxes, b, e - b, ent, c->cap[t], &c->need[t], c->ip->qbox.data, c->ip->kernel);
    else
        w = lc_encode_f32(&c->grid, c->boxes, b, e - b, ent, c->cap[t], &c->need[t], c->ip->qbox.data, c->ip->kernel);
    if (w == (size_t)-1) {
        c->overflow[t] = 1;
        return;
    }
    c->overflow[t] = 0;
    c->cnt[t] = w;
    t1 = lc_now_ms();
    res = lc_radix_sort(ent, scr, w, c->grid.index_bits);
    if (res != ent && k > 1)
        memcpy(ent, res, w * sizeof *ent); /* runs must sit in `ent`: the merge writes `scr` */
    c->runs[t] = k > 1 ? ent : res;
    c->ms_enc[t] = t1 - t0;
    c->ms_sort[t] = lc_now_ms() - t1;
}

static void task_merge(void *arg, uint32_t t, uint32_t k)
{
    lc_job_ctx *c = arg;
    size_t lo[LC_MAX_THREADS], hi[LC_MAX_THREADS];
    size_t r0 = chunk_begin(c->total, t, k), r1 = chunk_begin(c->total, t + 1, k);
    lc_merge_split(c->runs, c->cnt, k, r0, lo);
    lc_merge_split(c->runs, c->cnt, k, r1, hi);
    lc_merge_ranges(c->runs, lo, hi, k, (uint64_t *)c->ip->scr.data + r0);
}

static void task_sweep(void *arg, uint32_t t, uint32_t k)
{
    lc_job_ctx *c = arg;
    size_t b = chunk_begin(c->total, t, k), e = chunk_begin(c->total, t + 1, k);
    lc_sweep_out *o = &c->ip->sw[t];
    o->count = 0;
    o->candidates = o->exact_tests = 0;
    if (c->f64)
        c->status[t] = lc_sweep_range_f64(&c->grid, c->boxes, c->ip->qbox.data, c->sorted, c->total, b, e, o);
    else
        c->status[t] = lc_sweep_range_f32(&c->grid, c->boxes, c->ip->qbox.data, c->sorted, c->total, b, e, o);
}

static void task_gather(void *arg, uint32_t t, uint32_t k)
{
    lc_job_ctx *c = arg;
    const lc_sweep_out *o = &c->ip->sw[t];
    (void)k;
    if (o->count)
        memcpy(c->dst + 2 * c->pair_off[t], o->pairs.data, o->count * 2 * sizeof(uint32_t));
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
    /* A box at most 2^-bias of its cell crosses into the next cell on an
       axis with probability at most 2^-bias: (1 + 2^-bias)^3 entries per
       object on average, 1.95 for the default bias. Later calls use the
       last call's figure; an overflow is redone with exact sizes. */
    ip->per_object = pow(1.0 + ldexp(1.0, -e->cfg.cell_bias), 3) + 0.25;
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

/* Lays out per-thread regions of the entry buffers, `cap[t]` entries each. */
static locd_status layout(locd_engine *e, lc_job_ctx *c)
{
    size_t total = 0;
    uint32_t t;
    locd_status st;
    for (t = 0; t < c->k; t++) {
        c->off[t] = total;
        total += c->cap[t];
    }
    if ((st = lc_buf_reserve(&e->alloc, &c->ip->qbox, 2 * sizeof(uint64_t), c->n)) != LOCD_OK)
        return st;
    if ((st = lc_buf_reserve(&e->alloc, &c->ip->ent, sizeof(uint64_t), total)) != LOCD_OK)
        return st;
    return lc_buf_reserve(&e->alloc, &c->ip->scr, sizeof(uint64_t), total);
}

static locd_status inproc_find(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags,
                               locd_pairs *out, locd_stats *stats)
{
    lc_inproc *ip = e->backend;
    lc_job_ctx *c;
    lc_bounds all;
    locd_status st = LOCD_OK;
    double t0, t1;
    size_t npairs = 0, order_bytes = 0;
    uint64_t *order_tmp = NULL;
    uint32_t t, k;
    int retry;

    stats->objects = n;
    if (n < 2) {
        if (n == 1) { /* still validate the one box */
            lc_bounds b1;
            lc_bounds_init(&b1);
            if (f64)
                lc_bounds_f64(boxes, 0, 1, &b1, ip->kernel);
            else
                lc_bounds_f32(boxes, 0, 1, &b1, ip->kernel);
            if (b1.bad >= 0)
                return lc_error_box(b1.bad_status, 0, "box 0");
        }
        out->count = 0;
        stats->threads = 1;
        return LOCD_OK;
    }
    c = lc_alloc(&e->alloc, sizeof *c);
    if (!c)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the call state");
    memset(c, 0, sizeof *c);
    k = e->threads;
    if (n < LC_PARALLEL_MIN_OBJECTS)
        k = 1;
    c->e = e;
    c->ip = ip;
    c->boxes = boxes;
    c->n = n;
    c->f64 = f64;
    c->k = k;
    stats->threads = k;

    t0 = lc_now_ms();
    lc_pool_run(ip->pool, k, task_bounds, c);
    lc_bounds_init(&all);
    for (t = 0; t < k; t++)
        lc_bounds_merge(&all, &c->bounds[t]);
    if (all.bad >= 0) {
        st = lc_error_box(all.bad_status, all.bad, "box %lld", (long long)all.bad);
        goto done;
    }
    if ((st = lc_grid_from_bounds(&all, n, e->cfg.max_depth, e->cfg.cell_bias, e->cfg.flags, &c->grid)) != LOCD_OK)
        goto done;
    if (!e->cfg.max_depth) {
        if (f64)
            lc_grid_tune_depth_f64(&c->grid, boxes, n);
        else
            lc_grid_tune_depth_f32(&c->grid, boxes, n);
    }
    stats->depth = c->grid.depth;
    t1 = lc_now_ms();
    stats->ms_bounds = t1 - t0;

    /* Encode + sort; regions sized from the last call's entries per object,
       redone with exact sizes if a region overflows. */
    for (t = 0; t < k; t++) {
        size_t m = chunk_begin(n, t + 1, k) - chunk_begin(n, t, k);
        c->cap[t] = (size_t)((double)m * ip->per_object) + 64;
        if (c->cap[t] > m * LOCD_MAX_ENTRIES_PER_BOX)
            c->cap[t] = m * LOCD_MAX_ENTRIES_PER_BOX + 1;
    }
    for (retry = 0;; retry++) {
        if ((st = layout(e, c)) != LOCD_OK)
            goto done;
        lc_pool_run(ip->pool, k, task_encode_sort, c);
        {
            int again = 0;
            for (t = 0; t < k; t++)
                if (c->overflow[t]) {
                    c->cap[t] = c->need[t];
                    again = 1;
                }
            if (!again)
                break;
        }
    }
    c->total = 0;
    for (t = 0; t < k; t++)
        c->total += c->cnt[t];
    ip->per_object = (double)c->total / (double)n + 0.25;
    stats->entries = c->total;
    t0 = lc_now_ms();
    /* Encode and sort run back to back in each thread: split the wall time
       in the proportion of the slowest thread's two parts. */
    {
        double enc = 0, srt = 0;
        for (t = 0; t < k; t++)
            if (c->ms_enc[t] + c->ms_sort[t] > enc + srt) {
                enc = c->ms_enc[t];
                srt = c->ms_sort[t];
            }
        stats->ms_encode = (enc + srt) > 0 ? (t0 - t1) * enc / (enc + srt) : 0;
        stats->ms_sort = (t0 - t1) - stats->ms_encode;
    }

    if (k > 1) {
        lc_pool_run(ip->pool, k, task_merge, c);
        c->sorted = ip->scr.data;
    } else {
        c->sorted = c->runs[0];
    }
    t1 = lc_now_ms();
    stats->ms_merge = t1 - t0;

    /* The entry buffer the sweep does not read is dead until the next call:
       each sweep thread writes its pairs to a slice of it first, so that
       only the result needs memory of its own (8 bytes a pair). */
    {
        uint64_t *dead = c->sorted == (const uint64_t *)ip->ent.data ? ip->scr.data : ip->ent.data;
        const size_t slice = (ip->ent.cap < ip->scr.cap ? ip->ent.cap : ip->scr.cap) / k;
        for (t = 0; t < k; t++)
            lc_sweep_out_lend(&ip->sw[t], (uint32_t *)(dead + t * slice), 2 * slice);
    }
    lc_pool_run(ip->pool, k, task_sweep, c);
    for (t = 0; t < k; t++) {
        if (c->status[t] && !st)
            st = c->status[t];
        c->pair_off[t] = npairs;
        npairs += ip->sw[t].count;
        stats->candidates += ip->sw[t].candidates;
        stats->exact_tests += ip->sw[t].exact_tests;
    }
    if (st)
        goto done;
    /* Everything that can fail happens before `out` is touched. */
    if ((flags & LOCD_FIND_SORTED) && npairs > 1) {
        if (!lc_mul_size(npairs, 2 * sizeof(uint64_t), &order_bytes) ||
            !(order_tmp = lc_alloc(&e->alloc, order_bytes))) {
            st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the buffer to sort %zu pairs", npairs);
            goto done;
        }
    }
    if ((st = lc_pairs_reserve(out, npairs)) != LOCD_OK)
        goto done;
    c->dst = out->data;
    lc_pool_run(ip->pool, k, task_gather, c);
    out->count = npairs;
    stats->pairs = npairs;
    t0 = lc_now_ms();
    stats->ms_sweep = t0 - t1;
    if (order_tmp) {
        lc_sort_pair_array(out->data, npairs, order_tmp, order_tmp + npairs);
        stats->ms_order = lc_now_ms() - t0;
    }
done:
    for (t = 0; t < k; t++)
        lc_sweep_out_lend(&ip->sw[t], NULL, 0);
    if (order_tmp)
        lc_free(&e->alloc, order_tmp, order_bytes);
    lc_free(&e->alloc, c, sizeof *c);
    return st;
}

const lc_backend lc_inproc_backend = {"in-process", inproc_open, inproc_close, inproc_find, NULL};
