#!/usr/bin/env bash
# The ABI guard (docs/abi.md): the library must stay compatible with the
# committed baseline abi/liblocd.abi (abidiff --no-added-syms), and export
# nothing but locd_* functions (the version script's job). Each check is one
# JUnit testcase.
set -uo pipefail
cd "$ROOT"
rc=0

case_result() { # NAME passed|failed MESSAGE
  python3 scripts/ci/junit.py case abi "$1" "$2" "${3:-}" > "$LOCD_RESULTS/abi-$1.junit.xml"
}

echo "== abidiff against abi/liblocd.abi"
if out=$(bash scripts/abi.sh check 2>&1); then
  echo "$out"
  case_result abidiff passed
else
  echo "$out"
  case_result abidiff failed "$out"
  rc=1
fi

echo "== exported symbols"
lib=$(readlink -f "${LOCD_ABI_BUILD:-build-ci/abi}/lib/liblocd.so" 2>/dev/null || true)
if [ -z "$lib" ] || [ ! -f "$lib" ]; then
  case_result exports failed "no library to inspect (the ABI build failed)"
  rc=1
else
  # Defined dynamic symbols, less the version node itself (type A, e.g. LOCD_0).
  syms=$(nm -D --defined-only "$lib" | awk '$2 != "A" { sub(/@.*/, "", $3); print $3 }')
  stray=$(echo "$syms" | grep -v '^locd_' || true)
  soname=$(objdump -p "$lib" | awk '/SONAME/ { print $2 }')
  major=$(sed -n 's/^#define LOCD_VERSION_MAJOR \([0-9]*\).*/\1/p' include/locd/version.h)
  soversion=$(sed -n "s/^locd_soversion = '\([0-9]*\)'.*/\1/p" meson.build)
  echo "$(echo "$syms" | wc -l) exported symbols, soname $soname (locd_soversion $soversion, LOCD_VERSION_MAJOR $major)"
  if [ -n "$stray" ]; then
    echo "symbols outside the locd_ prefix:"
    echo "$stray"
    case_result exports failed "exported symbols without the locd_ prefix: $(echo "$stray" | tr '\n' ' ')"
    rc=1
  elif [ "$soname" != "liblocd.so.$soversion" ]; then
    case_result exports failed "soname $soname, expected liblocd.so.$soversion (meson.build locd_soversion)"
    rc=1
  else
    case_result exports passed
  fi
fi
exit $rc
