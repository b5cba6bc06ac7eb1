/* The collectives every stage uses: agreeing on errors, the chunked
 * all-to-all and gather (no int count or displacement limit), laps. */
#include "mpi/part.h"

#include <stdlib.h>

/* Elements per message: counts stay far below INT_MAX and a message below
 * a gigabyte for the largest element (48-byte boxes). */
#define LM_CHUNK ((uint64_t)1 << 24)
#define LM_TAG 0x10cd

locd_status lm_agree(lm_ctx *c, locd_status st)
{
    struct {
        int v, r;
    } in, out;
    in.v = st < 0 ? (int)st : 0;
    in.r = c->rank;
    MPI_Allreduce(&in, &out, 1, MPI_2INT, MPI_MINLOC, c->comm);
    if (out.v >= 0)
        return LOCD_OK;
    if (st == out.v)
        return st; /* this rank's own message stays */
    return lc_error(out.v, "rank %d failed: %s", out.r, locd_status_string(out.v));
}

double lm_lap(lm_ctx *c)
{
    double now = lc_now_ms(), d = now - c->lap;
    c->lap = now;
    return d;
}

void lm_allgather_u64(lm_ctx *c, uint64_t mine, uint64_t *out)
{
    MPI_Allgather(&mine, 1, MPI_UINT64_T, out, 1, MPI_UINT64_T, c->comm);
}

/* One message in flight as a stream of chunks. */
typedef struct lm_stream {
    char *p;
    uint64_t left; /* elements */
    int peer, send;
} lm_stream;

/* Moves the streams forward together, at most LM_BATCH chunks of each
 * posted before a wait: no allocation, and the chunks of one stream are
 * matched in order (same peer, tag and communicator). */
#define LM_BATCH 16
static void run_streams(lm_ctx *c, lm_stream *sm, int ns, MPI_Datatype type, size_t esize)
{
    MPI_Request req[4 * LM_BATCH];
    int more = 1;
    while (more) {
        int nreq = 0, i, b;
        more = 0;
        for (i = 0; i < ns; i++)
            for (b = 0; b < LM_BATCH && sm[i].left; b++) {
                const int part = (int)(sm[i].left < LM_CHUNK ? sm[i].left : LM_CHUNK);
                if (sm[i].send)
                    MPI_Isend(sm[i].p, part, type, sm[i].peer, LM_TAG, c->comm, &req[nreq++]);
                else
                    MPI_Irecv(sm[i].p, part, type, sm[i].peer, LM_TAG, c->comm, &req[nreq++]);
                sm[i].p += (size_t)part * esize;
                sm[i].left -= (uint64_t)part;
            }
        if (nreq)
            MPI_Waitall(nreq, req, MPI_STATUSES_IGNORE);
        for (i = 0; i < ns; i++)
            more |= sm[i].left != 0;
    }
}

void lm_sendrecv(lm_ctx *c, int to, const void *send, uint64_t scount, int from, void *recv, uint64_t rcount,
                 MPI_Datatype type, size_t esize)
{
    lm_stream sm[2];
    sm[0].p = recv;
    sm[0].left = rcount;
    sm[0].peer = from;
    sm[0].send = 0;
    sm[1].p = (char *)(uintptr_t)send; /* only read: MPI_Isend takes const void * */
    sm[1].left = scount;
    sm[1].peer = to;
    sm[1].send = 1;
    run_streams(c, sm, 2, type, esize);
    c->st.bytes_sent += scount * esize;
    c->st.bytes_received += rcount * esize;
}

void lm_gather(lm_ctx *c, int root, const void *send, const uint64_t *counts, void *recv, MPI_Datatype type,
               size_t esize)
{
    lm_stream sm;
    int s;
    if (c->rank != root) {
        sm.p = (char *)(uintptr_t)send;
        sm.left = counts[c->rank];
        sm.peer = root;
        sm.send = 1;
        run_streams(c, &sm, 1, type, esize);
        c->st.bytes_sent += counts[c->rank] * esize;
        return;
    }
    sm.p = recv;
    for (s = 0; s < c->ranks; s++) {
        if (s == root) {
            if (counts[s])
                memcpy(sm.p, send, counts[s] * esize);
            sm.p += counts[s] * esize;
            continue;
        }
        sm.left = counts[s];
        sm.peer = s;
        sm.send = 0;
        run_streams(c, &sm, 1, type, esize); /* advances sm.p past rank s's elements */
        c->st.bytes_received += counts[s] * esize;
    }
}
