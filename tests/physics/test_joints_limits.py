"""Twist limits of ball joints; angle limits and motors of universal joints.

The twist is the angle of the swing-twist decomposition Q = Fa^T Fb = Q_swing Q_twist
(``tumble.solver.joints.twist_angle``); the limit rows are velocity-level rows with Box2D
v3's soft bias, as the hinge and cone limits, solved by Gauss-Seidel (also around the exact
tree solve of ``method="tree"``). Each test names what it compares with and why its
tolerance. Runs through the standalone stepper ``step_with_joints``, dt 1/240 s, 4 substeps,
with Box2D's settings (``JointSettings()``) and with ``ACCURATE`` (the tree method).
"""

import math

import numpy as np
import pytest

import tumble as tb
from tumble.joints import BallJoint, UniversalJoint
from tumble.solver.joints import ACCURATE, JointSettings, JointSolver, step_with_joints, twist_angle

DT = 1 / 240
SETTINGS = {"box2d": JointSettings(), "accurate": ACCURATE}


# ---------------------------------------------------------------------- helpers
def rot(axis, angle):
    """Rotation matrix (3, 3) about ``axis`` by ``angle`` rad (Rodrigues' formula)."""
    k = np.asarray(axis, dtype=float)
    k = k / np.linalg.norm(k)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * K @ K


def twist_of(Fa, Fb):
    """``twist_angle`` (rad) of frame b relative to frame a, each (3, 3), columns x, y, z."""
    return twist_angle(*[tuple(float(c) for c in F[:, k]) for F in (Fa, Fb) for k in range(3)])


def joint_frames(w, solver, j):
    """World joint frames (3, 3) of joint j fixed in body a and in body b."""
    a, b = solver.joint_a[j], solver.joint_b[j]
    Fa = (w.R[a] if a >= 0 else np.eye(3)) @ solver.frame_a[j]
    Fb = (w.R[b] if b >= 0 else np.eye(3)) @ solver.frame_b[j]
    return Fa, Fb


def universal_angles(Fa, Fb):
    """(angle, angle_b) rad of a universal joint from the entries of Q = Fa^T Fb =
    Rx(angle) Ry(angle_b): Q[:, 1] = (0, cos angle, sin angle), Q[0] = (cos angle_b, 0,
    sin angle_b). Written here from the definition, apart from the solver's code."""
    Q = Fa.T @ Fb
    return math.atan2(Q[2, 1], Q[1, 1]), math.atan2(Q[0, 2], Q[0, 0])


def run(w, seconds, settings, each=None, substeps=4):
    solver = JointSolver(settings)
    for _ in range(round(seconds / DT)):
        step_with_joints(w, solver, DT, substeps)
        if each is not None:
            each(solver)
    return solver


def twists(w, settings, seconds, joints=(0,)):
    """(steps, len(joints)) twist angles (rad) after each step."""
    out = []
    run(w, seconds, settings, lambda s: out.append([twist_of(*joint_frames(w, s, j)) for j in joints]))
    return np.array(out)


