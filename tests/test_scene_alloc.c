/* Allocation failures: every allocation of a call fails in turn
 * (tests/fail_alloc.c). The call gives LOCD_ERR_NO_MEMORY and the scene
 * behaves as if it had not been made, or the failure is absorbed and the
 * answer stays exact: small adds and moves, moves of every object (the
 * kept entry list, the near-pair list), and the double boxes a scene fed
 * floats makes when the first box that is not a float comes in. The
 * counting allocator's blocks are counted over the whole process: every
 * test here gives all of them back. */
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "fail_alloc.h"
#include "scene_util.h"

/* Every allocation of a move of every object and of the update after it
 * fails in turn, on a scene large enough for the kept entry list (small
 * steps: its merge; every object far: its full sort; after a failure: a
 * list made again). The failing call gives LOCD_ERR_NO_MEMORY (or absorbs
 * the failure) and the next working update's pairs, created and lost are
 * the engine's own find's, against the last working update. */
static void whole_scene_allocation_failures(const locd_scene_config *cfg, const char *what, int min_failed,
                                            int min_absorbed)
{
    const size_t n = 70000;
    const double edge = 0.0153;
    locd_engine *e = su_new_engine(2, fa_allocator()), *er = su_new_engine(2, NULL);
    locd_scene *s = NULL;
    locd_id *ids = malloc(n * sizeof *ids), *before, *now;
    float *f = malloc(n * 6 * sizeof *f), *g = malloc(n * 6 * sizeof *g);
    size_t k, nbefore, nnow;
    ts_rng r;
    int a, far, failed_calls = 0, absorbed = 0;
    uint64_t fail;
    ts_seed(&r, 818);
    su_cube_boxes(&r, f, n, edge, 0.0);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, cfg, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, f, n, NULL, ids));
    before = su_engine_rows(er, f, ids, n, 0, &nbefore);
    su_check_against(s, before, nbefore, NULL, 0);
    for (far = 0; far < 2; far++)
        for (fail = 1;; fail++) {
            locd_status st;
            fa_counts c;
            int moved;
            for (k = 0; k < n; k++)
                for (a = 0; a < 3; a++) {
                    float d = far ? (float)ts_uniform(&r) - f[6 * k + a] : (float)((ts_uniform(&r) - 0.5) * 0.06 * edge);
                    g[6 * k + a] = f[6 * k + a] + d, g[6 * k + 3 + a] = g[6 * k + a] + (float)edge;
                }
            fa_arm(fail, 0);
            st = locd_scene_move_f32(s, ids, g, n);
            moved = st == LOCD_OK;
            if (moved)
                st = locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS);
            fa_counts_get(&c);
            fa_arm(0, 0);
            if (moved)
                memcpy(f, g, n * 6 * sizeof *f);
            now = su_engine_rows(er, f, ids, n, 0, &nnow);
            absorbed += st == LOCD_OK && c.failures > 0;
            if (st == LOCD_OK) { /* no failure, or one absorbed: the update is exact */
                TEST_ASSERT_TRUE(moved);
                su_check_lists_against(s, now, nnow, before, nbefore);
            } else { /* the next working update takes the failed one's place */
                TEST_ASSERT_EQUAL_INT(LOCD_ERR_NO_MEMORY, st);
                failed_calls++;
                su_check_against(s, now, nnow, before, nbefore);
            }
            free(before);
            before = now, nbefore = nnow;
            if (c.failures == 0)
                break;
        }
    LT_PRINT("%s: %d failed calls, each left the scene as before; %d failures absorbed\n", what, failed_calls,
             absorbed);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    locd_engine_destroy(er);
    free(before), free(f), free(g), free(ids);
    /* the buffers are kept from frame to frame: a move and an update of a
       warm scene allocate a few blocks only, but some */
    TEST_ASSERT_TRUE(failed_calls >= min_failed);
    TEST_ASSERT_TRUE(absorbed >= min_absorbed);
}

static void kept_entry_list_allocation_failures(void)
{
    whole_scene_allocation_failures(&su_kept_cfg, "kept entry list", 4, 0);
}

/* The same with the near-pair list (near_list.c): its build failing is
 * absorbed (the update goes from scratch without it: five of this
 * sequence's failures fall in builds); a frame's pass failing fails the
 * update and drops the list. */
static void near_list_allocation_failures(void)
{
    whole_scene_allocation_failures(NULL, "near-pair list", 1, 4);
}

/* Every allocation of a change or an update fails in turn: the call gives
 * LOCD_ERR_NO_MEMORY, and the scene then behaves as if the failed call had
 * not been made (checked against the model by the next, working update). */
