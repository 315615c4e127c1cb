"""Area queries (``collision.query.overlap_aabb``, ``World.overlap_aabb``) against a brute force.

The expected bodies are computed here independently of the engine's bounds: a sphere's box is
c +- r, a box's the min and max of its 8 corners, a capsule's its two end centres +- r; a
plane is hit when one of the query box's 8 corners is on or below it. Exact comparison: the
two are the same boxes up to round-off, and the random queries are not placed on their edges.
"""

import itertools

import numpy as np
import pytest

import tumble as tb
from tumble.errors import InputError
from tumble.math3d import quat_to_matrix


def _field(seed=4, n=150):
    rng = np.random.default_rng(seed)
    w = tb.World()
    w.add_body(tb.Plane(normal=(0.2, 0.1, 1.0)), fixed=True, name="ground",
               collision_filter={"category": 4})
    expected = []  # per body: (lower, upper) of its shape's box, None for the plane
    expected.append(None)
    for i in range(n):
        c = rng.uniform(-5, 5, 3) + (0, 0, 3)
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        R = quat_to_matrix(q)
        kind = i % 3
        cat = 1 << (i % 2)
        if kind == 0:
            r = rng.uniform(0.1, 0.5)
            w.add_body(tb.Sphere(r), mass=1.0, position=c, orientation=q, collision_filter={"category": cat})
            expected.append((c - r, c + r))
        elif kind == 1:
            h = rng.uniform(0.1, 0.6, 3)
            w.add_body(tb.Box(size=tuple(2 * h)), mass=1.0, position=c, orientation=q, collision_filter={"category": cat})
            corners = np.array([c + R @ (np.array(s) * h) for s in itertools.product((-1, 1), repeat=3)])
            expected.append((corners.min(axis=0), corners.max(axis=0)))
        else:
            r, length = rng.uniform(0.1, 0.3), rng.uniform(0.2, 1.0)
            w.add_body(tb.Capsule(r, length), mass=1.0, position=c, orientation=q, collision_filter={"category": cat})
            ends = np.array([c + R @ (0, 0, s * length / 2) for s in (-1, 1)])
            expected.append((ends.min(axis=0) - r, ends.max(axis=0) + r))
    return w, expected


def _brute(w, expected, lo, hi, mask):
    n = np.array([0.2, 0.1, 1.0]) / np.linalg.norm([0.2, 0.1, 1.0])
    out = []
    for b, box in enumerate(expected):
        if not (w.collision_filters[b].category & mask):
            continue
        if box is None:
            corners = np.array([np.where(s, hi, lo) for s in itertools.product((False, True), repeat=3)])
            if np.min(corners @ n) <= 0.0:
                out.append(b)
        elif np.all(box[0] <= hi) and np.all(box[1] >= lo):
            out.append(b)
    return out


@pytest.mark.parametrize("mask", [0xFFFFFFFF, 1, 2 | 4, 0])
def test_overlap_aabb_returns_the_bodies_a_brute_force_finds(mask):
    w, expected = _field()
    rng = np.random.default_rng(9)
    found = 0
    for _ in range(60):
        lo = rng.uniform(-6, 6, 3) + (0, 0, 2)
        hi = lo + rng.uniform(0.1, 4.0, 3)
        got = w.overlap_aabb(lo, hi, mask=mask)
        assert got.dtype == np.int64 and np.all(np.diff(got) > 0)
        want = _brute(w, expected, lo, hi, mask)
        assert got.tolist() == want
        found += len(want)
    assert (found > 30) if mask else found == 0  # the queries do find bodies (53-121; none for mask 0)


def test_overlap_follows_the_bodies_as_they_move():
    w = tb.World()
    w.add_body(tb.Sphere(0.5), mass=1.0, position=(0, 0, 10), velocity=(0, 0, -5), name="ball")
    assert w.overlap_aabb((-1, -1, -1), (1, 1, 1)).tolist() == []
    assert w.overlap_aabb((-1, -1, 9), (1, 1, 11)).tolist() == [0]
    tb.Simulator(w).run(1.0)  # free fall from 10 m: z = 10 - 5 t - g t^2 / 2 = 0.095 m at 1 s
    assert w.overlap_aabb((-1, -1, -1), (1, 1, 1)).tolist() == [0]
    assert w.overlap_aabb((-1, -1, 9), (1, 1, 11)).tolist() == []


@pytest.mark.parametrize("kwargs, key", [
    (dict(lower=(0, 0), upper=(1, 1, 1)), "lower"),
    (dict(lower=(0, 0, 0), upper=(1, np.nan, 1)), "upper"),
    (dict(lower=(0, 0, 2), upper=(1, 1, 1)), "upper"),
    (dict(lower=(0, 0, 0), upper=(1, 1, 1), mask=-2), "mask"),
])
def test_bad_query_is_one_line_naming_the_argument(kwargs, key):
    w = tb.World()
    w.add_body(tb.Sphere(0.5), mass=1.0)
    with pytest.raises(InputError) as err:
        w.overlap_aabb(**kwargs)
    assert err.value.key == key and "\n" not in str(err.value)
