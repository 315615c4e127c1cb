"""Scene files: the ``[[cameras]]`` entries, and the camera images of a run (``tumble run --images``).

Each entry is one ``tumble.Camera`` (docs/viewing.md, "Camera images")::

    [[cameras]]
    name = "overhead"              # required: the images' folder name
    position = [3, 0, 1.5]         # m, world (or the body's frame with body = ...)
    target = [0, 0, 0.5]
    up = [0, 0, 1]
    fov_deg = 60                   # vertical field of view
    width = 160                    # pixels
    height = 120
    body = "robot/hand"            # optional: mounted on this body (moves with it)
    track = "point"                # optional with body: follow it without turning ("point" or "com")

``write_images`` captures every camera at every recorded frame of a run from the poses in its
trajectory (a camera sees positions and orientations only, so the images need no solver state and
come out the same for a resumed run): ``images/NAME/rgb_00000.png``, ... and ``images/NAME.npz``
with ``depth`` (F, H, W) m float32 (inf: nothing hit), ``body`` (F, H, W) int32 (the segmentation,
-1: nothing), ``time`` (F,) s, ``position`` (F, 3) and ``rotation`` (F, 3, 3) the camera's pose,
``intrinsics`` (3, 3) K, and ``body_names``.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .camera import Camera
from .errors import InputError
from .scene_joints import _number, _vector
from .scene_values import _describe

CAMERA_KEYS = ("name", "position", "target", "up", "fov_deg", "width", "height", "max_distance", "body",
               "exclude_body", "track", "point")


def parse_cameras(entries, world, file: str | None = None) -> dict:
    """The ``[[cameras]]`` entries as {name: Camera}, checked (bodies against ``world``).

    Raises:
        InputError: ``FILE: cameras[i].KEY: problem`` for the first problem found.
    """
    if entries is None:
        return {}
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise InputError(f"expected a list of tables ([[cameras]]), got {_describe(entries)}", "cameras", file)
    cameras: dict = {}
    for i, entry in enumerate(entries):
        key = f"cameras[{i}]"
        for k in entry:
            if k not in CAMERA_KEYS:
                raise InputError(f"unknown key (expected one of {', '.join(CAMERA_KEYS)})", f"{key}.{k}", file)
        name = entry.get("name")
        if name is None:
            raise InputError("missing key 'name'", key, file)
        if not isinstance(name, str) or not name or os.sep in name or name in (".", ".."):
            raise InputError(f"expected a name usable as a folder name, got {_describe(name)}", f"{key}.name", file)
        if name in cameras:
            raise InputError(f"duplicate camera name {name!r}", f"{key}.name", file)
        kw = {}
        for k, v in entry.items():
            sub = f"{key}.{k}"
            if k in ("position", "target", "up", "point"):
                kw[k] = _vector(v, sub, file)
            elif k in ("fov_deg", "max_distance"):
                kw[k] = _number(v, sub, file, unbounded=k == "max_distance")
            elif k in ("width", "height"):
                if isinstance(v, bool) or not isinstance(v, int):
                    raise InputError(f"expected a whole number of pixels, got {_describe(v)}", sub, file)
                kw[k] = v
            elif k == "body":
                if not isinstance(v, str) or v not in world.names:
                    raise InputError(f"unknown body {v!r}", sub, file)
                kw[k] = v
            elif k == "exclude_body":
                if not isinstance(v, bool):
                    raise InputError(f"expected true or false, got {_describe(v)}", sub, file)
                kw[k] = v
            elif k == "track":
                if v not in ("point", "com"):
                    raise InputError(f"expected \"point\" or \"com\", got {_describe(v)}", sub, file)
                kw[k] = v
        try:
            cameras[name] = Camera(**kw)
        except InputError as err:
            raise err.within(key, file) from None
    return cameras


def pose_frame(world, traj, f: int):
    """Put ``world``'s bodies at frame ``f`` of ``traj`` (positions and orientations; at rest)."""
    n = world.body_count
    Y = world.pack()
    Y[:, :3] = traj.position[f, :n]
    q = np.asarray(traj.orientation[f, :n], dtype=float)
    if world.layout == "matrix":
        from .math3d import quat_to_matrix

        Y[:, 3:12] = np.array([quat_to_matrix(qi).ravel() for qi in q])
    else:
        Y[:, 3:7] = q
    W = world.state_size
    Y[:, W - 6:] = 0.0
    world.unpack(Y)


def write_images(out_dir, world, cameras: dict, traj) -> list[Path]:
    """Capture each camera at every frame of ``traj`` (a run of ``world``'s scene) into
    ``out_dir/images`` (module docstring). Returns the files written (the .npz files last of
    each camera). Needs imageio (the ``render`` extra)."""
    import imageio.v3 as iio

    out = Path(out_dir) / "images"
    written = []
    frames = traj.position.shape[0]
    for name, cam in cameras.items():
        folder = out / name
        folder.mkdir(parents=True, exist_ok=True)
        for old in folder.glob("rgb_*.png"):  # an earlier run's frames (tumble run --force): not mixed in
            old.unlink()
        depth = np.empty((frames, cam.height, cam.width), dtype=np.float32)
        body = np.empty((frames, cam.height, cam.width), dtype=np.int32)
        position = np.empty((frames, 3))
        rotation = np.empty((frames, 3, 3))
        for f in range(frames):
            pose_frame(world, traj, f)
            img = cam.capture(world)
            depth[f] = img.depth
            body[f] = img.body
            position[f] = img.position
            rotation[f] = img.rotation
            path = folder / f"rgb_{f:05d}.png"
            iio.imwrite(path, img.rgb)
            written.append(path)
        npz = out / f"{name}.npz"
        tmp = npz.with_suffix(".tmp.npz")
        np.savez_compressed(tmp, depth=depth, body=body, time=np.asarray(traj.time, dtype=float), position=position,
                            rotation=rotation, intrinsics=cam.intrinsics, body_names=np.array(world.names, dtype=str))
        os.replace(tmp, npz)  # whole or not at all
        written.append(npz)
    return written
