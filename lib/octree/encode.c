/* Step 1: boxes -> (octree cell, object) entries.
 *
 * Each box goes to the deepest level whose cell edge is at least 2^bias times
 * the box's largest quantized extent, so it touches at most two cells per
 * axis (at most 8 entries; about 1.7 on average for the default bias 2 on
 * uniform cubes, 2.7 for bias 1). */
#include "octree/octree.h"

#include <assert.h>

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

/* lc_pack_qbox on eight boxes (q: lo xyz, hi xyz, one vector each): object
 * j's two words are lanes j of the lo and hi words. */
LC_AVX512 LC_INLINE void pack_qbox8(const __m256i q[6], uint64_t *qbox)
{
    const __m512i even = _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11);
    const __m512i odd = _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15);
    __m512i wd[2];
    int a;
    for (a = 0; a < 2; a++)
        wd[a] = _mm512_or_si512(
            _mm512_cvtepu32_epi64(_mm256_srli_epi32(q[3 * a], LC_SDROP)),
            _mm512_or_si512(
                _mm512_slli_epi64(_mm512_cvtepu32_epi64(_mm256_srli_epi32(q[3 * a + 1], LC_SDROP)), LC_SBITS),
                _mm512_slli_epi64(_mm512_cvtepu32_epi64(_mm256_srli_epi32(q[3 * a + 2], LC_SDROP)), 2 * LC_SBITS)));
    _mm512_storeu_si512(qbox, _mm512_permutex2var_epi64(wd[0], even, wd[1]));
    _mm512_storeu_si512(qbox + 8, _mm512_permutex2var_epi64(wd[0], odd, wd[1]));
}

/* Writes the real cells of eight objects at out + w, object by object:
 * code[k] holds cell k (x, y, z bits of k) of each object, dd[j] says which
 * cells object j has (its second cell on each axis, or not). An 8x8
 * transpose of 64-bit lanes makes row j object j's 8 cells; one compress
 * and one store then write its real ones. Returns the new w. */
LC_AVX512 LC_INLINE size_t store_cells8(const __m512i code[8], const uint32_t dd[8], uint64_t *out, size_t w)
{
    static const uint8_t valid[8] = {0x01, 0x03, 0x05, 0x0f, 0x11, 0x33, 0x55, 0xff};
    const __m512i t0 = _mm512_unpacklo_epi64(code[0], code[1]), t1 = _mm512_unpackhi_epi64(code[0], code[1]);
    const __m512i t2 = _mm512_unpacklo_epi64(code[2], code[3]), t3 = _mm512_unpackhi_epi64(code[2], code[3]);
    const __m512i t4 = _mm512_unpacklo_epi64(code[4], code[5]), t5 = _mm512_unpackhi_epi64(code[4], code[5]);
    const __m512i t6 = _mm512_unpacklo_epi64(code[6], code[7]), t7 = _mm512_unpackhi_epi64(code[6], code[7]);
    const __m512i u0 = _mm512_shuffle_i64x2(t0, t2, 0x88), u1 = _mm512_shuffle_i64x2(t1, t3, 0x88);
    const __m512i u2 = _mm512_shuffle_i64x2(t0, t2, 0xdd), u3 = _mm512_shuffle_i64x2(t1, t3, 0xdd);
    const __m512i u4 = _mm512_shuffle_i64x2(t4, t6, 0x88), u5 = _mm512_shuffle_i64x2(t5, t7, 0x88);
    const __m512i u6 = _mm512_shuffle_i64x2(t4, t6, 0xdd), u7 = _mm512_shuffle_i64x2(t5, t7, 0xdd);
    __m512i row[8];
    int j;
    row[0] = _mm512_shuffle_i64x2(u0, u4, 0x88);
    row[1] = _mm512_shuffle_i64x2(u1, u5, 0x88);
    row[2] = _mm512_shuffle_i64x2(u2, u6, 0x88);
    row[3] = _mm512_shuffle_i64x2(u3, u7, 0x88);
    row[4] = _mm512_shuffle_i64x2(u0, u4, 0xdd);
    row[5] = _mm512_shuffle_i64x2(u1, u5, 0xdd);
    row[6] = _mm512_shuffle_i64x2(u2, u6, 0xdd);
    row[7] = _mm512_shuffle_i64x2(u3, u7, 0xdd);
    for (j = 0; j < 8; j++) {
        const __mmask8 v = valid[dd[j]];
        _mm512_storeu_si512(out + w, _mm512_maskz_compress_epi64(v, row[j]));
        w += (size_t)__builtin_popcount(v);
    }
    return w;
}
#endif

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define LC_HAVE_AVX2_ENCODE 1
#define LC_AVX2_ENCODE __attribute__((target("avx2")))

