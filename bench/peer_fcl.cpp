// FCL 0.7 broad-phase managers as benchmark peers.
//
// Each box becomes a CollisionObject holding an fcl::Box posed at the box's
// center. FCL computes the object's AABB from that pose; we then set it to the
// input box exactly (float -> double is exact), so that any difference from
// locd's pair set comes from the manager, not from FCL's transform arithmetic.
// FCL's AABB::overlap is a closed test (min > other.max means apart).
#include "peers.h"

#include <fcl/broadphase/broadphase_SSaP.h>
#include <fcl/broadphase/broadphase_SaP.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree_array.h>
#include <fcl/broadphase/broadphase_interval_tree.h>
#include <fcl/geometry/shape/box.h>

#include <cstdio>
#include <exception>
#include <memory>

namespace {

class box_object : public fcl::CollisionObjectd {
public:
    box_object(const std::shared_ptr<fcl::CollisionGeometryd> &g, const fcl::Transform3d &tf, const float *b)
        : fcl::CollisionObjectd(g, tf)
    {
        aabb.min_ = fcl::Vector3d(b[0], b[1], b[2]);
        aabb.max_ = fcl::Vector3d(b[3], b[4], b[5]);
    }
};

bool collect(fcl::CollisionObjectd *a, fcl::CollisionObjectd *b, void *data)
{
    auto *out = static_cast<peer_pairs *>(data);
    out->push_back(peer_pair((std::uint32_t)(std::uintptr_t)a->getUserData(),
                             (std::uint32_t)(std::uintptr_t)b->getUserData()));
    return false; // keep going
}

template <class Manager>
int run_fcl(const peer_scene &s, peer_pairs &out, peer_times &t, char *err, std::size_t errlen)
{
    try {
        double t0 = peer_now_ms();
        std::vector<std::unique_ptr<box_object>> objs;
        std::vector<fcl::CollisionObjectd *> ptrs(s.n);
        objs.reserve(s.n);
        for (std::size_t i = 0; i < s.n; i++) {
            const float *b = s.b + 6 * i;
            auto geom = std::make_shared<fcl::Boxd>((double)b[3] - b[0], (double)b[4] - b[1], (double)b[5] - b[2]);
            fcl::Transform3d tf = fcl::Transform3d::Identity();
            tf.translation() = fcl::Vector3d(0.5 * ((double)b[0] + b[3]), 0.5 * ((double)b[1] + b[4]),
                                             0.5 * ((double)b[2] + b[5]));
            objs.emplace_back(new box_object(geom, tf, b));
            objs.back()->setUserData((void *)(std::uintptr_t)i);
            ptrs[i] = objs.back().get();
        }
        double t1 = peer_now_ms();
        {
            Manager m;
            m.registerObjects(ptrs);
            m.setup();
            double t2 = peer_now_ms();
            m.collide(&out, collect);
            double t3 = peer_now_ms();
            t.prep_ms = t1 - t0;
            t.setup_ms = t2 - t1;
            t.query_ms = t3 - t2;
        }
        return 0;
    } catch (const std::exception &e) {
        std::snprintf(err, errlen, "FCL threw: %s", e.what());
    } catch (...) {
        std::snprintf(err, errlen, "FCL threw an unknown exception");
    }
    return 1;
}

} // namespace

int peer_fcl_dynamic_aabb_tree(const peer_scene &s, peer_pairs &o, peer_times &t, char *e, std::size_t l)
{
    return run_fcl<fcl::DynamicAABBTreeCollisionManager<double>>(s, o, t, e, l);
}

int peer_fcl_dynamic_aabb_tree_array(const peer_scene &s, peer_pairs &o, peer_times &t, char *e, std::size_t l)
{
    return run_fcl<fcl::DynamicAABBTreeCollisionManager_Array<double>>(s, o, t, e, l);
}

int peer_fcl_sap(const peer_scene &s, peer_pairs &o, peer_times &t, char *e, std::size_t l)
{
    return run_fcl<fcl::SaPCollisionManager<double>>(s, o, t, e, l);
}

int peer_fcl_ssap(const peer_scene &s, peer_pairs &o, peer_times &t, char *e, std::size_t l)
{
    return run_fcl<fcl::SSaPCollisionManager<double>>(s, o, t, e, l);
}

int peer_fcl_interval_tree(const peer_scene &s, peer_pairs &o, peer_times &t, char *e, std::size_t l)
{
    return run_fcl<fcl::IntervalTreeCollisionManager<double>>(s, o, t, e, l);
}
