#!/usr/bin/env python3
"""docs/cluster.md's figure and model from bench/mpi_scaling.sh's measurements.

  bench/mpi_plot.py [bench/results/mpi_scaling.jsonl] [docs/img/cluster.png] [bench/results/mpi_model.md]

Reads one JSON line per rank per run (locd-mpi) and the `locd pairs`
reference lines; draws per-stage time, bytes per rank, replicated entries,
imbalance and peak memory per rank against the rank count, both
strategies, 10^6 and 10^7; then calibrates the cost model of
docs/cluster.md on the single-process run and writes its predictions
(time, speedup, efficiency) for the paper's setting and for 10^8 and 10^9
objects on 64 machines, as a Markdown table.
"""
import json
import math
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SRC = sys.argv[1] if len(sys.argv) > 1 else "bench/results/mpi_scaling.jsonl"
PNG = sys.argv[2] if len(sys.argv) > 2 else "docs/img/cluster.png"
MD = sys.argv[3] if len(sys.argv) > 3 else "bench/results/mpi_model.md"
STAGES = ["bounds", "encode_sort", "split", "exchange", "merge", "sweep", "gather"]

# The paper's measured run times (Lucchesi, Egbert, Harris, IJCA 21(4) 2014,
# Tables 1-2): the rows the project records (tools/cmd_bench.c); the other
# rows of its tables are not reproduced here.
PAPER = {(1000000, 1): 29.5, (1000000, 2): 15.58, (1000000, 40): 1.48, (2000000, 1): 59.7, (2000000, 40): 2.89}


def load(path):
    ranks = defaultdict(list)  # (n, strategy, K) -> per-rank records
    ref = {}
    for line in open(path):
        r = json.loads(line)
        if r.get("run") == "locd-pairs":
            ref[r["n"]] = r
        elif "rank" in r:
            ranks[(r["n"], r["strategy"], r["ranks"])].append(r)
    return ranks, ref


def figure(ranks, ref):
    sizes = sorted({k[0] for k in ranks})
    fig, ax = plt.subplots(2, 3, figsize=(15, 8.5))
    colors = {"distributed": "tab:blue", "master": "tab:red"}
    # (a) per-stage time of the slowest rank, stacked, at the largest n
    n = sizes[-1]
    x, labels = 0, []
    stage_colors = plt.cm.tab10.colors
    for strategy in ("distributed", "master"):
        for k in range(1, 5):
            recs = ranks.get((n, strategy, k))
            if not recs:
                continue
            slow = max(recs, key=lambda r: r["total_ms"])
            bottom = 0.0
            for i, s in enumerate(STAGES):
                v = slow["stage_ms"][s] / 1e3
                ax[0, 0].bar(x, v, bottom=bottom, color=stage_colors[i], label=s if x == 0 else None)
                bottom += v
            labels.append(("D" if strategy == "distributed" else "M") + str(k))
            x += 1
    ax[0, 0].set_xticks(range(len(labels)), labels)
    ax[0, 0].set_ylabel("seconds (slowest rank)")
    ax[0, 0].set_title(f"stages at n = {n:.0e} (D = distributed, M = master; K ranks)\n"
                       "oversubscribed on 2 shared cores: read the shape, not the seconds", fontsize=9)
    ax[0, 0].legend(fontsize=7)
    # (b) bytes sent per rank (the largest), per object of the scene
    # (c) entries held per rank (max) and replicated entries (sum)
    # (d) imbalance (sweep work: max / mean)
    # (e) peak memory per rank against 1/K
    for n in sizes:
        style = "-" if n == sizes[-1] else "--"
        for strategy in ("distributed", "master"):
            ks = sorted(k for (nn, s, k) in ranks if nn == n and s == strategy)
            if not ks:
                continue
            c = colors[strategy]
            lab = f"{strategy} n={n:.0e}"
            sent = [max(max(r["bytes_sent"], r["bytes_received"]) for r in ranks[(n, strategy, k)]) / 1e6 for k in ks]
            ax[0, 1].plot(ks, sent, style, marker="o", color=c, label=lab)
            held = [max(r["entries_held"] for r in ranks[(n, strategy, k)]) / n for k in ks]
            ax[0, 2].plot(ks, held, style, marker="o", color=c, label=lab)
            imb = [ranks[(n, strategy, k)][0]["imbalance"] for k in ks]
            ax[1, 0].plot(ks, imb, style, marker="o", color=c, label=lab)
            rss1 = max(r["peak_rss_kb"] for r in ranks[(n, strategy, 1)]) if (n, strategy, 1) in ranks else None
            rss = [max(r["peak_rss_kb"] for r in ranks[(n, strategy, k)]) / 1024 for k in ks]
            ax[1, 1].plot(ks, rss, style, marker="o", color=c, label=lab)
            if strategy == "distributed" and rss1:
                ax[1, 1].plot(ks, [rss1 / 1024 / k for k in ks], ":", color="gray")
                if n == sizes[-1]:  # the target: at most 40% of the 1-rank peak at 4 ranks
                    ax[1, 1].plot([4], [0.4 * rss1 / 1024], "kx")
                    ax[1, 1].annotate("40% of 1 rank", (3.3, 0.4 * rss1 / 1024 + 15), fontsize=7)
        if n in ref:
            ax[1, 1].axhline(ref[n]["peak_rss_kb"] / 1024, color="black", lw=0.8, ls=style)
            ax[1, 1].annotate(f"locd pairs n={n:.0e}", (3.0, ref[n]["peak_rss_kb"] / 1024), fontsize=7)
    ax[0, 1].set_title("bulk MB sent or received by the busiest rank", fontsize=9)
    ax[0, 2].set_title("entries held by the largest rank / n (replicated ones included)", fontsize=9)
    ax[1, 0].set_title("imbalance: max / mean of sweep work (entries + candidates)", fontsize=9)
    ax[1, 1].set_title("peak memory per rank (MB, ru_maxrss); dotted: 1/K of -np 1", fontsize=9)
    for a in (ax[0, 1], ax[0, 2], ax[1, 0], ax[1, 1]):
        a.set_xlabel("ranks K")
        a.set_xticks([1, 2, 3, 4])
        a.legend(fontsize=7)
    return fig, ax


