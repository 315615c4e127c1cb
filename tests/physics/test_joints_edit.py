"""Joint records edited after ``World.add_joint`` (``tumble.joints.edit_joint``): a field set on a
bound record (``hinge.damping = 2.0``) acts from the next step, as MuJoCo's model fields and
PyBullet's ``changeDynamics`` do, and wakes the joint's bodies, as Box2D's joint setters do.

Compared with: a record made with the value from the start (the same parameter row and the same
bits: an edit before the first step must be indistinguishable from the constructor's value);
closed-form rest angles of a pendulum under a torque and a spring (``brentq``); an uninterrupted
run (checkpoints and snapshots, bit for bit). Before this change a field set after ``add_joint``
changed nothing and said nothing, and ``Simulator.set_joint_target`` left a sleeping arm where
it was (both checked here)."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import tumble as tb
from tumble import checks
from tumble.joints import (BallJoint, DistanceJoint, FixedJoint, GearJoint, HingeJoint, SliderJoint, UniversalJoint,
                           edit_count)
from tumble.solver.island import ANGULAR_SLEEP_TOLERANCE
from tumble.solver.joints import ACCURATE, JointSolver, step_with_joints

DT = 1 / 240


def two_boxes(gravity=(0.0, 0.0, -9.81)):
    w = tb.World(gravity=gravity)
    w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0.0, 0.0, 1.0), name="a")
    w.add_body(tb.Box(size=(0.2, 0.2, 0.6)), mass=0.5, position=(0.0, 0.0, 0.5), angular_velocity=(0.5, 1.0, 0.0),
               name="b")
    return w


def gear_pair(ratio):
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    w.add_body(tb.Cylinder(0.2, 0.05), mass=1.0, position=(0.0, 0.0, 0.0), angular_velocity=(0, 0, 2.0), name="p")
    w.add_body(tb.Cylinder(0.4, 0.05), mass=2.0, position=(1.0, 0.0, 0.0), name="q")
    w.add_joint(HingeJoint("world", "p", anchor=(0.0, 0.0, 0.0), axis=(0, 0, 1), name="hp"))
    w.add_joint(HingeJoint("world", "q", anchor=(1.0, 0.0, 0.0), axis=(0, 0, 1), name="hq"))
    return w, GearJoint(joint="hq", follows="hp", ratio=ratio)


# (joint type, constructor keywords, field edited, its value): each sets a different column group
EDITS = [
    (HingeJoint, {"axis": (1, 0, 0)}, "damping", 0.7),
    (HingeJoint, {"axis": (1, 0, 0), "lower": -0.2, "upper": 0.3}, "upper", 0.05),
    (HingeJoint, {"axis": (1, 0, 0), "motor_speed": 1.0}, "motor_speed", None),
    (HingeJoint, {"axis": (1, 0, 0)}, "torque", 0.4),
    (HingeJoint, {"axis": (1, 0, 0), "stiffness": 3.0}, "target", 0.5),
    (HingeJoint, {"axis": (1, 0, 0)}, "armature", 0.02),
    (HingeJoint, {"axis": (1, 0, 0)}, "passive_damping", 0.7),
    (HingeJoint, {"axis": (1, 0, 0), "passive_stiffness": 3.0}, "springref", 0.5),
    (SliderJoint, {"axis": (0, 0, 1)}, "passive_stiffness", 40.0),
    (SliderJoint, {"axis": (0, 0, 1)}, "lower", -0.05),
    (BallJoint, {"axis": (0, 0, 1)}, "cone_limit", 0.3),
    (BallJoint, {"axis": (0, 0, 1)}, "twist_upper", 0.2),
    (BallJoint, {"stiffness": 2.0, "damping": 0.1}, "target", (0.0, 0.4, 0.0)),
    (DistanceJoint, {"anchor_b": (0.0, 0.0, 0.6)}, "max_length", 0.45),
    (DistanceJoint, {"anchor_b": (0.0, 0.0, 0.6), "stiffness": 50.0, "min_length": 0.0, "max_length": 1.0},
     "target", None),
    (UniversalJoint, {}, "lower_b", -0.1),
    (HingeJoint, {"axis": (1, 0, 0)}, "max_force", 4.0),
]


@pytest.mark.parametrize("cls, kw, name, value", EDITS, ids=[f"{c.__name__}.{n}" for c, _, n, _ in EDITS])
def test_a_field_set_after_add_joint_is_the_constructors_value(cls, kw, name, value):
    """A record edited after ``add_joint`` (before the first step) has the parameter row of a
    record made with that value, and its run the same bits over 1 s: every column the field
    decides, and only those, reaches the solver."""
    runs = []
    for edited in (False, True):
        w = two_boxes()
        made = dict(kw, **({} if edited else {name: value}))
        j = w.add_joint(cls("a", "b", anchor=(0.0, 0.0, 0.9), **made))
        if edited:
            before = edit_count()
            setattr(j, name, value)
            assert edit_count() == before + 1
            assert getattr(j, name) == value
        w.add_joint(HingeJoint("world", "a", anchor=(0.0, 0.0, 1.0), axis=(0, 1, 0)))
        sim = tb.Simulator(w, dt=DT)
        sim.step(240)
        runs.append((j.bound.param.copy(), checks.state_hash(w)))
    np.testing.assert_array_equal(runs[1][0], runs[0][0])
    assert runs[1][1] == runs[0][1]


def test_an_edit_mid_run_reaches_the_solver_and_the_gear_ratio_too():
    """Between steps: a gear's ratio set from -0.5 to -2 (the follower then turns at -2 times the
    driver's rate, to 1e-3 relative: the soft gear row's residual), the solver's row equal to the
    record's after the next step, through ``step_with_joints`` (no Simulator) as well."""
    w, gear = gear_pair(-0.5)
    w.add_joint(gear)
    solver = JointSolver(ACCURATE)
    for _ in range(60):
        step_with_joints(w, solver, DT, 4)
    assert w.omega[1, 2] / w.omega[0, 2] == pytest.approx(-0.5, rel=1e-3)
    gear.ratio = -2.0
    for _ in range(60):
        step_with_joints(w, solver, DT, 4)
    assert w.omega[1, 2] / w.omega[0, 2] == pytest.approx(-2.0, rel=1e-3)
    np.testing.assert_array_equal(solver.param[2, :11], gear.bound.param[:11])  # (11: G_MASS, the solve's own)


