#!/usr/bin/env bash
# locd as its users get it (README, "Using locd from C, C++, CMake and
# Meson"): install the library into a temporary prefix, then build and run,
# against that installed copy only,
#   - a C99 program (-std=c99 -Wall -Wextra -Wpedantic -Werror) with pkg-config's flags,
#   - a C++17 program (-Wall -Wextra -Wpedantic -Werror) with pkg-config's flags,
#   - a C99 program of the narrow phase with `pkg-config locd-narrow`,
#   - each public header alone (`#include <locd/X.h>`) in C99 and C++17 with
#     the same flags, every function it declares (beyond locd.h's) exported
#     by its own library: locd.h, scene.h, service.h by liblocd, pipeline.h
#     by liblocd_narrow (mpi.h, not installed here, from the tree with MPI's
#     flags when mpicc is there),
#   - a CMake project with find_package(locd) (the prefix moved elsewhere
#     first: locdConfig.cmake must be relocatable),
#   - when Bullet is installed, a C++17 program on liblocd_bullet with
#     `pkg-config locd-bullet` and with CMake's locd::bullet,
#   - a Meson project with locd as a subproject, whose `meson test --list`
#     must show no locd test and which must install nothing.
# "A machine where FCL is not installed" is simulated: PKG_CONFIG_LIBDIR is
# restricted to the prefix's pkgconfig directory (to an empty one for the
# Meson project), so no fcl.pc, ccd.pc, eigen3.pc or octomap.pc is visible;
# and liblocd.so itself must NEED nothing but libc, libm (and libpthread/librt
# on older glibc), checked with readelf and ldd. The narrow-phase program is
# the one exception: liblocd_narrow links FCL by design (docs/abi.md).
# Each consumer is one JUnit testcase: $LOCD_RESULTS/consumers-*.junit.xml.
set -uo pipefail
cd "$ROOT"
OUT=$ROOT/build-ci/consumers
rm -rf "$OUT"
mkdir -p "$OUT/empty-pkgconfig"
PREFIX=$OUT/prefix
SRC=$ROOT/tests/consumers
rc=0

case_result() { # NAME passed|failed [MESSAGE]
  python3 scripts/ci/junit.py case consumers "$1" "$2" "${3:-}" > "$LOCD_RESULTS/consumers-$1.junit.xml"
}
run_case() { # NAME FUNCTION: runs FUNCTION, keeps its output, records a testcase
  local name=$1 log=$OUT/$1.log start
  start=$(date +%s)
  echo "== $name"
  # Not inside an `if`: there errexit would be off in the function too.
  ( set -euo pipefail; "$2" ) > "$log" 2>&1
  if [ $? -eq 0 ]; then
    cat "$log"
    echo "   $name: passed ($(( $(date +%s) - start ))s)"
    case_result "$name" passed
  else
    cat "$log"
    echo "   $name: FAILED"
    case_result "$name" failed "$(tail -n 40 "$log")"
    rc=1
  fi
}

install_locd() {
  # The library only; the narrow phase is built when libccd and FCL are found.
  meson setup "$OUT/build" --prefix="$PREFIX" --buildtype=release -Dpython=false -Dtests=disabled \
    -Dtools=false -Dexamples=false -Dbench_peers=disabled -Dmpi=disabled
  ninja -C "$OUT/build" -j "${JOBS:-2}"
  meson install -C "$OUT/build" --quiet
  find "$PREFIX" -type f -o -type l | sed "s|$PREFIX/||" | sort
}
run_case install install_locd
[ $rc -eq 0 ] || exit 1
LIBDIR=$(dirname "$(find "$PREFIX" -name liblocd.so | head -1)")
export PKG_CONFIG_LIBDIR="$LIBDIR/pkgconfig"
export PKG_CONFIG_PATH=
echo "PKG_CONFIG_LIBDIR=$PKG_CONFIG_LIBDIR"

