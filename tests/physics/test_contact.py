"""Contact through the Simulator (issue 3 acceptance): bounces against h e^(2k), sliding against
the textbook incline, conservation in free collisions, resting impulse against m g, continuous
collision against a thin wall. Every run uses the Simulator's defaults (dt 1/240 s, rk4 in flight,
the soft step in contact) unless a test says otherwise.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import tumble as tb

G = 9.81


def ground_world(gravity=(0.0, 0.0, -G)):
    w = tb.World(gravity=gravity)
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground", material=tb.Material(friction=0.0))
    return w


# ---------------------------------------------------------------------- restitution
def test_bouncing_sphere_apexes_follow_h_e_2k():
    """Radius 0.5, its lowest point dropped from 2 m, e = 0.8, no friction. The apex of bounce k
    is h e^(2k) (each bounce returns e of the speed, so e^2 of the height). The apex is read from
    the highest recorded frame of each flight as z + vz^2 / 2g (exact on a parabola, and the flight
    away from the ground is the rk4 step, exact for constant gravity). Tolerance: the issue's 1 %.
    Measured (dt 1/240 s, 4 solver substeps): -0.001, -0.007, -0.02, -0.04, -0.07 %: the steps the
    ball spends within the speculative margin after each bounce are semi-implicit Euler, which
    loses g h^2 / 2 of height a substep."""
    h, e, r = 2.0, 0.8, 0.5
    w = ground_world()
    w.add_body(tb.Sphere(radius=r), mass=1.0, position=(0, 0, h + r), name="ball",
               material=tb.Material(friction=0.0, restitution=e))
    traj = tb.Simulator(w).run(6.0, frame_rate=240)
    z = traj.position[:, 1, 2] - r
    vz = traj.velocity[:, 1, 2]
    apex_estimate = z + np.where(vz > 0, vz * vz / (2 * G), 0.0)
    # flights start where vz turns from negative to positive (a bounce)
    bounces = np.flatnonzero((vz[:-1] < 0) & (vz[1:] > 0)) + 1
    assert len(bounces) >= 6
    for k in range(5):
        flight = slice(bounces[k], bounces[k + 1])
        apex = apex_estimate[flight].max()
        expected = h * e ** (2 * (k + 1))
        assert apex == pytest.approx(expected, rel=0.01), (k + 1, apex, expected)


def test_restitution_threshold_ends_bouncing_and_the_ball_rests():
    """Below 1 m/s (RESTITUTION_THRESHOLD) impacts are inelastic, so a bouncing ball comes to rest
    on the ground instead of chattering: after 10 s it lies at z = r within 1 mm, still."""
    w = ground_world()
    w.add_body(tb.Sphere(radius=0.5), mass=1.0, position=(0, 0, 2.5), name="ball",
               material=tb.Material(friction=0.0, restitution=0.8))
    sim = tb.Simulator(w)
    sim.run(10.0, frame_rate=4)
    assert abs(w.x[1, 2] - 0.5) < 1e-3
    assert np.linalg.norm(w.v[1]) < 1e-3


# ---------------------------------------------------------------------- friction
def incline_world(mu, angle_deg=30.0):
    """A 1 m cube on a fixed slab tilted by angle about y; the cube starts resting on it."""
    a = math.radians(angle_deg)
    w = tb.World(gravity=(0, 0, -G))
    q_tilt = (math.cos(a / 2), 0.0, math.sin(a / 2), 0.0)  # rotation by a about +y
    down_slope = np.array([-math.cos(a), 0.0, math.sin(a)])  # rotated +x is (cos a, 0, -sin a): downhill is +x'
    normal = np.array([math.sin(a), 0.0, math.cos(a)])
    w.add_body(tb.Box(size=(20, 4, 1)), fixed=True, name="slope", orientation=q_tilt,
               position=tuple(-0.5 * normal), material=tb.Material(friction=mu))
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, name="block", orientation=q_tilt,
               position=tuple(0.5 * normal), material=tb.Material(friction=mu))
    return w, -down_slope, normal


def test_block_slides_down_incline_at_the_coulomb_acceleration():
    """mu = 0.3 on 30 degrees: a = g (sin 30 - mu cos 30) along the slope (kinetic friction mu N,
    N = m g cos 30). Fitted from the velocity along the slope between 0.5 s and 2 s (constant
    acceleration: a straight line). Tolerance: the issue's 1 %."""
    mu = 0.3
    w, downhill, _ = incline_world(mu)
    traj = tb.Simulator(w).run(2.0, frame_rate=48)
    t = traj.time
    speed = traj.velocity[:, 1] @ downhill
    sel = t >= 0.5
    slope = np.polyfit(t[sel], speed[sel], 1)[0]
    expected = G * (math.sin(math.radians(30)) - mu * math.cos(math.radians(30)))
    assert slope == pytest.approx(expected, rel=0.01)


