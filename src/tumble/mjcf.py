"""MJCF models: MuJoCo's XML (``MjModel.from_xml_path``) read into tumble's bodies and joints.

``load_mjcf(world, path, ...)`` reads a MuJoCo model file (https://mujoco.readthedocs.io,
"XML Reference") into the same parsed form as a URDF (``urdf_read.UrdfModel``: a tree of links and
joints) and builds it with the URDF loader's builder (``urdf.build_robot``), so a model from MJCF
is ordinary bodies and joints and gets everything else (contacts, sleeping, checkpoints, export,
readings, the tree solver) unchanged; it returns the same ``urdf.Robot``.

What maps to what:

- ``<body>``: a link whose frame is the body's (``pos`` and one of ``quat`` (w x y z), ``axisangle``,
  ``euler`` (``<compiler eulerseq>``, lowercase axes turning with the frame), ``xyaxes``, ``zaxis``),
  nested bodies their children. Its mass, centre and inertia: its ``<inertial>`` (``mass``, ``pos``,
  orientation, ``diaginertia`` or ``fullinertia``), else its geoms' (each of uniform ``density``,
  default 1000 kg/m^3, or of the given ``mass``; visual-only geoms included, as MuJoCo's
  ``inertiafromgeom``), combined by the parallel-axis theorem. A geom of ``density="0"`` or
  ``mass="0"`` is massless, as MuJoCo compiles it (the visual geoms' idiom): it adds nothing; a
  moving body with no mass (massless geoms, no ``<inertial>``) is one line, as MuJoCo refuses it.
- ``<geom>``: ``sphere``, ``capsule``, ``cylinder`` (``size`` radius and half-length, or ``fromto``),
  ``box`` (half-sizes), ``ellipsoid`` (semi-axes: ``tb.Ellipsoid``), ``mesh`` (an ``<asset><mesh file scale>``, or
  inline ``vertex`` points: its convex hull, as MuJoCo collides meshes), ``plane`` (in ``<worldbody>``). ``friction``'s first number is the body's
  friction (default 1, MuJoCo's; the first colliding geom's when several differ), combined
  with another body's by the larger of the two (MuJoCo's rule: ``Material.friction_combine``
  "max"); ``margin`` the body's ``Material.margin`` with ``load_mjcf(margins=True)`` (MuJoCo's pair rests its
  two margins apart; off by default: ``load_mjcf`` says why). A geom with
  ``contype = conaffinity = 0`` (a visual geom) has mass but no collision shape. The
  ``<worldbody>``'s own geoms become fixed bodies of their own (the floor).
- ``<joint>``: ``hinge`` a ``HingeJoint`` and ``slide`` a ``SliderJoint`` about
  ``axis`` (default z) through ``pos`` (body frame), with ``range`` limits (``limited`` "true", or
  "auto" with ``<compiler autolimits>`` on, MuJoCo's default: a given range is a limit), ``damping``,
  ``stiffness`` towards ``springref`` (a spring drive), ``frictionloss`` (a speed-0 motor limited
  to that torque or force) and ``armature`` (the joint's ``armature``: an inertia added to its
  coordinate's, as MuJoCo adds it to the joint's diagonal of the mass matrix); ``ball`` a ``BallJoint`` whose ``range`` upper value is its swing cone,
  ``stiffness`` and ``damping`` its drive (a spring to the model's pose: MuJoCo's qpos_spring of a
  ball is its qpos0);
  ``free`` (or ``<freejoint>``) no joint: the body is free. A body with no joint is welded to
  its parent (merged into its body; a top-level one is fixed). A body with several joints
  (MuJoCo composes them, the first nearest the parent): a chain through virtual links of
  ``VIRTUAL_FRACTION`` of the body's mass and inertia (``LIGHT_VIRTUAL_FRACTION`` where no
  Gauss-Seidel row acts on their joints: ``_lighten_virtual_links``; bodies "MODEL/BODY/JOINT", touching
  nothing; the parent and the body still do not touch), and ``world.exact_joints`` is set so
  that the Simulator solves joints exactly by default (the tree method: Gauss-Seidel's soft
  rows go wrong by tenths of a radian on such light links, measured against MuJoCo). Joint angles and ``euler`` and
  ``axisangle`` angles are degrees unless ``<compiler angle="radian">`` (MuJoCo's default).
  The joint's coordinate is MuJoCo's qpos: its ``ref`` (default 0) at the model's pose (qpos0).
- ``<compiler inertiafromgeom>``: "auto" (the default: the ``<inertial>`` where there is one),
  "true" (the geoms' where the body has any), "false" (never). ``<compiler settotalmass>``
  (positive): every body's mass and inertia scaled by one factor to that total (Gymnasium's
  half cheetah: 14 kg; read since session 30, the cheetah weighed 21.2 kg before).
- ``<equality>``: ``connect`` (``body1``, ``body2`` or the world, ``anchor`` in body1's frame) a
  ``BallJoint`` closing a loop, ``weld`` a ``FixedJoint`` keeping the model's relative pose, both
  taken at the model's pose (MuJoCo's qpos0) before ``joint_positions`` places the bodies;
  ``joint`` (``joint1``, ``joint2``, ``polycoef``: q1 - q1_0 = a0 + a1 (q2 - q2_0) + ... + a4
  (q2 - q2_0)^4, hinge and slide joints; without joint2, joint1 locked at a0) a ``GearJoint``; in ``Robot.equalities``; rigid
  (MuJoCo's are soft: ``solref``/``solimp`` are not read); a model with one gets the tree solve
  by default. ``active="false"`` ones are left off.
- ``<default>`` classes (nested, ``class`` and ``childclass``) give geoms, joints and actuators
  their attributes, as in MuJoCo. ``<contact><exclude body1 body2>`` excludes a pair;
  ``<contact><pair geom1 geom2 friction condim>`` is a pair material between the two geoms'
  bodies (``World.set_pair_material``), which then collide whatever their masks.
- ``<actuator>`` on joints, in ``Robot.actuators`` by name, driven by ``Robot.set_controls(sim,
  {name: ctrl})`` (MuJoCo's ``data.ctrl``; ctrl starts at 0), in MuJoCo's general form (``mjcf_control.MjcfActuator``:
  force = gain ctrl + b0 + b1 l + b2 l' on l = gear q, the joint's torque gear x force):
  ``<motor>`` (gain 1), ``<position kp kv>``, ``<velocity kv>``, ``<general gainprm biasprm>``
  (``gaintype`` fixed, ``biastype`` none or affine, ``dyntype`` none), with ``gear``, ``ctrlrange`` and
  ``forcerange`` (when limited: ``ctrllimited``/``forcelimited`` true, or auto with the range
  given). The bias's stiffness and damping are a PD drive on the joint (implicit, capped by the
  forcerange), the rest its target or, without stiffness, an applied torque or force (a damper's
  with a forcerange, a velocity actuator's, the drive's target velocity: its force clipped whole,
  as MuJoCo clips it). The joint's
  own ``damping`` and ``stiffness`` + ``springref`` act beside them, as MuJoCo's passive forces: the
  joint's passive spring-damper (``passive_damping``, ``passive_stiffness``, ``springref``), solved
  with the drive as one row whose cap, the forcerange, holds the drive's share alone (MuJoCo caps
  the actuator's force alone; ``joint_solve._drive_and_passive``; docs/robots.md). Refused:
  other gain, bias or activation types, a negative stiffness or damping. Other actuators (``intvelocity``,
  ``damper``, ``cylinder``, ``muscle``, ``adhesion``...) and those on sites are left off. Fixed
  tendons (``<tendon><fixed>``) are read for the motors on them (each joint gets coef gear f), and
  need no more when they have no range, stiffness, damping or friction loss (MuJoCo's default).

Sites and cameras: ``<site>`` frames become ``Robot.sites`` ({name: (link, position, rotation)} in
the link frame; ``Robot.site_pose(name)`` in the world: MuJoCo's ``site_xpos``, ``site_xmat``, and
a site's Jacobian is ``robot.kinematics.jacobian(link, position)``), fixed ``<camera>``s become
``Robot.cameras`` ({name: ``tb.Camera``} mounted on their body, or following it for ``track`` and
``trackcom``: MuJoCo's camera frame looks along -z with y up; ``fovy``; ``resolution``, default
160 x 120).

A body's ``gravcomp`` (MuJoCo's gravity compensation, a force -gravcomp m g at its centre of
mass) is its gravity scale 1 - gravcomp (``World.set_gravity_scale``; ``_gravity_compensation``
for bodies merged into one); a joint's ``actuatorgravcomp="true"`` is refused.
Collisions: the model's bodies touch each other except bodies a joint links (MuJoCo's parent-child
rule, ``self_collision=True`` by default here, unlike ``load_urdf``) and those none of whose geoms
may touch by MuJoCo's ``contype``/``conaffinity`` rule (``mjcf_control._exclude_by_masks``: per body pair; the
masks are not read against the scene's own bodies). Not read, on purpose and documented (docs/robots.md):
``<option>`` but its fluid (set the World's gravity and the Simulator's dt yourself; ``tumble run
model.xml`` takes its ``gravity``; ``density``, ``viscosity`` and ``wind`` are read as a
``tumble.Fluid``: ``load_mjcf(fluid=)``), condim 6's rolling friction, ``solref``,
``solimp``, ``margin`` unless ``load_mjcf(margins=True)``, ``gap``, a ball or free joint's ``armature`` (a hinge's and a slide's are read),
cameras whose ``mode`` is not ``fixed``, lights, the sensors ``mjcf_sensors`` leaves off, visual settings.
``<sensor>``: read by ``mjcf_sensors`` (``Robot.sensor_data``). ``<keyframe>`` keys become
``Robot.keyframes`` (``Robot.reset_to_keyframe``, ``load_mjcf(keyframe=)``: MuJoCo's
``mj_resetDataKeyframe``).
``<include>``: expanded as MuJoCo does (``mjcf_xml``: the included file's top-level children in
its place, paths from the main file's directory; repeated worldbody and compiler sections merged).
``<asset><hfield>`` and ``hfield`` geoms (``<worldbody>`` ones): static terrain
(``shapes.heightfield``), read as MuJoCo's compiler reads them (``mjcf_hfield``).
``<frame>``: its bodies, geoms, joints, sites, cameras and frames placed in its pose, with its
``childclass`` (``mjcf_xml.framed``), as MuJoCo places them. ``<replicate>``: its copies, as
MuJoCo makes them (``mjcf_xml.expand_replicates``: frames in the poses T^i, names suffixed).
Refused with one line: ``<equality>`` other than connect, weld and joint (tendon,
flex; between sites; a weld's ``relpose``), spatial tendons and fixed ones with a range,
stiffness, damping or friction loss, position, velocity and biased actuators on tendons,
``<composite>``, ``<flexcomp>``, ``<attach>``, sdf geoms, hfield geoms on bodies, a free joint beside another joint, and unknown joint or geom types.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from . import checks
from .errors import InputError
from .joints import (P_DAMPING, P_MAX_DRIVE, P_MAX_MOTOR, P_MOTOR_ON, P_MOTOR_SPEED, P_PASSIVE_DAMPING,
                     P_PASSIVE_STIFFNESS, P_SPRINGREF, P_STIFFNESS, P_TARGET_RATE)
from .material import CONDIMS, Material
from .math3d import matrix_to_quat, quat_to_matrix
from .mjcf_hfield import read_hfields
from .shapes import Box, Capsule, Convex, Cylinder, Ellipsoid, Plane, Sphere, heightfield
from .urdf import balanced_inertia
from .mjcf_control import (  # noqa: F401  (MjcfActuator, apply_controls: public here too)
    MjcfActuator,
    _actuators,
    _keyframes,
    _tendons,
    _tendon_servos,
    _add_equalities,
    resolve_dampratios,
    check_keyframes,
    _equalities,
    _exclude_by_masks,
    apply_controls,
)
from .mjcf_control import floats as _floats
from .mjcf_control import whole_number
from .mjcf_sensors import _camera, _sites_and_cameras, read_sensors
from .mjcf_xml import GENERATORS, check_tag as _check_tag, expand_replicates, framed, place, read_model_xml  # noqa: F401
from .urdf_read import UrdfJoint, UrdfLink, UrdfModel

DEFAULT_DENSITY = 1000.0  # kg/m^3, MuJoCo's geom density
DEFAULT_FRICTION = 1.0  # MuJoCo's geom friction (sliding)
DEFAULT_FRICTIONS = (DEFAULT_FRICTION, 0.005, 0.0001)  # MuJoCo's: sliding, torsional (m), rolling (m)
# the mass and inertia of the virtual link between two joints of one body, as a fraction of the
# body's (MuJoCo has nothing there; a moving body needs a mass in maximal coordinates)
VIRTUAL_FRACTION = 1e-3
# ... and where no Gauss-Seidel row acts on the joints beside the virtual link (no limit, spring,
# damper, friction, drive, equality or tendon: the chains the tree solve alone holds, the roots of
# Gymnasium's runners and swimmer), LIGHT_VIRTUAL_FRACTION: their mass is a difference from MuJoCo
# (the swimmer's episode stayed 4e-3 from MuJoCo's however fine the step, its two virtual links
# weighing 0.1 % of it each; 1e-6 converges, tests/test_envs.py). Not everywhere: on a chain with
# stiff slide springs (GS rows) links 1e-6 as heavy left a cart 0.041 off MuJoCo at dt 1/240 s
# where 1e-3 left it 0.01 (tests/physics/test_mjcf.py, the planar cart; measured session 31).
LIGHT_VIRTUAL_FRACTION = 1e-6
GEOM_TYPES = ("plane", "sphere", "capsule", "cylinder", "box", "ellipsoid", "mesh", "hfield")
JOINT_TYPES = ("hinge", "slide", "ball", "free")


@dataclass
class MjcfStatic:
    """A ``<worldbody>`` geom: a fixed body of its own. position (3,), R (3, 3) world."""

    name: str
    shape: object
    position: np.ndarray
    R: np.ndarray
    material: object  # its Material (``_geom``'s surface)


@dataclass
class MjcfModel:
    """A parsed MJCF file: the tree (``model``, links and joints as a URDF's), the worldbody's
    geoms, the actuators' drives {joint: (stiffness, damping, force limit)}, excluded body pairs."""

    model: UrdfModel
    statics: list = field(default_factory=list)
    drives: dict = field(default_factory=dict)
    excluded: list = field(default_factory=list)
    materials: dict = field(default_factory=dict)  # link name: Material of its (first) colliding geom
    virtual: list = field(default_factory=list)  # the links between two joints of one body
    gravcomp: dict = field(default_factory=dict)  # body (and its virtual links) name: its gravcomp, where not 0
    actuators: dict = field(default_factory=dict)  # name: MjcfActuator, the file's order
    # (kind "connect" | "weld", name, body1, body2, anchor (3,)); ("joint", name, joint1, joint2, polycoef (5,))
    equalities: list = field(default_factory=list)
    masks: dict = field(default_factory=dict)  # link name: [(contype, conaffinity)] of its colliding geoms
    geom_links: dict = field(default_factory=dict)  # geom name: its link ("world/NAME" for a worldbody geom)
    pairs: list = field(default_factory=list)  # <contact><pair>: (link1, link2, Material)
    sites: dict = field(default_factory=dict)  # name: (link, position (3,), rotation (3, 3)) in the link frame
    cameras: dict = field(default_factory=dict)  # name: (link, position, rotation, fovy deg, (width, height))
    keyframes: dict = field(default_factory=dict)  # name: (qpos | None, qvel | None, ctrl | None)
    tendons: dict = field(default_factory=dict)  # fixed tendon name: ((joint, coef), ...)
    tendon_servos: list = field(default_factory=list)  # (actuator name, key): biased actuators on tendons
    site_shapes: dict = field(default_factory=dict)  # site name: (type, size (3,) m) (touch sensors)
    anchors: dict = field(default_factory=dict)  # body name: its link frame's origin in the body frame (m)
    sensors: list = field(default_factory=list)  # mjcf_sensors.MjcfSensor, the file's order
    sensors_left_off: list = field(default_factory=list)  # names of the sensors not read
    # link name: (3, 3) its inertia's axes (columns) in the link frame where MuJoCo's compiler takes
    # them from the file (a single geom's frame, an <inertial>'s diaginertia frame): Fluid's boxes
    principal: dict = field(default_factory=dict)
    fluid: tuple | None = None  # <option density viscosity wind>: (kg/m^3, Pa s, (3,) m/s), when either > 0
    ctrl_names: list = field(default_factory=list)  # per actuator element (MuJoCo's ctrl order): its name, None if left off
    refs: dict = field(default_factory=dict)  # hinge or slide joint name: its ``ref`` (rad or m), where not 0


# ---------------------------------------------------------------------- numbers and frames
def _axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """(3, 3) rotation by ``angle`` rad about unit ``axis`` (Rodrigues)."""
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


def _unit(v, key) -> np.ndarray:
    n = float(np.linalg.norm(v))
    if n < 1e-12:
        raise InputError("must not be the zero vector", key)
    return np.asarray(v, dtype=float) / n


def _z_to(z) -> np.ndarray:
    """The smallest rotation taking (0, 0, 1) to unit z (MuJoCo's ``zaxis`` and ``fromto`` frames)."""
    c = float(z[2])
    if c < -1.0 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])  # a half turn about x
    axis = np.array([-z[1], z[0], 0.0])
    s = float(np.linalg.norm(axis))
    if s < 1e-12:
        return np.eye(3)
    return _axis_rotation(axis / s, math.atan2(s, c))


