"""Collision shapes as flat arrays: ``ShapeTable`` and ``build_shape_table(world)``.

Reads a World's shape records and ``com_offset``; writes nothing else. One shape per
body for now; ``shape_body`` lets compound bodies add more rows later.

Supported: plane, sphere, capsule, box. Cylinder, cone, convex, mesh and particles
raise ``NotImplementedError`` naming the type and body (or are left without a
collision shape with ``skip_unsupported=True``) until their pair routines exist.

``shape_params`` (S, 4), in the shape's own frame, metres:

=========  ===================================================
plane      (nx, ny, nz, offset): the plane n . p = offset, n unit
sphere     (radius, 0, 0, 0)
capsule    (radius, half_length, 0, 0): segment from -h z to +h z
box        (hx, hy, hz, 0): half extents
=========  ===================================================
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..shapes import (
    SHAPE_BOX,
    SHAPE_CAPSULE,
    SHAPE_CONE,
    SHAPE_CONVEX,
    SHAPE_CYLINDER,
    SHAPE_MESH,
    SHAPE_PARTICLES,
    SHAPE_PLANE,
    SHAPE_SPHERE,
    Box,
    Capsule,
    Plane,
    Sphere,
)

SHAPE_NAMES = {
    SHAPE_PLANE: "plane", SHAPE_SPHERE: "sphere", SHAPE_CAPSULE: "capsule", SHAPE_CYLINDER: "cylinder",
    SHAPE_CONE: "cone", SHAPE_BOX: "box", SHAPE_CONVEX: "convex", SHAPE_MESH: "mesh", SHAPE_PARTICLES: "particles",
}
SUPPORTED_TYPES = (SHAPE_PLANE, SHAPE_SPHERE, SHAPE_CAPSULE, SHAPE_BOX)


@dataclass
class ShapeTable:
    """Every collision shape of a World, one row each (constants: they change only when bodies are added).

    Attributes:
        shape_type: (S,) int64, ``SHAPE_*`` id of ``tumble.shapes``.
        shape_body: (S,) int64, index of the body the shape belongs to.
        shape_params: (S, 4) float, see the module docstring; metres.
        shape_local_pos: (S, 3) m, the shape origin in the body frame (``-com_offset``).
        shape_local_q: (S, 4) (w, x, y, z), shape frame to body frame (identity for primitives).
        body_moving: (N,) bool, a copy of ``World.moving`` (False for fixed bodies).
    """

    shape_type: np.ndarray
    shape_body: np.ndarray
    shape_params: np.ndarray
    shape_local_pos: np.ndarray
    shape_local_q: np.ndarray
    body_moving: np.ndarray

    @property
    def shape_count(self) -> int:
        return len(self.shape_type)

    @property
    def body_count(self) -> int:
        return len(self.body_moving)


def shape_params(shape) -> tuple[int, tuple[float, float, float, float]]:
    """``(SHAPE_* id, params (4,))`` of one shape record; NotImplementedError for types without collision yet."""
    if isinstance(shape, Plane):
        n = shape.normal
        return SHAPE_PLANE, (n[0], n[1], n[2], shape.offset)
    if isinstance(shape, Sphere):
        return SHAPE_SPHERE, (shape.radius, 0.0, 0.0, 0.0)
    if isinstance(shape, Capsule):
        return SHAPE_CAPSULE, (shape.radius, 0.5 * shape.length, 0.0, 0.0)
    if isinstance(shape, Box):
        h = shape.half_extents
        return SHAPE_BOX, (float(h[0]), float(h[1]), float(h[2]), 0.0)
    type_id = getattr(shape, "type_id", None)
    name = SHAPE_NAMES.get(type_id, type(shape).__name__)
    raise NotImplementedError(f"collision shape {name!r} is not supported yet (supported: plane, sphere, capsule, box)")


def build_shape_table(world, skip_unsupported: bool = False) -> ShapeTable:
    """The ``ShapeTable`` of ``world``: one row per body, in body order.

    Args:
        world: a ``tumble.World``.
        skip_unsupported: if True, bodies whose shape has no collision support yet
            get no row (they collide with nothing) instead of raising.

    Raises:
        NotImplementedError: a body's shape type has no collision support yet
            (message names the type and the body).
    """
    types, bodies, params, local_pos = [], [], [], []
    com_offset = np.asarray(world.com_offset)
    for i, shape in enumerate(world.shapes):
        try:
            type_id, p = shape_params(shape)
        except NotImplementedError as err:
            if skip_unsupported:
                continue
            raise NotImplementedError(f"body {world.names[i]!r}: {err}") from None
        types.append(type_id)
        bodies.append(i)
        params.append(p)
        local_pos.append(-com_offset[i])
    s = len(types)
    local_q = np.zeros((s, 4))
    local_q[:, 0] = 1.0
    return ShapeTable(
        shape_type=np.asarray(types, dtype=np.int64).reshape(s),
        shape_body=np.asarray(bodies, dtype=np.int64).reshape(s),
        shape_params=np.asarray(params, dtype=float).reshape(s, 4),
        shape_local_pos=np.asarray(local_pos, dtype=float).reshape(s, 3),
        shape_local_q=local_q,
        body_moving=np.array(world.moving, dtype=bool),
    )
