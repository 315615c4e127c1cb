"""MJCF models in tumble and MuJoCo: the same files (PyBullet's ``pybullet_data/mjcf``), the same dt.

``ant.xml`` (8 hinges, four legs) and ``humanoid.xml`` (21 hinges, bodies with two and three joints:
tumble's virtual links and the tree solve); in these copies the torso has no free joint (PyBullet
commented it out), so each model hangs from its fixed torso, its limbs falling under gravity onto
their limits and the floor. Each is loaded by ``tumble.load_mjcf`` and by
``mujoco.MjModel.from_xml_path`` and stepped 2 s from the file's pose with no control at dt 1/240
s (MuJoCo: its file's integrator and solver, the timestep set to 1/240 s). Quality beside the
time: the largest joint-angle difference between the two at the end (the models use joint
``armature``, which tumble does not read, and the engines' contact and limit models differ).

Times: wall time per step, median of ``--repeats`` runs after one warm-up (compilation apart).

    PYTHONPATH=src python benchmarks/mjcf_models.py --repeats 3
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import time

DT, DURATION = 1 / 240, 2.0


def path_of(name):
    import pybullet_data

    return os.path.join(pybullet_data.getDataPath(), "mjcf", name)


def run_tumble(name):
    import tumble as tb

    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_mjcf(world, path_of(name))
    sim = tb.Simulator(world, dt=DT)
    sim.step(1)
    steps = int(round(DURATION / DT)) - 1
    t0 = time.perf_counter()
    sim.step(steps)
    per_step = (time.perf_counter() - t0) / steps
    readings = robot.joint_states(sim)
    return per_step, {n: q for n, (q, _) in readings.items()}, sim.joint_settings is not None


def run_mujoco(name):
    import mujoco

    m = mujoco.MjModel.from_xml_path(path_of(name))
    m.opt.timestep = DT
    d = mujoco.MjData(m)
    steps = int(round(DURATION / DT))
    t0 = time.perf_counter()
    mujoco.mj_step(m, d, nstep=steps)
    per_step = (time.perf_counter() - t0) / steps
    return per_step, {m.joint(j).name: float(d.qpos[m.jnt_qposadr[j]]) for j in range(m.njnt)}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, tumble git {rev}; "
          f"dt 1/240 s, {DURATION:g} s, median of {args.repeats}")
    print()
    print("| model | tumble us/step | MuJoCo us/step | largest joint-angle difference at the end (rad) |")
    print("|---|---|---|---|")
    for name in ("ant.xml", "humanoid.xml"):
        times, finals, tree = {}, {}, False
        for engine, run in (("tumble", run_tumble), ("mujoco", run_mujoco)):
            run(name)  # warm-up (compilation)
            results = [run(name) for _ in range(args.repeats)]
            times[engine] = statistics.median(r[0] for r in results)
            finals[engine] = results[0][1]
            tree = tree or (engine == "tumble" and results[0][2])
        diff = max(abs(finals["tumble"][j] - finals["mujoco"][j]) for j in finals["tumble"])
        label = name + (" (tree solve)" if tree else "")
        print(f"| {label} | {times['tumble'] * 1e6:.1f} | {times['mujoco'] * 1e6:.1f} | {diff:.3f} |")


if __name__ == "__main__":
    main()
