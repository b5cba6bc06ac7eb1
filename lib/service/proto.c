/* Level 3 wire protocol: encoding, framing and checked socket I/O (see
 * service.h for the message layouts). */
#include "service/service.h"

#include <errno.h>
#include <poll.h>
#include <stdio.h>
#include <sys/socket.h>
#include <sys/types.h>
#include <unistd.h>

int lc_proto_host_ok(void)
{
    const uint32_t one = 1;
    return *(const uint8_t *)&one == 1;
}

void lc_put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

void lc_put_u64(uint8_t *p, uint64_t v)
{
    lc_put_u32(p, (uint32_t)v);
    lc_put_u32(p + 4, (uint32_t)(v >> 32));
}

uint32_t lc_get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

uint64_t lc_get_u64(const uint8_t *p)
{
    return (uint64_t)lc_get_u32(p) | ((uint64_t)lc_get_u32(p + 4) << 32);
}

static void put_f64(uint8_t *p, double d)
{
    uint64_t v;
    memcpy(&v, &d, sizeof v);
    lc_put_u64(p, v);
}

static double get_f64(const uint8_t *p)
{
    uint64_t v = lc_get_u64(p);
    double d;
    memcpy(&d, &v, sizeof d);
    return d;
}

void lc_proto_put_header(uint8_t *out, uint16_t type, uint64_t id, uint64_t length)
{
    lc_put_u32(out, LC_PROTO_MAGIC);
    out[4] = (uint8_t)LC_PROTO_VERSION;
    out[5] = (uint8_t)(LC_PROTO_VERSION >> 8);
    out[6] = (uint8_t)type;
    out[7] = (uint8_t)(type >> 8);
    lc_put_u64(out + 8, id);
    lc_put_u64(out + 16, length);
}

int lc_proto_get_header(const uint8_t *in, uint64_t max_length, lc_msg_header *h, char *why, size_t why_len)
{
    h->magic = lc_get_u32(in);
    h->version = (uint16_t)(in[4] | (in[5] << 8));
    h->type = (uint16_t)(in[6] | (in[7] << 8));
    h->id = lc_get_u64(in + 8);
    h->length = lc_get_u64(in + 16);
    if (h->magic != LC_PROTO_MAGIC) {
        snprintf(why, why_len, "bad magic 0x%08x (not a locd client?)", h->magic);
        return 0;
    }
    if (h->version != LC_PROTO_VERSION) {
        snprintf(why, why_len, "protocol version %u, expected %u", h->version, LC_PROTO_VERSION);
        return 0;
    }
    if (h->type < LC_MSG_HELLO || h->type > LC_MSG_ERROR) {
        snprintf(why, why_len, "unknown message type %u", h->type);
        return 0;
    }
    if (h->length > max_length) {
        snprintf(why, why_len, "message of %llu bytes exceeds the limit of %llu", (unsigned long long)h->length,
                 (unsigned long long)max_length);
        return 0;
    }
    return 1;
}

void lc_proto_put_submit(uint8_t *out, const lc_submit_fixed *s)
{
    lc_put_u32(out, s->flags);
    lc_put_u32(out + 4, s->f64);
    lc_put_u64(out + 8, s->n);
    lc_put_u32(out + 16, s->max_depth);
    lc_put_u32(out + 20, (uint32_t)s->cell_bias);
    lc_put_u32(out + 24, s->config_flags);
    lc_put_u32(out + 28, s->transport);
    lc_put_u32(out + 32, 0);
}

void lc_proto_get_submit(const uint8_t *in, lc_submit_fixed *s)
{
    s->flags = lc_get_u32(in);
    s->f64 = lc_get_u32(in + 4);
    s->n = lc_get_u64(in + 8);
    s->max_depth = lc_get_u32(in + 16);
    s->cell_bias = (int32_t)lc_get_u32(in + 20);
    s->config_flags = lc_get_u32(in + 24);
    s->transport = lc_get_u32(in + 28);
}

void lc_proto_put_stats(uint8_t *out, const locd_stats *s)
{
    lc_put_u32(out, s->threads);
    lc_put_u32(out + 4, s->depth);
    lc_put_u64(out + 8, s->objects);
    lc_put_u64(out + 16, s->entries);
    lc_put_u64(out + 24, s->candidates);
    lc_put_u64(out + 32, s->exact_tests);
    lc_put_u64(out + 40, s->pairs);
    put_f64(out + 48, s->ms_total);
    put_f64(out + 56, s->ms_bounds);
    put_f64(out + 64, s->ms_encode);
    put_f64(out + 72, s->ms_sort);
    put_f64(out + 80, s->ms_merge);
    put_f64(out + 88, s->ms_sweep);
    put_f64(out + 96, s->ms_order);
    put_f64(out + 104, s->ms_transfer);
}

void lc_proto_get_stats(const uint8_t *in, locd_stats *s)
{
    locd_stats_init(s);
    s->threads = lc_get_u32(in);
    s->depth = lc_get_u32(in + 4);
    s->objects = lc_get_u64(in + 8);
    s->entries = lc_get_u64(in + 16);
    s->candidates = lc_get_u64(in + 24);
    s->exact_tests = lc_get_u64(in + 32);
    s->pairs = lc_get_u64(in + 40);
    s->ms_total = get_f64(in + 48);
    s->ms_bounds = get_f64(in + 56);
    s->ms_encode = get_f64(in + 64);
    s->ms_sort = get_f64(in + 72);
    s->ms_merge = get_f64(in + 80);
    s->ms_sweep = get_f64(in + 88);
    s->ms_order = get_f64(in + 96);
    s->ms_transfer = get_f64(in + 104);
}

