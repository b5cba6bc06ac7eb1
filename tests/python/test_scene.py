"""locd.Scene against a numpy model: long random sequences of add/move/remove/set_filter with
static objects, compared at every update and query with a brute force; stale ids, bad boxes and
the batch-rejection rule (a failed call changes nothing)."""
import math
import threading

import numpy as np
import pytest
from hypothesis import given, note
from hypothesis import strategies as st

import locd

ALL = (1 << 64) - 1
EMPTY = np.empty((0, 2), dtype=np.uint64)


# -- the model ----------------------------------------------------------------------
class Model:
    """What the scene should hold: boxes (float64, exact copies of the scene's
    dtype values) and attributes per live id, and the pairs of the last update."""

    def __init__(self, dtype):
        self.dtype = np.dtype(dtype)
        self.objects = {}  # id -> dict(box, static, category, mask, group, user)
        self.previous = set()
        self.issued = set()

    def exact(self, boxes):
        return np.asarray(boxes, dtype=self.dtype).astype(np.float64)

    def ids(self):
        return np.array(sorted(self.objects), dtype=np.uint64)

    def arrays(self):
        ids = self.ids()
        objs = [self.objects[int(i)] for i in ids]
        box = np.array([o["box"] for o in objs], dtype=np.float64).reshape(-1, 6)
        col = lambda k, t: np.array([o[k] for o in objs], dtype=t)  # noqa: E731
        return ids, box, col("static", bool), col("category", np.uint64), col("mask", np.uint64), \
            col("group", np.uint64), col("user", np.uint64)

    def pairs(self):
        ids, box, static, cat, mask, group, _ = self.arrays()
        n = len(ids)
        if n < 2:
            return set()
        lo, hi = box[:, :3], box[:, 3:]
        ok = np.ones((n, n), dtype=bool)
        for a in range(3):
            ok &= lo[:, None, a] <= hi[None, :, a]
            ok &= lo[None, :, a] <= hi[:, None, a]
        ok &= (cat[:, None] & mask[None, :]) != 0
        ok &= (cat[None, :] & mask[:, None]) != 0
        ok &= ~((group[:, None] == group[None, :]) & (group[:, None] != 0))
        ok &= ~(static[:, None] & static[None, :])
        i, j = np.nonzero(np.triu(ok, 1))  # ids ascending: row < column is first < second
        return {(int(ids[a]), int(ids[b])) for a, b in zip(i, j)}

    def hits(self, test, mask):
        return np.array([i for i in sorted(self.objects)
                         if (self.objects[i]["category"] & mask) and test(self.objects[i]["box"])], dtype=np.uint64)

    def query_box(self, q, mask):
        q = self.exact(q)
        return self.hits(lambda b: all(b[a] <= q[3 + a] and q[a] <= b[3 + a] for a in range(3)), mask)

    def query_point(self, p, mask):
        p = self.exact(p)
        return self.hits(lambda b: all(b[a] <= p[a] <= b[3 + a] for a in range(3)), mask)

    def raycast(self, origin, direction, max_t, mask):
        """Slab test in float64. The test rays use coordinates and directions for
        which every quotient is exact, so any correct implementation agrees to the bit."""
        o, d = self.exact(origin), self.exact(direction)
        out = []
        for i in sorted(self.objects):
            ob = self.objects[i]
            if not ob["category"] & mask:
                continue
            b = ob["box"]
            enter, leave = 0.0, float(max_t)
            for a in range(3):
                if d[a] == 0:
                    if o[a] < b[a] or o[a] > b[3 + a]:
                        enter, leave = 1.0, 0.0
                    continue
                t1, t2 = (b[a] - o[a]) / d[a], (b[3 + a] - o[a]) / d[a]
                enter, leave = max(enter, min(t1, t2)), min(leave, max(t1, t2))
            if enter <= leave:
                out.append((enter, i))
        out.sort()
        return np.array([i for _, i in out], dtype=np.uint64), np.array([t for t, _ in out], dtype=np.float64)


def rows(pairs):
    return np.array(sorted(pairs), dtype=np.uint64).reshape(-1, 2)


