#!/usr/bin/env bash
# Windows x86_64: cross-builds locd.dll and the C tests that apply to it with
# Debian's mingw-w64 (scripts/cross/mingw64.ini; level 1, the narrow phase's
# stubs, levels 2 and 3 as LOCD_ERR_UNSUPPORTED stubs) and runs them under
# wine through `meson test` (the cross file's exe_wrapper). The suites are
# listed in tests/meson.build (windows_tests). JUnit: $LOCD_RESULTS/windows.junit.xml
set -euo pipefail
cd "$ROOT"
B=build-ci/windows
for tool in x86_64-w64-mingw32-gcc-posix /usr/lib/wine/wine64; do
  command -v "$tool" >/dev/null || { echo "$tool not found: run scripts/setup.sh"; exit 1; }
done
# A wine prefix of this build's own (never ~/.wine). Creating it (wineboot)
# is the slow part of a first wine start. The wineserver is kept running
# for the whole step (-p) and started before `meson test`: otherwise the
# services wine starts with the first test inherit that test's stdout, and
# Meson waits for them to exit before it sees the test end.
export WINEPREFIX="$ROOT/build-ci/wine-prefix" WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml="
OPTS=(--cross-file scripts/cross/mingw64.ini --buildtype=release -Dtests=enabled -Dtools=false -Dexamples=false
      -Dnarrow=disabled -Dmpi=disabled -Dbench_peers=disabled)
t0=$(date +%s)
meson setup "$B" "${OPTS[@]}" --wipe >/dev/null 2>&1 || meson setup "$B" "${OPTS[@]}"
ninja -C "$B" -j "$JOBS"
t1=$(date +%s)
fresh=$([ -d "$WINEPREFIX/drive_c" ] && echo reused || echo created)
/usr/lib/wine/wineserver -p
trap '/usr/lib/wine/wineserver -k >/dev/null 2>&1 || true' EXIT
/usr/lib/wine/wine64 wineboot -i >/dev/null 2>&1
t2=$(date +%s)
echo "cross build: $((t1 - t0)) s; wine prefix $fresh and started: $((t2 - t1)) s"
x86_64-w64-mingw32-objdump -p "$B"/lib/liblocd*.dll | grep 'DLL Name'
rc=0
meson test -C "$B" --print-errorlogs --num-processes "$JOBS" || rc=$?
t3=$(date +%s)
echo "tests under wine: $((t3 - t2)) s"
cp "$B/meson-logs/testlog.junit.xml" "$LOCD_RESULTS/windows.junit.xml"
exit $rc
