"""A body's type changed between steps (``World.set_body_type``) in a pile of boxes, beside
PyBullet's ``changeDynamics(mass=0)`` (a body made static) and back, on the same pile, in one run;
and a body taken out of the simulation and put back (``World.set_enabled``) beside PyBullet's
``removeBody`` and a new ``createMultiBody`` at the pose it left (its way of despawning and
respawning), then the step of the pile with every other box out.

    PYTHONPATH=src python benchmarks/type_change.py --n 100 1000

For each engine: the pile (``tumble.scenes.contact`` "pile") is stepped 1 s, then, --repeats
times, one box (a different one each time) is made fixed and the next step timed, then made
dynamic again and the next step timed; beside them the median of plain steps. tumble's Simulator
builds its contact and joint stages again after a type change (``Simulator._take_type_changes``:
a snapshot's save and restore with the shape table made anew), which the first figure includes.
MuJoCo has no type change (a mocap body is one at compile) and no body removal. Steps as in
benchmarks/contact.py.
Writes benchmarks/results/type_change.md.
"""

from __future__ import annotations

import argparse
import math
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

    def set_enabled(self, i, on: bool):
        self.sim.world.set_enabled(1 + i, on)


class Pybullet:
    def __init__(self, spec):
        from peers.pybullet_scenes import PybulletScene

        self.name = "pybullet (rigidbody)"
        self.eng = PybulletScene(spec, "rigidbody")
        self.p, self.c, self.dt = self.eng.p, self.eng.cid, self.eng.dt
        self.mass = [float(m) for m in spec.mass]
        self.half = [tuple(float(h) for h in spec.half[i]) for i in range(spec.n)]
        # the material the scene gave it (peers/pybullet_scenes.py: sqrt of tumble's, as Bullet multiplies)
        self.friction = [math.sqrt(float(f)) for f in spec.friction]
        self.restitution = [float(e) for e in spec.restitution]
        self.gone, self.shapes = {}, {}  # removed boxes' poses and velocities; collision shapes by half-extents

    def step(self, k):
        self.eng.step(k)

    def set_fixed(self, i, fixed: bool):
        self.p.changeDynamics(self.eng.ids[i], -1, mass=0.0 if fixed else self.mass[i], physicsClientId=self.c)

    def set_enabled(self, i, on: bool):
        p, c = self.p, self.c
        if not on:  # removed; its pose and velocities kept for the respawn
            b = self.eng.ids[i]
            self.gone[i] = (p.getBasePositionAndOrientation(b, physicsClientId=c),
                            p.getBaseVelocity(b, physicsClientId=c))
            p.removeBody(b, physicsClientId=c)
            return
        (pos, orn), (v, w) = self.gone.pop(i)
        half = self.half[i]
        if half not in self.shapes:
            self.shapes[half] = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half), physicsClientId=c)
        b = p.createMultiBody(self.mass[i], self.shapes[half], basePosition=pos, baseOrientation=orn, physicsClientId=c)
        p.resetBaseVelocity(b, v, w, physicsClientId=c)
        p.changeDynamics(b, -1, lateralFriction=self.friction[i], restitution=self.restitution[i], physicsClientId=c)
        self.eng.ids[i] = b


def toggled(change, eng, n: int, repeats: int, stride: int, first: int) -> tuple[float, float]:
    """(ms, ms): medians over ``repeats`` boxes of ``change(i, True)`` + a step and ``change(i, False)``
    + a step, box i = (first + stride k) mod n."""
    on, off = [], []
    for k in range(repeats):
        i = (first + stride * k) % n
        for flag, times in ((True, on), (False, off)):
            t0 = time.perf_counter()
            change(i, flag)
            eng.step(1)
            times.append(time.perf_counter() - t0)
    return 1e3 * median(on), 1e3 * median(off)


def measure(eng, n: int, repeats: int) -> dict:
    eng.step(round(1.0 / eng.dt))
    row = {"engine": eng.name, "dt": eng.dt, "step_ms": 1e3 * timed(lambda: eng.step(1), repeats)}
    # a box (a different one each time) changed and changed back, each change timed with the step after
    row["fixed_ms"], row["dynamic_ms"] = toggled(eng.set_fixed, eng, n, repeats, stride=37, first=0)
    row["out_ms"], row["back_ms"] = toggled(lambda i, on: eng.set_enabled(i, not on), eng, n, repeats, stride=53, first=11)
    for i in range(0, n, 2):
        eng.set_enabled(i, False)
    eng.step(5)  # the stages made anew, the half left settling
    row["half_step_ms"] = 1e3 * timed(lambda: eng.step(1), repeats)
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
        warm.set_enabled(1, False)
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
    header = ["boxes", "engine", "a step ms", "a box taken out + the step ms", "put back + the step ms",
              "a step with every other box out ms"]
    table2 = md_table(header, [[r["n"], r["engine"], f"{r['step_ms']:.2f}", f"{r['out_ms']:.2f}", f"{r['back_ms']:.2f}",
                                f"{r['half_step_ms']:.2f}"] for r in rows])
    info = machine()
    markdown = f"machine: {info}\n\n{table}\n\n{table2}\n"
    print(markdown)
    write_results(HERE / "results", "type_change", markdown, rows, info)


if __name__ == "__main__":
    main()
