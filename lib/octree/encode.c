/* Step 1: boxes -> (octree cell, object) entries.
 *
 * Each box goes to the deepest level whose cell edge is at least 2^bias times
 * the box's largest quantized extent, so it touches at most two cells per
 * axis (at most 8 entries; about 1.7 on average for the default bias 2 on
 * uniform cubes, 2.7 for bias 1). */
#include "octree/octree.h"

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
        if (qbox)                                                                                            \
            lc_pack_qbox(lo, hi, qbox + 2 * i);                                                              \
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
        lvl = lc_level_for(ext, bias, depth);                                                                   \
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
                                size_t capacity, size_t *needed, uint64_t *qbox)
{
    LC_ENCODE_BODY(float)
}

static size_t encode_scalar_f64(const locd_grid *g, const double *boxes, size_t first, size_t count,
                                uint64_t *out, size_t capacity, size_t *needed, uint64_t *qbox)
{
    LC_ENCODE_BODY(double)
}

#ifdef LC_HAVE_AVX512_KERNEL
#include <immintrin.h>


/* split3 on eight 21-bit values at once (the magic-bits spread of lc_morton_split3). */
LC_AVX512 LC_INLINE __m512i spread3x8(__m256i v)
{
    __m512i x = _mm512_cvtepu32_epi64(v);
    x = _mm512_and_si512(_mm512_or_si512(x, _mm512_slli_epi64(x, 32)), _mm512_set1_epi64(0x1f00000000ffffLL));
    x = _mm512_and_si512(_mm512_or_si512(x, _mm512_slli_epi64(x, 16)), _mm512_set1_epi64(0x1f0000ff0000ffLL));
    x = _mm512_and_si512(_mm512_or_si512(x, _mm512_slli_epi64(x, 8)), _mm512_set1_epi64(0x100f00f00f00f00fLL));
    x = _mm512_and_si512(_mm512_or_si512(x, _mm512_slli_epi64(x, 4)), _mm512_set1_epi64(0x10c30c30c30c30c3LL));
    x = _mm512_and_si512(_mm512_or_si512(x, _mm512_slli_epi64(x, 2)), _mm512_set1_epi64(0x1249249249249249LL));
    return x;
}

/* Eight objects per step, with the same arithmetic as the scalar body (the
 * same IEEE operations in the same order as lc_quantize, so the same
 * integers) and the same entries in the same order: each object's cells in
 * (z, y, x) order, objects ascending. The coordinates are gathered into one
 * vector per axis and end, the sweep boxes packed for qbox,
 * and the up-to-8 cells of the eight objects transposed so that each
 * object's real cells leave in one compress and one store. */
