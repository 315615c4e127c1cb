"""What a body looks like: one triangle mesh per shape, and the body colours.

Shared by every way tumble shows a run (glTF and USD export, video, the
browser viewer), so that a body looks the same everywhere. Meshes are in the
*shape's* frame; the caller shifts them by ``-com_offset`` into the body frame
(origin at the centre of mass), where ``p_world = R(q) p_body + position``
puts the mesh where the user put the shape (DESIGN.md, conventions).
"""

from __future__ import annotations

import json

import numpy as np

# Tessellation: fine enough to look round at a metre's distance, small enough for thousands of bodies
# (geometry is shared between bodies whose shape and centre-of-mass offset are the same).
SPHERE_SUBDIVISIONS = 3         # icosphere: 642 vertices
SECTIONS = 48                   # around cylinders, capsules and cones
PARTICLE_SUBDIVISIONS = 2       # icosphere per particle: 162 vertices (1 when there are many points)
SHARP_ANGLE_DEG = 30.0          # faces meeting at more than this get separate vertex normals
PLANE_MIN_SIZE = 20.0           # m, side of the quad drawn for a plane (more if the bodies travel further)
MARKER_RADIUS = 0.05            # m, sphere drawn for a body whose shape is unknown (trajectories without shapes)

# Body colours (sRGB, 0-255), in turn by body: bright and distinct on a light ground
# and in a dark viewer (after Trubetskoy's "20 distinct colours"); fixed bodies grey.
PALETTE = (
    (66, 135, 245), (245, 130, 48), (60, 180, 75), (230, 25, 75), (145, 30, 180),
    (70, 200, 200), (240, 50, 230), (170, 110, 40), (128, 128, 0),
)
FIXED_COLOR = (154, 154, 154)


def body_color(index: int, fixed: bool = False) -> tuple[int, int, int]:
    """sRGB colour (0-255) of body ``index``: the palette in turn, grey when fixed."""
    return FIXED_COLOR if fixed else PALETTE[index % len(PALETTE)]


def palette_colors(fixed) -> np.ndarray:
    """(N, 3) uint8 sRGB colour of each body from ``fixed`` (N,) bool: ``body_color(i, fixed[i])``
    for every body, i.e. the palette in turn over *all* bodies (a fixed one uses up its turn) and
    fixed bodies grey. The one rule of every view (glTF, USD, HTML, video, camera images, viewer),
    so that body i has the same colour in each whatever bodies come before it."""
    fixed = np.asarray(fixed, dtype=bool).reshape(-1)
    palette = np.array(PALETTE, dtype=np.uint8)
    out = palette[np.arange(len(fixed)) % len(PALETTE)].reshape(len(fixed), 3)
    out[fixed] = FIXED_COLOR
    return out


def shape_dict(shape) -> dict | None:
    """A shape as its ``shapes.shape_to_dict`` mapping (accepts a record, a mapping, JSON text or None)."""
    if shape is None or isinstance(shape, dict):
        return shape
    if isinstance(shape, (str, np.str_)):
        return json.loads(str(shape))
    from .shapes import shape_to_dict

    return shape_to_dict(shape)


