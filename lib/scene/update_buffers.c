/* The update's buffers: grown as its paths need them, freed at its end. */
#include "scene/scene.h"
#include "scene/update.h"

locd_status lc_update_room(lc_update *u, size_t len, size_t n)
{
    size_t cap;
    uint64_t *b;
    if (len + n <= u->buf_cap)
        return LOCD_OK;
    cap = lc_grow_cap(u->buf_cap, len + n);
    if (!(b = lc_alloc(u->s->alloc, cap * sizeof *b)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not grow the entry deltas");
    if (len)
        memcpy(b, u->buf, len * sizeof *b);
    lc_free(u->s->alloc, u->buf, u->buf_cap * sizeof *u->buf);
    u->buf = b, u->buf_cap = cap;
    return LOCD_OK;
}

/* p allocated with n elements unless it is already; 0 on no memory. */
#define TAKE(a, p, n) ((p) != NULL || ((p) = lc_alloc((a), (n) * sizeof *(p))) != NULL)

locd_status lc_update_moved_room(lc_update *u, size_t n, int undo)
{
    const locd_allocator *a = u->s->alloc;
    lc_undo *un = &u->undo;
    if (!un->cap)
        un->cap = n ? n : 1; /* one row per dirty slot, for every array below */
    if (!TAKE(a, u->stay, un->cap))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the update's moved list");
    if (undo && (!TAKE(a, u->srch, un->cap) || !TAKE(a, un->slot, un->cap) || !TAKE(a, un->dense, un->cap) ||
                 !TAKE(a, un->cells, un->cap) || !TAKE(a, un->rec, un->cap) ||
                 !TAKE(a, un->qfat, LC_FAT_WORDS * un->cap) || !TAKE(a, un->flags, un->cap) ||
                 !TAKE(a, u->new_cells, un->cap) || !TAKE(a, u->new_q, LC_QPAIR * un->cap)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the update's undo list");
    return LOCD_OK;
}

void lc_update_free(lc_update *u)
{
    const locd_allocator *a = u->s->alloc;
    const size_t cap = u->undo.cap;
    lc_undo *un = &u->undo;
    lc_entry_edit_free(a, &u->edit[0]);
    lc_entry_edit_free(a, &u->edit[1]);
    lc_pair_list_fini(a, &u->next);
    lc_pair_list_fini(a, &u->cr);
    lc_pair_list_fini(a, &u->lo);
    lc_free(a, u->stay, cap * sizeof *u->stay);
    lc_free(a, u->srch, cap * sizeof *u->srch);
    lc_free(a, un->slot, cap * sizeof *un->slot);
    lc_free(a, un->dense, cap * sizeof *un->dense);
    lc_free(a, un->cells, cap * sizeof *un->cells);
    lc_free(a, un->rec, cap * sizeof *un->rec);
    lc_free(a, un->qfat, cap * LC_FAT_WORDS * sizeof *un->qfat);
    lc_free(a, un->flags, cap * sizeof *un->flags);
    lc_free(a, u->new_cells, cap * sizeof *u->new_cells);
    lc_free(a, u->new_q, cap * LC_QPAIR * sizeof *u->new_q);
    lc_search_out_fini(a, &u->found);
    lc_free(a, u->buf, u->buf_cap * sizeof *u->buf);
}
