"""Shape records, defined in the shape's own frame (metres).

A shape says what a body is made of; ``tumble.mass`` turns it into mass
properties, and later the collision stages read the same records. When a
shape's centre of mass is off its origin (a cone, a particle set, a mesh),
``World.add_body`` moves the body frame to the centre of mass and keeps the
offset (DESIGN.md, conventions).

Each record validates its own numbers and raises ``InputError`` naming the key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError

#: largest |coordinate| (m) a mesh vertex, a hull point, a heightfield's height or size, a fractured
#: shape's extent may have: 10 million km, far beyond any scene; small enough that trimesh's vertex
#: merging (coordinates times 1e8, as 64-bit integers: at most 9.2e18) and the volume and inertia
#: integrals (coordinates to the 5th power) stay in range. Beyond it: InputError.
MAX_COORDINATE = 1e10


def check_coordinates(values, key: str, what: str = "coordinates", rows: bool = True) -> None:
    """InputError (``key``) unless every number of ``values`` is finite and within ``MAX_COORDINATE``
    m, naming the first bad row when ``rows`` (vectorised; checked before any arithmetic, so no NumPy warning)."""
    a = np.asarray(values, dtype=float)
    bad = ~(np.abs(a) <= MAX_COORDINATE)  # NaN is bad too
    if bad.any():
        where = np.argwhere(bad)[0]
        value = a[tuple(where)]
        row = f" (row {int(where[0])}" + (f", column {int(where[1])})" if len(where) > 1 else ")") if a.ndim and rows else ""
        problem = "must be finite" if not np.isfinite(value) else f"must be at most {MAX_COORDINATE:g} m in magnitude"
        raise InputError(f"{what} {problem}, got {value:g}{row}", key)

# Type ids in the order collision pair routines will dispatch on (STYLE 5.2).
# NOTE: a pair's routine is found with its two ids in this order (narrowphase.collide_shapes: the
# smaller id is a; the convex family spans SHAPE_SPHERE..SHAPE_CONVEX, a mesh comes last), so a new
# convex kind goes before SHAPE_CONVEX (the ellipsoid did: the ids after it moved up by one).
(SHAPE_PLANE, SHAPE_SPHERE, SHAPE_CAPSULE, SHAPE_CYLINDER, SHAPE_CONE, SHAPE_BOX, SHAPE_ELLIPSOID, SHAPE_CONVEX, SHAPE_MESH,
 SHAPE_PARTICLES) = range(10)
# A compound is not a collision type: the shape table has one row per part.
SHAPE_COMPOUND = 10


def positive(value, key: str) -> float:
    """``value`` as a finite float > 0, or an InputError naming ``key``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"expected a number, got {value!r}", key) from None
    if not math.isfinite(v):
        raise InputError(f"must be a finite number, got {v}", key)
    if v <= 0.0:
        raise InputError(f"must be positive, got {v:g}", key)
    return v


