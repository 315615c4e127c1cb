"""``tumble export TRAJ -o OUT``: a trajectory file to glTF (.glb), USD (.usd, .usda, .usdc) or a
self-contained web page (.html).

Hooked into the ``tumble`` command by ``tumble.cli.COMMAND_MODULES``. TRAJ is a
``trajectory.npz`` or the output folder of ``tumble run`` / ``tumble demo``
(its ``trajectory.npz`` is used). The format follows OUT's suffix. An existing
OUT is never overwritten without ``--force``. Bad input raises ``InputError``
(one line, exit status 2).
"""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from . import GLTF_SUFFIXES, HTML_SUFFIXES, SUFFIXES

FORMAT_NAMES = {".glb": "glTF 2.0 binary", ".usd": "USD (binary)", ".usdc": "USD (binary)", ".usda": "USD (text)",
                ".html": "web page with its viewer", ".htm": "web page with its viewer"}


def add_commands(subparsers) -> dict:
    p = subparsers.add_parser(
        "export", help="write a trajectory as glTF (.glb), USD (.usd, .usda, .usdc) or a web page (.html)",
        description="Write a trajectory as an animation: glTF 2.0 binary (.glb), USD (.usd, .usda, .usdc) or one "
                    "self-contained web page that plays it (.html: no network, no server), chosen by the output "
                    "file's suffix. Each body is a mesh whose transform follows its centre of mass and "
                    "orientation, frame by frame.")
    p.add_argument("trajectory", metavar="TRAJ", help="trajectory.npz, or a folder written by tumble run / tumble demo; "
                   "or a scene file (.toml, .json, MJCF .xml) to write as a USD stage with physics (UsdPhysics)")
    p.add_argument("-o", "--output", metavar="OUT", required=True, help="output file: .glb, .usd, .usda, .usdc or .html")
    p.add_argument("--force", action="store_true", help="overwrite OUT if it exists")
    return {"export": cmd_export}


SCENE_SUFFIXES = (".toml", ".json", ".xml", ".usda")  # a .usda stage in: written again (units, axes made tumble's)


def _export_scene(source: Path, out: Path, suffix: str) -> int:
    """``tumble export scene.toml -o scene.usda``: the scene's World at its start as a UsdPhysics stage."""
    from ..scene import load_scene

    if suffix not in (".usd", ".usda", ".usdc"):
        raise InputError(f"a scene is written as a USD stage with physics (.usd, .usda, .usdc), not {suffix}", None,
                         str(out))
    scene = load_scene(source)
    try:
        import pxr  # noqa: F401  (usd-core)
    except ImportError:
        raise InputError("USD export needs usd-core (pip install 'tumble[export]')", None, str(out)) from None
    from .usd_scene import save_usd

    try:
        save_usd(scene.world, out)
    except OSError as exc:
        raise InputError(f"cannot write: {exc.strerror or exc}", None, str(exc.filename or out)) from None
    w = scene.world
    n, j = w.body_count, len(w.joints)
    print(f"wrote {out} (USD stage with physics: {n} {'body' if n == 1 else 'bodies'}, {j} "
          f"{'joint' if j == 1 else 'joints'}; tumble run {out.name} reads it back)")
    return 0


def cmd_export(args) -> int:
    from ..trajectory import load_trajectory

    out = Path(args.output)
    suffix = out.suffix.lower()
    if suffix not in SUFFIXES:
        raise InputError(f"unknown export format {out.suffix or '(no suffix)'!r} (expected {', '.join(SUFFIXES)})",
                         None, str(out))
    if out.is_dir():
        raise InputError("is a folder (give a file name ending in " + suffix + ")", None, str(out))
    if out.exists() and not args.force:
        raise InputError("exists (pass --force to overwrite)", None, str(out))
    source = Path(args.trajectory)
    if source.suffix.lower() in SCENE_SUFFIXES:
        return _export_scene(source, out, suffix)
    if source.is_dir():
        source = source / "trajectory.npz"
    traj = load_trajectory(source)  # InputError for a missing or unreadable file
    if len(traj.time) == 0:
        raise InputError("the trajectory has no frames", None, str(source))
    if traj.shape_table is None:
        print(f"tumble: note: {source} has no body shapes (an older file): bodies are drawn as small spheres")

    try:
        if suffix in GLTF_SUFFIXES:
            from .gltf import export_gltf as write
        elif suffix in HTML_SUFFIXES:
            from .html import export_html as write
        else:
            try:
                import pxr  # noqa: F401  (usd-core)

                from .usd import export_usd as write
            except ImportError:
                raise InputError("USD export needs usd-core (pip install 'tumble[export]')", None, str(out)) from None
        write(traj, out)
    except InputError as err:  # a value of the file that cannot be written (a shape_table row): name the file
        raise err if err.file else err.within(file=str(source)) from None
    except OSError as exc:
        raise InputError(f"cannot write: {exc.strerror or exc}", None, str(exc.filename or out)) from None

    size = out.stat().st_size
    n, f = len(traj.names), len(traj.time)
    print(f"wrote {out} ({FORMAT_NAMES[suffix]}: {n} {'body' if n == 1 else 'bodies'}, {f} frames, {size / 1024:.0f} KiB)")
    return 0
