"""``tumble sweep SCENE --vary KEY=SPEC ... --out DIR``: run variants of a scene, gather a Parquet table.

Hooked into ``tumble`` by ``tumble.cli.COMMAND_MODULES``. Bad input (scene,
key path, spec, metric, options) raises ``InputError``: one line, exit status 2.
Variants that fail are rows with status "failed", not errors of the command
(exit 0). Ctrl-C stops the sweep (exit 130); the same command again resumes it.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from ..errors import InputError


def add_commands(subparsers) -> dict:
    p = subparsers.add_parser(
        "sweep", help="run many variants of a scene (grid or random design) and gather a Parquet table",
        description="Run variants of a scene file, each with some values changed, as independent tasks on local worker "
                    "processes or a Dask cluster, and gather their figures into DIR/results.parquet. "
                    "Running the same command again on the same DIR resumes an interrupted sweep. See docs/sweeps.md.")
    p.add_argument("scene", metavar="SCENE", help="scene file, .toml or .json (may hold a [sweep] table); or an MJCF .xml or a USD stage, as tumble run takes them")
    p.add_argument("--vary", metavar="KEY=SPEC", action="append", default=[],
                   help="a key path and its values, e.g. bodies.box.angular_velocity[0]=linspace(0.001,0.1,100); "
                        "specs: [a,b,c], linspace(a,b,n), range(a,b,step), uniform(a,b), normal(mu,sigma)")
    p.add_argument("--samples", metavar="N", type=_whole(1), help="random design of N variants (needs a uniform/normal spec)")
    p.add_argument("--seed", metavar="S", type=_whole(0), help="random seed of --samples (default 0)")
    p.add_argument("--metric", metavar="NAME", action="append", default=[],
                   help="a metric to record, e.g. flip_time:box:y, energy_drift, final_position:box (repeatable)")
    p.add_argument("--out", metavar="DIR", required=True, help="output folder (sweep.json, parts/, results.parquet, runs/)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler, tcp://HOST:PORT (default: local processes)")
    p.add_argument("--workers", metavar="N", type=_whole(0), help="local worker processes (default: one per core; 0: this process)")
    p.add_argument("--chunk-size", metavar="N", type=_whole(1), help="variants per task (default 200)")
    p.add_argument("--save-trajectories", action="store_true", help="write each variant's trajectory to DIR/runs/")
    p.add_argument("--no-batch", action="store_true", help="run every variant alone (same numbers, slower)")
    p.add_argument("--force", action="store_true", help="discard the results of a different sweep in DIR")
    p.add_argument("--no-progress", action="store_true", help="never show a progress bar")
    return {"sweep": cmd_sweep}


def _whole(least: int):
    import argparse

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if v < least:
            raise argparse.ArgumentTypeError(f"must be >= {least}, got {v}")
        return v

    return parse


def cmd_sweep(args) -> int:
    from .runner import run_sweep

    if args.scheduler is not None and args.workers is not None:
        raise InputError("give either --scheduler or --workers, not both", "--workers")
    if args.scheduler is not None and not args.scheduler.strip():
        raise InputError("empty scheduler address (expected tcp://HOST:PORT)", "--scheduler")
    out = Path(args.out)
    started = time.perf_counter()
    progress = False if args.no_progress else None
    try:
        table = run_sweep(args.scene, vary=args.vary, samples=args.samples, seed=args.seed, out=out,
                          metrics=args.metric or None, scheduler=args.scheduler, workers=args.workers,
                          chunk_size=args.chunk_size, save_trajectories=args.save_trajectories,
                          batch=not args.no_batch, progress=progress, force=args.force)
    except KeyboardInterrupt:
        print(f"tumble: sweep interrupted; finished chunks are kept in {out / 'parts'}: run the same command again to resume",
              file=sys.stderr)
        return 130
    n = table.num_rows
    failed = sum(1 for s in table.column("status").to_pylist() if s != "ok")
    lost = sum(1 for s in table.column("error_kind").to_pylist() if s == "worker")
    print(f"{args.scene}: {n} variants ({n - failed} ok, {failed} failed) in {time.perf_counter() - started:.1f} s")
    if lost:
        print(f"tumble: {lost} variants were lost with their workers: run the same command again to retry them", file=sys.stderr)
        return 1
    print(f"wrote {out / 'results.parquet'}")
    return 0
