#!/usr/bin/env python3
"""Python overhead of locd versus its C call, and locd versus what Python users use today.

    python bench/python_overhead.py [--sizes 100,10000,1000000] [--peer-sizes 10000,100000,1000000] [--out FILE.md]

Part 1, overhead: the same scene through ``locd.find_pairs``, ``Engine.find_pairs``
and ``locd.abi.find_pairs`` (cffi). The C time is the engine's own
``stats.ms_total`` (wall time inside the C call); the overhead is the
per-call difference wall - C (argument checks, GIL release, copying the
pairs into the result array), median over repetitions. One thread, so the C
time is steady.

Part 2, peers, side by side on the same scenes (the CLI's 'uniform' scene:
n equal cubes, about one overlapping pair per cube):
  - python-fcl (PyPI `python-fcl`): DynamicAABBTreeCollisionManager, boxes as
    fcl.Box objects, collide() with a Python callback collecting the
    candidate pairs (its broad phase: AABB overlap, closed intervals).
  - scipy's cKDTree.query_pairs for the sphere variant: equal spheres
    inscribed in the cubes; locd answers it with the spheres' bounding cubes
    plus an exact distance filter in numpy.
Times are medians of 3 runs (5 for locd; 1 for python-fcl at n > 100,000).
Every peer's pair set is compared with locd's. Peers missing from the venv are
installed with pip first (bench-only: they are not needed by the tests).
"""
import argparse
import os
import platform
import statistics
import subprocess
import sys
import time

import numpy as np

import locd
import locd.abi


def ensure_peers(install):
    missing = []
    for module, package in (("fcl", "python-fcl"), ("scipy", "scipy")):
        try:
            __import__(module)
        except ImportError:
            missing.append(package)
    if missing and install:
        print("installing %s into %s" % (" ".join(missing), sys.prefix), file=sys.stderr)
        subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--disable-pip-version-check"] + missing,
                       check=False)


def uniform_scene(n, seed=1):
    rng = np.random.default_rng(seed)
    w = (4.0 * n) ** (-1.0 / 3.0)
    lo = rng.random((n, 3)) * (1 - w)
    return np.ascontiguousarray(np.hstack([lo, lo + w]).astype(np.float32)), w


def reps_for(n):
    return 2000 if n <= 1000 else 200 if n <= 100_000 else 7


def abi_stats():
    engine = locd.abi._engine_for(1).engine
    s = locd.abi.ffi.new("locd_stats *")
    locd.abi.lib.locd_stats_init(s)
    locd.abi.lib.locd_engine_get_stats(engine, s)
    return s.ms_total


def overhead_rows(sizes):
    rows = []
    for n in sizes:
        boxes, _ = uniform_scene(n)
        engine = locd.Engine(threads=1)
        paths = [
            ("locd.find_pairs", lambda: locd.find_pairs(boxes, threads=1),
             lambda: locd._engine_for(1)._core.stats()["ms_total"]),
            ("Engine.find_pairs", lambda: engine.find_pairs(boxes), lambda: engine._core.stats()["ms_total"]),
            ("locd.abi.find_pairs (cffi)", lambda: locd.abi.find_pairs(boxes, threads=1), abi_stats),
        ]
        for name, call, c_ms in paths:
            pairs = call()  # warm up: engine, buffers, page faults
            walls, cs = [], []
            for _ in range(reps_for(n)):
                t = time.perf_counter()
                call()
                walls.append((time.perf_counter() - t) * 1e3)
                cs.append(c_ms())
            over = [w - c for w, c in zip(walls, cs)]
            rows.append(dict(n=n, pairs=len(pairs), path=name, wall=statistics.median(walls),
                             c=statistics.median(cs), over=statistics.median(over), reps=len(walls)))
        engine.close()
    return rows


def timed(fn, repeat=3):
    """(result of the last run, median wall time in ms over `repeat` runs)."""
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append((time.perf_counter() - t) * 1e3)
    return out, statistics.median(times)


def canon(pairs):
    pairs = np.sort(np.asarray(pairs, dtype=np.int64).reshape(-1, 2), axis=1)
    return np.unique(pairs, axis=0)


def fcl_pairs(boxes, repeat):
    import fcl
    b = boxes.astype(np.float64)
    centers = (b[:, :3] + b[:, 3:]) / 2
    extents = b[:, 3:] - b[:, :3]

    def build():
        objs = [fcl.CollisionObject(fcl.Box(*extents[i]), fcl.Transform(centers[i])) for i in range(len(b))]
        manager = fcl.DynamicAABBTreeCollisionManager()
        manager.registerObjects(objs)
        manager.setup()
        return manager

    manager, t_build = timed(build, repeat)

    def callback(o1, o2, cdata):
        cdata.append((o1.getTranslation(), o2.getTranslation()))
        return False

    def collide():
        found = []
        manager.collide(found, callback)
        return found

    found, t_collide = timed(collide, repeat)
    index = {tuple(c): i for i, c in enumerate(centers)}
    pairs = [(index[tuple(p)], index[tuple(q)]) for p, q in found]
    return canon(pairs), t_build, t_collide


