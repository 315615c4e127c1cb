"""``World.closest_points`` (collision/distance.py): signed distance, closest points and normal
between bodies, against exact answers computed here independently of GJK and EPA:

- spheres, and a sphere against a plane: closed forms;
- a sphere against a cylinder, cone or capsule: the distance of its centre to the solid of
  revolution is a 2-D distance to the shape's profile in the (radius, height) half-plane (a
  segment's for the capsule), minus the sphere's radius, in or out (the offset of a convex set);
- boxes and convex hulls: apart, the smallest of every vertex's distance to the other's triangles
  (the foot on the triangle's plane when it falls inside it, else the nearest edge point) and of
  every pair of edges' interior closest points (a 2x2 linear system); overlapping, the depth is the smallest overlap over the separating-axis
  candidates (face normals of both, cross products of edge pairs): the facets of A - B have no
  other normals, so that minimum is the exact translational depth;
- a static triangle mesh (a heightfield): the same vertex and edge terms against its triangles.

Tolerances: GJK stops at a relative 1e-9 of the distance (``GJK_REL``) and EPA at 1e-9 m
(``EPA_TOLERANCE``); shapes here are about a metre, so 1e-8 m is ten times the solver's stopping
rule, far below any error a wrong feature or sign would make (centimetres).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

import tumble as tb
from tumble.errors import InputError

from .helpers import random_rotation, rot

TOL = 1e-8
POINT_TOL_OVERLAP = 2e-5  # m (test_sphere_against_solid_of_revolution)
NORMAL_TOL_OVERLAP = 1e-4  # rad
NORMAL_GAP = 1e-8  # m (test_every_convex_pair_against_support_functions)


def _world():
    return tb.World(gravity=(0, 0, 0))


def _consistent(r, i=0):
    """point_b = point_a + distance * normal, the normal unit."""
    assert np.linalg.norm(r.normal[i]) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(r.point_b[i], r.point_a[i] + r.distance[i] * r.normal[i], atol=1e-12)


def _q(R):
    """(w, x, y, z) of a rotation matrix."""
    from tumble.math3d import matrix_to_quat

    return matrix_to_quat(np.ascontiguousarray(R))


# ---------------------------------------------------------------------- closed forms
def test_two_spheres_apart_and_overlapping():
    w = _world()
    w.add_body(tb.Sphere(0.5), mass=1, position=(0.1, 0.2, 0.3), name="a")
    b = w.add_body(tb.Sphere(0.25), mass=1, position=(1.1, 1.2, 1.3), name="b")
    r = w.closest_points("a", "b")
    c = np.array([1.0, 1.0, 1.0])
    assert r.distance[0] == pytest.approx(np.linalg.norm(c) - 0.75, abs=1e-12)
    np.testing.assert_allclose(r.normal[0], c / np.linalg.norm(c), atol=1e-12)
    np.testing.assert_allclose(r.point_a[0], [0.1, 0.2, 0.3] + 0.5 * c / np.linalg.norm(c), atol=1e-12)
    _consistent(r)
    b.x[:] = (0.1, 0.2, 0.8)  # centres 0.5 apart: 0.25 deep
    r = w.closest_points("a", "b")
    assert r.distance[0] == pytest.approx(-0.25, abs=1e-12)
    np.testing.assert_allclose(r.normal[0], [0, 0, 1], atol=1e-12)
    _consistent(r)
    # the other way round: the same distance, the normal turned
    r2 = w.closest_points("b", "a")
    assert r2.distance[0] == pytest.approx(-0.25, abs=1e-12)
    np.testing.assert_allclose(r2.normal[0], [0, 0, -1], atol=1e-12)


def test_shapes_above_a_tilted_plane_get_their_lowest_point():
    """The plane through (0, 0, 1) with normal n: a cylinder's lowest point is the rim's, a cone's
    the base rim's or its apex, a box's a corner: each's height above the plane from its vertices
    (or, for the round shapes, the closed form h cos + r sin of the axis's tilt)."""
    rng = np.random.default_rng(4)
    n = np.array([0.3, -0.2, 1.0])
    n /= np.linalg.norm(n)
    w = _world()
    # a plane body rotated so that its shape's +z is n, placed at (0, 0, 1)
    Rp = rot(np.cross([0, 0, 1], n), np.arccos(n[2]))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, position=(0, 0, 1), orientation=_q(Rp), name="ground")
    for k in range(20):
        R = random_rotation(rng)
        p = rng.uniform(-1, 1, 3) + (0, 0, 1.5)
        shape = [tb.Box(size=(0.4, 0.6, 0.8)), tb.Cylinder(0.3, 0.8), tb.Capsule(0.2, 0.5)][k % 3]
        w.add_body(shape, mass=1, position=p, orientation=_q(R), name=f"s{k}")
    r = w.closest_points([f"s{k}" for k in range(20)], "ground")
    for k in range(20):
        i = w.index_of(f"s{k}")
        x, R = w.x[i], w.R[i]
        u = R[:, 2]  # the shape's axis
        h0 = n @ (x - (0, 0, 1))
        if k % 3 == 0:
            expect = h0 - np.abs(n @ R) @ [0.2, 0.3, 0.4]
        elif k % 3 == 1:
            c = abs(n @ u)
            expect = h0 - 0.4 * c - 0.3 * np.sqrt(max(0.0, 1 - c * c))
        else:
            expect = h0 - 0.25 * abs(n @ u) - 0.2
        assert r.distance[k] == pytest.approx(expect, abs=1e-12), k
        np.testing.assert_allclose(r.normal[k], -n, atol=1e-12)  # from the shape down to the plane
        assert n @ (r.point_b[k] - (0, 0, 1)) == pytest.approx(0.0, abs=1e-12)  # on the plane
        _consistent(r, k)


