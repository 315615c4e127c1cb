"""Cylinder, cone and convex hull pairs (pairs/convex.py, GJK/EPA + face clipping).

Analytic cases (resting flat, lying, tilted) check counts, depths and points to 1e-9 m
or better: the support functions are exact, so GJK on separated cores converges to
round-off, and EPA stops within EPA_TOLERANCE (1e-9 m) on polyhedral Minkowski faces.
The fuzz tests compare with independent references: a convex hull of a box's corners
against the box routines (SAT, already checked against brute force in test_fuzz),
a sphere against the closed-form distance to a solid cylinder, and a cylinder against
a 256-sided hull of itself (tolerance from the polygon's sagitta r (1 - cos(pi/256))).
"""

import numpy as np
import pytest

import tumble as tb

from .helpers import (
    SPEC,
    box,
    box_sdf,
    capsule,
    collide,
    cone,
    convex,
    cylinder,
    plane,
    random_rotation,
    rot,
    sphere,
)

UP = np.array([0.0, 0.0, 1.0])
CUBE = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def rotation_taking(u, v):
    """A rotation matrix that maps unit u onto unit v (Rodrigues)."""
    u = np.asarray(u, float) / np.linalg.norm(u)
    v = np.asarray(v, float) / np.linalg.norm(v)
    axis = np.cross(u, v)
    s = np.linalg.norm(axis)
    if s < 1e-12:
        return np.eye(3) if u @ v > 0 else rot(np.cross(u, [1, 0, 0]) if abs(u[0]) < 0.9 else np.cross(u, [0, 1, 0]), np.pi)
    return rot(axis, np.arctan2(s, u @ v))


def cylinder_points(r, half, n=256):
    a = 2 * np.pi * np.arange(n) / n
    ring = np.stack([r * np.cos(a), r * np.sin(a), np.zeros(n)], axis=1)
    return np.concatenate([ring + [0, 0, -half], ring + [0, 0, half]])


# ---------------------------------------------------------------- resting analytic cases
def test_cylinder_standing_on_box_four_points():
    # cylinder a above box b: the normal points from a down to b
    n, p, s, f = collide(cylinder((0.1, 0.2, 0.399), np.eye(3), 0.3, 0.4), box((0, 0, -0.5), np.eye(3), (1, 1, 0.5)))
    assert len(s) == 4
    np.testing.assert_allclose(n, -UP, atol=1e-12)
    np.testing.assert_allclose(s, -0.001, atol=1e-12)
    np.testing.assert_allclose(p[:, 2], -0.0005, atol=1e-12)
    # the points are rim points of the cap (the cap octagon's corners lie on the circle)
    np.testing.assert_allclose(np.linalg.norm(p[:, :2] - [0.1, 0.2], axis=1), 0.3, atol=1e-12)
    assert len(set(f.tolist())) == 4


def test_cylinder_lying_on_box_two_points():
    R = rot((1, 0, 0), np.pi / 2)  # axis along -y
    n, p, s, f = collide(cylinder((0, 0, 0.299), R, 0.3, 0.4), box((0, 0, -0.5), np.eye(3), (1, 1, 0.5)))
    assert len(s) == 2
    # EPA on the round side: the normal to its 1e-9 m stopping tolerance over the radius
    np.testing.assert_allclose(n, -UP, atol=1e-9)
    np.testing.assert_allclose(s, -0.001, atol=1e-12)
    np.testing.assert_allclose(np.sort(p[:, 1]), [-0.4, 0.4], atol=1e-12)
    np.testing.assert_allclose(p[:, [0, 2]], [[0, -0.0005]] * 2, atol=1e-9)


@pytest.mark.parametrize("lying", [False, True])
def test_cylinder_on_plane(lying):
    R = rot((1, 0, 0), np.pi / 2) if lying else np.eye(3)
    z = 0.3 if lying else 0.4
    n, p, s, f = collide(plane(), cylinder((0.5, 0, z - 0.002), R, 0.3, 0.4))
    assert len(s) == (2 if lying else 4)
    np.testing.assert_allclose(n, UP)
    np.testing.assert_allclose(s, -0.002, atol=1e-12)
    np.testing.assert_allclose(p[:, 2], -0.001, atol=1e-12)


