"""Gear joints (``tb.GearJoint``: q_joint = p(q_follows), URDF's mimic, MuJoCo's joint equality,
Box2D v2's gear) against the reduced systems they make: a coupled pair of coordinates is one
degree of freedom whose inertia is the gear's effective one, so closed forms (constant
effort) and SciPy's DOP853 of the reduced equation (a pendulum geared to a flywheel) give the
motion without tumble."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import tumble as tb
from tumble import checks
from tumble.errors import InputError
from tumble.solver.joints import ACCURATE, JointSettings, JointSolver, step_with_joints

from .solutions import resumed_run

DT = 1 / 240
RIGID_GS = JointSettings(hertz=0.0)  # rigid rows, Gauss-Seidel (no tree)
METHODS = {"gauss-seidel rigid": RIGID_GS, "tree": ACCURATE}


def gear_pair(ratio=-2.0, torque=0.5, settings=None, offset=0.0):
    """Two wheels on vertical hinges to the world, 0.6 m apart (they do not touch), no gravity: a
    torque on the first (cylinder r 0.1 m, 2 kg: I1 = 0.01 kg m^2), the second (r 0.2 m, 2 kg:
    I2 = 0.04) geared to it, q2 = offset + ratio q1."""
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    g1 = w.add_body(tb.Cylinder(0.1, 0.05), mass=2.0, position=(0.0, 0.0, 1.0), name="pinion")
    g2 = w.add_body(tb.Cylinder(0.2, 0.05), mass=2.0, position=(0.6, 0.0, 1.0), name="wheel")
    w.add_joint(tb.HingeJoint("world", g1, anchor=(0.0, 0.0, 1.0), axis=(0.0, 0.0, 1.0), torque=torque, name="a1"))
    w.add_joint(tb.HingeJoint("world", g2, anchor=(0.6, 0.0, 1.0), axis=(0.0, 0.0, 1.0), name="a2"))
    w.add_joint(tb.GearJoint(joint="a2", follows="a1", ratio=ratio, offset=offset, name="gear"))
    return w


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("path", ["simulator", "standalone"])
@pytest.mark.parametrize("ratio", [-2.0, 0.5, 3.0])
def test_a_gear_pair_spins_up_with_the_reduced_inertia(method, path, ratio):
    # Compared with the closed form of the one degree of freedom left: q2 = r q1, so the kinetic
    # energy is (I1 + r^2 I2) q1'^2 / 2 and a torque tau on q1 gives q1'' = tau / (I1 + r^2 I2).
    # A constant acceleration about principal axes is integrated exactly by the semi-implicit
    # substeps, so the rates are equal to rounding (1e-9 relative); the rigid gear row holds
    # q2 - r q1 to 1e-9 rad. Fails with the sign of joint 2's part of the row wrong (checked: the
    # pair blows up, NaN within the second).
    tau, I1, I2 = 0.5, 0.01, 0.04
    w = gear_pair(ratio, tau)
    settings = METHODS[method]
    if path == "simulator":
        sim = tb.Simulator(w, dt=DT, joint_settings=settings)
        sim.step(240)
        r = sim.joint_readings()
    else:
        solver = JointSolver(settings)
        for _ in range(240):
            step_with_joints(w, solver, DT, 4)
        r = solver.readings()
    alpha = tau / (I1 + ratio**2 * I2)
    assert r["rate"][0] == pytest.approx(alpha * 1.0, rel=1e-9)
    assert r["rate"][1] == pytest.approx(ratio * alpha * 1.0, rel=1e-9)
    assert abs(r["position"][2]) < 1e-9  # the gear's reading: its error q2 - r q1
    assert abs(r["position"][1] - ratio * r["position"][0]) < 1e-9
    # what the gear applies to the wheel: the torque that turns it, I2 r alpha about z
    np.testing.assert_allclose(r["torque"][2], [0.0, 0.0, I2 * ratio * alpha], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(r["force"][2], 0.0, atol=0.0)


def test_the_default_soft_gear_sags_under_load_as_its_stiffness_says():
    # Box2D's soft rows (60 Hz, damping ratio 2, the defaults) under a steady load: the wheel's
    # angular acceleration needs a torque I2 r alpha through the gear. In the steady state the
    # soft row's increment is 0, so m_eff bias_rate C mass_scale = -impulse_scale lambda, and with
    # b2Softness's coefficients that is C = load / (m_eff omega^2), omega = 2 pi 60 /s: 7.0e-4 rad
    # here, equal to the closed form to 2.5e-13 (measured; bound 1e-9). The rates still follow
    # the reduced inertia (1e-14 measured, bound 1e-9): the sag is constant once reached. The sag
    # measures the row's effective mass 1/k exactly (10 % off with the shared body's cross term
    # left out, in the gripper below).
    tau, I1, I2, ratio = 0.5, 0.01, 0.04, -2.0
    w = gear_pair(ratio, tau)
    sim = tb.Simulator(w, dt=DT, joint_settings=JointSettings())  # Box2D's (a gear's default is the tree's)
    sim.step(240)
    r = sim.joint_readings()
    alpha = tau / (I1 + ratio**2 * I2)
    assert r["rate"][0] == pytest.approx(alpha, rel=1e-9)
    # the row's effective mass 1/k, k = 1/I2 + r^2/I1 (1/(kg m^2)); its spring omega^2 / k
    k = 1.0 / I2 + ratio**2 / I1
    stiffness = (2 * math.pi * 60.0) ** 2 / k
    load = I2 * ratio * alpha  # the torque (N m) that turns the wheel, carried by the row
    assert abs(r["position"][2]) == pytest.approx(abs(load) / stiffness, rel=1e-9)


def rack_and_pinion(settings, g=9.81):
    """A rack (box, 3 kg) on a vertical slider pulled down by gravity, geared to a pinion (ball r
    0.1, 2 kg: I = 0.008) on a horizontal hinge: the rack's displacement = 0.1 m per rad."""
    w = tb.World(gravity=(0.0, 0.0, -g))
    pinion = w.add_body(tb.Sphere(0.1), mass=2.0, position=(0.0, 0.0, 2.0), name="pinion")
    rack = w.add_body(tb.Box(size=(0.05, 0.05, 0.5)), mass=3.0, position=(0.5, 0.0, 2.0), name="rack")
    w.add_joint(tb.HingeJoint("world", pinion, anchor=(0.0, 0.0, 2.0), axis=(0.0, 1.0, 0.0), name="pinion"))
    w.add_joint(tb.SliderJoint("world", rack, anchor=(0.5, 0.0, 2.0), axis=(0.0, 0.0, 1.0), name="rack"))
    w.add_joint(tb.GearJoint(joint="rack", follows="pinion", ratio=0.1))
    return w, pinion


