"""``World.shape_cast`` and ``World.overlap_shape`` (collision/shape_query.py) against answers that use
no GJK, EPA or advancement:

- a sphere cast at a sphere, and any shape cast straight at a tilted plane: closed forms;
- any convex shape cast at any convex body: the first contact of A moved by t u with B is where the
  ray t u enters the Minkowski difference D = B - A, t* = max over directions n with u . n < 0 of
  h_D(n) / (u . n), h_D(n) = h_B(n) + h_A(-n) from the shapes' support functions in closed form
  (maximised by Nelder-Mead from the best of 1000 spread directions);
- a ball dropped on a heightfield: bisection on the distance of its centre to the triangles
  (the same plain NumPy point-triangle distance as test_closest_points.py);
- overlaps: the closed-form distance of a point to a box.

Tolerances: the cast stops within CAST_TOLERANCE = 1e-9 m of touching, approaching at a closing
speed here no less than a tenth of the translation's length, so the fraction is right to 1e-8 of
it (the comparisons take 1e-8 m along the path), where the distances it advances on are exact:
planes, spheres, capsules, boxes and hulls. Where the contact is on a cylinder's or cone's curved
rim or side, GJK near contact is the limit: on a curved core it closes in linearly and stops on
round-off (its stopping test's floor, 1e-13 |w|^2, is a relative 1e-13 / |v|: loose at gaps of
1e-7 m) with the distance up to 1e-7 m off; measured: the fraction up to 1.4e-7 m along the path
from the exact one, either side. CURVED_PATH_TOL is twice that.
"""

from __future__ import annotations

import numpy as np
import pytest

import tumble as tb
from tumble.errors import InputError
from tumble.math3d import matrix_to_quat

from .helpers import random_rotation, rot
from .test_closest_points import _point_surface_distance, _support_value

PATH_TOL = 1e-8  # m along the translation
CURVED_PATH_TOL = 3e-7  # m, where a cylinder's or cone's curved surface makes the contact (module docstring)


def _world():
    return tb.World(gravity=(0, 0, 0))


def test_a_sphere_cast_at_a_sphere_touches_where_the_centres_are_the_radii_apart():
    rng = np.random.default_rng(1)
    w = _world()
    w.add_body(tb.Sphere(0.5), mass=1, position=(0.2, -0.1, 0.3), name="target")
    c = np.array([0.2, -0.1, 0.3])
    starts = rng.normal(size=(20, 3)) * 3
    aims = c + rng.normal(size=(20, 3)) * 0.3
    trans = (aims - starts) * 2.0  # past the target
    h = w.shape_cast(tb.Sphere(0.25), starts, trans)
    assert h.hit.all()
    for k in range(20):
        # |s + t u - c| = 0.75: the smaller root
        u, oc = trans[k], starts[k] - c
        a, b, cc = u @ u, 2 * u @ oc, oc @ oc - 0.75 ** 2
        t = (-b - np.sqrt(b * b - 4 * a * cc)) / (2 * a)
        assert h.fraction[k] * np.linalg.norm(u) == pytest.approx(t * np.linalg.norm(u), abs=PATH_TOL)
        at = starts[k] + t * u
        np.testing.assert_allclose(h.position[k], at, atol=PATH_TOL)
        n = (at - c) / 0.75
        np.testing.assert_allclose(h.normal[k], n, atol=1e-7)
        np.testing.assert_allclose(h.point[k], c + 0.5 * n, atol=1e-7)


@pytest.mark.parametrize("shape", [tb.Box(size=(0.4, 0.6, 0.8)), tb.Cylinder(0.3, 0.8), tb.Capsule(0.2, 0.5),
                                   tb.Cone(0.3, 0.6), tb.Ellipsoid(radii=(0.35, 0.15, 0.25))])
