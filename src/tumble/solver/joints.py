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
forest are instead solved exactly in linear time (Baraff 1996; ``tree_factor_kernel``, ``tree_substitute_kernel``).

``step_with_joints`` is a standalone stepper (the World's built-in forces and joints; no
contacts, no user callables) in the stage order of the Simulator's soft step
(``solver.soft_step``). It differs in its forces (evaluated once a step, not every substep),
its velocity update (the gyroscopic term by one implicit Newton step, where the soft step
keeps L as the state) and the NGS projection (``position_iterations``), which only it runs.

Modules: ``joint_math`` (vectors, anchors, rows' masses), ``joint_solve`` (the rows' velocity
solve, the sweep kernels), ``joint_gear`` (the gear row), ``joint_tree`` (the exact solve on trees), ``joint_stepper`` (the
standalone stepper); here the settings, the position projection, the readings and
``JointSolver``, which holds the tables and calls them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..joints import (
    JOINT_BALL,
    JOINT_DISTANCE,
    JOINT_GEAR,
    JOINT_HINGE,
    JOINT_SLIDER,
    JOINT_UNIVERSAL,
    P_ARMATURE,
    P_BALL_DAMPING,
    P_BALL_STIFFNESS,
    P_BALL_TARGET,
    P_EFFORT,
    P_LIMIT2_ON,
    P_LIMIT_ON,
    P_LOWER,
    P_MAX_FORCE,
    P_MAX_TORQUE,
    P_PASSIVE_STIFFNESS,
    P_SPRINGREF,
    P_STIFFNESS,
    P_TARGET,
    P_TARGET_RATE,
    P_UPPER,
    PARAM_COUNT,
    edit_count,
    edited_since,
    set_record_effort,
    set_record_target,
)
from ..math3d import (
    JIT,
    normalize_quat_inplace,
    quat_exp_multiply_inplace,
    quat_to_matrix_into,
    start_threads,
)
from .joint_gear import GEAR_COLUMN, gear_axis, gear_rate
from .joint_math import (
    _add,
    _anchor,
    _angular_K,
    _cross,
    _dot,
    _frames,
    _inv_m,
    _mat_vec,
    _point_K,
    _row_mass,
    _row_velocity,
    _scale,
    _slider_rows,
    _solve2,
    _solve3,
    _sub,
)
from .joint_solve import (
    A_BALL_DRIVE,
    A_EQUAL,
    A_LOWER,
    A_LOWER2,
    A_MOTOR,
    A_MOTOR2,
    A_MOTOR_ANCHOR,
    A_SPRING,
    A_UPPER,
    A_UPPER2,
    ARMATURE_STATE_WIDTH,
    AXIAL_COUNT,
    _coordinate_row,
    _second_row,
    ball_drive_error,
    _sym_mat_vec,
    armature_rates_current_kernel,
    first_substep_rates_kernel,
    flywheel_rates_kernel,
    joint_rates_kernel,
    keep_armature_state_kernel,
    solve_joints_kernel,
    twist_angle,  # noqa: F401  (public here, as before the split)
    clear_idle_impulses_kernel,
    warm_start_joints_kernel,
)
from .joint_stepper import (  # noqa: F401  (public here, as before the split: tests, docs/joints.md)
    integrate_positions_kernel,
    integrate_velocities_kernel,
    step_with_joints,
)
from .joint_tree import (
    tree_layout,
    tree_sweeps_kernel,
)
from .partition import SweepOrder


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
        1996), loop-closing joints and the 1-D coordinate rows (motors, springs, drives) by
        Gauss-Seidel around it, ``velocity_iterations`` / ``relax_iterations`` times; the limits
        of hinges, sliders, ball joints (cone and twist), universal joints and ropes as rows of
        the whole tree (``joint_tree.tree_limits_kernel``). With
        "tree", the rows are rigid with bias rate 1/h (hertz 0) or the soft bias rate of
        ``hertz`` (no mass or impulse scaling).
    limit_hertz, limit_damping_ratio: (240 Hz, 2) with the tree method, the softness at which a
        limit solved through the tree pushes a crossed limit back in the biased solve (a soft row,
        Box2D's b2MakeSoft; capped as ``hertz``: 240 Hz is the cap at the default substep of
        1/960 s); 0: rigid, the rigid rows' 1/h bias. Its stop stays rigid (a limit apart may close
        within a substep, no more). NOTE: why: rigid, a limit pressed by contacts overshot its
        push-out and bounced: Gymnasium's humanoid lying with an elbow on its limit never came to
        rest (0.11 rad/s, the elbow 4e-4 rad past its limit, then 5e-4 apart, step after step;
        MuJoCo's, whose limits are soft, 0.012), soft at 30 to 240 Hz: 1e-13 rad/s (measured,
        session 35). Under load a soft limit gives a little (an arm resting on its limit: 1e-5 rad
        at 240 Hz, 1.5e-4 at Box2D's 60 Hz: tests/physics/test_urdf.py).
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
    limit_hertz: float = 240.0
    limit_damping_ratio: float = 2.0

    def __post_init__(self):
        if self.method not in ("gauss-seidel", "tree"):
            raise ValueError(f"method must be 'gauss-seidel' or 'tree', got {self.method!r}")


# Settings for accuracy (the acceptance tests of issue 4): rigid rows solved exactly on the
# spanning tree, two sweeps for the 1-D rows around it. See docs/joints.md for what each costs.
ACCURATE = JointSettings(hertz=0.0, velocity_iterations=2, relax_iterations=2, method="tree")


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
            if t == JOINT_GEAR:
                continue  # gears are left to the velocity solve
            if t != JOINT_BALL and t != JOINT_DISTANCE:
                xa, ya, za, xb, yb, zb = _frames(R, a, b, frame_a, frame_b, j)
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
        if t == JOINT_GEAR:  # its error and rate; what it applies to its joint; it does not break
            position[j], rate[j] = gear_rate(j, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b,
                                             param, position, x, R, v, omega)
            linear, n = gear_axis(j, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param,
                                  position, x, R)
            effort = axial_impulse[j, GEAR_COLUMN] * inv_h
            for k in range(3):
                reaction_force[j, k] = effort * n[k] if linear else 0.0
                reaction_torque[j, k] = 0.0 if linear else effort * n[k]
            broke[j] = False
            continue
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
        if t == JOINT_BALL and (param[j, P_BALL_STIFFNESS] != 0.0 or param[j, P_BALL_DAMPING] != 0.0):
            tq = _add(tq, (axial_impulse[j, A_BALL_DRIVE], axial_impulse[j, A_BALL_DRIVE + 1],
                           axial_impulse[j, A_BALL_DRIVE + 2]))
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


def present_readings(world, records=None) -> dict:
    """``JointSolver.readings()`` of ``world.joints`` (or of the bound, non-gear joint ``records``
    given, in their order) as the end of a step would store them, taken from the bodies' present
    poses and velocities by the step's own ``store_joints_kernel``: ``position`` and ``rate`` as after
    a step (a hinge's angle in (-pi, pi]: no earlier reading to count whole turns from, as the first
    step's), ``force`` and ``torque`` zero (no step has acted), ``enabled`` from the records. What a
    robot's ``joint_states`` reads before the first step (its own joints: PERF: a vector env of n
    copies read each copy's over all n copies' joints, n^2: 201 s for the first step of 2048
    pendulums; an RL audit, session 43)."""
    solver = JointSolver()
    solver._build(list(world.joints) if records is None else list(records))
    if solver.count:
        store_joints_kernel(solver.joint_type, solver.joint_a, solver.joint_b, solver.local_a, solver.local_b,
                            solver.frame_a, solver.frame_b, solver.param, world.x, world.R, world.v, world.omega,
                            1.0, solver.linear_impulse, solver.angular_impulse, solver.axial_impulse,
                            solver.enabled, solver.position, solver.rate, solver.reaction_force,
                            solver.reaction_torque, solver.broke)
    return solver.readings()


def joint_spring_energy(world) -> float:
    """J: the energy the joints' springs hold at the world's poses, 1/2 k (q - target)^2 of each
    hinge, slider and distance joint with a stiffness (q its angle, displacement or length) and
    1/2 k |theta|^2 of each ball joint drive (``joint_solve.ball_drive_error``: its torque is this
    potential's gradient); broken joints hold none. A hinge's angle is taken within half a turn of
    its target (the poses alone do not count turns; the solver's coordinate does): a spring wound
    more than half a turn from its target is under-counted. Read from the records' bound rows
    (``tumble.joints.BoundJoint``), so it needs no solver."""
    x, R = world.x, world.R
    energy = 0.0
    for joint in world.joints:
        b = joint.bound
        if b is None or joint.broken or b.type_id not in (JOINT_BALL, JOINT_HINGE, JOINT_SLIDER, JOINT_DISTANCE):
            continue
        p = b.param
        if b.type_id == JOINT_BALL:
            if p[P_BALL_STIFFNESS] == 0.0:
                continue
            theta = ball_drive_error(R, b.body_a, b.body_b, b.frame_a[None], b.frame_b[None], p[None], 0)
            energy += 0.5 * p[P_BALL_STIFFNESS] * (theta[0] ** 2 + theta[1] ** 2 + theta[2] ** 2)
            continue
        # the drive's spring to its target and the passive spring to springref (hinges, sliders)
        for stiffness, rest in ((p[P_STIFFNESS], p[P_TARGET]), (p[P_PASSIVE_STIFFNESS], p[P_SPRINGREF])):
            if stiffness == 0.0:
                continue
            # the hinge's angle unwrapped around the spring's rest: last_position = the rest
            has, _linear, _n, _ra, _rb, q = _coordinate_row(b.type_id, 0, b.body_a, b.body_b, x, R, b.local_a[None],
                                                            b.local_b[None], b.frame_a[None], b.frame_b[None],
                                                            np.array([rest]))
            if has:
                energy += 0.5 * stiffness * (q - rest) ** 2
    return float(energy)


# ---------------------------------------------------------------------- the solver object
def soft_coefficients(hertz: float, zeta: float, h: float):
    """(bias_rate 1/s, mass_scale, impulse_scale) of a soft row (Box2D ``b2MakeSoft``; Catto,
    GDC 2011, https://box2d.org/files/ErinCatto_SoftConstraints_GDC2011.pdf)."""
    omega = 2.0 * math.pi * hertz
    a1 = 2.0 * zeta + h * omega
    a2 = h * omega * a1
    a3 = 1.0 / (1.0 + a2)
    return omega / a1, a2 * a3, a3


# the tree method's extra sweeps while a limit row's impulse still changes (``JointSolver.solve``):
# at most this many sweeps, until no limit impulse changes by more than LIMIT_TOLERANCE of the largest
TREE_LIMIT_SWEEPS = 32
LIMIT_TOLERANCE = 1e-2
#: the tree method sweeps the groups of a world side by side on the threads from this many tree nodes
#: (``JointSolver._group_tables``)
GROUP_THREADS_MIN_NODES = 48


def _root(parent: list, i: int) -> int:
    """The root of ``i`` in the union-find forest ``parent`` (halving the path as it goes)."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


class JointSolver:
    """The joints of one World as arrays, and the accumulated impulses between steps.

    Constant arrays (J = joint count, in ``world.joints`` order): ``joint_type`` (J,) int64
    (``tumble.joints.JOINT_*``), ``joint_a``, ``joint_b`` (J,) int64 body indices (-1: world),
    ``local_a``, ``local_b`` (J, 3) m anchors in the body frames, ``frame_a``, ``frame_b``
    (J, 3, 3) joint axes in the body frames, ``param`` (J, PARAM_COUNT) (``tumble.joints.P_*``;
    writable between steps, e.g. ``param[j, P_MOTOR_SPEED]``).

    State: ``enabled`` (J,) bool (False once broken), ``linear_impulse``, ``angular_impulse``
    (J, 3) N s and ``axial_impulse`` (J, AXIAL_COUNT = 15) N s or N m s (the coordinate's
    spring, motor, lower, upper, equal rows; then the second angular coordinate's lower,
    upper, motor rows: ball twist, universal angle_b; then the motor and drive rows' anchor
    impulse, (3,) N s world, ``A_MOTOR_ANCHOR``; then the armature row's, ``A_ARMATURE``; then a
    ball joint drive's angular impulse, (3,) N m s world, ``A_BALL_DRIVE``),
    world, accumulated over the last substep, carried to the next for warm starting.
    ``rate0`` (J,): the armature rows' target, the armatures' own rates before the current
    substep's forces (``capture_rates``). ``armature_rate`` (J,) rad/s or m/s: the armatures'
    rates at the end of the last step (``joint_solve.flywheel_rates_kernel``; NaN: none, or no
    longer current), the first substep's target; ``armature_state`` (J, 2, 18): the rows of
    the state of the joint's two bodies (``World.state()``'s numbers, zeros past the layout's
    width and for the world) when they were taken, to tell whether anything moved the bodies
    since (``check_armature_rates``).

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
        self._row_of: dict = {}  # id(record) -> row (``index``)
        self.h = 1.0 / 240.0
        self.last_projection_error = 0.0
        self._soft_key = None
        self.sweep = SweepOrder()  # the joints' order in the sweeps (slabs for a large world)
        self._parts = None  # tree_parts of this step
        self.soft_limit = np.zeros(3)  # the tree's limit rows' softness in the biased solve (prepare)
        self._build([])

    def _build(self, joints):
        J = len(joints)
        old = {name: getattr(self, name, None) for name in ("enabled", "linear_impulse", "angular_impulse",
                                                              "axial_impulse", "position", "armature_rate",
                                                              "armature_state")}
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
        self.armature_rate = np.full(J, np.nan)  # the first substep's target (store, check_armature_rates)
        self.armature_state = np.zeros((J, 2, ARMATURE_STATE_WIDTH))
        # joints kept from before (a joint added later goes at the end): keep their state
        k = self.count
        if k and old["enabled"] is not None and self._joints == joints[:k]:
            for name, arr in old.items():
                getattr(self, name)[:k] = arr[:k]
        self.rate = np.zeros(J)
        self.rate0 = np.zeros(J)  # the armature rows' target, taken each substep (capture_rates)
        self.reaction_force = np.zeros((J, 3))
        self.reaction_torque = np.zeros((J, 3))
        self.broke = np.zeros(J, dtype=bool)
        self._joints = list(joints)
        self._edits_seen = edit_count()  # every row read from its record just now
        # record -> row, for ``index`` (a search through the list cost O(J) a lookup: resetting the
        # copies of a vector environment, tumble.envs, was quadratic in their number)
        self._row_of = {id(rec): j for j, rec in enumerate(self._joints)}
        self.count = J
        self._tree_key = None
        self.tree_layout = None  # (body_node, node_tree, tree_lo, tree_hi) with the tree method (_build_tree)
        self.has_gears = bool(np.any(self.joint_type == JOINT_GEAR))

    def _build_tree(self, moving: np.ndarray):
        """Spanning forest of the joint graph (moving bodies; the world and fixed bodies are
        one ground node): its joints are solved exactly, the others (loops) by Gauss-Seidel.
        Nodes are the moving bodies and the tree joints, each with its parent, leaves first."""
        J = self.count
        nb = moving.shape[0]
        ground = nb
        parent = list(range(nb + 1))

        def find(i):
            return _root(parent, i)

        def node_of(i):
            return i if i >= 0 and moving[i] else ground

        in_tree = np.zeros(J, dtype=bool)
        adjacency: dict[int, list] = {}
        for j in range(J):
            if not self.enabled[j] or self.joint_type[j] == JOINT_GEAR:
                continue  # a gear is a Gauss-Seidel row around the tree (it spans up to four bodies)
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
        # where each body sits in the forest, for contacts solved through it (contact_tree)
        self.tree_layout = tree_layout(self.node_body, self.node_parent, nb)
        _, _, lo, hi = self.tree_layout
        self.tree_width = int((hi - lo).max()) if n else 0
        self.gauss_seidel = ~in_tree
        # gears are solved by the tree sweeps themselves, each on tree-consistent velocities (tree_sweeps_kernel)
        self.gauss_seidel[self.joint_type == JOINT_GEAR] = False
        self._groups(moving)
        self._scratch = {
            "Ja": np.zeros((J, 6, 6)), "Jb": np.zeros((J, 6, 6)), "C": np.zeros((J, 6)),
            "nrow": np.zeros(J, dtype=np.int64), "D": np.zeros((n, 6, 6)), "Dinv": np.zeros((n, 6, 6)),
            "H_up": np.zeros((n, 6, 6)), "W": np.zeros((n, 6, 6)), "y": np.zeros((n, 6)), "sol": np.zeros((n, 6)),
            "work": np.zeros((6, 6)), "node_skip": np.zeros(n, dtype=bool), "sub_order": np.zeros(J, dtype=np.int64),
            "no_skip": np.zeros(n, dtype=bool),
            # the limit rows' responses through the tree (joint_tree.tree_limits_kernel): rows j, each
            # joint's first coordinate, and J + j, its second
            "limit_rows": (np.zeros(2 * J, dtype=np.int64), np.zeros((2 * J, self.tree_width), dtype=np.int64),
                           np.zeros((2 * J, self.tree_width, 8)), np.zeros(2 * J), np.zeros(2 * J, dtype=bool),
                           self.soft_limit),
        }

    def _groups(self, moving: np.ndarray):
        """The joints' groups for the tree sweeps' settling test (``joint_tree.tree_sweeps_kernel``):
        joints that share a moving body, directly or through others, are one group (the world and
        fixed bodies join nothing: two robots on one floor are two groups). ``joint_group`` (J,) and
        ``body_group`` (N,) int64, -1 outside any, and the scratch of the test. A world with a gear
        is one group (a gear's four bodies)."""
        J, nb = self.count, moving.shape[0]
        parent = list(range(nb))

        def find(i):
            return _root(parent, i)

        ends = []
        for j in range(J):
            a, b = self.joint_a[j], self.joint_b[j]
            pair = [i for i in (a, b) if i >= 0 and moving[i]]
            ends.append(pair)
            if len(pair) == 2:
                parent[find(pair[0])] = find(pair[1])
        body_group = np.full(nb, -1, dtype=np.int64)
        joint_group = np.full(J, -1, dtype=np.int64)
        label: dict = {}
        for j, pair in enumerate(ends):
            if pair:
                joint_group[j] = label.setdefault(find(pair[0]), len(label))
                for i in pair:
                    body_group[i] = joint_group[j]
        if self.has_gears:
            joint_group[joint_group >= 0] = 0
            body_group[body_group >= 0] = 0
            label = {0: 0} if len(label) else {}
        G = len(label)
        self.joint_group, self.body_group = joint_group, body_group
        self._group_scratch = (np.zeros(G), np.zeros(G), np.zeros(G, dtype=bool))
        self._group_tables(moving)

    def _group_tables(self, moving: np.ndarray):
        """The groups' own tables, for sweeping them side by side (``joint_tree._tree_sweeps_groups``):
        (mode, joint_start (G + 1,), joints (J',): each group's joints in joint order, tree_start
        (G + 1,), trees (T,): each group's trees, then scratch: order_start (G + 1,), order (J,),
        bounds (G, 2), work (G, 6, 6), and every joint 0..J-1 (J,): the serial sweep's limits).
        ``mode`` 1: side by side, when there are at least two groups (no gear: a gear makes the
        world one group), every enabled joint is in one, and the trees
        have at least ``GROUP_THREADS_MIN_NODES`` nodes (fewer: the threads' start costs more
        than they save); 0: the serial loop over the world."""
        G = len(self._group_scratch[0])
        J = self.count
        jg = self.joint_group
        joints = np.flatnonzero(jg >= 0)
        joints = joints[np.argsort(jg[joints], kind="stable")].astype(np.int64)
        joint_start = np.searchsorted(jg[joints], np.arange(G + 1)).astype(np.int64)
        _, node_tree, tree_lo, _ = self.tree_layout
        T = len(tree_lo)
        tree_group = np.full(T, -1, dtype=np.int64)
        bodies = np.flatnonzero(self.node_body >= 0)
        tree_group[node_tree[bodies]] = self.body_group[self.node_body[bodies]]
        trees = np.flatnonzero(tree_group >= 0)
        trees = trees[np.argsort(tree_group[trees], kind="stable")].astype(np.int64)
        tree_start = np.searchsorted(tree_group[trees], np.arange(G + 1)).astype(np.int64)
        apart = bool(np.all(jg[self.enabled] >= 0)) and not self.has_gears
        mode = int(G >= 2 and apart and len(self.node_order) >= GROUP_THREADS_MIN_NODES)
        self._groups_table = (mode, joint_start, joints, tree_start, trees, np.zeros(G + 1, dtype=np.int64),
                              np.zeros(J, dtype=np.int64), np.zeros((G, 2), dtype=np.int64), np.zeros((G, 6, 6)),
                              np.arange(J, dtype=np.int64))

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
        elif self._edits_seen != edit_count():  # a record edited since (tumble.joints.edit_joint)
            self.take_edits()
        if self.count:  # rows switched off since the last step drop their impulses (edits and robot writes alike)
            clear_idle_impulses_kernel(self.joint_type, self.param, self.axial_impulse)
        if self.settings.method == "tree":
            key = (self.count, world.body_count, bytes(world.moving), bytes(self.enabled))
            if key != self._tree_key:
                self._build_tree(np.asarray(world.moving))
                self._tree_key = key
        else:
            self.gauss_seidel = np.ones(self.count, dtype=bool)
            self.tree_layout = None
        self.h = float(h)
        self.inv_mass = world.inv_mass if inv_mass is None else inv_mass
        self.I_inv = world.I_inv if I_inv is None else I_inv
        st = self.settings
        key = (self.h, st.hertz, st.damping_ratio, st.hertz_cap_per_substep, st.bias_factor, st.limit_hertz,
               st.limit_damping_ratio)
        if key != self._soft_key:
            if st.hertz > 0.0:
                hertz = min(st.hertz, st.hertz_cap_per_substep / h)
                self.soft_bias = np.array(soft_coefficients(hertz, st.damping_ratio, h))
            else:  # rigid: the bias takes out bias_factor of the error in one substep
                self.soft_bias = np.array([st.bias_factor / h, 1.0, 0.0])
            self.soft_relax = np.array([0.0, 1.0, 0.0])
            if st.limit_hertz > 0.0:  # the tree's limit rows (joint_tree.tree_limits_kernel)
                hertz = min(st.limit_hertz, st.hertz_cap_per_substep / h)
                self.soft_limit[:] = soft_coefficients(hertz, st.limit_damping_ratio, h)
            else:
                self.soft_limit[:] = self.soft_bias
            self._soft_key = key
        st = self.settings
        self._parts = None  # tree_parts: the limit columns follow param, which may change between steps
        # a gear touches up to four bodies, the slabs see two: with gears, one sweep in the joints' order
        parts = 1 if self.has_gears else int(st.partitions)
        self.sweep.update(self.joint_a, self.joint_b, np.asarray(world.moving), world.x if x is None else x,
                          parts, st.partition_min_joints)

    def take_edits(self) -> list[int]:
        """Copy the parameter rows of the records edited since the tables last took them
        (``tumble.joints.mark_edited``: a field set after ``add_joint``, a target or torque set
        between steps) into ``param``; returns their rows."""
        rows = edited_since(self._joints, self._edits_seen)
        for k in rows:
            rec = self._joints[k]
            row = rec.bound.param
            self.param[k, :row.shape[0]] = row
            self.enabled[k] = not rec.broken  # set by the user too (tumble.joints.set_broken)
        self._edits_seen = edit_count()
        return rows

    def fusable(self) -> bool:
        """Whether ``soft_step.substeps_kernel`` can run this step's substeps (after
        ``prepare``): joints in one partition (on the calling thread)."""
        return self.count > 0 and self.sweep.bounds.shape[0] == 2

    def warm_start(self, v: np.ndarray, omega: np.ndarray, x: np.ndarray, R: np.ndarray):
        """Apply the accumulated impulses once to v, omega (N, 3) (each substep, before solve)."""
        if self.count:
            warm_start_joints_kernel(self.joint_type, self.joint_a, self.joint_b, self.local_a, self.local_b,
                                     self.frame_a, self.frame_b, self.param, self.enabled, self.position, x, R,
                                     self.inv_mass, self.I_inv, self.h, self.linear_impulse, self.angular_impulse,
                                     self.axial_impulse, v, omega)

    def has_armature(self) -> bool:
        """Whether a joint has armature (then ``capture_rates`` must run before each substep's forces)."""
        # (the array's own any: np.any's Python wrapper cost more than the test, twice a step)
        return bool(self.count) and bool((self.param[:, P_ARMATURE] > 0.0).any())

    def effort_bodies(self, body_count: int):
        """(N,) bool: the bodies of the enabled joints applying a torque or force (``P_EFFORT``), or
        None when there are none. Box2D wakes a body each time a force is applied to it: these may not
        sleep (a damped arm held by a joint torque fell asleep 5e-3 rad short of its rest, measured)."""
        if not self.count:
            return None
        on = (self.param[:, P_EFFORT] != 0.0) & self.enabled
        if not on.any():
            return None
        mask = np.zeros(body_count, dtype=bool)
        for ends in (self.joint_a[on], self.joint_b[on]):
            mask[ends[ends >= 0]] = True
        return mask

    def capture_rates(self, v: np.ndarray, omega: np.ndarray, x: np.ndarray, R: np.ndarray, first: bool = False,
                      carried: bool = True):
        """``rate0`` (J,): the armature rows' target, each substep before its forces. ``first``: the
        step's first substep: the coordinates' rates of the joints with armature from v, omega (N, 3)
        at poses x, R, or where ``carried`` and ``armature_rate`` is current, those
        (``first_substep_rates_kernel``); later substeps: the armature's own rate after the last
        substep (``flywheel_rates_kernel``)."""
        if self.count:
            if first:
                joint_rates_kernel(self.joint_type, self.joint_a, self.joint_b, self.local_a, self.local_b,
                                   self.frame_a, self.frame_b, self.param, self.enabled, self.position, x, R, v, omega,
                                   self.rate0)
                if carried:
                    first_substep_rates_kernel(self.armature_rate, self.rate0)
            else:
                flywheel_rates_kernel(self.param, self.enabled, self.axial_impulse, self.rate0, self.rate0)

    def check_armature_rates(self, Y: np.ndarray):
        """Before a step with armature: forget (NaN) ``armature_rate`` of the joints one of whose
        bodies' state rows in Y (N, 13 or 18) is not what it was at the end of the last step (the
        user moved, pushed or placed it, a reset, a restored snapshot of another time): their first
        substep takes its target from the velocities derived from the momenta, as before."""
        if self.count:
            armature_rates_current_kernel(self.joint_a, self.joint_b, Y, self.armature_state, self.armature_rate)

    def solve(self, v: np.ndarray, omega: np.ndarray, x: np.ndarray, R: np.ndarray, use_bias: bool,
              factor: bool = True):
        """Sweeps over the joints on v, omega (N, 3) at poses x (N, 3), R (N, 3, 3):
        ``use_bias=True`` before the positions move (soft rows, ``velocity_iterations``),
        False after (relax: rigid rows without bias, ``relax_iterations``). ``factor=False``: the
        tree method sweeps on the last solve's factors (nothing they depend on has moved since), with
        no limit re-sweeps."""
        if self.count:
            st = self.settings
            iterations = st.velocity_iterations if use_bias else st.relax_iterations
            soft = self.soft_bias if use_bias else self.soft_relax
            args = (self.sweep.order[:self.count], self.sweep.bounds, self.joint_type, self.joint_a, self.joint_b,
                    self.local_a, self.local_b, self.frame_a, self.frame_b,
                    self.param, self.enabled, self.gauss_seidel, self.position, self.rate0, x, R, self.inv_mass,
                    self.I_inv, self.h, soft)
            out = (v, omega, self.linear_impulse, self.angular_impulse, self.axial_impulse)
            if st.method != "tree":
                solve_joints_kernel(*args, int(iterations), *out)
                return
            limits, max_sweeps, tolerance, *tree = self.tree_parts()
            node_order, node_joint, node_body, node_parent, *scratch = tree
            start_threads()  # the groups may be swept side by side (joint_tree._tree_sweeps_groups)
            tree_sweeps_kernel(int(iterations), limits, max_sweeps, tolerance, *args, node_order, node_joint, node_body,
                               node_parent, np.int64((2 if use_bias and self.has_armature() else 1) if factor else 0),
                               *scratch, *out)

    def tree_parts(self) -> tuple:
        """The tree method's arrays for ``tree_sweeps_kernel``: (limit columns, TREE_LIMIT_SWEEPS,
        LIMIT_TOLERANCE, node_order, node_joint, node_body, node_parent, then its scratch: Ja, Jb,
        C, nrow, D, Dinv, H_up, W, y, sol, work, before, then the settling groups: joint_group,
        body_group and their scratch (``_groups``), node_skip, sub_order, sub_bounds). Empty arrays
        of the same types when the method is not the tree's (``soft_step.substeps_kernel`` takes
        them either way)."""
        if self.settings.method != "tree":
            if self.__dict__.get("_no_tree") is None:
                z = np.zeros
                i64 = np.int64
                self._no_tree = (z(0, i64), TREE_LIMIT_SWEEPS, LIMIT_TOLERANCE, z(0, i64), z(0, i64), z(0, i64),
                                 z(0, i64), z((0, 6, 6)), z((0, 6, 6)), z((0, 6)), z(0, i64), z((0, 6, 6)),
                                 z((0, 6, 6)), z((0, 6, 6)), z((0, 6, 6)), z((0, 6)), z((0, 6)), z((6, 6)), z((0, 0)),
                                 z(0, i64), z(0, i64), z(0), z(0), z(0, dtype=bool), z(0, dtype=bool), z(0, i64),
                                 z(2, i64), (z(0, i64), z(0, i64), z(0, i64), z(0, i64), z(0, dtype=bool)),
                                 (z(0, i64), z((0, 0), i64), z((0, 0, 8)), z(0), z(0, dtype=bool), z(3)),
                                 (0, z(1, i64), z(0, i64), z(1, i64), z(0, i64), z(1, i64), z(0, i64),
                                  z((0, 2), i64), z((0, 6, 6)), z(0, i64)))
            return self._no_tree
        if self._parts is not None:
            return self._parts  # PERF: once a step (prepare clears it): it was 10 us a solve, 8 solves a step
        limits = self._limit_columns()
        sc = self._scratch
        before = sc.get("before")
        if before is None or before.shape != (self.count, len(limits)):
            before = sc["before"] = np.zeros((self.count, len(limits)))
        self._parts = (limits, TREE_LIMIT_SWEEPS, LIMIT_TOLERANCE, self.node_order, self.node_joint, self.node_body,
                       self.node_parent, sc["Ja"], sc["Jb"], sc["C"], sc["nrow"], sc["D"], sc["Dinv"], sc["H_up"],
                       sc["W"], sc["y"], sc["sol"], sc["work"], before, self.joint_group, self.body_group,
                       *self._group_scratch, sc["node_skip"], sc["sub_order"],
                       np.zeros(len(self.sweep.bounds), dtype=np.int64), (*self.tree_layout, sc["no_skip"]),
                       sc["limit_rows"], self._groups_table)
        return self._parts

    def _limit_columns(self) -> np.ndarray:
        """The ``axial_impulse`` columns of the limit rows some joint has (empty: none)."""
        p = self.param
        columns = []
        # (the arrays' own any, not np.any's Python wrapper: asked at every step by tree_parts)
        if p.shape[0] and (p[:, P_LIMIT_ON] != 0.0).any():
            columns += [A_LOWER, A_UPPER]
        if p.shape[0] and (p[:, P_LIMIT2_ON] != 0.0).any():
            columns += [A_LOWER2, A_UPPER2]
        if self.has_gears:
            # a gear is a Gauss-Seidel row around the exact tree solve, as a limit is: sweep on while its
            # impulse changes
            columns.append(GEAR_COLUMN)
        return np.array(columns, dtype=np.int64)

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
        if self.has_armature():
            # the first substep of the next step resists from the flywheels' rates, not from those derived
            # again from the momenta at the new orientation (see first_substep_rates_kernel)
            flywheel_rates_kernel(self.param, self.enabled, self.axial_impulse, self.rate0, self.armature_rate)
            keep_armature_state_kernel(self.joint_a, self.joint_b, self.param, self.enabled, x, self.armature_state,
                                       self.armature_rate)
        broke = store_joints_kernel(self.joint_type, self.joint_a, self.joint_b, self.local_a, self.local_b,
                                    self.frame_a, self.frame_b, self.param, x, R, v, omega, 1.0 / self.h,
                                    self.linear_impulse, self.angular_impulse, self.axial_impulse,
                                    self.enabled, self.position, self.rate, self.reaction_force,
                                    self.reaction_torque, self.broke)
        if broke:
            for j in np.flatnonzero(self.broke):
                object.__setattr__(self._joints[j], "broken", True)  # the solver's own: not an edit
        return broke

    # -- queries -------------------------------------------------------------------------
    def index(self, joint) -> int:
        """Index of a joint given as its record, its name or an index."""
        j = self._row_of.get(id(joint))
        if j is not None and self._joints[j] is joint:
            return j
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
        universal joint's motor about axis_b (``motor_speed_b``); kept in the record too (its
        field and row), as an edit of that field: a motor that is off is switched on."""
        j = self.index(joint)
        setattr(self._joints[j], "motor_speed_b" if axis_b else "motor_speed", float(speed))
        self.param[j] = self._joints[j].bound.param

    def set_target(self, joint, target, velocity=None):
        """Change a drive's target between steps: rad or m for a hinge, slider or distance joint,
        a rotation (vector (3,) rad or quaternion (4,) w, x, y, z, in body_a's axes) for a ball
        joint (``BallJoint.target``) and its ``velocity`` (3,) rad/s (``target_velocity``; None:
        unchanged); kept in the joint's record too, so a checkpoint carries it."""
        j = self.index(joint)
        columns = set_record_target(self._joints[j], target, velocity)
        if self.joint_type[j] == JOINT_BALL:
            self.param[j, P_BALL_TARGET:P_BALL_TARGET + 7] = columns  # the quaternion, then P_BALL_RATE
        else:
            self.param[j, P_TARGET] = columns[0]
            if len(columns) > 1:  # a hinge's or slider's target velocity
                self.param[j, P_TARGET_RATE] = columns[1]

    def set_effort(self, joint, effort: float):
        """Set the torque (N m, a hinge) or force (N, a slider) a joint applies along its
        coordinate from the next step on (PyBullet's ``TORQUE_CONTROL``; MuJoCo's ``ctrl`` of a
        motor actuator); kept in the joint's record too, so a checkpoint carries it."""
        j = self.index(joint)
        self.param[j, P_EFFORT] = set_record_effort(self._joints[j], effort)
