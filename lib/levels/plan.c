/* The work split of levels 1 and 2: shares of the objects and the entry
 * regions they encode into (levels.h). It calls nothing but the C library
 * (it takes only declarations and constants from the private headers). */
#include "levels/levels.h"

#include <math.h>

/* Room above the estimate: small shares, rounding, a few boxes that cross more cells. */
#define LC_REGION_SLACK 64
/* Added to the entries per object seen, so that a slightly denser call fits. */
#define LC_PER_OBJECT_MARGIN 0.25

size_t lc_chunk_begin(size_t n, uint32_t t, uint32_t k)
{
    size_t q = n / k, r = n % k;
    return q * t + (t < r ? t : r);
}

double lc_entries_per_object_guess(int32_t cell_bias)
{
    /* A box at most 2^-bias of its cell crosses into the next cell on an
       axis with probability at most 2^-bias: (1 + 2^-bias)^3 entries per
       object on average, 1.95 for the default bias. */
    return pow(1.0 + ldexp(1.0, -cell_bias), 3) + LC_PER_OBJECT_MARGIN;
}

size_t lc_region_capacity(size_t m, double per_object)
{
    size_t cap = (size_t)((double)m * per_object) + LC_REGION_SLACK;
    /* + 1: an empty share still gets a region (a non-empty malloc). */
    return cap > m * LOCD_MAX_ENTRIES_PER_BOX ? m * LOCD_MAX_ENTRIES_PER_BOX + 1 : cap;
}

void lc_plan_regions(lc_plan *p, size_t n, double per_object)
{
    uint32_t t;
    for (t = 0; t < p->k; t++)
        p->cap[t] = lc_region_capacity(lc_chunk_begin(n, t + 1, p->k) - lc_chunk_begin(n, t, p->k), per_object);
}

size_t lc_plan_layout(lc_plan *p)
{
    size_t total = 0;
    uint32_t t;
    for (t = 0; t < p->k; t++) {
        p->off[t] = total;
        total += p->cap[t];
    }
    return total;
}

double lc_plan_finish(lc_plan *p, size_t n)
{
    uint32_t t;
    p->total = 0;
    for (t = 0; t < p->k; t++)
        p->total += p->cnt[t];
    return (double)p->total / (double)n + LC_PER_OBJECT_MARGIN;
}
