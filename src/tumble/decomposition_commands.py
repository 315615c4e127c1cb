"""``tumble decompose MESH -o PIECES.obj``: a closed mesh's convex pieces (``tumble.decompose``, CoACD)
written as one OBJ, one object per piece, in the mesh's frame: to look at them (Blender imports
each object apart), to use them elsewhere as collision proxies (PyBullet's ``p.vhacd`` writes the
same kind of file; MuJoCo's obj2mjcf writes one file per piece), and to make the decomposition
before a run (it is kept in the cache the run reads: ``tumble.decomposition``).

Hooked into the ``tumble`` command by ``tumble.cli.COMMAND_MODULES``. OUT is never overwritten
without ``--force`` and is written whole or not at all. Bad input raises ``InputError`` (one
line, exit status 2).
"""

from __future__ import annotations

import os
from pathlib import Path

from .errors import InputError


def add_commands(subparsers) -> dict:
    p = subparsers.add_parser(
        "decompose", help="cut a closed mesh into convex pieces (CoACD) and write them as one .obj",
        description="Cut a closed mesh (OBJ, STL, PLY...) into convex pieces with CoACD, as a scene's "
                    "decompose = true does, and write them as one OBJ file, one object per piece, in the "
                    "mesh's frame. The decomposition is kept in tumble's cache for later runs.")
    p.add_argument("mesh", metavar="MESH", help="a closed mesh file")
    p.add_argument("-o", "--output", metavar="OUT", required=True, help="output file, .obj")
    p.add_argument("--threshold", type=float, default=0.05,
                   help="CoACD's concavity threshold, 0.01 to 1 (smaller: more, finer pieces; default 0.05)")
    p.add_argument("--max-parts", type=int, default=None, help="at most this many pieces (default: as needed)")
    p.add_argument("--max-hull-vertices", type=int, default=None, help="at most this many vertices a piece")
    p.add_argument("--seed", type=int, default=0, help="CoACD's random seed (default 0)")
    p.add_argument("--force", action="store_true", help="overwrite OUT if it exists")
    return {"decompose": cmd_decompose}


def cmd_decompose(args) -> int:
    from .decomposition import decompose
    from .shapes import Mesh

    out = Path(args.output)
    if out.suffix.lower() != ".obj":
        raise InputError(f"expected an .obj file, got {out.suffix or '(no suffix)'!r}", None, str(out))
    if out.is_dir():
        raise InputError("is a folder (give a file name ending in .obj)", None, str(out))
    if out.exists() and not args.force:
        raise InputError("exists (pass --force to overwrite)", None, str(out))
    source = Path(args.mesh)
    if not source.is_file():
        raise InputError("no such file", None, str(source))
    try:
        mesh = Mesh(path=str(source))
        compound = decompose(mesh, threshold=args.threshold, max_parts=args.max_parts,
                             max_hull_vertices=args.max_hull_vertices, seed=args.seed)
    except InputError as err:
        key = f"--{err.key.replace('_', '-')}" if err.key in ("threshold", "max_parts", "max_hull_vertices", "seed") else None
        raise InputError(err.problem, key, str(source)) from None
    lines = [f"# {len(compound.parts)} convex pieces of {source.name} (CoACD, threshold {args.threshold:g}, "
             f"seed {args.seed}), written by tumble decompose; one object per piece, the mesh's frame"]
    first = 1
    hulls = 0.0
    for k, (part, position, _q) in enumerate(compound.parts):  # each piece is placed by a translation
        lines.append(f"o piece{k}")
        lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in (part.vertices + position).tolist()]
        lines += [f"f {a + first} {b + first} {c + first}" for a, b, c in part.faces.tolist()]
        first += len(part.vertices)
        hulls += abs(float(part.trimesh.volume))
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text("\n".join(lines) + "\n")
        os.replace(tmp, out)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise InputError(f"cannot write: {exc.strerror or exc}", None, str(out)) from None
    ratio = hulls / abs(float(mesh.trimesh.volume))
    print(f"wrote {out} ({len(compound.parts)} convex pieces of {source}; their hulls hold {ratio:.3f} x the "
          f"mesh's volume)")
    return 0
