/* Hard inputs never break exactness (issue 8).
 *
 * Every scene below is checked against the O(n^2) brute force in the input
 * precision, through every engine the build offers: level 1 at 1, 2, 3 and 8
 * threads (scenes of >= 4096 objects, so the parallel path runs), level 2
 * (worker processes) and level 3 (a `locd serve` started here) when they are
 * available, and a few engines with other octree knobs (cubes, bias 0 and 8,
 * shallow depth). Engines with the same knobs must also return the pairs in
 * bitwise the same order (determinism is part of the contract).
 *
 * Environment: LOCD_HARD_BUDGET_MS (randomized search time, default 3000),
 * LOCD_HARD_SEED (its seed), LOCD_TEST_SERVICE ("unix:PATH" of a running
 * service to use instead of starting one), LOCD_HARD_VERBOSE=1.
 */
#include <fcntl.h>
#include <float.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "runner.h"

#include "support.h"

#ifndef LOCD_BUILD_DIR
#define LOCD_BUILD_DIR "."
#endif

/* LOCD_TEST_HEAVY=0 (the sanitizer builds, tests/README.md) shrinks the
 * scenes whose output is quadratic; everything stays >= HC_PAR objects
 * except those. */
static int heavy(void)
{
    const char *v = getenv("LOCD_TEST_HEAVY");
    return !(v && v[0] == '0');
}

/* Scenes of at least this many objects take the engine's parallel path. */
#define HC_PAR 4096

/* ------------------------------------------------------------------ */
/* Engines under test                                                 */
/* ------------------------------------------------------------------ */

typedef struct hc_runner {
    locd_engine *e;
    char name[96];
    int group; /* same knobs => the same pair order is required */
    int level;
    int light_skip; /* left out when LOCD_TEST_HEAVY=0 (its neighbours cover it) */
    locd_engine_config cfg; /* to make the engine again (trim_runners) */
} hc_runner;

#define HC_MAX_RUNNERS 16
static hc_runner runners[HC_MAX_RUNNERS];
static int nrunners;
static pid_t service_pid = -1;
static char service_dir[64], service_path[128], service_log[128];
static const char *level2_note = "not probed";
static const char *level3_note = "not probed";
static int verbose;
static locd_engine_config last_cfg; /* of the last make_engine call */

static locd_engine *make_engine(int level, uint32_t threads, int32_t bias, uint32_t depth, uint32_t flags,
                                const char *worker_path, const char *address, locd_status *st_out)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_status st;
    locd_engine_config_init(&cfg);
    cfg.level = level;
    cfg.threads = threads;
    cfg.cell_bias = bias;
    cfg.max_depth = depth;
    cfg.flags = flags;
    cfg.worker_path = worker_path;
    cfg.service_address = address;
    st = locd_engine_create(&cfg, &e);
    if (st_out)
        *st_out = st;
    last_cfg = cfg;
    return st ? NULL : e;
}

static void add_runner(locd_engine *e, int group, int level, const char *fmt, ...)
{
    va_list ap;
    hc_runner *r;
    if (!e)
        return;
    if (nrunners >= HC_MAX_RUNNERS) {
        locd_engine_destroy(e);
        return;
    }
    r = &runners[nrunners++];
    r->e = e;
    r->cfg = last_cfg; /* strings are static or owned by the probes */
    r->group = group;
    r->level = level;
    va_start(ap, fmt);
    vsnprintf(r->name, sizeof r->name, fmt, ap);
    va_end(ap);
}

/* Level 2 needs the worker executable: the installed default, else the
 * build tree's. */
static void probe_level2(void)
{
    static const char *paths[] = {NULL, LOCD_BUILD_DIR "/tools/locd-worker", LOCD_BUILD_DIR "/lib/locd-worker",
                                  LOCD_BUILD_DIR "/locd-worker"};
    static char note[256];
    size_t i;
    locd_status st = LOCD_ERR_UNSUPPORTED;
    for (i = 0; i < sizeof paths / sizeof paths[0]; i++) {
        locd_engine *e;
        if (paths[i] && access(paths[i], X_OK) != 0)
            continue;
        e = make_engine(LOCD_LEVEL_WORKERS, 2, 1, 0, 0, paths[i], NULL, &st);
        if (e) {
            add_runner(e, 0, 2, "level 2, 2 workers");
            add_runner(make_engine(LOCD_LEVEL_WORKERS, 3, 1, 0, 0, paths[i], NULL, NULL), 0, 2,
                       "level 2, 3 workers");
            snprintf(note, sizeof note, "level 2 tested (worker %s)", paths[i] ? paths[i] : "default");
            level2_note = note;
            return;
        }
    }
    snprintf(note, sizeof note, "level 2 unavailable: %s (%s)", locd_status_string(st), locd_last_error());
    level2_note = note;
}

/* Level 3: a service named by LOCD_TEST_SERVICE, else one started here. */
static void probe_level3(void)
{
    static char note[300], addr[160];
    const char *given = getenv("LOCD_TEST_SERVICE");
    locd_status st = LOCD_ERR_UNSUPPORTED;
    locd_engine *e = NULL;
    int tries;
    if (given && *given) {
        snprintf(addr, sizeof addr, "%s", given);
    } else {
        const char *exe = LOCD_BUILD_DIR "/tools/locd";
        if (access(exe, X_OK) != 0) {
            level3_note = "level 3 unavailable: no locd executable in the build tree";
            return;
        }
        /* The service wants a private (0700) socket directory: mkdtemp's. */
        snprintf(service_dir, sizeof service_dir, "/tmp/locd-hard-XXXXXX");
        if (!mkdtemp(service_dir)) {
            level3_note = "level 3 unavailable: mkdtemp failed";
            return;
        }
        snprintf(service_path, sizeof service_path, "%s/s.sock", service_dir);
        snprintf(addr, sizeof addr, "unix:%s", service_path);
        snprintf(service_log, sizeof service_log, "%s/serve.log", service_dir);
        service_pid = fork();
        if (service_pid == 0) {
            int fd = open(service_log, O_WRONLY | O_CREAT | O_TRUNC, 0600);
            prctl(PR_SET_PDEATHSIG, SIGKILL); /* a crashed test leaves no service behind */
            if (fd >= 0) {
                dup2(fd, 1);
                dup2(fd, 2);
            }
            execl(exe, "locd", "serve", "--listen", addr, (char *)NULL);
            _exit(127);
        }
    }
    for (tries = 0; tries < 200 && !e; tries++) { /* up to 10 s on a busy machine */
        int status;
        e = make_engine(LOCD_LEVEL_SERVICE, 2, 1, 0, 0, NULL, addr, &st);
        if (e)
            break;
        if (service_pid > 0 && waitpid(service_pid, &status, WNOHANG) == service_pid) {
            service_pid = -1;
            break; /* the service exited: `locd serve` is not implemented */
        }
        usleep(50000);
    }
    if (!e) {
        snprintf(note, sizeof note, "level 3 unavailable: %s (%s)", locd_status_string(st), locd_last_error());
        level3_note = note;
        if (service_pid > 0) {
            kill(service_pid, SIGTERM);
            waitpid(service_pid, NULL, 0);
            service_pid = -1;
        }
        if (service_dir[0]) {
            unlink(service_path);
            unlink(service_log);
            rmdir(service_dir);
        }
        return;
    }
    add_runner(e, 0, 3, "level 3, %s", addr);
    snprintf(note, sizeof note, "level 3 tested (%s)", addr);
    level3_note = note;
}

static int group_setup(void)
{
    static const uint32_t threads[] = {1, 2, 3, 8};
    size_t i;
    verbose = getenv("LOCD_HARD_VERBOSE") != NULL;
    for (i = 0; i < 4; i++)
        add_runner(make_engine(LOCD_LEVEL_INPROCESS, threads[i], 1, 0, 0, NULL, NULL, NULL), 0, 1,
                   "level 1, %u threads", threads[i]);
    if (nrunners != 4)
        return -1;
    /* The octree's knobs change the work and the order, never the set. */
    add_runner(make_engine(1, 1, 0, 0, LOCD_CONFIG_CUBES, NULL, NULL, NULL), 1, 1, "level 1, 1 thread, cubes, bias 0");
    add_runner(make_engine(1, 3, 0, 0, LOCD_CONFIG_CUBES, NULL, NULL, NULL), 1, 1, "level 1, 3 threads, cubes, bias 0");
    add_runner(make_engine(1, 1, 8, 3, 0, NULL, NULL, NULL), 2, 1, "level 1, 1 thread, bias 8, depth 3");
    add_runner(make_engine(1, 8, 8, 3, 0, NULL, NULL, NULL), 2, 1, "level 1, 8 threads, bias 8, depth 3");
    add_runner(make_engine(1, 2, 3, 21, LOCD_CONFIG_CUBES, NULL, NULL, NULL), 3, 1,
               "level 1, 2 threads, cubes, bias 3, depth 21");
    /* The light run (sanitizers) keeps one engine per group of knobs
       besides 1, 3 and 8 threads and the other levels. */
    runners[1].light_skip = 1; /* 2 threads */
    runners[4].light_skip = 1; /* cubes, 1 thread */
    runners[6].light_skip = 1; /* bias 8, 1 thread */
    add_runner(make_engine(1, 3, 0, 1, 0, NULL, NULL, NULL), 4, 1, "level 1, 3 threads, bias 0, depth 1");
    probe_level2();
    probe_level3();
    LT_PRINT("# %s\n# %s\n", level2_note, level3_note);
    return 0;
}

