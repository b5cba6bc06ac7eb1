/* The near-pair list (lib/scene/near_list.c): the fat boxes' pairs, kept
 * while every box stays inside its fat box, so that whole-scene moves of
 * small steps cost a pass over the list. Through its builds, its frames,
 * its outputs' overflows and its drops, on 1, 2 and 3 threads; every
 * update against the engine's own find and the path its statistics show. */
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "scene_util.h"

/* What a frame of near_list_follows_whole_scene_moves does, and which
 * path its update must take. */
typedef struct near_frame {
    const char *what;
    int near; /* 1: from the near-pair list; 0: from scratch (with or without building it) */
} near_frame;

/* The near-pair list (near_list.c) serves whole-scene moves of small
 * steps: a from-scratch update builds it, the next ones take it while every
 * box stays inside its fat box. Three scenes (1, 2 and 3 threads: the pass's
 * outputs closed up from one, two and three regions) go through each way,
 * a quarter of the objects static and each update checked against the
 * engine's own find (pairs, created, lost) and the path its statistics show:
 * steps; one object out of its fat box (built again); every box shrunk to
 * a point and back (a set that falls and grows past the rows' regions and
 * the events': the rows written again, the events from the diff); a group
 * filter set (built again with it); every object far twice (the second list
 * served nothing: the next builds wait); the last object removed, then one
 * added in its slot (ids ascending with a gap: the rows' ids read, not
 * computed); an object removed (no list). */
