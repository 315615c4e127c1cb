"""A World written as a UsdPhysics stage (``tb.save_usd``, ``tumble export SCENE -o x.usda``) and read
back (``tb.load_usd``): the same bodies, shapes, materials and joints.

The schema stores masses, inertias, velocities and joint frames in single precision (its
attributes are floats; the parser's descriptors too), so the comparison is to float32's
relative 6e-8, widened to 1e-6 for the sums formed from them; positions are doubles in the
stage but the parser hands them over in single precision too (1e-6 m at a few metres).
"""

import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pxr")

import tumble as tb  # noqa: E402
from tumble.joints import P_LOWER, P_MOTOR_SPEED, P_TARGET, P_UPPER  # noqa: E402
from tumble.scene import load_scene  # noqa: E402

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def round_trip(world, tmp_path):
    path = tmp_path / "stage.usda"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tb.TumbleWarning)
        tb.save_usd(world, path)
    back = tb.World()
    stage = tb.load_usd(back, path)
    back.gravity[:] = stage.gravity
    return back


def world_frames(world, bound):
    """A bound joint's two frames (3, 3) in the world now."""
    return [(np.eye(3) if body < 0 else world.R[body]) @ frame
            for body, frame in ((bound.body_a, bound.frame_a), (bound.body_b, bound.frame_b))]


@pytest.mark.parametrize("name", ["bowling", "robot_arm", "platforms", "dice", "marbles", "joints/four_bar",
                                  "joints/ragdoll_stairs", "mjcf_turntable"])
def test_a_scene_written_and_read_back_has_the_same_bodies_and_joints(tmp_path, name):
    """Every body by its name: fixed, kinematic or moving as before, its mass, world inertia,
    centre of mass, orientation, velocities and material; every joint of a kind the schema has,
    with its bodies and limits. Tolerances: single precision (module docstring)."""
    world = load_scene(EXAMPLES / f"{name}.toml").world
    back = round_trip(world, tmp_path)
    assert sorted(back.names) == sorted(world.names)
    np.testing.assert_allclose(back.gravity, world.gravity, rtol=1e-7)
    for i, n in enumerate(world.names):
        k = back.index_of(n)
        for flag in ("moving", "kinematic"):
            assert getattr(back, flag)[k] == getattr(world, flag)[i], (n, flag)
        if world.moving[i]:
            assert back.mass[k] == pytest.approx(world.mass[i], rel=1e-6)
            Iw = world.R[i] @ world.inertia_body[i] @ world.R[i].T
            Ib = back.R[k] @ back.inertia_body[k] @ back.R[k].T
            np.testing.assert_allclose(Ib, Iw, atol=1e-6 * np.abs(Iw).max())
        if not isinstance(world.shapes[i], tb.Plane):
            np.testing.assert_allclose(back.x[k], world.x[i], atol=1e-6 * max(1.0, np.abs(world.x[i]).max()))
            np.testing.assert_allclose(back.R[k], world.R[i], atol=1e-6)
        np.testing.assert_allclose(back.v[k], world.v[i], atol=1e-6)
        np.testing.assert_allclose(back.omega[k], world.omega[i], atol=1e-6)
        assert back.materials[k].friction == pytest.approx(world.materials[i].friction, rel=1e-6)
        assert back.materials[k].restitution == pytest.approx(world.materials[i].restitution, rel=1e-6)
    kinds = ("hinge", "slider", "ball", "fixed", "distance")
    written = [j for j in world.joints if j.kind in kinds]
    assert [j.kind for j in back.joints] == [j.kind for j in written]
    for a, b in zip(written, back.joints):
        pa, pb = a.bound.param.copy(), b.bound.param
        names = [world.names[x] if x >= 0 else None for x in (a.bound.body_a, a.bound.body_b)]
        flipped = names[0] is None
        if flipped:
            # a joint from the world to a body: the schema's body0 is the world, tumble's body_a is
            # a body, so it comes back from the body to the world, its coordinate the other way
            # round (the same joint: limits, speed and target negated)
            names = names[::-1]
            pa[P_LOWER], pa[P_UPPER] = -pa[P_UPPER], -pa[P_LOWER]
            pa[P_MOTOR_SPEED], pa[P_TARGET] = -pa[P_MOTOR_SPEED], -pa[P_TARGET]
        assert [back.names[x] if x >= 0 else None for x in (b.bound.body_a, b.bound.body_b)] == names
        # limits, motor and drive settings (the first ten parameters)
        np.testing.assert_allclose(pb[:10], pa[:10], rtol=1e-6, atol=1e-6)
        # the same joint frames in the world: the coordinate reads the same (a hinge opened before
        # the save reads its angle after the load)
        if a.kind != "distance":  # (a distance joint has no frames to keep)
            fa, fb = world_frames(world, a.bound), world_frames(back, b.bound)
            for x, y in zip(fa[::-1] if flipped else fa, fb):
                np.testing.assert_allclose(y, x, atol=1e-6)


