// The state behind locd::BulletBroadphase (broadphase.cpp: proxies and
// pairs; queries.cpp: rayTest and aabbTest).
#ifndef LOCD_BULLET_IMPL_HPP
#define LOCD_BULLET_IMPL_HPP

#include "locd/bullet/broadphase.hpp"

#include <locd/locd.h>
#include <locd/scene.h>

#include <cstdint>
#include <deque>
#include <memory>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace locd {

// A proxy lives in Impl::pool (ProxyPool: stable addresses) until the broadphase is
// destroyed: a destroyed one is only marked dead, so a second destroyProxy
// or a setAabb on it reads our own memory and is caught (docs/engines.md,
// "Bad use"). Dead slots are reused oldest first, and only once 64 more
// have died after them.
struct BulletProxy : btBroadphaseProxy {
    static constexpr std::uint32_t kMagic = 0x6c6f6364u; // "locd"
    std::uint32_t magic = kMagic;
    bool alive = false;
    bool dirty = false;       // in Impl::dirty: its box or filter reaches the scene at the next flush
    bool box_ok = false;      // AABB and scene box finite, min <= max: only then is it in the scene
    bool is_static = false;   // as added to the scene
    locd_id id = LOCD_ID_NONE; // its scene object, or NONE (not added yet, or held out)
    int scene_group = 0;      // the filter the scene has for it
    int scene_mask = 0;
    std::uint64_t moved_frame = 0; // the frame of its last changed box
    std::uint64_t move_batch = 0;  // == Impl::batch: its box is queued at moves.ids[move_slot]
    std::uint32_t move_slot = 0;
    btVector3 scene_min, scene_max; // the box the scene holds: the AABB, grown by Impl::margin
};

// Bullet's rule (group0 & mask1) && (group1 & mask0) on int is the scene's
// (category_a & mask_b) && (category_b & mask_a) on the same 32 bits.
inline std::uint64_t bits(int v) { return (std::uint64_t)(std::uint32_t)v; }

// Static in the scene (never paired with another static object) only where
// Bullet's own rule already keeps two such proxies apart: group exactly
// StaticFilter and a mask without it (btCollisionWorld's static objects).
inline bool static_filter(int group, int mask)
{
    return group == btBroadphaseProxy::StaticFilter && !(mask & btBroadphaseProxy::StaticFilter);
}

// The proxies, in blocks made contiguous: Bullet's updateAabbs calls
// setAabb in the order the proxies were made, and a constant stride lets
// the processor fetch the next ones ahead (std::deque's chunks of 4 did not:
// a cache miss on each proxy was two thirds of setAabb's time). Addresses
// are stable until the pool goes.
class ProxyPool {
public:
    BulletProxy *add()
    {
        if (n_ % kBlock == 0)
            blocks_.emplace_back(new BulletProxy[kBlock]);
        return &blocks_.back()[n_++ % kBlock];
    }
    template <class F> void each(F f) const
    {
        for (size_t k = 0; k < n_; k++)
            f(blocks_[k / kBlock][k % kBlock]);
    }

private:
    static constexpr size_t kBlock = 1024;
    std::vector<std::unique_ptr<BulletProxy[]>> blocks_;
    size_t n_ = 0;
};

struct PairKey {
    locd_id a, b;
    bool operator==(const PairKey &o) const { return a == o.a && b == o.b; }
};
struct PairKeyHash {
    std::size_t operator()(const PairKey &k) const
    {
        std::uint64_t h = k.a * 0x9e3779b97f4a7c15ull ^ (k.b + 0x632be59bd9b4e019ull + (k.a << 6));
        return (std::size_t)(h ^ (h >> 29));
    }
};

struct BulletBroadphase::Impl {
    locd_engine *engine = nullptr;
    locd_scene *scene = nullptr;
    btOverlappingPairCache *cache = nullptr;
    bool owns_cache = false;
    btScalar margin = 0; // BulletBroadphaseOptions::margin

    ProxyPool pool;
    std::deque<BulletProxy *> free_slots; // oldest first
    static constexpr size_t kQuarantine = 64;
    std::unordered_map<locd_id, BulletProxy *> by_id;
    std::vector<BulletProxy *> dirty;
    // Box changes of proxies in the scene whose filter did not change,
    // queued by setAabb itself: the flush sends them without touching the
    // proxies again (a second pass over 10^4 proxies missed the cache on
    // each). An entry whose proxy later took the dirty path or died is
    // dropped at the flush (`stale`).
    struct Moves {
        std::vector<locd_id> ids;
        std::vector<btScalar> boxes; // 6 a move: min x y z, max x y z (room for at least ids.size())
        std::vector<BulletProxy *> proxies;
        bool stale = false;
    } moves;
    std::uint64_t batch = 1; // the flushes so far, plus one
    std::uint64_t sent = 0;  // boxes sent to the scene by the flushes since the last update
    std::vector<locd_id> removed; // scene objects of destroyed or held-out proxies, removed at the flush
    std::vector<locd_id> retired; // removed ids of live proxies: by_id keeps them until their lost pairs are read
    // Overlapping pairs the cache refused (its filter callback): offered
    // again when one of the two moves, as btDbvtBroadphase offers a pair
    // again when a proxy leaves its fattened box.
    std::unordered_set<PairKey, PairKeyHash> rejected;
    int next_uid = 0;
    std::uint64_t live = 0;
    std::uint64_t frame = 1;
    BulletBroadphaseStats st;

    // Query buffers, grown on LOCD_ERR_BUFFER_TOO_SMALL.
    std::vector<locd_id> hit_ids;
    std::vector<double> hit_t;
    bool in_query = false; // a callback that queries again gets buffers of its own

    bool check(const btBroadphaseProxy *p) const;
    bool holds(const BulletProxy *p, const btVector3 &lo, const btVector3 &hi) const;
    void grow(BulletProxy *p);
    void mark(BulletProxy *p);
    void queue_move(BulletProxy *p);
    void put_move_box(size_t k, const BulletProxy *p);
    void drop_stale_moves();
    void flush();
    BulletProxy *proxy_of(locd_id id) const
    {
        auto it = by_id.find(id);
        return it == by_id.end() ? nullptr : it->second;
    }
};

} // namespace locd

#endif
