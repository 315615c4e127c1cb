"""``run_sweep``: design the variants, run them as tasks on an executor, gather one Parquet table.

Output folder (``out``)::

    sweep.json            what the sweep is (scene, keys and specs, samples, seed, metrics,
                          chunk size): a later call with the same definition resumes
    parts/chunk-NNNNNN.parquet   one file per finished chunk, each written atomically
    results.parquet       all rows ordered by variant, gathered when every chunk is done
    runs/variant-NNNNNNN.npz     trajectory files (save_trajectories=True)

Executors, all calling the same ``tasks.run_chunk``: a ``dask.distributed``
``LocalCluster`` of worker processes (default, one per core), an existing
cluster (``scheduler="tcp://host:port"`` or ``client=Client(...)``), or this
process alone (``workers=0``).
"""

from __future__ import annotations

import contextlib
import copy
import json
import logging
import math
import os
import re
import shutil
import sys
import tomllib
from collections import deque
from pathlib import Path

from ..errors import InputError
from ..scene import parse_scene
from ..scene_values import MAX_WHOLE, shown
from . import metrics as M
from .spec import MAX_VARIANTS, design, format_key, parse_spec, parse_vary, resolve_key
from .tasks import Plan, run_chunk

FORMAT = "tumble-sweep/1"
DEFAULT_CHUNK_SIZE = 200
SWEEP_KEYS = ("vary", "samples", "seed", "metrics", "chunk_size")
BASE_COLUMNS_END = ("status", "error_kind", "error", "state_hash", "wall_time_s", "batch_size")
TIME_COLUMNS = ("wall_time_s",)


# ---------------------------------------------------------------------- the scene and its [sweep] table


MODEL_SUFFIXES = (".xml", ".usd", ".usda", ".usdc", ".usdz")


def read_scene_document(scene):
    """(document without [sweep], the [sweep] table or {}, file label, base folder) of a path or a dict.

    ``tumble.scene`` does not know a [sweep] table, so it is taken out here before
    the document goes to ``parse_scene``.
    """
    if isinstance(scene, dict):
        data = copy.deepcopy(scene)
        file, base_dir = None, "."
    else:
        path = Path(scene)
        file, base_dir = str(path), str(path.parent)
        suffix = path.suffix.lower()
        if suffix in MODEL_SUFFIXES:  # an MJCF model or a USD stage: the document tumble run makes of it
            from ..scene import model_document

            if not path.is_file():
                raise InputError("file not found", None, file)
            return model_document(path), {}, file, base_dir
        if suffix not in (".toml", ".json"):
            raise InputError(f"unknown scene file type {path.suffix or '(none)'!r} (expected .toml, .json, an MJCF .xml "
                             "or a USD stage)", None, file)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise InputError("file not found", None, file) from None
        except IsADirectoryError:
            raise InputError("is a folder, not a scene file", None, file) from None
        except UnicodeDecodeError as exc:
            raise InputError(f"not UTF-8 text (byte {exc.start})", None, file) from None
        except OSError as exc:
            raise InputError(f"cannot read file: {exc.strerror or exc}", None, file) from None
        try:
            data = tomllib.loads(text) if suffix == ".toml" else json.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise InputError(f"invalid TOML: {' '.join(str(exc).split())}", None, file) from None
        except json.JSONDecodeError as exc:
            raise InputError(f"invalid JSON: {exc.msg} (at line {exc.lineno}, column {exc.colno})", None, file) from None
        except RecursionError:
            raise InputError("nested too deeply", None, file) from None
        except ValueError as exc:  # Python's limit on the digits of an integer read from text
            from ..scene_values import _int_digits_problem

            raise InputError(f"invalid {'TOML' if suffix == '.toml' else 'JSON'}: {_int_digits_problem(exc)}", None, file) from None
    if not isinstance(data, dict):
        raise InputError("expected a table of [simulation], [[bodies]] and [[forces]]", None, file)
    section = data.pop("sweep", {})
    if not isinstance(section, dict):
        raise InputError("expected a table [sweep]", "sweep", file)
    for k in section:
        if k not in SWEEP_KEYS:
            raise InputError(f"unknown key (expected one of {', '.join(SWEEP_KEYS)})", f"sweep.{k}", file)
    return data, section, file, base_dir


