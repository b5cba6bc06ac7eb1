/* The pairs of the moved objects into the new set: steps 3 and 4 of an
 * update that takes the entry lists (incremental, relist). Without
 * partner lists, the moved objects' rows are searched and the carry pass
 * merges them with the previous set's unchanged rows. With them, the
 * changes are exact before the set is touched (the PAIRED bits), and the
 * set is patched. docs/scene.md, "One update". */
#include "scene/scene.h"
#include "scene/update.h"

/* The moved objects' records lose the update's flags once the search has
 * read them: here, before the pass over the whole set (which evicts them
 * from the caches), rather than at commit. The undo puts the records back
 * whole if the update fails after. */
static void clear_moved_records(lc_update *u)
{
    lc_record *rec = u->s->entries.rec;
    size_t k;
    for (k = 0; k < u->nstay; k++)
        rec[u->stay[k]].flags &= ~(uint32_t)(LC_SLOT_DIRTY | LC_REC_SEARCH);
    for (k = 0; k < u->nsrch; k++)
        rec[u->srch[k]].flags &= ~(uint32_t)(LC_SLOT_DIRTY | LC_REC_SEARCH);
}

locd_status lc_moved_pairs(lc_update *u, const lc_moved *m)
{
    locd_scene *s = u->s;
    const locd_allocator *a = s->alloc;
    lc_pair_list *n = &u->found.rows, dropped = s->set.spare_dropped;
    locd_status st;
    double t0 = lc_now_ms(), t1;
    dropped.count = dropped.first = 0;
    memset(&s->set.spare_dropped, 0, sizeof s->set.spare_dropped);
    st = lc_search_moved(s, m, LC_SEARCH_ROWS, &u->found);
    t1 = lc_now_ms();
    u->ms_sweep = t1 - t0;
    t0 = t1;
    clear_moved_records(u);
    if (st == LOCD_OK)
        st = lc_carry(s, n, &u->next, &dropped);
    if (st == LOCD_OK && (u->flags & LOCD_SCENE_UPDATE_EVENTS)) {
        /* previous = kept + dropped, now = kept + n, kept disjoint from both */
        if ((st = lc_pair_list_reserve(a, &u->cr, n->count + 1)) == LOCD_OK &&
            (st = lc_pair_list_reserve(a, &u->lo, dropped.count + 1)) == LOCD_OK) {
            lc_pair_rows_diff(n->rows.data, n->count, lc_pair_list_rows(&dropped), dropped.count, u->cr.rows.data,
                              &u->cr.count, u->lo.rows.data, &u->lo.count);
        }
    }
    u->ms_events = lc_now_ms() - t0;
    s->set.spare_dropped = dropped; /* sized for a whole set: kept, as the set's own buffers */
    return st;
}

/* Appends the row of dense indices m and o to p (room made beforehand). */
LC_INLINE void put_pair(const locd_scene *s, lc_pair_list *p, uint32_t m, uint32_t o)
{
    const locd_id a = s->entries.rec[m].id, b = s->entries.rec[o].id;
    locd_id *r = (locd_id *)p->rows.data + 2 * p->count++;
    r[0] = a < b ? a : b, r[1] = a < b ? b : a;
}

/* Whether m reports its pair with partner o (their records): not when o
 * was removed (o's removal does), nor when both searched and o's id is the
 * smaller (o does). As the search's rule (search.c), for the pairs of
 * before. */
LC_INLINE int reports(const lc_record *hm, const lc_record *ho)
{
    return !(ho->flags & LC_REC_GONE) && !((ho->flags & LC_REC_SEARCH) && ho->id < hm->id);
}

/* The searched objects' pairs of before (their lists' PAIRED entries) and
 * of now (the fat partners found whose boxes meet), as keys m << 32 | o,
 * each part sorted: keys[0, *nold) and keys[*nold, *nold + *nnew). */
static locd_status searched_keys(lc_update *u, uint64_t *keys, size_t *nold, size_t *nnew)
{
    const locd_scene *s = u->s;
    const lc_partners *pa = &s->partners;
    const lc_search_out *f = &u->found;
    size_t k, x, no = 0, nn = 0;
    locd_status st;
    for (k = 0; k < u->nsrch; k++) {
        const uint32_t m = u->srch[k];
        const lc_partner_list *h = &pa->list[m];
        for (x = 0; x < h->n; x++) {
            const uint32_t e = pa->pool[h->off + x], o = e & LC_INDEX_BITS;
            if ((e & LC_PAIRED) && reports(&s->entries.rec[m], &s->entries.rec[o]))
                keys[no++] = (uint64_t)m << 32 | o;
        }
    }
    for (k = 0; k < f->nfat; k++) {
        const uint32_t *e = (const uint32_t *)f->fat.data + 2 * k;
        if (e[1] & LC_PAIRED)
            keys[no + nn++] = (uint64_t)e[0] << 32 | (e[1] & LC_INDEX_BITS);
    }
    *nold = no, *nnew = nn;
    if ((st = lc_sort_u64_radix(s->alloc, keys, no)) != LOCD_OK)
        return st;
    return lc_sort_u64_radix(s->alloc, keys + no, nn);
}

