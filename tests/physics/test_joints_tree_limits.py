"""The limits of a ball joint (its cone and its twist), of a universal joint's angles and of a rope
(a distance joint's lengths) solved through the joint tree with the tree method (``joint_tree.tree_limits_kernel``), as a hinge's and a slider's are: each row's mass is the
articulated bodies' (checked against the reduced coordinates' mass matrix), and a heap of ragdolls
loses energy and comes to rest (it did not: as Gauss-Seidel rows around the exact tree solve, a
head held on its neck's cone limit against the ground rocked with its energy rising)."""

import numpy as np
import pytest

import tumble as tb
from tumble.joints import BallJoint, DistanceJoint, HingeJoint, UniversalJoint
from tumble.scenes.ragdolls import ragdolls
from tumble.solver.joint_solve import A_LOWER2, A_UPPER2
from tumble.solver.joints import ACCURATE

G = 9.81
M_A, M_B = 2.0, 1.0  # kg: the arm hinged to the world, the rod on its ball joint


def arm_and_rod(case: str):
    """A 1 m box arm hinged to the world at (0, 0, 1) about y, held level by its hinge's upper
    limit; at its tip (1, 0, 1) a 1 m box rod on a ball joint whose axis is x (along the arm).
    "cone": the rod starts along x and falls onto its 45 deg cone (the swing row's axis is y);
    "twist": the rod starts along y (perpendicular to the axis, its weight a torque about x) and
    turns onto its twist limit of 30 deg; a weak drive (5 N m/rad, 5 N m s/rad toward the start:
    9.4 would hold the weight at the limit) keeps its swing at 0 (with the twist limit alone the
    rest on it is unstable: a swing and a twist together bring the rod down to hang);
    "universal": the rod starts along x on a universal joint (axis x in the arm, axis_b y in the
    rod) and falls about y onto its second angle's upper limit, 45 deg (the row's axis: the rod's y);
    "universal_first": the rod starts along y on that joint and falls about x onto its first
    angle's lower limit, -30 deg (the row's axis: the arm's x; the angle read in the chart centred
    on its limits, ``joint_solve._centred_angle``).
    The tree method, 1/240 s."""
    w = tb.World(gravity=(0.0, 0.0, -G))
    w.sleeping = False
    arm = w.add_body(tb.Box(size=(1.0, 0.1, 0.1)), mass=M_A, position=(0.5, 0, 1.0), name="arm")
    w.add_joint(HingeJoint("world", arm, anchor=(0, 0, 1.0), axis=(0, 1, 0), lower=-1.0, upper=0.0))
    if case == "cone":
        rod = w.add_body(tb.Box(size=(1.0, 0.1, 0.1)), mass=M_B, position=(1.5, 0, 1.0), name="rod")
        w.add_joint(BallJoint(arm, rod, anchor=(1.0, 0, 1.0), axis=(1, 0, 0), cone_limit=np.pi / 4))
    elif case == "universal":
        rod = w.add_body(tb.Box(size=(1.0, 0.1, 0.1)), mass=M_B, position=(1.5, 0, 1.0), name="rod")
        w.add_joint(UniversalJoint(arm, rod, anchor=(1.0, 0, 1.0), axis=(1, 0, 0), axis_b=(0, 1, 0),
                                   upper_b=np.pi / 4))
    elif case == "universal_first":
        rod = w.add_body(tb.Box(size=(0.1, 1.0, 0.1)), mass=M_B, position=(1.0, 0.5, 1.0), name="rod")
        w.add_joint(UniversalJoint(arm, rod, anchor=(1.0, 0, 1.0), axis=(1, 0, 0), axis_b=(0, 1, 0),
                                   lower=-np.pi / 6))
    else:
        rod = w.add_body(tb.Box(size=(0.1, 1.0, 0.1)), mass=M_B, position=(1.0, 0.5, 1.0), name="rod")
        w.add_joint(BallJoint(arm, rod, anchor=(1.0, 0, 1.0), axis=(1, 0, 0), twist_lower=-np.pi / 6,
                              twist_upper=np.pi / 6, stiffness=5.0, damping=5.0))
    return w, tb.Simulator(w, dt=1 / 240, joint_settings=ACCURATE)


