"""What every engine of the contact benchmark shares: the scene as plain arrays, the run loop and
the quality figures (/work/shared/BENCHMARKS.md tables b and c), computed the same way for all.

An engine adapter has ``step(k)`` (k steps of its dt), ``state()`` -> (x (n, 3) m, R (n, 3, 3),
v (n, 3) m/s, omega (n, 3) rad/s, world frame) of the moving bodies in the scene's order, and
optionally ``solver_iterations()`` (mean solver iterations per step so far, or None).
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field

import numpy as np

#: quality figures are sampled every 1/60 s of simulated time (stepping alone is timed)
SAMPLE_INTERVAL = 1.0 / 60.0


@dataclass
class SceneSpec:
    """A tumble contact scene as arrays: what a peer needs to rebuild it."""

    name: str
    gravity: np.ndarray
    pos: np.ndarray  # (n, 3) m, centres of the moving boxes
    quat: np.ndarray  # (n, 4) (w, x, y, z)
    half: np.ndarray  # (n, 3) m, half-extents
    mass: np.ndarray  # (n,) kg
    friction: np.ndarray  # (n,)
    restitution: np.ndarray  # (n,)
    statics: list = field(default_factory=list)  # dicts: kind "plane" | "box", pos, quat, half, friction, restitution
    settings: dict = field(default_factory=dict)

    @property
    def n(self) -> int:
        return len(self.pos)


def scene_spec(world, settings: dict) -> SceneSpec:
    """The moving boxes and the static ground of a tumble World (planes must be z = 0, normal +z)."""
    from tumble import Box, Plane

    moving = np.flatnonzero(world.moving)
    statics = []
    for i in np.flatnonzero(~world.moving):
        shape, mat = world.shapes[i], world.materials[i]
        if isinstance(shape, Plane):
            if not (np.allclose(shape.normal, (0, 0, 1)) and shape.offset == 0.0):
                raise ValueError("peers support the ground plane z = 0 only")
            statics.append({"kind": "plane", "friction": mat.friction, "restitution": mat.restitution})
        elif isinstance(shape, Box):
            statics.append({"kind": "box", "pos": world.x[i].copy(), "quat": world.q[i].copy(), "half": shape.half_extents,
                                "friction": mat.friction, "restitution": mat.restitution})
        else:
            raise TypeError(f"peers support static planes and boxes, not {type(shape).__name__}")
    for i in moving:
        if not isinstance(world.shapes[i], Box):
            raise TypeError("peers support box bodies only")
    return SceneSpec(
        name=settings.get("scene", "?"),
        gravity=np.array(world.gravity, dtype=float),
        pos=world.x[moving].copy(),
        quat=world.q[moving].copy(),
        half=np.array([world.shapes[i].half_extents for i in moving]),
        mass=world.mass[moving].copy(),
        friction=np.array([world.materials[i].friction for i in moving]),
        restitution=np.array([world.materials[i].restitution for i in moving]),
        statics=statics,
        settings=dict(settings),
    )


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotation matrices of unit quaternions (n, 4) (w, x, y, z)."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    R = np.empty((len(q), 3, 3))
    R[:, 0, 0] = 1 - 2 * (y * y + z * z)
    R[:, 0, 1] = 2 * (x * y - w * z)
    R[:, 0, 2] = 2 * (x * z + w * y)
    R[:, 1, 0] = 2 * (x * y + w * z)
    R[:, 1, 1] = 1 - 2 * (x * x + z * z)
    R[:, 1, 2] = 2 * (y * z - w * x)
    R[:, 2, 0] = 2 * (x * z - w * y)
    R[:, 2, 1] = 2 * (y * z + w * x)
    R[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def lowest_corner_z(x: np.ndarray, R: np.ndarray, half: np.ndarray) -> np.ndarray:
    """(n,) z of each box's lowest corner: z - sum_k h_k |R[2, k]|."""
    return x[:, 2] - np.sum(np.abs(R[:, 2, :]) * half, axis=1)


