#!/usr/bin/env python3
"""Accuracy versus time of the filter pipeline, end to end: writes
docs/accuracy-pipeline.md and docs/img/accuracy-pipeline.png.

    python3 scripts/pipeline_accuracy.py [--locd build/tools/locd] [--seconds 2.0]
    python3 scripts/pipeline_accuracy.py --replot   # only redraw the figure from the page's tables

For each example scene and step size, `locd simulate --ladder` runs the full
pipeline for the dynamics and, on every step's state, the ladder of
configurations: boxes only (broad phase) -> + convex exact (shape test, mesh
pairs left at the box test) -> + mesh exact (every pair exact) -> + swept
(every moving object swept, time of impact). It reports the pairs and the
pipeline time of each rung, and which swept contacts discrete stepping finds
one step late or misses entirely (no overlap left at the step's end).
"""
import argparse
import datetime
import json
import os
import platform
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENES = ["falling_balls", "box_pile", "rocks_on_terrain"]
RUNGS = ["boxes", "convex", "mesh", "swept"]
STEP_SIZES = [1 / 240, 1 / 120, 1 / 60, 1 / 30]


def run(locd, scene, dt, seconds):
    steps = max(1, int(round(seconds / dt)))
    cmd = [locd, "simulate", os.path.join(ROOT, "examples", "scenes", scene + ".json"), "--ladder", "--quiet",
           "--dt", repr(dt), "--steps", str(steps), "--threads", "1"]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    s = json.loads(out.strip().splitlines()[-1])["summary"]
    s["steps_run"] = steps
    return s


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def plot(results, path, seconds):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from matplotlib.ticker import FixedLocator, MaxNLocator, NullFormatter, NullLocator

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    width = 0.2
    ref = 1 / 60
    for k, rung in enumerate(RUNGS):
        ms = [results[(sc, ref)]["ladder"][rung]["ms"] / results[(sc, ref)]["steps_run"] for sc in SCENES]
        a.bar([i + (k - 1.5) * width for i in range(len(SCENES))], ms, width, label=rung)
    a.set_xticks(range(len(SCENES)))
    a.set_xticklabels(SCENES)
    a.set_ylabel("pipeline ms per step")
    a.set_yscale("log")
    # Plain numbers at 1-2-5 steps: a log axis labelled only at powers of ten is hard to read.
    a.yaxis.set_major_locator(FixedLocator([0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5]))
    a.yaxis.set_major_formatter(plt.FuncFormatter(lambda v, _: "%g" % v))
    a.yaxis.set_minor_locator(NullLocator())
    a.yaxis.set_minor_formatter(NullFormatter())
    a.grid(True, axis="y", alpha=0.3)
    a.set_title("time per rung (dt = 1/60 s)")
    a.legend()
    for sc in SCENES:
        xs = [1 / dt for dt in STEP_SIZES]
        ys = [results[(sc, dt)]["ladder"]["missed_by_discrete"] for dt in STEP_SIZES]
        b.plot(xs, ys, marker="o", label=sc)
    b.set_xscale("log", base=2)
    # Ticks at the step rates that were run (30, 60, 120, 240), not at powers of two.
    b.xaxis.set_major_locator(FixedLocator([1 / dt for dt in STEP_SIZES]))
    b.xaxis.set_major_formatter(plt.FuncFormatter(lambda v, _: "%d" % round(v)))
    b.xaxis.set_minor_locator(NullLocator())
    b.yaxis.set_major_locator(MaxNLocator(integer=True))
    b.grid(True, alpha=0.3)
    b.set_xlabel("steps per second (1/dt)")
    b.set_ylabel("contacts missed by discrete stepping")
    b.set_title("caught only by the swept stage (%g s simulated)" % seconds)
    b.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def from_page(path):
    """The figure's numbers from the page's two tables: ms per step of each rung at dt = 1/60, and the
    contacts missed by discrete stepping per step size."""
    results = {(sc, dt): {"steps_run": 1, "ladder": {}} for sc in SCENES for dt in STEP_SIZES}
    seconds = 2.0
    for line in open(path, encoding="utf-8"):
        if "--seconds" in line:
            seconds = float(line.split("--seconds", 1)[1].split()[0].strip("`"))
        cols = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cols) == 10 and cols[0] in SCENES:  # scene, objects, then (pairs, ms) per rung
            for k, rung in enumerate(RUNGS):
                results[(cols[0], 1 / 60)]["ladder"][rung] = {"ms": float(cols[3 + 2 * k])}
        elif len(cols) == 8 and cols[0] in SCENES and cols[1].startswith("1/"):
            dt = 1 / int(cols[1][2:])
            key = min(STEP_SIZES, key=lambda s: abs(s - dt))
            results[(cols[0], key)]["ladder"]["missed_by_discrete"] = int(cols[5])
    return results, seconds


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--locd", default=os.path.join(ROOT, "build", "tools", "locd"))
    ap.add_argument("--seconds", type=float, default=2.0, help="simulated time per run")
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "accuracy-pipeline.md"))
    ap.add_argument("--replot", action="store_true",
                    help="redraw the figure from the tables of --out (the recorded results); run nothing")
    a = ap.parse_args()
    if a.replot:
        results, seconds = from_page(a.out)
        plot(results, os.path.join(os.path.dirname(a.out), "img", "accuracy-pipeline.png"), seconds)
        return
    results = {}
    for sc in SCENES:
        for dt in STEP_SIZES:
            results[(sc, dt)] = run(a.locd, sc, dt, a.seconds)
            print("%s dt=1/%d done" % (sc, round(1 / dt)), file=sys.stderr)
    img_rel = "img/accuracy-pipeline.png"
    os.makedirs(os.path.join(os.path.dirname(a.out), "img"), exist_ok=True)
    plot(results, os.path.join(os.path.dirname(a.out), img_rel), a.seconds)

    L = []
    L.append("# Accuracy versus time: the filter pipeline end to end")
    L.append("")
    L.append("Generated by `python3 scripts/pipeline_accuracy.py --locd %s --seconds %g` on %s (%s), %s."
             % (os.path.relpath(a.locd, ROOT), a.seconds, cpu_model(), platform.machine(),
                datetime.date.today().isoformat()))
    L.append("Single-threaded broad phase (`--threads 1`); times are wall-clock, best of 3 per step, on a shared")
    L.append("machine, so read them as orders of magnitude. Each run simulates %g s of the scene with the full pipeline (the dynamics)," % a.seconds)
    L.append("and on every step's state runs the ladder of configurations (`locd simulate --ladder`):")
    L.append("")
    L.append("| rung | stages | what it decides |")
    L.append("|---|---|---|")
    L.append("| boxes | broad phase only (octree + exact box test) | world boxes overlap |")
    L.append("| convex | + shape test, mesh pairs routed to the box test | convex shapes (closed form / libccd GJK) |")
    L.append("| mesh | + shape test on every pair | meshes too (FCL, or libccd per triangle for hulls) |")
    L.append("| swept | + swept test for every moving object (dt) | contacts at any time in the step (time of impact) |")
    L.append("")
    L.append("## What each stage adds in time and removes in false pairs (dt = 1/60 s)")
    L.append("")
    L.append("Pairs are summed over all steps; ms is the pipeline time per step. \"Removed\" pairs are the previous")
    L.append("rung's false positives (box overlaps that are not shape contacts); the swept rung adds the contacts that")
    L.append("happen inside the step.")
    L.append("")
    L.append("| scene | objects | boxes: pairs | ms | convex: pairs (removed) | ms | mesh: pairs (removed) | ms | swept: pairs (added) | ms |")
    L.append("|---|---|---|---|---|---|---|---|---|---|")
    ref = 1 / 60
    for sc in SCENES:
        r = results[(sc, ref)]
        ld, n = r["ladder"], r["steps_run"]
        p = [ld[k]["pairs"] for k in RUNGS]
        ms = [ld[k]["ms"] / n for k in RUNGS]
        L.append("| %s | %d | %d | %.3f | %d (-%d) | %.3f | %d (-%d) | %.3f | %d (+%d) | %.3f |"
                 % (sc, r["objects"], p[0], ms[0], p[1], p[0] - p[1], ms[1], p[2], p[1] - p[2], ms[2], p[3],
                    p[3] - p[2], ms[3]))
    L.append("")
    L.append("## Contacts discrete stepping misses, by step size")
    L.append("")
    L.append("A swept contact (time of impact inside the step) is *late* for discrete stepping when the shapes still")
    L.append("overlap at the step's end (the next discrete test finds it one step late), and *missed* when they do")
    L.append("not (the objects passed through each other: tunnelling).")
    L.append("")
    L.append("| scene | dt (s) | steps | swept contacts inside the step | late for discrete | missed by discrete | swept ms/step | discrete (mesh rung) ms/step |")
    L.append("|---|---|---|---|---|---|---|---|")
    for sc in SCENES:
        for dt in STEP_SIZES:
            r = results[(sc, dt)]
            ld, n = r["ladder"], r["steps_run"]
            L.append("| %s | 1/%d | %d | %d | %d | %d | %.3f | %.3f |"
                     % (sc, round(1 / dt), n, ld["swept_late"] + ld["missed_by_discrete"], ld["swept_late"],
                        ld["missed_by_discrete"], ld["swept"]["ms"] / n, ld["mesh"]["ms"] / n))
    L.append("")
    L.append("![time per rung and contacts missed by discrete stepping](%s)" % img_rel)
    L.append("")
    L.append("_The figure alone is redrawn from this page's tables, without running anything, by "
             "`python3 scripts/pipeline_accuracy.py --replot`._")
    L.append("")
    L.append("Reading it: the box test alone pairs every rock with the terrain (the terrain's box covers the scene);")
    L.append("the mesh stage removes those. The convex stage removes the box-only pairs among spheres and rocks;")
    L.append("stacked axis-aligned boxes touch for real, so nothing is removed there. The swept stage costs the most")
    L.append("(a bisection of GJK tests per moving pair, per triangle against meshes), which is why")
    L.append("`continuous: auto` sweeps only objects whose motion in the step exceeds `swept_threshold` times their")
    L.append("size. Most contacts inside a step are only late for discrete stepping. The missed ones are the fast ball")
    L.append("and the fast rock (one each, at every step size: they move metres per step), plus, with these simple")
    L.append("dynamics, grazing contacts of objects that bounce off each other or the terrain within one step; more")
    L.append("steps per second give more such short contacts to miss, not fewer, in the rock scene.")
    L.append("")
    with open(a.out, "w") as f:
        f.write("\n".join(L))
    print("wrote %s and %s" % (a.out, img_rel), file=sys.stderr)


if __name__ == "__main__":
    main()
