/* The two-set query (locd_engine_find_pairs_between_*): exactly the pairs
 * (i in a, j in b) whose closed boxes overlap, against a bipartite brute
 * force, for random and hard scenes, every kernel, 1 and 2 threads,
 * float32 and float64, empty sets, level 2 against level 1, and the errors
 * (a bad box of b is reported as na + j; level 3 does not offer it). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <pthread.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "levels_util.h"
#include "support.h"

static int cmp_pair(const void *x, const void *y)
{
    const uint32_t *p = x, *q = y;
    if (p[0] != q[0])
        return p[0] < q[0] ? -1 : 1;
    return (p[1] > q[1]) - (p[1] < q[1]);
}

static int overlap_f64(const double *a, const double *b)
{
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

/* Every (i, j) with a[i] and b[j] overlapping, sorted; *m gets the count. */
static uint32_t *brute_between(const double *a, size_t na, const double *b, size_t nb, size_t *m)
{
    size_t cap = 1024, cnt = 0, i, j;
    uint32_t *out = malloc(cap * 2 * sizeof *out);
    for (i = 0; i < na; i++)
        for (j = 0; j < nb; j++)
            if (overlap_f64(a + 6 * i, b + 6 * j)) {
                if (cnt == cap) {
                    cap *= 2;
                    out = realloc(out, cap * 2 * sizeof *out);
                }
                out[2 * cnt] = (uint32_t)i;
                out[2 * cnt + 1] = (uint32_t)j;
                cnt++;
            }
    *m = cnt;
    return out;
}

static double *widen(const float *f, size_t n)
{
    double *d = malloc((n ? n : 1) * 6 * sizeof *d);
    size_t k;
    for (k = 0; k < 6 * n; k++)
        d[k] = f[k];
    return d;
}

static locd_engine *engine_with(uint32_t threads)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_engine_config_init(&cfg);
    cfg.threads = threads;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
    return e;
}

/* Runs the query (f32 on the given boxes, or f64 on their widened copies)
 * and checks it against the brute force: the same set, each pair once,
 * sorted when asked. Returns the pairs in the engine's order (malloc'd). */
static uint32_t *check_between(locd_engine *e, const double *a, size_t na, const double *b, size_t nb, int f64,
                               uint32_t flags, size_t *count)
{
    locd_pairs *p;
    size_t m = 0, got, k;
    uint32_t *ref, *res, *sorted;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    if (f64) {
        ref = brute_between(a, na, b, nb, &m);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_between_f64(e, a, na, b, nb, flags, p));
    } else { /* the reference sees the float-rounded boxes the engine sees */
        float *fa = malloc((na ? na : 1) * 6 * sizeof *fa), *fb = malloc((nb ? nb : 1) * 6 * sizeof *fb);
        double *ra, *rb;
        for (k = 0; k < 6 * na; k++)
            fa[k] = (float)a[k];
        for (k = 0; k < 6 * nb; k++)
            fb[k] = (float)b[k];
        ra = widen(fa, na);
        rb = widen(fb, nb);
        ref = brute_between(ra, na, rb, nb, &m);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_between_f32(e, fa, na, fb, nb, flags, p));
        free(fa);
        free(fb);
        free(ra);
        free(rb);
    }
    got = locd_pairs_count(p);
    res = malloc((got ? got : 1) * 2 * sizeof *res);
    if (got)
        memcpy(res, locd_pairs_data(p), got * 2 * sizeof *res);
    locd_pairs_destroy(p);
    sorted = malloc((got ? got : 1) * 2 * sizeof *sorted);
    if (got)
        memcpy(sorted, res, got * 2 * sizeof *res);
    qsort(sorted, got, 2 * sizeof *sorted, cmp_pair);
    if (flags & LOCD_FIND_SORTED && got)
        TEST_ASSERT_EQUAL_MEMORY(sorted, res, got * 2 * sizeof *res);
    if (m != got)
        LT_FAIL("na %zu nb %zu f64 %d: %zu pairs, brute force %zu", na, nb, f64, got, m);
    if (m)
        TEST_ASSERT_EQUAL_MEMORY(ref, sorted, m * 2 * sizeof *ref);
    free(ref);
    free(sorted);
    *count = got;
    return res;
}

