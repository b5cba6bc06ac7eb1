#!/usr/bin/env bash
# locd-mpi under Open MPI: 1, 2 and 3 ranks (oversubscribed on a small
# machine) must report level 1's pairs in level 1's order (--check) and
# write the same pairs file as `locd pairs`. One JUnit testcase per (scene,
# ranks). Skipped when MPI is not installed.
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
CASES=()
for spec in uniform:30000:1 clustered:3000:2 mixed:60000:3 lattice:8000:4 far:20000:5; do
  IFS=: read -r kind n seed <<<"$spec"
  "$BUILD/tools/locd" gen "$kind" "$n" --seed "$seed" -o "$OUT/$kind.aabb" >/dev/null
  "$BUILD/tools/locd" pairs "$OUT/$kind.aabb" --out "$OUT/$kind.ref.bin" >/dev/null
  for np in 1 2 3; do
    name="$kind n=$n ranks=$np"
    log="$OUT/$kind.$np.log"
    if timeout 120 mpirun --oversubscribe --allow-run-as-root -np "$np" "$BUILD/tools/locd-mpi" "$OUT/$kind.aabb" \
         --check --out "$OUT/$kind.$np.bin" >"$log" 2>&1 && cmp -s "$OUT/$kind.ref.bin" "$OUT/$kind.$np.bin"; then
      CASES+=("$name|ok|")
      echo "ok   $name: $(tail -1 "$log")"
    else
      CASES+=("$name|fail|$(tail -5 "$log" | tr '\n|' '  ')")
      echo "FAIL $name"; cat "$log"
    fi
  done
done
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
