"""Coulomb's sliding friction opposes the slip, in every direction, and through the whole impact.

Two laws the rest of the suite never saw broken, because its bodies slid along the contact
solver's tangent directions (fixed in the world: the incline tests' downhill, launches along x)
and its oblique bounce stuck within the compression (mu = 1):

- A body sliding on a plane feels mu m g against its velocity whatever the direction it slides
  in: it slows at mu g along a straight line. The solver's two tangent rows have different
  effective masses at a box's corner; the radial clamp of their impulses to the friction disc
  pointed the friction along diag(m1, m2) slip instead (``friction_impulses_after``).
- Over an impact with restitution e, Coulomb's friction impulse can reach mu times the whole
  normal impulse, (1 + e) times the compression's (Newton's impact law with Coulomb friction).

Each test fails on the code before (figures in each docstring)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tumble as tb
from tumble.joints import FixedJoint
from tumble.solver.joints import ACCURATE

G = 9.81
MU = 0.3


def _sliding_box(direction_deg: float, dt: float = 1 / 240):
    """A 0.4 x 0.2 x 0.1 m box of 1 kg, axis-aligned, launched at 2 m/s along ``direction_deg``
    from the world's x on a level plane, mu 0.3, no restitution: (trajectory over 0.5 s at 120
    frames a second, the box's row)."""
    w = tb.World(gravity=(0.0, 0.0, -G))
    material = tb.Material(friction=MU, restitution=0.0)
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, material=material)
    phi = math.radians(direction_deg)
    w.add_body(tb.Box((0.4, 0.2, 0.1)), mass=1.0, position=(0, 0, 0.05),
               velocity=(2.0 * math.cos(phi), 2.0 * math.sin(phi), 0.0), material=material)
    return tb.Simulator(w, dt=dt).run(0.5, frame_rate=120)


@pytest.mark.parametrize("direction_deg", [0.0, 30.0, 45.0, 60.0, 135.0])
def test_a_box_sliding_in_any_direction_slows_at_mu_g_in_a_straight_line(direction_deg):
    """Against the analytic slide: speed 2 - mu g t along the launch direction, no turn about the
    vertical. Every frame from 0.05 s (the soft contact's sag settled) to 0.5 s (the box stops at
    0.68 s): speed to 1e-5 m/s, heading to 1e-5 rad, yaw rate under 1e-4 rad/s (measured at most
    8.8e-7 m/s, 5.3e-7 rad and 8.4e-6 rad/s, in every direction alike, 0 degrees included: the
    soft contacts' sag as the box starts to slide rocks it slightly). Before: launched at 30 and 45 degrees, the box veered to 53 and 70 degrees and
    slowed 5.6 and 7.4 % less than mu g, at dt 1/240 and 1/960 alike."""
    traj = _sliding_box(direction_deg)
    late = traj.time > 0.05
    v = traj.velocity[late, 1]
    t = traj.time[late]
    speed = np.linalg.norm(v[:, :2], axis=1)
    np.testing.assert_allclose(speed, 2.0 - MU * G * t, atol=1e-5)
    heading = np.arctan2(v[:, 1], v[:, 0])
    expected = math.radians(direction_deg)
    assert np.max(np.abs(np.angle(np.exp(1j * (heading - expected))))) < 1e-5
    assert np.max(np.abs(traj.angular_velocity[late, 1, 2])) < 1e-4


