/* Integration level 2: encode + sort in k worker processes (locd-worker),
 * merge + sweep in the caller, talking through POSIX shared memory and
 * process-shared POSIX semaphores (layout in levels.h).
 *
 * Workers are started once per engine and kept. Every wait on a worker is
 * a sem_timedwait of at most 50 ms followed by a waitpid(WNOHANG) check, so
 * a dead worker is noticed within 50 ms and a silent one after a bounded
 * deadline; the call then kills the whole set, starts a fresh one and redoes
 * the work once (the result is never partial: the caller only merges runs
 * whose worker answered). A second failure returns LOCD_ERR_WORKER and the
 * next call starts again from fresh workers.
 *
 * The result is the level-1 result, pair for pair and in the same order: the
 * grid is fitted exactly as level 1 fits it (same bounds, max_depth,
 * cell_bias, flags), entries are unique, so the merged run is the same
 * sorted array and one serial sweep over it gives level 1's order. */
#define _GNU_SOURCE /* dladdr, posix_spawn_file_actions_addclosefrom_np */
#include "levels/levels.h"

#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

extern char **environ;

#ifndef PATH_MAX
#define PATH_MAX 4096
#endif
#define LC_WORKER_EXE "locd-worker"
/* Below this many objects one worker beats waking the others. */
#define LC_WORKERS_PARALLEL_MIN 4096
#define LC_POLL_MS 50
#define LC_START_TIMEOUT_MS 10000.0
/* How long a round may take before its workers are declared stuck: generous
 * (a loaded machine, a huge scene) but bounded, so that a stopped worker
 * cannot hang the caller. */
#define LC_ROUND_TIMEOUT_MS 30000.0
#define LC_ROUND_TIMEOUT_MS_PER_OBJECT 0.01

typedef struct lc_workers {
    uint32_t k;
    pid_t pid[LC_MAX_THREADS];
    int exit_status[LC_MAX_THREADS];
    lc_shm_ctl *ctl;
    char ctl_name[LC_SHM_NAME_MAX];
    int ctl_linked; /* name still in /dev/shm */
    void *data;
    size_t data_size;
    char data_name[LC_SHM_NAME_MAX];
    int data_linked;
    int running;
    char exe[PATH_MAX];
    lc_buf merged;    /* uint64 entries */
    locd_pairs pairs; /* the sweep's output before it is handed over */
    double per_object;
    int kernel; /* LC_KERNEL_* for the host's stages, chosen when the engine is created */
} lc_workers;

/* ---- shared memory segments ---- */

/* Creates a fresh segment of `size` bytes (mode 0600, exclusive) and maps
 * it. Space is reserved up front so that a full /dev/shm is an error here,
 * not a SIGBUS later. */
