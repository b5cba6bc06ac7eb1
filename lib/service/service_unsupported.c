/* Integration level 3 where it cannot exist: Windows builds (meson selects
 * this file instead of client*.c, proto.c and server*.c for
 * host_machine.system() == 'windows'). The service and its clients use Unix
 * domain sockets, poll() and POSIX shared memory; here an engine asking for
 * level 3 and locd_service_create both return LOCD_ERR_UNSUPPORTED with a
 * message, and the other service functions behave as on a handle that was
 * never created. The exported functions are the same as in every build, so
 * the ABI does not depend on the platform's features. */
#include "engine/engine.h"
#include "locd/service.h"

#define LC_NO_SERVICE_WHY "it uses Unix domain sockets and POSIX shared memory (not available on Windows); use level 1"

static locd_status service_unsupported_open(struct locd_engine *e)
{
    (void)e;
    return lc_error(LOCD_ERR_UNSUPPORTED, "level 3 (service client) is not available in this build: " LC_NO_SERVICE_WHY);
}

static void service_unsupported_close(struct locd_engine *e)
{
    (void)e;
}

static locd_status service_unsupported_find(struct locd_engine *e, const void *boxes, size_t n, int f64,
                                            uint32_t flags, locd_pairs *out, locd_stats *stats)
{
    (void)e, (void)boxes, (void)n, (void)f64, (void)flags, (void)out, (void)stats;
    return lc_error(LOCD_ERR_UNSUPPORTED, "level 3 (service client) is not available in this build");
}

const lc_backend lc_service_backend = {"service (unsupported)", service_unsupported_open, service_unsupported_close,
                                       service_unsupported_find, NULL};

void locd_service_config_init(locd_service_config *config)
{
    if (!config)
        return;
    memset(config, 0, sizeof *config);
    config->size = sizeof *config;
}

locd_status locd_service_create(const locd_service_config *config, locd_service **out)
{
    (void)config;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    return lc_error(LOCD_ERR_UNSUPPORTED, "the locd service is not available in this build: " LC_NO_SERVICE_WHY);
}

const char *locd_service_address(const locd_service *service)
{
    (void)service;
    return "";
}

locd_status locd_service_run(locd_service *service)
{
    (void)service;
    return lc_error(LOCD_ERR_INVALID_HANDLE, "not a locd_service handle (no service can be created in this build)");
}

void locd_service_stop(locd_service *service)
{
    (void)service;
}

void locd_service_destroy(locd_service *service)
{
    (void)service;
}
