#!/usr/bin/env bash
# Compares two builds of locd on the same scenes, interleaved: each round
# runs every (scene, kernel, threads) case once with A and once with B, so a
# load change on a shared machine hits both; prints the median total_ms of
# each case over the rounds and B/A. Use it before and after a change to
# the core (a refactor must show no consistent B/A away from 1).
#
# usage: bench/ab.sh A_LOCD B_LOCD [SCENE.aabb ...]
#   A_LOCD, B_LOCD  two `locd` executables (e.g. a worktree of the old commit
#                   built with --buildtype=release, and the current build)
#   SCENE.aabb      scenes to run (default: uniform and mixed, 10^6 boxes,
#                   made with B's `locd gen` in a temporary directory)
#   ROUNDS=7  KERNELS="avx512 avx2"  THREADS="1 2"  REPEAT=3
#   PAUSE=0   milliseconds slept before each run (locd pairs --pause: the
#             threads idle between runs, as between a game's frames)
set -euo pipefail
A=$1 B=$2
shift 2
ROUNDS=${ROUNDS:-7}
KERNELS=${KERNELS:-avx512 avx2}
THREADS=${THREADS:-1 2}
REPEAT=${REPEAT:-3}
PAUSE=${PAUSE:-0}
PAUSE_ARG=()
if [ "$PAUSE" != 0 ]; then PAUSE_ARG=(--pause "$PAUSE"); fi # (older builds lack the option)
DIR=$(mktemp -d /tmp/locd-ab-XXXXXX)
trap 'rm -rf "$DIR"' EXIT
SCENES=("$@")
if [ ${#SCENES[@]} -eq 0 ]; then
  for kind in uniform mixed; do
    "$B" gen "$kind" 1000000 --seed 1 -o "$DIR/$kind.aabb" >/dev/null
    SCENES+=("$DIR/$kind.aabb")
  done
fi
if grep -q -w avx512f /proc/cpuinfo; then SIMD="AVX-512 and AVX2"; else SIMD="AVX2 only or less"; fi
echo "# $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores, $SIMD; each case forces its kernel with LOCD_KERNEL; A=$A B=$B"
for round in $(seq 1 "$ROUNDS"); do
  for scene in "${SCENES[@]}"; do
    for k in $KERNELS; do
      for t in $THREADS; do
        for side in A B; do
          bin=${!side}
          # The JSON is read after the run: a parser started beside it (a
          # pipe) took a core from the 2-thread runs on a 2-core machine.
          out=$(LOCD_KERNEL=$k "$bin" pairs "$scene" --threads "$t" --repeat "$REPEAT" ${PAUSE_ARG[@]+"${PAUSE_ARG[@]}"})
          ms=$(python3 -c "import sys, json; print(json.loads(sys.argv[1])['total_ms'])" "$out")
          echo "$(basename "$scene" .aabb) $k $t $side $ms"
        done
      done
    done
  done
done > "$DIR/times.txt"
python3 - "$DIR/times.txt" <<'PY'
import statistics, sys
rows = {}
for line in open(sys.argv[1]):
    scene, kernel, threads, side, ms = line.split()
    rows.setdefault((scene, kernel, int(threads)), {}).setdefault(side, []).append(float(ms))
print(f"{'scene':10s} {'kernel':7s} {'threads':>7s} {'A ms':>8s} {'B ms':>8s} {'B/A':>6s}")
for (scene, kernel, threads), d in sorted(rows.items()):
    a, b = statistics.median(d["A"]), statistics.median(d["B"])
    print(f"{scene:10s} {kernel:7s} {threads:7d} {a:8.4g} {b:8.4g} {b / a:6.3f}")
PY
