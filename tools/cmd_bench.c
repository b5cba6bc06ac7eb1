/* locd bench: the paper's Tables 1-2 (processors, run time, speedup,
 * efficiency) measured on this machine, next to the paper's own figures. */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Lucchesi, Egbert, Harris (IJCA 2014), uniform cubes: seconds by processors. */
typedef struct paper_row {
    size_t n;
    unsigned procs;
    double seconds;
} paper_row;
static const paper_row paper[] = {
    {1000000, 1, 29.5}, {1000000, 2, 15.58}, {1000000, 40, 1.48}, {2000000, 1, 59.7}, {2000000, 40, 2.89},
};

static double paper_seconds(size_t n, unsigned p)
{
    size_t i;
    for (i = 0; i < sizeof paper / sizeof paper[0]; i++)
        if (paper[i].n == n && paper[i].procs == p)
            return paper[i].seconds;
    return 0.0;
}

static int parse_sizes(const char *s, size_t *sizes, int max)
{
    char buf[256], *tok, *save = NULL;
    int k = 0;
    snprintf(buf, sizeof buf, "%s", s);
    for (tok = strtok_r(buf, ",", &save); tok && k < max; tok = strtok_r(NULL, ",", &save))
        if (cli_parse_size(tok, &sizes[k++]) != 0)
            return -1;
    return k;
}

typedef struct bench_opts {
    size_t sizes[8], repeat, pmax;
    int nsizes;
    const char *kind;
} bench_opts;

static void bench_usage(void)
{
    printf("usage: locd bench [--sizes 1e6,2e6] [--repeat R] [--threads-max P] [--kind KIND]\n"
           "Prints the paper's Tables 1-2 layout for this machine: processors, run time (median of R),\n"
           "speedup and efficiency, beside the paper's 2014 figures for the same number of cubes.\n");
}

/* 1 after --help (usage printed), else 0; a bad command line exits. */
static int parse_bench_args(int argc, char **argv, bench_opts *o)
{
    int a;
    memset(o, 0, sizeof *o);
    o->sizes[0] = 1000000;
    o->sizes[1] = 2000000;
    o->nsizes = 2;
    o->repeat = 5;
    o->pmax = (size_t)sysconf(_SC_NPROCESSORS_ONLN);
    o->kind = "uniform";
    if (o->pmax < 1)
        o->pmax = 1;
    for (a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "--help")) {
            bench_usage();
            return 1;
        } else if (!strcmp(argv[a], "--sizes") && a + 1 < argc) {
            if ((o->nsizes = parse_sizes(argv[++a], o->sizes, 8)) <= 0)
                cli_die("bench: bad --sizes");
        } else if (!strcmp(argv[a], "--repeat") && a + 1 < argc) {
            o->repeat = cli_size_option(argv[++a], 1, SIZE_MAX, "bench: bad --repeat");
        } else if (!strcmp(argv[a], "--threads-max") && a + 1 < argc) {
            o->pmax = cli_size_option(argv[++a], 1, 64, "bench: bad --threads-max");
        } else if (!strcmp(argv[a], "--kind") && a + 1 < argc) {
            o->kind = argv[++a];
        } else {
            cli_die("bench: unknown option '%s'", argv[a]);
        }
    }
    return 0;
}

static void print_table_head(const bench_opts *o)
{
    char cpu[256];
    cli_cpu_model(cpu, sizeof cpu);
    printf("locd %s bench: '%s' scenes (locd gen %s N --seed 1), median of %zu runs\n", locd_version_string(), o->kind,
           o->kind, o->repeat);
    printf("machine: %s, %ld cores online\n\n", cpu, sysconf(_SC_NPROCESSORS_ONLN));
    printf("| objects   | processors | run time    | speedup | efficiency | pairs     | paper run time | paper speedup | paper efficiency |\n");
    printf("|----------:|-----------:|------------:|--------:|-----------:|----------:|---------------:|--------------:|-----------------:|\n");
}

/* Median in-call time (ms) of `repeat` calls with p threads, after one
 * warm-up call that brings the buffers to their size; *npairs the pairs found. */
static double median_ms(const float *boxes, size_t n, size_t p, size_t repeat, size_t *npairs)
{
    locd_engine_config cfg;
    locd_engine *eng;
    locd_pairs *pairs;
    locd_stats st;
    double *ms = calloc(repeat, sizeof(double)), med;
    size_t r;
    locd_engine_config_init(&cfg);
    cfg.threads = (uint32_t)p;
    if (locd_engine_create(&cfg, &eng) || locd_pairs_create(NULL, &pairs))
        cli_die("bench: %s", locd_last_error());
    locd_engine_find_pairs_f32(eng, boxes, n, 0, pairs);
    for (r = 0; r < repeat; r++) {
        if (locd_engine_find_pairs_f32(eng, boxes, n, 0, pairs) != LOCD_OK)
            cli_die("bench: %s", locd_last_error());
        locd_stats_init(&st);
        locd_engine_get_stats(eng, &st);
        ms[r] = st.ms_total;
    }
    med = cli_median(ms, repeat);
    *npairs = locd_pairs_count(pairs);
    free(ms);
    locd_pairs_destroy(pairs);
    locd_engine_destroy(eng);
    return med;
}

/* The paper's columns of a row: its time with p processors, speedup and efficiency. */
static void print_paper_columns(size_t n, size_t p)
{
    double pp = paper_seconds(n, (unsigned)p), paper1 = paper_seconds(n, 1);
    if (pp > 0)
        printf(" %12.2f s | %13.2f | %15.1f%% |\n", pp, paper1 / pp, 100.0 * paper1 / pp / (double)p);
    else
        printf(" %14s | %13s | %16s |\n", "-", "-", "-");
}

/* The rows of one size: 1..pmax threads here, then the paper's 40 processors. */
static void bench_size(const bench_opts *o, size_t n)
{
    float *boxes = cli_generate(o->kind, n, 1);
    double t1 = 0, paper1 = paper_seconds(n, 1), pp40 = paper_seconds(n, 40);
    size_t p;
    if (!boxes)
        cli_die("bench: cannot generate '%s' (kinds: %s)", o->kind, cli_generator_kinds());
    for (p = 1; p <= o->pmax; p++) {
        size_t npairs;
        double med = median_ms(boxes, n, p, o->repeat, &npairs);
        if (p == 1)
            t1 = med;
        printf("| %9zu | %10zu | %8.2f ms | %7.2f | %9.1f%% | %9zu |", n, p, med, t1 / med,
               100.0 * t1 / med / (double)p, npairs);
        print_paper_columns(n, p);
    }
    if (pp40 > 0)
        printf("| %9zu | %10d | %11s | %7s | %10s | %9s | %12.2f s | %13.2f | %15.1f%% |\n", n, 40, "-", "-", "-", "-",
               pp40, paper1 / pp40, 100.0 * paper1 / pp40 / 40.0);
    free(boxes);
}

int cmd_bench(int argc, char **argv)
{
    bench_opts o;
    int si;
    if (parse_bench_args(argc, argv, &o))
        return 0;
    print_table_head(&o);
    for (si = 0; si < o.nsizes; si++) {
        cli_progress("bench: size", (size_t)si, (size_t)o.nsizes);
        bench_size(&o, o.sizes[si]);
    }
    cli_progress("bench: size", 1, 1);
    printf("\npaper: Lucchesi, Egbert, Harris, IJCA 21(4) 2014, Tables 1-2 (2 processors at 1M: 94.7%% efficiency).\n");
    return 0;
}
