"""The narrowphase's analytic families (``collision.geometry.analytic_family``): a world of
planes and boxes, or of planes and spheres, compiles only its own pair routines. Compared
with the dispatch over every analytic routine (FAMILY_ALL) on the same poses: the same
manifolds to the bit, or a family would have dropped or changed a pair."""

import numpy as np
import pytest

import tumble as tb
from tumble.collision import CollisionPipeline
from tumble.collision import narrowphase as NP
from tumble.collision.geometry import analytic_family
from tumble.shapes import SHAPE_BOX, SHAPE_CAPSULE, SHAPE_PLANE, SHAPE_SPHERE


def test_family_of_a_world_is_what_its_shapes_allow():
    assert analytic_family(np.array([SHAPE_PLANE, SHAPE_BOX, SHAPE_BOX])) == NP.FAMILY_BOXES
    assert analytic_family(np.array([SHAPE_BOX])) == NP.FAMILY_BOXES
    assert analytic_family(np.array([SHAPE_PLANE, SHAPE_SPHERE])) == NP.FAMILY_SPHERES
    assert analytic_family(np.array([SHAPE_SPHERE, SHAPE_BOX])) == NP.FAMILY_ALL
    assert analytic_family(np.array([SHAPE_PLANE, SHAPE_CAPSULE])) == NP.FAMILY_ALL


def _jumble(shape, n, seed):
    """A plane and n shapes in a 0.9 m grid of 1 m cells, turned at random and pushed down into
    each other and the plane: face, edge and corner contacts, some speculative."""
    rng = np.random.default_rng(seed)
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    for i in range(n):
        pos = (0.9 * (i % 4), 0.9 * ((i // 4) % 4), 0.45 + 0.9 * (i // 16) + 0.05 * rng.standard_normal())
        w.add_body(shape(), mass=1.0, position=pos, euler_deg=tuple(rng.uniform(-180, 180, 3)))
    return w


@pytest.mark.parametrize("shape, family", [(lambda: tb.Box((1.0, 0.8, 0.9)), NP.FAMILY_BOXES),
                                           (lambda: tb.Sphere(0.5), NP.FAMILY_SPHERES)])
@pytest.mark.parametrize("parallel", [False, True])
def test_a_family_finds_the_manifolds_of_every_routine(shape, family, parallel, monkeypatch):
    monkeypatch.setattr(NP, "PARALLEL_MIN_CANDIDATES", 0 if parallel else 10 ** 9)
    w = _jumble(shape, 40, seed=3)
    got = CollisionPipeline(w).detect()
    assert got.contact_count > 20  # the jumble touches: the comparison below is not of empty sets
    pipe = CollisionPipeline(w)
    table = pipe.refresh()
    assert table.analytic_family == family
    table.analytic_family = NP.FAMILY_ALL  # the dispatch over every analytic routine
    every = pipe.detect()
    for name in ("manifold_shape_a", "manifold_shape_b", "manifold_normal", "contact_point", "contact_separation",
                 "contact_key"):
        np.testing.assert_array_equal(getattr(got, name), getattr(every, name), err_msg=name)
