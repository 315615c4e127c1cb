"""The substep loop in one compiled call (``soft_step.substeps_kernel``) against the stage loop
(``SoftStep.fuse = False``: the same kernels called one by one from Python), same process,
same scenes, the same bits (the state hashes are printed side by side).

- Example scenes run whole (``Scene.run`` without progress), best of 3 after a warm run.
- Gym's ant with its free joint standing on the floor (benchmarks/mjcf_models.py), 2 s at dt
  1/240, us per step, median of 3.
- Box3D's large pyramid at its step (1/60 s, 4 substeps), 20 steps, ms per step, median of 3:
  its 60 000 contacts are solved in slabs on both cores inside the fused call as well.

    PYTHONPATH=src python benchmarks/fused_substeps.py [--out benchmarks/results/fused_substeps.md]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))

import tumble as tb  # noqa: E402
from report import emit, machine_line  # noqa: E402
from tumble.solver import soft_step  # noqa: E402

EXAMPLES = ("dice", "dominoes", "bowling", "marbles", "platforms", "robot_arm", "joints/ragdoll_stairs",
            "joints/chain_over_box", "mjcf_turntable")


def digest(world) -> str:
    return hashlib.sha256(world.pack().tobytes()).hexdigest()[:16]


def example_row(name, fuse):
    soft_step.SoftStep.fuse = fuse
    path = f"examples/{name}.toml"
    warm = tb.load_scene(path)
    warm.simulator().step(int(round(float(warm.duration) / warm.dt)))  # compile and cache
    best, steps, h = float("inf"), 0, ""
    for _ in range(3):
        scene = tb.load_scene(path)
        sim = scene.simulator()
        n = int(round(float(scene.duration) / sim.dt))
        t0 = time.perf_counter()
        sim.step(n)
        best = min(best, time.perf_counter() - t0)
        steps, h = n, digest(scene.world)
    return best, steps, h


def ant_row(fuse):
    from mjcf_models import free_ant_file, in_range_start

    soft_step.SoftStep.fuse = fuse
    path = free_ant_file()
    out = []
    for _ in range(3):
        world = tb.World(gravity=(0, 0, -9.81))
        tb.load_mjcf(world, path, joint_positions=in_range_start("ant.xml"))
        sim = tb.Simulator(world, dt=1 / 240)
        sim.step(1)
        t0 = time.perf_counter()
        sim.step(479)
        out.append((time.perf_counter() - t0) / 479)
    return statistics.median(out), digest(world)


def pyramid_row(fuse):
    from tumble.scenes.contact import large_pyramid

    soft_step.SoftStep.fuse = fuse
    out = []
    for _ in range(3):
        world, settings = large_pyramid()
        sim = tb.Simulator(world, dt=1 / 60, contact_settings=soft_step.C.SoftStepSettings(substeps=4))
        sim.step(2)
        t0 = time.perf_counter()
        sim.step(20)
        out.append((time.perf_counter() - t0) / 20)
    return statistics.median(out), digest(world)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None)
    ap.add_argument("--no-pyramid", action="store_true")
    args = ap.parse_args()
    lines = [machine_line(), "",
             "| scene | steps | stage loop | one call | faster | same bits |", "|---|---|---|---|---|---|"]
    for name in EXAMPLES:
        loop, steps, h0 = example_row(name, False)
        fused, _, h1 = example_row(name, True)
        lines.append(f"| {name} (whole run) | {steps} | {loop * 1e6 / steps:.0f} us/step | {fused * 1e6 / steps:.0f} us/step "
                     f"| {loop / fused:.2f}x | {'yes' if h0 == h1 else 'NO'} ({h1}) |")
        print(lines[-1], flush=True)
    loop, h0 = ant_row(False)
    fused, h1 = ant_row(True)
    lines.append(f"| ant_free.xml standing | 479 | {loop * 1e6:.0f} us/step | {fused * 1e6:.0f} us/step | "
                 f"{loop / fused:.2f}x | {'yes' if h0 == h1 else 'NO'} ({h1}) |")
    print(lines[-1], flush=True)
    if not args.no_pyramid:
        loop, h0 = pyramid_row(False)
        fused, h1 = pyramid_row(True)
        lines.append(f"| large_pyramid (1/60 s, 4 substeps) | 20 | {loop * 1e3:.1f} ms/step | {fused * 1e3:.1f} ms/step | "
                     f"{loop / fused:.2f}x | {'yes' if h0 == h1 else 'NO'} ({h1}) |")
        print(lines[-1], flush=True)
    soft_step.SoftStep.fuse = True
    emit(lines, args.out)


if __name__ == "__main__":
    main()
