/* Slots and ids. A slot holds one object's box, filter and user value in
 * arrays indexed by slot; an id is the add's serial number (high 32 bits)
 * and the slot (low 32). A removed object's slot is freed only by the next
 * update, after the broad phase has dropped its entries, so a slot never
 * holds two objects between two updates. Serials are never reused, so an
 * id is never reused either, and a stale id never aliases a new object:
 * the slot's current id must equal it. */
#include "scene/scene.h"

/* The flag bytes counted in blocks whose count fits 32 bits: the inner
 * loop vectorizes. */
#define LC_COUNT_BLOCK 65536

int64_t lc_scene_slot(const locd_scene *s, locd_id id)
{
    uint32_t slot = LC_ID_SLOT(id);
    if (id == LOCD_ID_NONE || slot >= s->slots.nslots)
        return -1;
    if (s->slots.id[slot] != id || !(s->slots.flags[slot] & LC_SLOT_LIVE))
        return -1;
    return slot;
}

/* The per-slot arrays (the entry lists' per-slot arrays grow with the
 * slots) and their element sizes; box is NULL until doubles are kept. */
#define LC_SLOT_ARRAYS 11
static void slot_arrays(locd_scene *s, void **arrays[LC_SLOT_ARRAYS], size_t elems[LC_SLOT_ARRAYS])
{
    arrays[0] = (void **)&s->slots.id, elems[0] = sizeof(locd_id);
    arrays[1] = (void **)&s->slots.box, elems[1] = 6 * sizeof(double);
    arrays[2] = (void **)&s->slots.cat, elems[2] = sizeof(uint64_t);
    arrays[3] = (void **)&s->slots.mask, elems[3] = sizeof(uint64_t);
    arrays[4] = (void **)&s->slots.group, elems[4] = sizeof(uint64_t);
    arrays[5] = (void **)&s->slots.user, elems[5] = sizeof(uint64_t);
    arrays[6] = (void **)&s->slots.flags, elems[6] = sizeof(uint8_t);
    arrays[7] = (void **)&s->slots.stamp, elems[7] = sizeof(uint32_t);
    arrays[8] = (void **)&s->entries.cell, elems[8] = sizeof(lc_cells);
    arrays[9] = (void **)&s->entries.dense, elems[9] = sizeof(uint32_t);
    arrays[10] = (void **)&s->slots.fbox, elems[10] = 6 * sizeof(float);
}

/* Every array for cap slots, zeroed, and the free list's room: all or
 * nothing (0, nothing allocated, on no memory). */
static int alloc_arrays(locd_scene *s, const size_t elems[LC_SLOT_ARRAYS], void *fresh[LC_SLOT_ARRAYS], size_t cap)
{
    int k;
    for (k = 0; k < LC_SLOT_ARRAYS; k++) {
        fresh[k] = NULL;
        if (k == 1 && !s->slots.keep_f64)
            continue; /* no doubles kept */
        if (!(fresh[k] = lc_alloc(s->alloc, elems[k] * cap)))
            break;
        memset(fresh[k], 0, elems[k] * cap);
    }
    if (k == LC_SLOT_ARRAYS && lc_buf_reserve(s->alloc, &s->slots.free_slots, sizeof(uint32_t), cap) == LOCD_OK)
        return 1;
    while (k-- > 0)
        lc_free(s->alloc, fresh[k], elems[k] * cap);
    return 0;
}

locd_status lc_scene_reserve(locd_scene *s, size_t more)
{
    void **arrays[LC_SLOT_ARRAYS];
    size_t elems[LC_SLOT_ARRAYS], need, cap, old;
    void *fresh[LC_SLOT_ARRAYS];
    int k;
    if (more <= s->slots.nfree)
        return LOCD_OK;
    need = s->slots.nslots + (more - s->slots.nfree);
    if (need > (size_t)UINT32_MAX)
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "a scene holds at most %u slots", UINT32_MAX);
    if (need <= s->slots.slot_cap)
        return LOCD_OK;
    old = s->slots.slot_cap;
    cap = lc_grow_cap(old, need);
    if (cap > (size_t)UINT32_MAX)
        cap = UINT32_MAX;
    slot_arrays(s, arrays, elems);
    if (!alloc_arrays(s, elems, fresh, cap))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not grow the scene to %zu slots", cap);
    for (k = 0; k < LC_SLOT_ARRAYS; k++) {
        if (*arrays[k]) {
            memcpy(fresh[k], *arrays[k], elems[k] * old);
            lc_free(s->alloc, *arrays[k], elems[k] * old);
        }
        *arrays[k] = fresh[k];
    }
    s->slots.slot_cap = cap;
    return LOCD_OK;
}

