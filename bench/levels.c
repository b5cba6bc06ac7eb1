/* locd-bench-levels: per-call cost of integration levels 2 and 3 against
 * level 1, and the service's throughput with many small jobs. Run through
 * bench/levels.sh, which starts the services and writes the tables into
 * docs/levels.md.
 *
 *   locd-bench-levels --calls unix:SOCK --jobs unix:SOCK2 [--sizes 1e3,1e5,1e6]
 *                     [--threads K] [--out FILE.md]
 *
 * --calls: a service with one runner of K engine threads (same threads as
 * level 1 and level 2 here, so the difference is the integration cost);
 * --jobs: a service with several single-threaded runners (throughput). */
#include <locd/locd.h>

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static uint64_t rng_next(uint64_t *s)
{
    uint64_t x = *s;
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    *s = x;
    return x * 0x2545f4914f6cdd1dULL;
}

static double uni(uint64_t *s)
{
    return (double)(rng_next(s) >> 11) * (1.0 / 9007199254740992.0);
}

/* n cubes in a box sized for about one overlap per object. */
static float *scene(size_t n, uint64_t seed)
{
    float *b = malloc(n * 6 * sizeof *b);
    double side = 1.0, edge = 0.9 / 2.0 * side / (double)(n > 1 ? n : 1);
    size_t i;
    uint64_t s = seed * 0x9e3779b97f4a7c15ULL + 1;
    /* volume fraction ~ edge^3 * n: pick edge = (1/n)^(1/3) * 0.6 */
    edge = 0.6 * side / __builtin_cbrt((double)n);
    for (i = 0; i < n; i++) {
        int a;
        for (a = 0; a < 3; a++) {
            double lo = uni(&s) * side, e = edge * (0.5 + uni(&s));
            b[6 * i + a] = (float)lo;
            b[6 * i + 3 + a] = (float)(lo + e);
        }
    }
    return b;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static locd_engine *engine(int level, uint32_t threads, const char *addr)
{
    locd_engine_config cfg;
    locd_engine *e = NULL;
    locd_engine_config_init(&cfg);
    cfg.level = level;
    cfg.threads = threads;
    cfg.service_address = addr;
    if (locd_engine_create(&cfg, &e) != LOCD_OK) {
        fprintf(stderr, "locd-bench-levels: level %d: %s\n", level, locd_last_error());
        exit(1);
    }
    return e;
}

/* Median wall time of `reps` calls (after one warm-up call). */
static double time_calls(locd_engine *e, const float *b, size_t n, int reps, locd_pairs *p, double *transfer)
{
    double *t = malloc((size_t)reps * sizeof *t), med, tr = 0;
    locd_stats st;
    int r;
    if (locd_engine_find_pairs_f32(e, b, n, 0, p) != LOCD_OK) {
        fprintf(stderr, "locd-bench-levels: %s\n", locd_last_error());
        exit(1);
    }
    for (r = 0; r < reps; r++) {
        double t0 = now_ms();
        locd_engine_find_pairs_f32(e, b, n, 0, p);
        t[r] = now_ms() - t0;
        locd_stats_init(&st);
        locd_engine_get_stats(e, &st);
        tr += st.ms_transfer;
    }
    qsort(t, (size_t)reps, sizeof *t, cmp_double);
    med = t[reps / 2];
    free(t);
    *transfer = tr / reps;
    return med;
}

typedef struct tp_ctx {
    const char *addr;
    size_t n;
    int jobs, window;
    int done, failed;
} tp_ctx;

static void *tp_client(void *arg)
{
    tp_ctx *c = arg;
    locd_engine *e = engine(LOCD_LEVEL_SERVICE, 0, c->addr);
    locd_pairs *p;
    locd_job **inflight = calloc((size_t)c->window, sizeof *inflight);
    float *b = scene(c->n, 7);
    int submitted = 0, head = 0, i;
    locd_pairs_create(NULL, &p);
    while (c->done + c->failed < c->jobs) {
        while (submitted < c->jobs && submitted - (c->done + c->failed) < c->window) {
            if (locd_engine_submit_f32(e, b, c->n, 0, &inflight[submitted % c->window]) != LOCD_OK) {
                c->failed++;
                inflight[submitted % c->window] = NULL;
            }
            submitted++;
        }
        i = head++ % c->window;
        if (inflight[i]) {
            if (locd_job_wait(inflight[i], -1) == LOCD_OK && locd_job_take(inflight[i], p) == LOCD_OK)
                c->done++;
            else
                c->failed++;
            locd_job_release(inflight[i]);
            inflight[i] = NULL;
        }
    }
    free(inflight);
    free(b);
    locd_pairs_destroy(p);
    locd_engine_destroy(e);
    return NULL;
}

static double throughput(const char *addr, int clients, size_t n, int jobs, int window, int *failed)
{
    pthread_t th[64];
    tp_ctx c[64];
    double t0 = now_ms(), dt;
    int i, total = 0;
    *failed = 0;
    for (i = 0; i < clients; i++) {
        memset(&c[i], 0, sizeof c[i]);
        c[i].addr = addr;
        c[i].n = n;
        c[i].jobs = jobs / clients;
        c[i].window = window;
        pthread_create(&th[i], NULL, tp_client, &c[i]);
    }
    for (i = 0; i < clients; i++) {
        pthread_join(th[i], NULL);
        total += c[i].done;
        *failed += c[i].failed;
    }
    dt = now_ms() - t0;
    return total / (dt / 1000.0);
}

int main(int argc, char **argv)
{
    const char *calls = NULL, *jobs = NULL, *out = NULL;
    size_t sizes[8] = {1000, 100000, 1000000};
    int nsizes = 3, a, i;
    uint32_t threads = 2;
    FILE *f = stdout;
    for (a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "--calls") && a + 1 < argc)
            calls = argv[++a];
        else if (!strcmp(argv[a], "--jobs") && a + 1 < argc)
            jobs = argv[++a];
        else if (!strcmp(argv[a], "--out") && a + 1 < argc)
            out = argv[++a];
        else if (!strcmp(argv[a], "--threads") && a + 1 < argc)
            threads = (uint32_t)atoi(argv[++a]);
        else if (!strcmp(argv[a], "--sizes") && a + 1 < argc) {
            char *s = argv[++a], *tok;
            nsizes = 0;
            for (tok = strtok(s, ","); tok && nsizes < 8; tok = strtok(NULL, ","))
                sizes[nsizes++] = (size_t)strtod(tok, NULL);
        } else {
            fprintf(stderr, "usage: locd-bench-levels --calls ADDR --jobs ADDR [--sizes 1e3,1e5,1e6] [--threads K] "
                            "[--out FILE]\n");
            return 2;
        }
    }
    if (!calls || !jobs) {
        fprintf(stderr, "locd-bench-levels: --calls and --jobs are required (bench/levels.sh starts the services)\n");
        return 2;
    }
    if (out && !(f = fopen(out, "w"))) {
        perror(out);
        return 1;
    }
    {
        locd_engine *e1 = engine(LOCD_LEVEL_INPROCESS, threads, NULL);
        locd_engine *e2 = engine(LOCD_LEVEL_WORKERS, threads, NULL);
        locd_engine *e3 = engine(LOCD_LEVEL_SERVICE, 0, calls);
        locd_pairs *p1, *p2, *p3;
        locd_pairs_create(NULL, &p1);
        locd_pairs_create(NULL, &p2);
        locd_pairs_create(NULL, &p3);
        fprintf(f, "| n | pairs | level 1 ms | level 2 ms | level 2 overhead | level 3 ms | level 3 overhead |\n");
        fprintf(f, "|---:|---:|---:|---:|---:|---:|---:|\n");
        for (i = 0; i < nsizes; i++) {
            size_t n = sizes[i];
            int reps = n <= 1000 ? 301 : n <= 100000 ? 31 : 7;
            float *b = scene(n, 42 + (uint64_t)i);
            double tr, t1 = time_calls(e1, b, n, reps, p1, &tr);
            double t2 = time_calls(e2, b, n, reps, p2, &tr);
            double t3 = time_calls(e3, b, n, reps, p3, &tr);
            if (locd_pairs_count(p1) != locd_pairs_count(p2) || locd_pairs_count(p1) != locd_pairs_count(p3) ||
                memcmp(locd_pairs_data(p1), locd_pairs_data(p2), locd_pairs_count(p1) * 8) ||
                memcmp(locd_pairs_data(p1), locd_pairs_data(p3), locd_pairs_count(p1) * 8)) {
                fprintf(stderr, "locd-bench-levels: levels disagree at n = %zu\n", n);
                return 3;
            }
            fprintf(f, "| %zu | %zu | %.3f | %.3f | %+.3f ms (x%.2f) | %.3f | %+.3f ms (x%.2f) |\n", n,
                    locd_pairs_count(p1), t1, t2, t2 - t1, t2 / t1, t3, t3 - t1, t3 / t1);
            fflush(f);
            free(b);
        }
        locd_engine_destroy(e1);
        locd_engine_destroy(e2);
        locd_engine_destroy(e3);
        locd_pairs_destroy(p1);
        locd_pairs_destroy(p2);
        locd_pairs_destroy(p3);
    }
    {
        static const int clients[] = {1, 4, 16};
        static const size_t jn[] = {100, 1000};
        size_t k, c;
        fprintf(f, "\n| boxes per job | clients | jobs in flight per client | jobs | jobs/s | failed |\n");
        fprintf(f, "|---:|---:|---:|---:|---:|---:|\n");
        for (k = 0; k < sizeof jn / sizeof jn[0]; k++)
            for (c = 0; c < sizeof clients / sizeof clients[0]; c++) {
                int failed, njobs = 4000;
                double rate = throughput(jobs, clients[c], jn[k], njobs, 32, &failed);
                fprintf(f, "| %zu | %d | 32 | %d | %.0f | %d |\n", jn[k], clients[c], njobs, rate, failed);
                fflush(f);
            }
    }
    if (out)
        fclose(f);
    return 0;
}
