/* The pipeline's options and statistics structs: their defaults and the
 * route table. Built with and without the narrow phase
 * (pipeline_unsupported.c), so both builds set them up the same way. */
#include "core/core.h"
#include "narrow/narrow.h"

#include <stddef.h>

void locd_pipeline_options_init(locd_pipeline_options *o)
{
    if (!o)
        return;
    memset(o, 0, sizeof *o);
    o->size = sizeof *o;
    o->stages = LOCD_STAGE_SHAPE;
    o->swept = LOCD_SWEPT_OFF;
    o->contact_method = LOCD_CONTACT_EPA;
    o->dt = 0.0;
    o->swept_threshold = 0.25;
}

locd_status locd_pipeline_options_route(locd_pipeline_options *o, int32_t a, int32_t b, int32_t route)
{
    if (!o)
        return lc_error(LOCD_ERR_NULL_POINTER, "options is NULL");
    /* An older caller's struct may end before the route table. */
    if (o->size < offsetof(locd_pipeline_options, route) + sizeof o->route)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT,
                        "options->size %u has no route table: call locd_pipeline_options_init", o->size);
    if (a < 1 || a > LOCD_SHAPE_MESH || b < 1 || b > LOCD_SHAPE_MESH)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "unknown shape kind %d or %d", (int)a, (int)b);
    if (route < LOCD_ROUTE_AUTO || route > LOCD_ROUTE_FCL)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "unknown route %d", (int)route);
    o->route[a * LOCD_SHAPE_KINDS + b] = (uint8_t)route;
    o->route[b * LOCD_SHAPE_KINDS + a] = (uint8_t)route;
    lc_clear_error();
    return LOCD_OK;
}

void locd_pipeline_stats_init(locd_pipeline_stats *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof *s);
    s->size = sizeof *s;
}
