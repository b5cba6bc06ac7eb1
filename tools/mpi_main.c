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
/* The work split the library's levels 1 and 2 use (levels/plan.c, compiled
 * into this program: it calls nothing private), so that ranks take the same
 * shares as threads and workers. */
#include "levels/levels.h"

#include <limits.h>
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct mpi_opts {
    const char *path, *out_path;
    int check;
    uint32_t depth, flags;
    int32_t bias;
} mpi_opts;

/* MPI_Wtime() at the end of each stage, from the broadcast on. */
typedef struct mpi_times {
    double start, fit, encode, gather, merge, sweep;
} mpi_times;

/* Every rank's sorted run, gathered on rank 0. */
typedef struct mpi_runs {
    uint64_t *all; /* the runs back to back */
    const uint64_t **runs;
    size_t *counts;
    uint64_t total;
} mpi_runs;

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

/* 0, or the exit status of a bad command line (after the usage on rank 0). */
static int parse_args(int argc, char **argv, int rank, mpi_opts *o)
{
    int a;
    memset(o, 0, sizeof *o);
    o->bias = LOCD_DEFAULT_CELL_BIAS;
    for (a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "--out") && a + 1 < argc)
            o->out_path = argv[++a];
        else if (!strcmp(argv[a], "--check"))
            o->check = 1;
        else if (!strcmp(argv[a], "--depth") && a + 1 < argc)
            o->depth = (uint32_t)atoi(argv[++a]);
        else if (!strcmp(argv[a], "--bias") && a + 1 < argc)
            o->bias = atoi(argv[++a]);
        else if (!strcmp(argv[a], "--cubes"))
            o->flags |= LOCD_CONFIG_CUBES;
        else if (argv[a][0] != '-' && !o->path)
            o->path = argv[a];
        else {
            if (rank == 0)
                fprintf(stderr, "usage: mpirun -np K locd-mpi SCENE.aabb [--out PAIRS.bin] [--check] [--depth D] "
                                "[--bias B] [--cubes]\n");
            return 2;
        }
    }
    if (!o->path) {
        if (rank == 0)
            fprintf(stderr, "usage: mpirun -np K locd-mpi SCENE.aabb [--out PAIRS.bin] [--check]\n");
        return 2;
    }
    return 0;
}

/* Rank 0 reads the scene, every rank gets its boxes; returns them (sc's on
 * rank 0, a malloc'd copy elsewhere). */
