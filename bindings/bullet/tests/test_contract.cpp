// locd::BulletBroadphase called directly: closed intervals, the filter
// mapping (int groups, static proxies), a user filter asked again on a move,
// batching (getAabb, queries before an update), the queries against brute
// force over the proxies, and bad use ignored (release builds; debug builds
// assert, so that part is skipped there).
#include "world.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <stdexcept>

#include <locd/scene.h>

using namespace locd_test;

namespace {

typedef std::set<std::pair<int, int>> Pairs;

Pairs cached(btBroadphaseInterface &bp)
{
    Pairs out;
    btOverlappingPairCache *c = bp.getOverlappingPairCache();
    for (int k = 0; k < c->getNumOverlappingPairs(); k++) {
        const btBroadphasePair &p = c->getOverlappingPairArray()[k];
        out.insert(std::minmax(p.m_pProxy0->m_uniqueId, p.m_pProxy1->m_uniqueId));
    }
    return out;
}

std::pair<int, int> pair_of(btBroadphaseProxy *a, btBroadphaseProxy *b) { return std::minmax(a->m_uniqueId, b->m_uniqueId); }

btBroadphaseProxy *box(btBroadphaseInterface &bp, btDispatcher *d, btVector3 lo, btVector3 hi, int group = 1, int mask = -1)
{
    return bp.createProxy(lo, hi, BOX_SHAPE_PROXYTYPE, nullptr, group, mask, d);
}

struct Toggle : btOverlapFilterCallback {
    bool accept = false;
    bool needBroadphaseCollision(btBroadphaseProxy *, btBroadphaseProxy *) const override { return accept; }
};

struct Collect : btBroadphaseRayCallback {
    std::vector<const btBroadphaseProxy *> seen;
    bool process(const btBroadphaseProxy *p) override
    {
        seen.push_back(p);
        return true;
    }
};

bool overlap(const btBroadphaseProxy *p, const btVector3 &lo, const btVector3 &hi)
{
    for (int k = 0; k < 3; k++)
        if (p->m_aabbMax[k] < lo[k] || hi[k] < p->m_aabbMin[k])
            return false;
    return true;
}

// Entry t of the segment from + t (to - from), 0 <= t <= 1, into the box
// grown by -smax..-smin (a swept box smin..smax), in double; -1 when missed.
double entry(const btBroadphaseProxy *p, const btVector3 &from, const btVector3 &to, const btVector3 &smin,
             const btVector3 &smax)
{
    double lo[3], hi[3];
    for (int k = 0; k < 3; k++)
        lo[k] = (double)p->m_aabbMin[k] - smax[k], hi[k] = (double)p->m_aabbMax[k] - smin[k];
    return locd_test::segment_entry(lo, hi, from, to);
}

bool overlap(const btVector3 &alo, const btVector3 &ahi, const btVector3 &blo, const btVector3 &bhi)
{
    for (int k = 0; k < 3; k++)
        if (ahi[k] < blo[k] || bhi[k] < alo[k])
            return false;
    return true;
}

bool contains(const btVector3 &lo, const btVector3 &hi, const btBroadphaseProxy *p)
{
    for (int k = 0; k < 3; k++)
        if (!(lo[k] <= p->m_aabbMin[k] && p->m_aabbMax[k] <= hi[k]))
            return false;
    return true;
}

// A long random sequence of calls between updates: moves (some twice in one
// batch), filter changes, bad boxes (release builds), proxies destroyed after
// a move and created in their slots, queries that flush mid-batch. After
// every update the cache equals brute force over the live proxies' AABBs
// (with a margin, over the boxes the scene holds, each of which must contain
// its proxy's AABB) with Bullet's filter rule.
// Returns the boxes sent to the scene (stats().moved summed).
std::uint64_t random_sequence(Tap &tap, btDispatcher &disp, double margin)
{
    std::uint64_t moved = 0;
    locd::BulletBroadphaseOptions options;
    options.margin = margin;
    locd::BulletBroadphase bp(options);
    Rng r(7);
    std::vector<btBroadphaseProxy *> live;
    auto random_box = [&](btVector3 &lo, btVector3 &hi) {
        lo = btVector3(r.uniform(0, 10), r.uniform(0, 10), r.uniform(0, 10));
        hi = lo + btVector3(r.uniform(0, 1.5), r.uniform(0, 1.5), r.uniform(0, 1.5));
    };
    auto add_one = [&]() {
        btVector3 lo, hi;
        random_box(lo, hi);
        live.push_back(box(bp, &disp, lo, hi, 1 + r.below(3), -1));
    };
    for (int k = 0; k < 300; k++)
        add_one();
    bool vacuous = false; // a frame with no pair would test little
#ifdef NDEBUG
    const bool bad_boxes = true;
#else
    const bool bad_boxes = false; // they assert
#endif
    std::set<btBroadphaseProxy *> held_out; // given a NaN box: in no pair until a valid one
    int frames_bad = 0, frames = 200, outside = 0;
    std::uint64_t set = 0;
    for (int f = 0; f < frames; f++) {
        int ops = 1 + r.below(120);
        for (int o = 0; o < ops; o++) {
            double u = r.uniform(0, 1);
            btBroadphaseProxy *p = live[(size_t)r.below((int)live.size())];
            btVector3 lo, hi;
            random_box(lo, hi);
            if (u < 0.6) {
                // A small move, or a jump.
                btVector3 a, b;
                bp.getAabb(p, a, b);
                if (u < 0.45 && !held_out.count(p)) {
                    btVector3 d(r.uniform(-0.1, 0.1), r.uniform(-0.1, 0.1), r.uniform(-0.1, 0.1));
                    lo = a + d, hi = b + d;
                }
                bp.setAabb(p, lo, hi, &disp);
                set++;
                held_out.erase(p);
            } else if (u < 0.7) {
                // A new filter, seen at the next setAabb (as btCollisionWorld does).
                p->m_collisionFilterGroup = 1 + r.below(3);
                p->m_collisionFilterMask = r.uniform(0, 1) < 0.3 ? 1 : -1;
                btVector3 a, b;
                bp.getAabb(p, a, b);
                bp.setAabb(p, a, b, &disp);
            } else if (u < 0.75 && bad_boxes) {
                float nan = std::numeric_limits<float>::quiet_NaN();
                bp.setAabb(p, btVector3(nan, 0, 0), hi, &disp);
                held_out.insert(p);
            } else if (u < 0.85) {
                bp.setAabb(p, lo, hi, &disp); // moved, then destroyed in the same batch
                bp.destroyProxy(p, &disp);
                held_out.erase(p);
                live.erase(std::find(live.begin(), live.end(), p));
                add_one();
            } else {
                Collect got;
                bp.aabbTest(lo, hi, got); // flushes the batch so far
            }
        }
        bp.calculateOverlappingPairs(&disp);
        moved += bp.stats().moved;
        Pairs want;
        for (size_t i = 0; i < live.size(); i++)
            for (size_t j = i + 1; j < live.size(); j++) {
                btBroadphaseProxy *a = live[i], *b = live[j];
                if (held_out.count(a) || held_out.count(b))
                    continue;
                bool filt = (a->m_collisionFilterGroup & b->m_collisionFilterMask) &&
                            (b->m_collisionFilterGroup & a->m_collisionFilterMask);
                btVector3 alo, ahi, blo, bhi;
                if (margin > 0) {
                    bool ok = bp.sceneAabb(a, alo, ahi) && bp.sceneAabb(b, blo, bhi);
                    outside += !ok || !contains(alo, ahi, a) || !contains(blo, bhi, b);
                } else {
                    bp.getAabb(a, alo, ahi);
                    bp.getAabb(b, blo, bhi);
                }
                if (filt && overlap(alo, ahi, blo, bhi))
                    want.insert(pair_of(a, b));
            }
        frames_bad += cached(bp) != want;
        vacuous = vacuous || want.empty();
    }
    char what[300];
    std::snprintf(what, sizeof what, "margin %g: 200 batches of random moves, filters, bad boxes, destroys and "
                  "queries: the cache equals brute force over the %s after every update", margin,
                  margin > 0 ? "grown boxes, each around its AABB" : "AABBs");
    tap.ok(frames_bad == 0 && outside == 0 && !vacuous, what);
    std::printf("# margin %g: %llu boxes set, %llu sent to the scene\n", margin, (unsigned long long)set,
                (unsigned long long)moved);
    return moved;
}

// A margin, call by call: grown boxes pair where the AABBs do not, a move
// inside the grown box sends nothing, one out of it sends the AABB grown
// again; a bad margin is refused.
void grown_boxes(Tap &tap, btDispatcher &disp)
{
    locd::BulletBroadphaseOptions o;
    o.margin = 0.1;
    locd::BulletBroadphase bp(o), exact;
    btBroadphaseProxy *a = box(bp, &disp, btVector3(0, 0, 0), btVector3(1, 1, 1));
    btBroadphaseProxy *b = box(bp, &disp, btVector3(1.15f, 0, 0), btVector3(2, 1, 1));
    box(exact, &disp, btVector3(0, 0, 0), btVector3(1, 1, 1));
    box(exact, &disp, btVector3(1.15f, 0, 0), btVector3(2, 1, 1));
    bp.calculateOverlappingPairs(&disp);
    exact.calculateOverlappingPairs(&disp);
    tap.ok(cached(bp) == Pairs{pair_of(a, b)} && cached(exact).empty(),
           "AABBs 0.15 apart: paired with a margin of 0.1, not without");
    btVector3 lo, hi;
    bool in = bp.sceneAabb(a, lo, hi);
    const btVector3 m(0.1f, 0.1f, 0.1f);
    tap.ok(in && lo == btVector3(0, 0, 0) - m && hi == btVector3(1, 1, 1) + m,
           "sceneAabb: the AABB grown by the margin");
    bp.setAabb(a, btVector3(0.05f, 0, 0), btVector3(1.05f, 1, 1), &disp);
    bp.calculateOverlappingPairs(&disp);
    bp.getAabb(a, lo, hi);
    tap.ok(bp.stats().moved == 0 && lo == btVector3(0.05f, 0, 0), "a move inside the grown box sends nothing (getAabb has it)");
    bp.setAabb(a, btVector3(-0.5f, 0, 0), btVector3(0.5f, 1, 1), &disp);
    bp.calculateOverlappingPairs(&disp);
    bp.sceneAabb(a, lo, hi);
    tap.ok(bp.stats().moved == 1 && cached(bp).empty() && hi == btVector3(0.5f, 1, 1) + m,
           "a move out of it sends the new AABB grown, and the pair is lost");
#ifdef NDEBUG
    // Bad use (release builds; debug builds assert): grown, this AABB would be a valid box.
    std::uint64_t before = bp.stats().misuse;
    bp.setAabb(b, btVector3(1.5f, 0, 0), btVector3(1.45f, 1, 1), &disp);
    bp.calculateOverlappingPairs(&disp);
    tap.ok(bp.stats().misuse == before + 1 && !bp.sceneAabb(b, lo, hi) && bp.stats().in_scene == 1,
           "an AABB inverted by less than two margins is bad use all the same: held out");
#endif
    int threw = 0;
    for (double m : {-1.0, std::nan(""), 1e300}) {
        o.margin = m;
        try {
            locd::BulletBroadphase bad(o);
        } catch (const std::invalid_argument &) {
            threw++;
        }
    }
    tap.ok(threw == 3, "a negative, NaN or (as btScalar) infinite margin is refused");
}

} // namespace

