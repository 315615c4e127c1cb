"""buoyancy: the cost of ``tb.Buoyancy`` per step, on crates (boxes: 12 triangles each), barrels
(cylinders: a 192-segment tessellation, 768 triangles) and balls (the cap's closed form) floating in
water, against the same bodies in free fall with ``tb.Drag`` only (no contact: the bodies are apart).

Scene: N bodies on a grid 1.5 m apart, half under a surface at z = 0 (density 500 in water), drag;
2 s at dt 1/240 s. Times: wall time per step, median of ``--repeats`` runs after a warm-up run
(compilation apart), and the buoyancy kernel's own time per body (``apply_buoyancy`` alone). No peer
engine on PyPI has a fluid surface (MuJoCo's ``density`` option immerses the whole world).

    PYTHONPATH=src python benchmarks/buoyancy.py --bodies 100 1000 --repeats 3
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import time

import numpy as np

DT, DURATION = 1 / 240, 2.0
SHAPES = {"crate": lambda tb: tb.Box((0.6, 0.6, 0.6)), "barrel": lambda tb: tb.Cylinder(0.3, 0.9),
          "ball": lambda tb: tb.Sphere(0.3)}


def world(n, kind, floating):
    import tumble as tb

    w = tb.World(gravity=(0, 0, -9.81))
    if floating:
        w.add_force(tb.Buoyancy(density=1000.0, linear=50.0, angular_linear=5.0))
    else:
        w.add_force(tb.Drag(linear=50.0, angular_linear=5.0))
    w.collisions = False
    k = int(np.ceil(np.sqrt(n)))
    for j in range(n):
        w.add_body(SHAPES[kind](tb), density=500.0, position=(1.5 * (j % k), 1.5 * (j // k), 0.05),
                   euler_deg=(10, 5, 0))
    return w


def per_step(n, kind, floating, repeats):
    import tumble as tb

    out = []
    for r in range(repeats + 1):  # the first a warm-up
        w = world(n, kind, floating)
        sim = tb.Simulator(w, dt=DT)
        steps = int(round(DURATION / DT))
        t0 = time.perf_counter()
        sim.step(steps)
        if r:
            out.append((time.perf_counter() - t0) / steps)
    return statistics.median(out)


def kernel_time(n, kind, repeats):
    from tumble.buoyancy import apply_buoyancy

    w = world(n, kind, True)
    Y = w.pack()
    apply_buoyancy(w, Y, DT)  # the geometry and the compilation
    times = []
    for _ in range(max(repeats, 5)):
        t0 = time.perf_counter()
        apply_buoyancy(w, Y, DT)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bodies", type=int, nargs="+", default=[100, 1000])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    git = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    print(f"buoyancy: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, Python "
          f"{platform.python_version()}, tumble at git {git}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    print("\n| bodies | shape | drag only (ms/step) | buoyancy (ms/step) | buoyancy kernel (us/body) |")
    print("|---|---|---|---|---|")
    for n in args.bodies:
        for kind in SHAPES:
            dry = per_step(n, kind, False, args.repeats)
            wet = per_step(n, kind, True, args.repeats)
            k = kernel_time(n, kind, args.repeats)
            print(f"| {n} | {kind} | {dry * 1e3:.3f} | {wet * 1e3:.3f} | {k / n * 1e6:.2f} |", flush=True)


if __name__ == "__main__":
    main()
