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

static size_t encode_scalar_f32(const locd_grid *g, const float *boxes, size_t first, size_t count, uint64_t *out,
                                size_t capacity, size_t *needed, int32_t *qbox)
{
    LC_ENCODE_BODY(float)
}

static size_t encode_scalar_f64(const locd_grid *g, const double *boxes, size_t first, size_t count,
                                uint64_t *out, size_t capacity, size_t *needed, int32_t *qbox)
{
    LC_ENCODE_BODY(double)
}

/* Sets *needed for the objects from i on when the output is too small. */
static size_t encode_overflow(size_t w, size_t cells, size_t i, size_t end, size_t *needed)
{
    *needed = w + cells + (end - i - 1) * LOCD_MAX_ENTRIES_PER_BOX;
    return (size_t)-1;
}

#ifdef LC_HAVE_AVX512_KERNEL
#include <immintrin.h>

/* The same entries as the scalar body, in the same order: the six
 * coordinates quantized in one vector (the same IEEE operations in the same
 * order as lc_quantize, so the same integers), Morton codes by pdep, and the
 * up to 8 cells written without branches (every candidate cell is stored,
 * the output position advances only past the real ones). */
#define LC_MORTON_X 0x1249249249249249ULL
#define LC_ENCODE_AVX512_BODY(LOAD)                                                                          \
    const uint32_t depth = g->depth, ib = g->index_bits;                                                     \
    const int32_t bias = g->cell_bias;                                                                       \
    const int cubes = (g->flags & LOCD_CONFIG_CUBES) != 0;                                                   \
    const __m512d half = _mm512_set1_pd(0.5), zero = _mm512_setzero_pd(), qmax = _mm512_set1_pd(LC_QMAX);   \
    const __m512d origin = _mm512_setr_pd(g->origin[0], g->origin[1], g->origin[2], g->origin[0],           \
                                          g->origin[1], g->origin[2], 0.0, 0.0);                             \
    const __m512d sa = _mm512_setr_pd(g->scale_a, g->scale_a, g->scale_a, g->scale_a, g->scale_a,          \
                                      g->scale_a, 1.0, 1.0);                                                 \
    const __m512d sb = _mm512_setr_pd(g->scale_b, g->scale_b, g->scale_b, g->scale_b, g->scale_b,          \
                                      g->scale_b, 1.0, 1.0);                                                 \
    const size_t end = first + count;                                                                        \
    size_t i, w = 0;                                                                                         \
    for (i = first; i < end; i++) {                                                                          \
        const __m512d x = LOAD;                                                                              \
        const __m512d t = _mm512_mul_pd(_mm512_mul_pd(_mm512_sub_pd(_mm512_mul_pd(x, half), origin), sa), sb); \
        const __m256i qv = _mm512_cvttpd_epi32(_mm512_min_pd(_mm512_max_pd(t, zero), qmax));                 \
        int32_t q[8];                                                                                        \
        uint32_t ext, lvl, sh, d[3], c0[3], k, cells;                                                        \
        uint64_t mx[2], my[2], mz[2], base;                                                                  \
        int a;                                                                                               \
        _mm256_storeu_si256((__m256i *)q, qv);                                                               \
        if (qbox)                                                                                            \
            _mm256_mask_storeu_epi32(qbox + 6 * i, 0x3f, qv);                                                \
        ext = (uint32_t)(q[3] - q[0]);                                                                       \
        if ((uint32_t)(q[4] - q[1]) > ext)                                                                   \
            ext = (uint32_t)(q[4] - q[1]);                                                                   \
        if ((uint32_t)(q[5] - q[2]) > ext)                                                                   \
            ext = (uint32_t)(q[5] - q[2]);                                                                   \
        if (cubes) /* the paper's bounding cube: same extent on every axis */                                \
            for (a = 0; a < 3; a++) {                                                                        \
                int64_t h = (int64_t)q[a] + ext;                                                             \
                q[a + 3] = h > 2147483647 ? 2147483647 : (int32_t)h;                                         \
            }                                                                                                \
        lvl = level_for(ext, bias, depth);                                                                   \
        sh = LC_QBITS - lvl;                                                                                 \
        for (a = 0; a < 3; a++) { /* d is 0 or 1: lc_grid_check keeps the bias >= 0 */                       \
            c0[a] = (uint32_t)q[a] >> sh;                                                                    \
            d[a] = ((uint32_t)q[a + 3] >> sh) - c0[a];                                                       \
        }                                                                                                    \
        cells = (d[0] + 1) * (d[1] + 1) * (d[2] + 1);                                                        \
        if (LC_UNLIKELY(w + 8 > capacity) && w + cells > capacity)                                           \
            return encode_overflow(w, cells, i, end, needed);                                                \
        mx[0] = _pdep_u64(c0[0], LC_MORTON_X);                                                               \
        mx[1] = _pdep_u64(c0[0] + d[0], LC_MORTON_X);                                                        \
        my[0] = _pdep_u64(c0[1], LC_MORTON_X << 1);                                                          \
        my[1] = _pdep_u64(c0[1] + d[1], LC_MORTON_X << 1);                                                   \
        mz[0] = _pdep_u64(c0[2], LC_MORTON_X << 2);                                                          \
        mz[1] = _pdep_u64(c0[2] + d[2], LC_MORTON_X << 2);                                                   \
        base = (((uint64_t)lvl) << ib) | (uint64_t)i;                                                        \
        sh = 3u * (depth - lvl) + LC_LEVEL_BITS + ib;                                                        \
        if (LC_LIKELY(w + 8 <= capacity)) {                                                                  \
            for (k = 0; k < 8; k++) {                                                                        \
                const uint32_t kx = k & 1u, ky = (k >> 1) & 1u, kz = k >> 2;                                 \
                out[w] = ((mx[kx] | my[ky] | mz[kz]) << sh) | base;                                          \
                w += (kx <= d[0]) & (ky <= d[1]) & (kz <= d[2]);                                             \
            }                                                                                                \
        } else { /* near the end of the buffer: write only the real cells */                                 \
            for (k = 0; k < 8; k++) {                                                                        \
                const uint32_t kx = k & 1u, ky = (k >> 1) & 1u, kz = k >> 2;                                 \
                if ((kx <= d[0]) & (ky <= d[1]) & (kz <= d[2]))                                              \
                    out[w++] = ((mx[kx] | my[ky] | mz[kz]) << sh) | base;                                    \
            }                                                                                                \
        }                                                                                                    \
    }                                                                                                        \
    return w;

