/* Loads a JSON scene (docs/pipeline.md): global effects, listed objects and
 * generated ones (random or grid layouts, rocks, height-field terrain). */
#include "sim_scene.h"

#include "cli.h"
#include "json.h"

#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SIM_PI 3.14159265358979323846

static int bad(char *err, size_t errlen, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, errlen, fmt, ap);
    va_end(ap);
    return -1;
}

const char *sim_kind_name(int32_t kind)
{
    switch (kind) {
    case LOCD_SHAPE_SPHERE: return "sphere";
    case LOCD_SHAPE_BOX: return "box";
    case LOCD_SHAPE_CAPSULE: return "capsule";
    case LOCD_SHAPE_CONVEX: return "convex";
    case LOCD_SHAPE_MESH: return "mesh";
    default: return "?";
    }
}

static int add_shape(sim_scene *s, const sim_shape *sh)
{
    if (s->nshapes == s->shapes_cap) {
        size_t cap = s->shapes_cap ? 2 * s->shapes_cap : 8;
        sim_shape *q = realloc(s->shapes, cap * sizeof *q);
        if (!q)
            return -1;
        s->shapes = q;
        s->shapes_cap = cap;
    }
    s->shapes[s->nshapes++] = *sh;
    return 0;
}

/* Random convex "rock": points on a sphere, pushed in by up to 30%. */
static double *rock_points(double radius, size_t count, uint64_t seed)
{
    cli_rng r;
    size_t i;
    double *p = malloc(3 * count * sizeof(double));
    if (!p)
        return NULL;
    cli_rng_seed(&r, seed);
    for (i = 0; i < count; i++) {
        double z = 2.0 * cli_rng_uniform(&r) - 1.0, a = 2.0 * SIM_PI * cli_rng_uniform(&r);
        double rr = radius * (0.7 + 0.3 * cli_rng_uniform(&r)), q = sqrt(1.0 - z * z);
        p[3 * i] = rr * q * cos(a);
        p[3 * i + 1] = rr * q * sin(a);
        p[3 * i + 2] = rr * z;
    }
    return p;
}

/* Whether a JSON number is a whole number in [0, 2^53): exact in a double,
 * so it converts to uint64_t without loss (a NaN fails too). */
static int is_whole_u53(double d)
{
    return d >= 0 && d < 9007199254740992.0 && d == floor(d);
}

/* o's "seed" (default 1) into *seed: 0 when absent or valid, -1 when it is
 * not a whole number in [0, 2^53) (a negative or NaN seed cast to uint64_t
 * was undefined behaviour, found by 42-fuzz). */
static int get_seed(const json_value *o, uint64_t *seed)
{
    double d = 1.0;
    if (json_get_number(o, "seed", &d) < 0 || !is_whole_u53(d))
        return -1;
    *seed = (uint64_t)d;
    return 0;
}

/* Height field: size[0] x size[1] centred on the origin, cells[0] x cells[1]
 * quads, heights a sum of three random waves of the given amplitude. */
