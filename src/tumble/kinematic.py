"""Kinematic bodies on keyframed paths: a platform that shuttles, a paddle that swings.

A kinematic body (``World.add_body(..., kinematic=True)``) moves at the velocities it is given.
A ``KeyframePath`` gives them for it, step by step: poses at key times, the position
interpolated linearly and the orientation by slerp (shortest arc) between them, held before
the first key and after the last (or repeated with ``repeat=True``). Before each step the
Simulator sets the body's v and omega to reach the path's pose at the step's end from where it
is (``drive_paths``; Box2D's b2Body_SetTargetTransform each step, MuJoCo's mocap pose set each
step but with a velocity the bodies it touches feel), so it hits every pose at a step's end to
round-off and never drifts from the path; within a step it moves at constant velocity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .errors import InputError
from .math3d import mat_vec, matrix_to_quat, norm3, quat_from_euler_deg, quat_multiply, quat_to_matrix


@dataclass(eq=False)
class KeyframePath:
    """A kinematic body's poses at key times.

    Args:
        body: the kinematic body (``Body``, name or index).
        times: (K,) s, strictly increasing, K >= 2.
        positions: (K, 3) m, world: where the shape's origin is at each key (as ``position`` in
            ``World.add_body``).
        orientations: (K, 4) unit quaternions (w, x, y, z), or ``euler_deg`` (K, 3); neither:
            the body keeps its orientation at the time the path is added.
        repeat: after the last key, start again from the first (period times[-1] - times[0]):
            each period ends on the last key, the next begins at the first (a jump unless the
            last pose is the first: make it so for a closed loop). Default: hold the last pose.
        release: at the last key, let the body go: it becomes dynamic (``World.set_body_type``)
            and goes on at the velocity it arrived with, the last step's (a ball thrown, a crate
            dropped by a crane, an animated object handed to the simulation: Blender's
            "Animated" box unticked at a frame). The body needs a mass (``mass`` or ``density``
            at ``add_body``). Not with ``repeat``.
    """

    body: Any
    times: Any
    positions: Any
    orientations: Any = None
    euler_deg: Any = None
    repeat: bool = False
    release: bool = False

    def __post_init__(self):
        t = np.asarray(self.times, dtype=float) if _numbers(self.times) else None
        if t is None or t.ndim != 1 or len(t) < 2 or not np.all(np.isfinite(t)):
            raise InputError(f"expected a list of at least 2 finite times, got {self.times!r}", "times")
        if not np.all(np.diff(t) > 0.0):
            raise InputError(f"times must increase strictly, got {t.tolist()}", "times")
        self.times = t
        self.positions = _rows(self.positions, len(t), 3, "positions")
        if self.orientations is not None and self.euler_deg is not None:
            raise InputError("give orientations or euler_deg, not both", "orientations")
        if self.euler_deg is not None:
            angles = _rows(self.euler_deg, len(t), 3, "euler_deg")
            self.orientations = np.array([quat_from_euler_deg(a) for a in angles])
            self.euler_deg = None
        elif self.orientations is not None:
            q = _rows(self.orientations, len(t), 4, "orientations")
            n = np.linalg.norm(q, axis=1)
            if np.any(n < 1e-12):
                raise InputError("quaternion must not be zero (w, x, y, z = 0, 0, 0, 0)", "orientations")
            self.orientations = q / n[:, None]
        if not isinstance(self.repeat, (bool, np.bool_)):
            raise InputError(f"expected true or false, got {self.repeat!r}", "repeat")
        self.repeat = bool(self.repeat)
        if not isinstance(self.release, (bool, np.bool_)):
            raise InputError(f"expected true or false, got {self.release!r}", "release")
        self.release = bool(self.release)
        if self.release and self.repeat:
            raise InputError("a repeating path has no last key to let its body go at: give repeat or release", "release")

    def pose(self, t: float):
        """(position (3,) m of the shape origin, quaternion (4,) or None) on the path at time t (s)."""
        times = self.times
        if self.repeat and t > times[-1]:
            # each period ends on the last key (reached, as without repeat) and the next starts
            # from the first: t in (t0 + n P, t0 + (n + 1) P] maps to (t0, t_last]
            period = times[-1] - times[0]
            u = math.fmod(t - times[0], period)
            # a time on a period's end computed in floating point (t_last + P) leaves u a few
            # rounding units above 0 and jumped to the first key (hypothesis found it, CI
            # 2026-12-03): within the rounding of t - t0 it is the end, so the last key
            rounding = 8.0 * np.finfo(float).eps * max(abs(t - times[0]), period)
            t = times[0] + (u if u > rounding else period)
        if t <= times[0]:
            k, s = 0, 0.0
        elif t >= times[-1]:
            k, s = len(times) - 2, 1.0
        else:
            k = int(np.searchsorted(times, t, side="right")) - 1
            s = (t - times[k]) / (times[k + 1] - times[k])
        p = (1.0 - s) * self.positions[k] + s * self.positions[k + 1]
        if self.orientations is None:
            return p, None
        return p, _slerp(self.orientations[k], self.orientations[k + 1], s)

    def to_dict(self) -> dict:
        return {"times": self.times.tolist(), "positions": self.positions.tolist(),
                "orientations": None if self.orientations is None else self.orientations.tolist(),
                "repeat": self.repeat, "release": self.release}


def _numbers(value) -> bool:
    try:
        np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    return not isinstance(value, (str, bytes))


def _rows(value, k: int, width: int, key: str) -> np.ndarray:
    a = np.asarray(value, dtype=float) if _numbers(value) else None
    if a is None or a.shape != (k, width) or not np.all(np.isfinite(a)):
        shape = "?" if a is None else list(a.shape)
        raise InputError(f"expected {k} rows of {width} finite numbers (one per time), got shape {shape}", key)
    return a


# The per-step arithmetic of a path is written out (``_dot``, ``math3d.norm3`` and ``mat_vec``)
# rather than left to NumPy's ``dot``, ``norm`` and ``@``: those go through
# OpenBLAS, whose kernels differ by CPU (SkylakeX on AVX-512, Haswell on AVX2) and round
# differently, so the same scene gave other bits on another machine (examples/platforms.toml's
# state hash, measured 2026-12-04; tests/conftest.py).
def _dot(a, b) -> float:
    """a . b, summed in index order (no BLAS)."""
    total = 0.0
    for u, w in zip(a, b):
        total += float(u) * float(w)
    return total


def _slerp(q0: np.ndarray, q1: np.ndarray, s: float) -> np.ndarray:
    """Spherical interpolation from q0 (s = 0) to q1 (s = 1), the short way round."""
    if s <= 0.0:
        return q0.copy()
    if s >= 1.0:
        return q1.copy()
    d = _dot(q0, q1)
    if d < 0.0:
        q1, d = -q1, -d
    if d > 1.0 - 1e-12:
        q = q0 + s * (q1 - q0)
        return q / norm3(q)
    angle = math.acos(d)
    q = (math.sin((1.0 - s) * angle) * q0 + math.sin(s * angle) * q1) / math.sin(angle)
    return q / norm3(q)


def velocities_to(x0, q0, x1, q1, time: float):
    """(v (3,), omega (3,)): the constant velocities that take the pose (x0, q0) to (x1, q1) in
    ``time`` s (positions of the centre of mass; the turn is the shortest rotation q1 q0^-1)."""
    v = (np.asarray(x1, dtype=float) - x0) / time
    dq = quat_multiply(np.asarray(q1, dtype=float), np.asarray(q0, dtype=float) * np.array([1.0, -1.0, -1.0, -1.0]))
    if dq[0] < 0.0:
        dq = -dq
    s = float(norm3(dq[1:]))
    angle = 2.0 * math.atan2(s, float(dq[0]))
    omega = dq[1:] * (angle / (s * time)) if s > 0.0 else np.zeros(3)
    return v, omega


def bind_path(world, path: KeyframePath) -> int:
    """Check a path against its world and return its body's row (a kinematic body)."""
    i = world.index_of(path.body)
    if not world.kinematic[i]:
        raise InputError(f"body {world.names[i]!r} is not kinematic: only a kinematic body follows a path", "body")
    if any(world.index_of(p.body) == i for p in world.paths):
        raise InputError(f"body {world.names[i]!r} already has a path", "body")
    if path.release:
        # the mass it will be let go with, checked now as the release will (World.set_body_type):
        # known, with its centre at the body frame's origin; not found mid-run at the last key
        try:
            world._type_mass(i, None, None, None)
        except InputError as err:
            raise InputError(err.problem, "release") from None
    return i


