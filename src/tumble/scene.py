"""Scene files (TOML, or JSON with the same structure): parse, validate, build a ``World``.

The format is DESIGN.md's "Scene file" contract::

    [simulation]            duration, frame_rate, dt, integrator, substeps,
                            gravity, layout, rtol, atol, max_energy_growth,
                            collisions, record_contacts, record_joints, sleeping
                            (all optional)
    [contact]               the contact solver's settings (SoftStepSettings:
                            contact_hertz, contact_damping_ratio, ...; optional)
    [[joints]]              type = ball | hinge | slider | fixed | distance | universal,
                            body_a, body_b, anchor, axis, limits, motors ... (docs/joints.md,
                            tumble.scene_joints)
    [joint_solver]          the joint solver's settings (JointSettings; optional)
    [[bodies]]              name, shape = {type = ..., ...}, mass or density,
                            inertia, fixed, position, orientation or euler_deg,
                            velocity, angular_velocity, angular_velocity_frame,
                            material = {friction, restitution}
    [[forces]]              type = drag | wind | constant | point | spring | impulse,
                            with that type's keys; bodies are referred to by name.

Validation is strict: an unknown key, a value of the wrong type, a missing key,
a non-finite or out-of-range number, a name that refers to nothing, each is
an ``InputError`` whose ``str`` is one line ``FILE: KEY.PATH: problem``, e.g.
``scene.toml: bodies[1].mass: must be positive, got -1``. Nothing else
escapes ``load_scene``: an unexpected exception while building the scene is
turned into an ``InputError`` naming the file and the key being read.

Scene files are data only: TOML or JSON is parsed, nothing is evaluated or
unpickled. Sizes are checked against ``checks.memory_limit()`` before memory is
spent: the scene file's size, the counts of bodies, particles and inline mesh
vertices, and each mesh file's size (``TUMBLE_MAX_MEMORY`` raises the limit).
"""

from __future__ import annotations

import dataclasses
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import checks
from . import integrators as K
from .errors import InputError
from .forces import ConstantForce, Drag, Impulse, PointForce, Spring, Wind
from .math3d import quat_from_euler_deg
from .shapes import (
    Box,
    Capsule,
    Compound,
    Cone,
    Convex,
    Cylinder,
    Mesh,
    Particles,
    Plane,
    Sphere,
)
from .simulator import Simulator, steps_between
from .solver.contact import SoftStepSettings
from .trajectory import Trajectory
from .world import Material, World

# Defaults of [simulation] (DESIGN.md; gravity z down).
DEFAULTS = {
    "duration": 5.0,
    "frame_rate": 24.0,
    "dt": 1.0 / 240.0,
    "integrator": "rk4",
    "substeps": 1,
    "gravity": [0.0, 0.0, -9.81],
    "layout": "quaternion",
    "rtol": 1e-10,
    "atol": 1e-12,
    "max_energy_growth": checks.MAX_ENERGY_GROWTH,
    "collisions": True,
    "record_contacts": False,
    "record_joints": False,
    "sleeping": True,
}

TOP_KEYS = ("simulation", "bodies", "forces", "contact", "joints", "joint_solver")
# [contact]: the soft step's settings (tumble.solver.contact.SoftStepSettings), all optional.
CONTACT_KEYS = tuple(f.name for f in dataclasses.fields(SoftStepSettings))
SIMULATION_KEYS = tuple(DEFAULTS)
BODY_KEYS = (
    "name", "shape", "mass", "density", "inertia", "fixed", "position", "orientation", "euler_deg",
    "velocity", "angular_velocity", "angular_velocity_frame", "material",
)
MATERIAL_KEYS = ("friction", "restitution")
# Per shape type: (required keys, optional keys).
SHAPE_KEYS = {
    "sphere": (("radius",), ()),
    "box": (("size",), ()),
    "capsule": (("radius", "length"), ()),
    "cylinder": (("radius", "length"), ()),
    "cone": (("radius", "height"), ()),
    "plane": ((), ("normal", "offset")),
    "mesh": ((), ("path", "vertices", "faces")),
    "convex": ((), ("path", "points")),
    "particles": (("points", "masses"), ()),
    "compound": (("parts",), ()),
}
# A compound's parts: solid convex shapes only (no plane, mesh, particles, nor another compound).
PART_KEYS = ("shape", "position", "orientation", "euler_deg")
PART_TYPES = ("sphere", "box", "capsule", "cylinder", "cone", "convex")
# Per force type: (required keys, optional keys), besides "type".
FORCE_KEYS = {
    "drag": ((), ("linear", "quadratic", "angular_linear", "angular_quadratic", "wind", "bodies")),
    "wind": (("velocity",), ("linear", "quadratic", "bodies")),
    "constant": (("body",), ("force", "torque")),
    "point": (("body", "force", "point"), ("frame",)),
    "spring": (("body_a", "stiffness"), ("body_b", "anchor_a", "anchor_b", "damping", "rest_length")),
    "impulse": (("body", "impulse"), ("point", "time")),
}


