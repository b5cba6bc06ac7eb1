/* One grid for the whole scene from one reduction: the grid level 1 fits
 * on all the boxes at once (lib/octree/grid.c), so that the entries, the
 * sweep and its order are level 1's. */
#include "mpi/part.h"

#include <math.h>
#include <stdlib.h>

/* Sample k of the depth tuning is box k * stride: the first k this rank holds. */
static uint64_t first_sample(uint64_t offset, uint64_t stride)
{
    uint64_t k = (offset + stride - 1) / stride;
    return k < LC_TUNE_SAMPLE ? k : LC_TUNE_SAMPLE;
}

/* Gathers the tuning sample (6 doubles a box, in k order) and sets the depth. */
static locd_status tune_depth(lm_ctx *c)
{
    const uint64_t stride = c->n / LC_TUNE_SAMPLE;
    const uint64_t k0 = first_sample(c->offsets[c->rank], stride), k1 = first_sample(c->offsets[c->rank + 1], stride);
    double *sample = malloc(LC_TUNE_SAMPLE * 6 * sizeof *sample);
    int *counts = malloc((size_t)c->ranks * 2 * sizeof *counts), r;
    uint64_t k;
    locd_status st = (!sample || !counts) ? lc_error(LOCD_ERR_NO_MEMORY, "depth sample") : LOCD_OK;
    if ((st = lm_agree(c, st)) == LOCD_OK) {
        for (r = 0; r < c->ranks; r++) {
            const uint64_t a = first_sample(c->offsets[r], stride), b = first_sample(c->offsets[r + 1], stride);
            counts[r] = (int)(6 * (b - a));
            counts[c->ranks + r] = (int)(6 * a);
        }
        for (k = k0; k < k1; k++) {
            const size_t i = (size_t)(k * stride - c->offsets[c->rank]);
            int a;
            for (a = 0; a < 6; a++) /* float to double is exact: level 1 reads (double)b[a] */
                sample[6 * k + (uint64_t)a] =
                    c->f64 ? ((const double *)c->boxes)[6 * i + (size_t)a] : (double)((const float *)c->boxes)[6 * i + (size_t)a];
        }
        MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, sample, counts, counts + c->ranks, MPI_DOUBLE, c->comm);
        lc_grid_tune_sample(&c->grid, sample, (size_t)c->n);
    }
    free(sample);
    free(counts);
    return st;
}

locd_status lm_fit_grid(lm_ctx *c)
{
    lc_bounds b;
    double v[7];
    int a;
    locd_status st;
    lc_bounds_init(&b);
    if (c->f64)
        lc_bounds_f64(c->boxes, 0, c->local_n, &b, c->kernel);
    else
        lc_bounds_f32(c->boxes, 0, c->local_n, &b, c->kernel);
    /* One MIN reduction: the low corner, the negated high corner, and the
       first bad box as 2 * global index + (inverted ? 1 : 0), exact in a
       double (indices < 2^33). */
    for (a = 0; a < 3; a++) {
        v[a] = b.lo[a];
        v[a + 3] = -b.hi[a];
    }
    v[6] = b.bad >= 0 ? 2.0 * (double)(c->offsets[c->rank] + (uint64_t)b.bad) + (b.bad_status == LOCD_ERR_INVERTED_BOX)
                      : HUGE_VAL;
    MPI_Allreduce(MPI_IN_PLACE, v, 7, MPI_DOUBLE, MPI_MIN, c->comm);
    if (v[6] != HUGE_VAL) {
        const uint64_t code = (uint64_t)v[6], idx = code >> 1;
        int r = 0;
        while (r + 1 < c->ranks && c->offsets[r + 1] <= idx)
            r++;
        return lc_error_box((code & 1) ? LOCD_ERR_INVERTED_BOX : LOCD_ERR_NONFINITE, (int64_t)idx,
                            "box %llu (rank %d's box %llu)", (unsigned long long)idx, r,
                            (unsigned long long)(idx - c->offsets[r]));
    }
    for (a = 0; a < 3; a++) {
        b.lo[a] = v[a];
        b.hi[a] = -v[a + 3];
    }
    st = lc_grid_from_bounds(&b, (size_t)c->n, c->opt.max_depth, c->opt.cell_bias, c->opt.flags, &c->grid);
    if (st) /* the same arguments on every rank: the same error */
        return st;
    if (!c->opt.max_depth && c->n >= LC_TUNE_MIN_N)
        st = tune_depth(c);
    c->st.depth = c->grid.depth;
    return st;
}
