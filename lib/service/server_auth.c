/* The service's door: the shared secret and where it listens.
 *
 * A wrong secret is answered only after LC_AUTH_FAIL_DELAY_MS (one guess
 * per connection per second), and the whole service checks at most
 * LC_AUTH_MAX_FAILS secrets that turn out wrong per second: past that, every
 * HELLO of the rest of the second is refused unchecked (LOCD_ERR_BUSY), so
 * a flood of connections cannot test more than LC_AUTH_MAX_FAILS guesses
 * a second and learns nothing from the refused ones. A secret shorter than
 * LC_AUTH_MIN_SECRET bytes and a TCP bind to every interface are logged as
 * warnings when the service starts. */
#define _GNU_SOURCE
#include "service/service.h"

#include <stdio.h>
#include <time.h>

static void sleep_ms(int ms)
{
    struct timespec ts;
    ts.tv_sec = ms / 1000;
    ts.tv_nsec = (long)(ms % 1000) * 1000000L;
    while (nanosleep(&ts, &ts) != 0)
        ;
}

int lc_srv_auth_check(lc_server *s, const uint8_t *secret, size_t len)
{
    double now = lc_now_ms();
    int throttled, log_it = 0;
    if (!s->secret)
        return LC_AUTH_OK;
    pthread_mutex_lock(&s->mu);
    if (now - s->auth_window >= 1000.0) {
        s->auth_window = now;
        s->auth_fails = 0;
        s->auth_logged = 0;
    }
    throttled = s->auth_fails >= LC_AUTH_MAX_FAILS;
    if (throttled && !s->auth_logged)
        log_it = s->auth_logged = 1;
    pthread_mutex_unlock(&s->mu);
    if (log_it)
        lc_srv_log(s, LOCD_LOG_WARNING,
                   "%d wrong secrets within a second: refusing every connection for the rest of it", LC_AUTH_MAX_FAILS);
    if (throttled)
        return LC_AUTH_THROTTLED;
    if (lc_proto_secret_equal(s->secret, strlen(s->secret), (const char *)secret, len))
        return LC_AUTH_OK;
    pthread_mutex_lock(&s->mu);
    s->auth_fails++;
    pthread_mutex_unlock(&s->mu);
    sleep_ms(s->auth_fail_delay_ms);
    return LC_AUTH_WRONG;
}

/* 1 when host (of a tcp: address) means every interface. */
static int wildcard_host(const char *host)
{
    return !host[0] || !strcmp(host, "*") || !strcmp(host, "0.0.0.0") || !strcmp(host, "::") ||
           !strcmp(host, "[::]") || !strcmp(host, "0");
}

void lc_srv_warn_exposure(const lc_server *s, const lc_address *a)
{
    if (s->secret && strlen(s->secret) < LC_AUTH_MIN_SECRET)
        lc_srv_log(s, LOCD_LOG_WARNING, "the shared secret is %zu bytes; use at least %d (random)",
                   strlen(s->secret), LC_AUTH_MIN_SECRET);
    if (a->tcp && wildcard_host(a->host))
        lc_srv_log(s, LOCD_LOG_WARNING,
                   "listening on every network interface (%s): anyone who can reach port %s may try the secret; "
                   "bind to one address or firewall the port",
                   s->address, a->port);
}
