"""A hinge's or slider's drive target velocity (``target_velocity``: the rate its damping pulls to,
so the drive is -stiffness (q - target) - damping (q' - target_velocity), capped whole by
``max_drive_torque``): PyBullet's POSITION_CONTROL targetVelocity, UsdPhysics' drive
targetVelocity, and with stiffness 0 MuJoCo's velocity actuator with a forcerange (the MJCF side
against MuJoCo itself in ``test_mjcf_passive_and_actuators.py``). Compared here with the closed
forms of I q'' = -K (q - t) - C (q' - w) (+ the passive pair), exact by the matrix exponential."""

import math

import numpy as np
import pytest
from scipy.linalg import expm

import tumble as tb
from tumble import checks
from tumble.errors import InputError
from tumble.joints import DistanceJoint, HingeJoint, SliderJoint
from tumble.scene import parse_scene
from tumble.solver.joints import ACCURATE

I_WHEEL = 0.5 * 2.0 * 0.1 ** 2  # kg m^2: a 2 kg cylinder of radius 0.1 m about its axis


def wheel(dt=1 / 240, **joint):
    """A wheel on a vertical hinge to the world (no gravity torque about it); (Simulator, record)."""
    w = tb.World(gravity=(0.0, 0.0, -9.81))
    w.sleeping = False
    body = w.add_body(tb.Cylinder(0.1, 0.05), mass=2.0, position=(0.0, 0.0, 1.0))
    record = w.add_joint(HingeJoint("world", body, anchor=(0.0, 0.0, 1.0), axis=(0.0, 0.0, 1.0), **joint))
    return tb.Simulator(w, dt=dt, joint_settings=ACCURATE), record


def angle_and_rate(sim, seconds):
    """(times (n,), (q, q') (n, 2)) every 1/24 s."""
    steps = round(1 / (24 * sim.dt))
    times, out = [], []
    for k in range(round(seconds * 24)):
        sim.step(steps)
        r = sim.joint_readings()
        times.append((k + 1) / 24)
        out.append((r["position"][0], r["rate"][0]))
    return np.array(times), np.array(out)


def closed_form(times, K, C, F):
    """(q, q') (n, 2) of I q'' = -K q - C q' + F from rest at 0 (matrix exponential: exact)."""
    M = np.array([[0.0, 1.0, 0.0], [-K / I_WHEEL, -C / I_WHEEL, F / I_WHEEL], [0.0, 0.0, 0.0]])
    return np.array([(expm(M * t) @ np.array([0.0, 0.0, 1.0]))[:2] for t in times])


def test_a_velocity_drive_spins_a_flywheel_up_as_the_closed_form_at_first_order():
    """Damping C = 0.05 N m s towards w = 10 rad/s, no stiffness (a velocity servo): q' = w (1 -
    exp(-C t / I)), time constant 0.2 s. The implicit damper is first order: the largest rate error
    over 2 s measured 0.0096 rad/s at dt 1/240 and 0.0024 at 1/960 (ratio 4.0 for h / 4), the angle's
    0.0019 and 0.00048 rad; tolerances 0.02 and 0.005 rad/s, the ratio between 3 and 5, the angle
    0.001 rad at 1/960. Before, no drive had a target rate: a damper alone keeps the wheel at rest."""
    errors = []
    for dt in (1 / 240, 1 / 960):
        sim, _ = wheel(dt=dt, damping=0.05, target_velocity=10.0)
        times, got = angle_and_rate(sim, 2.0)
        ref = closed_form(times, 0.0, 0.05, 0.05 * 10.0)
        errors.append(np.abs(got - ref).max(axis=0))
    assert errors[0][1] < 0.02 and errors[1][1] < 0.005
    assert 3.0 < errors[0][1] / errors[1][1] < 5.0
    assert errors[1][0] < 0.001  # the angle, rad (integral of the rate's first-order error)


def test_at_its_cap_a_velocity_drive_gives_the_cap_exactly_until_its_law_asks_less():
    """Cap L = 0.02 N m: C (w - q') = 0.5 N m > L until q' = w - L / C = 9.6 rad/s, so for 2 s the
    drive gives L whole and q' = L t / I = 2 t: each substep's impulse is L h exactly (measured
    1.3e-13 rad/s; tolerance 1e-11). After it the law takes over and the rate settles at w
    (measured 1.7e-13 rad/s off after 12 s; tolerance 1e-6: exp(-C 7 / I) = 6e-16 of the gap left
    at saturation's end, 4.8 s)."""
    sim, _ = wheel(damping=0.05, target_velocity=10.0, max_drive_torque=0.02)
    times, got = angle_and_rate(sim, 2.0)
    np.testing.assert_allclose(got[:, 1], 0.02 / I_WHEEL * times, rtol=0, atol=1e-11)
    sim.step(240 * 10)
    assert sim.joint_readings()["rate"][0] == pytest.approx(10.0, abs=1e-6)


