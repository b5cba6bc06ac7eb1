/* Step 1: boxes -> (octree cell, object) entries.
 *
 * Each box goes to the deepest level whose cell edge is at least 2^bias times
 * the box's largest quantized extent, so it touches at most two cells per
 * axis (at most 8 entries; about 1.7 on average for the default bias 2 on
 * uniform cubes, 2.7 for bias 1). */
#include "internal.h"
#include "morton.h"

LC_INLINE uint32_t bitlen32(uint32_t v)
{
    return v ? 32u - (uint32_t)__builtin_clz(v) : 0u;
}

/* Level of a box with quantized extent w (largest axis). */
LC_INLINE uint32_t level_for(uint32_t w, int32_t bias, uint32_t depth)
{
    int32_t l = (int32_t)LC_QBITS - bias - (int32_t)bitlen32(w);
    if (l < 0)
        l = 0;
    return (uint32_t)l > depth ? depth : (uint32_t)l;
}

#define LC_ENCODE_BODY(T)                                                                                    \
    size_t i, w = 0;                                                                                         \
    const uint32_t depth = g->depth, ib = g->index_bits;                                                     \
    const int32_t bias = g->cell_bias;                                                                       \
    const int cubes = (g->flags & LOCD_CONFIG_CUBES) != 0;                                                   \
    for (i = first; i < first + count; i++) {                                                                \
        const T *b = boxes + 6 * i;                                                                          \
        int32_t lo[3], hi[3];                                                                                \
        uint32_t ext, lvl, sh, a, x, y, z;                                                                   \
        uint32_t c0[3], c1[3];                                                                               \
        uint64_t mx[2], my[2], mz[2], base;                                                                  \
        for (a = 0; a < 3; a++) {                                                                            \
            lo[a] = lc_quantize(g, (int)a, (double)b[a]);                                                    \
            hi[a] = lc_quantize(g, (int)a, (double)b[a + 3]);                                                \
        }                                                                                                    \
        if (qbox) {                                                                                          \
            int32_t *q = qbox + 6 * i;                                                                       \
            q[0] = lo[0];                                                                                    \
            q[1] = lo[1];                                                                                    \
            q[2] = lo[2];                                                                                    \
            q[3] = hi[0];                                                                                    \
            q[4] = hi[1];                                                                                    \
            q[5] = hi[2];                                                                                    \
        }                                                                                                    \
        ext = (uint32_t)(hi[0] - lo[0]);                                                                     \
        if ((uint32_t)(hi[1] - lo[1]) > ext)                                                                 \
            ext = (uint32_t)(hi[1] - lo[1]);                                                                 \
        if ((uint32_t)(hi[2] - lo[2]) > ext)                                                                 \
            ext = (uint32_t)(hi[2] - lo[2]);                                                                 \
        if (cubes) { /* the paper's bounding cube: same extent on every axis */                              \
            for (a = 0; a < 3; a++) {                                                                        \
                int64_t h = (int64_t)lo[a] + ext;                                                            \
                hi[a] = h > 2147483647 ? 2147483647 : (int32_t)h;                                            \
            }                                                                                                \
        }                                                                                                    \
        lvl = level_for(ext, bias, depth);                                                                   \
        sh = LC_QBITS - lvl;                                                                                 \
        for (a = 0; a < 3; a++) {                                                                            \
            c0[a] = (uint32_t)lo[a] >> sh;                                                                   \
            c1[a] = (uint32_t)hi[a] >> sh;                                                                   \
        }                                                                                                    \
        /* Bias >= 0 keeps c1 - c0 <= 1, but stay safe if a grid says otherwise. */                          \
        mx[0] = lc_morton_split3(c0[0]);                                                                     \
        mx[1] = lc_morton_next3(mx[0]);                                                                     \
        my[0] = lc_morton_split3(c0[1]) << 1;                                                                \
        my[1] = lc_morton_next3(my[0] >> 1) << 1;                                                                \
        mz[0] = lc_morton_split3(c0[2]) << 2;                                                                \
        mz[1] = lc_morton_next3(mz[0] >> 2) << 2;                                                                \
        base = (((uint64_t)lvl) << ib) | (uint64_t)i;                                                        \
        if (w + 8 > capacity) { /* slow path near the end of the buffer */                                   \
            size_t need = w + (size_t)(c1[0] - c0[0] + 1) * (c1[1] - c0[1] + 1) * (c1[2] - c0[2] + 1);       \
            if (need > capacity) {                                                                           \
                size_t rest = need;                                                                          \
                size_t j;                                                                                    \
                for (j = i + 1; j < first + count; j++)                                                      \
                    rest += LOCD_MAX_ENTRIES_PER_BOX;                                                        \
                *needed = rest;                                                                              \
                return (size_t)-1;                                                                           \
            }                                                                                                \
        }                                                                                                    \
        for (z = 0; z <= c1[2] - c0[2]; z++)                                                                 \
            for (y = 0; y <= c1[1] - c0[1]; y++)                                                             \
                for (x = 0; x <= c1[0] - c0[0]; x++) {                                                       \
                    uint64_t m = mx[x] | my[y] | mz[z];                                                      \
                    uint64_t pm = m << (3u * (depth - lvl));                                                 \
                    out[w++] = (pm << (LC_LEVEL_BITS + ib)) | base;                                          \
                }                                                                                            \
    }                                                                                                        \
    return w;

size_t lc_encode_f32(const locd_grid *g, const float *boxes, size_t first, size_t count, uint64_t *out,
                     size_t capacity, size_t *needed, int32_t *qbox)
{
    LC_ENCODE_BODY(float)
}

size_t lc_encode_f64(const locd_grid *g, const double *boxes, size_t first, size_t count, uint64_t *out,
                     size_t capacity, size_t *needed, int32_t *qbox)
{
    LC_ENCODE_BODY(double)
}

#define LC_ENCODE_PUBLIC(SUFFIX, T)                                                                          \
    locd_status locd_encode_##SUFFIX(const locd_grid *grid, const T *boxes, size_t first, size_t count,    \
                                     uint64_t *entries, size_t capacity, size_t *written)                    \
    {                                                                                                        \
        size_t need = 0, w;                                                                                  \
        locd_status st = lc_grid_check(grid);                                                                \
        if (st)                                                                                              \
            return st;                                                                                       \
        if (!written || (count && (!boxes || !entries)))                                                     \
            return lc_error(LOCD_ERR_NULL_POINTER, "boxes, entries and written must not be NULL");          \
        *written = 0;                                                                                        \
        if (count && (first + count < first || (uint64_t)(first + count - 1) >> grid->index_bits))          \
            return lc_error(LOCD_ERR_INVALID_ARGUMENT, "object indices exceed the grid's %u index bits",    \
                            grid->index_bits);                                                               \
        w = lc_encode_##SUFFIX(grid, boxes, first, count, entries, capacity, &need, NULL);                   \
        if (w == (size_t)-1) {                                                                               \
            *written = need;                                                                                 \
            return lc_error(LOCD_ERR_BUFFER_TOO_SMALL, "entries need up to %zu slots, capacity %zu", need,  \
                            capacity);                                                                       \
        }                                                                                                    \
        *written = w;                                                                                        \
        lc_clear_error();                                                                                    \
        return LOCD_OK;                                                                                      \
    }

LC_ENCODE_PUBLIC(f32, float)
LC_ENCODE_PUBLIC(f64, double)
