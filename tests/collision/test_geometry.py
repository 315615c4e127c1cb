"""ShapeTable and update_bounds."""

from pathlib import Path

import numpy as np
import pytest

import tumble as tb
from tumble.collision import SPECULATIVE_DISTANCE, build_shape_table, update_bounds
from tumble.collision.geometry import mesh_edge_flags
from tumble.shapes import SHAPE_BOX, SHAPE_CAPSULE, SHAPE_CONVEX, SHAPE_PLANE, SHAPE_SPHERE

from .helpers import rot


def make_world():
    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1), offset=0.5), fixed=True, name="ground")
    w.add_body(tb.Sphere(0.3), mass=1.0, position=(1, 2, 3), name="ball")
    w.add_body(tb.Capsule(0.1, 1.0), mass=1.0, position=(0, 0, 1), name="pill",
               orientation=(np.cos(np.pi / 4), np.sin(np.pi / 4), 0, 0))
    w.add_body(tb.Box((0.2, 0.4, 0.6)), mass=1.0, position=(-1, 0, 1), name="crate")
    return w


def test_table_rows():
    t = build_shape_table(make_world())
    assert t.shape_count == 4
    assert t.shape_type.tolist() == [SHAPE_PLANE, SHAPE_SPHERE, SHAPE_CAPSULE, SHAPE_BOX]
    assert t.shape_body.tolist() == [0, 1, 2, 3]
    assert t.shape_type.dtype == np.int64 and t.shape_body.dtype == np.int64
    np.testing.assert_allclose(t.shape_params[0], [0, 0, 1, 0.5])
    np.testing.assert_allclose(t.shape_params[1], [0.3, 0, 0, 0])
    np.testing.assert_allclose(t.shape_params[2], [0.1, 0.5, 0, 0])
    np.testing.assert_allclose(t.shape_params[3], [0.1, 0.2, 0.3, 0])
    np.testing.assert_array_equal(t.shape_local_q, np.tile([1.0, 0, 0, 0], (4, 1)))
    np.testing.assert_array_equal(t.shape_local_pos, 0.0)
    assert t.body_moving.tolist() == [False, True, True, True]


