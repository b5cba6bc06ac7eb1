/* The paper's split (Lucchesi, Egbert, Harris 2014), kept for comparison:
 * every rank encodes and sorts its own boxes, one rank (the master)
 * gathers every sorted run and every box, merges the runs and sweeps the
 * whole scene alone. Its memory and its sweep do not shrink with more
 * ranks: docs/cluster.md measures what that costs. */
#include "mpi/part.h"

#include <stdlib.h>

/* The merge of the paper's MergeSlaveResults(): k ascending runs, back to
 * back in rank order, into one (a sort past LC_MAX_THREADS runs). */
static locd_status merge_runs(lm_ctx *c, const uint64_t *counts, lm_held *h)
{
    uint64_t *out = malloc(h->count * sizeof *out + 1);
    locd_status st;
    if (!out)
        return lc_error(LOCD_ERR_NO_MEMORY, "%zu merged entries", h->count);
    if (c->ranks <= LC_MAX_THREADS) {
        const uint64_t *runs[LC_MAX_THREADS];
        size_t cnt[LC_MAX_THREADS], at = 0;
        int r;
        for (r = 0; r < c->ranks; r++) {
            runs[r] = h->ent + at;
            cnt[r] = (size_t)counts[r];
            at += cnt[r];
        }
        st = locd_merge_entries(runs, cnt, (size_t)c->ranks, out);
    } else {
        st = locd_sort_entries(&c->grid, h->ent, out, h->count); /* out as scratch */
        if (!st)
            memcpy(out, h->ent, h->count * sizeof *out);
    }
    free(h->ent);
    h->ent = out;
    return st;
}

locd_status lm_master_gather(lm_ctx *c, int root, lm_held *h)
{
    uint64_t *counts = malloc(2 * (size_t)c->ranks * sizeof *counts), total = 0;
    MPI_Datatype box_type;
    locd_status st = LOCD_OK;
    size_t i;
    int r;
    memset(h, 0, sizeof *h);
    if ((st = lm_agree(c, counts ? LOCD_OK : lc_error(LOCD_ERR_NO_MEMORY, "gather counts"))) != LOCD_OK) {
        free(counts);
        return st;
    }
    lm_allgather_u64(c, c->nent, counts);
    for (r = 0; r < c->ranks; r++) {
        counts[c->ranks + r] = c->offsets[r + 1] - c->offsets[r];
        total += counts[r];
    }
    for (i = 0; i < c->nent; i++) /* local to global indices: no carry, both below 2^index_bits */
        c->ent[i] += c->offsets[c->rank];
    if (c->rank == root) {
        h->count = (size_t)total;
        h->nobj = (size_t)c->n;
        h->ent = malloc(h->count * sizeof *h->ent + 1);
        h->boxes = malloc(h->nobj * c->es + 1);
        if (!h->ent || !h->boxes)
            st = lc_error(LOCD_ERR_NO_MEMORY, "%zu entries and %zu boxes on the master", h->count, h->nobj);
    }
    if ((st = lm_agree(c, st)) == LOCD_OK) {
        MPI_Type_contiguous((int)c->es, MPI_BYTE, &box_type);
        MPI_Type_commit(&box_type);
        lm_gather(c, root, c->ent, counts, h->ent, MPI_UINT64_T, sizeof(uint64_t));
        lm_gather(c, root, c->boxes, counts + c->ranks, h->boxes, box_type, c->es);
        MPI_Type_free(&box_type);
        free(c->ent);
        c->ent = NULL;
        c->st.ms_exchange = lm_lap(c);
        st = lm_agree(c, c->rank == root ? merge_runs(c, counts, h) : LOCD_OK);
        c->st.ms_merge = lm_lap(c);
    }
    free(counts);
    if (st)
        lm_held_free(h);
    return st;
}