def _vary_items(vary, where: str, file=None) -> list[tuple[str, object]]:
    if vary is None:
        return []
    if isinstance(vary, dict):
        return [(str(k), v) for k, v in vary.items()]
    if isinstance(vary, str):
        vary = [vary]
    if isinstance(vary, (list, tuple)):
        out = []
        for item in vary:
            if isinstance(item, (list, tuple)) and len(item) == 2:
                out.append((str(item[0]), item[1]))
            else:
                try:
                    out.append(parse_vary(item))
                except InputError as err:
                    raise InputError(err.problem, where, file) from None
        return out
    raise InputError(f"expected a table of KEY = SPEC or a list of \"KEY=SPEC\", got {vary!r}", where, file)


def _toml_key(key: str) -> str:
    """A key of the [sweep] vary table as the file writes it: quoted when it is not a bare key."""
    return key if re.fullmatch(r"[A-Za-z0-9_-]+", key) else json.dumps(key)


def _table_error(err: InputError, from_table: set, varied: set, samples_key: str, file) -> InputError:
    """``design()``'s error keyed as the scene file's ``[sweep]`` table when the values it is about
    came from it (``--vary K`` -> ``sweep.vary.K``; ``--vary`` -> ``sweep.vary`` when every varied
    key is the table's; ``--samples`` -> ``sweep.samples``), with the file; else as it was."""
    key = err.key or ""
    if key == "--samples" and samples_key == "sweep.samples":
        return InputError(err.problem, "sweep.samples", file)
    if key.startswith("--vary ") and key[len("--vary "):] in from_table:
        return InputError(err.problem, f"sweep.vary.{_toml_key(key[len('--vary '):])}", file)
    if key == "--vary" and varied and varied <= from_table:
        return InputError(err.problem, "sweep.vary", file)
    return err


def _file_of(key: str, file):
    """The file a key's value came from: the scene file for a [sweep] key, none for an option."""
    return file if key.startswith("sweep.") else None


