"""locd.Scene's queries against a numpy brute force of the documented float64 tests: boxes, points,
spheres, rays and swept boxes, the batches in every mode, in every state of the scene (before the
first update, after it, after moves and their update, between a move and its update, after removals,
adds and filter changes); the batches equal to the queries one by one for 1, 2 and 3 threads; hand-made
hard cases (overflowing radii and entry times among them); bad input; the GIL; the scene's front doors."""
import ast
import math
import os
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import given, note
from hypothesis import strategies as st

import locd
from conftest import progress_during

ALL = (1 << 64) - 1


# -- the brute force: the library's float64 tests, element by element, for Q queries x m boxes ----------
# numpy's float64 operations round as C's do (one IEEE operation each, no contraction), so the results
# must agree to the bit: ids, their order and t.
def bf_overlap(boxes, lo, hi):
    """(Q, m): box k of the scene overlaps query box lo[q]..hi[q] (closed)."""
    ok = np.ones((len(lo), len(boxes)), dtype=bool)
    for a in range(3):
        ok &= (boxes[None, :, a] <= hi[:, None, a]) & (lo[:, None, a] <= boxes[None, :, a + 3])
    return ok


def bf_sphere(boxes, c, r):
    """(Q, m): with d the distance from c[q] to the box per axis (0 inside), (dx*dx + dy*dy) + dz*dz <= r*r."""
    g = []
    for a in range(3):
        ca, lo, hi = c[:, None, a], boxes[None, :, a], boxes[None, :, a + 3]
        g.append(np.where(ca < lo, lo - ca, np.where(ca > hi, ca - hi, 0.0)))
    with np.errstate(over="ignore"):
        return (g[0] * g[0] + g[1] * g[1]) + g[2] * g[2] <= (r * r)[:, None]


def bf_cast(boxes, lo, hi, d, max_t):
    """(hit, t), each (Q, m): the box lo[q]..hi[q] moved by t * d[q], 0 <= t <= max_t[q], meets box k
    of the scene, first at t. Per axis the moved box overlaps while box.lo - hi <= t d <= box.hi - lo:
    on an axis where d is 0 the gaps must hold at t = 0; else the entry u and exit v are the gaps
    divided by d, t0 = max(0, u...), t1 = min(max_t, v...), a hit iff t0 <= t1 (tests/test_queries.c's
    bf_cast, with max and min written as the C's comparisons)."""
    shape = (len(lo), len(boxes))
    t0, t1 = np.zeros(shape), np.broadcast_to(max_t[:, None], shape).copy()
    ok = np.ones(shape, dtype=bool)
    with np.errstate(all="ignore"):
        for a in range(3):
            gin = boxes[None, :, a] - hi[:, None, a]
            gout = boxes[None, :, a + 3] - lo[:, None, a]
            da = d[:, None, a]
            zero, pos = da == 0.0, da > 0.0
            ok &= ~(zero & ((gin > 0.0) | (gout < 0.0)))
            u = np.where(pos, gin, gout) / da
            v = np.where(pos, gout, gin) / da
            t0 = np.where(~zero & (u > t0), u, t0)
            t1 = np.where(~zero & (v < t1), v, t1)
    return ok & ~(t0 > t1), t0


def hits_of(ids, hit_row, t_row=None):
    """One query's hits: ids ascending, or (ids, t) sorted by (t, id)."""
    if t_row is None:
        return ids[hit_row]
    i, t = ids[hit_row], t_row[hit_row]
    order = np.lexsort((i, t))
    return i[order], t[order]


# -- the model of the scene ---------------------------------------------------------------------------------
class World:
    """What the scene holds: per live id its box (float64, the exact values of the scene's dtype) and
    category."""

    def __init__(self, dtype):
        self.dtype = np.dtype(dtype)
        self.box, self.cat = {}, {}

    def exact(self, boxes):
        return np.asarray(boxes, dtype=self.dtype).astype(np.float64).reshape(-1, 6)

    def add(self, scene, boxes, cats):
        ids = scene.add(boxes, category=cats)
        for i, b, c in zip(ids.tolist(), self.exact(boxes), cats):
            self.box[i], self.cat[i] = b, int(c)
        return ids

    def move(self, scene, ids, boxes):
        scene.move(ids, boxes)
        for i, b in zip(ids.tolist(), self.exact(boxes)):
            self.box[i] = b

    def remove(self, scene, ids):
        scene.remove(ids)
        for i in ids.tolist():
            del self.box[i], self.cat[i]

    def set_category(self, scene, ids, cats):
        scene.set_filter(ids, category=cats)
        for i, c in zip(ids.tolist(), cats):
            self.cat[i] = int(c)

    def live(self):
        return np.array(sorted(self.box), dtype=np.uint64)

    def arrays(self, mask):
        """The ids (ascending) and boxes of the objects whose category has a bit in mask."""
        ids = [i for i in sorted(self.box) if self.cat[i] & mask]
        return np.array(ids, dtype=np.uint64), np.array([self.box[i] for i in ids]).reshape(-1, 6)


# -- worlds and queries of three styles -------------------------------------------------------------------
# grid: integer coordinates times a power of two, extents 0 to 2: touching faces, edges and corners,
#   zero-size boxes, rays along faces and edges, sphere distances equal to the radius are common;
# float: arbitrary floats (float64 ones that float32 cannot hold);
# wild: magnitudes from 1e-30 to 1e30 (float64: to 1e160, past the 2**500 beyond which the library's
#   node test takes the exact path), directions from 1e-140 to 1e140. (Quotients that overflow to inf and
#   radii whose square overflows have their own tests at the end.)
STYLES = ["grid", "float", "wild"]
CATEGORIES = np.array([1, 2, 4, 0, 1 << 63], dtype=np.uint64)
MASKS = [ALL, 1, 2, 3, 4, 6, 0, (1 << 63) | 1]


def wild_values(rng, shape, top):
    return rng.choice([-1.0, 1.0], shape) * 10.0 ** rng.uniform(-30, top, shape)


def make_boxes(rng, style, dtype, n, scale):
    if style == "grid":
        lo = rng.integers(-4, 5, (n, 3)).astype(np.float64)
        return np.hstack([lo, lo + rng.integers(0, 3, (n, 3))]) * scale
    if style == "float":
        lo = rng.uniform(-20, 20, (n, 3))
        return np.hstack([lo, lo + rng.uniform(0, 6, (n, 3)) * (rng.random((n, 1)) < 0.9)])
    top = 160 if np.dtype(dtype) == np.float64 else 30
    lo = wild_values(rng, (n, 3), top)
    ext = np.abs(lo) * 10.0 ** rng.uniform(-8, 0.5, (n, 3)) * (rng.random((n, 3)) < 0.9)
    return np.hstack([lo, lo + ext])


def make_points(rng, style, dtype, q, scale, world_boxes):
    """q query points: of the style, and a third of them corners of the scene's boxes."""
    if style == "grid":
        p = rng.integers(-6, 7, (q, 3)) * scale + rng.choice([0.0, 0.0, 0.5 * scale], (q, 3))
    elif style == "float":
        p = rng.uniform(-25, 25, (q, 3))
    else:
        p = wild_values(rng, (q, 3), 160 if np.dtype(dtype) == np.float64 else 30)
    if len(world_boxes):
        take = rng.random(q) < 0.35
        b = world_boxes[rng.integers(0, len(world_boxes), q)]
        corner = np.where(rng.random((q, 3)) < 0.5, b[:, :3], b[:, 3:])
        p[take] = corner[take]
    return p


