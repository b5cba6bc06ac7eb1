/* Placeholder until the levels work lands. */
#include "engine_internal.h"

static locd_status service_open(locd_engine *e)
{
    (void)e;
    return lc_error(LOCD_ERR_UNSUPPORTED, "level 'service' is not implemented yet");
}

static void service_close(locd_engine *e) { (void)e; }

static locd_status service_find(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags, locd_pairs *out,
                              locd_stats *stats)
{
    (void)e; (void)boxes; (void)n; (void)f64; (void)flags; (void)out; (void)stats;
    return lc_error(LOCD_ERR_UNSUPPORTED, "level 'service' is not implemented yet");
}

const lc_backend lc_service_backend = {"service", service_open, service_close, service_find, NULL};
