/* Moves of 65,536 objects or more, which run on the pool (lib/scene/move.c),
 * against one thread's serial loop and a fresh scene: shuffled and
 * overlapping batches, float and double boxes, a later small move that
 * finds every moved object clean, bad batches that name the position the
 * serial checks name and change nothing; a float move of every object in
 * slot order (the boxes copied to the spare array, the arrays swapped)
 * between moves in other orders and of fewer objects. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "scene_util.h"

/* Object k's box on a 200 x 200 x 4 lattice of unit cubes along x (so
 * x-neighbours touch), y and z 3 apart; odd ones shrunk by `gap` (1e-9:
 * apart as doubles, touching once rounded to floats). */
static void lattice_box(size_t k, double gap, double *b)
{
    double x = (double)(k % 200), y = 3.0 * (double)((k / 200) % 200), z = 3.0 * (double)(k / 40000);
    double g = (k & 1) ? gap : 0.0;
    b[0] = x + g, b[1] = y, b[2] = z, b[3] = x + 1.0 - g, b[4] = y + 1.0, b[5] = z + 1.0;
}

/* Moves ids[pos[0..cnt)] to the boxes lattice_box gives them, in scene s1
 * (one thread: the serial loop) and s2 (two threads: move.c), f64 or f32. */
static void move_both(locd_scene *s1, locd_scene *s2, su_model *m, const locd_id *ids, const size_t *pos, size_t cnt,
                      double gap, int f32)
{
    locd_id *mv = malloc(cnt * sizeof *mv);
    double *b = malloc(cnt * 6 * sizeof *b);
    float *f = malloc(cnt * 6 * sizeof *f);
    size_t i;
    int a;
    for (i = 0; i < cnt; i++) {
        mv[i] = ids[pos[i]];
        lattice_box(pos[i], gap, b + 6 * i);
        for (a = 0; a < 6; a++) {
            f[6 * i + a] = (float)b[6 * i + a];
            if (f32)
                b[6 * i + a] = f[6 * i + a];
        }
        memcpy(m->o[pos[i]].box, b + 6 * i, 6 * sizeof *b);
    }
    if (f32) {
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, cnt));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, cnt));
    } else {
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s1, mv, b, cnt));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s2, mv, b, cnt));
    }
    free(mv), free(b), free(f);
}

/* Updates both scenes and checks both against a fresh scene of the model. */
static void update_both(locd_engine *e, locd_scene *s1, locd_scene *s2, su_model *m)
{
    const locd_id *p1, *p2;
    size_t n1, n2, nf;
    locd_id *want;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s1, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s2, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s1, &p1, &n1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s2, &p2, &n2));
    su_same_rows("two threads' moves against one thread's", p1, n1, p2, n2);
    if (su_steps(10) == 10) { /* the sanitizer runs (LOCD_TEST_HEAVY=0) compare the two scenes only */
        want = su_fresh_pairs(e, m, &nf);
        su_same_rows("one thread's moves against a fresh scene", want, nf, p1, n1);
        su_same_rows("two threads' moves against a fresh scene", want, nf, p2, n2);
        free(want);
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_created(s1, &p1, &n1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_created(s2, &p2, &n2));
    su_same_rows("created: 1 thread against 2", p1, n1, p2, n2);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_lost(s1, &p1, &n1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_lost(s2, &p2, &n2));
    su_same_rows("lost: 1 thread against 2", p1, n1, p2, n2);
}

/* The pairs after an update (pending changes taken in), hashed with the
 * count of objects: fingerprint() for scenes too big for its query. */
static uint64_t pairs_hash(locd_scene *s)
{
    const locd_id *p;
    size_t np, i;
    uint64_t h = 1469598103934665603ull;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s, &p, &np));
    for (i = 0; i < 2 * np; i++)
        h = (h ^ p[i]) * 1099511628211ull;
    return h ^ locd_scene_count(s);
}

/* A move of float (f64 0) or double boxes. */
static locd_status move_any(locd_scene *s, const locd_id *mv, const void *b, int f64, size_t cnt)
{
    return f64 ? locd_scene_move_f64(s, mv, b, cnt) : locd_scene_move_f32(s, mv, b, cnt);
}