def finite_vector(value, key: str, length: int = 3) -> np.ndarray:
    """``value`` as a finite float array of shape (length,), or an InputError naming ``key``."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"expected {length} numbers, got {value!r}", key) from None
    if arr.shape != (length,):
        raise InputError(f"expected {length} numbers, got {value!r}", key)
    if not np.all(np.isfinite(arr)):
        raise InputError(f"must be finite numbers, got {arr.tolist()}", key)
    return arr


def positive_vector(value, key: str) -> tuple:
    """``value`` as three finite floats > 0 (a tuple), or an InputError naming ``key`` or ``key[k]``."""
    return tuple(positive(v, f"{key}[{k}]") for k, v in enumerate(finite_vector(value, key)))


@dataclass(frozen=True)
class Sphere:
    """Solid sphere of ``radius`` (m), centred on its origin."""

    radius: float
    type_id = SHAPE_SPHERE

    def __post_init__(self):
        object.__setattr__(self, "radius", positive(self.radius, "radius"))


@dataclass(frozen=True)
class Box:
    """Solid box with full side lengths ``size`` (m) along x, y, z, centred on its origin."""

    size: tuple
    type_id = SHAPE_BOX

    def __post_init__(self):
        object.__setattr__(self, "size", positive_vector(self.size, "size"))

    @property
    def half_extents(self) -> np.ndarray:
        return 0.5 * np.asarray(self.size)


@dataclass(frozen=True)
class Cylinder:
    """Solid cylinder of ``radius`` and ``length`` (m) along z, centred on its origin."""

    radius: float
    length: float
    type_id = SHAPE_CYLINDER

    def __post_init__(self):
        object.__setattr__(self, "radius", positive(self.radius, "radius"))
        object.__setattr__(self, "length", positive(self.length, "length"))


@dataclass(frozen=True)
class Capsule:
    """Cylinder of ``length`` (m, between the two hemisphere centres) capped by hemispheres of ``radius``, along z, centred."""

    radius: float
    length: float
    type_id = SHAPE_CAPSULE

    def __post_init__(self):
        object.__setattr__(self, "radius", positive(self.radius, "radius"))
        object.__setattr__(self, "length", positive(self.length, "length"))


@dataclass(frozen=True)
class Cone:
    """Solid right circular cone: base disc of ``radius`` centred on the origin in the xy plane, apex at z = ``height``.

    Its centre of mass is at z = height / 4, so a body made of it is re-centred.
    """

    radius: float
    height: float
    type_id = SHAPE_CONE

    def __post_init__(self):
        object.__setattr__(self, "radius", positive(self.radius, "radius"))
        object.__setattr__(self, "height", positive(self.height, "height"))


@dataclass(frozen=True)
class Ellipsoid:
    """Solid ellipsoid with semi-axes ``radii`` (a, b, c) (m) along x, y, z, centred on its origin
    (MuJoCo's ``ellipsoid`` geom, whose ``size`` is the same three semi-axes):
    (x / a)^2 + (y / b)^2 + (z / c)^2 <= 1."""

    radii: tuple
    type_id = SHAPE_ELLIPSOID

    def __post_init__(self):
        object.__setattr__(self, "radii", positive_vector(self.radii, "radii"))


@dataclass(frozen=True)
class Plane:
    """Static half-space boundary ``normal . p = offset`` (normal made unit). Only for fixed bodies."""

    normal: tuple = (0.0, 0.0, 1.0)
    offset: float = 0.0
    type_id = SHAPE_PLANE

    def __post_init__(self):
        n = finite_vector(self.normal, "normal")
        length = float(np.linalg.norm(n))
        if length == 0.0:
            raise InputError("must not be the zero vector", "normal")
        off = float(self.offset)
        if not math.isfinite(off):
            raise InputError(f"must be a finite number, got {off}", "offset")
        object.__setattr__(self, "normal", tuple(float(c) for c in n / length))
        object.__setattr__(self, "offset", off)


@dataclass(frozen=True)
class Particles:
    """The course's discretised body: point masses ``masses`` (n,) kg at ``points`` (n, 3) m in the shape frame.

    Its centre of mass is wherever the points put it; the body is re-centred.
    """

    points: np.ndarray
    masses: np.ndarray
    type_id = SHAPE_PARTICLES

    def __post_init__(self):
        try:
            pts = np.asarray(self.points, dtype=float)
            m = np.asarray(self.masses, dtype=float)
        except (TypeError, ValueError):
            raise InputError("points and masses must be numbers", "points") from None
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) == 0:
            raise InputError(f"expected a non-empty list of [x, y, z] points, got shape {pts.shape}", "points")
        if m.ndim == 0:
            m = np.full(len(pts), float(m))
        if m.shape != (len(pts),):
            raise InputError(f"expected {len(pts)} masses (one per point), got {m.size}", "masses")
        if not (np.all(np.isfinite(pts))):
            raise InputError("must be finite numbers", "points")
        if not np.all(np.isfinite(m)) or np.any(m <= 0):
            raise InputError("every mass must be a positive finite number", "masses")
        pts.setflags(write=False)
        m.setflags(write=False)
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "masses", m)

    def __eq__(self, other):
        return isinstance(other, Particles) and np.array_equal(self.points, other.points) and np.array_equal(self.masses, other.masses)

    __hash__ = None


@dataclass(frozen=True, eq=False)
class Mesh:
    """Triangle mesh, from a file (OBJ, STL, PLY... through trimesh) or inline arrays: a closed solid,
    or with ``closed=False`` an open surface for a fixed or kinematic body.

    Args:
        path: mesh file; relative paths are resolved by the caller (the scene
            loader resolves them against the scene file's folder).
        vertices: (V, 3) m, shape frame.
        faces: (F, 3) vertex indices, counter-clockwise seen from outside.
        closed: True (default): the mesh must be closed (watertight) and is a solid, with a volume,
            a mass and an inside. False: any triangle surface (a terrain sheet, a ramp, a chute, a
            hollow shell to hold bodies inside): two-sided, each triangle solid on neither side and
            pushing a shape back to the side its centre is on (Bullet's triangle meshes, PhysX's
            double-sided meshes), its winding free; only on a fixed or kinematic body, with no mass.
    """

    path: str | None = None
    vertices: np.ndarray | None = None
    faces: np.ndarray | None = None
    type_id = SHAPE_MESH
    _mesh: object = field(default=None, repr=False, compare=False)
    closed: bool = True

    def __post_init__(self):
        from .mass import load_closed_mesh, load_open_mesh  # trimesh is imported only when a mesh is used

        if not isinstance(self.closed, (bool, np.bool_)):
            raise InputError(f"expected true or false, got {self.closed!r}", "closed")
        object.__setattr__(self, "closed", bool(self.closed))
        mesh = (load_closed_mesh if self.closed else load_open_mesh)(self.path, self.vertices, self.faces)
        object.__setattr__(self, "_mesh", mesh)
        object.__setattr__(self, "vertices", np.asarray(mesh.vertices, dtype=float))
        object.__setattr__(self, "faces", np.asarray(mesh.faces, dtype=np.int64))

    @property
    def trimesh(self):
        """The validated ``trimesh.Trimesh`` (closed and wound outward; with ``closed=False``, the
        surface as given, duplicate vertices merged, zero-area triangles dropped)."""
        return self._mesh


@dataclass(frozen=True, eq=False)
class Convex(Mesh):
    """Convex hull of ``points`` (n, 3) m, or of a mesh file's vertices."""

    points: np.ndarray | None = None
    type_id = SHAPE_CONVEX

    def __post_init__(self):
        from .mass import convex_hull_mesh

        if self.closed is not True:
            raise InputError("a convex hull is always closed", "closed")

        mesh = convex_hull_mesh(self.path, self.points if self.points is not None else self.vertices)
        object.__setattr__(self, "_mesh", mesh)
        object.__setattr__(self, "vertices", np.asarray(mesh.vertices, dtype=float))
        object.__setattr__(self, "faces", np.asarray(mesh.faces, dtype=np.int64))


@dataclass(frozen=True, eq=False)
class Compound:
    """Several shapes rigidly joined in one body (a chair, a dumbbell, a concave object cut into convex pieces).

    Args:
        parts: sequence of ``(shape, position, orientation)``: a shape record
            (not a Plane or Particles; a Compound is flattened), its origin (3,) m
            and its orientation (4,) unit quaternion (w, x, y, z), both in the
            compound's frame; or ``(shape, position, orientation, material)``. A part
            may also be a mapping with keys ``shape`` (a record or its ``shape_to_dict``
            form), ``position`` (default 0), ``orientation`` (default identity) and
            ``material``, as scene files give it.
        A part's ``material`` (a ``tumble.Material`` or a mapping of its keys; friction,
        restitution and their combine modes; its body's ``margin``, not its own) is the one its contacts use (MuJoCo's per-geom friction, Box2D's per-shape
        material); a part without one takes the body's. Kept in ``materials`` (a tuple with one
        Material or None per part; None when no part has one).
        source: optional closed ``Mesh`` the parts were cut from (``tumble.decompose``: a concave
            mesh as convex pieces). Then the body's mass properties are the source's exact
            integrals (the pieces' hulls overlap and over-fill a concave solid: CoACD's pieces of
            a thin bowl hold 42 % more volume than the bowl), the pieces only collide, and exports
            and the viewer draw the source. A mapping with ``vertices`` and ``faces`` is read as a Mesh.

    Without a source the mass is spread by volume (uniform density): overlapping parts count twice.
    """

    parts: tuple
    materials: tuple | None = None
    source: Mesh | None = None
    type_id = SHAPE_COMPOUND

    def __post_init__(self):
        try:
            raw = list(self.parts)
        except TypeError:
            raise InputError(f"expected a list of (shape, position, orientation), got {self.parts!r}", "parts") from None
        if not raw:
            raise InputError("a compound needs at least one part", "parts")
        parts = []
        given = list(self.materials) if self.materials is not None else [None] * len(raw)
        if len(given) != len(raw):
            raise InputError(f"expected one material (or None) per part, got {len(given)} for {len(raw)} parts", "materials")
        for k, part in enumerate(raw):
            key = f"parts[{k}]"
            if isinstance(part, dict):
                unknown = set(part) - {"shape", "position", "orientation", "material"}
                if unknown or "shape" not in part:
                    raise InputError("a part has keys shape, position, orientation, material", key)
                shape = part["shape"]
                position = part.get("position", (0.0, 0.0, 0.0))
                orientation = part.get("orientation", (1.0, 0.0, 0.0, 0.0))
                if part.get("material") is not None:
                    given[k] = part["material"]
            else:
                try:
                    if len(part) == 4:
                        shape, position, orientation, material = part
                        if material is not None:
                            given[k] = material
                    else:
                        shape, position, orientation = part
                except (TypeError, ValueError):
                    raise InputError("expected (shape, position, orientation)", key) from None
            if isinstance(shape, dict):
                shape = shape_from_dict(shape)
            if isinstance(shape, (Plane, Particles)) or not hasattr(shape, "type_id"):
                raise InputError(f"a part must be a solid shape record, got {type(shape).__name__}", key)
            pos = finite_vector(position, f"{key}.position")
            q = finite_vector(orientation, f"{key}.orientation", 4)
            length = float(np.linalg.norm(q))
            if length == 0.0:
                raise InputError("must not be the zero quaternion", f"{key}.orientation")
            pos.setflags(write=False)
            parts.append((shape, pos, tuple(float(c) for c in q / length)))
        object.__setattr__(self, "parts", tuple(parts))
        from .material import Material  # here: material.py is below shapes.py in the imports

        materials = []
        for k, m in enumerate(given):
            try:
                materials.append(None if m is None else Material.coerce(m))
            except InputError as err:
                raise err.within(f"parts[{k}].material") from None
            if materials[-1] is not None and materials[-1].margin:  # the margin is a body's (Material.margin)
                raise InputError("a part has no margin of its own: set it on the body's material",
                                 f"parts[{k}].material.margin")
        object.__setattr__(self, "materials", tuple(materials) if any(m is not None for m in materials) else None)
        if self.source is not None:
            source = self.source
            if isinstance(source, dict):
                unknown = set(source) - {"type", "vertices", "faces"}
                if unknown or source.get("type", "mesh") != "mesh" or "vertices" not in source or "faces" not in source:
                    raise InputError("expected a Mesh or a mapping with keys vertices and faces", "source")
                source = Mesh(vertices=np.asarray(source["vertices"], dtype=float), faces=np.asarray(source["faces"]))
            if type(source) is not Mesh:
                raise InputError(f"expected a closed Mesh, got {type(source).__name__}", "source")
            object.__setattr__(self, "source", source)


SHAPE_TYPES = {
    "sphere": Sphere,
    "box": Box,
    "cylinder": Cylinder,
    "capsule": Capsule,
    "cone": Cone,
    "ellipsoid": Ellipsoid,
    "plane": Plane,
    "particles": Particles,
    "mesh": Mesh,
    "convex": Convex,
    "compound": Compound,
}


def shape_to_dict(shape) -> dict:
    """A JSON-ready description of a shape record: ``{"type": ..., its parameters}``.

    Meshes and convex hulls carry their (cleaned) vertices and faces inline, so
    a trajectory file alone is enough to draw and export every body.
    """
    for name, cls in SHAPE_TYPES.items():
        if type(shape) is cls:
            kind = name
            break
    else:
        raise InputError(f"not a shape record: {shape!r}", "shape")
    if kind in ("mesh", "convex"):
        out = {"type": kind, "vertices": np.asarray(shape.vertices).tolist(), "faces": np.asarray(shape.faces).tolist()}
        if not shape.closed:
            out["closed"] = False  # only when open: a closed mesh's description is as it always was
        return out
    if kind == "particles":
        return {"type": kind, "points": shape.points.tolist(), "masses": shape.masses.tolist()}
    if kind == "compound":
        materials = shape.materials or (None,) * len(shape.parts)
        out = {"type": kind, "parts": [{"shape": shape_to_dict(part), "position": pos.tolist(), "orientation": list(q),
                                        **({} if m is None else {"material": m.to_dict()})}
                                       for (part, pos, q), m in zip(shape.parts, materials)]}
        if shape.source is not None:
            out["source"] = shape_to_dict(shape.source)
        return out
    out = {"type": kind}
    for key in shape.__dataclass_fields__:
        if not key.startswith("_"):
            value = getattr(shape, key)
            out[key] = list(value) if isinstance(value, tuple) else value
    return out


def shape_from_dict(data: dict):
    """Inverse of ``shape_to_dict``."""
    data = dict(data)
    kind = data.pop("type")
    if kind == "convex":
        return Convex(points=np.asarray(data["vertices"], dtype=float))
    return SHAPE_TYPES[kind](**data)


def heightfield(heights, size, base: float = 0.5) -> Mesh:
    """A terrain from a grid of heights (MuJoCo's ``hfield``, PyBullet's and Box3D's heightfields), as
    a closed triangle ``Mesh`` for a fixed (or kinematic) body.

    Args:
        heights: (ny, nx) m, ny, nx >= 2: the surface's height over the grid point (x_j, y_i) of
            the shape frame, x_j = (j / (nx - 1) - 1/2) size[0], y_i = (i / (ny - 1) - 1/2) size[1]
            (row i along y, column j along x; the grid centred on the origin).
        size: (2,) m, the grid's full extent along x and y.
        base: m > 0, the solid's thickness below its lowest height (its sides and flat bottom close
            the surface into a solid, as MuJoCo's ``base_z``).

    Each grid cell is two triangles split along its diagonal from (i, j) to (i + 1, j + 1): the
    surface is exact at the grid points and linear on each triangle between them.
    """
    try:
        H = np.asarray(heights, dtype=float)
    except (TypeError, ValueError):
        raise InputError("expected a grid of numbers (rows along y)", "heights") from None
    if H.ndim != 2 or H.shape[0] < 2 or H.shape[1] < 2:
        raise InputError(f"expected at least 2 rows of at least 2 heights, got shape {H.shape}", "heights")
    if not np.all(np.isfinite(H)):
        raise InputError("heights must be finite numbers", "heights")
    check_coordinates(H, "heights", "heights")  # 1e308: the mesh's arithmetic would overflow (warnings, inf)
    sx, sy = (positive(v, "size") for v in finite_vector(size, "size", 2))
    check_coordinates((sx, sy), "size", "size")
    base = positive(base, "base")
    check_coordinates(base, "base", "base")
    ny, nx = H.shape
    xs = (np.arange(nx) / (nx - 1) - 0.5) * sx
    ys = (np.arange(ny) / (ny - 1) - 0.5) * sy
    X, Y = np.meshgrid(xs, ys)
    top = np.column_stack([X.ravel(), Y.ravel(), H.ravel()])  # vertex i * nx + j
    index = np.arange(ny * nx).reshape(ny, nx)
    a, b, c, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, 1:].ravel(), index[1:, :-1].ravel()
    faces = [np.column_stack([a, b, c]), np.column_stack([a, c, d])]  # counter-clockwise seen from above
    # the perimeter, counter-clockwise seen from above, and the same points at the bottom
    ring = np.concatenate([index[0, :-1], index[:-1, -1], index[-1, :0:-1], index[:0:-1, 0]])
    z0 = float(H.min()) - base
    bottom = top[ring].copy()
    bottom[:, 2] = z0
    nb = len(ring)
    first = ny * nx
    centre = first + nb
    below = first + np.arange(nb)
    after = np.roll(np.arange(nb), -1)
    # the sides: each perimeter edge (p, q) down to its bottom edge, facing outwards
    faces.append(np.column_stack([ring, below, ring[after]]))
    faces.append(np.column_stack([ring[after], below, below[after]]))
    # the bottom: a fan about its centre, facing down
    faces.append(np.column_stack([np.full(nb, centre), below[after], below]))
    vertices = np.vstack([top, bottom, [[0.0, 0.0, z0]]])
    return Mesh(vertices=vertices, faces=np.vstack(faces))
