"""Collision detection (issue 3, stage 3 of DESIGN.md's step): shapes, bounds, pairs, manifolds.

``build_shape_table`` turns a World into flat shape arrays; then, each step,
``update_bounds`` (world poses and AABBs) -> ``find_pairs`` (sort-and-sweep
broadphase) -> ``collide_pairs`` (narrowphase, contact manifolds) ->
``flatten_seam_ghosts`` (a moving body's contacts at the seam of two flush static
shapes take the floor's normal, ``seams.py``). The ``CollisionPipeline`` class holds
the growing buffers and runs the four in order.
Not yet wired into the Simulator; no contact solver here.
"""

from .constants import LINEAR_SLOP, MAX_MANIFOLD_POINTS, SPECULATIVE_DISTANCE
from .geometry import ShapeTable, build_shape_table
from .bounds import update_bounds
from .broadphase import PairBuffer, find_pairs
from .manifold import ContactManifolds, match_contacts
from .narrowphase import collide_pairs
from .pipeline import CollisionPipeline

__all__ = [
    "LINEAR_SLOP", "MAX_MANIFOLD_POINTS", "SPECULATIVE_DISTANCE",
    "ShapeTable", "build_shape_table", "update_bounds", "PairBuffer", "find_pairs",
    "ContactManifolds", "match_contacts", "collide_pairs", "CollisionPipeline",
]
