// bench/queries_peers: ray and box queries on one scene, locd's scene beside Bullet's
// btDbvtBroadphase (rayTest, aabbTest), Embree 3 (a user-geometry BVH over the same boxes:
// rtcIntersect1, the ray-traversal limit on a CPU) and FCL's DynamicAABBTreeCollisionManager
// (boxes: it has no ray query). Every system answers with the same exact test (queries_common.h),
// so their checksums must agree.
//
//   queries_peers SCENE.aabb [--queries Q] [--frames F] [--threads T] [--reps R] [--systems a,b,...]
//
// --frames F: F frames of 1% of the boxes moving (every system told of them) before the queries
// (the state "after 1%-moving frames"; 0: right after the first update). One JSON line per system
// and query: microseconds per query (the median of R runs, systems interleaved), hits, checksum.
// locd: one query at a time on one thread; locd_batch: the batch call on the engine's T threads.
#include "queries_common.h"

#include <locd/scene.h>

#include <btBulletCollisionCommon.h>
#include <embree3/rtcore.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/box.h>

#include <cstring>
#include <map>
#include <memory>
#include <set>

using namespace qb;

namespace {

const char *kQueries[] = {"ray_short_all", "ray_short_closest", "ray_long_all", "ray_long_closest", "box"};
enum { RAY_SHORT_ALL, RAY_SHORT_CLOSEST, RAY_LONG_ALL, RAY_LONG_CLOSEST, BOX, NQUERY };

// A system answers the queries of one kind; returns the hits and the checksum.
struct System {
    virtual ~System() {}
    virtual const char *name() const = 0;
    virtual bool has(int kind) const = 0;
    virtual void moved(const Scene &sc, const std::vector<uint32_t> &ids) = 0;
    virtual void run(int kind, const std::vector<Query> &q, uint64_t &hits, uint64_t &sum) = 0;
};

bool closest(int kind) { return kind == RAY_SHORT_CLOSEST || kind == RAY_LONG_CLOSEST; }

// ---- locd ----

struct Locd : System {
    locd_engine *e = nullptr;
    locd_scene *s = nullptr;
    locd_hits *h = nullptr;
    std::vector<locd_id> ids, out;
    std::vector<double> t;
    bool batch;
    double prepare_ms = 0.0;
    Locd(const Scene &sc, uint32_t threads, bool b) : batch(b)
    {
        locd_engine_config cfg;
        locd_engine_config_init(&cfg);
        cfg.threads = b ? threads : 1;
        if (locd_engine_create(&cfg, &e) || locd_scene_create(e, nullptr, &s) || locd_hits_create(nullptr, &h))
            std::abort();
        ids.resize(sc.n);
        if (locd_scene_add_f32(s, sc.box.data(), sc.n, nullptr, ids.data()) || locd_scene_update(s, 0))
            std::abort();
        out.resize(sc.n + 1), t.resize(sc.n + 1);
    }
    ~Locd() override
    {
        locd_hits_destroy(h);
        locd_scene_destroy(s);
        locd_engine_destroy(e);
    }
    const char *name() const override { return batch ? "locd_batch" : "locd"; }
    bool has(int) const override { return true; }
    void moved(const Scene &sc, const std::vector<uint32_t> &m) override
    {
        std::vector<locd_id> mid(m.size());
        std::vector<float> b(6 * m.size());
        for (size_t k = 0; k < m.size(); k++) {
            mid[k] = ids[m[k]];
            std::memcpy(&b[6 * k], &sc.box[6 * (size_t)m[k]], 6 * sizeof(float));
        }
        const double a = now_us();
        if (locd_scene_move_f32(s, mid.data(), b.data(), m.size()) || locd_scene_update(s, 0))
            std::abort();
        const double u = now_us();
        if (locd_scene_prepare_queries(s)) // as a game that queries every frame: the tree's sync
            std::abort();
        update_ms.push_back((u - a) / 1e3), sync_ms.push_back((now_us() - u) / 1e3);
    }
    std::vector<double> update_ms, sync_ms; // per frame
    // The index of a box from its id: its slot (one batch added them in order).
    static uint32_t index(locd_id id) { return (uint32_t)(id & 0xffffffffu); }
    void one(int kind, const Query &x, uint64_t k, uint64_t &hits, uint64_t &sum)
    {
        size_t n = 0;
        locd_status st;
        if (kind == BOX)
            st = locd_scene_overlap_box_f32(s, x.b, nullptr, out.data(), out.size(), &n);
        else
            st = locd_scene_cast_ray_f32(s, x.o, x.d, 1.0, closest(kind) ? LOCD_HIT_CLOSEST : LOCD_HIT_ALL, nullptr,
                                         out.data(), t.data(), out.size(), &n);
        if (st)
            std::abort();
        hits += n;
        for (size_t j = 0; j < n; j++)
            sum += mix(k, index(out[j]));
    }
    void run(int kind, const std::vector<Query> &q, uint64_t &hits, uint64_t &sum) override
    {
        hits = sum = 0;
        if (!batch) {
            for (size_t k = 0; k < q.size(); k++)
                one(kind, q[k], k, hits, sum);
            return;
        }
        const size_t n = q.size();
        std::vector<float> v(6 * n), d(3 * n);
        std::vector<double> mt(n, 1.0);
        for (size_t k = 0; k < n; k++) {
            std::memcpy(&v[(kind == BOX ? 6 : 3) * k], kind == BOX ? q[k].b : q[k].o, (kind == BOX ? 6 : 3) * 4);
            std::memcpy(&d[3 * k], q[k].d, 12);
        }
        locd_status st = kind == BOX ? locd_scene_overlap_box_batch_f32(s, v.data(), n, nullptr, h)
                                     : locd_scene_cast_ray_batch_f32(s, v.data(), d.data(), mt.data(), n,
                                                                     closest(kind) ? LOCD_HIT_CLOSEST : LOCD_HIT_ALL,
                                                                     nullptr, h);
        if (st)
            std::abort();
        const uint64_t *off = locd_hits_offsets(h);
        const locd_id *hid = locd_hits_ids(h);
        for (size_t k = 0; k < n; k++)
            for (uint64_t j = off[k]; j < off[k + 1]; j++)
                if (hid[j] != LOCD_ID_NONE)
                    hits++, sum += mix(k, index(hid[j]));
    }
};

// ---- Bullet btDbvtBroadphase ----

inline uint32_t proxy_index(const btBroadphaseProxy *p) { return (uint32_t)((uintptr_t)p->m_clientObject - 1); }

struct RayCb : btBroadphaseRayCallback {
    const Query *q = nullptr;
    const float *box = nullptr;
    bool closest = false;
    double len = 1.0;
    std::vector<Hit> hits;
    Hit best{INFINITY, 0xffffffffu};
    bool process(const btBroadphaseProxy *p) override
    {
        const uint32_t i = proxy_index(p);
        const double t = ray_t(*q, box + 6 * (size_t)i);
        if (t < 0.0)
            return true;
        if (!closest) {
            hits.push_back(Hit{t, i});
        } else if (Hit{t, i} < best) {
            best = Hit{t, i};
            m_lambda_max = (btScalar)(t * len) * (btScalar)1.000001; // prune past it (a little room for rounding)
        }
        return true;
    }
};

struct AabbCb : btBroadphaseAabbCallback {
    const Query *q = nullptr;
    const float *box = nullptr;
    uint64_t k = 0, hits = 0, sum = 0;
    bool process(const btBroadphaseProxy *p) override
    {
        const uint32_t i = proxy_index(p);
        if (box_meets(*q, box + 6 * (size_t)i))
            hits++, sum += mix(k, i);
        return true;
    }
};

struct Bullet : System {
    btDefaultCollisionConfiguration cfg;
    btCollisionDispatcher disp{&cfg};
    btDbvtBroadphase bp;
    std::vector<btBroadphaseProxy *> proxies;
    const Scene *sc;
    explicit Bullet(const Scene &s) : sc(&s)
    {
        proxies.resize(s.n);
        for (size_t i = 0; i < s.n; i++) {
            const float *b = &s.box[6 * i];
            proxies[i] = bp.createProxy(btVector3(b[0], b[1], b[2]), btVector3(b[3], b[4], b[5]), BOX_SHAPE_PROXYTYPE,
                                        (void *)(uintptr_t)(i + 1), btBroadphaseProxy::DefaultFilter,
                                        btBroadphaseProxy::AllFilter, &disp);
        }
        bp.calculateOverlappingPairs(&disp);
    }
    const char *name() const override { return "bullet_dbvt"; }
    bool has(int) const override { return true; }
    void moved(const Scene &s, const std::vector<uint32_t> &m) override
    {
        for (uint32_t i : m) {
            const float *b = &s.box[6 * (size_t)i];
            bp.setAabb(proxies[i], btVector3(b[0], b[1], b[2]), btVector3(b[3], b[4], b[5]), &disp);
        }
        bp.calculateOverlappingPairs(&disp);
    }
    void run(int kind, const std::vector<Query> &q, uint64_t &hits, uint64_t &sum) override
    {
        hits = sum = 0;
        for (size_t k = 0; k < q.size(); k++) {
            const Query &x = q[k];
            if (kind == BOX) {
                AabbCb cb;
                cb.q = &x, cb.box = sc->box.data(), cb.k = k;
                bp.aabbTest(btVector3(x.b[0], x.b[1], x.b[2]), btVector3(x.b[3], x.b[4], x.b[5]), cb);
                hits += cb.hits, sum += cb.sum;
                continue;
            }
            // As btCollisionWorld::rayTest sets the callback up.
            RayCb cb;
            const btVector3 from(x.o[0], x.o[1], x.o[2]), to(x.o[0] + x.d[0], x.o[1] + x.d[1], x.o[2] + x.d[2]);
            btVector3 dir = to - from;
            cb.len = dir.length();
            if (cb.len > 0)
                dir /= (btScalar)cb.len;
            for (int a = 0; a < 3; a++) {
                cb.m_rayDirectionInverse[a] = dir[a] == btScalar(0.0) ? btScalar(BT_LARGE_FLOAT) : btScalar(1.0) / dir[a];
                cb.m_signs[a] = cb.m_rayDirectionInverse[a] < 0.0;
            }
            cb.m_lambda_max = dir.dot(to - from);
            cb.q = &x, cb.box = sc->box.data(), cb.closest = closest(kind);
            bp.rayTest(from, to, cb);
            if (cb.closest && cb.best.i != 0xffffffffu)
                hits++, sum += mix(k, cb.best.i);
            for (const Hit &h : cb.hits)
                hits++, sum += mix(k, h.i);
        }
    }
};

// ---- Embree 3: a user-geometry BVH over the boxes ----

struct EmbreeCtx {
    RTCIntersectContext ctx; // first: Embree passes a pointer to it
    const Query *q;
    const float *box;
    bool closest;
    std::vector<Hit> *hits;
    Hit best;
};

void embree_bounds(const RTCBoundsFunctionArguments *args)
{
    const float *b = (const float *)args->geometryUserPtr + 6 * (size_t)args->primID;
    RTCBounds *o = args->bounds_o;
    o->lower_x = b[0], o->lower_y = b[1], o->lower_z = b[2];
    o->upper_x = b[3], o->upper_y = b[4], o->upper_z = b[5];
}

void embree_intersect(const RTCIntersectFunctionNArguments *args)
{
    EmbreeCtx *c = (EmbreeCtx *)args->context;
    if (!args->valid[0])
        return;
    const uint32_t i = args->primID;
    const double t = ray_t(*c->q, c->box + 6 * (size_t)i);
    if (t < 0.0)
        return;
    RTCRayHit *rh = (RTCRayHit *)args->rayhit;
    if (!c->closest) {
        c->hits->push_back(Hit{t, i});
        return;
    }
    if (Hit{t, i} < c->best) {
        c->best = Hit{t, i};
        rh->ray.tfar = std::nextafter((float)t, INFINITY); // farther boxes pruned; ties still seen
        rh->hit.geomID = args->geomID, rh->hit.primID = i;
    }
}

struct Embree : System {
    RTCDevice dev;
    RTCScene scn;
    const Scene *sc;
    explicit Embree(const Scene &s) : sc(&s)
    {
        dev = rtcNewDevice("threads=1");
        scn = rtcNewScene(dev);
        RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_USER);
        rtcSetGeometryUserPrimitiveCount(g, (unsigned)s.n);
        rtcSetGeometryUserData(g, (void *)s.box.data());
        rtcSetGeometryBoundsFunction(g, embree_bounds, nullptr);
        rtcSetGeometryIntersectFunction(g, embree_intersect);
        rtcCommitGeometry(g);
        rtcAttachGeometry(scn, g);
        rtcReleaseGeometry(g);
        rtcCommitScene(scn);
    }
    ~Embree() override
    {
        rtcReleaseScene(scn);
        rtcReleaseDevice(dev);
    }
    const char *name() const override { return "embree"; }
    bool has(int kind) const override { return kind != BOX; }
    void moved(const Scene &, const std::vector<uint32_t> &) override { rtcCommitScene(scn); }
    void run(int kind, const std::vector<Query> &q, uint64_t &hits, uint64_t &sum) override
    {
        std::vector<Hit> hv;
        hits = sum = 0;
        for (size_t k = 0; k < q.size(); k++) {
            const Query &x = q[k];
            EmbreeCtx c;
            rtcInitIntersectContext(&c.ctx);
            c.q = &x, c.box = sc->box.data(), c.closest = closest(kind), c.hits = &hv, c.best = Hit{INFINITY, 0xffffffffu};
            hv.clear();
            RTCRayHit rh;
            rh.ray.org_x = x.o[0], rh.ray.org_y = x.o[1], rh.ray.org_z = x.o[2];
            rh.ray.dir_x = x.d[0], rh.ray.dir_y = x.d[1], rh.ray.dir_z = x.d[2];
            rh.ray.tnear = 0.0f, rh.ray.tfar = 1.0f, rh.ray.time = 0.0f;
            rh.ray.mask = 0xffffffffu, rh.ray.id = 0, rh.ray.flags = 0;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID, rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scn, &c.ctx, &rh);
            if (c.closest && c.best.i != 0xffffffffu)
                hits++, sum += mix(k, c.best.i);
            for (const Hit &h : hv)
                hits++, sum += mix(k, h.i);
        }
    }
};

