"""joint_grid: Box3D's 100 x 100 net of spheres on 19 800 ball joints (/work/shared/BENCHMARKS.md),
in tumble (standalone joint stepper) and, in the same run, MuJoCo.

The scene (BENCHMARKS.md): gravity (0, -10, 0), y up; body (k, i), k, i = 0..99, a sphere of
radius 0.4 and density 1000 (268.1 kg) at (k, -i, 0); row i = 0 static. Ball joints between
(k, i-1) at local (0, -0.5, 0) and (k, i) at (0, 0.5, 0), and between (k-1, i) at (0.5, 0, 0)
and (k, i) at (-0.5, 0, 0): 19 800 joints (99 of them static-static). No contacts.
dt = 1/60 s, 4 substeps, 100 steps.

tumble: ``step_with_joints`` with Box2D v3's settings (soft rows 60 Hz, damping ratio 2,
one Gauss-Seidel sweep and one relax sweep per substep; ``JointSettings()``), timed per
1/60 s step; the first step (Numba compile or cache load) is timed apart. The figure is the
median step time over the 100 steps, and the best of ``--repeats`` runs from the start.

MuJoCo: the columns are kinematic chains of ball joints hanging from the static top row (a
tree, which MuJoCo solves in generalised coordinates) and the horizontal links are
``connect`` equality constraints (9 801 of them; those between two static bodies are left
out). timestep 1/240 s, four ``mj_step`` per 1/60 s step, the default solver (Newton) and
settings. Timed the same way over ``--mujoco-steps`` steps (MuJoCo is much slower here, and
compiling the 100-level-deep model takes minutes; it needs ``<size memory>``).

Run from the repository root:

    PYTHONPATH=src python benchmarks/joint_grid.py [--size 100] [--steps 100] [--repeats 3]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

RADIUS = 0.4
DENSITY = 1000.0
DT = 1.0 / 60.0
SUBSTEPS = 4


def build_tumble(n: int):
    import tumble as tb
    from tumble.joints import BallJoint

    w = tb.World(gravity=(0.0, -10.0, 0.0))
    index = {}
    for k in range(n):
        for i in range(n):
            b = w.add_body(tb.Sphere(RADIUS), density=None if i == 0 else DENSITY, position=(k, -i, 0.0),
                           fixed=(i == 0), name=f"s{k}_{i}")
            index[k, i] = b.index
    for k in range(n):
        for i in range(n):
            if i > 0:
                w.add_joint(BallJoint(index[k, i - 1], index[k, i], anchor=(0, -0.5, 0), anchor_b=(0, 0.5, 0),
                                      frame="body"))
            if k > 0:
                w.add_joint(BallJoint(index[k - 1, i], index[k, i], anchor=(0.5, 0, 0), anchor_b=(-0.5, 0, 0),
                                      frame="body"))
    return w


def time_tumble(n: int, steps: int, repeats: int):
    from tumble.solver.joints import JointSettings, JointSolver, step_with_joints

    t0 = time.perf_counter()
    w = build_tumble(n)
    build = time.perf_counter() - t0
    start = w.pack().copy()
    runs = []
    compile_time = None
    for r in range(repeats):
        w.unpack(start)
        w.t = 0.0
        solver = JointSolver(JointSettings())
        times = []
        for s in range(steps):
            t0 = time.perf_counter()
            step_with_joints(w, solver, DT, SUBSTEPS)
            dt = time.perf_counter() - t0
            if r == 0 and s == 0:
                compile_time = dt
                continue
            times.append(dt)
        runs.append(statistics.median(times))
    # quality: the largest anchor gap at the end (m)
    a, b = solver.joint_a, solver.joint_b
    pa = np.einsum("jkl,jl->jk", w.R[a], solver.local_a) + w.x[a]
    pb = np.einsum("jkl,jl->jk", w.R[b], solver.local_b) + w.x[b]
    gap = float(np.linalg.norm(pa - pb, axis=1).max())
    return {"build_s": build, "first_step_s": compile_time, "ms_per_step": 1e3 * min(runs),
            "runs_ms": [1e3 * t for t in runs], "bodies": w.body_count, "joints": len(w.joints),
            "max_gap_m": gap, "lowest_y": float(w.x[:, 1].min())}


def mjcf(n: int) -> str:
    mass = DENSITY * 4.0 / 3.0 * math.pi * RADIUS**3
    out = ['<mujoco model="joint_grid">',
           '  <size memory="1500M"/>',
           f'  <option timestep="{DT / SUBSTEPS!r}" gravity="0 -10 0"/>',
           '  <default><geom type="sphere" size="0.4" contype="0" conaffinity="0"/></default>',
           "  <worldbody>"]
    for k in range(n):
        # static top body, then the column as a chain of ball joints 1 m apart
        out.append(f'    <body name="b{k}_0" pos="{k} 0 0"><geom/>')
        depth = 1
        for i in range(1, n):
            out.append("  " * depth + f'    <body name="b{k}_{i}" pos="0 -1 0">'
                       f'<joint type="ball" pos="0 0.5 0" damping="0"/><geom mass="{mass!r}"/>')
            depth += 1
        out.append("  " * depth + "    " + "</body>" * n)
    out.append("  </worldbody>")
    out.append("  <equality>")
    for k in range(1, n):
        for i in range(1, n):
            out.append(f'    <connect body1="b{k - 1}_{i}" body2="b{k}_{i}" anchor="0.5 0 0"/>')
    out.append("  </equality>")
    out.append("</mujoco>")
    return "\n".join(out)


def time_mujoco(n: int, steps: int):
    import mujoco

    t0 = time.perf_counter()
    model = mujoco.MjModel.from_xml_string(mjcf(n))
    build = time.perf_counter() - t0
    data = mujoco.MjData(model)
    times = []
    for s in range(steps):
        t0 = time.perf_counter()
        for _ in range(SUBSTEPS):
            mujoco.mj_step(model, data)
        times.append(time.perf_counter() - t0)
    # quality: the largest gap of the connect constraints (m)
    gap = 0.0
    for e in range(model.neq):
        b1, b2 = model.eq_obj1id[e], model.eq_obj2id[e]
        p1 = data.xpos[b1] + data.xmat[b1].reshape(3, 3) @ model.eq_data[e, 0:3]
        p2 = data.xpos[b2] + data.xmat[b2].reshape(3, 3) @ model.eq_data[e, 3:6]
        gap = max(gap, float(np.linalg.norm(p1 - p2)))
    return {"build_s": build, "ms_per_step": 1e3 * statistics.median(times[1:] if len(times) > 1 else times),
            "nv": model.nv, "neq": model.neq, "max_gap_m": gap, "lowest_y": float(data.xpos[:, 1].min()),
            "steps": steps, "version": mujoco.__version__}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=100, help="net size (default 100: Box3D's)")
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--mujoco-steps", type=int, default=5)
    ap.add_argument("--no-mujoco", action="store_true")
    args = ap.parse_args()
    n = args.size
    print(f"joint_grid {n} x {n}: dt 1/60 s, {SUBSTEPS} substeps, {args.steps} steps")
    r = time_tumble(n, args.steps, args.repeats)
    print(f"tumble  : {r['ms_per_step']:.1f} ms/step (median per step, best of {args.repeats} runs: "
          f"{', '.join(f'{t:.1f}' for t in r['runs_ms'])}); first step {r['first_step_s']:.2f} s; "
          f"build {r['build_s']:.1f} s; {r['bodies']} bodies, {r['joints']} joints; "
          f"after {args.steps} steps max anchor gap {r['max_gap_m']:.3g} m, lowest y {r['lowest_y']:.2f} m")
    if args.no_mujoco:
        return
    try:
        import mujoco  # noqa: F401
    except ImportError:
        print("mujoco: not installed")
        return
    m = time_mujoco(n, args.mujoco_steps)
    print(f"mujoco {m['version']}: {m['ms_per_step']:.1f} ms/step (median of {m['steps']} steps, 4 x mj_step "
          f"at 1/240 s); build {m['build_s']:.1f} s; nv {m['nv']}, {m['neq']} connect constraints; after "
          f"{m['steps']} steps max connect gap {m['max_gap_m']:.3g} m, lowest y {m['lowest_y']:.2f} m")
    print(f"ratio mujoco / tumble: {m['ms_per_step'] / r['ms_per_step']:.2f}")


if __name__ == "__main__":
    main()
