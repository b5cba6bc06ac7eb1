/* The scene handle and its changes: add, move, remove, set_filter,
 * set_user. Each change call checks the whole batch and reserves all the
 * memory it needs before it changes anything, so a failing call leaves the
 * scene as it was. The broad phase sees the changes at the next update
 * (update.c) through the dirty and removed lists. */
#include "scene/scene.h"
#include "scene/update.h"

void locd_scene_config_init(locd_scene_config *config)
{
    if (!config)
        return;
    memset(config, 0, sizeof *config);
    config->size = sizeof *config;
}

void locd_scene_add_options_init(locd_scene_add_options *options)
{
    if (!options)
        return;
    memset(options, 0, sizeof *options);
    options->size = sizeof *options;
    options->category = 1;
    options->mask = ~(uint64_t)0;
}

locd_status locd_scene_create(locd_engine *engine, const locd_scene_config *config, locd_scene **out)
{
    locd_scene_config cfg;
    locd_scene *s;
    locd_status st;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    if ((st = lc_engine_check(engine)) != LOCD_OK)
        return st;
    locd_scene_config_init(&cfg);
    if (config && (st = lc_struct_in(&cfg, sizeof cfg, config, LOCD_SCENE_CONFIG_MIN_SIZE, "config")) != LOCD_OK)
        return st;
    if (cfg.flags & ~LOCD_SCENE_NO_NEAR_LIST)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "config->flags 0x%x: unknown flags 0x%x", cfg.flags,
                        cfg.flags & ~LOCD_SCENE_NO_NEAR_LIST);
    if (engine->level != LOCD_LEVEL_INPROCESS)
        return lc_error(LOCD_ERR_UNSUPPORTED,
                        "a scene needs an engine of level 1 (LOCD_LEVEL_INPROCESS); this engine is level %d "
                        "(docs/levels.md)",
                        (int)engine->level);
    s = lc_alloc(&engine->alloc, sizeof *s);
    if (!s)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the scene");
    memset(s, 0, sizeof *s);
    s->magic = LC_MAGIC_SCENE;
    lc_slots_forget_order(&s->slots);
    lc_slots_forget_filter(&s->slots);
    s->engine = engine;
    s->alloc = &engine->alloc;
    s->pool = lc_inproc_pool(engine, &s->kernel);
    s->threads = engine->threads;
    s->config_flags = cfg.flags;
    lc_pairs_init_embedded(&s->found, s->alloc);
    lc_query_tree_init(&s->qtree);
    locd_scene_stats_init(&s->stats);
    if (cfg.capacity_hint) {
        size_t hint = cfg.capacity_hint > UINT32_MAX ? UINT32_MAX : (size_t)cfg.capacity_hint;
        if ((st = lc_scene_reserve(s, hint)) != LOCD_OK) {
            locd_scene_destroy(s);
            return st;
        }
    }
    *out = s;
    lc_clear_error();
    return LOCD_OK;
}

void locd_scene_destroy(locd_scene *s)
{
    const locd_allocator *a;
    if (!s || s->magic != LC_MAGIC_SCENE)
        return;
    a = s->alloc;
    lc_query_tree_fini(s);
    lc_partners_drop(s);
    lc_entries_fini(s);
    lc_scene_slots_fini(s);
    lc_pair_set_fini(a, &s->set);
    lc_pairs_fini_embedded(&s->found);
    lc_pair_order_memo_fini(a, &s->order);
    lc_kept_release(s);
    lc_near_release(s);
    lc_update_keep_release(s);
    s->magic = LC_MAGIC_DEAD;
    lc_free(a, s, sizeof *s);
}

size_t locd_scene_count(const locd_scene *s)
{
    if (!s || s->magic != LC_MAGIC_SCENE)
        return 0;
    return s->slots.live;
}

/* The value of a per-object attribute: the array's when given. */
static uint64_t attr(const uint64_t *arr, uint64_t scalar, size_t i)
{
    return arr ? arr[i] : scalar;
}