/* Both precisions, threads 1 and 2, sorted and not: all match the brute
 * force, and the unsorted order is the same for both thread counts. */
static void check_all_ways(const double *a, size_t na, const double *b, size_t nb)
{
    locd_engine *e1 = engine_with(1), *e2 = engine_with(2);
    int f64;
    for (f64 = 0; f64 < 2; f64++) {
        size_t c1, c2, cs;
        uint32_t *r1 = check_between(e1, a, na, b, nb, f64, 0, &c1);
        uint32_t *r2 = check_between(e2, a, na, b, nb, f64, 0, &c2);
        uint32_t *rs = check_between(e2, a, na, b, nb, f64, LOCD_FIND_SORTED, &cs);
        TEST_ASSERT_EQUAL_UINT64(c1, c2);
        if (c1)
            TEST_ASSERT_EQUAL_MEMORY(r1, r2, c1 * 2 * sizeof *r1);
        free(r1);
        free(r2);
        free(rs);
    }
    locd_engine_destroy(e1);
    locd_engine_destroy(e2);
}

static void random_scenes_match_brute_force(void)
{
    static const size_t sizes[][2] = {{1, 1}, {2, 900}, {700, 3}, {1500, 1200}, {3000, 5000}, {2500, 2000}};
    /* The full run takes 8,000 objects (row 4); the sanitizer runs
       (LOCD_TEST_HEAVY=0), whose brute force is instrumented too, take 4,500
       instead (row 5), which still runs 2 threads. */
    const size_t skip = lu_heavy() ? 5 : 4;
    int kind;
    size_t s;
    for (kind = 0; kind < TS_SCENE_KINDS; kind++)
        for (s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
            if (s == skip)
                continue;
            const size_t na = sizes[s][0], nb = sizes[s][1];
            float *fa = ts_scene(kind, na, 100 + (uint64_t)s), *fb = ts_scene((kind + 2) % TS_SCENE_KINDS, nb, 200 + s);
            double *a = widen(fa, na), *b = widen(fb, nb);
            check_all_ways(a, na, b, nb);
            free(fa);
            free(fb);
            free(a);
            free(b);
        }
}

/* The same scene in both sets: every box meets its twin, so (i, i) pairs
 * (never reported by a one-set query) must all be there. */
static void same_scene_in_both_sets(void)
{
    const size_t n = lu_heavy() ? 5000 : 2500; /* 2n objects: the engine runs 2 threads either way */
    float *f = ts_scene(0, n, 9);
    double *a = widen(f, n);
    check_all_ways(a, n, a, n);
    free(f);
    free(a);
}

static void put(double *b, double x0, double y0, double z0, double x1, double y1, double z1)
{
    b[0] = x0, b[1] = y0, b[2] = z0, b[3] = x1, b[4] = y1, b[5] = z1;
}

/* Touching faces, edges and corners across the sets, identical boxes,
 * points on cell boundaries, huge and tiny boxes far from the origin. */