@pytest.mark.slow
def test_block_sticks_on_incline_when_friction_holds_it():
    """mu = 0.7 > tan 30 = 0.577: static friction holds; the block drifts under 1 mm in 5 s (issue)."""
    w, downhill, _ = incline_world(0.7)
    x0 = w.x[1].copy()
    tb.Simulator(w).run(5.0, frame_rate=4)
    assert np.linalg.norm(w.x[1] - x0) < 1e-3


# ---------------------------------------------------------------------- conservation
def total_momenta(w):
    m = w.moving
    P = w.P[m].sum(axis=0)
    L = (np.cross(w.x[m], w.P[m]) + w.L[m]).sum(axis=0)
    return P, L


def test_free_collision_conserves_linear_and_angular_momentum():
    """Two spinning boxes hit off-centre with friction and e = 0.5, no gravity. Contact impulses are
    equal and opposite at one point, so P and L about the origin are conserved up to round-off:
    1e-9 relative (issue)."""
    w = tb.World(gravity=(0, 0, 0))
    mat = tb.Material(friction=0.6, restitution=0.5)
    w.add_body(tb.Box(size=(1, 0.6, 0.4)), mass=2.0, position=(-1.0, 0.15, 0.1), velocity=(3, 0, 0),
               angular_velocity=(0.5, 1.0, 2.0), material=mat, name="a")
    w.add_body(tb.Box(size=(0.5, 0.8, 0.7)), mass=1.0, position=(1.0, -0.1, 0.0), velocity=(-2, 0.3, 0),
               angular_velocity=(-1.0, 0.2, 0.7), euler_deg=(10, 20, 30), material=mat, name="b")
    P0, L0 = total_momenta(w)
    sim = tb.Simulator(w)
    touched = 0
    for _ in range(240):
        sim.step(1)
        touched += len(sim.contacts())
    assert touched > 0
    P1, L1 = total_momenta(w)
    assert np.linalg.norm(P1 - P0) <= 1e-9 * np.linalg.norm(P0)
    assert np.linalg.norm(L1 - L0) <= 1e-9 * np.linalg.norm(L0)


def test_elastic_head_on_collision_keeps_kinetic_energy_and_gives_the_textbook_velocities():
    """Two spheres (1 kg, 3 kg), e = 1, no friction, head on, no gravity: kinetic energy after
    equals before within 1e-6 relative (issue) and the velocities are the 1-D elastic impact's,
    v1' = ((m1 - m2) v1 + 2 m2 v2) / (m1 + m2) and v2' = ((m2 - m1) v2 + 2 m1 v1) / (m1 + m2), to 1e-9."""
    w = tb.World(gravity=(0, 0, 0))
    mat = tb.Material(friction=0.0, restitution=1.0)
    m1, m2, v1, v2 = 1.0, 3.0, 4.0, -1.0
    w.add_body(tb.Sphere(radius=0.3), mass=m1, position=(-1, 0, 0), velocity=(v1, 0, 0), material=mat, name="a")
    w.add_body(tb.Sphere(radius=0.4), mass=m2, position=(1, 0, 0), velocity=(v2, 0, 0), material=mat, name="b")
    e0 = w.kinetic_energy()
    tb.Simulator(w).run(1.0, frame_rate=24)
    assert w.kinetic_energy() == pytest.approx(e0, rel=1e-6)
    assert w.v[0, 0] == pytest.approx(((m1 - m2) * v1 + 2 * m2 * v2) / (m1 + m2), abs=1e-9)
    assert w.v[1, 0] == pytest.approx(((m2 - m1) * v2 + 2 * m1 * v1) / (m1 + m2), abs=1e-9)