def make_extents(rng, style, q, scale):
    if style == "grid":
        return rng.integers(0, 3, (q, 3)) * scale
    if style == "float":
        return rng.uniform(0, 8, (q, 3)) * (rng.random((q, 1)) < 0.85)
    return 10.0 ** rng.uniform(-30, 20, (q, 3)) * (rng.random((q, 3)) < 0.85)


def make_directions(rng, style, q):
    if style == "grid":
        d = rng.choice([0.0, 0.0, 1.0, -1.0, 0.5, -0.5, 2.0, -3.0], (q, 3))
    elif style == "float":
        d = rng.normal(size=(q, 3)) * 10.0 * (rng.random((q, 3)) < 0.85)
    else:
        d = wild_values(rng, (q, 3), 140) * 10.0 ** rng.uniform(-110, 0, (q, 1)) * (rng.random((q, 3)) < 0.8)
    return d


def make_max_t(rng, style, q):
    if style == "wild":
        return rng.choice([0.0, 1.0, 1e10, 1e100, math.inf], q)
    return rng.choice([0.0, 0.5, 1.0, 2.0, 3.5, 10.0, math.inf], q)


def make_radii(rng, style, q, scale):
    if style == "grid":
        return rng.choice([0.0, 0.5, 1.0, 2.0, 3.0], q) * scale
    if style == "float":
        return rng.uniform(0, 10, q) * (rng.random(q) < 0.9)
    return 10.0 ** rng.uniform(-30, 150, q)


# -- the checks --------------------------------------------------------------------------------------------
def assert_hits(got, want, what):
    """One query's answer equals the brute force's (what: a callable naming the query, for the message)."""
    if isinstance(want, tuple):
        got_ids, got_t = got
        assert got_ids.dtype == np.uint64 and got_t.dtype == np.float64
        same = got_ids.tolist() == want[0].tolist() and got_t.tolist() == want[1].tolist()
        assert same, "%s: got %s, brute force %s" % (what(), list(zip(got_t, got_ids)), list(zip(want[1], want[0])))
    else:
        assert got.dtype == np.uint64
        assert got.tolist() == want.tolist(), "%s: got %s, brute force %s" % (what(), got, want)


def bf_batch(ids, hit, t=None):
    """Every query's hits laid out as a batch gives them: (offsets, ids, t), each query's hits sorted by
    (t, id) (by id for overlaps)."""
    q, j = np.nonzero(hit)  # by query, then by id (ids are ascending)
    offsets = np.concatenate([[0], np.cumsum(hit.sum(axis=1))]).astype(np.int64)
    if t is None:
        return offsets, ids[j], None
    order = np.lexsort((ids[j], t[q, j], q))
    return offsets, ids[j][order], t[q, j][order]


def assert_batch(got, want, what):
    """A batch equals the brute force's; on a difference, names the first query that differs."""
    offsets, bids, bt = (got + (None,))[:3]
    assert offsets.dtype == np.int64 and bids.dtype == np.uint64 and (bt is None or bt.dtype == np.float64)
    if (np.array_equal(offsets, want[0]) and np.array_equal(bids, want[1])
            and (bt is None or np.array_equal(bt, want[2]))):
        return
    for k in range(len(want[0]) - 1):
        a, b, c, d = offsets[k], offsets[k + 1], want[0][k], want[0][k + 1]
        if b - a != d - c or not np.array_equal(bids[a:b], want[1][c:d]) or \
                (bt is not None and not np.array_equal(bt[a:b], want[2][c:d])):
            raise AssertionError("%s: got %s %s, brute force %s %s" % (
                what(k), bids[a:b], None if bt is None else bt[a:b], want[1][c:d],
                None if bt is None else want[2][c:d]))
    raise AssertionError("%s: the offsets differ: %s, brute force %s" % (what(-1), offsets, want[0]))


def assert_one_per_query(ids, hit, t, got_closest, got_any, what):
    """closest: the first of every hit by (t, id), or (0, inf); any: one of the hits, or (0, inf)."""
    offsets, all_ids, all_t = bf_batch(ids, hit, t)
    count = np.diff(offsets)
    first = np.minimum(offsets[:-1], max(len(all_ids) - 1, 0))
    want_id = np.where(count > 0, all_ids[first] if len(all_ids) else 0, 0).astype(np.uint64)
    want_t = np.where(count > 0, all_t[first] if len(all_t) else 0.0, math.inf)
    cid, ct = got_closest
    aid, at = got_any
    assert cid.dtype == aid.dtype == np.uint64 and ct.dtype == at.dtype == np.float64
    assert cid.shape == ct.shape == aid.shape == at.shape == (len(hit),)
    bad = np.flatnonzero((cid != want_id) | (ct != want_t))
    assert not len(bad), "%s (closest): got (%r, %r), brute force (%r, %r)" % (
        what(bad[0]), ct[bad[0]], cid[bad[0]], want_t[bad[0]], want_id[bad[0]])
    j = np.minimum(np.searchsorted(ids, aid), max(len(ids) - 1, 0))
    if len(ids):
        rows = np.arange(len(hit))
        one_of = (ids[j] == aid) & hit[rows, j] & (t[rows, j] == at)
    else:
        one_of = np.zeros(len(hit), dtype=bool)
    ok = np.where(count > 0, one_of, (aid == 0) & (at == math.inf))
    bad = np.flatnonzero(~ok)
    assert not len(bad), "%s (any): got (%r, %r), not a hit of %d" % (what(bad[0]), at[bad[0]], aid[bad[0]],
                                                                      count[bad[0]])


