"""MJCF models (``tumble.load_mjcf``) against MuJoCo itself: the same file compiled by MuJoCo is the
reference for what the file means (masses, centres, inertias, joint anchors and axes, after its
defaults, classes, angle units, orientation forms and fromto geoms), and MuJoCo's RK4 at a small
step is the reference for the motion. The engines' contact and joint models differ, so the motion
is compared on a chain without contacts or struck limits, where both integrate the same equations.
"""

import re
from pathlib import Path

import numpy as np
import pytest

import tumble as tb
from tumble.solver.joints import ACCURATE

mujoco = pytest.importorskip("mujoco")

G = 9.81

# Every orientation form, nested default classes (class and childclass), fromto capsules and
# cylinders, densities and masses, an inertial with a quat and one with fullinertia, a joint pos off
# the body origin, a slide and a ball joint, a visual geom (mass, no collision), a welded body
# (merged into its parent in tumble), angles in degrees (MuJoCo's default compiler).
MODEL = """
<mujoco model="parts">
  <default>
    <joint damping="0.05"/>
    <geom density="800"/>
    <default class="heavy">
      <geom density="2500" type="box" size="0.05 0.04 0.03"/>
      <default class="heavier"><geom density="4000"/></default>
    </default>
  </default>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="a" pos="0.1 0.2 2" euler="10 20 30">
      <joint name="j1" type="hinge" axis="0 1 0.2" pos="0.02 0 0.05" range="-90 90"/>
      <geom type="capsule" fromto="0 0 0 0.1 0.05 -0.5" size="0.04"/>
      <geom class="heavy" pos="0.1 0 -0.2" quat="0.9 0.1 0.3 0.2"/>
      <body name="b" pos="0.1 0.05 -0.5" axisangle="1 1 0 25" childclass="heavy">
        <joint name="j2" type="slide" axis="1 0 0" range="-0.1 0.2"/>
        <geom pos="0 0 -0.1"/>
        <geom class="heavier" pos="0.05 0.02 -0.2" xyaxes="0 1 0 -1 0 0.3"/>
        <geom type="cylinder" fromto="0 0 -0.3 0 0.1 -0.5" size="0.03" mass="0.7"/>
        <body name="c" pos="0 0 -0.6" zaxis="0.2 0.3 1">
          <joint name="j3" type="ball" damping="0"/>
          <inertial pos="0.01 0.02 -0.1" quat="0.8 0.2 0.4 0.1" mass="1.3" diaginertia="0.02 0.03 0.04"/>
          <geom type="sphere" size="0.06" contype="0" conaffinity="0"/>
        </body>
        <body name="d" pos="0.2 0 -0.1">
          <joint name="j4" axis="0 0 1" pos="0 0.01 0"/>
          <inertial pos="0 0 0" mass="0.5" fullinertia="0.01 0.012 0.014 0.001 -0.002 0.0005"/>
          <body name="welded" pos="0.1 0 0" euler="0 90 0">
            <geom type="sphere" size="0.05" pos="0 0 0.02" density="3000"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def write(tmp_path, text, name="model.xml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def mujoco_bodies(path):
    """{body name: (mass, centre (3,) world, inertia (3, 3) world about the centre)} and
    {joint name: (anchor (3,), axis (3,))} of MuJoCo's compiled model at qpos0."""
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    bodies = {}
    for i in range(1, m.nbody):
        R = d.ximat[i].reshape(3, 3)
        bodies[m.body(i).name] = (float(m.body_mass[i]), d.xipos[i].copy(), R @ np.diag(m.body_inertia[i]) @ R.T)
    joints = {m.joint(j).name: (d.xanchor[j].copy(), d.xaxis[j].copy()) for j in range(m.njnt)}
    return bodies, joints


def mujoco_motion(path, q0=None, samples=20, sample=0.05, controls=None):
    """(joint names, qpos (samples, n) every ``sample`` s) of MuJoCo stepping the file from qpos q0
    (default the model's) with ``controls`` ({actuator: ctrl}) (its <option>: RK4 at dt 1/4000 s
    in these models)."""
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    if q0 is not None:
        d.qpos[:] = q0
    for name, value in (controls or {}).items():
        d.ctrl[m.actuator(name).id] = value
    qpos = []
    for _ in range(samples):
        mujoco.mj_step(m, d, nstep=int(round(sample / m.opt.timestep)))
        qpos.append(d.qpos.copy())
    return [m.joint(j).name for j in range(m.njnt)], np.array(qpos)


def tumble_motion(path, names, dt=1 / 240, controls=None, samples=20, sample=0.05, **load):
    """(joint positions (samples, n) of ``names`` every ``sample`` s, the Simulator, the Robot) of
    tumble running the file at ``dt`` (its default joint solver) with ``controls``."""
    world = tb.World(gravity=(0, 0, -G))
    robot = tb.load_mjcf(world, path, **load)
    sim = tb.Simulator(world, dt=dt)
    if controls:
        robot.set_controls(sim, controls)
    q = []
    for _ in range(samples):
        sim.step(int(round(sample / dt)))
        s = robot.joint_states(sim)
        q.append([s[n][0] for n in names])
    return np.array(q), sim, robot


def combined(parts):
    """Mass, centre and inertia about it of (mass, centre, inertia) parts (parallel-axis theorem)."""
    mass = sum(p[0] for p in parts)
    centre = sum(p[0] * p[1] for p in parts) / mass
    inertia = sum(I + m * (np.dot(c - centre, c - centre) * np.eye(3) - np.outer(c - centre, c - centre))
                  for m, c, I in parts)
    return mass, centre, inertia


def assert_mass_properties(body, reference, name="", rel=1e-12, centre=1e-12, inertia=1e-10):
    """``body``'s mass, centre (world) and inertia (world, about the centre) equal ``reference``
    (mass, centre, inertia: ``mujoco_bodies``' entry) to ``rel`` relative, ``centre`` m and
    ``inertia`` relative to the largest moment."""
    mass, c, I = reference
    assert body.mass == pytest.approx(mass, rel=rel), name
    np.testing.assert_allclose(body.x, c, atol=centre, err_msg=name)
    R = np.asarray(body.R)
    np.testing.assert_allclose(R @ np.asarray(body.inertia_body) @ R.T, I, atol=inertia * np.abs(I).max(), err_msg=name)


def assert_rays_down_hit_where_mujoco_does(world, path, points, tol):
    """Rays straight down from z = 3 m over ``points`` ((x, y) pairs) hit tumble's world where
    ``mj_ray`` hits MuJoCo's compiled model of ``path``, to ``tol`` m (both must hit)."""
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    for x, y in points:
        origin = np.array([x, y, 3.0])
        expected = mujoco.mj_ray(m, d, origin, np.array([0.0, 0.0, -1.0]), None, 1, -1, np.zeros(1, np.int32))
        assert expected > 0, (x, y)
        assert world.ray_cast(origin, (0.0, 0.0, -1.0)).distance[0] == pytest.approx(expected, abs=tol), (x, y)


@pytest.mark.parametrize("eulerseq, inertiafromgeom", [("xyz", "auto"), ("ZYX", "auto"), ("zxz", "auto"), ("XzY", "auto"),
                                                      ("xyz", "true")])
def test_mass_properties_and_joint_frames_match_mujocos_compiled_model(tmp_path, eulerseq, inertiafromgeom):
    # Tolerances: both sides compute the same closed forms in double precision (1e-12 relative for
    # masses and positions; 1e-10 for inertias, summed from several parts). A misread default, class,
    # angle unit (degrees here), orientation form or fromto frame is off by percents.
    # (each Euler sequence: lowercase axes turn with the frame, uppercase stay fixed, as MuJoCo's)
    path = write(tmp_path, MODEL.replace('<mujoco model="parts">',
                                         f'<mujoco model="parts"><compiler eulerseq="{eulerseq}" '
                                         f'inertiafromgeom="{inertiafromgeom}"/>'))
    ref, ref_joints = mujoco_bodies(path)
    world = tb.World(gravity=(0, 0, -G))
    robot = tb.load_mjcf(world, path)
    ref["d"] = combined([ref["d"], ref["welded"]])  # tumble merges a welded body into its parent
    assert robot.links["welded"] is robot.links["d"]
    for name in ("a", "b", "c", "d"):
        assert_mass_properties(robot.links[name], ref[name], name)
    for name in ("j1", "j2", "j3", "j4"):
        joint = robot.joints[name]
        anchor, axis = ref_joints[name]
        np.testing.assert_allclose(joint.anchor, anchor, atol=1e-12, err_msg=name)
        if name != "j3":
            np.testing.assert_allclose(np.asarray(joint.axis) / np.linalg.norm(joint.axis), axis, atol=1e-12,
                                       err_msg=name)
    # the ranges in degrees, the slide's in metres; the ball has no limit; the visual sphere has no shape
    assert robot.joints["j1"].lower == pytest.approx(-np.pi / 2) and robot.joints["j1"].upper == pytest.approx(np.pi / 2)
    assert (robot.joints["j2"].lower, robot.joints["j2"].upper) == (-0.1, 0.2)
    assert robot.joints["j3"].cone_limit is None
    assert world.names[robot.links["world/floor"].index] == "parts/world/floor"


def test_settotalmass_scales_masses_and_inertias_as_mujoco_does(tmp_path):
    """``<compiler settotalmass>`` (Gymnasium's half cheetah weighs 14 kg by it; tumble read 21.2 kg
    before session 30): every body's mass and inertia against MuJoCo's compiled model, the same
    closed forms times one factor (tolerances as the test above); a total that is no number is one
    line."""
    path = write(tmp_path, MODEL.replace('<mujoco model="parts">',
                                         '<mujoco model="parts"><compiler settotalmass="7.5"/>'))
    ref, _ = mujoco_bodies(path)
    assert sum(r[0] for r in ref.values()) == pytest.approx(7.5, rel=1e-12)
    world = tb.World(gravity=(0, 0, -G))
    robot = tb.load_mjcf(world, path)
    ref["d"] = combined([ref["d"], ref["welded"]])
    for name in ("a", "b", "c", "d"):
        assert_mass_properties(robot.links[name], ref[name], name)
    bad = write(tmp_path, MODEL.replace('<mujoco model="parts">',
                                        '<mujoco model="parts"><compiler settotalmass="heavy"/>'), "bad.xml")
    with pytest.raises(tb.InputError, match=r"bad\.xml.*compiler\.settotalmass"):
        tb.load_mjcf(tb.World(), bad)



MASSLESS = """
<mujoco model="massless">
  <compiler angle="radian" inertiafromgeom="{ifg}"/>
  <default><default class="visual"><geom contype="0" conaffinity="0" density="0"/></default></default>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="h" axis="0 1 0"/>
      <inertial pos="0.3 0 0" mass="1.5" diaginertia="0.01 0.02 0.03"/>
      <geom class="visual" type="capsule" fromto="0 0 0 0.6 0 0" size="0.03"/>
      <geom type="sphere" size="0.05" pos="0.6 0 0" mass="0"/>
      <body name="hand" pos="0.6 0 0">
        <joint name="s" type="slide" axis="1 0 0"/>
        <geom type="box" size="0.04 0.05 0.06" pos="0.1 0 0" euler="0 0 0.4" density="2000"/>
        <geom class="visual" type="box" size="0.2 0.2 0.2" euler="0.3 0 0"/>
        <geom type="sphere" size="0.3" mass="0" density="500"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.mark.parametrize("ifg", ["auto", "true"])
def test_massless_geoms_are_accepted_and_weigh_nothing_as_in_mujoco(tmp_path, ifg):
    """``density="0"`` and ``mass="0"`` geoms (the visual geoms' idiom: contype 0, conaffinity 0,
    density 0) are massless, as MuJoCo compiles them: they add nothing to their body's mass, centre
    or inertia (nor to its inertial frame: the hand's lone massive box sets it, as in MuJoCo), with
    an ``<inertial>`` (the arm) or without (the hand), and with ``inertiafromgeom`` "true" (the
    arm's geoms all massless: its ``<inertial>`` holds, as MuJoCo's compiler keeps it). Compared with
    MuJoCo's compiled model of the same file; tolerances as ``test_mass_properties_...`` (the same
    closed forms in double precision). Before, both files stopped with "must be positive, got 0"."""
    path = write(tmp_path, MASSLESS.format(ifg=ifg))
    ref, _ = mujoco_bodies(path)
    assert ref["arm"][0] == 1.5 and ref["hand"][0] == pytest.approx(2000 * 0.08 * 0.1 * 0.12, rel=1e-12)
    world = tb.World(gravity=(0, 0, -G))
    robot = tb.load_mjcf(world, path)
    for name in ("arm", "hand"):
        assert_mass_properties(robot.links[name], ref[name], name)
    # the massless geoms that collide keep their shapes; the visual ones have none
    assert len(robot.model.links["arm"].parts) == 1 and len(robot.model.links["hand"].parts) == 2


@pytest.mark.parametrize("geoms, key, problem", [
    ('<geom size="0.1" density="0"/>', "link[b]", "a link that moves needs an <inertial> with a mass > 0"),
    ('<geom size="0.1" mass="0"/><geom size="0.1" pos="0 0 1" density="0"/>', "link[b]",
     "a link that moves needs an <inertial> with a mass > 0"),
    ('<geom size="0.1" density="-1"/>', "body[b].geom[0].density", "must be >= 0, got -1"),
    ('<geom size="0.1" mass="-2"/>', "body[b].geom[0].mass", "must be >= 0, got -2"),
])
def test_a_moving_body_of_massless_geoms_alone_is_one_line_as_mujoco_refuses_it(tmp_path, geoms, key, problem):
    """A moving body whose geoms are all massless and that has no ``<inertial>`` has no mass: one
    line naming it, as MuJoCo's compiler refuses it ("mass and inertia of moving bodies must be
    larger than mjMINVAL"); a negative mass or density is one line too (MuJoCo: "negative in
    geom"). A massless body welded to a heavy child is fine in both (tumble merges them)."""
    path = write(tmp_path, f'<mujoco><worldbody><body name="b"><joint/>{geoms}</body></worldbody></mujoco>')
    with pytest.raises(ValueError):
        mujoco.MjModel.from_xml_path(str(path))
    with pytest.raises(tb.InputError) as info:
        tb.load_mjcf(tb.World(), path)
    line = str(info.value)
    assert "\n" not in line and str(path) in line and key in line and problem in line, line
    welded = write(tmp_path, '<mujoco><worldbody><body name="b"><joint/><geom size="0.1" density="0"/>'
                             '<body name="c" pos="1 0 0"><geom size="0.1"/></body></body></worldbody></mujoco>',
                   "welded.xml")
    ref, _ = mujoco_bodies(welded)
    robot = tb.load_mjcf(tb.World(), welded)
    assert ref["b"][0] == 0.0 and robot.links["b"] is robot.links["c"]
    assert robot.links["b"].mass == pytest.approx(ref["c"][0], rel=1e-12)


