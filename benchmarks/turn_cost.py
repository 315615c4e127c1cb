"""A/B: the soft step's turn of its moving bodies (``solver.soft_step._turn_free``, the implicit
midpoint of the torque-free rotation, session 45) against the turn at constant omega before it, at
two revisions interleaved in one run, each a fresh process (``git worktree add --detach DIR REV``):

    python benchmarks/turn_cost.py OLD_DIR NEW_DIR [--rounds 3] [CASE ...]

Cases: ``pile`` (examples/pile.toml's 1000 boxes, dt 1/60 s with 4 substeps: cubes, whose isotropic
inertia makes the midpoint's iteration end at once; its first second), ``planks`` (400 planks of
0.3 x 0.1 x 0.02 m dropped tumbling at 20 rad/s onto a plane in a 20 x 20 grid, dt 1/240 s: the
iteration's worst kind of body, 1 s), ``tower`` (examples/tower.toml, 10 boxes at rest, 2 s). Each
run: the first step apart (compilation, shape table), then microseconds per step over the rest; the
table gives medians over the rounds, and a digest of each end state (they differ: the turn changed).
"""
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(__file__))
from interleaved import interleaved, take_rounds  # noqa: E402

code = r'''
import json, sys, time, numpy as np
import tumble as tb
from tumble.scene import load_scene
case = sys.argv[1]
if case == "planks":
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    rng = np.random.default_rng(0)
    for i in range(20):
        for j in range(20):
            axis = rng.normal(size=3)
            w.add_body(tb.Box((0.3, 0.1, 0.02)), mass=1.0, position=(0.4 * i, 0.4 * j, 0.3 + 0.2 * rng.random()),
                       angular_velocity=tuple(20.0 * axis / np.linalg.norm(axis)))
    sim = tb.Simulator(w, dt=1 / 240)
    steps = 240
else:
    scene = load_scene(f"examples/{case}.toml")
    sim = scene.simulator()
    steps = int(round((1.0 if case == "pile" else 2.0) / sim.dt))
sim.step()
t0 = time.perf_counter()
sim.step(steps - 1)
us = (time.perf_counter() - t0) / (steps - 1) * 1e6
print(json.dumps({"us": us, "digest": float(np.abs(sim.world.x).sum())}))
'''


def main():
    args = sys.argv[1:]
    rounds = take_rounds(args, 3)
    old, new = args[0], args[1]
    cases = [(c,) for c in (args[2:] or ["pile", "planks", "tower"])]
    results = interleaved(code, old, new, cases, rounds)
    print(f"machine: {os.cpu_count()} cores; {rounds} rounds")
    print("| case | before (us/step) | midpoint turn (us/step) | change |")
    print("|---|---:|---:|---:|")
    for (case,) in cases:
        a = statistics.median(r["us"] for r in results[((case,), "old")])
        b = statistics.median(r["us"] for r in results[((case,), "new")])
        print(f"| {case} | {a:.1f} | {b:.1f} | {100 * (b / a - 1):+.1f} % |")


if __name__ == "__main__":
    main()
