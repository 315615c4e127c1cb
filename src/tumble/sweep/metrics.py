"""Sweep metrics: what each variant's row of the table records.

A metric is named on the command line (``--metric``) or in the scene's
``[sweep] metrics = [...]``:

=================================  ==========================================================
``final_position:BODY``            centre of mass at the last frame, m (columns ``...[0..2]``)
``final_orientation:BODY``         quaternion (w, x, y, z) at the last frame (``...[0..3]``)
``final_velocity:BODY``            m/s, world (``...[0..2]``)
``final_angular_velocity:BODY``    rad/s, world (``...[0..2]``)
``final_angular_velocity_body:BODY`` rad/s, in the body's axes (``...[0..2]``)
``energy_initial``, ``energy_final`` total energy of the variant, J (kinetic + gravity + springs)
``energy_drift``                   (E_final - E_0) / |E_0|
``flip_time:BODY:AXIS``            first time the body-frame angular velocity component about
                                   AXIS (x, y, z or 0, 1, 2) changes sign, s, linearly
                                   interpolated between frames; NaN if it never does
``final_sensor_visitors:SENSOR``   bodies overlapping the sensor body at the last frame
``max_sensor_visitors:SENSOR``     the most at any frame (the trajectory's ``sensor_visitors``;
                                   NaN when nothing was sensed: collisions off)
=================================  ==========================================================

Every row also has ``status`` (ok / failed), ``error``, ``error_kind`` (input /
simulation / internal), ``state_hash`` (``checks.state_hash`` of the variant's
world at the end), ``wall_time_s`` and ``batch_size``.

All metrics are computed from frame arrays shaped (F, V, n, ...) (frames,
variants, bodies of one variant) with element-wise operations only and sums
over bodies in a fixed order, so one variant gives the same bits whether it ran
alone (V = 1) or in a batch of thousands.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

VECTOR_METRICS = {
    "final_position": 3,
    "final_orientation": 4,
    "final_velocity": 3,
    "final_angular_velocity": 3,
    "final_angular_velocity_body": 3,
}
SCALAR_METRICS = ("energy_initial", "energy_final", "energy_drift")
SENSOR_METRICS = ("final_sensor_visitors", "max_sensor_visitors")
AXES = {"x": 0, "y": 1, "z": 2, "0": 0, "1": 1, "2": 2}
KNOWN = tuple(VECTOR_METRICS) + SCALAR_METRICS + ("flip_time",) + SENSOR_METRICS


@dataclass(frozen=True)
class Metric:
    """A parsed metric: ``kind``, ``body`` (name or None), ``axis`` (flip_time), ``columns``."""

    text: str
    kind: str
    body: str | None = None
    axis: int | None = None

    @property
    def columns(self) -> list[str]:
        if self.kind in VECTOR_METRICS:
            return [f"{self.text}[{i}]" for i in range(VECTOR_METRICS[self.kind])]
        return [self.text]


def parse_metric(text, body_names: list[str], sensor_names=None) -> Metric:
    """``"flip_time:box:y"`` -> Metric; body names are checked against the scene (and, for the
    sensor metrics, against ``sensor_names`` when given)."""
    where = "--metric"
    if not isinstance(text, str) or not text.strip():
        raise InputError(f"expected a metric name, got {text!r} (known: {', '.join(KNOWN)})", where)
    parts = [p.strip() for p in text.strip().split(":")]
    kind = parts[0]
    if kind not in KNOWN:
        raise InputError(f"unknown metric {kind!r} (known: {', '.join(KNOWN)})", where)
    if kind in SCALAR_METRICS:
        if len(parts) != 1:
            raise InputError(f"metric {kind} takes no body (got {text!r})", where)
        return Metric(kind, kind)
    need = 3 if kind == "flip_time" else 2
    form = "flip_time:BODY:AXIS" if kind == "flip_time" else f"{kind}:BODY"
    if len(parts) != need or not all(parts):
        raise InputError(f"expected {form}, got {text!r}", where)
    body = parts[1]
    if body not in body_names:
        raise InputError(f"metric {text!r}: unknown body {body!r} (known: {', '.join(map(repr, body_names))})", where)
    if kind == "flip_time":
        if parts[2] not in AXES:
            raise InputError(f"metric {text!r}: axis must be x, y, z (or 0, 1, 2), got {parts[2]!r}", where)
        canon = f"flip_time:{body}:{'xyz'[AXES[parts[2]]]}"
        return Metric(canon, kind, body, AXES[parts[2]])
    if kind in SENSOR_METRICS and sensor_names is not None and body not in sensor_names:
        raise InputError(f"metric {text!r}: body {body!r} is not a sensor (sensors: "
                         f"{', '.join(map(repr, sensor_names)) or 'none'})", where)
    return Metric(f"{kind}:{body}", kind, body)


def default_metrics(body_names: list[str], moving: list[bool]) -> list[Metric]:
    """energy_drift, and the final position and orientation of each moving body (up to 8)."""
    out = [Metric("energy_drift", "energy_drift")]
    movers = [n for n, m in zip(body_names, moving) if m]
    if len(movers) <= 8:
        for n in movers:
            out += [Metric(f"final_position:{n}", "final_position", n), Metric(f"final_orientation:{n}", "final_orientation", n)]
    return out


# ---------------------------------------------------------------------- computing


@dataclass
class Frames:
    """Frame arrays of V variants of n bodies each: (F,) time, (F, V, n, 3 or 4) per-body values."""

    time: np.ndarray
    position: np.ndarray
    orientation: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    linear_momentum: np.ndarray
    angular_momentum: np.ndarray
    sensor_visitors: np.ndarray | None = None  # (F, V, K) or None (nothing sensed)

    @classmethod
    def from_trajectory(cls, traj, variants: int) -> Frames:
        F = len(traj.time)

        def r(a):
            return a.reshape((F, variants, a.shape[1] // variants) + a.shape[2:])

        sensed = getattr(traj, "sensor_visitors", None)
        return cls(traj.time, r(traj.position), r(traj.orientation), r(traj.velocity), r(traj.angular_velocity),
                   r(traj.linear_momentum), r(traj.angular_momentum), None if sensed is None else r(sensed))


def _dot3(a, b):
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _rotate(q, v, transpose=False):
    """R(q) v (or R(q)^T v), element-wise over leading axes; q (..., 4) unit (w, x, y, z)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    r00 = 1.0 - 2.0 * (y * y + z * z)
    r01 = 2.0 * (x * y - w * z)
    r02 = 2.0 * (x * z + w * y)
    r10 = 2.0 * (x * y + w * z)
    r11 = 1.0 - 2.0 * (x * x + z * z)
    r12 = 2.0 * (y * z - w * x)
    r20 = 2.0 * (x * z - w * y)
    r21 = 2.0 * (y * z + w * x)
    r22 = 1.0 - 2.0 * (x * x + y * y)
    a, b, c = v[..., 0], v[..., 1], v[..., 2]
    if transpose:
        return np.stack([r00 * a + r10 * b + r20 * c, r01 * a + r11 * b + r21 * c, r02 * a + r12 * b + r22 * c], axis=-1)
    return np.stack([r00 * a + r01 * b + r02 * c, r10 * a + r11 * b + r12 * c, r20 * a + r21 * b + r22 * c], axis=-1)


