"""What a run records: the frame arrays filled from the World (``_Recorder``, for
``Simulator.run``), one frame's and the static per-body values of the trajectory file
(``frame_values``, ``static_values``, shared with the streamed ``runfile.stream_run``), the
outcome of a run written to disk (``RunResult``), and the progress bar with its first-frame
notice."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .shapes import shape_to_dict
from .trajectory import CONTACT_FIELDS, EnabledLog, Trajectory, joint_frame_shapes, pad_contact_frames, shape_table_of
from .world import World


@dataclass
class RunResult:
    """What ``Simulator.run_to_file`` did.

    Attributes:
        status: "running" (at an intermediate flush), "completed", "interrupted" or "failed".
        frames: frames in trajectory.npz (frame 0 included). steps: steps of dt taken in all.
        wall_time_s: s of computing over all sessions of the run.
        energy_initial, energy_final: total energy (J) of the first and last frames.
        max_orthonormality_error: largest over the frames.
        state_hash: ``checks.state_hash`` of the state at the last frame.
        error: the blow-up message (status "failed"). signal: "SIGINT"/"SIGTERM" (status "interrupted").
        out_dir: the output folder. t: simulated time of the last frame, s.
        largest_penetration_m: m, >= 0, the deepest penetration of any contact point at any step of
            the run (``Simulator.largest_penetration``: the contact detection's separations at each
            step's start, every step, not only the recorded frames); None when the run found no
            contact point.
    """

    status: str
    frames: int
    steps: int
    wall_time_s: float
    energy_initial: float
    energy_final: float
    max_orthonormality_error: float
    state_hash: str
    t: float
    out_dir: Path
    error: str | None = None
    signal: str | None = None
    largest_penetration_m: float | None = None

    def figures(self) -> dict:
        drift = (self.energy_final - self.energy_initial) / max(abs(self.energy_initial), float(np.finfo(float).tiny))
        return {
            "status": self.status,
            "frames": int(self.frames),
            "steps": int(self.steps),
            "wall_time_s": float(self.wall_time_s),
            "energy_initial": _finite_or_none(self.energy_initial),
            "energy_final": _finite_or_none(self.energy_final),
            "energy_drift_relative": _finite_or_none(drift),  # None: E_0 = 0 and it overflowed
            "max_orthonormality_error": _finite_or_none(self.max_orthonormality_error),
            "largest_penetration_m": None if self.largest_penetration_m is None else _finite_or_none(self.largest_penetration_m),
            "state_hash": self.state_hash,
            "error": self.error,
            "signal": self.signal,
        }


def _finite_or_none(x):
    x = float(x)
    return x if math.isfinite(x) else None


def frame_values(world: World) -> dict:
    """One frame of the trajectory file (its per-frame keys) from the world's current state."""
    w = world
    # A run heading for a blow-up may overflow the diagnostics before the state
    # itself turns non-finite: record inf, and let the checks report the body.
    with np.errstate(over="ignore", invalid="ignore"):
        return {
            "time": w.t,
            "position": w.x,
            "orientation": w.q,
            "velocity": w.v,
            "angular_velocity": w.omega,
            "linear_momentum": w.P,
            "angular_momentum": w.L,
            "kinetic_energy": w.kinetic_energy(),
            "potential_energy": w.potential_energy(),
            "total_linear_momentum": w.linear_momentum(),
            "total_angular_momentum": w.angular_momentum(),
            "orthonormality_error": w.orthonormality_error(),
        }


def static_values(world: World, fixed=None) -> dict:
    """The per-body keys of the trajectory file that do not change with time. ``fixed`` (N,) bool:
    the bodies fixed at every recorded frame (``World.set_body_type`` changes a body's type
    during a run; the exports animate every body that was not), default the world's now."""
    return {
        "names": np.array(world.names, dtype=str),
        "com_offset": world.com_offset.copy(),
        **dict(zip(("shape_table", "shape_index"), shape_table_of(_shape_texts(world)))),
        "fixed": world.fixed.copy() if fixed is None else np.asarray(fixed, dtype=bool).copy(),
        # only in a world with a sensor: the files of others keep their bytes
        **({"sensor": world.sensor.copy()} if world.sensor.any() else {}),
    }


def _shape_texts(world: World) -> list[str]:
    """Each body's shape as JSON text (``shapes.shape_to_dict``); a shape record shared by many
    bodies (one mesh object for a pile) is written out once. The trajectory file keeps each
    distinct text once (``Trajectory.shape_table``)."""
    text_of: dict[int, str] = {}  # id of a shape record (alive in world.shapes) -> its text
    for sh in world.shapes:
        if id(sh) not in text_of:
            text_of[id(sh)] = json.dumps(shape_to_dict(sh))
    return [text_of[id(sh)] for sh in world.shapes]


#: s: a first frame slower than this gets one line on stderr saying why (see _first_frame_notice)
FIRST_FRAME_NOTICE_S = 3.0
FIRST_FRAME_NOTICE = ("tumble: the first frame is still running: on a first run the kernels for this scene are "
                      "compiled (up to a minute or two with contacts), then cached on disk")


def _first_frame_notice():
    """A started timer that writes FIRST_FRAME_NOTICE to stderr unless cancelled within
    FIRST_FRAME_NOTICE_S: the first frame of a run compiles the Numba kernels it needs (a minute
    with contacts on a fresh install) and the progress bar, which waits for a frame, would
    otherwise show nothing at all. Only with a progress bar (an interactive run)."""
    import sys
    import threading

    timer = threading.Timer(FIRST_FRAME_NOTICE_S, lambda: print(FIRST_FRAME_NOTICE, file=sys.stderr, flush=True))
    timer.daemon = True
    timer.start()
    return timer


def _progress_bar(frames: int, progress: bool | None):
    import sys

    if progress is False or (progress is None and not sys.stderr.isatty()):
        return None
    from tqdm import tqdm

    return tqdm(total=frames, unit="frame", delay=1.0, file=sys.stderr, leave=False)


class _Recorder:
    """Pre-allocated frame arrays, filled from the World one frame at a time."""

    KEYS = {
        "time": (), "position": (3,), "orientation": (4,), "velocity": (3,), "angular_velocity": (3,),
        "linear_momentum": (3,), "angular_momentum": (3,), "kinetic_energy": None, "potential_energy": None,
        "total_linear_momentum": "3", "total_angular_momentum": "3", "orthonormality_error": None,
    }

    def __init__(self, world: World, capacity: int, contacts_of=None, joints_of=None, sensors_of=None,
                 switches_of=None):
        self.world = world
        # a Simulator whose shown_disabled() gives each frame's disabled bodies (its due switches
        # taken as done), or None: World.disabled
        self.switches_of = switches_of
        self.contacts_of = contacts_of  # a Simulator whose contacts() are recorded each frame, or None
        self.contact_frames = []
        self.joints_of = joints_of  # a Simulator whose joint_frame() is recorded each frame, or None
        self.sensors_of = sensors_of  # a Simulator whose sensor_frame() is recorded each frame, or None
        n = world.body_count
        self.count = 0
        self.fixed = world.fixed.copy()  # fixed at every frame recorded so far (static_values)
        self.enabled_log = EnabledLog(n)  # the bodies disabled and enabled, frame by frame
        self.arrays = {}
        for key, shape in self.KEYS.items():
            if shape is None or shape == ():
                self.arrays[key] = np.zeros(capacity)
            elif shape == "3":
                self.arrays[key] = np.zeros((capacity, 3))
            else:
                self.arrays[key] = np.zeros((capacity, n) + shape)
        if joints_of is not None:
            for key, shape in joint_frame_shapes(len(world.joints)).items():
                self.arrays[key] = np.zeros((capacity,) + shape)
        if sensors_of is not None:
            self.arrays["sensor_visitors"] = np.zeros((capacity, int(world.sensor.sum())))

    def grow(self):
        """Twice the capacity, the frames kept (a recording of unknown length: the live viewer's)."""
        for key, a in self.arrays.items():
            bigger = np.zeros((2 * max(len(a), 1),) + a.shape[1:], dtype=a.dtype)
            bigger[:len(a)] = a
            self.arrays[key] = bigger

    def truncate(self, count: int):
        """Keep the first ``count`` frames only (the live viewer's "Back to mark")."""
        self.count = min(self.count, int(count))
        del self.contact_frames[self.count:]
        self.enabled_log.truncate(self.count)

    def record(self):
        if self.count == len(self.arrays["time"]):
            self.grow()
        for key, value in frame_values(self.world).items():
            self.arrays[key][self.count] = value
        self.fixed &= self.world.fixed
        shown = self.world.disabled if self.switches_of is None else self.switches_of.shown_disabled()
        self.enabled_log.observe(self.count, shown)
        if self.contacts_of is not None:
            # the rows a trajectory keeps (``CONTACT_FIELDS``), not the whole ``Contacts``: its body
            # names (text, 4 bytes a character a contact) and parts made the run hold 1.8 GB for 1.2 GB
            # of contact data (1000 boxes, 60 s; a performance audit, session 43)
            contacts = self.contacts_of.contacts()
            self.contact_frames.append(tuple(getattr(contacts, field) for field in CONTACT_FIELDS))
        if self.joints_of is not None:
            for key, value in self.joints_of.joint_frame().items():
                self.arrays[key][self.count] = value
        if self.sensors_of is not None:
            self.arrays["sensor_visitors"][self.count] = self.sensors_of.sensor_frame()
        self.count += 1

    def trajectory(self) -> Trajectory:
        k = self.count
        contacts = {}
        if self.contacts_of is not None:
            contacts = pad_contact_frames(self.contact_frames[:k])
        if self.joints_of is not None:
            contacts["joint_names"] = np.array([j.name or "" for j in self.world.joints], dtype=str)
        contacts["enabled_changes"] = self.enabled_log.array()
        return Trajectory(**{key: a[:k].copy() for key, a in self.arrays.items()}, **static_values(self.world, self.fixed), **contacts)