core_needs() {
  test -f "$LIBDIR/liblocd.so"
  readelf -d "$LIBDIR/liblocd.so" | grep NEEDED
  local stray
  stray=$(readelf -d "$LIBDIR/liblocd.so" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p' |
          grep -v -E '^(libc|libm|libpthread|librt|libdl)\.so\.[0-9]+$|^ld-linux' || true)
  [ -z "$stray" ] || { echo "liblocd.so needs more than libc, libm and pthreads: $stray"; exit 1; }
  ldd "$LIBDIR/liblocd.so"
  if ldd "$LIBDIR/liblocd.so" | grep -E 'libfcl|libccd|liboctomap|libstdc\+\+'; then
    echo "liblocd.so pulls in FCL, libccd, octomap or libstdc++"; exit 1
  fi
}
run_case core-needs core_needs

pkgconfig_flags() {
  if pkg-config --exists fcl || pkg-config --exists ccd || pkg-config --exists eigen3; then
    echo "fcl.pc, ccd.pc or eigen3.pc is visible: the simulation of a machine without FCL does not hold"; exit 1
  fi
  local cflags libs ncflags
  # Word-split once to drop pkg-config's trailing blank.
  cflags=$(echo $(pkg-config --cflags locd))
  libs=$(echo $(pkg-config --libs locd))
  ncflags=$(echo $(pkg-config --cflags locd-narrow))
  echo "pkg-config --cflags locd:        $cflags"
  echo "pkg-config --libs locd:          $libs"
  echo "pkg-config --cflags locd-narrow: $ncflags"
  echo "pkg-config --libs locd-narrow:   $(pkg-config --libs locd-narrow)"
  [ "$cflags" = "-I$PREFIX/include" ] || { echo "--cflags locd is not just locd's include path"; exit 1; }
  [ "$libs" = "-L$LIBDIR -llocd" ] || { echo "--libs locd is not -L<libdir> -llocd"; exit 1; }
  if echo "$ncflags" | grep -E -e '-std=|eigen|fcl' >/dev/null; then echo "--cflags locd-narrow leaks FCL's flags"; exit 1; fi
}
run_case pkg-config pkgconfig_flags

c99_program() {
  # shellcheck disable=SC2046
  cc -std=c99 -Wall -Wextra -Wpedantic -Werror -o "$OUT/c99" "$SRC/c/app.c" $(pkg-config --cflags --libs locd)
  LD_LIBRARY_PATH="$LIBDIR" ldd "$OUT/c99" | grep "$LIBDIR/liblocd.so" >/dev/null
  LD_LIBRARY_PATH="$LIBDIR" "$OUT/c99"
}
run_case c99 c99_program

cxx17_program() {
  # shellcheck disable=SC2046
  c++ -std=c++17 -Wall -Wextra -Wpedantic -Werror -o "$OUT/cxx17" "$SRC/cpp/app.cpp" $(pkg-config --cflags --libs locd)
  LD_LIBRARY_PATH="$LIBDIR" ldd "$OUT/cxx17" | grep "$LIBDIR/liblocd.so" >/dev/null
  LD_LIBRARY_PATH="$LIBDIR" "$OUT/cxx17"
}
run_case cxx17 cxx17_program

narrow_program() {
  # liblocd_narrow needs FCL and libccd at link and run time (they are
  # installed on the CI machine); its pkg-config flags still carry none of them.
  # shellcheck disable=SC2046
  cc -std=c99 -Wall -Wextra -Wpedantic -Werror -o "$OUT/narrow" "$SRC/c/narrow.c" $(pkg-config --cflags --libs locd-narrow)
  local st=0
  LD_LIBRARY_PATH="$LIBDIR" "$OUT/narrow" || st=$?
  # 77: built without libccd/FCL (the stubs answer LOCD_ERR_UNSUPPORTED): linking is what is tested then.
  [ $st -eq 0 ] || [ $st -eq 77 ]
}
run_case narrow-c99 narrow_program

