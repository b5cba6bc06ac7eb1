/* The engine handle: configuration, validation, and dispatch to the
 * integration level chosen at creation. */
#include "engine/engine.h"
#include "octree/octree.h"

#include <stdio.h>
#include <time.h>

void locd_engine_config_init(locd_engine_config *config)
{
    if (!config)
        return;
    memset(config, 0, sizeof *config);
    config->size = sizeof *config;
    config->level = LOCD_LEVEL_INPROCESS;
    config->threads = 0;
    config->max_depth = 0;
    config->cell_bias = LOCD_DEFAULT_CELL_BIAS;
}

void locd_stats_init(locd_stats *stats)
{
    if (!stats)
        return;
    memset(stats, 0, sizeof *stats);
    stats->size = sizeof *stats;
}

locd_status lc_engine_check(const locd_engine *e)
{
    if (!e)
        return lc_error(LOCD_ERR_INVALID_HANDLE, "engine is NULL");
    if (e->magic != LC_MAGIC_ENGINE)
        return lc_error(LOCD_ERR_INVALID_HANDLE, "not a locd_engine handle (destroyed?)");
    return LOCD_OK;
}

int lc_engine_acquire(locd_engine *e)
{
    int expected = 0;
    return __atomic_compare_exchange_n(&e->busy, &expected, 1, 0, __ATOMIC_ACQUIRE, __ATOMIC_RELAXED);
}

void lc_engine_release(locd_engine *e)
{
    __atomic_store_n(&e->busy, 0, __ATOMIC_RELEASE);
}

void lc_engine_log(const locd_engine *e, int32_t severity, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    lc_log_emit(e->cfg.log, e->cfg.log_user, severity, fmt, ap);
    va_end(ap);
}

locd_status lc_order_pairs(locd_pairs *p, locd_stats *stats)
{
    double t0 = lc_now_ms();
    locd_status st = locd_pairs_sort(p);
    if (stats)
        stats->ms_order = lc_now_ms() - t0;
    return st;
}

static char *dup_string(const locd_allocator *a, const char *s)
{
    size_t len;
    char *d;
    if (!s)
        return NULL;
    len = strlen(s) + 1;
    d = lc_alloc(a, len);
    if (d)
        memcpy(d, s, len);
    return d;
}

static void free_string(const locd_allocator *a, char *s)
{
    if (s)
        lc_free(a, s, strlen(s) + 1);
}

static void engine_free(locd_engine *e)
{
    locd_allocator a = e->alloc;
    free_string(&a, e->service_address);
    free_string(&a, e->service_secret);
    free_string(&a, e->worker_path);
    lc_pairs_fini_embedded(&e->last);
    e->magic = LC_MAGIC_DEAD;
    lc_free(&a, e, sizeof *e);
}

