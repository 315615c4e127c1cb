"""Reading URDF files: the XML into plain records (``UrdfModel``), checked; ``tumble.urdf`` builds
them into a world (its docstring says what each element becomes).

Every problem is an ``InputError`` keyed by the element, e.g. ``joint[elbow].limit.lower``, and
``read_urdf`` puts the file in front of it.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import checks
from .errors import InputError
from .material import Material
from .math3d import quat_from_euler_deg, quat_to_matrix
from .shapes import Box, Capsule, Convex, Cylinder, Plane, Sphere

JOINT_KINDS = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar", "spherical")


# ---------------------------------------------------------------------- the file, as read


@dataclass
class UrdfLink:
    """One ``<link>``: ``mass`` kg (0 without ``<inertial>``), ``center`` (3,) m and ``inertia``
    (3, 3) kg m^2 about it, both in the link frame; ``parts``: [(shape, position (3,) m,
    rotation (3, 3))] in the link frame; ``material``: from Bullet's ``<contact>``, or None."""

    name: str
    mass: float = 0.0
    center: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    parts: list = field(default_factory=list)
    material: Material | None = None


@dataclass
class UrdfJoint:
    """One ``<joint>``: ``origin`` (position (3,) m, rotation (3, 3)) of the child link frame in the
    parent's; ``axis`` (3,) unit, child frame; ``lower``, ``upper`` (None: no limit), ``effort``
    N m or N (None: not given), ``velocity``, ``damping``, ``friction``."""

    name: str
    kind: str
    parent: str
    child: str
    origin: tuple
    axis: np.ndarray
    lower: float | None = None
    upper: float | None = None
    effort: float | None = None
    velocity: float | None = None
    damping: float = 0.0
    friction: float = 0.0
    stiffness: float = 0.0  # a spring towards ``target`` (MJCF's joint stiffness and springref; URDF has none)
    target: float = 0.0
    cone_limit: float | None = None  # a spherical joint's swing limit, rad (MJCF's ball range; URDF has none)
    armature: float = 0.0  # kg m^2 or kg added to the coordinate's inertia (MJCF's joint armature; URDF has none)
    mimic: tuple | None = None  # <mimic joint multiplier offset>: (the joint followed, multiplier, offset)


@dataclass
class UrdfModel:
    """A parsed URDF: ``links`` in file order, ``joints`` in file order, ``root`` the link that is no
    joint's child, ``source`` the file."""

    name: str
    links: dict
    joints: list
    root: str
    source: str


def _numbers(text, key, count, default=None):
    if text is None:
        if default is None:
            raise InputError("missing", key)
        return np.array(default, dtype=float)
    try:
        values = [float(t) for t in text.replace(",", " ").split()]  # commas: Bullet reads them too
    except ValueError:
        raise InputError(f"expected {count} number{'s' if count > 1 else ''}, got {text!r}", key) from None
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise InputError(f"expected {count} finite number{'s' if count > 1 else ''}, got {text!r}", key)
    return np.array(values)


def _number(element, attribute, key, default=None, positive=False, nonnegative=False):
    value = float(_numbers(element.get(attribute), f"{key}.{attribute}", 1,
                           None if default is None else [default])[0])
    if positive and value <= 0:
        raise InputError(f"must be positive, got {value:g}", f"{key}.{attribute}")
    if nonnegative and value < 0:
        raise InputError(f"must be >= 0, got {value:g}", f"{key}.{attribute}")
    return value


def rpy_matrix(rpy) -> np.ndarray:
    """(3, 3) rotation of a URDF ``rpy`` (roll x, pitch y, yaw z, rad, fixed axes): Rz Ry Rx."""
    return quat_to_matrix(quat_from_euler_deg(np.degrees(rpy)))


def _origin(element, key) -> tuple:
    o = element.find("origin")
    if o is None:
        return np.zeros(3), np.eye(3)
    return _numbers(o.get("xyz"), f"{key}.origin.xyz", 3, [0, 0, 0]), \
        rpy_matrix(_numbers(o.get("rpy"), f"{key}.origin.rpy", 3, [0, 0, 0]))


def _name(element, key) -> str:
    name = element.get("name")
    if not name:
        raise InputError("missing name", key)
    return name


def read_urdf(path, package_dirs=()) -> UrdfModel:
    """Parse and check a URDF file (module docstring). Raises InputError (file, element, problem)."""
    path = Path(path)
    file = str(path)
    try:
        return _read(path, [Path(d) for d in package_dirs])
    except InputError as err:
        raise err.within(None, file) from None


