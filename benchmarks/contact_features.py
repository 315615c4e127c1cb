"""What collision filters, rolling resistance, contact events and kinematic bodies cost when
they are used, in one process.

Each case runs a scene twice, interleaved round by round, with the feature off and on, in the
same process (same compiled kernels, the same minutes of the machine), and reports the minima
of the step times (ms a step, over ``--steps`` steps after ``--warm`` warm-up steps):

- ``filters``: Box3D's large_pyramid (5050 cubes, 1/60 s, 4 substeps, 1 thread) with the
  default filters (the narrowphase skips the test) and with every body given a filter that
  allows every pair (category 1, mask 0xFFFF: the test runs on every candidate, the contacts
  and the bits are the same);
- ``events``: the same pyramid with contact events off and on (the touching pairs of 59 800
  contacts sorted every step);
- ``rolling``: 1000 balls (radius 5 cm) dropped on a 10 x 10 x 10 grid onto the ground, 1/240 s
  with the default 4 substeps, with rolling resistance 0 and 0.05 (and spinning friction
  0.001 m): every ball contact gets three rows.
- ``sensor``: the large pyramid with a sensor box over its top third (every step, the overlaps of
  its ~560 boxes: bounds, a NumPy box test and the narrowphase on the pairs that meet);
- ``kinematic``: 400 boxes (10 cm, a 10 x 10 x 4 grid) dropped on a 3 m slab, fixed, or
  kinematic and moving at 0.2 m/s (a conveyor: the slab moves in the substeps, its velocity is
  felt by every contact with it, its passengers are kept awake).

Usage: ``python benchmarks/contact_features.py [--case filters|events|rolling|kinematic|sensor|all] [--rounds 3]``;
prints one markdown table (the figures in docs/benchmarks.md).
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import time

import numpy as np


def _git():
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              cwd=os.path.dirname(__file__)).stdout.strip()
    except OSError:
        return "?"


def _pyramid(filtered: bool, events: bool = False):
    import tumble as tb
    from tumble.scenes import contact as C
    from tumble.solver.contact import SoftStepSettings

    world, settings = C.build("large_pyramid")
    if filtered:
        for body in world.bodies:
            body.collision_filter = tb.CollisionFilter(category=1, mask=0xFFFF)
    return tb.Simulator(world, dt=settings["dt"], integrator="semi-implicit-euler",
                        contact_settings=SoftStepSettings(substeps=4), contact_events=events)


def _pyramid_sensor(sensor: bool):
    """large_pyramid, with or without a sensor box over its top third (~560 boxes in it)."""
    import tumble as tb

    sim = _pyramid(False)
    if sensor:
        world = sim.world
        top = float(world.x[:, 2].max())
        sim.world.add_body(tb.Box((20.0, 20.0, top / 3)), fixed=True, sensor=True,
                           position=(0.0, 0.0, top - top / 6))
        sim = type(sim)(world, dt=sim.dt, integrator=sim.integrator, contact_settings=sim.contact_settings)
    return sim


def _balls(rolling: bool):
    import tumble as tb

    world = tb.World(gravity=(0.0, 0.0, -9.81))
    world.add_body(tb.Plane(), fixed=True)
    material = tb.Material(friction=0.5, rolling_resistance=0.05 if rolling else 0.0,
                           spinning_friction=0.001 if rolling else 0.0)
    rng = np.random.default_rng(0)
    for i in range(10):
        for j in range(10):
            for k in range(10):
                pos = (0.12 * i - 0.54, 0.12 * j - 0.54, 0.06 + 0.12 * k) + rng.uniform(-0.005, 0.005, 3)
                world.add_body(tb.Sphere(0.05), mass=0.1, position=pos, material=material)
    world.sleeping = False
    return tb.Simulator(world, dt=1.0 / 240.0)


def _conveyor(kinematic: bool):
    import tumble as tb

    world = tb.World(gravity=(0.0, 0.0, -9.81))
    material = tb.Material(friction=0.6)
    slab = dict(kinematic=True, velocity=(0.2, 0.0, 0.0)) if kinematic else dict(fixed=True)
    world.add_body(tb.Box((3.0, 3.0, 0.2)), position=(0.0, 0.0, -0.1), material=material, **slab)
    rng = np.random.default_rng(0)
    for i in range(10):
        for j in range(10):
            for k in range(4):
                pos = (0.15 * i - 0.675, 0.15 * j - 0.675, 0.05 + 0.12 * k) + rng.uniform(-0.005, 0.005, 3)
                world.add_body(tb.Box((0.1, 0.1, 0.1)), mass=0.1, position=pos, material=material)
    return tb.Simulator(world, dt=1.0 / 240.0)


CASES = {"filters": (_pyramid, "large_pyramid, 5050 cubes, 1/60 s x 4, 1 thread", "default filters",
                     "a filter on every body"),
         "events": (lambda on: _pyramid(False, events=on), "large_pyramid, 5050 cubes, 1/60 s x 4, 1 thread",
                    "contact events off", "contact events on"),
         "rolling": (_balls, "1000 balls dropped on the ground, 1/240 s x 4, 1 thread", "rolling resistance 0",
                     "rolling resistance 0.05, spinning friction 0.001 m"),
         "sensor": (_pyramid_sensor, "large_pyramid, 5050 cubes, 1/60 s x 4, 1 thread", "no sensor",
                    "a sensor box over the top third of the pyramid"),
         "kinematic": (_conveyor, "400 boxes dropped on a slab, 1/240 s x 4, 1 thread", "fixed slab",
                       "kinematic slab moving at 0.2 m/s")}


def _step_minimum(sim, warm: int, steps: int) -> float:
    sim.step(warm)
    best = np.inf
    for _ in range(steps):
        t0 = time.perf_counter()
        sim.step(1)
        best = min(best, time.perf_counter() - t0)
    return best * 1e3


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", choices=[*CASES, "all"], default="all")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--warm", type=int, default=30)
    parser.add_argument("--steps", type=int, default=40)
    args = parser.parse_args()
    import numba

    numba.set_num_threads(1)
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, tumble git {_git()}, "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; step minima in ms over {args.steps} steps "
          f"after {args.warm}, rounds interleaved\n")
    print("| scene | off | on | off, per round | on, per round | on / off |")
    print("|---|---|---|---|---|---|")
    for name in (CASES if args.case == "all" else [args.case]):
        build, scene, off_label, on_label = CASES[name]
        for flag in (False, True):  # compile both paths before timing
            build(flag).step(2)
        off, on = [], []
        for _ in range(args.rounds):
            off.append(_step_minimum(build(False), args.warm, args.steps))
            on.append(_step_minimum(build(True), args.warm, args.steps))
        print(f"| {scene}: {off_label} / {on_label} | {min(off):.2f} | {min(on):.2f} | "
              f"{', '.join(f'{t:.2f}' for t in off)} | {', '.join(f'{t:.2f}' for t in on)} | "
              f"{min(on) / min(off):.3f} |")


if __name__ == "__main__":
    main()
