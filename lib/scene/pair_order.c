/* The pair order of a from-scratch update: the engine's pairs (i, j),
 * i < j, of objects in id order, filtered and ordered into rows of ids.
 *
 * Buckets of 2^shift consecutive i (a few hundred buckets, so each
 * thread's scatter writes a few hundred streams and each bucket's sort runs
 * in the cache), then within a bucket a counting sort on i and an insertion
 * sort of each i's few j. Pairs the filter drops are dropped first.
 *
 * The keys (i << 32 | j) reach their buckets one of two ways:
 * - from the engine's gathered pairs (lc_pair_order_rows): a count pass and a
 *   scatter pass, each split over the pool by pair ranges;
 * - from the sweep itself (lc_pair_order_open): the thread that swept a
 *   block counts its pairs by bucket, claims that many places in each
 *   bucket's region (one atomic add a bucket and block) and writes the
 *   keys there. The regions are sized from the previous order's counts; a
 *   region that fills up sends the rest to a spill area, and a spill area
 *   that fills up makes the caller sweep again and take the first way. No
 *   pass reads the pairs again: they are bucketed while the block is in
 *   the caches.
 * Either way the buckets' sort and the rows follow, split over the pool by
 * bucket ranges of about equal pairs. A bucket's keys arrive in any order
 * (the threads' interleaving); its sort makes the rows the same. */
#include "scene/scene.h"

/* The largest bucket count kept to size a region with (uint32 room). */
#define LC_ORDER_LAST_MAX ((size_t)1 << 30)

struct lc_pair_order {
    locd_scene *s;
    uint32_t *p;               /* the engine's pairs; filtered in place (gathered pairs only) */
    size_t np, n;
    const uint32_t *live;      /* slot of index i (lc_slot_at) */
    const locd_id *idl;        /* id of index i; NULL when it is (serial0 + i) << 32 | i */
    uint64_t serial0;
    int all;                   /* no pair is filtered out */
    uint32_t kk;               /* threads */
    uint32_t shift, nb;        /* bucket of i: i >> shift; nb buckets */
    size_t pb[LC_MAX_THREADS + 1], kept[LC_MAX_THREADS];
    size_t *cnt[LC_MAX_THREADS]; /* per thread: count then offset, per bucket */
    size_t *start;             /* nb + 1: first row of each bucket */
    uint32_t bb[LC_MAX_THREADS + 1]; /* the threads' bucket ranges for the sort */
    uint32_t *local[LC_MAX_THREADS]; /* per thread: 2^shift + 1 counters */
    uint64_t *key;             /* the keys by bucket: bucket b's at key + kst[b] */
    size_t *kst;               /* nb + 1 (gathered pairs: start itself) */
    uint64_t *run[LC_MAX_THREADS]; /* per thread: a bucket's keys by i (the largest bucket's room) */
    locd_id *rows;
    int pass;
    /* from the sweep (sink) only */
    int sink;
    uint32_t *cap;             /* nb: each region's room */
    size_t *cur;               /* nb: keys claimed in each region, spilled ones too (atomic) */
    uint64_t *spill, *spill_by; /* keys past their region's room, as they came and by bucket */
    size_t spill_cap, nspill;  /* nspill: claimed (atomic) */
    size_t *sst;               /* nb + 1: bucket b's spilled keys at spill_by + sst[b] */
    uint32_t *hist[LC_MAX_THREADS];  /* per thread: a block's count, then room left, per bucket */
    uint64_t **dst[LC_MAX_THREADS];  /* per thread: where the block's next key of each bucket goes,
                                        in its region then in the spill area */
    int full;                  /* the spill area overflowed (atomic) */
};

static void order_count(lc_pair_order *c, uint32_t t)
{
    size_t x, w = c->pb[t], *cnt = c->cnt[t];
    uint32_t *p = c->p;
    memset(cnt, 0, c->nb * sizeof *cnt);
    if (c->all) { /* every pair kept: counts only, no store of each pair back in place */
        for (x = c->pb[t]; x < c->pb[t + 1]; x++)
            cnt[p[2 * x] >> c->shift]++;
        c->kept[t] = c->pb[t + 1] - c->pb[t];
        return;
    }
    for (x = c->pb[t]; x < c->pb[t + 1]; x++) {
        uint32_t i = p[2 * x], j = p[2 * x + 1];
        if (!lc_slots_may_pair(&c->s->slots, lc_slot_at(c->live, i), lc_slot_at(c->live, j)))
            continue;
        p[2 * w] = i, p[2 * w + 1] = j, w++;
        cnt[i >> c->shift]++;
    }
    c->kept[t] = w - c->pb[t];
}

