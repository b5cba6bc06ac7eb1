/* lib/octree: the paper's four steps (bounds and grid, encode, sort,
 * merge, sweep) and the O(n^2) reference. Private; not installed.
 *
 * How variants are written: one style for every precision (float, double)
 * and SIMD kernel variant in this folder, the include-template. A body that
 * exists in several variants lives once in a NAME_impl.h file, written as
 * ordinary C with LC_T for the box coordinate type and LC_FN(name) for each
 * function name, and the .c file includes it once per variant after
 * defining LC_T and LC_SUFFIX (f32 or f64, and a kernel name where there is
 * more than one; the template #undefs both at its end). Where a SIMD
 * kernel runs the same body (the sweep's main loop), the body is included
 * once more with LC_TARGET (the target attribute) and one-line macros for
 * what differs (the scan, the quantization); a SIMD body that is different
 * code (encode's, the float bounds') is an ordinary function with the
 * LC_AVX512 attribute beside the scalar one (in the template when it
 * exists per precision; a one-line LC_GATHER macro loads the coordinates).
 * So every variant is real code a debugger steps through and a formatter
 * formats; no function body sits in a backslash-continued macro. The
 * choice between kernels is an `int kernel` argument (LC_KERNEL_*, chosen
 * once by lc_kernel_choose) that a small dispatch function tests; public
 * locd_* functions are written out by name as one-line wrappers, so they
 * can be found with grep. */
#ifndef LOCD_OCTREE_H
#define LOCD_OCTREE_H

#include "core/core.h"

/* The name of a template function for the variant being included. */
#define LC_CAT2(a, b) a##b
#define LC_CAT(a, b) LC_CAT2(a, b)
#define LC_FN(name) LC_CAT(name, LC_SUFFIX)

/* ---- grid (grid.c) ---- */
typedef struct lc_bounds {
    double lo[3], hi[3];
    int64_t bad;       /* first bad box index, or -1 */
    locd_status bad_status;
} lc_bounds;
/* LC_SHARED here and below: the helpers liblocd_mpi (lib/mpi/) calls to fit
 * one grid over boxes spread across ranks and to sweep a key range
 * (docs/cluster.md); private node of lib/locd.map.in, no part of the ABI. */
LC_SHARED void lc_bounds_init(lc_bounds *b);
/* Grows out to hold boxes [begin, end), stopping at the first bad one;
 * kernel is an LC_KERNEL_* value (lc_kernel_choose). */
LC_SHARED void lc_bounds_f32(const float *boxes, size_t begin, size_t end, lc_bounds *out, int kernel);
LC_SHARED void lc_bounds_f64(const double *boxes, size_t begin, size_t end, lc_bounds *out, int kernel);
/* Combines b into acc (a later chunk's bad index never hides an earlier one). */
void lc_bounds_merge(lc_bounds *acc, const lc_bounds *b);
LC_SHARED locd_status lc_grid_from_bounds(const lc_bounds *b, size_t n, uint32_t max_depth, int32_t cell_bias,
                                          uint32_t flags, locd_grid *grid);
/* The one check of the depth limit, for a config's max_depth, a fit's and
 * a grid's depth (`what` names it in the error). */
locd_status lc_depth_check(uint32_t depth, const char *what);
locd_status lc_grid_check(const locd_grid *g);
/* The automatic depth (max_depth 0): may lower g->depth (see grid.c). */
void lc_grid_tune_depth_f32(locd_grid *g, const float *boxes, size_t n);
void lc_grid_tune_depth_f64(locd_grid *g, const double *boxes, size_t n);
/* The automatic depth reads LC_TUNE_SAMPLE boxes, box k * (n / LC_TUNE_SAMPLE)
 * for k < LC_TUNE_SAMPLE, of scenes of at least LC_TUNE_MIN_N boxes. */
#define LC_TUNE_SAMPLE 1024
#define LC_TUNE_MIN_N 16384
/* The same depth from those sample boxes gathered beforehand (6 doubles a
 * box, in k order; a float scene's values converted exactly), for a scene
 * whose boxes no one process holds (liblocd_mpi). n is the whole scene's. */
LC_SHARED void lc_grid_tune_sample(locd_grid *g, const double *sample, size_t n);

/* Quantization: a monotone map from coordinates to [0, 2^31). Monotone is all
 * exactness needs: a <= b implies q(a) <= q(b), so overlapping boxes always
 * get overlapping integer ranges (docs/encoding.md). */
#define LC_QBITS 31
#define LC_QMAX 2147483647.0
LC_INLINE int32_t lc_quantize(const locd_grid *g, int axis, double x)
{
    double t = ((x * 0.5 - g->origin[axis]) * g->scale_a) * g->scale_b;
    t = t > 0.0 ? t : 0.0; /* written so that compilers emit maxsd/minsd, not branches */
    t = t < LC_QMAX ? t : LC_QMAX;
    return (int32_t)t;
}