def check_update(scene, model):
    r = scene.update()
    now = model.pairs()
    for name, got, want in (("pairs", r.pairs, now), ("created", r.created, now - model.previous),
                            ("lost", r.lost, model.previous - now)):
        assert got.dtype == np.uint64 and got.ndim == 2 and got.shape[1] == 2, name
        np.testing.assert_array_equal(got, rows(want), err_msg=name)
    model.previous = now
    assert len(scene) == len(model.objects)


def move_both(scene, model, ids, boxes):
    """Moves ids to boxes in the scene and in the model."""
    scene.move(ids, boxes)
    for i, box in zip(ids.tolist(), model.exact(boxes)):
        model.objects[i]["box"] = box


def replace_some(scene, model, rng, count, boxes):
    """Removes count random objects and adds count plain ones at boxes, in the scene and in the model."""
    gone = rng.choice(model.ids(), size=count, replace=False)
    scene.remove(gone)
    for i in gone.tolist():
        del model.objects[i]
    for k, i in enumerate(scene.add(boxes).tolist()):
        model.objects[i] = dict(box=model.exact(boxes[k]), static=False, category=1, mask=ALL, group=0, user=0)


def check_queries(scene, model, box, point, ray, mask):
    got = scene.query_box(box, mask=mask)
    assert got.dtype == np.uint64
    np.testing.assert_array_equal(got, model.query_box(box, mask), err_msg="query_box")
    np.testing.assert_array_equal(scene.query_point(point, mask=mask), model.query_point(point, mask),
                                  err_msg="query_point")
    origin, direction, max_t = ray
    ids, t = scene.raycast(origin, direction, max_t, mask=mask)
    want_ids, want_t = model.raycast(origin, direction, max_t, mask)
    assert ids.dtype == np.uint64 and t.dtype == np.float64
    np.testing.assert_array_equal(ids, want_ids, err_msg="raycast ids")
    np.testing.assert_array_equal(t, want_t, err_msg="raycast t")


# -- strategies ---------------------------------------------------------------------
# Coordinates on a grid of powers of two: touching faces, edges and corners are common and
# every value (and every ray quotient below) is exact in float32 and float64.
SCALES = [1.0, 0.25, 1024.0]
CATEGORIES = st.sampled_from([1, 2, 3, 0, 1 << 63])
MASKS = st.sampled_from([ALL, 1, 2, 3, 0, (1 << 63) | 1])
GROUPS = st.sampled_from([0, 0, 1, 2])


def boxes_st(n, scale):
    coord = st.integers(-4, 4)
    ext = st.integers(0, 2)
    return st.lists(st.tuples(coord, coord, coord, ext, ext, ext), min_size=n, max_size=n).map(
        lambda r: np.array([[x, y, z, x + a, y + b, z + c] for x, y, z, a, b, c in r],
                           dtype=np.float64).reshape(-1, 6) * scale)


def attribute(draw, values, n):
    """A scalar, a numpy array of some integer dtype, or a list of Python ints."""
    how = draw(st.sampled_from(["scalar", "array", "list"]))
    if how == "scalar":
        return draw(values)
    vals = draw(st.lists(values, min_size=n, max_size=n))
    if how == "list":
        return vals
    dtype = np.uint64 if max(vals, default=0) > 0x7FFFFFFF else draw(st.sampled_from([np.uint64, np.int64, np.int32]))
    return np.array(vals, dtype=dtype)


def expand(value, n):
    return [int(v) for v in np.broadcast_to(np.asarray(value, dtype=object), (n,))] if n else []


def some_ids(draw, model, allow_empty=True):
    live = sorted(model.objects)
    return draw(st.lists(st.sampled_from(live), unique=True, min_size=0 if allow_empty else 1,
                         max_size=min(len(live), 6))) if live else []


def ray_st(scale):
    comp = st.sampled_from([0.0, 1.0, -1.0, 0.5, -0.5, 2.0])
    coord = st.integers(-6, 6).map(lambda v: v * scale)
    return st.tuples(st.tuples(coord, coord, coord), st.tuples(comp, comp, comp),
                     st.sampled_from([0.0, 1.0, 4.0, 64.0, math.inf]).map(lambda t: t * (scale if t else 1)))