@pytest.mark.parametrize("downhill_deg", [20.0, 45.0])
def test_a_block_slides_straight_down_an_incline_whose_slope_lies_between_the_tangents(downhill_deg):
    """A 0.3 x 0.2 x 0.1 m block on a 30 degree plane whose downhill direction lies at
    ``downhill_deg`` from the world's x in plan: it slides with a = g (sin 30 - mu cos 30) (2.3563
    m/s^2 at mu 0.3) straight down the slope. Acceleration from a line through the speeds after
    0.1 s to 1e-6 relative (measured 7.3e-8), sideways speed under 1e-4 m/s (measured 5.3e-6 m/s at
    0.1 s, decaying: the start's sag, as above). Before: +2.1 % at
    20 degrees (and 0.19 m/s sideways after 1 s), +7.9 % at 45 degrees."""
    theta = math.radians(30.0)
    psi = math.radians(downhill_deg)
    down = np.array([math.cos(theta) * math.cos(psi), math.cos(theta) * math.sin(psi), -math.sin(theta)])
    normal = np.array([math.sin(theta) * math.cos(psi), math.sin(theta) * math.sin(psi), math.cos(theta)])
    side = np.cross(normal, down)
    w = tb.World(gravity=(0.0, 0.0, -G))
    material = tb.Material(friction=MU, restitution=0.0)
    w.add_body(tb.Plane(normal=tuple(normal)), fixed=True, material=material)
    # the block's axes: x down the slope, z along the normal
    q = Rotation.from_matrix(np.column_stack([down, side, normal])).as_quat(scalar_first=True)
    w.add_body(tb.Box((0.3, 0.2, 0.1)), mass=1.0, position=tuple(0.05 * normal), orientation=q, material=material)
    traj = tb.Simulator(w, dt=1 / 240).run(1.0, frame_rate=120)
    late = traj.time > 0.1
    v = traj.velocity[late, 1]
    a = np.polyfit(traj.time[late], v @ down, 1)[0]
    expected = G * (math.sin(theta) - MU * math.cos(theta))
    assert abs(a - expected) < 1e-6 * expected, (a, expected)
    assert np.max(np.abs(v @ side)) < 1e-4


R_BALL = 0.1


def _expected_bounce(e: float, mu: float, vx: float = 2.0, vz: float = 3.0):
    """A uniform ball (I = 2/5 m r^2) striking a plane at vz down and vx along it, no spin: (vx',
    omega_y') after a rigid impact with Newton's restitution e and Coulomb friction mu over the
    whole impact, normal impulse (1 + e) m vz. Sliding throughout when the friction it can have,
    mu (1 + e) m vz, is less than the 2/7 m vx that brings it to rolling."""
    jn = (1.0 + e) * vz
    if mu * jn < 2.0 / 7.0 * vx:
        return vx - mu * jn, 2.5 * mu * jn / R_BALL
    return 5.0 / 7.0 * vx, 5.0 / 7.0 * vx / R_BALL


@pytest.mark.parametrize("e, mu", [(0.5, 0.1), (0.9, 0.05), (1.0, 0.1), (0.5, 1.0)])
@pytest.mark.parametrize("dt", [1 / 240, 1 / 60])
def test_an_oblique_bounce_has_coulomb_friction_over_the_whole_impact(e, mu, dt):
    """A ball (r 0.1 m, 1 kg) meets the floor at 3 m/s down and 2 m/s across, no gravity, no spin:
    it leaves at e 3 m/s up with the tangential speed and spin of ``_expected_bounce``, to 1e-9
    (round-off; measured 1e-15), at the default step and Box3D's 1/60 s. (e, mu) = (0.5, 0.1) and
    (0.9, 0.05) slide throughout, (1, 0.1) just reaches rolling in the restitution phase, (0.5, 1)
    within the compression (the case the suite had). Before: 1.70 m/s and 7.5 rad/s against 1.55
    and 11.25 at (0.5, 0.1); at (1, 0.1) 1.70 m/s still slipping against 1.4286 rolling."""
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    material = tb.Material(friction=mu, restitution=e)
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, material=material)
    ball = w.add_body(tb.Sphere(R_BALL), mass=1.0, position=(0, 0, R_BALL + 0.05), velocity=(2.0, 0, -3.0),
                      material=material)
    tb.Simulator(w, dt=dt).run(0.25, frame_rate=12)
    vx, wy = _expected_bounce(e, mu)
    assert abs(ball.v[0] - vx) < 1e-9, (ball.v, vx)
    assert abs(ball.v[2] - 3.0 * e) < 1e-9, ball.v
    assert abs(ball.omega[1] - wy) < 1e-9 / R_BALL, (ball.omega, wy)
    assert abs(ball.v[1]) < 1e-12 and abs(ball.omega[0]) < 1e-12 and abs(ball.omega[2]) < 1e-12


