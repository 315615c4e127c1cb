"""A motor or a drive switched off lets go: its stored impulse no longer acts.

Compared with: a free hinge rotor keeps its rate when nothing acts on it (Newton: exact but for
the solver's rounding); a horizontal pendulum let go from rest falls as I theta'' = m g r cos theta,
integrated here by SciPy's DOP853 at rtol 1e-12 (the engine's first-order joint solve at dt 1/240
agrees to about 1 % after 0.1 s: the tolerance is 3 %; a motor or drive still holding it moves it
by under 1e-3 rad, the bug: 0.000 rad). Each case in both joint solvers (Gauss-Seidel, the exact
tree) and by each way of switching off: ``robot.set_motor(sim, j, None)``, a PD target of zero
gains, ``joint.motor_speed = None``. Before session 42 every case failed: the warm start applied
the last impulse of a row that is no longer solved (found by a robotics audit).
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import tumble as tb
from tumble.solver.joints import ACCURATE

URDF = """<robot name="r">
 <link name="base"/>
 <link name="rotor"><inertial><origin xyz="0.2 0 0"/><mass value="2"/>
   <inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial></link>
 <joint name="j" type="continuous"><parent link="base"/><child link="rotor"/><origin xyz="0 0 0.5"/>
   <axis xyz="{axis}"/><limit effort="100" velocity="10"/></joint>
</robot>"""
M, R_COM = 2.0, 0.2
I_Z = 0.03 + M * R_COM ** 2  # about z through the joint, kg m^2
I_Y = 0.02 + M * R_COM ** 2  # about y
SOLVERS = {"gauss-seidel": None, "tree": ACCURATE}


def rotor(tmp_path, axis, solver):
    path = tmp_path / "rotor.urdf"
    path.write_text(URDF.format(axis=axis))
    w = tb.World(gravity=(0, 0, -9.81))
    w.sleeping = False
    robot = tb.load_urdf(w, path, fixed_base=True)
    return robot, tb.Simulator(w, dt=1 / 240, joint_settings=SOLVERS[solver])


def pendulum_fall(duration):
    """theta(duration) of the pendulum about y let go level from rest: I_Y theta'' = m g r
    cos theta (theta measured downwards), DOP853."""
    sol = solve_ivp(lambda t, y: [y[1], M * 9.81 * R_COM * np.cos(y[0]) / I_Y], (0, duration), [0.0, 0.0],
                    method="DOP853", rtol=1e-12, atol=1e-12)
    return sol.y[0, -1]


@pytest.mark.parametrize("solver", SOLVERS)
def test_a_motor_switched_off_at_its_force_limit_stops_pushing(tmp_path, solver):
    """A horizontal rotor driven for one step by a motor at its 100 N m limit, then switched
    off: 1 s later it turns at the rate that step gave it, 100 N m x (1/240 s) / I (3.79 rad/s):
    no torque acts about the axis. To 1e-3 relative: the default soft joint rows take energy out
    of the spinning off-centre rotor (1.1e-4 in this second, docs/joints.md; the tree 6e-8). With
    the motor's impulse left on it reached 328 rad/s."""
    robot, sim = rotor(tmp_path, "0 0 1", solver)
    robot.set_motor(sim, "j", 5.0)
    sim.step(1)
    rate = robot.joint_states(sim)["j"][1]
    assert rate == pytest.approx(100.0 / I_Z / 240, rel=1e-4)  # the hinge's soft rows take ~1e-5 of it
    robot.set_motor(sim, "j", None)
    sim.step(240)
    assert robot.joint_states(sim)["j"][1] == pytest.approx(rate, rel=1e-3)


@pytest.mark.parametrize("solver", SOLVERS)
@pytest.mark.parametrize("how", ["set_motor None", "motor_speed None", "zero PD gains"])
def test_a_pendulum_held_level_falls_when_its_motor_or_drive_is_switched_off(tmp_path, solver, how):
    robot, sim = rotor(tmp_path, "0 1 0", solver)
    if how == "zero PD gains":
        robot.set_position_target(sim, "j", 0.0, stiffness=1e4, damping=100.0)
    else:
        robot.set_motor(sim, "j", 0.0)
    sim.step(240)
    q0 = robot.joint_states(sim)["j"][0]
    assert abs(q0) < 0.05  # held near level
    if how == "set_motor None":
        robot.set_motor(sim, "j", None)
    elif how == "motor_speed None":
        robot.joints["j"].motor_speed = None
    else:
        robot.set_position_target(sim, "j", 0.0, stiffness=0.0, damping=0.0)
    sim.step(24)
    fallen = abs(robot.joint_states(sim)["j"][0] - q0)
    assert fallen == pytest.approx(pendulum_fall(0.1), rel=0.03)


