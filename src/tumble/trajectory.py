"""Trajectory: the recorded frames of a run, and its file (``trajectory.npz``, DESIGN.md).

Every array has frames along axis 0 and bodies along axis 1. The file loads
with ``np.load(path, allow_pickle=False)``; it is written under a temporary
name and renamed into place, so no reader ever sees half a file.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from .errors import InputError


@dataclass
class Trajectory:
    """Recorded frames of a run.

    Attributes (F frames, N bodies; world frame unless said):
        time: (F,) s.  names: (N,) body names.
        position: (F, N, 3) centre of mass, m.
        orientation: (F, N, 4) unit quaternion (w, x, y, z), body to world.
        velocity: (F, N, 3) m/s.  angular_velocity: (F, N, 3) rad/s.
        linear_momentum: (F, N, 3) P, kg m/s.
        angular_momentum: (F, N, 3) L about the centre of mass, kg m^2/s.
        kinetic_energy: (F,) J, total.  potential_energy: (F,) J, gravity and springs.
        total_linear_momentum: (F, 3) sum of P over moving bodies.
        total_angular_momentum: (F, 3) sum of L + x cross P, about the world origin.
        orthonormality_error: (F,) largest |R^T R - 1| entry (|q|^2 - 1 for quaternions).
        com_offset: (N, 3) m, centre of mass seen from each shape's origin, body frame
            (the shape origin is at position - R com_offset), for display and export.
        shapes: (N,) JSON text of each body's shape (``shapes.shape_to_dict``), so that
            the file alone is enough to draw and export the bodies (None in old files).
        fixed: (N,) bool, True for fixed bodies (None in old files).
    """

    time: np.ndarray
    names: np.ndarray
    position: np.ndarray
    orientation: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    linear_momentum: np.ndarray
    angular_momentum: np.ndarray
    kinetic_energy: np.ndarray
    potential_energy: np.ndarray
    total_linear_momentum: np.ndarray
    total_angular_momentum: np.ndarray
    orthonormality_error: np.ndarray
    com_offset: np.ndarray
    shapes: np.ndarray | None = None
    fixed: np.ndarray | None = None

    OPTIONAL = ("shapes", "fixed")

    @property
    def frame_count(self) -> int:
        return len(self.time)

    @property
    def total_energy(self) -> np.ndarray:
        return self.kinetic_energy + self.potential_energy

    def shape(self, index: int):
        """The shape record of body ``index`` (rebuilt from ``shapes``), or None."""
        if self.shapes is None:
            return None
        from .shapes import shape_from_dict

        return shape_from_dict(json.loads(str(self.shapes[index])))

    def body(self, name: str) -> int:
        """Column index of the body called ``name``."""
        hits = np.flatnonzero(self.names == name)
        if len(hits) == 0:
            raise KeyError(name)
        return int(hits[0])

    def save(self, path) -> Path:
        """Write the .npz atomically (temporary file in the same folder, then rename)."""
        arrays = {f.name: np.asarray(getattr(self, f.name)) for f in fields(self) if getattr(self, f.name) is not None}
        arrays["names"] = np.asarray(self.names, dtype=str)
        if self.shapes is not None:
            arrays["shapes"] = np.asarray(self.shapes, dtype=str)
        return write_atomic(path, lambda fh: np.savez_compressed(fh, **arrays))


def load_trajectory(path) -> Trajectory:
    """Read a trajectory file written by ``Trajectory.save`` (no pickles)."""
    path = Path(path)
    if not path.is_file():
        raise InputError("trajectory file not found", None, str(path))
    try:
        with np.load(path, allow_pickle=False) as data:
            values = {f.name: data[f.name] for f in fields(Trajectory) if f.name in data.files}
    except Exception as exc:  # a damaged or foreign file: one clear line
        raise InputError(f"not a readable trajectory file ({type(exc).__name__}: {exc})", None, str(path)) from None
    missing = [f.name for f in fields(Trajectory) if f.name not in values and f.name not in Trajectory.OPTIONAL]
    if missing:
        raise InputError(f"not a trajectory file: missing {', '.join(missing)}", None, str(path))
    return Trajectory(**values)


def write_atomic(path, write) -> Path:
    """Call ``write(binary file)`` on a temporary file beside ``path``, then rename it into place.

    A reader sees the old file or the whole new one, never half a file; the new
    file gets the ordinary permissions of the umask (mkstemp makes 0600).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def write_json_atomic(path, obj) -> Path:
    """Write ``obj`` as indented JSON, atomically (``write_atomic``)."""
    text = json.dumps(obj, indent=2, default=_json_default) + "\n"
    return write_atomic(path, lambda fh: fh.write(text.encode()))


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")