def reduced_mass_matrix(w, anchor_hinge, anchor_ball, axis_hinge, relative_axes):
    """The (1 + k) x (1 + k) mass matrix of the generalized velocities u = (hinge rate, the rates
    about the rod's k relative axes, ``relative_axes`` (3, k) world: the ball's three, the identity;
    the universal joint's two), from the bodies' masses and world inertias: the arm turns at
    omega_A = u0 axis_hinge about the hinge, the rod at omega_B = omega_A + relative_axes u[1:] about
    the joint's anchor, which the arm carries. M = sum J^T diag(m, I) J over the two bodies."""
    arm, rod = 0, 1
    k = relative_axes.shape[1]
    jac = {}
    for i in (arm, rod):
        Jv = np.zeros((3, 1 + k))
        Jw = np.zeros((3, 1 + k))
        Jw[:, 0] = axis_hinge
        if i == arm:
            Jv[:, 0] = np.cross(axis_hinge, w.x[arm] - anchor_hinge)
        else:
            Jv[:, 0] = np.cross(axis_hinge, w.x[rod] - anchor_hinge)
            Jw[:, 1:] = relative_axes
            # omega_rel x (x_rod - anchor): the relative turn moves the rod's centre about the anchor
            r = w.x[rod] - anchor_ball
            Jv[:, 1:] = -np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]]) @ relative_axes
        jac[i] = (Jv, Jw)
    M = np.zeros((1 + k, 1 + k))
    for i, m in ((arm, M_A), (rod, M_B)):
        Jv, Jw = jac[i]
        I_world = w.R[i] @ w.inertia_body[i] @ w.R[i].T
        M += m * Jv.T @ Jv + Jw.T @ I_world @ Jw
    return M


