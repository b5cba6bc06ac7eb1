#!/usr/bin/env bash
# The filter pipeline end to end: `locd simulate` on the example scenes
# (fast ball caught only with continuous detection, fast rock on a mesh
# terrain, broad-phase-only million boxes with idle stages, box pile, frames).
# The C tests of the pipeline (tests/test_pipeline.c) run in 10-c. One JUnit testcase per check.
set -euo pipefail
cd "$ROOT"
BUILD="$ROOT/build-ci/c"
if [ ! -f "$BUILD/build.ninja" ]; then
  meson setup "$BUILD" --buildtype=release -Dtests=enabled >/dev/null
fi
ninja -C "$BUILD" -j "$JOBS" tools/locd
# A build without libccd/FCL has the pipeline functions answer "not supported".
probe=$("$BUILD/tools/locd" simulate "$ROOT/examples/scenes/falling_balls.json" --steps 0 --quiet 2>&1 || true)
if grep -q "not supported" <<< "$probe"; then
  echo "locd was built without the narrow phase (libccd/FCL missing): skipped"
  python3 "$ROOT/scripts/ci/junit.py" case pipeline simulate passed "skipped: no narrow phase" \
    > "$LOCD_RESULTS/pipeline.junit.xml"
  exit 0
fi
python3 "$ROOT/scripts/ci/pipeline_checks.py" "$BUILD/tools/locd" "$LOCD_RESULTS/pipeline.junit.xml" \
  ${LOCD_QUICK:+--quick}
