/* Long random sequences of add, move (a small step or anywhere), remove,
 * set_filter and set_user, with static objects, against the brute-force
 * model at every update (pairs, created, lost), with box, point and ray
 * queries between them: random boxes, touching lattices, boxes far from the
 * origin; a larger scene on two threads; one and two threads giving the
 * same lists; a dense scene whose every object moves, then a few, then some
 * come and go (the from-scratch update, then the incremental one). */
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "scene_util.h"

typedef struct run_opts {
    uint32_t threads;
    int steps;
    int start; /* objects added first */
    int shape;
    int queries; /* queries per step */
    uint64_t seed;
} run_opts;

/* Runs one random sequence; returns a hash of every update's pair lists
 * (for the thread-count comparison). */
static uint64_t run_sequence(const run_opts *ro)
{
    su_world w;
    su_model m;
    locd_engine *e = su_new_engine(ro->threads, NULL);
    locd_scene *s = NULL;
    uint64_t hash = 1469598103934665603ull;
    int step, k;
    size_t big = ro->start > 256 ? (size_t)ro->start : 256;
    locd_id *ids = malloc(big * sizeof *ids);
    double *boxes = malloc(6 * big * sizeof *boxes);
    uint64_t *v[3];
    float *f = malloc(6 * big * sizeof *f);
    v[0] = malloc(3 * big * sizeof(uint64_t)), v[1] = v[0] + big, v[2] = v[1] + big;
    memset(&m, 0, sizeof m);
    w = su_world_make(ro->seed, 100.0, 4.0, ro->shape);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    for (step = 0; step < ro->steps; step++) {
        int op = step == 0 ? 0 : (int)(ts_next(&w.r) % 10);
        size_t n = step == 0 ? (size_t)ro->start : 1 + ts_next(&w.r) % 8;
        size_t i;
        if (op <= 1 || m.n < 10) { /* add */
            locd_scene_add_options o;
            int stat = (ts_next(&w.r) % 3) == 0;
            locd_scene_add_options_init(&o);
            o.flags = stat ? LOCD_OBJECT_STATIC : 0;
            for (i = 0; i < n; i++) {
                su_random_box(&w, boxes + 6 * i);
                v[0][i] = su_random_bits(&w), v[1][i] = su_random_bits(&w), v[2][i] = ts_next(&w.r) % 3;
            }
            o.categories = v[0], o.masks = v[1], o.groups = v[2];
            o.user = ts_next(&w.r);
            if (n > 4 && (ts_next(&w.r) & 1)) {
                for (i = 0; i < 6 * n; i++)
                    f[i] = su_to_float(boxes[i]), boxes[i] = f[i];
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, f, n, &o, ids));
            } else {
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, boxes, n, &o, ids));
            }
            for (i = 0; i < n; i++)
                su_model_add(&m, ids[i], boxes + 6 * i, v[0][i], v[1][i], v[2][i], o.user, stat);
        } else if (op <= 5) { /* move: some by a small step, some anywhere */
            size_t cnt = 0;
            for (i = 0; i < n && i < m.n; i++) {
                const su_obj *o = &m.o[ts_next(&w.r) % m.n];
                size_t j;
                int a, dup = 0;
                for (j = 0; j < cnt; j++)
                    dup |= ids[j] == o->id;
                if (dup)
                    continue;
                ids[cnt] = o->id;
                if (ts_next(&w.r) & 1) {
                    double d = (ts_uniform(&w.r) - 0.5) * w.size;
                    for (a = 0; a < 6; a++)
                        boxes[6 * cnt + (size_t)a] = o->box[a] + (w.shape == 1 ? 0.0 : d);
                } else {
                    su_random_box(&w, boxes + 6 * cnt);
                }
                cnt++;
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, ids, boxes, cnt));
            for (i = 0; i < cnt; i++)
                memcpy(su_model_find(&m, ids[i])->box, boxes + 6 * i, 6 * sizeof(double));
        } else if (op == 6) { /* remove */
            size_t cnt = 0;
            for (i = 0; i < n && m.n > 0; i++) {
                locd_id id = m.o[ts_next(&w.r) % m.n].id;
                ids[cnt++] = id;
                su_model_remove(&m, id);
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, ids, cnt));
        } else if (op == 7) { /* filter */
            size_t cnt = 0;
            int which = (int)(ts_next(&w.r) % 4);
            for (i = 0; i < n && i < m.n; i++) {
                const su_obj *o = &m.o[ts_next(&w.r) % m.n];
                size_t j;
                int dup = 0;
                for (j = 0; j < cnt; j++)
                    dup |= ids[j] == o->id;
                if (dup)
                    continue;
                ids[cnt] = o->id;
                v[0][cnt] = su_random_bits(&w), v[1][cnt] = su_random_bits(&w), v[2][cnt] = ts_next(&w.r) % 3;
                cnt++;
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, ids, cnt, which != 1 ? v[0] : NULL,
                                                                 which != 2 ? v[1] : NULL, which != 3 ? v[2] : NULL));
            for (i = 0; i < cnt; i++) {
                su_obj *o = su_model_find(&m, ids[i]);
                if (which != 1)
                    o->cat = v[0][i];
                if (which != 2)
                    o->mask = v[1][i];
                if (which != 3)
                    o->group = v[2][i];
            }
        } else if (op == 8) { /* users */
            size_t cnt = 0;
            uint64_t *got = v[1];
            for (i = 0; i < n && i < m.n; i++) {
                const su_obj *o = &m.o[ts_next(&w.r) % m.n];
                size_t j;
                int dup = 0;
                for (j = 0; j < cnt; j++)
                    dup |= ids[j] == o->id;
                if (dup)
                    continue;
                ids[cnt] = o->id;
                v[0][cnt] = ts_next(&w.r);
                cnt++;
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_user(s, ids, cnt, v[0]));
            for (i = 0; i < cnt; i++)
                su_model_find(&m, ids[i])->user = v[0][i];
            for (i = 0; i < m.n && i < 256; i++)
                ids[i] = m.o[i].id;
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_get_user(s, ids, i, got));
            while (i-- > 0)
                TEST_ASSERT_EQUAL_UINT64(m.o[i].user, got[i]);
        }
        /* op 9: no change */
        if ((ts_next(&w.r) % 3) != 0 || step == ro->steps - 1) {
            const locd_id *p;
            size_t np;
            su_check_update(s, &m);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s, &p, &np));
            for (i = 0; i < 2 * np; i++)
                hash = (hash ^ p[i]) * 1099511628211ull;
        }
        for (k = 0; k < ro->queries; k++)
            su_random_query(&w, s, &m);
    }
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o);
    free(m.pairs);
    free(ids), free(boxes), free(f), free(v[0]);
    return hash;
}

