/* The broad phase's two sorted entry lists, one for the dynamic objects and
 * one for the static ones, on a grid kept from update to update. An entry
 * is (octree key << index_bits) | slot, exactly as octree/encode.c writes
 * it, so the order is the pre-order of the cells (docs/encoding.md).
 *
 * An object's entries are a function of its cells (lc_cells), so a moved
 * object whose cells did not change keeps its entries, and the old entries
 * of one whose cells changed are written again from its old cells to be
 * deleted. The lists are repaired by one merge pass with the sorted deltas
 * (deleted, added): no full sort. */
#include "scene/scene.h"

#include <math.h>
#include <stdlib.h>

void lc_scene_tree_fini(locd_scene *s)
{
    lc_buf_release(s->alloc, &s->dyn.ent, sizeof(uint64_t));
    lc_buf_release(s->alloc, &s->sta.ent, sizeof(uint64_t));
    s->dyn.count = s->sta.count = 0;
}

void lc_cells_of(const locd_grid *g, const double *b, lc_cells *c, uint32_t qlo[3])
{
    int32_t lo[3], hi[3];
    uint32_t ext = 0, sh, a;
    for (a = 0; a < 3; a++) {
        lo[a] = lc_quantize(g, (int)a, b[a]);
        hi[a] = lc_quantize(g, (int)a, b[a + 3]);
        if ((uint32_t)(hi[a] - lo[a]) > ext)
            ext = (uint32_t)(hi[a] - lo[a]);
        qlo[a] = (uint32_t)lo[a] >> LC_SDROP;
    }
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

void lc_tree_count_levels(const locd_grid *g, lc_tree *t)
{
    size_t k;
    const uint64_t *e = t->ent.data;
    memset(t->per_level, 0, sizeof t->per_level);
    for (k = 0; k < t->count; k++)
        t->per_level[(e[k] >> g->index_bits) & 31u]++;
}

locd_status lc_tree_repair(const locd_allocator *a, const locd_grid *g, const lc_tree *t, const uint64_t *del,
                           size_t ndel, const uint64_t *add, size_t nadd, lc_tree *out)
{
    const uint64_t *e = t->ent.data;
    uint64_t *o;
    size_t i = 0, d = 0, j = 0, w = 0, n = t->count - ndel + nadd;
    uint32_t ib = g->index_bits;
    memset(out, 0, sizeof *out);
    if (lc_buf_reserve(a, &out->ent, sizeof(uint64_t), n ? n : 1) != LOCD_OK)
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate the repaired entry list");
    o = out->ent.data;
    memcpy(out->per_level, t->per_level, sizeof out->per_level);
    /* One merge pass: entries of t not in del, interleaved with add. */
    while (i < t->count) {
        uint64_t v = e[i];
        if (d < ndel && del[d] == v) {
            d++, i++;
            continue;
        }
        while (j < nadd && add[j] < v)
            o[w++] = add[j++];
        o[w++] = v;
        i++;
    }
    while (j < nadd)
        o[w++] = add[j++];
    for (i = 0; i < ndel; i++)
        out->per_level[(del[i] >> ib) & 31u]--;
    for (i = 0; i < nadd; i++)
        out->per_level[(add[i] >> ib) & 31u]++;
    out->count = w;
    return w == n ? LOCD_OK : lc_error(LOCD_ERR_INTERNAL, "entry list repair lost entries (%zu of %zu)", w, n);
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
            for (a = 0; a < 3; a++) {
                if (!n || s->box[6 * k + (size_t)a] < b.lo[a])
                    b.lo[a] = s->box[6 * k + (size_t)a];
                if (!n || s->box[6 * k + 3 + (size_t)a] > b.hi[a])
                    b.hi[a] = s->box[6 * k + 3 + (size_t)a];
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
    st = lc_grid_from_bounds(&b, n, e->cfg.max_depth, e->cfg.cell_bias, e->cfg.flags, g);
    if (st)
        return st;
    {
        size_t room = s->nslots ? s->nslots : 1;
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
    if (!e->cfg.max_depth)
        lc_grid_tune_depth_f64(g, s->box, s->nslots);
    (void)n;
    return LOCD_OK;
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