static int terrain_mesh(const json_value *o, sim_shape *sh, char *err, size_t errlen)
{
    double size[2] = {20.0, 20.0}, cells[2] = {32, 32}, amp = 1.0, ph[6], fr[6];
    uint64_t seed;
    size_t nx, ny, i, j, t = 0;
    cli_rng r;
    int k;
    if (json_get_vec(o, "size", size, 2) < 0 || json_get_vec(o, "cells", cells, 2) < 0 ||
        json_get_number(o, "amplitude", &amp) < 0 || get_seed(o, &seed) < 0)
        return bad(err, errlen, "terrain: size [x, y], cells [nx, ny] and amplitude are numbers, seed a whole number 0..2^53");
    if (!(cells[0] >= 1 && cells[1] >= 1 && cells[0] <= 2048 && cells[1] <= 2048))
        return bad(err, errlen, "terrain: cells must be 1..2048");
    nx = (size_t)cells[0];
    ny = (size_t)cells[1];
    cli_rng_seed(&r, seed);
    for (k = 0; k < 6; k++) {
        ph[k] = 2.0 * SIM_PI * cli_rng_uniform(&r);
        fr[k] = (0.5 + 1.5 * cli_rng_uniform(&r)) * 2.0 * SIM_PI / fmax(size[0], size[1]) * (1 + k / 2);
    }
    sh->npoints = (nx + 1) * (ny + 1);
    sh->ntris = 2 * nx * ny;
    sh->points = malloc(3 * sh->npoints * sizeof(double));
    sh->tris = malloc(3 * sh->ntris * sizeof(uint32_t));
    if (!sh->points || !sh->tris)
        return bad(err, errlen, "out of memory");
    for (i = 0; i <= nx; i++)
        for (j = 0; j <= ny; j++) {
            double x = size[0] * ((double)i / (double)nx - 0.5), y = size[1] * ((double)j / (double)ny - 0.5), z = 0;
            double *p = sh->points + 3 * (i * (ny + 1) + j);
            for (k = 0; k < 3; k++)
                z += amp / (1 + k) * sin(fr[2 * k] * x + ph[2 * k]) * cos(fr[2 * k + 1] * y + ph[2 * k + 1]);
            p[0] = x;
            p[1] = y;
            p[2] = z;
        }
    for (i = 0; i < nx; i++)
        for (j = 0; j < ny; j++) {
            uint32_t a = (uint32_t)(i * (ny + 1) + j), b = a + 1, c = a + (uint32_t)(ny + 1), d = c + 1;
            uint32_t *q = sh->tris + 3 * t;
            q[0] = a, q[1] = c, q[2] = b, q[3] = b, q[4] = c, q[5] = d;
            t += 2;
        }
    sh->kind = LOCD_SHAPE_MESH;
    return 0;
}

/* One [x, y, z] into out; -1 if p is not three numbers. */
static int read_point(const json_value *p, double *out)
{
    int k;
    if (p->type != JSON_ARRAY || p->count != 3)
        return -1;
    for (k = 0; k < 3; k++) {
        if (p->items[k].type != JSON_NUMBER)
            return -1;
        out[k] = p->items[k].number;
    }
    return 0;
}

/* A non-empty list of [x, y, z] into *out (malloc, 3 per point); -1 with
 * *out NULL if it is not one. */
static int read_point_list(const json_value *arr, double **out, size_t *count)
{
    size_t i;
    *out = NULL;
    if (!arr || arr->type != JSON_ARRAY || arr->count == 0)
        return -1;
    *out = malloc(3 * arr->count * sizeof(double));
    if (!*out)
        return -1;
    for (i = 0; i < arr->count; i++)
        if (read_point(&arr->items[i], *out + 3 * i) != 0) {
            free(*out);
            *out = NULL;
            return -1;
        }
    *count = arr->count;
    return 0;
}

/* A shape that is not (or no longer) the scene's: its handle and arrays. */
static void free_shape(sim_shape *sh)
{
    locd_shape_destroy(sh->handle);
    free(sh->points);
    free(sh->tris);
    memset(sh, 0, sizeof *sh);
}

/* What a shape builder reads (the object and, for a rock, the variant) and
 * fills (the shape; err on a bad description). */
typedef struct shape_req {
    const json_value *o;
    int variant;
    sim_shape *sh;
    char *err;
    size_t errlen;
} shape_req;

/* A builder returns -1 (err set) for a bad description, else 0 with the
 * library's answer in *st. */
typedef int (*shape_builder)(const shape_req *q, locd_status *st);

static int build_sphere(const shape_req *q, locd_status *st)
{
    q->sh->kind = LOCD_SHAPE_SPHERE;
    *st = locd_shape_sphere(q->sh->radius, &q->sh->handle);
    return 0;
}

static int build_box(const shape_req *q, locd_status *st)
{
    sim_shape *sh = q->sh;
    sh->kind = LOCD_SHAPE_BOX;
    *st = locd_shape_box(sh->half[0], sh->half[1], sh->half[2], &sh->handle);
    return 0;
}