/* split3 on four 21-bit values at once (lc_morton_split3's magic bits). */
LC_AVX2_ENCODE LC_INLINE __m256i spread3x4(__m128i v)
{
    __m256i x = _mm256_cvtepu32_epi64(v);
    x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi64(x, 32)), _mm256_set1_epi64x(0x1f00000000ffffLL));
    x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi64(x, 16)), _mm256_set1_epi64x(0x1f0000ff0000ffLL));
    x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi64(x, 8)), _mm256_set1_epi64x(0x100f00f00f00f00fLL));
    x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi64(x, 4)), _mm256_set1_epi64x(0x10c30c30c30c30c3LL));
    x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi64(x, 2)), _mm256_set1_epi64x(0x1249249249249249LL));
    return x;
}

/* lc_pack_qbox on four boxes (q: lo xyz, hi xyz, four lanes each). */
LC_AVX2_ENCODE LC_INLINE void pack_qbox4(const __m128i q[6], uint64_t *qbox)
{
    __m256i wd[2], lo, hi;
    int a;
    for (a = 0; a < 2; a++)
        wd[a] = _mm256_or_si256(
            _mm256_cvtepu32_epi64(_mm_srli_epi32(q[3 * a], LC_SDROP)),
            _mm256_or_si256(
                _mm256_slli_epi64(_mm256_cvtepu32_epi64(_mm_srli_epi32(q[3 * a + 1], LC_SDROP)), LC_SBITS),
                _mm256_slli_epi64(_mm256_cvtepu32_epi64(_mm_srli_epi32(q[3 * a + 2], LC_SDROP)), 2 * LC_SBITS)));
    lo = _mm256_unpacklo_epi64(wd[0], wd[1]); /* objects 0 and 2 */
    hi = _mm256_unpackhi_epi64(wd[0], wd[1]); /* objects 1 and 3 */
    _mm256_storeu_si256((__m256i *)qbox, _mm256_permute2x128_si256(lo, hi, 0x20));
    _mm256_storeu_si256((__m256i *)(qbox + 4), _mm256_permute2x128_si256(lo, hi, 0x31));
}

/* The cells k (bit 0: second x cell, bit 1: y, bit 2: z) an object has when
 * its second cells are the bits of d, ascending ((z, y, x) order: the
 * scalar body's), padded; and how many. */
static const uint8_t cells_of_d[8][8] = {
    {0, 0, 0, 0, 0, 0, 0, 0}, {0, 1, 0, 0, 0, 0, 0, 0}, {0, 2, 0, 0, 0, 0, 0, 0}, {0, 1, 2, 3, 0, 0, 0, 0},
    {0, 4, 0, 0, 0, 0, 0, 0}, {0, 1, 4, 5, 0, 0, 0, 0}, {0, 2, 4, 6, 0, 0, 0, 0}, {0, 1, 2, 3, 4, 5, 6, 7}};
static const uint8_t ncells_of_d[8] = {1, 2, 2, 4, 2, 4, 4, 8};
#endif

/* The variants (octree.h): the scalar body and, where the compiler has it,
 * the AVX2 and AVX-512 ones, per precision; LC_GATHER loads coordinate a of
 * eight boxes as doubles, LC_LOAD4 of four. */
#define LC_T float
#define LC_SUFFIX f32
#define LC_GATHER(a) _mm512_cvtps_pd(_mm256_i32gather_ps(b + (a), lane6, 4))
#define LC_LOAD4(a) _mm256_cvtps_pd(_mm_setr_ps(b[a], b[(a) + 6], b[(a) + 12], b[(a) + 18]))
#include "encode_impl.h"
#undef LC_GATHER
#undef LC_LOAD4

#define LC_T double
#define LC_SUFFIX f64
#define LC_GATHER(a) _mm512_i32gather_pd(lane6, b + (a), 8)
#define LC_LOAD4(a) _mm256_setr_pd(b[a], b[(a) + 6], b[(a) + 12], b[(a) + 18])
#include "encode_impl.h"
#undef LC_GATHER
#undef LC_LOAD4
