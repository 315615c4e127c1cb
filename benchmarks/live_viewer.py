"""The live viewer (``tumble view SCENE --live``): does it keep real time on the examples?

For each scene: ``tumble.viewer.live(path)`` started playing (no browser connected), 2 s to
settle in (the first contacts load their kernels), then the simulated time over ``--seconds``
of wall time; then, paused, the cost of a tick's display (``LiveViewer._refresh``: the poses,
the contacts' points and forces, the time; median of 20) with the contacts shown and hidden.
A scene whose Numba cache is cold compiles its contact routines at its first contacts: run the
script twice and take the second run (the first says how long a cold start stalls).

    PYTHONPATH=src python benchmarks/live_viewer.py [--seconds 6] [SCENE ...]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import time

EXAMPLES = ("dice", "dominoes", "robot_arm", "mjcf_turntable", "ring_toss", "pyramid", "pile")


def measure(path: str, seconds: float) -> dict:
    from tumble.viewer import live

    v = live(path, port=0, play=True, out=os.devnull)
    try:
        time.sleep(2.0)
        t0, w0 = v.world.t, time.monotonic()
        time.sleep(seconds)
        t1, w1 = v.world.t, time.monotonic()
        v.pause()
        ticks = {}
        for shown in (True, False):
            v.contact_points_checkbox.value = shown
            v.contact_forces_checkbox.value = shown
            samples = []
            for _ in range(20):
                start = time.perf_counter()
                v._refresh()
                samples.append(time.perf_counter() - start)
            ticks[shown] = statistics.median(samples)
        return {"bodies": v.world.body_count, "dt": v.sim.dt, "factor": (t1 - t0) / (w1 - w0),
                "tick_shown_ms": 1e3 * ticks[True], "tick_hidden_ms": 1e3 * ticks[False],
                "contacts": len(v.sim.contacts().point)}
    finally:
        v.stop()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="*", help="scene files (default: the examples listed in EXAMPLES)")
    ap.add_argument("--seconds", type=float, default=6.0)
    args = ap.parse_args()
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    scenes = args.scenes or [os.path.join(root, "examples", f"{name}.toml") for name in EXAMPLES]
    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=root).stdout.strip()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, tumble git {rev}; "
          f"{args.seconds:g} s of wall time after 2 s")
    print()
    print("| scene | bodies | dt s | simulated s per wall s | contacts | tick ms, contacts shown / hidden |")
    print("|---|---:|---:|---:|---:|---:|")
    for path in scenes:
        r = measure(path, args.seconds)
        print(f"| {os.path.basename(path)} | {r['bodies']} | {r['dt']:.5g} | {r['factor']:.2f} | {r['contacts']} | "
              f"{r['tick_shown_ms']:.2f} / {r['tick_hidden_ms']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
