// bench/queries_jolt: the queries of bench/queries_peers on Jolt Physics' BroadPhaseQuadTree (the
// broad phase of its PhysicsSystem), for the comparison bench/queries.py makes. Jolt is in no package
// registry: bench/queries_jolt.sh builds this against a Jolt source tree and build the user gives.
// Not part of the project's build or CI.
//
//   queries_jolt SCENE.aabb [--queries Q] [--reps R] [--frames F]
//
// Each box is a static body with a box shape (no convex radius) at the box's centre, in one broad-phase
// layer; the broad phase is optimized once. --frames F: then F frames of 1% of the boxes moving, the
// moves of queries_peers (the same seed), each body moved with SetPosition and the frame ended with
// PhysicsSystem::Update (which brings the broad phase's tree up to date), as a game does. Its hits are
// Jolt's own (its float bounds); the checksum uses the box indices, as queries_peers does.
#include "queries_common.h"

#include <Jolt/Jolt.h>

#include <Jolt/Core/Factory.h>
#include <Jolt/Core/JobSystemSingleThreaded.h>
#include <Jolt/Core/TempAllocator.h>
#include <Jolt/Physics/Body/BodyCreationSettings.h>
#include <Jolt/Physics/Collision/BroadPhase/BroadPhaseQuery.h>
#include <Jolt/Physics/Collision/CastResult.h>
#include <Jolt/Physics/Collision/CollisionCollectorImpl.h>
#include <Jolt/Physics/Collision/RayCast.h>
#include <Jolt/Physics/Collision/Shape/BoxShape.h>
#include <Jolt/Physics/PhysicsSystem.h>
#include <Jolt/RegisterTypes.h>

#include <string>

using namespace qb;

namespace {

class OneLayer final : public JPH::BroadPhaseLayerInterface {
public:
    JPH::uint GetNumBroadPhaseLayers() const override { return 1; }
    JPH::BroadPhaseLayer GetBroadPhaseLayer(JPH::ObjectLayer) const override { return JPH::BroadPhaseLayer(0); }
};

class AllObjectVsBroadPhase final : public JPH::ObjectVsBroadPhaseLayerFilter {
public:
    bool ShouldCollide(JPH::ObjectLayer, JPH::BroadPhaseLayer) const override { return true; }
};

class AllPairs final : public JPH::ObjectLayerPairFilter {
public:
    bool ShouldCollide(JPH::ObjectLayer, JPH::ObjectLayer) const override { return true; }
};

// A box's centre, where its body sits.
JPH::RVec3 centre(const float *b)
{
    return JPH::RVec3(0.5f * (b[0] + b[3]), 0.5f * (b[1] + b[4]), 0.5f * (b[2] + b[5]));
}

} // namespace