def test_elastic_off_centre_collision_energy_error_is_small_and_shrinks_with_dt():
    """Off-centre, the contact normal and point are those found at the start of the step, when the
    spheres are still up to one step's travel apart; the line of centres turns a little before they
    touch, so the impulse is slightly off the line of centres and spins them (a known first-order
    error of contacts detected once a step, as in Box2D/Box3D). Measured: relative energy error
    5.5e-4 at dt 1/240 s, 1.1e-4 at 1/480, 3.3e-5 at 1/960, 6.3e-6 at 1/1920 s. Bounds: 1e-3 at 1/240 and 2e-5 at 1/1920, and
    momentum still to 1e-9 (the impulses of a contact act at one point)."""
    errors = []
    for dt in (1 / 240, 1 / 1920):
        w = tb.World(gravity=(0, 0, 0))
        mat = tb.Material(friction=0.0, restitution=1.0)
        w.add_body(tb.Sphere(radius=0.3), mass=1.0, position=(-1, 0.2, 0), velocity=(4, 0, 0), material=mat, name="a")
        w.add_body(tb.Sphere(radius=0.4), mass=3.0, position=(1, -0.1, 0), velocity=(-1, 0, 0), material=mat, name="b")
        e0 = w.kinetic_energy()
        P0, L0 = total_momenta(w)
        tb.Simulator(w, dt=dt).run(0.5, frame_rate=24)
        errors.append(abs(w.kinetic_energy() / e0 - 1))
        P1, L1 = total_momenta(w)
        assert np.linalg.norm(P1 - P0) <= 1e-9 * np.linalg.norm(P0)
        assert np.linalg.norm(L1 - L0) <= 1e-9 * np.linalg.norm(L0)
    assert errors[0] < 1e-3
    assert errors[1] < 2e-5


# ---------------------------------------------------------------------- resting contact
def test_resting_box_carries_its_weight():
    """A 2 kg box on the ground: over 1 s after settling, the normal impulses of its contacts sum to
    m g (1 s) within 0.1 %; penetration under 1 mm; speed under 1 mm/s (issue)."""
    w = ground_world()
    w.sleeping = False  # measured over 1 s of rest: a sleeping box has no contacts to measure
    m = 2.0
    w.add_body(tb.Box(size=(0.4, 0.6, 0.3)), mass=m, position=(0, 0, 0.15), name="box",
               material=tb.Material(friction=0.5))
    sim = tb.Simulator(w)
    sim.step(240)  # settle 1 s
    total = 0.0
    deepest = 0.0
    for _ in range(240):
        sim.step(1)
        c = sim.contacts()
        total += c.normal_impulse.sum()
        deepest = min(deepest, c.separation.min())
    assert total == pytest.approx(m * G * 1.0, rel=1e-3)
    assert -deepest < 1e-3
    assert np.linalg.norm(w.v[1]) < 1e-3
    assert np.linalg.norm(w.omega[1]) < 1e-2


# ---------------------------------------------------------------------- continuous collision
@pytest.mark.parametrize("dt", [1 / 240, 1 / 60])
def test_fast_small_sphere_does_not_tunnel_through_a_thin_wall(dt):
    """A 1 cm sphere at 100 m/s moves 0.42 m (dt 1/240) or 1.7 m (1/60) a step, 40-170 times the
    1 cm wall: without continuous collision it would jump over. Speculative margins make the
    contact before the step; the sphere must end on the near side."""
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Box(size=(0.01, 2, 2)), fixed=True, position=(0, 0, 0), name="wall")
    w.add_body(tb.Sphere(radius=0.005), mass=0.001, position=(-3.0, 0.0, 0.0), velocity=(100, 0, 0), name="bullet",
               material=tb.Material(restitution=0.0))
    sim = tb.Simulator(w, dt=dt)
    sim.run(0.25, frame_rate=24 if dt == 1 / 240 else 12)
    assert w.x[1, 0] < -0.005 + 1e-4