def test_cylinder_tilted_on_plane_deepest_point_exact():
    # on its rim: the lowest point is c - h |u_z| - r sqrt(1 - u_z^2) along z
    R = rot((1, 0, 0), 0.5)
    u = R[:, 2]
    c = np.array([0.0, 0.0, 0.4 * abs(u[2]) + 0.3 * np.sqrt(1 - u[2] ** 2) - 0.003])
    n, p, s, f = collide(plane(), cylinder(c, R, 0.3, 0.4))
    k = np.argmin(s)
    assert s[k] == pytest.approx(-0.003, abs=1e-12)
    lowest = c - 0.4 * np.sign(u[2]) * u - 0.3 * (UP - u[2] * u) / np.sqrt(1 - u[2] ** 2) * np.sign(1)
    np.testing.assert_allclose(p[k], lowest + [0, 0, 0.0015], atol=1e-12)
    assert np.all(s < SPEC)


def test_cone_base_on_plane_and_on_its_side():
    n, p, s, f = collide(plane(), cone((0, 0, -0.001), np.eye(3), 0.3, 0.6))
    assert len(s) == 4
    np.testing.assert_allclose(s, -0.001, atol=1e-12)
    # on its side: turn the side normal at azimuth 0, (H, 0, r) / L, to -z
    r, H = 0.3, 0.6
    R = rotation_taking([H, 0, r], [0, 0, -1])
    apex, rim = R @ [0, 0, H], R @ [r, 0, 0]
    assert apex[2] == pytest.approx(rim[2], abs=1e-12)
    pos = np.array([0, 0, -0.001 - rim[2]])
    n, p, s, f = collide(plane(), cone(pos, R, r, H))
    assert len(s) == 2
    np.testing.assert_allclose(s, -0.001, atol=1e-12)
    expected = np.array([pos + apex, pos + rim]) + [0, 0, 0.0005]
    got = p[np.argsort(np.linalg.norm(p - expected[0], axis=1))]
    np.testing.assert_allclose(got, expected, atol=1e-12)


def test_cone_base_on_box_four_points():
    # cone a (type cone < box) resting on box b: normal down
    n, p, s, f = collide(cone((0, 0, -0.001), np.eye(3), 0.3, 0.6), box((0, 0, -0.5), np.eye(3), (1, 1, 0.5)))
    assert len(s) == 4
    np.testing.assert_allclose(n, -UP, atol=1e-12)
    np.testing.assert_allclose(s, -0.001, atol=1e-12)


def test_convex_cube_on_plane_and_box():
    for R in (np.eye(3), rot((0, 0, 1), 0.4)):
        n, p, s, f = collide(plane(), convex((0.2, 0.1, 0.499), R, 0.5 * CUBE))
        assert len(s) == 4
        np.testing.assert_allclose(s, -0.001, atol=1e-12)
        n, p, s, f = collide(box((0, 0, -0.5), np.eye(3), (2, 2, 0.5)), convex((0.2, 0.1, 0.499), R, 0.5 * CUBE))
        assert len(s) == 4
        np.testing.assert_allclose(n, UP, atol=1e-12)
        np.testing.assert_allclose(s, -0.001, atol=1e-12)
        corners = (0.2, 0.1, 0.0) + (0.5 * CUBE[CUBE[:, 2] < 0]) @ R.T
        corners[:, 2] = -0.0005
        got = p[np.lexsort(p.T[::-1])]
        np.testing.assert_allclose(got, corners[np.lexsort(corners.T[::-1])], atol=1e-12)


def test_convex_on_convex_tetrahedron_apex_down():
    # a tetrahedron standing on its apex on a cube hull: one point, the apex
    tet = np.array([[0, 0, 0], [1, 0, 1], [-0.5, 0.8, 1], [-0.5, -0.8, 1]], float)
    n, p, s, f = collide(convex((0, 0, -0.5), np.eye(3), 0.5 * CUBE), convex((0.1, 0.0, 0.0 + 0.004), np.eye(3), tet))
    assert len(s) == 1
    np.testing.assert_allclose(n, UP, atol=1e-9)
    assert s[0] == pytest.approx(0.004, abs=1e-12)
    np.testing.assert_allclose(p[0], [0.1, 0, 0.002], atol=1e-12)


