"""Loading URDF files (tumble.urdf, the scene file's [[robots]]): what each element becomes, the
options, the control helpers, the one-line errors. The motion itself is tested against
Lagrange's equations in tests/physics/test_urdf.py."""

from pathlib import Path

import numpy as np
import pytest

import tumble as tb
from tumble.joints import P_EFFORT
from tumble import checks
from tumble.cli import main
from tumble.urdf import NO_CONTACT, balanced_inertia, load_urdf

from .physics.solutions import resumed_run

INERTIAL = '<inertial><mass value="{m}"/><inertia ixx="{i}" iyy="{i}" izz="{i}"/></inertial>'


def urdf(body, name="r"):
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n{body}\n</robot>\n'


def link(name, shape='<box size="0.2 0.2 0.2"/>', mass=1.0, inertia=0.01, origin="", extra=""):
    inertial = "" if mass is None else INERTIAL.format(m=mass, i=inertia)
    collision = "" if shape is None else f"<collision>{origin}<geometry>{shape}</geometry></collision>"
    return f'<link name="{name}">{inertial}{collision}{extra}</link>'


def joint(name, kind, parent, child, xyz="0 0 0", axis="0 0 1", extra=""):
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}"/><axis xyz="{axis}"/>{extra}</joint>')


def write(tmp_path, text, name="r.urdf"):
    p = tmp_path / name
    p.write_text(text)
    return p


CHAIN = urdf(link("base", mass=None) + link("a") + link("b") + link("c", shape='<sphere radius="0.05"/>', mass=0.2)
             + joint("j1", "revolute", "base", "a", "0 0 1", "0 1 0", '<limit lower="-1" upper="1" effort="3"/>')
             + joint("j2", "prismatic", "a", "b", "0.5 0 0", "1 0 0", '<limit lower="0" upper="0.3"/>')
             + joint("j3", "fixed", "b", "c", "0.3 0 0"))


def test_links_joints_and_names(tmp_path):
    world = tb.World()
    robot = load_urdf(world, write(tmp_path, CHAIN), name="arm", position=(1, 2, 0))
    assert world.names == ["arm/base", "arm/a", "arm/b"]  # c merged into b
    assert robot.links["c"] is robot.links["b"] and robot.base is robot.links["base"]
    assert world.fixed[robot.base.index]  # the root link has no mass
    assert [j.name for j in world.joints] == ["arm/j1", "arm/j2"]
    j1, j2 = robot.joints["j1"], robot.joints["j2"]
    assert isinstance(j1, tb.HingeJoint) and (j1.lower, j1.upper) == (-1.0, 1.0)
    assert isinstance(j2, tb.SliderJoint) and (j2.lower, j2.upper) == (0.0, 0.3)
    np.testing.assert_allclose(j2.anchor, (1.5, 2, 1))
    # the link frames: c sits 0.3 m along b's x
    p, R = robot.link_pose("c")
    np.testing.assert_allclose(p, (1.8, 2, 1), atol=1e-15)
    np.testing.assert_allclose(R, np.eye(3), atol=1e-15)

    unmerged = tb.World()
    robot = load_urdf(unmerged, write(tmp_path, CHAIN), merge_fixed=False)
    assert unmerged.names == ["r/base", "r/a", "r/b", "r/c"]
    assert isinstance(robot.joints["j3"], tb.FixedJoint)


def test_start_joint_positions_place_the_links(tmp_path):
    # j1 turns a (and what hangs on it) 0.4 rad about y; j2 slides b 0.2 m along a's x
    world = tb.World()
    robot = load_urdf(world, write(tmp_path, CHAIN), joint_positions={"j1": 0.4, "j2": 0.2})
    p, R = robot.link_pose("b")
    Ry = np.array([[np.cos(0.4), 0, np.sin(0.4)], [0, 1, 0], [-np.sin(0.4), 0, np.cos(0.4)]])
    np.testing.assert_allclose(p, (0, 0, 1) + Ry @ (0.7, 0, 0), atol=1e-15)
    np.testing.assert_allclose(R, Ry, atol=1e-15)
    sim = tb.Simulator(world, dt=1 / 240)
    sim.world.gravity[:] = 0.0
    sim.step(1)
    states = robot.joint_states(sim)
    assert states["j1"][0] == pytest.approx(0.4, abs=1e-12) and states["j2"][0] == pytest.approx(0.2, abs=1e-12)
    for bad, problem in (({"nope": 1.0}, "not a revolute"), ({"j3": 1.0}, "not a revolute"), ({"j1": "x"}, "expected")):
        with pytest.raises(tb.InputError, match=problem):
            load_urdf(tb.World(), write(tmp_path, CHAIN), joint_positions=bad)


