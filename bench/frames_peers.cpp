// bench/frames_peers: frame to frame, locd's scene against the incremental
// paths of Bullet's btDbvtBroadphase and FCL's DynamicAABBTreeCollisionManager.
//
//   frames_peers SCENE.aabb --moving P --frames F [--static S] [--threads T]
//                [--seed N] [--warmup W] [--peers locd,rebuild,bullet,fcl]
//                [--pause MS] [--evict MB]
//
// Every system is built once from the scene and then kept across frames, as
// a game or a simulation keeps its broad phase. Each frame, the workload of
// `locd frames` (tools/frames_motion.c, same seed = same frames) moves a
// fraction P of the non-static boxes; then, in turn (the order rotating from
// frame to frame, so no system always runs first):
//   locd     locd_scene_move_f32 + locd_scene_update (pairs and created/lost)
//   locd_1t  the same on an engine of one thread
//   rebuild  locd_engine_find_pairs_f32 on all the boxes (no scene)
//   bullet   btDbvtBroadphase::setAabb for each moved proxy, then
//            calculateOverlappingPairs (its pair cache holds the pairs);
//            static boxes are proxies of StaticFilter that do not collide
//            with each other (Bullet's own rule); coordinates scaled by a
//            power of two to Bullet's unit-sized regime (bullet_scale); then
//            one pass over its pair cache keeps the pairs whose boxes overlap
//            (the cache is a superset: margins, incremental cleanup)
//   fcl      each moved object's AABB set, DynamicAABBTreeCollisionManager::
//            update(moved objects), then collide() (dynamic x dynamic) and
//            collide(static manager) (dynamic x static): statics live in a
//            manager of their own, built once, so static pairs cost nothing
// and it prints one JSON line: the median ms per frame of each system (and the mean), and the
// pairs each one holds after the last frame. The first W frames (--warmup,
// 2 by default) run the same way and are not counted: each system's first
// frames touch memory for the first time (locd's rotating pair lists and kept
// entry list, the peers' pair caches), which a kept broad phase pays once. locd uses T threads; Bullet and
// FCL have no threads on these paths (one core).
//
// In a game the broad phase runs once a frame between the rest of the
// frame's work: its threads idle and its memory leaves the caches. Before
// each system's frame (not timed), --pause MS sleeps MS milliseconds (the
// threads idle: a pool's workers sleep) and --evict MB writes and reads a
// buffer of MB megabytes (the caches fill with other data).
#include "peers.h"

extern "C" {
#include "cli.h"
#include "frames_motion.h"
#include <locd/scene.h>
}

#include <btBulletCollisionCommon.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/box.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <string>
#include <vector>

double peer_now_ms()
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

