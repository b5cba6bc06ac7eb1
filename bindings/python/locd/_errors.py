"""Exceptions raised by locd (shared by the pybind11 and the cffi modules)."""
from __future__ import annotations

from ._cdef import CONSTANTS

#: Status code name (without the LOCD_ prefix) -> value, from include/locd/locd.h.
STATUS = {name[len("LOCD_"):]: value for name, value in CONSTANTS.items()
          if name in ("LOCD_OK", "LOCD_PENDING") or name.startswith("LOCD_ERR_")}
_STATUS_NAMES = {value: name for name, value in STATUS.items()}


class Error(Exception):
    """A locd call failed.

    Attributes: ``status`` (the C library's negative ``locd_status`` code),
    ``name`` (e.g. ``'ERR_NO_MEMORY'``), ``detail`` (the library's message for
    the failed call) and ``index`` (the first bad box, or -1).
    """

    def __init__(self, status: int, message: str, detail: str = "", index: int = -1):
        super().__init__(message)
        self.status = status
        self.name = _STATUS_NAMES.get(status, "UNKNOWN")
        self.detail = detail
        self.index = index


class InvalidBoxError(Error, ValueError):
    """A box has a NaN/infinite coordinate or min > max; ``index`` names it."""


def from_status(status: int, text: str, detail: str, index: int) -> Error:
    """Builds the exception for a failed call (text: locd_status_string)."""
    if status in (STATUS["ERR_NONFINITE"], STATUS["ERR_INVERTED_BOX"]):
        what = "has a NaN or infinite coordinate" if status == STATUS["ERR_NONFINITE"] else "has min > max on some axis"
        return InvalidBoxError(status, "box %d %s" % (index, what), detail, index)
    # The library's detail usually starts with the status text already.
    message = detail if detail.startswith(text) else ("%s: %s" % (text, detail) if detail else text)
    message = "%s [LOCD_%s = %d]" % (message, _STATUS_NAMES.get(status, "?"), status)
    return Error(status, message, detail, index)
