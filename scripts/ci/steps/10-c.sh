#!/usr/bin/env bash
# Release build of the library, the CLI and the C test suite (Unity), then
# the exactness suites again with each narrower SIMD kernel forced
# (LOCD_KERNEL caps the run-time choice; test_determinism also compares the
# kernels byte for byte inside one process).
set -euo pipefail
cd "$ROOT"
meson setup build-ci/c --buildtype=release -Dtests=enabled --wipe >/dev/null 2>&1 || meson setup build-ci/c --buildtype=release -Dtests=enabled
ninja -C build-ci/c -j "$JOBS"
rc=0
meson test -C build-ci/c --print-errorlogs --num-processes "$JOBS" || rc=$?
cp build-ci/c/meson-logs/testlog.junit.xml "$LOCD_RESULTS/c.junit.xml"
for kernel in avx2 scalar; do
    LOCD_KERNEL=$kernel meson test -C build-ci/c --no-rebuild --print-errorlogs --num-processes "$JOBS" \
        engine hard_cases hard_cases_shapes hard_cases_input determinism || rc=$?
    sed "s/<testsuite name=\"\([^\"]*\)\"/<testsuite name=\"\1 (LOCD_KERNEL=$kernel)\"/; s/<testcase name=\"/<testcase name=\"$kernel: /g" \
        build-ci/c/meson-logs/testlog.junit.xml >"$LOCD_RESULTS/c-$kernel.junit.xml"
done
exit $rc