# ---------------------------------------------------------------------- the twist angle
def test_twist_angle_of_hand_built_rotations():
    # Compared with the angle each rotation was built with, in a random common frame P
    # (Fa = P, Fb = P Q): a pure twist about z (theta), a pure swing about an axis in the
    # xy-plane (0), a swing after a twist, Q = Q_swing Q_twist (theta: the decomposition's
    # definition); and with the quaternion formula 2 atan2(q_z, q_w) (wrapped to (-pi, pi])
    # of random rotations. 1e-12 rad: only rounding separates them, a few ulps of the dot
    # products divided by cos^2(swing / 2), so swings up to 170 deg (the twist is undefined
    # at 180). Measured worst error over these 200 cases: 1.6e-14 rad.
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(200):
        P = rot(rng.normal(size=3), rng.uniform(0.0, math.pi))
        theta = rng.uniform(-math.pi + 1e-6, math.pi - 1e-6)
        phi = rng.uniform(0.0, math.radians(170))
        psi = rng.uniform(0.0, 2.0 * math.pi)
        twist = rot((0.0, 0.0, 1.0), theta)
        swing = rot((math.cos(psi), math.sin(psi), 0.0), phi)
        worst = max(worst, abs(twist_of(P, P @ twist) - theta), abs(twist_of(P, P @ swing)),
                    abs(twist_of(P, P @ swing @ twist) - theta))
        qw, qx, qy, qz = rng.normal(size=4)
        n = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
        qw, qx, qy, qz = qw / n, qx / n, qy / n, qz / n
        if qw * qw + qz * qz < 0.5 * (1.0 + math.cos(math.radians(170))):
            continue  # swing beyond 170 deg: 1 + za.zb = 2 (qw^2 + qz^2)
        Q = np.array([[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qw * qz), 2 * (qx * qz + qw * qy)],
                      [2 * (qx * qy + qw * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qw * qx)],
                      [2 * (qx * qz - qw * qy), 2 * (qy * qz + qw * qx), 1 - 2 * (qx * qx + qy * qy)]])
        expected = 2.0 * math.atan2(qz, qw)
        expected -= 2.0 * math.pi * math.floor((expected + math.pi) / (2.0 * math.pi))
        worst = max(worst, abs(twist_of(P, P @ Q) - expected))
    assert worst < 1e-12
    # positive by the right-hand rule about the axis, as the hinge angle
    assert twist_of(np.eye(3), rot((0.0, 0.0, 1.0), 0.3)) == pytest.approx(0.3, abs=1e-15)


def test_limit_row_directions_give_the_rates_of_the_angles():
    # The limit rows act along n with angle rate = (omega_b - omega_a) . n: n = (za + zb) /
    # (1 + za . zb) for the twist, xa and yb for the universal joint's angles (the solver's
    # _second_row and _coordinate_row). Compared with the central difference of the angle
    # itself along a rotation of body b at a random angular velocity, from random poses (swing
    # up to 150 deg; universal poses Rx Ry with xa . yb = 0). Tolerance 1e-6 relative to
    # |omega|: the difference's truncation (step 1e-5 s, ~1e-10) and rounding (eps / 1e-5,
    # ~1e-11); measured 3.9e-10. A wrong direction (zb instead) is off by up to 2.1.
    from tumble.joints import JOINT_BALL, JOINT_UNIVERSAL
    from tumble.solver.joint_solve import _coordinate_row, _second_row

    rng = np.random.default_rng(3)
    frame = np.eye(3)[None].copy()
    local = np.zeros((1, 3))
    step = 1e-5
    worst = 0.0
    for _ in range(100):
        Ra = rot(rng.normal(size=3), rng.uniform(0.0, math.pi))
        omega_b = rng.normal(size=3)
        for kind in ("ball", "universal"):
            if kind == "ball":
                swing_axis = (math.cos(rng.uniform(0, 6.3)), math.sin(rng.uniform(0, 6.3)), 0.0)
                Q = rot(swing_axis, rng.uniform(0.0, math.radians(150))) @ rot((0, 0, 1), rng.uniform(-3.0, 3.0))
            else:
                Q = rot((1, 0, 0), rng.uniform(-3.0, 3.0)) @ rot((0, 1, 0), rng.uniform(-3.0, 3.0))
            Rb = Ra @ Q

            def angles(Rb_now):
                if kind == "ball":
                    return [twist_of(Ra, Rb_now)]
                return list(universal_angles(Ra, Rb_now))

            R = np.stack([Ra, Rb])
            if kind == "ball":
                _has, n2, _pos = _second_row(JOINT_BALL, 0, 0, 1, R, frame, frame)
                directions = [np.array(n2)]
            else:
                row = _coordinate_row(JOINT_UNIVERSAL, 0, 0, 1, np.zeros((2, 3)), R, local, local, frame, frame,
                                      np.zeros(1))
                _has, n2, _pos = _second_row(JOINT_UNIVERSAL, 0, 0, 1, R, frame, frame)
                directions = [np.array(row[2]), np.array(n2)]
            plus = angles(rot(omega_b, step * np.linalg.norm(omega_b)) @ Rb)
            minus = angles(rot(omega_b, -step * np.linalg.norm(omega_b)) @ Rb)
            for n, p_, m_ in zip(directions, plus, minus):
                rate = (p_ - m_) / (2 * step)
                worst = max(worst, abs(rate - n @ omega_b) / np.linalg.norm(omega_b))
    assert worst < 1e-6


