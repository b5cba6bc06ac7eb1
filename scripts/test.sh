#!/usr/bin/env bash
# Builds locd and runs every test suite (C, Python, C#, sanitizers, ABI,
# valgrind, ...). Each step is a script in scripts/ci/steps/, run in name
# order; each leaves JUnit XML in $LOCD_RESULTS. The last line is the total:
# "N passed, N failed, N skipped". Exits non-zero if any step or test failed.
#   LOCD_STEPS="10-c 20-python"  runs only those steps (default: all)
#   LOCD_QUICK=1                 lets steps skip their slow parts
set -u
cd "$(dirname "$0")/.."
ROOT=$(pwd)
export ROOT
export LOCD_RESULTS="$ROOT/build-ci/results"
export LOCD_LOGS="$ROOT/build-ci/logs"
rm -rf "$LOCD_RESULTS" "$LOCD_LOGS"
mkdir -p "$LOCD_RESULTS" "$LOCD_LOGS"
if [ -f "$ROOT/.venv/bin/activate" ]; then
  # shellcheck disable=SC1091
  . "$ROOT/.venv/bin/activate"
fi
export JOBS=${JOBS:-$(nproc)}

failed_steps=()
for step in "$ROOT"/scripts/ci/steps/*.sh; do
  name=$(basename "$step" .sh)
  if [ -n "${LOCD_STEPS:-}" ] && ! [[ " $LOCD_STEPS " == *" $name "* ]]; then
    continue
  fi
  start=$(date +%s)
  echo "==> step $name"
  if bash "$step" > "$LOCD_LOGS/$name.log" 2>&1; then
    status=passed
  else
    status=failed
    failed_steps+=("$name")
    echo "---- last 60 lines of $name.log ----"
    tail -n 60 "$LOCD_LOGS/$name.log"
    echo "------------------------------------"
  fi
  secs=$(( $(date +%s) - start ))
  echo "    $name: $status (${secs}s)"
  python3 "$ROOT/scripts/ci/junit.py" step "$name" "$status" "$secs" "$LOCD_LOGS/$name.log" \
    > "$LOCD_RESULTS/step-$name.junit.xml"
done

python3 "$ROOT/scripts/ci/junit.py" summary "$LOCD_RESULTS"
summary_rc=$?
if [ ${#failed_steps[@]} -ne 0 ]; then
  echo "failed steps: ${failed_steps[*]}"
  exit 1
fi
exit $summary_rc
