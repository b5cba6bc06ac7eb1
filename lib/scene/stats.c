/* The statistics of the last update. */
#include "scene/scene.h"

void locd_scene_stats_init(locd_scene_stats *stats)
{
    if (!stats)
        return;
    memset(stats, 0, sizeof *stats);
    stats->size = sizeof *stats;
}

locd_status locd_scene_stats_get(const locd_scene *s, locd_scene_stats *stats)
{
    return locd_scene_get_stats(s, stats);
}

locd_status locd_scene_get_stats(const locd_scene *s, locd_scene_stats *stats)
{
    locd_status st;
    if ((st = lc_scene_check_handle(s)) != LOCD_OK ||
        (st = lc_struct_check(stats, sizeof *stats, LOCD_SCENE_STATS_MIN_SIZE, "stats")) != LOCD_OK)
        return st;
    lc_struct_out(stats, &s->stats);
    lc_clear_error();
    return LOCD_OK;
}
