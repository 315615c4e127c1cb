"""Joint records: what a user asks for (ball, hinge, slider, fixed, distance, universal).

A record names two bodies (``body_b=None`` or ``"world"``: the world), an anchor and,
where the type has one, an axis, given in world coordinates (``frame="world"``, the
default) or in the bodies' own frames (``frame="body"``). ``World.add_joint`` binds the
record: it checks the input and resolves anchors and the joint frame into each body's
frame at the current poses (the pose at creation is the joint's zero: hinge angle 0,
slider position 0). The solver (``tumble.solver.joints``) reads the bound values into
its arrays; records are not read inside a step.

A bound record's parameters stay editable: setting a field after ``add_joint`` (``hinge.damping
= 0.5``, ``ball.cone_limit = 0.3``, ``hinge.motor_speed = None``) checks the new value (InputError,
the field left as it was), writes the parameter columns it decides and marks the record edited
(``edit_count``): the solver takes the row at its next step and the Simulator wakes the joint's
bodies (Box2D's joint setters wake them too: b2Joint_WakeBodies). MuJoCo's model fields and
PyBullet's ``changeDynamics`` are edited the same way between steps. The geometry resolved at
``add_joint`` (the bodies, anchors, frame and axes; a gear's joints) is fixed: setting it raises
(make a new joint instead).

Units: m, rad, N, N m. Angular parameters of hinges are per radian (stiffness N m/rad,
damping N m s/rad); linear ones of sliders and distance joints per metre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from .errors import InputError
from .math3d import mat_t_mat, mat_t_vec, mat_vec, norm3
from .shapes import finite_vector

# joint type ids (the solver's ``joint_type``)
JOINT_BALL = 0
JOINT_HINGE = 1
JOINT_SLIDER = 2
JOINT_FIXED = 3
JOINT_DISTANCE = 4
JOINT_UNIVERSAL = 5
JOINT_GEAR = 6

JOINT_TYPES = {"ball": JOINT_BALL, "hinge": JOINT_HINGE, "slider": JOINT_SLIDER, "fixed": JOINT_FIXED,
               "distance": JOINT_DISTANCE, "universal": JOINT_UNIVERSAL, "gear": JOINT_GEAR}

# columns of the solver's per-joint parameter table ``joint_param`` (J, PARAM_COUNT)
P_LOWER, P_UPPER, P_LIMIT_ON, P_MOTOR_ON, P_MOTOR_SPEED, P_MAX_MOTOR = 0, 1, 2, 3, 4, 5
P_STIFFNESS, P_DAMPING, P_TARGET, P_MAX_DRIVE, P_MAX_FORCE, P_MAX_TORQUE, P_RIGID = 6, 7, 8, 9, 10, 11, 12
# the second angular coordinate of a joint: a ball joint's twist, a universal joint's angle
# about axis_b (limits, and a motor on the universal joint)
P_LOWER2, P_UPPER2, P_LIMIT2_ON, P_MOTOR2_ON, P_MOTOR2_SPEED, P_MAX_MOTOR2 = 13, 14, 15, 16, 17, 18
# the 1-D coordinate's applied effort (a hinge's torque N m, a slider's force N: PyBullet's
# TORQUE_CONTROL, MuJoCo's motor actuator) and its armature (kg m^2 or kg: MuJoCo's joint
# armature, a rotor's inertia added to the coordinate's own)
P_EFFORT, P_ARMATURE = 19, 20
# a ball joint's drive (``BallJoint``'s stiffness, damping, max_drive_torque, and its target: the
# rotation of body_b relative to body_a from their pose at creation, in body_a's axes, as a unit
# quaternion w, x, y, z in P_BALL_TARGET..P_BALL_TARGET+3): a spring-damper on the whole relative
# rotation (``solver.joint_solve._solve_ball_drive``); columns of their own, so that the 1-D
# coordinate's rows (``_solve_axial``) never read a ball joint's drive as a spring on its swing
P_BALL_STIFFNESS, P_BALL_DAMPING, P_BALL_MAX_DRIVE, P_BALL_TARGET = 21, 22, 23, 24
# and its target velocity: body_b's angular velocity relative to body_a that the damping pulls to,
# rad/s in body_a's axes (x, y, z in P_BALL_RATE..P_BALL_RATE+2)
P_BALL_RATE = 28
# a hinge's or slider's passive spring and damper (MuJoCo's joint ``stiffness`` to ``springref`` and
# ``damping``: its qfrc_passive), acting beside the drive and never capped by ``max_drive_*``: the
# drive row solves them together, and a saturated drive keeps them (``joint_solve._solve_axial``)
P_PASSIVE_STIFFNESS, P_PASSIVE_DAMPING, P_SPRINGREF = 31, 32, 33
# a hinge's or slider's drive target velocity (rad/s or m/s): the rate its damping pulls to, so the
# drive is -stiffness (q - target) - damping (q' - target_velocity) (PyBullet's POSITION_CONTROL
# targetVelocity, MuJoCo's velocity actuator, UsdPhysics' drive targetVelocity), capped whole
P_TARGET_RATE = 34
PARAM_COUNT = 35
# the columns a parameter row had in older versions (checkpoints): before the effort and
# armature (their joints get none), and before the ball joints' drive (none either)
PARAM_COUNT_V1 = 19
PARAM_COUNT_V2 = 21
# 28: the ball drive without its target velocity; 31: no passive spring and damper; 34: no drive
# target velocity
OLD_PARAM_COUNTS = (PARAM_COUNT_V1, PARAM_COUNT_V2, 28, 31, 34)
# a gear's parameter row (``GearJoint``): the indices in ``world.joints`` of the joint that follows and of
# the joint it follows, and the coefficients a0..a4 of q_joint = a0 + a1 q + ... + a4 q^4 (q = q_follows)
# in columns G_COEF..G_COEF+4 (P_STIFFNESS..P_MAX_FORCE). Columns no other row of a gear is read from (every kernel takes a gear's
# own branch first); the limit, motor, effort and armature columns stay 0, so the checks that scan them
# over all joints (the tree's limit sweeps, armature, efforts) pass a gear by.
# G_MASS (P_MAX_TORQUE's column): the row's J M^-1 J^T through the tree solve, which the tree method
# writes each solve (``joint_tree.tree_gear_masses``); 0: the free bodies' (the Gauss-Seidel method).
G_JOINT, G_FOLLOWS, G_COEF, G_MASS = 0, 1, 6, 11


def _number(value, key, *, minimum=None, allow_inf=False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"expected a number, got {value!r}", key) from None
    if isinstance(value, bool) or math.isnan(v) or (math.isinf(v) and not allow_inf):
        raise InputError(f"must be a finite number, got {value!r}", key)
    if minimum is not None and v < minimum:
        raise InputError(f"must be >= {minimum:g}, got {v:g}", key)
    return v


def _unit(value, key) -> np.ndarray:
    a = finite_vector(value, key)
    n = float(norm3(a))
    if n < 1e-12:
        raise InputError(f"must not be the zero vector, got {a.tolist()}", key)
    return a / n


def _frame_from_z(z: np.ndarray) -> np.ndarray:
    """A right-handed orthonormal frame (3, 3), columns x, y, z, with z given."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= norm3(x)
    return np.column_stack([x, np.cross(z, x), z])


