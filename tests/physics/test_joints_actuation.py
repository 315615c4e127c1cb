"""Applied joint torques and forces (PyBullet's TORQUE_CONTROL, MuJoCo's motor actuators) and
joint armature (MuJoCo's: an inertia added to a joint coordinate), against closed forms and
against Lagrange's equations of the chain with the armature on the mass matrix's diagonal,
integrated by SciPy's DOP853 (``solutions.planar_chain_dop853``, written without tumble)."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import tumble as tb
from tumble import checks
from tumble.joints import HingeJoint, SliderJoint
from tumble.solver.joints import ACCURATE, JointSettings, JointSolver, step_with_joints

from .solutions import planar_chain_dop853, resumed_run

DT = 1 / 240
METHODS = {"gauss-seidel": JointSettings(), "tree": ACCURATE}


def wheel_world(torque, armature=0.0, contact_elsewhere=False):
    """A wheel (cylinder r 0.1 m, 2 kg: I_z = 0.01 kg m^2) on a vertical hinge to the world, no
    gravity; ``contact_elsewhere``: a box resting on a ground plane far away, so the Simulator's
    step takes its loop with contacts rather than the fused joint kernel."""
    w = tb.World(gravity=(0.0, 0.0, -9.81 if contact_elsewhere else 0.0))
    wheel = w.add_body(tb.Cylinder(0.1, 0.05), mass=2.0, position=(0.0, 0.0, 1.0), name="wheel")
    w.add_joint(HingeJoint("world", wheel, anchor=(0.0, 0.0, 1.0), axis=(0.0, 0.0, 1.0), torque=torque,
                           armature=armature, name="axle"))
    if contact_elsewhere:
        w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
        w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(5.0, 0.0, 0.1))
    return w


def spin_rate(path, method, torque, armature=0.0, seconds=1.0):
    """The wheel's rate (rad/s) after ``seconds`` by one of the three paths a step can take."""
    w = wheel_world(torque, armature, contact_elsewhere=path == "stage loop")
    if path == "standalone":
        solver = JointSolver(METHODS[method])
        for _ in range(round(seconds / DT)):
            step_with_joints(w, solver, DT, 4)
        return solver.readings(0)["rate"], w
    sim = tb.Simulator(w, dt=DT, joint_settings=METHODS[method])
    sim.step(round(seconds / DT))
    return sim.joint_readings()["rate"][0], w


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("path", ["standalone", "fused", "stage loop"])
def test_a_hinge_torque_spins_a_wheel_at_torque_over_inertia(path, method):
    # Compared with omega = tau t / I_z: a constant torque about a principal axis with no
    # gyroscopic term is integrated exactly by any of the steps (the torque enters as an impulse
    # tau h each substep); the tolerance is rounding over 960 substeps. With armature a the
    # inertia is I_z + a (MuJoCo's armature on the joint coordinate), exact the same way.
    tau, I_z = 0.5, 0.5 * 2.0 * 0.1**2
    rate, w = spin_rate(path, method, tau)
    assert rate == pytest.approx(tau / I_z * 1.0, rel=1e-9)
    assert w.omega[0, 2] == pytest.approx(tau / I_z, rel=1e-9)
    rate, _ = spin_rate(path, method, tau, armature=0.03)
    assert rate == pytest.approx(tau / (I_z + 0.03) * 1.0, rel=1e-9)


@pytest.mark.parametrize("method", METHODS)
def test_a_joint_torque_acts_equal_and_opposite_on_the_two_bodies(method):
    # Two coaxial cylinders floating free, joined by a hinge along their common axis, a torque
    # tau between them: each spins up as tau t / I (b) and -tau t / I (a), so the total angular
    # momentum stays zero (an internal torque: to rounding, 1e-12 of the bodies' |L|).
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    a = w.add_body(tb.Cylinder(0.2, 0.1), mass=3.0, position=(0.0, 0.0, 0.0))
    b = w.add_body(tb.Cylinder(0.1, 0.1), mass=1.0, position=(0.0, 0.0, 0.1))
    w.add_joint(HingeJoint(a, b, anchor=(0.0, 0.0, 0.05), axis=(0.0, 0.0, 1.0), torque=0.2))
    sim = tb.Simulator(w, dt=DT, joint_settings=METHODS[method])
    sim.step(240)
    Ia, Ib = 0.5 * 3.0 * 0.2**2, 0.5 * 1.0 * 0.1**2
    assert w.omega[b.index, 2] == pytest.approx(0.2 / Ib, rel=1e-9)
    assert w.omega[a.index, 2] == pytest.approx(-0.2 / Ia, rel=1e-9)
    L = w.L[a.index] + w.L[b.index] + np.cross(w.x[a.index], w.P[a.index]) + np.cross(w.x[b.index], w.P[b.index])
    assert np.abs(L).max() < 1e-12 * np.abs(w.L[b.index]).max()


