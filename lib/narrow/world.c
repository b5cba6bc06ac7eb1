/* The world handle: shapes with poses and velocities, and the result
 * buffer (locd_contacts). */
#include "core/core.h"
#include "narrow/narrow.h"

#include <math.h>
#include <stdlib.h>

locd_status lc_world_check(const locd_world *w)
{
    if (!w || w->magic != LC_MAGIC_WORLD)
        return lc_error(LOCD_ERR_INVALID_HANDLE, "not a live locd_world");
    return LOCD_OK;
}

locd_status locd_world_create(const locd_engine_config *config, locd_world **out)
{
    locd_engine_config cfg;
    locd_allocator a;
    locd_world *w;
    locd_status st;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    /* The world's memory comes from the allocator of its engine's config. */
    locd_engine_config_init(&cfg);
    if (config && (st = lc_struct_in(&cfg, sizeof cfg, config, LOCD_ENGINE_CONFIG_MIN_SIZE, "config")) != LOCD_OK)
        return st;
    lc_allocator_resolve(&a, &cfg.allocator);
    w = lc_alloc(&a, sizeof *w);
    if (!w)
        return lc_error(LOCD_ERR_NO_MEMORY, "world");
    memset(w, 0, sizeof *w);
    w->magic = LC_MAGIC_WORLD;
    w->alloc = a;
    if ((st = locd_engine_create(config, &w->engine)) != LOCD_OK ||
        (st = locd_pairs_create(&w->alloc, &w->pairs)) != LOCD_OK || (st = lc_world_broad_open(w)) != LOCD_OK) {
        locd_world_destroy(w);
        return st;
    }
    *out = w;
    lc_clear_error();
    return LOCD_OK;
}

/* Frees the per-object arrays (not the shapes they hold). */
static void free_objects(locd_world *w)
{
    lc_free(&w->alloc, w->shapes, w->cap * sizeof *w->shapes);
    lc_free(&w->alloc, w->poses, w->cap * 7 * sizeof(double));
    lc_free(&w->alloc, w->vel, w->cap * 6 * sizeof(double));
}

void locd_world_destroy(locd_world *w)
{
    size_t i;
    if (!w || w->magic != LC_MAGIC_WORLD)
        return;
    for (i = 0; i < w->n; i++)
        if (w->shapes[i])
            lc_shape_release(w->shapes[i]);
    free_objects(w);
    lc_world_free_scratch(w);
    lc_world_broad_close(w);
    lc_world_events_free(w);
    lc_buf_release(&w->alloc, &w->filter, sizeof(lc_filter));
    lc_buf_release(&w->alloc, &w->dirty, 1);
    lc_free(&w->alloc, w->work, w->work_cap * sizeof(uint32_t));
    locd_engine_destroy(w->engine);
    locd_pairs_destroy(w->pairs);
    w->magic = LC_MAGIC_DEAD;
    lc_free(&w->alloc, w, sizeof *w);
}

void lc_world_free_scratch(locd_world *w)
{
    lc_free(&w->alloc, w->R, w->scratch_n * 12 * sizeof(double));
    lc_free(&w->alloc, w->boxes, w->scratch_n * 6 * sizeof(double));
    lc_free(&w->alloc, w->fast, w->scratch_n);
    w->R = NULL;
    w->boxes = NULL;
    w->fast = NULL;
    w->scratch_n = 0;
}

size_t locd_world_count(const locd_world *w)
{
    return w && w->magic == LC_MAGIC_WORLD ? w->n : 0;
}

/* Doubles the per-object arrays, all three or none: their sizes for
 * lc_free come from the one w->cap. */
