"""closest_points: signed distance between shapes, tumble's ``World.closest_points`` beside
PyBullet's ``getClosestPoints`` and MuJoCo's ``mj_geomDistance`` on the same shapes, in the same run.

Scene: ``--count`` (default 100) shapes at seeded random positions in a cube of side 3 m and random
orientations, a fifth each of boxes (half-extents 0.1-0.3 m), spheres (radius 0.1-0.3), capsules
(radius 0.05-0.15, segment 0.2-0.6), cylinders (radius 0.1-0.25, length 0.2-0.6) and convex hulls
(20 Gaussian points, 0.15 m spread; tumble and PyBullet only: MuJoCo moves a mesh's frame to its
inertial frame). Queries: every pair of shapes (4950 for 100), with no distance bound.

- tumble: one ``closest_points`` call for all pairs (both cores; and on one thread), and one call
  per pair (a Python loop, as a user's per-pair query);
- PyBullet: ``getClosestPoints(a, b, distance=100)`` per pair (plain rigid bodies,
  ``useMaximalCoordinates``), its negative distances included;
- MuJoCo: ``mj_geomDistance(m, d, g1, g2, 100, fromto)`` per pair (geoms of mocap bodies, after
  ``mj_forward``; ``opt.ccd_tolerance`` 1e-6 by default, also run at 1e-10).

Shape casts (no peer: PyBullet's API has no convex sweep, MuJoCo none): ``--count`` capsules
(radius 0.1 m, segment 0.3 m) dropped 6 m straight down from above the same shapes, one
``shape_cast`` call for all (both cores), and a box cast likewise; each's median.

Near pairs: ``World.near_pairs(0.1)`` over the same shapes, and ``near_pairs(0.25)`` over
BENCHMARKS.md's pile of 1000 boxes at its start poses (0.4 m apart on a grid, the lowest 0.4 m above the ground).

Timed: each query set's median of ``--runs``, tumble's first call (compilation or cache load) apart.
Agreement: for each kind of pair, the largest difference of the distances from tumble's.

    PYTHONPATH=src python benchmarks/closest_points.py [--count 100] [--runs 5]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import time

import numpy as np

import tumble as tb

KINDS = ("box", "sphere", "capsule", "cylinder", "hull")


def scene(count: int, seed: int = 0):
    """[(kind, params, position (3,), quaternion (w, x, y, z))] of ``count`` shapes."""
    rng = np.random.default_rng(seed)
    shapes = []
    for k in range(count):
        kind = KINDS[k % len(KINDS)]
        if kind == "box":
            p = rng.uniform(0.1, 0.3, 3)
        elif kind == "sphere":
            p = rng.uniform(0.1, 0.3, 1)
        elif kind == "capsule":
            p = np.array([rng.uniform(0.05, 0.15), rng.uniform(0.2, 0.6)])
        elif kind == "cylinder":
            p = np.array([rng.uniform(0.1, 0.25), rng.uniform(0.2, 0.6)])
        else:
            p = rng.normal(size=(20, 3)) * 0.15
        q = rng.normal(size=4)
        shapes.append((kind, p, rng.uniform(-1.5, 1.5, 3), q / np.linalg.norm(q)))
    return shapes


def tumble_world(shapes):
    w = tb.World(gravity=(0, 0, 0))
    for kind, p, x, q in shapes:
        shape = {"box": lambda: tb.Box(size=2 * p), "sphere": lambda: tb.Sphere(p[0]),
                 "capsule": lambda: tb.Capsule(p[0], p[1]), "cylinder": lambda: tb.Cylinder(p[0], p[1]),
                 "hull": lambda: tb.Convex(points=p)}[kind]()
        w.add_body(shape, mass=1.0, position=x, orientation=q)
    return w


def hull_offset(w, i):
    """The hull body's centre of mass in its shape frame (tumble re-centres the body on it)."""
    return np.asarray(w.com_offset[i])


