/* What the scene takes and what it refuses: updates of an empty scene
 * (never filled, emptied, filled again); bad batches (stale, repeated and
 * missing ids, NaN and inverted boxes, float32 and float64) rejected with
 * the index of the first fault, nothing changed; engines of levels 2 and 3
 * refused; hard boxes (identical, touching, zero-size, -0, huge next to
 * tiny, at scales from 3.5e-300 to 1e30, one that grows the root cube and
 * comes back) against the brute-force model, with queries. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "scene_util.h"

/* A fingerprint of the scene: its pairs after an update and a big query. */
static uint64_t fingerprint(locd_scene *s)
{
    const locd_id *p;
    size_t np, i, nq = 0;
    locd_id ids[64];
    double q[6] = {-1e9, -1e9, -1e9, 1e9, 1e9, 1e9};
    uint64_t h = 1469598103934665603ull;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_box_f64(s, q, ~(uint64_t)0, ids, 64, &nq));
    for (i = 0; i < nq; i++)
        h = (h ^ ids[i]) * 1099511628211ull;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, LOCD_SCENE_UPDATE_PAIRS));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s, &p, &np));
    for (i = 0; i < 2 * np; i++)
        h = (h ^ p[i]) * 1099511628211ull;
    return h ^ locd_scene_count(s);
}

/* Empty scenes: an update with no object, after every object was removed,
 * and after objects come back, at 1 and 2 threads (the bindings' random
 * sequences met a failing update on an empty scene). */
static void empty_scene_updates(void)
{
    int threads;
    for (threads = 1; threads <= 2; threads++) {
        locd_engine *e = su_new_engine((uint32_t)threads, NULL);
        locd_scene *s = NULL;
        su_model m;
        double b[6 * 3] = {0, 0, 0, 1, 1, 1, 0.5, 0.5, 0.5, 2, 2, 2, 5, 5, 5, 6, 6, 6};
        locd_id ids[3];
        size_t got, k;
        memset(&m, 0, sizeof m);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
        su_check_update(s, &m); /* nothing ever added */
        su_check_update(s, &m);
        su_add_boxes(s, &m, b, 3, 0, ids);
        su_check_update(s, &m);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, ids, 3));
        for (k = 0; k < 3; k++)
            su_model_remove(&m, ids[k]);
        su_check_update(s, &m); /* every pair lost */
        TEST_ASSERT_EQUAL_UINT64(0, locd_scene_count(s));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_query_box_f64(s, b, ~(uint64_t)0, ids, 3, &got));
        TEST_ASSERT_EQUAL_UINT64(0, got);
        su_check_update(s, &m); /* empty again, after removals */
        su_add_boxes(s, &m, b, 3, 1, ids); /* static this time: no pair */
        su_check_update(s, &m);
        su_add_boxes(s, &m, b, 2, 0, ids);
        su_check_update(s, &m);
        locd_scene_destroy(s);
        locd_engine_destroy(e);
        free(m.o), free(m.pairs);
    }
}

/* Identical boxes, touching faces, zero-size boxes, huge next to tiny, far
 * from the origin, -0, and a box that grows the root cube and comes back:
 * each update against the model, with queries. */
