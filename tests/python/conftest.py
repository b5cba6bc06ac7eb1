"""Shared helpers for the Python tests of locd (run against the *installed* package)."""
import os
import threading
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

# Fixed, modest example counts so CI stays fast; no deadline (timings on a
# shared 2-core machine vary). LOCD_HYPOTHESIS_EXAMPLES raises it locally.
settings.register_profile(
    "locd",
    max_examples=int(os.environ.get("LOCD_HYPOTHESIS_EXAMPLES", "60")),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    print_blob=True,
)
settings.load_profile("locd")

REPO_ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def numpy_pairs(boxes):
    """Independent reference: every pair (i < j) overlapping under the closed-interval rule, sorted.

    float32 widens to float64 exactly, so comparing in float64 is the same test.
    """
    b = np.asarray(boxes, dtype=np.float64)
    lo, hi = b[:, :3], b[:, 3:]
    out = [np.empty((0, 2), dtype=np.uint32)]
    for start in range(0, len(b), 256):  # row blocks keep memory at 256 x n
        rows = slice(start, start + 256)
        overlap = np.ones((len(b[rows]), len(b)), dtype=bool)
        for axis in range(3):  # 2-D comparisons per axis: far faster than a reduction over a length-3 axis
            overlap &= lo[rows, axis, None] <= hi[None, :, axis]
            overlap &= lo[None, :, axis] <= hi[rows, axis, None]
        i, j = np.nonzero(overlap)
        i = i + start
        keep = i < j
        out.append(np.stack([i[keep], j[keep]], axis=1).astype(np.uint32))
    return np.concatenate(out)


def sorted_pairs(pairs):
    pairs = np.asarray(pairs).reshape(-1, 2)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def uniform_scene(n, seed=1, dtype=np.float32):
    """n equal cubes in the unit cube, about one overlapping pair per cube (the CLI's 'uniform')."""
    rng = np.random.default_rng(seed)
    w = (4.0 * max(n, 1)) ** (-1.0 / 3.0)
    lo = rng.random((n, 3)) * (1 - w)
    return np.ascontiguousarray(np.hstack([lo, lo + w]).astype(dtype))


def progress_during(call):
    """Runs call() while a Python thread records timestamps; returns (the
    duration of call in s, the longest stretch in the middle 80% of the call
    during which the thread recorded nothing)."""
    stamps = []
    stop = threading.Event()

    def ticker():
        while not stop.is_set():
            stamps.append(time.perf_counter())
            time.sleep(0.0005)  # needs the GIL back to go on

    t = threading.Thread(target=ticker)
    t.start()
    while not stamps:
        time.sleep(0.001)
    start = time.perf_counter()
    call()
    end = time.perf_counter()
    stop.set()
    t.join()
    duration = end - start
    lo, hi = start + 0.1 * duration, end - 0.1 * duration
    inside = [lo] + [s for s in stamps if lo <= s <= hi] + [hi]
    return duration, max(b - a for a, b in zip(inside, inside[1:]))


@pytest.fixture
def small_scene():
    return uniform_scene(500, seed=7)
