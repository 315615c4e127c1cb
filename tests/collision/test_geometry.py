"""ShapeTable and update_bounds."""

import numpy as np
import pytest

import tumble as tb
from tumble.collision import SPECULATIVE_DISTANCE, build_shape_table, update_bounds
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
