/* The from-scratch path's entry list, kept from one update to the next.
 *
 * When most objects move, an update finds its pairs from scratch: the
 * engine encodes every box on a grid fitted to them, sorts the entries and
 * sweeps them (from_scratch.c). Objects that move a little keep their cells, so
 * most entries of one update are those of the last. The kept list holds
 * the last update's entries twice: in slot order, each thread's share in
 * its own region as the encode writes them, and sorted. An update encodes
 * every box again into new regions, compares each object's entries with
 * its old ones, sorts the entries of the few objects whose cells changed
 * and merges them into the sorted list; the engine sweeps that list
 * (lc_inproc_sweep_sorted). The bounds pass, the grid fit and the sort of
 * every entry are gone; the encode and the sweep are the engine's own.
 *
 * Exactness: the entries are those the engine's encode writes on the
 * list's grid, a grid fitted as the engine fits one (its bounds, its depth
 * tuning) with a margin of 1/LC_KEPT_MARGIN of the extent on each side;
 * the find is exact on it as on the engine's tight one (the quantization
 * is monotone; the scene's entry lists use such grids too). An update whose
 * boxes leave the grid makes the list again (encode and sort, the engine's
 * work), as does one with another number of objects or threads: boxes
 * clamped to its faces would crowd the cells there. The pairs are a set:
 * the pair order (pair_order.c) sorts them, so the sweep's order does not
 * matter.
 *
 * A move of every object in slot order (move.c) can do the encode ahead,
 * chunk by chunk as it checks and copies the boxes, through the move's
 * hand-over (handover.c): the entries go to the regions this update would
 * write (lc_kept_next_*), the packed boxes to the engine's buffer. The
 * update takes them when the hand-over says nothing changed them since;
 * they are then the update's own encode's, on the same grid.
 *
 * Used when the slots are the engine's input as they are (every slot live,
 * in id order), every box is a float exactly, and there are at least
 * LC_KEPT_MIN objects. */
#include "scene/scene.h"

/* A margin of 1/256 of the extent: the cells are 0.8% larger than on the
 * tight grid, and objects wander that far only after many frames. */
#define LC_KEPT_MARGIN 256.0
/* Above this share of changed entries the merge costs about what the full
 * sort does: the update sorts them all (and the list goes on from there). */
#define LC_KEPT_DELTA_DIV 8

typedef struct kept_ctx {
    locd_scene *s;
    lc_kept *l;
    const float *boxes;
    size_t n;
    uint32_t k;
    int nw; /* the buffers this update writes (l->cur: the last update's) */
    lc_bounds bounds[LC_MAX_THREADS];
    size_t need[LC_MAX_THREADS];
    int overflow[LC_MAX_THREADS];
    uint64_t *del, *add; /* per share t: dcap[t] entries at doff[t] */
    size_t doff[LC_MAX_THREADS + 1], dcap[LC_MAX_THREADS], ndel[LC_MAX_THREADS], nadd[LC_MAX_THREADS];
    uint64_t *qbox; /* the engine's packed boxes buffer (lc_inproc_qbox) */
    uint64_t *dels, *adds, *scratch; /* all shares' deltas, then sorted */
    size_t nd, na;
    const uint64_t *old;
    uint64_t *out;
    size_t ob[LC_MAX_THREADS + 1], d0[LC_MAX_THREADS + 1], a0[LC_MAX_THREADS + 1];
    int pass;
} kept_ctx;

void lc_kept_release(locd_scene *s)
{
    lc_kept *l = &s->kept;
    int b;
    for (b = 0; b < 2; b++) {
        lc_buf_release(s->alloc, &l->reg[b], sizeof(uint64_t));
        lc_buf_release(s->alloc, &l->sorted[b], sizeof(uint64_t));
    }
    lc_buf_release(s->alloc, &l->delta, sizeof(uint64_t));
    memset(l, 0, sizeof *l);
}

/* Share t's range of the n objects. */
LC_INLINE size_t share_begin(const kept_ctx *c, uint32_t t)
{
    return lc_chunk_begin(c->n, t, c->k);
}

static void bounds_share(kept_ctx *c, uint32_t t)
{
    lc_bounds_init(&c->bounds[t]);
    lc_bounds_f32(c->boxes, share_begin(c, t), share_begin(c, t + 1), &c->bounds[t], c->s->kernel);
}