@dataclass
class Scene:
    """A parsed scene: its ``World`` (bodies and forces built) and the run settings.

    Attributes:
        world: the bodies and forces, at t = 0 until a run advances it.
        duration: s. frame_rate: recorded frames per second. dt: internal step, s.
        integrator: a name of ``integrators.INTEGRATOR_IDS``. substeps: integrator
            steps per dt. layout: "quaternion" or "matrix".
        source: the file it was read from (None when built from a dict).
        data: the parsed document, as read (for summary.json).
        rtol, atol: tolerances of the adaptive integrators (rk45, dop853).
        max_energy_growth: blow-up bound on the total energy (``checks.energy_bound``), >= 1.
    """

    world: World
    duration: float
    frame_rate: float
    dt: float
    integrator: str
    substeps: int
    layout: str
    source: Path | None = None
    data: dict = field(default_factory=dict)
    rtol: float = DEFAULTS["rtol"]
    atol: float = DEFAULTS["atol"]
    max_energy_growth: float = DEFAULTS["max_energy_growth"]
    record_contacts: bool = False
    contact: SoftStepSettings = field(default_factory=SoftStepSettings)
    joint_settings: Any = None
    record_joints: bool = False

    @property
    def gravity(self) -> list[float]:
        return [float(g) for g in self.world.gravity]

    def settings(self) -> dict[str, Any]:
        """The run settings as plain JSON values (summary.json "settings")."""
        return {
            "dt": self.dt,
            "integrator": self.integrator,
            "substeps": self.substeps,
            "layout": self.layout,
            "duration": self.duration,
            "frame_rate": self.frame_rate,
            "gravity": self.gravity,
            "rtol": self.rtol,
            "atol": self.atol,
            "max_energy_growth": self.max_energy_growth,
            "collisions": bool(self.world.collisions),
            "sleeping": bool(self.world.sleeping),
            "record_contacts": self.record_contacts,
            "contact": dataclasses.asdict(self.contact),
            "record_joints": self.record_joints,
            "joint_solver": None if self.joint_settings is None else dataclasses.asdict(self.joint_settings),
        }

    def check(self):
        """Validate the settings (after changing e.g. ``duration``); InputError keyed ``simulation.*``."""
        file = None if self.source is None else str(self.source)
        try:
            _check_settings(self.duration, self.frame_rate, self.dt, self.integrator, self.substeps, self.rtol, self.atol)
        except InputError as err:
            raise err.within(None, file) from None

    def simulator(self) -> Simulator:
        """A ``Simulator`` for ``world`` with the scene's dt, integrator, substeps and tolerances."""
        return Simulator(self.world, dt=self.dt, integrator=self.integrator, substeps=self.substeps, rtol=self.rtol, atol=self.atol,
                         max_energy_growth=self.max_energy_growth, contact_settings=self.contact,
                         record_contacts=self.record_contacts, joint_settings=self.joint_settings,
                         record_joints=self.record_joints)

    def run(self, progress: bool | None = None) -> Trajectory:
        """Run ``duration`` s at ``frame_rate`` from the world's current state (t = 0 for a fresh scene)."""
        return self.simulator().run(self.duration, self.frame_rate, progress=progress)


# ---------------------------------------------------------------------- reading files