class SweepDefinition:
    """A checked sweep: the plan the tasks get, the design, and what sweep.json records."""

    def __init__(self, scene, vary=None, samples=None, seed=None, metrics=None, chunk_size=None, batch=True):
        data, section, file, base_dir = read_scene_document(scene)
        # the base scene must be valid on its own
        base_scene = parse_scene(copy.deepcopy(data), file, base_dir)
        names = list(base_scene.world.names)
        moving = [bool(m) for m in base_scene.world.moving]
        sensors = [n for n, s in zip(names, base_scene.world.sensor) if s]

        items = _vary_items(section.get("vary"), "sweep.vary", file)
        given = _vary_items(vary, "--vary")
        seen = set()
        for k, _ in given:
            if k in seen:
                raise InputError(f"key {k!r} is varied twice", "--vary")
            seen.add(k)
        merged: dict[str, object] = {}
        from_table = set()  # keys whose spec is the [sweep] table's (a --vary of the same key replaces it)
        for k, v in items:
            merged[k] = v
            from_table.add(k)
        for k, v in given:
            merged[k] = v
            from_table.discard(k)
        specs, self.paths = [], []
        for k, v in merged.items():
            try:
                spec = parse_spec(k, v)
                self.paths.append(resolve_key(data, spec.key))
            except InputError as err:
                if k in from_table:  # the scene file's [sweep] table, not a --vary option: name them
                    raise InputError(err.problem, f"sweep.vary.{_toml_key(k)}", file) from None
                raise
            specs.append(spec)
        canon = [format_key(p) for p in self.paths]
        if len(set(map(str, self.paths))) != len(self.paths):
            dup = next(c for c in canon if canon.count(c) > 1)
            raise InputError(f"two keys name the same value {dup!r}", "--vary")

        samples_key, seed_key = "--samples", "--seed"
        if samples is None and "samples" in section:
            samples, samples_key = section["samples"], "sweep.samples"
        if samples is not None and (isinstance(samples, bool) or not isinstance(samples, int) or samples < 1):
            raise InputError(f"must be a whole number >= 1, got {shown(samples)}", samples_key, _file_of(samples_key, file))
        if seed is None and "seed" in section:
            seed, seed_key = section["seed"], "sweep.seed"
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_WHOLE):
            raise InputError(f"must be a whole number from 0 to 2^63 - 1, got {shown(seed)}", seed_key, _file_of(seed_key, file))
        if seed is not None and samples is None:
            raise InputError(f"{'seed' if seed_key == 'sweep.seed' else '--seed'} only matters with --samples N "
                             "(a random design)", seed_key, _file_of(seed_key, file))
        if samples is not None and samples > MAX_VARIANTS:  # design() says it too, as --samples
            raise InputError(f"must be at most {MAX_VARIANTS}, got {shown(samples)}", samples_key, _file_of(samples_key, file))
        if samples is not None and seed is None:
            seed = 0
        try:
            self.columns = design(specs, samples, seed)
        except InputError as err:  # design() names the options; the values may be the [sweep] table's
            raise _table_error(err, from_table, set(merged), samples_key, file) from None
        self.count = len(next(iter(self.columns.values())))

        texts = metrics if metrics else section.get("metrics")
        metrics_key = "--metric" if metrics else "sweep.metrics"
        if texts is None:
            self.metrics = M.default_metrics(names, moving)
        else:
            if isinstance(texts, str):
                texts = [texts]
            if not isinstance(texts, (list, tuple)) or not texts:
                raise InputError(f"expected a list of metric names, got {shown(texts)}", metrics_key, _file_of(metrics_key, file))
            self.metrics = []
            for t in texts:
                try:
                    m = M.parse_metric(t, names, sensors)
                except InputError as err:
                    if metrics_key == "--metric":
                        raise
                    raise InputError(err.problem, metrics_key, file) from None
                if m.text not in [x.text for x in self.metrics]:
                    self.metrics.append(m)

        chunk_key = "--chunk-size"
        if chunk_size is None:
            chunk_size = section.get("chunk_size", DEFAULT_CHUNK_SIZE)
            chunk_key = "sweep.chunk_size" if "chunk_size" in section else chunk_key
        if isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or chunk_size < 1:
            raise InputError(f"must be a whole number >= 1, got {shown(chunk_size)}", chunk_key, _file_of(chunk_key, file))
        self.chunk_size = chunk_size
        self.keys = [s.key for s in specs]
        self.specs = specs
        self.samples, self.seed, self.batch = samples, seed, bool(batch)
        self.plan = Plan(data, file, base_dir, self.keys, self.paths, self.metrics, None, self.batch)
        self.identity = json.loads(json.dumps({
            "format": FORMAT, "scene": data, "file": None if file is None else Path(file).name,
            "vary": [[s.key, s.text] for s in specs], "samples": samples, "seed": seed,
            "metrics": [m.text for m in self.metrics], "chunk_size": chunk_size, "variants": self.count,
            "batch": self.batch,
        }, default=str))

    def chunks(self) -> list[list]:
        out = []
        for start in range(0, self.count, self.chunk_size):
            idx = range(start, min(start + self.chunk_size, self.count))
            out.append([(i, {k: self.columns[k][i] for k in self.keys}) for i in idx])
        return out

    def schema(self):
        import pyarrow as pa

        fields = [pa.field("variant", pa.int64())]
        for k in self.keys:
            vals = self.columns[k]
            if all(isinstance(v, int) and not isinstance(v, bool) for v in vals):
                t = pa.int64()
            elif all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
                t = pa.float64()
            else:
                t = pa.string()
            fields.append(pa.field(k, t))
        fields += [pa.field(c, pa.float64()) for c in self.plan.metric_columns]
        fields += [pa.field("status", pa.string()), pa.field("error_kind", pa.string()), pa.field("error", pa.string()),
                   pa.field("state_hash", pa.string()), pa.field("wall_time_s", pa.float64()), pa.field("batch_size", pa.int64())]
        return pa.schema(fields)


# ---------------------------------------------------------------------- parts on disk


def _to_table(rows: list[dict], schema):
    import pyarrow as pa

    cols = {}
    for f in schema:
        vals = [r[f.name] for r in rows]
        if pa.types.is_string(f.type):
            vals = [None if v is None else str(v) for v in vals]
        cols[f.name] = pa.array(vals, type=f.type)
    return pa.table(cols, schema=schema)


