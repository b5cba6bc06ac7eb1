"""locd.Scene: a persistent broad phase for a world that changes a little each frame.

Objects live in the scene under stable uint64 ids (never 0, never reused).
They are added, moved, removed and re-filtered in batches; :meth:`Scene.update`
gives the full set of overlapping pairs and the pairs created and lost since
the previous update. Queries (box, point, sphere, ray segment, swept box; one at
a time or in batches) see the scene as it is now. The C side is include/locd/scene.h; docs/scene.md explains the design.

>>> import numpy as np, locd
>>> scene = locd.Scene()
>>> ids = scene.add(np.array([[0, 0, 0, 1, 1, 1], [1, 0, 0, 2, 1, 1]], np.float32))
>>> r = scene.update()
>>> r.pairs.tolist() == [[int(ids[0]), int(ids[1])]]
True

A pair (a, b) is reported iff the boxes overlap (closed intervals),
``(category_a & mask_b) != 0 and (category_b & mask_a) != 0``, not
``group_a == group_b != 0``, and not both objects are static. Pair lists are
(m, 2) uint64 arrays of ids, first < second in each row, rows sorted.

Errors name the position in the batch: a stale (removed or never issued) id
raises :class:`StaleIdError` (a ``KeyError``), an id twice in one batch
:class:`DuplicateIdError` (a ``ValueError``), a NaN/infinite box or min > max
:class:`locd.InvalidBoxError` (a ``ValueError``); each has ``.index``. A batch
that fails changes nothing. A bad query (a NaN or infinite coordinate or
direction, min > max, a negative or NaN ``max_t`` or radius) raises
:class:`InvalidQueryError` (a subclass of ``InvalidBoxError``) whose ``.index``
names the query in its batch (0 for a single query).
"""
from __future__ import annotations

import contextlib
import dataclasses
import operator
from typing import Any, Dict, Iterator, Optional, Tuple

import numpy as np

from . import _core, _errors
from ._errors import STATUS as _STATUS
from ._errors import DuplicateIdError, InvalidArgumentError, InvalidBoxError, InvalidQueryError, StaleIdError

__all__ = ["Scene", "SceneUpdate", "StaleIdError", "DuplicateIdError", "InvalidQueryError", "ALL"]

#: A mask with every category bit set (the default mask).
ALL: int = (1 << 64) - 1

_U64_MAX = ALL


@dataclasses.dataclass(frozen=True)
class SceneUpdate:
    """What :meth:`Scene.update` found: three (m, 2) uint64 arrays of ids, rows sorted.

    ``pairs``: every pair now; ``created``: pairs now that were not at the
    previous update (all of them at the first); ``lost``: pairs at the previous
    update that are not now (those of removed objects included).
    """

    pairs: np.ndarray
    created: np.ndarray
    lost: np.ndarray


def _u64_scalar(name: str, value: Any) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError("%s must be an integer or an array of integers, got %r" % (name, value))
    v = int(value)
    if not 0 <= v <= _U64_MAX:
        raise ValueError("%s = %d is outside 0 .. 2**64-1" % (name, v))
    return v


def _u64_array(name: str, values: Any, n: Optional[int] = None) -> np.ndarray:
    """Any integer array (or sequence of Python ints) as a C-contiguous (n,) uint64 array.

    Negative or too large values raise ValueError naming the index; other
    dtypes raise TypeError. Zero-copy for a C-contiguous native uint64 array."""
    arr = values if isinstance(values, np.ndarray) else np.asarray(values)
    if not isinstance(values, np.ndarray) and arr.dtype.kind not in "iub":
        # A list mixing ints below and above 2**63 becomes float64 in numpy:
        # take the Python ints one by one instead (floats are refused there).
        arr = np.empty(len(values), dtype=object) if np.ndim(values) == 1 else arr
        if arr.dtype == object and arr.ndim == 1:
            arr[:] = list(values)
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1:
        raise ValueError("%s must be one-dimensional, got shape %s" % (name, arr.shape))
    if n is not None and len(arr) != n:
        raise ValueError("%s has %d values for a batch of %d" % (name, len(arr), n))
    kind = arr.dtype.kind
    if kind == "u":
        return np.ascontiguousarray(arr, dtype=np.uint64)
    if kind == "i":
        neg = np.flatnonzero(arr < 0)
        if len(neg):
            raise ValueError("%s[%d] = %d is negative" % (name, neg[0], arr[neg[0]]))
        return np.ascontiguousarray(arr, dtype=np.uint64)
    if kind == "O":  # Python ints past int64
        out = np.empty(len(arr), dtype=np.uint64)
        for k, v in enumerate(arr):
            out[k] = _u64_scalar("%s[%d]" % (name, k), v)
        return out
    raise TypeError("%s must hold integers, got dtype %s" % (name, arr.dtype))


