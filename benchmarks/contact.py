"""Contact benchmarks: tumble, PyBullet and MuJoCo on the scenes of /work/shared/BENCHMARKS.md, in one run.

The scenes come from ``tumble.scenes.contact`` (pile, stack, tower, pyramid, large_pyramid,
many_pyramids); the peers rebuild the same bodies from the tumble World (benchmarks/peers/).
Run from the repository root:

    PYTHONPATH=src python benchmarks/contact.py --scene pile --n 1000 --runs 3
    PYTHONPATH=src python benchmarks/contact.py --scene pile --n 100 --runs 3
    PYTHONPATH=src python benchmarks/contact.py --scene stack --runs 3
    PYTHONPATH=src python benchmarks/contact.py --scene large_pyramid --runs 3          # tumble (Box3D's figure beside it)
    PYTHONPATH=src python benchmarks/contact.py --scene pile --n 1000 --engines pybullet --variants pybullet:rigidbody
    PYTHONPATH=src python benchmarks/contact.py --scene pile --n 100 --duration 0.5     # a quick check

Prints a Markdown table and writes benchmarks/results/contact_<scene>[_<n>][_<tag>].csv (one row
per engine and variant) and .md (the table, with the machine and the load average).

What is timed
-------------
Each engine and variant: the scene is built (tumble World + Simulator; MuJoCo: MJCF compile;
PyBullet: the bodies created in a DIRECT client), timed apart as "load". tumble's first
``sim.step(1)`` (Numba compile or cache load) is timed apart too, on a throw-away copy. Then
each run starts from the initial state (a fresh World and Simulator; a fresh MjData; the
PyBullet scene rebuilt) and steps the scene's whole duration; only the stepping is timed.
Quality figures are sampled every 1/60 s of simulated time, outside the timer
(benchmarks/peers/common.py says how each is defined). "wall s" is the median over runs; a
variant whose first run takes longer than --long-run seconds runs once. A run longer than
--timeout seconds stops and is reported INCOMPLETE with the figures at that time.

Steps: PyBullet and MuJoCo step dt = 1/240 s (BENCHMARKS.md); tumble steps the scene's
recommended dt = 1/60 s. tumble variants are "SxC": ``Simulator(world, dt=1/60,
integrator="semi-implicit-euler", substeps=S)`` with ``SoftStepSettings(substeps=C)``, so a
step is S x C solver substeps: 1x4 is Box3D's step (h = 1/240 s); 4x4 is
``Simulator(substeps=4)`` with the default solver substeps (h = 1/960 s). "default" takes
--tumble-substeps / --tumble-contact-substeps. "ms/step" is per step of
the engine's own dt (the dt column); the real-time factor compares them directly.
"""

from __future__ import annotations

import argparse
import csv
import datetime as _dt
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"
sys.path.insert(0, str(HERE))

from peers.common import fmt, median, run, scene_spec

SCENES = ("pile", "stack", "tower", "pyramid", "large_pyramid", "many_pyramids")
ENGINES = ("tumble", "pybullet", "mujoco")
#: Box3D on this machine kind (BENCHMARKS.md), ms per 1/60 s step with 4 substeps: (1 thread, 2 threads), min
BOX3D_MS = {"large_pyramid": (26.3, 15.5), "many_pyramids": (52.7, 27.8)}


# --------------------------------------------------------------------------- tumble


