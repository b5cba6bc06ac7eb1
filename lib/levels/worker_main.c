/* locd-worker: one level-2 worker process (levels/workers.c starts it).
 *
 *   locd-worker CONTROL_SEGMENT INDEX PARENT_PID
 *
 * Maps the control segment, says it is ready, then loops: wait for `go`,
 * encode + sort its share of the boxes into its region of the data segment,
 * post `done`. It checks every second that its parent still lives; an
 * orphan removes the segment names it knows (in case the parent died before
 * removing them) and exits, so a crashed host leaves nothing behind.
 *
 * It is linked from the library's core and octree objects rather than
 * against liblocd.so, so that it runs the internal steps with the SIMD
 * kernel its engine chose at creation (lc_shm_ctl.kernel). */

#include "levels/levels.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static void *map_segment(const char *name, size_t min_size, size_t *size)
{
    struct stat sb;
    void *p;
    int fd = shm_open(name, O_RDWR, 0);
    if (fd < 0)
        return NULL;
    if (fstat(fd, &sb) != 0 || (size_t)sb.st_size < min_size) {
        close(fd);
        return NULL;
    }
    p = mmap(NULL, (size_t)sb.st_size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    close(fd);
    if (p == MAP_FAILED)
        return NULL;
    *size = (size_t)sb.st_size;
    return p;
}

typedef struct worker {
    lc_shm_ctl *ctl;
    lc_shm_slot *slot;
    uint64_t gen;
    void *data;
    size_t data_size;
    uint64_t *scratch;
    size_t scratch_cap;
    int kernel; /* the engine's choice, capped by this CPU: read once at start */
} worker;

static int32_t run_share(worker *w)
{
    lc_shm_ctl *c = w->ctl;
    lc_shm_slot *s = w->slot;
    locd_grid grid = c->grid;
    size_t es = c->f64 ? sizeof(double) : sizeof(float), written = 0;
    uint64_t *entries;
    locd_status st;
    double t0, t1;
    if (c->data_gen != w->gen) {
        if (w->data)
            munmap(w->data, w->data_size);
        w->data = map_segment(c->data_name, 0, &w->data_size);
        if (!w->data)
            return LOCD_ERR_IO;
        w->gen = c->data_gen;
    }
    if (s->count == 0) {
        s->written = 0;
        return LOCD_OK;
    }
    if (c->n > w->data_size / (6 * es) || s->first + s->count > c->n || s->offset > w->data_size ||
        s->capacity > (w->data_size - s->offset) / sizeof(uint64_t))
        return LOCD_ERR_PROTOCOL;
    entries = (uint64_t *)((char *)w->data + s->offset);
    t0 = now_ms();
    st = c->f64 ? lc_block_encode_f64(&grid, w->data, s->first, s->count, entries, s->capacity, &written, w->kernel)
                : lc_block_encode_f32(&grid, w->data, s->first, s->count, entries, s->capacity, &written, w->kernel);
    s->written = written;
    if (st)
        return st;
    t1 = now_ms();
    if (written > w->scratch_cap) {
        free(w->scratch);
        w->scratch_cap = written + written / 4;
        w->scratch = malloc(w->scratch_cap * sizeof(uint64_t));
        if (!w->scratch) {
            w->scratch_cap = 0;
            return LOCD_ERR_NO_MEMORY;
        }
    }
    st = locd_sort_entries(&grid, entries, w->scratch, written);
    s->ms_encode = t1 - t0;
    s->ms_sort = now_ms() - t1;
    return st;
}

int main(int argc, char **argv)
{
    worker w;
    size_t ctl_size;
    unsigned long idx;
    long ppid;
    if (argc != 4) {
        fprintf(stderr, "usage: locd-worker CONTROL_SEGMENT INDEX PARENT_PID (started by liblocd, level 2)\n");
        return 2;
    }
    idx = strtoul(argv[2], NULL, 10);
    ppid = strtol(argv[3], NULL, 10);
    if ((long)getppid() != ppid)
        return 3;
    memset(&w, 0, sizeof w);
    w.ctl = map_segment(argv[1], sizeof(lc_shm_ctl), &ctl_size);
    if (!w.ctl) {
        fprintf(stderr, "locd-worker: cannot map %s: %s\n", argv[1], strerror(errno));
        return 4;
    }
    if (w.ctl->magic != LC_SHM_MAGIC || w.ctl->version != LC_SHM_VERSION || idx >= w.ctl->workers) {
        fprintf(stderr, "locd-worker: %s is not a control segment of this locd version\n", argv[1]);
        return 5;
    }
    w.slot = &w.ctl->slot[idx];
    w.kernel = lc_kernel_choose();
    if (w.ctl->kernel >= LC_KERNEL_SCALAR && w.ctl->kernel < w.kernel)
        w.kernel = w.ctl->kernel;
    w.slot->pid = (int32_t)getpid();
    sem_post(&w.slot->done); /* ready */
    for (;;) {
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        ts.tv_sec += 1;
        if (sem_timedwait(&w.slot->go, &ts) != 0) {
            if (errno != EINTR && (long)getppid() != ppid) {
                /* Orphaned: the host died, possibly before removing names. */
                shm_unlink(w.ctl->ctl_name);
                if (w.ctl->data_name[0])
                    shm_unlink(w.ctl->data_name);
                break;
            }
            continue;
        }
        if (w.ctl->command == LC_SHM_CMD_EXIT)
            break;
        w.slot->status = run_share(&w);
        sem_post(&w.slot->done);
    }
    free(w.scratch);
    return 0;
}