# ---------------------------------------------------------------------- solids of revolution
def _profile_distance(rho, z, polygon, real_edges):
    """Signed 2-D distance of (rho, z) to a convex polygon (K, 2) in the (radius, height) half-plane,
    over its ``real_edges`` (the edge on the axis is inside the solid): > 0 outside, < 0 inside;
    and the nearest point (2,) of those edges."""
    p = np.array([rho, z])
    best, nearest = np.inf, None
    inside = True
    K = len(polygon)
    centre = polygon.mean(axis=0)
    for e in range(K):
        a, b = polygon[e], polygon[(e + 1) % K]
        t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        d = np.linalg.norm(p - (a + t * (b - a)))
        if e in real_edges and d < best:
            best, nearest = d, a + t * (b - a)
        nrm = np.array([b[1] - a[1], a[0] - b[0]])
        if nrm @ (centre - a) > 0:
            nrm = -nrm
        if nrm @ (p - a) > 0:
            inside = False
    return (-best if inside else best), nearest


@pytest.mark.parametrize("kind", ["cylinder", "cone", "capsule"])
def test_sphere_against_solid_of_revolution(kind):
    """Distance to 1e-8 m either way. The points and normal: apart, to 1e-8 m and 1e-8 rad (GJK's
    closest points); overlapping, to POINT_TOL_OVERLAP and NORMAL_TOL_OVERLAP, EPA's looser
    accuracy on a curved surface (its polytope's faces approximate the surface near the deepest
    point: the depth, a minimum, is accurate to second order in the normal's error, 1e-9 m, the
    normal only to about the square root; measured here: up to 6.4e-6 m and 4.1e-5 rad, the
    tolerances three times that)."""
    rng = np.random.default_rng({"cylinder": 1, "cone": 2, "capsule": 3}[kind])
    radius, length = 0.4, 1.0
    shape = {"cylinder": tb.Cylinder(radius, length), "cone": tb.Cone(radius, length),
             "capsule": tb.Capsule(radius, length)}[kind]
    w = _world()
    body = w.add_body(shape, mass=1, position=(0, 0, 0), name="solid")
    balls = [w.add_body(tb.Sphere(0.1), mass=1, position=(5 + k, 0, 0), name=f"ball{k}") for k in range(60)]
    body.R = random_rotation(rng)
    body.x = (0.2, -0.1, 0.3)
    from tumble.collision.raycast import kept_scene

    # the shape's origin (the cone's base centre sits a quarter of its height below its centre of mass)
    origin = w.x[0] + w.R[0] @ kept_scene(w).table.shape_local_pos[0]
    R = w.R[0].copy()
    expect, surface, outward = [], [], []
    for k, ball in enumerate(balls):
        # centres around the shape, some inside it (negative distances), some just outside
        c = origin + R @ (rng.uniform(-0.7, 0.7, 3) + (0, 0, 0.5 if kind == "cone" else 0.0))
        ball.x[:] = c
        local = R.T @ (c - origin)
        rho, z = np.hypot(local[0], local[1]), local[2]
        if kind == "capsule":
            foot = np.array([0.0, np.clip(z, -length / 2, length / 2)])
            gap = np.linalg.norm([rho, z - foot[1]])
            sd, nearest = gap - radius, foot + radius * np.array([rho, z - foot[1]]) / gap
        elif kind == "cylinder":
            poly = np.array([[0, -length / 2], [radius, -length / 2], [radius, length / 2], [0, length / 2]])
            sd, nearest = _profile_distance(rho, z, poly, real_edges={0, 1, 2})
        else:
            poly = np.array([[0, 0], [radius, 0], [0, length]])
            sd, nearest = _profile_distance(rho, z, poly, real_edges={0, 1})
        radial = local[:2] / rho
        q = origin + R @ np.array([nearest[0] * radial[0], nearest[0] * radial[1], nearest[1]])
        expect.append(sd - 0.1)
        surface.append(q)
        outward.append((c - q) / np.linalg.norm(c - q) * np.sign(sd))  # the solid's outward normal at q
    w.update_derived()
    r = w.closest_points("solid", [f"ball{k}" for k in range(60)])
    expect = np.array(expect)
    assert (expect < 0).sum() >= 5 and (expect > 0).sum() >= 5  # both kinds of pair were measured
    np.testing.assert_allclose(r.distance, expect, atol=TOL)
    for k in range(60):
        _consistent(r, k)
        point_tol, normal_tol = (TOL, TOL) if expect[k] > 0 else (POINT_TOL_OVERLAP, NORMAL_TOL_OVERLAP)
        np.testing.assert_allclose(r.point_a[k], surface[k], atol=point_tol)
        np.testing.assert_allclose(r.normal[k], outward[k], atol=normal_tol)
        # the point on the ball is on its surface along the normal
        np.testing.assert_allclose(r.point_b[k], w.x[k + 1] - 0.1 * r.normal[k], atol=point_tol)


