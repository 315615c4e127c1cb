"""A simulation's state in memory: ``Simulator.save_state`` and ``Simulator.restore_state``.

PyBullet's ``saveState`` / ``restoreState`` and MuJoCo's ``mj_getState`` / ``mj_setState`` for
tumble: take the state of a running simulation, try something (push a body, change a motor's
target, step ahead), and put the state back; the steps after a restore are bit-identical to
those the simulation would have taken from the save (model predictive control, search over
actions, resets of a learning environment, "what if" branches of one run).

What is saved is what a checkpoint file saves of the run (``tumble.checkpoint``), without the
world's description, which stays where it is: the bodies' state (x, q and R, P, L), the
kinematic bodies' velocities, the time and step index, the joints broken so far, the impulses
already applied, the bodies to wake at the next step, and what the next step reads from the
steps before: the contact solver's warm start, the sleep timers and flags, the joint solver's
warm start and coordinates, the touching pairs of the contact events and the sensors' overlaps.

A restore makes the simulation's contact pipeline anew, as ``Simulator.load_checkpoint`` does,
and gives it the saved arrays: the continuation is then the checkpoint's resumed run, which the
reliability tests hold to the uninterrupted run's bits. The new pipeline keeps the old one's
shape table (the world's description: the costly part of a new one); its other buffers are made
by the next step, which is the restore's cost beyond copying arrays (docs/benchmarks.md
"snapshots").
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from .checkpoint import KINEMATIC, STATE, _restore_logs, _restore_solvers, _solver_arrays, _solver_parts
from .errors import InputError


@dataclass(frozen=True, eq=False)
class SimState:
    """A Simulator's state at one time (``Simulator.save_state``); plain data: it pickles, so a
    state can go to another process and be restored there into an equal simulation.

    Attributes:
        t: s, the world's time.
        step_index: steps taken since t = 0 (t = step_index * dt).
        dt: s, the step of the simulator it came from (a restore needs the same).
        layout: the world's state layout ("quaternion" or "matrix").
        body_count, joint_count: the size of the world it came from (a restore needs the same).
        arrays: name -> a copy: the bodies' state ``x`` (N, 3) m, ``q`` (N, 4), ``R`` (N, 3, 3),
            ``P`` (N, 3) kg m/s, ``L`` (N, 3) kg m^2/s (world frame); the kinematic bodies'
            flags and velocities; and the solvers' arrays (``contact_*``, ``sleep_*``,
            ``joint_*``: ``checkpoint._solver_arrays``).
        broken: (J,) bool per joint: broken at the save.
        applied_impulses: the ``Impulse`` force records (by index) already applied.
        wake_requests: the bodies pushed, moved or placed since the last step (``World.
            wake_requests``): the next step wakes them.
        stats: the simulator's step counts.
        energy_reference: the current run's energy reference (the blow-up check's), or None.
        contact_touching: the touching pairs of the contact events, when they are on.
        sensor_pairs: (K, 2) the (sensor, visitor) overlaps, when the world has sensors.
        paths: the kinematic bodies' keyframed paths, as (body row, ``KeyframePath.to_dict()``):
            with the bodies' types (``moving``, ``kinematic`` and their mass rows in ``arrays``),
            what a restore puts back for a body whose type changed since the save (a path that
            let its body go, or ``World.set_body_type``).
    """

    t: float
    step_index: int
    dt: float
    layout: str
    body_count: int
    joint_count: int
    arrays: dict = field(repr=False)
    broken: tuple = field(repr=False)
    applied_impulses: frozenset = field(repr=False)
    wake_requests: frozenset = field(repr=False)
    stats: dict = field(repr=False)
    energy_reference: list | None = field(repr=False)
    contact_touching: list | None = field(repr=False)
    sensor_pairs: np.ndarray | None = field(repr=False)
    paths: tuple = field(default=(), repr=False)


# a body's type and the mass rows that go with it (World.set_body_type): put back for the bodies
# whose type differs at a restore (the others keep theirs: a mass set since stays)
TYPE_ARRAYS = ("moving", "kinematic", "mass", "inv_mass", "inertia_body", "inertia_body_inv", "principal_q",
               "principal_moments", "dynamic_mass", "kinematic_v", "kinematic_omega",
               "disabled", "held_type", "held_v", "held_omega")  # World.set_enabled's


def capture_types(w) -> tuple[dict, tuple]:
    """(copies of the ``TYPE_ARRAYS`` and of the joints a disabled body switched off, the keyframed
    paths as (body row, ``to_dict()``)): what ``put_types_back`` needs (a snapshot's, or a step
    call's that may change types)."""
    arrays = {name: np.array(getattr(w, name), order="C") for name in TYPE_ARRAYS}
    arrays["switched_off_joints"] = np.array(sorted(w.joints_switched_off), dtype=np.int64)
    return arrays, tuple((w.index_of(p.body), p.to_dict()) for p in w.paths)


def save_state(sim) -> SimState:
    """``Simulator.save_state``: copies of everything the steps after now read (module docstring)."""
    w = sim.world
    arrays = {name: np.array(getattr(w, name), order="C") for name in STATE + KINEMATIC}
    types, paths = capture_types(w)
    arrays.update(types)
    arrays.update(_solver_arrays(sim))
    sensors = sim._sensor_log
    return SimState(
        t=float(w.t), step_index=int(sim.step_index), dt=float(sim.dt), layout=w.layout,
        body_count=int(w.body_count), joint_count=len(getattr(w, "joints", ())), arrays=arrays,
        broken=tuple(bool(j.broken) for j in getattr(w, "joints", ())),
        applied_impulses=frozenset(int(k) for k in w.applied_impulses),
        wake_requests=frozenset(int(k) for k in w.wake_requests),
        stats=dict(sim.stats), energy_reference=copy.deepcopy(sim.energy_reference),
        contact_touching=sim._event_log.pairs() if sim._event_log is not None else None,
        sensor_pairs=None if sensors is None else np.array(sensors.pairs),
        paths=paths)


def restore_state(sim, state: SimState, keep_table: bool = True) -> None:
    """``Simulator.restore_state``: put ``state`` back into ``sim`` and its world, in place.
    ``keep_table=False`` builds the new pipeline's shape table anew too (a body's type changed:
    ``Simulator._take_type_changes``; the table holds which bodies move).

    Raises:
        InputError: ``state`` is not a ``SimState``, or was saved from a world of another size
            or layout or a simulator of another dt (one line, key ``state``).
    """
    if not isinstance(state, SimState):
        raise InputError(f"must be a SimState from Simulator.save_state, got {type(state).__name__}", "state")
    w = sim.world
    joints = getattr(w, "joints", [])
    here = (w.body_count, len(joints), w.layout)
    if (state.body_count, state.joint_count, state.layout) != here:
        raise InputError(f"was saved from a world of {state.body_count} bodies and {state.joint_count} joints "
                         f"({state.layout} layout); this one has {here[0]} bodies and {here[1]} joints "
                         f"({here[2]} layout)", "state")
    if state.dt != sim.dt:
        raise InputError(f"was saved by a simulator stepping dt = {state.dt} s; this one steps {sim.dt} s", "state")
    # a state saved before types could change (no ``moving`` array) changes none
    retyped = "moving" in state.arrays and put_types_back(w, state.arrays, state.paths)
    for name in STATE + KINEMATIC:
        getattr(w, name)[...] = state.arrays[name]
    for joint, broken in zip(joints, state.broken):
        object.__setattr__(joint, "broken", broken)  # the saved state (the solver's enabled comes back too)
    w.t = state.t
    w.applied_impulses = set(state.applied_impulses)
    w.wake_requests = set(state.wake_requests)
    w.update_derived()
    sim.step_index = state.step_index
    sim.stats = dict(state.stats)
    sim.energy_reference = copy.deepcopy(state.energy_reference)
    # The pipeline and the logs are made anew and given the saved arrays, exactly as a loaded
    # checkpoint's are (checkpoint.load_checkpoint): the continuation is the resumed run's.
    # NOTE: keeping the pipeline and putting the saved arrays into it gave the same bits on
    # tests/test_snapshot.py's scenes too (its caches are refreshed from the state each step),
    # but that is a property of today's caches, which nothing holds it to; made anew, it takes
    # the loaded checkpoint's path, which the reliability tests hold to the bits in every scene.
    old = sim.soft_step
    sim.soft_step = None
    if old is not None:
        sim.soft_step = sim._new_soft_step()
        if keep_table and not retyped:
            sim.soft_step.pipeline.take_table(old.pipeline)
    sim._type_changes_seen = len(w.type_changes)  # the stages are made anew from the types as they are
    sim.sleep = None
    sim._sensor_log = None
    if sim._event_log is not None:
        sim._event_log = type(sim._event_log)()
    _restore_logs(sim, state.contact_touching, None if state.sensor_pairs is None else state.sensor_pairs.tolist())
    warm, sleep, joint_state = _solver_parts(list(state.arrays), lambda name: state.arrays[name].copy())
    _restore_solvers(sim, warm, sleep, joint_state)


def put_types_back(w, arrays: dict, paths) -> bool:
    """Put back the type of each body whose type differs from ``arrays``' (``capture_types``: the
    ``TYPE_ARRAYS`` rows) and the keyframed path it had then (``paths``; a path that let its body
    go since goes again at its last key); paths of those bodies added since are dropped. Returns
    whether any body's type changed."""
    from .kinematic import KeyframePath

    if "switched_off_joints" in arrays:
        w.joints_switched_off = {int(k) for k in arrays["switched_off_joints"]}
    changed = (arrays["moving"] != w.moving) | (arrays["kinematic"] != w.kinematic)
    if "disabled" in arrays:
        changed |= arrays["disabled"] != w.disabled
    if not changed.any():
        return False
    rows = np.flatnonzero(changed)
    for name in TYPE_ARRAYS:
        getattr(w, name)[rows] = arrays[name][rows]
    back = set(rows.tolist())
    w.paths = [p for p in w.paths if w.index_of(p.body) not in back]
    w.paths.extend(KeyframePath(body=row, **record) for row, record in paths if row in back)
    w._retyped(rows)
    return True