def test_fast_small_sphere_does_not_tunnel_through_a_moving_body():
    """The same bullet against a thin moving plate coming the other way at 5 m/s."""
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Box(size=(0.01, 1, 1)), mass=50.0, position=(0.5, 0, 0), velocity=(-5, 0, 0), name="plate")
    w.add_body(tb.Sphere(radius=0.005), mass=0.001, position=(-3.0, 0.0, 0.0), velocity=(100, 0, 0), name="bullet")
    sim = tb.Simulator(w)
    sim.run(0.25, frame_rate=24)
    assert w.x[1, 0] < w.x[0, 0] - 0.005


# ---------------------------------------------------------------------- free flight is the integrator's
def test_bodies_without_contacts_move_exactly_as_without_collisions():
    """Two boxes far apart (no contact in any step): the world with collisions on gives the same
    bits as with collisions off, since bodies without contacts take the chosen integrator's step."""
    def build(collisions):
        w = tb.World(gravity=(0, 0, -G))
        w.collisions = collisions
        w.add_body(tb.Box(size=(0.2, 0.6, 1.0)), mass=2.0, position=(0, 0, 0), angular_velocity=(0.1, 5, 0.1))
        w.add_body(tb.Box(size=(0.3, 0.3, 0.3)), mass=1.0, position=(5, 0, 0), velocity=(1, 0, 3))
        return w

    a, b = build(True), build(False)
    tb.Simulator(a).run(1.0)
    tb.Simulator(b).run(1.0)
    assert np.array_equal(a.pack(), b.pack())


# ---------------------------------------------------------------------- stacking
@pytest.mark.slow
def test_tower_of_ten_cubes_stands_30_s_at_the_default_dt():
    """Issue: the top of a 10-cube tower drifts under 1 cm in 30 s at the default dt (1/240 s).
    Drift is measured from the start, in 3-D (the settling sag counts). Measured: 0.2 mm sideways,
    1.6 mm down (the soft contacts' sag, 120 Hz at h = 1/960 s)."""
    from tumble.scenes.contact import tower

    w, _ = tower(10)
    top = w.body_count - 1
    x0 = w.x[top].copy()
    tb.Simulator(w).run(30.0, frame_rate=2)
    assert np.linalg.norm(w.x[top] - x0) < 0.01
    assert np.abs(w.v).max() < 1e-3


@pytest.mark.slow
def test_pyramid_of_20_rows_stands_10_s():
    """Issue: a 2-D pyramid of 20 rows (210 unit cubes, Box3D's materials) stands 10 s. Standing:
    every box within 1 cm of where it started and none faster than 1 cm/s at the end; overlap of
    any two boxes under 5 mm. Measured: 1.8 mm, 3e-8 m/s, 0.2 mm."""
    from tumble.scenes.contact import max_box_overlap, pyramid

    w, _ = pyramid(20)
    assert w.body_count == 211
    x0 = w.x.copy()
    tb.Simulator(w).run(10.0, frame_rate=2)
    assert np.linalg.norm(w.x - x0, axis=1).max() < 0.01
    assert np.abs(w.v).max() < 0.01
    assert max_box_overlap(w) < 0.005


