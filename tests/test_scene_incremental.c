/* The incremental update (the objects that moved search their pairs, and
 * the pair set is patched in place): dirty lists read as a list or as
 * every slot's flags; a scene of over 65,536 pairs on one and two threads,
 * each update against a fresh scene of the same objects; the partner lists
 * of the fat boxes through their life (built, used, dropped, built again),
 * in a large scene and in a small one. */
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "scene_util.h"

/* An update reads a dirty list of an eighth of the slots or more as the
 * flags of every slot (update.c, dirty_dense); a shorter one as the list.
 * Either way stats.moved counts the live objects of the list, and every
 * DIRTY flag is cleared: one left set would keep the next move of its
 * object off the list, and that object's new pairs out of the set. A dense
 * update with moved, removed, added and re-filtered objects, then sparse
 * ones that move objects of each kind again, each checked against the
 * model. */
static void dense_and_sparse_dirty_lists(void)
{
    locd_engine *e = su_new_engine(2, NULL);
    locd_scene *s = NULL;
    const size_t n = 2000;
    double *b = malloc(n * 6 * sizeof *b);
    locd_id *ids = malloc(n * sizeof *ids), gone[100], added[50], refiltered[10];
    uint64_t cat[10];
    su_model m;
    su_world w;
    size_t k, round;
    locd_scene_stats st;
    memset(&m, 0, sizeof m);
    w = su_world_make(4242, 50.0, 3.0, 0);
    for (k = 0; k < n; k++)
        su_random_box(&w, b + 6 * k);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    su_add_boxes(s, &m, b, n, 0, ids);
    su_check_update(s, &m);
    for (k = 0; k < 600; k++) { /* 600 moved, the first 100 of them then removed */
        su_random_box(&w, b);
        su_move_box(s, &m, ids[3 * k], b);
    }
    for (k = 0; k < 100; k++)
        gone[k] = ids[3 * k];
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, gone, 100));
    for (k = 0; k < 100; k++)
        su_model_remove(&m, gone[k]);
    for (k = 0; k < 50; k++)
        su_random_box(&w, b + 6 * k);
    su_add_boxes(s, &m, b, 50, 0, added);
    for (k = 0; k < 10; k++) /* unmoved, re-filtered to what they had: dirty all the same */
        refiltered[k] = ids[3 * k + 1], cat[k] = 1;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, refiltered, 10, cat, NULL, NULL));
    su_check_update(s, &m);
    locd_scene_stats_init(&st);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s, &st));
    TEST_ASSERT_EQUAL_UINT64(500 + 50 + 10, st.moved);
    for (round = 0; round < 3; round++) { /* sparse: one moved, one added and one re-filtered object each */
        const locd_id again[3] = {ids[3 * (100 + round * 150)], added[round * 20], refiltered[round * 4]};
        for (k = 0; k < 3; k++) {
            su_random_box(&w, b);
            su_move_box(s, &m, again[k], b);
        }
        su_check_update(s, &m);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s, &st));
        TEST_ASSERT_EQUAL_UINT64(3, st.moved);
    }
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(b), free(ids), free(m.o), free(m.pairs);
}

/* A scene with more than 65536 pairs (the carry pass and the search split
 * over threads), 1 and 2 threads side by side, each update against a fresh
 * scene of the same objects. */