LC_AVX512 static size_t encode_avx512_f32(const locd_grid *g, const float *boxes, size_t first, size_t count,
                                          uint64_t *out, size_t capacity, size_t *needed, int32_t *qbox)
{
    LC_ENCODE_AVX512_BODY(_mm512_cvtps_pd(_mm256_maskz_loadu_ps(0x3f, boxes + 6 * i)))
}

LC_AVX512 static size_t encode_avx512_f64(const locd_grid *g, const double *boxes, size_t first, size_t count,
                                          uint64_t *out, size_t capacity, size_t *needed, int32_t *qbox)
{
    LC_ENCODE_AVX512_BODY(_mm512_maskz_loadu_pd(0x3f, boxes + 6 * i))
}
#endif

size_t lc_encode_f32(const locd_grid *g, const float *boxes, size_t first, size_t count, uint64_t *out,
                     size_t capacity, size_t *needed, int32_t *qbox)
{
#ifdef LC_HAVE_AVX512_KERNEL
    if (lc_kernel() == LC_KERNEL_AVX512)
        return encode_avx512_f32(g, boxes, first, count, out, capacity, needed, qbox);
#endif
    return encode_scalar_f32(g, boxes, first, count, out, capacity, needed, qbox);
}

size_t lc_encode_f64(const locd_grid *g, const double *boxes, size_t first, size_t count, uint64_t *out,
                     size_t capacity, size_t *needed, int32_t *qbox)
{
#ifdef LC_HAVE_AVX512_KERNEL
    if (lc_kernel() == LC_KERNEL_AVX512)
        return encode_avx512_f64(g, boxes, first, count, out, capacity, needed, qbox);
#endif
    return encode_scalar_f64(g, boxes, first, count, out, capacity, needed, qbox);
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
