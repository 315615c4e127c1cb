"""URDF robots move as their links' masses, inertias and joints say (tumble.urdf).

Each test writes a small URDF, loads it with ``tumble.urdf.load_urdf`` and compares the motion
with physics computed without tumble: Lagrange's equations of a planar hinge chain integrated by
DOP853 (``solutions.planar_chain_dop853``, from the numbers in the URDF text, not from what the
loader made of them), uniform acceleration along a slider, conservation of momentum. The
engine's joints step at first order (semi-implicit Euler with soft constraints: the error falls
4x when dt does), so the tolerances are the measured error at dt 1/240 s with a margin of about
2x, and the convergence is checked too: a wrong inertia, centre, origin or axis shifts the
motion by tens of milliradians within a second, which no tolerance here admits.
"""

import numpy as np
import pytest

import tumble as tb
from tumble.solver.contact import SoftStepSettings
from tumble.solver.joints import ACCURATE
from tumble.urdf import load_urdf

from .solutions import planar_chain_dop853

G = 9.81


def write(tmp_path, text, name="robot.urdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


# A two-link arm whose first link's inertia is turned by its inertial rpy (roll 0.3, off the hinge
# axis: its I_yy in the link frame is cos^2 0.3 Iyy + sin^2 0.3 Izz), its second link carrying a tip
# fixed 0.6 m down and 5 cm aside (merged into it, or held by a FixedJoint).
ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="world"/>
  <link name="upper">
    <inertial><origin xyz="0.1 0 -0.4" rpy="0.3 0 0"/><mass value="1.5"/>
      <inertia ixx="0.05" ixy="0" ixz="0" iyy="0.08" iyz="0" izz="0.04"/></inertial>
    <collision><origin xyz="0 0 -0.4"/><geometry><box size="0.1 0.1 0.8"/></geometry></collision>
  </link>
  <link name="lower">
    <inertial><origin xyz="0 0 -0.3"/><mass value="0.7"/><inertia ixx="0.03" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.004"/></inertial>
    <collision><origin xyz="0 0 -0.3"/><geometry><cylinder radius="0.04" length="0.6"/></geometry></collision>
  </link>
  <link name="tip">
    <inertial><mass value="0.4"/><inertia ixx="0.0004" ixy="0" ixz="0" iyy="0.0004" iyz="0" izz="0.0004"/></inertial>
    <collision><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute"><parent link="world"/><child link="upper"/>
    <origin xyz="0 0 2"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="50" velocity="5"/>
    <dynamics damping="DAMPING"/></joint>
  <joint name="elbow" type="continuous"><parent link="upper"/><child link="lower"/>
    <origin xyz="0 0 -0.8"/><axis xyz="0 1 0"/></joint>
  <joint name="wrist" type="fixed"><parent link="lower"/><child link="tip"/><origin xyz="0.05 0 -0.6"/></joint>
</robot>
"""


def arm_reference(theta0, duration, t_eval, damping=0.0):
    """The arm's motion from the URDF's numbers, by Lagrange's equations (not tumble)."""
    c, s = np.cos(0.3), np.sin(0.3)
    upper_Iyy = c * c * 0.08 + s * s * 0.04
    pieces = [(0, 1.5, (0.1, -0.4), upper_Iyy), (1, 0.7, (0.0, -0.3), 0.03), (1, 0.4, (0.05, -0.6), 0.0004)]
    return planar_chain_dop853(pieces, [(0.0, 2.0), (0.0, -0.8)], theta0, duration, t_eval,
                               damping=[damping, 0.0])


def run_arm(tmp_path, dt, theta0, duration=1.0, damping=0.0, merge_fixed=True, sample=0.05, joint_settings=None):
    world = tb.World(gravity=(0, 0, -G))
    path = write(tmp_path, ARM.replace("DAMPING", repr(damping)))
    robot = load_urdf(world, path, merge_fixed=merge_fixed,
                      joint_positions={"shoulder": theta0[0], "elbow": theta0[1]})
    sim = tb.Simulator(world, dt=dt, joint_settings=joint_settings)
    steps = int(round(sample / dt))
    t, q = [], []
    for _ in range(int(round(duration / sample))):
        sim.step(steps)
        t.append(world.t)
        states = robot.joint_states(sim)
        q.append([states["shoulder"][0], states["elbow"][0]])
    return robot, np.array(t), np.array(q)


@pytest.mark.parametrize("merge_fixed", [True, False])
def test_two_link_arm_swings_as_lagrange_equations_say(tmp_path, merge_fixed):
    # The exact tree solve (ACCURATE: rigid rows) converges at first order: measured (merged)
    # 1.8e-3 rad at dt 1/240, 4.4e-4 at 1/960. The default soft joints (Box2D's 60 Hz rows) keep
    # a compliance error that does not fall with dt: 1.5e-3 rad at 1/240, 4e-4 at 1/960 and
    # 1/3840. A mistake in the inertial rpy (Iyy 0.08 instead of 0.0789) or a lost parallel-axis
    # term moves the elbow by more than 1e-2 rad within the second.
    theta0 = (0.6, -0.4)
    errors = []
    for dt in (1 / 240, 1 / 960):
        robot, t, q = run_arm(tmp_path, dt, theta0, merge_fixed=merge_fixed, joint_settings=ACCURATE)
        _, ref = arm_reference(theta0, t[-1], t)
        errors.append(np.max(np.abs(q - ref)))
    assert errors[0] < 4e-3, errors
    assert errors[0] / errors[1] > 3.5, errors  # first order: 4x smaller at a quarter of dt
    _, t, q = run_arm(tmp_path, 1 / 240, theta0, merge_fixed=merge_fixed)
    assert np.max(np.abs(q - arm_reference(theta0, t[-1], t)[1])) < 3e-3
    assert len(robot.world.joints) == (2 if merge_fixed else 3)
    assert robot.links["tip"] is (robot.links["lower"] if merge_fixed else robot.links["tip"])


def test_joint_damping_slows_the_arm_as_lagrange_equations_say(tmp_path):
    # <dynamics damping="0.8"> on the shoulder: a viscous torque -0.8 q' (stiffness 0 drive);
    # the undamped and damped runs differ by ~0.1 rad, the damped one matches its reference.
    theta0 = (0.6, -0.4)
    _, t, q = run_arm(tmp_path, 1 / 480, theta0, damping=0.8)
    _, ref = arm_reference(theta0, t[-1], t, damping=0.8)
    _, undamped = arm_reference(theta0, t[-1], t)
    assert np.max(np.abs(q - ref)) < 3e-3
    assert np.max(np.abs(undamped - ref)) > 0.05


def test_merged_link_carries_the_combined_mass_properties(tmp_path):
    # parallel-axis theorem by hand: lower (0.7 kg at z -0.3) and tip (0.4 kg at (0.05, 0, -0.6))
    world = tb.World()
    robot = load_urdf(world, write(tmp_path, ARM.replace("DAMPING", "0")))
    lower = robot.links["lower"]
    m = 1.1
    c = (0.7 * np.array([0, 0, -0.3]) + 0.4 * np.array([0.05, 0, -0.6])) / m
    I = np.diag([0.03, 0.03, 0.004]) + np.diag([0.0004] * 3)
    for mi, ci in ((0.7, np.array([0, 0, -0.3])), (0.4, np.array([0.05, 0, -0.6]))):
        d = ci - c
        I = I + mi * (d @ d * np.eye(3) - np.outer(d, d))
    assert lower.mass == pytest.approx(m, rel=1e-15)
    np.testing.assert_allclose(world.com_offset[lower.index], c, atol=1e-15)
    np.testing.assert_allclose(world.inertia_body[lower.index], I, atol=1e-15)
    # the upper link's tensor turned by its rpy (roll 0.3 about x)
    upper = robot.links["upper"]
    Rx = np.array([[1, 0, 0], [0, np.cos(0.3), -np.sin(0.3)], [0, np.sin(0.3), np.cos(0.3)]])
    np.testing.assert_allclose(world.inertia_body[upper.index], Rx @ np.diag([0.05, 0.08, 0.04]) @ Rx.T, atol=1e-15)
    # the massless root link is a fixed body; the tip's sphere is a part of lower's compound
    assert world.fixed[robot.base.index]
    assert isinstance(lower.shape, tb.Compound) and len(lower.shape.parts) == 2


SLIDER = """<robot name="lift">
  <link name="rail"><collision><geometry><box size="0.05 0.05 2"/></geometry></collision></link>
  <link name="cart">
    <inertial><mass value="2"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
  </link>
  <joint name="slide" type="prismatic"><parent link="rail"/><child link="cart"/>
    <origin xyz="0 0 0.5" rpy="0 0.5 0"/><axis xyz="0 0 1"/><limit lower="-0.3" upper="0.8" effort="100"/>
    FRICTION</joint>
</robot>
"""


def test_prismatic_cart_slides_down_its_tilted_axis_to_the_lower_limit(tmp_path):
    # the axis is the child's z turned 0.5 rad about y: gravity along it is -g cos 0.5, so
    # s(t) = -g cos(0.5) t^2 / 2 until s = -0.3 (t = 0.264 s), then it rests on the limit. The
    # semi-implicit Euler substeps (h = dt / 4) fall ahead by a h t / 2 (1.1e-4 m at 0.1 s): the
    # tolerance is that first-order term plus 2e-5 m.
    world = tb.World(gravity=(0, 0, -G))
    robot = load_urdf(world, write(tmp_path, SLIDER.replace("FRICTION", "")), fixed_base=True)
    sim = tb.Simulator(world, dt=1 / 960)
    a = -G * np.cos(0.5)
    for k in range(1, 6):
        sim.step(48)  # 0.05 s
        s = robot.joint_states(sim)["slide"][0]
        h = sim.dt / SoftStepSettings().substeps
        assert s == pytest.approx(0.5 * a * world.t**2, abs=0.5 * abs(a) * h * world.t + 2e-5)
    sim.step(960)
    s, rate = robot.joint_states(sim)["slide"]
    assert s == pytest.approx(-0.3, abs=2e-3) and abs(rate) < 1e-3
    axis = np.array([np.sin(0.5), 0, np.cos(0.5)])
    # on the axis line, but for the soft joint's sag under the weight across it (3e-5 m measured)
    np.testing.assert_allclose(robot.links["cart"].x, (0, 0, 0.5) + s * axis, atol=1e-4)


def test_joint_friction_holds_below_its_limit_and_slips_above(tmp_path):
    # <dynamics friction="F">: a motor of speed 0 limited to F N. Gravity along the axis pulls
    # with m g cos 0.5 = 17.2 N: F = 20 holds the cart, F = 10 lets it go at (17.2 - 10) / m.
    world = tb.World(gravity=(0, 0, -G))
    pull = 2 * G * np.cos(0.5)
    for friction, expected in ((20.0, 0.0), (10.0, -(pull - 10.0) / 2)):
        world = tb.World(gravity=(0, 0, -G))
        text = SLIDER.replace("FRICTION", f'<dynamics friction="{friction}"/>')
        robot = load_urdf(world, write(tmp_path, text), fixed_base=True)
        sim = tb.Simulator(world, dt=1 / 960)
        sim.step(96)
        s = robot.joint_states(sim)["slide"][0]
        h = sim.dt / SoftStepSettings().substeps
        assert s == pytest.approx(0.5 * expected * world.t**2, abs=0.5 * abs(expected) * h * world.t + 2e-5)


FLOATING = """<robot name="tumbler">
  <link name="body">
    <inertial><origin xyz="0.02 0 0"/><mass value="3"/><inertia ixx="0.05" iyy="0.08" izz="0.1" ixy="0.01"/></inertial>
    <collision><geometry><box size="0.4 0.3 0.2"/></geometry></collision>
  </link>
  <link name="flap">
    <inertial><origin xyz="0.2 0 0"/><mass value="0.5"/><inertia ixx="0.001" iyy="0.007" izz="0.007"/></inertial>
    <collision><origin xyz="0.2 0 0"/><geometry><box size="0.4 0.1 0.02"/></geometry></collision>
  </link>
  <link name="antenna">
    <inertial><origin xyz="0 0 0.15"/><mass value="0.2"/><inertia ixx="0.002" iyy="0.002" izz="0.0001"/></inertial>
    <collision><origin xyz="0 0 0.15"/><geometry><capsule radius="0.01" length="0.3"/></geometry></collision>
  </link>
  <joint name="hinge" type="revolute"><parent link="body"/><child link="flap"/>
    <origin xyz="0.2 0 0.1"/><axis xyz="0 1 0"/><limit lower="-1" upper="1"/></joint>
  <joint name="slide" type="prismatic"><parent link="body"/><child link="antenna"/>
    <origin xyz="-0.1 0 0.1"/><axis xyz="0 0 1"/><limit lower="0" upper="0.1"/></joint>
</robot>
"""


def test_floating_robot_keeps_its_momentum_and_its_centre_falls_freely(tmp_path):
    # a free base (its root link has a mass), spun and thrown; the joints only pass forces
    # between the links: total P changes by m g t exactly, the centre of mass falls as the
    # substeps' semi-implicit Euler says (x0 + v0 t - g t (t + h) / 2, h = dt / 4: exact for
    # internal forces, to round-off), total L about the centre of mass is conserved up to the
    # joint solver's first-order error.
    world = tb.World(gravity=(0, 0, -G))
    robot = load_urdf(world, write(tmp_path, FLOATING), position=(0, 0, 5), euler_deg=(10, 20, 30),
                      joint_positions={"hinge": 0.4, "slide": 0.05})
    # a spin about the whole robot's centre, given as each body's velocity (rigid motion)
    m = world.mass
    com = (m[:, None] * world.x).sum(0) / m.sum()
    w = np.array([0.5, -1.5, 2.0])
    for i in range(world.body_count):
        world.body(i).v = np.array([1.0, 0.5, 2.0]) + np.cross(w, world.x[i] - com)
        world.body(i).omega = w

    def totals():
        c = (m[:, None] * world.x).sum(0) / m.sum()
        P = world.P.sum(0)
        L = sum(np.cross(world.x[i] - c, world.P[i]) + world.L[i] for i in range(world.body_count))
        return c, P, L

    c0, P0, L0 = totals()
    sim = tb.Simulator(world, dt=1 / 480)
    sim.step(960)
    c1, P1, L1 = totals()
    t = world.t
    assert robot.base is robot.links["body"] and not world.fixed.any()
    np.testing.assert_allclose(P1, P0 + m.sum() * np.array([0, 0, -G]) * t, atol=1e-10)
    h = sim.dt / SoftStepSettings().substeps
    np.testing.assert_allclose(c1, c0 + P0 / m.sum() * t - 0.5 * np.array([0, 0, G]) * t * (t + h), atol=1e-9)
    assert np.linalg.norm(L1 - L0) < 1e-3 * np.linalg.norm(L0)


PENDULUM = """<robot name="pendulum">
  <link name="world"/>
  <link name="arm">
    <inertial><origin xyz="0 0 -0.5"/><mass value="2"/><inertia ixx="0.2" iyy="0.2" izz="0.01"/></inertial>
    <collision><origin xyz="0 0 -0.5"/><geometry><cylinder radius="0.05" length="1"/></geometry></collision>
  </link>
  <joint name="swing" type="continuous"><parent link="world"/><child link="arm"/>
    <origin xyz="0 0 2"/><axis xyz="0 1 0"/></joint>
</robot>
"""


def test_position_target_holds_where_the_drive_balances_gravity(tmp_path):
    # joint_targets: a PD drive k (0.5 - theta) on a pendulum of m g d = 2 x 9.81 x 0.5 N m rests
    # where k (0.5 - theta) = m g d sin(theta) (k = 30: theta = 0.37901, by brentq). Sleeping off:
    # the arm creeps its last 2.4e-4 rad slower than the sleep tolerance (2 deg/s for 0.5 s,
    # Box2D's) and would fall asleep that far short (measured).
    from scipy.optimize import brentq

    k, mgd = 30.0, 2 * G * 0.5
    expected = brentq(lambda th: k * (0.5 - th) - mgd * np.sin(th), 0.0, 0.5)
    world = tb.World(gravity=(0, 0, -G))
    world.sleeping = False
    robot = load_urdf(world, write(tmp_path, PENDULUM),
                      joint_targets={"swing": {"position": 0.5, "stiffness": k, "damping": 6.0}})
    sim = tb.Simulator(world, dt=1 / 240)
    sim.step(240 * 8)
    theta, rate = robot.joint_states(sim)["swing"]
    assert theta == pytest.approx(expected, abs=1e-6) and abs(rate) < 1e-6


def test_capped_drive_swings_the_arm_under_its_constant_limit(tmp_path):
    # the same drive capped at max_force = 3 N m: the cap holds the whole drive torque, spring and
    # damper, so I theta'' = clamp(k (0.5 - theta) - c theta', -3, 3) - m g d sin(theta), with
    # I = 0.2 + 2 x 0.5^2 = 0.7 (DOP853; the clamp's kinks are passed by its step control). The
    # arm rises at the capped 3 N m, overshoots the balance point asin(3 / 9.81) = 0.311 where the
    # damper takes over, and settles at 0.379 where the uncapped drive would.
    # Measured 1.0e-3 rad at dt 1/240 s over 2 s (first order).
    from scipy.integrate import solve_ivp

    world = tb.World(gravity=(0, 0, -G))
    robot = load_urdf(world, write(tmp_path, PENDULUM), joint_targets={
        "swing": {"position": 0.5, "stiffness": 30.0, "damping": 6.0, "max_force": 3.0}})
    sim = tb.Simulator(world, dt=1 / 240)
    t, theta = [], []
    for _ in range(40):
        sim.step(12)
        t.append(world.t)
        theta.append(robot.joint_states(sim)["swing"][0])
    def f(_, y):
        drive = np.clip(30.0 * (0.5 - y[0]) - 6.0 * y[1], -3.0, 3.0)
        return [y[1], (drive - G * np.sin(y[0])) / 0.7]

    ref = solve_ivp(f, (0, t[-1]), [0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t).y[0]
    assert np.max(np.abs(np.array(theta) - ref)) < 3e-3  # measured 1.0e-3 at dt 1/240 s
    uncapped = solve_ivp(lambda _, y: [y[1], (30.0 * (0.5 - y[0]) - 6.0 * y[1] - G * np.sin(y[0])) / 0.7],
                         (0, t[-1]), [0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t).y[0]
    assert np.max(np.abs(uncapped - ref)) > 0.05  # the cap matters here


def test_a_struck_limit_stops_the_joint_dead_with_the_tree_solve(tmp_path):
    # The arm swings down from -1.5 rad onto a shoulder limit at 0 (at 2.7 rad/s) under the exact
    # tree solve (ACCURATE: rigid rows). A rigid limit is an inelastic stop: the shoulder's rate
    # is 0 from the strike on, to the sweeps' tolerance. With the limit rows swept only ACCURATE's two times around the tree
    # solve, 0.12 rad/s was left after the strike and 0.016 rad/s into the limit after that (a
    # 7-joint arm bounced back at 90 % of its 7.8 rad/s: benchmarks/urdf_robots.py); the solver now
    # sweeps on while a limit's impulse changes (``JointSolver.solve``, TREE_LIMIT_SWEEPS).
    world = tb.World(gravity=(0, 0, -G))
    path = write(tmp_path, ARM.replace("DAMPING", "0").replace('lower="-3" upper="3"', 'lower="-3" upper="0"'))
    robot = load_urdf(world, path, joint_positions={"shoulder": -1.5, "elbow": 0.0})
    sim = tb.Simulator(world, dt=1 / 240, joint_settings=ACCURATE)
    states = []
    for _ in range(200):
        sim.step(1)
        states.append(robot.joint_states(sim)["shoulder"])
    position, rate = np.array(states).T
    strike = int(np.argmax(position > -1e-3))
    assert rate[strike - 1] > 2.5  # it arrives fast
    # measured: at most 1.3e-3 rad/s after the strike (the sweeps stop at 1 % change), 5e-7 rad in
    assert np.all(np.abs(rate[strike:]) < 5e-3) and np.all(np.abs(position[strike:]) < 1e-4)


def test_joint_reaction_holds_the_arm_up(tmp_path):
    # the PD-held pendulum at rest (as above): the joint's force on the arm carries its weight,
    # (0, 0, m g) = (0, 0, 19.62) N, and its torque about the arm's centre balances the moment of that
    # force about the centre: tau = -(pivot - c) x F (statics of the arm, to the solver's rest)
    world = tb.World(gravity=(0, 0, -G))
    world.sleeping = False
    robot = load_urdf(world, write(tmp_path, PENDULUM),
                      joint_targets={"swing": {"position": 0.5, "stiffness": 30.0, "damping": 6.0}})
    sim = tb.Simulator(world, dt=1 / 240)
    sim.step(240 * 8)
    force, torque = robot.joint_reactions(sim)["swing"]
    np.testing.assert_allclose(force, (0, 0, 2 * G), atol=1e-6)
    arm = robot.links["arm"]
    np.testing.assert_allclose(torque, -np.cross(np.array([0, 0, 2.0]) - arm.x, force), atol=1e-4)
