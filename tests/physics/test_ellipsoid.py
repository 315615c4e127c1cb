"""``tb.Ellipsoid``: mass properties, ray casts, resting and rocking on a plane, collisions.

References: closed forms (the unit ball's integrals scaled; the support height of a tilted
ellipsoid), a polyhedral integral of a fine mesh (trimesh), MuJoCo's ``mj_ray`` on the same
ellipsoid geoms, the small-oscillation period of a body rocking without slipping on a plane
(Routh), and the conservation of momentum. The pairwise distances and normals of the ellipsoid
against every convex kind are tested in tests/collision/test_closest_points.py.
"""

import math

import numpy as np
import pytest

import tumble as tb
from tumble.mass import mass_properties

G = 9.81


def test_mass_properties_are_the_closed_form_and_a_fine_meshs_integral():
    """m = rho 4/3 pi a b c, I = m/5 diag(b^2 + c^2, a^2 + c^2, a^2 + b^2) (the unit ball's integrals
    with x, y, z scaled by a, b, c), and the exact polyhedral integrals of a 655 362-vertex mesh of
    it agree to 2e-5 relative (the mesh's inscribed volume is short by O(h^2): measured 1.1e-5)."""
    import trimesh.creation

    a, b, c = 0.3, 0.2, 0.1
    props = mass_properties(tb.Ellipsoid(radii=(a, b, c)), density=1000.0)
    m = 1000.0 * 4.0 / 3.0 * math.pi * a * b * c
    assert props.mass == pytest.approx(m, rel=1e-15)
    np.testing.assert_allclose(np.diag(props.inertia), m / 5 * np.array([b * b + c * c, a * a + c * c, a * a + b * b]),
                               rtol=1e-15)
    np.testing.assert_array_equal(props.center, 0.0)
    mesh = trimesh.creation.icosphere(subdivisions=8, radius=1.0)
    mesh.vertices = mesh.vertices * (a, b, c)
    mesh.density = 1000.0
    assert mesh.mass == pytest.approx(props.mass, rel=2e-5)
    np.testing.assert_allclose(mesh.moment_inertia, props.inertia, rtol=2e-5, atol=1e-12)


def test_ray_casts_agree_with_mujoco_mj_ray():
    """A peer engine: 12 ellipsoids at random poses as MuJoCo ellipsoid geoms (size: the same
    semi-axes) and 1000 rays from outside them: the same one hit on every ray, the distances within
    1e-9 m (both solve the scaled sphere's quadratic in float64), and tumble's normal is the
    gradient of (x/a)^2 + (y/b)^2 + (z/c)^2 at the hit point."""
    mujoco = pytest.importorskip("mujoco")
    rng = np.random.default_rng(7)
    w = tb.World()
    geoms = []
    radii = []
    for i in range(12):
        r = rng.uniform(0.1, 0.5, 3)
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        pos = np.array([*rng.uniform(-3, 3, 2), rng.uniform(0.5, 2.5)])
        w.add_body(tb.Ellipsoid(radii=r), mass=1.0, position=pos, orientation=q)
        radii.append(r)
        geoms.append(f'<geom type="ellipsoid" size="{" ".join(map(repr, map(float, r)))}" '
                     f'pos="{" ".join(map(repr, map(float, pos)))}" quat="{" ".join(map(repr, map(float, q)))}"/>')
    m = mujoco.MjModel.from_xml_string("<mujoco><worldbody>" + "".join(geoms) + "</worldbody></mujoco>")
    data = mujoco.MjData(m)
    mujoco.mj_forward(m, data)
    origin = np.column_stack([rng.uniform(-6, 6, (1000, 2)), np.full(1000, 6.0)])
    target = np.column_stack([rng.uniform(-3.5, 3.5, (1000, 2)), rng.uniform(0.0, 2.5, 1000)])
    d = target - origin
    d /= np.linalg.norm(d, axis=1)[:, None]
    h = w.ray_cast(origin, d)
    geomid = np.zeros(1, dtype=np.int32)
    hits = 0
    for k in range(1000):
        t = mujoco.mj_ray(m, data, origin[k], d[k], None, 1, -1, geomid)
        body = int(geomid[0]) if t >= 0 else -1
        assert h.body[k] == body, k
        if body >= 0:
            hits += 1
            assert abs(h.distance[k] - t) < 1e-9, k
            R = np.asarray(w.R[body])
            local = R.T @ (h.point[k] - w.x[body])
            assert np.sum((local / radii[body]) ** 2) == pytest.approx(1.0, abs=1e-12)
            grad = R @ (local / radii[body] ** 2)
            np.testing.assert_allclose(h.normal[k], grad / np.linalg.norm(grad), atol=1e-12)
    assert hits > 100