#define LC_ENCODE_AVX512_BODY(T, GATHER, SCALAR)                                                                     \
    const uint32_t depth = g->depth, ib = g->index_bits;                                                     \
    const int cubes = (g->flags & LOCD_CONFIG_CUBES) != 0;                                                   \
    const __m512d half = _mm512_set1_pd(0.5), zero = _mm512_setzero_pd(), qmax = _mm512_set1_pd(LC_QMAX);   \
    const __m512d sa = _mm512_set1_pd(g->scale_a), sb = _mm512_set1_pd(g->scale_b);                         \
    const __m256i lane6 = _mm256_setr_epi32(0, 6, 12, 18, 24, 30, 36, 42);                                   \
    const __m256i top = _mm256_set1_epi32(31 - g->cell_bias), dmax = _mm256_set1_epi32((int)depth);         \
    const __m512i lane8 = _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 6, 7);                                         \
    /* packed boxes: object j's two words are lanes j of lo and hi */                                        \
    const __m512i even = _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11), odd = _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15); \
    static const uint8_t valid[8] = {0x01, 0x03, 0x05, 0x0f, 0x11, 0x33, 0x55, 0xff};                       \
    const size_t end = first + count;                                                                        \
    size_t i = first, w = 0;                                                                                 \
    for (; i + 8 <= end && w + 64 <= capacity; i += 8) {                                                     \
        const T *b = boxes + 6 * i;                                                                          \
        __m256i q[6], lv, sh, c0[3], d[3];                                                                   \
        __m512i m0[3], m1[3], code[8], shl, base;                                                            \
        uint32_t dd[8];                                                                                      \
        int a, k, j;                                                                                         \
        for (a = 0; a < 6; a++) {                                                                            \
            const __m512d o = _mm512_set1_pd(g->origin[a % 3]);                                              \
            const __m512d x = GATHER(a);                                                                     \
            const __m512d t = _mm512_mul_pd(_mm512_mul_pd(_mm512_sub_pd(_mm512_mul_pd(x, half), o), sa), sb); \
            q[a] = _mm512_cvttpd_epi32(_mm512_min_pd(_mm512_max_pd(t, zero), qmax));                         \
        }                                                                                                    \
        if (qbox) { /* lc_pack_qbox on eight boxes */                                                        \
            __m512i wd[2];                                                                                   \
            for (a = 0; a < 2; a++)                                                                          \
                wd[a] = _mm512_or_si512(                                                                     \
                    _mm512_cvtepu32_epi64(_mm256_srli_epi32(q[3 * a], LC_SDROP)),                            \
                    _mm512_or_si512(                                                                         \
                        _mm512_slli_epi64(_mm512_cvtepu32_epi64(_mm256_srli_epi32(q[3 * a + 1], LC_SDROP)), LC_SBITS), \
                        _mm512_slli_epi64(_mm512_cvtepu32_epi64(_mm256_srli_epi32(q[3 * a + 2], LC_SDROP)),    \
                                          2 * LC_SBITS)));                                                   \
            _mm512_storeu_si512(qbox + 2 * i, _mm512_permutex2var_epi64(wd[0], even, wd[1]));                 \
            _mm512_storeu_si512(qbox + 2 * i + 8, _mm512_permutex2var_epi64(wd[0], odd, wd[1]));              \
        }                                                                                                    \
        {                                                                                                    \
            __m256i ext = _mm256_max_epu32(_mm256_sub_epi32(q[3], q[0]), _mm256_sub_epi32(q[4], q[1]));      \
            ext = _mm256_max_epu32(ext, _mm256_sub_epi32(q[5], q[2]));                                       \
            if (cubes) /* the paper's bounding cube: same extent on every axis */                            \
                for (a = 0; a < 3; a++)                                                                      \
                    q[a + 3] = _mm256_min_epu32(_mm256_add_epi32(q[a], ext), _mm256_set1_epi32(2147483647)); \
            /* lc_level_for: 31 - bias - bitlen(ext), clamped to [0, depth] */                               \
            lv = _mm256_sub_epi32(top, _mm256_sub_epi32(_mm256_set1_epi32(32), _mm256_lzcnt_epi32(ext)));    \
            lv = _mm256_min_epi32(_mm256_max_epi32(lv, _mm256_setzero_si256()), dmax);                       \
            sh = _mm256_sub_epi32(_mm256_set1_epi32(LC_QBITS), lv);                                          \
        }                                                                                                    \
        for (a = 0; a < 3; a++) { /* d is 0 or 1: lc_grid_check keeps the bias >= 0 */                       \
            c0[a] = _mm256_srlv_epi32(q[a], sh);                                                             \
            d[a] = _mm256_sub_epi32(_mm256_srlv_epi32(q[a + 3], sh), c0[a]);                                 \
            m0[a] = _mm512_slli_epi64(spread3x8(c0[a]), a);                                                  \
            m1[a] = _mm512_slli_epi64(spread3x8(_mm256_add_epi32(c0[a], d[a])), a);                          \
        }                                                                                                    \
        _mm256_storeu_si256((__m256i *)dd,                                                                   \
                            _mm256_or_si256(d[0], _mm256_or_si256(_mm256_slli_epi32(d[1], 1),               \
                                                                  _mm256_slli_epi32(d[2], 2))));             \
        shl = _mm512_cvtepu32_epi64(_mm256_add_epi32(                                                        \
            _mm256_mullo_epi32(_mm256_sub_epi32(dmax, lv), _mm256_set1_epi32(3)),                            \
            _mm256_set1_epi32((int)(LC_LEVEL_BITS + ib))));                                                   \
        base = _mm512_or_si512(_mm512_sllv_epi64(_mm512_cvtepu32_epi64(lv), _mm512_set1_epi64(ib)),         \
                               _mm512_add_epi64(_mm512_set1_epi64((long long)i), lane8));                   \
        for (k = 0; k < 8; k++) {                                                                            \
            const __m512i c = _mm512_or_si512(_mm512_or_si512((k & 1) ? m1[0] : m0[0], (k & 2) ? m1[1] : m0[1]), \
                                              (k & 4) ? m1[2] : m0[2]);                                      \
            code[k] = _mm512_or_si512(_mm512_sllv_epi64(c, shl), base);                                      \
        }                                                                                                    \
        {                                                                                                    \
            /* 8x8 transpose of 64-bit lanes: row j = object j's 8 cells */                                  \
            const __m512i t0 = _mm512_unpacklo_epi64(code[0], code[1]), t1 = _mm512_unpackhi_epi64(code[0], code[1]); \
            const __m512i t2 = _mm512_unpacklo_epi64(code[2], code[3]), t3 = _mm512_unpackhi_epi64(code[2], code[3]); \
            const __m512i t4 = _mm512_unpacklo_epi64(code[4], code[5]), t5 = _mm512_unpackhi_epi64(code[4], code[5]); \
            const __m512i t6 = _mm512_unpacklo_epi64(code[6], code[7]), t7 = _mm512_unpackhi_epi64(code[6], code[7]); \
            const __m512i u0 = _mm512_shuffle_i64x2(t0, t2, 0x88), u1 = _mm512_shuffle_i64x2(t1, t3, 0x88);  \
            const __m512i u2 = _mm512_shuffle_i64x2(t0, t2, 0xdd), u3 = _mm512_shuffle_i64x2(t1, t3, 0xdd);  \
            const __m512i u4 = _mm512_shuffle_i64x2(t4, t6, 0x88), u5 = _mm512_shuffle_i64x2(t5, t7, 0x88);  \
            const __m512i u6 = _mm512_shuffle_i64x2(t4, t6, 0xdd), u7 = _mm512_shuffle_i64x2(t5, t7, 0xdd);  \
            __m512i row[8];                                                                                  \
            row[0] = _mm512_shuffle_i64x2(u0, u4, 0x88);                                                     \
            row[1] = _mm512_shuffle_i64x2(u1, u5, 0x88);                                                     \
            row[2] = _mm512_shuffle_i64x2(u2, u6, 0x88);                                                     \
            row[3] = _mm512_shuffle_i64x2(u3, u7, 0x88);                                                     \
            row[4] = _mm512_shuffle_i64x2(u0, u4, 0xdd);                                                     \
            row[5] = _mm512_shuffle_i64x2(u1, u5, 0xdd);                                                     \
            row[6] = _mm512_shuffle_i64x2(u2, u6, 0xdd);                                                     \
            row[7] = _mm512_shuffle_i64x2(u3, u7, 0xdd);                                                     \
            for (j = 0; j < 8; j++) {                                                                        \
                const __mmask8 v = valid[dd[j]];                                                             \
                _mm512_storeu_si512(out + w, _mm512_maskz_compress_epi64(v, row[j]));                        \
                w += (size_t)__builtin_popcount(v);                                                          \
            }                                                                                                \
        }                                                                                                    \
    }                                                                                                        \
    if (i < end) { /* the last objects, or the end of the buffer: the scalar body */                         \
        size_t more = SCALAR(g, boxes, i, end - i, out + w, capacity - w, needed, qbox);          \
        if (more == (size_t)-1) {                                                                            \
            *needed += w;                                                                                    \
            return more;                                                                                     \
        }                                                                                                    \
        w += more;                                                                                           \
    }                                                                                                        \
    return w;

