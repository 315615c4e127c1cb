"""Joint records (tumble.joints) and the joint solver (tumble.solver.joints) through the
standalone stepper ``step_with_joints``: input errors, each joint type's kinematics,
limits, springs/drives, breaking, reactions, readings."""

import math

import numpy as np
import pytest

import tumble as tb
from tumble.joints import (
    BallJoint,
    DistanceJoint,
    FixedJoint,
    HingeJoint,
    SliderJoint,
    UniversalJoint,
    jointed_body_pairs,
)
from tumble.solver.joints import ACCURATE, JointSettings, JointSolver, step_with_joints

DT = 1 / 240


def world_with(*positions, gravity=(0.0, 0.0, -9.81)):
    w = tb.World(gravity=gravity)
    bodies = [w.add_body(tb.Sphere(0.1), mass=1.0, position=p, name=f"b{i}") for i, p in enumerate(positions)]
    return w, bodies


def run(w, seconds, settings=ACCURATE, dt=DT, substeps=4, each=None):
    solver = JointSolver(settings)
    for k in range(round(seconds / dt)):
        step_with_joints(w, solver, dt, substeps)
        if each is not None:
            each(k, solver)
    return solver


# ---------------------------------------------------------------------- input errors
@pytest.mark.parametrize("joint, key, text", [
    (lambda b: BallJoint("nobody", b[0]), "body_a", "unknown body 'nobody'"),
    (lambda b: BallJoint(b[0], b[0]), "body_b", "two different bodies"),
    (lambda b: BallJoint("world", None), "body_b", "two different bodies"),
    (lambda b: HingeJoint(b[0], axis=(0, 0, 0)), "axis", "zero vector"),
    (lambda b: SliderJoint(b[0], axis=(0, 0, 0)), "axis", "zero vector"),
    (lambda b: HingeJoint(b[0], lower=1.0, upper=-1.0), "lower", "wrong way round"),
    (lambda b: SliderJoint(b[0], lower=0.5, upper=0.1), "lower", "wrong way round"),
    (lambda b: DistanceJoint(b[0], b[1], min_length=2.0, max_length=1.0), "min_length", "wrong way round"),
    (lambda b: BallJoint(b[0], cone_limit=-0.1), "cone_limit", ">= 0"),
    (lambda b: UniversalJoint(b[0], axis=(1, 0, 0), axis_b=(1, 1, 0)), "axis_b", "perpendicular"),
    (lambda b: BallJoint(b[0], frame="local"), "frame", "'world' or 'body'"),
    (lambda b: HingeJoint(b[0], stiffness=-1.0), "stiffness", ">= 0"),
    (lambda b: HingeJoint(b[0], anchor=(0, math.nan, 0)), "anchor", "finite"),
    (lambda b: BallJoint(b[0], max_force=-5.0), "max_force", ">= 0"),
])
def test_bad_input_is_one_clear_line(joint, key, text):
    w, bodies = world_with((0, 0, 0), (1, 0, 0))
    with pytest.raises(tb.InputError) as err:
        w.add_joint(joint(bodies))
    assert err.value.key == key
    assert text in str(err.value)
    assert "\n" not in str(err.value)
    assert w.joints == []


def test_not_a_joint_is_refused():
    w, _ = world_with((0, 0, 0))
    with pytest.raises(tb.InputError):
        w.add_joint("hinge")


def test_the_simulator_refuses_a_projection_it_would_not_run():
    """JointSettings.position_iterations drives only the standalone stepper's NGS projection; the
    Simulator's step has none, so a value other than 0 is refused in one line naming the key
    (before, it was taken and silently did nothing)."""
    w, bodies = world_with((0, 0, 0), (1, 0, 0))
    w.add_joint(BallJoint(bodies[0], bodies[1], anchor=(0.5, 0, 0)))
    with pytest.raises(tb.InputError) as err:
        tb.Simulator(w, joint_settings=JointSettings(position_iterations=3))
    assert err.value.key == "joint_settings.position_iterations"
    assert "does not project" in str(err.value)
    assert "\n" not in str(err.value)
    tb.Simulator(w, joint_settings=JointSettings(position_iterations=0)).step()  # 0 is the default and runs