# ---------------------------------------------------------------------- polytopes
def _hull(points):
    """(vertices (V, 3), triangles (T, 3), unit outward face normals (T, 3), offsets (T,)) of a hull."""
    h = ConvexHull(points)
    V = points[h.vertices]
    remap = {v: i for i, v in enumerate(h.vertices)}
    T = np.array([[remap[i] for i in s] for s in h.simplices])
    return V, T, h.equations[:, :3], -h.equations[:, 3]


def _edges(T):
    e = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0)


def _segment_distance(P, a, b):
    """(M, K) distances of points P (M, 3) to segments a, b (K, 3)."""
    u = b - a
    t = np.clip(((P[:, None, :] - a[None]) * u[None]).sum(-1) / (u * u).sum(-1)[None], 0.0, 1.0)
    return np.linalg.norm(P[:, None, :] - (a[None] + t[..., None] * u[None]), axis=-1)


def _point_surface_distance(P, V, T):
    """(M,) distances of points P (M, 3) to the triangles T (K, 3) of V: the foot on a triangle's
    plane where it falls inside the triangle (barycentric weights all >= 0), else its edges."""
    a, b, c = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1)[:, None]
    h = ((P[:, None, :] - a[None]) * n[None]).sum(-1)  # (M, K)
    foot = P[:, None, :] - h[..., None] * n[None]
    inside = np.ones(h.shape, dtype=bool)
    for p, q in ((a, b), (b, c), (c, a)):
        inside &= (np.cross(q - p, foot - p[None]) * n[None]).sum(-1) >= 0.0
    d = np.where(inside, np.abs(h), np.inf)
    for p, q in ((a, b), (b, c), (c, a)):
        d = np.minimum(d, _segment_distance(P, p, q))
    return d.min(axis=1)


def _polytope_signed_distance(VA, TA, VB, TB):
    """Exact signed distance of two convex polytopes (module docstring); B may be any triangle
    surface when they are apart."""
    eA, eB = _edges(TA), _edges(TB)
    dA = VA[eA[:, 1]] - VA[eA[:, 0]]
    dB = VB[eB[:, 1]] - VB[eB[:, 0]]
    axes = [np.cross(VA[TA[:, 1]] - VA[TA[:, 0]], VA[TA[:, 2]] - VA[TA[:, 0]]),
            np.cross(VB[TB[:, 1]] - VB[TB[:, 0]], VB[TB[:, 2]] - VB[TB[:, 0]]),
            np.cross(dA[:, None, :], dB[None, :, :]).reshape(-1, 3)]
    axes = np.concatenate(axes)
    length = np.linalg.norm(axes, axis=1)
    axes = axes[length > 1e-9] / length[length > 1e-9, None]
    pa, pb = VA @ axes.T, VB @ axes.T
    overlap = np.minimum(pa.max(0) - pb.min(0), pb.max(0) - pa.min(0))
    if overlap.min() < 0:  # a separating axis: apart, measure exactly
        d = min(_point_surface_distance(VA, VB, TB).min(), _point_surface_distance(VB, VA, TA).min())
        # interiors of two edges: the closest points of their lines, where both fall inside
        p0, q0 = VA[eA[:, 0]][:, None, :], VB[eB[:, 0]][None, :, :]
        u, v = dA[:, None, :], dB[None, :, :]
        r = p0 - q0
        a, b, c = (u * u).sum(-1), (u * v).sum(-1), (v * v).sum(-1)
        e, f = (u * r).sum(-1), (v * r).sum(-1)
        den = a * c - b * b
        ok = den > 1e-12 * a * c
        s = np.where(ok, (b * f - c * e) / np.where(ok, den, 1), -1)
        t = np.where(ok, (a * f - b * e) / np.where(ok, den, 1), -1)
        inside = ok & (s > 0) & (s < 1) & (t > 0) & (t < 1)
        gaps = np.linalg.norm(r + s[..., None] * u - t[..., None] * v, axis=-1)
        if inside.any():
            d = min(d, gaps[inside].min())
        return d
    return -overlap.min()