static void allocation_failures_change_nothing(void)
{
    locd_engine *e = su_new_engine(1, fa_allocator());
    locd_scene *s = NULL;
    enum { N0 = 2000 };
    double *b = malloc(6 * N0 * sizeof *b);
    locd_id *ids = malloc(N0 * sizeof *ids), more[8];
    uint64_t k;
    int i, round, failed_calls = 0;
    su_world w;
    su_model m;
    w = su_world_make(5, 60.0, 3.0, 0);
    memset(&m, 0, sizeof m);
    for (i = 0; i < N0; i++)
        su_random_box(&w, b + 6 * i);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, N0, NULL, ids));
    for (i = 0; i < N0; i++)
        su_model_add(&m, ids[i], b + 6 * i, 1, ~(uint64_t)0, 0, 0, 0);
    su_check_update(s, &m);
    for (round = 0; round < 4; round++) {
        for (k = 1; k < 400; k++) {
            locd_status st;
            fa_counts c;
            for (i = 0; i < 8; i++) {
                su_random_box(&w, b + 6 * i);
                if (round == 3) { /* far outside the root cube: the update rebuilds */
                    int a;
                    for (a = 0; a < 6; a++)
                        b[6 * i + a] += 1000.0;
                }
            }
            fa_arm(k, 0);
            if (round == 0 || round == 3)
                st = locd_scene_add_f64(s, b, 8, NULL, more);
            else
                st = locd_scene_move_f64(s, ids + 8 * (size_t)((50 * round + (int)k) % (N0 / 8)), b, 8);
            if (st == LOCD_OK) { /* the change went in: the model follows */
                for (i = 0; i < 8; i++) {
                    if (round == 0 || round == 3)
                        su_model_add(&m, more[i], b + 6 * i, 1, ~(uint64_t)0, 0, 0, 0);
                    else
                        memcpy(su_model_find(&m, ids[8 * (size_t)((50 * round + (int)k) % (N0 / 8)) + (size_t)i])->box,
                               b + 6 * i, 6 * sizeof(double));
                }
                st = locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS);
            }
            fa_counts_get(&c);
            fa_arm(0, 0);
            if (c.failures == 0 || st == LOCD_OK) {
                /* a failure may be absorbed (the lists' directory is only a
                   shortcut): the answer must still be exact */
                TEST_ASSERT_EQUAL_INT(LOCD_OK, st);
                su_check_lists(s, &m);
                if (c.failures == 0)
                    break;
                continue;
            }
            TEST_ASSERT_EQUAL_INT(LOCD_ERR_NO_MEMORY, st);
            failed_calls++;
            /* pending changes (if the update failed) go in now; the lists must
               equal the model's, created and lost against the last good update */
            su_check_update(s, &m);
            if (round == 0 || round == 3) { /* keep the scene small: remove what was added */
                size_t cnt = 0;
                locd_id rm[8];
                for (i = 0; i < 8 && locd_scene_count(s) > N0; i++) {
                    locd_id id = m.o[m.n - 1].id;
                    rm[cnt++] = id;
                    su_model_remove(&m, id);
                }
                if (cnt)
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, rm, cnt));
                su_check_update(s, &m);
            }
        }
    }
    LT_PRINT("allocation failures: %d failed calls, each left the scene as before\n", failed_calls);
    TEST_ASSERT_TRUE(failed_calls > 20);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o);
    free(m.pairs);
    free(b);
    free(ids);
    {
        fa_counts c;
        fa_counts_get(&c);
        TEST_ASSERT_EQUAL_UINT64(0, c.bad_frees);
        TEST_ASSERT_EQUAL_UINT64(0, c.live_blocks);
    }
}

/* A scene fed floats keeps no doubles; the first double box that is not a
 * float exactly makes them. That allocation failing rejects the batch and
 * changes nothing; once it works, the pairs and the queries see the double
 * boxes, not their floats (a box 1e-9 apart from another only as doubles). */
static void doubles_come_in_late(void)
{
    locd_engine *e = su_new_engine(2, fa_allocator());
    locd_scene *s = NULL;
    enum { N0 = 3000 };
    double *b = malloc(6 * N0 * sizeof *b);
    float *f = malloc(6 * N0 * sizeof *f);
    locd_id *ids = malloc(N0 * sizeof *ids);
    double q[7];
    uint64_t k;
    int i, a, failed = 0;
    su_world w;
    su_model m;
    w = su_world_make(11, 60.0, 3.0, 0);
    memset(&m, 0, sizeof m);
    for (i = 0; i < 6 * N0; i++) {
        if (i % 6 == 0)
            su_random_box(&w, b + i);
        f[i] = su_to_float(b[i]), b[i] = f[i];
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, f, N0, NULL, ids));
    for (i = 0; i < N0; i++)
        su_model_add(&m, ids[i], b + 6 * i, 1, ~(uint64_t)0, 0, 0, 0);
    su_check_update(s, &m);
    /* Object 1 moves to touch object 0's high x face from beyond it by
       1e-9: as floats the two would touch; as doubles they do not. Object 2
       takes object 1's old box nudged by 1e-9, overlapping as doubles. */
    for (a = 0; a < 6; a++) {
        b[a] = m.o[0].box[a];
        b[6 + a] = m.o[0].box[a] + (a == 0 ? m.o[0].box[3] - m.o[0].box[0] + 1e-9 : 0.0);
        b[12 + a] = m.o[1].box[a] + 1e-9;
    }
    b[9] = b[6] + 1.0;
    for (k = 1; k < 1000; k++) {
        locd_status st;
        fa_counts c;
        fa_arm(k, 0);
        st = locd_scene_move_f64(s, ids, b, 3);
        fa_counts_get(&c);
        fa_arm(0, 0);
        if (st == LOCD_OK)
            break;
        TEST_ASSERT_EQUAL_INT(LOCD_ERR_NO_MEMORY, st);
        TEST_ASSERT_TRUE(c.failures > 0);
        failed++;
        su_check_update(s, &m); /* nothing moved */
    }
    TEST_ASSERT_TRUE(failed > 0);
    for (i = 0; i < 3; i++)
        memcpy(su_model_find(&m, ids[i])->box, b + 6 * i, 6 * sizeof(double));
    su_check_update(s, &m);
    /* a query between the two as doubles: a point on object 1's low face */
    for (a = 0; a < 3; a++)
        q[a] = b[6 + a];
    su_check_query(s, &m, 1, q, ~(uint64_t)0);
    for (a = 0; a < 6; a++)
        q[a] = b[6 + a];
    su_check_query(s, &m, 0, q, ~(uint64_t)0);
    /* more float moves and a big double move on the pool keep it exact */
    for (i = 0; i < N0; i++)
        for (a = 0; a < 6; a++)
            b[6 * i + a] = su_model_find(&m, ids[i])->box[a] + 1e-7 * (double)(i % 5);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, ids, b, N0));
    for (i = 0; i < N0; i++)
        memcpy(su_model_find(&m, ids[i])->box, b + 6 * i, 6 * sizeof(double));
    su_check_update(s, &m);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o);
    free(m.pairs);
    free(b);
    free(f);
    free(ids);
}