CHAIN = """
<mujoco model="chain">
  <compiler angle="radian"/>
  <option timestep="0.00025" integrator="RK4" gravity="0 0 -9.81"/>
  <default><joint type="hinge" axis="0 1 0" damping="0.3"/><geom type="capsule" size="0.04"/></default>
  <worldbody>
    <body name="upper" pos="0 0 2">
      <joint name="shoulder"/>
      <geom fromto="0 0 0 0.1 0 -0.8"/>
      <geom type="box" size="0.05 0.05 0.05" pos="0.1 0 -0.8" density="3000"/>
      <body name="lower" pos="0.1 0 -0.8">
        <joint name="elbow" pos="0 0 0"/>
        <geom fromto="0 0 0 0.05 0 -0.6"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_chain_swings_as_mujoco_rk4_says(tmp_path):
    # The same file in both engines, released at (0.6, -0.4) rad, 1 s, no contact: MuJoCo's RK4 at
    # dt 1/4000 s (its <option>) is exact to ~1e-8 here; tumble's tree solve is first order: measured
    # 1.16e-3 rad at dt 1/240 and 2.9e-4 at 1/960 (4.0x); the default soft joints 1.0e-3 at 1/240.
    # Tolerance about twice the measured error. A wrong mass property or joint frame moves the elbow
    # by more than 1e-2 rad within the second.
    path = write(tmp_path, CHAIN)
    _, ref = mujoco_motion(path, (0.6, -0.4))
    sample = 0.05
    errors = []
    for dt, settings in ((1 / 240, ACCURATE), (1 / 960, ACCURATE), (1 / 240, None)):
        world = tb.World(gravity=(0, 0, -G))
        robot = tb.load_mjcf(world, path, joint_positions={"shoulder": 0.6, "elbow": -0.4})
        sim = tb.Simulator(world, dt=dt, joint_settings=settings)
        q = []
        for _ in range(20):
            sim.step(int(round(sample / dt)))
            s = robot.joint_states(sim)
            q.append([s["shoulder"][0], s["elbow"][0]])
        errors.append(np.max(np.abs(np.array(q) - ref)))
    assert errors[0] < 2.5e-3 and errors[2] < 2.5e-3, errors
    assert errors[0] / errors[1] > 3.5, errors


BALL_SPRING = """
<mujoco model="ball spring">
  <option timestep="0.00025" integrator="RK4"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="shoulder" type="ball" stiffness="4" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.5 0.15 0.05" size="0.03" density="1000"/>
      <geom type="box" pos="0.5 0.15 0.05" size="0.04 0.06 0.02" density="3000"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_ball_joints_stiffness_and_damping_move_the_arm_as_mujoco_rk4_says(tmp_path):
    """A ball joint's ``stiffness`` (a spring to the model's pose: MuJoCo's qpos_spring of a ball is
    its qpos0) and ``damping`` (on the relative angular velocity) become the ``BallJoint``'s drive. An
    arm held out sideways by the spring sags 0.87 rad and wobbles in 3-D under gravity; its rotation
    from the start every 0.05 s for 1 s against MuJoCo's RK4 at dt 1/4000 s: measured 5.5e-3 rad at
    dt 1/240 (default joints; the tree solve 5.8e-3) and 1.4e-3 at 1/960 (first order, as the drive's
    implicit row). Bound: twice the measured. Without the spring the arm falls (over 1 rad off)."""
    from scipy.spatial.transform import Rotation

    path = write(tmp_path, BALL_SPRING)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    start = d.xmat[1].reshape(3, 3).copy()
    ref = []
    for _ in range(20):
        mujoco.mj_step(m, d, nstep=int(round(0.05 / m.opt.timestep)))
        ref.append(d.xmat[1].reshape(3, 3) @ start.T)
    assert np.linalg.norm(Rotation.from_matrix(ref[-1]).as_rotvec()) > 0.5  # it moves
    world = tb.World(gravity=(0, 0, -G))
    robot = tb.load_mjcf(world, path)
    joint = robot.joints["shoulder"]
    assert (joint.stiffness, joint.damping) == (4.0, 0.05)
    arm = world.index_of("ball spring/arm")
    sim = tb.Simulator(world, dt=1 / 240)
    R0 = np.array(world.R[arm])
    errors = []
    for k in range(20):
        sim.step(12)
        errors.append(np.linalg.norm(Rotation.from_matrix(world.R[arm] @ R0.T @ ref[k].T).as_rotvec()))
    assert max(errors) < 1.1e-2, max(errors)


def test_a_free_body_lands_on_the_worldbody_floor_and_a_position_actuator_holds_its_joint(tmp_path):
    # A free ball dropped on the worldbody's plane comes to rest on it (its centre r above, within
    # the soft contact's resting overlap); a position actuator (kp 200, kv 5) holds a horizontal
    # arm up at its static equilibrium k theta = m g d cos theta (brentq; the drive is a PD drive to
    # ctrl 0), its velocity motor left off.
    from scipy.optimize import brentq

    path = write(tmp_path, """
<mujoco model="m">
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1" friction="0.8"/>
    <body name="ball" pos="0 0 1"><freejoint/><geom type="sphere" size="0.1" mass="2"/></body>
    <body name="arm" pos="2 0 1">
      <joint name="hinge" type="hinge" axis="0 1 0"/>
      <geom type="sphere" size="0.05" pos="0.5 0 0" mass="1"/>
    </body>
  </worldbody>
  <actuator><position joint="hinge" kp="200" kv="5"/><motor joint="hinge" gear="1"/></actuator>
</mujoco>""")
    world = tb.World(gravity=(0, 0, -G))
    world.sleeping = False
    robot = tb.load_mjcf(world, path)
    sim = tb.Simulator(world, dt=1 / 240)
    sim.step(480)
    ball = robot.links["ball"]
    assert ball.x[2] == pytest.approx(0.1, abs=1e-4) and np.linalg.norm(ball.v) < 1e-3
    assert world.materials[robot.links["world/floor"].index].friction == 0.8  # the geom's friction
    assert world.materials[ball.index].friction == 1.0  # MuJoCo's default
    theta = robot.joint_states(sim)["hinge"][0]
    # MuJoCo's hinge about +y: a positive angle turns x towards -z, so gravity pushes theta up (positive)
    expected = brentq(lambda t: 200 * t - 1.0 * G * 0.5 * np.cos(t), 0, 1)
    assert theta == pytest.approx(expected, abs=1e-4)


@pytest.mark.parametrize("body, key, problem", [
    ('<body><geom type="sdf" size="0.1 0.2 0.3"/></body>', "body[body1].geom[0].type", "unsupported geom type"),
    ('<body><freejoint/><joint/><geom size="0.1"/></body>', "body[body1]", "free joint must be its body's only"),
    ('<body><joint name="h"/><joint name="h"/><geom size="0.1"/></body>', "joint[h]", "duplicate joint name"),
    ('<body><joint type="screw"/><geom size="0.1"/></body>', "joint[body1_joint].type", "unknown joint type"),
    ('<body><joint range="2 1"/><geom size="0.1"/></body>', "joint[body1_joint].range", "wrong way round"),
    ('<body><joint range="1"/><geom size="0.1"/></body>', "joint[body1_joint].range", "expected 2 numbers"),
    ('<body><geom type="capsule" size="0.1"/></body>', "body[body1].geom[0].size", "needs 2 size numbers"),
    ('<body><geom type="mesh" mesh="nope"/></body>', "body[body1].geom[0].mesh", "unknown mesh"),
    ('<body childclass="nope"><geom size="0.1"/></body>', "body[body1].childclass", "unknown default class"),
    ('<body><geom class="nope" size="0.1"/></body>', "geom.class", "unknown default class"),
    ('<body pos="0 0 x"><geom size="0.1"/></body>', "body[body1].pos", "expected numbers"),
    ('<body quat="0 0 0 0"><geom size="0.1"/></body>', "body[body1].quat", "zero vector"),
    ('<body euler="0 0 0" quat="1 0 0 0"><geom size="0.1"/></body>', "body[body1]", "one orientation"),
    ('<body><joint/><geom type="plane" size="1 1 1"/></body>', "body[body1].geom[0]", "<worldbody> geom"),
    ('<body><joint damping="-1"/><geom size="0.1"/></body>', "joint[body1_joint].damping", ">= 0"),
    ('<body><joint/></body>', "link[body1]", "mass > 0"),
])
def test_bad_models_stop_with_one_line_naming_file_element_and_problem(tmp_path, body, key, problem):
    path = write(tmp_path, f'<mujoco><worldbody>{body}</worldbody></mujoco>')
    with pytest.raises(tb.InputError) as info:
        tb.load_mjcf(tb.World(), path)
    line = str(info.value)
    assert "\n" not in line and str(path) in line and key in line and problem in line, line


@pytest.mark.parametrize("text, problem", [
    ("<mujoco><worldbody/><equality><weld body1='a'/></equality></mujoco>", "equality.weld[0].body1: unknown body 'a'"),
    ("<mujoco><worldbody/><equality><joint joint1='a'/></equality></mujoco>", "equality.joint[0].joint1: unknown joint 'a'"),
    ("<mujoco><worldbody/><equality><tendon tendon1='a'/></equality></mujoco>", "<equality><tendon> is not supported"),
    ("<mujoco><worldbody><body name='b'><joint/><geom size='0.1'/></body></worldbody><equality>"
     "<weld body1='b' relpose='0 0 1 1 0 0 0'/></equality></mujoco>", "relpose is not supported"),
    ("<mujoco><worldbody><body name='b'><joint/><geom size='0.1'/></body></worldbody><equality>"
     "<connect site1='s' site2='t'/></equality></mujoco>", "between sites is not supported"),
    ("<mujoco><worldbody><body name='b'><joint/><geom size='0.1'/></body></worldbody><equality>"
     "<connect body1='b' body2='b'/></equality></mujoco>", "the same body"),
    ("<mujoco><include file='x.xml'/><worldbody/></mujoco>", "MJCF file not found"),
    ("<mujoco><include/><worldbody/></mujoco>", "an <include> needs a file attribute"),
    ("<mujoco><worldbody/><tendon><spatial name='t'/></tendon></mujoco>", "a <spatial> tendon is not supported"),
    ("<mujoco><worldbody><body name='b'><joint name='j'/><geom size='0.1'/></body></worldbody><tendon>"
     "<fixed name='t' range='0 1' limited='true'><joint joint='j'/></fixed></tendon></mujoco>", "a tendon's range"),
    ("<mujoco><worldbody><body name='b'><joint name='j'/><geom size='0.1'/></body></worldbody><tendon>"
     "<fixed name='t' stiffness='3'><joint joint='j'/></fixed></tendon></mujoco>", "a tendon's stiffness"),
    ("<mujoco><worldbody><body name='b'><joint name='j'/><geom size='0.1'/></body></worldbody><tendon>"
     "<fixed name='t'><joint joint='nope'/></fixed></tendon></mujoco>", "unknown joint 'nope'"),
    ("<mujoco><worldbody><body name='b'><joint name='j'/><joint name='k' axis='1 0 0'/><geom size='0.1'/></body>"
     "</worldbody><tendon><fixed name='t'><joint joint='j'/><joint joint='k'/></fixed></tendon><actuator>"
     "<position tendon='t' kp='5'/></actuator></mujoco>",
     "actuator on a tendon is supported when joint equalities tie the tendon's joints to one of them"),
    ("<robot/>", "expected a <mujoco> element"),
    ("<mujoco><worldbody>", "invalid XML"),
    ("<mujoco/>", "missing <worldbody>"),
    ("<mujoco><worldbody><body><frame pos='1 0 0'><composite type='grid' count='2 2 1'/></frame>"
     "</body></worldbody></mujoco>", "body[body1].frame[0].composite: <composite> is not supported"),
    ("<mujoco><worldbody><replicate count='0'><geom size='0.1'/></replicate></worldbody></mujoco>",
     "worldbody.replicate[0].count: expected a whole number >= 1, got '0'"),
    ("<mujoco><worldbody><replicate count='2' offset='1 0'><geom size='0.1'/></replicate></worldbody></mujoco>",
     "worldbody.replicate[0].offset: expected 3 numbers"),
    ("<mujoco><worldbody><frame name='f' childclass='nope'><body><geom size='0.1'/></body></frame></worldbody>"
     "</mujoco>", "worldbody.frame[f].childclass: unknown default class 'nope'"),
    ("<mujoco><worldbody><frame euler='0 0 1' quat='1 0 0 0'><geom size='0.1'/></frame></worldbody></mujoco>",
     "worldbody.frame[0]: give one orientation"),
    ("<mujoco><worldbody><geom type='hfield' hfield='h'/></worldbody></mujoco>",
     "worldbody.geom[geom0].hfield: unknown height field 'h' (not in <asset>)"),
    ("<mujoco><asset><hfield name='h' nrow='2' ncol='2'/></asset><worldbody/></mujoco>",
     "asset.hfield[h]: missing size (rx ry top base)"),
    ("<mujoco><asset><hfield name='h' nrow='2' ncol='2' size='1 1 0 1'/></asset><worldbody/></mujoco>",
     "asset.hfield[h].size: expected four numbers > 0"),
    ("<mujoco><asset><hfield name='h' nrow='2' ncol='3' size='1 1 1 1' elevation='1 2 3 4'/></asset><worldbody/>"
     "</mujoco>", "asset.hfield[h].elevation: expected 6 numbers"),
    ("<mujoco><asset><hfield name='h' ncol='3' size='1 1 1 1'/></asset><worldbody/></mujoco>",
     "asset.hfield[h]: missing nrow (or a file)"),
    ("<mujoco><asset><hfield name='h' file='nope.png' size='1 1 1 1'/></asset><worldbody/></mujoco>",
     "asset.hfield[h].file: height field file not found"),
    ("<mujoco><asset><hfield name='h' nrow='2' ncol='2' size='1 1 1 1'/></asset><worldbody><body><joint/>"
     "<geom type='hfield' hfield='h'/></body></worldbody></mujoco>",
     "body[body1].geom[0]: a hfield must be a <worldbody> geom (tumble's are static)"),
    ("<mujoco><worldbody><body><joint name='h'/><geom size='0.1'/></body></worldbody>"
     "<actuator><position joint='x'/></actuator></mujoco>", "unknown joint 'x'"),
])
def test_unsupported_or_broken_files_stop_with_one_line(tmp_path, text, problem):
    path = write(tmp_path, text)
    with pytest.raises(tb.InputError) as info:
        tb.load_mjcf(tb.World(), path)
    line = str(info.value)
    assert "\n" not in line and problem in line, line


def test_a_scene_file_loads_an_mjcf_robot_and_refuses_urdf_options(tmp_path):
    from tumble.scene import load_scene

    write(tmp_path, CHAIN, "chain.xml")
    scene = tmp_path / "s.toml"
    scene.write_text('[[robots]]\nfile = "chain.xml"\njoint_positions = { shoulder = 0.3 }\n')
    world = load_scene(scene).world
    assert "chain/upper" in world.names and "chain/lower" in world.names and len(world.joints) == 2
    scene.write_text('[[robots]]\nfile = "chain.xml"\nfixed_base = true\n')
    with pytest.raises(tb.InputError) as info:
        load_scene(scene)
    assert "robots[0].fixed_base" in str(info.value) and "MJCF" in str(info.value)


def test_world_geoms_false_leaves_the_files_floor_off_and_the_scene_key_takes_it(tmp_path):
    """``load_mjcf(world_geoms=False)``: the model without its ``<worldbody>`` geoms (its floor), for a
    scene with its own ground; the bodies, joints and masses as with them. The scene key
    ``world_geoms = false`` does the same; a URDF refuses it with one line."""
    from tumble.scene import load_scene

    path = write(tmp_path, MODEL)
    full_world, bare_world = tb.World(), tb.World()
    full = tb.load_mjcf(full_world, path)
    bare = tb.load_mjcf(bare_world, path, world_geoms=False)
    assert "world/floor" in full.links and "world/floor" not in bare.links
    assert full_world.body_count == bare_world.body_count + 1 and "parts/world/floor" not in bare_world.names
    for name in ("a", "b", "c", "d"):
        assert bare.links[name].mass == full.links[name].mass
    assert bare_world.ray_cast((3, 3, 1), (0, 0, -1)).body[0] == -1  # nothing under it: no floor
    (tmp_path / "s.toml").write_text('[[robots]]\nfile = "model.xml"\nworld_geoms = false\n')
    assert "parts/world/floor" not in load_scene(tmp_path / "s.toml").world.names
    (tmp_path / "arm.urdf").write_text(Path("examples/robots/arm.urdf").read_text())
    (tmp_path / "s.toml").write_text('[[robots]]\nfile = "arm.urdf"\nworld_geoms = false\n')
    with pytest.raises(tb.InputError) as info:
        load_scene(tmp_path / "s.toml")
    assert "robots[0].world_geoms" in str(info.value) and "\n" not in str(info.value)


