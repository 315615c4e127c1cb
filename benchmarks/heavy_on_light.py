"""Heavy on light: a cube of M kg resting on a 1 kg one (both 0.2 m) on the ground, in tumble (by
default, and with the loaded contacts' stiffening, ``SoftStepSettings(load_hertz_cap_per_substep=
0.1875)``), PyBullet and MuJoCo, at dt 1/240 s and 1/60 s, M = 10, 100, 1000 kg; each let go
touching, run 6 s. Quality: how far the heavy box sinks into the light one (m), how far the light
one sinks into the ground, the largest speed at the end; the time of a step (microseconds, the
median of 5 blocks of 40 steps after the first second).

    python benchmarks/heavy_on_light.py [--out benchmarks/results/heavy_on_light.md]

PyBullet: its default solver (sequential impulses, 50 iterations), a plane and two boxes, friction
0.5. MuJoCo: its default solver (Newton, pyramidal cones), a plane and two free boxes, friction 0.5
(MuJoCo's default). tumble: ``Simulator(world, dt)``, friction 0.5 (Box2D's default combine: the
geometric mean), sleeping off so that nothing freezes before the end.
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

SECONDS = 6.0
RATIOS = (10.0, 100.0, 1000.0)
STEPS = (1.0 / 240.0, 1.0 / 60.0)


def _timed(step, n_blocks=5, block=40):
    times = []
    for _ in range(n_blocks):
        t = time.perf_counter()
        for _ in range(block):
            step()
        times.append((time.perf_counter() - t) / block * 1e6)
    return statistics.median(times)


def run_tumble(M, dt, stiffen=True):
    import tumble as tb
    from tumble.solver.contact import SoftStepSettings

    w = tb.World(gravity=(0, 0, -9.81))
    w.sleeping = False
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    light = w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 0.1))
    heavy = w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=M, position=(0, 0, 0.3))
    settings = SoftStepSettings(load_hertz_cap_per_substep=0.1875) if stiffen else SoftStepSettings()
    sim = tb.Simulator(w, dt=dt, contact_settings=settings)
    n = int(round(SECONDS / dt))
    sim.step(int(round(1.0 / dt)))
    us = _timed(lambda: sim.step(1))
    sim.step(n - int(round(1.0 / dt)) - 200)
    return 0.2 - (heavy.x[2] - light.x[2]), 0.1 - light.x[2], float(np.abs(w.v).max()), us


def run_pybullet(M, dt):
    import pybullet as p

    c = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81, physicsClientId=c)
    p.setTimeStep(dt, physicsClientId=c)
    plane = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=c)
    p.createMultiBody(0, plane, physicsClientId=c)
    box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.1, 0.1, 0.1], physicsClientId=c)
    light = p.createMultiBody(1.0, box, basePosition=[0, 0, 0.1], physicsClientId=c)
    heavy = p.createMultiBody(M, box, basePosition=[0, 0, 0.3], physicsClientId=c)
    for b in (-1, light, heavy):
        p.changeDynamics(b if b >= 0 else 0, -1, lateralFriction=0.5, physicsClientId=c)
    n = int(round(SECONDS / dt))
    for _ in range(int(round(1.0 / dt))):
        p.stepSimulation(physicsClientId=c)
    us = _timed(lambda: p.stepSimulation(physicsClientId=c))
    for _ in range(n - int(round(1.0 / dt)) - 200):
        p.stepSimulation(physicsClientId=c)
    zl = p.getBasePositionAndOrientation(light, physicsClientId=c)[0][2]
    zh = p.getBasePositionAndOrientation(heavy, physicsClientId=c)[0][2]
    v = max(float(np.abs(np.array(p.getBaseVelocity(b, physicsClientId=c)[0])).max()) for b in (light, heavy))
    p.disconnect(physicsClientId=c)
    return 0.2 - (zh - zl), 0.1 - zl, v, us


def run_mujoco(M, dt):
    import mujoco

    xml = f"""<mujoco><option timestep="{dt!r}" gravity="0 0 -9.81"/><worldbody>
      <geom type="plane" size="5 5 0.1"/>
      <body name="light" pos="0 0 0.1"><freejoint/><geom type="box" size="0.1 0.1 0.1" mass="1"/></body>
      <body name="heavy" pos="0 0 0.3"><freejoint/><geom type="box" size="0.1 0.1 0.1" mass="{M!r}"/></body>
    </worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    n = int(round(SECONDS / dt))
    for _ in range(int(round(1.0 / dt))):
        mujoco.mj_step(m, d)
    us = _timed(lambda: mujoco.mj_step(m, d))
    for _ in range(n - int(round(1.0 / dt)) - 200):
        mujoco.mj_step(m, d)
    zl, zh = d.qpos[2], d.qpos[9]
    return 0.2 - (zh - zl), 0.1 - zl, float(np.abs(d.qvel).max()), us


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="also write the table to this Markdown file")
    args = ap.parse_args()
    run_tumble(10.0, 1.0 / 60.0)  # compilation apart
    rows = ["| dt s | M / m | engine | heavy into light mm | light into ground mm | largest speed at 6 s m/s "
            "| us/step |", "|---|---|---|---:|---:|---:|---:|"]
    for dt in STEPS:
        for M in RATIOS:
            for name, fn in (("tumble (default)", lambda: run_tumble(M, dt, stiffen=False)),
                             ("tumble, loaded contacts stiffened", lambda: run_tumble(M, dt)),
                             ("PyBullet", lambda: run_pybullet(M, dt)), ("MuJoCo", lambda: run_mujoco(M, dt))):
                o, g, v, us = fn()
                rows.append(f"| 1/{round(1 / dt)} | {M:g} | {name} | {o * 1e3:.2f} | {g * 1e3:.2f} | {v:.1e} "
                            f"| {us:.1f} |")
                print(rows[-1], flush=True)
    if args.out:
        with open(args.out, "w") as f:
            f.write("\n".join(rows) + "\n")


if __name__ == "__main__":
    main()
