"""``CollisionPipeline``: the three collision stages in order, with their buffers kept between steps.

Reads a World's ``x`` and ``R``; writes shape poses, AABBs, pairs and a ``ContactManifolds``.
"""

from __future__ import annotations

from .bounds import update_bounds
from .broadphase import PairBuffer, find_pairs
from .constants import SPECULATIVE_DISTANCE
from .geometry import build_shape_table
from .manifold import ContactManifolds
from .narrowphase import collide_pairs


class CollisionPipeline:
    """update_bounds -> find_pairs -> collide_pairs over one World.

    Args:
        world: the ``tumble.World``; its shape table is rebuilt when bodies are added.
        speculative: m, speculative distance and AABB margin (default 0.02 m, Box3D's).
        skip_unsupported: bodies whose shape has no collision support yet collide
            with nothing instead of raising ``NotImplementedError``.

    Attributes after ``detect``: ``table``, ``shape_pos`` (S, 3), ``shape_rot`` (S, 3, 3),
    ``shape_aabb`` (S, 2, 3), ``pair_a``/``pair_b`` (P,), ``contacts`` (ContactManifolds).
    """

    def __init__(self, world, speculative: float = SPECULATIVE_DISTANCE, skip_unsupported: bool = False):
        self.world = world
        self.speculative = float(speculative)
        self.skip_unsupported = skip_unsupported
        self.table = None
        self._body_count = -1
        self.pairs = PairBuffer()
        self.contacts = ContactManifolds()
        self.shape_pos = self.shape_rot = self.shape_aabb = None
        self.pair_a = self.pair_b = None

    def detect(self) -> ContactManifolds:
        """Run the three stages on the world's current poses (``x``, ``R``); returns the contacts."""
        world = self.world
        if self.table is None or world.body_count != self._body_count:
            self.table = build_shape_table(world, self.skip_unsupported)
            self._body_count = world.body_count
            self.shape_pos = self.shape_rot = self.shape_aabb = None
        self.shape_pos, self.shape_rot, self.shape_aabb = update_bounds(
            world.x, world.R, self.table, self.speculative, self.shape_pos, self.shape_rot, self.shape_aabb)
        self.pair_a, self.pair_b = find_pairs(self.shape_aabb, self.table.shape_type, self.table.shape_body,
                                              self.table.body_moving, self.pairs)
        return collide_pairs(self.pair_a, self.pair_b, self.table, self.shape_pos, self.shape_rot, self.shape_aabb,
                             self.speculative, self.contacts)