def test_a_scene_sets_mjcf_controls_and_the_run_follows_them(tmp_path):
    # [[robots]] controls = {...}: MuJoCo's ctrl for the run, clipped as set_controls clips it; the
    # cart's 1.5 N (ctrl 0.5, gear 3) on 1 kg + armature 2 moves it by F t^2 / 2 (m + a) in 1 s
    # (semi-implicit Euler's a h t / 2 = 2.6e-4 m over the substeps; tolerance 5e-4 m).
    from tumble.scene import load_scene

    actuated(tmp_path)
    scene = tmp_path / "s.toml"
    scene.write_text('[simulation]\ngravity = [0, 0, -9.81]\n[[robots]]\nfile = "model.xml"\n'
                     'controls = { m_rail = 0.5, m_shoulder = 5.0 }\n')
    loaded = load_scene(scene)
    sim = tb.Simulator(loaded.world, dt=1 / 240)
    sim.step(240)
    rail = [j for j in loaded.world.joints if j.name == "actuated/rail"][0]
    assert sim.soft_step.joints.readings(rail)["position"] == pytest.approx(0.5 * 1.5 / 3.0, abs=5e-4)
    shoulder = [j for j in loaded.world.joints if j.name == "actuated/shoulder"][0]
    assert shoulder.bound.param[19] == 2.0  # ctrl 5 clipped to 1, times gear 2
    scene.write_text('[[robots]]\nfile = "model.xml"\ncontrols = { nope = 1.0 }\n')
    with pytest.raises(tb.InputError) as info:
        load_scene(scene)
    assert str(info.value) == f"{scene}: robots[0].controls.nope: unknown actuator 'nope' of robot 'actuated'"


PLANAR = """
<mujoco model="planar">
  <compiler angle="radian"/>
  <option timestep="0.00025" integrator="RK4"/>
  <worldbody>
    <body name="cart" pos="0 0 1">
      <joint name="x" type="slide" axis="1 0 0" stiffness="30"/>
      <joint name="z" type="slide" axis="0 0 1" stiffness="50"/>
      <joint name="pitch" type="hinge" axis="0 1 0" pos="0.05 0 0"/>
      <geom type="box" size="0.2 0.1 0.05" mass="2"/>
      <body name="pole" pos="0.3 0 0">
        <joint name="a1" type="hinge" axis="1 0 0"/>
        <joint name="a2" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.1 0.05 -0.6" size="0.03" mass="0.5"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_bodies_with_several_joints_move_as_mujoco_says_with_the_exact_joint_solve(tmp_path):
    # MuJoCo composes the joints of one body with nothing between them: a planar cart (slide x and z
    # on springs, then a hinge off its centre) carrying a pole on two hinges (a universal joint).
    # tumble chains them through virtual links of 1e-3 of the body's mass and inertia, and the
    # Simulator then solves joints exactly by default (world.exact_joints: the soft Gauss-Seidel rows
    # were off by tenths of a radian to several radians here, measured). Against MuJoCo RK4 at dt
    # 1/4000 s over 1 s: measured 0.031 rad at most (the pole's roll, which swings over 3.4 rad) at
    # dt 1/240, the cart's joints within 0.01; tolerance 2x. First order where the motion is smooth
    # (the cart's pitch: 1.0e-2 -> 4.3e-3 rad at dt 1/960).
    path = write(tmp_path, PLANAR)
    q0 = np.array([0.05, -0.02, 0.3, 0.2, -0.4])
    names, ref = mujoco_motion(path, q0)
    errors = []
    for dt in (1 / 240, 1 / 960):
        world = tb.World(gravity=(0, 0, -G))
        robot = tb.load_mjcf(world, path, joint_positions=dict(zip(names, q0)))
        sim = tb.Simulator(world, dt=dt)
        assert world.exact_joints and sim.joint_settings is ACCURATE
        q = []
        for _ in range(20):
            sim.step(int(round(0.05 / dt)))
            s = robot.joint_states(sim)
            q.append([s[n][0] for n in names])
        errors.append(np.abs(np.array(q) - ref).max(axis=0))
    assert np.all(errors[0][:3] < 0.02) and errors[0][3:].max() < 0.065, errors
    assert errors[0][2] / errors[1][2] > 2.0, errors
    # the virtual links touch nothing; the cart and the pole are kept apart as parent and child
    assert "planar/cart/x" in world.names and "planar/pole/a1" in world.names
    assert not world.should_collide(robot.links["cart"], robot.links["pole"])


ACTUATED = """
<mujoco model="actuated">
  <compiler angle="radian"/>
  <option timestep="0.00025" integrator="RK4" gravity="0 0 -9.81"/>
  <default><joint type="hinge" axis="0 1 0" damping="0.1"/><geom type="capsule" size="0.04"/></default>
  <worldbody>
    <body name="upper" pos="0 0 2">
      <joint name="shoulder" armature="ARM0"/>
      <geom fromto="0 0 0 0.1 0 -0.8"/>
      <body name="lower" pos="0.1 0 -0.8">
        <joint name="elbow" armature="ARM1"/>
        <geom fromto="0 0 0 0.05 0 -0.6"/>
      </body>
    </body>
    <body name="cart" pos="3 0 1">
      <joint name="rail" type="slide" axis="1 0 0" armature="ARM2" damping="0"/>
      <geom type="box" size="0.1 0.1 0.1" mass="1"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="m_shoulder" joint="shoulder" gear="2" ctrlrange="-1 1"/>
    <motor name="m_elbow" joint="elbow" forcerange="-0.3 0.3"/>
    <motor name="m_rail" joint="rail" gear="3" ctrllimited="false"/>
  </actuator>
</mujoco>
"""


def actuated(tmp_path, armature=(0.2, 0.05, 2.0)):
    text = ACTUATED
    for k, a in enumerate(armature):
        text = text.replace(f"ARM{k}", repr(a))
    return write(tmp_path, text)


def test_armature_and_motor_actuators_move_as_mujoco_rk4_says(tmp_path):
    # The same file in both engines: joints with armature (MuJoCo adds it to the mass matrix's
    # diagonal) driven by <motor> actuators at ctrl (5, 0.8, 0.5): the shoulder's ctrl is clipped to
    # its ctrlrange (1, times gear 2: 2 N m), the elbow's force to its forcerange (0.3 N m), the
    # rail's gear 3 makes 1.5 N on a 1 kg cart with armature 2 (1.5 / 3 m/s^2). MuJoCo's RK4 at
    # dt 1/4000 s is the reference (~1e-8 here); tumble's step is first order: measured 3.1e-4 rad
    # at dt 1/240 (the tree solve, the default with armature; 7.8e-5 at 1/960), the cart 2.6e-4 m
    # (semi-implicit Euler's a h t / 2 over the substeps h). Tolerances about 3x and 2x. With the
    # file's armatures set to 0 the arm is off by 0.081 rad and the cart by 0.5 m.
    path = actuated(tmp_path)
    controls = {"m_shoulder": 5.0, "m_elbow": 0.8, "m_rail": 0.5}
    names, ref = mujoco_motion(path, controls=controls)
    q, sim, robot = tumble_motion(path, names, controls=controls)
    assert sim.joint_settings is ACCURATE
    assert list(robot.actuators) == ["m_shoulder", "m_elbow", "m_rail"]
    assert np.abs(q[:, :2] - ref[:, :2]).max() < 1e-3
    assert np.abs(q[:, 2] - ref[:, 2]).max() < 5e-4
    assert ref[-1, 2] == pytest.approx(0.5 * 1.5 / 3.0 * 1.0**2, rel=1e-3)  # the reference itself: F t^2 / 2 (m + a)
    q0, _, _ = tumble_motion(actuated_zero(tmp_path), names, controls=controls)
    assert np.abs(q0[:, :2] - ref[:, :2]).max() > 0.05


def actuated_zero(tmp_path):
    sub = tmp_path / "zero"
    sub.mkdir(exist_ok=True)
    return actuated(sub, armature=(0.0, 0.0, 0.0))


@pytest.mark.parametrize("actuator, key, problem", [
    ('<motor joint="h" ctrllimited="true"/>', "actuator.motor[h].ctrlrange", "ctrllimited without a ctrlrange"),
    ('<motor joint="h" ctrlrange="1 -1"/>', "actuator.motor[h].ctrlrange", "wrong way round"),
    ('<motor joint="h" forcelimited="maybe" forcerange="0 1"/>', "actuator.motor[h].forcelimited",
     "expected true, false or auto"),
    ('<motor name="a" joint="h"/><motor name="a" joint="h"/>', "actuator.motor[a]", "duplicate actuator name"),
    ('<motor joint="h" gear="x"/>', "actuator.motor[h].gear", "expected numbers"),
    ('<motor joint="nope"/>', "actuator.motor[nope].joint", "unknown joint 'nope'"),
    ('<general joint="h" dyntype="filter"/>', "actuator.general[h].dyntype", "'filter' is not supported"),
    ('<general joint="h" gaintype="user"/>', "actuator.general[h].gaintype", "'user' is not supported"),
    ('<general joint="h" biastype="affine" biasprm="0 5 0"/>', "actuator.general[h]", "negative stiffness"),
    ('<position joint="h" kp="x"/>', "actuator.position[h].kp", "expected numbers"),
    ('<motor joint="b"/>', "actuator.motor[b].joint", "an actuator on a spherical joint is not supported"),
])
def test_bad_actuators_stop_with_one_line(tmp_path, actuator, key, problem):
    path = write(tmp_path, '<mujoco><worldbody><body><joint name="h"/><geom size="0.1"/></body>'
                           '<body pos="1 0 0"><joint name="b" type="ball"/><geom size="0.1"/></body></worldbody>'
                           f'<actuator>{actuator}</actuator></mujoco>')
    with pytest.raises(tb.InputError) as info:
        tb.load_mjcf(tb.World(), path)
    line = str(info.value)
    assert "\n" not in line and str(path) in line and key in line and problem in line, line


def test_bad_controls_stop_with_one_line(tmp_path):
    world = tb.World()
    robot = tb.load_mjcf(world, actuated(tmp_path))
    sim = tb.Simulator(world, dt=1 / 240)
    for controls, problem in (({"nope": 1.0}, "unknown actuator 'nope'"), ({"m_rail": float("nan")}, "finite"),
                              ({"m_rail": "fast"}, "finite"), ([1.0], "expected a table")):
        with pytest.raises(tb.InputError, match=problem):
            robot.set_controls(sim, controls)
    with pytest.raises(tb.InputError, match="finite"):
        robot.set_joint_torque(sim, "elbow", float("inf"))
    with pytest.raises(tb.InputError, match="unknown joint"):
        robot.set_joint_torque(sim, "knee", 1.0)


SERVOS = """
<mujoco model="servos">
  <compiler angle="radian"/>
  <option timestep="0.00025" integrator="RK4" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="arm" pos="0 0 2">
      <joint name="hinge" type="hinge" axis="0 1 0" armature="0.02"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.03" mass="1"/>
    </body>
    <body name="cart" pos="3 0 1">
      <joint name="rail" type="slide" axis="1 0 0"/>
      <geom type="box" size="0.1 0.1 0.1" mass="2"/>
    </body>
    <body name="wheel" pos="6 0 1">
      <joint name="spin" type="hinge" axis="0 0 1"/>
      <geom type="cylinder" size="0.2 0.05" mass="1"/>
    </body>
  </worldbody>
  <actuator>
    <general name="servo" joint="hinge" gear="2" gainprm="40" biastype="affine" biasprm="1 -40 -4" ctrlrange="-0.5 0.5"/>
    <velocity name="rail_speed" joint="rail" kv="3" gear="1.5"/>
    <general name="push" joint="spin" gainprm="0.5"/>
    <motor name="spin_motor" joint="spin" forcerange="-0.01 0.01"/>
  </actuator>
</mujoco>
"""


def test_general_velocity_and_stacked_actuators_move_as_mujoco_rk4_says(tmp_path):
    # MuJoCo's general form on each joint: a geared servo with an affine bias (gear 2: stiffness
    # 4 x 40, damping 4 x 4, its target 2 (40 ctrl + 1) / 160; ctrl 0.9 clipped to 0.5) holding a
    # 1 kg arm against gravity (both rest at 0.2772 rad); a velocity actuator (kv 3, gear 1.5: the
    # cart's rate goes to ctrl / 1.5 through a damper of 6.75 N s/m, implicit); two actuators on
    # one joint (a general of gain 0.5, biastype none, and a motor clipped to 0.01 N m) adding their
    # torques. Against MuJoCo's RK4 at dt 1/4000 s over 1 s, tumble at dt 1/240 (first order):
    # measured 1.6e-3 rad (the servo's swing up), 1e-4 m, 2.9e-3 rad (the spin: semi-implicit
    # Euler's alpha h t / 2 over the substeps); tolerances about 2x.
    path = write(tmp_path, SERVOS)
    controls = {"servo": 0.9, "rail_speed": 0.4, "push": 0.2, "spin_motor": 1.0}
    names, ref = mujoco_motion(path, controls=controls)
    q, _, _ = tumble_motion(path, names, controls=controls)
    err = np.abs(np.array(q) - ref).max(axis=0)
    assert err[0] < 3e-3 and err[1] < 5e-4 and err[2] < 5e-3, err
    assert q[-1][0] == pytest.approx(0.2772, abs=1e-3) and ref[-1, 0] == pytest.approx(0.2772, abs=1e-3)
    # the reference itself: the cart's rate r = ctrl / gear reached with tau = m / (gear^2 kv)
    r, tau = 0.4 / 1.5, 2.0 / (1.5**2 * 3.0)
    assert ref[-1, 1] == pytest.approx(r * (1.0 - tau * (1.0 - np.exp(-1.0 / tau))), rel=1e-6)


FOURBAR = """
<mujoco model="fourbar">
  <compiler angle="radian"/>
  <option timestep="0.00025" integrator="RK4" gravity="0 0 -9.81"/>
  <default>
    <joint type="hinge" axis="0 1 0" damping="0.05"/>
    <geom type="capsule" size="0.02" density="1000" contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="crank" pos="0 0 1">
      <joint name="j0"/>
      <geom fromto="0 0 0 0.3 0 0"/>
      <body name="coupler" pos="0.3 0 0">
        <joint name="j1"/>
        <geom fromto="0 0 0 0.5 0 0.4"/>
        <body name="rocker" pos="0.5 0 0.4">
          <joint name="j2"/>
          <geom fromto="0 0 0 0.3 0 -0.5"/>
        </body>
      </body>
    </body>
  </worldbody>
  <equality>
    <connect name="close" body1="rocker" body2="world" anchor="0.3 0 -0.5" solref="0.001 1" solimp="0.99 0.999 0.001"/>
  </equality>
</mujoco>
"""


def test_a_four_bar_closed_by_an_equality_connect_swings_as_mujoco_says(tmp_path):
    # A chain of three links whose end MuJoCo's <equality><connect> pins to the world (a four-bar
    # linkage, released at rest; its rocker swings through 3.2 rad in 1 s): a ball joint closing the
    # loop, solved by Gauss-Seidel around the tree solve (the default for a model with equalities).
    # MuJoCo's equality is soft: a stiff one (solref 0.001, 1e-7 m off its anchor) is the reference,
    # RK4 at dt 1/4000 s. Measured: 6.2e-3 rad at dt 1/240, 1.6e-3 at 1/960 (first order); the
    # default soft Gauss-Seidel joints were 0.047 rad off. Tolerance about 1.5x; the loop's gap
    # in tumble under 1e-4 m.
    path = write(tmp_path, FOURBAR)
    names, ref = mujoco_motion(path)
    errors = []
    for dt in (1 / 240, 1 / 960):
        q, sim, robot = tumble_motion(path, names, dt=dt)
        assert sim.joint_settings is ACCURATE and list(robot.equalities) == ["close"]
        errors.append(np.abs(np.array(q) - ref).max())
        origin, R = robot.link_pose("rocker")
        assert np.linalg.norm(origin + R @ np.array([0.3, 0.0, -0.5]) - robot.link_pose("world")[0]
                              - np.array([1.1, 0.0, 0.9])) < 1e-4
    assert errors[0] < 1e-2 and errors[0] / errors[1] > 3.0, errors
    assert np.abs(ref[:, 2]).max() > 3.0  # it swings: the loop is exercised


def test_a_weld_equality_keeps_two_bodies_together_and_joint_positions_come_after_it(tmp_path):
    # <weld body1 body2>: a free body b welded to the tip of arm a (a hinge about y): b
    # goes round with a, their relative pose kept (to 1e-4 m and rad, the loop's Gauss-Seidel
    # gap); joint_positions are applied after the weld took the model's pose (MuJoCo's qpos0).
    path = write(tmp_path, """
