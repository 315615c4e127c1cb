"""A convex hull's merged faces (``geometry.hull_polygons``: trimesh's facets, 7-8 ms a hull) are
merged once per record and content and kept on the record (``geometry.hull_faces``), not once per
shape table: each spawn and each new Simulator used to merge every distinct hull of the world again
(a spawn into 1000 distinct hulls stalled 7.5 s; docs/benchmarks.md, "Hull faces kept"). The kept
faces must be the faces merged afresh, array for array, and an edit in place must not be served
stale ones."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import tumble as tb
from tumble.collision import geometry
from tumble.collision.geometry import build_shape_table, hull_polygons


@pytest.fixture
def merges(monkeypatch):
    """Counts the hulls merged (``geometry.hull_polygons``, which ``hull_faces`` calls)."""
    calls = []
    real = geometry.hull_polygons

    def counting(vertices, faces):
        calls.append(len(vertices))
        return real(vertices, faces)

    monkeypatch.setattr(geometry, "hull_polygons", counting)
    return calls


def _rocks(n, seed=0):
    rng = np.random.default_rng(seed)
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    for i in range(n):
        w.add_body(tb.Convex(points=0.1 * rng.normal(size=(16, 3))), mass=1.0, position=(0.5 * (i % 8), 0.5 * (i // 8), 0.3))
    return w


def test_a_spawn_and_a_new_simulator_merge_no_hull_again(merges):
    w = _rocks(12)
    sim = tb.Simulator(w, dt=1 / 60)
    sim.step(2)
    assert len(merges) == 12  # each distinct hull once, at the first table
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(-2.0, -2.0, 1.0))
    sim.step()  # a spawn rebuilds the table: before, each of the 12 hulls was merged again
    tb.Simulator(w, dt=1 / 60).step()  # and so did a new Simulator on the same world
    w.add_body(tb.Convex(points=np.random.default_rng(9).normal(size=(10, 3))), mass=1.0, position=(-3.0, -2.0, 1.0))
    sim.step()
    assert len(merges) == 13  # the new hull alone


def test_kept_faces_are_the_faces_merged_afresh_and_the_tables_the_same():
    from tumble.collision.geometry import hull_faces

    w = _rocks(6, seed=3)
    first = build_shape_table(w)  # merges and keeps
    again = build_shape_table(w)  # from what the records keep
    for name in ("hull_vertex", "hull_plane", "hull_face_first", "hull_face_count", "hull_face_vertex", "shape_data"):
        np.testing.assert_array_equal(getattr(first, name), getattr(again, name), err_msg=name)
    for body in w.bodies:
        shape = body.shape
        if not isinstance(shape, tb.Convex):
            continue
        planes, polygons = hull_faces(shape)
        fresh_planes, fresh_polygons = hull_polygons(shape.vertices, shape.faces)
        np.testing.assert_array_equal(planes, fresh_planes)
        assert len(polygons) == len(fresh_polygons)
        for p, q in zip(polygons, fresh_polygons):
            np.testing.assert_array_equal(p, q)
        assert not planes.flags.writeable  # shared between tables: nobody may write through it


def test_a_hull_edited_in_place_is_merged_again(merges):
    from tumble.collision.geometry import hull_faces

    hull = tb.Convex(points=np.random.default_rng(1).normal(size=(12, 3)))
    before = hull_faces(hull)[0].copy()
    hull_faces(hull)
    assert len(merges) == 1
    hull.vertices[:] *= 2.0  # the same faces, every plane's offset doubled
    planes, _ = hull_faces(hull)
    assert len(merges) == 2
    np.testing.assert_allclose(planes[:, :3], before[:, :3], rtol=0, atol=1e-12)
    np.testing.assert_allclose(planes[:, 3], 2.0 * before[:, 3], rtol=1e-12)


def test_a_pickled_hull_keeps_right_faces(merges):
    from tumble.collision.geometry import hull_faces

    hull = tb.Convex(points=np.random.default_rng(2).normal(size=(12, 3)))
    planes, _ = hull_faces(hull)
    copy = pickle.loads(pickle.dumps(hull))
    np.testing.assert_array_equal(hull_faces(copy)[0], planes)
