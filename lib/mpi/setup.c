/* The first collective of a call: every rank's status, box count and
 * options, so that every rank takes the same decision (go on, or the same
 * error) before any other collective. */
#include "mpi/part.h"

#include <stdlib.h>

enum { LM_F_STATUS, LM_F_N, LM_F_STRATEGY, LM_F_ROOT, LM_F_DEPTH, LM_F_BIAS, LM_F_FLAGS, LM_F_SAMPLES,
       LM_F_F64, LM_FIELDS };

/* The first rank whose options differ from rank 0's, or -1. */
static int options_differ(const int64_t *all, int ranks)
{
    int r, f;
    for (r = 1; r < ranks; r++)
        for (f = LM_F_STRATEGY; f < LM_FIELDS; f++)
            if (all[r * LM_FIELDS + f] != all[f])
                return r;
    return -1;
}

locd_status lm_setup(lm_ctx *c, locd_status local)
{
    int64_t mine[LM_FIELDS], *all;
    uint64_t n = 0;
    int r, bad = -1;
    mine[LM_F_STATUS] = local < 0 ? local : 0;
    mine[LM_F_N] = (int64_t)c->local_n;
    mine[LM_F_STRATEGY] = c->opt.strategy;
    mine[LM_F_ROOT] = c->opt.gather_root;
    mine[LM_F_DEPTH] = c->opt.max_depth;
    mine[LM_F_BIAS] = c->opt.cell_bias;
    mine[LM_F_FLAGS] = c->opt.flags;
    mine[LM_F_SAMPLES] = c->opt.samples;
    mine[LM_F_F64] = c->f64;
    all = malloc((size_t)c->ranks * sizeof mine);
    c->offsets = malloc(((size_t)c->ranks + 1) * sizeof *c->offsets);
    /* No memory for a few bytes a rank: the others must still hear of it,
       and the gather needs the buffer, so the status alone goes round. */
    if (lm_agree(c, (!all || !c->offsets) ? lc_error(LOCD_ERR_NO_MEMORY, "rank tables") : LOCD_OK) != LOCD_OK) {
        free(all);
        return LOCD_ERR_NO_MEMORY;
    }
    MPI_Allgather(mine, LM_FIELDS, MPI_INT64_T, all, LM_FIELDS, MPI_INT64_T, c->comm);
    for (r = 0; r < c->ranks; r++) {
        if (all[r * LM_FIELDS + LM_F_STATUS] < 0 && bad < 0)
            bad = r;
        c->offsets[r] = n;
        n += (uint64_t)all[r * LM_FIELDS + LM_F_N];
    }
    c->offsets[c->ranks] = n;
    c->n = n;
    if (bad >= 0) {
        const locd_status st = (locd_status)all[bad * LM_FIELDS + LM_F_STATUS];
        free(all);
        return bad == c->rank ? local : lc_error(st, "rank %d failed: %s", bad, locd_status_string(st));
    }
    if ((r = options_differ(all, c->ranks)) >= 0) {
        free(all);
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "rank %d's options or precision differ from rank 0's", r);
    }
    free(all);
    if (c->opt.gather_root >= c->ranks)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "gather_root %d is not a rank of the %d", (int)c->opt.gather_root,
                        c->ranks);
    if (n > (uint64_t)UINT32_MAX + 1u)
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "%llu objects in all do not fit a 32-bit index",
                        (unsigned long long)n);
    return LOCD_OK;
}
