"""Camera images of a World by ray casting: depth, range, segmentation, normals, points and a shaded
colour image, exact to round-off (PyBullet's ``getCameraImage``, MuJoCo's ``Renderer`` with depth
and segmentation; a range camera or an RGB-D sensor on a robot).

Each pixel is one ray of ``World.ray_cast`` through the pixel's centre of an ideal pinhole camera,
so the depth of a pixel is the exact distance to the exact shape (no triangles, no z-buffer, no
GPU or display), and the body a pixel sees is the body the ray hits. Conventions (OpenCV's and
ROS's): the camera frame has x right, y down, z forward (the optical axis); ``intrinsics`` is
K = [[f, 0, cx], [0, f, cy], [0, 0, 1]] with f = (height / 2) / tan(fov / 2) (``fov_deg`` is the
vertical field of view, square pixels) and (cx, cy) = (width / 2, height / 2): pixel (u, v)
(column, row) has its centre at (u + 1/2, v + 1/2). ``depth`` is z in the camera frame (the
depth image of an RGB-D camera), ``distance`` the length along the ray.

The colour image is each body's colour (``visual.body_color``, as in the exports, the video and
the viewer: the palette in turn by body index, fixed bodies grey) lit by a light at the camera (a
headlight: ambient 0.35 + diffuse 0.65 |n . d|), on a pale sky; it is for looking, the other images are the measurements.
Cost: one ray per pixel on both cores (docs/benchmarks.md, "camera").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import InputError
from .shapes import finite_vector

SKY = (236, 240, 245)  # sRGB where a ray hits nothing
AMBIENT, DIFFUSE = 0.35, 0.65


@dataclass
class CameraImage:
    """What a ``Camera`` saw (H rows, W columns; the camera's pose at the capture).

    Attributes:
        depth: (H, W) m, z of the hit in the camera frame (inf where nothing was hit).
        distance: (H, W) m along the pixel's ray (inf where nothing was hit).
        body: (H, W) int64, the index of the body seen (-1: none): the segmentation.
        point: (H, W, 3) m, world, the hit point (NaN where nothing was hit).
        normal: (H, W, 3) unit, world, the surface's outward normal there (NaN where none).
        rgb: (H, W, 3) uint8, the shaded colour image.
        position: (3,) m, world, the camera's centre; rotation: (3, 3), its axes (x right, y
            down, z forward) as columns, world.
        intrinsics: (3, 3) K.
    """

    depth: np.ndarray
    distance: np.ndarray
    body: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    rgb: np.ndarray
    position: np.ndarray
    rotation: np.ndarray
    intrinsics: np.ndarray

    def point_cloud(self, frame: str = "world") -> np.ndarray:
        """(K, 3) m: the points hit, row by row, in the ``world`` frame or the ``camera`` frame."""
        hit = self.body >= 0
        p = self.point[hit]
        if frame == "world":
            return p
        if frame == "camera":
            return (p - self.position) @ self.rotation
        raise InputError(f"expected 'world' or 'camera', got {frame!r}", "frame")


@dataclass
class Camera:
    """An ideal pinhole camera (module docstring) at ``position`` (3,) m looking at ``target`` (3,) m
    with ``up`` (3,) towards the top of the image, a vertical field of view ``fov_deg`` and
    ``width`` x ``height`` pixels, seeing up to ``max_distance`` m.

    Mounted on a body (``body``: a ``Body``, name or index), ``position``, ``target`` and ``up`` are
    in that body's frame where its shape was placed (its ``com_offset`` undone, as a URDF link
    frame), and the camera moves with the body; the body itself is not seen (``exclude_body``
    False to see it). ``track`` (MuJoCo's camera modes ``track`` and ``trackcom``): ``"point"``
    follows the body's ``point`` (body frame as above, default its origin) and ``"com"`` the
    centre of mass of ``bodies`` (indices; default the body alone), or a function ``f(world)``
    the point (3,) it returns, without turning: ``position``, ``target`` and ``up`` are then world
    offsets from the point followed. ``mask``: the collision categories seen (``World.ray_cast``'s).
    """

    position: tuple = (3.0, 0.0, 1.5)
    target: tuple = (0.0, 0.0, 0.5)
    up: tuple = (0.0, 0.0, 1.0)
    fov_deg: float = 60.0
    width: int = 160
    height: int = 120
    max_distance: float = math.inf
    body: object = None
    exclude_body: bool = True
    mask: int = 0xFFFFFFFF
    track: str | None = None
    point: tuple = (0.0, 0.0, 0.0)
    bodies: tuple = ()

    def __post_init__(self):
        for key in ("width", "height"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= 8192:
                raise InputError(f"must be a whole number of pixels from 1 to 8192, got {value!r}", key)
        fov = self.fov_deg
        if isinstance(fov, bool) or not isinstance(fov, (int, float)) or not (0.0 < fov < 180.0):
            raise InputError(f"must be a number of degrees between 0 and 180, got {fov!r}", "fov_deg")
        if not (isinstance(self.max_distance, (int, float)) and self.max_distance > 0):
            raise InputError(f"must be a positive number of metres, got {self.max_distance!r}", "max_distance")
        if not (self.track in (None, "point", "com") or callable(self.track)):
            raise InputError(f"expected 'point', 'com', a function or None, got {self.track!r}", "track")
        if self.track is not None and self.body is None:
            raise InputError("a tracking camera needs the body it follows", "track")
        self.position = finite_vector(self.position, "position")
        self.target = finite_vector(self.target, "target")
        self.up = finite_vector(self.up, "up")
        self._axes(np.eye(3))  # the pose's own checks

    @property
    def intrinsics(self) -> np.ndarray:
        """(3, 3) K: focal length f in pixels, principal point at the image's centre."""
        f = 0.5 * self.height / math.tan(math.radians(0.5 * self.fov_deg))
        return np.array([[f, 0.0, 0.5 * self.width], [0.0, f, 0.5 * self.height], [0.0, 0.0, 1.0]])

    def _axes(self, R_body):
        """(3, 3) the camera's axes (x right, y down, z forward) as columns, in the frame of R_body."""
        forward = R_body @ (self.target - self.position)
        n = float(np.linalg.norm(forward))
        if n < 1e-12:
            raise InputError("the target is at the camera's position", "target")
        z = forward / n
        right = np.cross(z, R_body @ self.up)
        n = float(np.linalg.norm(right))
        if n < 1e-9 * max(float(np.linalg.norm(self.up)), 1e-300):
            raise InputError("up is along the line of sight (or zero): the image's top is undefined", "up")
        x = right / n
        return np.column_stack([x, np.cross(z, x), z])

    def pose(self, world) -> tuple[np.ndarray, np.ndarray]:
        """The camera's centre (3,) m and axes (3, 3) (columns x right, y down, z forward), world,
        at the world's present state."""
        if self.body is None:
            return self.position.copy(), self._axes(np.eye(3))
        i = world.index_of(self.body)
        Rb = np.asarray(world.R[i], dtype=float)
        origin = np.asarray(world.x[i], dtype=float) - Rb @ np.asarray(world.com_offset[i], dtype=float)
        if self.track == "point":
            return origin + Rb @ finite_vector(self.point, "point") + self.position, self._axes(np.eye(3))
        if callable(self.track):
            return finite_vector(self.track(world), "track") + self.position, self._axes(np.eye(3))
        if self.track == "com":
            idx = np.asarray(self.bodies if len(self.bodies) else [i], dtype=np.int64)
            m = np.asarray(world.mass, dtype=float)[idx]
            com = m @ np.asarray(world.x, dtype=float)[idx] / m.sum()
            return com + self.position, self._axes(np.eye(3))
        return origin + Rb @ self.position, self._axes(Rb)

    def rays(self, world) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(centre (3,), axes (3, 3), directions (H, W, 3) unit, world) of the pixels' rays."""
        c, axes = self.pose(world)
        K = self.intrinsics
        u = (np.arange(self.width) + 0.5 - K[0, 2]) / K[0, 0]
        v = (np.arange(self.height) + 0.5 - K[1, 2]) / K[1, 1]
        d = np.empty((self.height, self.width, 3))
        d[..., 0] = u[None, :]
        d[..., 1] = v[:, None]
        d[..., 2] = 1.0
        d /= np.linalg.norm(d, axis=2, keepdims=True)
        return c, axes, d @ axes.T

    def capture(self, world) -> CameraImage:
        """The images of ``world`` at its present state (``CameraImage``): one compiled pass over the
        pixels (``collision.raycast.image_kernel``: the rays of ``rays``, their casts as
        ``World.ray_cast``'s, the shading)."""
        from .collision.raycast import cast_image
        from .visual import palette_colors

        c, axes = self.pose(world)
        K = self.intrinsics
        exclude = -1
        if self.body is not None and self.exclude_body:
            exclude = world.index_of(self.body)
        colors = palette_colors(~(np.asarray(world.moving, bool) | np.asarray(world.kinematic, bool)))
        depth, distance, body, point, normal, rgb = cast_image(
            world, c, axes, K[0, 0], K[0, 2], K[1, 2], self.width, self.height, float(self.max_distance), exclude,
            int(self.mask), colors, SKY, AMBIENT, DIFFUSE)
        return CameraImage(depth=depth, distance=distance, body=body, point=point, normal=normal, rgb=rgb,
                           position=c, rotation=axes, intrinsics=K)