def test_edits_wake_a_sleeping_pendulum_and_it_rests_where_spring_torque_and_gravity_balance():
    """A bar (2 kg, centre d = 0.5 m below its pivot) on a damped hinge, sleeping on, asleep at
    the bottom: its ``stiffness`` and ``target`` fields set (4 N m/rad, 0.6 rad), the next step
    wakes it and it comes to rest at k (target - theta) = m g d sin theta; asleep there,
    ``Simulator.set_joint_target`` (0.3 rad) wakes it again and it rests at the new balance; its
    ``torque`` field set to 3 N m, at tau + k (target - theta) = m g d sin theta (brentq). Asleep,
    a body is frozen where its rate fell under the sleep tolerance: it may stop up to that rate
    over the swing's angular frequency from its balance (8e-3 rad here; measured 3e-3); with no
    sleep (the torque keeps it awake: ``JointSolver.effort_bodies``) to 1e-4 rad. Before this
    change the first two edits left the bar asleep at 0."""
    w = tb.World(gravity=(0.0, 0.0, -9.81))
    bar = w.add_body(tb.Box(size=(0.1, 0.1, 1.0)), mass=2.0, position=(0.0, 0.0, -0.5))
    pivot = w.add_joint(HingeJoint(bar, None, anchor=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0), damping=2.0))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, position=(0, 0, -3.0))  # contacts: the step with sleeping
    sim = tb.Simulator(w, dt=DT)
    mgd, inertia = 2.0 * 9.81 * 0.5, 2.0 * (1.0 / 12.0 + 0.25)  # about the pivot, kg m^2

    def rest(k, target, tau=0.0):
        """(the rest angle, the allowed distance from the balance): the bar stepped 10 s."""
        sim.step(1)
        assert sim.sleep.awake[bar.index]  # woken by the edit
        sim.step(240 * 10)
        theta = brentq(lambda th: tau + k * (target - th) - mgd * math.sin(th), -0.5, 1.5)
        asleep = not sim.sleep.awake[bar.index]
        assert asleep == (tau == 0.0)
        omega_n = math.sqrt((k + mgd * math.cos(theta)) / inertia)
        tolerance = ANGULAR_SLEEP_TOLERANCE / omega_n if asleep else 1e-4
        return sim.joint_readings()["position"][0] - theta, tolerance

    sim.step(240 * 10)
    assert not sim.sleep.awake[bar.index]
    pivot.stiffness = 4.0
    pivot.target = 0.6
    error, tolerance = rest(4.0, 0.6)
    assert abs(error) < tolerance
    sim.set_joint_target(pivot, 0.3)
    error, tolerance = rest(4.0, 0.3)
    assert abs(error) < tolerance
    pivot.torque = 3.0
    error, tolerance = rest(4.0, 0.3, tau=3.0)
    assert abs(error) < tolerance
    assert pivot.torque == 3.0 and pivot.target == 0.3 and pivot.stiffness == 4.0


