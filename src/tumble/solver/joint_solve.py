"""The joint rows' velocity solve (``solver.joints``' sweep): the 1-D coordinate rows (spring
or PD drive, motor, limits), a ball or universal joint's second angular coordinate, and the
rigid blocks, joint by joint (``solve_joints_kernel``, ``warm_start_joints_kernel``). Reads x,
R, inv_mass, I_inv and the joint tables; writes v, omega (N, 3) and the accumulated impulses."""

from __future__ import annotations

import math

from numba import njit, prange

from ..joints import (
    JOINT_BALL,
    JOINT_DISTANCE,
    JOINT_GEAR,
    JOINT_HINGE,
    JOINT_SLIDER,
    JOINT_UNIVERSAL,
    P_ARMATURE,
    P_BALL_DAMPING,
    P_BALL_MAX_DRIVE,
    P_BALL_RATE,
    P_BALL_STIFFNESS,
    P_BALL_TARGET,
    P_DAMPING,
    P_EFFORT,
    P_LIMIT2_ON,
    P_LIMIT_ON,
    P_LOWER,
    P_LOWER2,
    P_MAX_DRIVE,
    P_MAX_MOTOR,
    P_MAX_MOTOR2,
    P_MOTOR2_ON,
    P_MOTOR2_SPEED,
    P_MOTOR_ON,
    P_MOTOR_SPEED,
    P_PASSIVE_DAMPING,
    P_PASSIVE_STIFFNESS,
    P_RIGID,
    P_SPRINGREF,
    P_STIFFNESS,
    P_TARGET,
    P_TARGET_RATE,
    P_UPPER,
    P_UPPER2,
)
from ..math3d import (
    JIT,
    NO_NRT,
    serial_twin,
)
from .joint_gear import GEAR_COLUMN, gear_apply, gear_on, solve_gear
from .joint_math import (
    _add,
    _anchor,
    _angular_K,
    _angular_velocity,
    _apply_angular,
    _apply_linear,
    _axis,
    _coordinate_row,
    _cross,
    _dot,
    _frames,
    _inv_m,
    _mat_vec,
    _point_K,
    _point_velocity,
    _row_apply,
    _row_mass,
    _row_velocity,
    _scale,
    _slider_rows,
    _solve2,
    _solve3,
    _sub,
    _wrap,
)

# columns of ``axial_impulse`` (J, AXIAL_COUNT): accumulated impulses of the 1-D coordinate
# rows (spring, motor, lower, upper, equal), then of the second angular coordinate (a ball
# joint's twist, a universal joint's angle about axis_b: lower, upper limit, motor), then
# the anchor impulse (x, y, z world, N s) that the motor rows and the spring/PD drive row add
# to keep the anchor's velocity (``_solve_axial``'s ``comp``), kept apart from the anchor's
# own ``linear_impulse`` so that the soft anchor row's impulse scale does not relax it
# (see ``_axial_apply``); last, the armature row's impulse (``_solve_axial``)
A_SPRING, A_MOTOR, A_LOWER, A_UPPER, A_EQUAL = 0, 1, 2, 3, 4
A_LOWER2, A_UPPER2, A_MOTOR2 = 5, 6, 7
A_MOTOR_ANCHOR = 8
A_ARMATURE = 11
# a ball joint's drive (``_solve_ball_drive``): its accumulated angular impulse (x, y, z world, N m s)
A_BALL_DRIVE = 12
AXIAL_COUNT = 15
AXIAL_COUNT_V1 = 11  # before the armature column (checkpoints of older versions)
AXIAL_COUNT_V2 = 12  # before the ball drive's columns
OLD_AXIAL_COUNTS = (AXIAL_COUNT_V1, AXIAL_COUNT_V2)


@njit(**NO_NRT)
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


@njit(**NO_NRT)
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


@njit(**NO_NRT)
def _axial_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, comp, j, acc, col, impulse, keep, axial_impulse):
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
    ``linear_impulse`` so that their numbers do not change.

    ``keep`` < 1: the joint has armature, whose row answers at once (``_solve_axial``): of the
    row's impulse only ``keep`` moves the bodies, the rest goes to the armature's impulse."""
    if keep != 1.0:
        axial_impulse[j, A_ARMATURE] -= (1.0 - keep) * impulse
        impulse = keep * impulse
    _row_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, impulse)
    if comp[0] != 0.0 or comp[1] != 0.0 or comp[2] != 0.0:
        p = _scale(impulse, comp)
        _apply_linear(v, omega, inv_mass, I_inv, a, b, ra, rb, p)
        for k in range(3):
            acc[j, col + k] += p[k]


@njit(**NO_NRT)
def _solve_motor_row(j, slot, speed, max_impulse, m_eff, a, b, linear, n, ra, rb, comp, keep, inv_mass, I_inv,
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
                 new - old, keep, axial_impulse)


@njit(**NO_NRT, inline="always")
def limit_impulse_after(C, inv_h, push, m_eff, rate, old):
    """A limit row's accumulated impulse after one solve, at C >= 0 apart (rad or m), moving at ``rate``
    (into the limit < 0), effective mass ``m_eff``: speculative while apart (the gap may close within
    this substep, no more), pushed back at the softness ``push`` (3,) (bias rate, mass scale,
    impulse scale) once crossed. Shared by the Gauss-Seidel rows (``_solve_limit_rows``) and the
    tree's (``joint_tree.tree_limits_kernel``)."""
    bias, ms, iscale = 0.0, 1.0, 0.0
    if C > 0.0:
        bias = C * inv_h
    else:
        bias, ms, iscale = push[0] * C, push[1], push[2]
    return max(old - m_eff * ms * (rate + bias) - iscale * old, 0.0)