# ---------------------------------------------------------------------- ball joint: twist limit
def _spinning_box(omega, free):
    """(world, other, box): no gravity; a box (0.1 x 0.2 x 0.3 m, 1 kg) centred 0.5 m below the
    origin, turning at ``omega`` rad/s about the origin (its v = omega x r); ``other`` is "world",
    or with ``free`` a 2 kg cube of 0.2 m centred 0.3 m above the origin."""
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    other = "world"
    if free:
        other = w.add_body(tb.Box((0.2, 0.2, 0.2)), mass=2.0, position=(0.0, 0.0, 0.3), name="top")
    b = w.add_body(tb.Box((0.1, 0.2, 0.3)), mass=1.0, position=(0.0, 0.0, -0.5), name="box")
    b.omega = omega
    b.v = tuple(np.cross(omega, (0.0, 0.0, -0.5)))
    return w, other, b


def spun_box(twist_limit, omega, free=False):
    """A box (0.1 x 0.2 x 0.3 m, 1 kg) 0.5 m below a ball joint (cone and twist axis z, cone
    0.5 rad), no gravity, spun at ``omega`` rad/s; twist limits +-0.5 rad or none. ``free``:
    the joint's other body is a free 2 kg cube above the joint instead of the world."""
    w, other, b = _spinning_box(omega, free)
    lo, hi = (-0.5, 0.5) if twist_limit else (None, None)
    w.add_joint(BallJoint(other, b, anchor=(0, 0, 0), axis=(0, 0, 1), cone_limit=0.5, twist_lower=lo, twist_upper=hi))
    return w


@pytest.mark.parametrize("name", ["box2d", "accurate"])
@pytest.mark.parametrize("free", [False, True])
def test_twist_limit_stops_a_box_spun_about_the_twist_axis(name, free):
    # Compared with the limit (0.5 rad) and with the same box without it. Spun at 5 rad/s
    # about the twist axis, the box reaches 0.5 rad after 0.1 s and stops there (the limit is
    # inelastic, as Box2D's). The speculative row (bias C/h while apart) stops it at the limit
    # to rounding: measured overshoot 1e-15 rad, both settings, to the world or to a free
    # body. Bound 1e-9 rad, far below any soft-constraint allowance: a row that let the twist
    # run on by one substep would overshoot by 5 rad/s x h = 5e-3 rad. Without the limit the
    # twist runs through +-pi (max |twist| 3.137 rad).
    with_limit = twists(spun_box(True, (0.0, 0.0, 5.0), free), SETTINGS[name], 1.0)
    without = twists(spun_box(False, (0.0, 0.0, 5.0), free), SETTINGS[name], 1.0)
    assert with_limit.max() <= 0.5 + 1e-9
    assert with_limit[-1, 0] == pytest.approx(0.5, abs=1e-6)
    assert np.abs(without).max() > 3.0


