/* liblocd_mpi (include/locd/mpi.h) under mpirun -np 3 (tests/meson.build):
 * the union of the ranks' pairs is exactly the brute-force set, on random
 * scenes with uneven slices (an empty rank included), both strategies,
 * float32 and float64, 1 and 2 threads; gather_root gives level 1's order;
 * an error on one rank is the same error on every rank. Every check is
 * agreed between the ranks (all_true), so each rank's Unity sees the same
 * result; only rank 0 prints the TAP lines. */
#include <locd/mpi.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

static int rank, ranks;

/* 1 on every rank when cond holds on every rank. */
static int all_true(int cond)
{
    int all = 0;
    MPI_Allreduce(&cond, &all, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    return all;
}

static uint64_t rng_state;
static double rnd(void)
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng_state >> 11) / 9007199254740992.0;
}

/* The same scene on every rank: n cubes (sizes over three orders of
 * magnitude when mixed), snapped to a lattice of 1/8 so that many touch. */
static double *scene(size_t n, uint64_t seed, int mixed)
{
    double *b = malloc((n ? n : 1) * 6 * sizeof *b);
    size_t i;
    rng_state = seed;
    for (i = 0; i < n; i++) {
        double s = mixed ? pow(10.0, 3.0 * rnd() - 2.0) : 0.5, x[3];
        int a;
        for (a = 0; a < 3; a++)
            x[a] = floor(rnd() * 80.0) / 8.0;
        for (a = 0; a < 3; a++) {
            b[6 * i + a] = x[a];
            b[6 * i + 3 + a] = x[a] + s;
        }
    }
    return b;
}

/* Rank r's slice of n: uneven, rank 0 empty when there are several ranks. */
static void slice_of(size_t n, int r, size_t *first, size_t *count)
{
    size_t at = 0, c = 0;
    int k;
    for (k = 0; k <= r; k++) {
        at += c;
        c = ranks == 1 ? n : k == 0 ? 0 : (k == ranks - 1 ? n - at : n * (size_t)k / ((size_t)ranks * (size_t)ranks));
        if (k < ranks - 1 && at + c > n)
            c = n - at;
    }
    *first = at;
    *count = c;
}

static int by_pair(const void *a, const void *b)
{
    const uint32_t *x = a, *y = b;
    if (x[0] != y[0])
        return x[0] < y[0] ? -1 : 1;
    return x[1] < y[1] ? -1 : x[1] > y[1];
}

/* Every rank's pairs on rank 0, sorted by (i, j) (2 * *total values);
 * NULL elsewhere. */
static uint32_t *gather_sorted(const locd_pairs *mine, size_t *total)
{
    int cnt = (int)(2 * locd_pairs_count(mine)), *counts = malloc((size_t)ranks * sizeof *counts), *displ = NULL;
    int sum = 0, r;
    uint32_t *all = NULL;
    MPI_Allgather(&cnt, 1, MPI_INT, counts, 1, MPI_INT, MPI_COMM_WORLD);
    if (rank == 0) {
        displ = malloc((size_t)ranks * sizeof *displ);
        for (r = 0; r < ranks; r++) {
            displ[r] = sum;
            sum += counts[r];
        }
        all = malloc(((size_t)sum + 2) * sizeof *all);
    }
    MPI_Gatherv(locd_pairs_data(mine), cnt, MPI_UINT32_T, all, counts, displ, MPI_UINT32_T, 0, MPI_COMM_WORLD);
    if (rank == 0)
        qsort(all, (size_t)sum / 2, 2 * sizeof *all, by_pair);
    *total = (size_t)sum / 2;
    free(counts);
    free(displ);
    return all;
}

/* The union of the ranks' pairs is exactly brute force on the whole scene:
 * the same pairs, each once. */
static int check_union(const double *boxes, size_t n, int f64, int strategy, uint32_t threads)
{
    size_t first, count, total = 0, i;
    locd_pairs *mine = NULL, *ref = NULL;
    locd_mpi_options o;
    locd_status st;
    float *bf = NULL;
    uint32_t *all;
    int ok;
    slice_of(n, rank, &first, &count);
    locd_pairs_create(NULL, &mine);
    locd_mpi_options_init(&o);
    o.strategy = strategy;
    o.threads = threads;
    if (!f64) {
        bf = malloc((n ? n : 1) * 6 * sizeof *bf);
        for (i = 0; i < 6 * n; i++)
            bf[i] = (float)boxes[i];
        st = locd_mpi_find_pairs_f32(MPI_COMM_WORLD, bf + 6 * first, count, &o, mine, NULL);
    } else {
        st = locd_mpi_find_pairs_f64(MPI_COMM_WORLD, boxes + 6 * first, count, &o, mine, NULL);
    }
    ok = st == LOCD_OK;
    all = gather_sorted(mine, &total);
    if (rank == 0 && ok) {
        locd_pairs_create(NULL, &ref);
        if (f64)
            locd_brute_force_f64(boxes, n, ref);
        else
            locd_brute_force_f32(bf, n, ref);
        ok = locd_pairs_count(ref) == total &&
             (!total || !memcmp(locd_pairs_data(ref), all, total * 2 * sizeof(uint32_t)));
        if (!ok)
            LT_PRINT("n=%zu f64=%d strategy=%d threads=%u: %zu pairs from the ranks, brute force %zu\n", n, f64,
                     strategy, threads, total, locd_pairs_count(ref));
    }
    free(all);
    free(bf);
    locd_pairs_destroy(ref);
    locd_pairs_destroy(mine);
    return all_true(ok);
}

