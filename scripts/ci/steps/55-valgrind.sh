#!/usr/bin/env bash
# Valgrind memcheck over every C example and a short run of the CLI: any
# memory error or definite/indirect leak fails. Uses the debug-info build of
# the ABI step (build-ci/abi), so reports carry file:line. One JUnit testcase
# per program run.
set -uo pipefail
cd "$ROOT"
BUILD=${LOCD_ABI_BUILD:-build-ci/abi}
rc=0
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

if ! bash scripts/abi.sh build >/dev/null; then
  python3 scripts/ci/junit.py case valgrind build failed "$BUILD did not build" > "$LOCD_RESULTS/valgrind-build.junit.xml"
  exit 1
fi

vg=(valgrind --tool=memcheck --error-exitcode=1 --leak-check=full --show-leak-kinds=definite,indirect
    --errors-for-leak-kinds=definite,indirect --num-callers=30 --quiet)

# memcheck NAME COMMAND...: one testcase. --quiet leaves a process's log
# empty unless valgrind found something, so a non-empty log (of the program
# or, with extra_vg=(--trace-children=yes), of any process it started) fails
# as well as a non-zero exit.
extra_vg=()
memcheck() {
  local name=$1 st=0 logs
  shift
  echo "== valgrind $name: $*"
  "${vg[@]}" "${extra_vg[@]}" --log-file="$tmp/$name.%p.vg" "$@" > "$tmp/$name.out" 2>&1 || st=$?
  logs=$(cat "$tmp/$name".*.vg 2>/dev/null)
  if [ "$st" -eq 0 ] && [ -z "$logs" ]; then
    python3 scripts/ci/junit.py case valgrind "$name" passed > "$LOCD_RESULTS/valgrind-$name.junit.xml"
  else
    echo "FAILED: $name (exit $st)"
    cat "$tmp/$name.out"
    echo "$logs"
    python3 scripts/ci/junit.py case valgrind "$name" failed "exit $st: ${logs: -3000} $(tail -c 800 "$tmp/$name.out")" \
      > "$LOCD_RESULTS/valgrind-$name.junit.xml"
    rc=1
  fi
}

# Every executable defined in examples/meson.build, found through Meson's
# introspection so that new examples are checked without editing this file.
examples=$(meson introspect --targets "$BUILD" | python3 -c '
import json, sys
for t in json.load(sys.stdin):
    if t["type"] == "executable" and "/examples/" in t["defined_in"].replace("\\", "/"):
        print(t["filename"][0])')
if [ -z "$examples" ]; then
  python3 scripts/ci/junit.py case valgrind examples failed "no example executables in $BUILD" \
    > "$LOCD_RESULTS/valgrind-examples.junit.xml"
  rc=1
fi
for exe in $examples; do
  memcheck "example-$(basename "$exe")" "$exe"
done

locd="$BUILD/tools/locd"
memcheck cli-gen "$locd" gen uniform 20000 --seed 3 -o "$tmp/u.aabb"
memcheck cli-pairs "$locd" pairs "$tmp/u.aabb" --threads 2 --out "$tmp/p.bin"
if [ "$rc" -eq 0 ] && [ ! -s "$tmp/p.bin" ]; then
  echo "locd pairs wrote no pairs file"
  rc=1
fi

# Level 2, the worker processes traced too, when this build has it.
if "$locd" pairs "$tmp/u.aabb" --workers 2 > /dev/null 2>&1; then
  extra_vg=(--trace-children=yes)
  memcheck cli-pairs-workers "$locd" pairs "$tmp/u.aabb" --workers 2 --out "$tmp/p2.bin"
  extra_vg=()
else
  echo "level 2 not available in this build: no valgrind run of the workers"
fi

# Level 3: the service under memcheck serves one client (also under memcheck)
# and stops on SIGTERM; its exit status and log carry valgrind's verdict.
mkdir -m 700 "$tmp/sock"
"${vg[@]}" --log-file="$tmp/serve.vg" "$locd" serve --listen "unix:$tmp/sock/s.sock" > "$tmp/serve.out" 2>&1 &
server=$!
for _ in $(seq 1 300); do
  [ -S "$tmp/sock/s.sock" ] && break
  kill -0 "$server" 2>/dev/null || break
  sleep 0.1
done
if [ -S "$tmp/sock/s.sock" ]; then
  memcheck cli-pairs-service "$locd" pairs "$tmp/u.aabb" --service "unix:$tmp/sock/s.sock" --out "$tmp/p3.bin"
  kill -TERM "$server"
  st=0
  wait "$server" || st=$?
  if [ "$st" -eq 0 ] && [ ! -s "$tmp/serve.vg" ]; then
    python3 scripts/ci/junit.py case valgrind serve passed > "$LOCD_RESULTS/valgrind-serve.junit.xml"
  else
    echo "FAILED: serve (exit $st)"
    cat "$tmp/serve.out" "$tmp/serve.vg"
    python3 scripts/ci/junit.py case valgrind serve failed "exit $st: $(tail -c 3000 "$tmp/serve.vg") $(tail -c 500 "$tmp/serve.out")" \
      > "$LOCD_RESULTS/valgrind-serve.junit.xml"
    rc=1
  fi
else
  kill "$server" 2>/dev/null
  wait "$server" 2>/dev/null
  echo "level 3 not available in this build (locd serve did not listen): $(head -c 300 "$tmp/serve.out")"
fi
exit $rc
