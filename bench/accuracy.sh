#!/usr/bin/env bash
# Regenerates docs/accuracy.md, docs/accuracy.csv and docs/img/accuracy.png:
# what the broad phase's knobs cost in time. About 5-10 minutes on
# 2 cores. Extra arguments go to `locd accuracy` (e.g. --quick, --threads 2).
#   BUILD=build-accuracy bash bench/accuracy.sh
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build-accuracy}
if [ -f .venv/bin/activate ]; then
  # shellcheck disable=SC1091
  . .venv/bin/activate
fi
[ -f "$BUILD/build.ninja" ] || meson setup "$BUILD" --buildtype=release -Dtests=disabled >/dev/null
ninja -C "$BUILD" -j "${JOBS:-2}" tools/locd >/dev/null
mkdir -p docs/img
"$BUILD/tools/locd" accuracy --out docs/accuracy.md --csv docs/accuracy.csv "$@"
python3 bench/accuracy_plot.py docs/accuracy.csv docs/img/accuracy.png
echo "wrote docs/accuracy.md, docs/accuracy.csv, docs/img/accuracy.png"
