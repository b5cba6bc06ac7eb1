#!/usr/bin/env bash
# Native declares every function the library exports, each from the library
# that exports it, and nothing else: the [DllImport] entry points of the Locd
# assembly (read by reflection: "library entrypoint") against the locd_*
# symbols exported by every locd library in the given directories
# (liblocd.so and any library split off it, e.g. liblocd_narrow.so, as
# `nm -D --defined-only` lists them) or by a Windows DLL (its PE export
# table, `objdump -p`). A library file's DllImport name is its file name
# without "lib", the version and the extension (liblocd.so.0 -> locd,
# liblocd-0.dll -> locd, liblocd_narrow.so -> locd_narrow). liblocd_mpi is
# left out: its functions take an MPI_Comm, which has no meaning in Unity
# (the MPI library is for C and C++ programs run under mpirun).
#   bash bindings/csharp/tests/native-coverage.sh Locd.dll OUTDIR LIBDIR|DLL...
# Exit 1 when an export has no declaration (a Unity user could not call it)
# or a declaration has no export (calling it throws EntryPointNotFoundException).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
LOCD_DLL=$1
OUT=$2
shift 2
mkdir -p "$OUT"
mcs -langversion:7.2 -nologo -out:"$OUT/Reflect.exe" "$HERE/tools/Reflect.cs"
mono "$OUT/Reflect.exe" pinvoke "$LOCD_DLL" | sort -u > "$OUT/declared.txt"
libs=()
for where in "$@"; do
  if [ -d "$where" ]; then
    # Every locd library in the directory, each real file once.
    while IFS= read -r f; do libs+=("$f"); done < <(
      find "$where" -maxdepth 1 \( -name 'liblocd*.so*' -o -name '*locd*.dll' \) ! -name '*.meta' ! -name 'liblocd_mpi*' \( -type f -o -type l \) \
        -exec readlink -f {} \; | sort -u)
  else
    libs+=("$where")
  fi
done
[ ${#libs[@]} -gt 0 ] || { echo "no locd library found in: $*"; exit 1; }
: > "$OUT/exported.raw"
for f in "${libs[@]}"; do
  name=$(basename "$f" | sed -E 's/^lib//; s/\.dll$//; s/\.so(\..*)?$//; s/-[0-9]+$//')
  case "$f" in
    *.dll) objdump -p "$f" | sed -n '/\[Ordinal\/Name Pointer\] Table/,/^$/p' | grep -o 'locd_[A-Za-z0-9_]*' ;;
    *) nm -D --defined-only "$f" | awk '$2 ~ /^[TW]$/ && $3 ~ /^locd_/ { sub(/@.*/, "", $3); print $3 }' ;;
  esac | sed "s/^/$name /" >> "$OUT/exported.raw"
  echo "library: $f (DllImport name \"$name\")"
done
sort -u "$OUT/exported.raw" > "$OUT/exported.txt"
missing=$(comm -23 "$OUT/exported.txt" "$OUT/declared.txt")
extra=$(comm -13 "$OUT/exported.txt" "$OUT/declared.txt")
echo "exported: $(wc -l < "$OUT/exported.txt"), declared in Native: $(wc -l < "$OUT/declared.txt")"
rc=0
if [ -n "$missing" ]; then echo "exported but not declared in Native (library function):"; echo "$missing" | sed 's/^/  /'; rc=1; fi
if [ -n "$extra" ]; then echo "declared in Native but not exported (library function):"; echo "$extra" | sed 's/^/  /'; rc=1; fi
[ $rc -eq 0 ] && echo "ok: Native declares every exported function, from the library that exports it"
exit $rc
