/* Validation of the input boxes and the fitting of the octree's root cube. */
#include "octree/octree.h"

#include <math.h>

void lc_bounds_init(lc_bounds *b)
{
    int a;
    for (a = 0; a < 3; a++) {
        b->lo[a] = HUGE_VAL;
        b->hi[a] = -HUGE_VAL;
    }
    b->bad = -1;
    b->bad_status = LOCD_OK;
}

/* One loop for both precisions; stops at the first bad box of the range. */
#define LC_BOUNDS_BODY(T)                                                                                    \
    size_t i;                                                                                                \
    double lo0 = out->lo[0], lo1 = out->lo[1], lo2 = out->lo[2];                                             \
    double hi0 = out->hi[0], hi1 = out->hi[1], hi2 = out->hi[2];                                             \
    for (i = begin; i < end; i++) {                                                                          \
        const T *b = boxes + 6 * i;                                                                          \
        if (LC_UNLIKELY(!(isfinite(b[0]) && isfinite(b[1]) && isfinite(b[2]) && isfinite(b[3]) &&           \
                          isfinite(b[4]) && isfinite(b[5])))) {                                              \
            out->bad = (int64_t)i;                                                                           \
            out->bad_status = LOCD_ERR_NONFINITE;                                                            \
            break;                                                                                           \
        }                                                                                                    \
        if (LC_UNLIKELY(b[0] > b[3] || b[1] > b[4] || b[2] > b[5])) {                                        \
            out->bad = (int64_t)i;                                                                           \
            out->bad_status = LOCD_ERR_INVERTED_BOX;                                                         \
            break;                                                                                           \
        }                                                                                                    \
        lo0 = b[0] < lo0 ? b[0] : lo0;                                                                       \
        lo1 = b[1] < lo1 ? b[1] : lo1;                                                                       \
        lo2 = b[2] < lo2 ? b[2] : lo2;                                                                       \
        hi0 = b[3] > hi0 ? b[3] : hi0;                                                                       \
        hi1 = b[4] > hi1 ? b[4] : hi1;                                                                       \
        hi2 = b[5] > hi2 ? b[5] : hi2;                                                                       \
    }                                                                                                        \
    out->lo[0] = lo0;                                                                                        \
    out->lo[1] = lo1;                                                                                        \
    out->lo[2] = lo2;                                                                                        \
    out->hi[0] = hi0;                                                                                        \
    out->hi[1] = hi1;                                                                                        \
    out->hi[2] = hi2;

static void bounds_scalar_f32(const float *boxes, size_t begin, size_t end, lc_bounds *out)
{
    LC_BOUNDS_BODY(float)
}

#ifdef LC_HAVE_AVX512_KERNEL
#include <immintrin.h>

/* Eight boxes (48 floats, three vectors) per step. Float p of a block is
 * coordinate p % 6 of its box, the same in every block, so per-lane running
 * minima and maxima suffice; a block with a bad box goes to the scalar loop,
 * which finds the first bad box exactly as before. */
LC_AVX512 static void bounds_avx512_f32(const float *boxes, size_t begin, size_t end, lc_bounds *out)
{
    /* lanes holding a low corner (p % 6 < 3) in each of the three vectors */
    static const __mmask16 lo_lanes[3] = {0x71c7, 0xc71c, 0x1c71};
    const __m512i up3 = _mm512_setr_epi32(3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18);
    __m512 mn[3], mx[3];
    float vmin[48], vmax[48];
    size_t i = begin;
    int v, p;
    for (v = 0; v < 3; v++) {
        mn[v] = _mm512_set1_ps(HUGE_VALF);
        mx[v] = _mm512_set1_ps(-HUGE_VALF);
    }
    for (; i + 8 <= end; i += 8) {
        const float *b = boxes + 6 * i;
        const __m512 x0 = _mm512_loadu_ps(b), x1 = _mm512_loadu_ps(b + 16), x2 = _mm512_loadu_ps(b + 32);
        /* x - x is NaN exactly for NaN and infinities */
        __mmask16 bad = _mm512_cmp_ps_mask(_mm512_sub_ps(x0, x0), _mm512_setzero_ps(), _CMP_NEQ_UQ) |
                        _mm512_cmp_ps_mask(_mm512_sub_ps(x1, x1), _mm512_setzero_ps(), _CMP_NEQ_UQ) |
                        _mm512_cmp_ps_mask(_mm512_sub_ps(x2, x2), _mm512_setzero_ps(), _CMP_NEQ_UQ);
        /* low corner > high corner: float p against float p + 3 */
        bad |= _mm512_mask_cmp_ps_mask(lo_lanes[0], x0, _mm512_permutex2var_ps(x0, up3, x1), _CMP_GT_OQ) |
               _mm512_mask_cmp_ps_mask(lo_lanes[1], x1, _mm512_permutex2var_ps(x1, up3, x2), _CMP_GT_OQ) |
               _mm512_mask_cmp_ps_mask(lo_lanes[2], x2, _mm512_permutexvar_ps(up3, x2), _CMP_GT_OQ);
        if (LC_UNLIKELY(bad))
            break;
        mn[0] = _mm512_min_ps(mn[0], x0);
        mn[1] = _mm512_min_ps(mn[1], x1);
        mn[2] = _mm512_min_ps(mn[2], x2);
        mx[0] = _mm512_max_ps(mx[0], x0);
        mx[1] = _mm512_max_ps(mx[1], x1);
        mx[2] = _mm512_max_ps(mx[2], x2);
    }
    for (v = 0; v < 3; v++) {
        _mm512_storeu_ps(vmin + 16 * v, mn[v]);
        _mm512_storeu_ps(vmax + 16 * v, mx[v]);
    }
    for (p = 0; p < 48; p++) {
        const int a = p % 6;
        if (a < 3 && vmin[p] < out->lo[a])
            out->lo[a] = vmin[p];
        if (a >= 3 && vmax[p] > out->hi[a - 3])
            out->hi[a - 3] = vmax[p];
    }
    if (i < end)
        bounds_scalar_f32(boxes, i, end, out);
}
#endif

