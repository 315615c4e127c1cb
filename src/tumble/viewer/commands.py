"""``tumble view SCENE_OR_TRAJ``: the browser viewer from the command line (``tumble.cli`` hook).

A ``.npz`` trajectory is shown as is; a scene file (``.toml``/``.json``) is run
first (with a progress bar), then shown; with ``--live`` a scene is simulated as it
is shown (``tumble.viewer.live``). The server binds to 127.0.0.1 unless
``--host`` says otherwise, prints its URL, and serves until Ctrl-C or SIGTERM (exit 0).
Bad input (missing file, unknown suffix, bad scene or trajectory) raises
``InputError``: one line, exit status 2.
"""

from __future__ import annotations

import contextlib
import importlib.util
import signal
import sys
import threading

from ..errors import InputError


def add_commands(subparsers) -> dict:
    p = subparsers.add_parser("view", help="show a scene or a trajectory in the browser viewer (viser)")
    p.add_argument("target", metavar="SCENE_OR_TRAJ", help="trajectory .npz, or scene .toml/.json, MuJoCo model .xml or USD stage (run first, or live with --live)")
    p.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=_port, default=8080, help="port (default 8080; the next free one if busy)")
    p.add_argument("--no-browser", action="store_true", help="do not open a browser, just print the URL")
    p.add_argument("--live", action="store_true",
                   help="simulate the scene as it is shown, in real time: play, pause, step, reset, push and grab bodies")
    p.add_argument("--out", metavar="DIR", default=None,
                   help="with --live: where Save writes the runs (DIR/run-001/trajectory.npz and .glb; default tumble-live)")
    return {"view": cmd_view}


def _port(text: str) -> int:
    import argparse

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a port number, got {text!r}") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"must be between 0 and 65535, got {value}")
    return value


def cmd_view(args, wait=None) -> int:
    """Run the viewer until Ctrl-C. ``wait`` (tests) replaces the blocking wait."""
    from .app import Viewer, check_address, load_input, open_in_browser

    if importlib.util.find_spec("viser") is None:
        raise InputError("needs viser: pip install 'tumble[viewer]'", None, "tumble view") from None
    try:
        check_address(args.host, args.port)
    except InputError as err:
        raise InputError(err.problem, f"--{err.key}") from None
    if getattr(args, "out", None) is not None and not args.live:
        raise InputError("--out is for --live (where Save writes the runs)", "--out")
    if args.live:
        from .live_viewer import live

        viewer = live(args.target, host=args.host, port=args.port, out=args.out)  # InputError on bad input
        what = f"live, {viewer.sim.dt:g} s steps"
    else:
        traj, extras = load_input(args.target, progress=sys.stderr.isatty())  # InputError on bad input
        viewer = Viewer(traj, host=args.host, port=args.port, play=True, extras=extras)
        what = f"{len(traj.time)} frames"
    try:
        # NOTE: Ctrl-C is caught from before the ready line on: a SIGINT sent as soon as the line
        # was read once came before the wait and ended the viewer with status 130 (seen in CI)
        try:
            with _terminate_as_interrupt():
                print(f"tumble view: {args.target}: {viewer.body_count} bodies, {what} at "
                      f"{viewer.url} (Ctrl-C to stop)", flush=True)
                if not args.no_browser:
                    open_in_browser(viewer.url)
                (wait or _wait_forever)()
        except KeyboardInterrupt:
            pass
    finally:
        viewer.stop()
    print("tumble view: stopped", flush=True)
    return 0


def _wait_forever():
    event = threading.Event()
    while not event.wait(3600.0):
        pass


@contextlib.contextmanager
def _terminate_as_interrupt():
    """While serving, SIGTERM stops the viewer as Ctrl-C does (exit 0)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def _raise(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, _raise)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
