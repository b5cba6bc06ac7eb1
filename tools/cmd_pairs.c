/* locd pairs FILE.aabb: run the engine on a scene, print one JSON line.
 * With --against B: the two-set query (locd_engine_find_pairs_between_*). */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void pairs_usage(void)
{
    printf("usage: locd pairs SCENE [options]\n"
           "  SCENE: FILE.aabb (float32), FILE.aabb64 (float64), FILE.npy (float32/float64 (n, 6)),\n"
           "         or - for stdin (.npy if it starts with the NumPy magic, else .aabb); docs/formats.md\n"
           "  --against B        two sets: pairs (i in SCENE, j in B) only (levels 1, 2); B as SCENE\n"
           "  --threads K        threads (level 1; default: one per core)\n"
           "  --level L          inprocess (1), workers (2) or service (3)\n"
           "  --workers K        worker processes (implies --level workers)\n"
           "  --service ADDR     unix:PATH or tcp:HOST:PORT (implies --level service)\n"
           "  --secret-file F    shared secret for a TCP service: F's first line (or set LOCD_SECRET;\n"
           "                     --secret S works too, but others can read it in /proc/PID/cmdline)\n"
           "  --out PAIRS.bin    write the pairs, sorted by (i, j), as little-endian uint32 i j rows;\n"
           "                     - writes them to stdout (the JSON line then goes to stderr)\n"
           "  --repeat R         run R times; total_ms is the median (default 2)\n"
           "  --pause MS         sleep MS milliseconds before each run, as a game's frames are apart (the\n"
           "                     engine's threads go idle in between; default 0)\n"
           "  --f64              convert a float32 scene to float64 and use the f64 entry point\n"
           "  --sorted           ask the engine for (i, j) order inside the timed call\n"
           "  --depth D          octree depth limit (default automatic)\n"
           "  --bias B           cell edge >= 2^B x box extent (default 2)\n"
           "  --cubes            encode bounding cubes (the paper's choice) instead of boxes\n"
           "  --check            also compare with the O(n^2) reference (at most 100000 boxes)\n"
           "  --force            --check on more than 100000 boxes anyway (minutes to hours)\n"
           "Prints one JSON line: n, pairs, total_ms (median in-call time), stage_ms, entries, candidates.\n");
}

static int parse_level(const char *s)
{
    if (!strcmp(s, "1") || !strcmp(s, "inprocess") || !strcmp(s, "in-process"))
        return LOCD_LEVEL_INPROCESS;
    if (!strcmp(s, "2") || !strcmp(s, "workers"))
        return LOCD_LEVEL_WORKERS;
    if (!strcmp(s, "3") || !strcmp(s, "service"))
        return LOCD_LEVEL_SERVICE;
    cli_die("pairs: unknown level '%s' (inprocess, workers, service)", s);
    return 0;
}

static int same_pairs(const uint32_t *a, const uint32_t *b, size_t m)
{
    return m == 0 || memcmp(a, b, m * 2 * sizeof(uint32_t)) == 0;
}

typedef struct pairs_opts {
    const char *path, *out_path, *against, *secret_file;
    char *secret_arg, *secret;
    locd_engine_config cfg;
    size_t repeat;
    double pause_ms; /* slept before each run */
    uint32_t flags; /* LOCD_FIND_* */
    int want_f64, check, force;
} pairs_opts;

/* --check runs the O(n^2) reference: past this many boxes it takes minutes. */
#define PAIRS_CHECK_MAX 100000
/* Each repeat runs the whole query; a million is already days of work. */
#define PAIRS_REPEAT_MAX 1000000

/* The stage times of every repeat, in locd_stats order; the summary prints their medians. */
#define PAIRS_STAGES 7
typedef struct pairs_times {
    double *total, *stage[PAIRS_STAGES];
} pairs_times;

