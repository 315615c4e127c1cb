"""Checkpoints and resume of worlds with joints (issue 6 for issue 4's joints): the joint records
(bound as at their creation, ``broken`` kept), the joint solver's warm start and coordinates, and
the joint settings survive ``save_checkpoint`` / ``load_checkpoint`` and ``tumble run --resume``,
so a resumed run is bit-identical to an uninterrupted one.

Every comparison is exact (``np.array_equal``, state hashes, file bytes): a resume runs the same
kernels on the same bits, so any difference at all means something was not restored.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import tumble as tb
from tumble import checkpoint
from tumble.checks import state_hash
from tumble.cli import main as cli_main
from tumble.solver.joints import JointSettings, JointSolver

STATE = ("x", "q", "R", "P", "L")
WARM_START = ("linear_impulse", "angular_impulse", "axial_impulse")
STEPS = 192  # 0.8 s at dt = 1/240; the checkpoint is at 0.4 s
BREAKER = 5  # index of the breakable joint in joint_world()


def joint_world():
    """A hinge chain hung from the world (a motor at the top, a limited hinge, a driven ball joint at
    the end) falling onto a box that rests on the ground, a slider on a spring, and a hinge pendulum
    whose joint breaks at about 0.2 s (max_force 15 N; the tension at the bottom would be 3 m g)."""
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground", material=tb.Material(friction=0.5))
    w.add_body(tb.Box(size=(0.6, 0.6, 0.4)), mass=3.0, position=(0.5, 0, 0.2), name="box")
    for i in range(3):
        w.add_body(tb.Box(size=(0.2, 0.06, 0.06)), mass=0.3, position=(0.1 + 0.2 * i, 0, 0.55), name=f"link{i}")
    w.add_body(tb.Sphere(radius=0.05), mass=0.5, position=(-1, 0, 1), name="slider")
    w.add_body(tb.Sphere(radius=0.05), mass=1.0, position=(-0.5, 1, 1), name="bob")
    w.add_joint(tb.HingeJoint("link0", None, anchor=(0, 0, 0.55), axis=(0, 1, 0), motor_speed=0.5,
                              max_motor_torque=0.5, name="shoulder"))
    w.add_joint(tb.HingeJoint("link0", "link1", anchor=(0.2, 0, 0.55), axis=(0, 1, 0), lower=-0.3, upper=0.3,
                              name="elbow"))
    w.add_joint(tb.BallJoint("link1", "link2", anchor=(0.4, 0, 0.55), cone_limit=0.5, stiffness=0.4, damping=0.01,
                             target=(0.0, 0.3, 0.2), name="wrist"))  # a drive: its impulse is warm started
    w.add_joint(tb.SliderJoint("slider", None, anchor=(-1, 0, 1), axis=(0, 0, 1), stiffness=40.0, damping=0.3,
                               lower=-0.5, upper=0.5, name="spring"))
    w.add_joint(tb.DistanceJoint("link2", "box", anchor=(0.5, 0, 0.55), anchor_b=(0.5, 0, 0.4), min_length=0.0,
                                 max_length=0.3, collide_connected=True, name="rope"))
    w.add_joint(tb.HingeJoint("bob", None, anchor=(0, 1, 1), axis=(0, 1, 0), max_force=15.0, name="breaker"))
    return w


SETTINGS = {"gauss-seidel": JointSettings(), "tree": JointSettings(hertz=0.0, velocity_iterations=2,
                                                                   relax_iterations=2, method="tree")}


def same_state(a, b):
    return all(np.array_equal(getattr(a, k), getattr(b, k)) for k in STATE)


def same_readings(a, b):
    ra, rb = a.joint_readings(), b.joint_readings()
    return ra.keys() == rb.keys() and all(np.array_equal(ra[k], rb[k]) for k in ra)


def resumed_after_half(tmp_path, method):
    """(uninterrupted simulator, simulator loaded from the checkpoint at STEPS // 2)."""
    def start(steps):
        sim = tb.Simulator(joint_world(), joint_settings=SETTINGS[method], record_joints=True)
        sim.step(STEPS // 4)
        sim.soft_step.joints.set_motor_speed("shoulder", -1.0)  # a change between steps, kept in the solver only
        sim.step(steps - STEPS // 4)
        return sim

    whole = start(STEPS)
    first = start(STEPS // 2)
    assert first.world.joints[BREAKER].broken  # it broke in the first half: the record's state is saved
    assert not any(j.broken for j in first.world.joints[:BREAKER])
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    assert same_state(resumed.world, first.world) and same_readings(resumed, first)
    for name in checkpoint.JOINT_SOLVER_STATE:
        assert np.array_equal(getattr(resumed.soft_step.joints, name), getattr(first.soft_step.joints, name),
                              equal_nan=True), name  # armature_rate: NaN for the joints without armature
    return whole, resumed


@pytest.mark.parametrize("method", sorted(SETTINGS))
def test_resumed_joint_run_matches_an_uninterrupted_one_bit_for_bit(tmp_path, method):
    whole, resumed = resumed_after_half(tmp_path, method)
    w = resumed.world
    assert [type(j) for j in w.joints] == [type(j) for j in whole.world.joints]
    assert [j.name for j in w.joints] == ["shoulder", "elbow", "wrist", "spring", "rope", "breaker"]
    assert [j.broken for j in w.joints] == [False] * BREAKER + [True]
    assert resumed.joint_settings == SETTINGS[method] and resumed.record_joints
    resumed.step(STEPS - STEPS // 2)
    assert same_state(w, whole.world)
    assert same_readings(resumed, whole)
    assert state_hash(w) == state_hash(whole.world)
    assert len(whole.contacts()) > 0  # the chain lies on the box and the box on the ground


def test_without_the_joint_warm_start_the_continuation_differs(tmp_path):
    """The saved joint impulses matter: zeroing them after the load changes the continuation's bits
    (so the bit-identical resume above is a real check)."""
    whole, resumed = resumed_after_half(tmp_path, "gauss-seidel")
    solver = resumed.soft_step.joints
    assert np.abs(solver.linear_impulse).max() > 0
    for name in WARM_START:
        getattr(solver, name)[...] = 0.0
    resumed.step(STEPS - STEPS // 2)
    assert not same_state(resumed.world, whole.world)


def test_armature_rates_are_carried_by_checkpoints_and_snapshots(tmp_path):
    """A wrist of three hinges with armature on turning parents (tests/physics/test_mjcf.py's
    ``WRIST``; the armature rows' first substep takes the rates the last step ended with,
    ``JointSolver.armature_rate``): resumed from a checkpoint, or from a snapshot after other
    steps, it continues with the straight run's bits; forgetting those rates after the load
    changes the bits (its first substep then takes the rates derived from the momenta), so the
    resume checks that they are carried."""
    from .physics.test_mjcf import WRIST

    path = tmp_path / "wrist.xml"
    path.write_text(WRIST)

    def start():
        world = tb.World(gravity=(0, 0, 0))
        robot = tb.load_mjcf(world, path)
        sim = tb.Simulator(world, dt=0.002)
        robot.kinematics.set_state([0.3, -0.4, 0.7], [2.0, 1.0, -3.0], sim)
        return sim

    whole = start()
    whole.step(40)
    first = start()
    first.step(20)
    saved = first.save_state()
    first.save_checkpoint(tmp_path / "c.npz")
    rates = first.soft_step.joints.armature_rate
    assert np.isfinite(rates[[1, 2]]).all() and np.isnan(rates[0])  # the pan has no armature
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    resumed.step(20)
    assert same_state(resumed.world, whole.world)
    first.step(7)
    first.restore_state(saved)
    first.step(20)
    assert same_state(first.world, whole.world)
    forgetful = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    forgetful.soft_step.joints.armature_rate[:] = np.nan
    forgetful.step(20)
    assert not same_state(forgetful.world, whole.world)


def test_joint_added_after_the_last_step_resumes_bit_for_bit(tmp_path):
    """A joint added between steps and saved before the next one: the solver's arrays hold the
    joints of the last step only, and the first step after the load appends the new one."""
    def grow(sim):
        sim.step(60)
        sim.world.add_joint(tb.BallJoint("slider", "bob", anchor=(-0.75, 0.5, 1.0), anchor_b=(-0.5, 1, 1)))

    whole = tb.Simulator(joint_world())
    grow(whole)
    whole.step(60)
    first = tb.Simulator(joint_world())
    grow(first)
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    assert resumed.soft_step.joints.count == len(resumed.world.joints) - 1
    resumed.step(60)
    assert same_state(resumed.world, whole.world) and same_readings(resumed, whole)


def test_every_joint_solver_array_is_saved_or_rebuilt():
    """A JointSolver array that is in neither of checkpoint.py's lists would be silently dropped
    from checkpoints: each array of a solver that has stepped (tree method: all its tables) must
    be classified there."""
    sim = tb.Simulator(joint_world(), joint_settings=SETTINGS["tree"])
    sim.step(2)
    solver = sim.soft_step.joints
    assert isinstance(solver, JointSolver)
    arrays = {k for k, v in vars(solver).items() if isinstance(v, np.ndarray)}
    unlisted = arrays - set(checkpoint.JOINT_SOLVER_STATE) - set(checkpoint.JOINT_SOLVER_REBUILT)
    assert not unlisted, f"add {sorted(unlisted)} to checkpoint.JOINT_SOLVER_STATE or JOINT_SOLVER_REBUILT"
    assert set(checkpoint.JOINT_SOLVER_STATE) <= arrays


# ---------------------------------------------------------------------- the CLI

SCENE = """
[simulation]
duration = 1.0
frame_rate = 24
gravity = [0, 0, -9.81]
record_joints = true

[joint_solver]
method = "tree"
velocity_iterations = 2
relax_iterations = 2

[[bodies]]
name = "ground"
shape = { type = "plane", normal = [0, 0, 1] }
fixed = true

[[bodies]]
name = "box"
shape = { type = "box", size = [0.6, 0.6, 0.4] }
mass = 3.0
position = [0.5, 0, 0.2]

[[bodies]]
name = "link0"
shape = { type = "box", size = [0.2, 0.06, 0.06] }
mass = 0.3
position = [0.1, 0, 0.55]

[[bodies]]
name = "link1"
shape = { type = "box", size = [0.2, 0.06, 0.06] }
mass = 0.3
position = [0.3, 0, 0.55]

[[bodies]]
name = "slider"
shape = { type = "sphere", radius = 0.05 }
mass = 0.5
position = [-1, 0, 1]

[[bodies]]
name = "bob"
shape = { type = "sphere", radius = 0.05 }
mass = 1.0
position = [-0.5, 1, 1]

[[joints]]
type = "hinge"
body_a = "link0"
anchor = [0, 0, 0.55]
axis = [0, 1, 0]
motor_speed_deg = 30
max_motor_torque = 0.5

[[joints]]
type = "hinge"
body_a = "link0"
body_b = "link1"
anchor = [0.2, 0, 0.55]
axis = [0, 1, 0]
lower_deg = -20
upper_deg = 20

[[joints]]
type = "slider"
body_a = "slider"
anchor = [-1, 0, 1]
axis = [0, 0, 1]
stiffness = 40.0
damping = 0.3

[[joints]]
type = "hinge"
name = "breaker"
body_a = "bob"
anchor = [0, 1, 1]
axis = [0, 1, 0]
max_force = 15.0
"""


def test_cli_resume_of_a_joint_scene_continues_bit_identically(tmp_path, capsys):
    """``tumble run`` of a joint scene for 0.5 s with checkpoints, then ``--resume`` to 1 s, writes
    the same trajectory file (joint readings included) and state hash as one run of 1 s."""
    scene = tmp_path / "joints.toml"
    scene.write_text(SCENE)
    full, part = tmp_path / "full", tmp_path / "part"
    assert cli_main(["run", str(scene), "--out", str(full), "--no-progress"]) == 0
    assert cli_main(["run", str(scene), "--out", str(part), "--duration", "0.5", "--checkpoint-every", "0.25",
                     "--no-progress"]) == 0
    ckpt = tb.Simulator.load_checkpoint(part / "checkpoint.npz")
    assert ckpt.world.joints[3].broken and ckpt.joint_settings.method == "tree" and ckpt.record_joints
    assert cli_main(["run", "--resume", str(part), "--duration", "1", "--no-progress"]) == 0
    capsys.readouterr()
    a, b = (tb.load_trajectory(d / "trajectory.npz") for d in (full, part))
    assert a.frame_count == b.frame_count == 25
    assert np.array_equal(a.joint_position, b.joint_position) and np.array_equal(a.joint_force, b.joint_force)
    assert not a.joint_enabled[-1, 3] and a.joint_enabled[1, 3]  # the breaker broke during the first half
    assert (full / "trajectory.npz").read_bytes() == (part / "trajectory.npz").read_bytes()
    sa, sb = (json.loads((d / "summary.json").read_text())["run"] for d in (full, part))
    assert sa["state_hash"] == sb["state_hash"] and sb["status"] == "completed" and sa["steps"] == sb["steps"]


# ---------------------------------------------------------------------- bad joint records


def edit_meta(src, dst, change):
    with np.load(src, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(str(arrays["meta"]))
    change(meta["joints"])
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(dst, **arrays)
    return dst


BAD_JOINTS = {
    "type": (lambda js: js[0].update(type="weld"), r"joints\[0\]\.type: unknown joint type 'weld' \(expected one of ball, "),
    "body": (lambda js: js[1].update(body_b="nope"), r"joints\[1\]\.body_b: unknown body 'nope'$"),
    "field": (lambda js: js[2].update(twist=1.0), r"joints\[2\]\.twist: unknown field of a ball joint$"),
    "bound": (lambda js: js[3]["bound"].update(local_a=[0, 1]), r"joints\[3\]\.bound\.local_a: expected 3 finite numbers$"),
    "list": (lambda js: js.append(7), r"joints\[6\]: expected a joint record$"),
}


@pytest.mark.parametrize("kind", sorted(BAD_JOINTS))
def test_a_bad_joint_record_in_a_checkpoint_is_one_input_error_line(tmp_path, capsys, kind):
    change, expected = BAD_JOINTS[kind]
    sim = tb.Simulator(joint_world())
    sim.step(2)
    good = sim.save_checkpoint(tmp_path / "good.npz")
    bad = edit_meta(good, tmp_path / "bad.npz", change)
    with pytest.raises(tb.InputError) as info:
        tb.Simulator.load_checkpoint(bad)
    line = str(info.value)
    assert "\n" not in line and line.startswith(f"{bad}: checkpoint does not rebuild: "), line
    import re

    assert re.search(expected, line), line
    # and through the CLI: exit 2 and that one line
    run = tmp_path / "run"
    run.mkdir()
    (run / "checkpoint.npz").write_bytes(bad.read_bytes())
    assert cli_main(["run", "--resume", str(run)]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and "checkpoint does not rebuild: joints[" in err, err