/* The started service's own output, when a level-3 call fails. */
static void print_service_log(void)
{
    char line[512];
    FILE *f = service_log[0] ? fopen(service_log, "r") : NULL;
    int status;
    if (service_pid > 0 && waitpid(service_pid, &status, WNOHANG) == service_pid) {
        LT_PRINT("locd serve exited: %s %d\n", WIFSIGNALED(status) ? "signal" : "status",
                 WIFSIGNALED(status) ? WTERMSIG(status) : WEXITSTATUS(status));
        service_pid = -1;
    }
    if (!f)
        return;
    LT_PRINT("---- %s ----\n", service_log);
    while (fgets(line, sizeof line, f))
        LT_PRINT("%s", line);
    fclose(f);
}

/* Engines keep their buffers' capacity between calls (that is the point
 * of reusing one); after a test with millions of pairs, start them afresh
 * so that a dozen engines do not each hold hundreds of megabytes. */
static void trim_runners(void)
{
    int i;
    for (i = 0; i < nrunners; i++) {
        locd_engine *e = NULL;
        locd_engine_destroy(runners[i].e);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&runners[i].cfg, &e));
        runners[i].e = e;
    }
}

static void group_teardown(void)
{
    int i;
    for (i = 0; i < nrunners; i++)
        locd_engine_destroy(runners[i].e);
    nrunners = 0;
    if (service_pid > 0) {
        kill(service_pid, SIGTERM);
        waitpid(service_pid, NULL, 0);
    }
    if (service_dir[0]) {
        unlink(service_path);
        unlink(service_log);
        rmdir(service_dir);
    }
}

/* ------------------------------------------------------------------ */
/* Comparing pair sets                                                */
/* ------------------------------------------------------------------ */

/* Pairs as sorted uint64 keys (i << 32 | j): an independent LSD radix sort
 * so that million-pair outputs compare fast. */
static uint64_t *sorted_keys(const uint32_t *p, size_t m)
{
    uint64_t *a = malloc((m ? m : 1) * sizeof *a), *b = malloc((m ? m : 1) * sizeof *b), *t;
    size_t k, pass;
    TEST_ASSERT_NOT_NULL(a);
    TEST_ASSERT_NOT_NULL(b);
    for (k = 0; k < m; k++)
        a[k] = ((uint64_t)p[2 * k] << 32) | p[2 * k + 1];
    for (pass = 0; pass < 4; pass++) {
        size_t cnt[65537] = {0};
        unsigned sh = (unsigned)(16 * pass);
        for (k = 0; k < m; k++)
            cnt[((a[k] >> sh) & 0xffff) + 1]++;
        if (cnt[((a[0] >> sh) & 0xffff) + 1] == m)
            continue; /* every key has the same digit */
        for (k = 1; k <= 65536; k++)
            cnt[k] += cnt[k - 1];
        for (k = 0; k < m; k++)
            b[cnt[(a[k] >> sh) & 0xffff]++] = a[k];
        t = a;
        a = b;
        b = t;
    }
    free(b);
    return a;
}

static void print_box(const char *tag, const double *b, uint32_t i)
{
    LT_PRINT("  %s box %u: [%.17g %.17g %.17g] - [%.17g %.17g %.17g]\n", tag, i, b[6 * i], b[6 * i + 1],
             b[6 * i + 2], b[6 * i + 3], b[6 * i + 4], b[6 * i + 5]);
}

/* Reports the first difference between two sorted key arrays. */
static void explain_difference(const uint64_t *ref, size_t mr, const uint64_t *got, size_t mg, const double *wide)
{
    size_t a = 0, b = 0;
    while (a < mr || b < mg) {
        if (b >= mg || (a < mr && ref[a] < got[b])) {
            LT_PRINT("  missing pair (%u, %u)\n", (uint32_t)(ref[a] >> 32), (uint32_t)ref[a]);
            print_box("", wide, (uint32_t)(ref[a] >> 32));
            print_box("", wide, (uint32_t)ref[a]);
            return;
        }
        if (a >= mr || got[b] < ref[a]) {
            LT_PRINT("  extra or duplicate pair (%u, %u)\n", (uint32_t)(got[b] >> 32), (uint32_t)got[b]);
            print_box("", wide, (uint32_t)(got[b] >> 32));
            print_box("", wide, (uint32_t)got[b]);
            return;
        }
        a++;
        b++;
    }
}

typedef locd_status (*hc_find_fn)(locd_engine *, const void *, size_t, uint32_t, locd_pairs *);
static locd_status find32(locd_engine *e, const void *b, size_t n, uint32_t f, locd_pairs *p)
{
    return locd_engine_find_pairs_f32(e, b, n, f, p);
}
static locd_status find64(locd_engine *e, const void *b, size_t n, uint32_t f, locd_pairs *p)
{
    return locd_engine_find_pairs_f64(e, b, n, f, p);
}

static double *widen(const float *b, size_t n)
{
    double *d = malloc((n ? n : 1) * 6 * sizeof *d);
    size_t k;
    TEST_ASSERT_NOT_NULL(d);
    for (k = 0; k < 6 * n; k++)
        d[k] = (double)b[k];
    return d;
}

static float *narrow(const double *b, size_t n)
{
    float *f = malloc((n ? n : 1) * 6 * sizeof *f);
    size_t k;
    TEST_ASSERT_NOT_NULL(f);
    for (k = 0; k < 6 * n; k++)
        f[k] = (float)b[k]; /* round to nearest: monotone, so min <= max stays true */
    return f;
}

/* The brute-force answer in the input precision, as sorted keys. */
static uint64_t *reference(const void *boxes, size_t n, int f64, size_t *m)
{
    locd_pairs *ref;
    uint64_t *k;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &ref));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, f64 ? locd_brute_force_f64(boxes, n, ref) : locd_brute_force_f32(boxes, n, ref));
    *m = locd_pairs_count(ref);
    k = sorted_keys(locd_pairs_data(ref), *m);
    locd_pairs_destroy(ref);
    return k;
}

/* How many runners of the list to use: small scenes run on one thread in
 * every level-1 engine, so one engine per group and level is enough. */
static int runner_wanted(int r, size_t n)
{
    int q;
    if (!heavy() && runners[r].light_skip)
        return 0;
    if (n >= HC_PAR)
        return 1;
    for (q = 0; q < r; q++)
        if (runners[q].group == runners[r].group && runners[q].level == runners[r].level)
            return 0;
    return 1;
}

/* Every engine against the reference; the same pair order within a group.
 * Returns the number of pairs. */