/* A capsule's half length defaults to its radius. */
static int build_capsule(const shape_req *q, locd_status *st)
{
    sim_shape *sh = q->sh;
    sh->kind = LOCD_SHAPE_CAPSULE;
    if (!json_get(q->o, "half_length"))
        sh->half[2] = sh->radius;
    *st = locd_shape_capsule(sh->radius, sh->half[2], &sh->handle);
    return 0;
}

static int build_convex(const shape_req *q, locd_status *st)
{
    sim_shape *sh = q->sh;
    sh->kind = LOCD_SHAPE_CONVEX;
    if (read_point_list(json_get(q->o, "points"), &sh->points, &sh->npoints) != 0)
        return bad(q->err, q->errlen, "convex: \"points\" is a non-empty list of [x, y, z]");
    *st = locd_shape_convex(sh->points, sh->npoints, &sh->handle);
    return 0;
}

/* A convex rock; each variant of a generator gets its own random points. */
static int build_rock(const shape_req *q, locd_status *st)
{
    sim_shape *sh = q->sh;
    double count = 14;
    uint64_t seed;
    if (json_get_number(q->o, "points", &count) < 0 || get_seed(q->o, &seed) < 0 ||
        !(count >= 4 && count <= 1000)) /* written so that a NaN fails too */
        return bad(q->err, q->errlen, "rock: points is 4..1000, seed a whole number 0..2^53");
    sh->kind = LOCD_SHAPE_CONVEX;
    sh->npoints = (size_t)count;
    sh->points = rock_points(sh->radius, sh->npoints, seed * 7919u + (uint64_t)q->variant);
    if (!sh->points)
        return bad(q->err, q->errlen, "out of memory");
    *st = locd_shape_convex(sh->points, sh->npoints, &sh->handle);
    return 0;
}

/* Triangles come as triples of numbers; a negative or too large one becomes
 * UINT32_MAX, which the library rejects as out of range. */
static int build_mesh(const shape_req *q, locd_status *st)
{
    sim_shape *sh = q->sh;
    size_t i;
    double *tmp = NULL;
    sh->kind = LOCD_SHAPE_MESH;
    if (read_point_list(json_get(q->o, "vertices"), &sh->points, &sh->npoints) != 0 ||
        read_point_list(json_get(q->o, "triangles"), &tmp, &sh->ntris) != 0)
        return bad(q->err, q->errlen, "mesh: \"vertices\" and \"triangles\" are lists of triples");
    sh->tris = malloc(3 * sh->ntris * sizeof(uint32_t));
    for (i = 0; sh->tris && i < 3 * sh->ntris; i++)
        sh->tris[i] = tmp[i] >= 0 && tmp[i] < 4294967295.0 ? (uint32_t)tmp[i] : UINT32_MAX;
    free(tmp);
    if (!sh->tris)
        return bad(q->err, q->errlen, "out of memory");
    *st = locd_shape_mesh(sh->points, sh->npoints, sh->tris, sh->ntris, &sh->handle);
    return 0;
}

static int build_terrain(const shape_req *q, locd_status *st)
{
    sim_shape *sh = q->sh;
    if (terrain_mesh(q->o, sh, q->err, q->errlen) != 0)
        return -1;
    *st = locd_shape_mesh(sh->points, sh->npoints, sh->tris, sh->ntris, &sh->handle);
    return 0;
}

static const struct {
    const char *kind;
    shape_builder build;
} shape_builders[] = {
    {"sphere", build_sphere}, {"box", build_box},   {"capsule", build_capsule}, {"convex", build_convex},
    {"rock", build_rock},     {"mesh", build_mesh}, {"terrain", build_terrain},
};

static shape_builder find_builder(const char *kind)
{
    size_t i;
    for (i = 0; i < sizeof shape_builders / sizeof shape_builders[0]; i++)
        if (!strcmp(kind, shape_builders[i].kind))
            return shape_builders[i].build;
    return NULL;
}

