/* locd-mpi: the paper's master/slave split across MPI ranks (Open MPI), the
 * project's path past one machine (docs/levels.md).
 *
 *   mpirun -np K locd-mpi SCENE.aabb [--out PAIRS.bin] [--check] [--depth D] [--bias B] [--cubes]
 *
 * Rank 0 reads the scene and broadcasts it; every rank fits the same grid,
 * encodes and sorts its share of the boxes (the public building blocks);
 * rank 0 gathers the sorted runs, merges and sweeps them. The pairs are
 * exactly level 1's, in level 1's order (same grid, same merged entries,
 * same serial sweep); --check compares them with a level-1 engine on rank 0.
 * Prints one JSON line on rank 0; --out writes the pairs sorted by (i, j)
 * like `locd pairs --out`. */
#include "cli.h"

#include <limits.h>
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static size_t chunk_begin(size_t n, int t, int k)
{
    size_t q = n / (size_t)k, r = n % (size_t)k;
    return q * (size_t)t + ((size_t)t < r ? (size_t)t : r);
}

static void bcast_bytes(void *buf, size_t bytes)
{
    char *p = buf;
    while (bytes) {
        int chunk = bytes > (size_t)(1 << 30) ? (1 << 30) : (int)bytes;
        MPI_Bcast(p, chunk, MPI_BYTE, 0, MPI_COMM_WORLD);
        p += chunk;
        bytes -= (size_t)chunk;
    }
}

static void fail(int rank, const char *what, locd_status st)
{
    fprintf(stderr, "locd-mpi (rank %d): %s: %s\n", rank, what, st ? locd_last_error() : "");
    MPI_Abort(MPI_COMM_WORLD, 1);
}

