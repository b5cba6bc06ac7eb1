/* Integration level 2 where it cannot exist: Windows builds (meson selects
 * this file for host_machine.system() == 'windows'). Level 2 runs its
 * workers as separate processes talking through POSIX shared memory and
 * process-shared POSIX semaphores (workers.c), which Windows does not have;
 * an engine asking for it gets LOCD_ERR_UNSUPPORTED at creation, with a
 * message saying so, and nothing is allocated. */
#include "engine/engine.h"

static locd_status workers_unsupported_open(struct locd_engine *e)
{
    (void)e;
    return lc_error(LOCD_ERR_UNSUPPORTED,
                    "level 2 (worker processes) is not available in this build: it needs POSIX shared memory "
                    "and semaphores (Windows has neither); use level 1");
}

static void workers_unsupported_close(struct locd_engine *e)
{
    (void)e;
}

static locd_status workers_unsupported_find(struct locd_engine *e, const void *boxes, size_t n, int f64,
                                            uint32_t flags, locd_pairs *out, locd_stats *stats)
{
    (void)e, (void)boxes, (void)n, (void)f64, (void)flags, (void)out, (void)stats;
    return lc_error(LOCD_ERR_UNSUPPORTED, "level 2 (worker processes) is not available in this build");
}

const lc_backend lc_workers_backend = {"worker processes (unsupported)", workers_unsupported_open,
                                       workers_unsupported_close, workers_unsupported_find, NULL};
