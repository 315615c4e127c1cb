"""ragdolls: n ragdolls falling into a pile (issue 4's joint benchmark), in tumble and, in the same
run, MuJoCo.

The scene (``tumble.scenes.ragdolls.ragdolls(n, seed)``): n copies of the ragdoll of
examples/joints/ragdoll_stairs.toml (11 bodies: box pelvis and torso, sphere head, capsule
limbs; ball joints with cone limits at the waist 30 deg, neck 40, shoulders 90, hips 70;
hinges with limits at the elbows -150..0 deg and knees 0..150 deg; 10 joints), read from the
TOML file and copied over a 10 x 10 grid 1 m apart, each with a seeded random yaw, its lowest
point at a seeded random height of 1 to 3 m, at rest; ground plane z = 0; friction 0.5
everywhere, restitution 0; gravity 9.81. 5 s simulated.

tumble: ``tumble.Simulator(world, dt=1/60)``: the soft step with its default 4 solver substeps
(h = 1/240 s), joints and contacts solved together with the default JointSettings (Box2D v3's
soft rows, Gauss-Seidel), sleeping on (the World's default). Run twice by default: with all
Numba threads and with one (``--tumble-threads``): MuJoCo steps on one thread, and on this
shared 2-core machine tumble's parallel kernels (the contact solve by graph colours from 2048
contacts, the narrowphase from 1024 candidate pairs) were far slower than one thread.

MuJoCo: MJCF generated here from the tumble World: each ragdoll a kinematic tree rooted at its
pelvis (free joint), the other bodies nested under the body_a of their joint; the same geoms
(box, sphere, capsule; MuJoCo's capsule size is the radius and half the cylinder length), the
masses and body-frame inertias tumble computes (``world.mass``, ``world.inertia_body``, as
``<inertial>``), body frames placed at tumble's body frames (centre of mass), so both engines'
body poses compare directly. Ball joints ``type="ball"`` with ``range="0 cone_limit"``, hinges
``type="hinge"`` about the same axis with the same range. Contacts: MuJoCo's defaults (soft
contacts solref 0.02 1, pyramidal friction cones), friction 0.5 (MuJoCo takes the max of the two
geoms, tumble sqrt(fa fb): the same here), parent-child contacts filtered (MuJoCo's default,
and tumble's: jointed bodies do not collide). timestep 1/240 s, the default Euler integrator
and Newton solver (``--mujoco-solver`` to change it), no sleeping.

Limits do not mean the same: tumble's cone limit bounds the swing, the angle between the cone
axis fixed in body_a and its copy fixed in body_b (twist about that axis is free); MuJoCo's ball
joint range bounds the whole rotation angle of the joint's quaternion (swing and twist
together) from the start pose, about any axis. MuJoCo's limit is therefore the stricter one
(swing <= rotation angle); the two agree for rotations without twist. Hinge ranges mean the
same (angle of body_b about the axis relative to body_a, from the start pose). MuJoCo solves
limits as soft constraints (solreflimit 0.02 1), tumble as soft rows (60 Hz): both can
overshoot under impact.

What is timed: the scene is built apart ("load": tumble World; MuJoCo: MJCF text + compile).
tumble's Numba kernels are compiled (or loaded from the cache) on a throw-away warm-up scene of
4 ragdolls dropped onto the ground in contact from the first step and stepped 1 s (the first
step's time is "first step s", the whole warm-up "warm-up s"). Each run then starts from the
initial state (a fresh World and Simulator; a fresh MjData) and steps 5 s; only the stepping is
timed. "wall s" is the median over runs (a variant whose first run is longer than --long-run
runs once), ms/step per step of the engine's own dt, "ms per
1/60 s" per 1/60 s of simulated time (comparable across engines).

Quality (computed the same way for both engines, from body poses and velocities, sampled every
1/60 s of simulated time outside the timer):
  max anchor gap       largest distance (m) between a joint's two anchor points (each fixed in
                       its body: ``world.joints[k].bound.local_a`` / ``local_b``); MuJoCo's
                       joints are exact by construction (generalised coordinates): its gap is
                       round-off
  deepest below ground largest depth (m) of any body's lowest point below z = 0
  max speed            largest centre-of-mass speed (m/s) at the end
  limits > 2 deg       joints beyond their limit by more than 2 degrees at the end (ball: swing
                       angle over the cone limit, tumble's meaning; hinge: angle outside its
                       range); "worst" the largest excess (deg) at the end and over the run
  pelvises > 0.3 m     ragdolls whose pelvis centre ends above 0.3 m (lying on another ragdoll:
                       the pelvis is 0.3 m at its longest)

Run from the repository root:

    PYTHONPATH=src python benchmarks/ragdolls.py                        # 100 ragdolls, 5 s, 3 runs each
    PYTHONPATH=src python benchmarks/ragdolls.py --n 4 --duration 0.5 --runs 1   # a quick check

Prints a Markdown table and writes benchmarks/results/ragdolls[_<n>][_<tag>].csv and .md.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
sys.path.insert(0, str(HERE))

from contact import machine, md_table, write_results
from peers.common import fmt, median
from peers.mujoco_scenes import step_counting_iterations

SAMPLE_INTERVAL = 1.0 / 60.0
LIMIT_TOLERANCE_DEG = 2.0
MUJOCO_DT = 1.0 / 240.0
#: a pelvis (0.3 m at its longest) whose centre ends higher than this rests on another ragdoll
PILED_PELVIS_Z = 0.3


# --------------------------------------------------------------------------- quality


class JointTable:
    """The joints of a World as arrays (from each joint's ``bound``): what the quality figures read."""

    def __init__(self, world):
        from tumble.joints import JOINT_BALL, JOINT_HINGE, P_LIMIT_ON, P_LOWER, P_UPPER

        bound = [j.bound for j in world.joints]
        self.a = np.array([b.body_a for b in bound])
        self.b = np.array([b.body_b for b in bound])
        if (self.a < 0).any() or (self.b < 0).any():
            raise ValueError("joints to the world are not supported here")
        self.local_a = np.array([b.local_a for b in bound])
        self.local_b = np.array([b.local_b for b in bound])
        self.frame_a = np.array([b.frame_a for b in bound])
        self.frame_b = np.array([b.frame_b for b in bound])
        self.type = np.array([b.type_id for b in bound])
        self.lower = np.array([b.param[P_LOWER] for b in bound])
        self.upper = np.array([b.param[P_UPPER] for b in bound])
        self.limited = np.array([b.param[P_LIMIT_ON] > 0 for b in bound])
        self.ball = self.type == JOINT_BALL
        self.hinge = self.type == JOINT_HINGE

    def gaps(self, x, R) -> np.ndarray:
        """(J,) m: distance between the two anchors."""
        pa = np.einsum("jkl,jl->jk", R[self.a], self.local_a) + x[self.a]
        pb = np.einsum("jkl,jl->jk", R[self.b], self.local_b) + x[self.b]
        return np.linalg.norm(pa - pb, axis=1)

    def limit_excess(self, R) -> np.ndarray:
        """(J,) rad by which each joint is beyond its limits (0 inside; ball: swing over the cone
        limit; hinge: angle outside [lower, upper], on the circle)."""
        Fa = R[self.a] @ self.frame_a  # world joint frames, columns x, y, z
        Fb = R[self.b] @ self.frame_b
        out = np.zeros(len(self.a))
        za, zb = Fa[:, :, 2], Fb[:, :, 2]
        swing = np.arctan2(np.linalg.norm(np.cross(za, zb), axis=1), np.sum(za * zb, axis=1))
        m = self.ball & self.limited
        out[m] = np.maximum(0.0, swing[m] - self.upper[m])
        xa, ya, xb, yb = Fa[:, :, 0], Fa[:, :, 1], Fb[:, :, 0], Fb[:, :, 1]
        angle = np.arctan2(np.sum(ya * xb, axis=1) - np.sum(xa * yb, axis=1),
                           np.sum(xa * xb, axis=1) + np.sum(ya * yb, axis=1))
        m = self.hinge & self.limited
        best = np.full(len(self.a), np.inf)
        for turn in (-2 * math.pi, 0.0, 2 * math.pi):
            th = angle + turn
            best = np.minimum(best, np.maximum(0.0, np.maximum(self.lower - th, th - self.upper)))
        out[m] = best[m]
        return out


class Tracker:
    """Quality figures over a run from samples (x, R) of all bodies (tumble's body order)."""

    def __init__(self, shapes, moving: np.ndarray, joints: JointTable):
        self.shapes = [shapes[i] for i in moving]
        self.moving = moving
        self.joints = joints
        self.max_gap_run = 0.0
        self.max_depth_run = 0.0
        self.max_excess_run = 0.0
        children = set(joints.b.tolist())
        self.roots = np.array([i for i in moving if i not in children])  # one per ragdoll: the pelvis
        self.finite = True
        self.last = None

    def sample(self, x, R):
        from tumble.scenes.ragdolls import lowest_point_z

        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(R))):
            self.finite = False
        gap = float(self.joints.gaps(x, R).max())
        low = lowest_point_z(self.shapes, x[self.moving], R[self.moving])
        depth = float(max(0.0, -low.min()))
        excess = self.joints.limit_excess(R)
        self.max_gap_run = max(self.max_gap_run, gap)
        self.max_depth_run = max(self.max_depth_run, depth)
        self.max_excess_run = max(self.max_excess_run, float(excess.max()))
        self.last = (gap, depth, excess, x[self.roots, 2].copy())

    def figures(self, v) -> dict:
        gap, depth, excess, root_z = self.last
        tol = math.radians(LIMIT_TOLERANCE_DEG)
        return {"max_gap_end_m": gap, "max_gap_run_m": self.max_gap_run, "depth_end_m": depth,
                "depth_run_m": self.max_depth_run, "max_speed_end": float(np.linalg.norm(v[self.moving], axis=1).max()),
                "beyond_limits_end": int((excess > tol).sum()),
                "beyond_limits_ball_end": int(((excess > tol) & self.joints.ball).sum()),
                "beyond_limits_hinge_end": int(((excess > tol) & self.joints.hinge).sum()),
                "worst_excess_end_deg": math.degrees(float(excess.max())),
                "worst_excess_run_deg": math.degrees(self.max_excess_run), "finite": self.finite,
                "pelvis_above_0.3m_end": int((root_z > PILED_PELVIS_Z).sum()), "highest_pelvis_end_m": float(root_z.max())}


