/* locd-mpi: one scene across MPI ranks, through liblocd_mpi
 * (include/locd/mpi.h, docs/cluster.md).
 *
 *   mpirun -np K locd-mpi SCENE.aabb [--strategy distributed|master] [--out PAIRS.bin] [--check]
 *                                    [--threads T] [--depth D] [--bias B] [--cubes] [--samples S]
 *                                    [--counts C0,C1,...]
 *
 * Each rank reads only its slice of the scene (pread at its offset: rank r
 * holds boxes [n*r/K, n*(r+1)/K), or the counts --counts gives, which
 * the tests use for empty ranks and a rank holding all) and calls locd_mpi_find_pairs_*. With
 * --out or --check the pairs are gathered on rank 0 (in the whole sweep's
 * order): --check compares them, order included, with a level-1 engine run
 * on the whole scene on rank 0; --out writes them sorted by (i, j), the
 * bytes `locd pairs --out` writes. Prints one JSON line per rank (its
 * statistics and peak memory), then a summary line, all from rank 0. */
#include "cli.h"

#include <locd/mpi.h>

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#define LINE 1024

typedef struct mpi_opts {
    const char *path, *out_path;
    const char *counts; /* --counts c0,c1,...: boxes per rank (tests: empty ranks, one rank with all) */
    int check;
    locd_mpi_options o;
} mpi_opts;

/* This rank's slice of the scene file. */
typedef struct slice {
    int f64;
    size_t n, first, count;
    void *boxes;
} slice;

static int usage(int rank)
{
    if (rank == 0)
        fprintf(stderr, "usage: mpirun -np K locd-mpi SCENE.aabb [--strategy distributed|master] [--out PAIRS.bin] "
                        "[--check] [--threads T] [--depth D] [--bias B] [--cubes] [--samples S] [--counts C0,C1,...]\n");
    return 2;
}

static int parse_args(int argc, char **argv, int rank, mpi_opts *m)
{
    int a;
    memset(m, 0, sizeof *m);
    locd_mpi_options_init(&m->o);
    for (a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "--out") && a + 1 < argc)
            m->out_path = argv[++a];
        else if (!strcmp(argv[a], "--check"))
            m->check = 1;
        else if (!strcmp(argv[a], "--strategy") && a + 1 < argc) {
            const char *s = argv[++a];
            if (!strcmp(s, "distributed"))
                m->o.strategy = LOCD_MPI_DISTRIBUTED;
            else if (!strcmp(s, "master"))
                m->o.strategy = LOCD_MPI_MASTER;
            else
                return usage(rank);
        } else if (!strcmp(argv[a], "--threads") && a + 1 < argc)
            m->o.threads = (uint32_t)atoi(argv[++a]);
        else if (!strcmp(argv[a], "--depth") && a + 1 < argc)
            m->o.max_depth = (uint32_t)atoi(argv[++a]);
        else if (!strcmp(argv[a], "--bias") && a + 1 < argc)
            m->o.cell_bias = atoi(argv[++a]);
        else if (!strcmp(argv[a], "--samples") && a + 1 < argc)
            m->o.samples = (uint32_t)atoi(argv[++a]);
        else if (!strcmp(argv[a], "--counts") && a + 1 < argc)
            m->counts = argv[++a];
        else if (!strcmp(argv[a], "--cubes"))
            m->o.flags |= LOCD_CONFIG_CUBES;
        else if (argv[a][0] != '-' && !m->path)
            m->path = argv[a];
        else
            return usage(rank);
    }
    if (!m->path)
        return usage(rank);
    if (m->out_path || m->check)
        m->o.gather_root = 0;
    return 0;
}

static int ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && !strcmp(s + a - b, suffix);
}

/* The slice of rank `rank` under --counts (K numbers summing to n). 0, or -1. */
static int counted_slice(const char *counts, int rank, int ranks, slice *s)
{
    size_t at = 0, c;
    const char *p = counts;
    int r;
    for (r = 0; r < ranks; r++) {
        char *end;
        c = (size_t)strtoull(p, &end, 10);
        if (end == p || (r + 1 < ranks && *end != ',') || (r + 1 == ranks && *end))
            return -1;
        if (r == rank) {
            s->first = at;
            s->count = c;
        }
        at += c;
        p = end + 1;
    }
    return at == s->n ? 0 : -1;
}

/* Reads boxes [first, first + count) of the file: pread at the slice's
 * offset, nothing else of the file. 0, or -1 with a message. */
