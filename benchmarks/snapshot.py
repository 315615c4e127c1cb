"""Snapshots in memory: tumble's ``save_state`` / ``restore_state`` beside PyBullet's ``saveState`` /
``restoreState`` and MuJoCo's ``mj_getState`` / ``mj_setState`` (mjSTATE_INTEGRATION), on the same
pile of boxes (``tumble.scenes.contact`` "pile"), in one run.

    PYTHONPATH=src python benchmarks/snapshot.py --n 100 1000

For each engine: the pile is stepped 1 s (its boxes in contact), then

* save: the time of one save (median of --repeats);
* restore: the time of one restore;
* first step after a restore, and a step after another step (the median of --repeats each): a
  tumble restore makes the contact pipeline anew, and the step after it rebuilds its caches;
* branch: restore + 0.25 s of steps, the loop of a model predictive controller;
* identical: whether the 0.25 s after a restore give the same bits as the 0.25 s after the save
  (positions, orientations and velocities of every box, compared exactly), and if not, the
  largest distance between a box's two positions.

Steps as in benchmarks/contact.py: tumble dt = 1/60 s with 4 solver substeps (Box3D's step),
PyBullet and MuJoCo dt = 1/240 s; PyBullet's boxes as rigid bodies (maximal coordinates) and as
multibodies. Writes benchmarks/results/snapshot.md.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from contact import TumbleScene, machine, md_table, write_results  # noqa: E402
from peers.common import median, scene_spec  # noqa: E402
from peers.common import median_time as timed  # noqa: E402




class Tumble:
    name = "tumble"

    def __init__(self, n: int):
        self.scene = TumbleScene("pile", {"n": n}, "semi-implicit-euler", None, 1, 4)
        self.sim = self.scene.sim
        self.dt = self.scene.dt
        self.count = self.sim.world.body_count  # the ground too: a fixed row of zeros in both

    def step(self, k):
        self.sim.step(k)

    def save(self):
        return self.sim.save_state()

    def restore(self, s):
        self.sim.restore_state(s)

    def bits(self):
        w = self.sim.world
        return np.concatenate([w.x.ravel(), w.q.ravel(), w.P.ravel(), w.L.ravel()])


class Pybullet:
    def __init__(self, spec, variant: str):
        from peers.pybullet_scenes import PybulletScene

        self.name = f"pybullet ({variant})"
        self.eng = PybulletScene(spec, variant)
        self.p, self.c, self.dt = self.eng.p, self.eng.cid, self.eng.dt
        self.count = spec.n

    def step(self, k):
        self.eng.step(k)

    def save(self):
        return self.p.saveState(physicsClientId=self.c)

    def restore(self, s):
        self.p.restoreState(s, physicsClientId=self.c)

    def bits(self):
        x, R, v, w = self.eng.state()
        return np.concatenate([x.ravel(), R.ravel(), v.ravel(), w.ravel()])


class Mujoco:
    name = "mujoco"

    def __init__(self, spec):
        from peers.mujoco_scenes import MujocoScene

        self.eng = MujocoScene(spec)
        self.mj, self.m, self.dt = self.eng.mujoco, self.eng.model, self.eng.dt
        self.sig = int(self.mj.mjtState.mjSTATE_INTEGRATION)
        self.size = self.mj.mj_stateSize(self.m, self.sig)
        self.count = spec.n

    def step(self, k):
        for _ in range(k):
            self.mj.mj_step(self.m, self.eng.data)

    def save(self):
        s = np.empty(self.size)
        self.mj.mj_getState(self.m, self.eng.data, s, self.sig)
        return s

    def restore(self, s):
        self.mj.mj_setState(self.m, self.eng.data, s, self.sig)

    def bits(self):
        d = self.eng.data
        qpos = d.qpos.reshape(-1, 7)  # free joints: position, then quaternion
        return np.concatenate([qpos[:, :3].ravel(), qpos[:, 3:].ravel(), d.qvel.ravel()])


def measure(eng, repeats: int) -> dict:
    steps_1s = round(1.0 / eng.dt)
    branch = round(0.25 / eng.dt)
    eng.step(steps_1s)
    s = eng.save()
    eng.step(branch)
    after_save = eng.bits()
    eng.restore(s)
    eng.step(branch)
    again = eng.bits()
    identical = bool(np.array_equal(again, after_save))
    positions = slice(0, 3 * eng.count)  # every adapter's bits start with the (n, 3) positions
    apart = float(np.max(np.abs(again[positions] - after_save[positions])))
    row = {"engine": eng.name, "dt": eng.dt, "identical": identical, "apart_m": apart}
    row["save_ms"] = 1e3 * timed(eng.save, repeats)
    row["restore_ms"] = 1e3 * timed(lambda: eng.restore(s), repeats)
    eng.restore(s)
    eng.step(1)
    row["step_ms"] = 1e3 * timed(lambda: eng.step(1), repeats)

    first = []
    for _ in range(repeats):
        eng.restore(s)
        t0 = time.perf_counter()
        eng.step(1)
        first.append(time.perf_counter() - t0)
    row["first_step_ms"] = 1e3 * median(first)

    def loop():
        eng.restore(s)
        eng.step(branch)

    row["branch_ms"] = 1e3 * timed(loop, max(3, repeats // 4))
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[100, 1000])
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--engines", nargs="+", default=["tumble", "pybullet:rigidbody", "pybullet:multibody", "mujoco"])
    args = ap.parse_args(argv)
    rows = []
    for n in args.n:
        warm = Tumble(3)
        warm.step(30)  # compile (or load) the contact kernels outside the timings
        warm.restore(warm.save())
        warm.step(1)
        t = Tumble(n)
        spec = scene_spec(t.scene.world, {"scene": "pile"})
        for name in args.engines:
            engine, _, variant = name.partition(":")
            eng = {"tumble": lambda: t, "pybullet": lambda: Pybullet(spec, variant or "rigidbody"),
                   "mujoco": lambda: Mujoco(spec)}[engine]()
            row = {"n": n, **measure(eng, args.repeats)}
            rows.append(row)
            print(row, flush=True)
    header = ["boxes", "engine", "dt s", "save ms", "restore ms", "first step after ms", "a step ms",
              "restore + 0.25 s ms", "0.25 s after a restore = after the save"]
    table = md_table(header, [[r["n"], r["engine"], f"1/{round(1 / r['dt'])}", f"{r['save_ms']:.3f}",
                               f"{r['restore_ms']:.3f}", f"{r['first_step_ms']:.2f}", f"{r['step_ms']:.2f}",
                               f"{r['branch_ms']:.1f}",
                               "bit for bit" if r["identical"] else f"no: {r['apart_m']:.1e} m apart"] for r in rows])
    info = machine()
    markdown = f"machine: {info}\n\n{table}\n"
    print(markdown)
    write_results(HERE / "results", "snapshot", markdown, rows, info)


if __name__ == "__main__":
    main()