/* Builds the shape described by o's "shape" member (variant picks a rock). */
static int make_shape(const json_value *o, int variant, sim_shape *sh, char *err, size_t errlen)
{
    const char *kind = NULL;
    locd_status st = LOCD_OK;
    shape_req q;
    shape_builder build;
    int rc;
    memset(sh, 0, sizeof *sh);
    if (json_get_string(o, "shape", &kind) != 1)
        return bad(err, errlen, "missing \"shape\" (sphere, box, capsule, convex, rock, mesh, terrain)");
    sh->radius = 0.5;
    sh->half[0] = sh->half[1] = sh->half[2] = 0.5;
    if (json_get_number(o, "radius", &sh->radius) < 0 || json_get_vec(o, "half", sh->half, 3) < 0 ||
        json_get_number(o, "half_length", &sh->half[2]) < 0)
        return bad(err, errlen, "%s: radius, half [x, y, z] and half_length are numbers", kind);
    if (!(build = find_builder(kind)))
        return bad(err, errlen, "unknown shape \"%s\"", kind);
    q.o = o;
    q.variant = variant;
    q.sh = sh;
    q.err = err;
    q.errlen = errlen;
    rc = build(&q, &st);
    if (rc == 0 && st != LOCD_OK)
        rc = bad(err, errlen, "%s: %s", kind, locd_last_error());
    if (rc != 0)
        free_shape(sh); /* what the builder made before it failed */
    return rc;
}

/* Grows *p to n values; on failure *p stays (sim_scene_free frees it). */
static int grow_u64(uint64_t **p, size_t n)
{
    uint64_t *q = realloc(*p, n * sizeof(uint64_t));
    if (!q)
        return -1;
    *p = q;
    return 0;
}

static int grow_objects(sim_scene *s, size_t extra)
{
    size_t n = s->n + extra;
    /* Nothing to grow. realloc(p, 0) frees p and returns NULL on glibc, so
     * a generator of 0 objects after another one freed the arrays that
     * s still held: a double free at sim_scene_free (found by 42-fuzz). */
    if (extra == 0)
        return 0;
    double *poses = realloc(s->poses, 7 * n * sizeof(double));
    double *vel = poses ? realloc(s->vel, 6 * n * sizeof(double)) : NULL;
    uint8_t *dyn;
    uint32_t *sof;
    char **names;
    if (poses)
        s->poses = poses;
    if (vel)
        s->vel = vel;
    dyn = vel ? realloc(s->dynamic, n) : NULL;
    if (dyn)
        s->dynamic = dyn;
    sof = dyn ? realloc(s->shape_of, n * sizeof(uint32_t)) : NULL;
    if (sof)
        s->shape_of = sof;
    names = sof ? realloc(s->names, n * sizeof(char *)) : NULL;
    if (names)
        s->names = names;
    if (!names)
        return -1;
    if (grow_u64(&s->category, n) != 0 || grow_u64(&s->mask, n) != 0 || grow_u64(&s->group, n) != 0)
        return -1;
    {
        int32_t *ra = realloc(s->remove_at, n * sizeof(int32_t));
        if (!ra)
            return -1;
        s->remove_at = ra;
    }
    return 0;
}

/* Pose, velocity and flags shared by objects and generators. */
typedef struct placement {
    double pos[3], quat[4], vel[3], angular[3];
    int is_static;
    double category, mask, group, remove_at; /* mask < 0: all bits */
} placement;

static int read_placement(const json_value *o, placement *p, char *err, size_t errlen)
{
    memset(p, 0, sizeof *p);
    p->quat[3] = 1.0;
    p->category = 1;
    p->mask = -1;
    if (json_get_vec(o, "position", p->pos, 3) < 0 || json_get_vec(o, "orientation", p->quat, 4) < 0 ||
        json_get_vec(o, "velocity", p->vel, 3) < 0 || json_get_vec(o, "angular_velocity", p->angular, 3) < 0 ||
        json_get_bool(o, "static", &p->is_static) < 0)
        return bad(err, errlen, "position [3], orientation [x, y, z, w], velocity [3], static (bool)");
    if (json_get_number(o, "category", &p->category) < 0 || json_get_number(o, "mask", &p->mask) < 0 ||
        json_get_number(o, "group", &p->group) < 0 || json_get_number(o, "remove_at", &p->remove_at) < 0)
        return bad(err, errlen, "category, mask, group, remove_at are numbers");
    /* Filter bits as JSON numbers: integers below 2^53 (mask -1: all bits). */
    if (!is_whole_u53(p->category) || !(p->mask == -1 || is_whole_u53(p->mask)) || !is_whole_u53(p->group) ||
        !(p->remove_at >= 0 && p->remove_at <= 1e9 && p->remove_at == (double)(int32_t)p->remove_at))
        return bad(err, errlen, "category, group: integers 0..2^53; mask: -1 (all bits) or 0..2^53; "
                                "remove_at: a step number (0 = never)");
    return 0;
}

