"""Where the tree method's side-by-side sweep of joint groups pays (``JointSolver._group_tables``,
``GROUP_THREADS_MIN_NODES``): vector environments of 2 to 64 copies, the serial sweep over the
world (threshold raised past every world) against the groups side by side on the threads
(threshold 0), in one process, the two interleaved, median of 3; microseconds per environment
step under random controls, 10 warm-up steps apart.

    PYTHONPATH=src python benchmarks/group_threads.py [TASK ...]   (default: Ant Hopper)
"""
import statistics
import sys
import time

import gymnasium as gym
import numpy as np

import tumble.envs  # noqa: F401  (registers tumble/...-v5)
from tumble.solver import joints as J


def main(tasks):
    print("| task | copies | tree nodes | serial | side by side | ratio |")
    print("|---|---|---|---|---|---|")
    for task in tasks:
        for n in [2, 4, 8, 16, 32, 64]:
            res = {}
            nodes = 0
            for _ in range(3):
                for label, threshold in (("serial", 10**9), ("groups", 0)):
                    J.GROUP_THREADS_MIN_NODES = threshold
                    env = gym.make_vec(f"tumble/{task}-v5", num_envs=n, vectorization_mode="vector_entry_point")
                    env.reset(seed=0)
                    nu = env.single_action_space.shape[0]
                    rng = np.random.default_rng(0)
                    for _ in range(10):
                        env.step(rng.uniform(-0.4, 0.4, (n, nu)).astype(np.float32))
                    steps = max(20, 600 // n)
                    t = time.perf_counter()
                    for _ in range(steps):
                        env.step(rng.uniform(-0.4, 0.4, (n, nu)).astype(np.float32))
                    res.setdefault(label, []).append((time.perf_counter() - t) / steps / n * 1e6)
                    nodes = len(env.unwrapped.sim.soft_step.joints.node_order)
            a, b = statistics.median(res["serial"]), statistics.median(res["groups"])
            print(f"| {task}-v5 | {n} | {nodes} | {a:.0f} | {b:.0f} | {b / a:.2f} |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or ["Ant", "Hopper"])
