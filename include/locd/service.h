/* locd: the level-3 service (what `locd serve` runs), for programs that
 * want to host it themselves (liblocd; includes locd/locd.h). Clients do not
 * need this header: they create an engine with LOCD_LEVEL_SERVICE and
 * service_address. */
#ifndef LOCD_SERVICE_H
#define LOCD_SERVICE_H

#include "locd/locd.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct locd_service_config {
    uint32_t size;           /* sizeof(locd_service_config) */
    const char *listen;      /* "unix:PATH" or "tcp:HOST:PORT" (port 0 = any free port);
                                NULL = unix:$XDG_RUNTIME_DIR/locd/locd.sock, or /tmp/locd-UID/locd.sock */
    const char *secret;      /* shared secret clients must present; required for tcp */
    uint32_t threads;        /* job runners (each with its own level-1 engine); 0 = one per core */
    uint32_t engine_threads; /* threads of each runner's engine; 0 = 1 */
    uint64_t max_message;    /* largest accepted message in bytes; 0 = 1 GiB */
    uint32_t max_clients;    /* connections served at once; 0 = 256 */
    uint32_t max_jobs;       /* jobs in flight per connection; 0 = 1024 */
    locd_log_fn log;         /* NULL = silent */
    void *log_user;
    /* Limits and deadlines (docs/levels.md, "Limits and deadlines"). 0 = the
     * default given. A job over a limit fails alone with LOCD_ERR_LIMIT. */
    uint32_t auth_timeout_ms;    /* total time to authenticate (HELLO); 0 = 5000 */
    uint32_t message_timeout_ms; /* total time for one message once it started; 0 = 30000 */
    uint32_t send_timeout_ms;    /* total time to write one RESULT; 0 = 30000 (then the client is dropped) */
    uint32_t max_job_ms;         /* wall time a job may run; 0 = 600000 (10 minutes) */
    uint64_t max_job_boxes;      /* boxes in one job; 0 = 2^26 */
    uint64_t max_job_pairs;      /* pairs one job may find; 0 = 2^27 (1 GiB of pairs) */
    uint64_t max_job_memory;     /* bytes of one job: its boxes + what its find allocates; 0 = 4 GiB */
    uint64_t max_client_boxes;   /* boxes of one connection's jobs in flight; 0 = 2^27 */
    uint64_t max_client_pairs;   /* pairs of one connection's running jobs together; 0 = 2^28 */
    uint64_t max_client_memory;  /* bytes held for one connection's jobs in flight; 0 = 8 GiB */
} locd_service_config;

/* Smallest config->size accepted: size alone (and the padding after it),
 * which leaves every field at its default. */
#define LOCD_SERVICE_CONFIG_MIN_SIZE 8u

typedef struct locd_service locd_service;

LOCD_API void locd_service_config_init(locd_service_config *config);
/* Binds and listens (a Unix socket's directory must be private to the user:
 * it is created with mode 0700 if missing, refused if others can enter it). */
LOCD_API locd_status locd_service_create(const locd_service_config *config, locd_service **out);
/* The address actually listened on ("tcp:127.0.0.1:40123" for port 0). */
LOCD_API const char *locd_service_address(const locd_service *service);
/* Serves clients until locd_service_stop; then closes every connection. */
LOCD_API locd_status locd_service_run(locd_service *service);
/* Makes locd_service_run return. Async-signal-safe. */
LOCD_API void locd_service_stop(locd_service *service);
/* Frees the service (after run returned, or instead of running it). */
LOCD_API void locd_service_destroy(locd_service *service);

#ifdef __cplusplus
}
#endif

#endif