static void put_object(sim_scene *s, const placement *p, const double *pos, const double *vel, uint32_t shape,
                       const char *name)
{
    size_t i = s->n++;
    memcpy(s->poses + 7 * i, pos, 3 * sizeof(double));
    memcpy(s->poses + 7 * i + 3, p->quat, 4 * sizeof(double));
    memcpy(s->vel + 6 * i, vel, 3 * sizeof(double));
    memcpy(s->vel + 6 * i + 3, p->angular, 3 * sizeof(double));
    s->dynamic[i] = !p->is_static;
    if (p->is_static)
        memset(s->vel + 6 * i, 0, 6 * sizeof(double));
    s->shape_of[i] = shape;
    s->names[i] = name ? strdup(name) : NULL;
    s->category[i] = (uint64_t)p->category;
    s->mask[i] = p->mask < 0 ? ~(uint64_t)0 : (uint64_t)p->mask;
    s->group[i] = (uint64_t)p->group;
    s->remove_at[i] = (int32_t)p->remove_at;
    if (p->category != 1 || p->mask >= 0 || p->group != 0 || p->remove_at != 0)
        s->has_filters = 1;
}

static int read_name(const json_value *o, const char **name, char *err, size_t errlen)
{
    if (json_get_string(o, "name", name) < 0)
        return bad(err, errlen, "\"name\" is a string");
    return 0;
}

static int load_objects(const json_value *list, sim_scene *s, char *err, size_t errlen)
{
    size_t k;
    if (!list)
        return 0;
    if (list->type != JSON_ARRAY)
        return bad(err, errlen, "\"objects\" is a list");
    for (k = 0; k < list->count; k++) {
        const json_value *o = &list->items[k];
        sim_shape sh;
        placement p;
        const char *name = NULL;
        char sub[200];
        if (make_shape(o, 0, &sh, sub, sizeof sub) != 0)
            return bad(err, errlen, "objects[%zu]: %s", k, sub);
        if (read_placement(o, &p, sub, sizeof sub) != 0 || read_name(o, &name, sub, sizeof sub) != 0) {
            free_shape(&sh);
            return bad(err, errlen, "objects[%zu]: %s", k, sub);
        }
        if (add_shape(s, &sh) != 0) {
            free_shape(&sh);
            return bad(err, errlen, "out of memory");
        }
        if (grow_objects(s, 1) != 0)
            return bad(err, errlen, "out of memory");
        put_object(s, &p, p.pos, p.vel, (uint32_t)(s->nshapes - 1), name);
    }
    return 0;
}

/* A "generate" entry: how many objects, where, and how many shape variants. */
typedef struct generator {
    double count, lo[3], hi[3], grid[3], jitter, variants;
    uint64_t seed;
    const char *layout; /* "random" or "grid" */
} generator;

