"""A body's type changed between steps (``World.set_body_type``) in a pile of boxes, beside
PyBullet's ``changeDynamics(mass=0)`` (a body made static) and back, on the same pile, in one run.

    PYTHONPATH=src python benchmarks/type_change.py --n 100 1000

For each engine: the pile (``tumble.scenes.contact`` "pile") is stepped 1 s, then, --repeats
times, one box (a different one each time) is made fixed and the next step timed, then made
dynamic again and the next step timed; beside them the median of plain steps. tumble's Simulator
builds its contact and joint stages again after a type change (``Simulator._take_type_changes``:
a snapshot's save and restore with the shape table made anew), which the first figure includes.
MuJoCo has no type change (a mocap body is one at compile). Steps as in benchmarks/contact.py.
Writes benchmarks/results/type_change.md.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from contact import machine, md_table, write_results  # noqa: E402
from peers.common import median, scene_spec  # noqa: E402
from peers.common import median_time as timed  # noqa: E402
from snapshot import Tumble as PileTumble  # noqa: E402  (the pile at Box3D's step, as there)


class Tumble(PileTumble):
    def set_fixed(self, i, fixed: bool):
        # box i is body row i + 1 (row 0 is the ground)
        self.sim.world.set_body_type(1 + i, "fixed" if fixed else "dynamic")


class Pybullet:
    def __init__(self, spec):
        from peers.pybullet_scenes import PybulletScene

        self.name = "pybullet (rigidbody)"
        self.eng = PybulletScene(spec, "rigidbody")
        self.p, self.c, self.dt = self.eng.p, self.eng.cid, self.eng.dt
        self.mass = [float(m) for m in spec.mass]

    def step(self, k):
        self.eng.step(k)

    def set_fixed(self, i, fixed: bool):
        self.p.changeDynamics(self.eng.ids[i], -1, mass=0.0 if fixed else self.mass[i], physicsClientId=self.c)


def measure(eng, n: int, repeats: int) -> dict:
    eng.step(round(1.0 / eng.dt))
    row = {"engine": eng.name, "dt": eng.dt, "step_ms": 1e3 * timed(lambda: eng.step(1), repeats)}
    to_fixed, to_dynamic = [], []
    for k in range(repeats):
        i = (37 * k) % n
        t0 = time.perf_counter()
        eng.set_fixed(i, True)
        eng.step(1)
        to_fixed.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        eng.set_fixed(i, False)
        eng.step(1)
        to_dynamic.append(time.perf_counter() - t0)
    row["fixed_ms"] = 1e3 * median(to_fixed)
    row["dynamic_ms"] = 1e3 * median(to_dynamic)
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[100, 1000])
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--engines", nargs="+", default=["tumble", "pybullet"])
    args = ap.parse_args(argv)
    rows = []
    for n in args.n:
        warm = Tumble(3)
        warm.step(30)  # compile (or load) the contact kernels outside the timings
        warm.set_fixed(0, True)
        warm.step(1)
        t = Tumble(n)
        spec = scene_spec(t.scene.world, {"scene": "pile"})
        for name in args.engines:
            eng = t if name == "tumble" else Pybullet(spec)
            row = {"n": n, **measure(eng, n, args.repeats)}
            rows.append(row)
            print(row, flush=True)
    header = ["boxes", "engine", "dt s", "a step ms", "a box made fixed + the step ms", "made dynamic again + the step ms"]
    table = md_table(header, [[r["n"], r["engine"], f"1/{round(1 / r['dt'])}", f"{r['step_ms']:.2f}",
                               f"{r['fixed_ms']:.2f}", f"{r['dynamic_ms']:.2f}"] for r in rows])
    info = machine()
    markdown = f"machine: {info}\n\n{table}\n"
    print(markdown)
    write_results(HERE / "results", "type_change", markdown, rows, info)


if __name__ == "__main__":
    main()
