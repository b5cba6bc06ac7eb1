// After every step, the pair cache of a world on locd::BulletBroadphase is
// the brute force over the proxies' current AABBs (with a margin: over the
// grown boxes the scene holds, each around its AABB): closed intervals,
// Bullet's filter rule, and the user's btOverlapFilterCallback. A few
// thousand boxes, spheres and convex hulls fall into a static bowl; debris
// ignore each other; bodies are removed and added as they fall. At 1 and 2
// threads, and with btDbvtBroadphase's margin at 2.
#include "world.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <utility>

using namespace locd_test;

namespace {

// Bodies whose userIndex is 3 mod 7 do not pair with one another (beyond
// Bullet's rule, which a callback replaces).
bool special(const btBroadphaseProxy *p)
{
    auto *o = static_cast<const btCollisionObject *>(p->m_clientObject);
    return o->getUserIndex() % 7 == 3;
}

bool rule(const btBroadphaseProxy *a, const btBroadphaseProxy *b)
{
    return (a->m_collisionFilterGroup & b->m_collisionFilterMask) != 0 &&
           (b->m_collisionFilterGroup & a->m_collisionFilterMask) != 0;
}

struct Filter : btOverlapFilterCallback {
    bool needBroadphaseCollision(btBroadphaseProxy *a, btBroadphaseProxy *b) const override
    {
        return rule(a, b) && !(special(a) && special(b));
    }
};

// A proxy and the box it pairs by: its AABB, or with a margin the box the
// scene holds (which must contain the AABB).
struct Held {
    btBroadphaseProxy *p;
    btVector3 lo, hi;
};

bool overlap(const Held &a, const Held &b)
{
    for (int k = 0; k < 3; k++)
        if (a.hi[k] < b.lo[k] || b.hi[k] < a.lo[k])
            return false;
    return true;
}

typedef std::vector<std::pair<int, int>> Pairs; // unique ids, first < second, sorted

// Also counts the held boxes that fail to contain their AABB.
Pairs brute(btCollisionWorld *w, const locd::BulletBroadphase &bp, bool grown, const Filter &f, int &outside)
{
    std::vector<Held> hs;
    for (int k = 0; k < w->getNumCollisionObjects(); k++) {
        btBroadphaseProxy *p = w->getCollisionObjectArray()[k]->getBroadphaseHandle();
        Held h{p, p->m_aabbMin, p->m_aabbMax};
        if (grown && !bp.sceneAabb(p, h.lo, h.hi))
            outside++;
        for (int a = 0; a < 3; a++)
            outside += !(h.lo[a] <= p->m_aabbMin[a] && p->m_aabbMax[a] <= h.hi[a]);
        hs.push_back(h);
    }
    // Sorted on min x: a sweep, each pair tested exactly.
    std::sort(hs.begin(), hs.end(), [](const Held &a, const Held &b) { return a.lo[0] < b.lo[0]; });
    Pairs out;
    for (size_t i = 0; i < hs.size(); i++)
        for (size_t j = i + 1; j < hs.size() && hs[j].lo[0] <= hs[i].hi[0]; j++)
            if (overlap(hs[i], hs[j]) && f.needBroadphaseCollision(hs[i].p, hs[j].p))
                out.push_back(std::minmax(hs[i].p->m_uniqueId, hs[j].p->m_uniqueId));
    std::sort(out.begin(), out.end());
    return out;
}

Pairs cached(btCollisionWorld *w)
{
    Pairs out;
    btOverlappingPairCache *c = w->getPairCache();
    for (int k = 0; k < c->getNumOverlappingPairs(); k++) {
        const btBroadphasePair &p = c->getOverlappingPairArray()[k];
        out.push_back(std::minmax(p.m_pProxy0->m_uniqueId, p.m_pProxy1->m_uniqueId));
    }
    std::sort(out.begin(), out.end());
    return out;
}

std::string first_difference(const Pairs &want, const Pairs &got)
{
    Pairs miss, extra;
    std::set_difference(want.begin(), want.end(), got.begin(), got.end(), std::back_inserter(miss));
    std::set_difference(got.begin(), got.end(), want.begin(), want.end(), std::back_inserter(extra));
    char buf[200];
    std::snprintf(buf, sizeof buf, "%zu missing (first %d-%d), %zu extra (first %d-%d)", miss.size(),
                  miss.empty() ? 0 : miss[0].first, miss.empty() ? 0 : miss[0].second, extra.size(),
                  extra.empty() ? 0 : extra[0].first, extra.empty() ? 0 : extra[0].second);
    return buf;
}

void run(Tap &tap, Broadphase kind, unsigned threads, int n, int steps)
{
    double w = 15;
    World world(kind, threads, w);
    auto *bp = static_cast<locd::BulletBroadphase *>(world.broadphase.get());
    bool grown = kind == Broadphase::locd_margin;
    int outside = 0;
    Filter filter;
    world.world->getPairCache()->setOverlapFilterCallback(&filter);
    world.bowl(w);
    Rng r(7 + threads);
    world.drop_many(n, w, 1.0, r);
    int bad_step = -1;
    std::string why;
    size_t most = 0, total = 0;
    for (int s = 0; s < steps; s++) {
        world.step();
        Pairs want = brute(world.world.get(), *bp, grown, filter, outside), got = cached(world.world.get());
        most = std::max(most, want.size());
        total += want.size();
        if (want != got && bad_step < 0) {
            bad_step = s;
            why = first_difference(want, got);
        }
        // Mid-run: 2% of the bodies go, as many new ones drop in.
        if (s % 15 == 7) {
            int k = n / 50;
            for (int i = 0; i < k && !world.bodies.empty(); i++) {
                size_t at = (size_t)r.below((int)world.bodies.size());
                world.remove(world.bodies[at]);
                world.bodies[at] = world.bodies.back();
                world.bodies.pop_back();
            }
            for (int i = 0; i < k; i++)
                world.drop(world.next_index, btVector3(r.uniform(-w + 1, w - 1), 14 + r.uniform(0, 4), r.uniform(-w + 1, w - 1)), r);
        }
    }
    char what[300];
    std::snprintf(what, sizeof what, "%s, %d threads: %d bodies, %d steps, pair cache == brute force over the %s "
                  "after every step (up to %zu pairs, %zu in all)", name_of(kind), threads, n, steps,
                  grown ? "grown boxes" : "AABBs", most, total);
    if (bad_step >= 0)
        std::printf("# step %d: %s\n", bad_step, why.c_str());
    tap.ok(bad_step < 0 && outside == 0 && total > 0, what);
    tap.ok(bp->stats().misuse == 0, "no bad use counted");
}

} // namespace

int main(int argc, char **argv)
{
    // Past 4,096 objects, so that the scene's update runs on 2 threads
    // (the level-1 engine runs one below that).
    int n = argc > 1 ? std::atoi(argv[1]) : 4200;
    int steps = argc > 2 ? std::atoi(argv[2]) : heavy() ? 100 : 25;
    Tap tap;
    run(tap, Broadphase::locd, 1, n, steps);
    run(tap, Broadphase::locd, 2, n, steps);
    run(tap, Broadphase::locd_margin, 2, n, steps);
    return tap.done();
}