def test_separation_known_configurations():
    # two parallel cylinders side by side: gap = d - 2 r, normal along the line of centres
    R = rot((1, 0, 0), np.pi / 2)
    n, p, s, f = collide(cylinder((0, 0, 0), R, 0.3, 0.5), cylinder((0.61, 0, 0), R, 0.3, 0.5))
    np.testing.assert_allclose(s, 0.01, atol=1e-12)
    np.testing.assert_allclose(n, [1, 0, 0], atol=1e-12)
    assert len(s) == 2
    # sphere over a cylinder's rim: distance to the rim circle
    n, p, s, f = collide(sphere((0.4, 0, 0.6), 0.1), cylinder((0, 0, 0), np.eye(3), 0.3, 0.5), spec=0.1)
    assert s[0] == pytest.approx(np.hypot(0.1, 0.1) - 0.1, abs=1e-12)
    np.testing.assert_allclose(n, -np.array([1, 0, 1]) / np.sqrt(2), atol=1e-9)
    # capsule lying across a cone's base from below: gap to the base plane
    n, p, s, f = collide(capsule((0, 0, -0.215), rot((0, 1, 0), np.pi / 2), 0.2, 0.1), cone((0, 0, 0), np.eye(3), 0.3, 0.6))
    np.testing.assert_allclose(s, 0.015, atol=1e-12)
    np.testing.assert_allclose(n, UP, atol=1e-12)
    assert len(s) == 2
    # beyond the speculative distance: nothing
    assert len(collide(cylinder((0, 0, 0), R, 0.3, 0.5), cylinder((0.6 + SPEC + 1e-6, 0, 0), R, 0.3, 0.5))[2]) == 0


# ---------------------------------------------------------------- fuzz against references
def cube_hull(pos, R, h):
    return convex(pos, R, CUBE * h)



@pytest.mark.parametrize("kind", ["plane", "sphere", "capsule", "box"])
def test_convex_box_hull_matches_box_routines(kind):
    """A hull of a box's 8 corners must give the box routine's deepest separation and normal.

    Tolerance 1e-7 m: GJK stops at a relative 1e-9 and EPA at 1e-9 m on the flat faces
    of the Minkowski difference. The normal is compared only when the deepest point is
    unambiguous (a single closest feature: |cos| to the box's normal > 1 - 1e-6).
    """
    rng = np.random.default_rng({"plane": 1, "sphere": 2, "capsule": 3, "box": 4}[kind])
    compared = 0
    for _ in range(80):
        h = rng.uniform(0.1, 0.6, 3)
        Rb = random_rotation(rng)
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        if kind == "plane":
            a = plane()
            pos = np.array([0, 0, rng.uniform(-0.1, 0.1) + np.sum(np.abs(Rb[2]) * h)])
            pos[2] -= rng.uniform(0.0, 0.05)
        elif kind == "sphere":
            a = sphere(np.zeros(3), rng.uniform(0.1, 0.5))
            pos = d * rng.uniform(0.3, 0.9) * (a[3][0] + np.linalg.norm(h))
        elif kind == "capsule":
            a = capsule(np.zeros(3), random_rotation(rng), rng.uniform(0.1, 0.3), rng.uniform(0.1, 0.5))
            pos = d * rng.uniform(0.2, 1.1) * (a[3][0] + a[3][1] + np.linalg.norm(h))
        else:
            a = box(np.zeros(3), random_rotation(rng), rng.uniform(0.1, 0.6, 3))
            pos = d * rng.uniform(0.5, 1.1) * (np.linalg.norm(a[3][:3]) + np.linalg.norm(h))
        n_ref, p_ref, s_ref, _ = collide(a, box(pos, Rb, h))
        n_got, p_got, s_got, _ = collide(a, cube_hull(pos, Rb, h))
        if kind in ("sphere", "capsule", "box") and len(s_ref) and np.min(s_ref) < -0.05:
            continue  # deep penetration: the box routines prefer faces over edges (test_fuzz): not a reference
        assert (len(s_ref) > 0) == (len(s_got) > 0) or abs(np.min(np.concatenate([s_ref, s_got])) - SPEC) < 1e-7
        if len(s_ref) and len(s_got):
            assert np.min(s_got) == pytest.approx(np.min(s_ref), abs=1e-7)
            assert abs(np.linalg.norm(n_got) - 1) < 1e-12
            if np.min(s_ref) > 1e-6:
                # apart: one closest pair of points, so one normal (GJK's, from the witness points)
                np.testing.assert_allclose(n_got, n_ref, atol=1e-6)
            compared += 1
    assert compared >= 8


