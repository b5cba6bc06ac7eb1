/* Integration level 3, client side: the engine is a connection to a
 * `locd serve` process (client_conn.c). Jobs are submitted with an id
 * (client_jobs.c); one reader thread per connection finishes them from the
 * service's results (client_reader.c). A synchronous find is a submit
 * followed by a wait. */
#include "service/service.h"

#include <stdio.h>

static locd_status service_find(locd_engine *e, const void *boxes, size_t n, int f64, uint32_t flags,
                                locd_pairs *out, locd_stats *stats)
{
    locd_job *j;
    locd_status st = lc_svc_submit(e, boxes, n, f64, flags, &j);
    if (st)
        return st;
    st = locd_job_wait(j, -1);
    if (!st) {
        /* The job is finished: nobody else touches its buffer. */
        st = lc_pairs_give(&j->result, out);
        if (!st)
            *stats = j->stats;
    }
    if (st) {
        char msg[256];
        int64_t idx = locd_last_error_index();
        snprintf(msg, sizeof msg, "%s", lc_last_error_detail());
        locd_job_release(j);
        return lc_error_box(st, idx, "%s", msg);
    }
    locd_job_release(j);
    return LOCD_OK;
}

const lc_backend lc_service_backend = {"service", lc_svc_open, lc_svc_close, service_find, lc_svc_submit, NULL};