static locd_status create_segment(char *name, size_t len, size_t size, void **map)
{
    int fd = -1, tries, rc;
    for (tries = 0; tries < 8 && fd < 0; tries++) {
        lc_shm_unique_name(name, len, "");
        fd = shm_open(name, O_RDWR | O_CREAT | O_EXCL, 0600);
        if (fd < 0 && errno != EEXIST)
            break;
    }
    if (fd < 0)
        return lc_error(LOCD_ERR_IO, "shm_open(%s): %s", name, strerror(errno));
    if (ftruncate(fd, (off_t)size) != 0) {
        rc = errno;
        goto fail;
    }
    if ((rc = posix_fallocate(fd, 0, (off_t)size)) != 0 && rc != EINVAL && rc != EOPNOTSUPP)
        goto fail;
    *map = mmap(NULL, size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    if (*map == MAP_FAILED) {
        rc = errno;
        goto fail;
    }
    close(fd);
    return LOCD_OK;
fail:
    close(fd);
    shm_unlink(name);
    return lc_error(LOCD_ERR_IO, "shared memory segment %s of %zu bytes: %s", name, size, strerror(rc));
}

/* ---- finding and starting the workers ---- */

static int is_executable(const char *p)
{
    struct stat sb;
    return p && p[0] && stat(p, &sb) == 0 && S_ISREG(sb.st_mode) && access(p, X_OK) == 0;
}

/* dir of `file` + "/" + name into out; 1 on success, 0 when file has no
 * directory or the path does not fit. */
static int sibling(const char *file, const char *name, char *out, size_t len)
{
    const char *slash = strrchr(file, '/');
    int w;
    if (!slash)
        return 0;
    w = snprintf(out, len, "%.*s/%s", (int)(slash - file), file, name);
    return w >= 0 && (size_t)w < len;
}

/* Any object of this library: dladdr names the file it was loaded from. */
static const char lc_worker_anchor = 0;

/* config.worker_path, then $LOCD_WORKER, then the installed libexec path,
 * then next to the running library, then next to the running program. */
static locd_status find_worker(const locd_engine *e, char *out, size_t len)
{
    const char *env = getenv("LOCD_WORKER");
    char buf[PATH_MAX];
    Dl_info info;
    ssize_t r;
    if (e->cfg.worker_path) {
        if (!is_executable(e->cfg.worker_path))
            return lc_error(LOCD_ERR_INVALID_ARGUMENT, "worker_path '%s' is not an executable file",
                            e->cfg.worker_path);
        snprintf(out, len, "%s", e->cfg.worker_path);
        return LOCD_OK;
    }
    if (env && env[0]) {
        if (!is_executable(env))
            return lc_error(LOCD_ERR_INVALID_ARGUMENT, "LOCD_WORKER='%s' is not an executable file", env);
        snprintf(out, len, "%s", env);
        return LOCD_OK;
    }
#ifdef LOCD_LIBEXECDIR
    snprintf(buf, sizeof buf, "%s/%s", LOCD_LIBEXECDIR, LC_WORKER_EXE);
    if (is_executable(buf)) {
        snprintf(out, len, "%s", buf);
        return LOCD_OK;
    }
#endif
    if (dladdr(&lc_worker_anchor, &info) && info.dli_fname && sibling(info.dli_fname, LC_WORKER_EXE, buf, sizeof buf) &&
        is_executable(buf)) {
        snprintf(out, len, "%s", buf);
        return LOCD_OK;
    }
    r = readlink("/proc/self/exe", out, len - 1);
    if (r > 0) {
        out[r] = '\0';
        if (sibling(out, LC_WORKER_EXE, buf, sizeof buf) && is_executable(buf)) {
            snprintf(out, len, "%s", buf);
            return LOCD_OK;
        }
    }
    return lc_error(LOCD_ERR_UNSUPPORTED, "cannot find the %s executable (set config.worker_path or LOCD_WORKER)",
                    LC_WORKER_EXE);
}

static locd_status spawn_worker(lc_workers *w, uint32_t i)
{
    char idx[16], ppid[24];
    char *argv[5];
    posix_spawn_file_actions_t fa;
    posix_spawnattr_t attr;
    sigset_t none, dflt;
    int rc;
    snprintf(idx, sizeof idx, "%u", i);
    snprintf(ppid, sizeof ppid, "%ld", (long)getpid());
    argv[0] = w->exe;
    argv[1] = w->ctl_name;
    argv[2] = idx;
    argv[3] = ppid;
    argv[4] = NULL;
    posix_spawn_file_actions_init(&fa);
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 34))
    posix_spawn_file_actions_addclosefrom_np(&fa, 3); /* the host's sockets and files stay in the host */
#endif
    posix_spawnattr_init(&attr);
    sigemptyset(&none);
    sigemptyset(&dflt);
    sigaddset(&dflt, SIGINT);
    sigaddset(&dflt, SIGTERM);
    sigaddset(&dflt, SIGPIPE);
    sigaddset(&dflt, SIGHUP);
    posix_spawnattr_setsigmask(&attr, &none);
    posix_spawnattr_setsigdefault(&attr, &dflt);
    /* Own process group: a terminal's Ctrl-C goes to the host, which decides;
       an orphaned worker notices its parent is gone and exits by itself. */
    posix_spawnattr_setpgroup(&attr, 0);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETPGROUP);
    rc = posix_spawn(&w->pid[i], w->exe, &fa, &attr, argv, environ);
    posix_spawnattr_destroy(&attr);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) {
        w->pid[i] = 0;
        return lc_error(LOCD_ERR_WORKER, "cannot start %s: %s", w->exe, strerror(rc));
    }
    return LOCD_OK;
}