def test_a_pendulum_written_and_read_back_swings_as_before(tmp_path):
    """examples/joints/four_bar.toml (a closed loop of hinges, non-chaotic) written and read back:
    after 2 s at dt 1/240 s the bodies are where the original's are, within 1e-5 m (the single
    precision of the stored state, carried by a motion that does not amplify it)."""
    world = load_scene(EXAMPLES / "joints" / "four_bar.toml").world
    back = round_trip(world, tmp_path)
    for w in (world, back):
        tb.Simulator(w, dt=1 / 240).step(480)
    for i, n in enumerate(world.names):
        np.testing.assert_allclose(back.x[back.index_of(n)], world.x[i], atol=1e-5)


def test_what_the_schema_cannot_hold_is_named_in_one_warning(tmp_path):
    """examples/dominoes.toml pushes its first domino with an impulse (a force record): the
    stage is written without it and one TumbleWarning says so (the reeds' ball joint drives and wind
    likewise); a world of particles (no collider) is refused."""
    world = load_scene(EXAMPLES / "dominoes.toml").world
    with pytest.warns(tb.TumbleWarning, match="no place for: forces other than gravity"):
        tb.save_usd(world, tmp_path / "d.usda")
    reeds = load_scene(EXAMPLES / "joints" / "reeds.toml").world  # ball joints with drives, wind
    with pytest.warns(tb.TumbleWarning, match="ball joints' drives; forces other than gravity"):
        tb.save_usd(reeds, tmp_path / "reeds.usda")
    w = tb.World()
    w.add_body(tb.Particles(points=[(0, 0, 0), (1, 0, 0), (0, 1, 0)], masses=[1, 1, 1]), name="dumbbell")
    with pytest.raises(tb.InputError, match="dumbbell: a body of particles has no collider"):
        tb.save_usd(w, tmp_path / "p.usda")


