#!/usr/bin/env bash
# From 10^3 to 10^8 uniform cubes (docs/benchmarks.md, "From 10^3 to 10^8"):
# for each decade, `locd gen uniform N`, then `locd pairs` on 2 threads
# under /usr/bin/time -v (its maximum resident set size), once without
# --out (the pairs stay in memory) and once with --out (sorted by (i, j)
# and written), and the independent count of bench/count_pairs (a uniform
# grid, no locd code). Prints a Markdown table: pairs, independent count,
# in-call time (median of the repeats) and time per object, peak memory and
# the bytes per object beyond the input (24 bytes: float32) and the
# process's fixed cost (the peak of a 2-box run). At the largest size it
# also runs `locd pairs` with the address space limited to the input and
# half of what the call needs beyond it
# and prints the message (out of memory is an error, never a crash).
#   bench/scale.sh [BUILD_DIR] [MAX_EXPONENT]   (defaults: build, 8; MIN_EXP=3)
# A 10^8 scene is 2.4 GB and the run needs about 8.5 GB: check `free -g`
# first. Scenes go to ${TMPDIR:-/tmp} and are deleted after each decade.
set -euo pipefail
B=${1:-build}
MAX=${2:-8}
T=${THREADS:-2}
locd="$B/tools/locd"
count="$B/bench/count_pairs"
for x in "$locd" "$count" /usr/bin/time; do
  [ -x "$x" ] || { echo "missing $x (build $B first; /usr/bin/time is Debian's time package)"; exit 1; }
done
dir=$(mktemp -d "${TMPDIR:-/tmp}/locd-scale.XXXXXX")
trap 'rm -rf "$dir"' EXIT

peak_kb() { sed -n 's/.*Maximum resident set size (kbytes): //p' "$1"; }
field() { python3 -c 'import json,sys; d=json.loads(sys.stdin.readline()); print(d[sys.argv[1]])' "$1"; }

"$locd" gen uniform 2 -o "$dir/tiny.aabb" >/dev/null
/usr/bin/time -v "$locd" pairs "$dir/tiny.aabb" --threads "$T" --repeat 1 >/dev/null 2>"$dir/tiny.time"
base=$(peak_kb "$dir/tiny.time")

echo "| objects | pairs | independent count | in-call ms ($T threads) | ns / object | peak MB | bytes / object beyond input | peak MB with --out | bytes / object with --out | gen s |"
echo "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for e in $(seq "${MIN_EXP:-3}" "$MAX"); do
  n=$(python3 -c "print(10**$e)")
  scene="$dir/u$e.aabb"
  reps=$(( e >= 8 ? 2 : e >= 7 ? 3 : 5 ))
  g0=$(date +%s.%N)
  "$locd" gen uniform "$n" -o "$scene" >/dev/null
  g1=$(date +%s.%N)
  /usr/bin/time -v "$locd" pairs "$scene" --threads "$T" --repeat "$reps" >"$dir/run.json" 2>"$dir/run.time"
  /usr/bin/time -v "$locd" pairs "$scene" --threads "$T" --repeat 1 --out "$dir/pairs.bin" >/dev/null 2>"$dir/out.time"
  rm -f "$dir/pairs.bin"
  if [ "$e" = "$MAX" ]; then # out of memory: room for the input and half of what the call needs beyond it
    input_kb=$(( n * 24 / 1024 ))
    lim=$(( base + input_kb + ($(peak_kb "$dir/run.time") - base - input_kb) / 2 ))
    oom_rc=0
    oom_msg=$( (ulimit -v "$lim"; "$locd" pairs "$scene" --threads "$T" --repeat 1 2>&1 >/dev/null) ) || oom_rc=$?
    oom="With the address space limited to ${lim} kB (\`ulimit -v\`: the input and half of what the call needs beyond it) at 10^$e, \`locd pairs\` exits $oom_rc with: \`$oom_msg\`"
  fi
  ref=$(field pairs < <("$count" "$scene"))
  rm -f "$scene"
  pairs=$(field pairs < "$dir/run.json")
  ms=$(field total_ms < "$dir/run.json")
  p1=$(peak_kb "$dir/run.time")
  p2=$(peak_kb "$dir/out.time")
  python3 - "$n" "$pairs" "$ref" "$ms" "$p1" "$p2" "$base" "$g0" "$g1" <<'PY'
import sys
n, pairs, ref = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
ms, p1, p2, base = float(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6]), int(sys.argv[7])
gen = float(sys.argv[9]) - float(sys.argv[8])
def per(kb):  # below 10^5 objects the fixed cost's noise is larger than the data
    v = (kb - base) * 1024.0 / n - 24
    return f"{v:.1f}" if n >= 10**5 else "(fixed cost)"
mark = "" if pairs == ref else " **MISMATCH**"
print(f"| 10^{len(str(n)) - 1} | {pairs:,} | {ref:,}{mark} | {ms:,.2f} | {ms * 1e6 / n:.0f} | {p1 / 1024:,.0f} | {per(p1)} | {p2 / 1024:,.0f} | {per(p2)} | {gen:.1f} |")
PY
done
echo
[ -n "${oom:-}" ] && echo "$oom" && echo
echo "_Fixed cost subtracted: ${base} kB (the peak of a 2-box run). CPU: $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1), $(nproc) cores; kernel: ${LOCD_KERNEL:-(best the CPU has)}; command: \`bench/scale.sh $B $MAX\`; $(date -u '+%Y-%m-%d %H:%M') UTC._"