/* 1 while worker i runs; reaps it otherwise. */
static int worker_alive(lc_workers *w, uint32_t i)
{
    int status = 0;
    pid_t r;
    if (w->pid[i] <= 0)
        return 0;
    do
        r = waitpid(w->pid[i], &status, WNOHANG);
    while (r < 0 && errno == EINTR);
    if (r == 0)
        return 1;
    if (r < 0 && errno == ECHILD && kill(w->pid[i], 0) == 0) /* the host reaps children itself */
        return 1;
    w->exit_status[i] = status;
    w->pid[i] = 0;
    return 0;
}

static const char *death_reason(const lc_workers *w, uint32_t i, char *buf, size_t len)
{
    int s = w->exit_status[i];
    if (WIFSIGNALED(s))
        snprintf(buf, len, "killed by signal %d", WTERMSIG(s));
    else if (WIFEXITED(s))
        snprintf(buf, len, "exited with status %d", WEXITSTATUS(s));
    else
        snprintf(buf, len, "is gone");
    return buf;
}

/* Waits for worker i's `done`, never longer than until `deadline` (ms on
 * lc_now_ms's clock), checking every LC_POLL_MS that the worker lives. */
static locd_status wait_done(lc_workers *w, uint32_t i, double deadline)
{
    char why[64];
    pid_t pid = w->pid[i];
    for (;;) {
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        ts.tv_nsec += LC_POLL_MS * 1000000L;
        if (ts.tv_nsec >= 1000000000L) {
            ts.tv_sec++;
            ts.tv_nsec -= 1000000000L;
        }
        if (sem_timedwait(&w->ctl->slot[i].done, &ts) == 0)
            return LOCD_OK;
        if (errno == EINTR)
            continue;
        if (!worker_alive(w, i))
            return lc_error(LOCD_ERR_WORKER, "worker %u (pid %ld) %s", i, (long)pid,
                            death_reason(w, i, why, sizeof why));
        if (lc_now_ms() > deadline)
            return lc_error(LOCD_ERR_WORKER, "worker %u (pid %ld) did not answer in time", i, (long)pid);
    }
}

static void unlink_data(lc_workers *w)
{
    if (w->data_linked) {
        shm_unlink(w->data_name);
        w->data_linked = 0;
    }
}

/* Kills and reaps every worker and drops both segments. */
static void stop_workers(lc_workers *w, int graceful)
{
    uint32_t i;
    if (w->ctl && graceful) {
        double until = lc_now_ms() + 1000.0;
        w->ctl->command = LC_SHM_CMD_EXIT;
        for (i = 0; i < w->k; i++)
            if (w->pid[i] > 0)
                sem_post(&w->ctl->slot[i].go);
        for (i = 0; i < w->k; i++) {
            struct timespec pause = {0, 1000000L};
            while (worker_alive(w, i) && lc_now_ms() < until)
                nanosleep(&pause, NULL);
        }
    }
    for (i = 0; i < w->k; i++)
        if (w->pid[i] > 0) {
            kill(w->pid[i], SIGKILL);
            while (waitpid(w->pid[i], NULL, 0) < 0 && errno == EINTR)
                ;
            w->pid[i] = 0;
        }
    if (w->ctl_linked) {
        shm_unlink(w->ctl_name);
        w->ctl_linked = 0;
    }
    unlink_data(w);
    if (w->ctl) {
        for (i = 0; i < w->k; i++) {
            sem_destroy(&w->ctl->slot[i].go);
            sem_destroy(&w->ctl->slot[i].done);
        }
        munmap(w->ctl, sizeof *w->ctl);
        w->ctl = NULL;
    }
    if (w->data) {
        munmap(w->data, w->data_size);
        w->data = NULL;
        w->data_size = 0;
    }
    w->running = 0;
}

static locd_status start_workers(lc_workers *w)
{
    locd_status st;
    void *map;
    uint32_t i;
    double deadline;
    if ((st = create_segment(w->ctl_name, sizeof w->ctl_name, sizeof(lc_shm_ctl), &map)) != LOCD_OK)
        return st;
    w->ctl = map;
    w->ctl_linked = 1;
    memset(w->ctl, 0, sizeof *w->ctl);
    w->ctl->magic = LC_SHM_MAGIC;
    w->ctl->version = LC_SHM_VERSION;
    w->ctl->workers = w->k;
    w->ctl->kernel = w->kernel;
    snprintf(w->ctl->ctl_name, sizeof w->ctl->ctl_name, "%s", w->ctl_name);
    for (i = 0; i < w->k; i++)
        if (sem_init(&w->ctl->slot[i].go, 1, 0) != 0 || sem_init(&w->ctl->slot[i].done, 1, 0) != 0) {
            st = lc_error(LOCD_ERR_IO, "sem_init: %s", strerror(errno));
            goto fail;
        }
    for (i = 0; i < w->k; i++)
        if ((st = spawn_worker(w, i)) != LOCD_OK)
            goto fail;
    /* Each worker posts `done` once it has mapped the control segment. */
    deadline = lc_now_ms() + LC_START_TIMEOUT_MS;
    for (i = 0; i < w->k; i++)
        if ((st = wait_done(w, i, deadline)) != LOCD_OK)
            goto fail;
    shm_unlink(w->ctl_name); /* every party has it open */
    w->ctl_linked = 0;
    w->running = 1;
    return LOCD_OK;
fail:
    stop_workers(w, 0);
    return st;
}

