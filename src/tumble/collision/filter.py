"""Collision filtering: which bodies may touch.

A user of any peer engine expects this: a ragdoll whose limbs pass through each other, debris
that hits the ground but not itself, a sensor-like layer that touches nothing. tumble takes
Box2D's filter (v3 ``b3Filter``/``b2Filter``: ``categoryBits``, ``maskBits``, ``groupIndex``;
PyBullet's ``collisionFilterGroup``/``collisionFilterMask`` are the same two bit sets) and
MuJoCo's ``<exclude body1 body2>`` (PyBullet's ``setCollisionFilterPair``) for single pairs:

- each body has a ``CollisionFilter``: ``category``, the bits the body *is*; ``mask``, the bits
  it collides *with*; ``group``, an integer;
- two bodies with the same non-zero ``group`` always collide when the group is positive and
  never when it is negative (a ragdoll's parts share a negative group);
- otherwise they collide when each one's category meets the other's mask:
  ``(a.category & b.mask) != 0 and (b.category & a.mask) != 0`` (Box2D's
  ``b2ShouldShapesCollide``; MuJoCo's contype/conaffinity rule is an *or* of the two, Box2D's
  and PyBullet's an *and*: tumble follows the two that most users know, and the *and* lets
  either side refuse);
- two bodies of different non-zero ``env`` never collide, whatever the other fields: the copies
  of a scene or robot sharing one world, each touching its own bodies and the shared ones of
  env 0 (the default: the floor), as Isaac Gym's per-environment collision groups and
  MuJoCo's batched worlds keep theirs apart (``tumble.envs``' vector environments); the
  broadphase keeps the envs in lanes of their own (``broadphase.lane_bounds``), so copies
  stacked in one place cost no more than copies side by side;
- a pair excluded by ``World.exclude_collision(a, b)`` never collides, whatever the filters;
- so neither does a joint's pair with ``collide_connected=False`` (``joints.jointed_body_pairs``).

The filter is per body (a compound's parts share it), as in PyBullet and MuJoCo's body
exclusions. Bits are 32 (category and mask from 0 to 0xFFFFFFFF); the default filter (category
1, mask all bits, group 0) collides with every default body.

Where it acts: the narrowphase's candidate test (``narrowphase._candidate_pair``), before any
pair routine runs, for the broadphase's pairs and for each plane against each shape alike. A
filtered pair has no contact, so it links no island and wakes no sleeper. A world whose bodies
all have the default filter passes an empty table and skips the test (the same bits as
before filters existed: golden hashes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ..errors import InputError, coerce_record
from ..math3d import JIT

ALL_CATEGORIES = 0xFFFFFFFF  # the 32 category bits
FILTER_KEYS = ("category", "mask", "group", "env")
_GROUP_LIMIT = 2 ** 31  # group in [-2^31, 2^31): Box2D's int32 groupIndex


def _int(value, key: str, low: int, high: int) -> int:
    # bool is an int in Python; a filter bit set of True is a mistake, not 1
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InputError(f"expected an integer, got {value!r}", key)
    v = int(value)
    if not low <= v <= high:
        top = f"{high:#x}" if key not in ("group", "env") else str(high)
        raise InputError(f"must be between {low} and {top}, got {v}", key)
    return v


@dataclass(frozen=True)
class CollisionFilter:
    """Which bodies a body collides with (Box2D's filter; module docstring).

    Args:
        category: int bit set, the layers this body belongs to (default 1: the first).
        mask: int bit set, the layers it collides with (default all 32).
        group: int; bodies of one positive group always collide, of one negative group never
            (default 0: no group, the bits decide).
        env: int >= 0; bodies of two different non-zero envs never collide (default 0: shared
            by every env, the bits and group decide).
    """

    category: int = 1
    mask: int = ALL_CATEGORIES
    group: int = 0
    env: int = 0

    def __post_init__(self):
        object.__setattr__(self, "category", _int(self.category, "category", 0, ALL_CATEGORIES))
        object.__setattr__(self, "mask", _int(self.mask, "mask", 0, ALL_CATEGORIES))
        object.__setattr__(self, "group", _int(self.group, "group", -_GROUP_LIMIT, _GROUP_LIMIT - 1))
        object.__setattr__(self, "env", _int(self.env, "env", 0, _GROUP_LIMIT - 1))

    @classmethod
    def coerce(cls, value) -> "CollisionFilter":
        """``value`` as a filter: None (the default), a ``CollisionFilter``, or a mapping with
        the keys category, mask, group, env."""
        return coerce_record(cls, value, FILTER_KEYS, "collision_filter", DEFAULT_FILTER)

    def collides_with(self, other: "CollisionFilter") -> bool:
        """Box2D's rule and the envs' (module docstring): whether two bodies with these filters collide."""
        if self.env != other.env and self.env != 0 and other.env != 0:
            return False
        if self.group == other.group and self.group != 0:
            return self.group > 0
        return (self.category & other.mask) != 0 and (other.category & self.mask) != 0


DEFAULT_FILTER = CollisionFilter()
# the filter a disabled body's rows take in the collision pipeline and the queries
# (``World.set_enabled``): no category and no mask, no group: it meets no other filter
NOTHING_FILTER = CollisionFilter(category=0, mask=0)
FILTER_COLUMNS = 4  # category, mask, group, env
NO_FILTER = np.zeros((0, FILTER_COLUMNS), dtype=np.int64)


def filter_table(filters) -> np.ndarray:
    """(N, 4) int64 rows (category, mask, group, env) of the bodies' filters, or a (0, 4) table
    when every body has the default filter (then the narrowphase skips the test)."""
    if all(f == DEFAULT_FILTER for f in filters):
        return NO_FILTER
    return np.array([(f.category, f.mask, f.group, f.env) for f in filters],
                    dtype=np.int64).reshape(-1, FILTER_COLUMNS)


def live_filters(body_filter: np.ndarray) -> np.ndarray:
    """(N,) bool per row of ``filter_table`` (N, 4): whether the body's filter meets some other
    body's (``filter_allows``). Decided over the distinct rows (a world has few, or one per env
    when copies share it: the rule is then taken over the distinct (category, mask, group) and
    the envs apart), all pairs of them at once; a row meets itself only when two bodies hold it."""
    rows, inverse, counts = np.unique(body_filter, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    bits_rows, kind = np.unique(rows[:, :3], axis=0, return_inverse=True)
    kind = kind.ravel()
    cat, mask, group = bits_rows[:, 0], bits_rows[:, 1], bits_rows[:, 2]
    same_group = (group[:, None] == group[None, :]) & (group[:, None] != 0)
    bits = ((cat[:, None] & mask[None, :]) != 0) & ((cat[None, :] & mask[:, None]) != 0)
    kinds_allow = np.where(same_group, group[:, None] > 0, bits)  # (K, K) over the distinct bit rows
    env = rows[:, 3]
    live = np.zeros(len(rows), dtype=bool)
    # a row meets: a row of its own env or of env 0 (any row when it is env 0) whose bits allow it
    shared = env == 0
    for e in np.unique(env):
        mine = env == e
        others = np.ones(len(rows), dtype=bool) if e == 0 else (mine | shared)
        allow = kinds_allow[np.ix_(kind[mine], kind[others])]
        idx_mine, idx_others = np.flatnonzero(mine), np.flatnonzero(others)
        allow &= (idx_mine[:, None] != idx_others[None, :]) | (counts[idx_mine] > 1)[:, None]
        live[mine] = allow.any(axis=1)
    return live[inverse]


def exclusion_keys(pairs, body_count: int) -> np.ndarray:
    """Sorted unique (K,) int64 keys lo * N + hi of the body index pairs ``pairs``."""
    keys = [min(a, b) * body_count + max(a, b) for a, b in pairs]
    return np.unique(np.array(keys, dtype=np.int64))


@njit(**JIT, inline="always")
def filter_allows(body_filter, ba, bb):
    """Box2D's rule and the envs' on rows ``ba``, ``bb`` of ``filter_table`` (an empty table allows all)."""
    if body_filter.shape[0] == 0:
        return True
    ea = body_filter[ba, 3]
    eb = body_filter[bb, 3]
    if ea != eb and ea != 0 and eb != 0:
        return False
    ga = body_filter[ba, 2]
    if ga != 0 and ga == body_filter[bb, 2]:
        return ga > 0
    return (body_filter[ba, 0] & body_filter[bb, 1]) != 0 and (body_filter[bb, 0] & body_filter[ba, 1]) != 0
