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
                            material = {friction, restitution, rolling_resistance,
                            spinning_friction},
                            collision_filter = {category, mask, group} (tumble.scene_bodies)
    [[robots]]              file = "robot.urdf", name, position, euler_deg, fixed_base,
                            joint_positions ...: a URDF's links and joints (tumble.scene_robots)
    [[collision_exclusions]] bodies = [NAME, NAME]: a pair that never touches
    [[contact_pairs]]       bodies = [NAME, NAME], material = {...}: the pair's contacts take
                            that material (World.set_pair_material)
    [[forces]]              type = drag | wind | constant | point | spring | impulse | explosion,
                            with that type's keys; bodies are referred to by name
                            (tumble.scene_bodies).

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
from .scene_robots import RobotReader
from .scene_bodies import BODY_KEYS, FORCE_KEYS, BodyReader  # noqa: F401 (the keys: sweep.spec reads them here)
from .scene_values import _describe, _fmt, _int_digits_problem, _one_line
from .simulator import Simulator, check_step_count, steps_between
from .solver.contact import SoftStepSettings
from .trajectory import Trajectory
from .usd_physics import USD_SUFFIXES
from .world import World

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

TOP_KEYS = ("simulation", "bodies", "robots", "forces", "contact", "joints", "joint_solver", "collision_exclusions",
            "contact_pairs", "cameras")
# [contact]: the soft step's settings (tumble.solver.contact.SoftStepSettings), all optional.
CONTACT_KEYS = tuple(f.name for f in dataclasses.fields(SoftStepSettings))
SIMULATION_KEYS = tuple(DEFAULTS)
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
    # [[cameras]] and the robots' MJCF <camera>s ("ROBOT/CAMERA"): {name: tumble.Camera} (scene_cameras)
    cameras: dict = field(default_factory=dict)
    # the [[robots]] loaded (URDF and MJCF): {name: tumble.urdf.Robot}, for set_controls, set_motor, kinematics
    robots: dict = field(default_factory=dict)

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
    """Read a scene file: ``.toml`` (tomllib) or ``.json``; or a MuJoCo model (``.xml``, MJCF) or a
    USD stage with physics (``.usd``, ``.usda``, ``.usdc``, ``.usdz``) run as a scene of its own
    (``_model_scene``).

    Mesh paths inside it are relative to the file's folder.

    Raises:
        InputError: one line ``FILE: KEY: problem`` for any problem with the file.
    """
    path = Path(path)
    file = str(path)
    suffix = path.suffix.lower()
    if suffix == ".xml" or suffix in USD_SUFFIXES:
        return _model_scene(path)
    if suffix not in (".toml", ".json"):
        raise InputError(f"unknown scene file type {path.suffix or '(none)'!r} (expected .toml, .json, an MJCF .xml "
                         "or a USD stage)", None, file)
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
        except ValueError as exc:  # Python's limit on the digits of an integer read from text
            raise InputError(f"invalid TOML: {_int_digits_problem(exc)}", None, file) from None
    else:
        try:
            data = json.loads(text, object_pairs_hook=_no_duplicate_keys)
        except json.JSONDecodeError as exc:
            raise InputError(f"invalid JSON: {exc.msg} (at line {exc.lineno}, column {exc.colno})", None, file) from None
        except _DuplicateKey as exc:
            raise InputError(f"invalid JSON: duplicate key {exc.args[0]!r}", None, file) from None
        except RecursionError:
            raise InputError("invalid JSON: nested too deeply", None, file) from None
        except ValueError as exc:  # Python's limit on the digits of an integer read from text
            raise InputError(f"invalid JSON: {_int_digits_problem(exc)}", None, file) from None
    return parse_scene(data, file, path.parent, source=path)