static void order_scatter(lc_pair_order *c, uint32_t t)
{
    /* in locals: the stores through key may alias c's fields, which the
       loop would then read again on every step */
    size_t x, *off = c->cnt[t];
    const size_t end = c->pb[t] + c->kept[t];
    const uint32_t *p = c->p, shift = c->shift;
    uint64_t *key = c->key;
    for (x = c->pb[t]; x < end; x++)
        key[off[p[2 * x] >> shift]++] = (uint64_t)p[2 * x] << 32 | p[2 * x + 1];
}

/* Sorts v[0, n): an object's partners, a few as a rule (insertion sort),
 * all the others for a box over the whole scene (lc_sort_u64: no
 * quadratic case). */
static void sort_run(uint64_t *v, size_t n)
{
    size_t x, y;
    if (n > 32) {
        lc_sort_u64(v, n);
        return;
    }
    for (x = 1; x < n; x++) {
        uint64_t e = v[x];
        for (y = x; y > 0 && v[y - 1] > e; y--)
            v[y] = v[y - 1];
        v[y] = e;
    }
}

/* An i's run longer than this is sorted on its own. */
#define LC_ORDER_RUN 32

/* Bucket b's keys in its region, and those it spilled (none for gathered
 * pairs). */
static void bucket_keys(const lc_pair_order *c, uint32_t b, const uint64_t **k1, size_t *m1, const uint64_t **k2,
                        size_t *m2)
{
    *k1 = c->key + c->kst[b];
    if (!c->sink) {
        *m1 = c->kst[b + 1] - c->kst[b], *k2 = NULL, *m2 = 0;
        return;
    }
    *m1 = c->cur[b] < c->cap[b] ? c->cur[b] : c->cap[b];
    *k2 = c->spill_by + c->sst[b], *m2 = c->sst[b + 1] - c->sst[b];
}

/* Bucket b's keys (k1, k2) into v by i: a counting sort; cnt[u] ends as
 * the end of i = base + u's run. */
static void keys_by_i(const uint64_t *k1, size_t m1, const uint64_t *k2, size_t m2, uint32_t base, uint32_t span,
                      uint32_t *cnt, uint64_t *v)
{
    size_t x;
    uint32_t u, sum = 0;
    memset(cnt, 0, (span + 1) * sizeof *cnt);
    for (x = 0; x < m1; x++)
        cnt[(uint32_t)(k1[x] >> 32) - base]++;
    for (x = 0; x < m2; x++)
        cnt[(uint32_t)(k2[x] >> 32) - base]++;
    for (u = 0; u < span; u++) {
        uint32_t n = cnt[u];
        cnt[u] = sum;
        sum += n;
    }
    for (x = 0; x < m1; x++)
        v[cnt[(uint32_t)(k1[x] >> 32) - base]++] = k1[x];
    for (x = 0; x < m2; x++)
        v[cnt[(uint32_t)(k2[x] >> 32) - base]++] = k2[x];
}

/* One compare-exchange pass, with no branch: it carries the largest key so
 * far and leaves each i's run with its largest j last, which sorts every
 * run of one or two keys (most runs: an object has about one partner of
 * higher index in a sparse scene). Keys of different i keep their order
 * (v is in i order). The insertion pass after then finds few keys out of
 * place; run alone, its test mispredicted on about half the keys of the
 * runs of two. */
static void largest_last(uint64_t *v, size_t m)
{
    uint64_t cur = v[0];
    size_t x;
    for (x = 1; x < m; x++) {
        const uint64_t e = v[x];
        v[x - 1] = cur < e ? cur : e;
        cur = cur < e ? e : cur;
    }
    v[m - 1] = cur;
}

/* Each i's run by j: v is in i order, so one insertion pass over the whole
 * bucket moves each key back within its own run only (a few places: an
 * object has a few partners), with one compare a key, well predicted after
 * largest_last; a walk over the 2^shift runs took a branch per i whatever
 * its run's length. A run longer than LC_ORDER_RUN (a box over much of the
 * scene) is sorted on its own (no quadratic case); cnt[u] is the end of
 * i = base + u's run. */
