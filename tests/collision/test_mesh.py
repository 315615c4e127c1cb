"""Convex shapes against a static triangle mesh (pairs/mesh.py): BVH walk, per-triangle contacts, reduction, internal edges.

Terrains are closed height-field slabs (Mesh needs a closed surface). Flat terrains are
checked against the plane they lie in (exact: 1e-12 m, the routines' arithmetic only);
the bumpy one against a brute-force point-triangle distance over every triangle (which
also checks that the BVH walk misses no triangle); the tolerance 1e-9 m is GJK's stop.
"""

import numpy as np
import pytest

import tumble as tb
from tumble.collision import CollisionPipeline
from tumble.collision.geometry import build_bvh

from .helpers import (
    SPEC,
    box,
    capsule,
    collide,
    convex,
    cylinder,
    mesh,
    random_rotation,
    rot,
    sphere,
)

DOWN = np.array([0.0, 0.0, -1.0])
CUBE = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def heightfield(n, size, height, bottom=-1.0):
    """A closed slab: an (n x n)-cell height field on top, a flat bottom, four walls. Returns (vertices, faces)."""
    xs = np.linspace(-size / 2, size / 2, n + 1)
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    top = np.stack([X, Y, height(X, Y)], axis=-1).reshape(-1, 3)
    low = top.copy()
    low[:, 2] = bottom
    m = len(top)
    V = np.concatenate([top, low])

    def idx(i, j):
        return i * (n + 1) + j

    F = []
    for i in range(n):
        for j in range(n):
            a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
            F += [(a, b, c), (a, c, d), (a + m, c + m, b + m), (a + m, d + m, c + m)]
    ring = [idx(0, j) for j in range(n)] + [idx(i, n) for i in range(n)] + \
        [idx(n, j) for j in range(n, 0, -1)] + [idx(i, 0) for i in range(n, 0, -1)]
    for k in range(len(ring)):
        p, q = ring[k], ring[(k + 1) % len(ring)]
        F += [(p, q + m, q), (p, p + m, q + m)]
    return V, np.array(F)


FLAT = heightfield(8, 4.0, lambda x, y: 0.0 * x)
FLAT_MESH = mesh((0, 0, 0), np.eye(3), *FLAT)


def bumpy(x, y):
    return 0.15 * np.sin(2.1 * x) * np.cos(1.7 * y) + 0.05 * x


BUMPY_MESH = mesh((0, 0, 0), np.eye(3), *heightfield(10, 4.0, bumpy))