@njit(**NO_NRT, inline="always")
def limit_side(side, lower, upper, pos):
    """(sign, C) of a coordinate's lower limit row (side 0: C = pos - lower >= 0) or its upper one
    (side 1: C = upper - pos >= 0, the row reversed, sign -1), at ``pos`` within [lower, upper];
    C = inf for an infinite bound (no row)."""
    sign = 1.0 if side == 0 else -1.0
    bound = lower if side == 0 else upper
    if math.isinf(bound):
        return sign, math.inf
    return sign, sign * (pos - bound)


@njit(**NO_NRT)
def _solve_limit_rows(j, slot0, lower, upper, pos, a, b, linear, n, ra, rb, comp, keep, m_eff, soft, inv_h,
                      inv_mass, I_inv, v, omega, linear_impulse, axial_impulse):
    """The lower and upper limit rows of one joint coordinate (``pos``, rad or m, along row n:
    linear or angular), accumulated in ``axial_impulse[j, slot0]`` and ``[j, slot0 + 1]``: a
    one-sided row each, speculative while the limit is apart (the gap may close within this
    substep, no more), soft once crossed (Box2D v3's revolute and prismatic limits). An infinite
    bound has no row. Shared by the first coordinate (``_solve_axial``) and the second
    (``_solve_axial2``: a ball joint's twist, a universal joint's angle about axis_b)."""
    for side in range(2):
        sign, C = limit_side(side, lower, upper, pos)
        if math.isinf(C):
            continue
        slot = slot0 + side
        cdot = sign * _row_velocity(v, omega, a, b, linear, n, ra, rb)
        old = axial_impulse[j, slot]
        new = limit_impulse_after(C, inv_h, soft, m_eff, cdot, old)
        axial_impulse[j, slot] = new
        _axial_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, comp, j, linear_impulse, 0,
                     sign * (new - old), keep, axial_impulse)


@njit(**JIT, inline="always")
def _solve_axial(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, param, position, inv_mass, I_inv,
                 h, inv_h, soft, v, omega, linear_impulse, axial_impulse, in_tree):
    """Spring/PD drive, motor, then limits (or the rigid length of a distance joint) on the 1-D coordinate.
    ``in_tree``: the joint's rigid rows are the tree's, and its limits too (a hinge's, slider's,
    ball's cone, universal joint's or distance joint's: ``joint_tree.tree_limits_kernel``): left
    out here."""
    limit_on = param[j, P_LIMIT_ON] != 0.0 and not (in_tree and tree_limited(t))
    if (param[j, P_STIFFNESS] == 0.0 and param[j, P_DAMPING] == 0.0 and param[j, P_MOTOR_ON] == 0.0
            and param[j, P_RIGID] == 0.0 and not limit_on and not _has_passive(param, j)):
        return  # PERF: most joints (a net, a chain) have no 1-D rows; skip their geometry
    p = param[j]
    has, linear, n, ra, rb, pos = _coordinate_row(t, j, a, b, x, R, local_a, local_b, frame_a, frame_b, position)
    if not has:
        return
    if t == JOINT_UNIVERSAL and p[P_LIMIT_ON] != 0.0:
        pos = _centred_angle(pos, p[P_LOWER], p[P_UPPER])
    if (p[P_STIFFNESS] == 0.0 and p[P_DAMPING] == 0.0 and p[P_MOTOR_ON] == 0.0 and p[P_RIGID] == 0.0
            and not _has_passive(param, j) and limit_rows_idle(j, A_LOWER, p[P_LOWER], p[P_UPPER], pos,
                                _row_velocity(v, omega, a, b, linear, n, ra, rb), inv_h, axial_impulse)):
        # PERF: only limits, both apart and not closing within the substep, with no impulse: their
        # rows would add nothing; skip the row's mass (a 3x3 solve with the anchor block): a sweep of
        # an ant's eight hinges with limits alone, swinging freely, 7.7 -> 3.6 us (the same bits).
        return
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
    keep = 1.0
    if p[P_ARMATURE] > 0.0:
        # Armature a along this coordinate (``_solve_armature``): a row that pushes on the
        # coordinate also pushes on the armature, which answers at once (the armature row is
        # along the same J: its converged response to an impulse d is -d a k / (1 + a k)), so
        # each row here sees the coordinate's inertia 1/k + a and moves the bodies by
        # ``keep`` = 1 / (1 + a k) of its impulse. Without it a limit row saw the link's own
        # inertia alone: an ant's light legs (link inertia 1e-4, armature 1) started 30 deg
        # past their ankle limits blew up within 20 steps, and two light links with armature 1
        # pushed onto a limit bounced from stop to stop (measured).
        keep = 1.0 / (1.0 + p[P_ARMATURE] * k)
        k = k * keep
    m_eff = 1.0 / k
    ks = p[P_STIFFNESS]
    cs = p[P_DAMPING]
    if _has_passive(param, j):
        # the drive and the joint's passive spring-damper in one row: their impulse is the sum of
        # the two implicit laws, and the cap holds the drive's share alone (``_drive_and_passive``)
        cdot = _row_velocity(v, omega, a, b, linear, n, ra, rb)
        old = axial_impulse[j, A_SPRING]
        new = _drive_and_passive(p, k, h, cdot, pos, old)
        axial_impulse[j, A_SPRING] = new
        _axial_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, comp, j, axial_impulse, A_MOTOR_ANCHOR,
                     new - old, keep, axial_impulse)
    elif ks > 0.0 or cs > 0.0:
        # implicit spring-damper as a soft row (Catto, GDC 2011): gamma = 1 / (h (c + h k))
        # is the compliance, k / (c + h k) the rate at which the error feeds the bias
        gamma = 1.0 / (h * (cs + h * ks))
        eff = 1.0 / (k + gamma)
        cdot = _row_velocity(v, omega, a, b, linear, n, ra, rb)
        old = axial_impulse[j, A_SPRING]
        bias = ks / (cs + h * ks) * (pos - p[P_TARGET])
        if p[P_TARGET_RATE] != 0.0:
            # the damping pulls the rate to the target velocity w: -c (v+ - w) is -c v+ and a bias
            # c w; kept apart so that a drive without one keeps its bits
            bias -= cs * p[P_TARGET_RATE] / (cs + h * ks)
        imp = -eff * (cdot + bias) - gamma * eff * old
        lim = p[P_MAX_DRIVE] * h
        new = min(max(old + imp, -lim), lim)
        axial_impulse[j, A_SPRING] = new
        # the drive: its anchor compensation apart, as the motor's (see _axial_apply)
        _axial_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, comp, j, axial_impulse, A_MOTOR_ANCHOR,
                     new - old, keep, axial_impulse)
    if p[P_MOTOR_ON] != 0.0:
        _solve_motor_row(j, A_MOTOR, p[P_MOTOR_SPEED], p[P_MAX_MOTOR] * h, m_eff, a, b, linear, n, ra, rb, comp, keep,
                         inv_mass, I_inv, v, omega, axial_impulse)
    if p[P_RIGID] != 0.0:
        cdot = _row_velocity(v, omega, a, b, linear, n, ra, rb)
        old = axial_impulse[j, A_EQUAL]
        imp = -m_eff * soft[1] * (cdot + soft[0] * (pos - p[P_LOWER])) - soft[2] * old
        axial_impulse[j, A_EQUAL] = old + imp
        _axial_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, comp, j, linear_impulse, 0, imp, keep,
                     axial_impulse)
    elif limit_on:
        _solve_limit_rows(j, A_LOWER, p[P_LOWER], p[P_UPPER], pos, a, b, linear, n, ra, rb, comp, keep, m_eff, soft,
                          inv_h, inv_mass, I_inv, v, omega, linear_impulse, axial_impulse)


