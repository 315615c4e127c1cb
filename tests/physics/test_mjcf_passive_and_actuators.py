"""An MJCF joint's own passive forces (``damping``, ``stiffness`` towards ``springref``) beside the
actuators that drive it (``<position>``, ``<velocity>``, biased ``<general>``): in MuJoCo they act in
addition to the actuator's force. tumble's joint has both: the drive (kp, kv to the controls'
target, capped by the ``forcerange``) and its passive spring-damper (``passive_stiffness``,
``passive_damping`` to ``springref``, uncapped), solved as one row whose cap holds the drive's
share alone (``joint_solve._drive_and_passive``). Before session 42 the actuator's kp and kv took
the joint's drive fields and the joint's own spring and damper were dropped (robot audit, item 3:
a servo on a joint with damping 1 rang undamped; a velocity actuator reached ctrl instead of kv
ctrl / (kv + c)); in session 42 they were summed into the drive, whose cap then held them too (a
saturated servo lost its joint's damper: ``test_a_saturated_servo_keeps_its_joints_damper``).

Each model is compared with two references: MuJoCo's own simulation of the same file (RK4 at
dt 1/4000 s: 1e-12 from the closed form here, measured) and the closed form of the same linear equation
I q'' = -K (q - target) - C q' + F (``exact``: the matrix exponential of the state equation, exact
for piecewise constant controls), plus the settling value or steady velocity of the audit's table.
tumble steps at dt 1/240 s with the tree solve (``ACCURATE``), first order: its measured error is
given in each test, and the tolerance is about 2x it. The hinge turns about the vertical (gravity
does no work on it): I = 0.01 + 1 x 0.5^2 = 0.26 kg m^2.
"""

import math

import numpy as np
import pytest
from scipy.linalg import expm

import tumble as tb
from tumble.joints import (P_DAMPING, P_EFFORT, P_MAX_DRIVE, P_MAX_MOTOR, P_MOTOR_ON, P_MOTOR_SPEED, P_PASSIVE_DAMPING,
                           P_PASSIVE_STIFFNESS, P_SPRINGREF, P_STIFFNESS, P_TARGET, P_TARGET_RATE)
from tumble.solver.joints import ACCURATE

mujoco = pytest.importorskip("mujoco")

I_HINGE = 0.26  # kg m^2 about the hinge: 0.01 + 1 kg x (0.5 m)^2
DT = 1 / 240
SAMPLE = 0.05  # s between compared samples

MODEL = """
<mujoco model="passive">
  <option timestep="0.00025" integrator="RK4" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="h" type="{kind}" axis="{axis}" {joint}/>
      <inertial pos="0.5 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>
    </body>
  </worldbody>
  <actuator>{actuator}</actuator>
</mujoco>
"""


def model(tmp_path, joint, actuator, kind="hinge", axis="0 0 1"):
    path = tmp_path / "model.xml"
    path.write_text(MODEL.format(joint=joint, actuator=actuator, kind=kind, axis=axis))
    return path


def run_both(path, schedule, seconds):
    """(times (n,), MuJoCo's (q, q') (n, 2), tumble's (q, q') (n, 2), the Robot) every SAMPLE s of
    the file run by both engines with the controls of ``schedule`` [(time, ctrl of actuator "a")]
    (MuJoCo's data.ctrl, tumble's ``set_controls``, from that time on)."""
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    world = tb.World(gravity=(0, 0, -9.81))
    world.sleeping = False
    robot = tb.load_mjcf(world, path)
    sim = tb.Simulator(world, dt=DT, joint_settings=ACCURATE)
    changes = dict(schedule)
    times, ref, got = [], [], []
    for k in range(int(round(seconds / SAMPLE))):
        t = k * SAMPLE
        for at, ctrl in changes.items():
            if abs(at - t) < 1e-9:
                d.ctrl[0] = ctrl
                robot.set_controls(sim, {"a": ctrl})
        mujoco.mj_step(m, d, nstep=int(round(SAMPLE / m.opt.timestep)))
        sim.step(int(round(SAMPLE / DT)))
        times.append(t + SAMPLE)
        ref.append((d.qpos[0], d.qvel[0]))
        got.append(robot.joint_states(sim)["h"][:2])
    return np.array(times), np.array(ref), np.array(got), robot


