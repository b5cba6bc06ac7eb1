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

import collections
import numbers
import os
import threading
from typing import Any, Optional

import numpy as np
from cffi import FFI

from ._cdef import CDEF, CONSTANTS, LIBRARY
from ._arrays import boxes as _as_boxes
from ._arrays import index_dtype as _index_dtype
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


def _pairs_array(pairs: Any, wide: bool = False) -> np.ndarray:
    m = int(lib.locd_pairs_count(pairs))
    if m == 0:
        return np.empty((0, 2), dtype=np.int64 if wide else np.uint32)
    data = lib.locd_pairs_data(pairs)
    view = np.frombuffer(ffi.buffer(data, 8 * m), dtype=np.uint32).reshape(m, 2)
    return view.astype(np.int64) if wide else view.copy()


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

    def close(self) -> None:
        """Stops the engine's threads and frees its buffers now."""
        ffi.release(self.engine)
        ffi.release(self.pairs)


_local = threading.local()
# Engines kept per Python thread by find_pairs (see locd._ENGINES_PER_THREAD).
_ENGINES_PER_THREAD = 2


def _engine_for(threads: Optional[int]) -> _Engine:
    engines = getattr(_local, "engines", None)
    if engines is None:
        engines = _local.engines = collections.OrderedDict()
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, numbers.Integral)):
        raise TypeError("threads must be an integer, got %s" % type(threads).__name__)
    if threads is not None and int(threads) < 1:
        raise ValueError("threads must be >= 1 (or None for one per core), got %d" % threads)
    key = 0 if threads is None else int(threads)
    engine = engines.pop(key, None)
    if engine is None:
        engine = _Engine(key)
    engines[key] = engine
    while len(engines) > _ENGINES_PER_THREAD:  # as locd.find_pairs: the least recently used goes
        engines.popitem(last=False)[1].close()
    return engine


def find_pairs(boxes: Any, other: Any = None, *, threads: Optional[int] = None, sort: bool = False,
               index_dtype: Any = np.uint32) -> np.ndarray:
    """Same contract as :func:`locd.find_pairs`, through cffi (the GIL is released during the call)."""
    arr = _as_boxes(boxes)
    wide = _index_dtype(index_dtype)
    engine = _engine_for(threads)
    flags = CONSTANTS["LOCD_FIND_SORTED"] if sort else 0
    n = arr.shape[0]
    if other is not None:  # two sets: a float32 set meeting a float64 one is widened
        brr = _as_boxes(other)
        if arr.dtype != brr.dtype:
            arr, brr = arr.astype(np.float64), brr.astype(np.float64)
        if arr.dtype == np.float64:
            status = lib.locd_engine_find_pairs_between_f64(engine.engine, ffi.from_buffer("double[]", arr), n,
                                                            ffi.from_buffer("double[]", brr), brr.shape[0], flags,
                                                            engine.pairs)
        else:
            status = lib.locd_engine_find_pairs_between_f32(engine.engine, ffi.from_buffer("float[]", arr), n,
                                                            ffi.from_buffer("float[]", brr), brr.shape[0], flags,
                                                            engine.pairs)
    elif arr.dtype == np.float64:
        status = lib.locd_engine_find_pairs_f64(engine.engine, ffi.from_buffer("double[]", arr), n, flags,
                                                engine.pairs)
    else:
        status = lib.locd_engine_find_pairs_f32(engine.engine, ffi.from_buffer("float[]", arr), n, flags,
                                                engine.pairs)
    if status != _OK:
        _raise(status)
    return _pairs_array(engine.pairs, wide)


def brute_force(boxes: Any, *, index_dtype: Any = np.uint32) -> np.ndarray:
    """The O(n^2) C reference through cffi: pairs sorted by (i, j)."""
    arr = _as_boxes(boxes)
    wide = _index_dtype(index_dtype)
    pairs = _new_pairs()
    if arr.dtype == np.float64:
        status = lib.locd_brute_force_f64(ffi.from_buffer("double[]", arr), arr.shape[0], pairs)
    else:
        status = lib.locd_brute_force_f32(ffi.from_buffer("float[]", arr), arr.shape[0], pairs)
    if status != _OK:
        _raise(status)
    return _pairs_array(pairs, wide)


def version() -> str:
    """Version string of the loaded C library."""
    return ffi.string(lib.locd_version_string()).decode()