static int read_slice(const char *path, const char *counts, int rank, int ranks, slice *s)
{
    struct stat stt;
    size_t bytes, done = 0, rowb;
    int fd = open(path, O_RDONLY);
    memset(s, 0, sizeof *s);
    s->f64 = ends_with(path, ".aabb64");
    rowb = s->f64 ? 48 : 24;
    if (fd < 0 || fstat(fd, &stt) != 0) {
        fprintf(stderr, "locd-mpi (rank %d): cannot open %s: %s\n", rank, path, strerror(errno));
        if (fd >= 0)
            close(fd);
        return -1;
    }
    if ((size_t)stt.st_size % rowb) {
        fprintf(stderr, "locd-mpi (rank %d): %s is not a whole number of %zu-byte boxes\n", rank, path, rowb);
        close(fd);
        return -1;
    }
    s->n = (size_t)stt.st_size / rowb;
    s->first = s->n / (size_t)ranks * (size_t)rank + ((size_t)rank < s->n % (size_t)ranks ? (size_t)rank : s->n % (size_t)ranks);
    s->count = s->n / (size_t)ranks + ((size_t)rank < s->n % (size_t)ranks ? 1 : 0);
    if (counts && counted_slice(counts, rank, ranks, s) != 0) {
        fprintf(stderr, "locd-mpi (rank %d): --counts needs %d numbers summing to %zu\n", rank, ranks, s->n);
        close(fd);
        return -1;
    }
    bytes = s->count * rowb;
    s->boxes = malloc(bytes ? bytes : 1);
    while (s->boxes && done < bytes) {
        ssize_t got = pread(fd, (char *)s->boxes + done, bytes - done, (off_t)(s->first * rowb + done));
        if (got <= 0) {
            fprintf(stderr, "locd-mpi (rank %d): reading %s failed\n", rank, path);
            close(fd);
            return -1;
        }
        done += (size_t)got;
    }
    close(fd);
    if (!s->boxes) {
        fprintf(stderr, "locd-mpi (rank %d): out of memory for %zu boxes\n", rank, s->count);
        return -1;
    }
    return 0;
}

/* Rank 0: 0 when a level-1 engine on the whole scene finds the same pairs
 * in the same order; 3 (and a message) otherwise. */
static int check_level1(const mpi_opts *m, const locd_pairs *pairs)
{
    cli_scene sc;
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_pairs *ref = NULL;
    size_t k = locd_pairs_count(pairs);
    int rc = 0;
    if (cli_load_scene(m->path, &sc) != 0)
        return 3;
    locd_engine_config_init(&cfg);
    cfg.max_depth = m->o.max_depth;
    cfg.cell_bias = m->o.cell_bias;
    cfg.flags = m->o.flags;
    if (locd_engine_create(&cfg, &e) || locd_pairs_create(NULL, &ref) ||
        (sc.f64 ? locd_engine_find_pairs_f64(e, sc.d, sc.n, 0, ref) : locd_engine_find_pairs_f32(e, sc.f, sc.n, 0, ref)) ||
        locd_pairs_count(ref) != k ||
        (k && memcmp(locd_pairs_data(ref), locd_pairs_data(pairs), k * 2 * sizeof(uint32_t)))) {
        fprintf(stderr, "locd-mpi: CHECK FAILED: %zu pairs, level 1 has %zu (or another order)\n", k,
                locd_pairs_count(ref));
        rc = 3;
    }
    locd_pairs_destroy(ref);
    locd_engine_destroy(e);
    cli_free_scene(&sc);
    return rc;
}

static long peak_rss_kb(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss; /* kilobytes on Linux */
}

