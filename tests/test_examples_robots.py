"""examples/robot_arm.toml: a URDF arm (examples/robots/arm.urdf) loaded by a scene file's
[[robots]] entry, driven by a velocity motor and two PD drives, knocks over a tower of blocks.
Checked for what its header comment promises."""

from pathlib import Path

import numpy as np
import pytest

import tumble as tb
from tumble.scene import load_scene

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def test_robot_arm_sweeps_at_its_motor_speed_and_knocks_the_tower_over():
    scene = load_scene(EXAMPLES / "robot_arm.toml")
    world = scene.world
    sim = tb.Simulator(world, dt=scene.dt, joint_settings=scene.joint_settings)
    names = [j.name for j in world.joints]
    yaw, shoulder, elbow = (names.index(f"arm/{n}") for n in ("yaw", "shoulder", "elbow"))
    blocks = [world.names.index(f"block{k}") for k in range(6)]
    start = world.x[blocks].copy()
    # the turret, arm and hand's moment of inertia about the yaw axis (z through the origin)
    arm = [world.names.index(f"arm/{n}") for n in ("turret", "upper_arm", "forearm")]
    I_z = sum(world.R[i][2] @ world.inertia_body[i] @ world.R[i][2] + world.mass[i] * (world.x[i, :2] @ world.x[i, :2])
              for i in arm)
    sim.step(int(round(0.8 / scene.dt)))  # before the hand reaches the tower (a quarter turn: 1.05 s)
    r = sim.joint_readings()
    # the motor (20 N m) keeps the turret at its 1.5 rad/s (measured 1.49999: the exact tree
    # solve); the PD drives hold the shoulder and the elbow near their targets, sagging outwards
    # under the arm's weight (measured 0.037 and 0.014 rad)
    assert r["rate"][yaw] == pytest.approx(1.5, abs=1e-4)
    # spun up at the motor's 20 N m: it lags 1.5 t by 1.5^2 / (2 alpha), alpha = 20 / I_z (0.056 rad;
    # I_z grows 1 % as the arm sags)
    lag = 1.5**2 / (2 * 20.0 / I_z)
    assert r["position"][yaw] == pytest.approx(1.5 * world.t - lag, abs=2e-3)
    assert 0 < r["position"][shoulder] - 1.2 < 0.1 and 0 < r["position"][elbow] - 0.9 < 0.1
    np.testing.assert_allclose(world.x[blocks], start, atol=1e-3)  # the tower stands untouched
    sim.step(int(round(2.2 / scene.dt)))
    end = world.x[blocks]
    moved = np.linalg.norm(end[:, :2] - start[:, :2], axis=1)
    # the hand (its ball 0.07 to 0.19 m up, the arm sagging) strikes the lower blocks out from under
    # the rest: the whole tower ends on the ground, one block high (centres at 0.05 m to the
    # contact's 0.1 mm), the struck blocks thrown more than 0.2 m
    np.testing.assert_allclose(end[:, 2], 0.05, atol=2e-4)
    assert np.sum(moved > 0.2) >= 3
    r = sim.joint_readings()
    assert r["rate"][yaw] == pytest.approx(1.5, abs=1e-4)  # the arm swept on


def test_mjcf_pendulum_swings_as_mujoco_says_then_knocks_the_top_of_the_tower_off():
    """examples/mjcf_pendulum.toml: the MJCF double pendulum (examples/robots/pendulum.xml) swings
    as MuJoCo's RK4 (dt 1/4000 s) integrates the same file until the bob reaches the tower (0.58
    s): measured 0.0126 rad at most by 0.55 s at the scene's dt 1/240 with the default soft joints
    (the first-order step on a shoulder turning at 8 rad/s); tolerance 2x. Then the three upper
    blocks fly off (more than 0.3 m) and the bottom one stays within 0.1 m."""
    mujoco = pytest.importorskip("mujoco")
    scene = load_scene(EXAMPLES / "mjcf_pendulum.toml")
    world = scene.world
    sim = scene.simulator()
    m = mujoco.MjModel.from_xml_path(str(EXAMPLES / "robots" / "pendulum.xml"))
    d = mujoco.MjData(m)
    m.opt.timestep = 1 / 4000
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    blocks = [world.names.index(f"block{k}") for k in range(4)]
    start = world.x[blocks].copy()
    for _ in range(11):  # to 0.55 s, every 0.05 s
        sim.step(12)
        mujoco.mj_step(m, d, nstep=200)
        assert np.abs(sim.joint_readings()["position"] - d.qpos).max() < 0.025, world.t
    np.testing.assert_allclose(world.x[blocks], start, atol=1e-3)  # not reached yet
    sim.step(int(round(2.45 / scene.dt)))
    moved = np.linalg.norm(world.x[blocks] - start, axis=1)
    assert np.all(moved[1:] > 0.3) and moved[0] < 0.1, moved