def test_shapes_cast_down_onto_a_tilted_plane(shape):
    """The plane through the origin with normal n: a shape's lowest point along n is its support
    along -n; moved by t u it touches when that point's height h0 + t u . n reaches 0."""
    rng = np.random.default_rng(2)
    n = np.array([0.2, -0.3, 1.0])
    n /= np.linalg.norm(n)
    w = _world()
    Rp = rot(np.cross([0, 0, 1], n), np.arccos(n[2]))  # +z onto n
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, orientation=matrix_to_quat(Rp), name="ground")
    kind = type(shape).__name__.lower()
    dims = {"box": np.array([0.2, 0.3, 0.4]), "cylinder": np.array([0.3, 0.8]), "capsule": np.array([0.2, 0.5]),
            "cone": np.array([0.3, 0.6]), "ellipsoid": np.array([0.35, 0.15, 0.25])}[kind]
    for trial in range(10):
        R = random_rotation(rng)
        start = rng.uniform(-1, 1, 3) + (0, 0, 3)
        trans = np.array([rng.uniform(-1, 1), rng.uniform(-1, 1), -6.0])
        h = w.shape_cast(shape, start, trans, orientation=matrix_to_quat(R))
        h0 = -_support_value(kind, dims, start, R, -n)  # the lowest point's height above the plane
        t = h0 / -(trans @ n)
        assert h.body[0] == 0
        assert h.fraction[0] * np.linalg.norm(trans) == pytest.approx(t * np.linalg.norm(trans), abs=PATH_TOL)
        np.testing.assert_allclose(h.normal[0], n, atol=1e-12)
        assert n @ h.point[0] == pytest.approx(0.0, abs=PATH_TOL)


def _minkowski_entry(fa, fb, u):
    """First t with t u in D = B - A (module docstring): max over n with u . n < 0 of
    (h_B(n) + h_A(-n)) / (u . n), by Nelder-Mead on the sphere of directions."""
    from scipy.optimize import minimize

    def g(n):
        un = u @ n
        return (fb(n) + fa(-n)) / un if un < -1e-12 else -np.inf

    def unit(a):
        return np.array([np.sin(a[0]) * np.cos(a[1]), np.sin(a[0]) * np.sin(a[1]), np.cos(a[0])])

    k = np.arange(1000) + 0.5
    theta, phi = np.arccos(1 - 2 * k / 1000), np.pi * (1 + 5 ** 0.5) * k
    vals = np.array([g(unit((t, p))) for t, p in zip(theta, phi)])
    best = -np.inf
    for i in np.argsort(-vals)[:6]:
        r = minimize(lambda a: -g(unit(a)), (theta[i], phi[i]), method="Nelder-Mead",
                     options=dict(xatol=1e-12, fatol=1e-15, maxiter=4000))
        best = max(best, -r.fun)
    return best


KINDS = ("box", "capsule", "cylinder", "cone", "ellipsoid", "hull")