# ---------------------------------------------------------------------- kinematics per type
def test_body_frame_anchors_equal_world_anchors():
    # the same joint given in world coordinates and in the bodies' frames (joint_grid style)
    w1, (a1, b1) = world_with((0, 0, 0), (0, -1, 0))
    w1.add_joint(BallJoint(a1, b1, anchor=(0, -0.5, 0)))
    w2, (a2, b2) = world_with((0, 0, 0), (0, -1, 0))
    w2.add_joint(BallJoint(a2, b2, anchor=(0, -0.5, 0), anchor_b=(0, 0.5, 0), frame="body"))
    for w in (w1, w2):
        w.body("b0").v = (0.0, 0.0, 0.0)
    np.testing.assert_allclose(w1.joints[0].bound.local_a, w2.joints[0].bound.local_a)
    np.testing.assert_allclose(w1.joints[0].bound.local_b, w2.joints[0].bound.local_b)


def test_slider_moves_along_its_axis_only():
    # a body on a slider to the world along (1, 0, -1)/sqrt 2 slides down it at g sin 45
    # (frictionless incline without rotation): x(t) = 1/2 g/sqrt2 t^2 along the axis
    w, (b,) = world_with((0, 0, 0))
    axis = np.array([1.0, 0.0, -1.0]) / math.sqrt(2)
    w.add_joint(SliderJoint(b, None, anchor=(0, 0, 0), axis=axis))
    q0 = w.q[0].copy()
    solver = run(w, 0.5)
    expected = 0.5 * 9.81 / math.sqrt(2) * 0.5**2
    assert float(w.x[0] @ axis) == pytest.approx(expected, rel=1e-2)
    assert np.linalg.norm(w.x[0] - (w.x[0] @ axis) * axis) < 1e-6
    np.testing.assert_allclose(w.q[0], q0, atol=1e-9)
    # the reading is the displacement of b (the world) relative to a, along the axis
    assert solver.position[0] == pytest.approx(-float(w.x[0] @ axis), rel=1e-9)


def test_fixed_joint_keeps_the_relative_pose():
    w, (a, b) = world_with((0, 0, 1), (0.5, 0.2, 1.3), gravity=(0, 0, 0))
    a.omega = (1.0, 2.0, 0.5)
    a.v = (0.3, 0.0, 0.0)
    w.add_joint(FixedJoint(a, b, anchor=(0.2, 0.1, 1.1)))
    rel0 = w.R[0].T @ w.R[1]
    off0 = w.R[0].T @ (w.x[1] - w.x[0])
    run(w, 1.0)
    np.testing.assert_allclose(w.R[0].T @ w.R[1], rel0, atol=1e-6)
    np.testing.assert_allclose(w.R[0].T @ (w.x[1] - w.x[0]), off0, atol=1e-6)


def test_universal_joint_keeps_its_axes_perpendicular_and_anchors_together():
    w, (a, b) = world_with((0, 0, 0), (0, 0, -1))
    w.add_joint(UniversalJoint(a, None, anchor=(0, 0, 0.5), axis=(1, 0, 0), axis_b=(0, 1, 0)))
    w.add_joint(UniversalJoint(a, b, anchor=(0, 0, -0.5), axis=(1, 0, 0), axis_b=(0, 1, 0)))
    b.v = (1.0, 0.5, 0.0)
    solver = run(w, 1.0)
    Fa = solver.frame_a[1]
    Fb = solver.frame_b[1]
    xa = w.R[0] @ Fa[:, 0]
    yb = w.R[1] @ Fb[:, 1]
    assert abs(float(xa @ yb)) < 1e-6
    gap = w.R[0] @ solver.local_a[1] + w.x[0] - w.R[1] @ solver.local_b[1] - w.x[1]
    assert np.linalg.norm(gap) < 1e-6