/* The rows of old \ now (lost) and now \ old (created). */
static void searched_events(lc_update *u, const uint64_t *old, size_t nold, const uint64_t *now, size_t nnew)
{
    size_t i = 0, j = 0;
    while (i < nold || j < nnew) {
        if (j == nnew || (i < nold && old[i] < now[j])) {
            put_pair(u->s, &u->lo, (uint32_t)(old[i] >> 32), (uint32_t)old[i]), i++;
        } else if (i == nold || now[j] < old[i]) {
            put_pair(u->s, &u->cr, (uint32_t)(now[j] >> 32), (uint32_t)now[j]), j++;
        } else {
            i++, j++;
        }
    }
}

/* Each removed object's PAIRED entries, lost (of two removed objects, the
 * one with the smaller id reports). */
static void removed_events(lc_update *u)
{
    const locd_scene *s = u->s;
    const lc_partners *pa = &s->partners;
    const uint32_t *r = s->slots.removed.data;
    size_t k, x;
    for (k = 0; k < s->slots.nremoved; k++)
        if (s->slots.flags[r[k]] & LC_SLOT_LISTED) {
            const uint32_t m = s->entries.dense[r[k]];
            const lc_partner_list *h = &pa->list[m];
            for (x = 0; x < h->n; x++) {
                const uint32_t e = pa->pool[h->off + x], o = e & LC_INDEX_BITS;
                const lc_record *ho = &s->entries.rec[o];
                if ((e & LC_PAIRED) && !((ho->flags & LC_REC_GONE) && ho->id < s->entries.rec[m].id))
                    put_pair(s, &u->lo, m, o);
            }
        }
}

/* Room in created and lost for every change: the staying objects' events,
 * the searched objects' keys, the removed objects' partners. */
static locd_status events_room(lc_update *u, size_t nkeys)
{
    const locd_scene *s = u->s;
    const uint32_t *r = s->slots.removed.data;
    size_t k, room = u->found.nev + nkeys + 1;
    locd_status st;
    for (k = 0; k < s->slots.nremoved; k++)
        if (s->slots.flags[r[k]] & LC_SLOT_LISTED)
            room += s->partners.list[s->entries.dense[r[k]]].n;
    if ((st = lc_pair_list_reserve(s->alloc, &u->cr, room)) != LOCD_OK ||
        (st = lc_pair_list_reserve(s->alloc, &u->lo, room)) != LOCD_OK)
        return st;
    u->cr.count = u->lo.count = u->cr.first = u->lo.first = 0;
    return LOCD_OK;
}

/* Created and lost, sorted: the partner-list pass's changes, the searched
 * objects' (keys), the removed objects'. */
static locd_status all_events(lc_update *u, const uint64_t *keys, size_t nold, size_t nnew)
{
    const locd_scene *s = u->s;
    size_t k;
    locd_status st;
    if ((st = events_room(u, nold + nnew)) != LOCD_OK)
        return st;
    for (k = 0; k < u->found.nev; k++) {
        const uint32_t *e = (const uint32_t *)u->found.ev.data + 3 * k;
        put_pair(s, (e[2] & LC_PAIRED) ? &u->cr : &u->lo, e[0], e[2] & LC_INDEX_BITS);
    }
    searched_events(u, keys, nold, keys + nold, nnew);
    removed_events(u);
    if ((st = lc_pair_rows_sort(s->alloc, u->cr.rows.data, u->cr.count)) != LOCD_OK)
        return st;
    return lc_pair_rows_sort(s->alloc, u->lo.rows.data, u->lo.count);
}

locd_status lc_moved_events(lc_update *u, const lc_moved *m)
{
    locd_scene *s = u->s;
    const locd_allocator *a = s->alloc;
    uint64_t *keys = NULL;
    size_t k, nold = 0, nnew = 0, nkeys = 0;
    locd_status st;
    double t0 = lc_now_ms(), t1;
    st = lc_search_moved(s, m, LC_SEARCH_EVENTS, &u->found);
    t1 = lc_now_ms();
    u->ms_sweep = t1 - t0;
    t0 = t1;
    if (st != LOCD_OK)
        return st;
    for (k = 0; k < u->nsrch; k++)
        nkeys += s->partners.list[u->srch[k]].n;
    nkeys += u->found.nfat;
    if (!(keys = lc_alloc(a, (nkeys + 1) * sizeof *keys)))
        st = lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the searched objects' pairs");
    if (st == LOCD_OK && (st = searched_keys(u, keys, &nold, &nnew)) == LOCD_OK &&
        (st = all_events(u, keys, nold, nnew)) == LOCD_OK) {
        clear_moved_records(u);
        /* the last step: in place, nothing after it may fail */
        if (!(u->in_place = lc_patch_in_place(s, &u->lo, &u->cr)))
            st = lc_patch(s, &u->lo, &u->cr, &u->next);
        if (st == LOCD_OK && !(u->flags & LOCD_SCENE_UPDATE_EVENTS))
            u->cr.count = u->lo.count = 0;
    }
    lc_free(a, keys, (nkeys + 1) * sizeof *keys);
    u->ms_events = lc_now_ms() - t0;
    return st;
}
