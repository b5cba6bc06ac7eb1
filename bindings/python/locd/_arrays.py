"""Argument conversion shared by the pybind11 and the cffi modules (one set of rules).

- Boxes: float32/float64 arrays are used as they are (read in place when
  native-endian, aligned and C-contiguous). Integer arrays of any width, and
  lists, are converted to float64, which holds every integer up to 2**53
  exactly; larger integers raise ``ValueError`` rather than being rounded
  (rounding could join or split touching boxes). Other dtypes raise
  ``TypeError``; a shape other than (n, 6) raises ``ValueError``.
- Pairs: ``index_dtype`` is ``numpy.uint32`` (the library's own indices) or
  ``numpy.int64`` (so that subtracting columns cannot wrap).
- Integer inputs (indices, ids): any integer dtype, range-checked.
"""
from __future__ import annotations

from typing import Any

import numpy as np

_EXACT = 2 ** 53
_UINT32 = np.dtype(np.uint32)
_INT64 = np.dtype(np.int64)


def _shape(arr: np.ndarray) -> str:
    return str(tuple(arr.shape))


def boxes(obj: Any) -> np.ndarray:
    """An (n, 6) native, aligned, C-contiguous float32 or float64 array for the C library."""
    arr = obj if isinstance(obj, np.ndarray) else np.asarray(obj)
    kind = arr.dtype.kind
    if kind in "iu":
        if arr.size and (int(arr.max()) > _EXACT or int(arr.min()) < -_EXACT):
            raise ValueError("boxes: integer coordinates beyond +-2**53 cannot be converted to float64 exactly")
        arr = arr.astype(np.float64)
    elif not isinstance(obj, np.ndarray) and kind != "f":
        arr = np.asarray(obj, dtype=np.float64)  # lists of bools, Decimals, ...: as float64
    elif kind != "f" or arr.dtype.itemsize not in (4, 8):
        raise TypeError("boxes must be a float32, float64 or integer array, got dtype %s "
                        "(convert it with .astype(numpy.float64))" % arr.dtype)
    if arr.ndim != 2 or arr.shape[1] != 6:
        raise ValueError("boxes must have shape (n, 6): minx miny minz maxx maxy maxz per row; got shape %s"
                         % _shape(arr))
    native = np.dtype(np.float64 if arr.dtype.itemsize == 8 else np.float32)
    return np.require(arr, native, "CA")  # no copy when it already is


def index_dtype(dtype: Any) -> bool:
    """True for int64 output, False for uint32 (the default); anything else raises."""
    try:
        dt = np.dtype(dtype)
    except TypeError as e:
        raise TypeError("index_dtype must be numpy.uint32 or numpy.int64, got %r" % (dtype,)) from e
    if dt == _UINT32:
        return False
    if dt == _INT64:
        return True
    raise ValueError("index_dtype must be numpy.uint32 or numpy.int64, got %s" % dt)


def widen(pairs: np.ndarray, wide: bool) -> np.ndarray:
    """The (m, 2) uint32 pairs as they are, or as int64."""
    return pairs.astype(np.int64) if wide else pairs


def indices(obj: Any, what: str, lo: int = 0, hi: int = 2 ** 32 - 1) -> np.ndarray:
    """A C-contiguous uint32 array from integers of any dtype (or a list), each in [lo, hi]."""
    arr = obj if isinstance(obj, np.ndarray) else np.asarray(obj)
    if arr.size == 0:
        return np.zeros(arr.shape, dtype=np.uint32)
    if arr.dtype.kind not in "iu":
        raise TypeError("%s must be integers, got dtype %s" % (what, arr.dtype))
    if int(arr.min()) < lo or int(arr.max()) > hi:
        raise ValueError("%s must be in [%d, %d]" % (what, lo, hi))
    return np.ascontiguousarray(arr, dtype=np.uint32)
