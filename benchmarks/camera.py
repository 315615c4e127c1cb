"""Camera images: ``tb.Camera.capture`` (one exact ray per pixel, both cores) beside PyBullet's
``getCameraImage`` with its CPU rasteriser (``ER_TINY_RENDERER``: colour, depth buffer and
segmentation) on the same scenes, the same camera, in one process.

Scenes: a ball on the ground (a sphere of radius 0.5 m, a box, the ground plane), and BENCHMARKS.md's
pile of 1000 boxes at its start poses (seed 0) on the ground. Accuracy on the ball: the depth of
each pixel that sees the ball, against the closed-form ray-sphere distance (PyBullet's sphere is
a tessellated mesh, its depth a 24-bit-style nonlinear buffer turned back into metres). Median of 5.

    PYTHONPATH=src python benchmarks/camera.py [--out benchmarks/results/camera.md]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

import tumble as tb  # noqa: E402
from report import emit, machine_line  # noqa: E402
from tumble.scenes.contact import pile

NEAR, FAR = 0.01, 30.0
SIZES = ((160, 120), (320, 240), (640, 480))


def timed(fn, repeats=5):
    fn()
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return statistics.median(out)


def ball_world():
    world = tb.World(gravity=(0, 0, -9.81))
    world.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    world.add_body(tb.Sphere(radius=0.5), mass=1.0, position=(0, 0, 0.5))
    world.add_body(tb.Box(size=(0.4, 0.4, 0.4)), mass=1.0, position=(0.8, 0.6, 0.2), euler_deg=(0, 0, 30))
    return world


def pybullet_copy(world, p, client):
    """The world's planes, spheres and boxes as PyBullet bodies; {PyBullet id: tumble index}."""
    ids = {}
    for i, shape in enumerate(world.shapes):
        pos, quat = world.x[i], world.q[i]
        orn = (quat[1], quat[2], quat[3], quat[0])
        if isinstance(shape, tb.Plane):
            col = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=client)
            vis = p.createVisualShape(p.GEOM_BOX, halfExtents=(FAR, FAR, 0.001), visualFramePosition=(0, 0, -0.001),
                                      physicsClientId=client)
        elif isinstance(shape, tb.Sphere):
            col = p.createCollisionShape(p.GEOM_SPHERE, radius=shape.radius, physicsClientId=client)
            vis = p.createVisualShape(p.GEOM_SPHERE, radius=shape.radius, physicsClientId=client)
        else:
            half = np.asarray(shape.size) / 2
            col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=client)
            vis = p.createVisualShape(p.GEOM_BOX, halfExtents=half, physicsClientId=client)
        uid = p.createMultiBody(0.0, col, vis, basePosition=pos, baseOrientation=orn, physicsClientId=client)
        ids[uid] = i
    return ids


def rows_for(name, world, eye, target):
    import pybullet as p

    client = p.connect(p.DIRECT)
    pybullet_copy(world, p, client)
    view = p.computeViewMatrix(eye, target, (0, 0, 1), physicsClientId=client)
    rows = []
    for W, H in SIZES:
        cam = tb.Camera(position=eye, target=target, width=W, height=H, fov_deg=60)
        proj = p.computeProjectionMatrixFOV(60, W / H, NEAR, FAR, physicsClientId=client)
        ours = timed(lambda: cam.capture(world))
        theirs = timed(lambda: p.getCameraImage(W, H, view, proj, renderer=p.ER_TINY_RENDERER, physicsClientId=client))
        note = ""
        if name == "ball":
            img = cam.capture(world)
            _, _, _, buf, _ = p.getCameraImage(W, H, view, proj, renderer=p.ER_TINY_RENDERER, physicsClientId=client)
            z = FAR * NEAR / (FAR - (FAR - NEAR) * np.array(buf).reshape(H, W))
            c, axes, d = cam.rays(world)
            centre = np.array([0.0, 0.0, 0.5])
            oc = c - centre
            b = d @ oc
            disc = b * b - (oc @ oc - 0.25)
            hit = disc > 0
            exact = (-b - np.sqrt(np.where(hit, disc, 0.0))) * (d @ axes[:, 2])
            on = hit & (img.body == 1)
            ours_err = np.abs(img.depth[on] - exact[on])
            theirs_err = np.abs(z[on] - exact[on])
            note = (f"depth on the ball vs closed form: tumble max {ours_err.max():.1e} m, PyBullet median "
                    f"{np.median(theirs_err):.1e} m, max {theirs_err.max():.1e} m")
        rows.append((name, f"{W}x{H}", ours, theirs, note))
    p.disconnect(client)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    rows = rows_for("ball", ball_world(), (3.0, 0.0, 1.5), (0.0, 0.0, 0.5))
    boxes, _settings = pile(1000, seed=0)
    rows += rows_for("pile of 1000 boxes", boxes, (8.0, -6.0, 6.0), (0.0, 0.0, 2.0))
    lines = [machine_line('median of 5'), "",
             "| scene | pixels | tumble ms | PyBullet TinyRenderer ms | note |", "|---|---|---|---|---|"]
    for name, size, ours, theirs, note in rows:
        lines.append(f"| {name} | {size} | {ours * 1e3:.1f} | {theirs * 1e3:.1f} | {note} |")
    emit(lines, args.out)


if __name__ == "__main__":
    main()
