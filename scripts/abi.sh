#!/usr/bin/env bash
# The ABI baselines of liblocd and liblocd_narrow (docs/abi.md).
#   scripts/abi.sh build    builds build-ci/abi (debugoptimized, -g: abidw reads the DWARF)
#   scripts/abi.sh update   builds, then writes the baselines abi/liblocd.abi, abi/liblocd_narrow.abi
#   scripts/abi.sh check    builds, then compares each library with its baseline:
#                           any incompatible change (removed or changed function,
#                           changed layout of a public type) fails; added
#                           functions (--no-added-syms) and fields appended to
#                           versioned structs (abi/locd.abignore) pass
# Env: LOCD_ABI_BUILD (default build-ci/abi), JOBS.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
BUILD=${LOCD_ABI_BUILD:-build-ci/abi}
LIBS=(liblocd liblocd_narrow)
# liblocd_mpi (include/locd/mpi.h) is built only where Meson finds MPI:
# checked when its baseline exists and the build made it.
OPTIONAL_LIBS=(liblocd_mpi)
SUPPRESSIONS=abi/locd.abignore
HEADERS=include/locd
# Only what the public headers expose through exported functions: without
# these the dump also holds every FCL/Eigen type the C++ glue uses (4 MB).
DUMP_OPTS=(--no-corpus-path --no-comp-dir-path --headers-dir "$HEADERS" --drop-private-types
           --exported-interfaces-only --drop-undefined-syms)

build() {
  # -g is debugoptimized's default; said again because an ABI dump of a
  # library without debug info is empty and would "pass" every check.
  local opts=(--buildtype=debugoptimized -Dc_args=-g -Dtests=disabled -Dbench_peers=disabled -Dpython=false)
  if [ -f "$BUILD/build.ninja" ]; then
    meson setup --reconfigure "$BUILD" "${opts[@]}" >/dev/null || meson setup --wipe "$BUILD" "${opts[@]}"
  else
    meson setup "$BUILD" "${opts[@]}" >/dev/null
  fi
  ninja -C "$BUILD" -j "${JOBS:-2}" >/dev/null
}

# The real file behind the soname link (liblocd.so.MAJOR -> liblocd.so.X.Y.Z).
library() { # NAME
  local lib
  lib=$(readlink -f "$BUILD/lib/$1.so")
  [ -f "$lib" ] || { echo "abi: no $BUILD/lib/$1.so" >&2; exit 1; }
  echo "$lib"
}

# A dump without function declarations means the debug info was missing.
guard() {
  if ! grep -q '<function-decl' "$1"; then
    echo "abi: $1 holds no <function-decl>: the library was built without debug info (-g)" >&2
    exit 1
  fi
}

case "${1:-}" in
  build)
    build
    for name in "${LIBS[@]}"; do library "$name"; done
    ;;
  update)
    build
    for name in "${OPTIONAL_LIBS[@]}"; do [ -e "$BUILD/lib/$name.so" ] && LIBS+=("$name"); done
    mkdir -p abi
    for name in "${LIBS[@]}"; do
      lib=$(library "$name")
      baseline=abi/$name.abi
      abidw "${DUMP_OPTS[@]}" --out-file "$baseline" "$lib"
      guard "$baseline"
      echo "abi: wrote $baseline from $lib ($(grep -c '<function-decl' "$baseline") function declarations," \
        "$(grep -o "soname='[^']*'" "$baseline" | head -1))"
    done
    ;;
  check)
    for name in "${LIBS[@]}"; do
      [ -f "abi/$name.abi" ] || { echo "abi: no baseline abi/$name.abi (run scripts/abi.sh update)" >&2; exit 1; }
      guard "abi/$name.abi"
    done
    build
    for name in "${OPTIONAL_LIBS[@]}"; do
      if [ -f "abi/$name.abi" ] && [ -e "$BUILD/lib/$name.so" ]; then
        LIBS+=("$name")
      else
        echo "abi: $name not checked (no baseline or not built: MPI missing)"
      fi
    done
    tmp=$(mktemp)
    trap 'rm -f "$tmp"' EXIT
    failed=0
    for name in "${LIBS[@]}"; do
      lib=$(library "$name")
      baseline=abi/$name.abi
      # The library under test must have debug info too: dump it and guard.
      abidw "${DUMP_OPTS[@]}" --out-file "$tmp" "$lib"
      guard "$tmp"
      # abidiff's exit status is a bit field (1 error, 2 usage, 4 change, 8
      # incompatible change); with --no-added-syms only real breaks remain, so
      # any non-zero status fails.
      set +e
      abidiff --no-added-syms --drop-private-types --exported-interfaces-only --suppressions "$SUPPRESSIONS" \
        "$baseline" "$lib" --hd2 "$HEADERS"
      rc=$?
      set -e
      if [ $rc -ne 0 ]; then
        echo "abi: $lib INCOMPATIBLE with $baseline (abidiff exit $rc). If the break is intended, follow docs/abi.md." >&2
        failed=1
      else
        echo "abi: $lib is compatible with $baseline"
      fi
    done
    exit $failed
    ;;
  *)
    sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
    ;;
esac