def test_unsupported_types_are_named():
    # particles have no collision shape; a mesh on a moving body collides as its hull (warned when concave)
    w = make_world()
    w.add_body(tb.Particles([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [1.0] * 4), name="dust")
    with pytest.raises(NotImplementedError, match="'particles'.*not supported") as err:
        build_shape_table(w)
    assert "dust" in str(err.value)
    t = build_shape_table(w, skip_unsupported=True)
    assert t.shape_count == 4 and t.body_count == 5
    from tumble.mass import box_mesh

    v, f = box_mesh((1, 1, 1))
    w2 = make_world()
    w2.add_body(tb.Mesh(vertices=v, faces=f), mass=1.0, name="rock")
    assert build_shape_table(w2).shape_type[-1] == SHAPE_CONVEX


def test_bounds():
    w = make_world()
    t = build_shape_table(w)
    m = SPECULATIVE_DISTANCE
    pos, R, aabb = update_bounds(w.x, w.R, t, m)
    assert np.all(np.isinf(aabb[0]))
    np.testing.assert_allclose(aabb[1], [[1 - 0.3 - m, 2 - 0.3 - m, 3 - 0.3 - m], [1.3 + m, 2.3 + m, 3.3 + m]])
    # capsule along z turned about x by 90 degrees: its axis is -y
    np.testing.assert_allclose(aabb[2], [[-0.1 - m, -0.6 - m, 0.9 - m], [0.1 + m, 0.6 + m, 1.1 + m]], atol=1e-12)
    np.testing.assert_allclose(aabb[3], [[-1.1 - m, -0.2 - m, 0.7 - m], [-0.9 + m, 0.2 + m, 1.3 + m]])
    np.testing.assert_allclose(R[3], np.eye(3))


def test_bounds_contain_rotated_box_corners():
    rng = np.random.default_rng(1)
    w = tb.World()
    for _ in range(20):
        q = rng.normal(size=4)
        w.add_body(tb.Box(tuple(rng.uniform(0.1, 1.0, 3))), mass=1.0, position=tuple(rng.normal(size=3)),
                   orientation=tuple(q / np.linalg.norm(q)))
    t = build_shape_table(w)
    pos, R, aabb = update_bounds(w.x, w.R, t, 0.0)
    for s in range(20):
        h = t.shape_params[s, :3]
        signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
        corners = pos[s] + (signs * h) @ R[s].T
        # tight: the box touches each face of its AABB
        np.testing.assert_allclose(corners.min(axis=0), aabb[s, 0], atol=1e-12)
        np.testing.assert_allclose(corners.max(axis=0), aabb[s, 1], atol=1e-12)


def test_shape_origin_is_x_minus_R_com_offset():
    # a fixed box without mass has no offset; check the pose law with a synthetic offset
    w = make_world()
    t = build_shape_table(w)
    t.shape_local_pos[3] = (0.1, 0.0, 0.0)
    R = np.array(w.R)
    R[3] = rot((0, 0, 1), np.pi / 2)
    pos, _, _ = update_bounds(w.x, R, t, 0.0)
    np.testing.assert_allclose(pos[3], w.x[3] + R[3] @ [0.1, 0, 0])


def test_bodies_sharing_a_hull_share_its_rows():
    rock = tb.Convex(points=np.random.default_rng(0).normal(size=(12, 3)))
    w = tb.World()
    for k in range(3):
        w.add_body(rock, mass=1.0, position=(3.0 * k, 0, 0))
    w.add_body(tb.Convex(points=np.random.default_rng(1).normal(size=(12, 3))), mass=1.0, position=(0, 5, 0))
    t = build_shape_table(w)
    assert t.shape_data[0].tolist() == t.shape_data[1].tolist() == t.shape_data[2].tolist()
    assert t.shape_data[3, 0] == t.shape_data[0, 1]  # the other hull's vertices follow the first's
    assert len(t.hull_vertex) == t.shape_data[0, 1] + t.shape_data[3, 1]


def _edge_flags_by_loop(vertices, faces, two_sided=False, flat_cos=1.0 - 1e-6):
    """``mesh_edge_flags`` as it was written first (until session 26): a dict of each edge's owners and a
    loop over every face's three edges. Kept as the oracle of the sorted version."""
    from tumble.collision.geometry import BACK_SHIFT, TWO_SIDED

    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    size = float(np.max(np.abs(v))) or 1.0
    owner = {}
    for t in range(len(f)):
        for k in range(3):
            a, b = int(f[t, k]), int(f[t, (k + 1) % 3])
            owner.setdefault((min(a, b), max(a, b)), []).append((t, k))
    flags = np.zeros(len(f), dtype=np.int64)
    for t in range(len(f)):
        for k in range(3):
            a, b = int(f[t, k]), int(f[t, (k + 1) % 3])
            others = [o for o in owner[(min(a, b), max(a, b))] if o[0] != t]
            if len(others) != 1:
                flags[t] |= (1 << k) | ((1 << (BACK_SHIFT + 2 - k)) if two_sided else 0)
                continue
            u = others[0][0]
            far = v[f[u, (others[0][1] + 2) % 3]]
            flat = n[t] @ n[u] > flat_cos
            height = n[t] @ (far - tri[t, 0])
            if height < -1e-9 * size and not flat:
                flags[t] |= 1 << k
            if two_sided and height > 1e-9 * size and not flat:
                flags[t] |= 1 << (BACK_SHIFT + 2 - k)
    return flags | (TWO_SIDED if two_sided else 0)


def test_mesh_edge_flags_by_sorting_equal_the_loop_over_every_edge():
    """The sorted (vectorised) edge flags equal the per-edge loop's on the examples' meshes (closed
    bowl, chute and ring, the open half-pipe), an icosphere, a torus, a box, a random heightfield
    and a sheet with a non-manifold edge (three faces on it: active on both sides), one- and
    two-sided."""
    import trimesh

    examples = Path(__file__).resolve().parents[2] / "examples"
    meshes = [trimesh.load(examples / name, force="mesh", process=True) for name in
              ("bowl.obj", "chute.obj", "ring.obj", "halfpipe.obj")]
    meshes += [trimesh.creation.icosphere(3), trimesh.creation.torus(1.0, 0.3), trimesh.creation.box()]
    meshes.append(tb.heightfield(np.random.default_rng(0).normal(size=(12, 15)), (3.0, 4.0)).trimesh)
    fin = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], [[0, 1, 2], [0, 3, 1], [0, 1, 4]],
                          process=False)
    meshes.append(fin)
    for mesh in meshes:
        for two_sided in (False, True):
            expected = _edge_flags_by_loop(mesh.vertices, mesh.faces, two_sided)
            assert np.array_equal(mesh_edge_flags(mesh.vertices, mesh.faces, two_sided=two_sided), expected)
    assert np.all(mesh_edge_flags(fin.vertices, fin.faces) & 1)  # the edge 0 -> 1 of three faces: active
