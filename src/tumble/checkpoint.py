"""Checkpoint files: a World and its Simulator, saved so that a continuation is bit-identical.

A checkpoint is an .npz (loaded with ``allow_pickle=False``) holding:

* ``meta``: JSON text: format and version, the time and step index, the world's
  layout and gravity, per body its name, shape (``shapes.shape_to_dict``),
  material and collision filter, the excluded collision pairs, the force records
  (bodies by name; ``CustomForce`` as a placeholder), the touching pairs of the
  contact events when they are on, the joint records (``_joint_to_dict``: fields, bodies by name, ``broken``, and the
  anchors, axes and parameters they were bound to at creation), the impulses
  already applied, the bodies to wake at the next step, the simulator's settings (joint settings and ``record_joints``
  included), statistics and energy reference, and the caller's ``run`` data
  (``run_to_file`` keeps its progress there);
* the constant arrays (mass, inertia, principal axes, centre-of-mass offsets) and
  the state arrays ``x q R P L`` exactly as they are in memory: the rebuilt World
  takes these bits, not values recomputed from the shapes;
* what the next step reads besides the state: the contact solver's warm start
  (``contact_*``), the sleep state (``sleep_*``) and the joint solver's arrays that
  carry from step to step (``joint_*``, ``JOINT_SOLVER_STATE``).

Loading rebuilds the World body by body, overwrites its arrays with the saved
ones, then runs ``checks.validate_world``; any problem is an ``InputError``.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, fields
from pathlib import Path

import numpy as np

from . import __version__, checks
from .errors import InputError, SimulationError
from .forces import Buoyancy, ConstantForce, CustomForce, Drag, Explosion, Fluid, Impulse, PointForce, Spring, Switch
from .joints import (G_FOLLOWS, G_JOINT, JOINT_CLASSES, JOINT_TYPES, OLD_PARAM_COUNTS, P_BALL_MAX_DRIVE, P_BALL_TARGET,
                     PARAM_COUNT, BoundJoint, edit_count)
from .solver.contact import SoftStepSettings
from .solver.joint_solve import OLD_AXIAL_COUNTS
from .solver.joints import JointSettings
from .shapes import shape_from_dict, shape_to_dict
from .trajectory import write_atomic
from .kinematic import KeyframePath
from .world import Material, World

FORMAT = "tumble-checkpoint"
VERSION = 1
CONSTANTS = ("mass", "inv_mass", "inertia_body", "inertia_body_inv", "principal_q", "principal_moments", "com_offset", "moving",
             "dynamic_mass", "gravity_scale", "damping")
# absent from older checkpoints (dynamic_mass before session 39: World.set_body_type; gravity_scale
# and damping before session 40: World.set_gravity_scale, set_damping): as a new body has them
OPTIONAL_CONSTANTS = ("dynamic_mass", "gravity_scale", "damping")
STATE = ("x", "q", "R", "P", "L")
# kinematic bodies (World.kinematic, their velocities), surface velocities and sensors: absent
# from checkpoints written before they existed, which load with none
# disabled, held_*: the bodies out of the simulation and what they come back as (World.set_enabled;
# absent from checkpoints written before session 40: none disabled)
KINEMATIC = ("kinematic", "kinematic_v", "kinematic_omega", "surface_velocity", "sensor", "disabled", "held_type",
             "held_v", "held_omega")
FORCE_CLASSES = {c.__name__: c for c in (Drag, ConstantForce, PointForce, Spring, Impulse, Explosion, Buoyancy, Fluid,
                                          CustomForce, Switch)}
BODY_FIELDS = ("body", "body_a", "body_b")

# The JointSolver (``sim.soft_step.joints``) arrays saved as ``joint_<name>``, by attribute
# name and whatever their shape: those a step reads from the step before. ``enabled`` (J,)
# bool; ``linear_impulse``, ``angular_impulse`` (J, 3) N s or N m s and ``axial_impulse``
# (J, AXIAL_COUNT) (the warm start: motor, limit, drive and armature rows and the motors' anchor parts); ``position`` (J,) rad or m (a hinge angle is unwrapped around
# it); ``param`` (J, PARAM_COUNT) (writable between steps, e.g. ``set_motor_speed``); and
# the readings of the last step, ``rate`` (J,), ``reaction_force`` (J, 3) N,
# ``reaction_torque`` (J, 3) N m, ``broke`` (J,) bool, so ``joint_readings()`` after a
# load is what it was at the save; ``armature_rate`` (J,) and ``armature_state`` (J, 2, 18): the
# rates the next step's first substep takes as its armature rows' target and the bodies' state
# they were taken at (absent from checkpoints written before session 31: none known, NaN).
JOINT_SOLVER_STATE = ("enabled", "linear_impulse", "angular_impulse", "axial_impulse", "position", "param",
                      "rate", "reaction_force", "reaction_torque", "broke", "armature_rate", "armature_state")
JOINT_SOLVER_OPTIONAL = ("armature_rate", "armature_state")
# Its other arrays, not saved because the next step rebuilds them: the tables read from the
# bound joint records (types, bodies, anchors, frames), the tree solve's forest (from
# ``world.moving`` and ``enabled``) and scratch (refilled in every solve: no factorization
# is kept between steps), the soft step's inverse masses and inertias (passed to every
# ``prepare``), the softness coefficients (from the settings and h), and ``sweep`` (the
# sweep's order, cut from the positions in every ``prepare``). A new JointSolver
# array must go in one of the two lists (tests/test_reliability_joints.py checks).
JOINT_SOLVER_REBUILT = ("joint_type", "joint_a", "joint_b", "local_a", "local_b", "frame_a", "frame_b",
                        "gauss_seidel", "node_joint", "node_body", "node_parent", "node_order",
                        "joint_group", "body_group",  # the tree sweeps' settling groups, with the forest
                        "inv_mass", "I_inv", "soft_bias", "soft_relax", "soft_limit", "rate0")
# fields of a joint record that are not constructor arguments: kept apart in the meta
JOINT_STATE_FIELDS = ("bound", "broken")


def _force_to_dict(world: World, force) -> dict:
    out = {"type": type(force).__name__}
    for f in fields(force):
        value = getattr(force, f.name)
        if f.name == "function":
            continue
        if f.name in BODY_FIELDS:
            value = None if value is None else world.names[world.index_of(value)]
        elif f.name == "bodies":
            value = None if value is None else [world.names[world.index_of(b)] for b in value]
        elif isinstance(value, tuple):
            value = list(value)
        out[f.name] = value
    return out


def _body_name(world, index: int):
    return None if index < 0 else world.names[index]


def _joint_to_dict(world, joint) -> dict:
    """A bound joint record as JSON values: its type, constructor fields (bodies by name,
    None for the world), ``broken``, and ``bound``: the anchors (m), frames and parameter row
    resolved at its creation, which a rebind at the saved poses would not reproduce."""
    b = joint.bound
    out = {"type": joint.kind, "broken": bool(joint.broken)}
    for f in fields(joint):
        if not f.init or f.name in JOINT_STATE_FIELDS:
            continue
        value = getattr(joint, f.name)
        if f.name == "body_a":
            value = _body_name(world, b.body_a)
        elif f.name == "body_b":
            value = _body_name(world, b.body_b)
        elif f.name in ("joint", "follows"):  # a gear's joints: by index in world.joints (its bound row's)
            value = int(b.param[G_JOINT if f.name == "joint" else G_FOLLOWS])
            value = None if value < 0 else value  # a lock follows no joint
        elif isinstance(value, (tuple, list, np.ndarray)):
            value = np.asarray(value, dtype=float).tolist()
        out[f.name] = value
    out["bound"] = {"local_a": b.local_a.tolist(), "local_b": b.local_b.tolist(), "frame_a": b.frame_a.tolist(),
                    "frame_b": b.frame_b.tolist(), "param": b.param.tolist()}
    if math.isfinite(b.length):  # the anchors' distance at creation (an edit of a distance joint's lengths reads it)
        out["bound"]["length"] = float(b.length)
    return out


def _joint_from_dict(world, record, key: str):
    """Inverse of ``_joint_to_dict``: the record, bound as saved (not rebound at the current poses)."""
    if not isinstance(record, dict):
        raise InputError("expected a joint record", key)
    record = dict(record)
    kind = record.pop("type", None)
    cls = JOINT_CLASSES.get(kind) if isinstance(kind, str) else None
    if cls is None:
        raise InputError(f"unknown joint type {kind!r} (expected one of {', '.join(JOINT_CLASSES)})", f"{key}.type")
    broken = record.pop("broken", False)
    bound = record.pop("bound", None)
    if not isinstance(broken, bool):
        raise InputError(f"expected true or false, got {broken!r}", f"{key}.broken")
    if not isinstance(bound, dict):
        raise InputError("missing the bound anchors and frames", f"{key}.bound")
    ends = []
    for side in ("body_a", "body_b"):
        name = record.get(side)
        if name is None:
            ends.append(-1)
        elif isinstance(name, str) and name in world.names:
            ends.append(world.index_of(name))
        else:
            raise InputError(f"unknown body {name!r}", f"{key}.{side}")
    if ends[0] == ends[1]:
        raise InputError("a joint needs two different bodies", f"{key}.body_b")
    names = {f.name for f in fields(cls) if f.init and f.name not in JOINT_STATE_FIELDS}
    for k in record:
        if k not in names:
            raise InputError(f"unknown field of a {kind} joint", f"{key}.{k}")
    if not isinstance(record.get("collide_connected", False), bool):  # read by every step's contact filter
        raise InputError(f"expected true or false, got {record['collide_connected']!r}", f"{key}.collide_connected")
    arrays = {}
    for name, shape in (("local_a", (3,)), ("local_b", (3,)), ("frame_a", (3, 3)), ("frame_b", (3, 3)),
                        ("param", (PARAM_COUNT,))):
        try:
            a = np.array(bound.get(name), dtype=float)
        except (TypeError, ValueError):
            a = None
        if name == "param" and a is not None and a.ndim == 1 and a.shape[0] in OLD_PARAM_COUNTS:
            # older: no effort, no armature, no ball drive (its target quaternion the identity)
            a = _pad_param(a[None, :])[0]
        # param may hold inf (no limit, no force cap); anchors and frames may not
        if a is None or a.shape != shape or np.isnan(a).any() or (name != "param" and not np.isfinite(a).all()):
            raise InputError(f"expected {'x'.join(map(str, shape))} finite numbers", f"{key}.bound.{name}")
        arrays[name] = a
    length = bound.get("length", math.nan)  # (absent: written before session 38, or not known)
    if isinstance(length, bool) or not isinstance(length, (int, float)) or not (math.isnan(length) or length >= 0.0):
        raise InputError(f"expected a length >= 0, got {length!r}", f"{key}.bound.length")
    joint = cls(**record)
    joint.bound = BoundJoint(JOINT_TYPES[kind], ends[0], ends[1], arrays["local_a"], arrays["local_b"],
                             arrays["frame_a"], arrays["frame_b"], arrays["param"], float(length))
    object.__setattr__(joint, "broken", broken)  # the saved state, not an edit (tumble.joints.set_broken)
    return joint


def _joint_solver(sim):
    """The soft step's JointSolver when its tables hold joints, else None."""
    soft = sim.soft_step
    solver = None if soft is None else soft.joints
    return solver if solver is not None and solver.count else None


