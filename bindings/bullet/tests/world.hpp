// Shared by the Bullet tests and the benchmark: a dynamics world on a chosen
// broad phase, a static bowl, and bodies of three kinds dropped into it.
#ifndef LOCD_BULLET_TESTS_WORLD_HPP
#define LOCD_BULLET_TESTS_WORLD_HPP

#include <locd/bullet/broadphase.hpp>

#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

namespace locd_test {

// locd_margin: locd::BulletBroadphase with btDbvtBroadphase's margin.
enum class Broadphase { locd, locd_margin, dbvt, sap };

constexpr double kDbvtMargin = 0.05; // Bullet's gDbvtMargin

inline const char *name_of(Broadphase b)
{
    return b == Broadphase::locd          ? "locd"
           : b == Broadphase::locd_margin ? "locd, margin 0.05"
           : b == Broadphase::dbvt        ? "btDbvtBroadphase"
                                          : "btAxisSweep3";
}

inline locd::BulletBroadphaseOptions locd_options(Broadphase b, unsigned threads)
{
    locd::BulletBroadphaseOptions o;
    o.threads = threads;
    o.margin = b == Broadphase::locd_margin ? kDbvtMargin : 0;
    return o;
}

// A small deterministic generator (the same bodies on every run and platform).
struct Rng {
    std::uint64_t s;
    explicit Rng(std::uint64_t seed) : s(seed * 0x9e3779b97f4a7c15ull + 1) {}
    std::uint64_t next()
    {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        return s;
    }
    double uniform(double lo, double hi) { return lo + (hi - lo) * (double)(next() >> 11) * (1.0 / 9007199254740992.0); }
    int below(int n) { return (int)(next() % (std::uint64_t)n); }
};

struct World {
    btDefaultCollisionConfiguration config;
    btCollisionDispatcher dispatcher{&config};
    std::unique_ptr<btBroadphaseInterface> broadphase;
    btSequentialImpulseConstraintSolver solver;
    std::unique_ptr<btDiscreteDynamicsWorld> world;
    std::vector<std::unique_ptr<btCollisionShape>> shapes;
    std::vector<btRigidBody *> bodies;   // live dynamic bodies
    std::vector<btRigidBody *> statics;
    btCollisionShape *box_shape = nullptr, *sphere_shape = nullptr, *hull_shape = nullptr;
    int next_index = 0;                  // each body's userIndex: the order it was made in

    World(Broadphase kind, unsigned threads, double half_extent)
    {
        if (kind == Broadphase::locd || kind == Broadphase::locd_margin) {
            broadphase.reset(new locd::BulletBroadphase(locd_options(kind, threads)));
        } else if (kind == Broadphase::dbvt) {
            broadphase.reset(new btDbvtBroadphase());
        } else {
            double h = half_extent * 2 + 50;
            broadphase.reset(new btAxisSweep3(btVector3(-h, -10, -h), btVector3(h, 4 * h + 100, h), 32766));
        }
        world.reset(new btDiscreteDynamicsWorld(&dispatcher, broadphase.get(), &solver, &config));
        world->setGravity(btVector3(0, -10, 0));
        box_shape = own(new btBoxShape(btVector3(0.5, 0.5, 0.5)));
        sphere_shape = own(new btSphereShape(0.5));
        auto *hull = new btConvexHullShape();
        Rng r(99);
        for (int k = 0; k < 12; k++)
            hull->addPoint(btVector3(r.uniform(-0.5, 0.5), r.uniform(-0.5, 0.5), r.uniform(-0.5, 0.5)), false);
        hull->recalcLocalAabb();
        hull_shape = own(hull);
    }