headers_alone() {
  local installed=$PREFIX/include/locd dir=$OUT/headers h name names=(locd) flags mpi_flags lib own stray
  # Every header of the tree is installed (mpi.h only with MPI); each is checked, locd.h first.
  for h in "$ROOT"/include/locd/*.h; do
    name=$(basename "$h" .h)
    [ "$name" = mpi ] || [ -f "$installed/$name.h" ] || { echo "include/locd/$name.h is not installed"; exit 1; }
    [ "$name" = locd ] || names+=("$name")
  done
  mkdir -p "$dir"
  declared() { { grep -oE '\blocd_[a-z0-9_]+ *\(' "$1" || true; } | sed 's/ *($//' | sort -u; }
  exported() { nm -D --defined-only "$LIBDIR/$1" | awk '{ sub(/@.*/, "", $3); print $3 }' | sort -u; }
  for name in "${names[@]}"; do
    # shellcheck disable=SC2046
    flags=$(echo $(pkg-config --cflags locd))
    lib=liblocd.so
    case $name in
      pipeline) lib=liblocd_narrow.so ;;
      mpi)
        lib=
        # Open MPI's headers as system headers (their own warnings are not locd's);
        # the tree's mpi.h after the installed headers when it is not installed.
        mpi_flags=$(mpicc --showme:compile 2>/dev/null) || { echo "locd/mpi.h: not checked (no Open MPI mpicc)"; continue; }
        flags="$flags ${mpi_flags//-I/-isystem }"
        [ -f "$installed/mpi.h" ] || flags="$flags -I$ROOT/include"
        ;;
    esac
    printf '#include <locd/%s.h>\nint main(void) { return 0; }\n' "$name" > "$dir/$name.c"
    cp "$dir/$name.c" "$dir/$name.cpp"
    # shellcheck disable=SC2086
    cc -std=c99 -Wall -Wextra -Wpedantic -Werror $flags -c "$dir/$name.c" -o "$dir/$name.c.o"
    # shellcheck disable=SC2086
    c++ -std=c++17 -Wall -Wextra -Wpedantic -Werror $flags -c "$dir/$name.cpp" -o "$dir/$name.cpp.o"
    # The functions it declares beyond locd.h's (which every other header includes).
    # shellcheck disable=SC2086
    cc -std=c99 -E -P $flags "$dir/$name.c" > "$dir/$name.i"
    own=$(declared "$dir/$name.i")
    [ "$name" = locd ] || own=$(comm -23 <(echo "$own") <(declared "$dir/locd.i"))
    if [ -n "$lib" ]; then
      stray=$(comm -23 <(echo "$own") <(exported "$lib"))
    else
      stray=$(echo "$own" | grep -v '^locd_mpi_' || true)  # liblocd_mpi is not built here
      lib="liblocd_mpi (locd_mpi_*)"
    fi
    [ -z "$stray" ] || { echo "locd/$name.h declares functions that are not $lib's:" $stray; exit 1; }
    echo "locd/$name.h: compiles alone (C99, C++17); its $(echo "$own" | grep -c .) functions are $lib's"
  done
}
run_case headers headers_alone

cmake_project() {
  # Moved: the config files must find the library from their own location.
  cp -a "$PREFIX" "$OUT/moved"
  cmake -S "$SRC/cmake" -B "$OUT/cmake" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$OUT/moved" \
    | tee "$OUT/cmake-configure.txt"
  grep -q "from $OUT/moved/" "$OUT/cmake-configure.txt"
  cmake --build "$OUT/cmake" -j "${JOBS:-2}"
  ldd "$OUT/cmake/app" | grep liblocd
  ldd "$OUT/cmake/app" | grep "$OUT/moved/.*liblocd.so" >/dev/null
  "$OUT/cmake/app"
  local st=0
  "$OUT/cmake/narrow" || st=$?
  [ $st -eq 0 ] || [ $st -eq 77 ]
}
run_case cmake cmake_project

