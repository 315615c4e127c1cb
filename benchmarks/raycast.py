"""raycast: a range camera looking down onto the pile of 1000 boxes, tumble's ``World.ray_cast``
beside PyBullet's ``rayTestBatch`` and MuJoCo's ``mj_multiRay`` on the same boxes, in the same run.

Scene: BENCHMARKS.md's pile (``tumble.scenes.contact.pile(1000)``: cubes of half-extent 0.1 m at
seeded random orientations on a 10 x 10 x 10 grid 0.4 m apart, ground plane z = 0), at its start
poses. Rays: a range camera at (0, 0, 10) m, one ray towards each point of a K x K grid
(default 100 x 100 = 10 000) over x, y in [-2.5, 2.5] m on the ground, 20 m long (all rays from
one point: what ``mj_multiRay`` takes). PyBullet: the same cubes as plain rigid bodies
(``useMaximalCoordinates``), the same poses, a plane; ``rayTestBatch`` on one thread (its
default) and on all threads (``numThreads=0``). MuJoCo: the cubes as box geoms of the world body
at the same poses, a plane, ``mj_multiRay`` (one thread) after ``mj_forward``.

Timed: the query alone, median of ``--runs`` (tumble's first call, which compiles its kernel or
loads it from the cache, is timed apart). Agreement: the bodies hit and the distances of the two
engines compared ray by ray.

    PYTHONPATH=src python benchmarks/raycast.py [--rays-per-side 100] [--runs 7]
    PYTHONPATH=src python benchmarks/raycast.py --moving [N ...]   # a cast after every pose change
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import tumble as tb
from tumble.scenes.contact import pile


def rays(k: int):
    g = np.linspace(-2.5, 2.5, k)
    X, Y = np.meshgrid(g, g, indexing="ij")
    target = np.column_stack([X.ravel(), Y.ravel(), np.zeros(k * k)])
    origin = np.tile([0.0, 0.0, 10.0], (k * k, 1))
    direction = target - origin
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    return origin, direction, 20.0


def mujoco_cast(world, origin, direction, length, runs):
    import mujoco

    geoms = ['<geom type="plane" size="0 0 1"/>']
    boxes = np.flatnonzero(world.moving)
    for i in boxes:
        x, q = world.x[i], world.q[i]
        pos = " ".join(repr(float(v)) for v in x)
        quat = " ".join(repr(float(v)) for v in q)
        geoms.append(f'<geom type="box" size="0.1 0.1 0.1" pos="{pos}" quat="{quat}"/>')
    m = mujoco.MjModel.from_xml_string("<mujoco><worldbody>" + "".join(geoms) + "</worldbody></mujoco>")
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    n = len(direction)
    vec = np.ascontiguousarray(direction).ravel()
    geomid = np.zeros(n, dtype=np.int32)
    dist = np.zeros(n)
    normal = np.zeros(3 * n)
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        mujoco.mj_multiRay(m, d, origin[0].copy(), vec, None, 1, -1, geomid, dist, normal, n, length)
        times.append(time.perf_counter() - t)
    # geom 0 is the plane (tumble body 0), geom g >= 1 the box of tumble body boxes[g - 1]
    body = np.where(geomid < 0, -1, np.where(geomid == 0, 0, boxes[np.maximum(geomid - 1, 0)]))
    return body, np.where(geomid < 0, np.inf, dist), statistics.median(times)


def tumble_cast(world, origin, direction, length, runs):
    t = time.perf_counter()
    hits = world.ray_cast(origin, direction, max_distance=length)
    first = time.perf_counter() - t
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        hits = world.ray_cast(origin, direction, max_distance=length)
        times.append(time.perf_counter() - t)
    return hits, first, statistics.median(times)


def pybullet_cast(world, origin, direction, length, runs, threads):
    import pybullet as p

    cid = p.connect(p.DIRECT)
    p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid), physicsClientId=cid)
    box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.1, 0.1, 0.1], physicsClientId=cid)
    ids = {}
    for i in np.flatnonzero(world.moving):
        q = world.q[i]  # (w, x, y, z) -> PyBullet's (x, y, z, w)
        uid = p.createMultiBody(1.0, box, basePosition=world.x[i].tolist(),
                                baseOrientation=[q[1], q[2], q[3], q[0]], useMaximalCoordinates=True,
                                physicsClientId=cid)
        ids[uid] = i
    ends = origin + length * direction
    times = []
    out = None
    for _ in range(runs):
        t = time.perf_counter()
        out = p.rayTestBatch(origin.tolist(), ends.tolist(), numThreads=threads, physicsClientId=cid)
        times.append(time.perf_counter() - t)
    p.disconnect(cid)
    body = np.array([ids.get(r[0], -1 if r[0] < 0 else 0) for r in out])  # uid 0: the plane (tumble body 0)
    dist = np.array([r[2] * length if r[0] >= 0 else np.inf for r in out])
    return body, dist, statistics.median(times)


def exact_entry(world, i, o, d, half=0.1):
    """Entry distance (m) of the ray o + t d into box i by the slab test in plain NumPy, inf if it
    misses: the judge where the engines disagree."""
    from tumble.math3d import quat_to_matrix

    R = quat_to_matrix(world.q[i])
    lo, dl = R.T @ (o - world.x[i]), R.T @ d
    with np.errstate(divide="ignore"):
        t1, t2 = (-half - lo) / dl, (half - lo) / dl
    a, b = np.minimum(t1, t2).max(), np.maximum(t1, t2).min()
    return a if a <= b and a >= 0 else np.inf


def moving_query(count: int, runs: int, steps: int = 20):
    """A cast of one ray after every pose change (a sensor read each step), in a grid of ``count``
    cubes, each moved 1 mm and turned a little before each cast: the tree refitted (kept) against
    the tree built anew for each cast (``REFIT_GROWTH = 0``). Returns (refit ms, rebuild ms, the
    poses' boxes ms): medians over ``runs`` of the mean over ``steps`` casts; the last is
    ``update_bounds`` alone, which both pay."""
    import tumble.collision.raycast as rc
    from tumble.collision.bounds import update_bounds

    side = int(np.ceil(np.sqrt(count)))
    world = tb.World()
    world.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    for i in range(count):
        world.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0.4 * (i % side), 0.4 * (i // side), 0.5))
    turn = np.array([[1.0, -1e-3, 0.0], [1e-3, 1.0, 0.0], [0.0, 0.0, 1.0]])  # about z, nearly orthonormal
    moving = world.moving

    def per_cast(growth):
        rc.REFIT_GROWTH = growth
        world._ray_scene = None
        world.ray_cast((0.2, 0.2, 5.0), (0, 0, -1))  # table and first tree, apart
        times = []
        for _ in range(runs):
            total = 0.0
            for _ in range(steps):
                world.x[moving] += 1e-3
                world.R[moving] = world.R[moving] @ turn
                t = time.perf_counter()  # the cast alone, not the pose change
                world.ray_cast((0.2, 0.2, 5.0), (0, 0, -1))
                total += time.perf_counter() - t
            times.append(total / steps)
        return statistics.median(times)

    saved = rc.REFIT_GROWTH
    try:
        refit = per_cast(saved)
        rebuild = per_cast(0.0)
    finally:
        rc.REFIT_GROWTH = saved
    table = world._ray_scene.table
    bounds = []
    for _ in range(runs):
        t = time.perf_counter()
        update_bounds(np.asarray(world.x), np.asarray(world.R), table, 0.0)
        bounds.append(time.perf_counter() - t)
    return refit * 1e3, rebuild * 1e3, statistics.median(bounds) * 1e3


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rays-per-side", type=int, default=100)
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--moving", type=int, nargs="*", default=None, metavar="N",
                    help="instead: one ray cast after every pose change in grids of N cubes, tree refitted vs rebuilt")
    args = ap.parse_args(argv)
    if args.moving is not None:
        for count in args.moving or (1000, 10000, 100000):
            refit, rebuild, bounds = moving_query(count, args.runs)
            print(f"{count} cubes, one ray after each pose change: refit {refit:.3f} ms, rebuilt {rebuild:.3f} ms"
                  f" a cast ({rebuild / refit:.1f}x); of which the shapes' world boxes {bounds:.3f} ms")
        return
    world, _ = pile(1000)
    origin, direction, length = rays(args.rays_per_side)
    n = len(origin)
    hits, first, t_tumble = tumble_cast(world, origin, direction, length, args.runs)
    print(f"rays: {n}, bodies: {world.body_count} (1000 boxes + ground)")
    print(f"tumble World.ray_cast: first call {first:.2f} s (compile or cache load), median {t_tumble * 1e3:.2f} ms"
          f" = {n / t_tumble / 1e6:.2f} M rays/s; {hits.hit.sum()} hits, {np.sum(hits.body > 0)} on boxes")
    results = [(f"pybullet rayTestBatch ({'1 thread' if threads == 1 else 'all threads'})",
                pybullet_cast(world, origin, direction, length, args.runs, threads)) for threads in (1, 0)]
    try:
        results.append(("mujoco mj_multiRay", mujoco_cast(world, origin, direction, length, args.runs)))
    except ImportError:
        print("mujoco not installed: pip install mujoco")
    for label, (body, dist, t_peer) in results:
        same = body == hits.body
        both = same & np.isfinite(dist)
        diff = np.abs(dist[both] - hits.distance[both])
        print(f"{label}: median {t_peer * 1e3:.2f} ms = {n / t_peer / 1e6:.2f} M rays/s (tumble {t_peer / t_tumble:.1f}x"
              f" faster); same body on {same.mean() * 100:.2f} % of rays, distance differences there: median"
              f" {np.median(diff):.1e} m, largest {diff.max():.2e} m")
        # where the bodies differ: does the exact slab test put the peer's box in front of tumble's hit?
        wrong = [r for r in np.flatnonzero(~same) if body[r] > 0
                 and exact_entry(world, body[r], origin[r], direction[r]) < hits.distance[r] - 1e-9]
        print(f"  rays with another body: {np.sum(~same)}; of those, the peer's box is in front of tumble's hit"
              f" by the exact slab test on {len(wrong)}")


if __name__ == "__main__":
    main()
