"""Sweeps: many variants of one scene, run as independent tasks, gathered into one Parquet table.

``run_sweep(scene, vary=..., samples=..., seed=..., out=..., client=...)`` is the
Python API; ``tumble sweep SCENE --vary KEY=SPEC ...`` the command (docs/sweeps.md).

Modules: ``spec`` (key paths, value specs, the design), ``metrics`` (what a row
records), ``batch`` (many small variants stepped as one World), ``tasks``
(``run_chunk``: the task every executor runs), ``runner`` (executors, parts,
resume), ``commands`` (the CLI).
"""

from __future__ import annotations


def run_sweep(*args, **kwargs):
    """See ``tumble.sweep.runner.run_sweep``."""
    from .runner import run_sweep as _run

    return _run(*args, **kwargs)


def run_variant(scene, values: dict, metrics=None, batch: bool = False):
    """One variant of ``scene`` run alone in this process: its row (dict) as a sweep would record it.

    ``values`` is ``{key path: value}``. Useful to check a sweep's row against a single run.
    """
    from .runner import SweepDefinition
    from .tasks import run_chunk

    sd = SweepDefinition(scene, {k: [v] for k, v in values.items()}, metrics=metrics, batch=batch)
    return run_chunk(sd.plan, sd.chunks()[0])[0]


def table_for_comparison(table):
    """The table without wall-time columns (the only ones that differ between equal sweeps)."""
    from .runner import table_for_comparison as _t

    return _t(table)


def tables_equal(a, b, ignore=("wall_time_s",)) -> bool:
    """Same rows and values (NaN equal to NaN), leaving out the columns in ``ignore``."""
    from .runner import tables_equal as _eq

    return _eq(a, b, ignore)


__all__ = ["run_sweep", "run_variant", "table_for_comparison", "tables_equal"]
