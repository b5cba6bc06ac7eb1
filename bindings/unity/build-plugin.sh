#!/usr/bin/env bash
# Builds the native plugins of the Unity package:
#   bindings/unity/Plugins/Linux/x86_64/liblocd.so     (gcc)
#   bindings/unity/Plugins/Windows/x86_64/locd.dll     (mingw-w64 cross build, scripts/cross/mingw64.ini)
# and the .meta file beside each (import settings: Editor + Standalone of
# that OS and CPU only; scripts/unity_package.py plugin).
# Release, no optional dependencies (no libccd/FCL/MPI), so the Linux plugin
# needs nothing beyond glibc and the Windows one nothing beyond KERNEL32.dll
# and msvcrt.dll (winpthreads and libgcc are linked in statically).
#   bash bindings/unity/build-plugin.sh [BUILD_DIR]      (default build-unity-plugin; Windows in BUILD_DIR-windows)
#   PLATFORMS=linux bash bindings/unity/build-plugin.sh  only one of: linux windows (default both)
#   STATIC=1 bash bindings/unity/build-plugin.sh         also builds liblocd.a (iOS-style static linking)
# Needs what scripts/setup.sh installs (Meson and Ninja in the project's
# .venv, gcc-mingw-w64-x86-64 for Windows); nothing else to activate.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
BUILD=${1:-$ROOT/build-unity-plugin}
PLATFORMS=${PLATFORMS:-linux windows}
# scripts/setup.sh puts Meson (>= 1.1, which this project needs) and Ninja in
# .venv; use them without asking the caller to activate it.
if [ -x "$ROOT/.venv/bin/meson" ]; then
  export PATH="$ROOT/.venv/bin:$PATH"
fi
command -v meson >/dev/null || { echo "meson not found: run scripts/setup.sh first (it installs Meson into .venv)"; exit 1; }
LIBKIND=shared
[ "${STATIC:-0}" = 1 ] && LIBKIND=both
OPTS=(--buildtype=release -Dplugin=true -Dtests=disabled -Dexamples=false -Dtools=false
      -Dnarrow=disabled -Dmpi=disabled -Dbench_peers=disabled)

configure() { # BUILD_DIR CROSS_FILE|"" OPTIONS...
  local dir=$1 cross=$2; shift 2
  if [ -f "$dir/build.ninja" ]; then
    meson configure "$dir" "$@" >/dev/null
  else
    meson setup "$dir" "$ROOT" ${cross:+--cross-file "$cross"} "$@" >/dev/null
  fi
}

install_plugin() { # BUILT_FILE DEST STRIP_TOOL
  local dest=$2 tmp
  mkdir -p "$(dirname "$dest")"
  # A real file (Unity copies plugins, not symlinks), replaced atomically
  # so a process loading it never sees half a file.
  tmp="$(dirname "$dest")/.$(basename "$dest").$$"
  cp -L "$1" "$tmp"
  "$3" --strip-unneeded "$tmp"
  mv -f "$tmp" "$dest"
  python3 "$ROOT/scripts/unity_package.py" plugin "$dest" >/dev/null
  echo "plugin: $dest"
}

for platform in $PLATFORMS; do
  case $platform in
    linux)
      configure "$BUILD" "" "${OPTS[@]}" -Ddefault_library=$LIBKIND
      ninja -C "$BUILD" -j "${JOBS:-2}" >/dev/null
      install_plugin "$BUILD/lib/liblocd.so" "$HERE/Plugins/Linux/x86_64/liblocd.so" strip
      install_plugin "$BUILD/lib/liblocd_narrow.so" "$HERE/Plugins/Linux/x86_64/liblocd_narrow.so" strip
      if [ "$LIBKIND" = both ]; then
        # A host (Linux) archive: shows the static build works. An iOS player
        # needs the same build cross-compiled for arm64 (README.md, "iOS").
        echo "static library: $BUILD/lib/liblocd.a"
      fi
      ldd "$HERE/Plugins/Linux/x86_64/liblocd.so"
      ;;
    windows)
      command -v x86_64-w64-mingw32-gcc-posix >/dev/null || {
        echo "x86_64-w64-mingw32-gcc-posix not found: run scripts/setup.sh (apt gcc-mingw-w64-x86-64), or PLATFORMS=linux"
        exit 1; }
      configure "$BUILD-windows" "$ROOT/scripts/cross/mingw64.ini" "${OPTS[@]}" -Ddefault_library=shared
      ninja -C "$BUILD-windows" -j "${JOBS:-2}" >/dev/null
      # -Dplugin=true names them as [DllImport("locd")] and ("locd_narrow") look for them.
      for name in locd locd_narrow; do
        install_plugin "$BUILD-windows/lib/$name.dll" "$HERE/Plugins/Windows/x86_64/$name.dll" x86_64-w64-mingw32-strip
        x86_64-w64-mingw32-objdump -p "$HERE/Plugins/Windows/x86_64/$name.dll" | grep 'DLL Name' | sed 's/^\s*/  needs /'
      done
      ;;
    *) echo "unknown platform $platform (linux, windows)"; exit 1 ;;
  esac
done
