/* Key-range splitters by weighted sampling: rank r sweeps the cells whose
 * key lies in [split[r], split[r + 1]). An entry weighs what sweeping it
 * costs: a fixed part and the candidates it meets in its own cell, whose
 * population each rank estimates from its share of that cell (objects
 * arrive in no spatial order, so a rank holding local_n of the n boxes
 * holds about that fraction of every cell). Each rank takes `samples` keys
 * at equal steps of its own cumulative weight; all ranks then see all the
 * samples and cut the weight into equal parts at sample keys, the same cut
 * on every rank. */
#include "mpi/part.h"

#include <stdlib.h>

/* Candidate tests that cost about as much as one entry's fixed work
 * (loading, the cell walk): the scans test 8 candidates at a time. */
#define LM_TESTS_PER_ENTRY 8.0

typedef struct lm_sample {
    uint64_t key;
    double w;
} lm_sample;

uint64_t lm_key_last(uint64_t key, uint32_t depth)
{
    const uint32_t level = (uint32_t)(key & ((1u << LC_LEVEL_BITS) - 1));
    const uint64_t span = (uint64_t)1 << (3u * (depth - level)); /* cells of the deepest level below it */
    const uint64_t pm = key >> LC_LEVEL_BITS;
    return ((pm + span - 1) << LC_LEVEL_BITS) | ((1u << LC_LEVEL_BITS) - 1);
}

static int by_key(const void *a, const void *b)
{
    const lm_sample *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return x->w < y->w ? -1 : x->w > y->w;
}

/* This rank's samples: `s` keys at equal steps of its cumulative weight. */
static void local_samples(const lm_ctx *c, lm_sample *out, uint32_t s)
{
    const uint32_t ib = c->grid.index_bits;
    const double scale = c->local_n ? (double)c->n / (double)c->local_n : 0.0;
    double total = 0.0, acc = 0.0;
    size_t p, q;
    uint32_t i = 0;
    for (p = 0; p < c->nent; p = q) { /* pass 1: the total weight */
        for (q = p + 1; q < c->nent && (c->ent[q] >> ib) == (c->ent[p] >> ib); q++)
            ;
        total += (double)(q - p) * (1.0 + (double)(q - p) * scale / LM_TESTS_PER_ENTRY);
    }
    for (p = 0; p < c->nent && i < s; p = q) { /* pass 2: the keys at (i + 1/2) * total / s */
        double w;
        for (q = p + 1; q < c->nent && (c->ent[q] >> ib) == (c->ent[p] >> ib); q++)
            ;
        w = (double)(q - p) * (1.0 + (double)(q - p) * scale / LM_TESTS_PER_ENTRY);
        acc += w;
        while (i < s && acc >= ((double)i + 0.5) * total / s) {
            out[i].key = c->ent[p] >> ib;
            out[i].w = total / s;
            i++;
        }
    }
    for (; i < s; i++) { /* no entries: weightless samples */
        out[i].key = 0;
        out[i].w = 0.0;
    }
}

locd_status lm_splitters(lm_ctx *c, uint64_t *split)
{
    const uint32_t s = c->opt.samples ? c->opt.samples : 256;
    const size_t all = (size_t)s * (size_t)c->ranks;
    lm_sample *mine = malloc(s * sizeof *mine), *every = malloc(all * sizeof *every);
    locd_status st = (!mine || !every) ? lc_error(LOCD_ERR_NO_MEMORY, "%zu splitter samples", all) : LOCD_OK;
    double total = 0.0, acc = 0.0;
    size_t i;
    int r;
    if ((st = lm_agree(c, st)) != LOCD_OK) {
        free(mine);
        free(every);
        return st;
    }
    local_samples(c, mine, s);
    /* (key, weight) as two 8-byte words: the struct has no padding */
    MPI_Allgather(mine, (int)(2 * s), MPI_UINT64_T, every, (int)(2 * s), MPI_UINT64_T, c->comm);
    qsort(every, all, sizeof *every, by_key);
    for (i = 0; i < all; i++)
        total += every[i].w;
    split[0] = 0;
    for (r = 1; r <= c->ranks; r++)
        split[r] = UINT64_MAX; /* keys are below 2^(64 - index_bits) */
    for (i = 0, r = 1; i < all && r < c->ranks; i++) {
        /* rank r starts at the first sample whose weight reaches past r / K of the total */
        while (r < c->ranks && acc + every[i].w > total * r / c->ranks) {
            split[r] = every[i].key > split[r - 1] ? every[i].key : split[r - 1];
            r++;
        }
        acc += every[i].w;
    }
    for (; r < c->ranks; r++) /* weightless tail (no entries anywhere): the last rank takes all */
        split[r] = split[r - 1];
    free(mine);
    free(every);
    return LOCD_OK;
}
