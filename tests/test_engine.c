/* The whole call (level 1) against brute force on random scenes of every
 * kind, for every thread count, float32 and float64. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "support.h"

static locd_engine *engine_with(uint32_t threads)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_engine_config_init(&cfg);
    cfg.threads = threads;
    assert_int_equal(locd_engine_create(&cfg, &e), LOCD_OK);
    return e;
}

static void random_scenes_match_brute_force(void **state)
{
    static const size_t sizes[] = {2, 3, 17, 200, 1500, 5000};
    locd_pairs *p;
    uint32_t threads;
    (void)state;
    assert_int_equal(locd_pairs_create(NULL, &p), LOCD_OK);
    for (threads = 1; threads <= 3; threads++) {
        locd_engine *e = engine_with(threads);
        int kind;
        size_t si;
        for (kind = 0; kind < TS_SCENE_KINDS; kind++)
            for (si = 0; si < sizeof sizes / sizeof sizes[0]; si++) {
                float *b = ts_scene(kind, sizes[si], 1000u * (uint64_t)kind + si);
                assert_int_equal(locd_engine_find_pairs_f32(e, b, sizes[si], 0, p), LOCD_OK);
                if (!ts_same_as_brute_f32(b, sizes[si], p))
                    fail_msg("kind %d n %zu threads %u differs from brute force", kind, sizes[si], threads);
                free(b);
            }
        locd_engine_destroy(e);
    }
    locd_pairs_destroy(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(random_scenes_match_brute_force),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
