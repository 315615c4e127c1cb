"""glTF 2.0 binary (.glb) export of a trajectory: one node per body, one animation.

What the file holds (so that a reader can get the trajectory back):

* ``scenes[0]`` has one root node, ``"tumble (z up)"``, whose only transform is
  a rotation of -90 degrees about x: it turns tumble's z-up world into glTF's
  y-up one (world z becomes glTF +y, world y becomes glTF -z, as Blender's
  importer expects). Everything under it is in tumble's z-up world, metres.
* One child node per body, in body order, named after the body. Its
  translation is the body's **centre of mass** (``traj.position``) and its
  rotation is ``traj.orientation`` as glTF's (x, y, z, w); its mesh is in the
  body frame (origin at the centre of mass), i.e. the shape's mesh shifted by
  ``-com_offset``, so the mesh appears where the user put the shape. The shape's
  origin is at ``translation - R com_offset``. The node's static transform is
  the first frame's; ``extras`` has ``body_index``, ``com_offset`` and ``fixed``.
* One animation, ``"trajectory"``, with a translation and a rotation channel
  (LINEAR) per moving body, keyed at ``traj.time`` (seconds). Fixed bodies have
  no channels. Quaternion signs are made continuous from frame to frame, so
  interpolation takes the short way; a stored key may be ``-q`` of the
  trajectory's (the same rotation).
* A body out of the simulation at some frames (``World.set_enabled``:
  ``Trajectory.enabled`` False there), fixed or not, has a scale channel too,
  keyed at every frame: (0, 0, 0) where it is disabled, (1, 1, 1) where it is
  enabled, STEP, so that it vanishes and appears at once instead of shrinking
  and growing between two frames. Its node's static scale is the first frame's
  (0 for a body absent at the start), and ``extras`` has ``"hidden_frames": true``.
  Bodies present throughout have no scale (the file is what it was before
  bodies could be disabled).
* Accessors are float32 (glTF allows nothing else for these): a reader gets
  each value rounded to the nearest float32.

The GLB container is written by hand (a 12-byte header, a JSON chunk, a BIN
chunk; glTF 2.0 spec, "Binary glTF Layout"): it needs nothing beyond NumPy,
and the file is checked with the Khronos glTF validator in the tests.
"""

from __future__ import annotations

import json
import math
import struct
from pathlib import Path

import numpy as np

from ..errors import InputError
from .meshes import (
    absent_flags,
    body_color,
    body_meshes,
    continuous_quaternions,
    enabled_flags,
    fixed_flags,
    sensor_flags,
    SENSOR_OPACITY,
    srgb_to_linear,
)

# glTF constants (spec, "Accessor", "Buffer view")
FLOAT, UNSIGNED_INT = 5126, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
GLB_MAGIC, GLB_VERSION, CHUNK_JSON, CHUNK_BIN = 0x46546C67, 2, 0x4E4F534A, 0x004E4942
# Rotation of the root node, glTF (x, y, z, w): -90 degrees about x, z up -> y up.
Z_UP_TO_Y_UP = (-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))
ROOT_NAME = "tumble (z up)"
FLOAT32_MAX = float(np.finfo(np.float32).max)
ANIMATION_NAME = "trajectory"


