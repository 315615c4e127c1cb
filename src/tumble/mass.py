"""Mass properties: the course's particle sums, closed forms for primitives, exact polyhedral integrals.

Reads a shape record (``tumble.shapes``) and a mass or a density; returns a
``MassProperties`` (mass, centre of mass, inertia about the centre of mass, shape axes).
Also validates and builds the closed triangle meshes that ``Mesh`` and ``Convex`` hold.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputError
from .math3d import mat_vec, rotate_tensor
from .shapes import Box, Capsule, Compound, Cone, Cylinder, Ellipsoid, Mesh, Particles, Plane, Sphere, check_coordinates


@dataclass(frozen=True, eq=False)
class MassProperties:
    """What the course calls ``mass`` and ``Ibody``, plus where the centre of mass sits in the shape.

    Attributes:
        mass: total mass, kg.
        center: (3,) centre of mass, shape frame, m. The body frame's origin
            goes there (DESIGN.md, conventions).
        inertia: (3, 3) inertia tensor about the centre of mass, along the shape
            axes, kg m^2. Symmetric positive definite (semi-definite for
            collinear particles).
    """

    mass: float
    center: np.ndarray
    inertia: np.ndarray

    def __post_init__(self):
        center = np.array(self.center, dtype=float).reshape(3)
        inertia = np.array(self.inertia, dtype=float).reshape(3, 3)
        with np.errstate(over="ignore", invalid="ignore"):  # huge input overflows to inf: the checks name it
            inertia = 0.5 * (inertia + inertia.T)  # exact symmetry; round-off only
        center.setflags(write=False)
        inertia.setflags(write=False)
        object.__setattr__(self, "mass", float(self.mass))
        object.__setattr__(self, "center", center)
        object.__setattr__(self, "inertia", inertia)

    def principal(self) -> tuple[np.ndarray, np.ndarray]:
        """Principal moments and axes of ``inertia``.

        Returns:
            moments: (3,) principal moments, ascending, kg m^2.
            axes: (3, 3) unit principal axes as columns, shape frame; a proper
                rotation (det = +1), so ``inertia = axes @ diag(moments) @ axes.T``.
        """
        moments, axes = np.linalg.eigh(self.inertia)
        if np.linalg.det(axes) < 0.0:
            axes = axes.copy()
            axes[:, 2] = -axes[:, 2]
        return moments, axes

    def __eq__(self, other):
        return (
            isinstance(other, MassProperties)
            and self.mass == other.mass
            and np.array_equal(self.center, other.center)
            and np.array_equal(self.inertia, other.inertia)
        )

    __hash__ = None


# ---------- input checks ----------


def _positive_amount(value, key: str) -> float:
    """A mass or density as a finite float > 0, or an InputError naming ``key``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"expected a number, got {value!r}", key) from None
    if not math.isfinite(v):
        raise InputError(f"must be positive and finite, got {v}", key)
    if v <= 0.0:
        raise InputError(f"must be positive, got {v:g}", key)
    return v


def _mass_or_density(mass, density) -> tuple[float | None, float | None]:
    if mass is not None and density is not None:
        raise InputError("give either mass or density, not both", "mass")
    if mass is None and density is None:
        raise InputError("give either mass or density", "mass")
    if mass is not None:
        return _positive_amount(mass, "mass"), None
    return None, _positive_amount(density, "density")


# ---------- mass properties ----------


