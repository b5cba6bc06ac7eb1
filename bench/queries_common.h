// What the query benchmarks share (bench/queries_peers.cpp, bench/queries_jolt.cpp): the scene
// file, the queries drawn from a seed, the frames that move a share of the boxes, the exact tests
// (the same float64 tests as locd's, docs/queries.md), a timer and the JSON lines they print.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace qb {

struct Rng {
    uint64_t s;
    explicit Rng(uint64_t seed) : s(seed * 2654435761u + 88172645463325252ull) {}
    uint64_t next()
    {
        s ^= s << 13, s ^= s >> 7, s ^= s << 17;
        return s;
    }
    double uniform() { return (double)(next() >> 11) / 9007199254740992.0; }
};

// The boxes of a .aabb file (6 float32 a box) and their bounds and mean edge.
struct Scene {
    std::vector<float> box;
    size_t n = 0;
    float lo[3], hi[3];
    double edge = 0.0, extent = 0.0;
};

inline bool load(const char *path, Scene &sc)
{
    FILE *f = std::fopen(path, "rb");
    if (!f)
        return false;
    std::fseek(f, 0, SEEK_END);
    const long size = std::ftell(f);
    std::fseek(f, 0, SEEK_SET);
    sc.n = (size_t)size / 24;
    sc.box.resize(6 * sc.n);
    const bool ok = std::fread(sc.box.data(), 24, sc.n, f) == sc.n;
    std::fclose(f);
    for (int a = 0; a < 3; a++)
        sc.lo[a] = INFINITY, sc.hi[a] = -INFINITY;
    for (size_t i = 0; i < sc.n; i++)
        for (int a = 0; a < 3; a++) {
            sc.lo[a] = std::min(sc.lo[a], sc.box[6 * i + a]);
            sc.hi[a] = std::max(sc.hi[a], sc.box[6 * i + 3 + a]);
            sc.edge += (double)sc.box[6 * i + 3 + a] - sc.box[6 * i + a];
        }
    sc.edge /= 3.0 * (double)(sc.n ? sc.n : 1);
    for (int a = 0; a < 3; a++)
        sc.extent = std::max(sc.extent, (double)sc.hi[a] - sc.lo[a]);
    return ok;
}

// A query: a ray (origin o, vector d, 0 <= t <= 1) or a box b. Float32, as every system takes them.
struct Query {
    float o[3], d[3], b[6];
};

// Rays from points uniform in the scene's bounds, in random directions, of length
// `length` times the scene's extent; or cubes of three mean box edges around such points.
inline std::vector<Query> draw(const Scene &sc, size_t count, double length, uint64_t seed)
{
    Rng r(seed);
    std::vector<Query> q(count);
    for (auto &x : q) {
        const double z = 2.0 * r.uniform() - 1.0, ph = 6.283185307179586 * r.uniform(), s = std::sqrt(1.0 - z * z);
        const double dir[3] = {s * std::cos(ph), s * std::sin(ph), z};
        for (int a = 0; a < 3; a++) {
            x.o[a] = (float)(sc.lo[a] + (sc.hi[a] - sc.lo[a]) * r.uniform());
            x.d[a] = (float)(dir[a] * length * sc.extent);
            x.b[a] = (float)(x.o[a] - 1.5 * sc.edge);
            x.b[a + 3] = (float)(x.o[a] + 1.5 * sc.edge);
        }
    }
    return q;
}

// A frame: a share of the boxes moved by up to 3% of the mean edge on each axis (the ids of
// the moved ones in *moved); every system is told of the same moves.
inline void frame(Scene &sc, Rng &r, double share, std::vector<uint32_t> &moved)
{
    moved.clear();
    for (size_t i = 0; i < sc.n; i++)
        if (r.uniform() < share) {
            for (int a = 0; a < 3; a++) {
                const float dx = (float)(0.03 * sc.edge * (2.0 * r.uniform() - 1.0));
                sc.box[6 * i + a] += dx, sc.box[6 * i + 3 + a] += dx;
            }
            moved.push_back((uint32_t)i);
        }
}

// The exact tests, as locd's (docs/queries.md): the ray's entry time into box i, or -1.
inline double ray_t(const Query &q, const float *b)
{
    double t0 = 0.0, t1 = 1.0;
    for (int a = 0; a < 3; a++) {
        const double in = (double)b[a] - q.o[a], out = (double)b[a + 3] - q.o[a], d = q.d[a];
        if (d == 0.0) {
            if (in > 0.0 || out < 0.0)
                return -1.0;
            continue;
        }
        const double u = (d > 0.0 ? in : out) / d, v = (d > 0.0 ? out : in) / d;
        t0 = std::max(t0, u), t1 = std::min(t1, v);
        if (t0 > t1)
            return -1.0;
    }
    return t0;
}

inline bool box_meets(const Query &q, const float *b)
{
    return b[0] <= q.b[3] && q.b[0] <= b[3] && b[1] <= q.b[4] && q.b[1] <= b[4] && b[2] <= q.b[5] && q.b[2] <= b[5];
}

// A hit: box index and entry time.
struct Hit {
    double t;
    uint32_t i;
    bool operator<(const Hit &o) const { return t != o.t ? t < o.t : i < o.i; }
};

inline double now_us()
{
    return (double)std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch()).count() / 1e3;
}

// One result line.
inline void print(const char *system, const char *query, size_t n, const char *state, double us, uint64_t hits,
                  uint64_t checksum, const char *extra = "")
{
    std::printf("{\"system\": \"%s\", \"query\": \"%s\", \"n\": %zu, \"state\": \"%s\", \"us\": %.4f, \"hits\": %llu, "
                "\"checksum\": %llu%s}\n",
                system, query, n, state, us, (unsigned long long)hits, (unsigned long long)checksum, extra);
    std::fflush(stdout);
}

// An order-free checksum of a query's hits (box indices), to compare the systems' answers.
inline uint64_t mix(uint64_t k, uint64_t i)
{
    uint64_t x = (k + 1) * 0x9E3779B97F4A7C15ull ^ (i + 1) * 0xC2B2AE3D27D4EB4Full;
    x ^= x >> 31;
    return x * 0x94D049BB133111EBull;
}

} // namespace qb