def _box_polytope(size, x, R):
    h = np.asarray(size) / 2
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * h
    return _hull(corners @ R.T + x)


@pytest.mark.parametrize("kind", ["box", "hull"])
def test_polytopes_against_the_exact_distance(kind):
    rng = np.random.default_rng({"box": 11, "hull": 12}[kind])
    w = _world()
    if kind == "box":
        sa, sb = (0.6, 0.9, 0.4), (0.5, 0.3, 1.1)
        A = w.add_body(tb.Box(size=sa), mass=1, name="a")
        B = w.add_body(tb.Box(size=sb), mass=1, name="b")
    else:
        pts_a = rng.normal(size=(14, 3)) * (0.4, 0.3, 0.5)
        pts_b = rng.normal(size=(18, 3)) * (0.3, 0.5, 0.3)
        A = w.add_body(tb.Convex(points=pts_a), mass=1, name="a")
        B = w.add_body(tb.Convex(points=pts_b), mass=1, name="b")
    from tumble.collision.raycast import kept_scene

    table = kept_scene(w).table
    local = {}
    for i in (0, 1):
        s = int(np.flatnonzero(table.shape_body == i)[0])
        v0, nv = table.shape_data[s, :2]
        local[i] = table.hull_vertex[v0:v0 + nv] + table.shape_local_pos[s]  # body frame (no part rotation)
    signs = []
    for trial in range(40):
        Ra, Rb = random_rotation(rng), random_rotation(rng)
        xa = rng.uniform(-0.1, 0.1, 3)
        xb = xa + rng.normal(size=3) * 0.45
        A.R, B.R = Ra, Rb
        A.x, B.x = xa, xb
        if kind == "box":
            VA, TA, *_ = _box_polytope(sa, xa, w.R[0])
            VB, TB, *_ = _box_polytope(sb, xb, w.R[1])
        else:
            VA, TA, *_ = _hull(local[0] @ w.R[0].T + xa)
            VB, TB, *_ = _hull(local[1] @ w.R[1].T + xb)
        expect = _polytope_signed_distance(VA, TA, VB, TB)
        r = w.closest_points("a", "b")
        assert r.distance[0] == pytest.approx(expect, abs=TOL), trial
        _consistent(r)
        # each point is on its own polytope's surface: its largest face-plane distance is zero
        for P, (V, T) in ((r.point_a[0], (VA, TA)), (r.point_b[0], (VB, TB))):
            _, _, N, off = _hull(V)
            assert np.max(N @ P - off) == pytest.approx(0.0, abs=TOL)
        signs.append(np.sign(expect))
    assert signs.count(1) >= 8 and signs.count(-1) >= 8  # apart and overlapping both measured


# ---------------------------------------------------------------------- every convex kind
def _support_value(kind, dims, origin, R, n):
    """h(n) = max over the shape of p . n (world), in closed form from its dimensions."""
    l = R.T @ n
    if kind == "box":
        return origin @ n + np.abs(l) @ dims
    if kind == "sphere":
        return origin @ n + dims[0]
    if kind == "capsule":
        return origin @ n + abs(l[2]) * dims[1] / 2 + dims[0]
    if kind == "cylinder":
        return origin @ n + abs(l[2]) * dims[1] / 2 + dims[0] * np.hypot(l[0], l[1])
    if kind == "cone":  # base rim or apex
        return origin @ n + max(dims[0] * np.hypot(l[0], l[1]), dims[1] * l[2])
    if kind == "ellipsoid":  # max of p . l over (x/a)^2 + (y/b)^2 + (z/c)^2 <= 1: |diag(a, b, c) l|
        return origin @ n + np.linalg.norm(dims * l)
    return origin @ n + np.max(dims @ l)  # hull: its vertices (shape frame)


def _minkowski_signed_distance(f):
    """-min over unit n of f(n) = h_A(n) + h_B(-n): the signed distance of A and B (apart: the
    widest gap over directions; overlapping: the smallest overlap, the translational depth), by
    Nelder-Mead in spherical angles from the best of 1000 spread directions and 8 random ones."""
    from scipy.optimize import minimize

    k = np.arange(1000) + 0.5
    theta, phi = np.arccos(1 - 2 * k / 1000), np.pi * (1 + 5 ** 0.5) * k  # a Fibonacci sphere
    vals = [f(np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])) for t, p in zip(theta, phi)]
    starts = [(theta[i], phi[i]) for i in np.argsort(vals)[:4]]
    starts += list(np.random.default_rng(0).uniform((0, 0), (np.pi, 2 * np.pi), (8, 2)))
    best = np.inf
    for x0 in starts:
        r = minimize(lambda a: f(np.array([np.sin(a[0]) * np.cos(a[1]), np.sin(a[0]) * np.sin(a[1]), np.cos(a[0])])),
                     x0, method="Nelder-Mead", options=dict(xatol=1e-12, fatol=1e-15, maxiter=4000))
        best = min(best, r.fun)
    return -best