def check_queries(scene, world, rng, style, scale, mask, q):
    """q queries of every kind on the scene, one by one and in batches, against the brute force."""
    ids, boxes = world.arrays(mask)
    all_boxes = np.array(list(world.box.values())).reshape(-1, 6)
    dt = world.dtype
    origins = make_points(rng, style, dt, q, scale, all_boxes)
    qlo = make_points(rng, style, dt, q, scale, all_boxes)
    qboxes = np.hstack([qlo, qlo + make_extents(rng, style, q, scale)])
    dirs, max_t = make_directions(rng, style, q), make_max_t(rng, style, q)
    radii = make_radii(rng, style, q, scale)
    if len(all_boxes):  # a third aimed at a point of a box (a corner on the grid): reached at t = 1, 2 or 1/3
        aim = rng.random(q) < 0.35
        b = all_boxes[rng.integers(0, len(all_boxes), q)]
        w = rng.integers(0, 2, (q, 3)) if style == "grid" else rng.random((q, 3))
        to = (b[:, :3] + w * (b[:, 3:] - b[:, :3]) - origins) * rng.choice([1.0, 0.5, 3.0], (q, 1))
        dirs[aim] = to[aim]

    def ray(k):
        return "ray %d: origin %r direction %r max_t %r mask %#x" % (k, origins[k].tolist(), dirs[k].tolist(),
                                                                    max_t[k], mask)

    def box(k):
        return "box %d: %r mask %#x" % (k, qboxes[k].tolist(), mask)

    ray_hit, ray_t = bf_cast(boxes, origins, origins, dirs, max_t)
    assert_batch(scene.raycast_batch(origins, dirs, max_t, mask), bf_batch(ids, ray_hit, ray_t), ray)
    assert_one_per_query(ids, ray_hit, ray_t, scene.raycast_batch(origins, dirs, max_t, mask, mode="closest"),
                         scene.raycast_batch(origins, dirs, max_t, mask, mode="any"), ray)
    box_hit = bf_overlap(boxes, qboxes[:, :3], qboxes[:, 3:])
    assert_batch(scene.query_box_batch(qboxes, mask), bf_batch(ids, box_hit), box)
    # one by one, a share of them
    k = slice(0, min(q, 10))
    sweep_hit, sweep_t = bf_cast(boxes, qboxes[k, :3], qboxes[k, 3:], dirs[k], max_t[k])
    point_hit = bf_overlap(boxes, origins[k], origins[k])
    sphere_hit = bf_sphere(boxes, origins[k], radii[k])
    for k in range(min(q, 10)):
        assert_hits(scene.raycast(origins[k], dirs[k], max_t[k], mask), hits_of(ids, ray_hit[k], ray_t[k]),
                    lambda: ray(k))
        assert_hits(scene.sweep_box(qboxes[k], dirs[k], max_t[k], mask), hits_of(ids, sweep_hit[k], sweep_t[k]),
                    lambda: "sweep of " + box(k) + " direction %r max_t %r" % (dirs[k].tolist(), max_t[k]))
        assert_hits(scene.query_box(qboxes[k], mask), hits_of(ids, box_hit[k]), lambda: box(k))
        assert_hits(scene.query_point(origins[k], mask), hits_of(ids, point_hit[k]),
                    lambda: "point %r" % origins[k].tolist())
        assert_hits(scene.query_sphere(origins[k], radii[k], mask), hits_of(ids, sphere_hit[k]),
                    lambda: "sphere: centre %r radius %r mask %#x" % (origins[k].tolist(), radii[k], mask))


@given(data=st.data(), dtype=st.sampled_from([np.float32, np.float64]), threads=st.sampled_from([1, 2, 3]),
       style=st.sampled_from(STYLES), scale=st.sampled_from([1.0, 0.25, 1024.0]))
def test_queries_against_numpy_in_every_state(data, dtype, threads, style, scale):
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1), label="seed"))
    n = data.draw(st.integers(0, 250), label="objects")
    mask = data.draw(st.sampled_from(MASKS), label="mask")
    q = data.draw(st.sampled_from([12, 40, 300]), label="queries")  # 300: the batches run on the pool
    scene, world = locd.Scene(threads=threads, dtype=dtype), World(dtype)

    def check(state):
        note("state: %s, %d objects" % (state, len(world.box)))
        check_queries(scene, world, rng, style, scale, mask, q)

    # Shares of the objects changed at a time: the query tree writes the lanes of a few changed objects
    # again (up to an eighth of its objects), every lane beyond that, and builds itself again when the
    # objects it does not hold yet pass 64 and an eighth.
    shares = st.sampled_from([0.03, 0.1, 0.3, 0.7])

    def some(share):
        live = world.live()
        return live[rng.random(len(live)) < share]

    def move(share, far):
        ids = some(share)
        boxes = np.array([world.box[i] for i in ids.tolist()]).reshape(-1, 6)
        if far:
            boxes = make_boxes(rng, style, dtype, len(ids), scale)
        elif style == "grid":
            boxes = boxes + rng.integers(-1, 2, (len(ids), 1)) * scale
        else:
            boxes = boxes + rng.normal(size=(len(ids), 1)) * (np.abs(boxes).max(axis=1, keepdims=True) * 0.01 + 0.1)
        world.move(scene, ids, boxes)

    world.add(scene, make_boxes(rng, style, dtype, n, scale), rng.choice(CATEGORIES, n))
    check("added, never updated")
    scene.update()
    check("after the first update")
    move(data.draw(shares, label="moved"), far=False)
    check("moved, not updated")
    scene.update()
    check("after moves and their update")
    world.remove(scene, some(data.draw(shares, label="removed")))
    check("removed, not updated")
    scene.update()
    check("after removals and their update")
    for op in data.draw(st.lists(st.sampled_from(["update", "move", "move far", "remove", "add", "filter"]),
                                 max_size=4), label="more"):
        if op == "update":
            scene.update()
        elif op.startswith("move"):
            move(data.draw(shares), far=op == "move far")
        elif op == "remove":
            world.remove(scene, some(data.draw(shares)))
        elif op == "add":  # slots freed by removals are taken again
            k = int(rng.integers(1, 100))
            world.add(scene, make_boxes(rng, style, dtype, k, scale), rng.choice(CATEGORIES, k))
        else:
            ids = some(data.draw(shares))
            world.set_category(scene, ids, rng.choice(CATEGORIES, len(ids)))
        check(op)
    assert len(scene) == len(world.box)


# -- batches against the queries one by one, for 1, 2 and 3 threads -----------------------------------------
def test_batches_equal_single_queries_for_every_thread_count():
    rng = np.random.default_rng(11)
    n, q = 4000, 700  # 700 queries: chunks of 64 on the pool's threads
    lo = rng.uniform(0, 60, (n, 3)).astype(np.float32)
    boxes = np.hstack([lo, lo + rng.uniform(0, 3, (n, 3)).astype(np.float32)])
    cats = rng.choice([1, 2, 4], n)
    origins = rng.uniform(-5, 65, (q, 3))
    dirs = rng.normal(size=(q, 3)) * 10 * (rng.random((q, 3)) < 0.9)
    max_t = rng.choice([0.0, 0.3, 1.0, 2.0, math.inf], q)
    qboxes = np.hstack([origins, origins + rng.uniform(0, 4, (q, 3))])
    first = None
    for threads in (1, 2, 3):
        scene = locd.Scene(threads=threads)
        assert scene.threads == threads
        ids = scene.add(boxes, category=cats)
        scene.update()
        scene.move(ids[::20], boxes[::20] + np.float32(0.75))  # moved, not updated
        got = [scene.raycast_batch(origins, dirs, max_t, 3, mode=mode) for mode in ("all", "closest", "any")]
        got.append(scene.query_box_batch(qboxes, 5))
        (offsets, hit, t), (cid, ct), (aid, at), (qo, qi) = got
        for k in range(q):
            one_ids, one_t = scene.raycast(origins[k], dirs[k], max_t[k], 3)
            np.testing.assert_array_equal(hit[offsets[k]:offsets[k + 1]], one_ids)
            np.testing.assert_array_equal(t[offsets[k]:offsets[k + 1]], one_t)
            if len(one_ids):
                assert (cid[k], ct[k]) == (one_ids[0], one_t[0])
                assert (aid[k], at[k]) in set(zip(one_ids.tolist(), one_t.tolist()))
            else:
                assert cid[k] == aid[k] == 0 and ct[k] == at[k] == math.inf
            np.testing.assert_array_equal(qi[qo[k]:qo[k + 1]], scene.query_box(qboxes[k], 5))
        assert len(hit) > q // 4 and (cid != 0).sum() > q // 8 and len(qi) > q // 4  # (they meet something)
        if first is None:
            first = got
            continue
        for mine, theirs in zip(got, first):  # the same arrays, to the bit, for every thread count
            for x, y in zip(mine, theirs):
                assert x.dtype == y.dtype
                np.testing.assert_array_equal(x, y)


