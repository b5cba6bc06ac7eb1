/* From scratch: the pairs of every live object by the engine's own find
 * over their boxes (or the kept entry list), then the filter and the ids
 * in the pair order (pair_order.c). */
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
        memcpy(c->f + 6 * i, c->s->slots.fbox + 6 * (size_t)c->live[i], 6 * sizeof(float));
}

static void gather_floats(const locd_scene *s, const uint32_t *live, size_t n, float *f)
{
    floats_ctx c;
    uint32_t k = s->threads > 1 && n > LC_PARALLEL_MIN ? s->threads : 1;
    c.s = s, c.live = live, c.n = n, c.f = f;
    if (k > 1)
        lc_pool_run(s->pool, k, task_floats, &c);
    else
        task_floats(&c, 0, 1);
}

/* The pairs of the n objects of a scene whose slots are in id order (ids
 * idl, NULL when in arithmetic progression with the index) from the kept
 * entry list, ordered into out: the sweep gives its pairs to the order as
 * it finds them when the order has the counts of a previous one; when
 * those prove too small, the list is swept again and its gathered pairs
 * ordered. */
static locd_status kept_pairs(locd_scene *s, size_t n, const locd_id *idl, lc_pair_list *out, uint64_t *candidates)
{
    lc_pair_order *ord = NULL;
    lc_pair_sink sink;
    lc_kept_given given;
    locd_stats st_find;
    locd_status st;
    int overflow = 0;
    locd_stats_init(&st_find);
    if (lc_pair_order_can_sink(s, n) && (st = lc_pair_order_open(s, n, idl, &ord, &sink)) != LOCD_OK)
        return st;
    given.has_bounds = lc_handover_bounds(s, given.lo, given.hi);
    given.encoded = lc_handover_take_encode(s);
    st = lc_kept_find(s, n, &given, ord ? &sink : NULL, &s->found, &st_find);
    if (ord) {
        if (st == LOCD_OK) {
            st = lc_pair_order_close(ord, out, &overflow); /* (frees it) */
        } else {
            overflow = lc_pair_order_overflowed(ord);
            lc_pair_order_drop(ord);
        }
        if (!overflow) {
            if (st == LOCD_OK)
                *candidates = st_find.pairs;
            return st;
        }
        /* more pairs than the regions and the spill area hold */
        lc_clear_error();
        locd_stats_init(&st_find);
        st = lc_kept_sweep(s, n, NULL, &s->found, &st_find);
    }
    if (st == LOCD_OK)
        st = lc_pair_order_rows(s, s->found.data, s->found.count, NULL, idl, n, out);
    if (st == LOCD_OK)
        *candidates = s->found.count;
    return st;
}

/* The engine's input: the live objects in id order (their slots live,
 * ids idl; none of either when the slots are in id order: `ordered`), and
 * their boxes, floats when every box is a float exactly (the engine's float
 * find is cheaper than its double one and gives the same pairs; boxes given
 * through the f32 entry points always are). */
typedef struct scratch_in {
    int ordered; /* lc_slots_in_id_order's answer */
    size_t n, cap;
    uint32_t *live;
    locd_id *idl;
    float *fboxes;
    double *boxes;
    const void *in;
    int f64;
} scratch_in;

static void scratch_free(const locd_allocator *a, scratch_in *si)
{
    if (!si->ordered) {
        lc_free(a, si->live, si->cap * sizeof *si->live);
        lc_free(a, si->idl, si->cap * sizeof *si->idl);
    }
    lc_free(a, si->fboxes, si->cap * 6 * sizeof *si->fboxes);
    lc_free(a, si->boxes, si->cap * 6 * sizeof *si->boxes);
}

