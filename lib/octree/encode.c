/* Step 1: boxes -> (octree cell, object) entries.
 *
 * Each box goes to the deepest level whose cell edge is at least 2^bias times
 * the box's largest quantized extent, or up to `bias` levels deeper for a
 * flat or thin box (lc_level_of), and touches at most two cells per axis (at
 * most 8 entries; about 1.7 on average for the default bias 2 on uniform
 * cubes, 2.7 for bias 1). */
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

/* lc_level_of on eight boxes: the quantized boxes q (lo xyz, hi xyz) after
 * the cube's extension, the bias, the depth and lc_spread_limit(bias). The
 * same doubles as the scalar function's, computed in the same order. */
LC_AVX512 LC_INLINE __m256i level_of8(const __m256i q[6], int32_t bias, uint32_t depth, __m512d limit)
{
    const __m512d one = _mm512_set1_pd(1.0);
    const __m256i dmax = _mm256_set1_epi32((int)depth), zero = _mm256_setzero_si256();
    __m256i e[3], w, len, lv, top;
    __m512d ed[3];
    __mmask8 go;
    int a;
    for (a = 0; a < 3; a++) {
        e[a] = _mm256_sub_epi32(q[a + 3], q[a]);
        ed[a] = _mm512_cvtepu32_pd(e[a]);
    }
    w = _mm256_max_epu32(_mm256_max_epu32(e[0], e[1]), e[2]);
    len = _mm256_sub_epi32(_mm256_set1_epi32(32), _mm256_lzcnt_epi32(w));
    /* lc_level_for(w, bias) and lc_level_for(w, 0): 31 - bias - bitlen(w), clamped to [0, depth] */
    lv = _mm256_sub_epi32(_mm256_set1_epi32((int)LC_QBITS - bias), len);
    lv = _mm256_min_epi32(_mm256_max_epi32(lv, zero), dmax);
    top = _mm256_min_epi32(_mm256_max_epi32(_mm256_sub_epi32(_mm256_set1_epi32((int)LC_QBITS), len), zero), dmax);
    go = _mm256_cmplt_epi32_mask(lv, top);
    while (go) {
        const __m256i next = _mm256_add_epi32(lv, _mm256_set1_epi32(1));
        const __m512d s = _mm512_castsi512_pd(_mm512_slli_epi64( /* 2^(next - 31): its exponent field */
            _mm512_cvtepu32_epi64(_mm256_add_epi32(next, _mm256_set1_epi32(1023 - (int)LC_QBITS))), 52));
        const __m512d p = _mm512_mul_pd(_mm512_mul_pd(_mm512_add_pd(one, _mm512_mul_pd(ed[0], s)),
                                                      _mm512_add_pd(one, _mm512_mul_pd(ed[1], s))),
                                        _mm512_add_pd(one, _mm512_mul_pd(ed[2], s)));
        go &= _mm512_cmp_pd_mask(p, limit, _CMP_LE_OQ);
        lv = _mm256_mask_mov_epi32(lv, go, next);
        go &= _mm256_cmplt_epi32_mask(next, top);
    }
    return lv;
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

/* Coordinate a of the eight float boxes at b (48 floats), as doubles, in
 * x[a]: three loads, then per coordinate two two-source permutes (floats
 * 6j + a below 32 from the first two loads, the others from the last two)
 * and a masked move. With the gathers this replaces (eight loads each),
 * the stage took more than twice as long on an AMD EPYC (Zen 5). */
LC_AVX512 LC_INLINE void load8_f32(const float *b, __m512d x[6])
{
    const __m512 z0 = _mm512_loadu_ps(b), z1 = _mm512_loadu_ps(b + 16), z2 = _mm512_loadu_ps(b + 32);
    const __m512i six = _mm512_setr_epi32(0, 6, 12, 18, 24, 30, 36, 42, 0, 0, 0, 0, 0, 0, 0, 0);
    int a;
    for (a = 0; a < 6; a++) {
        const __m512i lo = _mm512_add_epi32(six, _mm512_set1_epi32(a)); /* index into z0:z1 (low 5 bits) */
        const __m512i hi = _mm512_sub_epi32(lo, _mm512_set1_epi32(16)); /* into z1:z2 */
        const __mmask16 late = _mm512_cmpge_epi32_mask(lo, _mm512_set1_epi32(32));
        const __m512 v = _mm512_mask_mov_ps(_mm512_permutex2var_ps(z0, lo, z1), late, _mm512_permutex2var_ps(z1, hi, z2));
        x[a] = _mm512_cvtps_pd(_mm512_castps512_ps256(v));
    }
}

/* The same for eight double boxes (48 doubles): six loads, then per
 * coordinate three two-source permutes (doubles 6j + a below 16, below 32,
 * and from 32) and two masked moves. */
LC_AVX512 LC_INLINE void load8_f64(const double *b, __m512d x[6])
{
    __m512d z[6];
    const __m512i six = _mm512_setr_epi64(0, 6, 12, 18, 24, 30, 36, 42);
    int a;
    for (a = 0; a < 6; a++)
        z[a] = _mm512_loadu_pd(b + 8 * a);
    for (a = 0; a < 6; a++) {
        const __m512i at = _mm512_add_epi64(six, _mm512_set1_epi64(a)); /* index into z0:z1 (low 4 bits) */
        const __m512i at1 = _mm512_sub_epi64(at, _mm512_set1_epi64(16)), at2 = _mm512_sub_epi64(at, _mm512_set1_epi64(32));
        const __mmask8 mid = _mm512_cmpge_epi64_mask(at, _mm512_set1_epi64(16)), late = _mm512_cmpge_epi64_mask(at, _mm512_set1_epi64(32));
        __m512d v = _mm512_permutex2var_pd(z[0], at, z[1]);
        v = _mm512_mask_mov_pd(v, mid, _mm512_permutex2var_pd(z[2], at1, z[3]));
        x[a] = _mm512_mask_mov_pd(v, late, _mm512_permutex2var_pd(z[4], at2, z[5]));
    }
}
#endif

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define LC_HAVE_AVX2_ENCODE 1
#define LC_AVX2_ENCODE __attribute__((target("avx2")))

/* split3 on four values below 2^depth at once (lc_morton_split3's magic
 * bits, depth <= 21). A value below 2^16 is unchanged by the first step, one
 * below 2^8 by the second too: a grid of depth 16 or less skips them (the
 * branches are the same for a whole call). */
LC_AVX2_ENCODE LC_INLINE __m256i spread3x4(__m128i v, uint32_t depth)
{
    __m256i x = _mm256_cvtepu32_epi64(v);
    if (depth > 16)
        x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi64(x, 32)), _mm256_set1_epi64x(0x1f00000000ffffLL));
    if (depth > 8)
        x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi64(x, 16)), _mm256_set1_epi64x(0x1f0000ff0000ffLL));
    x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi64(x, 8)), _mm256_set1_epi64x(0x100f00f00f00f00fLL));
    x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi64(x, 4)), _mm256_set1_epi64x(0x10c30c30c30c30c3LL));
    x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi64(x, 2)), _mm256_set1_epi64x(0x1249249249249249LL));
    return x;
}