# ---------------------------------------------------------------------- piles
@pytest.fixture(scope="module")
def pile_after_4_s():
    """BENCHMARKS.md's pile of 1000 boxes run 4 s at tumble's default step (dt 1/240 s, 4 solver
    substeps): the World at 4 s and the (lo, hi) corners (m) of the pile's region in x and y, the
    start's bounding box grown by 2 m (BENCHMARKS.md's "left region"). Shared by the two tests
    below, which split issue 3's acceptance item into what is met and what is not."""
    from tumble.scenes.contact import pile

    w, _ = pile(1000)
    start = w.x[w.moving].copy()
    lo, hi = start[:, :2].min(axis=0) - 2.0, start[:, :2].max(axis=0) + 2.0
    tb.Simulator(w).run(4.0, frame_rate=4)
    return w, lo, hi


@pytest.mark.slow
def test_pile_of_1000_boxes_has_no_penetration_over_5_mm_at_4_s(pile_after_4_s):
    """Issue: after 4 s the pile has no penetration over 5 mm: no box corner 5 mm below the ground,
    no two boxes overlapping 5 mm (separating-axis depth). Measured at the default step: 0.16 mm
    and 1.14 mm. (At Box3D's coarser step, dt 1/60 s, the box-box overlap is 8-19 mm over seeds 0-4,
    measured in session 46: soft contacts of 30 Hz compress under the weight above them, 0.28 mm per
    box of load; 3.9-5.8 mm with the loaded contacts stiffened; docs/contact.md.)"""
    from tumble.scenes.contact import box_corners, max_box_overlap

    w, _, _ = pile_after_4_s
    m = w.moving
    corners = box_corners(w.x[m], w.R[m], np.array([0.1, 0.1, 0.1]))
    assert -corners[..., 2].min() < 0.005
    assert max_box_overlap(w) < 0.005


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="at 4 s the column's collapse has not quite ended and its runout passes "
                   "the region's 2 m margin; no engine meets this on this scene (see the docstring)")
def test_pile_of_1000_boxes_is_at_rest_within_its_region_at_4_s(pile_after_4_s):
    """Issue: after 4 s no body faster than 1 cm/s and none outside the pile's region (the start's
    bounding box grown by 2 m, BENCHMARKS.md's "left region"). NOT MET, and not met by PyBullet or
    MuJoCo either. Measured at 4 s (default step): 56 boxes above 1 cm/s (the fastest 0.99 m/s;
    at 4.5 s 4, the fastest 0.08 m/s; at 5 s none, the fastest 9.2 mm/s), 3 boxes out (0.22 m
    past the margin, where they stay).

    Why: the 10 x 10 x 10 grid lands as 100 columns of tilted cubes, a block 2 m tall and 3.6 m
    wide, which then collapses like a granular column (side views in docs/contact.md). Collapse
    experiments put the runout at about 1.2 times the column's height for this aspect ratio
    (axisymmetric columns: Lube et al., J. Fluid Mech. 508, 2004; Lajeunesse et al., Phys. Fluids
    16, 2004), ~2.5 m here, with the front's grains scattered beyond it: past the 2 m margin. The
    energy never rises (tests/test_examples_contact.py::test_pile_only_loses_energy_and_nothing_sinks);
    the boxes out are the tops of the outer columns, thrown as the columns topple. The better
    converged the solve, the farther the runout. Over orientation seeds 0-4 (the benchmark's runs,
    docs/benchmarks.md "pile across seeds" and "The solve's chain"), boxes out at 4 s: tumble at
    Box3D's step 2, 3, 1, 2, 2 (and boxes overlap 7-11 mm there); tumble at the default resolution
    (h = 1/960 s) 1, 2, 6, 4, 2; PyBullet (dt 1/240 s) 0, 4, 3, 3, 0; MuJoCo CG 8, 6, 4, 3, 1; runs
    whose fastest box is below 1 cm/s at 4 s: tumble 3 of 5 at Box3D's step, 0 of 5 at the default
    resolution, PyBullet and MuJoCo 0 of 5. The item needs a region that admits the collapse's
    runout, or a later time: the issue's author to decide."""
    w, lo, hi = pile_after_4_s
    m = w.moving
    assert np.linalg.norm(w.v[m], axis=1).max() < 0.01
    xy = w.x[m, :2]
    assert np.all((xy >= lo) & (xy <= hi))
