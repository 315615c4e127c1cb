"""A pile of ellipsoids in tumble and MuJoCo, the same scene in the same run.

N ellipsoids (semi-axes drawn per body from 0.06-0.15 m, mass 1, seeded random orientations)
on a k x k x k grid with 0.4 m spacing, lowest centres at z = 0.5 m, centred on x = y = 0, fall
onto the ground plane z = 0 (friction 0.5, gravity -9.81 z) for ``--seconds`` s at dt 1/240 s:
tumble's default step (4 contact substeps), MuJoCo's default (Euler, Newton solver, its
ellipsoid collisions by its convex collider). Timed: the whole run after the first step (tumble's
compile or cache load, MuJoCo's first collision, reported apart), median of ``--repeats``
runs, one thread each. Quality beside the time, at the end: the deepest point of any
ellipsoid below the ground (its centre's height less its support height along -z, |A R^T z|),
the fastest body, and the pile's top.

    PYTHONPATH=src python benchmarks/ellipsoid_pile.py --sizes 100 500 --out benchmarks/results/ellipsoid_pile.md
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from report import emit, machine_line

DT = 1.0 / 240.0


def layout(n: int, seed: int = 0):
    """(positions (n, 3), quaternions (n, 4) w x y z, radii (n, 3)) of the pile's start."""
    rng = np.random.default_rng(seed)
    k = math.ceil(n ** (1 / 3) - 1e-9)
    grid = np.array([(i, j, m) for m in range(k) for j in range(k) for i in range(k)][:n], dtype=float)
    pos = np.column_stack([(grid[:, 0] - (k - 1) / 2) * 0.4, (grid[:, 1] - (k - 1) / 2) * 0.4, 0.5 + grid[:, 2] * 0.4])
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    radii = rng.uniform(0.06, 0.15, size=(n, 3))
    return pos, q, radii


def quality(x, R, radii, v) -> dict:
    """Deepest point below z = 0 (m), fastest body (m/s), top of the pile (m)."""
    support = np.linalg.norm(radii * R[:, 2, :], axis=1)  # |A R^T e_z|: row 2 of R is R^T's column
    low = x[:, 2] - support
    return {"deepest below ground (m)": float(max(0.0, -low.min())), "max speed (m/s)": float(np.linalg.norm(v, axis=1).max()),
            "top (m)": float((x[:, 2] + support).max())}


def run_tumble(n: int, seconds: float) -> dict:
    import tumble as tb

    pos, q, radii = layout(n)
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(), fixed=True, material=tb.Material(friction=0.5))
    for i in range(n):
        w.add_body(tb.Ellipsoid(radii=radii[i]), mass=1.0, position=pos[i], orientation=q[i],
                   material=tb.Material(friction=0.5))
    sim = tb.Simulator(w, dt=DT)
    t0 = time.perf_counter()
    sim.step(1)
    first = time.perf_counter() - t0
    steps = int(round(seconds / DT)) - 1
    t0 = time.perf_counter()
    sim.step(steps)
    wall = time.perf_counter() - t0
    m = w.moving
    return {"first step (s)": first, "wall (s)": wall, "ms/step": 1e3 * wall / steps,
            **quality(np.asarray(w.x)[m], np.asarray(w.R)[m], radii, np.asarray(w.v)[m])}


def run_mujoco(n: int, seconds: float) -> dict:
    import mujoco

    from tumble.math3d import quat_to_matrix

    pos, q, radii = layout(n)
    bodies = "".join(
        f'<body pos="{" ".join(map(repr, map(float, pos[i])))}" quat="{" ".join(map(repr, map(float, q[i])))}">'
        f'<freejoint/><geom type="ellipsoid" size="{" ".join(map(repr, map(float, radii[i])))}" mass="1" '
        f'friction="0.5"/></body>' for i in range(n))
    xml = (f'<mujoco><option timestep="{DT!r}"/><size memory="512M"/><worldbody>'
           f'<geom type="plane" size="0 0 1" friction="0.5"/>{bodies}</worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    t0 = time.perf_counter()
    mujoco.mj_step(model, data)
    first = time.perf_counter() - t0
    steps = int(round(seconds / DT)) - 1
    t0 = time.perf_counter()
    mujoco.mj_step(model, data, nstep=steps)
    wall = time.perf_counter() - t0
    x = data.xpos[1:].copy()
    R = np.array([quat_to_matrix(data.xquat[i]) for i in range(1, n + 1)])
    v = data.qvel.reshape(n, 6)[:, :3]
    return {"first step (s)": first, "wall (s)": wall, "ms/step": 1e3 * wall / steps, **quality(x, R, radii, v)}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 500])
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out")
    args = ap.parse_args()
    import numba

    numba.set_num_threads(1)
    rows = []
    for n in args.sizes:
        for engine, run in (("tumble", run_tumble), ("mujoco", run_mujoco)):
            results = [run(n, args.seconds) for _ in range(args.repeats)]
            walls = [r["wall (s)"] for r in results]
            best = results[int(np.argsort(walls)[len(walls) // 2])]
            rows.append({"engine": engine, "N": n, "seconds": args.seconds, **best,
                         "first step (s)": results[0]["first step (s)"]})
            print(rows[-1], flush=True)
    cols = list(rows[0])
    lines = [f"# ellipsoid pile ({args.seconds} s at dt 1/240 s, one thread, median of {args.repeats})", "",
             machine_line(), "", "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        lines.append("| " + " | ".join(f"{r[c]:.4g}" if isinstance(r[c], float) else str(r[c]) for c in cols) + " |")
    emit(lines, args.out)


if __name__ == "__main__":
    main()