def mass_properties(shape, mass=None, density=None) -> MassProperties:
    """Mass, centre of mass and inertia about the centre of mass of ``shape``.

    Args:
        shape: a record from ``tumble.shapes`` (not ``Plane``: a plane has no mass).
        mass: total mass, kg; or
        density: uniform density, kg/m^3. Solid shapes take exactly one of the two.
            ``Particles`` carry their own masses and take no density; if ``mass``
            is given they are all scaled by the same factor so that they add up
            to it (the centre of mass does not move, the inertia scales).

    Returns:
        MassProperties in the shape frame.

    Raises:
        InputError: key ``"mass"``, ``"density"`` or ``"shape"``.
    """
    if isinstance(shape, Plane):
        raise InputError("a plane has no mass: make it fixed", "shape")
    if isinstance(shape, Particles):
        if density is not None:
            raise InputError("particles carry their own masses: give no density (mass rescales them)", "density")
        masses = shape.masses
        if mass is not None:
            masses = masses * (_positive_amount(mass, "mass") / masses.sum())
        return particle_mass_properties(shape.points, masses)
    mass, density = _mass_or_density(mass, density)
    if isinstance(shape, Compound):
        if shape.source is not None:  # convex pieces of a concave mesh (tumble.decompose): the mesh's own integrals
            return _mesh_mass_properties(shape.source.trimesh, mass, density)
        return _compound_mass_properties(shape, mass, density)
    if isinstance(shape, Mesh):  # Convex is a Mesh
        if not shape.closed:
            raise InputError("an open mesh (closed = false) encloses no volume, so it has no mass: make its body fixed "
                             "or kinematic and give it no mass or density", "shape")
        return _mesh_mass_properties(shape.trimesh, mass, density)
    volume_of = {
        Sphere: lambda s: 4.0 / 3.0 * math.pi * s.radius**3,
        Box: lambda s: float(np.prod(s.size)),
        Cylinder: lambda s: math.pi * s.radius**2 * s.length,
        Capsule: lambda s: math.pi * s.radius**2 * (s.length + 4.0 / 3.0 * s.radius),
        Cone: lambda s: math.pi * s.radius**2 * s.height / 3.0,
        Ellipsoid: lambda s: 4.0 / 3.0 * math.pi * s.radii[0] * s.radii[1] * s.radii[2],
    }
    if type(shape) not in volume_of:
        raise InputError(f"cannot compute mass properties of {type(shape).__name__}", "shape")
    too_large = InputError("too large: the shape's mass properties (volume, inertia) overflow a float",
                           _dimension_key(shape))
    try:
        with np.errstate(over="ignore", invalid="ignore"):  # NumPy's overflow gives inf: checked below
            if mass is None:
                mass = density * volume_of[type(shape)](shape)
            props = _primitive_mass_properties(shape, mass)
    except OverflowError:  # Python's float power raises where NumPy would give inf (a 1e300 m radius)
        raise too_large from None
    if not (math.isfinite(props.mass) and np.all(np.isfinite(props.inertia)) and np.all(np.isfinite(props.center))):
        raise too_large  # a box of size 1e308: its moments are inf (was blamed on the body's inertia, a key not given)
    return props


def _dimension_key(shape) -> str:
    """``shape.KEY`` of the largest dimension of a primitive (``size`` of a box, ``radii`` of an
    ellipsoid, else ``radius``, ``length`` or ``height``): the key to blame when it is too large."""
    if isinstance(shape, Box):
        return "shape.size"
    if isinstance(shape, Ellipsoid):
        return "shape.radii"
    dims = {k: abs(float(getattr(shape, k))) for k in ("radius", "length", "height") if hasattr(shape, k)}
    return f"shape.{max(dims, key=dims.get)}" if dims else "shape"


def _primitive_mass_properties(shape, m: float) -> MassProperties:
    """Closed forms for a uniform solid of mass ``m``, about its centre of mass (any statics text)."""
    center = np.zeros(3)
    if isinstance(shape, Sphere):
        moments = np.full(3, 0.4 * m * shape.radius**2)
    elif isinstance(shape, Box):
        a, b, c = shape.size
        moments = m / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    elif isinstance(shape, Cylinder):
        r, h = shape.radius, shape.length
        ixx = m / 12.0 * (3.0 * r * r + h * h)
        moments = np.array([ixx, ixx, 0.5 * m * r * r])
    elif isinstance(shape, Capsule):
        moments = _capsule_moments(shape.radius, shape.length, m)
    elif isinstance(shape, Ellipsoid):  # the unit ball's m/5 (y^2 + z^2) ... with x, y, z scaled by a, b, c
        a, b, c = shape.radii
        moments = m / 5.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    else:  # Cone
        r, h = shape.radius, shape.height
        # the centroid of a cone is a quarter of the way up from the base
        center[2] = 0.25 * h
        ixx = 3.0 / 20.0 * m * r * r + 3.0 / 80.0 * m * h * h
        moments = np.array([ixx, ixx, 0.3 * m * r * r])
    return MassProperties(m, center, np.diag(moments))


