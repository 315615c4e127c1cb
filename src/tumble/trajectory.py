"""Trajectory: the recorded frames of a run, and its file (``trajectory.npz``, DESIGN.md).

Every array has frames along axis 0 and bodies along axis 1. The file loads
with ``np.load(path, allow_pickle=False)``; it is written under a temporary
name and renamed into place, so no reader ever sees half a file.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
import zipfile
from dataclasses import InitVar, dataclass, fields
from pathlib import Path

import numpy as np

from .errors import InputError


_UNSET = object()  # Trajectory(shapes=...) not given


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
        shape_table: (K,) str, each distinct body shape once, as JSON text
            (``shapes.shape_to_dict``), so that the file alone is enough to draw and export the
            bodies; shape_index: (N,) int64, body i's row of the table (both None in old files
            and for trajectories without shapes). Kept as a table so that a pile of equal balls
            over one large mesh stores the mesh once, not N times padded to its length.
        shapes: (N,) str, body i's JSON text (``shape_table[shape_index]``): the older form, built
            on first use; files written before the table (a ``shapes`` key) still load, and
            ``Trajectory(shapes=...)`` still builds one. ``shape_text(i)`` / ``shape(i)`` read
            one body's without building it.
        fixed: (N,) bool, True for fixed bodies (None in old files).
        sensor: (N,) bool, True for sensors (touch nothing; drawn translucent), written only
            when the world has one (None otherwise).

    Contacts, when the run recorded them (``record_contacts``; else None). C is the largest
    number of contact points of any frame; frame k uses its first ``contact_count[k]`` rows, the
    others are padding (-1 for bodies, NaN for numbers). All are the last step before the frame:
        contact_count: (F,) int64.
        contact_body_a, contact_body_b: (F, C) int64 body indices; normals point from a to b.
        contact_point: (F, C, 3) m, world.  contact_normal: (F, C, 3) unit, world.
        contact_separation: (F, C) m (< 0: penetration).
        contact_normal_impulse: (F, C) N s, on b over the step.
        contact_friction_impulse: (F, C, 3) N s, on b over the step, world.
        contact_force: (F, C, 3) N, mean force on b over the step (impulses / dt).

    Joints, when the run recorded them (``record_joints``; else None), J joints in the order
    they were added:
        joint_names: (J,) their names ("" when unnamed).
        joint_position: (F, J) rad or m, the joint coordinate.  joint_rate: (F, J) its rate.
        joint_force: (F, J, 3) N and joint_torque: (F, J, 3) N m, reaction on body b, world.
        joint_enabled: (F, J) 1.0 while the joint acts, 0.0 once broken.

    Sensors, when the world has any (else None), K sensors in body order (``sensor`` flags):
        sensor_visitors: (F, K) how many bodies overlap each sensor at the frame
            (``Simulator.sensor_overlaps``; frame 0 at the run's start).

    Bodies out of the simulation (``World.set_enabled``), when some body was at some frame (else
    None: every body present throughout):
        enabled_changes: (K, 3) int64 rows (frame, body, 1 enabled / 0 disabled), in frame order:
            the body is so from that frame on (a body disabled at the first frame has a row at
            frame 0). ``enabled`` unfolds them into (F, N) bool. Kept as changes, not per frame,
            so that a streamed file's memory does not grow with the run.
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
    # not a field: the (N,) form, given to the constructor (old files, older callers); the
    # ``shapes`` property set below reads it back from the table
    shapes: InitVar[np.ndarray | None] = _UNSET
    shape_table: np.ndarray | None = None
    shape_index: np.ndarray | None = None
    fixed: np.ndarray | None = None
    sensor: np.ndarray | None = None
    contact_count: np.ndarray | None = None
    contact_body_a: np.ndarray | None = None
    contact_body_b: np.ndarray | None = None
    contact_point: np.ndarray | None = None
    contact_normal: np.ndarray | None = None
    contact_separation: np.ndarray | None = None
    contact_normal_impulse: np.ndarray | None = None
    contact_friction_impulse: np.ndarray | None = None
    contact_force: np.ndarray | None = None
    joint_names: np.ndarray | None = None
    joint_position: np.ndarray | None = None
    joint_rate: np.ndarray | None = None
    joint_force: np.ndarray | None = None
    joint_torque: np.ndarray | None = None
    joint_enabled: np.ndarray | None = None
    sensor_visitors: np.ndarray | None = None
    enabled_changes: np.ndarray | None = None

    OPTIONAL = ("enabled_changes", "sensor_visitors", "joint_names", "joint_position", "joint_rate", "joint_force", "joint_torque", "joint_enabled",
                "shapes", "shape_table", "shape_index", "fixed", "sensor", "contact_count", "contact_body_a", "contact_body_b", "contact_point",
                "contact_normal", "contact_separation", "contact_normal_impulse", "contact_friction_impulse",
                "contact_force")

    def __post_init__(self, shapes):
        if shapes is not _UNSET:  # given: it wins over any table (dataclasses.replace(traj, shapes=None) drops them)
            self.shape_table, self.shape_index = shape_table_of(shapes)

    def shape_text(self, index: int) -> str | None:
        """The JSON text of body ``index``'s shape, or None when the trajectory has no shapes."""
        if self.shape_table is None:
            return None
        return str(self.shape_table[int(self.shape_index[index])])

    @property
    def frame_count(self) -> int:
        return len(self.time)

    @property
    def total_energy(self) -> np.ndarray:
        return self.kinetic_energy + self.potential_energy

    @property
    def enabled(self) -> np.ndarray:
        """(F, N) bool: whether each body is in the simulation at each frame (``enabled_changes``
        unfolded; all True when the file has none). The exports hide a body where it is False."""
        return unfold_enabled(self.enabled_changes, self.frame_count, len(self.names))

    def shape(self, index: int):
        """The shape record of body ``index`` (rebuilt from its JSON, ``shape_text``), or None."""
        text = self.shape_text(index)
        if text is None:
            return None
        from .shapes import shape_from_dict

        return shape_from_dict(json.loads(text))

    def body(self, name: str) -> int:
        """Column index of the body called ``name``."""
        hits = np.flatnonzero(self.names == name)
        if len(hits) == 0:
            raise KeyError(name)
        return int(hits[0])

    def show(self, height: int = 480, title: str | None = None):
        """The run as a web page in a notebook cell (Jupyter shows the returned ``HtmlView``: the
        glTF animation in Google's model-viewer, play, pause, a time slider; no server, no network;
        ``.save("run.html")`` keeps it). ``tumble.export.html``."""
        from .export.html import HtmlView

        return HtmlView(self, height=height, title=title)

    def save(self, path, compress: bool = True) -> Path:
        """Write the .npz atomically (temporary file in the same folder, then rename).

        ``compress``: deflate each array (zlib level 1: ``np.savez_compressed``'s level 6 spent 1.4x
        the time for a file 2 % smaller; docs/benchmarks.md, "Saving a trajectory"), or store them as
        they are (``np.savez``'s file: 8-14x faster for big contact recordings, whose float rows barely
        compress, about twice the bytes). Either way ``np.load`` reads it, and the entries carry a fixed
        time (as ``np.savez``'s do), so the same run gives the same file bytes.
        """
        arrays = {f.name: np.asarray(getattr(self, f.name)) for f in fields(self) if getattr(self, f.name) is not None}
        arrays["names"] = np.asarray(self.names, dtype=str)
        if self.joint_names is not None:
            arrays["joint_names"] = np.asarray(self.joint_names, dtype=str)
        if self.shape_table is not None:
            arrays["shape_table"] = np.asarray(self.shape_table, dtype=str)
            arrays["shape_index"] = np.asarray(self.shape_index, dtype=np.int64)
        method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED

        def write(fh):
            with zipfile.ZipFile(fh, "w", compression=method, compresslevel=1 if compress else None, allowZip64=True) as zf:
                for key, value in arrays.items():
                    info = zipfile.ZipInfo(f"{key}.npy", date_time=_ZIP_TIME)
                    info.compress_type = method
                    if compress:  # ZipFile.open(ZipInfo) takes the entry's level, not the file's
                        try:
                            info.compress_level = 1  # Python 3.13's name
                        except AttributeError:
                            info._compresslevel = 1  # before 3.13 (ZipInfo has slots)
                    with zf.open(info, "w", force_zip64=True) as out:
                        np.lib.format.write_array(out, value, allow_pickle=False)

        return write_atomic(path, write)


