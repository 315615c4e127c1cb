"""Seeded fuzz tests: random poses, each contact checked against independent brute-force geometry.

For every contact: the normal is unit; the point minus/plus half the separation along
the normal lies on shape a's/b's surface (exact signed distance of a box, distance to
a segment); the deepest separation agrees with an independent figure (box-box: SciPy
linprog for overlap, a search over directions for the penetration depth, vertices and
edges for the distance; capsules: a densely sampled core).
"""

import numpy as np
import pytest

from tumble.collision.constants import FEATURE_FACE

from .helpers import (SPEC, box, box_box_distance, box_sdf, boxes_intersect, capsule, collide, penetration_depth,
                      random_rotation, segment_distance, sphere)


def check_unit_normal(n, s):
    if len(s):
        assert abs(np.linalg.norm(n) - 1.0) < 1e-12


def random_box_pair(rng, touching=False):
    ha, hb = rng.uniform(0.1, 0.6, 3), rng.uniform(0.1, 0.6, 3)
    A = box(np.zeros(3), random_rotation(rng), ha)
    Rb = random_rotation(rng)
    d = rng.normal(size=3)
    d /= np.linalg.norm(d)
    if not touching:
        return A, box(d * rng.uniform(0.2, 1.0) * (np.linalg.norm(ha) + np.linalg.norm(hb)), Rb, hb)
    # bisect (with the independent overlap test) for the touching distance along d, then
    # move by a small random amount: the cases that matter for resting contact
    lo, hi = 0.0, np.linalg.norm(ha) + np.linalg.norm(hb) + 1e-6
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if boxes_intersect(A, box(d * mid, Rb, hb)) else (lo, mid)
    return A, box(d * (lo + rng.uniform(-0.03, 0.03)), Rb, hb)


@pytest.mark.parametrize("touching", [False, True])
def test_box_box_fuzz(touching):
    rng = np.random.default_rng(2024 + touching)
    n_pen = 0
    for _ in range(60):
        A, B = random_box_pair(rng, touching)
        n, p, s, f = collide(A, B)
        check_unit_normal(n, s)
        for k in range(len(s)):
            # both surface points lie on the boxes' surfaces (faces: exactly; edges: the edges)
            assert abs(box_sdf(p[k] - 0.5 * s[k] * n, A[1], A[2], A[3][:3])) < 1e-9
            assert abs(box_sdf(p[k] + 0.5 * s[k] * n, B[1], B[2], B[3][:3])) < 1e-9
        if boxes_intersect(A, B):
            depth = penetration_depth(A, B, rng, 1500)
            assert len(s) > 0 and np.min(s) < 1e-9
            # never shallower than the true depth; deeper only by the face-over-edge preference
            assert -(0.12 * depth + 0.003) <= np.min(s) + depth <= 1e-6
            n_pen += 1
        else:
            dist = box_box_distance(A, B)
            if dist > SPEC + 1e-9:
                assert len(s) == 0
            if len(s):
                assert np.min(s) > -1e-9
                if dist > 1e-6:
                    assert np.min(s) <= dist + 1e-9 or np.all(f >= FEATURE_FACE)
    assert n_pen > 15


def capsule_core(c):
    _, pos, R, prm = c
    return pos - prm[1] * R[:, 2], pos + prm[1] * R[:, 2], prm[0]


def capsule_sdf(x, c):
    p0, p1, r = capsule_core(c)
    d = p1 - p0
    t = np.clip(((x - p0) @ d) / (d @ d), 0, 1)
    return np.linalg.norm(x - (p0 + t * d)) - r


def test_sphere_box_fuzz():
    rng = np.random.default_rng(5)
    for _ in range(300):
        B = box(rng.normal(size=3) * 0.1, random_rotation(rng), rng.uniform(0.1, 0.5, 3))
        S = sphere(B[1] + rng.normal(size=3) * 0.4, rng.uniform(0.05, 0.3))
        n, p, s, f = collide(S, B)
        expected = box_sdf(S[1], B[1], B[2], B[3][:3]) - S[3][0]
        if expected >= SPEC:
            assert len(s) == 0
            continue
        assert len(s) == 1
        check_unit_normal(n, s)
        assert s[0] == pytest.approx(expected, abs=1e-12)
        assert abs(box_sdf(p[0] + 0.5 * s[0] * n, B[1], B[2], B[3][:3])) < 1e-12
        assert np.linalg.norm(p[0] - 0.5 * s[0] * n - S[1]) == pytest.approx(S[3][0], abs=1e-12)