bullet_consumer() {
  # liblocd_bullet (built when Bullet is found): a C++17 program with
  # `pkg-config locd-bullet`, and a CMake project with
  # find_package(locd COMPONENTS bullet) against the moved prefix. Bullet's
  # own .pc file must be visible here (locd-bullet.pc requires it). The
  # programs run with the prefix on LD_LIBRARY_PATH: they call no liblocd
  # function themselves, so their RUNPATH does not reach liblocd.so.
  if [ ! -f "$LIBDIR/pkgconfig/locd-bullet.pc" ]; then
    echo "liblocd_bullet not built (Bullet not found): nothing to check"
    return 0
  fi
  local sys_pc
  sys_pc=$(env -u PKG_CONFIG_LIBDIR pkg-config --variable pc_path pkg-config)
  PKG_CONFIG_LIBDIR="$LIBDIR/pkgconfig:$sys_pc" pkg-config --cflags --libs locd-bullet
  c++ -std=c++17 -Wall -Wextra -Werror "$SRC/bullet/app.cpp" -o "$OUT/bullet-app" \
    $(PKG_CONFIG_LIBDIR="$LIBDIR/pkgconfig:$sys_pc" pkg-config --cflags --libs locd-bullet)
  LD_LIBRARY_PATH="$LIBDIR" "$OUT/bullet-app"
  local moved_lib
  moved_lib=$(dirname "$(find "$OUT/moved" -name liblocd_bullet.so | head -1)")
  PKG_CONFIG_LIBDIR="$sys_pc" cmake -S "$SRC/bullet" -B "$OUT/cmake-bullet" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_PREFIX_PATH="$OUT/moved" | tee "$OUT/cmake-bullet-configure.txt"
  grep -q "from $OUT/moved/.*(bullet: TRUE)" "$OUT/cmake-bullet-configure.txt"
  cmake --build "$OUT/cmake-bullet" -j "${JOBS:-2}"
  LD_LIBRARY_PATH="$moved_lib" ldd "$OUT/cmake-bullet/app" | grep "$OUT/moved/.*liblocd_bullet.so" >/dev/null
  LD_LIBRARY_PATH="$moved_lib" "$OUT/cmake-bullet/app"
}
run_case bullet bullet_consumer

meson_subproject() {
  # The consumer next to its sources; locd's tree in its subprojects/ (a
  # symlink: what a project vendoring locd as a git submodule sees). No .pc
  # file is visible at all, so the subproject also builds without libccd/FCL.
  cp -r "$SRC" "$OUT/mc"
  mkdir -p "$OUT/mc/meson/subprojects"
  ln -s "$ROOT" "$OUT/mc/meson/subprojects/locd"
  PKG_CONFIG_LIBDIR="$OUT/empty-pkgconfig" meson setup "$OUT/mc-build" "$OUT/mc/meson" --force-fallback-for=locd
  meson test -C "$OUT/mc-build" --list 2>/dev/null | tee "$OUT/mc-tests.txt"
  [ "$(grep -c . "$OUT/mc-tests.txt")" -eq 1 ] && grep -q 'consumer_app' "$OUT/mc-tests.txt" \
    || { echo "meson test --list shows more than the consumer's own test"; exit 1; }
  meson test -C "$OUT/mc-build" --print-errorlogs
  local installed
  installed=$(meson introspect "$OUT/mc-build" --installed)
  echo "installed by the parent: $installed"
  [ "$installed" = "{}" ] || { echo "the subproject installs files unasked"; exit 1; }
  # Asked, it installs the library, headers, pkg-config and CMake files.
  PKG_CONFIG_LIBDIR="$OUT/empty-pkgconfig" meson setup --reconfigure "$OUT/mc-build" "$OUT/mc/meson" \
    -Dlocd:install_as_subproject=true > "$OUT/mc-reconfigure.txt"
  installed=$(meson introspect "$OUT/mc-build" --installed)
  for f in liblocd.so liblocd_narrow.so include/locd/locd.h pkgconfig/locd.pc cmake/locd/locdConfig.cmake; do
    echo "$installed" | grep "$f\"" >/dev/null || { echo "-Dlocd:install_as_subproject=true does not install $f"; exit 1; }
  done
  echo "with -Dlocd:install_as_subproject=true: $(echo "$installed" | grep -o '"/[^"]*":' | wc -l) files"
}
run_case meson-subproject meson_subproject

exit $rc