static void hard_cases_match_brute_force(void)
{
    const size_t n = 600;
    double *a = malloc(n * 6 * sizeof *a), *b = malloc(n * 6 * sizeof *b);
    size_t i;
    /* a lattice of unit cubes in a, the cubes shifted by one in b: faces touch */
    for (i = 0; i < n; i++) {
        double x = (double)(i % 8), y = (double)(i / 8 % 8), z = (double)(i / 64);
        put(a + 6 * i, x, y, z, x + 1, y + 1, z + 1);
        put(b + 6 * i, x + 1, y, z + 1, x + 2, y + 1, z + 2);
    }
    check_all_ways(a, n, b, n);
    /* every box identical in both sets: n * n pairs */
    for (i = 0; i < n; i++) {
        put(a + 6 * i, 1, 2, 3, 4, 5, 6);
        put(b + 6 * i, 1, 2, 3, 4, 5, 6);
    }
    check_all_ways(a, 100, b, 120);
    /* points of b on the corners and faces of a's boxes; a few far away */
    for (i = 0; i < n; i++) {
        double x = (double)(i % 10) * 0.5;
        put(a + 6 * i, x, 0, 0, x + 0.5, 0.5, 0.5);
        put(b + 6 * i, x + (i % 3 == 0 ? 0.5 : 0.25), i % 2 ? 0.5 : 0.0, 0.5, x + (i % 3 == 0 ? 0.5 : 0.25),
            i % 2 ? 0.5 : 0.0, 0.5);
    }
    put(b + 6 * 7, 1e30, 1e30, 1e30, 1e30, 1e30, 1e30);
    put(a + 6 * 8, -1e30, -1e30, -1e30, 1e30, 1e30, 1e30);
    check_all_ways(a, n, b, n);
    /* tiny boxes far from the origin, one huge box in b */
    for (i = 0; i < n; i++) {
        double x = 1e6 + (double)i * 1e-2;
        put(a + 6 * i, x, 1e6, 1e6, x + 1e-2, 1e6 + 1e-3, 1e6 + 1e-3);
        put(b + 6 * i, x + 5e-3, 1e6, 1e6, x + 5e-3, 1e6, 1e6);
    }
    put(b + 6 * 3, 0, 0, 0, 2e6, 2e6, 2e6);
    check_all_ways(a, n, b, n);
    free(a);
    free(b);
}

/* One set empty: no pairs, and the other set is still validated. */
static void empty_set_gives_no_pairs(void)
{
    float *f = ts_scene(0, 5000, 4);
    double *a = widen(f, 5000);
    check_all_ways(a, 0, a, 5000);
    check_all_ways(a, 5000, a, 0);
    check_all_ways(a, 0, a, 0);
    check_all_ways(a, 1, a, 0);
    {
        locd_engine *e = engine_with(2);
        locd_pairs *p;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_between_f32(e, NULL, 0, NULL, 0, 0, p));
        f[6 * 4321 + 1] = NAN;
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_between_f32(e, NULL, 0, f, 5000, 0, p));
        TEST_ASSERT_EQUAL_INT64(4321, locd_last_error_index());
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_between_f32(e, f, 5000, NULL, 0, 0, p));
        TEST_ASSERT_EQUAL_INT64(4321, locd_last_error_index());
        locd_pairs_destroy(p);
        locd_engine_destroy(e);
    }
    free(f);
    free(a);
}