@njit(**NO_NRT)
def _has_passive(param, j):
    """Whether joint j has a passive spring or damper of its own (``P_PASSIVE_STIFFNESS``,
    ``P_PASSIVE_DAMPING``: MuJoCo's joint stiffness and damping beside an actuator's drive)."""
    return param[j, P_PASSIVE_STIFFNESS] != 0.0 or param[j, P_PASSIVE_DAMPING] != 0.0


@njit(**NO_NRT)
def _drive_and_passive(p, k, h, cdot, pos, old):
    """The accumulated impulse (N s or N m s) of a 1-D coordinate's drive (stiffness ks, damping cs
    to ``P_TARGET``, at most ``P_MAX_DRIVE``) and passive spring-damper (kp, cp to ``P_SPRINGREF``,
    uncapped) together, solved locally: ``k`` the row's inverse mass, ``cdot`` its velocity with
    ``old`` (the accumulated impulse) applied, ``pos`` the coordinate, ``h`` the substep.

    Each law is implicit (Catto's soft row, GDC 2011): an impulse lambda with end velocity
    v+ = cdot + k (lambda - old) obeys lambda = -h ((c + h s) v+ + s (pos - rest)). Their sum is one
    soft row of stiffness ks + kp, damping cs + cp (MuJoCo sums a joint's passive force and its
    actuator's; until session 43 tumble's MJCF reader summed them into the drive, whose cap then
    held the passive share too: a servo saturated at 5 N m lost its joint's damping, 0.17 rad ahead
    of MuJoCo's at 0.3 s; with a 1 N m cap and no kv it swung on where MuJoCo's settled). When the
    drive's share, lambda - lambda_passive(v+), passes the cap L, the drive gives s L (s its sign)
    and the passive law alone decides the rest: lambda = s L + lambda_passive(v+), that is
    lambda = (a (k old - cdot) - h kp (pos - springref) + s L) / (1 + a k), a = h (cp + h kp).
    The drive's damping pulls to ``P_TARGET_RATE`` w (its law -ks (q - target) - cs (q' - w)), the
    passive damper to rest."""
    ks, cs = p[P_STIFFNESS], p[P_DAMPING]
    kp, cp = p[P_PASSIVE_STIFFNESS], p[P_PASSIVE_DAMPING]
    stiffness, damping = ks + kp, cs + cp
    gamma = 1.0 / (h * (damping + h * stiffness))
    error = (ks * (pos - p[P_TARGET]) + kp * (pos - p[P_SPRINGREF])) / (damping + h * stiffness)
    if p[P_TARGET_RATE] != 0.0:  # the drive's damping pulls to the target velocity (``_solve_axial``)
        error -= cs * p[P_TARGET_RATE] / (damping + h * stiffness)
    new = old - (cdot + error + gamma * old) / (k + gamma)
    lim = p[P_MAX_DRIVE] * h
    if lim < math.inf:
        a = h * (cp + h * kp)
        passive = -(a * (cdot + k * (new - old)) + h * kp * (pos - p[P_SPRINGREF]))
        drive = new - passive
        if drive > lim or drive < -lim:
            cap = lim if drive > 0.0 else -lim
            new = (a * (k * old - cdot) - h * kp * (pos - p[P_SPRINGREF]) + cap) / (1.0 + a * k)
    return new


@njit(**NO_NRT)
def tree_limited(t):
    """Whether the tree method solves the limits of a joint of type t through the tree
    (``joint_tree.tree_limits_kernel``): every coordinate with limits (a gear has none)."""
    return (t == JOINT_HINGE or t == JOINT_SLIDER or t == JOINT_BALL or t == JOINT_UNIVERSAL
            or t == JOINT_DISTANCE)


@njit(**NO_NRT)
def limit_rows_idle(j, slot0, lower, upper, pos, cdot, inv_h, axial_impulse):
    """Whether both limit rows [lower, upper] of the 1-D coordinate at ``pos`` moving at ``cdot``,
    accumulated in ``axial_impulse[j, slot0]`` and ``[j, slot0 + 1]`` (the first coordinate's or
    the second's), would apply nothing this sweep (``_solve_limit_rows``): each bound infinite, or
    apart (C > 0) with no accumulated impulse and C / h + its rate >= 0, so that
    max(0 - m (rate + C / h), 0) = 0."""
    for side in range(2):
        sign, C = limit_side(side, lower, upper, pos)
        if math.isinf(C):
            continue
        if C <= 0.0 or axial_impulse[j, slot0 + side] != 0.0 or sign * cdot + C * inv_h < 0.0:
            return False
    return True


