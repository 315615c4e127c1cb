"""sweep_batching: 10 000 one-body variants, batched in one World vs separate runs.

Scene (tests/test_sweep.py ``one_body_document``): a 0.2 x 0.6 x 1.0 m box spun
near its intermediate axis, with gravity, an initial velocity and drag
(linear 0.1, angular 0.01); rk4, dt = 1/60 s, 1 s, 30 frames a second (60 steps,
31 frames). Random design of 10 000 variants (seed 7): spin perturbation
uniform(-0.5, 0.5), mass uniform(0.5, 4), vertical velocity normal(3, 1).
Metrics: final position, orientation, velocity, body-frame angular velocity,
energy drift, flip time.

Run from the repository root:

    PYTHONPATH=src python benchmarks/sweep_batching.py             # about 1 min
    PYTHONPATH=src python benchmarks/sweep_batching.py --separate 300 --variants 10000

What is timed (wall clock, this process, after one warm-up sweep that loads the
compiled kernels):

- batched, one task: ``run_sweep(..., workers=0, chunk_size=10000)``: every variant's
  scene parsed and validated, one World of 10 000 bodies, one ``Simulator.run``,
  metrics, the table;
- batched, default chunks: ``chunk_size=200`` (50 tasks of 200 variants), in this process;
- separate runs: ``run_sweep(..., batch=False)`` on the first ``--separate`` variants
  (each variant parsed and run alone, as ``Scene.run``), extrapolated per variant;
- optionally (``--cluster``) the default executor: a LocalCluster of one worker per core,
  cluster start-up included.

Checks that the batched rows equal the separate rows (all columns but wall time and
batch size) on the variants run both ways. Writes benchmarks/results/sweep_batching.md.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"

VARY = {"bodies.box.angular_velocity[0]": "uniform(-0.5, 0.5)", "bodies.box.mass": "uniform(0.5, 4.0)",
        "bodies.box.velocity[2]": "normal(3.0, 1.0)"}
METRICS = ["final_position:box", "final_orientation:box", "final_velocity:box", "final_angular_velocity_body:box",
           "energy_drift", "flip_time:box:y"]


def document() -> dict:
    return {
        "simulation": {"duration": 1.0, "dt": 1.0 / 60.0, "frame_rate": 30, "integrator": "rk4"},
        "bodies": [{"name": "box", "shape": {"type": "box", "size": [0.2, 0.6, 1.0]}, "mass": 2.0, "position": [0, 0, 1],
                    "velocity": [1.0, 0.0, 3.0], "angular_velocity": [0.01, 5.0, 0.01], "angular_velocity_frame": "body"}],
        "forces": [{"type": "drag", "linear": 0.1, "angular_linear": 0.01}],
    }


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variants", type=int, default=10_000)
    ap.add_argument("--separate", type=int, default=300, help="separate runs timed (extrapolated to --variants)")
    ap.add_argument("--cluster", action="store_true", help="also time the default LocalCluster executor")
    args = ap.parse_args(argv)

    from tumble.sweep import run_sweep, tables_equal

    doc = document()
    kw = {"vary": VARY, "samples": args.variants, "seed": 7, "metrics": METRICS, "progress": False}
    run_sweep(doc, **{**kw, "samples": 50}, workers=0)  # warm-up: kernels loaded
    run_sweep(doc, **{**kw, "samples": 5}, workers=0, batch=False)

    rows = []
    t_one, s_one = timed(lambda: run_sweep(doc, **kw, workers=0, chunk_size=args.variants))
    rows.append((f"batched, one task of {args.variants}", args.variants, s_one))
    t_chunks, s_chunks = timed(lambda: run_sweep(doc, **kw, workers=0, chunk_size=200))
    rows.append(("batched, tasks of 200 (default), one process", args.variants, s_chunks))

    # separate runs: the first N variants of the same design, each alone
    sep_doc_kw = {**kw, "samples": args.variants}
    t_sep, s_sep = timed(lambda: _first_variants_alone(doc, sep_doc_kw, args.separate))
    rows.append((f"separate runs (first {args.separate}, extrapolated)", args.separate, s_sep))

    if args.cluster:
        t_cl, s_cl = timed(lambda: run_sweep(doc, **kw))
        rows.append((f"batched, tasks of 200, LocalCluster of {os.cpu_count()} workers (start-up included)", args.variants, s_cl))
        assert tables_equal(t_cl, t_chunks)

    # the same rows, bit for bit, however they ran
    ignore = ("wall_time_s", "batch_size")
    equal = tables_equal(t_one.slice(0, args.separate), t_sep, ignore)
    assert tables_equal(t_one, t_chunks, ignore)

    per_sep = s_sep / args.separate
    lines = [
        (f"Run of {_dt.datetime.now(_dt.UTC):%Y-%m-%d %H:%M} UTC, tumble at git {_git()}, "
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}."),
        "",
        "| how | variants timed | wall time, s | variants / s | per variant, ms | vs separate |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for name, n, s in rows:
        per = s / n
        lines.append(f"| {name} | {n} | {s:.2f} | {n / s:,.0f} | {1e3 * per:.3f} | {per_sep / per:.1f}x |")
    lines += ["", (f"Separate runs, extrapolated to {args.variants} variants: {per_sep * args.variants:.0f} s. "
              f"Batched rows equal to the separate rows on the {args.separate} variants run both ways "
              f"(all columns but wall time and batch size, bit for bit): {'yes' if equal else 'NO'}.")]
    text = "\n".join(lines) + "\n"
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "sweep_batching.md").write_text(text)
    print(text)
    return 0 if equal else 1


def _first_variants_alone(doc, kw, n):
    """The design's first n variants, each run alone (batch=False), in this process."""
    from tumble.sweep.runner import SweepDefinition
    from tumble.sweep.tasks import run_chunk

    sd = SweepDefinition(doc, kw["vary"], kw["samples"], kw["seed"], kw["metrics"], chunk_size=n, batch=False)
    rows = run_chunk(sd.plan, sd.chunks()[0])
    from tumble.sweep.runner import _to_table

    return _to_table(rows, sd.schema())


def _git() -> str:
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True, check=False).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "src"], cwd=ROOT, capture_output=True, text=True, check=False).stdout.strip()
        return rev + (" + uncommitted src changes" if dirty else "")
    except OSError:
        return "unknown"


if __name__ == "__main__":
    sys.exit(main())