static size_t check_scene(const void *boxes, size_t n, int f64, const char *what)
{
    size_t m, r;
    uint64_t *ref = reference(boxes, n, f64, &m);
    double *wide = f64 ? (double *)boxes : widen(boxes, n);
    uint32_t *first_order[8] = {0};
    size_t first_count[8] = {0};
    locd_pairs *p;
    hc_find_fn find = f64 ? find64 : find32;
    int failed = 0;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    for (r = 0; r < (size_t)nrunners; r++) {
        const hc_runner *R = &runners[r];
        locd_status st;
        size_t c;
        uint64_t *got;
        if (!runner_wanted((int)r, n))
            continue;
        st = find(R->e, boxes, n, 0, p);
        if (st != LOCD_OK && R->level == 3)
            print_service_log();
        if (st != LOCD_OK)
            LT_FAIL("%s (%s, n %zu, %s): status %d %s: %s", what, f64 ? "f64" : "f32", n, R->name, st,
                    locd_status_string(st), locd_last_error());
        c = locd_pairs_count(p);
        if (first_order[R->group]) {
            /* The same bytes as the group's first engine (already checked
               against the brute force): nothing more to compare. */
            if (c == first_count[R->group] &&
                (!c || !memcmp(first_order[R->group], locd_pairs_data(p), c * 2 * sizeof(uint32_t))))
                continue;
            LT_PRINT("%s (%s, n %zu, %s): pair order differs from the first engine of its group\n", what,
                     f64 ? "f64" : "f32", n, R->name);
            failed = 1;
        }
        got = sorted_keys(locd_pairs_data(p), c);
        if (c != m || (m && memcmp(got, ref, m * sizeof *ref) != 0)) {
            LT_PRINT("%s (%s, n %zu, %s): %zu pairs, brute force %zu\n", what, f64 ? "f64" : "f32", n, R->name, c,
                     m);
            explain_difference(ref, m, got, c, wide);
            failed = 1;
        }
        free(got);
        if (!first_order[R->group]) {
            first_order[R->group] = malloc((c ? c : 1) * 2 * sizeof(uint32_t));
            TEST_ASSERT_NOT_NULL(first_order[R->group]);
            if (c)
                memcpy(first_order[R->group], locd_pairs_data(p), c * 2 * sizeof(uint32_t));
            first_count[R->group] = c;
        }
    }
    /* The sorted variant is exactly the brute force's (i, j) order. */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, find(runners[nrunners > 2 ? 2 : 0].e, boxes, n, LOCD_FIND_SORTED, p));
    if (locd_pairs_count(p) != m) {
        failed = 1;
    } else {
        const uint32_t *d = locd_pairs_data(p);
        for (r = 0; r < m; r++)
            if (((uint64_t)d[2 * r] << 32 | d[2 * r + 1]) != ref[r]) {
                LT_PRINT("%s: LOCD_FIND_SORTED order differs at %zu\n", what, r);
                failed = 1;
                break;
            }
    }
    for (r = 0; r < 8; r++)
        free(first_order[r]);
    locd_pairs_destroy(p);
    free(ref);
    if (!f64)
        free(wide);
    if (failed)
        LT_FAIL("%s: engine results differ from brute force (details above)", what);
    if (verbose)
        LT_PRINT("# %s (%s): n %zu, %zu pairs\n", what, f64 ? "f64" : "f32", n, m);
    return m;
}

static size_t check_f32(const float *b, size_t n, const char *what)
{
    return check_scene(b, n, 0, what);
}

static size_t check_f64(const double *b, size_t n, const char *what)
{
    return check_scene(b, n, 1, what);
}

/* A float32 scene, then the same values through the float64 entry point
 * (the round trip through float64 is exact and must give the same pairs). */
static void check_both(const float *b, size_t n, const char *what)
{
    double *d = widen(b, n);
    size_t m32 = check_f32(b, n, what), m64 = heavy() ? check_f64(d, n, what) : m32;
    locd_pairs *p32, *p64;
    TEST_ASSERT_EQUAL_INT64(m64, m32);
    /* docs/encoding.md: the same values give the same order in either precision. */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p32));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p64));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(runners[2].e, b, n, 0, p32));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f64(runners[2].e, d, n, 0, p64));
    if (m32 && memcmp(locd_pairs_data(p32), locd_pairs_data(p64), m32 * 2 * sizeof(uint32_t)))
        LT_FAIL("%s: float32 and float64 input of the same values give different pair orders", what);
    locd_pairs_destroy(p32);
    locd_pairs_destroy(p64);
    free(d);
}

/* ------------------------------------------------------------------ */
/* Scene building                                                     */
/* ------------------------------------------------------------------ */

typedef struct sc {
    double *b;
    size_t n, cap;
} sc;

static void sc_add(sc *s, double x0, double y0, double z0, double x1, double y1, double z1)
{
    if (s->n == s->cap) {
        s->cap = s->cap ? 2 * s->cap : 1024;
        s->b = realloc(s->b, s->cap * 6 * sizeof(double));
        TEST_ASSERT_NOT_NULL(s->b);
    }
    s->b[6 * s->n + 0] = x0;
    s->b[6 * s->n + 1] = y0;
    s->b[6 * s->n + 2] = z0;
    s->b[6 * s->n + 3] = x1;
    s->b[6 * s->n + 4] = y1;
    s->b[6 * s->n + 5] = z1;
    s->n++;
}

static void sc_free(sc *s)
{
    free(s->b);
    memset(s, 0, sizeof *s);
}

static uint64_t rnd(ts_rng *r, uint64_t k)
{
    return k ? ts_next(r) % k : 0;
}

/* Boxes whose faces are drawn from sorted per-axis value tables: any two
 * boxes sharing a table value touch exactly there. span is the largest
 * number of table steps a box covers (0 = points). */
