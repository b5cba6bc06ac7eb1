// locd::BulletBroadphase: rayTest and aabbTest on the scene's queries.
#include "impl.hpp"

#include <cmath>

namespace locd {

namespace {

// Runs a query into ids (and t), growing the buffers while the scene says
// they are too small.
template <class Query>
locd_status run(Query q, std::vector<locd_id> &ids, std::vector<double> *t, size_t &count)
{
    for (;;) {
        if (ids.size() < 64)
            ids.resize(64);
        if (t && t->size() < ids.size())
            t->resize(ids.size());
        locd_status s = q(ids.data(), t ? t->data() : nullptr, ids.size(), &count);
        if (s != LOCD_ERR_BUFFER_TOO_SMALL)
            return s;
        ids.resize(count + count / 2);
    }
}

struct Buffers {
    std::vector<locd_id> ids;
    std::vector<double> t;
};

} // namespace

void BulletBroadphase::rayTest(const btVector3 &rayFrom, const btVector3 &rayTo, btBroadphaseRayCallback &rayCallback,
                               const btVector3 &aabbMin, const btVector3 &aabbMax)
{
    Impl &m = *impl_;
    m.flush();
    double lambda = rayCallback.m_lambda_max;
    if (!(lambda >= 0))
        return;
    // In float64 from Bullet's floats: the segment is exactly rayFrom..rayTo.
    double origin[3], dir[3], box[6];
    for (int k = 0; k < 3; k++) {
        origin[k] = rayFrom[k];
        dir[k] = (double)rayTo[k] - (double)rayFrom[k];
        box[k] = (double)rayFrom[k] + (double)aabbMin[k];
        box[3 + k] = (double)rayFrom[k] + (double)aabbMax[k];
    }
    bool sweep = !(aabbMin.isZero() && aabbMax.isZero());
    Buffers own;
    bool nested = m.in_query;
    std::vector<locd_id> &ids = nested ? own.ids : m.hit_ids;
    std::vector<double> &t = nested ? own.t : m.hit_t;
    size_t count = 0;
    locd_status s = run(
        [&](locd_id *io, double *to, size_t cap, size_t *c) {
            return sweep ? locd_scene_cast_box_f64(m.scene, box, dir, lambda, LOCD_HIT_ALL, nullptr, io, to, cap, c)
                         : locd_scene_cast_ray_f64(m.scene, origin, dir, lambda, LOCD_HIT_ALL, nullptr, io, to, cap, c);
        },
        ids, &t, count);
    if (s != LOCD_OK)
        return;
    m.in_query = true;
    // By entry t: the callback's narrow phase shrinks m_lambda_max as it
    // finds closer hits; a box entered past it cannot hold a closer one.
    for (size_t k = 0; k < count; k++) {
        if (t[k] > (double)rayCallback.m_lambda_max)
            break;
        if (BulletProxy *p = m.proxy_of(ids[k]))
            rayCallback.process(p);
    }
    m.in_query = nested;
}

void BulletBroadphase::aabbTest(const btVector3 &aabbMin, const btVector3 &aabbMax, btBroadphaseAabbCallback &callback)
{
    Impl &m = *impl_;
    m.flush();
    double box[6];
    for (int k = 0; k < 3; k++) {
        box[k] = aabbMin[k];
        box[3 + k] = aabbMax[k];
    }
    Buffers own;
    bool nested = m.in_query;
    std::vector<locd_id> &ids = nested ? own.ids : m.hit_ids;
    size_t count = 0;
    locd_status s = run(
        [&](locd_id *io, double *, size_t cap, size_t *c) {
            return locd_scene_overlap_box_f64(m.scene, box, nullptr, io, cap, c);
        },
        ids, nullptr, count);
    if (s != LOCD_OK)
        return;
    m.in_query = true;
    for (size_t k = 0; k < count; k++)
        if (BulletProxy *p = m.proxy_of(ids[k]))
            callback.process(p);
    m.in_query = nested;
}

} // namespace locd