# -- hard cases, by hand -------------------------------------------------------------------------------------
def test_two_touching_cubes_by_hand():
    """Answers worked out on paper (independent of the brute force above)."""
    for dtype in (np.float32, np.float64):
        scene = locd.Scene(dtype=dtype)
        a, b = scene.add([[0, 0, 0, 1, 1, 1], [1, 0, 0, 2, 1, 1]]).tolist()
        ids, t = scene.raycast([-1, 0.5, 0.5], [1, 0, 0], 10)
        assert ids.tolist() == [a, b] and t.tolist() == [1.0, 2.0]
        ids, t = scene.raycast([-1, 0.5, 0.5], [1, 0, 0], 1.5)  # b starts beyond max_t
        assert ids.tolist() == [a] and t.tolist() == [1.0]
        ids, t = scene.raycast([-1, 0.5, 0.5], [1, 0, 0], 2.0)  # b starts at max_t exactly: counts
        assert ids.tolist() == [a, b]
        ids, t = scene.raycast([1, 0.5, -1], [0, 0, 1], math.inf)  # up the shared face: both at t = 1
        assert ids.tolist() == [a, b] and t.tolist() == [1.0, 1.0]
        ids, t = scene.raycast([0.5, 0.5, 0.5], [0, 0, 0], 0)  # a point inside a: t = 0
        assert ids.tolist() == [a] and t.tolist() == [0.0]
        ids, t = scene.raycast([1, 1, 1], [0, 0, 0], 0)  # on the shared edge: both
        assert ids.tolist() == [a, b] and t.tolist() == [0.0, 0.0]
        ids, t = scene.raycast([3, 0.5, 0.5], [1, 0, 0], math.inf)  # pointing away
        assert len(ids) == 0 and t.dtype == np.float64
        ids, t = scene.raycast([3, 1, 1], [-1, 0, 0], math.inf)  # along the top back edge, backwards
        assert ids.tolist() == [b, a] and t.tolist() == [1.0, 2.0]
        ids, t = scene.raycast([3, 1.5, 0.5], [-1, 0, 0], math.inf)  # passes above: nothing
        assert len(ids) == 0
        for mode in ("closest", "any"):  # a tie at t = 1: closest takes the lower id
            cid, ct = scene.raycast_batch([[1, 0.5, -1]], [[0, 0, 1]], math.inf, mode=mode)
            assert ct.tolist() == [1.0] and (cid.tolist() == [min(a, b)] if mode == "closest" else cid[0] in (a, b))
        ids, t = scene.sweep_box([-2, 0, 0, -1, 1, 1], [1, 0, 0], 10)  # the box's face reaches x = 0 at t = 1
        assert ids.tolist() == [a, b] and t.tolist() == [1.0, 2.0]
        ids, t = scene.sweep_box([-3, 2, 0, -2, 3, 1], [1, -1, 0], 10)  # corner to edge at t = 1 (x 0..1, y 1)
        assert ids.tolist() == [a, b] and t.tolist() == [2.0, 3.0]
        ids, t = scene.sweep_box([0.25, 0.25, 0.25, 0.75, 0.75, 0.75], [0, 0, 0], 0)  # inside a
        assert ids.tolist() == [a] and t.tolist() == [0.0]
        assert scene.query_sphere([2, 0.5, 0.5], 0).tolist() == [b]  # on b's face
        assert scene.query_sphere([3, 0.5, 0.5], 1).tolist() == [b]  # 1 from b's face, 2 from a
        assert scene.query_sphere([3, 0.5, 0.5], 2).tolist() == [a, b]
        assert scene.query_sphere([3, 2, 0.5], 1).tolist() == []  # sqrt(2) from b's edge
        assert scene.query_sphere([3, 2, 0.5], 1.5).tolist() == [b]
        assert scene.query_sphere([3, 2, 2], 3).tolist() == [a, b]  # 1+1+1 and 4+1+1 <= 9
        assert scene.query_box([1, 0, 0, 1, 0, 0]).tolist() == [a, b]  # a point on the shared corner
        assert scene.query_box([2, 1, 1, 3, 3, 3]).tolist() == [b]
        assert scene.query_point([0, 0, 0]).tolist() == [a] and scene.query_point([2.5, 0, 0]).tolist() == []
        offsets, ids = scene.query_box_batch([[2, 1, 1, 3, 3, 3], [-1, -1, -1, -0.5, 0, 0], [0, 0, 0, 2, 1, 1]])
        assert offsets.tolist() == [0, 1, 1, 3] and ids.tolist() == [b, a, b]


def lattice_world(dtype):
    """Unit cubes on a 6 x 6 x 3 lattice, every face shared; some are points on their lower corner; one far
    off (tests/test_queries.c's hard cases)."""
    boxes = []
    for x in range(6):
        for y in range(6):
            for z in range(3):
                hi = (x, y, z) if (x + y + z) % 5 == 0 else (x + 1, y + 1, z + 1)
                boxes.append([x, y, z, *hi])
    boxes.append([1e7, 1e7, 1e7, 1e7 + 0.5, 1e7 + 0.5, 1e7 + 0.5])
    scene, world = locd.Scene(threads=2, dtype=dtype), World(dtype)
    world.add(scene, np.array(boxes, dtype=np.float64), np.ones(len(boxes), dtype=np.uint64))
    return scene, world


