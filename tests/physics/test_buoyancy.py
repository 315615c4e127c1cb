"""Buoyancy (``tb.Buoyancy``, tumble.buoyancy): Archimedes' force on each body's part under a level
surface, at that part's centroid, with drag in the fluid.

Compared with: trimesh's own slicing of the same surfaces (an independent clip, cap and mass
integral) for the submerged volume and centroid, the spherical cap's integral by SciPy's quad, the
floating equilibrium of Archimedes (draft = rho_body / rho_fluid of the height; a sphere's cap of
volume m / rho), the heave period of a floating slab 2 pi sqrt(m / (rho g A)), a sinking body's
acceleration g (1 - rho_fluid / rho_body), and the metacentric rule (a long bar floats on its side).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

import tumble as tb
from tumble.buoyancy import geometry, submerged_part, submerged_volume, surface_volume
from tumble.errors import InputError
from tumble.math3d import quat_to_matrix

G = 9.81
RHO = 1000.0


def _part(world, i, x, R, level=0.0):
    """(V, centroid) of body i's surface below z = level at pose (x, R)."""
    g = geometry(world)
    acc, wv, depth = np.empty(4), np.empty((g.most_vertices, 3)), np.empty(g.most_vertices)
    submerged_part(np.asarray(x, float), np.ascontiguousarray(R, dtype=float), g.first[i], g.count[i], g.faces,
                   g.vfirst[i], g.vcount[i], g.vertices, g.radius[i], np.ascontiguousarray(g.centre[i]), g.volume[i],
                   g.reach[i], np.ascontiguousarray(g.centroid[i]), np.array([0.0, 0.0, 1.0]), level, acc, wv, depth)
    return acc[0], (acc[1:] / acc[0] if acc[0] > 0 else np.zeros(3))


def _clipped_hull(points):
    """(V, centroid) of conv(points) below z = 0, by SciPy's Qhull: the hull of its corners below and
    of its edges' crossings of the cut (the clipped polytope's corners), its volume and a fan of
    tetrahedra from one of its points for the centroid."""
    from scipy.spatial import ConvexHull

    whole = ConvexHull(points)
    points = points[whole.vertices]  # the corners; then the hull's edges, which the cut crosses
    index = {v: k for k, v in enumerate(whole.vertices)}
    edges = {tuple(sorted((index[a], index[b]))) for tri in whole.simplices for a, b in zip(tri, np.roll(tri, 1))}
    edges = np.array(sorted(edges))
    below = points[points[:, 2] <= 0]
    if len(below) == 0:
        return 0.0, np.zeros(3)
    a, b = points[edges[:, 0]], points[edges[:, 1]]
    crossing = (a[:, 2] <= 0) != (b[:, 2] <= 0)
    a, b = a[crossing], b[crossing]
    s = a[:, 2] / (a[:, 2] - b[:, 2])
    cut = a + s[:, None] * (b - a)
    pts = np.vstack([below, cut])
    hull = ConvexHull(pts)
    o = pts[hull.vertices[0]]
    tet = pts[hull.simplices] - o
    vol = np.abs(np.einsum("ij,ij->i", tet[:, 0], np.cross(tet[:, 1], tet[:, 2]))) / 6.0
    centroid = o + (vol[:, None] * (tet.sum(axis=1) / 4.0)).sum(axis=0) / vol.sum()
    assert vol.sum() == pytest.approx(hull.volume, rel=1e-12)
    return hull.volume, centroid


