#!/usr/bin/env bash
# liblocd_mpi and locd-mpi under Open MPI (docs/cluster.md), 1 to 4 ranks
# oversubscribed on a small machine:
#   - the pairs file equals `locd pairs --out` byte for byte, and --check
#     finds level 1's pairs in level 1's order on rank 0, for random scenes
#     and hard ones (touching lattice, huge next to tiny, every box in one
#     cell, a box spanning every rank's key range, float64, one rank with
#     no boxes, one rank with all of them), both strategies;
#   - a bad box on rank 2 makes every rank fail with the same status naming
#     the same global index; every run is under `timeout`, so a hang fails.
# One JUnit testcase per run. Skipped when MPI is not installed. About 60 s
# on 2 shared cores.
set -euo pipefail
cd "$ROOT"
JUNIT="$LOCD_RESULTS/mpi.junit.xml"
OUT="$ROOT/build-ci/mpi-run"
rm -rf "$OUT"
mkdir -p "$OUT"
skip() {
  echo "locd-mpi: skipped ($1)"
  python3 - "$JUNIT" "$1" <<'PY'
import sys
from xml.sax.saxutils import quoteattr
open(sys.argv[1], "w").write('<?xml version="1.0" encoding="utf-8"?>\n<testsuites><testsuite name="mpi" tests="1" '
    'skipped="1"><testcase classname="mpi" name="locd-mpi"><skipped message=%s/></testcase></testsuite>'
    '</testsuites>\n' % quoteattr(sys.argv[2]))
PY
  exit 0
}
command -v mpirun >/dev/null || skip "mpirun not installed (openmpi-bin)"
# 10-c.sh's build holds tools/locd-mpi when MPI was found; otherwise build it here.
BUILD="$ROOT/build-ci/c"
if [ ! -x "$BUILD/tools/locd-mpi" ]; then
  BUILD="$ROOT/build-ci/mpi"
  [ -f "$BUILD/build.ninja" ] || meson setup "$BUILD" --buildtype=release -Dmpi=enabled -Dtests=disabled \
    -Dexamples=false >/dev/null || skip "MPI not found by meson (libopenmpi-dev)"
  ninja -C "$BUILD" -j "$JOBS" tools/locd tools/locd-mpi
fi
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
MPIRUN=(timeout 120 mpirun --oversubscribe --allow-run-as-root)
CASES=()
RUNS=0
t0=$(date +%s)

record() { # NAME ok|fail LOG
  if [ "$2" = ok ]; then
    CASES+=("$1|ok|")
    echo "ok   $1: $(tail -1 "$3" 2>/dev/null | cut -c1-160)"
  else
    CASES+=("$1|fail|$(tail -5 "$3" 2>/dev/null | tr '\n|' '  ')")
    echo "FAIL $1"; cat "$3" || true
  fi
}

# run SCENE NP STRATEGY [extra locd-mpi args...]: --check and --out against the reference
run() {
  local scene=$1 np=$2 strategy=$3
  shift 3
  RUNS=$((RUNS + 1))
  local tag; tag="$(basename "$scene").$np.$strategy.$RUNS"
  local log="$OUT/$tag.log" bin="$OUT/$tag.bin"
  if "${MPIRUN[@]}" -np "$np" "$BUILD/tools/locd-mpi" "$scene" --strategy "$strategy" --check --out "$bin" "$@" \
       >"$log" 2>&1 && cmp -s "$scene.ref.bin" "$bin" && grep -q '"check":"ok"' "$log"; then
    record "$(basename "$scene") ranks=$np $strategy $*" ok "$log"
  else
    record "$(basename "$scene") ranks=$np $strategy $*" fail "$log"
  fi
}

reference() { "$BUILD/tools/locd" pairs "$1" --out "$1.ref.bin" >/dev/null; }

for spec in uniform:30000:1 clustered:3000:2 mixed:60000:3 lattice:8000:4 far:20000:5; do
  IFS=: read -r kind n seed <<<"$spec"
  "$BUILD/tools/locd" gen "$kind" "$n" --seed "$seed" -o "$OUT/$kind.aabb" >/dev/null
  reference "$OUT/$kind.aabb"
  for np in 1 2 3 4; do run "$OUT/$kind.aabb" "$np" distributed; done
  for np in 2 4; do run "$OUT/$kind.aabb" "$np" master; done
done
for kind in hugetiny onecell span; do
  python3 scripts/ci/mpi_scenes.py "$kind" "$OUT/$kind.aabb" 3000
  reference "$OUT/$kind.aabb"
  for np in 2 3 4; do run "$OUT/$kind.aabb" "$np" distributed; done
  run "$OUT/$kind.aabb" 3 master
done
python3 scripts/ci/mpi_scenes.py mixed64 "$OUT/mixed.aabb64" 20000
reference "$OUT/mixed.aabb64"
run "$OUT/mixed.aabb64" 3 distributed
run "$OUT/mixed.aabb64" 2 master
# Uneven slices: one rank with no boxes, one rank with all of them.
run "$OUT/uniform.aabb" 4 distributed --counts 10000,0,10000,10000
run "$OUT/uniform.aabb" 4 distributed --counts 0,0,30000,0
run "$OUT/uniform.aabb" 3 master --counts 0,30000,0
run "$OUT/span.aabb" 4 distributed --counts 0,3001,0,0

# A bad box on rank 2: every rank fails, with the same status and index.
bad() { # KIND STATUS INDEX
  local log="$OUT/$1.log"
  python3 scripts/ci/mpi_scenes.py "$1" "$OUT/$1.aabb"
  for strategy in distributed master; do
    if ! "${MPIRUN[@]}" -np 4 "$BUILD/tools/locd-mpi" "$OUT/$1.aabb" --strategy "$strategy" >"$log" 2>&1 \
       && [ "$(grep -c "status $2 index $3:" "$log")" = 4 ]; then
      record "$1 ranks=4 $strategy: every rank reports status $2 at index $3" ok "$log"
    else
      record "$1 ranks=4 $strategy: every rank reports status $2 at index $3" fail "$log"
    fi
  done
}
bad badbox -3 2500
bad twobad -4 2100
echo "65-mpi: ${#CASES[@]} runs in $(( $(date +%s) - t0 )) s"

printf '%s\n' "${CASES[@]}" | python3 -c '
import sys
from xml.sax.saxutils import escape, quoteattr
rows = [l.rstrip("\n").split("|", 2) for l in sys.stdin if l.strip()]
fails = sum(1 for r in rows if r[1] != "ok")
out = ["<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<testsuites><testsuite name=\"mpi\" tests=\"%d\" failures=\"%d\">" % (len(rows), fails)]
for name, st, msg in rows:
    body = "" if st == "ok" else "<failure message=%s>%s</failure>" % (quoteattr(msg[:200]), escape(msg))
    out.append("<testcase classname=\"mpi\" name=%s>%s</testcase>" % (quoteattr(name), body))
out.append("</testsuite></testsuites>\n")
open(sys.argv[1], "w").write("".join(out))
sys.exit(1 if fails else 0)
' "$JUNIT"
