/* Encode's bodies for one precision: scalar, AVX2 (four objects a step),
 * AVX-512 (eight) and the dispatch between them. Included by encode.c once per precision
 * with LC_T, LC_SUFFIX, LC_LOAD8 and LC_LOAD4 defined (the include-template of
 * octree.h). */

static size_t LC_FN(encode_scalar_)(const locd_grid *g, const LC_T *boxes, size_t first, size_t count, uint64_t *out,
                                    size_t capacity, size_t *needed, uint64_t *qbox)
{
    size_t i, w = 0;
    const uint32_t depth = g->depth, ib = g->index_bits;
    const int32_t bias = g->cell_bias;
    const int cubes = (g->flags & LOCD_CONFIG_CUBES) != 0;
    for (i = first; i < first + count; i++) {
        const LC_T *b = boxes + 6 * i;
        int32_t lo[3], hi[3];
        uint32_t ext, lvl, sh, a, x, y, z;
        uint32_t c0[3], c1[3], e[3];
        uint64_t mx[2], my[2], mz[2], base;
        for (a = 0; a < 3; a++) {
            lo[a] = lc_quantize(g, (int)a, (double)b[a]);
            hi[a] = lc_quantize(g, (int)a, (double)b[a + 3]);
        }
        if (qbox)
            lc_pack_qbox(lo, hi, qbox + 2 * i);
        if (cubes) { /* the paper's bounding cube: same extent on every axis */
            ext = (uint32_t)(hi[0] - lo[0]);
            if ((uint32_t)(hi[1] - lo[1]) > ext)
                ext = (uint32_t)(hi[1] - lo[1]);
            if ((uint32_t)(hi[2] - lo[2]) > ext)
                ext = (uint32_t)(hi[2] - lo[2]);
            for (a = 0; a < 3; a++) {
                int64_t h = (int64_t)lo[a] + ext;
                hi[a] = h > 2147483647 ? 2147483647 : (int32_t)h;
            }
        }
        for (a = 0; a < 3; a++)
            e[a] = (uint32_t)(hi[a] - lo[a]);
        lvl = lc_level_of(e, bias, depth);
        sh = LC_QBITS - lvl;
        for (a = 0; a < 3; a++) {
            c0[a] = (uint32_t)lo[a] >> sh;
            c1[a] = (uint32_t)hi[a] >> sh;
        }
        /* The level's cell edge is above the box's largest extent
           (lc_level_of), so a box spans at most two cells per axis: the
           next-cell codes below are all the cells it needs. */
        assert(c1[0] - c0[0] <= 1 && c1[1] - c0[1] <= 1 && c1[2] - c0[2] <= 1);
        mx[0] = lc_morton_split3(c0[0]);
        mx[1] = lc_morton_next3(mx[0]);
        my[0] = lc_morton_split3(c0[1]) << 1;
        my[1] = lc_morton_next3(my[0] >> 1) << 1;
        mz[0] = lc_morton_split3(c0[2]) << 2;
        mz[1] = lc_morton_next3(mz[0] >> 2) << 2;
        base = (((uint64_t)lvl) << ib) | (uint64_t)i;
        if (w + 8 > capacity) { /* slow path near the end of the buffer */
            size_t need = w + (size_t)(c1[0] - c0[0] + 1) * (c1[1] - c0[1] + 1) * (c1[2] - c0[2] + 1);
            if (need > capacity) {
                size_t rest = need;
                size_t j;
                for (j = i + 1; j < first + count; j++)
                    rest += LOCD_MAX_ENTRIES_PER_BOX;
                *needed = rest;
                return (size_t)-1;
            }
        }
        for (z = 0; z <= c1[2] - c0[2]; z++)
            for (y = 0; y <= c1[1] - c0[1]; y++)
                for (x = 0; x <= c1[0] - c0[0]; x++) {
                    uint64_t m = mx[x] | my[y] | mz[z];
                    uint64_t pm = m << (3u * (depth - lvl));
                    out[w++] = (pm << (LC_LEVEL_BITS + ib)) | base;
                }
    }
    return w;
}

