"""Display meshes of shape records (``tumble.shapes``), tessellated with ``trimesh.creation``,
and the batched groups the viewer draws them in (``MeshGroup``, ``linear_colors``).

Each mesh is in the shape's own frame (the frame the user wrote the shape in).
``body_mesh`` moves it into the body frame (origin at the centre of mass) by
subtracting the trajectory's ``com_offset``, so that a body posed at its
centre of mass ``x`` with rotation ``R`` draws the mesh where the user put it:
``p_world = R (p_shape - com_offset) + x`` (DESIGN.md).
"""

from __future__ import annotations

import dataclasses
import hashlib

import numpy as np
import trimesh

from .. import visual
from ..shapes import Plane


def shape_mesh(shape) -> trimesh.Trimesh | None:
    """A closed triangle mesh of ``shape`` in its own frame (``tumble.visual.shape_trimesh``),
    or None for planes (the viewer draws the ground grid instead) and missing shapes."""
    if shape is None or isinstance(shape, Plane):
        return None
    return visual.shape_trimesh(shape)


def body_mesh(shape, com_offset) -> tuple[np.ndarray, np.ndarray] | None:
    """(vertices, faces) of ``shape`` in the body frame: the shape's mesh shifted by ``-com_offset``."""
    mesh = shape_mesh(shape)
    if mesh is None:
        return None
    vertices = np.asarray(mesh.vertices, dtype=float) - np.asarray(com_offset, dtype=float).reshape(1, 3)
    return vertices, np.asarray(mesh.faces, dtype=np.int64)


def mesh_key(vertices, faces) -> bytes:
    """A 16-byte digest of a mesh's arrays: equal for meshes that draw the same.

    ``vertices`` (V, 3) are hashed as float64 and ``faces`` (F, 3) as int64, with
    their shapes, so that the viewer can draw all bodies of one key as instances
    of one mesh. Records that differ but tessellate alike (the same box written
    twice) get the same key; equal shapes with different ``com_offset`` do not.
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    h = hashlib.blake2b(digest_size=16)
    h.update(np.asarray(v.shape + f.shape, dtype=np.int64).tobytes())
    h.update(v.tobytes())
    h.update(f.tobytes())
    return h.digest()



def linear_colors(colors) -> np.ndarray:
    """sRGB colours (..., 3), 0-255, as the linear-light values (uint8, 0-255) batched meshes are sent.

    viser 1.1.1's client reads ``batched_colors`` with ``THREE.Color.setRGB``, i.e. as
    linear values, while a single mesh's ``color`` is read as sRGB: sent as they are,
    the palette would come out paler than in the other views (and than before instancing).
    """
    c = np.asarray(colors, dtype=float) / 255.0
    linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return np.round(255.0 * linear).astype(np.uint8)


@dataclasses.dataclass
class MeshGroup:
    """Bodies drawn by one batched mesh node: they have the same mesh in the body frame.

    Attributes:
        handle: the viser ``BatchedMeshHandle``; row j of its ``batched_positions``
            (M, 3, world, m), ``batched_wxyzs`` (M, 4, body to world) and
            ``batched_colors`` (M, 3, linear 0-255: ``linear_colors``) is body ``bodies[j]``;
            ``batched_scales`` (M,) is None until some body of the group is hidden (disabled:
            ``World.set_enabled``), then 1 for a body drawn and 0 for one hidden.
        bodies: (M,) body indices, increasing.
        static: True if every body of the group keeps its pose over the whole run
            (the group is posed once, never updated per frame).
        colors: (M, 3) uint8, the sRGB colours the bodies are drawn in now (the selected
            body's row is the highlight).
    """

    handle: object
    bodies: np.ndarray
    static: bool
    colors: np.ndarray
    rows: object = None  # bodies as a slice when they are consecutive (a view, no copy, per frame)


__all__ = ["MeshGroup", "body_mesh", "linear_colors", "mesh_key", "shape_mesh"]