def _get_shapes(self):
    if self.shape_table is None:
        return None
    # built once per table: the (N,) fixed-width form pads every body to the longest JSON
    key = (id(self.shape_table), id(self.shape_index))
    cached = self.__dict__.get("_shapes_cache")
    if cached is None or cached[0] != key:
        cached = (key, np.asarray(self.shape_table, dtype=str)[np.asarray(self.shape_index, dtype=np.int64)])
        self.__dict__["_shapes_cache"] = cached
    return cached[1]


def _set_shapes(self, shapes):
    self.shape_table, self.shape_index = shape_table_of(shapes)


Trajectory.shapes = property(_get_shapes, _set_shapes, doc="(N,) str: each body's shape JSON (see the class docstring).")


def shape_table_of(shapes) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``(shape_table, shape_index)`` of the (N,) JSON texts ``shapes`` (None: (None, None)): each
    distinct text once, in order of first use, and each body's row of it ((K,) str, (N,) int64)."""
    if shapes is None:
        return None, None
    rows: dict[str, int] = {}
    index = np.array([rows.setdefault(str(text), len(rows)) for text in np.asarray(shapes).reshape(-1)], dtype=np.int64)
    return np.array(list(rows), dtype=str).reshape(len(rows)), index


def unfold_enabled(changes, frames: int, bodies: int) -> np.ndarray:
    """(F, N) bool from ``Trajectory.enabled_changes`` rows (frame, body, 0/1) (None: all True)."""
    out = np.ones((frames, bodies), dtype=bool)
    if changes is None:
        return out
    for frame, body, on in np.asarray(changes, dtype=np.int64).reshape(-1, 3).tolist():
        if 0 <= frame < frames and 0 <= body < bodies:
            out[frame:, body] = bool(on)
    return out


