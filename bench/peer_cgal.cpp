// CGAL's box_self_intersection_d (Zomorodian & Edelsbrunner's streamed
// segment tree) as a benchmark peer, with closed boxes: the same semantics as
// locd, so its pair set must equal locd's exactly. The half-open variant
// (CGAL's other topology, where touching boxes do not intersect) shows, and
// lets CI check, how the comparison attributes missing touching pairs.
#include "peers.h"

#include <CGAL/box_intersection_d.h>

#include <cstdio>
#include <exception>

namespace {
typedef CGAL::Box_intersection_d::Box_with_info_d<float, 3, std::uint32_t> cgal_box;
}

namespace {
int run_cgal(CGAL::Box_intersection_d::Topology topology, const peer_scene &s, peer_pairs &out, peer_times &t,
             char *err, std::size_t errlen)
{
    try {
        double t0 = peer_now_ms();
        std::vector<cgal_box> boxes;
        boxes.reserve(s.n);
        for (std::size_t i = 0; i < s.n; i++) {
            float lo[3] = {s.b[6 * i], s.b[6 * i + 1], s.b[6 * i + 2]};
            float hi[3] = {s.b[6 * i + 3], s.b[6 * i + 4], s.b[6 * i + 5]};
            boxes.emplace_back(lo, hi, (std::uint32_t)i);
        }
        double t1 = peer_now_ms();
        CGAL::box_self_intersection_d(
            boxes.begin(), boxes.end(),
            [&out](const cgal_box &a, const cgal_box &b) { out.push_back(peer_pair(a.info(), b.info())); },
            std::ptrdiff_t(10), topology);
        double t2 = peer_now_ms();
        t.prep_ms = t1 - t0;
        t.query_ms = t2 - t1;
        return 0;
    } catch (const std::exception &e) {
        std::snprintf(err, errlen, "CGAL threw: %s", e.what());
    }
    return 1;
}
} // namespace

int peer_cgal_closed(const peer_scene &s, peer_pairs &o, peer_times &t, char *e, std::size_t l)
{
    return run_cgal(CGAL::Box_intersection_d::CLOSED, s, o, t, e, l);
}

int peer_cgal_half_open(const peer_scene &s, peer_pairs &o, peer_times &t, char *e, std::size_t l)
{
    return run_cgal(CGAL::Box_intersection_d::HALF_OPEN, s, o, t, e, l);
}