def shape_trimesh(shape, plane_size: float = PLANE_MIN_SIZE, sections: int = SECTIONS,
                  subdivisions: int = SPHERE_SUBDIVISIONS):
    """A ``trimesh.Trimesh`` of ``shape`` in its own frame (metres).

    ``shape`` is a record of ``tumble.shapes``, its ``shape_to_dict`` mapping, or
    None (a small marker sphere). A plane becomes a square of side
    ``plane_size`` centred at the plane's point nearest the origin. ``sections`` (round shapes'
    segments) and ``subdivisions`` (icosphere levels of spheres and ellipsoids): the drawing's by
    default; finer for buoyancy's submerged volumes (tumble.buoyancy).
    """
    import trimesh
    import trimesh.creation as create

    d = shape_dict(shape)
    if d is None:
        return create.icosphere(subdivisions=2, radius=MARKER_RADIUS)
    kind = d["type"]
    if kind == "sphere":
        return create.icosphere(subdivisions=subdivisions, radius=float(d["radius"]))
    if kind == "box":
        return create.box(extents=np.asarray(d["size"], dtype=float))
    if kind == "cylinder":
        return create.cylinder(radius=float(d["radius"]), height=float(d["length"]), sections=sections)
    if kind == "capsule":  # trimesh's height is the distance between the hemisphere centres, as ours
        return create.capsule(height=float(d["length"]), radius=float(d["radius"]), count=[sections, sections // 2])
    if kind == "ellipsoid":  # the sphere's mesh, its vertices scaled by the semi-axes
        mesh = create.icosphere(subdivisions=subdivisions, radius=1.0)
        return trimesh.Trimesh(mesh.vertices * np.asarray(d["radii"], dtype=float), mesh.faces, process=False)
    if kind == "cone":  # base disc on z = 0 centred on the origin, apex at z = height: as tumble.shapes.Cone
        return create.cone(radius=float(d["radius"]), height=float(d["height"]), sections=sections)
    if kind in ("mesh", "convex"):
        return trimesh.Trimesh(np.asarray(d["vertices"], dtype=float), np.asarray(d["faces"], dtype=np.int64), process=False)
    if kind == "particles":
        return _particle_cloud(np.asarray(d["points"], dtype=float), np.asarray(d["masses"], dtype=float))
    if kind == "plane":
        return _plane_quad(np.asarray(d.get("normal", (0, 0, 1)), dtype=float), float(d.get("offset", 0.0)), plane_size)
    if kind == "compound" and d.get("source") is not None:  # cut from a concave mesh: draw the mesh, not its pieces
        return shape_trimesh(d["source"], plane_size, sections, subdivisions)
    if kind == "compound":  # the parts' meshes, each moved to its place in the shape's frame
        from .math3d import quat_to_matrix

        meshes = []
        for part in d["parts"]:
            mesh = shape_trimesh(part["shape"], plane_size, sections, subdivisions).copy()
            T = np.eye(4)
            T[:3, :3] = quat_to_matrix(np.asarray(part.get("orientation", (1, 0, 0, 0)), dtype=float))
            T[:3, 3] = np.asarray(part.get("position", (0, 0, 0)), dtype=float)
            mesh.apply_transform(T)
            meshes.append(mesh)
        return trimesh.util.concatenate(meshes)
    raise ValueError(f"unknown shape type {kind!r}")


def _particle_cloud(points: np.ndarray, masses: np.ndarray):
    """One small sphere per point mass, volume proportional to its mass; the heaviest is
    0.35 x the smallest distance between two points across (so no two spheres touch)."""
    import trimesh
    import trimesh.creation as create

    if len(points) > 1:
        from scipy.spatial import cKDTree

        nearest = float(cKDTree(points).query(points, k=2)[0][:, 1].min())  # smallest distance between two points
        extent = float(np.ptp(points, axis=0).max())
        r_max = 0.35 * nearest if nearest > 0 else 0.02 * max(extent, 1.0)
    else:
        r_max = MARKER_RADIUS
    radii = r_max * np.cbrt(masses / masses.max())
    unit = create.icosphere(subdivisions=PARTICLE_SUBDIVISIONS if len(points) <= 500 else 1, radius=1.0)
    nv = len(unit.vertices)
    vertices = (unit.vertices[None, :, :] * radii[:, None, None] + points[:, None, :]).reshape(-1, 3)
    faces = (unit.faces[None, :, :] + nv * np.arange(len(points))[:, None, None]).reshape(-1, 3)
    return trimesh.Trimesh(vertices, faces, process=False)


def _plane_quad(normal: np.ndarray, offset: float, size: float):
    import trimesh

    n = normal / np.linalg.norm(normal)
    centre = n * offset  # the point of {n . p = offset} nearest the origin
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(helper, n)
    u /= np.linalg.norm(u)
    v = np.cross(n, u)  # u x v = n: the quad faces along the normal
    h = 0.5 * size
    corners = np.array([centre - h * u - h * v, centre + h * u - h * v, centre + h * u + h * v, centre - h * u + h * v])
    return trimesh.Trimesh(corners, np.array([[0, 1, 2], [0, 2, 3]]), process=False)