def drive_paths(world, Y: np.ndarray, t: float, dt: float):
    """Set each path body's kinematic_v, kinematic_omega (N, 3) to reach its pose at t + dt from
    its pose in Y (N, W) at t."""
    W = Y.shape[1]
    for path in world.paths:
        i = world.index_of(path.body)
        x0 = Y[i, :3]
        if W == 13:
            q0 = Y[i, 3:7] / norm3(Y[i, 3:7])
        else:
            q0 = matrix_to_quat(np.ascontiguousarray(Y[i, 3:12].reshape(3, 3)))
        p, q1 = path.pose(t + dt)
        if q1 is None:
            q1 = q0
        x1 = p + mat_vec(quat_to_matrix(q1), world.com_offset[i])
        world.kinematic_v[i], world.kinematic_omega[i] = velocities_to(x0, q0, x1, q1, dt)


def touched_by_kinematic(world, soft, movers: np.ndarray, awake: np.ndarray, dynamic: np.ndarray) -> np.ndarray:
    """(N,) bool: the bodies the moving kinematic bodies (``movers`` (N,) bool) keep awake this
    step: those in contact with one or jointed to one, and the sleeping dynamic bodies
    (``dynamic`` (N,) bool, asleep or not; ``awake`` the sleep state's (N,) bool) whose shapes'
    bounds (grown by the step's margins) overlap one's shapes: their pairs are not in the
    broadphase (neither body counts as moving there), and their islands must wake before the
    kinematic body reaches them. ``soft``: the SoftStep after ``collide``.
    NOTE: Box2D wakes a sleeping body when a kinematic body's proxy begins to overlap it; the
    bounds here are the same test, made each step the kinematic body moves."""
    touched = np.zeros(world.body_count, dtype=bool)
    c = soft.contacts
    a, b = c.contact_body_a, c.contact_body_b
    hit = movers[a] | movers[b]
    touched[a[hit]] = True
    touched[b[hit]] = True
    for joint in world.joints:
        bound = joint.bound
        if joint.broken or bound is None:
            continue
        ja, jb = bound.body_a, bound.body_b
        if (ja >= 0 and movers[ja]) or (jb >= 0 and movers[jb]):
            touched[[i for i in (ja, jb) if i >= 0]] = True
    asleep = dynamic & ~awake[: world.body_count]
    if asleep.any():
        from .collision.broadphase import find_pairs

        pipe = soft.pipeline
        table = pipe.table
        pa, pb = find_pairs(pipe.shape_aabb, table.shape_type, table.shape_body, movers)
        for i, j in zip(table.shape_body[pa].tolist(), table.shape_body[pb].tolist()):
            other = j if movers[i] else i
            if asleep[other] and world.should_collide(i, j):
                touched[other] = True
    return touched