class _Reader:
    """One file's compiler settings and default classes."""

    def __init__(self, root, path: Path):
        self.path = path
        self.pair_geoms: set = set()  # the geoms a <contact><pair> names (``_pairs``): they collide
        compiler = root.find("compiler")
        c = {} if compiler is None else compiler.attrib
        angle = c.get("angle", "degree")
        if angle not in ("degree", "radian"):
            raise InputError(f"expected 'degree' or 'radian', got {angle!r}", "compiler.angle")
        self.angle = math.pi / 180.0 if angle == "degree" else 1.0
        self.eulerseq = c.get("eulerseq", "xyz")
        if len(self.eulerseq) != 3 or any(ch not in "xyzXYZ" for ch in self.eulerseq):
            raise InputError(f"expected three of x, y, z (X, Y, Z), got {self.eulerseq!r}", "compiler.eulerseq")
        self.autolimits = c.get("autolimits", "true") == "true"
        # "auto": a body's <inertial> if it has one, else its geoms'; "true": always the geoms'; "false": never
        self.inertiafromgeom = c.get("inertiafromgeom", "auto")
        if self.inertiafromgeom not in ("auto", "true", "false"):
            raise InputError(f"expected auto, true or false, got {self.inertiafromgeom!r}", "compiler.inertiafromgeom")
        # MuJoCo's settotalmass: when positive, every body's mass and inertia scaled so that they add up to it
        self.settotalmass = float(_floats(c.get("settotalmass", "-1"), "compiler.settotalmass", (1,))[0])
        self.meshdir = path.parent / c.get("meshdir", c.get("assetdir", ""))
        self.hfields: dict = {}  # name: (heights, size, base) of <asset><hfield> (mjcf_hfield.read_hfields)
        self.classes: dict[str, tuple] = {}  # name: (parent name or None, {tag: attributes})
        for d in root.findall("default"):
            self._read_defaults(d, None)
        if "main" not in self.classes:
            self.classes["main"] = (None, {})

    def _read_defaults(self, element, parent):
        name = element.get("class", "main" if parent is None else None)
        if name is None:
            raise InputError("a nested <default> needs a class", "default")
        if name in self.classes:
            raise InputError(f"duplicate default class {name!r}", f"default[{name}]")
        self.classes[name] = (parent, {child.tag: dict(child.attrib) for child in element if child.tag != "default"})
        for child in element.findall("default"):
            self._read_defaults(child, name)

    def attributes(self, element, cls: str, tag: str | None = None) -> dict:
        """The element's attributes over its class's defaults (``class`` or the inherited ``cls``) for
        its tag (or ``tag``: a ``<fixed>`` tendon takes the defaults' ``<tendon>``)."""
        name = element.get("class", cls)
        if name not in self.classes:
            raise InputError(f"unknown default class {name!r}", f"{element.tag}.class")
        chain = []
        while name is not None:
            chain.append(name)
            name = self.classes[name][0]
        merged: dict = {}
        for name in reversed(chain):
            merged.update(self.classes[name][1].get(tag or element.tag, {}))
        merged.update({k: v for k, v in element.attrib.items() if k != "class"})
        return merged

    def orientation(self, a: dict, key: str) -> np.ndarray:
        """(3, 3) of the element's quat, axisangle, euler, xyaxes or zaxis (identity without one)."""
        given = [k for k in ("quat", "axisangle", "euler", "xyaxes", "zaxis") if k in a]
        if len(given) > 1:
            raise InputError(f"give one orientation, got {', '.join(given)}", key)
        if not given:
            return np.eye(3)
        k = given[0]
        kk = f"{key}.{k}"
        if k == "quat":
            q = _unit(_floats(a[k], kk, (4,)), kk)
            return quat_to_matrix(q)
        if k == "axisangle":
            v = _floats(a[k], kk, (4,))
            return _axis_rotation(_unit(v[:3], kk), v[3] * self.angle)
        if k == "euler":
            v = _floats(a[k], kk, (3,)) * self.angle
            R = np.eye(3)
            for ch, angle in zip(self.eulerseq, v):
                Ra = _axis_rotation(np.eye(3)["xyz".index(ch.lower())], angle)
                R = R @ Ra if ch.islower() else Ra @ R  # lowercase: about the turned axes
            return R
        if k == "xyaxes":
            v = _floats(a[k], kk, (6,))
            x = _unit(v[:3], kk)
            y = _unit(v[3:] - (v[3:] @ x) * x, kk)
            return np.column_stack([x, y, np.cross(x, y)])
        return _z_to(_unit(_floats(a[k], kk, (3,)), kk))

    def pose(self, a: dict, key: str) -> tuple:
        """(position (3,), R (3, 3)) of the element in its parent frame."""
        return _floats(a.get("pos", "0 0 0"), f"{key}.pos", (3,)), self.orientation(a, key)