// ---- FCL DynamicAABBTreeCollisionManager (boxes) ----

class BoxObject : public fcl::CollisionObjectd {
public:
    BoxObject(const std::shared_ptr<fcl::CollisionGeometryd> &g, const float *b) : fcl::CollisionObjectd(g) { set(b); }
    void set(const float *b)
    {
        aabb.min_ = fcl::Vector3d(b[0], b[1], b[2]);
        aabb.max_ = fcl::Vector3d(b[3], b[4], b[5]);
    }
};

struct FclCtx {
    const Query *q;
    const float *box;
    uint64_t k, hits, sum;
};

bool fcl_collect(fcl::CollisionObjectd *a, fcl::CollisionObjectd *b, void *data)
{
    FclCtx *c = (FclCtx *)data;
    fcl::CollisionObjectd *o = a->getUserData() ? a : b;
    const uint32_t i = (uint32_t)((uintptr_t)o->getUserData() - 1);
    if (box_meets(*c->q, c->box + 6 * (size_t)i))
        c->hits++, c->sum += mix(c->k, i);
    return false;
}

struct Fcl : System {
    std::shared_ptr<fcl::Boxd> unit = std::make_shared<fcl::Boxd>(1.0, 1.0, 1.0);
    std::vector<std::unique_ptr<BoxObject>> objs;
    fcl::DynamicAABBTreeCollisionManagerd m;
    const Scene *sc;
    explicit Fcl(const Scene &s) : sc(&s)
    {
        std::vector<fcl::CollisionObjectd *> p(s.n);
        for (size_t i = 0; i < s.n; i++) {
            objs.emplace_back(new BoxObject(unit, &s.box[6 * i]));
            objs.back()->setUserData((void *)(uintptr_t)(i + 1));
            p[i] = objs.back().get();
        }
        m.registerObjects(p);
        m.setup();
    }
    const char *name() const override { return "fcl_dynamic_aabb_tree"; }
    bool has(int kind) const override { return kind == BOX; }
    void moved(const Scene &s, const std::vector<uint32_t> &ids) override
    {
        std::vector<fcl::CollisionObjectd *> p;
        for (uint32_t i : ids) {
            objs[i]->set(&s.box[6 * (size_t)i]);
            p.push_back(objs[i].get());
        }
        m.update(p);
    }
    void run(int, const std::vector<Query> &q, uint64_t &hits, uint64_t &sum) override
    {
        hits = sum = 0;
        for (size_t k = 0; k < q.size(); k++) {
            BoxObject probe(unit, q[k].b);
            probe.setUserData(nullptr);
            FclCtx c{&q[k], sc->box.data(), k, 0, 0};
            m.collide(&probe, &c, fcl_collect);
            hits += c.hits, sum += c.sum;
        }
    }
};

} // namespace