locd_status locd_engine_create(const locd_engine_config *config, locd_engine **out)
{
    locd_engine_config cfg;
    locd_allocator a;
    locd_engine *e;
    locd_status st;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    locd_engine_config_init(&cfg);
    if (config) {
        if (config->size < sizeof(uint32_t) * 6 || config->size > sizeof cfg)
            return lc_error(LOCD_ERR_INVALID_ARGUMENT,
                            "config->size is %u; initialize the config with locd_engine_config_init()",
                            config->size);
        /* An older, shorter struct keeps the defaults for the fields it lacks. */
        memcpy(&cfg, config, config->size);
        cfg.size = sizeof cfg;
    }
    if (cfg.level < LOCD_LEVEL_INPROCESS || cfg.level > LOCD_LEVEL_SERVICE)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "level %d is not 1, 2 or 3", (int)cfg.level);
    if (cfg.cell_bias < 0 || cfg.cell_bias > 8)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "cell_bias %d is outside 0..8", (int)cfg.cell_bias);
    if ((st = lc_depth_check(cfg.max_depth, "max_depth")) != LOCD_OK)
        return st;
    if (cfg.threads > 64)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "threads %u exceeds 64", cfg.threads);
    if ((cfg.allocator.alloc == NULL) != (cfg.allocator.free == NULL))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "allocator: set both alloc and free, or neither");
    if (cfg.level == LOCD_LEVEL_SERVICE && !cfg.service_address)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "level 3 needs service_address (\"unix:PATH\" or \"tcp:HOST:PORT\")");
    lc_allocator_resolve(&a, &cfg.allocator);
    e = lc_alloc(&a, sizeof *e);
    if (!e)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the engine");
    memset(e, 0, sizeof *e);
    e->alloc = a;
    e->cfg = cfg;
    e->cfg.allocator = a;
    e->level = cfg.level;
    e->threads = cfg.threads ? cfg.threads : lc_cpu_count();
    lc_pairs_init_embedded(&e->last, &a);
    e->service_address = dup_string(&a, cfg.service_address);
    e->service_secret = dup_string(&a, cfg.service_secret);
    e->worker_path = dup_string(&a, cfg.worker_path);
    if ((cfg.service_address && !e->service_address) || (cfg.service_secret && !e->service_secret) ||
        (cfg.worker_path && !e->worker_path)) {
        engine_free(e);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not copy the configuration strings");
    }
    e->cfg.service_address = e->service_address;
    e->cfg.service_secret = e->service_secret;
    e->cfg.worker_path = e->worker_path;
    e->ops = cfg.level == LOCD_LEVEL_WORKERS   ? &lc_workers_backend
             : cfg.level == LOCD_LEVEL_SERVICE ? &lc_service_backend
                                               : &lc_inproc_backend;
    locd_stats_init(&e->stats);
    e->magic = LC_MAGIC_ENGINE;
    st = e->ops->open(e);
    if (st) {
        engine_free(e);
        return st;
    }
    lc_engine_log(e, LOCD_LOG_INFO, "locd %s: engine created (level %d, %s, %u threads)", LOCD_VERSION_STRING,
                  (int)e->level, e->ops->name, e->threads);
    *out = e;
    lc_clear_error();
    return LOCD_OK;
}

void locd_engine_destroy(locd_engine *engine)
{
    if (!engine || engine->magic != LC_MAGIC_ENGINE)
        return;
    /* A job released while still running (levels 1 and 2) keeps the engine
       busy until its find returns, and its thread uses the engine's
       allocator until it exits: wait for both rather than free the engine
       under it. */
    while (__atomic_load_n(&engine->busy, __ATOMIC_ACQUIRE) || __atomic_load_n(&engine->job_threads, __ATOMIC_ACQUIRE)) {
        struct timespec pause = {0, 200000};
        nanosleep(&pause, NULL);
    }
    engine->ops->close(engine);
    engine_free(engine);
}

int32_t locd_engine_level(const locd_engine *engine)
{
    return lc_engine_check(engine) ? 0 : engine->level;
}

uint32_t locd_engine_threads(const locd_engine *engine)
{
    return lc_engine_check(engine) ? 0 : engine->threads;
}

locd_status lc_check_request(const locd_engine *e, const void *boxes, size_t n, uint32_t flags)
{
    locd_status st = lc_engine_check(e);
    if (st)
        return st;
    if (n && !boxes)
        return lc_error(LOCD_ERR_NULL_POINTER, "boxes is NULL");
    if (flags & ~LOCD_FIND_SORTED)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "unknown flags 0x%x", flags & ~LOCD_FIND_SORTED);
    if ((uint64_t)n > (uint64_t)UINT32_MAX + 1u)
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "%zu objects do not fit a 32-bit index", n);
    return LOCD_OK;
}