static locd_status grow_objects(locd_world *w)
{
    size_t cap = w->cap ? 2 * w->cap : 64, pose_bytes;
    locd_shape **shapes;
    double *poses, *vel;
    if (!lc_mul_size(cap, 7 * sizeof(double), &pose_bytes))
        return lc_error(LOCD_ERR_NO_MEMORY, "world arrays of %zu objects overflow size_t", cap);
    shapes = lc_alloc(&w->alloc, cap * sizeof *shapes);
    poses = lc_alloc(&w->alloc, pose_bytes);
    vel = lc_alloc(&w->alloc, cap * 6 * sizeof(double));
    if (!shapes || !poses || !vel) {
        lc_free(&w->alloc, shapes, cap * sizeof *shapes);
        lc_free(&w->alloc, poses, pose_bytes);
        lc_free(&w->alloc, vel, cap * 6 * sizeof(double));
        return lc_error(LOCD_ERR_NO_MEMORY, "world arrays");
    }
    if (w->n) {
        memcpy(shapes, w->shapes, w->n * sizeof *shapes);
        memcpy(poses, w->poses, w->n * 7 * sizeof(double));
        memcpy(vel, w->vel, w->n * 6 * sizeof(double));
    }
    free_objects(w);
    w->shapes = shapes;
    w->poses = poses;
    w->vel = vel;
    w->cap = cap;
    return LOCD_OK;
}

static locd_status check_pose(const double *pose, int64_t index)
{
    double R[9], t[3];
    if (!lc_pose_to_rt(pose, R, t))
        return lc_error_box(LOCD_ERR_SHAPE, index,
                            "object %lld: pose is non-finite or its quaternion is zero", (long long)index);
    return LOCD_OK;
}

static locd_status check_velocity(const double *v, int64_t index)
{
    int k;
    for (k = 0; k < 6; k++)
        if (!isfinite(v[k]))
            return lc_error_box(LOCD_ERR_SHAPE, index, "object %lld: velocity is non-finite", (long long)index);
    return LOCD_OK;
}

locd_status locd_world_add(locd_world *w, locd_shape *shape, const double *pose, const double *velocity,
                           uint32_t *index)
{
    static const double rest[6] = {0, 0, 0, 0, 0, 0};
    locd_status st;
    if ((st = lc_world_check(w)) != LOCD_OK || (st = lc_shape_check(shape)) != LOCD_OK)
        return st;
    if (!pose)
        return lc_error(LOCD_ERR_NULL_POINTER, "pose is NULL");
    if (!velocity)
        velocity = rest;
    if ((st = check_pose(pose, (int64_t)w->n)) != LOCD_OK || (st = check_velocity(velocity, (int64_t)w->n)) != LOCD_OK)
        return st;
    if (w->n >= UINT32_MAX - 1)
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "a world holds at most 2^32 - 2 objects");
    if (w->n == w->cap && (st = grow_objects(w)) != LOCD_OK)
        return st;
    if ((st = lc_buf_reserve(&w->alloc, &w->filter, sizeof(lc_filter), w->n + 1)) != LOCD_OK ||
        (st = lc_buf_reserve(&w->alloc, &w->dirty, 1, w->n + 1)) != LOCD_OK ||
        (st = lc_world_broad_reserve(w, w->n + 1)) != LOCD_OK)
        return st;
    lc_shape_retain(shape);
    w->shapes[w->n] = shape;
    {
        lc_filter *f = (lc_filter *)w->filter.data + w->n;
        f->category = 1;
        f->mask = ~(uint64_t)0;
        f->group = 0;
    }
    ((locd_id *)w->broad.ids.data)[w->n] = LOCD_ID_NONE;
    ((uint8_t *)w->dirty.data)[w->n] = 1;
    ((uint8_t *)w->broad.pending.data)[w->n] = 0;
    w->live++;
    memcpy(w->poses + 7 * w->n, pose, 7 * sizeof(double));
    memcpy(w->vel + 6 * w->n, velocity, 6 * sizeof(double));
    if (index)
        *index = (uint32_t)w->n;
    w->n++;
    lc_clear_error();
    return LOCD_OK;
}

/* A live object's index (the caller has checked the handle). */
static locd_status check_index(const locd_world *w, uint32_t index)
{
    if (index >= w->n)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "object %u of %zu", index, w->n);
    if (!w->shapes[index])
        return lc_error_box(LOCD_ERR_STALE_ID, index, "object %u was removed", index);
    return LOCD_OK;
}