def run(engine, tracker_factory, dt: float, steps: int, timeout: float) -> dict:
    """Step ``engine`` ``steps`` times of dt, sampling every SAMPLE_INTERVAL; only stepping is timed."""
    per_sample = max(1, round(SAMPLE_INTERVAL / dt))
    tracker = tracker_factory()
    tracker.sample(*engine.poses())
    wall = 0.0
    slowest = 0.0
    done = 0
    load0 = os.getloadavg()[0]
    while done < steps:
        k = min(per_sample, steps - done)
        t0 = time.perf_counter()
        engine.step(k)
        took = time.perf_counter() - t0
        wall += took
        slowest = max(slowest, took)
        done += k
        tracker.sample(*engine.poses())
        if wall > timeout and done < steps:
            break
    out = {"wall_s": wall, "slowest_60th_ms": 1e3 * slowest, "steps_done": done, "steps": steps, "complete": done == steps, "sim_time": done * dt,
           "loadavg_start": load0, "loadavg_end": os.getloadavg()[0]}
    out.update(tracker.figures(engine.velocities()))
    out.update(engine.extra())
    return out


# --------------------------------------------------------------------------- tumble


class TumbleRagdolls:
    """A fresh World and ``tumble.Simulator(world, dt=1/60)`` (the soft step's default 4 substeps)."""

    def __init__(self, n: int, seed: int, **scene_kw):
        self.n, self.seed, self.scene_kw = n, seed, scene_kw
        t0 = time.perf_counter()
        self.reset()
        self.load_s = time.perf_counter() - t0

    def reset(self):
        import tumble as tb
        from tumble.scenes.ragdolls import ragdolls

        self.world, self.settings = ragdolls(self.n, self.seed, **self.scene_kw)
        self.dt = self.settings["dt"]
        self.sim = tb.Simulator(self.world, dt=self.dt)

    def step(self, k: int):
        self.sim.step(k)

    def poses(self):
        return self.world.x, self.world.R

    def velocities(self):
        return self.world.v

    def extra(self) -> dict:
        sleep = self.sim.sleep
        moving = np.flatnonzero(self.world.moving)
        asleep = None if sleep is None else int((~sleep.awake[moving]).sum())
        return {"asleep_end": asleep, "contacts_end": len(self.sim.contacts().body_a)}


