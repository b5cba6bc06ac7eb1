/* Contact begin/end: each collide's contact pairs as sorted keys
 * (i << 32 | j), merged against the previous collide's keys. The cost is a
 * radix sort and a merge over the contacts (not the objects); removed objects
 * need nothing special, since their pairs are simply no longer in the set. */
#include "core/core.h"
#include "narrow/narrow.h"

void lc_world_events_clear(locd_world *w)
{
    w->events.began_n = 0;
    w->events.ended_n = 0;
}

void lc_world_events_free(locd_world *w)
{
    lc_world_events *e = &w->events;
    lc_buf_release(&w->alloc, &e->prev, sizeof(uint64_t));
    lc_buf_release(&w->alloc, &e->cur, sizeof(uint64_t));
    lc_buf_release(&w->alloc, &e->scratch, sizeof(uint64_t));
    lc_buf_release(&w->alloc, &e->began, 2 * sizeof(uint32_t));
    lc_buf_release(&w->alloc, &e->ended, 2 * sizeof(uint32_t));
}

static void put(lc_buf *list, size_t *n, uint64_t key)
{
    uint32_t *p = (uint32_t *)list->data + 2 * (*n)++;
    p[0] = (uint32_t)(key >> 32);
    p[1] = (uint32_t)key;
}

locd_status lc_world_events_update(locd_world *w, const locd_contacts *c)
{
    lc_world_events *e = &w->events;
    const locd_allocator *a = &w->alloc;
    size_t m = c->count, k, p = 0, q = 0;
    uint64_t *cur, *sorted, *prev;
    lc_buf t;
    locd_status st;
    lc_world_events_clear(w);
    /* Everything that can fail comes first: on failure the previous set stays. */
    if ((st = lc_buf_reserve(a, &e->cur, sizeof(uint64_t), m)) != LOCD_OK ||
        (st = lc_buf_reserve(a, &e->scratch, sizeof(uint64_t), m)) != LOCD_OK ||
        (st = lc_buf_reserve(a, &e->began, 2 * sizeof(uint32_t), m)) != LOCD_OK ||
        (st = lc_buf_reserve(a, &e->ended, 2 * sizeof(uint32_t), e->prev_n)) != LOCD_OK)
        return st;
    cur = e->cur.data;
    for (k = 0; k < m; k++)
        cur[k] = ((uint64_t)c->pairs[2 * k] << 32) | c->pairs[2 * k + 1];
    /* The scene path gives the discrete pairs in (i, j) order: often no sort is needed. */
    for (k = 1; k < m && cur[k - 1] < cur[k]; k++)
        ;
    sorted = k < m ? lc_radix_sort(cur, e->scratch.data, m, 0) : cur;
    if (sorted != cur) {
        /* The result landed in the scratch buffer: it becomes cur. */
        t = e->cur;
        e->cur = e->scratch;
        e->scratch = t;
    }
    cur = e->cur.data;
    prev = e->prev.data;
    while (p < e->prev_n || q < m) {
        if (q == m || (p < e->prev_n && prev[p] < cur[q]))
            put(&e->ended, &e->ended_n, prev[p++]);
        else if (p == e->prev_n || cur[q] < prev[p])
            put(&e->began, &e->began_n, cur[q++]);
        else
            p++, q++;
    }
    t = e->prev;
    e->prev = e->cur;
    e->cur = t;
    e->prev_n = m;
    return LOCD_OK;
}
