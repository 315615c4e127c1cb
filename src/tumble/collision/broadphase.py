"""Stage ``find_pairs``: sort-and-sweep broadphase over shape AABBs.

Sort-and-sweep within the columns of a 2-D grid. Reads ``shape_aabb`` (S, 2, 3),
``shape_type``, ``shape_body`` and ``body_moving``;
writes the pair arrays ``pair_a``, ``pair_b`` (P,) int64 with a < b, sorted by
(a, b). Planes (unbounded) are left out: the narrowphase tests each plane against
every moving shape directly.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..math3d import JIT, NO_NRT, argsort_stable
from ..shapes import SHAPE_PLANE


# Shapes whose AABB spans more than this many grid cells along either grid axis (a
# ground box, a long wall) skip the grid and are tested against every shape directly.
BIG_CELLS = 8


@njit(**NO_NRT)
def _cell(v, origin, size, n):
    c = int((v - origin) / size)
    return 0 if c < 0 else (n - 1 if c >= n else c)


@njit(**NO_NRT)
def _emit(a, b, pair_a, pair_b, count):
    if count < pair_a.shape[0]:
        if a < b:
            pair_a[count] = a
            pair_b[count] = b
        else:
            pair_a[count] = b
            pair_b[count] = a
    return count + 1


@njit(**NO_NRT)
def _overlap(aabb, a, b):
    for i in range(3):
        if aabb[a, 1, i] < aabb[b, 0, i] or aabb[b, 1, i] < aabb[a, 0, i]:
            return False
    return True


@njit(**JIT)
def _find_pairs_kernel(aabb, shape_type, shape_body, body_moving,
                       # outputs
                       pair_a, pair_b):
    """Sort-and-sweep in the columns of a 2-D grid ("sweep and prune": Cohen, Lin, Manocha,
    Ponamgi 1995, I-COLLIDE §4; the column split is Tracy, Buss, Woods 2009, "Efficient
    Large-Scale Sweep and Prune Methods with AABB Insertion and Removal", §3).

    A single sweep along one axis tests every pair whose intervals overlap on that axis:
    for shapes spread through a volume that is O(N^(5/3)) (measured: 0.56 s for 100 000
    boxes). Splitting the two other axes into columns about two shapes wide keeps each
    sweep short: O(N log N) for the one sort plus O(N + pairs). A pair is reported only
    by the column holding the lower corner of the two boxes' overlap, so exactly once.

    Returns the number of pairs found. Pairs are written only while they fit; when the
    count exceeds ``len(pair_a)`` the caller grows the buffers and calls again.
    """
    S = shape_type.shape[0]
    idx = np.empty(S, dtype=np.int64)
    n = 0
    for s in range(S):
        if shape_type[s] != SHAPE_PLANE and np.isfinite(aabb[s, 0, 0]) and np.isfinite(aabb[s, 1, 0]):
            idx[n] = s
            n += 1
    if n < 2:
        return 0
    # sweep axis: where the AABB centres spread most (largest variance); the grid spans the other two
    mean = np.zeros(3)
    width = np.zeros(3)
    for k in range(n):
        for i in range(3):
            mean[i] += 0.5 * (aabb[idx[k], 0, i] + aabb[idx[k], 1, i])
            width[i] += aabb[idx[k], 1, i] - aabb[idx[k], 0, i]
    var = np.zeros(3)
    for k in range(n):
        for i in range(3):
            d = 0.5 * (aabb[idx[k], 0, i] + aabb[idx[k], 1, i]) - mean[i] / n
            var[i] += d * d
    axis = 0
    if var[1] > var[axis]:
        axis = 1
    if var[2] > var[axis]:
        axis = 2
    ax1 = (axis + 1) % 3
    ax2 = (axis + 2) % 3
    # grid: cells twice the mean AABB width, at most about 4 n cells
    lo1, hi1, lo2, hi2 = np.inf, -np.inf, np.inf, -np.inf
    for k in range(n):
        s = idx[k]
        lo1 = min(lo1, aabb[s, 0, ax1])
        hi1 = max(hi1, aabb[s, 1, ax1])
        lo2 = min(lo2, aabb[s, 0, ax2])
        hi2 = max(hi2, aabb[s, 1, ax2])
    size = max(width[ax1] + width[ax2], 1e-300) / n
    size = max(size, 1e-9 * max(hi1 - lo1, hi2 - lo2, 1.0))
    n1 = max(1, min(int((hi1 - lo1) / size) + 1, 1 << 20))
    n2 = max(1, min(int((hi2 - lo2) / size) + 1, 1 << 20))
    while n1 * n2 > 4 * n + 16:
        size *= 1.5
        n1 = int((hi1 - lo1) / size) + 1
        n2 = int((hi2 - lo2) / size) + 1
    # one stable sort by the lower bound along the sweep axis (ties keep shape order)
    # PERF: shapes move little between steps; an insertion sort of last step's order
    # would make this O(n) for coherent scenes.
    keys = np.empty(n)
    for k in range(n):
        keys[k] = aabb[idx[k], 0, axis]
    order = argsort_stable(keys)
    # bucket the shapes into columns in that order (a counting sort), so that each
    # column's list is already sorted along the sweep axis; big shapes are kept apart
    cells = n1 * n2
    start = np.zeros(cells + 1, dtype=np.int64)
    big = np.zeros(S, dtype=np.bool_)
    big_list = np.empty(n, dtype=np.int64)
    n_big = 0
    for k in range(n):
        s = idx[order[k]]
        c1a = _cell(aabb[s, 0, ax1], lo1, size, n1)
        c1b = _cell(aabb[s, 1, ax1], lo1, size, n1)
        c2a = _cell(aabb[s, 0, ax2], lo2, size, n2)
        c2b = _cell(aabb[s, 1, ax2], lo2, size, n2)
        if c1b - c1a >= BIG_CELLS or c2b - c2a >= BIG_CELLS:
            big[s] = True
            big_list[n_big] = s
            n_big += 1
            continue
        for c1 in range(c1a, c1b + 1):
            for c2 in range(c2a, c2b + 1):
                start[c1 * n2 + c2 + 1] += 1
    for c in range(cells):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    column = np.empty(start[cells], dtype=np.int64)
    for k in range(n):
        s = idx[order[k]]
        if big[s]:
            continue
        c1a = _cell(aabb[s, 0, ax1], lo1, size, n1)
        c1b = _cell(aabb[s, 1, ax1], lo1, size, n1)
        c2a = _cell(aabb[s, 0, ax2], lo2, size, n2)
        c2b = _cell(aabb[s, 1, ax2], lo2, size, n2)
        for c1 in range(c1a, c1b + 1):
            for c2 in range(c2a, c2b + 1):
                c = c1 * n2 + c2
                column[fill[c]] = s
                fill[c] += 1
    count = np.int64(0)  # not a literal: _emit would be compiled twice
    for c in range(cells):
        c1 = c // n2
        c2 = c % n2
        for k in range(start[c], start[c + 1]):
            a = column[k]
            hi = aabb[a, 1, axis]
            body_a = shape_body[a]
            moving_a = body_moving[body_a]
            for m in range(k + 1, start[c + 1]):
                b = column[m]
                if aabb[b, 0, axis] > hi:
                    break
                if aabb[b, 1, ax1] < aabb[a, 0, ax1] or aabb[b, 0, ax1] > aabb[a, 1, ax1] \
                        or aabb[b, 1, ax2] < aabb[a, 0, ax2] or aabb[b, 0, ax2] > aabb[a, 1, ax2]:
                    continue
                body_b = shape_body[b]
                if body_b == body_a or not (moving_a or body_moving[body_b]):
                    continue
                # report in one column only: the one holding the overlap's lower corner
                if _cell(max(aabb[a, 0, ax1], aabb[b, 0, ax1]), lo1, size, n1) != c1 \
                        or _cell(max(aabb[a, 0, ax2], aabb[b, 0, ax2]), lo2, size, n2) != c2:
                    continue
                count = _emit(a, b, pair_a, pair_b, count)
    # big shapes against every shape (big pairs once: from the lower index)
    for k in range(n_big):
        a = big_list[k]
        for m in range(n):
            b = idx[m]
            if b == a or (big[b] and b < a):
                continue
            if shape_body[a] == shape_body[b] or not (body_moving[shape_body[a]] or body_moving[shape_body[b]]):
                continue
            if _overlap(aabb, a, b):
                count = _emit(a, b, pair_a, pair_b, count)
    if count > pair_a.shape[0]:
        return count
    # deterministic output order: by (a, b), whatever the axis and the grid were
    pkey = np.empty(count, dtype=np.int64)
    for k in range(count):
        pkey[k] = pair_a[k] * S + pair_b[k]
    rank = argsort_stable(pkey)  # the keys are unique: the same order as any sort
    for k in range(count):
        key = pkey[rank[k]]
        pair_a[k] = key // S
        pair_b[k] = key % S
    return count


@njit(**JIT)
def lane_bounds(aabb, shape_lane, out):
    """The boxes the broadphase sorts when bodies belong to envs (``filter.CollisionFilter.env``):
    ``aabb`` (S, 2, 3) m with each shape of env e > 0 (``shape_lane`` (S,) int64) moved along x by
    e lane widths (the span of all the finite boxes along x, plus 1 m), each finite shape of env 0
    (shared: a static ramp) stretched along x over every lane, and each shape of lane -1 (one that
    meets nothing: a link's marker) left out (no bounds), written to ``out`` (S, 2, 3).

    Why: copies of a robot placed in one spot (``tumble.envs``: each copy where the model puts it,
    so that it computes what it would alone) overlap each other, and a sweep over them tests every
    pair of copies: quadratic in their number (256 cheetahs: 2304 shapes in one column). In lanes
    a copy's shapes meet only their own and the shared ones. Only the pairs change, not the
    contacts: moving two bounds by the same number keeps their order (rounding is monotone), so
    every overlapping pair of one env still overlaps, and pairs of two envs are culled anyway
    (``filter_allows``). Shapes without bounds (planes) are left as they are: the narrowphase
    tests each plane against every shape."""
    S = aabb.shape[0]
    lo = np.inf
    hi = -np.inf
    top = 0
    for s in range(S):
        out[s] = aabb[s]
        if shape_lane[s] < 0:
            out[s, 0, 0] = np.inf  # the sweep skips a shape without finite bounds
            continue
        if np.isfinite(aabb[s, 0, 0]) and np.isfinite(aabb[s, 1, 0]):
            lo = min(lo, aabb[s, 0, 0])
            hi = max(hi, aabb[s, 1, 0])
            top = max(top, shape_lane[s])
    if not lo < np.inf:
        return
    width = hi - lo + 1.0
    for s in range(S):
        e = shape_lane[s]
        if e < 0 or not (np.isfinite(aabb[s, 0, 0]) and np.isfinite(aabb[s, 1, 0])):
            continue
        if e > 0:
            out[s, 0, 0] = aabb[s, 0, 0] + e * width
            out[s, 1, 0] = aabb[s, 1, 0] + e * width
        else:
            out[s, 0, 0] = lo - 1.0
            out[s, 1, 0] = hi + (top + 1) * width


@njit(**JIT)
def keep_overlapping(pair_a, pair_b, aabb):
    """Compact the pairs (P,) in place to those whose true boxes ``aabb`` (S, 2, 3) overlap (a
    shared shape stretched over the lanes by ``lane_bounds`` pairs with every copy beside it);
    returns how many are kept, in their order."""
    kept = 0
    for k in range(pair_a.shape[0]):
        if _overlap(aabb, pair_a[k], pair_b[k]):
            pair_a[kept] = pair_a[k]
            pair_b[kept] = pair_b[k]
            kept += 1
    return kept


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
    """Pairs of shapes whose AABBs overlap (sort-and-sweep along the axis of largest variance,
    in the columns of a grid over the two other axes).

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
