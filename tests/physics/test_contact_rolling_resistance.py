"""Rolling resistance and spinning friction (``solver.contact_rolling``) against the textbook.

A body of radius r and I = k m r^2 rolling without slip on a plane, braked by a torque
c r N (N = m g): m a = -f, I a / r = f r - c r N, so a = -c g / (1 + k): a ball (k = 2/5)
slows at 5/7 c g and stops after v0 (1 + k) / (c g) s and v0^2 (1 + k) / (2 c g) m. On a slope
theta it rolls down at g (sin - c cos) / (1 + k), and stays when c >= tan theta (and mu does).
A ball spinning about the normal, braked by s N: d omega / dt = -s g / (k r^2).

The rows carry their impulses from substep to substep (warm start), so the decelerations are
those of the formulas to round-off: the tolerances are 1e-9 relative. The stopping distance
is compared within 2 mm: the soft step moves positions after each velocity kick
(semi-implicit), which lags x by a h t / 2 under a constant deceleration a, 1.0 mm over the
5.7 s here at h = 1/960 s (not a rolling error; the speeds are exact).
"""

import numpy as np
import pytest

import tumble as tb
from tumble.checks import state_hash

from .solutions import resumed_run

G = 9.81
DT = 1.0 / 240.0
R = 0.1


def _on_plane(shape, material, velocity=(0.0, 0.0, 0.0), angular_velocity=(0.0, 0.0, 0.0), gravity=(0, 0, -G),
              euler_deg=(0, 0, 0), height=R):
    w = tb.World(gravity=gravity)
    w.add_body(tb.Plane(), fixed=True, name="ground")
    body = w.add_body(shape, mass=1.0, position=(0, 0, height), euler_deg=euler_deg, velocity=velocity,
                      angular_velocity=angular_velocity, material=material, name="body")
    return w, body


def _k(body, axis):
    """I about the rolling axis (world ``axis``) / (m r^2)."""
    a = np.asarray(axis, dtype=float)
    I_world = body.R @ body.inertia_body @ body.R.T
    return float(a @ I_world @ a) / (body.mass * R * R)


@pytest.mark.parametrize("shape, euler", [(tb.Sphere(R), (0, 0, 0)), (tb.Cylinder(R, 0.4), (90, 0, 0)),
                                          (tb.Capsule(R, 0.4), (90, 0, 0))], ids=["ball", "cylinder", "capsule"])
def test_rolling_body_slows_at_c_g_over_1_plus_k(shape, euler):
    c, v0 = 0.05, 2.0
    w, body = _on_plane(shape, tb.Material(friction=0.5, rolling_resistance=c), velocity=(v0, 0, 0),
                        angular_velocity=(0, v0 / R, 0), euler_deg=euler)
    k = _k(body, (0, 1, 0))
    a = c * G / (1 + k)
    sim = tb.Simulator(w, dt=DT)
    for step in range(1, 9):
        sim.run(0.25)
        t = 0.25 * step
        assert body.v[0] == pytest.approx(v0 - a * t, rel=1e-9, abs=0)
        assert body.omega[1] * R == pytest.approx(body.v[0], rel=1e-9, abs=0)  # still rolling, no slip


def test_without_rolling_resistance_the_same_ball_rolls_on():
    """The control: c = 0 leaves the rolling speed as it was (so the slowing above is the rows')."""
    w, body = _on_plane(tb.Sphere(R), tb.Material(friction=0.5), velocity=(2, 0, 0), angular_velocity=(0, 20, 0))
    tb.Simulator(w, dt=DT).run(2.0)
    assert abs(body.v[0] - 2.0) < 1e-12


def test_ball_stops_where_and_when_the_textbook_says_and_stays():
    c, v0 = 0.05, 2.0
    w, body = _on_plane(tb.Sphere(R), tb.Material(friction=0.5, rolling_resistance=c), velocity=(v0, 0, 0),
                        angular_velocity=(0, v0 / R, 0))
    a = 5.0 / 7.0 * c * G
    t_stop = v0 / a
    sim = tb.Simulator(w, dt=DT)
    sim.run(round((t_stop - 0.1) * 24) / 24)
    assert body.v[0] == pytest.approx(a * (t_stop - w.t), rel=1e-9)  # still rolling, a frame or two before
    sim.run(round(0.25 * 24) / 24)
    assert abs(body.v[0]) < 1e-9 and abs(body.omega[1]) < 1e-9  # at rest 0.15 s after
    x_stop = body.x[0]
    assert abs(x_stop - v0 * v0 / (2 * a)) < 2e-3
    sim.run(2.0)
    assert body.x[0] == x_stop and np.linalg.norm(body.v) < 1e-9