/* The sweep's coordinates: the quantized ones without their low LC_SDROP
 * bits (21 bits a coordinate). Still monotone, and a cell of any level up
 * to LC_SBITS = LOCD_MAX_DEPTH (lc_depth_check) has the same integer
 * coordinates at 21 bits as at 31, so the entries, the cells and the
 * canonical test are unchanged (docs/encoding.md); ends that become equal
 * go to the exact test. A box then packs into 16 bytes, three 21-bit fields
 * per corner, which never straddle a cache line. */
#define LC_SBITS 21
#define LC_SDROP (LC_QBITS - LC_SBITS)
#define LC_SMASK ((1ull << LC_SBITS) - 1)
/* The depth limit rests on the sweep's bits: a compile error if not. */
typedef char lc_sweep_bits_cover_max_depth[LC_SBITS >= LOCD_MAX_DEPTH ? 1 : -1];
LC_INLINE void lc_pack_qbox(const int32_t lo[3], const int32_t hi[3], uint64_t *w)
{
    w[0] = (uint64_t)(lo[0] >> LC_SDROP) | (uint64_t)(lo[1] >> LC_SDROP) << LC_SBITS |
           (uint64_t)(lo[2] >> LC_SDROP) << (2 * LC_SBITS);
    w[1] = (uint64_t)(hi[0] >> LC_SDROP) | (uint64_t)(hi[1] >> LC_SDROP) << LC_SBITS |
           (uint64_t)(hi[2] >> LC_SDROP) << (2 * LC_SBITS);
}

/* The deepest level, at most `depth`, whose cell edge is at least 2^bias
 * times w (and a power of two above it: 2^(bias + bitlength(w))). */
LC_INLINE uint32_t lc_level_for(uint32_t w, int32_t bias, uint32_t depth)
{
    int32_t l = (int32_t)LC_QBITS - bias - (int32_t)(w ? 32u - (uint32_t)__builtin_clz(w) : 0u);
    if (l < 0)
        l = 0;
    return (uint32_t)l > depth ? depth : (uint32_t)l;
}

/* 2^k as a double, for -1022 <= k <= 1023, without a call. */
LC_INLINE double lc_pow2(int k)
{
    const uint64_t bits = (uint64_t)(k + 1023) << 52;
    double d;
    memcpy(&d, &bits, sizeof d);
    return d;
}

/* (1 + 2^-bias)^3: the cells a box whose extents are all 2^-bias of its
 * cell's edge spans, on average over its place in the grid. */
LC_INLINE double lc_spread_limit(int32_t bias)
{
    const double f = 1.0 + lc_pow2(-bias);
    return f * f * f;
}

/* The largest of three extents. */
LC_INLINE uint32_t lc_max3(const uint32_t e[3])
{
    const uint32_t w = e[0] > e[1] ? e[0] : e[1];
    return w > e[2] ? w : e[2];
}

/* The level of a box whose quantized extents are e[0..2] (docs/encoding.md):
 * from the level of its largest extent w (lc_level_for), as many levels
 * deeper as keep the cells it spans on average, (1 + e0/c)(1 + e1/c)(1 +
 * e2/c) for cell edge c, within lc_spread_limit(bias), and c above w (at
 * most two cells per axis). A cube stays where w alone puts it; a flat or
 * thin box (a triangle's) goes up to `bias` levels deeper, where smaller
 * cells meet fewer boxes for a few more entries. The SIMD encodes compute
 * the same product with the same operations in the same order (no FMA:
 * meson.build), so every kernel gives every box the same level. */
LC_INLINE uint32_t lc_level_of(const uint32_t e[3], int32_t bias, uint32_t depth)
{
    const uint32_t w = lc_max3(e);
    uint32_t l = lc_level_for(w, bias, depth);
    uint64_t next;
    if (l >= depth)
        return l;
    /* A box none of whose extents is within 2^-bias of the next level's
       cell edge spans more there than the limit, in doubles too (each
       factor exceeds 1 + 2^-bias by 2^-38 or more, far above their
       rounding): the common cube stops here, in integers. */
    next = (1ull << (LC_QBITS - 1 - l)) >> bias;
    if (e[0] > next && e[1] > next && e[2] > next)
        return l;
    {
        const uint32_t top = lc_level_for(w, 0, depth);
        const double limit = lc_spread_limit(bias);
        for (; l < top; l++) {
            const double s = lc_pow2((int)l + 1 - (int)LC_QBITS); /* 1 / the cell edge one level deeper */
            if ((1.0 + (double)e[0] * s) * (1.0 + (double)e[1] * s) * (1.0 + (double)e[2] * s) > limit)
                break;
        }
    }
    return l;
}