static void add_table_boxes(sc *s, ts_rng *r, size_t count, const double *vals, size_t nv, size_t span)
{
    size_t i;
    int a;
    for (i = 0; i < count; i++) {
        double lo[3], hi[3];
        for (a = 0; a < 3; a++) {
            size_t i0 = (size_t)rnd(r, nv), i1 = i0 + (size_t)rnd(r, span + 1);
            if (i1 >= nv)
                i1 = nv - 1;
            lo[a] = vals[i0];
            hi[a] = vals[i1];
        }
        sc_add(s, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    }
}

/* Table of nv values starting at x0, each the next representable float
 * (or double) after the previous: a lattice in units of the local ulp. */
static void ulp_table_f32(double *v, size_t nv, float x0)
{
    size_t k;
    float x = x0;
    for (k = 0; k < nv; k++) {
        v[k] = x;
        x = nextafterf(x, INFINITY);
    }
}

static void ulp_table_f64(double *v, size_t nv, double x0)
{
    size_t k;
    double x = x0;
    for (k = 0; k < nv; k++) {
        v[k] = x;
        x = nextafter(x, INFINITY);
    }
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* ------------------------------------------------------------------ */
/* 1. Touching faces, edges and corners                               */
/* ------------------------------------------------------------------ */

static void lattice(sc *s, int m, int parity_mode, double step, double size)
{
    int x, y, z;
    for (z = 0; z < m; z++)
        for (y = 0; y < m; y++)
            for (x = 0; x < m; x++) {
                if (parity_mode == 1 && (x + y + z) % 2) /* checkerboard: edges, no faces */
                    continue;
                if (parity_mode == 2 && !((x % 2 == y % 2) && (y % 2 == z % 2))) /* corners only */
                    continue;
                sc_add(s, x * step, y * step, z * step, x * step + size, y * step + size, z * step + size);
            }
}

static void touching_faces_edges_corners(void)
{
    static const struct {
        int m, mode;
        const char *name;
    } cases[] = {{16, 0, "unit lattice: faces, edges, corners"},
                 {21, 1, "checkerboard: edges and corners only"},
                 {26, 2, "corners only"}};
    size_t c;
    for (c = 0; c < 3; c++) {
        sc s = {0};
        float *f;
        lattice(&s, cases[c].m, cases[c].mode, 1.0, 1.0);
        TEST_ASSERT_TRUE(s.n >= HC_PAR);
        f = narrow(s.b, s.n);
        check_both(f, s.n, cases[c].name);
        free(f);
        sc_free(&s);
    }
}

/* Non-dyadic coordinates: faces meet at values like 0.1 * k, exact in the
 * input precision but not in binary. */
static void touching_at_decimal_values(void)
{
    double v64[48], v32[48], back[48];
    ts_rng r;
    size_t k;
    sc s = {0};
    float *f;
    double *d;
    for (k = 0; k < 48; k++) {
        v64[k] = (double)k * 0.1 - 2.3;
        v32[k] = (float)((float)k * 0.1f - 2.3f);
        back[k] = (double)(float)v64[k]; /* double -> float -> double */
    }
    qsort(v32, 48, sizeof(double), cmp_double);
    ts_seed(&r, 11);
    add_table_boxes(&s, &r, 5000, v64, 48, 2);
    check_f64(s.b, s.n, "decimal faces, float64");
    /* The same scene rounded to float32: touching faces still touch. */
    f = narrow(s.b, s.n);
    check_both(f, s.n, "decimal faces rounded to float32 (and back to float64)");
    free(f);
    sc_free(&s);
    ts_seed(&r, 12);
    add_table_boxes(&s, &r, 5000, v32, 48, 3);
    f = narrow(s.b, s.n);
    check_both(f, s.n, "decimal faces computed in float32");
    free(f);
    sc_free(&s);
    ts_seed(&r, 13);
    add_table_boxes(&s, &r, 5000, back, 48, 1);
    d = s.b;
    check_f64(d, s.n, "float64 -> float32 -> float64 round trip");
    sc_free(&s);
}

/* ------------------------------------------------------------------ */
/* 2. Faces on octree cell boundaries, at every level                 */
/* ------------------------------------------------------------------ */

/* The root cube is fitted to the scene: with the scene spanning exactly
 * [lo, lo + S] on its widest axis, the fraction j / 2^L of S is a cell
 * boundary of level L. Boxes get faces on such fractions for every L. */
static void cell_boundary_scene(sc *s, ts_rng *r, size_t count, double lo, double S, int maxL, double yshrink)
{
    size_t i;
    int a;
    sc_add(s, lo, lo, lo, lo, lo, lo);                      /* pins the root cube's low corner */
    sc_add(s, lo + S, lo + S * yshrink, lo + S, lo + S, lo + S * yshrink, lo + S); /* ... and its far corner */
    for (i = 2; i < count; i++) {
        double bl[3], bh[3];
        for (a = 0; a < 3; a++) {
            int L = (int)rnd(r, (uint64_t)maxL + 1);
            double frac = a == 1 ? yshrink : 1.0; /* the axis spans frac * S */
            double cell = ldexp(S, -L), ext = frac * S;
            uint64_t ncell = (uint64_t)ldexp(frac, L); /* whole cells of level L on the axis */
            uint64_t j = rnd(r, ncell + 1), w = rnd(r, 3);
            bl[a] = lo + (double)j * cell;
            bh[a] = lo + (double)(j + w) * cell;
            if (bh[a] > lo + ext)
                bh[a] = lo + ext;
        }
        sc_add(s, bl[0], bl[1], bl[2], bh[0], bh[1], bh[2]);
    }
}

static void faces_on_cell_boundaries(void)
{
    static const struct {
        double lo, S;
        int maxL;
        double yshrink;
        int f32;
        const char *name;
    } cases[] = {
        {0.0, 2097152.0, 21, 1.0, 1, "float32, root [0, 2^21], levels 0..21"},
        {-1048576.0, 2097152.0, 21, 0.25, 1, "float32, root [-2^20, 2^20], flat y, levels 0..21"},
        {6291456.0, 2097152.0, 21, 1.0, 1, "float32, root [3*2^21, 4*2^21], levels 0..21"},
        {0.0, 1.0, 40, 1.0, 0, "float64, root [0, 1], levels 0..40"},
        {-3.0, 4.0, 30, 0.5, 0, "float64, root [-3, 1], flat y, levels 0..30"},
        {1e6, 1024.0, 45, 1.0, 0, "float64, root [1e6, 1e6 + 1024], levels 0..45"},
    };
    size_t c;
    for (c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        sc s = {0};
        ts_rng r;
        ts_seed(&r, 100 + c);
        cell_boundary_scene(&s, &r, 6000, cases[c].lo, cases[c].S, cases[c].maxL, cases[c].yshrink);
        if (cases[c].f32) {
            float *f = narrow(s.b, s.n);
            size_t k;
            for (k = 0; k < 6 * s.n; k++) /* the fractions are exact in float32 */
                TEST_ASSERT_TRUE((double)f[k] == s.b[k]);
            check_both(f, s.n, cases[c].name);
            free(f);
        } else {
            check_f64(s.b, s.n, cases[c].name);
        }
        sc_free(&s);
    }
}

/* ------------------------------------------------------------------ */
/* 3. Far from the origin, and scaled down                            */
/* ------------------------------------------------------------------ */

static void translated_far_from_origin(void)
{
    static const double offsets[] = {1e3, 1e6, 1e10, 1e20, 1e30, -1e30, -1e7};
    size_t c;
    /* The light run (sanitizers) takes every third offset: 1e3, 1e20, -1e7. */
    for (c = 0; c < sizeof offsets / sizeof offsets[0]; c += heavy() ? 1 : 3) {
        double v[40];
        char name[96];
        sc s = {0};
        ts_rng r;
        float *f;
        size_t k;
        /* A lattice in float32 ulp steps at the offset: exact touching there. */
        ts_seed(&r, 200 + c);
        ulp_table_f32(v, 40, (float)offsets[c]);
        add_table_boxes(&s, &r, 4500, v, 40, 3);
        f = narrow(s.b, s.n);
        snprintf(name, sizeof name, "float32 ulp lattice at %g", offsets[c]);
        check_both(f, s.n, name);
        free(f);
        sc_free(&s);
        /* The same in float64 ulp steps. */
        ts_seed(&r, 300 + c);
        ulp_table_f64(v, 40, offsets[c]);
        add_table_boxes(&s, &r, 4500, v, 40, 3);
        snprintf(name, sizeof name, "float64 ulp lattice at %g", offsets[c]);
        check_f64(s.b, s.n, name);
        sc_free(&s);
        /* A unit-size scene moved there: coordinates round, whatever they
           round to is the input the answer must follow. */
        {
            /* Past ~1e7 (float32) or ~1e15 (float64) the unit scene collapses
               to a few points: every pair overlaps, so keep those small. */
            const size_t m = fabs(offsets[c]) < 1e7 ? 4200 : 600;
            float *u = ts_scene(2, m, 400 + c);
            double *d = widen(u, m);
            for (k = 0; k < 6 * m; k++)
                d[k] += offsets[c];
            snprintf(name, sizeof name, "mixed scene + %g, float64", offsets[c]);
            check_f64(d, m, name);
            f = narrow(d, m);
            snprintf(name, sizeof name, "mixed scene + %g, rounded to float32", offsets[c]);
            check_both(f, m, name);
            free(f);
            free(d);
            free(u);
        }
    }
}

static void scaled_down_to_1e_30(void)
{
    static const double scales[] = {1e-30, 0x1p-100, 1e-300};
    size_t c, k;
    for (c = 0; c < 3; c += heavy() ? 1 : 2) { /* light run: 1e-30 and 1e-300 */
        sc s = {0};
        char name[96];
        float *u = ts_scene(3, 4200, 500 + c); /* touching unit lattice */
        double *d = widen(u, 4200);
        lattice(&s, 16, 0, 1.0, 1.0);
        for (k = 0; k < 6 * s.n; k++)
            s.b[k] *= scales[c];
        for (k = 0; k < 6 * 4200; k++)
            d[k] = d[k] * scales[c] + 3.0 * scales[c];
        snprintf(name, sizeof name, "lattice scaled by %g, float64", scales[c]);
        check_f64(s.b, s.n, name);
        check_f64(d, 4200, name);
        if (scales[c] > 1e-35) {
            float *f = narrow(s.b, s.n), *g = narrow(d, 4200);
            snprintf(name, sizeof name, "lattice scaled by %g, float32", scales[c]);
            check_both(f, s.n, name);
            check_both(g, 4200, name);
            free(f);
            free(g);
        }
        free(d);
        free(u);
        sc_free(&s);
    }
}

/* ------------------------------------------------------------------ */
/* 4. Near the largest finite values: max - min overflows             */
/* ------------------------------------------------------------------ */

static void extent_overflows(void)
{
    double v[24];
    size_t k;
    ts_rng r;
    sc s = {0};
    float *f;
    /* float32: +-FLT_MAX and their neighbours, and a few ordinary values. */
    {
        float x = -FLT_MAX, y = FLT_MAX;
        for (k = 0; k < 8; k++) {
            v[k] = x;
            v[23 - k] = y;
            x = nextafterf(x, 0.0f);
            y = nextafterf(y, 0.0f);
        }
        v[8] = -1e30;
        v[9] = -1.0;
        v[10] = -0.0;
        v[11] = 0.0;
        v[12] = 1e-30;
        v[13] = 1.0;
        v[14] = 3.0e38;
        v[15] = 3.1e38;
        qsort(v, 24, sizeof(double), cmp_double);
    }
    ts_seed(&r, 600);
    add_table_boxes(&s, &r, 4400, v, 24, 4);
    sc_add(&s, -FLT_MAX, -FLT_MAX, -FLT_MAX, FLT_MAX, FLT_MAX, FLT_MAX); /* contains everything */
    f = narrow(s.b, s.n);
    check_both(f, s.n, "float32 near +-FLT_MAX");
    free(f);
    sc_free(&s);
    /* float64: +-DBL_MAX; here even max/2 - min/2 is the largest double. */
    {
        double x = -DBL_MAX, y = DBL_MAX;
        for (k = 0; k < 8; k++) {
            v[k] = x;
            v[23 - k] = y;
            x = nextafter(x, 0.0);
            y = nextafter(y, 0.0);
        }
        v[8] = -1e300;
        v[9] = -FLT_MAX;
        v[10] = -0.0;
        v[11] = 0.0;
        v[12] = 1e-300;
        v[13] = FLT_MAX;
        v[14] = 1e307;
        v[15] = 1.7e308;
        qsort(v, 24, sizeof(double), cmp_double);
    }
    ts_seed(&r, 601);
    add_table_boxes(&s, &r, 4400, v, 24, 4);
    check_f64(s.b, s.n, "float64 near +-DBL_MAX");
    /* One axis spans everything, the others are ordinary. */
    for (k = 0; k < s.n; k++) {
        s.b[6 * k + 1] = s.b[6 * k + 4] = (double)(k % 7);
        s.b[6 * k + 2] = (double)(k % 5);
        s.b[6 * k + 5] = (double)(k % 5) + 1.0;
    }
    check_f64(s.b, s.n, "float64 near +-DBL_MAX on x only");
    sc_free(&s);
}

/* ------------------------------------------------------------------ */
/* 5. Points, identical boxes, one box containing all                 */
/* ------------------------------------------------------------------ */

static void points_and_zero_size_boxes(void)
{
    sc s = {0};
    ts_rng r;
    size_t i;
    float *f;
    ts_seed(&r, 700);
    /* Points on an integer lattice (some repeated), next to unit cubes with
       corners and faces on the same lattice. */
    for (i = 0; i < 3000; i++) {
        double x = (double)rnd(&r, 12), y = (double)rnd(&r, 12), z = (double)rnd(&r, 12);
        sc_add(&s, x, y, z, x, y, z);
    }
    for (i = 0; i < 1500; i++) {
        double x = (double)rnd(&r, 12), y = (double)rnd(&r, 12), z = (double)rnd(&r, 12);
        sc_add(&s, x, y, z, x + 1, y + 1, z + 1);
    }
    for (i = 0; i < 300; i++) { /* zero-thickness plates and sticks */
        double x = (double)rnd(&r, 12), y = (double)rnd(&r, 12), z = (double)rnd(&r, 12);
        if (i % 2)
            sc_add(&s, x, y, z, x + 2, y + 1, z);
        else
            sc_add(&s, x, y, z, x, y, z + 3);
    }
    f = narrow(s.b, s.n);
    check_both(f, s.n, "points, plates, sticks and cubes on a lattice");
    free(f);
    sc_free(&s);
}

static void many_identical_boxes(void)
{
    const size_t n = heavy() ? 4100 : 1500; /* n(n-1)/2 pairs */
    sc s = {0};
    size_t i, m;
    float *f;
    for (i = 0; i < n; i++)
        sc_add(&s, 0.25, -0.5, 3.0, 0.75, 0.5, 3.125);
    f = narrow(s.b, n);
    m = check_f32(f, n, "identical boxes");
    TEST_ASSERT_EQUAL_INT64(n * (n - 1) / 2, m);
    free(f);
    /* Identical boxes among ordinary ones. */
    {
        float *u = ts_scene(0, n, 701);
        for (i = 0; i < n; i += 3)
            memcpy(u + 6 * i, u + 6 * 7, 6 * sizeof(float));
        check_both(u, n, "every third box identical");
        free(u);
    }
    sc_free(&s);
    trim_runners();
}

static void one_box_contains_all(void)
{
    const size_t n = 4500;
    size_t at;
    for (at = 0; at < n; at += 2249) { /* first, middle, last */
        float *u = ts_scene(2, n, 702 + at);
        float big[6] = {-1, -1, -1, 2, 2, 2};
        size_t m;
        memcpy(u + 6 * at, big, sizeof big);
        m = check_f32(u, n, "one box containing all");
        TEST_ASSERT_TRUE(m >= n - 1);
        /* The container exactly equal to the scene's bounds. */
        {
            float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
            size_t i;
            int a;
            for (i = 0; i < n; i++)
                if (i != at)
                    for (a = 0; a < 3; a++) {
                        lo[a] = u[6 * i + a] < lo[a] ? u[6 * i + a] : lo[a];
                        hi[a] = u[6 * i + 3 + a] > hi[a] ? u[6 * i + 3 + a] : hi[a];
                    }
            for (a = 0; a < 3; a++) {
                u[6 * at + a] = lo[a];
                u[6 * at + 3 + a] = hi[a];
            }
            check_both(u, n, "one box equal to the scene's bounds");
        }
        free(u);
    }
}

/* ------------------------------------------------------------------ */
/* 6. Degenerate worlds: one plane, one line, one point               */
/* ------------------------------------------------------------------ */

static void degenerate_worlds(void)
{
    const size_t n = 4100, npoint = heavy() ? 4100 : 1500; /* the point world has n(n-1)/2 pairs */
    int kind, axis;
    for (kind = 0; kind < 3; kind++)
        for (axis = 0; axis < (kind == 2 || heavy() ? 3 : 1); axis++) { /* light run: axis 0 only */
            const size_t m = kind == 2 ? npoint : n;
            float *u = ts_scene(kind == 2 ? 0 : 2, m, 800 + 3 * (size_t)kind + (size_t)axis);
            size_t i;
            char name[80];
            for (i = 0; i < m; i++) {
                int a;
                for (a = 0; a < 3; a++) {
                    /* kind 0: all on the plane x_axis = 0.5; 1: on a line; 2: one point */
                    int flat = kind == 0 ? a == axis : kind == 1 ? a != axis : 1;
                    if (flat)
                        u[6 * i + a] = u[6 * i + 3 + a] = (kind == 2 && axis == 1) ? -1e20f : 0.5f;
                }
            }
            if (kind == 2 && axis == 2) { /* point worlds: 0.5 (axis 0) and -1e20 (axis 1) are enough */
                free(u);
                continue;
            }
            snprintf(name, sizeof name, "%s world (axis %d)", kind == 0 ? "plane" : kind == 1 ? "line" : "point",
                     axis);
            if (kind == 2) {
                TEST_ASSERT_EQUAL_INT64(m * (m - 1) / 2, check_f32(u, m, name));
            } else {
                check_both(u, m, name);
            }
            free(u);
        }
    trim_runners();
}

/* ------------------------------------------------------------------ */
/* 7. Huge next to tiny: twelve orders of magnitude                   */
/* ------------------------------------------------------------------ */

static void sizes_span_twelve_orders(void)
{
    const size_t n = 5000;
    sc s = {0};
    ts_rng r;
    size_t i;
    float *f;
    ts_seed(&r, 900);
    for (i = 0; i < n; i++) {
        double e = pow(10.0, 12.0 * ts_uniform(&r) - 6.0); /* 1e-6 .. 1e6 */
        double x = 1e6 * ts_uniform(&r), y = 1e6 * ts_uniform(&r), z = 1e6 * ts_uniform(&r);
        if (i % 50 == 0) { /* tiny boxes stuck to a huge one's face */
            x = 5e5;
            e = 1e-6;
        }
        sc_add(&s, x, y, z, x + e * (0.5 + ts_uniform(&r)), y + e * (0.5 + ts_uniform(&r)), z + e);
    }
    sc_add(&s, 0, 0, 0, 5e5, 1e6, 1e6);
    check_f64(s.b, s.n, "sizes 1e-6 .. 1e6, float64");
    f = narrow(s.b, s.n);
    check_both(f, s.n, "sizes 1e-6 .. 1e6, float32");
    free(f);
    sc_free(&s);
}

/* ------------------------------------------------------------------ */
/* 8. Subnormals and negative zero                                    */
/* ------------------------------------------------------------------ */

static void subnormals_and_negative_zero(void)
{
    double v[16];
    ts_rng r;
    int world;
    /* world 0: float32 subnormals only (the scene's extent is subnormal);
       1: float32 subnormals beside ordinary values; 2 and 3: the same in
       float64, where a subnormal extent overflows 2^31 / extent. */
    for (world = 0; world < 4; world++) {
        sc s = {0};
        float *f;
        char name[80];
        size_t k = 0;
        const int f64 = world >= 2, mixed = world % 2;
        const double tm = f64 ? 0x1p-1074 : 0x1p-149, mn = f64 ? DBL_MIN : FLT_MIN;
        const double one = mixed ? 1.0 : tm;
        v[k++] = -3 * tm;
        v[k++] = -tm;
        v[k++] = -0.0;
        v[k++] = 0.0;
        v[k++] = tm;
        v[k++] = 2 * tm;
        v[k++] = 3 * tm;
        v[k++] = mn - tm; /* the largest subnormal */
        v[k++] = -(mn - tm);
        if (mixed) {
            v[k++] = mn;
            v[k++] = -mn;
            v[k++] = 1.0;
            v[k++] = -1.0;
        }
        qsort(v, k, sizeof(double), cmp_double);
        ts_seed(&r, 1000 + (uint64_t)world);
        add_table_boxes(&s, &r, 4400, v, k, heavy() ? 2 : 1); /* light run: fewer pairs */
        /* Explicit -0 / +0 contacts: -0 <= +0 and +0 <= -0 both hold. */
        sc_add(&s, -one, -0.0, -0.0, -0.0, 0.0, 0.0);
        sc_add(&s, 0.0, 0.0, -0.0, one, -0.0, 0.0);
        sc_add(&s, -0.0, -0.0, -0.0, -0.0, -0.0, -0.0);
        sc_add(&s, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        snprintf(name, sizeof name, "subnormals and -0 (%s, %s)", f64 ? "float64" : "float32",
                 mixed ? "beside ordinary values" : "subnormal extent");
        if (f64) {
            check_f64(s.b, s.n, name);
        } else {
            f = narrow(s.b, s.n);
            check_both(f, s.n, name);
            free(f);
        }
        sc_free(&s);
    }
}

/* ------------------------------------------------------------------ */
/* 9. Float64 values that float32 cannot hold                         */
/* ------------------------------------------------------------------ */

static void float64_not_representable_in_float32(void)
{
    static const struct {
        double base, step;
        const char *name;
    } cases[] = {{1.0, 0x1p-40, "1 + k * 2^-40"}, {1e5, 1e-4, "1e5 + k * 1e-4 (the far scene's scale)"},
                 {-3.0, 0x1p-30, "-3 + k * 2^-30"}};
    size_t c;
    for (c = 0; c < 3; c++) {
        double v[32];
        sc s = {0};
        ts_rng r;
        size_t k, m64, m32;
        float *f;
        uint64_t *a, *b;
        for (k = 0; k < 32; k++)
            v[k] = cases[c].base + (double)k * cases[c].step;
        ts_seed(&r, 1100 + c);
        add_table_boxes(&s, &r, 4500, v, 32, 1);
        m64 = check_f64(s.b, s.n, cases[c].name);
        /* The test means something only if float32 rounding changes the answer. */
        f = narrow(s.b, s.n);
        a = reference(s.b, s.n, 1, &m64);
        b = reference(f, s.n, 0, &m32);
        TEST_ASSERT_TRUE(m32 != m64 || memcmp(a, b, m64 * sizeof *a) != 0);
        free(a);
        free(b);
        free(f);
        sc_free(&s);
    }
}

/* ------------------------------------------------------------------ */
/* 10. Very many boxes in one cell: quadratic output                  */
/* ------------------------------------------------------------------ */

typedef struct hc_counter {
    size_t cur, peak, cap, refused;
} hc_counter;

static void *cnt_alloc(size_t size, void *user)
{
    hc_counter *c = user;
    size_t now = __atomic_add_fetch(&c->cur, size, __ATOMIC_RELAXED);
    size_t peak = __atomic_load_n(&c->peak, __ATOMIC_RELAXED);
    void *p;
    if (now > c->cap) {
        __atomic_sub_fetch(&c->cur, size, __ATOMIC_RELAXED);
        __atomic_add_fetch(&c->refused, 1, __ATOMIC_RELAXED);
        return NULL;
    }
    while (now > peak && !__atomic_compare_exchange_n(&c->peak, &peak, now, 0, __ATOMIC_RELAXED, __ATOMIC_RELAXED))
        ;
    p = malloc(size);
    if (!p)
        __atomic_sub_fetch(&c->cur, size, __ATOMIC_RELAXED);
    return p;
}

static void cnt_free(void *p, size_t size, void *user)
{
    hc_counter *c = user;
    __atomic_sub_fetch(&c->cur, size, __ATOMIC_RELAXED);
    free(p);
}

static locd_engine *counted_engine(uint32_t threads, hc_counter *c)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_engine_config_init(&cfg);
    cfg.threads = threads;
    cfg.allocator.alloc = cnt_alloc;
    cfg.allocator.free = cnt_free;
    cfg.allocator.user = c;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
    return e;
}

static void many_boxes_in_one_cell(void)
{
    const size_t n = heavy() ? 4100 : 1500; /* n(n-1)/2 pairs */
    float *u = ts_scene(0, n, 1200);
    size_t i, m, want;
    static const uint32_t threads[] = {1, 2, 3, 8};
    /* Every box contains the centre: all n(n-1)/2 pairs, distinct boxes. */
    for (i = 0; i < n; i++) {
        int a;
        for (a = 0; a < 3; a++) {
            u[6 * i + a] = 0.5f - u[6 * i + a] * 0.1f - 0.001f;
            u[6 * i + 3 + a] = 0.5f + u[6 * i + 3 + a] * 0.1f;
        }
    }
    want = n * (n - 1) / 2;
    m = check_f32(u, n, "every box contains the centre");
    TEST_ASSERT_EQUAL_INT64(want, m);

    /* Memory runs out: a clean LOCD_ERR_NO_MEMORY, the old result kept, no
       leak; with enough memory the same engine then succeeds. */
    for (i = 0; i < 4; i++) {
        hc_counter ce = {0, 0, (size_t)-1, 0}, cp = {0, 0, (size_t)-1, 0};
        locd_allocator pa = {cnt_alloc, cnt_free, &cp};
        locd_engine *e = counted_engine(threads[i], &ce);
        locd_pairs *p;
        float two[12] = {0, 0, 0, 1, 1, 1, 1, 1, 1, 2, 2, 2};
        locd_status st;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(&pa, &p));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, two, 2, 0, p));
        TEST_ASSERT_EQUAL_INT64(1, locd_pairs_count(p));
        ce.cap = ce.cur + want * 2; /* a quarter of the pairs' 8 bytes each: not enough */
        st = locd_engine_find_pairs_f32(e, u, n, 0, p);
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NO_MEMORY, st);
        TEST_ASSERT_TRUE(ce.refused > 0);
        TEST_ASSERT_EQUAL_INT64(1, locd_pairs_count(p));
        TEST_ASSERT_EQUAL_INT64(0, locd_pairs_data(p)[0]);
        TEST_ASSERT_EQUAL_INT64(1, locd_pairs_data(p)[1]);
        /* Enough for the engine, but not for the caller's buffer. */
        ce.cap = (size_t)-1;
        cp.cap = cp.cur + want * 2;
        st = locd_engine_find_pairs_f32(e, u, n, 0, p);
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NO_MEMORY, st);
        TEST_ASSERT_EQUAL_INT64(1, locd_pairs_count(p));
        TEST_ASSERT_EQUAL_INT64(1, locd_pairs_data(p)[1]);
        cp.cap = (size_t)-1;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, u, n, 0, p));
        TEST_ASSERT_EQUAL_INT64(want, locd_pairs_count(p));
        locd_pairs_destroy(p);
        locd_engine_destroy(e);
        TEST_ASSERT_EQUAL_INT64(0, ce.cur);
        TEST_ASSERT_EQUAL_INT64(0, cp.cur);
    }
    free(u);
    trim_runners();
}