namespace {

[[noreturn]] void die(const std::string &msg)
{
    std::fprintf(stderr, "frames_peers: %s\n", msg.c_str());
    std::exit(1);
}

void ok(locd_status st, const char *what)
{
    if (st != LOCD_OK)
        die(std::string(what) + ": " + locd_last_error());
}

double median(std::vector<double> v)
{
    if (v.empty())
        return 0.0;
    std::sort(v.begin(), v.end());
    std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// One system kept across frames.
struct system_base {
    std::vector<double> ms;
    virtual ~system_base() = default;
    virtual const char *name() const = 0;
    virtual void frame(const frames_motion &m, const float *boxes) = 0;
    virtual std::size_t pairs() const = 0;
};

// ---- locd ----

struct locd_sys : system_base {
    locd_engine *eng = nullptr;
    locd_scene *scene = nullptr;
    std::vector<locd_id> ids, mid;
    std::vector<float> mbox;
    const char *label;
    locd_sys(locd_engine *e, const frames_motion &m, const float *boxes, const char *name_) : eng(e), label(name_)
    {
        ok(locd_scene_create(eng, nullptr, &scene), "scene");
        ids.resize(m.n);
        for (int pass = 0; pass < 2; pass++) {
            std::vector<std::uint32_t> order;
            std::vector<float> b;
            for (std::size_t i = 0; i < m.n; i++)
                if ((m.is_static[i] != 0) == (pass == 0)) {
                    order.push_back((std::uint32_t)i);
                    b.insert(b.end(), boxes + 6 * i, boxes + 6 * i + 6);
                }
            std::vector<locd_id> got(order.size());
            locd_scene_add_options opt;
            locd_scene_add_options_init(&opt);
            opt.flags = pass == 0 ? LOCD_OBJECT_STATIC : 0u;
            ok(locd_scene_add_f32(scene, b.data(), order.size(), &opt, got.data()), "add");
            for (std::size_t k = 0; k < order.size(); k++)
                ids[order[k]] = got[k];
        }
        ok(locd_scene_update(scene, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS), "update");
    }
    ~locd_sys() override { locd_scene_destroy(scene); }
    const char *name() const override { return label; }
    void frame(const frames_motion &m, const float *boxes) override
    {
        mid.resize(m.moved);
        mbox.resize(6 * m.moved);
        for (std::size_t k = 0; k < m.moved; k++) {
            std::uint32_t i = m.dynamic[k];
            mid[k] = ids[i];
            std::memcpy(&mbox[6 * k], boxes + 6 * (std::size_t)i, 6 * sizeof(float));
        }
        double t0 = peer_now_ms();
        ok(locd_scene_move_f32(scene, mid.data(), mbox.data(), m.moved), "move");
        ok(locd_scene_update(scene, LOCD_SCENE_UPDATE_PAIRS | LOCD_SCENE_UPDATE_EVENTS), "update");
        ms.push_back(peer_now_ms() - t0);
    }
    std::size_t pairs() const override
    {
        const locd_id *p;
        std::size_t c = 0;
        locd_scene_pairs(scene, &p, &c);
        return c;
    }
};

struct rebuild_sys : system_base {
    locd_engine *eng;
    locd_pairs *out = nullptr;
    std::size_t n;
    explicit rebuild_sys(locd_engine *e, std::size_t n_) : eng(e), n(n_) { ok(locd_pairs_create(nullptr, &out), "pairs"); }
    ~rebuild_sys() override { locd_pairs_destroy(out); }
    const char *name() const override { return "rebuild"; }
    void frame(const frames_motion &, const float *boxes) override
    {
        double t0 = peer_now_ms();
        ok(locd_engine_find_pairs_f32(eng, boxes, n, 0, out), "find_pairs");
        ms.push_back(peer_now_ms() - t0);
    }
    std::size_t pairs() const override { return locd_pairs_count(out); } // static-static pairs included
};

// ---- Bullet ----

// Bullet's tree margin (DBVT_BP_MARGIN, 0.05) is absolute: it is made for
// boxes about a unit in size. The boxes are scaled for Bullet by the power of
// two that brings the mean edge nearest to 1: exact in floating point, so
// the overlaps (and the work) are the same, in Bullet's own regime.
float bullet_scale(const frames_motion &m)
{
    double edge = m.step / 0.03; // frames_motion: step = 3% of the mean edge
    return edge > 0.0 ? (float)std::ldexp(1.0, -(int)std::lround(std::log2(edge))) : 1.0f;
}

struct bullet_sys : system_base {
    btDefaultCollisionConfiguration cfg;
    btCollisionDispatcher disp{&cfg};
    btDbvtBroadphase *bp = nullptr;
    std::vector<btBroadphaseProxy *> proxies;
    float scale;
    btVector3 lo(const float *b) const { return btVector3(scale * b[0], scale * b[1], scale * b[2]); }
    btVector3 hi(const float *b) const { return btVector3(scale * b[3], scale * b[4], scale * b[5]); }
    bullet_sys(const frames_motion &m, const float *boxes) : scale(bullet_scale(m))
    {
        bp = new btDbvtBroadphase();
        proxies.resize(m.n);
        for (std::size_t i = 0; i < m.n; i++) {
            const float *b = boxes + 6 * i;
            int group = m.is_static[i] ? btBroadphaseProxy::StaticFilter : btBroadphaseProxy::DefaultFilter;
            int mask = m.is_static[i] ? btBroadphaseProxy::AllFilter ^ btBroadphaseProxy::StaticFilter
                                      : btBroadphaseProxy::AllFilter;
            proxies[i] = bp->createProxy(lo(b), hi(b), BOX_SHAPE_PROXYTYPE, (void *)(std::uintptr_t)(i + 1), group, mask, &disp);
        }
        bp->calculateOverlappingPairs(&disp);
    }
    ~bullet_sys() override
    {
        // As in peer_bullet.cpp: the trees and the pair cache go with the
        // broadphase; destroyProxy one by one would scan the cache per proxy.
        delete bp;
        for (btBroadphaseProxy *p : proxies)
            btAlignedFree(p);
    }
    const char *name() const override { return "bullet_dbvt"; }
    void frame(const frames_motion &m, const float *boxes) override
    {
        double t0 = peer_now_ms();
        for (std::size_t k = 0; k < m.moved; k++) {
            std::uint32_t i = m.dynamic[k];
            const float *b = boxes + 6 * (std::size_t)i;
            bp->setAabb(proxies[i], lo(b), hi(b), &disp);
        }
        bp->calculateOverlappingPairs(&disp);
        exact = exact_pairs();
        ms.push_back(peer_now_ms() - t0);
    }
    // The pair cache holds every pair whose margin-fattened tree volumes
    // overlap (and keeps a pair until its incremental cleanup finds them
    // apart): a superset. The exact pairs are those whose proxies' own boxes
    // overlap (closed test), one pass over the cache, timed with the frame.
    std::size_t exact_pairs() const
    {
        btOverlappingPairCache *pc = bp->getOverlappingPairCache();
        const btBroadphasePair *arr = pc->getOverlappingPairArrayPtr();
        int m = pc->getNumOverlappingPairs();
        std::size_t k = 0;
        for (int i = 0; i < m; i++) {
            const btBroadphaseProxy *a = arr[i].m_pProxy0, *b = arr[i].m_pProxy1;
            k += TestAabbAgainstAabb2(a->m_aabbMin, a->m_aabbMax, b->m_aabbMin, b->m_aabbMax) ? 1 : 0;
        }
        return k;
    }
    std::size_t exact = 0;
    std::size_t pairs() const override { return exact; }
};

// ---- FCL ----

class box_object : public fcl::CollisionObjectd {
public:
    box_object(const std::shared_ptr<fcl::CollisionGeometryd> &g, const float *b) : fcl::CollisionObjectd(g)
    {
        set_box(b);
    }
    void set_box(const float *b)
    {
        aabb.min_ = fcl::Vector3d(b[0], b[1], b[2]);
        aabb.max_ = fcl::Vector3d(b[3], b[4], b[5]);
    }
};

bool count_pair(fcl::CollisionObjectd *, fcl::CollisionObjectd *, void *data)
{
    ++*static_cast<std::size_t *>(data);
    return false; // keep going
}

struct fcl_sys : system_base {
    std::shared_ptr<fcl::Boxd> geom = std::make_shared<fcl::Boxd>(1.0, 1.0, 1.0);
    std::vector<std::unique_ptr<box_object>> objs;
    fcl::DynamicAABBTreeCollisionManager<double> dyn, stat;
    std::vector<fcl::CollisionObjectd *> moved;
    std::size_t npairs = 0;
    bool any_static = false;
    fcl_sys(const frames_motion &m, const float *boxes)
    {
        std::vector<fcl::CollisionObjectd *> d, s;
        objs.reserve(m.n);
        for (std::size_t i = 0; i < m.n; i++) {
            objs.emplace_back(new box_object(geom, boxes + 6 * i));
            objs.back()->setUserData((void *)(std::uintptr_t)i);
            (m.is_static[i] ? s : d).push_back(objs.back().get());
        }
        any_static = !s.empty();
        dyn.registerObjects(d);
        dyn.setup();
        stat.registerObjects(s);
        stat.setup();
    }
    const char *name() const override { return "fcl_dynamic_aabb_tree"; }
    void frame(const frames_motion &m, const float *boxes) override
    {
        moved.resize(m.moved);
        double t0 = peer_now_ms();
        for (std::size_t k = 0; k < m.moved; k++) {
            std::uint32_t i = m.dynamic[k];
            objs[i]->set_box(boxes + 6 * (std::size_t)i);
            moved[k] = objs[i].get();
        }
        dyn.update(moved);
        npairs = 0;
        dyn.collide(&npairs, count_pair);
        if (any_static)
            dyn.collide(&stat, &npairs, count_pair);
        ms.push_back(peer_now_ms() - t0);
    }
    std::size_t pairs() const override { return npairs; }
};

struct args {
    const char *scene = nullptr;
    double moving = -1.0, static_frac = 0.0;
    std::size_t frames = 0, warmup = 2;
    std::uint32_t threads = 0;
    std::uint64_t seed = 1;
    std::string peers = "locd,locd_1t,rebuild,bullet,fcl";
    std::string label;
    double pause_ms = 0.0, evict_mb = 0.0;
};

// The rest of a game's frame, before each system's frame (--pause, --evict).
struct between_frames {
    double pause_ms;
    std::vector<unsigned char> buf;
    between_frames(double pause, double evict_mb) : pause_ms(pause), buf((std::size_t)(evict_mb * 1048576.0)) {}
    void run()
    {
        if (!buf.empty()) { // every cache line written, then read: the caches hold this buffer
            volatile unsigned sum = 0;
            for (std::size_t i = 0; i < buf.size(); i += 64)
                buf[i] = (unsigned char)(buf[i] + 1);
            for (std::size_t i = 0; i < buf.size(); i += 64)
                sum = sum + buf[i];
        }
        if (pause_ms > 0)
            cli_sleep_ms(pause_ms);
    }
};

args parse(int argc, char **argv)
{
    args a;
    for (int i = 1; i < argc; i++) {
        std::string o = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : nullptr;
        if (o == "--help" || o == "-h") {
            std::printf("usage: frames_peers SCENE.aabb --moving P --frames F [--static S] [--threads T] [--seed N]\n"
                        "                    [--warmup W] [--peers locd,locd_1t,rebuild,bullet,fcl] [--label TEXT]\n"
                        "                    [--pause MS] [--evict MB]\n"
                        "  --warmup W  frames run first and not counted (default 2)\n"
                        "  --pause MS  sleep MS milliseconds before each system's frame (its threads idle)\n"
                        "  --evict MB  write and read MB megabytes before each system's frame (cold caches)\n");
            std::exit(0);
        }
        if (o.rfind("--", 0) == 0 && !v)
            die(o + " needs a value");
        if (o == "--moving")
            a.moving = std::atof(argv[++i]);
        else if (o == "--static")
            a.static_frac = std::atof(argv[++i]);
        else if (o == "--frames")
            a.frames = (std::size_t)std::atol(argv[++i]);
        else if (o == "--warmup")
            a.warmup = (std::size_t)std::atol(argv[++i]);
        else if (o == "--threads")
            a.threads = (std::uint32_t)std::atol(argv[++i]);
        else if (o == "--seed")
            a.seed = std::strtoull(argv[++i], nullptr, 10);
        else if (o == "--peers")
            a.peers = argv[++i];
        else if (o == "--label")
            a.label = argv[++i];
        else if (o == "--pause")
            a.pause_ms = std::atof(argv[++i]);
        else if (o == "--evict")
            a.evict_mb = std::atof(argv[++i]);
        else if (o.rfind("--", 0) == 0)
            die("unknown option " + o);
        else
            a.scene = argv[i];
    }
    if (!a.scene || !(a.moving >= 0.0 && a.moving <= 1.0) || !(a.static_frac >= 0.0 && a.static_frac <= 1.0) ||
        a.frames < 1 || !(a.pause_ms >= 0.0 && a.pause_ms <= 60000.0) || !(a.evict_mb >= 0.0 && a.evict_mb <= 4096.0))
        die("usage: frames_peers SCENE.aabb --moving P --frames F [--static S] (see --help)");
    return a;
}

bool wants(const args &a, const char *name)
{
    std::string list = "," + a.peers + ",";
    return list.find(std::string(",") + name + ",") != std::string::npos;
}

} // namespace

int main(int argc, char **argv)
{
    args a = parse(argc, argv);
    cli_scene sc;
    if (cli_load_scene(a.scene, &sc) != 0 || sc.f64)
        die("cannot read the float32 scene " + std::string(a.scene));
    std::vector<float> boxes(sc.f, sc.f + 6 * sc.n);
    frames_motion m;
    if (frames_motion_init(&m, boxes.data(), sc.n, a.static_frac, a.moving, a.seed) != 0)
        die("out of memory");
    locd_engine *eng = nullptr, *eng1 = nullptr;
    locd_engine_config cfg;
    locd_engine_config_init(&cfg);
    cfg.threads = a.threads;
    ok(locd_engine_create(&cfg, &eng), "engine");
    cfg.threads = 1; // like for like with the single-threaded peers
    ok(locd_engine_create(&cfg, &eng1), "engine");

    std::vector<std::unique_ptr<system_base>> sys;
    std::vector<double> setup_ms;
    between_frames between(a.pause_ms, a.evict_mb);
    try {
        auto add = [&](system_base *s, double t0) {
            sys.emplace_back(s);
            setup_ms.push_back(peer_now_ms() - t0);
        };
        double t0;
        if (wants(a, "locd"))
            t0 = peer_now_ms(), add(new locd_sys(eng, m, boxes.data(), "locd"), t0);
        if (wants(a, "locd_1t"))
            t0 = peer_now_ms(), add(new locd_sys(eng1, m, boxes.data(), "locd_1t"), t0);
        if (wants(a, "rebuild"))
            t0 = peer_now_ms(), add(new rebuild_sys(eng, sc.n), t0);
        if (wants(a, "bullet"))
            t0 = peer_now_ms(), add(new bullet_sys(m, boxes.data()), t0);
        if (wants(a, "fcl"))
            t0 = peer_now_ms(), add(new fcl_sys(m, boxes.data()), t0);
        for (std::size_t f = 0; f < a.warmup + a.frames; f++) {
            if (f == a.warmup)
                for (auto &x : sys)
                    x->ms.clear();
            frames_motion_step(&m, boxes.data());
            for (std::size_t k = 0; k < sys.size(); k++) {
                between.run();
                sys[(f + k) % sys.size()]->frame(m, boxes.data());
            }
        }
    } catch (const std::exception &e) {
        die(std::string("a peer threw: ") + e.what());
    }

    char cpu[256];
    cli_cpu_model(cpu, sizeof cpu);
    const char *kernel = std::getenv("LOCD_KERNEL");
    locd_stats st;
    locd_stats_init(&st);
    locd_engine_get_stats(eng, &st);
    std::printf("{\"label\":\"%s\",\"n\":%zu,\"static_fraction\":%.4g,\"moving\":%.4g,\"moved_per_frame\":%zu,"
                "\"frames\":%zu,\"warmup\":%zu,\"pause_ms\":%.4g,\"evict_mb\":%.4g,\"threads\":%u,\"seed\":%llu,"
                "\"cpu\":\"%s\",\"kernel\":\"%s\",\"systems\":{",
                a.label.c_str(), sc.n, a.static_frac, a.moving, m.moved, a.frames, a.warmup, a.pause_ms, a.evict_mb, st.threads,
                (unsigned long long)a.seed, cpu, kernel && *kernel ? kernel : "auto");
    for (std::size_t k = 0; k < sys.size(); k++)
        std::printf("%s\"%s\":{\"ms\":%.4f,\"mean_ms\":%.4f,\"setup_ms\":%.2f,\"pairs\":%zu}", k ? "," : "",
                    sys[k]->name(), median(sys[k]->ms), cli_mean(sys[k]->ms.data(), sys[k]->ms.size()), setup_ms[k], sys[k]->pairs());
    std::printf("}}\n");
    sys.clear();
    locd_engine_destroy(eng);
    locd_engine_destroy(eng1);
    frames_motion_free(&m);
    cli_free_scene(&sc);
    return 0;
}
