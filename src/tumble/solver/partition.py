"""Spatial slabs for the Gauss-Seidel sweeps on both cores (``partition_pairs_kernel``) and the
order of a sweep (``SweepOrder``), shared by the contact and joint solves. Reads the pairs'
bodies (K,) and x (N, 3) m; writes the pairs' order and each slab's bounds."""

from __future__ import annotations

import numpy as np
from numba import njit

from ..math3d import JIT, argsort_stable


@njit(**JIT)
def partition_pairs_kernel(body_a, body_b, moving, x, parts,
                           # outputs
                           body_part, order, bounds):
    """Split the contacts (or joints: body_a, body_b (C,) int64, -1 for the world) into
    ``parts`` partitions that share no moving body, and a seam.

    The moving bodies of the contacts are ranked along the world axis in which their centres
    x (N, >= 3) m spread most and cut into ``parts`` slabs of equal count; a contact whose moving
    bodies lie in one slab is that slab's, one joining two slabs is the seam's. ``order`` (C,)
    lists the contacts slab by slab, then the seam, each in the contacts' own order (a stable
    counting sort): partition p is order[bounds[p]:bounds[p + 1]], the seam
    order[bounds[parts]:bounds[parts + 1]]; bounds is (parts + 2,). body_part (N,) int64 is
    scratch: each body's slab, -1 for bodies that the contacts do not move.

    Box2D v3 spreads its solve over threads by graph colouring (each colour's constraints share
    no body), with a barrier after each colour; tried here first and dropped: a dozen barriers a
    sweep cost more than the sweep (docs/benchmarks.md). Slabs need one barrier a sweep, and a
    large scene has few contacts across a cut (large_pyramid: 1 %).
    """
    n_contacts = body_a.shape[0]
    for i in range(body_part.shape[0]):
        body_part[i] = -1
    count = 0
    for c in range(n_contacts):
        a = body_a[c]
        b = body_b[c]
        if a >= 0 and moving[a] and body_part[a] < 0:
            body_part[a] = 0
            count += 1
        if b >= 0 and moving[b] and body_part[b] < 0:
            body_part[b] = 0
            count += 1
    ids = np.empty(count, dtype=np.int64)
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    k = 0
    for i in range(body_part.shape[0]):
        if body_part[i] == 0:
            ids[k] = i
            k += 1
            for d in range(3):
                lo[d] = min(lo[d], x[i, d])
                hi[d] = max(hi[d], x[i, d])
    axis = 0
    for d in range(1, 3):
        if hi[d] - lo[d] > hi[axis] - lo[axis]:
            axis = d
    coord = np.empty(count)
    for k in range(count):
        coord[k] = x[ids[k], axis]
    rank = argsort_stable(coord)
    for r in range(count):
        body_part[ids[rank[r]]] = r * parts // count
    # stable counting sort of the contacts by group: slab 0 .. parts - 1, then the seam (parts)
    group_count = np.zeros(parts + 1, dtype=np.int64)
    for c in range(n_contacts):
        group_count[_pair_group(body_part, body_a[c], body_b[c], parts)] += 1
    bounds[0] = 0
    for g in range(parts + 1):
        bounds[g + 1] = bounds[g] + group_count[g]
    cursor = bounds[:parts + 1].copy()
    for c in range(n_contacts):
        g = _pair_group(body_part, body_a[c], body_b[c], parts)
        order[cursor[g]] = c
        cursor[g] += 1


@njit(**JIT)
def _pair_group(body_part, a, b, parts):
    """The partition of a pair of bodies a, b (-1: the world) by their slabs (-1: not moved), or
    ``parts`` (the seam) when the slabs differ or neither body moves."""
    part_a = body_part[a] if a >= 0 else -1
    part_b = body_part[b] if b >= 0 else -1
    if part_a < 0:
        return part_b if part_b >= 0 else parts
    if part_b < 0 or part_b == part_a:
        return part_a
    return parts


class SweepOrder:
    """The order of a Gauss-Seidel sweep over pairs of bodies (the contacts of a step, or the
    joints), kept between steps: slabs and a seam (``partition_pairs_kernel``) for a sweep of
    at least ``min_count`` pairs when ``parts`` > 1, else the pairs' own order.

    ``order`` (>= n,) int64 and ``bounds`` (P + 2,) int64 are what the sweep kernels take
    (``order[:n]``): P = 0 and bounds [0, n] for the pairs' own order. ``partitioned``: the last
    ``update`` cut slabs.
    """

    def __init__(self):
        self.partitioned = False
        self.order = np.zeros(0, dtype=np.int64)
        self.bounds = np.zeros(2, dtype=np.int64)
        self._order_is_identity = True
        self._body_part = np.zeros(0, dtype=np.int64)

    def update(self, body_a, body_b, moving, x, parts: int, min_count: int):
        """The order for the pairs (body_a[k], body_b[k]) (n,) int64 (-1: the world) of bodies at
        x (N, >= 3) m, ``moving`` (N,) bool; returns (order[:n], bounds)."""
        n = len(body_a)
        self.partitioned = parts > 1 and n > 0 and n >= min_count
        if len(self.order) < n:
            self.order = np.arange(2 * n, dtype=np.int64)
            self._order_is_identity = True
        if not self.partitioned:
            # PERF: nothing to write while the order is still 0, 1, ... (every step of a small scene)
            if not self._order_is_identity:
                self.order[:] = np.arange(len(self.order))
                self._order_is_identity = True
            if len(self.bounds) != 2:
                self.bounds = np.zeros(2, dtype=np.int64)
            self.bounds[1] = n
            return self.order[:n], self.bounds
        if len(self._body_part) != len(moving):
            self._body_part = np.zeros(len(moving), dtype=np.int64)
        if len(self.bounds) != parts + 2:
            self.bounds = np.zeros(parts + 2, dtype=np.int64)
        partition_pairs_kernel(body_a, body_b, moving, x, parts, self._body_part, self.order[:n], self.bounds)
        self._order_is_identity = False
        return self.order[:n], self.bounds