def tilt_deg(R: np.ndarray) -> np.ndarray:
    """(n,) angle (degrees) between world z and the nearest body axis (0 for a box lying flat on any face)."""
    c = np.clip(np.max(np.abs(R[:, 2, :]), axis=1), -1.0, 1.0)
    return np.degrees(np.arccos(c))


class Tracker:
    """Quality figures over a run, from samples of (x, R, v, omega) of the moving boxes.

    Figures (the ground's top is z = 0 in every scene):
      min_z_minus_h_end     min over boxes of z_centre - h_z at the end (BENCHMARKS "min z - h")
      max_pen_end / _run    deepest box corner below z = 0 at the end / over all samples
      max_speed_end, max_ang_speed_end   largest |v| (m/s) and |omega| (rad/s) at the end
      left_region           boxes at the end outside the region: xy beyond the start's bounding
                            box grown by ``margin`` (2 m), or centre below z = 0
      max_xy_dist_end       largest horizontal distance (m) of a box centre from the centre of the
                            start's bounding box, at the end
      top_xy_drift_end / _max, top_dz_end, top_abs_dz_max   the box that starts highest
      stands                every box ends within its half-extent of its start (xy and z)
      bottom_pen_end        deepest corner of the box that starts lowest, below z = 0, at the end
      max_tilt_deg          largest tilt of any box over all samples (max_tilt_end_deg: at the end)
    """

    def __init__(self, spec: SceneSpec, margin: float = 2.0):
        self.spec = spec
        self.x0 = spec.pos.copy()
        self.top = int(np.argmax(spec.pos[:, 2]))
        self.bottom = int(np.argmin(spec.pos[:, 2]))
        self.lo = spec.pos[:, :2].min(axis=0) - margin
        self.c0 = 0.5 * (spec.pos[:, :2].min(axis=0) + spec.pos[:, :2].max(axis=0))
        self.c0 = 0.5 * (spec.pos[:, :2].min(axis=0) + spec.pos[:, :2].max(axis=0))
        self.hi = spec.pos[:, :2].max(axis=0) + margin
        self.max_pen_run = 0.0
        self.top_xy_max = 0.0
        self.top_dz_max = 0.0
        self.max_tilt = 0.0
        self.samples = 0
        self.last = None
        self.finite = True

    def sample(self, x, R, v, omega):
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(v))):
            self.finite = False
        zc = lowest_corner_z(x, R, self.spec.half)
        self.max_pen_run = max(self.max_pen_run, float(max(0.0, -zc.min())))
        d = x[self.top] - self.x0[self.top]
        self.top_xy_max = max(self.top_xy_max, float(np.hypot(d[0], d[1])))
        self.top_dz_max = max(self.top_dz_max, abs(float(d[2])))
        self.max_tilt = max(self.max_tilt, float(tilt_deg(R).max()))
        self.samples += 1
        self.last = (x, R, v, omega)

    def figures(self) -> dict:
        x, R, v, omega = self.last
        h = self.spec.half
        zc = lowest_corner_z(x, R, h)
        d = x[self.top] - self.x0[self.top]
        disp = x - self.x0
        outside = ((x[:, 0] < self.lo[0]) | (x[:, 0] > self.hi[0]) | (x[:, 1] < self.lo[1]) | (x[:, 1] > self.hi[1])
                   | (x[:, 2] < 0.0) | ~np.all(np.isfinite(x), axis=1))
        stands = bool(np.all(np.hypot(disp[:, 0], disp[:, 1]) < h[:, 0]) and np.all(np.abs(disp[:, 2]) < h[:, 2]))
        return {
            "min_z_minus_h_end": float(np.min(x[:, 2] - h[:, 2])),
            "max_pen_end": float(max(0.0, -zc.min())),
            "max_pen_run": self.max_pen_run,
            "max_speed_end": float(np.linalg.norm(v, axis=1).max()),
            "max_ang_speed_end": float(np.linalg.norm(omega, axis=1).max()),
            "left_region": int(outside.sum()),
            "max_xy_dist_end": float(np.hypot(x[:, 0] - self.c0[0], x[:, 1] - self.c0[1]).max()),
            "top_xy_drift_end": float(np.hypot(d[0], d[1])),
            "top_dz_end": float(d[2]),
            "top_xy_drift_max": self.top_xy_max,
            "top_abs_dz_max": self.top_dz_max,
            "stands": "yes" if stands else "no",
            "bottom_pen_end": float(max(0.0, -zc[self.bottom])),
            "max_tilt_deg": self.max_tilt,
            "max_tilt_end_deg": float(tilt_deg(R).max()),
            "samples": self.samples,
            "finite": self.finite,
        }


