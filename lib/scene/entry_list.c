/* One sorted entry list (the scene has two: entries.c). An entry is
 * (octree key << index_bits) | dense index, as octree/encode.c writes an
 * entry (with the slot there), so the order is the pre-order of the cells
 * (docs/encoding.md).
 *
 * An object's entries are a function of its cells (lc_cells) and its dense
 * index, so a moved object whose cells did not change keeps its entries,
 * and the old entries of one whose cells changed are written again from
 * its old cells to be deleted. The main array is sorted by key (the entry
 * without its index bits); within one key the order is free, because the
 * searches probe keys only (key << index_bits) and a deletion scans the
 * few entries of its key. Deleted entries become tombstones in place, new
 * ones go to the sorted overflow; a compaction merges them by key: no full
 * sort after a build. */
#include "scene/scene.h"

/* A main array shorter than this has no directory (a binary search over
 * it is a few cache lines). */
#define LC_DIR_MIN 4096
/* The directory's buckets hold about 2^LC_DIR_BUCKET_BITS entries, with
 * at most 2^LC_DIR_MAX_BITS buckets. */
#define LC_DIR_BUCKET_BITS 3
#define LC_DIR_MAX_BITS 22
/* An edit compacts the list when its overflow and tombstones pass
 * 1/2^LC_COMPACT_SHIFT of the main array: amortized, each change is
 * merged once. */
#define LC_COMPACT_SHIFT 4

void lc_entry_list_release(const locd_allocator *a, lc_entry_list *t)
{
    if (t->dir)
        lc_free(a, t->dir, (((size_t)1 << t->dir_bits) + 1) * sizeof *t->dir);
    t->dir = NULL;
    lc_buf_release(a, &t->ent, sizeof(uint64_t));
    lc_buf_release(a, &t->ovf, sizeof(uint64_t));
    t->count = t->novf = t->dead = 0;
}

void lc_entry_list_count_levels(const locd_grid *g, lc_entry_list *t)
{
    size_t k;
    const uint64_t *e = t->ent.data;
    memset(t->per_level, 0, sizeof t->per_level);
    for (k = 0; k < t->count; k++)
        if (!LC_IS_TOMB(g, e[k]))
            t->per_level[(e[k] >> g->index_bits) & 31u]++;
    e = t->ovf.data;
    for (k = 0; k < t->novf; k++)
        t->per_level[(e[k] >> g->index_bits) & 31u]++;
}

void lc_entry_list_build_dir(const locd_allocator *a, const locd_grid *g, lc_entry_list *t)
{
    const uint64_t *e = t->ent.data;
    uint32_t used = 3u * g->depth + LC_LEVEL_BITS + g->index_bits, bits = 0, shift;
    size_t n = t->count, j, i = 0, len;
    if (t->dir)
        lc_free(a, t->dir, (((size_t)1 << t->dir_bits) + 1) * sizeof *t->dir);
    t->dir = NULL;
    if (n < LC_DIR_MIN || n > UINT32_MAX)
        return;
    while (((size_t)1 << (bits + LC_DIR_BUCKET_BITS)) < n && bits < LC_DIR_MAX_BITS)
        bits++;
    if (used <= bits || used > 64)
        return;
    shift = used - bits;
    len = ((size_t)1 << bits) + 1;
    if (!(t->dir = lc_alloc(a, len * sizeof *t->dir)))
        return;
    for (j = 0; j < len; j++) {
        while (i < n && (e[i] >> shift) < j)
            i++;
        t->dir[j] = (uint32_t)i;
    }
    t->dir_bits = bits;
    t->dir_shift = shift;
}

size_t lc_entry_list_lower_bound(const lc_entry_list *t, uint64_t v)
{
    const uint64_t *e = t->ent.data;
    size_t j, lo, hi;
    if (!t->dir)
        return lc_lower_bound(e, t->count, v);
    j = (size_t)(v >> t->dir_shift);
    if (j >= ((size_t)1 << t->dir_bits))
        return j == ((size_t)1 << t->dir_bits) ? t->dir[j] + lc_lower_bound(e + t->dir[j], t->count - t->dir[j], v)
                                                 : t->count;
    lo = t->dir[j];
    hi = t->dir[j + 1];
    return lo + lc_lower_bound(e + lo, hi - lo, v);
}

/* The position of entry v in t's main array, or (size_t)-1 (then it is in
 * the overflow). Equal keys are few: one binary search, a short scan. */