def exact(times, inertia, phases):
    """(q, q') (n, 2) at ``times`` of inertia q'' = -K q - C q' + F from rest at q = 0, with
    ``phases`` [(start time, K, C, F)] (piecewise constant): the state equation's matrix
    exponential, exact (the closed form of the report's table, at every sample)."""
    out = []
    for t in times:
        z = np.array([0.0, 0.0, 1.0])
        for i, (start, K, C, F) in enumerate(phases):
            end = min(t, phases[i + 1][0] if i + 1 < len(phases) else math.inf)
            if end <= start:
                break
            M = np.array([[0.0, 1.0, 0.0], [-K / inertia, -C / inertia, F / inertia], [0.0, 0.0, 0.0]])
            z = expm(M * (end - start)) @ z
        out.append(z[:2])
    return np.array(out)


def test_a_position_servo_on_a_damped_joint_settles_as_mujocos_does(tmp_path):
    """The audit's model B: joint ``damping="1"``, ``<position kp="10">`` (kv 0), ctrl 1. MuJoCo's
    joint damping acts beside the servo: q settles at 1 with the time constant 2 I / c = 0.52 s
    (MuJoCo 1.0001 at 4 s). tumble before: no damping at all, the arm rang between 0 and 2 (0.194 at
    4 s, 0.9 off). Measured at dt 1/240: 8.3e-3 rad from MuJoCo's RK4 and from the closed form over
    4 s (2.1e-3 at 1/960: first order), 1.5e-4 rad from 1 at 4 s; the reference and the closed form
    agree to 7e-14. Tolerances 1.5e-2 rad (the swing), 1e-3 rad (the settled value: the closed
    form's own transient left at 4 s is 1.4e-4 rad, under exp(-4 / 0.52) = 4.6e-4 of the step)."""
    path = model(tmp_path, 'damping="1"', '<position name="a" joint="h" kp="10"/>')
    times, ref, got, robot = run_both(path, [(0.0, 1.0)], 4.0)
    closed = exact(times, I_HINGE, [(0.0, 10.0, 1.0, 10.0)])
    assert np.abs(ref[:, 0] - closed[:, 0]).max() < 1e-9
    assert np.abs(got[:, 0] - ref[:, 0]).max() < 1.5e-2
    assert np.abs(got[:, 0] - closed[:, 0]).max() < 1.5e-2
    assert got[-1, 0] == pytest.approx(1.0, abs=1e-3)
    row = robot.joints["h"].bound.param
    assert (row[P_STIFFNESS], row[P_DAMPING], row[P_TARGET]) == (10.0, 0.0, 1.0)  # the servo's drive
    assert (row[P_PASSIVE_STIFFNESS], row[P_PASSIVE_DAMPING]) == (0.0, 1.0)  # the joint's own damper