@dataclass(eq=False)
class Joint:
    """Fields every joint has.

    Args:
        body_a: a ``Body``, a body name or index.
        body_b: the second body, or None / "world" to attach ``body_a`` to the world.
        anchor: (3,) m. ``frame="world"``: the joint point in world coordinates (on
            both bodies). ``frame="body"``: the point in body_a's frame (centre of mass
            origin, body axes).
        anchor_b: (3,) m, optional: the point on body_b, in world coordinates or in
            body_b's frame (as ``frame`` says). Default: the same world point as
            ``anchor`` now. Give it to create a joint that starts pulled apart (the
            solver closes the gap).
        frame: "world" or "body": how ``anchor``, ``anchor_b`` and axes are given.
        collide_connected: whether the two bodies still collide with each other
            (default False: ``jointed_body_pairs`` lists them for the contact step).
        max_force: N. The joint breaks (stops acting, for good) when its reaction
            force exceeds this. Default inf.
        max_torque: N m, the same for its reaction torque. Default inf.
        name: optional label, for error messages and lookups.
    """

    body_a: Any
    body_b: Any = None
    anchor: Any = (0.0, 0.0, 0.0)
    anchor_b: Any = None
    frame: str = "world"
    collide_connected: bool = False
    max_force: float = math.inf
    max_torque: float = math.inf
    name: str | None = None
    kind: ClassVar[str] = ""
    # set by bind_joint
    bound: Any = field(default=None, init=False, repr=False)
    broken: bool = field(default=False, init=False)
    # the value of ``edit_count`` at this record's last edit after binding (0: never edited)
    _edit_stamp: ClassVar[int] = 0

    def __setattr__(self, name, value):
        # before binding (the constructor, dataclasses.replace) and for the state fields: plain
        if name in _PLAIN_FIELDS or self.__dict__.get("bound") is None or name not in self.__dataclass_fields__:
            object.__setattr__(self, name, value)
        else:
            edit_joint(self, name, value)

    # -- per type: world joint frame (3, 3) at creation from the axis arguments, and params
    def _frame_world(self, axis_to_world) -> np.ndarray:
        return np.eye(3)

    def _params(self, p: np.ndarray, length: float):
        pass


def _limits(lower, upper, lkey="lower", ukey="upper"):
    lo = -math.inf if lower is None else _number(lower, lkey)
    hi = math.inf if upper is None else _number(upper, ukey)
    if lo > hi:
        raise InputError(f"limits the wrong way round: {lkey} {lo:g} > {ukey} {hi:g}", lkey)
    return lo, hi


def _drive_params(p, j, motor_key, drive_key, effort_key):
    """Limits, motor, spring/PD drive, applied effort and armature of a 1-D joint coordinate
    into the parameter row p."""
    lo, hi = _limits(j.lower, j.upper)
    p[P_LOWER], p[P_UPPER] = lo, hi
    p[P_LIMIT_ON] = float(lower_or_upper(j.lower, j.upper))
    if j.motor_speed is not None:
        p[P_MOTOR_ON] = 1.0
        p[P_MOTOR_SPEED] = _number(j.motor_speed, "motor_speed")
        p[P_MAX_MOTOR] = _number(getattr(j, motor_key), motor_key, minimum=0.0, allow_inf=True)
    p[P_STIFFNESS] = _number(j.stiffness, "stiffness", minimum=0.0)
    p[P_DAMPING] = _number(j.damping, "damping", minimum=0.0)
    p[P_TARGET] = _number(j.target, "target")
    p[P_TARGET_RATE] = _number(j.target_velocity, "target_velocity")
    p[P_MAX_DRIVE] = _number(getattr(j, drive_key), drive_key, minimum=0.0, allow_inf=True)
    p[P_EFFORT] = _number(getattr(j, effort_key), effort_key)
    p[P_ARMATURE] = _number(j.armature, "armature", minimum=0.0)
    p[P_PASSIVE_STIFFNESS] = _number(j.passive_stiffness, "passive_stiffness", minimum=0.0)
    p[P_PASSIVE_DAMPING] = _number(j.passive_damping, "passive_damping", minimum=0.0)
    p[P_SPRINGREF] = _number(j.springref, "springref")


def lower_or_upper(lower, upper) -> bool:
    return lower is not None or upper is not None


def _angle_limits(lower, upper, lkey, ukey):
    """(lower, upper, on) of an angle measured in (-pi, pi] (a ball joint's twist, a universal
    joint's angles): each within [-pi, pi], lower <= upper. A side left out is -pi or pi: the
    angle lives on a circle, and a stop at the chart's edge keeps it from jumping across it
    (from -pi to pi, which the other limit would take for a violation of 2 pi - ...). Both at
    the edges (or both left out): no limit (on False)."""
    lo = -math.pi if lower is None else _number(lower, lkey)
    hi = math.pi if upper is None else _number(upper, ukey)
    for value, key in ((lo, lkey), (hi, ukey)):
        if abs(value) > math.pi:
            raise InputError(f"must be between -pi and pi, got {value:g}", key)
    if lo > hi:
        raise InputError(f"limits the wrong way round: {lkey} {lo:g} > {ukey} {hi:g}", lkey)
    return lo, hi, not (lo == -math.pi and hi == math.pi)