# (origin, direction, max_t): along faces and edges, through corners, zero and huge directions, max_t 0 and
# inf, origins on corners and far away.
HARD_RAYS = [
    ((0, 0, 0), (1, 0, 0), 10), ((0, 1, 1), (1, 0, 0), 10), ((1, 1, 1), (1, 1, 1), 10), ((2, 2, 2), (0, 0, 0), 10),
    ((2, 2, 2), (1e30, 0, 0), 1), ((0.5, 0.5, -5), (0, 0, 1), 0), ((0.5, 0.5, -5), (0, 0, 1), math.inf),
    ((-1, 3, 1), (1, 0, 0), math.inf), ((6, 6, 3), (-1, -1, -1), 20), ((3, 3, 1), (0, 0, 0), 0),
    ((0, 0, 0), (0, 0, 0), 0), ((6, 0, 0), (-1, 0, 0), 6), ((6, 0, 0), (-1, 0, 0), 5.5), ((-1, -1, -1), (1, 1, 1), 1),
    ((3, -2, 1.5), (0, 1, 0), math.inf), ((3, 3, 3), (0, 0, -1), 3), ((1.5, 2.5, 3), (0, 0, -1e-30), math.inf),
    ((0, 6, 0), (1, -1, 0), math.inf), ((1e7, 1e7, 1e7 - 1), (0, 0, 1), 1), ((1e7, 1e7, 1e7 - 1), (0, 0, 1), 0.999),
    ((-2, 0.5, 3), (1, 0, -0.25), math.inf), ((7, 7, 4), (-2, -2, -2), 0.5),
]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_hard_cases_on_a_touching_lattice(dtype):
    scene, world = lattice_world(dtype)
    ids, boxes = world.arrays(ALL)
    for state in ("added", "updated", "moved back and forth", "a few removed", "a few added again", "updated again",
                  "many removed"):
        if state.startswith("updated"):
            scene.update()
        elif state == "moved back and forth":  # every box moved away, then home again, not updated
            scene.move(ids, boxes + 100.0)
            scene.move(ids, boxes)
        elif state == "a few removed":  # (a few: the tree clears their lanes; many: it writes every lane)
            gone = boxes[::25]
            world.remove(scene, ids[::25])
        elif state == "a few added again":  # (new objects, outside the tree until it is built again)
            world.add(scene, gone + [0.5, 0, 0, 0.5, 0, 0], np.ones(len(gone), dtype=np.uint64))
        elif state == "many removed":
            world.remove(scene, ids[::3])
        ids, boxes = world.arrays(ALL)
        o = np.array([r[0] for r in HARD_RAYS], dtype=np.float64)
        d = np.array([r[1] for r in HARD_RAYS], dtype=np.float64)
        mt = np.array([r[2] for r in HARD_RAYS], dtype=np.float64)
        unit = np.hstack([o, o + 1.0])
        ray_hit, ray_t = bf_cast(boxes, o, o, d, mt)
        sweep_hit, sweep_t = bf_cast(boxes, unit[:, :3], unit[:, 3:], d, mt)

        def ray(k):
            return "%s: ray %r" % (state, HARD_RAYS[k])

        assert_batch(scene.raycast_batch(o, d, mt), bf_batch(ids, ray_hit, ray_t), ray)
        assert_one_per_query(ids, ray_hit, ray_t, scene.raycast_batch(o, d, mt, mode="closest"),
                             scene.raycast_batch(o, d, mt, mode="any"), ray)
        for k in range(len(o)):
            assert_hits(scene.raycast(o[k], d[k], mt[k]), hits_of(ids, ray_hit[k], ray_t[k]), lambda: ray(k))
            assert_hits(scene.sweep_box(unit[k], d[k], mt[k]), hits_of(ids, sweep_hit[k], sweep_t[k]),
                        lambda: "%s: unit box swept from %r" % (state, HARD_RAYS[k]))
        # spheres and points on corners, edges and faces, radii reaching them exactly
        centres = np.array([[x, y, z] for x in (-1, 0, 0.5, 3, 6, 7) for y in (-1, 0, 2.5, 6) for z in (0, 1.5, 4)],
                           dtype=np.float64)
        for r in (0.0, 0.5, 1.0, 2.0, 3.0):
            want = bf_sphere(boxes, centres, np.full(len(centres), r))
            for k in range(len(centres)):
                assert_hits(scene.query_sphere(centres[k], r), hits_of(ids, want[k]),
                            lambda: "%s: sphere %r radius %r" % (state, centres[k].tolist(), r))
        qb = np.vstack([np.hstack([centres, centres]), np.hstack([centres, centres + 1.0]), unit])
        box_hit = bf_overlap(boxes, qb[:, :3], qb[:, 3:])
        assert_batch(scene.query_box_batch(qb), bf_batch(ids, box_hit), lambda k: "%s: box %r" % (state, qb[k]))
        for k in range(len(centres)):
            assert_hits(scene.query_point(centres[k]), hits_of(ids, box_hit[k]),
                        lambda: "%s: point %r" % (state, centres[k].tolist()))
        assert ray_hit.any(axis=1).sum() > len(o) // 2 and box_hit.any(axis=1).sum() > len(qb) // 3


def test_entry_and_exit_times_on_the_boundary():
    """Rays that meet their box only at one instant: entering at max_t exactly, or entering one slab as they
    leave another (at a corner). The times are quotients that the reciprocal of the direction, which the
    library's node test multiplies by, does not always give to the bit; the node test must still let them
    through."""
    rng = np.random.default_rng(4)
    n = 400
    g = rng.integers(1, 1000, n).astype(np.float64)
    d = rng.integers(1, 1000, n) / rng.integers(1, 1000, n) * rng.choice([-1.0, 1.0], n)
    lane = np.arange(n, dtype=np.float64) * 2.0
    # at max_t: box k is x in [g, g + 1] (mirrored for a negative direction), on its own y lane
    x0 = np.where(d > 0, g, -g - 1)
    at_max = np.column_stack([x0, lane, np.zeros(n), x0 + 1, lane + 1, np.ones(n)])
    o_max = np.column_stack([np.zeros(n), lane + 0.5, np.full(n, 0.5)])
    d_max = np.column_stack([d, np.zeros(n), np.zeros(n)])
    t_max = g / np.abs(d)
    # at a corner: enters y >= gy at gy/dy as it leaves x <= g at g/dx, the same quotient; on its own z lane.
    # (Integers: the boxes are float32's too, so the node test sees them as they are, with no rounding outward.)
    gy = rng.integers(1, 1000, n).astype(np.float64)
    dx = np.abs(d)
    dy = gy / (g / dx)
    keep = gy / dy == g / dx
    corner = np.column_stack([np.full(n, -1e4), gy, lane, g, gy + 1e4, lane + 1])[keep]
    o_corner = np.column_stack([np.zeros(n), np.zeros(n), lane + 0.5])[keep]
    d_corner = np.column_stack([dx, dy, np.zeros(n)])[keep]
    assert keep.sum() > n // 2 and (g * (1 / dx) != g / dx).sum() > n // 10  # (cases that tell)
    cases = [(dtype, boxes, o, dirs, mt) for dtype in (np.float64, np.float32)
             for boxes, o, dirs, mt in ((at_max, o_max, d_max, t_max),
                                        (corner, o_corner, d_corner, np.full(len(o_corner), math.inf)))]
    for dtype, boxes, o, dirs, mt in cases:
        scene = locd.Scene(dtype=dtype)
        ids = scene.add(boxes)
        hit, t = bf_cast(boxes, o, o, dirs, mt)
        assert hit.trace() == len(o), "the brute force meets every ray's box"
        assert_batch(scene.raycast_batch(o, dirs, mt), bf_batch(ids, hit, t),
                     lambda k: "ray %r %r max_t %r, box %r" % (o[k], dirs[k], mt[k], boxes[k]))
        assert_one_per_query(ids, hit, t, scene.raycast_batch(o, dirs, mt, mode="closest"),
                             scene.raycast_batch(o, dirs, mt, mode="any"), lambda k: "ray %d" % k)


def test_many_hits_grow_the_buffers():
    scene = locd.Scene()
    ids = scene.add(np.tile(np.array([[0, 0, 0, 1, 1, 1]], np.float32), (1000, 1)))
    np.testing.assert_array_equal(scene.query_sphere([2, 0.5, 0.5], 1), ids)
    hit, t = scene.sweep_box([-3, 0, 0, -2, 1, 1], [1, 0, 0], 5)
    np.testing.assert_array_equal(hit, ids)
    assert (t == 2.0).all()
    offsets, hit, t = scene.raycast_batch([[-1, 0.5, 0.5], [-1, 0.5, 0.5], [0.5, -1, 0.5]],
                                          [[1, 0, 0], [-1, 0, 0], [0, 1, 0]], [5, 5, 1])
    assert offsets.tolist() == [0, 1000, 1000, 2000]
    np.testing.assert_array_equal(hit[:1000], ids)
    np.testing.assert_array_equal(hit[1000:], ids)
    assert (t == 1.0).all()
    offsets, hit = scene.query_box_batch([[0, 0, 0, 0, 0, 0], [5, 5, 5, 6, 6, 6]])
    assert offsets.tolist() == [0, 1000, 1000]