/* lc_level_of on four boxes, as level_of8. bitlen(w) is the exponent of w
 * as a double (exact: w < 2^31), less 1022. */
LC_AVX2_ENCODE LC_INLINE __m128i level_of4(const __m128i q[6], int32_t bias, uint32_t depth, __m256d limit)
{
    const __m256d one = _mm256_set1_pd(1.0);
    const __m256i lo32 = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
    const __m128i dmax = _mm_set1_epi32((int)depth), zero = _mm_setzero_si128();
    __m128i e[3], w, len, lv, top, go;
    __m256d ed[3];
    int a;
    for (a = 0; a < 3; a++) {
        e[a] = _mm_sub_epi32(q[a + 3], q[a]);
        ed[a] = _mm256_cvtepi32_pd(e[a]);
    }
    w = _mm_max_epu32(_mm_max_epu32(e[0], e[1]), e[2]);
    len = _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(
        _mm256_srli_epi64(_mm256_castpd_si256(_mm256_cvtepi32_pd(w)), 52), lo32));
    len = _mm_max_epi32(_mm_sub_epi32(len, _mm_set1_epi32(1022)), zero);
    lv = _mm_min_epi32(_mm_max_epi32(_mm_sub_epi32(_mm_set1_epi32((int)LC_QBITS - bias), len), zero), dmax);
    top = _mm_min_epi32(_mm_max_epi32(_mm_sub_epi32(_mm_set1_epi32((int)LC_QBITS), len), zero), dmax);
    go = _mm_cmplt_epi32(lv, top);
    while (_mm_movemask_epi8(go)) {
        const __m128i next = _mm_add_epi32(lv, _mm_set1_epi32(1));
        const __m256d s = _mm256_castsi256_pd(_mm256_slli_epi64( /* 2^(next - 31): its exponent field */
            _mm256_cvtepi32_epi64(_mm_add_epi32(next, _mm_set1_epi32(1023 - (int)LC_QBITS))), 52));
        const __m256d p = _mm256_mul_pd(_mm256_mul_pd(_mm256_add_pd(one, _mm256_mul_pd(ed[0], s)),
                                                      _mm256_add_pd(one, _mm256_mul_pd(ed[1], s))),
                                        _mm256_add_pd(one, _mm256_mul_pd(ed[2], s)));
        const __m128i le = _mm256_castsi256_si128(
            _mm256_permutevar8x32_epi32(_mm256_castpd_si256(_mm256_cmp_pd(p, limit, _CMP_LE_OQ)), lo32));
        go = _mm_and_si128(go, le);
        lv = _mm_blendv_epi8(lv, next, go);
        go = _mm_and_si128(go, _mm_cmplt_epi32(next, top));
    }
    return lv;
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