def closest_on_triangle(p, a, b, c):
    """Ericson §5.1.5, in plain NumPy (the test's own copy)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = ab @ ap, ac @ ap
    if d1 <= 0 and d2 <= 0:
        return a
    bp = p - b
    d3, d4 = ab @ bp, ac @ bp
    if d3 >= 0 and d4 <= d3:
        return b
    vc = d1 * d4 - d3 * d2
    if vc <= 0 and d1 >= 0 and d3 <= 0:
        return a + d1 / (d1 - d3) * ab
    cp = p - c
    d5, d6 = ab @ cp, ac @ cp
    if d6 >= 0 and d5 <= d6:
        return c
    vb = d5 * d2 - d1 * d6
    if vb <= 0 and d2 >= 0 and d6 <= 0:
        return a + d2 / (d2 - d6) * ac
    va = d3 * d6 - d5 * d4
    if va <= 0 and (d4 - d3) >= 0 and (d5 - d6) >= 0:
        return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b)
    denom = 1.0 / (va + vb + vc)
    return a + ab * vb * denom + ac * vc * denom


# ---------------------------------------------------------------- flat terrain: against the plane z = 0
@pytest.mark.parametrize("xy", [(0.13, 0.27), (0.0, 0.0), (0.5, 0.25), (0.25, 0.25), (-1.0, 1.5)])
def test_sphere_on_flat_terrain_matches_plane(xy):
    # on a face, on an internal edge, on an internal vertex: always one point straight down
    n, p, s, f = collide(sphere((*xy, 0.299), 0.3), FLAT_MESH)
    assert len(s) >= 1
    np.testing.assert_allclose(n, DOWN, atol=1e-12)
    np.testing.assert_allclose(s, -0.001, atol=1e-12)
    np.testing.assert_allclose(p[:, :2], [xy] * len(s), atol=1e-12)


def test_box_on_flat_terrain_four_points_at_the_right_depth():
    rng = np.random.default_rng(3)
    for _ in range(20):
        xy = rng.uniform(-1, 1, 2)
        R = rot((0, 0, 1), rng.uniform(0, np.pi))
        n, p, s, f = collide(box((*xy, 0.295), R, (0.3, 0.2, 0.3)), FLAT_MESH)
        assert len(s) == 4
        # internal-edge handling: never a tilted edge normal on a flat floor
        np.testing.assert_allclose(n, DOWN, atol=1e-12)
        np.testing.assert_allclose(s, -0.005, atol=1e-12)
        corners = (xy[0], xy[1], 0.295) + (np.array([0.3, 0.2, 0.3]) * CUBE[CUBE[:, 2] < 0]) @ R.T
        corners[:, 2] = -0.0025
        for q in corners:
            assert np.min(np.linalg.norm(p - q, axis=1)) < 1e-12


@pytest.mark.parametrize("kind,count", [("cylinder", 4), ("cylinder lying", 2), ("capsule lying", 2), ("convex", 4)])
def test_other_shapes_resting_on_flat_terrain(kind, count):
    shape = {
        "cylinder": cylinder((0.1, 0.2, 0.398), np.eye(3), 0.3, 0.4),
        "cylinder lying": cylinder((0.1, 0.2, 0.298), rot((1, 0, 0), np.pi / 2), 0.3, 0.4),
        "capsule lying": capsule((0.1, 0.2, 0.198), rot((0, 1, 0), np.pi / 2), 0.2, 0.5),
        "convex": convex((0.1, 0.2, 0.498), rot((0, 0, 1), 0.3), 0.5 * CUBE),
    }[kind]
    n, p, s, f = collide(shape, FLAT_MESH)
    assert len(s) == count
    np.testing.assert_allclose(n, DOWN, atol=1e-9)  # the lying cylinder's side: EPA on a round surface
    np.testing.assert_allclose(s, -0.002, atol=1e-9)


def test_far_above_and_behind_give_nothing():
    assert len(collide(sphere((0, 0, 0.3 + SPEC + 1e-6), 0.3), FLAT_MESH)[2]) == 0
    assert len(collide(sphere((10, 0, 0), 0.3), FLAT_MESH)[2]) == 0


def test_feature_keys_stable_for_a_box_on_terrain():
    """Triangle rows and slots name the points: the same keys after 0.1 mm moves (warm starting)."""
    def case(d):
        return box(np.array([0.3, 0.1, 0.298]) + d, rot((0, 0, 1), 0.2), (0.3, 0.2, 0.3)), FLAT_MESH

    _, _, s0, f0 = collide(*case(np.zeros(3)))
    assert len(f0) == 4 and len(set(f0.tolist())) == 4
    for d in [(1e-4, 0, 0), (0, 1e-4, 0), (0, 0, -1e-4)]:
        _, _, s, f = collide(*case(np.asarray(d)))
        assert sorted(f.tolist()) == sorted(f0.tolist())


# ---------------------------------------------------------------- bumpy terrain: brute force
def test_sphere_on_bumpy_terrain_matches_brute_force():
    """Deepest separation = min over all triangles of |c - closest point| - r (sphere centre above the surface)."""
    rng = np.random.default_rng(5)
    tris = BUMPY_MESH[4].vertices[BUMPY_MESH[4].faces]
    compared = 0
    for _ in range(60):
        x, y = rng.uniform(-1.8, 1.8, 2)
        r = rng.uniform(0.05, 0.4)
        c = np.array([x, y, bumpy(x, y) + r + rng.uniform(-0.02, 0.03)])
        n, p, s, f = collide(sphere(c, r), BUMPY_MESH)
        d = min(np.linalg.norm(c - closest_on_triangle(c, *t)) for t in tris)
        if d - r >= SPEC:
            assert len(s) == 0
            continue
        if d < 1e-3:
            continue  # centre at the surface: the depth is EPA's, not a distance
        assert len(s) >= 1
        assert np.min(s) == pytest.approx(d - r, abs=1e-9)
        assert abs(np.linalg.norm(n) - 1) < 1e-12 and n[2] < 0  # from the sphere into the ground
        compared += 1
    assert compared >= 30


def test_v_groove_two_points_one_per_slope():
    # a valley along y: two slopes z = |x| tan(20 deg); a sphere sitting in it touches both
    t = np.tan(np.radians(20))
    groove = mesh((0, 0, 0), np.eye(3), *heightfield(8, 4.0, lambda x, y: np.abs(x) * t))
    r = 0.3
    c = np.array([0.0, 0.1, r / np.cos(np.radians(20)) - 0.001])
    n, p, s, f = collide(sphere(c, r), groove)
    assert len(s) == 2
    # each slope's distance is (c_z cos - ...) : both the same by symmetry
    expected = c[2] * np.cos(np.radians(20)) - r
    np.testing.assert_allclose(s, expected, atol=1e-12)
    assert p[0, 0] * p[1, 0] < 0  # one point on each side of the valley
    # the shared normal: the two slopes' normals averaged (equal weights by symmetry), straight down
    np.testing.assert_allclose(n, DOWN, atol=1e-9)


def test_bvh_holds_every_triangle_once_and_boxes_contain_them():
    rng = np.random.default_rng(1)
    tris = rng.normal(size=(57, 3, 3))
    order, aabb, first, count, skip = build_bvh(tris, leaf_size=4)
    assert sorted(order.tolist()) == list(range(57))
    leaves = np.flatnonzero(count > 0)
    covered = np.concatenate([np.arange(first[k], first[k] + count[k]) for k in leaves])
    assert sorted(covered.tolist()) == list(range(57))
    stored = tris[order]
    for k in range(len(aabb)):
        if count[k]:
            t = stored[first[k]:first[k] + count[k]]
            assert np.all(t.min(axis=(0, 1)) >= aabb[k, 0]) and np.all(t.max(axis=(0, 1)) <= aabb[k, 1])
        assert k < skip[k] <= len(aabb)


def test_mesh_in_a_world_pipeline():
    """A fixed mesh and a box in a World: CollisionPipeline finds the (box, mesh) manifold, mesh as b."""
    w = tb.World()
    w.add_body(tb.Mesh(vertices=FLAT[0], faces=FLAT[1]), fixed=True, name="ground")
    w.add_body(tb.Box((0.4, 0.4, 0.4)), mass=1.0, position=(0.3, 0.2, 0.199), name="crate")
    c = CollisionPipeline(w).detect()
    assert c.manifold_count == 1 and c.manifold_point_count[0] == 4
    assert c.manifold_body_a[0] == 1 and c.manifold_body_b[0] == 0
    np.testing.assert_allclose(c.manifold_normal[0], DOWN, atol=1e-12)
    np.testing.assert_allclose(c.contact_separation, -0.001, atol=1e-12)


def test_random_shapes_on_bumpy_terrain_are_sane():
    """Every shape type against the bumpy mesh: unit normal into the ground, at most 4 distinct features,
    and each point's separation within the speculative distance."""
    rng = np.random.default_rng(9)
    hull = tb.Convex(points=rng.normal(size=(10, 3)) * 0.2)
    for _ in range(30):
        x, y = rng.uniform(-1.5, 1.5, 2)
        R = random_rotation(rng)
        c = np.array([x, y, bumpy(x, y) + rng.uniform(0.05, 0.25)])
        for shape in (box(c, R, (0.2, 0.1, 0.15)), cylinder(c, R, 0.15, 0.1), capsule(c, R, 0.1, 0.15),
                      convex(c, R, hull), sphere(c, 0.2)):
            n, p, s, f = collide(shape, BUMPY_MESH)
            assert len(s) <= 4 and len(set(f.tolist())) == len(f)
            if len(s):
                assert abs(np.linalg.norm(n) - 1) < 1e-12 and n[2] < 0
                assert np.all(s < SPEC)