def test_rope_is_slack_then_taut():
    # a rope of 1 m from the world anchor to a body 0.5 m below it: free fall for 0.5 m,
    # then the rope holds at 1 m
    w, (b,) = world_with((0, 0, -0.5))
    w.add_joint(DistanceJoint(b, None, anchor=(0, 0, -0.5), anchor_b=(0, 0, 0), min_length=0.0, max_length=1.0))
    z = []
    run(w, 1.0, each=lambda k, s: z.append(w.x[0, 2]))
    t_fall = math.sqrt(2 * 0.5 / 9.81)
    k = round(0.8 * t_fall / DT)
    # falling freely (semi-implicit Euler: within g h t of the parabola)
    assert z[k] == pytest.approx(-0.5 - 0.5 * 9.81 * ((k + 1) * DT) ** 2, abs=3e-3)
    assert min(z) > -1.0 - 1e-3
    assert z[-1] == pytest.approx(-1.0, abs=1e-3)


def test_rigid_rod_keeps_its_length():
    w, (a, b) = world_with((0, 0, 0), (0.7, 0, 0.7), gravity=(0, 0, 0))
    a.v = (0.0, 1.0, 0.0)
    w.add_joint(DistanceJoint(a, b, anchor=(0, 0, 0), anchor_b=(0.7, 0, 0.7)))
    solver = run(w, 1.0)
    assert float(np.linalg.norm(w.x[1] - w.x[0])) == pytest.approx(0.7 * math.sqrt(2), abs=1e-6)
    assert solver.position[0] == pytest.approx(0.7 * math.sqrt(2), abs=1e-6)


# ---------------------------------------------------------------------- limits, springs, drives
def test_hinge_limits_stop_the_swing():
    # a pendulum released from horizontal, limited to [-0.5, 0.5] rad about the hinge
    w, (b,) = world_with((1, 0, 0))
    w.add_joint(HingeJoint("world", b, anchor=(0, 0, 0), axis=(0, 1, 0), lower=-0.5, upper=0.5))
    seen = []
    run(w, 2.0, settings=JointSettings(), each=lambda k, s: seen.append(float(s.position[0])))
    assert min(seen) > -0.5 - 0.02 and max(seen) < 0.5 + 0.02
    assert max(seen) > 0.45  # it reached the limit (gravity pulls to +pi/2)


def test_slider_limit_holds_against_gravity():
    w, (b,) = world_with((0, 0, 0))
    w.add_joint(SliderJoint("world", b, anchor=(0, 0, 0), axis=(0, 0, 1), lower=-0.2, upper=0.2))
    solver = run(w, 1.0, settings=JointSettings())
    assert w.x[0, 2] == pytest.approx(-0.2, abs=5e-3)
    # the lower limit carries the weight: 9.81 N up on the body
    assert solver.readings(0)["force"][2] == pytest.approx(9.81, rel=1e-3)


def test_cone_limit_of_ball_joint():
    # a pendulum on a ball joint hanging straight down (swing 0 at creation), kicked hard
    # sideways: its axis stays within the 30 deg cone about the downward vertical
    w, (b,) = world_with((0, 0, -1))
    b.v = (4.0, 2.0, 0.0)
    w.add_joint(BallJoint("world", b, anchor=(0, 0, 0), axis=(0, 0, -1), cone_limit=math.radians(30)))
    angles = []
    run(w, 2.0, settings=JointSettings(),
        each=lambda k, s: angles.append(math.degrees(math.acos(-w.x[0, 2] / np.linalg.norm(w.x[0])))))
    assert 29.0 < max(angles) < 31.0


def test_slider_spring_oscillates_at_its_natural_frequency():
    # 1 kg on a slider spring k = 100 N/m, no gravity: period 2 pi sqrt(m/k) = 0.628 s
    w, (b,) = world_with((0, 0, 0), gravity=(0, 0, 0))
    w.add_joint(SliderJoint("world", b, anchor=(0, 0, 0), axis=(1, 0, 0), stiffness=100.0, target=0.1))
    xs = []
    run(w, 2.0, each=lambda k, s: xs.append(float(s.position[0])))
    xs = np.array(xs) - 0.1
    idx = np.flatnonzero((xs[:-1] < 0) & (xs[1:] >= 0))
    period = np.mean(np.diff(idx)) * DT
    assert period == pytest.approx(2 * math.pi * math.sqrt(1 / 100.0), rel=0.01)