SIBLINGS = urdf(link("base", mass=None) + link("left", shape='<box size="0.4 0.2 0.2"/>')
                + link("right", shape='<box size="0.4 0.2 0.2"/>')
                + joint("l", "continuous", "base", "left", "0 0 1", "0 0 1")
                + joint("r", "continuous", "base", "right", "0.3 0 1", "0 0 1"))


@pytest.mark.parametrize("self_collision", [False, True])
def test_self_collision_is_off_unless_asked(tmp_path, self_collision):
    # two sibling links overlapping by 0.1 m along x (not joined to each other): PyBullet's default
    # is that a robot does not touch itself; with self_collision they are pushed apart
    world = tb.World(gravity=(0, 0, 0))
    robot = load_urdf(world, write(tmp_path, SIBLINGS), self_collision=self_collision)
    sim = tb.Simulator(world, dt=1 / 240)
    sim.step(2)
    contacts = sim.contacts()
    pairs = {tuple(sorted((int(a), int(b)))) for a, b in zip(contacts.body_a, contacts.body_b)}
    left, right = robot.links["left"].index, robot.links["right"].index
    assert ((left, right) in pairs) == self_collision
    assert world.should_collide(left, right) == self_collision
    assert not world.should_collide(robot.base, left)  # jointed: never


def test_contact_material_and_shapeless_links(tmp_path):
    text = urdf(link("base", extra='<contact><lateral_friction value="0.2"/><restitution value="0.5"/></contact>')
                + link("sensor", shape=None, mass=0.1, inertia=1e-4)
                + joint("s", "revolute", "base", "sensor", "0 0 0.2", "1 0 0"))
    world = tb.World()
    robot = load_urdf(world, write(tmp_path, text), material={"friction": 0.9})
    base = robot.links["base"]
    assert world.materials[base.index].friction == 0.2 and world.materials[base.index].restitution == 0.5
    marker = robot.links["sensor"]
    assert world.materials[marker.index].friction == 0.9
    assert world.collision_filters[marker.index] == NO_CONTACT
    # a moving link without mass has no dynamics to give it
    text = urdf(link("base") + link("ghost", mass=None) + joint("g", "revolute", "base", "ghost"))
    with pytest.raises(tb.InputError, match=r"link\[ghost\]: a link that moves needs an <inertial>"):
        load_urdf(tb.World(), write(tmp_path, text))


def test_mesh_from_a_package_path_is_hulled_and_scaled(tmp_path):
    import trimesh

    (tmp_path / "pkg" / "meshes").mkdir(parents=True)
    trimesh.creation.box(extents=(0.2, 0.4, 0.6)).export(tmp_path / "pkg" / "meshes" / "part.stl")
    text = urdf(link("base", shape='<mesh filename="package://pkg/meshes/part.stl" scale="2 1 1"/>'))
    (tmp_path / "urdf").mkdir()
    world = tb.World()
    robot = load_urdf(world, write(tmp_path / "urdf", text))  # found in a parent folder's pkg/
    shape = robot.base.shape
    assert isinstance(shape, tb.Convex)
    np.testing.assert_allclose(np.ptp(shape.vertices, axis=0), (0.4, 0.4, 0.6), atol=1e-12)
    with pytest.raises(tb.InputError, match="mesh file not found: package://nope/x.stl"):
        load_urdf(tb.World(), write(tmp_path, urdf(link("base", shape='<mesh filename="package://nope/x.stl"/>'))))


def test_bullet_plane_on_a_fixed_link(tmp_path):
    text = urdf(link("floor", shape='<plane normal="0 0 1"/>', mass=0.0, origin='<origin xyz="0 0 -0.5"/>'))
    world = tb.World()
    robot = load_urdf(world, write(tmp_path, text))
    assert isinstance(robot.base.shape, tb.Plane) and world.fixed[0]
    assert robot.base.shape.offset == pytest.approx(-0.5)
    with pytest.raises(tb.InputError, match="a plane must be the only collision shape of a fixed link"):
        load_urdf(tb.World(), write(tmp_path, text.replace('value="0.0"', 'value="1"')))