@dataclass(eq=False)
class BallJoint(Joint):
    """Ball (spherical) joint: the anchor points coincide; rotation is free.

    The joint frame (x, y, z) is fixed in each body, z = ``axis``, both frames together at
    creation; Q = Fa^T Fb is the rotation of b's joint frame relative to a's. It splits into
    swing and twist, Q = Q_swing Q_twist (the swing-twist decomposition; Jolt's
    SwingTwistConstraint, PhysX's spherical joint with twist): Q_twist turns about z by the
    twist angle, Q_swing about an axis perpendicular to z (the shortest arc taking a's z to
    b's z) by the swing angle. With the world axes xa, ya, za of a's joint frame and xb, yb,
    zb of b's, and the unit quaternion (w, v) of Q, tan(twist / 2) = v_z / w, so

        twist = atan2(ya . xb - xa . yb, xa . xb + ya . yb)   in (-pi, pi]
        swing = atan2(|za x zb|, za . zb)                     in [0, pi]

    (Q_yx - Q_xy = 4 w v_z and Q_xx + Q_yy = 2 (w^2 - v_z^2); the twist has the hinge
    angle's formula). Its rate is (wb - wa) . (za + zb) / (1 + za . zb); the twist is
    undefined at swing pi (the limit rows switch off beyond a swing of about 179.9 deg).

    Args:
        axis: (3,) the cone and twist axis (world, or body_a's frame with ``frame="body"``);
            only used with ``cone_limit`` or the twist limits. Default z.
        cone_limit: rad, optional: the largest swing angle (between the cone axis fixed
            in body_a and the same axis fixed in body_b, both start together), in [0, pi].
        twist_lower, twist_upper: rad, optional limits of the twist angle, each in
            [-pi, pi], twist_lower <= twist_upper; one left out is -pi or pi (a stop there:
            the twist cannot cross from -pi to pi). Combined with ``cone_limit`` they make
            a ragdoll's shoulder or hip (a swing cone plus a twist range).
        stiffness: N m/rad, damping: N m s/rad, both >= 0: a drive on the whole relative
            rotation (MuJoCo's ball joint ``stiffness`` and ``damping``, PyBullet's spherical
            PD control, PhysX's slerp drive): with E the rotation from the target to body_b's
            present orientation relative to body_a and theta = log(E) its rotation vector
            (world, rad), a torque -stiffness theta - damping (omega_b - omega_a) on body_b
            and its opposite on body_a, at most ``max_drive_torque`` N m (the norm). The spring
            has the potential stiffness |theta|^2 / 2 (its torque is that potential's exact
            gradient, at any angle below pi). Solved implicitly, as the hinge's PD drive:
            stable at any stiffness.
        target: the orientation the drive pulls body_b to, relative to body_a: a rotation from
            their relative pose at creation, in body_a's axes (the world's when body_a is the
            world), as a rotation vector (3,) rad or a unit quaternion (4,) w, x, y, z. Default:
            the pose at creation. Change it between steps with ``Simulator.set_joint_target``.
        target_euler_deg: (3,) the same rotation as roll x, pitch y, yaw z in degrees (applied
            z-y'-x'', as ``World.add_body``'s ``euler_deg``); give it or ``target``.
        target_velocity: (3,) rad/s, body_b's angular velocity relative to body_a that the
            damping pulls to (PyBullet's ``targetVelocity``), in body_a's axes: the torque is
            then -stiffness theta - damping (omega_b - omega_a - target_velocity). Default 0:
            a motion clip gives both, the pose and its rate.
        max_drive_torque: N m, the largest drive torque (default inf).
    """

    axis: Any = (0.0, 0.0, 1.0)
    cone_limit: float | None = None
    twist_lower: float | None = None
    twist_upper: float | None = None
    stiffness: float = 0.0
    damping: float = 0.0
    target: Any = None
    target_euler_deg: Any = None
    target_velocity: Any = (0.0, 0.0, 0.0)
    max_drive_torque: float = math.inf
    kind: ClassVar[str] = "ball"

    def _frame_world(self, axis_to_world):
        return _frame_from_z(axis_to_world(_unit(self.axis, "axis")))

    def _params(self, p, length):
        if self.cone_limit is not None:
            c = _number(self.cone_limit, "cone_limit", minimum=0.0)
            if c > math.pi:
                raise InputError(f"must be between 0 and pi, got {c:g}", "cone_limit")
            p[P_UPPER] = c
            p[P_LIMIT_ON] = 1.0
        if lower_or_upper(self.twist_lower, self.twist_upper):
            lo, hi, on = _angle_limits(self.twist_lower, self.twist_upper, "twist_lower", "twist_upper")
            if on:
                p[P_LOWER2], p[P_UPPER2], p[P_LIMIT2_ON] = lo, hi, 1.0
        p[P_BALL_STIFFNESS] = _number(self.stiffness, "stiffness", minimum=0.0)
        p[P_BALL_DAMPING] = _number(self.damping, "damping", minimum=0.0)
        p[P_BALL_MAX_DRIVE] = _number(self.max_drive_torque, "max_drive_torque", minimum=0.0, allow_inf=True)
        if self.target is not None and self.target_euler_deg is not None:
            raise InputError("give target or target_euler_deg, not both", "target")
        if self.target_euler_deg is not None:
            p[P_BALL_TARGET:P_BALL_TARGET + 4] = ball_target_quaternion(self.target_euler_deg, "target_euler_deg",
                                                                        euler=True)
        else:
            p[P_BALL_TARGET:P_BALL_TARGET + 4] = ball_target_quaternion(self.target, "target")
        p[P_BALL_RATE:P_BALL_RATE + 3] = finite_vector(self.target_velocity, "target_velocity")


