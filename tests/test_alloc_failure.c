/* Allocation-failure injection: for every k, the k-th allocation of a
 * representative call of each public entry point fails (first that one
 * allocation alone, then it and every later one). Each such call must return
 * LOCD_ERR_NO_MEMORY, leave its output as it was, leak nothing (the counting
 * allocator's live bytes return to their baseline), and leave the handles
 * usable: the next call succeeds and equals brute force. The loop over k
 * stops at the first k the call completes without meeting a failure, so
 * every allocation the call makes has been failed once.
 *
 * LOCD_TEST_HEAVY=0 (set by the sanitizer runs) shrinks the scenes, keeping
 * them large enough for the engine to split the work between threads. */
#include <locd/pipeline.h>
#include <signal.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "fail_alloc.h"
#include "levels_util.h"
#include "support.h"

/* Level 3: a `locd serve` started by the group setup. */
static char g_dir[256], g_addr[300];
static pid_t g_service = -1;

/* Far more allocations than any call here makes: a loop that gets there is a bug. */
#define MAX_K 20000u
/* The engine runs one thread below this many objects (lib/levels/inproc.c). */
#define PARALLEL_N 4096

static int heavy(void)
{
    const char *v = getenv("LOCD_TEST_HEAVY");
    return !(v && v[0] == '0');
}

/* ------------------------------------------------------------------ */
/* Scenes and their brute-force answers                               */
/* ------------------------------------------------------------------ */

typedef struct scene {
    size_t n;
    float *f;
    double *d;     /* the same values as float64 */
    uint32_t *ref; /* brute force, sorted by (i, j) */
    size_t m;
} scene;

static int cmp_pair(const void *a, const void *b)
{
    const uint32_t *x = a, *y = b;
    if (x[0] != y[0])
        return x[0] < y[0] ? -1 : 1;
    return x[1] < y[1] ? -1 : x[1] > y[1];
}

/* The doubles and the brute-force answer of s->f (n boxes). */
static void scene_finish(scene *s, size_t n)
{
    locd_pairs *p;
    size_t i;
    s->n = n;
    s->d = malloc(6 * n * sizeof(double));
    TEST_ASSERT_NOT_NULL(s->d);
    for (i = 0; i < 6 * n; i++)
        s->d[i] = (double)s->f[i];
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(NULL, &p));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_brute_force_f32(s->f, n, p));
    s->ref = ts_sorted_copy(p, &s->m);
    TEST_ASSERT_TRUE(s->m > 0);
    locd_pairs_destroy(p);
}

static void scene_make(scene *s, int kind, size_t n, uint64_t seed)
{
    s->f = ts_scene(kind, n, seed);
    scene_finish(s, n);
}

/* n cubes of edge 0.12 in the unit cube: about 80 partners each, so each
 * sweep thread finds more pairs than the engine's spare entry memory holds
 * and grows a pair buffer of its own (the one a result may take over). */
static void scene_make_dense(scene *s, size_t n, uint64_t seed)
{
    ts_rng r;
    size_t i;
    int a;
    s->f = ts_boxes(n, &r, seed);
    for (i = 0; i < n; i++)
        for (a = 0; a < 3; a++) {
            s->f[6 * i + a] = (float)(ts_uniform(&r) * 0.88);
            s->f[6 * i + a + 3] = s->f[6 * i + a] + 0.12f;
        }
    scene_finish(s, n);
}

static void scene_free(scene *s)
{
    free(s->f);
    free(s->d);
    free(s->ref);
}

/* 1 if `count` pairs (any order) are exactly the scene's brute-force answer. */
static int pairs_match(const uint32_t *data, size_t count, const scene *s)
{
    uint32_t *c;
    int ok;
    if (count != s->m)
        return 0;
    c = malloc((count ? count : 1) * 2 * sizeof(uint32_t));
    TEST_ASSERT_NOT_NULL(c);
    if (count)
        memcpy(c, data, count * 2 * sizeof(uint32_t));
    qsort(c, count, 2 * sizeof(uint32_t), cmp_pair);
    ok = count == 0 || memcmp(c, s->ref, count * 2 * sizeof(uint32_t)) == 0;
    free(c);
    return ok;
}

static int result_match(const locd_pairs *p, const scene *s)
{
    return pairs_match(locd_pairs_data(p), locd_pairs_count(p), s);
}

/* ------------------------------------------------------------------ */
/* The driver                                                         */
/* ------------------------------------------------------------------ */

/* One scenario: fresh objects for each k (prepare), the call under test
 * (call, run with the failure armed), the checks after a failed call
 * (unchanged), the checks after a successful one (correct), a following
 * unarmed call (usable), and destruction (teardown). */
