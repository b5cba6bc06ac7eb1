/* The world's broad phase. Every live object's box lives in a locd scene
 * (locd/scene.h) under a scene id; each collide adds the new objects, moves
 * only those whose box changed and lets the scene find the pairs, so an
 * object that did not move costs nothing there. Filters are the scene's, so
 * filtered pairs are never generated. An engine of level 2 or 3 has no scene:
 * then each collide runs a from-scratch find on the live boxes and applies the
 * same filter rule to its pairs. Both paths give the same pair set. */
#include "core/core.h"
#include "narrow/narrow.h"

#include <stdlib.h>

locd_status lc_world_broad_open(locd_world *w)
{
    locd_status st = locd_scene_create(w->engine, NULL, &w->broad.scene);
    if (st == LOCD_ERR_UNSUPPORTED) {
        w->broad.scene = NULL; /* level 2 or 3: the from-scratch path */
        return LOCD_OK;
    }
    return st;
}

void lc_world_broad_close(locd_world *w)
{
    lc_world_broad *b = &w->broad;
    const locd_allocator *a = &w->alloc;
    locd_scene_destroy(b->scene);
    b->scene = NULL;
    lc_buf_release(a, &b->ids, sizeof(locd_id));
    lc_buf_release(a, &b->held, 6 * sizeof(double));
    lc_free(a, b->map_keys, b->map_cap * sizeof(uint64_t));
    lc_free(a, b->map_vals, b->map_cap * sizeof(uint32_t));
    lc_buf_release(a, &b->pending, 1);
    lc_buf_release(a, &b->keys, sizeof(uint64_t));
    lc_buf_release(a, &b->keys2, sizeof(uint64_t));
    lc_buf_release(a, &b->ck, sizeof(uint64_t));
    lc_buf_release(a, &b->lk, sizeof(uint64_t));
    lc_buf_release(a, &b->scratch, sizeof(uint64_t));
    lc_buf_release(a, &b->b_idx, sizeof(uint32_t));
    lc_buf_release(a, &b->b_ids, sizeof(locd_id));
    lc_buf_release(a, &b->b_boxes, 6 * sizeof(double));
    lc_buf_release(a, &b->b_cat, sizeof(uint64_t));
    lc_buf_release(a, &b->b_mask, sizeof(uint64_t));
    lc_buf_release(a, &b->b_group, sizeof(uint64_t));
}

locd_status lc_world_broad_reserve(locd_world *w, size_t objects)
{
    locd_status st;
    if ((st = lc_buf_reserve(&w->alloc, &w->broad.ids, sizeof(locd_id), objects)) != LOCD_OK ||
        (st = lc_buf_reserve(&w->alloc, &w->broad.pending, 1, objects)) != LOCD_OK)
        return st;
    return lc_buf_reserve(&w->alloc, &w->broad.held, 6 * sizeof(double), objects);
}

/* ---- scene id -> object index ---- */

static size_t map_slot(uint64_t key, size_t cap)
{
    return (size_t)((key * 0x9E3779B97F4A7C15ull) >> 17) & (cap - 1);
}

/* Room for `more` new keys at a load of at most one half. */
static locd_status map_reserve(locd_world *w, size_t more)
{
    lc_world_broad *b = &w->broad;
    size_t cap = b->map_cap ? b->map_cap : 64, k;
    uint64_t *keys;
    uint32_t *vals;
    while (2 * (b->map_used + more) > cap)
        cap *= 2;
    if (cap == b->map_cap)
        return LOCD_OK;
    keys = lc_alloc(&w->alloc, cap * sizeof *keys);
    vals = lc_alloc(&w->alloc, cap * sizeof *vals);
    if (!keys || !vals) {
        lc_free(&w->alloc, keys, cap * sizeof *keys);
        lc_free(&w->alloc, vals, cap * sizeof *vals);
        return lc_error(LOCD_ERR_NO_MEMORY, "world id map of %zu entries", cap);
    }
    memset(keys, 0, cap * sizeof *keys);
    for (k = 0; k < b->map_cap; k++)
        if (b->map_keys[k]) {
            size_t s = map_slot(b->map_keys[k], cap);
            while (keys[s])
                s = (s + 1) & (cap - 1);
            keys[s] = b->map_keys[k];
            vals[s] = b->map_vals[k];
        }
    lc_free(&w->alloc, b->map_keys, b->map_cap * sizeof *keys);
    lc_free(&w->alloc, b->map_vals, b->map_cap * sizeof *vals);
    b->map_keys = keys;
    b->map_vals = vals;
    b->map_cap = cap;
    return LOCD_OK;
}

