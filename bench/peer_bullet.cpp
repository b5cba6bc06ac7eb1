// Bullet broad phases as benchmark peers.
//
// Proxies are created with the boxes' exact AABBs (createProxy adds no
// margin; the Dbvt's velocity prediction and margins only apply in setAabb,
// which we never call). The pairs are read from the broadphase's own
// overlapping-pair cache after calculateOverlappingPairs().
//  - btDbvtBroadphase: two dynamic AABB trees; by default each createProxy
//    queries the trees at once (incremental); with m_deferedcollide the
//    pairs are found in calculateOverlappingPairs (the "deferred" peer).
//    Its Intersect test is closed (b.max < a.min means apart).
//  - bt32BitAxisSweep3: sweep and prune on quantized 32-bit endpoints over a
//    world box fitted to the scene. Quantization rounds outward, so it may
//    report pairs that are a quantum apart (counted as "extra, disjoint").
//    Each insertion sorts its endpoints into place: O(n) per proxy.
#include "peers.h"

#include <btBulletCollisionCommon.h>

#include <algorithm>
#include <cstdio>
#include <exception>
#include <vector>

namespace {

// userPtr = index + 1 (a NULL client object is best avoided).
inline std::uint32_t proxy_index(const btBroadphaseProxy *p)
{
    return (std::uint32_t)((std::uintptr_t)p->m_clientObject - 1);
}

void read_pairs(btBroadphaseInterface *bp, peer_pairs &out)
{
    btOverlappingPairCache *pc = bp->getOverlappingPairCache();
    int m = pc->getNumOverlappingPairs();
    const btBroadphasePair *arr = pc->getOverlappingPairArrayPtr();
    out.reserve(out.size() + (std::size_t)m);
    for (int k = 0; k < m; k++)
        out.push_back(peer_pair(proxy_index(arr[k].m_pProxy0), proxy_index(arr[k].m_pProxy1)));
}

void add_proxies(btBroadphaseInterface *bp, const peer_scene &s, btDispatcher *disp,
                 std::vector<btBroadphaseProxy *> &proxies)
{
    proxies.resize(s.n);
    for (std::size_t i = 0; i < s.n; i++) {
        const float *b = s.b + 6 * i;
        proxies[i] = bp->createProxy(btVector3(b[0], b[1], b[2]), btVector3(b[3], b[4], b[5]), BOX_SHAPE_PROXYTYPE,
                                     (void *)(std::uintptr_t)(i + 1), btBroadphaseProxy::DefaultFilter,
                                     btBroadphaseProxy::AllFilter, disp);
    }
}

int run_dbvt(bool deferred, const peer_scene &s, peer_pairs &out, peer_times &t, char *err, std::size_t errlen)
{
    try {
        btDefaultCollisionConfiguration cfg;
        btCollisionDispatcher disp(&cfg);
        std::vector<btBroadphaseProxy *> proxies;
        double t0 = peer_now_ms();
        btDbvtBroadphase *bp = new btDbvtBroadphase();
        bp->m_deferedcollide = deferred;
        add_proxies(bp, s, &disp, proxies);
        double t1 = peer_now_ms();
        bp->calculateOverlappingPairs(&disp);
        read_pairs(bp, out);
        double t2 = peer_now_ms();
        t.setup_ms = t1 - t0;
        t.query_ms = t2 - t1;
        // destroyProxy would scan the whole hashed pair cache per proxy
        // (O(n * pairs)); the trees and the cache go with the broadphase,
        // the proxies themselves are btAlignedAlloc'ed blocks we free here.
        delete bp;
        for (btBroadphaseProxy *p : proxies)
            btAlignedFree(p);
        return 0;
    } catch (const std::exception &e) {
        std::snprintf(err, errlen, "Bullet threw: %s", e.what());
    }
    return 1;
}

} // namespace

int peer_bullet_dbvt(const peer_scene &s, peer_pairs &o, peer_times &t, char *e, std::size_t l)
{
    return run_dbvt(false, s, o, t, e, l);
}

int peer_bullet_dbvt_deferred(const peer_scene &s, peer_pairs &o, peer_times &t, char *e, std::size_t l)
{
    return run_dbvt(true, s, o, t, e, l);
}

int peer_bullet_axis_sweep(const peer_scene &s, peer_pairs &out, peer_times &t, char *err, std::size_t errlen)
{
    if (s.n >= 0x7ffffffeu) {
        std::snprintf(err, errlen, "bt32BitAxisSweep3 holds at most 2^31 - 2 proxies");
        return 1;
    }
    try {
        btDefaultCollisionConfiguration cfg;
        btCollisionDispatcher disp(&cfg);
        std::vector<btBroadphaseProxy *> proxies;
        double t0 = peer_now_ms();
        btVector3 lo(BT_LARGE_FLOAT, BT_LARGE_FLOAT, BT_LARGE_FLOAT), hi(-BT_LARGE_FLOAT, -BT_LARGE_FLOAT, -BT_LARGE_FLOAT);
        for (std::size_t i = 0; i < s.n; i++) {
            const float *b = s.b + 6 * i;
            lo.setMin(btVector3(b[0], b[1], b[2]));
            hi.setMax(btVector3(b[3], b[4], b[5]));
        }
        if (s.n == 0)
            lo = hi = btVector3(0, 0, 0);
        double t1 = peer_now_ms();
        bt32BitAxisSweep3 *bp = new bt32BitAxisSweep3(lo, hi, (unsigned)std::max<std::size_t>(s.n, 1), nullptr, true);
        add_proxies(bp, s, &disp, proxies);
        double t2 = peer_now_ms();
        bp->calculateOverlappingPairs(&disp);
        read_pairs(bp, out);
        double t3 = peer_now_ms();
        t.prep_ms = t1 - t0;
        t.setup_ms = t2 - t1;
        t.query_ms = t3 - t2;
        delete bp; // the handles live in the sweep's own array
        return 0;
    } catch (const std::exception &e) {
        std::snprintf(err, errlen, "Bullet threw: %s", e.what());
    }
    return 1;
}
