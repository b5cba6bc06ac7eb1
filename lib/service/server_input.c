/* The service, reading a SUBMIT: the fixed part, checked against the
 * limits before anything is allocated for it, then the boxes, either
 * inline in the message or copied out of a shared-memory segment the
 * client made. Every read of one message shares its deadline (c->deadline,
 * set when its first byte came). A job over a limit is answered
 * LOCD_ERR_LIMIT after its payload is read past; the connection goes on. */
#define _XOPEN_SOURCE 700 /* pread */
#include "service/service.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

static int valid_shm_name(const char *n)
{
    size_t i, p = strlen(LC_PROTO_SHM_PREFIX);
    if (strncmp(n, LC_PROTO_SHM_PREFIX, p) != 0)
        return 0;
    for (i = p; n[i]; i++)
        if (!((n[i] >= 'a' && n[i] <= 'z') || (n[i] >= 'A' && n[i] <= 'Z') || (n[i] >= '0' && n[i] <= '9') ||
              n[i] == '-'))
            return 0;
    return 1;
}

/* Copies the segment's bytes with pread rather than mapping them: the
 * client still holds the segment and may shrink it (ftruncate) at any
 * time, which would make a read of a mapping past its new end a SIGBUS
 * that kills the service. A shrunk segment is a short read here: an error
 * for this job only. 1, or 0 (why). */
static int copy_segment(lc_srv_job *j, int fd, const char *name, char *why, size_t wl)
{
    char *dst;
    size_t off = 0;
    j->boxes = malloc(j->bytes ? j->bytes : 1);
    if (!j->boxes) {
        snprintf(why, wl, "out of memory for %zu bytes of boxes", j->bytes);
        return 0;
    }
    dst = j->boxes;
    while (off < j->bytes) {
        ssize_t r = pread(fd, dst + off, j->bytes - off, (off_t)off);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0) {
            snprintf(why, wl, "segment %s shrank or failed after %zu of %zu bytes", name, off, j->bytes);
            return 0;
        }
        off += (size_t)r;
    }
    return 1;
}

/* Opens the client's segment, removes its name (the service is the last
 * party to open it) and copies the boxes. 1, or 0 (why). */
static int read_client_segment(lc_srv_job *j, const char *name, char *why, size_t wl)
{
    struct stat sb;
    int ok, fd = shm_open(name, O_RDONLY, 0);
    if (fd < 0) {
        snprintf(why, wl, "cannot open the job's segment %s: %s", name, strerror(errno));
        return 0;
    }
    shm_unlink(name);
    if (fstat(fd, &sb) != 0 || sb.st_uid != geteuid() || (uint64_t)sb.st_size != (uint64_t)j->bytes) {
        close(fd);
        snprintf(why, wl, "segment %s has the wrong owner or size", name);
        return 0;
    }
    ok = copy_segment(j, fd, name, why, wl);
    close(fd);
    return ok;
}

/* Reads the fixed part into a new job (no boxes yet): 1, or 0 to drop (why). */
static int read_fixed(lc_srv_conn *c, const lc_msg_header *h, lc_srv_job **out, char *why, size_t wl)
{
    uint8_t fixed[LC_PROTO_SUBMIT_FIXED];
    lc_srv_job *j;
    size_t es;
    if (h->length < LC_PROTO_SUBMIT_FIXED) {
        snprintf(why, wl, "short SUBMIT message");
        return 0;
    }
    if (lc_proto_read_by(c->fd, fixed, sizeof fixed, c->deadline, why, wl) != 1)
        return 0;
    j = calloc(1, sizeof *j);
    if (!j) {
        snprintf(why, wl, "out of memory");
        return 0;
    }
    j->id = h->id;
    lc_proto_get_submit(fixed, &j->f);
    es = j->f.f64 ? sizeof(double) : sizeof(float);
    /* n is bounded before n * bytes-per-box is computed: no overflow. */
    if (j->f.f64 > 1 || j->f.transport > 1 || j->f.n > (uint64_t)UINT32_MAX + 1u ||
        j->f.n > c->s->cfg.max_message / (LC_PROTO_BOX_VALUES * es) + 1) {
        snprintf(why, wl, "bad SUBMIT header (n %llu, f64 %u, transport %u)", (unsigned long long)j->f.n, j->f.f64,
                 j->f.transport);
        free(j);
        return 0;
    }
    j->bytes = (size_t)(j->f.n * LC_PROTO_BOX_VALUES * es);
    *out = j;
    return 1;
}

/* Reads and drops len bytes of the current message: 1, or 0 (why). */
static int skip_payload(lc_srv_conn *c, uint64_t len, char *why, size_t wl)
{
    char buf[4096];
    while (len) {
        size_t chunk = len > sizeof buf ? sizeof buf : (size_t)len;
        if (lc_proto_read_by(c->fd, buf, chunk, c->deadline, why, wl) != 1)
            return 0;
        len -= chunk;
    }
    return 1;
}

