"""Integer inputs, index_dtype=, and the one error mapping (docs/python.md, "Errors").

Every public function is called with bad input and must raise the documented
type, through the pybind11 module and through the cffi module.
"""
import concurrent.futures

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import locd
import locd.abi
import locd.pipeline as lp
from conftest import numpy_pairs, sorted_pairs, uniform_scene

FINDERS = [pytest.param(locd.find_pairs, id="pybind11"), pytest.param(locd.abi.find_pairs, id="cffi"),
           pytest.param(lambda b, **kw: locd.Engine(threads=1).find_pairs(b, **kw), id="engine"),
           pytest.param(lambda b, **kw: locd.Engine(threads=1).submit(b, **kw).result(60), id="job"),
           pytest.param(lambda b, sort=True, **kw: locd.brute_force(b, **kw), id="brute-pybind11"),
           pytest.param(lambda b, sort=True, **kw: locd.abi.brute_force(b, **kw), id="brute-cffi")]


def lattice(n=5):
    """Unit cubes on an integer lattice: every face, edge and corner touches (exact ties)."""
    g = np.array([[x, y, z] for x in range(n) for y in range(n) for z in range(n)], dtype=np.int64)
    return np.hstack([g, g + 1])


# -- integer boxes ------------------------------------------------------------------
@pytest.mark.parametrize("find", FINDERS)
@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64])
def test_integer_boxes_are_accepted_like_lists(find, dtype):
    boxes = lattice().astype(dtype)
    expected = find(boxes.tolist(), sort=True)  # a list: converted to float64
    got = find(boxes, sort=True)
    np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(sorted_pairs(got), numpy_pairs(boxes.astype(np.float64)))
    assert len(got) > 0
    # A strided integer view converts too.
    np.testing.assert_array_equal(find(np.asfortranarray(boxes), sort=True), expected)


@given(st.integers(1, 300), st.sampled_from([np.int16, np.int64, np.uint32]), st.integers(0, 2 ** 32 - 1),
       st.sampled_from([0, 2 ** 40]))
def test_random_integer_boxes_match_the_reference(n, dtype, seed, offset):
    """Small integer boxes on a coarse grid (many exact ties), shifted far from 0 for int64/uint32."""
    rng = np.random.default_rng(seed)
    lo = rng.integers(0, 12, size=(n, 3))
    boxes = np.hstack([lo, lo + rng.integers(0, 4, size=(n, 3))])
    if np.dtype(dtype).itemsize >= 8:
        boxes = boxes + offset
    boxes = boxes.astype(dtype)
    expected = numpy_pairs(boxes.astype(np.float64))
    np.testing.assert_array_equal(locd.find_pairs(boxes, sort=True), expected)
    np.testing.assert_array_equal(locd.abi.find_pairs(boxes, sort=True, index_dtype=np.int64), expected)


@pytest.mark.parametrize("find", FINDERS)
def test_integers_beyond_2_53_are_refused_not_rounded(find):
    boxes = lattice(2)
    big = boxes.copy()
    big[0, 3] = 2 ** 53 + 1  # would round to 2**53 in float64
    with pytest.raises(ValueError, match="2\\*\\*53"):
        find(big)
    ok = boxes.copy()
    ok[0, 3] = 2 ** 53  # exact
    assert len(find(ok)) > 0


# -- index_dtype ----------------------------------------------------------------------
@pytest.mark.parametrize("find", FINDERS)
def test_index_dtype_int64(find):
    boxes = uniform_scene(2000, seed=3)
    narrow = find(boxes, sort=True)
    wide = find(boxes, sort=True, index_dtype=np.int64)
    assert narrow.dtype == np.uint32 and wide.dtype == np.int64
    np.testing.assert_array_equal(wide, narrow.astype(np.int64))
    # The reason it exists: i - j must not wrap around.
    assert (wide[:, 0] - wide[:, 1] < 0).all()
    assert (narrow[:, 0] - narrow[:, 1] > 0).all()  # uint32 wraps (documented)
    empty = find(np.zeros((0, 6)), index_dtype="int64")
    assert empty.shape == (0, 2) and empty.dtype == np.int64


