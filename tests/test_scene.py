"""Tests for tumble/scene.py: the scene file format, the World it builds, one-line errors for bad input."""

import json
import math
import re
import tomllib

import numpy as np
import pytest

import tumble
from tumble.errors import InputError
from tumble.forces import ConstantForce, Drag, Impulse, PointForce, Spring
from tumble.integrators import INTEGRATOR_IDS
from tumble.scene import Scene, load_scene, parse_scene
from tumble.shapes import Box, Capsule, Cone, Convex, Cylinder, Mesh, Particles, Plane, Sphere

# World.add_body fills a fixed body's inertia with eye(3) * inf, which warns
# "invalid value encountered in multiply" (0 * inf); see the note to world.py.

CUBE_VERTICES = [[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
# 12 triangles of the unit cube around the origin, wound outward
CUBE_FACES = [
    [0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
    [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3],
]


def write_obj(path, vertices, faces):
    lines = [f"v {x} {y} {z}" for x, y, z in vertices] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


FULL_SCENE = """
[simulation]
duration = 0.5
frame_rate = 24
dt = 0.004166666666666667
integrator = "splitting"
substeps = 2
gravity = [0, 0, -9.8]
layout = "matrix"

[[bodies]]
name = "ground"
shape = { type = "plane", normal = [0, 0, 1], offset = 0 }
fixed = true

[[bodies]]
name = "ball"
shape = { type = "sphere", radius = 0.1 }
mass = 1.5
position = [0, 0, 1]
velocity = [1, 0, 0]
material = { friction = 0.4, restitution = 0.5 }

[[bodies]]
name = "brick"
shape = { type = "box", size = [0.2, 0.1, 0.05] }
density = 2000
position = [1, 0, 1]
euler_deg = [0, 0, 90]
angular_velocity = [0, 5, 0]
angular_velocity_frame = "body"

[[bodies]]
name = "pill"
shape = { type = "capsule", radius = 0.05, length = 0.2 }
mass = 0.3
position = [2, 0, 1]
orientation = [0, 1, 0, 0]

[[bodies]]
name = "can"
shape = { type = "cylinder", radius = 0.05, length = 0.12 }
mass = 0.4
position = [3, 0, 1]
inertia = [0.001, 0.001, 0.0005]

[[bodies]]
name = "cone"
shape = { type = "cone", radius = 0.1, height = 0.4 }
mass = 1.0
position = [4, 0, 1]

[[bodies]]
name = "bunny"
shape = { type = "mesh", path = "cube.obj" }
mass = 2.0
position = [5, 0, 1]

[[bodies]]
name = "inline_cube"
shape = { type = "mesh", vertices = VERTICES, faces = FACES }
density = 10
position = [6, 0, 1]

[[bodies]]
name = "rock"
shape = { type = "convex", points = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.2, 0.2, 0.2]] }
mass = 3.0
position = [7, 0, 1]

[[bodies]]
name = "dumbbell"
shape = { type = "particles", points = [[-0.5, 0, 0], [0.5, 0, 0], [0, 0.1, 0], [0, 0, 0.1]], masses = [1, 1, 0.5, 0.5] }
position = [8, 0, 1]

[[forces]]
type = "drag"
linear = 0.1
quadratic = 0.01
angular_linear = 0.001
angular_quadratic = 0.0001
wind = [1, 0, 0]

[[forces]]
type = "wind"
velocity = [0, 2, 0]
linear = 0.2
bodies = ["ball", "brick"]

[[forces]]
type = "constant"
body = "pill"
force = [0, 0, 3]
torque = [0, 0.1, 0]

[[forces]]
type = "point"
body = "can"
force = [1, 0, 0]
point = [0, 0, 0.06]
frame = "body"

[[forces]]
type = "spring"
body_a = "cone"
anchor_a = [0, 0, 0.1]
anchor_b = [4, 0, 2]
stiffness = 50
damping = 0.5

[[forces]]
type = "spring"
body_a = "ball"
body_b = "brick"
stiffness = 10
rest_length = 0.5

[[forces]]
type = "impulse"
body = "rock"
impulse = [0, 0, 1]
point = [7, 0.1, 1]
time = 0.25
""".replace("VERTICES", json.dumps(CUBE_VERTICES)).replace("FACES", json.dumps(CUBE_FACES))


@pytest.fixture
def full_scene_file(tmp_path):
    write_obj(tmp_path / "cube.obj", CUBE_VERTICES, CUBE_FACES)
    path = tmp_path / "scene.toml"
    path.write_text(FULL_SCENE)
    return path


def test_full_scene_builds_the_world(full_scene_file):
    scene = load_scene(full_scene_file)
    w = scene.world
    assert isinstance(scene, Scene)
    assert scene.source == full_scene_file
    assert (scene.duration, scene.frame_rate, scene.integrator, scene.substeps, scene.layout) == (0.5, 24, "splitting", 2, "matrix")
    assert scene.dt == pytest.approx(1 / 240)
    assert w.layout == "matrix"
    np.testing.assert_array_equal(w.gravity, [0, 0, -9.8])
    assert w.names == ["ground", "ball", "brick", "pill", "can", "cone", "bunny", "inline_cube", "rock", "dumbbell"]
    types = [Plane, Sphere, Box, Capsule, Cylinder, Cone, Mesh, Mesh, Convex, Particles]
    assert [type(s) for s in w.shapes] == types

    mass = dict(zip(w.names, w.mass))
    assert math.isinf(mass["ground"]) and not w.moving[0]
    assert mass["ball"] == 1.5
    assert mass["brick"] == pytest.approx(2000 * 0.2 * 0.1 * 0.05)
    assert mass["bunny"] == pytest.approx(2.0)
    assert mass["inline_cube"] == pytest.approx(10.0)  # unit cube, density 10
    assert mass["dumbbell"] == pytest.approx(3.0)
    np.testing.assert_allclose(w.inertia_body[4], np.diag([0.001, 0.001, 0.0005]))

    x = dict(zip(w.names, w.x))
    np.testing.assert_allclose(x["ball"], [0, 0, 1])
    np.testing.assert_allclose(x["bunny"], [5, 0, 1], atol=1e-12)
    np.testing.assert_allclose(x["cone"], [4, 0, 1 + 0.4 / 4])  # re-centred on the centre of mass
    np.testing.assert_allclose(x["dumbbell"], [8, 0.1 / 6, 1 + 0.1 / 6])
    np.testing.assert_allclose(w.v[1], [1, 0, 0])
    np.testing.assert_allclose(w.q[3], [0, 1, 0, 0])
    np.testing.assert_allclose(w.R[2] @ [1, 0, 0], [0, 1, 0], atol=1e-12)  # yaw 90 degrees
    np.testing.assert_allclose(w.omega[2], w.R[2] @ [0, 5, 0])  # body frame spin
    assert w.materials[1].friction == 0.4 and w.materials[1].restitution == 0.5

    assert len(w.forces) == 7
    assert [type(f) for f in w.forces] == [Drag, Drag, ConstantForce, PointForce, Spring, Spring, Impulse]
    assert w.forces[1].wind == (0, 2, 0) and w.forces[1].bodies == ["ball", "brick"]
    assert w.forces[4].body_b is None and w.forces[4].rest_length == pytest.approx(0.8)  # anchor 1.2 m high (centre of mass 1.1 + 0.1), world anchor 2 m
    assert w.forces[5].rest_length == 0.5
    assert w.forces[6].time == 0.25

    traj = scene.run(progress=False)
    assert traj.frame_count == 13


def test_toml_and_json_give_the_same_world(full_scene_file, tmp_path):
    data = tomllib.loads(full_scene_file.read_text())
    json_path = tmp_path / "scene.json"
    json_path.write_text(json.dumps(data))
    a, b = load_scene(full_scene_file), load_scene(json_path)
    assert a.data == b.data
    assert a.world.names == b.world.names
    for name in ("mass", "inertia_body", "com_offset", "x", "q", "R", "P", "L", "moving"):
        np.testing.assert_array_equal(getattr(a.world, name), getattr(b.world, name), err_msg=name)
    assert a.settings() == b.settings()
    assert len(a.world.forces) == len(b.world.forces)


def test_defaults_and_public_entry_point(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[[bodies]]\nname = "a"\nshape = { type = "sphere", radius = 1 }\nmass = 1\n')
    scene = tumble.load_scene(path)
    assert (scene.duration, scene.frame_rate, scene.integrator, scene.substeps, scene.layout) == (5.0, 24.0, "rk4", 1, "quaternion")
    assert scene.dt == 1 / 240
    assert scene.gravity == [0, 0, -9.81]
    assert scene.world.forces == []
    sim = scene.simulator()
    assert sim.dt == scene.dt and sim.integrator == "rk4"


def test_parse_scene_from_a_dict(tmp_path):
    data = {"bodies": [{"name": "a", "shape": {"type": "box", "size": [1, 2, 3]}, "mass": 6}]}
    scene = parse_scene(data, None, tmp_path)
    assert scene.source is None and scene.world.mass[0] == 6
    with pytest.raises(InputError) as info:
        parse_scene({"bodies": [{"name": "a", "shape": {"type": "box", "size": [1, 2, 0]}, "mass": 6}]}, "mem.toml", tmp_path)
    assert str(info.value) == "mem.toml: bodies[0].shape.size[2]: must be positive, got 0"


# ---------------------------------------------------------------------- bad input

BODY = '[[bodies]]\nname = "a"\nshape = { type = "sphere", radius = 1 }\nmass = 1\n'
INTEGRATORS = ", ".join(INTEGRATOR_IDS)  # explicit-euler, semi-implicit-euler, midpoint, rk4, ...
SHAPES = "sphere, box, capsule, cylinder, cone, ellipsoid, plane, mesh, convex, particles, compound, heightfield"
BODY_KEYS = ("name, shape, mass, density, inertia, fixed, kinematic, position, orientation, euler_deg, velocity, "
             "angular_velocity, angular_velocity_frame, material, collision_filter, path, surface_velocity, sensor, drop, fracture, enabled, enable_at, disable_at, gravity_scale, linear_damping, angular_damping")
PATH = "{ times = [0, 1], positions = [[0, 0, 0], [1, 0, 0]] }"


def body(**keys):
    """A body table with the given key = TOML value lines (None removes a key)."""
    lines = {"name": '"a"', "shape": '{ type = "sphere", radius = 1 }', "mass": "1"}
    lines.update(keys)
    return "[[bodies]]\n" + "".join(f"{k} = {v}\n" for k, v in lines.items() if v is not None)


OPEN_BOX_FACES = CUBE_FACES[:10]  # two triangles short of closed

BAD_SCENES = [
    # unknown keys, everywhere
    ("unknown-top", 'title = "x"\n' + BODY, "title", "unknown key (expected one of simulation, bodies, robots, forces, contact, joints, joint_solver, collision_exclusions, contact_pairs, cameras)"),
    ("unknown-simulation", "[simulation]\nspeed = 2\n" + BODY, "simulation.speed",
     "unknown key (expected one of duration, frame_rate, dt, integrator, substeps, gravity, layout, rtol, atol, max_energy_growth, "
     "collisions, record_contacts, record_joints, sleeping)"),
    ("unknown-body", body(colour='"red"'), "bodies[0].colour", f"unknown key (expected one of {BODY_KEYS})"),
    ("unknown-shape", body(shape='{ type = "sphere", radius = 1, size = 2 }'), "bodies[0].shape.size", "unknown key (expected one of type, radius)"),
    ("unknown-material", body(material="{ friction = 0.5, bounce = 1 }"), "bodies[0].material.bounce", "unknown key (expected one of friction, restitution, rolling_resistance, spinning_friction, margin, friction_combine, restitution_combine, condim)"),
    ("unknown-force", BODY + '[[forces]]\ntype = "drag"\nlinear = 0.1\nstrength = 2\n', "forces[0].strength",
     "unknown key (expected one of type, linear, quadratic, angular_linear, angular_quadratic, wind, bodies)"),
    # wrong types
    ("string-for-number", body(mass='"heavy"'), "bodies[0].mass", "expected a number, got 'heavy' (a string)"),
    ("number-for-list", body(position="3"), "bodies[0].position", "expected a list of 3 numbers, got 3 (a number)"),
    ("short-list", body(position="[1, 2]"), "bodies[0].position", "expected a list of 3 numbers, got 2"),
    ("bool-for-number", body(mass="true"), "bodies[0].mass", "expected a number, got true (a boolean)"),
    ("bool-in-list", body(velocity="[1, true, 0]"), "bodies[0].velocity[1]", "expected a number, got true (a boolean)"),
    ("number-for-bool", body(fixed="1"), "bodies[0].fixed", "expected true or false, got 1 (a number)"),
    ("kinematic-string", body(kinematic='"yes"'), "bodies[0].kinematic", "expected true or false, got 'yes' (a string)"),
    ("kinematic-and-fixed", body(fixed="true", kinematic="true"), "bodies[0].kinematic", "a body is fixed or kinematic, not both"),
    ("surface-velocity-short", body(surface_velocity="[1, 0]"), "bodies[0].surface_velocity", "expected a list of 3 numbers, got 2"),
    ("sensor-string", body(sensor='"yes"'), "bodies[0].sensor", "expected true or false, got 'yes' (a string)"),
    ("sensor-plane", body(shape='{ type = "plane" }', mass=None, fixed="true", sensor="true"), "bodies[0].sensor",
     re.escape("a plane cannot be a sensor (it has no inside to enter)")),
    ("path-not-kinematic", body(path=PATH), "bodies[0].path", "a path moves a kinematic body: set kinematic = true"),
    ("path-and-position", body(mass=None, kinematic="true", path=PATH, position="[0, 0, 1]"), "bodies[0].position",
     "a body on a path starts at the path's pose and moves at its velocity: give no position, orientation or velocity"),
    ("path-unknown-key", body(mass=None, kinematic="true", path="{ times = [0, 1], positions = [[0, 0, 0], [1, 0, 0]], loop = true }"),
     "bodies[0].path.loop", "unknown key (expected one of times, positions, orientations, euler_deg, repeat, release)"),
    ("path-missing-positions", body(mass=None, kinematic="true", path="{ times = [0, 1] }"), "bodies[0].path",
     "missing key 'positions'"),
    ("path-times-decrease", body(mass=None, kinematic="true", path="{ times = [1, 0], positions = [[0, 0, 0], [1, 0, 0]] }"),
     "bodies[0].path.times", "times must increase strictly, got [1.0, 0.0]"),
    ("path-short-rows", body(mass=None, kinematic="true", path="{ times = [0, 1, 2], positions = [[0, 0, 0], [1, 0, 0]] }"),
     "bodies[0].path.positions", "expected 3 rows of 3 finite numbers (one per time), got shape [2, 3]"),
    ("path-repeat-number", body(mass=None, kinematic="true", path="{ times = [0, 1], positions = [[0, 0, 0], [1, 0, 0]], repeat = 1 }"),
     "bodies[0].path.repeat", "expected true or false, got 1 (a number)"),
    ("kinematic-plane", body(shape='{ type = "plane" }', mass=None, kinematic="true"), "bodies[0].kinematic",
     re.escape("a plane can only be a fixed body (set fixed = true)")),
    ("string-for-shape", body(shape='"sphere"'), "bodies[0].shape", "expected a table with a 'type' key, got 'sphere' (a string)"),
    ("bodies-not-array", '[bodies]\nname = "a"\n', "bodies", "expected a list of tables ([[bodies]]), got a table"),
    ("substeps-fraction", "[simulation]\nsubsteps = 1.5\n" + BODY, "simulation.substeps", "expected a whole number, got 1.5 (a number)"),
    ("frame-string", body(angular_velocity_frame='"local"'), "bodies[0].angular_velocity_frame", "must be one of 'world', 'body', got 'local'"),
    # missing keys
    ("missing-name", body(name=None), "bodies[0]", "missing key 'name'"),
    ("missing-shape", body(shape=None), "bodies[0]", "missing key 'shape'"),
    ("missing-shape-type", body(shape="{ radius = 1 }"), "bodies[0].shape", "missing key 'type'"),
    ("missing-size", body(shape='{ type = "box" }'), "bodies[0].shape", "missing key 'size'"),
    ("missing-radius", body(shape='{ type = "sphere" }'), "bodies[0].shape", "missing key 'radius'"),
    ("missing-mass", body(mass=None), "bodies[0]", "missing key 'mass' (or 'density')"),
    ("missing-bodies", "[simulation]\nduration = 1\n", None, "missing key 'bodies' (a scene needs at least one [[bodies]] or [[robots]] entry)"),
    # zero or negative amounts
    ("negative-mass", body(mass="-1"), "bodies[0].mass", "must be positive, got -1"),
    ("zero-mass", body(mass="0"), "bodies[0].mass", "must be positive, got 0"),
    ("negative-density", body(mass=None, density="-5.5"), "bodies[0].density", "must be positive, got -5.5"),
    ("zero-size", body(shape='{ type = "box", size = [1, 1, 0] }'), "bodies[0].shape.size[2]", "must be positive, got 0"),
    ("negative-radius", body(shape='{ type = "sphere", radius = -0.1 }'), "bodies[0].shape.radius", "must be positive, got -0.1"),
    ("negative-friction", body(material="{ friction = -1 }"), "bodies[0].material.friction", "must be a finite number >= 0, got -1.0"),
    ("negative-rolling-resistance", body(material="{ rolling_resistance = -0.1 }"), "bodies[0].material.rolling_resistance",
     "must be a finite number >= 0, got -0.1"),
    ("string-spinning-friction", body(material='{ spinning_friction = "a" }'), "bodies[0].material.spinning_friction",
     "expected a number, got 'a' (a string)"),
    ("negative-stiffness", BODY + '[[forces]]\ntype = "spring"\nbody_a = "a"\nstiffness = -3\n', "forces[0].stiffness", "must be >= 0, got -3"),
    # collision filters and exclusions (collision/filter.py)
    ("filter-unknown-key", body(collision_filter="{ layer = 2 }"), "bodies[0].collision_filter.layer",
     "unknown key (expected one of category, mask, group, env)"),
    ("filter-not-table", body(collision_filter="2"), "bodies[0].collision_filter", "expected a table, got 2 (a number)"),
    ("filter-float-mask", body(collision_filter="{ mask = 1.5 }"), "bodies[0].collision_filter.mask", "expected an integer, got 1.5"),
    ("filter-bool-category", body(collision_filter="{ category = true }"), "bodies[0].collision_filter.category",
     "expected an integer, got True"),
    ("filter-category-too-wide", body(collision_filter="{ category = 0x100000000 }"), "bodies[0].collision_filter.category",
     "must be between 0 and 0xffffffff, got 4294967296"),
    ("filter-negative-mask", body(collision_filter="{ mask = -1 }"), "bodies[0].collision_filter.mask",
     "must be between 0 and 0xffffffff, got -1"),
    ("filter-group-too-large", body(collision_filter="{ group = 2147483648 }"), "bodies[0].collision_filter.group",
     "must be between -2147483648 and 2147483647, got 2147483648"),
    ("exclusion-unknown-body", BODY + '[[collision_exclusions]]\nbodies = ["a", "b"]\n', "collision_exclusions[0].bodies[1]",
     "unknown body 'b'"),
    ("exclusion-self", BODY + '[[collision_exclusions]]\nbodies = ["a", "a"]\n', "collision_exclusions[0].bodies",
     "a body cannot be excluded from itself ('a')"),
    ("exclusion-three-bodies", BODY + '[[collision_exclusions]]\nbodies = ["a", "a", "a"]\n', "collision_exclusions[0].bodies",
     "expected a list of two body names, got a list of 3"),
    ("exclusion-no-bodies", BODY + '[[collision_exclusions]]\n', "collision_exclusions[0]", "missing key 'bodies'"),
    ("exclusion-unknown-key", BODY + '[[collision_exclusions]]\nbody = "a"\n', "collision_exclusions[0].body",
     "unknown key (expected one of bodies)"),
    ("exclusions-not-list", 'collision_exclusions = 3\n' + BODY, "collision_exclusions",
     "expected a list of tables ([[collision_exclusions]]), got 3 (a number)"),
    # non-finite numbers (TOML nan / inf literals)
    ("nan-mass", body(mass="nan"), "bodies[0].mass", "must be a finite number, got nan"),
    ("inf-position", body(position="[0, inf, 0]"), "bodies[0].position[1]", "must be a finite number, got inf"),
    ("inf-duration", "[simulation]\nduration = inf\n" + BODY, "simulation.duration", "must be a finite number, got inf"),
    # orientation and inertia
    ("zero-quaternion", body(orientation="[0, 0, 0, 0]"), "bodies[0].orientation", "quaternion must not be zero (w, x, y, z = 0, 0, 0, 0)"),
    ("orientation-and-euler", body(orientation="[1, 0, 0, 0]", euler_deg="[0, 0, 0]"), "bodies[0].euler_deg", "give orientation or euler_deg, not both"),
    ("inertia-not-positive-definite", body(inertia="[[1, 0, 0], [0, 1, 0], [0, 0, -1]]"), "bodies[0].inertia",
     re.escape("inertia is not positive definite (eigenvalues [-1.0, 1.0, 1.0])")),
    ("inertia-triangle", body(inertia="[1, 1, 3]"), "bodies[0].inertia", "inertia violates the triangle inequality I1 \\+ I2 >= I3 .*"),
    ("inertia-negative-diagonal", body(inertia="[1, 1, -1]"), "bodies[0].inertia[2]", "must be positive, got -1"),
    # meshes
    ("mesh-not-closed", body(shape=f'{{ type = "mesh", vertices = {CUBE_VERTICES}, faces = {OPEN_BOX_FACES} }}'),
     "bodies[0].shape.vertices", re.escape("mesh is not closed (watertight): ") + r"\d+ boundary edges"
     + re.escape(" (an open surface on a fixed body: closed = false)")),
    ("mesh-closed-not-bool", body(shape=f'{{ type = "mesh", vertices = {CUBE_VERTICES}, faces = {OPEN_BOX_FACES}, closed = 0 }}'),
     "bodies[0].shape.closed", "expected true or false, got 0 (a number)"),
    ("mesh-open-moving", body(shape=f'{{ type = "mesh", vertices = {CUBE_VERTICES}, faces = {OPEN_BOX_FACES}, closed = false }}'),
     "bodies[0].fixed", re.escape("an open mesh (closed = false) can only be on a fixed or kinematic body (set fixed = true)")),
    ("mesh-file-missing", body(shape='{ type = "mesh", path = "meshes/nothere.obj" }'), "bodies[0].shape.path",
     "mesh file not found: .*meshes/nothere.obj"),
    ("mesh-no-faces", body(shape=f'{{ type = "mesh", vertices = {CUBE_VERTICES} }}'), "bodies[0].shape",
     re.escape("missing key 'faces' (give a mesh file 'path', or 'vertices' and 'faces')")),
    # compounds: every problem keyed down to the part
    ("compound-no-parts", body(shape='{ type = "compound", parts = [] }'), "bodies[0].shape.parts", "a compound needs at least one part"),
    ("compound-parts-not-list", body(shape='{ type = "compound", parts = { shape = { type = "sphere", radius = 1 } } }'),
     "bodies[0].shape.parts", "expected a list of part tables, got a table"),
    ("compound-missing-parts", body(shape='{ type = "compound" }'), "bodies[0].shape", "missing key 'parts'"),
    ("compound-part-not-table", body(shape='{ type = "compound", parts = [1] }'), "bodies[0].shape.parts[0]", "expected a table, got 1 (a number)"),
    ("compound-part-no-shape", body(shape='{ type = "compound", parts = [{ position = [0, 0, 0] }] }'), "bodies[0].shape.parts[0]",
     "missing key 'shape'"),
    ("compound-part-unknown-key", body(shape='{ type = "compound", parts = [{ shape = { type = "sphere", radius = 1 }, offset = 1 }] }'),
     "bodies[0].shape.parts[0].offset", "unknown key (expected one of shape, position, orientation, euler_deg, material)"),
    ("compound-part-negative-radius",
     body(shape='{ type = "compound", parts = [{ shape = { type = "sphere", radius = 1 } }, { shape = { type = "sphere", radius = -1 } }] }'),
     "bodies[0].shape.parts[1].shape.radius", "must be positive, got -1"),
    ("compound-in-compound", body(shape='{ type = "compound", parts = [{ shape = { type = "compound", parts = [] } }] }'),
     "bodies[0].shape.parts[0].shape.type", "a compound part cannot be a compound (expected one of sphere, box, capsule, cylinder, cone, ellipsoid, convex)"),
    ("compound-plane-part", body(shape='{ type = "compound", parts = [{ shape = { type = "plane" } }] }'),
     "bodies[0].shape.parts[0].shape.type", "a compound part cannot be a plane (expected one of sphere, box, capsule, cylinder, cone, ellipsoid, convex)"),
    ("compound-mesh-part", body(shape='{ type = "compound", parts = [{ shape = { type = "mesh", path = "x.obj" } }] }'),
     "bodies[0].shape.parts[0].shape.type", "a compound part cannot be a mesh (expected one of sphere, box, capsule, cylinder, cone, ellipsoid, convex)"),
    ("compound-unknown-part-type", body(shape='{ type = "compound", parts = [{ shape = { type = "blob" } }] }'),
     "bodies[0].shape.parts[0].shape.type", re.escape(f"unknown shape type 'blob' (expected one of {SHAPES})")),
    ("compound-part-zero-quaternion", body(shape='{ type = "compound", parts = [{ shape = { type = "sphere", radius = 1 }, orientation = [0, 0, 0, 0] }] }'),
     "bodies[0].shape.parts[0].orientation", re.escape("quaternion must not be zero (w, x, y, z = 0, 0, 0, 0)")),
    ("compound-part-orientation-and-euler",
     body(shape='{ type = "compound", parts = [{ shape = { type = "box", size = [1, 1, 1] }, orientation = [1, 0, 0, 0], euler_deg = [0, 0, 0] }] }'),
     "bodies[0].shape.parts[0].euler_deg", "give orientation or euler_deg, not both"),
    ("compound-part-short-position", body(shape='{ type = "compound", parts = [{ shape = { type = "sphere", radius = 1 }, position = [0, 1] }] }'),
     "bodies[0].shape.parts[0].position", "expected a list of 3 numbers, got 2"),
    # names and types
    ("unknown-integrator", '[simulation]\nintegrator = "rk5"\n' + BODY, "simulation.integrator",
     re.escape(f"unknown integrator 'rk5' (expected one of {INTEGRATORS})")),
    ("unknown-layout", '[simulation]\nlayout = "euler"\n' + BODY, "simulation.layout", "must be one of 'quaternion', 'matrix', got 'euler'"),
    ("unknown-shape-type", body(shape='{ type = "blob" }'), "bodies[0].shape.type", re.escape(f"unknown shape type 'blob' (expected one of {SHAPES})")),
    ("unknown-force-type", BODY + '[[forces]]\ntype = "magnet"\n', "forces[0].type",
     "unknown force type 'magnet' \\(expected one of drag, wind, constant, point, spring, impulse, explosion, fluid, buoyancy\\)"),
    ("force-missing-type", BODY + "[[forces]]\nlinear = 1\n", "forces[0]", "missing key 'type'"),
    ("unknown-body-in-force", BODY + '[[forces]]\ntype = "constant"\nbody = "boxx"\nforce = [1, 0, 0]\n', "forces[0].body", "unknown body 'boxx'"),
    ("unknown-body-in-list", BODY + '[[forces]]\ntype = "drag"\nbodies = ["a", "b"]\n', "forces[0].bodies[1]", "unknown body 'b'"),
    ("unknown-spring-body", BODY + '[[forces]]\ntype = "spring"\nbody_a = "a"\nbody_b = "c"\nstiffness = 1\n', "forces[0].body_b", "unknown body 'c'"),
    ("duplicate-names", BODY + BODY, "bodies[1].name", "duplicate body name 'a' (also bodies[0])"),
    ("mass-and-density", body(density="1000"), "bodies[0].density", "give either mass or density, not both"),
    ("plane-not-fixed", body(shape='{ type = "plane" }', mass=None), "bodies[0].fixed", re.escape("a plane can only be a fixed body (set fixed = true)")),
    ("no-bodies", "bodies = []\n", "bodies", "a scene needs at least one body"),
    ("drop-not-boolean", body(drop='"yes"'), "bodies[0].drop", re.escape("expected true or false, got 'yes' (a string)")),
    ("drop-nothing-below", body(drop="true"), "bodies[0].drop",
     re.escape("nothing to land on within 1000 m along [0.0, 0.0, -9.81]")),
    # time steps
    ("dt-not-dividing-frame", "[simulation]\ndt = 0.01\n" + BODY, "simulation.dt",
     re.escape("must divide 1 / frame_rate = 0.0416667 s into whole steps, got 0.01 s (4.16667 steps a frame)")),
    ("duration-not-whole-frames", "[simulation]\nduration = 0.3\n" + BODY, "simulation.duration",
     re.escape("must be a whole number of frames at 24 per second, got 0.3 s (7.2 frames)")),
    ("negative-dt", "[simulation]\ndt = -0.1\n" + BODY, "simulation.dt", "must be positive, got -0.1"),
]


def _escape_literal(problem: str) -> str:
    """Expected problems are regexes when they look like one, else literal text."""
    return problem if any(s in problem for s in ("\\", ".*", "\\d")) else re.escape(problem)


@pytest.mark.parametrize("text, key, problem", [c[1:] for c in BAD_SCENES], ids=[c[0] for c in BAD_SCENES])
def test_bad_scene_is_one_line_input_error(tmp_path, text, key, problem):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        load_scene(path)
    line = str(info.value)
    assert "\n" not in line
    prefix = f"{path}: " + (f"{key}: " if key else "")
    assert line.startswith(prefix), line
    assert re.fullmatch(_escape_literal(problem), line[len(prefix):]), line
    assert info.value.file == str(path) and info.value.key == key


def test_toml_syntax_error_names_file_line_and_column(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text('[[bodies]]\nname = "a"\nmass = = 1\n')
    with pytest.raises(InputError) as info:
        load_scene(path)
    assert str(info.value) == f"{path}: invalid TOML: Invalid value (at line 3, column 8)"


def test_json_syntax_error_names_file_line_and_column(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text('{"bodies": [\n  {"name": "a",}\n]}\n')
    with pytest.raises(InputError) as info:
        load_scene(path)
    assert str(info.value) == f"{path}: invalid JSON: Expecting property name enclosed in double quotes (at line 2, column 16)"


def test_json_duplicate_key(tmp_path):
    path = tmp_path / "dup.json"
    path.write_text('{"bodies": [{"name": "a", "name": "b"}]}')
    with pytest.raises(InputError, match=re.escape(f"{path}: invalid JSON: duplicate key 'name'")):
        load_scene(path)


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity"])
def test_json_non_finite_numbers(tmp_path, literal):
    path = tmp_path / "scene.json"
    path.write_text('{"bodies": [{"name": "a", "shape": {"type": "sphere", "radius": 1}, "mass": 1, "velocity": [0, %s, 0]}]}' % literal)
    with pytest.raises(InputError) as info:
        load_scene(path)
    value = {"NaN": "nan", "Infinity": "inf", "-Infinity": "-inf"}[literal]
    assert str(info.value) == f"{path}: bodies[0].velocity[1]: must be a finite number, got {value}"


def test_json_null_and_wrong_top_level(tmp_path):
    path = tmp_path / "scene.json"
    path.write_text('{"bodies": [{"name": "a", "shape": {"type": "sphere", "radius": null}, "mass": 1}]}')
    with pytest.raises(InputError, match=re.escape(f"{path}: bodies[0].shape.radius: expected a number, got null")):
        load_scene(path)
    path.write_text("[1, 2]")
    with pytest.raises(InputError) as info:
        load_scene(path)
    assert str(info.value) == f"{path}: expected a table of [simulation], [[bodies]] and [[forces]], got a list of 2"


def test_json_integer_too_large_for_a_float(tmp_path):
    path = tmp_path / "scene.json"
    path.write_text('{"bodies": [{"name": "a", "shape": {"type": "sphere", "radius": 1}, "mass": 1%s}]}' % ("0" * 400))
    with pytest.raises(InputError) as info:
        load_scene(path)
    assert str(info.value) == f"{path}: bodies[0].mass: must be a finite number, got an integer of 401 digits"


def test_missing_file_and_unknown_suffix(tmp_path):
    missing = tmp_path / "nothere.toml"
    with pytest.raises(InputError) as info:
        load_scene(missing)
    assert str(info.value) == f"{missing}: file not found"
    other = tmp_path / "scene.yaml"
    other.write_text("bodies: []\n")
    with pytest.raises(InputError) as info:
        load_scene(other)
    assert str(info.value) == f"{other}: unknown scene file type '.yaml' (expected .toml, .json, an MJCF .xml or a USD stage)"
    folder = tmp_path / "dir.toml"
    folder.mkdir()
    with pytest.raises(InputError) as info:
        load_scene(folder)
    assert str(info.value) == f"{folder}: is a folder, not a scene file"


def test_not_utf8(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_bytes(b"name = \"\xff\"\n")
    with pytest.raises(InputError, match=re.escape(f"{path}: not UTF-8 text")):
        load_scene(path)


def test_mesh_path_is_relative_to_the_scene_file(tmp_path, monkeypatch):
    (tmp_path / "meshes").mkdir()
    write_obj(tmp_path / "meshes" / "cube.obj", CUBE_VERTICES, CUBE_FACES)
    path = tmp_path / "scene.toml"
    path.write_text(body(shape='{ type = "mesh", path = "meshes/cube.obj" }'))
    monkeypatch.chdir(tmp_path / "meshes")  # not where the scene file is
    assert load_scene(path).world.mass[0] == 1


def test_library_errors_get_the_scene_key_prefixed():
    err = InputError("must be positive, got 0", "size[2]")
    assert str(err.within("bodies[0].shape", "scene.toml")) == "scene.toml: bodies[0].shape.size[2]: must be positive, got 0"
    assert str(InputError("bad", None).within("bodies[1]", "s.toml")) == "s.toml: bodies[1]: bad"


def test_unexpected_exception_becomes_input_error(tmp_path, monkeypatch):
    import tumble.scene_bodies as scene_module  # where the [[bodies]] entries build their shapes

    def broken(*args, **kwargs):
        raise KeyError("surprise")

    monkeypatch.setattr(scene_module, "Sphere", broken)
    path = tmp_path / "scene.toml"
    path.write_text(BODY)
    with pytest.raises(InputError) as info:
        load_scene(path)
    assert str(info.value) == f"{path}: bodies[0].shape: cannot read this value (KeyError: 'surprise')"


def test_scene_check_after_changing_settings(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(BODY)
    scene = load_scene(path)
    scene.duration = 0.5
    scene.check()
    scene.integrator = "rk5"
    with pytest.raises(InputError, match=re.escape(f"{path}: simulation.integrator: unknown integrator 'rk5'")):
        scene.check()


def test_a_key_with_control_characters_still_gives_one_line():
    # Regression (found by tests/test_fuzz.py): a key containing a newline made a two-line error.
    from tumble.scene import parse_scene

    with pytest.raises(InputError) as err:
        parse_scene({"\n": None}, "f.toml")
    assert str(err.value) == "f.toml: \\n: unknown key (expected one of simulation, bodies, robots, forces, contact, joints, joint_solver, collision_exclusions, contact_pairs, cameras)"


# ---------------------------------------------------------------------- compounds

COMPOUND_SCENE = """
[[bodies]]
name = "ground"
shape = { type = "plane" }
fixed = true

[[bodies]]
name = "pin"
mass = 1.5
position = [0, 0, 0.5]
shape = { type = "compound", parts = [
    { shape = { type = "cylinder", radius = 0.05, length = 0.3 } },
    { shape = { type = "sphere", radius = 0.06 }, position = [0, 0, 0.2] },
    { shape = { type = "box", size = [0.1, 0.1, 0.04] }, position = [0, 0, -0.17], euler_deg = [0, 0, 45] },
    { shape = { type = "capsule", radius = 0.02, length = 0.1 }, position = [0.07, 0, 0], orientation = [0, 1, 0, 0] },
] }
"""


def test_compound_scene_builds_the_parts_in_place(tmp_path):
    from tumble.math3d import quat_from_euler_deg
    from tumble.shapes import Compound, shape_from_dict, shape_to_dict

    path = tmp_path / "pin.toml"
    path.write_text(COMPOUND_SCENE)
    w = load_scene(path).world
    pin = w.shapes[1]
    assert isinstance(pin, Compound)
    assert [type(s) for s, _, _ in pin.parts] == [Cylinder, Sphere, Box, Capsule]
    np.testing.assert_array_equal(pin.parts[1][1], [0, 0, 0.2])
    np.testing.assert_array_equal(pin.parts[0][2], [1, 0, 0, 0])  # default: identity
    np.testing.assert_allclose(pin.parts[2][2], quat_from_euler_deg([0, 0, 45]), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(pin.parts[3][2], [0, 1, 0, 0])
    assert w.mass[1] == pytest.approx(1.5, rel=1e-14)
    # round trip through the JSON-ready form (what summary.json and the trajectory carry)
    d = shape_to_dict(pin)
    assert d["type"] == "compound" and [p["shape"]["type"] for p in d["parts"]] == ["cylinder", "sphere", "box", "capsule"]
    again = shape_from_dict(json.loads(json.dumps(d)))
    assert shape_to_dict(again) == d
    for (a, pa, qa), (b, pb, qb) in zip(pin.parts, again.parts):
        assert a == b and np.array_equal(pa, pb) and qa == qb
    # and the same body through a JSON scene file built from that dict
    doc = tomllib.loads(COMPOUND_SCENE)
    doc["bodies"][1]["shape"] = d
    json_path = tmp_path / "pin.json"
    json_path.write_text(json.dumps(doc))
    w2 = load_scene(json_path).world
    for name in ("mass", "inertia_body", "com_offset", "x", "q"):
        np.testing.assert_array_equal(getattr(w2, name), getattr(w, name), err_msg=name)


def test_compound_scene_runs_and_rests_on_its_parts(tmp_path):
    """A two-sphere dumbbell (spheres of radius 0.1 at x = -+0.3) dropped flat from 0.3 m lands on
    both spheres and rests with its centre at z = 0.1 (both spheres touching the ground): the parts
    collide where the scene put them. 2 mm covers the soft contact's sag (well under 1 mm here)."""
    path = tmp_path / "dumbbell.toml"
    path.write_text("""
[simulation]
duration = 1.5
[[bodies]]
name = "ground"
shape = { type = "plane" }
fixed = true
[[bodies]]
name = "dumbbell"
mass = 2
position = [0, 0, 0.3]
shape = { type = "compound", parts = [
    { shape = { type = "sphere", radius = 0.1 }, position = [-0.3, 0, 0] },
    { shape = { type = "sphere", radius = 0.1 }, position = [0.3, 0, 0] },
    { shape = { type = "cylinder", radius = 0.02, length = 0.5 }, euler_deg = [0, 90, 0] },
] }
""")
    scene = load_scene(path)
    traj = scene.run(progress=False)
    assert abs(traj.position[-1, 1, 2] - 0.1) < 0.002
    assert np.linalg.norm(traj.velocity[-1, 1]) < 0.01


def test_cli_validates_and_runs_a_compound_scene(tmp_path, capsys):
    """``tumble validate`` and ``tumble run`` on a compound body: ok, outputs written, the shape kept
    in summary.json; a bad part is one line with the part's key and exit status 2."""
    from tumble.cli import main

    path = tmp_path / "pin.toml"
    path.write_text("[simulation]\nduration = 0.25\n" + COMPOUND_SCENE)
    assert main(["validate", str(path)]) == 0
    assert capsys.readouterr().out == f"{path}: ok (2 bodies, 0 forces, integrator rk4, duration 0.25 s)\n"
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--no-progress"]) == 0
    capsys.readouterr()
    with np.load(out / "trajectory.npz", allow_pickle=False) as data:
        assert data["position"].shape == (7, 2, 3)
        assert data["position"][-1, 1, 2] < 0.5  # it fell
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scene"]["data"]["bodies"][1]["shape"]["type"] == "compound"

    bad = tmp_path / "bad.toml"
    bad.write_text(COMPOUND_SCENE.replace("radius = 0.06", "radius = -1"))
    for command in (["validate", str(bad)], ["run", str(bad), "--out", str(tmp_path / "o2")]):
        assert main(command) == 2
        err = capsys.readouterr().err
        assert err == f"tumble: error: {bad}: bodies[1].shape.parts[1].shape.radius: must be positive, got -1\n"


def test_a_kinematic_body_on_a_path_from_a_scene_file(tmp_path):
    """A scene's kinematic body with a path: it starts at the path's first pose and passes
    through each key at its time (to round-off), as the API's KeyframePath does."""
    path = tmp_path / "s.toml"
    path.write_text('[simulation]\nduration = 2.0\n'
                    '[[bodies]]\nname = "lift"\nkinematic = true\nshape = { type = "box", size = [1, 1, 0.1] }\n'
                    'path = { times = [0, 1, 2], positions = [[0, 0, 0], [0, 0, 1], [1, 0, 1]], '
                    'euler_deg = [[0, 0, 0], [0, 0, 90], [0, 0, 90]] }\n')
    scene = tumble.load_scene(path)
    lift = scene.world.body("lift")
    assert lift.kinematic and len(scene.world.paths) == 1
    traj = scene.run(progress=False)
    for k, (t, p) in enumerate(((0.0, (0, 0, 0)), (1.0, (0, 0, 1)), (2.0, (1, 0, 1)))):
        frame = int(round(t * scene.frame_rate))
        np.testing.assert_allclose(traj.position[frame, 0], p, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.orientation[-1, 0], (np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)), rtol=0, atol=1e-12)


def test_a_sensor_from_a_scene_file(tmp_path):
    """A scene's sensor body reports the ball that falls through it and never touches it."""
    path = tmp_path / "s.toml"
    path.write_text('[simulation]\nduration = 1.0\n'
                    '[[bodies]]\nname = "zone"\nsensor = true\nfixed = true\nshape = { type = "box", size = [1, 1, 1] }\n'
                    'position = [0, 0, 2]\n'
                    '[[bodies]]\nname = "ball"\nshape = { type = "sphere", radius = 0.1 }\nmass = 1\nposition = [0, 0, 4]\n')
    scene = tumble.load_scene(path)
    assert scene.world.body("zone").sensor
    sim = scene.simulator()
    sim.run(scene.duration, frame_rate=scene.frame_rate)
    ev = sim.sensor_events()
    assert ev.begin_visitor.tolist() == [1] and ev.end_visitor.tolist() == [1]