/* The boxes that follow the fixed part: 1, or 0 to drop (why). *refused
 * is set (with the reason in refusal) when the job is over a limit: its
 * boxes are then read past. */
static int read_inline_boxes(lc_srv_conn *c, const lc_msg_header *h, lc_srv_job *j, int refused, char *why,
                             size_t wl)
{
    if (h->length != LC_PROTO_SUBMIT_FIXED + (uint64_t)j->bytes) {
        snprintf(why, wl, "SUBMIT length %llu does not match %llu boxes", (unsigned long long)h->length,
                 (unsigned long long)j->f.n);
        return 0;
    }
    if (refused)
        return skip_payload(c, j->bytes, why, wl);
    j->boxes = malloc(j->bytes ? j->bytes : 1);
    if (!j->boxes) {
        snprintf(why, wl, "out of memory for %llu bytes", (unsigned long long)j->bytes);
        return 0;
    }
    if (j->bytes && lc_proto_read_by(c->fd, j->boxes, j->bytes, c->deadline, why, wl) != 1)
        return 0;
    return 1;
}

/* Reads the segment name that ends a shared-memory SUBMIT into name
 * (LC_SRV_MAX_SHM_NAME + 1 bytes): 1, or 0 to drop (why). A bad name is
 * logged escaped: it is the client's text. */
static int read_shm_name(lc_srv_conn *c, const lc_msg_header *h, char *name, char *why, size_t wl)
{
    uint8_t nl[4];
    uint32_t len;
    /* The name's length is part of this message: never read past it. */
    if (h->length < LC_PROTO_SUBMIT_FIXED + sizeof nl) {
        snprintf(why, wl, "bad segment name in SUBMIT");
        return 0;
    }
    if (lc_proto_read_by(c->fd, nl, sizeof nl, c->deadline, why, wl) != 1)
        return 0;
    len = lc_get_u32(nl);
    if (len > LC_SRV_MAX_SHM_NAME || h->length != LC_PROTO_SUBMIT_FIXED + sizeof nl + (uint64_t)len) {
        snprintf(why, wl, "bad segment name in SUBMIT");
        return 0;
    }
    if (lc_proto_read_by(c->fd, name, len, c->deadline, why, wl) != 1)
        return 0;
    name[len] = '\0';
    if (strlen(name) != len || !valid_shm_name(name)) {
        char shown[4 * LC_SRV_MAX_SHM_NAME + 1];
        lc_srv_escape(name, len, shown, sizeof shown);
        snprintf(why, wl, "segment name '%s' is not a locd segment", shown);
        return 0;
    }
    return 1;
}

/* The boxes of j from the client's segment: 1 when the connection is fine
 * (*ok 0 when this job failed, with the reason in fail), 0 to drop (why). */
static int read_shm_boxes(lc_srv_conn *c, const lc_msg_header *h, lc_srv_job *j, int refused, int *ok, char *fail,
                          size_t fl, char *why, size_t wl)
{
    char name[LC_SRV_MAX_SHM_NAME + 1];
    *ok = 1;
    if (!c->shm_ok) {
        snprintf(why, wl, "shared-memory SUBMIT on a connection that may not use it");
        return 0;
    }
    if (!read_shm_name(c, h, name, why, wl))
        return 0;
    /* The client's problem (or a cancelled job): answer, keep serving. A
       refused job's segment is the client's to remove. */
    if (!refused && !read_client_segment(j, name, fail, fl))
        *ok = 0;
    return 1;
}

int lc_srv_read_submit(lc_srv_conn *c, const lc_msg_header *h, lc_srv_job **out, char *why, size_t wl)
{
    char fail[300];
    lc_srv_job *j;
    locd_status st;
    int ok = 1, refused;
    *out = NULL;
    if (!read_fixed(c, h, &j, why, wl))
        return 0;
    /* Admitted jobs count against the connection's limits from here on. */
    st = lc_srv_admit(c, j, fail, sizeof fail);
    refused = st != LOCD_OK;
    if (!(j->f.transport == 0 ? read_inline_boxes(c, h, j, refused, why, wl)
                              : read_shm_boxes(c, h, j, refused, &ok, fail, sizeof fail, why, wl))) {
        if (refused)
            lc_srv_job_free(j);
        else
            lc_srv_job_retire(j);
        return 0;
    }
    if (refused || !ok) {
        uint64_t id = j->id;
        /* Out of the count before the answer: see server_jobs.c, answer(). */
        if (refused) {
            lc_srv_log(c->s, LOCD_LOG_INFO, "refused a job of %s: %s", c->peer, fail);
            lc_srv_job_free(j);
        } else {
            lc_srv_job_retire(j); /* this thread's reference keeps c */
        }
        lc_srv_send_result(c, id, refused ? st : LOCD_ERR_IO, fail, -1, NULL, NULL, 0);
        return 1;
    }
    *out = j;
    return 1;
}