static void random_sequences(void)
{
    int shape;
    for (shape = 0; shape < 3; shape++) {
        run_opts ro = {1, 1500, 60, 0, 2, 0};
        ro.steps = su_steps(ro.steps);
        ro.shape = shape;
        ro.seed = 100 + (uint64_t)shape;
        su_updates = su_incremental = 0;
        run_sequence(&ro);
        LT_PRINT("shape %d: %u of %u updates incremental\n", shape, su_incremental, su_updates);
        /* the incremental path is what is under test */
        TEST_ASSERT_TRUE(su_incremental * 2 > su_updates);
    }
}

static void bigger_scene_two_threads(void)
{
    run_opts ro = {2, 200, 3000, 0, 1, 7};
    ro.steps = su_steps(ro.steps);
    run_sequence(&ro);
}

/* A dense scene (about 10^5 pairs: the from-scratch rows and events are
 * split over the threads) where every object moves, then a few, then some
 * are added and removed: a from-scratch update drops the entry lists, the
 * next small one builds them again before its search, queries in between
 * test every object. Float-exact boxes and default filters (the float find,
 * no filter pass) or double boxes, static objects and random filters. */
static void whole_scene_moves_then_a_few(void)
{
    int variant, frame;
    uint32_t threads;
    for (variant = 0; variant < 2; variant++)
        for (threads = 1; threads <= 2; threads++) {
            const size_t n0 = 3000;
            su_world w;
            su_model m;
            locd_engine *e = su_new_engine(threads, NULL);
            locd_scene *s = NULL;
            locd_scene_add_options o;
            locd_scene_stats st;
            locd_id *ids = malloc(n0 * sizeof *ids);
            double *boxes = malloc(6 * n0 * sizeof *boxes);
            float *f = malloc(6 * n0 * sizeof *f);
            size_t i, k;
            memset(&m, 0, sizeof m);
            w = su_world_make(77 + (uint64_t)variant, 20.0, 4.0, 0);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
            locd_scene_add_options_init(&o);
            for (i = 0; i < n0; i++) {
                su_random_box(&w, boxes + 6 * i);
                if (variant == 0)
                    for (k = 0; k < 6; k++)
                        f[6 * i + k] = su_to_float(boxes[6 * i + k]), boxes[6 * i + k] = f[6 * i + k];
            }
            if (variant == 0) {
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, f, n0, &o, ids));
                for (i = 0; i < n0; i++)
                    su_model_add(&m, ids[i], boxes + 6 * i, 1, ~(uint64_t)0, 0, 0, 0);
            } else {
                o.flags = LOCD_OBJECT_STATIC;
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, boxes, 300, &o, ids));
                o.flags = 0;
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, boxes + 6 * 300, n0 - 300, &o, ids + 300));
                for (i = 0; i < n0; i++)
                    su_model_add(&m, ids[i], boxes + 6 * i, 1, ~(uint64_t)0, 0, 0, i < 300);
                for (i = 0; i < 400; i++) { /* filters on a few */
                    uint64_t c = su_random_bits(&w), mk = su_random_bits(&w), g = ts_next(&w.r) % 3;
                    su_obj *mo = &m.o[(size_t)(ts_next(&w.r) % n0)];
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, &mo->id, 1, &c, &mk, &g));
                    mo->cat = c, mo->mask = mk, mo->group = g;
                }
            }
            for (frame = 0; frame < 9; frame++) {
                int kind = frame % 3; /* 0 all move, 1: 1% move, 2: add, remove, move a few */
                size_t cnt = 0;
                if (kind == 0 || kind == 1) {
                    size_t every = kind == 0 ? 1 : 97;
                    for (i = 0; i < m.n; i += every) {
                        double d = (ts_uniform(&w.r) - 0.5) * 0.4;
                        ids[cnt] = m.o[i].id;
                        for (k = 0; k < 6; k++) {
                            boxes[6 * cnt + k] = m.o[i].box[k] + d;
                            if (variant == 0)
                                boxes[6 * cnt + k] = su_to_float(boxes[6 * cnt + k]);
                        }
                        memcpy(m.o[i].box, boxes + 6 * cnt, 6 * sizeof(double));
                        cnt++;
                    }
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, ids, boxes, cnt));
                } else {
                    for (i = 0; i < 5; i++) {
                        ids[i] = m.o[(size_t)(ts_next(&w.r) % m.n)].id;
                        su_model_remove(&m, ids[i]);
                    }
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, ids, 5));
                    for (i = 0; i < 5; i++)
                        su_random_box(&w, boxes + 6 * i);
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, boxes, 5, NULL, ids));
                    for (i = 0; i < 5; i++)
                        su_model_add(&m, ids[i], boxes + 6 * i, 1, ~(uint64_t)0, 0, 0, 0);
                }
                for (k = 0; k < 5; k++) /* changes pending */
                    su_random_query(&w, s, &m);
                su_check_update(s, &m);
                locd_scene_stats_init(&st);
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s, &st));
                TEST_ASSERT_EQUAL_UINT32(kind == 0 ? 1u : 0u, st.rebuilt);
                if (frame == 0)
                    TEST_ASSERT_TRUE(m.npairs > 65536); /* the threads' split is used */
                for (k = 0; k < 10; k++)
                    su_random_query(&w, s, &m);
            }
            locd_scene_destroy(s);
            locd_engine_destroy(e);
            free(m.o);
            free(m.pairs);
            free(ids), free(boxes), free(f);
        }
}

static void thread_counts_give_identical_lists(void)
{
    run_opts ro = {1, 300, 2000, 0, 0, 99};
    uint64_t h1, h2;
    ro.steps = su_steps(ro.steps);
    h1 = run_sequence(&ro);
    ro.threads = 2;
    h2 = run_sequence(&ro);
    TEST_ASSERT_EQUAL_UINT64(h1, h2);
}

static const lt_test tests[] = {
    LT_TEST(random_sequences),
    LT_TEST(bigger_scene_two_threads),
    LT_TEST(whole_scene_moves_then_a_few),
    LT_TEST(thread_counts_give_identical_lists),
};

int main(void)
{
    return LT_RUN(tests);
}