def load_scene(path) -> Scene:
    """Read a scene file: ``.toml`` (tomllib) or ``.json``.

    Mesh paths inside it are relative to the file's folder.

    Raises:
        InputError: one line ``FILE: KEY: problem`` for any problem with the file.
    """
    path = Path(path)
    file = str(path)
    suffix = path.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise InputError(f"unknown scene file type {path.suffix or '(none)'!r} (expected .toml or .json)", None, file)
    try:
        size = path.stat().st_size
    except OSError:
        size = 0
    checks.check_memory(size * checks.FILE_EXPANSION, f"reading this {checks.fmt_bytes(size)} scene file", None, file)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise InputError("file not found", None, file) from None
    except IsADirectoryError:
        raise InputError("is a folder, not a scene file", None, file) from None
    except OSError as exc:
        raise InputError(f"cannot read file: {exc.strerror or exc}", None, file) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"not UTF-8 text (byte {exc.start})", None, file) from None
    if suffix == ".toml":
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise InputError(f"invalid TOML: {_one_line(str(exc))}", None, file) from None
        except RecursionError:
            raise InputError("invalid TOML: nested too deeply", None, file) from None
    else:
        try:
            data = json.loads(text, object_pairs_hook=_no_duplicate_keys)
        except json.JSONDecodeError as exc:
            raise InputError(f"invalid JSON: {exc.msg} (at line {exc.lineno}, column {exc.colno})", None, file) from None
        except _DuplicateKey as exc:
            raise InputError(f"invalid JSON: duplicate key {exc.args[0]!r}", None, file) from None
        except RecursionError:
            raise InputError("invalid JSON: nested too deeply", None, file) from None
    return parse_scene(data, file, path.parent, source=path)


class _DuplicateKey(Exception):
    pass


def _no_duplicate_keys(pairs):
    out = {}
    for k, v in pairs:
        if k in out:
            raise _DuplicateKey(k)
        out[k] = v
    return out


# ---------------------------------------------------------------------- parsing