/* One row of poses or velocities, checked before it is written. The
 * caller has checked the handle. */
static locd_status set_row(locd_world *w, uint32_t index, const double *row, size_t width, double *dst,
                           locd_status (*check)(const double *row, int64_t index), const char *what)
{
    locd_status st;
    if (!row)
        return lc_error(LOCD_ERR_NULL_POINTER, "%s is NULL", what);
    if ((st = check_index(w, index)) != LOCD_OK || (st = check(row, index)) != LOCD_OK)
        return st;
    memcpy(dst + width * (size_t)index, row, width * sizeof(double));
    ((uint8_t *)w->dirty.data)[index] = 1;
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_world_set_pose(locd_world *w, uint32_t index, const double *pose)
{
    locd_status st = lc_world_check(w);
    return st ? st : set_row(w, index, pose, 7, w->poses, check_pose, "pose");
}

locd_status locd_world_set_velocity(locd_world *w, uint32_t index, const double *velocity)
{
    locd_status st = lc_world_check(w);
    return st ? st : set_row(w, index, velocity, 6, w->vel, check_velocity, "velocity");
}

/* Bulk setters validate every row first: nothing is half-written. The
 * caller has checked the handle. */
static locd_status set_rows(locd_world *w, const double *rows, size_t count, size_t width, double *dst,
                            locd_status (*check)(const double *row, int64_t index), const char *what)
{
    locd_status st;
    size_t i;
    if (!rows && count)
        return lc_error(LOCD_ERR_NULL_POINTER, "%s is NULL", what);
    if (count != w->n)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "%zu %s for %zu objects", count, what, w->n);
    /* A removed object's row is not read (its index stays in the count). */
    for (i = 0; i < count; i++)
        if (w->shapes[i] && (st = check(rows + width * i, (int64_t)i)) != LOCD_OK)
            return st;
    /* Only the objects whose row changed get a new box at the next collide. */
    for (i = 0; i < count; i++)
        if (memcmp(dst + width * i, rows + width * i, width * sizeof(double)) != 0) {
            memcpy(dst + width * i, rows + width * i, width * sizeof(double));
            ((uint8_t *)w->dirty.data)[i] = 1;
        }
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_world_set_poses(locd_world *w, const double *poses, size_t count)
{
    locd_status st = lc_world_check(w);
    return st ? st : set_rows(w, poses, count, 7, w->poses, check_pose, "poses");
}

locd_status locd_world_set_velocities(locd_world *w, const double *velocities, size_t count)
{
    locd_status st = lc_world_check(w);
    return st ? st : set_rows(w, velocities, count, 6, w->vel, check_velocity, "velocities");
}

locd_status locd_world_get_pose(const locd_world *w, uint32_t index, double *pose)
{
    locd_status st;
    if ((st = lc_world_check(w)) != LOCD_OK)
        return st;
    if (!pose)
        return lc_error(LOCD_ERR_NULL_POINTER, "pose is NULL");
    if ((st = check_index(w, index)) != LOCD_OK)
        return st;
    memcpy(pose, w->poses + 7 * (size_t)index, 7 * sizeof(double));
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_world_remove(locd_world *w, uint32_t index)
{
    locd_status st;
    if ((st = lc_world_check(w)) != LOCD_OK || (st = check_index(w, index)) != LOCD_OK)
        return st;
    /* The scene first: if it refuses, the world is unchanged. */
    if ((st = lc_world_broad_remove(w, index)) != LOCD_OK)
        return st;
    lc_shape_release(w->shapes[index]);
    w->shapes[index] = NULL;
    w->live--;
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_world_set_filter(locd_world *w, uint32_t index, uint64_t category, uint64_t mask, uint64_t group)
{
    lc_filter f;
    locd_status st;
    if ((st = lc_world_check(w)) != LOCD_OK || (st = check_index(w, index)) != LOCD_OK)
        return st;
    f.category = category;
    f.mask = mask;
    f.group = group;
    if ((st = lc_world_broad_filter(w, index, &f)) != LOCD_OK)
        return st;
    ((lc_filter *)w->filter.data)[index] = f;
    lc_clear_error();
    return LOCD_OK;
}

/* The lists world_events.c keeps (here, beside the handle check: world.c
 * calls into world_events.c, never the reverse). */
locd_status locd_world_contact_events(const locd_world *w, const uint32_t **began, size_t *began_count,
                                      const uint32_t **ended, size_t *ended_count)
{
    locd_status st;
    if ((st = lc_world_check(w)) != LOCD_OK)
        return st;
    if (began)
        *began = w->events.began.data;
    if (began_count)
        *began_count = w->events.began_n;
    if (ended)
        *ended = w->events.ended.data;
    if (ended_count)
        *ended_count = w->events.ended_n;
    lc_clear_error();
    return LOCD_OK;
}

/* ---- contacts ---- */

locd_status lc_contacts_check(const locd_contacts *c)
{
    if (!c || c->magic != LC_MAGIC_CONTACTS)
        return lc_error(LOCD_ERR_INVALID_HANDLE, "not a live locd_contacts");
    return LOCD_OK;
}

locd_status locd_contacts_create(locd_contacts **out)
{
    locd_contacts *c;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    c = calloc(1, sizeof *c);
    *out = c;
    if (!c)
        return lc_error(LOCD_ERR_NO_MEMORY, "contacts");
    c->magic = LC_MAGIC_CONTACTS;
    lc_clear_error();
    return LOCD_OK;
}

void locd_contacts_destroy(locd_contacts *c)
{
    if (!c || c->magic != LC_MAGIC_CONTACTS)
        return;
    free(c->pairs);
    free(c->toi);
    free(c->depth);
    free(c->normal);
    free(c->point);
    c->magic = LC_MAGIC_DEAD;
    free(c);
}

/* Contacts have no allocator (locd.h lists them among the exceptions). */
static locd_status grow(void **p, size_t count, size_t elem)
{
    void *q = realloc(*p, count * elem);
    if (!q)
        return lc_error(LOCD_ERR_NO_MEMORY, "contact arrays");
    *p = q;
    return LOCD_OK;
}

locd_status lc_contacts_reserve(locd_contacts *c, size_t count)
{
    locd_status st;
    size_t cap;
    if (count <= c->cap)
        return LOCD_OK;
    cap = c->cap ? c->cap : 64;
    while (cap < count)
        cap *= 2;
    if ((st = grow((void **)&c->pairs, cap, 2 * sizeof(uint32_t))) != LOCD_OK ||
        (st = grow((void **)&c->toi, cap, sizeof(double))) != LOCD_OK ||
        (st = grow((void **)&c->depth, cap, sizeof(double))) != LOCD_OK ||
        (st = grow((void **)&c->normal, cap, 3 * sizeof(double))) != LOCD_OK ||
        (st = grow((void **)&c->point, cap, 3 * sizeof(double))) != LOCD_OK)
        return st;
    c->cap = cap;
    return LOCD_OK;
}

size_t locd_contacts_count(const locd_contacts *c)
{
    return c && c->magic == LC_MAGIC_CONTACTS ? c->count : 0;
}

const uint32_t *locd_contacts_pairs(const locd_contacts *c)
{
    return c && c->magic == LC_MAGIC_CONTACTS ? c->pairs : NULL;
}

const double *locd_contacts_toi(const locd_contacts *c)
{
    return c && c->magic == LC_MAGIC_CONTACTS ? c->toi : NULL;
}

const double *locd_contacts_depth(const locd_contacts *c)
{
    return c && c->magic == LC_MAGIC_CONTACTS && c->has_contact ? c->depth : NULL;
}

const double *locd_contacts_normal(const locd_contacts *c)
{
    return c && c->magic == LC_MAGIC_CONTACTS && c->has_contact ? c->normal : NULL;
}

const double *locd_contacts_point(const locd_contacts *c)
{
    return c && c->magic == LC_MAGIC_CONTACTS && c->has_contact ? c->point : NULL;
}
