"""The two-set query locd.find_pairs(a, b): every (i in a, j in b) overlapping, against a numpy brute force."""
import numpy as np
import pytest
from hypothesis import given, note
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import locd
import locd.abi


def numpy_between(a, b):
    """Independent reference: every (i, j) with a[i] and b[j] overlapping (closed boxes), sorted."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 6)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 6)
    overlap = np.ones((len(a), len(b)), dtype=bool)
    for axis in range(3):
        overlap &= a[:, None, axis] <= b[None, :, axis + 3]
        overlap &= b[None, :, axis] <= a[:, None, axis + 3]
    i, j = np.nonzero(overlap)  # row-major: already sorted by (i, j)
    return np.stack([i, j], axis=1).astype(np.uint32).reshape(-1, 2)


def sorted_rows(p):
    p = np.asarray(p).reshape(-1, 2)
    return p[np.lexsort((p[:, 1], p[:, 0]))]


@st.composite
def grid_boxes(draw, dtype, max_n=40):
    """Corners on a coarse grid: touching faces and corners, zero-size boxes, duplicates."""
    n = draw(st.integers(0, max_n))
    lo = draw(arrays(np.int64, (n, 3), elements=st.integers(-3, 3)))
    ext = draw(arrays(np.int64, (n, 3), elements=st.integers(0, 2)))
    scale = draw(st.sampled_from([1.0, 0.25, 1e6]))
    return (np.hstack([lo, lo + ext]) * scale).astype(dtype)


def check(a, b, threads):
    note("a=%r b=%r" % (a.tolist(), b.tolist()))
    expected = numpy_between(a, b)
    got = locd.find_pairs(a, b, threads=threads)
    assert got.dtype == np.uint32 and got.shape == (len(expected), 2)
    np.testing.assert_array_equal(sorted_rows(got), expected)
    np.testing.assert_array_equal(locd.find_pairs(a, b, threads=threads, sort=True), expected)
    # deterministic: the same order for every thread count
    np.testing.assert_array_equal(locd.find_pairs(a, b, threads=1), got)
    # the cffi ABI module returns the identical array
    np.testing.assert_array_equal(locd.abi.find_pairs(a, b, threads=threads), got)


@given(grid_boxes(np.float32), grid_boxes(np.float32), st.sampled_from([1, 2]))
def test_grid_sets_f32(a, b, threads):
    check(a, b, threads)


@given(grid_boxes(np.float64), grid_boxes(np.float64), st.sampled_from([1, 2]))
def test_grid_sets_f64(a, b, threads):
    check(a, b, threads)


@given(grid_boxes(np.float32), grid_boxes(np.float64))
def test_mixed_precision_is_computed_in_float64(a, b):
    check(a, b, 2)


def test_larger_sets_and_engine_method():
    rng = np.random.default_rng(5)
    lo_a, lo_b = rng.random((4000, 3)), rng.random((3000, 3))
    a = np.hstack([lo_a, lo_a + rng.random((4000, 3)) * 0.03])
    b = np.hstack([lo_b, lo_b + rng.random((3000, 3)) * 0.03])
    expected = numpy_between(a, b)
    assert len(expected) > 100
    with locd.Engine(threads=2) as engine:
        np.testing.assert_array_equal(engine.find_pairs(a, b, sort=True), expected)
        np.testing.assert_array_equal(sorted_rows(engine.find_pairs(a.astype(np.float32), b.astype(np.float32))),
                                      numpy_between(a.astype(np.float32), b.astype(np.float32)))


def test_same_set_twice_pairs_every_box_with_itself():
    boxes = np.array([[0, 0, 0, 1, 1, 1], [5, 5, 5, 6, 6, 6]], dtype=np.float32)
    assert locd.find_pairs(boxes, boxes, sort=True).tolist() == [[0, 0], [1, 1]]
    assert locd.find_pairs(boxes).tolist() == []


def test_empty_set():
    a = np.array([[0, 0, 0, 1, 1, 1]], dtype=np.float64)
    empty = np.zeros((0, 6))
    assert locd.find_pairs(a, empty).shape == (0, 2)
    assert locd.find_pairs(empty, a).shape == (0, 2)


def test_bad_box_of_b_is_reported_as_na_plus_j():
    a = np.zeros((3, 6), dtype=np.float32)
    b = np.zeros((5, 6), dtype=np.float32)
    b[4, 2] = np.nan
    with pytest.raises(locd.InvalidBoxError) as err:
        locd.find_pairs(a, b)
    assert err.value.index == 3 + 4
    with pytest.raises(locd.InvalidBoxError) as err:
        locd.find_pairs(b, a)
    assert err.value.index == 4


def test_shape_is_checked():
    with pytest.raises(ValueError):
        locd.find_pairs(np.zeros((2, 6)), np.zeros((2, 5)))