BAD_INERTIA = urdf(link("base", extra="") .replace('<inertia ixx="0.01" iyy="0.01" izz="0.01"/>',
                                                   '<inertia ixx="0.01" iyy="0.02" izz="0.05"/>'))


def test_inertia_sources(tmp_path):
    path = write(tmp_path, BAD_INERTIA)
    with pytest.raises(tb.InputError, match=r'link\[base\].inertia: inertia violates the triangle.*inertia="balance".*'
                                            r'inertia="shapes"'):
        load_urdf(tb.World(), path)
    world = tb.World()
    robot = load_urdf(world, path, inertia="balance")
    # 0.01 + 0.02 < 0.05: each small moment raised by half the shortfall 0.02, axes kept
    np.testing.assert_allclose(world.inertia_body[robot.base.index], np.diag([0.02, 0.03, 0.05]), atol=1e-15)
    np.testing.assert_allclose(balanced_inertia(np.diag([1.0, 2.0, 2.5])), np.diag([1.0, 2.0, 2.5]))
    world = tb.World()
    robot = load_urdf(world, path, inertia="shapes")
    # a 0.2 m cube of 1 kg: m (b^2 + c^2) / 12 = 0.00667 about every axis
    np.testing.assert_allclose(world.inertia_body[robot.base.index], np.eye(3) * 0.08 / 12, atol=1e-15)
    with pytest.raises(tb.InputError, match="inertia: must be one of"):
        load_urdf(tb.World(), path, inertia="guess")


def wheel_robot(tmp_path):
    """(world, robot, sim): a wheel on a continuous joint about z (the URDF's effort 0.02 N m), no gravity."""
    text = urdf(link("base", mass=None) + link("wheel", inertia=0.08 / 12)
                + joint("spin", "continuous", "base", "wheel", axis="0 0 1", extra='<limit effort="0.02"/>'))
    world = tb.World(gravity=(0, 0, 0))
    robot = load_urdf(world, write(tmp_path, text))
    sim = tb.Simulator(world, dt=1 / 240)
    return world, robot, sim


def test_motor_and_position_control(tmp_path):
    # a 1 kg, 0.2 m cube turning about z through its centre: I = m (0.2^2 + 0.2^2) / 12 = 0.00667.
    # The motor's torque is at most the URDF's effort, 0.02 N m: alpha = 0.02 / I = 3 rad/s^2
    # until the target speed 1.5 rad/s (0.5 s); then the PD drive takes it to 0.25 rad.
    world, robot, sim = wheel_robot(tmp_path)
    robot.set_motor(sim, "spin", 1.5)  # before the first step: written into the joint record
    sim.step(60)
    assert robot.joint_states(sim)["spin"][1] == pytest.approx(3.0 * 0.25, rel=1e-6)
    sim.step(120)
    assert robot.joint_states(sim)["spin"][1] == pytest.approx(1.5, rel=1e-6)
    robot.set_motor(sim, "spin", None)  # off: it coasts
    sim.step(24)
    assert robot.joint_states(sim)["spin"][1] == pytest.approx(1.5, rel=1e-9)
    robot.set_position_target(sim, "spin", target=0.25, stiffness=2.0, damping=0.3, max_force=10.0)
    sim.step(960)
    position, rate = robot.joint_states(sim)["spin"]
    # the hinge angle is followed across turns: the drive unwinds it to 0.25 itself
    assert position == pytest.approx(0.25, abs=1e-3) and abs(rate) < 1e-3
    with pytest.raises(tb.InputError, match="unknown joint 'nope'"):
        robot.set_motor(sim, "nope", 1.0)


def test_a_sleeping_robot_wakes_to_a_new_control(tmp_path):
    # The wheel of test_motor_and_position_control held by its PD drive at 0 falls asleep; a new
    # position target wakes it (Box2D's joint setters wake the joint's bodies) and it turns to it
    # (before, it stayed asleep at 0: the control was written, nothing woke the wheel).
    world, robot, sim = wheel_robot(tmp_path)
    robot.set_position_target(sim, "spin", target=0.0, stiffness=2.0, damping=0.3, max_force=10.0)
    sim.step(240)
    assert not sim.sleep.awake[world.index_of(robot.links["wheel"])]
    robot.set_position_target(sim, "spin", target=0.25, stiffness=2.0, damping=0.3, max_force=10.0)
    sim.step(960)
    position, rate = robot.joint_states(sim)["spin"]
    assert position == pytest.approx(0.25, abs=1e-3) and abs(rate) < 1e-3