int main(int argc, char **argv)
{
    if (argc < 2) {
        std::fprintf(stderr, "usage: queries_jolt SCENE.aabb [--queries Q] [--reps R] [--frames F]\n");
        return 2;
    }
    size_t nq = 2000;
    int reps = 3, frames = 0;
    for (int i = 2; i + 1 < argc; i += 2) {
        const std::string a = argv[i];
        if (a == "--queries")
            nq = (size_t)std::atol(argv[i + 1]);
        else if (a == "--reps")
            reps = std::atoi(argv[i + 1]);
        else if (a == "--frames")
            frames = std::atoi(argv[i + 1]);
    }
    Scene sc;
    if (!load(argv[1], sc))
        return 1;
    JPH::RegisterDefaultAllocator();
    JPH::Factory::sInstance = new JPH::Factory();
    JPH::RegisterTypes();
    OneLayer layers;
    AllObjectVsBroadPhase ovb;
    AllPairs pairs;
    JPH::PhysicsSystem ps;
    ps.Init((JPH::uint)sc.n, 0, 1024, 1024, layers, ovb, pairs);
    JPH::BodyInterface &bi = ps.GetBodyInterfaceNoLock();
    std::vector<JPH::BodyID> ids(sc.n);
    const double t0 = now_us();
    for (size_t i = 0; i < sc.n; i++) {
        const float *b = &sc.box[6 * i];
        const JPH::Vec3 half(0.5f * (b[3] - b[0]), 0.5f * (b[4] - b[1]), 0.5f * (b[5] - b[2]));
        JPH::BoxShapeSettings shape(half, 0.0f);
        shape.SetEmbedded();
        JPH::BodyCreationSettings s(&shape, centre(b), JPH::Quat::sIdentity(), JPH::EMotionType::Static, 0);
        ids[i] = bi.CreateBody(s)->GetID();
    }
    // A body's box, by the body's index, and a box's body (taken now: AddBodiesPrepare reorders the ids).
    std::vector<uint32_t> index(ps.GetMaxBodies());
    for (size_t i = 0; i < sc.n; i++)
        index[ids[i].GetIndex()] = (uint32_t)i;
    const std::vector<JPH::BodyID> body = ids;
    JPH::BodyInterface::AddState st = bi.AddBodiesPrepare(ids.data(), (int)ids.size());
    bi.AddBodiesFinalize(ids.data(), (int)ids.size(), st, JPH::EActivation::DontActivate);
    ps.OptimizeBroadPhase();
    std::printf("{\"system\": \"jolt\", \"setup\": \"bodies and broad phase\", \"n\": %zu, \"ms\": %.3f}\n", sc.n,
                (now_us() - t0) / 1e3);
    JPH::TempAllocatorImpl temp(16 << 20);
    JPH::JobSystemSingleThreaded jobs(JPH::cMaxPhysicsJobs);
    Rng r(7);
    std::vector<uint32_t> moved;
    for (int f = 0; f < frames; f++) {
        frame(sc, r, 0.01, moved);
        for (uint32_t i : moved)
            bi.SetPosition(body[i], centre(&sc.box[6 * i]), JPH::EActivation::DontActivate);
        ps.Update(1.0f / 60.0f, 1, &temp, &jobs);
    }
    const char *state = frames ? "frames" : "first";
    const JPH::BroadPhaseQuery &bq = ps.GetBroadPhaseQuery();
    const char *names[] = {"ray_short_all", "ray_short_closest", "ray_long_all", "ray_long_closest", "box"};
    const std::vector<Query> shortq = draw(sc, nq, 0.05, 11), longq = draw(sc, nq, 1.5, 12), boxq = draw(sc, nq, 0.0, 13);
    for (int kind = 0; kind < 5; kind++) {
        const std::vector<Query> &q = kind < 2 ? shortq : kind < 4 ? longq : boxq;
        std::vector<double> us;
        uint64_t hits = 0, sum = 0;
        for (int rep = 0; rep < reps; rep++) {
            hits = sum = 0;
            const double a = now_us();
            for (size_t k = 0; k < q.size(); k++) {
                const Query &x = q[k];
                if (kind == 4) {
                    JPH::AllHitCollisionCollector<JPH::CollideShapeBodyCollector> c;
                    bq.CollideAABox(JPH::AABox(JPH::Vec3(x.b[0], x.b[1], x.b[2]), JPH::Vec3(x.b[3], x.b[4], x.b[5])), c);
                    for (const JPH::BodyID &h : c.mHits)
                        hits++, sum += mix(k, index[h.GetIndex()]);
                    continue;
                }
                const JPH::RayCast ray{JPH::Vec3(x.o[0], x.o[1], x.o[2]), JPH::Vec3(x.d[0], x.d[1], x.d[2])};
                if (kind == 1 || kind == 3) {
                    JPH::ClosestHitCollisionCollector<JPH::RayCastBodyCollector> c;
                    bq.CastRay(ray, c);
                    if (c.HadHit())
                        hits++, sum += mix(k, index[c.mHit.mBodyID.GetIndex()]);
                } else {
                    JPH::AllHitCollisionCollector<JPH::RayCastBodyCollector> c;
                    bq.CastRay(ray, c);
                    for (const JPH::BroadPhaseCastResult &h : c.mHits)
                        hits++, sum += mix(k, index[h.mBodyID.GetIndex()]);
                }
            }
            us.push_back((now_us() - a) / (double)nq);
        }
        std::sort(us.begin(), us.end());
        print("jolt", names[kind], sc.n, state, us[us.size() / 2], hits, sum);
    }
    JPH::UnregisterTypes();
    delete JPH::Factory::sInstance;
    return 0;
}