def step(draw, scene, model, scale):
    """One random operation on scene and model, checked where it answers."""
    op = draw(st.sampled_from(["add", "add", "move", "move", "remove", "filter", "user", "update", "query",
                               "stale", "badbox", "duplicate"]))
    note("op %s" % op)
    if op == "add":
        n = draw(st.integers(0, 6))
        boxes = draw(boxes_st(n, scale))
        static = draw(st.booleans())
        cat, mask, group = attribute(draw, CATEGORIES, n), attribute(draw, MASKS, n), attribute(draw, GROUPS, n)
        user = draw(st.one_of(st.none(), st.integers(0, ALL)))
        ids = scene.add(boxes, static=static, category=cat, mask=mask, group=group, user=user)
        assert ids.dtype == np.uint64 and ids.shape == (n,)
        assert all(int(i) != 0 and int(i) not in model.issued for i in ids), "ids are new and nonzero"
        assert len(set(ids.tolist())) == n
        exact = model.exact(boxes)
        for k, (i, c, m, g) in enumerate(zip(ids.tolist(), expand(cat, n), expand(mask, n), expand(group, n))):
            model.objects[i] = dict(box=exact[k], static=static, category=c, mask=m, group=g, user=user or 0)
            model.issued.add(i)
    elif op == "move":
        ids = some_ids(draw, model)
        boxes = draw(boxes_st(len(ids), scale))
        scene.move(np.array(ids, dtype=np.uint64), boxes)
        for i, b in zip(ids, model.exact(boxes)):
            model.objects[i]["box"] = b
    elif op == "remove":
        ids = some_ids(draw, model)
        scene.remove(ids)  # a plain list of Python ints
        for i in ids:
            del model.objects[i]
    elif op == "filter":
        ids = some_ids(draw, model)
        n = len(ids)
        kw = {}
        for name, values in (("category", CATEGORIES), ("mask", MASKS), ("group", GROUPS)):
            if draw(st.booleans()):
                kw[name] = attribute(draw, values, n)
        scene.set_filter(np.array(ids, dtype=np.uint64), **kw)
        for name, value in kw.items():
            for i, v in zip(ids, expand(value, n)):
                model.objects[i][name] = v
    elif op == "user":
        ids = some_ids(draw, model)
        users = draw(st.lists(st.integers(0, ALL), min_size=len(ids), max_size=len(ids)))
        scene.set_user(ids, np.array(users, dtype=np.uint64))
        for i, u in zip(ids, users):
            model.objects[i]["user"] = u
        ids = some_ids(draw, model)
        got = scene.user(np.array(ids, dtype=np.uint64))
        assert got.dtype == np.uint64
        assert got.tolist() == [model.objects[i]["user"] for i in ids]
    elif op == "update":
        check_update(scene, model)
    elif op == "query":
        q = draw(boxes_st(1, scale))[0]
        p = np.array(draw(st.tuples(*[st.integers(-5, 7)] * 3)), dtype=np.float64) * scale
        check_queries(scene, model, q, p, draw(ray_st(scale)), draw(MASKS))
    elif op == "stale":
        # A removed or never-issued id somewhere in an otherwise good batch.
        gone = sorted(model.issued - set(model.objects))
        bad = draw(st.sampled_from(gone)) if gone and draw(st.booleans()) else draw(
            st.sampled_from([12345, (1 << 64) - 1, 1, 1 << 32]).filter(lambda v: v not in model.objects))
        ids = some_ids(draw, model)
        at = draw(st.integers(0, len(ids)))
        ids = ids[:at] + [bad] + ids[at:]
        what = draw(st.sampled_from(["move", "remove", "filter", "user"]))
        with pytest.raises(KeyError) as e:
            if what == "move":
                scene.move(ids, draw(boxes_st(len(ids), scale)))
            elif what == "remove":
                scene.remove(ids)
            elif what == "filter":
                scene.set_filter(ids, category=0, mask=0, group=1)
            else:
                scene.user(ids)
        assert isinstance(e.value, locd.StaleIdError) and e.value.index == at, (what, e.value.index, at)
        assert "index %d" % at in str(e.value)
    elif op == "badbox":
        n = draw(st.integers(1, 5))
        boxes = draw(boxes_st(n, scale))
        at = draw(st.integers(0, n - 1))
        axis = draw(st.integers(0, 2))
        if draw(st.booleans()):
            boxes[at, draw(st.integers(0, 5))] = draw(st.sampled_from([math.nan, math.inf, -math.inf]))
        else:
            boxes[at, axis] = boxes[at, 3 + axis] + scale  # min > max
        ids = some_ids(draw, model)
        with pytest.raises(ValueError) as e:
            if ids and len(ids) >= n and draw(st.booleans()):
                scene.move(ids[:n], boxes)
            else:
                scene.add(boxes, static=draw(st.booleans()))
        assert isinstance(e.value, locd.InvalidBoxError) and e.value.index == at
        assert "box %d" % at in str(e.value)
    elif op == "duplicate":
        ids = some_ids(draw, model, allow_empty=False)
        if ids:
            dup = ids + [draw(st.sampled_from(ids))]
            with pytest.raises(ValueError) as e:
                if draw(st.booleans()):
                    scene.remove(dup)
                else:
                    scene.move(dup, draw(boxes_st(len(dup), scale)))
            assert isinstance(e.value, locd.DuplicateIdError)
            assert e.value.index in (dup.index(dup[-1]), len(dup) - 1)
    assert len(scene) == len(model.objects)


