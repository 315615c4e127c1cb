"""The contact benchmark scenes of tumble.scenes.contact: counts, layouts, materials, no initial overlap."""

import numpy as np
import pytest

import tumble as tb
from tumble.scenes import contact as C


def _moving(world):
    return np.flatnonzero(world.moving)


def _check_settings(settings, duration):
    assert settings["dt"] == pytest.approx(1 / 60)
    assert settings["substeps"] == 4
    assert settings["duration"] == pytest.approx(duration)
    assert settings["steps"] == round(duration * 60)


@pytest.mark.parametrize("n, k", [(1, 1), (8, 2), (9, 3), (27, 3), (100, 5), (1000, 10), (1001, 11)])
def test_grid_side_is_integer_cube_root_ceiling(n, k):
    assert C.grid_side(n) == k


@pytest.mark.parametrize("n", [1, 27, 100])
def test_pile_layout_materials_and_no_overlap(n):
    world, settings = C.pile(n)
    _check_settings(settings, 4.0)
    assert world.body_count == n + 1
    assert world.fixed[0] and isinstance(world.shapes[0], tb.Plane)
    assert np.allclose(world.gravity, (0, 0, -9.81))
    m = _moving(world)
    assert len(m) == n
    assert np.all(world.mass[m] == 1.0)
    for i in m:
        assert world.shapes[i].size == (0.2, 0.2, 0.2)
        assert world.materials[i] == tb.Material(friction=0.5, restitution=0.0)
    assert world.materials[0].friction == 0.5
    x = world.x[m]
    assert x[:, 2].min() == pytest.approx(0.5)
    k = C.grid_side(n)
    if n == k ** 3:  # a full grid is centred on x = y = 0 with 0.4 m spacing
        assert np.allclose(x[:, :2].mean(axis=0), 0.0, atol=1e-12)
        assert x[:, 0].max() - x[:, 0].min() == pytest.approx(0.4 * (k - 1))
    assert np.allclose(np.linalg.norm(world.q[m], axis=1), 1.0)
    assert C.max_box_overlap(world) == 0.0


def test_pile_is_seeded():
    a, _ = C.pile(64, seed=3)
    b, _ = C.pile(64, seed=3)
    c, _ = C.pile(64, seed=4)
    assert np.array_equal(a.q, b.q)
    assert not np.allclose(a.q[1:], c.q[1:])
    # random orientations: not all axis-aligned
    assert np.abs(a.q[1:, 0]).max() < 1.0


def test_pile_1000_fills_a_10_cube_grid():
    world, settings = C.pile(1000)
    x = world.x[_moving(world)]
    assert settings["grid"] == 10
    assert np.allclose(x.min(axis=0), (-1.8, -1.8, 0.5))
    assert np.allclose(x.max(axis=0), (1.8, 1.8, 4.1))
    assert len(np.unique(np.round(x, 9), axis=0)) == 1000


@pytest.mark.parametrize("builder, mass, duration", [(C.stack, 1.0, 10.0), (C.tower, 1000.0, 30.0)])
def test_columns_touch_without_gap(builder, mass, duration):
    world, settings = builder()
    _check_settings(settings, duration)
    assert world.body_count == 11
    m = _moving(world)
    assert np.allclose(world.x[m], [(0, 0, 0.5 + i) for i in range(10)])
    assert np.all(world.mass[m] == mass)
    assert all(world.shapes[i].size == (1.0, 1.0, 1.0) for i in m)
    assert all(world.materials[i].friction == 0.6 for i in range(world.body_count))
    assert C.max_box_overlap(world) == 0.0
    assert len(_moving(builder(n=3)[0])) == 3


def test_pyramid_20_rows_has_210_boxes_resting_in_rows():
    world, settings = C.pyramid()
    _check_settings(settings, 10.0)
    m = _moving(world)
    assert len(m) == 210 and world.body_count == 211
    x = world.x[m]
    assert np.allclose(x[:, 1], 0.0)
    for i in range(20):
        row = np.sort(x[np.isclose(x[:, 2], i + 0.5), 0])
        assert len(row) == 20 - i
        assert np.allclose(np.diff(row), 1.0)  # touching neighbours
        assert row[0] == pytest.approx(-9.5 + 0.5 * i)  # half a box right of the row below
    assert np.allclose(world.mass[m], 100.0)
    assert np.allclose(world.gravity, (0, 0, -10))
    assert C.max_box_overlap(world) == 0.0