def test_collide_connected_set_after_add_joint_lets_the_two_bodies_touch():
    """A box on a free vertical slider above a fixed box: with collide_connected False it falls
    through the box below; set True (after add_joint, mid-run) they collide and it rests on top."""
    heights = []
    for collide in (False, True):
        w = tb.World(gravity=(0.0, 0.0, -9.81))
        w.add_body(tb.Box(size=(1.0, 1.0, 1.0)), fixed=True, position=(0.0, 0.0, 0.0), name="base")
        w.add_body(tb.Box(size=(0.4, 0.4, 0.4)), mass=1.0, position=(0.0, 0.0, 1.5), name="top")
        j = w.add_joint(SliderJoint("base", "top", anchor=(0.0, 0.0, 1.5), axis=(0, 0, 1)))
        sim = tb.Simulator(w, dt=DT)
        sim.step(24)
        j.collide_connected = collide
        sim.step(240 * 2)
        heights.append(w.x[1, 2])
    assert heights[0] < -1.0  # fell through
    assert heights[1] == pytest.approx(0.7, abs=2e-3)  # on top (0.5 + 0.2; the contact's softness)


def test_a_bad_value_or_a_fixed_field_is_refused_and_nothing_changes():
    w = two_boxes()
    j = w.add_joint(HingeJoint("a", "b", anchor=(0.0, 0.0, 0.9), axis=(1, 0, 0), damping=0.5, lower=-1.0, upper=1.0))
    row = j.bound.param.copy()
    count = edit_count()
    for name, value, key, problem in (("damping", -1.0, "damping", "must be >= 0"),
                                      ("lower", 2.0, "lower", "the wrong way round"),
                                      ("max_force", math.nan, "max_force", "finite"),
                                      ("collide_connected", "yes", "collide_connected", "true or false"),
                                      ("axis", (0, 1, 0), "axis", "fixed when the joint was added"),
                                      ("body_b", "a", "body_b", "fixed when the joint was added")):
        old = getattr(j, name)
        with pytest.raises(tb.InputError, match=problem) as err:
            setattr(j, name, value)
        assert err.value.key == key
        assert getattr(j, name) == old
    np.testing.assert_array_equal(j.bound.param, row)
    assert edit_count() == count
    j.name = "elbow"  # a label: free
    assert j.name == "elbow"


def test_an_edit_just_before_a_checkpoint_resumes_bit_for_bit(tmp_path):
    """A record edited after the last step and saved at once: the resumed run equals the
    uninterrupted one (the checkpoint carries the row and the wake)."""
    def start():
        w = tb.World(gravity=(0.0, 0.0, -9.81))
        bar = w.add_body(tb.Box(size=(0.1, 0.1, 1.0)), mass=2.0, position=(0.0, 0.0, -0.5))
        w.add_joint(HingeJoint(bar, None, anchor=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0), damping=2.0, name="p"))
        w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, position=(0, 0, -3.0))
        sim = tb.Simulator(w, dt=DT)
        sim.step(240 * 10)  # asleep
        w.joints[0].torque = 3.0
        return sim

    whole = start()
    first = start()
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    assert resumed.world.joints[0].torque == 3.0
    whole.step(240)
    resumed.step(240)
    assert checks.state_hash(resumed.world) == checks.state_hash(whole.world)
    assert whole.joint_readings()["position"][0] > 0.1  # it woke and swung


def test_a_snapshot_restore_puts_the_rows_back_and_drops_the_edits_since():
    """save_state, an edit (a torque), a restore: the run goes on as if the edit was never made
    (MuJoCo's mj_setState restores ctrl; tumble's snapshot restores the joint rows, targets and
    torques included), and the record's row is the restored one."""
    w = two_boxes(gravity=(0.0, 0.0, 0.0))
    j = w.add_joint(HingeJoint("a", "b", anchor=(0.0, 0.0, 0.9), axis=(1, 0, 0)))
    sim = tb.Simulator(w, dt=DT)
    sim.step(24)
    state = sim.save_state()
    sim.step(24)
    after = checks.state_hash(w)
    sim.restore_state(state)
    j.torque = 2.0
    sim.step(1)
    sim.restore_state(state)
    assert j.bound.param[19] == 0.0
    sim.step(24)
    assert checks.state_hash(w) == after