/* ---- encode / merge (encode.c, merge.c); the radix sort is core's lc_radix_sort ---- */
/* Bits of the octree key: (padded morton << 5) | level. */
#define LC_LEVEL_BITS 5
/* Encodes boxes [first, first+count); returns entries written or, when
 * capacity is too small, (size_t)-1 with *needed set. */
/* qbox, when not NULL, receives each object's packed sweep box (lc_pack_qbox)
 * at 2 * index. */
size_t lc_encode_f32(const locd_grid *g, const float *boxes, size_t first, size_t count, uint64_t *out,
                     size_t capacity, size_t *needed, uint64_t *qbox, int kernel);
size_t lc_encode_f64(const locd_grid *g, const double *boxes, size_t first, size_t count, uint64_t *out,
                     size_t capacity, size_t *needed, uint64_t *qbox, int kernel);
/* Multiway merge of runs restricted to [begin[r], end[r]) into out. */
void lc_merge_ranges(const uint64_t *const *runs, const size_t *begin, const size_t *end, size_t k, uint64_t *out);
/* Splits k runs so that exactly `rank` elements lie before the split; pos[r] receives the split in run r. */
void lc_merge_split(const uint64_t *const *runs, const size_t *counts, size_t k, size_t rank, size_t *pos);

/* ---- the sort of k threads' entries (sort.c) ---- */
/* k runs whose concatenation is in order of the low index_bits within
 * equal high bits (as lc_radix_sort's input): thread t's run of objects
 * below thread t+1's, each run in object order. The runs' memory is
 * scratch once they are read. */
typedef struct lc_psort_in {
    uint32_t k; /* runs; the pool runs k tasks (k <= its size) */
    uint32_t index_bits;
    uint32_t key_bits; /* the bits above index_bits that can vary, or 0: unknown */
    uint64_t *run[LC_MAX_THREADS];
    size_t count[LC_MAX_THREADS];
} lc_psort_in;
/* Sorts the runs into out (all their entries; it must not overlap a run)
 * on the pool, the same result as lc_radix_sort of the concatenation.
 * scratch holds as many entries and may be the runs' own memory. Fails
 * only on the allocation of the counts (changing nothing the caller
 * reads). */
locd_status lc_psort(lc_pool *pool, const locd_allocator *alloc, const lc_psort_in *in, uint64_t *out,
                     uint64_t *scratch);

/* ---- sweep (sweep.c) ---- */
typedef struct lc_sweep_out {
    const locd_allocator *alloc;
    lc_buf pairs; /* uint32, two per pair */
    int pairs_lent; /* pairs.data is the caller's memory (see lc_sweep_out_lend) */
    size_t count; /* pairs */
    int32_t *cand;   /* candidate records, 7 columns of cand_cap: lo xyz, hi xyz, index */
    size_t cand_cap;
    int kernel;           /* LC_KERNEL_*, fixed at init */
    void (*filter)(void); /* the segment filter for that kernel (sweep.c casts it back) */
    lc_buf group;         /* uint64 per entry of the largest slab-ordered cell so far: slab and object */
    uint64_t candidates;
    uint64_t exact_tests;
    /* Two-set query (locd_engine_find_pairs_between_*): 0 for one set;
       otherwise objects below `split` form set a, the others set b, and a
       candidate of the same set is dropped before any test, so only pairs
       with one object of each are reported (as (a's index, b's index +
       split)). Set between sweeps by the level that runs them. */
    uint32_t split;
    /* NULL, or a flag another thread may raise to stop the sweep: it is
       read every LC_SWEEP_POLL rows of a dense cell and every
       LC_SWEEP_POLL cells, and a raised flag makes the sweep return
       LOCD_ERR_CANCELLED (its pairs are then incomplete). Set between
       sweeps by the level that runs them. */
    const int *stop;
} lc_sweep_out;
#define LC_SWEEP_POLL 64u
/* kernel: the LC_KERNEL_* every sweep into o uses (lc_kernel_choose). */
void lc_sweep_out_init(lc_sweep_out *o, const locd_allocator *a, int kernel);
void lc_sweep_out_fini(lc_sweep_out *o);
/* Has the next sweeps write their pairs to `values` (cap uint32, two per
 * pair) until it is full, then to a buffer of their own, releasing o's own
 * buffer unless that is the larger one (kept: a scene with many pairs runs
 * again without growing it). NULL ends the loan. The memory stays the
 * caller's. */