# ---------------------------------------------------------------------- geoms
def _geom(reader: _Reader, a: dict, key: str, meshes: dict):
    """(shape, position (3,), R (3, 3), collides, surface) of a geom's attributes; surface: its
    ``Material``: ``friction``'s first number, ``margin``, and MuJoCo's rule for a pair's friction,
    the larger of the two ("max")."""
    kind = a.get("type", "sphere")
    if kind not in GEOM_TYPES:
        raise InputError(f"unsupported geom type {kind!r} (expected one of {', '.join(GEOM_TYPES)})", f"{key}.type")
    size = _floats(a["size"], f"{key}.size", (1, 2, 3)) if "size" in a else None
    if "fromto" in a and kind in ("capsule", "cylinder"):
        ends = _floats(a["fromto"], f"{key}.fromto", (6,))
        d = ends[3:] - ends[:3]
        half = 0.5 * float(np.linalg.norm(d))
        if half < 1e-12:
            raise InputError("its two ends are the same point", f"{key}.fromto")
        position, R = 0.5 * (ends[:3] + ends[3:]), _z_to(d / (2 * half))
        if size is None:
            raise InputError("missing (the radius)", f"{key}.size")
        size = np.array([size[0], half])
    else:
        position, R = reader.pose(a, key)

    def need(n):
        if size is None or len(size) < n:
            raise InputError(f"a {kind} needs {n} size number{'s' if n > 1 else ''}", f"{key}.size")
        return size

    try:
        if kind == "sphere":
            shape = Sphere(radius=need(1)[0])
        elif kind == "capsule":
            shape = Capsule(radius=need(2)[0], length=2.0 * need(2)[1])
        elif kind == "cylinder":
            shape = Cylinder(radius=need(2)[0], length=2.0 * need(2)[1])
        elif kind == "box":
            shape = Box(size=2.0 * need(3)[:3])
        elif kind == "ellipsoid":
            shape = Ellipsoid(radii=need(3)[:3])
        elif kind == "plane":
            shape = Plane(normal=(0.0, 0.0, 1.0))
        elif kind == "hfield":
            name = a.get("hfield")
            if name not in reader.hfields:
                raise InputError(f"unknown height field {name!r} (not in <asset>)", f"{key}.hfield")
            shape = heightfield(*reader.hfields[name])
        else:
            name = a.get("mesh")
            if name not in meshes:
                raise InputError(f"unknown mesh {name!r} (not in <asset>)", f"{key}.mesh")
            shape = meshes[name]
    except InputError as err:
        raise err.within(key) from None
    contype, conaffinity = _masks(a, key)
    # a geom named in a <contact><pair> collides whatever its masks (MuJoCo's explicit pairs)
    collides = not (contype == 0 and conaffinity == 0) or a.get("name") in reader.pair_geoms
    frictions = _floats(a["friction"], f"{key}.friction", (1, 2, 3)) if "friction" in a else DEFAULT_FRICTIONS
    friction = float(frictions[0])
    if friction < 0:
        raise InputError(f"must be >= 0, got {friction:g}", f"{key}.friction")
    condim = _condim(a, key)
    # the torsional friction (m) with condim 4 or 6: tumble's spinning friction, MuJoCo's the same torque
    # limit (s N); the rolling one (condim 6) is not read: tumble's is per radius (docs/robots.md)
    spinning = float(frictions[1] if len(frictions) > 1 else DEFAULT_FRICTIONS[1]) if condim >= 4 else 0.0
    if spinning < 0:
        raise InputError(f"must be >= 0, got {spinning:g}", f"{key}.friction")
    margin = float(_floats(a["margin"], f"{key}.margin", (1,))[0]) if "margin" in a else 0.0
    if not margin >= 0:
        raise InputError(f"must be >= 0, got {margin:g}", f"{key}.margin")
    return shape, position, R, collides, Material(friction=friction, margin=margin, friction_combine="max",
                                                  condim=condim, spinning_friction=spinning)