static void hard_cases(void)
{
    static const double scales[] = {1.0, 1e-6, 1e30, 3.5e-300};
    size_t si;
    for (si = 0; si < sizeof scales / sizeof scales[0]; si++) {
        const double u = scales[si];
        locd_engine *e = su_new_engine(2, NULL);
        locd_scene *s = NULL;
        su_model m;
        double b[6 * 64];
        locd_id ids[64];
        int i, a, step;
        memset(&m, 0, sizeof m);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
        /* 20 identical boxes */
        for (i = 0; i < 20; i++)
            for (a = 0; a < 3; a++)
                b[6 * i + a] = 1.0 * u, b[6 * i + 3 + a] = 2.0 * u;
        su_add_boxes(s, &m, b, 20, 0, ids);
        /* a lattice of touching unit boxes, some static */
        for (i = 0; i < 27; i++)
            for (a = 0; a < 3; a++) {
                int c = (i / (a == 0 ? 1 : a == 1 ? 3 : 9)) % 3;
                b[6 * i + a] = (3.0 + c) * u, b[6 * i + 3 + a] = (4.0 + c) * u;
            }
        su_add_boxes(s, &m, b, 14, 1, ids + 20);
        su_add_boxes(s, &m, b + 6 * 14, 13, 0, ids + 34);
        /* zero-size boxes on the lattice's corners and faces, -0 */
        for (i = 0; i < 6; i++)
            for (a = 0; a < 3; a++)
                b[6 * i + a] = b[6 * i + 3 + a] = (3.0 + (double)((i + a) % 4)) * u;
        b[0] = b[3] = -0.0;
        su_add_boxes(s, &m, b, 6, 0, ids + 47);
        /* huge next to tiny */
        for (a = 0; a < 3; a++) {
            b[a] = -1e3 * u, b[3 + a] = 1e3 * u;
            b[6 + a] = 3.5 * u, b[9 + a] = 3.5 * u + 1e-9 * u;
        }
        su_add_boxes(s, &m, b, 2, 0, ids + 53);
        su_check_update(s, &m);
        for (step = 0; step < 30; step++) {
            locd_id id = ids[(size_t)(step * 7) % 55];
            double nb[6], q[7];
            const su_obj *o = su_model_find(&m, id);
            memcpy(nb, o->box, sizeof nb);
            if (step % 10 == 3) { /* far out: the root cube must grow */
                for (a = 0; a < 6; a++)
                    nb[a] += 1e6 * u;
            } else if (step % 10 == 4) { /* and back */
                for (a = 0; a < 6; a++)
                    nb[a] -= 1e6 * u;
            } else { /* onto a neighbour's face */
                double d = (double)(step % 3) * 1.0 * u;
                for (a = 0; a < 6; a++)
                    nb[a] += d;
            }
            if (isfinite(nb[0]) && isfinite(nb[5]) && nb[0] <= nb[3] && nb[1] <= nb[4] && nb[2] <= nb[5])
                su_move_box(s, &m, id, nb);
            su_check_update(s, &m);
            for (a = 0; a < 3; a++)
                q[a] = 3.0 * u, q[a + 3] = 4.0 * u;
            su_check_query(s, &m, 0, q, ~(uint64_t)0);
            su_check_query(s, &m, 1, q + 3, ~(uint64_t)0);
            q[0] = 0.0, q[1] = 3.5 * u, q[2] = 3.5 * u, q[3] = 1.0, q[4] = 0.0, q[5] = 0.0, q[6] = 10.0 * u;
            su_check_query(s, &m, 2, q, ~(uint64_t)0);
        }
        locd_scene_destroy(s);
        locd_engine_destroy(e);
        free(m.o);
        free(m.pairs);
    }
}

static void bad_batches_change_nothing(void)
{
    locd_engine *e = su_new_engine(1, NULL);
    locd_scene *s = NULL;
    double b[6 * 8];
    float f[6 * 8];
    locd_id ids[8], bad[4], removed;
    uint64_t v[4] = {1, 2, 3, 4}, h;
    int i;
    for (i = 0; i < 8; i++) {
        int a;
        for (a = 0; a < 3; a++)
            b[6 * i + a] = i * 0.5 + a, b[6 * i + 3 + a] = i * 0.5 + a + 1.0;
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, 8, NULL, ids));
    removed = ids[7];
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, &removed, 1));
    h = fingerprint(s);
    TEST_ASSERT_TRUE(h == fingerprint(s));
    /* stale: removed, never issued, id 0 */
    bad[0] = ids[0], bad[1] = ids[1], bad[2] = removed;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_scene_move_f64(s, bad, b, 3));
    TEST_ASSERT_EQUAL_INT64(2, locd_last_error_index());
    bad[2] = ids[6] + ((uint64_t)1000 << 32);
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_scene_remove(s, bad, 3));
    TEST_ASSERT_EQUAL_INT64(2, locd_last_error_index());
    bad[1] = LOCD_ID_NONE;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_scene_set_filter(s, bad, 2, v, NULL, NULL));
    TEST_ASSERT_EQUAL_INT64(1, locd_last_error_index());
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_scene_set_user(s, bad, 2, v));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_scene_get_user(s, bad, 2, v));
    /* duplicates */
    bad[0] = ids[0], bad[1] = ids[1], bad[2] = ids[0];
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_DUPLICATE_ID, locd_scene_move_f64(s, bad, b, 3));
    TEST_ASSERT_EQUAL_INT64(2, locd_last_error_index());
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_DUPLICATE_ID, locd_scene_remove(s, bad, 3));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_DUPLICATE_ID, locd_scene_set_filter(s, bad, 3, v, v, v));
    /* NaN and inverted boxes, f64 and f32, add and move */
    for (i = 0; i < 48; i++)
        f[i] = (float)b[i];
    b[6 * 2 + 4] = NAN;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_NONFINITE, locd_scene_add_f64(s, b, 4, NULL, bad));
    TEST_ASSERT_EQUAL_INT64(2, locd_last_error_index());
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_NONFINITE, locd_scene_move_f64(s, ids, b, 4));
    TEST_ASSERT_EQUAL_INT64(2, locd_last_error_index());
    f[6 * 3 + 0] = 10.0f;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVERTED_BOX, locd_scene_add_f32(s, f, 4, NULL, bad));
    TEST_ASSERT_EQUAL_INT64(3, locd_last_error_index());
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVERTED_BOX, locd_scene_move_f32(s, ids, f, 4));
    TEST_ASSERT_EQUAL_INT64(3, locd_last_error_index());
    f[6 * 3 + 0] = INFINITY;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_NONFINITE, locd_scene_move_f32(s, ids, f, 4));
    TEST_ASSERT_TRUE(h == fingerprint(s));
    TEST_ASSERT_EQUAL_UINT64(7, locd_scene_count(s));
    locd_scene_destroy(s);
    locd_engine_destroy(e);
}