def test_a_servo_and_the_joints_spring_pull_to_their_weighted_mean_as_mujocos_do(tmp_path):
    """The audit's model C: joint ``damping="1" stiffness="10" springref="1"`` (degrees),
    ``<position kp="10" kv="0.5">``, ctrl 0, then 0.5 rad from 2 s (``set_controls`` recomputes the
    target). MuJoCo: the spring and the servo pull to (k springref + kp ctrl) / (k + kp): 10 x
    0.01745 / 20 = 0.00873 rad (the report's table), then 0.2587 rad, damped by c + kv = 1.5.
    tumble before: q = 0 exactly (the spring dropped; it rang about 0.25 after the switch, 0.51
    off). Measured at dt 1/240: 2.8e-3 rad from MuJoCo's RK4 over 4 s (7.1e-4 at 1/960: first
    order), the same from the closed form; 2.2e-5 rad from the settled 0.00873 at 2 s, 6.5e-4 rad
    from the settled 0.2587 at 4 s. Tolerances 6e-3 rad over the run, 5e-4 rad at 2 s and 2e-3 at
    4 s (the closed form's own transient left then: 2.5e-5 and 7.2e-4 rad)."""
    path = model(tmp_path, 'damping="1" stiffness="10" springref="1"',
                 '<position name="a" joint="h" kp="10" kv="0.5"/>')
    times, ref, got, robot = run_both(path, [(0.0, 0.0), (2.0, 0.5)], 4.0)
    k, r, kp = 10.0, math.radians(1.0), 10.0
    closed = exact(times, I_HINGE, [(0.0, k + kp, 1.5, k * r), (2.0, k + kp, 1.5, k * r + kp * 0.5)])
    assert np.abs(ref[:, 0] - closed[:, 0]).max() < 1e-9
    assert np.abs(got[:, 0] - ref[:, 0]).max() < 6e-3
    assert np.abs(got[:, 0] - closed[:, 0]).max() < 6e-3
    settled = int(np.argmin(np.abs(times - 2.0)))  # the sample at 2 s, before the switch
    assert got[settled, 0] == pytest.approx(k * r / (k + kp), abs=5e-4)  # 0.00873: the table's
    assert got[-1, 0] == pytest.approx((k * r + kp * 0.5) / (k + kp), abs=2e-3)
    row = robot.joints["h"].bound.param
    assert (row[P_STIFFNESS], row[P_DAMPING], row[P_TARGET]) == (10.0, 0.5, 0.5)  # the servo's, at ctrl 0.5
    assert (row[P_PASSIVE_STIFFNESS], row[P_PASSIVE_DAMPING]) == (10.0, 1.0)
    assert row[P_SPRINGREF] == pytest.approx(r, rel=1e-14)


def test_a_velocity_actuator_on_a_damped_joint_reaches_mujocos_steady_rate(tmp_path):
    """The audit's model D: joint ``damping="1"``, ``<velocity kv="2">``, ctrl 3: kv (ctrl - v) = c v
    at the steady rate v = kv ctrl / (kv + c) = 2 rad/s (MuJoCo 2.000), reached as 2 (1 - exp(-(kv
    + c) t / I)). tumble before: 3.000 rad/s (the joint's damper dropped). And the audit's model E
    (a ``<motor>``, ctrl 1, on the same damped joint: rate ctrl / c = 1), which was right before
    and stays so. Measured at dt 1/240: the rate 4.4e-3 rad/s and the angle 3.8e-4 rad from
    MuJoCo's RK4 over 4 s (1.1e-3, 9.5e-5 at 1/960: first order), the same from the closed form;
    before, the angle 3.8 rad off. Tolerances 1e-2 rad/s, 1e-3 rad over the run, 1e-6 rad/s at 4 s
    (the closed form's transient left: exp(-46) of it; tumble's implicit damper reaches the same
    fixed point)."""
    path = model(tmp_path, 'damping="1"', '<velocity name="a" joint="h" kv="2"/>')
    times, ref, got, _ = run_both(path, [(0.0, 3.0)], 4.0)
    closed = exact(times, I_HINGE, [(0.0, 0.0, 3.0, 6.0)])
    assert np.abs(ref - closed).max() < 1e-9
    assert np.abs(got[:, 1] - ref[:, 1]).max() < 1e-2 and np.abs(got[:, 0] - ref[:, 0]).max() < 1e-3
    assert np.abs(got[:, 1] - closed[:, 1]).max() < 1e-2
    assert got[-1, 1] == pytest.approx(2.0 * 3.0 / (2.0 + 1.0), abs=1e-6)  # kv ctrl / (kv + c): the table's 2
    motor = model(tmp_path, 'damping="1"', '<motor name="a" joint="h"/>')
    times, ref, got, _ = run_both(motor, [(0.0, 1.0)], 4.0)
    assert np.abs(got[:, 1] - ref[:, 1]).max() < 1e-2
    assert got[-1, 1] == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("case", ["general", "dampratio", "velocity_spring", "forcerange"])
