/* The lower-bound searches on sorted arrays of 64- and 32-bit values, out
 * of line (core.h's lc_lower_bound_inline and lc_search_first do them). */
#include "core/core.h"

size_t lc_lower_bound(const uint64_t *a, size_t n, uint64_t v)
{
    return lc_lower_bound_inline(a, n, v);
}

static int at_or_above_u32(const void *ctx, uint64_t i)
{
    const uint32_t *a = ((const uint32_t *const *)ctx)[0], *v = ((const uint32_t *const *)ctx)[1];
    return a[i] >= *v;
}

size_t lc_lower_bound_u32(const uint32_t *a, size_t n, uint32_t v)
{
    const uint32_t *ctx[2];
    ctx[0] = a, ctx[1] = &v;
    return (size_t)lc_search_first(0, n, at_or_above_u32, ctx);
}
