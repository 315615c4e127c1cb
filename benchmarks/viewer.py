"""viewer: server-side cost of the browser viewer (tumble.viewer) with many bodies.

A synthetic trajectory: a fixed ground plane and N cubes of 20 cm (the pile's
boxes) on a square grid, each falling and turning (seeded), F frames. For
N = 100, 1000 and 10 000 (``--sizes``):

* build: the time of ``Viewer._build_scene`` (tessellating the meshes and
  queueing the scene's nodes), measured by wrapping the method while the
  ``Viewer`` is made (one run: it is seconds at N = 10 000 before instancing);
* frame: the time of ``Viewer._show_frame(k)`` (what the playback loop and the
  frame slider call), median over ``--frames`` calls on successive frames, after
  two untimed calls;
* frame, axes shown: the same with the "Body axes" toggle on;
* messages: the number of messages ``_show_frame`` queues for the browser per
  frame (counted by wrapping viser's ``queue_message``; each one is serialized
  and applied by every connected browser: the cost that made playback crawl).

No browser is connected: the figures are the Python side only. The same script
runs against an older tree (``PYTHONPATH=/tmp/viewer_before/src``), which is how
the "before" figures of docs/benchmarks.md were made.

Run from the repository root:

    PYTHONPATH=src python benchmarks/viewer.py                 # N = 100, 1000, 10 000
    PYTHONPATH=src python benchmarks/viewer.py --sizes 1000 --frames 20
"""

from __future__ import annotations

import argparse
import contextlib
import datetime as _dt
import io
import json
import os
import platform
import statistics
import time

import numpy as np

from tumble.shapes import Box, Plane, shape_to_dict
from tumble.trajectory import Trajectory


def make_trajectory(n: int, frames: int = 60, seed: int = 0) -> Trajectory:
    """A ground plane (body 0, fixed) and ``n`` 20 cm cubes (bodies 1..n) on a grid 40 cm apart,
    falling at 1 m/s and turning at a seeded angular velocity; ``frames`` frames at 30 Hz.

    Positions in m (world, z up), orientations (w, x, y, z); momenta are those of 1 kg cubes.
    """
    rng = np.random.default_rng(seed)
    m = n + 1
    t = np.arange(frames) / 30.0
    side = int(np.ceil(np.sqrt(n)))
    ij = np.stack(np.divmod(np.arange(n), side), axis=1) * 0.4
    start = np.column_stack([ij - 0.2 * side, np.full(n, 2.0)])
    pos = np.zeros((frames, m, 3))
    pos[:, 1:] = start[None] + t[:, None, None] * np.array([0.0, 0.0, -1.0])
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    rate = rng.uniform(1.0, 4.0, n)  # rad/s
    half = 0.5 * rate[None, :] * t[:, None]  # (F, n)
    ori = np.zeros((frames, m, 4))
    ori[:, 0, 0] = 1.0
    ori[:, 1:, 0] = np.cos(half)
    ori[:, 1:, 1:] = np.sin(half)[..., None] * axis[None]
    vel = np.zeros((frames, m, 3))
    vel[:, 1:, 2] = -1.0
    w = np.zeros((frames, m, 3))
    w[:, 1:] = (rate[:, None] * axis)[None]
    inertia = 1.0 * 0.2**2 / 6.0  # kg m^2, a 1 kg cube of side 0.2 m
    zero = np.zeros(frames)
    ke = 0.5 * np.sum(vel**2, axis=(1, 2)) + 0.5 * inertia * np.sum(w**2, axis=(1, 2))
    shapes = [json.dumps(shape_to_dict(Plane()))] + [json.dumps(shape_to_dict(Box((0.2, 0.2, 0.2))))] * n
    return Trajectory(
        time=t, names=np.array(["ground"] + [f"box{i}" for i in range(n)]), position=pos, orientation=ori,
        velocity=vel, angular_velocity=w, linear_momentum=vel.copy(), angular_momentum=inertia * w,
        kinetic_energy=ke, potential_energy=9.81 * np.sum(pos[..., 2], axis=1), total_linear_momentum=vel.sum(axis=1),
        total_angular_momentum=(inertia * w).sum(axis=1), orthonormality_error=zero, com_offset=np.zeros((m, 3)),
        shapes=np.array(shapes), fixed=np.array([True] + [False] * n),
    )


class _Counter:
    """Counts the messages viser queues (wraps ``WebsockMessageHandler.queue_message``)."""

    def __init__(self):
        from viser.infra import _infra

        self.count = 0
        self._cls = _infra.WebsockMessageHandler
        self._original = self._cls.queue_message
        counter = self

        def queue_message(handler, message):
            counter.count += 1
            return counter._original(handler, message)

        self._cls.queue_message = queue_message

    def close(self):
        self._cls.queue_message = self._original


def measure(n: int, frames: int) -> dict:
    from tumble.viewer import app

    traj = make_trajectory(n, frames=max(frames + 2, 10))
    built = {}
    original = app.Viewer._build_scene

    def timed_build(viewer):
        t0 = time.perf_counter()
        original(viewer)
        built["s"] = time.perf_counter() - t0

    app.Viewer._build_scene = timed_build
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # viser's banner
            viewer = app.Viewer(traj, host="127.0.0.1", port=0, play=False)
    finally:
        app.Viewer._build_scene = original

    def timed_frames():
        viewer._show_frame(1)  # untimed: first calls
        viewer._show_frame(2)
        counter.count = 0
        times = []
        for j in range(frames):
            k = (3 + j) % traj.frame_count
            t0 = time.perf_counter()
            viewer._show_frame(k)
            times.append(time.perf_counter() - t0)
        return times, counter.count / frames

    counter = _Counter()
    try:
        times, messages = timed_frames()
        viewer.axes_checkbox.value = True
        axes_times, axes_messages = timed_frames()
    finally:
        counter.close()
        with contextlib.redirect_stdout(io.StringIO()):
            viewer.stop()
    return {"bodies": n, "build_s": built["s"], "frame_ms": 1e3 * statistics.median(times),
            "frame_ms_min": 1e3 * min(times), "frame_ms_max": 1e3 * max(times), "messages_per_frame": messages,
            "axes_frame_ms": 1e3 * statistics.median(axes_times), "axes_messages_per_frame": axes_messages}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 1000, 10_000])
    parser.add_argument("--frames", type=int, default=50, help="frames timed per size (median)")
    args = parser.parse_args(argv)
    import viser

    print(f"{_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M} UTC, {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores, viser {viser.__version__}, load average {os.getloadavg()[0]:.2f}")
    print("| bodies | _build_scene (s) | _show_frame median (ms) | min-max (ms) | messages per frame "
          "| axes shown: median (ms) | messages |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for n in args.sizes:
        r = measure(n, args.frames)
        print(f"| {r['bodies']} | {r['build_s']:.3f} | {r['frame_ms']:.3f} | {r['frame_ms_min']:.3f}-{r['frame_ms_max']:.3f} "
              f"| {r['messages_per_frame']:.0f} | {r['axes_frame_ms']:.3f} | {r['axes_messages_per_frame']:.0f} |", flush=True)
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
