#include "support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void ts_seed(ts_rng *r, uint64_t seed)
{
    r->s = seed * 0x9e3779b97f4a7c15ULL + 0x632be59bd9b4e019ULL;
    if (!r->s)
        r->s = 1;
}

uint64_t ts_next(ts_rng *r)
{
    uint64_t x = r->s;
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    r->s = x;
    return x * 0x2545f4914f6cdd1dULL;
}

double ts_uniform(ts_rng *r)
{
    return (double)(ts_next(r) >> 11) * (1.0 / 9007199254740992.0);
}

static void put(float *b, double x, double y, double z, double sx, double sy, double sz)
{
    b[0] = (float)x;
    b[1] = (float)y;
    b[2] = (float)z;
    b[3] = (float)(x + sx);
    b[4] = (float)(y + sy);
    b[5] = (float)(z + sz);
}

float *ts_boxes(size_t n, ts_rng *r, uint64_t seed)
{
    float *b = malloc((n ? n : 1) * 6 * sizeof(float));
    if (!b) {
        fprintf(stderr, "ts_boxes: no memory for %zu boxes\n", n);
        exit(1);
    }
    ts_seed(r, seed);
    return b;
}

float *ts_scene(int kind, size_t n, uint64_t seed)
{
    ts_rng r;
    size_t i;
    float *b = malloc((n ? n : 1) * 6 * sizeof(float));
    double w = n ? pow(4.0 * (double)n, -1.0 / 3.0) : 0.1;
    ts_seed(&r, seed);
    for (i = 0; i < n; i++) {
        double x = ts_uniform(&r), y = ts_uniform(&r), z = ts_uniform(&r);
        switch (kind) {
        case 0:
            put(b + 6 * i, x, y, z, w, w, w);
            break;
        case 1: {
            double c = (double)(ts_next(&r) % 4) * 0.25;
            put(b + 6 * i, c + 0.05 * x, c + 0.05 * y, c + 0.05 * z, w, w, w);
            break;
        }
        case 2: {
            double s = w * pow(10.0, 3.0 * ts_uniform(&r) - 2.0);
            put(b + 6 * i, x, y, z, s * (0.2 + ts_uniform(&r)), s * (0.2 + ts_uniform(&r)),
                s * (0.2 + ts_uniform(&r)));
            break;
        }
        case 3: { /* integer lattice: unit cubes touching, some repeated */
            double gx = (double)(ts_next(&r) % 8), gy = (double)(ts_next(&r) % 8), gz = (double)(ts_next(&r) % 8);
            put(b + 6 * i, gx, gy, gz, 1, 1, 1);
            break;
        }
        default: { /* points, flat boxes, duplicates */
            uint64_t v = ts_next(&r) % 4;
            if (v == 0)
                put(b + 6 * i, x, y, z, 0, 0, 0);
            else if (v == 1)
                put(b + 6 * i, x, y, 0.5, w, w, 0);
            else if (v == 2 && i > 0)
                memcpy(b + 6 * i, b + 6 * (i - 1), 6 * sizeof(float));
            else
                put(b + 6 * i, floor(x * 4) / 4, floor(y * 4) / 4, floor(z * 4) / 4, 0.25, 0.25, 0.25);
            break;
        }
        }
    }
    return b;
}

static int cmp_pair(const void *a, const void *b)
{
    const uint32_t *x = a, *y = b;
    if (x[0] != y[0])
        return x[0] < y[0] ? -1 : 1;
    if (x[1] != y[1])
        return x[1] < y[1] ? -1 : 1;
    return 0;
}

uint32_t *ts_sorted_copy(const locd_pairs *p, size_t *m)
{
    size_t c = locd_pairs_count(p);
    uint32_t *d = malloc((c ? c : 1) * 2 * sizeof(uint32_t));
    if (c)
        memcpy(d, locd_pairs_data(p), c * 2 * sizeof(uint32_t));
    qsort(d, c, 2 * sizeof(uint32_t), cmp_pair);
    *m = c;
    return d;
}

static int same_as(const locd_pairs *ref, const locd_pairs *result)
{
    size_t m1, m2;
    uint32_t *a = ts_sorted_copy(ref, &m1), *b = ts_sorted_copy(result, &m2);
    int ok = m1 == m2 && (m1 == 0 || memcmp(a, b, m1 * 2 * sizeof(uint32_t)) == 0);
    free(a);
    free(b);
    return ok;
}

int ts_same_as_brute_f32(const float *boxes, size_t n, const locd_pairs *result)
{
    locd_pairs *ref;
    int ok;
    if (locd_pairs_create(NULL, &ref) || locd_brute_force_f32(boxes, n, ref))
        return 0;
    ok = same_as(ref, result);
    locd_pairs_destroy(ref);
    return ok;
}

int ts_same_as_brute_f64(const double *boxes, size_t n, const locd_pairs *result)
{
    locd_pairs *ref;
    int ok;
    if (locd_pairs_create(NULL, &ref) || locd_brute_force_f64(boxes, n, ref))
        return 0;
    ok = same_as(ref, result);
    locd_pairs_destroy(ref);
    return ok;
}

int ts_under_tsan(void)
{
#if defined(__SANITIZE_THREAD__)
    return 1;
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
    return 1;
#else
    return 0;
#endif
#else
    return 0;
#endif
}