static void test_union_is_brute_force(void)
{
    static const size_t sizes[] = {0, 1, 2, 7, 300, 2500};
    size_t s;
    int f64, strategy;
    uint32_t threads;
    for (s = 0; s < sizeof sizes / sizeof sizes[0]; s++)
        for (f64 = 0; f64 < 2; f64++)
            for (strategy = 0; strategy < 2; strategy++)
                for (threads = 1; threads <= 2; threads++) {
                    double *b = scene(sizes[s], 1000 + s, (int)(s & 1));
                    int ok = check_union(b, sizes[s], f64, strategy, threads);
                    free(b);
                    TEST_ASSERT_TRUE(ok);
                }
}

/* Large enough (>= 16384 boxes) for the automatic depth's sample: the
 * gathered pairs are level 1's, in level 1's order, with either strategy. */
static void test_gather_root_has_level1_order(void)
{
    const size_t n = 20000;
    double *b = scene(n, 7, 1);
    size_t first, count;
    locd_pairs *ref = NULL;
    locd_engine *e = NULL;
    int strategy, ok = 1;
    slice_of(n, rank, &first, &count);
    if (rank == ranks - 1) {
        locd_engine_create(NULL, &e);
        locd_pairs_create(NULL, &ref);
        ok = locd_engine_find_pairs_f64(e, b, n, 0, ref) == LOCD_OK;
    }
    for (strategy = 0; strategy < 2; strategy++) {
        locd_pairs *mine = NULL;
        locd_mpi_options o;
        locd_mpi_stats stt;
        locd_pairs_create(NULL, &mine);
        locd_mpi_options_init(&o);
        o.strategy = strategy;
        o.gather_root = ranks - 1;
        locd_mpi_stats_init(&stt);
        ok = ok && locd_mpi_find_pairs_f64(MPI_COMM_WORLD, b + 6 * first, count, &o, mine, &stt) == LOCD_OK;
        if (ok && rank == ranks - 1)
            ok = locd_pairs_count(ref) == locd_pairs_count(mine) &&
                 !memcmp(locd_pairs_data(ref), locd_pairs_data(mine), locd_pairs_count(ref) * 2 * sizeof(uint32_t)) &&
                 stt.pairs == locd_pairs_count(ref);
        else if (ok)
            ok = locd_pairs_count(mine) == 0;
        ok = ok && stt.rank == rank && stt.ranks == ranks && stt.objects == n && stt.local_objects == count &&
             stt.first_index == first && stt.imbalance >= 1.0 && stt.strategy == strategy;
        locd_pairs_destroy(mine);
        TEST_ASSERT_TRUE(all_true(ok));
    }
    locd_pairs_destroy(ref);
    locd_engine_destroy(e);
    free(b);
}

/* LOCD_FIND_SORTED: each rank's own pairs in (i, j) order. */
static void test_sorted_flag(void)
{
    const size_t n = 5000;
    double *b = scene(n, 13, 0);
    size_t first, count, i;
    locd_pairs *mine = NULL;
    locd_mpi_options o;
    const uint32_t *d;
    int ok;
    slice_of(n, rank, &first, &count);
    locd_pairs_create(NULL, &mine);
    locd_mpi_options_init(&o);
    o.find_flags = LOCD_FIND_SORTED;
    o.threads = 2;
    ok = locd_mpi_find_pairs_f64(MPI_COMM_WORLD, b + 6 * first, count, &o, mine, NULL) == LOCD_OK;
    d = locd_pairs_data(mine);
    for (i = 1; ok && i < locd_pairs_count(mine); i++)
        ok = by_pair(d + 2 * (i - 1), d + 2 * i) < 0;
    locd_pairs_destroy(mine);
    free(b);
    TEST_ASSERT_TRUE(all_true(ok));
}

/* A box over the whole scene: its root cell is copied to every rank that
 * sweeps, and the bytes sent add up to the bytes received. */