def support_height(b, c, theta):
    """Height of the centre of an ellipse of semi-axes b (y) and c (z) tilted by theta about x,
    touching the plane z = 0: sqrt(b^2 sin^2 + c^2 cos^2)."""
    return math.sqrt((b * math.sin(theta)) ** 2 + (c * math.cos(theta)) ** 2)


def rocking(theta0, dt, seconds, a=0.15, b=0.2, c=0.1):
    """(t (K,), tilt about x (K,) rad, the World) of an ellipsoid released at rest tilted by theta0
    about x, touching the ground, friction 1 (it rolls without slipping)."""
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Plane(), fixed=True, material=tb.Material(friction=1.0))
    egg = w.add_body(tb.Ellipsoid(radii=(a, b, c)), mass=1.0, position=(0, 0, support_height(b, c, theta0)),
                     euler_deg=(math.degrees(theta0), 0, 0), material=tb.Material(friction=1.0))
    w.sleeping = False
    sim = tb.Simulator(w, dt=dt)
    n = int(round(seconds / dt))
    t, tilt = [], []
    for k in range(n):
        sim.step(1)
        R = np.asarray(egg.R)
        t.append((k + 1) * dt)
        tilt.append(math.atan2(R[2, 1], R[2, 2]))
    return np.array(t), np.array(tilt), w


def test_an_ellipsoid_rocks_with_the_period_of_rolling_without_slipping():
    """Tilted 0.02 rad about x from resting on its shortest axis c and let go, an ellipsoid rocks
    on the ground without slipping. Small oscillations about the contact point (Routh): omega^2 =
    m g (rho - c) / (I_x + m c^2), rho = b^2 / c the radius of curvature of its y-z section at the
    bottom, I_x = m (b^2 + c^2) / 5. Over 2 s at the default dt 1/240 s: the period from the zero
    crossings within 0.3 % (measured 0.092 %: the amplitude's own nonlinear lengthening, O(theta0^2):
    0.575 % at 0.05 rad, the same at dt 1/960), and the amplitude kept to 0.2 % (measured 6e-5:
    rolling without slipping does no work). The anchors' dead ends (contact_anchor._ellipsoid_offset)
    gained 20 % and 31 % of amplitude in 2 s at 0.05 rad."""
    a, b, c = 0.15, 0.2, 0.1
    theta0 = 0.02
    t, tilt, _ = rocking(theta0, 1 / 240, 2.0, a, b, c)
    omega = math.sqrt(G * (b * b / c - c) / ((b * b + c * c) / 5 + c * c))
    up = np.flatnonzero((tilt[:-1] < 0) & (tilt[1:] >= 0))  # upward zero crossings
    crossings = t[up] - tilt[up] * (t[up + 1] - t[up]) / (tilt[up + 1] - tilt[up])
    assert len(crossings) >= 3
    period = float(np.mean(np.diff(crossings)))
    assert period == pytest.approx(2 * math.pi / omega, rel=0.003)
    last = np.abs(tilt[t > 2.0 - period]).max()
    assert last == pytest.approx(theta0, rel=0.002)


