/* locd serve: run the level-3 service in the foreground until SIGINT or
 * SIGTERM. One log line says where it listens; later lines (dropped
 * connections and their reasons) go to stderr too. */
#include "cli.h"

#include <locd/service.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static locd_service *g_service;

static void on_signal(int sig)
{
    (void)sig;
    locd_service_stop(g_service); /* async-signal-safe: writes one byte to a pipe */
}

static void log_line(int32_t severity, const char *message, void *user)
{
    static const char *names[] = {"error", "warning", "info", "debug"};
    int verbose = *(int *)user;
    if (severity == LOCD_LOG_DEBUG && !verbose)
        return;
    fprintf(stderr, "locd serve: %s%s%s\n", severity <= LOCD_LOG_WARNING ? names[severity] : "",
            severity <= LOCD_LOG_WARNING ? ": " : "", message);
    fflush(stderr);
}

static void serve_usage(void)
{
    printf("usage: locd serve [--listen unix:PATH|tcp:HOST:PORT] [options]\n"
           "  --listen ADDR        where to listen (default unix:$XDG_RUNTIME_DIR/locd/locd.sock or\n"
           "                       unix:/tmp/locd-UID/locd.sock); the socket's directory must be private (0700)\n"
           "  --secret-file PATH   shared secret clients must present (required for tcp): the file's\n"
           "                       first line, at least 16 bytes; or set LOCD_SECRET. --secret S works\n"
           "                       too but every local user can read it in /proc/PID/cmdline\n"
           "  --threads K          job runners, each with its own level-1 engine (default: one per core)\n"
           "  --engine-threads T   threads of each runner's engine (default 1)\n"
           "  --max-mb M           largest message accepted, in MiB (default 1024)\n"
           "  --max-clients C      connections at once (default 256)\n"
           "  --max-jobs J         jobs in flight per connection (default 1024)\n"
           "Limits per job and per client (a job over one fails alone with LOCD_ERR_LIMIT):\n"
           "  --max-job-boxes N    boxes in one job (default 67108864)\n"
           "  --max-job-pairs N    pairs one job may find (default 134217728)\n"
           "  --max-job-mb M       memory of one job, boxes included, MiB (default 4096)\n"
           "  --max-job-ms T       wall time of one job (default 600000)\n"
           "  --max-client-boxes N boxes of one connection's jobs in flight (default 134217728)\n"
           "  --max-client-pairs N pairs of one connection's running jobs (default 268435456)\n"
           "  --max-client-mb M    memory of one connection's jobs in flight, MiB (default 8192)\n"
           "Deadlines, each for the whole step, in ms:\n"
           "  --auth-timeout T     to authenticate after connecting (default 5000)\n"
           "  --message-timeout T  for a message once its first byte came (default 30000)\n"
           "  --send-timeout T     for a client to take one result (default 30000; then it is dropped)\n"
           "  --verbose            also log connects and disconnects\n"
           "Runs in the foreground until SIGINT or SIGTERM.\n");
}

