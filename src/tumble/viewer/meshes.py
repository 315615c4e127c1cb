"""Display meshes of shape records (``tumble.shapes``), tessellated with ``trimesh.creation``.

Each mesh is in the shape's own frame (the frame the user wrote the shape in).
``body_mesh`` moves it into the body frame (origin at the centre of mass) by
subtracting the trajectory's ``com_offset``, so that a body posed at its
centre of mass ``x`` with rotation ``R`` draws the mesh where the user put it:
``p_world = R (p_shape - com_offset) + x`` (DESIGN.md).
"""

from __future__ import annotations

import numpy as np
import trimesh

from ..shapes import Box, Capsule, Cone, Cylinder, Mesh, Particles, Plane, Sphere

SPHERE_SUBDIVISIONS = 3  # icosphere: 642 vertices
ROUND_SECTIONS = 48  # segments around cylinders, capsules and cones
MAX_PARTICLE_SPHERES = 4000  # beyond that, particles are drawn as a point cloud by the caller


def shape_mesh(shape) -> trimesh.Trimesh | None:
    """A closed triangle mesh of ``shape`` in its own frame, or None (planes, unknown shapes).

    Spheres, boxes, cylinders (along z, centred), capsules (``length`` between the
    hemisphere centres, along z, centred), cones (base disc at z = 0, apex at
    z = height), meshes and convex hulls (as given), particles (one small sphere
    per point, sized from the spacing of the points).
    """
    if isinstance(shape, Sphere):
        return trimesh.creation.icosphere(subdivisions=SPHERE_SUBDIVISIONS, radius=shape.radius)
    if isinstance(shape, Box):
        return trimesh.creation.box(extents=shape.size)
    if isinstance(shape, Cylinder):
        return trimesh.creation.cylinder(radius=shape.radius, height=shape.length, sections=ROUND_SECTIONS)
    if isinstance(shape, Capsule):
        return trimesh.creation.capsule(height=shape.length, radius=shape.radius, count=[ROUND_SECTIONS, ROUND_SECTIONS // 2])
    if isinstance(shape, Cone):
        return trimesh.creation.cone(radius=shape.radius, height=shape.height, sections=ROUND_SECTIONS)
    if isinstance(shape, Mesh):  # also Convex
        return trimesh.Trimesh(vertices=np.asarray(shape.vertices, float), faces=np.asarray(shape.faces), process=False)
    if isinstance(shape, Particles):
        return particle_spheres(shape.points)
    if isinstance(shape, Plane):
        return None
    return None


def particle_radius(points: np.ndarray) -> float:
    """Radius of the sphere drawn at each particle: a third of the typical nearest-neighbour distance."""
    pts = np.asarray(points, float)
    if len(pts) < 2:
        return 0.05
    sample = pts[:: max(1, len(pts) // 256)]
    d = np.linalg.norm(sample[:, None, :] - pts[None, :, :], axis=-1)
    d[d == 0.0] = np.inf
    nearest = d.min(axis=1)
    nearest = nearest[np.isfinite(nearest)]
    if len(nearest) == 0:
        return 0.05
    return float(np.median(nearest)) / 3.0


def particle_spheres(points: np.ndarray) -> trimesh.Trimesh | None:
    """One low-polygon sphere per point (None when there are too many points for that)."""
    pts = np.asarray(points, float)
    if len(pts) > MAX_PARTICLE_SPHERES:
        return None
    ball = trimesh.creation.icosphere(subdivisions=1, radius=particle_radius(pts))
    nv = len(ball.vertices)
    vertices = (ball.vertices[None, :, :] + pts[:, None, :]).reshape(-1, 3)
    faces = (ball.faces[None, :, :] + nv * np.arange(len(pts))[:, None, None]).reshape(-1, 3)
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)


def body_mesh(shape, com_offset) -> tuple[np.ndarray, np.ndarray] | None:
    """(vertices, faces) of ``shape`` in the body frame: the shape's mesh shifted by ``-com_offset``."""
    mesh = shape_mesh(shape)
    if mesh is None:
        return None
    vertices = np.asarray(mesh.vertices, dtype=float) - np.asarray(com_offset, dtype=float).reshape(1, 3)
    return vertices, np.asarray(mesh.faces, dtype=np.int64)


__all__ = ["body_mesh", "particle_radius", "particle_spheres", "shape_mesh"]