def test_position_control_with_a_target_velocity_and_a_motor_after_it(tmp_path):
    # PyBullet's POSITION_CONTROL with a targetVelocity and no position gain: the drive's damping c
    # pulls the rate to w, capped at max_force: the wheel (I = 0.00667 kg m^2) spins up at the cap,
    # 0.01 / I = 1.5 rad/s^2, until c (w - rate) falls below it (rate 2 - 0.01 / 0.05 = 1.8 rad/s
    # at 1.2 s), then settles at w = 2 rad/s (exp(-c t / I) = exp(-7.5 s-1 t): 1e-13 after 4 s more).
    # A motor set after it takes the joint alone: the target velocity is cleared with the drive
    # (the wheel stops at the motor's speed 0.5 rad/s, not pulled on towards 2).
    world, robot, sim = wheel_robot(tmp_path)
    robot.set_position_target(sim, "spin", target=0.0, stiffness=0.0, damping=0.05, max_force=0.01,
                              target_velocity=2.0)
    sim.step(240)
    assert robot.joint_states(sim)["spin"][1] == pytest.approx(1.5, abs=1e-9)
    assert robot.joints["spin"].target_velocity == 2.0  # the record says what acts
    sim.step(5 * 240)
    assert robot.joint_states(sim)["spin"][1] == pytest.approx(2.0, abs=1e-9)
    robot.set_motor(sim, "spin", 0.5)
    sim.step(480)
    assert robot.joint_states(sim)["spin"][1] == pytest.approx(0.5, abs=1e-9)
    assert robot.joints["spin"].target_velocity == 0.0


def test_torque_control(tmp_path):
    # PyBullet's TORQUE_CONTROL: the same cube (I = 0.00667 kg m^2) under a joint torque of 0.01 N m
    # spins up at 0.01 / I = 1.5 rad/s^2 (exactly: no gyroscopic term about a principal axis), not
    # clipped by the URDF's effort (0.005 N m, the motors' and drives' limit), set before the first
    # step and changed between steps.
    text = urdf(link("base", mass=None) + link("wheel", inertia=0.08 / 12)
                + joint("spin", "continuous", "base", "wheel", axis="0 0 1", extra='<limit effort="0.005"/>'))
    world = tb.World(gravity=(0, 0, 0))
    robot = load_urdf(world, write(tmp_path, text))
    sim = tb.Simulator(world, dt=1 / 240)
    robot.set_joint_torque(sim, "spin", 0.01)
    sim.step(240)
    assert robot.joint_states(sim)["spin"][1] == pytest.approx(1.5, rel=1e-9)
    robot.set_joint_torque(sim, "spin", -0.02)  # brakes at 3 rad/s^2: at rest 0.5 s later
    sim.step(120)
    assert abs(robot.joint_states(sim)["spin"][1]) < 1e-9


def test_robot_runs_resume_bit_for_bit(tmp_path):
    path = write(tmp_path, CHAIN)

    def make():
        world = tb.World()
        world.add_body(tb.Plane(), fixed=True)
        load_urdf(world, path, position=(0, 0, 0.2), joint_positions={"j1": 0.8})
        return world

    whole, resumed = resumed_run(make, tmp_path, 1.0, 1 / 240)
    assert checks.state_hash(whole.world) == checks.state_hash(resumed.world)


