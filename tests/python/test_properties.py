"""Property tests: locd.find_pairs and locd.abi.find_pairs against a numpy brute force."""
import numpy as np
from hypothesis import given, note
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import locd
import locd.abi
from conftest import numpy_pairs, sorted_pairs


@st.composite
def grid_scenes(draw, dtype):
    """Boxes with corners on a coarse grid: touching faces, edges and corners,
    zero-size boxes and exact duplicates are frequent."""
    n = draw(st.integers(0, 48))
    lo = draw(arrays(np.int64, (n, 3), elements=st.integers(-3, 3)))
    ext = draw(arrays(np.int64, (n, 3), elements=st.integers(0, 2)))  # 0: flat or zero-size
    scale = draw(st.sampled_from([1.0, 0.25, 1e-3, 1e6]))
    offset = draw(st.sampled_from([0.0, 1.0, -1e5, 3e7]))
    boxes = (np.hstack([lo, lo + ext]) * scale + offset).astype(dtype)
    for dst, src in draw(st.lists(st.tuples(st.integers(0, max(n - 1, 0)), st.integers(0, max(n - 1, 0))),
                                  max_size=6 if n else 0)):
        boxes[dst] = boxes[src]  # duplicates
    return boxes


@st.composite
def float64_only_scenes(draw):
    """Coordinates that differ by less than float32 can tell apart: near 1.0,
    2**-40 offsets decide whether two boxes touch. Rounding to float32 would
    get these wrong, so they check the float64 path is float64 all the way."""
    n = draw(st.integers(2, 32))
    base = draw(arrays(np.int64, (n, 6), elements=st.integers(0, 2))).astype(np.float64)
    tiny = draw(arrays(np.int64, (n, 6), elements=st.integers(-2, 2))).astype(np.float64) * 2.0 ** -40
    boxes = base + tiny
    lo = np.minimum(boxes[:, :3], boxes[:, 3:])
    hi = np.maximum(boxes[:, :3], boxes[:, 3:])
    return np.hstack([lo, hi])


@st.composite
def wild_scenes(draw, dtype):
    """Arbitrary finite floats: huge and tiny boxes far from the origin in one scene."""
    n = draw(st.integers(0, 40))
    width = 32 if dtype == np.float32 else 64
    big, small = float(dtype(1e30)), float(dtype(1e-3))  # bounds exact at this width
    lo = draw(arrays(dtype, (n, 3), elements=st.floats(-big, big, width=width)))
    ext = draw(arrays(dtype, (n, 3), elements=st.one_of(st.just(0.0), st.floats(0, big, width=width),
                                                          st.floats(0, small, width=width))))
    hi = (lo.astype(np.float64) + ext).astype(dtype)
    return np.hstack([lo, np.maximum(lo, hi)]).astype(dtype)


def check_scene(boxes, threads):
    note("boxes=%r" % boxes.tolist())
    expected = numpy_pairs(boxes)
    got = locd.find_pairs(boxes, threads=threads)
    assert got.dtype == np.uint32 and got.ndim == 2 and got.shape[1] == 2
    if len(got):
        assert np.all(got[:, 0] < got[:, 1])
    np.testing.assert_array_equal(sorted_pairs(got), expected)
    # sort=True gives exactly the (i, j) order.
    np.testing.assert_array_equal(locd.find_pairs(boxes, threads=threads, sort=True), expected)
    # The cffi ABI module returns the identical array (same order).
    np.testing.assert_array_equal(locd.abi.find_pairs(boxes, threads=threads), got)
    # The order is deterministic: the same for every thread count.
    np.testing.assert_array_equal(locd.find_pairs(boxes, threads=1), got)


@given(grid_scenes(np.float32), st.sampled_from([1, 2, 3]))
def test_grid_scenes_f32(boxes, threads):
    check_scene(boxes, threads)