def test_an_ellipsoid_settles_on_its_shortest_axis():
    """Dropped from 0.5 m tilted 25 degrees, with rolling resistance and spinning friction (without
    them it rolls, rocks and spins on for good: rolling does no work, as for a ball), it comes to
    rest on its shortest semi-axis c (its only stable pose on a plane): centre c above the ground
    within the solver's resting penetration (1 mm), the c axis vertical within 1 degree, still
    (1 mm/s) after 6 s (measured: asleep after 4 s); the ground's closest point to it is then its
    lowest point, 1 mm deep at most."""
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Plane(), fixed=True)
    egg = w.add_body(tb.Ellipsoid(radii=(0.3, 0.2, 0.1)), mass=1.0, position=(0, 0, 0.6), euler_deg=(25, 10, 0),
                     material=tb.Material(rolling_resistance=0.02, spinning_friction=0.01))
    tb.Simulator(w, dt=1 / 240).step(6 * 240)
    assert egg.x[2] == pytest.approx(0.1, abs=1e-3)
    assert abs(np.asarray(egg.R)[2, 2]) > math.cos(math.radians(1))
    assert np.linalg.norm(egg.v) < 1e-3
    assert -1e-3 < w.closest_points(egg.index, 0).distance[0] <= 1e-6


def test_two_ellipsoids_colliding_keep_their_momenta():
    """No gravity, two ellipsoids turning and meeting off-centre (restitution 1, friction 0.5):
    total linear and angular momentum (about the origin) kept to 1e-9 relative (the impulses act
    at one point on each body, equal and opposite), and the kinetic energy does not grow."""
    w = tb.World(gravity=(0, 0, 0))
    mat = tb.Material(friction=0.5, restitution=1.0)
    a = w.add_body(tb.Ellipsoid(radii=(0.4, 0.2, 0.15)), mass=2.0, position=(-1, 0.1, 0), euler_deg=(10, 30, 50),
                   velocity=(2, 0, 0), angular_velocity=(0, 1, 3), material=mat)
    b = w.add_body(tb.Ellipsoid(radii=(0.25, 0.3, 0.2)), mass=1.0, position=(1, -0.05, 0.1), euler_deg=(70, 0, 20),
                   velocity=(-1.5, 0, 0), angular_velocity=(2, 0, 0), material=mat)

    def momenta():
        P = np.asarray(w.P).sum(axis=0)
        L = sum(np.cross(w.x[i], w.P[i]) + w.L[i] for i in range(2))
        ke = sum(0.5 * w.P[i] @ w.v[i] + 0.5 * w.L[i] @ w.omega[i] for i in range(2))
        return P, L, ke

    P0, L0, ke0 = momenta()
    sim = tb.Simulator(w, dt=1 / 240, record_contacts=True)
    touched = False
    for _ in range(240):
        sim.step(1)
        touched = touched or len(sim.contacts().body_a) > 0
    assert touched
    assert abs(a.v[0] - 2.0) > 0.5 and abs(b.v[0] + 1.5) > 0.5  # they met
    P1, L1, ke1 = momenta()
    np.testing.assert_allclose(P1, P0, atol=1e-9 * np.linalg.norm(P0))
    np.testing.assert_allclose(L1, L0, atol=1e-9 * np.linalg.norm(L0))
    assert ke1 <= ke0 * (1 + 1e-9)


def test_the_scene_file_and_its_bad_radii():
    """A scene's ``shape = {type = "ellipsoid", radii = [a, b, c]}``, also as a compound part; bad
    radii stop with one line naming the key."""
    from tumble.scene import parse_scene

    scene = parse_scene({"bodies": [
        {"name": "egg", "shape": {"type": "ellipsoid", "radii": [0.3, 0.2, 0.1]}, "mass": 1.0},
        {"name": "pair", "mass": 1.0, "shape": {"type": "compound", "parts": [
            {"shape": {"type": "ellipsoid", "radii": [0.1, 0.1, 0.2]}, "position": [0, 0, 0.2]},
            {"shape": {"type": "sphere", "radius": 0.1}}]}}]})
    assert scene.world.shapes[0] == tb.Ellipsoid(radii=(0.3, 0.2, 0.1))
    for radii, problem in (([0.3, -0.2, 0.1], "bodies[0].shape.radii[1]"), ([0.3, 0.2], "bodies[0].shape.radii")):
        with pytest.raises(tb.InputError) as info:
            parse_scene({"bodies": [{"name": "egg", "shape": {"type": "ellipsoid", "radii": radii}, "mass": 1.0}]},
                        file="s.toml")
        line = str(info.value)
        assert "\n" not in line and problem in line and "s.toml" in line, line
