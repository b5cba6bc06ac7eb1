/* The grid's per-precision bodies: the scalar bounds loop and the automatic
 * depth. Included by grid.c once per precision with LC_T and LC_SUFFIX
 * defined (the include-template of octree.h). */

/* Grows out to hold boxes [begin, end); stops at the first bad box. */
static void LC_FN(bounds_scalar_)(const LC_T *boxes, size_t begin, size_t end, lc_bounds *out)
{
    size_t i;
    double lo0 = out->lo[0], lo1 = out->lo[1], lo2 = out->lo[2];
    double hi0 = out->hi[0], hi1 = out->hi[1], hi2 = out->hi[2];
    for (i = begin; i < end; i++) {
        const LC_T *b = boxes + 6 * i;
        if (LC_UNLIKELY(!(isfinite(b[0]) && isfinite(b[1]) && isfinite(b[2]) && isfinite(b[3]) &&
                          isfinite(b[4]) && isfinite(b[5])))) {
            out->bad = (int64_t)i;
            out->bad_status = LOCD_ERR_NONFINITE;
            break;
        }
        if (LC_UNLIKELY(b[0] > b[3] || b[1] > b[4] || b[2] > b[5])) {
            out->bad = (int64_t)i;
            out->bad_status = LOCD_ERR_INVERTED_BOX;
            break;
        }
        lo0 = b[0] < lo0 ? b[0] : lo0;
        lo1 = b[1] < lo1 ? b[1] : lo1;
        lo2 = b[2] < lo2 ? b[2] : lo2;
        hi0 = b[3] > hi0 ? b[3] : hi0;
        hi1 = b[4] > hi1 ? b[4] : hi1;
        hi2 = b[5] > hi2 ? b[5] : hi2;
    }
    out->lo[0] = lo0;
    out->lo[1] = lo1;
    out->lo[2] = lo2;
    out->hi[0] = hi0;
    out->hi[1] = hi1;
    out->hi[2] = hi2;
}

/* The depth from the sample boxes k * stride, k < LC_TUNE_SAMPLE, of a
 * scene of n boxes (stride n / LC_TUNE_SAMPLE for the whole scene, 1 for a
 * sample gathered beforehand: lc_grid_tune_sample). */
static void LC_FN(tune_strided_)(locd_grid *g, const LC_T *boxes, size_t stride, size_t n)
{
    int32_t q[LC_TUNE_SAMPLE][3];
    uint32_t lvl[LC_TUNE_SAMPLE];
    uint64_t code[LC_TUNE_SAMPLE], tmp[LC_TUNE_SAMPLE];
    const size_t s = LC_TUNE_SAMPLE;
    size_t k;
    if (n < LC_TUNE_MIN_N)
        return;
    for (k = 0; k < s; k++) {
        const LC_T *b = boxes + 6 * (k * stride);
        uint32_t e[3];
        int a;
        for (a = 0; a < 3; a++) {
            const int32_t l = lc_quantize(g, a, (double)b[a]), h = lc_quantize(g, a, (double)b[a + 3]);
            q[k][a] = l;
            e[a] = (uint32_t)(h - l);
        }
        if (g->flags & LOCD_CONFIG_CUBES) /* encode's bounding cube */
            e[0] = e[1] = e[2] = lc_max3(e);
        lvl[k] = lc_level_of(e, g->cell_bias, g->depth);
    }
    g->depth = tune_depth((const int32_t(*)[3])q, lvl, s, n, g->depth, code, tmp);
}

void LC_FN(lc_grid_tune_depth_)(locd_grid *g, const LC_T *boxes, size_t n)
{
    LC_FN(tune_strided_)(g, boxes, n / LC_TUNE_SAMPLE, n);
}

#undef LC_T
#undef LC_SUFFIX
