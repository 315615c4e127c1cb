"""Joint solver: Box2D v3's soft step for joints, in Numba kernels over joint arrays.

Reads the bound joint records of ``World.joints`` (``tumble.joints``) into arrays once,
then per step (dt = ``substeps`` x h), in the order of Box2D v3's ``b2SolverStage``
(Catto, "Solver2D", https://box2d.org/posts/2024/02/solver2d/):

    JointSolver.prepare(world, h[, inv_mass, I_inv])   tables if joints changed; softness for h
    per substep:
        (caller) integrate velocities                  v += h F/m, omega from L += h tau
        JointSolver.warm_start(v, omega, x, R)         the accumulated impulses of the last substep
        JointSolver.solve(v, omega, x, R, True)        soft rows (bias pulls the error out)
        (caller) integrate positions                   x += h v, q by the exact rotation
        JointSolver.solve(v, omega, x, R, False)       relax: rigid rows, no bias
    JointSolver.project(x, q, R)                       NGS position projection (off by default)
    JointSolver.store(v, omega, x, R)                  reactions, coordinates, breaking

Each joint is a set of rows solved by sequential impulses (Gauss-Seidel over joints, in
the order they were added; Catto, "Iterative dynamics with temporal coherence", 2005):
the 1-D joint coordinate first (spring/PD drive, motor, lower and upper limit), then a
second angular coordinate where the joint has one (a ball joint's twist, a universal
joint's angle about axis_b: motor, lower and upper limit; ``_solve_axial2``), then the
rigid blocks, each solved exactly as a block (angular 3x3 / 2x2 / 1x1, then the anchor
3x3, or the slider's 2x2 perpendicular rows), the anchor last since it matters most
(Box2D ``b2SolveRevoluteJoint``). Rows read the current poses (x, R), so arms and errors
follow the bodies through the substeps; the inverse world inertia is the caller's
``I_inv`` (N, 3, 3) at call time. With ``method="tree"`` the rigid rows of a spanning
forest are instead solved exactly in linear time (Baraff 1996; ``tree_solve_kernel``).

``step_with_joints`` is a standalone stepper (the World's built-in forces and joints; no
contacts, no user callables) in the stage order of the Simulator's soft step
(``solver.soft_step``). It differs in its forces (evaluated once a step, not every substep),
its velocity update (the gyroscopic term by one implicit Newton step, where the soft step
keeps L as the state) and the NGS projection (``position_iterations``), which only it runs.

NOTE: this module is over STYLE's ~600 lines; the natural cut is the tree solve
(``_joint_rows`` to the end) into a module of its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from ..joints import (
    JOINT_BALL,
    JOINT_DISTANCE,
    JOINT_HINGE,
    JOINT_SLIDER,
    JOINT_UNIVERSAL,
    P_DAMPING,
    P_LIMIT2_ON,
    P_LIMIT_ON,
    P_LOWER,
    P_LOWER2,
    P_MAX_DRIVE,
    P_MAX_FORCE,
    P_MAX_MOTOR,
    P_MAX_MOTOR2,
    P_MAX_TORQUE,
    P_MOTOR2_ON,
    P_MOTOR2_SPEED,
    P_MOTOR_ON,
    P_MOTOR_SPEED,
    P_RIGID,
    P_STIFFNESS,
    P_TARGET,
    P_UPPER,
    P_UPPER2,
    PARAM_COUNT,
)
from ..math3d import (
    JIT,
    normalize_quat_inplace,
    quat_exp_multiply_inplace,
    quat_to_matrix_into,
)
from .contact import SweepOrder

# columns of ``axial_impulse`` (J, AXIAL_COUNT): accumulated impulses of the 1-D coordinate
# rows (spring, motor, lower, upper, equal), then of the second angular coordinate (a ball
# joint's twist, a universal joint's angle about axis_b: lower, upper limit, motor), then
# the anchor impulse (x, y, z world, N s) that the motor rows and the spring/PD drive row add
# to keep the anchor's velocity (``_solve_axial``'s ``comp``), kept apart from the anchor's
# own ``linear_impulse`` so that the soft anchor row's impulse scale does not relax it
# (see ``_axial_apply``)
A_SPRING, A_MOTOR, A_LOWER, A_UPPER, A_EQUAL = 0, 1, 2, 3, 4
A_LOWER2, A_UPPER2, A_MOTOR2 = 5, 6, 7
A_MOTOR_ANCHOR = 8
AXIAL_COUNT = 11


@dataclass
class JointSettings:
    """Tuning of the joint solver.

    hertz: Hz, stiffness of the rigid rows' error correction in the biased solve (Box2D v3:
        2 x contact hertz = 60 Hz), capped at ``hertz_cap_per_substep / h``. 0 makes the
        rows rigid: the bias removes the whole error of the last substep in one (Baumgarte 1).
    damping_ratio: of that soft correction (Box2D v3's joint damping ratio, 2).
    velocity_iterations: Gauss-Seidel sweeps per biased solve (Box2D: 1).
    relax_iterations: sweeps per relax solve (Box2D: 1).
    position_iterations: NGS sweeps of ``project`` (0: no projection, Box2D's choice).
        Stops early once every rigid row's error is below ``position_tolerance`` (m or rad).
    bias_factor: with hertz 0, the fraction of the error the bias removes per substep
        (Baumgarte's beta; 1 by default).
    method: "gauss-seidel" (Box2D: every row by sequential impulses) or "tree": the rigid
        rows of a spanning forest of the joint graph solved exactly in linear time (Baraff
        1996), loop-closing joints and all 1-D coordinate rows (limits, motors, springs) by
        Gauss-Seidel around it, ``velocity_iterations`` / ``relax_iterations`` times. With
        "tree", the rows are rigid with bias rate 1/h (hertz 0) or the soft bias rate of
        ``hertz`` (no mass or impulse scaling).
    partitions: (2) a world with at least ``partition_min_joints`` (256) joints sweeps them in
        this many spatial slabs side by side (one per core), then the joints joining two slabs,
        as the contacts (``contact.SoftStepSettings.partitions``); the bits follow these two
        settings, never the number of threads; 1: every joint in its own order on one thread.
    """

    hertz: float = 60.0
    damping_ratio: float = 2.0
    hertz_cap_per_substep: float = 0.25
    velocity_iterations: int = 1
    relax_iterations: int = 1
    position_iterations: int = 0
    position_tolerance: float = 1e-10
    method: str = "gauss-seidel"
    bias_factor: float = 1.0
    partitions: int = 2
    partition_min_joints: int = 256

    def __post_init__(self):
        if self.method not in ("gauss-seidel", "tree"):
            raise ValueError(f"method must be 'gauss-seidel' or 'tree', got {self.method!r}")


# Settings for accuracy (the acceptance tests of issue 4): rigid rows solved exactly on the
# spanning tree, two sweeps for the 1-D rows around it. See docs/joints.md for what each costs.
ACCURATE = JointSettings(hertz=0.0, velocity_iterations=2, relax_iterations=2, method="tree")


# ---------------------------------------------------------------------- vector helpers (tuples)
@njit(**JIT)
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(**JIT)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(**JIT)
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(**JIT)
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(**JIT)
def _scale(s, a):
    return (s * a[0], s * a[1], s * a[2])


@njit(**JIT)
def _mat_vec(M, i, a):
    """M[i] @ a, or 0 for the world (i < 0)."""
    if i < 0:
        return (0.0, 0.0, 0.0)
    return (M[i, 0, 0] * a[0] + M[i, 0, 1] * a[1] + M[i, 0, 2] * a[2],
            M[i, 1, 0] * a[0] + M[i, 1, 1] * a[1] + M[i, 1, 2] * a[2],
            M[i, 2, 0] * a[0] + M[i, 2, 1] * a[1] + M[i, 2, 2] * a[2])


@njit(**JIT)
def _anchor(x, R, i, local, j):
    """(arm, point): arm R_i l from the centre of mass and the world point, of local[j]."""
    lj = (local[j, 0], local[j, 1], local[j, 2])
    if i < 0:
        return (0.0, 0.0, 0.0), lj
    r = _mat_vec(R, i, lj)
    return r, (r[0] + x[i, 0], r[1] + x[i, 1], r[2] + x[i, 2])


@njit(**JIT)
def _axis(R, i, frame, j, col):
    """World direction of column ``col`` of the joint frame ``frame[j]`` of body i."""
    f = (frame[j, 0, col], frame[j, 1, col], frame[j, 2, col])
    if i < 0:
        return f
    return _mat_vec(R, i, f)


@njit(**JIT)
def _inv_m(inv_mass, i):
    return inv_mass[i] if i >= 0 else 0.0


@njit(**JIT)
def _point_velocity(v, omega, i, r):
    if i < 0:
        return (0.0, 0.0, 0.0)
    w = (omega[i, 0], omega[i, 1], omega[i, 2])
    c = _cross(w, r)
    return (v[i, 0] + c[0], v[i, 1] + c[1], v[i, 2] + c[2])


@njit(**JIT)
def _angular_velocity(omega, i):
    if i < 0:
        return (0.0, 0.0, 0.0)
    return (omega[i, 0], omega[i, 1], omega[i, 2])


@njit(**JIT)
def _apply_linear(v, omega, inv_mass, I_inv, a, b, ra, rb, p):
    """Impulse p (world) on b at arm rb and -p on a at arm ra."""
    if a >= 0:
        ma = inv_mass[a]
        w = _mat_vec(I_inv, a, _cross(ra, p))
        for k in range(3):
            v[a, k] -= ma * p[k]
            omega[a, k] -= w[k]
    if b >= 0:
        mb = inv_mass[b]
        w = _mat_vec(I_inv, b, _cross(rb, p))
        for k in range(3):
            v[b, k] += mb * p[k]
            omega[b, k] += w[k]


@njit(**JIT)
def _apply_angular(omega, I_inv, a, b, t):
    """Angular impulse t (world) on b and -t on a."""
    if a >= 0:
        w = _mat_vec(I_inv, a, t)
        for k in range(3):
            omega[a, k] -= w[k]
    if b >= 0:
        w = _mat_vec(I_inv, b, t)
        for k in range(3):
            omega[b, k] += w[k]


@njit(**JIT)
def _row_mass(inv_mass, I_inv, a, b, linear, n, ra, rb):
    """J M^-1 J^T of a row: linear along n at arms ra, rb, or angular about n."""
    if linear:
        ca = _cross(ra, n)
        cb = _cross(rb, n)
        return (_inv_m(inv_mass, a) + _inv_m(inv_mass, b)
                + _dot(ca, _mat_vec(I_inv, a, ca)) + _dot(cb, _mat_vec(I_inv, b, cb)))
    return _dot(n, _mat_vec(I_inv, a, n)) + _dot(n, _mat_vec(I_inv, b, n))


@njit(**JIT)
def _slider_rows(inv_mass, I_inv, R, a, b, frame_a, j, ra, rb):
    """A slider's two linear rows, across its axis: the unit axes p1, p2 (3,) (world frame;
    columns 0 and 1 of joint j's frame on body a) and the rows' 2x2 K = J M^-1 J^T as k11, k12,
    k22 (1/kg), at arms ra (a's centre to b's anchor) and rb (m, world frame). Shared by the
    velocity solve and the position projection."""
    p1 = _axis(R, a, frame_a, j, 0)
    p2 = _axis(R, a, frame_a, j, 1)
    k11 = _row_mass(inv_mass, I_inv, a, b, True, p1, ra, rb)
    k22 = _row_mass(inv_mass, I_inv, a, b, True, p2, ra, rb)
    k12 = (_dot(_cross(ra, p1), _mat_vec(I_inv, a, _cross(ra, p2)))
           + _dot(_cross(rb, p1), _mat_vec(I_inv, b, _cross(rb, p2))))
    return p1, p2, k11, k12, k22


@njit(**JIT)
def _row_velocity(v, omega, a, b, linear, n, ra, rb):
    if linear:
        return _dot(n, _sub(_point_velocity(v, omega, b, rb), _point_velocity(v, omega, a, ra)))
    return _dot(n, _sub(_angular_velocity(omega, b), _angular_velocity(omega, a)))


@njit(**JIT)
def _row_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, impulse):
    if linear:
        _apply_linear(v, omega, inv_mass, I_inv, a, b, ra, rb, _scale(impulse, n))
    else:
        _apply_angular(omega, I_inv, a, b, _scale(impulse, n))


@njit(**JIT)
def _solve3(K, r):
    """K^-1 r for a symmetric 3x3 K given as 6 numbers (k00, k01, k02, k11, k12, k22); 0 if singular."""
    k00, k01, k02, k11, k12, k22 = K
    c00 = k11 * k22 - k12 * k12
    c01 = k02 * k12 - k01 * k22
    c02 = k01 * k12 - k02 * k11
    det = k00 * c00 + k01 * c01 + k02 * c02
    if det == 0.0:
        return (0.0, 0.0, 0.0)
    c11 = k00 * k22 - k02 * k02
    c12 = k01 * k02 - k00 * k12
    c22 = k00 * k11 - k01 * k01
    inv = 1.0 / det
    return ((c00 * r[0] + c01 * r[1] + c02 * r[2]) * inv,
            (c01 * r[0] + c11 * r[1] + c12 * r[2]) * inv,
            (c02 * r[0] + c12 * r[1] + c22 * r[2]) * inv)


@njit(**JIT)
def _point_K(inv_mass, I_inv, a, b, ra, rb):
    """K = (ma + mb) 1 + S_a Ia S_a^T + S_b Ib S_b^T, S = [r]x, as (k00, k01, k02, k11, k12, k22)."""
    m = _inv_m(inv_mass, a) + _inv_m(inv_mass, b)
    k00, k01, k02, k11, k12, k22 = m, 0.0, 0.0, m, 0.0, m
    for side in range(2):
        i = a if side == 0 else b
        if i < 0:
            continue
        r = ra if side == 0 else rb
        # rows of [r]x
        s0 = (0.0, -r[2], r[1])
        s1 = (r[2], 0.0, -r[0])
        s2 = (-r[1], r[0], 0.0)
        t0 = _mat_vec(I_inv, i, s0)
        t1 = _mat_vec(I_inv, i, s1)
        t2 = _mat_vec(I_inv, i, s2)
        k00 += _dot(s0, t0)
        k01 += _dot(s0, t1)
        k02 += _dot(s0, t2)
        k11 += _dot(s1, t1)
        k12 += _dot(s1, t2)
        k22 += _dot(s2, t2)
    return (k00, k01, k02, k11, k12, k22)


@njit(**JIT)
def _angular_K(I_inv, a, b):
    k00 = k01 = k02 = k11 = k12 = k22 = 0.0
    for side in range(2):
        i = a if side == 0 else b
        if i >= 0:
            k00 += I_inv[i, 0, 0]
            k01 += I_inv[i, 0, 1]
            k02 += I_inv[i, 0, 2]
            k11 += I_inv[i, 1, 1]
            k12 += I_inv[i, 1, 2]
            k22 += I_inv[i, 2, 2]
    return (k00, k01, k02, k11, k12, k22)


@njit(**JIT)
def _solve2(k00, k01, k11, r0, r1):
    det = k00 * k11 - k01 * k01
    if det == 0.0:
        return 0.0, 0.0
    inv = 1.0 / det
    return (k11 * r0 - k01 * r1) * inv, (k00 * r1 - k01 * r0) * inv


@njit(**JIT)
def _wrap(angle):
    return angle - 2.0 * math.pi * math.floor((angle + math.pi) / (2.0 * math.pi))


@njit(**JIT)
def _coordinate_row(t, j, a, b, x, R, local_a, local_b, frame_a, frame_b, last_position):
    """The joint's 1-D coordinate: (has_row, linear, n, arm_a, arm_b, position).

    hinge: angle of b about the axis (rad), unwrapped around ``last_position``;
    slider: displacement along the axis (m), arm of a is ra + d (Box2D prismatic);
    distance: length (m) along the unit line a -> b; ball: swing angle between the cone
    axes (rad), about their common normal; universal: the angle about ``axis`` (rad, in
    (-pi, pi], ``tumble.joints.UniversalJoint``), rate about a's axis.
    """
    ra, pa = _anchor(x, R, a, local_a, j)
    rb, pb = _anchor(x, R, b, local_b, j)
    d = _sub(pb, pa)
    za = _axis(R, a, frame_a, j, 2)
    if t == JOINT_HINGE:
        xa = _axis(R, a, frame_a, j, 0)
        ya = _axis(R, a, frame_a, j, 1)
        xb = _axis(R, b, frame_b, j, 0)
        yb = _axis(R, b, frame_b, j, 1)
        angle = math.atan2(_dot(ya, xb) - _dot(xa, yb), _dot(xa, xb) + _dot(ya, yb))
        base = last_position[j]
        return True, False, za, ra, rb, base + _wrap(angle - base)
    if t == JOINT_SLIDER:
        return True, True, za, _add(ra, d), rb, _dot(d, za)
    if t == JOINT_DISTANCE:
        length = math.sqrt(_dot(d, d))
        if length < 1e-12:
            return False, True, za, ra, rb, 0.0
        return True, True, _scale(1.0 / length, d), ra, rb, length
    if t == JOINT_BALL:
        zb = _axis(R, b, frame_b, j, 2)
        s = _cross(za, zb)
        sn = math.sqrt(_dot(s, s))
        if sn < 1e-12:
            return False, False, za, ra, rb, 0.0 if _dot(za, zb) > 0 else math.pi
        return True, False, _scale(1.0 / sn, s), ra, rb, math.atan2(sn, _dot(za, zb))
    if t == JOINT_UNIVERSAL:
        # Q = Fa^T Fb = Rx(angle) Ry(angle_b): b's y axis in a's joint frame is (0, cos, sin)
        xa = _axis(R, a, frame_a, j, 0)
        ya = _axis(R, a, frame_a, j, 1)
        yb = _axis(R, b, frame_b, j, 1)
        return True, False, xa, ra, rb, math.atan2(_dot(za, yb), _dot(ya, yb))
    return False, False, za, ra, rb, 0.0


@njit(**JIT)
def twist_angle(xa, ya, za, xb, yb, zb):
    """Twist (rad, in (-pi, pi]) of frame b relative to frame a about the z axis, by the
    swing-twist decomposition Q = Fa^T Fb = Q_swing Q_twist (Q_twist about z, Q_swing
    about an axis perpendicular to z; Jolt's SwingTwistConstraint). With Q's unit
    quaternion (w, v), tan(twist / 2) = v_z / w, hence sin twist = 2 w v_z / (w^2 + v_z^2)
    and cos twist = (w^2 - v_z^2) / (w^2 + v_z^2); with Q_yx - Q_xy = 4 w v_z and
    Q_xx + Q_yy = 2 (w^2 - v_z^2),

        twist = atan2(ya.xb - xa.yb, xa.xb + ya.yb)

    (the hinge angle's formula: with no swing the two agree). Rounding error about
    eps / (w^2 + v_z^2) = eps / cos^2(swing / 2); the form 2 atan2(4 w v_z, 4 w^2) has an
    extra 1 / |w| near twist pi. The axes are (3,) unit vectors of the two right-handed
    frames, in any common frame. 0 where the twist is undefined (swing pi: w = v_z = 0)."""
    return math.atan2(_dot(ya, xb) - _dot(xa, yb), _dot(xa, xb) + _dot(ya, yb))


@njit(**JIT)
def _second_row(t, j, a, b, R, frame_a, frame_b):
    """The joint's second angular coordinate: (has_row, n, position).

    ball: the twist about the cone axis (``twist_angle``); its rate is (wb - wa) . n with
    n = (za + zb) / (1 + za . zb) (the time derivative of 2 atan2(v_z, w) under
    dQ/dt = [wb - wa] Q; n = za at zero swing), no row near swing pi where it blows up.
    universal: the angle about axis_b, atan2(xa . zb, xa . xb), rate (wb - wa) . yb.
    """
    xa = _axis(R, a, frame_a, j, 0)
    za = _axis(R, a, frame_a, j, 2)
    xb = _axis(R, b, frame_b, j, 0)
    yb = _axis(R, b, frame_b, j, 1)
    zb = _axis(R, b, frame_b, j, 2)
    if t == JOINT_BALL:
        ya = _axis(R, a, frame_a, j, 1)
        c = 1.0 + _dot(za, zb)
        if c < 1e-6:
            return False, za, 0.0
        return True, _scale(1.0 / c, _add(za, zb)), twist_angle(xa, ya, za, xb, yb, zb)
    if t == JOINT_UNIVERSAL:
        return True, yb, math.atan2(_dot(xa, zb), _dot(xa, xb))
    return False, za, 0.0


@njit(**JIT)
def _axial_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, comp, j, acc, col, impulse):
    """A 1-D coordinate row's impulse, with the anchor impulse ``comp`` per unit that keeps
    the anchor's velocity (zero for rows without an anchor block), accumulated in
    ``acc[j, col:col + 3]``: the anchor's ``linear_impulse`` (col 0) for limits,
    ``axial_impulse[:, A_MOTOR_ANCHOR:]`` for motors and the spring/PD drive.

    Why motors apart: the soft anchor row takes ``impulse_scale`` x its accumulated impulse
    back every biased sweep (Box2D's softness). A motor with unlimited torque put its
    compensation there each sweep and takes back none of its own impulse (its row has no
    softness, no clamp), while the warm start applies the motor's full angular impulse
    about the body's centre: what the anchor relaxed, a force at the anchor arm, spun the
    body about its centre, and the motor answered with more. A box on a hinge driven at
    1 rad/s with ``JointSettings()`` reached 1e8 rad/s in two steps of 1/240 s; stable with
    hertz 0 (impulse scale 0) or a finite torque (measured). Kept apart, motor row and its
    compensation act as one rigid row about the anchor, warm started whole: the same box
    holds 1 rad/s to 1.3e-5 rad/s (tests/physics/test_joints_stability.py). A stiff PD
    drive did the same (its row's own softness gamma is tiny when stiff): a 1 m arm driven
    to 1 rad with 1e5 N m/rad, 1e4 N m s/rad spun at 280 rad/s and sat at 0.54 rad after
    2 s; apart, it rests at 1 rad (as with rigid rows). Limits have their own softness
    (the impulse scale) and a one-sided clamp and were stable; they stay in
    ``linear_impulse`` so that their numbers do not change."""
    _row_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, impulse)
    if comp[0] != 0.0 or comp[1] != 0.0 or comp[2] != 0.0:
        p = _scale(impulse, comp)
        _apply_linear(v, omega, inv_mass, I_inv, a, b, ra, rb, p)
        for k in range(3):
            acc[j, col + k] += p[k]


@njit(**JIT)
def _solve_motor_row(j, slot, speed, max_impulse, m_eff, a, b, linear, n, ra, rb, comp, inv_mass, I_inv,
                     v, omega, axial_impulse):
    """A motor on one joint coordinate (row n, linear or angular): drives the row's rate to
    ``speed`` (m/s or rad/s) with an accumulated impulse ``axial_impulse[j, slot]`` clamped to
    +-``max_impulse`` (N s or N m s: the force or torque limit times h); its anchor
    compensation goes to ``axial_impulse[j, A_MOTOR_ANCHOR:]`` (see ``_axial_apply``)."""
    cdot = _row_velocity(v, omega, a, b, linear, n, ra, rb)
    old = axial_impulse[j, slot]
    new = min(max(old - m_eff * (cdot - speed), -max_impulse), max_impulse)
    axial_impulse[j, slot] = new
    _axial_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, comp, j, axial_impulse, A_MOTOR_ANCHOR,
                 new - old)


@njit(**JIT)
def _solve_limit_rows(j, slot0, lower, upper, pos, a, b, linear, n, ra, rb, comp, m_eff, soft, inv_h,
                      inv_mass, I_inv, v, omega, linear_impulse, axial_impulse):
    """The lower and upper limit rows of one joint coordinate (``pos``, rad or m, along row n:
    linear or angular), accumulated in ``axial_impulse[j, slot0]`` and ``[j, slot0 + 1]``: a
    one-sided row each, speculative while the limit is apart (the gap may close within this
    substep, no more), soft once crossed (Box2D v3's revolute and prismatic limits). An infinite
    bound has no row. Shared by the first coordinate (``_solve_axial``) and the second
    (``_solve_axial2``: a ball joint's twist, a universal joint's angle about axis_b)."""
    for side in range(2):
        # lower: C = pos - lower >= 0; upper: C = upper - pos >= 0 (the row reversed)
        sign = 1.0 if side == 0 else -1.0
        bound = lower if side == 0 else upper
        if math.isinf(bound):
            continue
        C = sign * (pos - bound)
        bias, ms, iscale = 0.0, 1.0, 0.0
        if C > 0.0:
            bias = C * inv_h  # speculative: the gap may close within this substep, no more
        else:
            bias, ms, iscale = soft[0] * C, soft[1], soft[2]
        slot = slot0 + side
        cdot = sign * _row_velocity(v, omega, a, b, linear, n, ra, rb)
        old = axial_impulse[j, slot]
        new = max(old - m_eff * ms * (cdot + bias) - iscale * old, 0.0)
        axial_impulse[j, slot] = new
        _axial_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, comp, j, linear_impulse, 0,
                     sign * (new - old))


@njit(**JIT, inline="always")
def _solve_axial(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, param, position, inv_mass, I_inv,
                 h, inv_h, soft, v, omega, linear_impulse, axial_impulse):
    """Spring/PD drive, motor, then limits (or the rigid length of a distance joint) on the 1-D coordinate."""
    p = param[j]
    if (p[P_STIFFNESS] == 0.0 and p[P_DAMPING] == 0.0 and p[P_MOTOR_ON] == 0.0 and p[P_RIGID] == 0.0
            and p[P_LIMIT_ON] == 0.0):
        return  # PERF: most joints (a net, a chain) have no 1-D rows; skip their geometry
    has, linear, n, ra, rb, pos = _coordinate_row(t, j, a, b, x, R, local_a, local_b, frame_a, frame_b, position)
    if not has:
        return
    if t == JOINT_UNIVERSAL and p[P_LIMIT_ON] != 0.0:
        pos = _centred_angle(pos, p[P_LOWER], p[P_UPPER])
    # An angular row of a joint that also pins its anchor (hinge angle, ball cone) moves
    # the bodies about the anchor, not about their centres: solve it with the anchor block
    # (``_coupled_row_mass``). Alone, the row sees only the bodies' own inertias: a 1 m
    # pendulum's limit was 250x too soft and Gauss-Seidel took hundreds of sweeps to pass
    # the load to the anchor (I measured a 4 deg overshoot of a hinge limit).
    if (t == JOINT_HINGE or t == JOINT_BALL or t == JOINT_UNIVERSAL) and not linear:
        k, comp = _coupled_row_mass(inv_mass, I_inv, a, b, n, ra, rb)
    else:
        k = _row_mass(inv_mass, I_inv, a, b, linear, n, ra, rb)
        comp = (0.0, 0.0, 0.0)
    if k <= 0.0:
        return
    m_eff = 1.0 / k
    ks = p[P_STIFFNESS]
    cs = p[P_DAMPING]
    if ks > 0.0 or cs > 0.0:
        # implicit spring-damper as a soft row (Catto, GDC 2011): gamma = 1 / (h (c + h k))
        # is the compliance, k / (c + h k) the rate at which the error feeds the bias
        gamma = 1.0 / (h * (cs + h * ks))
        eff = 1.0 / (k + gamma)
        cdot = _row_velocity(v, omega, a, b, linear, n, ra, rb)
        old = axial_impulse[j, A_SPRING]
        imp = -eff * (cdot + ks / (cs + h * ks) * (pos - p[P_TARGET])) - gamma * eff * old
        lim = p[P_MAX_DRIVE] * h
        new = min(max(old + imp, -lim), lim)
        axial_impulse[j, A_SPRING] = new
        # the drive: its anchor compensation apart, as the motor's (see _axial_apply)
        _axial_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, comp, j, axial_impulse, A_MOTOR_ANCHOR,
                     new - old)
    if p[P_MOTOR_ON] != 0.0:
        _solve_motor_row(j, A_MOTOR, p[P_MOTOR_SPEED], p[P_MAX_MOTOR] * h, m_eff, a, b, linear, n, ra, rb, comp,
                         inv_mass, I_inv, v, omega, axial_impulse)
    if p[P_RIGID] != 0.0:
        cdot = _row_velocity(v, omega, a, b, linear, n, ra, rb)
        old = axial_impulse[j, A_EQUAL]
        imp = -m_eff * soft[1] * (cdot + soft[0] * (pos - p[P_LOWER])) - soft[2] * old
        axial_impulse[j, A_EQUAL] = old + imp
        _axial_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, comp, j, linear_impulse, 0, imp)
    elif p[P_LIMIT_ON] != 0.0:
        _solve_limit_rows(j, A_LOWER, p[P_LOWER], p[P_UPPER], pos, a, b, linear, n, ra, rb, comp, m_eff, soft, inv_h,
                          inv_mass, I_inv, v, omega, linear_impulse, axial_impulse)


@njit(**JIT)
def _centred_angle(angle, lower, upper):
    """An angle of (-pi, pi] (twist, universal angles) seen in the chart of width 2 pi centred
    on the middle of its limits [lower, upper] (within [-pi, pi]): the cut where the angle
    jumps by 2 pi then lies in the middle of the forbidden arc (upper, lower + 2 pi), as far
    as it can be from both limits, so an overshoot past a limit reads as one (not as a
    violation of the other limit by nearly 2 pi)."""
    mid = 0.5 * (lower + upper)
    return mid + _wrap(angle - mid)


@njit(**JIT)
def _coupled_row_mass(inv_mass, I_inv, a, b, n, ra, rb):
    """(k_eff, comp) of an angular row about n on a joint that pins its anchor (both joint
    coordinates' rows): k_eff = k - c.K^-1 c and comp = -K^-1 c, the anchor impulse per unit
    row impulse that keeps the anchor's velocity (c = J_anchor M^-1 J_row^T, K the anchor's
    3x3 block)."""
    k = _row_mass(inv_mass, I_inv, a, b, False, n, ra, rb)
    c = _scale(-1.0, _add(_cross(rb, _mat_vec(I_inv, b, n)), _cross(ra, _mat_vec(I_inv, a, n))))
    comp = _scale(-1.0, _solve3(_point_K(inv_mass, I_inv, a, b, ra, rb), c))
    return k + _dot(c, comp), comp


@njit(**JIT, inline="always")
def _solve_axial2(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, param, inv_mass, I_inv, h, inv_h, soft,
                  v, omega, linear_impulse, axial_impulse):
    """Motor (universal joints), then lower and upper limit of the second angular
    coordinate (``_second_row``: a ball joint's twist, a universal joint's angle about
    axis_b), the same rows as the first coordinate's in ``_solve_axial`` (Box2D v3's
    revolute limit: velocity level, speculative while the limit is apart, soft once
    crossed; solved with the anchor block). Accumulated in ``axial_impulse[j, A_*2]``.
    The first coordinate's code is left as it is so that joints without these rows give
    the same numbers as before."""
    p = param[j]
    if p[P_LIMIT2_ON] == 0.0 and p[P_MOTOR2_ON] == 0.0:
        return
    has, n, pos = _second_row(t, j, a, b, R, frame_a, frame_b)
    if not has:
        return
    if p[P_LIMIT2_ON] != 0.0:
        pos = _centred_angle(pos, p[P_LOWER2], p[P_UPPER2])
    ra, pa = _anchor(x, R, a, local_a, j)
    rb, pb = _anchor(x, R, b, local_b, j)
    k, comp = _coupled_row_mass(inv_mass, I_inv, a, b, n, ra, rb)
    if k <= 0.0:
        return
    m_eff = 1.0 / k
    if p[P_MOTOR2_ON] != 0.0:
        _solve_motor_row(j, A_MOTOR2, p[P_MOTOR2_SPEED], p[P_MAX_MOTOR2] * h, m_eff, a, b, False, n, ra, rb, comp,
                         inv_mass, I_inv, v, omega, axial_impulse)
    if p[P_LIMIT2_ON] == 0.0:
        return
    _solve_limit_rows(j, A_LOWER2, p[P_LOWER2], p[P_UPPER2], pos, a, b, False, n, ra, rb, comp, m_eff, soft, inv_h,
                      inv_mass, I_inv, v, omega, linear_impulse, axial_impulse)


@njit(**JIT, inline="always")
def _solve_rigid(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, inv_mass, I_inv, soft,
                 v, omega, linear_impulse, angular_impulse):
    """The rigid blocks: angular (3x3 fixed/slider, 2x2 hinge, 1 universal), then the anchor
    (3x3) or the slider's two perpendicular rows (2x2)."""
    br, ms, iscale = soft[0], soft[1], soft[2]
    if t != JOINT_BALL and t != JOINT_DISTANCE:
        xa = _axis(R, a, frame_a, j, 0)
        ya = _axis(R, a, frame_a, j, 1)
        za = _axis(R, a, frame_a, j, 2)
        xb = _axis(R, b, frame_b, j, 0)
        yb = _axis(R, b, frame_b, j, 1)
        zb = _axis(R, b, frame_b, j, 2)
        wrel = _sub(_angular_velocity(omega, b), _angular_velocity(omega, a))
        old = (angular_impulse[j, 0], angular_impulse[j, 1], angular_impulse[j, 2])
        K = _angular_K(I_inv, a, b)
        if t == JOINT_HINGE:
            e = _cross(za, zb)
            Kx = _sym_mat_vec(K, xa)
            Ky = _sym_mat_vec(K, ya)
            o1 = _dot(old, xa)
            o2 = _dot(old, ya)
            l1, l2 = _solve2(_dot(xa, Kx), _dot(xa, Ky), _dot(ya, Ky),
                             _dot(wrel, xa) + br * _dot(e, xa), _dot(wrel, ya) + br * _dot(e, ya))
            i1 = -ms * l1 - iscale * o1
            i2 = -ms * l2 - iscale * o2
            imp = _add(_scale(i1, xa), _scale(i2, ya))
            acc = _add(_scale(o1 + i1, xa), _scale(o2 + i2, ya))
        elif t == JOINT_UNIVERSAL:
            nn = _cross(yb, xa)
            nl = math.sqrt(_dot(nn, nn))
            nn = _scale(1.0 / nl, nn)
            kk = _dot(nn, _sym_mat_vec(K, nn))
            o1 = _dot(old, nn)
            i1 = 0.0
            if kk > 0.0:
                i1 = -ms * (_dot(wrel, nn) + br * _dot(xa, yb)) / kk - iscale * o1
            imp = _scale(i1, nn)
            acc = _scale(o1 + i1, nn)
        else:  # fixed, slider: no relative rotation; e = rotation vector of b relative to a (small)
            e = _scale(0.5, _add(_add(_cross(xa, xb), _cross(ya, yb)), _cross(za, zb)))
            lam = _solve3(K, _add(wrel, _scale(br, e)))
            imp = _sub(_scale(-ms, lam), _scale(iscale, old))
            acc = _add(old, imp)
        angular_impulse[j, 0], angular_impulse[j, 1], angular_impulse[j, 2] = acc
        _apply_angular(omega, I_inv, a, b, imp)
    if t == JOINT_DISTANCE:
        return
    ra, pa = _anchor(x, R, a, local_a, j)
    rb, pb = _anchor(x, R, b, local_b, j)
    d = _sub(pb, pa)
    old = (linear_impulse[j, 0], linear_impulse[j, 1], linear_impulse[j, 2])
    if t == JOINT_SLIDER:
        ra = _add(ra, d)
        p1, p2, k11, k12, k22 = _slider_rows(inv_mass, I_inv, R, a, b, frame_a, j, ra, rb)
        o1 = _dot(old, p1)
        o2 = _dot(old, p2)
        l1, l2 = _solve2(k11, k12, k22,
                         _row_velocity(v, omega, a, b, True, p1, ra, rb) + br * _dot(d, p1),
                         _row_velocity(v, omega, a, b, True, p2, ra, rb) + br * _dot(d, p2))
        i1 = -ms * l1 - iscale * o1
        i2 = -ms * l2 - iscale * o2
        imp = _add(_scale(i1, p1), _scale(i2, p2))
        acc = _add(_scale(o1 + i1, p1), _scale(o2 + i2, p2))
    else:
        cdot = _sub(_point_velocity(v, omega, b, rb), _point_velocity(v, omega, a, ra))
        lam = _solve3(_point_K(inv_mass, I_inv, a, b, ra, rb), _add(cdot, _scale(br, d)))
        imp = _sub(_scale(-ms, lam), _scale(iscale, old))
        acc = _add(old, imp)
    linear_impulse[j, 0], linear_impulse[j, 1], linear_impulse[j, 2] = acc
    _apply_linear(v, omega, inv_mass, I_inv, a, b, ra, rb, imp)


@njit(**JIT)
def _sym_mat_vec(K, u):
    """K u for K as 6 numbers."""
    k00, k01, k02, k11, k12, k22 = K
    return (k00 * u[0] + k01 * u[1] + k02 * u[2],
            k01 * u[0] + k11 * u[1] + k12 * u[2],
            k02 * u[0] + k12 * u[1] + k22 * u[2])


@njit(**JIT, inline="always")
def _sweep_joints(lo, hi, backward, order, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param,
                  enabled, gauss_seidel, position, x, R, inv_mass, I_inv, h, inv_h, soft, v, omega, linear_impulse,
                  angular_impulse, axial_impulse):
    """One Gauss-Seidel sweep over joints order[lo:hi], forward or ``backward``."""
    for k in range(lo, hi):
        j = order[lo + hi - 1 - k] if backward else order[k]
        if not enabled[j]:
            continue
        a = joint_a[j]
        b = joint_b[j]
        if _inv_m(inv_mass, a) + _inv_m(inv_mass, b) == 0.0:
            continue
        t = joint_type[j]
        _solve_axial(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, param, position, inv_mass, I_inv,
                     h, inv_h, soft, v, omega, linear_impulse, axial_impulse)
        if param[j, P_LIMIT2_ON] != 0.0 or param[j, P_MOTOR2_ON] != 0.0:
            # PERF: tested here, not only inside: while _solve_axial2 was a call (some 20
            # array arguments), the call alone cost 25 % of the joint_grid step, whose joints
            # have no such rows; it is inlined now, and the test still skips its set-up
            _solve_axial2(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, param, inv_mass, I_inv, h, inv_h,
                          soft, v, omega, linear_impulse, axial_impulse)
        if gauss_seidel[j]:
            _solve_rigid(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, inv_mass, I_inv, soft,
                         v, omega, linear_impulse, angular_impulse)


@njit(**JIT, parallel=True)
def solve_joints_kernel(order, bounds, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param,
                        enabled, gauss_seidel, position, x, R, inv_mass, I_inv, h, soft, iterations,
                        # outputs
                        v, omega, linear_impulse, angular_impulse, axial_impulse):
    """``iterations`` Gauss-Seidel sweeps over the joints, forward then backward in turn.

    soft: (3,) (bias rate 1/s, mass scale, impulse scale) of the rigid rows in this pass
    (Box2D ``b2Softness``; (0, 1, 0) in relax). Joints between two immovable bodies are skipped.
    ``gauss_seidel`` (J,) bool: whose rigid rows this sweep solves (the others are left to
    ``tree_solve_kernel``); the 1-D coordinate rows of every joint are solved here.

    The joints are taken in the order ``order`` (J,), cut by ``bounds`` (P + 2,) into P
    partitions that share no moving body (``contact.partition_pairs_kernel``), swept side by
    side, then the joints joining two partitions on this thread; P = 0 with order = 0..J-1 is
    one sweep of all in their own order. The bits depend on the partitions, not the threads.
    PERF: the sweep's body is inlined into this parallel kernel: 20 % faster than calls from a
    serial kernel on the 100 ragdolls, same bits (Numba's parallel pipeline also removes the
    inlined calls' reference counting).
    """
    parts = bounds.shape[0] - 2
    inv_h = 1.0 / h
    for it in range(iterations):
        # NOTE: alternating the sweep direction (symmetric Gauss-Seidel) lets an error
        # travel along a chain both ways within two sweeps
        backward = it % 2 == 1
        if parts > 0:
            for p in prange(parts):
                _sweep_joints(bounds[p], bounds[p + 1], backward, order, joint_type, joint_a, joint_b, local_a,
                              local_b, frame_a, frame_b, param, enabled, gauss_seidel, position, x, R, inv_mass,
                              I_inv, h, inv_h, soft, v, omega, linear_impulse, angular_impulse, axial_impulse)
        _sweep_joints(bounds[parts], bounds[parts + 1], backward, order, joint_type, joint_a, joint_b, local_a,
                      local_b, frame_a, frame_b, param, enabled, gauss_seidel, position, x, R, inv_mass, I_inv, h,
                      inv_h, soft, v, omega, linear_impulse, angular_impulse, axial_impulse)


@njit(**JIT)
def warm_start_joints_kernel(joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, enabled,
                             position, x, R, inv_mass, I_inv, linear_impulse, angular_impulse, axial_impulse,
                             # outputs
                             v, omega):
    """Apply each joint's accumulated impulses (of the last substep) once."""
    for j in range(joint_type.shape[0]):
        if not enabled[j]:
            continue
        a = joint_a[j]
        b = joint_b[j]
        t = joint_type[j]
        ra, pa = _anchor(x, R, a, local_a, j)
        rb, pb = _anchor(x, R, b, local_b, j)
        if t == JOINT_SLIDER:
            ra = _add(ra, _sub(pb, pa))
        _apply_linear(v, omega, inv_mass, I_inv, a, b, ra, rb,
                      (linear_impulse[j, 0], linear_impulse[j, 1], linear_impulse[j, 2]))
        motor_anchor = (axial_impulse[j, A_MOTOR_ANCHOR], axial_impulse[j, A_MOTOR_ANCHOR + 1],
                        axial_impulse[j, A_MOTOR_ANCHOR + 2])
        if motor_anchor[0] != 0.0 or motor_anchor[1] != 0.0 or motor_anchor[2] != 0.0:
            _apply_linear(v, omega, inv_mass, I_inv, a, b, ra, rb, motor_anchor)
        _apply_angular(omega, I_inv, a, b, (angular_impulse[j, 0], angular_impulse[j, 1], angular_impulse[j, 2]))
        total = (axial_impulse[j, A_SPRING] + axial_impulse[j, A_MOTOR] + axial_impulse[j, A_LOWER]
                 - axial_impulse[j, A_UPPER] + axial_impulse[j, A_EQUAL])
        if total != 0.0:
            has, linear, n, ra1, rb1, _pos = _coordinate_row(t, j, a, b, x, R, local_a, local_b, frame_a, frame_b,
                                                            position)
            if has:
                _row_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra1, rb1, total)
        total2 = axial_impulse[j, A_LOWER2] - axial_impulse[j, A_UPPER2] + axial_impulse[j, A_MOTOR2]
        if total2 != 0.0:
            has2, n2, _pos2 = _second_row(t, j, a, b, R, frame_a, frame_b)
            if has2:
                _apply_angular(omega, I_inv, a, b, _scale(total2, n2))


# ---------------------------------------------------------------------- position projection
@njit(**JIT)
def _turn_body(q, R, I_inv, i, sign, t):
    """Rotate body i by sign I_inv[i] t (a small rotation vector, rad), keep q unit and R = R(q)."""
    if i < 0:
        return
    w = _mat_vec(I_inv, i, t)
    quat_exp_multiply_inplace(q[i], sign * w[0], sign * w[1], sign * w[2], 1.0)
    normalize_quat_inplace(q[i])
    quat_to_matrix_into(q[i], R[i])


@njit(**JIT)
def _shift_body(x, q, R, inv_mass, I_inv, i, sign, r, p):
    """Move body i by the position-level 'impulse' sign p applied at arm r."""
    if i < 0:
        return
    for k in range(3):
        x[i, k] += sign * inv_mass[i] * p[k]
    _turn_body(q, R, I_inv, i, sign, _cross(r, p))


@njit(**JIT)
def project_joints_kernel(joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, enabled,
                          inv_mass, I_inv, iterations, tolerance,
                          # outputs
                          x, q, R):
    """Nonlinear Gauss-Seidel on positions (Catto, "Solver2D" NGS): per joint, move the two
    bodies along the rigid rows' directions (weighted by M^-1) so that the linearised error
    vanishes: anchors, locked rotations, slider rows, rigid and taut distances. Limits of
    angles are left to the velocity solve. Stops when a whole sweep saw no error above
    ``tolerance`` (m or rad). Returns the largest error seen in the last sweep."""
    n = joint_type.shape[0]
    worst = 0.0
    for it in range(iterations):
        worst = 0.0
        for jj in range(n):
            j = jj if it % 2 == 0 else n - 1 - jj
            if not enabled[j]:
                continue
            a = joint_a[j]
            b = joint_b[j]
            if _inv_m(inv_mass, a) + _inv_m(inv_mass, b) == 0.0:
                continue
            t = joint_type[j]
            if t != JOINT_BALL and t != JOINT_DISTANCE:
                xa = _axis(R, a, frame_a, j, 0)
                ya = _axis(R, a, frame_a, j, 1)
                za = _axis(R, a, frame_a, j, 2)
                xb = _axis(R, b, frame_b, j, 0)
                yb = _axis(R, b, frame_b, j, 1)
                zb = _axis(R, b, frame_b, j, 2)
                K = _angular_K(I_inv, a, b)
                if t == JOINT_HINGE:
                    e = _cross(za, zb)
                    Kx = _sym_mat_vec(K, xa)
                    Ky = _sym_mat_vec(K, ya)
                    c1 = _dot(e, xa)
                    c2 = _dot(e, ya)
                    l1, l2 = _solve2(_dot(xa, Kx), _dot(xa, Ky), _dot(ya, Ky), c1, c2)
                    turn = _add(_scale(-l1, xa), _scale(-l2, ya))
                    err = max(abs(c1), abs(c2))
                elif t == JOINT_UNIVERSAL:
                    nn = _cross(yb, xa)
                    nn = _scale(1.0 / max(math.sqrt(_dot(nn, nn)), 1e-12), nn)
                    c1 = _dot(xa, yb)
                    kk = _dot(nn, _sym_mat_vec(K, nn))
                    turn = _scale(-c1 / kk if kk > 0.0 else 0.0, nn)
                    err = abs(c1)
                else:
                    e = _scale(0.5, _add(_add(_cross(xa, xb), _cross(ya, yb)), _cross(za, zb)))
                    turn = _scale(-1.0, _solve3(K, e))
                    err = max(abs(e[0]), max(abs(e[1]), abs(e[2])))
                worst = max(worst, err)
                _turn_body(q, R, I_inv, a, -1.0, turn)
                _turn_body(q, R, I_inv, b, 1.0, turn)
            ra, pa = _anchor(x, R, a, local_a, j)
            rb, pb = _anchor(x, R, b, local_b, j)
            d = _sub(pb, pa)
            if t == JOINT_DISTANCE:
                length = math.sqrt(_dot(d, d))
                lo = param[j, P_LOWER]
                hi = param[j, P_UPPER]
                if length < 1e-12 or (lo < length < hi):
                    continue
                C = length - (hi if length >= hi else lo)
                nrm = _scale(1.0 / length, d)
                k = _row_mass(inv_mass, I_inv, a, b, True, nrm, ra, rb)
                corr = _scale(-C / k, nrm)
                err = abs(C)
            elif t == JOINT_SLIDER:
                ra = _add(ra, d)
                p1, p2, k11, k12, k22 = _slider_rows(inv_mass, I_inv, R, a, b, frame_a, j, ra, rb)
                c1 = _dot(d, p1)
                c2 = _dot(d, p2)
                l1, l2 = _solve2(k11, k12, k22, c1, c2)
                corr = _add(_scale(-l1, p1), _scale(-l2, p2))
                err = max(abs(c1), abs(c2))
            else:
                corr = _scale(-1.0, _solve3(_point_K(inv_mass, I_inv, a, b, ra, rb), d))
                err = math.sqrt(_dot(d, d))
            worst = max(worst, err)
            _shift_body(x, q, R, inv_mass, I_inv, a, -1.0, ra, corr)
            _shift_body(x, q, R, inv_mass, I_inv, b, 1.0, rb, corr)
        if worst <= tolerance:
            break
    return worst


# ---------------------------------------------------------------------- after the step
@njit(**JIT)
def store_joints_kernel(joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, x, R, v, omega,
                        inv_h, linear_impulse, angular_impulse, axial_impulse,
                        # outputs
                        enabled, position, rate, reaction_force, reaction_torque, broke):
    """Joint coordinates and rates at the end of the step; reactions on body b (force N and
    torque N m about its anchor, world; the accumulated impulse of the last substep / h);
    joints whose reaction exceeds ``max_force`` / ``max_torque`` are disabled and flagged in
    ``broke``. Returns how many broke in this step."""
    count = 0
    for j in range(joint_type.shape[0]):
        t = joint_type[j]
        a = joint_a[j]
        b = joint_b[j]
        has, linear, n, ra, rb, pos = _coordinate_row(t, j, a, b, x, R, local_a, local_b, frame_a, frame_b, position)
        position[j] = pos
        rate[j] = _row_velocity(v, omega, a, b, linear, n, ra, rb) if has else 0.0
        axial = (axial_impulse[j, A_SPRING] + axial_impulse[j, A_MOTOR] + axial_impulse[j, A_LOWER]
                 - axial_impulse[j, A_UPPER] + axial_impulse[j, A_EQUAL])
        f = (linear_impulse[j, 0], linear_impulse[j, 1], linear_impulse[j, 2])
        if axial_impulse[j, A_MOTOR_ANCHOR] != 0.0 or axial_impulse[j, A_MOTOR_ANCHOR + 1] != 0.0 \
                or axial_impulse[j, A_MOTOR_ANCHOR + 2] != 0.0:
            f = _add(f, (axial_impulse[j, A_MOTOR_ANCHOR], axial_impulse[j, A_MOTOR_ANCHOR + 1],
                         axial_impulse[j, A_MOTOR_ANCHOR + 2]))
        tq = (angular_impulse[j, 0], angular_impulse[j, 1], angular_impulse[j, 2])
        if has and linear:
            f = _add(f, _scale(axial, n))
        elif has:
            tq = _add(tq, _scale(axial, n))
        axial2 = axial_impulse[j, A_LOWER2] - axial_impulse[j, A_UPPER2] + axial_impulse[j, A_MOTOR2]
        if axial2 != 0.0:
            has2, n2, _pos2 = _second_row(t, j, a, b, R, frame_a, frame_b)
            if has2:
                tq = _add(tq, _scale(axial2, n2))
        for k in range(3):
            reaction_force[j, k] = f[k] * inv_h
            reaction_torque[j, k] = tq[k] * inv_h
        broke[j] = False
        if enabled[j]:
            fn = math.sqrt(_dot(f, f)) * inv_h
            tn = math.sqrt(_dot(tq, tq)) * inv_h
            if fn > param[j, P_MAX_FORCE] or tn > param[j, P_MAX_TORQUE]:
                enabled[j] = False
                broke[j] = True
                count += 1
                for k in range(3):
                    linear_impulse[j, k] = 0.0
                    angular_impulse[j, k] = 0.0
                for k in range(axial_impulse.shape[1]):
                    axial_impulse[j, k] = 0.0
    return count


@njit(**JIT)
def integrate_velocities_kernel(moving, inv_mass, I_inv, R, inertia_body, force, torque, h,
                                # outputs
                                v, omega):
    """v += h F / m; omega += h I^-1 tau, then the gyroscopic term -omega x I omega by one
    implicit Newton step in the body frame (Catto, "Numerical Methods", GDC 2015,
    https://box2d.org/files/ErinCatto_NumericalMethods_GDC2015.pdf):

        f(w) = Ib (w - w1) + h w x Ib w = 0,  Jf = Ib + h ([w1]x Ib - [Ib w1]x),  w2 = w1 - Jf^-1 f(w1)

    Stable for thin bodies (a chain link's spin about its long axis, I 12x smaller than
    across): the explicit update blew a 50-link chain apart at h = 1/240 s (I measured).
    Slightly dissipative, O(h): a free spinning body loses energy at that order."""
    for i in range(moving.shape[0]):
        if not moving[i]:
            continue
        w = _mat_vec(I_inv, i, (torque[i, 0], torque[i, 1], torque[i, 2]))
        for k in range(3):
            v[i, k] += h * inv_mass[i] * force[i, k]
            omega[i, k] += h * w[k]
        wb = _mat_vec_T(R, i, (omega[i, 0], omega[i, 1], omega[i, 2]))
        Iw = _mat_vec(inertia_body, i, wb)
        f = _scale(h, _cross(wb, Iw))
        # columns of Jf = Ib + h (S(w) Ib - S(Ib w)), S(a) b = a x b
        dw = _solve_columns3(_jacobian_column(inertia_body, i, 0, wb, Iw, h),
                             _jacobian_column(inertia_body, i, 1, wb, Iw, h),
                             _jacobian_column(inertia_body, i, 2, wb, Iw, h), f)
        wb = _sub(wb, dw)
        wn = _mat_vec(R, i, wb)
        omega[i, 0], omega[i, 1], omega[i, 2] = wn


@njit(**JIT)
def _jacobian_column(inertia_body, i, c, wb, Iw, h):
    col = (inertia_body[i, 0, c], inertia_body[i, 1, c], inertia_body[i, 2, c])
    e = (1.0 if c == 0 else 0.0, 1.0 if c == 1 else 0.0, 1.0 if c == 2 else 0.0)
    return _add(col, _scale(h, _sub(_cross(wb, col), _cross(Iw, e))))


@njit(**JIT)
def _solve_columns3(c0, c1, c2, b):
    """x with [c0 c1 c2] x = b (Cramer's rule with triple products); 0 if singular."""
    n12 = _cross(c1, c2)
    det = _dot(c0, n12)
    if det == 0.0:
        return (0.0, 0.0, 0.0)
    return (_dot(b, n12) / det, _dot(c0, _cross(b, c2)) / det, _dot(c0, _cross(c1, b)) / det)


@njit(**JIT)
def integrate_positions_kernel(moving, v, omega, h, inertia_body_inv,
                               # outputs
                               x, q, R, I_inv):
    """x += h v; q rotated exactly by omega over h (omega kept, as Box2D: the gyroscopic
    term is in the velocity update); then R = R(q) and I^-1 = R Ibody^-1 R^T."""
    for i in range(moving.shape[0]):
        if not moving[i]:
            continue
        for k in range(3):
            x[i, k] += h * v[i, k]
        quat_exp_multiply_inplace(q[i], omega[i, 0], omega[i, 1], omega[i, 2], h)
        normalize_quat_inplace(q[i])
        quat_to_matrix_into(q[i], R[i])
        for r in range(3):
            for c in range(3):
                s = 0.0
                for k in range(3):
                    for m in range(3):
                        s += R[i, r, k] * inertia_body_inv[i, k, m] * R[i, c, m]
                I_inv[i, r, c] = s


@njit(**JIT)
def _mat_vec_T(M, i, a):
    """M[i]^T @ a."""
    return (M[i, 0, 0] * a[0] + M[i, 1, 0] * a[1] + M[i, 2, 0] * a[2],
            M[i, 0, 1] * a[0] + M[i, 1, 1] * a[1] + M[i, 2, 1] * a[2],
            M[i, 0, 2] * a[0] + M[i, 1, 2] * a[1] + M[i, 2, 2] * a[2])


# ---------------------------------------------------------------------- the solver object
def soft_coefficients(hertz: float, zeta: float, h: float):
    """(bias_rate 1/s, mass_scale, impulse_scale) of a soft row (Box2D ``b2MakeSoft``; Catto,
    GDC 2011, https://box2d.org/files/ErinCatto_SoftConstraints_GDC2011.pdf)."""
    omega = 2.0 * math.pi * hertz
    a1 = 2.0 * zeta + h * omega
    a2 = h * omega * a1
    a3 = 1.0 / (1.0 + a2)
    return omega / a1, a2 * a3, a3


class JointSolver:
    """The joints of one World as arrays, and the accumulated impulses between steps.

    Constant arrays (J = joint count, in ``world.joints`` order): ``joint_type`` (J,) int64
    (``tumble.joints.JOINT_*``), ``joint_a``, ``joint_b`` (J,) int64 body indices (-1: world),
    ``local_a``, ``local_b`` (J, 3) m anchors in the body frames, ``frame_a``, ``frame_b``
    (J, 3, 3) joint axes in the body frames, ``param`` (J, PARAM_COUNT) (``tumble.joints.P_*``;
    writable between steps, e.g. ``param[j, P_MOTOR_SPEED]``).

    State: ``enabled`` (J,) bool (False once broken), ``linear_impulse``, ``angular_impulse``
    (J, 3) N s and ``axial_impulse`` (J, AXIAL_COUNT = 11) N s or N m s (the coordinate's
    spring, motor, lower, upper, equal rows; then the second angular coordinate's lower,
    upper, motor rows: ball twist, universal angle_b; then the motor and drive rows' anchor
    impulse, (3,) N s world, ``A_MOTOR_ANCHOR``), world, accumulated over the last
    substep, carried to the next for warm starting.

    Read after each step (``store``): ``position`` (J,) joint coordinate (hinge angle rad,
    slider displacement m, distance m, ball swing angle rad, universal angle about ``axis``
    rad; 0 for fixed),
    ``rate`` (J,) its time derivative, ``reaction_force`` (J, 3) N and ``reaction_torque``
    (J, 3) N m on body b from body a (world; the torque excludes the moment of the force
    about body b's centre), ``broke`` (J,) bool: broke in this step. See ``readings``.
    """

    def __init__(self, settings: JointSettings | None = None):
        self.settings = settings or JointSettings()
        self.count = 0
        self._joints: list = []
        self.h = 1.0 / 240.0
        self.last_projection_error = 0.0
        self._soft_key = None
        self.sweep = SweepOrder()  # the joints' order in the sweeps (slabs for a large world)
        self._build([])

    def _build(self, joints):
        J = len(joints)
        old = {name: getattr(self, name, None) for name in ("enabled", "linear_impulse", "angular_impulse",
                                                              "axial_impulse", "position")}
        self.joint_type = np.array([j.bound.type_id for j in joints], dtype=np.int64)
        self.joint_a = np.array([j.bound.body_a for j in joints], dtype=np.int64)
        self.joint_b = np.array([j.bound.body_b for j in joints], dtype=np.int64)
        self.local_a = np.array([j.bound.local_a for j in joints], dtype=float).reshape(J, 3)
        self.local_b = np.array([j.bound.local_b for j in joints], dtype=float).reshape(J, 3)
        self.frame_a = np.ascontiguousarray(np.array([j.bound.frame_a for j in joints], dtype=float).reshape(J, 3, 3))
        self.frame_b = np.ascontiguousarray(np.array([j.bound.frame_b for j in joints], dtype=float).reshape(J, 3, 3))
        # NOTE: a record bound with a shorter parameter row (a checkpoint written before the
        # second-coordinate columns) gets zeros there: those rows off
        self.param = np.zeros((J, PARAM_COUNT))
        for k, rec in enumerate(joints):
            row = np.asarray(rec.bound.param, dtype=float)
            self.param[k, :row.shape[0]] = row
        self.enabled = np.array([not j.broken for j in joints], dtype=bool)
        self.linear_impulse = np.zeros((J, 3))
        self.angular_impulse = np.zeros((J, 3))
        self.axial_impulse = np.zeros((J, AXIAL_COUNT))
        self.position = np.zeros(J)
        # joints kept from before (a joint added later goes at the end): keep their state
        k = self.count
        if k and old["enabled"] is not None and self._joints == joints[:k]:
            for name, arr in old.items():
                getattr(self, name)[:k] = arr[:k]
        self.rate = np.zeros(J)
        self.reaction_force = np.zeros((J, 3))
        self.reaction_torque = np.zeros((J, 3))
        self.broke = np.zeros(J, dtype=bool)
        self._joints = list(joints)
        self.count = J
        self._tree_key = None

    def _build_tree(self, moving: np.ndarray):
        """Spanning forest of the joint graph (moving bodies; the world and fixed bodies are
        one ground node): its joints are solved exactly, the others (loops) by Gauss-Seidel.
        Nodes are the moving bodies and the tree joints, each with its parent, leaves first."""
        J = self.count
        nb = moving.shape[0]
        ground = nb
        parent = list(range(nb + 1))

        def find(i):
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        def node_of(i):
            return i if i >= 0 and moving[i] else ground

        in_tree = np.zeros(J, dtype=bool)
        adjacency: dict[int, list] = {}
        for j in range(J):
            if not self.enabled[j]:
                continue
            u, w = node_of(self.joint_a[j]), node_of(self.joint_b[j])
            if u == w:
                continue
            ru, rw = find(u), find(w)
            if ru == rw:
                continue  # closes a loop: Gauss-Seidel
            parent[ru] = rw
            in_tree[j] = True
            for body in (u, w):
                adjacency.setdefault(body, []).append(j)
        # roots: per component, the joint to the ground if there is one, else a body
        kinds, refs, parents = [], [], []
        seen_body, seen_joint = set(), set()

        def grow(kind, ref, par):
            stack = [(kind, ref, par)]
            while stack:
                kind, ref, par = stack.pop()
                k = len(kinds)
                kinds.append(kind)
                refs.append(ref)
                parents.append(par)
                if kind == 0:  # body: its joints
                    for j in adjacency.get(ref, ()):
                        if j not in seen_joint:
                            seen_joint.add(j)
                            stack.append((1, j, k))
                else:  # joint: its other body
                    for body in (node_of(self.joint_a[ref]), node_of(self.joint_b[ref])):
                        if body != ground and body not in seen_body:
                            seen_body.add(body)
                            stack.append((0, body, k))

        for j in adjacency.get(ground, ()):
            seen_joint.add(j)
            grow(1, j, -1)
        for body in adjacency:
            if body != ground and body not in seen_body:
                seen_body.add(body)
                grow(0, body, -1)
        n = len(kinds)
        self.node_joint = np.array([r if k == 1 else -1 for k, r in zip(kinds, refs)], dtype=np.int64)
        self.node_body = np.array([r if k == 0 else -1 for k, r in zip(kinds, refs)], dtype=np.int64)
        self.node_parent = np.array(parents, dtype=np.int64)
        self.node_order = np.arange(n - 1, -1, -1, dtype=np.int64)  # parents were added before children
        self.gauss_seidel = ~in_tree
        self._scratch = {
            "Ja": np.zeros((J, 6, 6)), "Jb": np.zeros((J, 6, 6)), "C": np.zeros((J, 6)),
            "nrow": np.zeros(J, dtype=np.int64), "D": np.zeros((n, 6, 6)), "Dinv": np.zeros((n, 6, 6)),
            "H_up": np.zeros((n, 6, 6)), "y": np.zeros((n, 6)), "sol": np.zeros((n, 6)), "work": np.zeros((6, 6)),
        }

    # -- stages --------------------------------------------------------------------------
    def prepare(self, world, h: float, inv_mass: np.ndarray | None = None, I_inv: np.ndarray | None = None,
                x: np.ndarray | None = None):
        """Once per step, before the substeps: (re)build the tables if ``world.joints`` changed,
        the softness of the rigid rows for substep ``h`` (s), and the sweep's order (slabs of
        ``settings.partitions`` for a large world).

        inv_mass: (N,) 1/kg and I_inv: (N, 3, 3) world inverse inertia, the arrays the
        solve reads from now on (default ``world.inv_mass``, ``world.I_inv``). The caller
        keeps I_inv current in place (or fixed over the step, as Box2D); an immovable body
        has inv_mass 0 and I_inv 0. x: (N, >= 3) m, the centres the slabs are cut by (default
        ``world.x``).
        """
        # joints are only ever appended (World.add_joint): the count and the last record tell
        # whether the tables are current, without a Python loop over the joints each step
        joints = world.joints
        if len(joints) != self.count or (self.count and joints[-1] is not self._joints[-1]):
            self._build(joints)
        if self.settings.method == "tree":
            key = (self.count, world.body_count, bytes(world.moving), bytes(self.enabled))
            if key != self._tree_key:
                self._build_tree(np.asarray(world.moving))
                self._tree_key = key
        else:
            self.gauss_seidel = np.ones(self.count, dtype=bool)
        self.h = float(h)
        self.inv_mass = world.inv_mass if inv_mass is None else inv_mass
        self.I_inv = world.I_inv if I_inv is None else I_inv
        st = self.settings
        key = (self.h, st.hertz, st.damping_ratio, st.hertz_cap_per_substep, st.bias_factor)
        if key != self._soft_key:
            if st.hertz > 0.0:
                hertz = min(st.hertz, st.hertz_cap_per_substep / h)
                self.soft_bias = np.array(soft_coefficients(hertz, st.damping_ratio, h))
            else:  # rigid: the bias takes out bias_factor of the error in one substep
                self.soft_bias = np.array([st.bias_factor / h, 1.0, 0.0])
            self.soft_relax = np.array([0.0, 1.0, 0.0])
            self._soft_key = key
        st = self.settings
        self.sweep.update(self.joint_a, self.joint_b, np.asarray(world.moving), world.x if x is None else x,
                          int(st.partitions), st.partition_min_joints)

    def warm_start(self, v: np.ndarray, omega: np.ndarray, x: np.ndarray, R: np.ndarray):
        """Apply the accumulated impulses once to v, omega (N, 3) (each substep, before solve)."""
        if self.count:
            warm_start_joints_kernel(self.joint_type, self.joint_a, self.joint_b, self.local_a, self.local_b,
                                     self.frame_a, self.frame_b, self.enabled, self.position, x, R, self.inv_mass,
                                     self.I_inv, self.linear_impulse, self.angular_impulse, self.axial_impulse,
                                     v, omega)

    def solve(self, v: np.ndarray, omega: np.ndarray, x: np.ndarray, R: np.ndarray, use_bias: bool):
        """Sweeps over the joints on v, omega (N, 3) at poses x (N, 3), R (N, 3, 3):
        ``use_bias=True`` before the positions move (soft rows, ``velocity_iterations``),
        False after (relax: rigid rows without bias, ``relax_iterations``)."""
        if self.count:
            st = self.settings
            iterations = st.velocity_iterations if use_bias else st.relax_iterations
            soft = self.soft_bias if use_bias else self.soft_relax
            args = (self.sweep.order[:self.count], self.sweep.bounds, self.joint_type, self.joint_a, self.joint_b,
                    self.local_a, self.local_b, self.frame_a, self.frame_b,
                    self.param, self.enabled, self.gauss_seidel, self.position, x, R, self.inv_mass, self.I_inv, self.h,
                    soft)
            out = (v, omega, self.linear_impulse, self.angular_impulse, self.axial_impulse)
            if st.method != "tree":
                solve_joints_kernel(*args, int(iterations), *out)
                return
            sc = self._scratch
            for _ in range(iterations):
                solve_joints_kernel(*args, 1, *out)
                tree_solve_kernel(self.node_order, self.node_joint, self.node_body, self.node_parent, self.joint_type,
                                  self.joint_a, self.joint_b, self.local_a, self.local_b, self.frame_a, self.frame_b,
                                  self.param, x, R, self.inv_mass, self.I_inv, float(soft[0]), sc["Ja"], sc["Jb"],
                                  sc["C"], sc["nrow"], sc["D"], sc["Dinv"], sc["H_up"], sc["y"], sc["sol"], sc["work"],
                                  *out)

    def project(self, x: np.ndarray, q: np.ndarray, R: np.ndarray) -> float:
        """NGS position projection after the substeps (``position_iterations`` > 0): moves
        x, q, R (kept R = R(q)) so that anchors and locked axes meet; velocities unchanged.
        Returns the largest rigid-row error (m or rad) of the last sweep."""
        st = self.settings
        if self.count and st.position_iterations > 0:
            self.last_projection_error = project_joints_kernel(
                self.joint_type, self.joint_a, self.joint_b, self.local_a, self.local_b, self.frame_a, self.frame_b,
                self.param, self.enabled, self.inv_mass, self.I_inv, int(st.position_iterations),
                float(st.position_tolerance), x, q, R)
        return self.last_projection_error

    def store(self, v: np.ndarray, omega: np.ndarray, x: np.ndarray, R: np.ndarray) -> int:
        """After the step: coordinates, rates, reactions; break overloaded joints (their
        records get ``broken = True``). Returns how many broke in this step."""
        if not self.count:
            return 0
        broke = store_joints_kernel(self.joint_type, self.joint_a, self.joint_b, self.local_a, self.local_b,
                                    self.frame_a, self.frame_b, self.param, x, R, v, omega, 1.0 / self.h,
                                    self.linear_impulse, self.angular_impulse, self.axial_impulse,
                                    self.enabled, self.position, self.rate, self.reaction_force,
                                    self.reaction_torque, self.broke)
        if broke:
            for j in np.flatnonzero(self.broke):
                self._joints[j].broken = True
        return broke

    # -- queries -------------------------------------------------------------------------
    def index(self, joint) -> int:
        """Index of a joint given as its record, its name or an index."""
        for j, rec in enumerate(self._joints):
            if rec is joint or (isinstance(joint, str) and rec.name == joint):
                return j
        if isinstance(joint, (int, np.integer)) and 0 <= joint < self.count:
            return int(joint)
        raise KeyError(f"unknown joint {joint!r}")

    def readings(self, joint=None) -> dict:
        """The per-step readings, for one joint (by record, name or index) or all (arrays):
        ``position`` (rad or m), ``rate`` (rad/s or m/s), ``force`` (3,) N and ``torque``
        (3,) N m on body b, world; ``enabled``. Copies, safe to keep."""
        sel = slice(None) if joint is None else self.index(joint)
        return {"position": np.copy(self.position[sel]), "rate": np.copy(self.rate[sel]),
                "force": np.copy(self.reaction_force[sel]), "torque": np.copy(self.reaction_torque[sel]),
                "enabled": np.copy(self.enabled[sel])}

    def set_motor_speed(self, joint, speed: float, axis_b: bool = False):
        """Change a motor's target rate (rad/s or m/s) between steps; ``axis_b=True``: a
        universal joint's motor about axis_b (``motor_speed_b``)."""
        self.param[self.index(joint), P_MOTOR2_SPEED if axis_b else P_MOTOR_SPEED] = float(speed)


# ---------------------------------------------------------------------- standalone stepper
def step_with_joints(world, joints: JointSolver, dt: float, substeps: int = 4):
    """Advance ``world`` by ``dt`` under its built-in forces (gravity and force records,
    evaluated once at the start of the step) and its joints; no contacts, no user callables.

    Box2D v3's order: prepare; per substep integrate velocities -> warm start -> solve
    (bias) -> integrate positions (L kept, omega from it) -> relax; then the optional
    projection and store. Writes x, q, R, P, L and the derived arrays; advances ``world.t``.
    """
    h = dt / substeps
    world.update_derived()
    moving = world.moving
    v, omega, x, q, R, I_inv = world.v, world.omega, world.x, world.q, world.R, world.I_inv
    joints.prepare(world, h)
    for _ in range(substeps):
        integrate_velocities_kernel(moving, world.inv_mass, I_inv, R, world.inertia_body, world.force, world.torque, h,
                                    v, omega)
        joints.warm_start(v, omega, x, R)
        joints.solve(v, omega, x, R, True)
        integrate_positions_kernel(moving, v, omega, h, world.inertia_body_inv, x, q, R, I_inv)
        joints.solve(v, omega, x, R, False)
    joints.project(x, q, R)
    _store_momenta_kernel(moving, world.mass, world.inertia_body, R, v, omega, world.P, world.L)
    world.t += dt
    joints.store(v, omega, x, R)
    return joints


@njit(**JIT)
def _store_momenta_kernel(moving, mass, inertia_body, R, v, omega,
                          # outputs
                          P, L):
    """P = m v, L = R Ibody R^T omega (at the final pose)."""
    for i in range(moving.shape[0]):
        if moving[i]:
            wb = _mat_vec_T(R, i, (omega[i, 0], omega[i, 1], omega[i, 2]))
            Lw = _mat_vec(R, i, _mat_vec(inertia_body, i, wb))
            for k in range(3):
                P[i, k] = mass[i] * v[i, k]
                L[i, k] = Lw[k]


# ---------------------------------------------------------------------- exact solve on trees
# Baraff, "Linear-Time Dynamics using Lagrange Multipliers", SIGGRAPH 1996: the KKT matrix
# H = [[M, J^T], [J, 0]] of a tree of bodies and joints, ordered leaves first, factors as
# L D L^T with no fill-in. Each node (a moving body: 6 dofs v, omega; a joint: up to 6 rigid
# rows, padded with identity rows) is one 6x6 block.
@njit(**JIT)
def _joint_rows(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, param, Ja, Jb, C):
    """Rigid rows of joint j at the current pose into Ja[j], Jb[j] (6, 6) (rows x (v, omega)
    of body a / b) and their errors C[j] (6,) (m or rad). Returns the row count."""
    for r in range(6):
        C[j, r] = 0.0
        for c in range(6):
            Ja[j, r, c] = 0.0
            Jb[j, r, c] = 0.0
    ra, pa = _anchor(x, R, a, local_a, j)
    rb, pb = _anchor(x, R, b, local_b, j)
    d = _sub(pb, pa)
    n = 0
    if t != JOINT_BALL and t != JOINT_DISTANCE:
        xa = _axis(R, a, frame_a, j, 0)
        ya = _axis(R, a, frame_a, j, 1)
        za = _axis(R, a, frame_a, j, 2)
        xb = _axis(R, b, frame_b, j, 0)
        yb = _axis(R, b, frame_b, j, 1)
        zb = _axis(R, b, frame_b, j, 2)
        if t == JOINT_HINGE:
            e = _cross(za, zb)
            dirs = (xa, ya, za)
            errs = (_dot(e, xa), _dot(e, ya), 0.0)
            count = 2
        elif t == JOINT_UNIVERSAL:
            nn = _cross(yb, xa)
            nn = _scale(1.0 / max(math.sqrt(_dot(nn, nn)), 1e-12), nn)
            dirs = (nn, xa, ya)
            errs = (_dot(xa, yb), 0.0, 0.0)
            count = 1
        else:
            e = _scale(0.5, _add(_add(_cross(xa, xb), _cross(ya, yb)), _cross(za, zb)))
            dirs = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
            errs = e
            count = 3
        for k in range(count):
            u = dirs[k]
            for c in range(3):
                Ja[j, n, 3 + c] = -u[c]
                Jb[j, n, 3 + c] = u[c]
            C[j, n] = errs[k]
            n += 1
    if t == JOINT_DISTANCE:
        if param[j, P_RIGID] == 0.0:
            return n
        length = math.sqrt(_dot(d, d))
        if length < 1e-12:
            return n
        dirs = (_scale(1.0 / length, d), d, d)
        errs = (length - param[j, P_LOWER], 0.0, 0.0)
        count = 1
    elif t == JOINT_SLIDER:
        ra = _add(ra, d)
        p1 = _axis(R, a, frame_a, j, 0)
        p2 = _axis(R, a, frame_a, j, 1)
        dirs = (p1, p2, p2)
        errs = (_dot(d, p1), _dot(d, p2), 0.0)
        count = 2
    else:
        dirs = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
        errs = d
        count = 3
    for k in range(count):
        u = dirs[k]
        ca = _cross(ra, u)
        cb = _cross(rb, u)
        for c in range(3):
            Ja[j, n, c] = -u[c]
            Ja[j, n, 3 + c] = -ca[c]
            Jb[j, n, c] = u[c]
            Jb[j, n, 3 + c] = cb[c]
        C[j, n] = errs[k]
        n += 1
    return n


@njit(**JIT)
def _invert6(A, out):
    """out = A^-1 for a 6x6 A (Gauss-Jordan, partial pivoting); A is overwritten. False if singular."""
    for r in range(6):
        for c in range(6):
            out[r, c] = 1.0 if r == c else 0.0
    for c in range(6):
        p = c
        for r in range(c + 1, 6):
            if abs(A[r, c]) > abs(A[p, c]):
                p = r
        if A[p, c] == 0.0:
            return False
        if p != c:
            for k in range(6):
                A[c, k], A[p, k] = A[p, k], A[c, k]
                out[c, k], out[p, k] = out[p, k], out[c, k]
        inv = 1.0 / A[c, c]
        for k in range(6):
            A[c, k] *= inv
            out[c, k] *= inv
        for r in range(6):
            if r != c and A[r, c] != 0.0:
                f = A[r, c]
                for k in range(6):
                    A[r, k] -= f * A[c, k]
                    out[r, k] -= f * out[c, k]
    return True


@njit(**JIT)
def _project_accumulated(j, t, a, b, x, R, local_a, local_b, m, Jb, inv_mass, I_inv, v, omega,
                         linear_impulse, angular_impulse):
    """Put joint j's accumulated angular (hinge: 2 rows, universal: 1) and linear (slider: 2
    rows) impulses back in the span of its current rigid rows (``Jb[j]``, unit directions,
    orthogonal within a block), and take the part outside it back off the bodies (the warm
    start of this substep applied it).

    Why: the tree solve adds lambda along the rows of the current pose, which turn with the
    bodies, so the sum of a rotating direction's impulses leaves a part along the joint's
    free axes; warm started every substep, that part is a torque (or force) about a free
    axis that does work. It pumped a floating, spinning ball + universal chain up 5e4 times
    in energy in 2 s (docs/joints.md). ``_solve_rigid`` (Gauss-Seidel) keeps only the parts
    along the current rows ((o1 + i1) n) and has no such drift. With 3 rows of a kind
    (anchor, fixed, slider's angular block) the span is everything: nothing to do."""
    n_ang = 0
    n_lin = 0
    for r in range(m):
        if Jb[j, r, 0] != 0.0 or Jb[j, r, 1] != 0.0 or Jb[j, r, 2] != 0.0:
            n_lin += 1
        else:
            n_ang += 1
    if t == JOINT_DISTANCE:
        return  # its row is accumulated in axial_impulse (a scalar along the current line)
    if 0 < n_ang < 3:
        old = (angular_impulse[j, 0], angular_impulse[j, 1], angular_impulse[j, 2])
        kept = (0.0, 0.0, 0.0)
        for r in range(n_ang):
            u = (Jb[j, r, 3], Jb[j, r, 4], Jb[j, r, 5])
            kept = _add(kept, _scale(_dot(old, u), u))
        _apply_angular(omega, I_inv, a, b, _sub(kept, old))
        angular_impulse[j, 0], angular_impulse[j, 1], angular_impulse[j, 2] = kept
    if 0 < n_lin < 3:
        old = (linear_impulse[j, 0], linear_impulse[j, 1], linear_impulse[j, 2])
        kept = (0.0, 0.0, 0.0)
        for r in range(n_ang, m):
            u = (Jb[j, r, 0], Jb[j, r, 1], Jb[j, r, 2])
            kept = _add(kept, _scale(_dot(old, u), u))
        ra, pa = _anchor(x, R, a, local_a, j)
        rb, pb = _anchor(x, R, b, local_b, j)
        if t == JOINT_SLIDER:
            ra = _add(ra, _sub(pb, pa))
        _apply_linear(v, omega, inv_mass, I_inv, a, b, ra, rb, _sub(kept, old))
        for c in range(3):
            linear_impulse[j, c] = kept[c]


@njit(**JIT)
def tree_solve_kernel(order, node_joint, node_body, node_parent, joint_type, joint_a, joint_b, local_a, local_b,
                      frame_a, frame_b, param, x, R, inv_mass, I_inv, bias_rate,
                      # scratch
                      Ja, Jb, C, nrow, D, Dinv, H_up, y, sol, work,
                      # outputs
                      v, omega, linear_impulse, angular_impulse, axial_impulse):
    """One exact solve of the rigid rows of the tree joints: J (u + du) = -bias_rate C,
    M du = J^T lambda, by block L D L^T of the KKT matrix in ``order`` (leaves first).

    Nodes: ``node_joint[k]`` >= 0 for a joint node, else ``node_body[k]`` is a body node;
    ``node_parent[k]`` (-1 for a root). Adds lambda to the joints' accumulated impulses.
    """
    n_nodes = order.shape[0]
    # the rows at the current pose, and the accumulated impulses put back in their span
    # (all joints first: the undo changes velocities the right-hand sides read)
    for k in range(n_nodes):
        j = node_joint[k]
        if j >= 0:
            nrow[j] = _joint_rows(j, joint_type[j], joint_a[j], joint_b[j], x, R, local_a, local_b, frame_a, frame_b,
                                  param, Ja, Jb, C)
            _project_accumulated(j, joint_type[j], joint_a[j], joint_b[j], x, R, local_a, local_b, nrow[j], Jb,
                                 inv_mass, I_inv, v, omega, linear_impulse, angular_impulse)
    # diagonal blocks and right-hand sides
    for k in range(n_nodes):
        j = node_joint[k]
        for r in range(6):
            y[k, r] = 0.0
            for c in range(6):
                D[k, r, c] = 0.0
        if j >= 0:
            a = joint_a[j]
            b = joint_b[j]
            m = nrow[j]
            for r in range(m, 6):
                D[k, r, r] = 1.0
            for r in range(m):
                s = bias_rate * C[j, r]
                for c in range(3):
                    if a >= 0:
                        s += Ja[j, r, c] * v[a, c] + Ja[j, r, 3 + c] * omega[a, c]
                    if b >= 0:
                        s += Jb[j, r, c] * v[b, c] + Jb[j, r, 3 + c] * omega[b, c]
                y[k, r] = -s
        else:
            i = node_body[k]
            # M = diag(m 1, I_world), I_world = I_inv^-1
            for r in range(3):
                D[k, r, r] = 1.0 / inv_mass[i]
            for r in range(3):
                for c in range(3):
                    work[r, c] = I_inv[i, r, c]
                    work[r + 3, c] = 0.0
                    work[r, c + 3] = 0.0
                    work[r + 3, c + 3] = 1.0 if r == c else 0.0
            _invert6(work, Dinv[k])
            for r in range(3):
                for c in range(3):
                    D[k, 3 + r, 3 + c] = Dinv[k, r, c]
    # H_up[k] = H[k, parent]: joint rows x body dofs, or its transpose
    for k in range(n_nodes):
        p = node_parent[k]
        if p < 0:
            continue
        j = node_joint[k]
        if j >= 0:
            J = Ja if joint_a[j] == node_body[p] else Jb
            for r in range(6):
                for c in range(6):
                    H_up[k, r, c] = J[j, r, c]
        else:
            jp = node_joint[p]
            J = Ja if joint_a[jp] == node_body[k] else Jb
            for r in range(6):
                for c in range(6):
                    H_up[k, r, c] = J[jp, c, r]
    # factor and forward substitution, leaves first: D_p -= H_pk D_k^-1 H_kp, y_p -= H_pk D_k^-1 y_k
    for kk in range(n_nodes):
        k = order[kk]
        for r in range(6):
            for c in range(6):
                work[r, c] = D[k, r, c]
        if not _invert6(work, Dinv[k]):
            for r in range(6):
                for c in range(6):
                    Dinv[k, r, c] = 0.0
        p = node_parent[k]
        if p < 0:
            continue
        # work = D_k^-1 H_kp (6x6), then D_p -= H_kp^T work, y_p -= work^T y_k
        for r in range(6):
            for c in range(6):
                s = 0.0
                for m in range(6):
                    s += Dinv[k, r, m] * H_up[k, m, c]
                work[r, c] = s
        for r in range(6):
            for c in range(6):
                s = 0.0
                for m in range(6):
                    s += H_up[k, m, r] * work[m, c]
                D[p, r, c] -= s
            s = 0.0
            for m in range(6):
                s += work[m, r] * y[k, m]
            y[p, r] -= s
    # back substitution, roots first: sol_k = D_k^-1 (y_k - H_kp sol_p)
    for kk in range(n_nodes - 1, -1, -1):
        k = order[kk]
        p = node_parent[k]
        for r in range(6):
            s = y[k, r]
            if p >= 0:
                for m in range(6):
                    s -= H_up[k, r, m] * sol[p, m]
            work[0, r] = s
        for r in range(6):
            s = 0.0
            for m in range(6):
                s += Dinv[k, r, m] * work[0, m]
            sol[k, r] = s
    # apply: body nodes take du; joint nodes give lambda = -mu
    for k in range(n_nodes):
        j = node_joint[k]
        if j < 0:
            i = node_body[k]
            for c in range(3):
                v[i, c] += sol[k, c]
                omega[i, c] += sol[k, 3 + c]
            continue
        t = joint_type[j]
        m = nrow[j]
        for r in range(m):
            lam = -sol[k, r]
            # a row's world direction is body b's Jacobian: linear part for linear rows,
            # angular part for angular rows (rows are angular first, see _joint_rows)
            lin = Jb[j, r, 0] != 0.0 or Jb[j, r, 1] != 0.0 or Jb[j, r, 2] != 0.0
            if t == JOINT_DISTANCE:
                axial_impulse[j, A_EQUAL] += lam
            elif lin:
                for c in range(3):
                    linear_impulse[j, c] += lam * Jb[j, r, c]
            else:
                for c in range(3):
                    angular_impulse[j, c] += lam * Jb[j, r, 3 + c]
