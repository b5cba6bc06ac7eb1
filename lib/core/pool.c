/* A fork-join thread pool that lives as long as its engine: threads are
 * created once, so a call costs a wake-up, not a pthread_create.
 *
 * A wake-up through a condition variable costs tens of microseconds on a
 * virtual machine, and a scene update or a find runs the pool several
 * times in a row with little serial work between. So a thread that finished its part
 * first waits for up to LC_POOL_WAIT_US before it sleeps on the condition
 * variable: the workers for the next run, the caller for the workers. It
 * waits by yielding the CPU (sched_yield), not by spinning on it: a thread
 * that spun with `pause` kept the CPU from the thread it waited for
 * whenever the two shared one (docs/benchmarks.md: one-shot finds of 10^4
 * boxes then took 1.07-1.36 ms in most runs, against 0.70-0.95). The wait is bounded: a pool
 * idle between frames sleeps.
 *
 * On a virtual machine a pool that slept (a game's frame apart) wakes up on
 * one CPU: the guest's scheduler takes the other virtual CPUs, halted, for
 * busy, and puts a woken worker on the caller's own CPU, where it runs only
 * when the caller waits. Two threads then took longer than one (10^4
 * boxes, calls 16 ms apart: bench/results/pool_notes.md). So the caller
 * takes its own CPU out of sleeping workers' sets before it wakes them
 * (steer_off), and a worker that still finds itself on the caller's CPU
 * moves off it (move_off).
 *
 * A run's parts are claimed, not assigned: the caller and the workers
 * take the next part until none is left, so a worker still waking up
 * costs the caller no wait (the first run of a call after a frame's pause
 * had waited for its worker: bench/results/pool_notes.md). */
#if defined(__linux__) && !defined(_GNU_SOURCE)
#define _GNU_SOURCE 1 /* sched_getcpu, sched_setaffinity, pthread_setaffinity_np */
#endif
#include "core/core.h"

#include <pthread.h>
#ifdef _WIN32
#include <windows.h>
#else
#include <sched.h>
#include <unistd.h>
#endif

/* How long a worker waits for the next run by yielding before it sleeps,
 * and how long the caller waits so for the workers to finish theirs: the
 * caller has nothing else to do in the meantime, and a caller that slept
 * was woken by a worker onto that worker's CPU (see move_off), one thread
 * chasing the other from CPU to CPU. A pool of more threads than CPUs
 * keeps the short wait (its threads share CPUs anyway, and a caller that
 * yields takes turns from the workers). */
#define LC_POOL_WAIT_US 50.0
#define LC_POOL_JOIN_US 2000.0

struct lc_pool {
    locd_allocator alloc;
    uint32_t size; /* threads including the caller */
    pthread_t *threads;
    pthread_mutex_t mu;
    pthread_cond_t start_cv, done_cv;
    uint64_t generation; /* atomic; bumped under mu, after fn, ctx and claim are set */
    uint64_t claim;      /* atomic: the run's generation (32 bits), its part count k (16), the next part (16) */
    uint32_t done;       /* atomic: parts of the run finished */
    int stop;            /* under mu */
    struct lc_worker *worker; /* size - 1 */
    lc_task_fn fn;
    void *ctx;
    int caller_cpu; /* atomic: the CPU the caller ran on when it started the run, or -1 */
    int spread;     /* no more threads than CPUs: each may have one of its own */
};

typedef struct lc_worker {
    lc_pool *pool;
    int asleep;  /* under mu: on start_cv */
    int steered; /* under mu: steer_off changed its CPU set while it slept */
} lc_worker;

/* A bounded wait: wait_on() yields the CPU once and says whether the wait
 * may go on (us microseconds from its first call). */
typedef struct lc_wait {
    double end, us;
} lc_wait;

static int wait_on(lc_wait *w)
{
    const double t = lc_now_ms();
    if (!w->end)
        w->end = t + w->us / 1000.0;
    else if (t >= w->end)
        return 0;
#ifdef _WIN32
    SwitchToThread();
#else
    sched_yield();
#endif
    return 1;
}

/* If this worker runs on the caller's CPU, it moves to another CPU it may
 * run on: allowed there no more, the kernel migrates it at once (waking
 * that CPU), and the old set back leaves it where it went. */
static void move_off(int caller_cpu)
{
#if defined(__linux__)
    cpu_set_t allowed, others;
    if (caller_cpu < 0 || caller_cpu >= CPU_SETSIZE || sched_getcpu() != caller_cpu ||
        sched_getaffinity(0, sizeof allowed, &allowed) != 0 || CPU_COUNT(&allowed) < 2)
        return;
    others = allowed;
    CPU_CLR(caller_cpu, &others);
    if (sched_setaffinity(0, sizeof others, &others) == 0)
        (void)sched_setaffinity(0, sizeof allowed, &allowed);
#else
    (void)caller_cpu;
#endif
}

