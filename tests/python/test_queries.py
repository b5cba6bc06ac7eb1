"""locd.Scene's queries (docs/queries.md) against a numpy brute force of the documented float64
tests: spheres, rays and swept boxes in every mode, the batches (equal to the queries one by one,
for 1 and 2 threads), in every state of the scene (after updates, between a move and its update,
after removals); bad input; the scene's front doors."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import locd

ALL = (1 << 64) - 1


# -- the brute force (the library's float64 tests, element by element) ----------------------------
def cast_t(box, lo, hi, d, max_t):
    """The entry time of the box lo..hi moved by t d into `box`, or None."""
    t0, t1 = 0.0, float(max_t)
    for a in range(3):
        gin, gout = box[a] - hi[a], box[a + 3] - lo[a]
        if d[a] == 0.0:
            if gin > 0.0 or gout < 0.0:
                return None
            continue
        u = (gin if d[a] > 0 else gout) / d[a]
        v = (gout if d[a] > 0 else gin) / d[a]
        t0, t1 = max(t0, u), min(t1, v)
        if t0 > t1:
            return None
    return t0


def sphere_meets(box, c, r):
    g = [box[a] - c[a] if c[a] < box[a] else c[a] - box[a + 3] if c[a] > box[a + 3] else 0.0 for a in range(3)]
    return (g[0] * g[0] + g[1] * g[1]) + g[2] * g[2] <= r * r


class Model:
    def __init__(self, dtype):
        self.dtype = np.dtype(dtype)
        self.box = {}  # id -> float64 box (the scene's values exactly)
        self.cat = {}

    def add(self, scene, boxes, cats):
        ids = scene.add(boxes, category=cats)
        for i, b, c in zip(ids.tolist(), np.asarray(boxes, self.dtype).astype(np.float64), cats):
            self.box[i], self.cat[i] = [float(x) for x in b], int(c)
        return ids

    def cast(self, lo, hi, d, max_t, mask):
        hits = []
        for i in sorted(self.box):
            if self.cat[i] & mask:
                t = cast_t(self.box[i], lo, hi, d, max_t)
                if t is not None:
                    hits.append((t, i))
        hits.sort()
        return hits

    def sphere(self, c, r, mask):
        return [i for i in sorted(self.box) if self.cat[i] & mask and sphere_meets(self.box[i], c, r)]

    def box_query(self, q, mask):
        return [i for i in sorted(self.box) if self.cat[i] & mask
                and all(self.box[i][a] <= q[a + 3] and q[a] <= self.box[i][a + 3] for a in range(3))]


def check_cast(scene, model, kind, v, d, max_t, mask):
    lo, hi = (v, v) if kind == "ray" else (v[:3], v[3:])
    want = model.cast([float(x) for x in lo], [float(x) for x in hi], [float(x) for x in d], max_t, mask)
    ids, t = scene.raycast(v, d, max_t, mask) if kind == "ray" else scene.sweep_box(v, d, max_t, mask)
    assert ids.dtype == np.uint64 and t.dtype == np.float64
    assert [(float(a), int(b)) for a, b in zip(t, ids)] == want
    if kind == "ray":  # the modes, through the batch of one
        for mode in ("closest", "any"):
            bid, bt = scene.raycast_batch([v], [d], max_t, mask, mode=mode)
            assert bid.shape == (1,) and bt.shape == (1,)
            if not want:
                assert bid[0] == 0 and math.isinf(bt[0])
            elif mode == "closest":
                assert (float(bt[0]), int(bid[0])) == want[0]
            else:
                assert (float(bt[0]), int(bid[0])) in want


coord = st.floats(-50, 50, allow_nan=False, width=32)


@settings(max_examples=40, deadline=None)
@given(data=st.data(), dtype=st.sampled_from([np.float32, np.float64]), threads=st.sampled_from([1, 2]))
def test_random_queries_against_numpy(data, dtype, threads):
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    scene, model = locd.Scene(threads=threads, dtype=dtype), Model(dtype)
    n = data.draw(st.integers(0, 300))
    lo = rng.uniform(-40, 40, (n, 3))
    boxes = np.hstack([lo, lo + rng.uniform(0, 8, (n, 3)) * (rng.random((n, 1)) < 0.9)])
    ids = model.add(scene, boxes, rng.choice([1, 2, 4], n).astype(np.uint64))
    for step in range(4):
        if step == 1:
            scene.update()
        if step == 2 and n:  # moved, not updated
            k = ids[: n // 3]
            nb = np.asarray(boxes[: n // 3], dtype) + dtype(1.5)
            scene.move(k, nb)
            for i, b in zip(k.tolist(), nb.astype(np.float64)):
                model.box[i] = [float(x) for x in b]
        if step == 3 and n:  # removed
            gone = ids[n // 2: n // 2 + 10]
            scene.remove(gone)
            for i in gone.tolist():
                model.box.pop(i, None)
        mask = data.draw(st.sampled_from([ALL, 3, 4]))
        v = [data.draw(coord) for _ in range(3)]
        d = [data.draw(st.sampled_from([0.0, 1.0, -2.0, 0.25, 30.0])) for _ in range(3)]
        max_t = data.draw(st.sampled_from([0.0, 0.5, 1.0, 3.0, math.inf]))
        check_cast(scene, model, "ray", v, d, max_t, mask)
        box = v + [v[a] + data.draw(st.floats(0, 10, width=32)) for a in range(3)]
        check_cast(scene, model, "box", box, d, max_t, mask)
        r = data.draw(st.sampled_from([0.0, 0.5, 3.0, 20.0]))
        got = scene.query_sphere(v, r, mask)
        assert got.tolist() == model.sphere([float(x) for x in v], r, mask)
        offsets, bids = scene.query_box_batch([box, [0, 0, 0, 1, 1, 1]], mask)
        assert offsets.dtype == np.int64 and offsets.tolist()[0] == 0 and len(offsets) == 3
        assert bids[offsets[0]:offsets[1]].tolist() == model.box_query([float(x) for x in box], mask)
        assert bids[offsets[1]:offsets[2]].tolist() == model.box_query([0, 0, 0, 1, 1, 1], mask)


def test_batches_equal_single_queries_for_every_thread_count():
    rng = np.random.default_rng(11)
    lo = rng.uniform(0, 100, (5000, 3)).astype(np.float32)
    boxes = np.hstack([lo, lo + rng.uniform(0, 3, (5000, 3)).astype(np.float32)])
    origins = rng.uniform(0, 100, (700, 3))
    dirs = rng.normal(size=(700, 3)) * 20
    max_t = rng.uniform(0, 2, 700)
    results = []
    for threads in (1, 2):
        scene = locd.Scene(threads=threads)
        scene.add(boxes)
        scene.update()
        all_ = scene.raycast_batch(origins, dirs, max_t)
        closest = scene.raycast_batch(origins, dirs, max_t, mode="closest")
        qb = scene.query_box_batch(np.hstack([origins, origins + 2]))
        results.append((all_, closest, qb))
        offsets, ids, t = all_
        for k in range(0, 700, 37):
            one_ids, one_t = scene.raycast(origins[k], dirs[k], max_t[k])
            np.testing.assert_array_equal(ids[offsets[k]:offsets[k + 1]], one_ids)
            np.testing.assert_array_equal(t[offsets[k]:offsets[k + 1]], one_t)
            if len(one_ids):
                assert closest[0][k] == one_ids[0] and closest[1][k] == one_t[0]
            else:
                assert closest[0][k] == 0 and math.isinf(closest[1][k])
    for a, b in zip(results[0], results[1]):
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x, y)


def test_scalar_max_t_and_empty_batches():
    scene = locd.Scene()
    scene.add([[0, 0, 0, 1, 1, 1]])
    offsets, ids, t = scene.raycast_batch([[-1, 0.5, 0.5]], [[1, 0, 0]], 5)
    assert offsets.tolist() == [0, 1] and t.tolist() == [1.0]
    offsets, ids, t = scene.raycast_batch(np.empty((0, 3)), np.empty((0, 3)), 1.0)
    assert offsets.tolist() == [0] and len(ids) == 0
    offsets, ids = scene.query_box_batch(np.empty((0, 6)))
    assert offsets.tolist() == [0]


def test_bad_query_input_names_the_query():
    scene = locd.Scene()
    scene.add([[0, 0, 0, 1, 1, 1]])
    with pytest.raises(ValueError) as e:
        scene.raycast_batch([[0, 0, 0], [0, math.nan, 0]], [[1, 0, 0], [1, 0, 0]], 1.0)
    assert getattr(e.value, "index", None) == 1
    with pytest.raises(ValueError):
        scene.raycast([0, 0, 0], [1, 0, 0], -1.0)
    with pytest.raises(ValueError):
        scene.query_sphere([0, 0, 0], math.nan)
    with pytest.raises(ValueError):
        scene.sweep_box([1, 1, 1, 0, 0, 0], [1, 0, 0], 1.0)
    with pytest.raises(ValueError, match="mode"):
        scene.raycast_batch([[0, 0, 0]], [[1, 0, 0]], 1.0, mode="first")
    with pytest.raises(TypeError):
        scene.raycast([0, 0, 0], [1, 0, 0], "1")
    with pytest.raises(TypeError):
        scene.query_sphere([0, 0, 0], None)


def test_float32_scene_takes_queries_in_float64():
    scene = locd.Scene(dtype=np.float32)
    ids = scene.add([[0, 0, 0, 1, 1, 1]])
    assert scene.query_box([-1e300, -1e300, -1e300, 1e300, 1e300, 1e300]).tolist() == ids.tolist()
    hit, t = scene.raycast([-1, 0.5, 0.5], [1e39, 0, 0], 1.0)
    assert hit.tolist() == ids.tolist() and t[0] == 1.0 / 1e39


def test_front_doors():
    with pytest.raises(ValueError):
        locd.Scene(threads=2**32)
    with pytest.raises(ValueError):
        locd.Scene(capacity=2**64)
    scene = locd.Scene(threads=2)
    scene.close()
    with pytest.raises(ValueError, match="closed"):
        scene.threads
