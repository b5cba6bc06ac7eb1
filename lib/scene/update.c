/* locd_scene_update and the lists it leaves. The new pair set, created and
 * lost lists are built in buffers of their own and swapped in at the end,
 * so a failing update (no memory, engine busy) changes nothing: the
 * pending changes stay pending for the next one. */
#include "scene/scene.h"

/* Forgets the changes the update has taken in. */
static void clear_changes(locd_scene *s)
{
    size_t k;
    const uint32_t *d = s->dirty.data;
    for (k = 0; k < s->ndirty; k++)
        s->flags[d[k]] &= (uint8_t)~LC_SLOT_DIRTY;
    s->ndirty = 0;
    lc_scene_free_removed(s);
}

static void swap_plist(lc_plist *a, lc_plist *b)
{
    lc_plist t = *a;
    *a = *b;
    *b = t;
}

locd_status locd_scene_update(locd_scene *s, uint32_t flags)
{
    const locd_allocator *a;
    lc_plist next = {{NULL, 0}, 0}, cr = {{NULL, 0}, 0}, lo = {{NULL, 0}, 0};
    locd_scene_stats stats;
    uint64_t candidates = 0, moved;
    double t0 = lc_now_ms(), t1;
    locd_status st;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK)
        return st;
    if (flags & ~(LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "unknown update flags 0x%x",
                        flags & ~(LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
    if (!lc_engine_acquire(s->engine))
        return lc_error(LOCD_ERR_BUSY, "the scene's engine is running another call");
    a = s->alloc;
    moved = s->ndirty;
    st = lc_scene_pairs_from_scratch(s, &next, &candidates);
    t1 = lc_now_ms();
    if (st == LOCD_OK && (flags & LOCD_SCENE_UPDATE_EVENTS)) {
        if ((st = lc_plist_reserve(a, &cr, next.count)) == LOCD_OK &&
            (st = lc_plist_reserve(a, &lo, s->pairs.count)) == LOCD_OK) {
            cr.count = lc_plist_minus(next.rows.data, next.count, s->pairs.rows.data, s->pairs.count, cr.rows.data);
            lo.count = lc_plist_minus(s->pairs.rows.data, s->pairs.count, next.rows.data, next.count, lo.rows.data);
        }
    }
    if (st != LOCD_OK) {
        lc_plist_fini(a, &next);
        lc_plist_fini(a, &cr);
        lc_plist_fini(a, &lo);
        lc_engine_release(s->engine);
        return st;
    }
    swap_plist(&s->pairs, &next);
    swap_plist(&s->created, &cr);
    swap_plist(&s->lost, &lo);
    lc_plist_fini(a, &next);
    lc_plist_fini(a, &cr);
    lc_plist_fini(a, &lo);
    clear_changes(s);
    s->show_pairs = (flags & LOCD_SCENE_UPDATE_PAIRS) != 0;
    s->show_events = (flags & LOCD_SCENE_UPDATE_EVENTS) != 0;

    locd_scene_stats_init(&stats);
    stats.threads = s->threads;
    stats.objects = s->live;
    stats.static_objects = s->live_static;
    stats.moved = moved;
    stats.reencoded = s->live;
    stats.candidates = candidates;
    stats.pairs = s->pairs.count;
    stats.created = s->created.count;
    stats.lost = s->lost.count;
    stats.rebuilt = 1;
    stats.ms_sweep = t1 - t0;
    stats.ms_events = lc_now_ms() - t1;
    stats.ms_total = lc_now_ms() - t0;
    s->stats = stats;
    lc_engine_release(s->engine);
    lc_clear_error();
    return LOCD_OK;
}

/* One of the lists of the last update; empty when not asked for. */
static locd_status give_list(const locd_scene *s, const lc_plist *p, int shown, const locd_id **pairs,
                             size_t *count)
{
    locd_status st;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK)
        return st;
    if (!pairs || !count)
        return lc_error(LOCD_ERR_NULL_POINTER, "pairs or count is NULL");
    *pairs = shown ? p->rows.data : NULL;
    *count = shown ? p->count : 0;
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_scene_pairs(const locd_scene *s, const locd_id **pairs, size_t *count)
{
    return give_list(s, s ? &s->pairs : NULL, s && s->show_pairs, pairs, count);
}

locd_status locd_scene_created(const locd_scene *s, const locd_id **pairs, size_t *count)
{
    return give_list(s, s ? &s->created : NULL, s && s->show_events, pairs, count);
}

locd_status locd_scene_lost(const locd_scene *s, const locd_id **pairs, size_t *count)
{
    return give_list(s, s ? &s->lost : NULL, s && s->show_events, pairs, count);
}
