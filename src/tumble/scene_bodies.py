"""Scene files: the ``[[bodies]]`` entries (shape, mass or density, inertia, pose, velocities,
material) and the ``[[forces]]`` entries, each added to the ``World`` as it is read.

A shape is one of ``SHAPE_KEYS``' types; a compound's parts are solid convex shapes
(``PART_TYPES``); a mesh or hull may come from a file, resolved against the scene's folder and
checked against ``checks.memory_limit()`` before it is read. Bodies are referred to by name.
Errors are ``InputError`` lines ``FILE: bodies[2].shape.radius: must be positive, got -1``
(``scene_values.ValueReader``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from . import checks
from .errors import InputError
from .forces import Buoyancy, ConstantForce, Drag, Explosion, Fluid, Impulse, PointForce, Spring, Switch, Wind
from .math3d import quat_from_euler_deg
from .scene_values import ValueReader, _describe
from .shapes import (
    Box,
    Capsule,
    Compound,
    Cone,
    Ellipsoid,
    Convex,
    Cylinder,
    Mesh,
    Particles,
    Plane,
    Sphere,
    heightfield,
)
from .collision.filter import FILTER_KEYS, CollisionFilter
from .material import COMBINE_MODES, MATERIAL_KEYS, Material
from .world import World

BODY_KEYS = (
    "name", "shape", "mass", "density", "inertia", "fixed", "kinematic", "position", "orientation", "euler_deg",
    "velocity", "angular_velocity", "angular_velocity_frame", "material", "collision_filter", "path",
    "surface_velocity", "sensor", "drop", "fracture", "enabled", "enable_at", "disable_at", "gravity_scale",
    "linear_damping", "angular_damping",
)
# fracture = {pieces, seed, strength, min_face}: the body as Voronoi cells glued by breakable joints (tumble.fracturing)
FRACTURE_KEYS = ("pieces", "seed", "strength", "min_face")
FRACTURE_SHAPES = (Box, Convex, Sphere, Capsule, Cylinder, Cone, Ellipsoid)
# path = {times, positions, orientations or euler_deg, repeat, release}: a kinematic body's keyframes (tumble.kinematic)
PATH_KEYS = ("times", "positions", "orientations", "euler_deg", "repeat", "release")
# collision_filter = {category, mask, group}: which bodies this one touches (collision/filter.py)
# Per shape type: (required keys, optional keys).
SHAPE_KEYS = {
    "sphere": (("radius",), ()),
    "box": (("size",), ()),
    "capsule": (("radius", "length"), ()),
    "cylinder": (("radius", "length"), ()),
    "cone": (("radius", "height"), ()),
    "ellipsoid": (("radii",), ()),
    "plane": ((), ("normal", "offset")),
    "mesh": ((), ("path", "vertices", "faces", "closed", "decompose")),
    "convex": ((), ("path", "points")),
    "particles": (("points", "masses"), ()),
    "compound": (("parts",), ()),
    "heightfield": (("size",), ("heights", "path", "base")),
}
# decompose = true or {threshold, max_parts, max_hull_vertices, seed}: a moving concave mesh as convex pieces
DECOMPOSE_KEYS = ("threshold", "max_parts", "max_hull_vertices", "seed")
# A compound's parts: solid convex shapes only (no plane, mesh, particles, nor another compound).
PART_KEYS = ("shape", "position", "orientation", "euler_deg", "material")
PART_TYPES = ("sphere", "box", "capsule", "cylinder", "cone", "ellipsoid", "convex")
# Per force type: (required keys, optional keys), besides "type".
FORCE_KEYS = {
    "drag": ((), ("linear", "quadratic", "angular_linear", "angular_quadratic", "wind", "bodies")),
    "wind": (("velocity",), ("linear", "quadratic", "bodies")),
    "constant": (("body",), ("force", "torque")),
    "point": (("body", "force", "point"), ("frame",)),
    "spring": (("body_a", "stiffness"), ("body_b", "anchor_a", "anchor_b", "damping", "rest_length")),
    "impulse": (("body", "impulse"), ("point", "time")),
    "explosion": (("position", "radius", "impulse_per_area"), ("falloff", "time", "mask", "shaded")),
    "fluid": ((), ("density", "viscosity", "wind", "bodies")),
    "buoyancy": ((), ("density", "level", "linear", "quadratic", "angular_linear", "angular_quadratic", "flow",
                      "bodies")),
}


class BodyReader(ValueReader):
    """``ValueReader`` and the entries that build bodies and forces."""

    def body(self, world: World, b: dict, key: str, names: dict):
        self.table(b, key, BODY_KEYS, required=("name", "shape"))
        name = self.string(b["name"], f"{key}.name")
        if not name:
            raise self.error("must not be empty", f"{key}.name")
        if name in names:
            raise self.error(f"duplicate body name {name!r} (also bodies[{names[name]}])", f"{key}.name")
        shape = self.shape(b["shape"], f"{key}.shape")

        kw: dict[str, Any] = {"name": name}
        fixed = self.boolean(b["fixed"], f"{key}.fixed") if "fixed" in b else False
        kw["fixed"] = fixed
        kinematic = self.boolean(b["kinematic"], f"{key}.kinematic") if "kinematic" in b else False
        if "sensor" in b:
            kw["sensor"] = self.boolean(b["sensor"], f"{key}.sensor")  # a sensor plane: add_body's error
        if kinematic:
            if fixed:
                raise self.error("a body is fixed or kinematic, not both", f"{key}.kinematic")
            if isinstance(shape, Plane):
                raise self.error("a plane can only be a fixed body (set fixed = true)", f"{key}.kinematic")
            kw["kinematic"] = True
        if "mass" in b and "density" in b:
            raise self.error("give either mass or density, not both", f"{key}.density")
        if "mass" in b:
            kw["mass"] = self.positive(b["mass"], f"{key}.mass")
        if "density" in b:
            kw["density"] = self.positive(b["density"], f"{key}.density")
        if isinstance(shape, Plane):
            if not fixed:
                raise self.error("a plane can only be a fixed body (set fixed = true)", f"{key}.fixed")
            for k in ("mass", "density", "inertia"):
                if k in b:
                    raise self.error("a plane has no mass properties (it is fixed)", f"{key}.{k}")
        elif isinstance(shape, Particles):
            if "density" in b:
                raise self.error("particles carry their own masses: give no density (mass rescales them)", f"{key}.density")
        elif not (fixed or kinematic) and "mass" not in b and "density" not in b:
            raise self.error("missing key 'mass' (or 'density')", key)
        if "inertia" in b:
            kw["inertia"] = self.inertia(b["inertia"], f"{key}.inertia")
        if "gravity_scale" in b:
            kw["gravity_scale"] = self.number(b["gravity_scale"], f"{key}.gravity_scale")
        for k in ("linear_damping", "angular_damping"):
            if k in b:
                kw[k] = self.nonnegative(b[k], f"{key}.{k}")
        for k in ("position", "velocity", "angular_velocity", "euler_deg", "surface_velocity"):
            if k in b:
                kw[k] = self.vector(b[k], f"{key}.{k}")
        if "orientation" in b:
            if "euler_deg" in b:
                raise self.error("give orientation or euler_deg, not both", f"{key}.euler_deg")
            q = self.vector(b["orientation"], f"{key}.orientation", 4)
            if all(c == 0 for c in q):
                raise self.error("quaternion must not be zero (w, x, y, z = 0, 0, 0, 0)", f"{key}.orientation")
            kw["orientation"] = q
        if "angular_velocity_frame" in b:
            kw["angular_velocity_frame"] = self.string(b["angular_velocity_frame"], f"{key}.angular_velocity_frame", ("world", "body"))
        if "material" in b:
            kw["material"] = self.material(b["material"], f"{key}.material")
        if "collision_filter" in b:
            f = self.table(b["collision_filter"], f"{key}.collision_filter", FILTER_KEYS)
            kw["collision_filter"] = self.library(f"{key}.collision_filter", CollisionFilter, **f)
        path = None
        if "path" in b:
            path = self.table(b["path"], f"{key}.path", PATH_KEYS, required=("times", "positions"))
            if not kinematic:
                raise self.error("a path moves a kinematic body: set kinematic = true", f"{key}.path")
            for k in ("position", "orientation", "euler_deg", "velocity", "angular_velocity"):
                if k in b:
                    raise self.error("a body on a path starts at the path's pose and moves at its velocity: "
                                     "give no position, orientation or velocity", f"{key}.{k}")
            for k in ("repeat", "release"):
                if k in path:
                    path[k] = self.boolean(path[k], f"{key}.path.{k}")
        switches = self.switches(b, key, shape)
        if switches and "enabled" not in b:
            kw["enabled"] = not switches[0][1]  # the first switch an enable: the body appears then
        elif "enabled" in b:
            kw["enabled"] = self.boolean(b["enabled"], f"{key}.enabled")
        drop = self.boolean(b["drop"], f"{key}.drop") if "drop" in b else False
        if drop and path is not None:
            raise self.error("a body on a path starts at the path's pose: it cannot be dropped", f"{key}.drop")
        if "fracture" in b:
            if "enabled" in kw:
                raise self.error("a fractured body's cells cannot be disabled or switched (give no enabled, "
                                 "enable_at or disable_at)", f"{key}.fracture")
            self.fractured(world, b, shape, kw, key, names, drop)
            return
        body = self.library(key, world.add_body, shape, **kw)
        for time, on, where in switches:
            self.library(where, world.add_force, Switch(body, enabled=on, time=time))
        if drop:
            # dropped once every body and robot is in the world, in the file's order (scene.py)
            self.drops.append((name, key))
        if path is not None:
            from .kinematic import KeyframePath

            self.library(f"{key}.path", lambda: world.add_path(KeyframePath(body, **path)))
        names[name] = len(names)

    def switches(self, b: dict, key: str, shape) -> list:
        """[(time s, enabled, key)] from a body's ``enable_at`` and ``disable_at`` (a number of
        seconds or a list of them: ``Switch`` records), in time order; a time in both is refused."""
        out = []
        for name, on in (("enable_at", True), ("disable_at", False)):
            if name not in b:
                continue
            where = f"{key}.{name}"
            values = b[name] if isinstance(b[name], list) else [b[name]]
            if not values:
                raise self.error("expected a time in s or a list of them, got an empty list", where)
            out += [(self.nonnegative(v, where), on, where) for v in values]
        if out and isinstance(shape, Plane):
            raise self.error("a plane cannot be disabled (it is the ground of everything)", out[0][2])
        out.sort(key=lambda r: (r[0], r[1]))
        for (t0, _, _), (t1, _, where) in zip(out, out[1:]):
            if t0 == t1:
                raise self.error(f"two switches at t = {t1:g} s", where)
        return out

    def fractured(self, world: World, b: dict, shape, kw: dict, key: str, names: dict, drop: bool):
        """A body with ``fracture = {...}``: its shape cut into cells, each a body ``NAME/k``, glued
        (``World.add_fractured``)."""
        from .fracturing import MIN_FACE, cell_names, fracture

        where = f"{key}.fracture"
        f = self.table(b["fracture"], where, FRACTURE_KEYS)
        if kw.get("fixed") or kw.get("kinematic") or kw.get("sensor") or "path" in b or drop:
            raise self.error("only a dynamic body can be fractured (not fixed, kinematic, a sensor, on a path "
                             "or dropped)", where)
        if not isinstance(shape, FRACTURE_SHAPES):
            raise self.error(f"cannot fracture a {type(shape).__name__.lower()} shape: a box, convex, sphere, "
                             "capsule, cylinder, cone or ellipsoid", where)
        if "inertia" in b:
            raise self.error("the cells' inertias come from their shapes: give no inertia", f"{key}.inertia")
        pieces = self.integer(f["pieces"], f"{where}.pieces", 2) if "pieces" in f else 16
        seed = self.integer(f["seed"], f"{where}.seed", 0) if "seed" in f else 0
        strength = self.positive(f["strength"], f"{where}.strength") if "strength" in f else float("inf")
        min_face = self.nonnegative(f["min_face"], f"{where}.min_face") if "min_face" in f else MIN_FACE
        try:
            cells = fracture(shape, pieces, seed)
        except InputError as err:
            # the shape's own keys (shape.size: too large to cut) are the body's; the scene gives no points, so
            # a cell that cannot be cut is the fracture table's (its pieces, its seed)
            if err.key and err.key.startswith("shape"):
                raise InputError(err.problem, f"{key}.{err.key}", self.file) from None
            raise InputError(err.problem, where if err.key == "points" else f"{where}.{err.key}", self.file) from None
        name = kw.pop("name")
        density = kw.pop("density") if "density" in kw else kw.pop("mass") / float(cells.volume.sum())
        kw.pop("fixed", None)
        taken = cell_names(name, len(cells))
        for piece in taken:
            if piece in names:
                raise self.error(f"a cell's name {piece!r} is taken (bodies[{names[piece]}])", f"{key}.name")
        self.library(key, world.add_fractured, cells, density=density, strength=strength, min_face=min_face, name=name,
                     **kw)
        for piece in taken:
            names[piece] = len(names)

    def inertia(self, value, key: str):
        self.where = key
        if isinstance(value, list) and len(value) == 3 and all(isinstance(r, list) for r in value):
            return self.rows(value, key, 3)
        if isinstance(value, list) and len(value) == 3:
            return self.vector(value, key, 3, self.positive)
        raise self.error(f"expected 3 numbers (the diagonal) or a 3x3 matrix, got {_describe(value)}", key)

    def shape(self, value, key: str):
        self.where = key
        if not isinstance(value, dict):
            raise self.error(f"expected a table with a 'type' key, got {_describe(value)}", key)
        if "type" not in value:
            raise self.error("missing key 'type'", key)
        kind = self.string(value["type"], f"{key}.type")
        if kind not in SHAPE_KEYS:
            raise self.error(f"unknown shape type {kind!r} (expected one of {', '.join(SHAPE_KEYS)})", f"{key}.type")
        required, optional = SHAPE_KEYS[kind]
        s = self.table(value, key, ("type",) + required + optional, required)
        g = lambda k: f"{key}.{k}"  # noqa: E731
        if kind == "sphere":
            return self.library(key, Sphere, self.positive(s["radius"], g("radius")))
        if kind == "box":
            return self.library(key, Box, self.vector(s["size"], g("size"), 3, self.positive))
        if kind in ("capsule", "cylinder"):
            cls = Capsule if kind == "capsule" else Cylinder
            return self.library(key, cls, self.positive(s["radius"], g("radius")), self.positive(s["length"], g("length")))
        if kind == "cone":
            return self.library(key, Cone, self.positive(s["radius"], g("radius")), self.positive(s["height"], g("height")))
        if kind == "ellipsoid":
            return self.library(key, Ellipsoid, self.vector(s["radii"], g("radii"), 3, self.positive))
        if kind == "plane":
            normal = self.vector(s.get("normal", [0.0, 0.0, 1.0]), g("normal"))
            if all(c == 0 for c in normal):
                raise self.error("must not be the zero vector", g("normal"))
            return self.library(key, Plane, normal, self.number(s.get("offset", 0.0), g("offset")))
        if kind == "particles":
            points = self.rows(s["points"], g("points"), 3)
            masses = s["masses"]
            if isinstance(masses, list):
                if len(masses) != len(points):
                    raise self.error(f"expected {len(points)} masses (one per point), got {len(masses)}", g("masses"))
                masses = [self.positive(m, f"{g('masses')}[{i}]") for i, m in enumerate(masses)]
            else:
                masses = self.positive(masses, g("masses"))
            return self.library(key, Particles, points, masses)
        if kind == "mesh":
            # closed = false: an open, two-sided surface for a fixed or kinematic body (shapes.Mesh)
            closed = self.boolean(s["closed"], g("closed")) if "closed" in s else True
            if "path" in s:
                if "vertices" in s or "faces" in s:
                    raise self.error("give either a mesh file path or inline vertices and faces, not both", g("path"))
                mesh = self.library(key, Mesh, path=self.mesh_path(s["path"], g("path")), closed=closed)
            else:
                if "vertices" not in s or "faces" not in s:
                    missing = "vertices" if "vertices" not in s else "faces"
                    raise self.error(f"missing key {missing!r} (give a mesh file 'path', or 'vertices' and 'faces')", key)
                vertices = self.rows(s["vertices"], g("vertices"), 3)
                faces = self.rows(s["faces"], g("faces"), 3, lambda v, k: self.integer(v, k, 0))
                mesh = self.library(key, Mesh, vertices=vertices, faces=faces, closed=closed)
            return self.decomposed(mesh, s["decompose"], g("decompose")) if "decompose" in s else mesh
        if kind == "compound":
            return self.compound(s["parts"], g("parts"), key)
        if kind == "heightfield":
            return self.heightfield(s, key)
        # convex
        if "path" in s:
            if "points" in s:
                raise self.error("give either a mesh file path or points, not both", g("path"))
            return self.library(key, Convex, path=self.mesh_path(s["path"], g("path")))
        if "points" not in s:
            raise self.error("missing key 'points' (or a mesh file 'path')", key)
        return self.library(key, Convex, points=self.rows(s["points"], g("points"), 3))

    def decomposed(self, mesh, value, key: str):
        """``decompose = true`` (CoACD's defaults) or ``{threshold, max_parts, max_hull_vertices, seed}``:
        the mesh as a compound of convex pieces (``tumble.decompose``), so that it can move; false
        keeps the mesh (a fixed or kinematic body's)."""
        from .decomposition import decompose

        if isinstance(value, bool) and not value:
            return mesh
        options = {} if value is True else self.table(value, key, DECOMPOSE_KEYS,
                                                      what="true, false or a table of decomposition settings")
        kw = {"threshold": self.number(options["threshold"], f"{key}.threshold")} if "threshold" in options else {}
        for k in ("max_parts", "max_hull_vertices", "seed"):
            if k in options:
                kw[k] = self.integer(options[k], f"{key}.{k}", 0)
        try:
            return decompose(mesh, **kw)
        except InputError as err:  # keyed by decompose's keyword: the scene's key is KEY.keyword
            raise (err.within(key, self.file) if err.key != "mesh" else InputError(err.problem, key, self.file)) from None

    def heightfield(self, s: dict, key: str):
        """``heights`` = [[...], ...] (rows along y) or ``path`` = a .npy file of them, ``size`` = [sx, sy],
        ``base`` (tumble.shapes.heightfield)."""
        g = lambda k: f"{key}.{k}"  # noqa: E731
        if ("heights" in s) == ("path" in s):
            raise self.error("give either heights (rows of numbers) or a .npy file path, not both" if "path" in s
                             else "missing key 'heights' (rows of heights, or a .npy file 'path')", key)
        if "path" in s:
            path = self.data_path(s["path"], g("path"), "heights")
            try:
                import numpy as np

                heights = np.load(path, allow_pickle=False)
            except (OSError, ValueError) as exc:
                raise self.error(f"cannot read heights from {Path(path).name}: {exc}", g("path")) from None
        else:
            rows = s["heights"]
            if not isinstance(rows, list) or not rows or not all(isinstance(r, list) for r in rows):
                raise self.error(f"expected rows of heights, got {_describe(rows)}", g("heights"))
            heights = [[self.number(v, f"{g('heights')}[{i}][{j}]") for j, v in enumerate(r)] for i, r in enumerate(rows)]
            if len({len(r) for r in heights}) != 1:
                raise self.error("every row needs the same number of heights", g("heights"))
        size = self.vector(s["size"], g("size"), 2, self.positive)
        base = self.positive(s["base"], g("base")) if "base" in s else 0.5
        return self.library(key, heightfield, heights, size, base)

    def compound(self, value, key: str, shape_key: str):
        """``parts = [{shape = {...}, position = [...], orientation = [w, x, y, z] or euler_deg = [...],
        material = {...}}, ...]`` (a part's material: its contacts' friction and restitution)."""
        self.where = key
        if not isinstance(value, list):
            raise self.error(f"expected a list of part tables, got {_describe(value)}", key)
        if not value:
            raise self.error("a compound needs at least one part", key)
        parts = []
        for i, part in enumerate(value):
            pk = f"{key}[{i}]"
            t = self.table(part, pk, PART_KEYS, required=("shape",))
            kind = t["shape"].get("type") if isinstance(t["shape"], dict) else None
            if isinstance(kind, str) and kind in SHAPE_KEYS and kind not in PART_TYPES:
                raise self.error(f"a compound part cannot be a {kind} (expected one of {', '.join(PART_TYPES)})", f"{pk}.shape.type")
            shape = self.shape(t["shape"], f"{pk}.shape")
            position = self.vector(t["position"], f"{pk}.position") if "position" in t else [0.0, 0.0, 0.0]
            if "orientation" in t:
                if "euler_deg" in t:
                    raise self.error("give orientation or euler_deg, not both", f"{pk}.euler_deg")
                q = self.vector(t["orientation"], f"{pk}.orientation", 4)
                if all(c == 0 for c in q):
                    raise self.error("quaternion must not be zero (w, x, y, z = 0, 0, 0, 0)", f"{pk}.orientation")
            elif "euler_deg" in t:
                q = [float(c) for c in quat_from_euler_deg(self.vector(t["euler_deg"], f"{pk}.euler_deg"))]
            else:
                q = [1.0, 0.0, 0.0, 0.0]
            material = self.material(t["material"], f"{pk}.material") if "material" in t else None
            parts.append((shape, position, q, material))
        return self.library(shape_key, Compound, parts)

    def material(self, value, key: str) -> Material:
        """A ``Material`` from a table of its keys (a body's or a compound part's ``material``);
        built here, not in add_body or Compound, so that its errors are keyed ``KEY.friction``."""
        m = self.table(value, key, MATERIAL_KEYS)
        return self.library(key, Material, **{k: self.string(v, f"{key}.{k}", COMBINE_MODES) if k.endswith("_combine")
                                              else self.number(v, f"{key}.{k}") for k, v in m.items()})

    def mesh_path(self, value, key: str) -> str:
        return self.data_path(value, key, "mesh")

    def data_path(self, value, key: str, what: str) -> str:
        """A file the scene names (a mesh, a heights array, a URDF), relative to the scene's folder:
        it must exist, not be empty and fit in ``checks.memory_limit()``."""
        rel = self.string(value, key)
        if not rel:
            raise self.error("must not be empty", key)
        p = Path(rel).expanduser()
        if not p.is_absolute():
            p = self.base_dir / p
        if not p.is_file():
            raise self.error(f"{what} file not found: {p}", key)
        size = p.stat().st_size
        if size == 0:
            raise self.error(f"{what} file is empty: {p}", key)
        try:
            checks.check_memory(size * checks.FILE_EXPANSION, f"reading the {checks.fmt_bytes(size)} {what} file {p}", key, self.file)
        except InputError as err:
            raise self.error(err.problem, key) from None
        return str(p)

    def force(self, world: World, f: dict, key: str, names: dict):
        self.where = key
        if "type" not in f:
            raise self.error("missing key 'type'", key)
        kind = self.string(f["type"], f"{key}.type")
        if kind not in FORCE_KEYS:
            raise self.error(f"unknown force type {kind!r} (expected one of {', '.join(FORCE_KEYS)})", f"{key}.type")
        required, optional = FORCE_KEYS[kind]
        self.table(f, key, ("type",) + required + optional, required)
        g = lambda k: f"{key}.{k}"  # noqa: E731
        nonneg = lambda k: self.nonnegative(f[k], g(k))  # noqa: E731
        vec = lambda k: self.vector(f[k], g(k))  # noqa: E731
        kw: dict[str, Any] = {}
        if kind in ("drag", "wind"):
            for k in ("linear", "quadratic", "angular_linear", "angular_quadratic"):
                if k in f:
                    kw[k] = nonneg(k)
            for k in ("wind", "velocity"):
                if k in f:
                    kw[k] = vec(k)
            if "bodies" in f:
                kw["bodies"] = self.name_list(f["bodies"], g("bodies"), names)
            record = self.library(key, Drag if kind == "drag" else Wind, **kw)
        elif kind == "constant":
            kw = {k: vec(k) for k in ("force", "torque") if k in f}
            record = self.library(key, ConstantForce, self.body_ref(f["body"], g("body"), names), **kw)
        elif kind == "point":
            frame = self.string(f["frame"], g("frame"), ("world", "body")) if "frame" in f else "world"
            record = self.library(key, PointForce, self.body_ref(f["body"], g("body"), names), vec("force"), vec("point"), frame)
        elif kind == "spring":
            a = self.body_ref(f["body_a"], g("body_a"), names)
            b = None if f.get("body_b") is None else self.body_ref(f["body_b"], g("body_b"), names)
            if b is not None and b == a:
                raise self.error(f"a spring needs two different bodies, got {a!r} twice", g("body_b"))
            kw = {k: vec(k) for k in ("anchor_a", "anchor_b") if k in f}
            kw["stiffness"] = nonneg("stiffness")
            if "damping" in f:
                kw["damping"] = nonneg("damping")
            if f.get("rest_length") is not None:
                kw["rest_length"] = nonneg("rest_length")
            record = self.library(key, Spring, a, b, **kw)
        elif kind == "fluid":
            kw = {k: nonneg(k) for k in ("density", "viscosity") if k in f}
            if "wind" in f:
                kw["wind"] = vec("wind")
            if "bodies" in f:
                kw["bodies"] = self.name_list(f["bodies"], g("bodies"), names)
            record = self.library(key, Fluid, **kw)
        elif kind == "buoyancy":
            kw = {k: nonneg(k) for k in ("density", "linear", "quadratic", "angular_linear", "angular_quadratic")
                  if k in f}
            if "level" in f:
                kw["level"] = self.number(f["level"], g("level"))
            if "flow" in f:
                kw["flow"] = vec("flow")
            if "bodies" in f:
                kw["bodies"] = self.name_list(f["bodies"], g("bodies"), names)
            record = self.library(key, Buoyancy, **kw)
        elif kind == "explosion":
            kw = {k: nonneg(k) for k in ("radius", "falloff", "time") if k in f}
            kw["impulse_per_area"] = self.number(f["impulse_per_area"], g("impulse_per_area"))
            if "mask" in f:
                kw["mask"] = f["mask"]  # the record checks it as a filter's bits
            if "shaded" in f:
                kw["shaded"] = self.boolean(f["shaded"], g("shaded"))
            record = self.library(key, Explosion, vec("position"), **kw)
        else:  # impulse
            body = self.body_ref(f["body"], g("body"), names)
            kw = {"point": vec("point")} if "point" in f else {}
            if "time" in f:
                kw["time"] = nonneg("time")
            record = self.library(key, Impulse, body, vec("impulse"), **kw)
        self.library(key, world.add_force, record)
