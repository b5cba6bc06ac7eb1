"""The filter pipeline from Python: shapes, a world, and its stages.

A thin layer over the C API of ``include/locd/pipeline.h`` through cffi (the
same ``ffi``/``lib`` as :mod:`locd.abi`); docs/pipeline.md describes the
semantics. Poses are ``(x, y, z, qx, qy, qz, qw)``, velocities
``(vx, vy, vz, wx, wy, wz)``; a contact normal points from a pair's first
object to its second.

    >>> from locd import pipeline as lp
    >>> floor, ball = lp.Shape.box(10, 10, 0.1), lp.Shape.sphere(0.25)
    >>> w = lp.World()
    >>> w.add(floor, (0, 0, -0.1, 0, 0, 0, 1))
    0
    >>> w.add(ball, (0, 0, 1, 0, 0, 0, 1), velocity=(0, 0, -300, 0, 0, 0))
    1
    >>> r = w.collide(swept="auto", dt=1 / 60, contacts=True)
    >>> r.pairs.tolist(), round(float(r.toi[0]), 6)
    ([[0, 1]], 0.15)

Without the narrow phase in the library (built without libccd/FCL), every
call raises :class:`locd.UnsupportedError` (status ``ERR_UNSUPPORTED``).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Dict, Optional, Sequence

import numpy as np

from . import _arrays
from .abi import CONSTANTS, _raise, ffi, lib

__all__ = ["Shape", "World", "Result", "collide_pair", "available"]

_OK = CONSTANTS["LOCD_OK"]
_KINDS = {"sphere": CONSTANTS["LOCD_SHAPE_SPHERE"], "box": CONSTANTS["LOCD_SHAPE_BOX"],
          "capsule": CONSTANTS["LOCD_SHAPE_CAPSULE"], "convex": CONSTANTS["LOCD_SHAPE_CONVEX"],
          "mesh": CONSTANTS["LOCD_SHAPE_MESH"]}
_KIND_NAMES = {v: k for k, v in _KINDS.items()}
_ROUTES = {"auto": CONSTANTS["LOCD_ROUTE_AUTO"], "box": CONSTANTS["LOCD_ROUTE_BOX"],
           "closed": CONSTANTS["LOCD_ROUTE_CLOSED"], "ccd": CONSTANTS["LOCD_ROUTE_CCD"],
           "fcl": CONSTANTS["LOCD_ROUTE_FCL"]}
_SWEPT = {"off": CONSTANTS["LOCD_SWEPT_OFF"], "on": CONSTANTS["LOCD_SWEPT_ON"],
          "auto": CONSTANTS["LOCD_SWEPT_AUTO"]}
_METHODS = {"epa": CONSTANTS["LOCD_CONTACT_EPA"], "mpr": CONSTANTS["LOCD_CONTACT_MPR"]}
_STAGES = ("broad", "shape", "swept", "contact")


def _choice(table: Dict[str, int], value: Any, what: str) -> int:
    if not isinstance(value, str):
        raise TypeError("%s must be a str, got %s" % (what, type(value).__name__))
    if value not in table:
        raise ValueError("%s must be one of %s, got %r" % (what, ", ".join(map(repr, table)), value))
    return table[value]


def _check(status: int) -> None:
    if status != _OK:
        _raise(status)


def _doubles(values: Any, n: int, what: str) -> Any:
    arr = np.ascontiguousarray(values, dtype=np.float64).reshape(-1)
    if arr.size != n:
        raise ValueError("%s must have %d numbers, got %d" % (what, n, arr.size))
    return arr


def _ptr(arr: np.ndarray, ctype: str = "double *") -> Any:
    return ffi.cast(ctype, arr.ctypes.data)


def available() -> bool:
    """True when the library was built with the narrow phase (libccd, FCL)."""
    out = ffi.new("locd_shape **")
    st = lib.locd_shape_sphere(1.0, out)
    if st == _OK:
        lib.locd_shape_destroy(out[0])
    return st == _OK


class Shape:
    """A shape (reference counted in C; worlds keep the shapes they hold)."""

    def __init__(self, handle: Any):
        self._h = ffi.gc(handle, lib.locd_shape_destroy)

    @staticmethod
    def _make(fn: Any, *args: Any) -> "Shape":
        out = ffi.new("locd_shape **")
        _check(fn(*args, out))
        return Shape(out[0])

    @classmethod
    def sphere(cls, radius: float) -> "Shape":
        return cls._make(lib.locd_shape_sphere, float(radius))

    @classmethod
    def box(cls, half_x: float, half_y: float, half_z: float) -> "Shape":
        return cls._make(lib.locd_shape_box, float(half_x), float(half_y), float(half_z))

    @classmethod
    def capsule(cls, radius: float, half_length: float) -> "Shape":
        return cls._make(lib.locd_shape_capsule, float(radius), float(half_length))

    @classmethod
    def convex(cls, points: Any) -> "Shape":
        p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        return cls._make(lib.locd_shape_convex, _ptr(p), p.shape[0])

    @classmethod
    def mesh(cls, vertices: Any, triangles: Any) -> "Shape":
        v = np.ascontiguousarray(vertices, dtype=np.float64).reshape(-1, 3)
        t = _arrays.indices(triangles, "triangles").reshape(-1, 3)
        return cls._make(lib.locd_shape_mesh, _ptr(v), v.shape[0], _ptr(t, "uint32_t *"), t.shape[0])

    @property
    def kind(self) -> str:
        return _KIND_NAMES.get(int(lib.locd_shape_kind(self._h)), "?")

    def aabb(self, pose: Sequence[float]) -> np.ndarray:
        """World box (minx, miny, minz, maxx, maxy, maxz) at pose."""
        p = _doubles(pose, 7, "pose")
        box = np.empty(6, dtype=np.float64)
        _check(lib.locd_shape_aabb(self._h, _ptr(p), _ptr(box)))
        return box


def collide_pair(a: Shape, pose_a: Sequence[float], b: Shape, pose_b: Sequence[float], *, route: str = "auto",
                 contact: bool = False, method: str = "epa"):
    """(hit, contact) for one pair; contact is (depth, normal[3], point[3]) or None."""
    if not isinstance(a, Shape) or not isinstance(b, Shape):
        raise TypeError("a and b must be locd.pipeline.Shape objects")
    pa, pb = _doubles(pose_a, 7, "pose_a"), _doubles(pose_b, 7, "pose_b")
    hit = ffi.new("int32_t *")
    c = np.zeros(7, dtype=np.float64)
    _check(lib.locd_shape_collide(a._h, _ptr(pa), b._h, _ptr(pb), _choice(_ROUTES, route, "route"), _choice(_METHODS, method, "method"), hit,
                                  _ptr(c) if contact else ffi.NULL))
    if not hit[0]:
        return False, None
    return True, ((float(c[0]), c[1:4].copy(), c[4:7].copy()) if contact else None)


@dataclass
class Result:
    """Colliding pairs of one :meth:`World.collide` call (arrays are copies)."""
    pairs: np.ndarray             # (m, 2) uint32 (or int64: index_dtype), i < j
    toi: np.ndarray               # (m,) time of impact as a fraction of dt (0 for discrete pairs)
    depth: Optional[np.ndarray]   # (m,) or None without contact data
    normal: Optional[np.ndarray]  # (m, 3) or None
    point: Optional[np.ndarray]   # (m, 3) or None
    stats: Dict[str, Any]         # per stage: calls, ms, pairs_in, pairs_out, tests; and tests by path


class World:
    """Shapes with poses and velocities, and the pipeline over them."""

    def __init__(self, threads: int = 0):
        cfg = ffi.new("locd_engine_config *")
        lib.locd_engine_config_init(cfg)
        cfg.threads = int(threads)
        out = ffi.new("locd_world **")
        _check(lib.locd_world_create(cfg, out))
        self._h = ffi.gc(out[0], lib.locd_world_destroy)
        c = ffi.new("locd_contacts **")
        _check(lib.locd_contacts_create(c))
        self._c = ffi.gc(c[0], lib.locd_contacts_destroy)

    def __len__(self) -> int:
        return int(lib.locd_world_count(self._h))

    def add(self, shape: Shape, pose: Sequence[float], velocity: Optional[Sequence[float]] = None) -> int:
        if not isinstance(shape, Shape):
            raise TypeError("shape must be a locd.pipeline.Shape, got %s" % type(shape).__name__)
        p = _doubles(pose, 7, "pose")
        v = _doubles(velocity, 6, "velocity") if velocity is not None else None
        idx = ffi.new("uint32_t *")
        _check(lib.locd_world_add(self._h, shape._h, _ptr(p), _ptr(v) if v is not None else ffi.NULL, idx))
        return int(idx[0])

    def set_poses(self, poses: Any) -> None:
        p = _doubles(poses, 7 * len(self), "poses")
        _check(lib.locd_world_set_poses(self._h, _ptr(p), len(self)))

    def set_velocities(self, velocities: Any) -> None:
        v = _doubles(velocities, 6 * len(self), "velocities")
        _check(lib.locd_world_set_velocities(self._h, _ptr(v), len(self)))

    def collide(self, *, shape_tests: bool = True, contacts: bool = False, swept: str = "off", dt: float = 0.0,
                swept_threshold: float = 0.25, method: str = "epa", routes: Optional[Dict[Any, str]] = None,
                sort: bool = False, index_dtype: Any = np.uint32) -> Result:
        """Runs the pipeline. routes maps (kind_a, kind_b) names to route names, e.g.
        ``{("sphere", "sphere"): "ccd", ("mesh", "convex"): "box"}``. ``index_dtype``: pairs as
        ``numpy.uint32`` (default) or ``numpy.int64``."""
        wide = _arrays.index_dtype(index_dtype)
        o = ffi.new("locd_pipeline_options *")
        lib.locd_pipeline_options_init(o)
        o.stages = ((CONSTANTS["LOCD_STAGE_SHAPE"] if shape_tests else 0)
                    | (CONSTANTS["LOCD_STAGE_CONTACT"] if contacts else 0))
        o.swept = _choice(_SWEPT, swept, "swept")
        o.dt = float(dt)
        o.swept_threshold = float(swept_threshold)
        o.contact_method = _choice(_METHODS, method, "method")
        o.find_flags = CONSTANTS["LOCD_FIND_SORTED"] if sort else 0
        for (ka, kb), r in (routes or {}).items():
            _check(lib.locd_pipeline_options_route(o, _choice(_KINDS, ka, "shape kind"), _choice(_KINDS, kb, "shape kind"),
                                                   _choice(_ROUTES, r, "route")))
        s = ffi.new("locd_pipeline_stats *")
        lib.locd_pipeline_stats_init(s)
        _check(lib.locd_world_collide(self._h, o, self._c, s))
        m = int(lib.locd_contacts_count(self._c))

        def arr(ptr: Any, width: int, dtype: Any) -> Optional[np.ndarray]:
            if ptr == ffi.NULL:
                return None
            a = np.frombuffer(ffi.buffer(ptr, m * width * np.dtype(dtype).itemsize), dtype=dtype).copy()
            return a.reshape(m, width) if width > 1 else a

        stats: Dict[str, Any] = {name: {f: getattr(getattr(s, name), f)
                                        for f in ("calls", "ms", "pairs_in", "pairs_out", "tests")}
                                 for name in _STAGES}
        stats.update(objects=s.objects, swept_objects=s.swept_objects, ms_total=s.ms_total,
                     tests={"closed": s.tests_closed, "ccd": s.tests_ccd, "fcl": s.tests_fcl})
        pairs = arr(lib.locd_contacts_pairs(self._c), 2, np.uint32) if m else np.empty((0, 2), dtype=np.uint32)
        return Result(pairs=_arrays.widen(pairs, wide),
                      toi=arr(lib.locd_contacts_toi(self._c), 1, np.float64) if m else np.empty(0),
                      depth=arr(lib.locd_contacts_depth(self._c), 1, np.float64),
                      normal=arr(lib.locd_contacts_normal(self._c), 3, np.float64),
                      point=arr(lib.locd_contacts_point(self._c), 3, np.float64),
                      stats=stats)