@pytest.mark.parametrize("find", FINDERS)
@pytest.mark.parametrize("bad,exc", [(np.int32, ValueError), (np.float64, ValueError), ("nonsense", TypeError),
                                     (object(), TypeError)])
def test_bad_index_dtype(find, bad, exc):
    with pytest.raises(exc, match="index_dtype"):
        find(uniform_scene(10), index_dtype=bad)


def test_uint32_output_is_one_fresh_array():
    # The default output is one fresh uint32 array, owned by numpy (no view of a C buffer).
    out = locd.find_pairs(uniform_scene(1000))
    assert out.dtype == np.uint32 and out.flags.owndata and out.flags.c_contiguous


def test_pipeline_index_dtype_and_integer_triangles():
    if not lp.available():
        pytest.skip("library built without the narrow phase")
    verts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.int32)  # integers: converted
    tris = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]], dtype=np.int64)
    mesh = lp.Shape.mesh(verts, tris)
    assert mesh.kind == "mesh"
    with pytest.raises(ValueError, match="triangles"):
        lp.Shape.mesh(verts, tris - 1)  # -1 would wrap to 4294967295 in uint32
    with pytest.raises(TypeError, match="triangles"):
        lp.Shape.mesh(verts, tris.astype(np.float64))
    w = lp.World()
    w.add(mesh, (0, 0, 0, 0, 0, 0, 1))
    w.add(lp.Shape.sphere(0.3), (0.2, 0.2, 0.2, 0, 0, 0, 1))
    r = w.collide(index_dtype=np.int64)
    assert r.pairs.dtype == np.int64 and r.pairs.tolist() == [[0, 1]]
    assert w.collide().pairs.dtype == np.uint32


# -- one error mapping ------------------------------------------------------------------
def test_every_status_has_its_class():
    for name, value in locd.STATUS.items():
        if value >= 0:
            continue
        cls = locd.ERRORS.get(name, locd.Error)
        err = locd._errors.from_status(value, "text", "detail", -1)
        assert type(err) is cls and isinstance(err, locd.Error) and err.status == value and err.name == name
    assert set(locd.ERRORS) <= set(locd.STATUS)


@pytest.mark.parametrize("name,builtin", [
    ("ERR_INVALID_ARGUMENT", ValueError), ("ERR_NONFINITE", ValueError), ("ERR_SHAPE", ValueError),
    ("ERR_INVALID_HANDLE", ValueError), ("ERR_NO_MEMORY", MemoryError), ("ERR_UNSUPPORTED", NotImplementedError),
    ("ERR_CONNECTION", ConnectionError), ("ERR_IO", OSError), ("ERR_AUTH", PermissionError),
    ("ERR_TIMEOUT", concurrent.futures.TimeoutError), ("ERR_CANCELLED", concurrent.futures.CancelledError),
])
def test_subclasses_are_also_the_builtin(name, builtin):
    err = locd._errors.from_status(locd.STATUS[name], "t", "d", -1)
    assert isinstance(err, builtin) and isinstance(err, locd.Error)
    assert ("LOCD_%s" % name in str(err)) or isinstance(err, locd.InvalidBoxError)


@pytest.mark.parametrize("name", ["ERR_BUSY", "ERR_WORKER", "ERR_PROTOCOL", "ERR_INTERNAL"])
def test_runtime_failures_are_not_value_errors(name):
    err = locd._errors.from_status(locd.STATUS[name], "t", "d", -1)
    assert not isinstance(err, (ValueError, TypeError))


def test_errors_pickle():
    import pickle
    err = locd._errors.from_status(locd.STATUS["ERR_NONFINITE"], "t", "d", 7)
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is locd.InvalidBoxError and back.index == 7 and str(back) == str(err)


def _closed_engine():
    e = locd.Engine(threads=1)
    e.close()
    return e