class EnabledLog:
    """The rows of ``Trajectory.enabled_changes`` gathered frame by frame (the recorder's and the
    streamed writer's): a row where a body's ``World.disabled`` flag differs from the frame
    before's (at the first frame, from enabled)."""

    def __init__(self, body_count: int, rows=()):
        self.rows = [tuple(int(v) for v in r) for r in rows]
        self.last = np.zeros(body_count, dtype=bool)  # disabled at the last frame observed
        self._replay()

    def _replay(self):
        self.last[:] = False
        for _, body, on in self.rows:
            if body < len(self.last):
                self.last[body] = not on

    def observe(self, frame: int, disabled: np.ndarray) -> bool:
        """Note the flags ``disabled`` (N,) bool at frame ``frame``; returns whether a row was added."""
        if disabled.shape != self.last.shape:  # bodies added since: they start enabled
            last = np.zeros(disabled.shape, dtype=bool)
            last[: min(len(last), len(self.last))] = self.last[: len(last)]
            self.last = last
        changed = np.flatnonzero(disabled != self.last)
        if len(changed):
            self.rows.extend((int(frame), int(i), int(not disabled[i])) for i in changed)
            self.last = disabled.copy()
        return bool(len(changed))

    def truncate(self, frames: int):
        """Keep the rows of the first ``frames`` frames only."""
        self.rows = [r for r in self.rows if r[0] < frames]
        self._replay()

    def array(self):
        """(K, 3) int64, or None when no body was ever disabled."""
        return np.array(self.rows, dtype=np.int64).reshape(-1, 3) if self.rows else None


def joint_frame_shapes(joint_count: int) -> dict:
    """Per-frame joint keys of a trajectory and the shape of one frame (J joints)."""
    J = joint_count
    return {"joint_position": (J,), "joint_rate": (J,), "joint_force": (J, 3), "joint_torque": (J, 3),
            "joint_enabled": (J,)}


