/* The O(n^2) reference: every pair, the exact closed-interval test. */
#include "octree/octree.h"

#define LC_T float
#define LC_SUFFIX f32
#include "brute_impl.h"
#define LC_T double
#define LC_SUFFIX f64
#include "brute_impl.h"

locd_status locd_brute_force_f32(const float *boxes, size_t n, locd_pairs *out)
{
    return brute_force_f32(boxes, n, out);
}

locd_status locd_brute_force_f64(const double *boxes, size_t n, locd_pairs *out)
{
    return brute_force_f64(boxes, n, out);
}