def calibrate(ranks, ref, n):
    """Per-object costs from the single-process run of each strategy at n;
    the exchange's local work (routing, packing, the copies over shared
    memory) and the sort of what arrives, which one rank does not have,
    and the master's merge of several runs, from the 2-rank runs (two ranks
    on two cores), per object a rank holds."""
    d = ranks[(n, "distributed", 1)][0]
    m = ranks[(n, "master", 1)][0]
    d2 = max(ranks[(n, "distributed", 2)], key=lambda r: r["total_ms"])
    m2 = [r for r in ranks[(n, "master", 2)] if r["rank"] == 0][0]
    k4 = ranks.get((n, "distributed", 4))
    cal = {
        "encode": d["stage_ms"]["encode_sort"] / 1e3 / n,
        "pack": d2["stage_ms"]["exchange"] / 1e3 / (n / 2),
        "sort": d2["stage_ms"]["merge"] / 1e3 / (n / 2),
        "sweep": d["stage_ms"]["sweep"] / 1e3 / n,
        "mmerge": m2["stage_ms"]["merge"] / 1e3 / n,
        "msweep": m["stage_ms"]["sweep"] / 1e3 / n,
        "entries": d["entries_encoded"] / n,
        "serial": ref[n]["total_ms"] / 1e3 / n if n in ref else None,
    }
    # bytes a rank sends per object it holds, when all but 1/K stays home
    if k4:
        sent = sum(r["bytes_sent"] for r in k4)
        cal["xbytes"] = sent / n / (3 / 4)  # all-to-all: (K-1)/K of the data leaves its rank
        cal["imbalance"] = k4[0]["imbalance"]
    else:
        cal["xbytes"] = 8 * cal["entries"] + 28
        cal["imbalance"] = 1.0
    cal["mbytes"] = 8 * cal["entries"] + 24  # master: sorted entries and the boxes
    return cal


def model(cal, n, machines, per_machine, gbit, latency_s):
    """Predicted seconds (distributed, master) for n objects on machines x per_machine ranks."""
    k = machines * per_machine
    bw = gbit * 1e9 / 8  # bytes/s per machine link
    local = n / k
    rounds = math.log2(k) + 3 if k > 1 else 0  # bounds, sample and splitter collectives
    # distributed: every rank's share of the work, its exchange through its
    # machine's link (the ranks of a machine share it; 1/machines stays home)
    off = (machines - 1) / machines if machines > 1 else 0.0
    xfer = per_machine * local * cal["xbytes"] * off / bw + (k - 1) * latency_s
    if k == 1:  # one rank moves nothing
        dist = n * (cal["encode"] + cal["sweep"])
    else:
        dist = local * (cal["encode"] + cal["pack"] + cal["sort"]) + local * cal["sweep"] * cal["imbalance"] + xfer
    dist += rounds * latency_s
    # master: encode and sort in parallel, then everything into one link,
    # the merge of k runs and the whole sweep on one rank
    gather = n * cal["mbytes"] * off / bw + (k - 1) * latency_s
    merge = n * cal["mmerge"] * max(1.0, math.log2(k) / 2)
    if k == 1:
        merge = 0.0
    master = local * cal["encode"] + gather + merge + n * cal["msweep"] + rounds * latency_s
    return dist, master


