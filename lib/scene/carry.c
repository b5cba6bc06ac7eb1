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
 * the rows thread 0 dropped (lc_plist.first); so are the dropped rows. */
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

locd_status lc_scene_carry(locd_scene *s, const lc_plist *n, lc_plist *next, lc_plist *dropped)
{
    const locd_allocator *a = s->alloc;
    const uint32_t *d = s->dirty.data, *r = s->removed.data;
    size_t words = (s->nslots + 63) / 64 + 1, np = s->pairs.count, k, nd = 0;
    uint32_t kk = s->threads ? s->threads : 1, t;
    carry_ctx *c = lc_alloc(a, sizeof *c);
    uint64_t *bits = lc_alloc(a, words * sizeof *bits);
    locd_status st = LOCD_OK;
    if (!c || !bits) {
        st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the carry pass");
        goto done;
    }
    memset(c, 0, sizeof *c);
    memset(bits, 0, words * sizeof *bits);
    for (k = 0; k < s->ndirty; k++)
        bits[d[k] >> 6] |= (uint64_t)1 << (d[k] & 63);
    for (k = 0; k < s->nremoved; k++)
        bits[r[k] >> 6] |= (uint64_t)1 << (r[k] & 63);
    if (np < 65536)
        kk = 1;
    c->changed = bits, c->p = lc_plist_rows(&s->pairs), c->n = n->rows.data;
    for (t = 0; t <= kk; t++) {
        c->pb[t] = np * t / kk;
        c->nb[t] = t == 0    ? 0
                   : t == kk ? n->count
                             : lc_rows_lower_bound(n->rows.data, n->count, lc_pair_key(c->p + 2 * c->pb[t]));
    }
    if (kk == 2) {
        if ((st = lc_plist_reserve(a, next, np + n->count + 1)) != LOCD_OK ||
            (st = lc_plist_reserve(a, dropped, np + 1)) != LOCD_OK)
            goto done;
        c->out = next->rows.data;
        c->drop = dropped->rows.data;
        c->pass = 3;
        lc_pool_run(s->pool, 2, task_carry2, c);
        next->first = c->out_off[0];
        next->count = c->out_end[1] - c->out_off[0];
        dropped->first = c->drop_off[0];
        dropped->count = c->drop_end[1] - c->drop_off[0];
        goto done;
    }
    c->pass = 1;
    if (kk > 1)
        lc_pool_run(s->pool, kk, task_carry, c);
    else
        task_carry(c, 0, 1);
    for (t = 0; t < kk; t++) {
        c->drop_off[t] = nd;
        nd += c->ndrop[t];
    }
    for (t = 0, k = 0; t < kk; t++) {
        c->out_off[t] = k;
        k += (c->pb[t + 1] - c->pb[t]) - c->ndrop[t] + (c->nb[t + 1] - c->nb[t]);
    }
    if ((st = lc_plist_reserve(a, next, k + 1)) != LOCD_OK || (st = lc_plist_reserve(a, dropped, nd + 1)) != LOCD_OK)
        goto done;
    c->out = next->rows.data;
    c->drop = dropped->rows.data;
    c->pass = 2;
    if (kk > 1)
        lc_pool_run(s->pool, kk, task_carry, c);
    else
        task_carry(c, 0, 1);
    next->count = k;
    dropped->count = nd;
done:
    lc_free(a, c, sizeof *c);
    lc_free(a, bits, words * sizeof *bits);
    return st;
}

/* Every 2^LC_SAMPLE_BITS-th row's key: the edits' positions are found in
 * this sample first (it stays in the cache), then within one block of the
 * set, instead of by binary searches over the whole set (each of them a
 * dozen misses: at 3% of 10^6 cubes moving, 2,700 edits a frame made the
 * patch cost twice its copy). */
#define LC_SAMPLE_BITS 8

