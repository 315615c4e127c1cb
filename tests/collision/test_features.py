"""Feature ids stay put under small motions (warm starting), swapping a and b flips the normal,
and the whole pipeline on a World (keys, match_contacts, shape order)."""

import numpy as np
import pytest

import tumble as tb
from tumble.collision import CollisionPipeline, match_contacts
from tumble.collision.pairs.box_box import collide_box_box
from tumble.collision.pairs.capsule import collide_capsule_capsule
from tumble.collision.pairs.sphere import collide_sphere_sphere

from .helpers import SPEC, box, capsule, collide, plane, random_rotation, rot, sphere

UNIT = (0.5, 0.5, 0.5)
MOVES = [(1e-4, 0, 0), (0, 1e-4, 0), (0, 0, -1e-4), (-1e-4, 1e-4, 1e-4), (1e-4, 1e-4, 0)]

RESTING = {
    "box on plane": lambda d: (plane(), box(np.array([0.3, 0.1, 0.499]) + d, rot((0, 0, 1), 0.2), UNIT)),
    "box on box, same size": lambda d: (box((0, 0, 0.5), np.eye(3), UNIT), box(np.array([0, 0, 1.499]) + d, np.eye(3), UNIT)),
    "box on box, turned": lambda d: (box((0, 0, 0.5), np.eye(3), UNIT),
                                     box(np.array([0.1, 0, 1.499]) + d, rot((0, 0, 1), 0.5), UNIT)),
    "box on ground box": lambda d: (box((0, 0, -1), np.eye(3), (10, 10, 1)), box(np.array([2, 1, 0.299]) + d, np.eye(3), (0.3, 0.2, 0.3))),
    "box under box (b is the reference)": lambda d: (box(np.array([0.0, 0, 0.499]) + d, np.eye(3), UNIT),
                                                     box((0, 0, -1), np.eye(3), (10, 10, 1))),
    "capsule on plane": lambda d: (plane(), capsule(np.array([0, 0, 0.199]) + d, rot((0, 1, 0), np.pi / 2), 0.2, 0.5)),
    "capsule on box": lambda d: (capsule(np.array([0, 0, 0.199]) + d, rot((0, 1, 0), np.pi / 2), 0.2, 0.5),
                                 box((0, 0, -1), np.eye(3), (3, 3, 1))),
    "capsule on capsule": lambda d: (capsule((0, 0, 0), rot((0, 1, 0), np.pi / 2), 0.2, 0.5),
                                     capsule(np.array([0.2, 0, 0.399]) + d, rot((0, 1, 0), np.pi / 2), 0.2, 0.5)),
}


@pytest.mark.parametrize("name", sorted(RESTING))
def test_feature_ids_unchanged_by_small_moves(name):
    n0, p0, s0, f0 = collide(*RESTING[name](np.zeros(3)))
    assert len(f0) >= 2 and len(set(f0.tolist())) == len(f0)
    for d in MOVES:
        n, p, s, f = collide(*RESTING[name](np.asarray(d)))
        assert sorted(f.tolist()) == sorted(f0.tolist()), d
        # the same id names the same point
        for k, fid in enumerate(f):
            j = f0.tolist().index(fid)
            assert np.linalg.norm(p[k] - p0[j]) < 3e-4


def call(routine, a, b):
    normal = np.zeros(3)
    point = np.zeros((4, 3))
    sep = np.zeros(4)
    feat = np.zeros(4, dtype=np.int64)
    n = routine(a[1], a[2], a[3], b[1], b[2], b[3], SPEC, normal, point, sep, feat)
    return normal, point[:n], sep[:n]


def same_points(p, q, tol=1e-9):
    return len(p) == len(q) and all(np.min(np.linalg.norm(q - x, axis=1)) < tol for x in p)


