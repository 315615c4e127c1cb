"""A/B: the time of one step of small scenes, where Python between the compiled calls is most of
the step, at two revisions interleaved in one run. Each revision is a checkout
(``git worktree add --detach DIR REV``):

    python benchmarks/step_overhead.py OLD_DIR NEW_DIR [--rounds 5] [CASE ...]

Cases: ``box`` (a box resting on a plane, sleeping off: ``sim.step()``), ``tower`` (10 boxes,
examples/tower.toml, sleeping off), ``arm`` (examples/robot_arm.toml), ``pendulum``
(InvertedPendulum-v5, a single env step: 2 physics steps), ``hopper`` (Hopper-v5: 4), ``ant``
(Ant-v5: 5). Each timing is a fresh process: 50 warm-up steps (compilation apart), then the
median of 5 blocks of 400 steps (200 for the ant), microseconds per step; the table gives the
median over the rounds. Also prints a digest of the final state of each (the same bits at both
revisions, or the change is not an overhead change)."""
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(__file__))
from interleaved import interleaved, take_rounds  # noqa: E402

code = r'''
import time, hashlib, sys, json, statistics, numpy as np
import tumble as tb
case = sys.argv[1]
if case in ("pendulum", "hopper", "ant"):
    import gymnasium as gym, tumble.envs
    task = {"pendulum": "InvertedPendulum", "hopper": "Hopper", "ant": "Ant"}[case]
    env = gym.make(f"tumble/{task}-v5").unwrapped
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    lo, hi = env.action_space.low, env.action_space.high
    actions = rng.uniform(lo, hi, (100_000, lo.shape[0])).astype(np.float32)
    it = iter(actions)
    def step():
        o, r, t, tr, _ = env.step(next(it))
        if t or tr:
            env.reset(seed=1)
    world = lambda: env.world
else:
    if case == "box":
        w = tb.World(gravity=(0, 0, -9.81))
        w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
        w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 0.1))
        w.sleeping = False
        sim = tb.Simulator(w, dt=1 / 240)
    else:
        scene = tb.load_scene({"tower": "examples/tower.toml", "arm": "examples/robot_arm.toml"}[case])
        sim = scene.simulator()
        sim.world.sleeping = False
    step = sim.step
    world = lambda: sim.world
for _ in range(50):
    step()
blocks = 5
n = 200 if case == "ant" else 400
times = []
for _ in range(blocks):
    t = time.perf_counter()
    for _ in range(n):
        step()
    times.append(1e6 * (time.perf_counter() - t) / n)
w = world()
digest = hashlib.sha256(w.pack().tobytes()).hexdigest()[:12] if w is not None else "-"
print(json.dumps([statistics.median(times), digest]))
'''

CASES = ["box", "tower", "arm", "pendulum", "hopper", "ant"]


def main(argv):
    args = list(argv)
    rounds = take_rounds(args, 5)
    old, new, *cases = args
    cases = cases or CASES
    runs = interleaved(code, old, new, [(case,) for case in cases], rounds)
    us = {(case, rev): [u for u, _ in runs[((case,), rev)]] for case in cases for rev in ("old", "new")}
    digests = {(case, rev): runs[((case,), rev)][-1][1] for case in cases for rev in ("old", "new")}
    print("| case | before: us per step | after | change | same bits |")
    print("|---|---|---|---|---|")
    for case in cases:
        a, b = statistics.median(us[(case, "old")]), statistics.median(us[(case, "new")])
        same = "yes" if digests[(case, "old")] == digests[(case, "new")] else "NO"
        print(f"| {case} | {a:.1f} | {b:.1f} | {100 * (b / a - 1):+.1f} % | {same} |")


if __name__ == "__main__":
    main(sys.argv[1:])