typedef struct scenario {
    const char *name;
    void (*prepare)(void *ctx);
    locd_status (*call)(void *ctx);
    void (*unchanged)(void *ctx);
    void (*correct)(void *ctx);
    void (*usable)(void *ctx);
    void (*teardown)(void *ctx);
} scenario;

/* Runs the scenario for every k; returns how many allocations the call made. */
static uint64_t drive(const scenario *sc, void *ctx)
{
    uint64_t total = 0;
    int sticky;
    for (sticky = 0; sticky <= 1; sticky++) {
        uint64_t k;
        for (k = 1; k <= MAX_K; k++) {
            fa_counts base, c, after;
            locd_status st;
            fa_counts_get(&base);
            sc->prepare(ctx);
            fa_arm(k, sticky);
            st = sc->call(ctx);
            fa_counts_get(&c);
            fa_arm(0, 0);
            if (st != LOCD_OK) {
                if (st != LOCD_ERR_NO_MEMORY)
                    LT_FAIL("%s: allocation %llu%s failed: status %d (%s: %s), expected LOCD_ERR_NO_MEMORY", sc->name,
                            (unsigned long long)k, sticky ? "+" : "", (int)st, locd_status_string(st),
                            locd_last_error());
                if (c.failures == 0)
                    LT_FAIL("%s: failed with %d (%s) though no allocation failed", sc->name, (int)st,
                            locd_last_error());
                if (sc->unchanged)
                    sc->unchanged(ctx);
            } else if (sc->correct) {
                sc->correct(ctx); /* a failure absorbed (e.g. a retry) must still give the exact answer */
            }
            if (sc->usable)
                sc->usable(ctx);
            sc->teardown(ctx);
            fa_counts_get(&after);
            if (after.bad_frees != base.bad_frees)
                LT_FAIL("%s: allocation %llu%s: free() with a wrong size or pointer", sc->name, (unsigned long long)k,
                        sticky ? "+" : "");
            if (after.live_bytes < base.live_bytes || after.live_blocks < base.live_blocks)
                LT_FAIL("%s: allocation %llu%s: %lld bytes in %lld blocks allocated before this call were freed "
                        "during it: an earlier call's memory outlived its destroy (a thread still freeing?)",
                        sc->name, (unsigned long long)k, sticky ? "+" : "",
                        (long long)(base.live_bytes - after.live_bytes),
                        (long long)(base.live_blocks - after.live_blocks));
            if (after.live_bytes != base.live_bytes || after.live_blocks != base.live_blocks)
                LT_FAIL("%s: allocation %llu%s failed: %lld bytes in %lld blocks leaked (status %d)", sc->name,
                        (unsigned long long)k, sticky ? "+" : "", (long long)(after.live_bytes - base.live_bytes),
                        (long long)(after.live_blocks - base.live_blocks), (int)st);
            if (c.failures == 0) {
                if (st != LOCD_OK)
                    LT_FAIL("%s: status %d with no failure", sc->name, (int)st);
                total = c.calls;
                break;
            }
        }
        if (k > MAX_K)
            LT_FAIL("%s: still failing after %u allocations", sc->name, MAX_K);
    }
    return total;
}

static void report(const char *name, uint64_t allocations)
{
    printf("# %s: %llu allocations, each failed in turn\n", name, (unsigned long long)allocations);
}

/* ------------------------------------------------------------------ */
/* Engine create                                                      */
/* ------------------------------------------------------------------ */

typedef struct create_ctx {
    int32_t level;
    uint32_t threads;
    locd_engine *e;
    const scene *s;
} create_ctx;

static void create_prepare(void *p)
{
    create_ctx *c = p;
    c->e = NULL;
}

static locd_status create_call(void *p)
{
    create_ctx *c = p;
    locd_engine_config cfg;
    locd_engine_config_init(&cfg);
    cfg.level = c->level;
    cfg.threads = c->threads;
    cfg.allocator = *fa_allocator();
    /* Strings the engine copies: more allocations to fail. */
    cfg.service_address = g_addr;
    if (c->level == LOCD_LEVEL_INPROCESS) {
        cfg.worker_path = "/nonexistent/locd-worker";
        cfg.service_secret = "secret";
    }
    c->e = (locd_engine *)&cfg; /* must be reset to NULL on failure */
    return locd_engine_create(&cfg, &c->e);
}

static void create_unchanged(void *p)
{
    create_ctx *c = p;
    TEST_ASSERT_NULL(c->e);
}

static void create_usable(void *p)
{
    create_ctx *c = p;
    locd_pairs *out;
    if (!c->e) { /* the failed create must not have poisoned a later one */
        locd_engine_config cfg;
        locd_engine_config_init(&cfg);
        cfg.level = c->level;
        cfg.service_address = g_addr;
        cfg.threads = c->threads;
        cfg.allocator = *fa_allocator();
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &c->e));
    }
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(fa_allocator(), &out));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(c->e, c->s->f, c->s->n, 0, out));
    TEST_ASSERT_TRUE(result_match(out, c->s));
    locd_pairs_destroy(out);
}