static void near_list_follows_whole_scene_moves(void)
{
    static const near_frame plan[] = {
        {"first update", 0},   {"step: build", 0},         {"step", 1},           {"one object out", 0},
        {"points", 1},         {"back", 1},                {"filter: build", 0},  {"step", 1},
        {"all far: build", 0}, {"all far: no build", 0},   {"step: wait", 0},     {"step: build", 0},
        {"step", 1},           {"step", 1},                {"remove the last", 0}, {"add one: build", 0},
        {"step", 1},           {"remove one", 0},
    };
    const size_t n = 72000, nd = n - n / 4, nplan = sizeof plan / sizeof plan[0];
    const double edge = 0.0153;
    locd_engine *e[3], *er = su_new_engine(2, NULL);
    locd_scene *s[3];
    locd_scene_add_options o;
    locd_id *ids = malloc(n * sizeof *ids), *ids2 = malloc(n * sizeof *ids2), *before, *now;
    float *f = malloc(n * 6 * sizeof *f), *pt = malloc(n * 6 * sizeof *pt), last[6];
    uint64_t *groups = malloc(n * sizeof *groups);
    size_t k, nbefore, nnow, live = n;
    uint32_t grouped = 0;
    ts_rng r;
    int i, a;
    size_t frame;
    ts_seed(&r, 1313);
    su_cube_boxes(&r, f, n, edge, 0.0);
    locd_scene_add_options_init(&o);
    o.flags = LOCD_OBJECT_STATIC;
    for (i = 0; i < 3; i++) {
        e[i] = su_new_engine((uint32_t)i + 1, NULL);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e[i], NULL, &s[i]));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[i], f, nd, NULL, i ? ids2 : ids));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[i], f + 6 * nd, n - nd, &o, (i ? ids2 : ids) + nd));
        if (i)
            TEST_ASSERT_EQUAL_MEMORY(ids, ids2, n * sizeof *ids);
    }
    before = malloc(2 * sizeof *before), nbefore = 0;
    for (frame = 0; frame < nplan; frame++) {
        const char *w = plan[frame].what;
        size_t moved = nd;
        if (!strcmp(w, "points")) {
            memcpy(pt, f, n * 6 * sizeof *f);
            for (k = 0; k < nd; k++)
                for (a = 0; a < 3; a++)
                    f[6 * k + a] = f[6 * k + 3 + a] = 0.5f * (f[6 * k + a] + f[6 * k + 3 + a]);
        } else if (!strcmp(w, "back")) {
            memcpy(f, pt, n * 6 * sizeof *f);
        } else if (!strncmp(w, "all far", 7)) {
            su_cube_boxes(&r, f, nd, edge, 0.0);
        } else if (frame) {
            su_cube_boxes(&r, f, nd, edge, 0.06 * edge); /* steps of up to 0.03 edge: a fat box holds two */
        } else {
            moved = 0;
        }
        if (!strcmp(w, "one object out"))
            for (a = 0; a < 3; a++)
                f[6 * 777 + a] += (float)edge, f[6 * 777 + 3 + a] += (float)edge;
        if (!strcmp(w, "filter: build")) {
            grouped = 5;
            for (k = 0; k < n; k++)
                groups[k] = k % grouped ? 0 : 7;
        }
        if (!strcmp(w, "add one: build")) /* (the last slot again, with a new serial: ids ascend, with a gap) */
            memcpy(f + 6 * (n - 1), last, sizeof last);
        for (i = 0; i < 3; i++) {
            if (!strcmp(w, "remove the last"))
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s[i], &ids[n - 1], 1));
            if (!strcmp(w, "add one: build")) {
                locd_id id;
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s[i], last, 1, &o, &id));
                TEST_ASSERT_TRUE(id > ids[n - 2]);
                if (i == 0)
                    ids[n - 1] = id;
                TEST_ASSERT_EQUAL_UINT64(ids[n - 1], id);
            }
            if (grouped && !strcmp(w, "filter: build"))
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_set_filter(s[i], ids, n, NULL, NULL, groups));
            if (!strcmp(w, "remove one"))
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_remove(s[i], &ids[nd - 1], 1));
            if (moved)
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s[i], ids, f, !strcmp(w, "remove one") ? nd - 1 : nd));
        }
        if (!strcmp(w, "remove one") || !strcmp(w, "remove the last")) { /* the reference without it: far away */
            const size_t gone = !strcmp(w, "remove one") ? nd - 1 : n - 1;
            memcpy(last, f + 6 * gone, sizeof last);
            for (a = 0; a < 3; a++)
                f[6 * gone + a] = 100.0f, f[6 * gone + 3 + a] = 100.0f;
            live--;
        }
        if (!strcmp(w, "add one: build"))
            live++;
        now = su_engine_rows_filtered(er, f, ids, n, grouped, nd, &nnow);
        TEST_ASSERT_TRUE(!strcmp(w, "points") ? nnow < n / 8 : nnow > n / 2);
        for (i = 0; i < 3; i++) {
            locd_scene_stats st;
            su_check_against(s[i], now, nnow, before, nbefore);
            locd_scene_stats_init(&st);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_stats_get(s[i], &st));
            TEST_ASSERT_EQUAL_UINT64(live, st.objects);
            if (plan[frame].near != (st.rebuilt == 0 && st.coasted == st.moved && st.entries == 0))
                LT_FAIL("frame %zu (%s), %d threads: %s the near-pair list", frame, w, i + 1,
                        plan[frame].near ? "not from" : "from");
        }
        free(before);
        before = now, nbefore = nnow;
    }
    free(before);
    for (i = 0; i < 3; i++) {
        locd_scene_destroy(s[i]);
        locd_engine_destroy(e[i]);
    }
    locd_engine_destroy(er);
    free(f), free(pt), free(ids), free(ids2), free(groups);
}

/* A lattice of unit cubes that touch exactly (faces, edges, corners),
 * their places shuffled among the ids (each closed test then meets its
 * equality with either object first), moving all together in dyadic steps, so that they go on touching; every
 * other frame every second column steps one more 1/1024 along x, and its
 * faces part from their neighbours' by exactly that gap, then touch again.
 * The near-pair list must serve these frames (stats.coasted: every object)
 * and give every touching pair (closed intervals), as the engine's find. */