@pytest.mark.parametrize("case", ["cone", "twist", "universal", "universal_first"])
def test_a_joints_limit_row_has_the_articulated_mass_behind_it(case):
    """Resting on its limit, the joint's limit row (omega_rod - omega_arm) . n has through the tree
    the mass 1 / (e^T M^-1 e) of the reduced coordinates (e picks the row's rate from the relative
    ones, e = (0, A^T n) with A the relative axes; M the arm-and-rod mass matrix at the pose, the
    hinge free: its limit is a row of its own). n from the pose, with the joint's axes fixed in each
    body: the ball's cone row unit(za x zb), its twist's (za + zb) / (1 + za . zb) (za, zb its axis,
    x at the start, in the arm and the rod: ``joint_solve._second_row``), the universal joint's
    first angle's the arm's x, its second's the rod's y. Tolerance: the cone's and the universal's
    rods rest (every rate under 1e-9 after 2 s, but the first universal rod's turn about its own
    axis, which leaves its world inertia as it is), 1e-9 relative for the rounding through the 6x6
    factors; the twist's creeps at under 1e-6 rad/s after 3 s (its drive's damping is a
    Gauss-Seidel row), 4e-9 rad a step, so 1e-7. The Gauss-Seidel row saw the two bodies alone with
    the anchor held (``_coupled_row_mass``). Fails on the code before: no such rows (the masses 0)."""
    w, sim = arm_and_rod(case)
    if case == "twist":
        sim.step(720)
        assert np.abs(w.omega).max() < 1e-6 and np.abs(w.v).max() < 1e-6
        assert sim.soft_step.joints.axial_impulse[1, A_LOWER2] > 0.0  # held by its lower twist limit
    elif case == "universal_first":
        sim.step(480)
        # at rest on the limit (about the arm's x: 1e-9), but for a turn about the rod's own long
        # axis (its axis_b), which nothing resists and the rod's symmetric inertia does not feel:
        # 6e-5 rad/s left from the strike (measured)
        assert abs((w.omega[1] - w.omega[0]) @ (w.R[0] @ [1.0, 0.0, 0.0])) < 1e-9
        assert np.abs(w.v).max() < 1e-9
    else:
        sim.step(480)
        assert np.abs(w.omega).max() < 1e-9 and np.abs(w.v).max() < 1e-9
        # on its limit (the soft push-out leaves 1e-5 rad past it, as a hinge's limit: docs/joints.md)
        if case == "cone":
            assert sim.joint_readings()["position"][1] == pytest.approx(np.pi / 4, abs=2e-5)
        elif case == "universal":
            assert sim.soft_step.joints.axial_impulse[1, A_UPPER2] > 0.0  # held by its upper limit
        else:
            assert sim.joint_readings()["position"][1] == pytest.approx(-np.pi / 6, abs=2e-5)
    arm, rod = 0, 1
    za, zb = w.R[arm] @ [1.0, 0.0, 0.0], w.R[rod] @ [1.0, 0.0, 0.0]
    axes = np.eye(3)
    if case == "cone":
        n = np.cross(za, zb) / np.linalg.norm(np.cross(za, zb))
    elif case == "twist":
        n = (za + zb) / (1.0 + za @ zb)
    else:
        yb = w.R[rod] @ [0.0, 1.0, 0.0]  # axis_b, fixed in the rod
        axes = np.column_stack([za, yb])  # the universal's two: axis in the arm, axis_b in the rod
        n = yb if case == "universal" else za
    anchor = w.x[arm] + w.R[arm] @ [0.5, 0.0, 0.0]  # the arm's tip, where it is now
    M = reduced_mass_matrix(w, np.array([0.0, 0.0, 1.0]), anchor, np.array([0.0, 1.0, 0.0]), axes)
    e = np.concatenate([[0.0], axes.T @ n])
    joints = sim.soft_step.joints
    row = 1 if case in ("cone", "universal_first") else joints.count + 1  # its first coordinate's row, or second's
    mass = joints._scratch["limit_rows"][3][row]
    assert mass == pytest.approx(1.0 / (e @ np.linalg.solve(M, e)), rel=1e-7 if case == "twist" else 1e-9)


def test_a_ropes_taut_row_has_the_articulated_mass_behind_it():
    """A 1 kg ball of radius 0.1 m hanging on a 0.5 m rope (``DistanceJoint(min_length=0,
    max_length=0.5)``) from the tip of the arm of ``arm_and_rod`` (hinged to the world, held level
    by its hinge's limit): at rest (rates under 1e-9 after 2 s) the taut end's row, u . (v_ball -
    v_tip) with u the rope's direction, has through the tree the mass 1 / (c^2 / I_hinge + 1 / m)
    of the reduced coordinates (the hinge angle, free: its limit is a row of its own; the ball's
    six), c = u . (y x (tip - hinge)) the tip's rate along u per unit hinge rate, I_hinge the arm's
    inertia about the hinge (from its mass and world inertia), to 1e-9 relative (rounding). The
    rope's slack and taut ends were Gauss-Seidel rows with the free bodies' masses before: the mass
    0 there (fails). A rigid distance joint's length stays a row of the tree itself."""
    w = tb.World(gravity=(0.0, 0.0, -G))
    w.sleeping = False
    arm = w.add_body(tb.Box(size=(1.0, 0.1, 0.1)), mass=M_A, position=(0.5, 0, 1.0), name="arm")
    w.add_joint(HingeJoint("world", arm, anchor=(0, 0, 1.0), axis=(0, 1, 0), lower=-1.0, upper=0.0))
    ball = w.add_body(tb.Sphere(0.1), mass=M_B, position=(1.0, 0, 0.5), name="ball")
    w.add_joint(DistanceJoint(arm, ball, anchor=(1.0, 0, 1.0), anchor_b=(1.0, 0, 0.5), min_length=0.0, max_length=0.5))
    sim = tb.Simulator(w, dt=1 / 240, joint_settings=ACCURATE)
    sim.step(480)
    assert np.abs(w.omega).max() < 1e-9 and np.abs(w.v).max() < 1e-9
    hinge, y = np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])
    tip = w.x[0] + w.R[0] @ [0.5, 0.0, 0.0]
    u = (w.x[1] - tip) / np.linalg.norm(w.x[1] - tip)
    offset = w.x[0] - hinge
    I_hinge = y @ (w.R[0] @ w.inertia_body[0] @ w.R[0].T) @ y + M_A * (offset @ offset - (offset @ y) ** 2)
    c = u @ np.cross(y, tip - hinge)
    mass = sim.soft_step.joints._scratch["limit_rows"][3][1]  # the rope's first coordinate's row
    assert mass == pytest.approx(1.0 / (c ** 2 / I_hinge + 1.0 / M_B), rel=1e-9)