def test_biased_general_dampratio_and_capped_servos_add_the_joints_spring_and_damper(tmp_path, case):
    """The other ways a drive reaches the joint, each against MuJoCo's RK4 and the closed form:
    a biased ``<general>`` with gear 2 on a slide (stiffness gear^2 10 = 40, damping 4, target
    gear (10 ctrl + 0.5) / 40) beside the slide's spring (20 N/m to 0.1 m) and damper (3 N s/m):
    it settles at (20 x 0.1 + 40 x 0.175) / 60 = 0.15 m; a position servo's ``dampratio`` (kv from
    the inertia at qpos0, ``resolve_dampratios``, then the joint's damping added: it wrote the
    actuators' alone before); a velocity actuator on a joint with a spring (the spring kept, its
    target springref: the velocity actuator's drive had stiffness 0 before); a servo whose
    ``forcerange`` it never reaches (reached: ``test_a_saturated_servo_keeps_its_joints_damper``). Measured at dt
    1/240 from MuJoCo's RK4 and the closed form: 1.1e-3 m, 6.4e-4 rad, 4.7e-4 rad, 5.8e-3 rad over
    4 s (first order: a quarter at 1/960); before, off by 0.061 m, 0.099, 3.5 and 0.18 rad.
    Tolerances about 2x; the settled values to 1e-4 (measured 1e-6). And the joint record's
    fields say what its solver row holds (the controls' target and effort, the dampratio's
    damping: written into the row alone before)."""
    if case == "general":
        path = model(tmp_path, 'damping="3" stiffness="20" springref="0.1"',
                     '<general name="a" joint="h" gear="2" gainprm="10" biastype="affine" biasprm="0.5 -10 -1"/>',
                     kind="slide", axis="1 0 0")
        ctrl, phases, tol, settled = 0.3, [(0.0, 60.0, 7.0, 20 * 0.1 + 2 * (10 * 0.3 + 0.5))], 2.5e-3, 0.15
        inertia = 1.0
    elif case == "dampratio":
        path = model(tmp_path, 'damping="2" stiffness="50" springref="0.2"',
                     '<position name="a" joint="h" kp="30" dampratio="0.3"/>')
        kv = 2 * 0.3 * math.sqrt(30 * I_HINGE)
        r = math.radians(0.2)
        ctrl, phases, tol, settled = -0.1, [(0.0, 80.0, 2.0 + kv, 50 * r - 30 * 0.1)], 1.5e-3, (50 * r - 3.0) / 80
        inertia = I_HINGE
    elif case == "velocity_spring":
        path = model(tmp_path, 'damping="1" stiffness="5" springref="0.3"', '<velocity name="a" joint="h" kv="2"/>')
        r = math.radians(0.3)
        ctrl, phases, tol, settled = 1.0, [(0.0, 5.0, 3.0, 5 * r + 2.0)], 1e-3, None
        inertia = I_HINGE
    else:
        path = model(tmp_path, 'damping="0.5" stiffness="5" springref="6"',
                     '<position name="a" joint="h" kp="20" kv="1" forcerange="-100 100"/>')
        r = math.radians(6.0)
        ctrl, phases, tol, settled = 0.5, [(0.0, 25.0, 1.5, 5 * r + 20 * 0.5)], 1.2e-2, (5 * r + 10.0) / 25
        inertia = I_HINGE
    times, ref, got, robot = run_both(path, [(0.0, ctrl)], 4.0)
    closed = exact(times, inertia, phases)
    assert np.abs(ref[:, 0] - closed[:, 0]).max() < 1e-9
    assert np.abs(got[:, 0] - ref[:, 0]).max() < tol
    assert np.abs(got[:, 0] - closed[:, 0]).max() < tol
    if settled is not None:
        assert got[-1, 0] == pytest.approx(settled, abs=1e-4)
    row = robot.joints["h"].bound.param  # the drive and the passive spring-damper: the equation's K and C
    assert row[P_STIFFNESS] + row[P_PASSIVE_STIFFNESS] == pytest.approx(phases[0][1], rel=1e-12)
    assert row[P_DAMPING] + row[P_PASSIVE_DAMPING] == pytest.approx(phases[0][2], rel=1e-12)
    # the record's fields say what its row holds (``Robot._write``: the record says what acts; the
    # controls' target and effort and the dampratio's damping were written into the row alone)
    record = robot.joints["h"]
    effort = record.force if case == "general" else record.torque
    assert (record.stiffness, record.damping, record.target, effort) == \
        (row[P_STIFFNESS], row[P_DAMPING], row[P_TARGET], row[P_EFFORT])


