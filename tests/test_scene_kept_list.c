/* The kept entry list (lib/scene/kept_list.c): a from-scratch update of
 * 65,536 objects or more keeps its entries for the next one and merges in
 * those of the objects whose cells changed. Through each of its ways (a
 * merge, a full sort, a new grid, the scene's trees, an object removed),
 * through pair counts that jump (the pair order's buckets spill and
 * overflow), and with a move that encodes the boxes for the update while
 * another scene or a find shares the engine. Every update against the
 * engine's own find; the scenes have no near-pair list (su_kept_cfg). */
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "scene_util.h"

/* A from-scratch update of 65,536 objects or more keeps its entries for the
 * next one (lib/scene/kept_list.c): it encodes every box again and merges
 * the entries of the objects whose cells changed into the sorted list. The
 * sequence takes each of its ways, with one thread and with two, and every
 * update is checked against the engine's own find: small steps (a merge),
 * every object far (more changes than the merge takes: all sorted), an
 * object out of the list's grid and back (a new grid), a fifth of the
 * objects moving (the band rule builds the scene's trees, and the list is
 * made again after), and one object removed (the slots are no longer the
 * engine's input: the engine's find). */
static void kept_entry_list_follows_whole_scene_moves(void)
{
    const size_t n = 70000;
    const double edge = 0.0153; /* about one pair an object */
    locd_engine *e1 = su_new_engine(1, NULL), *e2 = su_new_engine(2, NULL), *er = su_new_engine(2, NULL);
    locd_scene *s[2] = {NULL, NULL};
    locd_id *ids = malloc(n * sizeof *ids), *ids2 = malloc(n * sizeof *ids2), *before, *now;
    float *f = malloc(n * 6 * sizeof *f);
    size_t k, nbefore, nnow, nmove;
    ts_rng r;
    int frame, a, i;
    ts_seed(&r, 717);
    su_cube_boxes(&r, f, n, edge, 0.0);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e1, &su_kept_cfg, &s[0]));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e2, &su_kept_cfg, &s[1]));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[0], f, n, NULL, ids));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[1], f, n, NULL, ids2));
    TEST_ASSERT_EQUAL_MEMORY(ids, ids2, n * sizeof *ids);
    before = malloc(2 * sizeof *before), nbefore = 0;
    for (frame = 0; frame < 20; frame++) {
        /* frame 0 adds; 6 sends everything anywhere; 10 takes object 123 out
           of the grid, 13 back; 15 and 16 move a fifth; the others step */
        nmove = frame == 15 || frame == 16 ? n / 5 : frame == 0 ? 0 : n;
        for (k = 0; k < nmove; k++) {
            float *b = f + 6 * k;
            for (a = 0; a < 3; a++) {
                float d = frame == 6 ? (float)ts_uniform(&r) - b[a] : (float)((ts_uniform(&r) - 0.5) * 0.06 * edge);
                b[a] += d, b[a + 3] = b[a] + (float)edge;
            }
            if (k == 123 && (frame == 10 || frame == 13))
                for (a = 0; a < 6; a++)
                    b[a] += frame == 10 ? 5.0f : -5.0f;
        }
        for (i = 0; i < 2; i++)
            if (nmove)
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[i], ids, f, nmove));
        now = su_engine_rows(er, f, ids, n, 0, &nnow);
        TEST_ASSERT_TRUE(nnow > n / 2);
        for (i = 0; i < 2; i++)
            su_check_against(s[i], now, nnow, before, nbefore);
        free(before);
        before = now, nbefore = nnow;
    }
    /* one object removed: every slot is no longer live */
    for (i = 0; i < 2; i++)
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s[i], &ids[n - 1], 1));
    for (k = 0; k + 1 < n; k++)
        f[6 * k] += 0.25f * (float)edge, f[6 * k + 3] += 0.25f * (float)edge;
    for (i = 0; i < 2; i++)
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[i], ids, f, n - 1));
    now = su_engine_rows(er, f, ids, n - 1, 0, &nnow);
    for (i = 0; i < 2; i++)
        su_check_against(s[i], now, nnow, before, nbefore);
    free(before), free(now);
    locd_scene_destroy(s[0]);
    locd_scene_destroy(s[1]);
    locd_engine_destroy(e1);
    locd_engine_destroy(e2);
    locd_engine_destroy(er);
    free(f), free(ids), free(ids2);
}

