// The same scenes on btDbvtBroadphase and on locd::BulletBroadphase: a heap
// of boxes, spheres and convex hulls comes to rest in a static bowl with no
// body through the floor, and a stacked pyramid still stands after a few
// seconds. The thresholds are met by btDbvtBroadphase; locd must meet them too.
#include "world.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>

using namespace locd_test;

namespace {

struct Heap {
    double lowest = 1e30, mean_speed = 0, max_speed = 0, outside = 0;
};

Heap heap(Broadphase kind, int n, int steps)
{
    double w = 8;
    World world(kind, 2, w);
    world.bowl(w);
    Rng r(5);
    world.drop_many(n, w, 2.0, r);
    for (int s = 0; s < steps; s++)
        world.step();
    Heap h;
    for (btRigidBody *b : world.bodies) {
        btVector3 p = b->getWorldTransform().getOrigin();
        h.lowest = std::min(h.lowest, (double)p.y());
        double v = b->getLinearVelocity().length();
        h.mean_speed += v / world.bodies.size();
        h.max_speed = std::max(h.max_speed, v);
        // Inside the bowl: above the floor and within the walls' reach.
        if (p.y() < 0 || std::fabs(p.x()) > 2 * w || std::fabs(p.z()) > 2 * w)
            h.outside++;
    }
    return h;
}

// A pyramid of `levels` rows of unit boxes on a static ground; the largest
// displacement of any box after `steps` steps.
double pyramid(Broadphase kind, int levels, int steps)
{
    World world(kind, 2, 20);
    btCollisionShape *ground = world.own(new btBoxShape(btVector3(30, 1, 30)));
    btRigidBody *g = world.make(ground, 0, btTransform(btQuaternion::getIdentity(), btVector3(0, -1, 0)));
    world.world->addRigidBody(g);
    std::vector<btVector3> start;
    for (int l = 0; l < levels; l++)
        for (int i = 0; i < levels - l; i++) {
            btVector3 at(-(levels - l - 1) * 0.5 + i, 0.5 + l, 0);
            btRigidBody *b = world.make(world.box_shape, 1, btTransform(btQuaternion::getIdentity(), at));
            world.world->addRigidBody(b);
            world.bodies.push_back(b);
            start.push_back(at);
        }
    for (int s = 0; s < steps; s++)
        world.step();
    double worst = 0;
    for (size_t k = 0; k < world.bodies.size(); k++)
        worst = std::max(worst, (double)(world.bodies[k]->getWorldTransform().getOrigin() - start[k]).length());
    return worst;
}

} // namespace

int main(int argc, char **argv)
{
    int n = argc > 1 ? std::atoi(argv[1]) : heavy() ? 400 : 150;
    int steps = argc > 2 ? std::atoi(argv[2]) : 600;
    Tap tap;
    for (Broadphase kind : {Broadphase::dbvt, Broadphase::locd, Broadphase::locd_margin}) {
        Heap h = heap(kind, n, steps);
        char what[240];
        std::snprintf(what, sizeof what, "%s: %d bodies at rest in the bowl after %d steps (lowest centre %.3f, "
                      "mean speed %.3f, max %.3f, %g outside)", name_of(kind), n, steps, h.lowest, h.mean_speed,
                      h.max_speed, h.outside);
        tap.ok(h.outside == 0 && h.lowest > 0.05 && h.mean_speed < 0.1 && h.max_speed < 2, what);
        double moved = pyramid(kind, 10, 300);
        std::snprintf(what, sizeof what, "%s: a 10-level pyramid stands after 300 steps (largest displacement %.4f)",
                      name_of(kind), moved);
        tap.ok(moved < 0.05, what);
    }
    return tap.done();
}