def save_checkpoint(sim, path, run: dict | None = None) -> Path:
    """``Simulator.save_checkpoint``: write ``sim`` and its world to ``path`` atomically."""
    w = sim.world
    meta = {
        "format": FORMAT,
        "version": VERSION,
        "tumble_version": __version__,
        "t": w.t,
        "step_index": sim.step_index,
        "layout": w.layout,
        "gravity": [float(g) for g in w.gravity],
        "names": list(w.names),
        "shapes": [shape_to_dict(s) for s in w.shapes],
        "materials": [m.to_dict() for m in w.materials],
        "collision_filters": [asdict(f) for f in w.collision_filters],
        "collision_exclusions": sorted([int(a), int(b)] for a, b in w.excluded_collisions),
        # body pairs with a material of their own (World.set_pair_material; absent from older checkpoints)
        "pair_materials": [[int(a), int(b), m.to_dict()] for (a, b), m in sorted(w.pair_materials.items())],
        # keyframed paths of kinematic bodies (tumble.kinematic), by body row
        "kinematic_paths": [{"body": w.index_of(p.body), **p.to_dict()} for p in w.paths],
        # the (sensor, visitor) pairs overlapping after the last step: the resumed run's events go on
        "sensor_pairs": [] if sim._sensor_log is None else sim._sensor_log.pairs.tolist(),
        "forces": [_force_to_dict(w, f) for f in w.forces],
        "joints": [_joint_to_dict(w, j) for j in getattr(w, "joints", ())],
        "applied_impulses": sorted(int(k) for k in w.applied_impulses),
        # the joints switched off by a disabled body (World.set_enabled; absent from older checkpoints)
        "joints_switched_off": sorted(int(k) for k in w.joints_switched_off),
        # bodies pushed, moved or placed since the last step: the next step wakes them (absent
        # from older checkpoints: none)
        "wake_requests": sorted(int(k) for k in w.wake_requests),
        "settings": sim.settings(),
        # the pairs touching after the last step, when contact events are on: the resumed run's
        # first step then begins only new touches, as the whole run's would
        "contact_touching": sim._event_log.pairs() if sim._event_log is not None else None,
        "stats": {k: v for k, v in sim.stats.items()},
        "energy_reference": sim.energy_reference,
        "collisions": bool(getattr(w, "collisions", True)),
        "sleeping": bool(getattr(w, "sleeping", True)),
        "run": run,
    }
    arrays = {name: np.ascontiguousarray(getattr(w, name)) for name in CONSTANTS + STATE + KINEMATIC}
    arrays.update(_solver_arrays(sim))
    arrays["meta"] = np.array(json.dumps(meta, default=_json_default, allow_nan=True))
    return write_atomic(path, lambda fh: np.savez(fh, **arrays))


