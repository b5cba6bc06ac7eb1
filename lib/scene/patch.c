/* The patch of an incremental update whose changes are known exactly (the
 * partner lists' PAIRED bits): the new set is the previous one without the
 * lost rows and with the created ones. The edits are a few hundred a frame
 * where the set holds a million rows, so the patch is a copy at memory
 * speed, into the spare buffer (lc_patch) or, when the set's own buffer
 * has room after it, in place (lc_patch_in_place). */
#include "scene/scene.h"

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
        pos[i] = lo + lc_pair_rows_lower_bound(p + 2 * lo, hi - lo, k);
    }
}

/* The lost rows' positions (each must hold its row) and the created rows',
 * through one sample of the set. */
static locd_status patch_positions(const locd_allocator *a, const locd_id *p, size_t np, const lc_pair_list *lost,
                                   const lc_pair_list *created, uint64_t *pos_l, uint64_t *pos_c)
{
    const locd_id *lo = lc_pair_list_rows(lost);
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
    edit_positions(key, ns, p, np, lc_pair_list_rows(created), created->count, pos_c);
    lc_free(a, key, ns * sizeof *key);
    for (i = 0; i < lost->count; i++)
        if (pos_l[i] >= np || p[2 * pos_l[i]] != lo[2 * i] || p[2 * pos_l[i] + 1] != lo[2 * i + 1])
            return lc_error(LOCD_ERR_INTERNAL, "a lost pair is not in the pair set");
    return LOCD_OK;
}

/* The patch of an incremental update whose changes are known exactly (the
 * partner lists' PAIRED bits, moved_pairs.c): the new set is the previous one
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

locd_status lc_patch(locd_scene *s, const lc_pair_list *lost, const lc_pair_list *created, lc_pair_list *next)
{
    const locd_allocator *a = s->alloc;
    const size_t np = s->set.pairs.count, nl = lost->count, nc = created->count;
    uint64_t *pos = lc_alloc(a, (nl + nc + 1) * sizeof *pos);
    patch_ctx c;
    uint32_t kk = s->threads > 1 && np >= LC_PARALLEL_MIN ? s->threads : 1, t;
    locd_status st = LOCD_OK;
    if (!pos)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the pair set's patch");
    memset(&c, 0, sizeof c);
    c.p = lc_pair_list_rows(&s->set.pairs), c.lost = lc_pair_list_rows(lost), c.created = lc_pair_list_rows(created);
    c.np = np, c.nl = nl, c.nc = nc;
    c.pos_l = pos, c.pos_c = pos + nl;
    if ((st = patch_positions(a, c.p, np, lost, created, pos, pos + nl)) != LOCD_OK ||
        (st = lc_pair_list_reserve(a, next, np - nl + nc + 1)) != LOCD_OK)
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

/* The forward walk (as task_patch) as ops, new rows counted from the
 * set's start: returns the ops' count; *w the new set's rows, *shift the
 * largest leftward move a row makes. */
static size_t walk_ops(const uint64_t *pos, size_t np, size_t nl, size_t nc, size_t f0, patch_op *op, size_t *w_out,
                       size_t *shift_out)
{
    size_t i = 0, w = 0, li = 0, ci = 0, n = 0, shift = 0;
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
    *w_out = w, *shift_out = shift;
    return n;
}

/* Two threads: the right half starts at the first op whose source is past
 * the middle (of np rows from f0); its first rows, which the left half may
 * overwrite first, are saved in *head (nhead rows). 0: one thread. */
static int split_in_two(const locd_allocator *a, inplace_ctx *c, size_t n, size_t f0, size_t np, locd_id **head,
                        size_t *nhead)
{
    const patch_op *op = c->op;
    size_t m = 0, reach;
    while (m < n && !(op[m].len && op[m].src >= f0 + np / 2))
        m++;
    if (m == 0 || m == n)
        return 0;
    reach = op[m - 1].dst + (op[m - 1].len ? op[m - 1].len : 1); /* the left half writes below this */
    c->hb = op[m].src, c->he = reach > op[m].src ? reach : op[m].src;
    *nhead = c->he - c->hb;
    if (*nhead && !(*head = lc_alloc(a, 2 * *nhead * sizeof **head)))
        return 0;
    if (*nhead)
        memcpy(*head, c->buf + 2 * c->hb, 2 * *nhead * sizeof **head);
    c->head = *head, c->ob[1] = m, c->ob[2] = n;
    return 1;
}

int lc_patch_in_place(locd_scene *s, const lc_pair_list *lost, const lc_pair_list *created)
{
    const locd_allocator *a = s->alloc;
    lc_pair_list *set = &s->set.pairs;
    const size_t np = set->count, nl = lost->count, nc = created->count, f0 = set->first;
    const size_t nops = 2 * (nl + nc) + 2;
    patch_op *op = lc_alloc(a, nops * sizeof *op);
    uint64_t *pos = lc_alloc(a, (nl + nc + 1) * sizeof *pos);
    locd_id *head = NULL;
    size_t w, n, x, shift, nhead = 0;
    inplace_ctx c;
    int done = 0, two;
    if (!op || !pos || patch_positions(a, lc_pair_list_rows(set), np, lost, created, pos, pos + nl) != LOCD_OK)
        goto out; /* the copying patch reports what went wrong */
    n = walk_ops(pos, np, nl, nc, f0, op, &w, &shift);
    if (f0 + shift + w > set->rows.cap) /* the set starts at f0 + shift: every run moves right */
        goto out;
    for (x = 0; x < n; x++)
        op[x].dst += f0 + shift;
    memset(&c, 0, sizeof c);
    c.buf = set->rows.data, c.created = lc_pair_list_rows(created), c.op = op;
    c.ob[0] = 0, c.ob[1] = n;
    two = s->threads > 1 && np >= LC_PARALLEL_MIN && n >= 2 && split_in_two(a, &c, n, f0, np, &head, &nhead);
    if (two)
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
