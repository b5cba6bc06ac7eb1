"""locd through cffi's ABI mode: no compiler, no extension module.

This module opens the shared libraries installed beside it with ``ffi.dlopen``
(liblocd_narrow, whose dependency liblocd comes with it: one handle finds
the functions of both)
and declares its functions from the public header (the declarations in
``locd._cdef`` are generated from include/locd/locd.h when the package is
built). It is the path any FFI takes (C#, Julia, LuaJIT...), kept here as the
proof that the C ABI alone is enough. :func:`find_pairs` returns exactly what
:func:`locd.find_pairs` returns.

``ffi`` and ``lib`` are exported for direct use of the whole C API.
"""
from __future__ import annotations

import os
import threading
from typing import Any, Optional

import numpy as np
from cffi import FFI

from ._cdef import CDEF, CONSTANTS, LIBRARY
from ._errors import from_status

__all__ = ["find_pairs", "brute_force", "version", "ffi", "lib", "CONSTANTS", "LIBRARY_PATH"]

ffi = FFI()
ffi.cdef(CDEF)
#: Full path of the shared library this module uses.
LIBRARY_PATH: str = os.path.join(os.path.dirname(os.path.abspath(__file__)), LIBRARY)
lib: Any = ffi.dlopen(LIBRARY_PATH)

_OK = CONSTANTS["LOCD_OK"]


def _raise(status: int) -> None:
    # Read the thread-local detail before any other locd call on this thread.
    detail = ffi.string(lib.locd_last_error()).decode("utf-8", "replace")
    index = int(lib.locd_last_error_index())
    text = ffi.string(lib.locd_status_string(status)).decode("utf-8", "replace")
    raise from_status(status, text, detail, index)


def _as_boxes(boxes: Any) -> np.ndarray:
    """The same checks and conversions as the pybind11 module."""
    arr = boxes if isinstance(boxes, np.ndarray) else np.asarray(boxes, dtype=np.float64)
    if arr.dtype.kind != "f" or arr.dtype.itemsize not in (4, 8):
        raise TypeError("boxes must be a float32 or float64 array, got dtype %s "
                        "(convert it with .astype(numpy.float64))" % arr.dtype)
    if arr.ndim != 2 or arr.shape[1] != 6:
        raise ValueError("boxes must have shape (n, 6): minx miny minz maxx maxy maxz per row; got shape %s"
                         % (arr.shape,))
    native = np.dtype(np.float64 if arr.dtype.itemsize == 8 else np.float32)
    # Zero-copy when already native, aligned and C-contiguous.
    return np.require(arr, native, "CA")


def _pairs_array(pairs: Any) -> np.ndarray:
    m = int(lib.locd_pairs_count(pairs))
    if m == 0:
        return np.empty((0, 2), dtype=np.uint32)
    data = lib.locd_pairs_data(pairs)
    return np.frombuffer(ffi.buffer(data, 8 * m), dtype=np.uint32).reshape(m, 2).copy()


def _new_pairs() -> Any:
    out = ffi.new("locd_pairs **")
    status = lib.locd_pairs_create(ffi.NULL, out)
    if status != _OK:
        _raise(status)
    return ffi.gc(out[0], lib.locd_pairs_destroy)


class _Engine:
    """A level-1 engine and a pairs buffer (one per Python thread and thread count)."""

    def __init__(self, threads: int) -> None:
        cfg = ffi.new("locd_engine_config *")
        lib.locd_engine_config_init(cfg)
        cfg.threads = threads
        out = ffi.new("locd_engine **")
        status = lib.locd_engine_create(cfg, out)
        if status != _OK:
            _raise(status)
        self.engine = ffi.gc(out[0], lib.locd_engine_destroy)
        self.pairs = _new_pairs()


_local = threading.local()


def _engine_for(threads: Optional[int]) -> _Engine:
    engines = getattr(_local, "engines", None)
    if engines is None:
        engines = _local.engines = {}
    if threads is not None and int(threads) < 1:
        raise ValueError("threads must be >= 1 (or None for one per core), got %d" % threads)
    key = 0 if threads is None else int(threads)
    engine = engines.get(key)
    if engine is None:
        engine = engines[key] = _Engine(key)
    return engine


def find_pairs(boxes: Any, *, threads: Optional[int] = None, sort: bool = False) -> np.ndarray:
    """Same contract as :func:`locd.find_pairs`, through cffi (the GIL is released during the call)."""
    arr = _as_boxes(boxes)
    engine = _engine_for(threads)
    flags = CONSTANTS["LOCD_FIND_SORTED"] if sort else 0
    n = arr.shape[0]
    if arr.dtype == np.float64:
        status = lib.locd_engine_find_pairs_f64(engine.engine, ffi.from_buffer("double[]", arr), n, flags,
                                                engine.pairs)
    else:
        status = lib.locd_engine_find_pairs_f32(engine.engine, ffi.from_buffer("float[]", arr), n, flags,
                                                engine.pairs)
    if status != _OK:
        _raise(status)
    return _pairs_array(engine.pairs)


def brute_force(boxes: Any) -> np.ndarray:
    """The O(n^2) C reference through cffi: pairs sorted by (i, j)."""
    arr = _as_boxes(boxes)
    pairs = _new_pairs()
    if arr.dtype == np.float64:
        status = lib.locd_brute_force_f64(ffi.from_buffer("double[]", arr), arr.shape[0], pairs)
    else:
        status = lib.locd_brute_force_f32(ffi.from_buffer("float[]", arr), arr.shape[0], pairs)
    if status != _OK:
        _raise(status)
    return _pairs_array(pairs)


def version() -> str:
    """Version string of the loaded C library."""
    return ffi.string(lib.locd_version_string()).decode()
