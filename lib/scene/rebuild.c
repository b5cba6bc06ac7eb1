/* The pairs of the live objects from scratch: the engine's own find over
 * their boxes, then the filter and the ids. */
#include "scene/scene.h"

/* Copies the live boxes' float copies into f, split over the pool. */
typedef struct floats_ctx {
    const locd_scene *s;
    const uint32_t *live;
    size_t n;
    float *f;
} floats_ctx;

static void task_floats(void *arg, uint32_t t, uint32_t k)
{
    floats_ctx *c = arg;
    size_t i = c->n * t / k, e = c->n * (t + 1) / k;
    for (; i < e; i++)
        memcpy(c->f + 6 * i, c->s->fbox + 6 * (size_t)c->live[i], 6 * sizeof(float));
}

static void gather_floats(const locd_scene *s, const uint32_t *live, size_t n, float *f)
{
    floats_ctx c;
    uint32_t k = s->threads > 1 && n > 65536 ? s->threads : 1;
    c.s = s, c.live = live, c.n = n, c.f = f;
    if (k > 1)
        lc_pool_run(s->pool, k, task_floats, &c);
    else
        task_floats(&c, 0, 1);
}

/* 1 when the slots [0, nslots) are all live and their serials ascend: then
 * slot order is id order and the slot arrays are the engine's input as
 * they are (the common case: no object removed). 2 when, besides, the
 * serials are consecutive: then the id of slot k is
 * (serial of slot 0 + k) << 32 | k, and the pair order writes its rows
 * without reading the ids (each a cache miss: a pair's j is anywhere). */
static int slots_in_id_order(locd_scene *s)
{
    size_t k;
    int affine = 1;
    if (s->order_known >= 0)
        return s->order_known;
    s->order_known = 0;
    if (s->live != s->nslots)
        return 0;
    for (k = 0; k < s->nslots; k++) {
        if (!(s->flags[k] & LC_SLOT_LIVE) || (k && LC_ID_SERIAL(s->id[k]) <= LC_ID_SERIAL(s->id[k - 1])))
            return 0;
        affine &= (uint64_t)LC_ID_SERIAL(s->id[k]) == (uint64_t)LC_ID_SERIAL(s->id[0]) + k;
    }
    return s->order_known = 1 + affine;
}

/* The slot of the engine's index i: live[i], or i itself when live is
 * NULL (the slots in id order). */
LC_INLINE uint32_t slot_of(const uint32_t *live, size_t i)
{
    return live ? live[i] : (uint32_t)i;
}

/* 1 when no two live objects can be filtered out: none static, no group,
 * and every category meets the AND of all masks. */
static int filter_passes_all(locd_scene *s, const uint32_t *live, size_t n)
{
    uint64_t m = ~(uint64_t)0;
    size_t k;
    if (s->filter_known >= 0)
        return s->filter_known;
    s->filter_known = 0;
    if (s->live_static)
        return 0;
    for (k = 0; k < n; k++) {
        m &= s->mask[slot_of(live, k)];
        if (s->group[slot_of(live, k)])
            return 0;
    }
    for (k = 0; k < n; k++)
        if (!(s->cat[slot_of(live, k)] & m))
            return 0;
    return s->filter_known = 1;
}

/* Ordering the engine's pairs (i, j), i < j, by (i, j): buckets of 2^shift
 * consecutive i (a few hundred buckets, so each thread's scatter writes a
 * few hundred streams and each bucket's sort runs in the cache), then
 * within a bucket a counting sort on i and an insertion sort of each i's
 * few j. Pairs the filter drops are dropped first. Each step is split over
 * the pool: pair ranges for the counts and the scatter, bucket ranges of
 * about equal pairs for the sort and the rows. */