def test_joint_targets_keep_the_callers_drive_over_a_dampratio_servo(tmp_path):
    """``load_mjcf(joint_targets=)`` on a joint that a ``dampratio`` servo drives: the caller's drive
    (stiffness, damping, target) stays whole, as the module docstring says; before,
    ``resolve_dampratios`` wrote the actuator's damping over the caller's (here 0.9 became 1.68)."""
    path = model(tmp_path, 'damping="2"', '<position name="a" joint="h" kp="30" dampratio="0.3"/>')
    robot = tb.load_mjcf(tb.World(), path, joint_targets={"h": {"position": 0.3, "stiffness": 7.0, "damping": 0.9}})
    row = robot.joints["h"].bound.param
    assert (row[P_STIFFNESS], row[P_DAMPING], row[P_TARGET]) == (7.0, 0.9, 0.3)


@pytest.mark.parametrize("case", ["damped", "undamped_servo", "spring"])
def test_a_saturated_servo_keeps_its_joints_damper(tmp_path, case):
    """A servo that reaches its ``forcerange``: MuJoCo caps the actuator's force alone and the
    joint's damper and spring act on, uncapped. Swinging the arm from 0 to ctrl 1 rad: ``damped``
    (kp 200, kv 20, cap 5 N m, joint damping 1), ``undamped_servo`` (kp 200, no kv, cap 1 N m:
    the joint's damper is all that settles it), ``spring`` (kp 100, kv 5, cap 2 N m, joint damping
    0.5 and a spring of 4 N m/rad to -20 deg that the servo cannot overcome: it stops where the
    spring's pull and the cap meet, and swings there). Compared with MuJoCo's RK4 of the same file
    over 3 s. Measured at dt 1/240: 1.8e-3, 7.1e-3 and 9.4e-4 rad at most (at 1/960: 4.8e-4, 2.1e-3,
    2.4e-4: first order). Before (session 42: the cap held the drive and the passive terms summed):
    0.17 rad ahead at 0.3 s, 0.92 rad off (the arm swung on where MuJoCo's settled) and 1.3 rad off
    (the spring lost under saturation). Tolerances about 2x the measured."""
    joint, actuator, tol = {
        "damped": ('damping="1"', '<position name="a" joint="h" kp="200" kv="20" forcerange="-5 5"/>', 4e-3),
        "undamped_servo": ('damping="1"', '<position name="a" joint="h" kp="200" forcerange="-1 1"/>', 1.5e-2),
        "spring": ('damping="0.5" stiffness="4" springref="-20"',
                   '<position name="a" joint="h" kp="100" kv="5" forcerange="-2 2"/>', 2e-3),
    }[case]
    times, ref, got, robot = run_both(model(tmp_path, joint, actuator), [(0.0, 1.0)], 3.0)
    assert np.abs(got[:, 0] - ref[:, 0]).max() < tol
    row = robot.joints["h"].bound.param
    # the drive holds the servo's kv, the passive columns the joint's damper
    kv, c = {"damped": (20.0, 1.0), "undamped_servo": (0.0, 1.0), "spring": (5.0, 0.5)}[case]
    assert (row[P_DAMPING], row[P_PASSIVE_DAMPING]) == (kv, c)