def _solver_arrays(sim) -> dict:
    """Copies of what the next step reads from the steps before, besides the bodies' state, by
    file name: the contact solver's warm start (``contact_*``: without it a resumed run differs in
    the last bits), the sleep timers and flags (``sleep_*``: a resumed run sleeps when the whole
    one does) and the joint solver's warm start and coordinates (``joint_*``, none before the
    first step: the resumed run starts from zeros too)."""
    arrays = {}
    if sim.soft_step is not None:
        for name, arr in sim.soft_step.solver.warm_start_state().items():
            arrays["contact_" + name] = np.array(arr, order="C")
    if sim.sleep is not None:
        for name, arr in sim.sleep.state().items():
            arrays["sleep_" + name] = np.array(arr, order="C")
    solver = _joint_solver(sim)
    if solver is not None:
        for name in JOINT_SOLVER_STATE:
            arrays["joint_" + name] = np.array(getattr(solver, name), order="C")
    return arrays


def _solver_parts(names, get) -> tuple[dict, dict, dict]:
    """(warm start, sleep state, joint solver state) from the arrays ``names`` (``get(name)`` reads
    one): ``_solver_arrays``'s files, split by prefix."""
    warm = {name[len("contact_"):]: get(name) for name in WARM_START + WARM_START_OPTIONAL if name in names}
    sleep = {name[len("sleep_"):]: get(name) for name in names if name.startswith("sleep_")}
    joint_state = {name[len("joint_"):]: get(name) for name in names if name.startswith("joint_")}
    return warm, sleep, joint_state


