"""Pair routines on cases with known answers (one test or more per pair type)."""

import numpy as np
import pytest

from .helpers import SPEC, box, capsule, collide, plane, rot, sphere

S2 = np.sqrt(2.0)
UP = np.array([0.0, 0.0, 1.0])


def sorted_rows(p):
    return p[np.lexsort(p.T[::-1])]


# ---------------------------------------------------------------- plane
def test_sphere_resting_on_plane():
    n, p, s, f = collide(plane(), sphere((0.3, -0.2, 0.499), 0.5))
    assert len(s) == 1
    np.testing.assert_allclose(n, UP)
    np.testing.assert_allclose(s, [-0.001], atol=1e-15)
    np.testing.assert_allclose(p[0], [0.3, -0.2, -0.0005], atol=1e-15)


def test_sphere_on_tilted_offset_plane():
    normal = np.array([1.0, 0.0, 1.0]) / S2
    centre = 2.0 * normal + 0.7 * normal  # plane n.p = 2, sphere radius 0.7 touching
    n, p, s, f = collide(plane(normal, 2.0), sphere(centre + 0.01 * normal, 0.7))
    np.testing.assert_allclose(n, normal, atol=1e-15)
    np.testing.assert_allclose(s, [0.01], atol=1e-12)
    np.testing.assert_allclose(p[0], 2.0 * normal + 0.005 * normal, atol=1e-12)


def test_box_on_plane_four_corners():
    R = rot((0, 0, 1), 0.3)
    n, p, s, f = collide(plane(), box((1.0, 2.0, 0.298), R, (0.5, 0.4, 0.3)))
    assert len(s) == 4
    np.testing.assert_allclose(n, UP)
    np.testing.assert_allclose(s, -0.002, atol=1e-12)
    expected = [(1.0, 2.0, 0.0) + R @ [sx * 0.5, sy * 0.4, 0] for sx in (-1, 1) for sy in (-1, 1)]
    expected = np.array(expected)
    expected[:, 2] = -0.001
    np.testing.assert_allclose(sorted_rows(p), sorted_rows(expected), atol=1e-12)
    assert sorted(f.tolist()) == [0, 1, 2, 3]  # the corners with local z = -h


def test_box_on_plane_edge_two_corners():
    # turned 45 degrees about x: resting on one edge
    n, p, s, f = collide(plane(), box((0, 0, 0.5 * S2 - 0.001), rot((1, 0, 0), np.pi / 4), (0.5, 0.5, 0.5)))
    assert len(s) == 2
    np.testing.assert_allclose(s, -0.001, atol=1e-12)
    np.testing.assert_allclose(sorted_rows(p), [[-0.5, 0, -0.0005], [0.5, 0, -0.0005]], atol=1e-12)


def test_capsule_lying_on_plane_two_points():
    R = rot((0, 1, 0), np.pi / 2)  # axis along x
    n, p, s, f = collide(plane(), capsule((0, 0, 0.199), R, 0.2, 0.5))
    assert len(s) == 2
    np.testing.assert_allclose(n, UP)
    np.testing.assert_allclose(s, -0.001, atol=1e-12)
    np.testing.assert_allclose(sorted_rows(p), [[-0.5, 0, -0.0005], [0.5, 0, -0.0005]], atol=1e-12)