def _model_scene(path: Path) -> Scene:
    """A MuJoCo model file or a USD stage as a scene of its own (``tumble run model.xml``, as
    MuJoCo's ``simulate`` opens one; ``tumble run stage.usda``): ``model_document``'s one
    ``[[robots]]`` entry loading it, the file's gravity (MJCF's ``<option gravity>``, MuJoCo's
    default 0 0 -9.81; the stage's PhysicsScene) as the scene's, the other ``[simulation]`` keys at
    their defaults (dt 1/240 s: a model's ``timestep`` is not taken, the frames must be a whole
    number of steps)."""
    return parse_scene(model_document(path), str(path), path.parent, source=path)


def model_document(path: Path) -> dict:
    """The scene document of a model file run as a scene of its own: an MJCF ``.xml`` or a USD
    stage, one ``[[robots]]`` entry loading it and its gravity as ``[simulation]``'s (what
    ``tumble run`` and ``tumble sweep`` take such a file as). An MJCF file's own problems are its
    own line (FILE: element: problem), not the entry's; a stage's are the entry's (both files on
    the line) but for those of the file itself (not found, not USD, its units)."""
    path = Path(path)
    if path.suffix.lower() == ".xml":
        from .mjcf import read_mjcf, read_option_gravity

        read_mjcf(path)
        gravity = read_option_gravity(path)
    else:  # the stage opened and its PhysicsScene read (its bodies are read once, by the entry)
        from .usd_physics import read_gravity

        gravity = read_gravity(path)
    return {"simulation": {"gravity": [float(g) for g in gravity]}, "robots": [{"file": path.name}]}


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
    # before the whole-steps tests: a run of absurdly many steps (substeps = 1e12, dt = 1e-300,
    # duration = 1e308) is refused with the step count, not left to run for ever or overflow
    check_step_count(duration, frame_rate, dt, substeps)
    period = 1.0 / frame_rate
    n = period / dt
    if abs(n - round(n)) > 1e-6 * max(1.0, n) or round(n) < 1:
        raise InputError(f"must divide 1 / frame_rate = {_fmt(period)} s into whole steps, got {_fmt(dt)} s ({_fmt(n)} steps a frame)", "simulation.dt")
    steps_between(period, dt, "1 / frame_rate")  # the Simulator's own test, same tolerance
    frames = duration * frame_rate
    if abs(frames - round(frames)) > 1e-6 * max(1.0, frames) or round(frames) < 1:
        raise InputError(f"must be a whole number of frames at {_fmt(frame_rate)} per second, got {_fmt(duration)} s ({_fmt(frames)} frames)", "simulation.duration")


