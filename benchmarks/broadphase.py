"""broadphase: time ``find_pairs`` (sort-and-sweep) and ``update_bounds`` on random shapes.

Run from the repository root:

    PYTHONPATH=src python benchmarks/broadphase.py            # N = 10 000 and 100 000
    PYTHONPATH=src python benchmarks/broadphase.py --sizes 1000 10000 100000 1000000

Scene: N random AABBs, centres uniform in a box of N / density m^3 (density 1 box
per m^3, like a loose pile), half extents uniform in [0.05, 0.3] m, 10 % of the
bodies fixed. The first call (compile or cache load) is timed apart; the figure is
the minimum and median of the repeats, reusing the pair buffers (as in a step).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from tumble.collision import PairBuffer, SPECULATIVE_DISTANCE, find_pairs, update_bounds
from tumble.collision.geometry import ShapeTable
from tumble.shapes import SHAPE_BOX


def scene(n, seed=0, density=1.0):
    rng = np.random.default_rng(seed)
    side = (n / density) ** (1 / 3)
    x = rng.uniform(0, side, (n, 3))
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, a, b, c = q.T
    R = np.stack([
        np.stack([1 - 2 * (b * b + c * c), 2 * (a * b - w * c), 2 * (a * c + w * b)], -1),
        np.stack([2 * (a * b + w * c), 1 - 2 * (a * a + c * c), 2 * (b * c - w * a)], -1),
        np.stack([2 * (a * c - w * b), 2 * (b * c + w * a), 1 - 2 * (a * a + b * b)], -1),
    ], 1)
    params = np.zeros((n, 4))
    params[:, :3] = rng.uniform(0.05, 0.3, (n, 3))
    local_q = np.zeros((n, 4))
    local_q[:, 0] = 1
    table = ShapeTable(np.full(n, SHAPE_BOX, dtype=np.int64), np.arange(n, dtype=np.int64), params,
                       np.zeros((n, 3)), local_q, rng.random(n) > 0.1)
    return x, np.ascontiguousarray(R), table


def timed(f, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t0)
    return out, min(times), statistics.median(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000])
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    t0 = time.perf_counter()
    x, R, table = scene(100)
    pos, rot, aabb = update_bounds(x, R, table, SPECULATIVE_DISTANCE)
    find_pairs(aabb, table.shape_type, table.shape_body, table.body_moving)
    print(f"first call (compile or cache load): {time.perf_counter() - t0:.2f} s")
    print(f"{'N':>9} {'pairs':>9} {'update_bounds ms (min/med)':>27} {'find_pairs ms (min/med)':>25} {'ns per shape':>13}")
    for n in args.sizes:
        x, R, table = scene(n)
        pos, rot, aabb = update_bounds(x, R, table, SPECULATIVE_DISTANCE)
        _, b_min, b_med = timed(lambda: update_bounds(x, R, table, SPECULATIVE_DISTANCE, pos, rot, aabb),
                                args.repeats)
        buf = PairBuffer()
        find_pairs(aabb, table.shape_type, table.shape_body, table.body_moving, buf)
        (a, b), p_min, p_med = timed(
            lambda: find_pairs(aabb, table.shape_type, table.shape_body, table.body_moving, buf), args.repeats)
        print(f"{n:>9} {len(a):>9} {1e3 * b_min:>13.2f} / {1e3 * b_med:<11.2f} {1e3 * p_min:>11.2f} / "
              f"{1e3 * p_med:<11.2f} {1e9 * p_min / n:>13.0f}")


if __name__ == "__main__":
    main()
