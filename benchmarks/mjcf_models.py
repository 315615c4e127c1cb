"""MJCF models in tumble and MuJoCo: the same files (PyBullet's ``pybullet_data/mjcf``), the same dt.

``ant.xml`` (8 hinges, four legs) and ``humanoid.xml`` (21 hinges, bodies with two and three joints:
tumble's virtual links and the tree solve); in these copies the torso has no free joint (PyBullet
commented it out), so each model hangs from its fixed torso, its limbs falling under gravity onto
their limits and the floor. Third, ``ant_free.xml``: the ant with its free joint put back and a
floor added (Gym's locomotion ant), dropped to stand on its legs; its torso's height at the end
is printed under the table. Each is loaded by ``tumble.load_mjcf`` and by
``mujoco.MjModel.from_xml_path`` and stepped 2 s from the file's pose with no control at dt 1/240
s (MuJoCo: its file's integrator and solver, the timestep set to 1/240 s). Quality beside the
time: the largest joint-angle difference between the two at 0.5 s and at the end, from the
file's pose with each joint whose range leaves out 0 started at its range's middle (the ant's
ankles have ranges of 30 to 100 deg: from 0, 30 deg past a limit, MuJoCo's soft limit throws the
leg to the other stop and tumble's pushes it back to the near one, which says more about the
limit models than about the motion). The models use joint ``armature``, read by tumble; the
engines' contact and limit models differ.

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

    return name if os.path.isabs(name) else os.path.join(pybullet_data.getDataPath(), "mjcf", name)


def free_ant_file() -> str:
    """PyBullet's ant.xml with its torso's free joint put back (PyBullet commented it out) and a floor
    (this copy has none): the ant of Gym's locomotion tasks, dropped to stand on its legs."""
    import tempfile

    text = open(path_of("ant.xml")).read()
    text = text.replace('<!--joint armature="0" damping="0" limited="false" margin="0.01" name="root" pos="0 0 0" '
                        'type="free"/-->', '<joint armature="0" damping="0" limited="false" margin="0.01" name="root" '
                        'pos="0 0 0" type="free"/>')
    text = text.replace("<worldbody>", '<worldbody><geom name="floor" type="plane" size="40 40 0.1" conaffinity="1" '
                        'contype="1"/>', 1)
    assert 'name="root"' in text and "floor" in text
    path = os.path.join(tempfile.mkdtemp(), "ant_free.xml")
    with open(path, "w") as fh:
        fh.write(text)
    return path


MID = 0.5  # s, the first comparison (limbs swinging, before they settle on the floor)
heights: dict = {}  # the torso frame's height at the end of the last run of each engine, m


def in_range_start(name):
    """{joint: the middle of its range} for the limited hinges and slides whose range leaves out 0."""
    import mujoco

    m = mujoco.MjModel.from_xml_path(path_of(name))
    start = {}
    for j in range(m.njnt):
        lo, hi = m.jnt_range[j]
        if m.jnt_limited[j] and m.jnt_type[j] in (2, 3) and not lo <= 0.0 <= hi:
            start[m.joint(j).name] = 0.5 * (lo + hi)
    return start


def run_tumble(name, start):
    import tumble as tb

    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_mjcf(world, path_of(name), joint_positions=start)
    sim = tb.Simulator(world, dt=DT)
    sim.step(1)
    mid = int(round(MID / DT)) - 1
    steps = int(round(DURATION / DT)) - 1
    t0 = time.perf_counter()
    sim.step(mid)
    at_mid = {n: q for n, (q, _) in robot.joint_states(sim).items()}
    sim.step(steps - mid)
    per_step = (time.perf_counter() - t0) / steps
    readings = robot.joint_states(sim)
    heights["tumble"] = float(robot.link_pose("torso")[0][2]) if "torso" in robot.links else None
    return per_step, (at_mid, {n: q for n, (q, _) in readings.items()}), sim.joint_settings is not None


def run_mujoco(name, start):
    import mujoco

    m = mujoco.MjModel.from_xml_path(path_of(name))
    m.opt.timestep = DT
    d = mujoco.MjData(m)
    for joint, q in start.items():
        d.qpos[m.jnt_qposadr[m.joint(joint).id]] = q

    def angles():
        return {m.joint(j).name: float(d.qpos[m.jnt_qposadr[j]]) for j in range(m.njnt)}

    mid = int(round(MID / DT))
    steps = int(round(DURATION / DT))
    t0 = time.perf_counter()
    mujoco.mj_step(m, d, nstep=mid)
    at_mid = angles()
    mujoco.mj_step(m, d, nstep=steps - mid)
    per_step = (time.perf_counter() - t0) / steps
    torso = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "torso")
    heights["mujoco"] = float(d.xpos[torso][2]) if torso >= 0 else None
    return per_step, (at_mid, angles())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, tumble git {rev}; "
          f"dt 1/240 s, {DURATION:g} s, median of {args.repeats}")
    print()
    print(f"| model | tumble us/step | MuJoCo us/step | largest joint-angle difference at {MID:g} s / at the end (rad) |")
    print("|---|---|---|---|")
    standing = []
    for name in ("ant.xml", "humanoid.xml", free_ant_file()):
        times, angles, tree = {}, {}, False
        start = in_range_start(name)
        for engine, run in (("tumble", run_tumble), ("mujoco", run_mujoco)):
            run(name, start)  # warm-up (compilation)
            results = [run(name, start) for _ in range(args.repeats)]
            times[engine] = statistics.median(r[0] for r in results)
            angles[engine] = results[0][1]
            tree = tree or (engine == "tumble" and results[0][2])
        diffs = [max(abs(angles["tumble"][k][j] - angles["mujoco"][k][j]) for j in angles["tumble"][k]) for k in (0, 1)]
        label = os.path.basename(name) + (" (tree solve)" if tree else "")
        print(f"| {label} | {times['tumble'] * 1e6:.1f} | {times['mujoco'] * 1e6:.1f} | {diffs[0]:.4f} / {diffs[1]:.3f} |")
        if os.path.isabs(name):
            standing.append(f"{os.path.basename(name)}: the torso frame {heights['tumble']:.4f} m above the floor at "
                            f"the end in tumble, {heights['mujoco']:.4f} m in MuJoCo")
    for line in standing:
        print()
        print(line)


if __name__ == "__main__":
    main()
