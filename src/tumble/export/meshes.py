"""Visual triangle meshes of the bodies, in each body's frame, for export and display.

Every shape of ``tumble.shapes`` becomes a closed triangle mesh (a plane
becomes a large finite quad) in the *shape's* frame; ``body_meshes`` then
shifts it by ``-com_offset`` into the *body* frame, whose origin is the centre
of mass (DESIGN.md, conventions). A body's world pose is then simply
``p_world = R(q) p_body + position``, with ``position`` and ``q`` straight from
the trajectory, and the mesh appears where the user put the shape.

Shading: vertices are split where neighbouring faces meet at more than
``SHARP_ANGLE_DEG`` (box edges, cylinder rims), and kept shared elsewhere, so
spheres look round and boxes look sharp with one normal per vertex.

Colours: ``body_color`` picks from a fixed palette by body index (sRGB, the
numbers a colour picker shows); fixed bodies are grey. ``srgb_to_linear``
converts for formats whose colour factors are linear (glTF, USD).
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

# Tessellation: fine enough to look round at a metre's distance, small enough for thousands of bodies
# (geometry is shared between bodies whose shape and centre-of-mass offset are the same).
SPHERE_SUBDIVISIONS = 3         # icosphere: 642 vertices
SECTIONS = 48                   # around cylinders, capsules and cones
PARTICLE_SUBDIVISIONS = 2       # icosphere per particle: 162 vertices (1 when there are many points)
SHARP_ANGLE_DEG = 30.0          # faces meeting at more than this get separate vertex normals
PLANE_MIN_SIZE = 20.0           # m, side of the quad drawn for a plane (more if the bodies travel further)
MARKER_RADIUS = 0.05            # m, sphere drawn for a body whose shape is unknown (trajectories without shapes)

# Tableau 10 without its grey (sRGB): distinct, pleasant, and readable on white and black.
PALETTE = (
    "#4E79A7", "#F28E2B", "#E15759", "#76B7B2", "#59A14F",
    "#EDC948", "#B07AA1", "#FF9DA7", "#9C755F",
)
FIXED_COLOR = "#9A9A9A"


@dataclass
class VisualMesh:
    """A triangle mesh ready for export.

    Attributes:
        vertices: (V, 3) float64, m, body frame (origin at the centre of mass).
        normals: (V, 3) float64 unit vertex normals.
        faces: (T, 3) int64 vertex indices, counter-clockwise seen from outside.
        double_sided: True for open surfaces (the plane's quad).
    """

    vertices: np.ndarray
    normals: np.ndarray
    faces: np.ndarray
    double_sided: bool = False


def hex_to_rgb(text: str) -> tuple[float, float, float]:
    text = text.lstrip("#")
    return tuple(int(text[k:k + 2], 16) / 255.0 for k in (0, 2, 4))


def body_color(index: int, fixed: bool = False) -> tuple[float, float, float]:
    """sRGB colour (0..1) of body ``index``: the palette in turn, grey when fixed."""
    return hex_to_rgb(FIXED_COLOR if fixed else PALETTE[index % len(PALETTE)])


def srgb_to_linear(rgb) -> tuple[float, float, float]:
    """sRGB (0..1) to linear-light values, the IEC 61966-2-1 transfer curve."""
    c = np.asarray(rgb, dtype=float)
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return tuple(float(v) for v in lin)


def shape_dict(shape) -> dict | None:
    """A shape as its ``shapes.shape_to_dict`` mapping (accepts a record, a mapping, JSON text or None)."""
    if shape is None or isinstance(shape, dict):
        return shape
    if isinstance(shape, (str, np.str_)):
        return json.loads(str(shape))
    from ..shapes import shape_to_dict

    return shape_to_dict(shape)


def shape_trimesh(shape, plane_size: float = PLANE_MIN_SIZE):
    """A ``trimesh.Trimesh`` of ``shape`` in its own frame (metres).

    ``shape`` is a record of ``tumble.shapes``, its ``shape_to_dict`` mapping, or
    None (a small marker sphere). A plane becomes a square of side
    ``plane_size`` centred at the plane's point nearest the origin.
    """
    import trimesh
    import trimesh.creation as create

    d = shape_dict(shape)
    if d is None:
        return create.icosphere(subdivisions=2, radius=MARKER_RADIUS)
    kind = d["type"]
    if kind == "sphere":
        return create.icosphere(subdivisions=SPHERE_SUBDIVISIONS, radius=float(d["radius"]))
    if kind == "box":
        return create.box(extents=np.asarray(d["size"], dtype=float))
    if kind == "cylinder":
        return create.cylinder(radius=float(d["radius"]), height=float(d["length"]), sections=SECTIONS)
    if kind == "capsule":  # trimesh's height is the distance between the hemisphere centres, as ours
        return create.capsule(height=float(d["length"]), radius=float(d["radius"]), count=[SECTIONS, SECTIONS // 2])
    if kind == "cone":  # base disc on z = 0 centred on the origin, apex at z = height: as tumble.shapes.Cone
        return create.cone(radius=float(d["radius"]), height=float(d["height"]), sections=SECTIONS)
    if kind in ("mesh", "convex"):
        return trimesh.Trimesh(np.asarray(d["vertices"], dtype=float), np.asarray(d["faces"], dtype=np.int64), process=False)
    if kind == "particles":
        return _particle_cloud(np.asarray(d["points"], dtype=float), np.asarray(d["masses"], dtype=float))
    if kind == "plane":
        return _plane_quad(np.asarray(d.get("normal", (0, 0, 1)), dtype=float), float(d.get("offset", 0.0)), plane_size)
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


def visual_mesh(mesh, offset=(0.0, 0.0, 0.0), double_sided: bool = False) -> VisualMesh:
    """Shift a trimesh by ``-offset``, split vertices at sharp edges, and compute unit vertex normals."""
    import trimesh

    mesh = trimesh.Trimesh(np.asarray(mesh.vertices, dtype=float) - np.asarray(offset, dtype=float),
                           np.asarray(mesh.faces, dtype=np.int64), process=False)
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.remove_unreferenced_vertices()
    if double_sided or len(mesh.faces) <= 2:
        normals = np.repeat(mesh.face_normals[:1], len(mesh.vertices), axis=0)
        return VisualMesh(mesh.vertices.copy(), _unit(normals, mesh.face_normals[0]), mesh.faces.copy(), double_sided)
    smooth = trimesh.graph.smooth_shade(mesh, angle=np.radians(SHARP_ANGLE_DEG), facet_minarea=None)
    vertices = np.asarray(smooth.vertices, dtype=float)
    faces = np.asarray(smooth.faces, dtype=np.int64)
    # Area-weighted vertex normals (trimesh's), then made unit; a vertex with no usable normal gets +z.
    normals = np.asarray(smooth.vertex_normals, dtype=float)
    return VisualMesh(vertices, _unit(normals, np.array([0.0, 0.0, 1.0])), faces, double_sided)


def _unit(normals: np.ndarray, fallback) -> np.ndarray:
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    bad = ~np.isfinite(length[:, 0]) | (length[:, 0] < 1e-12)
    out = np.where(bad[:, None], np.asarray(fallback, dtype=float)[None, :], normals / np.where(bad[:, None], 1.0, length))
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def plane_size_for(traj, index: int) -> float:
    """Side (m) of the quad drawn for plane body ``index``: PLANE_MIN_SIZE, or larger so that
    every centre of mass of the run, projected on the plane, falls inside with a 2 m margin."""
    pos = np.asarray(traj.position, dtype=float)
    if pos.size == 0:
        return PLANE_MIN_SIZE
    d = shape_dict(traj.shapes[index]) if traj.shapes is not None else None
    from ..math3d import quat_to_matrix

    q0 = np.asarray(traj.orientation[0, index], dtype=float)
    R = quat_to_matrix(q0 / np.linalg.norm(q0))
    origin = pos[0, index] - R @ np.asarray(traj.com_offset[index], dtype=float)
    n = np.asarray(d.get("normal", (0, 0, 1)), dtype=float) if d else np.array([0.0, 0.0, 1.0])
    n = n / np.linalg.norm(n)
    centre_world = origin + R @ (n * (float(d.get("offset", 0.0)) if d else 0.0))
    rel = pos.reshape(-1, 3) - centre_world
    rel = rel[np.all(np.isfinite(rel), axis=1)]
    if len(rel) == 0:
        return PLANE_MIN_SIZE
    n_world = R @ n
    in_plane = rel - np.outer(rel @ n_world, n_world)
    reach = float(np.abs(in_plane).max()) if len(in_plane) else 0.0
    return max(PLANE_MIN_SIZE, 2.0 * (reach + 2.0))


def body_meshes(traj) -> list[tuple[VisualMesh, str]]:
    """Per body of ``traj``: (its VisualMesh in the body frame, a key equal for bodies whose mesh is the same).

    Bodies with the same shape and centre-of-mass offset share one VisualMesh object.
    """
    n = len(traj.names)
    cache: dict[str, VisualMesh] = {}
    out = []
    for i in range(n):
        raw = None if traj.shapes is None else str(traj.shapes[i])
        d = None if raw is None else json.loads(raw)
        offset = np.asarray(traj.com_offset[i], dtype=float)
        plane = d is not None and d.get("type") == "plane"
        size = plane_size_for(traj, i) if plane else PLANE_MIN_SIZE
        key = json.dumps([raw, offset.tolist(), size if plane else None])
        if key not in cache:
            cache[key] = visual_mesh(shape_trimesh(d, plane_size=size), offset, double_sided=plane)
        out.append((cache[key], key))
    return out


def fixed_flags(traj) -> np.ndarray:
    """(N,) bool: the trajectory's ``fixed`` flags (all False for files written before it existed)."""
    if getattr(traj, "fixed", None) is None:
        return np.zeros(len(traj.names), dtype=bool)
    return np.asarray(traj.fixed, dtype=bool)


def continuous_quaternions(q: np.ndarray) -> np.ndarray:
    """(F, N, 4) quaternions with signs flipped so that consecutive frames have a
    non-negative dot product: interpolating between them (slerp, or nlerp as glTF
    viewers do) then takes the short way. q and -q are the same rotation."""
    q = np.array(q, dtype=float, copy=True)
    if len(q) < 2:
        return q
    dots = np.einsum("fnk,fnk->fn", q[1:], q[:-1])
    flips = np.where(dots < 0.0, -1.0, 1.0)
    signs = np.concatenate([np.ones((1,) + flips.shape[1:]), np.cumprod(flips, axis=0)], axis=0)
    return q * signs[..., None]


def frame_rate(traj) -> float:
    """Frames per second of ``traj``, from its frame times (24 when it has fewer than two frames).

    Rounded to an integer when within 1e-6 of one (recorded times carry float error).
    """
    t = np.asarray(traj.time, dtype=float)
    if len(t) < 2 or not t[-1] > t[0]:
        return 24.0
    fps = (len(t) - 1) / (t[-1] - t[0])
    return float(round(fps)) if abs(fps - round(fps)) < 1e-6 * max(1.0, fps) else float(fps)
