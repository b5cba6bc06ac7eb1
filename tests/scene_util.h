/* Helpers of the scene's suites (tests/test_scene_*.c): a brute-force model
 * of the scene that every update and query is checked against, random
 * worlds to fill scenes with, and for scenes too large for the model, the
 * engine's own find as the reference (it shares no code with the scene's
 * update paths). A helper that checks fails the running test. */
#ifndef LOCD_TEST_SCENE_UTIL_H
#define LOCD_TEST_SCENE_UTIL_H

#include <locd/scene.h>
#include <stddef.h>
#include <stdint.h>

#include "support.h"

/* ---- the model ---- */
typedef struct su_obj {
    locd_id id;
    double box[6];
    uint64_t cat, mask, group, user;
    int stat;
} su_obj;

typedef struct su_model {
    su_obj *o;
    size_t n, cap;
    locd_id *pairs; /* rows of the last update, sorted */
    size_t npairs;
} su_model;

void su_model_add(su_model *m, locd_id id, const double *box, uint64_t cat, uint64_t mask, uint64_t group,
                  uint64_t user, int stat);
su_obj *su_model_find(su_model *m, locd_id id);
/* The object must be there; the model's last object takes its place. */
void su_model_remove(su_model *m, locd_id id);

/* Rows of (id, id) pairs equal, row for row. */
void su_same_rows(const char *what, const locd_id *want, size_t nwant, const locd_id *got, size_t ngot);

/* n steps, a tenth of them when LOCD_TEST_HEAVY=0 (the sanitizer runs). */
int su_steps(int n);

/* The lists of the update just made (pairs, created, lost) against the
 * model, which then takes them as its previous set; su_check_update makes
 * the update first. Each call counts su_updates, and su_incremental when
 * the update was not from scratch. */
void su_check_lists(locd_scene *s, su_model *m);
void su_check_update(locd_scene *s, su_model *m);
extern unsigned su_updates, su_incremental;

/* A query against the model: kind 0 box (q: 6 values), 1 point (3), 2 ray
 * (origin, direction, max_t); also one short of room for the hits. */
void su_check_query(const locd_scene *s, const su_model *m, int kind, const double *q, uint64_t mask);

/* x rounded to float (never left unrounded by the optimizer). */
float su_to_float(double x);

/* ---- random worlds ---- */
typedef struct su_world {
    ts_rng r;
    double extent; /* coordinates in [0, extent) */
    double size;   /* typical box edge */
    int shape;     /* 0 random, 1 lattice (touching faces), 2 far from the origin */
} su_world;

su_world su_world_make(uint64_t seed, double extent, double size, int shape);
void su_random_box(su_world *w, double *b);
/* Filter bits from a few values, so that filters bite often. */
uint64_t su_random_bits(su_world *w);
/* A random box, point or ray query, checked against the model. */
void su_random_query(su_world *w, const locd_scene *s, const su_model *m);

/* A level-1 engine of that many threads (alloc may be NULL). */
locd_engine *su_new_engine(uint32_t threads, const locd_allocator *alloc);
/* The scene configuration of the kept entry list's tests: no near-pair list. */
extern const locd_scene_config su_kept_cfg;

/* ---- scenes and the model side by side ---- */
void su_add_boxes(locd_scene *s, su_model *m, const double *b, size_t n, int stat, locd_id *ids);
void su_move_box(locd_scene *s, su_model *m, locd_id id, const double *b);
/* Every object moved to its own box, then an update that must be from scratch. */
void su_update_all_from_scratch(locd_scene *s, su_model *m);
/* The pairs of a fresh scene of the model's objects, in the model's ids, sorted. */
locd_id *su_fresh_pairs(locd_engine *e, const su_model *m, size_t *count);

/* ---- the engine's own find as the reference ---- */
/* The pairs of boxes f[0, n) as rows of ids[], less those a group filter
 * (every index a multiple of grouped, when not 0) or two statics (indices
 * from first_static on) would drop; malloc'd. */
locd_id *su_engine_rows_filtered(locd_engine *e, const float *f, const locd_id *ids, size_t n, uint32_t grouped,
                                 size_t first_static, size_t *count);
locd_id *su_engine_rows(locd_engine *e, const float *f, const locd_id *ids, size_t n, uint32_t grouped,
                        size_t *count);
/* The last update's lists against the reference rows now and before it;
 * su_check_against makes the update first. */
void su_check_lists_against(locd_scene *s, const locd_id *now, size_t nnow, const locd_id *before, size_t nbefore);
void su_check_against(locd_scene *s, const locd_id *now, size_t nnow, const locd_id *before, size_t nbefore);
/* Cubes of edge `edge` at random corners in the unit cube, or (jitter > 0)
 * each one's corner stepped by up to `jitter` on each axis. */
void su_cube_boxes(ts_rng *r, float *f, size_t n, double edge, double jitter);

#endif