def ball_target_quaternion(value, key: str, euler: bool = False) -> np.ndarray:
    """A ball joint drive's target (``BallJoint.target``) as a unit quaternion (4,) w, x, y, z
    with w >= 0: from a rotation vector (3,) rad, a quaternion (4,) (normalised; not zero), roll,
    pitch, yaw in degrees (``euler``), or None (the identity). InputError keyed ``key``."""
    if value is None:
        return np.array([1.0, 0.0, 0.0, 0.0])
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise InputError(f"expected {'3' if euler else '3 or 4'} numbers, got {value!r}", key)
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"expected {'3' if euler else '3 or 4'} numbers, got {value!r}", key) from None
    if a.ndim != 1 or a.shape[0] not in ((3,) if euler else (3, 4)) or not np.isfinite(a).all():
        raise InputError(f"expected {'3' if euler else '3 or 4'} finite numbers, got {value!r}", key)
    if euler:
        from .math3d import quat_from_euler_deg

        q = quat_from_euler_deg(a)
    elif a.shape[0] == 4:
        norm = float(np.linalg.norm(a))
        if norm < 1e-9:
            raise InputError("a quaternion of length 0 is no rotation", key)
        q = a / norm
    else:
        angle = float(np.linalg.norm(a))
        q = np.array([1.0, 0.0, 0.0, 0.0]) if angle == 0.0 else np.concatenate(
            [[math.cos(0.5 * angle)], math.sin(0.5 * angle) / angle * a])
    return -q if q[0] < 0.0 else q


@dataclass(eq=False)
class HingeJoint(Joint):
    """Hinge (revolute) joint: the anchors coincide and body_b turns about ``axis`` only.

    The joint coordinate is the angle (rad) of body_b about ``axis`` relative to body_a,
    0 at creation, positive by the right-hand rule, followed across turns.

    Args:
        axis: (3,) hinge axis (world, or body_a's frame with ``frame="body"``).
        lower, upper: rad, optional angle limits (lower <= upper).
        motor_speed: rad/s, optional target rate of the angle, reached with at most
            ``max_motor_torque`` N m (default inf).
        stiffness: N m/rad, damping: N m s/rad: a spring-damper (PD drive) pulling the
            angle to ``target`` (rad, default 0), at most ``max_drive_torque`` N m.
        target_velocity: rad/s, the rate the drive's damping pulls the angle's to: the drive's
            torque is -stiffness (angle - target) - damping (rate - target_velocity), capped
            whole at ``max_drive_torque`` (PyBullet's POSITION_CONTROL with a targetVelocity;
            with stiffness 0, MuJoCo's velocity actuator with a forcerange: unlike
            ``motor_speed``, a finite gain). Default 0.
        torque: N m, a torque applied about the axis, on body_b and its opposite on body_a
            (PyBullet's ``TORQUE_CONTROL``, MuJoCo's ``motor`` actuator), every substep
            until changed (``JointSolver.set_effort``). Default 0.
        armature: kg m^2, >= 0: an inertia added to the angle's own (MuJoCo's joint
            ``armature``: a geared motor's rotor), so that the angle obeys
            (I_angle + armature) angle'' = torques. Default 0.
        passive_stiffness: N m/rad, passive_damping: N m s/rad, both >= 0: the joint's own
            spring to ``springref`` (rad) and damper (MuJoCo's joint ``stiffness``,
            ``springref`` and ``damping``), acting beside the drive and never capped by
            ``max_drive_torque``: a drive saturated at its cap still has them (MuJoCo caps an
            actuator's force alone). Default 0.
    """

    axis: Any = (0.0, 0.0, 1.0)
    lower: float | None = None
    upper: float | None = None
    motor_speed: float | None = None
    max_motor_torque: float = math.inf
    stiffness: float = 0.0
    damping: float = 0.0
    target: float = 0.0
    max_drive_torque: float = math.inf
    torque: float = 0.0
    armature: float = 0.0
    passive_stiffness: float = 0.0
    passive_damping: float = 0.0
    springref: float = 0.0
    target_velocity: float = 0.0
    kind: ClassVar[str] = "hinge"

    def _frame_world(self, axis_to_world):
        return _frame_from_z(axis_to_world(_unit(self.axis, "axis")))

    def _params(self, p, length):
        _drive_params(p, self, "max_motor_torque", "max_drive_torque", "torque")


@dataclass(eq=False)
class SliderJoint(Joint):
    """Slider (prismatic) joint: no relative rotation; body_b moves along ``axis`` only.

    The joint coordinate is the displacement (m) of body_b's anchor from body_a's along
    the axis, 0 at creation.

    Args:
        axis: (3,) slide direction (world, or body_a's frame with ``frame="body"``).
        lower, upper: m, optional position limits.
        motor_speed: m/s, optional target rate, with at most ``max_motor_force`` N.
        stiffness: N/m, damping: N s/m: spring-damper / PD drive to ``target`` (m), at
            most ``max_drive_force`` N.
        target_velocity: m/s, the rate the drive's damping pulls the displacement's to (as the
            hinge's). Default 0.
        force: N, a force applied along the axis at the anchor, on body_b and its opposite
            on body_a, every substep until changed (``JointSolver.set_effort``). Default 0.
        armature: kg, >= 0: a mass added to the displacement's own (MuJoCo's armature).
        passive_stiffness: N/m, passive_damping: N s/m, both >= 0: the joint's own spring to
            ``springref`` (m) and damper, beside the drive and never capped by
            ``max_drive_force`` (as the hinge's).
    """

    axis: Any = (0.0, 0.0, 1.0)
    lower: float | None = None
    upper: float | None = None
    motor_speed: float | None = None
    max_motor_force: float = math.inf
    stiffness: float = 0.0
    damping: float = 0.0
    target: float = 0.0
    max_drive_force: float = math.inf
    force: float = 0.0
    armature: float = 0.0
    passive_stiffness: float = 0.0
    passive_damping: float = 0.0
    springref: float = 0.0
    target_velocity: float = 0.0
    kind: ClassVar[str] = "slider"

    def _frame_world(self, axis_to_world):
        return _frame_from_z(axis_to_world(_unit(self.axis, "axis")))

    def _params(self, p, length):
        _drive_params(p, self, "max_motor_force", "max_drive_force", "force")


@dataclass(eq=False)
class FixedJoint(Joint):
    """Fixed (weld) joint: the two bodies keep their relative pose at creation."""

    kind: ClassVar[str] = "fixed"