/* Writes the real cells of four objects at out + w, object by object:
 * code[k] holds cell k (bit 0: second x cell, bit 1: y, bit 2: z) of each
 * object in lane j, dd[j] says which second cells object j has. Two 4x4
 * transposes of 64-bit lanes make object j's cells 0-3 one vector and its
 * cells 4-7 another. An object's real cells in a half are k with no bit
 * outside dd[j]: 0; 0, 1; 0, 2; or all four, in (z, y, x) order (the scalar
 * body's); one permute brings them to the front (only 0, 2 moves a lane),
 * one store writes the half, and w advances by their number (by none for
 * the z half of an object with no second z cell: the next store writes over
 * it). At most eight entries are written past w per object, as before. */
LC_AVX2_ENCODE LC_INLINE size_t store_cells4(const __m256i code[8], const uint32_t dd[4], uint64_t *out, size_t w)
{
    static const int32_t front[4][8] = {
        {0, 1, 2, 3, 4, 5, 6, 7}, {0, 1, 2, 3, 4, 5, 6, 7}, {0, 1, 4, 5, 2, 3, 6, 7}, {0, 1, 2, 3, 4, 5, 6, 7}};
    static const uint8_t count[4] = {1, 2, 2, 4};
    __m256i row[2][4];
    int h, j;
    for (h = 0; h < 2; h++) {
        const __m256i *c = code + 4 * h;
        const __m256i t0 = _mm256_unpacklo_epi64(c[0], c[1]), t1 = _mm256_unpackhi_epi64(c[0], c[1]);
        const __m256i t2 = _mm256_unpacklo_epi64(c[2], c[3]), t3 = _mm256_unpackhi_epi64(c[2], c[3]);
        row[h][0] = _mm256_permute2x128_si256(t0, t2, 0x20);
        row[h][1] = _mm256_permute2x128_si256(t1, t3, 0x20);
        row[h][2] = _mm256_permute2x128_si256(t0, t2, 0x31);
        row[h][3] = _mm256_permute2x128_si256(t1, t3, 0x31);
    }
    for (j = 0; j < 4; j++) {
        const uint32_t xy = dd[j] & 3u;
        const __m256i p = _mm256_loadu_si256((const __m256i *)front[xy]);
        _mm256_storeu_si256((__m256i *)(out + w), _mm256_permutevar8x32_epi32(row[0][j], p));
        w += count[xy];
        _mm256_storeu_si256((__m256i *)(out + w), _mm256_permutevar8x32_epi32(row[1][j], p));
        w += (dd[j] & 4u) ? count[xy] : 0u;
    }
    return w;
}

