#!/usr/bin/env bash
# The whole C test suite again under the sanitizers, each in its own build
# directory (docs/ci.md):
#   build-ci/asan  AddressSanitizer + UndefinedBehaviorSanitizer, no recovery:
#                  any out-of-bounds access, use-after-free, leak or UB report
#                  ends the test with a failure;
#   build-ci/tsan  ThreadSanitizer: any data race fails the test.
# Heavy scenes run only once, in the normal build (10-c): the tests read
# LOCD_TEST_HEAVY=0 and shrink their scenes (tests/README.md).
# LOCD_SANITIZERS="asan" or "tsan" runs one of the two.
#
# TSan runs every test but those in LOCD_TSAN_SKIP (default: the three
# hard_cases suites, blocks and mpi). The hard_cases suites check exactness
# on hard inputs through every engine: they run in full in 10-c and under
# ASan here, but under TSan they alone take over 6 minutes on 2 cores, and
# the threaded code they drive (the level-1 pool, the workers, the service)
# is the same that engine, determinism, alloc_failure, levels and service
# drive under TSan. blocks calls the building blocks, which run on the
# caller's thread (48 s under TSan for no thread to watch), and the engine's
# default find that engine and determinism run there.
set -uo pipefail
cd "$ROOT"
JOBS=${JOBS:-2}
export LOCD_TEST_HEAVY=0
# test_hard_cases' randomized search: its full 3 s budget runs in 10-c.
export LOCD_HARD_BUDGET_MS=${LOCD_HARD_BUDGET_MS:-500}
# halt_on_error: the first report fails the test. detect_leaks: LeakSanitizer
# is ASan's default on Linux; said here so nobody turns it off by accident.
# allocator_may_return_null: an impossible allocation (`locd gen uniform 1e12`)
# must return NULL as malloc does, so the out-of-memory paths are what is
# tested, not ASan's own abort on a huge request.
export ASAN_OPTIONS="allocator_may_return_null=1:halt_on_error=1:abort_on_error=0:detect_leaks=1:detect_stack_use_after_return=1:check_initialization_order=1:strict_init_order=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export TSAN_OPTIONS="allocator_may_return_null=1:halt_on_error=1:second_deadlock_stack=1:history_size=4"

# Options that do not change what the tests cover but keep the builds short:
# the benchmark peers (FCL, Bullet, CGAL comparisons) have no tests.
common=(--buildtype=debugoptimized -Dtests=enabled -Dbench_peers=disabled -Dpython=false)

# Configures DIR with the given options (reconfigures an existing one, so a
# local rerun only recompiles what changed) and builds it.
build() {
  local dir=$1
  shift
  if [ -f "$dir/build.ninja" ]; then
    meson setup --reconfigure "$dir" "${common[@]}" "$@" >/dev/null ||
      meson setup --wipe "$dir" "${common[@]}" "$@" || return 1
  else
    meson setup "$dir" "${common[@]}" "$@" || return 1
  fi
  ninja -C "$dir" -j "$JOBS"
}

# Runs the suite of DIR, less the tests named in SKIP (space-separated), and
# keeps its JUnit file as $LOCD_RESULTS/NAME.junit.xml. Sanitizers slow the
# tests down: their timeouts are multiplied.
run_suite() {
  local dir=$1 name=$2 skip=$3 rc=0 tests=()
  shift 3
  if [ -n "$skip" ]; then
    mapfile -t tests < <(meson test -C "$dir" --list 2>/dev/null | sed 's/^[^:]*://' |
      grep -vxF -f <(tr ' ' '\n' <<< "$skip" | sed '/^$/d'))
    echo "$name: skipping $skip (see the step's header)"
    for t in $skip; do # one skipped testcase each, so the summary shows them
      python3 - "$name" "$t" > "$LOCD_RESULTS/$name-skipped-$t.junit.xml" <<'EOF'
import sys
from xml.sax.saxutils import quoteattr
run, test = sys.argv[1], sys.argv[2]
print('<?xml version="1.0" encoding="utf-8"?>\n<testsuites><testsuite name=%s tests="1" skipped="1">'
      '<testcase classname=%s name=%s time="0"><skipped message="left out of this sanitizer run: see '
      'scripts/ci/steps/40-sanitize.sh"/></testcase></testsuite></testsuites>'
      % (quoteattr(run), quoteattr(run + ":locd.locd"), quoteattr(test)))
EOF
    done
  fi
  "$@" meson test -C "$dir" --print-errorlogs --num-processes "$JOBS" --timeout-multiplier 4 "${tests[@]}" || rc=$?
  if [ -f "$dir/meson-logs/testlog.junit.xml" ]; then
    # Distinct suite names, so the summary tells the three runs of a test apart.
    sed "s/<testsuite name=\"/<testsuite name=\"$name:/; s/classname=\"/classname=\"$name:/g" \
      "$dir/meson-logs/testlog.junit.xml" > "$LOCD_RESULTS/$name.junit.xml"
  else
    python3 "$ROOT/scripts/ci/junit.py" case "$name" "meson test" failed "no testlog.junit.xml in $dir" \
      > "$LOCD_RESULTS/$name.junit.xml"
    rc=1
  fi
  return $rc
}

# ThreadSanitizer needs the address-space layout it was built for; kernels
# with high mmap randomization break it ("unexpected memory mapping"), so its
# run goes without ASLR when setarch is there.
norandom=()
if setarch "$(uname -m)" -R true 2>/dev/null; then
  norandom=(setarch "$(uname -m)" -R)
fi

# mpi: Open MPI is not built with TSan, whose reports would be about its
# internals (the ASan run covers liblocd_mpi, tests/lsan_mpi.supp).
TSAN_SKIP=${LOCD_TSAN_SKIP-hard_cases hard_cases_shapes hard_cases_input blocks mpi}

rc=0
which=${LOCD_SANITIZERS:-asan tsan}
if [[ " $which " == *" asan "* ]]; then
  echo "== ASan + UBSan: build-ci/asan"
  if build build-ci/asan -Db_sanitize=address,undefined -Db_lundef=false -Dc_args=-fno-sanitize-recover=all \
      -Dcpp_args=-fno-sanitize-recover=all; then
    run_suite build-ci/asan asan "" || rc=1
  else
    python3 scripts/ci/junit.py case asan build failed "build-ci/asan did not build" > "$LOCD_RESULTS/asan.junit.xml"
    rc=1
  fi
fi
if [[ " $which " == *" tsan "* ]]; then
  echo "== TSan: build-ci/tsan"
  if build build-ci/tsan -Db_sanitize=thread -Db_lundef=false; then
    run_suite build-ci/tsan tsan "$TSAN_SKIP" "${norandom[@]}" || rc=1
  else
    python3 scripts/ci/junit.py case tsan build failed "build-ci/tsan did not build" > "$LOCD_RESULTS/tsan.junit.xml"
    rc=1
  fi
fi
exit $rc