# The contact keys of a trajectory: field of ``Contacts`` -> (key, row shape, dtype, padding).
CONTACT_FIELDS = {
    "body_a": ("contact_body_a", (), np.int64, -1), "body_b": ("contact_body_b", (), np.int64, -1),
    "point": ("contact_point", (3,), np.float64, np.nan), "normal": ("contact_normal", (3,), np.float64, np.nan),
    "separation": ("contact_separation", (), np.float64, np.nan),
    "normal_impulse": ("contact_normal_impulse", (), np.float64, np.nan),
    "friction_impulse": ("contact_friction_impulse", (3,), np.float64, np.nan),
    "force": ("contact_force", (3,), np.float64, np.nan),
}


def pad_contacts(counts, rows: dict) -> dict:
    """The padded (F, C, ...) contact arrays of a trajectory from per-frame counts (F,) and the
    frames' rows laid end to end, ``rows[field]`` (sum(counts), ...) per ``CONTACT_FIELDS`` field."""
    starts = np.concatenate([[0], np.cumsum(np.asarray(counts, dtype=np.int64))])
    # each frame's rows as views of ``rows`` (no copy), padded by ``pad_contact_frames``
    src = [np.asarray(rows[field]) for field in CONTACT_FIELDS]
    frames = [tuple(a[starts[k]:starts[k + 1]] for a in src) for k in range(len(starts) - 1)]
    return pad_contact_frames(frames)


def pad_contact_frames(frames) -> dict:
    """``pad_contacts`` of frames given one by one: ``frames`` a list of tuples of each frame's rows,
    one array per ``CONTACT_FIELDS`` field in its order. Fills the padded arrays frame by frame
    (PERF: no concatenated copy of every row first: the peak held the rows three times over, 4.75
    GB for 1.2 GB of contacts; a performance audit, session 43)."""
    counts = np.array([len(f[0]) for f in frames], dtype=np.int64)
    F = len(counts)
    C = int(counts.max()) if F else 0
    out = {"contact_count": counts}
    for i, (key, shape, dtype, pad) in enumerate(CONTACT_FIELDS.values()):
        a = np.full((F, C) + shape, pad, dtype=dtype)
        for k, frame in enumerate(frames):
            a[k, : counts[k]] = frame[i]
        out[key] = a
    return out


def load_trajectory(path, check: bool = True) -> Trajectory:
    """Read a trajectory file written by ``Trajectory.save`` (no pickles).

    ``check`` (default): refuse a file whose values cannot be drawn or exported (``check_trajectory``:
    non-finite positions or times, times not increasing, orientations not unit quaternions, a shape
    text that is not a shape's JSON) with an ``InputError`` naming the file and the key."""
    path = Path(path)
    if not path.is_file():
        raise InputError("trajectory file not found", None, str(path))
    try:
        # our own handle: np.load leaks its own when the zip is damaged
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as data:
            values = {f.name: data[f.name] for f in fields(Trajectory) if f.name in data.files}
            if "shape_table" not in values and "shapes" in data.files:  # a file from before the table
                values["shapes"] = data["shapes"]
    except Exception as exc:  # a damaged or foreign file: one clear line
        raise InputError(f"not a readable trajectory file ({type(exc).__name__}: {exc})", None, str(path)) from None
    missing = [f.name for f in fields(Trajectory) if f.name not in values and f.name not in Trajectory.OPTIONAL]
    if missing:
        raise InputError(f"not a trajectory file: missing {', '.join(missing)}", None, str(path))
    frames, bodies = len(np.atleast_1d(values["time"])), len(np.atleast_1d(values["names"]))
    for key, shape in frame_shapes(bodies).items():
        a = values[key]
        if a.shape != (frames,) + shape or a.dtype.kind != "f":
            raise InputError(f"not a trajectory file: {key} has shape {a.shape} ({a.dtype}), expected {(frames,) + shape} numbers", None, str(path))
    if "shape_table" in values or "shape_index" in values:
        table, index = values.get("shape_table"), values.get("shape_index")
        if (table is None or index is None or table.ndim != 1 or table.dtype.kind != "U" or index.shape != (bodies,)
                or index.dtype.kind not in "iu" or (bodies and not (0 <= index.min() and index.max() < len(table)))):
            raise InputError(f"not a trajectory file: shape_table / shape_index are not {bodies} rows of a table of "
                             f"shape texts", None, str(path))
        values["shape_index"] = index.astype(np.int64)
    if "contact_count" in values:  # streamed files keep it as float64 beside the other frame keys
        values["contact_count"] = np.asarray(values["contact_count"]).astype(np.int64)
    traj = Trajectory(**values)
    if check:
        check_trajectory(traj, str(path))
    return traj


