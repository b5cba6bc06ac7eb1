// locd::BulletBroadphase: proxies, the batched changes, and the pairs.
#include "impl.hpp"

#include <BulletCollision/BroadphaseCollision/btDispatcher.h>

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

// Bad use is asserted in debug builds (btAssert only fires with BT_DEBUG,
// so assert() too) and ignored in release, counted in stats().misuse.
#define LOCD_BULLET_ASSERT(x) \
    do {                      \
        btAssert(x);          \
        assert(x);            \
    } while (0)

namespace locd {

namespace {

#if defined(BT_USE_DOUBLE_PRECISION)
typedef double scalar;
inline locd_status scene_add(locd_scene *s, const double *b, size_t n, const locd_scene_add_options *o, locd_id *ids)
{
    return locd_scene_add_f64(s, b, n, o, ids);
}
inline locd_status scene_move(locd_scene *s, const locd_id *ids, const double *b, size_t n)
{
    return locd_scene_move_f64(s, ids, b, n);
}
#else
typedef float scalar;
inline locd_status scene_add(locd_scene *s, const float *b, size_t n, const locd_scene_add_options *o, locd_id *ids)
{
    return locd_scene_add_f32(s, b, n, o, ids);
}
inline locd_status scene_move(locd_scene *s, const locd_id *ids, const float *b, size_t n)
{
    return locd_scene_move_f32(s, ids, b, n);
}
#endif

bool ordered(const btVector3 &lo, const btVector3 &hi)
{
    return lo[0] <= hi[0] && lo[1] <= hi[1] && lo[2] <= hi[2];
}

bool valid_box(const btVector3 &lo, const btVector3 &hi)
{
    for (int k = 0; k < 3; k++)
        if (!std::isfinite(lo[k]) || !std::isfinite(hi[k]))
            return false;
    return ordered(lo, hi);
}

void put_box(scalar *v, const BulletProxy *p)
{
    for (int k = 0; k < 3; k++) {
        v[k] = p->scene_min[k];
        v[3 + k] = p->scene_max[k];
    }
}

void push_box(std::vector<scalar> &v, const BulletProxy *p)
{
    v.resize(v.size() + 6);
    put_box(v.data() + v.size() - 6, p);
}

// Objects added in one call: the scene takes the static flag per batch.
struct AddBatch {
    std::vector<BulletProxy *> proxies;
    std::vector<scalar> boxes;
    std::vector<std::uint64_t> categories, masks;
};

void failed(const char *what, locd_status s)
{
    std::fprintf(stderr, "locd::BulletBroadphase: %s failed: %s (%s)\n", what, locd_status_string(s),
                 locd_last_error());
    LOCD_BULLET_ASSERT(!"a locd scene call failed");
}

} // namespace

inline bool BulletBroadphase::Impl::check(const btBroadphaseProxy *proxy) const
{
    const BulletProxy *p = static_cast<const BulletProxy *>(proxy);
    bool ok = p && p->magic == BulletProxy::kMagic && p->alive;
    LOCD_BULLET_ASSERT(ok && "a destroyed or foreign proxy");
    if (!ok)
        const_cast<Impl *>(this)->st.misuse++;
    return ok;
}

// Whether the box the scene holds for p serves the AABB lo..hi as it is:
// the same box (exact pairs), or with a margin a grown box around it (lo <=
// hi asked too: an inverted AABB inside the grown box is bad use).
inline bool BulletBroadphase::Impl::holds(const BulletProxy *p, const btVector3 &lo, const btVector3 &hi) const
{
    bool ok = true;
    for (int k = 0; k < 3; k++)
        ok &= margin > 0 ? p->scene_min[k] <= lo[k] && lo[k] <= hi[k] && hi[k] <= p->scene_max[k]
                         : p->scene_min[k] == lo[k] && hi[k] == p->scene_max[k];
    return ok;
}

// The scene's box for p's AABB: grown by the margin on every side. Rounding
// cannot shrink it: lo - margin rounds to a value <= lo. The grown box is
// finite only if the AABB is, but an AABB inverted by less than two margins
// grows into a valid box: its order is asked of the AABB itself.
inline void BulletBroadphase::Impl::grow(BulletProxy *p)
{
    btVector3 d(margin, margin, margin);
    p->scene_min = p->m_aabbMin - d;
    p->scene_max = p->m_aabbMax + d;
    p->box_ok = valid_box(p->scene_min, p->scene_max) && ordered(p->m_aabbMin, p->m_aabbMax);
}

inline void BulletBroadphase::Impl::mark(BulletProxy *p)
{
    if (p->move_batch == batch)
        moves.stale = true; // its queued move is dropped: the dirty path sends its box
    if (!p->dirty) {
        p->dirty = true;
        dirty.push_back(p);
    }
}

// A new box for a proxy in the scene with its filter unchanged: queued as
// is (a second change in the same batch overwrites the first).
inline void BulletBroadphase::Impl::queue_move(BulletProxy *p)
{
    if (p->move_batch != batch) {
        p->move_batch = batch;
        p->move_slot = (std::uint32_t)moves.ids.size();
        moves.ids.push_back(p->id);
        moves.proxies.push_back(p);
    }
    put_move_box(p->move_slot, p);
}

// Move k's box. The boxes' vector only grows (its size is not the moves'
// count): a resize per move zeroed its 6 values first, and that `rep stos`
// was a third of setAabb's time in a resting stack.
inline void BulletBroadphase::Impl::put_move_box(size_t k, const BulletProxy *p)
{
    if (moves.boxes.size() < 6 * (k + 1))
        moves.boxes.resize(std::max(6 * (k + 1), 2 * moves.boxes.size()));
    put_box(moves.boxes.data() + 6 * k, p);
}

// Keeps the queued moves whose proxies are still alive, in the scene under
// the same id, and not on the dirty path.
void BulletBroadphase::Impl::drop_stale_moves()
{
    size_t kept = 0;
    for (size_t k = 0; k < moves.ids.size(); k++) {
        const BulletProxy *p = moves.proxies[k];
        if (!p->alive || p->dirty || p->id != moves.ids[k])
            continue;
        moves.ids[kept] = moves.ids[k];
        moves.proxies[kept] = moves.proxies[k];
        std::copy(&moves.boxes[6 * k], &moves.boxes[6 * k] + 6, &moves.boxes[6 * kept]);
        kept++;
    }
    moves.ids.resize(kept);
    moves.proxies.resize(kept);
    moves.stale = false;
}

// Brings the scene up to date with the proxies: removes, adds, moves and
// filters in one batch each (the scene's calls are per batch).
void BulletBroadphase::Impl::flush()
{
    AddBatch adds[2]; // dynamic, static
    std::vector<locd_id> filter_ids;
    std::vector<std::uint64_t> filter_cats, filter_masks;
    if (moves.stale)
        drop_stale_moves();
    batch++; // the queued moves are sent below: new ones start a new queue
    for (BulletProxy *p : dirty) {
        p->dirty = false;
        if (!p->alive)
            continue; // destroyed: its object is in `removed` already
        int group = p->m_collisionFilterGroup, mask = p->m_collisionFilterMask;
        bool want_static = static_filter(group, mask);
        if (p->id != LOCD_ID_NONE && (!p->box_ok || want_static != p->is_static)) {
            // Held out (bad box) or re-added (static changed): its old id
            // names it until this frame's lost pairs are read.
            removed.push_back(p->id);
            retired.push_back(p->id);
            p->id = LOCD_ID_NONE;
        }
        if (p->id == LOCD_ID_NONE) {
            if (p->box_ok) {
                AddBatch &b = adds[want_static ? 1 : 0];
                b.proxies.push_back(p);
                push_box(b.boxes, p);
                b.categories.push_back(bits(group));
                b.masks.push_back(bits(mask));
            }
            continue;
        }
        if (p->moved_frame == frame) { // (after the stale check: moves.proxies is not needed past it)
            moves.ids.push_back(p->id);
            put_move_box(moves.ids.size() - 1, p);
        }
        if (group != p->scene_group || mask != p->scene_mask) {
            filter_ids.push_back(p->id);
            filter_cats.push_back(bits(group));
            filter_masks.push_back(bits(mask));
            p->scene_group = group;
            p->scene_mask = mask;
        }
    }
    dirty.clear();
    sent += moves.ids.size();
    locd_status s;
    if (!removed.empty() && (s = locd_scene_remove(scene, removed.data(), removed.size())) != LOCD_OK)
        failed("locd_scene_remove", s);
    removed.clear();
    std::vector<locd_id> ids;
    for (int k = 0; k < 2; k++) {
        AddBatch &b = adds[k];
        if (b.proxies.empty())
            continue;
        locd_scene_add_options o;
        locd_scene_add_options_init(&o);
        o.flags = k ? LOCD_OBJECT_STATIC : 0;
        o.categories = b.categories.data();
        o.masks = b.masks.data();
        ids.resize(b.proxies.size());
        if ((s = scene_add(scene, b.boxes.data(), b.proxies.size(), &o, ids.data())) != LOCD_OK) {
            failed("locd_scene_add", s);
            continue;
        }
        for (size_t i = 0; i < ids.size(); i++) {
            BulletProxy *p = b.proxies[i];
            p->id = ids[i];
            p->is_static = k == 1;
            p->scene_group = (int)b.categories[i];
            p->scene_mask = (int)b.masks[i];
            by_id[ids[i]] = p;
        }
    }
    if (!moves.ids.empty() &&
        (s = scene_move(scene, moves.ids.data(), moves.boxes.data(), moves.ids.size())) != LOCD_OK)
        failed("locd_scene_move", s);
    moves.ids.clear();
    moves.proxies.clear();
    if (!filter_ids.empty() &&
        (s = locd_scene_set_filter(scene, filter_ids.data(), filter_ids.size(), filter_cats.data(),
                                   filter_masks.data(), nullptr)) != LOCD_OK)
        failed("locd_scene_set_filter", s);
}

BulletBroadphase::BulletBroadphase(const BulletBroadphaseOptions &options) : BulletBroadphase(nullptr, options) {}

BulletBroadphase::BulletBroadphase(btOverlappingPairCache *pairCache, const BulletBroadphaseOptions &options)
    : impl_(new Impl)
{
    impl_->margin = (btScalar)options.margin;
    if (!(options.margin >= 0) || !std::isfinite(impl_->margin))
        throw std::invalid_argument("locd::BulletBroadphase: the margin must be finite and >= 0");
    locd_engine_config ec;
    locd_engine_config_init(&ec);
    ec.threads = options.threads;
    locd_status s = locd_engine_create(&ec, &impl_->engine);
    if (s == LOCD_OK) {
        locd_scene_config sc;
        locd_scene_config_init(&sc);
        sc.flags = options.scene_flags;
        sc.capacity_hint = options.capacity_hint;
        s = locd_scene_create(impl_->engine, &sc, &impl_->scene);
    }
    if (s != LOCD_OK) {
        std::string msg = std::string("locd::BulletBroadphase: ") + locd_status_string(s) + ": " + locd_last_error();
        locd_engine_destroy(impl_->engine);
        throw std::runtime_error(msg);
    }
    if (pairCache) {
        impl_->cache = pairCache;
    } else {
        impl_->cache = new btHashedOverlappingPairCache();
        impl_->owns_cache = true;
    }
}

BulletBroadphase::~BulletBroadphase()
{
    locd_scene_destroy(impl_->scene);
    locd_engine_destroy(impl_->engine);
    if (impl_->owns_cache)
        delete impl_->cache;
}

btBroadphaseProxy *BulletBroadphase::createProxy(const btVector3 &aabbMin, const btVector3 &aabbMax, int shapeType,
                                                 void *userPtr, int collisionFilterGroup, int collisionFilterMask,
                                                 btDispatcher *dispatcher)
{
    (void)shapeType;
    (void)dispatcher;
    Impl &m = *impl_;
    BulletProxy *p;
    // A dead slot waits behind kQuarantine others before its reuse, so a
    // late call on the dead proxy still finds it dead.
    if (m.free_slots.size() <= Impl::kQuarantine) {
        p = m.pool.add();
    } else {
        p = m.free_slots.front();
        m.free_slots.pop_front();
    }
    p->m_clientObject = userPtr;
    p->m_collisionFilterGroup = collisionFilterGroup;
    p->m_collisionFilterMask = collisionFilterMask;
    p->m_uniqueId = ++m.next_uid;
    p->m_aabbMin = aabbMin;
    p->m_aabbMax = aabbMax;
    p->alive = true;
    p->id = LOCD_ID_NONE;
    p->move_batch = 0;
    m.grow(p);
    LOCD_BULLET_ASSERT(p->box_ok && "createProxy: a NaN, infinite or inverted AABB");
    if (!p->box_ok)
        m.st.misuse++;
    p->moved_frame = m.frame;
    m.mark(p);
    m.live++;
    return p;
}

void BulletBroadphase::destroyProxy(btBroadphaseProxy *proxy, btDispatcher *dispatcher)
{
    Impl &m = *impl_;
    if (!m.check(proxy))
        return;
    BulletProxy *p = static_cast<BulletProxy *>(proxy);
    m.cache->removeOverlappingPairsContainingProxy(p, dispatcher);
    if (p->move_batch == m.batch)
        m.moves.stale = true;
    if (p->id != LOCD_ID_NONE) {
        m.removed.push_back(p->id);
        m.by_id.erase(p->id);
        p->id = LOCD_ID_NONE;
    }
    // An old id still naming it (held out or re-added this frame) must not
    // reach the slot's next owner.
    for (locd_id r : m.retired) {
        auto it = m.by_id.find(r);
        if (it != m.by_id.end() && it->second == p)
            m.by_id.erase(it);
    }
    p->alive = false;
    p->m_clientObject = nullptr;
    m.free_slots.push_back(p);
    m.live--;
}

void BulletBroadphase::setAabb(btBroadphaseProxy *proxy, const btVector3 &aabbMin, const btVector3 &aabbMax,
                               btDispatcher *dispatcher)
{
    (void)dispatcher;
    Impl &m = *impl_;
    if (!m.check(proxy))
        return;
    BulletProxy *p = static_cast<BulletProxy *>(proxy);
    bool held = p->box_ok && m.holds(p, aabbMin, aabbMax);
    bool same_filter = p->m_collisionFilterGroup == p->scene_group && p->m_collisionFilterMask == p->scene_mask;
    p->m_aabbMin = aabbMin;
    p->m_aabbMax = aabbMax;
    if (held && same_filter)
        return; // a resting body's step (or one inside its grown box): nothing for the scene
    if (!held) {
        m.grow(p);
        LOCD_BULLET_ASSERT(p->box_ok && "setAabb: a NaN, infinite or inverted AABB");
        if (!p->box_ok)
            m.st.misuse++;
        p->moved_frame = m.frame;
    }
    if (same_filter && p->box_ok && p->id != LOCD_ID_NONE && !p->dirty)
        m.queue_move(p); // the common step: nothing but the box changed
    else
        m.mark(p);
}

void BulletBroadphase::getAabb(btBroadphaseProxy *proxy, btVector3 &aabbMin, btVector3 &aabbMax) const
{
    if (!impl_->check(proxy))
        return;
    aabbMin = proxy->m_aabbMin;
    aabbMax = proxy->m_aabbMax;
}

void BulletBroadphase::calculateOverlappingPairs(btDispatcher *dispatcher)
{
    Impl &m = *impl_;
    auto t0 = std::chrono::steady_clock::now();
    m.flush();
    m.st.moved = m.sent;
    m.sent = 0;
    locd_status s = locd_scene_update(m.scene, LOCD_SCENE_UPDATE_EVENTS);
    if (s != LOCD_OK) {
        failed("locd_scene_update", s);
        return;
    }
    const locd_id *rows;
    size_t n;
    locd_scene_lost(m.scene, &rows, &n);
    m.st.lost = n;
    for (size_t k = 0; k < n; k++) {
        m.rejected.erase(PairKey{rows[2 * k], rows[2 * k + 1]});
        BulletProxy *a = m.proxy_of(rows[2 * k]), *b = m.proxy_of(rows[2 * k + 1]);
        if (a && b) // else destroyed: destroyProxy removed its pairs
            m.cache->removeOverlappingPair(a, b, dispatcher);
    }
    for (locd_id r : m.retired)
        m.by_id.erase(r);
    m.retired.clear();
    // Refused pairs still overlapping: the cache's filter is asked again
    // when one of the two moved.
    for (auto it = m.rejected.begin(); it != m.rejected.end();) {
        BulletProxy *a = m.proxy_of(it->a), *b = m.proxy_of(it->b);
        if (!a || !b) {
            it = m.rejected.erase(it);
        } else if ((a->moved_frame == m.frame || b->moved_frame == m.frame) && m.cache->addOverlappingPair(a, b)) {
            it = m.rejected.erase(it);
        } else {
            ++it;
        }
    }
    locd_scene_created(m.scene, &rows, &n);
    m.st.created = n;
    for (size_t k = 0; k < n; k++) {
        BulletProxy *a = m.proxy_of(rows[2 * k]), *b = m.proxy_of(rows[2 * k + 1]);
        if (a && b && !m.cache->addOverlappingPair(a, b))
            m.rejected.insert(PairKey{rows[2 * k], rows[2 * k + 1]});
    }
    m.frame++;
    m.st.update_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

btOverlappingPairCache *BulletBroadphase::getOverlappingPairCache() { return impl_->cache; }

const btOverlappingPairCache *BulletBroadphase::getOverlappingPairCache() const { return impl_->cache; }

void BulletBroadphase::getBroadphaseAabb(btVector3 &aabbMin, btVector3 &aabbMax) const
{
    bool any = false;
    impl_->pool.each([&](const BulletProxy &p) {
        if (!p.alive || !p.box_ok)
            return;
        if (!any) {
            aabbMin = p.scene_min;
            aabbMax = p.scene_max;
            any = true;
        } else {
            aabbMin.setMin(p.scene_min);
            aabbMax.setMax(p.scene_max);
        }
    });
    if (!any)
        aabbMin = aabbMax = btVector3(0, 0, 0);
}

void BulletBroadphase::resetPool(btDispatcher *dispatcher)
{
    (void)dispatcher;
    if (impl_->live == 0)
        impl_->next_uid = 0;
}

BulletBroadphaseStats BulletBroadphase::stats() const
{
    BulletBroadphaseStats s = impl_->st;
    s.proxies = impl_->live;
    s.in_scene = locd_scene_count(impl_->scene);
    s.rejected = impl_->rejected.size();
    return s;
}

bool BulletBroadphase::sceneAabb(const btBroadphaseProxy *proxy, btVector3 &aabbMin, btVector3 &aabbMax) const
{
    if (!impl_->check(proxy))
        return false;
    const BulletProxy *p = static_cast<const BulletProxy *>(proxy);
    if (!p->box_ok)
        return false;
    aabbMin = p->scene_min;
    aabbMax = p->scene_max;
    return true;
}

const locd_scene *BulletBroadphase::scene() const { return impl_->scene; }

void BulletBroadphase::printStats()
{
    BulletBroadphaseStats s = stats();
    std::printf("locd::BulletBroadphase: %llu proxies (%llu in the scene), last update %.3f ms: +%llu -%llu pairs, "
                "%llu refused by the pair cache, %llu bad calls ignored\n",
                (unsigned long long)s.proxies, (unsigned long long)s.in_scene, s.update_ms,
                (unsigned long long)s.created, (unsigned long long)s.lost, (unsigned long long)s.rejected,
                (unsigned long long)s.misuse);
}

} // namespace locd