def _masks(a: dict, key: str) -> tuple:
    """A geom's (``contype``, ``conaffinity``) bit masks, MuJoCo's default 1 and 1."""
    return tuple(whole_number(a.get(attr, "1"), f"{key}.{attr}", 0, "an integer") for attr in ("contype", "conaffinity"))


def _meshes(reader: _Reader, root) -> dict:
    """{name: Convex} of ``<asset><mesh>`` (the hull of the file's vertices, scaled)."""
    from .mass import _read_mesh_file

    out = {}
    for asset in root.findall("asset"):
        for m in asset.findall("mesh"):
            a = reader.attributes(m, "main")
            file = a.get("file")
            name = a.get("name") or (Path(file).stem if file else None)
            key = f"asset.mesh[{name}]"
            scale = _floats(a.get("scale", "1 1 1"), f"{key}.scale", (3,))
            if not file and "vertex" in a:  # inline vertices (x y z ...): their hull, as MuJoCo collides it
                count = len(a["vertex"].split())
                if count < 12 or count % 3:
                    raise InputError(f"expected at least 4 points of 3 numbers, got {count} numbers", f"{key}.vertex")
                points = _floats(a["vertex"], f"{key}.vertex", (count,)).reshape(-1, 3) * scale
                try:
                    out[name] = Convex(points=points)
                except InputError as err:
                    raise InputError(err.problem, f"{key}.vertex") from None
                continue
            if not file:
                raise InputError("missing file (or inline vertex)", key)
            p = reader.meshdir / file
            if not p.is_file():
                raise InputError(f"mesh file not found: {p}", f"{key}.file")
            checks.check_memory(p.stat().st_size * checks.FILE_EXPANSION, f"reading the mesh file {p}", key,
                                str(reader.path))
            try:
                out[name] = Convex(points=np.asarray(_read_mesh_file(str(p)).vertices, dtype=float) * scale)
            except InputError as err:
                raise InputError(f"{p.name}: {err.problem}", key) from None
    return out


# ---------------------------------------------------------------------- the tree
def read_mjcf(path) -> MjcfModel:
    """Parse and check an MJCF file (module docstring). Raises InputError (file, element, problem)."""
    path = Path(path)
    try:
        return _read(path)
    except InputError as err:
        raise err.within(None, str(path)) from None


def _option(root, name: str, shape: tuple, default, check=None):
    """The ``<option name>`` of a model's root (the last ``<option>`` that gives it, as MuJoCo's
    parser leaves it): an array of ``shape``, else ``default``. ``check(value) -> problem`` (None:
    fine) refuses a bad one with an InputError at ``option.name``."""
    value = default
    for option in root.findall("option"):
        if name in option.attrib:
            value = _floats(option.get(name), f"option.{name}", shape)
            problem = check(value) if check is not None else None
            if problem is not None:
                raise InputError(f"{problem}, got {option.get(name)!r}", f"option.{name}")
    return value


def _read_option(path, name: str, shape: tuple, default, check=None):
    """``_option`` of the MJCF file ``path``; InputError on a bad file or value."""
    path = Path(path)
    try:
        return _option(read_model_xml(path), name, shape, default, check)
    except InputError as err:
        raise err.within(None, str(path)) from None


def read_option_gravity(path) -> np.ndarray:
    """The ``<option gravity>`` of an MJCF file (3,) m/s^2 (MuJoCo's default 0 0 -9.81). InputError on a bad file."""
    return _read_option(path, "gravity", (3,), np.array([0.0, 0.0, -9.81]))


def read_option_timestep(path) -> float:
    """The ``<option timestep>`` of an MJCF file, s (MuJoCo's default 0.002). InputError on a bad file
    or a step that is not one positive number."""
    value = _read_option(path, "timestep", (1,), np.array([0.002]),
                         lambda v: None if v[0] > 0.0 else "expected a positive number of seconds")
    return float(value[0])


def _lighten_virtual_links(out: MjcfModel):
    """Make the virtual links that no Gauss-Seidel row touches ``LIGHT_VIRTUAL_FRACTION`` of their
    body's mass and inertia instead of ``VIRTUAL_FRACTION`` (the constants say why): those whose two
    joints have no limit, spring, damper, friction, actuator drive, joint equality or tendon.
    (Armature is a row of the joint's own tree block, and motors apply efforts: they do not count.)"""
    coupled = {name for eq in out.equalities if eq[0] == "joint" for name in eq[2:4]}
    for terms in out.tendons.values():
        coupled.update(joint for joint, _coef in terms)
    for name in out.virtual:
        beside = [j for j in out.model.joints if name in (j.parent, j.child)]
        if any(j.lower is not None or j.upper is not None or j.damping != 0.0 or j.stiffness != 0.0
               or j.friction != 0.0 or j.name in out.drives or j.name in coupled for j in beside):
            continue
        link = out.model.links[name]
        scale = LIGHT_VIRTUAL_FRACTION / VIRTUAL_FRACTION
        link.mass *= scale
        link.inertia = link.inertia * scale


