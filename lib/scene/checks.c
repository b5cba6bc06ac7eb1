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

/* A new stamp for a batch (the stamps are scratch, not state: a failing
 * batch may leave them changed). */
static uint32_t new_stamp(lc_slots *sl)
{
    if (++sl->stamp_now == 0) {
        memset(sl->stamp, 0, sl->slot_cap * sizeof *sl->stamp);
        sl->stamp_now = 1;
    }
    return sl->stamp_now;
}

/* Position k of a batch: its id live and not earlier in the batch, its box
 * (when boxes is not NULL) valid. */
static locd_status check_position(locd_scene *s, const locd_id *ids, const void *boxes, int f64, size_t k)
{
    lc_slots *sl = &s->slots;
    const int64_t slot = lc_scene_slot(s, ids[k]);
    if (slot < 0)
        return lc_error_box(LOCD_ERR_STALE_ID, (int64_t)k, "id %llu at %zu was removed or never issued by this scene",
                            (unsigned long long)ids[k], k);
    if (sl->stamp[slot] == sl->stamp_now)
        return lc_error_box(LOCD_ERR_DUPLICATE_ID, (int64_t)k, "id %llu at %zu appears earlier in the batch",
                            (unsigned long long)ids[k], k);
    sl->stamp[slot] = sl->stamp_now;
    if (boxes) {
        double b[6];
        int a;
        for (a = 0; a < 6; a++)
            b[a] = f64 ? ((const double *)boxes)[6 * k + (size_t)a] : (double)((const float *)boxes)[6 * k + (size_t)a];
        return check_box(b, k);
    }
    return LOCD_OK;
}

locd_status lc_scene_check_count(const locd_scene *s, size_t n)
{
    if (n > s->slots.live) /* such a batch repeats or names a stale id; its arrays may be shorter */
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "%zu ids, more than the scene's %zu objects", n, s->slots.live);
    return LOCD_OK;
}

locd_status lc_scene_check_batch(locd_scene *s, const locd_id *ids, const void *boxes, int f64, size_t n)
{
    size_t k;
    locd_status st;
    if ((st = lc_scene_check_count(s, n)) != LOCD_OK)
        return st;
    if (n && !ids)
        return lc_error(LOCD_ERR_NULL_POINTER, "ids is NULL");
    new_stamp(&s->slots);
    for (k = 0; k < n; k++) {
        if (k + LC_AHEAD < n)
            lc_slot_prefetch(&s->slots, ids[k + LC_AHEAD]);
        if ((st = check_position(s, ids, boxes, f64, k)) != LOCD_OK)
            return st;
    }
    return LOCD_OK;
}

locd_status lc_scene_check_ids(locd_scene *s, const locd_id *ids, size_t n)
{
    return lc_scene_check_batch(s, ids, NULL, 0, n);
}