def _attribute(name: str, value: Any, n: int) -> Tuple[int, Optional[np.ndarray]]:
    """(scalar, None) for a scalar, (0, array) for n values."""
    if isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)):
        return _u64_scalar(name, value), None
    return 0, _u64_array(name, value, n)


class Scene:
    """A persistent scene of boxes with stable ids (see the module docstring).

    Args:
        threads: threads of the scene's engine (None = one per core).
        dtype: ``np.float32`` or ``np.float64``: the precision of the scene's
            coordinates. Boxes are converted to it (float32 input of a
            float32 scene is read in place; float64 input of a float32 scene
            is rounded to nearest float32, and a finite value beyond
            float32's range raises InvalidBoxError). Query shapes are read
            as float64 whatever the dtype.
        capacity: objects to reserve room for (0 = grow as needed).

    One thread at a time may change a scene; Python threads sharing one take
    turns (the GIL is released while the C library works). Use it as a
    context manager or call :meth:`close` to free it at once.
    """

    def __init__(self, threads: Optional[int] = None, dtype: Any = np.float32, *, capacity: int = 0) -> None:
        dt = np.dtype(dtype)
        if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
            raise TypeError("dtype must be numpy.float32 or numpy.float64, got %s" % dt)
        if threads is not None:
            threads = operator.index(threads)
            if not 1 <= threads <= 0xFFFFFFFF:
                raise ValueError("threads must be 1 .. 2**32-1 (or None for one per core), got %d" % threads)
        capacity = operator.index(capacity)
        if not 0 <= capacity <= _U64_MAX:
            raise ValueError("capacity must be 0 .. 2**64-1, got %d" % capacity)
        self._dtype = dt
        self._core = _core.Scene(threads or 0, dt == np.dtype(np.float64), capacity)

    # -- lifetime -------------------------------------------------------------
    def close(self) -> None:
        """Frees the scene and its engine. Later calls raise ValueError."""
        core = getattr(self, "_core", None)
        if core is not None:
            core.close()

    def __enter__(self) -> "Scene":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    @property
    def closed(self) -> bool:
        return self._core.closed

    @property
    def dtype(self) -> np.dtype:
        """The scene's coordinate precision (float32 or float64)."""
        return self._dtype

    @property
    def threads(self) -> int:
        """Threads of the scene's engine."""
        return self._core.threads

    def __len__(self) -> int:
        """Objects in the scene now (static ones included)."""
        return self._core.count()

    def __repr__(self) -> str:
        if self._core.closed:
            return "<locd.Scene closed>"
        return "<locd.Scene %d objects %s threads=%d>" % (len(self), self._dtype.name, self.threads)

    # -- conversions ----------------------------------------------------------
    def _boxes(self, boxes: Any, n: Optional[int] = None) -> np.ndarray:
        arr = boxes if isinstance(boxes, np.ndarray) else np.asarray(boxes, dtype=np.float64)
        if arr.dtype.kind != "f" or arr.dtype.itemsize not in (4, 8):
            raise TypeError("boxes must be a float32 or float64 array, got dtype %s "
                            "(convert it with .astype(numpy.float64))" % arr.dtype)
        if arr.ndim == 1 and arr.shape[0] == 0:
            arr = arr.reshape(0, 6)
        if arr.ndim != 2 or arr.shape[1] != 6:
            raise ValueError("boxes must have shape (n, 6): minx miny minz maxx maxy maxz per row; got shape %s"
                             % (arr.shape,))
        if n is not None and arr.shape[0] != n:
            raise ValueError("boxes has %d rows for %d ids" % (arr.shape[0], n))
        with np.errstate(over="ignore"):
            out = np.ascontiguousarray(arr, dtype=self._dtype)
        if out.dtype != arr.dtype:  # float64 rounded to float32: a finite value may overflow to inf
            over = np.flatnonzero((np.isinf(out) & np.isfinite(arr)).any(axis=1))
            if len(over):
                k = int(over[0])
                value = arr[k][np.isinf(out[k]) & np.isfinite(arr[k])][0]
                raise InvalidBoxError(_STATUS["ERR_NONFINITE"],
                                      "box %d: %r is beyond the range of float32, the scene's dtype "
                                      "(use dtype=numpy.float64)" % (k, float(value)), "", k)
        return out

    # -- changes, in batches --------------------------------------------------
    def add(self, boxes: Any, *, static: bool = False, category: Any = 1, mask: Any = ALL, group: Any = 0,
            user: Any = None) -> np.ndarray:
        """Adds the (n, 6) boxes; returns their n new ids (uint64).

        ``category``, ``mask``, ``group`` and ``user`` are each a scalar for
        the whole batch or n values (any integer dtype; Python ints up to
        2**64-1). ``static=True`` makes the whole batch static: static objects
        never pair with each other (level geometry)."""
        b = self._boxes(boxes)
        n = b.shape[0]
        cat, cats = _attribute("category", category, n)
        msk, msks = _attribute("mask", mask, n)
        grp, grps = _attribute("group", group, n)
        usr, usrs = _attribute("user", 0 if user is None else user, n)
        return self._core.add(b, bool(static), cat, msk, grp, usr, cats, msks, grps, usrs)

    def move(self, ids: Any, boxes: Any) -> None:
        """Gives object ids[k] the box boxes[k]."""
        i = _u64_array("ids", ids)
        b = self._boxes(boxes, len(i))
        with self._first_bad_position(i, b):
            self._core.move(i, b)

    def remove(self, ids: Any) -> None:
        """Removes the objects; their pairs are lost pairs at the next update."""
        i = _u64_array("ids", ids)
        with self._first_bad_position(i):
            self._core.remove(i)

    def set_filter(self, ids: Any, *, category: Any = None, mask: Any = None, group: Any = None) -> None:
        """Sets category, mask and/or group (None keeps it) of the objects: scalars or n values."""
        i = _u64_array("ids", ids)
        n = len(i)

        def values(name: str, v: Any) -> Optional[np.ndarray]:
            if v is None:
                return None
            s, arr = _attribute(name, v, n)
            return arr if arr is not None else np.full(n, s, dtype=np.uint64)

        c, m, g = values("category", category), values("mask", mask), values("group", group)
        with self._first_bad_position(i):
            self._core.set_filter(i, c, m, g)

    def set_user(self, ids: Any, user: Any) -> None:
        """Sets the user values of the objects (a scalar or n values)."""
        i = _u64_array("ids", ids)
        s, arr = _attribute("user", user, len(i))
        users = arr if arr is not None else np.full(len(i), s, dtype=np.uint64)
        with self._first_bad_position(i):
            self._core.set_user(i, users)

    def user(self, ids: Any) -> np.ndarray:
        """The user values of the objects, as a uint64 array."""
        return self._core.get_user(_u64_array("ids", ids))

    @contextlib.contextmanager
    def _first_bad_position(self, ids: np.ndarray, boxes: Optional[np.ndarray] = None) -> Iterator[None]:
        """The library refuses a batch of more ids than the scene holds objects before it reads the
        batch (LOCD_ERR_TOO_MANY_OBJECTS, no index): such a batch names a stale id or an id twice.
        This names its first bad position as for any other bad batch (StaleIdError,
        DuplicateIdError or, for a move, InvalidBoxError, each with ``.index``), in the library's
        order for a position: the id stale, the id earlier in the batch, the box bad."""
        try:
            yield
        except InvalidArgumentError as e:
            if e.name != "ERR_TOO_MANY_OBJECTS":
                raise
            n = len(ids)
            seen = np.ones(n, dtype=bool)
            seen[np.unique(ids, return_index=True)[1]] = False
            at_dup = int(np.argmax(seen)) if seen.any() else n
            try:
                self._core.get_user(ids)  # names the first stale id (it reads any number of ids)
                stale = None
            except StaleIdError as s:
                stale = s
            at_stale = stale.index if stale is not None else n
            at_box, box_status = n, ""
            if boxes is not None:
                nonfinite = ~np.isfinite(boxes).all(axis=1)
                bad = np.flatnonzero(nonfinite | (boxes[:, :3] > boxes[:, 3:]).any(axis=1))
                if len(bad):
                    at_box = int(bad[0])
                    box_status = "ERR_NONFINITE" if nonfinite[at_box] else "ERR_INVERTED_BOX"
            at = min(at_stale, at_dup, at_box)
            if at == n:  # (nothing found: another thread changed the scene meanwhile)
                raise
            if at == at_stale:
                raise stale from None
            status = "ERR_DUPLICATE_ID" if at == at_dup else box_status
            raise _errors.from_status(_STATUS[status], "", e.detail, at) from None

    # -- update ---------------------------------------------------------------
    def update(self) -> SceneUpdate:
        """Brings the pairs up to date with every change since the previous update."""
        pairs, created, lost = self._core.update(True, True)
        return SceneUpdate(pairs, created, lost)

    @property
    def stats(self) -> Dict[str, Any]:
        """Counts and milliseconds of the last update (``locd_scene_stats``)."""
        return self._core.stats()

    # -- queries --------------------------------------------------------------
    # Query shapes are float64 whatever the scene's dtype: every float32 value is exact in float64, and no
    # finite value overflows (a float32 scene takes a query box of +-1e300 as it is). The library checks
    # each shape; bad ones raise InvalidQueryError naming the query. Batches run on the scene's threads,
    # the GIL released.
    def query_box(self, box: Any, mask: Any = ALL) -> np.ndarray:
        """Ids (ascending, uint64) of the objects whose box overlaps ``box``
        (6 values, closed) and whose category has a bit in ``mask``."""
        return self._core.overlap(0, _shape("box", box, 6), 0.0, _u64_scalar("mask", mask))

    def query_point(self, point: Any, mask: Any = ALL) -> np.ndarray:
        """Ids (ascending) of the objects whose box contains ``point`` (on a face, edge or corner counts)."""
        return self._core.overlap(1, _shape("point", point, 3), 0.0, _u64_scalar("mask", mask))

    def query_sphere(self, center: Any, radius: Any, mask: Any = ALL) -> np.ndarray:
        """Ids (ascending) of the objects whose box lies within ``radius`` of ``center``: with d the
        distance from the centre to the box per axis (0 inside), ``(dx*dx + dy*dy) + dz*dz <= r*r``
        in float64."""
        return self._core.overlap(2, _shape("center", center, 3), _real("radius", radius),
                                  _u64_scalar("mask", mask))

    def raycast(self, origin: Any, direction: Any, max_t: Any, mask: Any = ALL) -> Tuple[np.ndarray, np.ndarray]:
        """Objects whose box meets the segment ``origin + t * direction``, 0 <= t <= max_t.

        Returns ``(ids, t)``: uint64 ids and their float64 entry parameters
        (0 when the origin is inside the box), sorted by t, then id.
        ``direction`` need not be unit length; ``max_t`` may be ``math.inf``."""
        return self._core.cast(0, _shape("origin", origin, 3), _shape("direction", direction, 3),
                               _real("max_t", max_t), _MODES["all"], _u64_scalar("mask", mask))

    def sweep_box(self, box: Any, direction: Any, max_t: Any, mask: Any = ALL) -> Tuple[np.ndarray, np.ndarray]:
        """Objects that ``box`` meets as it moves to ``box + t * direction``, 0 <= t <= max_t.

        Returns ``(ids, t)``: each object's first touch t (0 when they touch at the start), sorted by
        (t, id)."""
        return self._core.cast(1, _shape("box", box, 6), _shape("direction", direction, 3),
                               _real("max_t", max_t), _MODES["all"], _u64_scalar("mask", mask))

    def raycast_batch(self, origins: Any, directions: Any, max_t: Any, mask: Any = ALL, *,
                      mode: str = "all") -> Tuple[np.ndarray, ...]:
        """n rays at once (``origins``, ``directions``: (n, 3); ``max_t``: a number or n numbers).

        ``mode="all"``: ``(offsets, ids, t)``, ray k's hits ``ids[offsets[k]:offsets[k+1]]``
        sorted by (t, id); ``offsets`` is (n+1,) int64. ``mode="closest"`` (the smallest (t, id)) or
        ``"any"`` (the first found: a line of sight): ``(ids, t)`` of shape (n,), 0 and inf where a ray
        hit nothing. The hits do not depend on the scene's thread count."""
        if not isinstance(mode, str) or mode not in _MODES:
            raise ValueError("mode must be 'all', 'closest' or 'any', got %r" % (mode,))
        o = _shapes("origins", origins, 3)
        d = _shapes("directions", directions, 3, len(o))
        return self._core.cast_batch(0, o, d, _reals("max_t", max_t, len(o)), _MODES[mode],
                                     _u64_scalar("mask", mask))

    def query_box_batch(self, boxes: Any, mask: Any = ALL) -> Tuple[np.ndarray, np.ndarray]:
        """n box queries at once (``boxes``: (n, 6)): ``(offsets, ids)``, query k's ids ascending in
        ``ids[offsets[k]:offsets[k+1]]``; ``offsets`` is (n+1,) int64."""
        return self._core.overlap_batch(0, _shapes("boxes", boxes, 6), None, _u64_scalar("mask", mask))


