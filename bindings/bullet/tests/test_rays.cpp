// btCollisionWorld::rayTest (closest and all hits) and convexSweepTest on
// locd::BulletBroadphase give what a brute force over every object's
// rayTestSingle / objectQuerySingle gives, at several steps of a heap of
// boxes, spheres and convex hulls falling into a static bowl.
#include "world.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <utility>

using namespace locd_test;

namespace {

typedef std::vector<std::pair<int, btScalar>> Hits; // (userIndex, fraction), sorted

btTransform at(const btVector3 &p, const btQuaternion &q = btQuaternion::getIdentity()) { return btTransform(q, p); }

// Whether the segment from..to meets the box lo - grow .. hi + grow (closed,
// in double). Bullet's rayTestSingle can report a hit on a convex hull whose
// point lies well outside the hull's AABB (seen: 0.67 off); a broad phase
// rightly never offers an object whose AABB the segment misses, so the brute
// force skips such hits. The AABB is the proxy's (the shape's, grown by
// Bullet's contact threshold and, for moving bodies, their motion), brought
// up to date by updateAabbs before the queries.
bool meets(btVector3 lo, btVector3 hi, const btVector3 &from, const btVector3 &to, double grow)
{
    double l[3], h[3];
    for (int k = 0; k < 3; k++)
        l[k] = lo[k] - grow, h[k] = hi[k] + grow;
    return locd_test::segment_entry(l, h, from, to) >= 0;
}

bool meets(const btCollisionObject *o, const btVector3 &from, const btVector3 &to, double grow)
{
    const btBroadphaseProxy *p = o->getBroadphaseHandle();
    return meets(p->m_aabbMin, p->m_aabbMax, from, to, grow);
}

// The closest fraction over every object (2 = none), and each object's own.
btScalar brute_closest(btCollisionWorld *w, const btVector3 &from, const btVector3 &to, std::vector<btScalar> &own)
{
    btScalar best = 2;
    own.assign(w->getNumCollisionObjects(), 2);
    for (int k = 0; k < w->getNumCollisionObjects(); k++) {
        btCollisionObject *o = w->getCollisionObjectArray()[k];
        btCollisionWorld::ClosestRayResultCallback cb(from, to);
        if (!cb.needsCollision(o->getBroadphaseHandle()))
            continue;
        btCollisionWorld::rayTestSingle(at(from), at(to), o, o->getCollisionShape(), o->getWorldTransform(), cb);
        if (cb.hasHit() && meets(o, from, to, 0)) {
            own[k] = cb.m_closestHitFraction;
            best = std::min(best, cb.m_closestHitFraction);
        }
    }
    return best;
}

Hits brute_all(btCollisionWorld *w, const btVector3 &from, const btVector3 &to)
{
    Hits out;
    for (int k = 0; k < w->getNumCollisionObjects(); k++) {
        btCollisionObject *o = w->getCollisionObjectArray()[k];
        btCollisionWorld::AllHitsRayResultCallback cb(from, to);
        if (!cb.needsCollision(o->getBroadphaseHandle()))
            continue;
        btCollisionWorld::rayTestSingle(at(from), at(to), o, o->getCollisionShape(), o->getWorldTransform(), cb);
        if (!meets(o, from, to, 0))
            continue;
        for (int i = 0; i < cb.m_hitFractions.size(); i++)
            out.push_back({o->getUserIndex(), cb.m_hitFractions[i]});
    }
    std::sort(out.begin(), out.end());
    return out;
}

btScalar brute_sweep(btCollisionWorld *w, const btConvexShape *shape, const btTransform &from, const btTransform &to,
                     std::vector<btScalar> &own)
{
    btScalar best = 2;
    own.assign(w->getNumCollisionObjects(), 2);
    for (int k = 0; k < w->getNumCollisionObjects(); k++) {
        btCollisionObject *o = w->getCollisionObjectArray()[k];
        btCollisionWorld::ClosestConvexResultCallback cb(from.getOrigin(), to.getOrigin());
        if (!cb.needsCollision(o->getBroadphaseHandle()))
            continue;
        btCollisionWorld::objectQuerySingle(shape, from, to, o, o->getCollisionShape(), o->getWorldTransform(), cb, 0);
        // The cast shape's box about its origin, as convexSweepTest computes
        // it (one rotation from start to end): the object's AABB grown by it.
        btVector3 smin, smax;
        btTransform r(from.getRotation());
        shape->getAabb(r, smin, smax);
        const btBroadphaseProxy *p = o->getBroadphaseHandle();
        if (cb.hasHit() && meets(p->m_aabbMin - smax, p->m_aabbMax - smin, from.getOrigin(), to.getOrigin(), 0)) {
            own[k] = cb.m_closestHitFraction;
            best = std::min(best, cb.m_closestHitFraction);
        }
    }
    return best;
}

int index_of(btCollisionWorld *w, const btCollisionObject *o)
{
    return w->getCollisionObjectArray().findLinearSearch(const_cast<btCollisionObject *>(o));
}

// One segment from a random point to another, in or above the heap.
void segment(Rng &r, double w, btVector3 &from, btVector3 &to)
{
    int kind = r.below(3);
    if (kind == 0) { // down from above
        from = btVector3(r.uniform(-w, w), r.uniform(10, 20), r.uniform(-w, w));
        to = btVector3(r.uniform(-w, w), r.uniform(-1, 2), r.uniform(-w, w));
    } else if (kind == 1) { // across, through the heap
        from = btVector3(-w - 3, r.uniform(0, 6), r.uniform(-w, w));
        to = btVector3(w + 3, r.uniform(0, 6), r.uniform(-w, w));
    } else { // short, starting inside
        from = btVector3(r.uniform(-w, w), r.uniform(0, 5), r.uniform(-w, w));
        to = from + btVector3(r.uniform(-3, 3), r.uniform(-3, 3), r.uniform(-3, 3));
    }
}

// Rays, all hits and sweeps at three steps of a falling heap on one broad phase.
void check_world(Tap &tap, Broadphase kind, int n, int rays)
{
    double w = 10;
    World world(kind, 2, w);
    world.bowl(w);
    Rng r(11);
    world.drop_many(n, w, 1.0, r);
    btCollisionWorld *cw = world.world.get();
    btSphereShape ball(0.4);
    btBoxShape brick(btVector3(0.6, 0.2, 0.3));
    int step = 0;
    for (int check : {1, 40, 120}) {
        while (step < check) {
            world.step();
            step++;
        }
        // The proxies' AABBs are those of the step's start: the bodies have
        // moved since. Brought up to date here (setAabb, then the query's
        // flush), so that the brute force and the broad phase see one world.
        cw->updateAabbs();
        int bad_closest = 0, bad_all = 0, bad_sweep = 0, hits = 0, sweeps_hit = 0;
        std::vector<btScalar> own;
        for (int q = 0; q < rays; q++) {
            btVector3 from, to;
            segment(r, w, from, to);
            // Closest.
            btCollisionWorld::ClosestRayResultCallback cc(from, to);
            cw->rayTest(from, to, cc);
            btScalar best = brute_closest(cw, from, to, own);
            bool ok = cc.hasHit() == (best <= 1);
            if (ok && cc.hasHit()) {
                hits++;
                int k = index_of(cw, cc.m_collisionObject);
                ok = cc.m_closestHitFraction == best && k >= 0 && own[k] == best;
            }
            if (!ok && bad_closest++ == 0)
                std::printf("# step %d ray %d: closest %g (hit %d), brute force %g\n", step, q,
                            (double)cc.m_closestHitFraction, (int)cc.hasHit(), (double)best);
            // All hits.
            btCollisionWorld::AllHitsRayResultCallback ac(from, to);
            cw->rayTest(from, to, ac);
            Hits got;
            for (int i = 0; i < ac.m_hitFractions.size(); i++)
                got.push_back({ac.m_collisionObjects[i]->getUserIndex(), ac.m_hitFractions[i]});
            std::sort(got.begin(), got.end());
            Hits want = brute_all(cw, from, to);
            if (got != want && bad_all++ == 0) {
                std::printf("# step %d ray %d: %zu hits, brute force %zu\n", step, q, got.size(), want.size());
                Hits miss, extra;
                std::set_difference(want.begin(), want.end(), got.begin(), got.end(), std::back_inserter(miss));
                std::set_difference(got.begin(), got.end(), want.begin(), want.end(), std::back_inserter(extra));
                for (auto &h : miss)
                    std::printf("#   missing: body %d at %.9g\n", h.first, (double)h.second);
                for (auto &h : extra)
                    std::printf("#   extra: body %d at %.9g\n", h.first, (double)h.second);
                std::printf("#   from %.9g %.9g %.9g to %.9g %.9g %.9g\n", from[0], from[1], from[2], to[0], to[1], to[2]);
                for (int k = 0; k < cw->getNumCollisionObjects(); k++) {
                    btCollisionObject *o = cw->getCollisionObjectArray()[k];
                    for (auto &h : miss)
                        if (o->getUserIndex() == h.first) {
                            const btBroadphaseProxy *p = o->getBroadphaseHandle();
                            std::printf("#   its aabb %.9g %.9g %.9g .. %.9g %.9g %.9g\n", p->m_aabbMin[0], p->m_aabbMin[1], p->m_aabbMin[2], p->m_aabbMax[0], p->m_aabbMax[1], p->m_aabbMax[2]);
                        }
                }
            }
            // A convex sweep: a ball, or a tilted brick.
            const btConvexShape *shape = q % 2 ? (const btConvexShape *)&ball : &brick;
            btQuaternion tilt(btVector3(1, 2, 3).normalized(), 0.1 * q);
            btTransform tf = at(from, tilt), tt = at(to, tilt);
            btCollisionWorld::ClosestConvexResultCallback sc(from, to);
            cw->convexSweepTest(shape, tf, tt, sc, 0);
            best = brute_sweep(cw, shape, tf, tt, own);
            ok = sc.hasHit() == (best <= 1);
            if (ok && sc.hasHit()) {
                sweeps_hit++;
                int k = index_of(cw, sc.m_hitCollisionObject);
                ok = sc.m_closestHitFraction == best && k >= 0 && own[k] == best;
            }
            if (!ok && bad_sweep++ == 0)
                std::printf("# step %d sweep %d: closest %g (hit %d), brute force %g\n", step, q,
                            (double)sc.m_closestHitFraction, (int)sc.hasHit(), (double)best);
        }
        char what[200];
        const char *name = name_of(kind);
        std::snprintf(what, sizeof what, "%s, step %d: ClosestRayResultCallback == brute force (%d rays, %d hit)", name,
                      step, rays, hits);
        tap.ok(bad_closest == 0 && hits > 0, what);
        std::snprintf(what, sizeof what, "%s, step %d: AllHitsRayResultCallback == brute force (%d rays)", name, step, rays);
        tap.ok(bad_all == 0, what);
        std::snprintf(what, sizeof what, "%s, step %d: convexSweepTest closest == brute force (%d sweeps, %d hit)", name,
                      step, rays, sweeps_hit);
        tap.ok(bad_sweep == 0 && sweeps_hit > 0, what);
    }
}

} // namespace

// The grown boxes of a margin offer more proxies; the narrow phase must
// still find exactly the brute force's hits.
int main(int argc, char **argv)
{
    int n = argc > 1 ? std::atoi(argv[1]) : heavy() ? 1500 : 500;
    int rays = argc > 2 ? std::atoi(argv[2]) : heavy() ? 150 : 50;
    Tap tap;
    check_world(tap, Broadphase::locd, n, rays);
    check_world(tap, Broadphase::locd_margin, n, rays);
    return tap.done();
}
