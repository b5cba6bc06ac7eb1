#!/usr/bin/env bash
# The exactness promise at scale: 1,000,000 uniform cubes and 1,000,000
# mixed-size boxes through `locd pairs` at 1 and 2 threads (and float64):
# byte-identical pair files, equal to an independent exact broad phase
# (tests/tools/check_pairs.c: a float hash grid, no octree) and to a plain
# scan for sampled boxes. Uses the build of step 10-c.
set -uo pipefail
cd "$ROOT"
B=build-ci/c
[ -x $B/tools/locd ] || { meson setup $B -Dtests=enabled >/dev/null && ninja -C $B; }
ninja -C $B tests/check_pairs >/dev/null
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
out="$LOCD_RESULTS/exact-1m.junit.xml"
cases=""
nfail=0
record() { # name ok message
  if [ "$2" = 1 ]; then cases="$cases<testcase classname=\"exact-1m\" name=\"$1\"/>"
  else cases="$cases<testcase classname=\"exact-1m\" name=\"$1\"><failure message=\"$3\"/></testcase>"; nfail=$((nfail+1)); fi
}
for kind in uniform mixed; do
  $B/tools/locd gen $kind 1000000 --seed 7 -o $T/$kind.aabb >/dev/null
  $B/tools/locd pairs $T/$kind.aabb --threads 1 --out $T/$kind.1.bin > $T/$kind.1.json
  $B/tools/locd pairs $T/$kind.aabb --threads 2 --out $T/$kind.2.bin > $T/$kind.2.json
  $B/tools/locd pairs $T/$kind.aabb --threads 2 --f64 --out $T/$kind.d.bin > $T/$kind.d.json
  cat $T/$kind.2.json
  if cmp -s $T/$kind.1.bin $T/$kind.2.bin; then record "$kind-1M-threads-1-equals-2" 1; else record "$kind-1M-threads-1-equals-2" 0 "pair files differ"; fi
  if cmp -s $T/$kind.1.bin $T/$kind.d.bin; then record "$kind-1M-f32-equals-f64" 1; else record "$kind-1M-f32-equals-f64" 0 "pair files differ"; fi
  if $B/tests/check_pairs $T/$kind.aabb $T/$kind.2.bin --samples 100; then record "$kind-1M-independent-check" 1
  else record "$kind-1M-independent-check" 0 "differs from the independent grid"; fi
done
echo "<?xml version=\"1.0\"?><testsuites><testsuite name=\"exact-1m\">$cases</testsuite></testsuites>" > "$out"
[ $nfail -eq 0 ]