def median_time(f, runs):
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def run_tumble(w, a, b, runs):
    import tumble.collision.distance as dist_module

    t0 = time.perf_counter()
    r = w.closest_points(a, b)
    first = time.perf_counter() - t0
    batch = median_time(lambda: w.closest_points(a, b), runs)
    keep = dist_module.PARALLEL_MIN_PAIRS
    dist_module.PARALLEL_MIN_PAIRS = 10 ** 9
    try:
        batch_one = median_time(lambda: w.closest_points(a, b), runs)
    finally:
        dist_module.PARALLEL_MIN_PAIRS = keep
    ai, bi = a.tolist(), b.tolist()

    def loop():
        for i, j in zip(ai, bi):
            w.closest_points(i, j)

    per_pair = median_time(loop, max(1, runs // 2)) / len(a)
    return r.distance, first, batch, batch_one, per_pair


def run_pybullet(w, shapes, a, b, runs):
    import pybullet as pb

    cid = pb.connect(pb.DIRECT)
    ids = []
    for i, (kind, p, x, q) in enumerate(shapes):
        if kind == "box":
            s = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=p.tolist(), physicsClientId=cid)
        elif kind == "sphere":
            s = pb.createCollisionShape(pb.GEOM_SPHERE, radius=float(p[0]), physicsClientId=cid)
        elif kind == "capsule":
            s = pb.createCollisionShape(pb.GEOM_CAPSULE, radius=float(p[0]), height=float(p[1]), physicsClientId=cid)
        elif kind == "cylinder":
            s = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=float(p[0]), height=float(p[1]), physicsClientId=cid)
        else:
            s = pb.createCollisionShape(pb.GEOM_MESH, vertices=p.tolist(), physicsClientId=cid)
        # tumble's body frame sits at the centre of mass (a hull's is off its shape origin): place
        # PyBullet's shape origin where tumble's is
        R = np.asarray(w.R[i])
        origin = np.asarray(w.x[i]) - R @ hull_offset(w, i) if kind == "hull" else np.asarray(w.x[i])
        quat = [q[1], q[2], q[3], q[0]]
        ids.append(pb.createMultiBody(1.0, s, -1, origin.tolist(), quat, useMaximalCoordinates=True,
                                      physicsClientId=cid))
    ai, bi = a.tolist(), b.tolist()
    out = np.full(len(a), np.nan)

    def loop():
        for k, (i, j) in enumerate(zip(ai, bi)):
            pts = pb.getClosestPoints(ids[i], ids[j], 100.0, physicsClientId=cid)
            if pts:
                out[k] = min(pt[8] for pt in pts)

    per_pair = median_time(loop, runs) / len(a)
    pb.disconnect(cid)
    return out, per_pair


def _num(v) -> str:
    return repr(float(v))