class TumbleScene:
    """tumble on a scene: a fresh World and ``Simulator(world, dt, integrator, substeps)``.

    The scene's ``substeps`` (4, Box3D's) are solver substeps per step of dt: one collision pass a
    step, then substeps of h = dt / 4. In tumble the soft step makes ``Simulator.substeps x
    SoftStepSettings.substeps`` substeps a step, so Box3D's step is ``Simulator(dt=1/60,
    substeps=1)`` with ``SoftStepSettings(substeps=4)`` (the default); ``Simulator(substeps=4)``
    with the default settings would take 16 substeps of 1/960 s.
    """

    def __init__(self, scene: str, kwargs: dict, integrator: str, dt: float | None, substeps: int | None,
                 contact_substeps: int | None = None, sleeping: bool | None = None):
        self.scene, self.kwargs, self.integrator = scene, kwargs, integrator
        self._sleeping = sleeping
        self._dt, self._substeps, self._contact_substeps = dt, substeps, contact_substeps
        t0 = time.perf_counter()
        self.reset()
        self.load_s = time.perf_counter() - t0

    def reset(self):
        import tumble as tb
        from tumble.scenes import contact as C

        self.world, settings = C.build(self.scene, **self.kwargs)
        if self._sleeping is not None:
            self.world.sleeping = self._sleeping
        self.dt = self._dt or settings["dt"]
        self.sim_substeps = self._substeps or 1
        self.contact_substeps = self._contact_substeps or max(1, settings["substeps"] // self.sim_substeps)
        self.substeps = self.sim_substeps * self.contact_substeps
        self.moving = np.flatnonzero(self.world.moving)
        try:
            from tumble.solver.contact import SoftStepSettings

            extra = {"contact_settings": SoftStepSettings(substeps=self.contact_substeps)}
        except (ImportError, TypeError):  # an API without solver substeps: Simulator substeps only
            extra = {}
            self.sim_substeps = self.substeps = self._substeps or settings["substeps"]
            self.contact_substeps = 1
        self.sim = tb.Simulator(self.world, dt=self.dt, integrator=self.integrator, substeps=self.sim_substeps, **extra)

    def step(self, k: int):
        self.sim.step(k)

    def state(self):
        w, m = self.world, self.moving
        return w.x[m].copy(), w.R[m].copy(), w.v[m].copy(), w.omega[m].copy()

    def extra_figures(self):
        """Sleeping (``world.sleeping``) and the boxes asleep at the end."""
        sleep = getattr(self.sim, "sleep", None)
        awake = getattr(sleep, "awake", None)
        asleep = None if awake is None else int((~np.asarray(awake, dtype=bool)[self.moving]).sum())
        return {"sleeping": getattr(self.world, "sleeping", None), "asleep_end": asleep}


def tumble_make(scene, kwargs, args, variant: str = "1x4"):
    """The engine at the scene's start, and the compile (or Numba cache load) time: 10 steps of a
    3-box stack (box-plane and box-box contacts from the first step: the contact kernels compile
    on first use) and one step of a throw-away copy of the scene."""
    sim_sub, contact_sub = args.tumble_substeps, args.tumble_contact_substeps
    if variant != "default":
        try:
            sim_sub, contact_sub = (int(v) for v in variant.split("x"))
        except ValueError:
            raise SystemExit(f"tumble variants are SIMxCONTACT substeps (1x4, 4x4) or default, got {variant!r}") from None
    t0 = time.perf_counter()
    sleeping = None if args.tumble_sleep is None else args.tumble_sleep == "on"
    warm = TumbleScene("stack", {"n": 3}, args.tumble_integrator, args.tumble_dt, sim_sub, contact_sub, sleeping)
    warm.step(10)
    eng = TumbleScene(scene, kwargs, args.tumble_integrator, args.tumble_dt, sim_sub, contact_sub, sleeping)
    t1 = time.perf_counter()
    eng.step(1)
    compile_s = (t1 - t0 - eng.load_s) + (time.perf_counter() - t1)
    eng.reset()
    return eng, eng.load_s, compile_s


# --------------------------------------------------------------------------- peers


def peer_module(engine: str):
    if engine == "mujoco":
        from peers import mujoco_scenes as mod
    else:
        from peers import pybullet_scenes as mod
    return mod


def default_variants(engine: str, scene: str, n: int) -> list[str]:
    if engine == "tumble":
        # 1x4: Box3D's step (Simulator substeps=1, 4 solver substeps: h = 1/240 s at dt = 1/60 s);
        # 4x4: Simulator(substeps=4) with the default 4 solver substeps (h = 1/960 s)
        return ["1x4", "4x4"]
    if scene in ("large_pyramid", "many_pyramids"):
        return []  # Box3D's scenes: tumble against Box3D's published figure; peers only on request
    if engine == "pybullet":
        return ["rigidbody", "multibody"]
    # MuJoCo's Newton solver stalls on the 1000-box pile (BENCHMARKS.md): CG only from 500 boxes
    if scene == "pile":
        return ["euler", "euler-cg"] if n < 500 else ["euler-cg"]
    return ["euler"]


# --------------------------------------------------------------------------- reporting


def machine() -> dict:
    cpu = "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    versions = {}
    for mod in ("numpy", "numba", "mujoco", "pybullet"):
        try:
            m = __import__(mod)
            versions[mod] = getattr(m, "__version__", "installed")
        except Exception:  # noqa: BLE001 (a version we cannot read is reported, not fatal)
            versions[mod] = "not installed"
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True, check=False).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "src"], cwd=ROOT, capture_output=True, text=True, check=False).stdout.strip()
    except OSError:
        head, dirty = "?", ""
    try:
        import numba

        threads = numba.get_num_threads()
    except Exception:  # noqa: BLE001
        threads = None
    import tumble

    src = Path(tumble.__file__).resolve().parent
    if src != (ROOT / "src" / "tumble").resolve():
        stamp = src.parent.parent / "HEAD_COMMIT"  # written beside a `git archive` copy of the source
        archived = stamp.read_text().strip() if stamp.exists() else "?"
        head = f"{archived} (tumble imported from {src}, a copy of that commit; the repository is at {head})"
        dirty = ""
    return dict(date=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"), cpu=cpu, nproc=os.cpu_count(),
                platform=platform.platform(), python=platform.python_version(),
                tumble_git=head + (" + uncommitted changes in src/" if dirty else ""), numba_threads=threads, **versions)