void lc_sweep_out_lend(lc_sweep_out *o, uint32_t *values, size_t cap);
/* Sweeps entries [begin, end) of the sorted array of `count` entries,
 * appending pairs to o. Both ends move forward to the next start of a cell,
 * so slices [b0, b1), [b1, b2), ... still cover every cell once; entries
 * before `begin` rebuild the state a serial sweep would hold there. qbox,
 * when not NULL, holds each object's packed sweep box as encode computed
 * it; otherwise the sweep quantizes again (bit-identically). */
locd_status lc_sweep_range_f32(const locd_grid *g, const float *boxes, const uint64_t *qbox, const uint64_t *entries,
                               size_t count, size_t begin, size_t end, lc_sweep_out *o);
locd_status lc_sweep_range_f64(const locd_grid *g, const double *boxes, const uint64_t *qbox, const uint64_t *entries,
                               size_t count, size_t begin, size_t end, lc_sweep_out *o);

/* ---- the building blocks with a kernel chosen by the caller (blocks.c) ---- */
/* locd_grid_fit_*, locd_encode_* and locd_sweep_* (locd.h) with their
 * checks, for code that holds a kernel choice (level 2's host side and its
 * worker processes). */
locd_status lc_block_grid_fit_f32(const float *boxes, size_t n, uint32_t max_depth, int32_t cell_bias, uint32_t flags,
                                  locd_grid *grid, int kernel);
locd_status lc_block_grid_fit_f64(const double *boxes, size_t n, uint32_t max_depth, int32_t cell_bias,
                                  uint32_t flags, locd_grid *grid, int kernel);
locd_status lc_block_encode_f32(const locd_grid *grid, const float *boxes, size_t first, size_t count,
                                uint64_t *entries, size_t capacity, size_t *written, int kernel);
locd_status lc_block_encode_f64(const locd_grid *grid, const double *boxes, size_t first, size_t count,
                                uint64_t *entries, size_t capacity, size_t *written, int kernel);
/* split: 0, or the two-set query's first object of set b (lc_sweep_out.split);
 * the pairs then come out as (i, j - split). */
locd_status lc_block_sweep_f32(const locd_grid *grid, const float *boxes, size_t n, const uint64_t *entries,
                               size_t count, size_t split, locd_pairs *out, locd_stats *stats, int kernel);
locd_status lc_block_sweep_f64(const locd_grid *grid, const double *boxes, size_t n, const uint64_t *entries,
                               size_t count, size_t split, locd_pairs *out, locd_stats *stats, int kernel);
/* The same on entries [begin, end) only: the entries before begin are the
 * context a serial sweep would hold there (its populated ancestor cells),
 * and both ends move forward to a cell start (lc_sweep_range_*). Sweeps of
 * [0, b1), [b1, b2), ... [bk, count) report exactly the whole sweep's pairs,
 * in its order. */
LC_SHARED locd_status lc_block_sweep_range_f32(const locd_grid *grid, const float *boxes, size_t n,
                                               const uint64_t *entries, size_t count, size_t begin, size_t end,
                                               size_t split, locd_pairs *out, locd_stats *stats, int kernel);
LC_SHARED locd_status lc_block_sweep_range_f64(const locd_grid *grid, const double *boxes, size_t n,
                                               const uint64_t *entries, size_t count, size_t begin, size_t end,
                                               size_t split, locd_pairs *out, locd_stats *stats, int kernel);

/* ---- 3-D Morton (Z-order) interleaving of 21-bit coordinates ---- */
static __inline__ uint64_t lc_morton_split3(uint32_t a)
{
    uint64_t x = a & 0x1fffffu;
    x = (x | x << 32) & 0x1f00000000ffffULL;
    x = (x | x << 16) & 0x1f0000ff0000ffULL;
    x = (x | x << 8) & 0x100f00f00f00f00fULL;
    x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
    x = (x | x << 2) & 0x1249249249249249ULL;
    return x;
}

/* split3(c + 1) from split3(c), without undoing the interleave. */
static __inline__ uint64_t lc_morton_next3(uint64_t dilated)
{
    return ((dilated | ~0x1249249249249249ULL) + 1) & 0x1249249249249249ULL;
}

static __inline__ uint32_t lc_morton_compact3(uint64_t x)
{
    x &= 0x1249249249249249ULL;
    x = (x ^ (x >> 2)) & 0x10c30c30c30c30c3ULL;
    x = (x ^ (x >> 4)) & 0x100f00f00f00f00fULL;
    x = (x ^ (x >> 8)) & 0x1f0000ff0000ffULL;
    x = (x ^ (x >> 16)) & 0x1f00000000ffffULL;
    x = (x ^ (x >> 32)) & 0x1fffffULL;
    return (uint32_t)x;
}

#endif