static void encode_share(kept_ctx *c, uint32_t t)
{
    lc_plan *p = &c->l->plan[c->nw];
    const size_t b = share_begin(c, t), e = share_begin(c, t + 1);
    size_t w = lc_encode_f32(&c->l->g, c->boxes, b, e - b, (uint64_t *)c->l->reg[c->nw].data + p->off[t], p->cap[t],
                             &c->need[t], c->qbox, c->s->kernel);
    c->overflow[t] = w == (size_t)-1;
    if (w != (size_t)-1)
        p->cnt[t] = w;
}

/* The end of the run of object `obj` that starts at v[i] (entries of one
 * object are together, objects ascending: the encode's order). */
LC_INLINE size_t run_end(const uint64_t *v, size_t i, size_t n, uint64_t imask, uint64_t obj)
{
    while (i < n && (v[i] & imask) == obj)
        i++;
    return i;
}

/* Share t: the old and the new entries of each object whose entries
 * changed, in slot order, into its part of del and add; an overflow when
 * they do not fit. The two regions hold the same objects, each with one
 * entry or more, so while they agree entry by entry the objects agree. */
static void compare_share(kept_ctx *c, uint32_t t)
{
    const lc_kept *l = c->l;
    const uint64_t imask = ((uint64_t)1 << l->g.index_bits) - 1;
    const uint64_t *nv = (const uint64_t *)l->reg[c->nw].data + l->plan[c->nw].off[t],
                   *ov = (const uint64_t *)l->reg[!c->nw].data + l->plan[!c->nw].off[t];
    const size_t nn = l->plan[c->nw].cnt[t], no = l->plan[!c->nw].cnt[t], cap = c->dcap[t];
    uint64_t *del = c->del + c->doff[t], *add = c->add + c->doff[t];
    size_t i = 0, j = 0, nd = 0, na = 0, i0 = 0;
    c->overflow[t] = 0;
    for (;;) {
        uint64_t obj;
        size_t ie, je;
        /* eight at a time while they agree (one branch per eight) */
        while (i + 8 <= nn && j + 8 <= no) {
            uint64_t x = 0;
            int q;
            for (q = 0; q < 8; q++)
                x |= nv[i + q] ^ ov[j + q];
            if (x)
                break;
            i += 8, j += 8;
        }
        while (i < nn && j < no && nv[i] == ov[j])
            i++, j++;
        if (i == nn && j == no)
            break;
        /* the first object that differs, from the start of its runs: the
           entries since the last difference (from i0 on) agree pairwise, so
           both runs start as far back */
        obj = i == nn ? ov[j] & imask : j == no ? nv[i] & imask
              : (nv[i] & imask) < (ov[j] & imask) ? nv[i] & imask : ov[j] & imask;
        while (i > i0 && (nv[i - 1] & imask) == obj)
            i--, j--;
        ie = run_end(nv, i, nn, imask, obj);
        je = run_end(ov, j, no, imask, obj);
        if (nd + (je - j) > cap || na + (ie - i) > cap) {
            c->overflow[t] = 1;
            return;
        }
        memcpy(del + nd, ov + j, (je - j) * sizeof *ov);
        memcpy(add + na, nv + i, (ie - i) * sizeof *nv);
        nd += je - j, na += ie - i;
        i = i0 = ie, j = je;
    }
    c->ndel[t] = nd, c->nadd[t] = na;
}

/* The first position of v[lo, hi) not below x (v ascending), searched
 * forward from lo in doubling steps: the next change is usually near. */
static size_t gallop(const uint64_t *v, size_t lo, size_t hi, uint64_t x)
{
    size_t step = 1, a = lo, b;
    while (a + step < hi && v[a + step] < x) {
        a += step;
        step *= 2;
    }
    b = a + step < hi ? a + step : hi;
    return a + lc_lower_bound(v + a, b - a, x);
}

/* Share t of the old sorted list, less its deleted entries, merged with
 * the added ones of its key range, at its place in the new list. Runs of
 * unchanged entries are copied whole. */
static void merge_share(kept_ctx *c, uint32_t t)
{
    const uint64_t *old = c->old, *dels = c->dels, *adds = c->adds;
    size_t i = c->ob[t], d = c->d0[t], a = c->a0[t];
    const size_t ie = c->ob[t + 1], de = c->d0[t + 1], ae = c->a0[t + 1];
    uint64_t *w = c->out + (c->ob[t] - c->d0[t] + c->a0[t]);
    while (i < ie) {
        const uint64_t nd = d < de ? dels[d] : UINT64_MAX, na = a < ae ? adds[a] : UINT64_MAX;
        const size_t p = gallop(old, i, ie, nd < na ? nd : na);
        memcpy(w, old + i, (p - i) * sizeof *old);
        w += p - i, i = p;
        if (i == ie)
            break;
        if (d < de && old[i] == dels[d]) /* deleted (a run of deletions is usual: an object's entries) */
            i++, d++;
        else
            *w++ = adds[a++]; /* below old[i]: adds never equal a kept entry */
    }
    memcpy(w, adds + a, (ae - a) * sizeof *adds);
}