def test_capsule_box_fuzz():
    rng = np.random.default_rng(11)
    t = np.linspace(0, 1, 4001)[:, None]
    for _ in range(300):
        B = box(np.zeros(3), random_rotation(rng), rng.uniform(0.1, 0.5, 3))
        C = capsule(rng.normal(size=3) * 0.35, random_rotation(rng), rng.uniform(0.03, 0.2), rng.uniform(0.05, 0.5))
        n, p, s, f = collide(C, B)
        p0, p1, r = capsule_core(C)
        sd = box_sdf(p0 + t * (p1 - p0), B[1], B[2], B[3][:3])
        true_sep = np.min(sd) - r
        if true_sep >= SPEC + 1e-9:
            assert len(s) == 0
            continue
        check_unit_normal(n, s)
        if np.min(sd) > 1e-3:
            # core outside the box: the separation is the exact distance (sampled to ~1e-4 here)
            assert len(s) >= 1
            assert np.min(s) == pytest.approx(true_sep, abs=2e-4 * np.linalg.norm(p1 - p0) + 1e-9)
            for k in range(len(s)):
                assert abs(box_sdf(p[k] + 0.5 * s[k] * n, B[1], B[2], B[3][:3])) < 1e-9
                # on the capsule's surface, or inside it where the clipped core is not
                # parallel to the face (then the point is the lowest point of the core's
                # sphere there, as in Box2D's capsule manifolds)
                assert capsule_sdf(p[k] - 0.5 * s[k] * n, C) < 1e-9
                if len(s) == 1:
                    assert abs(capsule_sdf(p[k] - 0.5 * s[k] * n, C)) < 1e-9
        elif np.min(sd) < -1e-3:
            assert len(s) >= 1 and np.min(s) < 0


def test_capsule_capsule_fuzz():
    rng = np.random.default_rng(3)
    for _ in range(300):
        A = capsule(np.zeros(3), random_rotation(rng), rng.uniform(0.03, 0.2), rng.uniform(0.05, 0.5))
        Rb = A[2] @ random_rotation(np.random.default_rng(0)) if rng.random() < 0.2 else random_rotation(rng)
        if rng.random() < 0.2:
            Rb = A[2]  # parallel: two points
        B = capsule(rng.normal(size=3) * 0.3, Rb, rng.uniform(0.03, 0.2), rng.uniform(0.05, 0.5))
        n, p, s, f = collide(A, B)
        a0, a1, ra = capsule_core(A)
        b0, b1, rb = capsule_core(B)
        true_sep = segment_distance(a0, a1, b0, b1, 4001) - ra - rb
        if true_sep >= SPEC + 1e-6:
            assert len(s) == 0
            continue
        if true_sep < SPEC - 1e-6:
            assert len(s) >= 1
        if len(s) == 0:
            continue
        check_unit_normal(n, s)
        assert np.min(s) == pytest.approx(true_sep, abs=1e-4)
        for k in range(len(s)):
            assert abs(capsule_sdf(p[k] - 0.5 * s[k] * n, A)) < 1e-9 or len(s) == 2
            assert abs(capsule_sdf(p[k] + 0.5 * s[k] * n, B)) < 1e-9 or len(s) == 2


def _ellipsoid(pos, R, radii):
    from tumble.shapes import SHAPE_ELLIPSOID

    return SHAPE_ELLIPSOID, np.asarray(pos, float), np.asarray(R, float), np.array([*radii, 0.0])


def _point_ellipsoid_distance(p, radii):
    """Distance from p (shape frame, outside) to the ellipsoid's surface and the nearest point:
    q_i = a_i^2 p_i / (a_i^2 + t), t > 0 the root of sum (a_i p_i / (a_i^2 + t))^2 = 1 (the
    Lagrange condition; brentq on a bracket), no GJK."""
    from scipy.optimize import brentq

    a2 = np.asarray(radii) ** 2
    g = lambda t: np.sum(a2 * p * p / (a2 + t) ** 2) - 1.0  # noqa: E731
    t = brentq(g, 0.0, np.linalg.norm(p) * np.max(radii) * 4.0, xtol=1e-15, rtol=1e-15, maxiter=500)
    q = a2 * p / (a2 + t)
    return float(np.linalg.norm(p - q)), q