def _read_fluid(root):
    """``<option density viscosity wind>``: (density kg/m^3, viscosity Pa s, wind (3,) m/s) when the
    density or the viscosity is above 0 (MuJoCo's fluid forces on), else None."""
    def non_negative(value):
        return None if value[0] >= 0.0 else "must be >= 0"

    density = float(_option(root, "density", (1,), np.zeros(1), non_negative)[0])
    viscosity = float(_option(root, "viscosity", (1,), np.zeros(1), non_negative)[0])
    wind = _option(root, "wind", (3,), np.zeros(3))
    if density > 0.0 or viscosity > 0.0:
        return density, viscosity, tuple(float(w) for w in wind)
    return None


def _read(path: Path) -> MjcfModel:
    root = read_model_xml(path)  # includes expanded (MuJoCo Menagerie's scene.xml + robot.xml)
    reader = _Reader(root, path)
    expand_replicates(root, reader)
    meshes = _meshes(reader, root)
    reader.hfields = read_hfields(reader, root)
    pairs = _pairs(reader, root)
    reader.pair_geoms = {g for _, g1, g2, _ in pairs for g in (g1, g2)}
    out = MjcfModel(UrdfModel(root.get("model") or path.stem, {"world": UrdfLink("world")}, [], "world", str(path)))
    worldbody = root.find("worldbody")
    if worldbody is None:
        raise InputError("missing <worldbody>", "mujoco")
    names: set = {"world"}
    joint_names: set = set()
    for k, (g, cls, frame) in enumerate(framed(reader, worldbody, ("geom",), "main", "worldbody")):
        a = reader.attributes(g, cls)
        name = a.get("name", f"geom{k}")
        if any(s.name == name for s in out.statics):
            raise InputError("duplicate geom name", f"worldbody.geom[{name}]")
        shape, position, R, collides, surface = _geom(reader, a, f"worldbody.geom[{name}]", meshes)
        position, R = place(frame, position, R)
        out.geom_links[name] = f"world/{name}"
        if collides:
            out.statics.append(MjcfStatic(name, shape, position, R, surface))
            out.masks[f"world/{name}"] = [_masks(a, f"worldbody.geom[{name}]")]
    for child in worldbody:
        _check_tag(child, "worldbody")
    _sites_and_cameras(reader, worldbody, "main", "worldbody", "world", np.zeros(3), out)
    counter = [0]
    for b, cls, frame in framed(reader, worldbody, ("body",), "main", "worldbody"):
        _body(reader, b, "world", cls, np.zeros(3), out, meshes, names, joint_names, counter, frame)
    if reader.settotalmass > 0.0:
        _set_total_mass(out, reader.settotalmass)
    out.fluid = _read_fluid(root)
    _tendons(reader, root, out, joint_names)
    _actuators(reader, root, out, joint_names)
    _equalities(reader, root, out, names)
    _tendon_servos(out)
    _keyframes(root, out)
    _lighten_virtual_links(out)
    read_sensors(root, out)
    for key, g1, g2, material in pairs:
        for role, geom in (("geom1", g1), ("geom2", g2)):
            if geom not in out.geom_links:
                raise InputError(f"unknown geom {geom!r}", f"{key}.{role}")
        out.pairs.append((out.geom_links[g1], out.geom_links[g2], material))
    for contact in root.findall("contact"):
        for e in contact.findall("exclude"):
            pair = (e.get("body1"), e.get("body2"))
            for role, body in zip(("body1", "body2"), pair):
                if body not in names:
                    raise InputError(f"unknown body {body!r}", f"contact.exclude.{role}")
            out.excluded.append(pair)
    return out


def _condim(a: dict, key: str) -> int:
    """A geom's or pair's ``condim`` (MuJoCo's default 3): one of ``material.CONDIMS``, else an
    InputError at ``key.condim``."""
    if "condim" not in a:
        return 3
    condim = int(_floats(a["condim"], f"{key}.condim", (1,))[0])
    if condim not in CONDIMS:
        raise InputError(f"expected 1, 3, 4 or 6, got {a['condim']}", f"{key}.condim")
    return condim


def _pairs(reader: _Reader, root) -> list:
    """``<contact><pair geom1 geom2 friction condim>``: [(key, geom1, geom2, Material)], the pair's
    sliding friction (``friction``'s first number; MuJoCo's default 1, not the geoms') and condim
    (default 3) as a pair material (``World.set_pair_material``)."""
    out = []
    for contact in root.findall("contact"):
        for k, p in enumerate(contact.findall("pair")):
            a = reader.attributes(p, "main")
            key = f"contact.pair[{a.get('name', k)}]"
            for role in ("geom1", "geom2"):
                if role not in a:
                    raise InputError("missing (a geom's name)", f"{key}.{role}")
            friction = float(_floats(a["friction"], f"{key}.friction", (1, 2, 3, 4, 5))[0]) if "friction" in a else 1.0
            if not friction >= 0:
                raise InputError(f"must be >= 0, got {friction:g}", f"{key}.friction")
            out.append((key, a["geom1"], a["geom2"], Material(friction=friction, condim=_condim(a, key))))
    return out


def _set_total_mass(out: MjcfModel, total: float):
    """``<compiler settotalmass>``: every link's mass and inertia times one factor, so that the model's
    bodies weigh ``total`` kg (MuJoCo's ``mj_setTotalmass``; the virtual links between the joints
    of one body are not MuJoCo's bodies: left out of the sum, scaled with their body)."""
    links = out.model.links
    present = sum(link.mass for name, link in links.items() if name != "world" and name not in out.virtual)
    if not present > 0.0:
        raise InputError("the model has no mass to scale", "compiler.settotalmass")
    factor = total / present
    for link in links.values():
        link.mass *= factor
        link.inertia = link.inertia * factor