#if defined(LC_HAVE_AVX512_KERNEL) || defined(LC_HAVE_AVX2_ENCODE)
/* The end of a SIMD body: objects [i, end) that did not fill a step, or
 * that met the end of the buffer, go to the scalar body, after the w
 * entries already written. */
static size_t LC_FN(encode_rest_)(const locd_grid *g, const LC_T *boxes, size_t i, size_t end, uint64_t *out,
                                  size_t capacity, size_t *needed, uint64_t *qbox, size_t w)
{
    size_t more;
    if (i >= end)
        return w;
    more = LC_FN(encode_scalar_)(g, boxes, i, end - i, out + w, capacity - w, needed, qbox);
    if (more == (size_t)-1) {
        *needed += w;
        return more;
    }
    return w + more;
}
#endif

#ifdef LC_HAVE_AVX512_KERNEL
/* Eight objects per step, with the same arithmetic as the scalar body (the
 * same IEEE operations in the same order as lc_quantize, so the same
 * integers) and the same entries in the same order: each object's cells in
 * (z, y, x) order, objects ascending. The coordinates are loaded (LC_LOAD8:
 * whole vectors and permutes, no gather) into one vector per axis and end,
 * the sweep boxes packed for qbox,
 * and the up-to-8 cells of the eight objects transposed so that each
 * object's real cells leave in one compress and one store. */
LC_AVX512 static size_t LC_FN(encode_avx512_)(const locd_grid *g, const LC_T *boxes, size_t first, size_t count,
                                              uint64_t *out, size_t capacity, size_t *needed, uint64_t *qbox)
{
    const uint32_t depth = g->depth, ib = g->index_bits;
    const int cubes = (g->flags & LOCD_CONFIG_CUBES) != 0;
    const __m512d half = _mm512_set1_pd(0.5), zero = _mm512_setzero_pd(), qmax = _mm512_set1_pd(LC_QMAX);
    const __m512d sa = _mm512_set1_pd(g->scale_a), sb = _mm512_set1_pd(g->scale_b);
    const __m256i dmax = _mm256_set1_epi32((int)depth);
    const __m512d limit = _mm512_set1_pd(lc_spread_limit(g->cell_bias));
    const __m512i lane8 = _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 6, 7);
    const size_t end = first + count;
    size_t i = first, w = 0;
    for (; i + 8 <= end && w + 64 <= capacity; i += 8) {
        const LC_T *b = boxes + 6 * i;
        __m256i q[6], lv, sh, c0[3], d[3];
        __m512i m0[3], m1[3], code[8], shl, base;
        __m512d x[6];
        uint32_t dd[8];
        int a, k;
        LC_LOAD8(b, x);
        for (a = 0; a < 6; a++) {
            const __m512d o = _mm512_set1_pd(g->origin[a % 3]);
            const __m512d t = _mm512_mul_pd(_mm512_mul_pd(_mm512_sub_pd(_mm512_mul_pd(x[a], half), o), sa), sb);
            q[a] = _mm512_cvttpd_epi32(_mm512_min_pd(_mm512_max_pd(t, zero), qmax));
        }
        if (qbox)
            pack_qbox8(q, qbox + 2 * i);
        if (cubes) { /* the paper's bounding cube: same extent on every axis */
            __m256i ext = _mm256_max_epu32(_mm256_sub_epi32(q[3], q[0]), _mm256_sub_epi32(q[4], q[1]));
            ext = _mm256_max_epu32(ext, _mm256_sub_epi32(q[5], q[2]));
            for (a = 0; a < 3; a++)
                q[a + 3] = _mm256_min_epu32(_mm256_add_epi32(q[a], ext), _mm256_set1_epi32(2147483647));
        }
        lv = level_of8(q, g->cell_bias, depth, limit);
        sh = _mm256_sub_epi32(_mm256_set1_epi32(LC_QBITS), lv);
        for (a = 0; a < 3; a++) { /* d is 0 or 1: the cell edge is above the largest extent (lc_level_of) */
            c0[a] = _mm256_srlv_epi32(q[a], sh);
            d[a] = _mm256_sub_epi32(_mm256_srlv_epi32(q[a + 3], sh), c0[a]);
            m0[a] = _mm512_slli_epi64(spread3x8(c0[a]), a);
            m1[a] = _mm512_slli_epi64(spread3x8(_mm256_add_epi32(c0[a], d[a])), a);
        }
        _mm256_storeu_si256((__m256i *)dd,
                            _mm256_or_si256(d[0], _mm256_or_si256(_mm256_slli_epi32(d[1], 1),
                                                                  _mm256_slli_epi32(d[2], 2))));
        shl = _mm512_cvtepu32_epi64(_mm256_add_epi32(
            _mm256_mullo_epi32(_mm256_sub_epi32(dmax, lv), _mm256_set1_epi32(3)),
            _mm256_set1_epi32((int)(LC_LEVEL_BITS + ib))));
        base = _mm512_or_si512(_mm512_sllv_epi64(_mm512_cvtepu32_epi64(lv), _mm512_set1_epi64(ib)),
                               _mm512_add_epi64(_mm512_set1_epi64((long long)i), lane8));
        for (k = 0; k < 8; k++) {
            const __m512i c = _mm512_or_si512(_mm512_or_si512((k & 1) ? m1[0] : m0[0], (k & 2) ? m1[1] : m0[1]),
                                              (k & 4) ? m1[2] : m0[2]);
            code[k] = _mm512_or_si512(_mm512_sllv_epi64(c, shl), base);
        }
        w = store_cells8(code, dd, out, w);
    }
    return LC_FN(encode_rest_)(g, boxes, i, end, out, capacity, needed, qbox, w);
}
#endif

