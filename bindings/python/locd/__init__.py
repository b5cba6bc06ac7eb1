"""locd: exact all-pairs collision detection of axis-aligned boxes.

Boxes are an (n, 6) numpy array, one row ``minx miny minz maxx maxy maxz``
per object, float32 (zero-copy: read in place when C-contiguous) or float64
(computed in float64, also zero-copy when C-contiguous). Two boxes
overlap iff on every axis ``a.min <= b.max and b.min <= a.max`` (closed
intervals: touching faces, edges and corners count; zero-size boxes are
valid). Integer arrays and lists are converted to float64. The result is exactly
the overlapping pairs as an (m, 2) uint32 array (``index_dtype=numpy.int64`` for int64),
``i < j``, each pair once, in an order that does not depend on the thread
count, the integration level or the run (``sort=True`` orders it by (i, j)).

>>> import numpy as np, locd
>>> boxes = np.array([[0, 0, 0, 1, 1, 1], [1, 1, 1, 2, 2, 2], [3, 3, 3, 4, 4, 4]], np.float32)
>>> locd.find_pairs(boxes).tolist()
[[0, 1]]

Main entry points:

- :func:`find_pairs` -- one call, an engine per Python thread behind the scenes.
- :class:`Engine` -- explicit engine (integration level, threads, worker
  processes or a service), its per-stage :class:`Stats`, and asynchronous
  :class:`Job` objects from :meth:`Engine.submit`.
- :mod:`locd.abi` -- the same ``find_pairs`` through cffi's ABI mode (no
  compiler, only the shared library and the public header's declarations).

Errors: arguments Python checks raise ``ValueError`` / ``TypeError``; failures
the C library reports raise a subclass of :class:`Error` chosen by the status
(``ERRORS``), which also derives from the matching builtin: bad boxes raise
:class:`InvalidBoxError` (a ``ValueError`` whose ``index`` names the first bad
box), a busy engine :class:`BusyError`, an unreachable service
:class:`ConnectionFailedError` (a ``ConnectionError``)... The GIL is released
while the C library works.
"""
from __future__ import annotations

import concurrent.futures
import numbers
import os
import dataclasses
import math
import collections
import threading
import weakref
from typing import Any, Dict, Optional, Union

import numpy as np

from . import _arrays, _core
from ._errors import (ERRORS, STATUS, AuthError, BusyError, ClosedError, ConnectionFailedError, Error, InternalError,
                      InvalidArgumentError, InvalidBoxError, InvalidQueryError, IOFailedError, JobCancelledError,
                      LimitError, NoMemoryError, ProtocolError, ShapeError, UnsupportedError, WaitTimeoutError,
                      WorkerError)

Future = concurrent.futures.Future

__all__ = ["find_pairs", "brute_force", "Engine", "Job", "Service", "Stats", "STATUS", "LEVELS", "__version__",
           "Error", "ERRORS", "InvalidArgumentError", "InvalidBoxError", "InvalidQueryError", "ShapeError", "ClosedError",
           "NoMemoryError", "BusyError", "UnsupportedError", "WorkerError", "ConnectionFailedError", "IOFailedError",
           "ProtocolError", "AuthError", "WaitTimeoutError", "JobCancelledError", "LimitError", "InternalError"]

#: Version of the loaded C library (the Meson project version).
__version__: str = _core.version()

#: Integration level names accepted by :class:`Engine`.
LEVELS: Dict[str, int] = {"inprocess": 1, "workers": 2, "service": 3}

_OK = STATUS["OK"]
_PENDING = STATUS["PENDING"]
_CANCELLED = STATUS["ERR_CANCELLED"]


@dataclasses.dataclass(frozen=True)
class Stats:
    """Statistics of one call (``locd_stats``): counts and per-stage milliseconds.

    ``ms_total`` is the wall time inside the C call; the stages are bounds
    (validation and root cube), encode, sort, merge, sweep, order (sorting the
    pairs when ``sort=True``) and transfer (shared memory or socket traffic of
    levels 2 and 3).
    """

    threads: int
    objects: int
    entries: int
    candidates: int
    exact_tests: int
    pairs: int
    depth: int
    ms_total: float
    ms_bounds: float
    ms_encode: float
    ms_sort: float
    ms_merge: float
    ms_sweep: float
    ms_order: float
    ms_transfer: float

    def as_dict(self) -> Dict[str, Any]:
        return dataclasses.asdict(self)


