"""A/B: the time of one step of small scenes, where Python between the compiled calls is most of
the step, at two revisions interleaved in one run, with MuJoCo's time for the same scene beside
them (``--peers``). Each revision is a checkout (``git worktree add --detach DIR REV``):

    python benchmarks/step_overhead.py OLD_DIR NEW_DIR [--rounds 5] [--peers] [CASE ...]

Cases: ``free`` (one box in free flight, spinning: ``sim.step()``), ``box`` (a box resting on a
plane, sleeping off), ``cartpole_tree`` and ``cartpole`` (examples/robots/cartpole.xml, the tree
joint method and the default one; sleeping off, the pole tipped 0.1 rad so that it falls and
swings), ``tower`` (10 boxes, examples/tower.toml, sleeping off), ``arm``
(examples/robot_arm.toml), ``pendulum`` (InvertedPendulum-v5, a single env step: 2 physics
steps), ``hopper`` (Hopper-v5: 4), ``ant`` (Ant-v5: 5). Each timing is a fresh process: 50
warm-up steps (compilation apart), then the median of 5 blocks of 400 steps (200 for the ant),
microseconds per step; the table gives the median over the rounds. Also prints a digest of the
final state of each (the same bits at both revisions, or the change is not an overhead change).

``--peers``: the same scene in MuJoCo (``mujoco.mj_step`` one call at a time: a free box, a box
on a plane, the cartpole file itself; the envs: Gymnasium's own MuJoCo ``InvertedPendulum-v5``,
``Hopper-v5``, ``Ant-v5``, ``env.step`` with the same random actions), timed the same way in its own
process in each round. NUMBA_CACHE_DIR, NUMBA_NUM_THREADS and OMP_WAIT_POLICY are passed on."""
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
    if case == "free":
        w = tb.World(gravity=(0, 0, -9.81))
        w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 100), angular_velocity=(1, 2, 3))
        sim = tb.Simulator(w, dt=1 / 240)
    elif case == "box":
        w = tb.World(gravity=(0, 0, -9.81))
        w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
        w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 0.1))
        w.sleeping = False
        sim = tb.Simulator(w, dt=1 / 240)
    elif case in ("cartpole", "cartpole_tree"):
        from tumble.solver.joints import JointSettings
        w = tb.World(gravity=(0, 0, -9.81))
        robot = tb.load_mjcf(w, "examples/robots/cartpole.xml")
        w.sleeping = False
        extra = {"joint_settings": JointSettings(method="tree")} if case == "cartpole_tree" else {}
        sim = tb.Simulator(w, dt=1 / 240, **extra)
        robot.reset_joint_positions(sim, {"hinge": 0.1})
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

PEER = r'''
import time, sys, json, statistics, numpy as np
case = sys.argv[1]
import mujoco
FREE = """<mujoco><option timestep="0.0041666667"/><worldbody><body pos="0 0 100"><freejoint/>
<geom type="box" size=".1 .1 .1" mass="1"/></body></worldbody></mujoco>"""
BOX = """<mujoco><option timestep="0.0041666667"/><worldbody><geom type="plane" size="10 10 .1"/>
<body pos="0 0 0.1"><freejoint/><geom type="box" size=".1 .1 .1" mass="1"/></body></worldbody></mujoco>"""
if case in ("pendulum", "hopper", "ant"):
    import gymnasium as gym
    task = {"pendulum": "InvertedPendulum", "hopper": "Hopper", "ant": "Ant"}[case]
    env = gym.make(f"{task}-v5").unwrapped
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    lo, hi = env.action_space.low, env.action_space.high
    actions = rng.uniform(lo, hi, (100_000, lo.shape[0])).astype(np.float32)
    it = iter(actions)
    def step():
        o, r, t, tr, _ = env.step(next(it))
        if t or tr:
            env.reset(seed=1)
elif case in ("free", "box", "cartpole", "cartpole_tree"):
    if case in ("free", "box"):
        m = mujoco.MjModel.from_xml_string(FREE if case == "free" else BOX)
    else:
        m = mujoco.MjModel.from_xml_path("examples/robots/cartpole.xml")
        m.opt.timestep = 1 / 240
    d = mujoco.MjData(m)
    if case == "free":
        d.qvel[3:6] = (1, 2, 3)
    elif case != "box":
        d.qpos[1] = 0.1
    step = lambda: mujoco.mj_step(m, d)
else:
    print(json.dumps(None))
    raise SystemExit
for _ in range(50):
    step()
n = 200 if case == "ant" else 400
times = []
for _ in range(5):
    t = time.perf_counter()
    for _ in range(n):
        step()
    times.append(1e6 * (time.perf_counter() - t) / n)
print(json.dumps(statistics.median(times)))
'''

CASES = ["free", "box", "cartpole_tree", "cartpole", "tower", "arm", "pendulum", "hopper", "ant"]


def peer_runs(cases: list, rounds: int) -> dict:
    """{case: [MuJoCo's us per step (Gymnasium's env.step for the envs), one a round]}."""
    import json
    import subprocess

    out = {}
    for _ in range(rounds):
        for case in cases:
            run = subprocess.run([sys.executable, "-c", PEER, case], cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                 capture_output=True, text=True)
            if run.returncode:
                raise SystemExit(f"MuJoCo {case}: {run.stderr.strip().splitlines()[-1]}")
            value = json.loads(run.stdout.strip().splitlines()[-1])
            if value is not None:
                out.setdefault(case, []).append(value)
    return out


def main(argv):
    args = list(argv)
    rounds = take_rounds(args, 5)
    peers = "--peers" in args
    if peers:
        args.remove("--peers")
    old, new, *cases = args
    cases = cases or CASES
    runs = interleaved(code, old, new, [(case,) for case in cases], rounds)
    mujoco = peer_runs(cases, rounds) if peers else {}
    us = {(case, rev): [u for u, _ in runs[((case,), rev)]] for case in cases for rev in ("old", "new")}
    digests = {(case, rev): runs[((case,), rev)][-1][1] for case in cases for rev in ("old", "new")}
    print("| case | before: us per step | after | change | same bits | MuJoCo |")
    print("|---|---|---|---|---|---|")
    for case in cases:
        a, b = statistics.median(us[(case, "old")]), statistics.median(us[(case, "new")])
        same = "yes" if digests[(case, "old")] == digests[(case, "new")] else "NO"
        peer = f"{statistics.median(mujoco[case]):.1f}" if case in mujoco else "-"
        print(f"| {case} | {a:.1f} | {b:.1f} | {100 * (b / a - 1):+.1f} % | {same} | {peer} |")


if __name__ == "__main__":
    main(sys.argv[1:])