@dataclass(eq=False)
class DistanceJoint(Joint):
    """Distance joint between ``anchor`` on body_a and ``anchor_b`` on body_b.

    The joint coordinate is the distance (m) between the anchors.

    Args:
        min_length, max_length: m. Both None (default): a rigid rod of the length at
            creation. One of them None: 0 or no upper bound. Equal: a rigid rod of that length. ``min_length=0`` and
            ``max_length=L``: a rope with slack (pulls only when taut).
        stiffness: N/m, damping: N s/m: a spring-damper along the line to ``target``
            (m, default the length at creation), at most ``max_drive_force`` N.
    """

    min_length: float | None = None
    max_length: float | None = None
    stiffness: float = 0.0
    damping: float = 0.0
    target: float | None = None
    max_drive_force: float = math.inf
    kind: ClassVar[str] = "distance"

    def _params(self, p, length):
        if self.min_length is None and self.max_length is None:
            lo = hi = length
        else:
            lo, hi = _limits(0.0 if self.min_length is None else self.min_length, self.max_length,
                             "min_length", "max_length")
            if lo < 0:
                raise InputError(f"must be >= 0, got {lo:g}", "min_length")
        if hi == lo == 0.0:
            raise InputError("a rigid distance joint needs a length > 0 (use a ball joint)", "max_length")
        p[P_LOWER], p[P_UPPER] = lo, hi
        p[P_LIMIT_ON] = 1.0
        p[P_RIGID] = float(lo == hi)
        p[P_STIFFNESS] = _number(self.stiffness, "stiffness", minimum=0.0)
        p[P_DAMPING] = _number(self.damping, "damping", minimum=0.0)
        p[P_TARGET] = length if self.target is None else _number(self.target, "target", minimum=0.0)
        p[P_MAX_DRIVE] = _number(self.max_drive_force, "max_drive_force", minimum=0.0, allow_inf=True)


@dataclass(eq=False)
class UniversalJoint(Joint):
    """Universal (Cardan) joint: the anchors coincide; body_a turns about ``axis`` fixed
    in it, body_b about ``axis_b`` fixed in it, and the two axes stay perpendicular.

    Its two angles, 0 at creation: with the joint frame x = axis, y = axis_b, z = x x y
    fixed in each body (world axes xa, ya, za of a's, xb, yb, zb of b's), the relative
    rotation is Q = Fa^T Fb = Rx(angle) Ry(angle_b) (the cross piece turns about ``axis``,
    then body_b about ``axis_b``), so

        angle   = atan2(za . yb, ya . yb)   about axis   (rate (wb - wa) . xa)
        angle_b = atan2(xa . zb, xa . xb)   about axis_b (rate (wb - wa) . yb)

    both in (-pi, pi], positive by the right-hand rule.

    Args:
        axis, axis_b: (3,) perpendicular at creation (world, or each body's frame).
        lower, upper: rad, optional limits of ``angle``; lower_b, upper_b: of ``angle_b``;
            each in [-pi, pi], lower <= upper; one left out is -pi or pi (as the ball
            joint's twist limits).
        motor_speed, motor_speed_b: rad/s, optional target rates of the two angles, reached
            with at most ``max_motor_torque``, ``max_motor_torque_b`` N m (default inf).
    """

    axis: Any = (1.0, 0.0, 0.0)
    axis_b: Any = (0.0, 1.0, 0.0)
    lower: float | None = None
    upper: float | None = None
    lower_b: float | None = None
    upper_b: float | None = None
    motor_speed: float | None = None
    max_motor_torque: float = math.inf
    motor_speed_b: float | None = None
    max_motor_torque_b: float = math.inf
    kind: ClassVar[str] = "universal"

    def _params(self, p, length):
        if lower_or_upper(self.lower, self.upper):
            lo, hi, on = _angle_limits(self.lower, self.upper, "lower", "upper")
            if on:
                p[P_LOWER], p[P_UPPER], p[P_LIMIT_ON] = lo, hi, 1.0
        if lower_or_upper(self.lower_b, self.upper_b):
            lo, hi, on = _angle_limits(self.lower_b, self.upper_b, "lower_b", "upper_b")
            if on:
                p[P_LOWER2], p[P_UPPER2], p[P_LIMIT2_ON] = lo, hi, 1.0
        if self.motor_speed is not None:
            p[P_MOTOR_ON] = 1.0
            p[P_MOTOR_SPEED] = _number(self.motor_speed, "motor_speed")
            p[P_MAX_MOTOR] = _number(self.max_motor_torque, "max_motor_torque", minimum=0.0, allow_inf=True)
        if self.motor_speed_b is not None:
            p[P_MOTOR2_ON] = 1.0
            p[P_MOTOR2_SPEED] = _number(self.motor_speed_b, "motor_speed_b")
            p[P_MAX_MOTOR2] = _number(self.max_motor_torque_b, "max_motor_torque_b", minimum=0.0, allow_inf=True)


@dataclass(eq=False)
class GearJoint(Joint):
    """Gear (coupling) between the coordinates of two hinge or slider joints: ``joint`` follows
    ``follows`` as

        q_joint = offset + ratio * q_follows

    (or the quartic ``polynomial``), each coordinate 0 at its joint's creation. Two hinges make a
    gear pair (ratio -2: turning the other way at half the teeth), a hinge and a slider a rack and
    pinion (m/rad), two sliders a gripper's mirrored fingers (ratio -1). It is URDF's
    ``<mimic joint multiplier offset>`` (``load_urdf``), MuJoCo's ``<equality><joint joint1 joint2
    polycoef>`` (``load_mjcf``: joint1 follows joint2, both measured from the model's pose), Box2D
    v2's b2GearJoint, Jolt's GearConstraint and RackAndPinionConstraint, PyBullet's ``JOINT_GEAR``.

    One row of the velocity solve spanning the up to four bodies of the two joints: its rate is
    rate_joint - p'(q_follows) rate_follows, its error q_joint - p(q_follows), soft as the other
    rigid rows (``JointSettings.hertz``); a Gauss-Seidel row around the tree solve with
    ``method="tree"`` (``tumble.solver.joint_gear``). The gear acts while both its joints do: a
    broken joint stops it.

    Args:
        joint: the joint that follows: its record, name or index in ``world.joints``, a hinge or
            a slider added before the gear.
        follows: the joint it follows (another hinge or slider); None: none, the joint is locked
            at q_joint = offset (``polynomial[0]``; MuJoCo's joint equality without joint2).
        ratio: dq_joint / dq_follows (rad/rad, m/rad, rad/m or m/m). Default 1.
        offset: q_joint when q_follows is 0 (rad or m). Default 0: the two keep their creation's
            relation.
        polynomial: optional (a0, ..., a4) (up to 5 numbers; the rest 0): q_joint = a0 + a1 q
            + a2 q^2 + a3 q^3 + a4 q^4 with q = q_follows, MuJoCo's ``polycoef``; replaces
            ``offset`` and ``ratio``.
        collide_connected: default True: a gear joins no bodies of its own (the bodies its
            joints join follow those joints' settings).
        name: optional label.

    ``body_a``, ``body_b`` and the anchor are set from the two joints (a body of each, for
    islands and checkpoints); the readings' ``position`` is the gear's error q_joint - p(q)
    (rad or m), ``rate`` its rate, and ``torque`` (a hinge) or ``force`` (a slider) what the gear
    applies to its ``joint``'s body b along that joint's axis (N m or N, world; the other is 0).
    """

    body_a: Any = None
    joint: Any = None
    follows: Any = None
    ratio: float = 1.0
    offset: float = 0.0
    polynomial: Any = None
    collide_connected: bool = True
    kind: ClassVar[str] = "gear"