static void sort_deltas(kept_ctx *c, uint32_t t, uint32_t k)
{
    const uint32_t ib = c->l->g.index_bits;
    if (k == 1 || t == 0) {
        const uint64_t *r = lc_radix_sort(c->dels, c->scratch, c->nd, ib);
        if (r != c->dels)
            memcpy(c->dels, r, c->nd * sizeof *r);
    }
    if (k == 1 || t == 1) {
        const uint64_t *r = lc_radix_sort(c->adds, c->scratch + c->nd, c->na, ib);
        if (r != c->adds)
            memcpy(c->adds, r, c->na * sizeof *r);
    }
}

static void task_kept(void *arg, uint32_t t, uint32_t k)
{
    kept_ctx *c = arg;
    switch (c->pass) {
    case 0: bounds_share(c, t); break;
    case 1: encode_share(c, t); break;
    case 2: compare_share(c, t); break;
    case 3: sort_deltas(c, t, k); break;
    default: merge_share(c, t); break;
    }
}

static void kept_run(kept_ctx *c, int pass, uint32_t k)
{
    c->pass = pass;
    if (k > 1)
        lc_pool_run(c->s->pool, k, task_kept, c);
    else
        task_kept(c, 0, 1);
}

/* 1 when any share overflowed in the pass just run. */
static int any_overflow(const kept_ctx *c)
{
    uint32_t t;
    for (t = 0; t < c->k; t++)
        if (c->overflow[t])
            return 1;
    return 0;
}

/* A new grid for the boxes: the engine's fit (its bounds grown by the
 * margin, its depth tuning), for n objects. */
static locd_status fit_grid(kept_ctx *c, const lc_bounds *all)
{
    const locd_engine *e = c->s->engine;
    lc_bounds b = *all;
    locd_status st;
    int a;
    for (a = 0; a < 3; a++) {
        const double m = (b.hi[a] * 0.5 - b.lo[a] * 0.5) / (0.5 * LC_KEPT_MARGIN);
        const double lo = b.lo[a] - m, hi = b.hi[a] + m;
        if (isfinite(lo) && isfinite(hi))
            b.lo[a] = lo, b.hi[a] = hi;
    }
    if ((st = lc_grid_from_bounds(&b, c->n, e->cfg.max_depth, e->cfg.cell_bias, e->cfg.flags, &c->l->g)) != LOCD_OK)
        return st;
    if (!e->cfg.max_depth)
        lc_grid_tune_depth_f32(&c->l->g, c->boxes, c->n);
    return LOCD_OK;
}

/* Every box encoded into the regions of buffer nw (sized from the entries
 * per object seen last, redone with exact sizes when a share overflows),
 * the packed boxes into the engine's buffer (the sweep's next). */
