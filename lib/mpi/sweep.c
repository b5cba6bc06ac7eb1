/* A rank's sweep of its key range: `threads` slices of the range, each a
 * sweep that rebuilds the stack a serial sweep would hold at its start
 * from the entries before it (lc_block_sweep_range_*), concatenated in
 * order; local box numbers become global indices on the way out. */
#include "mpi/part.h"

#include <pthread.h>
#include <stdlib.h>

typedef struct lm_slice {
    const lm_ctx *c;
    const lm_held *h;
    size_t begin, end;
    locd_pairs *pairs;
    locd_stats stats;
    locd_status st;
} lm_slice;

static void *sweep_slice(void *arg)
{
    lm_slice *s = arg;
    const lm_ctx *c = s->c;
    const lm_held *h = s->h;
    locd_stats_init(&s->stats);
    s->st = c->f64 ? lc_block_sweep_range_f64(&c->grid, h->boxes, h->nobj, h->ent, h->count, s->begin, s->end, 0,
                                              s->pairs, &s->stats, c->kernel)
                   : lc_block_sweep_range_f32(&c->grid, h->boxes, h->nobj, h->ent, h->count, s->begin, s->end, 0,
                                              s->pairs, &s->stats, c->kernel);
    return NULL;
}

/* Appends slice pairs to out, mapped to global indices. */
static void append(const lm_held *h, const locd_pairs *from, locd_pairs *out)
{
    const uint32_t *d = locd_pairs_data(from);
    const size_t k = locd_pairs_count(from);
    uint32_t *o = out->data + 2 * out->count;
    size_t i;
    if (h->gidx)
        for (i = 0; i < 2 * k; i++)
            o[i] = h->gidx[d[i]];
    else if (k)
        memcpy(o, d, 2 * k * sizeof *o);
    out->count += k;
}

/* One thread: the sweep writes into out itself (reserved for about one
 * pair an entry: pages it does not touch cost no memory), renumbered in
 * place. */
static locd_status sweep_one(lm_ctx *c, const lm_held *h, locd_pairs *out)
{
    lm_slice sl;
    size_t i;
    out->count = 0;
    sl.c = c;
    sl.h = h;
    sl.begin = h->begin;
    sl.end = h->count;
    sl.pairs = out;
    if ((sl.st = lc_pairs_reserve(out, h->count - h->begin + 64)) != LOCD_OK)
        return sl.st;
    sweep_slice(&sl);
    if (sl.st)
        return sl.st;
    if (h->gidx)
        for (i = 0; i < 2 * out->count; i++)
            out->data[i] = h->gidx[out->data[i]];
    c->st.candidates += sl.stats.candidates;
    return LOCD_OK;
}

locd_status lm_sweep(lm_ctx *c, const lm_held *h, locd_pairs *out)
{
    uint32_t t, k = c->opt.threads ? c->opt.threads : 1;
    lm_slice sl[LC_MAX_THREADS];
    pthread_t th[LC_MAX_THREADS];
    int started[LC_MAX_THREADS];
    size_t total = 0;
    locd_status st = LOCD_OK;
    c->st.entries_held = h->count;
    c->st.entries_replicated = h->begin;
    c->st.objects_held = h->nobj;
    if (k == 1) {
        st = sweep_one(c, h, out);
        c->st.pairs_owned = out->count;
        return st;
    }
    if (k > LC_MAX_THREADS)
        k = LC_MAX_THREADS;
    for (t = 0; t < k; t++) {
        sl[t].c = c;
        sl[t].h = h;
        sl[t].begin = h->begin + (h->count - h->begin) * t / k;
        sl[t].end = h->begin + (h->count - h->begin) * (t + 1) / k;
        sl[t].pairs = NULL;
        sl[t].st = locd_pairs_create(&out->alloc, &sl[t].pairs);
        started[t] = 0;
    }
    for (t = 1; t < k; t++)
        if (!sl[t].st)
            started[t] = pthread_create(&th[t], NULL, sweep_slice, &sl[t]) == 0;
    if (!sl[0].st)
        sweep_slice(&sl[0]);
    for (t = 1; t < k; t++) {
        if (started[t])
            pthread_join(th[t], NULL);
        else if (!sl[t].st)
            sweep_slice(&sl[t]); /* no thread: this one runs it */
    }
    for (t = 0; t < k && !st; t++) {
        st = sl[t].st;
        total += locd_pairs_count(sl[t].pairs);
        c->st.candidates += sl[t].stats.candidates;
    }
    out->count = 0;
    if (!st)
        st = lc_pairs_reserve(out, total);
    for (t = 0; t < k; t++) {
        if (!st)
            append(h, sl[t].pairs, out);
        locd_pairs_destroy(sl[t].pairs);
    }
    c->st.entries_held = h->count;
    c->st.entries_replicated = h->begin;
    c->st.objects_held = h->nobj;
    c->st.pairs_owned = out->count;
    return st;
}

void lm_held_free(lm_held *h)
{
    free(h->ent);
    if (!h->borrowed)
        free(h->boxes);
    free(h->gidx);
    memset(h, 0, sizeof *h);
}