/* With the kept entry list, the pair order takes the sweep's pairs as it
 * finds them, into bucket regions sized from the previous update's counts
 * (lib/scene/pair_order.c). The pair counts here jump between updates:
 * a bucket outgrows its region (its extra pairs spill), the spill area
 * overflows (the list is swept again and its gathered pairs ordered), the
 * counts fall back; with a group filter (pairs dropped in the sink) and
 * without, on one thread and two. Every update against the engine's find. */
static void kept_entry_list_pair_counts_jump(void)
{
    const size_t n = 70000;
    const double edge = 0.0153;
    locd_engine *e[2], *er = su_new_engine(2, NULL);
    locd_scene *s[2] = {NULL, NULL};
    locd_id *ids = malloc(n * sizeof *ids), *ids2 = malloc(n * sizeof *ids2), *before, *now;
    float *f = malloc(n * 6 * sizeof *f), *home = malloc(n * 6 * sizeof *f);
    uint64_t *groups = malloc(n * sizeof *groups);
    size_t k, nbefore, nnow;
    ts_rng r;
    int frame, a, i;
    uint32_t grouped;
    for (grouped = 0; grouped <= 5; grouped += 5) {
        ts_seed(&r, 919 + grouped);
        su_cube_boxes(&r, home, n, edge, 0.0);
        memcpy(f, home, n * 6 * sizeof *f);
        for (i = 0; i < 2; i++) {
            e[i] = su_new_engine((uint32_t)i + 1, NULL);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e[i], &su_kept_cfg, &s[i]));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[i], f, n, NULL, i ? ids2 : ids));
        }
        TEST_ASSERT_EQUAL_MEMORY(ids, ids2, n * sizeof *ids);
        if (grouped) {
            for (k = 0; k < n; k++)
                groups[k] = k % grouped ? 0 : 7;
            for (i = 0; i < 2; i++)
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s[i], ids, n, NULL, NULL, groups));
        }
        before = malloc(2 * sizeof *before), nbefore = 0;
        for (frame = 0; frame < 9; frame++) {
            /* 2, 3: the first 120 objects (one bucket) in one spot, about
               7,000 pairs where the bucket had a few hundred: they spill;
               5, 6: the first 1,500 in one spot, a million pairs: the spill
               area overflows, then the regions are that large; 8: all home */
            const size_t crowd = frame == 2 || frame == 3 ? 120 : frame == 5 || frame == 6 ? 1500 : 0;
            for (k = 0; frame && k < n; k++) {
                float *b = f + 6 * k;
                for (a = 0; a < 3; a++) {
                    b[a] = k < crowd ? 0.5f + (float)((ts_uniform(&r) - 0.5) * edge)
                                     : home[6 * k + a] + (float)((ts_uniform(&r) - 0.5) * 0.06 * edge);
                    b[a + 3] = b[a] + (float)edge;
                }
            }
            if (frame)
                for (i = 0; i < 2; i++)
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[i], ids, f, n));
            now = su_engine_rows(er, f, ids, n, grouped, &nnow);
            if (crowd) /* every two of the crowd overlap (but for a few of one group) */
                TEST_ASSERT_TRUE(nnow > crowd * (crowd - 1) / 2 * 9 / 10);
            for (i = 0; i < 2; i++)
                su_check_against(s[i], now, nnow, before, nbefore);
            free(before);
            before = now, nbefore = nnow;
        }
        free(before);
        for (i = 0; i < 2; i++) {
            locd_scene_destroy(s[i]);
            locd_engine_destroy(e[i]);
        }
    }
    locd_engine_destroy(er);
    free(f), free(home), free(ids), free(ids2), free(groups);
}

