/* The filter pipeline's public functions in a build without libccd and FCL
 * (meson -Dnarrow=disabled, or the libraries missing): they exist so that
 * the ABI does not depend on build options, and say why they cannot work.
 * Option and statistics initializers (options.c) still work. */
#include "core/core.h"
#include "locd/pipeline.h"

#define NO_NARROW() \
    lc_error(LOCD_ERR_UNSUPPORTED, "this locd was built without the narrow phase (libccd and FCL; meson -Dnarrow)")

static locd_status no_shape(locd_shape **out)
{
    if (out)
        *out = NULL;
    return NO_NARROW();
}

locd_status locd_shape_sphere(double radius, locd_shape **out)
{
    (void)radius;
    return no_shape(out);
}

locd_status locd_shape_box(double hx, double hy, double hz, locd_shape **out)
{
    (void)hx, (void)hy, (void)hz;
    return no_shape(out);
}

locd_status locd_shape_capsule(double radius, double half_length, locd_shape **out)
{
    (void)radius, (void)half_length;
    return no_shape(out);
}

locd_status locd_shape_convex(const double *points, size_t count, locd_shape **out)
{
    (void)points, (void)count;
    return no_shape(out);
}

locd_status locd_shape_mesh(const double *v, size_t nv, const uint32_t *t, size_t nt, locd_shape **out)
{
    (void)v, (void)nv, (void)t, (void)nt;
    return no_shape(out);
}

void locd_shape_destroy(locd_shape *shape)
{
    (void)shape;
}

int32_t locd_shape_kind(const locd_shape *shape)
{
    (void)shape;
    return 0;
}

locd_status locd_shape_aabb(const locd_shape *shape, const double *pose, double *box)
{
    (void)shape, (void)pose, (void)box;
    return NO_NARROW();
}

locd_status locd_shape_collide(const locd_shape *a, const double *pa, const locd_shape *b, const double *pb,
                               int32_t route, int32_t method, int32_t *hit, double *contact)
{
    (void)a, (void)pa, (void)b, (void)pb, (void)route, (void)method, (void)hit, (void)contact;
    return NO_NARROW();
}

locd_status locd_contacts_create(locd_contacts **out)
{
    if (out)
        *out = NULL;
    return NO_NARROW();
}

void locd_contacts_destroy(locd_contacts *c)
{
    (void)c;
}

size_t locd_contacts_count(const locd_contacts *c)
{
    (void)c;
    return 0;
}

const uint32_t *locd_contacts_pairs(const locd_contacts *c)
{
    (void)c;
    return NULL;
}

const double *locd_contacts_toi(const locd_contacts *c)
{
    (void)c;
    return NULL;
}

const double *locd_contacts_depth(const locd_contacts *c)
{
    (void)c;
    return NULL;
}

const double *locd_contacts_normal(const locd_contacts *c)
{
    (void)c;
    return NULL;
}

const double *locd_contacts_point(const locd_contacts *c)
{
    (void)c;
    return NULL;
}

locd_status locd_world_create(const locd_engine_config *config, locd_world **out)
{
    (void)config;
    if (out)
        *out = NULL;
    return NO_NARROW();
}

void locd_world_destroy(locd_world *w)
{
    (void)w;
}

locd_status locd_world_add(locd_world *w, locd_shape *s, const double *pose, const double *vel, uint32_t *index)
{
    (void)w, (void)s, (void)pose, (void)vel, (void)index;
    return NO_NARROW();
}

size_t locd_world_count(const locd_world *w)
{
    (void)w;
    return 0;
}

locd_status locd_world_set_pose(locd_world *w, uint32_t index, const double *pose)
{
    (void)w, (void)index, (void)pose;
    return NO_NARROW();
}

locd_status locd_world_set_velocity(locd_world *w, uint32_t index, const double *v)
{
    (void)w, (void)index, (void)v;
    return NO_NARROW();
}

locd_status locd_world_set_poses(locd_world *w, const double *poses, size_t count)
{
    (void)w, (void)poses, (void)count;
    return NO_NARROW();
}

locd_status locd_world_set_velocities(locd_world *w, const double *v, size_t count)
{
    (void)w, (void)v, (void)count;
    return NO_NARROW();
}

locd_status locd_world_get_pose(const locd_world *w, uint32_t index, double *pose)
{
    (void)w, (void)index, (void)pose;
    return NO_NARROW();
}

locd_status locd_world_collide(locd_world *w, const locd_pipeline_options *o, locd_contacts *out,
                               locd_pipeline_stats *stats)
{
    (void)w, (void)o, (void)out, (void)stats;
    return NO_NARROW();
}

locd_status locd_world_remove(locd_world *w, uint32_t index)
{
    (void)w, (void)index;
    return NO_NARROW();
}

locd_status locd_world_set_filter(locd_world *w, uint32_t index, uint64_t category, uint64_t mask, uint64_t group)
{
    (void)w, (void)index, (void)category, (void)mask, (void)group;
    return NO_NARROW();
}

locd_status locd_world_contact_events(const locd_world *w, const uint32_t **began, size_t *began_count,
                                      const uint32_t **ended, size_t *ended_count)
{
    (void)w, (void)began, (void)began_count, (void)ended, (void)ended_count;
    return NO_NARROW();
}
