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
int lc_scene_slots_in_id_order(locd_scene *s)
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

/* The pairs of the n objects of a scene whose slots are in id order (ids
 * idl, NULL when in arithmetic progression with the index) from the kept
 * entry list, ordered into out: the sweep gives its pairs to the order as
 * it finds them when the order has the counts of a previous one; when
 * those prove too small, the list is swept again and its gathered pairs
 * ordered. */
static locd_status kept_pairs(locd_scene *s, size_t n, const locd_id *idl, lc_plist *out, uint64_t *candidates)
{
    lc_order *ord = NULL;
    lc_pair_sink sink;
    locd_stats st_find;
    locd_status st;
    locd_stats_init(&st_find);
    if (lc_scene_order_can_sink(s, n) && (st = lc_scene_order_open(s, n, idl, &ord, &sink)) != LOCD_OK)
        return st;
    st = lc_kept_find(s, n, ord ? &sink : NULL, &s->found, &st_find);
    if (ord) {
        if (st == LOCD_OK)
            st = lc_scene_order_close(ord, out); /* (frees it) */
        else
            lc_scene_order_drop(ord);
        if (st == LOCD_OK)
            *candidates = st_find.pairs;
        if (st != LC_ORDER_FULL)
            return st;
        /* more pairs than the regions and the spill area hold */
        locd_stats_init(&st_find);
        st = lc_kept_sweep(s, n, NULL, &s->found, &st_find);
    }
    if (st == LOCD_OK)
        st = lc_scene_order_pairs(s, s->found.data, s->found.count, NULL, idl, n, out);
    if (st == LOCD_OK)
        *candidates = s->found.count;
    return st;
}

/* The live objects' pairs from scratch: the engine's find on their boxes
 * laid out in id order, so that pairs ordered by (i, j) are rows in order. */
locd_status lc_scene_pairs_from_scratch(locd_scene *s, lc_plist *out, uint64_t *candidates)
{
    const locd_allocator *a = s->alloc;
    size_t n = 0, k, cap = s->nslots ? s->nslots : 1, ncap = (size_t)s->serial + 1;
    const int ordered = lc_scene_slots_in_id_order(s);
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
    if (ordered && !f64 && n >= LC_KEPT_MIN) {
        st = kept_pairs(s, n, ordered == 2 ? NULL : idl, out, candidates);
        goto done;
    }
    locd_stats_init(&st_find);
    st = s->engine->ops->find(s->engine, in, n, f64, 0, found, &st_find);
    if (st == LOCD_OK)
        st = lc_scene_order_pairs(s, found->data, found->count, live, ordered == 2 ? NULL : idl, n, out);
    if (st == LOCD_OK)
        *candidates = found->count;
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