def _quat_matrix(q) -> np.ndarray:
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def combine_mass_properties(terms) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass kg, centre (3,), inertia (3, 3) about that centre) of parts given as (mass, centre (3,),
    inertia (3, 3) about its own centre), all in one frame: the parallel-axis theorem. No parts (or
    no mass): (0.0, zeros, zeros). For robot links merged into one body (URDF fixed joints, MJCF
    geoms and welded bodies)."""
    mass, moment = 0.0, np.zeros(3)
    for m, c, _ in terms:
        mass += m
        moment += m * c
    if mass <= 0.0:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    center = moment / mass
    inertia = np.zeros((3, 3))
    for m, c, I in terms:
        d = c - center
        inertia += I + m * (_squared(d) * np.eye(3) - np.outer(d, d))
    return mass, center, inertia


# Products written without BLAS (math3d.mat_vec's note): the same mass properties, to the bit, on
# every machine.
def _squared(d) -> float:
    return float(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])


def _compound_mass_properties(shape, mass: float | None, density: float | None) -> MassProperties:
    """Sum of the parts at one uniform density (``mass`` given: spread by volume).

    Part i of mass m_i, centre c_i and inertia I_i (its own frame), placed at p_i
    with rotation R_i: centre C = sum m_i (p_i + R_i c_i) / M; inertia about C by
    the parallel axis theorem, sum R_i I_i R_i^T + m_i (|d_i|^2 1 - d_i d_i^T) with
    d_i = p_i + R_i c_i - C. Overlapping parts are counted twice.
    """
    unit = []
    for i, (part, pos, q) in enumerate(shape.parts):
        try:
            unit.append((mass_properties(part, density=1.0), pos, _quat_matrix(q)))
        except InputError as err:
            if not err.problem.startswith("too large"):
                raise
            raise InputError(f"part {i} is too large: its volume or inertia is past the float range", "parts") from None
    for i, (props, _, _) in enumerate(unit):
        # a huge part (a ball of 1e80 m, a mesh scaled by 1e51) has moments past the float range: inf, then
        # 0 x inf = NaN in the sums below (the URDF fuzz test found it)
        if not (math.isfinite(props.mass) and np.isfinite(props.inertia).all()):
            raise InputError(f"part {i} is too large: its volume or inertia is past the float range", "parts")
    volume = sum(props.mass for props, _, _ in unit)
    if not volume > 0.0:  # parts scaled by 1e-234 m have a volume of 0 in floating point (the fuzz test again)
        raise InputError("the parts are too small: their volume is 0 in floating point", "parts")
    if density is None:
        density = mass / volume
    masses = np.array([density * props.mass for props, _, _ in unit])
    centers = np.array([pos + mat_vec(R, np.asarray(props.center, dtype=float)) for props, pos, R in unit])
    total = float(masses.sum())
    moment = np.zeros(3)
    for m, c in zip(masses, centers):
        moment += m * c
    center = moment / total
    inertia = np.zeros((3, 3))
    for (props, _, R), m, c in zip(unit, masses, centers):
        d = c - center
        inertia += density * rotate_tensor(R, np.asarray(props.inertia, dtype=float)) + m * (
            _squared(d) * np.eye(3) - np.outer(d, d))
    return MassProperties(total, center, inertia)


def _capsule_moments(r: float, length: float, m: float) -> np.ndarray:
    """Principal moments (x, y, z) of a capsule of total mass ``m``: a cylinder of ``length`` plus two hemispheres.

    The mass splits by volume: cylinder pi r^2 L, each hemisphere 2/3 pi r^3.
    A hemisphere of mass mh about a diameter of its flat face has 2/5 mh r^2
    (half a sphere); its centroid is 3r/8 from that face, so about its centroid
    it has (2/5 - 9/64) mh r^2 = 83/320 mh r^2, and about the capsule centre,
    at d = L/2 + 3r/8, it has mh (83/320 r^2 + d^2) = mh (2/5 r^2 + L^2/4 + 3 L r/8).
    """
    v_cyl = math.pi * r * r * length
    v_hemi = 2.0 / 3.0 * math.pi * r**3
    m_cyl = m * v_cyl / (v_cyl + 2.0 * v_hemi)
    m_hemi = m * v_hemi / (v_cyl + 2.0 * v_hemi)
    ixx = m_cyl * (3.0 * r * r + length * length) / 12.0 + 2.0 * m_hemi * (
        0.4 * r * r + 0.25 * length * length + 0.375 * length * r
    )
    izz = 0.5 * m_cyl * r * r + 2.0 * 0.4 * m_hemi * r * r
    return np.array([ixx, ixx, izz])


def particle_mass_properties(points, masses) -> MassProperties:
    """The course's sums over a discretised body (Baraff 2001, "Mass of a body", "Inertia tensor"; ERRATA 2).

    M = sum m_i,  c = sum m_i r_i / M,
    I = sum m_i ((r'_i . r'_i) 1 - r'_i r'_i^T)  with r'_i = r_i - c.

    Args:
        points: (n, 3) particle positions r_i, shape frame, m.
        masses: (n,) particle masses m_i, kg.
    """
    r = np.asarray(points, dtype=float)
    m = np.asarray(masses, dtype=float)
    total = m.sum()
    center = (m[:, None] * r).sum(axis=0) / total
    rp = r - center
    # sum m_i (r'_i . r'_i) 1  minus  sum m_i r'_i r'_i^T, each sum over the particles
    # (the second sum element by element, not by ``@``: no BLAS, math3d.mat_vec's note)
    second = np.array([[np.sum(m * rp[:, i] * rp[:, j]) for j in range(3)] for i in range(3)])
    inertia = np.sum(m * np.sum(rp * rp, axis=1)) * np.eye(3) - second
    return MassProperties(total, center, inertia)


def _mesh_mass_properties(mesh, mass: float | None, density: float | None) -> MassProperties:
    """Exact volume integrals of a closed, outward-wound triangle mesh, done by trimesh.

    ``trimesh.triangles.mass_properties`` implements Eberly, "Polyhedral Mass
    Properties (Revisited)", Geometric Tools 2002 (the divergence-theorem
    reduction of Mirtich, "Fast and Accurate Computation of Polyhedral Mass
    Properties", JGT 1996): integrals of 1, x, y, z, x^2, ..., xy, ... over the
    solid as sums over faces, then the inertia shifted to the centre of mass
    (trimesh returns it about the centre of mass; tests/test_mass.py checks).
    """
    import trimesh

    # NOTE: that shift subtracts V c c^T from integrals taken about the origin,
    # which cancels digits when the mesh sits far from its origin. I integrate
    # about the bounding-box centre instead and add it back to the centre.
    origin = 0.5 * (mesh.bounds[0] + mesh.bounds[1])
    triangles = np.asarray(mesh.vertices, dtype=float)[np.asarray(mesh.faces)] - origin
    props = trimesh.triangles.mass_properties(triangles, density=1.0)
    volume = float(props.volume)
    if not volume > 0.0:
        raise InputError(f"mesh encloses no volume (volume = {volume:g} m^3)", "shape")
    rho = density if density is not None else mass / volume
    return MassProperties(rho * volume, np.asarray(props.center_mass) + origin, rho * np.asarray(props.inertia))


# ---------- the course's discretised body ----------


def particles_from_shape(shape, n: int, mass: float) -> Particles:
    """Discretise a Box, Sphere or Cylinder into equal-mass particles, as the course discretises a body.

    The bounding box is cut into n x n x n equal cells; each cell centre that
    lies in the solid (all of them for a box) becomes one particle, and the
    particles share ``mass`` equally. For the box this is the midpoint rule,
    whose inertia error is exactly a factor (1 - 1/n^2).

    Args:
        shape: ``Box``, ``Sphere`` or ``Cylinder``.
        n: cells along each axis of the bounding box, >= 1.
        mass: total mass, kg.

    Returns:
        Particles with points (k, 3) m in the shape frame and masses (k,) kg, k <= n^3.
    """
    mass = _positive_amount(mass, "mass")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InputError(f"must be a whole number >= 1, got {n!r}", "n")
    if isinstance(shape, Box):
        half = shape.half_extents
    elif isinstance(shape, Sphere):
        half = np.full(3, shape.radius)
    elif isinstance(shape, Cylinder):
        half = np.array([shape.radius, shape.radius, 0.5 * shape.length])
    else:
        raise InputError(f"can discretise a box, sphere or cylinder, not {type(shape).__name__}", "shape")
    axes = [-h + (np.arange(n) + 0.5) * (2.0 * h / n) for h in half]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    if isinstance(shape, Sphere):
        points = points[np.einsum("ij,ij->i", points, points) <= shape.radius**2]
    elif isinstance(shape, Cylinder):
        points = points[points[:, 0] ** 2 + points[:, 1] ** 2 <= shape.radius**2]
    if len(points) == 0:
        raise InputError(f"no cell centre falls inside the {type(shape).__name__.lower()}: use a larger n", "n")
    return Particles(points, np.full(len(points), mass / len(points)))


# ---------- meshes ----------


def _inline_arrays(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """Check inline mesh arrays: vertices (V, 3) finite floats, faces (F, 3) ints in [0, V)."""
    try:
        v = np.asarray(vertices, dtype=float)
    except (TypeError, ValueError):
        raise InputError("vertices must be numbers", "vertices") from None
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0:
        raise InputError(f"expected a non-empty (V, 3) array of vertices, got shape {v.shape}", "vertices")
    if not np.all(np.isfinite(v)):
        raise InputError("vertices must be finite numbers", "vertices")
    check_coordinates(v, "vertices", "vertices")
    whole = InputError("faces must be whole numbers (vertex indices)", "faces")
    try:
        f_raw = np.asarray(faces)
        if f_raw.dtype.kind not in "iu":
            f_raw = f_raw.astype(float)
    except (TypeError, ValueError):
        raise whole from None
    if f_raw.ndim != 2 or f_raw.shape[1] != 3 or len(f_raw) == 0:
        raise InputError(f"expected a non-empty (F, 3) array of triangles, got shape {f_raw.shape}", "faces")
    if f_raw.dtype.kind == "f" and not (np.all(np.isfinite(f_raw)) and np.array_equal(f_raw, np.round(f_raw))):
        raise whole
    f = f_raw.astype(np.int64)
    if f.min() < 0 or f.max() >= len(v):
        raise InputError(f"vertex indices must lie in [0, {len(v) - 1}], got {f.min()}..{f.max()}", "faces")
    return v, f


def _read_mesh_file(path):
    """``trimesh.load`` a mesh file, with InputErrors (key "path") for a missing or unreadable file."""
    import trimesh

    p = Path(path)
    if not p.is_file():
        raise InputError(f"mesh file not found: {path}", "path")
    try:
        # quiet: a file's absurd coordinates (1e308) overflow in trimesh's merging; checked just below
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore", RuntimeWarning)
            mesh = trimesh.load(str(p), force="mesh", process=True)
    except Exception as exc:  # trimesh raises many types for bad files
        # what is wrong with the file, when we can tell (an OBJ), rather than NumPy's words for it
        problem = _obj_problem(p) if p.suffix.lower() == ".obj" else None
        raise InputError(f"cannot read mesh file {path}: {problem or exc}", "path") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise InputError(f"mesh file holds no triangles: {path}", "path")
    check_coordinates(mesh.vertices, "path", f"mesh file {path}: vertex coordinates", rows=False)
    return mesh


def _obj_problem(path: Path) -> str | None:
    """The first problem of an OBJ file that trimesh could not read, as "line N: ..." (a vertex
    without three numbers, a face that is not numbers or has fewer than three corners, a face
    referring to a vertex the file does not have), or None when none of these is found."""
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return None
    vertex_count = sum(1 for line in lines if line.split("#", 1)[0].split()[:1] == ["v"])
    seen = 0  # vertices before this line: a negative index counts back from here
    for number, line in enumerate(lines, 1):
        words = line.split("#", 1)[0].split()
        if not words:
            continue
        if words[0] == "v":
            try:
                coordinates = [float(x) for x in words[1:]]
            except ValueError:
                return f"line {number}: cannot parse the vertex {' '.join(words)!r} (expected v x y z, numbers)"
            if len(coordinates) < 3:
                return f"line {number}: a vertex has {len(coordinates)} coordinates, expected 3"
            seen += 1
        elif words[0] == "f":
            if len(words) < 4:
                return f"line {number}: a face has {len(words) - 1} corners, expected at least 3"
            for corner in words[1:]:
                try:
                    index = int(corner.split("/", 1)[0])
                except ValueError:
                    return f"line {number}: cannot parse the face corner {corner!r} (expected a vertex number)"
                k = index if index > 0 else seen + 1 + index
                if index == 0 or not 1 <= k <= vertex_count:
                    return f"line {number}: a face refers to vertex {index} of {vertex_count}"
    return None


def _mesh_source(path, vertices, faces):
    """(trimesh.Trimesh, key): a mesh file's or inline arrays' triangles, duplicate vertices merged;
    the key its problems are reported on ("path" or "vertices"). Shared by the closed and the open
    meshes' loaders."""
    import trimesh

    inline = vertices is not None or faces is not None
    if path is not None and inline:
        raise InputError("give either a mesh file path or inline vertices and faces, not both", "path")
    if path is None and not inline:
        raise InputError("give a mesh file path or inline vertices and faces", "path")
    if path is not None:
        key = "path"
        mesh = _read_mesh_file(path)
    else:
        key = "vertices"
        if vertices is None:
            raise InputError("faces were given without vertices", "vertices")
        if faces is None:
            raise InputError("vertices were given without faces", "faces")
        v, f = _inline_arrays(vertices, faces)
        mesh = trimesh.Trimesh(vertices=v, faces=f, process=True)
        if len(mesh.faces) == 0:
            raise InputError("mesh has no non-degenerate triangles", "faces")
    return mesh, key