/* An option that takes the value v; 0 if o is not one of these. */
static int parse_value_option(const char *o, const char *v, pairs_opts *p)
{
    if (!strcmp(o, "--threads")) {
        p->cfg.threads = (uint32_t)cli_size_option(v, 0, 64, "pairs: bad --threads");
    } else if (!strcmp(o, "--workers")) {
        p->cfg.threads = (uint32_t)cli_size_option(v, 0, 64, "pairs: bad --workers");
        p->cfg.level = LOCD_LEVEL_WORKERS;
    } else if (!strcmp(o, "--level")) {
        p->cfg.level = parse_level(v);
    } else if (!strcmp(o, "--service")) {
        p->cfg.service_address = v;
        p->cfg.level = LOCD_LEVEL_SERVICE;
    } else if (!strcmp(o, "--secret")) {
        p->secret_arg = (char *)v; /* argv: cli_secret overwrites it */
    } else if (!strcmp(o, "--secret-file")) {
        p->secret_file = v;
    } else if (!strcmp(o, "--against")) {
        p->against = v;
    } else if (!strcmp(o, "--out")) {
        p->out_path = v;
    } else if (!strcmp(o, "--repeat")) {
        p->repeat = cli_size_option(v, 1, PAIRS_REPEAT_MAX, "pairs: bad --repeat (1..%d)", PAIRS_REPEAT_MAX);
    } else if (!strcmp(o, "--pause")) {
        p->pause_ms = (double)cli_size_option(v, 0, 60000, "pairs: bad --pause (0..60000 ms)");
    } else if (!strcmp(o, "--depth")) {
        p->cfg.max_depth =
            (uint32_t)cli_size_option(v, 0, LOCD_MAX_DEPTH, "pairs: bad --depth (0..LOCD_MAX_DEPTH, 21)");
    } else if (!strcmp(o, "--bias")) {
        p->cfg.cell_bias = (int32_t)cli_size_option(v, 0, 8, "pairs: bad --bias (0..8)");
    } else {
        return 0;
    }
    return 1;
}

/* A flag option; 0 if not one of these. */
static int parse_flag_option(const char *o, pairs_opts *p)
{
    if (!strcmp(o, "--cubes"))
        p->cfg.flags |= LOCD_CONFIG_CUBES;
    else if (!strcmp(o, "--f64"))
        p->want_f64 = 1;
    else if (!strcmp(o, "--sorted"))
        p->flags |= LOCD_FIND_SORTED;
    else if (!strcmp(o, "--check"))
        p->check = 1;
    else if (!strcmp(o, "--force"))
        p->force = 1;
    else
        return 0;
    return 1;
}

/* 1 after --help (usage printed), else 0; a bad command line exits. */
static int parse_pairs_args(int argc, char **argv, pairs_opts *p)
{
    int a;
    memset(p, 0, sizeof *p);
    locd_engine_config_init(&p->cfg);
    p->repeat = 1;
    for (a = 1; a < argc; a++) {
        const char *o = argv[a];
        if (!strcmp(o, "--help")) {
            pairs_usage();
            return 1;
        } else if (a + 1 < argc && parse_value_option(o, argv[a + 1], p)) {
            a++;
        } else if (parse_flag_option(o, p)) {
            continue;
        } else if (o[0] == '-' && o[1]) {
            cli_die("pairs: unknown option '%s' (see locd pairs --help)", o);
        } else if (!p->path) {
            p->path = o;
        } else {
            cli_die("pairs: unexpected argument '%s'", o);
        }
    }
    if (!p->path)
        cli_die("usage: locd pairs FILE.aabb [--threads K] [--out PAIRS.bin] [--repeat R]");
    p->secret = cli_secret("pairs", p->secret_arg, p->secret_file);
    p->cfg.service_secret = p->secret;
    return 0;
}

/* --f64 on a float32 scene: the same boxes as doubles. */
static void scene_to_f64(cli_scene *sc)
{
    double *dbl = malloc((sc->n ? sc->n : 1) * 6 * sizeof(double));
    size_t i;
    if (!dbl)
        cli_die("pairs: out of memory");
    for (i = 0; i < 6 * sc->n; i++)
        dbl[i] = (double)sc->f[i];
    sc->d = dbl;
    sc->f64 = 1;
    free(sc->f);
    sc->f = NULL;
}

