"""``Simulator.run_to_file``: the frame loop with frames streamed to disk, flushes, checkpoints and signals.

Reads the World through the Simulator; writes ``trajectory.npz`` (``TrajectoryWriter``),
``checkpoint.npz`` and ``summary.json`` in the output folder, each atomically.
Order at every flush: trajectory, then checkpoint, then summary, so that the
trajectory file always holds at least the frames the checkpoint has reached.
"""

from __future__ import annotations

import math
import shutil
import signal
import threading
import time as _time
from pathlib import Path

import numpy as np

from . import checks
from .errors import InputError, SimulationError
from .scene_values import shown
from .trajectory import EnabledLog, TrajectoryWriter, frame_bytes, write_json_atomic

TRAJECTORY, CHECKPOINT, SUMMARY = "trajectory.npz", "checkpoint.npz", "summary.json"
# Without --checkpoint-every, flush (trajectory, checkpoint, summary) after the first frame
# that ends this many wall-clock seconds after the last flush, so that even a SIGKILL of a
# long run leaves a loadable trajectory and a checkpoint to resume from. A flush rewrites the
# trajectory file, so it is not made more often than this.
FLUSH_WALL_SECONDS = 60.0


def stream_run(sim, out_dir, duration, frame_rate, *, checkpoint_every=None, progress=None, handle_signals=False,
               summary=None, resume=False, run_info=None):
    from .recording import RunResult, frame_values, static_values

    out = Path(out_dir)
    w = sim.world
    plan = check_run(sim, out, duration, frame_rate, checkpoint_every=checkpoint_every, resume=resume)
    steps_per_frame, per_flush, remaining = plan["steps_per_frame"], plan["per_flush"], plan["remaining"]
    meta, recorded, fig, t_start = plan["meta"], plan["recorded"], plan["figures"], plan["t_start"]
    if not resume:
        t_start = w.t
        fig = {"energy_initial": None, "energy_final": None, "max_orthonormality_error": 0.0, "wall_time_s": 0.0}

    sensing = sim._sensing()
    # the bodies fixed at every frame so far: a resumed run's earlier frames are in its checkpoint
    fixed_so_far = meta.get("fixed") if resume else None
    fixed = None if fixed_so_far is None else np.asarray(fixed_so_far, dtype=bool) & w.fixed
    writer = TrajectoryWriter(out / TRAJECTORY, static_values(w, fixed), w.body_count, keep_frames=recorded if resume else None,
                              contacts=sim.record_contacts, joints=len(w.joints) if sim.record_joints else None,
                              sensors=int(w.sensor.sum()) if sensing else None)
    # the bodies disabled and enabled so far (Trajectory.enabled_changes): a resumed run's earlier
    # rows are in its checkpoint's run record
    enabled_log = EnabledLog(w.body_count, (meta.get("enabled_changes") or ()) if resume else ())
    enabled_log.truncate(recorded)
    if enabled_log.rows:
        writer.static["enabled_changes"] = enabled_log.array()
    state = {"stop": None, "wall0": fig["wall_time_s"], "started": _time.perf_counter()}
    state["last_flush"] = state["started"]

    def record():
        values = frame_values(w)
        writer.static["fixed"] &= w.fixed  # fixed at every frame: a body whose type changed moved
        if enabled_log.observe(writer.frames, sim.shown_disabled()):
            writer.static["enabled_changes"] = enabled_log.array()
        if sim.record_contacts:
            values["contacts"] = sim.contacts()
            values["contact_count"] = len(values["contacts"])
        if sim.record_joints:
            values.update(sim.joint_frame())
        if sensing:
            values["sensor_visitors"] = sim.sensor_frame()
        writer.append(values)
        e = float(values["kinetic_energy"] + values["potential_energy"])
        if fig["energy_initial"] is None:
            fig["energy_initial"] = e
        fig["energy_final"] = e
        fig["max_orthonormality_error"] = max(fig["max_orthonormality_error"], float(values["orthonormality_error"]))

    def flush(status, error=None, signal_name=None):
        state["last_flush"] = _time.perf_counter()
        fig["wall_time_s"] = state["wall0"] + (state["last_flush"] - state["started"])
        writer.flush()
        run = {"t_start": t_start, "frames": writer.frames, "fixed": writer.static["fixed"].tolist(), "enabled_changes": enabled_log.rows, "duration": float(duration), "frame_rate": float(frame_rate),
               "checkpoint_every": checkpoint_every, "figures": fig, "info": run_info}
        sim.save_checkpoint(out / CHECKPOINT, run=run)
        result = RunResult(
            status=status, frames=writer.frames, steps=int(sim.stats["steps"]), wall_time_s=fig["wall_time_s"],
            energy_initial=fig["energy_initial"], energy_final=fig["energy_final"],
            max_orthonormality_error=fig["max_orthonormality_error"], state_hash=checks.state_hash(w), t=w.t,
            out_dir=out, error=error, signal=signal_name, largest_penetration_m=sim.largest_penetration,
        )
        write_json_atomic(out / SUMMARY, summary(result) if summary is not None else {"run": result.figures(), "settings": sim.settings()})
        return result

    def after_frame():
        if state["stop"] is None:
            if per_flush is not None:
                due = (writer.frames - 1) % per_flush == 0
            else:
                due = _time.perf_counter() - state["last_flush"] >= FLUSH_WALL_SECONDS
            if due:
                flush("running")
        return state["stop"] is not None

    if not resume:
        w.update_derived()
        sim._reset_energy_reference()
        sim.stats["lowest_separation"] = None  # largest_penetration: this run's (a resumed run's is in its checkpoint)
        sim._sense_now()
        record()
    elif sim.energy_reference is None:
        sim._reset_energy_reference()

    previous = _install_handlers(state) if handle_signals else {}
    try:
        try:
            sim._loop(remaining, steps_per_frame, record, progress, after_frame)
        except SimulationError as err:
            flush("failed", error=" ".join(str(err).split()))
            writer.close()
            raise
        except KeyboardInterrupt:
            flush("interrupted", signal_name="SIGINT")
            writer.close()
            raise
        sim.stats["wall_time_s"] = _time.perf_counter() - state["started"]
        if state["stop"] is not None:
            result = flush("interrupted", signal_name=signal.Signals(state["stop"]).name)
            writer.close()
        else:
            result = flush("completed")
            writer.close(remove_parts=True)
        return result
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def check_run(sim, out_dir, duration, frame_rate, *, checkpoint_every=None, resume=False) -> dict:
    """Every check that can refuse ``stream_run`` (InputError), made before anything is written or
    removed: the frame plan, ``checkpoint_every``, a resumed run's record (``read_run_record``) and
    progress against ``duration``, the disk the trajectory needs. Writes nothing; ``tumble run``
    calls it before it writes the scene copy or removes the replaced run's media, so a refused run
    leaves the output folder as it was (and a new one uncreated). Returns the plan: ``total``
    frames, ``steps_per_frame``, ``per_flush``, ``remaining`` frames to run and, for ``resume``,
    the record's ``meta``, ``recorded`` frames, ``figures`` and ``t_start`` (else None, 0, None, None)."""
    out = Path(out_dir)
    w = sim.world
    meta, recorded, fig, t_start = None, 0, None, None
    if resume:  # the record first: a damaged one is named as the checkpoint's, not as a setting
        meta = read_run_record(sim.checkpoint_run, out / CHECKPOINT, w.body_count, progress=True)
        recorded, fig, t_start = meta["frames"], dict(meta["figures"]), meta["t_start"]
    total, steps_per_frame = sim._frame_plan(duration, frame_rate)
    if checkpoint_every is not None:
        if not (isinstance(checkpoint_every, (int, float)) and not isinstance(checkpoint_every, bool)
                and math.isfinite(checkpoint_every) and checkpoint_every > 0):
            raise InputError(f"must be a positive number of seconds, got {checkpoint_every!r}", "--checkpoint-every")
        per_flush = max(1, int(round(checkpoint_every * float(frame_rate))))
    else:
        per_flush = None
    remaining = total - max(recorded - 1, 0)
    if remaining < 0:
        raise InputError(f"the run has already reached t = {w.t:g} s, past its requested duration ({float(duration):g} s)", "--duration")
    _check_disk(out, (total + 1) * frame_bytes(w.body_count))
    return {"total": total, "steps_per_frame": steps_per_frame, "per_flush": per_flush, "remaining": remaining,
            "meta": meta, "recorded": recorded, "figures": fig, "t_start": t_start}