static void rank_line(char *buf, const locd_mpi_stats *s, long rss)
{
    snprintf(buf, LINE,
             "{\"rank\":%d,\"ranks\":%d,\"strategy\":\"%s\",\"n\":%llu,\"local_n\":%llu,\"entries_encoded\":%llu,"
             "\"entries_held\":%llu,\"entries_replicated\":%llu,\"objects_held\":%llu,\"candidates\":%llu,"
             "\"pairs_owned\":%llu,\"bytes_sent\":%llu,\"bytes_received\":%llu,\"depth\":%u,\"imbalance\":%.4f,"
             "\"peak_rss_kb\":%ld,\"total_ms\":%.3f,\"stage_ms\":{\"bounds\":%.3f,\"encode_sort\":%.3f,\"split\":%.3f,"
             "\"exchange\":%.3f,\"merge\":%.3f,\"sweep\":%.3f,\"gather\":%.3f}}",
             s->rank, s->ranks, s->strategy == LOCD_MPI_MASTER ? "master" : "distributed",
             (unsigned long long)s->objects, (unsigned long long)s->local_objects,
             (unsigned long long)s->entries_encoded, (unsigned long long)s->entries_held,
             (unsigned long long)s->entries_replicated, (unsigned long long)s->objects_held,
             (unsigned long long)s->candidates, (unsigned long long)s->pairs_owned,
             (unsigned long long)s->bytes_sent, (unsigned long long)s->bytes_received, s->depth, s->imbalance, rss,
             s->ms_total, s->ms_bounds, s->ms_encode, s->ms_split, s->ms_exchange, s->ms_merge, s->ms_sweep,
             s->ms_gather);
}

/* Every rank's line, printed in rank order by rank 0, then the summary. */
static void report(int rank, int ranks, const locd_mpi_stats *s, const char *check)
{
    char mine[LINE], *all = rank == 0 ? malloc((size_t)ranks * LINE) : NULL;
    double v[4] = {s->ms_total, (double)s->bytes_sent, (double)peak_rss_kb(), (double)s->pairs_owned}, mx[4], sum[4];
    int r;
    rank_line(mine, s, peak_rss_kb());
    MPI_Gather(mine, LINE, MPI_CHAR, all, LINE, MPI_CHAR, 0, MPI_COMM_WORLD);
    MPI_Reduce(v, mx, 4, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    MPI_Reduce(v, sum, 4, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
    if (rank != 0)
        return;
    for (r = 0; r < ranks; r++)
        printf("%s\n", all + (size_t)r * LINE);
    printf("{\"summary\":true,\"n\":%llu,\"pairs\":%.0f,\"ranks\":%d,\"strategy\":\"%s\",\"total_ms\":%.3f,"
           "\"bytes_sent_total\":%.0f,\"max_peak_rss_kb\":%.0f,\"imbalance\":%.4f%s%s%s}\n",
           (unsigned long long)s->objects, sum[3], ranks, s->strategy == LOCD_MPI_MASTER ? "master" : "distributed",
           mx[0], sum[1], mx[2], s->imbalance, check ? ",\"check\":\"" : "", check ? check : "", check ? "\"" : "");
    free(all);
}

int main(int argc, char **argv)
{
    int rank, ranks, rc, ok, all_ok;
    mpi_opts m;
    slice sl;
    locd_pairs *pairs = NULL;
    locd_mpi_stats stats;
    locd_status st;
    const char *check = NULL;

    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &ranks);
    if ((rc = parse_args(argc, argv, rank, &m)) != 0) {
        MPI_Finalize();
        return rc;
    }
    ok = read_slice(m.path, m.counts, rank, ranks, &sl) == 0 && locd_pairs_create(NULL, &pairs) == LOCD_OK;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (!all_ok) {
        free(sl.boxes);
        locd_pairs_destroy(pairs);
        MPI_Finalize();
        return 1;
    }
    locd_mpi_stats_init(&stats);
    st = sl.f64 ? locd_mpi_find_pairs_f64(MPI_COMM_WORLD, sl.boxes, sl.count, &m.o, pairs, &stats)
                : locd_mpi_find_pairs_f32(MPI_COMM_WORLD, sl.boxes, sl.count, &m.o, pairs, &stats);
    free(sl.boxes);
    if (st) {
        /* every rank has the same status (and index): each says so */
        fprintf(stderr, "locd-mpi (rank %d): status %d index %lld: %s\n", rank, (int)st,
                (long long)locd_last_error_index(), locd_last_error());
        locd_pairs_destroy(pairs);
        MPI_Finalize();
        return 1;
    }
    rc = 0;
    if (rank == 0 && m.check) {
        rc = check_level1(&m, pairs);
        check = rc ? "FAILED" : "ok";
    }
    if (rank == 0 && m.out_path) {
        if (locd_pairs_sort(pairs) != LOCD_OK ||
            cli_write_pairs(m.out_path, locd_pairs_data(pairs), locd_pairs_count(pairs)) != 0)
            rc = 1;
    }
    report(rank, ranks, &stats, check);
    locd_pairs_destroy(pairs);
    MPI_Finalize();
    return rc;
}