def model_table(cal, n_cal):
    serial = lambda n: n * (cal["serial"] or (cal["encode"] + cal["sweep"]))  # noqa: E731
    nets = [("1 Gb/s (the paper's era)", 1.0, 50e-6), ("25 Gb/s", 25.0, 5e-6)]
    L = [f"Model calibrated on the single-process runs at n = {n_cal:.0e} (per object: encode+sort "
         f"{cal['encode']*1e9:.0f} ns, exchange's local work {cal['pack']*1e9:.0f} ns and received-entry sort {cal['sort']*1e9:.0f} ns (2-rank run), "
         f"sweep {cal['sweep']*1e9:.0f} ns, master's merge of 2 runs {cal['mmerge']*1e9:.0f} ns; exchange {cal['xbytes']:.1f} bytes per object; master gather "
         f"{cal['mbytes']:.1f} bytes per object; imbalance {cal['imbalance']:.3f}); serial reference "
         f"{(cal['serial'] or 0)*1e9:.0f} ns per object (`locd pairs --threads 1`).", ""]
    L.append("| objects | machines x processes | network | distributed | speedup | efficiency | master | speedup | "
             "paper (measured, 2014) | paper speedup | paper efficiency |")
    L.append("|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for n in (1000000, 2000000):
        for machines, per in ((1, 1), (1, 2), (20, 2)):
            k = machines * per
            for net, gbit, lat in nets:
                if k == 1 and gbit != 1.0:
                    continue
                d, m = model(cal, n, machines, per, gbit, lat)
                t1 = serial(n)
                p = PAPER.get((n, k))
                p1 = PAPER.get((n, 1))
                paper = f"{p:.2f} s | {p1 / p:.2f} | {100 * p1 / p / k:.1f}%" if p and p1 else "- | - | -"
                L.append(f"| {n:,} | {machines} x {per} | {net if k > 1 else '-'} | {d*1e3:.1f} ms | {t1/d:.2f} | "
                         f"{100*t1/d/k:.0f}% | {m*1e3:.1f} ms | {t1/m:.2f} | {paper} |")
    L.append("")
    L.append("| objects | machines x processes | network | distributed | speedup | efficiency | master | "
             "memory per rank (distributed) | master's memory |")
    L.append("|---:|---:|---|---:|---:|---:|---:|---:|---:|")
    for n in (10**8, 10**9):
        for net, gbit, lat in nets:
            d, m = model(cal, n, 64, 2, gbit, lat)
            t1 = serial(n)
            per_rank = n / 128 * cal.get("bytes_per_object_rank", 110) / 2**30
            master_mem = n * cal.get("bytes_per_object_master", 70) / 2**30
            L.append(f"| {n:.0e} | 64 x 2 | {net} | {d:.2f} s | {t1/d:.0f} | {100*t1/d/128:.0f}% | {m:.2f} s | "
                     f"{per_rank:.2f} GiB | {master_mem:.0f} GiB on one rank |")
    return "\n".join(L) + "\n"


def main():
    ranks, ref = load(SRC)
    fig, ax = figure(ranks, ref)
    n_cal = max(k[0] for k in ranks if k[2] == 1)
    cal = calibrate(ranks, ref, n_cal)
    # memory per object: measured peak per rank at the largest K over its share
    kmax = max(k for (nn, s, k) in ranks if nn == n_cal and s == "distributed")
    cal["bytes_per_object_rank"] = max(r["peak_rss_kb"] for r in ranks[(n_cal, "distributed", kmax)]) * 1024 / (n_cal / kmax)
    cal["bytes_per_object_master"] = max(r["peak_rss_kb"] for r in ranks[(n_cal, "master", kmax)]) * 1024 / n_cal
    # (f) the model at the paper's setting: time against processes, 1M objects
    procs = [1, 2, 4, 8, 16, 20, 40]
    for net, gbit, lat, ls in (("1 Gb/s", 1.0, 50e-6, "-"), ("25 Gb/s", 25.0, 5e-6, "--")):
        ds, ms = [], []
        for p in procs:
            machines, per = (p // 2, 2) if p >= 2 else (1, 1)
            d, m = model(cal, 1000000, machines, per, gbit, lat)
            ds.append(d * 1e3)
            ms.append(m * 1e3)
        ax[1, 2].plot(procs, ds, ls, color="tab:blue", marker="o", label=f"distributed, {net}")
        ax[1, 2].plot(procs, ms, ls, color="tab:red", marker="s", label=f"master, {net}")
    ax[1, 2].set_xscale("log", base=2)
    ax[1, 2].set_yscale("log")
    ax[1, 2].set_xlabel("processes (2 per machine)")
    ax[1, 2].set_ylabel("predicted ms, 10^6 uniform cubes")
    ax[1, 2].set_title("model (calibrated here); paper 2014: 29.5 s at 1, 1.48 s at 40 processes", fontsize=9)
    ax[1, 2].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(PNG, dpi=110)
    open(MD, "w").write(model_table(cal, n_cal))
    print(open(MD).read())
    print(f"wrote {PNG} and {MD}")


if __name__ == "__main__":
    main()
