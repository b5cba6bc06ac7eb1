/* Names for the POSIX shared-memory segments locd creates (level 2's
 * worker segments, level 3's client box segments). One scheme for all so
 * that the service can recognise a locd segment by its prefix and a test
 * can count what a process left behind by "locd-<tag><pid>-". */
#include "core/core.h"

#include <stdio.h>
#include <time.h>
#include <unistd.h>

void lc_shm_unique_name(char *out, size_t len, const char *tag)
{
    static unsigned counter;
    struct timespec ts;
    /* The counter makes names unique within the process; the clock bits
     * make a name left by an earlier process with the same pid unlikely to
     * collide (callers still create with O_EXCL and retry). */
    unsigned c = __atomic_add_fetch(&counter, 1u, __ATOMIC_RELAXED);
    clock_gettime(CLOCK_MONOTONIC, &ts);
    snprintf(out, len, "%s%s%ld-%u-%lx", LC_SHM_PREFIX, tag, (long)getpid(), c,
             (unsigned long)(ts.tv_nsec ^ (ts.tv_sec << 20)));
}
