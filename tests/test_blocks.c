/* The paper's four steps one at a time, through the public building blocks:
 * encode, sort, merge, sweep, composed by hand the way levels 2 and 3 do. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "support.h"

static uint64_t *encode_all(const locd_grid *g, const float *b, size_t first, size_t count, size_t *m)
{
    uint64_t *e = malloc((count ? count : 1) * LOCD_MAX_ENTRIES_PER_BOX * sizeof *e);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_encode_f32(g, b, first, count, e, count * LOCD_MAX_ENTRIES_PER_BOX, m));
    return e;
}

static void encode_gives_one_to_eight_entries_per_box(void)
{
    locd_grid g;
    size_t n = 3000, m, i;
    float *b = ts_scene(2, n, 7);
    uint64_t *e;
    size_t *per = calloc(n, sizeof *per);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_grid_fit_f32(b, n, 0, 1, 0, &g));
    e = encode_all(&g, b, 0, n, &m);
    TEST_ASSERT_TRUE(m >= n && m <= 8 * n);
    for (i = 0; i < m; i++)
        per[e[i] & ((1ull << g.index_bits) - 1)]++;
    for (i = 0; i < n; i++)
        TEST_ASSERT_TRUE(per[i] >= 1 && per[i] <= 8);
    free(per);
    free(e);
    free(b);
}

static void encode_reports_capacity_needed(void)
{
    locd_grid g;
    float *b = ts_scene(0, 100, 3);
    uint64_t e[16];
    size_t w = 0;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_grid_fit_f32(b, 100, 0, 1, 0, &g));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_BUFFER_TOO_SMALL, locd_encode_f32(&g, b, 0, 100, e, 16, &w));
    TEST_ASSERT_TRUE(w > 16);
    free(b);
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static void sort_equals_qsort(void)
{
    locd_grid g;
    int kind;
    for (kind = 0; kind < TS_SCENE_KINDS; kind++) {
        size_t n = 5000, m;
        float *b = ts_scene(kind, n, 11 + (uint64_t)kind);
        uint64_t *e, *ref, *scratch;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_grid_fit_f32(b, n, 0, 1, 0, &g));
        e = encode_all(&g, b, 0, n, &m);
        ref = malloc(m * sizeof *ref);
        scratch = malloc(m * sizeof *scratch);
        memcpy(ref, e, m * sizeof *ref);
        qsort(ref, m, sizeof *ref, cmp_u64);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_sort_entries(&g, e, scratch, m));
        TEST_ASSERT_EQUAL_MEMORY(ref, e, m * sizeof *ref);
        free(e);
        free(ref);
        free(scratch);
        free(b);
    }
}

/* Encode+sort in k runs, merge, sweep: same pairs as brute force, and the
 * same order as the engine's. */
static void composed_steps_match_engine_n(size_t n)
{
    size_t k;
    float *b = ts_scene(2, n, 99);
    locd_grid g;
    locd_engine *eng;
    locd_pairs *p1, *p2;
    locd_stats es;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_grid_fit_f32(b, n, 0, LOCD_DEFAULT_CELL_BIAS, 0, &g));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p1));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p2));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(NULL, &eng));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(eng, b, n, 0, p2));
    locd_stats_init(&es);
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_stats(eng, &es));
    TEST_ASSERT_EQUAL_INT64(g.depth, es.depth); /* the automatic depth is the same on both paths */
    for (k = 1; k <= 5; k++) {
        uint64_t *runs[5], *merged, *scratch;
        size_t counts[5], total = 0, r;
        locd_stats st;
        for (r = 0; r < k; r++) {
            size_t first = n * r / k, last = n * (r + 1) / k;
            runs[r] = encode_all(&g, b, first, last - first, &counts[r]);
            scratch = malloc((counts[r] ? counts[r] : 1) * sizeof *scratch);
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_sort_entries(&g, runs[r], scratch, counts[r]));
            free(scratch);
            total += counts[r];
        }
        merged = malloc(total * sizeof *merged);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_merge_entries((const uint64_t *const *)runs, counts, k, merged));
        locd_stats_init(&st);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_sweep_f32(&g, b, n, merged, total, p1, &st));
        TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, n, p1));
        TEST_ASSERT_EQUAL_INT64(locd_pairs_count(p2), locd_pairs_count(p1));
        LT_ASSERT_EQUAL_MEMORY(locd_pairs_data(p2), locd_pairs_data(p1), locd_pairs_count(p1) * 8);
        TEST_ASSERT_EQUAL_INT64(locd_pairs_count(p1), st.pairs);
        TEST_ASSERT_TRUE(st.candidates >= st.pairs);
        for (r = 0; r < k; r++)
            free(runs[r]);
        free(merged);
    }
    locd_engine_destroy(eng);
    locd_pairs_destroy(p1);
    locd_pairs_destroy(p2);
    free(b);
}

/* 6,000 boxes keep the key's depth; 40,000 mixed ones get a shallower
 * automatic depth (lc_grid_tune_depth), which must be the same for the
 * building blocks and the engine. */
static void composed_steps_match_engine(void)
{
    composed_steps_match_engine_n(6000);
    composed_steps_match_engine_n(40000);
}

static void sweep_rejects_unsorted_entries(void)
{
    float b[12] = {0, 0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1};
    locd_grid g;
    uint64_t e[16], scratch[16];
    size_t m;
    locd_pairs *p;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_grid_fit_f32(b, 2, 0, 1, 0, &g));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_encode_f32(&g, b, 0, 2, e, 16, &m));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_sort_entries(&g, e, scratch, m));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_sweep_f32(&g, b, 2, e, m, p, NULL));
    TEST_ASSERT_EQUAL_INT64(1, locd_pairs_count(p));
    {
        uint64_t t = e[0];
        e[0] = e[m - 1];
        e[m - 1] = t;
    }
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_sweep_f32(&g, b, 2, e, m, p, NULL));
    TEST_ASSERT_EQUAL_INT64(1, locd_pairs_count(p)); /* untouched on error */
    locd_pairs_destroy(p);
}

static void pairs_sort_orders_by_i_then_j(void)
{
    size_t n = 4000, k;
    float *b = ts_scene(1, n, 5);
    locd_engine *e;
    locd_pairs *p;
    const uint32_t *d;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(NULL, &e));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, n, LOCD_FIND_SORTED, p));
    d = locd_pairs_data(p);
    TEST_ASSERT_TRUE(locd_pairs_count(p) > 100);
    for (k = 0; k < locd_pairs_count(p); k++) {
        TEST_ASSERT_TRUE(d[2 * k] < d[2 * k + 1]);
        if (k)
            TEST_ASSERT_TRUE(d[2 * k - 2] < d[2 * k] || (d[2 * k - 2] == d[2 * k] && d[2 * k - 1] < d[2 * k + 1]));
    }
    TEST_ASSERT_TRUE(ts_same_as_brute_f32(b, n, p));
    locd_engine_destroy(e);
    locd_pairs_destroy(p);
    free(b);
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(encode_gives_one_to_eight_entries_per_box),
        LT_TEST(encode_reports_capacity_needed),
        LT_TEST(sort_equals_qsort),
        LT_TEST(composed_steps_match_engine),
        LT_TEST(sweep_rejects_unsorted_entries),
        LT_TEST(pairs_sort_orders_by_i_then_j),
    };
    return LT_RUN(tests);
}