@given(st.data(), st.sampled_from([np.float32, np.float64]), st.sampled_from(SCALES), st.sampled_from([1, 2]))
def test_random_sequences_against_numpy(data, dtype, scale, threads):
    """Every update and query of a random sequence equals the brute force; failed calls
    (stale ids, bad boxes, duplicates) leave the scene as it was, which the next
    update and query check."""
    model = Model(dtype)
    with locd.Scene(threads=threads, dtype=dtype) as scene:
        for _ in range(data.draw(st.integers(5, 40), label="steps")):
            step(data.draw, scene, model, scale)
        check_update(scene, model)
        check_update(scene, model)  # nothing changed: no events
        assert model.previous == model.pairs()


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_long_random_sequence(dtype):
    """A few hundred objects over 150 frames: a fraction moves every frame, some come and go."""
    rng = np.random.default_rng(14)
    model = Model(dtype)

    def random_boxes(n):
        lo = rng.integers(0, 40, (n, 3)).astype(np.float64) * 0.5
        return np.hstack([lo, lo + rng.integers(0, 4, (n, 3)) * 0.5])

    with locd.Scene(dtype=dtype) as scene:
        for static in (True, False):
            b = random_boxes(150)
            cat = rng.integers(1, 4, 150).astype(np.uint8)
            ids = scene.add(b, static=static, category=cat)
            for k, i in enumerate(ids.tolist()):
                model.objects[i] = dict(box=model.exact(b[k]), static=static, category=int(cat[k]), mask=ALL,
                                        group=0, user=0)
        # Groups through set_filter (an array of int64).
        live = model.ids()
        groups = rng.integers(0, 3, len(live))
        scene.set_filter(live, group=groups)
        for i, g in zip(live.tolist(), groups.tolist()):
            model.objects[i]["group"] = g
        check_update(scene, model)
        for frame in range(150):
            live = model.ids()
            moving = rng.choice(live, size=max(1, len(live) // 20), replace=False)
            move_both(scene, model, moving, random_boxes(len(moving)))
            if frame % 10 == 3:
                replace_some(scene, model, rng, 5, random_boxes(5))
            if frame % 10 == 7:
                some = rng.choice(model.ids(), size=10, replace=False)
                masks = rng.integers(0, 4, 10).astype(np.uint64)
                masks[masks == 3] = ALL
                scene.set_filter(some, mask=masks)
                for i, m in zip(some.tolist(), masks.tolist()):
                    model.objects[i]["mask"] = m
            check_update(scene, model)
            if frame % 15 == 0:
                q = random_boxes(1)[0]
                check_queries(scene, model, q, q[:3], (q[:3] - 1.0, np.array([1.0, 0.5, 0.0]), 30.0), ALL)


# -- the surface ------------------------------------------------------------------------
@pytest.mark.parametrize("dtype,share", [(np.float32, 20), (np.float64, 20), (np.float64, 10)])
def test_small_moves_take_partner_lists(dtype, share):
    """Objects that move a little stay in their fat boxes and take their pairs from their partner
    lists (stats["coasted"]); a few jump, come and go, change filters; statics move too. Every frame
    against the model. With 1 in 10 moving (over 8%), the first updates go from scratch, then one
    builds the lists (scene.md, "Partner lists come and go")."""
    rng = np.random.default_rng(41)
    model = Model(dtype)

    def random_boxes(n):
        lo = rng.uniform(0.0, 12.0, (n, 3))
        edge = rng.uniform(0.5, 1.5, (n, 1))
        edge[rng.random(n) < 0.02] = 0.0  # points: no fat box to stay in
        return np.hstack([lo, lo + edge])

    with locd.Scene(dtype=dtype) as scene:
        for static in (True, False):
            b = random_boxes(200 if static else 600)
            cat = rng.integers(1, 4, len(b)).astype(np.uint8)
            ids = scene.add(b, static=static, category=cat)
            for k, i in enumerate(ids.tolist()):
                model.objects[i] = dict(box=model.exact(b[k]), static=static, category=int(cat[k]), mask=ALL,
                                        group=0, user=0)
        check_update(scene, model)
        coasted = 0
        for frame in range(40):
            live = model.ids()
            moving = rng.choice(live, size=len(live) // share, replace=False)
            old = np.array([model.objects[int(i)]["box"] for i in moving])
            d = rng.uniform(-0.01, 0.01, (len(moving), 3))
            b = old + np.hstack([d, d])
            jump = rng.random(len(moving)) < 0.05
            b[jump] = random_boxes(int(jump.sum()))
            move_both(scene, model, moving, b)
            if frame % 8 == 5:
                replace_some(scene, model, rng, 4, random_boxes(4))
                some = rng.choice(model.ids(), size=6, replace=False)
                groups = rng.integers(0, 3, 6)
                scene.set_filter(some, group=groups)
                for i, g in zip(some.tolist(), groups.tolist()):
                    model.objects[i]["group"] = g
            check_update(scene, model)
            coasted += scene.stats["coasted"]
        assert coasted > 40 * (len(model.objects) // share) // 2  # most small moves took their lists


def test_readme_example():
    scene = locd.Scene()
    ids = scene.add(np.array([[0, 0, 0, 1, 1, 1], [1, 0, 0, 2, 1, 1], [5, 5, 5, 6, 6, 6]], np.float32),
                    user=[10, 11, 12])
    assert ids.dtype == np.uint64 and ids.shape == (3,) and len(scene) == 3
    r = scene.update()
    assert r.pairs.tolist() == [[ids[0], ids[1]]] and r.created.tolist() == r.pairs.tolist()
    assert r.lost.shape == (0, 2) and r.lost.dtype == np.uint64
    assert scene.user(ids).tolist() == [10, 11, 12]
    scene.remove(ids[:1])
    r = scene.update()
    assert r.pairs.shape == (0, 2) and r.lost.tolist() == [[ids[0], ids[1]]]
    assert scene.query_point([5, 5, 5]).tolist() == [ids[2]]
    hit, t = scene.raycast([1.5, 0.5, 0.5], [1, 1, 1], 10.0)
    assert hit.tolist() == [ids[1], ids[2]] and t.tolist() == [0.0, 4.5]


def test_ids_never_reused():
    scene = locd.Scene(threads=1)
    seen = set()
    box = np.zeros((3, 6), np.float32)
    for _ in range(50):
        ids = scene.add(box)
        assert not seen & set(ids.tolist()) and 0 not in ids
        seen |= set(ids.tolist())
        scene.remove(ids)
    assert len(scene) == 0
    with pytest.raises(KeyError):
        scene.move(ids[:1], box[:1])


def test_statics_never_pair_with_each_other():
    scene = locd.Scene()
    box = np.zeros((4, 6), np.float64)
    s = scene.add(box, static=True)
    assert scene.update().pairs.shape == (0, 2)
    d = scene.add(box[:1])
    assert scene.update().pairs.tolist() == [[int(a), int(d[0])] for a in s]
    stats = scene.stats
    assert stats["objects"] == 5 and stats["static_objects"] == 4 and stats["pairs"] == 4 and stats["created"] == 4
    scene.move(s[:1], box[:1] + 10)  # statics may move
    assert len(scene.update().lost) == 1


def test_attribute_forms_and_dtypes():
    scene = locd.Scene()
    box = np.zeros((3, 6), np.float32)
    big = (1 << 63) + 5
    ids = scene.add(box, category=np.array([1, 2, 4], np.int8), mask=[big, ALL, np.uint16(7)],
                    group=np.uint32(0), user=[big, 0, ALL])
    assert scene.user(ids).tolist() == [big, 0, ALL]
    # big has bits 63, 2 and 0: 0-1 fails (2 & big == 0); 0-2 (1 & 7, 4 & big) and 1-2 (2 & 7, 4 & ALL) pair.
    assert scene.update().pairs.tolist() == [[ids[0], ids[2]], [ids[1], ids[2]]]
    scene.set_filter(ids, group=5)
    assert scene.update().pairs.shape == (0, 2)
    scene.set_filter(ids[1:], group=[0, 6], category=np.int64(1))  # groups 5, 0, 6; categories 1, 1, 1
    assert scene.update().pairs.tolist() == [[ids[0], ids[1]], [ids[0], ids[2]], [ids[1], ids[2]]]
    scene.set_filter(ids[:2], group=6)  # groups 6, 6, 6
    assert scene.update().pairs.shape == (0, 2)
    with pytest.raises(ValueError, match=r"category\[1\] = -2 is negative"):
        scene.add(box, category=np.array([1, -2, 3]))
    with pytest.raises(ValueError, match="outside"):
        scene.add(box, mask=1 << 64)
    with pytest.raises(TypeError):
        scene.add(box, category=[1.5, 2.0, 3.0])
    with pytest.raises(ValueError, match="2 values for a batch of 3"):
        scene.add(box, group=[1, 2])
    with pytest.raises(TypeError):
        scene.remove(np.array([1.0]))
    with pytest.raises(ValueError, match=r"ids\[0\] = -1 is negative"):
        scene.remove([-1])
    with pytest.raises(TypeError, match="float32 or float64"):
        scene.add(np.zeros((2, 6), np.int32))
    with pytest.raises(ValueError, match=r"shape \(n, 6\)"):
        scene.add(np.zeros((2, 5), np.float32))
    with pytest.raises(ValueError, match="3 rows for 2 ids"):
        scene.move(ids[:2], box)
    assert len(scene) == 3


def test_failed_batches_change_nothing():
    scene = locd.Scene()
    box = np.array([[0, 0, 0, 1, 1, 1]] * 4, np.float32)
    ids = scene.add(box, user=7)
    before = scene.update().pairs
    bad = box.copy()
    bad[2, 4] = np.nan
    with pytest.raises(ValueError, match="box 2") as e:
        scene.move(ids, bad + 5)  # rows 0 and 1 are fine: they must not move either
    assert e.value.index == 2
    with pytest.raises(KeyError, match="index 3") as e:
        scene.remove([ids[0], ids[1], ids[2], 999])
    assert e.value.index == 3
    with pytest.raises(KeyError):
        scene.set_filter([ids[0], 999], category=0)
    with pytest.raises(KeyError):
        scene.set_user([ids[0], 999], 5)
    with pytest.raises(ValueError):
        scene.add(np.vstack([box, [[2, 0, 0, 1, 1, 1]]]))  # inverted: nothing added
    assert len(scene) == 4 and scene.user(ids).tolist() == [7] * 4
    r = scene.update()
    np.testing.assert_array_equal(r.pairs, before)
    assert r.created.shape == r.lost.shape == (0, 2)
    np.testing.assert_array_equal(scene.query_box([0, 0, 0, 0, 0, 0]), np.sort(ids))


def test_float64_scene_keeps_float64():
    tiny = 2.0 ** -40
    for dtype, pairs in ((np.float64, 0), (np.float32, 1)):
        scene = locd.Scene(dtype=dtype)
        assert scene.dtype == np.dtype(dtype)
        scene.add(np.array([[0, 0, 0, 1, 1, 1], [1 + tiny, 0, 0, 2, 1, 1]], np.float64))
        assert len(scene.update().pairs) == pairs  # float32 rounds 1 + 2**-40 to 1: touching


def test_many_query_hits_grow_the_buffer():
    scene = locd.Scene()
    ids = scene.add(np.zeros((1000, 6), np.float32))
    np.testing.assert_array_equal(scene.query_point([0, 0, 0]), ids)
    hit, t = scene.raycast([-1, 0, 0], [1, 0, 0], 5)
    np.testing.assert_array_equal(hit, ids)
    assert (t == 1.0).all()


def test_bad_query_arguments():
    scene = locd.Scene()
    with pytest.raises(ValueError, match=r"shape \(6,\)"):
        scene.query_box([0, 0, 0])
    with pytest.raises(ValueError, match=r"shape \(3,\)"):
        scene.query_point([0, 0, 0, 1])
    with pytest.raises(TypeError):
        scene.query_point([0, 0, 0], mask=1.5)


def test_constructor_and_close():
    with pytest.raises(ValueError):
        locd.Scene(threads=0)
    with pytest.raises(TypeError):
        locd.Scene(dtype=np.int32)
    scene = locd.Scene(threads=2, dtype="float64", capacity=100)
    assert scene.threads == 2 and "0 objects" in repr(scene)
    scene.close()
    scene.close()
    assert scene.closed and "closed" in repr(scene)
    with pytest.raises(ValueError, match="closed"):
        scene.update()
    with pytest.raises(ValueError, match="closed"):
        len(scene)


def test_same_results_for_every_thread_count():
    rng = np.random.default_rng(3)
    lo = rng.random((3000, 3), dtype=np.float32) * 50
    boxes = np.hstack([lo, lo + 4 * rng.random((3000, 3), dtype=np.float32)])
    results = []
    for threads in (1, 2):
        scene = locd.Scene(threads=threads)
        ids = scene.add(boxes[:2000])
        scene.add(boxes[2000:], static=True)
        scene.update()
        scene.move(ids[::7], boxes[:2000:7] + 0.5)
        results.append(scene.update())
    for name in ("pairs", "created", "lost"):
        np.testing.assert_array_equal(getattr(results[0], name), getattr(results[1], name))
    assert len(results[0].pairs) > 500 and len(results[0].created) and len(results[0].lost)


def test_threads_share_a_scene():
    """Python threads take turns on one scene (the GIL is released while C works)."""
    scene = locd.Scene()
    box = np.zeros((10, 6), np.float32)
    errors = []

    def worker():
        try:
            for _ in range(50):
                ids = scene.add(box)
                scene.update()
                scene.query_point([0, 0, 0])
                scene.remove(ids)
        except Exception as e:  # pragma: no cover - reported below
            errors.append(e)

    threads = [threading.Thread(target=worker) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and len(scene) == 0


def test_cffi_declares_the_scene():
    """locd.abi (cffi, declarations generated from every public header) drives the same scene API."""
    import locd.abi

    ffi, lib = locd.abi.ffi, locd.abi.lib
    cfg = ffi.new("locd_engine_config *")
    lib.locd_engine_config_init(cfg)
    engine, scene = ffi.new("locd_engine **"), ffi.new("locd_scene **")
    assert lib.locd_engine_create(cfg, engine) == 0
    try:
        assert lib.locd_scene_create(engine[0], ffi.NULL, scene) == 0
        boxes = np.array([[0, 0, 0, 1, 1, 1], [1, 1, 1, 2, 2, 2]], np.float64)
        ids = np.zeros(2, np.uint64)
        assert lib.locd_scene_add_f64(scene[0], ffi.from_buffer("double[]", boxes), 2, ffi.NULL,
                                      ffi.from_buffer("locd_id[]", ids)) == 0
        assert lib.locd_scene_update(scene[0], locd.abi.CONSTANTS["LOCD_SCENE_UPDATE_PAIRS"]) == 0
        data, count = ffi.new("const locd_id **"), ffi.new("size_t *")
        assert lib.locd_scene_pairs(scene[0], data, count) == 0
        assert count[0] == 1 and [data[0][0], data[0][1]] == ids.tolist()
        stale = ffi.new("locd_id[]", [int(ids[0]) + 12345])
        assert lib.locd_scene_remove(scene[0], stale, 1) == locd.abi.CONSTANTS["LOCD_ERR_STALE_ID"]
        assert lib.locd_last_error_index() == 0
    finally:
        lib.locd_scene_destroy(scene[0])
        lib.locd_engine_destroy(engine[0])


def test_scene_calls_release_the_gil():
    """Another Python thread keeps running during add and update (conftest.py's detector, whose
    negative control in test_runtime.py shows it sees a call that holds the GIL)."""
    from conftest import progress_during, uniform_scene

    boxes = uniform_scene(300_000, seed=5)
    with locd.Scene(threads=1) as scene:
        ids = []
        duration, gap = progress_during(lambda: ids.append(scene.add(boxes)))
        assert gap < 0.5 * duration or duration < 0.02, "add: no progress for %.3f of %.3f s" % (gap, duration)
        duration, gap = progress_during(scene.update)
        assert duration > 0.02, "the update is too short to tell (%.3f s)" % duration
        assert gap < 0.5 * duration, "update: no Python progress for %.3f s of a %.3f s call" % (gap, duration)


def test_batches_longer_than_the_scene_name_their_first_bad_position():
    """A batch of more ids than the scene holds must name a stale id or an id twice: the error names the
    first bad position, as for any other bad batch (the library refuses such a batch before reading it),
    and the scene is unchanged."""
    scene = locd.Scene()
    a, b = scene.add([[0, 0, 0, 1, 1, 1], [2, 0, 0, 3, 1, 1]]).tolist()
    gone = int(scene.add([[5, 5, 5, 6, 6, 6]])[0])
    scene.remove([gone])
    before = scene.update().pairs.tolist(), scene.query_box([-9, -9, -9, 9, 9, 9]).tolist()
    box = [[0, 0, 0, 1, 1, 1]] * 3
    cases = [
        (lambda: scene.move([gone, a, b], box), locd.StaleIdError, 0),
        (lambda: scene.move([a, b, b], box), locd.DuplicateIdError, 2),
        (lambda: scene.move([a, b, gone], box), locd.StaleIdError, 2),
        (lambda: scene.move([a, a, b], [[0, 0, 0, 1, 1, 1], [0, 0, math.nan, 1, 1, 1], [0] * 6]),
         locd.DuplicateIdError, 1),  # the id before the box at a position
        (lambda: scene.move([a, b, a], [[0, 0, 0, 1, 1, 1], [1, 0, 0, 0, 1, 1], [0] * 6]), locd.InvalidBoxError, 1),
        (lambda: scene.remove([a, 12345, b]), locd.StaleIdError, 1),
        (lambda: scene.remove([b, a, b, a]), locd.DuplicateIdError, 2),
        (lambda: scene.set_filter([a, b, a], category=2), locd.DuplicateIdError, 2),
        (lambda: scene.set_user([gone, gone, gone], 7), locd.StaleIdError, 0),
    ]
    for call, exc, at in cases:
        with pytest.raises(exc) as e:
            call()
        assert type(e.value) is exc and e.value.index == at, (e.value, at)
        assert ("index %d" % at if exc is not locd.InvalidBoxError else "box %d" % at) in str(e.value)
    assert (scene.update().pairs.tolist(), scene.query_box([-9, -9, -9, 9, 9, 9]).tolist()) == before
    assert scene.user([a, b]).tolist() == [0, 0]
    empty = locd.Scene()
    with pytest.raises(locd.StaleIdError) as e:
        empty.remove([1])
    assert e.value.index == 0