/* A scene that would give 2^41 pairs, with one bad box: the call fails at
 * validation, before any quadratic work, and names the right box. */
static void huge_scene_with_bad_box_fails_fast(void)
{
    const size_t n = heavy() ? (size_t)1 << 21 : (size_t)1 << 16;
    float *u = malloc(n * 6 * sizeof(float));
    double *d;
    size_t i, bad[3] = {n - 1, n / 2 + 3, 1};
    size_t t;
    static const uint32_t threads[] = {1, 2, 3, 8};
    TEST_ASSERT_NOT_NULL(u);
    for (i = 0; i < n; i++) {
        float b[6] = {1, 2, 3, 4, 5, 6};
        memcpy(u + 6 * i, b, sizeof b);
    }
    for (t = 0; t < 4; t++) {
        hc_counter ce = {0, 0, (size_t)-1, 0};
        locd_engine *e = counted_engine(threads[t], &ce);
        locd_pairs *p;
        size_t k;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
        for (k = 0; k < 3; k++) {
            size_t before = ce.cur;
            double t0;
            locd_status st;
            float save = u[6 * bad[k] + 4];
            float save2 = u[6 * (n - 1) + 2];
            /* bad[k] gets min > max on y; box n-1 also gets a NaN (later index) */
            u[6 * bad[k] + 4] = 1.0f;
            if (bad[k] != n - 1)
                u[6 * (n - 1) + 2] = NAN;
            ce.peak = ce.cur;
            t0 = (double)clock() / CLOCKS_PER_SEC;
            st = locd_engine_find_pairs_f32(e, u, n, 0, p);
            TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVERTED_BOX, st);
            TEST_ASSERT_EQUAL_INT64((int64_t)bad[k], locd_last_error_index());
            TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(p));
            /* No entry buffers were grown for a scene that was refused. */
            TEST_ASSERT_TRUE(ce.peak - before < ((size_t)1 << 20));
            TEST_ASSERT_TRUE((double)clock() / CLOCKS_PER_SEC - t0 < 5.0);
            u[6 * bad[k] + 4] = save;
            u[6 * (n - 1) + 2] = save2;
        }
        locd_pairs_destroy(p);
        locd_engine_destroy(e);
    }
    /* The same in float64, NaN first. */
    d = widen(u, n);
    free(u);
    d[6 * 77 + 5] = NAN;
    d[6 * (n / 2) + 0] = 7.0;
    for (t = 0; t < 4; t++) {
        hc_counter ce = {0, 0, (size_t)-1, 0};
        locd_engine *e = counted_engine(threads[t], &ce);
        locd_pairs *p;
        size_t before = ce.cur;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
        ce.peak = ce.cur;
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_f64(e, d, n, 0, p));
        TEST_ASSERT_EQUAL_INT64(77, locd_last_error_index());
        TEST_ASSERT_TRUE(ce.peak - before < ((size_t)1 << 20));
        locd_pairs_destroy(p);
        locd_engine_destroy(e);
    }
    free(d);
}