def test_tumble_export_writes_a_scene_that_tumble_run_reads_back(tmp_path):
    """``tumble export scene.toml -o scene.usda`` then ``tumble run scene.usda``: both exit 0; the
    run has the scene's bodies; a .glb asked of a scene is one line and exit status 2."""
    out = tmp_path / "arm.usda"
    cmd = [sys.executable, "-m", "tumble.cli"]
    p = subprocess.run(cmd + ["export", str(EXAMPLES / "robot_arm.toml"), "-o", str(out)], capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 0, p.stderr
    assert "USD stage with physics: 11 bodies, 3 joints" in p.stdout
    p = subprocess.run(cmd + ["validate", str(out)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0 and "11 bodies" in p.stdout, p.stderr
    p = subprocess.run(cmd + ["export", str(EXAMPLES / "robot_arm.toml"), "-o", str(tmp_path / "arm.glb")],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1
    assert "a scene is written as a USD stage with physics" in p.stderr


def test_joint_angles_reached_before_the_save_read_the_same_after_the_load(tmp_path):
    """examples/robot_arm.toml run 0.5 s (its turret turned 0.7 rad by its motor, its shoulder and
    elbow held near 1.2 and 0.9 rad by their drives), written and read back: one more step of
    each, both from a cold start, gives the same joint positions (within 1e-5 rad: the stored
    single precision carried through a step) and the same drive targets, so the loaded arm holds where the original holds. Without
    the schema's frames given to the joints, the loaded joints would read 0 and their targets
    and limits would have moved by the angles at the save."""
    scene = load_scene(EXAMPLES / "robot_arm.toml")
    world = scene.world
    sim = tb.Simulator(world, dt=scene.dt, joint_settings=scene.joint_settings)
    sim.step(120)
    back = round_trip(world, tmp_path)
    # both from a cold start (a new Simulator has no warm-start impulses: a warm original differs
    # from a cold copy by 1.6e-4 rad after one step, measured)
    sim = tb.Simulator(world, dt=scene.dt, joint_settings=scene.joint_settings)
    sim2 = tb.Simulator(back, dt=scene.dt, joint_settings=scene.joint_settings)
    sim.step(1)
    sim2.step(1)
    r1, r2 = sim.joint_readings(), sim2.joint_readings()
    assert np.abs(r1["position"]).max() > 0.5  # the arm is away from its zero pose
    np.testing.assert_allclose(r2["position"], r1["position"], atol=1e-5)
    for a, b in zip(world.joints, back.joints):
        assert b.bound.param[P_TARGET] == pytest.approx(a.bound.param[P_TARGET], abs=1e-6)


def test_collision_filters_go_out_as_collision_groups_and_come_back_the_same(tmp_path):
    """examples/sieve.toml sorts balls from boxes with Box2D filters (category, mask, and a
    group): written as one collision group per filter and read back, every pair of bodies
    collides or not exactly as before (``World.should_collide`` over all pairs)."""
    world = load_scene(EXAMPLES / "sieve.toml").world
    assert len(set(world.collision_filters)) > 2
    back = round_trip(world, tmp_path)
    n = world.body_count
    for a in range(n):
        for b in range(a + 1, n):
            ka, kb = back.index_of(world.names[a]), back.index_of(world.names[b])
            assert back.should_collide(ka, kb) == world.should_collide(a, b), (world.names[a], world.names[b])


def test_a_keyframed_path_goes_out_as_time_samples_and_comes_back_a_path(tmp_path):
    """examples/platforms.toml's shuttle moves on a keyframed path: written as time samples of its
    transform and read back as a path through the same poses (its centre of mass at each key
    and between keys, to the stored single precision), and after 3 s of both runs the shuttle is
    in the same place (1e-5 m)."""
    world = load_scene(EXAMPLES / "platforms.toml").world
    assert len(world.paths) == 1
    back = round_trip(world, tmp_path)
    assert len(back.paths) == 1
    p0, p1 = world.paths[0], back.paths[0]
    i, k = world.index_of(p0.body), back.index_of(p1.body)
    assert back.names[k] == world.names[i]
    for t in np.linspace(0.0, float(p0.times[-1]), 37):
        x0, q0 = p0.pose(t)
        q0 = world.q[i] if q0 is None else q0
        x1, q1 = p1.pose(t)
        from tumble.mass import _quat_matrix

        np.testing.assert_allclose(x1, x0 + _quat_matrix(q0) @ world.com_offset[i], atol=1e-6)
    for w in (world, back):
        tb.Simulator(w, dt=1 / 240).step(720)
    np.testing.assert_allclose(back.x[k], world.x[i], atol=1e-5)


def test_joint_armature_goes_out_as_physx_joint_armature_and_comes_back(tmp_path):
    """examples/mjcf_turntable.toml's MJCF turntable has joint armature (MuJoCo's), which
    UsdPhysics has no place for: it is written as PhysX's ``physxJoint:armature`` (the
    ``PhysxJointAPI`` Isaac Sim reads) and read back, so the World again takes the exact tree
    solve its armature asks for."""
    world = load_scene(EXAMPLES / "mjcf_turntable.toml").world
    armed = [j for j in world.joints if j.bound.param[20] > 0.0]  # P_ARMATURE
    assert armed
    back = round_trip(world, tmp_path)
    text = (tmp_path / "stage.usda").read_text()
    assert '"PhysxJointAPI"' in text and "float physxJoint:armature" in text
    for a in armed:
        b = next(j for j in back.joints if back.names[j.bound.body_b] == world.names[a.bound.body_b])
        assert b.bound.param[20] == pytest.approx(a.bound.param[20], rel=1e-6)
    assert back.exact_joints


def test_open_meshes_go_out_double_sided_and_come_back_open(tmp_path):
    """An open sheet and a closed icosphere held open (closed = false: a hollow shell) are written as
    double-sided meshes marked ``tumble:closed = false``; read back both are open meshes with their
    triangles (single precision), so a ball inside the shell stays inside after the load."""
    import trimesh
    from pxr import Usd, UsdGeom

    sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    world = tb.World(gravity=(0, 0, -9.81))
    V = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=float)
    world.add_body(tb.Mesh(vertices=V, faces=[[0, 1, 2], [0, 2, 3]], closed=False), fixed=True, name="sheet",
                   position=(5, 0, 0))
    world.add_body(tb.Mesh(vertices=sphere.vertices, faces=sphere.faces, closed=False), fixed=True, name="shell")
    world.add_body(tb.Sphere(0.2), mass=1.0, position=(0.1, 0, 0), name="ball")
    back = round_trip(world, tmp_path)
    stage = Usd.Stage.Open(str(tmp_path / "stage.usda"))
    meshes = [UsdGeom.Mesh(p) for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    assert len(meshes) == 2 and all(m.GetDoubleSidedAttr().Get() for m in meshes)
    names = list(back.names)
    for i, name in enumerate(("sheet", "shell")):
        shape = back.shapes[names.index(name)]
        assert isinstance(shape, tb.Mesh) and not shape.closed
        assert np.array_equal(shape.faces, world.shapes[i].faces)
        assert np.allclose(shape.vertices, world.shapes[i].vertices, atol=1e-6)
    tb.Simulator(back).step(480)
    ball = names.index("ball")
    assert np.linalg.norm(back.x[ball]) < 1.0 - 0.2 + 2e-3 and back.x[ball, 2] < -0.7


def test_a_path_that_lets_its_body_go_says_the_release_is_left_out(tmp_path):
    """examples/toss.toml's ball and crate are let go at their paths' last keys (``release``):
    UsdPhysics has no such event (a body's kinematic flag is one value of the stage), so the
    stage keeps their paths as time samples and the export's warning names the release as left
    out, rather than writing a stage that silently behaves otherwise."""
    world = load_scene(EXAMPLES / "toss.toml").world
    with pytest.warns(UserWarning, match="the release of keyframed paths"):
        tb.save_usd(world, tmp_path / "toss.usda")


def test_a_body_without_weight_goes_out_as_physx_disable_gravity_and_comes_back(tmp_path):
    """A box of gravity scale 0 (``World.set_gravity_scale``) is written with PhysX's
    ``physxRigidBody:disableGravity`` (``PhysxRigidBodyAPI``; UsdPhysics has no gravity scale) and
    read back with scale 0: it floats where it is, to the bit, over 0.5 s. A scale of 0.5 has no
    place in either schema: named in the warning, read back as 1. Damping rates go out as
    ``physxRigidBody:linearDamping`` and ``angularDamping`` and come back (float32)."""
    world = tb.World(gravity=(0, 0, -9.81))
    world.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 1), gravity_scale=0.0, name="floating")
    world.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(1, 0, 1), gravity_scale=0.5, name="half",
                   linear_damping=0.04, angular_damping=0.1)
    with pytest.warns(tb.TumbleWarning, match="gravity scales other than 0 and 1"):
        tb.save_usd(world, tmp_path / "stage.usda")
    text = (tmp_path / "stage.usda").read_text()
    assert '"PhysxRigidBodyAPI"' in text and "bool physxRigidBody:disableGravity = 1" in text
    back = round_trip(world, tmp_path)
    assert back.body("floating").gravity_scale == 0.0 and back.body("half").gravity_scale == 1.0
    half = back.body("half")  # PhysX's float damping rates: 32-bit
    assert (half.linear_damping, half.angular_damping) == (pytest.approx(0.04, rel=1e-7), pytest.approx(0.1, rel=1e-7))
    assert back.body("floating").linear_damping == 0.0 and "float physxRigidBody:angularDamping = 0.1" in text
    x = back.body("floating").x.copy()
    tb.Simulator(back).step(120)
    assert np.array_equal(back.body("floating").x, x)


def test_a_joints_passive_spring_and_damper_go_out_summed_into_its_drive(tmp_path):
    """UsdPhysics has one drive a joint: a hinge's drive (stiffness 2, damping 0.1 to 0.4 rad) and its
    passive spring and damper (0.5, 0.04 to -1 rad: MuJoCo's joint stiffness and damping, the MJCF
    reader's servoed joints) are written as one drive of their sums, the target the
    stiffness-weighted rest, which is the same law (both linear in q and q'; tumble solves them as
    one row below a cap): read back, the joint's drive holds 2.5, 0.14 and (2 x 0.4 - 0.5) / 2.5
    (single precision: 1e-6 relative). Before, the passive pair was left out of the file."""
    world = tb.World()
    arm = world.add_body(tb.Box(size=(0.1, 0.1, 0.5)), mass=1.0, position=(0, 0, 1))
    world.add_joint(tb.HingeJoint(arm, None, anchor=(0, 0, 1.25), axis=(1, 0, 0), stiffness=2.0, damping=0.1,
                                  target=0.4, passive_stiffness=0.5, passive_damping=0.04, springref=-1.0))
    back = round_trip(world, tmp_path)
    (joint,) = back.joints
    assert (joint.stiffness, joint.damping, joint.target) == pytest.approx((2.5, 0.14, (2 * 0.4 - 0.5) / 2.5), rel=1e-6)


def test_a_drives_target_velocity_goes_out_as_the_drives_target_velocity_and_comes_back(tmp_path):
    """A hinge's PD drive with a target velocity (stiffness 2, damping 0.1 to 0.4 rad and 3 rad/s) is
    UsdPhysics' drive law stiffness (tp - q) + damping (tv - q') as it is: written as the drive's
    targetVelocity (per degree, as its angles), and read back as the drive's ``target_velocity``
    (single precision: 1e-6 relative); with the passive damper summed into the drive (0.04), the
    velocity written is the pull c w over the summed damping, 0.1 x 3 / 0.14, the same law. Before,
    the exporter left it out, and the reader refused a drive with a stiffness and a target velocity.
    A slider's drive without stiffness goes out the same way and comes back a drive (damping 4 N s/m
    towards 0.5 m/s; before, a motor: infinite gain), a motor as a motor (the stiff damping the
    exporter writes a motor with)."""
    world = tb.World()
    arm = world.add_body(tb.Box(size=(0.1, 0.1, 0.5)), mass=1.0, position=(0, 0, 1))
    world.add_joint(tb.HingeJoint(arm, None, anchor=(0, 0, 1.25), axis=(1, 0, 0), stiffness=2.0, damping=0.1,
                                  target=0.4, target_velocity=3.0))
    (joint,) = round_trip(world, tmp_path).joints
    assert (joint.stiffness, joint.damping, joint.target, joint.target_velocity) == \
        pytest.approx((2.0, 0.1, 0.4, 3.0), rel=1e-6)

    world = tb.World()
    arm = world.add_body(tb.Box(size=(0.1, 0.1, 0.5)), mass=1.0, position=(0, 0, 1))
    world.add_joint(tb.HingeJoint(arm, None, anchor=(0, 0, 1.25), axis=(1, 0, 0), stiffness=2.0, damping=0.1,
                                  target=0.4, target_velocity=3.0, passive_damping=0.04))
    (joint,) = round_trip(world, tmp_path / "passive").joints
    assert (joint.damping, joint.target_velocity) == pytest.approx((0.14, 0.1 * 3.0 / 0.14), rel=1e-6)

    world = tb.World()
    block = world.add_body(tb.Box(size=(0.1, 0.1, 0.1)), mass=1.0, position=(0, 0, 1))
    wheel = world.add_body(tb.Cylinder(0.1, 0.05), mass=1.0, position=(1, 0, 1))
    world.add_joint(tb.SliderJoint(block, None, anchor=(0, 0, 1), axis=(1, 0, 0), damping=4.0, target_velocity=0.5))
    world.add_joint(tb.HingeJoint(wheel, None, anchor=(1, 0, 1), axis=(0, 0, 1), motor_speed=2.0, max_motor_torque=3.0))
    slider, motor = round_trip(world, tmp_path / "velocity").joints
    assert (slider.damping, slider.target_velocity) == pytest.approx((4.0, 0.5), rel=1e-6)
    assert slider.motor_speed is None
    assert (motor.motor_speed, motor.max_motor_torque, motor.damping) == pytest.approx((2.0, 3.0, 0.0), rel=1e-6)