@pytest.mark.parametrize("pair", [(a, b) for a in KINDS for b in KINDS if KINDS.index(a) <= KINDS.index(b)])
def test_every_convex_cast_against_the_minkowski_difference(pair):
    rng = np.random.default_rng(sum(map(ord, "cast" + "".join(pair))))
    make = {"box": lambda: (tb.Box(size=(0.5, 0.3, 0.7)), np.array([0.25, 0.15, 0.35])),
            "capsule": lambda: (tb.Capsule(0.15, 0.5), np.array([0.15, 0.5])),
            "cylinder": lambda: (tb.Cylinder(0.25, 0.6), np.array([0.25, 0.6])),
            "cone": lambda: (tb.Cone(0.3, 0.6), np.array([0.3, 0.6])),
            "ellipsoid": lambda: (tb.Ellipsoid(radii=(0.35, 0.15, 0.25)), np.array([0.35, 0.15, 0.25])),
            "hull": lambda: (tb.Convex(points=rng.normal(size=(12, 3)) * 0.25), None)}
    moving, dims_a = make[pair[0]]()
    target, dims_b = make[pair[1]]()
    if dims_a is None:
        dims_a = np.asarray(moving.vertices)
    w = _world()
    w.add_body(target, mass=1, name="b")
    from tumble.collision.raycast import kept_scene

    table = kept_scene(w).table
    if dims_b is None:
        dims_b = table.hull_vertex[table.shape_data[0, 0]:table.shape_data[0, 0] + table.shape_data[0, 1]]
    for trial in range(4):
        w.body("b").R = random_rotation(rng)
        w.body("b").x = rng.normal(size=3) * 0.1
        origin_b = w.x[0] + w.R[0] @ table.shape_local_pos[0]
        Ra = random_rotation(rng)
        start = rng.normal(size=3)
        start *= 2.0 / np.linalg.norm(start)
        trans = (origin_b + rng.normal(size=3) * 0.1 - start) * 1.5
        h = w.shape_cast(moving, start, trans, orientation=matrix_to_quat(Ra))
        t = _minkowski_entry(lambda n: _support_value(pair[0], dims_a, start, Ra, n),
                             lambda n: _support_value(pair[1], dims_b, origin_b, w.R[0], n), trans)
        L = np.linalg.norm(trans)
        tol = CURVED_PATH_TOL if {"cylinder", "cone", "ellipsoid"} & set(pair) else PATH_TOL
        assert h.body[0] == 0, trial
        assert h.fraction[0] * L == pytest.approx(t * L, abs=tol), trial
        # there, the two touch: the moved shape, added as a body, is at distance 0 (to the same tolerance)
        placed = tb.World(gravity=(0, 0, 0))
        b = placed.add_body(target, mass=1)
        b.R, b.x = w.R[0], w.x[0]
        q = placed.add_body(moving, mass=1)
        q.R = Ra
        placed_table = kept_scene(placed).table
        q.x = h.position[0] - Ra @ placed_table.shape_local_pos[int(np.flatnonzero(placed_table.shape_body == 1)[0])]
        gap = placed.closest_points(0, 1).distance[0]
        assert abs(gap) <= tol, gap


def test_a_ball_dropped_on_a_heightfield():
    rng = np.random.default_rng(6)
    w = _world()
    w.add_body(tb.heightfield(rng.uniform(0.0, 0.4, size=(6, 6)), size=(3.0, 3.0)), fixed=True, name="terrain")
    from tumble.collision.raycast import kept_scene

    table = kept_scene(w).table
    t0, nt = table.shape_data[0, :2]
    V = (table.mesh_triangle[t0:t0 + nt] + table.shape_local_pos[0]).reshape(-1, 3)
    T = np.arange(len(V)).reshape(-1, 3)
    r = 0.2
    for trial in range(8):
        start = np.array([*rng.uniform(-1.1, 1.1, 2), 2.0])
        trans = np.array([*rng.uniform(-0.3, 0.3, 2), -3.0])
        h = w.shape_cast(tb.Sphere(r), start, trans)

        def gap(t):
            return _point_surface_distance((start + t * trans)[None, :], V, T)[0] - r

        ts = np.linspace(0, 1, 2001)
        first = next(i for i, t in enumerate(ts) if gap(t) <= 0)
        lo, hi = ts[first - 1], ts[first]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if gap(mid) > 0 else (lo, mid)
        L = np.linalg.norm(trans)
        assert h.body[0] == 0 and h.fraction[0] * L == pytest.approx(lo * L, abs=PATH_TOL)


def test_a_shape_already_touching_hits_at_zero_and_one_moving_away_never():
    w = _world()
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1, name="box")
    h = w.shape_cast(tb.Sphere(0.3), position=[(0.6, 0, 0), (0.9, 0, 0)], translation=[(1, 0, 0), (1, 0, 0)])
    assert h.fraction[0] == 0.0 and h.body[0] == 0  # 0.2 m deep at the start
    np.testing.assert_allclose(h.normal[0], [1, 0, 0], atol=1e-12)  # out of the box
    assert h.body[1] == -1 and np.isinf(h.fraction[1]) and np.isnan(h.point[1]).all()