def _restore_solvers(sim, warm: dict, sleep: dict, joint_state: dict):
    """Put ``_solver_parts`` back into a Simulator whose soft step is new or not made yet and whose
    sleep state is not made yet (a loaded checkpoint's, a restored ``snapshot.SimState``'s)."""
    if all(name[len("contact_"):] in warm for name in WARM_START):
        _restore_warm_start(sim, warm)
    if joint_state:
        _restore_joint_solver(sim, joint_state)
    if sleep:
        from .solver.island import SleepState

        sim.sleep = SleepState(sim.world.body_count)
        sim.sleep.set_state(sleep)


def _json_default(o):
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def load_checkpoint(cls, path, custom_forces=None):
    """``Simulator.load_checkpoint``: rebuild the World and a Simulator of class ``cls``."""
    path = Path(path)
    file = str(path)
    if not path.is_file():
        raise InputError("checkpoint file not found", None, file)
    try:
        # our own handle: np.load leaks its own when the zip is damaged
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            arrays = {name: np.array(data[name]) for name in CONSTANTS + STATE + KINEMATIC if name in data.files}
            missing = [name for name in CONSTANTS + STATE if name not in arrays and name not in OPTIONAL_CONSTANTS]
            if missing:
                raise KeyError(f"{missing[0]} is not a file in the archive")
            warm, sleep, joint_state = _solver_parts(data.files, lambda name: np.array(data[name]))
    except Exception as exc:  # damaged or foreign file: one line
        raise InputError(f"not a readable checkpoint file ({type(exc).__name__}: {' '.join(str(exc).split())})", None, file) from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise InputError("not a tumble checkpoint file", None, file)
    if meta.get("version") != VERSION:
        raise InputError(f"checkpoint format version {meta.get('version')!r} is not supported (expected {VERSION})", None, file)
    try:
        sim = _rebuild(cls, meta, arrays, custom_forces)
        _restore_solvers(sim, warm, sleep, joint_state)
    except InputError as err:
        raise InputError(f"checkpoint does not rebuild: {err}", None, file) from None
    except SimulationError as err:
        raise InputError(f"checkpoint state is invalid: {err}", None, file) from None
    except KeyError as exc:  # an entry the rebuild needs is gone: name it (the line said "KeyError: 'settings'")
        key = str(exc.args[0]) if exc.args else None
        raise InputError("missing from the checkpoint (it does not rebuild without it)", key, file) from None
    except Exception as exc:
        raise InputError(f"checkpoint does not rebuild ({type(exc).__name__}: {' '.join(str(exc).split())})", None, file) from None
    return sim


