#!/usr/bin/env python3
"""Hard scenes for the MPI step (scripts/ci/steps/65-mpi.sh), written as
.aabb (float32) or .aabb64 (float64) rows minx miny minz maxx maxy maxz.

  mpi_scenes.py KIND PATH [N]

KIND: hugetiny (one huge box among tiny ones, 1e6 apart in size), onecell
(every box inside one octree cell), span (a box over the whole scene: its
root cell spans every rank's key range, plus small boxes), mixed64 (sizes
over four orders of magnitude, float64), badbox (NaN at index 2500, the
third of four equal slices of 4000), twobad (inverted box at 2100 and NaN
at 3500: the lower index wins). Deterministic (fixed seeds), stdlib only.
"""
import random
import struct
import sys


def write(path, rows, f64=False):
    fmt = "<6d" if f64 else "<6f"
    with open(path, "wb") as f:
        for r in rows:
            f.write(struct.pack(fmt, *r))


def cube(rng, lo, hi, size):
    x, y, z = (rng.uniform(lo, hi) for _ in range(3))
    return (x, y, z, x + size, y + size, z + size)


def main():
    kind, path = sys.argv[1], sys.argv[2]
    n = int(sys.argv[3]) if len(sys.argv) > 3 else 4000
    rng = random.Random(17)
    if kind == "hugetiny":
        rows = [cube(rng, 0.0, 1000.0, 1e-3) for _ in range(n)]
        rows.insert(n // 3, (100.0, 100.0, 100.0, 600.0, 600.0, 600.0))
    elif kind == "onecell":
        rows = [cube(rng, 0.0, 0.05, 0.01) for _ in range(n)]
        rows += [(0, 0, 0, 0, 0, 0), (1000, 1000, 1000, 1000, 1000, 1000)]
    elif kind == "span":
        rows = [cube(rng, 0.0, 100.0, 0.5) for _ in range(n)]
        rows.insert(n // 2, (-1.0, -1.0, -1.0, 101.0, 101.0, 101.0))
    elif kind == "mixed64":
        rows = [cube(rng, -1e3, 1e3, 10 ** rng.uniform(-1, 3) * 1e-1) for _ in range(n)]
        write(path, rows, f64=True)
        return
    elif kind in ("badbox", "twobad"):
        rows = [cube(rng, 0.0, 100.0, 1.0) for _ in range(4000)]
        if kind == "badbox":
            rows[2500] = (float("nan"), 0, 0, 1, 1, 1)
        else:
            rows[2100] = (5, 5, 5, 4, 6, 6)
            rows[3500] = (0, 0, 0, 1, float("inf"), 1)
    else:
        sys.exit("unknown kind " + kind)
    write(path, rows)


if __name__ == "__main__":
    main()