@pytest.mark.parametrize("solver", SOLVERS)
def test_a_position_target_takes_over_from_a_running_motor_and_a_motor_from_a_target(tmp_path, solver):
    """One control mode a joint, as PyBullet's ``setJointMotorControl2``: a horizontal rotor
    turning under ``set_motor(1 rad/s)`` given ``set_position_target(0.2, 50, 5)`` settles at 0.2
    rad (an overdamped PD of the rotor's I = 0.11 kg m^2: its slow pole -14.8 /s leaves e^-44 of
    the error after 3 s; the joint's soft rows: 1e-4 rad). Before, the motor (100 N m) kept
    winning: 1 rad/s after 3 s. Then ``set_motor(-0.5)``: the target gives way, the rotor turns
    at -0.5 rad/s (1e-4: the soft rows)."""
    robot, sim = rotor(tmp_path, "0 0 1", solver)
    robot.set_motor(sim, "j", 1.0)
    sim.step(120)
    robot.set_position_target(sim, "j", 0.2, stiffness=50.0, damping=5.0)
    sim.step(720)
    q, rate = robot.joint_states(sim)["j"]
    assert q == pytest.approx(0.2, abs=1e-4) and abs(rate) < 1e-4
    robot.set_motor(sim, "j", -0.5)
    sim.step(240)
    assert robot.joint_states(sim)["j"][1] == pytest.approx(-0.5, abs=1e-4)


def test_a_motor_switched_off_gives_the_joint_its_friction_back(tmp_path):
    """A URDF joint with ``<dynamics friction="2">`` (a speed-0 motor limited to 2 N m): driven at 5
    rad/s by ``set_motor``, then ``set_motor(None)``: friction slows it at 2 / I rad/s^2 again
    (I = 0.11 kg m^2: 18.2 rad/s^2, from 5 rad/s to 5 - 18.2 x 0.1 after 0.1 s; to 1e-3 rad/s:
    the soft rows). Before, switching the motor off removed the friction too: the rotor spun on
    at 5 rad/s."""
    path = tmp_path / "rotor.urdf"
    path.write_text(URDF.format(axis="0 0 1").replace('<limit effort="100" velocity="10"/>',
                                                      '<limit effort="100" velocity="10"/><dynamics friction="2"/>'))
    w = tb.World(gravity=(0, 0, -9.81))
    w.sleeping = False
    robot = tb.load_urdf(w, path, fixed_base=True)
    sim = tb.Simulator(w, dt=1 / 240, joint_settings=ACCURATE)
    robot.set_motor(sim, "j", 5.0)
    sim.step(240)
    start = robot.joint_states(sim)["j"][1]
    assert start == pytest.approx(5.0, abs=1e-4)
    robot.set_motor(sim, "j", None)
    sim.step(24)
    assert robot.joint_states(sim)["j"][1] == pytest.approx(start - 2.0 / I_Z * 0.1, abs=1e-3)


def test_joint_states_after_a_reset_read_the_robot_at_rest(tmp_path):
    """``reset_joint_positions`` puts every body at rest: ``joint_states`` then reads (7.0, 0.0) for a
    rotor reset to 7 rad while it turned at 5 rad/s (it read the last step's 5 rad/s, as PyBullet's
    getJointState after resetJointState does not); ``kinematics.set_state`` with a qvel reads its
    rate."""
    robot, sim = rotor(tmp_path, "0 0 1", "tree")
    robot.set_motor(sim, "j", 5.0)
    sim.step(240)
    robot.set_motor(sim, "j", None)
    robot.reset_joint_positions(sim, {"j": 7.0})
    assert robot.joint_states(sim)["j"] == pytest.approx((7.0, 0.0), abs=1e-12)
    robot.kinematics.set_state(np.array([1.5]), np.array([-2.0]), sim=sim)
    assert robot.joint_states(sim)["j"] == pytest.approx((1.5, -2.0), abs=1e-12)
