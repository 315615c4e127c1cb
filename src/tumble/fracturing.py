"""Pre-fractured bodies: a convex shape cut into Voronoi cells, the cells glued by breakable
fixed joints (Blender's Cell Fracture, Bullet's and PhysX's pre-fractured destructibles).

``tb.fracture(shape, pieces, seed)`` cuts a box or convex hull (a sphere, capsule, cylinder,
cone or ellipsoid by the hull of its drawn mesh, ``visual.shape_trimesh``) into the Voronoi
cells of ``pieces`` points drawn uniformly inside it: cell i is the part of the shape nearer to point i than to any
other, the intersection of the shape's half-spaces with the bisector half-spaces
(s_j - s_i) . p <= (|s_j|^2 - |s_i|^2) / 2 (``scipy.spatial.HalfspaceIntersection`` from the
point, which lies inside its cell). The cells are convex, fill the shape without overlap
(their volumes sum to its volume) and two cells meet on a face of their bisector plane.

``World.add_fractured(fractured, density, position, ...)`` adds each cell as a body (a
``tb.Convex``, its mass properties exact from the polyhedron) and glues pairs of cells that
share a face (``glued_faces``: the faces of a quarter of the mean face's area or more, and a
spanning tree that holds every cell) by a ``FixedJoint`` at the face's centroid that breaks
under the force or torque a glue of tensile ``strength`` (Pa) over that face can bear: ``max_force = strength * A`` and
``max_torque = strength * A^1.5 / 6`` (a square joint of area A in bending: the section modulus
a^3 / 6 of a square of side a = sqrt(A)). Glued cells do not collide with each other (the
joints' ``collide_connected`` is False); once a joint breaks, its two cells do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError
from .math3d import norm3, rows_dot

# Two cells share a face when at least 3 of a cell's vertices lie within this fraction of the
# shape's size of their bisector plane and the polygon they span has at least FACE_AREA_MIN
# (a fraction of the size squared): Voronoi neighbours whose cells only touch at an edge or a
# corner inside the shape are not glued.
PLANE_TOLERANCE = 1e-9
FACE_AREA_MIN = 1e-8
# Faces smaller than this fraction of the mean face's area are glued only where they hold the
# cells together (the largest-area spanning tree of the faces is always glued: no cell is left
# loose). A joint does not know its face's area, so the solver shares a load among the glues of
# a cell without regard to it, and the small faces' glues, whose strength scales with their area
# (and in bending with area^1.5), took stresses far above the load's: in a 40-cell wall of
# concrete standing on the ground (28 kPa of weight at its foot), glues on faces of 3 %, 8 % and
# 6 % of the mean face carried 4.3, 0.71 and 0.28 MPa in bending, the larger ones 0.1-0.24 MPa
# (measured; a rigid network of joints leaves the split of a load among its loops to the
# solver, not to elasticity). With 0.25 the largest stress in that wall at rest is 0.26 MPa.
MIN_FACE = 0.25


@dataclass
class Fractured:
    """A shape cut into K convex cells (``fracture``), in the shape's frame (m).

    cells: K arrays (V_k, 3) of each cell's vertices.
    seeds: (K, 3) the points whose Voronoi cells they are.
    faces: (F, 2) int64 pairs (i < j) of cells sharing a face.
    face_area: (F,) m^2, face_centroid: (F, 3) m, face_normal: (F, 3) unit, from cell i to cell j.
    volume: (K,) m^3 of each cell.
    """

    cells: list
    seeds: np.ndarray
    faces: np.ndarray
    face_area: np.ndarray
    face_centroid: np.ndarray
    face_normal: np.ndarray
    volume: np.ndarray = field(repr=False)

    def __len__(self) -> int:
        return len(self.cells)


#: rounds of 4 x pieces random points ``fracture`` draws at most to find the seeds inside the shape
SAMPLING_ROUNDS = 1000


def _shape_hull(shape):
    """(vertices (V, 3), halfspaces (H, 4) as a x + b <= 0) of the convex shape, its frame."""
    from scipy.spatial import ConvexHull, QhullError

    from .shapes import Box, Capsule, Cone, Convex, Cylinder, Ellipsoid, Sphere

    if isinstance(shape, Box):
        h = np.asarray(shape.half_extents, dtype=float)
        verts = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float) * h
    elif isinstance(shape, Convex):
        verts = np.asarray(shape.vertices, dtype=float)
    elif isinstance(shape, (Sphere, Capsule, Cylinder, Cone, Ellipsoid)):
        from .visual import shape_trimesh

        with np.errstate(all="ignore"):  # a 1e308 radius: inf vertices, refused below (no NumPy warning)
            verts = np.asarray(shape_trimesh(shape).vertices, dtype=float)
    else:
        raise InputError(f"cannot fracture a {type(shape).__name__}: a Box, Convex, Sphere, Capsule, Cylinder, "
                         "Cone or Ellipsoid", "shape")
    from .mass import _dimension_key
    from .shapes import MAX_COORDINATE

    with np.errstate(all="ignore"):  # a 1e308 box: its extent overflows to inf, refused just below
        size = float(np.max(verts.max(axis=0) - verts.min(axis=0)))
    if not size <= MAX_COORDINATE:  # Qhull's arithmetic (and the cells' volumes) would overflow
        across = f"{size:g} m across" if math.isfinite(size) else "its extent overflows a float"
        raise InputError(f"too large to fracture: {across} (at most {MAX_COORDINATE:g} m)", _dimension_key(shape))
    try:
        hull = ConvexHull(verts)
    except (QhullError, ValueError) as err:
        raise InputError(f"cannot be cut into cells: its hull cannot be built ({_qhull_words(err)})",
                         _dimension_key(shape)) from None
    return verts[hull.vertices], hull.equations


def _qhull_words(err) -> str:
    """The first line of a Qhull error, without Qhull's option dump (or the exception's type)."""
    text = str(err).strip()
    return text.splitlines()[0].split(" While executing")[0] if text else type(err).__name__


# The cells' arithmetic is written out column by column (``math3d.rows_dot``, ``norm3``) rather
# than left to ``@``: NumPy's matrix products go through OpenBLAS, whose kernels differ by CPU and
# round differently, and qhull turned those last bits into other cells: examples/wrecking_ball.toml
# ended in another state on an AVX-512 machine (measured 2026-12-04; tests/conftest.py).
def _inside(points, halfspaces, margin):
    return np.all(rows_dot(points, halfspaces[:, :3]) + halfspaces[:, 3] <= -margin, axis=1)


def fracture(shape, pieces: int = 16, seed: int = 0, points=None) -> Fractured:
    """Cut ``shape`` into the Voronoi cells of ``pieces`` points drawn uniformly inside it (NumPy's
    generator from ``seed``), or of the given ``points`` ((K, 3) m, shape frame, inside it)."""
    from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError

    verts, walls = _shape_hull(shape)
    size = float(np.max(np.ptp(verts, axis=0)))
    if points is None:
        if isinstance(pieces, bool) or not isinstance(pieces, (int, np.integer)) or not 2 <= pieces <= 1000:
            raise InputError(f"must be a whole number from 2 to 1000, got {pieces!r}", "pieces")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise InputError(f"must be a whole number >= 0, got {seed!r}", "seed")
        rng = np.random.default_rng(seed)
        lo, hi = verts.min(axis=0), verts.max(axis=0)
        seeds = np.zeros((0, 3))
        rounds = 0
        while len(seeds) < pieces:  # rejection sampling in the bounding box: uniform in the shape
            rounds += 1
            if rounds > SAMPLING_ROUNDS:  # a shape far thinner than it is wide has no inside at the margin: no end
                from .mass import _dimension_key

                raise InputError(f"too thin to cut into cells: {len(seeds)} of {pieces} points found inside it "
                                 f"({size:g} m across, far more than its thickness)", _dimension_key(shape))
            trial = rng.uniform(lo, hi, size=(4 * pieces, 3))
            seeds = np.vstack([seeds, trial[_inside(trial, walls, 1e-6 * size)]])
        seeds = seeds[:pieces]
    else:
        seeds = np.asarray(points, dtype=float)
        if seeds.ndim != 2 or seeds.shape[1] != 3 or len(seeds) < 2 or not np.all(np.isfinite(seeds)):
            raise InputError(f"must be two or more finite 3-vectors, got shape {seeds.shape}", "points")
        if not np.all(_inside(seeds, walls, 1e-9 * size)):
            raise InputError("every point must lie inside the shape", "points")
        if len(np.unique(seeds, axis=0)) != len(seeds):
            raise InputError("the points must differ", "points")
    K = len(seeds)
    cells, volume = [], np.empty(K)
    for i in range(K):
        others = np.delete(np.arange(K), i)
        normal = seeds[others] - seeds[i]  # (s_j - s_i) . p - (|s_j|^2 - |s_i|^2) / 2 <= 0
        offset = -0.5 * (rows_dot(seeds[others] * seeds[others], np.ones(3)) - rows_dot(seeds[i:i + 1], seeds[i])[0])
        halfspaces = np.vstack([walls, np.column_stack([normal, offset])])
        try:
            cell = HalfspaceIntersection(halfspaces, seeds[i]).intersections
            hull = ConvexHull(cell)
        except (QhullError, ValueError) as err:  # a flat or vanishing cell: points nearly together
            raise InputError(f"cell {i} could not be cut (points too close together?): {_qhull_words(err)}",
                             "points") from None
        cells.append(cell[hull.vertices])
        volume[i] = hull.volume
    faces, area, centroid, facing = [], [], [], []
    for i in range(K):
        for j in range(i + 1, K):
            n = seeds[j] - seeds[i]
            length = float(norm3(n))
            n = n / length
            c = float(rows_dot(0.5 * (seeds[i] + seeds[j])[None, :], n)[0])  # the bisector plane: n . p = c
            on = cells[i][np.abs(rows_dot(cells[i], n) - c) <= PLANE_TOLERANCE * size + 1e-12]
            if len(on) < 3:
                continue
            a, centre = _polygon(on, n)
            if a < FACE_AREA_MIN * size * size:
                continue
            faces.append((i, j))
            area.append(a)
            centroid.append(centre)
            facing.append(n)
    return Fractured(cells=cells, seeds=seeds, faces=np.array(faces, dtype=np.int64).reshape(-1, 2),
                     face_area=np.array(area), face_centroid=np.array(centroid).reshape(-1, 3),
                     face_normal=np.array(facing).reshape(-1, 3), volume=volume)


def _polygon(points, n):
    """(area m^2, centroid (3,)) of the convex polygon of ``points`` (P, 3) on a plane of normal n."""
    from scipy.spatial import ConvexHull, QhullError

    e1 = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= norm3(e1)
    e2 = np.cross(n, e1)
    flat = np.column_stack([rows_dot(points, e1), rows_dot(points, e2)])
    try:
        hull = ConvexHull(flat)
    except (QhullError, ValueError):  # collinear: an edge, no face
        return 0.0, points.mean(axis=0)
    ring = flat[hull.vertices]
    x, y = ring[:, 0], ring[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    a = 0.5 * cross.sum()
    cx = ((x + np.roll(x, -1)) * cross).sum() / (6 * a)
    cy = ((y + np.roll(y, -1)) * cross).sum() / (6 * a)
    level = float(rows_dot(points[:1], n)[0])
    return abs(a), cx * e1 + cy * e2 + level * n


def cell_names(name: str, count: int) -> list[str]:
    """The bodies' names of a fractured body's ``count`` cells: ``name/00``, ``name/01``, ... (as
    many digits as the last index has)."""
    width = len(str(count - 1))
    return [f"{name}/{k:0{width}d}" for k in range(count)]


def glued_faces(fractured: Fractured, min_face: float = MIN_FACE) -> np.ndarray:
    """(F,) bool: the faces ``add_fractured`` glues: those of at least ``min_face`` times the mean
    face's area, and those of the largest-area spanning tree of the cells (Kruskal's, over the
    faces from the largest down), so that every cell is held and the whole is one piece."""
    F = len(fractured.faces)
    keep = np.zeros(F, dtype=bool)
    if F == 0:
        return keep
    keep |= fractured.face_area >= min_face * float(np.mean(fractured.face_area))
    parent = list(range(len(fractured)))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for f in np.argsort(-fractured.face_area, kind="stable"):
        a, b = root(int(fractured.faces[f, 0])), root(int(fractured.faces[f, 1]))
        if a != b:
            parent[a] = b
            keep[f] = True
    return keep


def add_fractured(world, fractured: Fractured, *, density: float, position=(0.0, 0.0, 0.0), orientation=None,
                  euler_deg=None, strength: float = math.inf, min_face: float = MIN_FACE, name: str = "piece",
                  **body_options):
    """Add the cells of ``fractured`` to ``world`` as bodies ``{name}/{k}`` of ``density`` (kg/m^3)
    placed as one shape at ``position`` (its shape origin, world) and ``orientation`` /
    ``euler_deg``, and glue each pair sharing a face with a breakable ``FixedJoint`` (module
    docstring; ``strength`` Pa, inf: never breaks); the faces glued are ``glued_faces(fractured,
    min_face)``. ``body_options``: the rest of
    ``World.add_body``'s (velocity, angular_velocity, material, collision_filter, ...), the same
    for every cell: ``velocity`` is the whole's centre of mass's, and with an ``angular_velocity``
    each cell takes the rigid motion's velocity at its own centre of mass. Returns (bodies, joints)."""
    from .joints import FixedJoint
    from .math3d import quat_from_euler_deg, quat_to_matrix
    from .shapes import Convex

    if not (isinstance(strength, (int, float)) and not isinstance(strength, bool) and strength > 0):
        raise InputError(f"must be a positive number of Pa, got {strength!r}", "strength")
    bodies = []
    for cell, cell_name in zip(fractured.cells, cell_names(name, len(fractured))):
        bodies.append(world.add_body(Convex(points=cell), density=density, position=position, orientation=orientation,
                                     euler_deg=euler_deg, name=cell_name, **body_options))
    w = world
    rows = [b.index for b in bodies]
    omega = w.omega[rows[0]].copy()
    if np.any(omega):  # a spinning whole: each cell moves with the rigid motion, v + omega x (x_k - centre)
        m = w.mass[rows]
        centre = (m[:, None] * w.x[rows]).sum(axis=0) / m.sum()
        v = w.v[rows[0]].copy()
        for b in bodies:
            b.v = v + np.cross(omega, b.x - centre)
    if euler_deg is not None:
        R = quat_to_matrix(quat_from_euler_deg(np.asarray(euler_deg, dtype=float)))
    elif orientation is not None:
        q = np.asarray(orientation, dtype=float)
        R = quat_to_matrix(q / math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]))
    else:
        R = np.eye(3)
    origin = np.asarray(position, dtype=float)
    joints = []
    glued = glued_faces(fractured, min_face)
    for (i, j), a, c, keep in zip(fractured.faces, fractured.face_area, fractured.face_centroid, glued):
        if not keep:
            continue
        joint = FixedJoint(bodies[i], bodies[j], anchor=origin + rows_dot(R, c), max_force=strength * a,
                           max_torque=strength * a ** 1.5 / 6.0, name=f"{name}/glue{i}-{j}")
        joints.append(world.add_joint(joint))
    return bodies, joints