def test_hinge_pd_drive_reaches_its_target_angle():
    w, (b,) = world_with((1, 0, 0), gravity=(0, 0, 0))
    w.add_joint(HingeJoint("world", b, anchor=(0, 0, 0), axis=(0, 0, 1), stiffness=50.0, damping=10.0,
                           target=math.radians(40)))
    solver = run(w, 3.0)
    assert solver.position[0] == pytest.approx(math.radians(40), abs=1e-3)
    assert math.degrees(math.atan2(w.x[0, 1], w.x[0, 0])) == pytest.approx(40.0, abs=0.1)


def test_set_motor_speed_between_steps():
    w, (b,) = world_with((1, 0, 0), gravity=(0, 0, 0))
    w.add_joint(HingeJoint("world", b, anchor=(0, 0, 0), axis=(0, 0, 1), motor_speed=1.0, name="m"))
    solver = JointSolver(ACCURATE)
    step_with_joints(w, solver, DT, 4)
    assert solver.readings("m")["rate"] == pytest.approx(1.0)
    solver.set_motor_speed("m", -2.0)
    step_with_joints(w, solver, DT, 4)
    assert solver.readings("m")["rate"] == pytest.approx(-2.0)


# ---------------------------------------------------------------------- breaking, pairs, reactions
def test_breakable_joint_breaks_above_max_force():
    w, (a, b) = world_with((0, 0, 0), (0, 0, -1))
    w.add_joint(BallJoint("world", a, anchor=(0, 0, 0)))
    weak = w.add_joint(BallJoint(a, b, anchor=(0, 0, -0.5), max_force=5.0))  # holds 9.81 N: breaks
    assert jointed_body_pairs(w).tolist() == [[0, 1]]
    solver = run(w, 0.5)
    assert weak.broken and not solver.enabled[1]
    assert w.x[1, 2] < -1.5  # fell
    assert jointed_body_pairs(w).shape == (0, 2)
    assert not w.joints[0].broken


def test_reaction_of_a_hanging_body_is_its_weight():
    w, (b,) = world_with((0, 0, -1))
    w.add_joint(BallJoint("world", b, anchor=(0, 0, 0)))
    solver = run(w, 0.5)
    np.testing.assert_allclose(solver.readings(0)["force"], (0, 0, 9.81), atol=1e-6)


def test_jointed_body_pairs_lists_pairs_not_to_collide():
    w, bodies = world_with((0, 0, 0), (1, 0, 0), (2, 0, 0))
    w.add_joint(BallJoint(bodies[2], bodies[1], anchor=(1.5, 0, 0)))
    w.add_joint(BallJoint(bodies[0], bodies[1], anchor=(0.5, 0, 0), collide_connected=True))
    w.add_joint(BallJoint(bodies[0], None, anchor=(0, 0, 0)))
    pairs = jointed_body_pairs(w)
    assert pairs.dtype == np.int64 and pairs.tolist() == [[1, 2]]


@pytest.mark.parametrize("method", ["gauss-seidel", "tree"])
def test_both_methods_keep_a_loop_closed(method):
    # a four-bar loop: three 1 m bars on hinges, both ends on the world; the tree method
    # leaves the loop-closing hinge to Gauss-Seidel. The loop is redundant in 3-D (four
    # parallel hinges), which the soft rows absorb.
    w = tb.World(gravity=(0, 0, -9.81))
    pts = [(0, 0, 0), (0, 0, -1), (1, 0, -1), (1, 0, 0)]
    sizes = [(0.05, 0.05, 1.0), (1.0, 0.05, 0.05), (0.05, 0.05, 1.0)]
    links = [w.add_body(tb.Box(sizes[i]), mass=1.0, position=np.mean([pts[i], pts[i + 1]], axis=0), name=f"l{i}")
             for i in range(3)]
    w.add_joint(HingeJoint("world", links[0], anchor=pts[0], axis=(0, 1, 0)))
    w.add_joint(HingeJoint(links[0], links[1], anchor=pts[1], axis=(0, 1, 0)))
    w.add_joint(HingeJoint(links[1], links[2], anchor=pts[2], axis=(0, 1, 0)))
    w.add_joint(HingeJoint(links[2], "world", anchor=pts[3], axis=(0, 1, 0)))
    links[1].v = (1.0, 0.0, 0.0)
    solver = run(w, 1.0, settings=JointSettings(method=method))
    if method == "tree":
        assert solver.gauss_seidel.sum() == 1
    gap = w.R[2] @ solver.local_a[3] + w.x[2] - solver.local_b[3]
    assert np.linalg.norm(gap) < 2e-3
    # a parallelogram: the coupler stays horizontal while it swings
    assert abs(w.x[1, 0] - 0.5) > 0.02 or np.linalg.norm(w.v[1]) > 0.1
    np.testing.assert_allclose(w.R[1][:, 0], (1, 0, 0), atol=5e-3)


