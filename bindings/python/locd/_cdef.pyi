# Type stub of the module generated at build time by bindings/python/gen_cdef.py.
from typing import Dict

LIBRARY: str
CONSTANTS: Dict[str, int]
CDEF: str