@njit(**NO_NRT)
def _solve_armature(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, param, position, rate0, inv_mass, I_inv,
                    v, omega, axial_impulse):
    """MuJoCo's armature a on the 1-D coordinate q: (I_q + a) q'' = tau adds a q'' to its
    equation, over a substep the impulse -a (q' - q'_0) along the row, with q'_0 = ``rate0[j]``
    the armature's own rate before the substep's forces (``flywheel_rates_kernel``): a soft row of compliance
    1/a and target q'_0, solved implicitly (as the PD drive's row; a hinge's with the anchor
    block, ``_coupled_row_mass``), accumulated in ``axial_impulse[j, A_ARMATURE]``.

    Solved after the joint's rigid rows: they pass the forces' pull on the anchor into the
    rotation, which this row then slows, so one sweep gives a lone pendulum exactly
    q' = q'_0 + h tau / (I + a). Before them, one sweep left it 4 % of the angle off at
    0.5 s (the anchor row then turned the body after the armature had acted; measured)."""
    has, linear, n, ra, rb, _pos = _coordinate_row(t, j, a, b, x, R, local_a, local_b, frame_a, frame_b, position)
    if not has:
        return
    if t == JOINT_HINGE:
        k, comp = _coupled_row_mass(inv_mass, I_inv, a, b, n, ra, rb)
    else:
        k = _row_mass(inv_mass, I_inv, a, b, linear, n, ra, rb)
        comp = (0.0, 0.0, 0.0)
    gamma = 1.0 / param[j, P_ARMATURE]
    cdot = _row_velocity(v, omega, a, b, linear, n, ra, rb)
    old = axial_impulse[j, A_ARMATURE]
    imp = -(cdot - rate0[j] + gamma * old) / (k + gamma)
    axial_impulse[j, A_ARMATURE] = old + imp
    _axial_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, comp, j, axial_impulse, A_MOTOR_ANCHOR, imp, 1.0,
                 axial_impulse)


@njit(**NO_NRT)
def _centred_angle(angle, lower, upper):
    """An angle of (-pi, pi] (twist, universal angles) seen in the chart of width 2 pi centred
    on the middle of its limits [lower, upper] (within [-pi, pi]): the cut where the angle
    jumps by 2 pi then lies in the middle of the forbidden arc (upper, lower + 2 pi), as far
    as it can be from both limits, so an overshoot past a limit reads as one (not as a
    violation of the other limit by nearly 2 pi)."""
    mid = 0.5 * (lower + upper)
    return mid + _wrap(angle - mid)


@njit(**NO_NRT)
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
                  v, omega, linear_impulse, axial_impulse, in_tree):
    """Motor (universal joints), then lower and upper limit of the second angular
    coordinate (``_second_row``: a ball joint's twist, a universal joint's angle about
    axis_b), the same rows as the first coordinate's in ``_solve_axial`` (Box2D v3's
    revolute limit: velocity level, speculative while the limit is apart, soft once
    crossed; solved with the anchor block). Accumulated in ``axial_impulse[j, A_*2]``.
    The first coordinate's code is left as it is so that joints without these rows give
    the same numbers as before. ``in_tree``: the joint is the tree's, whose limits are solved
    through it (``joint_tree.tree_limits_kernel``): only the motor here."""
    p = param[j]
    limit_on = p[P_LIMIT2_ON] != 0.0 and not in_tree
    if not limit_on and p[P_MOTOR2_ON] == 0.0:
        return
    has, n, pos = _second_row(t, j, a, b, R, frame_a, frame_b)
    if not has:
        return
    if limit_on:
        pos = _centred_angle(pos, p[P_LOWER2], p[P_UPPER2])
    ra, pa = _anchor(x, R, a, local_a, j)
    rb, pb = _anchor(x, R, b, local_b, j)
    k, comp = _coupled_row_mass(inv_mass, I_inv, a, b, n, ra, rb)
    if k <= 0.0:
        return
    m_eff = 1.0 / k
    if p[P_MOTOR2_ON] != 0.0:
        _solve_motor_row(j, A_MOTOR2, p[P_MOTOR2_SPEED], p[P_MAX_MOTOR2] * h, m_eff, a, b, False, n, ra, rb, comp, 1.0,
                         inv_mass, I_inv, v, omega, axial_impulse)
    if not limit_on:
        return
    _solve_limit_rows(j, A_LOWER2, p[P_LOWER2], p[P_UPPER2], pos, a, b, False, n, ra, rb, comp, 1.0, m_eff, soft, inv_h,
                      inv_mass, I_inv, v, omega, linear_impulse, axial_impulse)


@njit(**JIT, inline="always")
def _solve_rigid(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, inv_mass, I_inv, soft,
                 v, omega, linear_impulse, angular_impulse):
    """The rigid blocks: angular (3x3 fixed/slider, 2x2 hinge, 1 universal), then the anchor
    (3x3) or the slider's two perpendicular rows (2x2)."""
    br, ms, iscale = soft[0], soft[1], soft[2]
    if t != JOINT_BALL and t != JOINT_DISTANCE:
        xa, ya, za, xb, yb, zb = _frames(R, a, b, frame_a, frame_b, j)
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