@pytest.mark.parametrize("seed", range(40))
def test_swapping_a_and_b_flips_the_normal(seed):
    rng = np.random.default_rng(seed)
    # sphere-sphere
    a = sphere(rng.normal(size=3) * 0.2, 0.3)
    b = sphere(rng.normal(size=3) * 0.2, 0.25)
    (n1, p1, s1), (n2, p2, s2) = call(collide_sphere_sphere, a, b), call(collide_sphere_sphere, b, a)
    np.testing.assert_allclose(n1, -n2, atol=1e-12)
    np.testing.assert_allclose(s1, s2, atol=1e-12)
    assert same_points(p1, p2)
    # capsule-capsule (non-parallel)
    a = capsule(rng.normal(size=3) * 0.1, random_rotation(rng), 0.1, 0.4)
    b = capsule(rng.normal(size=3) * 0.1, random_rotation(rng), 0.15, 0.3)
    (n1, p1, s1), (n2, p2, s2) = call(collide_capsule_capsule, a, b), call(collide_capsule_capsule, b, a)
    np.testing.assert_allclose(n1, -n2, atol=1e-9)
    np.testing.assert_allclose(np.sort(s1), np.sort(s2), atol=1e-9)
    # box-box: a small turned box sinking into a big one's face, so that both orders
    # pick the same reference face; and a generic edge case
    big = box((0, 0, -1), random_rotation(rng) if seed % 2 else np.eye(3), (2, 2, 1))
    up = big[2][:, 2]
    small = box(big[1] + up * (1.0 + rng.uniform(0.1, 0.3)), random_rotation(rng), (0.2, 0.25, 0.3))
    (n1, p1, s1), (n2, p2, s2) = call(collide_box_box, big, small), call(collide_box_box, small, big)
    if len(s1):
        np.testing.assert_allclose(n1, -n2, atol=1e-12)
        np.testing.assert_allclose(np.sort(s1), np.sort(s2), atol=1e-12)
        assert same_points(p1, p2)


def test_pipeline_on_a_world():
    w = tb.World()
    w.add_body(tb.Plane(), fixed=True, name="ground")
    w.add_body(tb.Box((1, 1, 1)), mass=1, position=(0, 0, 0.499), name="b0")
    w.add_body(tb.Box((1, 1, 1)), mass=1, position=(0.1, 0, 1.498), name="b1")
    w.add_body(tb.Sphere(0.25), mass=1, position=(3, 0, 0.25), name="ball")
    w.add_body(tb.Capsule(0.1, 0.5), mass=1, position=(0.1, 0, 2.097), orientation=(np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0))
    w.add_body(tb.Box((1, 1, 1)), position=(10, 0, 0.5), fixed=True, name="fixed box")  # touches nothing moving
    pipe = CollisionPipeline(w)
    c = pipe.detect()
    pairs = list(zip(c.manifold_shape_a.tolist(), c.manifold_shape_b.tolist()))
    # sweep pairs by (a, b) first, then the plane's pairs; a's type <= b's type (capsule 4 before box 2)
    assert pairs == [(1, 2), (4, 2), (0, 1), (0, 3)]
    assert c.manifold_point_count.tolist() == [4, 2, 4, 1]
    np.testing.assert_allclose(c.manifold_normal[:, 2], [1, -1, 1, 1], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(c.contact_normal, axis=1), 1.0)
    assert c.contact_count == 11 and len(set(c.contact_key.tolist())) == 11
    np.testing.assert_array_equal(c.contact_body_a, c.manifold_body_a[c.contact_manifold])
    old = c.contact_key.copy()
    # move everything a little: every contact finds its previous self
    w.x[:] += (2e-5, -3e-5, -1e-5)
    w.x[0] = 0
    c = pipe.detect()
    m = match_contacts(old, c.contact_key)
    assert np.all(m >= 0) and sorted(m.tolist()) == list(range(11))
    # lift the top box and the capsule on it: the box-box contacts vanish, the others match
    w.x[2, 2] += 1.0
    w.x[4, 2] += 1.0
    c = pipe.detect()
    m = match_contacts(old, c.contact_key)
    assert c.contact_count == 7 and np.all(m >= 0)


def test_match_contacts():
    old = np.array([5, 9, 2, 7], dtype=np.int64)
    new = np.array([7, 1, 5, 10, 2], dtype=np.int64)
    assert match_contacts(old, new).tolist() == [3, -1, 0, -1, 2]
    assert match_contacts([], new).tolist() == [-1] * 5


def test_match_contacts_equals_a_dictionary_on_many_keys():
    # keys shaped as contact keys ((a << 42) | (b << 21) | feature), old and new overlapping in part
    # and in another order (the hashed path; the in-place path needs the same rows): compared
    # with a Python dict, key by key
    rng = np.random.default_rng(3)
    a = rng.integers(0, 5000, size=30000)
    b = a + rng.integers(1, 40, size=30000)
    f = rng.integers(0, 1 << 20, size=30000)
    keys = np.unique((a << 42) | (b << 21) | f)
    rng.shuffle(keys)
    old, new = keys[:20000], np.concatenate([keys[10000:25000], keys[:100]])
    rng.shuffle(new)
    row = {int(k): i for i, k in enumerate(old)}
    expect = [row.get(int(k), -1) for k in new]
    assert match_contacts(old, new).tolist() == expect