def test_large_pyramid_matches_box3d_positions():
    world, settings = C.large_pyramid()
    assert settings["steps"] == 200 and settings["substeps"] == 4
    assert world.body_count == 5051
    ground = world.shapes[0]
    assert world.fixed[0] and ground.size == (800.0, 800.0, 2.0)
    assert np.allclose(world.x[0], (0, 0, -1))  # top face at z = 0
    m = _moving(world)
    assert len(m) == 5050
    assert np.allclose(world.mass[m], 100.0)  # density 100, unit cube
    expected = [(0.5 * (i + 1) + (j - i) - 50.0, 0.0, i + 0.5) for i in range(100) for j in range(i, 100)]
    assert np.allclose(world.x[m], expected)
    assert np.allclose(world.q[m], (1, 0, 0, 0))
    assert all(world.materials[i] == tb.Material(friction=0.6, restitution=0.0) for i in range(world.body_count))
    assert world.sleeping is False and settings["sleeping"] is False


def test_many_pyramids_matches_box3d_layout():
    world, settings = C.many_pyramids()
    assert settings["steps"] == 100
    assert world.body_count == 10781
    assert world.sleeping is False and settings["sleeping"] is False
    assert world.shapes[0].size == (154.0, 154.0, 2.0) and np.allclose(world.x[0], (0, 0, -1))
    x = world.x[_moving(world)]
    assert len(x) == 10780
    ys = np.unique(np.round(x[:, 1], 9))
    assert len(ys) == 14 and np.allclose(np.diff(ys), 152 / 13) and ys.min() == pytest.approx(-76)
    base = np.sort(x[np.isclose(x[:, 2], 0.5) & np.isclose(x[:, 1], ys[0]), 0])
    assert len(base) == 140
    assert base[0] == pytest.approx(-76.0) and base[-1] == pytest.approx(-76 + 11 * 13 + 9)
    gaps = np.diff(base)
    assert np.allclose(gaps[gaps > 1.5], 2.0)  # 1 m between neighbouring pyramids (centres 2 m apart)
    assert x[:, 2].max() == pytest.approx(9.5)
    # one pyramid: no overlap, resting on z = 0
    sub, _ = C.pyramid(rows=10)
    assert C.max_box_overlap(sub) == 0.0


def test_build_by_name_and_unknown_name():
    world, settings = C.build("pile", n=8, seed=1)
    assert world.body_count == 9 and settings["scene"] == "pile"
    with pytest.raises(ValueError, match="unknown contact scene"):
        C.build("piles")


def test_overlap_check_sees_an_overlap():
    world = tb.World()
    world.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, position=(0, 0, 0.5))
    world.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, position=(0.9, 0, 0.5))
    assert C.max_box_overlap(world) == pytest.approx(0.1)
    world.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, position=(5, 0, 0.45))
    assert C.max_box_overlap(world) == pytest.approx(0.1)
    assert C.max_box_overlap(C.stack(2)[0]) == 0.0


def test_convex_pile_matches_box3d_layout():
    """Box3D's convex_pile (benchmarks/convex_pile.py): one 32-point hull on a sphere of radius 2 m
    (PEEL's generator: every point on the sphere to float32 rounding), shared by 64 bodies a layer
    on a grid 4 m apart, the first layer's centres 2 m up, density 1; the ground box's top at z = 0.
    With the hull's points fewer than 32 (a generator that repeats), the test fails."""
    points = C.convex_pile_points()
    assert points.shape == (32, 3) and len(np.unique(points, axis=0)) == 32
    np.testing.assert_allclose(np.linalg.norm(points, axis=1), 2.0, rtol=1e-6)
    w, settings = C.convex_pile(layers=2)
    assert w.body_count == 129 and settings["n"] == 128 and settings["steps"] == 500
    hulls = {id(s) for s in w.shapes[1:]}
    assert len(hulls) == 1 and len(w.shapes[1].vertices) <= 32
    start = w.x[1:] - np.einsum("nij,j->ni", w.R[1:], w.com_offset[1])  # the hull's origin, where Box3D puts it
    assert sorted(set(np.round(start[:, 2], 9))) == [2.0, 6.0]
    assert sorted(set(np.round(start[:, 0], 9))) == [-16.0, -12.0, -8.0, -4.0, 0.0, 4.0, 8.0, 12.0]
    assert w.x[0, 2] + w.shapes[0].size[2] / 2 == 0.0
    assert np.isclose(w.mass[1], abs(w.shapes[1].trimesh.volume))
