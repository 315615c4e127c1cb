"""Gymnasium environments: tumble's ``InvertedPendulum`` (``tumble.envs``) beside Gymnasium's own
``InvertedPendulum-v5`` stepped by MuJoCo, on the same model file, in the same run.

Single environments: ``env.step`` from a Python loop, microseconds a step (one step is 2 simulator
steps of 0.02 s), with two policies: the LQR of tests/test_envs.py (the pole stays up, no
resets) and uniform random controls (the pole falls within about 8 steps: resets are part of the
cost). Vector environments: tumble's ``ModelVectorEnv`` (all copies in one World, one step)
against Gymnasium's ``SyncVectorEnv`` over MuJoCo environments (a Python loop over them), microseconds
per vector step and per environment step. Then Gymnasium's ``Reacher-v5`` (a two-link arm with
armature: tumble's tree solve), the double pendulum (InvertedDoublePendulum-v5) and the runners (HalfCheetah-v5, Hopper-v5, Walker2d-v5: contacts
with the floor) the same way, with random controls. Median of ``--repeats`` timings of ``--steps`` steps
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
    ap.add_argument("--runner-sizes", type=int, nargs="+", default=[1, 64, 256])
    ap.add_argument("--sections", nargs="+", default=["pendulum", "reacher", "double", "pusher", "swimmer", "runners",
                                                      "ant", "humanoid"],
                    choices=["pendulum", "reacher", "double", "pusher", "swimmer", "runners", "ant", "humanoid"])
    args = ap.parse_args()
    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    import mujoco

    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, tumble git "
          f"{rev}, gymnasium {gym.__version__}, mujoco {mujoco.__version__}; median of {args.repeats}")
    print()
    if "pendulum" in args.sections:
        pendulum(args, gym, te)
    if "reacher" in args.sections:
        random_task(args, "Reacher", 2, args.reacher_sizes)
    if "double" in args.sections:
        random_task(args, "InvertedDoublePendulum", 1, args.reacher_sizes)
    if "pusher" in args.sections:
        random_task(args, "Pusher", 7, args.reacher_sizes)
    if "swimmer" in args.sections:
        random_task(args, "Swimmer", 2, args.reacher_sizes)
    if "runners" in args.sections:
        for task, nu in (("HalfCheetah", 6), ("Hopper", 3), ("Walker2d", 6)):
            random_task(args, task, nu, args.runner_sizes)
    if "ant" in args.sections:  # Ant-v5: four legs on the floor, its observation's contact forces
        random_task(args, "Ant", 8, args.runner_sizes)
    if "humanoid" in args.sections:  # 17 motors within +-0.4; the walker falls (episodes end), the standup lies
        for task in ("Humanoid", "HumanoidStandup"):
            random_task(args, task, 17, args.runner_sizes, limit=0.4)


def pendulum(args, gym, te):
    """InvertedPendulum-v5: single environments (LQR and random controls) and vector ones."""
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




def random_task(args, task: str, nu: int, sizes, limit: float = 1.0):
    """Gymnasium's ``TASK-v5`` and tumble's ``tumble/TASK-v5`` with uniform random controls in [-1, 1]
    (``nu`` of them): single environments (size 1) and vector environments side by side. The
    reacher (two links with armature: tumble's tree solve) is truncated at 50 steps, the pusher
    (seven joints with armature, an object on the table) at 100, the swimmer (in MuJoCo's fluid,
    tumble.Fluid) at 1000; the runners
    (contacts with the floor in every step; each vector copy in an env of its own) at 1000, the
    hopper and walker terminated when they fall; the humanoids' controls within +-``limit``
    (their range, 0.4): the walking humanoid terminated when it falls (z < 1 m), the standup never."""
    import gymnasium as gym

    import tumble.envs  # noqa: F401

    def controls(obs, rng):
        return rng.uniform(-limit, limit, size=obs.shape[:-1] + (nu,)).astype(np.float32)

    print()
    print(f"| {task}-v5, random controls | copies | us per step | us per environment step | environment steps/s | "
          "episodes ended per round |")
    print("|---|---|---|---|---|---|")
    for n in sizes:
        if n == 1:
            for name, make in ((f"tumble {task}", lambda: gym.make(f"tumble/{task}-v5")),
                               (f"Gymnasium {task}-v5 (MuJoCo)", lambda: gym.make(f"{task}-v5"))):
                us, resets = time_single(make(), controls, args.steps, args.repeats)
                print(f"| {name} | 1 | {us:.1f} | {us:.1f} | {1e6 / us:.0f} | {resets:.0f} |")
            continue
        steps = max(20, 20000 // n)
        for name, make in (
                ("tumble ModelVectorEnv", lambda: gym.make_vec(f"tumble/{task}-v5", num_envs=n,
                                                               vectorization_mode="vector_entry_point")),
                ("Gymnasium SyncVectorEnv (MuJoCo)", lambda: gym.make_vec(f"{task}-v5", num_envs=n,
                                                                          vectorization_mode="sync"))):
            us, ended = time_vector(make(), controls, steps, args.repeats)
            print(f"| {name} | {n} | {us:.0f} | {us / n:.1f} | {1e6 * n / us:.0f} | {ended:.0f} |")


if __name__ == "__main__":
    main()
