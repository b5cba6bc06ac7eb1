/* The broad phase's two sorted entry lists, one for the dynamic objects and
 * one for the static ones, on a grid kept from update to update. An entry
 * is (octree key << index_bits) | slot, exactly as octree/encode.c writes
 * it, so the order is the pre-order of the cells (docs/encoding.md).
 *
 * An object's entries are a function of its cells (lc_cells) and its dense
 * index, so a moved object whose cells did not change keeps its entries,
 * and the old entries of one whose cells changed are written again from
 * its old cells to be deleted. The main array is sorted by key (the entry
 * without its index bits); within one key the order is free, because the
 * searches probe keys only (key << index_bits) and a deletion scans the
 * few entries of its key. Deleted entries become tombstones in place, new
 * ones go to the sorted overflow; a compaction merges them by key: no full
 * sort after a rebuild. */
#include "scene/scene.h"

#include <math.h>
#include <stdlib.h>

void lc_tree_release(const locd_allocator *a, lc_tree *t)
{
    if (t->dir)
        lc_free(a, t->dir, (((size_t)1 << t->dir_bits) + 1) * sizeof *t->dir);
    t->dir = NULL;
    lc_buf_release(a, &t->ent, sizeof(uint64_t));
    lc_buf_release(a, &t->ovf, sizeof(uint64_t));
    t->count = t->novf = t->dead = 0;
}

void lc_scene_tree_fini(locd_scene *s)
{
    lc_tree_release(s->alloc, &s->dyn);
    lc_tree_release(s->alloc, &s->sta);
}

void lc_cells_of(const locd_grid *g, const double *b, lc_cells *c, uint64_t q[4])
{
    int32_t lo[3], hi[3];
    uint32_t ext = 0, sh, a, m;
    for (a = 0; a < 3; a++) {
        lo[a] = lc_quantize(g, (int)a, b[a]);
        hi[a] = lc_quantize(g, (int)a, b[a + 3]);
        if ((uint32_t)(hi[a] - lo[a]) > ext)
            ext = (uint32_t)(hi[a] - lo[a]);
    }
    lc_pack_qbox(lo, hi, q + 2);
    /* the fat box: a margin of the largest edge >> LC_FAT_SHIFT on every
       side, kept in the quantized range (it still holds the box) */
    m = ext >> LC_FAT_SHIFT;
    for (a = 0; a < 3; a++) {
        int64_t l = (int64_t)lo[a] - m, h = (int64_t)hi[a] + m;
        lo[a] = l < 0 ? 0 : (int32_t)l;
        hi[a] = h > 2147483647 ? 2147483647 : (int32_t)h;
    }
    ext = 0;
    for (a = 0; a < 3; a++)
        if ((uint32_t)(hi[a] - lo[a]) > ext)
            ext = (uint32_t)(hi[a] - lo[a]);
    lc_pack_qbox(lo, hi, q);
    if (g->flags & LOCD_CONFIG_CUBES)
        for (a = 0; a < 3; a++) {
            int64_t h = (int64_t)lo[a] + ext;
            hi[a] = h > 2147483647 ? 2147483647 : (int32_t)h;
        }
    c->level = (uint8_t)lc_level_for(ext, g->cell_bias, g->depth);
    sh = LC_QBITS - c->level;
    c->span = 0;
    for (a = 0; a < 3; a++) {
        c->c0[a] = (uint32_t)lo[a] >> sh;
        if (((uint32_t)hi[a] >> sh) != c->c0[a])
            c->span |= (uint8_t)(1u << a);
    }
    c->pad[0] = c->pad[1] = 0;
}

int lc_cells_same(const lc_cells *a, const lc_cells *b)
{
    return a->level == b->level && a->span == b->span && a->c0[0] == b->c0[0] && a->c0[1] == b->c0[1] &&
           a->c0[2] == b->c0[2];
}

uint32_t lc_cells_entries(const locd_grid *g, const lc_cells *c, uint32_t slot, uint64_t *out)
{
    uint32_t x, y, z, w = 0, ib = g->index_bits, lvl = c->level;
    uint64_t base = ((uint64_t)lvl << ib) | slot;
    for (z = 0; z <= ((c->span >> 2) & 1u); z++)
        for (y = 0; y <= ((c->span >> 1) & 1u); y++)
            for (x = 0; x <= (c->span & 1u); x++) {
                uint64_t m = lc_morton_split3(c->c0[0] + x) | lc_morton_split3(c->c0[1] + y) << 1 |
                             lc_morton_split3(c->c0[2] + z) << 2;
                uint64_t pm = m << (3u * (g->depth - lvl));
                out[w++] = (pm << (LC_LEVEL_BITS + ib)) | base;
            }
    return w;
}