@pytest.mark.parametrize("name, bound", [("box2d", 1e-2), ("accurate", 1e-3)])
def test_twist_limits_hold_in_a_chain_thrown_spinning_under_gravity(name, bound):
    # Compared with the limits (+-0.3 rad) and with the same chain without them. Three boxes
    # (0.1 x 0.2 x 0.4 m, 1 kg) hang from the world on ball joints (cone 0.6 rad, twist
    # +-0.3 rad); the lowest is thrown at 1 m/s sideways spinning at 20 rad/s about its long
    # axis and (3 rad/s) across it, so cone and twist limits and the swing all act together,
    # 3 s under gravity. Here the rows of three joints fight in one Gauss-Seidel sweep and the
    # soft rows let the twist past its limit a little: measured worst overshoot 6.1e-3 rad with
    # Box2D's settings (the middle joint), 2.1e-4 rad with ACCURATE; bounds 1e-2 and 1e-3 rad
    # (about 1.5x and 5x). Without the limits the lowest joint twists by 2.8 rad past 0.3.
    def chain(limit):
        w = tb.World(gravity=(0.0, 0.0, -9.81))
        prev = "world"
        for i in range(3):
            b = w.add_body(tb.Box((0.1, 0.2, 0.4)), mass=1.0, position=(0.0, 0.0, -0.2 - 0.4 * i), name=f"l{i}")
            lo, hi = (-0.3, 0.3) if limit else (None, None)
            w.add_joint(BallJoint(prev, b, anchor=(0.0, 0.0, -0.4 * i), axis=(0, 0, 1), cone_limit=0.6,
                                  twist_lower=lo, twist_upper=hi))
            prev = b
        b.omega = (3.0, 0.0, 20.0)
        b.v = (1.0, 0.0, 0.0)
        return w

    with_limit = twists(chain(True), SETTINGS[name], 3.0, joints=(0, 1, 2))
    without = twists(chain(False), SETTINGS[name], 3.0, joints=(0, 1, 2))
    assert np.abs(with_limit).max() - 0.3 < bound
    assert np.abs(without).max() - 0.3 > 1.0


@pytest.mark.parametrize("name", ["box2d", "accurate"])
def test_one_sided_twist_limit_stops_at_minus_pi_on_the_other_side(name):
    # Compared with -pi (a twist limit left out is -pi or pi: the twist lives in (-pi, pi])
    # and with the kinetic energy at the start. Only twist_upper = 0.5 rad; the box spun the
    # other way at 5 rad/s twists down to -pi and stops there instead of jumping to +pi, which
    # the upper limit would read as a violation of 2.6 rad and push on (the rows see the angle
    # in a chart centred on the middle of the limits). Measured: rests at -pi exactly (both
    # settings), never past it (it would read near +pi), and the energy only falls (by the
    # stop). Bounds: 1e-3 rad from -pi, energy never above the start by 1e-9 relative.
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    b = w.add_body(tb.Box((0.1, 0.2, 0.3)), mass=1.0, position=(0.0, 0.0, -0.5), name="box")
    b.omega = (0.0, 0.0, -5.0)
    w.add_joint(BallJoint("world", b, anchor=(0, 0, 0), axis=(0, 0, 1), twist_upper=0.5))
    w.update_derived()
    E0 = w.kinetic_energy()
    seen, energy = [], []
    run(w, 2.0, SETTINGS[name], lambda s: (seen.append(twist_of(*joint_frames(w, s, 0))),
                                          energy.append(w.kinetic_energy())))
    seen = np.array(seen)
    assert max(energy) <= E0 * (1 + 1e-9)
    assert abs(abs(seen[-1]) - math.pi) < 1e-3
    assert seen.max() <= 0.5  # it never came round to the upper limit from above