ERRORS = [
    ("<robot", None, "invalid XML"),
    ("<model/>", None, "expected a <robot> element at the top"),
    (urdf(""), "robot", "at least one <link>"),
    (urdf(link("a") + link("a")), r"link\[a\]", "duplicate link name"),
    (urdf(link("a") + link("b")), "robot", "2 links .a, b. without a parent joint"),
    (urdf(link("a") + link("b") + joint("j", "fixed", "a", "zz")), r"joint\[j\].child", "unknown link 'zz'"),
    (urdf(link("a") + link("b") + link("c") + joint("j", "fixed", "a", "b") + joint("k", "fixed", "c", "b")),
     r"joint\[k\].child", "child of two joints"),
    (urdf(link("r") + link("a") + link("b") + joint("j", "fixed", "a", "b") + joint("k", "fixed", "b", "a")),
     r"link\[a\]", "cycle"),
    (urdf(link("a") + link("b") + joint("j", "screw", "a", "b")), r"joint\[j\].type", "unknown joint type 'screw'"),
    (urdf(link("a") + link("b") + joint("j", "planar", "a", "b")), r"joint\[j\].type", "planar joints are not supported"),
    (urdf(link("a") + link("b") + joint("j", "revolute", "a", "b", axis="0 0 0")), r"joint\[j\].axis.xyz", "zero vector"),
    (urdf(link("a") + link("b") + joint("j", "revolute", "a", "b", xyz="1 x 0")), r"joint\[j\].origin.xyz",
     "expected 3 numbers, got '1 x 0'"),
    (urdf(link("a") + link("b") + joint("j", "revolute", "a", "b", extra='<limit lower="abc"/>')),
     r"joint\[j\].limit.lower", "expected 1 number"),
    (urdf(link("a", mass=-1)), r"link\[a\].inertial.mass.value", "must be >= 0"),
    (urdf('<link name="a"><inertial><inertia ixx="1" iyy="1" izz="1"/></inertial></link>'), r"link\[a\].inertial",
     "missing <mass>"),
    (urdf(link("a", shape='<torus radius="1"/>')), r"link\[a\].collision\[0\].geometry", "unknown shape <torus>"),
    (urdf(link("a", shape='<box size="1 1"/>')), r"link\[a\].collision\[0\].geometry.box.size", "expected 3"),
    (urdf(link("a", shape='<sphere radius="-1"/>')), r"link\[a\].collision\[0\].geometry.sphere.radius", "positive"),
    (urdf(link("a", shape='<mesh filename="missing.stl"/>')), r"link\[a\].collision\[0\].geometry.mesh.filename",
     "mesh file not found"),
    (urdf(link("a", inertia=0.0)), r"link\[a\].inertia", "not positive definite"),
]


@pytest.mark.parametrize("text, key, problem", ERRORS)
def test_bad_urdf_is_one_line_naming_file_and_element(tmp_path, text, key, problem):
    path = write(tmp_path, text)
    with pytest.raises(tb.InputError) as info:
        load_urdf(tb.World(), path)
    line = str(info.value)
    assert "\n" not in line and line.startswith(str(path) + ": ")
    assert problem and __import__("re").search(problem, line), line
    if key is not None:
        assert __import__("re").search(f": {key}: ", line), line


def test_missing_urdf_file():
    with pytest.raises(tb.InputError, match="nope.urdf: URDF file not found"):
        load_urdf(tb.World(), "nope.urdf")


# ---------------------------------------------------------------------- scene files


def scene_text(robot_table, extra=""):
    return f"""
[simulation]
duration = 0.5
[[bodies]]
name = "ground"
shape = {{ type = "plane" }}
fixed = true
[[robots]]
{robot_table}
{extra}
"""


def test_scene_robots_entry(tmp_path):
    write(tmp_path, CHAIN, "chain.urdf")
    extra = """
[[forces]]
type = "constant"
body = "arm/b"
force = [0, 0, 5]
[[collision_exclusions]]
bodies = ["ground", "arm/a"]
"""
    text = scene_text('file = "chain.urdf"\nname = "arm"\nposition = [0, 0, 0.5]\njoint_positions = { j1 = 0.3 }\n'
                      'material = { friction = 0.7 }\ninertia = "file"', extra)
    (tmp_path / "s.toml").write_text(text)
    scene = tb.load_scene(tmp_path / "s.toml")
    world = scene.world
    assert world.names == ["ground", "arm/base", "arm/a", "arm/b"]
    assert world.materials[3].friction == 0.7 and len(world.joints) == 2
    assert not world.should_collide("ground", "arm/a") and world.should_collide("ground", "arm/b")
    # a robot-only scene is a scene
    (tmp_path / "r.toml").write_text('[[robots]]\nfile = "chain.urdf"\n')
    assert tb.load_scene(tmp_path / "r.toml").world.body_count == 3
    # a constant joint torque from the scene: the joint's record carries it into the run
    (tmp_path / "t.toml").write_text('[[robots]]\nfile = "chain.urdf"\njoint_torques = { j1 = 0.25 }\n')
    joints = tb.load_scene(tmp_path / "t.toml").world.joints
    assert [j.bound.param[P_EFFORT] for j in joints] == [0.25, 0.0]


