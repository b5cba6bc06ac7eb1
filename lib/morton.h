/* 3-D Morton (Z-order) interleaving of 21-bit coordinates. */
#ifndef LOCD_MORTON_H
#define LOCD_MORTON_H

#include <stdint.h>

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
