#!/usr/bin/env bash
# Checks that no public type of the Locd assembly clashes with a Unity type a
# script imports (tools/unity-names.txt): compiles stubs of the Unity
# namespaces, then a generated file with `using UnityEngine; using
# Unity.Collections; using Unity.Jobs; using Unity.Mathematics; using Locd;`
# that names every public Locd type (read from the assembly by reflection)
# unqualified. CS0104 (ambiguous name) fails it.
#   bash bindings/csharp/tests/unity-names.sh Locd.dll OUTDIR
# Exit 0 when the [required] namespaces have no clash; a clash in the
# [advisory] ones (UnityEngine.SceneManagement, Unity.Entities, ...) is printed.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
LOCD_DLL=$1
OUT=$2
mkdir -p "$OUT"
MCS="mcs -langversion:7.2 -nologo"
NAMES="$HERE/tools/unity-names.txt"
$MCS -out:"$OUT/Reflect.exe" "$HERE/tools/Reflect.cs"
mono "$OUT/Reflect.exe" types "$LOCD_DLL" > "$OUT/locd-types.txt"
echo "public Locd types: $(tr '\n' ' ' < "$OUT/locd-types.txt" | sed 's/Locd \([^ ]*\) [0-9]*/\1/g')"
rc=0
for section in required advisory; do
  python3 "$HERE/tools/unity_names.py" stubs "$NAMES" $section > "$OUT/unity-$section-stubs.cs"
  python3 "$HERE/tools/unity_names.py" usingtest "$NAMES" $section "$OUT/locd-types.txt" > "$OUT/UsingTest-$section.cs"
  $MCS -target:library -out:"$OUT/UnityNames-$section.dll" "$OUT/unity-$section-stubs.cs"
  verdict=0
  python3 "$HERE/tools/unity_names.py" clashes "$NAMES" $section "$OUT/locd-types.txt" || verdict=1
  $MCS -target:library -warnaserror+ -r:"$LOCD_DLL" -r:"$OUT/UnityNames-$section.dll" \
    -out:"$OUT/UsingTest-$section.dll" "$OUT/UsingTest-$section.cs" || verdict=1
  if [ $verdict -ne 0 ]; then
    if [ $section = required ]; then
      echo "FAIL: a Locd type name clashes with UnityEngine / Unity.Collections / Unity.Jobs / Unity.Mathematics"; rc=1
    else
      echo "note: a Locd type name clashes with a less common Unity namespace (advisory, not a failure)"
    fi
  else
    echo "ok: [$section] no clash ($(grep -c . "$OUT/locd-types.txt") Locd types)"
  fi
done
exit $rc