/* A move of every object in slot order encodes the boxes for the next
 * update into the engine's packed-box buffer as it reads them (move.c,
 * kept_list.c). That update must encode them again when anything could
 * have written that buffer or changed a box since: another scene's move or
 * update on the same engine, a find of the engine, a later move of a few
 * objects. Two scenes share one two-thread engine; every update against
 * another engine's find. */
static void whole_scene_move_encodes_for_the_update(void)
{
    const size_t n = 70000, few = 100;
    const double edge = 0.0153, step = 0.06 * edge; /* about one pair an object; a small step */
    locd_engine *e2 = su_new_engine(2, NULL), *er = su_new_engine(2, NULL);
    locd_scene *s[2] = {NULL, NULL};
    locd_id *ids[2], *before[2] = {NULL, NULL}, *now;
    locd_pairs *p = NULL;
    float *f[2];
    size_t nbefore[2] = {0, 0}, nnow, k;
    ts_rng r;
    int round, i, order;
    ts_seed(&r, 919);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_pairs_create(NULL, &p));
    for (i = 0; i < 2; i++) {
        ids[i] = malloc(n * sizeof *ids[i]), f[i] = malloc(n * 6 * sizeof *f[i]);
        su_cube_boxes(&r, f[i], n, edge, 0.0);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e2, &su_kept_cfg, &s[i]));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[i], f[i], n, NULL, ids[i]));
    }
    /* rounds: 0 the first updates; then scene 0 moves every object and
       1 nothing else happens (the move's encode is the update's), 2 scene 1
       moves every object too, 3 the engine finds the pairs of scene 1's
       boxes, 4 scene 0 moves every object again, 5 scene 0 moves a few
       objects elsewhere, 6 scene 1 moves every object and updates first */
    for (round = 0; round < 7; round++) {
        const int both = round == 0 || round == 2 || round == 6;
        if (round > 0) {
            su_cube_boxes(&r, f[0], n, edge, step);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[0], ids[0], f[0], n));
        }
        if (round == 2 || round == 6) {
            su_cube_boxes(&r, f[1], n, edge, step);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[1], ids[1], f[1], n));
        } else if (round == 3) {
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_engine_find_pairs_f32(e2, f[1], n, 0, p));
        } else if (round == 4) {
            su_cube_boxes(&r, f[0], n, edge, step);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[0], ids[0], f[0], n));
        } else if (round == 5) {
            for (k = 0; k < few * 6; k++) /* elsewhere in the list's grid (out of it, the list is made again) */
                f[0][k] = k % 6 < 3 ? (float)(0.1 + 0.8 * ts_uniform(&r)) : f[0][k - 3] + (float)edge;
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[0], ids[0], f[0], few));
        }
        for (order = 0; order < (both ? 2 : 1); order++) {
            i = round == 6 ? 1 - order : order;
            now = su_engine_rows(er, f[i], ids[i], n, 0, &nnow);
            TEST_ASSERT_TRUE(nnow > n / 2);
            su_check_against(s[i], now, nnow, before[i], nbefore[i]);
            free(before[i]);
            before[i] = now, nbefore[i] = nnow;
        }
    }
    for (i = 0; i < 2; i++) {
        locd_scene_destroy(s[i]);
        free(before[i]), free(ids[i]), free(f[i]);
    }
    locd_pairs_destroy(p);
    locd_engine_destroy(e2);
    locd_engine_destroy(er);
}

static const lt_test tests[] = {
    LT_TEST(kept_entry_list_follows_whole_scene_moves),
    LT_TEST(kept_entry_list_pair_counts_jump),
    LT_TEST(whole_scene_move_encodes_for_the_update),
};

int main(void)
{
    return LT_RUN(tests);
}