def write_results(out: Path, stem: str, markdown: str, rows: list, info: dict) -> None:
    """``out/stem.md`` (the report as printed) and ``out/stem.csv``: one line per row, the row's
    keys in first-seen order then the run's ``info`` (machine, versions, date) on every line."""
    (out / f"{stem}.md").write_text(markdown)
    keys = []
    for r in rows:
        for k in r:
            if k not in keys:
                keys.append(k)
    keys += [k for k in info if k not in keys]
    with open(out / f"{stem}.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({**info, **r})
    print(f"wrote {out / (stem + '.csv')} and .md", flush=True)


def md_table(header, rows) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def dt_label(dt: float, substeps: int) -> str:
    inv = 1.0 / dt
    s = f"1/{inv:.0f}" if abs(inv - round(inv)) < 1e-9 else f"{dt:g}"
    return s + (f" x{substeps}" if substeps > 1 else "")


def wall_cell(r) -> str:
    if r["complete"]:
        return fmt(r["wall_s"], ".3g" if r["wall_s"] < 1 else ".2f")
    return f"INCOMPLETE: {r['sim_time']:.2f} s sim in {r['wall_s']:.0f} s wall (figures at that time)"


def asleep_cell(r) -> str:
    if r.get("sleeping") is None and r.get("asleep_end") is None:
        return "-"
    if r.get("sleeping") is False:
        return "sleep off"
    return "-" if r.get("asleep_end") is None else str(r["asleep_end"])


def table(rows, scene: str) -> str:
    if scene == "pile" or scene in BOX3D_MS:
        header = ["engine", "variant", "N", "dt", "runs", "load s", "first step s", "wall s (median)", "real-time factor",
                  "ms/step", "min z - h (end)", "max vertex pen. (end)", "max vertex pen. (run)", "max speed end (m/s)",
                  "max ang. speed end (rad/s)", "left region", "farthest box (m)", "mean solver iters", "asleep (end)"]
        if scene in BOX3D_MS:
            header += ["top box dz (end)", "Box3D ms/step 1 / 2 threads"]
        out = []
        for r in rows:
            line = [r["engine"], r["variant"], r["n"], r["dt_label"], r["runs"], fmt(r["load_s"], ".2f"),
                    fmt(r.get("compile_s"), ".2f"), wall_cell(r), fmt(r["rtf"], ".3f"),
                    fmt(r["ms_per_step"], ".2f") if r["complete"] else f"{r['last_ms_per_step']:.0f} (last)",
                    fmt(r["min_z_minus_h_end"]), fmt(r["max_pen_end"]), fmt(r["max_pen_run"]), fmt(r["max_speed_end"]),
                    fmt(r["max_ang_speed_end"]), r["left_region"], fmt(r["max_xy_dist_end"], ".2f"),
                    "-" if r["solver_iters"] is None else f"{r['solver_iters']:.0f}", asleep_cell(r)]
            if scene in BOX3D_MS:
                one, two = BOX3D_MS[scene]
                line += [fmt(r["top_dz_end"]), f"{one} / {two}"]
            out.append(line)
        return md_table(header, out)
    header = ["engine", "variant", "N", "dt", "runs", "load s", "first step s", "wall s (median)", "real-time factor",
              "ms/step", "top xy drift (end)", "top dz (end)", "top xy drift (max)", "top abs dz (max)", "stands",
              "bottom cube pen.", "max tilt deg (end)", "max tilt deg (run)", "max vertex pen. (run)", "asleep (end)"]
    out = []
    for r in rows:
        out.append([r["engine"], r["variant"], r["n"], r["dt_label"], r["runs"], fmt(r["load_s"], ".2f"),
                    fmt(r.get("compile_s"), ".2f"), wall_cell(r), fmt(r["rtf"], ".3g"), fmt(r["ms_per_step"], ".3f"),
                    fmt(r["top_xy_drift_end"]), fmt(r["top_dz_end"]), fmt(r["top_xy_drift_max"]), fmt(r["top_abs_dz_max"]),
                    r["stands"], fmt(r["bottom_pen_end"]), fmt(r["max_tilt_end_deg"], ".3f"), fmt(r["max_tilt_deg"], ".3f"),
                    fmt(r["max_pen_run"]), asleep_cell(r)])
    return md_table(header, out)


# --------------------------------------------------------------------------- main


def parse_variants(items):
    out = {}
    for item in items or ():
        engine, _, variant = item.partition(":")
        if engine not in ENGINES or not variant:
            raise SystemExit(f"--variants takes engine:variant (engine one of {', '.join(ENGINES)}), got {item!r}")
        out.setdefault(engine, []).append(variant)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", choices=SCENES, default="pile")
    ap.add_argument("--n", type=int, default=None, help="pile: boxes (default 1000); stack/tower: cubes (10); pyramid: rows (20)")
    ap.add_argument("--seed", type=int, default=0, help="pile orientation seed")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--engines", nargs="+", choices=ENGINES, default=list(ENGINES))
    ap.add_argument("--variants", nargs="+", metavar="ENGINE:VARIANT",
                    help="e.g. mujoco:euler mujoco:euler-cg pybullet:rigidbody pybullet:multibody (default per scene)")
    ap.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the scene's)")
    ap.add_argument("--timeout", type=float, default=600.0, help="stop a run after this many s of stepping (INCOMPLETE)")
    ap.add_argument("--long-run", type=float, default=30.0, help="a variant whose first run is longer runs once")
    ap.add_argument("--tumble-integrator", default="semi-implicit-euler")
    ap.add_argument("--tumble-dt", type=float, default=None, help="default: the scene's (1/60 s)")
    ap.add_argument("--tumble-substeps", type=int, default=None, help="Simulator substeps (default 1)")
    ap.add_argument("--tumble-contact-substeps", type=int, default=None,
                    help="SoftStepSettings.substeps (default: the scene's 4 / Simulator substeps)")
    ap.add_argument("--tumble-sleep", choices=("on", "off"), default=None,
                    help="world.sleeping (default: the scene's; on except large_pyramid, many_pyramids)")
    ap.add_argument("--tumble-threads", type=int, default=None, help="Numba threads for tumble (default: all)")
    ap.add_argument("--tag", default=None, help="suffix of the result files")
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)

    from tumble.scenes import contact as C

    if args.tumble_threads:
        import numba

        numba.set_num_threads(args.tumble_threads)
    scene = args.scene
    if scene == "pile":
        kwargs = {"n": args.n or 1000, "seed": args.seed}
    elif scene in ("stack", "tower"):
        kwargs = {"n": args.n or 10}
    elif scene == "pyramid":
        kwargs = {"rows": args.n or 20}
    else:
        if args.n is not None:
            raise SystemExit(f"{scene} has a fixed size (--n does not apply)")
        kwargs = {}
    world, settings = C.build(scene, **kwargs)
    spec = scene_spec(world, settings)
    n = spec.n
    duration = args.duration or settings["duration"]
    chosen = parse_variants(args.variants)
    info = machine()
    print(f"# contact benchmark: {scene} (N = {n}, {duration:g} s simulated), {info['date']}, {info['cpu']} "
          f"({info['nproc']} CPUs), load average {os.getloadavg()[0]:.2f}, tumble git {info['tumble_git']}", flush=True)

    rows = []
    for engine in args.engines:
        variants = chosen.get(engine) if args.variants else default_variants(engine, scene, n)
        for variant in variants or ():
            label = f"{engine}:{variant}"
            try:
                if engine == "tumble":
                    eng, load_s, compile_s = tumble_make(scene, kwargs, args, variant)
                    dt, substeps = eng.dt, eng.substeps
                    variant = f"{args.tumble_integrator}, soft step {eng.sim_substeps}x{eng.contact_substeps}" + (
                        f", {args.tumble_threads} thread{'s' if args.tumble_threads > 1 else ''}" if args.tumble_threads else "")
                    reset = TumbleScene.reset
                else:
                    mod = peer_module(engine)
                    eng, load_s, dt, substeps = mod.make(spec, variant)
                    compile_s = None
                    reset = None
                    new_run = mod.new_run
            except Exception as exc:  # noqa: BLE001 (an engine that cannot run this scene: one line, go on)
                print(f"  {label}: could not build: {exc!r}", flush=True)
                rows.append({"engine": engine, "variant": variant, "n": n, "error": repr(exc)})
                continue
            steps = round(duration / dt)
            results = []
            for k in range(args.runs):
                if k > 0:
                    if engine == "tumble":
                        reset(eng)
                    else:
                        eng = new_run(eng)
                r = run(eng, spec, dt, steps, timeout=args.timeout)
                results.append(r)
                print(f"  {label} run {k + 1}: {r['wall_s']:.2f} s wall for {r['sim_time']:.2f} s simulated"
                      f"{'' if r['complete'] else ' (INCOMPLETE)'}, load average {r['loadavg_start']:.2f} -> "
                      f"{r['loadavg_end']:.2f}", flush=True)
                if not r["complete"] or r["wall_s"] > args.long_run:
                    break
            if hasattr(eng, "close"):
                eng.close()
            last = results[-1]
            walls = [r["wall_s"] for r in results if r["complete"]]
            wall = median(walls) if walls else last["wall_s"]
            row = {"scene": scene, "engine": engine, "variant": variant, "n": n, "dt": dt, "substeps": substeps,
                       "dt_label": dt_label(dt, substeps), "runs": len(results), "load_s": load_s, "compile_s": compile_s,
                       "wall_s": wall, "wall_min_s": min(walls) if walls else None,
                       "walls": " ".join(f"{w:.3f}" for w in walls), "rtf": last["sim_time"] / last["wall_s"] if last["wall_s"] else None,
                       "ms_per_step": 1e3 * wall / steps if last["complete"] else None, "duration": duration,
                       "loadavg_start": min(r["loadavg_start"] for r in results),
                       "loadavg_end": max(r["loadavg_end"] for r in results)}
            row.update({k: v for k, v in last.items() if k not in ("wall_s",)})
            if last["complete"]:
                row["rtf"] = duration / wall
            if last["max_pen_run"] > 0.5 * float(spec.half[:, 2].min()):
                row["note"] = "deepest corner over half a box below the ground: contact not active?"
                print(f"  {label}: NOTE {row['note']}", flush=True)
            rows.append(row)

    ok = [r for r in rows if "error" not in r]
    text = table(ok, scene)
    header = (f"## contact: {scene}, N = {n}, {duration:g} s simulated ({info['date']})\n\n"
              f"Machine: {info['cpu']}, {info['nproc']} CPUs, {info['platform']}, Python {info['python']}; "
              f"numpy {info['numpy']}, numba {info['numba']} ({info['numba_threads']} threads), mujoco {info['mujoco']}, "
              f"pybullet {info['pybullet']}; tumble git {info['tumble_git']}. Load average (1 min) over the runs: "
              + ", ".join(f"{r['engine']}:{r['variant']} {r['loadavg_start']:.2f}-{r['loadavg_end']:.2f}" for r in ok) + ".\n")
    errors = "".join(f"\n- {r['engine']}:{r['variant']} could not run: {r['error']}" for r in rows if "error" in r)
    notes = "".join(f"\n- {r['engine']}:{r['variant']}: {r['note']}" for r in ok if r.get("note"))
    print()
    print(header)
    print(text + "\n" + errors + notes)

    args.out.mkdir(parents=True, exist_ok=True)
    tag = args.tag or (f"{duration:g}s" if args.duration else None)
    stem = f"contact_{scene}" + (f"_{n}" if scene in ("pile", "pyramid") or n != 10 else "") + (f"_{tag}" if tag else "")
    write_results(args.out, stem, header + "\n" + text + "\n" + errors + notes + "\n", rows, info)
    return 0


if __name__ == "__main__":
    sys.exit(main())
