"""A hinge's or slider's passive spring and damper (``passive_stiffness``, ``passive_damping`` to
``springref``: MuJoCo's joint stiffness, damping and springref), acting beside the drive and
never held by its cap (``max_drive_torque``): MuJoCo caps an actuator's force alone, and its
joint's passive forces act on (``joint_solve._drive_and_passive``; the MJCF side is tested in
``test_mjcf_passive_and_actuators.py`` against MuJoCo itself)."""

import math

import numpy as np
import pytest
from scipy.linalg import expm

import tumble as tb
from tumble import checks
from tumble.errors import InputError
from tumble.joints import HingeJoint, SliderJoint
from tumble.scene import parse_scene
from tumble.solver.joints import ACCURATE

DT = 1 / 240
I_WHEEL = 0.5 * 2.0 * 0.1 ** 2  # kg m^2: a 2 kg cylinder of radius 0.1 m about its axis
CAP = 0.5  # N m, the drive's cap
KP, CP = 0.05, 0.02  # N m/rad, N m s/rad: the passive spring (to springref 0) and damper


def wheel(**joint):
    """A wheel on a vertical hinge to the world (no gravity torque about it), the joint's fields
    ``joint``; (Simulator, the joint record)."""
    w = tb.World(gravity=(0.0, 0.0, -9.81))
    w.sleeping = False
    body = w.add_body(tb.Cylinder(0.1, 0.05), mass=2.0, position=(0.0, 0.0, 1.0))
    record = w.add_joint(HingeJoint("world", body, anchor=(0.0, 0.0, 1.0), axis=(0.0, 0.0, 1.0), **joint))
    return tb.Simulator(w, dt=DT, joint_settings=ACCURATE), record


def angle_and_rate(sim, seconds):
    """(times (n,), (q, q') (n, 2)) every 1/24 s."""
    times, out = [], []
    for k in range(round(seconds * 24)):
        sim.step(10)
        r = sim.joint_readings()
        times.append((k + 1) / 24)
        out.append((r["position"][0], r["rate"][0]))
    return np.array(times), np.array(out)


def closed_form(times, K, C, F):
    """(q, q') (n, 2) of I q'' = -K q - C q' + F from rest at 0: the state equation's matrix
    exponential (exact)."""
    M = np.array([[0.0, 1.0, 0.0], [-K / I_WHEEL, -C / I_WHEEL, F / I_WHEEL], [0.0, 0.0, 0.0]])
    return np.array([(expm(M * t) @ np.array([0.0, 0.0, 1.0]))[:2] for t in times])


def test_a_drive_saturated_at_its_cap_leaves_the_passive_spring_and_damper_whole():
    """The drive pulls to 100 rad (stiffness 1000: saturated at CAP for the whole run) and the
    joint's passive spring and damper act beside it: I q'' = CAP - KP q - CP q', the closed form
    (a damped swing to CAP / KP = 10 rad; damping ratio 0.45). If the cap held the passive terms
    too (one capped row: the MJCF reader's sum before session 43) the wheel would see CAP alone:
    with the passive terms left off it has turned 199.6 rad at 4 s, where the closed form has
    9.9. Measured at dt 1/240: 0.022 rad and 0.035 rad/s at most over 4 s (0.0056 and 0.0089 at
    1/960: first order, the implicit damper's). Tolerances 0.05 rad and 0.07 rad/s."""
    sim, _ = wheel(stiffness=1000.0, target=100.0, max_drive_torque=CAP, passive_stiffness=KP, passive_damping=CP)
    times, got = angle_and_rate(sim, 4.0)
    ref = closed_form(times, KP, CP, CAP)
    assert np.abs(got[:, 0] - ref[:, 0]).max() < 0.05
    assert np.abs(got[:, 1] - ref[:, 1]).max() < 0.07


