"""urdf_quadruped: a legged robot standing on PD drives, tumble beside PyBullet on the same URDF.

Robot: the Unitree A1 of PyBullet's ``pybullet_data`` (``a1/a1.urdf``: a 12.5 kg trunk and legs, 12
revolute joints, mesh and primitive collision shapes; tumble: ``inertia="balance"``, the file's
tensors with one triangle-inequality fix). Start: hips 0, thighs 0.8 rad, calves -1.5 rad (a
standing pose), trunk at 0.32 m, at rest on a plane (friction 1). Every joint held by a PD drive
to that pose, stiffness 100 N m/rad, damping 2 N m s/rad, at most the URDF's effort. tumble: the
drives of ``load_urdf(joint_targets=...)`` (implicit springs in the solver), default step and the
tree solve. PyBullet: the same PD as joint torques computed before each step (TORQUE_CONTROL, its
velocity motors off, link damping 0), its default solver, dt 1/240 s. 3 s.

Reported: wall time per step (median of ``--repeats`` runs after a warm-up), the trunk's height at
the end and its largest change over the last 2 s (standing still: near 0), and the mean sag of the
calves from their target at the end (the legs' load over the stiffness).

    PYTHONPATH=src python benchmarks/urdf_quadruped.py --repeats 3
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import time
from pathlib import Path

import numpy as np

DT, DURATION, KP, KD, Z0 = 1 / 240, 3.0, 100.0, 2.0, 0.32


def a1_path() -> Path:
    import pybullet_data

    return Path(pybullet_data.getDataPath()) / "a1" / "a1.urdf"


def pose(names):
    return {n: (0.0 if "hip" in n else 0.8 if "upper" in n else -1.5) for n in names}


def run_tumble(accurate: bool):
    import tumble as tb
    from tumble.solver.joints import ACCURATE
    from tumble.urdf import load_urdf, read_urdf

    path = a1_path()
    model = read_urdf(path, [path.parent.parent])
    names = [j.name for j in model.joints if j.kind == "revolute"]
    q0 = pose(names)
    world = tb.World(gravity=(0, 0, -9.81))
    world.add_body(tb.Plane(), fixed=True, material={"friction": 1.0})
    robot = load_urdf(world, path, position=(0, 0, Z0), package_dirs=[path.parent.parent], inertia="balance",
                      material={"friction": 1.0}, joint_positions=q0,
                      joint_targets={n: {"position": q, "stiffness": KP, "damping": KD} for n, q in q0.items()})
    sim = tb.Simulator(world, dt=DT, joint_settings=ACCURATE if accurate else None)
    sim.step(1)
    heights, clock, steps = [], 0.0, int(round(DURATION / DT)) - 1
    for _ in range(steps):
        t0 = time.perf_counter()
        sim.step(1)
        clock += time.perf_counter() - t0
        heights.append(float(robot.base.x[2]))
    states = robot.joint_states(sim)
    sag = np.mean([states[n][0] - q0[n] for n in names if "lower" in n])
    return clock / steps, heights, sag


def run_pybullet():
    import pybullet as p

    path = a1_path()
    cid = p.connect(p.DIRECT)
    try:
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        p.setTimeStep(DT, physicsClientId=cid)
        plane = p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid), physicsClientId=cid)
        p.changeDynamics(plane, -1, lateralFriction=1.0, physicsClientId=cid)
        rid = p.loadURDF(str(path), (0, 0, Z0), flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=cid)
        joints = [i for i in range(p.getNumJoints(rid, physicsClientId=cid))
                  if p.getJointInfo(rid, i, physicsClientId=cid)[2] == p.JOINT_REVOLUTE]
        names = [p.getJointInfo(rid, i, physicsClientId=cid)[1].decode() for i in joints]
        effort = np.array([p.getJointInfo(rid, i, physicsClientId=cid)[10] for i in joints])
        q0 = pose(names)
        target = np.array([q0[n] for n in names])
        for link in range(-1, p.getNumJoints(rid, physicsClientId=cid)):
            p.changeDynamics(rid, link, linearDamping=0, angularDamping=0, lateralFriction=1.0, physicsClientId=cid)
        for i, q in zip(joints, target):
            p.resetJointState(rid, i, q, physicsClientId=cid)
        p.setJointMotorControlArray(rid, joints, p.VELOCITY_CONTROL, forces=[0.0] * len(joints), physicsClientId=cid)
        heights, clock, steps = [], 0.0, int(round(DURATION / DT)) - 1
        for _ in range(steps + 1):
            t0 = time.perf_counter()
            st = p.getJointStates(rid, joints, physicsClientId=cid)
            q = np.array([s[0] for s in st])
            qd = np.array([s[1] for s in st])
            tau = np.clip(KP * (target - q) - KD * qd, -effort, effort)
            p.setJointMotorControlArray(rid, joints, p.TORQUE_CONTROL, forces=tau.tolist(), physicsClientId=cid)
            p.stepSimulation(physicsClientId=cid)
            clock += time.perf_counter() - t0
            heights.append(p.getBasePositionAndOrientation(rid, physicsClientId=cid)[0][2])
        q = np.array([s[0] for s in p.getJointStates(rid, joints, physicsClientId=cid)])
        sag = np.mean([q[k] - target[k] for k, n in enumerate(names) if "lower" in n])
        return clock / (steps + 1), heights[1:], sag
    finally:
        p.disconnect(cid)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    git = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                         cwd=os.path.dirname(__file__)).stdout.strip()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, tumble git {git}; "
          f"A1 standing on PD drives, {DURATION:g} s at dt 1/240 s, median of {args.repeats}\n")
    print("| engine | variant | us/step | trunk height at the end (m) | its largest change over the last 2 s (m) "
          "| mean calf sag (rad) |")
    print("|---|---|---|---|---|---|")
    last = int(round(2.0 / DT))
    for engine, variant, run in (("tumble", "default (soft step)", lambda: run_tumble(False)),
                                 ("tumble", "tree (ACCURATE)", lambda: run_tumble(True)),
                                 ("pybullet", "multibody, PD torques", run_pybullet)):
        run()
        results = [run() for _ in range(args.repeats)]
        per_step = statistics.median(r[0] for r in results)
        _, heights, sag = results[-1]
        tail = np.array(heights[-last:])
        print(f"| {engine} | {variant} | {1e6 * per_step:.0f} | {heights[-1]:.4f} | {tail.max() - tail.min():.1e} | "
              f"{sag:+.4f} |")


if __name__ == "__main__":
    main()