static locd_status find_common(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags,
                               locd_pairs *out)
{
    locd_stats st_local;
    locd_status st;
    double t0;
    if ((st = lc_engine_check(e)) != LOCD_OK || (st = lc_pairs_check(out)) != LOCD_OK ||
        (st = lc_check_request(e, boxes, n, flags)) != LOCD_OK)
        return st;
    if (!lc_engine_acquire(e))
        return lc_error(LOCD_ERR_BUSY, "the engine is running another call or job");
    locd_stats_init(&st_local);
    t0 = lc_now_ms();
    st = e->ops->find(e, boxes, n, f64, flags, out, &st_local);
    st_local.ms_total = lc_now_ms() - t0;
    if (!st) {
        e->stats = st_local;
        lc_clear_error();
    }
    lc_engine_release(e);
    return st;
}

locd_status locd_engine_find_pairs_f32(locd_engine *engine, const float *boxes, size_t n, uint32_t flags,
                                       locd_pairs *out)
{
    return find_common(engine, boxes, n, 0, flags, out);
}

locd_status locd_engine_find_pairs_f64(locd_engine *engine, const double *boxes, size_t n, uint32_t flags,
                                       locd_pairs *out)
{
    return find_common(engine, boxes, n, 1, flags, out);
}

static locd_status find_into(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags, uint32_t *pairs,
                             size_t capacity, size_t *count)
{
    locd_status st;
    if ((st = lc_engine_check(e)) != LOCD_OK)
        return st;
    if (!count)
        return lc_error(LOCD_ERR_NULL_POINTER, "count is NULL");
    if (capacity && !pairs)
        return lc_error(LOCD_ERR_NULL_POINTER, "pairs is NULL with capacity %zu", capacity);
    st = find_common(e, boxes, n, f64, flags, &e->last);
    if (st)
        return st;
    *count = e->last.count;
    if (e->last.count > capacity)
        return lc_error(LOCD_ERR_BUFFER_TOO_SMALL, "%zu pairs found, capacity %zu (see locd_engine_last_pairs)",
                        e->last.count, capacity);
    if (e->last.count)
        memcpy(pairs, e->last.data, e->last.count * 2 * sizeof(uint32_t));
    return LOCD_OK;
}

locd_status locd_engine_find_pairs_f32_into(locd_engine *engine, const float *boxes, size_t n, uint32_t flags,
                                            uint32_t *pairs, size_t capacity, size_t *count)
{
    return find_into(engine, boxes, n, 0, flags, pairs, capacity, count);
}

locd_status locd_engine_find_pairs_f64_into(locd_engine *engine, const double *boxes, size_t n, uint32_t flags,
                                            uint32_t *pairs, size_t capacity, size_t *count)
{
    return find_into(engine, boxes, n, 1, flags, pairs, capacity, count);
}

locd_status locd_engine_last_pairs(locd_engine *engine, const uint32_t **pairs, size_t *count)
{
    locd_status st = lc_engine_check(engine);
    if (st)
        return st;
    if (!pairs || !count)
        return lc_error(LOCD_ERR_NULL_POINTER, "pairs and count must not be NULL");
    *pairs = engine->last.data;
    *count = engine->last.count;
    return LOCD_OK;
}

locd_status lc_stats_check_out(const locd_stats *stats)
{
    if (!stats)
        return lc_error(LOCD_ERR_NULL_POINTER, "stats is NULL");
    if (stats->size < 2 * sizeof(uint32_t) || stats->size > sizeof(locd_stats))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "stats->size is %u; use locd_stats_init()", stats->size);
    return LOCD_OK;
}

void lc_stats_copy_out(locd_stats *dst, const locd_stats *src)
{
    const uint32_t size = dst->size;
    memcpy(dst, src, size);
    dst->size = size;
}

locd_status locd_engine_stats(const locd_engine *engine, locd_stats *stats)
{
    locd_status st = lc_engine_check(engine);
    if (st || (st = lc_stats_check_out(stats)) != LOCD_OK)
        return st;
    lc_stats_copy_out(stats, &engine->stats);
    return LOCD_OK;
}
