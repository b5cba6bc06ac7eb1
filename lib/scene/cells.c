/* Cells and fat boxes: an object's cells are those of its fat box (its box
 * grown on each side by its largest quantized edge >> LC_FAT_SHIFT), on a
 * grid fitted to the live boxes when the entry lists are built. */
#include "scene/scene.h"

uint32_t lc_cells_box(const locd_grid *g, const double *b, lc_qcorners *k, uint64_t q[4])
{
    uint32_t ext = 0, a;
    for (a = 0; a < 3; a++) {
        k->lo[a] = lc_quantize(g, (int)a, b[a]);
        k->hi[a] = lc_quantize(g, (int)a, b[a + 3]);
        if ((uint32_t)(k->hi[a] - k->lo[a]) > ext)
            ext = (uint32_t)(k->hi[a] - k->lo[a]);
    }
    lc_pack_qbox(k->lo, k->hi, q + 2);
    return ext;
}

void lc_cells_fat(const locd_grid *g, const lc_qcorners *k, uint32_t ext, lc_cells *c, uint64_t q[4])
{
    int32_t lo[3], hi[3];
    uint32_t sh, a, m;
    /* the fat box: a margin of the largest edge >> LC_FAT_SHIFT on every
       side, kept in the quantized range (it still holds the box) */
    m = ext >> LC_FAT_SHIFT;
    for (a = 0; a < 3; a++) {
        int64_t l = (int64_t)k->lo[a] - m, h = (int64_t)k->hi[a] + m;
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
    /* The largest edge's level, not lc_level_of's deeper one for a flat
       box: this runs for every moved object of every update, where the
       spread test cost 3% of an update of 100 moved cubes among 900
       (`frames_peers frames-uniform-1000.aabb --moving 1 --static 0.9`), and
       the scene's cells are already a level finer than the engine's. */
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

void lc_cells_of(const locd_grid *g, const double *b, lc_cells *c, uint64_t q[4])
{
    lc_qcorners k;
    const uint32_t ext = lc_cells_box(g, b, &k, q);
    lc_cells_fat(g, &k, ext, c, q);
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

/* The bounds of the live boxes; returns how many there are. */
static size_t live_bounds(const lc_slots *sl, lc_bounds *b)
{
    size_t k, n = 0;
    int a;
    lc_bounds_init(b);
    for (k = 0; k < sl->nslots; k++)
        if (sl->flags[k] & LC_SLOT_LIVE) {
            double tmp[6];
            const double *bx = lc_slot_box(sl, k, tmp);
            for (a = 0; a < 3; a++) {
                if (!n || bx[a] < b->lo[a])
                    b->lo[a] = bx[a];
                if (!n || bx[3 + a] > b->hi[a])
                    b->hi[a] = bx[3 + a];
            }
            n++;
        }
    return n;
}

/* The grid's margin on each side, as a share of the extent: room to move
 * before the lists must be built again. */
#define LC_GRID_MARGIN (1.0 / 32.0)

static void widen(lc_bounds *b)
{
    int a;
    for (a = 0; a < 3; a++) {
        const double m = (b->hi[a] * 0.5 - b->lo[a] * 0.5) * (2.0 * LC_GRID_MARGIN);
        const double lo = b->lo[a] - m, hi = b->hi[a] + m;
        if (isfinite(lo))
            b->lo[a] = lo;
        if (isfinite(hi))
            b->hi[a] = hi;
    }
}

/* Index bits for the dense indices a build of nslots makes room for (one
 * more costs a level of depth: a scene that outgrows them builds again). */
static void index_bits_for(locd_grid *g, size_t nslots)
{
    const size_t room = lc_entries_room(nslots) + 1; /* the all-ones index is the tombstone */
    uint32_t ib = 1;
    while (ib < 32 && ((size_t)1 << ib) < room)
        ib++;
    if (ib > g->index_bits) {
        const uint32_t depth = (64u - ib - LC_LEVEL_BITS) / 3u;
        g->index_bits = ib;
        if (g->depth > depth)
            g->depth = depth;
    }
}

locd_status lc_entries_fit_grid(locd_scene *s, locd_grid *g)
{
    const locd_engine *e = s->engine;
    lc_bounds b;
    const size_t n = live_bounds(&s->slots, &b);
    locd_status st;
    if (n)
        widen(&b);
    /* One step finer cells than the engine's (bias - 1): a moved object's
       search then meets about a third of the candidates, for about 1.5 times
       the entries (bench_scene on 10^6 uniform cubes). */
    st = lc_grid_from_bounds(&b, n, e->cfg.max_depth, e->cfg.cell_bias > 0 ? e->cfg.cell_bias - 1 : 0, e->cfg.flags,
                             g);
    if (st)
        return st;
    index_bits_for(g, s->slots.nslots);
    if (!e->cfg.max_depth && s->slots.keep_f64)
        lc_grid_tune_depth_f64(g, s->slots.box, s->slots.nslots);
    else if (!e->cfg.max_depth)
        lc_grid_tune_depth_f32(g, s->slots.fbox, s->slots.nslots);
    return LOCD_OK;
}

size_t lc_entries_room(size_t nslots)
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