def run(engine, spec: SceneSpec, dt: float, steps: int, timeout: float | None = None) -> dict:
    """Step ``engine`` ``steps`` times, sampling the figures every SAMPLE_INTERVAL of simulated time.

    Only ``engine.step`` is timed. With ``timeout`` (s of stepping), the run stops early and is
    reported as incomplete with the figures at that time.
    """
    per_sample = max(1, round(SAMPLE_INTERVAL / dt))
    tracker = Tracker(spec)
    tracker.sample(*engine.state())
    wall = 0.0
    done = 0
    last_step_s = float("nan")
    load0 = os.getloadavg()[0]
    while done < steps:
        k = min(per_sample, steps - done)
        t0 = time.perf_counter()
        engine.step(k)
        dt_wall = time.perf_counter() - t0
        wall += dt_wall
        last_step_s = dt_wall / k
        done += k
        tracker.sample(*engine.state())
        if timeout is not None and wall > timeout and done < steps:
            break
    out = {"wall_s": wall, "steps_done": done, "steps": steps, "complete": done == steps, "sim_time": done * dt,
               "last_ms_per_step": 1e3 * last_step_s, "loadavg_start": load0, "loadavg_end": os.getloadavg()[0]}
    out.update(tracker.figures())
    extra = getattr(engine, "extra_figures", None)
    if extra is not None:
        out.update(extra())
    iters = getattr(engine, "solver_iterations", None)
    out["solver_iters"] = iters() if iters is not None else None
    return out


def median(values):
    v = sorted(values)
    m = len(v) // 2
    return v[m] if len(v) % 2 else 0.5 * (v[m - 1] + v[m])


def median_time(f, repeats: int) -> float:
    """Median seconds of ``f()`` over ``repeats`` calls."""
    import time

    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return median(times)


def fmt(x, spec=".2e"):
    if x is None:
        return "-"
    if isinstance(x, float) and math.isnan(x):
        return "-"
    if isinstance(x, str):
        return x
    return format(x, spec)


def reusable_engine(engine):
    """``new_run`` of a peer module: the same engine back at its initial state for the next run
    (``engine.reset()``: MuJoCo's model is compiled once; PyBullet's scene is rebuilt, fresh
    contact caches)."""
    engine.reset()
    return engine


def script_main(make, variants, default_variant: str, argv=None) -> None:
    """``python benchmarks/peers/<engine>_scenes.py --scene S --variant V``: one run of one peer on
    one of tumble's contact scenes, its quality figures printed (the peer modules' entry point)."""
    import argparse
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "src"))
    from tumble.scenes import contact as C

    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default="pile")
    ap.add_argument("--n", type=int, default=None)
    ap.add_argument("--variant", default=default_variant, choices=sorted(variants))
    ap.add_argument("--duration", type=float, default=None)
    a = ap.parse_args(argv)
    kw = {} if a.n is None else ({"rows": a.n} if a.scene == "pyramid" else {"n": a.n})
    spec = scene_spec(*C.build(a.scene, **kw))
    eng, load_s, dt, _ = make(spec, a.variant)
    duration = a.duration or spec.settings["duration"]
    r = run(eng, spec, dt, round(duration / dt))
    print(f"load {load_s:.2f} s", r)