/* ---- the backend ---- */

static locd_status workers_open(locd_engine *e)
{
    lc_workers *w;
    locd_status st;
    if (e->threads > LC_MAX_THREADS)
        e->threads = LC_MAX_THREADS;
    w = lc_alloc(&e->alloc, sizeof *w);
    if (!w)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the workers state");
    memset(w, 0, sizeof *w);
    w->k = e->threads;
    w->per_object = lc_entries_per_object_guess(e->cfg.cell_bias);
    w->kernel = lc_kernel_choose();
    lc_pairs_init_embedded(&w->pairs, &e->alloc);
    if ((st = find_worker(e, w->exe, sizeof w->exe)) != LOCD_OK || (st = start_workers(w)) != LOCD_OK) {
        lc_free(&e->alloc, w, sizeof *w);
        return st;
    }
    e->backend = w;
    lc_engine_log(e, LOCD_LOG_DEBUG, "level 2: %u workers from %s", w->k, w->exe);
    return LOCD_OK;
}

static void workers_close(locd_engine *e)
{
    lc_workers *w = e->backend;
    if (!w)
        return;
    /* locd_engine_destroy has waited for the engine to be idle (no find,
       no job thread) before it closes the level. */
    stop_workers(w, 1);
    lc_buf_release(&e->alloc, &w->merged, sizeof(uint64_t));
    lc_pairs_fini_embedded(&w->pairs);
    lc_free(&e->alloc, w, sizeof *w);
    e->backend = NULL;
}

/* Makes the data segment at least `need` bytes (a new, larger segment;
 * workers map it on their next round, and its name goes once they have). */
static locd_status ensure_data(lc_workers *w, size_t need)
{
    char name[LC_SHM_NAME_MAX];
    size_t size = need;
    void *map;
    locd_status st;
    if (w->data && need <= w->data_size)
        return LOCD_OK;
    if (size < w->data_size + w->data_size / 2)
        size = w->data_size + w->data_size / 2;
    size = (size + 65535) & ~(size_t)65535;
    if ((st = create_segment(name, sizeof name, size, &map)) != LOCD_OK)
        return st;
    if (w->data) {
        munmap(w->data, w->data_size);
        unlink_data(w);
    }
    w->data = map;
    w->data_size = size;
    w->data_linked = 1;
    memcpy(w->data_name, name, sizeof name);
    memcpy(w->ctl->data_name, name, sizeof name);
    w->ctl->data_size = size;
    w->ctl->data_gen++;
    return LOCD_OK;
}

/* One call's input, as every stage after the grid fit reads it. */
typedef struct lc_call {
    const void *boxes;
    size_t n;
    size_t split; /* two-set query: first object of set b (0: one set) */
    int f64;
    locd_grid grid;
} lc_call;

/* Bytes of the call's boxes (6 coordinates each). */
static size_t box_bytes_of(const lc_call *c)
{
    return c->n * 6 * (c->f64 ? sizeof(double) : sizeof(float));
}

/* Copies the boxes into the data segment and starts every worker on its
 * share; returns when the workers were started (ms on lc_now_ms's clock).
 * Every worker takes part (idle ones with an empty share): that is how each
 * one maps a new data segment before its name goes. */