@pytest.mark.parametrize("name", ["box2d", "accurate"])
def test_twist_limit_does_not_restrict_swing(name):
    # Compared with the same pendulum without the twist limit. A box (0.1 x 0.1 x 0.3 m, 1 kg)
    # hangs 1 m below a ball joint (cone axis down, cone 60 deg) and is started swinging at
    # 1.5 rad/s about a horizontal axis 0.5 rad off the frame's x axis (amplitude about
    # 28 deg, within the cone): a plane pendulum, no twist motion (measured |twist| < 1e-14
    # rad). With a twist limit of [-0.1, 0.1] rad the period is the same: measured difference
    # 0 (the limit rows never push). Bound 1e-9 relative: any push of the limit rows (which a
    # twist measured with the swing in it, up to 0.5 rad here, would cause) changes the period
    # by far more. Both also match the physical pendulum's period, T0 (1 + a^2/16 + 11 a^4/3072)
    # with T0 = 2 pi sqrt(I / (m g l)) and amplitude a from the energy: measured 1.3e-5
    # (Box2D's settings) and 3.3e-6 (ACCURATE; the series' next term is 3e-6 at 28 deg),
    # bound 1e-3.
    u = np.array([math.cos(0.5), math.sin(0.5), 0.0])
    side = np.cross((0.0, 0.0, 1.0), u)  # the direction the bob swings along

    def period(limit):
        w = tb.World(gravity=(0.0, 0.0, -9.81))
        b = w.add_body(tb.Box((0.1, 0.1, 0.3)), mass=1.0, position=(0.0, 0.0, -1.0), name="bob")
        b.omega = tuple(1.5 * u)
        b.v = tuple(np.cross(1.5 * u, (0.0, 0.0, -1.0)))
        lo, hi = (-0.1, 0.1) if limit else (None, None)
        w.add_joint(BallJoint("world", b, anchor=(0, 0, 0), axis=(0, 0, -1), cone_limit=math.radians(60),
                              twist_lower=lo, twist_upper=hi))
        xs, tw = [], []
        run(w, 6.0, SETTINGS[name], lambda s: (xs.append(float(w.x[0] @ side)),
                                              tw.append(twist_of(*joint_frames(w, s, 0)))))
        d = np.array(xs)
        i = np.flatnonzero((d[:-1] < 0) & (d[1:] >= 0))
        crossings = i + d[i] / (d[i] - d[i + 1])  # linear interpolation between steps
        return float(np.mean(np.diff(crossings)) * DT), float(np.abs(tw).max()), float(np.abs(d).max())

    limited, twist_seen, reach = period(True)
    free, _, _ = period(False)
    assert reach > 0.4  # it does swing (about 0.47 m to the side)
    assert twist_seen < 1e-10
    assert limited == pytest.approx(free, rel=1e-9)
    inertia = 1.0 + (0.1**2 + 0.3**2) / 12.0  # about the pivot, kg m^2
    amplitude = math.acos(1.0 - 0.5 * inertia * 1.5**2 / 9.81)
    expected = 2 * math.pi * math.sqrt(inertia / 9.81) * (1 + amplitude**2 / 16 + 11 * amplitude**4 / 3072)
    assert limited == pytest.approx(expected, rel=1e-3)


# ---------------------------------------------------------------------- universal joint
LIMITS = {"lower": -0.4, "upper": 0.3, "lower_b": -0.2, "upper_b": 0.5}


def universal_box(omega, limits=True, free=False, **extra):
    """A box (0.1 x 0.2 x 0.3 m, 1 kg) 0.5 m below a universal joint (axis x in the world or
    the free cube above, axis_b y in the box), no gravity, spun at ``omega`` rad/s."""
    w, other, b = _spinning_box(omega, free)
    w.add_joint(UniversalJoint(other, b, anchor=(0, 0, 0), axis=(1, 0, 0), axis_b=(0, 1, 0),
                               **(LIMITS if limits else {}), **extra))
    return w


