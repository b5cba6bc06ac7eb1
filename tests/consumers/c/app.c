/* A C99 program built against an installed locd (scripts/ci/steps/12-consumers.sh):
 *   cc -std=c99 -Wall -Wextra -Wpedantic -Werror app.c $(pkg-config --cflags --libs locd)
 * It includes every public header and checks the pairs of four boxes exactly. */
#include <locd/locd.h>
#include <locd/scene.h>
#include <locd/service.h>
#include <locd/version.h>
#include <stdio.h>

int main(void)
{
    /* minx miny minz maxx maxy maxz */
    static const float boxes[] = {
        0, 0, 0, 1, 1, 1,                   /* 0 */
        1, 0, 0, 2, 1, 1,                   /* 1: touches 0 (closed intervals) */
        5, 5, 5, 6, 6, 6,                   /* 2: alone */
        0.5f, 0.5f, 0.5f, 1.5f, 1.5f, 1.5f, /* 3: overlaps 0 and 1 */
    };
    static const uint32_t expected[] = {0, 1, 0, 3, 1, 3};
    locd_engine_config cfg;
    locd_engine *engine = NULL;
    locd_pairs *pairs = NULL;
    size_t k;
    int bad = 0;

    if ((locd_version() >> 16) != LOCD_VERSION_MAJOR) {
        fprintf(stderr, "loaded locd %s, built against major %d\n", locd_version_string(), LOCD_VERSION_MAJOR);
        return 1;
    }
    locd_engine_config_init(&cfg);
    cfg.threads = 2;
    if (locd_engine_create(&cfg, &engine) != LOCD_OK || locd_pairs_create(NULL, &pairs) != LOCD_OK ||
        locd_engine_find_pairs_f32(engine, boxes, 4, LOCD_FIND_SORTED, pairs) != LOCD_OK) {
        fprintf(stderr, "locd: %s\n", locd_last_error());
        return 1;
    }
    if (locd_pairs_count(pairs) != 3)
        bad = 1;
    for (k = 0; !bad && k < 6; k++)
        bad = locd_pairs_data(pairs)[k] != expected[k];
    printf("c99 consumer: locd %s, %u pairs: %s\n", locd_version_string(), (unsigned)locd_pairs_count(pairs),
           bad ? "WRONG" : "ok");
    locd_pairs_destroy(pairs);
    locd_engine_destroy(engine);
    return bad;
}