def load_closed_mesh(path=None, vertices=None, faces=None):
    """A closed, consistently and outward wound triangle mesh from a file or inline arrays.

    Args:
        path: mesh file (OBJ, STL, PLY, ... anything ``trimesh.load`` reads); or
        vertices: (V, 3) vertex positions, shape frame, m; and
        faces: (F, 3) vertex indices per triangle.

    Returns:
        ``trimesh.Trimesh`` with duplicate vertices merged, every edge shared by
        exactly two faces, faces wound counter-clockwise seen from outside
        (repaired in place when they are not; see ``_orient_outward``) and volume > 0.

    Raises:
        InputError: key ``"path"`` for file problems, ``"vertices"``/``"faces"``
            for inline arrays (a mesh that is not closed or has no volume is
            reported on ``"path"`` or ``"vertices"``, whichever gave it).
    """
    mesh, key = _mesh_source(path, vertices, faces)
    _check_closed(mesh, key)
    if not _orient_outward(mesh):
        raise InputError("mesh faces cannot be wound consistently (non-orientable surface)", key)
    extent = float(np.max(mesh.extents))
    volume = float(_signed_volumes(mesh).sum())
    # NOTE: relative threshold: a closed mesh flattened to a sheet has volume ~ round-off * extent^3
    if not volume > 1e-12 * extent**3:
        raise InputError(f"mesh encloses no volume (volume = {volume:g} m^3)", key)
    return mesh