def test_filters_exclude_and_sensors():
    w = _world()
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1, position=(2, 0, 0), name="near",
               collision_filter=tb.CollisionFilter(category=2))
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1, position=(4, 0, 0), name="far")
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1, position=(1, 0, 0), sensor=True, name="zone")
    cast = lambda **kw: w.shape_cast(tb.Sphere(0.1), (0, 0, 0), (10, 0, 0), **kw).body[0]  # noqa: E731
    assert cast() == w.index_of("near")  # the sensor is never seen
    assert cast(exclude="near") == w.index_of("far")
    assert cast(mask=1) == w.index_of("far")
    assert list(w.overlap_shape(tb.Sphere(0.1), (1.0, 0, 0))) == []  # only the sensor there
    assert list(w.overlap_shape(tb.Sphere(0.6), (1.0, 0, 0))) == [w.index_of("near")]
    assert list(w.overlap_shape(tb.Sphere(0.6), (1.0, 0, 0), exclude="near")) == []


def test_overlap_against_the_distance_of_a_point_to_boxes():
    rng = np.random.default_rng(9)
    w = _world()
    boxes = []
    for k in range(30):
        R = random_rotation(rng)
        x = rng.uniform(-2, 2, 3)
        half = rng.uniform(0.1, 0.4, 3)
        w.add_body(tb.Box(size=2 * half), mass=1, position=x, orientation=matrix_to_quat(R))
        boxes.append((x, w.R[k].copy(), half))
    for trial in range(40):
        p, r = rng.uniform(-2, 2, 3), rng.uniform(0.05, 0.5)
        expect = []
        for k, (x, R, half) in enumerate(boxes):
            local = R.T @ (p - x)
            d = np.linalg.norm(local - np.clip(local, -half, half))
            if d <= r:
                expect.append(k)
        assert list(w.overlap_shape(tb.Sphere(r), p)) == expect


def test_many_casts_on_both_cores_give_the_serial_bits():
    from tumble.collision import shape_query

    rng = np.random.default_rng(3)
    w = _world()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    for k in range(30):
        w.add_body([tb.Box(size=(0.3, 0.2, 0.4)), tb.Cylinder(0.2, 0.5), tb.Convex(points=rng.normal(size=(10, 3)) * 0.2)][k % 3],
                   mass=1, position=rng.uniform(-2, 2, 3) + (0, 0, 2.5), orientation=matrix_to_quat(random_rotation(rng)))
    starts = rng.uniform(-2, 2, (100, 3)) + (0, 0, 6)
    trans = np.tile([0.0, 0.0, -8.0], (100, 1))
    assert len(starts) >= shape_query.PARALLEL_MIN_CASTS
    a = w.shape_cast(tb.Capsule(0.1, 0.3), starts, trans)
    keep = shape_query.PARALLEL_MIN_CASTS
    try:
        shape_query.PARALLEL_MIN_CASTS = 10 ** 9
        b = w.shape_cast(tb.Capsule(0.1, 0.3), starts, trans)
    finally:
        shape_query.PARALLEL_MIN_CASTS = keep
    np.testing.assert_array_equal(a.fraction, b.fraction)
    np.testing.assert_array_equal(a.body, b.body)
    assert (a.body == 0).any() and (a.body > 0).any()  # some reach the ground, some land on a body


def test_bad_arguments_get_one_line_naming_them():
    w = _world()
    w.add_body(tb.Sphere(0.5), mass=1, name="a")
    with pytest.raises(InputError, match="shape: must be a Sphere, Capsule, Cylinder, Cone, Box, Ellipsoid or Convex, got Plane"):
        w.shape_cast(tb.Plane(normal=(0, 0, 1)), (0, 0, 0), (1, 0, 0))
    with pytest.raises(InputError, match="orientation: must be a quaternion"):
        w.overlap_shape(tb.Sphere(0.1), (0, 0, 0), orientation=(1, 0, 0))
    with pytest.raises(InputError, match="translation: has 3 rows but position has 2"):
        w.shape_cast(tb.Sphere(0.1), np.zeros((2, 3)), np.ones((3, 3)))
    with pytest.raises(InputError, match="exclude: unknown body 'nope'"):
        w.shape_cast(tb.Sphere(0.1), (0, 0, 0), (1, 0, 0), exclude="nope")
    with pytest.raises(InputError, match="position: must be finite"):
        w.overlap_shape(tb.Sphere(0.1), (0, np.nan, 0))