def test_set_motor_speed_keeps_the_record_and_switches_a_motor_on():
    """``JointSolver.set_motor_speed`` writes the record's field too (a checkpoint or a scene saved
    later has it): a hinge without a motor gets one, and the wheel turns at its speed."""
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    w.add_body(tb.Cylinder(0.1, 0.05), mass=2.0, name="wheel")
    j = w.add_joint(HingeJoint("world", "wheel", axis=(0, 0, 1)))
    solver = JointSolver(ACCURATE)
    step_with_joints(w, solver, DT, 4)
    solver.set_motor_speed(j, 3.0)
    assert j.motor_speed == 3.0
    for _ in range(24):
        step_with_joints(w, solver, DT, 4)
    assert w.omega[0, 2] == pytest.approx(3.0, rel=1e-6)


def test_a_joint_switched_off_lets_go_and_switched_on_holds_again():
    """A grasp released (PyBullet's removeConstraint, MuJoCo's eq_active off): a box held by a fixed
    joint to the world, ``joint.broken = True``: it falls freely, z0 - g t^2 / 2 after 0.25 s (1e-6 m:
    the step's integration of constant gravity is exact to round-off; no joint impulse left
    acting) and its readings say disabled from the moment it is set (they said so only after the
    next step before session 39); ``broken = False`` mid-fall: the joint acts again from
    the error it finds and closes it, the anchors together to 1 mm within
    2 s (the soft rows' correction), the box's pose back to the one it was held at."""
    w = tb.World(gravity=(0.0, 0.0, -9.81))
    w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0.0, 0.0, 1.0), name="box")
    grip = w.add_joint(FixedJoint("world", "box", anchor=(0.0, 0.0, 1.0)))
    sim = tb.Simulator(w, dt=DT, joint_settings=ACCURATE)
    sim.step(48)
    z0 = w.x[0, 2]
    assert z0 == pytest.approx(1.0, abs=1e-6)
    grip.broken = True
    assert sim.joint_readings()["enabled"].tolist() == [False]  # at once, not after the next step
    sim.step(60)
    assert sim.joint_readings()["enabled"].tolist() == [False]
    assert w.x[0, 2] == pytest.approx(z0 - 0.5 * 9.81 * 0.25 ** 2, abs=1e-6)
    assert w.v[0, 2] == pytest.approx(-9.81 * 0.25, abs=1e-9)
    grip.broken = False
    assert sim.joint_readings()["enabled"].tolist() == [True]
    sim.step(480)
    assert abs(w.x[0, 2] - 1.0) < 1e-3
    assert sim.joint_readings()["enabled"].tolist() == [True]
    with pytest.raises(tb.InputError, match="true or false"):
        grip.broken = "no"


def test_a_world_with_edited_joints_pickles_and_its_copy_edits_alone():
    """An edited record holds no reference to its world (a World pickles, for process pools, and
    a copy's edits are its own): the unpickled world's run equals the original's bit for bit, and
    an edit of the copy's joint leaves the original's row alone."""
    import pickle

    w = two_boxes()
    j = w.add_joint(HingeJoint("a", "b", anchor=(0.0, 0.0, 0.9), axis=(1, 0, 0)))
    j.damping = 0.3
    copy = pickle.loads(pickle.dumps(w))
    copy.joints[0].damping = 0.9
    assert j.bound.param[7] == 0.3 and copy.joints[0].bound.param[7] == 0.9
    copy.joints[0].damping = 0.3
    for world in (w, copy):
        tb.Simulator(world, dt=DT).step(120)
    assert checks.state_hash(copy) == checks.state_hash(w)


def test_a_resumed_distance_joint_knows_its_length_at_creation(tmp_path):
    """A checkpoint carries a distance joint's anchor distance at creation (``BoundJoint.length``):
    after a load, a rope's lengths set back to None make it the rigid rod of that distance, as in
    the run that saved (the same row and the same bits after 0.5 s)."""
    def start():
        w = two_boxes()
        w.add_joint(DistanceJoint("a", "b", anchor=(0.0, 0.0, 0.9), anchor_b=(0.0, 0.0, 0.6), min_length=0.0,
                                  max_length=0.5, target=0.4))  # (a target given: the row holds no length)
        sim = tb.Simulator(w, dt=DT)
        sim.step(24)
        return sim

    whole, first = start(), start()
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    for sim in (whole, resumed):
        rope = sim.world.joints[0]
        assert rope.bound.length == pytest.approx(0.3, abs=1e-12)
        rope.min_length = None
        rope.max_length = None
        assert rope.bound.param[0] == rope.bound.param[1] == rope.bound.length
        sim.step(120)
    assert checks.state_hash(resumed.world) == checks.state_hash(whole.world)