<mujoco model="welded">
  <compiler angle="radian"/>
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="ha" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.03"/>
    </body>
    <body name="b" pos="0.5 0 1">
      <freejoint/>
      <geom type="box" size="0.05 0.05 0.05"/>
    </body>
  </worldbody>
  <equality><weld body1="b" body2="a"/></equality>
</mujoco>""")
    world = tb.World(gravity=(0, 0, -G))
    robot = tb.load_mjcf(world, path)
    a, b = robot.links["a"], robot.links["b"]
    rel0 = (a.R.T @ (b.x - a.x), a.R.T @ b.R)
    sim = tb.Simulator(world, dt=1 / 240)
    sim.step(240)
    assert robot.joint_states(sim)["ha"][0] > 0.5  # it swung down
    np.testing.assert_allclose(a.R.T @ (b.x - a.x), rel0[0], atol=1e-4)
    np.testing.assert_allclose(a.R.T @ b.R, rel0[1], atol=1e-4)
    world = tb.World(gravity=(0, 0, -G))
    robot = tb.load_mjcf(world, path, joint_positions={"ha": 0.3})
    a, b = robot.links["a"], robot.links["b"]
    # as MuJoCo's qpos: a turned by 0.3 rad, the free b left at its own (the model's) pose, so the
    # weld starts stretched; it pulls the two back to their model-pose relation
    np.testing.assert_allclose(b.x, (0.5, 0.0, 1.0), atol=1e-12)
    assert np.linalg.norm(a.R.T @ (b.x - a.x) - rel0[0]) > 0.1
    sim = tb.Simulator(world, dt=1 / 240)
    sim.step(240)
    np.testing.assert_allclose(a.R.T @ (b.x - a.x), rel0[0], atol=1e-3)


def test_the_cli_runs_and_validates_an_mjcf_file_as_a_scene(tmp_path, capsys):
    # ``tumble run model.xml`` (as MuJoCo's simulate opens a model): one [[robots]] entry, the file's
    # <option gravity>; its outputs as a scene's, the model copied as scene.xml. A bad model is one
    # line naming the file and the element, status 2.
    from tumble.cli import main

    path = write(tmp_path, SERVOS.replace('gravity="0 0 -9.81"', 'gravity="0 0 -3"'), "servos.xml")
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--duration", "0.5", "--no-progress"]) == 0
    traj = tb.load_trajectory(out / "trajectory.npz")
    assert "servos/cart" in list(traj.names) and (out / "scene.xml").read_bytes() == path.read_bytes()
    assert tb.load_scene(path).world.gravity.tolist() == [0.0, 0.0, -3.0]
    assert main(["validate", str(path)]) == 0
    bad = write(tmp_path, '<mujoco><worldbody><body><joint range="2 1"/><geom size="0.1"/></body></worldbody></mujoco>',
                "bad.xml")
    capsys.readouterr()
    assert main(["run", str(bad), "--out", str(tmp_path / "out2")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"tumble: error: {bad}: joint[body1_joint].range: the range is the wrong way round: 2 > 1", err


def test_contype_and_conaffinity_keep_apart_the_bodies_mujoco_keeps_apart(tmp_path):
    # MuJoCo's rule, geom by geom: (contype1 & conaffinity2) or (contype2 & conaffinity1). Gym's
    # models give their limbs contype 1, conaffinity 0: limbs never touch each other but touch the
    # floor (1, 1). Here a box (1, 0) falls onto another (1, 0) standing on the floor and passes
    # through it to the floor, as in MuJoCo; a third box (2, 0) lands on a fourth (1, 2), which
    # carries it (2 & 2) while the floor does not (2 & 1 = 0, 1 & 0 = 0). Checked against MuJoCo
    # stepping the same file for 1 s: the same resting heights to 2 mm (soft contacts).
    path = write(tmp_path, """
<mujoco model="masks">
  <worldbody>
    <geom name="floor" type="plane" size="3 3 0.1"/>
    <body name="low" pos="0 0 0.1"><freejoint/><geom type="box" size="0.1 0.1 0.1" contype="1" conaffinity="0"/></body>
    <body name="high" pos="0 0 0.5"><freejoint/><geom type="box" size="0.1 0.1 0.1" contype="1" conaffinity="0"/></body>
    <body name="base" pos="1 0 0.1"><freejoint/><geom type="box" size="0.1 0.1 0.1" contype="1" conaffinity="2"/></body>
    <body name="top" pos="1 0 0.5"><freejoint/><geom type="box" size="0.1 0.1 0.1" contype="2" conaffinity="0"/></body>
  </worldbody>
</mujoco>""")
    world = tb.World(gravity=(0, 0, -G))
    robot = tb.load_mjcf(world, path)
    links = robot.links
    assert not world.should_collide(links["low"], links["high"])
    assert world.should_collide(links["base"], links["top"])
    assert world.should_collide(links["world/floor"], links["high"]) and world.should_collide(links["world/floor"], links["low"])
    assert world.should_collide(links["world/floor"], links["base"])
    assert not world.should_collide(links["world/floor"], links["top"])
    sim = tb.Simulator(world, dt=1 / 240)
    sim.step(240)
    z = {n: float(links[n].x[2]) for n in ("low", "high", "base", "top")}
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_step(m, d, nstep=int(round(1.0 / m.opt.timestep)))
    zm = {n: float(d.xpos[m.body(n).id][2]) for n in ("low", "high", "base", "top")}
    # low and high both rest on the floor (0.1 m), one inside the other; base and top fall together
    for n in ("low", "high"):
        assert z[n] == pytest.approx(0.1, abs=2e-3) and zm[n] == pytest.approx(0.1, abs=2e-3)
    for n, h in (("base", 0.1), ("top", 0.3)):
        assert z[n] == pytest.approx(h, abs=2e-3) and zm[n] == pytest.approx(h, abs=2e-3)


ROBOT_PART = """
<mujoco model="arm">
  <compiler angle="radian"/>
  <default><joint damping="0.1"/><geom density="700"/></default>
  <worldbody>
    <body name="upper" pos="0 0 1" euler="0.2 0 0.1">
      <joint name="shoulder" axis="0 1 0" pos="0 0 0.05"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 -0.2" size="0.04"/>
      <include file="parts/hand.xml"/>
    </body>
  </worldbody>
  <actuator><motor name="m" joint="shoulder" gear="2"/></actuator>
</mujoco>
"""

HAND_PART = """
<mujoco>
  <body name="hand" pos="0.3 0 -0.2">
    <joint name="wrist" type="slide" axis="1 0 0.3"/>
    <geom type="box" size="0.05 0.03 0.02" density="2000"/>
  </body>
</mujoco>
"""

SCENE = """
<mujoco model="scene">
  <include file="arm.xml"/>
  <option gravity="0 0 -9.8"/>
  <compiler angle="radian"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="ball" pos="1 0 0.5"><freejoint name="ball_free"/><geom type="sphere" size="0.1"/></body>
  </worldbody>
</mujoco>
"""


def test_include_is_expanded_as_mujoco_does(tmp_path):
    """MuJoCo Menagerie's layout: a scene file that includes the robot's file, which includes a part
    from a subfolder (paths from the main file's folder) inside a body, with a second worldbody and
    compiler after the expansion: the same bodies, joints, actuators and, at random joint positions,
    the same mass matrix and Jacobians as MuJoCo's compiled model of the same files (1e-12)."""
    (tmp_path / "parts").mkdir()
    (tmp_path / "arm.xml").write_text(ROBOT_PART)
    (tmp_path / "parts" / "hand.xml").write_text(HAND_PART)
    scene = tmp_path / "scene.xml"
    scene.write_text(SCENE)
    world = tb.World(gravity=(0, 0, -9.8))
    robot = tb.load_mjcf(world, scene)
    m = mujoco.MjModel.from_xml_path(str(scene))
    d = mujoco.MjData(m)
    kin = robot.kinematics
    assert [c.name for c in kin.coordinates] == [m.joint(i).name for i in range(m.njnt)]
    assert list(robot.actuators) == ["m"] and "world/floor" in robot.links
    rng = np.random.default_rng(9)
    for _ in range(2):
        q = d.qpos.copy()
        q[0:2] = rng.uniform(-0.5, 0.5, 2)  # shoulder, wrist (the included arm comes first, as in the file)
        quat = rng.normal(size=4)
        q[2:9] = np.concatenate([rng.uniform(-1, 1, 3), quat / np.linalg.norm(quat)])  # the ball's free joint
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        np.testing.assert_allclose(kin.mass_matrix(q), M, atol=1e-12)
        jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        b = m.body("hand").id
        mujoco.mj_jac(m, d, jacp, jacr, d.xipos[b], b)
        o, R = kin.forward_kinematics(q)["hand"]
        np.testing.assert_allclose(kin.jacobian("hand", R.T @ (d.xipos[b] - o), q), np.vstack([jacp, jacr]), atol=1e-12)
    np.testing.assert_allclose(tb.mjcf.read_option_gravity(scene), (0, 0, -9.8))


def test_a_file_included_twice_is_one_line(tmp_path):
    (tmp_path / "part.xml").write_text("<mujoco><worldbody/></mujoco>")
    path = tmp_path / "twice.xml"
    path.write_text("<mujoco><include file='part.xml'/><include file='part.xml'/><worldbody/></mujoco>")
    with pytest.raises(tb.InputError) as err:
        tb.load_mjcf(tb.World(), path)
    assert "included twice" in str(err.value) and "include[part.xml]" in str(err.value) and "\n" not in str(err.value)


KEYED = """
<mujoco model="keyed">
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
      <body name="fore" pos="0.3 0 0">
        <joint name="slide" type="slide" axis="1 0 0"/>
        <geom type="box" size="0.05 0.02 0.02"/>
        <body name="hand" pos="0.1 0 0">
          <joint name="wrist" type="ball"/>
          <geom type="sphere" size="0.03" pos="0.05 0 0"/>
          <site name="tip" pos="0.08 0.01 0"/>
        </body>
      </body>
    </body>
    <body name="puck" pos="1 1 0.2"><freejoint name="puck_free"/><geom type="cylinder" size="0.1 0.02"/>
      <site name="rim" pos="0.1 0 0"/></body>
  </worldbody>
  <actuator>
    <motor name="drive" joint="hinge"/>
    <damper name="left_off" joint="slide" kv="1" ctrlrange="0 1"/>
    <position name="servo" joint="slide" kp="50"/>
  </actuator>
  <keyframe>
    <key name="pose" qpos="0.7 0.05 0.9 0.1 0.3 -0.2 0.4 -0.3 0.25 0.6 0.2 0.3 0.4" qvel="0.5 -0.1 0.2 0.3 -0.4 1 2 3 0.4 0.5 0.6" ctrl="0.3 0 0.02"/>
    <key name="still" qpos="-0.4 0 1 0 0 0 1 1 0.2 1 0 0 0"/>
  </keyframe>
</mujoco>
"""


def test_keyframes_put_the_model_where_mujoco_does(tmp_path):
    """A key's qpos, qvel and ctrl (a left-off actuator counted in ctrl's order): the sites' frames,
    the joint rates and the actuators' controls equal MuJoCo's after mj_resetDataKeyframe (1e-12);
    the model placed elsewhere takes its free body there too; a key of the wrong size is one line."""
    path = tmp_path / "keyed.xml"
    path.write_text(KEYED)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("pose").id)
    mujoco.mj_forward(m, d)
    world = tb.World()
    robot = tb.load_mjcf(world, path, keyframe="pose")
    for site in ("tip", "rim"):
        o, R = robot.site_pose(site)
        np.testing.assert_allclose(o, d.site(site).xpos, atol=1e-12)
        np.testing.assert_allclose(R, d.site(site).xmat.reshape(3, 3), atol=1e-12)
    np.testing.assert_allclose(robot.kinematics.qvel(), d.qvel, atol=1e-12)
    assert robot.actuators["drive"].ctrl == pytest.approx(0.3) and robot.actuators["servo"].ctrl == pytest.approx(0.02)
    # placed elsewhere: the whole model, the free puck included, turned and moved with it
    moved = tb.World()
    other = tb.load_mjcf(moved, path, position=(1.0, 2.0, 0.5), euler_deg=(0, 0, 90), keyframe="pose")
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    for site in ("tip", "rim"):
        np.testing.assert_allclose(other.site_pose(site)[0], (1.0, 2.0, 0.5) + turn @ d.site(site).xpos, atol=1e-12)
    robot.reset_to_keyframe("still")
    mujoco.mj_resetDataKeyframe(m, d, m.key("still").id)
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(robot.site_pose("tip")[0], d.site("tip").xpos, atol=1e-12)
    np.testing.assert_allclose(robot.kinematics.qvel(), 0.0, atol=1e-12)
    with pytest.raises(tb.InputError, match="unknown keyframe"):
        robot.reset_to_keyframe("nope")
    bad = tmp_path / "bad_key.xml"
    bad.write_text(KEYED.replace('qpos="-0.4 0 1 0 0 0 1 1 0.2 1 0 0 0"', 'qpos="-0.4 0 1"'))
    with pytest.raises(tb.InputError) as err:
        tb.load_mjcf(tb.World(), bad)
    assert "keyframe.key[still].qpos" in str(err.value) and "expected 13 numbers" in str(err.value)


SENSED = """
<mujoco model="sensed">
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <geom name="wall" type="box" size="0.1 2 1" pos="2 0 1"/>
    <body name="arm" pos="0 0 1" euler="0 0 20">
      <joint name="hinge" axis="0 1 0" pos="0 0 0.05"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
      <site name="eye" pos="0.3 0 0.02" zaxis="1 0.1 -0.2"/>
      <body name="fore" pos="0.3 0 0">
        <joint name="slide" type="slide" axis="1 0 0"/>
        <geom type="box" size="0.05 0.02 0.02"/>
        <site name="imu" pos="0.02 0.01 0" euler="10 20 30"/>
      </body>
    </body>
    <body name="puck" pos="0.5 0.5 0.3"><freejoint name="puck_free"/><geom type="cylinder" size="0.1 0.02"/></body>
  </worldbody>
  <sensor>
    <jointpos name="q_hinge" joint="hinge"/>
    <jointvel name="v_slide" joint="slide"/>
    <framepos name="p_imu" objtype="site" objname="imu"/>
    <framequat name="q_imu" objtype="site" objname="imu"/>
    <framezaxis name="z_fore" objtype="xbody" objname="fore"/>
    <framepos name="p_arm" objtype="xbody" objname="arm"/>
    <framelinvel name="v_imu" objtype="site" objname="imu"/>
    <frameangvel name="w_puck" objtype="xbody" objname="puck"/>
    <velocimeter name="velocimeter" site="imu"/>
    <gyro name="gyro" site="imu"/>
    <rangefinder name="range" site="eye"/>
    <subtreecom name="com_arm" body="arm"/>
    <accelerometer name="acc" site="imu"/>
    <framepos name="p_rel" objtype="site" objname="imu" reftype="xbody" refname="arm"/>
  </sensor>
</mujoco>
"""


