"""Gymnasium environments: tumble's ``InvertedPendulum`` (``tumble.envs``) beside Gymnasium's own
``InvertedPendulum-v5`` stepped by MuJoCo, on the same model file, in the same run.

Single environments: ``env.step`` from a Python loop, microseconds a step (one step is 2 simulator
steps of 0.02 s), with two policies: the LQR of tests/test_envs.py (the pole stays up, no
resets) and uniform random controls (the pole falls within about 8 steps: resets are part of the
cost). Vector environments: tumble's ``ModelVectorEnv`` (all copies in one World, one step)
against Gymnasium's ``SyncVectorEnv`` over MuJoCo environments (a Python loop over them), microseconds
per vector step and per environment step. Then Gymnasium's ``Reacher-v5`` (a two-link arm with
armature: tumble's tree solve) the same way, with random controls. Median of ``--repeats`` timings of ``--steps`` steps
each, after a warm-up (compilation apart: the first step's time is given on its own line).

    PYTHONPATH=src python benchmarks/envs.py --repeats 5
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import time

import numpy as np

# tests/test_envs.py's LQR gain (tumble's linearized step, Q = diag(1, 10, 0.1, 0.1), R = 0.1)
K = np.array([[-1.72340378, -12.1534953, -2.02245385, -1.8859492]])


def lqr(obs, rng):
    return np.clip(-obs @ K.T, -3.0, 3.0).astype(np.float32)


def random_controls(obs, rng):
    return rng.uniform(-3.0, 3.0, size=obs.shape[:-1] + (1,)).astype(np.float32)


def time_single(env, policy, steps, repeats):
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=0)
    times, resets = [], 0
    for _ in range(repeats + 1):  # the first round warms up
        t0 = time.perf_counter()
        for _ in range(steps):
            obs, _, terminated, truncated, _ = env.step(policy(obs, rng))
            if terminated or truncated:
                obs, _ = env.reset()
                resets += 1
        times.append(time.perf_counter() - t0)
    return 1e6 * statistics.median(times[1:]) / steps, resets / (repeats + 1)


def time_vector(env, policy, steps, repeats):
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=0)
    times, ended = [], 0
    for _ in range(repeats + 1):
        t0 = time.perf_counter()
        for _ in range(steps):
            obs, _, terminated, truncated, _ = env.step(policy(obs, rng))
            ended += int(np.count_nonzero(terminated | truncated))
        times.append(time.perf_counter() - t0)
    return 1e6 * statistics.median(times[1:]) / steps, ended / (repeats + 1)


def main():
    import gymnasium as gym

    import tumble.envs as te

    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--steps", type=int, default=1000, help="steps per timing of a single environment")
    ap.add_argument("--sizes", type=int, nargs="+", default=[16, 256, 1024])
    ap.add_argument("--reacher-sizes", type=int, nargs="+", default=[1, 256])
    args = ap.parse_args()
    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    import mujoco

    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, tumble git "
          f"{rev}, gymnasium {gym.__version__}, mujoco {mujoco.__version__}; median of {args.repeats}")
    print()
    t0 = time.perf_counter()
    env = te.InvertedPendulum()
    env.reset(seed=0)
    env.step(np.zeros(1, dtype=np.float32))
    print(f"tumble: first environment made and stepped in {time.perf_counter() - t0:.2f} s (the kernels "
          f"compiled or loaded from Numba's cache)")
    print()
    print("| environment | policy | us per step | resets per round |")
    print("|---|---|---|---|")
    for name, make in (("tumble InvertedPendulum", lambda: gym.make("tumble/InvertedPendulum-v5")),
                       ("Gymnasium InvertedPendulum-v5 (MuJoCo)", lambda: gym.make("InvertedPendulum-v5"))):
        for pname, policy in (("LQR", lqr), ("random", random_controls)):
            us, resets = time_single(make(), policy, args.steps, args.repeats)
            print(f"| {name} | {pname} | {us:.1f} | {resets:.0f} |")
    print()
    print("| vector environment | copies | policy | us per vector step | us per environment step | "
          "environment steps/s | episodes ended per round |")
    print("|---|---|---|---|---|---|---|")
    for n in args.sizes:
        steps = max(20, 20000 // n)
        for name, make in (
                ("tumble ModelVectorEnv", lambda: gym.make_vec("tumble/InvertedPendulum-v5", num_envs=n,
                                                               vectorization_mode="vector_entry_point")),
                ("Gymnasium SyncVectorEnv (MuJoCo)", lambda: gym.make_vec("InvertedPendulum-v5", num_envs=n,
                                                                          vectorization_mode="sync"))):
            for pname, policy in (("LQR", lqr), ("random", random_controls)):
                us, ended = time_vector(make(), policy, steps, args.repeats)
                print(f"| {name} | {n} | {pname} | {us:.0f} | {us / n:.1f} | {1e6 * n / us:.0f} | {ended:.0f} |")
    reacher(args)




def reacher(args):
    """Gymnasium's Reacher-v5 (two links with armature: tumble's tree solve) with random controls (no
    terminations; truncated at 50 steps): single environments and vector environments side by side."""
    import gymnasium as gym

    import tumble.envs  # noqa: F401

    def random2(obs, rng):
        return rng.uniform(-1.0, 1.0, size=obs.shape[:-1] + (2,)).astype(np.float32)

    print()
    print("| Reacher-v5, random controls | copies | us per step | us per environment step | environment steps/s |")
    print("|---|---|---|---|---|")
    for n in args.reacher_sizes:
        if n == 1:
            for name, make in (("tumble Reacher", lambda: gym.make("tumble/Reacher-v5")),
                               ("Gymnasium Reacher-v5 (MuJoCo)", lambda: gym.make("Reacher-v5"))):
                us, _ = time_single(make(), random2, args.steps, args.repeats)
                print(f"| {name} | 1 | {us:.1f} | {us:.1f} | {1e6 / us:.0f} |")
            continue
        steps = max(20, 20000 // n)
        for name, make in (
                ("tumble ModelVectorEnv", lambda: gym.make_vec("tumble/Reacher-v5", num_envs=n,
                                                               vectorization_mode="vector_entry_point")),
                ("Gymnasium SyncVectorEnv (MuJoCo)", lambda: gym.make_vec("Reacher-v5", num_envs=n,
                                                                          vectorization_mode="sync"))):
            us, _ = time_vector(make(), random2, steps, args.repeats)
            print(f"| {name} | {n} | {us:.0f} | {us / n:.1f} | {1e6 * n / us:.0f} |")


if __name__ == "__main__":
    main()