static void map_put(lc_world_broad *b, uint64_t key, uint32_t val)
{
    size_t s = map_slot(key, b->map_cap);
    while (b->map_keys[s])
        s = (s + 1) & (b->map_cap - 1);
    b->map_keys[s] = key;
    b->map_vals[s] = val;
    b->map_used++;
}

static uint32_t map_get(const lc_world_broad *b, uint64_t key)
{
    size_t s = map_slot(key, b->map_cap);
    while (b->map_keys[s] != key)
        s = (s + 1) & (b->map_cap - 1);
    return b->map_vals[s];
}

/* ---- changes the world passes on at once ---- */

locd_status lc_world_broad_remove(locd_world *w, uint32_t index)
{
    locd_id *id = (locd_id *)w->broad.ids.data + index;
    locd_status st;
    if (!w->broad.scene || *id == LOCD_ID_NONE)
        return LOCD_OK;
    if ((st = locd_scene_remove(w->broad.scene, id, 1)) != LOCD_OK)
        return st;
    *id = LOCD_ID_NONE;
    return LOCD_OK;
}

locd_status lc_world_broad_filter(locd_world *w, uint32_t index, const lc_filter *f)
{
    const locd_id *id = (const locd_id *)w->broad.ids.data + index;
    if (!w->broad.scene || *id == LOCD_ID_NONE)
        return LOCD_OK; /* read from w->filter when it is added */
    return locd_scene_set_filter(w->broad.scene, id, 1, &f->category, &f->mask, &f->group);
}

/* ---- the scene path ---- */

static locd_status reserve_batches(locd_world *w, size_t count)
{
    lc_world_broad *b = &w->broad;
    const locd_allocator *a = &w->alloc;
    locd_status st;
    if ((st = lc_buf_reserve(a, &b->b_idx, sizeof(uint32_t), count)) != LOCD_OK ||
        (st = lc_buf_reserve(a, &b->b_ids, sizeof(locd_id), count)) != LOCD_OK ||
        (st = lc_buf_reserve(a, &b->b_boxes, 6 * sizeof(double), count)) != LOCD_OK ||
        (st = lc_buf_reserve(a, &b->b_cat, sizeof(uint64_t), count)) != LOCD_OK ||
        (st = lc_buf_reserve(a, &b->b_mask, sizeof(uint64_t), count)) != LOCD_OK ||
        (st = lc_buf_reserve(a, &b->b_group, sizeof(uint64_t), count)) != LOCD_OK)
        return st;
    return LOCD_OK;
}

/* Objects not yet in the scene go in as one batch. */
static locd_status add_new(locd_world *w)
{
    lc_world_broad *b = &w->broad;
    locd_id *ids = b->ids.data;
    const lc_filter *f = w->filter.data;
    uint32_t *idx;
    double *boxes;
    uint64_t *cat, *mask, *group;
    locd_id *out;
    locd_scene_add_options opt;
    size_t i, k = 0;
    locd_status st;
    for (i = 0; i < w->n; i++)
        k += w->shapes[i] && ids[i] == LOCD_ID_NONE;
    if (!k)
        return LOCD_OK;
    if ((st = reserve_batches(w, k)) != LOCD_OK || (st = map_reserve(w, k)) != LOCD_OK)
        return st;
    idx = b->b_idx.data, boxes = b->b_boxes.data, out = b->b_ids.data;
    cat = b->b_cat.data, mask = b->b_mask.data, group = b->b_group.data;
    for (i = 0, k = 0; i < w->n; i++)
        if (w->shapes[i] && ids[i] == LOCD_ID_NONE) {
            idx[k] = (uint32_t)i;
            memcpy(boxes + 6 * k, w->boxes + 6 * i, 6 * sizeof(double));
            cat[k] = f[i].category;
            mask[k] = f[i].mask;
            group[k] = f[i].group;
            k++;
        }
    locd_scene_add_options_init(&opt);
    opt.categories = cat;
    opt.masks = mask;
    opt.groups = group;
    if ((st = locd_scene_add_f64(b->scene, boxes, k, &opt, out)) != LOCD_OK)
        return st;
    for (i = 0; i < k; i++) {
        ids[idx[i]] = out[i];
        memcpy((double *)b->held.data + 6 * (size_t)idx[i], boxes + 6 * i, 6 * sizeof(double));
        ((uint8_t *)b->pending.data)[idx[i]] = 0;
        map_put(b, out[i], idx[i]);
    }
    return LOCD_OK;
}