def test_ellipsoid_plane_and_sphere_fuzz():
    """An ellipsoid on a plane: one contact, its separation the closed form z - |A R^T e_z| (1e-12)
    and its point the lowest point; an ellipsoid against a sphere (GJK/EPA): one contact, the
    separation the exact point-ellipsoid distance less the radius (Lagrange root, no GJK) to 1e-8 m
    (GJK/EPA on a curved surface, docs/contact.md), both surface points on their surfaces to 1e-7."""
    from .helpers import plane

    rng = np.random.default_rng(17)
    P = plane()
    for _ in range(200):
        radii = rng.uniform(0.05, 0.4, 3)
        R = random_rotation(rng)
        E = _ellipsoid((0, 0, rng.uniform(-0.02, 0.05) + np.linalg.norm(radii * R[2])), R, radii)
        n, p, s, f = collide(P, E)
        expected = E[1][2] - np.linalg.norm(radii * R[2])
        if expected >= SPEC:
            assert len(s) == 0
            continue
        assert len(s) == 1
        np.testing.assert_allclose(n, (0, 0, 1), atol=1e-15)
        assert s[0] == pytest.approx(expected, abs=1e-12)
        low = R.T @ (p[0] + 0.5 * s[0] * n - E[1])  # b's surface point, shape frame
        assert np.sum((low / radii) ** 2) == pytest.approx(1.0, abs=1e-12)
    checked = 0
    for _ in range(200):
        radii = rng.uniform(0.05, 0.4, 3)
        R = random_rotation(rng)
        E = _ellipsoid(rng.normal(size=3) * 0.05, R, radii)
        r = rng.uniform(0.05, 0.3)
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        centre = E[1] + d * (np.linalg.norm(radii * (R.T @ d)) + rng.uniform(-0.8, 1.0) * r)
        local = R.T @ (centre - E[1])
        if np.sum((local / radii) ** 2) <= 1.0 + 1e-6:
            continue  # the sphere's centre inside the ellipsoid: no point-distance oracle
        dist, _ = _point_ellipsoid_distance(local, radii)
        expected = dist - r
        n, p, s, f = collide(sphere(centre, r), E)
        if expected >= SPEC:
            assert len(s) == 0
            continue
        checked += 1
        assert len(s) == 1
        check_unit_normal(n, s)
        assert s[0] == pytest.approx(expected, abs=1e-8)
        on_sphere = p[0] - 0.5 * s[0] * n
        on_ellipsoid = R.T @ (p[0] + 0.5 * s[0] * n - E[1])
        assert np.linalg.norm(on_sphere - centre) == pytest.approx(r, abs=1e-7)
        assert np.sum((on_ellipsoid / radii) ** 2) == pytest.approx(1.0, abs=1e-6)
    assert checked > 80


def test_smooth_penetration_is_newtons_minimum_of_the_support_functions():
    """Two overlapping ellipsoids, or an ellipsoid and a sphere's centre (pairs/gjk._smooth_depth):
    Newton from a coarse EPA ends (done, not the EPA fallback) in at least 95 % of 300 random
    overlaps, at a stationary direction of h_D(n) = h_A(n) + h_B(-n): its tangent gradient below
    1e-9 m; at a depth between the two bounds a full 64-iteration EPA gives, its inscribed
    polytope's face distance below and h_D along its normal above (any direction's h_D bounds the
    minimum from above); with the support points as the deepest points. (On deep overlaps, 0.3 m,
    the full EPA is itself 1e-5 to 4e-5 m short where Newton meets a Nelder-Mead minimum of h_D
    to 1e-15: measured.)"""
    from tumble.collision.pairs.gjk import (EPA_ITERATIONS, SMOOTH_EPA_ITERATIONS, _epa, _smooth_depth, gjk,
                                            gjk_scratch)
    from tumble.shapes import SHAPE_SPHERE

    rng = np.random.default_rng(23)
    scratch = gjk_scratch()
    H = np.empty((6, 3))
    done = trials = 0
    for _ in range(300):
        A = _ellipsoid(np.zeros(3), random_rotation(rng), rng.uniform(0.05, 0.4, 3))
        if rng.uniform() < 0.3:
            B = (SHAPE_SPHERE, rng.normal(size=3) * 0.1, np.eye(3), np.array([0.1, 0, 0, 0.0]))
        else:
            B = _ellipsoid(rng.normal(size=3) * 0.2, random_rotation(rng), rng.uniform(0.05, 0.4, 3))
        args = (A[0], A[1], A[2], A[3], np.zeros((0, 3)), B[0], B[1], B[2], B[3], np.zeros((0, 3)))
        k, dist, _, _ = gjk(*args, 1.0, scratch)
        if k != 4:
            continue  # apart (or touching): GJK's answer, no penetration solve
        trials += 1
        ok, coarse, n0, _, _ = _epa(*args, k, scratch, SMOOTH_EPA_ITERATIONS)
        assert ok
        ok_full, full, n_full, _, _ = _epa(*args, k, scratch, EPA_ITERATIONS)
        finished, depth, n, pa, pb = _smooth_depth(A[0], A[1], A[2], A[3], B[0], B[1], B[2], B[3], n0, H[:3], H[3:])
        if not finished:
            continue
        done += 1
        n = np.asarray(n)
        n_full = np.asarray(n_full)
        upper = (A[1] @ n_full + np.linalg.norm(A[3][:3] * (A[2].T @ n_full))
                 + (-B[1] @ n_full if B[0] == SHAPE_SPHERE else -B[1] @ n_full + np.linalg.norm(B[3][:3] * (B[2].T @ n_full))))
        assert full - 1e-12 <= depth <= upper + 1e-12, (full, depth, upper)
        # stationary: the support point of A - B along n is depth * n (no tangent gradient)
        g = np.asarray(pa) - np.asarray(pb)
        assert np.linalg.norm(g - (g @ n) * n) < 1e-9
        assert g @ n == pytest.approx(depth, abs=1e-12)
    assert trials > 150 and done >= 0.95 * trials, (done, trials)