@pytest.mark.parametrize("name", ["box2d", "accurate"])
@pytest.mark.parametrize("omega, which, bound", [
    ((4.0, 0.0, 0.0), 0, "upper"), ((-4.0, 0.0, 0.0), 0, "lower"),
    ((0.0, 4.0, 0.0), 1, "upper_b"), ((0.0, -4.0, 0.0), 1, "lower_b"),
])
def test_universal_joint_angles_stop_at_their_limits(name, omega, which, bound):
    # Compared with each limit (angle in [-0.4, 0.3], angle_b in [-0.2, 0.5] rad) and with the
    # same box without limits. Spun at 4 rad/s about one of the joint's axes, the box turns
    # until that angle reaches its limit and stops; the other angle stays 0. The angles are
    # computed here from Q = Fa^T Fb. Measured: never past the limit by more than 1e-16 rad
    # (both settings); bound 1e-9 rad (as the twist limit's: a one-substep overshoot would be
    # 4 rad/s x h = 4e-3 rad). At the end it rests within 8.5e-6 rad of the limit (Box2D's
    # soft rows push it back a little after the stop; ACCURATE 1e-16), bound 1e-4. The other
    # angle stays 0 (bound 1e-9 rad). Without limits the angle passes the limit by > 0.5 rad.
    def angles(limits):
        w = universal_box(omega, limits)
        out = []
        s = run(w, 1.0, SETTINGS[name], lambda s: out.append(universal_angles(*joint_frames(w, s, 0))
                                                             + (float(s.position[0]),)))
        return np.array(out), s

    A, solver = angles(True)
    free, _ = angles(False)
    limit = LIMITS[bound]
    sign = 1.0 if bound.startswith("upper") else -1.0
    assert (sign * (A[:, which] - limit)).max() <= 1e-9
    assert A[-1, which] == pytest.approx(limit, abs=1e-4)
    assert np.abs(A[:, 1 - which]).max() < 1e-9
    assert (sign * (free[:, which] - limit)).max() > 0.5
    # the reading ``position`` of a universal joint is its angle about ``axis``
    np.testing.assert_allclose(A[:, 2], A[:, 0], atol=1e-12)


@pytest.mark.parametrize("name, bound", [("box2d", 3e-3), ("accurate", 1e-3)])
def test_universal_joint_limits_hold_when_both_act(name, bound):
    # Compared with the limits. The box is spun about a skew axis (3, -3, 1) rad/s, so both
    # angles run into their limits while the box also twists about the joint's third axis
    # (which the joint's rigid row stops). Measured worst excursion past a limit: 1.5e-3 rad
    # with Box2D's settings (the soft rows of one sweep), 1.1e-16 with ACCURATE; bounds 3e-3
    # and 1e-3 rad.
    w = universal_box((3.0, -3.0, 1.0))
    out = []
    run(w, 1.0, SETTINGS[name], lambda s: out.append(universal_angles(*joint_frames(w, s, 0))))
    A = np.array(out)
    past = max((A[:, 0] - LIMITS["upper"]).max(), (LIMITS["lower"] - A[:, 0]).max(),
               (A[:, 1] - LIMITS["upper_b"]).max(), (LIMITS["lower_b"] - A[:, 1]).max())
    assert past < bound


def test_universal_joint_motors_drive_both_angles():
    # Compared with the motors' target rates (1 and -2 rad/s), ACCURATE settings (the rigid
    # rows; the soft rows are tested in tests/physics/test_joints_stability.py). Each
    # motor holds its rate to within 0.2 % at 0.5 s (measured 0.9988 and -1.999999 rad/s by
    # differencing the angles over one step, 1.0013 in the rate reading): the two motor rows and
    # the joint's rigid rows are coupled through the box's inertia about the anchor and two
    # Gauss-Seidel sweeps leave that residual. Bound 1 % (the hinge motor test's).
    w = universal_box((0.0, 0.0, 0.0), limits=False, motor_speed=1.0, motor_speed_b=-2.0,
                      max_motor_torque=5.0, max_motor_torque_b=5.0)
    out = []
    solver = run(w, 0.5, ACCURATE, lambda s: out.append(universal_angles(*joint_frames(w, s, 0))))
    rates = np.diff(np.array(out), axis=0) / DT
    assert rates[-1, 0] == pytest.approx(1.0, rel=0.01)
    assert rates[-1, 1] == pytest.approx(-2.0, rel=0.01)
    assert solver.readings(0)["rate"] == pytest.approx(1.0, rel=0.01)
    # a new target between steps, for axis_b
    solver.set_motor_speed(0, 1.0, axis_b=True)
    out.clear()
    for _ in range(120):
        step_with_joints(w, solver, DT, 4)
        out.append(universal_angles(*joint_frames(w, solver, 0)))
    rates = np.diff(np.array(out), axis=0) / DT
    assert rates[-1, 1] == pytest.approx(1.0, rel=0.01)