void lc_bounds_f32(const float *boxes, size_t begin, size_t end, lc_bounds *out)
{
#ifdef LC_HAVE_AVX512_KERNEL
    if (lc_kernel() == LC_KERNEL_AVX512) {
        bounds_avx512_f32(boxes, begin, end, out);
        return;
    }
#endif
    bounds_scalar_f32(boxes, begin, end, out);
}

void lc_bounds_f64(const double *boxes, size_t begin, size_t end, lc_bounds *out)
{
    LC_BOUNDS_BODY(double)
}

void lc_bounds_merge(lc_bounds *acc, const lc_bounds *b)
{
    int a;
    for (a = 0; a < 3; a++) {
        if (b->lo[a] < acc->lo[a])
            acc->lo[a] = b->lo[a];
        if (b->hi[a] > acc->hi[a])
            acc->hi[a] = b->hi[a];
    }
    if (b->bad >= 0 && (acc->bad < 0 || b->bad < acc->bad)) {
        acc->bad = b->bad;
        acc->bad_status = b->bad_status;
    }
}

static uint32_t bit_length(uint64_t v)
{
    uint32_t n = 0;
    while (v) {
        n++;
        v >>= 1;
    }
    return n;
}

locd_status lc_grid_check(const locd_grid *g)
{
    if (!g)
        return lc_error(LOCD_ERR_NULL_POINTER, "grid is NULL");
    if (g->size < LOCD_GRID_MIN_SIZE || g->size > sizeof(locd_grid))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "grid->size is %u, not %u..%zu (use locd_grid_fit_*)", g->size,
                        LOCD_GRID_MIN_SIZE, sizeof(locd_grid));
    if (g->depth > 21 || g->index_bits < 1 || g->index_bits > 32 ||
        g->index_bits + LC_LEVEL_BITS + 3 * g->depth > 64 || g->cell_bias < 0 || g->cell_bias > 8 ||
        !(g->scale_a > 0.0) || !(g->scale_b >= 0.0))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "grid is not one made by locd_grid_fit_*");
    return LOCD_OK;
}

locd_status lc_grid_from_bounds(const lc_bounds *b, size_t n, uint32_t max_depth, int32_t cell_bias, uint32_t flags,
                                locd_grid *g)
{
    uint32_t ibits, auto_depth, a;
    double half = 0.0, s;
    if (cell_bias < 0 || cell_bias > 8)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "cell_bias %d is outside 0..8", (int)cell_bias);
    if ((uint64_t)n > (uint64_t)UINT32_MAX + 1u)
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "%zu objects do not fit a 32-bit index", n);
    memset(g, 0, sizeof *g);
    g->size = sizeof *g;
    ibits = n > 1 ? bit_length((uint64_t)(n - 1)) : 1;
    auto_depth = (64u - ibits - LC_LEVEL_BITS) / 3u;
    if (auto_depth > 21)
        auto_depth = 21;
    g->depth = (max_depth && max_depth < auto_depth) ? max_depth : auto_depth;
    g->cell_bias = cell_bias;
    g->index_bits = ibits;
    g->flags = flags & LOCD_CONFIG_CUBES;
    for (a = 0; a < 3; a++) {
        double lo = n ? b->lo[a] : 0.0, hi = n ? b->hi[a] : 0.0;
        double h = hi * 0.5 - lo * 0.5; /* halved: never overflows */
        g->origin[a] = lo * 0.5 + 0.0; /* +0.0: the sign of a zero bound depends on box order */
        if (h > half)
            half = h;
    }
    g->scale_a = 1.0;
    g->scale_b = 1.0;
    if (half > 0.0) {
        s = 2147483648.0 / half;
        if (isfinite(s)) {
            g->scale_b = s;
        } else { /* tiny (subnormal) extents: scale in two exact steps */
            g->scale_a = ldexp(1.0, 600);
            g->scale_b = 2147483648.0 / (half * g->scale_a);
        }
    }
    return LOCD_OK;
}

