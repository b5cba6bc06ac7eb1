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
for asmdef in bindings/unity/Runtime/Locd.asmdef bindings/unity/Samples~/*/*.asmdef; do
  python3 -m json.tool "$asmdef" > /dev/null
done
# Each Unity sample compiles against a stub of the UnityEngine and
# Unity.Collections API it uses.
$MCS -target:library -out:"$OUT/UnityEngine.dll" bindings/csharp/tests/unity-stub/*.cs
for sample in bindings/unity/Samples~/*/; do
  $MCS -target:library -r:"$OUT/Locd.dll" -r:"$OUT/UnityEngine.dll" -out:"$OUT/LocdSample-$(basename "$sample").dll" \
    "$sample"*.cs
done

cc -std=c99 -Wall -Wextra -Werror -I include -o "$OUT/layout" bindings/csharp/tests/layout.c
"$OUT/layout" > "$OUT/layout.txt"

# The Unity package's plugins (Linux, and Windows cross-built with mingw-w64):
# built without optional dependencies, the Linux one must need nothing but
# glibc (checked with ldd), the Windows one nothing but KERNEL32 and msvcrt;
# the tests run on the Linux one too (the Windows one's C tests: step 35).
bash bindings/unity/build-plugin.sh "$ROOT/$OUT/plugin" > "$OUT/plugin.log"
PLUGIN=bindings/unity/Plugins/Linux/x86_64/liblocd.so
WINPLUGIN=bindings/unity/Plugins/Windows/x86_64/locd.dll
if ldd "$PLUGIN" | grep -v -E 'linux-vdso|libc\.so|libm\.so|ld-linux' | grep -q '=>'; then
  echo "the plugin needs more than glibc:"; ldd "$PLUGIN"; exit 1
fi
if x86_64-w64-mingw32-objdump -p "$WINPLUGIN" | grep 'DLL Name' | grep -v -i -E 'KERNEL32\.dll|msvcrt\.dll'; then
  echo "the Windows plugin needs more than KERNEL32.dll and msvcrt.dll"; exit 1
fi

# Package checks, one JUnit case each (a failure fails the step at the end):
# no public Locd type name clashes with UnityEngine / Unity.Collections /
# Unity.Jobs / Unity.Mathematics; Native declares exactly the exported
# functions of the CI library, of the Linux plugin and of the Windows DLL;
# every asset has its .meta (unique, stable GUIDs), LICENSE.md = LICENSE.
checks_rc=0
check() { # NAME COMMAND...
  local name=$1 rc=0; shift
  echo "---- check: $name ----"
  "$@" > "$OUT/check-$name.log" 2>&1 || rc=$?
  cat "$OUT/check-$name.log"
  python3 scripts/ci/junit.py case csharp "$name" "$([ $rc -eq 0 ] && echo passed || echo failed)" \
    "$(tail -n 20 "$OUT/check-$name.log")" > "$LOCD_RESULTS/csharp-check-$name.junit.xml"
  [ $rc -eq 0 ] || checks_rc=1
}
check unity_names_no_clash bash bindings/csharp/tests/unity-names.sh "$OUT/Locd.dll" "$OUT/names"
check native_covers_library_exports bash bindings/csharp/tests/native-coverage.sh "$OUT/Locd.dll" "$OUT/cov" "$LIBDIR"
check native_covers_linux_plugin_exports bash bindings/csharp/tests/native-coverage.sh "$OUT/Locd.dll" \
  "$OUT/cov-linux" "$(dirname "$PLUGIN")"
check native_covers_windows_dll_exports bash bindings/csharp/tests/native-coverage.sh "$OUT/Locd.dll" \
  "$OUT/cov-windows" "$(dirname "$WINPLUGIN")"
check unity_package_meta_license python3 scripts/unity_package.py check

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
run_tests "$ROOT/$(dirname "$PLUGIN")" "$OUT/csharp-plugin.junit.xml" || prc=$?
# One JUnit case for the second run (its tests are the same ones).
python3 scripts/ci/junit.py case csharp "unity_plugin_build_passes_the_suite" \
  "$([ $prc -eq 0 ] && echo passed || echo failed)" "see $OUT/csharp-plugin.junit.log" \
  > "$LOCD_RESULTS/csharp-plugin.junit.xml"
[ $prc -eq 0 ] || rc=$prc
[ $checks_rc -eq 0 ] || rc=1
exit $rc