static void levels_2_and_3_are_unsupported(void)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_scene *s = (locd_scene *)&cfg;
    locd_engine_config_init(&cfg);
    cfg.level = LOCD_LEVEL_WORKERS;
    cfg.threads = 1;
    if (locd_engine_create(&cfg, &e) != LOCD_OK)
        TEST_IGNORE_MESSAGE("no level-2 engine here");
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_UNSUPPORTED, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_NULL(s);
    TEST_ASSERT_NOT_NULL(strstr(locd_last_error(), "level 1"));
    locd_engine_destroy(e);
}

/* A count the scene can never hold is refused before the arrays are read:
 * the buffers here are one element long (reading past them would crash
 * under the sanitizers, or read garbage), the counts far larger. For add,
 * more ids than a scene ever issues; for move, remove and set_filter, more
 * ids than live objects (such a batch must repeat or name a stale id). */
static void huge_counts_are_refused_before_any_read(void)
{
    locd_engine *e = su_new_engine(1, NULL);
    locd_scene *s;
    float fb[6] = {0, 0, 0, 1, 1, 1};
    double db[6] = {0, 0, 0, 1, 1, 1};
    locd_id id, out[1];
    uint64_t one = 1;
    const size_t huge = SIZE_MAX / 6;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, fb, 1, NULL, &id));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_TOO_MANY_OBJECTS, locd_scene_add_f32(s, fb, huge, NULL, out));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_TOO_MANY_OBJECTS, locd_scene_add_f64(s, db, huge, NULL, out));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_TOO_MANY_OBJECTS, locd_scene_move_f32(s, &id, fb, huge));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_TOO_MANY_OBJECTS, locd_scene_move_f64(s, &id, db, 2));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_TOO_MANY_OBJECTS, locd_scene_remove(s, &id, huge));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_TOO_MANY_OBJECTS, locd_scene_set_filter(s, &id, huge, &one, NULL, NULL));
    TEST_ASSERT_EQUAL_size_t(1, locd_scene_count(s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s, &id, fb, 1)); /* the scene is as it was */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s, 0));
    locd_scene_destroy(s);
    locd_engine_destroy(e);
}

/* A move of [a NaN box, then a stale id]: the first bad position (0) is
 * named, as scene.h promises. */
static void first_bad_position_is_named(void)
{
    locd_engine *e = su_new_engine(1, NULL);
    locd_scene *s;
    double b[12] = {0, 0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1};
    locd_id ids[2];
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, 2, NULL, ids));
    b[1] = NAN;
    ids[1] = 777;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_NONFINITE, locd_scene_move_f64(s, ids, b, 2));
    TEST_ASSERT_EQUAL_INT64(0, locd_last_error_index());
    b[1] = 0;
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_scene_move_f64(s, ids, b, 2));
    TEST_ASSERT_EQUAL_INT64(1, locd_last_error_index());
    locd_scene_destroy(s);
    locd_engine_destroy(e);
}

static const lt_test tests[] = {
    LT_TEST(huge_counts_are_refused_before_any_read),
    LT_TEST(first_bad_position_is_named),
    LT_TEST(empty_scene_updates),
    LT_TEST(hard_cases),
    LT_TEST(bad_batches_change_nothing),
    LT_TEST(levels_2_and_3_are_unsupported),
};

int main(void)
{
    return LT_RUN(tests);
}