/* 0, or -1 (everything freed) when an allocation failed. */
static int times_alloc(pairs_times *t, size_t repeat)
{
    size_t i;
    int ok;
    t->total = calloc(repeat, sizeof *t->total);
    ok = t->total != NULL;
    for (i = 0; i < PAIRS_STAGES; i++)
        ok &= (t->stage[i] = calloc(repeat, sizeof(double))) != NULL;
    if (!ok) {
        free(t->total);
        for (i = 0; i < PAIRS_STAGES; i++)
            free(t->stage[i]);
        return -1;
    }
    return 0;
}

static void times_free(pairs_times *t)
{
    size_t i;
    free(t->total);
    for (i = 0; i < PAIRS_STAGES; i++)
        free(t->stage[i]);
}

static void times_record(pairs_times *t, size_t r, const locd_stats *st)
{
    t->total[r] = st->ms_total;
    t->stage[0][r] = st->ms_bounds;
    t->stage[1][r] = st->ms_encode;
    t->stage[2][r] = st->ms_sort;
    t->stage[3][r] = st->ms_merge;
    t->stage[4][r] = st->ms_sweep;
    t->stage[5][r] = st->ms_order;
    t->stage[6][r] = st->ms_transfer;
}

/* Runs the engine `repeat` times; *st gets the last run's stats. 0, or 1
 * after reporting a failed call. */
static int run_repeats(const pairs_opts *p, locd_engine *eng, const cli_scene *sc, const cli_scene *b,
                       locd_pairs *pairs, pairs_times *times, locd_stats *st)
{
    size_t r;
    for (r = 0; r < p->repeat; r++) {
        locd_status s;
        if (p->repeat > 1)
            cli_progress("pairs: run", r, p->repeat);
        if (p->pause_ms > 0)
            cli_sleep_ms(p->pause_ms);
        if (b)
            s = sc->f64 ? locd_engine_find_pairs_between_f64(eng, sc->d, sc->n, b->d, b->n, p->flags, pairs)
                        : locd_engine_find_pairs_between_f32(eng, sc->f, sc->n, b->f, b->n, p->flags, pairs);
        else
            s = sc->f64 ? locd_engine_find_pairs_f64(eng, sc->d, sc->n, p->flags, pairs)
                        : locd_engine_find_pairs_f32(eng, sc->f, sc->n, p->flags, pairs);
        if (s != LOCD_OK) {
            int64_t bad = locd_last_error_index();
            if (bad >= 0 && b && (uint64_t)bad >= sc->n) /* the two-set call names box j of b as na + j */
                fprintf(stderr, "locd: %s: box %lld is invalid: %s\n", p->against, (long long)(bad - (int64_t)sc->n),
                        locd_status_string(s));
            else if (bad >= 0)
                fprintf(stderr, "locd: %s: box %lld is invalid: %s\n", p->path, (long long)bad, locd_status_string(s));
            else
                fprintf(stderr, "locd: %s: %s\n", p->path, locd_last_error());
            return 1;
        }
        locd_stats_init(st);
        locd_engine_get_stats(eng, st);
        times_record(times, r, st);
    }
    if (p->repeat > 1)
        cli_progress("pairs: run", p->repeat, p->repeat);
    return 0;
}

static const double *box_f64(const cli_scene *sc, size_t i, double tmp[6])
{
    int k;
    if (sc->f64)
        return sc->d + 6 * i;
    for (k = 0; k < 6; k++)
        tmp[k] = (double)sc->f[6 * i + k];
    return tmp;
}

/* The two-set reference: every (i, j) with a's box i and b's box j
 * overlapping, in (i, j) order, compared with the (sorted) pairs. 0 when
 * they are the same, else 3. */
