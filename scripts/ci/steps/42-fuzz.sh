#!/usr/bin/env bash
# libFuzzer harnesses (tests/fuzz/, docs/ci.md "Fuzzing") under ASan + UBSan,
# each for a fixed number of inputs: first its whole committed corpus (every
# crash found so far is a file there, so this replays the regressions), then
# new inputs mutated from it. Any crash, sanitizer report, leak, hang (the
# service neither answering nor closing) or input slower than 60 s fails.
# One JUnit testcase per harness. About 2 min on 2 cores, build included.
#   LOCD_FUZZ_RUNS_SESSION / _SERVICE / _SCENE   inputs per harness
set -uo pipefail
cd "$ROOT"
export LOCD_FUZZ_BUILD=${LOCD_FUZZ_BUILD:-build-ci/fuzz}
export LOCD_FUZZ_OUT="$LOCD_FUZZ_BUILD/out"
rc=0

if ! command -v clang >/dev/null; then
  python3 scripts/ci/junit.py case fuzz build failed "clang is missing: run scripts/setup.sh" > "$LOCD_RESULTS/fuzz-build.junit.xml"
  exit 1
fi
if ! bash scripts/fuzz.sh build; then
  python3 scripts/ci/junit.py case fuzz build failed "the harnesses did not build (see the step log)" \
    > "$LOCD_RESULTS/fuzz-build.junit.xml"
  exit 1
fi
rm -rf "$LOCD_FUZZ_OUT"
shm_before=$(ls /dev/shm 2>/dev/null | grep -c '^locd-fuzz' || true)

# harness RUNS: one testcase.
fuzz() {
  local h=$1 runs=$2 st=0 start secs log="$LOCD_FUZZ_OUT/$1.log"
  mkdir -p "$LOCD_FUZZ_OUT"
  echo "== fuzz $h: $runs inputs"
  start=$(date +%s)
  bash scripts/fuzz.sh "$h" "$runs" > "$log" 2>&1 || st=$?
  secs=$(( $(date +%s) - start ))
  grep -E '^#[0-9]+[[:space:]]+(INITED|DONE)|stat::number_of_executed_units|stat::average_exec_per_sec' "$log"
  if [ "$st" -eq 0 ] && grep -q 'DONE' "$log"; then
    echo "   passed in ${secs}s"
    python3 scripts/ci/junit.py case fuzz "$h" passed > "$LOCD_RESULTS/fuzz-$h.junit.xml"
  else
    echo "FAILED: fuzz $h (exit $st, ${secs}s); the input is in $LOCD_FUZZ_OUT/$h/ (crash-*, leak-*, timeout-*)"
    tail -n 80 "$log"
    python3 scripts/ci/junit.py case fuzz "$h" failed "exit $st: $(grep -E 'ERROR|runtime error|fuzz_|SUMMARY' "$log" | head -c 1500) $(tail -c 1500 "$log")" \
      > "$LOCD_RESULTS/fuzz-$h.junit.xml"
    rc=1
  fi
}

fuzz session "${LOCD_FUZZ_RUNS_SESSION:-100000}"
fuzz service "${LOCD_FUZZ_RUNS_SERVICE:-10000}" # (about 190 inputs a second: each runs a real service)
fuzz scene "${LOCD_FUZZ_RUNS_SCENE:-30000}"

# The harnesses' segments live in a private /dev/shm when the system allows
# it, and are removed otherwise: none may be left.
shm_after=$(ls /dev/shm 2>/dev/null | grep -c '^locd-fuzz' || true)
if [ "$shm_after" -gt "$shm_before" ]; then
  echo "FAILED: the fuzzers left segments in /dev/shm: $(ls /dev/shm | grep '^locd-fuzz')"
  python3 scripts/ci/junit.py case fuzz dev-shm failed "segments left in /dev/shm" > "$LOCD_RESULTS/fuzz-dev-shm.junit.xml"
  rc=1
else
  python3 scripts/ci/junit.py case fuzz dev-shm passed > "$LOCD_RESULTS/fuzz-dev-shm.junit.xml"
fi
exit $rc