def load_open_mesh(path=None, vertices=None, faces=None):
    """A triangle surface that need not be closed (a terrain sheet, a ramp, a chute, a hollow shell),
    from a file or inline arrays, for ``Mesh(closed=False)``.

    Returns:
        ``trimesh.Trimesh`` with duplicate vertices merged and degenerate (zero-area) triangles
        dropped; its winding is kept as given (an open surface's two sides are both solid, so no
        side is "outward"; collision/geometry.py's edge flags do not depend on the winding).

    Raises:
        InputError: as ``load_closed_mesh`` for file and array problems; a surface left with no
            triangle of non-zero area ("mesh has no non-degenerate triangles").
    """
    mesh, key = _mesh_source(path, vertices, faces)
    # NOTE: relative threshold, as load_closed_mesh's volume: a sliver of round-off area is no triangle
    extent = float(np.max(mesh.extents)) if len(mesh.vertices) else 0.0
    keep = np.asarray(mesh.area_faces) > 1e-14 * extent**2
    if not np.all(keep):
        mesh.update_faces(keep)
        mesh.remove_unreferenced_vertices()
    if len(mesh.faces) == 0:
        raise InputError("mesh has no non-degenerate triangles", key)
    return mesh


def _signed_volumes(mesh, faces=None) -> np.ndarray:
    """(F,) signed volume of the tetrahedron from the bounding-box centre to each face, m^3."""
    origin = 0.5 * (mesh.bounds[0] + mesh.bounds[1])
    t = np.asarray(mesh.vertices, dtype=float)[np.asarray(mesh.faces if faces is None else faces)] - origin
    return np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])) / 6.0