def read_xml(path: Path, kind: str, top: str):
    """The root element of the XML file ``path`` (a ``kind`` file: "URDF", "MJCF"), checked: the file
    exists, fits in memory, parses, and its top element is ``<top>``. Raises InputError (no key)."""
    if not path.is_file():
        raise InputError(f"{kind} file not found", None)
    checks.check_memory(path.stat().st_size * checks.FILE_EXPANSION, f"reading the {kind} file {path}", None, str(path))
    try:
        # leading blank lines before <?xml ...?> are an XML error that Bullet's parser forgives
        root = ET.fromstring(path.read_bytes().lstrip())
    except ET.ParseError as exc:
        raise InputError(f"invalid XML: {exc}", None) from None
    if root.tag != top:
        raise InputError(f"expected a <{top}> element at the top, got <{root.tag}>", None)
    return root


def _read(path: Path, package_dirs) -> UrdfModel:
    root = read_xml(path, "URDF", "robot")
    links: dict[str, UrdfLink] = {}
    for element in root.findall("link"):
        link = _link(element, path, package_dirs)
        if link.name in links:
            raise InputError("duplicate link name", f"link[{link.name}]")
        links[link.name] = link
    if not links:
        raise InputError("a robot needs at least one <link>", "robot")
    joints = []
    parent_of: dict[str, str] = {}
    names = set()
    for element in root.findall("joint"):
        joint = _joint(element)
        key = f"joint[{joint.name}]"
        if joint.name in names:
            raise InputError("duplicate joint name", key)
        names.add(joint.name)
        for role, link in (("parent", joint.parent), ("child", joint.child)):
            if link not in links:
                raise InputError(f"unknown link {link!r}", f"{key}.{role}")
        if joint.child in parent_of:
            raise InputError(f"link {joint.child!r} is the child of two joints (a URDF is a tree)", f"{key}.child")
        parent_of[joint.child] = joint.name
        joints.append(joint)
    roots = [name for name in links if name not in parent_of]
    if len(roots) != 1:
        what = "no link" if not roots else f"{len(roots)} links ({', '.join(roots[:4])})"
        raise InputError(f"{what} without a parent joint: a URDF is one tree with one root link", "robot")
    # every link reachable from the root (else a cycle hangs off somewhere)
    children: dict[str, list] = {}
    for joint in joints:
        children.setdefault(joint.parent, []).append(joint.child)
    seen, todo = set(), [roots[0]]
    while todo:
        name = todo.pop()
        seen.add(name)
        todo.extend(children.get(name, []))
    if len(seen) != len(links):
        lost = sorted(set(links) - seen)[0]
        raise InputError("the joints form a cycle (this link is not reached from the root)", f"link[{lost}]")
    return UrdfModel(root.get("name") or path.stem, links, joints, roots[0], str(path))


