/* The paper's four steps as public building blocks (locd.h: grid fit,
 * encode, sort, merge, sweep): argument checks around the internal steps,
 * which stay free of the public contract's concerns. */
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

#define LC_GRID_FIT(SUFFIX, T)                                                                               \
    locd_status locd_grid_fit_##SUFFIX(const T *boxes, size_t n, uint32_t max_depth, int32_t cell_bias,     \
                                       uint32_t flags, locd_grid *grid)                                      \
    {                                                                                                        \
        lc_bounds b;                                                                                         \
        locd_grid g;                                                                                         \
        locd_status st;                                                                                      \
        if (!grid || (!boxes && n))                                                                          \
            return lc_error(LOCD_ERR_NULL_POINTER, "%s is NULL", grid ? "boxes" : "grid");                  \
        if ((uint64_t)n > (uint64_t)UINT32_MAX + 1u)                                                         \
            return lc_error(LOCD_ERR_TOO_MANY_OBJECTS, "%zu objects do not fit a 32-bit index", n);         \
        lc_bounds_init(&b);                                                                                  \
        lc_bounds_##SUFFIX(boxes, 0, n, &b);                                                                 \
        if (b.bad >= 0)                                                                                      \
            return lc_error_box(b.bad_status, b.bad, "box %lld", (long long)b.bad);                          \
        st = lc_grid_from_bounds(&b, n, max_depth, cell_bias, flags, &g);                                    \
        if (!st && !max_depth)                                                                               \
            lc_grid_tune_depth_##SUFFIX(&g, boxes, n);                                                       \
        if (!st) {                                                                                           \
            grid_out(grid, &g);                                                                              \
            lc_clear_error();                                                                                \
        }                                                                                                    \
        return st;                                                                                           \
    }

LC_GRID_FIT(f32, float)
LC_GRID_FIT(f64, double)

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
    size_t r, begin[64];
    if (k == 0) {
        lc_clear_error();
        return LOCD_OK;
    }
    if (!runs || !counts || !out)
        return lc_error(LOCD_ERR_NULL_POINTER, "runs, counts and out must not be NULL");
    if (k > 64)
        return lc_error(LOCD_ERR_INVALID_ARGUMENT, "at most 64 runs per merge (got %zu)", k);
    for (r = 0; r < k; r++) {
        if (counts[r] && !runs[r])
            return lc_error(LOCD_ERR_NULL_POINTER, "run %zu is NULL", r);
        begin[r] = 0;
    }
    lc_merge_ranges(runs, begin, counts, k, out);
    lc_clear_error();
    return LOCD_OK;
}

static int entries_sorted(const uint64_t *e, size_t count)
{
    size_t i;
    for (i = 1; i < count; i++)
        if (e[i - 1] >= e[i])
            return 0;
    return 1;
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

#define LC_SWEEP_PUBLIC(SUFFIX, T)                                                                           \
    locd_status locd_sweep_##SUFFIX(const locd_grid *grid, const T *boxes, size_t n, const uint64_t *entries, \
                                    size_t count, locd_pairs *out, locd_stats *stats)                        \
    {                                                                                                        \
        lc_sweep_out o;                                                                                      \
        locd_status st = lc_grid_check(grid);                                                                \
        size_t i;                                                                                            \
        if (st)                                                                                              \
            return st;                                                                                       \
        if ((st = lc_pairs_check(out)) != LOCD_OK)                                                           \
            return st;                                                                                       \
        if (count && (!entries || !boxes))                                                                   \
            return lc_error(LOCD_ERR_NULL_POINTER, "entries and boxes must not be NULL");                   \
        if (stats && (st = lc_struct_check_out(stats, sizeof *stats, LOCD_STATS_MIN_SIZE, "stats")) != LOCD_OK) \
            return st;                                                                                       \
        if (!entries_sorted(entries, count))                                                                 \
            return lc_error(LOCD_ERR_INVALID_ARGUMENT, "entries are not strictly ascending");               \
        for (i = 0; i < count; i++)                                                                          \
            if ((entries[i] & ((1ull << grid->index_bits) - 1)) >= n)                                        \
                return lc_error(LOCD_ERR_INVALID_ARGUMENT, "entry %zu names object >= n", i);               \
        lc_sweep_out_init(&o, &out->alloc);                                                                  \
        st = lc_sweep_range_##SUFFIX(grid, boxes, NULL, entries, count, 0, count, &o);                              \
        if (!st)                                                                                             \
            st = lc_pairs_reserve(out, o.count);                                                             \
        if (!st) {                                                                                           \
            if (o.count)                                                                                     \
                memcpy(out->data, o.pairs.data, o.count * 2 * sizeof(uint32_t));                             \
            out->count = o.count;                                                                            \
            if (stats)                                                                                       \
                sweep_stats_out(stats, n, count, &o);                                                        \
            lc_clear_error();                                                                                \
        }                                                                                                    \
        lc_sweep_out_fini(&o);                                                                               \
        return st;                                                                                           \
    }

LC_SWEEP_PUBLIC(f32, float)
LC_SWEEP_PUBLIC(f64, double)
