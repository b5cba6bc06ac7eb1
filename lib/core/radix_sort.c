/* An LSD radix sort of 64-bit keys over only the bits that vary above the
 * low `low_bits` (which carry the object index and so are already in
 * order); stable, so the result equals a full 64-bit sort. The octree's sort
 * step (the paper's step 2) and the pair ordering both use it. */
#include "core/core.h"

#include <stdlib.h>

#define LC_RADIX_MAX_BITS 11
#define LC_RADIX_MAX_PASSES 6
/* Below this many values a shell sort (short_sort) is faster than the radix sort's passes. */
#define LC_RADIX_SORT_MIN 256

/* Shell sort with Ciura's gaps, for short arrays (below
 * LC_RADIX_SORT_MIN): no call per comparison, as qsort makes, and no
 * quadratic case, as an insertion sort has on a few hundred keys. */
static void short_sort(uint64_t *v, size_t n)
{
    static const size_t gaps[] = {132, 57, 23, 10, 4, 1};
    size_t g, i, j;
    for (g = 0; g < sizeof gaps / sizeof gaps[0]; g++) {
        const size_t gap = gaps[g];
        for (i = gap; i < n; i++) {
            const uint64_t x = v[i];
            for (j = i; j >= gap && v[j - gap] > x; j -= gap)
                v[j] = v[j - gap];
            v[j] = x;
        }
    }
}

uint64_t *lc_radix_sort(uint64_t *entries, uint64_t *scratch, size_t count, uint32_t index_bits)
{
    uint64_t diff = 0, first, *src = entries, *dst = scratch;
    uint32_t lowbit, highbit, span, passes, bits, p, maxbits;
    size_t i;
    uint32_t hist[LC_RADIX_MAX_PASSES][1u << LC_RADIX_MAX_BITS];
    uint32_t shift[LC_RADIX_MAX_PASSES];
    uint64_t mask;

    if (count < 2)
        return entries;
    if (count <= 64) {
        short_sort(entries, count);
        return entries;
    }
    first = entries[0] >> index_bits;
    for (i = 0; i < count; i++)
        diff |= (entries[i] >> index_bits) ^ first;
    if (!diff)
        return entries; /* one key: already in object order */
    lowbit = (uint32_t)__builtin_ctzll(diff) + index_bits;
    highbit = 63u - (uint32_t)__builtin_clzll(diff) + index_bits;
    span = highbit - lowbit + 1;
    /* A short input (a bucket of lc_psort) takes narrower digits: the
       counts' clearing and prefix cost 2^bits each pass whatever count is,
       so they stay below about count / 4. */
    maxbits = 64u - (uint32_t)__builtin_clzll((uint64_t)count) - 3u;
    if (maxbits > LC_RADIX_MAX_BITS)
        maxbits = LC_RADIX_MAX_BITS;
    passes = (span + maxbits - 1) / maxbits;
    if (passes > LC_RADIX_MAX_PASSES)
        passes = LC_RADIX_MAX_PASSES; /* then bits <= 11: span <= 64 */
    bits = (span + passes - 1) / passes;
    mask = (1ull << bits) - 1;
    for (p = 0; p < passes; p++) {
        shift[p] = lowbit + p * bits;
        memset(hist[p], 0, sizeof(uint32_t) << bits);
    }
    /* 32-bit counters: callers hand at most 2^32 - 1 entries to one call. */
    for (i = 0; i < count; i++) {
        uint64_t v = src[i];
        for (p = 0; p < passes; p++)
            hist[p][(v >> shift[p]) & mask]++;
    }
    for (p = 0; p < passes; p++) {
        uint32_t sum = 0, b, *h = hist[p];
        int trivial = 0;
        for (b = 0; b <= mask; b++) {
            uint32_t c = h[b];
            if (c == count)
                trivial = 1;
            h[b] = sum;
            sum += c;
        }
        if (trivial)
            continue; /* every entry has the same digit here */
        for (i = 0; i < count; i++) {
            uint64_t v = src[i];
            dst[h[(v >> shift[p]) & mask]++] = v;
        }
        {
            uint64_t *t = src;
            src = dst;
            dst = t;
        }
    }
    return src;
}

static int cmp_u64(const void *pa, const void *pb)
{
    uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return (a > b) - (a < b);
}

void lc_sort_u64(uint64_t *v, size_t n)
{
    if (n < LC_RADIX_SORT_MIN)
        short_sort(v, n);
    else
        qsort(v, n, sizeof *v, cmp_u64);
}

locd_status lc_sort_u64_radix(const locd_allocator *a, uint64_t *v, size_t n)
{
    uint64_t *scratch, *r;
    if (n < LC_RADIX_SORT_MIN) {
        lc_sort_u64(v, n);
        return LOCD_OK;
    }
    if (!(scratch = lc_alloc(a, n * sizeof *scratch)))
        return lc_error(LOCD_ERR_NO_MEMORY, "could not allocate a sort's scratch");
    r = lc_radix_sort(v, scratch, n, 0);
    if (r != v)
        memcpy(v, r, n * sizeof *v);
    lc_free(a, scratch, n * sizeof *scratch);
    return LOCD_OK;
}