def test_sphere_cylinder_fuzz_closed_form():
    """Sphere against the closed-form signed distance of a solid cylinder.

    Outside: sqrt(max(rho - r, 0)^2 + max(|z| - h, 0)^2); centre inside: -min(r - rho, h - |z|).
    Tolerance: 1e-9 m when the centre is outside (GJK on a point and an exact support);
    1e-4 m inside (EPA on a round side stops when the support point is within 1e-9 m of
    the polytope face, but its 64 iterations bound how finely a curved side is faceted).
    """
    rng = np.random.default_rng(7)
    r, h = 0.3, 0.5
    for _ in range(300):
        R = random_rotation(rng)
        local = rng.uniform(-1, 1, 3) * [0.6, 0.6, 0.8]
        rs = rng.uniform(0.05, 0.3)
        c = R @ local
        rho, z = np.hypot(local[0], local[1]), abs(local[2])
        outside = rho > r or z > h
        dist = np.hypot(max(rho - r, 0), max(z - h, 0)) if outside else -min(r - rho, h - z)
        n, p, s, f = collide(sphere(c, rs), cylinder(np.zeros(3), R, r, h))
        expected = dist - rs
        if expected >= SPEC - 1e-9:
            assert len(s) == 0
            continue
        assert len(s) == 1
        assert s[0] == pytest.approx(expected, abs=1e-9 if outside else 1e-4)
        if outside and dist > 1e-6:
            # the normal points from the sphere's centre towards the cylinder
            q_local = np.array([*(local[:2] * min(1, r / rho)), np.clip(local[2], -h, h)])
            np.testing.assert_allclose(n, R @ (q_local - local) / dist, atol=1e-7)


@pytest.mark.parametrize("other", ["box", "cylinder", "convex", "plane"])
def test_cylinder_fuzz_against_polygonal_hull(other):
    """Cylinder against the same cylinder as a 256-sided hull: deepest separation within the sagitta.

    The hull is inscribed: its surface is at most r (1 - cos(pi / 256)) = 2.3e-5 m inside
    the round one (r = 0.3), so separations may differ by that plus the solvers' 1e-4 m.
    """
    rng = np.random.default_rng({"box": 11, "cylinder": 12, "convex": 13, "plane": 14}[other])
    r, half = 0.3, 0.4
    hull_record = tb.Convex(points=cylinder_points(r, half))
    tol = r * (1 - np.cos(np.pi / 256)) + 1e-4
    compared = 0
    for _ in range(60):
        R = random_rotation(rng)
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        if other == "plane":
            pos = np.array([0, 0, rng.uniform(-0.05, 0.02) + half * abs(R[2, 2]) + r * np.sqrt(1 - R[2, 2] ** 2)])
            A = plane()
        else:
            if other == "box":
                A = box(np.zeros(3), random_rotation(rng), rng.uniform(0.1, 0.5, 3))
                size = np.linalg.norm(A[3][:3])
            elif other == "cylinder":
                A = cylinder(np.zeros(3), random_rotation(rng), 0.2, 0.3)
                size = np.hypot(0.2, 0.3)
            else:
                A = convex(np.zeros(3), random_rotation(rng), rng.normal(size=(12, 3)) * 0.3)
                size = np.max(np.linalg.norm(A[4].vertices, axis=1))
            pos = d * rng.uniform(0.6, 1.05) * (size + np.hypot(r, half))
        B_round = cylinder(pos, R, r, half)
        B_hull = convex(pos, R, hull_record)
        if other == "box":
            pair_round, pair_hull = (B_round, A), (A, B_hull)  # cylinder < box < convex in SHAPE order
        else:
            pair_round, pair_hull = (A, B_round), (A, B_hull) if other != "convex" else (B_hull, A)
            if other == "convex":
                pair_round = (B_round, A)
                pair_hull = (A, B_hull)
        _, _, s1, _ = collide(*pair_round)
        _, _, s2, _ = collide(*pair_hull)
        if len(s1) and len(s2):
            assert np.min(s1) == pytest.approx(np.min(s2), abs=tol)
            compared += 1
        else:
            # one side found nothing: the other is within the tolerance of the speculative distance
            s = np.concatenate([s1, s2])
            assert len(s) == 0 or np.min(s) > SPEC - tol
    assert compared >= 8


