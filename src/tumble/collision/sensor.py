"""Sensors: bodies that detect what overlaps them and push nothing (Box2D v3's sensor shapes,
Bullet's ghost objects): trigger zones, goal lines, a bin that counts what falls in.

A sensor body (``World.add_body(..., sensor=True)``) has no contact with anything: the
collision pipeline gives it a filter row that meets no other (``sensor_filter_table``). After
each step the Simulator finds the bodies that overlap each sensor at the step's end
(``SensorLog.update``): the shapes of the dynamic and kinematic bodies (not fixed ones, nor other
sensors; Box3D's sensor events, too, apply to kinematic and dynamic bodies only) whose bounding boxes meet a sensor shape's
are passed to the narrowphase with no speculative distance, and a pair overlaps when one of its
points has a separation below zero. The user's collision filters and exclusions apply between
a sensor and its visitors as between any two bodies. A sensor may itself be fixed, kinematic or
dynamic (a dynamic one falls through everything).

Events: a pair (sensor, visitor) begins when it first overlaps at a step's end and ends when it
no longer does, each stamped with that step's end time. A sleeping visitor is still seen (its
shapes are where it fell asleep). The work is per step and only in a world with a sensor: the
sensor shapes' boxes against every shape's (NumPy, S x sensor shapes) and the narrowphase on the
few pairs that meet.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ..body_motion import _matrix
from ..math3d import JIT
from ..shapes import SHAPE_PLANE
from .bounds import update_bounds
from .filter import filter_table
from .manifold import ContactManifolds
from .narrowphase import collide_pairs

_EMPTY = np.zeros(0, dtype=np.int64)
# the most sub-step samples ``SensorLog.passes`` takes for one step (a body moving more than this
# many times its own size in a step is sampled more coarsely)
MAX_PASS_SAMPLES = 256


def sensor_filter_table(filters, sensor: np.ndarray) -> np.ndarray:
    """``filter.filter_table`` of the bodies with each sensor's row (category, mask, group, env) =
    (0, 0, 0, 0): it meets no mask and shares no group, so the narrowphase gives it no contact."""
    table = filter_table(filters)
    if not sensor.any():
        return table
    if table.shape[0] == 0:
        table = np.array([(1, 0xFFFFFFFF, 0, 0)] * len(filters), dtype=np.int64).reshape(-1, 4)
    table = table.copy()
    table[sensor] = 0
    return table


@njit(**JIT)
def _rotations_kernel(layout, Y, R):
    """R (N, 3, 3) of every body of the packed state Y (N, W)."""
    for i in range(Y.shape[0]):
        if layout == 1:
            o = (Y[i, 3], Y[i, 4], Y[i, 5], Y[i, 6], Y[i, 7], Y[i, 8], Y[i, 9], Y[i, 10], Y[i, 11])
        else:
            o = (Y[i, 3], Y[i, 4], Y[i, 5], Y[i, 6], 0.0, 0.0, 0.0, 0.0, 0.0)
        m = _matrix(layout, o)
        for k in range(9):
            R[i, k // 3, k % 3] = m[k]


@dataclass
class SensorEvents:
    """Sensor events since the last read, in the order they happened (within a step by pair).

    Attributes:
        begin_sensor, begin_visitor: (B,) int64 body indices of the pairs that began overlapping.
        begin_time: (B,) s, the end of the step at which they first overlapped.
        end_sensor, end_visitor: (E,) int64 of the pairs that stopped overlapping.
        end_time: (E,) s.
    """

    begin_sensor: np.ndarray
    begin_visitor: np.ndarray
    begin_time: np.ndarray
    end_sensor: np.ndarray
    end_visitor: np.ndarray
    end_time: np.ndarray


class SensorLog:
    """The overlapping (sensor, visitor) pairs at the last step's end and the events not yet read."""

    def __init__(self):
        self.pairs = np.zeros((0, 2), dtype=np.int64)  # (K, 2) sorted by sensor, then visitor
        self._begin: list[tuple] = []
        self._end: list[tuple] = []
        self._contacts = ContactManifolds()
        self._buffers = None

    # -- the step --------------------------------------------------------------------
    def update(self, world, pipeline, Y: np.ndarray, t: float, excluded=None, body_filter=None, Y0=None):
        """The overlaps at the poses of Y (N, W) (the step's end, time t s); records the events.
        ``excluded``, ``body_filter``: the user's exclusion keys and filter table (the
        pipeline's ``_filters``, before the sensors' own rows). ``Y0``: the poses at the step's
        start, for the bodies that pass through a sensor within the step (``passes``): each such
        pair begins and ends at t."""
        pairs = self.overlaps(world, pipeline, Y, excluded, body_filter)
        old = {tuple(p) for p in self.pairs.tolist()}
        new = {tuple(p) for p in pairs.tolist()}
        crossed = set() if Y0 is None else self.passes(world, pipeline, Y0, Y, excluded, body_filter) - old - new
        for s, v in sorted(new - old):
            self._begin.append((s, v, t))
        for s, v in sorted(crossed):
            self._begin.append((s, v, t))
        for s, v in sorted(crossed | (old - new)):
            self._end.append((s, v, t))
        self.pairs = pairs

    def passes(self, world, pipeline, Y0, Y1, excluded=None, body_filter=None) -> set:
        """(sensor, visitor) pairs that overlap somewhere between the poses Y0 and Y1 (N, W) of
        one step (call after ``overlaps(..., Y1, ...)``, whose boxes it reads), for visitors that move farther in it than their own size (a bullet through a
        thin sensor, which neither end sees). NOTE: sampled, not swept: the centres of mass move
        on straight lines from Y0 to Y1 (orientations as at Y1) in K steps no longer than the
        smallest half-width of the body's boxes (at most ``MAX_PASS_SAMPLES``; only the movers'
        shapes are moved, from their poses at Y1), so a sample
        overlaps any sensor the path crosses, as Box2D's newer sensor hits find by time of impact."""
        table = pipeline.refresh()
        n = world.body_count
        body = table.shape_body
        solid = table.shape_type != SHAPE_PLANE
        sens = world.sensor
        visitor_body = ~sens & ~world.fixed
        d = np.linalg.norm(Y1[:n, :3] - Y0[:n, :3], axis=1)
        if not np.any(d[visitor_body] > 0.0) or not sens.any():
            return set()
        # the shapes' boxes at Y1, as ``overlaps(Y1)`` (called first by ``update``) left them
        aabb = self._buffers[2].copy()
        half = 0.5 * (aabb[:, 1] - aabb[:, 0]).min(axis=1)
        size = np.full(n, np.inf)
        np.minimum.at(size, body[solid], half[solid])
        fast = visitor_body & (d > size)
        if not fast.any():
            return set()
        # the swept boxes of the fast bodies (end boxes moved back along their step) against the sensors'
        shift = (Y0[:n, :3] - Y1[:n, :3])[body]
        lo = np.minimum(aabb[:, 0], aabb[:, 0] + shift)
        hi = np.maximum(aabb[:, 1], aabb[:, 1] + shift)
        ss = np.flatnonzero(sens[body] & solid)
        vs = np.flatnonzero(fast[body] & solid)
        near = np.all((lo[vs][None, :, :] <= hi[ss][:, None, :]) & (hi[vs][None, :, :] >= lo[ss][:, None, :]), axis=2)
        movers = np.zeros(n, dtype=bool)
        movers[body[vs[near.any(axis=0)]]] = True
        if not movers.any():
            return set()
        K = int(min(MAX_PASS_SAMPLES, np.ceil(np.max(d[movers] / size[movers]))))
        # PERF: a sample moves only the movers' shapes, by their body's step (orientations as at
        # Y1), from the poses and boxes at Y1: no bounds of the whole world per sample (which
        # cost 0.6 ms a sample among the large pyramid's 5050 boxes, 100 ms a bullet's step)
        pos1, rot1 = self._buffers[0].copy(), self._buffers[1].copy()
        rows = np.flatnonzero(movers[body])
        back = (Y0[:n, :3] - Y1[:n, :3])[body[rows]]
        pos, box = pos1.copy(), aabb.copy()
        found = set()
        for k in range(1, K):
            shift = back * (1.0 - k / K)
            pos[rows] = pos1[rows] + shift
            box[rows] = aabb[rows] + shift[:, None, :]
            for s, v in self._overlaps_at(world, table, pos, rot1, box, excluded, body_filter, visitors=movers).tolist():
                found.add((s, v))
        return found

    def overlaps(self, world, pipeline, Y, excluded=None, body_filter=None, visitors=None) -> np.ndarray:
        """(K, 2) int64 (sensor, visitor) body pairs overlapping at the poses of Y, sorted;
        ``visitors`` (N,) bool: look only at these bodies (default all)."""
        table = pipeline.refresh()
        pos, rot, aabb, margin, R = self._bounds(world, table, Y)
        return self._overlaps_at(world, table, pos, rot, aabb, excluded, body_filter, visitors)

    def _overlaps_at(self, world, table, pos, rot, aabb, excluded=None, body_filter=None, visitors=None) -> np.ndarray:
        """``overlaps`` for the shapes' poses ``pos`` (S, 3), ``rot`` (S, 3, 3) and boxes ``aabb`` (S, 2, 3)."""
        S = table.shape_count
        body = table.shape_body
        sensor_shape = world.sensor[body] & (table.shape_type != SHAPE_PLANE)
        visitor_shape = ~world.sensor[body] & ~world.fixed[body] & (table.shape_type != SHAPE_PLANE)
        if visitors is not None:
            visitor_shape &= visitors[body]
        ss = np.flatnonzero(sensor_shape)
        vs = np.flatnonzero(visitor_shape)
        if len(ss) == 0 or len(vs) == 0:
            return np.zeros((0, 2), dtype=np.int64)
        lo, hi = aabb[:, 0], aabb[:, 1]
        meet = np.all((lo[vs][None, :, :] <= hi[ss][:, None, :]) & (hi[vs][None, :, :] >= lo[ss][:, None, :]), axis=2)
        si, vi = np.nonzero(meet)
        a, b = ss[si], vs[vi]
        a, b = np.minimum(a, b), np.maximum(a, b)
        keep = body[a] != body[b]
        a, b = a[keep], b[keep]
        if len(a) == 0:
            return np.zeros((0, 2), dtype=np.int64)
        order = np.lexsort((b, a))
        a, b = a[order], b[order]
        # planes are not candidates here; collide_pairs still tries each plane against each shape of
        # a moving body: those manifolds are dropped below (neither body is a sensor)
        c = collide_pairs(a, b, table, pos, rot, aabb, 0.0, self._contacts, shape_margin=np.zeros(S),
                          excluded_pairs=excluded, body_filter=body_filter)
        touching = c.contact_separation < 0.0
        ba, bb = c.contact_body_a[touching], c.contact_body_b[touching]
        sens = world.sensor
        one = sens[ba] ^ sens[bb]
        ba, bb = ba[one], bb[one]
        s = np.where(sens[ba], ba, bb)
        v = np.where(sens[ba], bb, ba)
        seen = ~world.fixed[v]  # the planes' candidates put fixed planes against a dynamic sensor
        s, v = s[seen], v[seen]
        if len(s) == 0:
            return np.zeros((0, 2), dtype=np.int64)
        return np.unique(np.stack([s, v], axis=1), axis=0)

    def _bounds(self, world, table, Y):
        """(shape_pos, shape_rot, shape_aabb, shape_margin, R) of the shapes at the poses of Y,
        without margins (the buffers are kept)."""
        n = world.body_count
        S = table.shape_count
        if self._buffers is None or self._buffers[0].shape[0] != S or self._buffers[4].shape[0] != n:
            self._buffers = (np.empty((S, 3)), np.empty((S, 3, 3)), np.empty((S, 2, 3)), np.empty(S),
                             np.empty((n, 3, 3)))
        pos, rot, aabb, margin, R = self._buffers
        _rotations_kernel(world.layout_id, Y, R)
        update_bounds(Y, R, table, 0.0, pos, rot, aabb, shape_margin=margin)
        return self._buffers

    # -- reading -----------------------------------------------------------------------
    def drain(self) -> SensorEvents:
        """The events since the last call, and forget them."""
        begin, end = self._begin, self._end
        self._begin, self._end = [], []

        def col(rows, k, dtype):
            return np.array([r[k] for r in rows], dtype=dtype)

        return SensorEvents(col(begin, 0, np.int64), col(begin, 1, np.int64), col(begin, 2, float),
                            col(end, 0, np.int64), col(end, 1, np.int64), col(end, 2, float))

    def counts(self, world) -> np.ndarray:
        """(K,) float: how many bodies overlap each of the world's K sensors (body order)."""
        sensors = np.flatnonzero(world.sensor)
        if not len(self.pairs):
            return np.zeros(len(sensors))
        return np.array([np.count_nonzero(self.pairs[:, 0] == s) for s in sensors], dtype=float)

    def set_pairs(self, pairs):
        """The overlapping pairs of a saved run (checkpoints), so a resumed run's events continue."""
        self.pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