    ~World()
    {
        for (int k = world->getNumCollisionObjects() - 1; k >= 0; k--) {
            btCollisionObject *o = world->getCollisionObjectArray()[k];
            world->removeCollisionObject(o);
            btRigidBody *b = btRigidBody::upcast(o);
            if (b)
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

    btRigidBody *make(btCollisionShape *shape, double mass, const btTransform &t)
    {
        btVector3 inertia(0, 0, 0);
        if (mass > 0)
            shape->calculateLocalInertia(mass, inertia);
        auto *ms = new btDefaultMotionState(t);
        auto *b = new btRigidBody(btRigidBody::btRigidBodyConstructionInfo(mass, ms, shape, inertia));
        b->setUserIndex(next_index++);
        return b;
    }

    // A static bowl: a floor and four walls leaning out, inner half width w.
    void bowl(double w)
    {
        btCollisionShape *floor = own(new btBoxShape(btVector3(w + 2, 1, w + 2)));
        btRigidBody *f = make(floor, 0, btTransform(btQuaternion::getIdentity(), btVector3(0, -1, 0)));
        world->addRigidBody(f);
        statics.push_back(f);
        btCollisionShape *wall = own(new btBoxShape(btVector3(0.5, w, w + 2)));
        for (int k = 0; k < 4; k++) {
            double a = k * SIMD_HALF_PI;
            btQuaternion q(btVector3(0, 1, 0), a);
            btQuaternion lean(btVector3(0, 0, 1), -0.25);
            btVector3 at = btVector3(w + 0.5 + 0.2 * w, w * 0.9, 0).rotate(btVector3(0, 1, 0), a);
            btRigidBody *b = make(wall, 0, btTransform(q * lean, at));
            world->addRigidBody(b);
            statics.push_back(b);
        }
    }

    // One body of kind (k % 3): box, sphere or convex hull, at `at`.
    // Every 5th is debris: it collides with everything but other debris.
    btRigidBody *drop(int k, const btVector3 &at, Rng &r)
    {
        btCollisionShape *s = k % 3 == 0 ? box_shape : k % 3 == 1 ? sphere_shape : hull_shape;
        btQuaternion q(btVector3(r.uniform(-1, 1), r.uniform(-1, 1), r.uniform(0.1, 1)).normalized(), r.uniform(0, 3));
        btRigidBody *b = make(s, 1, btTransform(q, at));
        if (k % 5 == 4)
            world->addRigidBody(b, btBroadphaseProxy::DebrisFilter,
                                btBroadphaseProxy::AllFilter ^ btBroadphaseProxy::DebrisFilter);
        else
            world->addRigidBody(b);
        bodies.push_back(b);
        return b;
    }

    // n bodies on a jittered grid above the bowl, starting at height y0.
    void drop_many(int n, double w, double y0, Rng &r)
    {
        int side = (int)(2 * (w - 1) / 1.3);
        if (side < 1)
            side = 1;
        double x0 = -(side - 1) * 0.65;
        for (int k = 0; k < n; k++) {
            int i = k % side, j = (k / side) % side, l = k / (side * side);
            btVector3 at(x0 + i * 1.3 + r.uniform(-0.1, 0.1), y0 + l * 1.3, x0 + j * 1.3 + r.uniform(-0.1, 0.1));
            drop(k, at, r);
        }
    }

    void remove(btRigidBody *b)
    {
        world->removeRigidBody(b);
        delete b->getMotionState();
        delete b;
    }

    void step() { world->stepSimulation(1.0 / 60.0, 0); }
};

// LOCD_TEST_HEAVY=0 (the sanitizer builds, tests/README.md): smaller scenes.
// Entry t of the segment from + t (to - from), 0 <= t <= 1, into the closed
// box [lo, hi] (doubles), by the slab test in double; -1 when it misses.
inline double segment_entry(const double lo[3], const double hi[3], const btVector3 &from, const btVector3 &to)
{
    double t0 = 0, t1 = 1;
    for (int k = 0; k < 3; k++) {
        double f = from[k], d = (double)to[k] - f;
        if (d == 0) {
            if (f < lo[k] || f > hi[k])
                return -1;
            continue;
        }
        double a = (lo[k] - f) / d, b = (hi[k] - f) / d;
        if (a > b)
            std::swap(a, b);
        t0 = std::max(t0, a);
        t1 = std::min(t1, b);
    }
    return t0 <= t1 ? t0 : -1;
}

inline bool heavy()
{
    const char *v = std::getenv("LOCD_TEST_HEAVY");
    return !(v && v[0] == '0');
}

// TAP for meson's test protocol: one line per check.
struct Tap {
    int n = 0, failed = 0;
    void ok(bool pass, const std::string &what)
    {
        n++;
        if (!pass)
            failed++;
        std::printf("%s %d - %s\n", pass ? "ok" : "not ok", n, what.c_str());
        std::fflush(stdout);
    }
    int done()
    {
        std::printf("1..%d\n", n);
        return failed ? 1 : 0;
    }
};

} // namespace locd_test

#endif