/* Coordinate a (lo x y z, hi x y z) of the four boxes at b, as doubles,
 * in x[a]: per box one load of its first four coordinates and one of its
 * last two, then a 4x4 transpose and two shuffles (four scalar loads and
 * inserts per coordinate before). */
LC_AVX2_ENCODE LC_INLINE void load4_f32(const float *b, __m256d x[6])
{
    __m128 r0 = _mm_loadu_ps(b), r1 = _mm_loadu_ps(b + 6), r2 = _mm_loadu_ps(b + 12), r3 = _mm_loadu_ps(b + 18);
    const __m128 s01 = _mm_loadh_pi(_mm_loadl_pi(_mm_setzero_ps(), (const __m64 *)(b + 4)), (const __m64 *)(b + 10));
    const __m128 s23 = _mm_loadh_pi(_mm_loadl_pi(_mm_setzero_ps(), (const __m64 *)(b + 16)), (const __m64 *)(b + 22));
    _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
    x[0] = _mm256_cvtps_pd(r0);
    x[1] = _mm256_cvtps_pd(r1);
    x[2] = _mm256_cvtps_pd(r2);
    x[3] = _mm256_cvtps_pd(r3);
    x[4] = _mm256_cvtps_pd(_mm_shuffle_ps(s01, s23, _MM_SHUFFLE(2, 0, 2, 0)));
    x[5] = _mm256_cvtps_pd(_mm_shuffle_ps(s01, s23, _MM_SHUFFLE(3, 1, 3, 1)));
}

LC_AVX2_ENCODE LC_INLINE void load4_f64(const double *b, __m256d x[6])
{
    const __m256d r0 = _mm256_loadu_pd(b), r1 = _mm256_loadu_pd(b + 6), r2 = _mm256_loadu_pd(b + 12),
                  r3 = _mm256_loadu_pd(b + 18);
    /* lx0 lx1 lz0 lz1, ly0 ly1 hx0 hx1, and the same for boxes 2 and 3 */
    const __m256d t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);
    const __m256d t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
    /* hy0 hz0 hy2 hz2, hy1 hz1 hy3 hz3 */
    const __m256d s0 = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(b + 4)), _mm_loadu_pd(b + 16), 1);
    const __m256d s1 = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(b + 10)), _mm_loadu_pd(b + 22), 1);
    x[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
    x[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
    x[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
    x[3] = _mm256_permute2f128_pd(t1, t3, 0x31);
    x[4] = _mm256_unpacklo_pd(s0, s1);
    x[5] = _mm256_unpackhi_pd(s0, s1);
}
#endif

/* The variants (octree.h): the scalar body and, where the compiler has it,
 * the AVX2 and AVX-512 ones, per precision; LC_LOAD8 loads the six
 * coordinates of eight boxes as doubles, LC_LOAD4 those of four. */
#define LC_T float
#define LC_SUFFIX f32
#define LC_LOAD8(b, x) load8_f32(b, x)
#define LC_LOAD4(b, x) load4_f32(b, x)
#include "encode_impl.h"
#undef LC_LOAD8
#undef LC_LOAD4

#define LC_T double
#define LC_SUFFIX f64
#define LC_LOAD8(b, x) load8_f64(b, x)
#define LC_LOAD4(b, x) load4_f64(b, x)
#include "encode_impl.h"
#undef LC_LOAD8
#undef LC_LOAD4