static int check_between_reference(const cli_scene *a, const cli_scene *b, const locd_pairs *pairs)
{
    const uint32_t *got = locd_pairs_data(pairs);
    size_t m = locd_pairs_count(pairs), k = 0, i, j, found = 0;
    int same = 1;
    for (i = 0; i < a->n; i++) {
        double ta[6];
        const double *x = box_f64(a, i, ta);
        if ((i & 1023) == 0)
            cli_progress("pairs: checking", i, a->n);
        for (j = 0; j < b->n; j++) {
            double tb[6];
            const double *y = box_f64(b, j, tb);
            if (x[0] <= y[3] && y[0] <= x[3] && x[1] <= y[4] && y[1] <= x[4] && x[2] <= y[5] && y[2] <= x[5]) {
                if (k >= m || got[2 * k] != i || got[2 * k + 1] != j)
                    same = 0;
                k++;
                found++;
            }
        }
    }
    cli_progress("pairs: checking", a->n, a->n);
    if (!same || found != m) {
        fprintf(stderr, "locd: CHECK FAILED: engine %zu pairs, reference %zu pairs\n", m, found);
        return 3;
    }
    return 0;
}

/* 0 when the O(n^2) reference finds the same pairs (both sorted), else 3. */
static int check_reference(const cli_scene *sc, const locd_pairs *pairs)
{
    locd_pairs *ref = NULL;
    locd_status s;
    int rc = 0;
    locd_pairs_create(NULL, &ref);
    s = sc->f64 ? locd_brute_force_f64(sc->d, sc->n, ref) : locd_brute_force_f32(sc->f, sc->n, ref);
    if (s != LOCD_OK || locd_pairs_count(ref) != locd_pairs_count(pairs) ||
        !same_pairs(locd_pairs_data(ref), locd_pairs_data(pairs), locd_pairs_count(ref))) {
        fprintf(stderr, "locd: CHECK FAILED: engine %zu pairs, reference %zu pairs\n", locd_pairs_count(pairs),
                locd_pairs_count(ref));
        rc = 3;
    }
    locd_pairs_destroy(ref);
    return rc;
}

static void print_summary(const pairs_opts *p, const cli_scene *sc, const cli_scene *b, int level,
                          const locd_pairs *pairs, const locd_stats *st, pairs_times *t, int rc)
{
    size_t m = p->repeat;
    /* With the pairs on stdout, the summary goes to stderr. */
    FILE *f = p->out_path && !strcmp(p->out_path, "-") ? stderr : stdout;
    if (b)
        fprintf(f, "{\"na\":%zu,\"nb\":%zu,", sc->n, b->n);
    else
        fputc('{', f);
    fprintf(f, "\"n\":%zu,\"pairs\":%zu,\"level\":%d,\"threads\":%u,\"precision\":\"%s\",\"repeat\":%zu,"
           "\"total_ms\":%.3f,\"stage_ms\":{\"bounds\":%.3f,\"encode\":%.3f,\"sort\":%.3f,\"merge\":%.3f,"
           "\"sweep\":%.3f,\"order\":%.3f,\"transfer\":%.3f},\"entries\":%llu,\"candidates\":%llu,"
           "\"exact_tests\":%llu,\"depth\":%u%s}\n",
           b ? sc->n + b->n : sc->n, locd_pairs_count(pairs), level, st->threads,
           sc->f64 ? "f64" : "f32", m,
           cli_median(t->total, m), cli_median(t->stage[0], m), cli_median(t->stage[1], m),
           cli_median(t->stage[2], m), cli_median(t->stage[3], m), cli_median(t->stage[4], m),
           cli_median(t->stage[5], m), cli_median(t->stage[6], m), (unsigned long long)st->entries,
           (unsigned long long)st->candidates, (unsigned long long)st->exact_tests, st->depth,
           p->check ? (rc ? ",\"check\":\"FAILED\"" : ",\"check\":\"ok\"") : "");
}

/* Loads SCENE (and --against's B; a float32 set meeting a float64 one is
 * widened), refusing a --check the O(n^2) reference would take minutes
 * over. 0, or 1 after a message. */
