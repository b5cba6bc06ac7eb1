/* The pair set of the last update, its created and lost rows, and the
 * spare buffers an update writes into; the lists the caller reads. */
#include "scene/scene.h"

static void swap_pair_list(lc_pair_list *a, lc_pair_list *b)
{
    lc_pair_list t = *a;
    *a = *b;
    *b = t;
}

/* *to = *from, emptied; *from = nothing. */
static void hand(lc_pair_list *to, lc_pair_list *from)
{
    *to = *from;
    to->count = to->first = 0;
    memset(from, 0, sizeof *from);
}

void lc_pair_set_lend(lc_pair_set *ps, lc_pair_list *next, lc_pair_list *created, lc_pair_list *lost)
{
    hand(next, &ps->spare);
    hand(created, &ps->spare_created);
    hand(lost, &ps->spare_lost);
}

void lc_pair_set_give_back(lc_pair_set *ps, lc_pair_list *next, lc_pair_list *created, lc_pair_list *lost)
{
    hand(&ps->spare, next);
    hand(&ps->spare_created, created);
    hand(&ps->spare_lost, lost);
}

void lc_pair_set_take(lc_pair_set *ps, lc_pair_list *next, int in_place, lc_pair_list *created, lc_pair_list *lost)
{
    if (!in_place) /* else ps->pairs is the new set already */
        swap_pair_list(&ps->pairs, next);
    swap_pair_list(&ps->created, created);
    swap_pair_list(&ps->lost, lost);
    lc_pair_set_give_back(ps, next, created, lost); /* the set's and the events' before */
    ps->valid = 1;
}

void lc_pair_set_fini(const locd_allocator *a, lc_pair_set *ps)
{
    lc_pair_list_fini(a, &ps->pairs);
    lc_pair_list_fini(a, &ps->created);
    lc_pair_list_fini(a, &ps->lost);
    lc_pair_list_fini(a, &ps->spare);
    lc_pair_list_fini(a, &ps->spare_created);
    lc_pair_list_fini(a, &ps->spare_lost);
    lc_pair_list_fini(a, &ps->spare_dropped);
}

/* The diff split over the pool by key range: thread t writes its rows in
 * the part of each output that its input range would fill, and the parts
 * are closed up after. */
typedef struct diff_ctx {
    const locd_id *p, *n;
    size_t pb[LC_MAX_THREADS + 1], nb[LC_MAX_THREADS + 1], ncr[LC_MAX_THREADS], nlo[LC_MAX_THREADS];
    locd_id *cr, *lo;
} diff_ctx;

static void task_diff(void *arg, uint32_t t, uint32_t k)
{
    diff_ctx *c = arg;
    const locd_id *p = c->p + 2 * c->pb[t], *n = c->n + 2 * c->nb[t];
    size_t np = c->pb[t + 1] - c->pb[t], nn = c->nb[t + 1] - c->nb[t];
    (void)k;
    lc_pair_rows_diff(n, nn, p, np, c->cr + 2 * c->nb[t], &c->ncr[t], c->lo + 2 * c->pb[t], &c->nlo[t]);
}

locd_status lc_pair_set_diff(locd_scene *s, const lc_pair_list *next, lc_pair_list *created, lc_pair_list *lost)
{
    const lc_pair_list *set = &s->set.pairs;
    locd_status st;
    diff_ctx c;
    uint32_t k = s->threads ? s->threads : 1, t;
    size_t wc = 0, wl = 0;
    if ((st = lc_pair_list_reserve(s->alloc, created, next->count + 1)) != LOCD_OK ||
        (st = lc_pair_list_reserve(s->alloc, lost, set->count + 1)) != LOCD_OK)
        return st;
    if (next->count + set->count < LC_PARALLEL_MIN)
        k = 1;
    c.p = lc_pair_list_rows(set), c.n = lc_pair_list_rows(next), c.cr = created->rows.data, c.lo = lost->rows.data;
    for (t = 0; t <= k; t++) {
        c.nb[t] = next->count * t / k;
        c.pb[t] = t == 0   ? 0
                  : t == k ? set->count
                           : lc_pair_rows_lower_bound(c.p, set->count, lc_pair_key(c.n + 2 * c.nb[t]));
    }
    if (k > 1)
        lc_pool_run(s->pool, k, task_diff, &c);
    else
        task_diff(&c, 0, 1);
    for (t = 0; t < k; t++) {
        memmove(c.cr + 2 * wc, c.cr + 2 * c.nb[t], 2 * c.ncr[t] * sizeof(locd_id));
        memmove(c.lo + 2 * wl, c.lo + 2 * c.pb[t], 2 * c.nlo[t] * sizeof(locd_id));
        wc += c.ncr[t], wl += c.nlo[t];
    }
    created->first = lost->first = 0;
    created->count = wc, lost->count = wl;
    return LOCD_OK;
}

/* One of the lists of the last update; empty when not asked for. */
static locd_status give_list(const locd_scene *s, const lc_pair_list *p, int shown, const locd_id **pairs,
                             size_t *count)
{
    locd_status st;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK)
        return st;
    if (!pairs || !count)
        return lc_error(LOCD_ERR_NULL_POINTER, "pairs or count is NULL");
    *pairs = shown ? lc_pair_list_rows(p) : NULL;
    *count = shown ? p->count : 0;
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_scene_pairs(const locd_scene *s, const locd_id **pairs, size_t *count)
{
    return give_list(s, s ? &s->set.pairs : NULL, s && s->set.show_pairs, pairs, count);
}

locd_status locd_scene_created(const locd_scene *s, const locd_id **pairs, size_t *count)
{
    return give_list(s, s ? &s->set.created : NULL, s && s->set.show_events, pairs, count);
}

locd_status locd_scene_lost(const locd_scene *s, const locd_id **pairs, size_t *count)
{
    return give_list(s, s ? &s->set.lost : NULL, s && s->set.show_events, pairs, count);
}