@pytest.mark.parametrize("table, key, problem", [
    ('name = "x"', "robots[0]", "missing key 'file'"),
    ('file = "nope.urdf"', "robots[0].file", "file not found"),
    ('file = "chain.urdf"\nfixed_base = 1', "robots[0].fixed_base", "expected true or false"),
    ('file = "chain.urdf"\ninertia = "x"', "robots[0].inertia", "must be one of"),
    ('file = "chain.urdf"\njoint_positions = { j3 = 1.0 }', "robots[0].joint_positions.j3", "not a revolute"),
    ('file = "chain.urdf"\ncolour = 1', "robots[0].colour", "unknown key"),
    ('file = "bad.urdf"', "robots[0].file", r"bad.urdf: joint\[j\].type: unknown joint type 'screw'"),
    ('file = "chain.urdf"\njoint_torques = { j9 = 1.0 }', "robots[0].joint_torques.j9", "unknown joint 'j9'"),
    ('file = "chain.urdf"\njoint_torques = { j1 = "hard" }', "robots[0].joint_torques.j1", "expected a number"),
    ('file = "chain.urdf"\njoint_torques = 3', "robots[0].joint_torques", "expected a table"),
    ('file = "chain.urdf"\ncontrols = { m = 1.0 }', "robots[0].controls", "a URDF has no actuators"),
])
def test_scene_robot_errors_are_one_line(tmp_path, table, key, problem):
    write(tmp_path, CHAIN, "chain.urdf")
    write(tmp_path, urdf(link("a") + link("b") + joint("j", "screw", "a", "b")), "bad.urdf")
    path = tmp_path / "s.toml"
    path.write_text(scene_text(table))
    with pytest.raises(tb.InputError) as info:
        tb.load_scene(path)
    line = str(info.value)
    assert line.startswith(f"{path}: {key}: ") and "\n" not in line, line
    assert __import__("re").search(problem, line), line