static int load_inputs(pairs_opts *p, cli_scene *sc, cli_scene *b)
{
    memset(b, 0, sizeof *b);
    if (p->against && !strcmp(p->path, "-") && !strcmp(p->against, "-"))
        cli_die("pairs: only one of SCENE and --against can be stdin");
    if (cli_load_scene(p->path, sc) != 0)
        return 1;
    if (p->against && cli_load_scene(p->against, b) != 0) {
        cli_free_scene(sc);
        return 1;
    }
    if (p->check && !p->force && sc->n + b->n > PAIRS_CHECK_MAX) {
        fprintf(stderr,
                "locd: pairs: --check compares with the O(n^2) reference, which takes minutes past %d boxes "
                "(this scene has %zu); add --force to run it anyway\n",
                PAIRS_CHECK_MAX, sc->n + b->n);
        cli_free_scene(sc);
        cli_free_scene(b);
        return 1;
    }
    if ((p->want_f64 || (p->against && b->f64)) && !sc->f64)
        scene_to_f64(sc);
    if (p->against && sc->f64 && !b->f64)
        scene_to_f64(b);
    return 0;
}

int cmd_pairs(int argc, char **argv)
{
    pairs_opts p;
    pairs_times times;
    locd_engine *eng = NULL;
    locd_pairs *pairs = NULL;
    locd_stats st;
    cli_scene sc, b;
    const cli_scene *bp;
    int rc;

    if (parse_pairs_args(argc, argv, &p))
        return 0;
    if (load_inputs(&p, &sc, &b) != 0) {
        free(p.secret);
        return 1;
    }
    bp = p.against ? &b : NULL;
    rc = locd_engine_create(&p.cfg, &eng);
    free(p.secret); /* the engine keeps its own copy */
    p.cfg.service_secret = p.secret = NULL;
    if (rc != LOCD_OK) {
        fprintf(stderr, "locd: cannot create the engine: %s\n", locd_last_error());
        cli_free_scene(&sc);
        cli_free_scene(&b);
        return 1;
    }
    if (locd_pairs_create(NULL, &pairs) != LOCD_OK)
        cli_die("pairs: %s", locd_last_error());
    if (times_alloc(&times, p.repeat) != 0) {
        fprintf(stderr, "locd: pairs: %s (the times of %zu repeats)\n", locd_status_string(LOCD_ERR_NO_MEMORY),
                p.repeat);
        locd_pairs_destroy(pairs);
        locd_engine_destroy(eng);
        cli_free_scene(&sc);
        cli_free_scene(&b);
        return 1;
    }
    if ((rc = run_repeats(&p, eng, &sc, bp, pairs, &times, &st)) == 0) {
        const int level = (int)locd_engine_level(eng);
        /* The engine's buffers (about 42 bytes an object) go before the
           pairs are sorted (8 bytes a pair more): the peak stays the call's. */
        locd_engine_destroy(eng);
        eng = NULL;
        if (!(p.flags & LOCD_FIND_SORTED) && (p.out_path || p.check) && locd_pairs_sort(pairs) != LOCD_OK) {
            fprintf(stderr, "locd: pairs: cannot sort the pairs: %s\n", locd_last_error());
            rc = 1;
        }
        if (p.check && rc == 0) {
            if (cli_stderr_is_terminal() && !bp)
                fprintf(stderr, "locd: pairs: checking against the O(n^2) reference...\n");
            rc = bp ? check_between_reference(&sc, bp, pairs) : check_reference(&sc, pairs);
        }
        if (rc == 0 && p.out_path &&
            cli_write_pairs(p.out_path, locd_pairs_data(pairs), locd_pairs_count(pairs)) != 0)
            rc = 1;
        print_summary(&p, &sc, bp, level, pairs, &st, &times, rc);
    }
    times_free(&times);
    locd_pairs_destroy(pairs);
    locd_engine_destroy(eng);
    cli_free_scene(&sc);
    cli_free_scene(&b);
    return rc;
}
