"""free_bodies: tumble and MuJoCo side by side on the scene of /work/shared/BENCHMARKS.md (table a).

N boxes with half-extents (0.1, 0.2, 0.3), mass 1, seeded random orientation,
|omega| = 5 rad/s in a random direction, no gravity, collisions off,
dt = 1/240 s; 1000 steps (200 at N >= 10 000). A second variant adds gravity
(0, 0, -9.81) and, in tumble only, Drag(linear=0.1, angular_linear=0.01)
(MuJoCo's damping is a different model, so MuJoCo only gets gravity).

Run from the repository root:

    PYTHONPATH=src python benchmarks/free_bodies.py            # N = 1 ... 100 000
    PYTHONPATH=src python benchmarks/free_bodies.py --quick    # N = 1, 100, 1000, fewer repeats
    PYTHONPATH=src python benchmarks/free_bodies.py --sizes 1000 10000 --no-demo

Writes benchmarks/results/free_bodies.md (markdown tables, machine) and
benchmarks/results/free_bodies.csv (one row per measurement).

What is timed
-------------
tumble: ``Simulator.step(n_steps)`` (one compiled loop over all steps, plus one
pack/unpack of the World around it), median over repeats, each repeat starting
from the same saved state (``World.pack()`` / ``unpack()``). The World build
and the first (compiling or cache-loading) call are timed apart.
MuJoCo: ``mj_step`` in a Python loop, and ``mujoco.rollout.rollout`` with one
MjData (the step loop runs in C, in the calling thread; it also copies the
full physics state out after every step). The C loop is the fair engine-loop
comparison. Both engines run single-threaded here.
"""

from __future__ import annotations

import argparse
import csv
import datetime as _dt
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"

HALF = np.array([0.1, 0.2, 0.3])
MASS = 1.0
OMEGA = 5.0
DT = 1.0 / 240.0
SEED = 20240601
GRAVITY = (0.0, 0.0, -9.81)
TUMBLE_INTEGRATORS = ("semi-implicit-euler", "rk4", "splitting")
# which MuJoCo integrator each tumble integrator is compared with (same force evaluations: 1 or 4)
PAIRING = {"semi-implicit-euler": "euler", "rk4": "rk4", "splitting": "euler"}
GOAL_RATIO = 10.0  # at N >= 1000: tumble body-steps/s >= 10 x MuJoCo's
GOAL_OVERHEAD_US = 50.0  # Python overhead per step at N = 1


# --------------------------------------------------------------------------- scene


