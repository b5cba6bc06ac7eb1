#!/usr/bin/env bash
# Measures integration levels 2 and 3 against level 1 (per-call cost at
# n = 1,000, 100,000 and 1,000,000) and the service's throughput with many
# small jobs, and writes both tables into docs/levels.md between its
# "levels-table" markers.
#
# usage: bench/levels.sh [BUILD_DIR]   (default build-levels-bench, a release build)
#   THREADS=K   threads of level 1 / workers of level 2 / engine threads of the
#               service (default: the number of cores)
#   SIZES=...   default 1e3,1e5,1e6
#   OUT=FILE    write the tables there instead of docs/levels.md
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${1:-$ROOT/build-levels-bench}
T=${THREADS:-$(nproc)}
SIZES=${SIZES:-1e3,1e5,1e6}
if [ ! -f "$BUILD/build.ninja" ]; then
  meson setup "$BUILD" "$ROOT" --buildtype=release >/dev/null
fi
ninja -C "$BUILD" -j2 tools/locd lib/locd-worker bench/locd-bench-levels >/dev/null
DIR=$(mktemp -d /tmp/locd-bench-XXXXXX)
P1= P2=
cleanup() { [ -n "$P1" ] && kill "$P1" 2>/dev/null; [ -n "$P2" ] && kill "$P2" 2>/dev/null; wait 2>/dev/null; rm -rf "$DIR"; }
trap cleanup EXIT
# Per-call cost: one runner with as many engine threads as level 1 has.
"$BUILD/tools/locd" serve --listen "unix:$DIR/calls.sock" --threads 1 --engine-threads "$T" 2>"$DIR/calls.log" &
P1=$!
# Throughput: one single-threaded runner per core.
"$BUILD/tools/locd" serve --listen "unix:$DIR/jobs.sock" --threads "$T" --engine-threads 1 2>"$DIR/jobs.log" &
P2=$!
for i in $(seq 100); do
  grep -q listening "$DIR/calls.log" 2>/dev/null && grep -q listening "$DIR/jobs.log" 2>/dev/null && break
  sleep 0.1
done
LOCD_WORKER="$BUILD/lib/locd-worker" "$BUILD/bench/locd-bench-levels" --calls "unix:$DIR/calls.sock" \
  --jobs "unix:$DIR/jobs.sock" --threads "$T" --sizes "$SIZES" --out "$DIR/table.md"
CPU=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
{
  echo "Measured $(date -u +%Y-%m-%d) on $CPU, $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)"
  echo "(\`THREADS=$T bench/levels.sh\`; medians of repeated calls; level 1 = $T threads, level 2 = $T"
  echo "worker processes, level 3 = a local \`locd serve\` over a Unix socket, one runner of $T threads)."
  echo
  cat "$DIR/table.md"
} > "$DIR/section.md"
if [ -n "${OUT:-}" ]; then
  cp "$DIR/section.md" "$OUT"
else
  python3 - "$ROOT/docs/levels.md" "$DIR/section.md" <<'PY'
import sys
doc, sec = sys.argv[1], open(sys.argv[2]).read()
text = open(doc).read()
a, b = '<!-- levels-table:begin -->', '<!-- levels-table:end -->'
i, j = text.index(a) + len(a), text.index(b)
open(doc, 'w').write(text[:i] + '\n' + sec + text[j:])
PY
  echo "bench/levels.sh: tables written into docs/levels.md"
fi
cat "$DIR/section.md"
