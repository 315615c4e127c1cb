"""The ragdolls scene of tumble.scenes.ragdolls: counts, names, layout, the example's bodies and joints."""

import math

import numpy as np
import pytest

import tumble as tb
from tumble.scenes.ragdolls import (
    BODIES_PER_RAGDOLL,
    JOINTS_PER_RAGDOLL,
    grid_side,
    lowest_point_z,
    ragdolls,
)


@pytest.mark.parametrize("n, k", [(1, 1), (4, 2), (5, 3), (100, 10), (101, 11)])
def test_grid_side(n, k):
    assert grid_side(n) == k


@pytest.mark.parametrize("n", [1, 3])
def test_body_and_joint_counts(n):
    world, settings = ragdolls(n, seed=1)
    assert world.body_count == 1 + BODIES_PER_RAGDOLL * n == 1 + 11 * n
    assert len(world.joints) == JOINTS_PER_RAGDOLL * n == 10 * n
    assert isinstance(world.shapes[0], tb.Plane) and world.fixed[0]
    assert int(world.moving.sum()) == 11 * n
    assert settings["dt"] == pytest.approx(1 / 60) and settings["substeps"] == 4 and settings["steps"] == 300
    kinds = [j.kind for j in world.joints]
    assert kinds.count("ball") == 6 * n and kinds.count("hinge") == 4 * n
    for c in range(n):
        assert f"pelvis_{c}" in world.names and f"shin_r_{c}" in world.names
    # the example's masses (pelvis 10 kg ... shin 4 kg), 69 kg a ragdoll
    assert world.mass[np.flatnonzero(world.moving)].sum() == pytest.approx(69.0 * n)


def test_copies_are_turned_and_dropped_from_rest():
    n = 4
    world, settings = ragdolls(n, seed=0)
    m = np.flatnonzero(world.moving)
    assert np.all(world.v[m] == 0.0)
    low = lowest_point_z([world.shapes[i] for i in m], world.x[m], world.R[m]).reshape(n, 11).min(axis=1)
    assert np.allclose(low, settings["drop_height"])
    assert np.all((low >= 1.0) & (low <= 3.0))
    # each copy's joints bind the same anchors in the body frames as the first copy's (a rigid turn)
    for c in range(1, n):
        for k in range(10):
            a, b = world.joints[k].bound, world.joints[10 * c + k].bound
            assert np.allclose(a.local_a, b.local_a) and np.allclose(a.local_b, b.local_b)
            assert a.param[2] == b.param[2] and a.param[1] == pytest.approx(b.param[1])
    # the pelvis turned by the copy's yaw
    yaw = settings["yaw"]
    for c in range(n):
        R = world.R[world.names.index(f"pelvis_{c}")]
        assert math.atan2(R[1, 0], R[0, 0]) % (2 * math.pi) == pytest.approx(yaw[c] % (2 * math.pi))