static void near_list_serves_a_touching_lattice(void)
{
    enum { SIDE = 42 };
    const size_t n = (size_t)SIDE * SIDE * SIDE;
    const float step = 1.0f / 1024.0f;
    locd_engine *e = su_new_engine(2, NULL), *er = su_new_engine(2, NULL);
    locd_scene *s;
    locd_id *ids = malloc(n * sizeof *ids), *before = NULL, *now;
    float *f = malloc(n * 6 * sizeof *f);
    size_t x, y, z, k, nbefore = 0, nnow;
    int frame, served = 0;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    for (k = 0; k < n; k++) {
        const size_t p = (k * 40501u) % n; /* (40501 is coprime with 42^3: a permutation) */
        x = p / (SIDE * SIDE), y = p / SIDE % SIDE, z = p % SIDE;
        f[6 * k] = (float)x, f[6 * k + 1] = (float)y, f[6 * k + 2] = (float)z;
        f[6 * k + 3] = (float)x + 1.0f, f[6 * k + 4] = (float)y + 1.0f, f[6 * k + 5] = (float)z + 1.0f;
    }
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, f, n, NULL, ids));
    for (frame = 0; frame < 8; frame++) {
        locd_scene_stats st;
        if (frame) {
            for (k = 0; k < n; k++) {
                const int odd = (int)f[6 * k] % 2; /* (its column, before the frame's steps) */
                const float dx = step + ((frame & 1) && odd ? step : 0.0f) - (!(frame & 1) && frame > 1 && odd ? step : 0.0f);
                f[6 * k] += dx, f[6 * k + 3] += dx;
                f[6 * k + 1] += step, f[6 * k + 4] += step;
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s, ids, f, n));
        }
        now = su_engine_rows(er, f, ids, n, 0, &nnow);
        su_check_against(s, now, nnow, before, nbefore);
        locd_scene_stats_init(&st);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_get_stats(s, &st));
        served += frame && !st.rebuilt && st.coasted == n;
        free(before);
        before = now, nbefore = nnow;
    }
    LT_PRINT("touching lattice: the near-pair list served %d of 7 frames\n", served);
    TEST_ASSERT_TRUE(served >= 4);
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    locd_engine_destroy(er);
    free(before), free(f), free(ids);
}

/* Small scenes take the list too (100 to 5,000 objects, 1 and 2 threads):
 * every object steps each frame, by a fraction of its edge (the list
 * serves) or, every fifth frame, by several edges (built again); each
 * update checked against the engine's own find. */
static void near_list_serves_small_scenes(void)
{
    static const size_t sizes[] = {100, 1000, 5000};
    size_t z;
    uint32_t t;
    for (z = 0; z < sizeof sizes / sizeof sizes[0]; z++)
        for (t = 1; t <= 2; t++) {
            const size_t n = sizes[z];
            const double edge = 0.6 / cbrt((double)n); /* about 2 pairs a cube */
            locd_engine *e = su_new_engine(t, NULL), *er = su_new_engine(1, NULL);
            locd_scene *s;
            locd_id *ids = malloc(n * sizeof *ids), *before = NULL, *now;
            float *f = malloc(n * 6 * sizeof *f);
            size_t nbefore = 0, nnow;
            int frame, served = 0;
            ts_rng r;
            ts_seed(&r, 4242 + n + t);
            su_cube_boxes(&r, f, n, edge, 0.0);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, f, n, NULL, ids));
            for (frame = 0; frame < 16; frame++) {
                locd_scene_stats st;
                if (frame) {
                    su_cube_boxes(&r, f, n, edge, frame % 5 ? edge / 64 : 3 * edge);
                    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s, ids, f, n));
                }
                now = su_engine_rows(er, f, ids, n, 0, &nnow);
                su_check_against(s, now, nnow, before, nbefore);
                locd_scene_stats_init(&st);
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_get_stats(s, &st));
                served += frame && !st.rebuilt && st.coasted == n && st.entries == 0;
                free(before);
                before = now, nbefore = nnow;
            }
            LT_PRINT("%zu objects, %u threads: the near-pair list served %d of 15 frames\n", n, t, served);
            TEST_ASSERT_TRUE(served >= 5);
            locd_scene_destroy(s);
            locd_engine_destroy(e);
            locd_engine_destroy(er);
            free(before), free(f), free(ids);
        }
}

