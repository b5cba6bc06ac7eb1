/* Each rank encodes and sorts its own boxes, with local indices: the
 * global index is the local one plus the rank's offset, so the order of
 * (key, index) is the same either way. */
#include "mpi/part.h"

#include <stdlib.h>

static locd_status encode_into(lm_ctx *c, uint64_t *ent, size_t cap, size_t *written)
{
    return c->f64 ? locd_encode_f64(&c->grid, c->boxes, 0, c->local_n, ent, cap, written)
                  : locd_encode_f32(&c->grid, c->boxes, 0, c->local_n, ent, cap, written);
}

locd_status lm_encode(lm_ctx *c)
{
    /* About 1.7 entries a box at the default bias: try twice the boxes,
       then the exact need encode reports. */
    size_t cap = 2 * c->local_n + 16, w = 0;
    uint64_t *ent = malloc(cap * sizeof *ent), *scratch;
    locd_status st;
    if (!ent)
        return lc_error(LOCD_ERR_NO_MEMORY, "%zu entries", cap);
    st = encode_into(c, ent, cap, &w);
    if (st == LOCD_ERR_BUFFER_TOO_SMALL) {
        uint64_t *more = realloc(ent, w * sizeof *ent);
        if (!more) {
            free(ent);
            return lc_error(LOCD_ERR_NO_MEMORY, "%zu entries", w);
        }
        ent = more;
        cap = w;
        st = encode_into(c, ent, cap, &w);
    }
    if (st) {
        free(ent);
        return st;
    }
    scratch = malloc((w ? w : 1) * sizeof *scratch);
    if (!scratch) {
        free(ent);
        return lc_error(LOCD_ERR_NO_MEMORY, "%zu entries of sort scratch", w);
    }
    st = locd_sort_entries(&c->grid, ent, scratch, w);
    free(scratch);
    if (st) {
        free(ent);
        return st;
    }
    c->ent = ent;
    c->nent = w;
    c->st.entries_encoded = w;
    return LOCD_OK;
}