def test_empty_batches_and_scenes():
    scene = locd.Scene()
    for mode in ("closest", "any"):
        ids, t = scene.raycast_batch(np.empty((0, 3)), np.empty((0, 3)), 1.0, mode=mode)
        assert ids.shape == t.shape == (0,) and ids.dtype == np.uint64
    offsets, ids, t = scene.raycast_batch([], [], [])
    assert offsets.tolist() == [0] and len(ids) == len(t) == 0
    offsets, ids = scene.query_box_batch(np.empty((0, 6), np.float32))
    assert offsets.tolist() == [0] and offsets.dtype == np.int64 and len(ids) == 0
    ids, t = scene.raycast_batch([[0, 0, 0], [1, 1, 1]], [[1, 0, 0], [0, 0, 0]], math.inf, mode="closest")
    assert ids.tolist() == [0, 0] and t.tolist() == [math.inf, math.inf]  # an empty scene
    assert len(scene.query_sphere([0, 0, 0], 1e10)) == 0 and len(scene.sweep_box([0] * 6, [1, 1, 1], 1)[0]) == 0


def test_input_forms():
    """Lists, float32, integers, strided and Fortran arrays, a scalar or an array for max_t: the same
    answers; the inputs are not changed."""
    rng = np.random.default_rng(5)
    scene = locd.Scene(dtype=np.float64)
    lo = rng.integers(0, 20, (300, 3)).astype(np.float64)
    scene.add(np.hstack([lo, lo + 2]))
    o = rng.integers(-2, 22, (50, 3)).astype(np.float64)
    d = rng.integers(-2, 3, (50, 3)).astype(np.float64)
    want = scene.raycast_batch(o, d, np.full(50, 4.0))
    wide = np.zeros((50, 6))
    wide[:, ::2] = o
    copy = wide.copy()
    for origins in (o.tolist(), o.astype(np.float32), o.astype(np.int64), o.astype(np.int16), wide[:, ::2],
                    np.asfortranarray(o)):
        for max_t in (4, 4.0, np.float32(4), np.array(4.0), [4] * 50, np.full(50, 4, np.uint8)):
            got = scene.raycast_batch(origins, d.astype(np.int8), max_t)
            for x, y in zip(got, want):
                np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(wide, copy)
    qb = np.hstack([o, o + 3])
    want = scene.query_box_batch(qb)
    for boxes in (qb.tolist(), qb.astype(np.int32), np.asfortranarray(qb), qb.astype(np.float32)):
        for x, y in zip(scene.query_box_batch(boxes), want):
            np.testing.assert_array_equal(x, y)
    for k in range(5):
        one = scene.query_sphere(o[k], 3)
        for c, r in ((o[k].tolist(), 3), (o[k].astype(np.int32), np.int64(3)), (tuple(o[k]), np.array(3.0))):
            np.testing.assert_array_equal(scene.query_sphere(c, r), one)
        one = scene.sweep_box(qb[k], d[k], 2)
        for x, y in zip(scene.sweep_box(qb[k].tolist(), d[k].astype(np.int64), np.float32(2)), one):
            np.testing.assert_array_equal(x, y)


# -- precision: the queries are float64 in a float32 scene ----------------------------------------------------
def test_float32_scene_takes_queries_in_float64():
    scene = locd.Scene(dtype=np.float32)
    a, b = scene.add([[0, 0, 0, 1, 1, 1], [3, 0, 0, 4, 1, 1]]).tolist()
    big = 1e300  # far beyond float32: exact in float64
    assert scene.query_box([-big, -big, -big, big, big, big]).tolist() == [a, b]
    assert scene.query_box_batch([[-big, -big, -big, big, big, big]])[1].tolist() == [a, b]
    hit, t = scene.raycast([-1, 0.5, 0.5], [1e39, 0, 0], 1.0)  # a direction float32 cannot hold
    assert hit.tolist() == [a, b] and t.tolist() == [1.0 / 1e39, 4.0 / 1e39]
    ids, t = scene.raycast_batch([[-1, 0.5, 0.5]], [[1e39, 0, 0]], 1.0, mode="closest")
    assert ids.tolist() == [a] and t.tolist() == [1.0 / 1e39]
    assert scene.query_sphere([0.5, 0.5, -1e150], 1e150).tolist() == [a, b]  # d*d = r*r = 1e300
    # float64 values that float32 would round onto the box: no hit in float64
    eps = 2.0 ** -30
    assert scene.query_point([1 + eps, 0.5, 0.5]).tolist() == []
    assert scene.query_box([1 + eps, 0, 0, 2, 1, 1]).tolist() == []
    assert scene.raycast([1 + eps, 0.5, 0.5], [0, 1, 0], 10)[0].tolist() == []
    assert scene.query_sphere([1 + eps, 0.5, 0.5], 0).tolist() == []
    assert scene.sweep_box([1 + eps, 0, 0, 2, 1, 1], [0, 0, 1], 1)[0].tolist() == []
    # boxes are the scene's: a finite float64 beyond float32's range says so (not "NaN or infinite")
    with pytest.raises(locd.InvalidBoxError, match="beyond the range of float32") as e:
        scene.add([[0, 0, 0, 1, 1, 1], [0, 0, 0, 1e39, 1, 1]])
    assert e.value.index == 1 and len(scene) == 2
    with pytest.raises(locd.InvalidBoxError, match="beyond the range of float32") as e:
        scene.move([b], [[-1e39, 0, 0, 1, 1, 1]])
    assert e.value.index == 0 and scene.query_point([3.5, 0.5, 0.5]).tolist() == [b]
    with pytest.raises(locd.InvalidBoxError, match="NaN or infinite"):  # an inf stays an inf
        scene.add([[0, 0, 0, math.inf, 1, 1]])


# -- bad input ------------------------------------------------------------------------------------------------
def scene_state(scene, q):
    """What the scene answers: its pairs, and the hits of the query boxes q and of rays along them."""
    r = scene.update()
    return [r.pairs.tolist()] + [x.tolist() for x in scene.raycast_batch(q[:, :3], q[:, 3:] - q[:, :3], 2.0)] + \
        [x.tolist() for x in scene.query_box_batch(q)]