@pytest.mark.parametrize("e, mu", [(0.5, 0.1), (1.0, 0.1)])
def test_an_oblique_bounce_of_a_jointed_body_has_coulomb_friction_over_the_whole_impact(e, mu):
    """The same bounce through the joint tree (``contact_tree.restitution_tree_kernel``): the ball
    welded at its centre to a second ball of the same size and mass that touches nothing, the tree
    method (ACCURATE). The pair is one uniform ball of 2 kg (I = 2/5 M r^2): the same (vx',
    omega'), mass aside, to 1e-9 (round-off; measured 2e-16).
    Before: 1.70 m/s against 1.55 at (0.5, 0.1)."""
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    material = tb.Material(friction=mu, restitution=e)
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, material=material)
    start = (0.0, 0.0, R_BALL + 0.05)
    ball = w.add_body(tb.Sphere(R_BALL), mass=1.0, position=start, velocity=(2.0, 0, -3.0), material=material)
    partner = w.add_body(tb.Sphere(R_BALL), mass=1.0, position=start, velocity=(2.0, 0, -3.0),
                         collision_filter=tb.CollisionFilter(category=0, mask=0))
    w.add_joint(FixedJoint(ball, partner, anchor=start))
    sim = tb.Simulator(w, dt=1 / 240, joint_settings=ACCURATE)
    through_tree = False
    for _ in range(60):  # the impact's steps: its contact goes through the tree
        sim.step(1)
        tree = sim.soft_step.tree_contacts
        through_tree |= tree is not None and len(tree.contacts) > 0
    assert through_tree
    sim.run(0.25, frame_rate=12)
    vx, wy = _expected_bounce(e, mu)
    for body in (ball, partner):
        assert abs(body.v[0] - vx) < 1e-9, (body.v, vx)
        assert abs(body.v[2] - 3.0 * e) < 1e-9, body.v
        assert abs(body.omega[1] - wy) < 1e-9 / R_BALL, (body.omega, wy)


def test_the_sliding_friction_solve_is_coulombs_and_finite_at_its_edges():
    """``friction_impulses_after`` alone, against Coulomb's law for the contact's own 2 x 2 problem
    with diagonal masses: a sticking impulse inside the disc stops the slip; a sliding one lies on
    the disc's edge (1e-12 relative; measured 4e-16) opposite the slip it leaves, s' = slip + (new
    - old) / mass (cross product under 1e-8 of the norms' product, measured 7e-10: s' loses digits
    where the masses are 1e6 apart; dot product negative), over 2000 random cases with masses from
    1e-3 to 1e3 kg. A tree row of no response (mass 0) whose old impulse alone passes the
    disc has no such point: the impulse is the radial clamp's, finite (before the guard a zero
    derivative made it NaN)."""
    from tumble.solver.contact_solve import friction_impulses_after

    rng = np.random.default_rng(7)
    for _ in range(2000):
        old = rng.normal(size=2) * 10 ** rng.uniform(-2, 2)
        mass = 10 ** rng.uniform(-3, 3, 2)
        slip = rng.normal(size=2) * 10 ** rng.uniform(-3, 1)
        limit = float(10 ** rng.uniform(-3, 2))
        new = np.array(friction_impulses_after(old[0], old[1], mass[0], mass[1], slip[0], slip[1], limit))
        trial = old - mass * slip
        if np.linalg.norm(trial) <= limit:
            np.testing.assert_array_equal(new, trial)
            continue
        after = slip + (new - old) / mass
        assert abs(np.linalg.norm(new) - limit) <= 1e-12 * limit
        assert abs(new[0] * after[1] - new[1] * after[0]) <= 1e-8 * limit * np.linalg.norm(after) + 1e-300
        assert new @ after <= 0.0
    held = friction_impulses_after(0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    assert np.all(np.isfinite(held)) and abs(np.hypot(*held) - 1.0) < 1e-12