def _link(element, path, package_dirs) -> UrdfLink:
    name = _name(element, "link")
    key = f"link[{name}]"
    link = UrdfLink(name)
    inertial = element.find("inertial")
    if inertial is not None:
        k = f"{key}.inertial"
        mass = inertial.find("mass")
        if mass is None:
            raise InputError("missing <mass>", k)
        link.mass = _number(mass, "value", f"{k}.mass", nonnegative=True)
        position, rotation = _origin(inertial, k)
        tensor = inertial.find("inertia")
        if tensor is None:
            raise InputError("missing <inertia>", k)
        c = {a: _number(tensor, a, f"{k}.inertia", default=0.0) for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        I = np.array([[c["ixx"], c["ixy"], c["ixz"]], [c["ixy"], c["iyy"], c["iyz"]], [c["ixz"], c["iyz"], c["izz"]]])
        link.center = position
        link.inertia = rotation @ I @ rotation.T
    for j, collision in enumerate(element.findall("collision")):
        k = f"{key}.collision[{j}]"
        geometry = collision.find("geometry")
        if geometry is None or len(geometry) != 1:
            raise InputError("expected one shape in <geometry>", f"{k}.geometry")
        shape = _shape(geometry[0], f"{k}.geometry", path, package_dirs)
        link.parts.append((shape, *_origin(collision, k)))
    contact = element.find("contact")
    if contact is not None:
        given = {}
        for tag, field_name in (("lateral_friction", "friction"), ("restitution", "restitution")):
            e = contact.find(tag)
            if e is not None:
                given[field_name] = _number(e, "value", f"{key}.contact.{tag}", nonnegative=True)
        if given:
            try:
                link.material = Material(**given)
            except InputError as err:
                raise err.within(f"{key}.contact") from None
    return link


def _shape(g, key, path: Path, package_dirs):
    k = f"{key}.{g.tag}"
    try:
        if g.tag == "box":
            return Box(size=_numbers(g.get("size"), f"{k}.size", 3))
        if g.tag == "sphere":
            return Sphere(radius=_number(g, "radius", k))
        if g.tag == "cylinder":
            return Cylinder(radius=_number(g, "radius", k), length=_number(g, "length", k))
        if g.tag == "capsule":
            return Capsule(radius=_number(g, "radius", k), length=_number(g, "length", k))
        if g.tag == "mesh":
            return _mesh(g, k, path, package_dirs)
        if g.tag == "plane":  # Bullet's extension: a static half-space
            return Plane(normal=_numbers(g.get("normal"), f"{k}.normal", 3, [0, 0, 1]))
    except InputError as err:
        raise err.within(k) if err.key is None or not err.key.startswith(k) else err from None
    raise InputError(f"unknown shape <{g.tag}> (expected box, sphere, cylinder, capsule, mesh or plane)", key)


def resolve_mesh_path(filename: str, urdf: Path, package_dirs) -> Path:
    """The file a ``<mesh filename>`` names: ``package://PKG/rest`` is looked up as ``PKG/rest``
    under each of ``package_dirs`` and then the URDF's folder and its parents (a ROS package
    tree); ``file://`` is a path; anything else is relative to the URDF's folder."""
    if filename.startswith("package://"):
        rest = filename[len("package://"):]
        package, _, inner = rest.partition("/")
        for base in [*package_dirs, urdf.parent, *urdf.parent.parents]:
            for candidate in (base / package / inner, base / inner) if base.name != package else (base / inner,):
                if candidate.is_file():
                    return candidate
        raise InputError(f"mesh file not found: {filename} (looked for {package}/{inner} under the URDF's folders"
                         " and package_dirs)", "filename")
    if filename.startswith("file://"):
        filename = filename[len("file://"):]
    p = Path(filename)
    p = p if p.is_absolute() else urdf.parent / p
    if not p.is_file():
        raise InputError(f"mesh file not found: {p}", "filename")
    return p


def _mesh(g, key, path, package_dirs):
    from .mass import _read_mesh_file

    filename = g.get("filename")
    if not filename:
        raise InputError("missing filename", key)
    file = resolve_mesh_path(filename, path, package_dirs)
    checks.check_memory(file.stat().st_size * checks.FILE_EXPANSION, f"reading the mesh file {file}", key, str(path))
    scale = _numbers(g.get("scale"), f"{key}.scale", 3, [1, 1, 1])
    try:
        points = np.asarray(_read_mesh_file(str(file)).vertices, dtype=float) * scale
        return Convex(points=points)
    except InputError as err:
        raise InputError(f"{file.name}: {err.problem}", key) from None


def _joint(element) -> UrdfJoint:
    name = _name(element, "joint")
    key = f"joint[{name}]"
    kind = element.get("type")
    if kind not in JOINT_KINDS:
        raise InputError(f"unknown joint type {kind!r} (expected one of {', '.join(JOINT_KINDS)})", f"{key}.type")
    if kind == "planar":
        raise InputError("planar joints are not supported (use a slider on a slider, or a floating joint)", f"{key}.type")
    ends = {}
    for role in ("parent", "child"):
        e = element.find(role)
        if e is None or not e.get("link"):
            raise InputError(f"missing <{role} link=...>", f"{key}.{role}")
        ends[role] = e.get("link")
    axis_element = element.find("axis")
    axis = _numbers(None if axis_element is None else axis_element.get("xyz"), f"{key}.axis.xyz", 3, [1, 0, 0])
    n = float(np.linalg.norm(axis))
    if n < 1e-12 and kind in ("revolute", "continuous", "prismatic"):
        raise InputError("the axis must not be the zero vector", f"{key}.axis.xyz")
    joint = UrdfJoint(name, kind, ends["parent"], ends["child"], _origin(element, key), axis / max(n, 1e-300))
    limit = element.find("limit")
    if limit is not None:
        k = f"{key}.limit"
        lower = None if limit.get("lower") is None else _number(limit, "lower", k)
        upper = None if limit.get("upper") is None else _number(limit, "upper", k)
        if lower is not None and upper is not None and lower > upper:
            lower = upper = None  # Bullet's "no limit"
        if kind in ("revolute", "prismatic"):
            joint.lower, joint.upper = lower, upper
        if limit.get("effort") is not None:
            joint.effort = _number(limit, "effort", k, nonnegative=True)
        if limit.get("velocity") is not None:
            joint.velocity = _number(limit, "velocity", k, nonnegative=True)
    mimic = element.find("mimic")
    if mimic is not None:
        k = f"{key}.mimic"
        if not mimic.get("joint"):
            raise InputError("missing the joint it follows (joint=...)", f"{k}.joint")
        joint.mimic = (mimic.get("joint"), _number(mimic, "multiplier", k, default=1.0),
                       _number(mimic, "offset", k, default=0.0))
    dynamics = element.find("dynamics")
    if dynamics is not None:
        joint.damping = _number(dynamics, "damping", f"{key}.dynamics", default=0.0, nonnegative=True)
        joint.friction = _number(dynamics, "friction", f"{key}.dynamics", default=0.0, nonnegative=True)
    return joint