static void create_teardown(void *p)
{
    create_ctx *c = p;
    locd_engine_destroy(c->e);
    c->e = NULL;
}

/* ------------------------------------------------------------------ */
/* Engine find (f32/f64, pairs or caller buffer, sorted or not)       */
/* ------------------------------------------------------------------ */

typedef struct find_ctx {
    int32_t level;
    uint32_t threads;
    int f64, into, warm; /* warm 2: the output holds this scene's answer from another engine */
    uint32_t flags;
    const scene *s;     /* the scene of the call */
    const scene *small; /* what the output (and, when warm, the engine) held before */
    locd_engine *e;
    locd_pairs *out;
    uint32_t *before; /* copy of out before the call */
    size_t before_count;
    uint32_t *buf; /* caller buffer of the _into calls */
    size_t cap, count;
} find_ctx;

static void find_prepare(void *p)
{
    find_ctx *c = p;
    locd_engine_config cfg;
    locd_engine_config_init(&cfg);
    cfg.level = c->level ? c->level : LOCD_LEVEL_INPROCESS;
    cfg.service_address = g_addr;
    cfg.threads = c->threads;
    cfg.allocator = *fa_allocator();
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &c->e));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(fa_allocator(), &c->out));
    /* Output holding an earlier answer; a warm engine has sized its buffers for it. */
    if (c->warm == 2) { /* the output already has room for the answer: the result may take the sweep's buffer */
        locd_engine *other;
        cfg.threads = 1;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &other));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(other, c->s->f, c->s->n, 0, c->out));
        locd_engine_destroy(other);
    } else if (c->warm)
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(c->e, c->small->f, c->small->n, 0, c->out));
    else
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_brute_force_f32(c->small->f, c->small->n, c->out));
    c->before_count = locd_pairs_count(c->out);
    c->before = malloc(c->before_count * 2 * sizeof(uint32_t) + 8);
    memcpy(c->before, locd_pairs_data(c->out), c->before_count * 2 * sizeof(uint32_t));
    c->cap = c->s->m;
    c->buf = calloc(2 * c->cap + 2, sizeof(uint32_t));
    c->count = (size_t)-1;
}

static locd_status find_run(find_ctx *c)
{
    if (c->into)
        return c->f64 ? locd_engine_find_pairs_f64_into(c->e, c->s->d, c->s->n, c->flags, c->buf, c->cap, &c->count)
                      : locd_engine_find_pairs_f32_into(c->e, c->s->f, c->s->n, c->flags, c->buf, c->cap, &c->count);
    return c->f64 ? locd_engine_find_pairs_f64(c->e, c->s->d, c->s->n, c->flags, c->out)
                  : locd_engine_find_pairs_f32(c->e, c->s->f, c->s->n, c->flags, c->out);
}

static locd_status find_call(void *p)
{
    return find_run(p);
}

static void find_unchanged(void *p)
{
    find_ctx *c = p;
    if (c->into) {
        size_t i;
        TEST_ASSERT_EQUAL_INT64((size_t)-1, c->count); /* *count untouched */
        for (i = 0; i < 2 * c->cap; i++)
            if (c->buf[i])
                LT_FAIL("find_into wrote into the caller buffer and failed");
        return;
    }
    if (locd_pairs_count(c->out) != c->before_count ||
        memcmp(locd_pairs_data(c->out), c->before, c->before_count * 2 * sizeof(uint32_t)) != 0)
        LT_FAIL("a failed find (threads %u, %s, flags %u) changed *out (%zu pairs before, %zu after)", c->threads,
                c->f64 ? "f64" : "f32", c->flags, c->before_count, locd_pairs_count(c->out));
}

static void find_correct(void *p)
{
    find_ctx *c = p;
    const uint32_t *got = c->into ? c->buf : locd_pairs_data(c->out);
    size_t count = c->into ? c->count : locd_pairs_count(c->out);
    TEST_ASSERT_EQUAL_INT64(c->s->m, count);
    if (c->flags & LOCD_FIND_SORTED) /* (i, j) order, element by element, however it was sorted */
        LT_ASSERT_EQUAL_MEMORY(c->s->ref, got, count * 2 * sizeof(uint32_t));
    else
        TEST_ASSERT_TRUE(pairs_match(got, count, c->s));
}

static void find_usable(void *p)
{
    find_ctx *c = p;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, find_run(c));
    find_correct(c);
}