def test_cli_runs_a_robot_scene_and_refuses_a_bad_one(tmp_path, capsys):
    write(tmp_path, CHAIN, "chain.urdf")
    (tmp_path / "s.toml").write_text(scene_text('file = "chain.urdf"\njoint_positions = { j1 = 0.5 }'))
    assert main(["run", str(tmp_path / "s.toml"), "--out", str(tmp_path / "out"), "--no-progress"]) == 0
    traj = tb.load_trajectory(tmp_path / "out" / "trajectory.npz")
    assert list(traj.names) == ["ground", "r/base", "r/a", "r/b"]
    write(tmp_path, CHAIN.replace('upper="1"', 'upper="x"'), "chain.urdf")
    capsys.readouterr()
    assert main(["run", str(tmp_path / "s.toml"), "--out", str(tmp_path / "out2"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "robots[0].file: chain.urdf: joint[j1].limit.upper: expected 1 number" in err[0]


def test_sweep_over_a_robot_key(tmp_path):
    # a parameter sweep over a [[robots]] entry (tumble.sweep): the PD target of a pendulum's joint;
    # each variant rests where k (target - theta) = m g d sin(theta) (brentq), its centre of mass
    # 0.5 m from the pivot at -0.5 (sin theta, 0, cos theta). Sleeping off: the last creep is
    # slower than the sleep tolerance (tests/physics/test_urdf.py).
    pytest.importorskip("pyarrow")
    from scipy.optimize import brentq

    from tumble.sweep import run_sweep

    from .physics.test_urdf import PENDULUM

    write(tmp_path, PENDULUM, "pendulum.urdf")
    scene = tmp_path / "s.toml"
    scene.write_text('[simulation]\nduration = 8.0\nsleeping = false\n[[robots]]\nfile = "pendulum.urdf"\nname = "pend"\n'
                     'joint_targets = { swing = { position = 0.5, stiffness = 30.0, damping = 6.0 } }\n')
    table = run_sweep(scene, vary=["robots.pend.joint_targets.swing.position=[0.2, 0.6]"],
                      metrics=["final_position:pend/arm"], workers=0, progress=False)
    assert table["status"].to_pylist() == ["ok", "ok"]
    for target, x in zip((0.2, 0.6), table["final_position:pend/arm[0]"].to_pylist()):
        theta = brentq(lambda th: 30.0 * (target - th) - 2 * 9.81 * 0.5 * np.sin(th), 0.0, target)
        # to 2e-5 m: the soft hinge anchor gives a little under the load (5.6e-6 m measured at 0.6)
        assert x == pytest.approx(-0.5 * np.sin(theta), abs=2e-5)
    with pytest.raises(tb.InputError, match="no robot named 'nope'"):
        run_sweep(scene, vary=["robots.nope.fixed_base=[true]"], workers=0, progress=False)


def test_reset_joint_positions_mid_run(tmp_path):
    # PyBullet's resetJointState: the robot jumps to the given joint positions, base kept, at rest
    world = tb.World()
    robot = load_urdf(world, write(tmp_path, CHAIN), position=(0, 0, 1))
    sim = tb.Simulator(world, dt=1 / 240)
    sim.step(120)  # it swings under gravity
    assert abs(robot.joint_states(sim)["j1"][0]) > 0.1
    robot.reset_joint_positions(sim, {"j1": -0.7, "j2": 0.25})
    p, R = robot.link_pose("c")
    Ry = np.array([[np.cos(-0.7), 0, np.sin(-0.7)], [0, 1, 0], [-np.sin(-0.7), 0, np.cos(-0.7)]])
    np.testing.assert_allclose(p, (0, 0, 2) + Ry @ (0.5 + 0.25 + 0.3, 0, 0), atol=1e-12)
    np.testing.assert_allclose(world.v[1:], 0.0, atol=0) and np.testing.assert_allclose(world.omega[1:], 0.0, atol=0)
    sim.step(1)  # one step from rest: the joints move by about g dt^2 / L at most
    states = robot.joint_states(sim)
    assert states["j1"][0] == pytest.approx(-0.7, abs=1e-3) and states["j2"][0] == pytest.approx(0.25, abs=1e-3)
    with pytest.raises(tb.InputError, match="positions.j3: not a revolute"):
        robot.reset_joint_positions(sim, {"j3": 1.0})


EXAMPLE_ROBOTS = Path(__file__).resolve().parents[1] / "examples" / "robots"


@pytest.mark.parametrize("kind", ["urdf", "mjcf"])
def test_reset_joint_positions_before_the_first_step_keeps_the_joints_not_named(kind):
    """Before any step, ``reset_joint_positions`` of one joint keeps the others where they are.
    Compares the joint coordinates of the bodies' poses (``robot.kinematics.qpos``) and
    ``joint_states`` with the loaded ``joint_positions`` and the reset joint's value. The joints not
    named used to be read from the Simulator's readings, zeros until a step stores them: they went
    back to 0. Tolerance 1e-12 rad: the values only go through quaternions and rotation matrices
    (rounding, about 1e-16 rad); a zeroed joint is off by 0.9 rad or more."""
    world = tb.World(gravity=(0, 0, -9.81))
    if kind == "urdf":
        kept = {"shoulder": 1.2, "elbow": 0.9}
        robot = load_urdf(world, EXAMPLE_ROBOTS / "arm.urdf", fixed_base=True, joint_positions=kept)
        named = "yaw"
    else:
        kept = {"shoulder": 0.9}
        robot = tb.load_mjcf(world, EXAMPLE_ROBOTS / "pendulum.xml", joint_positions=kept)
        named = "elbow"
    sim = tb.Simulator(world, dt=1 / 240)
    kin = robot.kinematics
    names = [c.name for c in kin.coordinates]
    # before the first step, joint_states reads the present pose (it read zeros)
    assert robot.joint_states(sim)["shoulder"] == pytest.approx((kept["shoulder"], 0.0), abs=1e-12)
    robot.reset_joint_positions(sim, {named: 0.5})
    q = dict(zip(names, kin.qpos()))
    assert q[named] == pytest.approx(0.5, abs=1e-12)
    for joint, value in kept.items():
        assert q[joint] == pytest.approx(value, abs=1e-12)
        assert robot.joint_states(sim)[joint][0] == pytest.approx(value, abs=1e-12)


@pytest.mark.parametrize("solver", ["", '[joint_solver]\nmethod = "tree"\nhertz = 0.0\nvelocity_iterations = 2\n'
                                        'relax_iterations = 2\n'])
def test_robot_variants_batch_bit_for_bit(tmp_path, solver):
    # a sweep of a URDF arm's start pose: its links never touch each other (self-collision off),
    # so the variants are stepped as one World (tumble.sweep.batch) and each gives the bits of its
    # single run (state hashes equal), with both joint methods; with a limit the tree method's
    # extra sweeps would couple them: those run one by one
    pytest.importorskip("pyarrow")
    from tumble.sweep import run_sweep, tables_equal

    from .physics.test_urdf import ARM

    write(tmp_path, ARM.replace("DAMPING", "0.1"), "arm.urdf")
    scene = tmp_path / "s.toml"
    scene.write_text(f'[simulation]\nduration = 1.0\n{solver}[[robots]]\nfile = "arm.urdf"\n'
                     'joint_positions = { shoulder = 0.5, elbow = 0.0 }\n')
    vary = ["robots[0].joint_positions.shoulder=linspace(-1.0, 1.0, 6)"]
    batched = run_sweep(scene, vary=vary, workers=0, progress=False)
    single = run_sweep(scene, vary=vary, workers=0, progress=False, batch=False)
    expected_batch = 1 if solver else 6  # the ARM's shoulder has a limit (-3, 3): the tree cannot batch it
    assert batched["batch_size"].to_pylist() == [expected_batch] * 6
    assert tables_equal(batched, single, ignore=("wall_time_s", "batch_size"))
    assert len(set(batched["state_hash"].to_pylist())) == 6
    if solver:  # without the limit the tree method batches too
        write(tmp_path, ARM.replace("DAMPING", "0.1").replace('<limit lower="-3" upper="3" effort="50" velocity="5"/>', ''),
              "arm.urdf")
        batched = run_sweep(scene, vary=vary, workers=0, progress=False)
        single = run_sweep(scene, vary=vary, workers=0, progress=False, batch=False)
        assert batched["batch_size"].to_pylist() == [6] * 6 and tables_equal(batched, single, ignore=("wall_time_s", "batch_size"))


BALL_AND_FREE_MJCF = """<mujoco>
  <worldbody>
    <body name="upper" pos="0 0 2">
      <joint name="shoulder" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05" mass="1"/>
      <body name="lower" pos="0 0 -0.5">
        <joint name="wrist" type="ball"/>
        <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.05" mass="1"/>
      </body>
    </body>
    <body name="puck" pos="1 0 1">
      <freejoint name="loose"/>
      <geom type="box" size="0.1 0.2 0.05" mass="1"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_reset_joint_positions_keeps_the_ball_and_free_joints_not_named(tmp_path):
    """``reset_joint_positions`` of one hinge keeps an MJCF model's ball and free joints where they
    are: compared in MuJoCo's coordinates (``robot.kinematics.qpos``) before and after, the ball's
    and the free body's quaternions up to sign. They went back to the model's pose (the ball at
    identity, the free body at its file position): off by 0.6 rad and 1 m. Tolerance 1e-12: the
    values only pass through rotation matrices and quaternions (rounding, about 1e-16)."""
    path = tmp_path / "ball.xml"
    path.write_text(BALL_AND_FREE_MJCF)
    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_mjcf(world, path)
    sim = tb.Simulator(world, dt=1 / 240)
    kin = robot.kinematics
    qpos = kin.qpos()
    slices = {c.name: c.qpos for c in kin.coordinates}
    ball = np.array([np.cos(0.3), np.sin(0.3) * 0.6, 0.0, np.sin(0.3) * 0.8])
    free = np.concatenate([[0.4, -0.7, 1.3], [np.cos(0.2), 0.0, np.sin(0.2), 0.0]])
    qpos[slices["wrist"]] = ball
    qpos[slices["loose"]] = free
    kin.set_state(qpos, sim=sim)
    robot.reset_joint_positions(sim, {"shoulder": 0.5})
    after = kin.qpos()
    assert after[slices["shoulder"]][0] == pytest.approx(0.5, abs=1e-12)
    for name, expected in (("wrist", ball), ("loose", free)):
        got = after[slices[name]]
        if got[-4:] @ expected[-4:] < 0:  # q and -q are one rotation
            got = np.concatenate([got[:-4], -got[-4:]])
        np.testing.assert_allclose(got, expected, atol=1e-12, err_msg=name)