# ---------------------------------------------------------------------- drop
def test_dropped_bodies_come_to_touch_what_is_below_them():
    """Boxes, a cylinder and a compound dropped one after another onto a tilted plane and onto each
    other: each moves straight along gravity and ends touching (closest-points distance 0 to the
    cast's accuracy) the body it landed on, and nothing deeper."""
    rng = np.random.default_rng(12)
    w = tb.World(gravity=(0.5, -0.3, -9.81))
    n = np.array([0.1, 0.05, 1.0])
    n /= np.linalg.norm(n)
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, orientation=matrix_to_quat(rot(np.cross([0, 0, 1], n),
                                                                                     np.arccos(n[2]))), name="ground")
    dumbbell = tb.Compound(parts=[(tb.Sphere(0.2), (-0.4, 0, 0), (1, 0, 0, 0)), (tb.Sphere(0.3), (0.4, 0, 0), (1, 0, 0, 0))])
    shapes = [tb.Box(size=(1.0, 1.0, 0.4)), tb.Box(size=(0.5, 0.4, 0.3)), tb.Cylinder(0.2, 0.4), dumbbell]
    names = []
    for k, shape in enumerate(shapes):
        names.append(f"s{k}")
        w.add_body(shape, mass=1, position=(0.05 * k, 0, 3 + 2 * k), orientation=matrix_to_quat(random_rotation(rng)) if k else None,
                   name=names[-1])
    g = w.gravity / np.linalg.norm(w.gravity)
    for name in names:
        before = w.body(name).x.copy()
        moved = w.drop(name)
        step = w.body(name).x - before
        np.testing.assert_allclose(step, moved * g, atol=1e-12)  # straight along gravity
        others = [o for o in ["ground", *names] if o != name]
        gaps = w.closest_points(name, others).distance
        assert abs(gaps.min()) <= CURVED_PATH_TOL and gaps.min() > -CURVED_PATH_TOL, (name, gaps)
    assert w.drop("s0") == pytest.approx(0.0, abs=1e-9)  # already touching: stays


def test_drop_errors():
    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    w.add_body(tb.Sphere(0.5), mass=1, position=(0, 0, 2), name="ball")
    with pytest.raises(InputError, match="drop: nothing to land on within 1000 m along"):
        w.drop("ball", direction=(0, 0, 1))
    with pytest.raises(InputError, match="drop: a body of Plane shape cannot be dropped"):
        w.drop("ground")
    with pytest.raises(InputError, match="direction: must not be zero"):
        w.drop("ball", direction=(0, 0, 0))


def test_a_scene_drops_its_bodies_in_order(tmp_path):
    """``drop = true``: after every body is made, in the file's order, each onto what is below it."""
    from tumble.scene import load_scene

    path = tmp_path / "stack.toml"
    path.write_text('''[[bodies]]
name = "ground"
shape = { type = "plane" }
fixed = true

[[bodies]]
name = "lower"
shape = { type = "box", size = [0.6, 0.6, 0.2] }
mass = 1
position = [0, 0, 5]
euler_deg = [10, 0, 0]
drop = true

[[bodies]]
name = "upper"
shape = { type = "convex", points = [[0, 0, 0], [0.3, 0, 0], [0, 0.3, 0], [0, 0, 0.3], [0.2, 0.2, 0.2]] }
mass = 1
position = [0.05, 0.05, 9]
drop = true
''')
    scene = load_scene(path)
    w = scene.world
    assert abs(w.closest_points("lower", "ground").distance[0]) <= PATH_TOL
    assert abs(w.closest_points("upper", "lower").distance[0]) <= PATH_TOL
    assert w.x[w.index_of("upper"), 2] < 1.0 and w.x[w.index_of("lower"), 2] < 0.5