int main(int argc, char **argv)
{
    if (argc < 2) {
        std::fprintf(stderr, "usage: queries_peers SCENE.aabb [--queries Q] [--frames F] [--threads T] [--reps R] "
                             "[--systems locd,locd_batch,bullet_dbvt,embree,fcl_dynamic_aabb_tree]\n");
        return 2;
    }
    size_t nq = 2000;
    int frames = 0, reps = 3;
    uint32_t threads = 2;
    std::string systems = "locd,locd_batch,bullet_dbvt,embree,fcl_dynamic_aabb_tree";
    for (int i = 2; i + 1 < argc; i += 2) {
        const std::string a = argv[i];
        if (a == "--queries")
            nq = (size_t)std::atol(argv[i + 1]);
        else if (a == "--frames")
            frames = std::atoi(argv[i + 1]);
        else if (a == "--threads")
            threads = (uint32_t)std::atoi(argv[i + 1]);
        else if (a == "--reps")
            reps = std::atoi(argv[i + 1]);
        else if (a == "--systems")
            systems = argv[i + 1];
    }
    Scene sc;
    if (!load(argv[1], sc)) {
        std::fprintf(stderr, "cannot read %s\n", argv[1]);
        return 1;
    }
    std::vector<std::unique_ptr<System>> sys;
    std::map<std::string, double> setup_ms;
    auto want = [&](const char *n) { return ("," + systems + ",").find("," + std::string(n) + ",") != std::string::npos; };
    auto add = [&](System *s) {
        sys.emplace_back(s);
    };
    double t0 = now_us();
    if (want("locd")) {
        Locd *l = new Locd(sc, 1, false);
        const double t1 = now_us();
        locd_scene_prepare_queries(l->s);
        std::printf("{\"system\": \"locd\", \"setup\": \"query tree\", \"n\": %zu, \"ms\": %.3f}\n", sc.n,
                    (now_us() - t1) / 1e3);
        add(l);
    }
    if (want("locd_batch"))
        add(new Locd(sc, threads, true));
    if (want("bullet_dbvt"))
        add(new Bullet(sc));
    if (want("embree") && frames == 0) {
        t0 = now_us();
        add(new Embree(sc));
        std::printf("{\"system\": \"embree\", \"setup\": \"BVH build\", \"n\": %zu, \"ms\": %.3f}\n", sc.n,
                    (now_us() - t0) / 1e3);
    }
    if (want("fcl_dynamic_aabb_tree"))
        add(new Fcl(sc));
    Rng r(7);
    std::vector<uint32_t> moved;
    for (int f = 0; f < frames; f++) {
        frame(sc, r, 0.01, moved);
        for (auto &s : sys)
            s->moved(sc, moved);
    }
    for (auto &s : sys)
        if (Locd *l = dynamic_cast<Locd *>(s.get()))
            if (!l->batch && !l->update_ms.empty()) {
                std::sort(l->update_ms.begin(), l->update_ms.end());
                std::sort(l->sync_ms.begin(), l->sync_ms.end());
                std::printf("{\"system\": \"locd\", \"setup\": \"frame\", \"n\": %zu, \"update_ms\": %.3f, "
                            "\"sync_ms\": %.3f}\n", sc.n, l->update_ms[l->update_ms.size() / 2],
                            l->sync_ms[l->sync_ms.size() / 2]);
            }
    const char *state = frames ? "frames" : "first";
    std::vector<Query> q[NQUERY];
    q[RAY_SHORT_ALL] = q[RAY_SHORT_CLOSEST] = draw(sc, nq, 0.05, 11);
    q[RAY_LONG_ALL] = q[RAY_LONG_CLOSEST] = draw(sc, nq, 1.5, 12);
    q[BOX] = draw(sc, nq, 0.0, 13);
    for (int kind = 0; kind < NQUERY; kind++) {
        std::map<std::string, std::vector<double>> us;
        std::map<std::string, std::pair<uint64_t, uint64_t>> res;
        for (int rep = 0; rep < reps; rep++)
            for (size_t j = 0; j < sys.size(); j++) {
                System &s = *sys[(j + (size_t)rep) % sys.size()]; // the order rotates
                if (!s.has(kind))
                    continue;
                uint64_t hits, sum;
                const double a = now_us();
                s.run(kind, q[kind], hits, sum);
                us[s.name()].push_back((now_us() - a) / (double)nq);
                res[s.name()] = std::make_pair(hits, sum);
            }
        for (auto &s : sys)
            if (s->has(kind)) {
                std::vector<double> &v = us[s->name()];
                std::sort(v.begin(), v.end());
                print(s->name(), kQueries[kind], sc.n, state, v[v.size() / 2], res[s->name()].first,
                      res[s->name()].second);
            }
    }
    return 0;
}