def test_mjcf_turntable_spins_up_with_its_armature_then_sweeps_the_blocks():
    """examples/mjcf_turntable.toml: a velocity actuator (kv 30) set by the scene's controls to
    1.2 rad/s spins the table up as kv (r - rate) = (I + a) rate' says, rate = r (1 - exp(-t /
    tau)), tau = (I + a) / kv, I the table and boom's inertia about the axis from tumble's own
    bodies, a the joint's armature (2): measured 5e-4 and 1e-4 rad/s off at 0.5 and 1.0 s (the first-order
    step; without the armature tau would be 0.20 s, not 0.27, and the rate 0.09 higher at 0.5 s).
    Then the boom pushes the four blocks round over the floor: each ends more than 0.5 m from
    where it stood, still on the floor, and the table turns slower than its set rate under their
    friction."""
    import math

    scene = load_scene(EXAMPLES / "mjcf_turntable.toml")
    world = scene.world
    sim = tb.Simulator(world, dt=scene.dt, joint_settings=scene.joint_settings)
    assert sim.joint_settings.method == "tree"  # the armature's default
    i = world.names.index("turntable/table")
    I_z = world.R[i][2] @ world.inertia_body[i] @ world.R[i][2] + world.mass[i] * (world.x[i, :2] @ world.x[i, :2])
    tau = (I_z + 2.0) / 30.0
    blocks = [world.names.index(f"block{k}") for k in range(4)]
    start = world.x[blocks].copy()
    for t in (0.5, 1.0):
        sim.step(int(round(t / scene.dt)) - sim.step_index)
        rate = sim.joint_readings()["rate"][0]
        assert rate == pytest.approx(1.2 * (1.0 - math.exp(-t / tau)), abs=1.5e-3)
    # not reached yet: the blocks stand where they were (settled 4 um into the floor, the contact's overlap)
    np.testing.assert_allclose(world.x[blocks][:, :2], start[:, :2], atol=1e-6)
    np.testing.assert_allclose(world.x[blocks][:, 2], start[:, 2], atol=1e-5)
    sim.step(int(round(3.0 / scene.dt)) - sim.step_index)
    moved = np.linalg.norm(world.x[blocks][:, :2] - start[:, :2], axis=1)
    assert np.all(moved > 0.5) and np.allclose(world.x[blocks][:, 2], 0.05, atol=2e-4)
    assert 0.8 < sim.joint_readings()["rate"][0] < 1.15


def test_usd_catapult_throws_the_ball_and_the_hammer_breaks_the_stack():
    """examples/usd_catapult.toml (the stage examples/usd/catapult.usda: Y up, centimetres): the
    crate's fall throws the 1 kg ball up: its apex 2.3-2.7 m (measured 2.51 m; the plank's tip
    speed at the stop, sqrt(2 g h) = 6.9 m/s, sets it); the hammer's head sweeps the stack's two
    upper crates more than 1 m away while the bottom one stays within 0.3 m; the plank ends
    tilted with one end on the ground (asin(0.3 / 1.5) = 11.5 deg, within 1 deg: inside its 20
    deg limit; the crate slides off its low end and the ball, landing back on it, tips it the
    other way)."""
    scene = load_scene(EXAMPLES / "usd_catapult.toml")
    world = scene.world
    idx = {n: k for k, n in enumerate(world.names)}
    ball, plank = idx["World/ball"], idx["World/plank"]
    crates = [idx[f"World/stack/crate{k}"] for k in range(3)]
    start = world.x[crates].copy()
    np.testing.assert_allclose(world.x[ball], [-1.35, 0.0, 0.46], atol=1e-9)  # (x, y, z) of the stage -> (x, -z, y) / 100
    sim = tb.Simulator(world, dt=scene.dt)
    apex = 0.0
    for _ in range(int(round(1.5 / scene.dt))):
        sim.step(1)
        apex = max(apex, world.x[ball][2])
    assert 2.3 < apex < 2.7
    sim.step(int(round(2.5 / scene.dt)))
    moved = np.linalg.norm(world.x[crates] - start, axis=1)
    assert moved[1] > 1.0 and moved[2] > 1.0 and moved[0] < 0.3
    x_axis = world.R[plank][:, 0]
    tilt = np.degrees(np.arcsin(x_axis[2]))
    assert abs(tilt) == pytest.approx(np.degrees(np.arcsin(0.3 / 1.5)), abs=1.0)