int lc_proto_write_all(int fd, const void *buf, size_t len)
{
    const char *p = buf;
    while (len) {
        ssize_t w = send(fd, p, len, MSG_NOSIGNAL);
        if (w < 0) {
            if (errno == EINTR)
                continue;
            return 0;
        }
        p += w;
        len -= (size_t)w;
    }
    return 1;
}

/* Milliseconds left until deadline (an lc_now_ms() value; < 0 = none):
 * -1 for no deadline, else at least 0. */
static int ms_left(double deadline)
{
    double left;
    if (deadline < 0)
        return -1;
    left = deadline - lc_now_ms();
    if (left <= 0)
        return 0;
    return left > 2e9 ? 2000000000 : (int)left + 1;
}

/* The one reading loop: each wait for bytes is bounded by stall_ms (< 0 =
 * unbounded) and by the total deadline (< 0 = none), whichever is sooner. */
static int read_until(int fd, void *buf, size_t len, int stall_ms, double deadline, char *why, size_t why_len)
{
    char *p = buf;
    size_t got = 0;
    while (got < len) {
        ssize_t r;
        int left = ms_left(deadline), wait = left;
        if (stall_ms >= 0 && (wait < 0 || stall_ms < wait))
            wait = stall_ms;
        if (wait >= 0) {
            struct pollfd pfd;
            int pr;
            pfd.fd = fd;
            pfd.events = POLLIN;
            pfd.revents = 0;
            pr = wait ? poll(&pfd, 1, wait) : 0;
            if (pr < 0 && errno == EINTR)
                continue;
            if (pr == 0) {
                if (wait == left) /* the server's session tells the deadline by this text */
                    snprintf(why, why_len, "deadline passed after %zu of %zu bytes", got, len);
                else
                    snprintf(why, why_len, "timed out after %zu of %zu bytes", got, len);
                return -1;
            }
        }
        r = recv(fd, p + got, len - got, wait >= 0 ? MSG_DONTWAIT : 0);
        if (r < 0) {
            if (errno == EINTR || errno == EAGAIN || errno == EWOULDBLOCK)
                continue;
            snprintf(why, why_len, "read failed: %s", strerror(errno));
            return -1;
        }
        if (r == 0) {
            if (got == 0) {
                snprintf(why, why_len, "connection closed");
                return 0;
            }
            snprintf(why, why_len, "truncated message: connection closed after %zu of %zu bytes", got, len);
            return -1;
        }
        got += (size_t)r;
    }
    return 1;
}

int lc_proto_read_all(int fd, void *buf, size_t len, int timeout_ms, char *why, size_t why_len)
{
    return read_until(fd, buf, len, timeout_ms, -1.0, why, why_len);
}

int lc_proto_read_by(int fd, void *buf, size_t len, double deadline, char *why, size_t why_len)
{
    return read_until(fd, buf, len, -1, deadline, why, why_len);
}

int lc_proto_write_by(int fd, const void *buf, size_t len, double deadline)
{
    const char *p = buf;
    while (len) {
        ssize_t w;
        int left = ms_left(deadline);
        if (left >= 0) {
            struct pollfd pfd;
            int pr;
            pfd.fd = fd;
            pfd.events = POLLOUT;
            pfd.revents = 0;
            pr = left ? poll(&pfd, 1, left) : 0;
            if (pr < 0 && errno == EINTR)
                continue;
            if (pr == 0) {
                errno = ETIMEDOUT;
                return 0;
            }
        }
        w = send(fd, p, len, MSG_NOSIGNAL | (left >= 0 ? MSG_DONTWAIT : 0));
        if (w < 0) {
            if (errno == EINTR || errno == EAGAIN || errno == EWOULDBLOCK)
                continue;
            return 0;
        }
        p += w;
        len -= (size_t)w;
    }
    return 1;
}

int lc_proto_skip(int fd, uint64_t len, int timeout_ms, char *why, size_t why_len)
{
    char buf[4096];
    while (len) {
        size_t chunk = len > sizeof buf ? sizeof buf : (size_t)len;
        if (lc_proto_read_all(fd, buf, chunk, timeout_ms, why, why_len) != 1)
            return 0;
        len -= chunk;
    }
    return 1;
}

int lc_proto_parse_address(const char *s, lc_address *a, char *why, size_t why_len)
{
    const char *colon;
    memset(a, 0, sizeof *a);
    if (!s) {
        snprintf(why, why_len, "no address");
        return 0;
    }
    if (!strncmp(s, "unix:", 5)) {
        if (!s[5] || strlen(s + 5) >= sizeof a->path) {
            snprintf(why, why_len, "unix socket path is empty or longer than %zu bytes", sizeof a->path - 1);
            return 0;
        }
        strcpy(a->path, s + 5);
        return 1;
    }
    if (!strncmp(s, "tcp:", 4)) {
        s += 4;
        colon = strrchr(s, ':');
        if (!colon || colon == s || !colon[1] || (size_t)(colon - s) >= sizeof a->host ||
            strlen(colon + 1) >= sizeof a->port) {
            snprintf(why, why_len, "expected tcp:HOST:PORT");
            return 0;
        }
        a->tcp = 1;
        memcpy(a->host, s, (size_t)(colon - s));
        strcpy(a->port, colon + 1);
        return 1;
    }
    snprintf(why, why_len, "address '%s' is neither unix:PATH nor tcp:HOST:PORT", s);
    return 0;
}

int lc_proto_secret_equal(const char *a, size_t alen, const char *b, size_t blen)
{
    unsigned diff = (unsigned)(alen ^ blen);
    size_t i, n = alen < blen ? alen : blen;
    for (i = 0; i < n; i++)
        diff |= (unsigned)(unsigned char)(a[i] ^ b[i]);
    return diff == 0;
}