/* -1 (err set) when a member has the wrong type or is out of range. */
static int read_generator(const json_value *g, generator *gen, char *err, size_t errlen)
{
    static const generator defaults = {0, {0, 0, 0}, {1, 1, 1}, {0, 0, 0}, 0, 1, 1, "random"};
    *gen = defaults;
    if (json_get_number(g, "count", &gen->count) < 0 || json_get_vec(g, "min", gen->lo, 3) < 0 ||
        json_get_vec(g, "max", gen->hi, 3) < 0 || json_get_vec(g, "grid", gen->grid, 3) < 0 ||
        get_seed(g, &gen->seed) < 0 || json_get_number(g, "velocity_jitter", &gen->jitter) < 0 ||
        json_get_number(g, "variants", &gen->variants) < 0 || json_get_string(g, "layout", &gen->layout) < 0)
        return bad(err, errlen, "count, min, max, grid, seed (a whole number 0..2^53), velocity_jitter, variants, layout");
    if (!strcmp(gen->layout, "grid")) {
        int a;
        /* Whole cell counts of at least 1: a zero (or 0.5, read as 0) was
         * a division by zero when placing the objects (issue 18). */
        for (a = 0; a < 3; a++)
            if (!(gen->grid[a] >= 1 && gen->grid[a] <= 1e8 && gen->grid[a] == floor(gen->grid[a])))
                return bad(err, errlen, "grid is 3 whole numbers 1..1e8, got [%g, %g, %g]", gen->grid[0],
                           gen->grid[1], gen->grid[2]);
        gen->count = gen->grid[0] * gen->grid[1] * gen->grid[2];
    } else if (strcmp(gen->layout, "random") != 0) {
        return bad(err, errlen, "layout is \"random\" or \"grid\"");
    }
    if (!(gen->count >= 0 && gen->count <= 1e8) || !(gen->variants >= 1 && gen->variants <= 64))
        return bad(err, errlen, "count 0..1e8, variants 1..64");
    return 0;
}

/* Generator k's shape variants, added to the scene one after another. */
static int add_variants(const json_value *g, size_t k, const generator *gen, sim_scene *s, char *err, size_t errlen)
{
    char sub[200];
    int v;
    for (v = 0; v < (int)gen->variants; v++) {
        sim_shape sh;
        if (make_shape(g, v, &sh, sub, sizeof sub) != 0)
            return bad(err, errlen, "generate[%zu]: %s", k, sub);
        if (add_shape(s, &sh) != 0) {
            free_shape(&sh);
            return bad(err, errlen, "out of memory");
        }
    }
    return 0;
}

/* Object i's position: the centre of its grid cell, or uniform at random. */
static void generated_position(const generator *gen, size_t i, cli_rng *r, double *pos)
{
    int a;
    if (!strcmp(gen->layout, "grid")) {
        size_t gx = (size_t)gen->grid[0], gy = (size_t)gen->grid[1];
        size_t idx[3] = {i % gx, (i / gx) % gy, i / (gx * gy)};
        for (a = 0; a < 3; a++)
            pos[a] = gen->lo[a] + ((double)idx[a] + 0.5) * (gen->hi[a] - gen->lo[a]) / gen->grid[a];
    } else {
        for (a = 0; a < 3; a++)
            pos[a] = gen->lo[a] + (gen->hi[a] - gen->lo[a]) * cli_rng_uniform(r);
    }
}

/* The generator's objects, cycling through its variants from first_shape on. */
static void put_generated(sim_scene *s, const generator *gen, const placement *p, uint32_t first_shape)
{
    cli_rng r;
    size_t i;
    cli_rng_seed(&r, gen->seed);
    for (i = 0; i < (size_t)gen->count; i++) {
        double pos[3], vel[3];
        int a;
        generated_position(gen, i, &r, pos);
        for (a = 0; a < 3; a++)
            vel[a] = p->vel[a] + gen->jitter * cli_rng_normal(&r);
        put_object(s, p, pos, vel, first_shape + (uint32_t)(i % (size_t)gen->variants), NULL);
    }
}