static void find_teardown(void *p)
{
    find_ctx *c = p;
    locd_pairs_destroy(c->out);
    locd_engine_destroy(c->e);
    free(c->before);
    free(c->buf);
    c->out = NULL;
    c->e = NULL;
}

/* ------------------------------------------------------------------ */
/* Pairs: create and sort                                             */
/* ------------------------------------------------------------------ */

typedef struct pairs_ctx {
    const scene *s;
    locd_pairs *p;
    uint32_t *before;
    size_t before_count;
} pairs_ctx;

static void pcreate_prepare(void *v)
{
    ((pairs_ctx *)v)->p = NULL;
}

static locd_status pcreate_call(void *v)
{
    pairs_ctx *c = v;
    c->p = (locd_pairs *)c; /* must be reset to NULL on failure */
    return locd_pairs_create(fa_allocator(), &c->p);
}

static void pcreate_unchanged(void *v)
{
    TEST_ASSERT_NULL(((pairs_ctx *)v)->p);
}

static void pcreate_usable(void *v)
{
    pairs_ctx *c = v;
    if (!c->p)
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(fa_allocator(), &c->p));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_brute_force_f32(c->s->f, c->s->n, c->p));
    TEST_ASSERT_TRUE(result_match(c->p, c->s));
}

static void pairs_teardown(void *v)
{
    pairs_ctx *c = v;
    locd_pairs_destroy(c->p);
    free(c->before);
    c->before = NULL;
    c->p = NULL;
}

/* The buffer holds the scene's pairs in the engine's sweep order (unsorted). */
static void psort_prepare(void *v)
{
    pairs_ctx *c = v;
    locd_engine *e;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(fa_allocator(), &c->p));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(NULL, &e));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_find_pairs_f32(e, c->s->f, c->s->n, 0, c->p));
    locd_engine_destroy(e);
    c->before_count = locd_pairs_count(c->p);
    c->before = malloc(c->before_count * 2 * sizeof(uint32_t) + 8);
    memcpy(c->before, locd_pairs_data(c->p), c->before_count * 2 * sizeof(uint32_t));
}

static locd_status psort_call(void *v)
{
    return locd_pairs_sort(((pairs_ctx *)v)->p);
}

static void pairs_unchanged(void *v)
{
    pairs_ctx *c = v;
    if (locd_pairs_count(c->p) != c->before_count ||
        memcmp(locd_pairs_data(c->p), c->before, c->before_count * 2 * sizeof(uint32_t)) != 0)
        LT_FAIL("a failed call changed the pairs buffer");
}

/* Sorted means exactly the reference, element by element. */
static void psort_correct(void *v)
{
    pairs_ctx *c = v;
    TEST_ASSERT_EQUAL_INT64(c->s->m, locd_pairs_count(c->p));
    LT_ASSERT_EQUAL_MEMORY(c->s->ref, locd_pairs_data(c->p), c->s->m * 2 * sizeof(uint32_t));
}

static void psort_usable(void *v)
{
    pairs_ctx *c = v;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_sort(c->p));
    psort_correct(c);
}

/* ------------------------------------------------------------------ */
/* Brute force                                                        */
/* ------------------------------------------------------------------ */

typedef struct brute_ctx {
    pairs_ctx pc;
    const scene *small;
    int f64;
} brute_ctx;

static void brute_prepare(void *v)
{
    brute_ctx *c = v;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(fa_allocator(), &c->pc.p));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_brute_force_f32(c->small->f, c->small->n, c->pc.p));
    c->pc.before_count = locd_pairs_count(c->pc.p);
    c->pc.before = malloc(c->pc.before_count * 2 * sizeof(uint32_t) + 8);
    memcpy(c->pc.before, locd_pairs_data(c->pc.p), c->pc.before_count * 2 * sizeof(uint32_t));
}

static locd_status brute_call(void *v)
{
    brute_ctx *c = v;
    return c->f64 ? locd_brute_force_f64(c->pc.s->d, c->pc.s->n, c->pc.p)
                  : locd_brute_force_f32(c->pc.s->f, c->pc.s->n, c->pc.p);
}

static void brute_correct(void *v)
{
    psort_correct(&((brute_ctx *)v)->pc); /* brute force returns (i, j) order */
}

static void brute_usable(void *v)
{
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, brute_call(v));
    brute_correct(v);
}

static void brute_unchanged(void *v)
{
    pairs_unchanged(&((brute_ctx *)v)->pc);
}

static void brute_teardown(void *v)
{
    pairs_teardown(&((brute_ctx *)v)->pc);
}

/* ------------------------------------------------------------------ */
/* Building blocks: fit, encode (two runs), sort, merge, sweep         */
/* ------------------------------------------------------------------ */

typedef struct blocks_ctx {
    pairs_ctx pc;
    int f64;
} blocks_ctx;

