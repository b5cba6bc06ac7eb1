#!/bin/sh
# A/B of the scene's update as the issue times it: two builds' `locd frames`
# run alternately on one scene (A B, then B A, ...), ROUNDS times each;
# prints one line per run and, per build, the medians of update_ms,
# rebuild_ms and update/rebuild (and of the runs' means per frame, where
# the build prints them). Each run's ratio is its own frames'
# medians, so a load change on a shared machine hits both builds alike.
#   bench/ab_frames.sh OLD/tools/locd NEW/tools/locd SCENE.aabb
# Env: ROUNDS (6), MOVING (1), FRAMES (15), THREADS (2), STATIC (0), PAUSE (0: ms
# asleep before each update and rebuild, locd frames --pause).
# Build the old commit apart, e.g.
#   git worktree add /tmp/old REV && cd /tmp/old &&
#   meson setup build -Dbuildtype=release -Dtests=disabled && ninja -C build tools/locd
set -eu
A=$1 B=$2 SCENE=$3
ROUNDS=${ROUNDS:-6} MOVING=${MOVING:-1} FRAMES=${FRAMES:-15} THREADS=${THREADS:-2} STATIC=${STATIC:-0} PAUSE=${PAUSE:-0}
pause_arg=""
if [ "$PAUSE" != 0 ]; then pause_arg="--pause $PAUSE"; fi # (older builds lack the option)
out=$(mktemp)
trap 'rm -f "$out"' EXIT
r=0
while [ "$r" -lt "$ROUNDS" ]; do
    if [ $((r % 2)) -eq 0 ]; then order="A B"; else order="B A"; fi
    for side in $order; do
        if [ "$side" = A ]; then bin=$A; else bin=$B; fi
        # shellcheck disable=SC2086
        line=$("$bin" frames "$SCENE" --moving "$MOVING" --static "$STATIC" --frames "$FRAMES" --threads "$THREADS" $pause_arg)
        echo "$side $line" | tee -a "$out"
    done
    r=$((r + 1))
done
python3 - "$out" <<'PY'
import json, statistics, sys
runs = {}
for line in open(sys.argv[1]):
    side, js = line.split(' ', 1)
    runs.setdefault(side, []).append(json.loads(js))
print('side update_ms rebuild_ms ratio (medians of the runs\' medians) ratios; then the means per frame')
for side, ds in sorted(runs.items()):
    med = lambda k: statistics.median(d[k] for d in ds)
    print(side, round(med('update_ms'), 2), round(med('rebuild_ms'), 2), round(med('ratio'), 4),
          ' '.join('%.3f' % d['ratio'] for d in ds))
    if all('ratio_mean' in d for d in ds):  # (builds before the means were printed have none)
        print(side, 'mean', round(med('update_mean_ms'), 2), round(med('rebuild_mean_ms'), 2),
              round(med('ratio_mean'), 4), ' '.join('%.3f' % d['ratio_mean'] for d in ds))
PY