@pytest.mark.parametrize("method", METHODS)
def test_a_rack_falls_with_the_pinion_s_inertia_added(method):
    # Rack and pinion (a slider's linear row geared to a hinge's angular row, m per rad): with x the
    # rack's fall, x = r theta, so (m + I / r^2) x'' = -m g. Constant, so exact as above (1e-9).
    w, pinion = rack_and_pinion(METHODS[method])
    sim = tb.Simulator(w, dt=DT, joint_settings=METHODS[method])
    sim.step(120)
    r = sim.joint_readings()
    I = float(np.linalg.inv(w.I_inv[pinion.index])[1, 1])
    a = -3.0 * 9.81 / (3.0 + I / 0.1**2)
    assert r["rate"][1] == pytest.approx(a * 0.5, rel=1e-9)
    # what the gear applies to the rack: m (a + g) upwards, the force that slows its fall
    np.testing.assert_allclose(r["force"][2], [0.0, 0.0, 3.0 * (a + 9.81)], rtol=1e-9, atol=1e-12)
    assert r["rate"][0] == pytest.approx(a * 0.5 / 0.1, rel=1e-9)
    assert abs(r["position"][2]) < 1e-9


def gripper(force, settings_mass=(4.0, 0.5)):
    """A floating hand (4 kg box, no gravity) with two fingers (0.5 kg each) on sliders along x,
    the second mirrored on the first (ratio -1: a parallel gripper's fingers, Franka's
    finger_joint2 equal to finger_joint1). A force on the first finger's slider pushes it out.
    The centres and anchors lie on the sliders' line, so the rows have no rotational part and the
    gear's J M^-1 J^T is the closed form 2/m + 4/M."""
    M, m = settings_mass
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    hand = w.add_body(tb.Box(size=(0.2, 0.1, 0.05)), mass=M, position=(0.0, 0.0, 1.0), name="hand")
    f1 = w.add_body(tb.Box(size=(0.02, 0.02, 0.08)), mass=m, position=(0.15, 0.0, 1.0), name="f1")
    f2 = w.add_body(tb.Box(size=(0.02, 0.02, 0.08)), mass=m, position=(-0.15, 0.0, 1.0), name="f2")
    w.add_joint(tb.SliderJoint(hand, f1, anchor=(0.15, 0.0, 1.0), axis=(1.0, 0.0, 0.0), force=force, name="j1"))
    w.add_joint(tb.SliderJoint(hand, f2, anchor=(-0.15, 0.0, 1.0), axis=(1.0, 0.0, 0.0), name="j2"))
    w.add_joint(tb.GearJoint(joint="j2", follows="j1", ratio=-1.0))
    return w, hand


@pytest.mark.parametrize("method", METHODS)
def test_mirrored_fingers_on_one_hand_open_as_lagrange_says(method):
    # Lagrange with the hand's X and the first finger's q (the second at -q): T = (M + 2m) X'^2/2 +
    # m q'^2, the slider force F does work F dq, so X'' = 0 and q'' = F / (2m): the hand stays
    # where it is and the fingers open at F/(2m). The two sliders share the hand, so the gear's
    # effective mass has the hand's cross term (k = 2/m + 4/M, not 2/m + 2/M), which the soft
    # gear's sag shows (below). Total momentum stays 0 (the gear is internal): 1e-12 kg m/s. The
    # sliders' rows and the gear's act along or across one line, so both methods meet the closed
    # form to rounding (1e-15 measured; bound 1e-9).
    F, m = 2.0, 0.5
    w, hand = gripper(F)
    sim = tb.Simulator(w, dt=DT, joint_settings=METHODS[method])
    sim.step(60)
    r = sim.joint_readings()
    assert r["rate"][0] == pytest.approx(F / (2 * m) * 0.25, rel=1e-9)
    assert r["rate"][1] == pytest.approx(-F / (2 * m) * 0.25, rel=1e-9)
    assert np.abs(w.v[hand.index]).max() < 1e-12
    assert np.abs(w.P[:3].sum(axis=0)).max() < 1e-12


def test_the_soft_gear_of_two_fingers_sags_by_its_effective_mass():
    # The same gripper with Box2D's soft rows: the gear carries G = F/2 (the second finger's m a),
    # so in the steady state it sags by C = G k / omega^2 (as the gear pair above) with the
    # shared hand's cross term in k = 2/m + 4/M: 3.5e-5 m. Measured equal to 6.6e-14 at 0.5 s (bound 1e-9); left out of k
    # (2/m + 2/M) the sag is 10 % smaller (checked by dropping the term in joint_gear.free_mass).
    F, M, m = 2.0, 4.0, 0.5
    w, hand = gripper(F)
    sim = tb.Simulator(w, dt=DT, joint_settings=JointSettings())
    sim.step(120)
    C = sim.joint_readings()["position"][2]
    k = 2 / m + 4 / M
    assert abs(C) == pytest.approx((F / 2) * k / (2 * math.pi * 60.0) ** 2, rel=1e-9)