uint32_t lc_scene_take_slot(locd_scene *s)
{
    if (s->slots.nfree)
        return ((uint32_t *)s->slots.free_slots.data)[--s->slots.nfree];
    return (uint32_t)s->slots.nslots++;
}

locd_status lc_scene_reserve_lists(locd_scene *s, size_t more_dirty, size_t more_removed)
{
    if (lc_buf_reserve(s->alloc, &s->slots.dirty, sizeof(uint32_t), s->slots.ndirty + more_dirty) != LOCD_OK ||
        lc_buf_reserve(s->alloc, &s->slots.removed, sizeof(uint32_t), s->slots.nremoved + more_removed) != LOCD_OK)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not grow the scene's change lists");
    return LOCD_OK;
}

locd_status lc_scene_need_doubles(locd_scene *s, const double *boxes, size_t n)
{
    size_t k, bytes = s->slots.slot_cap * 6 * sizeof(double);
    double *b;
    if (s->slots.keep_f64)
        return LOCD_OK;
    for (k = 0; k < 6 * n; k++)
        if ((double)(float)boxes[k] != boxes[k])
            break;
    if (k == 6 * n)
        return LOCD_OK;
    b = s->slots.slot_cap ? lc_alloc(s->alloc, bytes) : NULL;
    if (s->slots.slot_cap && !b)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate %zu bytes for the scene's double boxes", bytes);
    for (k = 0; k < 6 * s->slots.slot_cap; k++)
        b[k] = (double)s->slots.fbox[k];
    s->slots.box = b;
    s->slots.keep_f64 = 1;
    return LOCD_OK;
}

int lc_scene_put_box(locd_scene *s, uint32_t slot, const void *boxes, int f64, size_t i)
{
    float *f = s->slots.fbox + 6 * (size_t)slot;
    int a, exact = 1, was = (s->slots.flags[slot] & LC_SLOT_INEXACT) != 0;
    if (f64) {
        const double *in = (const double *)boxes + 6 * i;
        for (a = 0; a < 6; a++) {
            f[a] = (float)in[a];
            exact &= (double)f[a] == in[a];
        }
        if (s->slots.keep_f64)
            memcpy(s->slots.box + 6 * (size_t)slot, in, 6 * sizeof(double));
    } else {
        const float *in = (const float *)boxes + 6 * i;
        for (a = 0; a < 6; a++)
            f[a] = in[a];
        if (s->slots.keep_f64)
            for (a = 0; a < 6; a++)
                s->slots.box[6 * (size_t)slot + (size_t)a] = (double)in[a];
    }
    s->slots.flags[slot] = (uint8_t)((s->slots.flags[slot] & ~LC_SLOT_INEXACT) | (exact ? 0 : LC_SLOT_INEXACT));
    return !exact - was;
}

void lc_scene_set_box(locd_scene *s, uint32_t slot, const void *boxes, int f64, size_t i)
{
    s->slots.ninexact = (size_t)((int64_t)s->slots.ninexact + lc_scene_put_box(s, slot, boxes, f64, i));
}

void lc_scene_mark_dirty(locd_scene *s, uint32_t slot)
{
    if (s->slots.flags[slot] & LC_SLOT_DIRTY)
        return;
    s->slots.flags[slot] |= LC_SLOT_DIRTY;
    ((uint32_t *)s->slots.dirty.data)[s->slots.ndirty++] = slot;
}

void lc_scene_free_removed(locd_scene *s)
{
    size_t k;
    const uint32_t *r = s->slots.removed.data;
    /* Freed in reverse so that the stack hands them out in removal order. */
    for (k = s->slots.nremoved; k-- > 0;) {
        s->slots.flags[r[k]] = 0;
        ((uint32_t *)s->slots.free_slots.data)[s->slots.nfree++] = r[k];
    }
    s->slots.nremoved = 0;
}

void lc_scene_slots_fini(locd_scene *s)
{
    lc_slots *sl = &s->slots;
    const size_t c = sl->slot_cap;
    lc_free(s->alloc, sl->id, c * sizeof(locd_id));
    if (sl->box)
        lc_free(s->alloc, sl->box, c * 6 * sizeof(double));
    lc_free(s->alloc, sl->fbox, c * 6 * sizeof(float));
    lc_free(s->alloc, sl->fbox_spare, sl->fbox_spare_cap * 6 * sizeof(float));
    lc_free(s->alloc, sl->cat, c * sizeof(uint64_t));
    lc_free(s->alloc, sl->mask, c * sizeof(uint64_t));
    lc_free(s->alloc, sl->group, c * sizeof(uint64_t));
    lc_free(s->alloc, sl->user, c * sizeof(uint64_t));
    lc_free(s->alloc, sl->flags, c * sizeof(uint8_t));
    lc_free(s->alloc, sl->stamp, c * sizeof(uint32_t));
    lc_buf_release(s->alloc, &sl->free_slots, sizeof(uint32_t));
    lc_buf_release(s->alloc, &sl->dirty, sizeof(uint32_t));
    lc_buf_release(s->alloc, &sl->removed, sizeof(uint32_t));
}