int cmd_serve(int argc, char **argv)
{
    locd_service_config cfg;
    struct sigaction sa;
    locd_status st;
    int a, verbose = 0;
    char *secret_arg = NULL, *secret;
    const char *secret_file = NULL;
    locd_service_config_init(&cfg);
    for (a = 1; a < argc; a++) {
        const char *o = argv[a];
        int more = a + 1 < argc;
        if (!strcmp(o, "--help")) {
            serve_usage();
            return 0;
        } else if (!strcmp(o, "--listen") && more) {
            cfg.listen = argv[++a];
        } else if (!strcmp(o, "--secret") && more) {
            secret_arg = argv[++a];
        } else if (!strcmp(o, "--secret-file") && more) {
            secret_file = argv[++a];
        } else if (!strcmp(o, "--threads") && more) {
            cfg.threads = (uint32_t)cli_size_option(argv[++a], 1, 256, "serve: bad --threads (1..256)");
        } else if (!strcmp(o, "--engine-threads") && more) {
            cfg.engine_threads =
                (uint32_t)cli_size_option(argv[++a], 1, 64, "serve: bad --engine-threads (1..64)");
        } else if (!strcmp(o, "--max-mb") && more) {
            cfg.max_message = (uint64_t)cli_size_option(argv[++a], 1, 1u << 20, "serve: bad --max-mb") << 20;
        } else if (!strcmp(o, "--max-clients") && more) {
            cfg.max_clients = (uint32_t)cli_size_option(argv[++a], 1, 100000, "serve: bad --max-clients");
        } else if (!strcmp(o, "--max-jobs") && more) {
            cfg.max_jobs = (uint32_t)cli_size_option(argv[++a], 1, 1u << 20, "serve: bad --max-jobs");
        } else if (!strcmp(o, "--max-job-boxes") && more) {
            cfg.max_job_boxes = cli_size_option(argv[++a], 1, (size_t)1 << 32, "serve: bad --max-job-boxes");
        } else if (!strcmp(o, "--max-job-pairs") && more) {
            cfg.max_job_pairs = cli_size_option(argv[++a], 1, (size_t)1 << 40, "serve: bad --max-job-pairs");
        } else if (!strcmp(o, "--max-job-mb") && more) {
            cfg.max_job_memory = (uint64_t)cli_size_option(argv[++a], 1, 1u << 24, "serve: bad --max-job-mb") << 20;
        } else if (!strcmp(o, "--max-job-ms") && more) {
            cfg.max_job_ms = (uint32_t)cli_size_option(argv[++a], 1, 2000000000u, "serve: bad --max-job-ms");
        } else if (!strcmp(o, "--max-client-boxes") && more) {
            cfg.max_client_boxes = cli_size_option(argv[++a], 1, (size_t)1 << 40, "serve: bad --max-client-boxes");
        } else if (!strcmp(o, "--max-client-pairs") && more) {
            cfg.max_client_pairs = cli_size_option(argv[++a], 1, (size_t)1 << 40, "serve: bad --max-client-pairs");
        } else if (!strcmp(o, "--max-client-mb") && more) {
            cfg.max_client_memory =
                (uint64_t)cli_size_option(argv[++a], 1, 1u << 24, "serve: bad --max-client-mb") << 20;
        } else if (!strcmp(o, "--auth-timeout") && more) {
            cfg.auth_timeout_ms = (uint32_t)cli_size_option(argv[++a], 1, 3600000, "serve: bad --auth-timeout");
        } else if (!strcmp(o, "--message-timeout") && more) {
            cfg.message_timeout_ms =
                (uint32_t)cli_size_option(argv[++a], 1, 3600000, "serve: bad --message-timeout");
        } else if (!strcmp(o, "--send-timeout") && more) {
            cfg.send_timeout_ms = (uint32_t)cli_size_option(argv[++a], 1, 3600000, "serve: bad --send-timeout");
        } else if (!strcmp(o, "--verbose")) {
            verbose = 1;
        } else {
            cli_die("serve: unknown option '%s' (see locd serve --help)", o);
        }
    }
    secret = cli_secret("serve", secret_arg, secret_file);
    if (secret && strlen(secret) < CLI_MIN_SECRET) {
        fprintf(stderr, "locd serve: the secret is %zu bytes; at least %d are required (e.g. head -c 24 /dev/urandom "
                        "| base64 > FILE; chmod 600 FILE)\n",
                strlen(secret), CLI_MIN_SECRET);
        free(secret);
        return 2;
    }
    cfg.secret = secret;
    cfg.log = log_line;
    cfg.log_user = &verbose;
    if ((st = locd_service_create(&cfg, &g_service)) != LOCD_OK) {
        fprintf(stderr, "locd serve: cannot start: %s\n", locd_last_error());
        free(secret);
        return 1;
    }
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sa.sa_handler = SIG_IGN;
    sigaction(SIGPIPE, &sa, NULL);
    st = locd_service_run(g_service); /* logs "listening on ADDR" first */
    locd_service_destroy(g_service);
    g_service = NULL;
    free(secret);
    return st ? 1 : 0;
}
