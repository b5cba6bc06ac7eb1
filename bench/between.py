#!/usr/bin/env python3
"""The two-set query against a single call on the union (docs/benchmarks.md, "Two-set query").

For each case, two sets a and b are generated with `locd gen`, their union is the two files
concatenated (an .aabb file is raw rows), and the script alternates, round after round in one run,
`locd pairs A --against B` (the two-set call) and `locd pairs UNION` (one call on na + nb boxes),
each with --repeat R (the CLI reports the median of its R in-call times). It prints a Markdown
table of the medians over the rounds, and writes it with the machine and the command to --out
(bench/run's report includes bench/results/between.md as its "Two-set query" section).

    python3 bench/between.py --locd build/tools/locd --out bench/results/between.md
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

# (label, kind of a, na, kind of b, nb)
CASES = [
    ("halves of a uniform scene", "uniform", 500_000, "uniform", 500_000),
    ("few against many (1%)", "uniform", 10_000, "uniform", 990_000),
    ("halves, 100k", "uniform", 50_000, "uniform", 50_000),
]


def run(cmd):
    out = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, universal_newlines=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--locd", required=True, help="the locd CLI")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", help="also write the table, machine and command to this Markdown file")
    args = ap.parse_args()
    load_start = " ".join(open("/proc/loadavg").read().split()[:3])
    common = ["--threads", str(args.threads), "--repeat", str(args.repeat)]
    rows = []
    with tempfile.TemporaryDirectory(prefix="locd-between-") as tmp:
        for label, ka, na, kb, nb in CASES:
            a, b, u = (os.path.join(tmp, x + ".aabb") for x in ("a", "b", "u"))
            subprocess.run([args.locd, "gen", ka, str(na), "--seed", "1", "-o", a], check=True,
                           stdout=subprocess.DEVNULL)
            subprocess.run([args.locd, "gen", kb, str(nb), "--seed", "2", "-o", b], check=True,
                           stdout=subprocess.DEVNULL)
            with open(u, "wb") as out:
                for path in (a, b):
                    with open(path, "rb") as f:
                        out.write(f.read())
            two, one = [], []
            for _ in range(args.rounds):
                r2 = run([args.locd, "pairs", a, "--against", b] + common)
                r1 = run([args.locd, "pairs", u] + common)
                two.append(r2["total_ms"])
                one.append(r1["total_ms"])
            rows.append((label, na, nb, r2["pairs"], statistics.median(two), r1["pairs"], statistics.median(one)))
    lines = ["| case | na | nb | two-set pairs | two-set ms | union pairs | union ms | two-set / union |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for label, na, nb, p2, t2, p1, t1 in rows:
        lines.append("| %s | %s | %s | %s | %.2f | %s | %.2f | %.2f |" % (
            label, format(na, ","), format(nb, ","), format(p2, ","), t2, format(p1, ","), t1, t2 / t1))
    print("\n".join(lines))
    if args.out:
        cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
        load_end = " ".join(open("/proc/loadavg").read().split()[:3])
        version = subprocess.run([args.locd, "--version"], stdout=subprocess.PIPE, universal_newlines=True).stdout
        with open(args.out, "w") as f:
            f.write("\n".join(lines) + "\n\n")
            f.write("_Machine: %s, %d cores, %d threads; load average %s at start, %s at end; %s, %s; command: "
                    "`python3 bench/between.py --locd %s --threads %d --rounds %d --repeat %d --out %s` "
                    "(each cell: median over %d rounds of the CLI's median of %d calls)._\n" % (
                        cpu, os.cpu_count(), args.threads, load_start, load_end, version.strip(),
                        time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "BUILD/tools/locd", args.threads,
                        args.rounds, args.repeat, args.out, args.rounds, args.repeat))


if __name__ == "__main__":
    main()