static void runs_by_j(uint64_t *v, size_t m, uint32_t base, const uint32_t *cnt)
{
    size_t x, y;
    for (x = 1; x < m; x++) {
        const uint64_t e = v[x];
        if (v[x - 1] <= e)
            continue;
        for (y = x; y > 0 && v[y - 1] > e && x - y < LC_ORDER_RUN; y--)
            v[y] = v[y - 1];
        v[y] = e;
        if (x - y == LC_ORDER_RUN && y > 0 && v[y - 1] > e) { /* a long run: sort all of it */
            const uint32_t i = (uint32_t)(e >> 32);
            size_t a = i - base ? cnt[i - base - 1] : 0, z = cnt[i - base];
            sort_run(v + a, z - a);
            x = z - 1;
        }
    }
}

/* The rows of sorted keys v[0, m). */
static void write_rows(const lc_pair_order *c, const uint64_t *v, size_t m, locd_id *rows)
{
    size_t x;
    if (!c->idl) { /* ids in arithmetic progression with the index */
        const uint64_t s0 = c->serial0;
        for (x = 0; x < m; x++) {
            const uint64_t i = v[x] >> 32, j = (uint32_t)v[x];
            rows[2 * x] = LC_ID_AFFINE(s0, i), rows[2 * x + 1] = LC_ID_AFFINE(s0, j);
        }
        return;
    }
    /* j's id is a cache miss each (j is anywhere): asked for ahead */
    for (x = 0; x < m; x++) {
        if (x + 16 < m)
            __builtin_prefetch(c->idl + (uint32_t)v[x + 16]);
        rows[2 * x] = c->idl[v[x] >> 32], rows[2 * x + 1] = c->idl[(uint32_t)v[x]];
    }
}

/* Bucket b: its keys to the thread's run buffer by i (counting sort), each
 * i's run sorted by j, then the rows at start[b]. The run buffer holds the
 * largest bucket: it stays in the caches from one bucket to the next, where
 * a buffer as long as the keys (one region per bucket) was written and read
 * back through memory. */
static void order_bucket(lc_pair_order *c, uint32_t t, uint32_t b)
{
    const size_t lo = c->start[b], m = c->start[b + 1] - lo;
    const uint32_t base = b << c->shift;
    size_t m1, m2;
    const uint64_t *k1, *k2;
    uint64_t *v = c->run[t];
    bucket_keys(c, b, &k1, &m1, &k2, &m2);
    if (m > 1) {
        keys_by_i(k1, m1, k2, m2, base, 1u << c->shift, c->local[t], v);
        largest_last(v, m);
        runs_by_j(v, m, base, c->local[t]);
    } else if (m) {
        v[0] = m1 ? k1[0] : k2[0];
    }
    write_rows(c, v, m, c->rows + 2 * lo);
}

static void task_order(void *arg, uint32_t t, uint32_t k)
{
    lc_pair_order *c = arg;
    uint32_t b;
    (void)k;
    if (c->pass == 1)
        order_count(c, t);
    else if (c->pass == 2)
        order_scatter(c, t);
    else
        for (b = c->bb[t]; b < c->bb[t + 1]; b++)
            order_bucket(c, t, b);
}

static void order_run(lc_pair_order *c, int pass)
{
    c->pass = pass;
    if (c->kk > 1)
        lc_pool_run(c->s->pool, c->kk, task_order, c);
    else
        task_order(c, 0, 1);
}

/* The buckets of n objects: at most 2^LC_ORDER_BUCKET_BITS, so that the
 * scatter's streams stay few enough for the caches (2,048 and 256 were
 * slower at 10^6 pairs). */
#define LC_ORDER_BUCKET_BITS 9
static void plan_buckets(lc_pair_order *c, size_t n)
{
    uint32_t bits = 0;
    while (bits < 32 && ((size_t)1 << bits) < n)
        bits++;
    c->shift = bits > LC_ORDER_BUCKET_BITS ? bits - LC_ORDER_BUCKET_BITS : 0;
    c->nb = (uint32_t)(((n ? n - 1 : 0) >> c->shift) + 1);
}