@pytest.mark.parametrize("method", METHODS)
def test_a_slider_force_accelerates_a_block_at_force_over_mass_plus_armature(method):
    # A 1 kg block on a horizontal slider to the world, pushed by 2 N: v = F t / (m + a) exactly
    # (rounding); x follows semi-implicit Euler's sum over the substeps, x = a_c h^2 n (n + 1) / 2.
    for armature in (0.0, 3.0):
        w = tb.World(gravity=(0.0, 0.0, 0.0))
        block = w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0.0, 0.0, 1.0))
        w.add_joint(SliderJoint("world", block, anchor=(0.0, 0.0, 1.0), axis=(1.0, 0.0, 0.0), force=2.0,
                                armature=armature))
        sim = tb.Simulator(w, dt=DT, joint_settings=METHODS[method])
        sim.step(240)
        acc = 2.0 / (1.0 + armature)
        h, n = DT / 4, 960
        assert w.v[0, 0] == pytest.approx(acc * 1.0, rel=1e-9)
        assert w.x[0, 0] == pytest.approx(acc * h * h * n * (n + 1) / 2, rel=1e-9)
        assert np.abs(w.x[0, 1:] - (0.0, 1.0)).max() < 1e-9


def level_chain(w, count, mass, length, z=0.0, **hinge):
    """``count`` bars (0.05 x 0.05 x ``length`` m, ``mass`` kg) laid level along +x from (0, 0, z),
    each on a hinge about y to the one before (the first to the world) with the ``hinge`` fields
    (a value, or a function of the bar's index)."""
    prev = None
    for k in range(count):
        bar = w.add_body(tb.Box(size=(0.05, 0.05, length)), mass=mass, position=((k + 0.5) * length, 0.0, z),
                         euler_deg=(0.0, 90.0, 0.0))
        fields = {name: value(k) if callable(value) else value for name, value in hinge.items()}
        w.add_joint(HingeJoint(bar, prev, anchor=(k * length, 0.0, z), axis=(0.0, 1.0, 0.0), **fields))
        prev = bar
    return w


def pendulum(armature, method, dt=DT, seconds=1.0, theta0=1.0):
    """A 2 kg bar (0.1 x 0.1 x 1 m) hanging from a hinge (world y axis) at its end, started at
    theta0 rad from the vertical, at rest; returns the hinge angles (rad, from the start) per step."""
    w = tb.World(gravity=(0.0, 0.0, -9.81))
    bar = w.add_body(tb.Box(size=(0.1, 0.1, 1.0)), mass=2.0,
                     position=(0.5 * math.sin(theta0), 0.0, -0.5 * math.cos(theta0)),
                     euler_deg=(0.0, math.degrees(theta0), 0.0))
    w.add_joint(HingeJoint(bar, None, anchor=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0), armature=armature))
    sim = tb.Simulator(w, dt=dt, joint_settings=METHODS[method])
    angles = []
    for _ in range(round(seconds / dt)):
        sim.step(1)
        angles.append(sim.joint_readings()["position"][0])
    return np.array(angles)


def pendulum_dop853(armature, dt=DT, seconds=1.0, theta0=1.0):
    """(I_pivot + a) theta'' = -m g d sin theta by DOP853 (rtol 1e-12), as angles from the start
    at the ends of the steps (the hinge's angle: the bar turns about +y as theta grows)."""
    I = 2.0 * (0.1**2 + 1.0**2) / 12 + 2.0 * 0.5**2 + armature
    t = dt * np.arange(1, round(seconds / dt) + 1)
    sol = solve_ivp(lambda _t, y: [y[1], -2.0 * 9.81 * 0.5 * math.sin(y[0]) / I], (0.0, seconds), [theta0, 0.0],
                    method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t)
    return sol.y[0] - theta0


