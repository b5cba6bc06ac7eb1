// locd::BulletBroadphase: a btBroadphaseInterface on a locd scene
// (docs/engines.md). Plug it into a Bullet world in place of
// btDbvtBroadphase:
//
//   locd::BulletBroadphase broadphase;   // owns a btHashedOverlappingPairCache
//   btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
//
// Pairs are exact: two proxies pair iff their AABBs, as last given to
// createProxy/setAabb, overlap (closed intervals) and Bullet's filter rule
// passes; with options.margin > 0, iff their grown boxes (sceneAabb)
// overlap, as btDbvtBroadphase pairs its fattened boxes. Proxy changes are batched and reach the scene at the next
// calculateOverlappingPairs (or query), which runs one scene update.
// Like btDbvtBroadphase, one thread at a time may use it.
#ifndef LOCD_BULLET_BROADPHASE_HPP
#define LOCD_BULLET_BROADPHASE_HPP

#include <BulletCollision/BroadphaseCollision/btBroadphaseInterface.h>
#include <BulletCollision/BroadphaseCollision/btBroadphaseProxy.h>
#include <BulletCollision/BroadphaseCollision/btOverlappingPairCache.h>

#include <cstdint>
#include <memory>

struct locd_scene;

// liblocd_bullet exports this class only (built with hidden visibility).
#if defined(_WIN32)
#define LOCD_BULLET_API
#else
#define LOCD_BULLET_API __attribute__((visibility("default")))
#endif

namespace locd {

struct BulletBroadphaseOptions {
    // Threads of the scene's engine (0 = one per core).
    unsigned threads = 0;
    // The scene's flags (LOCD_SCENE_* of <locd/scene.h>), e.g. LOCD_SCENE_NO_NEAR_LIST.
    std::uint32_t scene_flags = 0;
    // Proxies to reserve room for (0 = grow as needed).
    std::uint64_t capacity_hint = 0;
    // 0: the scene holds each proxy's AABB as given (exact pairs). > 0: it
    // holds the AABB grown by this much on every side, and keeps it while
    // the new AABBs stay inside it (btDbvtBroadphase's gDbvtMargin is
    // 0.05): a body that jitters in place costs the scene nothing, and
    // pairs are the grown boxes' overlaps. Finite and >= 0.
    double margin = 0;
};

// Counters of the last calculateOverlappingPairs and of misuse since construction.
struct BulletBroadphaseStats {
    std::uint64_t proxies = 0;      // live proxies
    std::uint64_t in_scene = 0;     // of them, in the scene (a bad AABB keeps one out)
    std::uint64_t created = 0;      // pairs the last update created
    std::uint64_t lost = 0;         // and lost
    std::uint64_t moved = 0;        // boxes sent to the scene for the last update (moves; with a margin, only out of the grown box)
    std::uint64_t rejected = 0;     // overlapping pairs the pair cache refused (user filter), held to offer again
    std::uint64_t misuse = 0;       // bad calls ignored: dead proxy, NaN or inverted AABB
    double update_ms = 0;           // the last calculateOverlappingPairs, flush and pair-cache calls included
};

class LOCD_BULLET_API BulletBroadphase : public btBroadphaseInterface {
public:
    // pairCache: used as is and not deleted (NULL: the broadphase owns a
    // btHashedOverlappingPairCache). Throws std::runtime_error when locd
    // cannot create its engine or scene.
    explicit BulletBroadphase(btOverlappingPairCache *pairCache = nullptr,
                              const BulletBroadphaseOptions &options = BulletBroadphaseOptions());
    explicit BulletBroadphase(const BulletBroadphaseOptions &options);
    ~BulletBroadphase() override;
    BulletBroadphase(const BulletBroadphase &) = delete;
    BulletBroadphase &operator=(const BulletBroadphase &) = delete;

    btBroadphaseProxy *createProxy(const btVector3 &aabbMin, const btVector3 &aabbMax, int shapeType, void *userPtr,
                                   int collisionFilterGroup, int collisionFilterMask,
                                   btDispatcher *dispatcher) override;
    void destroyProxy(btBroadphaseProxy *proxy, btDispatcher *dispatcher) override;
    void setAabb(btBroadphaseProxy *proxy, const btVector3 &aabbMin, const btVector3 &aabbMax,
                 btDispatcher *dispatcher) override;
    void getAabb(btBroadphaseProxy *proxy, btVector3 &aabbMin, btVector3 &aabbMax) const override;

    // Offers rayCallback.process() every proxy whose box in the scene (its
    // AABB, or with a margin its grown box) the segment
    // rayFrom..rayTo meets (grown by -aabbMax..-aabbMin for a convex sweep:
    // the box [rayFrom + aabbMin, rayFrom + aabbMax] swept to rayTo), in
    // order of entry, and stops past rayCallback.m_lambda_max as it shrinks.
    void rayTest(const btVector3 &rayFrom, const btVector3 &rayTo, btBroadphaseRayCallback &rayCallback,
                 const btVector3 &aabbMin = btVector3(0, 0, 0),
                 const btVector3 &aabbMax = btVector3(0, 0, 0)) override;
    void aabbTest(const btVector3 &aabbMin, const btVector3 &aabbMax, btBroadphaseAabbCallback &callback) override;

    // One scene update: created pairs go to pairCache->addOverlappingPair,
    // lost ones to removeOverlappingPair (which frees their algorithms).
    void calculateOverlappingPairs(btDispatcher *dispatcher) override;

    btOverlappingPairCache *getOverlappingPairCache() override;
    const btOverlappingPairCache *getOverlappingPairCache() const override;
    // The union of the boxes the scene holds (O(proxies)); zero when there are none.
    void getBroadphaseAabb(btVector3 &aabbMin, btVector3 &aabbMax) const override;
    // With no proxy left, restarts the unique ids (as btDbvtBroadphase does).
    void resetPool(btDispatcher *dispatcher) override;
    void printStats() override;

    // The box the scene holds for a proxy from the next update on: its AABB,
    // or with a margin the AABB grown when it last left its grown box (it
    // contains getAabb's). False for a proxy held out of the scene (a bad
    // AABB); a destroyed proxy is bad use, as for getAabb.
    bool sceneAabb(const btBroadphaseProxy *proxy, btVector3 &aabbMin, btVector3 &aabbMax) const;

    BulletBroadphaseStats stats() const;
    // The scene itself, for its statistics (locd_scene_get_stats). Do not change it.
    const locd_scene *scene() const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

} // namespace locd

#endif