def test_sensors_read_what_mujoco_reads(tmp_path):
    """At a random state (joint positions, rates, the free puck's pose and twist, set through
    ``Kinematics.set_state``), every sensor tumble reads equals MuJoCo's sensordata after mj_forward
    on the same file (1e-12): joint, frame (site and body frames), velocimeter, gyro, the
    rangefinder's ray to the wall and the subtree's centre of mass; the accelerometer and the
    relative frame sensor are left off and named."""
    path = tmp_path / "sensed.xml"
    path.write_text(SENSED)
    world = tb.World()
    robot = tb.load_mjcf(world, path)
    assert robot.sensors_left_off == ["acc", "p_rel"]
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    kin = robot.kinematics
    rng = np.random.default_rng(10)
    for _ in range(3):
        q = np.zeros(kin.nq)
        q[0:2] = rng.uniform(-0.4, 0.4, 2)
        quat = rng.normal(size=4)
        q[2:9] = np.concatenate([rng.uniform(-1, 1, 3) + (0, 0, 2), quat / np.linalg.norm(quat)])
        qd = rng.normal(size=kin.nv)
        kin.set_state(q, qd)
        d.qpos[:], d.qvel[:] = q, qd
        mujoco.mj_forward(m, d)
        values = robot.sensor_data()
        assert set(values) == set(robot.sensors)
        for name, got in values.items():
            expected = d.sensor(name).data
            if name == "q_imu" and got @ expected < 0:
                got = -got
            np.testing.assert_allclose(got, expected, atol=1e-12, err_msg=name)
    assert values["range"][0] > 0  # the eye sees the wall or the floor


def test_touch_sensor_weighs_what_rests_on_it(tmp_path):
    """A touch site over the whole underside of a 2 kg box resting on the floor reads its weight,
    m g, the mean over a step (1 %: the soft contact's settling), before and after it falls asleep
    (at about 0.4 s: a sleeping body keeps its last reading)."""
    path = tmp_path / "touch.xml"
    path.write_text("""<mujoco><worldbody><geom type="plane" size="5 5 0.1"/>
      <body name="box" pos="0 0 0.1"><freejoint/><geom type="box" size="0.1 0.1 0.1" mass="2"/>
        <site name="sole" type="box" size="0.11 0.11 0.02" pos="0 0 -0.1"/></body></worldbody>
      <sensor><touch name="weight" site="sole"/></sensor></mujoco>""")
    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_mjcf(world, path)
    sim = tb.Simulator(world, dt=1 / 240)
    sim.step(60)
    assert robot.sensor_data(sim)["weight"][0] == pytest.approx(2 * 9.81, rel=0.01)
    sim.step(180)
    assert not sim.sleep.awake[robot.links["box"].index]
    assert robot.sensor_data(sim)["weight"][0] == pytest.approx(2 * 9.81, rel=0.01)


HANGING = """
<mujoco model="hanging">
  <worldbody>
    <body name="upper" pos="0 0 2">
      <joint name="shoulder" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.03" mass="1.5"/>
      <body name="lower" pos="0 0 -0.5">
        <joint name="elbow" axis="1 0 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.03" mass="1"/>
        <site name="wrist_ft" pos="0.02 0.03 -0.1" euler="10 20 30"/>
        <body name="weight" pos="0 0 -0.4"><geom type="sphere" size="0.05" mass="2"/></body>
      </body>
    </body>
    <body name="free" pos="1 0 1"><freejoint/><geom type="sphere" size="0.1"/><site name="loose"/></body>
  </worldbody>
  <sensor>
    <force name="f" site="wrist_ft"/>
    <torque name="t" site="wrist_ft"/>
    <force name="f_free" site="loose"/>
  </sensor>
</mujoco>
"""


def test_force_torque_sensor_reads_what_the_joint_carries(tmp_path):
    """A chain hanging at rest (the exact tree solve): the force and torque sensor at the elbow's
    body (off its axis, turned) read MuJoCo's static values (the weight below the joint and its
    moment about the site, in the site frame, MuJoCo's sign) to 1e-9 relative; a sensor on a free
    body (no joint) is left off."""
    path = tmp_path / "hanging.xml"
    path.write_text(HANGING)
    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_mjcf(world, path)
    assert robot.sensors_left_off == ["f_free"]
    sim = tb.Simulator(world, dt=1 / 240, joint_settings=ACCURATE)
    sim.step(5)
    got = robot.sensor_data(sim)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    for name in ("f", "t"):
        np.testing.assert_allclose(got[name], d.sensor(name).data, rtol=1e-9, atol=1e-9, err_msg=name)
    assert np.linalg.norm(got["f"]) == pytest.approx(3.0 * 9.81, rel=1e-9)  # the lower arm and the weight


def test_a_scene_starts_an_mjcf_robot_in_a_keyframe(tmp_path):
    """[[robots]] keyframe = "pose": the model starts as load_mjcf(keyframe=) puts it (the sites'
    frames equal); an unknown key and a keyframe for a URDF are one line each."""
    from tumble.scene import load_scene

    (tmp_path / "keyed.xml").write_text(KEYED)
    scene = tmp_path / "s.toml"
    scene.write_text('[[robots]]\nfile = "keyed.xml"\nkeyframe = "pose"\n')
    world = load_scene(scene).world
    direct = tb.load_mjcf(tb.World(), tmp_path / "keyed.xml", keyframe="pose")
    i = world.names.index("keyed/hand")
    np.testing.assert_allclose(world.x[i], direct.world.x[direct.links["hand"].index], atol=1e-15)
    scene.write_text('[[robots]]\nfile = "keyed.xml"\nkeyframe = "nope"\n')
    with pytest.raises(tb.InputError) as info:
        load_scene(scene)
    assert "unknown keyframe 'nope'" in str(info.value) and "\n" not in str(info.value)
    (tmp_path / "arm.urdf").write_text(Path("examples/robots/arm.urdf").read_text())
    scene.write_text('[[robots]]\nfile = "arm.urdf"\nkeyframe = "home"\n')
    with pytest.raises(tb.InputError) as info:
        load_scene(scene)
    assert "robots[0].keyframe" in str(info.value) and "URDF has no keyframes" in str(info.value)


TENDON = """
<mujoco model="tendon">
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="hip" axis="0 1 0" armature="0.1"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03"/>
      <body name="b" pos="0.4 0 0">
        <joint name="knee" axis="0 1 0" armature="0.1"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
      </body>
    </body>
  </worldbody>
  <tendon>
    <fixed name="hipknee"><joint joint="hip" coef="-1"/><joint joint="knee" coef="2"/></fixed>
    <fixed name="idle"><joint joint="knee" coef="1"/></fixed>
  </tendon>
  <actuator>
    <motor name="pull" tendon="hipknee" gear="1.5" ctrlrange="-1 1"/>
    <motor name="hip_motor" joint="hip" gear="2"/>
  </actuator>
</mujoco>
"""


def test_fixed_tendon_motors_drive_their_joints_as_mujoco_does(tmp_path):
    """A motor on a fixed tendon applies coef gear ctrl to each of the tendon's joints (MuJoCo's
    qfrc_actuator, to 1e-12, with a joint motor on one of them too); the arm moves as MuJoCo's RK4
    says in zero gravity over 0.5 s (both integrate the same equations: 2e-3 rad, the first-order
    step at dt 1/960); a tendon with nothing on it does nothing."""
    path = tmp_path / "tendon.xml"
    path.write_text(TENDON)
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.gravity[:] = 0.0
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    m.opt.timestep = 1 / 4000
    d = mujoco.MjData(m)
    d.ctrl[:] = (0.7, -0.4)
    mujoco.mj_forward(m, d)
    world = tb.World(gravity=(0, 0, 0))
    robot = tb.load_mjcf(world, path)
    robot.set_controls(None, {"pull": 0.7, "hip_motor": -0.4})
    from tumble.joints import P_EFFORT

    efforts = [robot.joints[j].bound.param[P_EFFORT] for j in ("hip", "knee")]
    np.testing.assert_allclose(efforts, d.qfrc_actuator, atol=1e-12)
    sim = tb.Simulator(world, dt=1 / 960, joint_settings=ACCURATE)
    sim.step(480)
    while d.time < 0.5 - 1e-9:
        mujoco.mj_step(m, d)
    got = [robot.joint_states(sim)[j][0] for j in ("hip", "knee")]
    np.testing.assert_allclose(got, d.qpos, atol=2e-3)
    assert np.abs(d.qpos).max() > 0.3  # it moved


def test_pybullet_data_thrower_runs_once_its_fingertips_touch():
    """PyBullet's thrower.xml: arm links of 1e-9 kg moved by their joints' armature (0.75) alone.
    Its fingertips touch within the first steps; while a contact's change of a coordinate's rate
    became the armature's own (before joint_solve.flywheel_rates_kernel), that blew it up within
    0.2 s (a SimulationError: non-finite momentum, measured). Now it runs 2 s at dt 0.01 and its arm
    turns at under 1 rad/s (measured: holds still; MuJoCo's arm creeps at under 0.13 rad/s)."""
    pytest.importorskip("pybullet")
    import os

    import pybullet_data

    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_mjcf(world, os.path.join(pybullet_data.getDataPath(), "mjcf", "thrower.xml"))
    sim = tb.Simulator(world, dt=0.01)
    arm = 0.0
    for _ in range(200):
        sim.step(1)
        arm = max(arm, np.abs(robot.kinematics.qvel()[:7]).max())
    assert np.isfinite(world.pack()).all()
    assert arm < 1.0


def test_pybullet_data_humanoids_with_tendons_load():
    """PyBullet's copies of Gym's humanoids carry two fixed tendons each that nothing drives or
    limits (MuJoCo: no effect): the files tumble refused for them now load and run, or are refused
    for what MuJoCo refuses them for (ground.xml's tendons name joints it does not have;
    humanoid_fixed.xml has a joint of type "fixed")."""
    pytest.importorskip("pybullet")
    import os

    import pybullet_data

    folder = os.path.join(pybullet_data.getDataPath(), "mjcf")
    for name in ("humanoid_symmetric.xml", "humanoid_symmetric_no_ground.xml"):
        world = tb.World(gravity=(0, 0, -9.81))
        robot = tb.load_mjcf(world, os.path.join(folder, name))
        m = mujoco.MjModel.from_xml_path(os.path.join(folder, "humanoid_symmetric_no_ground.xml"))  # MuJoCo loads this one
        assert robot.kinematics.nv == m.nv and [c.name for c in robot.kinematics.coordinates][:3] == [
            m.joint(i).name for i in range(3)]
        tb.Simulator(world, dt=1 / 240).step(24)
        assert np.isfinite(world.pack()).all()
    for name, problem in (("ground.xml", "unknown joint 'left_hip_y'"), ("humanoid_fixed.xml", "unknown joint type 'fixed'")):
        with pytest.raises(tb.InputError, match=problem):
            tb.load_mjcf(tb.World(), os.path.join(folder, name))


# two slide fingers on a hand, mirrored (Franka's gripper in MuJoCo Menagerie), for the tendon models below
FINGERS = """      <body name="left" pos="0 0.02 -0.05">
        <joint name="finger1" type="slide" axis="0 1 0"/>
        <geom type="box" size="0.01 0.005 0.02" mass="0.1" contype="0" conaffinity="0"/>
      </body>
      <body name="right" pos="0 -0.02 -0.05">
        <joint name="finger2" type="slide" axis="0 -1 0"/>
        <geom type="box" size="0.01 0.005 0.02" mass="0.1" contype="0" conaffinity="0"/>
      </body>
"""


GRIPPER = """
<mujoco model="gripper">
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="hand" pos="0 0 1">
      <geom type="box" size="0.03 0.08 0.02" mass="1" contype="0" conaffinity="0"/>
      <body name="left" pos="0 0.02 -0.05">
        <joint name="finger1" type="slide" axis="0 1 0" range="0 0.04"/>
        <geom type="box" size="0.01 0.005 0.02" mass="0.1" contype="0" conaffinity="0"/>
      </body>
      <body name="right" pos="0 -0.02 -0.05">
        <joint name="finger2" type="slide" axis="0 -1 0" range="0 0.04"/>
        <geom type="box" size="0.01 0.005 0.02" mass="0.1" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
  <tendon>
    <fixed name="split"><joint joint="finger1" coef="0.5"/><joint joint="finger2" coef="0.5"/></fixed>
  </tendon>
  <equality><joint joint1="finger1" joint2="finger2" polycoef="{polycoef}"/></equality>
  <actuator>
    <general name="grip" tendon="split" ctrlrange="0 255" gainprm="0.01568627451 0 0" biasprm="0 -100 -10"
             biastype="affine"/>
  </actuator>
</mujoco>
"""


@pytest.mark.parametrize("a0, a1", [(0.0, 1.0), (0.002, 2.0)])
def test_a_servo_on_a_tendon_whose_joints_are_tied_moves_as_mujoco_does(tmp_path, a0, a1):
    """Franka's gripper in MuJoCo Menagerie: a general actuator with an affine bias (a position servo,
    kp 100, kv 10) on the tendon "split" = 0.5 finger1 + 0.5 finger2, the fingers mirrored by a joint
    equality. Its length L is the fingers' opening q; f = g ctrl - 100 L - 10 L' on the coordinate,
    so q settles at g ctrl / 100 (closed form: 0.0157 m for ctrl 100, to 1e-6 m at 2 s), and moves
    as MuJoCo's RK4 says on the same file (an overdamped 22 rad/s servo on 0.2 kg: 2e-4 m over
    0.5 s, the first-order step at dt 1/960 s; MuJoCo's equality is soft, tumble's gear rigid: the
    fingers on their relation to 1e-9 m here). A skewed equality, finger1 = a0 + a1 finger2, makes
    L = L0 + C finger2 with L0 = 0.5 a0, C = 0.5 (1 + a1): finger2 settles at (g ctrl / 100 - L0) / C
    (0.0147 m without C, 0.0105 m without L0, against 0.0098 m; checked to fail without L0). Before, the actuator stopped the
    model with one line."""
    path = tmp_path / "gripper.xml"
    # both engines start on the relation (a keyframe): MuJoCo's soft equality and tumble's rigid gear
    # close a gap at the start differently
    path.write_text(GRIPPER.format(polycoef=f"{a0} {a1} 0 0 0").replace(
        "<worldbody>", f'<keyframe><key name="open" qpos="{a0} 0"/></keyframe><worldbody>'))
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    m.opt.timestep = 1 / 4000
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    d.ctrl[:] = 100.0
    world = tb.World(gravity=(0, 0, 0))
    robot = tb.load_mjcf(world, path, keyframe="open")
    sim = tb.Simulator(world, dt=1 / 960, joint_settings=ACCURATE)
    robot.set_controls(sim, {"grip": 100.0})
    for t in (0.1, 0.25, 0.5):
        sim.step(int(round(t * 960)) - sim.step_index)
        while d.time < t - 1e-9:
            mujoco.mj_step(m, d)
        got = [robot.joint_states(sim)[j][0] for j in ("finger1", "finger2")]
        np.testing.assert_allclose(got, d.qpos, atol=2e-4)
        assert abs(got[0] - (a0 + a1 * got[1])) < 1e-9
    world.sleeping = False  # (asleep, the fingers stop within 4e-6 m of the target, below the sleep speed)
    sim.step(2 * 960 - sim.step_index)
    q2 = (0.01568627451 * 100 / 100 - 0.5 * a0) / (0.5 * (1 + a1))
    assert robot.joint_states(sim)["finger2"][0] == pytest.approx(q2, abs=1e-6)
    assert robot.joint_states(sim)["finger1"][0] == pytest.approx(a0 + a1 * q2, abs=1e-6)