JOINT_CLASSES = {"ball": BallJoint, "hinge": HingeJoint, "slider": SliderJoint, "fixed": FixedJoint,
                 "distance": DistanceJoint, "universal": UniversalJoint, "gear": GearJoint}


@dataclass
class BoundJoint:
    """A joint resolved against a world (what the solver reads).

    body_a, body_b: indices, -1 for the world. local_a, local_b: (3,) m, anchors in each
    body's frame (for the world: world point). frame_a, frame_b: (3, 3) joint axes
    (columns x, y, z) in each body's frame. param: (PARAM_COUNT,) see ``P_*``.
    """

    type_id: int
    body_a: int
    body_b: int
    local_a: np.ndarray
    local_b: np.ndarray
    frame_a: np.ndarray
    frame_b: np.ndarray
    param: np.ndarray
    # m, a distance joint's anchor distance at creation (the default of its rigid length and its
    # drive's target, which an edit of those fields needs again); nan: not known (a record read
    # from a checkpoint: ``_creation_length`` finds it in the row)
    length: float = math.nan


def _body_index(world, body, key) -> int:
    if body is None or (isinstance(body, str) and body == "world"):
        return -1
    try:
        return world.index_of(body)
    except InputError as err:
        raise InputError(err.problem, key) from None


# fields set freely after binding: the binding and the label (``broken``: set_broken)
_PLAIN_FIELDS = frozenset({"bound", "name"})
# fields resolved into the bound frames at ``add_joint``: an edit would have to re-resolve them
# at poses that are no longer the creation's (the joint's zero), so it is refused
_FIXED_FIELDS = frozenset({"body_a", "body_b", "anchor", "anchor_b", "frame", "axis", "axis_b", "joint", "follows"})
# the count of edits of bound records in this process (``edit_count``): a solver or simulator keeps
# the count it has seen and looks for edited records only when it moved (no loop over the joints
# in a step otherwise); and the count of edits of ``collide_connected`` (``pair_edit_count``)
_EDITS = [0, 0]


def edit_count() -> int:
    """The number of edits of bound joint records so far in this process (``mark_edited``)."""
    return _EDITS[0]


def pair_edit_count() -> int:
    """The number of edits of bound records' ``collide_connected`` so far (the contact step's
    pairs of jointed bodies that must not collide are made again when it moves)."""
    return _EDITS[1]


def mark_edited(joint: Joint):
    """Mark a bound record edited now: the solvers copy its parameter row (``bound.param``) into
    their tables at their next step and the Simulator wakes its bodies (``edited_since``)."""
    _EDITS[0] += 1
    object.__setattr__(joint, "_edit_stamp", _EDITS[0])


def edited_since(joints, seen: int) -> list[int]:
    """The indices in ``joints`` of the records edited after ``edit_count()`` was ``seen``."""
    return [k for k, rec in enumerate(joints) if rec._edit_stamp > seen]


def _param_row(joint: Joint, length: float) -> np.ndarray:
    """A non-gear record's parameter row (PARAM_COUNT,) from its fields (InputError on a bad one);
    ``length`` m: the anchors' distance at creation (a distance joint's defaults)."""
    param = np.zeros(PARAM_COUNT)
    param[P_LOWER], param[P_UPPER] = -math.inf, math.inf
    param[P_LOWER2], param[P_UPPER2] = -math.inf, math.inf
    param[P_MAX_MOTOR] = param[P_MAX_DRIVE] = param[P_MAX_MOTOR2] = param[P_BALL_MAX_DRIVE] = math.inf
    param[P_BALL_TARGET] = 1.0  # the identity quaternion: read by a ball joint's drive alone
    joint._params(param, length)
    param[P_MAX_FORCE] = _number(joint.max_force, "max_force", minimum=0.0, allow_inf=True)
    param[P_MAX_TORQUE] = _number(joint.max_torque, "max_torque", minimum=0.0, allow_inf=True)
    if not isinstance(joint.collide_connected, (bool, np.bool_)):
        raise InputError(f"expected true or false, got {joint.collide_connected!r}", "collide_connected")
    return param


def _creation_length(joint: Joint) -> float:
    """A bound record's anchor distance at creation, m (``BoundJoint.length``); for a record bound
    without it (read from a checkpoint), the row's default that holds it: the drive's target when
    the record gives none, else a rigid rod's length; nan when neither does (no field reads it)."""
    b = joint.bound
    if not math.isnan(b.length) or not isinstance(joint, DistanceJoint):
        return b.length
    if joint.target is None:
        return float(b.param[P_TARGET])
    if joint.min_length is None and joint.max_length is None:
        return float(b.param[P_LOWER])
    return math.nan


def _row_of_fields(joint: Joint, length: float) -> np.ndarray:
    if isinstance(joint, GearJoint):
        return _gear_row(joint, joint.bound.param[[G_JOINT, G_FOLLOWS]])
    return _param_row(joint, length)