/* Objects whose box was computed again (pending) and changed since the
 * scene last saw it are moved; the others are not touched. */
static locd_status move_changed(locd_world *w)
{
    lc_world_broad *b = &w->broad;
    const locd_id *ids = b->ids.data;
    uint8_t *pending = b->pending.data;
    double *held = b->held.data;
    uint32_t *idx;
    locd_id *mid;
    double *boxes;
    size_t i, k = 0;
    locd_status st;
    for (i = 0; i < w->n; i++) {
        if (!pending[i] || !w->shapes[i] || ids[i] == LOCD_ID_NONE)
            continue;
        if (memcmp(held + 6 * i, w->boxes + 6 * i, 6 * sizeof(double)) == 0) {
            pending[i] = 0;
            continue;
        }
        if (k == b->b_idx.cap && (st = reserve_batches(w, k + 1)) != LOCD_OK)
            return st;
        ((uint32_t *)b->b_idx.data)[k++] = (uint32_t)i;
    }
    if (!k)
        return LOCD_OK;
    idx = b->b_idx.data, mid = b->b_ids.data, boxes = b->b_boxes.data;
    for (i = 0; i < k; i++) {
        mid[i] = ids[idx[i]];
        memcpy(boxes + 6 * i, w->boxes + 6 * (size_t)idx[i], 6 * sizeof(double));
    }
    if ((st = locd_scene_move_f64(b->scene, mid, boxes, k)) != LOCD_OK)
        return st;
    for (i = 0; i < k; i++) {
        memcpy(held + 6 * (size_t)idx[i], boxes + 6 * i, 6 * sizeof(double));
        pending[idx[i]] = 0;
    }
    return LOCD_OK;
}

/* A scene pair as a key (i << 32 | j), i < j in object indices. */
static uint64_t key_of(const lc_world_broad *b, const locd_id *row)
{
    uint64_t i = map_get(b, row[0]), j = map_get(b, row[1]);
    return i < j ? (i << 32) | j : (j << 32) | i;
}

/* count rows of ids as sorted keys in *dst (scratch: b->scratch); the buffer
 * holding them (dst's or the scratch, swapped into dst). */
static locd_status sorted_keys(locd_world *w, const locd_id *rows, size_t count, lc_buf *dst)
{
    lc_world_broad *b = &w->broad;
    uint64_t *k, *sorted;
    size_t i;
    locd_status st;
    if ((st = lc_buf_reserve(&w->alloc, dst, sizeof(uint64_t), count)) != LOCD_OK ||
        (st = lc_buf_reserve(&w->alloc, &b->scratch, sizeof(uint64_t), count)) != LOCD_OK)
        return st;
    k = dst->data;
    for (i = 0; i < count; i++)
        k[i] = key_of(b, rows + 2 * i);
    sorted = count > 1 ? lc_radix_sort(k, b->scratch.data, count, 0) : k;
    if (sorted != k) {
        lc_buf t = *dst;
        *dst = b->scratch;
        b->scratch = t;
    }
    return LOCD_OK;
}

/* keys = (keys minus lost) merged with created; all three sorted, lost a
 * subset of keys and created disjoint from keys minus lost (the scene's
 * events are exact set differences). */
static locd_status apply_events(locd_world *w, const locd_id *cr, size_t nc, const locd_id *lo, size_t nl)
{
    lc_world_broad *b = &w->broad;
    const uint64_t *cur, *c, *l;
    uint64_t *out;
    size_t p = 0, q = 0, r = 0, k = 0;
    locd_status st;
    if ((st = sorted_keys(w, cr, nc, &b->ck)) != LOCD_OK || (st = sorted_keys(w, lo, nl, &b->lk)) != LOCD_OK ||
        (st = lc_buf_reserve(&w->alloc, &b->keys2, sizeof(uint64_t), b->nkeys + nc)) != LOCD_OK)
        return st;
    cur = b->keys.data, c = b->ck.data, l = b->lk.data, out = b->keys2.data;
    while (p < b->nkeys || q < nc) {
        if (p < b->nkeys && r < nl && cur[p] == l[r]) {
            p++, r++;
        } else if (q == nc || (p < b->nkeys && cur[p] < c[q])) {
            out[k++] = cur[p++];
        } else {
            out[k++] = c[q++];
        }
    }
    if (r != nl)
        return lc_error(LOCD_ERR_INTERNAL, "world: %zu lost pairs were not in the pair set", nl - r);
    {
        lc_buf t = b->keys;
        b->keys = b->keys2;
        b->keys2 = t;
    }
    b->nkeys = k;
    return LOCD_OK;
}