def tumble_warmup(seed: int) -> tuple[float, float]:
    """(first step s, whole warm-up s): 4 ragdolls 0.6 m apart, standing within the speculative
    margin of the ground (contacts from the first step), stepped 1 s so that they fall onto one
    another. The big scene takes the parallel narrowphase (from 1024 candidate pairs) that 4
    ragdolls never reach: its threshold is lowered for the warm-up only, so that kernel compiles
    (or loads from the cache) here too."""
    from tumble.collision import narrowphase as NP

    saved = NP.PARALLEL_MIN_CANDIDATES
    t0 = time.perf_counter()
    try:
        eng = TumbleRagdolls(4, seed, spacing=0.6, heights=(0.0, 0.01))
        t1 = time.perf_counter()
        eng.step(1)
        first = time.perf_counter() - t1
        eng.step(29)
        NP.PARALLEL_MIN_CANDIDATES = 1
        eng.step(30)
    finally:
        NP.PARALLEL_MIN_CANDIDATES = saved
    return first, time.perf_counter() - t0 - eng.load_s


# --------------------------------------------------------------------------- MuJoCo


def _f(v) -> str:
    return " ".join(repr(float(c)) for c in np.atleast_1d(v))


def _quat_conj_mul(p, q):
    """conj(p) * q for unit quaternions (w, x, y, z)."""
    pw, px, py, pz = p[0], -p[1], -p[2], -p[3]
    qw, qx, qy, qz = q
    return np.array([pw * qw - px * qx - py * qy - pz * qz, pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx, pw * qz + px * qy - py * qx + pz * qw])