class _Parser(BodyReader, RobotReader):
    """One parse of one document: its [simulation], [contact], bodies, forces and joints.
    ``where`` is the key being read (for unexpected errors)."""

    # ----------------------------------------------------------------- the document
    def scene(self, data) -> Scene:
        doc = self.table(data, "", TOP_KEYS, what="a table of [simulation], [[bodies]] and [[forces]]")
        if "bodies" not in doc and "robots" not in doc:
            raise self.error("missing key 'bodies' (a scene needs at least one [[bodies]] or [[robots]] entry)", None)
        sim = self.simulation(doc.get("simulation", {}))
        contact = self.contact(doc.get("contact", {}))
        world = self.library("simulation", World, gravity=sim["gravity"], layout=sim["layout"])
        world.collisions = sim["collisions"]
        world.sleeping = sim["sleeping"]

        bodies = doc.get("bodies", [])
        if not isinstance(bodies, list) or not all(isinstance(b, dict) for b in bodies):
            raise self.error(f"expected a list of tables ([[bodies]]), got {_describe(bodies)}", "bodies")
        robots = doc.get("robots", [])
        if not isinstance(robots, list) or not all(isinstance(r, dict) for r in robots):
            raise self.error(f"expected a list of tables ([[robots]]), got {_describe(robots)}", "robots")
        if not bodies and not robots:
            raise self.error("a scene needs at least one body", "bodies")
        self.check_sizes(bodies)
        names: dict[str, int] = {}
        self.robot_cameras: dict = {}  # filled by self.robot
        self.robots: dict = {}  # {name: Robot}, filled by self.robot
        self.drops: list = []  # (name, key) of the bodies with drop = true, filled by self.body
        for i, body in enumerate(bodies):
            self.body(world, body, f"bodies[{i}]", names)
        for i, robot in enumerate(robots):
            self.robot(world, robot, f"robots[{i}]", names)
        for name, key in self.drops:  # each onto what is below it by then (shape_query.drop)
            self.library(key, world.drop, name)

        forces = doc.get("forces", [])
        if not isinstance(forces, list) or not all(isinstance(f, dict) for f in forces):
            raise self.error(f"expected a list of tables ([[forces]]), got {_describe(forces)}", "forces")
        for i, force in enumerate(forces):
            self.force(world, force, f"forces[{i}]", names)

        exclusions = doc.get("collision_exclusions", [])
        if not isinstance(exclusions, list) or not all(isinstance(e, dict) for e in exclusions):
            raise self.error(f"expected a list of tables ([[collision_exclusions]]), got {_describe(exclusions)}",
                             "collision_exclusions")
        for i, entry in enumerate(exclusions):
            self.exclusion(world, entry, f"collision_exclusions[{i}]", names)
        pairs = doc.get("contact_pairs", [])
        if not isinstance(pairs, list) or not all(isinstance(e, dict) for e in pairs):
            raise self.error(f"expected a list of tables ([[contact_pairs]]), got {_describe(pairs)}", "contact_pairs")
        for i, entry in enumerate(pairs):
            key = f"contact_pairs[{i}]"
            self.table(entry, key, ("bodies", "material"), required=("bodies", "material"))
            a, b = self.body_pair(entry, key, names, "a body has no contacts with itself")
            self.library(key, world.set_pair_material, a, b, self.material(entry["material"], f"{key}.material"))

        from .scene_joints import parse_joint_settings, parse_joints

        self.where = "joints"
        parse_joints(doc.get("joints"), world, self.file)
        self.where = "joint_solver"
        joint_settings = parse_joint_settings(doc.get("joint_solver"), self.file) if "joint_solver" in doc else None
        from .scene_cameras import parse_cameras

        self.where = "cameras"
        cameras = dict(self.robot_cameras)
        for name, camera in parse_cameras(doc.get("cameras"), world, self.file).items():
            if name in cameras:
                raise self.error(f"duplicate camera name {name!r} (a robot's camera has it)", "cameras")
            cameras[name] = camera

        return Scene(
            world=world, duration=sim["duration"], frame_rate=sim["frame_rate"], dt=sim["dt"],
            integrator=sim["integrator"], substeps=sim["substeps"], layout=sim["layout"],
            data=data, rtol=sim["rtol"], atol=sim["atol"], max_energy_growth=sim["max_energy_growth"],
            record_contacts=sim["record_contacts"], contact=contact, joint_settings=joint_settings,
            record_joints=sim["record_joints"], cameras=cameras, robots=dict(self.robots),
        )

    def exclusion(self, world: World, entry: dict, key: str, names: dict):
        """One [[collision_exclusions]] entry: ``bodies = [NAME, NAME]``, two different bodies."""
        self.table(entry, key, ("bodies",), required=("bodies",))
        pair = self.body_pair(entry, key, names, "a body cannot be excluded from itself")
        self.library(key, world.exclude_collision, pair[0], pair[1])

    def body_pair(self, entry: dict, key: str, names: dict, same: str) -> list:
        """``entry["bodies"]``: two names of different bodies (``same``: the problem if equal)."""
        pair = entry["bodies"]
        if not isinstance(pair, list) or len(pair) != 2 or not all(isinstance(n, str) for n in pair):
            raise self.error(f"expected a list of two body names, got {_describe(pair)}", f"{key}.bodies")
        for j, n in enumerate(pair):
            if n not in names:
                raise self.error(f"unknown body {n!r}", f"{key}.bodies[{j}]")
        if pair[0] == pair[1]:
            raise self.error(f"{same} ({pair[0]!r})", f"{key}.bodies")
        return pair

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
            elif k == "impact_chains":
                kw[k] = self.boolean(v, f"contact.{k}")
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