# ---------------------------------------------------------------------- scene files
from tumble.scene_joints import parse_joint_settings, parse_joints


def scene_world():
    w = tb.World()
    w.add_body(tb.Sphere(0.1), mass=1.0, position=(0, 0, -1), name="bob")
    w.add_body(tb.Sphere(0.1), mass=1.0, position=(1, 0, -1), name="bob2")
    return w


def test_parse_joints_builds_each_type():
    w = scene_world()
    entries = [
        {"type": "hinge", "name": "h", "body_a": "bob", "anchor": [0, 0, 0], "axis": [0, 1, 0], "lower_deg": -45,
         "upper_deg": 45, "motor_speed": 1.0, "max_motor_torque": 2.0, "torque": 0.5, "armature": 0.01},
        {"type": "ball", "body_a": "bob", "body_b": "bob2", "anchor": [0.5, 0, -1], "cone_limit_deg": 30},
        {"type": "slider", "body_a": "bob2", "body_b": "world", "axis": [1, 0, 0], "lower": -0.1, "upper": 0.1,
         "force": -2.0, "armature": 3.0},
        {"type": "fixed", "body_a": "bob", "body_b": "bob2", "collide_connected": True},
        {"type": "distance", "body_a": "bob", "body_b": "bob2", "anchor": [0, 0, -1], "anchor_b": [1, 0, -1],
         "min_length": 0.0, "max_length": 1.5, "max_force": float("inf")},
        {"type": "universal", "body_a": "bob", "body_b": "bob2", "anchor": [0.5, 0, -1], "axis": [1, 0, 0],
         "axis_b": [0, 0, 1], "frame": "world"},
    ]
    records = parse_joints(entries, w, "s.toml")
    assert [type(r).__name__ for r in records] == ["HingeJoint", "BallJoint", "SliderJoint", "FixedJoint",
                                                    "DistanceJoint", "UniversalJoint"]
    assert records[0].lower == pytest.approx(-math.pi / 4) and records[1].cone_limit == pytest.approx(math.pi / 6)
    assert (records[0].torque, records[0].armature, records[2].force, records[2].armature) == (0.5, 0.01, -2.0, 3.0)
    assert len(w.joints) == 6 and w.exact_joints  # armature: the Simulator's default is the exact tree solve