static void test_spanning_box_is_replicated(void)
{
    const size_t n = 3000;
    double *b = scene(n, 9, 0);
    size_t first, count;
    locd_pairs *mine = NULL;
    locd_mpi_stats stt;
    unsigned long long v[3], sum[3];
    int ok;
    b[6 * 1500 + 0] = b[6 * 1500 + 1] = b[6 * 1500 + 2] = -1.0;
    b[6 * 1500 + 3] = b[6 * 1500 + 4] = b[6 * 1500 + 5] = 20.0;
    slice_of(n, rank, &first, &count);
    locd_pairs_create(NULL, &mine);
    locd_mpi_stats_init(&stt);
    ok = locd_mpi_find_pairs_f64(MPI_COMM_WORLD, b + 6 * first, count, NULL, mine, &stt) == LOCD_OK;
    v[0] = stt.entries_replicated;
    v[1] = stt.bytes_sent;
    v[2] = stt.bytes_received;
    MPI_Allreduce(v, sum, 3, MPI_UNSIGNED_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    ok = ok && sum[1] == sum[2] && (ranks == 1 || sum[0] > 0);
    locd_pairs_destroy(mine);
    free(b);
    TEST_ASSERT_TRUE(all_true(ok));
}

/* Only rank r_bad passes `bad_boxes`; every rank must return `want`. */
static int same_error_everywhere(locd_status got, locd_status want, int64_t index)
{
    int ok = got == want && (index < 0 || locd_last_error_index() == index);
    if (!ok)
        LT_PRINT("rank %d: status %d (want %d), index %lld (want %lld): %s\n", rank, (int)got, (int)want,
                 (long long)locd_last_error_index(), (long long)index, locd_last_error());
    return all_true(ok);
}

static void test_one_rank_error_is_every_rank_error(void)
{
    const size_t n = 3000;
    double *b = scene(n, 11, 0);
    size_t first, count;
    locd_pairs *mine = NULL;
    locd_mpi_options o;
    int strategy;
    slice_of(n, rank, &first, &count);
    locd_pairs_create(NULL, &mine);
    /* a known result, which no failed call may change */
    TEST_ASSERT_EQUAL_INT(LOCD_OK, locd_mpi_find_pairs_f64(MPI_COMM_WORLD, b + 6 * first, count, NULL, mine, NULL));
    {
        const size_t before = locd_pairs_count(mine);
        for (strategy = 0; strategy < 2; strategy++) {
            locd_mpi_options_init(&o);
            o.strategy = strategy;
            /* NULL boxes on the last rank only */
            TEST_ASSERT_TRUE(same_error_everywhere(
                locd_mpi_find_pairs_f64(MPI_COMM_WORLD, rank == ranks - 1 ? NULL : b + 6 * first, count, &o, mine,
                                        NULL),
                LOCD_ERR_NULL_POINTER, -1));
            /* options that differ on the last rank */
            o.cell_bias = rank == ranks - 1 ? 1 : 2;
            TEST_ASSERT_TRUE(same_error_everywhere(
                locd_mpi_find_pairs_f64(MPI_COMM_WORLD, b + 6 * first, count, &o, mine, NULL),
                ranks > 1 ? LOCD_ERR_INVALID_ARGUMENT : LOCD_OK, -1));
            o.cell_bias = 2;
            o.gather_root = ranks; /* not a rank */
            TEST_ASSERT_TRUE(same_error_everywhere(
                locd_mpi_find_pairs_f64(MPI_COMM_WORLD, b + 6 * first, count, &o, mine, NULL),
                LOCD_ERR_INVALID_ARGUMENT, -1));
            o.gather_root = -1;
            TEST_ASSERT_TRUE(all_true(locd_pairs_count(mine) == before));
        }
        /* a NaN in the last rank's slice and an inverted box after it: the first is named everywhere */
        b[6 * (n - 5) + 4] = NAN;
        b[6 * (n - 2) + 0] = 1e9;
        TEST_ASSERT_TRUE(same_error_everywhere(
            locd_mpi_find_pairs_f64(MPI_COMM_WORLD, b + 6 * first, count, NULL, mine, NULL), LOCD_ERR_NONFINITE,
            (int64_t)(n - 5)));
        TEST_ASSERT_TRUE(all_true(locd_pairs_count(mine) == before));
    }
    locd_pairs_destroy(mine);
    free(b);
}

int main(int argc, char **argv)
{
    static const lt_test tests[] = {
        LT_TEST(test_union_is_brute_force),
        LT_TEST(test_gather_root_has_level1_order),
        LT_TEST(test_sorted_flag),
        LT_TEST(test_spanning_box_is_replicated),
        LT_TEST(test_one_rank_error_is_every_rank_error),
    };
    int rc;
    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &ranks);
    if (rank != 0) /* one TAP stream: every check is agreed, so rank 0's report is every rank's */
        if (!freopen("/dev/null", "w", stdout))
            return 1;
    rc = LT_RUN(tests);
    MPI_Finalize();
    return rc;
}
