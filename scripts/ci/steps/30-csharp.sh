#!/usr/bin/env bash
# C# binding (bindings/unity/Runtime, also reachable as bindings/csharp/Locd):
# compile it, its tests and its benchmark with mono's mcs at C# 7.2, check the
# struct layouts against the C compiler, run the tests under mono.
# JUnit: $LOCD_RESULTS/csharp.junit.xml
set -euo pipefail
cd "$ROOT"
OUT=build-ci/cs
mkdir -p "$OUT"

# The native library: reuse step 10-c's build when there is one.
if [ -e build-ci/c/lib/liblocd.so ] && [ -x build-ci/c/tools/locd ] && [ -x build-ci/c/lib/locd-worker ]; then
  BUILD=build-ci/c
else
  BUILD=build-ci/cs/native
  meson setup "$BUILD" --buildtype=release -Dtests=disabled -Dexamples=false >/dev/null 2>&1 \
    || meson setup "$BUILD" --buildtype=release -Dtests=disabled -Dexamples=false --wipe
  ninja -C "$BUILD" -j "${JOBS:-2}"
fi
LIBDIR="$ROOT/$BUILD/lib"
echo "native library: $LIBDIR"

# mono resolves [DllImport("locd")] to liblocd.so: the unversioned symlink.
test -e "$LIBDIR/liblocd.so"

# The Unity package's Runtime is the only copy of the sources; the csharp
# path is a symlink to it, so they cannot drift. Fail loudly if that changes.
test "$(readlink bindings/csharp/Locd)" = "../unity/Runtime"

MCS="mcs -langversion:7.2 -unsafe -warn:4 -warnaserror+ -nologo"
$MCS -target:library -out:"$OUT/Locd.dll" bindings/unity/Runtime/*.cs
$MCS -r:"$OUT/Locd.dll" -out:"$OUT/LocdTests.exe" bindings/csharp/tests/*.cs
$MCS -r:"$OUT/Locd.dll" -out:"$OUT/LocdBench.exe" bindings/csharp/bench/*.cs
# The iOS branch (DllImport("__Internal")) compiles too, and the package's
# JSON files parse.
$MCS -target:library -define:UNITY_IOS -out:"$OUT/Locd.ios.dll" bindings/unity/Runtime/*.cs
python3 -m json.tool bindings/unity/package.json > /dev/null
python3 -m json.tool bindings/unity/Runtime/Locd.asmdef > /dev/null
# The Unity sample compiles against a stub of the UnityEngine API it uses.
$MCS -target:library -out:"$OUT/UnityEngine.dll" bindings/csharp/tests/unity-stub/*.cs
$MCS -target:library -r:"$OUT/Locd.dll" -r:"$OUT/UnityEngine.dll" -out:"$OUT/LocdSample.dll" \
  bindings/unity/Samples~/CollisionPairs/*.cs

cc -std=c99 -Wall -Wextra -Werror -I include -o "$OUT/layout" bindings/csharp/tests/layout.c
"$OUT/layout" > "$OUT/layout.txt"

# The Unity package's Linux plugin: built without optional dependencies, it
# must need nothing but glibc (checked with ldd), and the tests run on it too.
bash bindings/unity/build-plugin.sh "$ROOT/$OUT/plugin" > "$OUT/plugin.log"
PLUGIN=bindings/unity/Plugins/x86_64/liblocd.so
if ldd "$PLUGIN" | grep -v -E 'linux-vdso|libc\.so|libm\.so|ld-linux' | grep -q '=>'; then
  echo "the plugin needs more than glibc:"; ldd "$PLUGIN"; exit 1
fi

run_tests() { # LIBDIR JUNIT
  local log="$OUT/$(basename "$2" .xml).log" rc=0
  LD_LIBRARY_PATH="$1${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" \
  LOCD_LAYOUT="$ROOT/$OUT/layout.txt" LOCD_CLI="$ROOT/$BUILD/tools/locd" \
    mono --debug "$OUT/LocdTests.exe" "$2" > "$log" 2>&1 || rc=$?
  cat "$log"
  # A native crash on a thread mono does not know can end the process with
  # status 0 after the summary line: treat its report as a failure.
  if grep -q -E 'Native Crash Reporting|Got a SIG' "$log"; then
    echo "mono reported a native crash"; rc=1
  fi
  return $rc
}
rc=0
run_tests "$LIBDIR" "$LOCD_RESULTS/csharp.junit.xml" || rc=$?
echo "---- again on the Unity plugin build ($PLUGIN) ----"
prc=0
run_tests "$ROOT/bindings/unity/Plugins/x86_64" "$OUT/csharp-plugin.junit.xml" || prc=$?
# One JUnit case for the second run (its tests are the same ones).
python3 scripts/ci/junit.py case csharp "unity_plugin_build_passes_the_suite" \
  "$([ $prc -eq 0 ] && echo passed || echo failed)" "see $OUT/csharp-plugin.junit.log" \
  > "$LOCD_RESULTS/csharp-plugin.junit.xml"
[ $prc -eq 0 ] || rc=$prc
exit $rc
