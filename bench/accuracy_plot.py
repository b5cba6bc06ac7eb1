#!/usr/bin/env python3
"""Draws docs/img/accuracy.png from the CSV written by `locd accuracy`.

usage: accuracy_plot.py ACCURACY.csv OUT.png

Three panels for the largest scene size in the CSV: total time against the
octree depth limit, total time and false candidates against the level-choice
bias, and the per-stage time of the default beside the alternatives (cubes,
bias 0 and 3, float64 input), as CPU time split in the proportion of the stages'
wall times (steadier than wall time on a shared machine). Only rows with stage == "broad" are drawn;
other stages may share the CSV.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.ticker import FixedLocator, NullFormatter, NullLocator  # noqa: E402

STAGES = ["bounds", "encode", "sort", "merge", "sweep"]


def load(path):
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["stage"] == "broad"]
    for r in rows:
        for k in ("n", "depth", "entries", "candidates", "exact_tests", "pairs", "default", "threads"):
            r[k] = int(float(r[k]))
        for k in list(r):
            if k.startswith("ms_") or k.endswith("_mib") or k == "cpu_ms":
                r[k] = float(r[k])
    return rows


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rows = load(sys.argv[1])
    n = max(r["n"] for r in rows)
    rows = [r for r in rows if r["n"] == n]
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    fig, ax = plt.subplots(1, 3, figsize=(17, 5.2))

    for s in scenes:
        pts = sorted((r["depth"], r["cpu_ms"], r["default"]) for r in rows
                     if r["scene"] == s and r["knob"] == "max_depth")
        line, = ax[0].plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=s)
        for d, t, is_def in pts:
            if is_def:
                ax[0].plot([d], [t], "*", ms=16, color=line.get_color())
    ax[0].set_xlabel("octree depth used (max_depth; the star is the default, automatic)")
    ax[0].set_ylabel("CPU ms per call")
    ax[0].set_title("Depth limit ({:,} objects)".format(n))
    ax[0].legend()

    twin = ax[1].twinx()
    for s in scenes:
        pts = sorted((int(r["value"]), r["cpu_ms"], (r["candidates"] - r["pairs"]) / r["n"]) for r in rows
                     if r["scene"] == s and r["knob"] == "cell_bias")
        line, = ax[1].plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=s)
        twin.plot([p[0] for p in pts], [p[2] for p in pts], "x--", color=line.get_color(), alpha=0.6)
    ax[1].axvline(2, color="grey", lw=0.8, ls=":")
    ax[1].set_xticks([0, 1, 2, 3])
    ax[1].set_xlabel("cell_bias (dotted: default 2)")
    ax[1].set_ylabel("CPU ms per call (solid)")
    twin.set_ylabel("false candidates per object (dashed)")
    twin.set_yscale("log")
    # Plain numbers on the log axis (5, 10, 20, 50), not 2x10^1.
    twin.yaxis.set_major_locator(FixedLocator([1, 2, 5, 10, 20, 50, 100, 200]))
    twin.yaxis.set_major_formatter(plt.FuncFormatter(lambda v, _: "%g" % v))
    twin.yaxis.set_minor_locator(NullLocator())
    twin.yaxis.set_minor_formatter(NullFormatter())
    ax[1].set_title("Level-choice bias ({:,} objects)".format(n))
    # Colours are the scenes of the first panel; here the legend says which line is which axis.
    ax[1].legend(handles=[Line2D([], [], color="black", marker="o", label="CPU ms per call (left axis)"),
                          Line2D([], [], color="black", marker="x", ls="--", alpha=0.6,
                                 label="false candidates per object (right)")],
                 loc="center left", fontsize=8)

    variants = [("default", lambda r: r["knob"] == "shape" and r["value"] == "boxes"),
                ("cubes", lambda r: r["knob"] == "shape" and r["value"] == "cubes"),
                ("bias 0", lambda r: r["knob"] == "cell_bias" and r["value"] == "0"),
                ("bias 3", lambda r: r["knob"] == "cell_bias" and r["value"] == "3"),
                ("float64", lambda r: r["knob"] == "precision" and r["value"] == "float64")]
    width = 0.8 / len(variants)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for vi, (vname, pick) in enumerate(variants):
        for si, s in enumerate(scenes):
            r = next((r for r in rows if r["scene"] == s and pick(r)), None)
            if r is None:
                continue
            bottom = 0.0
            x = si + (vi - (len(variants) - 1) / 2) * width
            # Wall times on a shared machine include waiting: split the call's
            # CPU time in the proportion of the stages' (least) wall times.
            wall = sum(r["ms_" + st] for st in STAGES) or 1.0
            for k, st in enumerate(STAGES):
                h = r["cpu_ms"] * r["ms_" + st] / wall
                ax[2].bar(x, h, width * 0.95, bottom=bottom, color=colors[k % len(colors)],
                          label=st if (vi == 0 and si == 0) else None, edgecolor="black", linewidth=0.3)
                bottom += h
            ax[2].text(x, bottom, vname, rotation=90, ha="center", va="bottom", fontsize=7)
    ax[2].set_xticks(range(len(scenes)))
    ax[2].set_xticklabels(scenes)
    ax[2].set_ylabel("CPU ms per call, split by the stages' wall times")
    ax[2].set_title("Where the time goes ({:,} objects)".format(n))
    ax[2].legend(fontsize=8)
    ymax = ax[2].get_ylim()[1]
    ax[2].set_ylim(0, ymax * 1.25)

    fig.suptitle("locd broad phase: what each knob costs (the answer is the same exact pair set in every case)")
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=110)


if __name__ == "__main__":
    main()
