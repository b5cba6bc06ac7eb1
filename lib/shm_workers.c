/* Placeholder until the levels work lands. */
#include "engine_internal.h"

static locd_status workers_open(locd_engine *e)
{
    (void)e;
    return lc_error(LOCD_ERR_UNSUPPORTED, "level 'worker processes' is not implemented yet");
}

static void workers_close(locd_engine *e) { (void)e; }

static locd_status workers_find(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags, locd_pairs *out,
                              locd_stats *stats)
{
    (void)e; (void)boxes; (void)n; (void)f64; (void)flags; (void)out; (void)stats;
    return lc_error(LOCD_ERR_UNSUPPORTED, "level 'worker processes' is not implemented yet");
}

const lc_backend lc_workers_backend = {"worker processes", workers_open, workers_close, workers_find, NULL};