def mjcf(world, solver: str = "Newton", integrator: str = "Euler", dt: float = MUJOCO_DT, friction: float = 0.5) -> str:
    """MJCF of a tumble World of jointed trees of boxes, spheres and capsules on a ground plane.

    Each tree is nested from its root (a body that is never a joint's body_b; free joint); a
    joint's body_b becomes a child of its body_a. Body frames = tumble's body frames."""
    from tumble import Box, Capsule, Plane, Sphere
    from tumble.joints import JOINT_BALL, JOINT_HINGE, P_LIMIT_ON, P_LOWER, P_UPPER

    moving = [int(i) for i in np.flatnonzero(world.moving)]
    children: dict[int, list[tuple[int, object]]] = {i: [] for i in moving}
    parent = {}
    for j in world.joints:
        bj = j.bound
        if bj.body_b in parent or bj.body_a < 0 or bj.body_b < 0:
            raise ValueError("MJCF export handles trees with every joint's body_b a child of its body_a")
        parent[bj.body_b] = bj.body_a
        children[bj.body_a].append((bj.body_b, bj))
    x, q = world.x, world.q
    n_bodies = len(moving)
    out = ['<mujoco model="ragdolls">',
           '  <compiler angle="radian" autolimits="true"/>',
           f'  <option timestep="{dt!r}" gravity="{_f(world.gravity)}" integrator="{integrator}" solver="{solver}"/>',
           f'  <size memory="{64 + n_bodies // 4}M"/>',
           f'  <default><geom friction="{friction!r} 0.005 0.0001"/></default>',
           "  <worldbody>"]
    for i in np.flatnonzero(~world.moving):
        s = world.shapes[i]
        if not (isinstance(s, Plane) and np.allclose(s.normal, (0, 0, 1)) and s.offset == 0.0):
            raise TypeError("MJCF export supports the ground plane z = 0 as the only fixed body")
        out.append('    <geom name="ground" type="plane" size="0 0 1"/>')

    def geom(i):
        s = world.shapes[i]
        if isinstance(s, Box):
            return f'<geom type="box" size="{_f(s.half_extents)}"/>'
        if isinstance(s, Sphere):
            return f'<geom type="sphere" size="{s.radius!r}"/>'
        if isinstance(s, Capsule):
            return f'<geom type="capsule" size="{s.radius!r} {0.5 * s.length!r}"/>'
        raise TypeError(f"MJCF export: unsupported shape {type(s).__name__}")

    def inertial(i):
        I = world.inertia_body[i]
        return (f'<inertial pos="0 0 0" mass="{float(world.mass[i])!r}" '
                f'fullinertia="{_f([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])}"/>')

    def joint(bj, name):
        p = bj.param
        if bj.type_id == JOINT_BALL:
            rng = f' range="0 {float(p[P_UPPER])!r}"' if p[P_LIMIT_ON] > 0 else ""
            return f'<joint name="{name}" type="ball" pos="{_f(bj.local_b)}"{rng}/>'
        if bj.type_id == JOINT_HINGE:
            rng = f' range="{float(p[P_LOWER])!r} {float(p[P_UPPER])!r}"' if p[P_LIMIT_ON] > 0 else ""
            return f'<joint name="{name}" type="hinge" pos="{_f(bj.local_b)}" axis="{_f(bj.frame_b[:, 2])}"{rng}/>'
        raise TypeError(f"MJCF export: unsupported joint type {bj.type_id}")

    def emit(i, par, bj, depth):
        ind = "    " * depth
        if par is None:
            pos, quat, jtext = x[i], q[i], "<freejoint/>"
        else:
            Rp = world.R[par]
            pos = Rp.T @ (x[i] - x[par])
            quat = _quat_conj_mul(q[par], q[i])
            jtext = joint(bj, f"j_{world.names[i]}")
        out.append(f'{ind}<body name="{world.names[i]}" pos="{_f(pos)}" quat="{_f(quat)}">{jtext}{inertial(i)}{geom(i)}')
        for c, cbj in children[i]:
            emit(c, i, cbj, depth + 1)
        out.append(f"{ind}</body>")

    for i in moving:
        if i not in parent:
            emit(i, None, None, 2)
    out += ["  </worldbody>", "</mujoco>"]
    return "\n".join(out)


