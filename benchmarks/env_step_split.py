"""The time of a single Gymnasium environment step split: the whole step, the soft step (``SoftStep.step``), its compiled substeps (``SoftStep._fused_substeps``) and its collision stages (``SoftStep.collide``), us per environment step over 1500 steps under random controls (50 warm-up steps apart). Run it at two checkouts one after the other, several times, to tell a change in the compiled substeps from the noise of the whole step:

    PYTHONPATH=src python benchmarks/env_step_split.py Hopper
"""
import time, sys, numpy as np, gymnasium as gym
import tumble.envs  # noqa: F401  (registers tumble/...-v5)
from tumble.solver import soft_step as ss
acc = {"fused": 0.0, "step": 0.0, "collide": 0.0}
def wrap(name, key):
    f = getattr(ss.SoftStep, name)
    def g(self, *a, **k):
        t = time.perf_counter(); r = f(self, *a, **k); acc[key] += time.perf_counter() - t; return r
    setattr(ss.SoftStep, name, g)
wrap("_fused_substeps", "fused"); wrap("step", "step"); wrap("collide", "collide")
task = sys.argv[1]
env = gym.make(f"tumble/{task}-v5").unwrapped
env.reset(seed=0)
rng = np.random.default_rng(0)
lo, hi = env.action_space.low, env.action_space.high
for _ in range(50): env.step(rng.uniform(lo, hi).astype(np.float32))
for k in acc: acc[k] = 0.0
N = 1500
t = time.perf_counter()
for _ in range(N):
    o, r, te, tr, _ = env.step(rng.uniform(lo, hi).astype(np.float32))
    if te or tr: env.reset(seed=1)
tot = time.perf_counter() - t
print(task, "env step %.0f us" % (tot / N * 1e6), " ".join("%s %.0f" % (k, v / N * 1e6) for k, v in acc.items()))