static locd_status blocks_run(blocks_ctx *c)
{
    const scene *s = c->pc.s;
    const size_t half = s->n / 2;
    locd_grid g;
    locd_stats st;
    uint64_t *ent, *scr, *merged;
    size_t w0 = 0, w1 = 0, cap = s->n * LOCD_MAX_ENTRIES_PER_BOX;
    locd_status r;
    ent = malloc(cap * sizeof *ent);
    scr = malloc(cap * sizeof *scr);
    merged = malloc(cap * sizeof *merged);
    TEST_ASSERT_TRUE(ent && scr && merged);
    /* fit, encode, sort and merge take caller buffers: they must not need the allocator at all. */
    if (c->f64) {
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_grid_fit_f64(s->d, s->n, 0, 1, 0, &g));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_encode_f64(&g, s->d, 0, half, ent, cap, &w0));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_encode_f64(&g, s->d, half, s->n - half, ent + w0, cap - w0, &w1));
    } else {
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_grid_fit_f32(s->f, s->n, 0, 1, 0, &g));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_encode_f32(&g, s->f, 0, half, ent, cap, &w0));
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_encode_f32(&g, s->f, half, s->n - half, ent + w0, cap - w0, &w1));
    }
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_sort_entries(&g, ent, scr, w0));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_sort_entries(&g, ent + w0, scr, w1));
    {
        const uint64_t *runs[2];
        size_t counts[2];
        runs[0] = ent;
        runs[1] = ent + w0;
        counts[0] = w0;
        counts[1] = w1;
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_merge_entries(runs, counts, 2, merged));
    }
    locd_stats_init(&st);
    r = c->f64 ? locd_sweep_f64(&g, s->d, s->n, merged, w0 + w1, c->pc.p, &st)
               : locd_sweep_f32(&g, s->f, s->n, merged, w0 + w1, c->pc.p, &st);
    free(ent);
    free(scr);
    free(merged);
    return r;
}

static void blocks_prepare(void *v)
{
    blocks_ctx *c = v;
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(fa_allocator(), &c->pc.p));
    c->pc.before_count = 0;
    c->pc.before = NULL;
}

static locd_status blocks_call(void *v)
{
    return blocks_run(v);
}

static void blocks_unchanged(void *v)
{
    TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(((blocks_ctx *)v)->pc.p));
}

static void blocks_correct(void *v)
{
    blocks_ctx *c = v;
    TEST_ASSERT_TRUE(result_match(c->pc.p, c->pc.s));
}

static void blocks_usable(void *v)
{
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, blocks_run(v));
    blocks_correct(v);
}

static void blocks_teardown(void *v)
{
    pairs_teardown(&((blocks_ctx *)v)->pc);
}

/* ------------------------------------------------------------------ */
/* Jobs: submit, wait, take                                           */
/* ------------------------------------------------------------------ */

typedef struct job_ctx {
    const scene *s;
    int f64;
    locd_engine *e;
    locd_pairs *out;
} job_ctx;

static void job_prepare(void *v)
{
    job_ctx *c = v;
    locd_engine_config cfg;
    locd_engine_config_init(&cfg);
    cfg.threads = 2;
    cfg.allocator = *fa_allocator();
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_engine_create(&cfg, &c->e));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_pairs_create(fa_allocator(), &c->out));
}

static locd_status job_run(job_ctx *c)
{
    locd_job *job = NULL;
    locd_status st = c->f64 ? locd_engine_submit_f64(c->e, c->s->d, c->s->n, 0, &job)
                            : locd_engine_submit_f32(c->e, c->s->f, c->s->n, 0, &job);
    if (st)
        return st;
    st = locd_job_wait(job, -1);
    if (!st)
        st = locd_job_take(job, c->out);
    locd_job_release(job);
    return st;
}

static locd_status job_call(void *v)
{
    return job_run(v);
}

static void job_unchanged(void *v)
{
    TEST_ASSERT_EQUAL_INT64(0, locd_pairs_count(((job_ctx *)v)->out));
}

static void job_correct(void *v)
{
    job_ctx *c = v;
    TEST_ASSERT_TRUE(result_match(c->out, c->s));
}

static void job_usable(void *v)
{
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, job_run(v));
    job_correct(v);
}

static void job_teardown(void *v)
{
    job_ctx *c = v;
    locd_pairs_destroy(c->out);
    locd_engine_destroy(c->e);
    c->out = NULL;
    c->e = NULL;
}

/* ------------------------------------------------------------------ */
/* Tests                                                              */
/* ------------------------------------------------------------------ */

typedef struct scenes {
    scene big;   /* >= PARALLEL_N objects: the engine splits the work */
    scene dense; /* as many, with many more pairs than entries */
    scene small; /* what an output buffer held before the call */
    scene tiny;  /* for the O(n^2) reference */
} scenes;

