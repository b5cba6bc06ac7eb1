/* The from-scratch update (most objects moved, or the scene's layout
 * changed): what it keeps of the slots (ids in order, no filter that drops
 * a pair) across adds, removes and set_filter; the float copies of the
 * boxes, used only when every box is a float exactly; a box over the whole
 * scene; its created and lost lists merged over the pool, with objects
 * removed at both ends of the ids and where the threads' shares meet. */
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "scene_util.h"

/* A from-scratch update keeps what it learns of every slot (ids in slot
 * order and consecutive; no filter that can drop a pair) until an add, a
 * remove or a set_filter changes it (scene.h, order_known and
 * filter_known): each change here comes between two from-scratch updates
 * of a scene that moves only, and each update is checked against the
 * model. */
static void from_scratch_follows_adds_removes_and_filters(void)
{
    locd_engine *e = su_new_engine(2, NULL);
    locd_scene *s = NULL;
    const size_t n = 3000;
    double *b = malloc(n * 6 * sizeof *b);
    locd_id *ids = malloc(n * sizeof *ids);
    uint64_t *grp = malloc(n * sizeof *grp);
    su_model m;
    su_world w;
    size_t k;
    memset(&m, 0, sizeof m);
    w = su_world_make(8080, 60.0, 3.0, 0);
    for (k = 0; k < n; k++)
        su_random_box(&w, b + 6 * k);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    su_add_boxes(s, &m, b, n, 0, ids); /* one batch: ids consecutive in slot order */
    su_update_all_from_scratch(s, &m);
    su_update_all_from_scratch(s, &m);
    /* a group on every third object: pairs among them go */
    for (k = 0; k < n; k++)
        grp[k] = k % 3 == 0 ? 7 : 0;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, ids, n, NULL, NULL, grp));
    for (k = 0; k < n; k++)
        su_model_find(&m, ids[k])->group = grp[k];
    su_update_all_from_scratch(s, &m);
    /* groups off again, then a mask that drops every pair with category 2 */
    for (k = 0; k < n; k++)
        grp[k] = 0;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, ids, n, NULL, NULL, grp));
    for (k = 0; k < n; k++)
        su_model_find(&m, ids[k])->group = 0;
    su_update_all_from_scratch(s, &m);
    /* two static objects on one box: their pair must not be reported */
    {
        locd_id st_ids[2];
        su_random_box(&w, b);
        memcpy(b + 6, b, 6 * sizeof *b);
        su_add_boxes(s, &m, b, 2, 1, st_ids);
    }
    su_update_all_from_scratch(s, &m);
    {
        uint64_t cat = 2, mask = ~(uint64_t)2;
        locd_id some[40];
        for (k = 0; k < 40; k++)
            some[k] = ids[k * 70];
        for (k = 0; k < 40; k++) {
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, &some[k], 1, &cat, &mask, NULL));
            su_model_find(&m, some[k])->cat = cat, su_model_find(&m, some[k])->mask = mask;
        }
    }
    su_update_all_from_scratch(s, &m);
    /* removed objects: slot order is no longer id order once their slots
       are free, then new objects fill the slots with later ids */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, ids + 100, 50));
    for (k = 0; k < 50; k++)
        su_model_remove(&m, ids[100 + k]);
    su_update_all_from_scratch(s, &m);
    su_update_all_from_scratch(s, &m);
    for (k = 0; k < 30; k++)
        su_random_box(&w, b + 6 * k);
    su_add_boxes(s, &m, b, 30, 0, ids + 100);
    su_update_all_from_scratch(s, &m);
    su_update_all_from_scratch(s, &m);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(b), free(ids), free(grp), free(m.o), free(m.pairs);
}

/* The from-scratch path gives the engine the float copies of the boxes
 * only when every live box is floats exactly. Boxes 1e-12 apart, which
 * touch once rounded to floats, go from not floats to floats and back, on
 * slots in id order and, after removals and adds, out of it. */