@njit(**NO_NRT)
def ball_drive_error(R, a, b, frame_a, frame_b, param, j):
    """theta (3,) rad, world: the rotation vector of E = G D_w^T, the rotation from a ball
    joint drive's target orientation of body_b to its present one (``BallJoint.target``).

    G = Fb Fa^T = xb xa^T + yb ya^T + zb za^T turns body_a's joint frame onto body_b's (the
    identity at creation, when the two frames coincide); D_w = Ra D Ra^T is the target D (a
    rotation in body_a's axes, ``P_BALL_TARGET``: quaternion (d_w, d)) in world axes, whose
    quaternion is (d_w, Ra d). At the target Fb = D_w Fa, so E = 1. With E's quaternion (w, u),
    w >= 0: theta = 2 atan2(|u|, w) u / |u| (accurate at small angles, where u ~ theta / 2)."""
    xa, ya, za, xb, yb, zb = _frames(R, a, b, frame_a, frame_b, j)
    gw, g1, g2, g3 = _matrix_quaternion(
        xb[0] * xa[0] + yb[0] * ya[0] + zb[0] * za[0], xb[0] * xa[1] + yb[0] * ya[1] + zb[0] * za[1],
        xb[0] * xa[2] + yb[0] * ya[2] + zb[0] * za[2], xb[1] * xa[0] + yb[1] * ya[0] + zb[1] * za[0],
        xb[1] * xa[1] + yb[1] * ya[1] + zb[1] * za[1], xb[1] * xa[2] + yb[1] * ya[2] + zb[1] * za[2],
        xb[2] * xa[0] + yb[2] * ya[0] + zb[2] * za[0], xb[2] * xa[1] + yb[2] * ya[1] + zb[2] * za[1],
        xb[2] * xa[2] + yb[2] * ya[2] + zb[2] * za[2])
    dw = param[j, P_BALL_TARGET]
    d = (param[j, P_BALL_TARGET + 1], param[j, P_BALL_TARGET + 2], param[j, P_BALL_TARGET + 3])
    if a >= 0:  # (the world's axes are its own: _mat_vec gives 0 for the world)
        d = _mat_vec(R, a, d)
    # E = G D_w^T: quaternion (gw, g) (dw, -d)
    g = (g1, g2, g3)
    w = gw * dw + _dot(g, d)
    u = _add(_sub(_scale(dw, g), _scale(gw, d)), _cross(d, g))
    if w < 0.0:
        w = -w
        u = _scale(-1.0, u)
    s = math.sqrt(_dot(u, u))
    if s == 0.0:
        return (0.0, 0.0, 0.0)
    return _scale(2.0 * math.atan2(s, w) / s, u)