def run_mujoco(shapes, a, b, runs, tolerance):
    import mujoco

    bodies = []
    for i, (kind, p, x, q) in enumerate(shapes):
        pos = " ".join(repr(float(v)) for v in x)
        quat = " ".join(repr(float(v)) for v in q)
        if kind == "box":
            geom = f'type="box" size="{_num(p[0])} {_num(p[1])} {_num(p[2])}"'
        elif kind == "sphere":
            geom = f'type="sphere" size="{_num(p[0])}"'
        elif kind == "capsule":
            geom = f'type="capsule" size="{_num(p[0])} {_num(p[1] / 2)}"'
        elif kind == "cylinder":
            geom = f'type="cylinder" size="{_num(p[0])} {_num(p[1] / 2)}"'
        else:
            geom = 'type="sphere" size="0.01" contype="0" conaffinity="0"'  # hulls: not compared (module docstring)
        bodies.append(f'<body mocap="true" pos="{pos}" quat="{quat}"><geom {geom}/></body>')
    xml = (f'<mujoco><option><flag/></option><worldbody>{"".join(bodies)}</worldbody></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    m.opt.ccd_tolerance = tolerance
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    ai, bi = a.tolist(), b.tolist()
    out = np.full(len(a), np.nan)
    fromto = np.zeros(6)
    skip = [kind == "hull" for kind, *_ in shapes]

    def loop():
        for k, (i, j) in enumerate(zip(ai, bi)):
            if not (skip[i] or skip[j]):
                out[k] = mujoco.mj_geomDistance(m, d, i, j, 100.0, fromto)

    per_pair = median_time(loop, runs) / max(1, sum(1 for i, j in zip(ai, bi) if not (skip[i] or skip[j])))
    return out, per_pair


def agreement(shapes, a, b, ours, theirs):
    """{pair kind: (pairs compared, largest |difference| m)}."""
    rows = {}
    for k in range(len(a)):
        if np.isnan(theirs[k]):
            continue
        key = "-".join(sorted((shapes[a[k]][0], shapes[b[k]][0])))
        n, worst = rows.get(key, (0, 0.0))
        rows[key] = (n + 1, max(worst, abs(ours[k] - theirs[k])))
    return dict(sorted(rows.items()))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=100)
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args(argv)
    shapes = scene(args.count)
    w = tumble_world(shapes)
    a, b = (v.astype(np.int64) for v in np.triu_indices(args.count, 1))
    ours, first, batch, batch_one, per_pair = run_tumble(w, a, b, args.runs)
    bullet, bullet_pair = run_pybullet(w, shapes, a, b, args.runs)
    mj6, mj6_pair = run_mujoco(shapes, a, b, args.runs, 1e-6)
    mj10, mj10_pair = run_mujoco(shapes, a, b, args.runs, 1e-10)
    rng = np.random.default_rng(1)
    starts = np.column_stack([rng.uniform(-1.5, 1.5, (args.count, 2)), np.full(args.count, 3.0)])
    drop = np.tile([0.0, 0.0, -6.0], (args.count, 1))
    cast_rows = []
    for label, probe in (("capsule (radius 0.1, segment 0.3)", tb.Capsule(0.1, 0.3)),
                         ("box (0.2 x 0.3 x 0.4)", tb.Box(size=(0.2, 0.3, 0.4)))):
        hits = w.shape_cast(probe, starts, drop)
        t_cast = median_time(lambda: w.shape_cast(probe, starts, drop), args.runs)
        cast_rows.append((label, t_cast, int(hits.hit.sum())))
    near = w.near_pairs(0.1)
    t_near = median_time(lambda: w.near_pairs(0.1), args.runs)
    from tumble.scenes.contact import pile

    pile_world = pile(1000)[0]
    pile_world.near_pairs(0.25)
    t_pile = median_time(lambda: pile_world.near_pairs(0.25), args.runs)
    pile_near = pile_world.near_pairs(0.25)
    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, tumble git {rev}; "
          f"{args.count} shapes, {len(a)} pairs, median of {args.runs}")
    print()
    print("| engine | query | total ms | us per pair |")
    print("|---|---|---|---|")
    print(f"| tumble | all pairs in one call, both cores | {batch * 1e3:.2f} | {batch / len(a) * 1e6:.2f} |")
    print(f"| tumble | all pairs in one call, one thread | {batch_one * 1e3:.2f} | {batch_one / len(a) * 1e6:.2f} |")
    print(f"| tumble | one call per pair (Python loop) | {per_pair * len(a) * 1e3:.1f} | {per_pair * 1e6:.2f} |")
    print(f"| pybullet | getClosestPoints per pair | {bullet_pair * len(a) * 1e3:.1f} | {bullet_pair * 1e6:.2f} |")
    print(f"| mujoco | mj_geomDistance per pair, ccd_tolerance 1e-6 (no hulls) | – | {mj6_pair * 1e6:.2f} |")
    print(f"| mujoco | mj_geomDistance per pair, ccd_tolerance 1e-10 (no hulls) | – | {mj10_pair * 1e6:.2f} |")
    print()
    print(f"tumble's first call (compilation or cache load): {first:.2f} s; overlapping pairs: "
          f"{int((ours < 0).sum())} of {len(a)}")
    print()
    print(f"| shape cast ({args.count} casts 6 m down through the shapes, one call) | total ms | us per cast | hits |")
    print("|---|---|---|---|")
    for label, t_cast, n_hit in cast_rows:
        print(f"| {label} | {t_cast * 1e3:.2f} | {t_cast / args.count * 1e6:.1f} | {n_hit} |")
    print()
    print("| near pairs | ms | pairs found |")
    print("|---|---|---|")
    print(f"| `near_pairs(0.1)` over these {args.count} shapes | {t_near * 1e3:.2f} | {len(near)} |")
    print(f"| `near_pairs(0.25)` over the pile of 1000 boxes at its start (and its ground) | {t_pile * 1e3:.2f} | "
          f"{len(pile_near)} |")
    print()
    print("| pair kind | pairs | largest difference from tumble: PyBullet (m) | MuJoCo 1e-6 (m) | MuJoCo 1e-10 (m) |")
    print("|---|---|---|---|---|")
    rb, r6, r10 = (agreement(shapes, a, b, ours, x) for x in (bullet, mj6, mj10))
    for key, (n, worst) in rb.items():
        m6 = f"{r6[key][1]:.1e}" if key in r6 else "–"
        m10 = f"{r10[key][1]:.1e}" if key in r10 else "–"
        print(f"| {key} | {n} | {worst:.1e} | {m6} | {m10} |")


if __name__ == "__main__":
    main()
