#!/usr/bin/env bash
# Linux on 64-bit ARM: cross-builds liblocd (no narrow phase, MPI or peers:
# the library needs only libc, libm and pthreads) with Debian's aarch64 cross
# compiler (scripts/cross/aarch64-linux-gnu.ini) and runs, under qemu-user
# (the cross file's exe_wrapper), the suites that compare the SIMD kernels
# byte for byte and the result with brute force: determinism (every scene
# kind, both precisions, 1 and 3 threads: NEON against scalar, scalar
# against brute force), between (the two-set query, every kernel), sweep_buckets
# (dense cells' buckets, every kernel), blocks, queries (the query tree's
# node tests on NEON registers, against brute force)
# (the building blocks against brute force) and the touching-boxes cases of
# hard_cases. Then the CLI's pairs file of a 100,000-box scene with
# LOCD_KERNEL=neon must be scalar's, byte for byte.
# JUnit: $LOCD_RESULTS/arm*.junit.xml. About 2 minutes on 2 cores (121 s
# measured; 351 s at load average 16).
set -euo pipefail
cd "$ROOT"
B=build-ci/arm
for tool in aarch64-linux-gnu-gcc qemu-aarch64; do
  command -v "$tool" >/dev/null || { echo "$tool not found: run scripts/setup.sh"; exit 1; }
done
OPTS=(--cross-file scripts/cross/aarch64-linux-gnu.ini --buildtype=release -Dtests=enabled -Dtools=true
      -Dexamples=false -Dnarrow=disabled -Dmpi=disabled -Dbench_peers=disabled)
t0=$(date +%s)
meson setup "$B" "${OPTS[@]}" --wipe >/dev/null 2>&1 || meson setup "$B" "${OPTS[@]}"
ninja -C "$B" -j "$JOBS"
t1=$(date +%s)
echo "cross build: $((t1 - t0)) s"
# The NEON kernel is compiled in (its functions are static: the symbol table names them;
# grep reads all of nm's output: grep -q would close the pipe early and pipefail fail the step).
aarch64-linux-gnu-nm "$B/lib/liblocd.so" | grep ' scan_neon' >/dev/null || { echo "no NEON kernel in liblocd.so"; exit 1; }

rc=0
meson test -C "$B" --no-rebuild --print-errorlogs --num-processes "$JOBS" determinism between blocks sweep_buckets queries || rc=$?
cp "$B/meson-logs/testlog.junit.xml" "$LOCD_RESULTS/arm.junit.xml"
LOCD_TEST_FILTER=touching meson test -C "$B" --no-rebuild --print-errorlogs hard_cases || rc=$?
cp "$B/meson-logs/testlog.junit.xml" "$LOCD_RESULTS/arm-hard.junit.xml"
t2=$(date +%s)
echo "suites under qemu: $((t2 - t1)) s"

# The command-line tool under qemu: NEON's pairs file is scalar's.
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
run() { qemu-aarch64 -L /usr/aarch64-linux-gnu "$@"; }
why=""
for kind in uniform clustered mixed; do
  run "$B/tools/locd" gen "$kind" 100000 --seed 5 -o "$tmp/$kind.aabb" >/dev/null
  LOCD_KERNEL=scalar run "$B/tools/locd" pairs "$tmp/$kind.aabb" --threads 2 --out "$tmp/$kind.scalar" >/dev/null
  LOCD_KERNEL=neon run "$B/tools/locd" pairs "$tmp/$kind.aabb" --threads 2 --out "$tmp/$kind.neon" >/dev/null
  if [ ! -s "$tmp/$kind.scalar" ]; then
    why+="$kind: the scalar run found no pairs; "
  elif ! cmp -s "$tmp/$kind.scalar" "$tmp/$kind.neon"; then
    why+="$kind: NEON's pairs file differs from scalar's; "
  fi
done
if [ -z "$why" ]; then
  python3 scripts/ci/junit.py case arm cli-neon-equals-scalar passed > "$LOCD_RESULTS/arm-cli.junit.xml"
else
  echo "$why"
  python3 scripts/ci/junit.py case arm cli-neon-equals-scalar failed "$why" > "$LOCD_RESULTS/arm-cli.junit.xml"
  rc=1
fi
t3=$(date +%s)
echo "CLI under qemu: $((t3 - t2)) s; step total: $((t3 - t0)) s"
exit $rc
