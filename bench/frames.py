#!/usr/bin/env python3
"""bench/frames.py: frame to frame, locd's scene against a full rebuild and against the incremental
paths of Bullet's btDbvtBroadphase and FCL's DynamicAABBTreeCollisionManager.

    bench/frames.py                 full grid: n = 1e5, 1e6; 1%, 10%, 100% moving; 0% and 90% static
    bench/frames.py --quick         CI-sized (n = 2,000, 3 frames); results under bench/results/tmp/
    bench/frames.py --report-only   regenerate bench/results/frames.md and docs/img/frames.png (and
                                    frames_cold.md, frames_cold.png)
    bench/frames.py --sizes 1e3,1e4,1e5 --pause 16 --evict 64
                                    between a game's other work (frames_cold.md, docs/img/frames_cold.png)

Each row is one run of bench/frames_peers on `locd gen uniform N --seed 1`: every system is built
once and kept across the frames, the systems take turns within each frame (the order rotating), and
the figure is the median per frame. With --reps R > 1 the whole grid runs R times, rows interleaved,
and each figure is the median of the R medians. bench/run --report-only puts bench/results/frames.md
into docs/benchmarks.md.

With --pause MS or --evict MB, each system's frame follows the rest of a game's frame (frames_peers
--pause, --evict: MS ms asleep, its threads idle; MB megabytes written and read, its memory out of
the caches), and the files are frames_cold.* (bench/run puts frames_cold.md after frames.md).
"""
import argparse
import datetime
import importlib.machinery
import json
import os
import shlex
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# bench/run's helpers (machine, SIMD kernel, commit, load, number formats); it re-executes itself under
# the project's venv when matplotlib is missing, so import it the same way.
bench_run = importlib.machinery.SourceFileLoader("bench_run", str(ROOT / "bench" / "run")).load_module()
plt = bench_run.plt
from matplotlib import ticker  # noqa: E402

SYSTEMS = ["locd", "locd_1t", "rebuild", "bullet_dbvt", "fcl_dynamic_aabb_tree"]
LABELS = {
    "locd": "locd scene update",
    "locd_1t": "locd scene update, 1 thread",
    "rebuild": "locd full find_pairs (rebuild)",
    "bullet_dbvt": "Bullet btDbvtBroadphase (setAabb + calculateOverlappingPairs)",
    "fcl_dynamic_aabb_tree": "FCL DynamicAABBTree (update + collide)",
}
COLORS = {"locd": "#000000", "locd_1t": "#2ca02c", "rebuild": "#7f7f7f", "bullet_dbvt": "#d62728", "fcl_dynamic_aabb_tree": "#1f77b4"}


def grid(args):
    rows = []
    for n in [int(float(x)) for x in args.sizes.split(",")]:
        for st in [float(x) for x in args.statics.split(",")]:
            for mv in [float(x) for x in args.moving.split(",")]:
                rows.append((n, st, mv))
    return rows


def run_grid(args, exe, locd, results):
    tmp = ROOT / "bench" / "results" / "tmp"
    tmp.mkdir(parents=True, exist_ok=True)
    out = {}
    for rep in range(args.reps):
        for n, st, mv in grid(args):
            scene = tmp / ("frames-uniform-%d.aabb" % n)
            if not scene.exists():
                bench_run.run([locd, "gen", "uniform", n, "--seed", "1", "-o", scene], stdout=subprocess.DEVNULL)
            frames = args.frames if n < 10 ** 6 else args.frames_large
            cmd = [exe, scene, "--moving", mv, "--static", st, "--frames", frames, "--seed", rep + 1]
            if args.pause or args.evict:
                cmd += ["--pause", args.pause, "--evict", args.evict]
            if args.threads:
                cmd += ["--threads", args.threads]
            res = bench_run.run(cmd, capture_output=True, text=True)
            line = json.loads(res.stdout.strip().splitlines()[-1])
            bench_run.log("  " + " ".join("%s %.3f ms" % (k, v["ms"]) for k, v in line["systems"].items()))
            out.setdefault((n, st, mv), []).append(line)
    with open(results / (stem(args) + ".jsonl"), "w") as f:
        for key in sorted(out):
            for line in out[key]:
                f.write(json.dumps(line) + "\n")