KINDS = ("box", "sphere", "capsule", "cylinder", "cone", "ellipsoid", "hull")


@pytest.mark.parametrize("pair", [(a, b) for i, a in enumerate(KINDS) for b in KINDS[i:] if "sphere" not in (a, b)
                                  or (a, b) in (("sphere", "hull"), ("sphere", "ellipsoid"))], ids="-".join)
def test_every_convex_pair_against_support_functions(pair):
    """Any two convex shapes, apart and overlapping: the signed distance equals -min over directions
    of h_A(n) + h_B(-n) (support functions in closed form; no GJK or EPA) to 1e-8 m (the solvers'
    stopping rules, module docstring; the Nelder-Mead minimum is converged to 1e-12 and checked
    no worse than tumble's own normal), and the normal nearly achieves it: h_A(normal) +
    h_B(-normal) = -distance to NORMAL_GAP. Measured (2026-12-04): distances within 1.2e-9 m, support
    gaps at most 1.2e-9 m (about EPA's tolerance, 1e-9 m). Before GJK
    kept its last simplex when a step did not bring it closer and took a triangle's closest point
    from its plane and areas (``pairs/gjk.py``), GJK's normal on a thin triangle (a cone's apex or
    rim against a curved or cornered shape) was up to 1.5e-4 rad off: support gaps of 8e-6 m (a box
    corner beside a cone's rim), 7.7e-7 (two cones), 2.9e-5 (a cone's apex against an ellipsoid),
    which cases showing up depending on the random rotations (OpenBLAS's kernels, tests/conftest.py).
    The contacts use the same GJK."""
    rng = np.random.default_rng(sum(map(ord, "".join(pair))))
    make = {"box": lambda: (tb.Box(size=(0.5, 0.3, 0.7)), np.array([0.25, 0.15, 0.35])),
            "sphere": lambda: (tb.Sphere(0.3), np.array([0.3])),
            "capsule": lambda: (tb.Capsule(0.15, 0.5), np.array([0.15, 0.5])),
            "cylinder": lambda: (tb.Cylinder(0.25, 0.6), np.array([0.25, 0.6])),
            "cone": lambda: (tb.Cone(0.3, 0.6), np.array([0.3, 0.6])),
            "ellipsoid": lambda: (tb.Ellipsoid(radii=(0.35, 0.15, 0.25)), np.array([0.35, 0.15, 0.25])),
            "hull": lambda: (tb.Convex(points=rng.normal(size=(12, 3)) * 0.25), None)}
    w = _world()
    dims = []
    for i, kind in enumerate(pair):
        shape, d = make[kind]()
        w.add_body(shape, mass=1, name="ab"[i])
        dims.append(d)
    from tumble.collision.raycast import kept_scene

    table = kept_scene(w).table
    for i, kind in enumerate(pair):
        if kind == "hull":
            v0, nv = table.shape_data[i, :2]
            dims[i] = table.hull_vertex[v0:v0 + nv]
    signs = []
    for trial in range(6):
        w.body("a").R, w.body("b").R = random_rotation(rng), random_rotation(rng)
        w.body("a").x = (0, 0, 0)
        w.body("b").x = rng.normal(size=3) * 0.35
        origins = [w.x[i] + w.R[i] @ table.shape_local_pos[i] for i in (0, 1)]

        def f(n):
            return (_support_value(pair[0], dims[0], origins[0], w.R[0], n)
                    + _support_value(pair[1], dims[1], origins[1], w.R[1], -n))

        expect = _minkowski_signed_distance(f)
        r = w.closest_points("a", "b")
        assert r.distance[0] == pytest.approx(expect, abs=TOL), (trial, r.distance[0], expect)
        assert -f(r.normal[0]) == pytest.approx(r.distance[0], abs=NORMAL_GAP)
        assert expect >= -f(r.normal[0]) - 1e-12  # the oracle's minimum is no worse than tumble's direction
        _consistent(r)
        signs.append(np.sign(expect))
    assert 1 in signs and -1 in signs  # apart and overlapping both measured