/* ------------------------------------------------------------------ */
/* Bad input, through every engine                                    */
/* ------------------------------------------------------------------ */

/* Puts a known result into p so tests can see that an error keeps it. */
static void prime(locd_engine *e, locd_pairs *p)
{
    float b[18] = {0, 0, 0, 1, 1, 1, 0.5f, 0.5f, 0.5f, 2, 2, 2, 1, 1, 1, 3, 3, 3};
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, b, 3, LOCD_FIND_SORTED, p));
    TEST_ASSERT_EQUAL_INT64(3, locd_pairs_count(p));
}

static void assert_primed(const locd_pairs *p)
{
    static const uint32_t want[6] = {0, 1, 0, 2, 1, 2};
    TEST_ASSERT_EQUAL_INT64(3, locd_pairs_count(p));
    TEST_ASSERT_EQUAL_MEMORY(want, locd_pairs_data(p), sizeof want);
}

static void bad_values_name_the_first_bad_box(void)
{
    static const size_t sizes[] = {1, 10, 5000};
    size_t si;
    int r;
    locd_pairs *p;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    for (si = 0; si < 3; si++) {
        size_t n = sizes[si];
        float *u = ts_scene(2, n, 1300 + si);
        double *d = widen(u, n);
        size_t idx[4] = {0, 1, n / 2, n - 1};
        int ii, kind, coord;
        for (r = 0; r < nrunners; r++) {
            if (!runner_wanted(r, n))
                continue;
            for (ii = 0; ii < 4; ii++) {
                size_t at = idx[ii] < n ? idx[ii] : n - 1;
                for (kind = 0; kind < 4; kind++)
                    for (coord = 0; coord < 6; coord++) {
                        float sf = u[6 * at + coord];
                        double sd = d[6 * at + coord];
                        locd_status want = kind < 3 ? LOCD_ERR_NONFINITE : LOCD_ERR_INVERTED_BOX;
                        double bad = kind == 0 ? NAN : kind == 1 ? INFINITY : kind == 2 ? -INFINITY : 0.0;
                        if (kind == 3) /* min > max on this coordinate's axis */
                            bad = coord < 3 ? d[6 * at + coord + 3] + 1.0 : d[6 * at + coord - 3] - 1.0;
                        if (kind != 0 && coord % 2 && n == 5000)
                            continue; /* keep the run short: NaN on all six, the rest on three */
                        u[6 * at + coord] = (float)bad;
                        d[6 * at + coord] = bad;
                        prime(runners[r].e, p);
                        if (locd_engine_find_pairs_f32(runners[r].e, u, n, 0, p) != want ||
                            locd_last_error_index() != (int64_t)at)
                            LT_FAIL("%s: f32 n %zu bad value kind %d at box %zu coord %d: got index %lld (%s)",
                                    runners[r].name, n, kind, at, coord, (long long)locd_last_error_index(),
                                    locd_last_error());
                        assert_primed(p);
                        if (locd_engine_find_pairs_f64(runners[r].e, d, n, 0, p) != want ||
                            locd_last_error_index() != (int64_t)at)
                            LT_FAIL("%s: f64 n %zu bad value kind %d at box %zu coord %d", runners[r].name, n, kind, at,
                                    coord);
                        assert_primed(p);
                        u[6 * at + coord] = sf;
                        d[6 * at + coord] = sd;
                    }
            }
            /* Two bad boxes: the lower index wins whatever its kind. */
            if (n > 2) {
                size_t lo = n > 10 ? n / 3 : 1, hi = n - 1;
                float a = u[6 * lo], b = u[6 * hi + 4];
                u[6 * lo] = u[6 * lo + 3] + 1.0f; /* inverted at lo */
                u[6 * hi + 4] = NAN;              /* NaN at hi */
                prime(runners[r].e, p);
                TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVERTED_BOX, locd_engine_find_pairs_f32(runners[r].e, u, n, 0, p));
                TEST_ASSERT_EQUAL_INT64((int64_t)lo, locd_last_error_index());
                assert_primed(p);
                u[6 * lo] = a;
                u[6 * hi + 4] = b;
                a = u[6 * lo + 2];
                b = u[6 * hi + 1];
                u[6 * lo + 2] = INFINITY;
                u[6 * hi + 1] = u[6 * hi + 4] + 1.0f;
                TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_f32(runners[r].e, u, n, 0, p));
                TEST_ASSERT_EQUAL_INT64((int64_t)lo, locd_last_error_index());
                assert_primed(p);
                u[6 * lo + 2] = a;
                u[6 * hi + 1] = b;
            }
            /* The fixed scene is valid again. */
            TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(runners[r].e, u, n, 0, p));
        }
        free(u);
        free(d);
    }
    locd_pairs_destroy(p);
}

