"""Area queries: which bodies may be inside an axis-aligned box (Box2D's ``b2World_OverlapAABB``,
PyBullet's ``getOverlappingObjects``).

A body is returned when the bounding box of one of its shapes, at the bodies' current poses,
overlaps the query box: the boxes the broadphase uses (``bounds.update_bounds`` without margin:
exact for spheres, boxes, capsules and cylinders, the local box's rotation for hulls and
meshes, a cylinder around a cone), so a body returned may still miss the query box by the
slack of its bounding box, as in Box2D ("shapes that potentially overlap"). A plane is solid
below it: it is returned when some corner of the query box is on or below it. Bodies whose
collision category does not meet ``mask``, or whose mask does not meet ``category``, are not
returned (a query filter, as ray casts); nor are sensors.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..shapes import SHAPE_PLANE
from .bounds import update_bounds
from .filter import ALL_CATEGORIES


def _corner(name: str, value) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.shape != (3,):
        raise InputError(f"must be a 3-vector, got shape {a.shape}", name)
    if not np.all(np.isfinite(a)):
        raise InputError("must be finite", name)
    return a


def overlap_aabb(world, lower, upper, mask=ALL_CATEGORIES, category=ALL_CATEGORIES) -> np.ndarray:
    """Sorted (K,) int64 indices of the bodies with a shape whose bounding box overlaps the box
    ``lower`` .. ``upper`` ((3,) m, world; touching counts), among those whose collision
    category meets ``mask`` and whose mask meets ``category`` (module docstring)."""
    from .raycast import _seen, kept_scene

    lo = _corner("lower", lower)
    hi = _corner("upper", upper)
    if np.any(lo > hi):
        raise InputError(f"must be >= lower on every axis, got {hi.tolist()} below {lo.tolist()}", "upper")
    seen = _seen(world, mask, category)
    table = kept_scene(world).table  # the shape table the ray casts keep

    if table.shape_count == 0:
        return np.zeros(0, dtype=np.int64)
    pos, rot, aabb = update_bounds(np.asarray(world.x), np.asarray(world.R), table, 0.0)
    hit = np.all(aabb[:, 0] <= hi, axis=1) & np.all(aabb[:, 1] >= lo, axis=1)
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    for s in np.flatnonzero(table.shape_type == SHAPE_PLANE):
        # n . p <= d below the plane (collision.narrowphase: the same normal and offset)
        p = table.shape_params[s]
        n = rot[s] @ p[:3]
        d = p[3] + n @ pos[s]
        hit[s] = n @ centre - np.abs(n) @ half <= d
    bodies = table.shape_body[hit]
    return np.unique(bodies[seen[bodies]]).astype(np.int64)