BOX = np.zeros((1, 6))
# (what is called, the documented exception). Python checks -> builtin; C checks -> locd.Error subclass.
BAD_CALLS = [
    ("find_pairs: shape", lambda: locd.find_pairs(np.zeros((3, 5))), ValueError),
    ("find_pairs: dtype", lambda: locd.find_pairs(np.zeros((3, 6), np.float16)), TypeError),
    ("find_pairs: not numbers", lambda: locd.find_pairs([["a"] * 6]), ValueError),
    ("find_pairs: threads=0", lambda: locd.find_pairs(BOX, threads=0), ValueError),
    ("find_pairs: threads='2'", lambda: locd.find_pairs(BOX, threads="2"), TypeError),
    ("find_pairs: NaN", lambda: locd.find_pairs([[np.nan, 0, 0, 1, 1, 1]]), locd.InvalidBoxError),
    ("abi.find_pairs: shape", lambda: locd.abi.find_pairs(np.zeros((3, 5))), ValueError),
    ("abi.find_pairs: dtype", lambda: locd.abi.find_pairs(np.zeros((3, 6), np.float16)), TypeError),
    ("abi.find_pairs: threads=0", lambda: locd.abi.find_pairs(BOX, threads=0), ValueError),
    ("abi.find_pairs: threads=1.0", lambda: locd.abi.find_pairs(BOX, threads=1.0), TypeError),
    ("abi.find_pairs: inverted", lambda: locd.abi.find_pairs([[0, 0, 2, 1, 1, 1]]), locd.InvalidBoxError),
    ("brute_force: shape", lambda: locd.brute_force(np.zeros(6)), ValueError),
    ("abi.brute_force: dtype", lambda: locd.abi.brute_force(np.zeros((1, 6), bool)), TypeError),
    ("Engine: level", lambda: locd.Engine(level="gpu"), ValueError),
    ("Engine: level type", lambda: locd.Engine(level=1.0), TypeError),
    ("Engine: threads", lambda: locd.Engine(threads=-1), ValueError),
    ("Engine: cell_bias type", lambda: locd.Engine(cell_bias="2"), TypeError),
    ("Engine: max_depth by C", lambda: locd.Engine(max_depth=99), locd.InvalidArgumentError),
    ("Engine: secret type", lambda: locd.Engine(level="service", service="unix:/x", secret=b"x"), TypeError),
    ("Engine: unreachable service", lambda: locd.Engine(level="service", service="unix:/nonexistent/locd.sock"),
     locd.ConnectionFailedError),
    ("Engine.find_pairs: closed", lambda: _closed_engine().find_pairs(BOX), locd.ClosedError),
    ("Engine.submit: closed", lambda: _closed_engine().submit(BOX), locd.ClosedError),
    ("Engine.stats: closed", lambda: _closed_engine().stats, locd.ClosedError),
    ("Engine.submit: shape", lambda: locd.Engine(threads=1).submit(np.zeros((2, 2))), ValueError),
    ("Service: threads", lambda: locd.Service("unix:/tmp/x.sock", threads=0), ValueError),
    ("Service: listen type", lambda: locd.Service(5), TypeError),
    ("pipeline.Shape.sphere: radius", lambda: lp.Shape.sphere(-1.0), (locd.ShapeError, locd.UnsupportedError)),
    ("pipeline.collide_pair: type", lambda: lp.collide_pair(1, (0,) * 7, 2, (0,) * 7), TypeError),
    ("pipeline.World.add: type", lambda: lp.World().add("sphere", (0, 0, 0, 0, 0, 0, 1)), TypeError),
    ("pipeline.World.collide: swept", lambda: lp.World().collide(swept="maybe"), ValueError),
    ("pipeline.World.collide: routes", lambda: lp.World().collide(routes={("sphere", "cone"): "ccd"}), ValueError),
]


@pytest.mark.parametrize("call,exc", [pytest.param(c, e, id=name) for name, c, e in BAD_CALLS])
def test_public_functions_raise_the_documented_type(call, exc):
    with pytest.raises(exc) as info:
        call()
    if isinstance(info.value, locd.Error):
        assert info.value.status < 0 and info.value.name.startswith("ERR_")


def test_pipeline_without_narrow_phase_is_unsupported():
    if lp.available():
        pytest.skip("narrow phase present")
    with pytest.raises(locd.UnsupportedError):
        lp.Shape.sphere(1.0)


def test_busy_engine_is_busy_error():
    with locd.Engine(threads=1) as engine:
        job = engine.submit(uniform_scene(1_000_000, seed=6))
        try:
            engine.find_pairs(BOX)
        except locd.BusyError as e:
            assert e.status == locd.STATUS["ERR_BUSY"] and not isinstance(e, ValueError)
        job.result(60)