def pendulum_and_flywheel(ratio):
    """A pendulum (1 kg ball on a 0.5 m massless-ish rod: a sphere r 0.05 at 0.5 m below a hinge
    about y) geared to a flywheel (cylinder r 0.2, 4 kg about its own hinge), released at 1 rad."""
    w = tb.World(gravity=(0.0, 0.0, -9.81))
    bob = w.add_body(tb.Sphere(0.05), mass=1.0, position=(0.5 * math.sin(1.0), 0.0, 2.0 - 0.5 * math.cos(1.0)),
                     name="bob")
    wheel = w.add_body(tb.Sphere(0.2), mass=4.0, position=(2.0, 0.0, 2.0), name="wheel")
    w.add_joint(tb.HingeJoint("world", bob, anchor=(0.0, 0.0, 2.0), axis=(0.0, 1.0, 0.0), name="swing"))
    w.add_joint(tb.HingeJoint("world", wheel, anchor=(2.0, 0.0, 2.0), axis=(0.0, 1.0, 0.0), name="fly"))
    w.add_joint(tb.GearJoint(joint="fly", follows="swing", ratio=ratio))
    return w


def test_a_pendulum_geared_to_a_flywheel_follows_dop853():
    # The reduced equation (I_p + r^2 I_w) phi'' = -m g l sin(phi), phi the angle from the bottom
    # (the hinge's angle is phi - 1, about +y: phi grows as the bob swings to +x... so the hinge
    # coordinate q = 1 - phi with the right-hand rule about +y taking +x towards -z), written
    # without tumble and integrated by DOP853 at rtol 1e-12. tumble (tree, rigid rows, dt 1/240 s,
    # 4 substeps) is first order: measured 1.20e-3 rad at dt, 3.0e-4 at dt/4 over 2 s (a quarter:
    # the order); bounds 2.4e-3 and 6e-4 rad. The gear holds to 2e-15 rad; with the gear's mass
    # taken over the free bodies instead of through the tree (``joint_tree.tree_gear_masses``) it
    # slipped 0.34 rad by the first sample at 0.25 s (checked).
    ratio, m, l, g = 3.0, 1.0, 0.5, 9.81
    I_bob = m * l**2 + 0.4 * m * 0.05**2
    I_wheel = 0.4 * 4.0 * 0.2**2
    inertia = I_bob + ratio**2 * I_wheel

    def rhs(t, y):
        return [y[1], -m * g * l * math.sin(y[0]) / inertia]

    times = np.arange(1, 9) * 0.25
    ref = solve_ivp(rhs, (0.0, 2.0), [1.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14, t_eval=times)
    errors = []
    for dt in (DT, DT / 4):
        w = pendulum_and_flywheel(ratio)
        sim = tb.Simulator(w, dt=dt, joint_settings=ACCURATE)
        worst = 0.0
        for t, phi in zip(times, ref.y[0]):
            sim.step(round(0.25 / dt))
            q = sim.joint_readings()["position"]
            worst = max(worst, abs((1.0 - phi) - q[0]))
            assert abs(q[1] - ratio * q[0]) < 1e-8
        errors.append(worst)
    assert errors[0] < 2.4e-3
    assert errors[1] < 6e-4
    assert errors[1] < 0.4 * errors[0]  # first order: a quarter of the step, about a quarter the error


def test_a_quartic_gear_follows_its_polynomial():
    # MuJoCo's polycoef: q1 = a0 + a1 q2 + a2 q2^2 + a3 q2^3 + a4 q2^4 (q1 "joint" follows q2). q2
    # driven by a motor at 1 rad/s over 1 s; the rigid gear row (Gauss-Seidel with the tree's
    # sweeps) holds the curve to its linearisation error per substep (the row is the curve's
    # tangent: O(h^2 p'' q2'^2) a substep, corrected by the bias): measured 1.6e-7 rad; bound 1e-6.
    # Its rate is p'(q2) q2' to the same order.
    coef = (0.1, 0.5, -0.3, 0.2, 0.05)
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    b1 = w.add_body(tb.Sphere(0.1), mass=1.0, position=(0.0, 0.0, 1.0))
    b2 = w.add_body(tb.Sphere(0.1), mass=1.0, position=(1.0, 0.0, 1.0))
    w.add_joint(tb.HingeJoint("world", b1, anchor=(0.0, 0.0, 1.0), axis=(0.0, 0.0, 1.0), name="q1"))
    w.add_joint(tb.HingeJoint("world", b2, anchor=(1.0, 0.0, 1.0), axis=(0.0, 0.0, 1.0), motor_speed=1.0, name="q2"))
    w.add_joint(tb.GearJoint(joint="q1", follows="q2", polynomial=coef))
    sim = tb.Simulator(w, dt=DT, joint_settings=ACCURATE)
    p = np.polynomial.Polynomial(coef)
    worst = 0.0
    for _ in range(24):
        sim.step(10)
        r = sim.joint_readings()
        q1, q2 = r["position"][:2]
        worst = max(worst, abs(q1 - p(q2)))
        assert r["rate"][0] == pytest.approx(p.deriv()(q2) * r["rate"][1], abs=1e-5)
    assert worst < 2e-6
    # the motor drove q2 to about 1 rad: the motor and the gear are two Gauss-Seidel rows on
    # different bodies, each undoing part of the other until the sweeps stop (the tree's sweeps
    # stop on the gear's impulse): q2 3.2e-4 rad short (measured); bound 1e-3
    assert r["position"][1] == pytest.approx(1.0, abs=1e-3)


def test_an_offset_gear_pulls_its_joints_to_the_relation():
    # offset 0.3 rad with both joints at 0: the gear starts 0.3 rad off its relation and its bias
    # closes the gap (as the other rigid rows close a joint's gap); after 1 s the relation holds to
    # 1e-9 rad and the two rates agree (ratio 1), the pair turning on at the speed the correction
    # left (no torque acts).
    w = gear_pair(ratio=1.0, torque=0.0, offset=0.3)
    sim = tb.Simulator(w, dt=DT, joint_settings=ACCURATE)
    sim.step(240)
    r = sim.joint_readings()
    assert abs(r["position"][1] - (0.3 + r["position"][0])) < 1e-9
    assert r["rate"][1] == pytest.approx(r["rate"][0], abs=1e-9)


def test_a_broken_joint_stops_its_gear():
    # the follower's hinge (its anchor 0.2 m off the ball's centre) breaks in the first step, its
    # reaction over max_force: from then on the gear does nothing, so the ball flies free at the
    # velocity it had (no force acts: the same bits every step) while the driven wheel spins up
    # alone, tau / I1.
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    g1 = w.add_body(tb.Sphere(0.1), mass=1.0, position=(0.0, 0.0, 1.0))
    g2 = w.add_body(tb.Sphere(0.1), mass=1.0, position=(1.0, 0.0, 1.0))
    w.add_joint(tb.HingeJoint("world", g1, anchor=(0.0, 0.0, 1.0), axis=(0.0, 0.0, 1.0), torque=1.0, name="a1"))
    w.add_joint(tb.HingeJoint("world", g2, anchor=(1.2, 0.0, 1.0), axis=(0.0, 0.0, 1.0), max_force=1e-3,
                              name="a2"))
    w.add_joint(tb.GearJoint(joint="a2", follows="a1", ratio=1.0))
    g2_moving = tb.Simulator(w, dt=DT, joint_settings=ACCURATE)
    g2_moving.step(1)
    assert w.joints[1].broken
    rate = w.omega[g2.index].copy()
    v = w.v[g2.index].copy()
    spin = w.omega[g1.index, 2]
    g2_moving.step(24)
    assert np.array_equal(w.omega[g2.index], rate) and np.array_equal(w.v[g2.index], v)  # free now
    I1 = 0.4 * 1.0 * 0.1**2
    assert w.omega[g1.index, 2] - spin == pytest.approx(1.0 / I1 * 24 * DT, rel=1e-9)


def test_a_world_with_a_gear_defaults_to_the_tree_method():
    # Gauss-Seidel takes the gear's mass over the free bodies: on the pendulum geared to a flywheel
    # Box2D's soft rows let the gear slip 0.081 rad in 2 s and rigid rows blow up within 0.2 s
    # (measured); so a gear sets world.exact_joints and the Simulator takes the tree method
    # (ACCURATE) unless told otherwise: the gear then holds to rounding (1e-12 bound).
    w = pendulum_and_flywheel(3.0)
    assert w.exact_joints
    sim = tb.Simulator(w, dt=DT)
    assert sim.joint_settings.method == "tree"
    sim.step(480)
    q = sim.joint_readings()["position"]
    assert abs(q[1] - 3.0 * q[0]) < 1e-12
    soft = tb.Simulator(pendulum_and_flywheel(3.0), dt=DT, joint_settings=JointSettings())
    soft.step(480)
    q = soft.joint_readings()["position"]
    assert abs(q[1] - 3.0 * q[0]) > 1e-3  # what the default avoids: Gauss-Seidel's slip (0.08 rad at 2 s)
    with pytest.raises(tb.SimulationError):
        tb.Simulator(pendulum_and_flywheel(3.0), dt=DT, joint_settings=RIGID_GS).step(480)


def test_a_checkpoint_carries_a_gear_bit_for_bit(tmp_path):
    # Checkpoints name a gear's joints by index: the resumed run equals the whole run bit for bit.
    whole, resumed = resumed_run(lambda: gear_pair(-2.0, 0.5), tmp_path, 0.5, DT)
    assert checks.state_hash(whole.world) == checks.state_hash(resumed.world)
    assert resumed.world.joints[2].kind == "gear"


def test_a_gear_in_a_scene_file(tmp_path):
    scene = tmp_path / "gears.toml"
    scene.write_text("""
[simulation]
gravity = [0, 0, 0]
[[bodies]]
name = "pinion"
shape = {type = "cylinder", radius = 0.1, length = 0.05}
mass = 2.0
position = [0, 0, 1]
[[bodies]]
name = "wheel"
shape = {type = "cylinder", radius = 0.2, length = 0.05}
mass = 2.0
position = [0.6, 0, 1]
[[joints]]
type = "hinge"
name = "a1"
body_a = "pinion"
anchor = [0, 0, 1]
torque = 0.5
[[joints]]
type = "hinge"
name = "a2"
body_a = "wheel"
anchor = [0.6, 0, 1]
[[joints]]
type = "gear"
joint = "a2"
follows = "a1"
ratio = -2.0
[joint_solver]
hertz = 0
""")
    sim = tb.load_scene(scene).simulator()
    sim.step(round(1.0 / sim.dt))
    r = sim.joint_readings()
    # the hinges have body_a the wheel and the world as body_b: the angle of the world about the wheel
    assert r["position"][1] == pytest.approx(-2.0 * r["position"][0], abs=1e-9)
    assert abs(r["rate"][0]) == pytest.approx(0.5 / (0.01 + 4 * 0.04), rel=1e-9)


BAD_SCENE = """
[[bodies]]
name = "p"
shape = {type = "sphere", radius = 0.1}
mass = 1.0
position = [0, 0, 1]
[[bodies]]
name = "q"
shape = {type = "sphere", radius = 0.1}
mass = 1.0
position = [1, 0, 1]
[[joints]]
type = "hinge"
name = "a1"
body_a = "p"
anchor = [0, 0, 1]
[[joints]]
type = "slider"
name = "a2"
body_a = "q"
anchor = [1, 0, 1]
[[joints]]
type = "ball"
name = "b"
body_a = "q"
anchor = [1, 0, 1]
[[joints]]
"""


@pytest.mark.parametrize("entry, problem", [
    ('type = "gear"\njoint = "a1"\nfollows = "a1"', "joints[3].follows: a gear needs two different joints"),
    ('type = "gear"\njoint = "a1"\nfollows = "nope"', "joints[3].follows: unknown joint 'nope'"),
    ('type = "gear"\njoint = "a1"\nfollows = "b"', "joints[3].follows: a gear couples hinge and slider joints"),
    ('type = "gear"\nfollows = "a1"', "joints[3]: missing key 'joint'"),
    ('type = "gear"\njoint = "a1"\nfollows = "a2"\nbody_a = "p"', "joints[3].body_a: unknown key for a gear joint"),
    ('type = "gear"\njoint = "a1"\nfollows = "a2"\npolynomial = [1, 2, 3, 4, 5, 6]',
     "joints[3].polynomial: expected a list of 1 to 5 numbers"),
    ('type = "gear"\njoint = "a1"\nfollows = "a2"\nratio = "two"', "joints[3].ratio: expected a number"),
    ('type = "gear"\njoint = 1\nfollows = "a2"', "joints[3].joint: expected the name of a joint above"),
])
def test_bad_gears_in_a_scene_file_are_one_line(tmp_path, entry, problem):
    scene = tmp_path / "bad.toml"
    scene.write_text(BAD_SCENE + entry + "\n")
    with pytest.raises(InputError) as err:
        tb.load_scene(scene)
    assert problem in str(err.value)
    assert "\n" not in str(err.value)


def test_bad_gears_in_python_are_typed_errors():
    w = gear_pair()
    ball = w.add_body(tb.Sphere(0.1), mass=1.0, position=(3.0, 0.0, 1.0))
    w.add_joint(tb.BallJoint("world", ball, anchor=(3.0, 0.0, 1.0), name="ball"))
    with pytest.raises(InputError, match="a gear couples hinge and slider joints, not a ball joint"):
        w.add_joint(tb.GearJoint(joint="ball", follows="a1"))
    with pytest.raises(InputError, match="not in this world"):
        w.add_joint(tb.GearJoint(joint=tb.HingeJoint("world", ball), follows="a1"))
    with pytest.raises(InputError, match="does not break"):
        w.add_joint(tb.GearJoint(joint="a1", follows="a2", max_force=10.0))
    with pytest.raises(InputError, match="index below 4"):
        w.add_joint(tb.GearJoint(joint=7, follows="a2"))


GEARED_MJCF = """
<mujoco model="geared">
  <option timestep="0.0005" gravity="0 0 -9.81" integrator="RK4"/>
  <worldbody>
    <body name="bob" pos="0 0 2">
      <joint name="swing" type="hinge" axis="0 1 0"/>
      <inertial pos="0 0 -0.5" mass="1" diaginertia="0.001 0.001 0.001"/>
      <geom type="sphere" size="0.05" pos="0 0 -0.5" contype="0" conaffinity="0"/>
    </body>
    <body name="wheel" pos="2 0 2">
      <joint name="fly" type="hinge" axis="0 1 0"/>
      <inertial pos="0 0 0" mass="4" diaginertia="0.064 0.064 0.064"/>
      <geom type="sphere" size="0.2" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <equality>
    <joint name="gear" joint1="fly" joint2="swing" polycoef="0 3 0 0 0"/>
  </equality>
</mujoco>
"""


def geared_pendulum_reference(times):
    """DOP853 of the reduced equation of GEARED_MJCF: (I_swing + 9 I_fly) theta'' = -m g l sin(theta),
    theta the swing joint's qpos (about +y: the bob at (-l sin, -l cos)), from 1 rad at rest."""
    inertia = (0.001 + 1.0 * 0.5**2) + 3.0**2 * 0.064
    return solve_ivp(lambda t, y: [y[1], -1.0 * 9.81 * 0.5 * math.sin(y[0]) / inertia], (0.0, times[-1]), [1.0, 0.0],
                     method="DOP853", rtol=1e-12, atol=1e-14, t_eval=times).y[0]


def test_an_mjcf_joint_equality_is_a_gear_that_follows_dop853_as_mujoco_does(tmp_path):
    # MuJoCo's <equality><joint joint1 joint2 polycoef>: joint1 follows joint2 (fly = 3 swing). The
    # same file in tumble (its joint equality a GearJoint; the tree solve, as every MJCF model with
    # an equality) and in MuJoCo (RK4, dt 0.5 ms) against DOP853 of the reduced equation: tumble
    # at dt 1/960 s (4 substeps) 3.0e-4 rad off over 2 s (1.2e-3 at 1/240 s: first order, as the
    # pendulum above), the relation to 7e-16; MuJoCo 2.1e-4 rad off, its gear slipping 5.5e-4 rad
    # under the swing's load (its equality is soft: solref 0.02 by default). Bounds 2x the
    # measured (1e-12 for tumble's relation). Read the other way round (swing = 3 fly), the
    # reduced pendulum swings at another period: 1.95 rad off DOP853's within the 2 s.
    path = tmp_path / "geared.xml"
    path.write_text(GEARED_MJCF)
    times = np.arange(1, 9) * 0.25
    ref = geared_pendulum_reference(times)

    w = tb.World()
    robot = tb.load_mjcf(w, path, joint_positions={"swing": 1.0, "fly": 3.0})
    assert robot.equalities["gear"].kind == "gear"
    sim = tb.Simulator(w, dt=1 / 960)
    worst = slip = 0.0
    for theta in ref:
        sim.step(240)
        states = robot.joint_states(sim)
        worst = max(worst, abs(states["swing"][0] - theta))
        slip = max(slip, abs(states["fly"][0] - 3.0 * states["swing"][0]))
    assert worst < 6e-4
    assert slip < 1e-12

    mujoco = pytest.importorskip("mujoco")
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    d.qpos[:] = [1.0, 3.0]
    mujoco.mj_forward(m, d)
    worst_mj = slip_mj = 0.0
    for theta in ref:
        for _ in range(500):
            mujoco.mj_step(m, d)
        worst_mj = max(worst_mj, abs(d.qpos[0] - theta))
        slip_mj = max(slip_mj, abs(d.qpos[1] - 3.0 * d.qpos[0]))
    assert worst_mj < 4.2e-4
    assert slip_mj < 1.1e-3


MIMIC_URDF = """<?xml version="1.0"?>
<robot name="spinner">
  <link name="base"/>
  <link name="w1">
    <inertial><mass value="2"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><sphere radius="0.1"/></geometry></collision>
  </link>
  <link name="w2">
    <inertial><mass value="2"/><inertia ixx="0.04" iyy="0.04" izz="0.04" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><sphere radius="0.2"/></geometry></collision>
  </link>
  <joint name="j1" type="continuous">
    <parent link="base"/><child link="w1"/><origin xyz="0 0 1"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="j2" type="continuous">
    <parent link="base"/><child link="w2"/><origin xyz="1 0 1"/><axis xyz="0 0 1"/>
    <mimic joint="j1" multiplier="-2" offset="0.1"/>
  </joint>
</robot>
"""


def test_a_urdf_mimic_joint_follows_its_joint(tmp_path):
    # URDF's <mimic joint="j1" multiplier="-2" offset="0.1">: j2 = 0.1 - 2 j1, a GearJoint. The robot
    # starts on the relation (j2 placed at 0.1), and a torque on j1 spins the pair up at
    # tau / (I1 + 4 I2) as the gear pair above: rounding (1e-9), the relation to 1e-9 rad.
    path = tmp_path / "spinner.urdf"
    path.write_text(MIMIC_URDF)
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    robot = tb.load_urdf(w, path, fixed_base=True)
    assert robot.equalities["j2"].kind == "gear"
    sim = tb.Simulator(w, dt=DT, joint_settings=ACCURATE)
    R2 = robot.link_pose("w2")[1]
    assert math.atan2(R2[1, 0], R2[0, 0]) == pytest.approx(0.1, abs=1e-12)  # placed on the relation
    robot.set_joint_torque(sim, "j1", 0.5)
    sim.step(240)
    states = robot.joint_states(sim)
    assert states["j1"][1] == pytest.approx(0.5 / (0.01 + 4 * 0.04), rel=1e-9)
    assert abs(states["j2"][0] - (0.1 - 2.0 * states["j1"][0])) < 1e-9


@pytest.mark.parametrize("change, problem", [
    ('<mimic joint="j1" multiplier="-2" offset="0.1"/>', None),
    ('<mimic joint="nope"/>', "joint[j2].mimic.joint: unknown joint 'nope'"),
    ('<mimic multiplier="2"/>', "joint[j2].mimic.joint: missing the joint it follows"),
    ('<mimic joint="j1" multiplier="two"/>', "joint[j2].mimic.multiplier: expected"),
    ('<mimic joint="j2"/>', "joint[j2].mimic.follows: a gear needs two different joints"),
])
def test_bad_mimics_are_one_line(tmp_path, change, problem):
    path = tmp_path / "spinner.urdf"
    path.write_text(MIMIC_URDF.replace('<mimic joint="j1" multiplier="-2" offset="0.1"/>', change))
    w = tb.World()
    if problem is None:
        tb.load_urdf(w, path, fixed_base=True)
        return
    with pytest.raises(InputError) as err:
        tb.load_urdf(w, path, fixed_base=True)
    assert problem in str(err.value) and "spinner.urdf" in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("equality, problem", [
    ('<joint joint1="fly" joint2="nope"/>', "equality.joint[0].joint2: unknown joint 'nope'"),
    ('<joint joint1="fly" joint2="fly"/>', "equality.joint[0]: joint1 and joint2 are the same joint"),
    ('<joint joint1="fly" joint2="swing" polycoef="0 1 2 3 4 5"/>', "equality.joint[0].polycoef: expected"),
])
def test_bad_mjcf_joint_equalities_are_one_line(tmp_path, equality, problem):
    path = tmp_path / "geared.xml"
    path.write_text(GEARED_MJCF.replace('<joint name="gear" joint1="fly" joint2="swing" polycoef="0 3 0 0 0"/>',
                                        equality))
    with pytest.raises(InputError) as err:
        tb.load_mjcf(tb.World(), path)
    assert problem in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("method", ["gauss-seidel", "tree"])
def test_gear_variants_batch_bit_for_bit(method, tmp_path):
    # A sweep over the flywheel's mass in examples/joints/geared_flywheel.toml (collisions off, so
    # that the variants may share space): with Gauss-Seidel chosen in the file the
    # variants run as one World (tumble.sweep.batch), each gear pointing at its own variant's joints
    # (their rows moved by the joints before them), and give the bits of their single runs; the tree
    # method's sweeps while a gear's impulse changes run over all joints, so those run one by one.
    pytest.importorskip("pyarrow")
    from pathlib import Path

    from tumble.sweep import run_sweep, tables_equal

    example = Path(__file__).resolve().parents[2] / "examples" / "joints" / "geared_flywheel.toml"
    scene = tmp_path / "geared.toml"
    text = example.read_text().replace('method = "tree"', f'method = "{method}"')
    if method == "gauss-seidel":  # Box2D's soft rows (rigid Gauss-Seidel rows blow this pendulum up)
        text = text.replace("hertz = 0\n", "")
    scene.write_text(text.replace("gravity = [0, 0, -9.81]", "gravity = [0, 0, -9.81]\ncollisions = false"))
    vary = ["bodies.flywheel.mass=linspace(2.0, 6.0, 4)", "simulation.duration=[1.0]"]
    batched = run_sweep(scene, vary=vary, workers=0, progress=False)
    single = run_sweep(scene, vary=vary, workers=0, progress=False, batch=False)
    assert batched["batch_size"].to_pylist() == [4 if method == "gauss-seidel" else 1] * 4
    assert tables_equal(batched, single, ignore=("wall_time_s", "batch_size"))
    assert len(set(batched["state_hash"].to_pylist())) == 4


def test_a_gear_without_a_joint_to_follow_locks_its_joint():
    # follows=None: q_joint = offset (MuJoCo's joint equality without joint2). A pendulum on a hinge
    # about y, its bob 1 rad out, locked at 0.3 rad from that start: the lock's bias takes it there
    # and holds it against gravity; after 1 s it sits at 0.3 rad to 1e-9 (a rigid row through the
    # tree, the default with a gear), at rest (1e-9 rad/s).
    w2 = tb.World(gravity=(0.0, 0.0, -9.81))
    bob = w2.add_body(tb.Sphere(0.05), mass=1.0, position=(0.5 * math.sin(1.0), 0.0, 2.0 - 0.5 * math.cos(1.0)))
    w2.add_joint(tb.HingeJoint("world", bob, anchor=(0.0, 0.0, 2.0), axis=(0.0, 1.0, 0.0), name="swing"))
    w2.add_joint(tb.GearJoint(joint="swing", offset=0.3, name="lock"))
    assert w2.exact_joints
    sim = tb.Simulator(w2, dt=DT)
    sim.step(240)
    r = sim.joint_readings()
    assert r["position"][0] == pytest.approx(0.3, abs=1e-9)
    assert abs(r["rate"][0]) < 1e-9
    assert abs(r["position"][1]) < 1e-9  # the lock's own error


def test_an_mjcf_joint_equality_without_joint2_locks_the_joint_as_in_mujoco(tmp_path):
    # <equality><joint joint1="swing" polycoef="0.3"/>: swing held at 0.3 rad from its reference, the
    # flywheel (no longer geared) free. tumble holds 0.3 to 1e-9 (its rigid lock); MuJoCo's soft
    # equality sags under the bob's weight: measured 0.3 - 2.4e-4 rad; bound 5e-4.
    path = tmp_path / "locked.xml"
    path.write_text(GEARED_MJCF.replace('<joint name="gear" joint1="fly" joint2="swing" polycoef="0 3 0 0 0"/>',
                                        '<joint name="lock" joint1="swing" polycoef="0.3"/>'))
    w = tb.World()
    robot = tb.load_mjcf(w, path)
    sim = tb.Simulator(w, dt=1 / 960)
    sim.step(960)
    assert robot.joint_states(sim)["swing"][0] == pytest.approx(0.3, abs=1e-9)
    mujoco = pytest.importorskip("mujoco")
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    for _ in range(2000):
        mujoco.mj_step(m, d)
    assert d.qpos[0] == pytest.approx(0.3, abs=5e-4)


def test_two_gears_on_one_joint_hold_together():
    # A lock (h = 0.1 rad) and a gear (s = 0.01 + 0.5 h) on one hinge, the hinge's rod under gravity
    # and a point force, the slider's body on the world: the tree method solves each gear after a
    # tree solve (block Gauss-Seidel on the gears' Schur complement); both hold to 1e-9 after 1 s.
    # Solved beside the other Gauss-Seidel rows (on velocities the other gear had left
    # inconsistent), the pair blows up within the second (checked).
    w = tb.World(gravity=(0.0, 0.0, -9.81))
    rod = w.add_body(tb.Capsule(0.1, 1.0), mass=1.0, position=(0.0, 0.0, 0.0), name="rod")
    cart = w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=2.0, position=(2.0, 0.0, 0.0), name="cart")
    w.add_joint(tb.HingeJoint(rod, None, anchor=(0.0, 0.0, 0.6), axis=(0.0, 1.0, 0.0), name="h"))
    w.add_joint(tb.SliderJoint(cart, None, anchor=(2.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0), name="s"))
    w.add_joint(tb.GearJoint(joint="s", follows="h", ratio=0.5, offset=0.01))
    w.add_joint(tb.GearJoint(joint="h", offset=0.1))
    w.add_force(tb.PointForce(rod, force=(1.0, 0.0, 0.0), point=(0.0, 0.0, -0.5), frame="body"))
    sim = tb.Simulator(w, dt=DT)
    sim.step(240)
    q = sim.joint_readings()["position"]
    assert q[0] == pytest.approx(0.1, abs=1e-9) and q[1] == pytest.approx(0.06, abs=1e-9)
    assert np.abs(q[2:]).max() < 1e-9


