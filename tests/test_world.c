/* The world on the scene: remove, filters and contact begin/end, held
 * against a brute-force reference (every live pair through
 * locd_shape_collide) over long random sequences, at level 1 (the scene) and
 * level 2 (the from-scratch path), which must agree. */
#include <locd/pipeline.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "levels_util.h"
#include "support.h"

#define WT_MAX 512

/* What the test knows about each index of the world. */
typedef struct model {
    size_t n;
    int live[WT_MAX];
    double pose[WT_MAX][7];
    uint64_t cat[WT_MAX], mask[WT_MAX], group[WT_MAX];
    locd_shape *shape[WT_MAX];
} model;

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static int passes(const model *m, size_t i, size_t j)
{
    return (m->cat[i] & m->mask[j]) && (m->cat[j] & m->mask[i]) && !(m->group[i] && m->group[i] == m->group[j]);
}

/* Every live pair that passes the filter and whose shapes meet, as sorted keys. */
static size_t brute(const model *m, uint64_t *keys)
{
    size_t i, j, k = 0;
    for (i = 0; i < m->n; i++)
        for (j = i + 1; j < m->n; j++) {
            int32_t hit = 0;
            if (!m->live[i] || !m->live[j] || !passes(m, i, j))
                continue;
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_shape_collide(m->shape[i], m->pose[i], m->shape[j], m->pose[j],
                                                              LOCD_ROUTE_AUTO, LOCD_CONTACT_EPA, &hit, NULL));
            if (hit)
                keys[k++] = ((uint64_t)i << 32) | j;
        }
    return k;
}

static size_t keys_of(const uint32_t *pairs, size_t m, uint64_t *keys)
{
    size_t k;
    for (k = 0; k < m; k++) {
        TEST_ASSERT_TRUE(pairs[2 * k] < pairs[2 * k + 1]);
        keys[k] = ((uint64_t)pairs[2 * k] << 32) | pairs[2 * k + 1];
    }
    qsort(keys, m, sizeof *keys, cmp_u64);
    return m;
}

/* Keys of a not in b (both sorted) into out; the count. */
static size_t minus(const uint64_t *a, size_t na, const uint64_t *b, size_t nb, uint64_t *out)
{
    size_t i = 0, j = 0, k = 0;
    while (i < na) {
        if (j == nb || a[i] < b[j])
            out[k++] = a[i++];
        else if (a[i] > b[j])
            j++;
        else
            i++, j++;
    }
    return k;
}

static void assert_list(const uint64_t *want, size_t nwant, const uint32_t *got, size_t ngot, const char *what,
                        int frame)
{
    size_t k;
    if (nwant != ngot)
        LT_FAIL("frame %d: %s: %zu pairs, expected %zu", frame, what, ngot, nwant);
    for (k = 0; k < ngot; k++) {
        uint64_t g = ((uint64_t)got[2 * k] << 32) | got[2 * k + 1];
        if (g != want[k])
            LT_FAIL("frame %d: %s row %zu: (%u, %u), expected (%u, %u)", frame, what, k, got[2 * k], got[2 * k + 1],
                    (unsigned)(want[k] >> 32), (unsigned)want[k]);
    }
}

static void random_pose(ts_rng *r, double *p)
{
    int a;
    for (a = 0; a < 3; a++)
        p[a] = 8.0 * ts_uniform(r);
    p[3] = ts_uniform(r) - 0.5;
    p[4] = ts_uniform(r) - 0.5;
    p[5] = ts_uniform(r) - 0.5;
    p[6] = 1.0;
}

static void add_object(locd_world *w, model *m, ts_rng *r, locd_shape *const *shapes)
{
    uint32_t idx = 0;
    size_t i = m->n;
    m->shape[i] = shapes[ts_next(r) % 3];
    random_pose(r, m->pose[i]);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_add(w, m->shape[i], m->pose[i], NULL, &idx));
    TEST_ASSERT_EQUAL_UINT32(i, idx); /* indices are issued in order, never reused */
    m->live[i] = 1;
    m->cat[i] = 1;
    m->mask[i] = ~(uint64_t)0;
    m->group[i] = 0;
    m->n++;
}

static void random_filter(locd_world *w, model *m, ts_rng *r, size_t i)
{
    static const uint64_t cats[] = {1, 2, 4};
    static const uint64_t masks[] = {~(uint64_t)0, 1, 3, 6, ~(uint64_t)2};
    m->cat[i] = cats[ts_next(r) % 3];
    m->mask[i] = masks[ts_next(r) % 5];
    m->group[i] = ts_next(r) % 3;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_set_filter(w, (uint32_t)i, m->cat[i], m->mask[i], m->group[i]));
}

/* One random sequence of frames: moves (some objects only), removals,
 * additions and filter changes; every frame's contacts, began and ended
 * against the reference. */