static double post_round(lc_workers *w, const lc_call *c, const lc_plan *r, size_t regions_at, locd_stats *stats)
{
    double t0 = lc_now_ms(), t1;
    uint32_t t;
    memcpy(w->data, c->boxes, box_bytes_of(c));
    t1 = lc_now_ms();
    stats->ms_transfer += t1 - t0;
    w->ctl->command = LC_SHM_CMD_RUN;
    w->ctl->grid = c->grid;
    w->ctl->n = c->n;
    w->ctl->f64 = c->f64;
    for (t = 0; t < w->k; t++) {
        lc_shm_slot *s = &w->ctl->slot[t];
        s->first = t < r->k ? lc_chunk_begin(c->n, t, r->k) : 0;
        s->count = t < r->k ? lc_chunk_begin(c->n, t + 1, r->k) - s->first : 0;
        s->offset = t < r->k ? regions_at + r->off[t] * sizeof(uint64_t) : 0;
        s->capacity = t < r->k ? r->cap[t] : 0;
        s->status = LOCD_ERR_INTERNAL;
        s->written = 0;
        sem_post(&s->go);
    }
    return t1;
}

/* Waits for every worker posted at `posted` and reads back its run; an
 * overflowed region gets the exact size its worker asked for, and *again
 * says that the round must be redone. */
static locd_status collect_round(lc_workers *w, size_t n, lc_plan *r, double posted, locd_stats *stats, int *again)
{
    double deadline = posted + LC_ROUND_TIMEOUT_MS + (double)n * LC_ROUND_TIMEOUT_MS_PER_OBJECT, slowest = 0.0;
    uint32_t t;
    locd_status st;
    for (t = 0; t < w->k; t++)
        if ((st = wait_done(w, t, deadline)) != LOCD_OK)
            return st;
    unlink_data(w); /* every worker has mapped it */
    *again = 0;
    for (t = 0; t < r->k; t++) {
        const lc_shm_slot *s = &w->ctl->slot[t];
        if (s->status == LOCD_ERR_BUFFER_TOO_SMALL) {
            r->cap[t] = s->written;
            *again = 1;
        } else if (s->status != LOCD_OK) {
            return lc_error(LOCD_ERR_WORKER, "worker %u failed: %s", t, locd_status_string(s->status));
        } else {
            r->cnt[t] = s->written;
            r->runs[t] = (const uint64_t *)((const char *)w->data + s->offset);
            if (s->ms_encode + s->ms_sort > slowest) {
                slowest = s->ms_encode + s->ms_sort;
                stats->ms_encode = s->ms_encode;
                stats->ms_sort = s->ms_sort;
            }
        }
    }
    stats->ms_transfer += (lc_now_ms() - posted) - slowest; /* semaphore round trip */
    return LOCD_OK;
}

/* One round trip: boxes into shared memory, every worker encodes and sorts
 * its share, runs come back in the data segment after the boxes. Redone
 * with exact region sizes when a region overflows. */
static locd_status run_round(lc_workers *w, const lc_call *c, lc_plan *r, locd_stats *stats)
{
    size_t regions_at = (box_bytes_of(c) + 63) & ~(size_t)63; /* the entry regions, on a cache line after the boxes */
    locd_status st;
    int again;
    lc_plan_regions(r, c->n, w->per_object);
    do {
        double posted;
        if ((st = ensure_data(w, regions_at + lc_plan_layout(r) * sizeof(uint64_t))) != LOCD_OK)
            return st;
        posted = post_round(w, c, r, regions_at, stats);
        if ((st = collect_round(w, c->n, r, posted, stats, &again)) != LOCD_OK)
            return st;
    } while (again);
    w->per_object = lc_plan_finish(r, c->n);
    return LOCD_OK;
}

/* The round on a set of workers; whatever goes wrong, that set is not
 * trusted again, and a worker failure is redone once on a fresh set. */
static locd_status encode_sort(locd_engine *e, const lc_call *c, lc_plan *r, locd_stats *stats)
{
    lc_workers *w = e->backend;
    locd_status st;
    int attempt;
    for (attempt = 0;; attempt++) {
        if (!w->running && (st = start_workers(w)) != LOCD_OK)
            return st;
        if ((st = run_round(w, c, r, stats)) == LOCD_OK)
            return LOCD_OK;
        lc_engine_log(e, LOCD_LOG_WARNING, "level 2: %s; restarting the workers", locd_last_error());
        stop_workers(w, 0);
        if (st != LOCD_ERR_WORKER || attempt >= 1)
            return st;
    }
}