def test_below_its_cap_the_drive_and_the_passive_terms_are_one_spring_damper():
    """Unsaturated, the two laws sum (both are implicit and linear in q, q'): the same motion as
    one drive of stiffness k + kp, damping c + cp to the stiffness-weighted target, to rounding
    (measured 5e-15 over 2 s; tolerance 1e-12), and the closed form's to first order: 0.0091 rad and
    0.10 rad/s at dt 1/240 (0.0023, 0.026 at 1/960; the swing at 16 rad/s is stiff for the implicit
    step), tolerances 0.02 rad and 0.2 rad/s."""
    sim, _ = wheel(stiffness=2.0, damping=0.1, target=1.0, max_drive_torque=100.0,
                   passive_stiffness=0.5, passive_damping=0.04, springref=-1.0)
    one, _ = wheel(stiffness=2.5, damping=0.14, target=(2.0 - 0.5) / 2.5, max_drive_torque=100.0)
    times, got = angle_and_rate(sim, 2.0)
    _, same = angle_and_rate(one, 2.0)
    assert np.abs(got - same).max() < 1e-12
    closed = closed_form(times, 2.5, 0.14, 1.5)
    assert np.abs(got[:, 0] - closed[:, 0]).max() < 0.02 and np.abs(got[:, 1] - closed[:, 1]).max() < 0.2


def test_a_sliders_passive_spring_holds_it_under_gravity_and_stores_its_energy():
    """A 1 kg block on a vertical slider with a passive spring of 200 N/m to springref 0.1 m and a
    passive damper: it settles where k (springref - q) = m g, q = 0.1 - 9.81 / 200 (to 1e-9 m: the
    damped transient is gone by 5 s, exp(-25)), and ``World.potential_energy`` holds the spring's
    1/2 k (q - springref)^2 besides gravity's (to 1e-9 J)."""
    w = tb.World(gravity=(0.0, 0.0, -9.81))
    w.sleeping = False
    block = w.add_body(tb.Box(size=(0.1, 0.1, 0.1)), mass=1.0, position=(0.0, 0.0, 1.0))
    w.add_joint(SliderJoint("world", block, anchor=(0.0, 0.0, 1.0), axis=(0.0, 0.0, 1.0), passive_stiffness=200.0,
                            passive_damping=10.0, springref=0.1))
    sim = tb.Simulator(w, dt=DT, joint_settings=ACCURATE)
    sim.step(5 * 240)
    q = sim.joint_readings()["position"][0]
    assert q == pytest.approx(0.1 - 9.81 / 200.0, abs=1e-9)
    gravity = 1.0 * 9.81 * w.x[0, 2]
    assert w.potential_energy() == pytest.approx(gravity + 0.5 * 200.0 * (q - 0.1) ** 2, abs=1e-9)


def test_the_passive_fields_in_a_scene_file_and_their_bad_values(tmp_path):
    """A scene's hinge takes ``passive_stiffness``, ``passive_damping`` and ``springref`` (or
    ``springref_deg``), as the constructor; a negative one is one keyed line."""
    def scene(**joint):
        return {"simulation": {"gravity": [0, 0, 0]},
                "bodies": [{"name": "w", "shape": {"type": "sphere", "radius": 0.1}, "mass": 1.0}],
                "joints": [{"type": "hinge", "body_a": "w", "axis": [0, 0, 1], **joint}]}

    made = parse_scene(scene(passive_stiffness=3.0, passive_damping=0.2, springref_deg=90.0)).world.joints[0]
    assert (made.passive_stiffness, made.passive_damping, made.springref) == (3.0, 0.2, math.radians(90.0))
    with pytest.raises(InputError, match=r"joints\[0\]\.passive_damping: must be >= 0"):
        parse_scene(scene(passive_damping=-1.0), file="s.toml")


def test_a_checkpoint_carries_the_passive_columns_and_an_older_ones_rows_get_none(tmp_path):
    """Saved mid-swing and resumed: the same bits as the whole run. A checkpoint of a version before
    the passive columns (31 of them) loads with none (zeros: no passive spring or damper)."""
    def start():
        sim, _ = wheel(stiffness=1000.0, target=100.0, max_drive_torque=CAP, passive_stiffness=KP,
                       passive_damping=CP)
        sim.step(100)
        return sim

    whole, first = start(), start()
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    whole.step(240)
    resumed.step(240)
    assert checks.state_hash(resumed.world) == checks.state_hash(whole.world)

    from tumble.checkpoint import _pad_param
    from tumble.joints import P_PASSIVE_DAMPING, P_PASSIVE_STIFFNESS, P_SPRINGREF, PARAM_COUNT

    old = np.arange(31.0)[None, :]
    padded = _pad_param(old)
    assert padded.shape == (1, PARAM_COUNT)
    np.testing.assert_array_equal(padded[0, :31], old[0])
    assert padded[0, P_PASSIVE_STIFFNESS] == padded[0, P_PASSIVE_DAMPING] == padded[0, P_SPRINGREF] == 0.0