_MODES = {"all": 0, "closest": 1, "any": 2}

# Integers up to 2**53 are exact in float64; larger ones are refused rather than rounded (as for boxes).
_EXACT = 2 ** 53


def _real(name: str, value: Any) -> float:
    """A number (a Python or numpy int or float, or a 0-d array of one; not a bool or a string) as a
    float. Its range (NaN, negative) is the library's to check."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError("%s must be a number, got %r" % (name, value))
    if isinstance(value, (int, np.integer)) and not -_EXACT <= int(value) <= _EXACT:
        raise ValueError("%s: integers beyond +-2**53 cannot be converted to float64 exactly" % name)
    return float(value)


def _numbers(name: str, value: Any) -> np.ndarray:
    """Any array or sequence of numbers as float64 (not yet shaped): float32 and float64 as they are
    (float32 widens exactly), integers up to +-2**53, lists of Python numbers. Other dtypes
    (bool, float16, complex, strings, objects) raise TypeError."""
    arr = value if isinstance(value, np.ndarray) else np.asarray(value)
    kind = arr.dtype.kind
    if kind in "iu":
        if arr.size and (int(arr.max()) > _EXACT or int(arr.min()) < -_EXACT):
            raise ValueError("%s: integers beyond +-2**53 cannot be converted to float64 exactly" % name)
    elif kind != "f" or arr.dtype.itemsize not in (4, 8):
        raise TypeError("%s must hold numbers (float32, float64 or integers), got dtype %s" % (name, arr.dtype))
    return arr


def _reals(name: str, value: Any, n: int) -> np.ndarray:
    """A number for all n, or n numbers, as a C-contiguous (n,) float64 array."""
    if not isinstance(value, (np.ndarray, list, tuple)) or (isinstance(value, np.ndarray) and value.ndim == 0):
        return np.full(n, _real(name, value))
    arr = _numbers(name, value)
    if arr.shape != (n,):
        raise ValueError("%s must be a number or have shape (%d,), got shape %s" % (name, n, arr.shape))
    return np.ascontiguousarray(arr, dtype=np.float64)


def _shape(name: str, value: Any, size: int) -> np.ndarray:
    """A query's shape: `size` numbers as a C-contiguous (size,) float64 array."""
    arr = _numbers(name, value)
    if arr.shape != (size,):
        raise ValueError("%s must have shape (%d,), got shape %s" % (name, size, arr.shape))
    return np.ascontiguousarray(arr, dtype=np.float64)


def _shapes(name: str, value: Any, size: int, n: Optional[int] = None) -> np.ndarray:
    """n queries' shapes: a C-contiguous (n, size) float64 array."""
    arr = _numbers(name, value)
    if arr.ndim == 1 and arr.shape[0] == 0:
        arr = arr.reshape(0, size)
    if arr.ndim != 2 or arr.shape[1] != size:
        raise ValueError("%s must have shape (n, %d), got shape %s" % (name, size, arr.shape))
    if n is not None and arr.shape[0] != n:
        raise ValueError("%s has %d rows for %d queries" % (name, arr.shape[0], n))
    return np.ascontiguousarray(arr, dtype=np.float64)