/* The automatic depth. The key leaves room for 13 levels at a million
 * objects, but a small box alone in its own small cell costs more (a cell
 * to open, more key bits to sort) than sharing a coarser cell with a few
 * neighbours, which the slab-ordered sweep handles well: on boxes spread
 * over three orders of magnitude, depth 6 runs in 0.6x the time of depth
 * 13 (docs/accuracy.md). Too coarse, and cells fill up: the candidates
 * grow as the square of their population. So the depth is the shallowest
 * at which a fixed sample of the boxes, each at the level its size picks
 * under that depth, estimates at most LC_TUNE_NEIGHBOURS other boxes in an
 * object's own cell. The sample is fixed (every n/LC_TUNE_SAMPLE-th box),
 * so every path (engine, building blocks, workers, MPI) picks the same. Its
 * arrays take 32 KiB of the calling thread's stack, the radix sort of the
 * sample 48 KiB more (as any lc_radix_sort call). */
#define LC_TUNE_SAMPLE 1024
#define LC_TUNE_MIN_N 16384
#define LC_TUNE_NEIGHBOURS 16.0

/* Estimated boxes sharing an object's cell at depth d. */
static double tune_neighbours(const int32_t (*q)[3], const uint32_t *lvl, size_t s, size_t n, uint32_t d,
                              uint64_t *code, uint64_t *tmp)
{
    const uint64_t *sorted;
    size_t k, run = 1;
    double same = 0.0;
    for (k = 0; k < s; k++) {
        const uint32_t l = lvl[k] < d ? lvl[k] : d, sh = LC_QBITS - l;
        /* level (5 bits) and cell (3 x 19 bits: levels <= 19) */
        code[k] = (uint64_t)l << 59 | (uint64_t)((uint32_t)q[k][0] >> sh) << 38 |
                  (uint64_t)((uint32_t)q[k][1] >> sh) << 19 | (uint64_t)((uint32_t)q[k][2] >> sh);
    }
    sorted = lc_radix_sort(code, tmp, s, 0);
    for (k = 1; k <= s; k++) {
        if (k < s && sorted[k] == sorted[k - 1]) {
            run++;
            continue;
        }
        same += (double)run * (double)(run - 1);
        run = 1;
    }
    /* each sampled box stands for n / s boxes */
    return same / (double)s * ((double)n / (double)s);
}

#define LC_TUNE_DEPTH(SUFFIX, T)                                                                             \
    void lc_grid_tune_depth_##SUFFIX(locd_grid *g, const T *boxes, size_t n)                                 \
    {                                                                                                        \
        int32_t q[LC_TUNE_SAMPLE][3];                                                                        \
        uint32_t lvl[LC_TUNE_SAMPLE], lo = 1, hi = g->depth;                                                 \
        uint64_t code[LC_TUNE_SAMPLE], tmp[LC_TUNE_SAMPLE];                                                  \
        const size_t s = LC_TUNE_SAMPLE, stride = n / LC_TUNE_SAMPLE;                                        \
        size_t k;                                                                                            \
        if (n < LC_TUNE_MIN_N)                                                                               \
            return;                                                                                          \
        for (k = 0; k < s; k++) {                                                                            \
            const T *b = boxes + 6 * (k * stride);                                                           \
            uint32_t ext = 0;                                                                                \
            int a;                                                                                           \
            for (a = 0; a < 3; a++) {                                                                        \
                const int32_t l = lc_quantize(g, a, (double)b[a]), h = lc_quantize(g, a, (double)b[a + 3]);  \
                q[k][a] = l;                                                                                 \
                if ((uint32_t)(h - l) > ext)                                                                 \
                    ext = (uint32_t)(h - l);                                                                 \
            }                                                                                                \
            lvl[k] = lc_level_for(ext, g->cell_bias, g->depth);                                              \
        }                                                                                                    \
        /* the estimate only grows as the depth shrinks: bisect */                                           \
        while (lo < hi) {                                                                                    \
            const uint32_t mid = lo + (hi - lo) / 2;                                                         \
            if (tune_neighbours((const int32_t(*)[3])q, lvl, s, n, mid, code, tmp) <= LC_TUNE_NEIGHBOURS)    \
                hi = mid;                                                                                    \
            else                                                                                             \
                lo = mid + 1;                                                                                \
        }                                                                                                    \
        g->depth = lo;                                                                                       \
    }

LC_TUNE_DEPTH(f32, float)
LC_TUNE_DEPTH(f64, double)