class MujocoRagdolls:
    """One compiled model of the tumble scene; ``reset()`` gives a fresh MjData at the start."""

    def __init__(self, world, solver: str, integrator: str = "Euler"):
        import mujoco

        self.mj = mujoco
        self.dt = MUJOCO_DT
        self.solver, self.integrator = solver, integrator
        t0 = time.perf_counter()
        self.xml = mjcf(world, solver, integrator)
        self.model = mujoco.MjModel.from_xml_string(self.xml)
        self.load_s = time.perf_counter() - t0
        self.ids = np.array([mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name) if world.moving[i] else 0
                             for i, name in enumerate(world.names)])
        self.n = world.body_count
        self.reset()

    def reset(self):
        self.data = self.mj.MjData(self.model)
        self.mj.mj_forward(self.model, self.data)
        self._iters = 0
        self._steps = 0

    def step(self, k: int):
        self._iters += step_counting_iterations(self.mj, self.model, self.data, k)
        self._steps += k

    def poses(self):
        d = self.data
        return d.xpos[self.ids].copy(), d.xmat[self.ids].reshape(-1, 3, 3).copy()

    def velocities(self):
        v = np.zeros((self.n, 3))
        res = np.zeros(6)
        for i, b in enumerate(self.ids):
            if b > 0:
                self.mj.mj_objectVelocity(self.model, self.data, self.mj.mjtObj.mjOBJ_BODY, int(b), res, 0)
                v[i] = res[3:]
        return v

    def extra(self) -> dict:
        return {"asleep_end": None, "contacts_end": int(self.data.ncon),
                "solver_iters": self._iters / self._steps if self._steps else None}


# --------------------------------------------------------------------------- reporting


