"""A static mesh's BVH: built once per mesh content and shared by every shape table (a Simulator's, a ray
cast's, each one after a spawn), never served stale after an edit; the compiled build gives the
tree the recursive Python build gave, node for node; closest_points' nearest-first walk gives the
brute-force answer over every triangle (docs/benchmarks.md, "Static mesh trees: built once, faster")."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import tumble as tb
from tumble.collision import geometry
from tumble.collision.distance import convex_distance, shape_poses
from tumble.collision.geometry import build_bvh, build_shape_table, mesh_tree
from tumble.collision.pairs.gjk import gjk_scratch
from tumble.collision.pairs.mesh import TRIANGLE
from tumble.shapes import SHAPE_CONVEX


def _reference_bvh(triangles, leaf_size=4):
    """``build_bvh`` as the recursive Python closure it was (2.2 s for 102 134 triangles)."""
    centroid = triangles.mean(axis=1)
    lo_t = triangles.min(axis=1)
    hi_t = triangles.max(axis=1)
    order = np.arange(len(triangles))
    nodes = []

    def build(start, stop):
        idx = order[start:stop]
        node = [np.stack([lo_t[idx].min(axis=0), hi_t[idx].max(axis=0)]), start, 0, 0]
        me = len(nodes)
        nodes.append(node)
        if stop - start <= leaf_size:
            node[2] = stop - start
        else:
            c = centroid[idx]
            axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
            order[start:stop] = idx[np.argsort(c[:, axis], kind="stable")]
            mid = (start + stop) // 2
            build(start, mid)
            build(mid, stop)
        nodes[me][3] = len(nodes)

    build(0, len(triangles))
    return (order, np.array([n[0] for n in nodes], dtype=float).reshape(-1, 2, 3),
            np.array([n[1] for n in nodes], dtype=np.int64), np.array([n[2] for n in nodes], dtype=np.int64),
            np.array([n[3] for n in nodes], dtype=np.int64))


def _terrain(seed, cells=24, amplitude=0.05, size=4.0):
    heights = amplitude * np.random.default_rng(seed).random((cells + 1, cells + 1))
    return tb.heightfield(heights, (size, size))


@pytest.fixture
def builds(monkeypatch):
    """Counts the BVH builds (``geometry.build_bvh``, which ``mesh_tree`` calls)."""
    calls = []

    def counting(triangles, leaf_size=geometry.BVH_LEAF_SIZE):
        calls.append(len(triangles))
        return build_bvh(triangles, leaf_size)

    monkeypatch.setattr(geometry, "build_bvh", counting)
    return calls


def test_a_mesh_tree_is_built_once_across_simulators_ray_casts_and_spawns(builds):
    """Before, each shape table built the tree again: the Simulator's first step, the ray cast's own
    table, the table after a spawn, a second Simulator (2.2 s each for a 102 134-triangle terrain)."""
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(_terrain(101), fixed=True)
    w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0.0, 0.0, 0.5))
    sim = tb.Simulator(w)
    sim.step()
    hit = w.ray_cast((0.3, 0.2, 5.0), (0.0, 0.0, -1.0))  # past the box and the sphere
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(1.0, 0.0, 0.5))  # a spawn
    sim.step()
    again = w.ray_cast((0.3, 0.2, 5.0), (0.0, 0.0, -1.0))
    tb.Simulator(w).step()
    w.closest_points(1, 0)
    assert len(builds) == 1
    assert hit.body[0] == again.body[0] == 0 and hit.distance[0] == again.distance[0]
    # every table holds the same rows
    a, b = build_shape_table(w), build_shape_table(w)
    assert np.array_equal(a.mesh_triangle, b.mesh_triangle) and np.array_equal(a.mesh_node_skip, b.mesh_node_skip)
    assert len(builds) == 1


def test_records_of_the_same_content_share_one_tree_and_pickles_carry_none(builds):
    heights = 0.05 * np.random.default_rng(102).random((17, 17))
    m1, m2 = tb.heightfield(heights, (3.0, 3.0)), tb.heightfield(heights.copy(), (3.0, 3.0))
    bare = pickle.dumps(m1)
    t1 = mesh_tree(m1)
    assert mesh_tree(m2) is t1 and mesh_tree(m1) is t1
    assert len(builds) == 1
    data = pickle.dumps(m1)
    assert data == bare and b"MeshTree" not in data  # the record pickles without its tree
    m3 = pickle.loads(data)
    assert mesh_tree(m3) is t1 and len(builds) == 1
    w = tb.World()
    w.add_body(m3, fixed=True)
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(0.0, 0.0, 1.0))
    w2 = pickle.loads(pickle.dumps(w))
    tb.Simulator(w2).step()
    assert len(builds) == 1
    assert not t1.triangle.flags.writeable  # a shared tree cannot be changed through a table


def test_an_edited_or_replaced_mesh_gets_a_new_tree(builds):
    mesh = _terrain(103)
    w = tb.World()
    w.add_body(mesh, fixed=True)
    before = build_shape_table(w).mesh_triangle.copy()
    mesh.vertices[:, 2] += 0.25  # edited in place
    table = build_shape_table(w)
    assert len(builds) == 2
    tree = mesh_tree(mesh)
    assert np.array_equal(table.mesh_triangle, tree.triangle)
    assert np.array_equal(tree.triangle, mesh.vertices[mesh.faces][build_bvh(mesh.vertices[mesh.faces])[0]])
    assert np.allclose(table.mesh_triangle[..., 2], before[..., 2] + 0.25)
    other = _terrain(104)  # replaced by another record
    w2 = tb.World()
    w2.add_body(other, fixed=True)
    assert mesh_tree(other) is not tree
    assert np.array_equal(build_shape_table(w2).mesh_triangle, mesh_tree(other).triangle)
    assert len(builds) == 3
    # the same vertices and faces, as an open surface: other edge flags, so another tree
    open_surface = tb.Mesh(vertices=mesh.vertices, faces=mesh.faces, closed=False)
    assert mesh_tree(open_surface) is not mesh_tree(mesh)


@pytest.mark.parametrize("leaf_size", [1, 2, 4, 7])
def test_the_compiled_build_gives_the_recursive_builds_tree(leaf_size):
    rng = np.random.default_rng(5)
    cases = [rng.normal(size=(n, 3, 3)) for n in (1, 2, 3, 4, 5, 9, 57, 600)]
    cases.append(np.round(rng.normal(size=(300, 3, 3)), 1))  # many equal centroid coordinates
    for hf in (_terrain(6, cells=20), tb.heightfield(np.zeros((12, 15)), (2.0, 3.0))):  # grid ties
        cases.append(hf.vertices[hf.faces])
    for tri in cases:
        got, want = build_bvh(tri, leaf_size), _reference_bvh(tri, leaf_size)
        for g, r in zip(got, want):
            assert g.dtype == r.dtype and np.array_equal(g, r)


def test_the_tree_answers_box_and_ray_queries_as_every_triangle_does():
    hf = _terrain(7, cells=30, amplitude=0.4)
    tri = hf.vertices[hf.faces]
    order, aabb, first, count, skip = build_bvh(tri)
    stored = tri[order]
    lo_t, hi_t = stored.min(axis=1), stored.max(axis=1)
    rng = np.random.default_rng(8)
    for _ in range(200):  # boxes: the walk's triangles are those whose own boxes overlap it
        c = rng.uniform(-2.2, 2.2, 3) * (1, 1, 0.3)
        h = rng.uniform(0.01, 0.6, 3)
        lo, hi = c - h, c + h
        found, i = [], 0
        while i < len(aabb):
            if np.any(aabb[i, 0] > hi) or np.any(aabb[i, 1] < lo):
                i = skip[i]
                continue
            found += [t for t in range(first[i], first[i] + count[i]) if np.all(lo_t[t] <= hi) and np.all(hi_t[t] >= lo)]
            i += 1
        brute = np.flatnonzero(np.all(lo_t <= hi, axis=1) & np.all(hi_t >= lo, axis=1))
        assert sorted(found) == brute.tolist()
    # rays down onto the terrain: the ray cast's hit is the nearest triangle's (Moller-Trumbore, all)
    w = tb.World()
    w.add_body(hf, fixed=True)
    origin = np.c_[rng.uniform(-1.9, 1.9, (300, 2)), np.full(300, 3.0)]
    direction = np.c_[rng.normal(scale=0.3, size=(300, 2)), -np.ones(300)]
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    hits = w.ray_cast(origin, direction)
    a, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    for o, d, body, dist in zip(origin, direction, hits.body, hits.distance):
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        ok = np.abs(det) > 1e-14
        s = o - a
        u = np.einsum("ij,ij->i", s, p) / np.where(ok, det, 1.0)
        q = np.cross(s, e1)
        v = (q @ d) / np.where(ok, det, 1.0)
        t = np.einsum("ij,ij->i", e2, q) / np.where(ok, det, 1.0)
        inside = ok & (u >= -1e-12) & (v >= -1e-12) & (u + v <= 1 + 1e-12) & (t > 0)
        if inside.any():
            assert body == 0 and dist == pytest.approx(t[inside].min(), abs=1e-9)
        else:
            assert body == -1


def _brute_force_distance(table, pos, rot, sa, sm):
    """Shape row sa (convex) against every triangle of mesh row sm: the smallest distance, the first
    triangle on a tie, and its points and normal."""
    ta = table.shape_type[sa]
    v0, nv = table.shape_data[sa, 0], table.shape_data[sa, 1]
    verts = table.hull_vertex[v0:v0 + nv] if ta == SHAPE_CONVEX else table.hull_vertex[0:0]
    t0, nt = table.shape_data[sm, 0], table.shape_data[sm, 1]
    scratch, work = gjk_scratch(), np.empty(9)
    best, out = np.inf, None
    for t in range(t0, t0 + nt):
        d = convex_distance(ta, pos[sa], rot[sa], table.shape_params[sa], verts, TRIANGLE, pos[sm], rot[sm],
                            table.shape_params[sm], table.mesh_triangle[t], np.inf, scratch, work)
        if d < best:
            best, out = d, work.copy()
    return best, out


def test_nearest_first_closest_points_equal_brute_force_over_every_triangle():
    rng = np.random.default_rng(9)
    hull = tb.Convex(points=0.15 * rng.normal(size=(16, 3)))
    shapes = [tb.Box(size=(0.3, 0.2, 0.1)), tb.Sphere(radius=0.12), tb.Capsule(radius=0.05, length=0.3),
              tb.Cylinder(radius=0.1, length=0.2), hull]
    for terrain in (_terrain(10, cells=16, amplitude=0.3, size=3.0), tb.heightfield(np.zeros((7, 7)), (2.0, 2.0))):
        w = tb.World()
        w.add_body(terrain, fixed=True, position=(0.1, -0.1, 0.02), orientation=(0.995, 0.07, 0.05, 0.0))
        bodies = []
        for k in range(60):
            q = rng.normal(size=4) if k % 3 else np.array([1.0, 0.0, 0.0, 0.0])
            z = (rng.uniform(-0.2, 0.5), rng.uniform(0.5, 2.0), rng.uniform(2.0, 10.0))[k % 3]
            xy = rng.uniform(-1.8, 1.8, 2) if terrain.faces.shape[0] > 200 else np.round(rng.uniform(-1, 1, 2), 1)
            body = w.add_body(shapes[k % len(shapes)], mass=1.0, position=(*xy, z), orientation=q / np.linalg.norm(q))
            bodies.append(w.index_of(body))
        cp = w.closest_points(np.array(bodies), np.zeros(len(bodies), dtype=np.int64))
        scene, pos, rot, _ = shape_poses(w)
        table = scene.table
        for row, b in enumerate(bodies):
            sa = int(np.flatnonzero(table.shape_body == b)[0])
            d, out = _brute_force_distance(table, pos, rot, sa, 0)
            assert cp.distance[row] == pytest.approx(d, abs=1e-12)
            # the same witness points (triangles that meet at the nearest corner or edge give the same
            # distance to round-off: which of them answers may differ in the last bits)
            np.testing.assert_allclose(cp.point_a[row], out[0:3], rtol=0, atol=1e-9)
            np.testing.assert_allclose(cp.point_b[row], out[3:6], rtol=0, atol=1e-9)
            np.testing.assert_allclose(cp.normal[row], out[6:9], rtol=0, atol=1e-6)
        near = w.closest_points(np.array(bodies), np.zeros(len(bodies), dtype=np.int64), max_distance=0.3)
        within = cp.distance <= 0.3
        assert np.array_equal(near.distance[within], cp.distance[within]) and np.all(np.isinf(near.distance[~within]))