/* pos[i]: the first row of p[0, np) whose key is >= rows[i]'s (rows sorted),
 * through the sample key[0, ns). */
static void edit_positions(const uint64_t *key, size_t ns, const locd_id *p, size_t np, const locd_id *rows,
                           size_t n, uint64_t *pos)
{
    size_t i, b = 0;
    for (i = 0; i < n; i++) {
        const uint64_t k = lc_pair_key(rows + 2 * i);
        size_t lo, hi;
        while (b + 1 < ns && key[b + 1] <= k) /* rows ascend: the block only moves on */
            b++;
        lo = b << LC_SAMPLE_BITS;
        hi = lo + ((size_t)1 << LC_SAMPLE_BITS) < np ? lo + ((size_t)1 << LC_SAMPLE_BITS) : np;
        pos[i] = lo + lc_rows_lower_bound(p + 2 * lo, hi - lo, k);
    }
}

/* The lost rows' positions (each must hold its row) and the created rows',
 * through one sample of the set. */
static locd_status patch_positions(const locd_allocator *a, const locd_id *p, size_t np, const lc_plist *lost,
                                   const lc_plist *created, uint64_t *pos_l, uint64_t *pos_c)
{
    const locd_id *lo = lc_plist_rows(lost);
    const size_t ns = (np >> LC_SAMPLE_BITS) + 1;
    uint64_t *key;
    size_t i;
    if (!lost->count && !created->count)
        return LOCD_OK;
    if (!(key = lc_alloc(a, ns * sizeof *key)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the pair set's patch");
    for (i = 0; i < ns; i++) /* the first key of each block (the last block may be empty) */
        key[i] = (i << LC_SAMPLE_BITS) < np ? lc_pair_key(p + 2 * (i << LC_SAMPLE_BITS)) : UINT64_MAX;
    edit_positions(key, ns, p, np, lo, lost->count, pos_l);
    edit_positions(key, ns, p, np, lc_plist_rows(created), created->count, pos_c);
    lc_free(a, key, ns * sizeof *key);
    for (i = 0; i < lost->count; i++)
        if (pos_l[i] >= np || p[2 * pos_l[i]] != lo[2 * i] || p[2 * pos_l[i] + 1] != lo[2 * i + 1])
            return lc_error(LOCD_ERR_INTERNAL, "a lost pair is not in the pair set");
    return LOCD_OK;
}

/* The patch of an incremental update whose changes are known exactly (the
 * partner lists' PAIRED bits, update.c): the new set is the previous one
 * without the lost rows and with the created ones, copied in runs between
 * the edits' positions. The edits are a few hundred a frame where the
 * dropped and new rows are tens of thousands, so the pass is a copy at
 * memory speed, split over the pool by ranges of the previous rows. */
typedef struct patch_ctx {
    const locd_id *p, *lost, *created;
    const uint64_t *pos_l, *pos_c; /* each edit's position in p: the lost row's, the created row's lower bound */
    size_t np, nl, nc;
    size_t pb[LC_MAX_THREADS + 1], lb[LC_MAX_THREADS + 1], cb[LC_MAX_THREADS + 1], off[LC_MAX_THREADS];
    locd_id *out;
} patch_ctx;

static void task_patch(void *arg, uint32_t t, uint32_t k)
{
    patch_ctx *c = arg;
    const locd_id *p = c->p;
    size_t i = c->pb[t], w = c->off[t], li = c->lb[t], ci = c->cb[t];
    const size_t pe = c->pb[t + 1], le = c->lb[t + 1], ce = c->cb[t + 1];
    (void)k;
    for (;;) {
        size_t e = pe;
        if (li < le && c->pos_l[li] < e)
            e = c->pos_l[li];
        if (ci < ce && c->pos_c[ci] < e)
            e = c->pos_c[ci];
        memcpy(c->out + 2 * w, p + 2 * i, 2 * (e - i) * sizeof *p);
        w += e - i, i = e;
        if (ci < ce && c->pos_c[ci] == i) { /* a created row goes before the row at its lower bound */
            c->out[2 * w] = c->created[2 * ci], c->out[2 * w + 1] = c->created[2 * ci + 1];
            w++, ci++;
        } else if (li < le && c->pos_l[li] == i) {
            i++, li++;
        } else {
            break;
        }
    }
}

locd_status lc_scene_patch(locd_scene *s, const lc_plist *lost, const lc_plist *created, lc_plist *next)
{
    const locd_allocator *a = s->alloc;
    const size_t np = s->pairs.count, nl = lost->count, nc = created->count;
    uint64_t *pos = lc_alloc(a, (nl + nc + 1) * sizeof *pos);
    patch_ctx c;
    uint32_t kk = s->threads > 1 && np >= 65536 ? s->threads : 1, t;
    locd_status st = LOCD_OK;
    if (!pos)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the pair set's patch");
    memset(&c, 0, sizeof c);
    c.p = lc_plist_rows(&s->pairs), c.lost = lc_plist_rows(lost), c.created = lc_plist_rows(created);
    c.np = np, c.nl = nl, c.nc = nc;
    c.pos_l = pos, c.pos_c = pos + nl;
    if ((st = patch_positions(a, c.p, np, lost, created, pos, pos + nl)) != LOCD_OK ||
        (st = lc_plist_reserve(a, next, np - nl + nc + 1)) != LOCD_OK)
        goto done;
    c.out = next->rows.data;
    next->first = 0;
    for (t = 0; t <= kk; t++) {
        c.pb[t] = np * t / kk;
        c.lb[t] = t == kk ? nl : lc_lower_bound(c.pos_l, nl, c.pb[t]);
        c.cb[t] = t == kk ? nc : lc_lower_bound(c.pos_c, nc, c.pb[t]);
    }
    for (t = 0; t < kk; t++)
        c.off[t] = c.pb[t] - c.lb[t] + c.cb[t];
    if (kk > 1)
        lc_pool_run(s->pool, kk, task_patch, &c);
    else
        task_patch(&c, 0, 1);
    next->count = np - nl + nc;
done:
    lc_free(a, pos, (nl + nc + 1) * sizeof *pos);
    return st;
}

/* The same patch in the set's own buffer, when it has room after the set:
 * every row moves toward the buffer's end (the set starts B rows later,
 * B the largest leftward move a row would make), so one pass from the end
 * moves each run in place. A run is read and written in the same cache
 * lines: 32 MB of traffic at 10^6 pairs where a copy into another buffer
 * makes 48 (its lines are read before they are written). The ops are the
 * forward walk's runs and insertions, done in reverse. On two threads the
 * right half's first rows, which the left half may overwrite first, are
 * saved before. */
typedef struct patch_op {
    size_t src, dst, len; /* a run: len rows from src to dst (buffer rows); len 0: insert created row src at dst */
} patch_op;

typedef struct inplace_ctx {
    locd_id *buf;
    const locd_id *created;
    const patch_op *op;
    size_t ob[3];        /* op ranges of the (at most two) threads */
    const locd_id *head; /* thread 1: buffer rows [hb, he) as they were */
    size_t hb, he;
} inplace_ctx;

static void task_inplace(void *arg, uint32_t t, uint32_t k)
{
    const inplace_ctx *c = arg;
    size_t x;
    (void)k;
    for (x = c->ob[t + 1]; x-- > c->ob[t];) {
        const patch_op *o = &c->op[x];
        if (!o->len) {
            c->buf[2 * o->dst] = c->created[2 * o->src], c->buf[2 * o->dst + 1] = c->created[2 * o->src + 1];
            continue;
        }
        if (t == 1 && o->src < c->he) { /* partly or wholly in the saved head */
            const size_t in = c->he - o->src < o->len ? c->he - o->src : o->len;
            memmove(c->buf + 2 * (o->dst + in), c->buf + 2 * (o->src + in), 2 * (o->len - in) * sizeof *c->buf);
            memcpy(c->buf + 2 * o->dst, c->head + 2 * (o->src - c->hb), 2 * in * sizeof *c->buf);
            continue;
        }
        memmove(c->buf + 2 * o->dst, c->buf + 2 * o->src, 2 * o->len * sizeof *c->buf);
    }
}

int lc_scene_patch_in_place(locd_scene *s, const lc_plist *lost, const lc_plist *created)
{
    const locd_allocator *a = s->alloc;
    lc_plist *set = &s->pairs;
    const size_t np = set->count, nl = lost->count, nc = created->count, f0 = set->first;
    const locd_id *p = lc_plist_rows(set), *cr = lc_plist_rows(created);
    const size_t nops = 2 * (nl + nc) + 2;
    patch_op *op = lc_alloc(a, nops * sizeof *op);
    uint64_t *pos = lc_alloc(a, (nl + nc + 1) * sizeof *pos);
    locd_id *head = NULL;
    size_t i = 0, w = 0, li = 0, ci = 0, n = 0, x, shift = 0, nhead = 0;
    inplace_ctx c;
    uint32_t kk = 1;
    int done = 0;
    if (!op || !pos || patch_positions(a, p, np, lost, created, pos, pos + nl) != LOCD_OK)
        goto out; /* the copying patch reports what went wrong */
    /* the forward walk (as task_patch), new rows counted from the set's start */
    for (;;) {
        const size_t pl = li < nl ? pos[li] : SIZE_MAX, pc = ci < nc ? pos[nl + ci] : SIZE_MAX;
        size_t e = np;
        if (pl < e)
            e = pl;
        if (pc < e)
            e = pc;
        if (e > i) {
            op[n].src = f0 + i, op[n].dst = w, op[n++].len = e - i;
            if (i > w && i - w > shift)
                shift = i - w;
            w += e - i, i = e;
        }
        if (pc == i)
            op[n].src = ci++, op[n].dst = w++, op[n++].len = 0;
        else if (pl == i)
            i++, li++;
        else
            break;
    }
    /* the set starts at f0 + shift: every run moves right */
    if (f0 + shift + w > set->rows.cap)
        goto out;
    for (x = 0; x < n; x++)
        op[x].dst += f0 + shift;
    memset(&c, 0, sizeof c);
    c.buf = set->rows.data, c.created = cr, c.op = op;
    c.ob[0] = 0, c.ob[1] = n;
    if (s->threads > 1 && np >= 65536 && n >= 2) {
        /* the right half starts at the first op whose source is past the middle */
        size_t m = 0, reach;
        while (m < n && !(op[m].len && op[m].src >= f0 + np / 2))
            m++;
        if (m > 0 && m < n) {
            reach = op[m - 1].dst + (op[m - 1].len ? op[m - 1].len : 1); /* the left half writes below this */
            c.hb = op[m].src, c.he = reach > op[m].src ? reach : op[m].src;
            nhead = c.he - c.hb;
            if (!nhead || (head = lc_alloc(a, 2 * nhead * sizeof *head)) != NULL) {
                if (nhead)
                    memcpy(head, c.buf + 2 * c.hb, 2 * nhead * sizeof *head);
                c.head = head, c.ob[1] = m, c.ob[2] = n, kk = 2;
            }
        }
    }
    if (kk > 1)
        lc_pool_run(s->pool, 2, task_inplace, &c);
    else
        task_inplace(&c, 0, 1);
    set->first = f0 + shift, set->count = w;
    done = 1;
out:
    lc_free(a, head, 2 * (nhead ? nhead : 1) * sizeof *head);
    lc_free(a, pos, (nl + nc + 1) * sizeof *pos);
    lc_free(a, op, nops * sizeof *op);
    return done;
}