/* A small update (a few objects moved: a game's frame) takes the rows its
 * moved objects need (ten arrays), its entry buffer and its search's
 * output buffers from the update before it instead of allocating them
 * again: the median small update of this scene made 28 allocations when
 * each allocated its own, 16 since; the budget, 22, fails if the rows and
 * the entry buffer (eleven) come back. The pairs stay exact, and the scene
 * gives every block back when it goes. */
static locd_status small_move_and_update(locd_scene *s, su_world *w, su_model *m, const locd_id *ids, int first,
                                         uint64_t *calls)
{
    double b[6 * 8];
    locd_status st;
    fa_counts c;
    int i;
    for (i = 0; i < 8; i++)
        su_random_box(w, b + 6 * i);
    fa_arm(0, 0);
    st = locd_scene_move_f64(s, ids + first, b, 8);
    if (st == LOCD_OK)
        st = locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS);
    fa_counts_get(&c);
    *calls = c.calls;
    for (i = 0; i < 8; i++)
        memcpy(su_model_find(m, ids[first + i])->box, b + 6 * i, 6 * sizeof(double));
    return st;
}

static int cmp_u64(const void *x, const void *y)
{
    const uint64_t a = *(const uint64_t *)x, b = *(const uint64_t *)y;
    return (a > b) - (a < b);
}

static void small_updates_reuse_their_rows(void)
{
    locd_engine *e = su_new_engine(1, fa_allocator());
    locd_scene *s = NULL;
    enum { N0 = 2000, FRAMES = 19 };
    double *b = malloc(6 * N0 * sizeof *b);
    locd_id *ids = malloc(N0 * sizeof *ids);
    uint64_t calls[FRAMES + 1];
    locd_scene_stats st;
    int i, frame;
    su_world w;
    su_model m;
    fa_counts c;
    w = su_world_make(17, 60.0, 3.0, 0);
    memset(&m, 0, sizeof m);
    for (i = 0; i < N0; i++)
        su_random_box(&w, b + 6 * i);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    su_add_boxes(s, &m, b, N0, 0, ids);
    su_check_update(s, &m);
    for (frame = 0; frame <= FRAMES; frame++) {
        TEST_ASSERT_EQUAL_INT(LOCD_OK, small_move_and_update(s, &w, &m, ids, 8 * frame, &calls[frame]));
        locd_scene_stats_init(&st);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_get_stats(s, &st));
        TEST_ASSERT_EQUAL_UINT32(0, st.rebuilt); /* the incremental path, which needs the rows */
        su_check_lists(s, &m);
    }
    qsort(calls + 1, FRAMES, sizeof *calls, cmp_u64); /* the first made the rows */
    LT_PRINT("a small update: %llu allocations the first time, a median of %llu after\n",
             (unsigned long long)calls[0], (unsigned long long)calls[1 + FRAMES / 2]);
    TEST_ASSERT_TRUE(calls[1 + FRAMES / 2] <= 22);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o);
    free(m.pairs);
    free(b);
    free(ids);
    fa_counts_get(&c);
    TEST_ASSERT_EQUAL_UINT64(0, c.bad_frees);
    TEST_ASSERT_EQUAL_UINT64(0, c.live_blocks);
}

static const lt_test tests[] = {
    LT_TEST(kept_entry_list_allocation_failures),
    LT_TEST(near_list_allocation_failures),
    LT_TEST(allocation_failures_change_nothing),
    LT_TEST(doubles_come_in_late),
    LT_TEST(small_updates_reuse_their_rows),
};

int main(void)
{
    return LT_RUN(tests);
}