def test_pybullet_s_joint_gear_on_the_same_file_turns_as_tumble_s_gear(tmp_path):
    # PyBullet's createConstraint(JOINT_GEAR) with gearRatio g makes q_child = -q_parent / g; with
    # g = 2 the URDF's two wheels (I 0.01 and 0.04, inertia from the file) spun by 0.5 N m on the
    # first turn at 0.5 / (0.01 + 0.04 / 4) = 25 rad/s^2 in both engines: tumble's mimic with
    # multiplier -1/g, the same rates after 1 s to 1e-9 (PyBullet's to 1e-14 of the closed form,
    # tumble's to rounding).
    p = pytest.importorskip("pybullet")
    path = tmp_path / "spinner.urdf"
    path.write_text(MIMIC_URDF.replace('<mimic joint="j1" multiplier="-2" offset="0.1"/>', ''))
    client = p.connect(p.DIRECT)
    try:
        p.setGravity(0, 0, 0, physicsClientId=client)
        p.setTimeStep(DT, physicsClientId=client)
        r = p.loadURDF(str(path), useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=client)
        for j in range(2):
            p.setJointMotorControl2(r, j, p.VELOCITY_CONTROL, force=0, physicsClientId=client)
            p.changeDynamics(r, j, linearDamping=0, angularDamping=0, physicsClientId=client)
        c = p.createConstraint(r, 0, r, 1, jointType=p.JOINT_GEAR, jointAxis=[0, 0, 1], parentFramePosition=[0, 0, 0],
                               childFramePosition=[0, 0, 0], physicsClientId=client)
        p.changeConstraint(c, gearRatio=2.0, maxForce=1e6, physicsClientId=client)
        for _ in range(240):
            p.setJointMotorControl2(r, 0, p.TORQUE_CONTROL, force=0.5, physicsClientId=client)
            p.stepSimulation(physicsClientId=client)
        pb = [s[1] for s in p.getJointStates(r, [0, 1], physicsClientId=client)]
    finally:
        p.disconnect(client)
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    robot = tb.load_urdf(w, path, fixed_base=True)
    w.add_joint(tb.GearJoint(joint=robot.joints["j2"], follows=robot.joints["j1"], ratio=-1.0 / 2.0))
    sim = tb.Simulator(w, dt=DT)
    robot.set_joint_torque(sim, "j1", 0.5)
    sim.step(240)
    states = robot.joint_states(sim)
    assert pb[0] == pytest.approx(25.0, rel=1e-12)
    assert states["j1"][1] == pytest.approx(pb[0], rel=1e-9)
    assert states["j2"][1] == pytest.approx(pb[1], rel=1e-9)


