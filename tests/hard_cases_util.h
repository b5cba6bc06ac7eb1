/* The engines and checks of the hard-case suites (tests/test_hard_cases*.c).
 *
 * Every scene is checked against the O(n^2) brute force in the input
 * precision, through every engine the build offers: level 1 at 1, 2, 3 and 8
 * threads (scenes of >= 4096 objects, so the parallel path runs), level 2
 * (worker processes) and level 3 (a `locd serve` started by the suite) when
 * they are available, and a few engines with other octree knobs (cubes,
 * bias 0 and 8, shallow depth). Engines with the same knobs must also
 * return the pairs in bitwise the same order (determinism is part of the
 * contract). A suite makes the engines in its group setup and ends them,
 * and the service, in its group teardown:
 *
 *   return LT_RUN_GROUP(tests, hc_group_setup, hc_group_teardown);
 *
 * Environment: LOCD_TEST_SERVICE ("unix:PATH" of a running service to use
 * instead of starting one), LOCD_HARD_VERBOSE=1 (a line per scene).
 */
#ifndef LOCD_TEST_HARD_CASES_UTIL_H
#define LOCD_TEST_HARD_CASES_UTIL_H

#include <locd/locd.h>
#include <stddef.h>
#include <stdint.h>

#include "support.h"

/* Scenes of at least this many objects take the engine's parallel path. */
#define HC_PAR 4096

/* LOCD_TEST_HEAVY=0 (the sanitizer builds, tests/README.md) shrinks the
 * scenes whose output is quadratic; everything stays >= HC_PAR objects
 * except those. 0 then, 1 otherwise. */
int hc_heavy(void);

/* ---- the engines under test ---- */
typedef struct hc_runner {
    locd_engine *e;
    char name[96];
    int group; /* same knobs => the same pair order is required */
    int level;
    int light_skip; /* left out when LOCD_TEST_HEAVY=0 (its neighbours cover it) */
    locd_engine_config cfg; /* to make the engine again (hc_trim_runners) */
} hc_runner;

#define HC_MAX_RUNNERS 16
extern hc_runner hc_runners[HC_MAX_RUNNERS];
extern int hc_nrunners;

/* LT_RUN_GROUP's setup and teardown: the engines, and the service. */
int hc_group_setup(void);
void hc_group_teardown(void);
/* Makes every engine again, after a test with millions of pairs. */
void hc_trim_runners(void);
/* Whether engine r takes part for a scene of n objects. */
int hc_runner_wanted(int r, size_t n);

/* ---- checks ---- */
/* Every engine against the brute force; returns the number of pairs. */
size_t hc_check_f32(const float *b, size_t n, const char *what);
size_t hc_check_f64(const double *b, size_t n, const char *what);
/* A float32 scene, then the same values through the float64 entry point
 * (the same pairs, in the same order). */
void hc_check_both(const float *b, size_t n, const char *what);
/* The brute-force answer in the input precision, as sorted (i << 32 | j)
 * keys; malloc'd. */
uint64_t *hc_reference(const void *boxes, size_t n, int f64, size_t *m);
/* float32 boxes as float64, and float64 rounded to nearest float32; malloc'd. */
double *hc_widen(const float *b, size_t n);
float *hc_narrow(const double *b, size_t n);

/* ---- scene building ---- */
typedef struct hc_scene {
    double *b;
    size_t n, cap;
} hc_scene;

void hc_scene_add(hc_scene *s, double x0, double y0, double z0, double x1, double y1, double z1);
void hc_scene_free(hc_scene *s);
/* A random number below k (0 when k is 0). */
uint64_t hc_rnd(ts_rng *r, uint64_t k);
/* count boxes whose faces are values of the sorted table vals[0, nv), each
 * covering up to span table steps per axis (0: points). */
void hc_add_table_boxes(hc_scene *s, ts_rng *r, size_t count, const double *vals, size_t nv, size_t span);

/* ---- a counting allocator ---- */
/* Bytes in use and their peak; an allocation past cap is refused. */
typedef struct hc_counter {
    size_t cur, peak, cap, refused;
} hc_counter;

/* The allocator's functions (user: the hc_counter), and a level-1 engine of
 * that many threads that allocates through them. */
void *hc_count_alloc(size_t size, void *user);
void hc_count_free(void *p, size_t size, void *user);
locd_engine *hc_counted_engine(uint32_t threads, hc_counter *c);

#endif
