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

locd_status lc_depth_check(uint32_t depth, const char *what)
{
    if (depth > LOCD_MAX_DEPTH)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "%s %u exceeds LOCD_MAX_DEPTH (%d)", what, depth, LOCD_MAX_DEPTH);
    return LOCD_OK;
}

locd_status lc_grid_check(const locd_grid *g)
{
    if (!g)
        return lc_error(LOCD_ERR_NULL_POINTER, "grid is NULL");
    if (g->size < LOCD_GRID_MIN_SIZE || g->size > sizeof(locd_grid))
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "grid->size is %u, not %u..%zu (use locd_grid_fit_*)", g->size,
                        LOCD_GRID_MIN_SIZE, sizeof(locd_grid));
    if (lc_depth_check(g->depth, "grid depth"))
        return LOCD_ERR_INVALID_ARGUMENT;
    if (g->index_bits < 1 || g->index_bits > 32 ||
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
    if (lc_depth_check(max_depth, "max_depth"))
        return LOCD_ERR_INVALID_ARGUMENT;
    if ((uint64_t)n > (uint64_t)UINT32_MAX + 1u)
        return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "%zu objects do not fit a 32-bit index", n);
    memset(g, 0, sizeof *g);
    g->size = sizeof *g;
    ibits = n > 1 ? bit_length((uint64_t)(n - 1)) : 1;
    auto_depth = (64u - ibits - LC_LEVEL_BITS) / 3u; /* at most 19 (ibits >= 1): below LOCD_MAX_DEPTH */
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
 * object's own cell, or, in a scene so dense that even the deepest cells
 * hold more, no more than those hold (the mixed scene at 3.5 pairs per box
 * takes 6, not 13, in about 0.8x the time: docs/encoding.md section 3).
 * The sample is fixed (every n/LC_TUNE_SAMPLE-th box),
 * so every path (engine, building blocks, workers, MPI) picks the same. Its
 * arrays take 32 KiB of the calling thread's stack, the radix sort of the
 * sample 48 KiB more (as any lc_radix_sort call). */
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

typedef struct tune_sample {
    const int32_t (*q)[3];
    const uint32_t *lvl;
    size_t s, n;
    uint64_t *code, *tmp;
    double target;
} tune_sample;

static int within_target(const void *ctx, uint64_t d)
{
    const tune_sample *t = (const tune_sample *)ctx;
    return tune_neighbours(t->q, t->lvl, t->s, t->n, (uint32_t)d, t->code, t->tmp) <= t->target;
}

/* The depth for s sampled boxes (quantized corners q, levels lvl) of a
 * scene of n, at most `depth`. The estimate only grows as the depth
 * shrinks: the shallowest depth within the target, which is
 * LC_TUNE_NEIGHBOURS or, when even the deepest cells hold more, what they
 * hold (deeper cells would not be emptier, only cost more key bits and
 * cells). */
static uint32_t tune_depth(const int32_t (*q)[3], const uint32_t *lvl, size_t s, size_t n, uint32_t depth,
                           uint64_t *code, uint64_t *tmp)
{
    tune_sample t;
    t.q = q, t.lvl = lvl, t.s = s, t.n = n, t.code = code, t.tmp = tmp;
    t.target = tune_neighbours(q, lvl, s, n, depth, code, tmp);
    if (t.target < LC_TUNE_NEIGHBOURS)
        t.target = LC_TUNE_NEIGHBOURS;
    return (uint32_t)lc_search_first(1, depth, within_target, &t);
}

#define LC_T float
#define LC_SUFFIX f32
#include "grid_impl.h"
#define LC_T double
#define LC_SUFFIX f64
#include "grid_impl.h"

void lc_grid_tune_sample(locd_grid *g, const double *sample, size_t n)
{
    tune_strided_f64(g, sample, 1, n);
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

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define LC_HAVE_AVX2_BOUNDS 1

/* Four boxes (24 floats, three vectors) per step: float p of a block is
 * coordinate p % 6 of its box in every block, so per-lane running minima
 * and maxima suffice, as in the AVX-512 loop. Each vector is compared with
 * the floats three places on (an unaligned load) in the lanes that hold a
 * low corner: box ends p and p + 3. A block with a bad box goes to the
 * scalar loop, which finds the first bad box exactly. The loads reach 3
 * floats past the block, so the loop stops one box early. */
__attribute__((target("avx2"))) static void bounds_avx2_f32(const float *boxes, size_t begin, size_t end,
                                                            lc_bounds *out)
{
    /* lanes holding a low corner (p % 6 < 3) in each of the three vectors */
    static const int lo_lanes[3] = {0xc7, 0x71, 0x1c};
    __m256 mn[3], mx[3];
    float vmin[24], vmax[24];
    size_t i = begin;
    int v, p;
    for (v = 0; v < 3; v++) {
        mn[v] = _mm256_set1_ps(HUGE_VALF);
        mx[v] = _mm256_set1_ps(-HUGE_VALF);
    }
    for (; i + 5 <= end; i += 4) {
        const float *b = boxes + 6 * i;
        int bad = 0;
        __m256 x[3];
        for (v = 0; v < 3; v++) {
            const __m256 up = _mm256_loadu_ps(b + 8 * v + 3);
            x[v] = _mm256_loadu_ps(b + 8 * v);
            /* x - x is NaN exactly for NaN and infinities */
            bad |= _mm256_movemask_ps(_mm256_cmp_ps(_mm256_sub_ps(x[v], x[v]), _mm256_setzero_ps(), _CMP_NEQ_UQ));
            bad |= _mm256_movemask_ps(_mm256_cmp_ps(x[v], up, _CMP_GT_OQ)) & lo_lanes[v];
        }
        if (LC_UNLIKELY(bad))
            break;
        for (v = 0; v < 3; v++) {
            mn[v] = _mm256_min_ps(mn[v], x[v]);
            mx[v] = _mm256_max_ps(mx[v], x[v]);
        }
    }
    for (v = 0; v < 3; v++) {
        _mm256_storeu_ps(vmin + 8 * v, mn[v]);
        _mm256_storeu_ps(vmax + 8 * v, mx[v]);
    }
    for (p = 0; p < 24; p++) {
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

void lc_bounds_f32(const float *boxes, size_t begin, size_t end, lc_bounds *out, int kernel)
{
#ifdef LC_HAVE_AVX512_KERNEL
    if (kernel == LC_KERNEL_AVX512) {
        bounds_avx512_f32(boxes, begin, end, out);
        return;
    }
#endif
#ifdef LC_HAVE_AVX2_BOUNDS
    if (kernel >= LC_KERNEL_AVX2) {
        bounds_avx2_f32(boxes, begin, end, out);
        return;
    }
#endif
    (void)kernel; /* no vector variant on other CPUs */
    bounds_scalar_f32(boxes, begin, end, out);
}

/* Only the float loop has a vector variant; every kernel runs this one. */
void lc_bounds_f64(const double *boxes, size_t begin, size_t end, lc_bounds *out, int kernel)
{
    (void)kernel;
    bounds_scalar_f64(boxes, begin, end, out);
}
