"""The contact scenes in PyBullet (DIRECT mode), from a tumble scene (``common.SceneSpec``).

Each moving box is ``createMultiBody`` with one GEOM_BOX collision shape (its half-extents and
mass) and no links; the ground is a GEOM_PLANE (or a GEOM_BOX) body of mass 0. Bullet multiplies
the two bodies' friction coefficients, so every body (ground included) gets sqrt(mu); restitution
0. Everything else keeps PyBullet's defaults (solver iterations, sleeping, ERP, ...), as in
BENCHMARKS.md. dt = 1/240 s.

Variants (BENCHMARKS.md):
  rigidbody   ``useMaximalCoordinates=True``: a plain btRigidBody per box (PyBullet's fastest form
              in the pile)
  multibody   the default: a Featherstone btMultiBody per box (linear/angular damping 0.04)

Standalone:  PYTHONPATH=src python benchmarks/peers/pybullet_scenes.py --scene pile --n 100
"""

from __future__ import annotations

import math
import time

import numpy as np

try:
    from .common import SceneSpec, quat_to_matrix, reusable_engine, script_main
except ImportError:  # pragma: no cover
    from common import SceneSpec, quat_to_matrix, reusable_engine, script_main

DT = 1.0 / 240.0
VARIANTS = {"rigidbody": True, "multibody": False}


def _xyzw(q_wxyz):
    w, x, y, z = (float(c) for c in q_wxyz)
    return [x, y, z, w]


class PybulletScene:
    """One PyBullet physics client holding the scene; ``reset()`` rebuilds it at its initial state."""

    def __init__(self, spec: SceneSpec, variant: str = "rigidbody", dt: float = DT):
        import pybullet as p

        self.p = p
        self.spec = spec
        self.variant = variant
        self.maximal = VARIANTS[variant]
        self.dt = dt
        self.cid = p.connect(p.DIRECT)
        self.ids: list[int] = []
        t0 = time.perf_counter()
        self.reset()
        self.load_s = time.perf_counter() - t0

    def reset(self):
        p, c, spec = self.p, self.cid, self.spec
        p.resetSimulation(physicsClientId=c)
        p.setGravity(*(float(g) for g in spec.gravity), physicsClientId=c)
        p.setTimeStep(self.dt, physicsClientId=c)
        for s in spec.statics:
            if s["kind"] == "plane":
                shape = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=c)
                body = p.createMultiBody(0.0, shape, physicsClientId=c)
            else:
                shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[float(h) for h in s["half"]], physicsClientId=c)
                body = p.createMultiBody(0.0, shape, basePosition=[float(v) for v in s["pos"]],
                                         baseOrientation=_xyzw(s["quat"]), physicsClientId=c)
            p.changeDynamics(body, -1, lateralFriction=math.sqrt(s["friction"]), restitution=float(s["restitution"]),
                             physicsClientId=c)
        shapes = {}
        self.ids = []
        for i in range(spec.n):
            key = tuple(float(h) for h in spec.half[i])
            if key not in shapes:
                shapes[key] = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(key), physicsClientId=c)
            body = p.createMultiBody(float(spec.mass[i]), shapes[key], basePosition=[float(v) for v in spec.pos[i]],
                                     baseOrientation=_xyzw(spec.quat[i]), useMaximalCoordinates=self.maximal,
                                     physicsClientId=c)
            p.changeDynamics(body, -1, lateralFriction=math.sqrt(spec.friction[i]),
                             restitution=float(spec.restitution[i]), physicsClientId=c)
            self.ids.append(body)

    def step(self, k: int):
        step, c = self.p.stepSimulation, self.cid
        for _ in range(k):
            step(physicsClientId=c)

    def state(self):
        p, c = self.p, self.cid
        n = len(self.ids)
        x = np.empty((n, 3))
        q = np.empty((n, 4))
        v = np.empty((n, 3))
        w = np.empty((n, 3))
        for k, b in enumerate(self.ids):
            pos, orn = p.getBasePositionAndOrientation(b, physicsClientId=c)
            lin, ang = p.getBaseVelocity(b, physicsClientId=c)
            x[k] = pos
            q[k] = (orn[3], orn[0], orn[1], orn[2])
            v[k] = lin
            w[k] = ang
        return x, quat_to_matrix(q), v, w

    def close(self):
        self.p.disconnect(physicsClientId=self.cid)


def make(spec: SceneSpec, variant: str):
    """(engine, load seconds, dt, substeps): a client with the scene built."""
    eng = PybulletScene(spec, variant)
    return eng, eng.load_s, eng.dt, 1


new_run = reusable_engine


if __name__ == "__main__":  # pragma: no cover
    script_main(make, VARIANTS, "rigidbody")