def stem(args):
    """The files' name: frames, or frames_cold for frames between a game's other work."""
    return "frames_cold" if args.pause or args.evict else "frames"


def warmup_of(results, name):
    """The warm-up frames of the runs (frames_peers --warmup; none before it had the option)."""
    w = {json.loads(t).get("warmup", 0) for t in (results / (name + ".jsonl")).read_text().splitlines()}
    return "/".join(str(x) for x in sorted(w))


def load(results, name):
    rows = {}
    for text in (results / (name + ".jsonl")).read_text().splitlines():
        line = json.loads(text)
        rows.setdefault((line["n"], line["static_fraction"], line["moving"]), []).append(line)
    table = []
    for (n, st, mv), lines in sorted(rows.items()):
        r = {"n": n, "static": st, "moving": mv, "reps": len(lines), "frames": lines[0]["frames"],
             "threads": lines[0]["threads"], "moved": lines[0]["moved_per_frame"]}
        for s in SYSTEMS:
            vals = [ln["systems"][s]["ms"] for ln in lines if s in ln["systems"]]
            r[s] = statistics.median(vals) if vals else None
            means = [ln["systems"][s]["mean_ms"] for ln in lines if "mean_ms" in ln["systems"].get(s, {})]
            r[s + "_mean"] = statistics.median(means) if means else None
            r[s + "_pairs"] = lines[-1]["systems"].get(s, {}).get("pairs")
        r["ratio_mean"] = r["locd_mean"] / r["rebuild_mean"] if r["locd_mean"] and r["rebuild_mean"] else None
        table.append(r)
    return table


def pct(x):
    return "%g%%" % (100 * x)


