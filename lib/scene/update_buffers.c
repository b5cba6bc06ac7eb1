/* The update's buffers: grown as its paths need them; at its end a small
 * update's are kept for the next (lc_update_keep), the others freed. */
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

/* An update keeps its moved objects' rows for the next one up to this
 * many rows (about 160 bytes a row), its entry buffer up to this many
 * entries, and its search's output while each of its three buffers holds
 * up to this many items (16, 8 and 12 bytes): the scene holds at most
 * about 900 KB between updates, and a large update's buffers go back to
 * the allocator. */
#define LC_KEEP_ROWS 2048
#define LC_KEEP_ENTRIES 32768
#define LC_KEEP_FOUND 8192

/* Frees the moved objects' rows (every array but those never taken). */
static void free_rows(lc_update *u)
{
    const locd_allocator *a = u->s->alloc;
    const size_t cap = u->undo.cap;
    lc_undo *un = &u->undo;
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
    u->stay = u->srch = un->slot = un->dense = NULL;
    un->cells = u->new_cells = NULL;
    un->rec = NULL;
    un->qfat = u->new_q = NULL;
    un->flags = NULL;
    un->cap = 0;
}

locd_status lc_update_moved_room(lc_update *u, size_t n, int undo)
{
    const locd_allocator *a = u->s->alloc;
    lc_undo *un = &u->undo;
    if (un->cap < n) /* the rows kept from the last update are too few */
        free_rows(u);
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

void lc_update_adopt(lc_update *u)
{
    lc_update_keep *k = &u->s->keep;
    lc_undo *un = &u->undo;
    u->stay = k->stay, u->srch = k->srch, un->slot = k->slot, un->dense = k->dense;
    un->cells = k->cells, u->new_cells = k->new_cells;
    un->rec = k->rec;
    un->qfat = k->qfat, u->new_q = k->new_q;
    un->flags = k->flags;
    un->cap = k->cap;
    u->buf = k->buf, u->buf_cap = k->buf_cap;
    u->found = k->found;
    u->found.candidates = 0;
    memset(k, 0, sizeof *k);
}

void lc_update_free(lc_update *u)
{
    const locd_allocator *a = u->s->alloc;
    lc_update_keep *k = &u->s->keep;
    lc_undo *un = &u->undo;
    lc_entry_edit_free(a, &u->edit[0]);
    lc_entry_edit_free(a, &u->edit[1]);
    lc_pair_list_fini(a, &u->next);
    lc_pair_list_fini(a, &u->cr);
    lc_pair_list_fini(a, &u->lo);
    if (u->found.rows.rows.cap <= LC_KEEP_FOUND && u->found.fat.cap <= LC_KEEP_FOUND &&
        u->found.ev.cap <= LC_KEEP_FOUND)
        k->found = u->found;
    else
        lc_search_out_fini(a, &u->found);
    if (un->cap <= LC_KEEP_ROWS) {
        k->stay = u->stay, k->srch = u->srch, k->slot = un->slot, k->dense = un->dense;
        k->cells = un->cells, k->new_cells = u->new_cells;
        k->rec = un->rec;
        k->qfat = un->qfat, k->new_q = u->new_q;
        k->flags = un->flags;
        k->cap = un->cap;
    } else {
        free_rows(u);
    }
    if (u->buf_cap <= LC_KEEP_ENTRIES)
        k->buf = u->buf, k->buf_cap = u->buf_cap;
    else
        lc_free(a, u->buf, u->buf_cap * sizeof *u->buf);
}

void lc_update_keep_release(locd_scene *s)
{
    lc_update u;
    memset(&u, 0, sizeof u);
    u.s = s;
    lc_update_adopt(&u);
    free_rows(&u);
    lc_free(s->alloc, u.buf, u.buf_cap * sizeof *u.buf);
    lc_search_out_fini(s->alloc, &u.found);
}
