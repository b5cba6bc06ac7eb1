#!/usr/bin/env bash
# Release build of the library, the CLI and the C test suite (cmocka).
set -euo pipefail
cd "$ROOT"
meson setup build-ci/c --buildtype=release -Dtests=enabled --wipe >/dev/null 2>&1 || meson setup build-ci/c --buildtype=release -Dtests=enabled
ninja -C build-ci/c -j "$JOBS"
rc=0
meson test -C build-ci/c --print-errorlogs --num-processes "$JOBS" || rc=$?
cp build-ci/c/meson-logs/testlog.junit.xml "$LOCD_RESULTS/c.junit.xml"
exit $rc