static void run_sequence(int32_t level, uint64_t seed, int frames)
{
    locd_engine_config cfg;
    locd_world *w;
    locd_contacts *c;
    locd_pipeline_options o;
    locd_shape *shapes[3];
    model *m = calloc(1, sizeof *m);
    uint64_t *want = malloc(WT_MAX * WT_MAX * sizeof *want / 2), *prev = malloc(WT_MAX * WT_MAX * sizeof *prev / 2);
    uint64_t *got = malloc(WT_MAX * WT_MAX * sizeof *got / 2), *diff = malloc(WT_MAX * WT_MAX * sizeof *diff / 2);
    size_t nprev = 0, i;
    ts_rng r;
    int f;
    TEST_ASSERT_NOT_NULL(m);
    TEST_ASSERT_NOT_NULL(diff);
    ts_seed(&r, seed);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_shape_sphere(0.5, &shapes[0]));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_shape_box(0.4, 0.3, 0.6, &shapes[1]));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_shape_capsule(0.25, 0.5, &shapes[2]));
    locd_engine_config_init(&cfg);
    cfg.level = level;
    cfg.threads = 2;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_create(&cfg, &w));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_contacts_create(&c));
    locd_pipeline_options_init(&o);
    o.find_flags = seed % 2 ? LOCD_FIND_SORTED : 0u;
    for (i = 0; i < 200; i++)
        add_object(w, m, &r, shapes);
    for (f = 0; f < frames; f++) {
        const uint32_t *began, *ended;
        size_t nb, ne, nwant, ngot, k;
        /* Changes: a fraction of the objects move, a few filters change, an
         * object goes and another comes now and then. */
        for (i = 0; i < m->n; i++)
            if (m->live[i] && ts_next(&r) % 5 == 0) {
                int a;
                for (a = 0; a < 3; a++)
                    m->pose[i][a] += 0.3 * (ts_uniform(&r) - 0.5);
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_set_pose(w, (uint32_t)i, m->pose[i]));
            }
        for (k = 0; k < m->n / 10; k++) {
            i = ts_next(&r) % m->n;
            if (m->live[i])
                random_filter(w, m, &r, i);
        }
        if (f % 3 == 1) {
            i = ts_next(&r) % m->n;
            if (m->live[i]) {
                TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_remove(w, (uint32_t)i));
                m->live[i] = 0;
            }
        }
        if (f % 4 == 2 && m->n < WT_MAX)
            add_object(w, m, &r, shapes);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_collide(w, &o, c, NULL));
        ngot = locd_contacts_count(c);
        if (o.find_flags & LOCD_FIND_SORTED)
            for (k = 1; k < ngot; k++) {
                const uint32_t *p = locd_contacts_pairs(c);
                TEST_ASSERT_TRUE(p[2 * k - 2] < p[2 * k] || (p[2 * k - 2] == p[2 * k] && p[2 * k - 1] < p[2 * k + 1]));
            }
        keys_of(locd_contacts_pairs(c), ngot, got);
        nwant = brute(m, want);
        if (nwant != ngot || memcmp(want, got, ngot * sizeof *got) != 0)
            LT_FAIL("level %d seed %llu frame %d: %zu contacts, brute force %zu", (int)level,
                    (unsigned long long)seed, f, ngot, nwant);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_contact_events(w, &began, &nb, &ended, &ne));
        k = minus(want, nwant, prev, nprev, diff);
        assert_list(diff, k, began, nb, "began", f);
        k = minus(prev, nprev, want, nwant, diff);
        assert_list(diff, k, ended, ne, "ended", f);
        memcpy(prev, want, nwant * sizeof *want);
        nprev = nwant;
    }
    locd_contacts_destroy(c);
    locd_world_destroy(w);
    for (i = 0; i < 3; i++)
        locd_shape_destroy(shapes[i]);
    free(m);
    free(want);
    free(prev);
    free(got);
    free(diff);
}

static void random_sequences_match_brute_force(void)
{
    uint64_t seed;
    for (seed = 1; seed <= 4; seed++)
        run_sequence(LOCD_LEVEL_INPROCESS, seed, 40);
}

/* Level 2 has no scene: the world falls back to a from-scratch find and the
 * same filter rule, and must give the same answers. */
static void workers_level_matches_brute_force(void)
{
    lu_setup();
    run_sequence(LOCD_LEVEL_WORKERS, 11, 12);
}

/* A fresh world holding model m (same indices: removed ones added, then removed). */
static locd_world *fresh_world(const model *m, const double *vel)
{
    locd_world *w;
    size_t i;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_create(NULL, &w));
    for (i = 0; i < m->n; i++) {
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_add(w, m->shape[i], m->pose[i], vel + 6 * i, NULL));
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_set_filter(w, (uint32_t)i, m->cat[i], m->mask[i], m->group[i]));
    }
    for (i = 0; i < m->n; i++)
        if (!m->live[i])
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_remove(w, (uint32_t)i));
    return w;
}

