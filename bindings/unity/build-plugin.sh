#!/usr/bin/env bash
# Builds the Linux x86_64 native plugin of the Unity package:
#   bindings/unity/Plugins/x86_64/liblocd.so
# Release, no optional dependencies (no libccd/FCL/MPI), so the plugin needs
# nothing beyond glibc on the player's machine.
#   bash bindings/unity/build-plugin.sh [BUILD_DIR]      (default build-unity-plugin)
#   STATIC=1 bash bindings/unity/build-plugin.sh         also builds liblocd.a (iOS-style static linking)
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
BUILD=${1:-$ROOT/build-unity-plugin}
LIBKIND=shared
[ "${STATIC:-0}" = 1 ] && LIBKIND=both
OPTS=(--buildtype=release -Ddefault_library=$LIBKIND -Dtests=disabled -Dexamples=false -Dtools=false
      -Dnarrow=disabled -Dmpi=disabled -Dbench_peers=disabled)
if [ -f "$BUILD/build.ninja" ]; then
  meson configure "$BUILD" "${OPTS[@]}" >/dev/null
else
  meson setup "$BUILD" "$ROOT" "${OPTS[@]}" >/dev/null
fi
ninja -C "$BUILD" -j "${JOBS:-2}" >/dev/null
mkdir -p "$HERE/Plugins/x86_64"
# A real file named liblocd.so (Unity copies plugins, not symlinks), replaced
# atomically so a process loading it never sees half a file.
tmp="$HERE/Plugins/x86_64/.liblocd.so.$$"
cp -L "$BUILD/lib/liblocd.so" "$tmp"
strip --strip-unneeded "$tmp"
mv -f "$tmp" "$HERE/Plugins/x86_64/liblocd.so"
if [ "$LIBKIND" = both ]; then
  # A host (Linux) archive: shows the static build works. An iOS player needs
  # the same build cross-compiled for arm64 (README.md, "iOS").
  echo "static library: $BUILD/lib/liblocd.a"
fi
echo "plugin: $HERE/Plugins/x86_64/liblocd.so"
ldd "$HERE/Plugins/x86_64/liblocd.so"
