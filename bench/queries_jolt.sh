#!/bin/sh
# Builds bench/queries_jolt against a Jolt Physics tree the user gives (Jolt is in no package
# registry; the project neither fetches nor commits it), and prints its path. Optional: bench/queries.py
# runs it when JOLT_SRC is set. Not part of CI.
#   JOLT_SRC=/path/to/JoltPhysics sh bench/queries_jolt.sh [OUT_DIR]
# JOLT_SRC holds Jolt/ and Build/ (a release of JoltPhysics, or its repository without the Assets);
# Jolt is built there once with CMake (Release, AVX2; about 3 minutes on 2 cores) into
# $JOLT_SRC/build-locd, then this program with the same defines.
set -eu
: "${JOLT_SRC:?set JOLT_SRC to a Jolt Physics source tree}"
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${1:-$HERE/../build/bench}
B=$JOLT_SRC/build-locd
if [ ! -f "$B/libJolt.a" ]; then
  cmake -S "$JOLT_SRC/Build" -B "$B" -DCMAKE_BUILD_TYPE=Release -DUSE_AVX2=ON -DUSE_AVX512=OFF \
    -DTARGET_UNIT_TESTS=OFF -DTARGET_HELLO_WORLD=OFF -DTARGET_PERFORMANCE_TEST=OFF -DTARGET_SAMPLES=OFF \
    -DTARGET_VIEWER=OFF -DENABLE_OBJECT_STREAM=OFF -DPROFILER_IN_DEBUG_AND_RELEASE=OFF \
    -DDEBUG_RENDERER_IN_DEBUG_AND_RELEASE=OFF -DINTERPROCEDURAL_OPTIMIZATION=OFF >/dev/null
  cmake --build "$B" -j 2 >/dev/null
fi
# The defines and flags Jolt was built with: a program must use the same.
DEFS=$(sed -n 's/^CXX_DEFINES = //p' "$B/CMakeFiles/Jolt.dir/flags.make")
mkdir -p "$OUT"
# shellcheck disable=SC2086
c++ -std=c++17 -O2 $DEFS -mavx2 -mbmi -mpopcnt -mlzcnt -mf16c -mfma -fno-rtti -Wno-psabi -I"$JOLT_SRC" \
  "$HERE/queries_jolt.cpp" "$B/libJolt.a" -pthread -o "$OUT/queries_jolt"
echo "$OUT/queries_jolt"
