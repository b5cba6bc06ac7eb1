/* The level-1 thread pool (lib/core/pool.c): when lc_pool_run returns,
 * every part of the run has been done exactly once and its writes are
 * visible to the caller, whichever thread claimed it (a part of a worker
 * still waking up is the caller's) and whichever way each thread waited;
 * no part of a finished run is run late. A thread yields the CPU for a
 * bounded time, then sleeps on a condition variable; these tests drive
 * each of the four waits: workers that find the next run while they yield
 * or only after they slept, and a caller that finds the workers done while
 * it yields or only after it slept. Each run's parts write plain (non-atomic) memory,
 * which the caller then reads: under ThreadSanitizer (CI step 40-sanitize)
 * a missing happens-before edge is a reported race. */
#if defined(__linux__) && !defined(_GNU_SOURCE)
#define _GNU_SOURCE 1 /* sched_getaffinity, sched_getcpu */
#endif
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#if defined(__linux__)
#include <dirent.h>
#include <sched.h>
#include <stdlib.h>
#endif

#include "runner.h"

#include "core/core.h"

#define LT_POOL_MAX 4
#define LT_CELLS 64

typedef struct run_ctx {
    uint64_t run;                          /* the run's number, read by every part */
    uint64_t cell[LT_POOL_MAX][LT_CELLS];  /* part t writes row t */
    uint32_t calls[LT_POOL_MAX];           /* runs of each part, over all runs */
    uint32_t nap_tid;                      /* this part sleeps nap_us first (LT_POOL_MAX: none) */
    uint32_t nap_us;
    int bad_args;                          /* a part called with t >= k or k past the pool */
} run_ctx;

static void nap(uint32_t us)
{
    struct timespec ts;
    ts.tv_sec = 0;
    ts.tv_nsec = (long)us * 1000L;
    nanosleep(&ts, NULL);
}

static void part(void *arg, uint32_t t, uint32_t k)
{
    run_ctx *c = arg;
    size_t x;
    if (t >= k || k > LT_POOL_MAX) { /* (no Unity assertion off the main thread) */
        c->bad_args = 1;
        return;
    }
    if (t == c->nap_tid)
        nap(c->nap_us);
    for (x = 0; x < LT_CELLS; x++)
        c->cell[t][x] = c->run * LT_CELLS + x + t;
    c->calls[t]++;
}

/* Runs the pool `runs` times with k cycling through 1..size (so some
 * workers sit runs out); after each run, rows [0, k) hold this run's values
 * and rows past k are untouched. gap_us: the caller's sleep between runs. */
static void drive(uint32_t size, uint32_t runs, uint32_t gap_us, uint32_t nap_tid, uint32_t nap_us)
{
    static run_ctx c;
    uint32_t r, t, want[LT_POOL_MAX] = {0};
    lc_pool *p = NULL;
    locd_allocator a;
    size_t x;
    lc_allocator_resolve(&a, NULL);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, lc_pool_create(&a, size, &p));
    memset(&c, 0, sizeof c);
    c.nap_tid = nap_tid, c.nap_us = nap_us;
    for (r = 1; r <= runs; r++) {
        const uint32_t k = 1 + r % size;
        uint64_t before[LT_POOL_MAX][LT_CELLS];
        memcpy(before, c.cell, sizeof before);
        c.run = r;
        lc_pool_run(p, k, part, &c);
        if (c.bad_args) {
            LT_FAIL("run %u: a part was called with t >= k or k > %u", r, LT_POOL_MAX);
            lc_pool_destroy(p);
            return;
        }
        for (t = 0; t < size; t++) {
            want[t] += t < k;
            for (x = 0; x < LT_CELLS; x++) {
                const uint64_t v = c.cell[t][x], w = t < k ? (uint64_t)r * LT_CELLS + x + t : before[t][x];
                if (v != w) {
                    LT_FAIL("run %u of %u threads (k %u): part %u's cell %zu is %llu, expected %llu", r, size,
                            k, t, x, (unsigned long long)v, (unsigned long long)w);
                    lc_pool_destroy(p);
                    return;
                }
            }
            if (c.calls[t] != want[t]) {
                LT_FAIL("run %u: part %u ran %u times, expected %u", r, t, c.calls[t], want[t]);
                lc_pool_destroy(p);
                return;
            }
        }
        if (gap_us)
            nap(gap_us);
    }
    lc_pool_destroy(p);
}

/* Runs back to back: the workers find each run while they yield, the
 * caller finds them done while it yields (as a scene update's passes). */
static void back_to_back_runs_finish_every_part(void)
{
    drive(2, 20000, 0, LT_POOL_MAX, 0);
    drive(LT_POOL_MAX, 5000, 0, LT_POOL_MAX, 0); /* more threads than cores on a 2-core machine */
}

/* 2 ms between runs, past the workers' bounded wait: each run wakes sleeping
 * workers through the condition variable. */