static locd_status encode_all(kept_ctx *c)
{
    lc_kept *l = c->l;
    lc_plan *p = &l->plan[c->nw];
    const locd_allocator *a = c->s->alloc;
    uint32_t t;
    p->k = c->k;
    lc_plan_regions(p, c->n, l->per_object);
    if (!(c->qbox = lc_inproc_qbox(c->s->engine, c->n)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's kept entry list");
    for (;;) {
        if (lc_buf_reserve(a, &l->reg[c->nw], sizeof(uint64_t), lc_plan_layout(p)) != LOCD_OK)
            return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's kept entry list");
        kept_run(c, 1, c->k);
        if (!any_overflow(c))
            break;
        for (t = 0; t < c->k; t++)
            if (c->overflow[t])
                p->cap[t] = c->need[t];
    }
    l->per_object = lc_plan_finish(p, c->n);
    return LOCD_OK;
}

/* The new regions' entries sorted into sorted[nw], all of them (a new
 * list, or too many changes): the regions are copied into sorted[!nw]
 * first, the sort's runs and scratch, so that they stay for the next
 * update's comparison. */
static locd_status sort_all(kept_ctx *c)
{
    lc_kept *l = c->l;
    const lc_plan *p = &l->plan[c->nw];
    const locd_allocator *a = c->s->alloc;
    lc_psort_in in;
    uint64_t *runs;
    size_t at = 0;
    uint32_t t;
    if (lc_buf_reserve(a, &l->sorted[0], sizeof(uint64_t), p->total + 1) != LOCD_OK ||
        lc_buf_reserve(a, &l->sorted[1], sizeof(uint64_t), p->total + 1) != LOCD_OK)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's kept entry list");
    runs = l->sorted[!c->nw].data;
    in.k = c->k, in.index_bits = l->g.index_bits, in.key_bits = LC_LEVEL_BITS + 3 * l->g.depth;
    for (t = 0; t < c->k; t++) {
        memcpy(runs + at, (const uint64_t *)l->reg[c->nw].data + p->off[t], p->cnt[t] * sizeof *runs);
        in.run[t] = runs + at, in.count[t] = p->cnt[t];
        at += p->cnt[t];
    }
    return lc_psort(c->s->pool, a, &in, l->sorted[c->nw].data, runs);
}

/* The deltas of every share, one after another (slot order), sorted;
 * 0 when they did not fit their shares' room (sort them all instead). */
static int collect_deltas(kept_ctx *c)
{
    uint32_t t;
    kept_run(c, 2, c->k);
    if (any_overflow(c))
        return 0;
    c->nd = c->na = 0;
    for (t = 0; t < c->k; t++) { /* share 0's part is in place already */
        memmove(c->del + c->nd, c->del + c->doff[t], c->ndel[t] * sizeof *c->del);
        memmove(c->add + c->na, c->add + c->doff[t], c->nadd[t] * sizeof *c->add);
        c->nd += c->ndel[t], c->na += c->nadd[t];
    }
    c->dels = c->del, c->adds = c->add;
    kept_run(c, 3, c->k > 1 ? 2 : 1);
    return 1;
}

/* sorted[!nw] less the deletions, with the additions, into sorted[nw],
 * split over the pool by positions of the old list. */
static locd_status merge_deltas(kept_ctx *c)
{
    lc_kept *l = c->l;
    const locd_allocator *a = c->s->alloc;
    const size_t old_total = l->plan[l->cur].total, total = old_total - c->nd + c->na;
    uint32_t t;
    if (total != l->plan[c->nw].total) /* cannot happen: the deltas are whole objects' entries */
        return lc_error(LOCD_ERR_INTERNAL, "the kept entry list's changes do not add up");
    if (lc_buf_reserve(a, &l->sorted[c->nw], sizeof(uint64_t), total + 1) != LOCD_OK)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's kept entry list");
    c->old = l->sorted[!c->nw].data, c->out = l->sorted[c->nw].data;
    c->ob[0] = c->d0[0] = c->a0[0] = 0;
    for (t = 1; t < c->k; t++) {
        c->ob[t] = lc_chunk_begin(old_total, t, c->k);
        if (c->ob[t] < old_total) {
            const uint64_t v = c->old[c->ob[t]];
            c->d0[t] = lc_lower_bound(c->dels, c->nd, v);
            c->a0[t] = lc_lower_bound(c->adds, c->na, v);
        } else {
            c->d0[t] = c->nd, c->a0[t] = c->na;
        }
    }
    c->ob[c->k] = old_total, c->d0[c->k] = c->nd, c->a0[c->k] = c->na;
    kept_run(c, 4, c->k);
    return LOCD_OK;
}

/* Room for each share's deltas: 1/LC_KEPT_DELTA_DIV of its new entries. */
static locd_status delta_room(kept_ctx *c)
{
    const lc_plan *p = &c->l->plan[c->nw];
    uint32_t t;
    c->doff[0] = 0;
    for (t = 0; t < c->k; t++) {
        c->dcap[t] = p->cnt[t] / LC_KEPT_DELTA_DIV + 64;
        c->doff[t + 1] = c->doff[t] + c->dcap[t];
    }
    /* del, add, and the radix sort's scratch for both */
    if (lc_buf_reserve(c->s->alloc, &c->l->delta, sizeof(uint64_t), 4 * c->doff[c->k]) != LOCD_OK)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's kept entry list");
    c->del = c->l->delta.data;
    c->add = c->del + c->doff[c->k];
    c->scratch = c->add + c->doff[c->k];
    return LOCD_OK;
}

int lc_kept_next_open(locd_scene *s, size_t n, uint32_t k)
{
    lc_kept *l = &s->kept;
    lc_plan *p = &l->plan[!l->cur];
    uint32_t t;
    if (!l->valid || l->n != n || l->plan[l->cur].k != k) /* (a valid list has its per_object) */
        return 0;
    p->k = k;
    lc_plan_regions(p, n, l->per_object);
    if (lc_buf_reserve(s->alloc, &l->reg[!l->cur], sizeof(uint64_t), lc_plan_layout(p)) != LOCD_OK)
        return 0;
    for (t = 0; t < k; t++)
        p->cnt[t] = 0;
    return 1;
}

int lc_kept_next_encode(locd_scene *s, uint32_t t, const float *boxes, size_t first, size_t count, uint64_t *qbox)
{
    lc_kept *l = &s->kept;
    lc_plan *p = &l->plan[!l->cur];
    size_t need, w = lc_encode_f32(&l->g, boxes, first, count, (uint64_t *)l->reg[!l->cur].data + p->off[t] + p->cnt[t],
                                   p->cap[t] - p->cnt[t], &need, qbox, s->kernel);
    if (w == (size_t)-1)
        return 0;
    p->cnt[t] += w;
    return 1;
}

locd_status lc_kept_sweep(locd_scene *s, size_t n, const lc_pair_sink *sink, locd_pairs *out, locd_stats *stats)
{
    const lc_kept *l = &s->kept;
    /* the packed boxes the list's encode wrote (the buffer is reserved) */
    const uint64_t *qbox = lc_inproc_qbox(s->engine, n);
    if (!l->valid || l->n != n || !qbox)
        return lc_error(LOCD_ERR_INTERNAL, "the kept entry list is not up to date");
    return lc_inproc_sweep_sorted(s->engine, &l->g, s->slots.fbox, qbox, n, l->sorted[l->cur].data, l->plan[l->cur].total,
                                  sink, out, stats);
}

/* The bounds of every box: given, or a pass of their own. */
static void all_bounds(kept_ctx *c, const lc_kept_given *given, lc_bounds *all)
{
    uint32_t t;
    lc_bounds_init(all);
    if (given->has_bounds) {
        for (t = 0; t < 3; t++)
            all->lo[t] = given->lo[t], all->hi[t] = given->hi[t];
        return;
    }
    kept_run(c, 0, c->k);
    for (t = 0; t < c->k; t++)
        lc_bounds_merge(all, &c->bounds[t]);
}

locd_status lc_kept_find(locd_scene *s, size_t n, const lc_kept_given *given, const lc_pair_sink *sink, locd_pairs *out,
                         locd_stats *stats)
{
    lc_kept *l = &s->kept;
    kept_ctx *c = lc_alloc(s->alloc, sizeof *c);
    lc_bounds all;
    locd_status st;
    int fresh, fits = 0, pre = given->encoded;
    double room[6];
    if (!c)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's kept entry list");
    memset(c, 0, sizeof *c);
    c->s = s, c->l = l, c->boxes = s->slots.fbox, c->n = n;
    c->k = s->threads > 1 ? s->threads : 1;
    all_bounds(c, given, &all);
    memcpy(room, all.lo, sizeof all.lo);
    memcpy(room + 3, all.hi, sizeof all.hi);
    fresh = !l->valid || l->n != n || l->plan[l->cur].k != c->k || !lc_grid_holds(&l->g, room);
    l->valid = 0; /* until this update's list is whole */
    if (fresh) {
        l->per_object = l->per_object > 0.0 ? l->per_object : lc_entries_per_object_guess(s->engine->cfg.cell_bias);
        if ((st = fit_grid(c, &all)) != LOCD_OK)
            goto done;
    }
    c->nw = fresh ? l->cur : !l->cur;
    if (!fresh && pre) { /* the move encoded the boxes (lc_kept_next_open's checks hold still) */
        l->per_object = lc_plan_finish(&l->plan[c->nw], n);
    } else if ((st = encode_all(c)) != LOCD_OK) {
        goto done;
    }
    if (!fresh && (st = delta_room(c)) == LOCD_OK)
        fits = collect_deltas(c);
    if (st == LOCD_OK)
        st = fits ? merge_deltas(c) : sort_all(c);
    if (st != LOCD_OK)
        goto done;
    l->cur = c->nw, l->n = n, l->valid = 1;
    st = lc_kept_sweep(s, n, sink, out, stats);
done:
    lc_free(s->alloc, c, sizeof *c);
    return st;
}