#define LC_GATHER_F32(a) _mm512_cvtps_pd(_mm256_i32gather_ps(b + (a), lane6, 4))
#define LC_GATHER_F64(a) _mm512_i32gather_pd(lane6, b + (a), 8)

LC_AVX512 static size_t encode_avx512_f32(const locd_grid *g, const float *boxes, size_t first, size_t count,
                                                 uint64_t *out, size_t capacity, size_t *needed, uint64_t *qbox)
{
    LC_ENCODE_AVX512_BODY(float, LC_GATHER_F32, encode_scalar_f32)
}

LC_AVX512 static size_t encode_avx512_f64(const locd_grid *g, const double *boxes, size_t first, size_t count,
                                                 uint64_t *out, size_t capacity, size_t *needed, uint64_t *qbox)
{
    LC_ENCODE_AVX512_BODY(double, LC_GATHER_F64, encode_scalar_f64)
}
#endif

#ifdef LC_HAVE_AVX512_KERNEL
#define LC_ENCODE_VECTOR(SUFFIX)                                                                             \
    if (lc_kernel() == LC_KERNEL_AVX512)                                                                     \
        return encode_avx512_##SUFFIX(g, boxes, first, count, out, capacity, needed, qbox);
#else
#define LC_ENCODE_VECTOR(SUFFIX)
#endif
#define LC_ENCODE_DISPATCH(SUFFIX, T)                                                                        \
    size_t lc_encode_##SUFFIX(const locd_grid *g, const T *boxes, size_t first, size_t count, uint64_t *out, \
                              size_t capacity, size_t *needed, uint64_t *qbox)                               \
    {                                                                                                        \
        LC_ENCODE_VECTOR(SUFFIX)                                                                             \
        return encode_scalar_##SUFFIX(g, boxes, first, count, out, capacity, needed, qbox);                  \
    }

LC_ENCODE_DISPATCH(f32, float)
LC_ENCODE_DISPATCH(f64, double)