class _Builder:
    """Accumulates the binary buffer and the JSON arrays of bufferViews and accessors."""

    def __init__(self):
        self.chunks: list[bytes] = []
        self.length = 0
        self.buffer_views: list[dict] = []
        self.accessors: list[dict] = []

    def accessor(self, data: np.ndarray, kind: str, component: int, target: int | None = None, minmax: bool = False) -> int:
        array = np.ascontiguousarray(data, dtype=np.float32 if component == FLOAT else np.uint32)
        raw = array.tobytes()
        view = {"buffer": 0, "byteOffset": self.length, "byteLength": len(raw)}
        if target is not None:
            view["target"] = target
        self.chunks.append(raw)
        pad = (-len(raw)) % 4  # every view starts 4-byte aligned
        if pad:
            self.chunks.append(b"\0" * pad)
        self.length += len(raw) + pad
        self.buffer_views.append(view)
        count = len(array) if array.ndim else 1
        acc = {"bufferView": len(self.buffer_views) - 1, "componentType": component, "count": count, "type": kind}
        if minmax and count:
            flat = array.reshape(count, -1)
            # float32 -> Python float is exact, and JSON keeps every digit: min/max match the data exactly
            cast = float if component == FLOAT else int
            acc["min"] = [cast(v) for v in flat.min(axis=0)]
            acc["max"] = [cast(v) for v in flat.max(axis=0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def binary(self) -> bytes:
        return b"".join(self.chunks)


def gltf_document(traj) -> tuple[dict, bytes]:
    """The glTF JSON (as a dict) and the binary buffer of ``traj`` (see the module's docstring)."""
    from .. import __version__
    from ..trajectory import check_trajectory

    check_trajectory(traj)  # InputError (key: time, position, ...) rather than a failure inside json.dumps
    names = [str(n) for n in traj.names]
    n_bodies = len(names)
    fixed = fixed_flags(traj)
    sensor = sensor_flags(traj)
    position = np.asarray(traj.position, dtype=float)
    orientation = np.asarray(traj.orientation, dtype=float)
    com_offset = np.asarray(traj.com_offset, dtype=float)
    time = np.asarray(traj.time, dtype=float)
    n_frames = len(time)
    if n_frames == 0 and n_bodies:
        raise ValueError("the trajectory has no frames")
    for key, values in (("time", time), ("position", position)):  # accessors are float32 (max 3.4e38)
        too_big = ~(np.abs(values) <= FLOAT32_MAX)
        if too_big.any():
            where = np.argwhere(too_big)[0]
            at = f"frame {where[0]}" + (f", body {where[1]}" if len(where) > 1 else "")
            raise InputError(f"too large for glTF's 32-bit floats at {at} (|value| > {FLOAT32_MAX:.3g})", key)
    q_cont = continuous_quaternions(orientation)
    q_xyzw = q_cont[..., [1, 2, 3, 0]]
    enabled = enabled_flags(traj)
    absent = absent_flags(enabled)  # bodies disabled at some frame: a scale channel hides them there

    b = _Builder()
    meshes, materials, nodes = [], [], []
    material_index: dict[tuple, int] = {}
    geometry_index: dict[str, tuple[int, int, int]] = {}

    root = {"name": ROOT_NAME, "rotation": list(Z_UP_TO_Y_UP), "children": list(range(1, n_bodies + 1))}
    if not n_bodies:
        del root["children"]
    nodes.append(root)

    for i, (mesh, key) in enumerate(body_meshes(traj)):
        if key not in geometry_index:  # bodies with the same shape share vertex data
            geometry_index[key] = (
                b.accessor(mesh.vertices, "VEC3", FLOAT, ARRAY_BUFFER, minmax=True),
                b.accessor(mesh.normals, "VEC3", FLOAT, ARRAY_BUFFER),
                b.accessor(mesh.faces.reshape(-1), "SCALAR", UNSIGNED_INT, ELEMENT_ARRAY_BUFFER),
            )
        pos_acc, nrm_acc, idx_acc = geometry_index[key]
        color = srgb_to_linear(body_color(i, bool(fixed[i])))
        alpha = SENSOR_OPACITY if sensor[i] else 1.0
        mat_key = (color, mesh.double_sided, alpha)
        if mat_key not in material_index:
            material_index[mat_key] = len(materials)
            material = {
                "name": f"body color {len(materials)}",
                "pbrMetallicRoughness": {"baseColorFactor": [*color, alpha], "metallicFactor": 0.0, "roughnessFactor": 0.6},
                "doubleSided": bool(mesh.double_sided),
            }
            if alpha < 1.0:  # a sensor: translucent, so what it holds shows
                material["alphaMode"] = "BLEND"
            materials.append(material)
        meshes.append({
            "name": names[i],
            "primitives": [{"attributes": {"POSITION": pos_acc, "NORMAL": nrm_acc}, "indices": idx_acc,
                            "material": material_index[mat_key], "mode": 4}],
        })
        node = {
            "name": names[i],
            "mesh": i,
            "translation": [float(v) for v in position[0, i]],
            "rotation": [float(v) for v in q_xyzw[0, i] / np.linalg.norm(q_xyzw[0, i])],
            "extras": {"body_index": i, "com_offset": [float(v) for v in com_offset[i]], "fixed": bool(fixed[i]),
                       **({"sensor": True} if sensor[i] else {})},
        }
        if absent[i]:
            node["extras"]["hidden_frames"] = True
            if not enabled[0, i]:  # the static pose (a reader that plays no animation) is frame 0's: hidden
                node["scale"] = [0.0, 0.0, 0.0]
        nodes.append(node)

    animations = []
    animated = [i for i in range(n_bodies) if not fixed[i] or absent[i]]
    if animated and n_frames:
        times = b.accessor(time, "SCALAR", FLOAT, minmax=True)  # min/max are required on sampler inputs
        samplers, channels = [], []
        interpolation = "LINEAR" if n_frames > 1 else "STEP"
        for i in animated:
            tracks = [] if fixed[i] else [("translation", position[:, i], "VEC3", interpolation),
                                          ("rotation", q_xyzw[:, i], "VEC4", interpolation)]
            if absent[i]:  # after the body's other tracks: a file without disabled bodies keeps its bytes
                scale = np.repeat(enabled[:, i, None].astype(np.float32), 3, axis=1)
                tracks.append(("scale", scale, "VEC3", "STEP"))
            for path, values, kind, how in tracks:
                samplers.append({"input": times, "output": b.accessor(values, kind, FLOAT), "interpolation": how})
                channels.append({"sampler": len(samplers) - 1, "target": {"node": i + 1, "path": path}})
        animations.append({"name": ANIMATION_NAME, "samplers": samplers, "channels": channels})

    binary = b.binary()
    doc = {
        "asset": {"version": "2.0", "generator": f"tumble {__version__}",
                  "extras": {"up_axis": "z (root node turns it to glTF's y)", "units": "metres",
                             "node_translation": "centre of mass", "frames": n_frames}},
        "scene": 0,
        "scenes": [{"name": "tumble", "nodes": [0]}],
        "nodes": nodes,
    }
    if meshes:
        doc["meshes"] = meshes
        doc["materials"] = materials
    if animations:
        doc["animations"] = animations
    if b.accessors:
        doc["accessors"] = b.accessors
        doc["bufferViews"] = b.buffer_views
        doc["buffers"] = [{"byteLength": len(binary)}]
    return doc, binary


def glb_bytes(doc: dict, binary: bytes) -> bytes:
    """Pack a glTF JSON document and its buffer into the GLB container."""
    text = json.dumps(doc, separators=(",", ":"), allow_nan=False).encode("utf-8")
    text += b" " * ((-len(text)) % 4)  # the JSON chunk is padded with spaces, the BIN chunk with zeros
    binary = binary + b"\0" * ((-len(binary)) % 4)
    parts = [struct.pack("<II", len(text), CHUNK_JSON), text]
    if binary:
        parts += [struct.pack("<II", len(binary), CHUNK_BIN), binary]
    body = b"".join(parts)
    return struct.pack("<III", GLB_MAGIC, GLB_VERSION, 12 + len(body)) + body


def export_gltf(traj, path) -> Path:
    """Write ``traj`` as a binary glTF 2.0 file (.glb) at ``path``, atomically; returns the path.

    See the module's docstring for what the file holds: per body a node whose
    translation is the centre of mass and whose rotation is the orientation, with
    the body's mesh in the body frame, under a root node that turns z up into
    glTF's y up, and one animation sampled at ``traj.time``.
    """
    from ..trajectory import write_atomic

    data = glb_bytes(*gltf_document(traj))
    return write_atomic(path, lambda fh: fh.write(data))