def test_the_submerged_volume_and_centroid_equal_an_independent_clip_of_convex_pieces():
    """A box, a hull, a compound of a box and a cone on it, a capsule and a concave closed mesh (an L
    prism) at random poses cut by z = 0: the tetrahedra from a point on the cut (no cap built) against
    SciPy's Qhull of each convex piece clipped (_clipped_hull; the L as its two boxes, the compound
    as its two parts, the round shapes by the same tessellation's points): 1e-9 relative, rounding.
    A quarter of the poses are wholly under (the whole surface's centroid, no triangle visited) and a
    quarter wholly out."""
    import trimesh

    from tumble.buoyancy import SECTIONS

    rng = np.random.default_rng(7)
    # an L-shaped prism (concave): the L's profile in (x, y), fanned from its corner, extruded 0.3 m
    profile = np.array([(0, 0), (1, 0), (1, 0.3), (0.3, 0.3), (0.3, 1), (0, 1)], dtype=float)
    L = trimesh.creation.extrude_triangulation(profile, np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]), 0.3)

    def corners(lo, hi):
        return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])], float)

    hull_points = rng.normal(size=(30, 3)) * 0.3
    cone = trimesh.creation.cone(0.2, 0.5, sections=SECTIONS).vertices + (0.1, 0, 0.1)
    capsule = trimesh.creation.capsule(height=0.5, radius=0.15, count=[SECTIONS, SECTIONS // 2]).vertices
    cases = [(tb.Box((0.6, 0.4, 0.3)), [corners((-0.3, -0.2, -0.15), (0.3, 0.2, 0.15))]),
             (tb.Convex(points=hull_points), [hull_points]),
             (tb.Compound([(tb.Box((0.4, 0.4, 0.2)), (0, 0, 0), (1, 0, 0, 0)), (tb.Cone(0.2, 0.5), (0.1, 0, 0.1), (1, 0, 0, 0))]),
              [corners((-0.2, -0.2, -0.1), (0.2, 0.2, 0.1)), cone]),
             (tb.Capsule(0.15, 0.5), [capsule]),
             (tb.Mesh(vertices=L.vertices, faces=L.faces), [corners((0, 0, 0), (1, 0.3, 0.3)), corners((0, 0.3, 0), (0.3, 1, 0.3))])]
    w = tb.World()
    for shape, _ in cases:
        w.add_body(shape, mass=1.0)
    for i, (_, pieces) in enumerate(cases):
        offset = -w.com_offset[i]  # the shape frame's origin in the body frame
        for k in range(8):
            x = rng.uniform(-0.2, 0.2, 3)
            x[2] += {2: 3.0, 3: -3.0}.get(k % 4, 0.0)  # some wholly out of the water, some wholly in
            R = quat_to_matrix(tb.math3d.random_quaternions(1, rng)[0])
            V, c = _part(w, i, x, R)
            parts = [_clipped_hull((p + offset) @ R.T + x) for p in pieces]
            Vr = sum(v for v, _ in parts)
            if Vr < 1e-12:
                assert V < 1e-12
                continue
            cr = sum(v * cc for v, cc in parts) / Vr
            assert V == pytest.approx(Vr, rel=1e-9)
            assert np.allclose(c, cr, rtol=0, atol=1e-9)


def test_a_spheres_cap_is_the_integral_of_its_discs():
    """A lone sphere takes the cap's closed form: V = pi h^2 (3 r - h) / 3 and its centroid
    3 (2 r - h)^2 / (4 (3 r - h)) below the centre, against SciPy's quad of the discs pi (r^2 - z^2)
    (1e-12: quad is exact on these polynomials to rounding), at depths from a touch to wholly under, off-centre on a body with a given centre of mass."""
    r = 0.4
    w = tb.World()
    w.add_body(tb.Sphere(r), mass=1.0)
    for depth in (1e-3, 0.1, 0.4, 0.65, 0.8, 1.2):
        z = r - depth  # the centre above z = 0
        V, c = _part(w, 0, (0.3, -0.2, z), np.eye(3))
        lo, hi = -r, min(r, -z)
        Vq = quad(lambda s: math.pi * (r * r - s * s), lo, hi)[0]
        Mq = quad(lambda s: s * math.pi * (r * r - s * s), lo, hi)[0]
        assert V == pytest.approx(Vq, rel=1e-12)
        assert c[2] == pytest.approx(z + Mq / Vq, abs=1e-12)
        assert c[:2] == pytest.approx((0.3, -0.2), abs=1e-15)
    assert surface_volume(w, 0) == pytest.approx(4 / 3 * math.pi * r**3, rel=1e-15)


def slab(density, size=(2.0, 2.0, 0.5), drag=0.0, layout="quaternion", z=None, **kw):
    """A flat box floating in water: stable flat (its metacentre above its centre of mass)."""
    w = tb.World(gravity=(0, 0, -G), layout=layout)
    m = density * float(np.prod(size))
    area = size[0] * size[1]
    omega = math.sqrt(RHO * G * area / m)
    w.add_force(tb.Buoyancy(density=RHO, level=0.0, linear=drag * 2.0 * m * omega, angular_linear=drag * 50.0))
    draft = density / RHO * size[2]
    start = size[2] / 2 - draft if z is None else z
    box = w.add_body(tb.Box(size), mass=m, position=(0, 0, start), **kw)
    return w, box, draft, omega


@pytest.mark.parametrize("density", [250.0, 500.0, 800.0])
def test_a_floating_slab_settles_at_archimedes_draft(density):
    """Dropped from 0.3 m above its rest, critically damped (drag 2 m omega): after 8 s its draft is
    rho / rho_water of its height (1e-6 m: the damped oscillation is e^-35 of its start by then) and
    the buoyant force m g (the submerged volume m / rho_water, 1e-9 relative)."""
    w, box, draft, omega = slab(density, drag=1.0)
    box.x[2] += 0.3
    tb.Simulator(w).run(8.0, frame_rate=4)
    assert box.x[2] - 0.25 == pytest.approx(-draft, abs=1e-6)
    assert submerged_volume(w, box) == pytest.approx(box.mass / RHO, rel=1e-6)


def test_a_floating_ball_sinks_to_the_cap_that_displaces_its_weight():
    """A ball of 300 kg/m^3 (r = 0.5 m) floats with a cap of height h under water, pi h^2 (3 r - h) / 3
    = m / rho_water (h by SciPy's brentq): after 10 s, damped, its centre is r - h above the
    surface (1e-6 m)."""
    r, density = 0.5, 300.0
    m = density * 4 / 3 * math.pi * r**3
    h = brentq(lambda h: math.pi * h * h * (3 * r - h) / 3 * RHO - m, 0.0, 2 * r, xtol=1e-15)
    area = math.pi * (2 * r * h - h * h)  # the waterline's disc
    omega = math.sqrt(RHO * G * area / m)
    w = tb.World(gravity=(0, 0, -G))
    w.add_force(tb.Buoyancy(density=RHO, linear=2.0 * m * omega, angular_linear=1.0))
    ball = w.add_body(tb.Sphere(r), mass=m, position=(0, 0, r - h + 0.2))
    tb.Simulator(w).run(10.0, frame_rate=4)
    assert ball.x[2] == pytest.approx(r - h, abs=1e-6)


@pytest.mark.parametrize("layout", ["quaternion", "matrix"])
def test_a_floating_slab_heaves_with_the_period_of_its_waterline(layout):
    """No drag; let go 2 cm below its rest: it bobs with the period 2 pi sqrt(m / (rho g A)) of a mass
    on the spring rho g A (no added mass in the model: docs/contact.md). Buoyancy is held over
    each step, taken at the mid-step pose, so the step is position Verlet for it: the period short
    by (omega dt)^2 / 24 = 2.8e-5 (measured so), tested to 1e-4; the amplitude kept (measured 2e-6),
    tested to 1e-4 (taken at the step's start instead, it grew 23 %); both layouts alike (1e-9 m)."""
    w, box, draft, omega = slab(500.0, layout=layout)
    box.x[2] -= 0.02
    sim = tb.Simulator(w)
    n = int(5 * 2 * math.pi / omega * 240)
    z = np.empty(n)
    for k in range(n):
        sim.step(1)
        z[k] = box.x[2] - (0.25 - draft)
    t = (np.arange(n) + 1) / 240
    up = np.flatnonzero((z[:-1] < 0) & (z[1:] >= 0))
    crossings = t[up] - z[up] * (t[up + 1] - t[up]) / (z[up + 1] - z[up])
    period = 2 * math.pi / omega
    assert np.diff(crossings) == pytest.approx(period, rel=1e-4)
    assert np.abs(z).max() == pytest.approx(0.02, rel=1e-4)
    if layout == "matrix":
        q, _, _, _ = slab(500.0, layout="quaternion")
        q.x[0, 2] -= 0.02
        tb.Simulator(q).step(n)
        assert box.x == pytest.approx(q.x[0], abs=1e-9)


def test_a_dense_body_under_the_surface_sinks_at_g_times_one_less_the_density_ratio():
    """A steel-like ball (2000 kg/m^3) wholly under water, no drag: a = g (1 - 1000 / 2000), so after
    0.5 s v = -g / 4 (1e-12 relative: the force is constant, every integrator exact for it)."""
    w = tb.World(gravity=(0, 0, -G))
    w.add_force(tb.Buoyancy(density=RHO, level=10.0))
    ball = w.add_body(tb.Sphere(0.1), density=2000.0, position=(0, 0, 0))
    tb.Simulator(w).run(0.5, frame_rate=4)
    assert ball.v[2] == pytest.approx(-G * 0.5 * 0.5, rel=1e-12)


def test_a_long_bar_floats_on_its_side_not_on_its_end():
    """A 1 x 0.2 x 0.2 m bar of half water's density let go upright (tilted 2 degrees): upright its
    metacentre lies below its centre of mass (BM = I / V = 0.2^4 / 12 / (0.2^2 0.5) = 0.0067 m
    against BG = 0.25 m), so it falls over and floats lying flat: at the end its long axis within
    2 degrees of level and its draft half its 0.2 m height (1 mm), with drag to settle it."""
    w = tb.World(gravity=(0, 0, -G))
    w.add_force(tb.Buoyancy(density=RHO, linear=30.0, angular_linear=3.0))
    bar = w.add_body(tb.Box((0.2, 0.2, 1.0)), density=500.0, position=(0, 0, 0.0), euler_deg=(2, 0, 0))
    tb.Simulator(w).run(20.0, frame_rate=4)
    axis = bar.R[:, 2]
    assert abs(math.degrees(math.asin(abs(axis[2])))) < 2.0
    assert bar.x[2] == pytest.approx(0.0, abs=1e-3)


def test_a_current_carries_a_floating_body_at_its_speed():
    """Flow (0.8, -0.3, 0) m/s and drag: the floating slab drifts at the flow's velocity (1e-6 m/s
    after 10 s of a critically damped approach); the buoyancy of a body above the water is nothing."""
    w, box, draft, omega = slab(500.0, drag=1.0)
    w.forces[0].flow = (0.8, -0.3, 0.0)
    w._tables = None
    dry = w.add_body(tb.Sphere(0.2), mass=1.0, position=(10, 0, 600))  # still 110 m up at the end
    tb.Simulator(w).run(10.0, frame_rate=4)
    assert box.v == pytest.approx((0.8, -0.3, 0.0), abs=1e-6)
    assert dry.v[2] == pytest.approx(-G * 10.0, rel=1e-12)
    assert submerged_volume(w)[dry.index] == 0.0


def test_buoyancy_goes_through_scene_files_checkpoints_and_snapshots(tmp_path):
    """A scene's ``[[forces]] type = "buoyancy"`` is the record; a run resumed from a checkpoint and a
    snapshot restored repeat the steps bit for bit; sweeps do not batch it; bad keys one line."""
    scene_text = """[simulation]
duration = 1.0
[[forces]]
type = "buoyancy"
density = 1025
level = 0.5
linear = 50
flow = [0.2, 0, 0]
bodies = ["crate"]
[[bodies]]
name = "crate"
shape = { type = "box", size = [0.6, 0.6, 0.4] }
density = 400
position = [0, 0, 1.0]
euler_deg = [10, 5, 0]
[[bodies]]
name = "ball"
shape = { type = "sphere", radius = 0.1 }
mass = 1
position = [2, 0, 1.0]
"""
    (tmp_path / "scene.toml").write_text(scene_text)
    scene = tb.load_scene(tmp_path / "scene.toml")
    (record,) = scene.world.forces
    assert isinstance(record, tb.Buoyancy) and record.density == 1025 and record.level == 0.5
    assert record.flow == (0.2, 0.0, 0.0) and list(record.bodies) == ["crate"]
    sim = scene.simulator()
    sim.step(120)
    saved = sim.save_state()
    path = sim.save_checkpoint(tmp_path / "c.npz")
    sim.step(120)
    end = scene.world.pack().copy()
    sim.restore_state(saved)
    sim.step(120)
    assert np.array_equal(scene.world.pack(), end)
    again = tb.Simulator.load_checkpoint(path)
    again.step(120)
    assert np.array_equal(again.world.pack(), end)
    # the ball is not in the record's bodies: it falls through the water untouched
    assert scene.world.v[1, 2] == pytest.approx(-G * 1.0, rel=1e-12)
    from tumble.sweep.batch import batch_key

    assert batch_key(scene) is None
    (tmp_path / "bad.toml").write_text(scene_text.replace("density = 1025", "density = -3"))
    with pytest.raises(InputError, match=r"bad.toml: forces\[0\].density: must be >= 0, got -3$"):
        tb.load_scene(tmp_path / "bad.toml")
    with pytest.raises(InputError, match="flow"):
        tb.Buoyancy(flow=(1, 2))


def test_a_body_resting_on_the_sea_bed_weighs_its_weight_less_its_buoyancy():
    """A 0.3 m cube of 7800 kg/m^3 resting on the bed 2 m under water (the soft step's contacts with
    buoyancy in their substeps): over 1 s its contacts' normal impulses sum to (rho - rho_water) V g
    (1 s) within 0.1 % (test_contact's resting box carries m g to that), and it stays at rest."""
    w = tb.World(gravity=(0, 0, -G))
    w.sleeping = False  # measured over 1 s of rest
    w.add_force(tb.Buoyancy(density=RHO, level=0.0, linear=50.0))
    w.add_body(tb.Plane(normal=(0, 0, 1), offset=-2.0), fixed=True)
    anchor = w.add_body(tb.Box((0.3, 0.3, 0.3)), density=7800.0, position=(0, 0, -2.0 + 0.15),
                        material=tb.Material(friction=0.8))
    sim = tb.Simulator(w)
    sim.step(240)
    total = 0.0
    for _ in range(240):
        sim.step(1)
        total += sim.contacts().normal_impulse.sum()
    assert total == pytest.approx((7800.0 - RHO) * 0.027 * G, rel=1e-3)
    assert np.linalg.norm(anchor.v) < 1e-6