static void *share_scene(int rank, const char *path, cli_scene *sc, mpi_times *tm)
{
    uint64_t hdr[2] = {0, 0};
    void *boxes;
    size_t es;
    memset(sc, 0, sizeof *sc);
    if (rank == 0) {
        if (cli_load_scene(path, sc) != 0)
            MPI_Abort(MPI_COMM_WORLD, 1);
        hdr[0] = sc->n;
        hdr[1] = (uint64_t)sc->f64;
    }
    MPI_Bcast(hdr, 2, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    sc->n = (size_t)hdr[0];
    sc->f64 = (int)hdr[1];
    es = sc->f64 ? sizeof(double) : sizeof(float);
    if (rank == 0) {
        boxes = sc->f64 ? (void *)sc->d : (void *)sc->f;
    } else {
        boxes = malloc((sc->n ? sc->n : 1) * 6 * es);
        if (!boxes)
            fail(rank, "out of memory for the scene", 0);
    }
    MPI_Barrier(MPI_COMM_WORLD);
    tm->start = MPI_Wtime();
    bcast_bytes(boxes, sc->n * 6 * es);
    return boxes;
}

/* Encodes and sorts this rank's share of the boxes; returns the run (malloc)
 * and its length in *written. */
static uint64_t *encode_share(int rank, int size, const locd_grid *grid, const void *boxes, const cli_scene *sc,
                              size_t *written)
{
    size_t first = lc_chunk_begin(sc->n, (uint32_t)rank, (uint32_t)size);
    size_t count = lc_chunk_begin(sc->n, (uint32_t)rank + 1, (uint32_t)size) - first;
    /* Room for every box at its worst: one pass, no overflow round trip. */
    size_t cap = lc_region_capacity(count, LOCD_MAX_ENTRIES_PER_BOX);
    uint64_t *entries = malloc(cap * sizeof *entries), *scratch = malloc(cap * sizeof *scratch);
    locd_status st;
    if (!entries || !scratch)
        fail(rank, "out of memory for entries", 0);
    st = sc->f64 ? locd_encode_f64(grid, boxes, first, count, entries, cap, written)
                 : locd_encode_f32(grid, boxes, first, count, entries, cap, written);
    if (!st)
        st = locd_sort_entries(grid, entries, scratch, *written);
    if (st)
        fail(rank, "encode/sort", st);
    free(scratch);
    if (*written > (size_t)INT_MAX)
        fail(rank, "more than INT_MAX entries on one rank: use more ranks", 0);
    return entries;
}

/* Rank 0 lays the runs out back to back: rcounts/displs for MPI_Gatherv. */
static void plan_gather(int size, const uint64_t *cnt, int *rcounts, int *displs, mpi_runs *g)
{
    int a;
    g->total = 0;
    for (a = 0; a < size; a++) {
        if (g->total > (uint64_t)INT_MAX)
            fail(0, "more than INT_MAX entries in all: the gather cannot address them", 0);
        rcounts[a] = (int)cnt[a];
        displs[a] = (int)g->total;
        g->total += cnt[a];
    }
    g->all = malloc((size_t)(g->total ? g->total : 1) * sizeof *g->all);
    g->runs = malloc((size_t)size * sizeof *g->runs);
    g->counts = malloc((size_t)size * sizeof *g->counts);
    if (!g->all)
        fail(0, "out of memory for the gathered entries", 0);
}

/* Gathers every rank's run on rank 0 (g is filled there only). */
static void gather_runs(int rank, int size, const uint64_t *entries, size_t written, mpi_runs *g)
{
    uint64_t mine = written, *cnt = rank == 0 ? malloc((size_t)size * sizeof *cnt) : NULL;
    int *rcounts = NULL, *displs = NULL, a;
    memset(g, 0, sizeof *g);
    MPI_Gather(&mine, 1, MPI_UINT64_T, cnt, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    if (rank == 0) {
        rcounts = malloc((size_t)size * sizeof *rcounts);
        displs = malloc((size_t)size * sizeof *displs);
        plan_gather(size, cnt, rcounts, displs, g);
    }
    MPI_Gatherv(entries, (int)written, MPI_UINT64_T, g->all, rcounts, displs, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    if (rank == 0)
        for (a = 0; a < size; a++) {
            g->runs[a] = g->all + displs[a];
            g->counts[a] = (size_t)cnt[a];
        }
    free(rcounts);
    free(displs);
    free(cnt);
}

static void free_runs(mpi_runs *g)
{
    free(g->all);
    free((void *)g->runs);
    free(g->counts);
}

/* Rank 0: merges the runs and sweeps them into a new pairs buffer. */
static locd_pairs *merge_and_sweep(int size, const locd_grid *grid, const void *boxes, const cli_scene *sc,
                                   const mpi_runs *g, mpi_times *tm)
{
    uint64_t *merged = malloc((size_t)(g->total ? g->total : 1) * sizeof *merged);
    locd_pairs *pairs = NULL;
    locd_stats ss;
    locd_status st = locd_merge_entries(g->runs, g->counts, (size_t)size, merged);
    if (st)
        fail(0, "merge", st);
    tm->merge = MPI_Wtime();
    locd_stats_init(&ss);
    if ((st = locd_pairs_create(NULL, &pairs)) != LOCD_OK)
        fail(0, "pairs", st);
    st = sc->f64 ? locd_sweep_f64(grid, boxes, sc->n, merged, (size_t)g->total, pairs, &ss)
                 : locd_sweep_f32(grid, boxes, sc->n, merged, (size_t)g->total, pairs, &ss);
    if (st)
        fail(0, "sweep", st);
    tm->sweep = MPI_Wtime();
    free(merged);
    return pairs;
}

/* 0 when a level-1 engine with the same settings finds the same pairs in
 * the same order; 3 (and a message) otherwise. */
static int check_level1(const mpi_opts *o, const void *boxes, const cli_scene *sc, const locd_pairs *pairs)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_pairs *ref = NULL;
    size_t k = locd_pairs_count(pairs);
    int rc = 0;
    locd_engine_config_init(&cfg);
    cfg.max_depth = o->depth;
    cfg.cell_bias = o->bias;
    cfg.flags = o->flags;
    if (locd_engine_create(&cfg, &e) || locd_pairs_create(NULL, &ref) ||
        (sc->f64 ? locd_engine_find_pairs_f64(e, boxes, sc->n, 0, ref)
                 : locd_engine_find_pairs_f32(e, boxes, sc->n, 0, ref)) ||
        locd_pairs_count(ref) != k ||
        (k && memcmp(locd_pairs_data(ref), locd_pairs_data(pairs), k * 2 * sizeof(uint32_t)))) {
        fprintf(stderr, "locd-mpi: CHECK FAILED: %zu pairs, level 1 has %zu\n", k, locd_pairs_count(ref));
        rc = 3;
    }
    locd_pairs_destroy(ref);
    locd_engine_destroy(e);
    return rc;
}

/* Rank 0: merge, sweep, optional check and pairs file, the JSON line. */
static int finish(int size, const mpi_opts *o, const locd_grid *grid, const void *boxes, const cli_scene *sc,
                  const mpi_runs *g, mpi_times *tm)
{
    locd_pairs *pairs = merge_and_sweep(size, grid, boxes, sc, g, tm);
    int rc = o->check ? check_level1(o, boxes, sc, pairs) : 0;
    if (o->out_path) {
        locd_pairs_sort(pairs);
        if (cli_write_pairs(o->out_path, locd_pairs_data(pairs), locd_pairs_count(pairs)) != 0)
            rc = 1;
    }
    printf("{\"n\":%zu,\"pairs\":%zu,\"ranks\":%d,\"precision\":\"%s\",\"total_ms\":%.3f,\"stage_ms\":{"
           "\"broadcast_fit\":%.3f,\"encode_sort\":%.3f,\"gather\":%.3f,\"merge\":%.3f,\"sweep\":%.3f},"
           "\"entries\":%llu%s}\n",
           sc->n, locd_pairs_count(pairs), size, sc->f64 ? "f64" : "f32", (tm->sweep - tm->start) * 1e3,
           (tm->fit - tm->start) * 1e3, (tm->encode - tm->fit) * 1e3, (tm->gather - tm->encode) * 1e3,
           (tm->merge - tm->gather) * 1e3, (tm->sweep - tm->merge) * 1e3, (unsigned long long)g->total,
           o->check ? (rc == 3 ? ",\"check\":\"FAILED\"" : ",\"check\":\"ok\"") : "");
    locd_pairs_destroy(pairs);
    return rc;
}

int main(int argc, char **argv)
{
    int rank, size, rc = 0;
    mpi_opts o;
    mpi_times tm;
    mpi_runs g;
    cli_scene sc;
    void *boxes;
    uint64_t *entries;
    size_t written = 0;
    locd_grid grid;
    locd_status st;

    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    if ((rc = parse_args(argc, argv, rank, &o)) != 0) {
        MPI_Finalize();
        return rc;
    }
    boxes = share_scene(rank, o.path, &sc, &tm);
    /* Every rank fits the same grid from the same boxes (and rejects the
       same bad box). */
    st = sc.f64 ? locd_grid_fit_f64(boxes, sc.n, o.depth, o.bias, o.flags, &grid)
                : locd_grid_fit_f32(boxes, sc.n, o.depth, o.bias, o.flags, &grid);
    if (st)
        fail(rank, "invalid scene", st);
    tm.fit = MPI_Wtime();
    entries = encode_share(rank, size, &grid, boxes, &sc, &written);
    tm.encode = MPI_Wtime();
    gather_runs(rank, size, entries, written, &g);
    free(entries);
    tm.gather = MPI_Wtime();
    if (rank == 0) {
        rc = finish(size, &o, &grid, boxes, &sc, &g, &tm);
        free_runs(&g);
        cli_free_scene(&sc);
    } else {
        free(boxes);
    }
    MPI_Finalize();
    return rc;
}
