"""Explosions (``World.explode``, ``tb.Explosion``; tumble.collision.explosion): Box2D v3's
``b2World_Explode`` in 3-D. Each shape within reach takes impulse_per_area x its shadow's area
along the direction from the centre to its closest point, at that point.

Checked against: the shadow areas of dense samplings of each shape's surface (2-D convex hulls of
their projections, and Cauchy's formula over a hull's faces), the closest points of spheres and
boxes in closed form, the momentum balance of the impulse at the point, and runs in which the
timed record acts at its step, wakes what sleeps and blows a wall apart."""

import math

import numpy as np
import pytest
from scipy.spatial import ConvexHull

import tumble as tb
from tumble.collision.explosion import blast, projected_area
from tumble.errors import InputError
from tumble.shapes import (
    SHAPE_BOX,
    SHAPE_CAPSULE,
    SHAPE_CONE,
    SHAPE_CONVEX,
    SHAPE_CYLINDER,
    SHAPE_ELLIPSOID,
    SHAPE_SPHERE,
)


def _unit(rng, k):
    u = rng.normal(size=(k, 3))
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def _shadow(points, u):
    """The area of the 2-D convex hull of ``points`` (P, 3) projected on the plane normal to u."""
    e1 = np.cross(u, [0.3, 0.5, 0.8])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    return ConvexHull(points @ np.stack([e1, e2], axis=1)).volume


def _sphere_points(subdivisions=7):
    import trimesh

    return np.asarray(trimesh.creation.icosphere(subdivisions=subdivisions).vertices)


def _circle(radius, z, m=20000):
    t = np.linspace(0.0, 2 * np.pi, m, endpoint=False)
    return np.stack([radius * np.cos(t), radius * np.sin(t), np.full(m, z)], axis=1)


# The oracles' own errors: a polygon inscribed in a circle of M = 20 000 points misses
# 1 - sin(2 pi / M) / (2 pi / M) ~ 1.6e-8 of its area; the icosphere of 7 subdivisions (163 842
# vertices, edges ~0.0095 of the radius) is inscribed in the sphere: its shadow falls short by
# about (edge / 2)^2 / 2 ~ 1.1e-5 relative (measured below 1.2e-5). So: rims 1e-7, curved
# surfaces 3e-5, polytopes to round-off.
RIM_TOL, SURFACE_TOL = 1e-7, 3e-5


@pytest.fixture(scope="module")
def ball_points():
    return _sphere_points()


def test_projected_areas_are_the_shadows_of_the_surfaces(ball_points):
    rng = np.random.default_rng(3)
    dirs = np.vstack([_unit(rng, 12), np.eye(3), [[0.6, 0.0, 0.8]]])
    r, half, h = 0.3, 0.45, 0.7
    a, b, c = 0.35, 0.15, 0.25
    hull = rng.normal(size=(15, 3)) * 0.3
    cases = {
        "sphere": (SHAPE_SPHERE, (r, 0, 0, 0), None, ball_points * r, SURFACE_TOL),
        "box": (SHAPE_BOX, (a, b, c, 0), None,
                np.array([[sx * a, sy * b, sz * c] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]), 1e-12),
        "capsule": (SHAPE_CAPSULE, (r, half, 0, 0), None,
                    np.vstack([ball_points * r + [0, 0, half], ball_points * r - [0, 0, half]]), SURFACE_TOL),
        "cylinder": (SHAPE_CYLINDER, (r, half, 0, 0), None, np.vstack([_circle(r, half), _circle(r, -half)]), RIM_TOL),
        "cone": (SHAPE_CONE, (r, h, 0, 0), None, np.vstack([_circle(r, 0.0), [[0, 0, h]]]), RIM_TOL),
        "ellipsoid": (SHAPE_ELLIPSOID, (a, b, c, 0), None, ball_points * [a, b, c], SURFACE_TOL),
        "hull": (SHAPE_CONVEX, (0, 0, 0, 0), hull, hull, 1e-12),
    }
    worst = {}
    for name, (t, params, verts, points, tol) in cases.items():
        for u in dirs:
            got = projected_area(t, np.array(params, float), verts, u)
            want = _shadow(points, u)
            worst[name] = max(worst.get(name, 0.0), abs(got - want) / want)
            assert got == pytest.approx(want, rel=tol), (name, u)
    # the curved ones are inscribed: their oracle's error is real and of the size said above
    assert 1e-7 < worst["sphere"] < SURFACE_TOL


