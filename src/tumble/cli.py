"""The ``tumble`` command: ``demo``, ``run SCENE``, ``validate SCENE``.

Outputs of a run go to one folder: ``trajectory.npz`` (DESIGN.md's trajectory
file), ``summary.json`` (the scene, the settings, the versions, the run's
figures) and a copy of the scene file. Nothing already there is overwritten
without ``--force``; with it, the replaced run's media that this run does not write are removed.

Frames are streamed to disk while the scene runs (peak memory does not grow
with the duration); ``--checkpoint-every S`` flushes the trajectory and writes
``checkpoint.npz`` every S simulated seconds, and ``tumble run --resume DIR``
continues a run from its checkpoint, bit-identically (docs/reliability.md).

Exit status: 0 success; 2 bad input (one line ``tumble: error: FILE: KEY:
problem`` on stderr, never a traceback; also command-line usage errors);
3 the simulation went bad (``SimulationError``: non-finite state, orientation
off unit length, energy past ``max_energy_growth``; the frames so far are kept);
130 interrupted by SIGINT (Ctrl-C), 143 by SIGTERM (frames so far, a checkpoint
and summary.json with "status": "interrupted" are written first).
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
from importlib import resources
from pathlib import Path

from . import __version__
from .errors import InputError, SimulationError
from .runfile import check_run, read_run_record
from .scene import Scene, load_scene
from .scene_values import shown
from .trajectory import write_atomic

EXIT_OK, EXIT_INPUT, EXIT_SIMULATION, EXIT_INTERRUPTED, EXIT_TERMINATED = 0, 2, 3, 130, 143
# Subcommands that live with their feature (export, render, plot, view): each
# module has ``add_commands(subparsers) -> {name: handler}``, a handler takes the
# parsed args and returns the exit status, and raises InputError on bad input.
COMMAND_MODULES = ("tumble.export.commands", "tumble.render.commands", "tumble.viewer.commands", "tumble.sweep.commands",
                   "tumble.decomposition_commands")
OUTPUT_NAMES = ("trajectory.npz", "summary.json", "checkpoint.npz")
# What --video, --gltf, --usd, --html and --plots write beside them (tumble demo writes all but USD and HTML).
MEDIA_NAMES = {"video": "video.mp4", "gltf": "trajectory.glb", "usd": "trajectory.usdc", "html": "trajectory.html",
               "plots": "plots", "images": "images"}
# The modules each kind of media needs, and the extra that installs them.
MEDIA_NEEDS = {"video": (("pyvista", "imageio", "imageio_ffmpeg"), "render"), "plots": (("matplotlib",), "render"),
               "usd": (("pxr",), "export"), "gltf": ((), "export"), "html": ((), "export"), "images": (("imageio",), "render")}
VIDEO_SIZE = (960, 540)  # pixels: sharp enough to watch, quick to render (about 0.1 s a frame)


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (exit status 2), like every other bad input."""

    def error(self, message):
        raise _UsageError(f"{self.prog}: error: {' '.join(message.split())} (see {self.prog} --help)")