static int cmp_u64(const void *pa, const void *pb)
{
    uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return (a > b) - (a < b);
}

void lc_sort_u64(uint64_t *v, size_t n)
{
    qsort(v, n, sizeof *v, cmp_u64);
}

locd_status lc_sort_u64_radix(const locd_allocator *a, uint64_t *v, size_t n)
{
    uint64_t *scratch, *r;
    if (n < 256) {
        lc_sort_u64(v, n);
        return LOCD_OK;
    }
    if (!(scratch = lc_alloc(a, n * sizeof *scratch)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate a sort's scratch");
    r = lc_radix_sort(v, scratch, n, 0);
    if (r != v)
        memcpy(v, r, n * sizeof *v);
    lc_free(a, scratch, n * sizeof *scratch);
    return LOCD_OK;
}

void lc_tree_count_levels(const locd_grid *g, lc_tree *t)
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

void lc_tree_build_dir(const locd_allocator *a, const locd_grid *g, lc_tree *t)
{
    const uint64_t *e = t->ent.data;
    uint32_t used = 3u * g->depth + LC_LEVEL_BITS + g->index_bits, bits = 0, shift;
    size_t n = t->count, j, i = 0, len;
    if (t->dir)
        lc_free(a, t->dir, (((size_t)1 << t->dir_bits) + 1) * sizeof *t->dir);
    t->dir = NULL;
    if (n < 4096 || n > UINT32_MAX)
        return;
    while (((size_t)1 << (bits + 3)) < n && bits < 22)
        bits++; /* about 8 entries a bucket */
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

size_t lc_tree_lower_bound(const lc_tree *t, uint64_t v)
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
static size_t find_main(const locd_grid *g, const lc_tree *t, uint64_t v)
{
    const uint64_t *e = t->ent.data;
    const uint32_t ib = g->index_bits;
    size_t i = lc_tree_lower_bound(t, (v >> ib) << ib);
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

locd_status lc_tree_edit_apply(const locd_allocator *a, const locd_grid *g, lc_tree *t, const uint64_t *del,
                               size_t ndel, const uint64_t *add, size_t nadd, lc_tree_edit *e)
{
    const uint32_t ib = g->index_bits;
    size_t k, nod = 0, live;
    uint64_t *ovf_del = NULL, *m = t->ent.data;
    memset(e, 0, sizeof *e);
    memcpy(e->out.per_level, t->per_level, sizeof e->out.per_level);
    for (k = 0; k < ndel; k++)
        e->out.per_level[(del[k] >> ib) & 31u]--;
    for (k = 0; k < nadd; k++)
        e->out.per_level[(add[k] >> ib) & 31u]++;
    if (!ndel && !nadd) {
        e->out.novf = (size_t)-1; /* nothing changes: keep t's overflow */
        return LOCD_OK;
    }
    e->pos_cap = ndel ? ndel : 1;
    if (lc_buf_reserve(a, &e->out.ovf, sizeof(uint64_t), t->novf + nadd + 1) != LOCD_OK ||
        !(e->pos = lc_alloc(a, e->pos_cap * sizeof *e->pos)) ||
        !(e->old = lc_alloc(a, e->pos_cap * sizeof *e->old)) ||
        !(ovf_del = lc_alloc(a, e->pos_cap * sizeof *ovf_del)))
        goto nomem;
    /* Tombstones in place for the deleted entries of main (positions and
       old values kept for undo); the others are in the overflow. */
    for (k = 0; k < ndel; k++) {
        size_t p = find_main(g, t, del[k]);
        if (p == (size_t)-1) {
            ovf_del[nod++] = del[k];
        } else {
            e->old[e->npos] = m[p];
            e->pos[e->npos++] = p;
            m[p] = LC_TOMB(g, m[p]);
        }
    }
    e->out.novf = merge_minus(t->ovf.data, t->novf, ovf_del, nod, add, nadd, e->out.ovf.data);
    lc_free(a, ovf_del, e->pos_cap * sizeof *ovf_del);
    ovf_del = NULL;
    if (e->out.novf != t->novf - nod + nadd) {
        lc_tree_edit_undo(t, e);
        lc_tree_edit_free(a, e);
        return lc_error(LOCD_ERR_INTERNAL, "entry overflow lost entries");
    }
    /* Compact when the overflow and the tombstones pass 1/16 of the main
       array: amortized, each change is merged once. */
    live = t->count - t->dead - e->npos + e->out.novf;
    if (16 * (e->out.novf + t->dead + e->npos) > t->count) {
        lc_buf ent = {NULL, 0};
        if (lc_buf_reserve(a, &ent, sizeof(uint64_t), live ? live : 1) != LOCD_OK)
            goto nomem;
        e->out.count = merge_by_key(g, m, t->count, e->out.ovf.data, e->out.novf, ent.data);
        e->out.ent = ent;
        lc_tree_build_dir(a, g, &e->out);
        lc_buf_release(a, &e->out.ovf, sizeof(uint64_t));
        e->out.novf = 0;
        e->compacted = 1;
        if (e->out.count != live) {
            lc_tree_edit_undo(t, e);
            lc_tree_edit_free(a, e);
            return lc_error(LOCD_ERR_INTERNAL, "entry list compaction lost entries (%zu of %zu)", e->out.count, live);
        }
    }
    return LOCD_OK;
nomem:
    lc_free(a, ovf_del, e->pos_cap * sizeof *ovf_del);
    lc_tree_edit_undo(t, e);
    lc_tree_edit_free(a, e);
    return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the entry list's edit");
}

void lc_tree_edit_undo(lc_tree *t, lc_tree_edit *e)
{
    uint64_t *m = t->ent.data;
    size_t k;
    for (k = e->npos; k-- > 0;)
        m[e->pos[k]] = e->old[k];
    e->npos = 0;
}

void lc_tree_edit_commit(const locd_allocator *a, lc_tree *t, lc_tree_edit *e)
{
    if (e->compacted) {
        lc_tree_release(a, t);
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
        e->out.ovf = tmp; /* freed by lc_tree_edit_free */
        t->dead += e->npos;
    }
    memcpy(t->per_level, e->out.per_level, sizeof t->per_level);
}

void lc_tree_edit_free(const locd_allocator *a, lc_tree_edit *e)
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

locd_status lc_scene_fit_grid(locd_scene *s, locd_grid *g)
{
    const locd_engine *e = s->engine;
    lc_bounds b;
    size_t k, n = 0;
    int a;
    locd_status st;
    lc_bounds_init(&b);
    for (k = 0; k < s->nslots; k++)
        if (s->flags[k] & LC_SLOT_LIVE) {
            double tmp[6];
            const double *bx = lc_scene_box(s, k, tmp);
            for (a = 0; a < 3; a++) {
                if (!n || bx[a] < b.lo[a])
                    b.lo[a] = bx[a];
                if (!n || bx[3 + a] > b.hi[a])
                    b.hi[a] = bx[3 + a];
            }
            n++;
        }
    if (n) { /* a margin of 1/32 of the extent each side: room to move before a rebuild */
        for (a = 0; a < 3; a++) {
            double m = (b.hi[a] * 0.5 - b.lo[a] * 0.5) * 0.0625;
            double lo = b.lo[a] - m, hi = b.hi[a] + m;
            if (isfinite(lo))
                b.lo[a] = lo;
            if (isfinite(hi))
                b.hi[a] = hi;
        }
    }
    /* Index bits for the slots (one more costs a level of depth: a
       scene that outgrows them rebuilds). */
    /* One step finer cells than the engine's (bias - 1): a moved object's
       search then meets about a third of the candidates, for about 1.5 times
       the entries (bench_scene on 10^6 uniform cubes). */
    st = lc_grid_from_bounds(&b, n, e->cfg.max_depth, e->cfg.cell_bias > 0 ? e->cfg.cell_bias - 1 : 0, e->cfg.flags,
                             g);
    if (st)
        return st;
    {
        size_t room = lc_scene_dense_room(s->nslots) + 1; /* the all-ones index is the tombstone */
        uint32_t ib = 1;
        while (ib < 32 && ((size_t)1 << ib) < room)
            ib++;
        if (ib > g->index_bits) {
            uint32_t depth = (64u - ib - LC_LEVEL_BITS) / 3u;
            g->index_bits = ib;
            if (g->depth > depth)
                g->depth = depth;
        }
    }
    if (!e->cfg.max_depth && s->keep_f64)
        lc_grid_tune_depth_f64(g, s->box, s->nslots);
    else if (!e->cfg.max_depth)
        lc_grid_tune_depth_f32(g, s->fbox, s->nslots);
    (void)n;
    return LOCD_OK;
}

size_t lc_scene_dense_room(size_t nslots)
{
    return nslots + nslots / 4 + 64;
}

int lc_grid_holds(const locd_grid *g, const double *b)
{
    int a;
    for (a = 0; a < 3; a++) {
        double lo = b[a] * 0.5 - g->origin[a], hi = b[a + 3] * 0.5 - g->origin[a];
        double t_lo = (lo * g->scale_a) * g->scale_b, t_hi = (hi * g->scale_a) * g->scale_b;
        if (!(t_lo >= 0.0) || !(t_hi < LC_QMAX))
            return 0;
    }
    return 1;
}
