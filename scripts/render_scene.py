#!/usr/bin/env python3
"""Render a `locd simulate` positions dump (JSON lines) as PNG frames or a GIF.

    python3 scripts/render_scene.py POSITIONS.jsonl --frames DIR
    python3 scripts/render_scene.py POSITIONS.jsonl --gif OUT.gif [--fps 30]

The dump's first line is a header (shapes, which object uses which shape,
static flags); every other line holds one recorded step's poses
(x y z qx qy qz qw per object). The view is a side view (x horizontal,
z up), fitted to the scene's first frame. `locd simulate --frames/--gif`
writes the dump and calls this script.
"""
import argparse
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402


def rotate(q, p):
    x, y, z, w = q
    n = math.sqrt(x * x + y * y + z * z + w * w) or 1.0
    x, y, z, w = x / n, y / n, z / n, w / n
    px, py, pz = p
    r = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    return [r[i][0] * px + r[i][1] * py + r[i][2] * pz for i in range(3)]


def hull2d(points):
    """Andrew's monotone chain: the convex hull of 2-D points, counter-clockwise."""
    pts = sorted(set(points))
    if len(pts) <= 2:
        return pts

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def local_outline_points(shape):
    """Points whose projected hull is the shape's silhouette (not for meshes)."""
    kind = shape["kind"]
    if kind == "box":
        hx, hy, hz = shape["half"]
        return [(sx * hx, sy * hy, sz * hz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    if kind == "capsule":
        r, h = shape["radius"], shape["half"][2]
        pts = []
        for k in range(16):
            a = 2 * math.pi * k / 16
            for zc in (-h, h):
                pts += [(r * math.cos(a), 0.0, zc + r * math.sin(a)), (0.0, r * math.cos(a), zc + r * math.sin(a))]
        return pts
    if kind == "convex":
        p = shape["points"]
        return [tuple(p[i:i + 3]) for i in range(0, len(p), 3)]
    return []


def polygons_for(shape, pose):
    pos, q = pose[:3], pose[3:]
    kind = shape["kind"]
    if kind == "sphere":
        r = shape["radius"]
        return [[(pos[0] + r * math.cos(2 * math.pi * k / 24), pos[2] + r * math.sin(2 * math.pi * k / 24))
                 for k in range(24)]]
    if kind == "mesh":
        v, t = shape["points"], shape["triangles"]
        world = []
        for i in range(0, len(v), 3):
            w = rotate(q, v[i:i + 3])
            world.append((w[0] + pos[0], w[2] + pos[2]))
        return [[world[t[i]], world[t[i + 1]], world[t[i + 2]]] for i in range(0, len(t), 3)]
    pts = []
    for p in local_outline_points(shape):
        w = rotate(q, p)
        pts.append((w[0] + pos[0], w[2] + pos[2]))
    return [hull2d(pts)]


def load(path):
    header, frames = None, []
    with open(path) as f:
        for line in f:
            d = json.loads(line)
            if "header" in d:
                header = d["header"]
            else:
                frames.append(d)
    if header is None or not frames:
        sys.exit("render_scene: %s has no header or no frames" % path)
    return header, frames


def view_limits(header, frame):
    xs, zs = [], []
    p = frame["p"]
    for i, s in enumerate(header["shape_of"]):
        for poly in polygons_for(header["shapes"][s], p[7 * i:7 * i + 7]):
            xs += [a for a, _ in poly]
            zs += [b for _, b in poly]
    x0, x1, z0, z1 = min(xs), max(xs), min(zs), max(zs)
    mx, mz = 0.1 * (x1 - x0) + 0.5, 0.1 * (z1 - z0) + 0.5
    return x0 - mx, x1 + mx, z0 - mz - 2.0, z1 + mz


def draw(ax, header, frame, limits):
    ax.clear()
    still, moving = [], []
    p = frame["p"]
    for i, s in enumerate(header["shape_of"]):
        polys = polygons_for(header["shapes"][s], p[7 * i:7 * i + 7])
        (still if header["static"][i] else moving).extend(polys)
    ax.add_collection(PolyCollection(still, facecolors="#8c8c8c", edgecolors="none"))
    ax.add_collection(PolyCollection(moving, facecolors="#1f77b4", edgecolors="#0b3c5d", linewidths=0.4, alpha=0.85))
    ax.set_xlim(limits[0], limits[1])
    ax.set_ylim(limits[2], limits[3])
    ax.set_aspect("equal")
    ax.set_xlabel("x")
    ax.set_ylabel("z")
    shown = header["shown"]
    extra = "" if shown == header["objects"] else " (first %d of %d objects)" % (shown, header["objects"])
    ax.set_title("%s  t = %.3f s%s" % (header["scene"], frame["t"], extra))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dump")
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--frames", help="directory for frame_NNNNN.png")
    g.add_argument("--gif", help="animated GIF to write")
    ap.add_argument("--fps", type=float, default=30.0)
    a = ap.parse_args()
    header, frames = load(a.dump)
    limits = view_limits(header, frames[0])
    fig, ax = plt.subplots(figsize=(8, 5), dpi=90)
    if a.frames:
        os.makedirs(a.frames, exist_ok=True)
        for k, fr in enumerate(frames):
            draw(ax, header, fr, limits)
            fig.savefig(os.path.join(a.frames, "frame_%05d.png" % k))
        print("render_scene: %d frames in %s" % (len(frames), a.frames), file=sys.stderr)
    else:
        from matplotlib.animation import FuncAnimation, PillowWriter

        anim = FuncAnimation(fig, lambda k: draw(ax, header, frames[k], limits), frames=len(frames))
        anim.save(a.gif, writer=PillowWriter(fps=a.fps))
        print("render_scene: %d frames in %s" % (len(frames), a.gif), file=sys.stderr)


if __name__ == "__main__":
    main()