def _orient_outward(mesh) -> bool:
    """Wind a closed mesh's faces consistently, each connected body outward; in place.

    Returns False if no consistent winding exists (a non-orientable surface).
    """
    # NOTE: trimesh.repair.fix_normals does this too, but needs networkx, which
    # tumble does not depend on. Two faces agree when they run their shared edge
    # in opposite directions; a breadth-first walk over the face adjacency
    # flips each face that disagrees with the (already fixed) face it came from.
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order, connected_components

    faces = np.asarray(mesh.faces, dtype=np.int64).copy()
    n = len(faces)
    pairs = np.asarray(mesh.face_adjacency, dtype=np.int64).reshape(-1, 2)
    u, v = np.asarray(mesh.face_adjacency_edges, dtype=np.int64).reshape(-1, 2).T

    def runs_u_to_v(face_ids):
        f = faces[face_ids]
        return np.any((f == u[:, None]) & (np.roll(f, -1, axis=1) == v[:, None]), axis=1)

    same_way = runs_u_to_v(pairs[:, 0]) == runs_u_to_v(pairs[:, 1])
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)).tocsr()
    count, labels = connected_components(graph, directed=False)
    flip = np.zeros(n, dtype=bool)
    if np.any(same_way):
        disagree = {}
        for (a, b), s in zip(pairs.tolist(), same_way.tolist()):
            disagree[(a, b)] = disagree[(b, a)] = s
        for root in np.unique(labels, return_index=True)[1]:
            order, parent = breadth_first_order(graph, root, directed=False, return_predecessors=True)
            for face in order[1:].tolist():
                flip[face] = flip[parent[face]] ^ disagree[(int(parent[face]), face)]
        if np.any(same_way ^ flip[pairs[:, 0]] ^ flip[pairs[:, 1]]):
            return False  # some edge disagrees whichever way we turn: non-orientable
        faces[flip] = faces[flip, ::-1]
    # a body whose faces enclose negative volume is inside out: turn it
    body_volume = np.bincount(labels, _signed_volumes(mesh, faces), minlength=count)
    inverted = (body_volume < 0.0)[labels]
    faces[inverted] = faces[inverted, ::-1]
    if np.any(flip) or np.any(inverted):
        mesh.faces = faces
    return True


