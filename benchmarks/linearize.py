"""The step linearized by finite differences: tumble's ``Kinematics.transition_jacobians`` beside
MuJoCo's ``mjd_transitionFD`` on the same MJCF files, centred differences, eps 1e-6, dt 1/240 s.

Models: a pendulum on a motor (2 states, 1 input; tests/physics/test_linearize.py's), PyBullet's
copy of Gym's ``ant.xml`` hanging from its torso (8 hinges, 8 motors: 16 states) and the free ant
standing on its feet (its free joint put back, benchmarks/mjcf_models.py: 28 states, 8 inputs),
each after 1 s from its file's pose, tumble with the tree solve (MuJoCo with its Euler integrator: ``mjd_transitionFD`` refuses
the ants' RK4). Times: one whole linearization, median of ``--repeats`` after a
warm-up (compilation apart). Beside the time: the largest difference of the two engines' A and of
their B, the size of A's largest entry (the engines' schemes differ: tumble's 4 substeps against
MuJoCo's one Euler step, and their contact models).

    PYTHONPATH=src python benchmarks/linearize.py --repeats 5
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

DT = 1 / 240
PENDULUM = """<mujoco model="pend"><option timestep="{dt!r}" integrator="Euler"/><worldbody>
  <body name="arm" pos="0 0 2"><joint name="hinge" type="hinge" axis="0 1 0"/>
  <geom name="bob" type="sphere" size="0.05" pos="0 0 -1" mass="2"/></body></worldbody>
  <actuator><motor name="torque" joint="hinge" gear="1"/></actuator></mujoco>"""


def models():
    from mjcf_models import free_ant_file, path_of

    pend = os.path.join(tempfile.mkdtemp(), "pendulum.xml")
    with open(pend, "w") as fh:
        fh.write(PENDULUM.format(dt=DT))
    return [("pendulum", pend), ("ant (hanging)", path_of("ant.xml")), ("ant (free, standing)", free_ant_file())]


def tumble_linearize(path, repeats):
    import tumble as tb

    from tumble.solver.joints import JointSettings

    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_mjcf(world, path)
    # the tree solve: exact joints, as docs/robots.md advises for linearizing (Gauss-Seidel's soft
    # joints put their compliance into B: the pendulum's dq'/du 170 times the rigid one)
    sim = tb.Simulator(world, dt=DT, joint_settings=JointSettings(method="tree"))
    sim.step(int(round(1.0 / DT)))
    kin = robot.kinematics
    lin = kin.transition_jacobians(sim)  # warm-up (compiles)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        lin = kin.transition_jacobians(sim)
        times.append(time.perf_counter() - t0)
    return statistics.median(times), lin


def mujoco_linearize(path, repeats):
    import mujoco

    m = mujoco.MjModel.from_xml_path(path)
    m.opt.timestep = DT
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER  # mjd_transitionFD refuses RK4 (the ants' files)
    d = mujoco.MjData(m)
    mujoco.mj_step(m, d, nstep=int(round(1.0 / DT)))
    n = 2 * m.nv + m.na
    A, B = np.zeros((n, n)), np.zeros((n, m.nu))
    mujoco.mjd_transitionFD(m, d, 1e-6, True, A, B, None, None)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        mujoco.mjd_transitionFD(m, d, 1e-6, True, A, B, None, None)
        times.append(time.perf_counter() - t0)
    return statistics.median(times), A, B


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, tumble git {rev}; "
          f"dt 1/240 s, centred differences, eps 1e-6, median of {args.repeats}")
    print()
    print("| model | states, inputs | tumble ms | MuJoCo ms | largest A difference (largest entry) | largest B difference |")
    print("|---|---|---|---|---|---|")
    for name, path in models():
        t_tb, lin = tumble_linearize(path, args.repeats)
        t_mj, A, B = mujoco_linearize(path, args.repeats)
        same = A.shape == lin.A.shape and B.shape == lin.B.shape
        dA = f"{np.abs(lin.A - A).max():.1e} ({np.abs(A).max():.2g})" if same else "shapes differ"
        dB = f"{np.abs(lin.B - B).max():.1e}" if same else ""
        print(f"| {name} | {lin.A.shape[0]}, {lin.B.shape[1]} | {1e3 * t_tb:.1f} | {1e3 * t_mj:.2f} | {dA} | {dB} |")


if __name__ == "__main__":
    main()
