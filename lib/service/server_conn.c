/* The service, what every part of it shares about a connection: writing on
 * it (one writer at a time, since runners answer while its reader reads),
 * the RESULT and ERROR messages, its reference count, and the log. */
#include "service/service.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/socket.h>

void lc_srv_log(const lc_server *s, int32_t sev, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    lc_log_emit(s->cfg.log, s->cfg.log_user, sev, fmt, ap);
    va_end(ap);
}

void lc_srv_conn_unref_locked(lc_srv_conn *c)
{
    if (--c->refs == 0) {
        pthread_mutex_destroy(&c->wmu);
        free(c);
    }
}

void lc_srv_escape(const char *in, size_t len, char *out, size_t out_len)
{
    static const char hex[] = "0123456789abcdef";
    size_t i, o = 0;
    if (!out_len)
        return;
    for (i = 0; i < len; i++) {
        unsigned char ch = (unsigned char)in[i];
        if (ch >= 0x20 && ch < 0x7f && ch != '\\') {
            if (o + 1 >= out_len)
                break;
            out[o++] = (char)ch;
        } else {
            if (o + 4 >= out_len)
                break;
            out[o++] = '\\';
            out[o++] = 'x';
            out[o++] = hex[ch >> 4];
            out[o++] = hex[ch & 15];
        }
    }
    out[o] = '\0';
}

/* One message must be written within the send deadline as a whole: a
 * client that reads a byte now and then would otherwise hold the runner
 * that answers it (and every client waiting for a runner). A client too
 * slow for it is dropped. */
int lc_srv_send(lc_srv_conn *c, const void *a, size_t alen, const void *b, size_t blen)
{
    int ok = 0;
    pthread_mutex_lock(&c->wmu);
    if (!c->closed) {
        double deadline = lc_now_ms() + (double)c->s->cfg.send_timeout_ms;
        ok = lc_proto_write_by(c->fd, a, alen, deadline);
        if (ok && blen)
            ok = lc_proto_write_by(c->fd, b, blen, deadline);
        if (!ok) {
            if (errno == ETIMEDOUT)
                lc_srv_log(c->s, LOCD_LOG_WARNING, "dropping connection from %s: it did not read a message of %zu bytes within %u ms",
                           c->peer, alen + blen, c->s->cfg.send_timeout_ms);
            shutdown(c->fd, SHUT_RDWR); /* the reader thread notices and cleans up */
            c->closed = 1; /* nothing more goes out on a stream cut mid-message */
        }
    }
    pthread_mutex_unlock(&c->wmu);
    return ok;
}

static size_t text_length(const char *msg)
{
    size_t mlen = msg ? strlen(msg) : 0;
    return mlen > LC_PROTO_MAX_TEXT ? LC_PROTO_MAX_TEXT : mlen;
}

void lc_srv_send_result(lc_srv_conn *c, uint64_t id, locd_status st, const char *msg, int64_t index,
                        const locd_stats *stats, const uint32_t *pairs, size_t count)
{
    uint8_t buf[LC_PROTO_HEADER + LC_PROTO_RESULT_FIXED + LC_PROTO_MAX_TEXT + LC_PROTO_STATS_BYTES + 8];
    size_t mlen = text_length(msg), off;
    locd_stats empty;
    if (!stats) {
        locd_stats_init(&empty);
        stats = &empty;
    }
    off = LC_PROTO_HEADER;
    lc_put_u32(buf + off, (uint32_t)st);
    lc_put_u64(buf + off + 4, (uint64_t)index);
    lc_put_u32(buf + off + 12, (uint32_t)mlen);
    off += LC_PROTO_RESULT_FIXED;
    if (mlen)
        memcpy(buf + off, msg, mlen);
    off += mlen;
    lc_proto_put_stats(buf + off, stats);
    off += LC_PROTO_STATS_BYTES;
    lc_put_u64(buf + off, count);
    off += 8;
    lc_proto_put_header(buf, LC_MSG_RESULT, id, off - LC_PROTO_HEADER + (uint64_t)count * LC_PROTO_PAIR_BYTES);
    lc_srv_send(c, buf, off, pairs, count * LC_PROTO_PAIR_BYTES);
}

void lc_srv_send_error(int fd, locd_status st, const char *msg)
{
    uint8_t buf[LC_PROTO_HEADER + LC_PROTO_ERROR_FIXED + LC_PROTO_MAX_TEXT];
    size_t mlen = text_length(msg);
    lc_proto_put_header(buf, LC_MSG_ERROR, 0, LC_PROTO_ERROR_FIXED + mlen);
    lc_put_u32(buf + LC_PROTO_HEADER, (uint32_t)st);
    lc_put_u32(buf + LC_PROTO_HEADER + 4, (uint32_t)mlen);
    memcpy(buf + LC_PROTO_HEADER + LC_PROTO_ERROR_FIXED, msg, mlen);
    lc_proto_write_all(fd, buf, LC_PROTO_HEADER + LC_PROTO_ERROR_FIXED + mlen);
}