/* The live slots in serial (= id) order, and their ids. */
static locd_status gather_live(locd_scene *s, scratch_in *si)
{
    const lc_slots *sl = &s->slots;
    const size_t ncap = (size_t)sl->serial + 1;
    uint32_t *by_serial = lc_alloc(s->alloc, ncap * sizeof *by_serial);
    size_t k;
    si->live = lc_alloc(s->alloc, si->cap * sizeof *si->live);
    si->idl = lc_alloc(s->alloc, si->cap * sizeof *si->idl);
    if (!by_serial || !si->live || !si->idl) {
        lc_free(s->alloc, by_serial, ncap * sizeof *by_serial);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's from-scratch buffers");
    }
    memset(by_serial, 0xff, ncap * sizeof *by_serial);
    for (k = 0; k < sl->nslots; k++)
        if (sl->flags[k] & LC_SLOT_LIVE)
            by_serial[LC_ID_SERIAL(sl->id[k])] = (uint32_t)k;
    for (k = 0; k < ncap; k++)
        if (by_serial[k] != 0xffffffffu)
            si->idl[si->n] = sl->id[by_serial[k]], si->live[si->n++] = by_serial[k];
    lc_free(s->alloc, by_serial, ncap * sizeof *by_serial);
    return LOCD_OK;
}

/* The boxes of the live objects in id order, as floats or doubles. */
static locd_status gather_boxes(locd_scene *s, scratch_in *si)
{
    const lc_slots *sl = &s->slots;
    size_t k;
    si->f64 = sl->ninexact != 0;
    if (si->ordered) {
        si->in = si->f64 ? (const void *)sl->box : (const void *)sl->fbox;
        return LOCD_OK;
    }
    if (!si->f64) {
        if (!(si->fboxes = lc_alloc(s->alloc, si->cap * 6 * sizeof *si->fboxes)))
            return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's from-scratch buffers");
        gather_floats(s, si->live, si->n, si->fboxes);
        si->in = si->fboxes;
        return LOCD_OK;
    }
    if (!(si->boxes = lc_alloc(s->alloc, si->cap * 6 * sizeof *si->boxes)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's from-scratch buffers");
    for (k = 0; k < si->n; k++)
        memcpy(si->boxes + 6 * k, sl->box + 6 * (size_t)si->live[k], 6 * sizeof *si->boxes);
    si->in = si->boxes;
    return LOCD_OK;
}

/* The engine's find on the gathered boxes, its pairs ordered into out. */
static locd_status engine_pairs(locd_scene *s, const scratch_in *si, lc_pair_list *out, uint64_t *candidates)
{
    locd_pairs *found = &s->found;
    locd_stats st_find;
    locd_status st;
    locd_stats_init(&st_find);
    st = s->engine->ops->find(s->engine, si->in, si->n, si->f64, 0, found, &st_find);
    if (st == LOCD_OK)
        st = lc_pair_order_rows(s, found->data, found->count, si->live, si->ordered == 2 ? NULL : si->idl, si->n, out);
    if (st == LOCD_OK)
        *candidates = found->count;
    return st;
}

/* The engine's find on the live boxes laid out in id order, so that pairs
 * ordered by (i, j) are rows in order; from the kept entry list when the
 * slots are the engine's input as they are and there are enough of them. */
locd_status lc_from_scratch_pairs(locd_scene *s, lc_pair_list *out, uint64_t *candidates)
{
    scratch_in si;
    locd_status st;
    memset(&si, 0, sizeof si);
    si.ordered = lc_slots_in_id_order(s);
    si.cap = s->slots.nslots ? s->slots.nslots : 1;
    if (si.ordered)
        si.n = s->slots.nslots, si.idl = s->slots.id;
    else if ((st = gather_live(s, &si)) != LOCD_OK)
        goto done;
    if ((st = gather_boxes(s, &si)) != LOCD_OK)
        goto done;
    if (si.ordered && !si.f64 && si.n >= LC_KEPT_MIN)
        st = kept_pairs(s, si.n, si.ordered == 2 ? NULL : si.idl, out, candidates);
    else
        st = engine_pairs(s, &si, out, candidates);
done:
    scratch_free(s->alloc, &si);
    return st;
}
