/* locd pairs FILE.aabb: run the engine on a scene, print one JSON line. */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void pairs_usage(void)
{
    printf("usage: locd pairs FILE.aabb|FILE.aabb64 [options]\n"
           "  --threads K        threads (level 1; default: one per core)\n"
           "  --level L          inprocess (1), workers (2) or service (3)\n"
           "  --workers K        worker processes (implies --level workers)\n"
           "  --service ADDR     unix:PATH or tcp:HOST:PORT (implies --level service)\n"
           "  --secret S         shared secret for a TCP service\n"
           "  --out PAIRS.bin    write the pairs, sorted by (i, j), as little-endian uint32 i j rows\n"
           "  --repeat R         run R times; total_ms is the median (default 2)\n"
           "  --f64              convert a float32 scene to float64 and use the f64 entry point\n"
           "  --sorted           ask the engine for (i, j) order inside the timed call\n"
           "  --depth D          octree depth limit (default automatic)\n"
           "  --bias B           cell edge >= 2^B x box extent (default 2)\n"
           "  --cubes            encode bounding cubes (the paper's choice) instead of boxes\n"
           "  --check            also compare with the O(n^2) reference (small scenes)\n"
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

int cmd_pairs(int argc, char **argv)
{
    const char *path = NULL, *out_path = NULL;
    locd_engine_config cfg;
    locd_engine *eng = NULL;
    locd_pairs *pairs = NULL;
    locd_stats st;
    cli_scene sc;
    double *dbl = NULL;
    size_t repeat = 1, r, i;
    double *tot, *stage[7];
    uint32_t flags = 0;
    int want_f64 = 0, check = 0, rc = 0, a;
    size_t k;
    locd_status s;

    locd_engine_config_init(&cfg);
    for (a = 1; a < argc; a++) {
        const char *o = argv[a];
        int more = a + 1 < argc;
        if (!strcmp(o, "--help")) {
            pairs_usage();
            return 0;
        } else if (!strcmp(o, "--threads") && more) {
            if (cli_parse_size(argv[++a], &k) || k > 64)
                cli_die("pairs: bad --threads");
            cfg.threads = (uint32_t)k;
        } else if (!strcmp(o, "--workers") && more) {
            if (cli_parse_size(argv[++a], &k) || k > 64)
                cli_die("pairs: bad --workers");
            cfg.threads = (uint32_t)k;
            cfg.level = LOCD_LEVEL_WORKERS;
        } else if (!strcmp(o, "--level") && more) {
            cfg.level = parse_level(argv[++a]);
        } else if (!strcmp(o, "--service") && more) {
            cfg.service_address = argv[++a];
            cfg.level = LOCD_LEVEL_SERVICE;
        } else if (!strcmp(o, "--secret") && more) {
            cfg.service_secret = argv[++a];
        } else if (!strcmp(o, "--out") && more) {
            out_path = argv[++a];
        } else if (!strcmp(o, "--repeat") && more) {
            if (cli_parse_size(argv[++a], &repeat) || repeat < 1)
                cli_die("pairs: bad --repeat");
        } else if (!strcmp(o, "--depth") && more) {
            if (cli_parse_size(argv[++a], &k) || k > LOCD_MAX_DEPTH)
                cli_die("pairs: bad --depth (0..LOCD_MAX_DEPTH, 21)");
            cfg.max_depth = (uint32_t)k;
        } else if (!strcmp(o, "--bias") && more) {
            if (cli_parse_size(argv[++a], &k) || k > 8)
                cli_die("pairs: bad --bias (0..8)");
            cfg.cell_bias = (int32_t)k;
        } else if (!strcmp(o, "--cubes")) {
            cfg.flags |= LOCD_CONFIG_CUBES;
        } else if (!strcmp(o, "--f64")) {
            want_f64 = 1;
        } else if (!strcmp(o, "--sorted")) {
            flags |= LOCD_FIND_SORTED;
        } else if (!strcmp(o, "--check")) {
            check = 1;
        } else if (o[0] == '-') {
            cli_die("pairs: unknown option '%s' (see locd pairs --help)", o);
        } else if (!path) {
            path = o;
        } else {
            cli_die("pairs: unexpected argument '%s'", o);
        }
    }
    if (!path)
        cli_die("usage: locd pairs FILE.aabb [--threads K] [--out PAIRS.bin] [--repeat R]");
    if (cli_load_scene(path, &sc) != 0)
        return 1;
    if (want_f64 && !sc.f64) {
        dbl = malloc((sc.n ? sc.n : 1) * 6 * sizeof(double));
        if (!dbl)
            cli_die("pairs: out of memory");
        for (i = 0; i < 6 * sc.n; i++)
            dbl[i] = (double)sc.f[i];
        sc.d = dbl;
        sc.f64 = 1;
        free(sc.f);
        sc.f = NULL;
    }
    if ((s = locd_engine_create(&cfg, &eng)) != LOCD_OK) {
        fprintf(stderr, "locd: cannot create the engine: %s\n", locd_last_error());
        cli_free_scene(&sc);
        return 1;
    }
    if ((s = locd_pairs_create(NULL, &pairs)) != LOCD_OK)
        cli_die("pairs: %s", locd_last_error());
    tot = calloc(repeat, sizeof *tot);
    for (i = 0; i < 7; i++)
        stage[i] = calloc(repeat, sizeof(double));
    for (r = 0; r < repeat; r++) {
        s = sc.f64 ? locd_engine_find_pairs_f64(eng, sc.d, sc.n, flags, pairs)
                   : locd_engine_find_pairs_f32(eng, sc.f, sc.n, flags, pairs);
        if (s != LOCD_OK) {
            int64_t bad = locd_last_error_index();
            if (bad >= 0)
                fprintf(stderr, "locd: %s: box %lld is invalid: %s\n", path, (long long)bad, locd_status_string(s));
            else
                fprintf(stderr, "locd: %s: %s\n", path, locd_last_error());
            rc = 1;
            goto out;
        }
        locd_stats_init(&st);
        locd_engine_stats(eng, &st);
        tot[r] = st.ms_total;
        stage[0][r] = st.ms_bounds;
        stage[1][r] = st.ms_encode;
        stage[2][r] = st.ms_sort;
        stage[3][r] = st.ms_merge;
        stage[4][r] = st.ms_sweep;
        stage[5][r] = st.ms_order;
        stage[6][r] = st.ms_transfer;
    }
    if (!(flags & LOCD_FIND_SORTED) && (out_path || check))
        locd_pairs_sort(pairs);
    if (check) {
        locd_pairs *ref = NULL;
        locd_pairs_create(NULL, &ref);
        s = sc.f64 ? locd_brute_force_f64(sc.d, sc.n, ref) : locd_brute_force_f32(sc.f, sc.n, ref);
        if (s != LOCD_OK || locd_pairs_count(ref) != locd_pairs_count(pairs) ||
            !same_pairs(locd_pairs_data(ref), locd_pairs_data(pairs), locd_pairs_count(ref))) {
            fprintf(stderr, "locd: CHECK FAILED: engine %zu pairs, reference %zu pairs\n", locd_pairs_count(pairs),
                    locd_pairs_count(ref));
            rc = 3;
        }
        locd_pairs_destroy(ref);
    }
    if (out_path && cli_write_pairs(out_path, locd_pairs_data(pairs), locd_pairs_count(pairs)) != 0)
        rc = 1;
    printf("{\"n\":%zu,\"pairs\":%zu,\"level\":%d,\"threads\":%u,\"precision\":\"%s\",\"repeat\":%zu,"
           "\"total_ms\":%.3f,\"stage_ms\":{\"bounds\":%.3f,\"encode\":%.3f,\"sort\":%.3f,\"merge\":%.3f,"
           "\"sweep\":%.3f,\"order\":%.3f,\"transfer\":%.3f},\"entries\":%llu,\"candidates\":%llu,"
           "\"exact_tests\":%llu,\"depth\":%u%s}\n",
           sc.n, locd_pairs_count(pairs), (int)locd_engine_level(eng), st.threads, sc.f64 ? "f64" : "f32", repeat,
           cli_median(tot, repeat), cli_median(stage[0], repeat), cli_median(stage[1], repeat),
           cli_median(stage[2], repeat), cli_median(stage[3], repeat), cli_median(stage[4], repeat),
           cli_median(stage[5], repeat), cli_median(stage[6], repeat), (unsigned long long)st.entries,
           (unsigned long long)st.candidates, (unsigned long long)st.exact_tests, st.depth,
           check ? (rc ? ",\"check\":\"FAILED\"" : ",\"check\":\"ok\"") : "");
out:
    free(tot);
    for (i = 0; i < 7; i++)
        free(stage[i]);
    locd_pairs_destroy(pairs);
    locd_engine_destroy(eng);
    cli_free_scene(&sc);
    return rc;
}