def test_set_controls_after_set_motor_gives_the_joint_back_to_its_servo(tmp_path):
    """One control mode a joint: ``set_motor`` takes a servoed joint (its drive off, the joint's
    passive damper kept), and a later ``set_controls`` gives it back to its actuator (the file's
    drive written back, the motor off). The servo kp 10 on a joint with damping 1 then settles at
    its ctrl 0.5 as MuJoCo's does (time constant 2 I / c = 0.52 s: 5e-4 of the step left after 4 s,
    tolerance 2e-3 rad), the row's drive that of the load. Before: the ctrl went into the motor's
    drive of stiffness 0 and the motor ran on at 2 rad/s (the arm 10 rad away after 4 s)."""
    path = model(tmp_path, 'damping="1"', '<position name="a" joint="h" kp="10"/>')
    world = tb.World(gravity=(0, 0, -9.81))
    world.sleeping = False
    robot = tb.load_mjcf(world, path)
    loaded = robot.joints["h"].bound.param.copy()
    sim = tb.Simulator(world, dt=DT, joint_settings=ACCURATE)
    robot.set_motor(sim, "h", 2.0, max_force=50.0)
    sim.step(240)
    assert robot.joint_states(sim)["h"][1] == pytest.approx(2.0, abs=1e-6)  # the motor's, against the damper
    robot.set_controls(sim, {"a": 0.5})
    sim.step(4 * 240)
    assert robot.joint_states(sim)["h"][0] == pytest.approx(0.5, abs=2e-3)
    row = robot.joints["h"].bound.param.copy()
    assert row[P_MOTOR_ON] == 0.0  # (its speed and limit columns are left as set_motor wrote them: read when on)
    loaded[P_TARGET] = 0.5
    row[[P_MOTOR_SPEED, P_MAX_MOTOR]] = loaded[[P_MOTOR_SPEED, P_MAX_MOTOR]]
    np.testing.assert_array_equal(row, loaded)


def test_a_callers_motor_on_a_servoed_joint_stays_on_at_load_and_after_set_controls(tmp_path):
    """``load_mjcf(joint_motors=)`` on a joint a servo drives: the motor the caller gave stays on
    through the load's controls at 0 and a later ``set_controls`` (which writes back the drive as
    loaded, motor included); an earlier form of that write-back put the file's friction motor (none)
    in its place."""
    path = model(tmp_path, 'damping="1"', '<position name="a" joint="h" kp="10"/>')
    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_mjcf(world, path, joint_motors={"h": {"speed": 1.5, "max_force": 5.0}})
    sim = tb.Simulator(world, dt=DT, joint_settings=ACCURATE)
    for _ in range(2):
        row = robot.joints["h"].bound.param
        assert (row[P_MOTOR_ON], row[P_MOTOR_SPEED], row[P_MAX_MOTOR]) == (1.0, 1.5, 5.0)
        assert robot.joints["h"].motor_speed == 1.5
        robot.set_controls(sim, {"a": 0.2})


@pytest.mark.parametrize("gear", [1.0, 2.0])
def test_a_velocity_actuator_with_a_forcerange_is_clipped_whole_as_mujocos(tmp_path, gear):
    """``<velocity kv="2" forcerange="-0.3 0.3">`` on a joint with damping 0.5: MuJoCo's force
    kv (ctrl - gear q') clipped whole to the range, the joint's damper beside it. On tumble's joint
    a drive of damping gear^2 kv pulling to the target velocity ctrl / gear, capped at gear x 0.3
    (``P_TARGET_RATE``), the damper its passive one. ctrl 3 for 2 s: saturated throughout (the
    damper holds the rate at gear 0.3 / 0.5), then ctrl 0.2: saturated the other way until the law
    takes over. Compared with MuJoCo's RK4 of the same file over 4 s: measured 1.2e-4 / 3.7e-4 rad
    and 4.2e-4 / 8.3e-4 rad/s at dt 1/240 (gear 1 / 2; first order: a quarter at 1/960);
    tolerances about 2.5x. Refused before (the drive had no target velocity: an effort beside a
    damper could not be clipped whole)."""
    path = model(tmp_path, 'damping="0.5"', f'<velocity name="a" joint="h" kv="2" gear="{gear:g}" forcerange="-0.3 0.3"/>')
    times, ref, got, robot = run_both(path, [(0.0, 3.0), (2.0, 0.2)], 4.0)
    tol_q, tol_v = {1.0: (3e-4, 1e-3), 2.0: (9e-4, 2e-3)}[gear]
    assert np.abs(got[:, 0] - ref[:, 0]).max() < tol_q
    assert np.abs(got[:, 1] - ref[:, 1]).max() < tol_v
    row = robot.joints["h"].bound.param
    assert (row[P_DAMPING], row[P_PASSIVE_DAMPING], row[P_MAX_DRIVE]) == (gear * gear * 2.0, 0.5, gear * 0.3)
    assert row[P_TARGET_RATE] == pytest.approx(0.2 / gear, rel=1e-15)
    assert robot.joints["h"].target_velocity == row[P_TARGET_RATE]
