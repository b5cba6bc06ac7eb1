/* Batch checks. Each runs before anything is changed, so a failing call
 * leaves the scene as it was; the error names the first bad position in the
 * batch (locd_last_error_index). */
#include "scene/scene.h"

/* One box, as doubles (a float converts exactly). */
static locd_status check_box(const double *b, size_t i)
{
    int a = 0;
    locd_status st = lc_scene_box_fault(b, &a);
    if (st == LOCD_ERR_NONFINITE)
        return lc_error_box(st, (int64_t)i, "box %zu has a non-finite coordinate", i);
    if (st == LOCD_ERR_INVERTED_BOX)
        return lc_error_box(st, (int64_t)i, "box %zu has min > max on axis %d", i, a);
    return LOCD_OK;
}

locd_status lc_scene_check_boxes_f32(const float *boxes, size_t n)
{
    size_t i;
    int a;
    locd_status st;
    if (n && !boxes)
        return lc_error(LOCD_ERR_NULL_POINTER, "boxes is NULL");
    for (i = 0; i < n; i++) {
        double b[6];
        for (a = 0; a < 6; a++)
            b[a] = boxes[6 * i + (size_t)a];
        if ((st = check_box(b, i)) != LOCD_OK)
            return st;
    }
    return LOCD_OK;
}

locd_status lc_scene_check_boxes_f64(const double *boxes, size_t n)
{
    size_t i;
    locd_status st;
    if (n && !boxes)
        return lc_error(LOCD_ERR_NULL_POINTER, "boxes is NULL");
    for (i = 0; i < n; i++)
        if ((st = check_box(boxes + 6 * i, i)) != LOCD_OK)
            return st;
    return LOCD_OK;
}

locd_status lc_scene_check_handle(const locd_scene *s)
{
    if (!s || s->magic != LC_MAGIC_SCENE)
        return lc_error(LOCD_ERR_INVALID_HANDLE, "not a scene handle");
    return LOCD_OK;
}

locd_status lc_scene_check_ids_live(const locd_scene *s, const locd_id *ids, size_t n)
{
    size_t k;
    if (n && !ids)
        return lc_error(LOCD_ERR_NULL_POINTER, "ids is NULL");
    for (k = 0; k < n; k++) {
        if (k + LC_AHEAD < n)
            lc_slot_prefetch(&s->slots, ids[k + LC_AHEAD]);
        if (lc_scene_slot(s, ids[k]) < 0)
            return lc_error_box(LOCD_ERR_STALE_ID, (int64_t)k,
                                "id %llu at %zu was removed or never issued by this scene",
                                (unsigned long long)ids[k], k);
    }
    return LOCD_OK;
}

locd_status lc_scene_check_ids(locd_scene *s, const locd_id *ids, size_t n)
{
    size_t k;
    locd_status st = lc_scene_check_ids_live(s, ids, n);
    if (st)
        return st;
    /* A stamp per batch marks the slots seen; the stamps are scratch, not
       state, so a failing batch may leave them changed. */
    if (++s->slots.stamp_now == 0) {
        memset(s->slots.stamp, 0, s->slots.slot_cap * sizeof *s->slots.stamp);
        s->slots.stamp_now = 1;
    }
    for (k = 0; k < n; k++) {
        uint32_t slot = LC_ID_SLOT(ids[k]);
        if (k + LC_AHEAD < n) /* the ids are live: their slots are in range */
            __builtin_prefetch(s->slots.stamp + LC_ID_SLOT(ids[k + LC_AHEAD]), 1);
        if (s->slots.stamp[slot] == s->slots.stamp_now)
            return lc_error_box(LOCD_ERR_DUPLICATE_ID, (int64_t)k, "id %llu at %zu appears earlier in the batch",
                                (unsigned long long)ids[k], k);
        s->slots.stamp[slot] = s->slots.stamp_now;
    }
    return LOCD_OK;
}
