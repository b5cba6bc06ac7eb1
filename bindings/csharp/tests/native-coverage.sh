#!/usr/bin/env bash
# Native declares every function the library exports, and nothing else: the
# [DllImport] entry points of the Locd assembly (read by reflection) against
# the locd_* symbols exported by every locd library in the given directories
# (liblocd.so and any library split off it, e.g. a separate narrow-phase
# liblocd_narrow.so; `nm -D --defined-only`) or by a Windows DLL (its PE
# export table, `objdump -p`).
#   bash bindings/csharp/tests/native-coverage.sh Locd.dll OUTDIR LIBDIR|DLL...
# Exit 1 when an export has no declaration (a Unity user could not call it)
# or a declaration has no export (calling it throws EntryPointNotFoundException).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
LOCD_DLL=$1
OUT=$2
shift 2
mkdir -p "$OUT"
[ -x "$OUT/Reflect.exe" ] || mcs -langversion:7.2 -nologo -out:"$OUT/Reflect.exe" "$HERE/tools/Reflect.cs"
mono "$OUT/Reflect.exe" pinvoke "$LOCD_DLL" | sort -u > "$OUT/declared.txt"
: > "$OUT/exported.raw"
libs=()
for where in "$@"; do
  if [ -d "$where" ]; then
    # Every locd library in the directory, each real file once.
    while IFS= read -r f; do libs+=("$f"); done < <(
      find "$where" -maxdepth 1 -name 'liblocd*.so*' \( -type f -o -type l \) -exec readlink -f {} \; | sort -u)
  else
    libs+=("$where")
  fi
done
[ ${#libs[@]} -gt 0 ] || { echo "no locd library found in: $*"; exit 1; }
for f in "${libs[@]}"; do
  case "$f" in
    *.dll) objdump -p "$f" | sed -n '/\[Ordinal\/Name Pointer\] Table/,/^$/p' \
             | grep -o 'locd_[A-Za-z0-9_]*' >> "$OUT/exported.raw" || true ;;
    *) nm -D --defined-only "$f" | awk '$2 ~ /^[TW]$/ && $3 ~ /^locd_/ { sub(/@.*/, "", $3); print $3 }' \
             >> "$OUT/exported.raw" ;;
  esac
  echo "library: $f"
done
sort -u "$OUT/exported.raw" > "$OUT/exported.txt"
missing=$(comm -23 "$OUT/exported.txt" "$OUT/declared.txt")
extra=$(comm -13 "$OUT/exported.txt" "$OUT/declared.txt")
echo "exported: $(wc -l < "$OUT/exported.txt"), declared in Native: $(wc -l < "$OUT/declared.txt")"
rc=0
if [ -n "$missing" ]; then echo "exported but not declared in Native:"; echo "$missing" | sed 's/^/  /'; rc=1; fi
if [ -n "$extra" ]; then echo "declared in Native but not exported:"; echo "$extra" | sed 's/^/  /'; rc=1; fi
[ $rc -eq 0 ] && echo "ok: Native covers every exported function"
exit $rc