@pytest.mark.parametrize("entry, line", [
    ({"body_a": "bob"}, "s.toml: joints[0]: missing key 'type'"),
    ({"type": "hinj", "body_a": "bob"}, "s.toml: joints[0].type: unknown joint type 'hinj'"),
    ({"type": "hinge"}, "s.toml: joints[0]: missing key 'body_a'"),
    ({"type": "hinge", "body_a": "nobody"}, "s.toml: joints[0].body_a: unknown body 'nobody'"),
    ({"type": "hinge", "body_a": "bob", "body_b": "ghost"}, "s.toml: joints[0].body_b: unknown body 'ghost'"),
    ({"type": "hinge", "body_a": "bob", "axis": [0, 0, 0]}, "s.toml: joints[0].axis: must not be the zero vector"),
    ({"type": "hinge", "body_a": "bob", "lower": 1, "upper": 0},
     "s.toml: joints[0].lower: limits the wrong way round: lower 1 > upper 0"),
    ({"type": "hinge", "body_a": "bob", "lower": 0.1, "lower_deg": 5},
     "s.toml: joints[0].lower_deg: give lower or lower_deg, not both"),
    ({"type": "ball", "body_a": "bob", "lower": 0.1}, "s.toml: joints[0].lower: unknown key for a ball joint"),
    ({"type": "slider", "body_a": "bob", "axis": [1, 0]}, "s.toml: joints[0].axis: expected a list of 3 numbers"),
    ({"type": "slider", "body_a": "bob", "stiffness": "stiff"},
     "s.toml: joints[0].stiffness: expected a number, got 'stiff' (a string)"),
    ({"type": "fixed", "body_a": "bob", "body_b": "bob"}, "s.toml: joints[0].body_b: a joint needs two different"),
    ({"type": "fixed", "body_a": "bob", "collide_connected": 1},
     "s.toml: joints[0].collide_connected: expected true or false"),
    ({"type": "distance", "body_a": "bob", "max_length": -1.0},
     "s.toml: joints[0].min_length: limits the wrong way round"),
    ({"type": "ball", "body_a": "bob", "twist_lower": 0.5, "twist_upper": 0.1},
     "s.toml: joints[0].twist_lower: limits the wrong way round: twist_lower 0.5 > twist_upper 0.1"),
    ({"type": "ball", "body_a": "bob", "twist_upper_deg": 200},
     "s.toml: joints[0].twist_upper: must be between -pi and pi, got 3.49066"),
    ({"type": "ball", "body_a": "bob", "twist_lower": -3.5},
     "s.toml: joints[0].twist_lower: must be between -pi and pi, got -3.5"),
    ({"type": "ball", "body_a": "bob", "twist_lower": float("nan")},
     "s.toml: joints[0].twist_lower: must be a finite number, got nan"),
    ({"type": "ball", "body_a": "bob", "twist_upper": float("inf")},
     "s.toml: joints[0].twist_upper: must be a finite number, got inf"),
    ({"type": "ball", "body_a": "bob", "twist_lower": -0.1, "twist_lower_deg": -5},
     "s.toml: joints[0].twist_lower_deg: give twist_lower or twist_lower_deg, not both"),
    ({"type": "hinge", "body_a": "bob", "twist_upper": 0.1}, "s.toml: joints[0].twist_upper: unknown key for a hinge"),
    ({"type": "universal", "body_a": "bob", "lower_b": 0.3, "upper_b": 0.1},
     "s.toml: joints[0].lower_b: limits the wrong way round: lower_b 0.3 > upper_b 0.1"),
    ({"type": "universal", "body_a": "bob", "lower": 0.2, "upper": -0.2},
     "s.toml: joints[0].lower: limits the wrong way round: lower 0.2 > upper -0.2"),
    ({"type": "universal", "body_a": "bob", "upper": 4},
     "s.toml: joints[0].upper: must be between -pi and pi, got 4"),
    ({"type": "universal", "body_a": "bob", "lower_b_deg": -190},
     "s.toml: joints[0].lower_b: must be between -pi and pi, got -3.31613"),
    ({"type": "universal", "body_a": "bob", "upper_b": float("-inf")},
     "s.toml: joints[0].upper_b: must be a finite number, got -inf"),
    ({"type": "universal", "body_a": "bob", "motor_speed_b": "fast"},
     "s.toml: joints[0].motor_speed_b: expected a number, got 'fast' (a string)"),
    ({"type": "universal", "body_a": "bob", "motor_speed_b": 1.0, "max_motor_torque_b": -1.0},
     "s.toml: joints[0].max_motor_torque_b: must be >= 0, got -1"),
    ({"type": "universal", "body_a": "bob", "stiffness": 1.0},
     "s.toml: joints[0].stiffness: unknown key for a universal joint"),
    ({"type": "hinge", "body_a": "bob", "armature": -0.1}, "s.toml: joints[0].armature: must be >= 0, got -0.1"),
    ({"type": "hinge", "body_a": "bob", "torque": float("nan")},
     "s.toml: joints[0].torque: must be a finite number, got nan"),
    ({"type": "slider", "body_a": "bob", "force": "hard"},
     "s.toml: joints[0].force: expected a number, got 'hard' (a string)"),
    ({"type": "hinge", "body_a": "bob", "force": 1.0}, "s.toml: joints[0].force: unknown key for a hinge"),
    ({"type": "ball", "body_a": "bob", "armature": 1.0}, "s.toml: joints[0].armature: unknown key for a ball"),
])
def test_parse_joints_errors(entry, line):
    w = scene_world()
    with pytest.raises(tb.InputError) as err:
        parse_joints([entry], w, "s.toml")
    assert str(err.value).startswith(line), str(err.value)
    assert "\n" not in str(err.value)


