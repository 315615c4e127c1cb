"""The task of a sweep: run one chunk of variants and return their rows.

``run_chunk(plan, chunk)`` is the only function the executors call, whether
in this process, in local worker processes or on a remote Dask cluster, so
every executor runs the same code. A chunk is a list of ``(variant index,
values)``; each variant's scene document is the plan's base document with the
values set at their key paths, parsed by ``tumble.scene.parse_scene`` (so a bad
value is an ``InputError`` of that variant only). Batchable variants of the
chunk run together (``batch.run_batched``), the others one by one.
"""

from __future__ import annotations

import copy
import math
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import InputError, SimulationError
from ..scene import parse_scene
from . import batch as B
from .spec import set_path


@dataclass
class Plan:
    """Everything a task needs (plain data: it travels to the workers with each task).

    base: the scene document without its [sweep] table. file: the name used in error
    messages. base_dir: folder for relative mesh paths. keys / paths: the varied key
    paths as given and as canonical paths. metrics: ``Metric`` records. runs_dir:
    where trajectory files go (None: not kept). batch: batch variants when possible.
    """

    base: dict
    file: str | None
    base_dir: str
    keys: list
    paths: list
    metrics: list = field(default_factory=list)
    runs_dir: str | None = None
    batch: bool = True

    @property
    def metric_columns(self) -> list[str]:
        return [c for m in self.metrics for c in m.columns]


def _copy_document(x):
    """A copy of a parsed TOML/JSON document (dicts and lists copied, values shared: they are immutable)."""
    if isinstance(x, dict):
        return {k: _copy_document(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_copy_document(v) for v in x]
    return copy.deepcopy(x) if not isinstance(x, (str, int, float, bool, type(None))) else x


def variant_document(plan: Plan, values: dict) -> dict:
    """The scene document of one variant."""
    data = _copy_document(plan.base)
    for key, path in zip(plan.keys, plan.paths):
        set_path(data, path, values[key])
    return data


def build_scene(plan: Plan, values: dict):
    return parse_scene(variant_document(plan, values), plan.file, plan.base_dir)


def trajectory_path(runs_dir, index: int) -> Path:
    return Path(runs_dir) / f"variant-{index:07d}.npz"


def run_chunk(plan: Plan, chunk: list) -> list[dict]:
    """Rows (dicts) of the variants of ``chunk`` (list of (index, {key: value})), in chunk order."""
    rows: dict[int, dict] = {}
    groups: dict = {}
    scenes: dict[int, object] = {}
    for index, values in chunk:
        started = time.perf_counter()
        try:
            scene = build_scene(plan, values)
        except InputError as err:
            rows[index] = _failed(plan, index, values, "input", err, time.perf_counter() - started)
            continue
        except Exception as exc:  # noqa: BLE001 - recorded, never stops the sweep
            rows[index] = _failed(plan, index, values, "internal", exc, time.perf_counter() - started)
            continue
        scenes[index] = scene
        key = B.batch_key(scene) if plan.batch else None
        groups.setdefault(key if key is not None else ("single", index), []).append(index)
    keep = plan.runs_dir is not None
    for key, members in groups.items():
        values_of = dict(chunk)
        try:
            outcomes = B.run_batched([scenes[i] for i in members], plan.metrics, keep)
        except Exception as exc:  # noqa: BLE001
            outcomes = [exc] * len(members)
        for i, got in zip(members, outcomes):
            if isinstance(got, B.Outcome):
                if keep and got.trajectory is not None:
                    got.trajectory.save(trajectory_path(plan.runs_dir, i))
                rows[i] = _row(plan, i, values_of[i], got.values, "ok", None, None, got.state_hash, got.wall_time_s, got.batch_size)
            else:
                kind = "simulation" if isinstance(got, SimulationError) else "input" if isinstance(got, InputError) else "internal"
                rows[i] = _failed(plan, i, values_of[i], kind, got, 0.0)
    return [rows[index] for index, _ in chunk]


def _row(plan, index, values, metric_values, status, kind, error, state_hash, wall, batch_size) -> dict:
    row = {"variant": int(index)}
    row.update({k: values[k] for k in plan.keys})
    for c in plan.metric_columns:
        row[c] = metric_values.get(c, math.nan)
    row.update({"status": status, "error_kind": kind, "error": error, "state_hash": state_hash,
                "wall_time_s": float(wall), "batch_size": int(batch_size)})
    return row


def _failed(plan, index, values, kind, err, wall) -> dict:
    if kind == "internal":
        last = traceback.extract_tb(err.__traceback__)[-1:] if err.__traceback__ else []
        where = f" at {last[0].filename}:{last[0].lineno}" if last else ""
        text = f"{type(err).__name__}: {err}{where}"
    else:
        text = str(err)
    return _row(plan, index, values, {}, "failed", kind, " ".join(text.split()), None, wall, 1)
