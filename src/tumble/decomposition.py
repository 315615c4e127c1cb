"""Concave moving bodies: a closed mesh cut into convex pieces (approximate convex decomposition).

tumble's narrowphase collides convex shapes (GJK/EPA, SAT) and a triangle mesh only on a fixed or
kinematic body (terrain, ramps, bowls). A moving concave object (a ring, a mug, a chair, a bowl
that is carried) is a ``Compound`` of convex pieces: ``decompose(mesh)`` makes them with CoACD
(Wei et al., "Approximate Convex Decomposition for 3D Meshes with Collision-Aware Concavity and
Tree Search", SIGGRAPH 2022; the ``coacd`` package, what MuJoCo Menagerie's ``obj2mjcf`` and
ManiSkill use), and keeps the mesh as the compound's ``source``: the body's mass properties are
the mesh's exact integrals (the pieces over-fill a concave solid) and exports draw the mesh.
PyBullet and MuJoCo take a moving mesh's convex hull instead (a ring then rests on a peg's top).

CoACD is deterministic for a given seed (the same pieces with 1 and 2 threads, measured), so a
run that decomposes stays bit-identical. A decomposition takes seconds (a 3072-triangle bowl:
5.4 s on 2 cores), so each is kept: in this process (the Compound record itself, returned again
for the same mesh and settings) and its pieces on disk, under
``$TUMBLE_CACHE_DIR`` (default ``~/.cache/tumble``) ``/decompositions/<sha256>.npz``, keyed by the
mesh's vertices and faces, the settings and CoACD's version. A cache file that cannot be read is
made again; one that cannot be written is skipped.
"""

from __future__ import annotations

import hashlib
import io
import os
import threading
import zipfile
from pathlib import Path

import numpy as np

from .errors import InputError
from .shapes import Compound, Convex, Mesh

#: CoACD's range for its concavity threshold (its README: 0.01 to 1; smaller: more, finer pieces)
THRESHOLD_RANGE = (0.01, 1.0)
_memory: dict[str, Compound] = {}  # key: the Compound made (a frozen record: shared by the calls)
_lock = threading.Lock()


def cache_dir() -> Path:
    """The folder decompositions are kept in: ``$TUMBLE_CACHE_DIR/decompositions`` (default
    ``~/.cache/tumble/decompositions``)."""
    root = os.environ.get("TUMBLE_CACHE_DIR") or os.path.join(os.path.expanduser("~"), ".cache", "tumble")
    return Path(root) / "decompositions"