def test_parse_joints_refuses_a_non_list_and_duplicate_names():
    w = scene_world()
    with pytest.raises(tb.InputError, match="joints: expected a list of tables"):
        parse_joints({"type": "ball"}, w, "s.toml")
    with pytest.raises(tb.InputError, match=r"joints\[1\].name: duplicate joint name 'j'"):
        parse_joints([{"type": "ball", "body_a": "bob", "name": "j"}, {"type": "ball", "body_a": "bob2", "name": "j"}],
                     w, "s.toml")


def test_parse_joint_settings():
    st = parse_joint_settings({"method": "tree", "hertz": 0, "velocity_iterations": 3}, "s.toml")
    assert st.method == "tree" and st.hertz == 0 and st.velocity_iterations == 3
    with pytest.raises(tb.InputError, match="joint_solver.method"):
        parse_joint_settings({"method": "pgs"}, "s.toml")
    with pytest.raises(tb.InputError, match="joint_solver.relax_iterations: must be a whole number"):
        parse_joint_settings({"relax_iterations": 0}, "s.toml")
    st = parse_joint_settings({"partitions": 1, "partition_min_joints": 0}, "s.toml")
    assert st.partitions == 1 and st.partition_min_joints == 0
    st = parse_joint_settings({"limit_hertz": 120, "limit_damping_ratio": 1}, "s.toml")
    assert st.limit_hertz == 120 and st.limit_damping_ratio == 1
    assert parse_joint_settings({}, "s.toml").limit_hertz == 240  # the tree's limits, soft (docs/joints.md)
    with pytest.raises(tb.InputError, match="joint_solver.limit_hertz: must be >= 0, got -5"):
        parse_joint_settings({"limit_hertz": -5}, "s.toml")
    with pytest.raises(tb.InputError, match="joint_solver.partitions: must be a whole number >= 1"):
        parse_joint_settings({"partitions": 0}, "s.toml")
    with pytest.raises(tb.InputError, match="joint_solver.partition_min_joints: must be a whole number >= 0"):
        parse_joint_settings({"partition_min_joints": 2.5}, "s.toml")


@pytest.mark.parametrize("method", ["gauss-seidel", "tree"])
def test_ragdoll_tree_keeps_its_joints_while_tumbling(method):
    # the ragdoll of examples/joints (11 bodies, a branched tree of ball joints with cone
    # limits and hinges with limits) thrown spinning in free fall, no contact: anchors stay
    # together and the knees stay within their limits
    from pathlib import Path

    from tumble.scene_joints import load_scene_with_joints

    scene, _, _ = load_scene_with_joints(Path(__file__).resolve().parents[2] / "examples/joints/ragdoll_stairs.toml")
    w = scene.world
    moving = np.flatnonzero(w.moving)
    for i in moving:
        r = w.x[i] - w.x[moving].mean(axis=0)
        w.body(int(i)).v = np.cross((2.0, 3.0, 1.0), r)
    solver = JointSolver(JointSettings(method=method))
    knees = []
    for _ in range(120):
        step_with_joints(w, solver, 1 / 60, 4)
        knees.append(solver.position[[7, 9]].copy())
    a, b = solver.joint_a, solver.joint_b
    gap = np.linalg.norm(np.einsum("jkl,jl->jk", w.R[a], solver.local_a) + w.x[a]
                         - np.einsum("jkl,jl->jk", w.R[b], solver.local_b) - w.x[b], axis=1)
    assert gap.max() < 1e-3, gap.max()  # soft rows (60 Hz): measured 2.6e-4 (tree), below 1e-3 (GS)
    knees = np.array(knees)
    assert knees.min() > -0.05 and knees.max() < math.radians(150) + 0.05
    if method == "tree":
        assert not solver.gauss_seidel.any()  # a tree: every joint solved exactly