static void large_scene_threads_and_fresh(void)
{
    locd_engine *e1 = su_new_engine(1, NULL), *e2 = su_new_engine(2, NULL);
    locd_scene *s1 = NULL, *s2 = NULL;
    const size_t n = 30000;
    double *b = malloc(n * 6 * sizeof *b);
    locd_id *ids1 = malloc(n * sizeof *ids1), *ids2 = malloc(n * sizeof *ids2), *mv = malloc(n * sizeof *mv);
    su_model m;
    su_world w;
    size_t k, i;
    int step;
    memset(&m, 0, sizeof m);
    w = su_world_make(4242, 100.0, 6.0, 0);
    for (k = 0; k < n; k++)
        su_random_box(&w, b + 6 * k);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e1, NULL, &s1));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e2, NULL, &s2));
    {
        locd_scene_add_options o;
        locd_scene_add_options_init(&o);
        o.flags = LOCD_OBJECT_STATIC;
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s1, b, n / 3, &o, ids1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s2, b, n / 3, &o, ids2));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s1, b + 6 * (n / 3), n - n / 3, NULL, ids1 + n / 3));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s2, b + 6 * (n / 3), n - n / 3, NULL, ids2 + n / 3));
    }
    TEST_ASSERT_EQUAL_MEMORY(ids1, ids2, n * sizeof *ids1);
    for (k = 0; k < n; k++)
        su_model_add(&m, ids1[k], b + 6 * k, 1, ~(uint64_t)0, 0, 0, k < n / 3);
    for (step = 0; step < su_steps(12); step++) {
        const locd_id *p1, *p2;
        size_t n1, n2, nf;
        locd_id *want;
        size_t cnt = (size_t)(step % 3 == 0 ? n / 100 : n / 20);
        for (i = 0; i < cnt; i++) { /* distinct: a stride walk */
            size_t j = (ts_next(&w.r) % 7 + i * 13) % m.n;
            int a;
            double d = (ts_uniform(&w.r) - 0.5) * 2.0;
            su_obj *o = &m.o[j];
            size_t q;
            int dup = 0;
            for (q = 0; q < i; q++)
                dup |= mv[q] == o->id;
            if (dup) {
                cnt = i;
                break;
            }
            for (a = 0; a < 6; a++)
                o->box[a] += d;
            mv[i] = o->id;
            memcpy(b + 6 * i, o->box, 6 * sizeof *b);
        }
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s1, mv, b, cnt));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s2, mv, b, cnt));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s1, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_update(s2, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s1, &p1, &n1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_pairs(s2, &p2, &n2));
        TEST_ASSERT_TRUE(n1 > 65536);
        su_same_rows("1 thread against 2", p1, n1, p2, n2);
        want = su_fresh_pairs(e1, &m, &nf);
        su_same_rows("pairs against a fresh scene", want, nf, p1, n1);
        free(want);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_created(s1, &p1, &n1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_created(s2, &p2, &n2));
        su_same_rows("1 thread against 2", p1, n1, p2, n2);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_lost(s1, &p1, &n1));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_lost(s2, &p2, &n2));
        su_same_rows("1 thread against 2", p1, n1, p2, n2);
    }
    locd_scene_destroy(s1);
    locd_scene_destroy(s2);
    locd_engine_destroy(e1);
    locd_engine_destroy(e2);
    free(b), free(ids1), free(ids2), free(mv), free(m.o), free(m.pairs);
}

/* ---- fat boxes and partner lists (docs/scene.md) ---- */

/* A box of the partner-list test: cubes of edge 0.5-1.5 in [0, 22]^3,
 * with a point now and then and a large box rarely. */
static void pl_box(su_world *w, double *b)
{
    double e = 0.5 + ts_uniform(&w->r);
    int a, kind = (int)(ts_next(&w->r) % 100);
    if (kind == 0)
        e = 0.0;
    else if (kind == 1)
        e = 5.0;
    for (a = 0; a < 3; a++) {
        b[a] = ts_uniform(&w->r) * 22.0;
        b[a + 3] = b[a] + e;
    }
}

/* Moves the model's object i by at most step on each axis, in the scene too. */
static void pl_move(locd_scene *s, su_world *w, su_obj *o, double step)
{
    double b[6];
    int a;
    for (a = 0; a < 3; a++) {
        const double d = (ts_uniform(&w->r) - 0.5) * 2.0 * step;
        b[a] = o->box[a] + d, b[a + 3] = o->box[a + 3] + d;
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, &o->id, b, 1));
    memcpy(o->box, b, sizeof b);
}

/* Moves `count` of the model's objects (every 13th, from the second) to
 * new random boxes, never where they were: they leave their fat boxes. */
static void pl_jump(locd_scene *s, su_world *w, su_model *m, size_t count)
{
    double b[6];
    size_t k;
    for (k = 0; k < count; k++) {
        su_obj *mo = &m->o[(k * 13 + 1) % m->n];
        pl_box(w, b);
        b[0] += 0.01, b[3] += 0.01;
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f64(s, &mo->id, b, 1));
        memcpy(mo->box, b, sizeof b);
    }
}

/* The partner lists through their life: objects moving a little each frame
 * take their pairs from their lists (stats.coasted); a frame where most
 * moved objects leave their fat boxes drops the lists (every moved object
 * searches, the update stays incremental); after LC_CALM_UPDATES calm
 * updates the lists are built again. Statics move too; adds, removes and
 * filter changes come in between. Every frame against the model, with
 * over 65,536 pairs (the two threads' patch of the set). */
