"""``CollisionPipeline``: the four collision stages in order, with their buffers kept between steps.

Reads a World's ``x`` and ``R``; writes shape poses, AABBs, pairs and a ``ContactManifolds``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..math3d import JIT
from .bounds import update_bounds
from .broadphase import PairBuffer, find_pairs, keep_overlapping, lane_bounds
from .constants import SPECULATIVE_DISTANCE
from .filter import NO_FILTER, exclusion_keys, filter_allows, filter_table, live_filters
from .geometry import SHAPE_PLANE, build_shape_table
from .manifold import ContactManifolds
from .narrowphase import collide_pairs
from .seams import flatten_seam_ghosts
from .speculative import delay_speculative_ghosts
from .sensor import sensor_filter_table


class CollisionPipeline:
    """update_bounds -> find_pairs -> collide_pairs -> flatten_seam_ghosts over one World.

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
        self.shape_pos = self.shape_rot = self.shape_aabb = self.shape_margin = self.shape_rest = None
        self._material_version = None  # World.material_version of shape_rest
        self.pair_a = self.pair_b = None
        # sorted int64 keys lo * N + hi of jointed body pairs that must not collide (set by the
        # soft step), or None; the World's own exclusions are added to them (``_filters``)
        self.excluded_pairs = None
        self._filter_key = None
        self._excluded = None  # jointed and World-excluded keys, merged
        self._joint_keys = None
        self._body_filter = NO_FILTER
        self._user_filter = NO_FILTER  # the filters as the user set them (sensors' included)
        self._meet_key = None  # (table, excluded keys, body filter) of ``_meet`` (``meeting_pairs``)
        self._meet = None

    def refresh(self):
        """Rebuild the shape table if bodies were added since the last call."""
        world = self.world
        if self.table is None or world.body_count != self._body_count:
            self.table = build_shape_table(world, self.skip_unsupported)
            self._body_count = world.body_count
            S = self.table.shape_count
            self.shape_pos = np.empty((S, 3))
            self.shape_rot = np.empty((S, 3, 3))
            self.shape_aabb = np.empty((S, 2, 3))
            self.shape_margin = np.empty(S)
            self._material_version = None
        if world.material_version != self._material_version:
            # each shape's body's Material.margin (None: no body has one): read again when a
            # body's material is set (World.set_material)
            rest = np.array([m.margin for m in world.materials[: world.body_count]], dtype=float)
            self.shape_rest = rest[self.table.shape_body] if rest.any() else None
            self._material_version = world.material_version
        return self.table

    def take_table(self, other: "CollisionPipeline"):
        """Use ``other``'s shape table (a pipeline of the same world with the same bodies): the
        table is the world's description, which ``refresh`` rebuilds only when bodies are added,
        and building it is most of a new pipeline's cost (43 ms at 1000 boxes, in Python).
        ``Simulator.restore_state`` makes a new pipeline with the old one's table."""
        if other.table is not None and other._body_count == self.world.body_count:
            self.table, self._body_count = other.table, other._body_count
            self.shape_pos, self.shape_rot = other.shape_pos, other.shape_rot
            self.shape_aabb, self.shape_margin = other.shape_aabb, other.shape_margin
            self.shape_rest, self._material_version = other.shape_rest, other._material_version

    def _filters(self):
        """(excluded keys or None, body filter table): the World's filters and exclusions
        (collision/filter.py) with the jointed pairs, rebuilt only when one of them changed."""
        w = self.world
        key = (w.body_count, w.filter_version)
        if key != self._filter_key or self._joint_keys is not self.excluded_pairs:
            # a disabled body's row meets no other (World.set_enabled: NOTHING_FILTER)
            filters = w.collision_filters_in_effect()
            self._user_filter = filter_table(filters)
            # sensors touch nothing (collision/sensor.py): their rows meet no other
            sensor = w.sensor
            self._body_filter = sensor_filter_table(filters, sensor) \
                if sensor.any() else self._user_filter
            excluded = exclusion_keys(w.excluded_collisions, w.body_count)
            if self.excluded_pairs is not None:
                excluded = np.union1d(excluded, self.excluded_pairs).astype(np.int64)
            self._excluded = excluded if excluded.shape[0] else None
            self._joint_keys = self.excluded_pairs
            self._filter_key = key
        return self._excluded, self._body_filter

    def _lanes(self, table, body_filter):
        """(S,) int64 each shape's env (``CollisionFilter.env``), or None when no body has one."""
        if body_filter.shape[0] == 0:
            return None
        key = (id(table), self._filter_key)
        if key != getattr(self, "_lanes_key", None):
            env = body_filter[:, 3]
            lanes = None
            if env.any():
                lanes = env[table.shape_body].copy()
                # shapes that meet nothing (a link's marker, category 0) left out of the sweep: in lane 0
                # they would be stretched over every lane and paired with every copy, in a lane of
                # their own with each other (256 hoppers' 768 markers: 40 ms a step in that lane)
                lanes[~live_filters(body_filter)[table.shape_body]] = -1
            self._lane_of_shape = lanes
            self._lane_aabb = np.empty((0, 2, 3))
            self._lanes_key = key
        return self._lane_of_shape

    def live_shapes(self):
        """(S,) bool: the shapes whose body's filter lets it touch something, or None when every
        body may (default filters). A body whose filter meets no other body's (``filter.
        filter_allows``) is not live: a URDF or MJCF link with no collision shape (a marker sphere
        of category 0), and the copies of a model that touches nothing (``tumble.envs``: a category
        no body's mask holds), need no collision stages."""
        self._filters()
        table = self.refresh()
        key = (id(table), self._filter_key)
        if key != getattr(self, "_live_key", None):
            f = self._user_filter
            self._live = None if f.shape[0] == 0 else live_filters(f)[table.shape_body]
            self._live_key = key
        return self._live

    def meeting_pairs(self):
        """(K, 2) int64: the body pairs of the shape pairs that the filters and the exclusions (the
        World's and the jointed pairs') let meet, one row per pair of shapes (two shapes of one body,
        two planes: none), or None when the table has more than ``MEETING_SHAPES_MAX`` shapes (not
        worked out). Made again when the table, the filters or the exclusions change (new objects).
        A shape pair not listed never gets a contact (``narrowphase._candidate_pair`` culls it):
        ``SoftStep.collide`` skips the collision stages when no listed pair has a moving body."""
        excluded, body_filter = self._filters()
        table = self.refresh()
        key = self._meet_key
        if key is None or key[0] is not table or key[1] is not excluded or key[2] is not body_filter:
            if table.shape_count > MEETING_SHAPES_MAX:
                self._meet = None
            else:
                self._meet = _meeting_pairs_kernel(table.shape_type, table.shape_body, table.body_moving.shape[0],
                                                   _NO_KEYS if excluded is None else excluded, body_filter)
            self._meet_key = (table, excluded, body_filter)
        return self._meet

    def user_filters(self):
        """(excluded keys or None, filter table) as the user set them, without the rows that keep
        sensors out of contact: what a sensor's overlaps obey (collision/sensor.py)."""
        excluded, _ = self._filters()
        return excluded, self._user_filter

    def detect(self, x=None, R=None, v=None, omega=None, dt: float = 0.0, force=None) -> ContactManifolds:
        """Run the five stages; returns the contacts.

        Args:
            x: (N, 3) or the packed state (N, W), m; R: (N, 3, 3). Default: the world's
                current ``x`` and ``R``.
            v, omega: (N, 3) m/s, rad/s and dt (s): widen each shape's margin by the distance
                it can travel in the step (continuous collision); default none.
            force: (N, 3) N, the step's first applied forces (``Scratch.F``): bounds each body's
                acceleration for the sweeps of ``delay_speculative_ghosts``; default gravity alone.
        """
        world = self.world
        table = self.refresh()
        if x is None:
            x, R = world.x, world.R
        update_bounds(x, R, table, self.speculative, self.shape_pos, self.shape_rot, self.shape_aabb,
                      v=v, omega=omega, dt=dt, shape_margin=self.shape_margin, shape_rest=self.shape_rest)
        excluded, body_filter = self._filters()
        aabb = self.shape_aabb
        lanes = self._lanes(table, body_filter)
        if lanes is not None:  # copies in envs of their own: each in its lane (broadphase.lane_bounds)
            if self._lane_aabb.shape != aabb.shape:
                self._lane_aabb = np.empty_like(aabb)
            lane_bounds(aabb, lanes, self._lane_aabb)
        self.pair_a, self.pair_b = find_pairs(aabb if lanes is None else self._lane_aabb, table.shape_type,
                                              table.shape_body, table.body_moving, self.pairs)
        if lanes is not None:  # a shared shape stretched over the lanes met every copy beside it
            kept = keep_overlapping(self.pair_a, self.pair_b, aabb)
            self.pair_a, self.pair_b = self.pair_a[:kept], self.pair_b[:kept]
        contacts = collide_pairs(self.pair_a, self.pair_b, table, self.shape_pos, self.shape_rot, self.shape_aabb,
                                 self.speculative, self.contacts, shape_margin=self.shape_margin,
                                 excluded_pairs=excluded, body_filter=body_filter)
        # each pair routine sees two shapes; a seam between two flush static shapes needs a body's
        # contacts with both at once (collision/seams.py: Jolt's internal-edge removal, across bodies)
        # fixed bodies: no mass and not kinematic (``World.fixed`` would count the sleepers as fixed
        # here: the Simulator masks them out of ``World.moving`` while it collides)
        flatten_seam_ghosts(contacts, table, self.shape_pos, self.shape_rot, (world.inv_mass == 0.0) & ~world.kinematic)
        # a speculative contact's linear gap closes before the shapes meet where its feature is an edge or
        # a corner they pass by (collision/speculative.py): its gap may close no earlier than a sweep touches
        if v is not None and dt > 0.0:
            delay_speculative_ghosts(contacts, table, self.shape_pos, self.shape_rot, x, v, omega, dt, world.inv_mass,
                                     world.gravity, force)
        else:
            contacts.allowance_count = 0
        return contacts


