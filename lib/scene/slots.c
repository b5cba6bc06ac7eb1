/* Slots and ids. A slot holds one object's box, filter and user value in
 * arrays indexed by slot; an id is the add's serial number (high 32 bits)
 * and the slot (low 32). A removed object's slot is freed only by the next
 * update, after the broad phase has dropped its entries, so a slot never
 * holds two objects between two updates. Serials are never reused, so an
 * id is never reused either, and a stale id never aliases a new object:
 * the slot's current id must equal it. */
#include "scene/scene.h"

int64_t lc_scene_slot(const locd_scene *s, locd_id id)
{
    uint32_t slot = LC_ID_SLOT(id);
    if (id == LOCD_ID_NONE || slot >= s->nslots)
        return -1;
    if (s->id[slot] != id || !(s->flags[slot] & LC_SLOT_LIVE))
        return -1;
    return slot;
}

/* Grows one per-slot array to cap elements (the old contents kept). */
static int grow(const locd_allocator *a, void **p, size_t elem, size_t old_cap, size_t cap)
{
    void *q = lc_alloc(a, elem * cap);
    if (!q)
        return 0;
    if (*p) {
        memcpy(q, *p, elem * old_cap);
        lc_free(a, *p, elem * old_cap);
    }
    memset((char *)q + elem * old_cap, 0, elem * (cap - old_cap));
    *p = q;
    return 1;
}

locd_status lc_scene_reserve(locd_scene *s, size_t more)
{
    size_t need, cap, old;
    /* 11 slot arrays and, last, the free list's room */
    void **arrays[12];
    size_t elems[12];
    void *fresh[12];
    int k, nk = 12;
    if (more <= s->nfree)
        return LOCD_OK;
    need = s->nslots + (more - s->nfree);
    if (need > (size_t)UINT32_MAX)
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "a scene holds at most %u slots", UINT32_MAX);
    if (need <= s->slot_cap)
        return LOCD_OK;
    old = s->slot_cap;
    cap = lc_grow_cap(old, need);
    if (cap > (size_t)UINT32_MAX)
        cap = UINT32_MAX;
    arrays[0] = (void **)&s->id, elems[0] = sizeof(locd_id);
    arrays[1] = (void **)&s->box, elems[1] = 6 * sizeof(double);
    arrays[2] = (void **)&s->cat, elems[2] = sizeof(uint64_t);
    arrays[3] = (void **)&s->mask, elems[3] = sizeof(uint64_t);
    arrays[4] = (void **)&s->group, elems[4] = sizeof(uint64_t);
    arrays[5] = (void **)&s->user, elems[5] = sizeof(uint64_t);
    arrays[6] = (void **)&s->flags, elems[6] = sizeof(uint8_t);
    arrays[7] = (void **)&s->stamp, elems[7] = sizeof(uint32_t);
    arrays[8] = (void **)&s->cell, elems[8] = sizeof(lc_cells);
    arrays[9] = (void **)&s->dense, elems[9] = sizeof(uint32_t);
    arrays[10] = (void **)&s->fbox, elems[10] = 6 * sizeof(float);
    arrays[11] = NULL, elems[11] = sizeof(uint32_t); /* the free list's room */
    /* All or nothing: allocate every new array first, then swap them in. */
    for (k = 0; k < nk; k++) {
        fresh[k] = NULL;
        if (k == 1 && !s->keep_f64)
            continue; /* no doubles kept */
        if (k == 11) {
            if (lc_buf_reserve(s->alloc, &s->free_slots, sizeof(uint32_t), cap) != LOCD_OK)
                break;
            continue;
        }
        if (!grow(s->alloc, &fresh[k], elems[k], 0, cap))
            break;
    }
    if (k < nk) {
        int j;
        for (j = 0; j < k && j < 11; j++)
            if (fresh[j])
                lc_free(s->alloc, fresh[j], elems[j] * cap);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not grow the scene to %zu slots", cap);
    }
    for (k = 0; k < 11; k++) {
        if (*arrays[k]) {
            memcpy(fresh[k], *arrays[k], elems[k] * old);
            lc_free(s->alloc, *arrays[k], elems[k] * old);
        }
        *arrays[k] = fresh[k];
    }
    s->slot_cap = cap;
    return LOCD_OK;
}

uint32_t lc_scene_take_slot(locd_scene *s)
{
    if (s->nfree)
        return ((uint32_t *)s->free_slots.data)[--s->nfree];
    return (uint32_t)s->nslots++;
}