static locd_status add_common(locd_scene *s, const void *boxes, int f64, size_t n,
                              const locd_scene_add_options *options, locd_id *ids_out)
{
    locd_scene_add_options o;
    locd_status st;
    size_t i;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK)
        return st;
    locd_scene_add_options_init(&o);
    if (options && (st = lc_struct_in(&o, sizeof o, options, LOCD_SCENE_ADD_OPTIONS_MIN_SIZE, "options")) != LOCD_OK)
        return st;
    if (o.flags & ~LOCD_OBJECT_STATIC)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "options->flags 0x%x has unknown bits", o.flags);
    if (n && !ids_out)
        return lc_error(LOCD_ERR_NULL_POINTER, "ids_out is NULL");
    if ((uint64_t)n > (uint64_t)(LC_MAX_SERIAL - s->slots.serial)) /* (before any read of the boxes) */
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "a scene issues at most %u ids in its lifetime", LC_MAX_SERIAL);
    st = f64 ? lc_scene_check_boxes_f64(boxes, n) : lc_scene_check_boxes_f32(boxes, n);
    if (st)
        return st;
    if ((st = lc_scene_reserve(s, n)) != LOCD_OK || (st = lc_scene_reserve_lists(s, n, 0)) != LOCD_OK ||
        (f64 && (st = lc_scene_need_doubles(s, boxes, n)) != LOCD_OK))
        return st;
    s->slots.epoch++;
    for (i = 0; i < n; i++) {
        uint32_t slot = lc_scene_take_slot(s);
        s->slots.id[slot] = (locd_id)(++s->slots.serial) << 32 | slot;
        s->slots.cat[slot] = attr(o.categories, o.category, i);
        s->slots.ncat0 += s->slots.cat[slot] == 0;
        s->slots.mask[slot] = attr(o.masks, o.mask, i);
        s->slots.group[slot] = attr(o.groups, o.group, i);
        s->slots.user[slot] = attr(o.users, o.user, i);
        s->slots.flags[slot] = LC_SLOT_LIVE | ((o.flags & LOCD_OBJECT_STATIC) ? LC_SLOT_STATIC : 0);
        lc_scene_set_box(s, slot, boxes, f64, i);
        lc_scene_mark_dirty(s, slot);
        ids_out[i] = s->slots.id[slot];
    }
    s->slots.live += n;
    if (o.flags & LOCD_OBJECT_STATIC)
        s->slots.live_static += n;
    if (n) {
        lc_slots_forget_order(&s->slots);
        lc_slots_forget_filter(&s->slots);
    }
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_scene_add_f32(locd_scene *s, const float *boxes, size_t n, const locd_scene_add_options *options,
                               locd_id *ids_out)
{
    return add_common(s, boxes, 0, n, options, ids_out);
}

locd_status locd_scene_add_f64(locd_scene *s, const double *boxes, size_t n, const locd_scene_add_options *options,
                               locd_id *ids_out)
{
    return add_common(s, boxes, 1, n, options, ids_out);
}

static locd_status move_common(locd_scene *s, const locd_id *ids, const void *boxes, int f64, size_t n)
{
    locd_status st;
    size_t i;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK)
        return st;
    if ((st = lc_scene_check_count(s, n)) != LOCD_OK)
        return st;
    if (n && !boxes)
        return lc_error(LOCD_ERR_NULL_POINTER, "boxes is NULL");
    s->slots.epoch++; /* (a move of every object in slot order hands over what it finds) */
    if (lc_scene_move_parallel(s, ids, boxes, f64, n, &st)) {
        if (st == LOCD_OK)
            lc_clear_error();
        return st;
    }
    if ((st = lc_scene_check_batch(s, ids, boxes, f64, n)) != LOCD_OK ||
        (st = lc_scene_reserve_lists(s, n, 0)) != LOCD_OK ||
        (f64 && (st = lc_scene_need_doubles(s, boxes, n)) != LOCD_OK))
        return st;
    for (i = 0; i < n; i++) {
        uint32_t slot = LC_ID_SLOT(ids[i]);
        if (i + LC_AHEAD < n) /* the box, its float copy: written next */
            lc_slot_prefetch_box(&s->slots, LC_ID_SLOT(ids[i + LC_AHEAD]), 1);
        lc_scene_set_box(s, slot, boxes, f64, i);
        lc_scene_mark_dirty(s, slot);
    }
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_scene_move_f32(locd_scene *s, const locd_id *ids, const float *boxes, size_t n)
{
    return move_common(s, ids, boxes, 0, n);
}

