"""Exceptions raised by locd (shared by the pybind11 and the cffi modules).

One mapping everywhere: arguments that Python can check itself raise the
builtin ``ValueError`` / ``TypeError``; every failure the C library reports
raises a subclass of :class:`Error` chosen by its ``locd_status``
(:data:`ERRORS`). The subclasses also derive from the builtin exception that
names the same kind of failure (``ValueError`` for bad input found by C,
``MemoryError``, ``ConnectionError``, ``OSError``...), so code that
catches builtins keeps working. docs/python.md has the table.
"""
from __future__ import annotations

import concurrent.futures
from typing import Dict, Type

from ._cdef import CONSTANTS

#: Status code name (without the LOCD_ prefix) -> value, from include/locd/locd.h.
STATUS = {name[len("LOCD_"):]: value for name, value in CONSTANTS.items()
          if name in ("LOCD_OK", "LOCD_PENDING") or name.startswith("LOCD_ERR_")}
_STATUS_NAMES = {value: name for name, value in STATUS.items()}


class Error(Exception):
    """A locd call failed.

    Attributes: ``status`` (the C library's negative ``locd_status`` code),
    ``name`` (e.g. ``'ERR_NO_MEMORY'``), ``detail`` (the library's message for
    the failed call) and ``index`` (the first bad box or id, or -1).
    """

    def __init__(self, status: int, message: str, detail: str = "", index: int = -1):
        super().__init__(message)
        self.status = status
        self.name = _STATUS_NAMES.get(status, "UNKNOWN")
        self.detail = detail
        self.index = index

    def __reduce__(self):  # picklable (multiprocessing, concurrent.futures.ProcessPoolExecutor)
        return (type(self), (self.status, str(self), self.detail, self.index))


class InvalidArgumentError(Error, ValueError):
    """The C library rejected an argument (an option out of range, too many objects, a bad id...)."""


class InvalidBoxError(InvalidArgumentError):
    """A box has a NaN/infinite coordinate or min > max; ``index`` names it."""


class InvalidQueryError(InvalidBoxError):
    """A scene query is invalid: a NaN or infinite coordinate (box, point, origin or centre), min > max,
    a NaN or infinite direction, a negative or NaN ``max_t`` or radius. ``index`` names the query in
    its batch (0 for a single query); ``status`` is the library's code for it."""


class ShapeError(InvalidArgumentError):
    """A shape description is invalid (locd.pipeline)."""


class StaleIdError(Error, KeyError):
    """A scene id was removed or never issued by this scene; ``index`` is its position in the batch."""

    def __str__(self) -> str:  # KeyError would show the message quoted
        return str(self.args[0]) if self.args else ""


class DuplicateIdError(InvalidArgumentError):
    """A scene id appears twice in one batch; ``index`` is the position of its second occurrence."""


class ClosedError(Error, ValueError):
    """The handle is closed or invalid (like I/O on a closed file: a ``ValueError``)."""


class NoMemoryError(Error, MemoryError):
    """An allocation failed; nothing was changed."""


class BusyError(Error):
    """The engine is running another call or job (levels 1 and 2)."""


class UnsupportedError(Error, NotImplementedError):
    """The feature or level is not in this build of the library."""


class WorkerError(Error):
    """A worker process failed or died, or a thread could not be started."""


class ConnectionFailedError(Error, ConnectionError):
    """The service is unreachable or went away."""


class IOFailedError(Error, OSError):
    """A shared memory, socket or file operation failed."""


class ProtocolError(Error):
    """A malformed or unexpected message from the service."""


class AuthError(Error, PermissionError):
    """The service refused the shared secret."""


class LimitError(Error):
    """The job exceeds a limit of the service (boxes, pairs, memory, time, jobs in flight);
    only this job failed (docs/levels.md, "Limits and deadlines")."""


class WaitTimeoutError(Error, concurrent.futures.TimeoutError):
    """A wait ran out of time (the work is still running), or a level-3 job
    passed its deadline (``service_timeout_ms``; the job is then finished)."""


class JobCancelledError(Error, concurrent.futures.CancelledError):
    """The job was cancelled."""


class InternalError(Error):
    """A bug in locd: please report it."""


#: Status name -> the exception class raised for it (anything else: :class:`Error`).
ERRORS: Dict[str, Type[Error]] = {
    "ERR_INVALID_ARGUMENT": InvalidArgumentError,
    "ERR_NULL_POINTER": InvalidArgumentError,
    "ERR_TOO_MANY_OBJECTS": InvalidArgumentError,
    "ERR_BUFFER_TOO_SMALL": InvalidArgumentError,
    "ERR_STALE_ID": StaleIdError,
    "ERR_DUPLICATE_ID": DuplicateIdError,
    "ERR_NONFINITE": InvalidBoxError,
    "ERR_INVERTED_BOX": InvalidBoxError,
    "ERR_SHAPE": ShapeError,
    "ERR_INVALID_HANDLE": ClosedError,
    "ERR_NO_MEMORY": NoMemoryError,
    "ERR_BUSY": BusyError,
    "ERR_THREAD": WorkerError,
    "ERR_WORKER": WorkerError,
    "ERR_UNSUPPORTED": UnsupportedError,
    "ERR_IO": IOFailedError,
    "ERR_CONNECTION": ConnectionFailedError,
    "ERR_PROTOCOL": ProtocolError,
    "ERR_AUTH": AuthError,
    "ERR_TIMEOUT": WaitTimeoutError,
    "ERR_CANCELLED": JobCancelledError,
    "ERR_LIMIT": LimitError,
    "ERR_INTERNAL": InternalError,
}
_BY_STATUS = {STATUS[name]: cls for name, cls in ERRORS.items() if name in STATUS}


_QUERY_STATUS = ("ERR_NONFINITE", "ERR_INVERTED_BOX", "ERR_INVALID_ARGUMENT")


def from_status(status: int, text: str, detail: str, index: int, query: bool = False) -> Error:
    """Builds the exception for a failed call (text: locd_status_string). ``query``: the call was a
    scene query, whose bad input (with the index of the query) raises :class:`InvalidQueryError`."""
    cls = _BY_STATUS.get(status, Error)
    if query and index >= 0 and status in (STATUS[name] for name in _QUERY_STATUS):
        # The library's detail is "<status text>: query <k>...": the part after the status text.
        what = detail[len(text) + 2:] if detail.startswith(text + ": ") else detail
        if not what.startswith("query %d" % index):
            what = "query %d: %s" % (index, what or text)
        return InvalidQueryError(status, what, detail, index)
    if status in (STATUS["ERR_NONFINITE"], STATUS["ERR_INVERTED_BOX"]):
        what = "has a NaN or infinite coordinate" if status == STATUS["ERR_NONFINITE"] else "has min > max on some axis"
        return cls(status, "box %d %s" % (index, what), detail, index)
    if status == STATUS["ERR_STALE_ID"]:
        return cls(status, "id at index %d is stale (removed or never issued by this scene)" % index, detail, index)
    if status == STATUS["ERR_DUPLICATE_ID"]:
        return cls(status, "id at index %d appears earlier in the same batch" % index, detail, index)
    # The library's detail usually starts with the status text already.
    message = detail if detail.startswith(text) else ("%s: %s" % (text, detail) if detail else text)
    message = "%s [LOCD_%s = %d]" % (message, _STATUS_NAMES.get(status, "?"), status)
    return cls(status, message, detail, index)