locd_status lc_scene_reserve_lists(locd_scene *s, size_t more_dirty, size_t more_removed)
{
    if (lc_buf_reserve(s->alloc, &s->dirty, sizeof(uint32_t), s->ndirty + more_dirty) != LOCD_OK ||
        lc_buf_reserve(s->alloc, &s->removed, sizeof(uint32_t), s->nremoved + more_removed) != LOCD_OK)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not grow the scene's change lists");
    return LOCD_OK;
}

locd_status lc_scene_need_doubles(locd_scene *s, const double *boxes, size_t n)
{
    size_t k, bytes = s->slot_cap * 6 * sizeof(double);
    double *b;
    if (s->keep_f64)
        return LOCD_OK;
    for (k = 0; k < 6 * n; k++)
        if ((double)(float)boxes[k] != boxes[k])
            break;
    if (k == 6 * n)
        return LOCD_OK;
    b = s->slot_cap ? lc_alloc(s->alloc, bytes) : NULL;
    if (s->slot_cap && !b)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate %zu bytes for the scene's double boxes", bytes);
    for (k = 0; k < 6 * s->slot_cap; k++)
        b[k] = (double)s->fbox[k];
    s->box = b;
    s->keep_f64 = 1;
    return LOCD_OK;
}

int lc_scene_put_box(locd_scene *s, uint32_t slot, const void *boxes, int f64, size_t i)
{
    float *f = s->fbox + 6 * (size_t)slot;
    int a, exact = 1, was = (s->flags[slot] & LC_SLOT_INEXACT) != 0;
    if (f64) {
        const double *in = (const double *)boxes + 6 * i;
        for (a = 0; a < 6; a++) {
            f[a] = (float)in[a];
            exact &= (double)f[a] == in[a];
        }
        if (s->keep_f64)
            memcpy(s->box + 6 * (size_t)slot, in, 6 * sizeof(double));
    } else {
        const float *in = (const float *)boxes + 6 * i;
        for (a = 0; a < 6; a++)
            f[a] = in[a];
        if (s->keep_f64)
            for (a = 0; a < 6; a++)
                s->box[6 * (size_t)slot + (size_t)a] = (double)in[a];
    }
    s->flags[slot] = (uint8_t)((s->flags[slot] & ~LC_SLOT_INEXACT) | (exact ? 0 : LC_SLOT_INEXACT));
    return !exact - was;
}

void lc_scene_set_box(locd_scene *s, uint32_t slot, const void *boxes, int f64, size_t i)
{
    s->ninexact = (size_t)((int64_t)s->ninexact + lc_scene_put_box(s, slot, boxes, f64, i));
}

void lc_scene_mark_dirty(locd_scene *s, uint32_t slot)
{
    if (s->flags[slot] & LC_SLOT_DIRTY)
        return;
    s->flags[slot] |= LC_SLOT_DIRTY;
    ((uint32_t *)s->dirty.data)[s->ndirty++] = slot;
}

void lc_scene_free_removed(locd_scene *s)
{
    size_t k;
    const uint32_t *r = s->removed.data;
    /* Freed in reverse so that the stack hands them out in removal order. */
    for (k = s->nremoved; k-- > 0;) {
        s->flags[r[k]] = 0;
        ((uint32_t *)s->free_slots.data)[s->nfree++] = r[k];
    }
    s->nremoved = 0;
}

void lc_scene_slots_fini(locd_scene *s)
{
    size_t c = s->slot_cap;
    lc_free(s->alloc, s->id, c * sizeof(locd_id));
    if (s->box)
        lc_free(s->alloc, s->box, c * 6 * sizeof(double));
    lc_free(s->alloc, s->fbox, c * 6 * sizeof(float));
    lc_free(s->alloc, s->fbox_spare, s->fbox_spare_cap * 6 * sizeof(float));
    lc_free(s->alloc, s->cat, c * sizeof(uint64_t));
    lc_free(s->alloc, s->mask, c * sizeof(uint64_t));
    lc_free(s->alloc, s->group, c * sizeof(uint64_t));
    lc_free(s->alloc, s->user, c * sizeof(uint64_t));
    lc_free(s->alloc, s->flags, c * sizeof(uint8_t));
    lc_free(s->alloc, s->stamp, c * sizeof(uint32_t));
    lc_free(s->alloc, s->cell, c * sizeof(lc_cells));
    lc_free(s->alloc, s->dense, c * sizeof(uint32_t));
    lc_free(s->alloc, s->hot, s->hot_cap * sizeof(lc_hot));
    lc_free(s->alloc, s->hq, s->hot_cap * LC_HQ * sizeof(uint64_t));
    lc_adj_drop(s);
    lc_buf_release(s->alloc, &s->free_slots, sizeof(uint32_t));
    lc_buf_release(s->alloc, &s->dirty, sizeof(uint32_t));
    lc_buf_release(s->alloc, &s->removed, sizeof(uint32_t));
}
