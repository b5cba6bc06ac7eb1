"""Engine, stats, options and errors of the Python API (both modules where they overlap)."""
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import locd
import locd.abi
from conftest import numpy_pairs, sorted_pairs, uniform_scene

MODULES = [pytest.param(locd.find_pairs, id="pybind11"), pytest.param(locd.abi.find_pairs, id="cffi")]


# -- shapes and dtypes ----------------------------------------------------------
@pytest.mark.parametrize("find", MODULES)
@pytest.mark.parametrize("shape", [(6,), (4, 5), (4, 7), (2, 3, 6), (6, 4)])
def test_bad_shape_is_value_error(find, shape):
    with pytest.raises(ValueError, match=r"shape \(n, 6\)"):
        find(np.zeros(shape, dtype=np.float32))


@pytest.mark.parametrize("find", MODULES)
@pytest.mark.parametrize("dtype", [np.float16, np.complex64, np.bool_, np.dtype("U3"), np.dtype("M8[s]")])
def test_bad_dtype_is_type_error(find, dtype):
    with pytest.raises(TypeError, match="float32, float64 or integer"):
        find(np.zeros((3, 6), dtype=dtype))


@pytest.mark.parametrize("find", MODULES)
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_empty_and_single(find, dtype):
    for n in (0, 1):
        out = find(np.zeros((n, 6), dtype=dtype))
        assert out.shape == (0, 2) and out.dtype == np.uint32


# -- bad boxes --------------------------------------------------------------------
@pytest.mark.parametrize("find", MODULES)
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("bad,status", [
    (np.nan, "ERR_NONFINITE"), (np.inf, "ERR_NONFINITE"), (-np.inf, "ERR_NONFINITE"), ("inverted", "ERR_INVERTED_BOX"),
])
def test_bad_box_names_first_index(find, dtype, bad, status):
    boxes = uniform_scene(20, dtype=dtype)
    for index in (13, 17):  # the first one must be reported
        if bad == "inverted":
            boxes[index, 1], boxes[index, 4] = boxes[index, 4], boxes[index, 1]
        else:
            boxes[index, 5] = bad
    with pytest.raises(ValueError, match="box 13 ") as info:
        find(boxes)
    err = info.value
    assert isinstance(err, locd.InvalidBoxError) and isinstance(err, locd.Error)
    assert err.index == 13
    assert err.status == locd.STATUS[status] and err.name == status


def test_bad_box_in_engine_leaves_previous_result_usable():
    with locd.Engine(threads=2) as engine:
        good = uniform_scene(300)
        first = engine.find_pairs(good)
        bad = good.copy()
        bad[5, 0] = np.nan
        with pytest.raises(locd.InvalidBoxError):
            engine.find_pairs(bad)
        np.testing.assert_array_equal(engine.find_pairs(good), first)


# -- engine -------------------------------------------------------------------------
def test_engine_context_manager_and_stats():
    boxes = uniform_scene(2000, seed=5)
    with locd.Engine(threads=1) as engine:
        assert engine.level == "inprocess" and engine.threads == 1
        pairs = engine.find_pairs(boxes)
        s = engine.stats
        assert isinstance(s, locd.Stats)
        assert s.objects == len(boxes) and s.pairs == len(pairs) and s.threads == 1
        assert s.entries >= len(boxes) and s.candidates >= s.pairs >= 0 and s.exact_tests <= s.candidates
        assert s.ms_total > 0
        stages = s.ms_bounds + s.ms_encode + s.ms_sort + s.ms_merge + s.ms_sweep + s.ms_order
        assert all(v >= 0 for v in (s.ms_bounds, s.ms_encode, s.ms_sort, s.ms_merge, s.ms_sweep, s.ms_order))
        assert stages <= s.ms_total * 1.05 + 0.05
        assert s.as_dict()["pairs"] == len(pairs)
        engine.find_pairs(boxes, sort=True)
        assert engine.stats.pairs == len(pairs)
    assert engine.closed
    with pytest.raises(ValueError, match="closed"):
        engine.find_pairs(boxes)
    engine.close()  # idempotent


@given(st.booleans(), st.integers(0, 8), st.sampled_from([0, 1, 2, 5, 21]), st.integers(1, 3))
def test_engine_options_do_not_change_the_result(cubes, cell_bias, max_depth, threads):
    rng = np.random.default_rng(cell_bias * 100 + max_depth)
    lo = rng.random((300, 3)) * 4
    boxes = np.hstack([lo, lo + rng.random((300, 3)) ** 3]).astype(np.float32)
    with locd.Engine(threads=threads, cubes=cubes, cell_bias=cell_bias, max_depth=max_depth) as engine:
        np.testing.assert_array_equal(sorted_pairs(engine.find_pairs(boxes)), numpy_pairs(boxes))


@pytest.mark.parametrize("kwargs,exc", [
    (dict(level="gpu"), ValueError),
    (dict(level=4), ValueError),
    (dict(threads=0), ValueError),
    (dict(workers=2), ValueError),  # workers= is for level='workers'
    (dict(level="service"), ValueError),  # needs service=
    (dict(cell_bias=9), ValueError),
    (dict(max_depth=22), locd.InvalidArgumentError),  # checked by the C library: a ValueError too
    (dict(threads=1.5), TypeError),
    (dict(service=5, level="service"), TypeError),
])
def test_engine_bad_options(kwargs, exc):
    with pytest.raises(exc):
        locd.Engine(**kwargs)


def test_c_side_argument_errors_are_locd_error_and_value_error():
    with pytest.raises(locd.Error) as info:
        locd.Engine(max_depth=22)
    assert info.value.status == locd.STATUS["ERR_INVALID_ARGUMENT"]
    assert "LOCD_ERR_INVALID_ARGUMENT" in str(info.value) and "max_depth" in str(info.value)
    assert isinstance(info.value, ValueError) and type(info.value) is locd.InvalidArgumentError


def test_engine_shared_by_threads_serializes_calls():
    import threading
    boxes = uniform_scene(20000, seed=2)
    with locd.Engine(threads=1) as engine:
        expected = engine.find_pairs(boxes)
        results, errors = [], []

        def work():
            try:
                for _ in range(3):
                    results.append(engine.find_pairs(boxes))
            except Exception as e:  # pragma: no cover - reported below
                errors.append(e)

        workers = [threading.Thread(target=work) for _ in range(3)]
        for t in workers:
            t.start()
        for t in workers:
            t.join()
        assert not errors
        assert len(results) == 9
        for r in results:
            np.testing.assert_array_equal(r, expected)


def test_find_pairs_from_many_threads():
    from concurrent.futures import ThreadPoolExecutor
    scenes = [uniform_scene(3000, seed=s) for s in range(8)]
    with ThreadPoolExecutor(4) as pool:
        results = list(pool.map(lambda b: locd.find_pairs(b, threads=1), scenes))
    for b, r in zip(scenes, results):
        np.testing.assert_array_equal(sorted_pairs(r), numpy_pairs(b))


def test_help_is_useful():
    import pydoc
    text = pydoc.render_doc(locd)
    for word in ("find_pairs", "Engine", "submit", "InvalidBoxError", "zero-copy", "GIL"):
        assert word in text
