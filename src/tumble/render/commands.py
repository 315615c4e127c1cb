"""``tumble render`` (a trajectory to a video) and ``tumble plot`` (its invariants to PNGs).

Both take TRAJ, a ``trajectory.npz`` or the folder ``tumble run`` wrote it to.
Nothing that exists is overwritten without ``--force``. Bad input raises
InputError: the CLI prints one line and exits with status 2.
"""

from __future__ import annotations

import sys
from pathlib import Path

from ..errors import InputError

CLI_KEYS = {"width": "--width", "height": "--height", "fps": "--fps", "camera": "--camera"}


def add_commands(subparsers) -> dict:
    render = subparsers.add_parser("render", help="render a trajectory to a video (.mp4 or .gif), headless",
                                   description="Render a trajectory to a video without a display: ground grid, "
                                               "lighting, one colour per body, a fixed or following camera.")
    render.add_argument("trajectory", metavar="TRAJ", help="trajectory.npz, or the folder holding it")
    render.add_argument("-o", "--out", metavar="VIDEO", help="output .mp4 (H.264) or .gif (default: TRAJ's folder/<name>.mp4)")
    render.add_argument("--width", type=int, default=1280, metavar="PX", help="width in pixels (default 1280; even for .mp4)")
    render.add_argument("--height", type=int, default=720, metavar="PX", help="height in pixels (default 720; even for .mp4)")
    render.add_argument("--fps", type=float, metavar="N", help="frames per second (default: the trajectory's); "
                        "the video plays in real time, poses are interpolated between recorded frames")
    render.add_argument("--camera", default="frame", metavar="frame|follow:NAME",
                        help="'frame' (fixed, frames all bodies over the run; default) or 'follow:NAME' (follows body NAME)")
    render.add_argument("--force", action="store_true", help="overwrite VIDEO if it exists")
    render.add_argument("--no-antialias", action="store_true", help="sharp-edged frames, about 1.7x faster "
                        "(by default edges are smoothed by super-sampling)")
    render.add_argument("--no-progress", action="store_true", help="never show a progress bar")

    plot = subparsers.add_parser("plot", help="plot energy, momentum and orthonormality error over time (PNG)",
                                 description="Write energy.png, momentum.png and orthonormality.png for a trajectory.")
    plot.add_argument("trajectory", metavar="TRAJ", help="trajectory.npz, or the folder holding it")
    plot.add_argument("-o", "--out", metavar="DIR", help="output folder (default: TRAJ's folder/plots)")
    plot.add_argument("--force", action="store_true", help="overwrite the PNGs if they exist")
    return {"render": cmd_render, "plot": cmd_plot}


def _trajectory_path(text: str) -> Path:
    path = Path(text)
    if path.is_dir() and (path / "trajectory.npz").is_file():
        return path / "trajectory.npz"
    return path


def cmd_render(args) -> int:
    from ..trajectory import load_trajectory
    from .video import VIDEO_SUFFIXES, render_video, trajectory_fps

    traj_path = _trajectory_path(args.trajectory)
    out = Path(args.out) if args.out is not None else traj_path.with_suffix(".mp4")
    if out.suffix.lower() not in VIDEO_SUFFIXES:
        raise InputError(f"video must end in {' or '.join(VIDEO_SUFFIXES)}, got {out.suffix or 'no suffix'!r}", "--out", str(out))
    if out.is_dir():
        raise InputError("is a folder (give a file name ending in .mp4 or .gif)", "--out", str(out))
    if out.exists() and not args.force:
        raise InputError("exists (pass --force to overwrite)", None, str(out))
    traj = load_trajectory(traj_path)
    progress = (not args.no_progress) and sys.stderr.isatty()
    try:
        render_video(traj, out, width=args.width, height=args.height, fps=args.fps, camera=args.camera, progress=progress,
                     antialias=not args.no_antialias)
    except InputError as err:
        if err.key in CLI_KEYS:  # name the option the user typed
            raise InputError(err.problem, CLI_KEYS[err.key], err.file) from None
        raise err if err.file else err.within(file=str(traj_path)) from None  # a value of the trajectory file
    except OSError as exc:
        raise InputError(f"cannot write the video: {exc.strerror or exc}", None, str(out)) from None
    fps = trajectory_fps(traj) if args.fps is None else args.fps
    duration = float(traj.time[-1] - traj.time[0])
    print(f"wrote {out} ({args.width}x{args.height}, {fps:g} fps, {duration:g} s, camera {args.camera})")
    return 0


def cmd_plot(args) -> int:
    from ..trajectory import load_trajectory
    from .plots import PLOT_NAMES, plot_trajectory

    traj_path = _trajectory_path(args.trajectory)
    out = Path(args.out) if args.out is not None else traj_path.parent / "plots"
    if out.exists() and not out.is_dir():
        raise InputError("exists and is not a folder (choose another -o)", "--out", str(out))
    if not args.force:
        for name in PLOT_NAMES:
            if (out / name).exists():
                raise InputError("exists (pass --force to overwrite)", None, str(out / name))
    traj = load_trajectory(traj_path)
    try:
        paths = plot_trajectory(traj, out)
    except OSError as exc:
        raise InputError(f"cannot write the plots: {exc.strerror or exc}", None, str(exc.filename or out)) from None
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0