static size_t find_main(const locd_grid *g, const lc_entry_list *t, uint64_t v)
{
    const uint64_t *e = t->ent.data;
    const uint32_t ib = g->index_bits;
    size_t i = lc_entry_list_lower_bound(t, (v >> ib) << ib);
    for (; i < t->count && (e[i] >> ib) == (v >> ib); i++)
        if (e[i] == v)
            return i;
    return (size_t)-1;
}

/* out = the sorted overflow a without the entries in del, merged with b
 * (all three sorted by value). Returns the count. */
static size_t merge_minus(const uint64_t *a, size_t na, const uint64_t *del, size_t ndel, const uint64_t *b,
                          size_t nb, uint64_t *out)
{
    size_t i = 0, d = 0, j = 0, w = 0;
    for (; i < na; i++) {
        uint64_t v = a[i];
        while (d < ndel && del[d] < v)
            d++;
        if (d < ndel && del[d] == v) {
            d++;
            continue;
        }
        while (j < nb && b[j] < v)
            out[w++] = b[j++];
        out[w++] = v;
    }
    while (j < nb)
        out[w++] = b[j++];
    return w;
}

/* out = main without its tombstones merged with b by key (main is sorted by
 * key only, b by value). Returns the count. */
static size_t merge_by_key(const locd_grid *g, const uint64_t *m, size_t nm, const uint64_t *b, size_t nb,
                           uint64_t *out)
{
    const uint32_t ib = g->index_bits;
    size_t i, j = 0, w = 0;
    for (i = 0; i < nm; i++) {
        uint64_t v = m[i];
        if (LC_IS_TOMB(g, v))
            continue;
        while (j < nb && (b[j] >> ib) < (v >> ib))
            out[w++] = b[j++];
        out[w++] = v;
    }
    while (j < nb)
        out[w++] = b[j++];
    return w;
}

/* The edit's entries per level: t's, less del, with add. */
static void count_edit_levels(const locd_grid *g, const lc_entry_list *t, const uint64_t *del, size_t ndel,
                              const uint64_t *add, size_t nadd, lc_entry_edit *e)
{
    const uint32_t ib = g->index_bits;
    size_t k;
    memcpy(e->out.per_level, t->per_level, sizeof e->out.per_level);
    for (k = 0; k < ndel; k++)
        e->out.per_level[(del[k] >> ib) & 31u]--;
    for (k = 0; k < nadd; k++)
        e->out.per_level[(add[k] >> ib) & 31u]++;
}

/* Tombstones in place for the deleted entries of t's main array (positions
 * and old values kept for undo); the others, in the overflow, into
 * ovf_del. Returns how many went there. */
static size_t tombstone(const locd_grid *g, lc_entry_list *t, const uint64_t *del, size_t ndel, lc_entry_edit *e,
                        uint64_t *ovf_del)
{
    uint64_t *m = t->ent.data;
    size_t k, nod = 0;
    for (k = 0; k < ndel; k++) {
        const size_t p = find_main(g, t, del[k]);
        if (p == (size_t)-1) {
            ovf_del[nod++] = del[k];
        } else {
            e->old[e->npos] = m[p];
            e->pos[e->npos++] = p;
            m[p] = LC_TOMB(g, m[p]);
        }
    }
    return nod;
}

/* The edit undone and freed, and the error. */
static locd_status edit_fail(const locd_allocator *a, lc_entry_list *t, lc_entry_edit *e, locd_status st,
                             const char *what)
{
    lc_entry_edit_undo(t, e);
    lc_entry_edit_free(a, e);
    return lc_error(st, "%s", what);
}

/* The main array without its tombstones merged with the new overflow into
 * a new main array (e->out), when they pass the compaction's share. */
static locd_status compact(const locd_allocator *a, const locd_grid *g, lc_entry_list *t, lc_entry_edit *e)
{
    const size_t live = t->count - t->dead - e->npos + e->out.novf;
    lc_buf ent = {NULL, 0};
    if ((e->out.novf + t->dead + e->npos) << LC_COMPACT_SHIFT <= t->count)
        return LOCD_OK;
    if (lc_buf_reserve(a, &ent, sizeof(uint64_t), live ? live : 1) != LOCD_OK)
        return edit_fail(a, t, e, LOCD_ERR_NO_MEMORY, "could not allocate the entry list's edit");
    e->out.count = merge_by_key(g, t->ent.data, t->count, e->out.ovf.data, e->out.novf, ent.data);
    e->out.ent = ent;
    lc_entry_list_build_dir(a, g, &e->out);
    lc_buf_release(a, &e->out.ovf, sizeof(uint64_t));
    e->out.novf = 0;
    e->compacted = 1;
    if (e->out.count != live)
        return edit_fail(a, t, e, LOCD_ERR_INTERNAL, "entry list compaction lost entries");
    return LOCD_OK;
}