/* 1 when the slots [0, nslots) are all live and their serials ascend: then
 * slot order is id order and the slot arrays are the engine's input as
 * they are (the common case: no object removed). 2 when, besides, the
 * serials are consecutive: then the id of slot k is
 * (serial of slot 0 + k) << 32 | k, and the pair order writes its rows
 * without reading the ids (each a cache miss: a pair's j is anywhere). */
int lc_slots_in_id_order(locd_scene *s)
{
    lc_slots *sl = &s->slots;
    size_t k;
    int affine = 1;
    if (sl->order_known >= 0)
        return sl->order_known;
    sl->order_known = 0;
    if (sl->live != sl->nslots)
        return 0;
    for (k = 0; k < sl->nslots; k++) {
        if (!(sl->flags[k] & LC_SLOT_LIVE) || (k && LC_ID_SERIAL(sl->id[k]) <= LC_ID_SERIAL(sl->id[k - 1])))
            return 0;
        affine &= (uint64_t)LC_ID_SERIAL(sl->id[k]) == (uint64_t)LC_ID_SERIAL(sl->id[0]) + k;
    }
    return sl->order_known = 1 + affine;
}

int lc_slots_filter_passes_all(locd_scene *s, const uint32_t *live, size_t n)
{
    lc_slots *sl = &s->slots;
    uint64_t m = ~(uint64_t)0;
    size_t k;
    if (sl->filter_known >= 0)
        return sl->filter_known;
    sl->filter_known = 0;
    if (sl->live_static)
        return 0;
    for (k = 0; k < n; k++) {
        m &= sl->mask[lc_slot_at(live, k)];
        if (sl->group[lc_slot_at(live, k)])
            return 0;
    }
    for (k = 0; k < n; k++)
        if (!(sl->cat[lc_slot_at(live, k)] & m))
            return 0;
    return sl->filter_known = 1;
}

void lc_slots_forget_order(lc_slots *sl)
{
    sl->order_known = -1;
}

void lc_slots_forget_filter(lc_slots *sl)
{
    sl->filter_known = -1;
}

/* A slot is on the dirty list iff its DIRTY flag is set (REFILTER is set
 * only with it). A list of an eighth of the slots or more is walked as the
 * flags of every slot, in order: a pass over one byte a slot, in vector
 * steps, instead of a read at each listed slot, for the count and for the
 * clearing below (docs/scene.md, step 5, has the measurement). */
LC_INLINE int dirty_dense(const locd_scene *s)
{
    return s->slots.ndirty >= s->slots.nslots / 8;
}

size_t lc_slots_live_dirty(const locd_scene *s)
{
    const uint32_t *d = s->slots.dirty.data;
    const uint8_t both = LC_SLOT_LIVE | LC_SLOT_DIRTY, *f = s->slots.flags;
    const size_t n = s->slots.nslots;
    size_t k, moved = 0;
    if (!dirty_dense(s)) {
        for (k = 0; k < s->slots.ndirty; k++)
            moved += (s->slots.flags[d[k]] & LC_SLOT_LIVE) != 0;
        return moved;
    }
    for (k = 0; k < n;) { /* blocks whose count fits 32 bits: the inner loop vectorizes */
        const size_t e = n - k > LC_COUNT_BLOCK ? k + LC_COUNT_BLOCK : n;
        uint32_t c = 0;
        for (; k < e; k++)
            c += (f[k] & both) == both;
        moved += c;
    }
    return moved;
}

void lc_slots_clear_changes(locd_scene *s)
{
    size_t k;
    const uint32_t *d = s->slots.dirty.data;
    const uint8_t keep = (uint8_t) ~(LC_SLOT_DIRTY | LC_SLOT_REFILTER);
    if (dirty_dense(s)) {
        uint8_t *f = s->slots.flags; /* in locals: a byte store may alias s's fields, read again at each step */
        const size_t n = s->slots.nslots;
        for (k = 0; k < n; k++)
            f[k] &= keep;
    } else {
        for (k = 0; k < s->slots.ndirty; k++) {
            if (k + 2 * LC_AHEAD < s->slots.ndirty) /* scattered: evicted by the pass over the set */
                __builtin_prefetch(s->slots.flags + d[k + 2 * LC_AHEAD], 1);
            s->slots.flags[d[k]] &= keep;
        }
    }
    s->slots.ndirty = 0;
    lc_scene_free_removed(s);
}
