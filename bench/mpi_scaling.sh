#!/usr/bin/env bash
# Measures locd-mpi (docs/cluster.md): both strategies, 1..4 ranks, on
# uniform cubes, one JSON line per rank per run into
# bench/results/mpi_scaling.jsonl (with "run" = the scene and setting).
# Also `locd pairs` on the same scene for the single-process reference
# (peak memory from /usr/bin/time or getrusage of the child).
#   bench/mpi_scaling.sh BUILD_DIR [SIZES...]      (default sizes: 1000000 10000000)
# On a small shared machine the ranks are oversubscribed: read the work,
# the bytes and the memory, not the times (docs/cluster.md).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:?usage: bench/mpi_scaling.sh BUILD_DIR [SIZES...]}
shift

[ $# -gt 0 ] && SIZES=("$@") || SIZES=(1000000 10000000)
OUT=bench/results/mpi_scaling.jsonl
SCENES=${LOCD_SCENES:-/tmp/locd-mpi-scenes}
mkdir -p "$SCENES" bench/results
: > "$OUT"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
for n in "${SIZES[@]}"; do
  scene="$SCENES/uniform-$n.aabb"
  [ -f "$scene" ] || "$BUILD/tools/locd" gen uniform "$n" -o "$scene" >/dev/null
  # the single-process reference: level 1, one thread, its peak memory
  python3 - "$BUILD/tools/locd" "$scene" "$n" >> "$OUT" <<'PY'
import json, resource, subprocess, sys
locd, scene, n = sys.argv[1:]
out = subprocess.run([locd, "pairs", scene, "--threads", "1"], capture_output=True, text=True, check=True).stdout
rec = json.loads(out.strip().splitlines()[-1])
rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
print(json.dumps({"run": "locd-pairs", "n": int(n), "ranks": 1, "strategy": "level1",
                  "total_ms": rec["total_ms"], "pairs": rec["pairs"], "peak_rss_kb": rss}))
PY
  for strategy in distributed master; do
    for np in 1 2 3 4; do
      echo "n=$n $strategy np=$np" >&2
      # read after the run: no parser beside the ranks
      res=$(timeout 900 mpirun --oversubscribe --allow-run-as-root -np "$np" "$BUILD/tools/locd-mpi" "$scene" \
        --strategy "$strategy")
      printf '%s\n' "$res" | python3 -c '
import json, sys
for line in sys.stdin:
    line = line.strip()
    if line.startswith("{"):
        rec = json.loads(line)
        rec["run"] = "locd-mpi"
        print(json.dumps(rec))
' >> "$OUT"
    done
  done
done
echo "wrote $OUT" >&2
