"""Display meshes of shape records (``tumble.shapes``), tessellated with ``trimesh.creation``.

Each mesh is in the shape's own frame (the frame the user wrote the shape in).
``body_mesh`` moves it into the body frame (origin at the centre of mass) by
subtracting the trajectory's ``com_offset``, so that a body posed at its
centre of mass ``x`` with rotation ``R`` draws the mesh where the user put it:
``p_world = R (p_shape - com_offset) + x`` (DESIGN.md).
"""

from __future__ import annotations

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


__all__ = ["body_mesh", "mesh_key", "shape_mesh"]