def table(rows) -> str:
    header = ["engine", "settings", "ragdolls", "bodies", "joints", "dt", "runs", "load s", "first step s",
              "wall s (median)", "ms/step", "ms per 1/60 s", "slowest 1/60 s (ms, last run)", "real-time factor", "max anchor gap end (m)",
              "max anchor gap run (m)", "deepest below ground end (m)", "deepest run (m)", "max speed end (m/s)",
              "joints > 2 deg beyond limits end (ball + hinge)", "worst excess end / run (deg)",
              "pelvises > 0.3 m end (on others)", "asleep end", "contacts end"]
    out = []
    for r in rows:
        wall = fmt(r["wall_s"], ".2f") if r["complete"] else f"INCOMPLETE: {r['sim_time']:.2f} s sim in {r['wall_s']:.0f} s"
        out.append([r["engine"], r["settings"], r["n"], r["bodies"], r["joints"], r["dt_label"], r["runs"],
                    fmt(r["load_s"], ".2f"),
                    "-" if r.get("first_step_s") is None else f"{r['first_step_s']:.2f} (warm-up {r['warmup_s']:.1f})",
                    wall, fmt(r["ms_per_step"], ".2f"), fmt(r["ms_per_60th"], ".1f"), fmt(r["slowest_60th_ms"], ".0f"), fmt(r["rtf"], ".3f"),
                    fmt(r["max_gap_end_m"], ".2e"), fmt(r["max_gap_run_m"], ".2e"), fmt(r["depth_end_m"], ".2e"),
                    fmt(r["depth_run_m"], ".2e"), fmt(r["max_speed_end"], ".3g"),
                    f"{r['beyond_limits_end']} ({r['beyond_limits_ball_end']} + {r['beyond_limits_hinge_end']})",
                    f"{r['worst_excess_end_deg']:.1f} / {r['worst_excess_run_deg']:.1f}",
                    f"{r['pelvis_above_0.3m_end']} (highest {r['highest_pelvis_end_m']:.2f} m)",
                    "-" if r.get("asleep_end") is None else r["asleep_end"], r["contacts_end"]])
    return md_table(header, out)