def _body(reader, element, parent: str, cls: str, shift: np.ndarray, out: MjcfModel, meshes, names, joint_names,
          counter, frame=None):
    """Add one ``<body>`` (and its subtree) as a link; ``shift`` (3,): the parent link frame's
    origin in the parent body's frame (its joint's ``pos``); ``frame``: the pose of the ``<frame>``
    holding it in the parent body's frame (``mjcf_xml.framed``), None outside frames."""
    counter[0] += 1
    name = element.get("name") or f"body{counter[0]}"
    key = f"body[{name}]"
    if name in names:
        raise InputError("duplicate body name", key)
    names.add(name)
    cls = element.get("childclass", cls)
    if cls not in reader.classes:
        raise InputError(f"unknown default class {cls!r}", f"{key}.childclass")
    position, R = place(frame, *reader.pose(element.attrib, key))
    position = position - shift
    for child in element:
        _check_tag(child, key)
    link = UrdfLink(name)
    specs = []  # (joint name, key, kind, attributes, anchor (3,) body frame)
    for je, jcls, jframe in framed(reader, element, ("joint", "freejoint"), cls, key):
        a = reader.attributes(je, jcls) if je.tag == "joint" else {"type": "free", **je.attrib}
        jname = a.get("name") or f"{name}_joint{len(specs) if specs else ''}"
        jkey = f"joint[{jname}]"
        if jname in joint_names:
            raise InputError("duplicate joint name", jkey)
        joint_names.add(jname)
        kind = a.get("type", "hinge")
        if a.get("actuatorgravcomp", "false") == "true":
            # MuJoCo then routes the joint's share of gravcomp through its actuators (capped by their
            # forcerange) instead of applying it passively: not modelled
            raise InputError("actuatorgravcomp (gravity compensation through the actuators) is not supported; "
                             "without it the body's gravcomp acts passively", f"{jkey}.actuatorgravcomp")
        if kind not in JOINT_TYPES:
            raise InputError(f"unknown joint type {kind!r} (expected one of {', '.join(JOINT_TYPES)})", f"{jkey}.type")
        anchor = np.zeros(3) if kind == "free" else _floats(a.get("pos", "0 0 0"), f"{jkey}.pos", (3,))
        if jframe is not None and kind != "free":
            anchor = place(jframe, anchor, np.eye(3))[0]
        specs.append((jname, jkey, kind, a, anchor, jframe))
    if len(specs) > 1 and any(spec[2] == "free" for spec in specs):
        raise InputError("a free joint must be its body's only joint", key)
    anchor = specs[-1][4] if specs else np.zeros(3)
    _mass_and_shapes(reader, element, cls, key, anchor, link, out, meshes)
    if "gravcomp" in element.attrib:  # a body attribute, not a default class's (MuJoCo's XML reference)
        gravcomp = float(_floats(element.get("gravcomp"), f"{key}.gravcomp", (1,))[0])
        if gravcomp != 0.0:
            out.gravcomp[name] = gravcomp
    # several joints in one body (MuJoCo composes them, the first nearest the parent, with nothing
    # between): a chain of links, each joint's child a virtual link of VIRTUAL_FRACTION of the body's
    # mass and inertia, the last joint's child the body. Its frame: the body frame moved to the
    # joint's anchor (a URDF joint turns about its child's origin).
    previous, previous_anchor = parent, None
    if not specs:
        out.model.joints.append(UrdfJoint(f"{name}_weld", "fixed", parent, name, (position, R),
                                          np.array([1.0, 0.0, 0.0])))
    for k, (jname, jkey, kind, a, at, jframe) in enumerate(specs):
        child = name if k == len(specs) - 1 else f"{name}/{jname}"
        joint = _joint(reader, a, jname, jkey, kind, previous, child)
        if jframe is not None:  # the axis, given in the frame
            joint.axis = jframe[1] @ joint.axis
        joint.origin = (position + R @ at, R) if previous_anchor is None else (at - previous_anchor, np.eye(3))
        ref = _joint_ref(reader, a, jkey, kind)
        if ref != 0.0:
            # MuJoCo's ``ref``: the file's pose is the joint at q = ref (qpos0), so the joint's zero is
            # the child moved by -ref from it: the origin T0 becomes T0 T_joint(-ref), and T(q) = T0
            # T_joint(-ref) T_joint(q) is the file's pose at q = ref. tumble's coordinate is then
            # MuJoCo's qpos itself (limits, springref, servos' targets, keyframes, sensors), and the
            # model starts at q = ref (``_build``). Read as 0 before, the target of Gymnasium's
            # reacher read 0 where MuJoCo reads its ref (0.1, -0.1), and its range sat 0.1 m aside.
            p0, R0 = joint.origin
            joint.origin = ((p0 - ref * (R0 @ joint.axis), R0) if kind == "slide"
                            else (p0, R0 @ _axis_rotation(joint.axis, -ref)))
            out.refs[jname] = ref
        out.model.joints.append(joint)
        if child != name:
            if link.mass <= 0.0:
                raise InputError("a body with several joints needs a mass", key)
            virtual = UrdfLink(child, mass=VIRTUAL_FRACTION * link.mass,
                               inertia=VIRTUAL_FRACTION * balanced_inertia(link.inertia))
            out.model.links[child] = virtual
            out.virtual.append(child)
            if name in out.gravcomp:
                out.gravcomp[child] = out.gravcomp[name]
        previous, previous_anchor = child, at
    if len(specs) > 1:  # MuJoCo's parent-child rule, across the virtual links
        out.excluded.append((parent, name))
    out.model.links[name] = link
    out.anchors[name] = anchor
    _sites_and_cameras(reader, element, cls, key, name, anchor, out)
    for b, bcls, frame in framed(reader, element, ("body",), cls, key):
        _body(reader, b, name, bcls, anchor, out, meshes, names, joint_names, counter, frame)


def _joint(reader, a, jname, jkey, kind, parent, child) -> UrdfJoint:
    kinds = {"hinge": "revolute", "slide": "prismatic", "ball": "spherical", "free": "floating"}
    axis = _unit(_floats(a.get("axis", "0 0 1"), f"{jkey}.axis", (3,)), f"{jkey}.axis")
    j = UrdfJoint(jname, kinds[kind], parent, child, (np.zeros(3), np.eye(3)), axis)
    if kind == "free":
        return j
    limited = a.get("limited", "auto")
    if limited not in ("true", "false", "auto"):
        raise InputError(f"expected true, false or auto, got {limited!r}", f"{jkey}.limited")
    has_range = "range" in a
    on = limited == "true" or (limited == "auto" and reader.autolimits and has_range)
    if on:
        if not has_range:
            raise InputError("limited without a range", f"{jkey}.range")
        lo, hi = _floats(a["range"], f"{jkey}.range", (2,))
        if lo > hi:
            raise InputError(f"the range is the wrong way round: {lo:g} > {hi:g}", f"{jkey}.range")
        scale = reader.angle if kind in ("hinge", "ball") else 1.0
        if kind == "ball":
            j.cone_limit = hi * scale
        else:
            j.lower, j.upper = lo * scale, hi * scale
    elif kind == "hinge":
        j.kind = "continuous"
    for attr, field_name in (("damping", "damping"), ("stiffness", "stiffness"), ("frictionloss", "friction"),
                             ("armature", "armature")):
        if attr in a:
            value = float(_floats(a[attr], f"{jkey}.{attr}", (1,))[0])
            if value < 0:
                raise InputError(f"must be >= 0, got {value:g}", f"{jkey}.{attr}")
            if kind == "ball" and value > 0 and attr in ("armature", "frictionloss"):
                if attr == "armature":
                    continue  # not read on a ball joint (module docstring)
                raise InputError(f"a ball joint's {attr} is not supported", f"{jkey}.{attr}")
            setattr(j, field_name, value)
    if "springref" in a:
        j.target = float(_floats(a["springref"], f"{jkey}.springref", (1,))[0]) * (
            reader.angle if kind == "hinge" else 1.0)
    return j


def _joint_ref(reader, a, jkey, kind) -> float:
    """A hinge's or slide's ``ref`` (rad or m; MuJoCo reads it on those two kinds only): the joint's
    value at the model's pose, MuJoCo's qpos0."""
    if kind not in ("hinge", "slide") or "ref" not in a:
        return 0.0
    return float(_floats(a["ref"], f"{jkey}.ref", (1,))[0]) * (reader.angle if kind == "hinge" else 1.0)


