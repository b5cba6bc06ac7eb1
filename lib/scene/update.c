/* locd_scene_update: the path chosen (path.c), taken, and its result made
 * the scene's. A path may find on its way that another one fits (a box
 * left the near-pair list's fat box, a box left the root cube, most moved
 * objects left their fat boxes): the update then chooses again, with what
 * it found. Each path builds its new set in buffers of its own; commit
 * swaps them in. A failing update changes nothing: the pending changes
 * stay pending for the next one. docs/scene.md, "The paths". */
#include "scene/scene.h"
#include "scene/update.h"

/* The pairs from scratch; the entry lists are dropped at commit and built
 * again only by the next update that searches moved objects (a relist): a
 * scene where most objects move every frame never pays for them. With
 * `near`, the near-pair list is built from these boxes and gives the set
 * (the next updates may take it; the kept entry list is not needed while
 * they do); when it cannot be, from scratch as without. */
static locd_status from_scratch(lc_update *u, int near)
{
    locd_scene *s = u->s;
    locd_status st;
    double t1 = lc_now_ms();
    int built = 0;
    if (near) {
        st = lc_near_build(s, &u->next, &u->candidates, &built);
        if (st != LOCD_OK || !built) {
            lc_clear_error(); /* a cache: without it, from scratch */
            u->next.count = u->next.first = 0;
        } else {
            lc_kept_release(s);
        }
    }
    if (!built && (st = lc_from_scratch_pairs(s, &u->next, &u->candidates)) != LOCD_OK)
        return st;
    u->ms_sweep = lc_now_ms() - t1;
    t1 = lc_now_ms();
    if ((u->flags & LOCD_SCENE_UPDATE_EVENTS) && (st = lc_pair_set_diff(s, &u->next, &u->cr, &u->lo)) != LOCD_OK)
        return st;
    u->ms_events = lc_now_ms() - t1;
    return LOCD_OK;
}

/* The near-pair list's pass; *found when a box left its fat box. */
static locd_status near(lc_update *u, lc_finding *found)
{
    locd_scene *s = u->s;
    double t1 = lc_now_ms();
    int left, diff;
    locd_status st = lc_near_frame(s, &u->next, &u->cr, &u->lo, &u->candidates, &left, &diff);
    if (st != LOCD_OK)
        return st;
    if (left) {
        lc_backoff_near_left(&s->backoff, s->near.served);
        u->next.count = u->next.first = 0;
        *found = LC_FOUND_LEFT_NEAR;
        return LOCD_OK;
    }
    u->ms_sweep = lc_now_ms() - t1;
    t1 = lc_now_ms();
    if (diff && (u->flags & LOCD_SCENE_UPDATE_EVENTS) && (st = lc_pair_set_diff(s, &u->next, &u->cr, &u->lo)) != LOCD_OK)
        return st;
    u->ms_events = lc_now_ms() - t1;
    return LOCD_OK;
}

/* Path p, taken; *found what it found that makes the update choose again. */
static locd_status take_path(lc_update *u, lc_path p, lc_finding *found)
{
    *found = LC_FOUND_NOTHING;
    switch (p) {
    case LC_PATH_NEAR:
        return near(u, found);
    case LC_PATH_INCREMENTAL:
        return lc_incremental(u, found);
    case LC_PATH_RELIST:
        return lc_relist(u);
    case LC_PATH_NEAR_BUILD:
        return from_scratch(u, 1);
    default:
        return from_scratch(u, 0);
    }
}

/* The path chosen and taken, chosen again after each finding. */
static locd_status run(lc_update *u)
{
    locd_scene *s = u->s;
    lc_finding found = LC_FOUND_NOTHING;
    lc_path_facts f;
    locd_status st;
    do {
        lc_path_facts_of(s, u->moved, found, &f);
        u->path = lc_path_choose(&f);
        lc_backoff_chose(&s->backoff, &f, u->path);
        if (u->path != LC_PATH_NEAR)
            lc_near_forget(s); /* only a run of updates in which most objects moved keeps it */
        st = take_path(u, u->path, &found);
    } while (st == LOCD_OK && found != LC_FOUND_NOTHING);
    return st;
}

/* The update's lists made the scene's. */
static void commit(lc_update *u)
{
    locd_scene *s = u->s;
    switch (u->path) {
    case LC_PATH_INCREMENTAL:
        lc_incremental_commit(u);
        break;
    case LC_PATH_RELIST:
        break;
    default: /* from scratch, near: the lists are built again by the next update that needs them */
        lc_entries_drop(s);
        lc_partners_drop(s);
        break;
    }
    lc_pair_set_take(&s->set, &u->next, u->in_place, &u->cr, &u->lo);
    s->set.show_pairs = (u->flags & LOCD_SCENE_UPDATE_PAIRS) != 0;
    s->set.show_events = (u->flags & LOCD_SCENE_UPDATE_EVENTS) != 0;
    lc_query_tree_note_update(s);
    lc_slots_clear_changes(s);
}

static void fill_stats(const lc_update *u, double t0)
{
    locd_scene *s = u->s;
    locd_scene_stats *o = &s->stats;
    const int scratch = u->path == LC_PATH_FROM_SCRATCH || u->path == LC_PATH_NEAR_BUILD;
    locd_scene_stats_init(o);
    o->threads = s->threads;
    o->objects = s->slots.live;
    o->static_objects = s->slots.live_static;
    o->moved = u->moved;
    o->reencoded = u->reencoded;
    o->entries = s->entries.dyn.count + s->entries.sta.count;
    o->candidates = u->candidates + u->found.candidates;
    o->pairs = s->set.pairs.count;
    o->created = s->set.created.count;
    o->lost = s->set.lost.count;
    o->rebuilt = (uint32_t)scratch;
    o->coasted = (uint32_t)(u->path == LC_PATH_NEAR ? u->moved : u->nstay);
    o->ms_encode = u->ms_encode;
    o->ms_merge = u->ms_merge;
    o->ms_sweep = u->ms_sweep;
    o->ms_events = u->ms_events;
    o->ms_total = lc_now_ms() - t0;
}

locd_status locd_scene_update(locd_scene *s, uint32_t flags)
{
    const uint32_t known = LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS;
    const double t0 = lc_now_ms();
    lc_update u;
    locd_status st;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK)
        return st;
    if (flags & ~known)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "unknown update flags 0x%x", flags & ~known);
    if (!lc_engine_acquire(s->engine))
        return lc_error(LOCD_ERR_BUSY, "the scene's engine is running another call");
    memset(&u, 0, sizeof u);
    u.s = s;
    u.flags = flags;
    lc_update_adopt(&u);
    lc_pair_set_lend(&s->set, &u.next, &u.cr, &u.lo);
    u.moved = lc_slots_live_dirty(s); /* every path's count: the live objects of the dirty list */
    if ((st = run(&u)) != LOCD_OK) {
        lc_near_forget(s); /* its PAIRED bits may be this update's */
        lc_incremental_undo(&u);
        lc_pair_set_give_back(&s->set, &u.next, &u.cr, &u.lo);
        lc_update_free(&u);
        lc_engine_release(s->engine);
        return st;
    }
    commit(&u);
    fill_stats(&u, t0);
    lc_update_free(&u);
    lc_engine_release(s->engine);
    lc_clear_error();
    return LOCD_OK;
}
