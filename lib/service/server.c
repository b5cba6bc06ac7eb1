/* Integration level 3, server side (what `locd serve` runs): the service's
 * life. One accept loop (server_session.c starts a thread per connection);
 * a fixed set of runner threads, each with its own level-1 engine, taking
 * jobs from one FIFO queue (server_jobs.c). Memory is bounded by
 * max_clients x max_jobs x max_message. */
#include "service/service.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <unistd.h>

/* The public handle holds the server's state. Its definition stays here,
 * not in service.h: the ABI check counts every type defined in a file named
 * like a public header (include/locd/service.h) as public. */
struct locd_service {
    lc_server srv;
};

/* The server behind a handle; NULL when h is not a live service. */
static lc_server *server_of(locd_service *h)
{
    return (h && h->srv.magic == LC_MAGIC_SERVICE) ? &h->srv : NULL;
}

void locd_service_config_init(locd_service_config *config)
{
    if (!config)
        return;
    memset(config, 0, sizeof *config);
    config->size = sizeof *config;
}

/* ---- create ---- */

/* unix:$XDG_RUNTIME_DIR/locd/locd.sock, else unix:/tmp/locd-UID/locd.sock. */
static void default_listen(char *def, size_t len)
{
    const char *xdg = getenv("XDG_RUNTIME_DIR");
    if (xdg && xdg[0] && strlen(xdg) < 80)
        snprintf(def, len, "unix:%s/locd/locd.sock", xdg);
    else
        snprintf(def, len, "unix:/tmp/locd-%ld/locd.sock", (long)geteuid());
}

/* Copies the caller's config (of any older size) and fills the defaults;
 * cfg->listen may then point into def. */
static locd_status resolve_config(const locd_service_config *config, locd_service_config *cfg, char *def, size_t len)
{
    locd_status st;
    locd_service_config_init(cfg);
    if (config && (st = lc_struct_in(cfg, sizeof *cfg, config, LOCD_SERVICE_CONFIG_MIN_SIZE, "config")) != LOCD_OK)
        return st;
    if (!cfg->listen) {
        default_listen(def, len);
        cfg->listen = def;
    }
    if (!cfg->threads)
        cfg->threads = lc_cpu_count();
    if (cfg->threads > LC_SRV_MAX_THREADS)
        cfg->threads = LC_SRV_MAX_THREADS;
    if (!cfg->max_message)
        cfg->max_message = LC_SRV_DEFAULT_MAX_MESSAGE;
    if (!cfg->max_clients)
        cfg->max_clients = LC_SRV_DEFAULT_MAX_CLIENTS;
    if (!cfg->max_jobs)
        cfg->max_jobs = LC_SRV_DEFAULT_MAX_JOBS;
    if (!cfg->auth_timeout_ms)
        cfg->auth_timeout_ms = LC_HELLO_TIMEOUT_MS;
    if (!cfg->message_timeout_ms)
        cfg->message_timeout_ms = LC_SRV_DEFAULT_MESSAGE_MS;
    if (!cfg->send_timeout_ms)
        cfg->send_timeout_ms = LC_SRV_DEFAULT_SEND_MS;
    if (!cfg->max_job_ms)
        cfg->max_job_ms = LC_SRV_DEFAULT_JOB_MS;
    if (!cfg->max_job_boxes)
        cfg->max_job_boxes = LC_SRV_DEFAULT_JOB_BOXES;
    if (!cfg->max_job_pairs)
        cfg->max_job_pairs = LC_SRV_DEFAULT_JOB_PAIRS;
    if (!cfg->max_job_memory)
        cfg->max_job_memory = LC_SRV_DEFAULT_JOB_MEMORY;
    if (!cfg->max_client_boxes)
        cfg->max_client_boxes = LC_SRV_DEFAULT_CLIENT_BOXES;
    if (!cfg->max_client_pairs)
        cfg->max_client_pairs = LC_SRV_DEFAULT_CLIENT_PAIRS;
    if (!cfg->max_client_memory)
        cfg->max_client_memory = LC_SRV_DEFAULT_CLIENT_MEMORY;
    return LOCD_OK;
}