typedef struct order_ctx {
    const locd_scene *s;
    uint32_t *p;               /* the engine's pairs; filtered in place */
    size_t np, n;
    const uint32_t *live;      /* slot of index i (slot_of) */
    const locd_id *idl;        /* id of index i; NULL when it is (serial0 + i) << 32 | i */
    uint64_t serial0;
    int all;                   /* no pair is filtered out */
    uint32_t shift, nb;        /* bucket of i: i >> shift; nb buckets */
    size_t pb[LC_MAX_THREADS + 1], kept[LC_MAX_THREADS];
    size_t *cnt[LC_MAX_THREADS]; /* per thread: count then offset, per bucket */
    size_t *start;             /* nb + 1: first pair of each bucket */
    uint32_t bb[LC_MAX_THREADS + 1]; /* the threads' bucket ranges for the sort */
    uint32_t *local[LC_MAX_THREADS]; /* per thread: 2^shift + 1 counters */
    uint64_t *key;             /* np: (i << 32 | j) by bucket */
    uint64_t *run[LC_MAX_THREADS]; /* per thread: a bucket's keys by i (the largest bucket's room) */
    locd_id *rows;
    int pass;
} order_ctx;

static void order_count(order_ctx *c, uint32_t t)
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
        if (!lc_scene_may_pair(c->s, slot_of(c->live, i), slot_of(c->live, j)))
            continue;
        p[2 * w] = i, p[2 * w + 1] = j, w++;
        cnt[i >> c->shift]++;
    }
    c->kept[t] = w - c->pb[t];
}

static void order_scatter(order_ctx *c, uint32_t t)
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

#define LC_ORDER_RUN 32

/* Bucket b: key[start[b], start[b+1]) to the thread's run buffer by i
 * (counting sort), each i's run sorted by j, then the rows at the same
 * positions. The run buffer holds the largest bucket: it stays in the
 * caches from one bucket to the next, where a buffer as long as the keys
 * (one region per bucket) was written and read back through memory. */
