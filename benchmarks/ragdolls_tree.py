"""Ragdolls on the tree joint method (``ACCURATE``) at two revisions, interleaved in one run: the
time of a heap of n ragdolls (tumble.scenes.ragdolls, seed 0, dropped from 1-3 m, sleeping on as the
World's default) over 16 s at 1/60 s, and how it ends: the largest rise of the energy (kinetic plus
gravity's) above its lowest so far after 6 s, the kinetic energy and the fastest body at 16 s.
Each revision is a checkout (``git worktree add --detach DIR REV``):

    python benchmarks/ragdolls_tree.py OLD_DIR NEW_DIR [--rounds 3] [N ...]

Each timing is a fresh process, after a first 0.5 s run of one ragdoll (compilation, cached on
disk, apart); the table gives the median wall time over the rounds and the last round's figures
(the runs are deterministic: every round ends the same)."""
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(__file__))
from interleaved import interleaved, take_rounds  # noqa: E402

code = r'''
import json, sys, time, numpy as np
import tumble as tb
from tumble.scenes.ragdolls import ragdolls
from tumble.solver.joints import ACCURATE
n = int(sys.argv[1])
w, _ = ragdolls(1, 0)
tb.Simulator(w, dt=1 / 60, joint_settings=ACCURATE).step(30)  # compile apart
w, _ = ragdolls(n, 0)
sim = tb.Simulator(w, dt=1 / 60, joint_settings=ACCURATE)
energy = []
t = time.perf_counter()
wall_energy = 0.0
for k in range(16 * 60):
    sim.step()
    if k >= 6 * 60 - 1:
        e = time.perf_counter()
        energy.append(w.kinetic_energy() + w.potential_energy())
        wall_energy += time.perf_counter() - e
wall = time.perf_counter() - t - wall_energy
energy = np.array(energy)
m = w.moving
print(json.dumps([wall, float(np.max(energy - np.minimum.accumulate(energy))), w.kinetic_energy(),
                  float(np.linalg.norm(w.v[m], axis=1).max()), float(np.linalg.norm(w.omega[m], axis=1).max())]))
'''


def main(argv):
    args = list(argv)
    rounds = take_rounds(args, 3)
    old, new, *sizes = args
    sizes = [int(s) for s in sizes] or [4, 25]
    runs = interleaved(code, old, new, [(n,) for n in sizes], rounds)
    walls = {(n, rev): [figures[0] for figures in runs[((n,), rev)]] for n in sizes for rev in ("old", "new")}
    last = {(n, rev): runs[((n,), rev)][-1] for n in sizes for rev in ("old", "new")}
    print("| ragdolls | revision | wall s (16 s simulated) | energy rise after 6 s (J) | kinetic energy at 16 s (J) "
          "| fastest body at 16 s (m/s, rad/s) |")
    print("|---|---|---|---|---|---|")
    for n in sizes:
        for rev in ("old", "new"):
            _, rise, ke, v, w = last[(n, rev)]
            print(f"| {n} | {'before' if rev == 'old' else 'after'} | {statistics.median(walls[(n, rev)]):.2f} | "
                  f"{rise:.2e} | {ke:.2e} | {v:.2e}, {w:.2e} |")


if __name__ == "__main__":
    main(sys.argv[1:])