def report(name, results, img_dir, meta):
    table = load(results, name)
    if name == "frames_cold":
        report_cold(table, results, img_dir, meta)
        return
    fmt = bench_run.fmt_ms
    cmd = meta["command"]
    L = ["## Frame to frame: scene update vs rebuild, Bullet and FCL", ""]
    L.append("A world that changes a little each frame: `locd gen uniform N --seed 1`, a fraction of "
             "the cubes static (chosen by seed), each frame a random fraction of the others moved by up to 3%% of "
             "the cube edge per axis. Every system is built once and kept across frames: locd's scene "
             "(`locd_scene_move_f32` + `locd_scene_update`, pairs and created/lost lists), a full "
             "`locd_engine_find_pairs_f32` on the same boxes (rebuild), Bullet's `btDbvtBroadphase` (`setAabb` "
             "per moved proxy, then `calculateOverlappingPairs`, then one pass over its pair cache for the exact pairs; statics are `StaticFilter` proxies) and FCL's "
             "`DynamicAABBTreeCollisionManager` (moved objects' AABBs set, `update(moved)`, `collide()` plus "
             "`collide(static manager)`; statics in a manager of their own). Bullet's tree margin is an "
             "absolute 0.05, made for unit-sized boxes: Bullet gets the scene scaled by the power of two that brings "
             "the mean edge nearest to 1 (exact in floating point: the same overlaps). The systems take turns within "
             "each frame; figures are medians per frame (of %d interleaved repetitions of the grid; the column "
             "'the same, means' divides the means per frame, which count the frames that build locd's near-pair "
             "list, [scene.md](scene.md#the-near-pair-list)), after %s "
             "warm-up frames that every system runs and that are not counted (a kept broad phase touches its "
             "memory for the first time in its first frames: locd's rotating pair lists and kept entry list, the "
             "peers' pair caches). "
             "locd runs on %s threads, and on one thread in a second scene (like for like: Bullet and FCL have no "
             "threads on these paths)." % (
                 meta["reps"], warmup_of(results, name), meta.get("threads", "?")))
    L.append("")
    L.extend(frame_table(table))
    L.append("")
    big = max((r["n"] for r in table), default=0)
    goals = [(0.0, 0.01, 0.10, "1% moving: update at most 10% of a rebuild"),
             (0.0, 1.0, 1.10, "100% moving: at most 1.1x a rebuild"),
             (0.9, 0.01, 0.05, "90% static, 1% moving: at most 5% of a rebuild")]
    L.append("The scene's goals at n = %s (update / rebuild, medians of this run, where each of locd's frames "
             "follows Bullet's and FCL's and finds the caches holding their trees; the goals are stated for "
             "`locd frames`, where the update and the rebuild alternate alone: [scene.md](scene.md#costs)):"
             % bench_run.fmt_n(big))
    L.append("")
    for st, mv, goal, text in goals:
        r = next((r for r in table if r["n"] == big and r["static"] == st and r["moving"] == mv), None)
        if r:
            ratio = r["locd"] / r["rebuild"]
            means = "; of the means per frame %.3f" % r["ratio_mean"] if r["ratio_mean"] else ""
            L.append("- %s: %.3f, %s%s." % (text, ratio, "met" if ratio <= goal else "**not met**", means))
    faster = all(r["locd"] < min(r[s] for s in ("bullet_dbvt", "fcl_dynamic_aabb_tree") if r[s] is not None)
                 for r in table)
    L.append("- Faster per frame than Bullet's and FCL's incremental paths at every row: %s." % (
        "yes (2 threads; on 1 thread too)" if faster and all(
            r["locd_1t"] < min(r["bullet_dbvt"], r["fcl_dynamic_aabb_tree"]) for r in table) else
        "yes" if faster else "**no**"))
    L.append("")
    spread = [ln["systems"]["rebuild"]["ms"] for text in (results / "frames.jsonl").read_text().splitlines()
              for ln in [json.loads(text)] if ln["n"] == big and "rebuild" in ln["systems"]]
    if spread:
        L.append("The update/rebuild ratio is the noisiest figure here: the rebuild runs on both cores and suffers "
                 "most when other jobs take one (its per-run median at %s ranged from %s to %s over this grid)." % (
                     bench_run.fmt_n(big), fmt(min(spread)), fmt(max(spread))))
    L.append("")
    L.append("Pairs after the last frame: every system reports the same exact set (static-static pairs excluded), "
             "except the rebuild, whose count includes the static-static pairs. Bullet's pair cache is a superset (it "
             "pairs margin-fattened tree volumes and drops a pair only when its incremental cleanup finds the volumes "
             "apart); its frame time includes one pass over the cache keeping the pairs whose boxes overlap.")
    L.append("")
    L.extend(pairs_table(table))
    L.append("")
    L.append("![frame time against the fraction moving](img/frames.png)")
    L.append("")
    L.append("_Machine: %s; %s; load average %s at start, %s at end; command: `%s`; %s. The machine "
             "is shared with other jobs: single figures are noisy; the medians over frames and repetitions are "
             "what to read._" % (meta["machine"], meta["simd"], meta["load_start"], meta["load_end"], cmd,
                                 meta["date"]))
    L.append("")
    L.append("One row by hand: `locd gen uniform 1000000 --seed 1 -o u.aabb && locd frames u.aabb --moving 0.01 "
             "--frames 10 --threads 2` (add `--static 0.9`, `--check`), or "
             "`build-bench/bench/frames_peers u.aabb --moving 0.01 --static 0 --frames 10` (2 warm-up frames first: "
             "`--warmup`).")
    L.append("")
    (results / "frames.md").write_text("\n".join(L))
    plot(table, img_dir / "frames.png", meta)
    bench_run.log("wrote %s and %s" % (results / "frames.md", img_dir / "frames.png"))