static void order_bucket(order_ctx *c, uint32_t t, uint32_t b)
{
    const size_t lo = c->start[b], m = c->start[b + 1] - lo;
    size_t x, y;
    uint32_t span = 1u << c->shift, base = b << c->shift, *cnt = c->local[t], u, sum = 0;
    const uint64_t *k = c->key + lo;
    uint64_t *v = c->run[t];
    locd_id *rows = c->rows + 2 * lo;
    if (m > 1) {
        memset(cnt, 0, (span + 1) * sizeof *cnt);
        for (x = 0; x < m; x++)
            cnt[(uint32_t)(k[x] >> 32) - base]++;
        for (u = 0; u < span; u++) {
            uint32_t n = cnt[u];
            cnt[u] = sum;
            sum += n;
        }
        for (x = 0; x < m; x++)
            v[cnt[(uint32_t)(k[x] >> 32) - base]++] = k[x];
        /* One compare-exchange pass first, with no branch: it carries the
           largest key so far and leaves each i's run with its largest j
           last, which sorts every run of one or two keys (most runs: an
           object has about one partner of higher index in a sparse
           scene). Keys of different i keep their order (v is in i order).
           The insertion pass below then finds few keys out of place; run
           alone, its test mispredicted on about half the keys of the runs
           of two. */
        {
            uint64_t cur = v[0];
            for (x = 1; x < m; x++) {
                const uint64_t e = v[x];
                v[x - 1] = cur < e ? cur : e;
                cur = cur < e ? e : cur;
            }
            v[m - 1] = cur;
        }
        /* Each i's run by j: v is in i order, so one insertion pass over
           the whole bucket moves each key back within its own run only
           (a few places: an object has a few partners), with one compare a
           key, well predicted after the pass above; a walk over the 2^shift
           runs took a branch per i whatever its run's length. A run longer than
           LC_ORDER_RUN (a box over much of the scene) is sorted on its own
           (no quadratic case). */
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
    } else if (m) {
        v[0] = k[0];
    }
    if (!c->idl) { /* ids in arithmetic progression with the index */
        const uint64_t s0 = c->serial0;
        for (x = 0; x < m; x++) {
            const uint64_t i = v[x] >> 32, j = (uint32_t)v[x];
            rows[2 * x] = (s0 + i) << 32 | i, rows[2 * x + 1] = (s0 + j) << 32 | j;
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

static void task_order(void *arg, uint32_t t, uint32_t k)
{
    order_ctx *c = arg;
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

static void order_run(lc_pool *pool, uint32_t kk, order_ctx *c, int pass)
{
    c->pass = pass;
    if (kk > 1)
        lc_pool_run(pool, kk, task_order, c);
    else
        task_order(c, 0, 1);
}

/* The pairs p[0, np) of the objects live[0, n) ordered into rows of ids;
 * returns the rows written (those the filter keeps). */
static locd_status order_pairs(locd_scene *s, uint32_t *p, size_t np, const uint32_t *live, const locd_id *idl,
                               size_t n, locd_id *rows, size_t *written)
{
    const locd_allocator *a = s->alloc;
    uint32_t kk = s->threads > 1 && np > 65536 ? s->threads : 1, t, b, bits = 0;
    order_ctx *c = lc_alloc(a, sizeof *c);
    size_t scratch, total = 0, w = 0, x, most = 1;
    void *mem;
    locd_status st = LOCD_OK;
    if (!c)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the rebuild's pair order");
    memset(c, 0, sizeof *c);
    while (bits < 32 && ((size_t)1 << bits) < n)
        bits++;
    /* at most 512 buckets: the scatter's streams stay few enough for the
       caches (2,048 and 256 were slower at 10^6 pairs: commit ebbfef4) */
    c->shift = bits > 9 ? bits - 9 : 0;
    c->nb = (uint32_t)(((n ? n - 1 : 0) >> c->shift) + 1);
    c->s = s, c->p = p, c->np = np, c->n = n, c->live = live, c->idl = idl, c->rows = rows;
    c->serial0 = n ? LC_ID_SERIAL(s->id[slot_of(live, 0)]) : 0;
    c->all = filter_passes_all(s, live, n);
    scratch = np * sizeof(uint64_t) + (kk + 1) * (c->nb + 1) * sizeof(size_t) +
              kk * (((size_t)1 << c->shift) + 1) * sizeof(uint32_t);
    if (lc_buf_reserve(a, &s->order_buf, 1, scratch) != LOCD_OK) {
        st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the rebuild's pair order");
        goto done;
    }
    mem = s->order_buf.data;
    c->key = mem;
    c->start = (size_t *)(c->key + np);
    for (t = 0; t < kk; t++)
        c->cnt[t] = c->start + (c->nb + 1) * (t + 1);
    for (t = 0; t < kk; t++)
        c->local[t] = (uint32_t *)(c->start + (kk + 1) * (c->nb + 1)) + t * (((size_t)1 << c->shift) + 1);
    for (t = 0; t <= kk; t++)
        c->pb[t] = np * t / kk;
    order_run(s->pool, kk, c, 1);
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
    for (b = 0; b < c->nb; b++)
        if (c->start[b + 1] - c->start[b] > most)
            most = c->start[b + 1] - c->start[b];
    if (lc_buf_reserve(a, &s->order_runs, sizeof(uint64_t), kk * most) != LOCD_OK) {
        st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the rebuild's pair order");
        goto done;
    }
    for (t = 0; t < kk; t++)
        c->run[t] = (uint64_t *)s->order_runs.data + t * most;
    order_run(s->pool, kk, c, 2);
    /* bucket ranges of about total / kk pairs each */
    c->bb[0] = 0;
    for (t = 1, b = 0; t < kk; t++) {
        while (b < c->nb && c->start[b] < total * t / kk)
            b++;
        c->bb[t] = b;
    }
    c->bb[kk] = c->nb;
    order_run(s->pool, kk, c, 3);
    for (x = 0; x < kk; x++)
        w += c->kept[x];
    *written = w;
done:
    lc_free(a, c, sizeof *c);
    return st;
}

/* The live objects' pairs from scratch: the engine's find on their boxes
 * laid out in id order, so that pairs ordered by (i, j) are rows in order. */
locd_status lc_scene_pairs_from_scratch(locd_scene *s, lc_plist *out, uint64_t *candidates)
{
    const locd_allocator *a = s->alloc;
    size_t n = 0, k, w = 0, cap = s->nslots ? s->nslots : 1, ncap = (size_t)s->serial + 1;
    const int ordered = slots_in_id_order(s);
    /* live: the slot of each index in id order; none when that is the index */
    uint32_t *live = ordered ? NULL : lc_alloc(a, cap * sizeof *live),
             *by_serial = ordered ? NULL : lc_alloc(a, ncap * sizeof *by_serial);
    locd_id *idl = ordered ? s->id : lc_alloc(a, cap * sizeof *idl);
    float *fboxes = ordered || s->ninexact ? NULL : lc_alloc(a, cap * 6 * sizeof *fboxes);
    double *boxes = NULL;
    const void *in;
    int f64 = 0;
    locd_pairs *found = &s->found;
    locd_stats st_find;
    locd_status st;
    if (!ordered && (!live || !by_serial || !idl || (!s->ninexact && !fboxes))) {
        st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's rebuild buffers");
        goto done;
    }
    /* the live slots in serial (= id) order */
    if (ordered) {
        n = s->nslots;
    } else {
        memset(by_serial, 0xff, ncap * sizeof *by_serial);
        for (k = 0; k < s->nslots; k++)
            if (s->flags[k] & LC_SLOT_LIVE)
                by_serial[LC_ID_SERIAL(s->id[k])] = (uint32_t)k;
        for (k = 0; k < ncap; k++)
            if (by_serial[k] != 0xffffffffu)
                idl[n] = s->id[by_serial[k]], live[n++] = by_serial[k];
    }
    /* The engine's float find is cheaper than its double one; it gives the
       same pairs when every box is a float exactly (boxes given through
       the f32 entry points always are): then the float copies are its
       input, as they are when the slots are in id order. */
    if (!s->ninexact) {
        in = ordered ? s->fbox : fboxes;
        if (!ordered)
            gather_floats(s, live, n, fboxes);
    } else if (ordered) {
        f64 = 1;
        in = s->box;
    } else {
        f64 = 1;
        boxes = lc_alloc(a, cap * 6 * sizeof *boxes);
        if (!boxes) {
            st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's rebuild buffers");
            goto done;
        }
        for (k = 0; k < n; k++)
            memcpy(boxes + 6 * k, s->box + 6 * (size_t)live[k], 6 * sizeof *boxes);
        in = boxes;
    }
    memset(&st_find, 0, sizeof st_find);
    st_find.size = sizeof st_find;
    if (ordered && !f64 && n >= LC_KEPT_MIN)
        st = lc_kept_find(s, n, found, &st_find);
    else
        st = s->engine->ops->find(s->engine, in, n, f64, 0, found, &st_find);
    if (st == LOCD_OK)
        st = lc_plist_reserve(a, out, found->count ? found->count : 1);
    if (st == LOCD_OK)
        st = order_pairs(s, found->data, found->count, live, ordered == 2 ? NULL : idl, n, out->rows.data, &w);
    if (st == LOCD_OK) {
        out->count = w;
        *candidates = found->count;
    }
done:
    if (!ordered) {
        lc_free(a, live, cap * sizeof *live);
        lc_free(a, idl, cap * sizeof *idl);
    }
    lc_free(a, by_serial, ncap * sizeof *by_serial);
    lc_free(a, fboxes, cap * 6 * sizeof *fboxes);
    lc_free(a, boxes, cap * 6 * sizeof *boxes);
    return st;
}

void lc_hot_fill(const locd_scene *s, size_t k, const uint64_t qbox[LC_QPAIR], lc_hot *h)
{
    h->qlo = qbox[2];
    h->qhi = qbox[3];
    h->pad = 0;
    h->cat = s->cat[k];
    h->mask = s->mask[k];
    h->group = s->group[k];
    h->slot = (uint32_t)k;
    h->id = s->id[k];
    h->flags = s->flags[k] & LC_SLOT_STATIC;
}

/* The parallel steps of a rebuild's lists: thread t takes slots
 * [b[t], b[t+1]), computes their cells and packed boxes and counts their
 * entries (pass 1), then writes its entries in its own region of each
 * list's run buffer (pass 2), in slot order. lc_psort sorts the regions
 * into the lists after. Pass 3 fills the records of dense indices
 * [b[t], b[t+1]) once they are numbered. */
typedef struct build_ctx {
    locd_scene *s;
    const locd_grid *g;
    lc_cells *cells;
    uint64_t *qb;
    size_t b[LC_MAX_THREADS + 1];
    size_t cnt[2][LC_MAX_THREADS], off[2][LC_MAX_THREADS];
    uint64_t *ent[2];
    const uint32_t *ord; /* pass 3: the slot of each dense index */
    lc_hot *hot;
    uint64_t *hq;
    int pass;
} build_ctx;

/* How far ahead the passes over slots in entry order (scattered) load
 * what they read: the numbering reads dense[slot], the records the slot
 * arrays. Taken one after another, on one thread, these misses made the
 * numbering most of a list build at 10^6 objects. */
#define LC_NUMBER_AHEAD 16

/* Pass 3: the records of dense indices [b, e) from their slots. */
static void fill_records(build_ctx *c, size_t b, size_t e)
{
    const locd_scene *s = c->s;
    size_t d;
    for (d = b; d < e; d++) {
        const uint32_t slot = c->ord[d];
        if (d + LC_NUMBER_AHEAD < e) {
            const uint32_t a = c->ord[d + LC_NUMBER_AHEAD];
            __builtin_prefetch(s->cat + a);
            __builtin_prefetch(s->mask + a);
            __builtin_prefetch(s->group + a);
            __builtin_prefetch(s->id + a);
            __builtin_prefetch(s->flags + a);
            __builtin_prefetch(c->qb + LC_QPAIR * (size_t)a);
        }
        lc_hot_fill(s, slot, c->qb + LC_QPAIR * (size_t)slot, &c->hot[d]);
        memcpy(c->hq + LC_HQ * d, c->qb + LC_QPAIR * (size_t)slot, LC_HQ * sizeof *c->hq);
    }
}

static void task_build(void *arg, uint32_t t, uint32_t k)
{
    build_ctx *c = arg;
    const locd_scene *s = c->s;
    size_t j;
    (void)k;
    if (c->pass == 3) {
        fill_records(c, c->b[t], c->b[t + 1]);
        return;
    }
    if (c->pass == 1) {
        size_t n[2] = {0, 0};
        for (j = c->b[t]; j < c->b[t + 1]; j++) {
            const lc_cells *cl = &c->cells[j];
            if (!(s->flags[j] & LC_SLOT_LIVE))
                continue;
            double tmp[6];
            lc_cells_of(c->g, lc_scene_box(s, j, tmp), &c->cells[j], c->qb + LC_QPAIR * j);
            n[(s->flags[j] & LC_SLOT_STATIC) ? 1 : 0] +=
                (1u + (cl->span & 1u)) * (1u + ((cl->span >> 1) & 1u)) * (1u + ((cl->span >> 2) & 1u));
        }
        c->cnt[0][t] = n[0], c->cnt[1][t] = n[1];
        return;
    }
    {
        size_t w[2] = {0, 0};
        for (j = c->b[t]; j < c->b[t + 1]; j++) {
            int kind;
            if (!(s->flags[j] & LC_SLOT_LIVE))
                continue;
            kind = (s->flags[j] & LC_SLOT_STATIC) ? 1 : 0;
            w[kind] += lc_cells_entries(c->g, &c->cells[j], (uint32_t)j, c->ent[kind] + c->off[kind][t] + w[kind]);
        }
    }
}

/* Every live object's cells, dense index and record, and the two entry
 * lists sorted by key (rebuild). */
locd_status lc_scene_build_trees(locd_scene *s, const locd_grid *g, lc_cells *cells, uint32_t *dense, lc_hot *hot,
                                 uint64_t *hq, size_t *ndense, lc_tree *dyn, lc_tree *sta)
{
    const locd_allocator *a = s->alloc;
    const uint64_t imask = ((uint64_t)1 << g->index_bits) - 1;
    size_t k, nk, n[2] = {0, 0}, qcap = LC_QPAIR * (s->nslots ? s->nslots : 1), next = 0, j;
    uint64_t *qb = lc_alloc(a, qcap * sizeof *qb), *scr = NULL;
    uint32_t *ord;
    build_ctx *c = lc_alloc(a, sizeof *c);
    lc_tree *ts[2];
    uint32_t kk = s->threads ? s->threads : 1, t;
    int i;
    memset(dyn, 0, sizeof *dyn);
    memset(sta, 0, sizeof *sta);
    if (!qb || !c)
        goto nomem;
    memset(c, 0, sizeof *c);
    if (s->nslots < 16384)
        kk = 1;
    c->s = s, c->g = g, c->cells = cells, c->qb = qb;
    for (t = 0; t <= kk; t++)
        c->b[t] = s->nslots * t / kk;
    c->pass = 1;
    if (kk > 1)
        lc_pool_run(s->pool, kk, task_build, c);
    else
        task_build(c, 0, 1);
    for (i = 0; i < 2; i++)
        for (t = 0; t < kk; t++) {
            c->off[i][t] = n[i];
            n[i] += c->cnt[i][t];
        }
    nk = n[0] + n[1];
    if (!(scr = lc_alloc(a, (nk ? nk : 1) * sizeof *scr)) ||
        lc_buf_reserve(a, &dyn->ent, sizeof(uint64_t), n[0] ? n[0] : 1) != LOCD_OK ||
        lc_buf_reserve(a, &sta->ent, sizeof(uint64_t), n[1] ? n[1] : 1) != LOCD_OK)
        goto nomem;
    ts[0] = dyn, ts[1] = sta;
    /* Each thread writes its entries into its region of scr (dyn's part,
       then sta's), in slot order: equal keys in index order, as lc_psort
       wants. The regions are its scratch. */
    c->ent[0] = scr, c->ent[1] = scr + n[0];
    c->pass = 2;
    if (kk > 1)
        lc_pool_run(s->pool, kk, task_build, c);
    else
        task_build(c, 0, 1);
    for (i = 0; i < 2; i++) {
        lc_psort_in in;
        in.k = kk, in.index_bits = g->index_bits, in.key_bits = LC_LEVEL_BITS + 3 * g->depth;
        for (t = 0; t < kk; t++)
            in.run[t] = c->ent[i] + c->off[i][t], in.count[t] = c->cnt[i][t];
        if (lc_psort(s->pool, a, &in, ts[i]->ent.data, c->ent[i]) != LOCD_OK)
            goto nomem;
        ts[i]->count = n[i];
    }
    /* Number the objects in entry order and put the numbers in the entries
       (ord: the slot of each number; scr is free again). Keys stay sorted;
       within one key the order may change, which nothing relies on
       (tree.c). Then the records, split over the pool. */
    for (k = 0; k < s->nslots; k++)
        dense[k] = UINT32_MAX;
    ord = (uint32_t *)scr;
    for (i = 0; i < 2; i++) {
        uint64_t *e = ts[i]->ent.data;
        const size_t cnt = ts[i]->count;
        for (j = 0; j < cnt; j++) {
            uint32_t slot = (uint32_t)(e[j] & imask);
            if (j + LC_NUMBER_AHEAD < cnt)
                __builtin_prefetch(dense + (e[j + LC_NUMBER_AHEAD] & imask), 1);
            if (dense[slot] == UINT32_MAX) {
                ord[next] = slot;
                dense[slot] = (uint32_t)next++;
            }
            e[j] = (e[j] & ~imask) | dense[slot];
        }
        lc_tree_count_levels(g, ts[i]);
        lc_tree_build_dir(a, g, ts[i]);
    }
    c->ord = ord, c->hot = hot, c->hq = hq;
    kk = next < 16384 ? 1 : (s->threads ? s->threads : 1);
    for (t = 0; t <= kk; t++)
        c->b[t] = next * t / kk;
    c->pass = 3;
    if (kk > 1)
        lc_pool_run(s->pool, kk, task_build, c);
    else
        task_build(c, 0, 1);
    *ndense = next;
    lc_free(a, qb, qcap * sizeof *qb);
    lc_free(a, scr, (nk ? nk : 1) * sizeof *scr);
    lc_free(a, c, sizeof *c);
    return LOCD_OK;
nomem:
    lc_free(a, qb, qcap * sizeof *qb);
    if (c)
        lc_free(a, scr, (n[0] + n[1] ? n[0] + n[1] : 1) * sizeof *scr);
    lc_free(a, c, sizeof *c);
    lc_tree_release(a, dyn);
    lc_tree_release(a, sta);
    return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's entry lists");
}