static void runs_wake_sleeping_workers(void)
{
    drive(2, 200, 2000, LT_POOL_MAX, 0);
    drive(3, 100, 2000, LT_POOL_MAX, 0);
}

/* A worker's part sleeps 2 ms, past the caller's bounded wait: the caller sleeps
 * until that worker's signal. */
static void caller_sleeps_until_the_last_part(void)
{
    drive(2, 200, 0, 1, 2000);
    drive(3, 100, 0, 2, 2000);
}

/* The caller's own part is the slow one: the workers finish first and
 * wait (or sleep) for the next run. */
static void caller_part_slowest(void)
{
    drive(2, 200, 0, 0, 2000);
}

/* A pool made and destroyed at once, and one destroyed while its workers
 * wait after a run: destroy returns (the workers see the stop). */
static void destroy_while_idle_or_waiting(void)
{
    lc_pool *p = NULL;
    locd_allocator a;
    static run_ctx c;
    int i;
    lc_allocator_resolve(&a, NULL);
    for (i = 0; i < 50; i++) {
        TEST_ASSERT_EQUAL_INT(LOCD_OK, lc_pool_create(&a, 2, &p));
        if (i % 2) {
            memset(&c, 0, sizeof c);
            c.nap_tid = LT_POOL_MAX, c.run = 1;
            lc_pool_run(p, 2, part, &c);
            TEST_ASSERT_EQUAL_UINT32(1, c.calls[1]);
        }
        lc_pool_destroy(p);
    }
}

#if defined(__linux__)
/* The first thread of the process whose CPU set is not `want` (its set in
 * *now), 0 when none, -1 when /proc cannot be read; *threads counted. */
static long changed_thread(const cpu_set_t *want, cpu_set_t *now, int *threads)
{
    DIR *d = opendir("/proc/self/task");
    struct dirent *e;
    long bad = 0;
    *threads = 0;
    if (!d)
        return -1;
    while (!bad && (e = readdir(d)) != NULL) {
        const long tid = strtol(e->d_name, NULL, 10);
        if (tid <= 0)
            continue;
        ++*threads;
        if (sched_getaffinity((pid_t)tid, sizeof *now, now) != 0)
            bad = -1;
        else if (!CPU_EQUAL(want, now))
            bad = tid;
    }
    closedir(d);
    return bad;
}
#endif

/* A woken worker starts away from the caller's CPU: the caller takes its
 * CPU out of the sleeping workers' sets, and each puts its own set back
 * once awake. After runs that woke sleeping workers, every thread of the
 * process may again run on every CPU it could before (a worker left
 * without the caller's CPU would share one with it whenever the caller
 * moved there). Linux only, and only with two CPUs or more. */
static void woken_workers_get_their_cpus_back(void)
{
#if defined(__linux__)
    cpu_set_t before, now;
    lc_pool *p = NULL;
    locd_allocator a;
    static run_ctx c;
    long bad_tid = 0;
    int r, tries, threads = 0;
    TEST_ASSERT_EQUAL_INT(0, sched_getaffinity(0, sizeof before, &before));
    if (CPU_COUNT(&before) < 2) {
        TEST_IGNORE_MESSAGE("one CPU: no worker is steered");
        return;
    }
    lc_allocator_resolve(&a, NULL);
    TEST_ASSERT_EQUAL_INT(LOCD_OK, lc_pool_create(&a, 2, &p));
    memset(&c, 0, sizeof c);
    c.nap_tid = LT_POOL_MAX;
    for (r = 1; r <= 20; r++) {
        nap(2000); /* past the workers' bounded wait: they sleep */
        c.run = (uint64_t)r;
        lc_pool_run(p, 2, part, &c);
    }
    /* The last woken worker puts its set back once it runs (the caller may
     * have done both parts before): up to 2 s on a loaded machine. */
    for (tries = 0; tries < 200 && (bad_tid = changed_thread(&before, &now, &threads)) != 0; tries++)
        nap(10000);
    lc_pool_destroy(p);
    if (bad_tid < 0)
        LT_FAIL("could not read the threads' CPU sets (/proc/self/task)");
    else if (bad_tid > 0)
        LT_FAIL("thread %ld may run on %d CPUs after the runs, %d before", bad_tid, CPU_COUNT(&now),
                CPU_COUNT(&before));
    else
        TEST_ASSERT_TRUE_MESSAGE(threads >= 2, "the pool's worker is among the process's threads");
#else
    TEST_IGNORE_MESSAGE("CPU sets: Linux only");
#endif
}

int main(void)
{
    static const lt_test tests[] = {
        LT_TEST(back_to_back_runs_finish_every_part),
        LT_TEST(runs_wake_sleeping_workers),
        LT_TEST(caller_sleeps_until_the_last_part),
        LT_TEST(caller_part_slowest),
        LT_TEST(destroy_while_idle_or_waiting),
        LT_TEST(woken_workers_get_their_cpus_back),
    };
    return LT_RUN(tests);
}