@dataclass(frozen=True)
class BodyInfo:
    """What the metrics need of the scene (the same for every variant of a batch group, except masses)."""

    names: tuple
    moving: tuple  # bool per body
    springs: tuple = ()  # (a, b or -1, anchor_a, anchor_b, stiffness, rest_length)
    sensors: tuple = ()  # the sensors' names, in body order (the trajectory's sensor_visitors columns)


def energies(fr: Frames, mass: np.ndarray, gravity: np.ndarray, info: BodyInfo, gravity_scale=None) -> np.ndarray:
    """(F, V) total energy of each variant: sum over moving bodies (in body order) of
    1/2 P.v + 1/2 L.omega - s m g.x, plus 1/2 k (l - l0)^2 per spring. ``mass`` (V, n);
    ``gravity_scale`` (V, n) the bodies' s (``World.set_gravity_scale``), None: 1."""
    with np.errstate(all="ignore"):  # fixed bodies (infinite mass) are left out of the sums below
        return _energies(fr, mass, gravity, info, gravity_scale)


def _energies(fr, mass, gravity, info, gravity_scale=None):
    ke = 0.5 * _dot3(fr.linear_momentum, fr.velocity) + 0.5 * _dot3(fr.angular_momentum, fr.angular_velocity)
    g = np.asarray(gravity, dtype=float)
    pe = -(mass[None, :, :] * _dot3(fr.position, np.broadcast_to(g, fr.position.shape)))
    if gravity_scale is not None and np.any(gravity_scale != 1.0):  # s m g h (World.potential_energy)
        pe = pe * np.asarray(gravity_scale, dtype=float)[None, :, :]
    e_body = ke + pe  # (F, V, n)
    total = np.zeros(e_body.shape[:2])
    for j, m in enumerate(info.moving):
        if m:
            total = total + e_body[:, :, j]
    for a, b, anchor_a, anchor_b, k, l0 in info.springs:
        pa = _rotate(fr.orientation[:, :, a], np.broadcast_to(np.asarray(anchor_a, float), fr.position[:, :, a].shape)) + fr.position[:, :, a]
        if b < 0:
            pb = np.broadcast_to(np.asarray(anchor_b, float), pa.shape)
        else:
            pb = _rotate(fr.orientation[:, :, b], np.broadcast_to(np.asarray(anchor_b, float), pa.shape)) + fr.position[:, :, b]
        d = pa - pb
        length = np.sqrt(_dot3(d, d))
        total = total + 0.5 * k * (length - l0) ** 2
    return total