def test_a_hulls_shadow_is_half_its_surfaces_projected_area():
    """Cauchy's projection formula, A(u) = 1/2 sum over faces |u . n_f| A_f, over the 3-D hull's
    triangles: another way to the hull's shadow than the 2-D hull the engine takes."""
    rng = np.random.default_rng(11)
    verts = rng.normal(size=(20, 3))
    h3 = ConvexHull(verts)
    tri = verts[h3.simplices]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # 2 A_f n_f
    for u in _unit(rng, 20):
        want = 0.25 * np.abs(n @ u).sum()
        assert projected_area(SHAPE_CONVEX, np.zeros(4), verts, u) == pytest.approx(want, rel=1e-12)


def test_the_cones_shadow_on_its_limits():
    """The cone's formula at its two ends and its seam: along the axis the base disc (pi r^2),
    side-on the triangle (r h), and continuous where the apex leaves the base's ellipse
    (h sin(theta) = r cos(theta))."""
    r, h = 0.3, 0.7
    assert projected_area(SHAPE_CONE, np.array([r, h, 0, 0]), None, [0, 0, 1]) == pytest.approx(math.pi * r * r, rel=1e-15)
    assert projected_area(SHAPE_CONE, np.array([r, h, 0, 0]), None, [1, 0, 0]) == pytest.approx(r * h, rel=1e-15)
    seam = math.atan2(r, h)
    below = projected_area(SHAPE_CONE, np.array([r, h, 0, 0]), None, [math.sin(seam - 1e-9), 0, math.cos(seam - 1e-9)])
    above = projected_area(SHAPE_CONE, np.array([r, h, 0, 0]), None, [math.sin(seam + 1e-9), 0, math.cos(seam + 1e-9)])
    assert above == pytest.approx(below, abs=1e-8)


def _free_world():
    return tb.World(gravity=(0, 0, 0))