# The run record run_to_file keeps in its checkpoint (``meta.run``): key -> (test, what it must be).
# ``info`` (tumble run's: the scene and its settings) is the caller's, checked by the CLI.
def _number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _count(v):
    return isinstance(v, int) and not isinstance(v, bool) and v >= 0


def _positive(v):
    return _number(v) and v > 0


def _figure(v):  # a figure of a failed run may be inf or nan (JSON's NaN, Infinity): still a number
    return v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))


FIGURES = {"energy_initial": (_figure, "a number or null"), "energy_final": (_figure, "a number or null"),
           "max_orthonormality_error": (lambda v: v is not None and _figure(v), "a number"),
           "wall_time_s": (_number, "a finite number")}
RUN_RECORD = {"t_start": (_number, "a finite number"), "frames": (lambda v: _count(v) and v >= 1, "a whole number of frames, at least 1"),
              "duration": (_positive, "a positive finite number of seconds"),
              "frame_rate": (_positive, "a positive finite number of frames per second"),
              "checkpoint_every": (lambda v: v is None or _positive(v), "a positive finite number of seconds or null")}


def read_run_record(run, path, body_count: int, progress: bool = False) -> dict:
    """The run record of the checkpoint at ``path`` (``meta.run``), checked: a JSON object with
    ``duration``, ``frame_rate``, ``checkpoint_every`` and, with ``progress`` (what ``stream_run``
    resumes from), ``t_start``, ``frames``, ``figures`` (``FIGURES``), ``fixed`` (null or one bool
    per body) and ``enabled_changes`` (rows [frame, body, enabled]). InputError
    ``PATH: run.KEY: problem`` for a missing or damaged entry: nothing is written before it."""
    path = str(path)
    if not isinstance(run, dict):
        raise InputError("not the checkpoint of a tumble run (its run record is "
                         f"{'missing' if run is None else 'not a table'})", "run", path)
    keys = ["duration", "frame_rate", "checkpoint_every"]
    if progress:
        keys = ["t_start", "frames"] + keys
    for key in keys:
        if key not in run:
            raise InputError("missing (the checkpoint was not written by run_to_file, or is damaged)", f"run.{key}", path)
        test, what = RUN_RECORD[key]
        if not test(run[key]):
            raise InputError(f"must be {what}, got {shown(run[key])}", f"run.{key}", path)
    if not progress:
        return run
    figures = run.get("figures")
    if not isinstance(figures, dict):
        raise InputError("missing" if figures is None else f"must be a table of the run's figures, got {shown(figures)}",
                         "run.figures", path)
    for key, (test, what) in FIGURES.items():
        if key not in figures:
            raise InputError("missing", f"run.figures.{key}", path)
        if not test(figures[key]):
            raise InputError(f"must be {what}, got {shown(figures[key])}", f"run.figures.{key}", path)
    fixed = run.get("fixed")
    if fixed is not None:
        if not (isinstance(fixed, list) and all(isinstance(f, bool) for f in fixed)):
            raise InputError("must be a list of true/false, one per body", "run.fixed", path)
        if len(fixed) != body_count:
            raise InputError(f"lists {len(fixed)} bodies, the checkpoint's world {body_count}", "run.fixed", path)
    changes = run.get("enabled_changes")
    if changes is not None:
        if not isinstance(changes, list):
            raise InputError(f"must be a list of [frame, body, enabled] rows, got {shown(changes)}", "run.enabled_changes", path)
        for i, row in enumerate(changes):
            if not (isinstance(row, list) and len(row) == 3 and all(_count(v) for v in row[:2])
                    and row[1] < body_count and (isinstance(row[2], bool) or row[2] in (0, 1))):
                raise InputError(f"must be [frame, body, enabled] (body below {body_count}), got {shown(row)}",
                                 f"run.enabled_changes[{i}]", path)
    return run


def _install_handlers(state) -> dict:
    """SIGINT and SIGTERM set ``state["stop"]``; the loop stops after the current frame."""
    if threading.current_thread() is not threading.main_thread():
        return {}

    def handler(signum, frame):
        state["stop"] = signum

    return {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}


def _check_disk(out: Path, trajectory_bytes: int):
    """InputError when the trajectory (twice: frame data and assembled file) cannot fit on the disk."""
    probe = out
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    try:
        free = shutil.disk_usage(probe).free
    except OSError:
        return
    need = 2 * trajectory_bytes
    if need > free:
        raise InputError(f"the trajectory would need about {checks.fmt_bytes(need)} of disk, {checks.fmt_bytes(free)} free "
                         f"(shorten the run or lower frame_rate)", None, str(out))