def test_capsule_standing_on_plane_one_point():
    n, p, s, f = collide(plane(), capsule((0, 0, 0.7), np.eye(3), 0.2, 0.5))
    assert len(s) == 1
    np.testing.assert_allclose(p[0], [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(s, 0.0, atol=1e-12)


# ---------------------------------------------------------------- spheres and capsules
def test_sphere_sphere():
    n, p, s, f = collide(sphere((0, 0, 0), 0.5), sphere((0.3, 0.4, 0), 0.4))
    np.testing.assert_allclose(n, [0.6, 0.8, 0])
    np.testing.assert_allclose(s, [0.5 - 0.9])
    # a's surface point 0.5 n, b's surface point c_b - 0.4 n; midway
    np.testing.assert_allclose(p[0], 0.5 * (0.5 * n + np.array([0.3, 0.4, 0]) - 0.4 * n))


def test_sphere_capsule_middle_and_end():
    cap = capsule((0, 0, 0), rot((0, 1, 0), np.pi / 2), 0.1, 1.0)  # along x from -1 to 1
    n, p, s, f = collide(sphere((0.3, 0, 0.35), 0.25), cap)
    np.testing.assert_allclose(n, -UP, atol=1e-15)
    np.testing.assert_allclose(s, [0.0], atol=1e-15)
    np.testing.assert_allclose(p[0], [0.3, 0, 0.1], atol=1e-15)
    n, p, s, f = collide(sphere((1.3, 0, 0), 0.25), cap)
    np.testing.assert_allclose(n, [-1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(s, [0.3 - 0.35])


def test_capsules_crossed_one_point():
    a = capsule((0, 0, 0), rot((0, 1, 0), np.pi / 2), 0.1, 1.0)   # along x
    b = capsule((0.2, 0.1, 0.19), rot((1, 0, 0), np.pi / 2), 0.1, 1.0)  # along y, above
    n, p, s, f = collide(a, b)
    assert len(s) == 1
    np.testing.assert_allclose(n, UP, atol=1e-15)
    np.testing.assert_allclose(s, [-0.01], atol=1e-12)
    np.testing.assert_allclose(p[0], [0.2, 0, 0.095], atol=1e-12)


def test_capsules_parallel_two_points():
    R = rot((0, 1, 0), np.pi / 2)
    a = capsule((0, 0, 0), R, 0.1, 1.0)
    b = capsule((0.5, 0, 0.195), R, 0.1, 1.0)  # overlap x in [-0.5, 1]
    n, p, s, f = collide(a, b)
    assert len(s) == 2
    np.testing.assert_allclose(n, UP, atol=1e-12)
    np.testing.assert_allclose(s, -0.005, atol=1e-12)
    np.testing.assert_allclose(sorted_rows(p), [[-0.5, 0, 0.0975], [1.0, 0, 0.0975]], atol=1e-12)


# ---------------------------------------------------------------- sphere-box regions
UNIT = (0.5, 0.5, 0.5)


@pytest.mark.parametrize("centre, sep, normal", [
    ((0.1, -0.2, 0.59), 0.09 - 0.1, (0, 0, -1)),                           # face region
    ((0.55, 0.0, 0.55), 0.05 * S2 - 0.1, (-1 / S2, 0, -1 / S2)),            # edge region
    ((0.55, 0.55, 0.55), 0.05 * np.sqrt(3) - 0.1, -np.ones(3) / np.sqrt(3)),  # corner region
    ((0.0, 0.1, 0.4), -0.1 - 0.1, (0, 0, -1)),                             # centre inside, nearest face +z
    ((-0.45, 0.0, 0.1), -0.05 - 0.1, (1, 0, 0)),                            # inside, nearest face -x
])
def test_sphere_box_regions(centre, sep, normal):
    Rb = rot((1, 2, 3), 0.7)
    pb = np.array([0.3, -0.1, 2.0])
    c = pb + Rb @ np.asarray(centre)
    n, p, s, f = collide(sphere(c, 0.1), box(pb, Rb, UNIT))
    assert len(s) == 1
    np.testing.assert_allclose(n, Rb @ np.asarray(normal, float), atol=1e-12)
    np.testing.assert_allclose(s, [sep], atol=1e-12)
    # midway between the sphere's point c + r n and the box's point c + r n - sep n
    np.testing.assert_allclose(p[0], c + 0.1 * n + 0.5 * sep * n, atol=1e-12)


# ---------------------------------------------------------------- capsule-box
def test_capsule_lying_on_box_two_points():
    b = box((0, 0, -0.5), np.eye(3), (2, 2, 0.5))
    n, p, s, f = collide(capsule((0.3, 0, 0.097), rot((0, 1, 0), np.pi / 2), 0.1, 0.6), b)
    assert len(s) == 2
    np.testing.assert_allclose(n, -UP, atol=1e-12)
    np.testing.assert_allclose(s, -0.003, atol=1e-12)
    np.testing.assert_allclose(sorted_rows(p), [[-0.3, 0, -0.0015], [0.9, 0, -0.0015]], atol=1e-12)


def test_capsule_overhanging_box_clipped():
    # lying across the edge x = 1 of the top face: the contact stops at the edge
    b = box((0, 0, -0.5), np.eye(3), (1, 1, 0.5))
    n, p, s, f = collide(capsule((1.0, 0, 0.099), rot((0, 1, 0), np.pi / 2), 0.1, 0.6), b)
    assert len(s) == 2
    np.testing.assert_allclose(sorted_rows(p)[:, 0], [0.4, 1.0], atol=1e-12)
    np.testing.assert_allclose(s, -0.001, atol=1e-12)


def test_capsule_standing_on_box_and_on_edge():
    b = box((0, 0, -0.5), np.eye(3), (1, 1, 0.5))
    n, p, s, f = collide(capsule((0.2, 0.3, 0.61), np.eye(3), 0.1, 0.5), b)
    assert len(s) == 1
    np.testing.assert_allclose(s, [0.01], atol=1e-12)
    np.testing.assert_allclose(p[0], [0.2, 0.3, 0.005], atol=1e-12)
    # a capsule along y over the edge x = 1, z = 0, at 45 degrees from both faces
    c = np.array([1.0, 0.0, 0.0]) + 0.095 * np.array([1, 0, 1]) / S2
    n, p, s, f = collide(capsule(c, rot((1, 0, 0), np.pi / 2), 0.1, 0.5), b)
    assert len(s) == 1
    np.testing.assert_allclose(n, -np.array([1, 0, 1]) / S2, atol=1e-12)
    np.testing.assert_allclose(s, [-0.005], atol=1e-12)


def test_capsule_core_inside_box():
    b = box((0, 0, 0), np.eye(3), (1, 1, 0.5))
    n, p, s, f = collide(capsule((0, 0, 0.4), rot((0, 1, 0), np.pi / 2), 0.1, 0.5), b)
    # the core (x in [-0.5, 0.5], z = 0.4) is 0.1 below the top face: push out up, depth 0.2
    assert len(s) == 2
    np.testing.assert_allclose(n, -UP, atol=1e-12)
    np.testing.assert_allclose(s, -0.2, atol=1e-12)


# ---------------------------------------------------------------- box-box
def test_box_flat_on_box_four_points():
    ground = box((0, 0, -0.5), np.eye(3), (5, 5, 0.5))
    R = rot((0, 0, 1), 0.4)
    top = box((0.2, 0.1, 0.497), R, UNIT)
    n, p, s, f = collide(ground, top)
    assert len(s) == 4
    np.testing.assert_allclose(n, UP, atol=1e-12)
    np.testing.assert_allclose(s, -0.003, atol=1e-12)
    expected = np.array([(0.2, 0.1, 0) + R @ [sx * 0.5, sy * 0.5, 0] for sx in (-1, 1) for sy in (-1, 1)])
    expected[:, 2] = -0.0015
    np.testing.assert_allclose(sorted_rows(p), sorted_rows(expected), atol=1e-12)
    assert len(set(f.tolist())) == 4


def test_equal_boxes_stacked_four_points_either_order():
    a = box((0, 0, 0.5), np.eye(3), UNIT)
    b = box((0, 0, 1.499), np.eye(3), UNIT)
    for first, second, up in ((a, b, 1), (b, a, -1)):
        n, p, s, f = collide(first, second)
        assert len(s) == 4
        np.testing.assert_allclose(n, up * UP, atol=1e-12)
        np.testing.assert_allclose(s, -0.001, atol=1e-12)
        np.testing.assert_allclose(np.abs(p[:, :2]), 0.5, atol=1e-12)
        np.testing.assert_allclose(p[:, 2], 0.9995, atol=1e-12)


def test_box_rotated_45_on_box_octagon_reduced_to_four():
    a = box((0, 0, 0.5), np.eye(3), UNIT)
    b = box((0, 0, 1.495), rot((0, 0, 1), np.pi / 4), UNIT)
    n, p, s, f = collide(a, b)
    assert len(s) == 4  # 8 clipped points, reduced
    np.testing.assert_allclose(n, UP, atol=1e-12)
    np.testing.assert_allclose(s, -0.005, atol=1e-12)
    # the 4 kept points span a quadrilateral of area > half the octagon's
    q = p[:, :2]
    ang = np.arctan2(q[:, 1], q[:, 0])
    q = q[np.argsort(ang)]
    area = 0.5 * abs(np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1]))
    assert area > 0.5


def test_boxes_edge_to_edge():
    r = 0.5 * S2
    a = box((0, 0, 0), rot((1, 0, 0), np.pi / 4), UNIT)          # top edge along x at z = r
    b = box((0.1, 0.05, 2 * r - 0.01), rot((0, 1, 0), np.pi / 4), UNIT)  # bottom edge along y
    n, p, s, f = collide(a, b)
    assert len(s) == 1
    np.testing.assert_allclose(n, UP, atol=1e-12)
    np.testing.assert_allclose(s, [-0.01], atol=1e-12)
    np.testing.assert_allclose(p[0], [0.1, 0.0, r - 0.005], atol=1e-12)


def test_box_corner_on_box_face():
    # a cube balanced on a corner above a face: the corner is the one point
    R = rot((1, -1, 0), np.arctan(S2))  # takes (1, 1, 1)/sqrt3 to +z... turn the diagonal upright
    diag = R @ np.array([-0.5, -0.5, -0.5])
    assert abs(abs(diag[2]) - 0.5 * np.sqrt(3)) < 1e-12
    lowest = diag if diag[2] < 0 else -diag
    ground = box((0, 0, -1), np.eye(3), (3, 3, 1))
    top = box(-lowest + [0, 0, -0.004], R, UNIT)
    n, p, s, f = collide(ground, top)
    assert len(s) == 1
    np.testing.assert_allclose(n, UP, atol=1e-12)
    np.testing.assert_allclose(s, [-0.004], atol=1e-12)
    np.testing.assert_allclose(p[0], [0, 0, -0.002], atol=1e-12)


# ---------------------------------------------------------------- speculative distance
CASES = {
    "plane-sphere": lambda d: (plane(), sphere((0, 0, 0.5 + d), 0.5)),
    "plane-capsule": lambda d: (plane(), capsule((0, 0, 0.2 + 0.5 * np.cos(1.2) + d), rot((0, 1, 0), 1.2), 0.2, 0.5)),
    "plane-box": lambda d: (plane(), box((0, 0, 0.5 * S2 + d), rot((1, 0, 0), np.pi / 4), UNIT)),
    "sphere-sphere": lambda d: (sphere((0, 0, 0), 0.5), sphere((0.3, 0.9, 0.6), 0.4).__class__(
        (sphere((0, 0, 0), 0.5)[0], np.array([0.6, 0.0, 0.8]) * (0.9 + d), np.eye(3), np.array([0.4, 0, 0, 0])))),
    "sphere-capsule": lambda d: (sphere((0.1, 0, 0.3 + d), 0.2), capsule((0, 0, 0), rot((0, 1, 0), np.pi / 2), 0.1, 1)),
    "sphere-box": lambda d: (sphere((0.55, 0.55, 0.55) + np.ones(3) / np.sqrt(3) * (0.1 + d) - 0.05 * np.ones(3), 0.1),
                             box((0, 0, 0), np.eye(3), UNIT)),
    "capsule-capsule": lambda d: (capsule((0, 0, 0), np.eye(3), 0.1, 1), capsule((0.2 + d, 0, 0), rot((1, 0, 0), 1.0), 0.1, 1)),
    "capsule-box": lambda d: (capsule((0, 0, 0.6 + d), rot((0, 1, 0), np.pi / 2), 0.1, 0.3), box((0, 0, 0), np.eye(3), UNIT)),
    "box-box": lambda d: (box((0, 0, 0), rot((1, 0, 0), np.pi / 4), UNIT),
                          box((0, 0.0, S2 + d), rot((0, 1, 0), np.pi / 4), UNIT)),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_no_contact_beyond_speculative_distance(name):
    a, b = CASES[name](SPEC + 1e-4)
    assert len(collide(a, b)[2]) == 0
    a, b = CASES[name](SPEC - 1e-4)
    n, p, s, f = collide(a, b)
    assert len(s) >= 1
    assert np.all(s < SPEC) and np.min(s) == pytest.approx(SPEC - 1e-4, abs=1e-9)
    a, b = CASES[name](0.0)
    assert np.min(collide(a, b)[2]) == pytest.approx(0.0, abs=1e-12)