static lc_pair_order *order_new(locd_scene *s, size_t np, const uint32_t *live, const locd_id *idl, size_t n)
{
    lc_pair_order *c = lc_alloc(s->alloc, sizeof *c);
    if (!c)
        return NULL;
    memset(c, 0, sizeof *c);
    c->s = s, c->np = np, c->n = n, c->live = live, c->idl = idl;
    c->kk = s->threads > 1 && np > LC_PARALLEL_MIN ? s->threads : 1;
    plan_buckets(c, n);
    c->serial0 = n ? LC_ID_SERIAL(s->slots.id[lc_slot_at(live, 0)]) : 0;
    c->all = lc_slots_filter_passes_all(s, live, n);
    return c;
}

/* The buckets' sort and rows, once every bucket's keys are in (start[]
 * their rows, total of them): the rows go to out, and the counts are kept
 * to size the next order's regions. */
static locd_status order_rows(lc_pair_order *c, size_t total, lc_pair_list *out)
{
    locd_scene *s = c->s;
    const locd_allocator *a = s->alloc;
    size_t most = 1;
    uint32_t b, t;
    for (b = 0; b < c->nb; b++)
        if (c->start[b + 1] - c->start[b] > most)
            most = c->start[b + 1] - c->start[b];
    if (lc_buf_reserve(a, &s->order.runs, sizeof(uint64_t), c->kk * most) != LOCD_OK ||
        lc_pair_list_reserve(a, out, total ? total : 1) != LOCD_OK ||
        lc_buf_reserve(a, &s->order.last, sizeof(uint32_t), c->nb) != LOCD_OK)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the from-scratch pair order");
    for (t = 0; t < c->kk; t++)
        c->run[t] = (uint64_t *)s->order.runs.data + t * most;
    c->rows = out->rows.data;
    /* bucket ranges of about total / kk pairs each */
    c->bb[0] = 0;
    for (t = 1, b = 0; t < c->kk; t++) {
        while (b < c->nb && c->start[b] < total * t / c->kk)
            b++;
        c->bb[t] = b;
    }
    c->bb[c->kk] = c->nb;
    order_run(c, 3);
    out->count = total;
    s->order.last_n = c->n;
    for (b = 0; b < c->nb; b++) {
        const size_t m = c->start[b + 1] - c->start[b];
        if (m > LC_ORDER_LAST_MAX) /* no region that large: the next order takes the gathered pairs */
            s->order.last_n = 0;
        ((uint32_t *)s->order.last.data)[b] = (uint32_t)(m > LC_ORDER_LAST_MAX ? 0 : m);
    }
    return LOCD_OK;
}

locd_status lc_pair_order_rows(locd_scene *s, uint32_t *p, size_t np, const uint32_t *live, const locd_id *idl,
                           size_t n, lc_pair_list *out)
{
    const locd_allocator *a = s->alloc;
    lc_pair_order *c = order_new(s, np, live, idl, n);
    size_t scratch, total = 0;
    uint32_t t, b, kk;
    locd_status st = LOCD_OK;
    if (!c)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the from-scratch pair order");
    c->p = p;
    kk = c->kk;
    scratch = np * sizeof(uint64_t) + (kk + 1) * (c->nb + 1) * sizeof(size_t) +
              kk * (((size_t)1 << c->shift) + 1) * sizeof(uint32_t);
    if (lc_buf_reserve(a, &s->order.buf, 1, scratch) != LOCD_OK) {
        st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the from-scratch pair order");
        goto done;
    }
    c->key = s->order.buf.data;
    c->start = c->kst = (size_t *)(c->key + np);
    for (t = 0; t < kk; t++)
        c->cnt[t] = c->start + (c->nb + 1) * (t + 1);
    for (t = 0; t < kk; t++)
        c->local[t] = (uint32_t *)(c->start + (kk + 1) * (c->nb + 1)) + t * (((size_t)1 << c->shift) + 1);
    for (t = 0; t <= kk; t++)
        c->pb[t] = np * t / kk;
    order_run(c, 1);
    /* offsets: bucket-major, thread-minor */
    for (b = 0; b < c->nb; b++) {
        c->start[b] = total;
        for (t = 0; t < kk; t++) {
            size_t m = c->cnt[t][b];
            c->cnt[t][b] = total;
            total += m;
        }
    }
    c->start[c->nb] = total;
    order_run(c, 2);
    st = order_rows(c, total, out);
done:
    lc_free(a, c, sizeof *c);
    return st;
}

/* ---- keys from the sweep ---- */

/* A block's keys in buckets with room in their regions (claimed by
 * count): one pass over the pairs. */