def _check_closed(mesh, key: str) -> None:
    """Every edge must be shared by exactly two faces (watertight)."""
    import trimesh

    if mesh.is_watertight:
        return
    edges = mesh.edges_sorted
    boundary = len(trimesh.grouping.group_rows(edges, require_count=1))
    if boundary:
        raise InputError(f"mesh is not closed (watertight): {boundary} boundary edges (an open surface on a fixed "
                         "body: closed = false)", key)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    shared = int(np.sum(counts > 2))
    raise InputError(f"mesh is not closed (watertight): {shared} edges shared by more than two faces", key)


def convex_hull_mesh(path=None, points=None):
    """The convex hull of ``points`` or of a mesh file's vertices, as a closed outward-wound mesh.

    Args:
        path: mesh file whose vertices are hulled (it need not be closed); or
        points: (n, 3) points, shape frame, m.

    Returns:
        ``trimesh.Trimesh`` of the hull (scipy Qhull through trimesh), volume > 0.

    Raises:
        InputError: key ``"path"`` or ``"points"``.
    """
    import trimesh

    if path is not None and points is not None:
        raise InputError("give either a mesh file path or points, not both", "path")
    if path is None and points is None:
        raise InputError("give a mesh file path or points", "points")
    if path is not None:
        pts = np.asarray(_read_mesh_file(path).vertices, dtype=float)
    else:
        try:
            pts = np.asarray(points, dtype=float)
        except (TypeError, ValueError):
            raise InputError("points must be numbers", "points") from None
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise InputError(f"expected a list of [x, y, z] points, got shape {pts.shape}", "points")
        if not np.all(np.isfinite(pts)):
            raise InputError("points must be finite numbers", "points")
        check_coordinates(pts, "points", "points")
    degenerate = InputError("convex hull needs at least 4 points not all in one plane", "points")
    if len(pts) < 4:
        raise degenerate
    # the smallest singular value of the centred cloud measures its thickness
    sv = np.linalg.svd(pts - pts.mean(axis=0), compute_uv=False)
    if not sv[2] > 1e-10 * sv[0]:
        raise degenerate
    try:
        hull = trimesh.convex.convex_hull(pts)
    except Exception:  # scipy QhullError on nearly flat input
        raise degenerate from None
    if not (hull.is_watertight and hull.volume > 0.0):
        raise degenerate
    return hull


def box_mesh(size) -> tuple[np.ndarray, np.ndarray]:
    """A closed, outward-wound box mesh centred on the origin.

    Args:
        size: (3,) full side lengths along x, y, z, m.

    Returns:
        vertices: (8, 3) corners, m.
        faces: (12, 3) vertex indices, counter-clockwise seen from outside.
    """
    import trimesh

    box = Box(size)  # validates the sizes
    mesh = trimesh.creation.box(extents=box.size)
    return np.asarray(mesh.vertices, dtype=float).copy(), np.asarray(mesh.faces, dtype=np.int64).copy()
