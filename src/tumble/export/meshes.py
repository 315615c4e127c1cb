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

Presence: ``enabled_flags`` says, frame by frame, which bodies are in the simulation
(``World.set_enabled``); the exports and views hide a body at the frames it is not.

Colours: ``body_color`` picks from a fixed palette by body index (sRGB, the
numbers a colour picker shows); fixed bodies are grey. ``srgb_to_linear``
converts for formats whose colour factors are linear (glTF, USD).
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from .. import visual
from ..errors import InputError
from ..visual import MARKER_RADIUS, PLANE_MIN_SIZE, SHARP_ANGLE_DEG, shape_dict, shape_trimesh  # noqa: F401 (re-exported)


@dataclass
class VisualMesh:
    """A triangle mesh ready for export.

    Attributes:
        vertices: (V, 3) float64, m, body frame (origin at the centre of mass).
        normals: (V, 3) float64 unit vertex normals.
        faces: (T, 3) int64 vertex indices, counter-clockwise seen from outside.
        double_sided: True for open surfaces (the plane's quad, an open mesh: ``Mesh(closed=False)``).
    """

    vertices: np.ndarray
    normals: np.ndarray
    faces: np.ndarray
    double_sided: bool = False


def body_color(index: int, fixed: bool = False) -> tuple[float, float, float]:
    """sRGB colour (0..1) of body ``index`` (``tumble.visual.body_color``)."""
    return tuple(c / 255.0 for c in visual.body_color(index, fixed))


def srgb_to_linear(rgb) -> tuple[float, float, float]:
    """sRGB (0..1) to linear-light values, the IEC 61966-2-1 transfer curve."""
    c = np.asarray(rgb, dtype=float)
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return tuple(float(v) for v in lin)


def visual_mesh(mesh, offset=(0.0, 0.0, 0.0), double_sided: bool = False) -> VisualMesh:
    """Shift a trimesh by ``-offset``, split vertices at sharp edges, and compute unit vertex normals."""
    import trimesh

    mesh = trimesh.Trimesh(np.asarray(mesh.vertices, dtype=float) - np.asarray(offset, dtype=float),
                           np.asarray(mesh.faces, dtype=np.int64), process=False)
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.remove_unreferenced_vertices()
    if len(mesh.faces) <= 2:  # a plane's quad, a lone triangle: one flat normal
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
    d = shape_dict(traj.shape_text(index))
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
        raw = traj.shape_text(i)
        d = None if raw is None else json.loads(raw)
        offset = np.asarray(traj.com_offset[i], dtype=float)
        plane = d is not None and d.get("type") == "plane"
        sheet = d is not None and d.get("type") == "mesh" and d.get("closed") is False  # an open mesh: both sides
        size = plane_size_for(traj, i) if plane else PLANE_MIN_SIZE
        key = json.dumps([raw, offset.tolist(), size if plane else None])
        if key not in cache:
            try:
                tm = shape_trimesh(d, plane_size=size)
            except (ValueError, TypeError, KeyError, AttributeError, IndexError) as exc:  # a shape text not from tumble
                row = None if traj.shape_index is None else int(traj.shape_index[i])
                problem = exc.problem if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
                raise InputError(f"row {row} (body {i}) is not a shape that can be drawn ({problem})", "shape_table") from None
            cache[key] = visual_mesh(tm, offset, double_sided=plane or sheet)
        out.append((cache[key], key))
    return out


def fixed_flags(traj) -> np.ndarray:
    """(N,) bool: the trajectory's ``fixed`` flags (all False for files written before it existed)."""
    if getattr(traj, "fixed", None) is None:
        return np.zeros(len(traj.names), dtype=bool)
    return np.asarray(traj.fixed, dtype=bool)


def sensor_flags(traj) -> np.ndarray:
    """(N,) bool: the trajectory's ``sensor`` flags (all False when it has none)."""
    if getattr(traj, "sensor", None) is None:
        return np.zeros(len(traj.names), dtype=bool)
    return np.asarray(traj.sensor, dtype=bool)


def enabled_flags(traj) -> np.ndarray:
    """(F, N) bool: whether each body is in the simulation at each frame (``Trajectory.enabled``;
    all True for a trajectory that never disabled a body, and for files written before
    ``enabled_changes`` existed). Every view and export hides a body where it is False."""
    from ..trajectory import unfold_enabled

    return unfold_enabled(getattr(traj, "enabled_changes", None), len(traj.time), len(traj.names))


def absent_flags(enabled: np.ndarray) -> np.ndarray:
    """(N,) bool: the bodies absent at some frame of ``enabled`` (F, N) (``enabled_flags``): those
    an export gives a visibility track. All False when no body was ever disabled."""
    return ~np.all(enabled, axis=0)


#: opacity a sensor is drawn with (video, glTF, USD, viewer): what it holds shows through it
SENSOR_OPACITY = 0.25


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