# ---------------------------------------------------------------------- meshes, compounds
def test_box_and_sphere_above_a_heightfield():
    rng = np.random.default_rng(5)
    heights = rng.uniform(0.0, 0.3, size=(7, 7))
    w = _world()
    w.add_body(tb.heightfield(heights, size=(3.0, 3.0)), fixed=True, name="terrain")
    ball = w.add_body(tb.Sphere(0.15), mass=1, name="ball")
    box = w.add_body(tb.Box(size=(0.3, 0.2, 0.4)), mass=1, name="box")
    from tumble.collision.raycast import kept_scene

    table = kept_scene(w).table
    s = int(np.flatnonzero(table.shape_body == 0)[0])
    t0, nt = table.shape_data[s, :2]
    tris = table.mesh_triangle[t0:t0 + nt] + table.shape_local_pos[s]  # world (the terrain body is at the origin)
    V = tris.reshape(-1, 3)
    T = np.arange(len(V)).reshape(-1, 3)
    for trial in range(12):
        xy = rng.uniform(-1.0, 1.0, 2)
        ball.x[:] = (*xy, 1.0 + rng.uniform(-0.3, 0.3))
        box.R = random_rotation(rng)
        box.x = (*rng.uniform(-1.0, 1.0, 2), 1.2)
        r = w.closest_points(["ball", "box"], "terrain")
        expect_ball = _point_surface_distance(ball.x[None, :], V, T)[0] - 0.15
        VB, TB, *_ = _box_polytope((0.3, 0.2, 0.4), box.x.copy(), w.R[2])
        expect_box = _polytope_signed_distance(VB, TB, V, T)
        assert r.distance[0] == pytest.approx(expect_ball, abs=TOL)
        assert r.distance[1] == pytest.approx(expect_box, abs=TOL)
        _consistent(r, 0)
        _consistent(r, 1)


def test_a_sphere_sunk_into_a_flat_mesh_gets_its_depth():
    w = _world()
    w.add_body(tb.heightfield(np.zeros((2, 2)), size=(4.0, 4.0)), fixed=True, name="floor")  # its top at z = 0
    w.add_body(tb.Sphere(0.5), mass=1, position=(0.3, 0.2, 0.2), name="ball")
    r = w.closest_points("ball", "floor")
    assert r.distance[0] == pytest.approx(-0.3, abs=TOL)
    np.testing.assert_allclose(r.normal[0], [0, 0, -1], atol=TOL)
    _consistent(r)


def test_a_compound_reports_its_nearest_part():
    w = _world()
    dumbbell = tb.Compound(parts=[(tb.Sphere(0.2), (-1, 0, 0), (1, 0, 0, 0)), (tb.Sphere(0.3), (1, 0, 0), (1, 0, 0, 0))])
    w.add_body(dumbbell, mass=1, position=(0, 0, 1), name="dumbbell")
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    w.add_body(tb.Sphere(0.1), mass=1, position=(-1, 0, 2), name="ball")
    from tumble.collision.raycast import kept_scene

    table = kept_scene(w).table
    parts = np.flatnonzero(table.shape_body == 0)
    com = w.x[0].copy()
    r = w.closest_points("dumbbell", ["ground", "ball"])
    big = parts[np.argmax(table.shape_params[parts, 0])]
    small = parts[np.argmin(table.shape_params[parts, 0])]
    centre_big = com + table.shape_local_pos[big]
    centre_small = com + table.shape_local_pos[small]
    assert r.shape_a[0] == big and r.distance[0] == pytest.approx(centre_big[2] - 0.3, abs=1e-12)
    assert r.shape_a[1] == small
    assert r.distance[1] == pytest.approx(np.linalg.norm(w.x[2] - centre_small) - 0.3, abs=1e-12)


# ---------------------------------------------------------------------- the query's rules
def test_max_distance_leaves_far_pairs_unmeasured_and_changes_no_near_one():
    w = _world()
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1, name="a")
    for k in range(5):
        w.add_body(tb.Box(size=(0.5, 0.5, 0.5)), mass=1, position=(1.0 + 0.5 * k, 0.3, 0.1), euler_deg=(10 * k, 0, 5),
                   name=f"b{k}")
    names = [f"b{k}" for k in range(5)]
    full = w.closest_points("a", names)
    near = w.closest_points("a", names, max_distance=1.0)
    kept = full.distance <= 1.0
    assert kept.sum() in (2, 3, 4)
    np.testing.assert_array_equal(near.distance[kept], full.distance[kept])
    assert np.all(np.isinf(near.distance[~kept])) and np.all(near.shape_a[~kept] == -1)
    assert np.all(np.isnan(near.point_a[~kept])) and not near.found[~kept].any()
    per_pair = w.closest_points("a", names, max_distance=np.where(kept, 0.0, 10.0))
    assert np.all(np.isinf(per_pair.distance[kept] if np.all(full.distance[kept] > 0) else []))
    np.testing.assert_array_equal(per_pair.distance[~kept], full.distance[~kept])


