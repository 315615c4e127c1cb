"""Scene files: the ``[[joints]]`` entries (and an optional ``[joint_solver]`` table).

Each entry is one joint of ``tumble.joints``; bodies are named as in ``[[bodies]]`` and
``body_b`` may be omitted or ``"world"``::

    [[joints]]
    type = "hinge"                 # ball | hinge | slider | fixed | distance | universal | gear
    name = "knee"                  # optional
    body_a = "thigh"
    body_b = "shin"                # or "world", or left out
    anchor = [0, 0, 0.5]           # m, world (frame = "world", the default) or body_a's frame
    axis = [0, 1, 0]
    lower_deg = -120               # or lower = -2.09 (rad)
    upper_deg = 0
    motor_speed = 2.0              # rad/s, with max_motor_torque (N m)
    torque = 0.5                   # N m applied about the axis (a slider: force, N)
    armature = 0.01                # kg m^2 added to the angle's inertia (a slider: kg; MuJoCo's)

A gear couples two hinge or slider joints named before it (``q_joint = offset + ratio *
q_follows``, or ``polynomial = [a0, a1, a2, a3, a4]``; ``tumble.joints.GearJoint``)::

    [[joints]]
    type = "gear"
    joint = "wheel_axle"           # the joint that follows
    follows = "motor_axle"         # the joint it follows (left out: joint locked at offset)
    ratio = -2.0                   # rad/rad (m/rad for a rack on a pinion)

A ball joint takes ``twist_lower``, ``twist_upper`` (rad, in [-pi, pi]) besides its
``cone_limit``, and a drive on its whole rotation: ``stiffness`` (N m/rad), ``damping`` (N m s/rad),
``max_drive_torque`` and ``target`` (body_b's rotation relative to body_a from their pose at
creation, in body_a's axes: a rotation vector ``[x, y, z]`` rad or a quaternion ``[w, x, y, z]``)
or ``target_euler_deg = [roll, pitch, yaw]``, and ``target_velocity`` (rad/s, body_a's axes); a universal joint ``lower``, ``upper`` (its angle about ``axis``) and
``lower_b``, ``upper_b`` (about ``axis_b``), each in [-pi, pi], and motors ``motor_speed``,
``motor_speed_b`` with ``max_motor_torque``, ``max_motor_torque_b``.

Angles may be given in degrees with the ``_deg`` keys (``lower_deg``, ``upper_deg``,
``target_deg``, ``cone_limit_deg``, ``twist_lower_deg``, ``twist_upper_deg``,
``lower_b_deg``, ``upper_b_deg``, ``motor_speed_deg`` and ``motor_speed_b_deg`` in deg/s)
instead of radians.
Errors are ``InputError`` lines ``FILE: joints[2].axis: must not be the zero vector``, as
in ``tumble.scene``.
"""

from __future__ import annotations

import math
from typing import Any

from .errors import InputError
from .joints import JOINT_CLASSES
from .scene_values import _describe  # the scene parser's wording for a value of the wrong type

COMMON_KEYS = ("type", "name", "body_a", "body_b", "anchor", "anchor_b", "frame", "collide_connected",
               "max_force", "max_torque")
DRIVE_KEYS = ("lower", "upper", "motor_speed", "stiffness", "damping", "target", "target_velocity",
              "passive_stiffness", "passive_damping", "springref")
# per type: its own keys besides COMMON_KEYS
TYPE_KEYS = {
    "ball": ("axis", "cone_limit", "cone_limit_deg", "twist_lower", "twist_upper", "twist_lower_deg",
             "twist_upper_deg", "stiffness", "damping", "target", "target_euler_deg", "target_velocity",
             "max_drive_torque"),
    "hinge": ("axis", *DRIVE_KEYS, "lower_deg", "upper_deg", "target_deg", "springref_deg", "motor_speed_deg", "target_velocity_deg",
              "max_motor_torque", "max_drive_torque", "torque", "armature"),
    "slider": ("axis", *DRIVE_KEYS, "max_motor_force", "max_drive_force", "force", "armature"),
    "fixed": (),
    "distance": ("min_length", "max_length", "stiffness", "damping", "target", "max_drive_force"),
    "universal": ("axis", "axis_b", "lower", "upper", "lower_b", "upper_b", "lower_deg", "upper_deg", "lower_b_deg",
                  "upper_b_deg", "motor_speed", "motor_speed_b", "motor_speed_deg", "motor_speed_b_deg",
                  "max_motor_torque", "max_motor_torque_b"),
}
# a gear names two joints, not bodies: its keys replace COMMON_KEYS
GEAR_KEYS = ("type", "name", "joint", "follows", "ratio", "offset", "polynomial", "collide_connected")
VECTOR_KEYS = ("anchor", "anchor_b", "axis", "axis_b")
# a ball joint drive's target: a rotation vector (3 numbers, rad) or a quaternion (4: w, x, y, z),
# or roll, pitch, yaw in degrees (``tumble.joints.ball_target_quaternion`` checks them)
ROTATION_KEYS = ("target_euler_deg", "target_velocity")
# keys that may be inf (TOML "inf")
UNBOUNDED_KEYS = ("max_force", "max_torque", "max_motor_torque", "max_motor_force", "max_drive_torque",
                  "max_drive_force", "max_motor_torque_b")