static void scatter_block(const lc_pair_order *c, uint64_t **dst, const uint32_t *p, size_t m)
{
    const uint32_t shift = c->shift;
    size_t x;
    for (x = 0; x < m; x++) {
        const uint32_t i = p[2 * x];
        *dst[i >> shift]++ = (uint64_t)i << 32 | p[2 * x + 1];
    }
}

/* The same when some bucket's region is full: room[b] keys of bucket b
 * to its region, the others to its claimed part of the spill area. */
static void scatter_block_spill(const lc_pair_order *c, uint64_t **dst, uint64_t **sdst, uint32_t *room,
                                const uint32_t *p, size_t m)
{
    size_t x;
    for (x = 0; x < m; x++) {
        const uint32_t i = p[2 * x], b = i >> c->shift;
        const uint64_t k = (uint64_t)i << 32 | p[2 * x + 1];
        if (room[b])
            *dst[b]++ = k, room[b]--;
        else
            *sdst[b]++ = k;
    }
}

/* The sink: a block's pairs, filtered in place, counted by bucket; each
 * bucket's count claimed in its region at once, and the keys written
 * there. */
static locd_status order_sink(void *arg, uint32_t t, uint32_t *p, size_t np)
{
    lc_pair_order *c = arg;
    uint32_t *h = c->hist[t], *room = h + c->nb, b;
    int spill = 0;
    uint64_t **dst = c->dst[t], **sdst = dst + c->nb;
    const uint32_t shift = c->shift;
    size_t x, m = np;
    if (!c->all) {
        for (x = m = 0; x < np; x++) {
            const uint32_t i = p[2 * x], j = p[2 * x + 1];
            if (lc_slots_may_pair(&c->s->slots, lc_slot_at(c->live, i), lc_slot_at(c->live, j)))
                p[2 * m] = i, p[2 * m + 1] = j, m++;
        }
    }
    memset(h, 0, c->nb * sizeof *h);
    for (x = 0; x < m; x++)
        h[p[2 * x] >> shift]++;
    for (b = 0; b < c->nb; b++) {
        size_t at;
        uint32_t fits;
        if (!h[b])
            continue;
        at = __atomic_fetch_add(&c->cur[b], (size_t)h[b], __ATOMIC_RELAXED);
        fits = at >= c->cap[b] ? 0 : (uint32_t)(c->cap[b] - at < h[b] ? c->cap[b] - at : h[b]);
        dst[b] = c->key + c->kst[b] + at;
        room[b] = fits;
        if (fits < h[b]) { /* the rest to the spill area */
            const size_t more = h[b] - fits, sp = __atomic_fetch_add(&c->nspill, more, __ATOMIC_RELAXED);
            if (sp + more > c->spill_cap) { /* the sweep stops; lc_pair_order_overflowed says why */
                __atomic_store_n(&c->full, 1, __ATOMIC_RELAXED);
                return LOCD_ERR_BUFFER_TOO_SMALL;
            }
            sdst[b] = c->spill + sp;
            spill = 1;
        }
    }
    if (spill)
        scatter_block_spill(c, dst, sdst, room, p, m);
    else
        scatter_block(c, dst, p, m);
    return LOCD_OK;
}

/* A region's room for a bucket that had `last` pairs: 1/16 more, and 16. */
LC_INLINE uint32_t region_room(uint32_t last)
{
    return last + last / 16 + 16;
}

int lc_pair_order_can_sink(const locd_scene *s, size_t n)
{
    return s->order.last_n == n && n > 0;
}