def frame_table(table):
    """The frame times' table: one row per (n, static, moving)."""
    fmt = bench_run.fmt_ms
    L = ["| n | static | moving | moved / frame | locd update | rebuild | update / rebuild | the same, means "
         "| locd update, 1 thread | Bullet Dbvt | FCL DynamicAABBTree | best peer / locd update "
         "| best peer / locd 1 thread |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in table:
        peers = [r[s] for s in ("bullet_dbvt", "fcl_dynamic_aabb_tree") if r[s] is not None]
        best = min(peers) if peers else None
        L.append("| %s | %s | %s | %s | %s | %s | %.3f | %s | %s | %s | %s | %s | %s |" % (
            bench_run.fmt_n(r["n"]), pct(r["static"]), pct(r["moving"]), "{:,}".format(r["moved"]),
            fmt(r["locd"]), fmt(r["rebuild"]), r["locd"] / r["rebuild"],
            "%.3f" % r["ratio_mean"] if r["ratio_mean"] else "-",
            fmt(r["locd_1t"]), fmt(r["bullet_dbvt"]),
            fmt(r["fcl_dynamic_aabb_tree"]), "%.2f" % (best / r["locd"]) if best else "-",
            "%.2f" % (best / r["locd_1t"]) if best and r["locd_1t"] else "-"))
    return L


def pairs_table(table):
    """Each system's pairs after the last frame."""
    L = ["| n | static | moving | locd | locd, 1 thread | rebuild | Bullet | FCL |", "|---|---|---|---|---|---|---|---|"]
    for r in table:
        L.append("| %s | %s | %s | %s | %s | %s | %s | %s |" % (
            bench_run.fmt_n(r["n"]), pct(r["static"]), pct(r["moving"]),
            *["{:,}".format(r[s + "_pairs"]) if r[s + "_pairs"] is not None else "-" for s in SYSTEMS]))
    return L


def report_cold(table, results, img_dir, meta):
    """The section of frames between a game's other work (--pause, --evict)."""
    L = ["## Frame to frame between a game's other work", ""]
    L.append("The tables above run the frames back to back, so every system finds its memory in the caches and "
             "locd's worker threads awake. In a game the broad phase runs once a frame, between the rest of the "
             "frame's work. Here each system's frame follows %s ms asleep (locd's pool workers go to sleep after "
             "a short wait) and %s MB written and read (the caches then hold other data): the same scenes, "
             "systems and motion as above, medians per frame of %d interleaved repetitions, after %s warm-up "
             "frames; locd on %s threads and on one." % (
                 "%g" % meta["pause_ms"], "%g" % meta["evict_mb"], meta["reps"], warmup_of(results, "frames_cold"),
                 meta.get("threads", "?")))
    L.append("")
    L.extend(frame_table(table))
    L.append("")
    faster = [r for r in table if r["locd"] < min(r["bullet_dbvt"], r["fcl_dynamic_aabb_tree"])]
    faster1 = [r for r in table if r["locd_1t"] < min(r["bullet_dbvt"], r["fcl_dynamic_aabb_tree"])]
    def rows(sel):
        return "none" if not sel else ", ".join("n = %s, %s static, %s moving" % (
            bench_run.fmt_n(r["n"]), pct(r["static"]), pct(r["moving"])) for r in sel)
    L.append("- Faster per frame than Bullet's and FCL's incremental paths: %d of %d rows on %s threads, %d of %d "
             "on one." % (len(faster), len(table), meta.get("threads", "?"), len(faster1), len(table)))
    L.append("- Updates dearer than the rebuild of the same boxes, on the medians per frame: %s; on the means per "
             "frame (which count the frames that build the near-pair list): %s." % (
                 rows([r for r in table if r["locd"] > r["rebuild"]]),
                 rows([r for r in table if r["ratio_mean"] and r["ratio_mean"] > 1])))
    L.append("")
    L.append("Pairs after the last frame (as above: the rebuild's count includes the static-static pairs):")
    L.append("")
    L.extend(pairs_table(table))
    L.append("")
    L.append("![frame time against the fraction moving, between a game's other work](img/frames_cold.png)")
    L.append("")
    L.append("_Machine: %s; %s; load average %s at start, %s at end; command: `%s`; %s._" % (
        meta["machine"], meta["simd"], meta["load_start"], meta["load_end"], meta["command"], meta["date"]))
    L.append("")
    (results / "frames_cold.md").write_text("\n".join(L))
    plot(table, img_dir / "frames_cold.png", meta)
    bench_run.log("wrote %s and %s" % (results / "frames_cold.md", img_dir / "frames_cold.png"))


def plot(table, path, meta):
    sizes = sorted({r["n"] for r in table})
    statics = sorted({r["static"] for r in table})
    if not sizes:
        return
    fig, axes = plt.subplots(len(statics), len(sizes), figsize=(5.2 * len(sizes), 4.2 * len(statics)),
                             squeeze=False)
    for a, st in enumerate(statics):
        for b, n in enumerate(sizes):
            ax = axes[a][b]
            rows = sorted([r for r in table if r["n"] == n and r["static"] == st], key=lambda r: r["moving"])
            xs = [100 * r["moving"] for r in rows]
            for s in SYSTEMS:
                ys = [r[s] for r in rows]
                if all(y is not None for y in ys):
                    ax.plot(xs, ys, marker="o", color=COLORS[s], label=LABELS[s], linewidth=2 if s == "locd" else 1.3)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xticks(xs)
            ax.set_xticklabels(["%d%%" % x for x in xs])
            ax.minorticks_off()
            # Readable y ticks on the log axis: 1, 2, 5 per decade, written as plain numbers.
            ax.yaxis.set_major_locator(ticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
            ax.yaxis.set_major_formatter(ticker.FuncFormatter(lambda v, _: "%g" % v))
            ax.set_xlabel("objects moving per frame (of the non-static ones)")
            ax.set_ylabel("ms per frame (median)")
            ax.set_title("n = %s, %d%% static" % (bench_run.fmt_n(n), round(100 * st)))
            ax.grid(True, which="major", alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2 if len(sizes) > 1 else 1, fontsize=8, frameon=False,
               bbox_to_anchor=(0.5, 0.02))
    fig.tight_layout(rect=(0, 0.09 if len(sizes) > 1 else 0.14, 1, 1))
    bench_run.plot_footer(fig, meta)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="CI-sized run into bench/results/tmp/frames-quick/")
    ap.add_argument("--report-only", action="store_true")
    ap.add_argument("--build", default="build-bench", help="meson build directory holding tools/locd and "
                    "bench/frames_peers (set up if missing, brought up to date each run)")
    ap.add_argument("--sizes", default="1e5,1e6")
    ap.add_argument("--statics", default="0,0.9")
    ap.add_argument("--moving", default="0.01,0.1,1")
    ap.add_argument("--frames", type=int, default=20, help="frames per row below 10^6 objects")
    ap.add_argument("--frames-large", type=int, default=8, help="frames per row at 10^6 objects")
    ap.add_argument("--reps", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--pause", type=float, default=0.0, help="ms asleep before each system's frame")
    ap.add_argument("--evict", type=float, default=0.0, help="MB written and read before each system's frame")
    ap.add_argument("--out", default="")
    args = ap.parse_args()
    if args.quick:
        args.sizes, args.frames, args.frames_large = "2000", 3, 3
    results = Path(args.out) if args.out else ROOT / "bench" / "results" / ("tmp/frames-quick" if args.quick else "")
    img_dir = results if (args.quick or args.out) else ROOT / "docs" / "img"
    results.mkdir(parents=True, exist_ok=True)
    meta_path = results / (stem(args) + "_meta.json")
    if args.report_only:
        for name in ("frames", "frames_cold"):
            if (results / (name + "_meta.json")).exists():
                report(name, results, img_dir, json.loads((results / (name + "_meta.json")).read_text()))
        return 0
    bdir = Path(args.build) if Path(args.build).is_absolute() else ROOT / args.build
    exe, locd = bdir / "bench" / "frames_peers", bdir / "tools" / "locd"
    if not (bdir / "build.ninja").exists():
        bench_run.build(argparse.Namespace(build=str(bdir), native=True))
    # Always brought up to date (ninja does nothing when it is): the report names the checkout's
    # commit, so binaries left from an older one would be measured under the new one's name.
    bench_run.run(["ninja", "-C", bdir, "-j", "2", "bench/frames_peers", "tools/locd"], cwd=ROOT)
    meta = {"machine": bench_run.machine(), "simd": bench_run.simd(),
            "command": "bench/frames.py" + "".join(" " + shlex.quote(a) for a in sys.argv[1:]),
            "commit": bench_run.git_rev(), "reps": args.reps, "threads": args.threads,
            "pause_ms": args.pause, "evict_mb": args.evict,
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "load_start": bench_run.loadavg()}
    run_grid(args, exe, locd, results)
    meta["load_end"] = bench_run.loadavg()
    meta_path.write_text(json.dumps(meta, indent=1) + "\n")
    report(stem(args), results, img_dir, meta)
    return 0


if __name__ == "__main__":
    sys.exit(main())