/* A bad box names its index: i in a, na + j in b; *out is unchanged. */
static void bad_box_names_its_index(void)
{
    const size_t na = 3000, nb = 2500;
    float *a = ts_scene(0, na, 5), *b = ts_scene(0, nb, 6);
    locd_engine *e = engine_with(2);
    locd_pairs *p;
    size_t before;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_between_f32(e, a, na, b, nb, 0, p));
    before = locd_pairs_count(p);
    TEST_ASSERT_TRUE(before > 0);
    b[6 * 17 + 0] = b[6 * 17 + 3] + 1.0f; /* min > max */
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVERTED_BOX, locd_engine_find_pairs_between_f32(e, a, na, b, nb, 0, p));
    TEST_ASSERT_EQUAL_INT64((int64_t)na + 17, locd_last_error_index());
    TEST_ASSERT_EQUAL_UINT64(before, locd_pairs_count(p));
    a[6 * 2999 + 5] = INFINITY;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_between_f32(e, a, na, b, nb, 0, p));
    TEST_ASSERT_EQUAL_INT64(2999, locd_last_error_index());
    TEST_ASSERT_EQUAL_UINT64(before, locd_pairs_count(p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_between_f32(e, NULL, 3, b, nb, 0, p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_between_f32(e, a, na, NULL, 3, 0, p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_find_pairs_between_f32(e, a, 2, b, 2, 0x80, p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_HANDLE, locd_engine_find_pairs_between_f32(NULL, a, 2, b, 2, 0, p));
    TEST_ASSERT_EQUAL_UINT64(before, locd_pairs_count(p));
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    free(a);
    free(b);
}

/* Every SIMD kernel the CPU has (LOCD_KERNEL caps the engine's choice at
 * creation) gives the same pairs in the same order. */
static void every_kernel_gives_the_same_pairs(void)
{
    static const char *kernels[] = TS_KERNELS;
    const size_t na = 4000, nb = 3000;
    float *fa = ts_scene(2, na, 31), *fb = ts_scene(1, nb, 32);
    double *a = widen(fa, na), *b = widen(fb, nb);
    const char *saved = getenv("LOCD_KERNEL");
    char keep[32] = "";
    uint32_t *first = NULL;
    size_t c0 = 0, k;
    if (saved)
        strncpy(keep, saved, sizeof keep - 1);
    for (k = 0; k < TS_KERNEL_COUNT; k++) {
        locd_engine *e;
        size_t c;
        uint32_t *r;
        setenv("LOCD_KERNEL", kernels[k], 1);
        e = engine_with(2);
        r = check_between(e, a, na, b, nb, 0, 0, &c);
        if (!first) {
            first = r;
            c0 = c;
        } else {
            TEST_ASSERT_EQUAL_UINT64(c0, c);
            TEST_ASSERT_EQUAL_MEMORY(first, r, c * 2 * sizeof *r);
            free(r);
        }
        locd_engine_destroy(e);
    }
    if (saved)
        setenv("LOCD_KERNEL", keep, 1);
    else
        unsetenv("LOCD_KERNEL");
    free(first);
    free(fa);
    free(fb);
    free(a);
    free(b);
}

/* An allocator that fails its k-th allocation (counting from when it is
 * armed) and counts what is live; locked: the engine's pool threads
 * allocate too. */
typedef struct failing {
    pthread_mutex_t mu;
    long left; /* allocations before the failing one; -1: never fail */
    long live;
} failing;

static void *failing_alloc(size_t size, void *user)
{
    failing *f = user;
    void *p = NULL;
    pthread_mutex_lock(&f->mu);
    if (f->left != 0) {
        if (f->left > 0)
            f->left--;
        if ((p = malloc(size)) != NULL)
            f->live++;
    } else {
        f->left = -1; /* one failure per call */
    }
    pthread_mutex_unlock(&f->mu);
    return p;
}

static void failing_free(void *ptr, size_t size, void *user)
{
    failing *f = user;
    (void)size;
    if (!ptr)
        return;
    pthread_mutex_lock(&f->mu);
    f->live--;
    pthread_mutex_unlock(&f->mu);
    free(ptr);
}

/* Every allocation of the call failing in turn: LOCD_ERR_NO_MEMORY, *out
 * as it was, nothing leaked once the engine is gone; then it succeeds. */
static void allocation_failures_fail_cleanly(void)
{
    const size_t na = 5000, nb = 3000;
    float *a = ts_scene(1, na, 51), *b = ts_scene(2, nb, 52);
    failing f;
    uint32_t threads;
    pthread_mutex_init(&f.mu, NULL);
    for (threads = 1; threads <= 2; threads++) {
        long k;
        int done = 0;
        for (k = 0; k < 400 && !done; k++) {
            locd_engine_config cfg;
            locd_engine *e = NULL;
            locd_pairs *p = NULL;
            uint32_t *before;
            size_t before_count;
            locd_status st;
            f.left = -1;
            f.live = 0;
            locd_engine_config_init(&cfg);
            cfg.threads = threads;
            cfg.allocator.alloc = failing_alloc;
            cfg.allocator.free = failing_free;
            cfg.allocator.user = &f;
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(&cfg.allocator, &p));
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, 200, 0, p)); /* an earlier answer */
            before_count = locd_pairs_count(p);
            before = malloc(before_count * 2 * sizeof *before + 8);
            memcpy(before, locd_pairs_data(p), before_count * 2 * sizeof *before);
            pthread_mutex_lock(&f.mu);
            f.left = k;
            pthread_mutex_unlock(&f.mu);
            st = locd_engine_find_pairs_between_f32(e, a, na, b, nb, LOCD_FIND_SORTED, p);
            if (st == LOCD_OK) {
                TEST_ASSERT_TRUE(f.left == -1 ? 0 : 1); /* succeeded without meeting the failure */
                TEST_ASSERT_TRUE(locd_pairs_count(p) > 100);
                done = 1;
            } else {
                if (st != LOCD_ERR_NO_MEMORY)
                    LT_FAIL("threads %u, allocation %ld failed: status %d, not LOCD_ERR_NO_MEMORY", threads, k,
                            (int)st);
                if (locd_pairs_count(p) != before_count ||
                    memcmp(locd_pairs_data(p), before, before_count * 2 * sizeof *before) != 0)
                    LT_FAIL("threads %u, allocation %ld failed: *out changed", threads, k);
            }
            free(before);
            locd_pairs_destroy(p);
            locd_engine_destroy(e);
            if (f.live != 0)
                LT_FAIL("threads %u, allocation %ld failed: %ld blocks leaked", threads, k, f.live);
        }
        TEST_ASSERT_TRUE(done);
        LT_PRINT("threads %u: the call makes %ld allocations, each failed in turn\n", threads, k - 1);
    }
    pthread_mutex_destroy(&f.mu);
    free(a);
    free(b);
}