DEGREE_KEYS = {"lower_deg": "lower", "upper_deg": "upper", "target_deg": "target", "springref_deg": "springref",
               "cone_limit_deg": "cone_limit", "motor_speed_deg": "motor_speed", "target_velocity_deg": "target_velocity", "twist_lower_deg": "twist_lower", "twist_upper_deg": "twist_upper",
               "lower_b_deg": "lower_b", "upper_b_deg": "upper_b", "motor_speed_b_deg": "motor_speed_b"}
SOLVER_KEYS = ("method", "hertz", "damping_ratio", "velocity_iterations", "relax_iterations", "bias_factor",
               "partitions", "partition_min_joints", "limit_hertz", "limit_damping_ratio")


def _number(value, key: str, file, unbounded=False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"expected a number, got {_describe(value)}", key, file)
    try:
        v = float(value)
    except OverflowError:
        raise InputError("must be a finite number", key, file) from None
    if math.isnan(v) or (math.isinf(v) and not (unbounded and v > 0)):
        raise InputError(f"must be a finite number, got {v}", key, file)
    return v


def _vector(value, key: str, file) -> list[float]:
    if not isinstance(value, list) or len(value) != 3:
        raise InputError(f"expected a list of 3 numbers, got {_describe(value)}", key, file)
    return [_number(v, f"{key}[{i}]", file) for i, v in enumerate(value)]


def _body(value, key: str, world, file):
    if value is None or value == "world":
        return None
    if not isinstance(value, str):
        raise InputError(f"expected a body name or \"world\", got {_describe(value)}", key, file)
    if value not in world.names:
        raise InputError(f"unknown body {value!r}", key, file)
    return value


def parse_joints(entries, world, file: str | None = None) -> list:
    """Build the ``[[joints]]`` entries into ``world`` (``World.add_joint``, at the bodies'
    poses as built) and return the joint records, in order.

    Raises:
        InputError: ``FILE: joints[i].KEY: problem`` for the first problem found.
    """
    if entries is None:
        return []
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise InputError(f"expected a list of tables ([[joints]]), got {_describe(entries)}", "joints", file)
    records = []
    names = set()
    for i, entry in enumerate(entries):
        key = f"joints[{i}]"
        records.append(_parse_one(entry, key, world, file, names))
    return records


def _parse_one(entry: dict, key: str, world, file, names: set):
    if "type" not in entry:
        raise InputError("missing key 'type'", key, file)
    kind = entry["type"]
    if not isinstance(kind, str) or kind not in (*TYPE_KEYS, "gear"):
        raise InputError(f"unknown joint type {kind!r} (expected one of {', '.join(TYPE_KEYS)}, gear)", f"{key}.type",
                         file)
    if kind == "gear":
        return _parse_gear(entry, key, world, file, names)
    allowed = COMMON_KEYS + TYPE_KEYS[kind]
    for k in entry:
        if k not in allowed:
            raise InputError(f"unknown key for a {kind} joint (expected one of {', '.join(allowed)})", f"{key}.{k}", file)
    if "body_a" not in entry:
        raise InputError("missing key 'body_a'", key, file)
    kw: dict[str, Any] = {"body_a": _body(entry["body_a"], f"{key}.body_a", world, file),
                          "body_b": _body(entry.get("body_b"), f"{key}.body_b", world, file)}
    if kw["body_a"] is None:
        kw["body_a"] = "world"
    for k, v in entry.items():
        sub = f"{key}.{k}"
        if k in ("type", "body_a", "body_b"):
            continue
        if k == "name":
            kw["name"] = _name(v, sub, file, names)
        elif k == "frame":
            if v not in ("world", "body"):
                raise InputError(f"must be \"world\" or \"body\", got {_describe(v)}", sub, file)
            kw["frame"] = v
        elif k == "collide_connected":
            if not isinstance(v, bool):
                raise InputError(f"expected true or false, got {_describe(v)}", sub, file)
            kw["collide_connected"] = v
        elif k in VECTOR_KEYS:
            kw[k] = _vector(v, sub, file)
        elif (k in ROTATION_KEYS and kind == "ball") or (k == "target" and kind == "ball"):
            # (a hinge's or slider's target_velocity is one number: its coordinate's rate)
            kw[k] = _numbers(v, sub, file)
        elif k in DEGREE_KEYS:
            target = DEGREE_KEYS[k]
            if target in entry:
                raise InputError(f"give {target} or {k}, not both", sub, file)
            kw[target] = math.radians(_number(v, sub, file))
        else:
            kw[k] = _number(v, sub, file, unbounded=k in UNBOUNDED_KEYS)
    try:
        record = JOINT_CLASSES[kind](**kw)
        world.add_joint(record)
    except InputError as err:
        raise err.within(key, file) from None
    return record


