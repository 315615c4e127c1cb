"""Speculative ghosts (collision/speculative.py, docs/contact.md "Speculative ghosts"): quality and
cost, with PyBullet and MuJoCo on the same scenes.

    python benchmarks/speculative_ghosts.py [--blocks 5]

Scenes (tests/physics/test_speculative_ghosts.py's):

- ``box_edge``: a ball (r 5 cm, 1 kg) sliding at 10 m/s along x, its bottom 2 mm above the top
  face of a fixed 0.5 x 0.5 x 0.2 m box it crosses, no gravity, frictionless, e = 0, dt 1/240 s,
  30 steps. Quality: its velocity at the end (it never touches the box: (10, 0, 0) exactly).
- ``ripples``: the same ball at 10 m/s over a 4 x 0.2 m heightfield of 4 mm cells rippled
  3 sin(2 pi x / 0.2 m) mm, gravity, frictionless, e = 0, dt 1/240 s, 0.34 s. Quality: its
  highest rise above the surface (a frictionless inelastic contact bounds it at 51 mm).
- ``rolling``: the same heightfield, the ball at 1 m/s (it stays on the surface in every engine:
  the time of a ball's contact with a fine heightfield, where ``ripples`` times flights too).
- ``pile``: examples/pile.toml's 1000 boxes (dt 1/60 s), the first second: the stage's cost where
  it does nothing (box-box pairs are left out; box-plane has no edge).
- ``terrain``: examples/terrain.toml (12 balls and 2 capsules on a 25 x 25 heightfield), 4 s.

tumble runs each scene with the stage and with it replaced by a stub (``off``: the code before,
to the bit), alternating in one process after a warm-up (compilation apart); time per step is
the median of ``--blocks`` runs, each timed from its second step (the first builds the shape
table: a heightfield's tree and edge flags; the peers' first step is left out the same way). PyBullet (``p.stepSimulation``, its default contact settings)
and MuJoCo (``mj_step``, default Euler, condim 1) run the box_edge and ripples scenes with the
same shapes, masses, step and speeds: PyBullet's heightfield (GEOM_HEIGHTFIELD) and MuJoCo's
hfield of the same heights.
"""
from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import time

import numpy as np

import tumble as tb
import tumble.collision.pipeline as pipeline
from tumble.scene import load_scene

HERE = os.path.dirname(os.path.abspath(__file__))
EXAMPLES = os.path.join(HERE, "..", "examples")
R, SPEED, DT = 0.05, 10.0, 1.0 / 240.0
A, WAVE, CELL, LENGTH, WIDTH = 0.003, 0.2, 0.004, 4.0, 0.2
RIPPLE_STEPS = int((LENGTH - 0.6) / SPEED / DT)
FRICTIONLESS = tb.Material(friction=0.0, restitution=0.0)

_stage = pipeline.delay_speculative_ghosts


def _off(contacts, *args, **kwargs):
    contacts.allowance_count = 0
    return 0


def stage(on: bool):
    pipeline.delay_speculative_ghosts = _stage if on else _off


def heights():
    nx = int(round(LENGTH / CELL)) + 1
    ny = int(round(WIDTH / CELL)) + 1
    xs = np.linspace(-LENGTH / 2, LENGTH / 2, nx)
    return xs, np.tile(A * np.sin(2.0 * math.pi * xs / WAVE), (ny, 1))


def surface(x):
    return A * math.sin(2.0 * math.pi * x / WAVE)


# ---------------------------------------------------------------------- tumble
def tumble_box_edge():
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    w.sleeping = False
    w.add_body(tb.Box((0.5, 0.5, 0.2)), fixed=True, material=FRICTIONLESS)
    b = w.add_body(tb.Sphere(R), mass=1.0, position=(-0.4, 0.0, 0.1 + R + 0.002), velocity=(SPEED, 0.0, 0.0),
                   material=FRICTIONLESS)
    return tb.Simulator(w, dt=DT), b, 30


def tumble_ripples(speed=SPEED):
    _, H = heights()
    w = tb.World(gravity=(0.0, 0.0, -9.81))
    w.sleeping = False
    w.add_body(tb.heightfield(H, (LENGTH, WIDTH), base=0.05), fixed=True, material=FRICTIONLESS)
    b = w.add_body(tb.Sphere(R), mass=1.0, position=(-LENGTH / 2 + 0.3, 0.0, R + A + 0.001),
                   velocity=(speed, 0.0, 0.0), material=FRICTIONLESS)
    return tb.Simulator(w, dt=DT), b, RIPPLE_STEPS


def tumble_example(name, seconds):
    scene = load_scene(os.path.join(EXAMPLES, f"{name}.toml"))
    sim = scene.simulator()
    return sim, None, int(round(seconds / sim.dt))


def run_tumble(make, on: bool):
    """(seconds per step, quality) of one run of a freshly made scene."""
    stage(on)
    sim, ball, steps = make()
    rise = 0.0
    sim.step()  # the first step builds the shape table (a heightfield's tree and edge flags): apart
    t0 = time.perf_counter()
    if ball is None:
        sim.step(steps - 1)
    else:
        for _ in range(steps - 1):
            sim.step()
            rise = max(rise, float(ball.x[2]) - R - surface(float(ball.x[0])))
    elapsed = time.perf_counter() - t0
    stage(True)
    quality = None if ball is None else (np.array(ball.v), rise)
    return elapsed / (steps - 1), quality


