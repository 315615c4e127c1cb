"""Known misbehaviours found by the contact examples (tests/test_examples_contact.py), each as the
smallest test that shows it, marked ``xfail(strict=True)``: when one is fixed its test passes,
strict xfail fails, and the mark is to be removed.
"""

from __future__ import annotations

import numpy as np
import pytest

import tumble as tb


@pytest.mark.xfail(strict=True, reason="a pile of 512 boxes (as BENCHMARKS.md's 1000-box pile, 8 layers) is not at "
                   "rest after 4 s: 7 boxes faster than 1 cm/s (at rest by 5 s), and one box slid and tumbled to "
                   "3.76 m from the centre, outside its 3.4 m region. examples/pile.toml (1000 boxes) likewise: 19 "
                   "boxes faster than 1 cm/s at 4 s (the fastest 2.1 m/s), one at 4.35 m (region 3.8 m).")
def test_pile_of_512_boxes_settles_within_4_s():
    """Issue 3's pile acceptance on the smallest pile that fails it. The scene is BENCHMARKS.md's pile
    with n = 512 (tumble.scenes.contact.pile(512): an 8 x 8 x 8 grid 0.4 m apart, cubes of 0.2 m),
    run at the benchmark's and examples/pile.toml's step (dt 1/60 s, 4 contact substeps). Checks, the
    issue's figures: after 4 s no box faster than 1 cm/s, and none outside the region (the start's
    bounding box grown by 2 m, |x|, |y| < 3.4 m here). Piles of n = 27 ... 343 pass both (n = 343 is
    at rest at 3.5 s, within 2.8 m of the centre); n = 512, 729 and 1000 do not: their upper layers
    fall from higher, and the last boxes slide off the top of the pile at 3.5-4.5 s, one of them far
    across the ground. (Peers are not at rest at 4 s either: BENCHMARKS.md, PyBullet 2.65 m/s.)"""
    from tumble.scenes.contact import pile

    world, settings = pile(512)
    sim = tb.Simulator(world, dt=settings["dt"])
    sim.run(4.0, frame_rate=1)
    moving = np.flatnonzero(world.moving)
    speed = np.linalg.norm(world.v[moving], axis=1)
    reach = np.abs(world.x[moving, :2]).max()
    assert reach < settings["region_half_width"] and speed.max() < 0.01, (reach, int((speed >= 0.01).sum()), speed.max())


def test_a_compound_body_can_be_drawn():  # fixed: visual.shape_trimesh draws the parts
    """The drawing of a compound is its parts' meshes, each placed in the compound's frame: its bounds
    are the union of the parts' (here a 0.2 m box at the origin and a sphere of radius 0.1 at z = 0.3:
    z from -0.1 to 0.4)."""
    from tumble.shapes import Compound
    from tumble.visual import shape_trimesh

    shape = Compound([(tb.Box(size=(0.2, 0.2, 0.2)), (0, 0, 0), (1, 0, 0, 0)),
                         (tb.Sphere(radius=0.1), (0, 0, 0.3), (1, 0, 0, 0))])
    mesh = shape_trimesh(shape)
    np.testing.assert_allclose(mesh.bounds[:, 2], [-0.1, 0.4], atol=2e-3)
