"""URDF robots in tumble, PyBullet and MuJoCo: the same files, accuracy and speed side by side.

Two cases, each loaded from the same URDF file by the three engines (tumble ``load_urdf``,
PyBullet ``loadURDF`` with ``URDF_USE_INERTIA_FROM_FILE`` and its default Featherstone multibody,
MuJoCo ``MjModel.from_xml_path``), fixed base, the URDF's joint damping (the kuka's 0.5 N m s/rad)
and no other (PyBullet's link damping set to 0), no motors (PyBullet's default velocity motors
switched off), no contacts, dt 1/240 s:

- ``arm``: the two-link arm of tests/physics/test_urdf.py (inertial frames turned and off the
  links' axes, a tip fused by a fixed joint), released at (0.6, -0.4) rad, 2 s; its error is
  measured against Lagrange's equations integrated by DOP853 (``solutions.planar_chain_dop853``):
  the largest joint-angle error over the run, sampled every 0.05 s.
- ``kuka``: PyBullet's ``kuka_iiwa/model.urdf`` (7 revolute joints; tumble hulls its OBJ meshes
  but nothing touches), released from a bent pose, 1 s: its shoulder strikes its limit at 0.36 s;
  no closed form, so the error is against MuJoCo RK4 at dt 1/4000 s on the same file (halving its
  step changes it by 5e-4 rad: MuJoCo's soft limit; the engines' limit models differ, a soft
  stop with 0.06 rad of overshoot in MuJoCo, a rigid one in tumble's tree solve).

Times: wall time per step, the median of ``--repeats`` runs after one warm-up run (tumble's
kernel compilation is in the warm-up and not counted); setup apart: loading the file and, for
tumble, its first step (which builds the shape and joint tables: the kuka's convex hulls). tumble runs its default joint solver
(Box2D's soft step, Gauss-Seidel) and the exact tree solve (``ACCURATE``).

Usage: ``python benchmarks/urdf_robots.py [--repeats 5]``; prints a markdown table (the figures in
docs/benchmarks.md, "URDF robots").
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

DT = 1 / 240
KUKA_START = [0.3, 0.8, -0.4, -1.2, 0.5, 0.9, 0.2]


def arm_file(folder: Path) -> Path:
    from tests.physics.test_urdf import ARM

    path = folder / "arm.urdf"
    path.write_text(ARM.replace("DAMPING", "0"))
    return path


def kuka_file() -> Path:
    import pybullet_data

    return Path(pybullet_data.getDataPath()) / "kuka_iiwa" / "model.urdf"


# ---------------------------------------------------------------------- engines: (joint angles (F, n), s per step)


def run_tumble(path, start, joints, duration, sample, accurate):
    import tumble as tb
    from tumble.solver.joints import ACCURATE
    from tumble.urdf import load_urdf

    t0 = time.perf_counter()
    world = tb.World(gravity=(0, 0, -9.81))
    world.collisions = False
    robot = load_urdf(world, path, fixed_base=True, joint_positions=dict(zip(joints, start)))
    sim = tb.Simulator(world, dt=DT, joint_settings=ACCURATE if accurate else None)
    sim.step(1)  # the first step builds the shape and joint tables: setup, timed apart
    setup = time.perf_counter() - t0
    every = int(round(sample / DT))
    out, clock, steps = [], 0.0, 0
    for k in range(int(round(duration / sample))):
        n = every - 1 if k == 0 else every
        t0 = time.perf_counter()
        sim.step(n)
        clock += time.perf_counter() - t0
        steps += n
        states = robot.joint_states(sim)
        out.append([states[j][0] for j in joints])
    return np.array(out), clock / steps, setup


def run_pybullet(path, start, joints, duration, sample):
    import pybullet as p

    t0 = time.perf_counter()
    cid = p.connect(p.DIRECT)
    try:
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        p.setTimeStep(DT, physicsClientId=cid)
        rid = p.loadURDF(str(path), useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=cid)
        index = {p.getJointInfo(rid, i, physicsClientId=cid)[1].decode(): i
                 for i in range(p.getNumJoints(rid, physicsClientId=cid))}
        ids = [index[j] for j in joints]
        for link in range(-1, p.getNumJoints(rid, physicsClientId=cid)):
            p.changeDynamics(rid, link, linearDamping=0, angularDamping=0, physicsClientId=cid)
        p.setJointMotorControlArray(rid, ids, p.VELOCITY_CONTROL, forces=[0.0] * len(ids), physicsClientId=cid)
        for i, q in zip(ids, start):
            p.resetJointState(rid, i, q, physicsClientId=cid)
        setup = time.perf_counter() - t0
        every = int(round(sample / DT))
        out, clock = [], 0.0
        for _ in range(int(round(duration / sample))):
            t0 = time.perf_counter()
            for _ in range(every):
                p.stepSimulation(physicsClientId=cid)
            clock += time.perf_counter() - t0
            out.append([s[0] for s in p.getJointStates(rid, ids, physicsClientId=cid)])
        return np.array(out), clock / (every * len(out)), setup
    finally:
        p.disconnect(cid)


def run_mujoco(path, start, joints, duration, sample, integrator="Euler", dt=DT):
    import mujoco

    t0 = time.perf_counter()
    model = mujoco.MjModel.from_xml_path(str(path))
    model.opt.timestep = dt
    model.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    model.dof_frictionloss[:] = 0.0
    data = mujoco.MjData(model)
    adr = [model.jnt_qposadr[model.joint(j).id] for j in joints]
    data.qpos[adr] = start
    mujoco.mj_forward(model, data)
    setup = time.perf_counter() - t0
    every = int(round(sample / dt))
    out, clock = [], 0.0
    for _ in range(int(round(duration / sample))):
        t0 = time.perf_counter()
        for _ in range(every):
            mujoco.mj_step(model, data)
        clock += time.perf_counter() - t0
        out.append(data.qpos[adr].copy())
    return np.array(out), clock / (every * len(out)), setup


def timed(run, repeats):
    """(joint angles, median s per step, median setup s) of ``repeats`` runs after a warm-up run."""
    run()  # warm-up: compilation, caches
    results = [run() for _ in range(repeats)]
    return results[0][0], statistics.median(r[1] for r in results), statistics.median(r[2] for r in results)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    rows = []

    from tests.physics.test_urdf import arm_reference

    arm, joints, start, duration = arm_file(folder), ["shoulder", "elbow"], [0.6, -0.4], 2.0
    t = 0.05 * np.arange(1, int(round(duration / 0.05)) + 1)
    _, reference = arm_reference(start, t[-1], t)
    kuka, kjoints = kuka_file(), [f"lbr_iiwa_joint_{i}" for i in range(1, 8)]
    kref = run_mujoco(kuka, KUKA_START, kjoints, 1.0, 0.05, "RK4", 1 / 4000)[0]
    kref_half = run_mujoco(kuka, KUKA_START, kjoints, 1.0, 0.05, "RK4", 1 / 8000)[0]
    print(f"kuka reference: RK4 1/4000 against 1/8000: {np.abs(kref - kref_half).max():.1e} rad", file=sys.stderr)

    for case, path, names, q0, length, ref in (("arm", arm, joints, start, duration, reference),
                                               ("kuka", kuka, kjoints, KUKA_START, 1.0, kref)):
        engines = [
            ("tumble", "default (soft step)", lambda: run_tumble(path, q0, names, length, 0.05, False)),
            ("tumble", "tree (ACCURATE)", lambda: run_tumble(path, q0, names, length, 0.05, True)),
            ("pybullet", "multibody", lambda: run_pybullet(path, q0, names, length, 0.05)),
            ("mujoco", "euler", lambda: run_mujoco(path, q0, names, length, 0.05, "Euler")),
            ("mujoco", "rk4", lambda: run_mujoco(path, q0, names, length, 0.05, "RK4")),
        ]
        for engine, variant, run in engines:
            q, per_step, setup = timed(run, args.repeats)
            rows.append((case, engine, variant, len(names), setup * 1e3, per_step * 1e6, float(np.abs(q - ref).max())))

    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}; dt 1/240 s; median of {args.repeats} runs\n")
    print("| robot | engine | variant | joints | setup ms | us/step | max joint-angle error (rad) |")
    print("|---|---|---|---|---|---|---|")
    for case, engine, variant, n, setup, us, err in rows:
        print(f"| {case} | {engine} | {variant} | {n} | {setup:.1f} | {us:.1f} | {err:.1e} |")


if __name__ == "__main__":
    main()
