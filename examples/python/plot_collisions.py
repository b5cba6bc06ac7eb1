#!/usr/bin/env python3
"""Find every overlapping pair among a million boxes, then plot a slice of the
scene with the colliding boxes highlighted.

    pip install '.[plot]'    # from the repository root, once: locd and matplotlib
    python examples/python/plot_collisions.py [--n 1000000] [--out locd_slice.png]

(`locd[plot]` is the extra that installs matplotlib; with locd already
installed, `pip install matplotlib` is the same.)

The scene is the CLI's `locd gen uniform`: n equal cubes in the unit cube,
edge (4n)^(-1/3), about one overlapping pair per cube.
"""
import argparse
import sys
import time

try:
    import matplotlib
except ImportError:
    sys.exit("this example needs matplotlib: pip install 'locd[plot]' (or: pip install matplotlib)")

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PatchCollection  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

import locd  # noqa: E402


def uniform_scene(n, seed):
    rng = np.random.default_rng(seed)
    w = (4.0 * n) ** (-1.0 / 3.0)
    lo = rng.random((n, 3), dtype=np.float32) * np.float32(1 - w)
    return np.hstack([lo, lo + np.float32(w)])  # (n, 6) float32, C-contiguous


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", default="locd_slice.png")
    ap.add_argument("--window", type=float, default=0.3, help="edge of the plotted x-y window")
    args = ap.parse_args()

    boxes = uniform_scene(args.n, args.seed)
    with locd.Engine() as engine:
        t = time.perf_counter()
        pairs = engine.find_pairs(boxes)
        wall = (time.perf_counter() - t) * 1e3
        s = engine.stats
    print("%d boxes: %d overlapping pairs in %.1f ms (C: %.1f ms on %d threads; encode %.1f, sort %.1f, "
          "merge %.1f, sweep %.1f)" % (len(boxes), len(pairs), wall, s.ms_total, s.threads, s.ms_encode,
                                       s.ms_sort, s.ms_merge, s.ms_sweep))

    # The slice: the cross-section of the scene by the plane z = 0.5. Two
    # boxes that both cross the plane overlap in 3-D exactly when their
    # rectangles overlap in the picture, so the red boxes (in a pair with
    # another box of the section) are the collisions one can see.
    in_plane = (boxes[:, 2] <= 0.5) & (boxes[:, 5] >= 0.5)
    both = pairs[in_plane[pairs[:, 0]] & in_plane[pairs[:, 1]]]
    colliding = np.zeros(len(boxes), dtype=bool)
    colliding[both.ravel()] = True

    x0 = y0 = 0.5 - args.window / 2
    x1 = y1 = 0.5 + args.window / 2
    sel = in_plane & (boxes[:, 3] >= x0) & (boxes[:, 0] <= x1) & (boxes[:, 4] >= y0) & (boxes[:, 1] <= y1)
    idx = np.nonzero(sel)[0]

    def patches(which):
        return [Rectangle((boxes[i, 0], boxes[i, 1]), boxes[i, 3] - boxes[i, 0], boxes[i, 4] - boxes[i, 1])
                for i in which]

    fig, ax = plt.subplots(figsize=(7, 7), dpi=120)
    ax.add_collection(PatchCollection(patches(idx[~colliding[idx]]), facecolor="#c8d0d8", edgecolor="#607080",
                                      linewidth=0.4))
    ax.add_collection(PatchCollection(patches(idx[colliding[idx]]), facecolor="#e8503a", edgecolor="#801a10",
                                      linewidth=0.5, alpha=0.85))
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_title("locd: %d boxes, %d pairs; section z = 0.5: %d boxes, %d colliding in it (red)"
                 % (len(boxes), len(pairs), len(idx), int(colliding[idx].sum())), fontsize=9)
    fig.tight_layout()
    fig.savefig(args.out)
    print("wrote %s" % args.out)


if __name__ == "__main__":
    main()