TENDON_ACTUATED = """
<mujoco model="actuated">
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="hand" pos="0 0 1">
      <geom type="box" size="0.03 0.08 0.02" mass="1" contype="0" conaffinity="0"/>
      <body name="a" pos="0 0 -0.1">
        <joint name="hip" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03" contype="0" conaffinity="0"/>
      </body>
""" + FINGERS + """    </body>
  </worldbody>
  <tendon>
    <fixed name="split"><joint joint="finger1" coef="0.5"/><joint joint="finger2" coef="0.5"/></fixed>
    <fixed name="mix"><joint joint="hip" coef="-1"/><joint joint="finger1" coef="2"/></fixed>
  </tendon>
  <equality><joint joint1="finger1" joint2="finger2" polycoef="0.001 2 0 0 0"/></equality>
  <actuator>
    <general name="grip" tendon="split" ctrlrange="0 255" gainprm="0.0157" biasprm="0.3 -100 -10" biastype="affine"
             gear="1.5"/>
    <position name="servo" joint="hip" kp="20" kv="2" forcerange="-3 3" gear="2"/>
    <motor name="pull" tendon="mix" gear="1.5" ctrlrange="-1 1"/>
  </actuator>
  <sensor>
    <actuatorfrc name="f_grip" actuator="grip"/><actuatorfrc name="f_servo" actuator="servo"/>
    <actuatorfrc name="f_pull" actuator="pull"/><actuatorpos name="l_grip" actuator="grip"/>
    <actuatorvel name="v_servo" actuator="servo"/><actuatorpos name="l_pull" actuator="pull"/>
    <jointactuatorfrc name="qf_hip" joint="hip"/><jointactuatorfrc name="qf_f1" joint="finger1"/>
    <jointactuatorfrc name="qf_f2" joint="finger2"/>
    <tendonpos name="L_split" tendon="split"/><tendonvel name="Ld_mix" tendon="mix"/>
  </sensor>
</mujoco>
"""


def test_actuator_and_tendon_sensors_read_what_mujoco_reads(tmp_path):
    """MuJoCo's actuator and tendon sensors at random states and controls (``Kinematics.set_state``,
    ``set_controls``; MuJoCo after mj_forward on the same file), to 1e-12: actuator lengths, rates
    and forces (a servo on a tendon, one on a joint with its force clipped by its forcerange, a
    motor on a tendon), each joint's actuator force (qfrc_actuator: the tendon servo's force on
    both fingers by its moment arms, though tumble drives their leader), and tendon lengths and
    rates. The states leave the fingers off their equality: the sensors read MuJoCo's definitions
    from the joints, not tumble's reduction."""
    path = tmp_path / "actuated.xml"
    path.write_text(TENDON_ACTUATED)
    world = tb.World(gravity=(0, 0, 0))
    robot = tb.load_mjcf(world, path)
    assert robot.sensors_left_off == [] and robot.actuators["grip"].given is not None
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    kin = robot.kinematics
    rng = np.random.default_rng(3)
    for _ in range(4):
        q, qd = rng.uniform(-0.3, 0.3, kin.nq), rng.normal(size=kin.nv)
        ctrl = {"grip": rng.uniform(0, 255), "servo": rng.uniform(-1, 1), "pull": rng.uniform(-1.5, 1.5)}
        kin.set_state(q, qd)
        robot.set_controls(None, ctrl)
        d.qpos[:], d.qvel[:] = q, qd
        d.ctrl[:] = [ctrl[n] for n in ("grip", "servo", "pull")]
        mujoco.mj_forward(m, d)
        values = robot.sensor_data()
        assert set(values) == set(robot.sensors)
        for name, got in values.items():
            np.testing.assert_allclose(got, d.sensor(name).data, atol=1e-12, err_msg=name)
    assert abs(values["f_servo"][0]) <= 3.0


def test_a_sensor_of_an_actuator_left_off_is_left_off_too(tmp_path):
    """An actuator on a site (a transmission tumble leaves off) is not read, nor is a sensor of it:
    the model loads and the sensor is named in ``sensors_left_off``, where it once was refused as
    an unknown actuator."""
    path = write(tmp_path, "<mujoco><worldbody><body name='b'><joint name='j'/><geom size='0.1'/><site name='s'/>"
                           "</body></worldbody><actuator><motor name='m' site='s' gear='1 0 0 0 0 0'/></actuator>"
                           "<sensor><actuatorfrc name='f' actuator='m'/></sensor></mujoco>")
    robot = tb.load_mjcf(tb.World(), path)
    assert "m" not in robot.actuators and robot.sensors_left_off == ["f"]


DAMPRATIO = """
<mujoco model="dampratio">
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="j1" axis="0 1 0" armature="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.05" mass="1" contype="0" conaffinity="0"/>
      <body name="b" pos="0.5 0 0">
        <joint name="j2" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.05" mass="0.7" contype="0" conaffinity="0"/>
      </body>
    </body>
    <body name="hand" pos="0 1 1">
      <geom type="box" size="0.03 0.08 0.02" mass="1" contype="0" conaffinity="0"/>
""" + FINGERS + """    </body>
  </worldbody>
  <tendon>
    <fixed name="split"><joint joint="finger1" coef="0.5"/><joint joint="finger2" coef="0.5"/></fixed>
  </tendon>
  <equality><joint joint1="finger1" joint2="finger2"/></equality>
  <actuator>
    <position name="p1" joint="j1" kp="30" dampratio="1"/>
    <position name="p2" joint="j2" kp="12" dampratio="0.7" gear="2"/>
    <position name="grip" tendon="split" kp="50" dampratio="1.2"/>
  </actuator>
</mujoco>
"""


def test_dampratio_sets_the_servos_damping_as_mujoco_does(tmp_path):
    """A position actuator's ``dampratio`` (Menagerie's arms use it): kv = 2 dampratio sqrt(kp m)
    with m = 1 / (r^T M^-1 r) at qpos0 (M with armature, r the moment arms: a joint's gear, a
    tendon's gear coef_i): equal to MuJoCo's compiled biasprm (1e-10) for a joint servo, a geared
    one down a chain and a tendon servo; the joints' damping gear^2 kv; and the arm, servoed under
    gravity, moves as MuJoCo's RK4 says (2e-3 rad over 1 s at dt 1/960 s, first order). Before, the
    attribute was read as no damping: the arm rang about its targets (checked: 0.19 rad off at 1 s)."""
    from tumble.joints import P_DAMPING

    path = tmp_path / "dampratio.xml"
    path.write_text(DAMPRATIO)
    m = mujoco.MjModel.from_xml_path(str(path))
    world = tb.World(gravity=(0, 0, -9.81))
    robot = tb.load_mjcf(world, path)
    for k, name in enumerate(("p1", "p2", "grip")):
        assert robot.actuators[name].bias[2] == pytest.approx(m.actuator_biasprm[k, 2], rel=1e-10, abs=1e-12)
    assert robot.joints["j2"].bound.param[P_DAMPING] == pytest.approx(4 * -m.actuator_biasprm[1, 2], rel=1e-12)
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    m.opt.timestep = 1 / 4000
    d = mujoco.MjData(m)
    d.ctrl[:] = (0.5, -0.3, 0.01)
    sim = tb.Simulator(world, dt=1 / 960, joint_settings=ACCURATE)
    robot.set_controls(sim, {"p1": 0.5, "p2": -0.3, "grip": 0.01})
    sim.step(960)
    while d.time < 1.0 - 1e-9:
        mujoco.mj_step(m, d)
    got = [robot.joint_states(sim)[j][0] for j in ("j1", "j2", "finger1", "finger2")]
    np.testing.assert_allclose(got[:2], d.qpos[:2], atol=2e-3)
    np.testing.assert_allclose(got[2:], d.qpos[2:], atol=2e-4)


def test_dampratio_with_kv_is_one_line(tmp_path):
    path = write(tmp_path, "<mujoco><worldbody><body name='b'><joint name='j'/><geom size='0.1'/></body></worldbody>"
                           "<actuator><position joint='j' kp='5' kv='1' dampratio='1'/></actuator></mujoco>")
    with pytest.raises(tb.InputError, match=r"dampratio: give kv or dampratio, not both$"):
        tb.load_mjcf(tb.World(), path)


@pytest.mark.parametrize("value, problem", [("-1", "must be >= 0, got -1"), ("nan", "expected finite numbers"),
                                            ("1e308", "the damping it makes (kv = inf) is past the float range")])
def test_bad_dampratios_are_one_line(tmp_path, value, problem):
    path = write(tmp_path, "<mujoco><worldbody><body name='b'><joint name='j'/><geom size='0.1'/></body></worldbody>"
                           f"<actuator><position joint='j' kp='5' dampratio='{value}'/></actuator></mujoco>")
    with pytest.raises(tb.InputError) as info:
        tb.load_mjcf(tb.World(), path)
    line = str(info.value)
    assert "\n" not in line and str(path) in line and ".dampratio: " in line and problem in line, line


def test_inheritrange_sets_the_ctrlrange_as_mujoco_does(tmp_path):
    """``inheritrange`` (a position servo's ctrlrange from its joint's range, scaled about its middle):
    equal to MuJoCo's compiled ctrlrange (a hinge's range in degrees, a slide's in metres; 1e-12), and
    a control past it clipped there, as MuJoCo clips; with a ctrlrange too, without a range, or with a
    timeconst (activation dynamics): one line."""
    path = write(tmp_path, "<mujoco><worldbody><body name='b'><joint name='h' range='-60 120'/>"
                           "<joint name='s' type='slide' axis='1 0 0' range='0 0.2'/><geom size='0.1'/></body>"
                           "</worldbody><actuator><position name='a' joint='h' kp='5' inheritrange='0.5'/>"
                           "<position name='b' joint='s' kp='5' inheritrange='1.5'/></actuator></mujoco>")
    m = mujoco.MjModel.from_xml_path(str(path))
    robot = tb.load_mjcf(tb.World(), path)
    for k, name in enumerate(("a", "b")):
        np.testing.assert_allclose(robot.actuators[name].ctrlrange, m.actuator_ctrlrange[k], atol=1e-12)
    robot.set_controls(None, {"a": 10.0})
    assert robot.actuators["a"].ctrl == pytest.approx(m.actuator_ctrlrange[0, 1], abs=1e-12)
    for extra, problem in (("ctrlrange='0 1' inheritrange='1'", "give ctrlrange or inheritrange, not both"),
                           ("inheritrange='1'", "inheritrange needs a joint with a range"),
                           ("timeconst='0.1'", "a timeconst (activation dynamics) is not supported")):
        bad = write(tmp_path, "<mujoco><worldbody><body name='b'><joint name='j'/><geom size='0.1'/></body>"
                              f"</worldbody><actuator><position joint='j' kp='5' {extra}/></actuator></mujoco>", "bad.xml")
        with pytest.raises(tb.InputError, match=re.escape(problem)):
            tb.load_mjcf(tb.World(), bad)


# <frame>s (MuJoCo 3's): nested, with every kind of element inside and a childclass, in the
# worldbody and in a body; a joint whose anchor and axis are given in a frame; a static geom in one
FRAMED = """
<mujoco model="framed">
  <default>
    <default class="big"><geom type="box" size="0.05 0.1 0.02" density="2000"/><site size="0.02"/>
      <joint axis="1 0 0" damping="0.1"/></default>
  </default>
  <worldbody>
    <frame name="shelf" pos="0.3 0 0.2" euler="0 0 30">
      <geom name="ledge" type="box" size="0.2 0.1 0.01" pos="0.1 0 0"/>
      <frame pos="0 0.5 1" axisangle="1 0 0 40" childclass="big">
        <body name="a" pos="0.1 0 0" euler="10 0 0">
          <frame pos="0 0 -0.1" zaxis="0.3 1 1">
            <joint name="ja" pos="0 0.02 0"/>
            <geom pos="0 0 -0.2"/>
            <site name="sa" pos="0.05 0 0"/>
          </frame>
          <geom type="capsule" fromto="0 0 0 0 0.1 -0.3" size="0.03"/>
          <frame pos="0 0.1 -0.3" quat="0.9 0.1 0.2 0.3">
            <body name="b" pos="0 0 -0.05">
              <joint name="jb" type="hinge" axis="0 1 0"/>
              <frame euler="0 90 0"><geom class="big" pos="0.02 0 0"/><camera name="eye" pos="0 0 0.1"/></frame>
              <geom type="sphere" size="0.05" pos="0 0 -0.1"/>
            </body>
          </frame>
        </body>
      </frame>
    </frame>
  </worldbody>
</mujoco>
"""