class _UsageError(Exception):
    pass


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="tumble", description="Rigid-body dynamics after Baraff's course notes: run and check scene files.")
    parser.add_argument("--version", action="version", version=f"tumble {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    def outputs(p, default_help):
        p.add_argument("--out", metavar="DIR", help=f"output folder (default {default_help})")
        p.add_argument("--force", action="store_true",
                       help="overwrite the outputs if they exist (and remove the replaced run's media this run does not write)")
        p.add_argument("--duration", type=_seconds, metavar="S", help="simulated time, s (default: the scene's)")
        p.add_argument("--integrator", metavar="NAME", help="integrator (default: the scene's), e.g. rk4, splitting, dop853")
        p.add_argument("--no-progress", action="store_true", help="never show a progress bar")
        p.add_argument("--checkpoint-every", type=_seconds, metavar="S",
                       help="flush the trajectory and write checkpoint.npz every S simulated seconds")
        p.add_argument("--max-memory", metavar="SIZE", help="memory limit of the run, e.g. 64G (default: TUMBLE_MAX_MEMORY or half the RAM)")

    demo = sub.add_parser("demo", help="run the built-in demo scene and write its outputs, a video, a .glb and plots")
    outputs(demo, "./tumble-demo")
    demo.add_argument("--no-media", action="store_true", help="write only the run's files: no video, .glb or plots")
    run = sub.add_parser("run", help="run a scene file (TOML or JSON, a MuJoCo model .xml, or a USD stage with "
                                     "physics) and write its outputs")
    run.add_argument("scene", metavar="SCENE", nargs="?",
                     help="scene file, .toml or .json; or an MJCF model, .xml; or a USD stage, .usda, .usdc, .usd or .usdz")
    outputs(run, "./out/<scene name>")
    run.add_argument("--video", action="store_true", help=f"also render {MEDIA_NAMES['video']} (headless)")
    run.add_argument("--gltf", action="store_true", help=f"also export {MEDIA_NAMES['gltf']} (Blender, three.js)")
    run.add_argument("--usd", action="store_true", help=f"also export {MEDIA_NAMES['usd']}")
    run.add_argument("--html", action="store_true",
                     help=f"also write {MEDIA_NAMES['html']}: one web page that plays the run (no server, no network)")
    run.add_argument("--plots", action="store_true", help=f"also plot energy, momentum and orthonormality into {MEDIA_NAMES['plots']}/")
    run.add_argument("--images", action="store_true",
                     help=f"also capture the scene's [[cameras]] at every frame into {MEDIA_NAMES['images']}/ "
                          "(colour PNGs, depth and segmentation)")
    run.add_argument("--resume", metavar="DIR", help="continue the run in DIR from its checkpoint.npz (no SCENE)")
    parser._run_parser = run
    val = sub.add_parser("validate", help="check a scene file and build its world without running it")
    val.add_argument("scene", metavar="SCENE",
                     help="scene file, .toml or .json; or an MJCF model, .xml; or a USD stage, .usda, .usdc, .usd or .usdz")
    parser._handlers_table = {}
    for module in _command_modules():
        parser._handlers_table.update(module.add_commands(sub))
    return parser


def _command_modules():
    import importlib
    import importlib.util

    for name in COMMAND_MODULES:
        if importlib.util.find_spec(name.rsplit(".", 1)[0]) and importlib.util.find_spec(name):
            yield importlib.import_module(name)


def _seconds(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got {text!r}")
    return v


def main(argv=None) -> int:
    """Entry point of the console script; returns the exit status. The library's ``TumbleWarning``s
    (what it did in place of what was asked) are one line each, ``tumble: note: ...``."""
    import warnings

    from .errors import TumbleWarning

    def note(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, TumbleWarning):
            print(f"tumble: note: {_one_line(str(message))}", file=sys.stderr)
        else:
            shown(message, category, filename, lineno, file, line)

    with warnings.catch_warnings():
        shown = warnings.showwarning
        warnings.simplefilter("default", TumbleWarning)
        warnings.showwarning = note
        return _main(argv)


def _main(argv=None) -> int:
    try:
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except _UsageError as exc:
            print(exc, file=sys.stderr)
            return EXIT_INPUT
        except SystemExit as exc:  # --help, --version
            return exc.code if isinstance(exc.code, int) else EXIT_OK
        if args.command == "validate":
            return cmd_validate(args)
        if args.command == "run":
            try:
                _check_run_args(parser._run_parser, args)
            except _UsageError as exc:
                print(exc, file=sys.stderr)
                return EXIT_INPUT
        handler = getattr(parser, "_handlers_table", {}).get(args.command)
        if handler is not None:
            return handler(args)
        return cmd_run(args)
    except InputError as err:
        print(f"tumble: error: {_one_line(str(err))}", file=sys.stderr)
        return EXIT_INPUT
    except SimulationError as err:
        print(f"tumble: simulation failed: {_one_line(str(err))}", file=sys.stderr)
        return EXIT_SIMULATION
    except KeyboardInterrupt:
        print("tumble: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def _one_line(text: str) -> str:
    return " ".join(text.split())


def cmd_validate(args) -> int:
    scene = load_scene(args.scene)
    w = scene.world
    print(f"{args.scene}: ok ({_count(w.body_count, 'body', 'bodies')}, {_count(len(w.forces), 'force', 'forces')}, "
          f"integrator {scene.integrator}, duration {scene.duration:g} s)")
    return EXIT_OK


def _energy_worker(sim) -> str | None:
    """What in the simulator's world adds or takes energy (forces other than gravity and undamped
    springs, contacts, joints), as words for the run's summary line; None for a conservative world,
    whose energy change is the integrator's error."""
    from .forces import Spring

    w = sim.world
    found = []
    if any(not (isinstance(f, Spring) and f.damping == 0.0) for f in w.forces):
        found.append("forces")
    if getattr(w, "joints", None):
        found.append("joints")
    elif sim._contact_on():
        found.append("contacts")
    if getattr(w, "type_changes", None):  # a body let go brings its energy in (a kinematic one counts none)
        found.append("bodies changing type")
    return " and ".join(found) if found else None


def _count(n, one, many):
    return f"{n} {one if n == 1 else many}"


def _check_run_args(run_parser, args):
    if args.resume is None and args.scene is None:
        run_parser.error("the following arguments are required: SCENE")
    if args.resume is not None:
        for given, option in ((args.scene is not None, "SCENE"), (args.out is not None, "--out"), (args.integrator is not None, "--integrator")):
            if given:
                run_parser.error(f"{option} cannot be given with --resume (the run continues as it was started)")


def cmd_run(args) -> int:
    if getattr(args, "max_memory", None) is not None:
        from .checks import parse_size

        os.environ["TUMBLE_MAX_MEMORY"] = str(parse_size(args.max_memory, "--max-memory"))
    if getattr(args, "resume", None) is not None:
        return cmd_resume(args)
    if args.command == "demo":
        ref = resources.files("tumble").joinpath("scenes", "demo.toml")
        with resources.as_file(ref) as path:
            scene = load_scene(path)
            scene_text = Path(path).read_bytes()
        label = "demo"
        out = Path(args.out if args.out is not None else "tumble-demo")
        copy_name = "scene.toml"
    else:
        scene = load_scene(args.scene)
        scene_text = Path(args.scene).read_bytes()
        label = str(args.scene)
        out = Path(args.out if args.out is not None else Path("out") / Path(args.scene).stem)
        copy_name = "scene" + Path(args.scene).suffix.lower()
    _apply_overrides(scene, args)

    media = _media_requested(args)
    if "images" in media and not scene.cameras:
        raise InputError("the scene has no [[cameras]] to capture", "--images", label)
    targets = [out / name for name in OUTPUT_NAMES] + [out / MEDIA_NAMES[m] for m in media] + [out / copy_name]
    if out.exists() and not out.is_dir():
        raise InputError("exists and is not a folder (choose another --out)", None, str(out))
    if not args.force:
        for t in targets:
            if t.exists():
                raise InputError("exists (pass --force to overwrite)", None, str(t))
    sim = scene.simulator()
    info = {"label": label, "source": None if scene.source is None else str(scene.source), "data": scene.data,
            "settings": scene.settings(), "copy": copy_name}
    # every check that can refuse the run (frame plan, --checkpoint-every, disk) before anything
    # is written or removed: a refused run leaves the folder as it was, a new one uncreated
    try:
        check_run(sim, out, scene.duration, scene.frame_rate, checkpoint_every=args.checkpoint_every)
    except InputError as err:
        raise _named(err, args, None if args.command == "demo" else label) from None
    copy_path = targets[-1]
    try:
        _write_bytes_atomic(copy_path, scene_text)
        if args.force:
            _remove_stale_media(out, media)
    except OSError as exc:
        raise InputError(f"cannot write outputs: {exc.strerror or exc}", None, str(exc.filename or out)) from None

    status = _stream(sim, out, scene.duration, scene.frame_rate, args, info, resume=False)
    if status == EXIT_OK and media:
        _write_media(out, media, progress=(not args.no_progress) and sys.stderr.isatty(), scene=scene)
    return status


def _named(err: InputError, args, scene_file) -> InputError:
    """A refusal of the run's plan keyed ``simulation.duration`` (or ``frame_rate``) and no file:
    the ``--duration`` typed, or the scene file the value came from."""
    if err.file is None and err.key == "simulation.duration" and getattr(args, "duration", None) is not None:
        return InputError(err.problem, "--duration")
    if err.file is None and err.key in ("simulation.duration", "simulation.frame_rate") and scene_file:
        return InputError(err.problem, err.key, scene_file)
    return err


def _media_requested(args) -> list[str]:
    """The media to write. ``tumble run --video`` without the packages it needs is bad input;
    ``tumble demo`` leaves out what cannot be made here, with one line saying how to get it."""
    if args.command == "demo":
        media = [] if args.no_media else ["video", "gltf", "plots"]
    else:
        media = [m for m in MEDIA_NAMES if getattr(args, m, False)]
    kept = []
    for m in media:
        modules, extra = MEDIA_NEEDS[m]
        missing = _missing_modules(modules)
        if not missing:
            kept.append(m)
        elif args.command == "demo":
            print(f"tumble: note: no {MEDIA_NAMES[m]}: it needs {', '.join(missing)} (pip install 'tumble[{extra}]')", file=sys.stderr)
        else:
            raise InputError(f"needs {', '.join(missing)}: pip install 'tumble[{extra}]'", f"--{m}")
    return kept


def _remove_stale_media(out: Path, media) -> list[Path]:
    """``--force``: remove the media of the run being replaced that this run will not write (the
    ``MEDIA_NAMES`` not in ``media``), so that no .glb, .html or video in ``out`` shows the old run
    beside the new trajectory. Only what tumble writes there: the media files themselves, plots/'s
    ``PLOT_NAMES`` and images/'s ``NAME/rgb_NNNNN.png`` and ``NAME.npz``; a folder goes only when
    that emptied it, so a file of the user's in it is kept. One line on stderr per media file or folder
    removed. Returns the files removed."""
    import re

    from .render.plots import PLOT_NAMES

    removed = []
    for kind, name in MEDIA_NAMES.items():
        path = out / name
        if kind in media or not (path.exists() or path.is_symlink()):
            continue
        if kind == "plots" and path.is_dir():
            files = [path / n for n in PLOT_NAMES if (path / n).is_file()]
        elif kind == "images" and path.is_dir():
            frame = re.compile(r"rgb_\d{5,}\.png")
            files = [f for d in sorted(path.iterdir()) if d.is_dir() and not d.is_symlink()
                     for f in sorted(d.iterdir()) if frame.fullmatch(f.name) and f.is_file()]
            files += [f for f in sorted(path.glob("*.npz")) if f.is_file()]
        elif path.is_file() or path.is_symlink():
            files = [path]
        else:  # a folder where tumble writes a file: not ours to empty
            continue
        for f in files:
            f.unlink()
        removed.extend(files)
        if files and path.is_dir() and not path.is_symlink():  # the folders emptied now: a camera's, plots/, images/
            for d in sorted({f.parent for f in files} - {path}):
                if not any(d.iterdir()):
                    d.rmdir()
            if not any(path.iterdir()):
                path.rmdir()
        if files:
            what = f"{path}" if files == [path] else f"{path}/ ({_count(len(files), 'file', 'files')})"
            print(f"tumble: note: removed {what}: the replaced run's, which this run does not write (--force)",
                  file=sys.stderr)
    return removed


def _missing_modules(modules) -> list[str]:
    import importlib.util

    return [m for m in modules if importlib.util.find_spec(m) is None]


def _write_media(out: Path, media, progress: bool, scene=None):
    """The video, glTF, USD and plots of the finished run in ``out`` (issue: see and share the motion);
    the camera images of ``scene``'s cameras."""
    from .trajectory import load_trajectory

    traj = load_trajectory(out / OUTPUT_NAMES[0])
    written = []
    if "video" in media:
        from .render import render_video

        written.append(render_video(traj, out / MEDIA_NAMES["video"], width=VIDEO_SIZE[0], height=VIDEO_SIZE[1], progress=progress))
    for kind in ("gltf", "usd", "html"):
        if kind in media:
            from .export import export

            written.append(export(traj, out / MEDIA_NAMES[kind]))
    if "plots" in media:
        from .render.plots import plot_trajectory

        written.extend(plot_trajectory(traj, out / MEDIA_NAMES["plots"]))
    if "images" in media:
        from .scene_cameras import write_images

        files = write_images(out, scene.world, scene.cameras, traj)
        written.append(f"{out / MEDIA_NAMES['images']}/ ({len(files)} files)")
    print("wrote " + ", ".join(str(p) for p in written))


def cmd_resume(args) -> int:
    """``tumble run --resume DIR [--duration S] [media flags]``: continue the run in DIR from its
    checkpoint; once it completes, write the media asked for now (``--video``, ``--gltf``, ...) from
    the whole trajectory, as ``tumble run`` does. They replace any the folder holds from an earlier
    part of the same run (they showed fewer frames), as the trajectory and summary are replaced."""
    from .simulator import Simulator

    out = Path(args.resume)
    if not out.is_dir():
        raise InputError("not a folder of a run (expected the --out folder of an earlier tumble run)", "--resume", str(out))
    # bad media flags (a missing package) are refused before the run, as for tumble run
    media = _media_requested(args)
    path = out / "checkpoint.npz"
    sim = Simulator.load_checkpoint(path)
    # the run record (progress and tumble run's info), checked before anything is written
    run = read_run_record(sim.checkpoint_run, path, sim.world.body_count, progress=True)
    info = _read_run_info(run.get("info"), path)
    scene = _resumed_scene_cameras(info) if "images" in media else None
    duration = args.duration if args.duration is not None else run["duration"]
    info["settings"]["duration"] = duration
    every = args.checkpoint_every if args.checkpoint_every is not None else run.get("checkpoint_every")
    args.checkpoint_every = every
    try:
        check_run(sim, out, duration, run["frame_rate"], checkpoint_every=every, resume=True)
    except InputError as err:  # a plan refused: the --duration typed, or the record's values
        if err.file is None and err.key in ("simulation.duration", "simulation.frame_rate") and (
                err.key == "simulation.frame_rate" or args.duration is None):
            raise InputError(err.problem, "run." + err.key.split(".")[1], str(path)) from None
        raise _named(err, args, None) from None
    status = _stream(sim, out, duration, run["frame_rate"], args, info, resume=True)
    if status == EXIT_OK and media:
        if scene is not None:  # the cameras of the scene file, over the resumed world (its bodies, their types now)
            scene.world = sim.world
        _write_media(out, media, progress=(not args.no_progress) and sys.stderr.isatty(), scene=scene)
    return status


# tumble run's part of a checkpoint's run record (``run.info``): key -> (test, what it must be)
RUN_INFO = {"label": (lambda v: isinstance(v, str), "text"),
            "source": (lambda v: v is None or isinstance(v, str), "the scene file's path or null"),
            "data": (lambda v: True, "the scene"),
            "settings": (lambda v: isinstance(v, dict) and isinstance(v.get("integrator"), str),
                         "a table of the run's settings (integrator, dt, ...)"),
            "copy": (lambda v: isinstance(v, str) and v != "" and Path(v).name == v, "a file name")}


def _read_run_info(info, path: Path) -> dict:
    """``run.info`` of the checkpoint at ``path``, checked (``RUN_INFO``): InputError
    ``PATH: run.info.KEY: problem`` for a missing or damaged entry."""
    if not isinstance(info, dict):
        raise InputError("not written by tumble run (no table of the run's scene and settings)", "run.info", str(path))
    for key, (test, what) in RUN_INFO.items():
        if key not in info:
            raise InputError("missing (the checkpoint was not written by tumble run, or is damaged)", f"run.info.{key}", str(path))
        if not test(info[key]):
            raise InputError(f"must be {what}, got {shown(info[key])}", f"run.info.{key}", str(path))
    return info


def _resumed_scene_cameras(info: dict):
    """The scene of a resumed run read again from its file, for its ``[[cameras]]`` (``--images``):
    the checkpoint keeps the world, not the cameras. InputError when the file is gone or has none."""
    source = info.get("source")
    if not source or not Path(source).is_file():
        raise InputError(f"needs the run's scene file for its cameras, and {source or 'it'} is not there "
                         "(capture them with tumble.scene_cameras.write_images)", "--images")
    scene = load_scene(source)
    if not scene.cameras:
        raise InputError("the scene has no [[cameras]] to capture", "--images", str(source))
    return scene


def _stream(sim, out: Path, duration, frame_rate, args, info, resume: bool) -> int:
    progress = (not args.no_progress) and sys.stderr.isatty()
    label = info["label"]

    def summary(result):
        return make_summary_from(info, sim, result)

    try:
        result = sim.run_to_file(out, duration, frame_rate, checkpoint_every=args.checkpoint_every, progress=progress,
                                 handle_signals=True, summary=summary, resume=resume, run_info=info)
    except OSError as exc:
        raise InputError(f"cannot write outputs: {exc.strerror or exc}", None, str(exc.filename or out)) from None
    except SimulationError as err:
        traj = out / "trajectory.npz"
        raise SimulationError(f"{' '.join(str(err).split())} [frames before it kept in {traj}]") from None
    traj_path, summary_path, ckpt_path = (out / name for name in OUTPUT_NAMES)
    if result.status == "interrupted":
        print(f"tumble: interrupted by {result.signal} at t = {result.t:g} s: {result.frames} frames kept in {traj_path}; "
              f"continue with: tumble run --resume {out}", file=sys.stderr)
        return EXIT_TERMINATED if result.signal == "SIGTERM" else EXIT_INTERRUPTED
    r = result.figures()
    settings = info["settings"]
    n = sim.world.body_count
    print(f"{label}: {_count(n, 'body', 'bodies')}, {r['frames']} frames "
          f"({float(duration):g} s at {float(frame_rate):g} fps), {r['steps']} steps of {settings['integrator']} "
          f"in {r['wall_time_s']:.2f} s wall time")
    drift = r["energy_drift_relative"]
    drift_text = "n/a" if drift is None else f"{drift:+.3g}"
    worker = _energy_worker(sim)
    if worker is None:  # gravity and undamped springs only: the change is the integrator's error
        print(f"energy: {r['energy_initial']:.6g} J -> {r['energy_final']:.6g} J (relative drift {drift_text})")
    else:
        print(f"energy: {r['energy_initial']:.6g} J -> {r['energy_final']:.6g} J (relative change {drift_text}; "
              f"{worker} in this scene do work, so it is not an error)")
    if sim._sensor_log is not None:  # sensors: what each holds at the end (per frame: sensor_visitors)
        w = sim.world
        sensors = [i for i in range(w.body_count) if w.sensor[i]]
        held = ", ".join(f"{w.names[i]} {int(c)}" for i, c in zip(sensors, sim.sensor_frame()))
        print(f"sensors (bodies inside at the end): {held}")
    print(f"wrote {traj_path}, {summary_path}, {out / info['copy']}, {ckpt_path}")
    return EXIT_OK


def _apply_overrides(scene: Scene, args):
    for option, attr in (("--duration", "duration"), ("--integrator", "integrator")):
        value = getattr(args, attr)
        if value is None:
            continue
        setattr(scene, attr, value)
        try:
            scene.check()
        except InputError as err:
            if err.key == f"simulation.{attr}":
                raise InputError(err.problem, option) from None
            raise


def make_summary_from(info: dict, sim, result) -> dict:
    """summary.json (DESIGN.md): the scene, the settings, the versions and the run's figures.

    ``run`` holds ``RunResult.figures()``: frames, steps, wall time, energies,
    ``status`` ("running" at intermediate flushes, "completed", "interrupted" or
    "failed"), ``state_hash`` of the last frame's state, ``error`` and ``signal``.
    """
    import numba
    import numpy as np
    import scipy

    return {
        "tumble_version": __version__,
        "scene": {"source": info["source"], "data": info["data"]},
        "settings": info["settings"],
        "versions": {
            "python": platform.python_version(),
            "numpy": np.__version__,
            "scipy": scipy.__version__,
            "numba": numba.__version__,
        },
        "run": result.figures(),
    }


def _write_bytes_atomic(path: Path, data: bytes):
    write_atomic(path, lambda fh: fh.write(data))


if __name__ == "__main__":
    sys.exit(main())
