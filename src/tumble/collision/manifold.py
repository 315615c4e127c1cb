"""Contact manifolds as arrays (written by ``collide_pairs``), and ``match_contacts`` for warm starting.

A manifold is one shape pair's contact (1 to 4 points sharing a normal); a contact
is one point. Both are stored flat, in pair order, in buffers that grow by doubling.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..math3d import JIT

from .constants import MAX_MANIFOLD_POINTS

# contact_key = (shape_a << 42) | (shape_b << 21) | feature: shapes and features below 2**21
KEY_BITS = 21

_MANIFOLD_ARRAYS = {
    "manifold_shape_a": ((), np.int64), "manifold_shape_b": ((), np.int64),
    "manifold_body_a": ((), np.int64), "manifold_body_b": ((), np.int64),
    "manifold_normal": ((3,), np.float64), "manifold_first": ((), np.int64), "manifold_point_count": ((), np.int64),
}
_CONTACT_ARRAYS = {
    "contact_manifold": ((), np.int64), "contact_body_a": ((), np.int64), "contact_body_b": ((), np.int64),
    "contact_point": ((3,), np.float64), "contact_normal": ((3,), np.float64),
    "contact_separation": ((), np.float64), "contact_feature": ((), np.int64), "contact_key": ((), np.int64),
}


class ContactManifolds:
    """The narrowphase's output. Each attribute below is a view of the first ``manifold_count``
    or ``contact_count`` rows of a buffer (views change when the buffers grow: read them after
    ``collide_pairs``, not before).

    Per manifold (M = ``manifold_count``):
        manifold_shape_a, manifold_shape_b: (M,) int64 shape indices; a's type <= b's type
            in SHAPE_* order (equal types: a < b), so a pair keeps its order from step to step.
        manifold_body_a, manifold_body_b: (M,) int64 their bodies.
        manifold_normal: (M, 3) unit, world, from a to b (against a mesh: its points'
            normals' weighted mean).
        manifold_first, manifold_point_count: (M,) int64, its contacts are rows
            ``first : first + point_count`` (1 to 4).

    Per contact point (C = ``contact_count``):
        contact_manifold: (C,) int64 manifold row.
        contact_body_a, contact_body_b: (C,) int64.
        contact_point: (C, 3) m, world, midway between the two surfaces.
        contact_normal: (C, 3) unit, world, from a to b: the manifold's normal, or, against
            a triangle mesh, the point's own triangle's (a manifold across a crease has two).
        contact_separation: (C,) m, signed gap along the normal; < 0 is penetration.
            Contacts exist while it is below the speculative distance.
        contact_feature: (C,) int64, the touching features, local to the shape pair.
        contact_key: (C,) int64 ``(shape_a << 42) | (shape_b << 21) | feature``: the same
            while the same features of the same shapes touch (warm starting).
    """

    # the contacts given an allowance by the last ``delay_speculative_ghosts`` (collision/speculative.py)
    allowance_count = 0

    def __init__(self, manifold_capacity: int = 64):
        self.manifold_count = 0
        self.contact_count = 0
        self._m_capacity = 0
        self._c_capacity = 0
        self._buffers: dict[str, np.ndarray] = {}
        self.reserve(manifold_capacity)

    def reserve(self, manifolds: int):
        """Room for ``manifolds`` manifolds and 4 points each (capacity doubles until it fits)."""
        m_cap = max(self._m_capacity, 1)
        while m_cap < manifolds:
            m_cap *= 2
        c_cap = MAX_MANIFOLD_POINTS * m_cap
        if m_cap != self._m_capacity:
            for name, (shape, dtype) in _MANIFOLD_ARRAYS.items():
                self._buffers[name] = np.zeros((m_cap,) + shape, dtype=dtype)
            self._m_capacity = m_cap
        if c_cap != self._c_capacity:
            for name, (shape, dtype) in _CONTACT_ARRAYS.items():
                self._buffers[name] = np.zeros((c_cap,) + shape, dtype=dtype)
            self._c_capacity = c_cap
        self.manifold_count = min(self.manifold_count, m_cap)
        self.contact_count = min(self.contact_count, c_cap)

    def candidates(self, total: int):
        """Per-candidate-pair scratch rows for the parallel narrowphase (grown by doubling, kept):
        (a, b, count, normal, points, separations, features, point normals), the first ``total``
        rows of each."""
        cap = self.__dict__.get("_cand_capacity", 0)
        if cap < total or cap == 0:
            cap = max(cap, 64)
            while cap < total:
                cap *= 2
            P = MAX_MANIFOLD_POINTS
            self._cand = (np.zeros(cap, dtype=np.int64), np.zeros(cap, dtype=np.int64), np.zeros(cap, dtype=np.int64),
                          np.zeros((cap, 3)), np.zeros((cap, P, 3)), np.zeros((cap, P)),
                          np.zeros((cap, P), dtype=np.int64), np.zeros((cap, P, 3)))
            self._cand_capacity = cap
        return tuple(a[:total] for a in self._cand)

    def buffers(self):
        """The full buffers in the kernel's argument order (manifold arrays, then contact arrays)."""
        return tuple(self._buffers[name] for name in (*_MANIFOLD_ARRAYS, *_CONTACT_ARRAYS))

    # PERF: the arrays are read as attributes (the first ``manifold_count`` or ``contact_count`` rows);
    # views kept in the instance and renewed when a count is set (``reserve`` sets both after it
    # grows the buffers), rather than built on each read by ``__getattr__`` (50 reads a step).
    @property
    def manifold_count(self) -> int:
        return self._manifold_count

    # PERF: a count set again to its value over the same buffers keeps its views (a box on a plane set
    # each count twice a step, 15 views each time: 4 renewals of 2.3 us a step, all of the same rows);
    # the buffers are replaced only when a capacity changes, which ``reserve`` records in the key
    @manifold_count.setter
    def manifold_count(self, n: int):
        d = self.__dict__
        key = (n, d.get("_m_capacity"))
        if d.get("_manifold_views") == key:
            return
        self._manifold_count = n
        self._refresh_views(_MANIFOLD_ARRAYS, n)
        d["_manifold_views"] = key

    @property
    def contact_count(self) -> int:
        return self._contact_count

    @contact_count.setter
    def contact_count(self, n: int):
        d = self.__dict__
        key = (n, d.get("_c_capacity"))
        if d.get("_contact_views") == key:
            return
        self._contact_count = n
        self._refresh_views(_CONTACT_ARRAYS, n)
        d["_contact_views"] = key

    def __setstate__(self, state):
        # a pickled or deep-copied view is an array of its own: made again from the buffers (the
        # count setters keep views while a count stays, so a copy's must be its buffers')
        self.__dict__.update(state)
        self._refresh_views(_MANIFOLD_ARRAYS, self._manifold_count)
        self._refresh_views(_CONTACT_ARRAYS, self._contact_count)

    def _refresh_views(self, names, n: int):
        d = self.__dict__
        buffers = d.get("_buffers", {})
        for name in names:
            if name in buffers:
                d[name] = buffers[name][:n]

    def __getattr__(self, name):
        buffers = self.__dict__.get("_buffers", {})
        if name in _MANIFOLD_ARRAYS:
            return buffers[name][: self.manifold_count]
        if name in _CONTACT_ARRAYS:
            return buffers[name][: self.contact_count]
        raise AttributeError(name)

    def __len__(self):
        return self.contact_count

    def allowance_buffer(self) -> np.ndarray:
        """The buffer ``delay_speculative_ghosts`` writes (one row per contact of the capacity)."""
        buf = self.__dict__.get("_allowance")
        if buf is None or buf.shape[0] != self._c_capacity:
            buf = self._allowance = np.zeros(self._c_capacity)
        return buf

    @property
    def contact_allowance(self) -> np.ndarray:
        """(C,) m: the gap beyond ``contact_separation`` the solver lets each contact close before it
        holds (collision/speculative.py: a speculative contact whose shape a sweep shows touching
        later than its linear gap says); zeros but after ``delay_speculative_ghosts`` gave some."""
        if not self.allowance_count:
            return np.zeros(self.contact_count)
        return self._allowance[: self.contact_count]


def match_contacts(old_key, new_key) -> np.ndarray:
    """For each new contact, the row of the old contact with the same key, or -1.

    The solver carries last step's impulses over by this map (warm starting).

    Args:
        old_key: (C_old,) int64 ``contact_key`` of the previous step.
        new_key: (C_new,) int64 ``contact_key`` of this step.

    Returns:
        (C_new,) int64 row of ``old_key`` or -1.
    """
    old_key = np.ascontiguousarray(old_key, dtype=np.int64)
    new_key = np.ascontiguousarray(new_key, dtype=np.int64)
    out = np.full(len(new_key), -1, dtype=np.int64)
    if len(old_key) == 0 or len(new_key) == 0:
        return out
    # PERF: contacts come in pair order, the same from step to step while nothing changes: then
    # every key sits in the same row as last step and no sort is needed.
    if _match_in_place_kernel(old_key, new_key, out):
        return out
    # PERF: a hash table of the old keys, O(C); an argsort and searchsorted took 3.5 ms a step
    # of the large pyramid (60 000 contacts), this 0.5 ms. Same map (keys are unique).
    size = 1
    while size < 2 * len(old_key):
        size *= 2
    _match_hashed_kernel(old_key, new_key, np.full(size, -1, dtype=np.int64), out)
    return out


@njit(**JIT)
def _key_hash(key, mask):
    """Slot of ``key`` in a table of mask + 1 slots: the key's bits mixed (splitmix64's finaliser)."""
    z = np.uint64(key)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return np.int64(z & np.uint64(mask))


@njit(**JIT)
def _match_hashed_kernel(old_key, new_key, table, out):
    """out[c] = the row of old_key equal to new_key[c], or -1, through ``table`` (a power of two
    of slots, all -1, at least twice the old keys: open addressing, linear probing)."""
    mask = table.shape[0] - 1
    for i in range(old_key.shape[0]):
        h = _key_hash(old_key[i], mask)
        while table[h] >= 0:
            h = (h + 1) & mask
        table[h] = i
    for c in range(new_key.shape[0]):
        key = new_key[c]
        h = _key_hash(key, mask)
        out[c] = -1
        while table[h] >= 0:
            if old_key[table[h]] == key:
                out[c] = table[h]
                break
            h = (h + 1) & mask


@njit(**JIT)
def _match_in_place_kernel(old_key, new_key, out):
    """out[c] = c while old_key[c] == new_key[c]; True when that held for every new key (all
    matched), False at the first that differs (the caller then searches them all). Keys are
    unique within a step, so an equal key is the match."""
    if old_key.shape[0] < new_key.shape[0]:
        return False
    for c in range(new_key.shape[0]):
        if old_key[c] != new_key[c]:
            return False
        out[c] = c
    return True