/* Level 2 gives level 1's pairs in level 1's order (and validates the
 * same way); level 3 says it does not offer the query, with a message. */
static void level_two_same_as_level_one(void)
{
    const size_t na = 5000, nb = 4000;
    float *a = ts_scene(2, na, 41), *b = ts_scene(0, nb, 42);
    locd_engine_config cfg;
    locd_engine *e2 = NULL, *e1 = engine_with(2);
    locd_pairs *p1, *p2;
    uint32_t flags;
    lu_setup();
    locd_engine_config_init(&cfg);
    cfg.level = LOCD_LEVEL_WORKERS;
    cfg.threads = 2;
    if (locd_engine_create(&cfg, &e2) != LOCD_OK) {
        locd_engine_destroy(e1);
        free(a);
        free(b);
        TEST_IGNORE_MESSAGE("no level-2 engine here");
    }
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p1));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p2));
    for (flags = 0; flags <= LOCD_FIND_SORTED; flags += LOCD_FIND_SORTED) {
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_between_f32(e1, a, na, b, nb, flags, p1));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_between_f32(e2, a, na, b, nb, flags, p2));
        TEST_ASSERT_TRUE(locd_pairs_count(p1) > 100);
        TEST_ASSERT_TRUE(lu_same_pairs(p1, p2));
    }
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_between_f32(e2, a, 0, b, nb, 0, p2));
    TEST_ASSERT_EQUAL_UINT64(0, locd_pairs_count(p2));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_between_f32(e2, a, na, b, 0, 0, p2));
    TEST_ASSERT_EQUAL_UINT64(0, locd_pairs_count(p2));
    b[6 * 9 + 2] = NAN;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_between_f32(e2, a, na, b, nb, 0, p2));
    TEST_ASSERT_EQUAL_INT64((int64_t)na + 9, locd_last_error_index());
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_between_f32(e2, NULL, 0, b, nb, 0, p2));
    TEST_ASSERT_EQUAL_INT64(9, locd_last_error_index());
    locd_pairs_destroy(p1);
    locd_pairs_destroy(p2);
    locd_engine_destroy(e1);
    locd_engine_destroy(e2);
    free(a);
    free(b);
}

static void level_three_is_unsupported(void)
{
    lu_fixture f;
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_pairs *p;
    float box[6] = {0, 0, 0, 1, 1, 1};
    if (lu_fixture_up(&f) != 0)
        TEST_IGNORE_MESSAGE("no level-3 service here");
    locd_engine_config_init(&cfg);
    cfg.level = LOCD_LEVEL_SERVICE;
    cfg.service_address = f.addr;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_UNSUPPORTED, locd_engine_find_pairs_between_f32(e, box, 1, box, 1, 0, p));
    TEST_ASSERT_NOT_NULL(strstr(locd_last_error(), "levels 1 and 2"));
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    lu_fixture_down(&f);
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(random_scenes_match_brute_force),
        LT_TEST(same_scene_in_both_sets),
        LT_TEST(hard_cases_match_brute_force),
        LT_TEST(empty_set_gives_no_pairs),
        LT_TEST(bad_box_names_its_index),
        LT_TEST(every_kernel_gives_the_same_pairs),
        LT_TEST(allocation_failures_fail_cleanly),
        LT_TEST(level_two_same_as_level_one),
        LT_TEST(level_three_is_unsupported),
    };
    return LT_RUN(tests);
}
