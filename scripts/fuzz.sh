#!/usr/bin/env bash
# Builds and runs locd's libFuzzer harnesses (tests/fuzz/, docs/ci.md, "42-fuzz").
#   scripts/fuzz.sh build                  build them (clang, ASan + UBSan) in $LOCD_FUZZ_BUILD
#   scripts/fuzz.sh HARNESS [RUNS] [ARGS]  build, then run HARNESS (service, session, scene or all)
#                                          for RUNS inputs (default 100000; 0 = until stopped)
#                                          from its committed corpus; ARGS go to libFuzzer
#   scripts/fuzz.sh replay HARNESS FILE... run the harness once on each file (a crash to check)
# New interesting inputs go to $LOCD_FUZZ_OUT/HARNESS/corpus (not into the
# repository: see docs/ci.md for minimizing and committing them); a crash
# is written to $LOCD_FUZZ_OUT/HARNESS/crash-* and the script exits non-zero.
#   LOCD_FUZZ_BUILD  build directory (default build-fuzz)
#   LOCD_FUZZ_OUT    work directory (default $LOCD_FUZZ_BUILD/out)
#   CC, CXX          clang, clang++ by default
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
BUILD=${LOCD_FUZZ_BUILD:-build-fuzz}
OUT=${LOCD_FUZZ_OUT:-$BUILD/out}
export CC=${CC:-clang} CXX=${CXX:-clang++}

# Every sanitizer finding is fatal; leaks too (LeakSanitizer at exit).
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1:handle_abort=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}

build() {
  if [ ! -f "$BUILD/build.ninja" ]; then
    # Static: the library and its instrumentation live in each harness.
    meson setup "$BUILD" -Dfuzz=true -Dbuildtype=debugoptimized -Db_ndebug=false \
      -Db_sanitize=address,undefined -Db_lundef=false -Ddefault_library=static \
      -Dc_args=-fno-sanitize-recover=all -Dcpp_args=-fno-sanitize-recover=all \
      -Dtests=disabled -Dexamples=false -Dtools=false -Dmpi=disabled -Dbench_peers=disabled >/dev/null
  fi
  ninja -C "$BUILD" -j "${JOBS:-2}" tests/fuzz/fuzz_service tests/fuzz/fuzz_session tests/fuzz/fuzz_scene > "$BUILD/ninja.log" 2>&1 || { tail -n 40 "$BUILD/ninja.log"; exit 1; }
}

# Per-harness libFuzzer settings: input size cap and dictionary.
harness_args() {
  case $1 in
    # The service's threads allocate after an input returns: libFuzzer's
    # per-input leak check would only see that (and costs most of the
    # time); LeakSanitizer still checks the whole run at exit.
    service) echo "-max_len=4096 -detect_leaks=0 -dict=$ROOT/tests/fuzz/service.dict" ;;
    session) echo "-max_len=4096 -dict=$ROOT/tests/fuzz/service.dict" ;;
    scene) echo "-max_len=8192 -dict=$ROOT/tests/fuzz/scene.dict" ;;
    *) echo "unknown harness '$1' (service, session, scene)" >&2; exit 2 ;;
  esac
}

# The session harness takes the same inputs as the service harness.
corpus_of() {
  if [ "$1" = session ]; then echo service; else echo "$1"; fi
}

run() {
  local h=$1 runs=$2
  shift 2
  local work="$OUT/$h"
  mkdir -p "$work/corpus"
  [ "$runs" = 0 ] && runs=-1 # libFuzzer's "no limit"
  # The committed corpus is read only: new inputs land in $work/corpus.
  # shellcheck disable=SC2046
  "$BUILD/tests/fuzz/fuzz_$h" $(harness_args "$h") -runs="$runs" -timeout=60 -rss_limit_mb=3072 \
    -artifact_prefix="$work/" -print_final_stats=1 "$@" "$work/corpus" "$ROOT/tests/fuzz/corpus/$(corpus_of "$h")"
}

cmd=${1:-}
case $cmd in
  build) build ;;
  replay)
    [ $# -ge 3 ] || { echo "usage: $0 replay HARNESS FILE..." >&2; exit 2; }
    build
    h=$2
    shift 2
    # shellcheck disable=SC2046
    "$BUILD/tests/fuzz/fuzz_$h" $(harness_args "$h") "$@"
    ;;
  service | session | scene)
    build
    shift
    runs=${1:-100000}
    [ $# -gt 0 ] && shift
    run "$cmd" "$runs" "$@"
    ;;
  all)
    build
    shift
    runs=${1:-100000}
    [ $# -gt 0 ] && shift
    run service "$runs" "$@"
    run session "$runs" "$@"
    run scene "$runs" "$@"
    ;;
  *)
    sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
    ;;
esac
