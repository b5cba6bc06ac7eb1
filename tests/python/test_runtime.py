"""Zero-copy input and GIL release, each checked with a negative control so the check can fail."""
import tracemalloc

import numpy as np
import pytest

import locd
import locd.abi
from conftest import progress_during, uniform_scene

MODULES = [pytest.param(locd.find_pairs, id="pybind11"), pytest.param(locd.abi.find_pairs, id="cffi")]


# -- zero-copy ----------------------------------------------------------------------
def sparse_scene(n, dtype):
    """n tiny boxes far apart: the result (and its array) is nearly empty."""
    rng = np.random.default_rng(11)
    lo = rng.random((n, 3)) * 1000.0
    return np.ascontiguousarray(np.hstack([lo, lo + 1e-4]).astype(dtype))


def traced_peak(fn):
    """Peak of memory allocated through Python/numpy during fn() (numpy reports
    its array buffers to tracemalloc; the C library's own malloc is not counted)."""
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        base, _ = tracemalloc.get_traced_memory()
        fn()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return peak - base


@pytest.mark.parametrize("find", MODULES)
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_contiguous_input_is_not_copied(find, dtype):
    boxes = sparse_scene(200_000, dtype)  # 4.8 MB (float32) / 9.6 MB (float64)
    find(boxes)  # warm up the per-thread engine and its buffers
    peak = traced_peak(lambda: find(boxes))
    assert peak < boxes.nbytes / 4, "a copy of the input was made (peak %d bytes)" % peak


@pytest.mark.parametrize("find", MODULES)
def test_negative_control_a_converted_input_is_seen(find):
    # Fortran order must be converted to C order: the measurement must show it.
    boxes = np.asfortranarray(sparse_scene(200_000, np.float32))
    find(boxes)
    peak = traced_peak(lambda: find(boxes))
    assert peak >= boxes.nbytes


def test_c_receives_the_numpy_buffer_itself():
    # The address handed to C (same conversion code as find_pairs).
    for dtype in (np.float32, np.float64):
        boxes = uniform_scene(100, dtype=dtype)
        assert locd._core._buffer_address(boxes) == boxes.ctypes.data
        view = boxes[10:20]  # a C-contiguous view: still in place
        assert locd._core._buffer_address(view) == view.ctypes.data
    fortran = np.asfortranarray(uniform_scene(100))
    assert locd._core._buffer_address(fortran) != fortran.ctypes.data
    swapped = uniform_scene(100).astype(">f4")
    assert locd._core._buffer_address(swapped) != swapped.ctypes.data


# -- GIL ------------------------------------------------------------------------------
@pytest.mark.parametrize("find", MODULES)
def test_gil_is_released_during_the_call(find):
    # 2e6 boxes: one thread's find of 1e6 took 49 ms on an AMD EPYC (AVX-512), under the 50 ms below
    boxes = uniform_scene(2_000_000, seed=3)
    find(boxes, threads=1)  # warm up
    duration, gap = progress_during(lambda: find(boxes, threads=1))
    assert duration > 0.05, "the call is too short to tell (%.3f s)" % duration
    # Released: the other thread runs all along (gaps of a few switch intervals).
    assert gap < 0.5 * duration, "no Python progress for %.3f s of a %.3f s call" % (gap, duration)


def test_gil_negative_control():
    # sorted() of a big float list holds the GIL throughout: the measurement
    # must see the other thread stall.
    data = np.random.default_rng(1).random(1_000_000).tolist()
    duration, gap = progress_during(lambda: sorted(data))
    assert duration > 0.05
    assert gap > 0.5 * duration


def test_engine_and_job_calls_release_the_gil():
    boxes = uniform_scene(1_000_000, seed=4)
    with locd.Engine(threads=1) as engine:
        engine.find_pairs(boxes)
        duration, gap = progress_during(lambda: engine.find_pairs(boxes))
        assert gap < 0.5 * duration