WARM_START = ("contact_key", "contact_normal_impulse", "contact_friction_impulse")
# the rolling and spinning impulses (solver.contact_rolling); absent from older checkpoints: zeros
WARM_START_OPTIONAL = ("contact_rolling_impulse",
                       # the last step's impulses of the same contacts (absent before session 39: zeros)
                       "contact_step_normal_impulse", "contact_step_friction_impulse")


def _restore_warm_start(sim, warm: dict):
    k = len(warm["key"])
    if warm["key"].dtype.kind != "i" or warm["normal_impulse"].shape != (k,) or warm["friction_impulse"].shape != (k, 3):
        raise InputError("contact warm-start arrays have inconsistent shapes")
    for name, shape in (("rolling_impulse", (k, 3)), ("step_normal_impulse", (k,)), ("step_friction_impulse", (k, 3))):
        if name in warm and warm[name].shape != shape:
            raise InputError("contact warm-start arrays have inconsistent shapes")
    if sim._contact_on():
        sim.soft_step.solver.set_warm_start_state(warm)


def _restore_joint_solver(sim, state: dict):
    """Build the soft step's JointSolver now (the first step would) and put the saved arrays in it.

    The saved arrays have k rows: the joints the solver held at the save. k < J when joints
    were added after the last step; the first step's ``prepare`` then appends the others and
    keeps the state of the first k, as it would have in the run that saved.
    """
    missing = [name for name in JOINT_SOLVER_STATE if name not in state and name not in JOINT_SOLVER_OPTIONAL]
    unknown = sorted(set(state) - set(JOINT_SOLVER_STATE))
    if missing or unknown:
        raise InputError(f"joint solver arrays do not match this version (missing {missing}, unknown {unknown})")
    k = len(state["enabled"])
    joints = sim.world.joints
    if not 0 < k <= len(joints):
        raise InputError(f"joint solver arrays have {k} rows for {len(joints)} joints")
    sim._contact_on()  # makes the soft step: a world with joints always takes it
    soft = sim.soft_step
    soft._refresh_joints()
    solver = soft.joints
    # NOTE: _build is what prepare calls when the joints changed; prepare would build all J
    # joints, and the saved state may be of the first k only.
    solver._build(list(joints[:k]))
    for name in JOINT_SOLVER_STATE:
        target = getattr(solver, name)
        if name not in state:
            continue  # JOINT_SOLVER_OPTIONAL: an older checkpoint; as a new solver has it
        saved = state[name]
        old_columns = {"param": OLD_PARAM_COUNTS, "axial_impulse": OLD_AXIAL_COUNTS}.get(name, ())
        if saved.ndim == 2 and saved.shape[0] == target.shape[0] and saved.shape[1] in old_columns:
            # a checkpoint of an older version: its joints had no effort, armature, armature impulse
            # or ball drive
            saved = _pad_param(saved) if name == "param" else np.concatenate(
                [saved, np.zeros((saved.shape[0], target.shape[1] - saved.shape[1]))], axis=1)
        if saved.shape != target.shape or saved.dtype.kind != target.dtype.kind:
            raise InputError(f"joint solver array {name!r} is {saved.dtype}{list(saved.shape)}, "
                             f"expected {target.dtype}{list(target.shape)}")
        target[...] = saved
    # the rows the run reads are the records' rows too (a snapshot's restore puts back the targets,
    # torques and motors set after its save): a later edit of a record writes its own columns over
    # them, and no edit made before the restore is taken after it
    for j in range(k):
        row = joints[j].bound.param
        row[...] = solver.param[j, :row.shape[0]]
    solver._edits_seen = edit_count()
    sim._joint_edits_seen = edit_count()