def test_frames_place_what_they_hold_as_mujoco_does(tmp_path):
    """Bodies, geoms, joints, sites, cameras and frames inside <frame>s (nested, with a
    childclass): masses, centres, inertias, joint anchors and axes, the site's and the camera's
    frames and the static geom's pose equal MuJoCo's compiled model at qpos0. Tolerances as in
    test_mass_properties_and_joint_frames_match_mujocos_compiled_model (same closed forms, double
    precision); a frame dropped, applied twice or in the wrong order is off by centimetres."""
    path = write(tmp_path, FRAMED)
    ref, ref_joints = mujoco_bodies(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    world = tb.World(gravity=(0, 0, -G))
    robot = tb.load_mjcf(world, path)
    for name in ("a", "b"):
        assert_mass_properties(robot.links[name], ref[name], name)
    for name in ("ja", "jb"):
        joint = robot.joints[name]
        anchor, axis = ref_joints[name]
        np.testing.assert_allclose(joint.anchor, anchor, atol=1e-12, err_msg=name)
        np.testing.assert_allclose(np.asarray(joint.axis) / np.linalg.norm(joint.axis), axis, atol=1e-12, err_msg=name)
    assert robot.joints["ja"].damping == pytest.approx(0.1)  # the frame's childclass
    o, R = robot.site_pose("sa")
    np.testing.assert_allclose(o, d.site("sa").xpos, atol=1e-12)
    np.testing.assert_allclose(R, d.site("sa").xmat.reshape(3, 3), atol=1e-12)
    camera = robot.cameras["eye"]
    centre, axes = camera.pose(world)  # tumble's axes x right, y down, z forward; MuJoCo's looks along -z, y up
    np.testing.assert_allclose(centre, d.cam("eye").xpos, atol=1e-12)
    np.testing.assert_allclose(axes * [1.0, -1.0, -1.0], d.cam("eye").xmat.reshape(3, 3), atol=1e-12)
    ledge = robot.links["world/ledge"]
    np.testing.assert_allclose(ledge.x, d.geom("ledge").xpos, atol=1e-12)
    np.testing.assert_allclose(ledge.R, d.geom("ledge").xmat.reshape(3, 3), atol=1e-12)


# Height fields (``mjcf_hfield``): an asymmetric grid from each source MuJoCo reads, placed by its
# geom (in a frame), and what MuJoCo's compiler makes of it
HFIELD_ELEVATION = np.array([[0.0, 1.0, 2.0, 3.0, 0.5], [4.0, 5.0, 6.0, 9.0, 7.5], [8.0, 2.0, 1.0, 0.0, 0.25]])


def hfield_files(tmp_path):
    """{source: the <hfield> attributes}: elevation, a grey PNG, a colour PNG, MuJoCo's binary file."""
    from PIL import Image

    grey = np.array([[20, 50, 100, 150, 90], [200, 220, 30, 20, 60], [70, 80, 10, 250, 40]], np.uint8)
    Image.fromarray(grey).save(tmp_path / "grey.png")
    green = (grey.astype(int) * 7 % 256).astype(np.uint8)  # unlike red: a colour read as a mean or luminance fails
    Image.fromarray(np.stack([grey, green, np.full_like(grey, 7)], -1)).save(tmp_path / "colour.png")
    with open(tmp_path / "grid.bin", "wb") as f:
        np.array(HFIELD_ELEVATION.shape, np.int32).tofile(f)
        HFIELD_ELEVATION.astype(np.float32).tofile(f)
    text = " ".join(f"{v:g}" for v in HFIELD_ELEVATION.ravel())
    return {"elevation": f'nrow="3" ncol="5" elevation="{text}"', "grey": 'file="grey.png"',
            "colour": 'file="colour.png"', "binary": 'file="grid.bin"'}


def hfield_model(source):
    return f"""
<mujoco model="terrain">
  <asset><hfield name="ground" {source} size="1.5 1.0 0.4 0.2"/></asset>
  <worldbody>
    <frame pos="0.2 -0.1 0.05" euler="0 0 20">
      <geom name="terrain" type="hfield" hfield="ground" pos="0.1 0 0.3" euler="3 -2 0"/>
    </frame>
  </worldbody>
</mujoco>
"""


@pytest.mark.parametrize("source", ["elevation", "grey", "colour", "binary"])
def test_hfields_are_the_terrain_mujoco_compiles(tmp_path, source):
    """Each height field source (elevation, grey and colour PNG, MuJoCo's binary file): the heights
    tumble reads are MuJoCo's compiled ``hfield_data`` to the bit (float32 normalisation, row order),
    and vertical rays hit tumble's terrain where MuJoCo's ``mj_ray`` hits MuJoCo's, at grid points
    and inside cells on both sides of each cell's diagonal (1e-9 m: both are the same planar
    triangles in double precision; a flipped row order, a wrong diagonal or a missed geom or
    frame pose is off by centimetres)."""
    from tumble import mjcf_hfield
    from tumble.mjcf import _Reader
    from tumble.mjcf_xml import read_model_xml

    path = write(tmp_path, hfield_model(hfield_files(tmp_path)[source]))
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    root = read_model_xml(path)
    heights, size, base = mjcf_hfield.read_hfields(_Reader(root, path), root)["ground"]
    assert heights.shape == (m.hfield_nrow[0], m.hfield_ncol[0])
    np.testing.assert_array_equal(heights, 0.4 * m.hfield_data.reshape(heights.shape).astype(float))
    assert (size.tolist(), base) == ([3.0, 2.0], 0.2)
    world = tb.World()
    robot = tb.load_mjcf(world, path)
    terrain = robot.links["world/terrain"].index
    centre, R = d.geom("terrain").xpos, d.geom("terrain").xmat.reshape(3, 3)
    rng = np.random.default_rng(3)
    u = np.concatenate([np.stack(np.meshgrid(np.linspace(-1, 1, 5) * 0.999, np.linspace(-1, 1, 3) * 0.999), -1)
                        .reshape(-1, 2), rng.uniform(-0.98, 0.98, (60, 2))])
    geomid = np.zeros(1, np.int32)
    for ux, uy in u:
        origin = centre + R @ np.array([1.5 * ux, 1.0 * uy, 0.0]) + np.array([0.0, 0.0, 3.0])
        expected = mujoco.mj_ray(m, d, origin, np.array([0.0, 0.0, -1.0]), None, 1, -1, geomid)
        assert geomid[0] == m.geom("terrain").id
        hit = world.ray_cast(origin, (0.0, 0.0, -1.0))
        assert hit.body[0] == terrain
        assert hit.distance[0] == pytest.approx(expected, abs=1e-9), (ux, uy)


def test_a_box_comes_to_rest_on_an_mjcf_hfield(tmp_path):
    """A box dropped onto a sloped height field (a 4 x 6 grid rising 0.4 m over 3 m, 7.6 degrees,
    under MuJoCo's default friction 1: it sticks) ends resting on the surface: its gap to the
    terrain (closest points) within the contact solver's resting penetration (under 1 mm),
    still (under 1 mm/s) after 3 s and where it landed."""
    slope = " ".join(f"{v:g}" for v in np.tile(np.linspace(1.0, 0.0, 6), 4))
    model = f"""
<mujoco model="slope">
  <asset><hfield name="ground" nrow="4" ncol="6" elevation="{slope}" size="1.5 1.0 0.4 0.2"/></asset>
  <worldbody>
    <geom name="terrain" type="hfield" hfield="ground"/>
    <body name="box" pos="0.1 0.2 0.6" euler="0 0 30"><freejoint/><geom type="box" size="0.1 0.08 0.05"/></body>
  </worldbody>
</mujoco>
"""
    path = write(tmp_path, model)
    world = tb.World(gravity=(0, 0, -G))
    robot = tb.load_mjcf(world, path)
    sim = tb.Simulator(world, dt=1 / 240)
    sim.step(720)
    box, terrain = robot.links["box"], robot.links["world/terrain"]
    gap = world.closest_points(box.index, terrain.index).distance[0]
    assert -1e-3 < gap < 1e-3, gap
    assert np.linalg.norm(box.v) < 1e-3
    # on the slope where it landed (the surface is 0.187 m high under its start; measured 6.6 mm
    # of settling along it), not slid down nor fallen past it
    assert np.linalg.norm(box.x[:2] - (0.1, 0.2)) < 0.02 and 0.2 < box.x[2] < 0.3


@pytest.mark.parametrize("name, content, problem", [
    ("short.bin", b"abc", "not a PNG and too short for MuJoCo's binary height field"),
    ("sized.bin", np.array([2, 3], np.int32).tobytes() + b"\0" * 20, "expected int32 nrow, ncol (>= 2)"),
    ("broken.png", b"not an image", "broken.png: cannot read the image"),
])
def test_bad_hfield_files_are_one_line(tmp_path, name, content, problem):
    (tmp_path / name).write_bytes(content)
    path = write(tmp_path, f"<mujoco><asset><hfield name='h' file='{name}' size='1 1 1 1'/></asset><worldbody>"
                           "<geom type='hfield' hfield='h'/></worldbody></mujoco>")
    with pytest.raises(tb.InputError) as info:
        tb.load_mjcf(tb.World(), path)
    line = str(info.value)
    assert "\n" not in line and str(path) in line and "asset.hfield[h].file" in line and problem in line, line


def test_ellipsoid_geoms_are_tumbles_ellipsoids_with_mujocos_mass_properties(tmp_path):
    """An ``ellipsoid`` geom (size: its three semi-axes) is a ``tb.Ellipsoid``: the body's mass,
    centre and inertia (an ellipsoid beside a sphere, turned) equal MuJoCo's compiled model to
    1e-12 (tolerances as the first test's), and a ray down onto it meets it where mj_ray does."""
    path = write(tmp_path, """
<mujoco><worldbody>
  <body name="egg" pos="0 0 1"><freejoint/>
    <geom type="ellipsoid" size="0.3 0.2 0.1" euler="20 30 40" density="1100"/>
    <geom type="sphere" size="0.05" pos="0.2 0 0.1"/>
  </body>
</worldbody></mujoco>""")
    ref, _ = mujoco_bodies(path)
    world = tb.World()
    robot = tb.load_mjcf(world, path)
    egg = robot.links["egg"]
    assert any(isinstance(part[0], tb.Ellipsoid) for part in world.shapes[egg.index].parts)
    assert_mass_properties(egg, ref["egg"])
    assert_rays_down_hit_where_mujoco_does(world, path, ((0.0, 0.0), (0.05, -0.03), (-0.04, 0.02)), 1e-9)


def test_inline_mesh_vertices_give_mujocos_mass_properties(tmp_path):
    """An ``<asset><mesh vertex="...">`` (no file), scaled and placed off the body's origin, is the
    hull of its points: the body's mass, centre and inertia equal MuJoCo's compiled model (its
    convex mesh's volume integrals) to 3e-7 relative and 1e-7 m (both integrate the same hull, but
    MuJoCo keeps its vertices in float32, 6e-8 relative each: measured 1.5e-8 in the mass, 3e-9 m
    in the centre, 4e-8 in the inertia), and a ray down onto it meets it where mj_ray does to
    1e-8 m (measured 6e-10). A short vertex list, or one with a word in it, is one line."""
    rng = np.random.default_rng(4)
    points = rng.normal(size=(20, 3)) * (0.1, 0.07, 0.05)
    text = " ".join(f"{v:.6f}" for v in points.ravel())
    path = write(tmp_path, f"""
<mujoco><asset><mesh name="rock" vertex="{text}" scale="1.5 1 1.2"/></asset><worldbody>
  <body name="rock" pos="0 0 1"><freejoint/><geom type="mesh" mesh="rock" pos="0.05 0 0.02" euler="10 0 30"/></body>
</worldbody></mujoco>""")
    ref, _ = mujoco_bodies(path)
    world = tb.World()
    robot = tb.load_mjcf(world, path)
    rock = robot.links["rock"]
    assert_mass_properties(rock, ref["rock"], rel=3e-7, centre=1e-7, inertia=3e-7)
    assert_rays_down_hit_where_mujoco_does(world, path, ((0.05, 0.0), (0.08, 0.02), (0.02, -0.02)), 1e-8)
    bad = write(tmp_path, '<mujoco><asset><mesh name="m" vertex="0 0 0 1 0 0"/></asset><worldbody/></mujoco>', "bad.xml")
    with pytest.raises(tb.InputError, match=r"asset.mesh\[m\].vertex: expected at least 4 points"):
        tb.load_mjcf(tb.World(), bad)
    words = write(tmp_path, '<mujoco><asset><mesh name="m" vertex="0 0 0 1 0 0 0 1 0 0 0 x"/></asset><worldbody/></mujoco>',
                  "words.xml")
    with pytest.raises(tb.InputError, match=r"asset.mesh\[m\].vertex: expected numbers"):
        tb.load_mjcf(tb.World(), words)


# <replicate>s (MuJoCo 3's): nested, turned (euler in radians here), with sep, a joint and a site
# in each copy, a sensor on one copy's joint, and a row of static pegs (12 copies: 2-digit suffixes)
REPLICATED = """
<mujoco model="rows">
  <compiler angle="radian"/>
  <worldbody>
    <replicate count="2" offset="0.6 0 0" euler="0 0 0.3" sep="x">
      <replicate count="3" offset="0 0.4 0.05" sep="y">
        <body name="arm" pos="0 0 1" euler="0.1 0 0">
          <joint name="hinge" axis="0 1 0" pos="0 0 0.1"/>
          <geom type="capsule" fromto="0 0 0 0 0.05 -0.3" size="0.03"/>
          <site name="tip" pos="0 0 -0.3"/>
        </body>
      </replicate>
    </replicate>
    <replicate count="12" offset="0.1 0 0" euler="0 0 0.05">
      <geom name="peg" type="box" size="0.01 0.01 0.05" pos="0 -1 0.05"/>
    </replicate>
  </worldbody>
  <sensor><jointpos name="q" joint="hingey1x0"/></sensor>
</mujoco>
"""


def test_replicates_make_the_copies_mujoco_makes(tmp_path):
    """Every copy MuJoCo's compiler makes of a <replicate> (nested, turned, sep, 2-digit
    suffixes) is in tumble under the same name: bodies with their masses, centres and inertias,
    joints with their anchors and axes, sites and static geoms where MuJoCo puts them (1e-12:
    the same closed forms; a pose composed the wrong way round is off by centimetres), and a
    sensor on one copy's joint reads it. Unnamed copies stay unnamed, as in MuJoCo."""
    path = write(tmp_path, REPLICATED)
    ref, ref_joints = mujoco_bodies(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    world = tb.World()
    robot = tb.load_mjcf(world, path)
    assert set(ref) == {f"army{i}x{j}" for i in range(3) for j in range(2)}
    for name, reference in ref.items():
        assert_mass_properties(robot.links[name], reference, name)
    for name, (anchor, axis) in ref_joints.items():
        joint = robot.joints[name]
        np.testing.assert_allclose(joint.anchor, anchor, atol=1e-12, err_msg=name)
        np.testing.assert_allclose(np.asarray(joint.axis) / np.linalg.norm(joint.axis), axis, atol=1e-12, err_msg=name)
    for k in range(m.nsite):
        o, R = robot.site_pose(m.site(k).name)
        np.testing.assert_allclose(o, d.site_xpos[k], atol=1e-12)
        np.testing.assert_allclose(R, d.site_xmat[k].reshape(3, 3), atol=1e-12)
    pegs = [m.geom(k).name for k in range(m.ngeom) if m.geom(k).name.startswith("peg")]
    assert pegs == [f"peg{i:02d}" for i in range(12)]
    for name in pegs:
        np.testing.assert_allclose(robot.links[f"world/{name}"].x, d.geom(name).xpos, atol=1e-12, err_msg=name)
    sim = tb.Simulator(world, dt=1 / 240)
    robot.reset_joint_positions(sim, {"hingey1x0": 0.25})
    assert robot.sensor_data(sim)["q"] == pytest.approx(0.25, abs=1e-12)


REFS = """
<mujoco model="refs">
  <compiler angle="radian"/>
  <option timestep="0.00025" integrator="RK4" gravity="0 0 -9.81"/>
  <default><geom type="capsule" size="0.03" contype="0" conaffinity="0"/></default>
  <worldbody>
    <body name="arm" pos="0 0 2">
      <joint name="swing" type="hinge" axis="0 1 0" ref="0.4" range="-0.3 1.2" stiffness="5" springref="0.1"
             damping="0.2"/>
      <geom fromto="0 0 0 0.3 0 -0.6"/>
    </body>
    <body name="cart" pos="2 0 1">
      <joint name="rail" type="slide" axis="1 0 0" ref="0.3" range="0 0.5"/>
      <geom type="box" size="0.1 0.1 0.1" mass="1"/>
    </body>
    <body name="lead" pos="4 0 2">
      <joint name="a" type="hinge" axis="0 1 0" ref="0.2" damping="0.5"/>
      <geom fromto="0 0 0 0 0 -0.5"/>
    </body>
    <body name="mirror" pos="5 0 2">
      <joint name="b" type="hinge" axis="0 1 0" ref="-0.1"/>
      <geom fromto="0 0 0 0 0 -0.5"/>
    </body>
  </worldbody>
  <equality><joint joint1="b" joint2="a" polycoef="0 -1 0 0 0"/></equality>
  <actuator>
    <position name="servo" joint="rail" kp="50" kv="5"/>
    <motor name="push" joint="a" gear="1"/>
  </actuator>
</mujoco>
"""


def test_joint_refs_are_mujocos_qpos0_and_the_model_moves_as_mujoco_rk4_says(tmp_path):
    """MuJoCo's joint ``ref``: the joint's value at the file's pose (qpos0). A hinge with ref 0.4 rad,
    a range and a spring to springref 0.1, a slide with ref 0.3 m and a range driven by a position
    servo to 0.45, and a joint equality (b - ref_b = -(a - ref_a)) between two hinges with refs,
    one pushed by a motor: qpos0 and the bodies' places equal MuJoCo's compiled model's (exactly:
    the file's numbers), and the motion over 1 s follows MuJoCo's RK4 at 1/4000 s (converged) to
    first order (measured 1.5e-3 at dt 1/240, 3.9e-4 at 1/960; tolerance 3e-3). With the refs read
    as 0 (tumble before: the attribute was not read) the readings are off by the refs (0.1 and
    more), the springs pull elsewhere and the limits sit aside."""
    path = write(tmp_path, REFS)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    world = tb.World(gravity=(0, 0, -G))
    robot = tb.load_mjcf(world, path)
    np.testing.assert_array_equal(robot.qpos0, m.qpos0)
    np.testing.assert_allclose(robot.kinematics.qpos(), m.qpos0, rtol=0, atol=1e-15)  # read back from the bodies
    for i in range(1, m.nbody):
        np.testing.assert_allclose(robot.link_pose(m.body(i).name)[0], d.xpos[i], rtol=0, atol=1e-15)
    controls = {"servo": 0.45, "push": 0.3}
    names, ref = mujoco_motion(path, controls=controls)
    q, _, _ = tumble_motion(path, names, controls=controls)
    assert np.abs(q - ref).max() < 3e-3
    # the servo near its target (in qpos: 0.15 m from the file's pose) and b mirroring a about their
    # refs: MuJoCo's soft equality to 1.1e-4 (measured), tumble's (the tree solve) closer
    assert abs(ref[-1, 1] - 0.45) < 0.02 and abs((ref[-1, 3] + 0.1) + (ref[-1, 2] - 0.2)) < 1e-3
    assert np.abs((q[:, 3] + 0.1) + (q[:, 2] - 0.2)).max() < 1e-5
    stripped = write(tmp_path, REFS.replace(' ref="0.4"', "").replace(' ref="0.3"', "").replace(' ref="0.2"', "")
                     .replace(' ref="-0.1"', ""), "stripped.xml")
    q0, _, _ = tumble_motion(stripped, names, controls=controls)
    assert np.abs(q0 - ref).max() > 0.1


def test_ref_polynomial_shifts_mujocos_joint_equality_to_the_coordinates():
    """``mjcf_control.ref_polynomial``: q1 - r1 = sum a_j (q2 - r2)^j rewritten as q1 = sum c_k q2^k
    agrees with the definition at random points (a quartic), and leaves the coefficients as they
    are without refs."""
    from tumble.mjcf_control import ref_polynomial

    rng = np.random.default_rng(4)
    a = rng.normal(size=5)
    r1, r2 = 0.3, -0.7
    c = ref_polynomial(a, r1, r2)
    for q2 in rng.uniform(-2, 2, size=7):
        assert sum(ck * q2**k for k, ck in enumerate(c)) == pytest.approx(
            r1 + sum(aj * (q2 - r2) ** j for j, aj in enumerate(a)), rel=1e-12, abs=1e-12)
    assert ref_polynomial(a, 0.0, 0.0) == tuple(a)


ARMATURE_ON_A_TURNING_PARENT = """
<mujoco model="turning"><compiler angle="radian"/><option gravity="0 0 0"/>
<worldbody><body name="base" pos="0 0 1"><joint name="pan" type="hinge" axis="0 0 1"/>
<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04" density="300"/>
<body name="roll" pos="0.3 0 0"><joint name="roll" type="hinge" axis="1 0 0" armature="0.04"/>
<geom type="capsule" fromto="0 -0.1 0 0.1 -0.1 0" size="0.02" density="300"/>
<geom type="capsule" fromto="0 0.1 0 0.1 0.1 0" size="0.02" density="300"/>
</body></body></worldbody></mujoco>
"""


def test_armature_resists_the_centrifugal_acceleration_as_mujocos_does(tmp_path):
    """MuJoCo's armature a adds to the coordinate's inertia, so a roll joint on a turning parent
    accelerates by -c/(I + a) (c its velocity-product term, MuJoCo's ``qfrc_bias``). At the state
    below (pan rate 2, roll rate -3, roll 0.7, no controls, no gravity) MuJoCo's roll acceleration is
    -0.0459 rad/s^2. Until session 31 tumble's was -1.934 = -c/I: the armature row's target was
    taken after the substep derived omega again from L at the new orientation, where the
    velocity-product terms enter (``joint_solve.first_substep_rates_kernel``). Compared: tumble's
    acceleration over the second of two steps of 1e-5 s (the first starts from a placed state,
    whose rates are derived from the momenta) against MuJoCo's ``qacc`` at the same state, to
    1e-3 (measured 1.7e-5 for the pan, 1.5e-4 for the roll: the step's own first-order error
    over 1e-5 s)."""
    path = write(tmp_path, ARMATURE_ON_A_TURNING_PARENT)
    qpos, qvel = np.array([0.3, 0.7]), np.array([2.0, -3.0])
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = qpos, qvel
    mujoco.mj_forward(m, d)
    world = tb.World(gravity=(0, 0, 0))
    robot = tb.load_mjcf(world, path)
    sim = tb.Simulator(world, dt=1e-5, joint_settings=ACCURATE)
    kin = robot.kinematics
    kin.set_state(qpos, qvel, sim)
    sim.step(1)
    v1 = kin.qvel()
    sim.step(1)
    acceleration = (kin.qvel() - v1) / 1e-5
    assert acceleration[0] == pytest.approx(d.qacc[0], rel=1e-3)  # the pan: no armature
    assert acceleration[1] == pytest.approx(d.qacc[1], rel=1e-3)


WRIST = """
<mujoco model="wrist"><compiler angle="radian"/><option gravity="0 0 0" integrator="RK4" timestep="1e-4"/>
<worldbody><body name="base" pos="0 0 1"><joint name="pan" type="hinge" axis="0 0 1"/>
<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04" density="300"/>
<body name="flex" pos="0.3 0 0"><joint name="flex" type="hinge" axis="0 1 0" armature="0.04"/>
<geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.03" density="300"/>
<body name="roll" pos="0.2 0 0"><joint name="roll" type="hinge" axis="1 0 0" armature="0.04"/>
<geom type="capsule" fromto="0 -0.1 0 0.1 -0.1 0" size="0.02" density="300"/>
<geom type="capsule" fromto="0 0.1 0 0.1 0.1 0" size="0.02" density="300"/>
</body></body></body></worldbody>
<actuator><motor name="pan" joint="pan"/><motor name="flex" joint="flex"/><motor name="roll" joint="roll"/></actuator>
</mujoco>
"""


def test_a_wrist_with_armature_converges_to_mujoco_rk4_at_first_order(tmp_path):
    """A pusher's wrist (pan about z, flex about y, roll about x; armature 0.04 on flex and roll,
    ten to forty times the links' own inertias about their axes), turning under constant motor
    torques from (0.3, -0.4, 0.7) rad at (2, 1, -3) rad/s, no gravity: tumble at steps 0.005 to
    0.00125 s against MuJoCo's RK4 at 1e-4 s after 0.25 s (converged: its own change at 5e-5 s is
    5e-15). tumble's step is first order: each halving of the step must halve the largest
    difference (ratios within 1.7-2.3; measured 1.98-2.0, 1.1e-4 rad at 0.005 s). Before session
    31 the difference stalled at 0.065 rad whatever the step (the armature did not resist the
    velocity-product acceleration: the test above); it found the bug through Gymnasium's Pusher."""
    path = write(tmp_path, WRIST)
    errors = converges_to_mujoco(path, [0.3, -0.4, 0.7], [2.0, 1.0, -3.0], [0.05, -0.02, 0.01], 0.25,
                                 (0.005, 0.0025, 0.00125), lambda q, ref: np.abs(q - ref).max(),
                                 joint_settings=ACCURATE)
    assert errors[-1] < 5e-5


def converges_to_mujoco(path, q0, v0, controls, duration, steps, difference, **settings):
    """The model at ``path`` (no gravity: the file's own option) from qpos ``q0``, qvel ``v0`` under
    constant ``controls`` (the actuators' ctrl, MuJoCo's order) for ``duration`` s: MuJoCo's run at
    the file's timestep (the reference) against tumble's at each step of ``steps``, each half the
    last, compared by ``difference(qpos, reference)``. They must halve with the step (ratios
    1.7-2.3 admit first order only). Returns the differences."""
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:], d.ctrl[:] = q0, v0, controls
    for _ in range(int(round(duration / m.opt.timestep))):
        mujoco.mj_step(m, d)
    errors = []
    for dt in steps:
        world = tb.World(gravity=(0, 0, 0))
        robot = tb.load_mjcf(world, path)
        sim = tb.Simulator(world, dt=dt, **settings)
        robot.kinematics.set_state(np.asarray(q0, dtype=float), np.asarray(v0, dtype=float), sim)
        robot.set_controls(sim, dict(zip(robot.ctrl_names, controls)))
        sim.step(int(round(duration / dt)))
        errors.append(difference(robot.kinematics.qpos(), d.qpos))
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 1.7) & (ratios < 2.3)), (errors, ratios)
    return errors


