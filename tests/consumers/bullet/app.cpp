// A C++ program using an installed liblocd_bullet (scripts/ci/steps/12-consumers.sh):
// a box dropped on the ground in a Bullet world on locd::BulletBroadphase comes to rest on it.
#include <locd/bullet/broadphase.hpp>

#include <btBulletDynamicsCommon.h>

#include <cmath>
#include <cstdio>

int main()
{
    btDefaultCollisionConfiguration config;
    btCollisionDispatcher dispatcher(&config);
    locd::BulletBroadphase broadphase;
    btSequentialImpulseConstraintSolver solver;
    btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
    world.setGravity(btVector3(0, -10, 0));
    btBoxShape ground_shape(btVector3(10, 1, 10)), box_shape(btVector3(0.5, 0.5, 0.5));
    btRigidBody ground(0, nullptr, &ground_shape);
    ground.setWorldTransform(btTransform(btQuaternion::getIdentity(), btVector3(0, -1, 0)));
    btVector3 inertia;
    box_shape.calculateLocalInertia(1, inertia);
    btRigidBody box(1, nullptr, &box_shape, inertia);
    box.setWorldTransform(btTransform(btQuaternion::getIdentity(), btVector3(0, 3, 0)));
    world.addRigidBody(&ground);
    world.addRigidBody(&box);
    for (int k = 0; k < 120; k++)
        world.stepSimulation(1.0 / 60.0, 0);
    double y = box.getWorldTransform().getOrigin().y();
    std::printf("box at rest at y = %.3f, %d pair(s)\n", y, world.getPairCache()->getNumOverlappingPairs());
    world.removeRigidBody(&box);
    world.removeRigidBody(&ground);
    return std::fabs(y - 0.5) < 0.05 ? 0 : 1;
}
