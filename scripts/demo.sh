#!/usr/bin/env bash
# Builds locd (release) and runs the main job on the built-in default scene:
# the paper's Tables 1-2 (1,000,000 and 2,000,000 uniform cubes, every thread
# count of this machine, median of 5 runs), printed as a table.
#   scripts/demo.sh [extra `locd bench` options, e.g. --sizes 1e5 --repeat 3]
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -f .venv/bin/activate ]; then . .venv/bin/activate; fi
if [ ! -f build/build.ninja ]; then
  meson setup build --buildtype=release >/dev/null
fi
ninja -C build >/dev/null
exec build/tools/locd bench "$@"