def test_many_pairs_on_both_cores_give_the_serial_bits():
    from tumble.collision import distance as dist_module

    rng = np.random.default_rng(8)
    w = _world()
    for k in range(40):
        shape = [tb.Box(size=(0.3, 0.2, 0.4)), tb.Sphere(0.2), tb.Cylinder(0.2, 0.5), tb.Capsule(0.1, 0.4),
                 tb.Convex(points=rng.normal(size=(10, 3)) * 0.2)][k % 5]
        w.add_body(shape, mass=1, position=rng.uniform(-1, 1, 3), orientation=_q(random_rotation(rng)))
    a, b = np.triu_indices(40, 1)
    assert len(a) >= dist_module.PARALLEL_MIN_PAIRS
    r = w.closest_points(a, b)
    keep = dist_module.PARALLEL_MIN_PAIRS
    try:
        dist_module.PARALLEL_MIN_PAIRS = 10 ** 9
        s = w.closest_points(a, b)
    finally:
        dist_module.PARALLEL_MIN_PAIRS = keep
    np.testing.assert_array_equal(r.distance, s.distance)
    np.testing.assert_array_equal(r.point_a, s.point_a)
    assert (r.distance < 0).any() and (r.distance > 0).any()
    # and row by row, the same as one pair at a time
    for p in range(0, len(a), 97):
        one = w.closest_points(int(a[p]), int(b[p]))
        assert one.distance[0] == r.distance[p]


def test_bad_arguments_get_one_line_naming_them():
    w = _world()
    w.add_body(tb.Sphere(0.5), mass=1, name="a")
    w.add_body(tb.Sphere(0.5), mass=1, position=(2, 0, 0), name="b")
    w.add_body(tb.Particles(points=np.eye(3) * 0.1, masses=[1, 1, 1]), position=(0, 3, 0), name="point")  # no collision shape
    with pytest.raises(InputError, match="body_b: unknown body 'nope'"):
        w.closest_points("a", "nope")
    with pytest.raises(InputError, match="body_b: body 0 is paired with itself"):
        w.closest_points("a", ["b", "a"])
    with pytest.raises(InputError, match="body_b: has 3 bodies but body_a has 2"):
        w.closest_points(["a", "b"], ["a", "b", "point"])
    with pytest.raises(InputError, match="max_distance: must not be NaN"):
        w.closest_points("a", "b", max_distance=np.nan)
    r = w.closest_points("a", "point")
    assert np.isinf(r.distance[0]) and r.shape_b[0] == -1


# ---------------------------------------------------------------------- near pairs
def test_near_pairs_are_every_pair_within_the_distance():
    """World.near_pairs against a brute force over all pairs of 60 spheres and boxes' bounding spheres
    (spheres only here, so the distances are closed forms: |c_i - c_j| - r_i - r_j) and a ground
    plane: the same set of pairs, the same distances; two fixed spheres near each other are left
    out (they never move), and so are a sensor and a body whose filter the query's mask leaves out."""
    rng = np.random.default_rng(21)
    w = _world()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    centres, radii = [], []
    for k in range(60):
        r = rng.uniform(0.05, 0.15)
        c = rng.uniform(-1, 1, 3) * (1, 1, 0.5) + (0, 0, 0.8)
        w.add_body(tb.Sphere(r), mass=1, position=c)
        centres.append(c)
        radii.append(r)
    w.add_body(tb.Sphere(0.1), fixed=True, position=(5, 0, 1), name="post1")
    w.add_body(tb.Sphere(0.1), fixed=True, position=(5, 0, 1.25), name="post2")
    w.add_body(tb.Sphere(0.1), mass=1, position=(5, 0, 1.5), sensor=True, name="zone")
    w.add_body(tb.Sphere(0.1), mass=1, position=(8, 0, 0.15), name="shy", collision_filter=tb.CollisionFilter(category=2))
    limit = 0.12
    got = w.near_pairs(limit, mask=1)
    expect = {}
    for i in range(60):
        if centres[i][2] - radii[i] <= limit:
            expect[(0, i + 1)] = centres[i][2] - radii[i]
        for j in range(i + 1, 60):
            d = np.linalg.norm(centres[i] - centres[j]) - radii[i] - radii[j]
            if d <= limit:
                expect[(i + 1, j + 1)] = d
    assert len(expect) >= 20
    pairs = list(zip(got.body_a.tolist(), got.body_b.tolist()))
    assert pairs == sorted(expect)
    np.testing.assert_allclose(got.distance, [expect[p] for p in pairs], atol=1e-12)
    # the posts (fixed, 0.05 m apart), the sensor and the masked body: none appears
    everything = w.near_pairs(limit)
    names = {w.index_of(n) for n in ("post1", "post2", "zone")}
    assert not names & set(everything.body_a.tolist() + everything.body_b.tolist())
    shy = w.index_of("shy")  # 0.05 m above the ground: found, unless the mask leaves its category out
    assert (0, shy) in set(zip(everything.body_a.tolist(), everything.body_b.tolist()))
    assert shy not in set(got.body_a.tolist() + got.body_b.tolist())
    with pytest.raises(InputError, match="max_distance: must be a finite number of metres >= 0"):
        w.near_pairs(-1.0)


