"""Headless video of a trajectory: pyvista (VTK) off-screen, written with imageio-ffmpeg or Pillow.

The picture: each body's visual mesh in its own colour (fixed bodies grey), a
ground grid at z = 0 (or at the lowest horizontal plane of the scene),
other planes as translucent patches, the light kit of pyvista, a sky
gradient and the time in a corner. The camera looks from the front right and
above (fixed direction) and either frames every body over the whole run
(``camera="frame"``, fixed) or keeps one body in the middle
(``camera="follow:NAME"``). A body disabled at a frame (``World.set_enabled``:
``Trajectory.enabled`` False) is not drawn there, and its disabled frames
are left out of the framing.

``Camera`` is the pinhole model the renderer is given (position, focal
point, view up, vertical view angle), so ``camera_at(...).project(points)``
says where a world point lands in the image: tests compare that with the
pixels.

No display is needed: without ``DISPLAY`` VTK renders through EGL (Mesa's
software rasteriser on machines without a GPU).
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from .. import visual
from ..export.meshes import SENSOR_OPACITY, enabled_flags, sensor_flags
from ..shapes import Plane
from ..trajectory import atomic_path

VIDEO_SUFFIXES = (".mp4", ".gif")
MAX_SIZE = 8192  # pixels along either side; VTK's off-screen buffers stop well above, memory does not

# Body colours (RGB 0-255) shared with export and the viewer; fixed bodies are grey.
PALETTE = np.array(visual.PALETTE, dtype=np.uint8)
FIXED_COLOR = visual.FIXED_COLOR
GROUND_COLOR, GRID_COLOR = (222, 219, 212), (150, 148, 142)
SKY_TOP, SKY_BOTTOM = (176, 196, 222), (245, 246, 248)
VIEW_DIRECTION = np.array([0.45, -1.0, 0.5]) / np.linalg.norm([0.45, -1.0, 0.5])  # from the scene towards the camera
VIEW_ANGLE = 30.0  # degrees, vertical (VTK's default)


# --------------------------------------------------------------------------- camera


@dataclass(frozen=True)
class Camera:
    """A pinhole camera as VTK uses it.

    Attributes:
        position, focal_point: (3,) m, world. The camera looks from ``position`` at ``focal_point``.
        view_up: (3,) world direction that appears upwards in the image.
        view_angle: vertical field of view, degrees.
    """

    position: np.ndarray
    focal_point: np.ndarray
    view_up: np.ndarray
    view_angle: float = VIEW_ANGLE

    def basis(self):
        """(right, up, forward) unit vectors, world."""
        f = np.asarray(self.focal_point, float) - np.asarray(self.position, float)
        f /= np.linalg.norm(f)
        r = np.cross(f, self.view_up)
        r /= np.linalg.norm(r)
        return r, np.cross(r, f), f

    def matrix(self, width: int, height: int) -> np.ndarray:
        """(3, 4) projection P with [u*w, v*w, w] = P [p, 1]; (u, v) as in ``project``."""
        r, u, f = self.basis()
        focal = 0.5 * height / math.tan(math.radians(self.view_angle) / 2)
        K = np.array([[focal, 0.0, 0.5 * width], [0.0, focal, 0.5 * height], [0.0, 0.0, 1.0]])
        Rc = np.stack([r, -u, f])  # camera axes: x right, y down (image rows), z forward
        return K @ np.hstack([Rc, -(Rc @ np.asarray(self.position, float))[:, None]])

    def project(self, points, width: int, height: int) -> np.ndarray:
        """Pixel coordinates (n, 2) = (column, row) of world ``points`` (n, 3).

        Row 0 is the top of the image; pixel ``img[i, j]`` covers columns
        [j, j + 1) and rows [i, i + 1), so its centre is at (j + 0.5, i + 0.5).
        Points behind the camera get NaN.
        """
        p = np.atleast_2d(np.asarray(points, float))
        h = np.hstack([p, np.ones((len(p), 1))]) @ self.matrix(width, height).T
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = h[:, :2] / h[:, 2:3]
        uv[h[:, 2] <= 0] = np.nan
        return uv


def camera_at(traj, frame_index: int, width: int = 1280, height: int = 720, camera: str = "frame") -> Camera:
    """The camera ``render_frame`` uses for frame ``frame_index`` (for projecting world points to pixels)."""
    stage = _Stage(traj, width, height, camera)
    return stage.camera(*stage.poses_at_frame(_frame_index(traj, frame_index)))


# --------------------------------------------------------------------------- meshes and colours


def visual_mesh(shape):
    """A ``trimesh.Trimesh`` drawing ``shape`` in its own frame (``tumble.visual``); None for a
    plane (drawn as ground). Bodies without a shape record (old trajectory files) get a marker ball."""
    if isinstance(shape, Plane):
        return None
    return visual.shape_trimesh(shape)


def _shaded(mesh):
    """(points, point normals, triangles) of a trimesh, vertices split along sharp edges (> 30 degrees)."""
    if mesh is None:
        return None
    import pyvista as pv

    poly = pv.PolyData.from_regular_faces(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64))
    poly = poly.compute_normals(cell_normals=False, point_normals=True, split_vertices=True, feature_angle=30.0,
                                consistent_normals=False, auto_orient_normals=False)
    return np.asarray(poly.points, float), np.asarray(poly.point_data["Normals"], float), poly.regular_faces.astype(np.int64)


def body_colors(traj, colors=None) -> np.ndarray:
    """(N, 3) uint8 sRGB colour of each body: ``visual.body_color(i, fixed)``, the palette in turn by
    body index, fixed bodies grey (the glTF's, USD's and HTML's colours).

    ``colors`` overrides: a mapping from body name, or a sequence (one per body),
    of any colour pyvista understands (name, hex, RGB 0-1 floats or 0-255 ints).
    """
    import pyvista as pv

    n = len(traj.names)
    fixed = np.zeros(n, bool) if traj.fixed is None else np.asarray(traj.fixed, bool)
    out = visual.palette_colors(fixed)  # the exporters' rule: a body looks the same in the video and in Blender
    if colors is None:
        return out
    items = colors.items() if hasattr(colors, "items") else zip(traj.names, colors)
    names = [str(x) for x in traj.names]
    for name, c in items:
        if str(name) not in names:
            raise InputError(f"no body called {name!r}", "colors")
        try:
            out[names.index(str(name))] = pv.Color(c).int_rgb
        except ValueError as exc:
            raise InputError(f"not a colour: {c!r} ({exc})", f"colors[{name}]") from None
    return out


def quat_matrices(q) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of quaternions (..., 4) (w, x, y, z), normalised first."""
    q = np.asarray(q, float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


# --------------------------------------------------------------------------- the stage


def _offscreen():
    """Make VTK render without a display: EGL when there is no X or Wayland display."""
    import ctypes.util

    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        if ctypes.util.find_library("EGL"):
            os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    return pv  # every Plotter here is made with off_screen=True; pyvista's global OFF_SCREEN is left alone


def _check_size(value, key: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        try:
            as_float = float(value)
        except (TypeError, ValueError):
            raise InputError(f"expected a whole number of pixels, got {value!r}", key) from None
        if not as_float.is_integer():
            raise InputError(f"expected a whole number of pixels, got {value!r}", key)
        value = int(as_float)
    if not 0 < value <= MAX_SIZE:
        raise InputError(f"must be between 1 and {MAX_SIZE} pixels, got {value}", key)
    return int(value)


def _frame_index(traj, frame_index) -> int:
    count = traj.frame_count
    try:
        k = int(frame_index)
    except (TypeError, ValueError):
        raise InputError(f"expected a frame number, got {frame_index!r}", "frame_index") from None
    if k != frame_index or not 0 <= k < count:
        raise InputError(f"must be a frame number from 0 to {count - 1}, got {frame_index!r}", "frame_index")
    return k


def _parse_camera(traj, camera) -> int | None:
    """None for 'frame', the body index for 'follow:NAME'."""
    spec = str(camera)
    if spec == "frame":
        return None
    if spec.startswith("follow:"):
        name = spec[len("follow:"):]
        names = [str(x) for x in traj.names]
        if name not in names:
            shown = ", ".join(names[:10]) + (", ..." if len(names) > 10 else "")
            raise InputError(f"no body called {name!r} to follow (bodies: {shown})", "camera")
        return names.index(name)
    raise InputError(f"expected 'frame' or 'follow:<body name>', got {spec!r}", "camera")


def trajectory_fps(traj) -> float:
    """The trajectory's frame rate (1 / median frame interval); 24 for a single frame."""
    if traj.frame_count < 2:
        return 24.0
    dt = float(np.median(np.diff(np.asarray(traj.time, float))))
    return 1.0 / dt if dt > 0 else 24.0


class _Stage:
    """Meshes, colours, ground and camera framing of one trajectory; renders poses into images."""

    def __init__(self, traj, width, height, camera="frame", colors=None, antialias=True):
        self.traj = traj
        self.antialias = bool(antialias)
        self.width = _check_size(width, "width")
        self.height = _check_size(height, "height")
        self.follow = _parse_camera(traj, camera)
        self.colors = body_colors(traj, colors)
        n = len(traj.names)
        offset = np.zeros((n, 3)) if traj.com_offset is None else np.asarray(traj.com_offset, float)
        self.meshes, self.planes = [], []
        cache = {}  # identical shapes (same JSON) share one tessellation
        for i in range(n):
            key = traj.shape_text(i)
            if key not in cache:
                try:
                    shape = traj.shape(i)
                    mesh = visual_mesh(shape)
                except (ValueError, TypeError, KeyError, AttributeError, IndexError) as exc:  # a shape text not from tumble
                    problem = exc.problem if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
                    raise InputError(f"row {int(traj.shape_index[i])} (body {i}) is not a shape that can be drawn "
                                     f"({problem})", "shape_table") from None
                cache[key] = (shape, _shaded(mesh))
            shape, mesh = cache[key]
            if mesh is not None:  # points in the body frame (origin at the centre of mass), normals, triangles
                mesh = (mesh[0] - offset[i], mesh[1], mesh[2])
            self.meshes.append(mesh)
            if isinstance(shape, Plane):
                self.planes.append(self._world_plane(i, shape, offset[i]))
        # Which bodies are drawn at each frame: (F, N) bool, or None when every body is throughout.
        enabled = enabled_flags(traj)
        self.enabled = None if enabled.all() else enabled
        # The bodies' reach over the run: centre of mass +- the body's bounding radius, at the
        # frames they are drawn (all frames, if that leaves nothing).
        self.radius = np.array([0.0 if m is None else float(np.linalg.norm(m[0], axis=1).max()) for m in self.meshes])
        drawn = [i for i in range(n) if self.meshes[i] is not None]
        if drawn:
            pos = np.asarray(traj.position, float)[:, drawn]
            r = self.radius[drawn]
            lo, hi = pos - r[:, None], pos + r[:, None]
            if self.enabled is not None and self.enabled[:, drawn].any():
                shown = self.enabled[:, drawn]
                lo, hi = lo[shown], hi[shown]
            self.lo = lo.reshape(-1, 3).min(axis=0)
            self.hi = hi.reshape(-1, 3).max(axis=0)
        else:
            self.lo, self.hi = -np.ones(3), np.ones(3)
        horizontal = [p[0][2] for p in self.planes if p[1][2] > 0.999]
        self.ground_z = min(horizontal) if horizontal else 0.0
        self.plotter = None

    def _world_plane(self, i, plane, offset):
        t = self.traj
        R = quat_matrices(t.orientation[0, i])
        n = R @ np.asarray(plane.normal)
        point = R @ (np.asarray(plane.normal) * plane.offset - offset) + t.position[0, i]
        return point, n

    # ---- poses and camera
    def poses_at_frame(self, k):
        return float(self.traj.time[k]), np.asarray(self.traj.position[k], float), np.asarray(self.traj.orientation[k], float)

    def shown_at_frame(self, k):
        """(N,) bool, the bodies drawn at frame ``k`` (those enabled), or None: all of them."""
        return None if self.enabled is None else self.enabled[k]

    def shown_at_time(self, t):
        """The bodies drawn at time ``t`` (``shown_at_frame``): those of the frame at or before ``t``
        (a body vanishes and appears at a frame, it does not fade between two). A time within a
        millionth of a frame before a frame's counts as that frame's (the video's clock and the
        recorded times differ by round-off)."""
        if self.enabled is None:
            return None
        return self.enabled[self._frame_before(t + 1e-6 / trajectory_fps(self.traj))]

    def _frame_before(self, t) -> int:
        time = np.asarray(self.traj.time, float)
        return int(np.clip(np.searchsorted(time, t, side="right") - 1, 0, len(time) - 1))

    def poses_at_time(self, t):
        """Positions and orientations at time ``t``: linear between frames, normalised-linear for quaternions."""
        time = np.asarray(self.traj.time, float)
        k = self._frame_before(t)
        if k == len(time) - 1 or t <= time[k]:
            return self.poses_at_frame(k)
        a = (t - time[k]) / (time[k + 1] - time[k])
        p0, p1 = self.traj.position[k], self.traj.position[k + 1]
        q0, q1 = np.asarray(self.traj.orientation[k], float), np.asarray(self.traj.orientation[k + 1], float)
        q1 = q1 * np.where(np.sum(q0 * q1, axis=1) < 0, -1.0, 1.0)[:, None]  # the short way round
        q = (1 - a) * q0 + a * q1
        return float(t), (1 - a) * p0 + a * p1, q / np.linalg.norm(q, axis=1, keepdims=True)

    def camera(self, t, position, orientation) -> Camera:
        """Fixed direction; distance so that the box to frame fills the picture with a margin."""
        if self.follow is None:
            lo, hi = self.lo, self.hi
        else:
            reach = max(1.8 * self.radius[self.follow], 0.3)
            lo, hi = position[self.follow] - reach, position[self.follow] + reach
        centre = 0.5 * (lo + hi)
        f = -VIEW_DIRECTION
        up = np.array([0.0, 0.0, 1.0])
        r = np.cross(f, up)
        r /= np.linalg.norm(r)
        u = np.cross(r, f)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]) - centre
        ty = math.tan(math.radians(VIEW_ANGLE) / 2) * 0.9  # 10 % margin
        tx = ty * self.width / self.height
        # a corner at (x, y, z) in camera axes, camera at distance d: |x| <= tx (d + z) and |y| <= ty (d + z)
        need = np.maximum(np.abs(corners @ r) / tx, np.abs(corners @ u) / ty) - corners @ f
        d = float(need.max()) + 1e-3 * float(np.linalg.norm(hi - lo)) + 1e-6
        return Camera(centre - d * f, centre, up, VIEW_ANGLE)

    # ---- drawing
    def open(self):
        pv = _offscreen()
        p = pv.Plotter(off_screen=True, window_size=(self.width, self.height), lighting="light kit")
        p.set_background(np.array(SKY_BOTTOM) / 255, top=np.array(SKY_TOP) / 255)
        self._add_ground(pv, p)
        # All bodies in one mesh whose points and normals are moved in place each frame:
        # one actor however many bodies there are (and one more, translucent, for sensors).
        drawn = [i for i, m in enumerate(self.meshes) if m is not None]
        sensor = sensor_flags(self.traj)
        self.layers = []
        for members, opacity in (([i for i in drawn if not sensor[i]], 1.0), ([i for i in drawn if sensor[i]], SENSOR_OPACITY)):
            if members:
                self.layers.append(self._add_layer(pv, p, members, opacity))
        self.label = p.add_text("", position="upper_left", font_size=max(8, self.height // 60), color=(0.15, 0.15, 0.15))
        if self.antialias:
            # Super-sampling: VTK with EGL has no FXAA (it falls back to this), and 8x MSAA
            # changed no pixel here. Measured: 49 frames of 960 x 540 in 8.6 s instead of 5.1 s.
            p.enable_anti_aliasing("ssaa")
        self.plotter = p
        return self

    def _add_layer(self, pv, p, members, opacity):
        """One actor drawing the bodies ``members``: (vertex_body, local_points, local_normals, poly)."""
        counts = np.array([len(self.meshes[i][0]) for i in members])
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        vertex_body = np.repeat(np.asarray(members, dtype=np.int64), counts)
        local_points = np.concatenate([self.meshes[i][0] for i in members])
        local_normals = np.concatenate([self.meshes[i][1] for i in members])
        faces = np.concatenate([self.meshes[i][2] + s for i, s in zip(members, starts)])
        poly = pv.PolyData.from_regular_faces(local_points.copy(), faces)
        poly.point_data["Normals"] = local_normals.copy()
        poly.point_data.active_normals_name = "Normals"
        poly.point_data["rgb"] = self.colors[vertex_body]
        actor = p.add_mesh(poly, scalars="rgb", rgb=True, smooth_shading=False, specular=0.3, specular_power=20,
                           ambient=0.15, diffuse=0.85, opacity=opacity)
        actor.prop.interpolation = "gouraud"  # shade with the normals we move (pyvista's smooth shading would copy the mesh)
        return vertex_body, local_points, local_normals, poly

    def _add_ground(self, pv, p):
        span = float(max(self.hi[0] - self.lo[0], self.hi[1] - self.lo[1], 1.0))
        spacing = _nice_step(span / 12)
        pad = max(0.5 * span, 2 * spacing)
        x0, y0 = (np.floor((self.lo[:2] - pad) / spacing) * spacing)
        x1, y1 = (np.ceil((self.hi[:2] + pad) / spacing) * spacing)
        z = self.ground_z
        lift = 1e-3 * span  # grid lines just above the surface, which sits just below z (no z-fighting)
        ground = pv.Plane(center=((x0 + x1) / 2, (y0 + y1) / 2, z - lift), direction=(0, 0, 1), i_size=x1 - x0, j_size=y1 - y0)
        # A ground plane in the scene is drawn solid; without one the grid is only a
        # reference at z = 0 (nothing collides with it yet), so bodies below it stay visible.
        solid = any(n[2] > 0.999 for _, n in self.planes)
        p.add_mesh(ground, color=np.array(GROUND_COLOR) / 255, ambient=0.3, diffuse=0.7, specular=0.0, opacity=1.0 if solid else 0.45)
        xs, ys = np.arange(x0, x1 + spacing / 2, spacing), np.arange(y0, y1 + spacing / 2, spacing)
        segments = [((x, y0, z + lift), (x, y1, z + lift)) for x in xs] + [((x0, y, z + lift), (x1, y, z + lift)) for y in ys]
        lines = pv.line_segments_from_points(np.array(segments).reshape(-1, 3))
        p.add_mesh(lines, color=np.array(GRID_COLOR) / 255, line_width=1, lighting=False)
        for point, normal in self.planes:  # other planes: translucent square patches
            if normal[2] > 0.999 and abs(point[2] - z) < 1e-9:
                continue
            size = 2 * span
            centre = _project_on_plane(0.5 * (self.lo + self.hi), point, normal)
            if abs(normal[2]) < 0.01:  # a wall: stand it on the ground
                centre[2] = z + size / 2
            p.add_mesh(pv.Plane(center=centre, direction=normal, i_size=size, j_size=size), color=np.array(FIXED_COLOR) / 255, opacity=0.35)

    def render(self, t, position, orientation, shown=None) -> np.ndarray:
        """The (H, W, 3) uint8 image of the bodies at these poses; ``shown`` (N,) bool: the bodies
        drawn (``shown_at_frame``; None: all)."""
        if self.plotter is None:
            self.open()
        p = self.plotter
        if self.layers:
            Rs = quat_matrices(orientation)
            for vertex_body, local_points, local_normals, poly in self.layers:
                R = Rs[vertex_body]
                points = np.einsum("vij,vj->vi", R, local_points)
                if shown is not None and not shown.all():
                    # a body not drawn: its mesh shrunk to its centre of mass, triangles of no area
                    # that cover no pixel (the layer keeps its points; no actor is added or removed)
                    points *= shown[vertex_body, None]
                poly.points[:] = points + position[vertex_body]
                poly.point_data["Normals"][:] = np.einsum("vij,vj->vi", R, local_normals)
                poly.Modified()
        cam = self.camera(t, position, orientation)
        p.camera.position, p.camera.focal_point, p.camera.up = (tuple(map(float, v)) for v in (cam.position, cam.focal_point, cam.view_up))
        p.camera.view_angle = cam.view_angle
        p.renderer.ResetCameraClippingRange()
        self.label.SetText(2, f"t = {t:.2f} s")  # corner 2: upper left
        p.render()  # pyvista renders by itself only the first time (before that this call is a no-op)
        img = p.screenshot(return_img=True)
        return np.ascontiguousarray(img[:, :, :3], dtype=np.uint8)

    def close(self):
        if self.plotter is not None:
            self.plotter.close()
            self.plotter = None


def _project_on_plane(x, point, normal):
    return x - np.dot(x - point, normal) * normal


def _nice_step(x: float) -> float:
    """1, 2 or 5 times a power of ten, at least ``x``."""
    e = 10.0 ** math.floor(math.log10(x))
    return next(m * e for m in (1, 2, 5, 10) if m * e >= x)


# --------------------------------------------------------------------------- public entry points


def render_frame(traj, frame_index: int, width: int = 1280, height: int = 720, camera: str = "frame", colors=None,
                 antialias: bool = True) -> np.ndarray:
    """Frame ``frame_index`` of ``traj`` as an (H, W, 3) uint8 RGB image (row 0 at the top);
    ``antialias``: smooth edges by super-sampling (as ``render_video``)."""
    stage = _Stage(traj, width, height, camera, colors, antialias)
    k = _frame_index(traj, frame_index)
    try:
        return stage.render(*stage.poses_at_frame(k), stage.shown_at_frame(k))
    finally:
        stage.close()


def render_video(traj, path, width: int = 1280, height: int = 720, fps: float | None = None, camera: str = "frame",
                 progress: bool = True, colors=None, antialias: bool = True) -> Path:
    """Render ``traj`` to ``path`` (``.mp4``: H.264, yuv420p; ``.gif``: looping) and return the path.

    Args:
        width, height: pixels (even for .mp4, as yuv420p needs).
        fps: frames per second of the video; default the trajectory's. The video
            always plays in real time: at another rate the bodies' poses are
            interpolated between the trajectory's frames (positions linearly,
            orientations by normalised linear quaternion interpolation).
        camera: ``"frame"`` (fixed, frames every body over the whole run) or
            ``"follow:NAME"`` (keeps body NAME in the middle).
        progress: show a progress bar (tqdm) on stderr.
        colors: per-body colours, see ``body_colors``.
        antialias: smooth edges (super-sampling; about 1.7x the time of a frame without).

    The file is written under a temporary name beside ``path`` and renamed
    into place when complete. A GIF stores frame times in hundredths of a
    second: its delays mix two values so that it plays at ``fps`` on average
    (``gif_durations_ms``); Pillow merges identical consecutive frames into one
    longer frame.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in VIDEO_SUFFIXES:
        raise InputError(f"video must end in {' or '.join(VIDEO_SUFFIXES)}, got {path.suffix or 'no suffix'!r}", None, str(path))
    from ..trajectory import check_trajectory

    check_trajectory(traj)  # InputError naming the key (time, position, ...) of a value that cannot be drawn
    stage = _Stage(traj, width, height, camera, colors, antialias)
    if suffix == ".mp4" and (stage.width % 2 or stage.height % 2):
        raise InputError(f"width and height must be even for .mp4 (yuv420p), got {stage.width}x{stage.height}", None, str(path))
    fps = _check_fps(trajectory_fps(traj) if fps is None else fps)
    time = np.asarray(traj.time, float)
    native = abs(fps - trajectory_fps(traj)) <= 1e-9 * fps and traj.frame_count > 1 and np.allclose(np.diff(time), 1 / fps, rtol=1e-6)
    if native or traj.frame_count == 1:
        poses = ((*stage.poses_at_frame(k), stage.shown_at_frame(k)) for k in range(traj.frame_count))
        count = traj.frame_count
    else:
        count = math.floor((time[-1] - time[0]) * fps + 1e-9) + 1
        poses = ((*stage.poses_at_time(t), stage.shown_at_time(t)) for t in (time[0] + j / fps for j in range(count)))
    bar = None
    try:
        with atomic_path(path, suffix=f".tmp{suffix}") as tmp:
            if progress:
                from tqdm import tqdm

                bar = tqdm(total=count, unit="frame", desc=f"render {path.name}", file=sys.stderr, leave=False)
            images = (_tick(stage.render(*pose), bar) for pose in poses)
            (_write_mp4 if suffix == ".mp4" else _write_gif)(tmp, images, stage.width, stage.height, fps)
    finally:
        if bar is not None:
            bar.close()
        stage.close()
    return path


def _tick(img, bar):
    if bar is not None:
        bar.update(1)
    return img


def _check_fps(fps) -> float:
    try:
        v = float(fps)
    except (TypeError, ValueError):
        raise InputError(f"expected frames per second, got {fps!r}", "fps") from None
    if not math.isfinite(v) or v <= 0 or v > 1000:
        raise InputError(f"must be a positive number of frames per second (at most 1000), got {fps!r}", "fps")
    return v


def _write_mp4(path, images, width, height, fps):
    import imageio_ffmpeg

    writer = imageio_ffmpeg.write_frames(path, (width, height), fps=fps, codec="libx264", pix_fmt_out="yuv420p",
                                         quality=None, macro_block_size=1, ffmpeg_log_level="error",
                                         output_params=["-crf", "18", "-preset", "medium", "-movflags", "+faststart", "-f", "mp4"])
    writer.send(None)  # start ffmpeg
    try:
        for img in images:
            writer.send(np.ascontiguousarray(img))
    finally:
        writer.close()


def _write_gif(path, images, width, height, fps):
    from PIL import Image

    frames = [Image.fromarray(img).quantize(colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE) for img in images]
    frames[0].save(path, format="GIF", save_all=True, append_images=frames[1:], duration=gif_durations_ms(len(frames), fps),
                   loop=0)


def gif_durations_ms(count: int, fps: float) -> list[int]:
    """Per-frame delays (ms, multiples of 10) of a GIF playing at ``fps`` on average.

    A GIF stores delays in hundredths of a second, so 24 fps (4.17 cs) cannot be one delay:
    rounded it plays at 25 fps (4 cs), 4 % fast. Frame k instead starts at round(100 k / fps)
    cs, so the delays mix 4 and 5 cs and frame k is never off by more than half a hundredth.
    At least 2 cs a frame: browsers show shorter delays as 10 cs.
    """
    starts = [round(100.0 * k / fps) for k in range(count + 1)]
    return [10 * max(2, starts[k + 1] - starts[k]) for k in range(count)]
