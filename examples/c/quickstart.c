/* The README's quick start: four boxes, two engines calls, every error checked. */
#include <locd/locd.h>
#include <stdio.h>

int main(void)
{
    /* minx miny minz maxx maxy maxz */
    const float boxes[] = {
        0, 0, 0, 1, 1, 1,       /* 0 */
        1, 0, 0, 2, 1, 1,       /* 1: touches 0 (closed intervals) */
        5, 5, 5, 6, 6, 6,       /* 2: alone */
        0.5f, 0.5f, 0.5f, 1.5f, 1.5f, 1.5f, /* 3: overlaps 0 and 1 */
    };
    locd_engine_config cfg;
    locd_engine *engine = NULL;
    locd_pairs *pairs = NULL;
    locd_stats stats;
    size_t k;

    locd_engine_config_init(&cfg); /* defaults: in-process, one thread per core */
    if (locd_engine_create(&cfg, &engine) != LOCD_OK || locd_pairs_create(NULL, &pairs) != LOCD_OK) {
        fprintf(stderr, "locd: %s\n", locd_last_error());
        return 1;
    }
    if (locd_engine_find_pairs_f32(engine, boxes, 4, LOCD_FIND_SORTED, pairs) != LOCD_OK) {
        fprintf(stderr, "locd: %s (box %lld)\n", locd_last_error(), (long long)locd_last_error_index());
        return 1;
    }
    for (k = 0; k < locd_pairs_count(pairs); k++)
        printf("%u %u\n", locd_pairs_data(pairs)[2 * k], locd_pairs_data(pairs)[2 * k + 1]);

    locd_stats_init(&stats);
    locd_engine_get_stats(engine, &stats);
    printf("%llu pairs in %.3f ms\n", (unsigned long long)stats.pairs, stats.ms_total);

    locd_pairs_destroy(pairs);
    locd_engine_destroy(engine);
    return 0;
}
