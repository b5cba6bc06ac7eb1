// Bullet's stepSimulation on three broad phases: btDbvtBroadphase,
// btAxisSweep3 (bt32BitAxisSweep3 past 16,000 bodies) and
// locd::BulletBroadphase (exact, and with btDbvtBroadphase's margin: locd-margin, not run unless
// asked), on three scenes scaled to n bodies, with R ray
// casts per step (docs/benchmarks.md, "Bullet: a world on locd").
//
//   build/bench/bullet [--sizes 1000,10000] [--steps 40] [--warmup 10] [--rays 1000] [--threads 2]
//                      [--scenes tower,stacks,heap] [--broadphases dbvt,sap,locd,locd-margin] [--reps 3]
//
// Per step: the whole stepSimulation, the broad phase's own time (every call
// into it, timed by a forwarding wrapper: setAabb, create/destroy,
// calculateOverlappingPairs) and the ray casts (ClosestRayResultCallback,
// narrow phase included). Medians over the measured steps; with --reps the
// median of each run's medians. Each scene is built afresh per broad phase.
#include "world.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

using namespace locd_test;

namespace {

double now_ms()
{
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Forwards every call and adds up the time spent inside the broad phase.
// setAabb calls are held and forwarded in one timed batch before the next
// other call (in a step: calculateOverlappingPairs), in the order Bullet
// made them: a clock read costs about 30 ns here, so timing each of 10^4
// calls would add more than some broad phases' whole time.
struct Timed : btBroadphaseInterface {
    btBroadphaseInterface *in;
    double ms = 0;
    struct Move {
        btBroadphaseProxy *p;
        btVector3 a, b;
        btDispatcher *d;
    };
    std::vector<Move> held;
    explicit Timed(btBroadphaseInterface *inner) : in(inner) {}
    struct Clock {
        double &acc;
        double t0 = now_ms();
        ~Clock() { acc += now_ms() - t0; }
    };
    void forward_held()
    {
        if (held.empty())
            return;
        Clock c{ms};
        for (const Move &m : held)
            in->setAabb(m.p, m.a, m.b, m.d);
        held.clear();
    }
    btBroadphaseProxy *createProxy(const btVector3 &a, const btVector3 &b, int s, void *u, int g, int m,
                                   btDispatcher *d) override
    {
        forward_held();
        Clock c{ms};
        return in->createProxy(a, b, s, u, g, m, d);
    }
    void destroyProxy(btBroadphaseProxy *p, btDispatcher *d) override
    {
        forward_held();
        Clock c{ms};
        in->destroyProxy(p, d);
    }
    void setAabb(btBroadphaseProxy *p, const btVector3 &a, const btVector3 &b, btDispatcher *d) override
    {
        held.push_back(Move{p, a, b, d});
    }
    void getAabb(btBroadphaseProxy *p, btVector3 &a, btVector3 &b) const override
    {
        const_cast<Timed *>(this)->forward_held();
        in->getAabb(p, a, b);
    }
    void rayTest(const btVector3 &f, const btVector3 &t, btBroadphaseRayCallback &cb, const btVector3 &a,
                 const btVector3 &b) override
    {
        forward_held();
        in->rayTest(f, t, cb, a, b);
    }
    void aabbTest(const btVector3 &a, const btVector3 &b, btBroadphaseAabbCallback &cb) override
    {
        forward_held();
        in->aabbTest(a, b, cb);
    }
    void calculateOverlappingPairs(btDispatcher *d) override
    {
        forward_held();
        Clock c{ms};
        in->calculateOverlappingPairs(d);
    }
    btOverlappingPairCache *getOverlappingPairCache() override
    {
        forward_held();
        return in->getOverlappingPairCache();
    }
    const btOverlappingPairCache *getOverlappingPairCache() const override
    {
        const_cast<Timed *>(this)->forward_held();
        return in->getOverlappingPairCache();
    }
    void getBroadphaseAabb(btVector3 &a, btVector3 &b) const override
    {
        const_cast<Timed *>(this)->forward_held();
        in->getBroadphaseAabb(a, b);
    }
    void resetPool(btDispatcher *d) override
    {
        forward_held();
        in->resetPool(d);
    }
    void printStats() override { in->printStats(); }
};

struct Bench {
    btDefaultCollisionConfiguration config;
    btCollisionDispatcher dispatcher{&config};
    std::unique_ptr<btBroadphaseInterface> inner;
    std::unique_ptr<Timed> timed;
    btSequentialImpulseConstraintSolver solver;
    std::unique_ptr<btDiscreteDynamicsWorld> world;
    std::vector<std::unique_ptr<btCollisionShape>> shapes;
    double half = 0; // the scene's half width

    Bench(Broadphase kind, unsigned threads, int n, double half_width) : half(half_width)
    {
        if (kind == Broadphase::locd || kind == Broadphase::locd_margin) {
            inner.reset(new locd::BulletBroadphase(locd_options(kind, threads)));
        } else if (kind == Broadphase::dbvt) {
            inner.reset(new btDbvtBroadphase());
        } else {
            btVector3 lo(-half - 10, -10, -half - 10), hi(half + 10, 200, half + 10);
            if (n + 10 < 16000)
                inner.reset(new btAxisSweep3(lo, hi, (unsigned short)(n + 10)));
            else
                inner.reset(new bt32BitAxisSweep3(lo, hi, (unsigned)(n + 10)));
        }
        timed.reset(new Timed(inner.get()));
        world.reset(new btDiscreteDynamicsWorld(&dispatcher, timed.get(), &solver, &config));
        world->setGravity(btVector3(0, -10, 0));
    }
    ~Bench()
    {
        for (int k = world->getNumCollisionObjects() - 1; k >= 0; k--) {
            btCollisionObject *o = world->getCollisionObjectArray()[k];
            world->removeCollisionObject(o);
            if (btRigidBody *b = btRigidBody::upcast(o))
                delete b->getMotionState();
            delete o;
        }
        world.reset();
    }
    btCollisionShape *own(btCollisionShape *s)
    {
        shapes.emplace_back(s);
        return s;
    }
    void add(btCollisionShape *s, double mass, const btTransform &t)
    {
        btVector3 inertia(0, 0, 0);
        if (mass > 0)
            s->calculateLocalInertia(mass, inertia);
        auto *b = new btRigidBody(btRigidBody::btRigidBodyConstructionInfo(mass, new btDefaultMotionState(t), s, inertia));
        world->addRigidBody(b);
    }
};

// Columns of 10 boxes on a grid: "tower" starts them 0.2 apart, so every
// column falls and settles; "stacks" starts them resting (touching).
// "heap": convex hulls dropped in layers onto the ground.
double half_width(const std::string &scene, int n)
{
    int cols = scene == "heap" ? std::max(1, n / 8) : std::max(1, n / 10);
    return 0.5 * std::ceil(std::sqrt((double)cols)) * (scene == "heap" ? 1.4 : 2.0) + 2;
}

void build(Bench &b, const std::string &scene, int n)
{
    btCollisionShape *ground = b.own(new btBoxShape(btVector3(b.half + 5, 1, b.half + 5)));
    b.add(ground, 0, btTransform(btQuaternion::getIdentity(), btVector3(0, -1, 0)));
    btCollisionShape *box = b.own(new btBoxShape(btVector3(0.5, 0.5, 0.5)));
    Rng r(1);
    if (scene == "heap") {
        auto *hull = new btConvexHullShape();
        for (int k = 0; k < 12; k++)
            hull->addPoint(btVector3(r.uniform(-0.5, 0.5), r.uniform(-0.5, 0.5), r.uniform(-0.5, 0.5)), false);
        hull->recalcLocalAabb();
        b.own(hull);
        int side = (int)std::ceil(std::sqrt(n / 8.0));
        for (int k = 0; k < n; k++) {
            int i = k % side, j = (k / side) % side, l = k / (side * side);
            btVector3 at(-b.half + 2 + i * 1.4, 1 + l * 1.4, -b.half + 2 + j * 1.4);
            btQuaternion q(btVector3(r.uniform(-1, 1), r.uniform(-1, 1), 1).normalized(), r.uniform(0, 3));
            b.add(hull, 1, btTransform(q, at));
        }
        return;
    }
    double gap = scene == "tower" ? 0.2 : 0.0;
    int cols = std::max(1, n / 10), side = (int)std::ceil(std::sqrt((double)cols));
    for (int k = 0; k < n; k++) {
        int c = k / 10, l = k % 10, i = c % side, j = c / side;
        b.add(box, 1, btTransform(btQuaternion::getIdentity(),
                                  btVector3(-b.half + 2 + i * 2.0, 0.5 + l * (1 + gap), -b.half + 2 + j * 2.0)));
    }
}

double median(std::vector<double> v)
{
    std::sort(v.begin(), v.end());
    return v.empty() ? 0 : v[v.size() / 2];
}

struct Result {
    double step = 0, broad = 0, rays = 0;
    long pairs = 0;
};

Result run(Broadphase kind, const std::string &scene, int n, int warmup, int steps, int rays, unsigned threads)
{
    Bench b(kind, threads, n, half_width(scene, n));
    build(b, scene, n);
    Rng r(2);
    std::vector<double> step_ms, broad_ms, ray_ms;
    for (int s = 0; s < warmup + steps; s++) {
        b.timed->ms = 0;
        double t0 = now_ms();
        b.world->stepSimulation(1.0 / 60.0, 0);
        double t1 = now_ms();
        // Rays down onto the scene from above, and across it.
        for (int q = 0; q < rays; q++) {
            btVector3 from(r.uniform(-b.half, b.half), 30, r.uniform(-b.half, b.half));
            btVector3 to(r.uniform(-b.half, b.half), -1, r.uniform(-b.half, b.half));
            if (q % 4 == 3) {
                from = btVector3(-b.half - 5, r.uniform(0, 8), r.uniform(-b.half, b.half));
                to = btVector3(b.half + 5, r.uniform(0, 8), r.uniform(-b.half, b.half));
            }
            btCollisionWorld::ClosestRayResultCallback cb(from, to);
            b.world->rayTest(from, to, cb);
        }
        double t2 = now_ms();
        if (s >= warmup) {
            step_ms.push_back(t1 - t0);
            broad_ms.push_back(b.timed->ms);
            ray_ms.push_back(t2 - t1);
        }
    }
    Result res;
    res.step = median(step_ms);
    res.broad = median(broad_ms);
    res.rays = median(ray_ms);
    res.pairs = b.world->getPairCache()->getNumOverlappingPairs();
    return res;
}

std::vector<std::string> split(const char *s)
{
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ','))
        out.push_back(item);
    return out;
}

} // namespace