def test_each_body_takes_its_impulse_at_its_closest_point():
    """A sphere and a turned box: the closest points in closed form (the sphere's along the line
    of centres; the box's by clamping the centre in the box's frame), the direction from the
    centre to them, the area of their shadows (pi r^2; 4 (b c |ux| + a c |uy| + a b |uz|)), and the
    momenta changed by exactly J and (p - x) x J. 1e-9 m: GJK's stopping rule on the points."""
    w = _free_world()
    ball = w.add_body(tb.Sphere(0.4), mass=2.0, position=(2.0, 1.0, -0.5), name="ball")
    box = w.add_body(tb.Box(size=(0.6, 1.0, 0.4)), mass=3.0, position=(-1.5, 0.5, 1.0), euler_deg=(20, 35, -50),
                     name="box")
    c = np.array([0.1, -0.2, 0.3])
    k = 2.5  # N s / m^2
    P0, L0 = w.P.copy(), w.L.copy()
    r = w.explode(c, radius=5.0, impulse_per_area=k)
    assert list(r.body) == [0, 1]

    d = ball.x - c
    p_ball = c + d * (1 - 0.4 / np.linalg.norm(d))
    u_ball = d / np.linalg.norm(d)
    J_ball = k * math.pi * 0.4 ** 2 * u_ball

    Rb = box.R.copy()
    local = np.clip(Rb.T @ (c - box.x), -np.array([0.3, 0.5, 0.2]), [0.3, 0.5, 0.2])
    p_box = box.x + Rb @ local
    u_box = (p_box - c) / np.linalg.norm(p_box - c)
    ul = Rb.T @ u_box
    area_box = 4 * (0.5 * 0.2 * abs(ul[0]) + 0.3 * 0.2 * abs(ul[1]) + 0.3 * 0.5 * abs(ul[2]))
    J_box = k * area_box * u_box

    np.testing.assert_allclose(r.point, [p_ball, p_box], atol=1e-9)
    np.testing.assert_allclose(r.impulse, [J_ball, J_box], rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(w.P - P0, [J_ball, J_box], rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(w.L - L0, [np.cross(p_ball - ball.x, J_ball), np.cross(p_box - box.x, J_box)],
                               rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(ball.v, J_ball / 2.0, rtol=1e-8)  # the derived quantities follow
    assert np.linalg.norm(ball.omega) < 1e-9  # a sphere's push goes through its centre


def test_every_shape_kind_is_pushed_where_the_closest_points_query_says():
    """Capsule, cylinder, cone, ellipsoid, hull and a compound's two parts: the point and distance
    of each row equal ``World.closest_points`` from a small sphere at the centre (radius rho:
    the same surface point, rho farther), the area equals ``projected_area`` in the shape's own
    frame, and the impulse is impulse_per_area x area along centre -> point."""
    rng = np.random.default_rng(5)
    w = _free_world()
    shapes = [tb.Capsule(0.2, 0.6), tb.Cylinder(0.25, 0.5), tb.Cone(0.3, 0.6), tb.Ellipsoid(radii=(0.35, 0.15, 0.25)),
              tb.Convex(points=rng.normal(size=(12, 3)) * 0.25),
              tb.Compound([(tb.Box(size=(0.2, 0.2, 0.2)), (0.3, 0, 0), (1, 0, 0, 0)),
                           (tb.Sphere(0.15), (-0.3, 0, 0), (1, 0, 0, 0))])]
    for i, s in enumerate(shapes):
        ang = 2 * np.pi * i / len(shapes)
        w.add_body(s, mass=1.0, position=(2 * np.cos(ang), 2 * np.sin(ang), 0.3 * i - 0.7),
                   euler_deg=tuple(rng.uniform(-180, 180, 3)), name=f"b{i}")
    rho = 1e-3
    probe = w.add_body(tb.Sphere(rho), mass=1.0, position=(0.05, -0.02, 0.1), name="probe")
    c = probe.x.copy()
    before = blast(w, tb.Explosion(position=c, radius=10.0, impulse_per_area=3.0, mask=1))
    rows = before.body != probe.index
    from tumble.collision.raycast import kept_scene

    table = kept_scene(w).table
    for k in np.flatnonzero(rows):
        s = before.shape[k]
        if not isinstance(shapes[before.body[k]], tb.Compound):  # a compound's pair gives its nearest part only
            cp = w.closest_points(probe.index, int(before.body[k]))
            assert before.distance[k] == pytest.approx(cp.distance[0] + rho, abs=1e-9)
            np.testing.assert_allclose(before.point[k], cp.point_b[0], atol=1e-8)
        u = (before.point[k] - c) / np.linalg.norm(before.point[k] - c)
        from tumble.collision.distance import shape_poses

        rot = shape_poses(w)[2][s]
        verts = None
        if table.shape_type[s] == SHAPE_CONVEX:
            v0, nv = table.shape_data[s, :2]
            verts = table.hull_vertex[v0:v0 + nv]
        assert before.area[k] == pytest.approx(projected_area(int(table.shape_type[s]), table.shape_params[s], verts,
                                                              rot.T @ u), rel=1e-12)
        np.testing.assert_allclose(before.impulse[k], 3.0 * before.area[k] * u, rtol=1e-12)
    compound = int(np.flatnonzero([isinstance(s, tb.Compound) for s in shapes])[0])
    assert np.sum(before.body == compound) == 2  # each part takes its own push


def test_falloff_fades_the_push_linearly_and_nothing_past_the_reach():
    """Three equal spheres whose surfaces are at radius / 2 (full push), in the middle of the
    falloff (half) and just past radius + falloff (none), on the three axes."""
    w = _free_world()
    radius, falloff, r = 1.0, 2.0, 0.1
    gaps = [0.5, radius + 0.5 * falloff, radius + falloff + 1e-6]
    for i, g in enumerate(gaps):
        w.add_body(tb.Sphere(r), mass=1.0, position=(g + r) * np.eye(3)[i], name=f"s{i}")  # along x, y, z
    c = np.array([0.0, 0.0, 0.0])
    res = w.explode(c, radius=radius, impulse_per_area=1.0, falloff=falloff)
    full = math.pi * r * r
    assert list(res.body) == [0, 1]
    # each sphere's push is along its own centre line; its size is the area times the ramp
    assert np.linalg.norm(res.impulse[0]) == pytest.approx(full, rel=1e-9)
    assert np.linalg.norm(res.impulse[1]) == pytest.approx(0.5 * full, rel=1e-9)
    assert np.all(w.P[2] == 0.0)


def test_a_symmetric_ring_keeps_zero_momentum_and_an_implosion_pulls_in():
    """Eight equal boxes on a circle around the centre, each turned to face it: equal radial
    pushes, so the total linear momentum stays zero (to round-off) and each box's angular
    momentum too (the push goes through its centre); with a negative impulse_per_area they move
    inwards."""
    for sign in (1.0, -1.0):
        w = _free_world()
        for i in range(8):
            ang = 2 * np.pi * i / 8
            w.add_body(tb.Box(size=(0.2, 0.4, 0.3)), mass=1.5, position=(np.cos(ang), np.sin(ang), 0.0),
                       euler_deg=(0, 0, np.degrees(ang)), name=f"b{i}")
        res = w.explode((0, 0, 0), radius=2.0, impulse_per_area=sign * 5.0)
        assert len(res) == 8
        np.testing.assert_allclose(w.P.sum(axis=0), 0.0, atol=1e-13)
        np.testing.assert_allclose(w.L, 0.0, atol=1e-13)
        radial = np.einsum("ij,ij->i", w.v, w.x / np.linalg.norm(w.x, axis=1, keepdims=True))
        np.testing.assert_allclose(radial, sign * 5.0 * 0.4 * 0.3 / 1.5, rtol=1e-12)


def test_only_dynamic_bodies_in_the_mask_are_pushed():
    """Fixed, kinematic and sensor bodies are never pushed; a body whose category misses the mask
    is spared; a body whose shape lies across the centre is pushed from its centre of mass."""
    w = _free_world()
    w.add_body(tb.Plane(normal=(0, 0, 1), offset=-1.0), fixed=True, name="ground")
    w.add_body(tb.Box(size=(0.5, 0.5, 0.5)), fixed=True, position=(1, 0, 0), name="wall")
    w.add_body(tb.Box(size=(0.5, 0.5, 0.5)), kinematic=True, position=(-1, 0, 0), name="platform")
    w.add_body(tb.Box(size=(0.5, 0.5, 0.5)), mass=1.0, sensor=True, position=(0, 1, 0), name="zone")
    spared = w.add_body(tb.Sphere(0.2), mass=1.0, position=(0, -1, 0), name="spared",
                        collision_filter=tb.CollisionFilter(category=2))
    hit = w.add_body(tb.Sphere(0.2), mass=1.0, position=(0, 0, 1), name="hit")
    across = w.add_body(tb.Box(size=(1.0, 1.0, 1.0)), mass=1.0, position=(0.2, 0.0, -0.1), name="across")
    P0 = w.P.copy()
    res = w.explode((0, 0, 0), radius=3.0, impulse_per_area=1.0, mask=1)
    assert sorted(res.body.tolist()) == [hit.index, across.index]
    untouched = np.ones(w.body_count, bool)
    untouched[[hit.index, across.index]] = False
    np.testing.assert_array_equal(w.P[untouched], P0[untouched])
    assert np.all(spared.v == 0)
    k = int(np.flatnonzero(res.body == across.index)[0])
    assert res.distance[k] < 0
    np.testing.assert_array_equal(res.point[k], across.x)
    u = across.x / np.linalg.norm(across.x)
    np.testing.assert_allclose(res.impulse[k], 1.0 * (np.abs(u).sum()) * u, rtol=1e-12)  # unit cube: A = |ux|+|uy|+|uz|
    np.testing.assert_allclose(across.omega, 0.0, atol=1e-15)  # pushed through its centre of mass


def test_a_timed_explosion_acts_at_its_step_on_the_pose_of_that_step():
    """A ``tb.Explosion`` record at time t acts before the first step starting at or after t (as
    an ``Impulse``), on the poses of that moment: a sphere drifting at constant velocity takes
    the push an explosion now would give it at that pose, and its velocity changes by J / m."""
    def world():
        w = _free_world()
        w.add_body(tb.Sphere(0.25), mass=2.0, position=(1.0, 0.0, 0.0), velocity=(0.5, 0.2, 0.0), name="ball")
        return w

    dt, t_blast = 1 / 240, 0.1
    w = world()
    w.add_force(tb.Explosion(position=(0, 0, 0), radius=3.0, impulse_per_area=4.0, time=t_blast))
    sim = tb.Simulator(w, dt=dt)
    step = math.ceil(t_blast / dt - 1e-9)
    sim.step(step)
    x_at = w.x[0].copy()
    v_before = w.v[0].copy()
    sim.step(1)

    ref = world()
    tb.Simulator(ref, dt=dt).step(step)
    np.testing.assert_array_equal(ref.x[0], x_at)
    res = ref.explode((0, 0, 0), radius=3.0, impulse_per_area=4.0)
    np.testing.assert_allclose(w.v[0], v_before + res.impulse[0] / 2.0, rtol=1e-12)
    # and the record is applied once: later steps keep the velocity
    v_after = w.v[0].copy()
    sim.step(10)
    np.testing.assert_allclose(w.v[0], v_after, rtol=1e-12)


def test_an_explosion_wakes_a_sleeping_stack_and_blows_it_away():
    """A stack of three boxes falls asleep on the ground; an explosion beside it at 2 s wakes it and
    every box moves away from the centre (its x grows by over 1 cm in 0.1 s), while no box sinks
    into the ground."""
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    for i in range(3):
        w.add_body(tb.Box(size=(0.3, 0.3, 0.3)), mass=1.0, position=(0, 0, 0.15 + 0.3 * i), name=f"box{i}")
    w.add_force(tb.Explosion(position=(-1.0, 0.0, 0.45), radius=1.0, falloff=1.0, impulse_per_area=20.0, time=2.0))
    sim = tb.Simulator(w, dt=1 / 240)
    sim.step(int(1.99 * 240))
    assert sim._sleep_state() is not None and not sim._sleep_state().awake[1:].any()  # asleep before
    x0 = w.x[1:].copy()
    sim.step(int(0.11 * 240))
    assert np.all(w.x[1:, 0] - x0[:, 0] > 0.01)
    assert w.x[1:, 2].min() > 0.15 - 0.005


def test_bad_explosions_are_one_line():
    with pytest.raises(InputError, match="radius"):
        tb.Explosion(position=(0, 0, 0), radius=-1.0, impulse_per_area=1.0)
    with pytest.raises(InputError, match="reaches nothing"):
        tb.Explosion(position=(0, 0, 0), radius=0.0, impulse_per_area=1.0)
    with pytest.raises(InputError, match="impulse_per_area"):
        tb.Explosion(position=(0, 0, 0), radius=1.0, impulse_per_area=float("nan"))
    with pytest.raises(InputError, match="mask"):
        tb.Explosion(position=(0, 0, 0), radius=1.0, impulse_per_area=1.0, mask=-1)
    with pytest.raises(InputError, match="position"):
        tb.World().explode((0, 0), radius=1.0, impulse_per_area=1.0)
    w = tb.World()
    e = w.add_force(tb.Explosion(position=(0, 0, 0), radius=1.0, impulse_per_area=1.0))
    with pytest.raises(InputError, match="explosion cannot be removed"):
        w.remove_force(e)


SCENE = """
[simulation]
duration = 0.5
gravity = [0, 0, 0]
[[bodies]]
name = "ball"
shape = {type = "sphere", radius = 0.2}
mass = 1.0
[[forces]]
type = "explosion"
position = [-1, 0, 0]
EXTRA
"""


@pytest.mark.parametrize("extra, problem", [
    ("radius = 2\nimpulse_per_area = 3\nfalloff = 1\ntime = 0.2\nmask = 1", None),
    ("radius = -2\nimpulse_per_area = 3", "forces[0].radius: must be >= 0, got -2"),
    ("radius = 2", "forces[0]: missing key 'impulse_per_area'"),
    ("radius = 2\nimpulse_per_area = 3\nmask = 4294967296", "forces[0].mask: must be between 0 and 0xffffffff"),
    ("radius = 0\nimpulse_per_area = 3", "forces[0].radius: radius + falloff must be positive"),
])
def test_scene_files_take_explosions(tmp_path, extra, problem):
    path = tmp_path / "blast.toml"
    path.write_text(SCENE.replace("EXTRA", extra))
    if problem is None:
        scene = tb.load_scene(path)
        traj = scene.run(progress=False)
        assert traj.velocity[-1, 0, 0] == pytest.approx(3 * math.pi * 0.2 ** 2, rel=1e-12)  # J / m, m = 1
        return
    with pytest.raises(InputError) as err:
        tb.load_scene(path)
    assert str(err.value).startswith(f"{path}: {problem}")
    assert "\n" not in str(err.value)


def _blast_world():
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    for i in range(3):
        w.add_body(tb.Box(size=(0.3, 0.3, 0.3)), mass=1.0, position=(0.4 * i, 0, 0.15), name=f"box{i}")
    w.add_force(tb.Explosion(position=(-0.5, 0.1, 0.2), radius=0.5, falloff=1.0, impulse_per_area=30.0, time=0.3))
    return w


def test_checkpoints_and_snapshots_keep_a_pending_or_spent_explosion(tmp_path):
    """A run with an explosion at 0.3 s, split at 0.2 s (pending) by a checkpoint file and by a
    snapshot, and at 0.4 s (spent) by a snapshot: each continuation ends with the whole run's
    state hash (bit for bit), and a spent explosion is not applied again."""
    from tumble.checks import state_hash

    dt = 1 / 240
    whole = tb.Simulator(_blast_world(), dt=dt)
    whole.step(144)
    expected = state_hash(whole.world)

    part = tb.Simulator(_blast_world(), dt=dt)
    part.step(48)
    part.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    resumed.step(96)
    assert state_hash(resumed.world) == expected

    for split in (48, 96):
        sim = tb.Simulator(_blast_world(), dt=dt)
        sim.step(split)
        saved = sim.save_state()
        sim.step(144 - split)
        assert state_hash(sim.world) == expected
        sim.restore_state(saved)
        sim.step(144 - split)
        assert state_hash(sim.world) == expected


def test_sweeps_do_not_batch_variants_with_an_explosion(tmp_path):
    """Batched variants share one World: an explosion would reach every variant's bodies (and a
    merged world of spheres at one place would be hit as one). The same scene batches without it."""
    from tumble.scene import parse_scene
    from tumble.sweep.batch import batch_key

    import tomllib

    data = tomllib.loads(SCENE.replace("EXTRA", "radius = 2\nimpulse_per_area = 3"))
    assert batch_key(parse_scene(data)) is None
    data.pop("forces")
    assert batch_key(parse_scene(data)) is not None


def test_the_blast_kernel_compiles_the_closest_point_routines_for_no_literal_shape_type():
    """The blast's centre is a point (a sphere of radius 0) whose type goes to ``convex_to_shape``
    as an int64: as the literal SHAPE_SPHERE it compiled ``convex_to_shape``, ``convex_distance``,
    GJK and EPA once more (found by the closest points' own literal test in the suite)."""
    from tumble.collision import distance

    w = _free_world()
    w.add_body(tb.Box(size=(0.5, 0.5, 0.5)), mass=1.0, position=(1.0, 0, 0))
    assert len(w.explode((0, 0, 0), radius=2.0, impulse_per_area=1.0)) == 1
    for routine in (distance.convex_to_shape, distance.convex_distance):
        literal = [sig for sig in routine.signatures if any("Literal" in str(t) for t in sig)]
        assert not literal, (routine.__name__, literal)


def _shelter():
    """A fixed wall (0.2 m thick, 2 m square) between the blast at the origin and a brick behind
    it at x = 2; a second brick in the open at y = 3."""
    w = _free_world()
    w.add_body(tb.Box(size=(0.2, 2.0, 2.0)), fixed=True, position=(1.0, 0.0, 0.0), name="wall")
    w.add_body(tb.Box(size=(0.2, 0.4, 0.2)), mass=1.0, position=(2.0, 0.0, 0.0), name="hidden")
    w.add_body(tb.Box(size=(0.2, 0.4, 0.2)), mass=1.0, position=(0.0, 3.0, 0.0), name="open")
    return w


def test_a_shaded_blast_spares_what_stands_behind_a_wall():
    """Unshaded (Box2D's rule), the brick behind the wall takes its whole push; shaded, none: all
    six rays to it meet the wall first. The brick in the open takes the same push either way, to
    the bit (every ray reaches it)."""
    plain, shaded = _shelter(), _shelter()
    a = plain.explode((0, 0, 0), radius=4.0, impulse_per_area=10.0)
    b = shaded.explode((0, 0, 0), radius=4.0, impulse_per_area=10.0, shaded=True)
    hidden, open_ = plain.index_of("hidden"), plain.index_of("open")
    assert np.linalg.norm(plain.P[hidden]) > 0.5  # 10 N s/m^2 on its 0.08 m^2 shadow: 0.8 N s
    np.testing.assert_array_equal(shaded.P[hidden], 0.0)
    np.testing.assert_array_equal(shaded.P[open_], plain.P[open_])
    assert len(a) == len(b) == 2


def test_a_brick_half_behind_a_block_takes_part_of_its_push():
    """A brick whose lower half is hidden by a block between it and the blast takes some of its
    push but not all: strictly between 0 and the unshaded impulse (six rays: the coarse shadow of
    ``visible_fraction``)."""
    def world():
        w = _free_world()
        w.add_body(tb.Box(size=(0.2, 1.0, 0.4)), fixed=True, position=(1.0, 0.0, -0.2), name="block")
        w.add_body(tb.Box(size=(0.2, 0.4, 0.4)), mass=1.0, position=(2.0, 0.0, 0.0), name="brick")
        return w

    plain, shaded = world(), world()
    a = plain.explode((0, 0, 0), radius=4.0, impulse_per_area=10.0)
    b = shaded.explode((0, 0, 0), radius=4.0, impulse_per_area=10.0, shaded=True)
    ratio = np.linalg.norm(b.impulse[0]) / np.linalg.norm(a.impulse[0])
    assert 0.0 < ratio < 1.0


def test_a_timed_shaded_explosion_shades_with_the_poses_of_its_step():
    """A shaded ``tb.Explosion`` at t = 0.1 s in a run of free bodies (the compiled loop: the
    World's arrays still hold the call's start; the rays must be cast at the state's poses): a
    heavy shield slides in front of a brick by then, and the brick takes nothing, as
    ``World.explode(shaded=True)`` gives at that moment; unshaded it would be pushed. (Cast at the
    call's start, the shield would be aside and the brick pushed: checked.)"""
    def world():
        w = _free_world()
        w.add_body(tb.Box(size=(0.2, 0.4, 0.2)), mass=1.0, position=(2.0, 0.0, 0.0), name="brick")
        w.add_body(tb.Box(size=(0.2, 1.5, 1.5)), mass=100.0, position=(1.0, 2.5, 0.0), velocity=(0.0, -25.0, 0.0),
                   name="shield")  # in front of the brick at 0.1 s
        w.collisions = False
        return w

    dt, t_blast = 1 / 240, 0.1
    w = world()
    w.add_force(tb.Explosion(position=(0, 0, 0), radius=4.0, impulse_per_area=10.0, time=t_blast, shaded=True))
    sim = tb.Simulator(w, dt=dt)
    step = math.ceil(t_blast / dt - 1e-9)
    sim.step(step + 1)
    ref = world()
    tb.Simulator(ref, dt=dt).step(step)
    plain = world()
    tb.Simulator(plain, dt=dt).step(step)
    i = ref.index_of("brick")
    assert np.linalg.norm(plain.explode((0, 0, 0), radius=4.0, impulse_per_area=10.0).impulse[0]) > 0.5
    res = ref.explode((0, 0, 0), radius=4.0, impulse_per_area=10.0, shaded=True)
    assert i not in list(res.body[np.linalg.norm(res.impulse, axis=1) > 0])
    np.testing.assert_array_equal(w.P[i], 0.0)