static locd_status check_config(const locd_service_config *cfg, lc_address *a)
{
    char why[200];
    if (!lc_proto_parse_address(cfg->listen, a, why, sizeof why))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "listen: %s", why);
    if (a->tcp && (!cfg->secret || !cfg->secret[0]))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "a TCP service needs a shared secret (locd serve: --secret-file or LOCD_SECRET)");
    if (cfg->secret && strlen(cfg->secret) > LC_PROTO_MAX_SECRET)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "the secret is longer than %d bytes", LC_PROTO_MAX_SECRET);
    if (!lc_proto_host_ok())
        return lc_error(LOCD_ERR_UNSUPPORTED, "the service needs a little-endian machine");
    return LOCD_OK;
}

/* A service with its own copy of the secret and nothing started. */
static locd_status service_new(const locd_service_config *cfg, locd_service **out)
{
    locd_service *h = calloc(1, sizeof *h);
    lc_server *s;
    if (!h)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the service");
    s = &h->srv;
    s->cfg = *cfg;
    s->lfd = -1;
    s->wake[0] = s->wake[1] = -1;
    if (cfg->secret && !(s->secret = strdup(cfg->secret))) {
        free(h);
        return lc_error(LOCD_ERR_NO_MEMORY, "could not copy the secret");
    }
    s->cfg.secret = s->secret;
    s->cfg.listen = NULL; /* the caller's string; s->address says where we listen */
    pthread_mutex_init(&s->mu, NULL);
    pthread_cond_init(&s->cv, NULL);
    pthread_cond_init(&s->conns_cv, NULL);
    s->auth_fail_delay_ms = LC_AUTH_FAIL_DELAY_MS;
    s->magic = LC_MAGIC_SERVICE;
    *out = h;
    return LOCD_OK;
}

/* The pipe locd_service_stop writes to (non-blocking: it is called from
 * signal handlers). */
static locd_status open_wake_pipe(lc_server *s)
{
    if (pipe(s->wake) != 0)
        return lc_error(LOCD_ERR_IO, "pipe: %s", strerror(errno));
    fcntl(s->wake[0], F_SETFD, FD_CLOEXEC);
    fcntl(s->wake[1], F_SETFD, FD_CLOEXEC);
    fcntl(s->wake[1], F_SETFL, O_NONBLOCK);
    return LOCD_OK;
}

static locd_status start_runners(lc_server *s)
{
    uint32_t i;
    s->runners = calloc(s->cfg.threads, sizeof *s->runners);
    if (!s->runners)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the runners");
    for (i = 0; i < s->cfg.threads; i++) {
        if (pthread_create(&s->runners[i], NULL, lc_srv_runner_main, s) != 0)
            return lc_error(LOCD_ERR_THREAD, "could not start runner %u", i);
        s->nrunners++;
    }
    return LOCD_OK;
}

/* Wakes the runners to leave (after the queue is empty) and joins them. */
static void stop_runners(lc_server *s)
{
    uint32_t i;
    pthread_mutex_lock(&s->mu);
    __atomic_store_n(&s->stopping, 1, __ATOMIC_RELAXED); /* runners' stop hooks read it unlocked */
    pthread_cond_broadcast(&s->cv);
    pthread_mutex_unlock(&s->mu);
    for (i = 0; i < s->nrunners; i++)
        pthread_join(s->runners[i], NULL);
    s->nrunners = 0;
}

locd_status locd_service_create(const locd_service_config *config, locd_service **out)
{
    locd_service_config cfg;
    locd_service *h = NULL;
    lc_address a;
    char def[sizeof a.path];
    locd_status st;
    if (!out)
        return lc_error(LOCD_ERR_NULL_POINTER, "out is NULL");
    *out = NULL;
    if ((st = resolve_config(config, &cfg, def, sizeof def)) != LOCD_OK || (st = check_config(&cfg, &a)) != LOCD_OK ||
        (st = service_new(&cfg, &h)) != LOCD_OK)
        return st;
    if ((st = lc_srv_listen(&h->srv, &a)) != LOCD_OK || (st = open_wake_pipe(&h->srv)) != LOCD_OK ||
        (st = start_runners(&h->srv)) != LOCD_OK) {
        locd_service_destroy(h);
        return st;
    }
    lc_srv_warn_exposure(&h->srv, &a);
    *out = h;
    lc_clear_error();
    return LOCD_OK;
}