/* One bad batch given to both scenes: the same error at the same position,
 * and neither scene changed. */
static void bad_move_both(locd_scene *s1, locd_scene *s2, const locd_id *mv, const void *b, int f64, size_t cnt,
                          locd_status want, int64_t at)
{
    uint64_t h1 = pairs_hash(s1), h2 = pairs_hash(s2);
    TEST_ASSERT_EQUAL_INT(want, move_any(s1, mv, b, f64, cnt));
    TEST_ASSERT_EQUAL_INT64(at, locd_last_error_index());
    TEST_ASSERT_EQUAL_INT(want, move_any(s2, mv, b, f64, cnt));
    TEST_ASSERT_EQUAL_INT64(at, locd_last_error_index());
    TEST_ASSERT_TRUE(h1 == pairs_hash(s1));
    TEST_ASSERT_TRUE(h2 == pairs_hash(s2));
}

/* A move of 65,536 objects or more runs on the pool (lib/scene/move.c):
 * the same lists as the serial loop's, in shuffled and overlapping
 * batches, with boxes that are floats exactly and boxes that are not (the
 * count of those decides whether the from-scratch path may use floats); a
 * later small move finds every moved object clean (the dirty list was
 * written right); and a bad batch names the position the serial checks
 * name (stale before repeated before bad box) and changes nothing. */