/* The scene's pairs, kept as sorted index keys: each update only maps and
 * merges its created and lost lists (small when little moved), so a frame
 * where nothing moved costs a pass over the pairs, not a sort. After a
 * failure half-way (the scene's events of that update are gone), the next
 * call takes the scene's full list instead. */
static locd_status find_in_scene(locd_world *w, uint64_t *candidates)
{
    lc_world_broad *b = &w->broad;
    const locd_id *cr, *lo;
    locd_scene_stats ss;
    size_t nc, nl, k;
    uint32_t *dst;
    const uint64_t *keys;
    int resync = b->resync;
    locd_status st;
    if ((st = add_new(w)) != LOCD_OK || (st = move_changed(w)) != LOCD_OK)
        return st;
    if ((st = locd_scene_update(b->scene, resync ? LOCD_SCENE_UPDATE_PAIRS : LOCD_SCENE_UPDATE_EVENTS)) != LOCD_OK)
        return st;
    b->resync = 1; /* until the key set is right again */
    if (resync) {
        if ((st = locd_scene_pairs(b->scene, &cr, &nc)) != LOCD_OK ||
            (st = sorted_keys(w, cr, nc, &b->keys)) != LOCD_OK)
            return st;
        b->nkeys = nc;
    } else if ((st = locd_scene_created(b->scene, &cr, &nc)) != LOCD_OK ||
               (st = locd_scene_lost(b->scene, &lo, &nl)) != LOCD_OK ||
               (st = apply_events(w, cr, nc, lo, nl)) != LOCD_OK) {
        return st;
    }
    if ((st = lc_pairs_reserve(w->pairs, b->nkeys)) != LOCD_OK)
        return st;
    b->resync = 0;
    dst = w->pairs->data;
    keys = b->keys.data;
    for (k = 0; k < b->nkeys; k++) {
        dst[2 * k] = (uint32_t)(keys[k] >> 32);
        dst[2 * k + 1] = (uint32_t)keys[k];
    }
    w->pairs->count = b->nkeys;
    locd_scene_stats_init(&ss);
    *candidates = locd_scene_get_stats(b->scene, &ss) == LOCD_OK ? ss.candidates : b->nkeys;
    return LOCD_OK;
}

/* ---- the from-scratch path (levels 2 and 3) ---- */

static int filter_pass(const lc_filter *a, const lc_filter *b)
{
    return (a->category & b->mask) && (b->category & a->mask) && !(a->group && a->group == b->group);
}

static locd_status find_from_scratch(locd_world *w, uint32_t find_flags, uint64_t *candidates)
{
    lc_world_broad *b = &w->broad;
    const lc_filter *f = w->filter.data;
    double *boxes = w->boxes;
    uint32_t *idx, *p;
    size_t i, k = 0, m, kept = 0;
    locd_stats bs;
    locd_status st;
    if ((st = reserve_batches(w, w->live)) != LOCD_OK)
        return st;
    idx = b->b_idx.data;
    /* Live boxes packed to the front of the batch buffer. */
    for (i = 0; i < w->n; i++)
        if (w->shapes[i]) {
            idx[k] = (uint32_t)i;
            memcpy((double *)b->b_boxes.data + 6 * k, boxes + 6 * i, 6 * sizeof(double));
            k++;
        }
    if ((st = locd_engine_find_pairs_f64(w->engine, b->b_boxes.data, k, find_flags, w->pairs)) != LOCD_OK)
        return st;
    m = locd_pairs_count(w->pairs);
    p = w->pairs->data;
    /* Packed indices are increasing in object index: (i, j) order survives. */
    for (k = 0; k < m; k++) {
        uint32_t a = idx[p[2 * k]], c = idx[p[2 * k + 1]];
        if (!filter_pass(f + a, f + c))
            continue;
        p[2 * kept] = a < c ? a : c;
        p[2 * kept + 1] = a < c ? c : a;
        kept++;
    }
    w->pairs->count = kept;
    locd_stats_init(&bs);
    *candidates = locd_engine_get_stats(w->engine, &bs) == LOCD_OK ? bs.candidates : m;
    return LOCD_OK;
}

locd_status lc_world_broad_find(locd_world *w, uint32_t find_flags, uint64_t *candidates)
{
    *candidates = 0;
    if (!w->broad.scene)
        return find_from_scratch(w, find_flags, candidates);
    /* Sorted by (i, j) already, whatever find_flags says. */
    return find_in_scene(w, candidates);
}