/* Merges the workers' runs in the caller; *sorted gets the merged entries. */
static locd_status merge_runs(locd_engine *e, const lc_plan *r, const uint64_t **sorted, locd_stats *stats)
{
    lc_workers *w = e->backend;
    double t0 = lc_now_ms();
    locd_status st;
    if (r->k > 1) {
        if ((st = lc_buf_reserve(&e->alloc, &w->merged, sizeof(uint64_t), r->total)) != LOCD_OK)
            return st;
        if ((st = locd_merge_entries(r->runs, r->cnt, r->k, w->merged.data)) != LOCD_OK)
            return st;
        *sorted = w->merged.data;
    } else {
        *sorted = r->runs[0];
    }
    stats->ms_merge = lc_now_ms() - t0;
    return LOCD_OK;
}

/* One serial sweep, into the engine's own buffer first: a failure (even in
 * the ordering) must leave *out as it was. */
static locd_status sweep_and_give(lc_workers *w, const lc_call *c, const uint64_t *sorted, size_t total,
                                  uint32_t flags, locd_pairs *out, locd_stats *stats)
{
    locd_stats sw;
    double t0 = lc_now_ms();
    locd_status st;
    locd_stats_init(&sw);
    st = c->f64 ? lc_block_sweep_f64(&c->grid, c->boxes, c->n, sorted, total, c->split, &w->pairs, &sw, w->kernel)
                : lc_block_sweep_f32(&c->grid, c->boxes, c->n, sorted, total, c->split, &w->pairs, &sw, w->kernel);
    if (st)
        return st;
    stats->pairs = sw.pairs;
    stats->candidates = sw.candidates;
    stats->exact_tests = sw.exact_tests;
    stats->ms_sweep = lc_now_ms() - t0;
    if ((flags & LOCD_FIND_SORTED) && (st = lc_order_pairs(&w->pairs, stats)) != LOCD_OK)
        return st;
    return lc_pairs_give(&w->pairs, out);
}

/* One octree over all n objects; with split > 0 the sweep keeps only the
 * pairs across [0, split) and [split, n) (the two-set query). */
static locd_status workers_run(locd_engine *e, const void *boxes, size_t n, size_t split, int f64, uint32_t flags,
                               locd_pairs *out, locd_stats *stats)
{
    lc_workers *w = e->backend;
    lc_call c;
    lc_plan r;
    const uint64_t *sorted;
    locd_status st;
    double t0;

    stats->objects = n;
    t0 = lc_now_ms();
    c.boxes = boxes;
    c.n = n;
    c.split = split;
    c.f64 = f64;
    /* The same validation and root cube as level 1 (the grid-fit building block). */
    st = f64 ? lc_block_grid_fit_f64(boxes, n, e->cfg.max_depth, e->cfg.cell_bias, e->cfg.flags, &c.grid, w->kernel)
             : lc_block_grid_fit_f32(boxes, n, e->cfg.max_depth, e->cfg.cell_bias, e->cfg.flags, &c.grid, w->kernel);
    if (st)
        return st;
    if (n < 2 || (split && split >= n)) { /* no pair; every box was validated above */
        out->count = 0;
        stats->threads = 1;
        return LOCD_OK;
    }
    stats->depth = c.grid.depth;
    stats->ms_bounds = lc_now_ms() - t0;

    memset(&r, 0, sizeof r);
    r.k = n < LC_WORKERS_PARALLEL_MIN ? 1 : w->k;
    stats->threads = r.k;
    if ((st = encode_sort(e, &c, &r, stats)) != LOCD_OK)
        return st;
    stats->entries = r.total;
    if ((st = merge_runs(e, &r, &sorted, stats)) != LOCD_OK)
        return st;
    return sweep_and_give(w, &c, sorted, r.total, flags, out, stats);
}

static locd_status workers_find(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags,
                                locd_pairs *out, locd_stats *stats)
{
    return workers_run(e, boxes, n, 0, f64, flags, out, stats);
}

static locd_status workers_find_between(locd_engine *e, const void *boxes, size_t n, size_t split, int f64,
                                        uint32_t flags, locd_pairs *out, locd_stats *stats)
{
    /* An empty set a (split 0) has no pair either: validate, as for an empty b. */
    return workers_run(e, boxes, n, split ? split : n, f64, flags, out, stats);
}

const lc_backend lc_workers_backend = {"worker processes", workers_open, workers_close, workers_find, NULL,
                                       workers_find_between};