/* n cubes stepping by up to `step` of their edge per axis every frame,
 * each update checked against the engine's own find; per frame, whether it
 * built the list (rebuilt) and the candidates a list frame tested. */
static void margin_run(uint32_t threads, double step, int frames, int *built, uint64_t *cand)
{
    const size_t n = 2000;
    const double edge = 0.6 / cbrt((double)n);
    locd_engine *e = su_new_engine(threads, NULL), *er = su_new_engine(1, NULL);
    locd_scene *s;
    locd_id *ids = malloc(n * sizeof *ids), *before = NULL, *now;
    float *f = malloc(n * 6 * sizeof *f);
    size_t nbefore = 0, nnow;
    int frame;
    ts_rng r;
    ts_seed(&r, 77 + threads);
    su_cube_boxes(&r, f, n, edge, 0.0);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_create(e, NULL, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_add_f32(s, f, n, NULL, ids));
    for (frame = 0; frame < frames; frame++) {
        locd_scene_stats st;
        if (frame) {
            su_cube_boxes(&r, f, n, edge, 2 * step * edge);
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_move_f32(s, ids, f, n));
        }
        now = su_engine_rows(er, f, ids, n, 0, &nnow);
        su_check_against(s, now, nnow, before, nbefore);
        locd_scene_stats_init(&st);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_scene_get_stats(s, &st));
        built[frame] = st.rebuilt != 0;
        cand[frame] = !st.rebuilt && st.coasted == n ? st.candidates : 0;
        free(before);
        before = now, nbefore = nnow;
    }
    locd_scene_destroy(s);
    locd_engine_destroy(e);
    locd_engine_destroy(er);
    free(before), free(f), free(ids);
}

/* Steps of up to 6% of the edge leave the first margin (an eighth) after
 * 2 updates: the lists that serve so little make the next ones' margins
 * twice as wide (path.c), which then serve about 4 updates, and a build
 * comes about every fifth update instead of every third. */
static void near_margin_widens_when_lists_serve_little(void)
{
    uint32_t t;
    for (t = 1; t <= 2; t++) {
        int built[60], frame, builds = 0, served = 0;
        uint64_t cand[60];
        margin_run(t, 0.06, 60, built, cand);
        for (frame = 30; frame < 60; frame++) /* past the first lists */
            builds += built[frame], served += cand[frame] > 0;
        LT_PRINT("%u threads, frames 30-59: %d builds, %d frames served by the list\n", t, builds, served);
        /* an eighth's margin would build 10 times in these 30 frames */
        TEST_ASSERT_TRUE(builds >= 3 && builds <= 7);
        TEST_ASSERT_EQUAL_INT(30, builds + served);
    }
}

/* Steps of up to 1% of the edge: the first list (an eighth) serves some
 * 20 updates, so the next one's margin is half as wide: fewer candidates
 * a pass. */
static void near_margin_narrows_when_lists_serve_long(void)
{
    int built[60], frame, first = -1;
    uint64_t cand[60];
    margin_run(2, 0.01, 60, built, cand);
    for (frame = 2; frame < 60 && first < 0; frame++) /* (frame 1 builds the first list) */
        if (built[frame])
            first = frame;
    LT_PRINT("the first list was built again at frame %d\n", first);
    TEST_ASSERT_TRUE(first > 16 + 1 && first + 2 < 60);
    LT_PRINT("the first list served until frame %d with %llu candidates; the next tested %llu\n", first,
             (unsigned long long)cand[first - 1], (unsigned long long)cand[first + 1]);
    TEST_ASSERT_TRUE(cand[first - 1] > 0 && cand[first + 1] > 0);
    TEST_ASSERT_TRUE(cand[first + 1] * 10 < cand[first - 1] * 9);
}

static const lt_test tests[] = {
    LT_TEST(near_list_follows_whole_scene_moves),
    LT_TEST(near_list_serves_a_touching_lattice),
    LT_TEST(near_list_serves_small_scenes),
    LT_TEST(near_margin_widens_when_lists_serve_little),
    LT_TEST(near_margin_narrows_when_lists_serve_long),
};

int main(void)
{
    return LT_RUN(tests);
}