# ---------------------------------------------------------------------- the fused substeps
@pytest.mark.parametrize("settings", [None, ACCURATE], ids=["soft", "tree"])
def test_joint_substeps_in_one_kernel_give_the_same_bits_as_the_stage_loop(monkeypatch, settings):
    # A step with joints and no contacts runs its substeps in one compiled call
    # (soft_step.substeps_kernel: the same kernels in the same order as SoftStep.step's loop).
    # Compared with that loop (JointSolver.fusable forced off) on a chain that uses every kind of
    # row: a hinge with limits (struck) and a motor, a hinge and a slider with PD drives, armature
    # and applied efforts, a ball joint with a cone limit, a spring and drag (compiled forces), with
    # either joint method (the tree's extra limit sweeps included): the states and readings must be
    # equal bit for bit.
    from tumble.solver import soft_step

    def build():
        w = tb.World(gravity=(0.0, 0.0, -9.81))
        w.collisions = False
        a = w.add_body(tb.Box(size=(0.4, 0.1, 0.1)), mass=1.0, position=(0.2, 0, 1), name="a")
        b = w.add_body(tb.Box(size=(0.4, 0.1, 0.1)), mass=2.0, position=(0.6, 0, 1), name="b")
        c = w.add_body(tb.Sphere(0.1), mass=0.5, position=(0.9, 0, 1), name="c")
        d = w.add_body(tb.Sphere(0.1), mass=0.5, position=(0.9, 0, 0.6), name="d")
        w.add_joint(HingeJoint("world", a, anchor=(0, 0, 1), axis=(0, 1, 0), lower=-0.6, upper=0.4,
                               motor_speed=1.5, max_motor_torque=3.0))
        w.add_joint(HingeJoint(a, b, anchor=(0.4, 0, 1), axis=(0, 1, 0), stiffness=20.0, damping=0.5, target=0.3,
                               armature=0.05, torque=0.4))
        w.add_joint(SliderJoint(b, c, axis=(1, 0, 0), lower=-0.05, upper=0.1, stiffness=50.0, damping=1.0,
                                armature=0.2, force=-0.5))
        w.add_joint(BallJoint(c, d, anchor=(0.9, 0, 0.8), cone_limit=0.5))
        w.add_force(tb.Spring(body_a=d, anchor_a=(0, 0, 0), body_b=None, anchor_b=(1.5, 0.5, 0.2), stiffness=30.0, damping=0.5))
        w.add_force(tb.Drag(linear=0.1, angular_linear=0.01))
        return w

    fused_calls = []
    original = soft_step.SoftStep._fused_substeps

    def counted(self, *args):
        fused_calls.append(1)
        return original(self, *args)

    monkeypatch.setattr(soft_step.SoftStep, "_fused_substeps", counted)
    runs = []
    for fusable in (True, False):
        if not fusable:
            monkeypatch.setattr(JointSolver, "fusable", lambda self: False)
        w = build()
        sim = tb.Simulator(w, dt=DT, joint_settings=settings)
        sim.step(240)
        runs.append((w.pack().tobytes(), {k: v.tobytes() for k, v in sim.joint_readings().items()}))
        if fusable:
            assert len(fused_calls) == 240  # every step took the fused substeps
    assert runs[0] == runs[1]


@pytest.mark.parametrize("example", ["dominoes", "bowling", "marbles", "platforms", "conveyor", "robot_arm",
                                     "terrain", "joints/ragdoll_stairs", "joints/chain_over_box"])
def test_substeps_in_one_kernel_give_the_same_bits_as_the_stage_loop_with_contacts(monkeypatch, example):
    # The fused substeps (soft_step.substeps_kernel) with contacts too: against SoftStep.step's
    # stage loop (SoftStep.fuse off) on example scenes that between them use boxes, hulls,
    # compounds, meshes and a heightfield, restitution, rolling resistance, kinematic bodies, a
    # conveyor's surface velocity and sensors, joints with contacts (a robot arm on the tree solve,
    # ragdolls, a chain over a box) and sleeping: 1 s of each, the states equal bit for bit.
    from tumble.solver import soft_step

    runs = []
    for fuse in (True, False):
        monkeypatch.setattr(soft_step.SoftStep, "fuse", fuse)
        scene = tb.load_scene(f"examples/{example}.toml")
        sim = scene.simulator()
        sim.step(int(round(1.0 / sim.dt)))
        runs.append(scene.world.pack().tobytes())
    assert runs[0] == runs[1]
