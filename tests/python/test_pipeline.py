"""locd.pipeline (shapes, world, stages) against independent references:
closed-form sphere geometry written here in numpy, brute force on world
boxes, the tunnelling ball, and bad shapes."""
import math

import numpy as np
import pytest

from locd import pipeline as lp

pytestmark = pytest.mark.skipif(not lp.available(), reason="locd built without the narrow phase (libccd/FCL)")

IDENTITY = (0.0, 0.0, 0.0, 1.0)


def pose(x, y, z, q=IDENTITY):
    return (x, y, z) + tuple(q)


def test_spheres_every_route_matches_numpy():
    rng = np.random.default_rng(3)
    for _ in range(300):
        ra, rb = rng.uniform(0.2, 1.0, 2)
        a, b = lp.Shape.sphere(ra), lp.Shape.sphere(rb)
        ca, cb = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)
        dist = float(np.linalg.norm(cb - ca))
        if abs(dist - (ra + rb)) < 1e-6:
            continue
        want = dist <= ra + rb
        for route in ("closed", "ccd", "fcl"):
            hit, c = lp.collide_pair(a, pose(*ca), b, pose(*cb), route=route, contact=True)
            assert hit == want, route
            if hit:
                depth, normal, _ = c
                assert depth == pytest.approx(ra + rb - dist, rel=2e-3, abs=1e-6)
                if dist > 1e-3:
                    assert np.dot(normal, (cb - ca) / dist) > 0.999


def test_world_matches_brute_force_and_skips_stages():
    rng = np.random.default_rng(5)
    w = lp.World(threads=1)
    shapes = [lp.Shape.sphere(0.2), lp.Shape.box(0.2, 0.1, 0.15), lp.Shape.capsule(0.1, 0.15)]
    poses, kinds = [], []
    for i in range(200):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        p = tuple(rng.uniform(-2, 2, 3)) + tuple(q)
        k = i % 3
        assert w.add(shapes[k], p) == i
        poses.append(p)
        kinds.append(k)
    broad = w.collide(shape_tests=False, sort=True)
    boxes = np.array([shapes[k].aabb(p) for k, p in zip(kinds, poses)])
    lo, hi = boxes[:, :3], boxes[:, 3:]
    expect = [(i, j) for i in range(200) for j in range(i + 1, 200)
              if np.all(lo[i] <= hi[j]) and np.all(lo[j] <= hi[i])]
    assert [tuple(p) for p in broad.pairs.tolist()] == expect
    for stage in ("shape", "swept", "contact"):
        assert broad.stats[stage]["calls"] == 0 and broad.stats[stage]["ms"] == 0.0
    exact = w.collide(contacts=True)
    assert exact.stats["shape"]["calls"] == 1 and exact.stats["contact"]["calls"] == 1
    got = {tuple(p) for p in exact.pairs.tolist()}
    want = {(i, j) for i, j in expect
            if lp.collide_pair(shapes[kinds[i]], poses[i], shapes[kinds[j]], poses[j])[0]}
    assert got == want
    assert exact.depth is not None and np.all(exact.depth >= -1e-9)


@pytest.mark.parametrize("swept,caught", [("off", False), ("on", True), ("auto", True)])
def test_fast_ball_through_the_floor(swept, caught):
    w = lp.World()
    w.add(lp.Shape.box(10, 10, 0.1), pose(0, 0, -0.1))
    w.add(lp.Shape.sphere(0.25), pose(0, 0, 1.0), velocity=(0, 0, -300, 0, 0, 0))
    r = w.collide(swept=swept, dt=1 / 60, contacts=True)
    assert (len(r.pairs) == 1) == caught
    if caught:
        assert r.toi[0] == pytest.approx(0.75 / 5.0, abs=1e-6)
        assert r.normal[0][2] > 0.99


def test_bad_shapes_raise_with_a_clear_message():
    import locd

    with pytest.raises(locd.Error, match="empty point set"):
        lp.Shape.convex(np.empty((0, 3)))
    with pytest.raises(locd.Error, match="degenerate"):
        lp.Shape.mesh([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]])
    w = lp.World()
    with pytest.raises(locd.Error, match="pose"):
        w.add(lp.Shape.sphere(1.0), (0, 0, math.nan, 0, 0, 0, 1))
    assert len(w) == 0