const char *locd_service_address(const locd_service *h)
{
    return (h && h->srv.magic == LC_MAGIC_SERVICE) ? h->srv.address : "";
}

/* ---- run, stop ---- */

/* Accepts connections until locd_service_stop writes to the wake pipe.
 * When accept runs out of descriptors the pending connection stays in the
 * backlog and the listener stays readable: polling it again at once would
 * spin, so the loop then waits on the wake pipe alone for a while. */
static void accept_until_stopped(lc_server *s)
{
    int rest = 0;
    for (;;) {
        struct pollfd p[2];
        p[0].fd = s->wake[0];
        p[0].events = POLLIN;
        p[1].fd = s->lfd;
        p[1].events = POLLIN;
        p[0].revents = p[1].revents = 0;
        if (poll(p, rest ? 1 : 2, rest ? LC_SRV_ACCEPT_BACKOFF_MS : -1) < 0) {
            if (errno == EINTR)
                continue;
            break;
        }
        if (p[0].revents)
            break;
        rest = 0;
        if (p[1].revents & POLLIN)
            rest = !lc_srv_accept(s);
    }
}

static void close_listener(lc_server *s)
{
    close(s->lfd);
    s->lfd = -1;
    if (s->unix_path[0]) {
        unlink(s->unix_path);
        s->unix_path[0] = '\0';
    }
}

/* Breaks every connection and waits for their threads to leave. */
static void close_connections(lc_server *s)
{
    lc_srv_conn *c;
    pthread_mutex_lock(&s->mu);
    for (c = s->conns; c; c = c->next) {
        pthread_mutex_lock(&c->wmu);
        if (c->fd >= 0)
            shutdown(c->fd, SHUT_RDWR);
        pthread_mutex_unlock(&c->wmu);
    }
    while (s->nconns)
        pthread_cond_wait(&s->conns_cv, &s->mu);
    pthread_mutex_unlock(&s->mu);
}

locd_status locd_service_run(locd_service *h)
{
    lc_server *s = server_of(h);
    if (!s)
        return lc_error(LOCD_ERR_INVALID_HANDLE, "not a locd_service handle");
    lc_srv_log(s, LOCD_LOG_INFO, "listening on %s (%u runners)", s->address, s->nrunners);
    accept_until_stopped(s);
    lc_srv_log(s, LOCD_LOG_INFO, "stopping");
    close_listener(s);
    close_connections(s);
    stop_runners(s);
    lc_srv_log(s, LOCD_LOG_INFO, "stopped after %llu jobs", (unsigned long long)s->served);
    lc_clear_error();
    return LOCD_OK;
}

void locd_service_stop(locd_service *h)
{
    lc_server *s = server_of(h);
    char x = 'x';
    if (s && s->wake[1] >= 0) {
        ssize_t w = write(s->wake[1], &x, 1);
        (void)w;
    }
}

void locd_service_destroy(locd_service *h)
{
    lc_server *s = server_of(h);
    if (!s)
        return;
    if (s->nrunners) /* never ran */
        stop_runners(s);
    if (s->lfd >= 0)
        close(s->lfd);
    if (s->unix_path[0])
        unlink(s->unix_path);
    if (s->wake[0] >= 0)
        close(s->wake[0]);
    if (s->wake[1] >= 0)
        close(s->wake[1]);
    free(s->runners);
    free(s->secret);
    pthread_cond_destroy(&s->cv);
    pthread_cond_destroy(&s->conns_cv);
    pthread_mutex_destroy(&s->mu);
    s->magic = LC_MAGIC_DEAD;
    free(h);
}
