#!/usr/bin/env bash
# Determinism at the CLI: the pairs file of a scene must be byte-identical
# for --threads 1..8, float32 and float64 (--f64), and every integration
# level this build has (level 2: --workers 1..4; level 3: a `locd serve`
# started here, over a Unix socket). A level that is not built yet is a
# skipped testcase with its reason; a level that exists but fails is a
# failure. The in-process order (not only the file) is checked by
# tests/test_determinism.c. Uses the release build of step 10-c.
set -uo pipefail
cd "$ROOT"
JOBS=${JOBS:-2}
BUILD=${LOCD_DET_BUILD:-build-ci/c}
rc=0
tmp=$(mktemp -d)
server=""
cleanup() {
  if [ -n "$server" ]; then kill "$server" 2>/dev/null; wait "$server" 2>/dev/null; fi
  rm -rf "$tmp"
}
trap cleanup EXIT

# Reuses 10-c's build; configures it the same way when this step runs alone.
if [ ! -f "$BUILD/build.ninja" ]; then
  meson setup "$BUILD" --buildtype=release -Dtests=enabled >/dev/null || exit 1
fi
ninja -C "$BUILD" -j "$JOBS" >/dev/null || { echo "cannot build $BUILD"; exit 1; }
locd="$BUILD/tools/locd"

junit_case() { # NAME passed|failed MESSAGE
  python3 scripts/ci/junit.py case determinism "$1" "$2" "${3:-}" > "$LOCD_RESULTS/determinism-$1.junit.xml"
  [ "$2" = passed ] || rc=1
}
junit_skip() { # NAME REASON
  python3 - "$1" "$2" > "$LOCD_RESULTS/determinism-$1.junit.xml" <<'EOF'
import sys
from xml.sax.saxutils import quoteattr
name, why = sys.argv[1], sys.argv[2]
print('<?xml version="1.0" encoding="utf-8"?>\n<testsuites><testsuite name="determinism" tests="1" skipped="1">'
      '<testcase classname="determinism" name=%s time="0"><skipped message=%s/></testcase></testsuite></testsuites>'
      % (quoteattr(name), quoteattr(why[:300])))
EOF
  echo "SKIPPED $1: $2"
}

# compare NAME REF ARGS...: runs `locd pairs` with ARGS and compares its pairs file with REF.
# Prints the failure reason, if any, on stdout.
compare() {
  local out=$1 ref=$2
  shift 2
  if ! "$locd" pairs "$@" --out "$out" > "$out.json" 2> "$out.err"; then
    echo "locd pairs $* failed: $(tail -c 400 "$out.err")"
  elif ! cmp -s "$out" "$ref"; then
    echo "locd pairs $* wrote a different pairs file ($(stat -c %s "$out") bytes, reference $(stat -c %s "$ref"))"
  fi
}

kinds="uniform clustered mixed lattice far"
for kind in $kinds; do
  "$locd" gen "$kind" 20000 --seed 7 -o "$tmp/$kind.aabb" > /dev/null || { junit_case "gen-$kind" failed "locd gen failed"; continue; }
  "$locd" pairs "$tmp/$kind.aabb" --threads 1 --out "$tmp/$kind.ref" > /dev/null || { junit_case "threads-$kind" failed "reference run failed"; continue; }
  if [ ! -s "$tmp/$kind.ref" ]; then
    junit_case "threads-$kind" failed "the reference run found no pairs"
    continue
  fi
  why=""
  for t in 1 2 3 4 5 6 7 8; do
    why+=$(compare "$tmp/$kind.t$t" "$tmp/$kind.ref" "$tmp/$kind.aabb" --threads "$t")
    why+=$(compare "$tmp/$kind.d$t" "$tmp/$kind.ref" "$tmp/$kind.aabb" --threads "$t" --f64)
  done
  if [ -z "$why" ]; then junit_case "threads-1..8-f32-f64-$kind" passed; else echo "$why"; junit_case "threads-1..8-f32-f64-$kind" failed "$why"; fi
done

# A level "is not there" only when the library says so; any other failure of
# the probe is a failure of the level.
unsupported() { grep -qiE 'not implemented|unsupported|not available in this build' "$1"; }

probe="$tmp/uniform.aabb"
if "$locd" pairs "$probe" --level workers --out "$tmp/probe2" > /dev/null 2> "$tmp/probe2.err"; then
  for kind in $kinds; do
    why=""
    for w in 1 2 3 4; do
      why+=$(compare "$tmp/$kind.w$w" "$tmp/$kind.ref" "$tmp/$kind.aabb" --workers "$w")
    done
    if [ -z "$why" ]; then junit_case "level2-workers-1..4-$kind" passed; else echo "$why"; junit_case "level2-workers-1..4-$kind" failed "$why"; fi
  done
elif unsupported "$tmp/probe2.err"; then
  junit_skip level2-workers "level 2 not in this build: $(head -c 200 "$tmp/probe2.err")"
else
  junit_case level2-workers failed "locd pairs --level workers failed: $(tail -c 400 "$tmp/probe2.err")"
fi

# Level 3: a private socket directory (the service insists on 0700).
mkdir -m 700 "$tmp/sock"
sock="unix:$tmp/sock/locd.sock"
"$locd" serve --listen "$sock" > "$tmp/serve.log" 2>&1 &
server=$!
for _ in $(seq 1 100); do
  [ -S "$tmp/sock/locd.sock" ] && break
  kill -0 "$server" 2>/dev/null || break
  sleep 0.1
done
if [ -S "$tmp/sock/locd.sock" ] && "$locd" pairs "$probe" --service "$sock" --out "$tmp/probe3" > /dev/null 2> "$tmp/probe3.err"; then
  for kind in $kinds; do
    why=$(compare "$tmp/$kind.s" "$tmp/$kind.ref" "$tmp/$kind.aabb" --service "$sock")
    why+=$(compare "$tmp/$kind.sd" "$tmp/$kind.ref" "$tmp/$kind.aabb" --service "$sock" --f64)
    if [ -z "$why" ]; then junit_case "level3-service-$kind" passed; else echo "$why"; junit_case "level3-service-$kind" failed "$why"; fi
  done
elif unsupported "$tmp/serve.log" || { [ -f "$tmp/probe3.err" ] && unsupported "$tmp/probe3.err"; }; then
  junit_skip level3-service "level 3 not in this build: $(head -c 200 "$tmp/serve.log" "$tmp/probe3.err" 2>/dev/null)"
else
  junit_case level3-service failed "service probe failed: $(tail -c 300 "$tmp/serve.log") $(tail -c 300 "$tmp/probe3.err" 2>/dev/null)"
fi
exit $rc
