/* Helpers shared by the C tests: scenes and the reference answer. */
#ifndef LOCD_TEST_SUPPORT_H
#define LOCD_TEST_SUPPORT_H

#include <locd/locd.h>
#include <stddef.h>
#include <stdint.h>

/* xorshift-based generator: tests are reproducible from their seed. */
typedef struct ts_rng {
    uint64_t s;
} ts_rng;
void ts_seed(ts_rng *r, uint64_t seed);
uint64_t ts_next(ts_rng *r);
double ts_uniform(ts_rng *r); /* [0, 1) */

/* Room for n boxes (6 floats each, malloc'd; the process stops with a
 * message if there is none) and r seeded to fill them. */
float *ts_boxes(size_t n, ts_rng *r, uint64_t seed);

/* Random scene of n boxes: kind 0 uniform, 1 clustered, 2 mixed sizes,
 * 3 touching lattice, 4 degenerate (points, planes, duplicates). malloc'd. */
float *ts_scene(int kind, size_t n, uint64_t seed);
#define TS_SCENE_KINDS 5

/* Copies pairs, sorted by (i, j), into a malloc'd array; *m gets the count. */
uint32_t *ts_sorted_copy(const locd_pairs *p, size_t *m);
/* 1 if the engine result (any order) equals the brute-force set. */
int ts_same_as_brute_f32(const float *boxes, size_t n, const locd_pairs *result);
int ts_same_as_brute_f64(const double *boxes, size_t n, const locd_pairs *result);

/* 1 in a ThreadSanitizer build. Its runs are some 20 times slower; a test
 * that makes a job long on purpose, or repeats a check over thread counts
 * for its result's sake (which the other builds check in full), does less
 * there: races need the threads, not the repetitions. */
int ts_under_tsan(void);

/* The LOCD_KERNEL names of this architecture's kernels, scalar first (the
 * reference the others must match byte for byte); TS_KERNEL_COUNT of them. */
#if defined(__aarch64__)
#define TS_KERNELS {"scalar", "neon"}
#define TS_KERNEL_COUNT 2
#else
#define TS_KERNELS {"scalar", "avx2", "avx512"}
#define TS_KERNEL_COUNT 3
#endif

#endif
