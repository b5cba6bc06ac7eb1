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
