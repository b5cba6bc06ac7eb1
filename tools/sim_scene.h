/* JSON scenes for `locd simulate` (format: docs/pipeline.md). */
#ifndef LOCD_TOOLS_SIM_SCENE_H
#define LOCD_TOOLS_SIM_SCENE_H

#include <locd/pipeline.h>
#include <stddef.h>
#include <stdint.h>

/* A shape as the scene described it (kept for the renderer). */
typedef struct sim_shape {
    locd_shape *handle;
    int32_t kind;
    double radius, half[3];
    double *points; /* convex points or mesh vertices, 3 per point */
    size_t npoints;
    uint32_t *tris; /* mesh: 3 per triangle */
    size_t ntris;
} sim_shape;

typedef struct sim_scene {
    char name[64];
    double dt, gravity[3], restitution, swept_threshold;
    int continuous;  /* LOCD_SWEPT_* */
    int shape_tests; /* LOCD_STAGE_SHAPE on */
    int contacts;    /* LOCD_STAGE_CONTACT on */
    int response;    /* bounce and push apart (needs contacts) */
    int steps;       /* default for --steps */
    uint32_t threads;
    size_t n;
    double *poses; /* 7 per object */
    double *vel;   /* 6 per object */
    uint8_t *dynamic;
    uint32_t *shape_of; /* index into shapes */
    /* Collision filter (locd_world_set_filter) and the step at which the
     * object is removed (0: never); has_filters says whether any object sets one. */
    uint64_t *category, *mask, *group;
    int32_t *remove_at;
    int has_filters;
    char **names;       /* NULL entries for unnamed objects */
    sim_shape *shapes;
    size_t nshapes, shapes_cap;
} sim_scene;

/* 0 on success; otherwise err says what and where. */
int sim_scene_load(const char *path, sim_scene *s, char *err, size_t errlen);
void sim_scene_free(sim_scene *s);
const char *sim_kind_name(int32_t kind);

#endif
