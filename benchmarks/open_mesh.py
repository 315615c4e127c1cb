"""open_mesh: an open terrain sheet (``tb.Mesh(closed=False)``) against the same terrain as a closed
heightfield in tumble, and PyBullet's concave triangle mesh of the same sheet, side by side.

Scene (benchmarks/heightfield.py's): a 129 x 129 grid over 20 x 20 m, heights
0.3 sin(x / 1.7) cos(y / 2.3) + 0.002 (x^2 + y^2) (a rippled bowl); the open sheet is its top, 32 768
triangles (the heightfield adds its sides and bottom); N balls (radius 0.1 m, 1 kg) dropped from
1 m above it on a grid 8 x 8 m around the middle; friction 0.8; gravity; 4 s at dt 1/240 s.
tumble: the default step (4 contact substeps). PyBullet: ``GEOM_MESH`` with
``GEOM_FORCE_CONCAVE_TRIMESH`` (Bullet's btBvhTriangleMeshShape, two-sided too), its default solver
and time step 1/240 s. MuJoCo has no concave triangle mesh (its meshes collide as hulls): its
heightfield figures are benchmarks/heightfield.py's.

Times: wall time per step over the whole run, median of ``--repeats`` runs after a warm-up run
(compilation apart). Quality beside it: the deepest ball below the surface at the end (a ray cast
down from each ball's centre against tumble's sheet, against its radius; the same for PyBullet's
positions) and the fastest ball at the end. Also the time to build the sheet's edge flags
(``geometry.mesh_edge_flags``, part of a world's first step) at 5 000 to 80 000 triangles, sorted
against the per-edge loop it replaced (tests/collision/test_geometry.py keeps it as the oracle).

    PYTHONPATH=src python benchmarks/open_mesh.py --balls 100 --repeats 3
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from heightfield import DT, DURATION, GRID, RADIUS, SIZE, heights, starts


def sheet():
    """(vertices, faces) of the heightfield's top surface alone: the open sheet."""
    c = (np.arange(GRID) / (GRID - 1) - 0.5) * SIZE
    x, y = np.meshgrid(c, c)
    vertices = np.column_stack([x.ravel(), y.ravel(), heights().ravel()])
    index = np.arange(GRID * GRID).reshape(GRID, GRID)
    a, b, c_, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, 1:].ravel(), index[1:, :-1].ravel()
    return vertices, np.vstack([np.column_stack([a, b, c_]), np.column_stack([a, c_, d])])


def depth_and_speed(x, v):
    """(deepest ball below the sheet, m; fastest ball, m/s) for centres x (n, 3), velocities v."""
    import tumble as tb

    V, F = sheet()
    probe = tb.World()
    probe.add_body(tb.Mesh(vertices=V, faces=F, closed=False), fixed=True)
    down = probe.ray_cast(origin=x, direction=np.tile((0.0, 0.0, -1.0), (len(x), 1)))
    return float(np.max(RADIUS - down.distance)), float(np.max(np.linalg.norm(v, axis=1)))


def run_tumble(n, kind):
    import tumble as tb

    H = heights()
    world = tb.World(gravity=(0, 0, -9.81))
    if kind == "open sheet":
        V, F = sheet()
        shape = tb.Mesh(vertices=V, faces=F, closed=False)
    else:
        shape = tb.heightfield(H, (SIZE, SIZE))
    world.add_body(shape, fixed=True, material={"friction": 0.8})
    for x, y in starts(n):
        world.add_body(tb.Sphere(RADIUS), mass=1.0, position=(x, y, float(H.max()) + 1.0), material={"friction": 0.8})
    sim = tb.Simulator(world, dt=DT)
    steps = int(round(DURATION / DT))
    t0 = time.perf_counter()
    sim.step(steps)
    per_step = (time.perf_counter() - t0) / steps
    return per_step, *depth_and_speed(world.x[1:], world.v[1:])


def run_pybullet(n):
    import pybullet as p

    V, F = sheet()
    H = heights()
    client = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81, physicsClientId=client)
    p.setTimeStep(DT, physicsClientId=client)
    terrain = p.createCollisionShape(p.GEOM_MESH, vertices=V.tolist(), indices=F.ravel().tolist(),
                                     flags=p.GEOM_FORCE_CONCAVE_TRIMESH, physicsClientId=client)
    ground = p.createMultiBody(0, terrain, physicsClientId=client)
    p.changeDynamics(ground, -1, lateralFriction=0.8, physicsClientId=client)
    ball = p.createCollisionShape(p.GEOM_SPHERE, radius=RADIUS, physicsClientId=client)
    ids = []
    for x, y in starts(n):
        b = p.createMultiBody(1.0, ball, basePosition=(x, y, float(H.max()) + 1.0), physicsClientId=client)
        p.changeDynamics(b, -1, lateralFriction=0.8, physicsClientId=client)
        ids.append(b)
    steps = int(round(DURATION / DT))
    t0 = time.perf_counter()
    for _ in range(steps):
        p.stepSimulation(physicsClientId=client)
    per_step = (time.perf_counter() - t0) / steps
    x = np.array([p.getBasePositionAndOrientation(b, physicsClientId=client)[0] for b in ids])
    v = np.array([p.getBaseVelocity(b, physicsClientId=client)[0] for b in ids])
    p.disconnect(client)
    return per_step, *depth_and_speed(x, v)


def flag_times(repeats):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from tests.collision.test_geometry import _edge_flags_by_loop

    from tumble.collision.geometry import mesh_edge_flags

    rows = []
    for cells in (50, 100, 200):
        c = np.linspace(-5, 5, cells + 1)
        x, y = np.meshgrid(c, c)
        V = np.column_stack([x.ravel(), y.ravel(), (0.3 * np.sin(x) * np.cos(y)).ravel()])
        index = np.arange((cells + 1) ** 2).reshape(cells + 1, cells + 1)
        a, b, c_, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, 1:].ravel(), index[1:, :-1].ravel()
        F = np.vstack([np.column_stack([a, b, c_]), np.column_stack([a, c_, d])])
        row = [len(F)]
        for fn in (_edge_flags_by_loop, mesh_edge_flags):
            times = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                fn(V, F, two_sided=True)
                times.append(time.perf_counter() - t0)
            row.append(statistics.median(times))
        rows.append(row)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--balls", type=int, nargs="+", default=[100, 400])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    git = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    print(f"open_mesh: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, Python "
          f"{platform.python_version()}, tumble at git {git}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    print("\n| balls | surface | engine | ms / step | deepest below (mm) | fastest at 4 s (m/s) |")
    print("|---|---|---|---|---|---|")
    runs = [("tumble", "open sheet", lambda n: run_tumble(n, "open sheet")),
            ("tumble", "closed heightfield", lambda n: run_tumble(n, "heightfield")),
            ("PyBullet", "concave trimesh", run_pybullet)]
    for n in args.balls:
        for engine, surface, fn in runs:
            fn(n)  # warm-up: compilation, caches
            out = [fn(n) for _ in range(args.repeats)]
            step = statistics.median(o[0] for o in out)
            print(f"| {n} | {surface} | {engine} | {step * 1e3:.2f} | {1e3 * out[-1][1]:.2f} | {out[-1][2]:.3f} |",
                  flush=True)
    print("\n| triangles | edge flags, per-edge loop (s) | sorted (s) | faster |")
    print("|---|---|---|---|")
    for count, loop, sort in flag_times(args.repeats):
        print(f"| {count} | {loop:.3f} | {sort:.4f} | {loop / sort:.0f}x |")


if __name__ == "__main__":
    main()