#: how far |q| of a recorded orientation may be from 1 (runs keep it within 1e-9; a file beyond
#: this was not written by a run, and its rotations cannot be drawn)
QUATERNION_NORM_TOLERANCE = 1e-3


def check_trajectory(traj, file: str | None = None) -> None:
    """Raise ``InputError`` (``FILE: KEY: problem``) if ``traj``'s values cannot be drawn or
    exported: ``time`` not finite or not strictly increasing, ``position`` not finite,
    ``orientation`` not unit quaternions (within ``QUATERNION_NORM_TOLERANCE``), a
    ``shape_table`` row that is not the JSON text of a shape. Vectorised: one pass over each
    array (the first bad frame and body are located only on failure)."""
    time = np.asarray(traj.time)
    if time.dtype.kind not in "fiu":
        raise InputError(f"expected numbers, got {time.dtype}", "time", file)
    time = time.reshape(-1).astype(float, copy=False)
    finite = np.isfinite(time)
    if not finite.all():
        k = int(np.flatnonzero(~finite)[0])
        raise InputError(f"not finite at frame {k} ({time[k]})", "time", file)
    if len(time) > 1:
        step = np.diff(time)
        if not (step > 0).all():
            k = int(np.flatnonzero(~(step > 0))[0]) + 1
            raise InputError(f"not increasing at frame {k} (t = {time[k]:.9g} after {time[k - 1]:.9g}): frame "
                             f"times must increase", "time", file)
    position = np.asarray(traj.position)
    with np.errstate(all="ignore"):
        finite = np.isfinite(position).all(axis=-1)
        if not finite.all():
            k, i = (int(v) for v in np.argwhere(~finite)[0])
            raise InputError(f"not finite at frame {k}, body {i}", "position", file)
        q = np.asarray(traj.orientation, dtype=float)
        norm = np.sqrt(np.einsum("...k,...k->...", q, q))
        good = np.abs(norm - 1.0) <= QUATERNION_NORM_TOLERANCE  # False for NaN
    if not good.all():
        k, i = (int(v) for v in np.argwhere(~good)[0])
        raise InputError(f"not a unit quaternion at frame {k}, body {i} (|q| = {norm[k, i]:.6g})", "orientation", file)
    if traj.shape_table is not None:
        from .shapes import SHAPE_TYPES

        for row, text in enumerate(np.asarray(traj.shape_table).reshape(-1).tolist()):
            try:
                d = json.loads(str(text))
            except (ValueError, RecursionError) as exc:  # JSONDecodeError is a ValueError
                raise InputError(f"row {row} is not JSON text ({exc})", "shape_table", file) from None
            kind = d.get("type") if isinstance(d, dict) else None
            if not isinstance(kind, str) or kind not in SHAPE_TYPES:
                raise InputError(f"row {row} is not a shape (expected an object whose type is one of "
                                 f"{', '.join(SHAPE_TYPES)}, got {kind!r})", "shape_table", file)