def parse_scene(data: dict, file: str | None = None, base_dir: Path | str | None = None, *, source: Path | str | None = None) -> Scene:
    """Validate a scene document (the dict a TOML or JSON file parses to) and build its ``World``.

    Args:
        data: the document.
        file: the name used in error messages (and ``Scene.source`` unless ``source`` is given).
        base_dir: folder that relative mesh paths are resolved against (default: the working folder).
        source: the scene file, if any.

    Raises:
        InputError: ``FILE: KEY: problem`` for the first problem found.
    """
    p = _Parser(file, Path(base_dir) if base_dir is not None else Path("."))
    try:
        scene = p.scene(data)
    except InputError as err:
        raise InputError(_one_line(err.problem), err.key, err.file or file) from None
    except RecursionError:
        raise InputError("scene is nested too deeply", p.where or None, file) from None
    except Exception as exc:  # never a traceback for a bad scene: name the key being read
        raise InputError(f"cannot read this value ({type(exc).__name__}: {_one_line(str(exc))})", p.where or None, file) from None
    if source is not None:
        scene.source = Path(source)
    elif file is not None:
        scene.source = Path(file)
    return scene


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _describe(value) -> str:
    """How a value of the wrong type is shown in a message."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"{str(value).lower()} (a boolean)"
    if isinstance(value, str):
        shown = value if len(value) <= 40 else value[:37] + "..."
        return f"{shown!r} (a string)"
    if isinstance(value, (int, float)):
        return f"{value!r} (a number)"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    return f"{value!r} ({type(value).__name__})"


def _fmt(v: float) -> str:
    return f"{v:g}"


def _check_settings(duration, frame_rate, dt, integrator, substeps, rtol, atol):
    """Checks across [simulation] values that are each of the right type already."""
    if integrator not in K.INTEGRATOR_IDS:
        raise InputError(f"unknown integrator {integrator!r} (expected one of {', '.join(K.INTEGRATOR_IDS)})", "simulation.integrator")
    for key, v in (("duration", duration), ("frame_rate", frame_rate), ("dt", dt), ("rtol", rtol), ("atol", atol)):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise InputError(f"expected a number, got {_describe(v)}", f"simulation.{key}")
        if not math.isfinite(v):
            raise InputError(f"must be a finite number, got {v}", f"simulation.{key}")
        if v <= 0:
            raise InputError(f"must be positive, got {_fmt(v)}", f"simulation.{key}")
    if isinstance(substeps, bool) or not isinstance(substeps, int) or substeps < 1:
        raise InputError(f"must be a whole number >= 1, got {_describe(substeps)}", "simulation.substeps")
    period = 1.0 / frame_rate
    n = period / dt
    if abs(n - round(n)) > 1e-6 * max(1.0, n) or round(n) < 1:
        raise InputError(f"must divide 1 / frame_rate = {_fmt(period)} s into whole steps, got {_fmt(dt)} s ({_fmt(n)} steps a frame)", "simulation.dt")
    steps_between(period, dt, "1 / frame_rate")  # the Simulator's own test, same tolerance
    frames = duration * frame_rate
    if abs(frames - round(frames)) > 1e-6 * max(1.0, frames) or round(frames) < 1:
        raise InputError(f"must be a whole number of frames at {_fmt(frame_rate)} per second, got {_fmt(duration)} s ({_fmt(frames)} frames)", "simulation.duration")


class _Parser:
    """One parse of one document. ``where`` is the key being read (for unexpected errors)."""

    def __init__(self, file: str | None, base_dir: Path):
        self.file = file
        self.base_dir = base_dir
        self.where = ""

    # ----------------------------------------------------------------- errors
    def error(self, problem: str, key: str | None) -> InputError:
        return InputError(problem, key or None, self.file)

    def library(self, key: str, call, *args, **kwargs):
        """Call a library constructor; its InputErrors (keys relative to its arguments) get ``key`` in front."""
        self.where = key
        try:
            return call(*args, **kwargs)
        except InputError as err:
            raise err.within(key, self.file) from None

    # ----------------------------------------------------------------- typed values
    def table(self, value, key: str, allowed, required=(), what="a table") -> dict:
        self.where = key
        if not isinstance(value, dict):
            raise self.error(f"expected {what}, got {_describe(value)}", key)
        allowed = tuple(allowed)
        for k in value:
            if k not in allowed:
                sub = f"{key}.{k}" if key else str(k)
                raise self.error(f"unknown key (expected one of {', '.join(allowed)})", sub)
        for k in required:
            if k not in value:
                raise self.error(f"missing key {k!r}", key)
        return value

    def number(self, value, key: str) -> float:
        self.where = key
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(f"expected a number, got {_describe(value)}", key)
        try:
            v = float(value)
        except OverflowError:  # a JSON integer beyond the float range
            raise self.error(f"must be a finite number, got an integer of {len(str(abs(value)))} digits", key) from None
        if not math.isfinite(v):
            raise self.error(f"must be a finite number, got {v}", key)
        return v

    def positive(self, value, key: str) -> float:
        v = self.number(value, key)
        if v <= 0:
            raise self.error(f"must be positive, got {_fmt(v)}", key)
        return v

    def nonnegative(self, value, key: str) -> float:
        v = self.number(value, key)
        if v < 0:
            raise self.error(f"must be >= 0, got {_fmt(v)}", key)
        return v

    def integer(self, value, key: str, minimum: int) -> int:
        self.where = key
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(f"expected a whole number, got {_describe(value)}", key)
        if value < minimum:
            raise self.error(f"must be >= {minimum}, got {value}", key)
        return value

    def boolean(self, value, key: str) -> bool:
        self.where = key
        if not isinstance(value, bool):
            raise self.error(f"expected true or false, got {_describe(value)}", key)
        return value

    def string(self, value, key: str, choices=None) -> str:
        self.where = key
        if not isinstance(value, str):
            raise self.error(f"expected a string, got {_describe(value)}", key)
        if choices is not None and value not in choices:
            raise self.error(f"must be one of {', '.join(repr(c) for c in choices)}, got {value!r}", key)
        return value

    def vector(self, value, key: str, length: int = 3, check=None) -> list[float]:
        self.where = key
        if not isinstance(value, list):
            raise self.error(f"expected a list of {length} numbers, got {_describe(value)}", key)
        if len(value) != length:
            raise self.error(f"expected a list of {length} numbers, got {len(value)}", key)
        check = check or self.number
        return [check(x, f"{key}[{i}]") for i, x in enumerate(value)]

    def rows(self, value, key: str, width: int, item=None, min_rows: int = 1) -> list[list]:
        """A list of rows of ``width`` numbers (points, vertices, faces)."""
        self.where = key
        if not isinstance(value, list):
            raise self.error(f"expected a list of rows of {width} numbers, got {_describe(value)}", key)
        if len(value) < min_rows:
            raise self.error(f"expected at least {min_rows} rows, got {len(value)}", key)
        return [self.vector(row, f"{key}[{i}]", width, item) for i, row in enumerate(value)]

    def name_list(self, value, key: str, names: dict) -> list[str]:
        self.where = key
        if not isinstance(value, list):
            raise self.error(f"expected a list of body names, got {_describe(value)}", key)
        return [self.body_ref(v, f"{key}[{i}]", names) for i, v in enumerate(value)]

    def body_ref(self, value, key: str, names: dict) -> str:
        name = self.string(value, key)
        if name not in names:
            raise self.error(f"unknown body {name!r}", key)
        return name

    # ----------------------------------------------------------------- the document
    def scene(self, data) -> Scene:
        doc = self.table(data, "", TOP_KEYS, what="a table of [simulation], [[bodies]] and [[forces]]")
        if "bodies" not in doc:
            raise self.error("missing key 'bodies' (a scene needs at least one [[bodies]] entry)", None)
        sim = self.simulation(doc.get("simulation", {}))
        contact = self.contact(doc.get("contact", {}))
        world = self.library("simulation", World, gravity=sim["gravity"], layout=sim["layout"])
        world.collisions = sim["collisions"]
        world.sleeping = sim["sleeping"]

        bodies = doc["bodies"]
        if not isinstance(bodies, list) or not all(isinstance(b, dict) for b in bodies):
            raise self.error(f"expected a list of tables ([[bodies]]), got {_describe(bodies)}", "bodies")
        if not bodies:
            raise self.error("a scene needs at least one body", "bodies")
        self.check_sizes(bodies)
        names: dict[str, int] = {}
        for i, body in enumerate(bodies):
            self.body(world, body, f"bodies[{i}]", names)

        forces = doc.get("forces", [])
        if not isinstance(forces, list) or not all(isinstance(f, dict) for f in forces):
            raise self.error(f"expected a list of tables ([[forces]]), got {_describe(forces)}", "forces")
        for i, force in enumerate(forces):
            self.force(world, force, f"forces[{i}]", names)

        from .scene_joints import parse_joint_settings, parse_joints

        self.where = "joints"
        parse_joints(doc.get("joints"), world, self.file)
        self.where = "joint_solver"
        joint_settings = parse_joint_settings(doc.get("joint_solver"), self.file) if "joint_solver" in doc else None

        return Scene(
            world=world, duration=sim["duration"], frame_rate=sim["frame_rate"], dt=sim["dt"],
            integrator=sim["integrator"], substeps=sim["substeps"], layout=sim["layout"],
            data=data, rtol=sim["rtol"], atol=sim["atol"], max_energy_growth=sim["max_energy_growth"],
            record_contacts=sim["record_contacts"], contact=contact, joint_settings=joint_settings,
            record_joints=sim["record_joints"],
        )

    def contact(self, value) -> SoftStepSettings:
        t = self.table(value, "contact", CONTACT_KEYS)
        kw = {}
        for k, v in t.items():
            if k in ("substeps", "partitions"):
                kw[k] = self.integer(v, f"contact.{k}", 1)
            elif k == "partition_min_contacts":
                kw[k] = self.integer(v, f"contact.{k}", 0)
            elif k in ("contact_hertz", "hertz_cap_per_substep", "speculative_distance"):
                kw[k] = self.positive(v, f"contact.{k}")
            else:
                kw[k] = self.nonnegative(v, f"contact.{k}")
        return SoftStepSettings(**kw)

    def check_sizes(self, bodies: list):
        """Refuse, before building anything, a scene whose bodies, particles or inline mesh
        rows would need more than ``checks.memory_limit()``."""
        items = 0
        for b in bodies:
            shape = b.get("shape")
            if isinstance(shape, dict):
                for key in ("points", "vertices", "faces", "masses"):
                    if isinstance(shape.get(key), list):
                        items += len(shape[key])
        estimate = len(bodies) * checks.BODY_BYTES + items * checks.ITEM_BYTES
        checks.check_memory(estimate, f"{len(bodies)} bodies with {items} particles and mesh rows", "bodies", self.file)

    def simulation(self, value) -> dict:
        t = self.table(value, "simulation", SIMULATION_KEYS)
        s = {k: (list(v) if isinstance(v, list) else v) for k, v in DEFAULTS.items()}
        for k in ("duration", "frame_rate", "dt", "rtol", "atol"):
            if k in t:
                s[k] = self.positive(t[k], f"simulation.{k}")
        if "substeps" in t:
            s["substeps"] = self.integer(t["substeps"], "simulation.substeps", 1)
        for k in ("collisions", "record_contacts", "record_joints", "sleeping"):
            if k in t:
                s[k] = self.boolean(t[k], f"simulation.{k}")
        if "max_energy_growth" in t:
            s["max_energy_growth"] = self.number(t["max_energy_growth"], "simulation.max_energy_growth")
            if s["max_energy_growth"] < 1:
                raise self.error(f"must be >= 1, got {_fmt(s['max_energy_growth'])}", "simulation.max_energy_growth")
        if "integrator" in t:
            s["integrator"] = self.string(t["integrator"], "simulation.integrator")
        if "layout" in t:
            s["layout"] = self.string(t["layout"], "simulation.layout", tuple(K.LAYOUT_IDS))
        if "gravity" in t:
            s["gravity"] = self.vector(t["gravity"], "simulation.gravity")
        self.where = "simulation"
        try:
            _check_settings(s["duration"], s["frame_rate"], s["dt"], s["integrator"], s["substeps"], s["rtol"], s["atol"])
        except InputError as err:
            raise err.within(None, self.file) from None
        return s

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
        elif not fixed and "mass" not in b and "density" not in b:
            raise self.error("missing key 'mass' (or 'density')", key)
        if "inertia" in b:
            kw["inertia"] = self.inertia(b["inertia"], f"{key}.inertia")
        for k in ("position", "velocity", "angular_velocity", "euler_deg"):
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
            m = self.table(b["material"], f"{key}.material", MATERIAL_KEYS)
            values = {k: self.number(v, f"{key}.material.{k}") for k, v in m.items()}
            # built here, not in add_body: its errors are keyed "friction", not "material.friction"
            kw["material"] = self.library(f"{key}.material", Material, **values)
        self.library(key, world.add_body, shape, **kw)
        names[name] = len(names)

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
            if "path" in s:
                if "vertices" in s or "faces" in s:
                    raise self.error("give either a mesh file path or inline vertices and faces, not both", g("path"))
                return self.library(key, Mesh, path=self.mesh_path(s["path"], g("path")))
            if "vertices" not in s or "faces" not in s:
                missing = "vertices" if "vertices" not in s else "faces"
                raise self.error(f"missing key {missing!r} (give a mesh file 'path', or 'vertices' and 'faces')", key)
            vertices = self.rows(s["vertices"], g("vertices"), 3)
            faces = self.rows(s["faces"], g("faces"), 3, lambda v, k: self.integer(v, k, 0))
            return self.library(key, Mesh, vertices=vertices, faces=faces)
        if kind == "compound":
            return self.compound(s["parts"], g("parts"), key)
        # convex
        if "path" in s:
            if "points" in s:
                raise self.error("give either a mesh file path or points, not both", g("path"))
            return self.library(key, Convex, path=self.mesh_path(s["path"], g("path")))
        if "points" not in s:
            raise self.error("missing key 'points' (or a mesh file 'path')", key)
        return self.library(key, Convex, points=self.rows(s["points"], g("points"), 3))

    def compound(self, value, key: str, shape_key: str):
        """``parts = [{shape = {...}, position = [...], orientation = [w, x, y, z] or euler_deg = [...]}, ...]``."""
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
            parts.append((shape, position, q))
        return self.library(shape_key, Compound, parts)

    def mesh_path(self, value, key: str) -> str:
        rel = self.string(value, key)
        if not rel:
            raise self.error("must not be empty", key)
        p = Path(rel).expanduser()
        if not p.is_absolute():
            p = self.base_dir / p
        if not p.is_file():
            raise self.error(f"mesh file not found: {p}", key)
        size = p.stat().st_size
        if size == 0:
            raise self.error(f"mesh file is empty: {p}", key)
        try:
            checks.check_memory(size * checks.FILE_EXPANSION, f"reading the {checks.fmt_bytes(size)} mesh file {p}", key, self.file)
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
        else:  # impulse
            body = self.body_ref(f["body"], g("body"), names)
            kw = {"point": vec("point")} if "point" in f else {}
            if "time" in f:
                kw["time"] = nonneg("time")
            record = self.library(key, Impulse, body, vec("impulse"), **kw)
        self.library(key, world.add_force, record)
