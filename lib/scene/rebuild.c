/* The pairs of the live objects from scratch: the engine's own find over
 * their boxes, then the filter and the ids. */
#include "scene/scene.h"

locd_status lc_scene_pairs_from_scratch(locd_scene *s, lc_plist *out, uint64_t *candidates)
{
    const locd_allocator *a = s->alloc;
    size_t n = 0, k, w = 0, cap = s->nslots ? s->nslots : 1;
    uint32_t *live = lc_alloc(a, cap * sizeof *live);
    double *boxes = lc_alloc(a, cap * 6 * sizeof *boxes);
    locd_pairs found;
    locd_stats st_find;
    locd_status st;
    if (!live || !boxes) {
        lc_free(a, live, cap * sizeof *live);
        lc_free(a, boxes, cap * 6 * sizeof *boxes);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's rebuild buffers");
    }
    for (k = 0; k < s->nslots; k++)
        if (s->flags[k] & LC_SLOT_LIVE) {
            memcpy(boxes + 6 * n, s->box + 6 * k, 6 * sizeof *boxes);
            live[n++] = (uint32_t)k;
        }
    lc_pairs_init_embedded(&found, a);
    memset(&st_find, 0, sizeof st_find);
    st_find.size = sizeof st_find;
    st = s->engine->ops->find(s->engine, boxes, n, 1, 0, &found, &st_find);
    if (st == LOCD_OK)
        st = lc_plist_reserve(a, out, found.count);
    if (st == LOCD_OK) {
        locd_id *rows = out->rows.data;
        for (k = 0; k < found.count; k++) {
            uint32_t i = live[found.data[2 * k]], j = live[found.data[2 * k + 1]];
            if (!lc_scene_may_pair(s, i, j))
                continue;
            if (s->id[i] < s->id[j])
                rows[2 * w] = s->id[i], rows[2 * w + 1] = s->id[j];
            else
                rows[2 * w] = s->id[j], rows[2 * w + 1] = s->id[i];
            w++;
        }
        out->count = w;
        st = lc_pairs_sort_rows(a, rows, w);
        *candidates = found.count;
    }
    lc_pairs_fini_embedded(&found);
    lc_free(a, live, cap * sizeof *live);
    lc_free(a, boxes, cap * 6 * sizeof *boxes);
    return st;
}

/* Every live object's cells on grid g into cells/qbox (slot-indexed arrays
 * of the caller), and the two entry lists, sorted. */
locd_status lc_scene_build_trees(locd_scene *s, const locd_grid *g, lc_cells *cells, uint64_t *qbox, lc_tree *dyn,
                                 lc_tree *sta)
{
    const locd_allocator *a = s->alloc;
    size_t k, nd = 0, ns = 0, cap;
    uint64_t *scratch;
    locd_status st = LOCD_OK;
    for (k = 0; k < s->nslots; k++) {
        uint32_t n;
        if (!(s->flags[k] & LC_SLOT_LIVE))
            continue;
        lc_cells_of(g, s->box + 6 * k, &cells[k], (uint32_t *)(qbox + 2 * k));
        n = (1u + (cells[k].span & 1u)) * (1u + ((cells[k].span >> 1) & 1u)) * (1u + ((cells[k].span >> 2) & 1u));
        if (s->flags[k] & LC_SLOT_STATIC)
            ns += n;
        else
            nd += n;
    }
    memset(dyn, 0, sizeof *dyn);
    memset(sta, 0, sizeof *sta);
    cap = nd > ns ? nd : ns;
    scratch = lc_alloc(a, (cap ? cap : 1) * sizeof *scratch);
    if (!scratch || lc_buf_reserve(a, &dyn->ent, sizeof(uint64_t), nd ? nd : 1) != LOCD_OK ||
        lc_buf_reserve(a, &sta->ent, sizeof(uint64_t), ns ? ns : 1) != LOCD_OK) {
        lc_free(a, scratch, (cap ? cap : 1) * sizeof *scratch);
        lc_buf_release(a, &dyn->ent, sizeof(uint64_t));
        lc_buf_release(a, &sta->ent, sizeof(uint64_t));
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene's entry lists");
    }
    /* Slot order, so that equal keys are in index order, as the radix sort wants. */
    for (k = 0; k < s->nslots; k++) {
        lc_tree *t;
        if (!(s->flags[k] & LC_SLOT_LIVE))
            continue;
        t = (s->flags[k] & LC_SLOT_STATIC) ? sta : dyn;
        t->count += lc_cells_entries(g, &cells[k], (uint32_t)k, (uint64_t *)t->ent.data + t->count);
    }
    {
        lc_tree *ts[2];
        int i;
        ts[0] = dyn, ts[1] = sta;
        for (i = 0; i < 2; i++) {
            uint64_t *r = lc_radix_sort(ts[i]->ent.data, scratch, ts[i]->count, g->index_bits);
            if (r != ts[i]->ent.data)
                memcpy(ts[i]->ent.data, r, ts[i]->count * sizeof *r);
            lc_tree_count_levels(g, ts[i]);
        }
    }
    lc_free(a, scratch, (cap ? cap : 1) * sizeof *scratch);
    return st;
}
