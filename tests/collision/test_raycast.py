"""Ray casts (``World.ray_cast``, ``collision.raycast``) against closed forms and brute force.

Two kinds of check:
- analytic: rays whose first hit is known by hand (a cube's top, a sphere's side, a cone's
  slant), to 1e-12 m: the routines are closed forms in float64, so any error above round-off
  is a wrong formula;
- brute force: random rays at random poses, each hit checked against an independent membership
  test written here in NumPy (SciPy's ConvexHull for hulls, all triangles for meshes): no
  sampled point of the ray before the hit is inside the shape, the points just past the hit and
  just behind its normal are inside, the point just outside the normal is not; and a miss has no
  sampled point inside. Samples are 2000 per ray, so only slivers thinner than ~1/2000 of the
  ray could hide (the analytic tests cover grazing hits).
"""

import numpy as np
import pytest
from scipy.spatial import ConvexHull

import tumble as tb
from tumble.collision.raycast import ray_cast
from tumble.errors import InputError
from tumble.math3d import quat_to_matrix

from .test_mesh import heightfield


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


# ---------------------------------------------------------------------- analytic
def test_rays_straight_down_meet_each_shape_at_its_top():
    """Rays down the z axis above each shape type: hit at the top (box, sphere, capsule, cylinder:
    centre + half height; cone: apex at base + H; plane: its height), normal +z except the cone's
    apex (+z too, by the rule for the apex)."""
    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1), offset=-1.0), fixed=True)
    shapes = [tb.Box(size=(1, 2, 3)), tb.Sphere(radius=0.7), tb.Capsule(radius=0.3, length=1.0),
              tb.Cylinder(radius=0.4, length=1.2), tb.Cone(radius=0.5, height=1.5)]
    tops = [1.5, 0.7, 0.5 + 0.3, 0.6, 1.5]
    for i, s in enumerate(shapes):
        w.add_body(s, mass=1.0, position=(3.0 * i, 0, 2))
    origin = [(3.0 * i, 0, 10) for i in range(len(shapes))] + [(50, 0, 10)]
    hits = w.ray_cast(origin, (0, 0, -1))
    assert list(hits.body) == [1, 2, 3, 4, 5, 0]
    np.testing.assert_allclose(hits.distance, [8 - t for t in tops] + [11.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(hits.normal, np.tile([0, 0, 1.0], (6, 1)), atol=1e-12)
    np.testing.assert_allclose(hits.point[:, 2], 10 - hits.distance, atol=1e-12)


def test_sideways_rays_meet_the_curved_surfaces_where_geometry_says():
    """A sphere, cylinder, capsule and cone hit from the side, off their axes: distance and
    normal from the circle the ray's line cuts (d = offset from the axis: x = sqrt(r^2 - d^2));
    the cone at height z has radius r (1 - z / H) and normal (cos, sin, r / H) / sqrt(1 + (r/H)^2)."""
    w = tb.World()
    w.add_body(tb.Sphere(radius=1.0), mass=1.0, position=(0, 0, 0))
    w.add_body(tb.Cylinder(radius=0.5, length=2.0), mass=1.0, position=(0, 10, 0))
    w.add_body(tb.Capsule(radius=0.5, length=2.0), mass=1.0, position=(0, 20, 0))
    w.add_body(tb.Cone(radius=1.0, height=2.0), mass=1.0, position=(0, 30, 0))
    off = 0.3
    hits = w.ray_cast([(-5, off, 0), (-5, 10 + off, 0.4), (-5, 20 + off, -0.9), (-5, 30 + off, 0.5)], (1, 0, 0))
    assert list(hits.body) == [0, 1, 2, 3]
    r_cone = 1.0 * (1 - 0.5 / 2.0)
    xs = [np.sqrt(1.0 - off ** 2), np.sqrt(0.25 - off ** 2), np.sqrt(0.25 - off ** 2), np.sqrt(r_cone ** 2 - off ** 2)]
    np.testing.assert_allclose(hits.distance, [5 - x for x in xs], rtol=0, atol=1e-12)
    np.testing.assert_allclose(hits.normal[0], [-xs[0], off, 0], atol=1e-12)
    np.testing.assert_allclose(hits.normal[1], [-xs[1] / 0.5, off / 0.5, 0], atol=1e-12)
    np.testing.assert_allclose(hits.normal[2], [-xs[2] / 0.5, off / 0.5, 0], atol=1e-12)
    k = 0.5
    np.testing.assert_allclose(hits.normal[3], np.array([-xs[3] / r_cone, off / r_cone, k]) / np.sqrt(1 + k * k),
                               atol=1e-12)


def test_capsule_end_cap_and_cylinder_cap_and_cone_base():
    """Rays along the axis from below: a capsule's lower end sphere (h + r below the centre), a
    cylinder's flat cap (normal -z), a cone's base (its shape origin, normal -z)."""
    w = tb.World()
    w.add_body(tb.Capsule(radius=0.25, length=1.0), mass=1.0, position=(0, 0, 0))
    w.add_body(tb.Cylinder(radius=0.5, length=1.0), mass=1.0, position=(5, 0, 0))
    w.add_body(tb.Cone(radius=0.5, height=1.0), mass=1.0, position=(10, 0, 0))
    hits = w.ray_cast([(0.1, 0, -5), (5.2, 0.1, -5), (10.1, 0.2, -5)], (0, 0, 1))
    assert list(hits.body) == [0, 1, 2]
    cap = np.sqrt(0.25 ** 2 - 0.1 ** 2)
    np.testing.assert_allclose(hits.distance, [5 - 0.5 - cap, 4.5, 5.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(hits.normal[0], [0.1 / 0.25, 0, -cap / 0.25], atol=1e-12)
    np.testing.assert_allclose(hits.normal[1:], [[0, 0, -1.0], [0, 0, -1.0]], atol=1e-12)


def test_rays_on_and_near_a_cones_axis_meet_its_base_from_below_and_its_apex_from_above():
    """A cone's axis is inside it from the base up to the apex, yet the quadratic of its side has
    a double root there (the apex): rays up the axis from below (and 1e-9 m, 1e-9 rad and 1e-12
    rad off it, where rounding gives the same double root) meet the base at 5 m with normal -z;
    they went through the base and hit the apex from inside at 6 m with normal +z (an audit of the
    scene queries, session 42). Down the axis from above: the apex at 4 m, normal +z. A ray
    steeper than the side through the apex from below and aside (x = 0.2 at the base, 10 degrees
    off the axis) enters by the base too. Closed forms in float64: 1e-12 m."""
    w = tb.World()
    w.add_body(tb.Cone(radius=0.5, height=1.0), fixed=True)
    tilt = np.radians(10.0)
    origins = [(0, 0, -5), (1e-9, 0, -5), (0, 0, -5), (0, 0, -5), (0, 0, 5), (0.2 - 5 * np.tan(tilt), 0, -5)]
    directions = [(0, 0, 1), (0, 0, 1), (1e-9, 0, 1), (0, 1e-12, 1), (0, 0, -1), (np.sin(tilt), 0, np.cos(tilt))]
    hits = w.ray_cast(origins, directions)
    assert list(hits.hit) == [True] * 6
    np.testing.assert_allclose(hits.distance, [5, 5, 5, 5, 4, 5 / np.cos(tilt)], rtol=0, atol=1e-12)
    np.testing.assert_allclose(hits.normal, [[0, 0, -1]] * 4 + [[0, 0, 1], [0, 0, -1]], atol=1e-12)


def test_rotated_box_and_plane_at_an_angle():
    """A unit cube turned 45 degrees about x: a ray down its middle meets the top edge at
    z = c + sqrt(2) / 2 (entering by the face that faces the ray, a normal of the two at 45
    degrees); a ray at 60 degrees from the vertical meets the ground plane z = 0 from height 3
    after 3 / cos 60 = 6 m."""
    c = np.cos(np.pi / 8)
    s = np.sin(np.pi / 8)
    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, position=(0, 0, 2), orientation=(c, s, 0, 0))
    hits = w.ray_cast([(0.2, 0.0, 10.0), (10, 0, 3)], [(0, 0, -1), (np.sin(np.pi / 3), 0, -np.cos(np.pi / 3))])
    assert list(hits.body) == [1, 0]
    np.testing.assert_allclose(hits.distance, [8 - np.sqrt(0.5), 6.0], rtol=0, atol=1e-12)
    assert abs(hits.normal[0, 2] - np.sqrt(0.5)) < 1e-12 and abs(abs(hits.normal[0, 1]) - np.sqrt(0.5)) < 1e-12


def test_the_nearest_shape_wins_and_exclude_and_max_distance_apply():
    """Five spheres on the x axis: a ray along +x meets the first; excluding it (as a Body, a name
    or per ray by index) the second; max_distance short of the first: nothing. A batch gives
    exactly the rows of the single casts."""
    w = tb.World()
    bodies = [w.add_body(tb.Sphere(radius=0.5), mass=1.0, position=(2.0 * i, 0, 0), name=f"s{i}") for i in range(5)]
    h = w.ray_cast((-10, 0, 0), (1, 0, 0))
    assert h.body[0] == 0 and abs(h.distance[0] - 9.5) < 1e-12
    for ex in (bodies[0], "s0", 0):
        h = w.ray_cast((-10, 0, 0), (1, 0, 0), exclude=ex)
        assert h.body[0] == 1 and abs(h.distance[0] - 11.5) < 1e-12
    h = w.ray_cast((-10, 0, 0), (1, 0, 0), max_distance=9.0)
    assert not h.hit[0] and h.body[0] == -1 and np.isinf(h.distance[0]) and np.all(np.isnan(h.point[0]))
    rng = np.random.default_rng(3)
    origins = rng.uniform(-12, 12, size=(40, 3))
    dirs = 2.0 * rng.integers(0, 5, size=(40, 1)) * np.array([1.0, 0, 0]) + rng.normal(scale=0.4, size=(40, 3)) - origins
    excl = rng.integers(-1, 5, size=40)
    batch = w.ray_cast(origins, dirs, max_distance=20.0, exclude=excl)
    assert batch.hit.sum() > 0
    for r in range(40):
        one = w.ray_cast(origins[r], dirs[r], max_distance=20.0, exclude=int(excl[r]) if excl[r] >= 0 else None)
        assert one.body[0] == batch.body[r] and one.distance[0] == batch.distance[r]
        assert np.array_equal(one.normal[0], batch.normal[r], equal_nan=True)


def test_one_origin_with_many_directions_and_many_origins_with_one_direction():
    """A camera: one origin, a direction per ray; and a sweep: an origin per ray, one direction."""
    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    fan = w.ray_cast((0, 0, 2), [(np.sin(a), 0, -np.cos(a)) for a in (0.0, 0.5, 1.0)])
    np.testing.assert_allclose(fan.distance, [2 / np.cos(a) for a in (0.0, 0.5, 1.0)], rtol=1e-14)
    sweep = w.ray_cast([(x, 0, 1 + x) for x in range(4)], (0, 0, -1))
    np.testing.assert_allclose(sweep.distance, [1.0, 2.0, 3.0, 4.0], rtol=1e-14)


def test_a_shape_holding_the_origin_is_not_hit_and_the_next_is():
    """Box2D's rule: a ray from inside a solid sees out of it. From the centre of a box, upward,
    the ray meets the sphere above it and not the box; from below the ground plane, nothing."""
    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, position=(0, 0, 1))
    w.add_body(tb.Sphere(radius=0.5), mass=1.0, position=(0, 0, 4))
    h = w.ray_cast([(0, 0, 1), (5, 5, -1)], [(0, 0, 1), (0, 0, 1)])
    assert list(h.body) == [2, -1]
    assert abs(h.distance[0] - 2.5) < 1e-12


def test_compound_parts_and_the_body_they_belong_to():
    """A compound of two boxes side by side (a 2 x 1 x 1 block): a ray down through the right half
    hits the right part's top, and reports the compound's body."""
    w = tb.World()
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(0, 5, 0))
    halves = tb.Compound([(tb.Box((1, 1, 1)), (0.5, 0, 0), (1, 0, 0, 0)), (tb.Box((1, 1, 1)), (-0.5, 0, 0), (1, 0, 0, 0))])
    w.add_body(halves, mass=2.0, position=(0, 0, 1))
    h = w.ray_cast([(0.7, 0, 5), (-0.3, 0.2, 5)], (0, 0, -1))
    assert list(h.body) == [1, 1]
    assert h.shape[0] != h.shape[1]
    np.testing.assert_allclose(h.distance, [3.5, 3.5], atol=1e-12)


# ---------------------------------------------------------------------- brute force
def _inside(kind, params, p):
    """(M,) bool: points p (M, 3), shape frame, inside the solid (independent of tumble)."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    if kind == "sphere":
        return np.linalg.norm(p, axis=1) <= params
    if kind == "box":
        return np.all(np.abs(p) <= params, axis=1)
    if kind == "capsule":
        r, h = params
        return x * x + y * y + (z - np.clip(z, -h, h)) ** 2 <= r * r
    if kind == "cylinder":
        r, h = params
        return (x * x + y * y <= r * r) & (np.abs(z) <= h)
    if kind == "cone":
        r, H = params
        return (z >= 0) & (z <= H) & (np.sqrt(x * x + y * y) <= r * (1 - z / H))
    if kind == "convex":
        eq = params  # SciPy's hull facets: n . p + c <= 0 inside
        return np.all(p @ eq[:, :3].T + eq[:, 3] <= 0.0, axis=1)
    raise AssertionError(kind)


CASES = {
    "sphere": (lambda rng: tb.Sphere(radius=0.6), 0.6),
    "box": (lambda rng: tb.Box(size=(0.6, 1.0, 1.6)), np.array([0.3, 0.5, 0.8])),
    "capsule": (lambda rng: tb.Capsule(radius=0.35, length=1.2), (0.35, 0.6)),
    "cylinder": (lambda rng: tb.Cylinder(radius=0.45, length=1.1), (0.45, 0.55)),
    "cone": (lambda rng: tb.Cone(radius=0.5, height=1.3), (0.5, 1.3)),
}
HULL_POINTS = np.random.default_rng(11).normal(size=(14, 3)) * np.array([0.5, 0.35, 0.6])


@pytest.mark.parametrize("kind", list(CASES) + ["convex"])
def test_random_rays_agree_with_brute_force_membership(kind):
    rng = np.random.default_rng(sum(map(ord, kind)))  # a fixed seed per shape
    if kind == "convex":
        shape, params = tb.Convex(points=HULL_POINTS), ConvexHull(HULL_POINTS).equations
    else:
        make, params = CASES[kind]
        shape = make(rng)
    hits = misses = 0
    for trial in range(12):
        q = unit(rng.normal(size=4))
        w = tb.World()
        body = w.add_body(shape, mass=1.0, position=rng.uniform(-0.5, 0.5, 3), orientation=q)
        R = quat_to_matrix(q)
        com = np.asarray(w.com_offset[body.index])

        def local(p):  # world -> shape frame: R^T (p - x) + com_offset
            return (np.atleast_2d(p) - body.x) @ R + com

        # rays from a shell around the body towards points near it: most hit, some graze or miss
        n = 60
        origin = body.x + np.array([unit(v) * 3.0 for v in rng.normal(size=(n, 3))])
        target = body.x + rng.normal(size=(n, 3)) * 0.6
        d = target - origin
        d /= np.linalg.norm(d, axis=1)[:, None]
        h = w.ray_cast(origin, d, max_distance=6.0)
        s = np.linspace(0.0, 1.0, 2000)
        for r in range(n):
            assert not _inside(kind, params, local(origin[r]))[0]
            if not h.hit[r]:
                misses += 1
                assert not np.any(_inside(kind, params, local(origin[r] + 6.0 * s[:, None] * d[r])))
                continue
            hits += 1
            t = h.distance[r]
            nrm = h.normal[r]
            assert abs(np.linalg.norm(nrm) - 1.0) < 1e-12
            assert nrm @ d[r] <= 1e-12  # the normal faces the ray
            np.testing.assert_allclose(h.point[r], origin[r] + t * d[r], atol=1e-12)
            before = origin[r] + (t - 1e-7) * s[:, None] * d[r]
            assert not np.any(_inside(kind, params, local(before))), (kind, r)
            if abs(nrm @ d[r]) > 1e-3:  # not grazing: past the hit and behind the normal is inside
                p = h.point[r]
                assert _inside(kind, params, local(p + 1e-7 * d[r]))[0], (kind, r)
                assert _inside(kind, params, local(p - 1e-7 * nrm))[0], (kind, r)
                assert not _inside(kind, params, local(p + 1e-7 * nrm))[0], (kind, r)
    assert hits > 200 and misses > 20  # both kinds of ray were exercised


def _terrain(n=12, size=4.0, seed=5):
    """A closed bumpy slab (tests/collision/test_mesh.heightfield: height field on top, flat bottom
    at z = -1, walls): meshes must be closed."""
    rng = np.random.default_rng(seed)
    return heightfield(n, size, lambda X, Y: 0.3 * rng.normal(size=X.shape))


def _brute_mesh(vertices, faces, o, d):
    """Nearest triangle along o + t d, both sides, every triangle (plain linear algebra)."""
    best = np.inf
    for f in faces:
        a, b, c = vertices[f]
        M = np.column_stack([b - a, c - a, -d])
        if abs(np.linalg.det(M)) < 1e-14:
            continue
        u, v, t = np.linalg.solve(M, o - a)
        if u >= 0 and v >= 0 and u + v <= 1 and 0 <= t < best:
            best = t
    return best


def test_mesh_terrain_against_every_triangle():
    """A bumpy static terrain (a closed slab of 624 triangles, so the BVH prunes): random rays from
    above and from below meet the same nearest triangle as a loop over all of
    them, to 1e-10 m; the normal is the triangle's, turned to face the ray."""
    vertices, faces = _terrain()
    w = tb.World()
    w.add_body(tb.Mesh(vertices=vertices, faces=faces), fixed=True, position=(1.0, -0.5, 0.2))
    rng = np.random.default_rng(8)
    n = 150
    origin = np.column_stack([rng.uniform(-0.8, 2.8, n), rng.uniform(-2.3, 1.3, n), rng.choice([-3.0, 3.0], n)])
    d = np.column_stack([rng.normal(scale=0.4, size=(n, 2)), -np.sign(origin[:, 2])])
    d /= np.linalg.norm(d, axis=1)[:, None]
    h = w.ray_cast(origin, d)
    shift = np.array([1.0, -0.5, 0.2])
    found = 0
    for r in range(n):
        t = _brute_mesh(vertices, faces, origin[r] - shift, d[r])
        if np.isinf(t):
            assert not h.hit[r]
            continue
        found += 1
        assert h.hit[r] and abs(h.distance[r] - t) < 1e-10
        assert h.normal[r] @ d[r] < 0
    assert found > 100


@pytest.mark.parametrize("kwargs, key", [
    (dict(origin=(0, 0), direction=(1, 0, 0)), "origin"),
    (dict(origin=(0, 0, 0), direction=(0, 0, 0)), "direction"),
    (dict(origin=[(0, 0, 0)] * 3, direction=[(1, 0, 0)] * 2), "direction"),
    (dict(origin=(0, 0, np.nan), direction=(1, 0, 0)), "origin"),
    (dict(origin=(0, 0, 0), direction=(1, 0, 0), max_distance=-1.0), "max_distance"),
    (dict(origin=(0, 0, 0), direction=(1, 0, 0), exclude="nobody"), "exclude"),
    (dict(origin=[(0, 0, 0)] * 2, direction=(1, 0, 0), exclude=[0, 0, 0]), "exclude"),
    (dict(origin=(0, 0, 0), direction=(1, 0, 0), mask=-1), "mask"),
    (dict(origin=(0, 0, 0), direction=(1, 0, 0), mask=1.5), "mask"),
])
def test_bad_arguments_raise_one_line_naming_the_argument(kwargs, key):
    w = tb.World()
    w.add_body(tb.Sphere(radius=0.5), mass=1.0, name="ball")
    with pytest.raises(InputError) as err:
        w.ray_cast(**kwargs)
    assert err.value.key == key and "\n" not in str(err.value)
    assert str(err.value).startswith(f"{key}: ")


def _sphere_distances(origin, d, centre, radius, max_distance):
    """(R, S) distance along each unit ray to each sphere by the closed form, in NumPy (inf: no
    hit; the rule of the casts: a sphere holding the origin is not hit)."""
    oc = origin[:, None, :] - centre[None, :, :]
    b = np.einsum("rsk,rk->rs", oc, d)
    c = np.einsum("rsk,rsk->rs", oc, oc) - radius[None, :] ** 2
    disc = b * b - c
    with np.errstate(invalid="ignore"):
        t = -b - np.sqrt(disc)
    return np.where((c >= 0) & (b <= 0) & (disc >= 0) & (t <= max_distance), t, np.inf)


def test_many_spheres_through_the_tree_equal_a_loop_over_all_of_them():
    """400 spheres scattered in a 10 m cube (a tree of ~7 levels) and 1000 random rays: each ray's
    nearest sphere and distance equal those of the closed form evaluated for every sphere in
    NumPy (with the same rule: a sphere holding the origin is not hit), to 1e-12 m."""
    rng = np.random.default_rng(21)
    centre = rng.uniform(-5, 5, size=(400, 3))
    radius = rng.uniform(0.05, 0.4, size=400)
    w = tb.World()
    for c, r in zip(centre, radius):
        w.add_body(tb.Sphere(radius=r), mass=1.0, position=c)
    origin = rng.uniform(-6, 6, size=(1000, 3))
    d = rng.normal(size=(1000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    h = w.ray_cast(origin, d, max_distance=8.0)
    t = _sphere_distances(origin, d, centre, radius, 8.0)
    nearest = np.where(np.isfinite(t.min(axis=1)), t.argmin(axis=1), -1)
    assert (nearest >= 0).sum() > 150
    assert np.array_equal(h.body, nearest)
    hit = nearest >= 0
    np.testing.assert_allclose(h.distance[hit], t.min(axis=1)[hit], rtol=0, atol=1e-12)


def test_a_mask_sees_only_the_categories_it_names():
    """The 400 spheres of the test above in three collision categories (1, 2, 4), cast with
    masks 1, 2 | 4 and 0: each ray's hit is the nearest sphere among those whose category meets
    the mask, by the same closed form over every sphere in NumPy, to 1e-12 m (and mask 0 sees
    nothing: a query that would pass on a mask ignored fails here)."""
    rng = np.random.default_rng(22)
    centre = rng.uniform(-5, 5, size=(400, 3))
    radius = rng.uniform(0.05, 0.4, size=400)
    category = 1 << rng.integers(0, 3, size=400)
    w = tb.World()
    for c, r, k in zip(centre, radius, category):
        w.add_body(tb.Sphere(radius=r), mass=1.0, position=c, collision_filter={"category": int(k)})
    origin = rng.uniform(-6, 6, size=(2000, 3))
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    t = _sphere_distances(origin, d, centre, radius, 8.0)
    for mask in (1, 2 | 4, 0):
        tm = np.where((category & mask)[None, :] != 0, t, np.inf)
        nearest = np.where(np.isfinite(tm.min(axis=1)), tm.argmin(axis=1), -1)
        h = w.ray_cast(origin, d, max_distance=8.0, mask=mask)
        assert np.array_equal(h.body, nearest)
        hit = nearest >= 0
        np.testing.assert_allclose(h.distance[hit], tm.min(axis=1)[hit], rtol=0, atol=1e-12)
        assert (hit.sum() > 50) if mask else not hit.any()


def test_a_query_category_and_sensors():
    """Box2D's query filter both ways: a body is seen when its category meets the query's mask
    and its own mask meets the query's category; sensors are never seen (not solid). Along x,
    three spheres in a row: a sensor, one whose mask leaves out category 2, then a plain one."""
    w = tb.World()
    w.add_body(tb.Sphere(radius=0.5), fixed=True, sensor=True, position=(2, 0, 0), name="sensor")
    w.add_body(tb.Sphere(radius=0.5), mass=1.0, position=(4, 0, 0), name="picky",
               collision_filter={"mask": 1})
    w.add_body(tb.Sphere(radius=0.5), mass=1.0, position=(6, 0, 0), name="plain")
    hit = lambda **kw: w.names[int(w.ray_cast((0, 0, 0), (1, 0, 0), **kw).body[0])]
    assert hit() == "picky"  # the sensor is passed through
    assert hit(category=1) == "picky"
    assert hit(category=2) == "plain"  # picky's mask leaves out category 2
    assert w.overlap_aabb((0, -1, -1), (7, 1, 1), category=2).tolist() == [w.index_of("plain")]
    assert w.overlap_aabb((0, -1, -1), (7, 1, 1)).tolist() == [w.index_of("picky"), w.index_of("plain")]


def test_a_changed_filter_is_seen_by_the_next_cast():
    """The categories are kept between casts (read once per change of the filters)."""
    w = tb.World()
    near = w.add_body(tb.Sphere(radius=0.5), mass=1.0, position=(2, 0, 0))
    w.add_body(tb.Sphere(radius=0.5), mass=1.0, position=(5, 0, 0), collision_filter={"category": 2})
    assert w.ray_cast((0, 0, 0), (1, 0, 0), mask=2).body[0] == 1
    near.collision_filter = {"category": 2}
    assert w.ray_cast((0, 0, 0), (1, 0, 0), mask=2).body[0] == 0
    assert w.overlap_aabb((1, -1, -1), (3, 1, 1), mask=1).tolist() == []


def test_a_body_added_after_a_cast_is_seen_by_the_next():
    """The shape table is kept between casts (it is built in Python); adding a body rebuilds it."""
    w = tb.World()
    w.add_body(tb.Sphere(radius=0.5), mass=1.0, position=(5, 0, 0))
    assert w.ray_cast((0, 0, 0), (1, 0, 0)).body[0] == 0
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, position=(2, 0, 0))
    h = w.ray_cast((0, 0, 0), (1, 0, 0))
    assert h.body[0] == 1 and abs(h.distance[0] - 1.5) < 1e-12


def test_random_rays_agree_with_mujoco_mj_ray():
    """A peer engine: 30 boxes, spheres, capsules and cylinders at random poses over a plane, as
    MuJoCo geoms at the same poses (its capsule and cylinder sizes are radius and half length),
    and 400 random rays from outside every shape (MuJoCo's rule for an origin inside a shape
    differs): the same body hit on every ray, the distances within 1e-9 m (both closed forms in
    float64; MuJoCo solves its quadratics in another arrangement)."""
    mujoco = pytest.importorskip("mujoco")
    rng = np.random.default_rng(42)
    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    geoms = ['<geom type="plane" size="0 0 1"/>']
    kinds = ["box", "sphere", "capsule", "cylinder"]
    for i in range(30):
        kind = kinds[i % 4]
        q = unit(rng.normal(size=4))
        pos = np.array([*rng.uniform(-3, 3, 2), rng.uniform(0.8, 2.5)])
        if kind == "box":
            h = rng.uniform(0.1, 0.4, 3)
            shape, size = tb.Box(size=2 * h), h
        elif kind == "sphere":
            r = rng.uniform(0.1, 0.4)
            shape, size = tb.Sphere(radius=r), [r]
        else:
            r, half = rng.uniform(0.1, 0.3), rng.uniform(0.1, 0.4)
            shape = (tb.Capsule if kind == "capsule" else tb.Cylinder)(radius=r, length=2 * half)
            size = [r, half]
        w.add_body(shape, mass=1.0, position=pos, orientation=q)
        geoms.append(f'<geom type="{kind}" size="{" ".join(map(repr, map(float, size)))}" '
                     f'pos="{" ".join(map(repr, map(float, pos)))}" quat="{" ".join(map(repr, map(float, q)))}"/>')
    m = mujoco.MjModel.from_xml_string("<mujoco><worldbody>" + "".join(geoms) + "</worldbody></mujoco>")
    data = mujoco.MjData(m)
    mujoco.mj_forward(m, data)
    origin = np.column_stack([rng.uniform(-6, 6, (400, 2)), np.full(400, 6.0)])
    target = np.column_stack([rng.uniform(-3.5, 3.5, (400, 2)), rng.uniform(0.0, 2.5, 400)])
    d = target - origin
    d /= np.linalg.norm(d, axis=1)[:, None]
    h = w.ray_cast(origin, d)
    geomid = np.zeros(1, dtype=np.int32)
    shapes_hit = 0
    for r in range(400):
        t = mujoco.mj_ray(m, data, origin[r], d[r], None, 1, -1, geomid)
        body = int(geomid[0]) if t >= 0 else -1  # geom g is tumble body g (the plane is 0 in both)
        assert h.body[r] == body, r
        if body >= 0:
            assert abs(h.distance[r] - t) < 1e-9, r
            shapes_hit += body > 0
    assert shapes_hit > 60  # the rays met the shapes, not only the plane


def test_casts_follow_the_bodies_as_the_simulation_moves_them():
    """The poses' tree is kept between casts while x and R stay as they were: after the
    Simulator moves the bodies, a cast sees them where they are now (the top of a falling
    sphere at its current height), and a cast in a world of the same poses stays the same."""
    w = tb.World(gravity=(0, 0, -9.81))
    ball = w.add_body(tb.Sphere(radius=0.5), mass=1.0, position=(0, 0, 5))
    first = w.ray_cast((0, 0, 20), (0, 0, -1))
    assert abs(first.distance[0] - 14.5) < 1e-12
    assert w.ray_cast((0, 0, 20), (0, 0, -1)).distance[0] == first.distance[0]
    tb.Simulator(w, dt=1 / 240).run(0.5)
    assert ball.x[2] < 4.0
    h = w.ray_cast((0, 0, 20), (0, 0, -1))
    assert abs(h.distance[0] - (20 - ball.x[2] - 0.5)) < 1e-12


def _refit_world(rng, count=300):
    """``count`` boxes and spheres scattered in a 10 m cube at random orientations (a tree of
    ~7 levels) and a ground plane."""
    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    for k in range(count):
        shape = tb.Box(size=rng.uniform(0.1, 0.6, 3)) if k % 2 else tb.Sphere(radius=rng.uniform(0.05, 0.3))
        q = unit(rng.normal(size=4))
        w.add_body(shape, mass=1.0, position=rng.uniform(-5, 5, 3) + (0, 0, 5.5), orientation=q)
    return w


def _move(w, rng, scale):
    """Every moving body displaced by up to ``scale`` m per axis and turned by a random small turn."""
    m = w.moving
    w.x[m] += rng.uniform(-scale, scale, size=(int(m.sum()), 3))
    for i in np.flatnonzero(m):
        q = w.q[i] + 0.1 * rng.normal(size=4)
        w.q[i] = q / np.linalg.norm(q)
        w.R[i] = quat_to_matrix(w.q[i])


def test_a_refitted_tree_gives_the_hits_of_a_fresh_one_and_bounds_its_shapes():
    """Casting after the bodies moved refits the kept tree (``refit_shape_bvh``) instead of
    building it again. Checked against a tree built fresh for the same poses (a cast given the
    table builds its own): the same body, distance and normal for 2000 rays aimed near the
    bodies' centres, bit for bit
    (the tree only prunes and orders the exact tests; a tie between two shapes at one distance
    could differ, none is drawn here). And every refitted node's box is the union of its
    shapes' boxes, computed here in NumPy from the leaves up."""
    from tumble.collision.bounds import update_bounds

    rng = np.random.default_rng(5)
    w = _refit_world(rng)
    origin = rng.uniform(-7, 7, size=(2000, 3)) + (0, 0, 5.5)
    d = w.x[rng.integers(1, w.body_count, 2000)] + rng.normal(scale=0.2, size=(2000, 3)) - origin  # at the shapes
    w.ray_cast(origin, d)  # builds the kept tree
    scene = w._ray_scene
    for step in range(3):
        _move(w, rng, 0.3)
        kept = w.ray_cast(origin, d)
        fresh = ray_cast(w, origin, d, table=scene.table)
        assert scene.builds == 1 and scene.refits == step + 1
        assert (kept.body > 0).sum() > 800  # rays that meet shapes, not only the plane (body 0)
        assert np.array_equal(kept.body, fresh.body)
        assert np.array_equal(kept.distance, fresh.distance)
        assert np.array_equal(kept.normal[kept.body >= 0], fresh.normal[fresh.body >= 0])
    _, _, aabb = update_bounds(np.asarray(w.x), np.asarray(w.R), scene.table, 0.0)
    _, _, _, items, (node_aabb, first, count, skip) = scene._tree
    expected = np.empty_like(node_aabb)
    for n in range(len(first) - 1, -1, -1):
        if count[n] > 0:
            boxes = aabb[items[first[n]:first[n] + count[n]]]
            expected[n] = boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)
        else:
            left, right = expected[n + 1], expected[skip[n + 1]]
            expected[n] = np.minimum(left[0], right[0]), np.maximum(left[1], right[1])
    assert np.array_equal(node_aabb, expected)


def test_a_tree_refitted_past_its_growth_bound_is_built_again():
    """Small moves refit the kept tree; moves that spread its shapes far from where it was built
    (each body 30 m away, across a 10 m scene) grow its boxes' area past ``REFIT_GROWTH`` times,
    and the next cast builds a new tree, whose hits still equal a fresh tree's."""
    rng = np.random.default_rng(6)
    w = _refit_world(rng, count=100)
    origin = rng.uniform(-7, 7, size=(500, 3)) + (0, 0, 5.5)
    d = rng.normal(size=(500, 3))
    w.ray_cast(origin, d)
    scene = w._ray_scene
    _move(w, rng, 0.05)
    w.ray_cast(origin, d)
    assert (scene.builds, scene.refits) == (1, 1)
    _move(w, rng, 30.0)
    kept = w.ray_cast(origin, d)
    assert (scene.builds, scene.refits) == (2, 1)
    fresh = ray_cast(w, origin, d, table=scene.table)
    assert np.array_equal(kept.body, fresh.body) and np.array_equal(kept.distance, fresh.distance)


def test_queries_compile_their_kernels_once_whatever_the_layout_of_their_arguments():
    """A read-only broadcast origin, a transposed (Fortran-order) direction array and read-only
    distance arrays give the same hits as plain arrays, through the kernels already compiled:
    Numba compiles a kernel once per layout of its array arguments, and each extra layout cost a
    user 3-7 s in the middle of a session (four ray-cast layouts were compiled by this suite
    before the queries copied their arguments into one layout, ``raycast.rows``)."""
    from tumble.collision import distance, raycast, shape_query

    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    w.add_body(tb.Sphere(radius=0.5), mass=1.0, position=(0, 0, 2))
    origin = np.array([[0.0, 0, 5], [0.1, 0, 5], [0.2, 0, 5]])
    down = np.array([[0.0, 0, -1]] * 3)
    plain = (w.ray_cast(origin, down, max_distance=np.full(3, 10.0)),
             w.closest_points([1], [0], max_distance=np.full(1, 10.0)),
             w.shape_cast(tb.Sphere(radius=0.1), origin, (0, 0, -10)))
    kernels = (raycast.ray_cast_kernel, distance.closest_points_serial_kernel, shape_query.shape_cast_serial_kernel)
    compiled = [len(k.signatures) for k in kernels]

    read_only_origin = np.broadcast_to(origin[0], (3, 3))
    fortran_down = np.asfortranarray(down)
    assert not read_only_origin.flags.writeable and not fortran_down.flags.c_contiguous
    read_only_distance = np.broadcast_to(np.array(10.0), (3,))
    odd = (w.ray_cast(read_only_origin, fortran_down, max_distance=read_only_distance),
           w.closest_points([1], [0], max_distance=read_only_distance[:1]),
           w.shape_cast(tb.Sphere(radius=0.1), read_only_origin, np.broadcast_to(np.array([0, 0, -10.0]), (3, 3))))
    assert [len(k.signatures) for k in kernels] == compiled
    np.testing.assert_array_equal(odd[0].distance, np.full(3, plain[0].distance[0]))
    assert odd[1].distance[0] == plain[1].distance[0]
    np.testing.assert_array_equal(odd[2].fraction, np.full(3, plain[2].fraction[0]))


def test_a_few_rays_cast_on_the_calling_thread_meet_what_a_batch_meets():
    """Up to a chunk of rays (``RAYS_PER_CHUNK``) go to the kernel's serial twin (a parallel region
    for one ray cost 1.4 ms instead of 14 us while another process kept the cores busy: a
    performance audit, session 43): each ray alone, and in a batch of 200 (the parallel kernel),
    hits the same body at the same distance, point and normal, bit for bit (the same source)."""
    from tumble.collision import raycast

    rng = np.random.default_rng(3)
    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    for k in range(30):
        shape = [tb.Box(size=(0.3, 0.2, 0.4)), tb.Sphere(radius=0.2), tb.Capsule(radius=0.1, length=0.4)][k % 3]
        w.add_body(shape, mass=1.0, position=rng.uniform((-2, -2, 0.2), (2, 2, 2)), euler_deg=rng.uniform(0, 90, 3))
    origins = rng.uniform((-3, -3, 3), (3, 3, 4), (200, 3))
    directions = rng.normal(size=(200, 3)) - (0, 0, 2.0)
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    calls = {"serial": 0}
    serial = raycast.ray_cast_serial

    def counting(*args):
        calls["serial"] += 1
        return serial(*args)

    batch = w.ray_cast(origins, directions)
    raycast.ray_cast_serial = counting
    try:
        for r in range(0, 200, 7):
            one = w.ray_cast(origins[r], directions[r])
            assert one.body[0] == batch.body[r]
            for field in ("distance", "point", "normal"):
                np.testing.assert_array_equal(getattr(one, field)[0], getattr(batch, field)[r])
    finally:
        raycast.ray_cast_serial = serial
    assert calls["serial"] == len(range(0, 200, 7))
    assert (batch.body >= 0).sum() > 100  # most rays meet something


def test_a_ray_starting_on_a_surface_reports_distance_plus_zero():
    """A ray starting on a box's face going in reported -0.0 (a sphere's 0.0): now +0.0 for both
    (``math.copysign`` tells them apart; the hit is the face itself, as before)."""
    import math

    w = tb.World()
    w.add_body(tb.Box(size=(1.0, 1.0, 1.0)), fixed=True)
    w.add_body(tb.Sphere(radius=0.5), fixed=True, position=(5.0, 0.0, 0.0))
    for origin in ((0.0, 0.0, 0.5), (5.0, 0.0, 0.5)):
        hit = w.ray_cast(origin, (0.0, 0.0, -1.0))
        assert hit.body[0] >= 0 and hit.distance[0] == 0.0 and math.copysign(1.0, hit.distance[0]) == 1.0