def first_sign_change(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(V,) first time each column of y (F, V) changes sign (linear interpolation), NaN if never."""
    s = np.sign(y)
    change = (s[:-1] * s[1:]) < 0
    has = change.any(axis=0)
    i = np.argmax(change, axis=0)
    cols = np.arange(y.shape[1])
    i1 = np.minimum(i + 1, len(t) - 1)
    y0, y1 = y[i, cols], y[i1, cols]
    t0, t1 = t[i], t[i1]
    with np.errstate(invalid="ignore", divide="ignore"):
        tc = t0 - y0 * (t1 - t0) / (y1 - y0)
    return np.where(has, tc, np.nan)


def compute(metrics: list[Metric], fr: Frames, mass: np.ndarray, gravity, info: BodyInfo,
            gravity_scale=None) -> dict[str, np.ndarray]:
    """{column: (V,) values} for ``metrics`` over the frames of V variants (``gravity_scale`` (V, n)
    or None: as ``energies``)."""
    out: dict[str, np.ndarray] = {}
    index = {n: j for j, n in enumerate(info.names)}
    need_energy = any(m.kind in SCALAR_METRICS for m in metrics)
    if need_energy:
        E = energies(fr, mass, gravity, info, gravity_scale)
        e0, e1 = E[0], E[-1]
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            drift = (e1 - e0) / np.maximum(np.abs(e0), np.finfo(float).tiny)
    for m in metrics:
        if m.kind == "energy_initial":
            out[m.text] = e0
        elif m.kind == "energy_final":
            out[m.text] = e1
        elif m.kind == "energy_drift":
            out[m.text] = drift
        elif m.kind in SENSOR_METRICS:
            V = fr.position.shape[1]
            if fr.sensor_visitors is None or m.body not in info.sensors:
                out[m.text] = np.full(V, np.nan)
            else:
                counts = fr.sensor_visitors[:, :, info.sensors.index(m.body)]
                out[m.text] = np.array(counts[-1] if m.kind == "final_sensor_visitors" else counts.max(axis=0), dtype=float)
        elif m.kind == "flip_time":
            j = index[m.body]
            w_body = _rotate(fr.orientation[:, :, j], fr.angular_velocity[:, :, j], transpose=True)
            out[m.text] = first_sign_change(fr.time, w_body[..., m.axis])
        else:
            j = index[m.body]
            if m.kind == "final_angular_velocity_body":
                last = _rotate(fr.orientation[-1, :, j], fr.angular_velocity[-1, :, j], transpose=True)
            else:
                last = getattr(fr, m.kind[len("final_"):])[-1, :, j]
            for c, col in enumerate(m.columns):
                out[col] = np.array(last[:, c])
    return out
