"""tumble.sweep on its own LocalCluster: each worker process runs Numba on one thread.

The workers are one per core (Dask's ``threads_per_worker=1``); Numba's default would give each a
thread per core, so the parallel kernels of N workers ran N x cores threads on the cores and waited
at their barriers on descheduled threads (docs/sweeps.md: 4-28x slower measured under shared cores).
The thread count must not change a result (docs/reliability.md): the table equals the in-process
one bit for bit, and the in-process path keeps Numba's default."""

from __future__ import annotations

import logging
import os

import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("distributed")
numba = pytest.importorskip("numba")

from tumble.sweep import run_sweep  # noqa: E402
from tumble.sweep.runner import SweepDefinition, run_chunk_on_worker  # noqa: E402
from tests.test_sweep import KEY, METRICS, SRC, same, write_scene  # noqa: E402


def test_run_chunk_on_worker_runs_on_the_threads_asked_and_gives_them_back(tmp_path):
    """The Dask task runs its chunk with ``numba_threads`` Numba threads (reported with the rows,
    the same rows as ``run_chunk``'s but for the wall time) and sets the calling thread's count back
    after; without ``numba_threads`` it leaves Numba's count alone."""
    from tumble.sweep.tasks import run_chunk

    scene = write_scene(tmp_path / "s.toml")
    sd = SweepDefinition(str(scene), {KEY: "[0.01, 0.1]"}, None, None, METRICS, None, True)
    chunk = sd.chunks()[0]
    default = numba.get_num_threads()
    rows, threads = run_chunk_on_worker(sd.plan, chunk, 1)
    assert threads == 1 and numba.get_num_threads() == default
    rows_default, threads_default = run_chunk_on_worker(sd.plan, chunk)
    assert threads_default == default
    plain = run_chunk(sd.plan, chunk)
    for a, b, c in zip(rows, rows_default, plain):
        a, b, c = ({k: v for k, v in r.items() if k != "wall_time_s"} for r in (a, b, c))
        assert a == b == c


def test_sweep_on_its_local_cluster_runs_numba_on_one_thread_per_worker(tmp_path, caplog, monkeypatch):
    """``run_sweep(workers=2)`` (``tumble sweep --workers 2``) starts 2 worker processes whose tasks
    report 1 Numba thread (logged by ``tumble.sweep``); the table is the in-process one
    (``workers=0``) bit for bit, and this process's own Numba thread count is untouched."""
    monkeypatch.setenv("PYTHONPATH", str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    scene = write_scene(tmp_path / "s.toml")
    kw = {"vary": {KEY: "linspace(0.001, 0.2, 40)"}, "metrics": METRICS, "chunk_size": 10, "progress": False}
    default = numba.get_num_threads()
    expected = run_sweep(scene, workers=0, **kw)
    assert numba.get_num_threads() == default
    with caplog.at_level(logging.INFO, logger="tumble.sweep"):
        table = run_sweep(scene, workers=2, **kw)
    assert same(table, expected)
    said = [r.getMessage() for r in caplog.records if r.name == "tumble.sweep"]
    assert said == ["sweep: Dask tasks ran Numba on 1 thread(s)"]
    assert numba.get_num_threads() == default