# ---------------------------------------------------------------- features
MOVES = [(1e-4, 0, 0), (0, 1e-4, 0), (0, 0, -1e-4), (-1e-4, 1e-4, 1e-4)]
RESTING = {
    "cylinder on box": lambda d: (cylinder(np.array([0.1, 0, 0.399]) + d, rot((0, 0, 1), 0.3), 0.3, 0.4),
                                  box((0, 0, -0.5), np.eye(3), (1, 1, 0.5))),
    "cylinder lying on box": lambda d: (cylinder(np.array([0, 0, 0.299]) + d, rot((1, 0, 0), np.pi / 2), 0.3, 0.4),
                                        box((0, 0, -0.5), np.eye(3), (1, 1, 0.5))),
    "cylinder on plane": lambda d: (plane(), cylinder(np.array([0, 0, 0.399]) + d, np.eye(3), 0.3, 0.4)),
    "convex on plane": lambda d: (plane(), convex(np.array([0, 0, 0.499]) + d, rot((0, 0, 1), 0.2), 0.5 * CUBE)),
    "convex on box": lambda d: (box((0, 0, -0.5), np.eye(3), (2, 2, 0.5)),
                                convex(np.array([0.1, 0, 0.499]) + d, rot((0, 0, 1), 0.2), 0.5 * CUBE)),
    "convex on convex, same size": lambda d: (convex((0, 0, -0.5), np.eye(3), 0.5 * CUBE),
                                              convex(np.array([0, 0, 0.499]) + d, np.eye(3), 0.5 * CUBE)),
    "cone on box": lambda d: (cone(np.array([0, 0, -0.001]) + d, np.eye(3), 0.3, 0.6),
                              box((0, 0, -0.5), np.eye(3), (1, 1, 0.5))),
}


@pytest.mark.parametrize("name", sorted(RESTING))
def test_feature_ids_unchanged_by_small_moves(name):
    """The same contact keys after a 0.1 mm move (warm starting carries impulses by them)."""
    n0, p0, s0, f0 = collide(*RESTING[name](np.zeros(3)))
    assert len(f0) >= 2 and len(set(f0.tolist())) == len(f0)
    for d in MOVES:
        n, p, s, f = collide(*RESTING[name](np.asarray(d)))
        assert sorted(f.tolist()) == sorted(f0.tolist()), d