/* Made once by the group setup, read by every test. */
static scenes g_scenes;

static int setup(void)
{
    scenes *sc = &g_scenes;
    size_t n = heavy() ? 6000 : PARALLEL_N + 200;
    lu_setup(); /* LOCD_WORKER: the build's locd-worker */
    lu_temp_dir(g_dir, sizeof g_dir);
    {
        char listen[300], log[300];
        snprintf(listen, sizeof listen, "unix:%s/s.sock", g_dir);
        snprintf(log, sizeof log, "%s/serve.log", g_dir);
        g_service = lu_start_service(listen, NULL, 1, log, g_addr, sizeof g_addr);
        if (g_service <= 0)
            return -1;
    }
    scene_make(&sc->big, 2, n, 41);    /* mixed sizes: several octree levels */
    scene_make(&sc->small, 0, 300, 7); /* uniform */
    scene_make_dense(&sc->dense, n, 43);
    scene_make(&sc->tiny, 1, heavy() ? 1500 : 600, 5);
    return 0;
}

static void teardown(void)
{
    scenes *sc = &g_scenes;
    scene_free(&sc->big);
    scene_free(&sc->dense);
    scene_free(&sc->small);
    scene_free(&sc->tiny);
    memset(sc, 0, sizeof *sc);
    if (g_service > 0)
        lu_stop_service(g_service, SIGTERM);
    g_service = -1;
    lu_cleanup_dir(g_dir);
}

static void engine_create_fails_cleanly(void)
{
    static const struct {
        int32_t level;
        uint32_t threads;
    } v[] = {{LOCD_LEVEL_INPROCESS, 1}, {LOCD_LEVEL_INPROCESS, 2}, {LOCD_LEVEL_WORKERS, 2}, {LOCD_LEVEL_SERVICE, 0}};
    const scenes *sc = &g_scenes;
    size_t i;
    for (i = 0; i < sizeof v / sizeof v[0]; i++) {
        create_ctx c;
        scenario s = {"engine_create", create_prepare, create_call, create_unchanged, NULL, create_usable,
                      create_teardown};
        char name[64];
        memset(&c, 0, sizeof c);
        c.level = v[i].level;
        c.threads = v[i].threads;
        c.s = &sc->big;
        snprintf(name, sizeof name, "engine_create level %d threads=%u", (int)c.level, c.threads);
        s.name = name;
        report(name, drive(&s, &c));
    }
}

typedef struct find_variant {
    int32_t level; /* 0 = level 1 */
    uint32_t threads;
    int f64, into, warm;
    uint32_t flags;
} find_variant;

/* Runs the variants; with LOCD_TEST_HEAVY=0 only those whose index is in
 * `light` (a bit mask): the sanitizer builds are slow, and under TSan every
 * level-2 engine start is two instrumented processes. */
static void find_variants(const scenes *sc, const scene *of, const find_variant *v, size_t nv, unsigned light)
{
    size_t i;
    for (i = 0; i < nv; i++) {
        if (!heavy() && !(light & (1u << i)))
            continue;
        find_ctx c;
        scenario s = {NULL, find_prepare, find_call, find_unchanged, find_correct, find_usable, find_teardown};
        char name[96];
        memset(&c, 0, sizeof c);
        c.level = v[i].level;
        c.threads = v[i].threads;
        c.f64 = v[i].f64;
        c.into = v[i].into;
        c.warm = v[i].warm;
        c.flags = v[i].flags;
        c.s = of;
        c.small = &sc->small;
        snprintf(name, sizeof name, "find_pairs_%s%s level %d threads=%u%s%s", c.f64 ? "f64" : "f32",
                 c.into ? "_into" : "", c.level ? (int)c.level : 1, c.threads,
                 c.warm == 2 ? " into a result sized for it" : c.warm ? " warm" : "",
                 c.flags ? " sorted" : "");
        s.name = name;
        report(name, drive(&s, &c));
    }
}

static void find_fails_cleanly(void)
{
    static const find_variant v[] = {
        {0, 1, 0, 0, 0, 0}, {0, 2, 0, 0, 0, 0},
        {0, 1, 1, 0, 0, 0}, {0, 2, 1, 0, 0, 0},
        {0, 2, 0, 0, 1, 0},                     /* warm engine, buffers sized for a smaller scene */
        {0, 2, 0, 1, 0, 0}, {0, 1, 1, 1, 1, 0}, /* into a caller buffer */
    };
    find_variants(&g_scenes, &g_scenes.big, v, sizeof v / sizeof v[0], 0x1u | 0x8u | 0x10u | 0x20u);
}