locd_status lc_pair_order_open(locd_scene *s, size_t n, const locd_id *idl, lc_pair_order **out, lc_pair_sink *sink)
{
    const locd_allocator *a = s->alloc;
    const uint32_t *last = s->order.last.data;
    lc_pair_order *c;
    size_t region = 0, scratch, np_guess = 0;
    uint32_t b, t, kk;
    char *mem;
    *out = NULL;
    if (!(c = order_new(s, 0, NULL, idl, n)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the from-scratch pair order");
    for (b = 0; b < c->nb; b++)
        np_guess += last[b];
    /* the threads are the sweep's (the pool's), whatever the pair count */
    kk = c->kk = s->threads > 1 ? s->threads : 1;
    c->sink = 1;
    /* room: the last counts and 1/16 more, spilling up to 1/16 of them */
    for (b = 0; b < c->nb; b++)
        region += region_room(last[b]);
    c->spill_cap = np_guess / 16 + 4096;
    scratch = (region + 2 * c->spill_cap) * sizeof(uint64_t) + (4 * c->nb + 3) * sizeof(size_t) +
              kk * 2 * (size_t)c->nb * sizeof(uint64_t *) + c->nb * sizeof(uint32_t) +
              kk * 2 * (size_t)c->nb * sizeof(uint32_t) + kk * (((size_t)1 << c->shift) + 1) * sizeof(uint32_t);
    if (lc_buf_reserve(a, &s->order.buf, 1, scratch) != LOCD_OK) {
        lc_free(a, c, sizeof *c);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the from-scratch pair order");
    }
    /* the 8-byte parts first, then the 4-byte ones: each aligned */
    mem = s->order.buf.data;
    c->key = (uint64_t *)mem, mem += region * sizeof(uint64_t);
    c->spill = (uint64_t *)mem, mem += c->spill_cap * sizeof(uint64_t);
    c->spill_by = (uint64_t *)mem, mem += c->spill_cap * sizeof(uint64_t);
    c->start = (size_t *)mem, mem += (c->nb + 1) * sizeof(size_t);
    c->kst = (size_t *)mem, mem += (c->nb + 1) * sizeof(size_t);
    c->sst = (size_t *)mem, mem += (c->nb + 1) * sizeof(size_t);
    c->cur = (size_t *)mem, mem += c->nb * sizeof(size_t);
    for (t = 0; t < kk; t++)
        c->dst[t] = (uint64_t **)mem, mem += 2 * (size_t)c->nb * sizeof(uint64_t *);
    c->cap = (uint32_t *)mem, mem += c->nb * sizeof(uint32_t);
    for (t = 0; t < kk; t++)
        c->hist[t] = (uint32_t *)mem, mem += 2 * (size_t)c->nb * sizeof(uint32_t);
    for (t = 0; t < kk; t++)
        c->local[t] = (uint32_t *)mem, mem += (((size_t)1 << c->shift) + 1) * sizeof(uint32_t);
    c->kst[0] = 0;
    for (b = 0; b < c->nb; b++) {
        c->cap[b] = region_room(last[b]);
        c->cur[b] = 0;
        c->kst[b + 1] = c->kst[b] + c->cap[b];
    }
    *out = c;
    sink->fn = order_sink, sink->arg = c;
    return LOCD_OK;
}

int lc_pair_order_overflowed(const lc_pair_order *c)
{
    return __atomic_load_n(&c->full, __ATOMIC_RELAXED);
}

locd_status lc_pair_order_close(lc_pair_order *c, lc_pair_list *out, int *overflow)
{
    const locd_allocator *a = c->s->alloc;
    size_t total = 0, x;
    uint32_t b;
    locd_status st = LOCD_OK;
    if ((*overflow = c->full) != 0)
        goto done;
    /* the spilled keys by bucket (none as a rule) */
    memset(c->sst, 0, (c->nb + 1) * sizeof *c->sst);
    for (x = 0; x < c->nspill; x++)
        c->sst[(uint32_t)(c->spill[x] >> 32) >> c->shift]++;
    for (b = 0; b < c->nb; b++) {
        size_t m = c->sst[b];
        c->sst[b] = total;
        total += m;
    }
    c->sst[c->nb] = total;
    for (x = 0; x < c->nspill; x++)
        c->spill_by[c->sst[(uint32_t)(c->spill[x] >> 32) >> c->shift]++] = c->spill[x];
    for (b = c->nb; b > 0; b--)
        c->sst[b] = c->sst[b - 1];
    c->sst[0] = 0;
    /* each bucket's rows */
    total = 0;
    for (b = 0; b < c->nb; b++) {
        c->start[b] = total;
        total += (c->cur[b] < c->cap[b] ? c->cur[b] : c->cap[b]) + (c->sst[b + 1] - c->sst[b]);
    }
    c->start[c->nb] = total;
    st = order_rows(c, total, out);
done:
    lc_free(a, c, sizeof *c);
    return st;
}

void lc_pair_order_drop(lc_pair_order *c)
{
    if (c)
        lc_free(c->s->alloc, c, sizeof *c);
}

void lc_pair_order_memo_fini(const locd_allocator *a, lc_pair_order_memo *m)
{
    lc_buf_release(a, &m->buf, 1);
    lc_buf_release(a, &m->runs, sizeof(uint64_t));
    lc_buf_release(a, &m->last, sizeof(uint32_t));
    m->last_n = 0;
}
