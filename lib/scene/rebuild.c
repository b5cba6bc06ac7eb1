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

void lc_hot_fill(const locd_scene *s, size_t k, const uint64_t qbox[2], lc_hot *h)
{
    h->qlo = qbox[0];
    h->qhi = qbox[1];
    h->cat = s->cat[k];
    h->mask = s->mask[k];
    h->group = s->group[k];
    h->slot = (uint32_t)k;
    h->flags = s->flags[k] & LC_SLOT_STATIC;
}

/* Every live object's cells, dense index and record, and the two entry
 * lists sorted by key (rebuild). */
locd_status lc_scene_build_trees(locd_scene *s, const locd_grid *g, lc_cells *cells, uint32_t *dense, lc_hot *hot,
                                 size_t *ndense, lc_tree *dyn, lc_tree *sta)
{
    const locd_allocator *a = s->alloc;
    const uint64_t imask = ((uint64_t)1 << g->index_bits) - 1;
    size_t k, nd = 0, ns = 0, cap, qcap = 2 * (s->nslots ? s->nslots : 1), next = 0, j;
    uint64_t *scratch, *qb = lc_alloc(a, qcap * sizeof *qb);
    lc_tree *ts[2];
    int i;
    for (k = 0; k < s->nslots; k++) {
        uint32_t n;
        if (!(s->flags[k] & LC_SLOT_LIVE))
            continue;
        if (qb)
            lc_cells_of(g, s->box + 6 * k, &cells[k], qb + 2 * k);
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
    if (!qb || !scratch || lc_buf_reserve(a, &dyn->ent, sizeof(uint64_t), nd ? nd : 1) != LOCD_OK ||
        lc_buf_reserve(a, &sta->ent, sizeof(uint64_t), ns ? ns : 1) != LOCD_OK) {
        lc_free(a, qb, qcap * sizeof *qb);
        lc_free(a, scratch, (cap ? cap : 1) * sizeof *scratch);
        lc_tree_release(a, dyn);
        lc_tree_release(a, sta);
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
    ts[0] = dyn, ts[1] = sta;
    for (i = 0; i < 2; i++) {
        uint64_t *r = lc_radix_sort(ts[i]->ent.data, scratch, ts[i]->count, g->index_bits);
        if (r != ts[i]->ent.data)
            memcpy(ts[i]->ent.data, r, ts[i]->count * sizeof *r);
    }
    /* Number the objects in entry order and put the numbers in the entries.
       Keys stay sorted; within one key the order may change, which nothing
       relies on (tree.c). */
    for (k = 0; k < s->nslots; k++)
        dense[k] = UINT32_MAX;
    for (i = 0; i < 2; i++) {
        uint64_t *e = ts[i]->ent.data;
        for (j = 0; j < ts[i]->count; j++) {
            uint32_t slot = (uint32_t)(e[j] & imask);
            if (dense[slot] == UINT32_MAX) {
                dense[slot] = (uint32_t)next;
                lc_hot_fill(s, slot, qb + 2 * (size_t)slot, &hot[next]);
                next++;
            }
            e[j] = (e[j] & ~imask) | dense[slot];
        }
        lc_tree_count_levels(g, ts[i]);
        lc_tree_build_dir(a, g, ts[i]);
    }
    *ndense = next;
    lc_free(a, qb, qcap * sizeof *qb);
    lc_free(a, scratch, (cap ? cap : 1) * sizeof *scratch);
    return LOCD_OK;
}