/* A find into a result that already holds its answer, on a fresh engine
 * and a dense scene (its sweep threads outgrow the spare entry memory and
 * allocate pair buffers of their own): each allocation failed in turn
 * leaves *out as it was, and the drive's teardown finds every block freed
 * with its own size. */
static void find_into_a_sized_result_fails_cleanly(void)
{
    static const find_variant v[] = {{0, 2, 0, 0, 2, 0}, {0, 3, 1, 0, 2, 0}, {0, 2, 0, 0, 2, LOCD_FIND_SORTED}};
    find_variants(&g_scenes, &g_scenes.dense, v, sizeof v / sizeof v[0], 0x1u);
}

/* The (i, j) ordering allocates after the pairs are found: a failure there
 * must still leave *out as it was. */
static void find_sorted_fails_cleanly(void)
{
    static const find_variant v[] = {
        {0, 1, 0, 0, 0, LOCD_FIND_SORTED}, {0, 2, 1, 0, 1, LOCD_FIND_SORTED},
        {LOCD_LEVEL_WORKERS, 2, 0, 0, 0, LOCD_FIND_SORTED}, {LOCD_LEVEL_SERVICE, 0, 1, 0, 0, LOCD_FIND_SORTED},
    };
    find_variants(&g_scenes, &g_scenes.big, v, sizeof v / sizeof v[0], 0x2u | 0x8u);
}

/* Levels 2 and 3: the caller's side of the call (requests, shared memory
 * bookkeeping, results) allocates through the hook too. Worker processes and
 * the service allocate in their own address space and are not injected. */
static void find_other_levels_fail_cleanly(void)
{
    static const find_variant v[] = {
        {LOCD_LEVEL_WORKERS, 2, 0, 0, 0, 0}, {LOCD_LEVEL_WORKERS, 2, 1, 0, 1, 0},
        {LOCD_LEVEL_WORKERS, 1, 0, 1, 0, 0}, {LOCD_LEVEL_SERVICE, 0, 0, 0, 0, 0},
        {LOCD_LEVEL_SERVICE, 0, 1, 1, 1, 0},
    };
    find_variants(&g_scenes, &g_scenes.big, v, sizeof v / sizeof v[0], 0x1u | 0x10u);
}

static void pairs_fail_cleanly(void)
{
    const scenes *sc = &g_scenes;
    pairs_ctx c;
    scenario create = {"pairs_create", pcreate_prepare, pcreate_call, pcreate_unchanged, NULL, pcreate_usable,
                       pairs_teardown};
    scenario sort = {"pairs_sort", psort_prepare, psort_call, pairs_unchanged, psort_correct, psort_usable,
                     pairs_teardown};
    memset(&c, 0, sizeof c);
    c.s = &sc->tiny;
    report(create.name, drive(&create, &c));
    c.s = &sc->big;
    report(sort.name, drive(&sort, &c));
}

static void brute_force_fails_cleanly(void)
{
    const scenes *sc = &g_scenes;
    int f64;
    for (f64 = 0; f64 <= 1; f64++) {
        brute_ctx c;
        scenario s = {f64 ? "brute_force_f64" : "brute_force_f32", brute_prepare, brute_call, brute_unchanged,
                      brute_correct, brute_usable, brute_teardown};
        memset(&c, 0, sizeof c);
        c.pc.s = &sc->tiny;
        c.small = &sc->small;
        c.f64 = f64;
        report(s.name, drive(&s, &c));
    }
}

static void building_blocks_fail_cleanly(void)
{
    const scenes *sc = &g_scenes;
    int f64;
    for (f64 = 0; f64 <= 1; f64++) {
        blocks_ctx c;
        scenario s = {f64 ? "fit/encode/sort/merge/sweep_f64" : "fit/encode/sort/merge/sweep_f32", blocks_prepare,
                      blocks_call, blocks_unchanged, blocks_correct, blocks_usable, blocks_teardown};
        memset(&c, 0, sizeof c);
        c.pc.s = &sc->big;
        c.f64 = f64;
        report(s.name, drive(&s, &c));
    }
}

static void jobs_fail_cleanly(void)
{
    const scenes *sc = &g_scenes;
    job_ctx c;
    int f64;
    memset(&c, 0, sizeof c);
    c.s = &sc->big;
    /* Jobs may not exist in this build yet: probe once, unarmed. */
    job_prepare(&c);
    {
        locd_job *job = NULL;
        locd_status st = locd_engine_submit_f32(c.e, c.s->f, c.s->n, 0, &job);
        if (st == LOCD_OK) {
            locd_job_wait(job, -1);
            locd_job_release(job);
        }
        job_teardown(&c);
        if (st == LOCD_ERR_UNSUPPORTED) {
            TEST_IGNORE_MESSAGE("jobs: not implemented in this build (LOCD_ERR_UNSUPPORTED): nothing to test");
        }
        TEST_ASSERT_EQUAL_INT64(LOCD_OK, st);
    }
    for (f64 = 0; f64 <= 1; f64++) {
        scenario s = {f64 ? "submit_f64/wait/take" : "submit_f32/wait/take", job_prepare, job_call, job_unchanged,
                      job_correct, job_usable, job_teardown};
        c.f64 = f64;
        report(s.name, drive(&s, &c));
    }
}