static void float_copies_follow_the_boxes(void)
{
    locd_engine *e = su_new_engine(2, NULL);
    locd_scene *s = NULL;
    su_model m;
    const size_t n = 100;
    double b[6 * 100];
    locd_id ids[100], bids[100];
    size_t k;
    int step;
    memset(&m, 0, sizeof m);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    for (k = 0; k < n; k++) { /* A: [2k, 2k + 1] on x */
        double *x = b + 6 * k;
        x[0] = 2.0 * (double)k, x[1] = 0, x[2] = 0, x[3] = 2.0 * (double)k + 1.0, x[4] = 1, x[5] = 1;
    }
    su_add_boxes(s, &m, b, n, 0, ids);
    for (k = 0; k < n; k++) { /* B: from just past A's end: no pair, but touching in floats */
        double *x = b + 6 * k;
        x[0] = 2.0 * (double)k + 1.0 + 1e-12, x[1] = 0, x[2] = 0, x[3] = 2.0 * (double)k + 1.5, x[4] = 1, x[5] = 1;
        TEST_ASSERT_TRUE((double)su_to_float(x[0]) != x[0]);
    }
    su_add_boxes(s, &m, b, n, 0, bids);
    su_check_update(s, &m);
    TEST_ASSERT_EQUAL_UINT64(0, m.npairs);
    for (step = 0; step < 6; step++) {
        /* steps 0, 2, 4: B on A's end (floats exactly: n pairs); 1, 3, 5: just past it */
        for (k = 0; k < n; k++) {
            su_obj *o = su_model_find(&m, bids[k]);
            if (o)
                o->box[0] = 2.0 * (double)k + 1.0 + (step % 2 ? 1e-12 : 0.0);
        }
        if (step == 4) /* one B past its A's end: one box not floats, the others are */
            su_model_find(&m, bids[7])->box[0] += 1e-12;
        su_update_all_from_scratch(s, &m);
        if (step % 2)
            TEST_ASSERT_EQUAL_UINT64(0, m.npairs);
        else
            TEST_ASSERT_TRUE(m.npairs > 0);
        if (step == 1) { /* out of id order: a removed A's slot taken by a new object */
            locd_id gone[10], fresh[10];
            for (k = 0; k < 10; k++) {
                gone[k] = ids[3 * k];
                su_model_remove(&m, gone[k]);
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, gone, 10));
            su_check_update(s, &m);
            for (k = 0; k < 10; k++) {
                double *x = b + 6 * k;
                x[0] = 2.0 * (double)(3 * k), x[1] = 0.5, x[2] = 0, x[3] = 2.0 * (double)(3 * k) + 1.0, x[4] = 1, x[5] = 1;
            }
            su_add_boxes(s, &m, b, 10, 0, fresh);
            for (k = 0; k < 10; k++)
                ids[3 * k] = fresh[k];
            su_check_update(s, &m);
        }
    }
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o), free(m.pairs);
}

/* A box over the whole scene, added first: its row run in the from-scratch
 * ordering is every other object, far past the insertion sort's few
 * (rebuild.c, sort_run). */
static void a_box_over_everything(void)
{
    locd_engine *e = su_new_engine(2, NULL);
    locd_scene *s = NULL;
    su_model m;
    su_world w;
    double b[6 * 301];
    locd_id ids[301];
    int k, a;
    memset(&m, 0, sizeof m);
    w = su_world_make(909, 50.0, 3.0, 0);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    for (a = 0; a < 3; a++)
        b[a] = -100.0, b[3 + a] = 100.0;
    for (k = 1; k < 301; k++)
        su_random_box(&w, b + 6 * k);
    su_add_boxes(s, &m, b, 301, 0, ids);
    su_check_update(s, &m);
    for (k = 0; k < 3; k++)
        su_update_all_from_scratch(s, &m);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o), free(m.pairs);
}

/* An update of s checked against er's find of boxes f of ids[0, n) and
 * the rows before it (*before, which then become those rows); it must be
 * from scratch. Returns the pair count. */
static size_t check_from_scratch(locd_scene *s, locd_engine *er, const float *f, const locd_id *ids, size_t n,
                                 locd_id **before, size_t *nbefore)
{
    locd_scene_stats st;
    size_t nnow;
    locd_id *now = su_engine_rows(er, f, ids, n, 0, &nnow);
    su_check_against(s, now, nnow, *before, *nbefore);
    locd_scene_stats_init(&st);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s, &st));
    TEST_ASSERT_EQUAL_UINT32(1, st.rebuilt);
    free(*before);
    *before = now, *nbefore = nnow;
    return nnow;
}

