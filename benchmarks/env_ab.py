"""A/B: the environment step time of Gymnasium tasks on tumble (default Ant-v5 and HalfCheetah-v5:
models with armature, for the tree solve's projection before its Gauss-Seidel rows, session 34;
Humanoid too) at two revisions, interleaved in one run. Each revision is a checkout
(``git worktree add --detach DIR REV``):

    python benchmarks/env_ab.py OLD_DIR NEW_DIR [TASK ...]   (default: Ant HalfCheetah)

Prints a table: the median of 3 timings (a single env: 300 steps; a vector env: 60 steps of 64
copies), microseconds per environment step, each timing in a fresh process after 20 warm-up steps
(compilation apart)."""
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(__file__))
from interleaved import interleaved  # noqa: E402

code = r'''
import time, numpy as np, gymnasium as gym, sys, json
import tumble.envs
task, n, steps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
nu = {"Ant": 8, "HalfCheetah": 6, "Hopper": 3, "Humanoid": 17}[task]
limit = 0.4 if task == "Humanoid" else 1.0
rng = np.random.default_rng(0)
if n == 1:
    env = gym.make(f"tumble/{task}-v5"); env.reset(seed=0)
    def step():
        o, r, t, tr, _ = env.step(rng.uniform(-limit, limit, nu).astype(np.float32))
        if t or tr: env.reset()
else:
    env = gym.make_vec(f"tumble/{task}-v5", num_envs=n, vectorization_mode="vector_entry_point"); env.reset(seed=0)
    def step():
        env.step(rng.uniform(-limit, limit, (n, nu)).astype(np.float32))
for _ in range(20): step()
t = time.perf_counter()
for _ in range(steps): step()
print(json.dumps(1e6 * (time.perf_counter() - t) / steps / n))
'''
TASKS = [(t, n, 300 if n == 1 else 60) for t in (sys.argv[3:] or ["Ant", "HalfCheetah"]) for n in (1, 64)]
results = {(case[0], case[1], rev): runs for (case, rev), runs in
           interleaved(code, sys.argv[1], sys.argv[2], TASKS, 3).items()}
print("| task | copies | before: us per env step | after | change |")
print("|---|---|---|---|---|")
for task, n, _ in TASKS:
    a, b = statistics.median(results[(task, n, "old")]), statistics.median(results[(task, n, "new")])
    print(f"| {task}-v5 | {n} | {a:.1f} | {b:.1f} | {100 * (b / a - 1):+.1f} % |")