static void partner_lists_come_and_go(void)
{
    const size_t n0 = 16000;
    su_world w = su_world_make(5151, 22.0, 1.0, 0);
    su_model m;
    locd_engine *e = su_new_engine(2, NULL);
    locd_scene *s = NULL;
    locd_scene_add_options o;
    locd_scene_stats st;
    double b[6];
    size_t i, k;
    int frame;
    memset(&m, 0, sizeof m);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    locd_scene_add_options_init(&o);
    for (i = 0; i < n0; i++) {
        locd_id id;
        const int stat = i % 10 == 0;
        uint64_t cat = 1, mask = ~(uint64_t)0, group = 0;
        if (i % 7 == 0)
            cat = su_random_bits(&w), mask = su_random_bits(&w), group = ts_next(&w.r) % 3;
        pl_box(&w, b);
        o.flags = stat ? LOCD_OBJECT_STATIC : 0;
        o.category = cat, o.mask = mask, o.group = group;
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, 1, &o, &id));
        su_model_add(&m, id, b, cat, mask, group, 0, stat);
    }
    su_check_update(s, &m);
    TEST_ASSERT_TRUE(m.npairs > 65536);
    for (frame = 1; frame <= 13; frame++) {
        const int teleport = frame == 6;
        size_t moved = 0;
        if (teleport) {
            /* more leave their fat boxes than stay, at least LC_ADJ_MIN_LEFT
               (1,024), under 8% of the objects: lists dropped, incremental */
            pl_jump(s, &w, &m, 1100);
            for (k = 0; k < 100; k++)
                pl_move(s, &w, &m.o[(k * 13 + 7) % m.n], 0.002);
        } else {
            for (i = (size_t)frame % 50; i < m.n; i += 50, moved++) /* 2%, a little */
                pl_move(s, &w, &m.o[i], 0.002);
        }
        if (frame == 5) { /* removes, adds, filters, on top */
            locd_id ids[20];
            uint64_t c[20], mk[20], g[20];
            for (k = 0; k < 20; k++)
                ids[k] = m.o[(k * 101 + 3) % m.n].id;
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s, ids, 20));
            for (k = 0; k < 20; k++)
                su_model_remove(&m, ids[k]);
            o.flags = 0, o.category = 1, o.mask = ~(uint64_t)0, o.group = 0;
            for (k = 0; k < 20; k++) {
                locd_id id;
                pl_box(&w, b);
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, 1, &o, &id));
                su_model_add(&m, id, b, 1, ~(uint64_t)0, 0, 0, 0);
            }
            for (k = 0; k < 20; k++) {
                su_obj *mo = &m.o[(k * 37 + 11) % m.n];
                ids[k] = mo->id, c[k] = su_random_bits(&w), mk[k] = su_random_bits(&w), g[k] = ts_next(&w.r) % 3;
                mo->cat = c[k], mo->mask = mk[k], mo->group = g[k];
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s, ids, 20, c, mk, g));
        }
        su_check_update(s, &m);
        for (k = 0; k < 3; k++)
            su_random_query(&w, s, &m);
        locd_scene_stats_init(&st);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s, &st));
        TEST_ASSERT_EQUAL_UINT32(0, st.rebuilt);
        if (frame <= 5 || frame >= 11) /* the lists: built by frame 1, again at frame 10's commit */
            TEST_ASSERT_TRUE(st.coasted * 10 >= moved * 9);
        else /* dropped at frame 6, none till then */
            TEST_ASSERT_EQUAL_UINT32(0, st.coasted);
    }
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o);
    free(m.pairs);
}

/* A small scene never moves 1,024 objects, so its partner lists go when
 * more of the moved objects left their fat boxes than stayed and those
 * that left are over 8% of the objects: such an update then goes from
 * scratch (stats.rebuilt), cheaper there than every moved object searching
 * (path.c). 5% jumping keeps the lists and the update incremental. Every
 * frame against the model. */
static void small_scene_drops_its_lists_when_most_jump(void)
{
    const size_t n = 2000;
    su_world w = su_world_make(6161, 22.0, 1.0, 0);
    su_model m;
    locd_engine *e = su_new_engine(1, NULL);
    locd_scene *s = NULL;
    locd_scene_stats st;
    double b[6];
    size_t i;
    int frame;
    memset(&m, 0, sizeof m);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    for (i = 0; i < n; i++) {
        locd_id id;
        pl_box(&w, b);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f64(s, b, 1, NULL, &id));
        su_model_add(&m, id, b, 1, ~(uint64_t)0, 0, 0, 0);
    }
    su_check_update(s, &m);
    for (frame = 1; frame <= 14; frame++) {
        /* frames 6 and 12: 5% and 10% of the objects jump; the others: 2% move a little */
        const size_t jump = frame == 6 ? n / 20 : frame == 12 ? n / 10 : 0;
        size_t moved = 0;
        pl_jump(s, &w, &m, jump);
        if (!jump)
            for (i = (size_t)frame % 50; i < m.n; i += 50, moved++)
                pl_move(s, &w, &m.o[i], 0.002);
        su_check_update(s, &m);
        locd_scene_stats_init(&st);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_get_stats(s, &st));
        TEST_ASSERT_EQUAL_UINT32(frame == 12 ? 1u : 0u, st.rebuilt);
        if (frame >= 2 && frame <= 5) /* the lists, built at frame 1 */
            TEST_ASSERT_TRUE(st.coasted * 10 >= moved * 9);
        if (frame == 7) /* kept through frame 6's 5% */
            TEST_ASSERT_TRUE(st.coasted * 10 >= moved * 9);
    }
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    free(m.o);
    free(m.pairs);
}

static const lt_test tests[] = {
    LT_TEST(dense_and_sparse_dirty_lists),
    LT_TEST(large_scene_threads_and_fresh),
    LT_TEST(partner_lists_come_and_go),
    LT_TEST(small_scene_drops_its_lists_when_most_jump),
};

int main(void)
{
    return LT_RUN(tests);
}
