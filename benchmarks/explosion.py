"""What an explosion costs: ``World.explode`` on the pile of boxes (``tumble.scenes.contact``
"pile") after it has fallen for 1 s, beside one step of the same pile, in one run.

    PYTHONPATH=src python benchmarks/explosion.py --n 100 1000 10000

For each N: the pile is stepped 1 s at Box3D's step (dt = 1/60 s, 4 solver substeps), then

* compile: the first ``World.explode`` in the process (its kernel from Numba's disk cache, or
  compiled when the cache is empty: the first run of the script on a machine);
* blast: the time of one ``collision.explosion.blast`` (the impulses, not applied) with the
  centre at the pile's middle, 1 m above the ground, and a reach (radius + falloff) of 0.5 m,
  1 m and 3 m: the bodies reached, and ms (median of --repeats);
* shaded: the same blast with ``shaded=True`` (six rays per shape reached), and how many of the
  shapes reached it spares entirely;
* step: one step of the pile (median of --repeats), the yardstick.

No peer is measured: PyBullet and MuJoCo have no explosion; Box2D v3 and Box3D have one
(``b2World_Explode``, a C loop over the shapes the broadphase finds), without Python bindings on
PyPI for v3 on this machine. Writes benchmarks/results/explosion.md.
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
from peers.common import median_time as timed  # noqa: E402


def main(argv=None):
    import tumble as tb
    from tumble.collision.explosion import blast

    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, nargs="+", default=[100, 1000, 10000])
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args(argv)
    rows = []
    first = None
    for n in args.n:
        scene = TumbleScene("pile", {"n": n}, "semi-implicit-euler", None, 1, 4)
        sim = scene.sim
        sim.step(round(1.0 / scene.dt))
        w = sim.world
        moving = w.moving
        middle = np.median(w.x[moving], axis=0)
        centre = (middle[0], middle[1], 1.0)
        if first is None:
            t0 = time.perf_counter()
            w.explode(centre, radius=0.1, impulse_per_area=0.0)
            first = time.perf_counter() - t0
        step_ms = 1e3 * timed(lambda: sim.step(1), args.repeats)
        for reach in (0.5, 1.0, 3.0):
            record = tb.Explosion(position=centre, radius=reach, impulse_per_area=10.0)
            shaded = tb.Explosion(position=centre, radius=reach, impulse_per_area=10.0, shaded=True)
            reached = len(np.unique(blast(w, record).body))
            ms = 1e3 * timed(lambda: blast(w, record), args.repeats)
            blast(w, shaded)  # its ray casts' first use
            shaded_ms = 1e3 * timed(lambda: blast(w, shaded), args.repeats)
            pushed = blast(w, shaded)
            spared = int(np.sum(np.linalg.norm(pushed.impulse, axis=1) == 0.0))
            rows.append({"n": n, "reach_m": reach, "bodies_reached": reached, "blast_ms": ms,
                         "shaded_ms": shaded_ms, "shapes_spared": spared, "step_ms": step_ms})
            print(rows[-1], flush=True)
    info = machine()
    table = md_table(["boxes", "reach (m)", "bodies reached", "blast ms", "shaded blast ms", "shapes spared (shaded)",
                      "a step of the pile, ms"],
                     [[r["n"], r["reach_m"], r["bodies_reached"], f"{r['blast_ms']:.3f}", f"{r['shaded_ms']:.3f}",
                       r["shapes_spared"], f"{r['step_ms']:.2f}"] for r in rows])
    markdown = (f"machine: {info['cpu']}, {info['nproc']} cores, Python {info['python']}, tumble git {info['tumble_git']}, "
                f"{info['date']}; pile after 1 s at dt 1/60 s x 4 "
                f"substeps; median of {args.repeats}\n\nfirst explode in the process (kernel load or compile): "
                f"{first:.2f} s\n\n{table}\n")
    print(markdown)
    write_results(HERE / "results", "explosion", markdown, rows, info)


if __name__ == "__main__":
    main()