@pytest.mark.parametrize("method", METHODS)
def test_a_pendulum_with_armature_swings_as_lagrange_says_to_first_order(method):
    # Compared with DOP853 on (I + a) theta'' = -m g d sin theta (a = 1 kg m^2 on a bar of
    # I_pivot 0.668: the swing 2.5x slower). The step is first order in dt (semi-implicit Euler
    # substeps): measured worst over 1 s 1.21e-3 rad (tree) / 1.18e-3 (Gauss-Seidel) at 1/240 s,
    # 4.0x / 4.3x less at dt / 4; bound 3e-3, and the ratio > 3 (first order). Without the
    # armature the angle is off by 0.80 rad within the second.
    err = np.abs(pendulum(1.0, method) - pendulum_dop853(1.0)).max()
    err4 = np.abs(pendulum(1.0, method, dt=DT / 4) - pendulum_dop853(1.0, dt=DT / 4)).max()
    assert err < 3e-3
    assert err / err4 > 3.0
    assert np.abs(pendulum(0.0, method) - pendulum_dop853(1.0)).max() > 0.3


def test_a_two_link_chain_with_armature_follows_lagrange():
    # Two 0.1 kg bars of 0.4 m on two hinges (y axis), started level, armature a on each joint:
    # Lagrange's equations with diag(a) added to M(q) (planar_chain_dop853), the tree solve (the
    # default a joint with armature gets). a = 1 dwarfs the links' inertia (5e-3 kg m^2 about the
    # first hinge): Gauss-Seidel alone is off by 0.36 rad there (0.23 rad with a = 0.1), which is
    # why the tree solve is the default. Measured worst over 1 s at dt 1/240 s: 1.7e-3 rad
    # (a = 0.1), 3.8e-4 (a = 1); bound 3e-3 (the step's first-order error, as the pendulum's).
    for armature in (0.1, 1.0):
        w = level_chain(tb.World(gravity=(0.0, 0.0, -9.81)), 2, 0.1, 0.4, armature=armature)
        assert w.exact_joints
        sim = tb.Simulator(w, dt=DT)
        assert sim.joint_settings is ACCURATE
        got = []
        for _ in range(240):
            sim.step(1)
            got.append(sim.joint_readings()["position"].copy())
        I = 0.1 * (0.05**2 + 0.4**2) / 12
        t = DT * np.arange(1, 241)
        _, q = planar_chain_dop853([(0, 0.1, (0.2, 0.0), I), (1, 0.1, (0.2, 0.0), I)], [(0.0, 0.0), (0.4, 0.0)],
                                   [0.0, 0.0], 1.0, t, armature=[armature, armature])
        # the chain's q turns about +y as (x, z) -> (x cos + z sin, ...): tumble's hinge angle is -q
        assert np.abs(np.array(got) + q).max() < 3e-3


def test_a_light_link_with_armature_is_brought_to_its_limit_without_bouncing():
    # Two 0.04 kg bars (inertia 3e-4 kg m^2) on hinges with armature 1, started level, 0.5 rad
    # outside their range [0.5, 1.5] rad, on the side gravity pulls them to: each joint is pushed
    # onto its lower limit and held there, without bouncing back out (overshooting into the range
    # by 5e-5 rad at most, measured; bound 1e-4). The tree's limits push back at their softness
    # (JointSettings.limit_hertz: 240 Hz, damping ratio 2), so the 0.5 rad close over a few steps
    # (measured: 0.156 rad left after the first step, 1e-5 by the 9th; session 34's rigid push-out
    # closed it in one), to 1e-5 rad from 0.1 s on (measured 8e-8). With
    # limit rows that saw the link's own inertia alone, not the armature's, the tree method
    # bounced the joints from stop to stop (12.8 rad after 0.5 s) and Gauss-Seidel went to NaN.
    w = level_chain(tb.World(gravity=(0.0, 0.0, -9.81)), 2, 0.04, 0.3, armature=1.0, lower=0.5, upper=1.5)
    sim = tb.Simulator(w, dt=DT)
    q = []
    for _ in range(120):
        sim.step(1)
        q.append(sim.joint_readings()["position"].copy())
    q = np.array(q)
    assert np.all(q <= 0.5 + 1e-4)  # no bounce into the range
    assert np.all(np.diff(q, axis=0) >= -1e-4)  # nor back out: the angles rise to the limit
    assert np.abs(q[24:] - 0.5).max() < 1e-5