def _write_parquet_atomic(table, path: Path):
    import pyarrow.parquet as pq

    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        pq.write_table(table, tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def part_path(out: Path, chunk: int) -> Path:
    return out / "parts" / f"chunk-{chunk:06d}.parquet"


def _read_part(path: Path, schema, expected: int):
    import pyarrow.parquet as pq

    try:
        t = pq.read_table(path)
    except Exception:  # noqa: BLE001 - a damaged part is run again
        return None
    if t.num_rows != expected or t.schema.names != schema.names:
        return None
    return t.cast(schema)


def gather(tables: list, schema):
    """One table of all rows, ordered by variant."""
    import pyarrow as pa

    if not tables:
        return schema.empty_table()
    t = pa.concat_tables(tables)
    return t.sort_by("variant")


def table_for_comparison(table):
    """The table without its wall-time columns (they are the only ones that may differ between equal sweeps)."""
    return table.drop_columns([c for c in TIME_COLUMNS if c in table.column_names])


def tables_equal(a, b, ignore=TIME_COLUMNS) -> bool:
    """True when two sweep tables hold the same rows, columns and values (NaN equal to NaN),
    leaving out the columns in ``ignore`` (the wall time by default)."""
    import numpy as np

    a = a.drop_columns([c for c in ignore if c in a.column_names])
    b = b.drop_columns([c for c in ignore if c in b.column_names])
    if a.schema != b.schema or a.num_rows != b.num_rows:
        return False
    for name in a.column_names:
        x, y = a[name].to_pylist(), b[name].to_pylist()
        if x == y:
            continue
        try:
            if not np.array_equal(np.array(x, dtype=float), np.array(y, dtype=float), equal_nan=True):
                return False
        except (TypeError, ValueError):
            return False
    return True


# ---------------------------------------------------------------------- running


def run_sweep(scene, vary=None, samples: int | None = None, seed: int | None = None, out=None, client=None, *,
              metrics=None, scheduler: str | None = None, workers: int | None = None, chunk_size: int | None = None,
              save_trajectories: bool = False, batch: bool = True, progress: bool | None = None, force: bool = False,
              stop_after: int | None = None):
    """Run a sweep of ``scene`` and return its table (``pyarrow.Table``, one row per variant, by variant index).

    Args:
        scene: a scene file path (TOML or JSON, may hold a ``[sweep]`` table) or a scene document (dict).
        vary: ``{key: spec}`` or a list of ``"KEY=SPEC"`` strings (``tumble.sweep.spec``); added to the
            scene's ``[sweep] vary`` (these win for the same key).
        samples: N random variants (needs at least one ``uniform``/``normal`` spec); None: the full grid.
        seed: random seed (default 0 with ``samples``). The same sweep and seed give the same table.
        out: output folder (``sweep.json``, ``parts/``, ``results.parquet``, ``runs/``); None keeps
            everything in memory (no resume). A folder holding the same sweep resumes it: finished
            chunks are not run again. A folder holding another sweep is an InputError unless ``force``.
        client: a ``dask.distributed.Client`` to run the tasks on.
        metrics: metric names (``tumble.sweep.metrics``); default the [sweep] list, else energy drift
            and the final position and orientation of the moving bodies.
        scheduler: address of a running Dask scheduler, ``tcp://host:port`` (instead of ``client``).
        workers: worker processes of the default LocalCluster (default: the core count);
            0 runs every task in this process.
        chunk_size: variants per task (default the [sweep] ``chunk_size``, else 200); batchable
            variants of a task are stepped in one World.
        save_trajectories: write each variant's trajectory to ``out/runs/variant-NNNNNNN.npz``
            (the workers must see ``out``).
        batch: batch variants within a task (False: every variant runs alone; same numbers).
        progress: tqdm bar (done, failed, running tasks); None: only on a terminal.
        force: discard the results of another sweep in ``out``.
        stop_after: run at most this many chunks in this call, then return the rows so far
            (the folder resumes later); for tests and for chunked use.

    Raises:
        InputError: bad scene, key path, spec, metric or option (before anything runs).
    """
    import pyarrow  # noqa: F401 - a clear ImportError before anything runs

    sd = SweepDefinition(scene, vary, samples, seed, metrics, chunk_size, batch)
    schema = sd.schema()
    chunks = sd.chunks()
    out_dir = None if out is None else Path(out)
    done_tables: dict[int, object] = {}
    if out_dir is not None:
        done_tables = _prepare_folder(out_dir, sd, schema, chunks, force)
        if save_trajectories:
            (out_dir / "runs").mkdir(parents=True, exist_ok=True)
            sd.plan.runs_dir = str((out_dir / "runs").resolve())
    elif save_trajectories:
        raise InputError("needs an output folder (out=...)", "--save-trajectories")
    todo = deque(c for c in range(len(chunks)) if c not in done_tables)
    if stop_after is not None:
        todo = deque(list(todo)[: max(0, int(stop_after))])
    lost: dict[int, list] = {}
    state = _Progress(sd.count, sum(len(chunks[c]) for c in done_tables), _failed_count(done_tables.values()), progress)

    def finished(c: int, rows: list[dict] | None, error: str | None = None):
        if rows is None:  # the task itself was lost (workers died): not persisted, run again on resume
            rows = [_lost_row(sd, i, values, error) for i, values in chunks[c]]
            lost[c] = rows
            state.update(len(rows), len(rows))
            return
        table = _to_table(rows, schema)
        if out_dir is not None:
            _write_parquet_atomic(table, part_path(out_dir, c))
        done_tables[c] = table
        state.update(len(rows), sum(r["status"] != "ok" for r in rows))

    try:
        if todo:
            if client is None and scheduler is None and workers == 0:
                for c in todo:
                    state.running(1)
                    finished(c, run_chunk(sd.plan, chunks[c]))
            else:
                _run_dask(sd.plan, chunks, todo, finished, state, client, scheduler, workers)
    finally:
        state.close()
    tables = [done_tables[c] for c in sorted(done_tables)] + [_to_table(rows, schema) for rows in lost.values()]
    table = gather(tables, schema)
    if out_dir is not None and len(done_tables) == len(chunks):
        _write_parquet_atomic(table, out_dir / "results.parquet")
    return table


def _failed_count(tables) -> int:
    import pyarrow.compute as pc

    return sum(int(pc.sum(pc.not_equal(t["status"], "ok")).as_py() or 0) for t in tables)


def _lost_row(sd, index, values, error) -> dict:
    row = {"variant": index, **{k: values[k] for k in sd.keys}}
    row.update({c: math.nan for c in sd.plan.metric_columns})
    row.update({"status": "failed", "error_kind": "worker", "error": error, "state_hash": None, "wall_time_s": 0.0, "batch_size": 0})
    return row


def _prepare_folder(out: Path, sd: SweepDefinition, schema, chunks, force: bool) -> dict:
    if out.exists() and not out.is_dir():
        raise InputError("exists and is not a folder (choose another --out)", None, str(out))
    meta = out / "sweep.json"
    if meta.exists() and not force:
        try:
            old = json.loads(meta.read_text())
        except (OSError, ValueError):
            raise InputError("holds an unreadable sweep.json (pass --force to start over)", None, str(meta)) from None
        if old != sd.identity:
            diff = [k for k in sd.identity if old.get(k) != sd.identity.get(k)] if isinstance(old, dict) else ["format"]
            raise InputError(f"holds the results of a different sweep ({', '.join(diff)} differ); pass --force to start over "
                             f"or choose another --out", None, str(out))
    elif force:
        for name in ("parts", "runs"):
            shutil.rmtree(out / name, ignore_errors=True)
        (out / "results.parquet").unlink(missing_ok=True)
    elif out.exists() and any(p.name in ("parts", "results.parquet") for p in out.iterdir()):
        raise InputError("holds sweep results without sweep.json; pass --force to start over or choose another --out", None, str(out))
    out.mkdir(parents=True, exist_ok=True)
    if not meta.exists() or force:
        tmp = meta.with_name(".sweep.json.tmp")
        tmp.write_text(json.dumps(sd.identity, indent=1))
        os.replace(tmp, meta)
    done = {}
    for c, chunk in enumerate(chunks):
        p = part_path(out, c)
        if p.exists():
            t = _read_part(p, schema, len(chunk))
            if t is not None:
                done[c] = t
    return done


class _Progress:
    """tqdm bar of variants done, with failed and running-task counts."""

    def __init__(self, total: int, done: int, failed: int, progress):
        self.failed = failed
        self.active = 0
        self.bar = None
        if progress or (progress is None and sys.stderr.isatty()):
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=done, unit="variant", desc="sweep", file=sys.stderr, dynamic_ncols=True)
            self._show()

    def _show(self):
        if self.bar is not None:
            self.bar.set_postfix_str(f"failed={self.failed} running={self.active} tasks", refresh=False)

    def running(self, active: int):
        self.active = active
        self._show()
        if self.bar is not None:
            self.bar.refresh()

    def update(self, done: int, failed: int):
        self.failed += failed
        self._show()
        if self.bar is not None:
            self.bar.update(done)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _check_reachable(address: str):
    """InputError at once when nothing listens at a tcp:// address (Dask would retry for its whole timeout)."""
    import socket
    from urllib.parse import urlsplit

    try:
        u = urlsplit(address if "://" in address else f"tcp://{address}")
        host, port = u.hostname, u.port
    except ValueError:
        raise InputError(f"expected a scheduler address tcp://HOST:PORT, got {address!r}", "--scheduler") from None
    if u.scheme not in ("tcp", "tls") or not host or not port:
        raise InputError(f"expected a scheduler address tcp://HOST:PORT, got {address!r}", "--scheduler")
    if u.scheme != "tcp":
        return
    try:
        with socket.create_connection((host, port), timeout=5):
            pass
    except OSError as exc:
        raise InputError(f"cannot connect to the Dask scheduler at {address} ({exc.strerror or exc})", "--scheduler") from None