def _integer(name: str, value: Any) -> int:
    """An int from a Python or numpy integer; anything else (floats, strings, bools) is a TypeError."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError("%s must be an integer, got %s" % (name, type(value).__name__))
    return int(value)


def _text(name: str, value: Any) -> Optional[str]:
    if value is None:
        return None
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if not isinstance(value, str):
        raise TypeError("%s must be a str or None, got %s" % (name, type(value).__name__))
    return value


def _count(name: str, value: Optional[int]) -> int:
    if value is None:
        return 0
    value = _integer(name, value)
    if value < 1:
        raise ValueError("%s must be >= 1 (or None for one per core), got %d" % (name, value))
    return value


class Engine:
    """A locd engine: an integration level, its threads/workers and buffers.

    Reuse one engine for many calls (it keeps its threads, workers or
    connection and its buffers). Use it as a context manager, or call
    :meth:`close`. An engine runs one call at a time; Python threads sharing it
    take turns (give each thread its own engine to run them in parallel).
    At levels ``'inprocess'`` and ``'workers'`` a submitted :class:`Job`
    occupies the engine until it finishes (a cancelled one until its current
    step returns): a call meanwhile raises :class:`Error` with status
    ``STATUS['ERR_BUSY']``. A ``'service'`` engine takes many jobs at once.

    Args:
        level: ``'inprocess'`` (threads in this process), ``'workers'`` (worker
            processes over POSIX shared memory) or ``'service'`` (a separate
            locd service process; asynchronous jobs), or the number 1, 2 or 3.
        threads: threads for level ``'inprocess'`` (None = one per core).
        workers: worker processes for level ``'workers'`` (None = one per core).
        service: level ``'service'``: ``"unix:/path/to.sock"`` or ``"tcp:host:port"``.
        secret: shared secret for a TCP service.
        max_depth: octree depth limit (0 = automatic).
        cell_bias: cell size bias 0..8 (see docs/encoding.md); default 2 (LOCD_DEFAULT_CELL_BIAS).
        cubes: choose cells from bounding cubes (the paper's choice) instead of
            the boxes' own extents. The result is the same; only the work differs.
        worker_path: level ``'workers'``: path of the locd-worker executable
            (None = the library's default).
        service_timeout_ms: level ``'service'``: each job's deadline in ms from
            its submit, plus 10 us per box (None = the library's default, 60 s;
            a negative number = no deadline). A job past it raises
            :class:`locd.WaitTimeoutError` (docs/levels.md, "Deadlines").
    """

    def __init__(self, level: Union[str, int] = "inprocess", threads: Optional[int] = None,
                 workers: Optional[int] = None, service: Optional[str] = None, secret: Optional[str] = None,
                 max_depth: int = 0, cell_bias: int = 2, cubes: bool = False,
                 worker_path: Optional[str] = None, service_timeout_ms: Optional[int] = None) -> None:
        if isinstance(level, str):
            if level not in LEVELS:
                raise ValueError("level must be one of %s, got %r" % (", ".join(map(repr, LEVELS)), level))
            lvl = LEVELS[level]
        else:
            lvl = _integer("level", level)
            if lvl not in LEVELS.values():
                raise ValueError("level must be 1, 2 or 3, got %d" % lvl)
        if workers is not None and lvl != LEVELS["workers"]:
            raise ValueError("workers= applies to level='workers' (use threads= for the other levels)")
        if lvl == LEVELS["workers"] and workers is None:
            workers = threads
        count = _count("workers" if lvl == LEVELS["workers"] else "threads",
                       workers if lvl == LEVELS["workers"] else threads)
        if lvl == LEVELS["service"] and not service:
            raise ValueError("level='service' needs service='unix:/path.sock' or 'tcp:host:port'")
        max_depth = _integer("max_depth", max_depth)
        cell_bias = _integer("cell_bias", cell_bias)
        if max_depth < 0:
            raise ValueError("max_depth must be >= 0, got %d" % max_depth)
        if not 0 <= cell_bias <= 8:
            raise ValueError("cell_bias must be in 0..8, got %d" % cell_bias)
        service, secret = _text("service", service), _text("secret", secret)
        worker_path = _text("worker_path", worker_path)
        self._jobs: "weakref.WeakSet[Job]" = weakref.WeakSet()
        timeout = 0 if service_timeout_ms is None else _integer("service_timeout_ms", service_timeout_ms)
        if timeout == 0 and service_timeout_ms is not None:
            raise ValueError("service_timeout_ms must be > 0, negative (no deadline) or None (the default)")
        self._core = _core.Engine(lvl, count, max_depth, cell_bias, bool(cubes), service, secret, worker_path,
                                  timeout)

    # -- lifetime -------------------------------------------------------------
    def close(self) -> None:
        """Stops the engine's threads/workers/connection. Unfinished jobs are cancelled."""
        core = getattr(self, "_core", None)
        if core is None or core.closed:
            return
        for job in list(self._jobs):
            job._release()
        core.close()

    def __enter__(self) -> "Engine":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # interpreter shutdown: nothing sensible to report
            pass

    @property
    def closed(self) -> bool:
        return self._core.closed

    @property
    def level(self) -> str:
        """Integration level in use (``'inprocess'``, ``'workers'`` or ``'service'``)."""
        self._check_open()
        return {v: k for k, v in LEVELS.items()}[self._core.level]

    @property
    def threads(self) -> int:
        """Threads (level 1) or worker processes (level 2) in use."""
        self._check_open()
        return self._core.threads

    def __repr__(self) -> str:
        if self._core.closed:
            return "<locd.Engine closed>"
        return "<locd.Engine level=%r threads=%d>" % (self.level, self.threads)

    def _check_open(self) -> None:
        if self._core.closed:
            raise ClosedError(STATUS["ERR_INVALID_HANDLE"], "the engine is closed")

    # -- work -----------------------------------------------------------------
    def find_pairs(self, boxes: Any, other: Any = None, *, sort: bool = False,
                   index_dtype: Any = np.uint32) -> np.ndarray:
        """Every overlapping pair of ``boxes`` as an (m, 2) array, i < j.

        ``boxes``: (n, 6) float32 or float64 array (read in place when
        C-contiguous), or integers/lists (converted to float64).
        ``sort=True`` orders the pairs by (i, j); otherwise the order is
        deterministic but unspecified. ``index_dtype``: ``numpy.uint32``
        (default) or ``numpy.int64``.

        With ``other`` (a second (nb, 6) array): the two-set query, every pair
        (i, j) with ``boxes[i]`` and ``other[j]`` overlapping (i indexes
        ``boxes``, j indexes ``other``; pairs within one set are not reported;
        a bad box of ``other`` has ``InvalidBoxError.index`` n + j). Levels 1
        and 2 (level 3 raises ``locd.UnsupportedError``).
        """
        wide = _arrays.index_dtype(index_dtype)
        if other is not None:
            return self._core.find_pairs_between(boxes, other, bool(sort), wide)
        return self._core.find_pairs(boxes, bool(sort), wide)

    @property
    def stats(self) -> Stats:
        """:class:`Stats` of this engine's last successful call."""
        self._check_open()
        return Stats(**self._core.stats())

    def submit(self, boxes: Any, *, sort: bool = False, index_dtype: Any = np.uint32) -> "Job":
        """Starts finding the pairs asynchronously and returns a :class:`Job` (a ``concurrent.futures.Future``).

        The boxes are copied, so the array may be reused at once.
        """
        wide = _arrays.index_dtype(index_dtype)
        job = Job(self._core.submit(boxes, bool(sort)), wide, self)
        self._jobs.add(job)
        return job


class Job(concurrent.futures.Future):
    """An asynchronous :meth:`Engine.submit` call: a real ``concurrent.futures.Future``.

    It works with ``concurrent.futures.as_completed`` and ``wait``,
    ``asyncio.wrap_future``, ``add_done_callback``, ``result(timeout)``,
    ``exception(timeout)`` and ``cancel()``. A thread of its own waits for the
    C job (blocked in ``locd_job_wait``, the GIL released: no polling) and
    sets the result, the exception or the cancellation; it ends as soon as the
    job does, and done-callbacks run on it. ``cancel()`` calls
    ``locd_job_cancel``: it returns False only if the job had already
    finished. ``running()`` is True until the job is done.
    """

    def __init__(self, core: Any, wide: bool, engine: "Engine") -> None:
        super().__init__()
        self._core = core
        self._engine: Optional[Engine] = engine  # an unfinished job keeps its engine open
        self._wide = wide
        self._stats: Optional[Stats] = None
        self._cancel_lock = threading.RLock()
        self._notified = False
        self._waiter = threading.Thread(target=self._wait, name="locd-job-waiter", daemon=True)
        self._waiter.start()

    # -- the waiter thread ----------------------------------------------------
    def _wait(self) -> None:
        try:
            status = self._core.wait(-1)
            if status == _OK:
                pairs = self._core.take(self._wide)
                self._stats = Stats(**self._core.stats())
                self._settle(pairs, None)
            elif status == STATUS["ERR_TIMEOUT"]:  # a level-3 job past its deadline: finished, and
                self._core.take(self._wide)  # take raises its error (WaitTimeoutError with the detail)
                raise WaitTimeoutError(status, "the job passed its deadline", "", -1)
            else:  # LOCD_ERR_CANCELLED
                self._mark_cancelled()
        except BaseException as e:  # the job's own error (InvalidBoxError, ConnectionFailedError, ...)
            self._settle(None, e)
        finally:
            self._engine = None

    def _settle(self, pairs: Optional[np.ndarray], exc: Optional[BaseException]) -> None:
        with self._cancel_lock:
            if self.cancelled():
                return
            try:
                if exc is None:
                    self.set_result(pairs)
                else:
                    self.set_exception(exc)
            except concurrent.futures.InvalidStateError:
                pass

    def _mark_cancelled(self) -> None:
        # PENDING -> CANCELLED (wakes result(), runs callbacks), then ->
        # CANCELLED_AND_NOTIFIED, which as_completed() and wait() look for.
        with self._cancel_lock:
            if Future.cancel(self) and not self._notified:
                self._notified = True
                self.set_running_or_notify_cancel()

    # -- the Future API -------------------------------------------------------
    def cancel(self) -> bool:
        """Cancels the job (``locd_job_cancel``). True unless it had already finished."""
        if self.done():
            return self.cancelled()
        self._core.cancel()
        if self._core.poll() != _CANCELLED:
            return False  # it finished first: the waiter sets its result
        self._mark_cancelled()
        return True

    def running(self) -> bool:
        """True until the job is done (it is queued or running in the library)."""
        return not self.done()

    @property
    def stats(self) -> Stats:
        """:class:`Stats` of the finished job (waits for it, like ``result()``)."""
        self.result()
        assert self._stats is not None
        return self._stats

    def _release(self) -> None:
        """Cancels the job if unfinished and frees the C job (Engine.close)."""
        self._core.cancel()
        if self._waiter is not threading.current_thread():
            self._waiter.join()
        self._core.release()

    def __repr__(self) -> str:
        state = ("cancelled" if self.cancelled() else "failed" if self.done() and self.exception() else
                 "finished" if self.done() else "running")
        return "<locd.Job %s>" % state


class Service:
    """Hosts the level-3 service (what ``locd serve`` runs) in this process.

    It listens on a background thread until :meth:`close`; engines created
    with ``Engine(level='service', service=svc.address)`` (here or in other
    processes of the same user) send it their work.

    Args:
        listen: ``"unix:/path/to.sock"`` or ``"tcp:host:port"`` (port 0 = any
            free port; see :attr:`address`). None = the per-user default socket.
        secret: shared secret clients must present (required for TCP).
        threads: job runners (None = one per core).
        engine_threads: threads of each runner's engine (None = 1).
    """

    def __init__(self, listen: Optional[str] = None, *, secret: Optional[str] = None,
                 threads: Optional[int] = None, engine_threads: Optional[int] = None) -> None:
        self._core = _core.Service(_text("listen", listen), _text("secret", secret), _count("threads", threads),
                                   _count("engine_threads", engine_threads))

    @property
    def address(self) -> str:
        """The address actually listened on (``"tcp:127.0.0.1:40123"`` for port 0)."""
        return self._core.address

    def close(self) -> None:
        """Stops serving and closes every connection."""
        self._core.stop()

    def __enter__(self) -> "Service":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        return "<locd.Service %s%s>" % (self.address, " stopped" if self._core.stopped else "")


_local = threading.local()

# find_pairs() keeps an engine per Python thread and thread count, so that
# repeated calls reuse its threads and buffers. Only the engines of the last
# _ENGINES_PER_THREAD thread counts a Python thread used stay open (the least
# recently used one is closed): a caller trying threads=1..64 must not be
# left with 2,000 idle threads and their buffers. A thread's engines go with it.
_ENGINES_PER_THREAD = 2


def _engine_for(threads: Optional[int]) -> Engine:
    engines = getattr(_local, "engines", None)
    if engines is None:
        engines = _local.engines = collections.OrderedDict()
    key = _count("threads", threads)
    engine = engines.pop(key, None)
    if engine is None:
        engine = Engine(threads=threads)
    engines[key] = engine
    while len(engines) > _ENGINES_PER_THREAD:
        engines.popitem(last=False)[1].close()
    return engine


def find_pairs(boxes: Any, other: Any = None, *, threads: Optional[int] = None, sort: bool = False,
               index_dtype: Any = np.uint32) -> np.ndarray:
    """Every overlapping pair of ``boxes`` as an (m, 2) array, i < j.

    Args:
        boxes: (n, 6) array, rows ``minx miny minz maxx maxy maxz``; float32
            (zero-copy when C-contiguous) or float64 (computed in float64);
            integer arrays and lists are converted to float64.
        other: a second (nb, 6) array for the two-set query: then the result is
            every pair (i, j) with ``boxes[i]`` and ``other[j]`` overlapping (i
            indexes ``boxes``, j indexes ``other``, so i < j does not apply;
            pairs within one set are not reported; a bad box of ``other`` has
            ``InvalidBoxError.index`` n + j). A float32 set meeting a float64
            one is computed in float64.
        threads: threads to use (None = one per core).
        sort: order the pairs by (i, j) (costs time); otherwise the order is
            deterministic (the same for every thread count and run).
        index_dtype: ``numpy.uint32`` (default, the library's own indices) or
            ``numpy.int64`` (subtracting columns cannot wrap).

    Raises:
        InvalidBoxError: a box has NaN/inf coordinates or min > max (``.index``).
        ValueError: ``boxes`` is not of shape (n, 6), or a bad option value.
        TypeError: ``boxes`` has a dtype that is neither float32/float64 nor
            integer, or an option has the wrong type.

    Each Python thread gets its own engine (kept for later calls), so calls
    from several threads run in parallel.
    """
    wide = _arrays.index_dtype(index_dtype)
    engine = _engine_for(threads)._core
    if other is not None:
        return engine.find_pairs_between(boxes, other, bool(sort), wide)
    return engine.find_pairs(boxes, bool(sort), wide)


def brute_force(boxes: Any, *, index_dtype: Any = np.uint32) -> np.ndarray:
    """The O(n^2) C reference: every overlapping pair, sorted by (i, j). For tests and tiny scenes."""
    return _core.brute_force(boxes, _arrays.index_dtype(index_dtype))


# -- the persistent scene (locd/scene.py) -----------------------------------------
from .scene import DuplicateIdError, Scene, SceneUpdate, StaleIdError  # noqa: E402

__all__ += ["Scene", "SceneUpdate", "StaleIdError", "DuplicateIdError"]
