/* The lower-bound search on a sorted array of 64-bit values, out of line
 * (core.h's lc_lower_bound_inline, on lc_search_first, does the search). */
#include "core/core.h"

size_t lc_lower_bound(const uint64_t *a, size_t n, uint64_t v)
{
    return lc_lower_bound_inline(a, n, v);
}