/* With every stage on (swept boxes that change with the velocities, contact
 * data, sorted order), a world kept across frames gives byte for byte the
 * result of a world built afresh each frame. */
static void persistent_world_equals_fresh_world(void)
{
    locd_world *w;
    locd_contacts *c, *cf;
    locd_pipeline_options o;
    locd_shape *shapes[3];
    model *m = calloc(1, sizeof *m);
    double *vel = calloc(6 * WT_MAX, sizeof(double));
    size_t i;
    ts_rng r;
    int f;
    TEST_ASSERT_NOT_NULL(m);
    TEST_ASSERT_NOT_NULL(vel);
    ts_seed(&r, 77);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_shape_sphere(0.4, &shapes[0]));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_shape_box(0.3, 0.3, 0.5, &shapes[1]));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_shape_capsule(0.2, 0.4, &shapes[2]));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_create(NULL, &w));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_contacts_create(&c));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_contacts_create(&cf));
    locd_pipeline_options_init(&o);
    o.stages = LOCD_STAGE_SHAPE | LOCD_STAGE_CONTACT;
    o.swept = LOCD_SWEPT_AUTO;
    o.dt = 0.05;
    o.find_flags = LOCD_FIND_SORTED;
    for (i = 0; i < 150; i++)
        add_object(w, m, &r, shapes);
    for (f = 0; f < 25; f++) {
        locd_world *fw;
        size_t k, n;
        for (i = 0; i < m->n; i++) {
            int a;
            if (!m->live[i] || ts_next(&r) % 4)
                continue;
            for (a = 0; a < 3; a++) {
                m->pose[i][a] += 0.2 * (ts_uniform(&r) - 0.5);
                vel[6 * i + a] = ts_next(&r) % 3 ? 0.0 : 20.0 * (ts_uniform(&r) - 0.5); /* some fast movers */
            }
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_set_pose(w, (uint32_t)i, m->pose[i]));
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_set_velocity(w, (uint32_t)i, vel + 6 * i));
        }
        i = ts_next(&r) % m->n;
        if (m->live[i])
            random_filter(w, m, &r, i);
        i = ts_next(&r) % m->n;
        if (f % 2 && m->live[i]) {
            TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_remove(w, (uint32_t)i));
            m->live[i] = 0;
        }
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_collide(w, &o, c, NULL));
        fw = fresh_world(m, vel);
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_collide(fw, &o, cf, NULL));
        n = locd_contacts_count(c);
        if (n != locd_contacts_count(cf))
            LT_FAIL("frame %d: %zu contacts, a fresh world %zu", f, n, locd_contacts_count(cf));
        for (k = 0; k < n; k++) {
            TEST_ASSERT_EQUAL_UINT32(locd_contacts_pairs(cf)[2 * k], locd_contacts_pairs(c)[2 * k]);
            TEST_ASSERT_EQUAL_UINT32(locd_contacts_pairs(cf)[2 * k + 1], locd_contacts_pairs(c)[2 * k + 1]);
            TEST_ASSERT_EQUAL_DOUBLE(locd_contacts_toi(cf)[k], locd_contacts_toi(c)[k]);
            TEST_ASSERT_EQUAL_DOUBLE(locd_contacts_depth(cf)[k], locd_contacts_depth(c)[k]);
        }
        locd_world_destroy(fw);
    }
    locd_contacts_destroy(c);
    locd_contacts_destroy(cf);
    locd_world_destroy(w);
    for (i = 0; i < 3; i++)
        locd_shape_destroy(shapes[i]);
    free(m);
    free(vel);
}

