/* The carry pass of an incremental update: the rows of the previous set
 * whose ends both stayed unchanged are kept, merged with the moved objects'
 * new rows into the new set; the others are the dropped rows (the events
 * are new rows minus dropped ones and the reverse). At 10^6 pairs it reads
 * and writes 16 MB, the largest part of a frame where 1% of the objects
 * moved (docs/scene.md).
 *
 * Split over the pool: thread t takes rows [pb[t], pb[t+1]) of the previous
 * set and the new rows whose keys fall in its key range, counts (pass 1)
 * then writes (pass 2) its kept rows merged with those new rows, and its
 * dropped rows, at offsets the counts give. On two threads one pass does
 * it (task_carry2).
 *
 * The pass is bound by memory: at 10^6 pairs on 2 threads it takes about
 * what copying the 16 MB takes when they are not in the caches. A version
 * that tested 4 or 8 rows at a time (AVX2, AVX-512 gathers of the bitmap)
 * and copied clean blocks whole was no faster. */
#include "scene/scene.h"

typedef struct carry_ctx {
    const uint64_t *changed; /* bitmap of changed slots */
    const locd_id *p;        /* previous rows */
    const locd_id *n;        /* new rows */
    size_t pb[LC_MAX_THREADS + 1], nb[LC_MAX_THREADS + 1]; /* row ranges */
    size_t ndrop[LC_MAX_THREADS], out_off[LC_MAX_THREADS], drop_off[LC_MAX_THREADS];
    locd_id *out, *drop;
    size_t out_end[LC_MAX_THREADS], drop_end[LC_MAX_THREADS]; /* pass 2: where each thread's rows end */
    int pass; /* 1: count the dropped rows; 2: write; 3: two threads, no count (task_carry2) */
} carry_ctx;

LC_INLINE int row_changed(const uint64_t *bits, const locd_id *r)
{
    uint32_t a = LC_ID_SLOT(r[0]), b = LC_ID_SLOT(r[1]);
    return (int)(((bits[a >> 6] >> (a & 63)) | (bits[b >> 6] >> (b & 63))) & 1u);
}

/* The loops below keep everything in locals (restrict pointers, the next
 * new row's key): through the context, each row reloaded the pointers and
 * bounds after every store, as they may alias. */
LC_INLINE uint64_t next_key(const locd_id *n, size_t j, size_t end)
{
    return j < end ? lc_pair_key(n + 2 * j) : UINT64_MAX; /* above every key: first < second */
}

/* Pass 2 (and thread 1 of task_carry2): rows [i, pe) forward. */
static void carry_forward(carry_ctx *c, uint32_t t)
{
    const uint64_t *restrict bits = c->changed;
    const locd_id *restrict p = c->p, *restrict n = c->n;
    locd_id *restrict out = c->out, *restrict drop = c->drop;
    const size_t pe = c->pb[t + 1], ne = c->nb[t + 1];
    size_t i, j = c->nb[t], w = c->out_off[t], dw = c->drop_off[t];
    uint64_t nkey = next_key(n, j, ne);
    for (i = c->pb[t]; i < pe; i++) {
        const locd_id r0 = p[2 * i], r1 = p[2 * i + 1];
        uint64_t key;
        if (row_changed(bits, p + 2 * i)) {
            drop[2 * dw] = r0, drop[2 * dw + 1] = r1, dw++;
            continue;
        }
        key = lc_pair_key(p + 2 * i);
        while (nkey < key) {
            out[2 * w] = n[2 * j], out[2 * w + 1] = n[2 * j + 1], w++, j++;
            nkey = next_key(n, j, ne);
        }
        out[2 * w] = r0, out[2 * w + 1] = r1, w++;
    }
    for (; j < ne; j++)
        out[2 * w] = n[2 * j], out[2 * w + 1] = n[2 * j + 1], w++;
    c->out_end[t] = w, c->drop_end[t] = dw;
}

static void task_carry(void *arg, uint32_t t, uint32_t k)
{
    carry_ctx *c = arg;
    (void)k;
    if (c->pass == 1) {
        size_t i, nd = 0;
        for (i = c->pb[t]; i < c->pb[t + 1]; i++)
            nd += (size_t)row_changed(c->changed, c->p + 2 * i);
        c->ndrop[t] = nd;
        return;
    }
    carry_forward(c, t);
}

/* The carry pass on two threads in one pass, with no count first: thread
 * 1 writes its rows forward from the position where thread 0's range
 * would end if nothing were dropped, thread 0 writes its rows backward
 * from that same position. The output is then one run that starts after
 * the rows thread 0 dropped (lc_pair_list.first); so are the dropped rows. */