/* ------------------------------------------------------------------ */
/* World: create, add (its arrays grow), collide (its scratch)         */
/* ------------------------------------------------------------------ */

typedef struct world_ctx {
    locd_shape *sphere;
    locd_contacts *out;
    locd_world *w;
    size_t count; /* pairs of the unarmed run */
} world_ctx;

static void world_prepare(void *v)
{
    world_ctx *c = v;
    c->w = NULL;
}

static locd_status world_call(void *v)
{
    world_ctx *c = v;
    locd_engine_config cfg;
    double pose[7] = {0, 0, 0, 0, 0, 0, 1};
    locd_status st;
    size_t i;
    locd_engine_config_init(&cfg);
    cfg.threads = 1;
    cfg.allocator = *fa_allocator();
    if ((st = locd_world_create(&cfg, &c->w)) != LOCD_OK)
        return st;
    for (i = 0; i < 150 && !st; i++) { /* past the first capacity (64): the arrays grow twice */
        pose[0] = 1.5 * (double)(i % 10);
        pose[1] = 1.5 * (double)(i / 10);
        st = locd_world_add(c->w, c->sphere, pose, NULL, NULL);
    }
    return st ? st : locd_world_collide(c->w, NULL, c->out, NULL);
}

static void world_correct(void *v)
{
    world_ctx *c = v;
    TEST_ASSERT_EQUAL_INT64(c->count, locd_contacts_count(c->out));
}

static void world_teardown(void *v)
{
    world_ctx *c = v;
    locd_world_destroy(c->w);
    c->w = NULL;
}

static void world_fails_cleanly(void)
{
    world_ctx c;
    scenario s = {"world create/add/collide", world_prepare, world_call, NULL, world_correct, NULL, world_teardown};
    memset(&c, 0, sizeof c);
    if (locd_shape_sphere(0.8, &c.sphere) != LOCD_OK)
        TEST_IGNORE_MESSAGE("world: no narrow phase in this build: nothing to test");
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, locd_contacts_create(&c.out));
    TEST_ASSERT_EQUAL_INT64(LOCD_OK, world_call(&c)); /* unarmed: the reference count, and contacts at full size */
    c.count = locd_contacts_count(c.out);
    TEST_ASSERT_TRUE(c.count > 0);
    world_teardown(&c);
    report(s.name, drive(&s, &c));
    locd_contacts_destroy(c.out);
    locd_shape_destroy(c.sphere);
}

/* The allocator itself: a test that cannot fail proves nothing. */
static void allocator_counts_and_fails(void)
{
    const locd_allocator *a = fa_allocator();
    fa_counts c0, c;
    void *p, *q;
    fa_counts_get(&c0);
    fa_arm(2, 0);
    p = a->alloc(100, a->user);
    q = a->alloc(50, a->user);
    TEST_ASSERT_NOT_NULL(p);
    TEST_ASSERT_NULL(q);
    TEST_ASSERT_EQUAL_INT64(0, ((uintptr_t)p) % 16);
    fa_counts_get(&c);
    TEST_ASSERT_EQUAL_INT64(2, c.calls);
    TEST_ASSERT_EQUAL_INT64(1, c.failures);
    TEST_ASSERT_EQUAL_INT64(c0.live_bytes + 100, c.live_bytes);
    a->free(p, 100, a->user);
    fa_arm(0, 0);
    fa_counts_get(&c);
    TEST_ASSERT_EQUAL_INT64(c0.live_bytes, c.live_bytes);
    TEST_ASSERT_EQUAL_INT64(c0.bad_frees, c.bad_frees);
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(allocator_counts_and_fails),
        LT_TEST(engine_create_fails_cleanly),
        LT_TEST(find_fails_cleanly),
        LT_TEST(find_sorted_fails_cleanly),
        LT_TEST(find_into_a_sized_result_fails_cleanly),
        LT_TEST(find_other_levels_fail_cleanly),
        LT_TEST(pairs_fail_cleanly),
        LT_TEST(brute_force_fails_cleanly),
        LT_TEST(building_blocks_fail_cleanly),
        LT_TEST(jobs_fail_cleanly),
        LT_TEST(world_fails_cleanly),
    };
    return LT_RUN_GROUP(tests, setup, teardown);
}
