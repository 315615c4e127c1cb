"""Learning to balance a pole on tumble: the cross-entropy method over linear policies, each
generation's candidates run side by side as the copies of one vector environment.

Gymnasium's ``InvertedPendulum-v5`` task (its model file, reward and termination) stepped by tumble
(``tumble.envs``): a policy u = clip(w . obs, -3, 3) earns 1 a step while the pole is within 0.2
rad of upright, for at most ``--horizon`` steps. Each generation draws ``--population`` weight
vectors from a Gaussian, runs them all at once in a ``ModelVectorEnv`` of as many copies (one
World, one compiled step for all), keeps the best fifth and refits the Gaussian to them (Rubinstein's
cross-entropy method; Szita and Lorincz, Neural Computation 18, 2006, on Tetris). No gradient and no
model: what it learns comes from episodes alone. The policy found is then tried on Gymnasium's own
environment stepped by MuJoCo, when the mujoco package is installed (sim-to-sim transfer).

    python examples/control/cem_pendulum.py --out out/cem
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np


def episode_returns(venv, weights: np.ndarray, horizon: int, seed: int) -> np.ndarray:
    """(P,) the first episode's return of each candidate (P, 4), copy k running candidate k."""
    obs, _ = venv.reset(seed=seed)
    returns = np.zeros(len(weights))
    running = np.ones(len(weights), dtype=bool)
    for _ in range(horizon):
        actions = np.clip(np.einsum("pd,pd->p", weights, obs), -3.0, 3.0)[:, None]
        obs, reward, terminated, truncated, _ = venv.step(actions)
        returns += np.where(running, reward, 0.0)
        running &= ~(terminated | truncated)
        if not running.any():
            break
    return returns


def cross_entropy_method(population: int = 48, generations: int = 12, horizon: int = 1000, seed: int = 0,
                         log=print) -> dict:
    """The search (module docstring): {"weights": (4,) the last mean, "history": per generation
    (mean return, best return, seconds)}."""
    import tumble.envs as te

    rng = np.random.default_rng(seed)
    venv = te.ModelVectorEnv(te.InvertedPendulum, population, max_episode_steps=horizon)
    mean, std = np.zeros(4), np.full(4, 5.0)
    elite = max(2, population // 5)
    history = []
    for g in range(generations):
        t0 = time.perf_counter()
        weights = mean + std * rng.standard_normal((population, 4))
        returns = episode_returns(venv, weights, horizon, seed=seed + 1000 * g)
        best = weights[np.argsort(returns)[::-1][:elite]]
        mean, std = best.mean(axis=0), best.std(axis=0) + 0.05  # the added spread keeps it searching
        history.append((float(returns.mean()), float(returns.max()), time.perf_counter() - t0))
        log(f"generation {g:2d}: mean return {returns.mean():7.1f}, best {returns.max():6.0f} "
            f"({history[-1][2]:.1f} s)")
        if returns.mean() >= 0.95 * horizon:
            break
    return {"weights": mean, "history": history}


def evaluate(env, weights, episodes: int = 3, seed: int = 100) -> list:
    """Returns of ``episodes`` episodes of u = clip(w . obs) on ``env`` (a single environment)."""
    out = []
    for k in range(episodes):
        obs, _ = env.reset(seed=seed + k)
        total, done = 0.0, False
        while not done:
            obs, reward, terminated, truncated, _ = env.step(
                np.clip([weights @ obs], -3.0, 3.0).astype(np.float32))
            total += reward
            done = terminated or truncated
        out.append(total)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/cem")
    ap.add_argument("--population", type=int, default=48)
    ap.add_argument("--generations", type=int, default=12)
    ap.add_argument("--horizon", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    import gymnasium as gym

    import tumble.envs  # noqa: F401  (registers tumble/InvertedPendulum-v5)

    found = cross_entropy_method(args.population, args.generations, args.horizon, args.seed)
    w = found["weights"]
    summary = {"weights": w.tolist(), "history": found["history"],
               "tumble_returns": evaluate(gym.make("tumble/InvertedPendulum-v5", max_episode_steps=args.horizon), w)}
    print(f"policy w = {np.array2string(w, precision=3)}: returns on tumble {summary['tumble_returns']}")
    try:
        import mujoco  # noqa: F401
    except ImportError:
        summary["mujoco_returns"] = None
        print("(mujoco is not installed: the policy is not tried on Gymnasium's MuJoCo environment)")
    else:
        summary["mujoco_returns"] = evaluate(gym.make("InvertedPendulum-v5", max_episode_steps=args.horizon), w)
        print(f"returns on Gymnasium's MuJoCo environment {summary['mujoco_returns']}")
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "summary.json"), "w") as fh:
        json.dump(summary, fh, indent=2)
    return summary


if __name__ == "__main__":
    main()
