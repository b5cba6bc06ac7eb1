/* The relist path: the entry lists built again from the current boxes
 * (entries.c) with the partner lists; then every moved object, inside the
 * fat box just made from its box, takes its pairs from its partner list.
 * When the partner lists could not be made, the moved objects search the
 * entry lists as in the incremental path. */
#include "scene/scene.h"
#include "scene/update.h"

/* The moved objects: to stay (with partner lists) or, without, their
 * entries to search (into u->buf, sorted). */
static locd_status gather_moved(lc_update *u, lc_moved *mv)
{
    locd_scene *s = u->s;
    const uint32_t *d = s->slots.dirty.data;
    size_t k, nq = 0;
    locd_status st;
    if ((st = lc_update_room(u, 0, 8 * s->slots.ndirty + 1)) != LOCD_OK ||
        (st = lc_update_moved_room(u, s->slots.ndirty, 0)) != LOCD_OK)
        return st;
    for (k = 0; k < s->slots.ndirty; k++) {
        const uint32_t slot = d[k];
        uint32_t di;
        if (!(s->slots.flags[slot] & LC_SLOT_LIVE))
            continue;
        di = s->entries.dense[slot];
        if (s->partners.valid) {
            u->stay[u->nstay++] = di;
            s->entries.rec[di].flags |= LC_SLOT_DIRTY;
        } else {
            nq += lc_cells_entries(&s->entries.grid, &s->entries.cell[slot], di, u->buf + nq);
            s->entries.rec[di].flags |= LC_SLOT_DIRTY | LC_REC_SEARCH;
        }
    }
    mv->dyn = &s->entries.dyn, mv->sta = &s->entries.sta;
    mv->q = u->buf, mv->nq = nq, mv->stay = u->stay, mv->nstay = u->nstay;
    return lc_sort_u64_radix(s->alloc, u->buf, nq);
}

locd_status lc_relist(lc_update *u)
{
    locd_scene *s = u->s;
    const uint32_t *d = s->slots.dirty.data;
    lc_moved mv;
    size_t k;
    locd_status st;
    double t0 = lc_now_ms();
    lc_kept_release(s); /* the updates go on incrementally: its memory back, before the lists take theirs */
    lc_near_release(s);
    if ((st = lc_entries_build(s)) != LOCD_OK)
        return st;
    lc_partners_build(s); /* on failure the scene goes on without partner lists */
    u->nstay = 0;
    st = gather_moved(u, &mv);
    u->reencoded = s->slots.live;
    u->ms_encode = lc_now_ms() - t0;
    if (st == LOCD_OK)
        st = lc_moved_pairs(u, &mv);
    for (k = 0; k < s->slots.ndirty; k++)
        if (s->slots.flags[d[k]] & LC_SLOT_LIVE)
            s->entries.rec[s->entries.dense[d[k]]].flags &= ~(uint32_t)(LC_SLOT_DIRTY | LC_REC_SEARCH);
    return st;
}