def _pad_param(rows: np.ndarray) -> np.ndarray:
    """(J, PARAM_COUNT) parameter rows from a checkpoint's older, shorter (J, k) ones: the columns
    they lack zero (no effort, no armature, no ball drive), but a ball drive's max torque inf and
    its target the identity quaternion, as ``bind_joint`` writes them."""
    out = np.zeros((rows.shape[0], PARAM_COUNT))
    out[:, :rows.shape[1]] = rows
    if rows.shape[1] <= P_BALL_MAX_DRIVE:
        out[:, P_BALL_MAX_DRIVE] = np.inf
        out[:, P_BALL_TARGET] = 1.0
    return out  # (a row of 28 lacks only the ball drive's target velocity: 0)


def _restore_logs(sim, contact_touching, sensor_pairs):
    """Give a simulator's new contact-event log the pairs touching after the last step and its
    sensor log the overlapping pairs (lists of pairs, or None / empty: none), so that the run's
    next step begins only new touches and overlaps, as the whole run's would. Shared by the
    checkpoint's load and the snapshot's restore."""
    if sim._event_log is not None and contact_touching:
        sim._event_log.set_pairs(contact_touching, sim.world.body_count)
    if sensor_pairs is not None and len(sensor_pairs) and sim._sensors() is not None:
        sim._sensors().set_pairs(list(sensor_pairs))