static void empty_single_and_null_arguments(void)
{
    locd_pairs *p;
    int r;
    float one[6] = {0, 0, 0, 1, 1, 1}, nanbox[6] = {0, 0, 0, 1, NAN, 1};
    double one64[6] = {-1, -1, -1, 1e300, 1e300, 1e300};
    uint32_t buf[8];
    size_t count;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    for (r = 0; r < nrunners; r++) {
        locd_engine *e = runners[r].e;
        if (!runner_wanted(r, 1))
            continue;
        prime(e, p);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, NULL, 0, 0, p));
        TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(p));
        prime(e, p);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f64(e, NULL, 0, LOCD_FIND_SORTED, p));
        TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(p));
        prime(e, p);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, one, 1, 0, p));
        TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(p));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f64(e, one64, 1, 0, p));
        TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(p));
        prime(e, p);
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NONFINITE, locd_engine_find_pairs_f32(e, nanbox, 1, 0, p));
        TEST_ASSERT_EQUAL_INT64(0, locd_last_error_index());
        assert_primed(p);
        /* NULL pointers. */
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f32(e, NULL, 3, 0, p));
        assert_primed(p);
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f64(e, NULL, 3, 0, p));
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f32(e, one, 1, 0, NULL));
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f32_into(e, one, 1, 0, NULL, 4, &count));
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f32_into(e, one, 1, 0, buf, 4, NULL));
        count = 99;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32_into(e, NULL, 0, 0, NULL, 0, &count));
        TEST_ASSERT_EQUAL_INT64(0, count);
        /* Unknown flags are refused, and the output kept. */
        TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_find_pairs_f32(e, one, 1, 0x80u, p));
    }
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_HANDLE, locd_engine_find_pairs_f32(NULL, one, 1, 0, p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_HANDLE, locd_engine_find_pairs_f64(NULL, one64, 1, 0, p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_brute_force_f32(NULL, 2, p));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_brute_force_f32(one, 1, NULL));
    locd_pairs_destroy(p);
}