static int load_generators(const json_value *list, sim_scene *s, char *err, size_t errlen)
{
    size_t k;
    if (!list)
        return 0;
    if (list->type != JSON_ARRAY)
        return bad(err, errlen, "\"generate\" is a list");
    for (k = 0; k < list->count; k++) {
        const json_value *g = &list->items[k];
        generator gen;
        placement p;
        uint32_t first_shape = (uint32_t)s->nshapes;
        char sub[200];
        if (read_generator(g, &gen, sub, sizeof sub) != 0 || read_placement(g, &p, sub, sizeof sub) != 0)
            return bad(err, errlen, "generate[%zu]: %s", k, sub);
        if (add_variants(g, k, &gen, s, err, errlen) != 0)
            return -1;
        if (grow_objects(s, (size_t)gen.count) != 0)
            return bad(err, errlen, "out of memory for %.0f objects", gen.count);
        put_generated(s, &gen, &p, first_shape);
    }
    return 0;
}

static int read_globals(const json_value *root, sim_scene *s, char *err, size_t errlen)
{
    const char *name = "scene", *cont = "auto";
    double steps = 100, threads = 0;
    s->dt = 1.0 / 60.0;
    s->gravity[2] = -9.81;
    s->restitution = 0.5;
    s->swept_threshold = 0.25;
    s->shape_tests = s->contacts = s->response = 1;
    if (json_get_string(root, "name", &name) < 0 || json_get_number(root, "dt", &s->dt) < 0 ||
        json_get_vec(root, "gravity", s->gravity, 3) < 0 || json_get_number(root, "restitution", &s->restitution) < 0 ||
        json_get_number(root, "swept_threshold", &s->swept_threshold) < 0 ||
        json_get_string(root, "continuous", &cont) < 0 || json_get_bool(root, "shape_tests", &s->shape_tests) < 0 ||
        json_get_bool(root, "contacts", &s->contacts) < 0 || json_get_bool(root, "response", &s->response) < 0 ||
        json_get_number(root, "steps", &steps) < 0 || json_get_number(root, "threads", &threads) < 0)
        return bad(err, errlen, "a top-level member has the wrong type (docs/pipeline.md lists them)");
    snprintf(s->name, sizeof s->name, "%s", name);
    if (!strcmp(cont, "on"))
        s->continuous = LOCD_SWEPT_ON;
    else if (!strcmp(cont, "off"))
        s->continuous = LOCD_SWEPT_OFF;
    else if (!strcmp(cont, "auto"))
        s->continuous = LOCD_SWEPT_AUTO;
    else
        return bad(err, errlen, "continuous is \"on\", \"off\" or \"auto\"");
    /* Upper bounds too: (int)1e300 is undefined (it gave -2147483648). */
    if (!(s->dt > 0) || !(steps >= 0 && steps <= INT_MAX) || !(threads >= 0 && threads <= 4096))
        return bad(err, errlen, "dt > 0, steps 0..%d, threads 0..4096", INT_MAX);
    s->steps = (int)steps;
    s->threads = (uint32_t)threads;
    return 0;
}

int sim_scene_load(const char *path, sim_scene *s, char *err, size_t errlen)
{
    char sub[256];
    json_value *root;
    int rc;
    memset(s, 0, sizeof *s);
    root = json_parse_file(path, sub, sizeof sub);
    if (!root)
        return bad(err, errlen, "%s: %s", path, sub);
    if (root->type != JSON_OBJECT) {
        json_free(root);
        return bad(err, errlen, "%s: the scene is a JSON object", path);
    }
    rc = read_globals(root, s, sub, sizeof sub);
    if (rc == 0)
        rc = load_objects(json_get(root, "objects"), s, sub, sizeof sub);
    if (rc == 0)
        rc = load_generators(json_get(root, "generate"), s, sub, sizeof sub);
    json_free(root);
    if (rc != 0) {
        sim_scene_free(s);
        return bad(err, errlen, "%s: %s", path, sub);
    }
    return 0;
}

void sim_scene_free(sim_scene *s)
{
    size_t i;
    for (i = 0; i < s->n; i++)
        free(s->names[i]);
    for (i = 0; i < s->nshapes; i++)
        free_shape(&s->shapes[i]);
    free(s->shapes);
    free(s->names);
    free(s->poses);
    free(s->vel);
    free(s->dynamic);
    free(s->shape_of);
    free(s->category);
    free(s->mask);
    free(s->group);
    free(s->remove_at);
    memset(s, 0, sizeof *s);
}