def measure(label, make_engine, reset, tracker_factory, steps, args):
    eng = make_engine()
    results = []
    for k in range(args.runs):
        if k > 0:
            reset(eng)
        r = run(eng, tracker_factory, eng.dt, steps, args.timeout)
        results.append(r)
        print(f"  {label} run {k + 1}: {r['wall_s']:.2f} s wall for {r['sim_time']:.2f} s simulated"
              f"{'' if r['complete'] else ' (INCOMPLETE)'}, load average {r['loadavg_start']:.2f} -> "
              f"{r['loadavg_end']:.2f}", flush=True)
        if not r["complete"] or r["wall_s"] > args.long_run:
            break
    last = results[-1]
    walls = [r["wall_s"] for r in results if r["complete"]]
    wall = median(walls) if walls else last["wall_s"]
    row = {k: v for k, v in last.items() if k != "wall_s"}
    row.update({"wall_s": wall, "walls": " ".join(f"{w:.3f}" for w in walls), "runs": len(results),
                "load_s": eng.load_s, "dt": eng.dt,
                "ms_per_step": 1e3 * wall / steps if last["complete"] else None,
                "ms_per_60th": 1e3 * wall / (steps * eng.dt * 60) if last["complete"] else None,
                "rtf": last["sim_time"] / wall if wall else None,
                "loadavg_start": min(r["loadavg_start"] for r in results),
                "loadavg_end": max(r["loadavg_end"] for r in results)})
    return eng, row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=100, help="ragdolls (default 100)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--spacing", type=float, default=1.0, help="grid spacing, m (default 1)")
    ap.add_argument("--heights", type=float, nargs=2, default=(1.0, 3.0), help="drop heights of the lowest points, m")
    ap.add_argument("--duration", type=float, default=5.0, help="simulated s (default 5)")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--engines", nargs="+", choices=("tumble", "mujoco"), default=["tumble", "mujoco"])
    ap.add_argument("--mujoco-solver", default="Newton", choices=("Newton", "CG", "PGS"))
    ap.add_argument("--tumble-threads", nargs="+", default=["all", "1"],
                    help="Numba thread counts for tumble, one variant each (default: all, then 1)")
    ap.add_argument("--timeout", type=float, default=900.0, help="stop a run after this many s of stepping")
    ap.add_argument("--long-run", type=float, default=60.0, help="a variant whose first run is longer runs once")
    ap.add_argument("--tag", default=None, help="suffix of the result files")
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)

    from tumble.scenes.ragdolls import ragdolls

    scene_kw = {"spacing": args.spacing, "heights": tuple(args.heights)}
    world0, settings = ragdolls(args.n, args.seed, **scene_kw)
    joints = JointTable(world0)
    moving = np.flatnonzero(world0.moving)
    shapes = list(world0.shapes)
    info = machine()
    print(f"# ragdolls: {args.n} ragdolls ({len(moving)} bodies, {len(world0.joints)} joints), {args.duration:g} s "
          f"simulated, {info['date']}, {info['cpu']} ({info['nproc']} CPUs), load average "
          f"{' '.join(f'{v:.2f}' for v in os.getloadavg())}, tumble git {info['tumble_git']}", flush=True)

    def tracker():
        return Tracker(shapes, moving, joints)

    common = {"n": args.n, "bodies": len(moving), "joints": len(world0.joints)}
    rows = []
    if "tumble" in args.engines:
        import numba

        all_threads = numba.config.NUMBA_NUM_THREADS
        first, warm = tumble_warmup(args.seed)
        print(f"  tumble warm-up: first step {first:.2f} s, warm-up {warm:.1f} s", flush=True)
        steps = round(args.duration / settings["dt"])
        for threads in args.tumble_threads:
            t = all_threads if threads == "all" else int(threads)
            numba.set_num_threads(t)
            eng, row = measure(f"tumble ({t} thread{'s' if t > 1 else ''})", lambda: TumbleRagdolls(args.n, args.seed, **scene_kw),
                               TumbleRagdolls.reset, tracker, steps, args)
            row.update(common, engine="tumble", first_step_s=first, warmup_s=warm, dt_label="1/60 x4", threads=t,
                       settings=f"Simulator(dt=1/60): soft step 4 substeps, JointSettings() (soft rows, Gauss-Seidel), "
                                f"sleeping on; {t} Numba thread{'s' if t > 1 else ''}")
            rows.append(row)
        numba.set_num_threads(all_threads)
    if "mujoco" in args.engines:
        import mujoco

        steps = round(args.duration / MUJOCO_DT)
        eng, row = measure("mujoco", lambda: MujocoRagdolls(world0, args.mujoco_solver), MujocoRagdolls.reset,
                           tracker, steps, args)
        row.update(common, engine=f"mujoco {mujoco.__version__}", dt_label="1/240", threads=1,
                   settings=f"Euler, {args.mujoco_solver} (mean {row['solver_iters']:.1f} iterations/step, worst island); "
                            f"nv {eng.model.nv}; joints exact (generalised coordinates); 1 thread")
        rows.append(row)

    text = table(rows)
    loads = ", ".join(f"{r['engine']} ({r['threads']} thr.) {r['loadavg_start']:.2f}-{r['loadavg_end']:.2f}" for r in rows)
    header = (f"## ragdolls: {args.n} ragdolls, {args.duration:g} s simulated, seed {args.seed}, grid spacing "
              f"{args.spacing:g} m, dropped from {args.heights[0]:g}-{args.heights[1]:g} m ({info['date']})\n\n"
              f"Command: `PYTHONPATH=src python benchmarks/ragdolls.py {' '.join(argv if argv is not None else sys.argv[1:])}`. "
              f"Machine: {info['cpu']}, {info['nproc']} CPUs (shared), {info['platform']}, Python {info['python']}; "
              f"numpy {info['numpy']}, numba {info['numba']} ({info['numba_threads']} threads), mujoco {info['mujoco']}; "
              f"tumble git {info['tumble_git']}. Load average (1 min) over the runs: {loads}.\n")
    notes = ("\nNotes: ms/step is per step of the engine's own dt (tumble 1/60 s with 4 solver substeps, MuJoCo "
             "1/240 s); ms per 1/60 s compares them directly. MuJoCo's anchor gap is round-off (its joints are exact "
             "in generalised coordinates). Limit excess is measured with tumble's meaning (ball: swing over the cone "
             "limit); MuJoCo's ball range bounds the whole rotation angle (swing and twist), a stricter limit. "
             "tumble sleeps bodies at rest (its default), MuJoCo does not.\n")
    print()
    print(header)
    print(text)
    print(notes)
    args.out.mkdir(parents=True, exist_ok=True)
    default = args.n == 100 and args.duration == 5.0 and args.spacing == 1.0 and tuple(args.heights) == (1.0, 3.0)
    tag = args.tag or (None if default else f"{args.n}_{args.duration:g}s_spacing{args.spacing:g}")
    stem = "ragdolls" + (f"_{tag}" if tag else "")
    write_results(args.out, stem, header + "\n" + text + "\n" + notes, rows, info)
    return 0


if __name__ == "__main__":
    sys.exit(main())
