/* The library's sorts of 64-bit keys (lib/core/radix_sort.c): the short
 * arrays' shell sort (below LC_RADIX_SORT_MIN keys), qsort above it and
 * the radix sort, each against the C library's qsort, on every length up
 * to past the switch and on the orders that break simple sorts: random,
 * ascending, descending, all equal, few distinct values (internals). */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "runner.h"

#include "core/core.h"

#define LT_SORT_MAX 600

static int cmp_u64(const void *a, const void *b)
{
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* n keys of the given order into v (r: the generator's state). */
static void keys(uint64_t *v, size_t n, int order, uint64_t *r)
{
    size_t i;
    for (i = 0; i < n; i++) {
        *r = *r * 6364136223846793005ull + 1442695040888963407ull;
        switch (order) {
        case 0: v[i] = *r; break;                      /* random, all 64 bits */
        case 1: v[i] = (uint64_t)i << 20; break;         /* ascending */
        case 2: v[i] = (uint64_t)(n - i) << 33; break;   /* descending */
        case 3: v[i] = 42; break;                        /* all equal */
        default: v[i] = (*r >> 61) << 40 | 7; break;     /* eight distinct values */
        }
    }
}

/* v sorted by `which` (0: lc_sort_u64, 1: lc_sort_u64_radix) equals ref
 * sorted by qsort. */
static void check_one(int which, const locd_allocator *al, uint64_t *v, uint64_t *ref, size_t n, int order)
{
    memcpy(ref, v, n * sizeof *v);
    qsort(ref, n, sizeof *ref, cmp_u64);
    if (which)
        TEST_ASSERT_EQUAL_INT(LOCD_OK, lc_sort_u64_radix(al, v, n));
    else
        lc_sort_u64(v, n);
    if (n && memcmp(v, ref, n * sizeof *v))
        LT_FAIL("%s: order %d, %zu keys", which ? "lc_sort_u64_radix" : "lc_sort_u64", order, n);
}

static void sorts_equal_qsort(void)
{
    static uint64_t v[LT_SORT_MAX], ref[LT_SORT_MAX];
    locd_allocator al;
    uint64_t r = 99;
    size_t n;
    int order, which;
    lc_allocator_resolve(&al, NULL);
    for (order = 0; order < 5; order++)
        for (n = 0; n < LT_SORT_MAX; n += n < 300 ? 1 : 37)
            for (which = 0; which < 2; which++) {
                keys(v, n, order, &r);
                check_one(which, &al, v, ref, n, order);
            }
}

static const lt_test tests[] = {
    LT_TEST(sorts_equal_qsort),
};

int main(void)
{
    return LT_RUN(tests);
}