int main(int argc, char **argv)
{
    std::vector<std::string> sizes{"1000", "10000"}, scenes{"tower", "stacks", "heap"};
    int steps = 40, warmup = 10, rays = 1000, reps = 1;
    unsigned threads = 2;
    std::vector<Broadphase> kinds{Broadphase::dbvt, Broadphase::sap, Broadphase::locd};
    for (int k = 1; k + 1 < argc; k += 2) {
        std::string a = argv[k];
        if (a == "--sizes") sizes = split(argv[k + 1]);
        else if (a == "--scenes") scenes = split(argv[k + 1]);
        else if (a == "--steps") steps = std::atoi(argv[k + 1]);
        else if (a == "--warmup") warmup = std::atoi(argv[k + 1]);
        else if (a == "--rays") rays = std::atoi(argv[k + 1]);
        else if (a == "--threads") threads = (unsigned)std::atoi(argv[k + 1]);
        else if (a == "--reps") reps = std::atoi(argv[k + 1]);
        else if (a == "--broadphases") {
            kinds.clear();
            for (const std::string &b : split(argv[k + 1]))
                if (b == "dbvt" || b == "sap" || b == "locd" || b == "locd-margin")
                    kinds.push_back(b == "dbvt" ? Broadphase::dbvt
                                    : b == "sap" ? Broadphase::sap
                                    : b == "locd" ? Broadphase::locd
                                                  : Broadphase::locd_margin);
                else {
                    std::fprintf(stderr, "unknown broad phase %s (dbvt, sap, locd, locd-margin)\n", b.c_str());
                    return 2;
                }
        }
        else {
            std::fprintf(stderr, "unknown option %s (see the comment at the top of bench/bullet.cpp)\n", argv[k]);
            return 2;
        }
    }
    std::printf("| scene | n | broad phase | stepSimulation ms | broad phase ms | %d rays ms | pairs |\n", rays);
    std::printf("|---|---:|---|---:|---:|---:|---:|\n");
    for (const std::string &scene : scenes)
        for (const std::string &size : sizes) {
            int n = std::atoi(size.c_str());
            std::vector<std::vector<Result>> runs(kinds.size()); // interleaved: each rep runs them in turn
            for (int rep = 0; rep < reps; rep++)
                for (size_t k = 0; k < kinds.size(); k++)
                    runs[k].push_back(run(kinds[k], scene, n, warmup, steps, rays, threads));
            for (size_t k = 0; k < kinds.size(); k++) {
                Broadphase kind = kinds[k];
                const std::vector<Result> &rs = runs[k];
                auto pick = [&](double Result::*f) {
                    std::vector<double> v;
                    for (auto &x : rs)
                        v.push_back(x.*f);
                    return median(v);
                };
                std::printf("| %s | %d | %s | %.2f | %.2f | %.2f | %ld |\n", scene.c_str(), n,
                            kind == Broadphase::locd          ? "locd::BulletBroadphase"
                            : kind == Broadphase::locd_margin ? "locd::BulletBroadphase, margin 0.05"
                                                              : name_of(kind),
                            pick(&Result::step), pick(&Result::broad), pick(&Result::rays), rs[0].pairs);
                std::fflush(stdout);
            }
        }
    return 0;
}