@pytest.mark.parametrize("method", METHODS)
def test_a_torque_limited_motor_spins_up_the_armature_too(method):
    # A motor at 10 rad/s limited to 0.2 N m on the wheel (I_z 0.01) with armature 0.03: it
    # saturates, and the rate grows at 0.2 / (I_z + a) (the motor row sees the coordinate's
    # inertia plus the armature); exact while saturated (rounding), 0.5 s in.
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    wheel = w.add_body(tb.Cylinder(0.1, 0.05), mass=2.0, position=(0.0, 0.0, 1.0))
    w.add_joint(HingeJoint("world", wheel, anchor=(0.0, 0.0, 1.0), axis=(0.0, 0.0, 1.0), motor_speed=10.0,
                           max_motor_torque=0.2, armature=0.03))
    sim = tb.Simulator(w, dt=DT, joint_settings=METHODS[method])
    sim.step(120)
    assert sim.joint_readings()["rate"][0] == pytest.approx(0.2 / 0.04 * 0.5, rel=1e-6)


def struck_bar_momentum_error(method, dt, armature=1.0, seconds=0.4):
    """A 1 kg ball (r 0.1 m) at 3 m/s strikes a 0.2 kg bar 1 m long, level on a vertical hinge to the
    world at its end with ``armature``, 0.8 m out (no gravity, friction 0.5, no restitution): the
    largest change over the run of the angular momentum about the hinge's axis, the armature's
    a q' included (N m s; 2.4 at the start)."""
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    w.sleeping = False
    material = tb.Material(friction=0.5, restitution=0.0)
    bar = w.add_body(tb.Box(size=(1.0, 0.1, 0.1)), mass=0.2, position=(0.5, 0.0, 0.0), material=material)
    w.add_body(tb.Sphere(0.1), mass=1.0, position=(0.8, -0.5, 0.0), velocity=(0.0, 3.0, 0.0), material=material)
    w.add_joint(HingeJoint("world", bar, anchor=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), armature=armature))
    sim = tb.Simulator(w, dt=dt, joint_settings=METHODS[method])

    def about_hinge():
        w.update_derived()
        orbital = w.x[:, 0] * w.P[:, 1] - w.x[:, 1] * w.P[:, 0]
        return float(orbital.sum() + w.L[:, 2].sum() + armature * w.omega[0, 2])

    start = about_hinge()
    worst = 0.0
    for _ in range(round(seconds / dt)):
        sim.step(1)
        worst = max(worst, abs(about_hinge() - start))
    assert w.omega[0, 2] > 1.0  # struck: the bar turns
    return worst


@pytest.mark.parametrize("method", METHODS)
def test_a_ball_striking_a_bar_with_armature_keeps_the_angular_momentum_about_the_hinge(method):
    # Conservation: the hinge's reaction acts through its axis, the contact's impulses are equal
    # and opposite, and the armature's row gives the bar what its flywheel loses, so the angular
    # momentum about the axis (ball, bar, armature 1 kg m^2: 15x the bar's 0.067) stays 2.4 N m s.
    # Measured at 1/240 s: 2.0e-4 (tree), 2.7e-4 (Gauss-Seidel), 1.8e-5 / 5.1e-5 at 1/960 s: the
    # step's discretization (the hinge's anchor drifts off the axis within a substep: 1.6e-5 with
    # no armature), so the bound 1e-3 and a fall of 3x with dt / 4. When each substep took the
    # armature's rate again from the bodies' rates after the contacts had changed them (before
    # joint_solve.flywheel_rates_kernel), it was off by 4.67.
    err = struck_bar_momentum_error(method, DT)
    err4 = struck_bar_momentum_error(method, DT / 4)
    assert err < 1e-3
    assert err4 < err / 3.0


