// FCL glue: FCL geometry for locd shapes and FCL's discrete collision test,
// behind the C functions declared in narrow.h. No C++ type or exception
// crosses this file's boundary: every entry point catches everything.
#include "narrow/narrow.h"

#include <fcl/fcl.h>

#include <cstdio>
#include <exception>
#include <memory>
#include <new>
#include <vector>

struct lc_fcl_geom {
    std::shared_ptr<fcl::CollisionGeometryd> geom;
};

namespace {

void set_err(char *err, size_t len, const char *what)
{
    if (err && len)
        std::snprintf(err, len, "%s", what);
}

std::shared_ptr<fcl::CollisionGeometryd> make_geometry(const locd_shape *s)
{
    switch (s->kind) {
    case LOCD_SHAPE_SPHERE:
        return std::make_shared<fcl::Sphered>(s->radius);
    case LOCD_SHAPE_BOX:
        return std::make_shared<fcl::Boxd>(2.0 * s->half[0], 2.0 * s->half[1], 2.0 * s->half[2]);
    case LOCD_SHAPE_CAPSULE:
        return std::make_shared<fcl::Capsuled>(s->radius, 2.0 * s->half[2]);
    case LOCD_SHAPE_MESH: {
        auto model = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
        std::vector<fcl::Vector3d> v(s->npoints);
        std::vector<fcl::Triangle> t(s->ntris);
        for (size_t i = 0; i < s->npoints; i++)
            v[i] = fcl::Vector3d(s->points[3 * i], s->points[3 * i + 1], s->points[3 * i + 2]);
        for (size_t i = 0; i < s->ntris; i++)
            t[i] = fcl::Triangle(s->tris[3 * i], s->tris[3 * i + 1], s->tris[3 * i + 2]);
        if (model->beginModel(static_cast<int>(s->ntris), static_cast<int>(s->npoints)) != fcl::BVH_OK ||
            model->addSubModel(v, t) != fcl::BVH_OK || model->endModel() != fcl::BVH_OK)
            return nullptr;
        model->computeLocalAABB();
        return model;
    }
    default:
        return nullptr;
    }
}

fcl::Transform3d to_transform(const lc_placed *p)
{
    fcl::Matrix3d r;
    r << p->R[0], p->R[1], p->R[2], p->R[3], p->R[4], p->R[5], p->R[6], p->R[7], p->R[8];
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    tf.linear() = r;
    tf.translation() = fcl::Vector3d(p->t[0], p->t[1], p->t[2]);
    return tf;
}

} // namespace

extern "C" lc_fcl_geom *lc_fcl_make(const locd_shape *s, char *err, size_t errlen)
{
    try {
        auto g = make_geometry(s);
        if (!g) {
            set_err(err, errlen, "FCL cannot represent this shape");
            return nullptr;
        }
        g->computeLocalAABB();
        return new lc_fcl_geom{g};
    } catch (const std::exception &e) {
        set_err(err, errlen, e.what());
    } catch (...) {
        set_err(err, errlen, "unknown C++ exception");
    }
    return nullptr;
}

extern "C" void lc_fcl_free(lc_fcl_geom *g)
{
    delete g; // destructors of FCL geometry do not throw
}

extern "C" int lc_fcl_test(const lc_placed *a, const lc_placed *b, int want_contact, lc_contact *c, char *err,
                           size_t errlen)
{
    try {
        if (!a->s->fcl || !b->s->fcl) {
            set_err(err, errlen, "shape has no FCL geometry");
            return -1;
        }
        fcl::CollisionRequestd request(1, want_contact != 0);
        fcl::CollisionResultd result;
        fcl::collide(a->s->fcl->geom.get(), to_transform(a), b->s->fcl->geom.get(), to_transform(b), request, result);
        if (!result.isCollision())
            return 0;
        if (want_contact) {
            if (result.numContacts() == 0) {
                set_err(err, errlen, "FCL reported a collision without contact data");
                return -1;
            }
            const fcl::Contactd &k = result.getContact(0);
            c->depth = k.penetration_depth;
            for (int i = 0; i < 3; i++) {
                c->normal[i] = k.normal[i];
                c->point[i] = k.pos[i];
            }
        }
        return 1;
    } catch (const std::exception &e) {
        set_err(err, errlen, e.what());
    } catch (...) {
        set_err(err, errlen, "unknown C++ exception");
    }
    return -1;
}
