/* Asynchronous jobs. Placeholder until the levels work lands: every call
 * reports LOCD_ERR_UNSUPPORTED. */
#include "engine_internal.h"

locd_status locd_engine_submit_f32(locd_engine *engine, const float *boxes, size_t n, uint32_t flags,
                                   locd_job **out)
{
    (void)engine; (void)boxes; (void)n; (void)flags;
    if (out)
        *out = NULL;
    return lc_error(LOCD_ERR_UNSUPPORTED, "jobs are not implemented yet");
}

locd_status locd_engine_submit_f64(locd_engine *engine, const double *boxes, size_t n, uint32_t flags,
                                   locd_job **out)
{
    (void)engine; (void)boxes; (void)n; (void)flags;
    if (out)
        *out = NULL;
    return lc_error(LOCD_ERR_UNSUPPORTED, "jobs are not implemented yet");
}

locd_status locd_job_poll(locd_job *job) { (void)job; return lc_error(LOCD_ERR_INVALID_HANDLE, "no job"); }
locd_status locd_job_wait(locd_job *job, int64_t timeout_ms) { (void)job; (void)timeout_ms; return lc_error(LOCD_ERR_INVALID_HANDLE, "no job"); }
locd_status locd_job_take(locd_job *job, locd_pairs *out) { (void)job; (void)out; return lc_error(LOCD_ERR_INVALID_HANDLE, "no job"); }
locd_status locd_job_stats(const locd_job *job, locd_stats *stats) { (void)job; (void)stats; return lc_error(LOCD_ERR_INVALID_HANDLE, "no job"); }
locd_status locd_job_cancel(locd_job *job) { (void)job; return lc_error(LOCD_ERR_INVALID_HANDLE, "no job"); }
void locd_job_release(locd_job *job) { (void)job; }