def test_a_pd_drive_with_a_target_velocity_and_a_passive_pair_follow_their_closed_form():
    """Stiffness K = 2 to target 0.5 rad, damping C = 0.1 towards w = 3 rad/s: I q'' = -K (q - 0.5)
    - C (q' - 3), resting at q = 0.5 + C w / K = 0.65 rad (the spring holds the damper's pull).
    With a passive spring kp = 0.5 (to springref -1) and damper cp = 0.04 beside it (the drive and
    passive row, ``_drive_and_passive``): I q'' = -K (q - 0.5) - C (q' - 3) - kp (q + 1) - cp q'.
    Largest errors over 3 s at dt 1/240: 0.011 / 0.0049 rad and 0.126 / 0.054 rad/s (without /
    with the passive pair; at 1/960 0.0028 / 0.0012 rad, 0.032 / 0.014 rad/s: first order, the
    implicit step in a 5.7 rad/s swing); tolerances 0.02 rad and 0.2 rad/s. The rest angle to
    1e-9 rad after 30 s (measured 9e-16; the transient decays as exp(-C t / 2I) = exp(-150))."""
    for passive in ({}, {"passive_stiffness": 0.5, "passive_damping": 0.04, "springref": -1.0}):
        sim, _ = wheel(stiffness=2.0, damping=0.1, target=0.5, target_velocity=3.0, **passive)
        times, got = angle_and_rate(sim, 3.0)
        kp, cp = passive.get("passive_stiffness", 0.0), passive.get("passive_damping", 0.0)
        ref = closed_form(times, 2.0 + kp, 0.1 + cp, 2.0 * 0.5 + 0.1 * 3.0 - kp * 1.0)
        assert np.abs(got[:, 0] - ref[:, 0]).max() < 0.02
        assert np.abs(got[:, 1] - ref[:, 1]).max() < 0.2
        if not passive:
            sim.step(240 * 27)
            assert sim.joint_readings()["position"][0] == pytest.approx(0.65, abs=1e-9)


def test_a_slider_drive_takes_a_target_velocity_too():
    """A 1 kg block on a horizontal slider (no gravity along it), damping 4 N s/m towards 0.5 m/s:
    x' = 0.5 (1 - exp(-4 t)); at 2 s 0.5 (1 - exp(-8)) = 0.49983 m/s (first order: measured 2.8e-6
    m/s off at dt 1/240, the transient nearly gone; tolerance 1e-4)."""
    w = tb.World(gravity=(0.0, 0.0, -9.81))
    w.sleeping = False
    block = w.add_body(tb.Box(size=(0.1, 0.1, 0.1)), mass=1.0, position=(0.0, 0.0, 1.0))
    w.add_joint(SliderJoint("world", block, anchor=(0.0, 0.0, 1.0), axis=(1.0, 0.0, 0.0), damping=4.0,
                            target_velocity=0.5))
    sim = tb.Simulator(w, dt=1 / 240, joint_settings=ACCURATE)
    sim.step(480)
    assert sim.joint_readings()["rate"][0] == pytest.approx(0.5 * (1.0 - math.exp(-8.0)), abs=1e-4)


def test_set_joint_target_moves_the_target_velocity_and_a_scene_file_gives_it():
    """``sim.set_joint_target(joint, target, velocity)`` before the first step gives the bits of a
    joint made with that target velocity; mid-run it takes effect from the next step; a scene's
    ``target_velocity_deg`` is the field in rad/s; a distance joint's drive refuses a velocity in
    one keyed line; a checkpoint carries the field and the column."""
    made, _ = wheel(damping=0.05, target_velocity=4.0)
    moved, record = wheel(damping=0.05)
    moved.set_joint_target(record, 0.0, velocity=4.0)
    made.step(120)
    moved.step(120)
    assert checks.state_hash(made.world) == checks.state_hash(moved.world)
    assert record.target_velocity == 4.0
    moved.set_joint_target(record, 0.0, velocity=-4.0)
    moved.step(240 * 3)
    assert moved.joint_readings()["rate"][0] == pytest.approx(-4.0, abs=1e-4)

    scene = {"simulation": {"gravity": [0, 0, 0]},
             "bodies": [{"name": "w", "shape": {"type": "sphere", "radius": 0.1}, "mass": 1.0}],
             "joints": [{"type": "hinge", "body_a": "w", "axis": [0, 0, 1], "damping": 1.0,
                         "target_velocity_deg": 90.0}]}
    assert parse_scene(scene).world.joints[0].target_velocity == math.radians(90.0)

    w = tb.World()
    a = w.add_body(tb.Sphere(0.1), mass=1.0)
    b = w.add_body(tb.Sphere(0.1), mass=1.0, position=(1.0, 0.0, 0.0))
    rod = w.add_joint(DistanceJoint(a, b, anchor_b=(1.0, 0.0, 0.0), stiffness=10.0))
    with pytest.raises(InputError, match="target_velocity: a distance joint's drive takes no target velocity"):
        tb.Simulator(w).set_joint_target(rod, 1.0, velocity=1.0)


def test_a_checkpoint_carries_the_target_velocity_and_older_rows_get_none(tmp_path):
    """Saved mid-spin and resumed: the same bits as the whole run. A checkpoint of a version before
    the column (34 of them) loads with a target velocity of 0 (what its drives did)."""
    def start():
        sim, _ = wheel(damping=0.05, target_velocity=10.0, max_drive_torque=0.02)
        sim.step(100)
        return sim

    whole, first = start(), start()
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    whole.step(240)
    resumed.step(240)
    assert checks.state_hash(resumed.world) == checks.state_hash(whole.world)

    from tumble.checkpoint import _pad_param
    from tumble.joints import P_TARGET_RATE, PARAM_COUNT

    old = np.arange(34.0)[None, :]
    padded = _pad_param(old)
    assert padded.shape == (1, PARAM_COUNT)
    np.testing.assert_array_equal(padded[0, :34], old[0])
    assert padded[0, P_TARGET_RATE] == 0.0