static void large_moves_on_the_pool(void)
{
    const size_t n = 140000, half = 70000;
    locd_engine *e1 = su_new_engine(1, NULL), *e2 = su_new_engine(2, NULL);
    locd_scene *s1 = NULL, *s2 = NULL;
    locd_id *ids1 = malloc(n * sizeof *ids1), *ids2 = malloc(n * sizeof *ids2), *mv = malloc(n * sizeof *mv);
    size_t *pos = malloc(n * sizeof *pos), k;
    double *b = malloc(n * 6 * sizeof *b);
    su_model m;
    ts_rng r;
    memset(&m, 0, sizeof m);
    ts_seed(&r, 515);
    for (k = 0; k < n; k++)
        lattice_box(k, 0.0, b + 6 * k);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e1, NULL, &s1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e2, NULL, &s2));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s1, b, n, NULL, ids1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s2, b, n, NULL, ids2));
    TEST_ASSERT_EQUAL_MEMORY(ids1, ids2, n * sizeof *ids1);
    for (k = 0; k < n; k++)
        su_model_add(&m, ids1[k], b + 6 * k, 1, ~(uint64_t)0, 0, 0, 0);
    update_both(e1, s1, s2, &m);
    /* the second half, shuffled, shrunk (not floats: no pair); then a few,
       incrementally: a slot left out of the dirty list would stay flagged
       dirty and its next move would be missed */
    for (k = 0; k < half; k++)
        pos[k] = half + k;
    for (k = half - 1; k > 0; k--) {
        size_t j = (size_t)(ts_next(&r) % (k + 1)), t = pos[k];
        pos[k] = pos[j], pos[j] = t;
    }
    move_both(s1, s2, &m, ids1, pos, half, 1e-9, 0);
    update_both(e1, s1, s2, &m);
    for (k = 0; k < 500; k++)
        pos[k] = (size_t)(ts_next(&r) % (n / 500)) + k * (n / 500);
    move_both(s1, s2, &m, ids1, pos, 500, 0.0, 0);
    update_both(e1, s1, s2, &m);
    /* the first half shrunk, then an overlapping range back to the lattice */
    for (k = 0; k < half; k++)
        pos[k] = k;
    move_both(s1, s2, &m, ids1, pos, half, 1e-9, 0);
    for (k = 0; k < half; k++)
        pos[k] = half / 2 + k;
    move_both(s1, s2, &m, ids1, pos, half, 0.0, 0);
    update_both(e1, s1, s2, &m);
    /* everything as floats, then shrunk again as doubles */
    for (k = 0; k < n; k++)
        pos[k] = n - 1 - k;
    move_both(s1, s2, &m, ids1, pos, n, 0.0, 1);
    update_both(e1, s1, s2, &m);
    move_both(s1, s2, &m, ids1, pos, n, 1e-9, 0);
    update_both(e1, s1, s2, &m);
    /* a few, incrementally: every slot must have left the dirty list */
    for (k = 0; k < 500; k++)
        pos[k] = (size_t)(ts_next(&r) % (n / 500)) + k * (n / 500);
    move_both(s1, s2, &m, ids1, pos, 500, 0.0, 0);
    update_both(e1, s1, s2, &m);
    {
        locd_scene_stats st;
        locd_scene_stats_init(&st);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s2, &st));
        TEST_ASSERT_EQUAL_UINT32(0, st.rebuilt);
        TEST_ASSERT_EQUAL_UINT64(500, st.moved);
    }
    /* an incremental update long enough to split its dirty list over the
       pool (LC_ENCODE_SPLIT, update.c): 10,000 moved, every 14th, and 100
       added (new dense indices taken in each part's turn) */
    {
        locd_id added1[100], added2[100], more1[5], more2[5];
        locd_scene_stats st;
        for (k = 0; k < 100; k++)
            lattice_box(n + k, 0.0, b + 6 * k);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s1, b, 100, NULL, added1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s2, b, 100, NULL, added2));
        TEST_ASSERT_EQUAL_MEMORY(added1, added2, sizeof added1);
        for (k = 0; k < 100; k++)
            su_model_add(&m, added1[k], b + 6 * k, 1, ~(uint64_t)0, 0, 0, 0);
        for (k = 0; k < 10000; k++)
            pos[k] = 14 * k + (k & 3);
        move_both(s1, s2, &m, ids1, pos, 10000, 0.25, 0); /* odd ones shrunk: their touching pairs lost */
        update_both(e1, s1, s2, &m);
        locd_scene_stats_init(&st);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s2, &st));
        TEST_ASSERT_EQUAL_UINT32(0, st.rebuilt);
        TEST_ASSERT_EQUAL_UINT64(10100, st.moved);
        for (k = 0; k < 10000; k++) /* back: the pairs those moves broke come back */
            pos[k] = 14 * k + (k & 3);
        move_both(s1, s2, &m, ids1, pos, 10000, 0.0, 0);
        update_both(e1, s1, s2, &m);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s2, &st));
        TEST_ASSERT_EQUAL_UINT32(0, st.rebuilt);
        /* five more, touching the hundred: each takes a dense index after
           theirs, which must all be taken */
        for (k = 0; k < 5; k++)
            lattice_box(n + 100 + k, 0.0, b + 6 * k);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s1, b, 5, NULL, more1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s2, b, 5, NULL, more2));
        TEST_ASSERT_EQUAL_MEMORY(more1, more2, sizeof more1);
        for (k = 0; k < 5; k++)
            su_model_add(&m, more1[k], b + 6 * k, 1, ~(uint64_t)0, 0, 0, 0);
        update_both(e1, s1, s2, &m);
        /* the bad batches below work on the first n objects */
        while (m.n > n) {
            locd_id id = m.o[m.n - 1].id;
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s1, &id, 1));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s2, &id, 1));
            su_model_remove(&m, id);
        }
        update_both(e1, s1, s2, &m);
    }
    /* bad batches of the whole scene */
    for (k = 0; k < n; k++) { /* odd ones 2 up in y: applied, the batch would change the pairs */
        mv[k] = ids1[k];
        memcpy(b + 6 * k, m.o[k].box, 6 * sizeof *b);
        b[6 * k + 1] += (k & 1) ? 2.0 : 0.0, b[6 * k + 4] += (k & 1) ? 2.0 : 0.0;
    }
    mv[30000] = ids1[10];                       /* repeated */
    mv[50000] = ids1[50000] + ((uint64_t)7 << 32); /* stale: wrong serial */
    b[6 * 20000 + 1] = NAN;
    /* each position's id and box together: the first bad position is named */
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_NONFINITE, 20000);
    b[6 * 20000 + 1] = m.o[20000].box[1];
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_DUPLICATE_ID, 30000);
    mv[30000] = ids1[30000];
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_STALE_ID, 50000);
    mv[50000] = ids1[50000];
    mv[30000] = ids1[10];
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_DUPLICATE_ID, 30000); /* the only fault */
    mv[30000] = ids1[30000];
    mv[100000] = ids1[10]; /* repeated across the two threads' halves */
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_DUPLICATE_ID, 100000);
    mv[100000] = ids1[100000];
    b[6 * 40000 + 4] = NAN;
    b[6 * 45000 + 0] = b[6 * 45000 + 3] + 1.0;
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_NONFINITE, 40000);
    b[6 * 40000 + 4] = m.o[40000].box[4];
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_INVERTED_BOX, 45000);
    /* put right, the same batch moves (and changes the pairs) */
    b[6 * 45000 + 0] = m.o[45000].box[0];
    /* The batch's ids ascend, which lets the pool skip the repeat check
       (move.c): one repeat breaks that, at the threads' split or inside a
       range. */
    mv[half] = mv[half - 1];
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_DUPLICATE_ID, half);
    mv[half] = ids1[half];
    mv[1001] = mv[1000];
    bad_move_both(s1, s2, mv, b, 1, n, LOCD_ERR_DUPLICATE_ID, 1001);
    mv[1001] = ids1[1001];
    for (k = 0; k < n; k++)
        memcpy(m.o[k].box, b + 6 * k, 6 * sizeof *b);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s1, mv, b, n));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s2, mv, b, n));
    update_both(e1, s1, s2, &m);
    locd_scene_destroy(s1);
    locd_scene_destroy(s2);
    locd_engine_destroy(e1);
    locd_engine_destroy(e2);
    free(b), free(ids1), free(ids2), free(mv), free(pos), free(m.o), free(m.pairs);
}