/* Object k of the ends test is removed: the first and last `cut` ids, and
 * every other one in a band of 2 `band` ids around the middle. */
static int end_removed(size_t k, size_t n, size_t cut, size_t band)
{
    return k < cut || k >= n - cut || (k >= n / 2 - band && k < n / 2 + band && k % 2);
}

/* The created and lost lists of a from-scratch update are one merge of the
 * new rows with the previous ones, split over the pool by key range
 * (update.c, events_full): a thread's share of the previous set starts at
 * the key of the first row of its share of the new rows. Previous rows
 * whose first id is below the first live one, above the last one, or
 * between two threads' shares are lost rows too: objects removed at both
 * ends, and every other one in a band around the middle of the ids (where
 * the two shares meet). Also every pair gone at once and all back. Two
 * threads, more than 65,536 pairs, each update against the engine's find. */
static void from_scratch_events_at_the_ends(void)
{
    const size_t n = 70000, cut = 500, band = 3000;
    const double edge = 0.02; /* about two pairs an object */
    locd_engine *e = su_new_engine(2, NULL), *er = su_new_engine(2, NULL);
    locd_scene *s = NULL;
    locd_id *ids = malloc(n * sizeof *ids), *gone = malloc(n * sizeof *gone), *lid = malloc(n * sizeof *lid), *before;
    float *f = malloc(n * 6 * sizeof *f), *far = malloc(n * 6 * sizeof *far), *lf = malloc(n * 6 * sizeof *lf);
    size_t k, nbefore, nnow, ngone = 0, nlive = 0;
    ts_rng r;
    int frame, a;
    ts_seed(&r, 4242);
    su_cube_boxes(&r, f, n, edge, 0.0);
    for (k = 0; k < n; k++) /* a lattice of spacing 2 edge: no two boxes meet */
        for (a = 0; a < 3; a++) {
            const size_t c = a == 0 ? k % 42 : a == 1 ? k / 42 % 42 : k / (42 * 42);
            far[6 * k + a] = (float)(2.0 * edge * (double)c);
            far[6 * k + 3 + a] = far[6 * k + a] + (float)edge;
        }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, f, n, NULL, ids));
    before = malloc(2 * sizeof *before), nbefore = 0;
    /* 0: the first update; 1: a step; 2: every pair gone; 3: all back */
    for (frame = 0; frame < 4; frame++) {
        const float *in = frame == 2 ? far : f;
        if (frame == 1)
            su_cube_boxes(&r, f, n, edge, 0.05 * edge);
        if (frame)
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s, ids, in, n));
        nnow = check_from_scratch(s, er, in, ids, n, &before, &nbefore);
        TEST_ASSERT_TRUE(frame == 2 ? nnow == 0 : nnow > 65536);
    }
    /* the first and last ids, and every other one in the band */
    for (k = 0; k < n; k++)
        if (end_removed(k, n, cut, band))
            gone[ngone++] = ids[k];
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, gone, ngone));
    for (frame = 0; frame < 2; frame++) {
        su_cube_boxes(&r, f, n, edge, 0.05 * edge);
        nlive = 0;
        for (k = 0; k < n; k++)
            if (!end_removed(k, n, cut, band)) {
                memcpy(lf + 6 * nlive, f + 6 * k, 6 * sizeof *f);
                lid[nlive++] = ids[k];
            }
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s, lid, lf, nlive));
        TEST_ASSERT_TRUE(check_from_scratch(s, er, lf, lid, nlive, &before, &nbefore) > 65536);
    }
    free(before);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    locd_engine_destroy(er);
    free(ids), free(gone), free(lid), free(f), free(far), free(lf);
}

static const lt_test tests[] = {
    LT_TEST(a_box_over_everything),
    LT_TEST(float_copies_follow_the_boxes),
    LT_TEST(from_scratch_events_at_the_ends),
    LT_TEST(from_scratch_follows_adds_removes_and_filters),
};

int main(void)
{
    return LT_RUN(tests);
}