logger = logging.getLogger("tumble.sweep")


def run_chunk_on_worker(plan: Plan, chunk: list, numba_threads: int | None = None):
    """``run_chunk`` as a Dask task: (rows, the Numba thread count the chunk ran with). With
    ``numba_threads`` the task's thread runs Numba's parallel kernels on that many threads
    (``numba.set_num_threads``: per thread, so here, in the thread that runs the task; set back
    after). The sweep's own LocalCluster asks for 1: its workers are one per core, and Numba's
    default (a thread per core in each worker) oversubscribes the cores, whose parallel regions then
    wait on descheduled threads (4-28x slower measured, docs/sweeps.md). The results do not depend
    on the thread count (docs/reliability.md)."""
    import numba

    before = numba.get_num_threads()
    if numba_threads is not None:
        numba.set_num_threads(min(int(numba_threads), numba.config.NUMBA_NUM_THREADS))
    try:
        rows = run_chunk(plan, chunk)
        return rows, numba.get_num_threads()
    finally:
        numba.set_num_threads(before)


def _run_dask(plan, chunks, todo: deque, finished, state: _Progress, client, scheduler, workers):
    from distributed import Client, LocalCluster, as_completed

    own_cluster = own_client = None
    numba_threads = None  # Numba's default on a cluster of the caller's (docs/sweeps.md)
    seen_threads: set = set()
    where: dict = {}
    try:
        if client is None:
            if scheduler is not None:
                _check_reachable(scheduler)
                try:
                    client = own_client = Client(scheduler, timeout="10s")
                except (OSError, TimeoutError, ValueError) as exc:
                    raise InputError(f"cannot connect to the Dask scheduler at {scheduler} ({type(exc).__name__}: "
                                     f"{' '.join(str(exc).split())})", "--scheduler") from None
            else:
                n = workers or os.cpu_count() or 1
                own_cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                                           silence_logs=logging.ERROR)
                client = own_client = Client(own_cluster)
                numba_threads = 1  # one worker per core: one Numba thread each (run_chunk_on_worker)
        slots = max(2, 2 * max(1, len(client.scheduler_info().get("workers", {})) or 1))
        ac = as_completed()

        def submit():
            c = todo.popleft()
            fut = client.submit(run_chunk_on_worker, plan, chunks[c], numba_threads, pure=False)
            where[fut] = c
            ac.add(fut)

        while todo and len(where) < slots:
            submit()
        state.running(len(where))
        for fut in ac:
            c = where.pop(fut)
            try:
                rows, threads = fut.result()
            except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker: the chunk is lost, not its sweep
                fut.release()
                finished(c, None, f"task lost: {type(exc).__name__}: {' '.join(str(exc).split())}")
            else:
                fut.release()
                seen_threads.add(threads)
                finished(c, rows)
            while todo and len(where) < slots:
                submit()
            state.running(len(where))
        if seen_threads:
            logger.info("sweep: Dask tasks ran Numba on %s thread(s)", "/".join(map(str, sorted(seen_threads))))
    finally:
        if where and client is not None:  # interrupted: leave nothing of ours running on the cluster
            with contextlib.suppress(Exception):
                client.cancel(list(where))
        if own_client is not None:
            own_client.close()
        if own_cluster is not None:
            own_cluster.close()
