"""Box3D's convex_pile in tumble, beside Box3D's figure measured on this machine kind (BENCHMARKS.md).

5120 copies of one 32-point convex hull (radius 2 m) fall from an 8 x 8 x 80 grid into a pile
(``tumble.scenes.contact.convex_pile``), stepped at Box3D's step (dt 1/60 s, 4 solver substeps,
semi-implicit Euler in flight), sleeping on as in Box3D's scene. Timed: ``--steps`` steps (Box3D
times 500) after the first, whose time (Numba compile or cache load) is reported apart; ms per
step, the median and the slowest of the recorded blocks, with 1 and 2 Numba threads (a process
each). Quality beside the time: the deepest hull vertex below the ground's top over the run and
at the end, the fastest body at the end, bodies asleep at the end, the pile's height.

    PYTHONPATH=src python benchmarks/convex_pile.py --steps 500 --out benchmarks/results/convex_pile.md
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from report import emit, machine_line

HERE = Path(__file__).resolve().parent
BOX3D_MS = {1: 82.9, 2: 45.8}  # BENCHMARKS.md, "Box3D on this machine": convex_pile ms/step (min of 1 run)


def one_run(steps: int, threads: int, layers: int) -> dict:
    import numba

    import tumble as tb
    from tumble.scenes.contact import convex_pile
    from tumble.solver.contact import SoftStepSettings

    numba.set_num_threads(threads)
    world, settings = convex_pile(layers)
    sim = tb.Simulator(world, dt=settings["dt"], integrator="semi-implicit-euler", substeps=1,
                       contact_settings=SoftStepSettings(substeps=settings["substeps"]))
    hull = world.shapes[1]
    local = np.asarray(hull.vertices) - world.com_offset[1]

    def lowest():  # m: the deepest hull vertex's height (every body has the same hull)
        m = world.moving
        return float((np.einsum("nij,vj->nvi", world.R[m], local)[..., 2] + world.x[m, 2:3]).min())

    t0 = time.perf_counter()
    sim.step(1)
    first = time.perf_counter() - t0
    block = 25
    times, deepest, elapsed = [], 0.0, 0.0
    done = 1
    while done < steps:
        k = min(block, steps - done)
        t0 = time.perf_counter()
        sim.step(k)
        took = time.perf_counter() - t0
        elapsed += took
        times.append(took / k)
        done += k
        deepest = max(deepest, -lowest())
    m = world.moving
    sleep = getattr(sim, "sleep", None)
    awake = getattr(sleep, "awake", None)
    return {"threads": threads, "steps": steps, "first_s": first, "ms_mean": 1e3 * elapsed / (steps - 1),
            "ms_median": 1e3 * float(np.median(times)), "ms_max": 1e3 * max(times), "deepest_run": deepest,
            "deepest_end": -lowest(), "speed_end": float(np.linalg.norm(world.v[m], axis=1).max()),
            "asleep_end": None if awake is None else int((~np.asarray(awake, dtype=bool)[m]).sum()),
            "height_end": float(world.x[m, 2].max()), "bodies": int(m.sum()), "contacts": int(
                0 if sim.soft_step is None or sim.soft_step.contacts is None else len(sim.contacts().body_a))}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=500)
    ap.add_argument("--layers", type=int, default=80)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--one", type=int, help=argparse.SUPPRESS)  # internal: one run with this many threads
    ap.add_argument("--out")
    args = ap.parse_args()
    if args.one:
        print(json.dumps(one_run(args.steps, args.one, args.layers)))
        return
    lines = [machine_line(f"{args.steps} steps of 1/60 s, 4 substeps, {64 * args.layers} hulls"), "",
             "| threads | first step s | ms/step (mean) | ms/step (median of 25-step blocks) | slowest block ms/step | "
             "Box3D ms/step | deepest vertex below the ground, run / end (m) | fastest body at the end (m/s) | "
             "asleep at the end | contacts at the end | pile top (m) |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for threads in args.threads:
        env = dict(os.environ, NUMBA_NUM_THREADS=str(max(args.threads)))
        out = subprocess.run([sys.executable, __file__, "--one", str(threads), "--steps", str(args.steps),
                              "--layers", str(args.layers)], capture_output=True, text=True, env=env, cwd=HERE)
        if out.returncode:
            raise SystemExit(out.stderr)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        lines.append(f"| {threads} | {r['first_s']:.1f} | {r['ms_mean']:.1f} | {r['ms_median']:.1f} | {r['ms_max']:.1f} | "
                     f"{BOX3D_MS.get(threads, '-')} | {r['deepest_run']:.4f} / {r['deepest_end']:.4f} | "
                     f"{r['speed_end']:.3f} | {r['asleep_end']} of {r['bodies']} | {r['contacts']} | {r['height_end']:.1f} |")
    emit(lines, args.out)


if __name__ == "__main__":
    main()