def swimmer_path():
    gymnasium = pytest.importorskip("gymnasium")
    return Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "swimmer.xml"


def test_the_files_fluid_is_read_and_pushes_as_mujocos_does():
    """Gymnasium's swimmer (``<option density="4000" viscosity="0.1">``): ``load_mjcf`` adds a
    ``tb.Fluid`` on its three capsules (not on the virtual links between its root's joints: MuJoCo
    has none), each box along the capsule's geom frame as MuJoCo's compiler takes it. At random
    states the generalized forces it makes (J^T F + J_w^T tau over the capsules, from
    ``Kinematics.jacobian``) equal MuJoCo's ``qfrc_passive`` (which holds the fluid alone here) to
    1e-12 of their size (measured 2e-12 on forces of 1e3). ``fluid=False`` leaves it off."""
    path = swimmer_path()
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    world = tb.World(gravity=(0, 0, 0))
    robot = tb.load_mjcf(world, path)
    assert robot.fluid.density == 4000 and robot.fluid.viscosity == 0.1 and robot.fluid in world.forces
    assert [b.name for b in robot.fluid.bodies] == ["swimmer/torso", "swimmer/mid", "swimmer/back"]
    sim = tb.Simulator(world, dt=0.01)
    kin = robot.kinematics
    rng = np.random.default_rng(1)
    for _ in range(4):
        qpos, qvel = rng.uniform(-1, 1, 5), rng.normal(size=5)
        d.qpos[:], d.qvel[:] = qpos, qvel
        mujoco.mj_forward(m, d)
        kin.set_state(qpos, qvel, sim)
        dY = world.dxdt(0.0, world.state()).reshape(world.body_count, -1)
        generalized = np.zeros(5)
        for body in robot.fluid.bodies:
            link = body.name.split("/", 1)[1]
            origin, R = robot.link_pose(link)
            J = kin.jacobian(link, point=R.T @ (body.x - origin))
            generalized += J[:3].T @ dY[body.index, 7:10] + J[3:].T @ dY[body.index, 10:13]
        np.testing.assert_allclose(generalized, d.qfrc_passive, rtol=0, atol=1e-12 * np.abs(d.qfrc_passive).max())
    bare = tb.World(gravity=(0, 0, 0))
    assert tb.load_mjcf(bare, path, fluid=False).fluid is None and bare.forces == []


def test_a_free_swimmer_converges_to_mujoco_rk4_at_first_order(tmp_path):
    """The swimmer's dynamics in its fluid, with its root a free joint (no virtual links: tumble's
    swimmer on its root's two slides and hinge carries their 0.1 % of its mass, tests/test_envs.py)
    and no gravity: from a turned start at rates that keep its hinges inside their ranges, under
    constant motor controls for 0.5 s, against MuJoCo's RK4 at 5e-4 s (converged: 4e-11 from 2.5e-4
    s). tumble's step is first order: each halving of the step must halve the largest difference
    of qpos (ratios within 1.7-2.3; measured 2.00, 3.2e-3 at 0.01 s to 4.0e-4 at 0.00125 s). Were
    the fluid's boxes, its viscosity or the armature read otherwise, it would stop shrinking."""
    text = swimmer_path().read_text()
    text = re.sub(r'<joint axis="1 0 0" name="slider1"[^>]*/>\s*<joint axis="0 1 0" name="slider2"[^>]*/>\s*'
                  r'<joint axis="0 0 1" name="free_body_rot"[^>]*/>', '<freejoint name="root"/>', text)
    text = text.replace('timestep="0.01"', 'timestep="0.0005" gravity="0 0 0"')
    assert "<freejoint" in text and "gravity" in text
    path = write(tmp_path, text)

    def difference(qpos, reference):
        out = np.abs(qpos - reference)
        out[3:7] = abs(abs(qpos[3:7] @ reference[3:7]) - 1.0)  # the root's turn, sign-free
        return out.max()

    converges_to_mujoco(path, [0, 0, 0, np.cos(0.15), 0, 0, np.sin(0.15), 0.5, -0.4],
                        [0.3, -0.2, 0, 0, 0, 0.5, 0.5, -0.6], [0.1, -0.15], 0.5, (0.01, 0.005, 0.0025), difference)


def test_a_bad_fluid_option_is_one_line(tmp_path):
    path = write(tmp_path, '<mujoco><option density="-1"/><worldbody><body><freejoint/><geom size="0.1"/></body>'
                           '</worldbody></mujoco>')
    with pytest.raises(tb.InputError) as info:
        tb.load_mjcf(tb.World(), path)
    assert str(info.value) == f"{path}: option.density: must be >= 0, got '-1'"


def bare_ant(tmp_path, armature: str):
    """Gymnasium's ant.xml with its limits and dampers off, friction 3 (its feet held), its hinges'
    armature ``armature``: (world, kinematics, simulator at 0.01 s) with the legs bent, at rest."""
    gymnasium = pytest.importorskip("gymnasium")
    text = (Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "ant.xml").read_text()
    text = (text.replace('limited="true"', 'limited="false"').replace('damping="1"', 'damping="0"')
            .replace('friction="1 0.5 0.5"', 'friction="3 0.5 0.5"').replace('armature="1"', f'armature="{armature}"'))
    assert text.count("friction=\"3") == 1 and text.count(f'armature="{armature}"') >= 1
    world = tb.World(gravity=(0, 0, -9.81))
    world.sleeping = False
    robot = tb.load_mjcf(world, write(tmp_path, text))
    sim = tb.Simulator(world, dt=0.01)
    kin = robot.kinematics
    q0 = kin.qpos()
    q0[7:] = [0, 0.6, 0, -0.6, 0, -0.6, 0, 0.6]
    kin.set_state(q0, np.zeros(kin.nv), sim)
    return kin, sim


def test_a_legged_mechanism_without_armature_comes_to_rest_on_its_feet(tmp_path):
    """The ant's four free legs (no limits, no dampers) on feet held by friction 3 let go bent: its
    torso settles on the floor and every rate falls to rounding (under 1e-9 after 3 s; measured
    5e-14): the joints' tree solve and the contacts agree at rest. The case below, with armature,
    too since the contacts are solved through the tree (session 35)."""
    kin, sim = bare_ant(tmp_path, "0")
    sim.step(300)
    assert np.abs(kin.qvel()).max() < 1e-9


def test_a_legged_mechanism_with_armature_loses_energy_and_sinks_as_mujocos_does(tmp_path):
    """The same ant with the file's armature (1 kg m^2 on every hinge, about 1000 times its legs' own
    inertia about their axes): a passive mechanism on contacts that hold or slide, so from the
    landing on (0.4 s) its energy E = kinetic + potential + sum a q'^2 / 2 only falls, but for the
    soft contacts' push-out: bound 0.005 J a step of the 3.1 J above the floor (measured 0.0007 J
    since the contacts are solved through the tree, session 35; 0.033 J before, when the contact
    rows saw the legs' own masses and the joints' solve undid part of each push: the armature-free
    twin's largest rise was 0.02 J).

    Held by friction, the bent stance is an equilibrium, but an unstable one: the torso can turn
    about the vertical while the legs swing about their hips the other way, which lowers it with
    the feet still (the twist mode). So the ant stands, then leaves the stance as a small
    disturbance grows, sinks to the floor (z 0.25, the torso's radius) and loses energy to the
    contacts. When it leaves depends on the disturbance: MuJoCo's same model, whose soft contacts
    creep, is on the floor by 2.5 s (0.261; its rates up to 0.24 rad/s from 1 s to 4 s, measured each
    step at dt 0.01 and 0.002); tumble's before session 35, whose contacts and joints disagreed by
    0.03 rad/s at rest, by 3 s; now by 10.2 s (measured; the stance holds to 1e-2 rad/s for 4 s).
    Over 16 s: E falls from 3.14 to 2.08 J (bound: by 0.5 J), rates under 1 rad/s after 1 s (measured
    0.91, the twist's fall), the torso on the floor.

    Found in session 31: the armature's rate was taken again each substep from the bodies' rates,
    which the contacts had changed with the free bodies' masses, so each contact's change of q' was
    the armature's too (momentum a dq' from nothing): the rates grew to 81 rad/s in 1 s and the ant
    leapt 20 m in 3 s (joint_solve.flywheel_rates_kernel)."""
    kin, sim = bare_ant(tmp_path, "1")
    world = sim.world

    def energy():
        return world.kinetic_energy() + world.potential_energy() + 0.5 * (kin.qvel()[6:] ** 2).sum()

    sim.step(40)
    landed = previous = energy()
    rise = fastest = 0.0
    for k in range(1560):
        sim.step(1)
        now = energy()
        rise = max(rise, now - previous)
        previous = now
        if k >= 60:
            fastest = max(fastest, np.abs(kin.qvel()).max())
    assert rise < 0.005
    assert previous < landed - 0.5
    assert fastest < 1.0
    assert 0.24 < kin.qpos()[2] < 0.27