@given(grid_scenes(np.float64), st.sampled_from([1, 2, 3]))
def test_grid_scenes_f64(boxes, threads):
    check_scene(boxes, threads)


@given(float64_only_scenes(), st.sampled_from([1, 2]))
def test_float64_values_not_representable_in_float32(boxes, threads):
    check_scene(boxes, threads)


@given(wild_scenes(np.float32), st.sampled_from([1, 2]))
def test_wild_scenes_f32(boxes, threads):
    check_scene(boxes, threads)


@given(wild_scenes(np.float64), st.sampled_from([1, 2]))
def test_wild_scenes_f64(boxes, threads):
    check_scene(boxes, threads)


def test_float64_path_differs_from_float32_rounding():
    # Box 1 starts 2**-40 after box 0 ends: apart in float64, touching once
    # rounded to float32. Guards the property test above against a reference
    # that silently rounds.
    boxes = np.array([[0, 0, 0, 1, 1, 1], [1 + 2.0 ** -40, 0, 0, 2, 1, 1]], dtype=np.float64)
    assert len(locd.find_pairs(boxes)) == 0
    assert len(locd.abi.find_pairs(boxes)) == 0
    assert locd.find_pairs(boxes.astype(np.float32)).tolist() == [[0, 1]]


def test_touching_and_zero_size():
    boxes = np.array([
        [0, 0, 0, 1, 1, 1],
        [1, 0, 0, 2, 1, 1],  # shares a face with 0
        [2, 1, 1, 3, 2, 2],  # shares only a corner with 1
        [3, 2, 2, 3, 2, 2],  # zero-size, on 2's corner
        [3, 2, 2, 3, 2, 2],  # duplicate of 3
        [5, 5, 5, 6, 6, 6],  # alone
    ], dtype=np.float32)
    expected = [[0, 1], [1, 2], [2, 3], [2, 4], [3, 4]]
    assert locd.find_pairs(boxes, sort=True).tolist() == expected
    assert numpy_pairs(boxes).tolist() == expected


def test_larger_scene_both_dtypes_and_all_thread_counts():
    rng = np.random.default_rng(3)
    n = 3000
    lo = rng.random((n, 3))
    boxes = np.hstack([lo, lo + rng.random((n, 3)) * 0.05])
    expected = numpy_pairs(boxes)
    reference = locd.find_pairs(boxes, threads=1)
    np.testing.assert_array_equal(sorted_pairs(reference), expected)
    for threads in (2, 3, 4):
        np.testing.assert_array_equal(locd.find_pairs(boxes, threads=threads), reference)
    f32 = boxes.astype(np.float32)
    np.testing.assert_array_equal(sorted_pairs(locd.find_pairs(f32)), numpy_pairs(f32))
    np.testing.assert_array_equal(locd.brute_force(f32), numpy_pairs(f32))
    np.testing.assert_array_equal(locd.abi.brute_force(boxes), expected)


def test_lists_and_non_contiguous_inputs():
    boxes = [[0, 0, 0, 1, 1, 1], [0.5, 0.5, 0.5, 2, 2, 2], [3, 3, 3, 4, 4, 4]]
    assert locd.find_pairs(boxes).tolist() == [[0, 1]]
    assert locd.abi.find_pairs(boxes).tolist() == [[0, 1]]
    big = np.zeros((3, 12), dtype=np.float32)
    big[:, ::2] = np.array(boxes, dtype=np.float32)
    strided = big[:, ::2]  # not contiguous: converted, same answer
    assert locd.find_pairs(strided).tolist() == [[0, 1]]
    assert locd.find_pairs(np.asfortranarray(boxes, dtype=np.float64)).tolist() == [[0, 1]]
    assert locd.find_pairs(np.array(boxes, dtype=">f8")).tolist() == [[0, 1]]  # big-endian
    assert locd.abi.find_pairs(np.array(boxes, dtype=">f4")).tolist() == [[0, 1]]