# ---------------------------------------------------------------------- momentum and energy
def angular_momentum(w):
    """Total angular momentum (3,) kg m^2/s about the origin from v, omega (not the stored L)."""
    m = w.moving
    I_world = w.R[m] @ w.inertia_body[m] @ np.transpose(w.R[m], (0, 2, 1))
    spin = np.einsum("nij,nj->ni", I_world, w.omega[m])
    return (spin + w.mass[m, None] * np.cross(w.x[m], w.v[m])).sum(axis=0)


def two_free_bodies(kind):
    """A 2 kg box and a 1 kg box, no world anchor, no gravity, joined at the origin by a
    ball joint (cone 0.4 rad, twist +-0.3 rad) or a universal joint (limits as above), spun
    against each other so that the limits are hit (and joint velocities made consistent)."""
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    top = w.add_body(tb.Box((0.2, 0.3, 0.2)), mass=2.0, position=(0.0, 0.0, 0.3), name="top")
    low = w.add_body(tb.Box((0.1, 0.2, 0.4)), mass=1.0, position=(0.0, 0.0, -0.2), name="low")
    if kind == "ball":
        w.add_joint(BallJoint(top, low, anchor=(0, 0, 0), axis=(0, 0, 1), cone_limit=0.4, twist_lower=-0.3,
                              twist_upper=0.3))
    else:
        w.add_joint(UniversalJoint(top, low, anchor=(0, 0, 0), axis=(1, 0, 0), axis_b=(0, 1, 0), **LIMITS))
    top.omega = (-1.0, 0.5, -2.0)
    top.v = tuple(np.cross((-1.0, 0.5, -2.0), (0.0, 0.0, 0.3)))
    low.omega = (3.0, -2.0, 6.0)
    low.v = tuple(np.cross((3.0, -2.0, 6.0), (0.0, 0.0, -0.2)))
    return w


@pytest.mark.parametrize("name", ["box2d", "accurate"])
@pytest.mark.parametrize("kind", ["ball", "universal"])
def test_limit_impulses_are_internal(name, kind):
    # Compared with the total angular momentum before each joint stage (warm start + biased
    # solve, and the relax solve) of every substep, the same substeps as step_with_joints.
    # Two free bodies, no world anchor, no gravity; the limits act (checked). The angular rows
    # (limits, the universal joint's rigid row) are equal and opposite couples; the anchor
    # rows are equal and opposite forces at the two anchor points, whose gap (soft rows: up to
    # ~1e-4 m) gives a moment gap x impulse: that is the only change. Measured largest change
    # of L in one stage, relative to |L0|: ball 5.6e-6 / 7.2e-7, universal 2.2e-6 / 4.2e-7
    # (Box2D's settings / ACCURATE); bound 1e-4. (The whole run's momentum also moves by the
    # implicit gyroscopic step of the integrator: 2e-3 over 2 s for the same boxes with no
    # joint at all; not the joints' doing, not tested here.) The limits are inelastic: the
    # kinetic energy after 2 s is below its start (measured 0.66 E0).
    from tumble.solver.joints import integrate_positions_kernel, integrate_velocities_kernel

    w = two_free_bodies(kind)
    solver = JointSolver(SETTINGS[name])
    w.update_derived()
    L0 = np.linalg.norm(angular_momentum(w))
    E0 = w.kinetic_energy()
    worst = 0.0
    acted = 0.0
    h = DT / 4
    v, omega, x, q, R, I_inv = w.v, w.omega, w.x, w.q, w.R, w.I_inv
    for _ in range(480):
        solver.prepare(w, h)
        for _sub in range(4):
            integrate_velocities_kernel(w.moving, w.inv_mass, I_inv, R, w.inertia_body, w.force, w.torque, h, v, omega)
            before = angular_momentum(w)
            solver.warm_start(v, omega, x, R)
            solver.solve(v, omega, x, R, True)
            worst = max(worst, float(np.linalg.norm(angular_momentum(w) - before)))
            integrate_positions_kernel(w.moving, v, omega, h, w.inertia_body_inv, x, q, R, I_inv)
            before = angular_momentum(w)
            solver.solve(v, omega, x, R, False)
            worst = max(worst, float(np.linalg.norm(angular_momentum(w) - before)))
            acted = max(acted, float(np.abs(solver.axial_impulse[0, 2:8]).max()))
        solver.store(v, omega, x, R)
    w.P[:] = w.mass[:, None] * v
    w.L[:] = np.einsum("nij,nj->ni", R @ w.inertia_body @ np.transpose(R, (0, 2, 1)), omega)
    assert acted > 0.0
    assert worst / L0 < 1e-4
    assert w.kinetic_energy() < E0


