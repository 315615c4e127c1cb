"""ball_drive: the cost of a ball joint's drive (``BallJoint(stiffness, damping)``), beside MuJoCo on
the same MJCF file.

Scene: a cable of N capsules (10 cm long, 1.5 cm radius, density 1000) hung from the world, each link
on a ball joint with ``stiffness`` and ``damping`` (MuJoCo's ball joint spring: a stiff rope that
springs back), held out level at the start so that it swings down, whips and settles; no contact
(the links' geoms have contype 0). The same file runs in MuJoCo (its default Euler integrator with
implicit damping at dt 1/240 s, and RK4 at the same dt) and in tumble (``tb.load_mjcf``, default
joint solver at dt 1/240 s; and the exact tree solve), and in tumble again without the drives
(stiffness and damping 0: what the drive rows cost). Times: wall time per step of a 2 s run, median
of ``--repeats`` runs after a warm-up (compilation apart). Quality: the tip's height at the end
against MuJoCo's Euler at dt 1/20000 s (the reference; its RK4, explicit in the damping, blows up on
these stiff light links even at small steps).

    PYTHONPATH=src python benchmarks/ball_drive.py --links 10 30 --repeats 3 [--out FILE]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

from report import emit, machine_line  # noqa: E402

DT, DURATION = 1 / 240, 2.0
LINK, RADIUS = 0.1, 0.015


def cable_xml(links: int, stiffness: float, damping: float) -> str:
    """The cable as MJCF: nested bodies along +x, each with a ball joint at its start."""
    body = ""
    for i in range(links):
        pos = "0 0 1" if i == 0 else f"{LINK:g} 0 0"
        body += (f'<body name="l{i}" pos="{pos}"><joint name="j{i}" type="ball" stiffness="{stiffness:g}" '
                 f'damping="{damping:g}"/><geom type="capsule" fromto="0 0 0 {LINK:g} 0 0" size="{RADIUS:g}" '
                 f'contype="0" conaffinity="0"/>')
    body += "</body>" * links
    return (f'<mujoco model="cable"><option timestep="{DT!r}"/><worldbody>{body}</worldbody></mujoco>')


def stiffness_for(links: int) -> float:
    """N m/rad at every joint: the root's spring turned 1 rad by the level cable's weight (a cable's
    bending stiffness is the same along it, so the links near the tip barely bend)."""
    mass = 1000.0 * (np.pi * RADIUS ** 2 * LINK + 4 / 3 * np.pi * RADIUS ** 3)
    return float(9.81 * mass * links * (links * LINK / 2))


def mujoco_run(path, integrator: str, dt: float, duration: float) -> tuple[float, float]:
    """(wall s per step, tip height at the end) of MuJoCo."""
    import mujoco

    m = mujoco.MjModel.from_xml_path(path)
    m.opt.timestep = dt
    m.opt.integrator = {"euler": mujoco.mjtIntegrator.mjINT_EULER,
                        "rk4": mujoco.mjtIntegrator.mjINT_RK4}[integrator]
    d = mujoco.MjData(m)
    steps = int(round(duration / dt))
    t0 = time.perf_counter()
    mujoco.mj_step(m, d, nstep=steps)
    wall = time.perf_counter() - t0
    if any(w.number > 0 for w in d.warning):
        return wall / steps, float("nan")  # it blew up (and MuJoCo reset its state) or warned
    tip = d.xpos[m.nbody - 1] + d.xmat[m.nbody - 1].reshape(3, 3) @ np.array([LINK, 0.0, 0.0])
    return wall / steps, float(tip[2])


def tumble_run(path, method: str | None) -> tuple[float, float]:
    """(wall s per step, tip height at the end) of tumble."""
    import tumble as tb
    from tumble.solver.joints import ACCURATE

    world = tb.World(gravity=(0, 0, -9.81))
    tb.load_mjcf(world, path)
    world.sleeping = False  # a settled cable would sleep and cost nothing: time the steps themselves
    sim = tb.Simulator(world, dt=DT, joint_settings=ACCURATE if method == "tree" else None)
    last = world.body_count - 1
    links = last  # body 0 is the model's world body
    x0, R0 = np.array(world.x[last]), np.array(world.R[last])
    tip0 = np.array([links * LINK, 0.0, 1.0])  # the last link's far end at the start
    steps = int(round(DURATION / DT))
    t0 = time.perf_counter()
    sim.step(steps)
    wall = time.perf_counter() - t0
    tip = world.x[last] + world.R[last] @ R0.T @ (tip0 - x0)
    return wall / steps, float(tip[2])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--links", type=int, nargs="+", default=[10, 30])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    lines = ["# ball joint drive: a cable of capsules on sprung ball joints", "", machine_line(), "",
             "| links | engine | variant | us/step | tip z at 2 s (m) | off the reference (m) |",
             "|---|---|---|---|---|---|"]
    tmp = tempfile.mkdtemp()
    for n in args.links:
        k = stiffness_for(n)
        files = {}
        for name, (kk, cc) in {"drive": (k, 0.1 * k), "free": (0.0, 0.0)}.items():
            files[name] = os.path.join(tmp, f"cable{n}_{name}.xml")
            with open(files[name], "w") as f:
                f.write(cable_xml(n, kk, cc))
        # the reference: MuJoCo's Euler (its damping implicit, the springs explicit) at dt 1/20000 s,
        # stable where its RK4 (all explicit) is not: the links' own rates are up to ~1e4 1/s
        _, ref = mujoco_run(files["drive"], "euler", 1 / 20000, DURATION)
        _, check = mujoco_run(files["drive"], "euler", 1 / 10000, DURATION)
        rows = [("mujoco", "Euler (implicit damping)", lambda: mujoco_run(files["drive"], "euler", DT, DURATION)),
                ("mujoco", "RK4", lambda: mujoco_run(files["drive"], "rk4", DT, DURATION)),
                ("tumble", "drives, Gauss-Seidel", lambda: tumble_run(files["drive"], None)),
                ("tumble", "drives, tree", lambda: tumble_run(files["drive"], "tree")),
                ("tumble", "no drives, Gauss-Seidel", lambda: tumble_run(files["free"], None))]
        for engine, variant, run in rows:
            run()  # warm-up: compilation apart
            results = [run() for _ in range(args.repeats)]
            per_step = statistics.median(r[0] for r in results)
            tip = results[-1][1]
            off = "" if variant.startswith("no drives") else f"{abs(tip - ref):.2e}"
            shown = "unstable" if np.isnan(tip) else f"{tip:.4f}"
            lines.append(f"| {n} | {engine} | {variant} | {per_step * 1e6:.0f} | {shown} | {off} |")
        lines.append(f"| {n} | (reference) | MuJoCo Euler at 1/20000 s | | {ref:.4f} | 1/10000 s: {abs(check - ref):.1e} |")
    lines += ["", "Reference: MuJoCo Euler at dt 1/20000 s; stiffness per joint = 9.81 m_cable "
                  "(L/2) N m/rad (the level cable's weight turns the root 1 rad), damping 10 % of it (N m s/rad)."]
    emit(lines, args.out)


if __name__ == "__main__":
    main()