@pytest.mark.parametrize("c, mu, rolls", [(0.1, 0.5, True), (0.7, 1.0, False)])
def test_ball_on_a_30_degree_slope_rolls_or_stays(c, mu, rolls):
    """Gravity tilted 30 degrees instead of the plane: the ball rolls down at
    g (sin - c cos) / (1 + 2/5) when c < tan 30 = 0.577, stays when c = 0.7 (mu = 1 holds it)."""
    th = np.radians(30.0)
    w, body = _on_plane(tb.Sphere(R), tb.Material(friction=mu, rolling_resistance=c),
                        gravity=(G * np.sin(th), 0, -G * np.cos(th)))
    sim = tb.Simulator(w, dt=DT)
    sim.run(1.0)
    v1 = body.v[0]
    x1 = body.x[0]
    sim.run(1.0)
    if rolls:
        assert body.v[0] - v1 == pytest.approx(G * (np.sin(th) - c * np.cos(th)) / 1.4, rel=1e-9)
    else:
        assert abs(body.x[0]) < 2e-5 and body.x[0] == x1  # settled in the first steps, then still
        assert np.linalg.norm(body.v) < 1e-9


def test_spinning_friction_brakes_a_spin_about_the_normal():
    s, w0 = 0.01, 20.0
    w, body = _on_plane(tb.Sphere(R), tb.Material(friction=0.5, spinning_friction=s), angular_velocity=(0, 0, w0))
    alpha = s * G / (0.4 * R * R)
    sim = tb.Simulator(w, dt=DT)
    for step in range(1, 5):
        sim.run(0.125)
        assert body.omega[2] == pytest.approx(w0 - alpha * 0.125 * step, rel=1e-9, abs=0)
    sim.run(0.5)  # it stops at w0 / alpha = 0.82 s
    assert abs(body.omega[2]) < 1e-9 and np.linalg.norm(body.v) < 1e-9
    # rolling resistance alone does not brake this spin, nor spinning friction a roll
    w, body = _on_plane(tb.Sphere(R), tb.Material(friction=0.5, rolling_resistance=0.5), angular_velocity=(0, 0, w0))
    tb.Simulator(w, dt=DT).run(0.5)
    assert body.omega[2] == pytest.approx(w0, rel=1e-12)


def test_materials_combine_by_the_larger_and_a_flat_face_does_not_roll():
    """The ground's rolling resistance brakes a plain ball as the ball's own does (max); a box
    sliding on a resisting ground is braked by friction alone (its faces have no radius)."""
    def run(ball_c, ground_c):
        w = tb.World(gravity=(0, 0, -G))
        w.add_body(tb.Plane(), fixed=True, material=tb.Material(rolling_resistance=ground_c))
        b = w.add_body(tb.Sphere(R), mass=1.0, position=(0, 0, R), velocity=(2, 0, 0), angular_velocity=(0, 20, 0),
                       material=tb.Material(rolling_resistance=ball_c))
        tb.Simulator(w, dt=DT).run(1.0)
        return b.v[0]
    assert run(0.05, 0.0) == run(0.0, 0.05) == run(0.05, 0.02)
    assert run(0.05, 0.0) == pytest.approx(2.0 - 5 / 7 * 0.05 * G, rel=1e-9)

    def slide(ground_c):
        w = tb.World(gravity=(0, 0, -G))
        w.add_body(tb.Plane(), fixed=True, material=tb.Material(rolling_resistance=ground_c))
        b = w.add_body(tb.Box((0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 0.1), velocity=(2, 0, 0))
        tb.Simulator(w, dt=DT).run(0.25)
        return b.v.copy(), b.omega.copy()
    with_c, without = slide(0.5), slide(0.0)
    assert np.array_equal(with_c[0], without[0]) and np.array_equal(with_c[1], without[1])


def test_rolling_run_resumes_bit_for_bit(tmp_path):
    """The rows' accumulated impulses are checkpointed with the contacts' warm start: a resumed
    ball on a slope held by rolling resistance continues to the same bits."""
    def scene():
        th = np.radians(20.0)
        w, _ = _on_plane(tb.Sphere(R), tb.Material(friction=1.0, rolling_resistance=0.3, spinning_friction=0.001),
                         gravity=(G * np.sin(th), 0, -G * np.cos(th)), velocity=(1, 0.5, 0),
                         angular_velocity=(-5, 10, 3))
        return w
    whole, resumed = resumed_run(scene, tmp_path, 1.0, DT)
    assert resumed.world.materials[1].rolling_resistance == 0.3
    assert np.any(resumed.soft_step.solver.warm_start_state()["rolling_impulse"] != 0.0)
    assert state_hash(resumed.world) == state_hash(whole.world)


def test_material_values_are_checked():
    with pytest.raises(tb.InputError, match="rolling_resistance: must be a finite number >= 0, got -1"):
        tb.Material(rolling_resistance=-1)
    with pytest.raises(tb.InputError, match="spinning_friction: must be a finite number >= 0, got inf"):
        tb.Material(spinning_friction=float("inf"))
    with pytest.raises(tb.InputError, match="material: unknown key 'rolling'"):
        tb.Material.coerce({"rolling": 1})
