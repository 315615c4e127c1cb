"""The contact scenes in MuJoCo: MJCF generated from a tumble scene (``common.SceneSpec``).

Each moving box is a body with a free joint and one box geom (its mass, half-extents, friction);
the ground is a plane (or a box) in the world body. MuJoCo mixes friction by the max of the two
geoms, so each geom gets the scene's mu (the same value on every body in these scenes); torsional
and rolling friction keep MuJoCo's defaults (0.005, 0.0001). MuJoCo has no restitution
coefficient: its default soft contact (solref 0.02 1) is close to inelastic, which the scenes ask
for (restitution 0). dt = 1/240 s as in BENCHMARKS.md.

Variants (BENCHMARKS.md table b):
  euler      mjINT_EULER with the default Newton solver (stalls on the 1000-box pile: over 2 s a
             step once one island forms)
  euler-cg   mjINT_EULER with the CG solver (finishes the 1000-box pile)

Standalone:  PYTHONPATH=src python benchmarks/peers/mujoco_scenes.py --scene pile --n 100
"""

from __future__ import annotations

import time

import numpy as np

try:  # run as part of the benchmarks package or as a script
    from .common import SceneSpec, quat_to_matrix, reusable_engine, script_main
except ImportError:  # pragma: no cover
    from common import SceneSpec, quat_to_matrix, reusable_engine, script_main

DT = 1.0 / 240.0
VARIANTS = {"euler": ("Euler", "Newton"), "euler-cg": ("Euler", "CG")}


def _f(x) -> str:
    return " ".join(repr(float(v)) for v in np.atleast_1d(x))


def step_counting_iterations(mujoco, model, data, k: int) -> int:
    """``k`` calls of ``mujoco.mj_step``; returns the sum over them of the solver iterations of
    the island that needed most (islands are on by default: one count per island in
    ``data.solver_niter[:data.nisland]``)."""
    step, niter = mujoco.mj_step, data.solver_niter
    total = 0
    for _ in range(k):
        step(model, data)
        ni = data.nisland
        total += int(niter[:ni].max()) if ni > 1 else int(niter[0])
    return total


def mjcf(spec: SceneSpec, variant: str = "euler", dt: float = DT) -> str:
    """The MJCF text of the scene for ``variant``."""
    integrator, solver = VARIANTS[variant]
    n = spec.n
    # arena: the default is too small once thousands of contacts form (about 0.3 MB a box is ample)
    memory_mb = max(64, int(0.4 * n) + 64)
    parts = [
        f'<mujoco model="{spec.name}">',
        '<compiler angle="radian"/>',
        f'<option timestep="{dt!r}" gravity="{_f(spec.gravity)}" integrator="{integrator}" solver="{solver}"/>',
        f'<size memory="{memory_mb}M"/>',
        "<worldbody>",
    ]
    for k, s in enumerate(spec.statics):
        fr = f'friction="{float(s["friction"])!r} 0.005 0.0001"'
        if s["kind"] == "plane":
            parts.append(f'<geom name="ground{k}" type="plane" size="0 0 1" {fr}/>')
        else:
            parts.append(f'<geom name="ground{k}" type="box" pos="{_f(s["pos"])}" quat="{_f(s["quat"])}" '
                         f'size="{_f(s["half"])}" {fr}/>')
    for i in range(n):
        parts.append(
            f'<body name="b{i}" pos="{_f(spec.pos[i])}" quat="{_f(spec.quat[i])}"><freejoint/>'
            f'<geom type="box" size="{_f(spec.half[i])}" mass="{float(spec.mass[i])!r}" '
            f'friction="{float(spec.friction[i])!r} 0.005 0.0001"/></body>')
    parts.append("</worldbody></mujoco>")
    return "\n".join(parts)


class MujocoScene:
    """One compiled model; ``reset()`` gives a fresh MjData at the scene's initial state."""

    def __init__(self, spec: SceneSpec, variant: str = "euler", dt: float = DT):
        import mujoco

        self.mujoco = mujoco
        self.spec = spec
        self.variant = variant
        self.dt = dt
        t0 = time.perf_counter()
        xml = mjcf(spec, variant, dt)
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.load_s = time.perf_counter() - t0
        self.data = None
        self.reset()

    def reset(self):
        mj = self.mujoco
        self.data = mj.MjData(self.model)
        mj.mj_forward(self.model, self.data)
        self._iters = 0
        self._steps = 0

    def step(self, k: int):
        self._iters += step_counting_iterations(self.mujoco, self.model, self.data, k)
        self._steps += k

    def state(self):
        n = self.spec.n
        qpos = self.data.qpos.reshape(n, 7)
        qvel = self.data.qvel.reshape(n, 6)
        R = quat_to_matrix(qpos[:, 3:])
        # free joint: linear velocity of the body origin (= its centre of mass here) in the world frame,
        # angular velocity in the body frame
        omega = np.einsum("nij,nj->ni", R, qvel[:, 3:])
        return qpos[:, :3].copy(), R, qvel[:, :3].copy(), omega

    def solver_iterations(self):
        """Mean over steps of the largest solver iteration count among the step's islands."""
        return self._iters / self._steps if self._steps else None


def make(spec: SceneSpec, variant: str):
    """(engine, load seconds, dt, substeps): a compiled model at its initial state."""
    eng = MujocoScene(spec, variant)
    return eng, eng.load_s, eng.dt, 1


new_run = reusable_engine


if __name__ == "__main__":  # pragma: no cover
    script_main(make, VARIANTS, "euler")