def edit_joint(joint: Joint, name: str, value):
    """Set field ``name`` of a bound record to ``value`` (``Joint.__setattr__`` after binding):
    check it, write the parameter columns it decides into ``bound.param`` and mark the record
    edited. Only the columns whose value the field changes are written: the others keep what the
    run put there (a drive target or torque set through the Simulator, a robot's controls).
    InputError, the field left as it was: a bad value, or a field fixed at ``add_joint``."""
    if name == "broken":
        set_broken(joint, value)
        return
    if name in _FIXED_FIELDS:
        raise InputError(f"fixed when the joint was added (its zero and frames were resolved then): "
                         f"make a new joint for another {name}", name)
    length = _creation_length(joint)
    old = joint.__dict__[name]
    try:
        before = _row_of_fields(joint, length)
    except InputError:  # fields read from a file that never made its row: every column written
        before = np.full(PARAM_COUNT, np.nan)
    object.__setattr__(joint, name, value)
    try:
        after = _row_of_fields(joint, length)
        if isinstance(joint, DistanceJoint) and math.isnan(length) and (
                joint.target is None or (joint.min_length is None and joint.max_length is None)):
            raise InputError("the joint's length at creation is not known here (a record read from a "
                             "checkpoint written before session 38): give the lengths and target", name)
    except InputError:
        object.__setattr__(joint, name, old)
        raise
    changed = ~((before == after) | (np.isnan(before) & np.isnan(after)))
    joint.bound.param[changed] = after[changed]
    if name == "collide_connected":
        _EDITS[1] += 1
    mark_edited(joint)


def set_broken(joint: Joint, broken):
    """A bound record's ``broken`` set by its user (``joint.broken = True``): the joint stops
    acting from the next step (PyBullet's ``removeConstraint`` of a grasp, MuJoCo's
    ``eq_active`` off; its bodies collide again unless other joints join them); ``False``: it acts
    again, from its present pose's error (a repaired joint). Marked
    edited: the solver takes it at the next step and the Simulator wakes the two bodies.
    InputError: not true or false. (The solver sets it itself when a joint breaks: not an edit.)"""
    if not isinstance(broken, (bool, np.bool_)):
        raise InputError(f"expected true or false, got {broken!r}", "broken")
    if bool(broken) != joint.broken:
        object.__setattr__(joint, "broken", bool(broken))
        mark_edited(joint)


def bind_joint(world, joint: Joint) -> BoundJoint:
    """Check ``joint`` against ``world`` and resolve it at the current poses (InputError on bad input)."""
    if not isinstance(joint, Joint) or not joint.kind:
        raise InputError(f"not a joint record: {joint!r}", "joints")
    if isinstance(joint, GearJoint):
        return _bind_gear(world, joint)
    a = _body_index(world, joint.body_a, "body_a")
    b = _body_index(world, joint.body_b, "body_b")
    if a == b:
        what = "the world" if a < 0 else f"body {world.names[a]!r}"
        raise InputError(f"a joint needs two different bodies, got {what} twice", "body_b")
    if joint.frame not in ("world", "body"):
        raise InputError(f"must be 'world' or 'body', got {joint.frame!r}", "frame")

    def pose(i):
        if i < 0:
            return np.eye(3), np.zeros(3)
        return np.array(world.R[i]), np.array(world.x[i])

    Ra, xa = pose(a)
    Rb, xb = pose(b)
    anchor = finite_vector(joint.anchor, "anchor")
    body_frame = joint.frame == "body"
    # products without BLAS (math3d.mat_vec's note): the same bits on every machine
    pa = mat_vec(Ra, anchor) + xa if body_frame else anchor
    if joint.anchor_b is None:
        pb = pa
    else:
        ab = finite_vector(joint.anchor_b, "anchor_b")
        pb = mat_vec(Rb, ab) + xb if body_frame else ab
    local_a = mat_t_vec(Ra, pa - xa)
    local_b = mat_t_vec(Rb, pb - xb)

    if isinstance(joint, UniversalJoint):
        ua = _unit(joint.axis, "axis")
        ub = _unit(joint.axis_b, "axis_b")
        ua = mat_vec(Ra, ua) if body_frame else ua
        ub = mat_vec(Rb, ub) if body_frame else ub
        if abs(float(ua @ ub)) > 1e-6:
            raise InputError(f"axis and axis_b must be perpendicular (cosine {float(ua @ ub):.3g})", "axis_b")
        frame_world = np.column_stack([ua, ub, np.cross(ua, ub)])
    else:
        frame_world = joint._frame_world(lambda u: mat_vec(Ra, np.asarray(u, dtype=float)) if body_frame else u)

    length = float(norm3(pb - pa))
    param = _param_row(joint, length)
    frame_world = np.ascontiguousarray(frame_world, dtype=float)
    bound = BoundJoint(JOINT_TYPES[joint.kind], a, b, local_a, local_b, mat_t_mat(Ra, frame_world),
                       mat_t_mat(Rb, frame_world), param, length)
    joint.bound = bound
    return bound


def joint_index(world, ref, key) -> int:
    """The index in ``world.joints`` of a joint given as its record, its name or an index
    (InputError keyed ``key`` when there is none)."""
    joints = world.joints
    if isinstance(ref, Joint):
        for k, rec in enumerate(joints):
            if rec is ref:
                return k
        raise InputError("the joint is not in this world (add it first)", key)
    if isinstance(ref, str):
        for k, rec in enumerate(joints):
            if rec.name == ref:
                return k
        raise InputError(f"unknown joint {ref!r}", key)
    if isinstance(ref, (int, np.integer)) and not isinstance(ref, bool) and 0 <= ref < len(joints):
        return int(ref)
    raise InputError(f"expected a joint record, a joint name or an index below {len(joints)}, got {ref!r}", key)