def decompose(mesh, *, threshold: float = 0.05, max_parts: int | None = None, max_hull_vertices: int | None = None,
              seed: int = 0, cache: bool = True) -> Compound:
    """A ``Compound`` of convex pieces approximating the closed ``mesh``, with ``source=mesh``.

    Args:
        mesh: a ``tumble.Mesh`` (closed, consistently wound), or a mesh file's path.
        threshold: CoACD's concavity threshold, 0.01 to 1: the largest concavity (its Hausdorff
            measure, relative to the mesh's size) a piece may keep. Smaller: more, finer pieces.
        max_parts: at most this many pieces (CoACD merges the closest); None: as many as the
            threshold needs.
        max_hull_vertices: at most this many vertices per piece (CoACD decimates the hull); None:
            no limit.
        seed: CoACD's random seed (its tree search); the same seed gives the same pieces.
        cache: keep and reuse the result (in this process and on disk, see the module's docstring).

    Returns:
        ``Compound(parts=[(Convex(points=piece - middle), middle, identity), ...], source=mesh)``,
        each piece placed at the middle of its bounds in the mesh's frame. Give it to
        ``World.add_body`` like any shape: its mass, centre of mass and inertia are the mesh's own.

    Raises:
        InputError: a bad setting (keyed by its name), a mesh that is not closed, or CoACD missing
        (``pip install 'tumble[decompose]'``).
    """
    if not isinstance(mesh, Mesh) or isinstance(mesh, Convex):
        if isinstance(mesh, (str, os.PathLike)):
            mesh = Mesh(path=os.fspath(mesh))
        else:
            raise InputError(f"expected a closed tumble.Mesh or a mesh file's path, got {type(mesh).__name__}", "mesh")
    if not mesh.closed:
        raise InputError("an open mesh (closed = false) has no inside to cut into convex pieces", "mesh")
    threshold = _number(threshold, "threshold")
    if not THRESHOLD_RANGE[0] <= threshold <= THRESHOLD_RANGE[1]:
        raise InputError(f"must be between {THRESHOLD_RANGE[0]} and {THRESHOLD_RANGE[1]}, got {threshold!r}", "threshold")
    max_parts = _count(max_parts, "max_parts", 1, optional=True)
    max_hull_vertices = _count(max_hull_vertices, "max_hull_vertices", 4, optional=True)
    seed = _count(seed, "seed", 0)
    try:
        import coacd
    except ImportError:
        raise InputError("decomposing a mesh needs coacd: pip install 'tumble[decompose]'", "mesh") from None
    from importlib.metadata import version

    vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
    faces = np.ascontiguousarray(mesh.faces, dtype=np.int64)
    settings = (threshold, max_parts, max_hull_vertices, seed)
    digest = hashlib.sha256()
    for part in (vertices.tobytes(), faces.tobytes(), repr(settings).encode(), version("coacd").encode()):
        digest.update(len(part).to_bytes(8, "little") + part)
    key = digest.hexdigest()
    if cache and key in _memory:
        # the same record again: bodies sharing a shape record share its hull data in the collision
        # tables, and the pieces are not hulled again (a scene of five rings: 5 x 14 hulls, 60 ms)
        return _memory[key]
    pieces = _read(cache_dir() / f"{key}.npz") if cache else None
    if pieces is None:
        pieces = _run_coacd(coacd, vertices, faces, *settings)
        if cache:
            _write(cache_dir() / f"{key}.npz", pieces)
    parts = []
    for points in pieces:
        # each piece about the middle of its own bounds: a hull's bounding box (collision/bounds.py) is
        # centred on its origin, so with the mesh's origin every piece of a ring had the whole ring's
        # box (a ring on a ring: 196 piece pairs to test, 1.3 ms a step; measured) and GJK started
        # from a far point
        middle = 0.5 * (points.min(axis=0) + points.max(axis=0))
        try:
            parts.append((Convex(points=points - middle), tuple(float(c) for c in middle), (1.0, 0.0, 0.0, 0.0)))
        except InputError:
            continue  # a flat sliver CoACD left (no volume to hull): the pieces beside it cover its place
    if not parts:
        raise InputError("CoACD gave no solid piece (the mesh encloses too little volume)", "mesh")
    compound = Compound(parts=parts, source=mesh)
    if cache:
        with _lock:
            _memory[key] = compound
    return compound


def _number(value, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"expected a number, got {value!r}", key)
    return float(value)


def _count(value, key: str, least: int, optional: bool = False) -> int | None:
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
        raise InputError(f"expected a whole number of at least {least}, got {value!r}", key)
    return int(value)


def _run_coacd(coacd, vertices, faces, threshold, max_parts, max_hull_vertices, seed) -> tuple:
    """CoACD's pieces, each an (n, 3) float64 array of its hull's vertices (the mesh's frame)."""
    coacd.set_log_level("error")  # it logs each stage to stdout otherwise
    result = coacd.run_coacd(coacd.Mesh(vertices, faces), threshold=threshold,
                             max_convex_hull=-1 if max_parts is None else max_parts,
                             decimate=max_hull_vertices is not None,
                             max_ch_vertex=256 if max_hull_vertices is None else max_hull_vertices, seed=seed)
    return tuple(np.ascontiguousarray(v, dtype=np.float64) for v, _f in result)


def _read(path: Path) -> tuple | None:
    try:
        # from bytes: np.load leaves the file open when it is not a whole zip (a ResourceWarning)
        with np.load(io.BytesIO(path.read_bytes()), allow_pickle=False) as data:
            count = int(data["count"])
            pieces = tuple(np.asarray(data[f"piece{k}"], dtype=np.float64) for k in range(count))
        if all(p.ndim == 2 and p.shape[1] == 3 and np.isfinite(p).all() for p in pieces):
            return pieces
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile):
        pass  # missing, or not a whole file (a run killed while writing it): made again
    return None


def _write(path: Path, pieces: tuple) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        buffer = io.BytesIO()
        np.savez(buffer, count=np.int64(len(pieces)), **{f"piece{k}": p for k, p in enumerate(pieces)})
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        tmp.write_bytes(buffer.getvalue())
        os.replace(tmp, path)  # whole or not at all: a reader never sees half a file
    except OSError:
        pass  # a read-only home: the decomposition is made again next time