def test_bad_queries_name_the_query_and_change_nothing():
    rng = np.random.default_rng(2)
    scene = locd.Scene(threads=2)
    lo = rng.uniform(0, 10, (500, 3))
    ids = scene.add(np.hstack([lo, lo + 1]))
    p = rng.uniform(0, 10, (20, 3))
    probe = np.hstack([p, p + 2])
    before = scene_state(scene, probe)
    scene.move(ids[:50], np.hstack([lo[:50], lo[:50] + 1]) + 0.5)  # a change the bad calls must not lose
    nan, inf = math.nan, math.inf
    good_o, good_d = rng.uniform(0, 10, (6, 3)), rng.normal(size=(6, 3))
    good_b = np.hstack([good_o, good_o + 1])
    cases = []  # (call, index, status name, words of the message)
    for at in (0, 3, 5):
        for value, status in ((nan, "ERR_NONFINITE"), (inf, "ERR_NONFINITE"), (-inf, "ERR_NONFINITE")):
            o = good_o.copy()
            o[at, at % 3] = value
            cases.append((lambda o=o: scene.raycast_batch(o, good_d, 1.0), at, status, "coordinate"))
            d = good_d.copy()
            d[at, 2] = value
            cases.append((lambda d=d: scene.raycast_batch(good_o, d, 1.0, mode="closest"), at, status, "direction"))
            b = good_b.copy()
            b[at, 3 + at % 3] = value
            cases.append((lambda b=b: scene.query_box_batch(b), at, status, "coordinate"))
        for bad_t in (-1.0, -1e-300, nan, -inf):
            mt = np.ones(6)
            mt[at] = bad_t
            cases.append((lambda mt=mt: scene.raycast_batch(good_o, good_d, mt, mode="any"), at,
                          "ERR_INVALID_ARGUMENT", "max_t"))
        b = good_b.copy()
        b[at, 1] = b[at, 4] + 1e-9  # min > max
        cases.append((lambda b=b: scene.query_box_batch(b), at, "ERR_INVERTED_BOX", "min > max"))
    single = [
        (lambda: scene.raycast([nan, 0, 0], [1, 0, 0], 1), "ERR_NONFINITE", "coordinate"),
        (lambda: scene.raycast([0, 0, 0], [1, inf, 0], 1), "ERR_NONFINITE", "direction"),
        (lambda: scene.raycast([0, 0, 0], [1, 0, 0], -0.5), "ERR_INVALID_ARGUMENT", "max_t"),
        (lambda: scene.raycast([0, 0, 0], [1, 0, 0], nan), "ERR_INVALID_ARGUMENT", "max_t"),
        (lambda: scene.raycast_batch([[0, 0, 0]], [[1, 0, 0]], nan), "ERR_INVALID_ARGUMENT", "max_t"),
        (lambda: scene.query_sphere([0, 0, 0], -1), "ERR_INVALID_ARGUMENT", "radius"),
        (lambda: scene.query_sphere([0, 0, 0], nan), "ERR_INVALID_ARGUMENT", "radius"),
        (lambda: scene.query_sphere([0, -inf, 0], 1), "ERR_NONFINITE", "coordinate"),
        (lambda: scene.sweep_box([1, 0, 0, 0, 1, 1], [1, 0, 0], 1), "ERR_INVERTED_BOX", "min > max"),
        (lambda: scene.sweep_box([0, 0, 0, 1, 1, nan], [1, 0, 0], 1), "ERR_NONFINITE", "coordinate"),
        (lambda: scene.sweep_box([0, 0, 0, 1, 1, 1], [nan, 0, 0], 1), "ERR_NONFINITE", "direction"),
        (lambda: scene.sweep_box([0, 0, 0, 1, 1, 1], [1, 0, 0], -2), "ERR_INVALID_ARGUMENT", "max_t"),
        (lambda: scene.query_box([0, 0, 0, 1, -1, 1]), "ERR_INVERTED_BOX", "min > max"),
        (lambda: scene.query_box([0, 0, 0, 1, 1, inf]), "ERR_NONFINITE", "coordinate"),
        (lambda: scene.query_point([0, nan, 0]), "ERR_NONFINITE", "coordinate"),
    ]
    cases += [(call, 0, status, words) for call, status, words in single]
    two = good_o.copy()
    two[[2, 4], 0] = nan
    cases.append((lambda: scene.raycast_batch(two, good_d, 1.0), 2, "ERR_NONFINITE", "coordinate"))  # the first
    for call, at, status, words in cases:
        with pytest.raises(locd.InvalidQueryError) as e:
            call()
        err = e.value
        assert isinstance(err, locd.InvalidBoxError) and isinstance(err, ValueError)
        assert err.index == at and err.name == status and err.status == locd.STATUS[status], (str(err), at, status)
        assert str(err).startswith("query %d" % at) and words in str(err), (str(err), words)
    scene.move(ids[:50], np.hstack([lo[:50], lo[:50] + 1]))  # back: the state of `before`
    assert scene_state(scene, probe) == before


@pytest.mark.parametrize("call, exc", [
    (lambda s: s.raycast_batch([[0, 0, 0]], [[1, 0, 0]], 1.0, mode="first"), ValueError),
    (lambda s: s.raycast_batch([[0, 0, 0]], [[1, 0, 0]], 1.0, mode=1), ValueError),
    (lambda s: s.raycast_batch([[0, 0, 0]], [[1, 0, 0]], 1.0, 3, "all"), TypeError),  # mode is keyword-only
    (lambda s: s.raycast_batch([[0, 0, 0]], [[1, 0, 0]], [1.0, 2.0]), ValueError),
    (lambda s: s.raycast_batch([[0, 0, 0]], [[1, 0, 0], [1, 0, 0]], 1.0), ValueError),
    (lambda s: s.raycast_batch([0, 0, 0], [1, 0, 0], 1.0), ValueError),
    (lambda s: s.raycast_batch([[0, 0, 0]], [[1, 0, 0]], "1"), TypeError),
    (lambda s: s.raycast_batch([[0, 0, 0]], [[1, 0, 0]], ["1"]), TypeError),
    (lambda s: s.raycast_batch([[0, 0, 0]], [[1, 0, 0]], [True]), TypeError),
    (lambda s: s.raycast_batch([[0, 0, 0]], [[1, 0, 0]], None), TypeError),
    (lambda s: s.raycast_batch([["a", "b", "c"]], [[1, 0, 0]], 1.0), TypeError),
    (lambda s: s.raycast_batch([[0, 0, 0]], [[1, 0, 0]], 1.0, mask=-1), ValueError),
    (lambda s: s.raycast_batch([[0, 0, 0]], [[1, 0, 0]], 1.0, mask=1.0), TypeError),
    (lambda s: s.raycast_batch(np.array([[2**53 + 1, 0, 0]]), [[1, 0, 0]], 1.0), ValueError),
    (lambda s: s.raycast_batch(np.zeros((1, 3), np.float16), [[1, 0, 0]], 1.0), TypeError),
    (lambda s: s.raycast_batch(np.zeros((1, 3), bool), [[1, 0, 0]], 1.0), TypeError),
    (lambda s: s.raycast([0, 0, 0], [1, 0, 0], "1"), TypeError),
    (lambda s: s.raycast([0, 0, 0], [1, 0, 0], None), TypeError),
    (lambda s: s.raycast([0, 0, 0], [1, 0, 0], True), TypeError),
    (lambda s: s.raycast([0, 0, 0], [1, 0, 0], [1.0]), TypeError),
    (lambda s: s.raycast([0, 0, 0], [1, 0, 0], 10**400), ValueError),
    (lambda s: s.raycast([0, 0, 0], [1, 0], 1), ValueError),
    (lambda s: s.raycast(np.zeros(3, complex), [1, 0, 0], 1), TypeError),
    (lambda s: s.query_box_batch([[0, 0, 0, 1, 1]]), ValueError),
    (lambda s: s.query_box_batch([0, 0, 0, 1, 1, 1]), ValueError),
    (lambda s: s.query_box_batch([[0, 0, 0, 1, 1, None]]), TypeError),
    (lambda s: s.query_box_batch([[0, 0, 0, 1, 1, 1]], mask=2**64), ValueError),
    (lambda s: s.query_sphere([0, 0, 0], None), TypeError),
    (lambda s: s.query_sphere([0, 0, 0], "2"), TypeError),
    (lambda s: s.query_sphere([0, 0, 0], -2**60), ValueError),
    (lambda s: s.query_sphere([[0, 0, 0]], 1), ValueError),
    (lambda s: s.sweep_box([0, 0, 0, 1, 1, 1], [1, 0, 0], "1"), TypeError),
    (lambda s: s.sweep_box([0, 0, 0], [1, 0, 0], 1), ValueError),
    (lambda s: s.sweep_box([0, 0, 0, 1, 1, 1], [1, 0, 0, 0], 1), ValueError),
])
def test_bad_arguments_raise_the_builtin(call, exc):
    """Arguments Python checks itself (types, shapes, modes): the builtin exception, not a locd.Error."""
    scene = locd.Scene()
    scene.add([[0, 0, 0, 1, 1, 1]])
    with pytest.raises(exc) as e:
        call(scene)
    assert not isinstance(e.value, locd.Error)