def peer_rows(sizes, fcl_max_n):
    rows = []
    try:
        import fcl  # noqa: F401
        have_fcl = True
    except ImportError:
        have_fcl = False
    try:
        from scipy.spatial import cKDTree
    except ImportError:
        cKDTree = None
    for n in sizes:
        boxes, w = uniform_scene(n, seed=2)
        locd.find_pairs(boxes)  # warm up both engines
        locd.find_pairs(boxes, threads=1)
        ref1, t1 = timed(lambda: locd.find_pairs(boxes, threads=1), 5)
        refk, tk = timed(lambda: locd.find_pairs(boxes), 5)
        ref = canon(ref1)
        k = locd._engine_for(None).threads
        rows.append(dict(n=n, task="boxes", tool="locd (1 thread)", build=0.0, query=t1, pairs=len(ref1), same="-"))
        rows.append(dict(n=n, task="boxes", tool="locd (%d threads)" % k, build=0.0, query=tk, pairs=len(refk),
                         same="yes" if np.array_equal(canon(refk), ref) else "NO"))
        if have_fcl and n <= fcl_max_n:
            pairs, tb, tc = fcl_pairs(boxes, 3 if n <= 100_000 else 1)
            rows.append(dict(n=n, task="boxes", tool="python-fcl DynamicAABBTree", build=tb, query=tc,
                             pairs=len(pairs), same="yes" if np.array_equal(pairs, ref) else "NO"))
        # Spheres inscribed in the cubes: centers c, radius w/2; overlap iff |ci - cj| <= w.
        centers = (boxes[:, :3].astype(np.float64) + boxes[:, 3:]) / 2
        r = w / 2

        def locd_spheres():
            cubes = np.hstack([centers - r, centers + r])
            cand = locd.find_pairs(cubes)
            d = centers[cand[:, 0]] - centers[cand[:, 1]]
            return cand[np.einsum("ij,ij->i", d, d) <= (2 * r) ** 2]

        locd_spheres()
        sph, ts = timed(locd_spheres)
        sref = canon(sph)
        rows.append(dict(n=n, task="spheres", tool="locd cubes + exact filter (%d threads)" % k, build=0.0, query=ts,
                         pairs=len(sph), same="-"))
        if cKDTree is not None:
            tree, tb = timed(lambda: cKDTree(centers))
            kd, tq = timed(lambda: tree.query_pairs(2 * r, output_type="ndarray"))
            rows.append(dict(n=n, task="spheres", tool="scipy cKDTree.query_pairs", build=tb, query=tq,
                             pairs=len(kd), same="yes" if np.array_equal(canon(kd), sref) else "NO"))
    return rows, have_fcl, cKDTree is not None


def machine():
    cpu = platform.processor() or "?"
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return "%s, %d cores, load average %.1f at start; Python %s, numpy %s, locd %s" % (
        cpu, os.cpu_count(), os.getloadavg()[0], platform.python_version(), np.__version__, locd.__version__)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="100,10000,1000000")
    ap.add_argument("--peer-sizes", default="10000,100000,1000000")
    ap.add_argument("--fcl-max-n", type=int, default=1_000_000,
                    help="largest n for python-fcl (its Python objects take a while to build)")
    ap.add_argument("--no-install", action="store_true", help="do not pip install missing peers")
    ap.add_argument("--out", help="also write the Markdown tables here")
    args = ap.parse_args()
    ensure_peers(not args.no_install)

    lines = ["Machine: " + machine(), ""]
    lines += ["| n | pairs | path | wall (ms) | C ms_total (ms) | overhead (µs) | overhead |",
              "|---:|---:|---|---:|---:|---:|---:|"]
    for r in overhead_rows([int(s) for s in args.sizes.split(",") if s]):
        lines.append("| %s | %s | %s | %.3f | %.3f | %.1f | %.1f%% |" % (
            format(r["n"], ","), format(r["pairs"], ","), r["path"], r["wall"], r["c"], r["over"] * 1e3,
            100.0 * r["over"] / r["wall"] if r["wall"] else 0.0))
    rows, have_fcl, have_scipy = peer_rows([int(s) for s in args.peer_sizes.split(",") if s], args.fcl_max_n)
    lines += ["", "| n | task | tool | build (ms) | query (ms) | total (ms) | pairs | same pairs as locd |",
              "|---:|---|---|---:|---:|---:|---:|---|"]
    for r in rows:
        lines.append("| %s | %s | %s | %.1f | %.1f | %.1f | %s | %s |" % (
            format(r["n"], ","), r["task"], r["tool"], r["build"], r["query"], r["build"] + r["query"],
            format(r["pairs"], ","), r["same"]))
    if not have_fcl:
        lines.append("\npython-fcl is not installed (pip install python-fcl failed or --no-install): no FCL rows.")
    if not have_scipy:
        lines.append("\nscipy is not installed: no cKDTree rows.")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
