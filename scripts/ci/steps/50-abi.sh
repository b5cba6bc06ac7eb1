#!/usr/bin/env bash
# The ABI guard (docs/abi.md): liblocd and liblocd_narrow must stay
# compatible with the committed baselines abi/liblocd.abi and
# abi/liblocd_narrow.abi (abidiff --no-added-syms), and export nothing but
# locd_* functions (and liblocd's private lc_* node: the version scripts'
# job). Each check is one JUnit testcase.
set -uo pipefail
cd "$ROOT"
rc=0

case_result() { # NAME passed|failed MESSAGE
  python3 scripts/ci/junit.py case abi "$1" "$2" "${3:-}" > "$LOCD_RESULTS/abi-$1.junit.xml"
}

echo "== abidiff against abi/liblocd.abi and abi/liblocd_narrow.abi"
if out=$(bash scripts/abi.sh check 2>&1); then
  echo "$out"
  case_result abidiff passed
else
  echo "$out"
  case_result abidiff failed "$out"
  rc=1
fi

echo "== exported symbols"
major=$(sed -n 's/^#define LOCD_VERSION_MAJOR \([0-9]*\).*/\1/p' include/locd/version.h)
soversion=$(sed -n "s/^locd_soversion = '\([0-9]*\)'.*/\1/p" meson.build)
version=$(sed -n "s/^  version: '\([0-9.]*\)'.*/\1/p" meson.build | head -1)
# liblocd: locd_* in LOCD_0, plus the lc_* helpers liblocd_narrow calls, in
# the private node LOCD_PRIVATE_<version> only (docs/abi.md, "Two
# libraries"). liblocd_narrow: locd_* only; liblocd_mpi: locd_mpi_* in LOCD_MPI_0.
for name in liblocd liblocd_narrow liblocd_mpi; do
  lib=$(readlink -f "${LOCD_ABI_BUILD:-build-ci/abi}/lib/$name.so" 2>/dev/null || true)
  if [ "$name" = liblocd_mpi ] && [ -z "$lib" ]; then
    echo "liblocd_mpi: not built (MPI missing): not inspected"
    continue
  fi
  if [ -z "$lib" ] || [ ! -f "$lib" ]; then
    case_result "exports-$name" failed "no $name to inspect (the ABI build failed)"
    rc=1
    continue
  fi
  # Defined dynamic symbols as name@node, less the version nodes themselves (type A).
  syms=$(nm -D --defined-only "$lib" | awk '$2 != "A" { sub(/@@/, "@", $3); print $3 }')
  if [ "$name" = liblocd ]; then
    stray=$(echo "$syms" | grep -v -E '^locd_[a-z0-9_]+@LOCD_0$' | grep -v -E "^lc_[a-z0-9_]+@LOCD_PRIVATE_${version//./\\.}\$" || true)
  elif [ "$name" = liblocd_mpi ]; then
    stray=$(echo "$syms" | grep -v -E '^locd_mpi_[a-z0-9_]+@LOCD_MPI_0$' || true)
  else
    stray=$(echo "$syms" | grep -v -E '^locd_[a-z0-9_]+@LOCD_NARROW_0$' || true)
  fi
  soname=$(objdump -p "$lib" | awk '/SONAME/ { print $2 }')
  echo "$name: $(echo "$syms" | wc -l) exported symbols, soname $soname (locd_soversion $soversion, LOCD_VERSION_MAJOR $major)"
  if [ -n "$stray" ]; then
    echo "symbols outside the allowed prefixes and nodes:"
    echo "$stray"
    case_result "exports-$name" failed "unexpected exported symbols: $(echo "$stray" | tr '\n' ' ')"
    rc=1
  elif [ "$soname" != "$name.so.$soversion" ]; then
    case_result "exports-$name" failed "soname $soname, expected $name.so.$soversion (meson.build locd_soversion)"
    rc=1
  else
    case_result "exports-$name" passed
  fi
done
exit $rc