# PERF: above this many shapes the pairs are not listed (S^2 / 2 of them; the collision stages then
# run whenever a shape of a moving body is live, as before)
MEETING_SHAPES_MAX = 64
_NO_KEYS = np.zeros(0, dtype=np.int64)


@njit(**JIT)
def _meeting_pairs_kernel(shape_type, shape_body, N, excluded, body_filter):
    """``CollisionPipeline.meeting_pairs`` of the shape table's ``shape_type``, ``shape_body`` (S,):
    (K, 2) int64 body rows; ``excluded`` sorted keys lo * N + hi, ``body_filter`` (N, 4) or empty."""
    S = shape_type.shape[0]
    out = np.empty((max(S * (S - 1) // 2, 1), 2), dtype=np.int64)
    k = 0
    for a in range(S):
        for b in range(a + 1, S):
            ba = shape_body[a]
            bb = shape_body[b]
            if ba == bb or (shape_type[a] == SHAPE_PLANE and shape_type[b] == SHAPE_PLANE):
                continue
            if excluded.shape[0] > 0:
                key = min(ba, bb) * N + max(ba, bb)
                i = np.searchsorted(excluded, key)
                if i < excluded.shape[0] and excluded[i] == key:
                    continue
            if not filter_allows(body_filter, ba, bb):
                continue
            out[k, 0] = ba
            out[k, 1] = bb
            k += 1
    return out[:k].copy()


@njit(**JIT)
def any_pair_moving_kernel(pairs, body_moving) -> bool:
    """Whether a row of ``pairs`` (K, 2) int64 has a body that ``body_moving`` (N,) bool marks."""
    for k in range(pairs.shape[0]):
        if body_moving[pairs[k, 0]] or body_moving[pairs[k, 1]]:
            return True
    return False


@njit(**JIT)
def any_at_kernel(flags, rows) -> bool:
    """Whether ``flags`` (N,) bool is True at one of ``rows`` (K,) int64 (``np.any(flags[rows])``
    without the copy)."""
    for k in range(rows.shape[0]):
        if flags[rows[k]]:
            return True
    return False