def test_a_rigid_distance_joint_is_a_row_of_the_tree_not_two_limits():
    """The ball of the rope test on a rigid rod instead (``DistanceJoint`` without lengths: its
    limits' parameters both the length, as the rigid row reads them): the tree's own row holds the
    length, and no limit row acts beside it (their impulses 0, no response taken), where the two
    one-sided rows at one length would push against each other and the tree's row."""
    from tumble.solver.joint_solve import A_LOWER, A_UPPER

    w = tb.World(gravity=(0.0, 0.0, -G))
    w.sleeping = False
    arm = w.add_body(tb.Box(size=(1.0, 0.1, 0.1)), mass=M_A, position=(0.5, 0, 1.0), name="arm")
    w.add_joint(HingeJoint("world", arm, anchor=(0, 0, 1.0), axis=(0, 1, 0), lower=-1.0, upper=0.0))
    ball = w.add_body(tb.Sphere(0.1), mass=M_B, position=(1.0, 0, 0.5), name="ball")
    w.add_joint(DistanceJoint(arm, ball, anchor=(1.0, 0, 1.0), anchor_b=(1.0, 0, 0.5)))
    sim = tb.Simulator(w, dt=1 / 240, joint_settings=ACCURATE)
    sim.step(480)
    joints = sim.soft_step.joints
    assert joints.axial_impulse[1, A_LOWER] == 0.0 and joints.axial_impulse[1, A_UPPER] == 0.0
    assert not joints._scratch["limit_rows"][4][1]  # no response taken for its rows
    tip = w.x[0] + w.R[0] @ [0.5, 0.0, 0.0]
    assert np.linalg.norm(w.x[1] - tip) == pytest.approx(0.5, abs=1e-9)


def test_a_heap_of_ragdolls_on_the_tree_method_loses_energy_and_comes_to_rest():
    """Four ragdolls (tumble.scenes.ragdolls, seed 0: ball joints with cone and twist limits, hinges
    with limits) dropped into a heap, the tree method, 16 s at 1/60 s. Nothing drives them, so from
    6 s (landed) the energy (kinetic plus gravity's) may only fall: it never rises more than 0.01 J
    above its lowest so far (measured 7.5e-4 J, the soft contacts and limits settling; before, with
    the ball joints' limits as Gauss-Seidel rows, 0.58 J: a head on its neck's cone limit against
    the ground rocked, its energy rising from 0.03 J at 8 s to 0.24 J at 14 s), and at 16 s the
    kinetic energy is under 1e-3 J (measured 2.4e-4: heads turning slowly about the line through
    their neck and their point on the ground, which neither friction nor the joints resist, as in
    the Gauss-Seidel method; before, 0.23 J)."""
    w, _ = ragdolls(4, 0)
    sim = tb.Simulator(w, dt=1 / 60, joint_settings=ACCURATE)
    sim.step(6 * 60)
    energy = [w.kinetic_energy() + w.potential_energy()]
    for _ in range(10 * 60):
        sim.step()
        energy.append(w.kinetic_energy() + w.potential_energy())
    energy = np.array(energy)
    rise = np.max(energy - np.minimum.accumulate(energy))
    assert rise < 0.01, rise
    assert w.kinetic_energy() < 1e-3