MIMIC_ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="upper">
    <inertial><origin xyz="0.5 0 0"/><mass value="1"/><inertia ixx="0.01" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="fore">
    <inertial><origin xyz="0.5 0 0"/><mass value="1"/><inertia ixx="0.01" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="fore"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
    <mimic joint="shoulder" multiplier="1.5" offset="0.2"/>
  </joint>
  <link name="hand">
    <inertial><origin xyz="0.5 0 0"/><mass value="1"/><inertia ixx="0.01" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="wrist" type="revolute">
    <parent link="fore"/><child link="hand"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
</robot>
"""


def test_inverse_kinematics_keeps_a_mimic_joint_on_its_relation(tmp_path):
    """A planar arm of three 1 m links (shoulder, elbow, wrist) whose elbow mimics its shoulder
    (elbow = 0.2 + 1.5 shoulder): the hand's end reaches (cos s + cos(s + e) + cos(s + e + w), ...).
    A target made from s = 0.7, w = 0.3 is met (1e-6 m) with the elbow on its relation (to
    rounding): two unknowns left for two equations. Without the coupling the search meets the
    target too, on a family of three-joint solutions, with the elbow off its relation (checked
    here: that is what the test would see if the mimic were ignored), as PyBullet's
    calculateInverseKinematics does (it reads no mimic)."""
    path = tmp_path / "arm.urdf"
    path.write_text(MIMIC_ARM)
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    robot = tb.load_urdf(w, path, fixed_base=True)
    kin = robot.kinematics
    assert [c[4][:2].tolist() for c in kin.couplings()] == [[0.2, 1.5]]
    s, wr = 0.7, 0.3
    e = 0.2 + 1.5 * s
    target = (math.cos(s) + math.cos(s + e) + math.cos(s + e + wr), math.sin(s) + math.sin(s + e)
              + math.sin(s + e + wr), 0.0)

    def joints(sol):
        return [float(sol.qpos[kin.by_name[n].qpos][0]) for n in ("shoulder", "elbow", "wrist")]

    sol = kin.inverse_kinematics("hand", target, point=(1.0, 0.0, 0.0), qpos=np.zeros(kin.nq))
    assert sol.converged and sol.position_error < 1e-6
    q_s, q_e, _ = joints(sol)
    assert q_e == pytest.approx(0.2 + 1.5 * q_s, abs=1e-12)
    kin.couplings = lambda: []  # the search without the coupling: the elbow leaves its relation
    free = kin.inverse_kinematics("hand", target, point=(1.0, 0.0, 0.0), qpos=np.zeros(kin.nq))
    assert free.converged
    q_s, q_e, _ = joints(free)
    assert abs(q_e - (0.2 + 1.5 * q_s)) > 0.1