def _mass_and_shapes(reader, element, cls, key, anchor, link: UrdfLink, out: MjcfModel, meshes):
    """The link's collision parts and mass properties (link frame: the body frame less ``anchor``)."""
    from .mass import combine_mass_properties, mass_properties

    terms = []  # (mass, centre, inertia about the centre) in the link frame
    geom_frames = []  # each term's geom frame in the link frame
    surfaces = []
    for k, (g, gcls, frame) in enumerate(framed(reader, element, ("geom",), cls, key)):
        a = reader.attributes(g, gcls)
        gkey = f"{key}.geom[{a.get('name', k)}]"
        shape, position, R, collides, surface = _geom(reader, a, gkey, meshes)
        if "name" in a:
            out.geom_links[a["name"]] = link.name
        if isinstance(shape, Plane) or a.get("type") == "hfield":
            raise InputError(f"a {a.get('type')} must be a <worldbody> geom (tumble's are static)", gkey)
        position, R = place(frame, position, R)
        position = position - anchor
        if collides:
            link.parts.append((shape, position, R))
            surfaces.append(surface)
            out.masks.setdefault(link.name, []).append(_masks(a, gkey))
        # the geom's mass (its ``mass``, else ``density``, MuJoCo's precedence); 0 is a massless geom, as
        # MuJoCo compiles it (the visual geoms' ``density="0"`` idiom): it adds nothing to the body's
        # mass, centre, inertia or inertial frame (refused as "must be positive" before)
        attr = "mass" if "mass" in a else "density"
        amount = float(_floats(a.get(attr, str(DEFAULT_DENSITY)), f"{gkey}.{attr}", (1,))[0])
        if amount < 0.0:
            raise InputError(f"must be >= 0, got {amount:g}", f"{gkey}.{attr}")
        if amount == 0.0:
            continue
        try:
            props = mass_properties(shape, **{attr: amount})
        except InputError as err:
            raise err.within(gkey) from None
        terms.append((props.mass, position + R @ np.asarray(props.center), R @ np.asarray(props.inertia) @ R.T))
        geom_frames.append(R)
    if surfaces:
        out.materials[link.name] = surfaces[0]
    inertial = element.find("inertial")
    if inertial is not None and not (reader.inertiafromgeom == "true" and terms):
        ikey = f"{key}.inertial"
        a = inertial.attrib
        if "mass" not in a:
            raise InputError("missing mass", ikey)
        position, R = reader.pose(a, ikey)
        link.mass = float(_floats(a["mass"], f"{ikey}.mass", (1,))[0])
        if "diaginertia" in a:
            I = np.diag(_floats(a["diaginertia"], f"{ikey}.diaginertia", (3,)))
        elif "fullinertia" in a:
            xx, yy, zz, xy, xz, yz = _floats(a["fullinertia"], f"{ikey}.fullinertia", (6,))
            I = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        else:
            raise InputError("missing diaginertia or fullinertia", ikey)
        link.center = position - anchor
        link.inertia = R @ I @ R.T
        if "diaginertia" in a:
            out.principal[link.name] = R
        return
    if reader.inertiafromgeom == "false":
        return  # massless: welded into its parent, or an error if it moves (the builder's)
    mass, center, inertia = combine_mass_properties(terms)
    if mass > 0.0:
        link.mass, link.center, link.inertia = float(mass), center, inertia
        if len(terms) == 1:  # MuJoCo's compiler takes a lone geom's frame as the body's inertial frame
            out.principal[link.name] = geom_frames[0]


# ---------------------------------------------------------------------- loading
def load_mjcf(world, path, *, position=(0.0, 0.0, 0.0), orientation=None, euler_deg=None, self_collision=True,
              joint_positions=None, material=None, collision_filter=None, name=None, inertia="file",
              joint_motors=None, joint_targets=None, keyframe=None, world_geoms=True, fluid=True, margins=False):
    """Add the model of an MJCF file to ``world`` (module docstring) and return it as a ``urdf.Robot``
    (links by body name, joints by joint name; bodies named "MODEL/BODY", the worldbody's geoms
    "MODEL/world/GEOM").

    Args:
        world: the ``World``. path: the MJCF file.
        position, orientation | euler_deg: where the model's world frame goes.
        self_collision: the model's bodies touch each other except jointed ones (default, MuJoCo's
            rule); False: none of them touch each other.
        joint_positions: {joint: rad or m}, the start (MuJoCo's qpos; the joints' ``ref``, 0 unless
            given, is the model's pose).
        joint_motors, joint_targets: as ``load_urdf``'s (``joint_targets`` add to and override the
            file's actuators' drives; the actuators on those joints are left at the caller's drive).
        material: the bodies' material (default: friction from the geoms, MuJoCo's 1 where unset).
        collision_filter, name, inertia: as ``load_urdf``'s.
        keyframe: the name of a ``<keyframe>`` key to start in (``Robot.reset_to_keyframe``), after
            ``joint_positions``.
        world_geoms: False leaves off the ``<worldbody>``'s own geoms (the file's floor): for a scene
            that has its own ground, or a model loaded many times over one floor (``tumble.envs``).
        fluid: the file's ``<option density viscosity wind>`` (MuJoCo's fluid forces, its inertia-box
            model) as a ``tumble.Fluid`` on the model's moving bodies (``robot.fluid``; default); False
            leaves it off.
        margins: True reads the geoms' ``margin`` as the bodies' ``Material.margin`` (a pair rests its
            two margins apart, as in MuJoCo: Gymnasium's ant stands 2 cm higher, its torso at
            MuJoCo's height to 0.2 mm). Off by default: a body whose joints keep it from leaving a
            contact within its margins is pushed against them (Gymnasium's pusher's object, held in
            z on its table, rises 2.2 mm out of its joints; MuJoCo's reduced coordinates cannot),
            and PyBullet's thrower (links of 1e-9 kg) blows up when its hand meets the ball within
            them (measured). The file's values are checked either way.

    Raises:
        InputError: a bad file or argument, one line (file, element, problem).
    """

    parsed = read_mjcf(path)
    model = parsed.model
    if material is None:
        for link_name, surface in parsed.materials.items():
            model.links[link_name].material = surface if margins else replace(surface, margin=0.0)
    # the actuators' springs and dampers, per joint: a PD drive (its target and the applied efforts are
    # the controls': set for ctrl = 0 once the robot is built), and the joint's own spring (stiffness
    # to springref) and damper beside it as the joint's passive spring-damper (MuJoCo's passive
    # forces act beside the actuators'), which the actuators' forcerange, the drive's cap, does not
    # hold (``joint_solve._drive_and_passive``). History: the passive terms took the drive's place
    # first (robot audit: a servoed joint's damping=1 rang undamped), then were summed into the drive
    # and capped with it (session 42: a saturated servo lost its joint's damper)
    passive = {j.name: (j.stiffness, j.target, j.damping) for j in model.joints if j.name in parsed.drives}
    targets = {}
    for j, (kp, kv, limit) in parsed.drives.items():
        if kp > 0.0 or kv > 0.0:
            targets[j] = {"position": 0.0, "stiffness": kp, "damping": kv,
                          # capped by a forcerange: a position servo's, or a velocity servo's
                          **({} if math.isinf(limit) or (kp == 0.0 and limit == 0.0) else {"max_force": limit})}
    given = joint_targets or {}
    targets.update(given)
    try:
        robot = _build(world, parsed, material, targets, position=position, orientation=orientation,
                       euler_deg=euler_deg, self_collision=self_collision, joint_positions=joint_positions,
                       collision_filter=collision_filter, name=name, inertia=inertia, joint_motors=joint_motors,
                       world_geoms=world_geoms, fluid=fluid, margins=margins)
        # the file's drives' joints' own (stiffness, springref, damping), as their passive spring-damper;
        # not the joints given ``joint_targets`` (the caller's drive takes the place of their own, as
        # ``load_urdf``'s)
        robot.joint_passive = {j: v for j, v in passive.items() if j in targets and j not in given}
        for joint, (k, springref, c) in robot.joint_passive.items():
            robot._write(None, joint, {P_PASSIVE_STIFFNESS: k, P_SPRINGREF: springref, P_PASSIVE_DAMPING: c},
                         {"passive_stiffness": k, "springref": springref, "passive_damping": c})
        resolve_dampratios(robot)
        # each servoed joint's drive as loaded (the actuators' stiffness, damping and cap, and the motor
        # it has now: the file's friction or the caller's ``joint_motors``): ``set_controls`` writes it
        # back over a ``set_motor`` or ``set_position_target`` (one control mode a joint). NOTE: why: a
        # servo's ctrl written after a set_motor went into the motor's drive of stiffness 0 and the
        # servo never acted (session 43)
        robot.servo_drives = {}
        for joint in robot.joint_passive:
            record = robot.joints[joint]
            max_drive, max_motor = robot._field(joint, "max_drive"), robot._field(joint, "max_motor")
            motor_on = record.motor_speed is not None
            robot.servo_drives[joint] = (
                {P_MOTOR_ON: float(motor_on), P_MOTOR_SPEED: record.motor_speed if motor_on else 0.0,
                 P_MAX_MOTOR: getattr(record, max_motor), P_STIFFNESS: record.stiffness, P_DAMPING: record.damping,
                 P_MAX_DRIVE: getattr(record, max_drive), P_TARGET_RATE: 0.0},
                {"motor_speed": record.motor_speed, max_motor: getattr(record, max_motor),
                 "stiffness": record.stiffness, "damping": record.damping, max_drive: getattr(record, max_drive),
                 "target_velocity": 0.0})
        # the controls at 0 (MuJoCo's start): a general actuator's bias b0 is a target or an effort; the
        # joints given ``joint_targets`` keep the caller's drive
        apply_controls(robot, None, {n: 0.0 for n, a in robot.actuators.items() if a.joint not in given})
        if keyframe is not None:
            robot.reset_to_keyframe(keyframe)
    except InputError as err:
        raise err if err.file else err.within(None, str(path)) from None
    return robot