# -- the GIL --------------------------------------------------------------------------------------------------
def test_batches_release_the_gil():
    rng = np.random.default_rng(8)
    lo = rng.uniform(0, 100, (20000, 3)).astype(np.float32)
    scene = locd.Scene(threads=1)
    scene.add(np.hstack([lo, lo + rng.uniform(0, 2, (20000, 3)).astype(np.float32)]))
    scene.update()
    o, d = rng.uniform(0, 100, (40000, 3)), rng.normal(size=(40000, 3))
    scene.raycast_batch(o[:10], d[:10], math.inf)  # the tree built
    for reps in (1, 4, 16, 64):  # one call long enough to tell, however fast the machine and the library
        oo, dd = np.tile(o, (reps, 1)), np.tile(d, (reps, 1))
        duration, gap = progress_during(lambda: scene.raycast_batch(oo, dd, math.inf))
        if duration > 0.2:
            break
    assert duration > 0.05, "the call is too short to tell (%.3f s)" % duration
    assert gap < 0.5 * duration, "no Python progress for %.3f s of a %.3f s batch" % (gap, duration)
    boxes = np.hstack([o, o + 4])
    for reps in (1, 4, 16, 64):
        bb = np.tile(boxes, (reps, 1))
        duration, gap = progress_during(lambda: scene.query_box_batch(bb))
        if duration > 0.2:
            break
    assert duration > 0.05 and gap < 0.5 * duration, (duration, gap)


# -- the front doors ------------------------------------------------------------------------------------------
def test_front_doors():
    for kw in (dict(threads=2**32), dict(threads=0), dict(threads=-1), dict(capacity=2**64), dict(capacity=-1)):
        with pytest.raises(ValueError) as e:
            locd.Scene(**kw)
        assert type(e.value) is ValueError and ("threads" if "threads" in kw else "capacity") in str(e.value)
    with pytest.raises(TypeError):
        locd.Scene(threads=2.0)
    scene = locd.Scene(threads=2)
    scene.add([[0, 0, 0, 1, 1, 1]])
    scene.close()
    calls = [lambda: scene.threads, lambda: len(scene), scene.update, lambda: scene.query_box([0] * 6),
             lambda: scene.query_point([0] * 3), lambda: scene.query_sphere([0] * 3, 1),
             lambda: scene.raycast([0] * 3, [1, 0, 0], 1), lambda: scene.sweep_box([0] * 6, [1, 0, 0], 1),
             lambda: scene.raycast_batch([[0] * 3], [[1, 0, 0]], 1, mode="closest"),
             lambda: scene.query_box_batch([[0] * 6]), lambda: scene.add([[0] * 6])]
    for call in calls:
        with pytest.raises(locd.ClosedError, match="the scene is closed"):
            call()
    assert scene.closed and "closed" in repr(scene)


# -- the extension's stub -------------------------------------------------------------------------------------
def test_stub_matches_the_extensions_scene():
    """locd/_core.pyi names every method and property of _core.Scene with the extension's parameters."""
    stub = ast.parse(open(os.path.join(os.path.dirname(locd.__file__), "_core.pyi")).read())
    cls = next(node for node in stub.body if isinstance(node, ast.ClassDef) and node.name == "Scene")
    methods = {f.name: [a.arg for a in f.args.args[1:]] for f in cls.body if isinstance(f, ast.FunctionDef)}
    real = {name for name in vars(locd._core.Scene) if not name.startswith("_")} | {"__init__"}
    assert set(methods) == real
    for name, params in methods.items():
        member = vars(locd._core.Scene)[name]
        if isinstance(member, property):
            assert params == [], name
            continue
        first = member.__doc__.strip().splitlines()[0]  # name(self: ..., a: type, ...) -> type
        assert re.findall(r"(?:\(|, )(\w+): ", first)[1:] == params, (name, first)


# -- overflows ------------------------------------------------------------------------------------------------
def run_python(code):
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=120)


def test_sphere_of_huge_radius_meets_everything():
    # By the documented test every box is within an infinite radius: (dx*dx + dy*dy) + dz*dz <= inf. The
    # walk must not take the query tree's empty lanes (+inf..-inf) as met (inf*inf <= inf) and follow their
    # child, which a version did. Run apart: a crash would kill the suite.
    r = run_python("""
        import math, locd
        for radius in (1e200, math.inf):
            scene = locd.Scene()
            ids = scene.add([[0, 0, 0, 1, 1, 1], [5, 5, 5, 6, 6, 6]])
            assert scene.query_sphere([0, 0, 0], radius).tolist() == ids.tolist(), radius
        print("ok")
        """)
    assert r.returncode == 0 and r.stdout.strip() == "ok", "exit %d: %s" % (r.returncode, r.stderr[-500:])


def test_closest_and_any_see_hits_at_infinite_t():
    # A direction of 1e-310 and max_t inf: the box at x = 1 is entered at t = 1/1e-310 = inf in float64, a
    # hit by the documented test (0 <= t <= max_t); "all" reports it at t = inf, and closest and any must
    # too (a version kept a hit only if (t, id) < (inf, 0), its "no hit yet").
    scene = locd.Scene()
    a, b = scene.add([[1, 0, 0, 2, 1, 1], [3, 0, 0, 4, 1, 1]]).tolist()
    ids, t = scene.raycast([0, 0.5, 0.5], [1e-310, 0, 0], math.inf)
    boxes = np.array([[1, 0, 0, 2, 1, 1], [3, 0, 0, 4, 1, 1]], np.float64)
    hit, want_t = bf_cast(boxes, np.array([[0, 0.5, 0.5]]), np.array([[0, 0.5, 0.5]]), np.array([[1e-310, 0, 0]]),
                          np.array([math.inf]))
    assert hit.all() and ids.tolist() == [a, b] and t.tolist() == want_t[0].tolist() == [math.inf, math.inf]
    cid, ct = scene.raycast_batch([[0, 0.5, 0.5]], [[1e-310, 0, 0]], math.inf, mode="closest")
    aid, at = scene.raycast_batch([[0, 0.5, 0.5]], [[1e-310, 0, 0]], math.inf, mode="any")
    assert cid.tolist() == [a] and aid[0] in (a, b)
