"""robot_sweep: a sweep over a URDF arm's start pose, batched in one World vs separate runs.

Scene: the two-link arm of tests/physics/test_urdf.py (a fused tip, joint damping 0.1 N m s/rad)
in a scene file with collisions on (its links never touch each other), 1 s at dt 1/240 s, the
default joint solver; varied: the shoulder's start angle, ``linspace(-1, 1, N)``. Metrics: the
defaults (energy drift, final positions and orientations).

Timed (wall clock, this process, after a warm-up sweep that loads the compiled kernels):
``run_sweep(..., workers=0, chunk_size=N)`` (one World of N arms) and ``batch=False`` on the
first ``--separate`` variants, extrapolated per variant. Checks that the rows run both ways are
equal (all columns but wall time and batch size).

    PYTHONPATH=src python benchmarks/robot_sweep.py --variants 1000 --separate 100
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def main():
    from tests.physics.test_urdf import ARM
    from tumble.sweep import run_sweep, tables_equal

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", type=int, default=1000)
    parser.add_argument("--separate", type=int, default=100)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    (folder / "arm.urdf").write_text(ARM.replace("DAMPING", "0.1"))
    scene = folder / "s.toml"
    scene.write_text('[simulation]\nduration = 1.0\n[[robots]]\nfile = "arm.urdf"\n'
                     'joint_positions = { shoulder = 0.5, elbow = 0.0 }\n')
    n = args.variants
    vary = [f"robots[0].joint_positions.shoulder=linspace(-1.0, 1.0, {n})"]
    run_sweep(scene, vary=["robots[0].joint_positions.shoulder=[0.1, 0.2]"], workers=0, progress=False)  # warm-up
    t0 = time.perf_counter()
    batched = run_sweep(scene, vary=vary, workers=0, progress=False, chunk_size=n)
    t_batched = time.perf_counter() - t0
    m = args.separate
    # the first m variants' exact values (a shorter linspace would round differently)
    values = batched["robots[0].joint_positions.shoulder"].to_pylist()[:m]
    sub = ["robots[0].joint_positions.shoulder=[" + ", ".join(repr(v) for v in values) + "]"]
    t0 = time.perf_counter()
    single = run_sweep(scene, vary=sub, workers=0, progress=False, batch=False)
    t_single = (time.perf_counter() - t0) / m
    same = tables_equal(batched.slice(0, m).drop_columns(["variant"]), single.drop_columns(["variant"]),
                        ignore=("wall_time_s", "batch_size"))
    git = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                         cwd=os.path.dirname(__file__)).stdout.strip()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, tumble git {git}")
    print("| variants | batched (one World) s | per variant ms | separate runs per variant ms | speed-up | rows equal |")
    print("|---|---|---|---|---|---|")
    print(f"| {n} | {t_batched:.2f} | {1e3 * t_batched / n:.2f} | {1e3 * t_single:.1f} | "
          f"{t_single * n / t_batched:.1f}x | {same} |")


if __name__ == "__main__":
    main()