def test_mesh_queries_compile_the_convex_routines_for_no_literal_shape_type():
    """A closest-points query and a shape cast against a static mesh pass the triangle's shape
    type to ``convex_distance`` as an int64, not as the literal 100: Numba compiles a routine
    once more for each literal value of an argument, and the literal compiled GJK, EPA and
    ``convex_distance`` twice (a first mesh query's compile 38.3 s -> 22.0 s once it went,
    docs/benchmarks.md "compile time"); likewise EPA's iteration counts."""
    import trimesh

    from tumble.collision import distance
    from tumble.collision.pairs import gjk

    slab = trimesh.creation.box(extents=(4, 4, 0.2))
    w = tb.World()
    w.add_body(tb.Mesh(vertices=np.array(slab.vertices), faces=np.array(slab.faces)), fixed=True)
    w.add_body(tb.Box(size=(0.5, 0.5, 0.5)), mass=1.0, position=(0.1, 0.2, 1.0))
    assert w.closest_points(1, 0).distance[0] == pytest.approx(1.0 - 0.25 - 0.1, abs=1e-9)
    # beside the box: onto the slab's top, z = 0.1
    assert w.shape_cast(tb.Sphere(radius=0.2), (1.5, 1.5, 2.0), (0, 0, -3)).fraction[0] == pytest.approx(1.7 / 3, abs=1e-8)
    # and EPA's iteration counts: two overlapping ellipsoids take 12 iterations then Newton, an
    # ellipsoid in a box the full 64; as literals they compiled ``_epa`` twice
    w.add_body(tb.Ellipsoid(radii=(0.3, 0.2, 0.1)), mass=1.0, position=(3.0, 0, 1))
    w.add_body(tb.Ellipsoid(radii=(0.3, 0.2, 0.1)), mass=1.0, position=(3.4, 0, 1))
    w.add_body(tb.Box(size=(0.5, 0.5, 0.5)), mass=1.0, position=(3.0, 0, 1.25))
    assert np.all(w.closest_points([2, 2], [3, 4]).distance < 0)
    for routine in (distance.convex_distance, gjk.gjk, gjk.epa, gjk._epa):
        literal = [sig for sig in routine.signatures if any("Literal" in str(t) for t in sig)]
        assert not literal, (routine.__name__, literal)


def test_a_query_about_a_few_bodies_of_a_large_world_updates_their_shapes_alone(monkeypatch):
    """A pair among 40 bodies brings only its two bodies' shape poses up to date (PERF: the whole
    world's cost a pair 0.3 ms at 10 000 boxes); its answers, after the bodies moved and between
    other queries that leave the buffers as they will, equal the answers with every shape updated
    (``FEW_BODIES_FACTOR`` 0), to the bit."""
    from tumble.collision import distance

    rng = np.random.default_rng(8)
    w = _world()
    for k in range(40):
        shape = [tb.Box(size=(0.3, 0.2, 0.4)), tb.Sphere(0.15), tb.Capsule(0.1, 0.3), tb.Cone(0.2, 0.3)][k % 4]
        w.add_body(shape, mass=1.0, position=rng.uniform(-2, 2, 3), euler_deg=rng.uniform(-180, 180, 3))
    pairs = [(0, 1), (5, 22), (39, 3), (12, 13)]

    def answers():
        out = []
        for a, b in pairs:
            r = w.closest_points(a, b)
            out.append(np.concatenate([r.distance, r.point_a[0], r.point_b[0], r.normal[0]]))
            w.near_pairs(0.05)  # a query that writes every shape's row
        return np.array(out)

    monkeypatch.setattr(distance, "FEW_BODIES_MIN_SHAPES", 0)  # a world of 40 shapes takes the few-bodies path
    for trial in range(3):
        before = w.x.copy()
        for body in w.bodies:
            body.x = body.x + rng.normal(scale=0.05, size=3)
            body.R = random_rotation(rng)
        assert not np.array_equal(w.x, before)
        few = answers()
        monkeypatch.setattr(distance, "FEW_BODIES_FACTOR", 0)
        every = answers()
        monkeypatch.setattr(distance, "FEW_BODIES_FACTOR", 8)
        assert np.array_equal(few, every)
    calls = []
    real = distance.update_bounds_rows
    monkeypatch.setattr(distance, "update_bounds_rows", lambda *args: calls.append(len(args[3])) or real(*args))
    w.closest_points(0, 1)
    assert calls == [2]  # the two bodies' one shape each