int main()
{
    Tap tap;
    btDefaultCollisionConfiguration config;
    btCollisionDispatcher disp(&config);
    {
        locd::BulletBroadphase bp;
        // Touching faces, edges and corners pair (closed intervals); a gap does not.
        btBroadphaseProxy *a = box(bp, &disp, btVector3(0, 0, 0), btVector3(1, 1, 1));
        btBroadphaseProxy *b = box(bp, &disp, btVector3(1, 0, 0), btVector3(2, 1, 1));
        btBroadphaseProxy *c = box(bp, &disp, btVector3(2, 1, 1), btVector3(3, 2, 2));
        btBroadphaseProxy *d = box(bp, &disp, btVector3(std::nextafter(3.0f, 4.0f), 0, 0), btVector3(4, 1, 1));
        btVector3 lo, hi;
        bp.getAabb(c, lo, hi);
        tap.ok(lo == btVector3(2, 1, 1) && hi == btVector3(3, 2, 2), "getAabb before any update: the AABB given");
        tap.ok(bp.getOverlappingPairCache()->getNumOverlappingPairs() == 0, "no pair before calculateOverlappingPairs");
        bp.calculateOverlappingPairs(&disp);
        tap.ok(cached(bp) == Pairs{pair_of(a, b), pair_of(b, c)}, "face and corner contacts pair, a gap of one ulp does not");
        // Moves are batched: the cache changes at the next update.
        bp.setAabb(d, btVector3(3, 0, 0), btVector3(4, 1, 1), &disp);
        tap.ok(cached(bp).size() == 2, "setAabb changes no pair until the update");
        bp.calculateOverlappingPairs(&disp);
        tap.ok(cached(bp) == Pairs{pair_of(a, b), pair_of(b, c), pair_of(c, d)}, "moved into contact: the pair is created");
        bp.destroyProxy(b, &disp);
        tap.ok(cached(bp) == Pairs{pair_of(c, d)}, "destroyProxy removes its pairs at once");
        bp.calculateOverlappingPairs(&disp);
        tap.ok(cached(bp) == Pairs{pair_of(c, d)}, "and the update after it agrees");

        // Queries see unflushed changes.
        btBroadphaseProxy *e = box(bp, &disp, btVector3(10, 10, 10), btVector3(11, 11, 11));
        Collect all;
        bp.aabbTest(btVector3(10.5, 10.5, 10.5), btVector3(12, 12, 12), all);
        tap.ok(all.seen.size() == 1 && all.seen[0] == e, "aabbTest sees a proxy created since the update");

        // Bad use: ignored in release, counted.
#ifdef NDEBUG
        std::uint64_t before = bp.stats().misuse;
        bp.destroyProxy(b, &disp); // twice
        bp.setAabb(b, btVector3(0, 0, 0), btVector3(1, 1, 1), &disp);
        float nan = std::numeric_limits<float>::quiet_NaN();
        bp.setAabb(c, btVector3(nan, 1, 1), btVector3(3, 2, 2), &disp);
        btBroadphaseProxy *f = box(bp, &disp, btVector3(1, 1, 1), btVector3(0, 2, 2)); // inverted
        bp.calculateOverlappingPairs(&disp);
        tap.ok(bp.stats().misuse == before + 4, "destroyProxy twice, setAabb on a dead proxy, a NaN and an inverted AABB: counted");
        tap.ok(cached(bp).empty() && bp.stats().in_scene == 3, "a proxy with a bad AABB is held out (no pair)");
        bp.setAabb(c, btVector3(2, 1, 1), btVector3(3, 2, 2), &disp);
        bp.setAabb(f, btVector3(0, 1, 1), btVector3(1, 2, 2), &disp);
        bp.calculateOverlappingPairs(&disp);
        tap.ok(cached(bp) == Pairs{pair_of(c, d), pair_of(a, f)}, "given a valid AABB again, it pairs again");
#else
        std::printf("# bad use asserts in debug builds: not exercised here\n");
#endif
    }
    {
        // Filters: Bullet's int groups, static proxies, a user callback.
        Toggle toggle;
        btHashedOverlappingPairCache cache;
        locd::BulletBroadphase bp(&cache);
        const int S = btBroadphaseProxy::StaticFilter, A = btBroadphaseProxy::AllFilter;
        btBroadphaseProxy *s1 = box(bp, &disp, btVector3(0, 0, 0), btVector3(2, 2, 2), S, A ^ S);
        btBroadphaseProxy *s2 = box(bp, &disp, btVector3(1, 1, 1), btVector3(3, 3, 3), S, A ^ S);
        // Masks with StaticFilter: these two pair (Bullet's rule), so neither is static in the scene.
        btBroadphaseProxy *s3 = box(bp, &disp, btVector3(1, 1, 1), btVector3(3, 3, 3), S, A);
        btBroadphaseProxy *s4 = box(bp, &disp, btVector3(1, 1, 1), btVector3(3, 3, 3), S, A);
        btBroadphaseProxy *hi_bit = box(bp, &disp, btVector3(0, 0, 0), btVector3(1, 1, 1), (int)0x80000000, (int)0x80000000);
        btBroadphaseProxy *dyn = box(bp, &disp, btVector3(0.5, 0.5, 0.5), btVector3(1.5, 1.5, 1.5));
        bp.calculateOverlappingPairs(&disp);
        Pairs want{pair_of(s1, dyn), pair_of(s2, dyn), pair_of(s3, dyn), pair_of(s4, dyn), pair_of(s3, s4)};
        locd_scene_stats ss;
        locd_scene_stats_init(&ss);
        locd_scene_get_stats(bp.scene(), &ss);
        tap.ok(ss.static_objects == 2, "StaticFilter proxies whose mask lacks StaticFilter are static in the scene");
        tap.ok(cached(bp) == want, "static proxies: no static-static pair unless a mask asks for it; group bit 31 kept apart from bit 0");
        // A user callback refuses a new pair; asked again when one of the two moves.
        cache.setOverlapFilterCallback(&toggle);
        btBroadphaseProxy *g = box(bp, &disp, btVector3(0, 0, 0), btVector3(1, 1, 1), (int)0x80000000, -1);
        bp.calculateOverlappingPairs(&disp);
        tap.ok(cached(bp) == want && bp.stats().rejected == 6, "a refused pair is not added (but held)");
        toggle.accept = true;
        bp.calculateOverlappingPairs(&disp);
        tap.ok(cached(bp) == want, "not asked again while neither moves");
        bp.setAabb(g, btVector3(0, 0, 0), btVector3(1.1, 1, 1), &disp);
        bp.calculateOverlappingPairs(&disp);
        want.insert({pair_of(hi_bit, g), pair_of(g, dyn), pair_of(s1, g), pair_of(s2, g), pair_of(s3, g), pair_of(s4, g)});
        tap.ok(cached(bp) == want && bp.stats().rejected == 0, "asked again on a move, and added");
        cache.setOverlapFilterCallback(nullptr);
    }
    // The same calls twice: with a margin, the small moves inside a grown box reach no scene.
    std::uint64_t exact_moves = random_sequence(tap, disp, 0);
    std::uint64_t grown_moves = random_sequence(tap, disp, 0.2);
    tap.ok(grown_moves < exact_moves * 9 / 10, "with a margin, fewer boxes reach the scene");
    grown_boxes(tap, disp);
    {
        // Queries against brute force over the proxies: rays, sweeps, boxes.
        locd::BulletBroadphase bp;
        Rng r(3);
        std::vector<btBroadphaseProxy *> ps;
        for (int k = 0; k < 3000; k++) {
            btVector3 lo(r.uniform(0, 50), r.uniform(0, 50), r.uniform(0, 50));
            ps.push_back(box(bp, &disp, lo, lo + btVector3(r.uniform(0, 2), r.uniform(0, 2), r.uniform(0, 2))));
        }
        bp.calculateOverlappingPairs(&disp);
        int bad_ray = 0, bad_box = 0, offered = 0;
        for (int q = 0; q < 300; q++) {
            btVector3 from(r.uniform(-5, 55), r.uniform(-5, 55), r.uniform(-5, 55));
            btVector3 to(r.uniform(-5, 55), r.uniform(-5, 55), r.uniform(-5, 55));
            btVector3 smin(0, 0, 0), smax(0, 0, 0);
            if (q % 2) {
                smin = btVector3(-r.uniform(0, 1), -r.uniform(0, 1), -r.uniform(0, 1));
                smax = btVector3(r.uniform(0, 1), r.uniform(0, 1), r.uniform(0, 1));
            }
            Collect got;
            got.m_lambda_max = 1;
            bp.rayTest(from, to, got, smin, smax);
            std::vector<std::pair<double, const btBroadphaseProxy *>> want;
            for (btBroadphaseProxy *p : ps) {
                double t = entry(p, from, to, smin, smax);
                if (t >= 0)
                    want.push_back({t, p});
            }
            std::sort(want.begin(), want.end());
            bool ok = want.size() == got.seen.size();
            for (size_t k = 0; ok && k < want.size(); k++)
                ok = want[k].second == got.seen[k] || want[k].first == want[k - (k > 0)].first;
            bad_ray += !ok;
            offered += (int)got.seen.size();
            Collect boxes;
            btVector3 lo(r.uniform(0, 50), r.uniform(0, 50), r.uniform(0, 50));
            btVector3 hi = lo + btVector3(r.uniform(0, 5), r.uniform(0, 5), r.uniform(0, 5));
            bp.aabbTest(lo, hi, boxes);
            size_t n = 0;
            for (btBroadphaseProxy *p : ps)
                n += overlap(p, lo, hi);
            std::set<const btBroadphaseProxy *> seen(boxes.seen.begin(), boxes.seen.end());
            bool box_ok = seen.size() == n && boxes.seen.size() == n;
            for (const btBroadphaseProxy *p : seen)
                box_ok = box_ok && overlap(p, lo, hi);
            bad_box += !box_ok;
        }
        tap.ok(bad_ray == 0 && offered > 0, "rayTest (rays and swept boxes) offers exactly the proxies met, by entry t");
        tap.ok(bad_box == 0, "aabbTest offers exactly the proxies overlapped");
        // A shrinking m_lambda_max: nothing entered past it is offered.
        struct Shrink : Collect {
            bool process(const btBroadphaseProxy *p) override
            {
                seen.push_back(p);
                m_lambda_max = 0.3f;
                return true;
            }
        } shrink;
        shrink.m_lambda_max = 1;
        // A wide swept box, so that many proxies are entered near t = 0.3.
        btVector3 from(-5, 25, 25), to(55, 25, 25), smin(-5, -5, -5), smax(5, 5, 5);
        bp.rayTest(from, to, shrink, smin, smax);
        std::set<const btBroadphaseProxy *> want, seen(shrink.seen.begin(), shrink.seen.end());
        int beyond = 0;
        for (btBroadphaseProxy *p : ps) {
            double t = entry(p, from, to, smin, smax);
            if (t >= 0 && t <= (double)0.3f)
                want.insert(p);
            beyond += t > (double)0.3f;
        }
        if (!shrink.seen.empty())
            want.insert(shrink.seen[0]); // offered before m_lambda_max shrank
        bool ok = !shrink.seen.empty() && seen == want && seen.size() == shrink.seen.size();
        std::printf("# %zu offered, %zu expected, %d entered past 0.3\n", shrink.seen.size(), want.size(), beyond);
        tap.ok(ok && beyond > 0, "rayTest stops once past the callback's shrinking m_lambda_max");
    }
    return tap.done();
}
