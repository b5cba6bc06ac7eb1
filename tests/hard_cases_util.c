/* The hard-case suites' engines and checks (hard_cases_util.h). */
#include "hard_cases_util.h"

#include <fcntl.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "runner.h"

#ifndef LOCD_BUILD_DIR
#define LOCD_BUILD_DIR "."
#endif

/* ------------------------------------------------------------------ */
/* Engines under test                                                 */
/* ------------------------------------------------------------------ */

hc_runner hc_runners[HC_MAX_RUNNERS];
int hc_nrunners;
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
    if (hc_nrunners >= HC_MAX_RUNNERS) {
        locd_engine_destroy(e);
        return;
    }
    r = &hc_runners[hc_nrunners++];
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

int hc_group_setup(void)
{
    static const uint32_t threads[] = {1, 2, 3, 8};
    size_t i;
    verbose = getenv("LOCD_HARD_VERBOSE") != NULL;
    for (i = 0; i < 4; i++)
        add_runner(make_engine(LOCD_LEVEL_INPROCESS, threads[i], 1, 0, 0, NULL, NULL, NULL), 0, 1,
                   "level 1, %u threads", threads[i]);
    if (hc_nrunners != 4)
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
    hc_runners[1].light_skip = 1; /* 2 threads */
    hc_runners[4].light_skip = 1; /* cubes, 1 thread */
    hc_runners[6].light_skip = 1; /* bias 8, 1 thread */
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
void hc_trim_runners(void)
{
    int i;
    for (i = 0; i < hc_nrunners; i++) {
        locd_engine *e = NULL;
        locd_engine_destroy(hc_runners[i].e);
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&hc_runners[i].cfg, &e));
        hc_runners[i].e = e;
    }
}

void hc_group_teardown(void)
{
    int i;
    for (i = 0; i < hc_nrunners; i++)
        locd_engine_destroy(hc_runners[i].e);
    hc_nrunners = 0;
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

double *hc_widen(const float *b, size_t n)
{
    double *d = malloc((n ? n : 1) * 6 * sizeof *d);
    size_t k;
    TEST_ASSERT_NOT_NULL(d);
    for (k = 0; k < 6 * n; k++)
        d[k] = (double)b[k];
    return d;
}

float *hc_narrow(const double *b, size_t n)
{
    float *f = malloc((n ? n : 1) * 6 * sizeof *f);
    size_t k;
    TEST_ASSERT_NOT_NULL(f);
    for (k = 0; k < 6 * n; k++)
        f[k] = (float)b[k]; /* round to nearest: monotone, so min <= max stays true */
    return f;
}

/* The brute-force answer in the input precision, as sorted keys. */
uint64_t *hc_reference(const void *boxes, size_t n, int f64, size_t *m)
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

/* LOCD_TEST_HEAVY=0 (the sanitizer builds, tests/README.md) shrinks the
 * scenes whose output is quadratic; everything stays >= HC_PAR objects
 * except those. */
int hc_heavy(void)
{
    const char *v = getenv("LOCD_TEST_HEAVY");
    return !(v && v[0] == '0');
}

/* How many runners of the list to use: small scenes run on one thread in
 * every level-1 engine, so one engine per group and level is enough. */
int hc_runner_wanted(int r, size_t n)
{
    int q;
    if (!hc_heavy() && hc_runners[r].light_skip)
        return 0;
    if (n >= HC_PAR)
        return 1;
    for (q = 0; q < r; q++)
        if (hc_runners[q].group == hc_runners[r].group && hc_runners[q].level == hc_runners[r].level)
            return 0;
    return 1;
}

/* Every engine against the reference; the same pair order within a group.
 * Returns the number of pairs. */
static size_t check_scene(const void *boxes, size_t n, int f64, const char *what)
{
    size_t m, r;
    uint64_t *ref = hc_reference(boxes, n, f64, &m);
    double *wide = f64 ? (double *)boxes : hc_widen(boxes, n);
    uint32_t *first_order[8] = {0};
    size_t first_count[8] = {0};
    locd_pairs *p;
    hc_find_fn find = f64 ? find64 : find32;
    int failed = 0;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    for (r = 0; r < (size_t)hc_nrunners; r++) {
        const hc_runner *R = &hc_runners[r];
        locd_status st;
        size_t c;
        uint64_t *got;
        if (!hc_runner_wanted((int)r, n))
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
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, find(hc_runners[hc_nrunners > 2 ? 2 : 0].e, boxes, n, LOCD_FIND_SORTED, p));
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

size_t hc_check_f32(const float *b, size_t n, const char *what)
{
    return check_scene(b, n, 0, what);
}

size_t hc_check_f64(const double *b, size_t n, const char *what)
{
    return check_scene(b, n, 1, what);
}

/* A float32 scene, then the same values through the float64 entry point
 * (the round trip through float64 is exact and must give the same pairs). */
void hc_check_both(const float *b, size_t n, const char *what)
{
    double *d = hc_widen(b, n);
    size_t m32 = hc_check_f32(b, n, what), m64 = hc_heavy() ? hc_check_f64(d, n, what) : m32;
    locd_pairs *p32, *p64;
    TEST_ASSERT_EQUAL_INT64(m64, m32);
    /* docs/encoding.md: the same values give the same order in either precision. */
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p32));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p64));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(hc_runners[2].e, b, n, 0, p32));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f64(hc_runners[2].e, d, n, 0, p64));
    if (m32 && memcmp(locd_pairs_data(p32), locd_pairs_data(p64), m32 * 2 * sizeof(uint32_t)))
        LT_FAIL("%s: float32 and float64 input of the same values give different pair orders", what);
    locd_pairs_destroy(p32);
    locd_pairs_destroy(p64);
    free(d);
}

/* ------------------------------------------------------------------ */
/* Scene building                                                     */
/* ------------------------------------------------------------------ */

void hc_scene_add(hc_scene *s, double x0, double y0, double z0, double x1, double y1, double z1)
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

void hc_scene_free(hc_scene *s)
{
    free(s->b);
    memset(s, 0, sizeof *s);
}

uint64_t hc_rnd(ts_rng *r, uint64_t k)
{
    return k ? ts_next(r) % k : 0;
}

/* Boxes whose faces are drawn from sorted per-axis value tables: any two
 * boxes sharing a table value touch exactly there. span is the largest
 * number of table steps a box covers (0 = points). */
void hc_add_table_boxes(hc_scene *s, ts_rng *r, size_t count, const double *vals, size_t nv, size_t span)
{
    size_t i;
    int a;
    for (i = 0; i < count; i++) {
        double lo[3], hi[3];
        for (a = 0; a < 3; a++) {
            size_t i0 = (size_t)hc_rnd(r, nv), i1 = i0 + (size_t)hc_rnd(r, span + 1);
            if (i1 >= nv)
                i1 = nv - 1;
            lo[a] = vals[i0];
            hi[a] = vals[i1];
        }
        hc_scene_add(s, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    }
}

/* ------------------------------------------------------------------ */
/* A counting allocator                                               */
/* ------------------------------------------------------------------ */

void *hc_count_alloc(size_t size, void *user)
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

void hc_count_free(void *p, size_t size, void *user)
{
    hc_counter *c = user;
    __atomic_sub_fetch(&c->cur, size, __ATOMIC_RELAXED);
    free(p);
}

locd_engine *hc_counted_engine(uint32_t threads, hc_counter *c)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_engine_config_init(&cfg);
    cfg.threads = threads;
    cfg.allocator.alloc = hc_count_alloc;
    cfg.allocator.free = hc_count_free;
    cfg.allocator.user = c;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &e));
    return e;
}
