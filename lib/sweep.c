/* Step 4: one pass over the sorted entries finds every overlapping pair.
 *
 * The pass keeps a stack of segments, one per populated cell on the current
 * root-to-leaf path. A cell's segment holds the records of the ancestor
 * entries whose quantized box overlaps the cell, then the cell's own entries:
 * exactly the objects a new entry of that cell must be tested against. A
 * pair is reported only in the cell that holds the low corner of the two
 * boxes' quantized intersection, so it is reported once, with no hash set. */
#include "internal.h"
#include "morton.h"

#define LC_MAX_SEGS 24
#define LC_PREFETCH 8

typedef struct lc_rec {
    int32_t lo[3];
    int32_t hi[3];
    uint32_t idx;
    uint32_t pad;
} lc_rec;

typedef struct lc_seg {
    uint64_t cm;   /* Morton code of the cell at its own level */
    size_t start;  /* first record of the segment */
    uint32_t level;
} lc_seg;

static size_t lc_lower_bound(const uint64_t *a, size_t n, uint64_t v)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (a[mid] < v)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

static size_t lc_upper_bound(const uint64_t *a, size_t n, uint64_t v)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (a[mid] <= v)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* Opens the segment of cell (pm, level) under the current top segment:
 * copies the top segment's records that overlap the cell, and reserves room
 * for `extra` more records. */
static locd_status lc_open_segment(const locd_grid *g, lc_sweep_out *o, lc_rec **cand, lc_seg *segs, uint32_t *nseg,
                                   size_t *ncand, uint64_t pm, uint32_t level, size_t extra)
{
    const uint32_t s = LC_QBITS - level;
    const uint64_t cm = pm >> (3u * (g->depth - level));
    size_t start = *ncand, pstart = *nseg ? segs[*nseg - 1].start : start, r, w;
    int64_t clo[3], chi[3];
    int a;
    if (start + (start - pstart) + extra > o->cand.cap) {
        locd_status st = lc_buf_reserve(o->alloc, &o->cand, sizeof(lc_rec), start + (start - pstart) + extra);
        if (st)
            return st;
        *cand = (lc_rec *)o->cand.data;
    }
    for (a = 0; a < 3; a++) {
        clo[a] = (int64_t)lc_morton_compact3(cm >> a) << s;
        chi[a] = clo[a] + ((int64_t)1 << s) - 1;
    }
    w = start;
    for (r = pstart; r < start; r++) {
        const lc_rec *c = &(*cand)[r];
        if (c->lo[0] <= chi[0] && c->hi[0] >= clo[0] && c->lo[1] <= chi[1] && c->hi[1] >= clo[1] &&
            c->lo[2] <= chi[2] && c->hi[2] >= clo[2])
            (*cand)[w++] = *c;
    }
    segs[*nseg].cm = cm;
    segs[*nseg].start = start;
    segs[*nseg].level = level;
    (*nseg)++;
    *ncand = w;
    return LOCD_OK;
}

#define LC_T float
#define LC_SUFFIX f32
#include "sweep_impl.h"
#undef LC_T
#undef LC_SUFFIX

#define LC_T double
#define LC_SUFFIX f64
#include "sweep_impl.h"
#undef LC_T
#undef LC_SUFFIX

void lc_sweep_out_init(lc_sweep_out *o, const locd_allocator *a)
{
    memset(o, 0, sizeof *o);
    o->alloc = a;
}

void lc_sweep_out_fini(lc_sweep_out *o)
{
    lc_buf_release(o->alloc, &o->pairs, sizeof(uint32_t));
    lc_buf_release(o->alloc, &o->cand, sizeof(lc_rec));
}

static int entries_sorted(const uint64_t *e, size_t count)
{
    size_t i;
    for (i = 1; i < count; i++)
        if (e[i - 1] >= e[i])
            return 0;
    return 1;
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
        if (stats && stats->size < sizeof(locd_stats))                                                       \
            return lc_error(LOCD_ERR_INVALID_ARGUMENT, "stats->size is too small (use locd_stats_init)");   \
        if (!entries_sorted(entries, count))                                                                 \
            return lc_error(LOCD_ERR_INVALID_ARGUMENT, "entries are not strictly ascending");               \
        for (i = 0; i < count; i++)                                                                          \
            if ((entries[i] & ((1ull << grid->index_bits) - 1)) >= n)                                        \
                return lc_error(LOCD_ERR_INVALID_ARGUMENT, "entry %zu names object >= n", i);               \
        lc_sweep_out_init(&o, &out->alloc);                                                                  \
        st = lc_sweep_range_##SUFFIX(grid, boxes, entries, count, 0, count, &o);                            \
        if (!st)                                                                                             \
            st = lc_pairs_reserve(out, o.count);                                                             \
        if (!st) {                                                                                           \
            if (o.count)                                                                                     \
                memcpy(out->data, o.pairs.data, o.count * 2 * sizeof(uint32_t));                             \
            out->count = o.count;                                                                            \
            if (stats) {                                                                                     \
                stats->entries = count;                                                                      \
                stats->objects = n;                                                                          \
                stats->candidates = o.candidates;                                                            \
                stats->exact_tests = o.exact_tests;                                                          \
                stats->pairs = o.count;                                                                      \
            }                                                                                                \
            lc_clear_error();                                                                                \
        }                                                                                                    \
        lc_sweep_out_fini(&o);                                                                               \
        return st;                                                                                           \
    }

LC_SWEEP_PUBLIC(f32, float)
LC_SWEEP_PUBLIC(f64, double)