def _gear_row(gear: GearJoint, ends) -> np.ndarray:
    """A gear's parameter row (PARAM_COUNT,): its joints' indices ``ends`` (joint, follows; -1: a
    lock) and the polynomial's coefficients from the record (InputError on a bad field)."""
    coef = np.zeros(5)
    if gear.polynomial is not None:
        if isinstance(gear.polynomial, (str, bytes)) or not hasattr(gear.polynomial, "__len__") \
                or not 1 <= len(gear.polynomial) <= 5:
            raise InputError(f"expected 1 to 5 numbers (a0, ..., a4), got {gear.polynomial!r}", "polynomial")
        for i, value in enumerate(gear.polynomial):
            coef[i] = _number(value, f"polynomial[{i}]")
    else:
        coef[0] = _number(gear.offset, "offset")
        coef[1] = _number(gear.ratio, "ratio")
    if not isinstance(gear.collide_connected, (bool, np.bool_)):
        raise InputError(f"expected true or false, got {gear.collide_connected!r}", "collide_connected")
    for key in ("max_force", "max_torque"):
        if getattr(gear, key) != math.inf:
            raise InputError("a gear does not break (give max_force / max_torque to its joints)", key)
    param = np.zeros(PARAM_COUNT)
    param[G_JOINT], param[G_FOLLOWS] = ends
    param[G_COEF:G_COEF + 5] = coef  # over P_MAX_FORCE too: a gear does not break (the store kernel's gear branch)
    return param


def _bind_gear(world, gear: GearJoint) -> BoundJoint:
    """A gear's bound row: the two joints' indices and the polynomial's coefficients (``G_*``)."""
    ends = []
    for key in ("joint", "follows"):
        if key == "follows" and gear.follows is None:  # a lock: q_joint = offset (MuJoCo's equality without joint2)
            ends.append(-1)
            continue
        k = joint_index(world, getattr(gear, key), key)
        rec = world.joints[k]
        if rec.kind not in ("hinge", "slider"):
            raise InputError(f"a gear couples hinge and slider joints, not a {rec.kind} joint", key)
        ends.append(k)
    if ends[0] == ends[1]:
        raise InputError("a gear needs two different joints, got the same twice", "follows")
    param = _gear_row(gear, ends)
    # a moving body of each joint (its body_b unless that is the world): islands join them, checkpoints name them
    bodies = []
    for k in ends:
        bj = world.joints[k if k >= 0 else ends[0]].bound
        bodies.append(bj.body_b if bj.body_b >= 0 else bj.body_a)
    if bodies[0] == bodies[1]:
        bodies[1] = world.joints[ends[1] if ends[1] >= 0 else ends[0]].bound.body_a
    z = np.zeros(3)
    bound = BoundJoint(JOINT_GEAR, bodies[0], bodies[1], z, z.copy(), np.eye(3), np.eye(3), param)
    gear.bound = bound
    return bound


def set_record_target(joint: Joint, value, velocity=None) -> np.ndarray:
    """Check ``value`` as a bound joint's drive target and write it into the record and its
    parameter row (a checkpoint carries both; the record marked edited): rad or m (``P_TARGET``)
    for a hinge, slider or distance joint; a rotation (``ball_target_quaternion``: rotation vector
    or quaternion) for a ball joint, and ``velocity`` (3,) rad/s its target velocity (None: left as
    it is; a hinge's or slider's: one number, rad/s or m/s, ``P_TARGET_RATE``). Returns the row's
    target column(s) (a ball joint's: quaternion then velocity, (7,); a hinge's or slider's: target
    and target velocity, (2,); a distance joint's: (1,)).
    InputError: not a target of that joint."""
    p = joint.bound.param
    t = joint.bound.type_id
    if t == JOINT_BALL:
        q = ball_target_quaternion(value, "target")
        if velocity is not None:
            rate = finite_vector(velocity, "target_velocity")
            object.__setattr__(joint, "target_velocity", [float(c) for c in rate])
            p[P_BALL_RATE:P_BALL_RATE + 3] = rate
        object.__setattr__(joint, "target", [float(c) for c in q])
        object.__setattr__(joint, "target_euler_deg", None)
        p[P_BALL_TARGET:P_BALL_TARGET + 4] = q
        mark_edited(joint)
        return np.concatenate([q, p[P_BALL_RATE:P_BALL_RATE + 3]])
    if velocity is not None and t not in (JOINT_HINGE, JOINT_SLIDER):
        raise InputError(f"a {joint.kind} joint's drive takes no target velocity (a hinge's, slider's or ball "
                         "joint's does)", "target_velocity")
    if t not in (JOINT_HINGE, JOINT_SLIDER, JOINT_DISTANCE):
        raise InputError(f"a {joint.kind} joint has no drive target", "joint")
    target = _number(value, "target", minimum=0.0 if t == JOINT_DISTANCE else None)
    if velocity is not None:
        rate = _number(velocity, "target_velocity")
        object.__setattr__(joint, "target_velocity", rate)
        p[P_TARGET_RATE] = rate
    object.__setattr__(joint, "target", target)
    p[P_TARGET] = target
    mark_edited(joint)
    return np.array([target, p[P_TARGET_RATE]]) if t != JOINT_DISTANCE else np.array([target])


def set_record_effort(joint: Joint, value) -> float:
    """Check ``value`` as the torque (N m, a hinge) or force (N, a slider) a bound joint applies
    along its coordinate and write it into the record (its ``torque`` or ``force``) and its
    parameter row (``P_EFFORT``; a checkpoint carries both); the record marked edited. Returns
    it. InputError: not a number, not finite, or not a hinge or slider."""
    effort = _number(value, "torque")
    if joint.bound.type_id not in (JOINT_HINGE, JOINT_SLIDER):
        raise InputError(f"only hinge and slider joints take a torque or force, not a {joint.kind} joint", "joint")
    object.__setattr__(joint, "torque" if joint.bound.type_id == JOINT_HINGE else "force", effort)
    joint.bound.param[P_EFFORT] = effort
    mark_edited(joint)
    return effort


def jointed_body_pairs(world) -> np.ndarray:
    """(K, 2) int64 body index pairs (low, high) that must not collide: both ends of every
    joint with ``collide_connected=False`` that is not broken and not attached to the world,
    sorted and without repeats. The contact step skips these pairs."""
    pairs = set()
    for j in getattr(world, "joints", ()):
        bj = j.bound
        if bj is None or j.collide_connected or j.broken or bj.body_a < 0 or bj.body_b < 0:
            continue
        pairs.add((min(bj.body_a, bj.body_b), max(bj.body_a, bj.body_b)))
    out = np.array(sorted(pairs), dtype=np.int64)
    return out.reshape(-1, 2)