# ---------------------------------------------------------------------- peers
def pybullet_scene(name, speed=SPEED):
    import pybullet as p
    cid = p.connect(p.DIRECT)
    p.setTimeStep(DT, physicsClientId=cid)
    if name == "box_edge":
        p.setGravity(0, 0, 0, physicsClientId=cid)
        box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.25, 0.25, 0.1], physicsClientId=cid)
        ground = p.createMultiBody(0, box, basePosition=[0, 0, 0], physicsClientId=cid)
        start, steps = [-0.4, 0, 0.1 + R + 0.002], 30
    else:
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        xs, H = heights()
        ny, nx = H.shape
        # PyBullet's heightfield: data row-major with x fastest, centred at the middle of its height range
        shape = p.createCollisionShape(p.GEOM_HEIGHTFIELD, meshScale=[CELL, CELL, 1.0],
                                       heightfieldData=H.ravel().tolist(), numHeightfieldRows=nx,
                                       numHeightfieldColumns=ny, physicsClientId=cid)
        ground = p.createMultiBody(0, shape, basePosition=[0, 0, 0.5 * (H.min() + H.max())], physicsClientId=cid)
        start, steps = [-LENGTH / 2 + 0.3, 0, R + A + 0.001], RIPPLE_STEPS
    sphere = p.createCollisionShape(p.GEOM_SPHERE, radius=R, physicsClientId=cid)
    ball = p.createMultiBody(1.0, sphere, basePosition=start, physicsClientId=cid)
    for body in (ground, ball):
        p.changeDynamics(body, -1, lateralFriction=0.0, restitution=0.0, rollingFriction=0.0, spinningFriction=0.0,
                         linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)
    p.resetBaseVelocity(ball, [speed, 0, 0], [0, 0, 0], physicsClientId=cid)

    def step():
        p.stepSimulation(physicsClientId=cid)
        x, _ = p.getBasePositionAndOrientation(ball, physicsClientId=cid)
        v, _ = p.getBaseVelocity(ball, physicsClientId=cid)
        return np.array(x), np.array(v)
    return step, steps, lambda: p.disconnect(cid)


def mujoco_scene(name, speed=SPEED):
    import mujoco
    if name == "box_edge":
        xml = f"""<mujoco><option timestep="{DT}" gravity="0 0 0"/><worldbody>
<geom type="box" size="0.25 0.25 0.1" condim="1" friction="0 0 0"/>
<body pos="-0.4 0 {0.1 + R + 0.002}"><freejoint/><geom type="sphere" size="{R}" mass="1" condim="1" friction="0 0 0"/></body>
</worldbody></mujoco>"""
        steps = 30
    else:
        xs, H = heights()
        ny, nx = H.shape
        xml = f"""<mujoco><option timestep="{DT}"/><asset>
<hfield name="h" nrow="{ny}" ncol="{nx}" size="{LENGTH / 2} {WIDTH / 2} {2 * A} 0.05"/></asset><worldbody>
<geom type="hfield" hfield="h" pos="0 0 {-A}" condim="1" friction="0 0 0"/>
<body pos="{-LENGTH / 2 + 0.3} 0 {R + A + 0.001}"><freejoint/><geom type="sphere" size="{R}" mass="1" condim="1" friction="0 0 0"/></body>
</worldbody></mujoco>"""
        steps = RIPPLE_STEPS
    model = mujoco.MjModel.from_xml_string(xml)
    if name != "box_edge":
        model.hfield_data[:] = ((H + A) / (2 * A)).ravel()  # elevation in [0, 1] of the size's top, rows along y
    data = mujoco.MjData(model)
    data.qvel[0] = speed

    def step():
        mujoco.mj_step(model, data)
        return data.qpos[:3].copy(), data.qvel[:3].copy()
    return step, steps, lambda: None


def run_peer(factory, name):
    step, steps, close = factory("ripples" if name == "rolling" else name, 1.0 if name == "rolling" else SPEED)
    rise = 0.0
    step()  # as tumble's: the first step apart
    t0 = time.perf_counter()
    for _ in range(steps - 1):
        x, v = step()
        if name != "box_edge":
            rise = max(rise, float(x[2]) - R - surface(float(x[0])))
    elapsed = time.perf_counter() - t0
    close()
    return elapsed / (steps - 1), (v, rise)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--blocks", type=int, default=5)
    args = ap.parse_args()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
          f"NUMBA_NUM_THREADS={os.environ.get('NUMBA_NUM_THREADS', 'default')}")
    cases = {"box_edge": tumble_box_edge, "ripples": tumble_ripples, "rolling": lambda: tumble_ripples(1.0),
             "pile": lambda: tumble_example("pile", 1.0), "terrain": lambda: tumble_example("terrain", 4.0)}
    print("| scene | run | us/step (median) | quality |")
    print("|---|---|---:|---|")
    for name, make in cases.items():
        run_tumble(make, True)  # warm-up: compilation apart
        run_tumble(make, False)
        times = {True: [], False: []}
        quality = {}
        for _ in range(args.blocks):
            for on in (True, False):
                t, q = run_tumble(make, on)
                times[on].append(t)
                quality[on] = q
        for on in (False, True):
            q = quality[on]
            text = "" if q is None else f"v end {np.round(q[0], 3).tolist()}" + (
                "" if name == "box_edge" else f", rise {q[1] * 1000:.1f} mm")
            print(f"| {name} | tumble {'stage' if on else 'off'} | {statistics.median(times[on]) * 1e6:.1f} | {text} |")
        if name in ("box_edge", "ripples", "rolling"):
            for peer, factory in (("PyBullet", pybullet_scene), ("MuJoCo", mujoco_scene)):
                runs = [run_peer(factory, name) for _ in range(args.blocks)]
                t = statistics.median(r[0] for r in runs)
                v, rise = runs[-1][1]
                text = "" if name == "box_edge" else f", rise {rise * 1000:.1f} mm"
                print(f"| {name} | {peer} | {t * 1e6:.1f} | v end {np.round(v, 3).tolist()}{text} |")


if __name__ == "__main__":
    main()