@njit(**NO_NRT)
def _matrix_quaternion(m00, m01, m02, m10, m11, m12, m20, m21, m22):
    """Unit quaternion (w, x, y, z) of a rotation matrix given by its entries (Shepperd's
    method, as ``math3d.matrix_to_quat_into``; any sign)."""
    t = m00 + m11 + m22
    if t >= m00 and t >= m11 and t >= m22:
        s = 2.0 * math.sqrt(1.0 + t)
        q = (0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s)
    elif m00 >= m11 and m00 >= m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        q = ((m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s)
    elif m11 >= m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        q = ((m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
        q = ((m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s)
    n = 1.0 / math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] * n, q[1] * n, q[2] * n, q[3] * n)


@njit(**NO_NRT)
def _solve_ball_drive(j, a, b, x, R, local_a, local_b, frame_a, frame_b, param, inv_mass, I_inv, h, v, omega,
                      axial_impulse):
    """A ball joint's drive: the spring-damper torque -k theta - c (omega_b - omega_a) on body b
    (``ball_drive_error``'s theta, world), solved implicitly as one 3x3 block of angular rows
    (the hinge's PD row, ``_solve_axial``, about three axes at once; Catto, GDC 2011: compliance
    gamma = 1 / (h (c + h k)), the error fed back at k / (c + h k)). The joint pins its anchor, so
    the rows turn the bodies about it: each world axis e_i has the anchor block's compensation
    (``_coupled_row_mass``'s c_i, comp_i), the block's mass K_ij = e_i.(Ia^-1 + Ib^-1) e_j +
    c_i.comp_j. The accumulated impulse (``axial_impulse[j, A_BALL_DRIVE:+3]``, N m s, world) is
    capped at ``P_BALL_MAX_DRIVE`` h in norm; the anchor part goes with the motors' (``A_MOTOR_ANCHOR``).

    NOTE: one block, not three rows one after another: a Gauss-Seidel sweep over three coupled rows
    leaves the cross terms of an unsymmetric body's inertia a sweep behind."""
    p = param[j]
    ks = p[P_BALL_STIFFNESS]
    cs = p[P_BALL_DAMPING]
    ra, pa = _anchor(x, R, a, local_a, j)
    rb, pb = _anchor(x, R, b, local_b, j)
    P = _point_K(inv_mass, I_inv, a, b, ra, rb)
    c0 = _scale(-1.0, _add(_cross(rb, _mat_vec(I_inv, b, (1.0, 0.0, 0.0))),
                           _cross(ra, _mat_vec(I_inv, a, (1.0, 0.0, 0.0)))))
    c1 = _scale(-1.0, _add(_cross(rb, _mat_vec(I_inv, b, (0.0, 1.0, 0.0))),
                           _cross(ra, _mat_vec(I_inv, a, (0.0, 1.0, 0.0)))))
    c2 = _scale(-1.0, _add(_cross(rb, _mat_vec(I_inv, b, (0.0, 0.0, 1.0))),
                           _cross(ra, _mat_vec(I_inv, a, (0.0, 0.0, 1.0)))))
    q0 = _scale(-1.0, _solve3(P, c0))
    q1 = _scale(-1.0, _solve3(P, c1))
    q2 = _scale(-1.0, _solve3(P, c2))
    k00, k01, k02, k11, k12, k22 = _angular_K(I_inv, a, b)
    gamma = 1.0 / (h * (cs + h * ks))
    K = (k00 + _dot(c0, q0) + gamma, k01 + _dot(c0, q1), k02 + _dot(c0, q2),
         k11 + _dot(c1, q1) + gamma, k12 + _dot(c1, q2), k22 + _dot(c2, q2) + gamma)
    theta = ball_drive_error(R, a, b, frame_a, frame_b, param, j)
    beta = ks / (cs + h * ks)
    wrel = _sub(_angular_velocity(omega, b), _angular_velocity(omega, a))
    rate = (p[P_BALL_RATE], p[P_BALL_RATE + 1], p[P_BALL_RATE + 2])  # the target velocity, body_a's axes
    if rate[0] != 0.0 or rate[1] != 0.0 or rate[2] != 0.0:
        # the row's velocity error: the relative angular velocity less the target's (in world axes);
        # the spring's feed-back is in the bias as before, so the damping pulls to the target rate
        wrel = _sub(wrel, rate if a < 0 else _mat_vec(R, a, rate))
    old = (axial_impulse[j, A_BALL_DRIVE], axial_impulse[j, A_BALL_DRIVE + 1], axial_impulse[j, A_BALL_DRIVE + 2])
    lam = _solve3(K, _add(_add(wrel, _scale(beta, theta)), _scale(gamma, old)))
    new = _sub(old, lam)
    norm = math.sqrt(_dot(new, new))
    cap = p[P_BALL_MAX_DRIVE] * h
    if norm > cap:
        new = _scale(cap / norm, new)
    imp = _sub(new, old)
    for k in range(3):
        axial_impulse[j, A_BALL_DRIVE + k] = new[k]
    _apply_angular(omega, I_inv, a, b, imp)
    # The anchor's part: the whole drive impulse's at the present arms, not the sum of each solve's
    # increment at the arms of its time. NOTE: summed (as the hinge's motor and drive do), it kept
    # a force the arms had turned away from, which only the soft anchor row (a spring of its own)
    # answered: a reed struck by a ball settled 3 cm off its unstruck neighbours' pose, its anchors
    # 3-12 mm apart where theirs were 0.4-2.8 mm (examples/joints/reeds.toml, measured).
    comp = _add(_add(_scale(new[0], q0), _scale(new[1], q1)), _scale(new[2], q2))
    before = (axial_impulse[j, A_MOTOR_ANCHOR], axial_impulse[j, A_MOTOR_ANCHOR + 1],
              axial_impulse[j, A_MOTOR_ANCHOR + 2])
    _apply_linear(v, omega, inv_mass, I_inv, a, b, ra, rb, _sub(comp, before))
    for k in range(3):
        axial_impulse[j, A_MOTOR_ANCHOR + k] = comp[k]


@njit(**NO_NRT)
def _sym_mat_vec(K, u):
    """K u for K as 6 numbers."""
    k00, k01, k02, k11, k12, k22 = K
    return (k00 * u[0] + k01 * u[1] + k02 * u[2],
            k01 * u[0] + k11 * u[1] + k12 * u[2],
            k02 * u[0] + k12 * u[1] + k22 * u[2])


@njit(**JIT, inline="always")
def _sweep_joints(lo, hi, backward, order, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param,
                  enabled, gauss_seidel, position, rate0, x, R, inv_mass, I_inv, h, inv_h, soft, v, omega,
                  linear_impulse, angular_impulse, axial_impulse):
    """One Gauss-Seidel sweep over joints order[lo:hi], forward or ``backward``."""
    for k in range(lo, hi):
        j = order[lo + hi - 1 - k] if backward else order[k]
        if not enabled[j]:
            continue
        t = joint_type[j]
        if t == JOINT_GEAR:  # (with the tree method: its own step, joint_tree.tree_sweeps_kernel)
            if gauss_seidel[j] and gear_on(j, param, enabled):
                solve_gear(j, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position, x,
                           R, inv_mass, I_inv, soft, v, omega, axial_impulse)
            continue
        a = joint_a[j]
        b = joint_b[j]
        if _inv_m(inv_mass, a) + _inv_m(inv_mass, b) == 0.0:
            continue
        _solve_axial(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, param, position, inv_mass, I_inv,
                     h, inv_h, soft, v, omega, linear_impulse, axial_impulse, not gauss_seidel[j])
        if param[j, P_LIMIT2_ON] != 0.0 or param[j, P_MOTOR2_ON] != 0.0:
            # PERF: tested here, not only inside: while _solve_axial2 was a call (some 20
            # array arguments), the call alone cost 25 % of the joint_grid step, whose joints
            # have no such rows; it is inlined now, and the test still skips its set-up
            _solve_axial2(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, param, inv_mass, I_inv, h, inv_h,
                          soft, v, omega, linear_impulse, axial_impulse, not gauss_seidel[j])
        if t == JOINT_BALL and (param[j, P_BALL_STIFFNESS] != 0.0 or param[j, P_BALL_DAMPING] != 0.0):
            _solve_ball_drive(j, a, b, x, R, local_a, local_b, frame_a, frame_b, param, inv_mass, I_inv, h, v, omega,
                              axial_impulse)
        if gauss_seidel[j]:
            _solve_rigid(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, inv_mass, I_inv, soft,
                         v, omega, linear_impulse, angular_impulse)
            if param[j, P_ARMATURE] != 0.0:
                _solve_armature(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, param, position, rate0,
                                inv_mass, I_inv, v, omega, axial_impulse)


@njit(**JIT, parallel=True)
def solve_joints_kernel(order, bounds, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param,
                        enabled, gauss_seidel, position, rate0, x, R, inv_mass, I_inv, h, soft, iterations,
                        # outputs
                        v, omega, linear_impulse, angular_impulse, axial_impulse):
    """``iterations`` Gauss-Seidel sweeps over the joints, forward then backward in turn.

    soft: (3,) (bias rate 1/s, mass scale, impulse scale) of the rigid rows in this pass
    (Box2D ``b2Softness``; (0, 1, 0) in relax). Joints between two immovable bodies are skipped.
    ``gauss_seidel`` (J,) bool: whose rigid rows this sweep solves (the others are left to
    ``joint_tree.tree_substitute_kernel``, with their armature rows); the other 1-D coordinate
    rows of every joint are solved here. rate0 (J,) rad/s or m/s: the armatures' rates before this
    substep's forces (``flywheel_rates_kernel``; read by the armature rows only).

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
                              local_b, frame_a, frame_b, param, enabled, gauss_seidel, position, rate0, x, R,
                              inv_mass, I_inv, h, inv_h, soft, v, omega, linear_impulse, angular_impulse,
                              axial_impulse)
        _sweep_joints(bounds[parts], bounds[parts + 1], backward, order, joint_type, joint_a, joint_b, local_a,
                      local_b, frame_a, frame_b, param, enabled, gauss_seidel, position, rate0, x, R, inv_mass, I_inv,
                      h, inv_h, soft, v, omega, linear_impulse, angular_impulse, axial_impulse)


# the same sweeps on the calling thread, for callers that are kernels themselves (the tree
# sweeps, the fused substeps): the same source, so the same bits (partitions run one after another).
# PERF: without reference counting (it allocates nothing): compiled with it, each of its calls to
# the sweep routines increfed and decrefed their two dozen arrays; the humanoid's NRT_incref and
# NRT_decref fell from 16 % to 6 % of its step (perf), 660 -> 625 us a step (same bits)
solve_joints_serial_kernel = serial_twin(solve_joints_kernel, "solve_joints_serial_kernel", NO_NRT)


@njit(**NO_NRT)
def warm_start_joints_kernel(joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, enabled,
                             position, x, R, inv_mass, I_inv, h, linear_impulse, angular_impulse, axial_impulse,
                             # outputs
                             v, omega):
    """Apply each joint's accumulated impulses (of the last substep) once, and its applied
    effort over the substep h (s): ``param[:, P_EFFORT]`` N m or N along the coordinate, an
    impulse effort h each substep (the semi-implicit kick the forces get in
    ``integrate_velocities``; here because it acts along the joint's row)."""
    for j in range(joint_type.shape[0]):
        if not enabled[j]:
            continue
        a = joint_a[j]
        b = joint_b[j]
        t = joint_type[j]
        if t == JOINT_GEAR:
            if gear_on(j, param, enabled) and axial_impulse[j, GEAR_COLUMN] != 0.0:
                gear_apply(j, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position, x,
                           R, inv_mass, I_inv, axial_impulse[j, GEAR_COLUMN], v, omega)
            continue
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
                 - axial_impulse[j, A_UPPER] + axial_impulse[j, A_EQUAL] + axial_impulse[j, A_ARMATURE]
                 + param[j, P_EFFORT] * h)
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
        if t == JOINT_BALL:
            drive = (axial_impulse[j, A_BALL_DRIVE], axial_impulse[j, A_BALL_DRIVE + 1],
                     axial_impulse[j, A_BALL_DRIVE + 2])
            if drive[0] != 0.0 or drive[1] != 0.0 or drive[2] != 0.0:
                _apply_angular(omega, I_inv, a, b, drive)


@njit(**NO_NRT)
def clear_idle_impulses_kernel(joint_type, param, axial_impulse):
    """Zero the accumulated impulses of the 1-D rows that are off (a motor, a spring or PD drive,
    a ball's drive, limits), before a step's warm start.

    NOTE: why: ``warm_start_joints_kernel`` applies every stored impulse, and a row is solved
    (its impulse updated) only while it is on: a motor switched off at its force limit kept
    pushing with it for ever (a rotor sped from 3.8 to 328 rad/s in 1 s; a pendulum held by a
    motor or a PD drive never fell once they were off; found by a robotics audit, session 42).
    Rows that are on keep theirs (the same bits)."""
    for j in range(joint_type.shape[0]):
        t = joint_type[j]
        if t == JOINT_GEAR:  # its impulse is GEAR_COLUMN's, its own row
            continue
        p = param[j]
        motor = p[P_MOTOR_ON] != 0.0
        spring = p[P_STIFFNESS] != 0.0 or p[P_DAMPING] != 0.0 or _has_passive(param, j)
        motor2 = p[P_MOTOR2_ON] != 0.0
        ball_drive = t == JOINT_BALL and (p[P_BALL_STIFFNESS] != 0.0 or p[P_BALL_DAMPING] != 0.0)
        if not motor:
            axial_impulse[j, A_MOTOR] = 0.0
        if not spring:
            axial_impulse[j, A_SPRING] = 0.0
        if not motor2:
            axial_impulse[j, A_MOTOR2] = 0.0
        if p[P_LIMIT_ON] == 0.0:
            axial_impulse[j, A_LOWER] = 0.0
            axial_impulse[j, A_UPPER] = 0.0
        if p[P_LIMIT2_ON] == 0.0:
            axial_impulse[j, A_LOWER2] = 0.0
            axial_impulse[j, A_UPPER2] = 0.0
        # (A_EQUAL and A_ARMATURE are left: the tree solve accumulates responses there for joints
        # of no rigid length or armature too, joint_tree.py)
        if not ball_drive:
            for k in range(3):
                axial_impulse[j, A_BALL_DRIVE + k] = 0.0
        if not (motor or spring or motor2 or ball_drive or p[P_ARMATURE] != 0.0):  # the anchor's share of those rows
            for k in range(3):
                axial_impulse[j, A_MOTOR_ANCHOR + k] = 0.0


@njit(**NO_NRT)
def joint_rates_kernel(joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, enabled, position,
                       x, R, v, omega,
                       # outputs
                       rate0):
    """rate0[j] = the 1-D coordinate's rate (rad/s or m/s) of each joint with armature, from
    v, omega (N, 3) at poses x, R: taken before a step's first substep's forces, the target of
    its armature row (``_solve_axial``, ``joint_tree.tree_factor_kernel``) where the last step's
    armature rate is not known (later substeps carry the armature's own rate,
    ``flywheel_rates_kernel``).

    NOTE: v, omega must be those the last substep solved, taken before this substep derives
    omega again from L at the new orientation: that derivation carries the velocity-product
    (gyroscopic, centrifugal) change of the coordinate's rate, which the armature must resist
    too (``first_substep_rates_kernel`` says what went wrong when it was taken after)."""
    for j in range(joint_type.shape[0]):
        if not enabled[j] or param[j, P_ARMATURE] == 0.0:
            continue
        has, linear, n, ra, rb, _pos = _coordinate_row(joint_type[j], j, joint_a[j], joint_b[j], x, R, local_a,
                                                       local_b, frame_a, frame_b, position)
        rate0[j] = _row_velocity(v, omega, joint_a[j], joint_b[j], linear, n, ra, rb) if has else 0.0


@njit(**NO_NRT)
def flywheel_rates_kernel(param, enabled, axial_impulse, rate0,
                          # outputs
                          rate):
    """rate[j] = rate0[j] - axial_impulse[j, A_ARMATURE] / a (rad/s or m/s), for each enabled joint
    with armature a: the armature's own rate after a substep, the next substep's target (and, kept
    by ``JointSolver.store``, the next step's first). rate0 (J,) the substep's target,
    axial_impulse (J, AXIAL_COUNT) N s or N m s its accumulated impulses; rate (J,) may be rate0.

    Why: the armature is an inertia a on the coordinate, a flywheel whose momentum a q' changes
    only by the impulses of its row (-lambda: the row gives the bodies J^T lambda). Its rate was
    taken again each substep from the bodies' solved velocities (J u), which is the flywheel's rate
    only if nothing moved the bodies after the row's last solve; the contacts do (they are solved
    after the joints, with the free bodies' masses). Every change a contact made to q' was then
    the flywheel's too, momentum a dq' from nothing: Gymnasium's ant (armature 1 kg m^2, about 1000
    times its legs' inertia about their hinges) let go on friction 3 turned its legs at 81 rad/s
    within 1 s and leapt 20 m; a ball striking a hinged bar with armature 1 (no gravity) left the
    angular momentum about the hinge 4.67 N m s off its 2.4 (measured; tests/physics/
    test_joints_actuation.py, test_mjcf.py). Carried, a contact's change of q' is resisted by the
    flywheel at the next solve of its row, as an impulse exchanged with the bodies: the momentum
    about the hinge keeps to 2e-4, and the ant falls to the floor as MuJoCo's does. The soft step
    also ends each substep with the joints' relax solve after the contacts', so that the bodies'
    rates are the flywheel's when stored (soft_step.substeps_kernel)."""
    for j in range(param.shape[0]):
        if not enabled[j] or param[j, P_ARMATURE] == 0.0:
            continue
        rate[j] = rate0[j] - axial_impulse[j, A_ARMATURE] / param[j, P_ARMATURE]


# numbers kept per body in ``JointSolver.armature_state``: the widest state row (the matrix
# layout's 18; the quaternion layout's 13 leave the rest zero)
ARMATURE_STATE_WIDTH = 18


@njit(**NO_NRT)
def first_substep_rates_kernel(armature_rate, rate0):
    """rate0[j] = armature_rate[j] where it is known (not NaN): the step's first substep.

    Why: the armature a of a coordinate adds to its inertia (MuJoCo: M + diag(a)), so it must
    resist every change of the coordinate's rate over a substep, the velocity-product
    (centrifugal, gyroscopic) part too. In the soft step that part enters when a substep derives
    omega again from L at the orientation the last substep reached (omega = I(R)^-1 L): a target
    taken after that derivation never sees it. Later substeps take their target before it
    (``substeps_kernel``); the first takes the rates the last step ended with, kept by
    ``JointSolver.store``. Measured (tests/physics/test_mjcf.py, a roll joint of armature 0.04
    on a turning parent): the roll's acceleration -1.934 rad/s^2 = -c/I with the target taken
    after, MuJoCo's -c/(I + a) = -0.0459 before."""
    for j in range(rate0.shape[0]):
        r = armature_rate[j]
        if r == r:
            rate0[j] = r


@njit(**NO_NRT)
def keep_armature_state_kernel(joint_a, joint_b, param, enabled, Y,
                               # outputs
                               armature_state, armature_rate):
    """After a step: armature_state[j] = the state rows (Y (N, 13 or 18)) of the two bodies of
    each enabled joint with armature (zeros for the world), which ``armature_rates_current_kernel``
    compares before the next step; armature_rate[j] NaN for the joints without armature."""
    width = Y.shape[1]
    for j in range(joint_a.shape[0]):
        if not enabled[j] or param[j, P_ARMATURE] == 0.0:
            armature_rate[j] = math.nan
            continue
        for side in range(2):
            body = joint_a[j] if side == 0 else joint_b[j]
            for c in range(armature_state.shape[2]):
                armature_state[j, side, c] = Y[body, c] if body >= 0 and c < width else 0.0


@njit(**NO_NRT)
def armature_rates_current_kernel(joint_a, joint_b, Y, armature_state,
                                  # outputs
                                  armature_rate):
    """armature_rate[j] = NaN where a state row of the joint's bodies in Y (N, 13 or 18) is no
    longer the one kept by ``keep_armature_state_kernel`` (bit for bit: anything that moved the
    body between the steps)."""
    width = Y.shape[1]
    for j in range(joint_a.shape[0]):
        if armature_rate[j] != armature_rate[j]:
            continue
        for side in range(2):
            body = joint_a[j] if side == 0 else joint_b[j]
            if body < 0:
                continue
            for c in range(width):
                if Y[body, c] != armature_state[j, side, c]:
                    armature_rate[j] = math.nan