int main(int argc, char **argv)
{
    const char *path = NULL, *out_path = NULL;
    int rank, size, a, check = 0, f64 = 0, rc = 0;
    uint32_t depth = 0, flags = 0;
    int32_t bias = LOCD_DEFAULT_CELL_BIAS;
    uint64_t hdr[2] = {0, 0};
    cli_scene sc;
    void *boxes;
    size_t n, first, count, es, cap, written = 0, k;
    uint64_t *entries, *scratch, mine;
    locd_grid grid;
    locd_status st;
    double t0, t_fit, t_enc, t_gather, t_merge, t_sweep;

    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    for (a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "--out") && a + 1 < argc)
            out_path = argv[++a];
        else if (!strcmp(argv[a], "--check"))
            check = 1;
        else if (!strcmp(argv[a], "--depth") && a + 1 < argc)
            depth = (uint32_t)atoi(argv[++a]);
        else if (!strcmp(argv[a], "--bias") && a + 1 < argc)
            bias = atoi(argv[++a]);
        else if (!strcmp(argv[a], "--cubes"))
            flags |= LOCD_CONFIG_CUBES;
        else if (argv[a][0] != '-' && !path)
            path = argv[a];
        else {
            if (rank == 0)
                fprintf(stderr, "usage: mpirun -np K locd-mpi SCENE.aabb [--out PAIRS.bin] [--check] [--depth D] "
                                "[--bias B] [--cubes]\n");
            MPI_Finalize();
            return 2;
        }
    }
    if (!path) {
        if (rank == 0)
            fprintf(stderr, "usage: mpirun -np K locd-mpi SCENE.aabb [--out PAIRS.bin] [--check]\n");
        MPI_Finalize();
        return 2;
    }
    memset(&sc, 0, sizeof sc);
    if (rank == 0) {
        if (cli_load_scene(path, &sc) != 0)
            MPI_Abort(MPI_COMM_WORLD, 1);
        hdr[0] = sc.n;
        hdr[1] = (uint64_t)sc.f64;
    }
    MPI_Bcast(hdr, 2, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    n = (size_t)hdr[0];
    f64 = (int)hdr[1];
    es = f64 ? sizeof(double) : sizeof(float);
    if (rank == 0) {
        boxes = f64 ? (void *)sc.d : (void *)sc.f;
    } else {
        boxes = malloc((n ? n : 1) * 6 * es);
        if (!boxes)
            fail(rank, "out of memory for the scene", 0);
    }
    MPI_Barrier(MPI_COMM_WORLD);
    t0 = MPI_Wtime();
    bcast_bytes(boxes, n * 6 * es);

    /* Every rank fits the same grid from the same boxes (and rejects the
       same bad box). */
    st = f64 ? locd_grid_fit_f64(boxes, n, depth, bias, flags, &grid)
             : locd_grid_fit_f32(boxes, n, depth, bias, flags, &grid);
    if (st)
        fail(rank, "invalid scene", st);
    t_fit = MPI_Wtime();

    first = chunk_begin(n, rank, size);
    count = chunk_begin(n, rank + 1, size) - first;
    cap = count * LOCD_MAX_ENTRIES_PER_BOX + 1;
    entries = malloc(cap * sizeof *entries);
    scratch = malloc(cap * sizeof *scratch);
    if (!entries || !scratch)
        fail(rank, "out of memory for entries", 0);
    st = f64 ? locd_encode_f64(&grid, boxes, first, count, entries, cap, &written)
             : locd_encode_f32(&grid, boxes, first, count, entries, cap, &written);
    if (!st)
        st = locd_sort_entries(&grid, entries, scratch, written);
    if (st)
        fail(rank, "encode/sort", st);
    free(scratch);
    if (written > (size_t)INT_MAX)
        fail(rank, "more than INT_MAX entries on one rank: use more ranks", 0);
    t_enc = MPI_Wtime();

    mine = written;
    {
        uint64_t *cnt = rank == 0 ? malloc((size_t)size * sizeof *cnt) : NULL;
        int *rcounts = NULL, *displs = NULL;
        uint64_t *all = NULL, total = 0;
        MPI_Gather(&mine, 1, MPI_UINT64_T, cnt, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
        if (rank == 0) {
            rcounts = malloc((size_t)size * sizeof *rcounts);
            displs = malloc((size_t)size * sizeof *displs);
            for (a = 0; a < size; a++) {
                if (total > (uint64_t)INT_MAX)
                    fail(rank, "more than INT_MAX entries in all: the gather cannot address them", 0);
                rcounts[a] = (int)cnt[a];
                displs[a] = (int)total;
                total += cnt[a];
            }
            all = malloc((size_t)(total ? total : 1) * sizeof *all);
            if (!all)
                fail(rank, "out of memory for the gathered entries", 0);
        }
        MPI_Gatherv(entries, (int)written, MPI_UINT64_T, all, rcounts, displs, MPI_UINT64_T, 0, MPI_COMM_WORLD);
        free(entries);
        t_gather = MPI_Wtime();
        if (rank == 0) {
            const uint64_t **runs = malloc((size_t)size * sizeof *runs);
            size_t *counts = malloc((size_t)size * sizeof *counts);
            uint64_t *merged = malloc((size_t)(total ? total : 1) * sizeof *merged);
            locd_pairs *pairs = NULL;
            locd_stats ss;
            for (a = 0; a < size; a++) {
                runs[a] = all + displs[a];
                counts[a] = (size_t)cnt[a];
            }
            st = locd_merge_entries(runs, counts, (size_t)size, merged);
            if (st)
                fail(rank, "merge", st);
            t_merge = MPI_Wtime();
            locd_stats_init(&ss);
            if ((st = locd_pairs_create(NULL, &pairs)) != LOCD_OK)
                fail(rank, "pairs", st);
            st = f64 ? locd_sweep_f64(&grid, boxes, n, merged, (size_t)total, pairs, &ss)
                     : locd_sweep_f32(&grid, boxes, n, merged, (size_t)total, pairs, &ss);
            if (st)
                fail(rank, "sweep", st);
            t_sweep = MPI_Wtime();
            if (check) {
                locd_engine_config cfg;
                locd_engine *e = NULL;
                locd_pairs *ref = NULL;
                locd_engine_config_init(&cfg);
                cfg.max_depth = depth;
                cfg.cell_bias = bias;
                cfg.flags = flags;
                k = locd_pairs_count(pairs);
                if (locd_engine_create(&cfg, &e) || locd_pairs_create(NULL, &ref) ||
                    (f64 ? locd_engine_find_pairs_f64(e, boxes, n, 0, ref) : locd_engine_find_pairs_f32(e, boxes, n, 0, ref)) ||
                    locd_pairs_count(ref) != k ||
                    (k && memcmp(locd_pairs_data(ref), locd_pairs_data(pairs), k * 2 * sizeof(uint32_t)))) {
                    fprintf(stderr, "locd-mpi: CHECK FAILED: %zu pairs, level 1 has %zu\n", k, locd_pairs_count(ref));
                    rc = 3;
                }
                locd_pairs_destroy(ref);
                locd_engine_destroy(e);
            }
            if (out_path) {
                locd_pairs_sort(pairs);
                if (cli_write_pairs(out_path, locd_pairs_data(pairs), locd_pairs_count(pairs)) != 0)
                    rc = 1;
            }
            printf("{\"n\":%zu,\"pairs\":%zu,\"ranks\":%d,\"precision\":\"%s\",\"total_ms\":%.3f,\"stage_ms\":{"
                   "\"broadcast_fit\":%.3f,\"encode_sort\":%.3f,\"gather\":%.3f,\"merge\":%.3f,\"sweep\":%.3f},"
                   "\"entries\":%llu%s}\n",
                   n, locd_pairs_count(pairs), size, f64 ? "f64" : "f32", (t_sweep - t0) * 1e3, (t_fit - t0) * 1e3,
                   (t_enc - t_fit) * 1e3, (t_gather - t_enc) * 1e3, (t_merge - t_gather) * 1e3,
                   (t_sweep - t_merge) * 1e3, (unsigned long long)total,
                   check ? (rc == 3 ? ",\"check\":\"FAILED\"" : ",\"check\":\"ok\"") : "");
            locd_pairs_destroy(pairs);
            free(merged);
            free((void *)runs);
            free(counts);
            free(all);
            free(rcounts);
            free(displs);
            free(cnt);
        }
    }
    if (rank == 0)
        cli_free_scene(&sc);
    else
        free(boxes);
    MPI_Finalize();
    return rc;
}
