// bench/peers: one repetition of each broad phase compared with locd.
//
// Every peer gets the same flat float32 scene (n rows of minx miny minz maxx
// maxy maxz) and appends the pairs it reports to `out` as (i << 32) | j with
// i < j, in any order, duplicates kept (the caller counts them). It times its
// own stages with peer_now_ms():
//   prep  : turning the flat array into the peer's own objects (FCL
//           CollisionObjects, CGAL boxes); a user of that library already has
//           them, so prep is reported but not part of the total;
//   setup : building the peer's structure (manager registration, tree build,
//           proxy insertion);
//   query : finding the pairs (collide(), calculateOverlappingPairs(), ...).
#ifndef LOCD_BENCH_PEERS_H
#define LOCD_BENCH_PEERS_H

#include <cstddef>
#include <cstdint>
#include <vector>

struct peer_scene {
    std::size_t n;
    const float *b; // 6n values
};

struct peer_times {
    double prep_ms = 0.0;
    double setup_ms = 0.0;
    double query_ms = 0.0;
    double engine_ms = -1.0; // locd only: the engine's own ms_total
    double cold_ms = -1.0;   // locd only: the first call of a fresh engine
    unsigned threads = 0;    // threads used (0 = one)
    long long hwm_kb = -1;   // peak RSS to report, when the peer measures it itself
};

typedef std::vector<std::uint64_t> peer_pairs;

inline std::uint64_t peer_pair(std::uint32_t a, std::uint32_t b)
{
    return a < b ? ((std::uint64_t)a << 32) | b : ((std::uint64_t)b << 32) | a;
}

double peer_now_ms();

// Each returns 0 on success, non-zero (with a message in err) on failure.
typedef int (*peer_fn)(const peer_scene &s, peer_pairs &out, peer_times &t, char *err, std::size_t errlen);

// FCL 0.7 managers (double precision: float inputs convert exactly).
int peer_fcl_dynamic_aabb_tree(const peer_scene &, peer_pairs &, peer_times &, char *, std::size_t);
int peer_fcl_dynamic_aabb_tree_array(const peer_scene &, peer_pairs &, peer_times &, char *, std::size_t);
int peer_fcl_sap(const peer_scene &, peer_pairs &, peer_times &, char *, std::size_t);
int peer_fcl_ssap(const peer_scene &, peer_pairs &, peer_times &, char *, std::size_t);
int peer_fcl_interval_tree(const peer_scene &, peer_pairs &, peer_times &, char *, std::size_t);
// Bullet (single precision, as Debian builds it).
int peer_bullet_dbvt(const peer_scene &, peer_pairs &, peer_times &, char *, std::size_t);
int peer_bullet_dbvt_deferred(const peer_scene &, peer_pairs &, peer_times &, char *, std::size_t);
int peer_bullet_axis_sweep(const peer_scene &, peer_pairs &, peer_times &, char *, std::size_t);
// CGAL box_self_intersection_d, closed boxes.
int peer_cgal_closed(const peer_scene &, peer_pairs &, peer_times &, char *, std::size_t);
// The same with Box_intersection_d::HALF_OPEN: touching boxes do not count.
int peer_cgal_half_open(const peer_scene &, peer_pairs &, peer_times &, char *, std::size_t);

#endif
