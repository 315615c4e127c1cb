"""Impacts through touching chains: five touching steel balls (radius 0.05 m, 1 kg, restitution 1,
no friction), the first thrown at them at 3 m/s, no gravity, dt 1/240 s, run 0.25 s; in tumble (by
default, and with ``SoftStepSettings(impact_chains=False)``: the restitution pass alone), PyBullet
and MuJoCo. Quality: each ball's speed at the end (a Newton's cradle leaves 0, 0, 0, 0, 3 m/s), the
momentum and the kinetic energy against the start's. Time: a whole run of the hung cradle (five
balls on hinges, the first lifted 30 degrees, 1.2 s at dt 1/240 s; tests/physics/test_impact_chain.py's)
in tumble with and without, the medians of 7 alternated runs after a warm-up.

    python benchmarks/touching_cradle.py [--out benchmarks/results/touching_cradle.md]

PyBullet: its default solver (sequential impulses), restitution 1 on every ball, no friction, no
damping, the restitution threshold at 1 m/s (tumble's and Box2D's; PyBullet's default is 1e-3
m/s). MuJoCo: elastic contacts by its direct solref (-stiffness, -damping) = (-1e4, 0): 100 rad/s, the contact lasting 31 ms, 7.5 steps, where 1e6 blew up at this dt (MuJoCo has no
coefficient of restitution: a stiff undamped spring is the way its documentation gives to bounce),
no friction (condim 1), its default solver.
"""
from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

V, R, N, DT, SECONDS = 3.0, 0.05, 5, 1.0 / 240.0, 0.25


def start_x():
    """The balls' x (m): the first 0.2 m before the touching row."""
    return [-0.3] + [i * 2 * R for i in range(N - 1)]


def run_tumble(chains=True):
    import tumble as tb
    from tumble.solver.contact import SoftStepSettings

    w = tb.World(gravity=(0, 0, 0))
    mat = tb.Material(friction=0.0, restitution=1.0)
    for i, x in enumerate(start_x()):
        w.add_body(tb.Sphere(radius=R), mass=1.0, position=(x, 0, 0), velocity=(V if i == 0 else 0.0, 0, 0),
                   material=mat)
    tb.Simulator(w, dt=DT, contact_settings=SoftStepSettings(impact_chains=chains)).run(SECONDS, 24, progress=False)
    return w.v[:, 0].copy()


def run_pybullet():
    import pybullet as p

    c = p.connect(p.DIRECT)
    p.setGravity(0, 0, 0, physicsClientId=c)
    p.setTimeStep(DT, physicsClientId=c)
    p.setPhysicsEngineParameter(restitutionVelocityThreshold=1.0, physicsClientId=c)
    shape = p.createCollisionShape(p.GEOM_SPHERE, radius=R, physicsClientId=c)
    ids = []
    for i, x in enumerate(start_x()):
        b = p.createMultiBody(1.0, shape, basePosition=(x, 0, 0), physicsClientId=c)
        p.changeDynamics(b, -1, restitution=1.0, lateralFriction=0.0, rollingFriction=0.0, spinningFriction=0.0,
                         linearDamping=0.0, angularDamping=0.0, physicsClientId=c)
        if i == 0:
            p.resetBaseVelocity(b, (V, 0, 0), (0, 0, 0), physicsClientId=c)
        ids.append(b)
    for _ in range(int(round(SECONDS / DT))):
        p.stepSimulation(physicsClientId=c)
    v = np.array([p.getBaseVelocity(b, physicsClientId=c)[0][0] for b in ids])
    p.disconnect(c)
    return v


def run_mujoco():
    import mujoco

    balls = "".join(
        f'<body pos="{x} 0 0"><freejoint/><geom type="sphere" size="{R}" mass="1" condim="1" '
        f'solref="-10000 0"/></body>' for x in start_x())
    xml = (f'<mujoco><option timestep="{DT}" gravity="0 0 0"/><worldbody>{balls}</worldbody></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qvel[0] = V
    mujoco.mj_step(m, d, nstep=int(round(SECONDS / DT)))
    return np.array([d.qvel[6 * i] for i in range(N)])


def hung_run_seconds(repeats=7):
    """(with, without) s: the medians of ``repeats`` runs each of the hung cradle (1.2 s) with and
    without impact chains, alternated after a warm-up of each."""
    import tumble as tb
    from tumble.solver.contact import SoftStepSettings

    def once(chains):
        w = tb.World(gravity=(0, 0, -9.81))
        mat = tb.Material(friction=0.0, restitution=1.0)
        th = math.radians(30.0)
        for i in range(N):
            x0 = i * 2 * R
            pos = (x0 - math.sin(th), 0, 1 - math.cos(th)) if i == 0 else (x0, 0, 0)
            w.add_body(tb.Sphere(radius=R), mass=1.0, position=pos, material=mat, name=f"ball{i}")
            w.add_joint(tb.HingeJoint(f"ball{i}", None, anchor=(x0, 0, 1.0), axis=(0, 1, 0)))
        sim = tb.Simulator(w, contact_settings=SoftStepSettings(impact_chains=chains))
        t = time.perf_counter()
        sim.run(1.2, 240, progress=False)
        return time.perf_counter() - t

    once(True), once(False)
    times = {True: [], False: []}
    for _ in range(repeats):
        for chains in (True, False):
            times[chains].append(once(chains))
    return statistics.median(times[True]), statistics.median(times[False])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/results/touching_cradle.md")
    args = ap.parse_args(argv)
    rows = []
    for name, run in (("tumble", run_tumble), ("tumble, impact_chains=False", lambda: run_tumble(False)),
                      ("PyBullet", run_pybullet), ("MuJoCo", run_mujoco)):
        try:
            v = run()
        except ImportError as exc:
            rows.append(f"| {name} | not installed ({exc}) | | |")
            continue
        rows.append(f"| {name} | {', '.join(f'{x:.3f}' for x in v)} | {v.sum() / V:.6f} | {(v ** 2).sum() / V ** 2:.4f} |")
    on, off = hung_run_seconds()
    text = "\n".join([
        "# Touching cradle (benchmarks/touching_cradle.py)", "",
        f"Five touching balls, the first at {V} m/s, no gravity, dt 1/240 s, {SECONDS} s. A cradle leaves "
        "0, 0, 0, 0, 3 m/s.", "",
        "| engine | speeds at the end, m/s | momentum / start | energy / start |", "|---|---|---|---|", *rows, "",
        f"The hung cradle (1.2 s at dt 1/240 s, 288 steps), medians of 7 alternated runs: {on * 1e3:.1f} ms with impact chains, "
        f"{off * 1e3:.1f} ms without.", ""])
    with open(args.out, "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main()