/* Before it wakes sleeping workers, the caller takes its own CPU out of
 * their sets (under mu): woken, they start on another CPU, not behind the
 * caller (move_off). Each puts its own set back once awake (sleep_until). */
static void steer_off(lc_pool *p, int caller_cpu)
{
#if defined(__linux__)
    cpu_set_t others;
    uint32_t t;
    for (t = 0; t + 1 < p->size && !p->worker[t].asleep; t++)
        ;
    if (t + 1 >= p->size) /* (none asleep: most runs, no system call) */
        return;
    if (caller_cpu < 0 || caller_cpu >= CPU_SETSIZE || sched_getaffinity(0, sizeof others, &others) != 0)
        return;
    CPU_CLR(caller_cpu, &others);
    if (CPU_COUNT(&others) == 0)
        return;
    for (t = 0; t + 1 < p->size; t++)
        if (p->worker[t].asleep && pthread_setaffinity_np(p->threads[t], sizeof others, &others) == 0)
            p->worker[t].steered = 1;
#else
    (void)p, (void)caller_cpu;
#endif
}

/* A worker's sleep until the next run (or the stop, returned), its CPU
 * set as it was before if steer_off changed it. */
static int sleep_until(lc_worker *wk, uint64_t seen)
{
    lc_pool *p = wk->pool;
    int stop, steered;
#if defined(__linux__)
    cpu_set_t mine;
    const int have = sched_getaffinity(0, sizeof mine, &mine) == 0;
#endif
    pthread_mutex_lock(&p->mu);
    wk->asleep = 1;
    while (__atomic_load_n(&p->generation, __ATOMIC_ACQUIRE) == seen && !p->stop)
        pthread_cond_wait(&p->start_cv, &p->mu);
    wk->asleep = 0;
    steered = wk->steered;
    wk->steered = 0;
    stop = p->stop;
    pthread_mutex_unlock(&p->mu);
#if defined(__linux__)
    if (have && steered)
        (void)sched_setaffinity(0, sizeof mine, &mine);
#else
    (void)steered;
#endif
    return stop;
}

/* The CPU the calling thread runs on, or -1. */
static int current_cpu(void)
{
#if defined(__linux__)
    return sched_getcpu();
#else
    return -1;
#endif
}

/* Runs parts of run `gen` until none is left to claim. A part is claimed
 * by one compare-and-swap on the claim word, which names the run: a thread
 * that comes late (the run over, or another begun) claims nothing and
 * reads nothing else of it. fn and ctx stay until every part is done, so
 * a claimed part may read them. */
static void run_parts(lc_pool *p, uint64_t gen)
{
    for (;;) {
        uint64_t cur = __atomic_load_n(&p->claim, __ATOMIC_ACQUIRE);
        uint32_t part, k;
        do {
            part = (uint32_t)(cur & 0xffffu), k = (uint32_t)(cur >> 16 & 0xffffu);
            if ((uint32_t)(cur >> 32) != (uint32_t)gen || part >= k)
                return;
        } while (!__atomic_compare_exchange_n(&p->claim, &cur, cur + 1, 0, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE));
        p->fn(p->ctx, part, k);
        if (__atomic_add_fetch(&p->done, 1, __ATOMIC_ACQ_REL) == k) {
            /* the caller may be asleep: it checks done under mu */
            pthread_mutex_lock(&p->mu);
            pthread_cond_signal(&p->done_cv);
            pthread_mutex_unlock(&p->mu);
        }
    }
}

static void *worker_main(void *arg)
{
    lc_worker *wk = arg;
    lc_pool *p = wk->pool;
    uint64_t seen = 0;
    for (;;) {
        lc_wait w = {0.0, LC_POOL_WAIT_US};
        while (__atomic_load_n(&p->generation, __ATOMIC_ACQUIRE) == seen && wait_on(&w))
            ;
        if (__atomic_load_n(&p->generation, __ATOMIC_ACQUIRE) == seen && sleep_until(wk, seen))
            break;
        seen = __atomic_load_n(&p->generation, __ATOMIC_ACQUIRE);
        if (p->spread)
            move_off(__atomic_load_n(&p->caller_cpu, __ATOMIC_RELAXED));
        run_parts(p, seen);
    }
    return NULL;
}

uint32_t lc_cpu_count(void)
{
#ifdef _WIN32
    /* mingw-w64 has no sysconf(_SC_NPROCESSORS_ONLN). */
    long c = (long)GetActiveProcessorCount(ALL_PROCESSOR_GROUPS);
#else
    long c = sysconf(_SC_NPROCESSORS_ONLN);
#endif
    return c < 1 ? 1u : (c > 64 ? 64u : (uint32_t)c);
}