def _build(world, parsed: MjcfModel, material, targets, *, position, orientation, euler_deg, self_collision,
           joint_positions, collision_filter, name, inertia, joint_motors, world_geoms=True, fluid=True,
           margins=False):
    from .urdf import MOVING_KINDS, build_robot

    model = parsed.model
    # the model's pose is its joints at their ``ref`` (MuJoCo's qpos0; 0 where not given)
    start = {**parsed.refs, **(joint_positions or {})}
    robot = build_robot(world, model, position=position, orientation=orientation, euler_deg=euler_deg,
                        fixed_base=True, merge_fixed=True, self_collision=self_collision,
                        joint_positions=(parsed.refs or None) if parsed.equalities else (start or None),
                        material=material,
                        collision_filter=collision_filter, name=name, inertia=inertia, joint_motors=joint_motors,
                        joint_targets=targets or None)
    if parsed.equalities:
        _add_equalities(world, robot, parsed.equalities, parsed.refs)
        # a loop closed by a joint: Gauss-Seidel's soft rows left a four-bar 0.047 rad off MuJoCo's
        # stiff loop in 1 s (and more at a finer dt), the tree solve 6e-3, first order (measured)
        world.exact_joints = True
        if joint_positions:  # placed after the equality joints took their anchors at the model's pose (MuJoCo's qpos0)
            # every moving joint named (the ones not in ``start`` at 0, the model's pose): the joints not
            # named would keep the pose's readings, equal but for rounding
            robot.reset_joint_positions(None, {**{j.name: 0.0 for j in model.joints if j.kind in MOVING_KINDS},
                                               **start})
    if parsed.virtual:  # light links between the joints of one body: the Simulator solves joints exactly
        world.exact_joints = True
    if parsed.gravcomp:
        _gravity_compensation(world, robot, parsed)
    base_p, base_R = robot.link_pose("world")
    statics = parsed.statics if world_geoms else []
    masks = parsed.masks if world_geoms else {k: v for k, v in parsed.masks.items() if not k.startswith("world/")}
    for s in statics:
        body_material = material if material is not None else s.material if margins else replace(s.material, margin=0.0)
        body = world.add_body(s.shape, fixed=True, position=base_p + base_R @ s.position,
                              orientation=matrix_to_quat(np.ascontiguousarray(base_R @ s.R)), material=body_material,
                              name=f"{robot.name}/world/{s.name}",
                              **({} if collision_filter is None else {"collision_filter": collision_filter}))
        robot.links[f"world/{s.name}"] = body
    # explicit pairs (<contact><pair>) collide whatever the masks and <exclude>s say, as in MuJoCo
    pairs = [(robot.links[a], robot.links[b], m) for a, b, m in parsed.pairs if a in robot.links and b in robot.links]
    paired = {(min(a.index, b.index), max(a.index, b.index)) for a, b, _ in pairs}
    for a, b in parsed.excluded:
        ia, ib = robot.links[a].index, robot.links[b].index
        if (min(ia, ib), max(ia, ib)) not in paired:
            world.exclude_collision(ia, ib)
    _exclude_by_masks(world, robot, masks, keep=paired)
    for a, b, m in pairs:
        if a.index != b.index:  # two geoms of one tumble body (welded bodies) never touch
            world.set_pair_material(a, b, m)
    robot.actuators = dict(parsed.actuators)
    robot.sites = dict(parsed.sites)
    robot.sensors = {sensor.name: sensor for sensor in parsed.sensors}
    robot.sensors_left_off = list(parsed.sensors_left_off)
    robot.site_shapes = dict(parsed.site_shapes)
    robot.tendons = dict(parsed.tendons)
    robot.anchors = dict(parsed.anchors)
    robot.virtual_links = list(parsed.virtual)
    robot.keyframes = dict(parsed.keyframes)
    robot.ctrl_names = list(parsed.ctrl_names)
    check_keyframes(robot, parsed.keyframes, parsed.ctrl_names)
    # MuJoCo's qpos0: the model's pose (hinges and slides at 0, balls at the identity, free joints
    # where the file puts them, as they are now), the default of a key without qpos
    robot.qpos0 = robot.kinematics.neutral()
    robot.joint_refs = dict(parsed.refs)
    for c in robot.kinematics.coordinates:
        if c.name in parsed.refs:
            robot.qpos0[c.qpos] = parsed.refs[c.name]
    robot.cameras = {name: _camera(robot, *spec) for name, spec in parsed.cameras.items()}
    if parsed.fluid is not None and fluid:
        robot.fluid = _add_fluid(world, robot, parsed, inertia)
    return robot


def _gravity_compensation(world, robot, parsed: MjcfModel):
    """MuJoCo's ``gravcomp``: a force -gravcomp m g at each body's centre of mass (a passive force,
    mj_passive), as the gravity scale 1 - gravcomp of the tumble body (``World.set_gravity_scale``;
    the same force at the same point). Bodies merged into one (a body with no joint is welded to
    its parent) take 1 - sum(c m) / sum(m): the whole force; where their gravcomps differ, the
    torque of the difference about the merged centre of mass is left out and a TumbleWarning says
    so."""
    import warnings

    from .errors import TumbleWarning

    totals: dict = {}  # tumble body's link: [sum m, sum c m, the gravcomps]
    for link, owner in robot.owners.items():
        part = parsed.model.links.get(link)
        if part is None:
            continue
        t = totals.setdefault(owner, [0.0, 0.0, set()])
        c = parsed.gravcomp.get(link, 0.0)
        t[0] += part.mass
        t[1] += c * part.mass
        t[2].add(c)
    for owner, (m, cm, gravcomps) in totals.items():
        if cm == 0.0 or m <= 0.0 or owner not in robot.links:
            continue
        if len(gravcomps) > 1:
            warnings.warn(f"bodies merged into {owner!r} have different gravcomp ({', '.join(f'{c:g}' for c in sorted(gravcomps))}): "
                          "their mass-weighted mean is applied at the merged centre of mass (the torque of the "
                          "difference is left out)", TumbleWarning, stacklevel=4)
        world.set_gravity_scale(robot.links[owner], 1.0 - cm / m)


def _add_fluid(world, robot, parsed: MjcfModel, inertia: str):
    """The file's fluid (``<option density viscosity wind>``) as a ``forces.Fluid`` on the model's
    moving bodies (not the virtual links between the joints of one body: MuJoCo has none), each box
    along MuJoCo's inertial frame where the file gives it (``MjcfModel.principal``), else along the
    principal axes of the body's inertia. Returns the record (added to ``world``)."""
    from .forces import Fluid, fluid_box

    density, viscosity, wind = parsed.fluid
    bodies, frames = [], []
    for link, body in robot.links.items():
        if link in robot.virtual_links or link.startswith("world") or robot.owners.get(link) != link:
            continue
        i = body.index
        if not world.moving[i] or world.mass[i] <= 0.0:
            continue
        merged = sum(1 for owner in robot.owners.values() if owner == link) > 1
        frame = parsed.principal.get(link) if inertia == "file" and not merged else None
        if frame is None:
            frame = fluid_box(float(world.mass[i]), world.inertia_body[i])[1]
        bodies.append(body)
        frames.append(np.asarray(frame, dtype=float))
    record = Fluid(density=density, viscosity=viscosity, wind=wind, bodies=bodies, frames=frames)
    world.add_force(record)
    return record
