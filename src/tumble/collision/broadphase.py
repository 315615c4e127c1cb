"""Stage ``find_pairs``: sort-and-sweep broadphase over shape AABBs.

Reads ``shape_aabb`` (S, 2, 3), ``shape_type``, ``shape_body`` and ``body_moving``;
writes the pair arrays ``pair_a``, ``pair_b`` (P,) int64 with a < b, sorted by
(a, b). Planes (unbounded) are left out: the narrowphase tests each plane against
every moving shape directly.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..math3d import JIT
from ..shapes import SHAPE_PLANE


@njit(**JIT)
def _find_pairs_kernel(aabb, shape_type, shape_body, body_moving,
                       # outputs
                       pair_a, pair_b):
    """Sort-and-sweep ("sweep and prune": Cohen, Lin, Manocha, Ponamgi 1995, I-COLLIDE §4; Bullet btAxisSweep3).

    Returns the number of pairs found. Pairs are written only while they fit;
    when the count exceeds ``len(pair_a)`` the caller grows the buffers and calls
    again. Cost: O(S log S) for the sort plus O(S + P + overlaps along the axis).
    """
    S = shape_type.shape[0]
    # candidates: every bounded shape (planes and other unbounded shapes are skipped)
    idx = np.empty(S, dtype=np.int64)
    n = 0
    for s in range(S):
        if shape_type[s] != SHAPE_PLANE and np.isfinite(aabb[s, 0, 0]) and np.isfinite(aabb[s, 1, 0]):
            idx[n] = s
            n += 1
    if n < 2:
        return 0
    # sweep axis: the one along which the AABB centres spread most (largest variance),
    # so that the fewest intervals overlap along it
    mean = np.zeros(3)
    for k in range(n):
        s = idx[k]
        for i in range(3):
            mean[i] += 0.5 * (aabb[s, 0, i] + aabb[s, 1, i])
    for i in range(3):
        mean[i] /= n
    var = np.zeros(3)
    for k in range(n):
        s = idx[k]
        for i in range(3):
            d = 0.5 * (aabb[s, 0, i] + aabb[s, 1, i]) - mean[i]
            var[i] += d * d
    axis = 0
    if var[1] > var[axis]:
        axis = 1
    if var[2] > var[axis]:
        axis = 2
    ax1 = (axis + 1) % 3
    ax2 = (axis + 2) % 3
    keys = np.empty(n)
    for k in range(n):
        keys[k] = aabb[idx[k], 0, axis]
    # mergesort is stable: equal keys keep shape order, so the sweep is deterministic.
    # PERF: shapes move little between steps; an insertion sort of last step's order
    # would be O(S) for coherent scenes.
    order = np.argsort(keys, kind="mergesort")
    # the sorted boxes, contiguous, so that the inner loop walks memory in order
    box = np.empty((n, 6))
    sid = np.empty(n, dtype=np.int64)
    for k in range(n):
        s = idx[order[k]]
        sid[k] = s
        box[k, 0] = aabb[s, 0, axis]
        box[k, 1] = aabb[s, 1, axis]
        box[k, 2] = aabb[s, 0, ax1]
        box[k, 3] = aabb[s, 1, ax1]
        box[k, 4] = aabb[s, 0, ax2]
        box[k, 5] = aabb[s, 1, ax2]
    cap = pair_a.shape[0]
    count = 0
    for k in range(n):
        hi = box[k, 1]
        a = sid[k]
        body_a = shape_body[a]
        moving_a = body_moving[body_a]
        for m in range(k + 1, n):
            if box[m, 0] > hi:
                break
            if box[m, 3] < box[k, 2] or box[m, 2] > box[k, 3] or box[m, 5] < box[k, 4] or box[m, 4] > box[k, 5]:
                continue
            b = sid[m]
            body_b = shape_body[b]
            if body_b == body_a or not (moving_a or body_moving[body_b]):
                continue
            if count < cap:
                if a < b:
                    pair_a[count] = a
                    pair_b[count] = b
                else:
                    pair_a[count] = b
                    pair_b[count] = a
            count += 1
    if count > cap:
        return count
    # deterministic output order: by (a, b), whatever the sweep axis was
    pkey = np.empty(count, dtype=np.int64)
    for k in range(count):
        pkey[k] = pair_a[k] * S + pair_b[k]
    porder = np.argsort(pkey, kind="mergesort")
    for k in range(count):
        p = pkey[porder[k]]
        pair_a[k] = p // S
        pair_b[k] = p % S
    return count


class PairBuffer:
    """Growing storage for the pair arrays (doubling, never shrinking)."""

    def __init__(self, capacity: int = 256):
        self.pair_a = np.empty(max(int(capacity), 1), dtype=np.int64)
        self.pair_b = np.empty_like(self.pair_a)
        self.pair_count = 0

    def grow(self, needed: int):
        capacity = len(self.pair_a)
        while capacity < needed:
            capacity *= 2
        self.pair_a = np.empty(capacity, dtype=np.int64)
        self.pair_b = np.empty(capacity, dtype=np.int64)


def find_pairs(aabb, shape_type, shape_body, body_moving, out: PairBuffer | None = None):
    """Pairs of shapes whose AABBs overlap (sort-and-sweep along the axis of largest variance).

    Args:
        aabb: (S, 2, 3) m, world AABBs from ``update_bounds`` (``[s, 0]`` min, ``[s, 1]`` max).
        shape_type: (S,) int64 ``SHAPE_*`` ids; planes are left out (see ``collide_pairs``).
        shape_body: (S,) int64 owning body; two shapes of one body never pair.
        body_moving: (N,) bool; two shapes of fixed bodies never pair.
        out: a ``PairBuffer`` to reuse (grown by doubling when too small).

    Returns:
        ``(pair_a, pair_b)``: (P,) int64 views into ``out``, ``pair_a < pair_b``,
        sorted by (a, b). Overlap is closed: touching boxes pair.
    """
    if out is None:
        out = PairBuffer(max(256, 2 * len(shape_type)))
    aabb = np.ascontiguousarray(aabb, dtype=np.float64)
    shape_type = np.ascontiguousarray(shape_type, dtype=np.int64)
    shape_body = np.ascontiguousarray(shape_body, dtype=np.int64)
    body_moving = np.ascontiguousarray(body_moving, dtype=np.bool_)
    count = _find_pairs_kernel(aabb, shape_type, shape_body, body_moving, out.pair_a, out.pair_b)
    if count > len(out.pair_a):
        out.grow(count)
        count = _find_pairs_kernel(aabb, shape_type, shape_body, body_moving, out.pair_a, out.pair_b)
    out.pair_count = count
    return out.pair_a[:count], out.pair_b[:count]