static void remove_rules(void)
{
    locd_world *w;
    locd_contacts *c;
    locd_shape *s;
    double p0[7] = {0, 0, 0, 0, 0, 0, 1}, p1[7] = {0.5, 0, 0, 0, 0, 0, 1}, p2[7] = {1.0, 0, 0, 0, 0, 0, 1};
    double poses[21], nan_pose[7] = {0, 0, 0, 0, 0, 0, 1}, out[7];
    const uint32_t *began, *ended;
    size_t nb, ne;
    uint32_t idx;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_shape_sphere(0.3, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_create(NULL, &w));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_contacts_create(&c));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_add(w, s, p0, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_add(w, s, p1, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_add(w, s, p2, NULL, NULL));
    locd_shape_destroy(s); /* the world keeps it alive */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_collide(w, NULL, c, NULL));
    TEST_ASSERT_EQUAL_size_t(2, locd_contacts_count(c)); /* (0,1), (1,2) */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_contact_events(w, &began, &nb, &ended, &ne));
    TEST_ASSERT_EQUAL_size_t(2, nb);
    TEST_ASSERT_EQUAL_size_t(0, ne);

    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_remove(w, 1));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_world_remove(w, 1));
    TEST_ASSERT_EQUAL_INT64(1, locd_last_error_index());
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVALID_ARGUMENT, locd_world_remove(w, 3));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_world_set_pose(w, 1, p1));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_world_set_velocity(w, 1, p1));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_world_get_pose(w, 1, out));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_STALE_ID, locd_world_set_filter(w, 1, 1, 1, 0));
    TEST_ASSERT_EQUAL_size_t(3, locd_world_count(w)); /* indices issued */

    /* Bulk setters still take count rows; a removed object's row is not read. */
    memcpy(poses, p0, sizeof p0);
    nan_pose[0] = 0.0 / 0.0;
    memcpy(poses + 7, nan_pose, sizeof nan_pose);
    memcpy(poses + 14, p2, sizeof p2);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_set_poses(w, poses, 3));
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVALID_ARGUMENT, locd_world_set_poses(w, poses, 2));

    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_collide(w, NULL, c, NULL));
    TEST_ASSERT_EQUAL_size_t(0, locd_contacts_count(c));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_contact_events(w, &began, &nb, &ended, &ne));
    TEST_ASSERT_EQUAL_size_t(0, nb);
    TEST_ASSERT_EQUAL_size_t(2, ne);
    TEST_ASSERT_EQUAL_UINT32(0, ended[0]);
    TEST_ASSERT_EQUAL_UINT32(1, ended[1]);
    TEST_ASSERT_EQUAL_UINT32(1, ended[2]);
    TEST_ASSERT_EQUAL_UINT32(2, ended[3]);

    /* A new object gets a new index, never the removed one's. */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_shape_sphere(0.3, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_add(w, s, p1, NULL, &idx));
    locd_shape_destroy(s);
    TEST_ASSERT_EQUAL_UINT32(3, idx);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_collide(w, NULL, c, NULL));
    TEST_ASSERT_EQUAL_size_t(2, locd_contacts_count(c)); /* (0,3), (2,3) */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_contact_events(w, NULL, &nb, NULL, &ne));
    TEST_ASSERT_EQUAL_size_t(2, nb);
    TEST_ASSERT_EQUAL_size_t(0, ne);
    /* Nothing changed: nothing begins or ends. */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_collide(w, NULL, c, NULL));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_contact_events(w, NULL, &nb, NULL, &ne));
    TEST_ASSERT_EQUAL_size_t(0, nb);
    TEST_ASSERT_EQUAL_size_t(0, ne);
    TEST_ASSERT_EQUAL_INT(LOCD_ERR_INVALID_HANDLE, locd_world_contact_events(NULL, NULL, NULL, NULL, NULL));
    locd_contacts_destroy(c);
    locd_world_destroy(w);
}

static void filters_and_groups(void)
{
    locd_world *w;
    locd_contacts *c;
    locd_shape *s;
    double p[7] = {0, 0, 0, 0, 0, 0, 1};
    int k;
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_shape_sphere(1.0, &s));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_create(NULL, &w));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_contacts_create(&c));
    for (k = 0; k < 3; k++)
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_add(w, s, p, NULL, NULL));
    locd_shape_destroy(s);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_collide(w, NULL, c, NULL));
    TEST_ASSERT_EQUAL_size_t(3, locd_contacts_count(c));
    /* 0 and 1 in one group: their pair goes. */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_set_filter(w, 0, 1, ~0ull, 7));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_set_filter(w, 1, 1, ~0ull, 7));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_collide(w, NULL, c, NULL));
    TEST_ASSERT_EQUAL_size_t(2, locd_contacts_count(c));
    /* 2 takes category 2 and masks out category 1: alone. */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_set_filter(w, 2, 2, 2, 0));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_collide(w, NULL, c, NULL));
    TEST_ASSERT_EQUAL_size_t(0, locd_contacts_count(c));
    /* Back to the defaults: all three pairs. */
    for (k = 0; k < 3; k++)
        TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_set_filter(w, (uint32_t)k, 1, ~0ull, 0));
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_world_collide(w, NULL, c, NULL));
    TEST_ASSERT_EQUAL_size_t(3, locd_contacts_count(c));
    locd_contacts_destroy(c);
    locd_world_destroy(w);
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(remove_rules),
        LT_TEST(filters_and_groups),
        LT_TEST(random_sequences_match_brute_force),
        LT_TEST(persistent_world_equals_fresh_world),
        LT_TEST(workers_level_matches_brute_force),
    };
    return LT_RUN(tests);
}