static void stop_threads(lc_pool *p, uint32_t started)
{
    uint32_t t;
    pthread_mutex_lock(&p->mu);
    p->stop = 1;
    pthread_cond_broadcast(&p->start_cv);
    pthread_mutex_unlock(&p->mu);
    for (t = 0; t < started; t++)
        pthread_join(p->threads[t], NULL);
}

locd_status lc_pool_create(const locd_allocator *a, uint32_t threads, lc_pool **out)
{
    lc_pool *p;
    uint32_t t;
    size_t bytes;
    *out = NULL;
    if (threads < 1)
        threads = 1;
    p = lc_alloc(a, sizeof *p);
    if (!p)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the thread pool");
    memset(p, 0, sizeof *p);
    p->alloc = *a;
    p->size = threads;
    p->spread = threads <= lc_cpu_count();
    bytes = (sizeof(pthread_t) + sizeof(lc_worker)) * threads;
    p->threads = lc_alloc(a, bytes);
    if (!p->threads) {
        lc_free(a, p, sizeof *p);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the thread pool");
    }
    p->worker = (lc_worker *)(p->threads + threads);
    pthread_mutex_init(&p->mu, NULL);
    pthread_cond_init(&p->start_cv, NULL);
    pthread_cond_init(&p->done_cv, NULL);
    for (t = 1; t < threads; t++) {
        lc_worker *wk = &p->worker[t - 1];
        wk->pool = p, wk->asleep = 0, wk->steered = 0;
        if (pthread_create(&p->threads[t - 1], NULL, worker_main, wk) != 0) {
            stop_threads(p, t - 1);
            pthread_mutex_destroy(&p->mu);
            pthread_cond_destroy(&p->start_cv);
            pthread_cond_destroy(&p->done_cv);
            lc_free(a, p->threads, bytes);
            lc_free(a, p, sizeof *p);
            return lc_error(LOCD_ERR_THREAD, "could not start thread %u of %u", t, threads);
        }
    }
    *out = p;
    return LOCD_OK;
}

void lc_pool_destroy(lc_pool *p)
{
    locd_allocator a;
    if (!p)
        return;
    stop_threads(p, p->size - 1);
    pthread_mutex_destroy(&p->mu);
    pthread_cond_destroy(&p->start_cv);
    pthread_cond_destroy(&p->done_cv);
    a = p->alloc;
    lc_free(&a, p->threads, (sizeof(pthread_t) + sizeof(lc_worker)) * p->size);
    lc_free(&a, p, sizeof *p);
}

void lc_pool_run(lc_pool *p, uint32_t k, lc_task_fn fn, void *ctx)
{
    uint64_t g;
    if (k > p->size)
        k = p->size;
    if (k <= 1 || p->size == 1) {
        fn(ctx, 0, 1);
        return;
    }
    pthread_mutex_lock(&p->mu);
    p->fn = fn;
    p->ctx = ctx;
    __atomic_store_n(&p->caller_cpu, p->spread ? current_cpu() : -1, __ATOMIC_RELAXED); /* (move_off's only reader) */
    __atomic_store_n(&p->done, 0, __ATOMIC_RELAXED);
    g = __atomic_load_n(&p->generation, __ATOMIC_RELAXED) + 1;
    __atomic_store_n(&p->claim, (g & 0xffffffffu) << 32 | (uint64_t)k << 16, __ATOMIC_RELEASE);
    __atomic_store_n(&p->generation, g, __ATOMIC_RELEASE);
    if (p->spread)
        steer_off(p, __atomic_load_n(&p->caller_cpu, __ATOMIC_RELAXED));
    pthread_cond_broadcast(&p->start_cv);
    pthread_mutex_unlock(&p->mu);
    /* The caller takes parts too: the parts of a worker still waking up
     * (tens of microseconds on a virtual machine, hundreds after a pause
     * of a frame) are the caller's, not a wait. */
    run_parts(p, g);
    {
        lc_wait w = {0.0, p->spread ? LC_POOL_JOIN_US : LC_POOL_WAIT_US};
        while (__atomic_load_n(&p->done, __ATOMIC_ACQUIRE) != k && wait_on(&w))
            ;
    }
    if (__atomic_load_n(&p->done, __ATOMIC_ACQUIRE) != k) {
        pthread_mutex_lock(&p->mu);
        while (__atomic_load_n(&p->done, __ATOMIC_ACQUIRE) != k)
            pthread_cond_wait(&p->done_cv, &p->mu);
        pthread_mutex_unlock(&p->mu);
    }
}
