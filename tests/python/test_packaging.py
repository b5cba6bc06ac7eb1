"""The installed package: no compiler at import, library inside the package,
cffi declarations that match the public header, one version everywhere."""
import importlib.metadata
import importlib.util
import os
import re
import subprocess
import sys
import tempfile

import numpy as np
import pytest

import locd
import locd.abi
from conftest import REPO_ROOT

PKG_DIR = os.path.dirname(os.path.abspath(locd.__file__))


def test_installed_package_not_the_source_tree():
    assert not PKG_DIR.startswith(os.path.join(REPO_ROOT, "bindings")), PKG_DIR
    names = os.listdir(PKG_DIR)
    assert "liblocd.so" in names and "py.typed" in names
    # Wheels hold no symlinks: exactly one, unversioned library.
    assert not [n for n in names if n.startswith("liblocd.so.")]


IMPORT_WITHOUT_COMPILER = r"""
import os, shutil, subprocess, sys
# Nothing may start a process (a compiler) from here on.
def refuse(*a, **k):
    raise AssertionError("a process was started: %r" % (a,))
subprocess.Popen = refuse
os.system = refuse
os.posix_spawn = os.posix_spawnp = refuse
for name in ("cc", "gcc", "c++", "g++", "clang", "ld"):
    assert shutil.which(name) is None, name
import numpy as np
import locd, locd.abi
boxes = np.array([[0, 0, 0, 1, 1, 1], [1, 1, 1, 2, 2, 2], [3, 3, 3, 4, 4, 4]], np.float32)
assert locd.find_pairs(boxes).tolist() == [[0, 1]]
assert locd.abi.find_pairs(boxes).tolist() == [[0, 1]]
assert not any(m in sys.modules for m in ("setuptools", "distutils", "cffi.recompiler", "cffi.verifier"))
maps = open("/proc/self/maps").read()
libs = sorted({line.split()[-1] for line in maps.splitlines() if "liblocd" in line})
print(libs)
assert libs == [os.path.join(os.path.dirname(locd.__file__), "liblocd.so")], libs
print("ok")
"""


def test_imports_and_runs_without_a_compiler():
    with tempfile.TemporaryDirectory() as bindir:
        # PATH is an empty directory: no cc, gcc, ld...
        env = {"PATH": bindir, "HOME": bindir, "LANG": "C.UTF-8"}
        out = subprocess.run([sys.executable, "-c", IMPORT_WITHOUT_COMPILER], env=env,
                             cwd=bindir, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    assert out.stdout.strip().endswith("ok")


def test_one_version_everywhere():
    meson = open(os.path.join(REPO_ROOT, "meson.build")).read()
    project_version = re.search(r"project\([^)]*?version:\s*'([^']+)'", meson, re.S).group(1)
    assert locd.__version__ == locd.abi.version() == project_version
    assert importlib.metadata.version("locd") == project_version


def _source_generator():
    path = os.path.join(REPO_ROOT, "bindings", "python", "gen_cdef.py")
    spec = importlib.util.spec_from_file_location("gen_cdef", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_cdef_matches_the_public_header():
    from locd import _cdef
    include = os.path.join(REPO_ROOT, "include", "locd")
    cdef, constants = _source_generator().convert_all(include)  # every public header, locd.h first
    assert _cdef.CDEF == cdef, "locd.abi was built from other headers: reinstall (pip install .)"
    assert _cdef.CONSTANTS == constants
    # Spot checks against the header text itself (independent of the generator).
    headers = "".join(open(os.path.join(include, name)).read() for name in sorted(os.listdir(include))
                      if name.endswith(".h"))
    for name, value in re.findall(r"#define (LOCD_ERR_\w+) \((-\d+)\)", headers):
        assert constants[name] == int(value)
    declared = set(re.findall(r"LOCD_API[^;(]*?\b(locd_\w+)\s*\(", headers))
    assert declared and declared == set(re.findall(r"\b(locd_\w+)\s*\(", cdef))


def test_every_declared_function_is_exported():
    from locd._cdef import CDEF
    names = set(re.findall(r"\b(locd_\w+)\s*\(", CDEF))
    assert len(names) > 30
    for name in sorted(names):
        assert callable(getattr(locd.abi.lib, name)), name


def test_struct_layouts_agree_with_the_library():
    ffi, lib = locd.abi.ffi, locd.abi.lib
    for struct, init in (("locd_stats", lib.locd_stats_init), ("locd_engine_config", lib.locd_engine_config_init)):
        obj = ffi.new(struct + " *")
        init(obj)
        assert obj.size == ffi.sizeof(struct), struct  # the C side writes its own sizeof
    cfg = ffi.new("locd_engine_config *")
    lib.locd_engine_config_init(cfg)
    assert cfg.level == locd.abi.CONSTANTS["LOCD_LEVEL_INPROCESS"] and cfg.cell_bias == 2
    assert cfg.service_address == ffi.NULL and cfg.allocator.alloc == ffi.NULL


def test_abi_status_strings():
    lib, ffi = locd.abi.lib, locd.abi.ffi
    unknown = ffi.string(lib.locd_status_string(12345)).decode()  # what a code C does not know gives
    for name, value in locd.abi.CONSTANTS.items():
        if name.startswith("LOCD_ERR_"):
            text = ffi.string(lib.locd_status_string(value)).decode()
            assert text and text != unknown, name