static void task_carry2(void *arg, uint32_t t, uint32_t k)
{
    carry_ctx *c = arg;
    const uint64_t *restrict bits = c->changed;
    const locd_id *restrict p = c->p, *restrict n = c->n;
    locd_id *restrict out = c->out, *restrict drop = c->drop;
    const size_t pb = c->pb[0], nb = c->nb[0];
    size_t i = c->pb[1], j = c->nb[1], w = c->pb[1] + c->nb[1], dw = c->pb[1];
    uint64_t nkey;
    (void)k;
    if (t == 1) {
        c->out_off[1] = w, c->drop_off[1] = dw;
        carry_forward(c, 1);
        return;
    }
    /* walking down: the next new row is n[j - 1]; 0 when there is none (a
       key is never 0: serials start at 1) */
    nkey = j > nb ? lc_pair_key(n + 2 * (j - 1)) : 0;
    while (i > pb) {
        const locd_id *r = p + 2 * --i;
        const locd_id r0 = r[0], r1 = r[1];
        uint64_t key;
        if (row_changed(bits, r)) {
            dw--;
            drop[2 * dw] = r0, drop[2 * dw + 1] = r1;
            continue;
        }
        key = lc_pair_key(r);
        while (nkey > key) {
            j--, w--;
            out[2 * w] = n[2 * j], out[2 * w + 1] = n[2 * j + 1];
            nkey = j > nb ? lc_pair_key(n + 2 * (j - 1)) : 0;
        }
        w--;
        out[2 * w] = r0, out[2 * w + 1] = r1;
    }
    while (j > nb) {
        j--, w--;
        out[2 * w] = n[2 * j], out[2 * w + 1] = n[2 * j + 1];
    }
    c->out_off[0] = w, c->drop_off[0] = dw;
}

/* The bitmap of the changed slots: dirty or removed. */
static void mark_changed(const lc_slots *sl, uint64_t *bits, size_t words)
{
    const uint32_t *d = sl->dirty.data, *r = sl->removed.data;
    size_t k;
    memset(bits, 0, words * sizeof *bits);
    for (k = 0; k < sl->ndirty; k++)
        bits[d[k] >> 6] |= (uint64_t)1 << (d[k] & 63);
    for (k = 0; k < sl->nremoved; k++)
        bits[r[k] >> 6] |= (uint64_t)1 << (r[k] & 63);
}

static void carry_run(locd_scene *s, carry_ctx *c, uint32_t kk, int pass)
{
    c->pass = pass;
    if (kk > 1)
        lc_pool_run(s->pool, kk, task_carry, c);
    else
        task_carry(c, 0, 1);
}

/* Two threads, one pass (task_carry2). */
static locd_status carry_two(locd_scene *s, carry_ctx *c, size_t nn, lc_pair_list *next, lc_pair_list *dropped)
{
    const size_t np = s->set.pairs.count;
    locd_status st;
    if ((st = lc_pair_list_reserve(s->alloc, next, np + nn + 1)) != LOCD_OK ||
        (st = lc_pair_list_reserve(s->alloc, dropped, np + 1)) != LOCD_OK)
        return st;
    c->out = next->rows.data;
    c->drop = dropped->rows.data;
    c->pass = 3;
    lc_pool_run(s->pool, 2, task_carry2, c);
    next->first = c->out_off[0];
    next->count = c->out_end[1] - c->out_off[0];
    dropped->first = c->drop_off[0];
    dropped->count = c->drop_end[1] - c->drop_off[0];
    return LOCD_OK;
}

/* kk threads: a counting pass gives each its offsets, then the write. */
static locd_status carry_counted(locd_scene *s, carry_ctx *c, uint32_t kk, lc_pair_list *next, lc_pair_list *dropped)
{
    size_t nd = 0, k = 0;
    uint32_t t;
    locd_status st;
    carry_run(s, c, kk, 1);
    for (t = 0; t < kk; t++) {
        c->drop_off[t] = nd;
        nd += c->ndrop[t];
        c->out_off[t] = k;
        k += (c->pb[t + 1] - c->pb[t]) - c->ndrop[t] + (c->nb[t + 1] - c->nb[t]);
    }
    if ((st = lc_pair_list_reserve(s->alloc, next, k + 1)) != LOCD_OK ||
        (st = lc_pair_list_reserve(s->alloc, dropped, nd + 1)) != LOCD_OK)
        return st;
    c->out = next->rows.data;
    c->drop = dropped->rows.data;
    carry_run(s, c, kk, 2);
    next->count = k;
    dropped->count = nd;
    return LOCD_OK;
}

locd_status lc_carry(locd_scene *s, const lc_pair_list *n, lc_pair_list *next, lc_pair_list *dropped)
{
    const locd_allocator *a = s->alloc;
    const size_t words = (s->slots.nslots + 63) / 64 + 1, np = s->set.pairs.count;
    uint32_t kk = s->threads && np >= LC_PARALLEL_MIN ? s->threads : 1, t;
    carry_ctx *c = lc_alloc(a, sizeof *c);
    uint64_t *bits = lc_alloc(a, words * sizeof *bits);
    locd_status st;
    if (!c || !bits) {
        st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the carry pass");
    } else {
        memset(c, 0, sizeof *c);
        mark_changed(&s->slots, bits, words);
        c->changed = bits, c->p = lc_pair_list_rows(&s->set.pairs), c->n = n->rows.data;
        for (t = 0; t <= kk; t++) {
            c->pb[t] = np * t / kk;
            c->nb[t] = t == 0    ? 0
                       : t == kk ? n->count
                                 : lc_pair_rows_lower_bound(n->rows.data, n->count, lc_pair_key(c->p + 2 * c->pb[t]));
        }
        st = kk == 2 ? carry_two(s, c, n->count, next, dropped) : carry_counted(s, c, kk, next, dropped);
    }
    lc_free(a, c, sizeof *c);
    lc_free(a, bits, words * sizeof *bits);
    return st;
}