/* Boxes of positions pos[0, cnt) for whole_scene_moves_in_slot_order: the
 * lattice's box of each object shifted along x by a quarter times 0 to 3,
 * from ts_next (floats exactly; which neighbours touch depends on the
 * draws, so a box written to another slot changes the pairs). */
static void jitter_boxes(su_model *m, const locd_id *ids, const size_t *pos, size_t cnt, ts_rng *r, locd_id *mv,
                         float *f)
{
    size_t i;
    int a;
    for (i = 0; i < cnt; i++) {
        double b[6], dx = 0.25 * (double)(ts_next(r) & 3);
        lattice_box(pos[i], 0.0, b);
        b[0] += dx, b[3] += dx;
        mv[i] = ids[pos[i]];
        for (a = 0; a < 6; a++)
            f[6 * i + a] = (float)b[a];
        memcpy(m->o[pos[i]].box, b, sizeof b);
    }
}

/* A float move of every object in slot order copies the boxes to the
 * spare array while it checks them, then swaps the arrays (move.c). The
 * swap must follow a good batch only; the spare it leaves (the old boxes)
 * must never be read as the boxes; a bad batch written half into the spare
 * changes nothing; and the batches that are not in slot order, or not of
 * every object, write the boxes as before. */
static void whole_scene_moves_in_slot_order(void)
{
    const size_t n = 120000;
    locd_engine *e1 = su_new_engine(1, NULL), *e2 = su_new_engine(2, NULL);
    locd_scene *s1 = NULL, *s2 = NULL;
    locd_id *ids1 = malloc(n * sizeof *ids1), *ids2 = malloc(n * sizeof *ids2), *mv = malloc(n * sizeof *mv);
    size_t *pos = malloc(n * sizeof *pos), k;
    float *f = malloc(n * 6 * sizeof *f);
    double b[6];
    su_model m;
    ts_rng r;
    int a, round;
    memset(&m, 0, sizeof m);
    ts_seed(&r, 616);
    for (k = 0; k < n; k++) {
        lattice_box(k, 0.0, b);
        for (a = 0; a < 6; a++)
            f[6 * k + a] = (float)b[a];
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e1, NULL, &s1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e2, NULL, &s2));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s1, f, n, NULL, ids1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s2, f, n, NULL, ids2));
    TEST_ASSERT_EQUAL_MEMORY(ids1, ids2, n * sizeof *ids1);
    for (k = 0; k < n; k++) {
        lattice_box(k, 0.0, b);
        su_model_add(&m, ids1[k], b, 1, ~(uint64_t)0, 0, 0, 0);
    }
    update_both(e1, s1, s2, &m);
    /* in slot order, three times: the arrays swap back and forth */
    for (k = 0; k < n; k++)
        pos[k] = k;
    for (round = 0; round < 3; round++) {
        if (round == 1) { /* some slots dirty already: the move counts only the others as new to the
                             dirty list, and sets every slot's flag */
            size_t few[3] = {0, 60001, n - 1};
            jitter_boxes(&m, ids1, few, 3, &r, mv, f);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, 3));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, 3));
        }
        jitter_boxes(&m, ids1, pos, n, &r, mv, f);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, n));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, n));
        update_both(e1, s1, s2, &m);
        if (round == 1) { /* a few moved after (one at the threads' split): every slot must have left
                             the dirty list, or its move would be missed */
            size_t few[2] = {n / 2, 70000};
            locd_scene_stats st;
            locd_scene_stats_init(&st);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s2, &st));
            TEST_ASSERT_EQUAL_UINT64(n, st.moved);
            jitter_boxes(&m, ids1, few, 2, &r, mv, f);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, 2));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, 2));
            update_both(e1, s1, s2, &m);
            locd_scene_stats_init(&st);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s2, &st));
            TEST_ASSERT_EQUAL_UINT64(2, st.moved);
        }
    }
    /* a bad batch in slot order: the spare takes the boxes up to the bad
       one (in each thread's range), and nothing changes */
    {
        su_model keep = m;
        keep.o = malloc(n * sizeof *keep.o);
        memcpy(keep.o, m.o, n * sizeof *keep.o);
        jitter_boxes(&keep, ids1, pos, n, &r, mv, f);
        f[6 * 90000 + 2] = NAN;
        bad_move_both(s1, s2, mv, f, 0, n, LOCD_ERR_NONFINITE, 90000);
        /* the ids ascending but one naming the next slot with its own serial
           (the slots' ids are consecutive: the move checks them without
           reading them) */
        f[6 * 90000 + 2] = f[6 * 90000 + 5] - 0.001f;
        mv[70000] += 1;
        bad_move_both(s1, s2, mv, f, 0, n, LOCD_ERR_STALE_ID, 70000);
        mv[70000] -= 1;
        /* an id twice: the batch no longer ascends, and the stamps find it */
        mv[50000] = mv[50001];
        bad_move_both(s1, s2, mv, f, 0, n, LOCD_ERR_DUPLICATE_ID, 50001);
        mv[50000] = ids1[50000];
        free(keep.o);
    }
    /* a fifth of the objects, then (from scratch) every box is read: the
       others must be the last good batch's boxes, not the spare's */
    for (k = 0; k < n / 5; k++)
        pos[k] = 5 * k;
    jitter_boxes(&m, ids1, pos, n / 5, &r, mv, f);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, n / 5));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, n / 5));
    update_both(e1, s1, s2, &m);
    /* every object in reverse slot order (the spare is written, not
       swapped), then in slot order again */
    for (k = 0; k < n; k++)
        pos[k] = n - 1 - k;
    for (round = 0; round < 2; round++) {
        jitter_boxes(&m, ids1, pos, n, &r, mv, f);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, n));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, n));
        update_both(e1, s1, s2, &m);
        for (k = 0; k < n; k++)
            pos[k] = k;
    }
    /* one object removed: a slot is not live, so no batch is of every slot */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s1, &ids1[7], 1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s2, &ids1[7], 1));
    su_model_remove(&m, ids1[7]); /* the model's last object takes position 7 */
    update_both(e1, s1, s2, &m);
    for (k = 0; k + 1 < n; k++)
        mv[k] = m.o[k].id;
    for (k = 0; k + 1 < n; k++) {
        m.o[k].box[0] += 0.125, m.o[k].box[3] -= 0.125;
        for (a = 0; a < 6; a++)
            f[6 * k + a] = (float)m.o[k].box[a];
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s1, mv, f, n - 1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s2, mv, f, n - 1));
    update_both(e1, s1, s2, &m);
    locd_scene_destroy(s1);
    locd_scene_destroy(s2);
    locd_engine_destroy(e1);
    locd_engine_destroy(e2);
    free(f), free(ids1), free(ids2), free(mv), free(pos), free(m.o), free(m.pairs);
}

static const lt_test tests[] = {
    LT_TEST(large_moves_on_the_pool),
    LT_TEST(whole_scene_moves_in_slot_order),
};

int main(void)
{
    return LT_RUN(tests);
}
