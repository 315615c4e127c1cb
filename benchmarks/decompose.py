"""Moving concave bodies: what ``tb.decompose`` costs, and the ring toss in tumble and PyBullet.

1. CoACD's decomposition (``tb.decompose(mesh, cache=False)``) of three closed meshes: the flat
   48-sided ring of tests/physics/test_decompose.py, the torus of examples/ring_toss.toml and the
   thin bowl of examples/marbles.toml: pieces, seconds (median of ``--repeats``), the pieces' hull
   volume over the mesh's; then the same call answered from the cache on disk and in memory.
2. examples/ring_toss.toml (five tori dropped over three pegs, 3 s at dt 1/240 s) in tumble, and
   the same scene in PyBullet (each ring a multibody base: its rigid bodies turn NaN once
   ``localInertiaDiagonal`` is set) with the same CoACD pieces
   loaded as one compound of convex hulls (``createCollisionShapeArray`` of one OBJ per piece), the torus's mass properties (``localInertiaDiagonal``), friction sqrt(mu) per
   body (Bullet multiplies the pair's), restitution 0; and PyBullet with the ring as one
   ``GEOM_MESH`` (its convex hull, what a moving mesh is in PyBullet). Wall time per step (median
   of ``--repeats`` after a warm-up, compilation apart) and the outcome: rings ending round a peg
   (centre within the 0.095 m clearance of its axis and below its top).

    PYTHONPATH=src python benchmarks/decompose.py --repeats 3 --out benchmarks/results/decompose.md
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from report import emit, machine_line

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
DT, DURATION = 1 / 240, 3.0
PEGS = [(-0.5, 0.0), (0.0, 0.0), (0.5, 0.0)]
PEG_TOP, CLEARANCE = 0.3, 0.15 - 0.025 - 0.03


def meshes():
    import trimesh

    import tumble as tb

    flat = trimesh.creation.annulus(r_min=0.2, r_max=0.3, height=0.1, sections=48)
    return {"flat ring (48-gon)": tb.Mesh(vertices=flat.vertices, faces=flat.faces),
            "torus (ring.obj)": tb.Mesh(path=str(EXAMPLES / "ring.obj")),
            "bowl (bowl.obj)": tb.Mesh(path=str(EXAMPLES / "bowl.obj"))}


def decomposition_table(repeats):
    import tumble as tb
    from tumble import decomposition

    lines = ["| mesh | triangles | pieces | CoACD s (median) | pieces' hull volume / mesh's | from the disk cache ms | "
             "from memory ms |", "|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as cache:
        os.environ["TUMBLE_CACHE_DIR"] = cache
        for name, mesh in meshes().items():
            times = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                c = tb.decompose(mesh, cache=False)
                times.append(time.perf_counter() - t0)
            hulls = sum(abs(float(p.trimesh.volume)) for p, _, _ in c.parts)
            tb.decompose(mesh)  # written to the cache
            decomposition._memory.clear()
            t0 = time.perf_counter()
            tb.decompose(mesh)
            disk = time.perf_counter() - t0
            t0 = time.perf_counter()
            tb.decompose(mesh)
            memory = time.perf_counter() - t0
            lines.append(f"| {name} | {len(mesh.faces)} | {len(c.parts)} | {statistics.median(times):.2f} | "
                         f"{hulls / abs(float(mesh.trimesh.volume)):.3f} | {disk * 1e3:.1f} | {memory * 1e3:.1f} |")
    return lines


def ringers(positions):
    out = 0
    for x in positions:
        if x[2] < PEG_TOP and min(math.hypot(x[0] - px, x[1] - py) for px, py in PEGS) < CLEARANCE:
            out += 1
    return out


def run_tumble():
    from tumble.scene import load_scene

    scene = load_scene(EXAMPLES / "ring_toss.toml")
    sim_steps = int(round(DURATION / DT))
    t0 = time.perf_counter()
    traj = scene.run(progress=False)
    wall = time.perf_counter() - t0
    names = traj.names.tolist()
    rings = [traj.position[-1, names.index(f"ring{k}")] for k in range(5)]
    return wall / sim_steps, ringers(rings)


def ring_specs():
    """(position, quaternion (x, y, z, w), angular velocity) of the five rings of ring_toss.toml."""
    import tomllib

    from tumble.math3d import quat_from_euler_deg

    doc = tomllib.loads((EXAMPLES / "ring_toss.toml").read_text())
    out = []
    for b in doc["bodies"]:
        if b["name"].startswith("ring"):
            w, x, y, z = quat_from_euler_deg(b.get("euler_deg", [0, 0, 0]))
            out.append((b["position"], (x, y, z, w), b.get("angular_velocity", [0, 0, 0])))
    return out


def run_pybullet(compound: bool):
    import pybullet as p

    import tumble as tb
    from tumble.mass import mass_properties

    ring = tb.Mesh(path=str(EXAMPLES / "ring.obj"))
    props = mass_properties(ring, mass=0.05)
    moments = np.linalg.eigvalsh(props.inertia)  # the torus's axes are the mesh's (symmetric about z)
    folder = tempfile.mkdtemp()
    files = []
    for k, (part, _, _) in enumerate(tb.decompose(ring).parts):
        files.append(os.path.join(folder, f"piece{k}.obj"))
        with open(files[-1], "w") as fh:
            fh.writelines(f"v {v[0]!r} {v[1]!r} {v[2]!r}\n" for v in part.vertices)
            fh.writelines(f"f {f[0] + 1} {f[1] + 1} {f[2] + 1}\n" for f in part.faces)
    cid = p.connect(p.DIRECT)
    try:
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        p.setTimeStep(DT, physicsClientId=cid)
        plane = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid)
        ground = p.createMultiBody(0, plane, physicsClientId=cid)
        p.changeDynamics(ground, -1, lateralFriction=math.sqrt(0.6), restitution=0.0, physicsClientId=cid)
        peg = p.createCollisionShape(p.GEOM_CYLINDER, radius=0.03, height=0.3, physicsClientId=cid)
        for px, py in PEGS:
            b = p.createMultiBody(0, peg, basePosition=(px, py, 0.15), useMaximalCoordinates=True, physicsClientId=cid)
            p.changeDynamics(b, -1, lateralFriction=math.sqrt(0.4), physicsClientId=cid)
        if compound:  # one convex hull per piece file, in one compound shape
            shape = p.createCollisionShapeArray(shapeTypes=[p.GEOM_MESH] * len(files), fileNames=files,
                                                physicsClientId=cid)
        else:
            shape = p.createCollisionShape(p.GEOM_MESH, fileName=str(EXAMPLES / "ring.obj"), physicsClientId=cid)
        rings = []
        for pos, quat, omega in ring_specs():
            # a multibody base: PyBullet's rigid bodies (useMaximalCoordinates) turn NaN when
            # localInertiaDiagonal is set (pybullet 3.2.7, measured: a ball NaN within 10 steps)
            b = p.createMultiBody(0.05, shape, basePosition=pos, baseOrientation=quat, physicsClientId=cid)
            p.resetBaseVelocity(b, (0, 0, 0), omega, physicsClientId=cid)
            p.changeDynamics(b, -1, lateralFriction=math.sqrt(0.4), restitution=0.0,
                             localInertiaDiagonal=tuple(float(m) for m in (moments[0], moments[1], moments[2])),
                             physicsClientId=cid)
            rings.append(b)
        steps = int(round(DURATION / DT))
        t0 = time.perf_counter()
        for _ in range(steps):
            p.stepSimulation(physicsClientId=cid)
        wall = time.perf_counter() - t0
        positions = [p.getBasePositionAndOrientation(b, physicsClientId=cid)[0] for b in rings]
        return wall / steps, ringers(positions)
    finally:
        p.disconnect(cid)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out")
    args = ap.parse_args()
    lines = [machine_line(f"median of {args.repeats}"), "", "Decomposition (CoACD 1.0.14, threshold 0.05, seed 0):", ""]
    lines += decomposition_table(args.repeats)
    lines += ["", f"examples/ring_toss.toml, {DURATION:g} s at dt 1/240 s (5 rings over 3 pegs; 4 land round a peg "
              "in tumble's run):", "", "| engine | ring shape | us/step | rings round a peg at the end |", "|---|---|---|---|"]
    for label, shape, run in (("tumble", "CoACD pieces", run_tumble),
                              ("pybullet", "the same CoACD pieces (compound)", lambda: run_pybullet(True)),
                              ("pybullet", "convex hull (GEOM_MESH)", lambda: run_pybullet(False))):
        run()  # warm-up (compilation)
        results = [run() for _ in range(args.repeats)]
        us = statistics.median(r[0] for r in results) * 1e6
        lines.append(f"| {label} | {shape} | {us:.1f} | {results[0][1]} |")
    emit(lines, args.out)


if __name__ == "__main__":
    main()