static void bad_config_sizes_and_values(void)
{
    locd_engine_config cfg;
    locd_engine *e = (locd_engine *)&cfg; /* must be reset to NULL on failure */
    locd_stats stats;
    locd_grid g;
    float one[12] = {0, 0, 0, 1, 1, 1, 1, 1, 1, 2, 2, 2};
    locd_engine_config_init(&cfg);
    cfg.size = 0;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create(&cfg, &e));
    TEST_ASSERT_NULL(e);
    cfg.size = (uint32_t)sizeof cfg + 8; /* a newer struct than this library knows */
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create(&cfg, &e));
    cfg.size = 3;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_create(&cfg, &e));
    /* An older, shorter struct (up to `flags`) keeps the defaults for the rest. */
    locd_engine_config_init(&cfg);
    cfg.size = (uint32_t)(offsetof(locd_engine_config, flags) + sizeof cfg.flags);
    cfg.threads = 2;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
    TEST_ASSERT_EQUAL_INT64(2, locd_engine_threads(e));
    locd_engine_destroy(e);
    {
        static const struct {
            int32_t level, bias;
            uint32_t threads, depth;
        } bad[] = {{0, 1, 1, 0}, {4, 1, 1, 0}, {1, -1, 1, 0}, {1, 9, 1, 0}, {1, 1, 65, 0}, {1, 1, 1, 22}, {3, 1, 1, 0}};
        size_t k;
        for (k = 0; k < sizeof bad / sizeof bad[0]; k++) {
            locd_engine_config_init(&cfg);
            cfg.level = bad[k].level;
            cfg.cell_bias = bad[k].bias;
            cfg.threads = bad[k].threads;
            cfg.max_depth = bad[k].depth;
            e = (locd_engine *)&cfg;
            TEST_ASSERT_NOT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
            TEST_ASSERT_NULL(e);
        }
    }
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_create(NULL, NULL));
    /* Stats with a bad size. */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(NULL, &e));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_find_pairs_f32(e, one, 2, 0, NULL));
    stats.size = 0;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_stats(e, &stats));
    stats.size = (uint32_t)sizeof stats + 4;
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_engine_stats(e, &stats));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_engine_stats(e, NULL));
    locd_engine_destroy(e);
    /* The building blocks refuse bad knobs too. */
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_grid_fit_f32(one, 2, 0, 9, 0, &g));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_INVALID_ARGUMENT, locd_grid_fit_f32(one, 2, 0, -1, 0, &g));
    TEST_ASSERT_EQUAL_INT64(LOCD_ERR_NULL_POINTER, locd_grid_fit_f32(one, 2, 0, 1, 0, NULL));
}

/* ------------------------------------------------------------------ */
/* Randomized search over the ingredients above                       */
/* ------------------------------------------------------------------ */

/* One axis-value table mixing the ingredients: an offset (zero, far,
 * near the largest value, subnormal), a step (ulps, dyadic, decimal,
 * twelve orders of magnitude), -0 and +0. */
static size_t random_table(ts_rng *r, double *v, int f64)
{
    size_t nv = 2 + (size_t)rnd(r, 30), k;
    const double big = f64 ? DBL_MAX : FLT_MAX, tiny = f64 ? 0x1p-1074 : 0x1p-149;
    static const double offs[] = {0.0, 1.0, -1.0, 1e3, -1e6, 1e10, 1e20, 1e30, -1e30, 0.5, 1e-30};
    double off = offs[rnd(r, sizeof offs / sizeof offs[0])];
    uint64_t style = rnd(r, 7);
    for (k = 0; k < nv; k++) {
        switch (style) {
        case 0: /* ulp lattice at the offset */
            v[k] = k ? (f64 ? nextafter(v[k - 1], INFINITY) : nextafterf((float)v[k - 1], INFINITY))
                     : (f64 ? off : (double)(float)off);
            break;
        case 1: /* dyadic fractions */
            v[k] = off + ldexp((double)rnd(r, 64), -(int)rnd(r, 30));
            break;
        case 2: /* decimal steps */
            v[k] = off + 0.1 * (double)rnd(r, 40);
            break;
        case 3: /* twelve orders of magnitude */
            v[k] = off + (rnd(r, 2) ? 1 : -1) * pow(10.0, 12.0 * ts_uniform(r) - 6.0);
            break;
        case 4: /* near the largest values */
            v[k] = (rnd(r, 2) ? big : -big) * (1.0 - ldexp((double)rnd(r, 8), f64 ? -52 : -23));
            break;
        case 5: /* subnormals and zeros */
            v[k] = (rnd(r, 2) ? 1 : -1) * tiny * (double)rnd(r, 6);
            break;
        default: /* a bit of everything */
            v[k] = rnd(r, 4) ? off * (double)rnd(r, 3) + (double)rnd(r, 5) : (rnd(r, 2) ? -0.0 : big * 0.5);
            break;
        }
        if (!f64)
            v[k] = (float)v[k];
        if (!isfinite(v[k]))
            v[k] = 0.0;
    }
    qsort(v, nv, sizeof(double), cmp_double);
    return nv;
}

static void randomized_search(void)
{
    const char *bs = getenv("LOCD_HARD_BUDGET_MS"), *ss = getenv("LOCD_HARD_SEED");
    double budget = bs ? atof(bs) : 3000.0;
    uint64_t seed = ss ? strtoull(ss, NULL, 10) : 20261122u, it;
    struct timespec t0, t1;
    size_t scenes = 0, pairs = 0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (it = 0; it < 1000000; it++) {
        ts_rng r;
        sc s = {0};
        double v[32];
        int f64;
        size_t nv, n, i;
        char name[96];
        double ms;
        clock_gettime(CLOCK_MONOTONIC, &t1);
        ms = (double)(t1.tv_sec - t0.tv_sec) * 1e3 + (double)(t1.tv_nsec - t0.tv_nsec) * 1e-6;
        if (ms > budget)
            break;
        ts_seed(&r, seed * 1000003u + it);
        f64 = (int)rnd(&r, 2);
        /* Every tenth scene is big enough for the parallel path (not in the
           light run: its pair count may be quadratic). */
        n = it % 10 == 9 && heavy() ? HC_PAR + (size_t)rnd(&r, 1000) : 2 + (size_t)rnd(&r, 400);
        if (it % 10 == 4) { /* around a power of two: the index bits and the automatic depth change there */
            static const size_t edges[] = {2, 3, 4, 5, 255, 256, 257, 4096, 4097, 8192, 8193};
            n = edges[rnd(&r, heavy() ? 11 : 7)];
        }
        nv = random_table(&r, v, f64);
        add_table_boxes(&s, &r, n, v, nv, (size_t)rnd(&r, 5));
        /* Extra ingredients: duplicates, a container, a second table. */
        for (i = 0; i < n / 8; i++)
            if (rnd(&r, 4) == 0)
                memmove(s.b + 6 * rnd(&r, n), s.b + 6 * rnd(&r, n), 6 * sizeof(double));
        if (rnd(&r, 4) == 0) {
            size_t at = (size_t)rnd(&r, n);
            s.b[6 * at] = s.b[6 * at + 1] = s.b[6 * at + 2] = v[0];
            s.b[6 * at + 3] = s.b[6 * at + 4] = s.b[6 * at + 5] = v[nv - 1];
        }
        if (rnd(&r, 3) == 0) {
            sc t = {0};
            nv = random_table(&r, v, f64);
            add_table_boxes(&t, &r, n / 3 + 1, v, nv, 2);
            for (i = 0; i < t.n; i++)
                memcpy(s.b + 6 * rnd(&r, n), t.b + 6 * i, 6 * sizeof(double));
            sc_free(&t);
        }
        snprintf(name, sizeof name, "random scene (LOCD_HARD_SEED=%llu, iteration %llu)", (unsigned long long)seed,
                 (unsigned long long)it);
        if (f64) {
            pairs += check_f64(s.b, n, name);
        } else {
            float *f = narrow(s.b, n);
            pairs += check_f32(f, n, name);
            free(f);
        }
        scenes++;
        sc_free(&s);
    }
    LT_PRINT("# randomized search: %zu scenes, %zu pairs, seed %llu, budget %.0f ms\n", scenes, pairs,
             (unsigned long long)seed, budget);
    TEST_ASSERT_TRUE(scenes > 0);
    trim_runners();
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(touching_faces_edges_corners),
        LT_TEST(touching_at_decimal_values),
        LT_TEST(faces_on_cell_boundaries),
        LT_TEST(translated_far_from_origin),
        LT_TEST(scaled_down_to_1e_30),
        LT_TEST(extent_overflows),
        LT_TEST(points_and_zero_size_boxes),
        LT_TEST(many_identical_boxes),
        LT_TEST(one_box_contains_all),
        LT_TEST(degenerate_worlds),
        LT_TEST(sizes_span_twelve_orders),
        LT_TEST(subnormals_and_negative_zero),
        LT_TEST(float64_not_representable_in_float32),
        LT_TEST(many_boxes_in_one_cell),
        LT_TEST(huge_scene_with_bad_box_fails_fast),
        LT_TEST(bad_values_name_the_first_bad_box),
        LT_TEST(empty_single_and_null_arguments),
        LT_TEST(bad_config_sizes_and_values),
        LT_TEST(randomized_search),
    };
    return LT_RUN_GROUP(tests, group_setup, group_teardown);
}
