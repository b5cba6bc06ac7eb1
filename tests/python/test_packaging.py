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
    assert "liblocd.so" in names and "liblocd_narrow.so" in names and "py.typed" in names
    assert "LICENSE" in names
    # Wheels hold no symlinks: unversioned libraries only.
    assert not [n for n in names if re.match(r"liblocd(_narrow)?\.so\.", n)]


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
# liblocd and the narrow phase's liblocd_narrow (locd.abi opens it), both from the package.
pkg = os.path.dirname(locd.__file__)
assert libs == [os.path.join(pkg, "liblocd.so"), os.path.join(pkg, "liblocd_narrow.so")], libs
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


GRAFTED_LIBS = r"""
import sys, numpy as np, locd, locd.abi
import locd.pipeline as lp
print("narrow" if lp.available() else "broad")
if lp.available():
    lp.collide_pair(lp.Shape.sphere(1), (0, 0, 0, 0, 0, 0, 1), lp.Shape.box(1, 1, 1), (1, 0, 0, 0, 0, 0, 1),
                    route="fcl")
for line in open("/proc/self/maps"):
    path = line.split()[-1]
    if any(k in path for k in ("libfcl", "libccd", "liboctom")):
        print(path)
"""


def test_narrow_phase_libraries_come_from_the_wheel():
    """A repaired (manylinux) wheel loads FCL, libccd and octomap from its own locd.libs.

    CI sets LOCD_EXPECT_GRAFTED=1 (it installs the auditwheel-repaired wheel);
    a plain `pip install .` links the system's copies and is not checked here.
    """
    libs_dir = os.path.join(os.path.dirname(PKG_DIR), "locd.libs")
    expect = os.environ.get("LOCD_EXPECT_GRAFTED") == "1"
    if not os.path.isdir(libs_dir):
        if expect:
            pytest.fail("LOCD_EXPECT_GRAFTED=1 but there is no %s" % libs_dir)
        pytest.skip("not an auditwheel-repaired install")
    out = subprocess.run([sys.executable, "-c", GRAFTED_LIBS], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    kind, *paths = out.stdout.split()
    if kind == "narrow":
        assert paths, "the narrow phase ran but no FCL/libccd was mapped"
    for path in paths:
        assert os.path.dirname(path) == libs_dir, path


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
    # Every code has its own text, not the fallback for codes the library does
    # not know (a text may itself say "unknown": "stale or unknown scene id").
    fallback = ffi.string(lib.locd_status_string(-12345)).decode()
    for name, value in locd.abi.CONSTANTS.items():
        if name.startswith("LOCD_ERR_"):
            text = ffi.string(lib.locd_status_string(value)).decode()
            assert text and text != fallback, name