def test_every_pair_type_is_sane_on_random_poses():
    """All pairs among sphere, capsule, cylinder, cone, box, convex, deep overlaps included: finite output,
    unit normal pointing from a towards b (positive along the centre line when the centres are well apart
    relative to the overlap), at most 4 points with distinct features, separations below the speculative distance."""
    rng = np.random.default_rng(21)
    hull = tb.Convex(points=rng.normal(size=(14, 3)) * 0.25)
    makers = [
        lambda p, R: sphere(p, 0.25),
        lambda p, R: capsule(p, R, 0.15, 0.2),
        lambda p, R: cylinder(p, R, 0.2, 0.25),
        lambda p, R: cone(p, R, 0.25, 0.5),
        lambda p, R: box(p, R, (0.2, 0.15, 0.25)),
        lambda p, R: convex(p, R, hull),
    ]
    for _ in range(40):
        for i in range(len(makers)):
            for j in range(i, len(makers)):
                d = rng.normal(size=3)
                d /= np.linalg.norm(d)
                a = makers[i](np.zeros(3), random_rotation(rng))
                b = makers[j](d * rng.uniform(0.0, 0.7), random_rotation(rng))
                n, p, s, f = collide(a, b)
                assert len(s) <= 4 and len(set(f.tolist())) == len(f)
                assert np.all(np.isfinite(p)) and np.all(np.isfinite(s)) and np.all(s < SPEC)
                if len(s):
                    assert abs(np.linalg.norm(n) - 1) < 1e-9


def test_hull_hull_points_lie_on_both_surfaces():
    """Random hulls brought to touching (bisection on the routine's own separation), then moved by -1..+1.5 cm:
    for every point, p - s/2 n is on a's boundary and p + s/2 n on b's, exactly: max over the hull's face
    planes of (n_f . x - d_f) is 0 on the boundary (1e-9 m: round-off of the clip and the projection)."""
    from tumble.collision.geometry import hull_polygons

    def boundary_value(x, shape, planes):
        local = (x - shape[1]) @ shape[2]
        return np.max(local @ planes[:, :3].T - planes[:, 3])

    rng = np.random.default_rng(4)
    checked = 0
    for _ in range(60):
        ha, hb = (tb.Convex(points=rng.normal(size=(10, 3)) * 0.3) for _ in range(2))
        pa, pb = hull_polygons(ha.vertices, ha.faces)[0], hull_polygons(hb.vertices, hb.faces)[0]
        A = convex(np.zeros(3), random_rotation(rng), ha)
        Rb = random_rotation(rng)
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        lo, hi = 0.0, 2.0
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            s = collide(A, convex(d * mid, Rb, hb), spec=10.0)[2]
            lo, hi = (mid, hi) if len(s) and s.min() < 0 else (lo, mid)
        B = convex(d * (hi + rng.uniform(-0.01, 0.015)), Rb, hb)
        n, p, s, f = collide(A, B)
        for k in range(len(s)):
            assert abs(boundary_value(p[k] - 0.5 * s[k] * n, A, pa)) < 1e-9
            assert abs(boundary_value(p[k] + 0.5 * s[k] * n, B, pb)) < 1e-9
            checked += 1
    assert checked > 60


def test_cylinder_box_points_lie_on_both_surfaces():
    """As for hulls, with the exact signed distances of a solid cylinder and a box. Tolerance 1e-7 m: the
    normal comes from GJK/EPA on a round surface, which stop within ~1e-8 m (2e-8 worst seen)."""
    def cylinder_sdf(x, shape, r, h):
        local = (x - shape[1]) @ shape[2]
        q = np.array([np.hypot(local[0], local[1]) - r, abs(local[2]) - h])
        return min(max(q[0], q[1]), 0.0) + np.linalg.norm(np.maximum(q, 0.0))

    rng = np.random.default_rng(8)
    checked = 0
    for _ in range(60):
        Rb, hb = random_rotation(rng), rng.uniform(0.1, 0.5, 3)
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        C = cylinder(np.zeros(3), random_rotation(rng), 0.25, 0.3)
        lo, hi = 0.0, 3.0
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            s = collide(C, box(d * mid, Rb, hb), spec=10.0)[2]
            lo, hi = (mid, hi) if len(s) and s.min() < 0 else (lo, mid)
        B = box(d * (hi + rng.uniform(-0.01, 0.015)), Rb, hb)
        n, p, s, f = collide(C, B)
        for k in range(len(s)):
            assert abs(cylinder_sdf(p[k] - 0.5 * s[k] * n, C, 0.25, 0.3)) < 1e-7
            assert abs(box_sdf(p[k] + 0.5 * s[k] * n, B[1], B[2], hb)) < 1e-7
            checked += 1
    assert checked > 60
