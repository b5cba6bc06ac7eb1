/* The service, reading a SUBMIT: the fixed part, checked against the
 * limits before anything is allocated for it, then the boxes, either
 * inline in the message or in a shared-memory segment the client made. */
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

/* Maps the client's segment, then removes its name: the service is the
 * last party to open it. 1, or 0 (why). */
static int map_client_segment(lc_srv_job *j, const char *name, char *why, size_t wl)
{
    struct stat sb;
    int fd = shm_open(name, O_RDONLY, 0);
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
    if (j->bytes) {
        j->boxes = mmap(NULL, j->bytes, PROT_READ, MAP_SHARED, fd, 0);
        if (j->boxes == MAP_FAILED) {
            j->boxes = NULL;
            close(fd);
            snprintf(why, wl, "cannot map segment %s", name);
            return 0;
        }
        j->mapped = 1;
    }
    close(fd);
    return 1;
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
    if (lc_proto_read_all(c->fd, fixed, sizeof fixed, LC_MSG_TIMEOUT_MS, why, wl) != 1)
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

/* The boxes that follow the fixed part: 1, or 0 to drop (why). */
static int read_inline_boxes(lc_srv_conn *c, const lc_msg_header *h, lc_srv_job *j, char *why, size_t wl)
{
    if (h->length != LC_PROTO_SUBMIT_FIXED + (uint64_t)j->bytes) {
        snprintf(why, wl, "SUBMIT length %llu does not match %llu boxes", (unsigned long long)h->length,
                 (unsigned long long)j->f.n);
        return 0;
    }
    j->boxes = malloc(j->bytes ? j->bytes : 1);
    if (!j->boxes) {
        snprintf(why, wl, "out of memory for %llu bytes", (unsigned long long)j->bytes);
        return 0;
    }
    if (j->bytes && lc_proto_read_all(c->fd, j->boxes, j->bytes, LC_MSG_TIMEOUT_MS, why, wl) != 1)
        return 0;
    return 1;
}

/* Reads the segment name that ends a shared-memory SUBMIT into name
 * (LC_SRV_MAX_SHM_NAME + 1 bytes): 1, or 0 to drop (why). */
static int read_shm_name(lc_srv_conn *c, const lc_msg_header *h, char *name, char *why, size_t wl)
{
    uint8_t nl[4];
    uint32_t len;
    /* The name's length is part of this message: never read past it. */
    if (h->length < LC_PROTO_SUBMIT_FIXED + sizeof nl) {
        snprintf(why, wl, "bad segment name in SUBMIT");
        return 0;
    }
    if (lc_proto_read_all(c->fd, nl, sizeof nl, LC_MSG_TIMEOUT_MS, why, wl) != 1)
        return 0;
    len = lc_get_u32(nl);
    if (len > LC_SRV_MAX_SHM_NAME || h->length != LC_PROTO_SUBMIT_FIXED + sizeof nl + (uint64_t)len) {
        snprintf(why, wl, "bad segment name in SUBMIT");
        return 0;
    }
    if (lc_proto_read_all(c->fd, name, len, LC_MSG_TIMEOUT_MS, why, wl) != 1)
        return 0;
    name[len] = '\0';
    if (!valid_shm_name(name)) {
        snprintf(why, wl, "segment name '%s' is not a locd segment", name);
        return 0;
    }
    return 1;
}

/* Maps the boxes of *jp from the client's segment: 1 when the connection
 * is fine (*jp is NULL, freed, when its segment was refused), 0 to drop
 * (why). */
static int read_shm_boxes(lc_srv_conn *c, const lc_msg_header *h, lc_srv_job **jp, char *why, size_t wl)
{
    char name[LC_SRV_MAX_SHM_NAME + 1];
    if (!c->shm_ok) {
        snprintf(why, wl, "shared-memory SUBMIT on a connection that may not use it");
        return 0;
    }
    if (!read_shm_name(c, h, name, why, wl))
        return 0;
    if (!map_client_segment(*jp, name, why, wl)) {
        /* The client's problem (or a cancelled job): answer, keep serving. */
        lc_srv_send_result(c, (*jp)->id, LOCD_ERR_IO, why, -1, NULL, NULL, 0);
        lc_srv_job_free(*jp);
        *jp = NULL;
    }
    return 1;
}

int lc_srv_read_submit(lc_srv_conn *c, const lc_msg_header *h, lc_srv_job **out, char *why, size_t wl)
{
    lc_srv_job *j;
    *out = NULL;
    if (!read_fixed(c, h, &j, why, wl))
        return 0;
    if (!(j->f.transport == 0 ? read_inline_boxes(c, h, j, why, wl) : read_shm_boxes(c, h, &j, why, wl))) {
        lc_srv_job_free(j);
        return 0;
    }
    *out = j;
    return 1;
}