locd_status lc_entry_edit_apply(const locd_allocator *a, const locd_grid *g, lc_entry_list *t, const uint64_t *del,
                                size_t ndel, const uint64_t *add, size_t nadd, lc_entry_edit *e)
{
    uint64_t *ovf_del;
    size_t nod;
    memset(e, 0, sizeof *e);
    count_edit_levels(g, t, del, ndel, add, nadd, e);
    if (!ndel && !nadd) {
        e->out.novf = (size_t)-1; /* nothing changes: keep t's overflow */
        return LOCD_OK;
    }
    e->pos_cap = ndel ? ndel : 1;
    ovf_del = lc_alloc(a, e->pos_cap * sizeof *ovf_del);
    if (!ovf_del || lc_buf_reserve(a, &e->out.ovf, sizeof(uint64_t), t->novf + nadd + 1) != LOCD_OK ||
        !(e->pos = lc_alloc(a, e->pos_cap * sizeof *e->pos)) || !(e->old = lc_alloc(a, e->pos_cap * sizeof *e->old))) {
        lc_free(a, ovf_del, e->pos_cap * sizeof *ovf_del);
        return edit_fail(a, t, e, LOCD_ERR_NO_MEMORY, "could not allocate the entry list's edit");
    }
    nod = tombstone(g, t, del, ndel, e, ovf_del);
    e->out.novf = merge_minus(t->ovf.data, t->novf, ovf_del, nod, add, nadd, e->out.ovf.data);
    lc_free(a, ovf_del, e->pos_cap * sizeof *ovf_del);
    if (e->out.novf != t->novf - nod + nadd)
        return edit_fail(a, t, e, LOCD_ERR_INTERNAL, "entry overflow lost entries");
    return compact(a, g, t, e);
}

void lc_entry_edit_undo(lc_entry_list *t, lc_entry_edit *e)
{
    uint64_t *m = t->ent.data;
    size_t k;
    for (k = e->npos; k-- > 0;)
        m[e->pos[k]] = e->old[k];
    e->npos = 0;
}

void lc_entry_edit_commit(const locd_allocator *a, lc_entry_list *t, lc_entry_edit *e)
{
    if (e->compacted) {
        lc_entry_list_release(a, t);
        t->ent = e->out.ent;
        t->count = e->out.count;
        t->dir = e->out.dir, t->dir_bits = e->out.dir_bits, t->dir_shift = e->out.dir_shift;
        t->dead = 0;
        t->novf = 0;
        memset(&e->out.ent, 0, sizeof e->out.ent);
        e->out.dir = NULL;
    } else if (e->out.novf != (size_t)-1) {
        lc_buf tmp = t->ovf;
        t->ovf = e->out.ovf;
        t->novf = e->out.novf;
        e->out.ovf = tmp; /* freed by lc_entry_edit_free */
        t->dead += e->npos;
    }
    memcpy(t->per_level, e->out.per_level, sizeof t->per_level);
}

void lc_entry_edit_free(const locd_allocator *a, lc_entry_edit *e)
{
    if (e->out.dir)
        lc_free(a, e->out.dir, (((size_t)1 << e->out.dir_bits) + 1) * sizeof *e->out.dir);
    e->out.dir = NULL;
    lc_buf_release(a, &e->out.ent, sizeof(uint64_t));
    lc_buf_release(a, &e->out.ovf, sizeof(uint64_t));
    lc_free(a, e->pos, e->pos_cap * sizeof *e->pos);
    lc_free(a, e->old, e->pos_cap * sizeof *e->old);
    e->pos = NULL;
    e->old = NULL;
}

void lc_entry_edit_view(const lc_entry_list *t, const lc_entry_edit *e, lc_entry_list *v)
{
    if (e->compacted) {
        *v = e->out;
        v->ovf.data = NULL, v->novf = 0;
    } else {
        *v = *t;
        if (e->out.novf != (size_t)-1)
            v->ovf = e->out.ovf, v->novf = e->out.novf;
    }
    memcpy(v->per_level, e->out.per_level, sizeof v->per_level);
}
