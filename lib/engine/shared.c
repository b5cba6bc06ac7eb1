/* Helpers the engine shares with its jobs and its levels: handle and
 * request checks, the busy flag, logging, stats copies, the pair order.
 * Nothing here names a backend table, so the levels call these without
 * a loop back into engine.c (which refers to their tables). */
#include "engine/engine.h"

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

int lc_engine_acquire(locd_engine *e)
{
    int got;
    pthread_mutex_lock(&e->mu);
    got = !e->busy;
    e->busy = 1;
    pthread_mutex_unlock(&e->mu);
    return got;
}

void lc_engine_release(locd_engine *e)
{
    pthread_mutex_lock(&e->mu);
    e->busy = 0;
    pthread_cond_broadcast(&e->idle);
    pthread_mutex_unlock(&e->mu);
}

void lc_engine_log(const locd_engine *e, int32_t severity, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    lc_log_emit(e->cfg.log, e->cfg.log_user, severity, fmt, ap);
    va_end(ap);
}

locd_status lc_stats_check_out(const locd_stats *stats)
{
    return lc_struct_check(stats, sizeof *stats, LOCD_STATS_MIN_SIZE, "stats");
}

void lc_stats_copy_out(locd_stats *dst, const locd_stats *src)
{
    lc_struct_out(dst, src);
}

locd_status lc_order_pairs(locd_pairs *p, locd_stats *stats)
{
    double t0 = lc_now_ms();
    locd_status st = locd_pairs_sort(p);
    if (stats)
        stats->ms_order = lc_now_ms() - t0;
    return st;
}