def _rebuild(cls, meta: dict, arrays: dict, custom_forces):
    names = meta["names"]
    n = len(names)
    for name, arr in arrays.items():
        expected = {"moving": (n,), "kinematic": (n,), "sensor": (n,), "mass": (n,), "inv_mass": (n,)}.get(name)
        if arr.shape[:1] != (n,) or (expected is not None and arr.shape != expected):
            raise InputError(f"array {name!r} has shape {arr.shape}, expected {n} rows")
        if arr.dtype.kind not in "fb":
            raise InputError(f"array {name!r} has dtype {arr.dtype}, expected numbers")
    w = World(gravity=meta["gravity"], layout=meta["layout"])
    moving = arrays["moving"].astype(bool)
    kinematic = arrays["kinematic"].astype(bool) if "kinematic" in arrays else np.zeros(n, dtype=bool)
    sensor = arrays["sensor"].astype(bool) if "sensor" in arrays else np.zeros(n, dtype=bool)
    # checkpoints written before collision filters existed have none: every body the default
    filters = meta.get("collision_filters") or [None] * n
    for i, name in enumerate(names):
        shape = shape_from_dict(meta["shapes"][i])
        kw = {}
        if moving[i] and type(shape).__name__ != "Particles":
            kw["mass"] = float(arrays["mass"][i])
        w.add_body(shape, name=name, fixed=not (moving[i] or kinematic[i]), kinematic=bool(kinematic[i]),
                   sensor=bool(sensor[i]),
                   material=Material(**meta["materials"][i]),
                   collision_filter=filters[i], **kw)
    for a, b in meta.get("collision_exclusions") or ():
        w.exclude_collision(int(a), int(b))
    for a, b, material in meta.get("pair_materials") or ():
        w.set_pair_material(int(a), int(b), Material(**material))
    for name in CONSTANTS + STATE + KINEMATIC:
        if name in arrays:
            getattr(w, name)[:] = arrays[name]
    for k, record in enumerate(meta.get("kinematic_paths") or ()):
        try:
            # placed already: the saved state holds the body's pose and velocities (and, for a path
            # that lets its body go, the mass it goes with: dynamic_mass, read above)
            w.add_path(KeyframePath(**record), place=False)
        except (InputError, TypeError) as err:
            raise InputError(f"kinematic_paths[{k}]: {err}") from None
    customs = list(custom_forces or [])
    wanted = sum(1 for f in meta["forces"] if f["type"] == "CustomForce")
    if len(customs) != wanted:
        raise InputError(f"the world has {wanted} CustomForce record(s): give their functions as custom_forces (got {len(customs)})")
    for record in meta["forces"]:
        record = dict(record)
        kind = FORCE_CLASSES.get(record.pop("type"))
        if kind is None:
            raise InputError("unknown force type in checkpoint")
        if kind is CustomForce:
            record["function"] = customs.pop(0)
        w.add_force(kind(**record))
    joints = meta.get("joints") or []
    if not isinstance(joints, list):
        raise InputError("expected a list of joint records", "joints")
    # appended as bound at their creation: World.add_joint would rebind them at the saved poses
    w.joints.extend(_joint_from_dict(w, record, f"joints[{i}]") for i, record in enumerate(joints))
    w.joints_switched_off = {int(k) for k in meta.get("joints_switched_off") or ()}
    w.t = float(meta["t"])
    w.collisions = bool(meta.get("collisions", True))
    w.sleeping = bool(meta.get("sleeping", True))
    w.applied_impulses = {int(k) for k in meta["applied_impulses"]}
    w.wake_requests = {int(k) for k in meta.get("wake_requests") or ()}
    w.update_derived()
    checks.validate_world(w, "load_checkpoint")
    s = meta["settings"]
    sim = cls(w, dt=s["dt"], integrator=s["integrator"], substeps=s["substeps"], rtol=s["rtol"], atol=s["atol"],
              max_energy_growth=s["max_energy_growth"],
              contact_settings=SoftStepSettings(**s["contact"]) if "contact" in s else None,
              record_contacts=bool(s.get("record_contacts", False)),
              joint_settings=None if s.get("joint_solver") is None else JointSettings(**s["joint_solver"]),
              record_joints=bool(s.get("record_joints", False)),
              contact_events=bool(s.get("contact_events", False)))
    _restore_logs(sim, meta.get("contact_touching"), meta.get("sensor_pairs"))
    sim.step_index = int(meta["step_index"])
    if not math.isclose(sim.step_index * sim.dt, w.t, rel_tol=1e-12, abs_tol=1e-12):
        raise InputError(f"step index {sim.step_index} does not match t = {w.t}")
    sim.stats.update(_checked_stats(meta["stats"]))
    sim.energy_reference = _checked_energy_reference(meta["energy_reference"])
    sim.checkpoint_run = meta["run"]
    return sim


def _is_number(v, finite=True) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and (not finite or math.isfinite(v))


def _checked_stats(stats) -> dict:
    """The simulator's statistics from a checkpoint: a table whose ``steps`` and
    ``derivative_evaluations`` are whole numbers >= 0, ``lowest_separation`` a number or null and
    any other entry a number (a damaged one failed at the end of a resumed run, after its writes)."""
    if not isinstance(stats, dict):
        raise InputError("expected a table of the simulator's statistics", "stats")
    for key, v in stats.items():
        if key in ("steps", "derivative_evaluations"):
            ok = isinstance(v, int) and not isinstance(v, bool) and v >= 0
        else:
            ok = (v is None and key == "lowest_separation") or _is_number(v, finite=False)
        if not ok:
            raise InputError(f"expected {'a whole number >= 0' if key in ('steps', 'derivative_evaluations') else 'a number'}, "
                             f"got {' '.join(repr(v).split())[:60]}", f"stats.{key}")
    return stats


def _checked_energy_reference(ref):
    """``[E0 J, scale J, impulses applied]`` or null (``Simulator.energy_reference``)."""
    if ref is None:
        return None
    if not (isinstance(ref, list) and len(ref) == 3 and _is_number(ref[0]) and _is_number(ref[1]) and ref[1] >= 0
            and isinstance(ref[2], int) and not isinstance(ref[2], bool) and ref[2] >= 0):
        raise InputError(f"expected null or [E0 J, scale J >= 0, impulses applied], got {' '.join(repr(ref).split())[:60]}",
                         "energy_reference")
    return ref