locd_status locd_scene_move_f64(locd_scene *s, const locd_id *ids, const double *boxes, size_t n)
{
    return move_common(s, ids, boxes, 1, n);
}

locd_status locd_scene_remove(locd_scene *s, const locd_id *ids, size_t n)
{
    locd_status st;
    size_t i;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK || (st = lc_scene_check_ids(s, ids, n)) != LOCD_OK ||
        (st = lc_scene_reserve_lists(s, 0, n)) != LOCD_OK)
        return st;
    s->slots.epoch++;
    for (i = 0; i < n; i++) {
        uint32_t slot = LC_ID_SLOT(ids[i]);
        if (s->slots.flags[slot] & LC_SLOT_STATIC)
            s->slots.live_static--;
        if (s->slots.flags[slot] & LC_SLOT_INEXACT)
            s->slots.ninexact--;
        s->slots.ncat0 -= s->slots.cat[slot] == 0;
        s->slots.flags[slot] = (uint8_t)((s->slots.flags[slot] & ~(LC_SLOT_LIVE | LC_SLOT_INEXACT)) | LC_SLOT_REMOVED);
        ((uint32_t *)s->slots.removed.data)[s->slots.nremoved++] = slot;
    }
    s->slots.live -= n;
    if (n) /* a filter that passed every pair still does */
        lc_slots_forget_order(&s->slots);
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_scene_set_filter(locd_scene *s, const locd_id *ids, size_t n, const uint64_t *categories,
                                  const uint64_t *masks, const uint64_t *groups)
{
    locd_status st;
    size_t i;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK || (st = lc_scene_check_ids(s, ids, n)) != LOCD_OK ||
        (st = lc_scene_reserve_lists(s, n, 0)) != LOCD_OK)
        return st;
    for (i = 0; i < n; i++) {
        uint32_t slot = LC_ID_SLOT(ids[i]);
        s->slots.ncat0 -= s->slots.cat[slot] == 0;
        s->slots.cat[slot] = attr(categories, s->slots.cat[slot], i);
        s->slots.ncat0 += s->slots.cat[slot] == 0;
        s->slots.mask[slot] = attr(masks, s->slots.mask[slot], i);
        s->slots.group[slot] = attr(groups, s->slots.group[slot], i);
        lc_scene_mark_dirty(s, slot);
        s->slots.flags[slot] |= LC_SLOT_REFILTER;
    }
    if (n)
        lc_slots_forget_filter(&s->slots);
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_scene_set_user(locd_scene *s, const locd_id *ids, size_t n, const uint64_t *users)
{
    locd_status st;
    size_t i;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK || (st = lc_scene_check_ids(s, ids, n)) != LOCD_OK)
        return st;
    if (n && !users)
        return lc_error(LOCD_ERR_NULL_POINTER, "users is NULL");
    for (i = 0; i < n; i++)
        s->slots.user[LC_ID_SLOT(ids[i])] = users[i];
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_scene_get_user(const locd_scene *s, const locd_id *ids, size_t n, uint64_t *users_out)
{
    locd_status st;
    size_t i;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK || (st = lc_scene_check_ids_live(s, ids, n)) != LOCD_OK)
        return st;
    if (n && !users_out)
        return lc_error(LOCD_ERR_NULL_POINTER, "users_out is NULL");
    for (i = 0; i < n; i++)
        users_out[i] = s->slots.user[LC_ID_SLOT(ids[i])];
    lc_clear_error();
    return LOCD_OK;
}