#ifdef LC_HAVE_AVX2_ENCODE
/* Four objects per step, with the scalar body's arithmetic (the same IEEE
 * operations as lc_quantize, so the same integers; the level from the
 * extents as the scalar lc_level_of) and its entries in its order. The
 * eight candidate cells of the four objects are computed as vectors; each
 * object's real ones leave through store_cells4, with no branch on how many
 * cells an object has. A second cell's Morton bits are the first's plus one
 * on its axis (lc_morton_next3's carry through the other axes' bits, taken
 * where the box has a second cell), not a second spread. */
LC_AVX2_ENCODE static size_t LC_FN(encode_avx2_)(const locd_grid *g, const LC_T *boxes, size_t first, size_t count,
                                                 uint64_t *out, size_t capacity, size_t *needed, uint64_t *qbox)
{
    const uint32_t depth = g->depth, ib = g->index_bits;
    const int32_t bias = g->cell_bias;
    const int cubes = (g->flags & LOCD_CONFIG_CUBES) != 0;
    const __m256d half = _mm256_set1_pd(0.5), zero = _mm256_setzero_pd(), qmax = _mm256_set1_pd(LC_QMAX);
    const __m256d sa = _mm256_set1_pd(g->scale_a), sb = _mm256_set1_pd(g->scale_b);
    const __m256d limit = _mm256_set1_pd(lc_spread_limit(bias));
    const __m256i lane4 = _mm256_setr_epi64x(0, 1, 2, 3);
    const __m256i axis = _mm256_set1_epi64x(0x1249249249249249LL), others = _mm256_set1_epi64x(~0x1249249249249249LL);
    const size_t end = first + count;
    size_t i = first, w = 0;
    for (; i + 4 <= end && w + 32 <= capacity; i += 4) {
        const LC_T *b = boxes + 6 * i;
        __m256d x[6];
        __m128i q[6], sh, lv, c0[3], d[3];
        __m256i m0[3], m1[3], shl, base, code[8];
        uint32_t dd[4];
        int a, k;
        LC_LOAD4(b, x);
        for (a = 0; a < 6; a++) {
            const __m256d o = _mm256_set1_pd(g->origin[a % 3]);
            const __m256d t = _mm256_mul_pd(_mm256_mul_pd(_mm256_sub_pd(_mm256_mul_pd(x[a], half), o), sa), sb);
            q[a] = _mm256_cvttpd_epi32(_mm256_min_pd(_mm256_max_pd(t, zero), qmax));
        }
        if (qbox)
            pack_qbox4(q, qbox + 2 * i);
        if (cubes) { /* the paper's bounding cube: same extent on every axis */
            const __m128i ext = _mm_max_epu32(_mm_max_epu32(_mm_sub_epi32(q[3], q[0]), _mm_sub_epi32(q[4], q[1])),
                                              _mm_sub_epi32(q[5], q[2]));
            for (a = 0; a < 3; a++)
                q[a + 3] = _mm_min_epu32(_mm_add_epi32(q[a], ext), _mm_set1_epi32(2147483647));
        }
        lv = level_of4(q, bias, depth, limit);
        sh = _mm_sub_epi32(_mm_set1_epi32(LC_QBITS), lv);
        for (a = 0; a < 3; a++) { /* d is 0 or 1: the cell edge is above the largest extent (lc_level_of) */
            __m256i sp, next, has;
            c0[a] = _mm_srlv_epi32(q[a], sh);
            d[a] = _mm_sub_epi32(_mm_srlv_epi32(q[a + 3], sh), c0[a]);
            sp = spread3x4(c0[a], depth); /* a cell's coordinates are below 2^level <= 2^depth */
            next = _mm256_and_si256(_mm256_add_epi64(_mm256_or_si256(sp, others), _mm256_set1_epi64x(1)), axis);
            has = _mm256_sub_epi64(_mm256_setzero_si256(), _mm256_cvtepu32_epi64(d[a])); /* all ones where d = 1 */
            m0[a] = _mm256_slli_epi64(sp, a);
            m1[a] = _mm256_slli_epi64(_mm256_blendv_epi8(sp, next, has), a);
        }
        _mm_storeu_si128((__m128i *)dd, _mm_or_si128(d[0], _mm_or_si128(_mm_slli_epi32(d[1], 1), _mm_slli_epi32(d[2], 2))));
        shl = _mm256_cvtepu32_epi64(_mm_add_epi32(_mm_mullo_epi32(_mm_sub_epi32(_mm_set1_epi32((int)depth), lv), _mm_set1_epi32(3)),
                                                  _mm_set1_epi32((int)(LC_LEVEL_BITS + ib))));
        base = _mm256_or_si256(_mm256_sllv_epi64(_mm256_cvtepu32_epi64(lv), _mm256_set1_epi64x(ib)),
                               _mm256_add_epi64(_mm256_set1_epi64x((long long)i), lane4));
        for (a = 0; a < 3; a++) { /* the shift first, six times, not once per cell; base with x */
            m0[a] = _mm256_sllv_epi64(m0[a], shl);
            m1[a] = _mm256_sllv_epi64(m1[a], shl);
        }
        m0[0] = _mm256_or_si256(m0[0], base);
        m1[0] = _mm256_or_si256(m1[0], base);
        for (k = 0; k < 8; k++)
            code[k] = _mm256_or_si256(_mm256_or_si256((k & 1) ? m1[0] : m0[0], (k & 2) ? m1[1] : m0[1]),
                                      (k & 4) ? m1[2] : m0[2]);
        w = store_cells4(code, dd, out, w);
    }
    return LC_FN(encode_rest_)(g, boxes, i, end, out, capacity, needed, qbox, w);
}
#endif

size_t LC_FN(lc_encode_)(const locd_grid *g, const LC_T *boxes, size_t first, size_t count, uint64_t *out,
                         size_t capacity, size_t *needed, uint64_t *qbox, int kernel)
{
#ifdef LC_HAVE_AVX512_KERNEL
    if (kernel == LC_KERNEL_AVX512)
        return LC_FN(encode_avx512_)(g, boxes, first, count, out, capacity, needed, qbox);
#endif
#ifdef LC_HAVE_AVX2_ENCODE
    if (kernel == LC_KERNEL_AVX2)
        return LC_FN(encode_avx2_)(g, boxes, first, count, out, capacity, needed, qbox);
#endif
    (void)kernel;
    return LC_FN(encode_scalar_)(g, boxes, first, count, out, capacity, needed, qbox);
}

#undef LC_T
#undef LC_SUFFIX