# ---------------------------------------------------------------------- scene files
SCENE = """
[simulation]
duration = 1.0
frame_rate = 60
dt = 0.004166666666666667
substeps = 4
gravity = [0, 0, 0]

[[bodies]]
name = "arm"
shape = { type = "box", size = [0.1, 0.2, 0.3] }
mass = 1.0
position = [0, 0, -0.5]
angular_velocity = [0, 0, 5]

[[bodies]]
name = "leg"
shape = { type = "box", size = [0.1, 0.2, 0.3] }
mass = 1.0
position = [2, 0, -0.5]
velocity = [0, 2, 0]            # omega x (centre - anchor): turning about the hip
angular_velocity = [4, 0, 0]

[[joints]]
type = "ball"
name = "shoulder"
body_a = "world"
body_b = "arm"
anchor = [0, 0, 0]
axis = [0, 0, 1]
cone_limit_deg = 30
twist_lower_deg = -20
twist_upper_deg = 20

[[joints]]
type = "universal"
name = "hip"
body_a = "world"
body_b = "leg"
anchor = [2, 0, 0]
axis = [1, 0, 0]
axis_b = [0, 1, 0]
lower_deg = -10
upper_deg = 15
lower_b_deg = -30
upper_b_deg = 30
"""


def test_scene_file_keys_reach_the_simulator(tmp_path):
    # Compared with the limits given in degrees in the scene file, through tumble.load_scene
    # and the Simulator's soft step (contacts and joints, Box2D's settings). The arm spins at
    # 5 rad/s about the twist axis into its 20 deg twist limit, the leg at 4 rad/s about the
    # hip's axis into its 15 deg limit; both stop there. Measured: the twist stops at 20 deg
    # exactly (0 past it); the hip never passes 15 deg and rests 3.2e-5 rad below it (the
    # soft rows push back a little). Bounds: 1e-6 rad past a limit, 1e-4 rad from it at the end.
    path = tmp_path / "limits.toml"
    path.write_text(SCENE)
    scene = tb.load_scene(path)
    records = scene.world.joints
    assert records[0].twist_lower == pytest.approx(math.radians(-20))
    assert records[1].upper == pytest.approx(math.radians(15)) and records[1].lower_b == pytest.approx(math.radians(-30))
    sim = scene.simulator()
    w = scene.world
    twist, hip = [], []
    for _ in range(120):
        sim.step()
        solver = sim.soft_step.joints
        twist.append(twist_of(*joint_frames(w, solver, 0)))
        hip.append(universal_angles(*joint_frames(w, solver, 1))[0])
    assert max(twist) <= math.radians(20) + 1e-6
    assert twist[-1] == pytest.approx(math.radians(20), abs=1e-4)
    assert max(hip) <= math.radians(15) + 1e-6
    assert hip[-1] == pytest.approx(math.radians(15), abs=1e-4)
    # the universal joint's position reading is its angle about axis
    assert sim.joint_readings()["position"][1] == pytest.approx(hip[-1], abs=1e-12)
