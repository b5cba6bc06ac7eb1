#!/bin/sh
# A/B of the scene's update: two builds' bench_scene run alternately on one
# scene, ROUNDS times each per moving fraction; prints one line per run and
# the medians of update/rebuild (wall and CPU) per build and fraction.
#   bench/ab_scene.sh OLD/bench/bench_scene NEW/bench/bench_scene SCENE.aabb
# Env: ROUNDS (3), MOVING ("0.01 1"), THREADS (2), FRAMES (9), STATIC (0).
set -eu
A=$1 B=$2 SCENE=$3
ROUNDS=${ROUNDS:-3} MOVING=${MOVING:-"0.01 1"} THREADS=${THREADS:-2} FRAMES=${FRAMES:-9} STATIC=${STATIC:-0}
out=$(mktemp)
trap 'rm -f "$out"' EXIT
for m in $MOVING; do
    r=0
    while [ "$r" -lt "$ROUNDS" ]; do
        for side in A B; do
            if [ "$side" = A ]; then bin=$A; else bin=$B; fi
            line=$("$bin" "$SCENE" --moving "$m" --static "$STATIC" --threads "$THREADS" --frames "$FRAMES")
            echo "$side $m $line" | tee -a "$out"
        done
        r=$((r + 1))
    done
done
python3 - "$out" <<'PY'
import json, statistics, sys
runs = {}
for line in open(sys.argv[1]):
    side, m, js = line.split(' ', 2)
    d = json.loads(js)
    runs.setdefault((m, side), []).append(d)
print('moving side update_ms rebuild_ms ratio cpu_ratio (medians)')
for (m, side), ds in sorted(runs.items()):
    med = lambda k: statistics.median(d[k] for d in ds)
    print(m, side, round(med('update_ms'), 2), round(med('rebuild_ms'), 2), round(med('ratio'), 4), round(med('cpu_ratio'), 4))
PY
