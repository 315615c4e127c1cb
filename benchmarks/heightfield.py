"""heightfield: balls rolling on a large heightfield, tumble and MuJoCo (its native hfield) side by side.

Scene: a 129 x 129 grid over 20 x 20 m (32 768 triangles in tumble), heights
0.3 sin(x / 1.7) cos(y / 2.3) + 0.002 (x^2 + y^2) (a rippled bowl); N balls (radius 0.1 m, 1 kg)
dropped from 1 m above it on a grid 8 x 8 m around the middle; friction 0.8; gravity; 4 s.
tumble: the default step (dt 1/240 s, 4 contact substeps); MuJoCo 4.0: its hfield with the same
heights (``size = (10, 10, top, base)``, elevations scaled to [0, 1]), Euler at dt 1/240 s, its
default solver, contacts with the hfield only.

Times: wall time per step over the whole run, median of ``--repeats`` runs after a warm-up run
(compilation apart). Quality beside it: the deepest ball below the surface at the end (tumble: a
ray cast down from each centre, against its radius; MuJoCo: its deepest contact's distance) and
the fastest ball at the end.

    PYTHONPATH=src python benchmarks/heightfield.py --balls 100 --repeats 3
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import time

import numpy as np

GRID, SIZE, RADIUS, DURATION, DT = 129, 20.0, 0.1, 4.0, 1 / 240


def heights():
    c = (np.arange(GRID) / (GRID - 1) - 0.5) * SIZE
    x, y = np.meshgrid(c, c)
    return 0.3 * np.sin(x / 1.7) * np.cos(y / 2.3) + 0.002 * (x * x + y * y)


def starts(n):
    k = int(np.ceil(np.sqrt(n)))
    c = (np.arange(k) / max(k - 1, 1) - 0.5) * 8.0
    x, y = np.meshgrid(c, c)
    return np.column_stack([x.ravel(), y.ravel()])[:n]


def run_tumble(n):
    import tumble as tb

    H = heights()
    world = tb.World(gravity=(0, 0, -9.81))
    world.add_body(tb.heightfield(H, (SIZE, SIZE)), fixed=True, material={"friction": 0.8})
    for x, y in starts(n):
        world.add_body(tb.Sphere(RADIUS), mass=1.0, position=(x, y, float(H.max()) + 1.0), material={"friction": 0.8})
    sim = tb.Simulator(world, dt=DT)
    steps = int(round(DURATION / DT))
    t0 = time.perf_counter()
    sim.step(steps)
    per_step = (time.perf_counter() - t0) / steps
    down = world.ray_cast(origin=world.x[1:], direction=np.tile((0.0, 0.0, -1.0), (n, 1)),
                          exclude=np.arange(1, n + 1))
    depth = float(np.max(RADIUS - down.distance))
    return per_step, depth, float(np.linalg.norm(world.v[1:], axis=1).max())


def run_mujoco(n):
    import mujoco

    H = heights()
    lo, hi = float(H.min()), float(H.max())
    balls = "".join(f'<body pos="{x} {y} {hi + 1.0}"><freejoint/><geom type="sphere" size="{RADIUS}" mass="1" '
                    f'friction="0.8 0.005 0.0001"/></body>' for x, y in starts(n))
    xml = f"""<mujoco><option timestep="{DT}" integrator="Euler"/>
      <asset><hfield name="h" nrow="{GRID}" ncol="{GRID}" size="{SIZE / 2} {SIZE / 2} {hi - lo} 0.5"/></asset>
      <worldbody><geom type="hfield" hfield="h" pos="0 0 {lo}" friction="0.8 0.005 0.0001"/>{balls}</worldbody>
    </mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    # MuJoCo's rows run along y from -y to +y, as tumble's; elevations scaled to [0, 1] of size[2]
    model.hfield_data[:] = ((H - lo) / (hi - lo)).ravel()
    data = mujoco.MjData(model)
    steps = int(round(DURATION / DT))
    t0 = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    per_step = (time.perf_counter() - t0) / steps
    depth = float(max([-data.contact[i].dist for i in range(data.ncon)] + [0.0]))
    speed = float(np.max(np.linalg.norm(data.qvel.reshape(n, 6)[:, :3], axis=1)))
    return per_step, depth, speed


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--balls", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    git = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                         cwd=os.path.dirname(__file__)).stdout.strip()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, tumble git {git}; "
          f"{GRID} x {GRID} heightfield, {args.balls} balls, {DURATION:g} s at dt 1/240 s, median of {args.repeats}\n")
    print("| engine | ms/step | deepest below the surface at the end (m) | fastest ball at the end (m/s) |")
    print("|---|---|---|---|")
    for name, run in (("tumble", run_tumble), ("mujoco", run_mujoco)):
        run(args.balls)  # warm-up: compilation
        results = [run(args.balls) for _ in range(args.repeats)]
        per_step = statistics.median(r[0] for r in results)
        _, depth, speed = results[-1]
        print(f"| {name} | {1e3 * per_step:.2f} | {depth:.1e} | {speed:.3f} |")


if __name__ == "__main__":
    main()