def _numbers(value, key, file) -> list:
    """A list of numbers (its length is checked by the joint record)."""
    if not isinstance(value, list) or not all(isinstance(c, (int, float)) and not isinstance(c, bool) for c in value):
        raise InputError(f"expected a list of numbers, got {_describe(value)}", key, file)
    return [float(c) for c in value]


def _name(value, key, file, names: set):
    if not isinstance(value, str) or not value:
        raise InputError(f"expected a non-empty string, got {_describe(value)}", key, file)
    if value in names:
        raise InputError(f"duplicate joint name {value!r}", key, file)
    names.add(value)
    return value


def _parse_gear(entry: dict, key: str, world, file, names: set):
    """A ``type = "gear"`` entry: ``joint`` and ``follows`` name joints above it."""
    for k in entry:
        if k not in GEAR_KEYS:
            raise InputError(f"unknown key for a gear joint (expected one of {', '.join(GEAR_KEYS)})", f"{key}.{k}",
                             file)
    kw: dict[str, Any] = {}
    for k in ("joint", "follows"):
        if k not in entry:
            if k == "follows":  # none: the joint is locked at offset
                continue
            raise InputError(f"missing key {k!r}", key, file)
        if not isinstance(entry[k], str) or not entry[k]:
            raise InputError(f"expected the name of a joint above, got {_describe(entry[k])}", f"{key}.{k}", file)
        kw[k] = entry[k]
    for k, v in entry.items():
        sub = f"{key}.{k}"
        if k == "name":
            kw["name"] = _name(v, sub, file, names)
        elif k == "collide_connected":
            if not isinstance(v, bool):
                raise InputError(f"expected true or false, got {_describe(v)}", sub, file)
            kw[k] = v
        elif k in ("ratio", "offset"):
            kw[k] = _number(v, sub, file)
        elif k == "polynomial":
            if not isinstance(v, list) or not 1 <= len(v) <= 5:
                raise InputError(f"expected a list of 1 to 5 numbers (a0, ..., a4), got {_describe(v)}", sub, file)
            kw[k] = [_number(c, f"{sub}[{i}]", file) for i, c in enumerate(v)]
    try:
        record = JOINT_CLASSES["gear"](**kw)
        world.add_joint(record)
    except InputError as err:
        raise err.within(key, file) from None
    return record


def parse_joint_settings(table, file: str | None = None):
    """A ``[joint_solver]`` table (method, hertz, damping_ratio, velocity_iterations,
    relax_iterations, bias_factor, partitions, partition_min_joints, limit_hertz, limit_damping_ratio) as
    ``tumble.solver.joints.JointSettings``."""
    from .solver.joints import JointSettings

    if table is None:
        return JointSettings()
    if not isinstance(table, dict):
        raise InputError(f"expected a table, got {_describe(table)}", "joint_solver", file)
    kw: dict[str, Any] = {}
    for k, v in table.items():
        sub = f"joint_solver.{k}"
        if k not in SOLVER_KEYS:
            raise InputError(f"unknown key (expected one of {', '.join(SOLVER_KEYS)})", sub, file)
        if k == "method":
            if v not in ("gauss-seidel", "tree"):
                raise InputError(f"must be \"gauss-seidel\" or \"tree\", got {_describe(v)}", sub, file)
            kw[k] = v
        elif k in ("velocity_iterations", "relax_iterations", "partitions"):
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise InputError(f"must be a whole number >= 1, got {_describe(v)}", sub, file)
            kw[k] = v
        elif k == "partition_min_joints":
            if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                raise InputError(f"must be a whole number >= 0, got {_describe(v)}", sub, file)
            kw[k] = v
        else:
            x = _number(v, sub, file)
            if x < 0:
                raise InputError(f"must be >= 0, got {x:g}", sub, file)
            kw[k] = x
    return JointSettings(**kw)


def load_scene_with_joints(path):
    """A scene file with its joints: (Scene, joint records, JointSettings). ``tumble.scene``
    reads ``[[joints]]`` and ``[joint_solver]`` itself; this keeps the three together for
    code that steps the World with ``tumble.solver.joints.step_with_joints``."""
    from .scene import load_scene
    from .solver.joints import JointSettings

    scene = load_scene(path)
    settings = getattr(scene, "joint_settings", None) or JointSettings()
    return scene, list(scene.world.joints), settings
