/* The paper's four steps as public building blocks (locd.h: grid fit,
 * encode, sort, merge, sweep): argument checks around the internal steps,
 * which stay free of the public contract's concerns. The public functions
 * have no engine to hold a kernel choice, so they choose per call. */
#include "octree/octree.h"

/* Writes a fitted grid into the caller's, bounded by its size as locd.h
 * states for locd_grid_fit_*: the grid is output only, so its size may be
 * unset, and every caller's grid has at least LOCD_GRID_MIN_SIZE bytes. */
static void grid_out(locd_grid *dst, const locd_grid *g)
{
    uint32_t size = dst->size;
    if (size < LOCD_GRID_MIN_SIZE)
        size = LOCD_GRID_MIN_SIZE;
    if (size > sizeof *g)
        size = sizeof *g;
    memcpy(dst, g, size);
    dst->size = size;
}

/* The sweep's figures into the caller's stats, no further than its size
 * (its other fields keep their values). */
static void sweep_stats_out(locd_stats *stats, size_t n, size_t count, const lc_sweep_out *o)
{
    locd_stats s;
    memset(&s, 0, sizeof s);
    memcpy(&s, stats, stats->size);
    s.objects = n;
    s.entries = count;
    s.candidates = o->candidates;
    s.exact_tests = o->exact_tests;
    s.pairs = o->count;
    lc_struct_out(stats, &s);
}

static int entries_sorted(const uint64_t *e, size_t count)
{
    size_t i;
    for (i = 1; i < count; i++)
        if (e[i - 1] >= e[i])
            return 0;
    return 1;
}

#define LC_T float
#define LC_SUFFIX f32
#include "blocks_impl.h"
#define LC_T double
#define LC_SUFFIX f64
#include "blocks_impl.h"

locd_status locd_grid_fit_f32(const float *boxes, size_t n, uint32_t max_depth, int32_t cell_bias, uint32_t flags,
                              locd_grid *grid)
{
    return lc_block_grid_fit_f32(boxes, n, max_depth, cell_bias, flags, grid, lc_kernel_choose());
}

locd_status locd_grid_fit_f64(const double *boxes, size_t n, uint32_t max_depth, int32_t cell_bias, uint32_t flags,
                              locd_grid *grid)
{
    return lc_block_grid_fit_f64(boxes, n, max_depth, cell_bias, flags, grid, lc_kernel_choose());
}

locd_status locd_encode_f32(const locd_grid *grid, const float *boxes, size_t first, size_t count, uint64_t *entries,
                            size_t capacity, size_t *written)
{
    return lc_block_encode_f32(grid, boxes, first, count, entries, capacity, written, lc_kernel_choose());
}

locd_status locd_encode_f64(const locd_grid *grid, const double *boxes, size_t first, size_t count,
                            uint64_t *entries, size_t capacity, size_t *written)
{
    return lc_block_encode_f64(grid, boxes, first, count, entries, capacity, written, lc_kernel_choose());
}

locd_status locd_sort_entries(const locd_grid *grid, uint64_t *entries, uint64_t *scratch, size_t count)
{
    locd_status st = lc_grid_check(grid);
    uint64_t *r;
    if (st)
        return st;
    if (count && (!entries || !scratch))
        return lc_error(LOCD_ERR_NULL_POINTER, "entries and scratch must not be NULL");
    if (count > UINT32_MAX)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "sort at most 2^32-1 entries per call");
    r = lc_radix_sort(entries, scratch, count, grid->index_bits);
    if (r != entries)
        memcpy(entries, r, count * sizeof *entries);
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_merge_entries(const uint64_t *const *runs, const size_t *counts, size_t k, uint64_t *out)
{
    size_t r, begin[LC_MAX_THREADS];
    if (k == 0) {
        lc_clear_error();
        return LOCD_OK;
    }
    if (!runs || !counts || !out)
        return lc_error(LOCD_ERR_NULL_POINTER, "runs, counts and out must not be NULL");
    if (k > LC_MAX_THREADS)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "at most %d runs per merge (got %zu)", LC_MAX_THREADS, k);
    for (r = 0; r < k; r++) {
        if (counts[r] && !runs[r])
            return lc_error(LOCD_ERR_NULL_POINTER, "run %zu is NULL", r);
        begin[r] = 0;
    }
    lc_merge_ranges(runs, begin, counts, k, out);
    lc_clear_error();
    return LOCD_OK;
}

locd_status locd_sweep_f32(const locd_grid *grid, const float *boxes, size_t n, const uint64_t *entries, size_t count,
                           locd_pairs *out, locd_stats *stats)
{
    return lc_block_sweep_f32(grid, boxes, n, entries, count, 0, out, stats, lc_kernel_choose());
}

locd_status locd_sweep_f64(const locd_grid *grid, const double *boxes, size_t n, const uint64_t *entries,
                           size_t count, locd_pairs *out, locd_stats *stats)
{
    return lc_block_sweep_f64(grid, boxes, n, entries, count, 0, out, stats, lc_kernel_choose());
}