def scene(n: int, seed: int = SEED):
    """Positions (n, 3) on a 1 m grid in z = 0, unit quaternions (n, 4) (w, x, y, z), world omega (n, 3)."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    d = rng.normal(size=(n, 3))
    omega = OMEGA * d / np.linalg.norm(d, axis=1, keepdims=True)
    k = int(np.ceil(np.sqrt(n)))
    idx = np.arange(n)
    pos = np.stack([(idx % k) - 0.5 * (k - 1), (idx // k) - 0.5 * (k - 1), np.zeros(n)], axis=1).astype(float)
    return pos, q, omega


def quat_to_matrix(q):
    w, x, y, z = q.T
    R = np.empty((q.shape[0], 3, 3))
    R[:, 0, 0] = 1 - 2 * (y * y + z * z)
    R[:, 0, 1] = 2 * (x * y - w * z)
    R[:, 0, 2] = 2 * (x * z + w * y)
    R[:, 1, 0] = 2 * (x * y + w * z)
    R[:, 1, 1] = 1 - 2 * (x * x + z * z)
    R[:, 1, 2] = 2 * (y * z - w * x)
    R[:, 2, 0] = 2 * (x * z - w * y)
    R[:, 2, 1] = 2 * (y * z + w * x)
    R[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def steps_for(n: int) -> int:
    return 200 if n >= 10_000 else 1000


# --------------------------------------------------------------------------- tumble


def build_tumble_world(n, gravity=(0.0, 0.0, 0.0)):
    import tumble as tb

    pos, q, omega = scene(n)
    w = tb.World(gravity=gravity)
    box = tb.Box(size=tuple(2 * HALF))
    for i in range(n):
        w.add_body(box, mass=MASS, position=pos[i], orientation=q[i], angular_velocity=omega[i])
    return w


def _dispatchers():
    """Every Numba dispatcher of tumble.integrators (the stepping kernels change names as the code evolves)."""
    from numba.core.registry import CPUDispatcher
    from tumble import integrators as K

    return [v for v in vars(K).values() if isinstance(v, CPUDispatcher)]


def _stats_total(counter_attr):
    """Cache hits or misses summed over the integrator dispatchers (on-disk cache loads / compilations)."""
    return sum(sum(getattr(d.stats, counter_attr).values()) for d in _dispatchers())


def tumble_energy(world, with_potential):
    world.update_derived()
    e = world.kinetic_energy()
    if with_potential:
        e += world.potential_energy()
    return e


def time_tumble(world, integrator, n_steps, repeats, with_potential):
    """Median wall time of sim.step(n_steps) over repeats from the same start; energy drift after the last."""
    import tumble as tb

    Y0 = world.pack()
    world.unpack(Y0)
    e0 = tumble_energy(world, with_potential)
    sim = tb.Simulator(world, dt=DT, integrator=integrator)
    sim.step(1)  # warm-up: the kernel chosen for this N may not be compiled / loaded yet
    times = []
    for _ in range(repeats):
        world.unpack(Y0)
        world.t = 0.0
        sim.step_index = 0
        t0 = time.perf_counter()
        sim.step(n_steps)
        times.append(time.perf_counter() - t0)
    e1 = tumble_energy(world, with_potential)
    world.unpack(Y0)
    world.t = 0.0
    return statistics.median(times), min(times), (e1 - e0) / abs(e0)


def compile_probe(integrators=TUMBLE_INTEGRATORS):
    """First call (compile or cache load) vs a warm call of sim.step(1) at N = 1, per integrator, in call order."""
    t_import = time.perf_counter()
    import tumble as tb
    from tumble import integrators as K  # noqa: F401

    t_import = time.perf_counter() - t_import
    out = {"import_s": t_import, "rows": []}
    for integ in integrators:
        w = build_tumble_world(1)
        sim = tb.Simulator(w, dt=DT, integrator=integ)
        h0, m0 = _stats_total("cache_hits"), _stats_total("cache_misses")
        t0 = time.perf_counter()
        sim.step(1)
        first = time.perf_counter() - t0
        h1, m1 = _stats_total("cache_hits"), _stats_total("cache_misses")
        warm = []
        for _ in range(20):
            t0 = time.perf_counter()
            sim.step(1)
            warm.append(time.perf_counter() - t0)
        warm = statistics.median(warm)
        out["rows"].append(dict(integrator=integ, first_s=first, warm_s=warm, compile_s=first - warm,
                                cache_hits=h1 - h0, cache_misses=m1 - m0))
    out["cache_path"] = str(_dispatchers()[0].stats.cache_path) if _dispatchers() else ""
    return out


def cold_compile_probe(python):
    """compile_probe in a fresh interpreter with an empty NUMBA_CACHE_DIR (a true cold compile)."""
    cache = tempfile.mkdtemp(prefix="tumble-numba-cold-")
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=_pythonpath())
    try:
        t0 = time.perf_counter()
        r = subprocess.run([python, str(Path(__file__).resolve()), "--_compile-probe"], env=env,
                           capture_output=True, text=True, timeout=900)
        wall = time.perf_counter() - t0
        if r.returncode != 0:
            return {"error": r.stderr.strip()[-2000:]}
        out = json.loads(r.stdout.strip().splitlines()[-1])
        out["process_wall_s"] = wall
        return out
    finally:
        shutil.rmtree(cache, ignore_errors=True)


def _pythonpath():
    src = str(ROOT / "src")
    old = os.environ.get("PYTHONPATH", "")
    return src if not old else src + os.pathsep + old


def python_overhead(n_calls=10_000):
    """At N = 1: sim.step(1) in a Python loop, and sim.run(10 s) (2400 steps, 241 frames), vs the compiled loop."""
    import tumble as tb

    res = {}
    for integ in ("semi-implicit-euler", "rk4"):
        w = build_tumble_world(1)
        Y0 = w.pack()
        sim = tb.Simulator(w, dt=DT, integrator=integ)
        sim.step(1)
        # compiled loop cost per step at N = 1 (amortised over 100 000 steps)
        w.unpack(Y0)
        t0 = time.perf_counter()
        sim.step(100_000)
        kernel_us = (time.perf_counter() - t0) / 100_000 * 1e6
        w.unpack(Y0)
        loops = []
        for _ in range(3):
            w.unpack(Y0)
            t0 = time.perf_counter()
            for _ in range(n_calls):
                sim.step(1)
            loops.append((time.perf_counter() - t0) / n_calls * 1e6)
        call_us = statistics.median(loops)
        runs = []
        for _ in range(3):
            w.unpack(Y0)
            w.t = 0.0
            s2 = tb.Simulator(w, dt=DT, integrator=integ)
            t0 = time.perf_counter()
            s2.run(duration=10.0, progress=False)
            runs.append(time.perf_counter() - t0)
        run_s = statistics.median(runs)
        res[integ] = dict(kernel_us=kernel_us, step1_us=call_us, step1_overhead_us=call_us - kernel_us,
                          run_s=run_s, run_us_per_step=run_s / 2400 * 1e6,
                          run_overhead_us_per_step=run_s / 2400 * 1e6 - kernel_us,
                          run_us_per_frame=run_s / 240 * 1e6)
    return res


def kernel_breakdown(world, integrator, n_calls):
    """Time of each stage kernel of one step, called directly (what step_kernel fuses), us per call."""
    from tumble import integrators as K
    from tumble.world import Scratch

    tb_ = world.tables
    Y = world.pack()
    s = Scratch(world.body_count, world.state_size)
    lay = world.layout_id
    h = DT
    args_forces = (lay, Y, world.mass, world.inv_mass, world.inertia_body_inv, world.moving, world.gravity,
                   tb_.uforce_kind, tb_.uforce_param, tb_.uforce_start, tb_.spring_body, tb_.spring_anchor,
                   tb_.spring_param, s.R, s.v, s.omega, s.F, s.T)
    calls = {
        "accumulate_forces_kernel": lambda: K.accumulate_forces_kernel(*args_forces),
        "derivative_kernel": lambda: K.derivative_kernel(lay, Y, s.R, s.v, s.omega, world.moving, s.F, s.T, s.K),
        "axpy_kernel": lambda: K.axpy_kernel(Y, 0.0, s.K, s.Y1),
        "kick_kernel": lambda: K.kick_kernel(lay, Y, world.moving, s.F, s.T, 0.0),
        "drift_kernel(split=False)": lambda: K.drift_kernel(lay, Y, world.moving, world.inv_mass, world.inertia_body_inv,
                                                            world.principal_q, world.principal_moments, False, h),
        "drift_kernel(split=True)": lambda: K.drift_kernel(lay, Y, world.moving, world.inv_mass, world.inertia_body_inv,
                                                           world.principal_q, world.principal_moments, True, h),
        "project_orientation_kernel": lambda: K.project_orientation_kernel(lay, Y, world.moving),
    }
    per_step_counts = {
        "semi-implicit-euler": {"accumulate_forces_kernel": 1, "kick_kernel": 1, "drift_kernel(split=False)": 1,
                                "project_orientation_kernel": 1},
        "rk4": {"accumulate_forces_kernel": 4, "derivative_kernel": 4, "axpy_kernel": 8, "project_orientation_kernel": 1},
        "splitting": {"accumulate_forces_kernel": 2, "kick_kernel": 2, "drift_kernel(split=True)": 1,
                      "project_orientation_kernel": 1},
    }[integrator]
    out = []
    for name, count in per_step_counts.items():
        f = calls[name]
        f()
        ts = []
        for _ in range(3):
            t0 = time.perf_counter()
            for _ in range(n_calls):
                f()
            ts.append((time.perf_counter() - t0) / n_calls * 1e6)
        us = min(ts)
        out.append(dict(kernel=name, calls_per_step=count, us_per_call=us, us_per_step=us * count,
                        ns_per_body_call=us * 1e3 / world.body_count))
    return out


# --------------------------------------------------------------------------- MuJoCo


def set_mujoco_options(m, integrator, gravity):
    import mujoco

    m.opt.integrator = {"euler": mujoco.mjtIntegrator.mjINT_EULER, "rk4": mujoco.mjtIntegrator.mjINT_RK4}[integrator]
    m.opt.gravity[:] = gravity


def build_mujoco(n, integrator="euler", gravity=(0.0, 0.0, 0.0)):
    import mujoco

    pos, q, omega = scene(n)
    parts = ['<mujoco model="free_bodies"><compiler angle="radian"/>',
             '<option timestep="%r"><flag contact="disable"/></option>' % DT,
             # the default arena is too small from N = 10 000 on ("Could not allocate memory")
             '<size memory="%dM"/>' % max(64, (n * 32) // 1024),
             "<worldbody>"]
    size = "%g %g %g" % tuple(HALF)
    for i in range(n):
        parts.append('<body pos="%r %r %r"><freejoint/><geom type="box" size="%s" mass="%r" contype="0" conaffinity="0"/></body>'
                     % (float(pos[i, 0]), float(pos[i, 1]), float(pos[i, 2]), size, MASS))
    parts.append("</worldbody></mujoco>")
    m = mujoco.MjModel.from_xml_string("".join(parts))
    m.opt.timestep = DT
    set_mujoco_options(m, integrator, gravity)
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    d = mujoco.MjData(m)
    qpos = d.qpos.reshape(n, 7)
    qpos[:, :3] = pos
    qpos[:, 3:] = q
    # free joint qvel: linear velocity (world), angular velocity in the BODY frame: R^T omega_world
    R = quat_to_matrix(q)
    qvel = d.qvel.reshape(n, 6)
    qvel[:, :3] = 0.0
    qvel[:, 3:] = np.einsum("nji,nj->ni", R, omega)
    mujoco.mj_forward(m, d)
    return m, d


def mujoco_energy(m, d, with_potential):
    import mujoco

    mujoco.mj_forward(m, d)
    mujoco.mj_energyVel(m, d)
    e = float(d.energy[1])
    if with_potential:
        mujoco.mj_energyPos(m, d)
        e += float(d.energy[0])
    return e


def time_mujoco(m, d, n_steps, repeats, with_potential, use_rollout):
    import mujoco
    from mujoco import rollout

    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    nstate = mujoco.mj_stateSize(m, spec)
    s0 = np.empty(nstate)
    mujoco.mj_getState(m, d, s0, spec)
    e0 = mujoco_energy(m, d, with_potential)
    times = []
    if use_rollout:
        out = np.empty((1, n_steps, nstate))
        rollout.rollout(m, d, s0[None], nstep=1, state=out[:, :1])  # warm-up (first call sets things up)
        for _ in range(repeats):
            t0 = time.perf_counter()
            rollout.rollout(m, d, s0[None], nstep=n_steps, state=out)
            times.append(time.perf_counter() - t0)
        mujoco.mj_setState(m, d, out[0, -1], spec)
    else:
        step = mujoco.mj_step
        for _ in range(repeats):
            mujoco.mj_setState(m, d, s0, spec)
            t0 = time.perf_counter()
            for _ in range(n_steps):
                step(m, d)
            times.append(time.perf_counter() - t0)
    e1 = mujoco_energy(m, d, with_potential)
    mujoco.mj_setState(m, d, s0, spec)
    mujoco.mj_forward(m, d)
    return statistics.median(times), min(times), (e1 - e0) / abs(e0), float(d.time)


# --------------------------------------------------------------------------- tumble demo cold / warm


def demo_start(python, timeout=900):
    import importlib.util

    if importlib.util.find_spec("tumble.cli") is None:
        return {"error": "tumble.cli does not exist yet: demo start not measured"}
    cache = tempfile.mkdtemp(prefix="tumble-numba-demo-")
    outdir = tempfile.mkdtemp(prefix="tumble-demo-out-")
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=_pythonpath())
    res = {}
    try:
        for label in ("cold", "warm"):
            t0 = time.perf_counter()
            r = subprocess.run([python, "-m", "tumble.cli", "demo", "--out", outdir, "--force"], env=env,
                               capture_output=True, text=True, timeout=timeout, cwd=str(ROOT))
            res[label + "_s"] = time.perf_counter() - t0
            res[label + "_rc"] = r.returncode
            if r.returncode != 0:
                res[label + "_stderr"] = r.stderr.strip()[-1500:]
        res["cache_files"] = sum(len(f) for _, _, f in os.walk(cache))
    finally:
        shutil.rmtree(cache, ignore_errors=True)
        shutil.rmtree(outdir, ignore_errors=True)
    return res


# --------------------------------------------------------------------------- reporting


def machine():
    import numba
    import numpy

    try:
        import mujoco

        mj = mujoco.__version__
    except Exception:  # pragma: no cover
        mj = "not installed"
    cpu = "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import hashlib

    h = hashlib.sha256()
    for f in sorted((ROOT / "src" / "tumble").glob("*.py")):
        h.update(f.read_bytes())
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "src"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    except OSError:
        head, dirty = "?", ""
    source = f"git {head}{' + uncommitted changes in src/' if dirty else ''}, sha256(src/tumble/*.py) {h.hexdigest()[:12]}"
    from tumble import integrators as K

    par = [name for name, v in vars(K).items() if v in _dispatchers() and v.targetoptions.get("parallel")]
    if par:
        threshold = getattr(K, "PARALLEL_MIN_BODIES", None)
        threads = (f"tumble has parallel kernels ({', '.join(par)}: prange over chunks of bodies) and Numba used "
                   f"{numba.get_num_threads()} threads (nproc = {os.cpu_count()})"
                   + (f"; the Simulator picks the parallel one from N >= {threshold} bodies" if threshold else "")
                   + "; the other kernels are single-threaded.")
    else:
        threads = "tumble's Numba kernels are single-threaded (no `parallel=True` / `prange`)."
    return dict(source=source, tumble_threads=threads, date=_dt.datetime.now().astimezone().isoformat(timespec="seconds"), nproc=os.cpu_count(), cpu=cpu,
                platform=platform.platform(), python=platform.python_version(), numpy=numpy.__version__,
                numba=numba.__version__, mujoco=mj, numba_threads=numba.config.NUMBA_NUM_THREADS)


def fmt(x, spec):
    return "" if x is None or (isinstance(x, float) and np.isnan(x)) else format(x, spec)


def md_table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def throughput_table(results):
    header = ["engine", "variant", "integrator", "loop", "N", "steps", "repeats", "us/step (median)", "steps/s",
              "body-steps/s", "energy rel. drift after the run", "tumble / MuJoCo body-steps/s (C loop)",
              "tumble / best MuJoCo loop"]
    rows = []
    for r in results:
        rows.append([r["engine"], r["variant"], r["integrator"], r["loop"], r["N"], r["steps"], r["repeats"],
                     fmt(r["us_per_step"], ".1f"), fmt(r["steps_per_s"], ".0f"), fmt(r["body_steps_per_s"], ".3g"),
                     fmt(r["energy_drift"], "+.2e"),
                     "" if r.get("ratio") is None else f"{r['ratio']:.2f} (vs {r['ratio_vs']})",
                     fmt(r.get("ratio_best"), ".2f")])
    return md_table(header, rows)


def add_ratios(results):
    """tumble body-steps/s over MuJoCo's at the same N and variant: over its C loop (rollout), and over the
    faster of its two loops (the conservative figure: on this machine the Python mj_step loop is sometimes faster)."""
    best, cloop = {}, {}
    for r in results:
        if r["engine"] != "mujoco" or r.get("body_steps_per_s") is None:
            continue
        key = (r["variant"], r["integrator"], r["N"])
        best[key] = max(best.get(key, 0.0), r["body_steps_per_s"])
        if r["loop"] == "C (rollout)":
            cloop[key] = r["body_steps_per_s"]
    for r in results:
        if r["engine"] != "tumble":
            continue
        key = ("free" if r["variant"] == "free" else "gravity", PAIRING[r["integrator"]], r["N"])
        if key in cloop:
            r["ratio"] = r["body_steps_per_s"] / cloop[key]
            r["ratio_vs"] = "mujoco " + PAIRING[r["integrator"]]
        if key in best:
            r["ratio_best"] = r["body_steps_per_s"] / best[key]


# --------------------------------------------------------------------------- main


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="N = 1, 100, 1000 only, fewer repeats")
    ap.add_argument("--sizes", type=int, nargs="+", help="the N to run (default 1 100 1000 10000 100000)")
    ap.add_argument("--repeats", type=int, default=None, help="tumble repeats for N <= 1000 (default 5, quick 3)")
    ap.add_argument("--no-mujoco", action="store_true")
    ap.add_argument("--no-gravity-variant", action="store_true")
    ap.add_argument("--no-demo", action="store_true", help="skip the `tumble demo` cold/warm start")
    ap.add_argument("--no-cold-compile", action="store_true", help="skip the compile probe with an empty Numba cache")
    ap.add_argument("--mujoco-big-steps", type=int, default=20, help="MuJoCo steps at N >= 100 000 (default 20)")
    ap.add_argument("--mujoco-max-seconds", type=float, default=60.0,
                    help="skip a MuJoCo measurement whose estimated time exceeds this (default 60 s)")
    ap.add_argument("--mujoco-max-build-seconds", type=float, default=120.0,
                    help="skip MuJoCo at an N whose model build is estimated to take longer (default 120 s)")
    ap.add_argument("--out", type=Path, default=RESULTS)
    ap.add_argument("--_compile-probe", dest="compile_probe", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)

    if args.compile_probe:
        print(json.dumps(compile_probe()))
        return 0

    sizes = args.sizes or ([1, 100, 1000] if args.quick else [1, 100, 1000, 10_000, 100_000])
    rep_small = args.repeats or (3 if args.quick else 5)
    python = sys.executable
    info = machine()
    print(f"# free_bodies on {info['cpu']} ({info['nproc']} CPUs), {info['date']}", flush=True)

    # 1. compile: warm-cache probe in this process (the first tumble call of the run), then a cold one
    probe = compile_probe()
    print("compile probe (this process):", json.dumps(probe), flush=True)
    cold = None if args.no_cold_compile else cold_compile_probe(python)
    if cold is not None:
        print("compile probe (empty NUMBA_CACHE_DIR):", json.dumps(cold), flush=True)

    results = []
    builds = []
    breakdown = {}
    variants = [("free", (0.0, 0.0, 0.0))] + ([] if args.no_gravity_variant else [("gravity+drag", GRAVITY)])

    for n in sizes:
        n_steps = steps_for(n)
        reps = rep_small if n <= 1000 else 3
        # --- tumble
        import tumble as tb

        t0 = time.perf_counter()
        world = build_tumble_world(n)
        t_build = time.perf_counter() - t0
        builds.append(dict(engine="tumble", N=n, build_s=t_build))
        print(f"tumble N={n}: world built in {t_build:.2f} s", flush=True)
        for variant, g in variants:
            if variant != "free":
                world.gravity = np.array(g, dtype=float)
                world.add_force(tb.Drag(linear=0.1, angular_linear=0.01))
            for integ in TUMBLE_INTEGRATORS:
                med, best, drift = time_tumble(world, integ, n_steps, reps, with_potential=variant != "free")
                if variant != "free":
                    drift = None  # drag dissipates energy: its change is physics, not integration error
                row = dict(engine="tumble", variant=variant, integrator=integ, loop="compiled (sim.step(n))", N=n,
                           steps=n_steps, repeats=reps, wall_s=med, wall_min_s=best, us_per_step=med / n_steps * 1e6,
                           steps_per_s=n_steps / med, body_steps_per_s=n * n_steps / med, energy_drift=drift)
                results.append(row)
                print(f"  tumble {variant:12s} {integ:20s} N={n:6d}: {row['us_per_step']:10.1f} us/step "
                      f"{row['body_steps_per_s']:.3g} body-steps/s drift {fmt(drift, '+.2e')}", flush=True)
        if n in (1000, 10_000) or (n == max(sizes) and n >= 1000):
            world.gravity = np.zeros(3)
            world.forces.clear()
            world._tables = None
            calls = max(20, min(2000, 2_000_000 // n))
            try:
                breakdown[n] = {integ: kernel_breakdown(world, integ, calls) for integ in TUMBLE_INTEGRATORS}
            except Exception as exc:  # the stage kernels' signatures may change
                print(f"  kernel breakdown failed: {exc!r}", flush=True)
        del world

        # --- MuJoCo
        if args.no_mujoco:
            continue
        mj_steps = args.mujoco_big_steps if n >= 100_000 else n_steps
        mj_reps = rep_small if n <= 1000 else (3 if n < 100_000 else 2)
        prev = [b for b in builds if b["engine"] == "mujoco" and b.get("build_s") == b.get("build_s") and b.get("build_s")]
        if prev:
            est = prev[-1]["build_s"] * n / prev[-1]["N"]  # at least linear (it grows faster than that here)
            if est > args.mujoco_max_build_seconds:
                note = (f"skipped: building the MJCF model would take over {est:.0f} s "
                        f"({prev[-1]['build_s']:.1f} s at N = {prev[-1]['N']}, scaled linearly)")
                print(f"  mujoco N={n}: {note}", flush=True)
                builds.append(dict(engine="mujoco", N=n, build_s=float("nan"), note=note))
                results.append(dict(engine="mujoco", variant="free", integrator="euler, rk4", loop="both", N=n,
                                    steps=mj_steps, repeats=0, wall_s=None, wall_min_s=None, us_per_step=None,
                                    steps_per_s=None, body_steps_per_s=None, energy_drift=None, note=note))
                continue
        t0 = time.perf_counter()
        try:
            m, d = build_mujoco(n)
        except Exception as exc:  # memory, model size
            print(f"  mujoco N={n}: build failed: {exc}", flush=True)
            builds.append(dict(engine="mujoco", N=n, build_s=float("nan"), note=str(exc)))
            continue
        t_build = time.perf_counter() - t0
        builds.append(dict(engine="mujoco", N=n, build_s=t_build))
        print(f"mujoco N={n}: model built in {t_build:.2f} s", flush=True)
        for variant, g in [("free", (0.0, 0.0, 0.0)), ("gravity", GRAVITY)][: len(variants)]:
            for integ in ("euler", "rk4"):
                set_mujoco_options(m, integ, g)
                # a short probe to estimate the cost, to respect --mujoco-max-seconds
                t0 = time.perf_counter()
                mujoco_probe = min(5, mj_steps)
                import mujoco

                d2 = mujoco.MjData(m)
                d2.qpos[:] = d.qpos
                d2.qvel[:] = d.qvel
                for _ in range(mujoco_probe):
                    mujoco.mj_step(m, d2)
                per_step = (time.perf_counter() - t0) / mujoco_probe
                del d2
                for loop, use_rollout in (("Python (mj_step)", False), ("C (rollout)", True)):
                    est = per_step * mj_steps * (mj_reps + 1)
                    if est > args.mujoco_max_seconds:
                        reps_here = max(1, int(args.mujoco_max_seconds / (per_step * mj_steps)) - 1)
                    else:
                        reps_here = mj_reps
                    if per_step * mj_steps > args.mujoco_max_seconds:
                        print(f"  mujoco {variant} {integ} N={n} {loop}: skipped (estimated {per_step * mj_steps:.0f} s)", flush=True)
                        results.append(dict(engine="mujoco", variant=variant, integrator=integ, loop=loop, N=n,
                                            steps=mj_steps, repeats=0, wall_s=None, wall_min_s=None, us_per_step=None,
                                            steps_per_s=None, body_steps_per_s=None, energy_drift=None,
                                            note=f"skipped: estimated {per_step * mj_steps:.0f} s"))
                        continue
                    med, best, drift, t_end = time_mujoco(m, d, mj_steps, reps_here, variant != "free", use_rollout)
                    row = dict(engine="mujoco", variant=variant, integrator=integ, loop=loop, N=n, steps=mj_steps,
                               repeats=reps_here, wall_s=med, wall_min_s=best, us_per_step=med / mj_steps * 1e6,
                               steps_per_s=mj_steps / med, body_steps_per_s=n * mj_steps / med, energy_drift=drift)
                    results.append(row)
                    print(f"  mujoco {variant:12s} {integ:6s} {loop:17s} N={n:6d}: {row['us_per_step']:10.1f} us/step "
                          f"{row['body_steps_per_s']:.3g} body-steps/s drift {drift:+.2e}", flush=True)
        del m, d

    add_ratios(results)

    # 3. Python overhead at N = 1
    overhead = python_overhead() if 1 in sizes else None
    # 4. demo cold / warm
    demo = None if args.no_demo else demo_start(python)
    if demo is not None:
        print("demo:", json.dumps(demo), flush=True)

    end_source = machine()["source"]
    if end_source != info["source"]:
        info["source"] += f" -- WARNING: src/tumble changed during the run (at the end: {end_source})"
    report = render(info, sizes, probe, cold, results, builds, breakdown, overhead, demo, args)
    print()
    print(report)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "free_bodies.md").write_text(report + "\n")
    keys = ["engine", "variant", "integrator", "loop", "N", "steps", "repeats", "wall_s", "wall_min_s", "us_per_step",
            "steps_per_s", "body_steps_per_s", "energy_drift", "ratio", "ratio_vs", "ratio_best", "note"]
    with open(args.out / "free_bodies.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
        wr.writeheader()
        for r in results:
            wr.writerow(r)
    print(f"\nwrote {args.out / 'free_bodies.md'} and {args.out / 'free_bodies.csv'}")
    return 0


def render(info, sizes, probe, cold, results, builds, breakdown, overhead, demo, args):
    out = []
    out.append("# free_bodies: tumble vs MuJoCo (same run)\n")
    out.append(f"Machine: {info['cpu']}, nproc = {info['nproc']}, {info['platform']}; Python {info['python']}, "
               f"NumPy {info['numpy']}, Numba {info['numba']} (NUMBA_NUM_THREADS = {info['numba_threads']}), "
               f"MuJoCo {info['mujoco']}; {info['date']}.\n")
    out.append("Command: `PYTHONPATH=src python benchmarks/free_bodies.py " + " ".join(sys.argv[1:]) + "`\n")
    out.append(f"tumble source measured: {info['source']}.\n")
    out.append(f"Threads: {info['tumble_threads']} MuJoCo's `mj_step` is single-threaded and `rollout` with one "
               "MjData runs in the calling thread.\n")
    out.append("Scene: N boxes, half-extents (0.1, 0.2, 0.3), mass 1, seeded random orientation, |omega| = 5 rad/s, "
               "collisions off, dt = 1/240 s; 1000 steps (200 at N >= 10 000; MuJoCo "
               f"{args.mujoco_big_steps} at N >= 100 000). Variant `gravity+drag` (tumble): gravity (0, 0, -9.81) and "
               "Drag(linear=0.1, angular_linear=0.01); variant `gravity` (MuJoCo): gravity only. Energy drift: "
               "kinetic energy for `free`; KE + PE for MuJoCo `gravity` (conserved); none for `gravity+drag` "
               "(drag dissipates energy, so its change is physics, not integration error).\n")
    out.append("The ratio column divides tumble's body-steps/s by MuJoCo's C-loop (rollout) figure at the same N "
               "and variant, pairing semi-implicit-euler and splitting with MuJoCo Euler, rk4 with MuJoCo RK4; the last column "
               "divides by the faster of MuJoCo's two loops (Python mj_step or rollout). "
               f"Goal: >= {GOAL_RATIO:g} at N >= 1000.\n")
    out.append("## Throughput\n")
    for variant_set, title in ((("free",), "free (no gravity)"), (("gravity+drag", "gravity"), "with gravity (tumble: and drag)")):
        rows = [r for r in results if r["variant"] in variant_set]
        if rows:
            out.append(f"### {title}\n")
            out.append(throughput_table(sorted(rows, key=lambda r: (r["N"], r["engine"] != "tumble", r["integrator"], r["loop"]))) + "\n")
    notes = [r for r in results if r.get("note")]
    for r in notes:
        out.append(f"- mujoco {r['variant']} {r['integrator']} N={r['N']} {r['loop']}: {r['note']}")
    if notes:
        out.append("")
    out.append("## Building the scene\n")
    out.append(md_table(["engine", "N", "build s", "note"],
                        [[b["engine"], b["N"], fmt(b["build_s"], ".3f"), b.get("note", "")] for b in builds]) + "\n")
    out.append("tumble: `World.add_body` in a Python loop; MuJoCo: MJCF string -> `MjModel.from_xml_string` + `MjData`.\n")
    out.append("## Compilation (Numba)\n")
    rows = []
    for label, p in (("this run (on-disk cache as found)", probe), ("empty NUMBA_CACHE_DIR (cold)", cold)):
        if not p:
            continue
        if "error" in p:
            rows.append([label, "error: " + p["error"][:200], "", "", "", ""])
            continue
        for r in p["rows"]:
            rows.append([label, r["integrator"], fmt(r["first_s"], ".3f"), fmt(r["warm_s"] * 1e6, ".0f"),
                         fmt(r["compile_s"], ".3f"), f"{r['cache_hits']} / {r['cache_misses']}"])
    out.append(md_table(["cache", "integrator (in call order)", "first sim.step(1) s", "warm sim.step(1) us",
                         "compile / load s (first - warm)", "integrator kernels: cache hits / misses"], rows) + "\n")
    out.append("The stepping kernels take the integrator as a runtime integer, so one compilation serves every "
               "fixed-step integrator: only the first call of a process compiles (or loads from the cache). Hits / "
               "misses count dispatcher signatures of `tumble.integrators` loaded from / compiled into the on-disk cache.")
    if probe:
        out.append(f" `import tumble` took {probe['import_s']:.2f} s in this run"
                   + (f" and {cold['import_s']:.2f} s cold; the cold probe process took {cold['process_wall_s']:.1f} s in all."
                      if cold and "error" not in cold else ".") + "\n")
    if overhead:
        out.append("## Python overhead at N = 1\n")
        rows = []
        for integ, o in overhead.items():
            rows.append([integ, fmt(o["kernel_us"], ".2f"), fmt(o["step1_us"], ".1f"), fmt(o["step1_overhead_us"], ".1f"),
                         fmt(o["run_s"], ".3f"), fmt(o["run_us_per_step"], ".2f"), fmt(o["run_overhead_us_per_step"], ".2f"),
                         fmt(o["run_us_per_frame"], ".0f")])
        out.append(md_table(["integrator", "compiled loop us/step", "sim.step(1) in a Python loop, us/call",
                             "overhead us/call", "sim.run(10 s) wall s (2400 steps, 241 frames)", "run us/step",
                             "run overhead us/step", "run us/frame"], rows) + "\n")
        worst = max(o["step1_overhead_us"] for o in overhead.values())
        run_worst = max(o["run_overhead_us_per_step"] for o in overhead.values())
        out.append(f"Goal: under {GOAL_OVERHEAD_US:g} us of Python overhead per step at N = 1. `sim.run`: "
                   f"{run_worst:.1f} us/step -> {'met' if run_worst < GOAL_OVERHEAD_US else 'NOT met'}; "
                   f"`sim.step(1)` called from Python: {worst:.1f} us/call -> "
                   f"{'met' if worst < GOAL_OVERHEAD_US else 'NOT met'}.\n")
    if breakdown:
        out.append("## Where the time goes (stage kernels called one by one)\n")
        out.append("These are the all-bodies stage kernels (the path `step_kernel` takes with springs, and the "
                   "stage-by-stage path with custom forces), each called from Python over all N bodies; without "
                   "springs the per-body stepping kernels instead advance each body through all its steps "
                   "(`_advance_body`), so the shares say which per-body operation is expensive, not the exact "
                   "split of the fused loop.\n")
        for n, per in breakdown.items():
            rows = []
            for integ, ks in per.items():
                tot = sum(k["us_per_step"] for k in ks)
                for k in ks:
                    rows.append([integ, k["kernel"], k["calls_per_step"], fmt(k["us_per_call"], ".1f"),
                                 fmt(k["ns_per_body_call"], ".1f"), fmt(100 * k["us_per_step"] / tot, ".0f") + " %"])
            out.append(f"N = {n}:\n")
            out.append(md_table(["integrator", "kernel", "calls/step", "us/call", "ns per body per call", "share of step"], rows) + "\n")
    if demo is not None:
        out.append("## `tumble demo` start-up\n")
        if "error" in demo:
            out.append(demo["error"] + "\n")
        else:
            out.append(md_table(["run", "wall s", "exit code"],
                                [["cold (empty NUMBA_CACHE_DIR)", fmt(demo["cold_s"], ".2f"), demo["cold_rc"]],
                                 ["warm (same cache dir)", fmt(demo["warm_s"], ".2f"), demo["warm_rc"]]]) + "\n")
            for k in ("cold_stderr", "warm_stderr"):
                if k in demo:
                    out.append(f"{k}: `{demo[k][-300:]}`\n")
    return "\n".join(out)


if __name__ == "__main__":
    sys.exit(main())
