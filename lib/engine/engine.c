/* The engine handle: configuration, validation, and dispatch to the
 * integration level chosen at creation. */
#include "engine/engine.h"
#include "octree/octree.h"

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
    pthread_cond_destroy(&e->idle);
    pthread_mutex_destroy(&e->mu);
    e->magic = LC_MAGIC_DEAD;
    lc_free(&a, e, sizeof *e);
}

/* The caller's config over the defaults, validated. */
static locd_status read_config(const locd_engine_config *config, locd_engine_config *cfg)
{
    locd_status st;
    locd_engine_config_init(cfg);
    /* An older, shorter struct keeps the defaults for the fields it lacks. */
    if (config && (st = lc_struct_in(cfg, sizeof *cfg, config, LOCD_ENGINE_CONFIG_MIN_SIZE, "config")) != LOCD_OK)
        return st;
    if (cfg->level < LOCD_LEVEL_INPROCESS || cfg->level > LOCD_LEVEL_SERVICE)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "level %d is not 1, 2 or 3", (int)cfg->level);
    if (cfg->cell_bias < 0 || cfg->cell_bias > 8)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "cell_bias %d is outside 0..8", (int)cfg->cell_bias);
    if ((st = lc_depth_check(cfg->max_depth, "max_depth")) != LOCD_OK)
        return st;
    if (cfg->threads > LC_MAX_THREADS)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "threads %u exceeds %d", cfg->threads, LC_MAX_THREADS);
    if ((cfg->allocator.alloc == NULL) != (cfg->allocator.free == NULL))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "allocator: set both alloc and free, or neither");
    if (cfg->level == LOCD_LEVEL_SERVICE && !cfg->service_address)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "level 3 needs service_address (\"unix:PATH\" or \"tcp:HOST:PORT\")");
    return LOCD_OK;
}

/* A zeroed engine with its lock ready, owning copies of cfg's strings. */
static locd_status engine_new(const locd_engine_config *cfg, const locd_allocator *a, locd_engine **out)
{
    locd_engine *e = lc_alloc(a, sizeof *e);
    *out = NULL;
    if (!e)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the engine");
    memset(e, 0, sizeof *e);
    if (pthread_mutex_init(&e->mu, NULL) != 0) {
        lc_free(a, e, sizeof *e);
        return lc_error(LOCD_ERR_THREAD, "pthread_mutex_init failed");
    }
    if (pthread_cond_init(&e->idle, NULL) != 0) {
        pthread_mutex_destroy(&e->mu);
        lc_free(a, e, sizeof *e);
        return lc_error(LOCD_ERR_THREAD, "pthread_cond_init failed");
    }
    e->alloc = *a;
    lc_pairs_init_embedded(&e->last, a);
    e->service_address = dup_string(a, cfg->service_address);
    e->service_secret = dup_string(a, cfg->service_secret);
    e->worker_path = dup_string(a, cfg->worker_path);
    if ((cfg->service_address && !e->service_address) || (cfg->service_secret && !e->service_secret) ||
        (cfg->worker_path && !e->worker_path)) {
        engine_free(e);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not copy the configuration strings");
    }
    *out = e;
    return LOCD_OK;
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
    if ((st = read_config(config, &cfg)) != LOCD_OK)
        return st;
    lc_allocator_resolve(&a, &cfg.allocator);
    if ((st = engine_new(&cfg, &a, &e)) != LOCD_OK)
        return st;
    e->cfg = cfg;
    e->cfg.allocator = a;
    e->cfg.service_address = e->service_address;
    e->cfg.service_secret = e->service_secret;
    e->cfg.worker_path = e->worker_path;
    e->level = cfg.level;
    e->threads = cfg.threads ? cfg.threads : lc_cpu_count();
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
       busy until its find returns, and its queue thread uses the engine's
       allocator and lock until it exits: wait for both rather than free
       the engine under it. */
    pthread_mutex_lock(&engine->mu);
    while (engine->busy || engine->queue.threads)
        pthread_cond_wait(&engine->idle, &engine->mu);
    pthread_mutex_unlock(&engine->mu);
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

/* The two-set query: a and b are copied into one array (b after a), so
 * the level builds one octree over both and its sweep keeps only the
 * pairs across the two (lc_backend.find_between); a bad box of b is
 * reported as na + its index. */
static locd_status find_between_common(locd_engine *e, const void *a, size_t na, const void *b, size_t nb, int f64,
                                       uint32_t flags, locd_pairs *out)
{
    const size_t row = 6 * (f64 ? sizeof(double) : sizeof(float));
    locd_stats st_local;
    locd_status st;
    size_t bytes = 0;
    void *boxes = NULL;
    double t0;
    if ((st = lc_engine_check(e)) != LOCD_OK || (st = lc_pairs_check(out)) != LOCD_OK)
        return st;
    if ((na && !a) || (nb && !b))
        return lc_error(LOCD_ERR_NULL_POINTER, "%s is NULL", na && !a ? "a" : "b");
    if (na > SIZE_MAX - nb)
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "na + nb overflows size_t");
    if ((st = lc_check_request(e, a ? a : b, na + nb, flags)) != LOCD_OK)
        return st;
    if (!e->ops->find_between)
        return lc_error(LOCD_ERR_UNSUPPORTED,
                        "the two-set query runs at levels 1 and 2 only (this engine is level %d, %s)", (int)e->level,
                        e->ops->name);
    if (!lc_mul_size(na + nb, row, &bytes))
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "%zu boxes overflow size_t", na + nb);
    if (bytes && !(boxes = lc_alloc(&e->alloc, bytes)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate %zu bytes to hold both sets", bytes);
    if (na)
        memcpy(boxes, a, na * row);
    if (nb)
        memcpy((char *)boxes + na * row, b, nb * row);
    if (!lc_engine_acquire(e)) {
        lc_free(&e->alloc, boxes, bytes);
        return lc_error(LOCD_ERR_BUSY, "the engine is running another call or job");
    }
    locd_stats_init(&st_local);
    t0 = lc_now_ms();
    st = e->ops->find_between(e, boxes, na + nb, na, f64, flags, out, &st_local);
    st_local.ms_total = lc_now_ms() - t0;
    if (!st) {
        e->stats = st_local;
        lc_clear_error();
    }
    lc_engine_release(e);
    lc_free(&e->alloc, boxes, bytes);
    return st;
}

locd_status locd_engine_find_pairs_between_f32(locd_engine *engine, const float *a, size_t na, const float *b,
                                               size_t nb, uint32_t flags, locd_pairs *out)
{
    return find_between_common(engine, a, na, b, nb, 0, flags, out);
}

locd_status locd_engine_find_pairs_between_f64(locd_engine *engine, const double *a, size_t na, const double *b,
                                               size_t nb, uint32_t flags, locd_pairs *out)
{
    return find_between_common(engine, a, na, b, nb, 1, flags, out);
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
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_engine_stats(const locd_engine *engine, locd_stats *stats)
{
    return locd_engine_get_stats(engine, stats);
}

locd_status locd_engine_get_stats(const locd_engine *engine, locd_stats *stats)
{
    locd_status st = lc_engine_check(engine);
    if (st || (st = lc_stats_check_out(stats)) != LOCD_OK)
        return st;
    lc_stats_copy_out(stats, &engine->stats);
    lc_clear_error();
    return LOCD_OK;
}