@contextlib.contextmanager
def atomic_path(path, suffix: str = ".tmp"):
    """Yield a temporary path beside ``path`` (ending in ``suffix``, for writers that pick the
    format by name); when the block ends without error, give it the ordinary permissions of
    the umask (mkstemp makes 0600) and rename it into place, else remove it.

    A reader sees the old file or the whole new one, never half a file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    try:
        yield tmp
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_atomic(path, write) -> Path:
    """Call ``write(binary file)`` on a temporary file beside ``path``, then rename it into place (``atomic_path``)."""
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        write(fh)
    return Path(path)


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


# ---------------------------------------------------------------------- streaming


# Per-frame keys of the file and the shape of one frame (N: bodies), in file order.
def frame_shapes(body_count: int) -> dict:
    n = body_count
    return {
        "time": (), "position": (n, 3), "orientation": (n, 4), "velocity": (n, 3), "angular_velocity": (n, 3),
        "linear_momentum": (n, 3), "angular_momentum": (n, 3), "kinetic_energy": (), "potential_energy": (),
        "total_linear_momentum": (3,), "total_angular_momentum": (3,), "orthonormality_error": (),
    }


def frame_bytes(body_count: int) -> int:
    """Bytes of one frame in the file (float64)."""
    return 8 * sum(int(np.prod(s)) for s in frame_shapes(body_count).values())


_COPY_CHUNK = 8 << 20  # bytes copied at a time from the raw frame files into the .npz
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # fixed entry times: the same frames give the same file bytes


class TrajectoryWriter:
    """Streams frames to disk: raw float64 rows appended to one file per key in a work folder
    (``.trajectory.parts`` beside the file), and ``flush()`` assembles the trajectory file from
    them atomically (``write_atomic``), copying in chunks, so memory does not grow with the run.

    The assembled file is an uncompressed .npz with fixed entry times: the same frames
    give the same bytes. It loads with ``load_trajectory`` / ``np.load(allow_pickle=False)``.

    Args:
        path: the trajectory file (``.../trajectory.npz``).
        static: the keys that do not change with time (names, com_offset, shape_table, shape_index, fixed).
        body_count: N.
        keep_frames: None starts afresh (any old work folder is removed); a number
            continues a run: the work folder (or, if it is missing or short, the
            trajectory file) must hold at least that many frames, and later ones are dropped.
    """

    def __init__(self, path, static: dict, body_count: int, keep_frames: int | None = None, contacts: bool = False,
                 joints: int | None = None, sensors: int | None = None):
        self.path = Path(path)
        self.parts = self.path.parent / f".{self.path.stem}.parts"
        self.static = static
        self.shapes = frame_shapes(body_count)
        if joints is not None:  # joint readings: fixed-size rows, like the bodies' keys
            self.shapes.update(joint_frame_shapes(joints))
        if sensors is not None:  # each sensor's visitor count
            self.shapes["sensor_visitors"] = (sensors,)
        if contacts:  # contact_count, one number a frame; the contact rows in their own files (ragged)
            self.shapes["contact_count"] = ()
        self.contacts = contacts
        self.row_bytes = {k: 8 * int(np.prod(s)) for k, s in self.shapes.items()}
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if keep_frames is None:
            shutil.rmtree(self.parts, ignore_errors=True)
            self.parts.mkdir()
            self.frames = 0
        else:
            self._keep(int(keep_frames))
            self.frames = int(keep_frames)
        self.files = {k: open(self.parts / f"{k}.f8", "ab") for k in self.shapes}
        if contacts:
            for field, (key, _, _, _) in CONTACT_FIELDS.items():
                self.files[key] = open(self.parts / f"{key}.rows", "ab")

    def _keep(self, frames: int):
        sizes = {k: (self.parts / f"{k}.f8").stat().st_size if (self.parts / f"{k}.f8").is_file() else -1 for k in self.shapes}
        if all(sizes[k] >= frames * self.row_bytes[k] for k in self.shapes):
            for k in self.shapes:
                os.truncate(self.parts / f"{k}.f8", frames * self.row_bytes[k])
            if self.contacts:
                rows = int(np.fromfile(self.parts / "contact_count.f8", dtype="<f8").sum())
                for field, (key, shape, _, _) in CONTACT_FIELDS.items():
                    os.truncate(self.parts / f"{key}.rows", rows * 8 * int(np.prod(shape)))
            return
        # the work folder is gone (or short): take the frames from the trajectory file
        traj = load_trajectory(self.path)
        if traj.frame_count < frames:
            raise InputError(f"holds {traj.frame_count} frames, the checkpoint needs {frames}", None, str(self.path))
        shutil.rmtree(self.parts, ignore_errors=True)
        self.parts.mkdir()
        for k in self.shapes:
            np.ascontiguousarray(getattr(traj, k)[:frames], dtype="<f8").tofile(self.parts / f"{k}.f8")
        if self.contacts:
            counts = traj.contact_count[:frames]
            for field, (key, shape, _, _) in CONTACT_FIELDS.items():
                padded = getattr(traj, key)
                rows = [padded[k, : counts[k]] for k in range(frames)]
                data = np.concatenate(rows) if rows else np.zeros((0,) + shape)
                np.ascontiguousarray(data, dtype="<i8" if key.endswith(("_a", "_b")) else "<f8").tofile(
                    self.parts / f"{key}.rows")

    def append(self, values: dict):
        """Append one frame: ``values[key]`` for every per-frame key (``frame_shapes``)."""
        for k in self.shapes:
            self.files[k].write(np.ascontiguousarray(values[k], dtype="<f8").tobytes())
        if self.contacts:
            c = values["contacts"]
            for field, (key, _, dtype, _) in CONTACT_FIELDS.items():
                self.files[key].write(np.ascontiguousarray(getattr(c, field), dtype=np.dtype(dtype).newbyteorder("<")).tobytes())
        self.frames += 1

    def flush(self) -> Path:
        """Write every frame so far to the trajectory file (atomically) and return its path."""
        for fh in self.files.values():
            fh.flush()
        return write_atomic(self.path, self._write_npz)

    def _write_npz(self, fh):
        order = [f.name for f in fields(Trajectory)]
        with zipfile.ZipFile(fh, "w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
            padded = self._padded_contacts() if self.contacts else {}
            for key in order:
                if key not in self.static and key not in self.shapes and key not in padded:
                    continue
                info = zipfile.ZipInfo(f"{key}.npy", date_time=_ZIP_TIME)
                if key in padded:
                    with zf.open(info, "w", force_zip64=True) as out:
                        np.lib.format.write_array(out, padded[key], allow_pickle=False)
                    continue
                if key == "shape_table":  # fixed-width text padded to its longest row (a mesh): deflate shrinks the padding
                    info.compress_type = zipfile.ZIP_DEFLATED
                with zf.open(info, "w", force_zip64=True) as out:
                    if key in self.static:
                        np.lib.format.write_array(out, np.asarray(self.static[key]), allow_pickle=False)
                        continue
                    header = {"descr": "<f8", "fortran_order": False, "shape": (self.frames,) + self.shapes[key]}
                    np.lib.format.write_array_header_1_0(out, header)
                    left = self.frames * self.row_bytes[key]
                    with open(self.parts / f"{key}.f8", "rb") as src:
                        while left > 0:
                            chunk = src.read(min(_COPY_CHUNK, left))
                            if not chunk:
                                raise OSError(f"frame data of {key!r} is shorter than {self.frames} frames")
                            out.write(chunk)
                            left -= len(chunk)

    def _padded_contacts(self) -> dict:
        """The contact arrays padded to (F, C, ...) from the ragged work files.
        NOTE: held in memory while the file is written (contacts are small beside the frames)."""
        counts = np.fromfile(self.parts / "contact_count.f8", dtype="<f8")[: self.frames].astype(np.int64)
        rows = {}
        for field, (key, shape, dtype, _) in CONTACT_FIELDS.items():
            raw = np.fromfile(self.parts / f"{key}.rows", dtype=np.dtype(dtype).newbyteorder("<"))
            rows[field] = raw.reshape((-1,) + shape)[: int(counts.sum())]
        out = pad_contacts(counts, rows)
        out.pop("contact_count")  # written from its frame file like the other per-frame keys
        return out

    def close(self, remove_parts: bool = False):
        """Close the work files; ``remove_parts`` deletes the work folder (once the file is complete)."""
        for fh in self.files.values():
            fh.close()
        if remove_parts:
            shutil.rmtree(self.parts, ignore_errors=True)
