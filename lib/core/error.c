/* Status strings and the thread-local last error. The status and the
 * detail are kept apart, so code that passes an error on (a job, the
 * service's wire) takes the detail without cutting the status text off;
 * locd_last_error() composes "status text: detail" when it is read. */
#include "core/core.h"

#include <stdio.h>

static LC_TLS locd_status last_status; /* LOCD_OK: no error */
static LC_TLS char last_detail[256];
static LC_TLS char last_message[256]; /* composed by locd_last_error() */
static LC_TLS int64_t last_index = -1;

const char *locd_status_string(locd_status status)
{
    switch (status) {
    case LOCD_OK: return "success";
    case LOCD_PENDING: return "job still running";
    case LOCD_ERR_INVALID_ARGUMENT: return "invalid argument";
    case LOCD_ERR_NULL_POINTER: return "null pointer";
    case LOCD_ERR_NONFINITE: return "non-finite coordinate (NaN or infinity)";
    case LOCD_ERR_INVERTED_BOX: return "box with min > max";
    case LOCD_ERR_NO_MEMORY: return "out of memory";
    case LOCD_ERR_TOO_MANY_OBJECTS: return "too many objects";
    case LOCD_ERR_BUFFER_TOO_SMALL: return "buffer too small";
    case LOCD_ERR_INVALID_HANDLE: return "invalid handle";
    case LOCD_ERR_BUSY: return "engine busy";
    case LOCD_ERR_THREAD: return "thread creation failed";
    case LOCD_ERR_UNSUPPORTED: return "not supported";
    case LOCD_ERR_WORKER: return "worker process failed";
    case LOCD_ERR_IO: return "input/output error";
    case LOCD_ERR_CONNECTION: return "service connection failed";
    case LOCD_ERR_PROTOCOL: return "protocol error";
    case LOCD_ERR_TIMEOUT: return "timed out";
    case LOCD_ERR_CANCELLED: return "cancelled";
    case LOCD_ERR_AUTH: return "authentication refused";
    case LOCD_ERR_SHAPE: return "invalid shape";
    case LOCD_ERR_STALE_ID: return "stale or unknown scene id";
    case LOCD_ERR_DUPLICATE_ID: return "scene id repeated in one batch";
    case LOCD_ERR_LIMIT: return "the job exceeds a limit of the service";
    case LOCD_ERR_INTERNAL: return "internal error";
    default: return "unknown status";
    }
}

void lc_log_emit(locd_log_fn log, void *user, int32_t severity, const char *fmt, va_list ap)
{
    char msg[600];
    if (!log)
        return;
    vsnprintf(msg, sizeof msg, fmt, ap);
    log(severity, msg, user);
}

const char *locd_last_error(void)
{
    if (last_status == LOCD_OK)
        return "";
    /* Cut at the buffer's size: the text a caller saw when it was stored
     * composed (the return value is read only to say so). */
    if (snprintf(last_message, sizeof last_message, "%s: %s", locd_status_string(last_status), last_detail) < 0)
        last_message[0] = '\0';
    return last_message;
}

const char *lc_last_error_detail(void)
{
    return last_detail;
}

int64_t locd_last_error_index(void)
{
    return last_index;
}

void lc_clear_error(void)
{
    last_status = LOCD_OK;
    last_detail[0] = '\0';
    last_index = -1;
}

/* Formats into a local buffer first: an argument may be the detail itself
 * (an error passed on unchanged). */
static void set_message(locd_status status, const char *fmt, va_list ap)
{
    char detail[sizeof last_detail];
    vsnprintf(detail, sizeof detail, fmt, ap);
    memcpy(last_detail, detail, sizeof detail);
    last_status = status;
}

locd_status lc_error(locd_status status, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    set_message(status, fmt, ap);
    va_end(ap);
    last_index = -1;
    return status;
}

locd_status lc_error_box(locd_status status, int64_t index, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    set_message(status, fmt, ap);
    va_end(ap);
    last_index = index;
    return status;
}