def test_a_torque_holds_a_damped_pendulum_where_gravity_balances_it():
    # A hinge torque of 3 N m on the bar of ``pendulum`` (m g d = 9.81 N m), joint damping to let
    # it settle: at rest tau = m g d sin theta (brentq); set between steps (Simulator.set_joint_torque).
    w = tb.World(gravity=(0.0, 0.0, -9.81))
    bar = w.add_body(tb.Box(size=(0.1, 0.1, 1.0)), mass=2.0, position=(0.0, 0.0, -0.5))
    w.add_joint(HingeJoint(bar, None, anchor=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0), damping=2.0, name="pivot"))
    sim = tb.Simulator(w, dt=DT)
    sim.step(1)
    sim.set_joint_torque("pivot", 3.0)
    sim.step(240 * 8)
    theta = brentq(lambda th: 3.0 - 2.0 * 9.81 * 0.5 * math.sin(th), 0.0, 1.5)
    assert sim.joint_readings()["position"][0] == pytest.approx(theta, abs=1e-4)
    assert w.joints[0].bound.param[19] == 3.0  # kept in the record (checkpoints carry it)
    for bad, problem in (("x", "expected a number"), (math.inf, "finite")):
        with pytest.raises(tb.InputError, match=problem):
            sim.soft_step.joints.set_effort("pivot", bad)
        with pytest.raises(tb.InputError, match=problem):
            sim.set_joint_torque("pivot", bad)
    with pytest.raises(tb.InputError, match="unknown joint 'knee'"):
        sim.set_joint_torque("knee", 1.0)
    # before the first step: into the record, which the solver reads when it is built
    w2 = tb.World(gravity=(0.0, 0.0, 0.0))
    wheel = w2.add_body(tb.Cylinder(0.1, 0.05), mass=2.0, position=(0.0, 0.0, 1.0))
    w2.add_joint(HingeJoint("world", wheel, anchor=(0.0, 0.0, 1.0), axis=(0.0, 0.0, 1.0)))
    sim2 = tb.Simulator(w2, dt=DT)
    sim2.set_joint_torque(0, 0.5)
    sim2.step(240)
    assert w2.omega[0, 2] == pytest.approx(0.5 / 0.01, rel=1e-9)


def test_a_run_with_torques_and_armature_resumes_bit_for_bit(tmp_path):
    # The checkpoint carries the joints' efforts and armatures (their parameter rows) and the
    # armature rows' impulses (axial_impulse): the resumed run equals the uninterrupted one.
    def make_world():
        return level_chain(tb.World(gravity=(0.0, 0.0, -9.81)), 3, 0.5, 0.4, z=1.0, armature=lambda k: 0.05 * k,
                           torque=lambda k: 0.3 - 0.2 * k, lower=-2.0, upper=2.0)

    whole, resumed = resumed_run(make_world, tmp_path, duration=1.0, dt=DT)
    assert checks.state_hash(resumed.world) == checks.state_hash(whole.world)
    assert resumed.joint_settings == ACCURATE  # the armature's default, carried by the checkpoint


def test_a_checkpoint_of_the_version_before_efforts_and_armature_loads(tmp_path):
    # A checkpoint written before the effort and armature columns (parameter rows of 19 numbers,
    # 11 accumulated-impulse columns), made here by cutting those columns off a new one: it loads
    # with no effort and no armature and resumes bit for bit (the cut columns were zeros).
    import json

    def make_world():
        w = tb.World(gravity=(0.0, 0.0, -9.81))
        bar = w.add_body(tb.Box(size=(0.05, 0.05, 0.4)), mass=0.5, position=(0.2, 0.0, 1.0), euler_deg=(0.0, 90.0, 0.0))
        w.add_joint(HingeJoint(bar, None, anchor=(0.0, 0.0, 1.0), axis=(0.0, 1.0, 0.0), lower=-1.0, upper=1.0,
                               motor_speed=0.5, max_motor_torque=0.1))
        return w

    whole = tb.Simulator(make_world(), dt=DT)
    whole.run(1.0)
    first = tb.Simulator(make_world(), dt=DT)
    first.run(0.5)
    first.save_checkpoint(tmp_path / "new.npz")
    with np.load(tmp_path / "new.npz") as data:
        arrays = {name: data[name] for name in data.files}
    meta = json.loads(str(arrays["meta"]))
    for joint in meta["joints"]:
        joint["bound"]["param"] = joint["bound"]["param"][:19]
        for key in ("torque", "force", "armature"):
            joint.pop(key, None)
    arrays["meta"] = np.array(json.dumps(meta))
    arrays["joint_param"] = arrays["joint_param"][:, :19]
    arrays["joint_axial_impulse"] = arrays["joint_axial_impulse"][:, :11]
    np.savez(tmp_path / "old.npz", **arrays)
    resumed = tb.Simulator.load_checkpoint(tmp_path / "old.npz")
    resumed.run(0.5)
    assert checks.state_hash(resumed.world) == checks.state_hash(whole.world)
