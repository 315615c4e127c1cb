"""USD physics scenes (the ``UsdPhysics`` schema) read into a World: ``load_usd``.

UsdPhysics is the rigid-body description that Pixar, Apple and NVIDIA wrote into OpenUSD
(openusd.org, "UsdPhysics: USD Physics Schema"): Omniverse and Isaac Sim author it, PhysX and
Newton simulate it, Unity's and other exporters write it. A stage marks rigid bodies with
``PhysicsRigidBodyAPI``, their colliders with ``PhysicsCollisionAPI`` on geometry prims
(``Cube``, ``Sphere``, ``Capsule``, ``Cylinder``, ``Cone``, ``Plane``, ``Mesh`` with
``PhysicsMeshCollisionAPI``), mass with ``PhysicsMassAPI``, surfaces with ``PhysicsMaterialAPI``,
and joints as ``PhysicsRevoluteJoint``, ``PhysicsPrismaticJoint``, ``PhysicsSphericalJoint``,
``PhysicsFixedJoint``, ``PhysicsDistanceJoint`` prims. The stage is parsed by OpenUSD's own
parser (``UsdPhysics.LoadUsdPhysicsFromRange``, usd-core), which resolves the transform
hierarchy: each body's world pose, each collider's pose in its body and its size with the
scales applied, each joint's two local frames. What this module adds is the mapping onto
tumble's bodies, shapes, materials and joints:

- units: lengths times the stage's ``metersPerUnit`` (USD's fallback when it is not authored is
  0.01, centimetres: taken, with a warning), masses times ``kilogramsPerUnit``;
  angles of the schema (joint limits, drive targets, angular velocities) are degrees.
- axes: a stage whose up axis is Y is turned into tumble's z up (a rotation of +90 degrees
  about x applied to every world pose, velocity, axis and to gravity); its bodies' names and
  local frames are unchanged.
- a body: ``add_body`` at the body prim's world pose with its colliders as the shape (a
  ``Compound`` when there are several or one is offset); a body whose ``rigidBodyEnabled`` is
  false is a fixed body with its colliders (PhysX's static body); colliders of no rigid body
  are fixed bodies of their own; ``kinematicEnabled``
  makes a kinematic body (moving at its velocity, or along its transform's time samples:
  ``_animation``); velocities as authored (the schema gives
  them in the body's parent space: turned into the world); PhysX's
  ``physxRigidBody:disableGravity`` makes its gravity scale 0 (``World.set_gravity_scale``), and
  ``physxRigidBody:linearDamping`` / ``angularDamping`` its damping rates (``World.set_damping``).
- mass (the schema's precedence, "Mass properties" in its overview): the body's
  ``physics:mass`` if positive, else the sum over its colliders of each one's mass (its own
  ``physics:mass``, or a density times its volume: the collider's ``physics:density``, else
  the body's, else its bound material's, else 1000 kg/m^3); ``physics:centerOfMass``,
  ``physics:diagonalInertia`` with ``physics:principalAxes`` replace what the shapes give
  (tumble's ``add_body(mass, inertia, center_of_mass)``).
- materials: ``dynamicFriction`` becomes the body's (or the collider's) ``friction`` (tumble
  has one Coulomb coefficient for sticking and sliding: the sliding one is the one a slide
  shows), ``restitution`` as is; PhysX's ``physxMaterial:frictionCombineMode`` and
  ``restitutionCombineMode`` (average, min, multiply, max) as the material's combine modes
  (``Material.friction_combine``; unset: tumble's rules, docs/contact.md). ``physxCollision:
  restOffset`` is not read (``Material.margin`` is its kin).
- articulations (``PhysicsArticulationRootAPI``): their joints are solved by tumble's exact
  tree solve by default (``World.exact_joints``), as PhysX solves them in reduced coordinates.
- collision filters: ``PhysicsFilteredPairsAPI`` between bodies or their colliders: the
  bodies' pair excluded; ``PhysicsCollisionGroup`` prims with ``filteredGroups`` (and
  ``invertFilteredGroups``) become Box2D category and mask bits (up to 31 groups; a body's
  colliders must share their groups, since tumble's filter is per body).
- joints: anchors and axes from the joint's two local frames (``localPos0/1``, ``localRot0/1``,
  the joint axis ``X``, ``Y`` or ``Z`` of frame 0) in the world at load time; the two frames
  become the joint's body-fixed frames (``_schema_frames``), so its coordinate is the schema's
  from the start (a revolute joint 30 deg open at load reads 30 deg). A side on a static prim
  is the world to the parser; when that prim is a fixed body here, the joint holds on to it.
  When body0 is the world, tumble's joint runs from body1 to the world and its coordinate is
  the schema's negated (limits, targets and motor speeds are turned round to match). Limits,
  ``PhysicsDriveAPI`` (force drives: stiffness and damping per degree for angles; a drive
  with a target velocity and no stiffness becomes a velocity motor with ``maxForce``),
  ``breakForce`` / ``breakTorque``, ``collisionEnabled``, ``jointEnabled`` are read. A
  spherical joint's two cone angles must be equal (tumble's cone is round).

D6 joints (``PhysicsJoint`` with a limit per degree of freedom) that are one of those joints
(fixed, one rotation or one translation left, a free ball) are read as that joint (``_d6_as``).

Refused, with one line naming the prim: other D6 joints and custom joints, acceleration drives,
a drive with both a stiffness and a target velocity, unequal cone angles, a plane on a moving
body, a rigid body without a collider, more than one PhysicsScene. A capsule or cylinder with two
radii (``Capsule_1``, ``Cylinder_1``) is the plain shape when they are equal, else the convex hull
of 64 points on each rim (each cap's sphere: ``_tapered_points``). A triangle mesh (approximation ``none``) on a moving body collides as its convex
hull, with a warning (PhysX's rule); ``convexHull``, ``boundingCube``, ``boundingSphere`` and
``meshSimplification`` are the hull; ``convexDecomposition`` is cut by CoACD (the ``decompose``
extra). Time-sampled values are read at the stage's default time, but for the transforms of
kinematic bodies (``_animation``).
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import InputError, TumbleWarning
from .mass import _quat_matrix, combine_mass_properties, mass_properties
from .math3d import matrix_to_quat, quat_multiply
from .material import Material
from .shapes import Box, Capsule, Compound, Cone, Convex, Cylinder, Mesh, Plane, Sphere

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")

DEFAULT_DENSITY = 1000.0  # kg/m^3, the schema's density when nothing sets one (its overview)
MAX_GROUPS = 31  # collision groups: bit 0 is "no group", 31 bits are left for groups
# a drive's damping from which a target velocity without stiffness is a motor (infinite gain): PhysX's
# velocity drives' stiff damping (save_usd writes tumble's motors with 1e10, export.usd_scene)
STIFF_DAMPING = 1e9

#: the authored size attributes of each collider kind's UsdGeom prim, refused when negative or not finite
#: (zero goes on to the shape's own check: "must be positive", or a capsule of no spine, a ball)
GEOM_SIZE_ATTRIBUTES = {
    "CubeShape": ("size",), "SphereShape": ("radius",), "CapsuleShape": ("radius", "height"),
    "CylinderShape": ("radius", "height"), "ConeShape": ("radius", "height"),
    "Capsule1Shape": ("radiusTop", "radiusBottom", "height"), "Cylinder1Shape": ("radiusTop", "radiusBottom", "height"),
}


@dataclass
class UsdScene:
    """What ``load_usd`` added to the World.

    Attributes:
        bodies: {prim path: ``Body``}, the rigid bodies and the static colliders.
        joints: {prim path: ``Joint``}.
        gravity: (3,) m/s^2, world (z up): the stage's ``PhysicsScene`` gravity, or the
            schema's default (9.81 m/s^2 against the up axis) when it has none. ``load_usd``
            does not set the World's gravity; ``tumble run file.usda`` does.
        up_axis: "Y" or "Z", the stage's.
        meters_per_unit, kilograms_per_unit: the stage's units.
    """

    bodies: dict = field(default_factory=dict)
    joints: dict = field(default_factory=dict)
    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    up_axis: str = "Z"
    meters_per_unit: float = 1.0
    kilograms_per_unit: float = 1.0


def _f(x) -> float:
    """A number the parser hands over in single precision (its descriptors hold Gf.Vec3f and
    floats), as the shortest decimal that rounds to it: 9.81 read back as 9.81, not 9.8100004."""
    return float(str(np.float32(x)))


def _usd_message(exc) -> str:
    """The message of a ``Tf.ErrorException`` without its C++ location: "Error in 'pxr...::_Init' at
    line 142 in file .../xformOp.cpp : 'MESSAGE'" -> MESSAGE (the first, at most 200 characters)."""
    text = " ".join(str(exc).split())
    found = re.findall(r" : '(.*?)'(?: Error in|$)", text)
    return (found[0] if found else text)[:200]


def _vec(v) -> np.ndarray:
    return np.array([_f(v[0]), _f(v[1]), _f(v[2])])


def _quat(q) -> np.ndarray:
    """(w, x, y, z) of a Gf quaternion, made unit."""
    im = q.GetImaginary()
    out = np.array([_f(q.GetReal()), _f(im[0]), _f(im[1]), _f(im[2])])
    n = float(np.linalg.norm(out))
    return out / n if n > 0.0 else np.array([1.0, 0.0, 0.0, 0.0])


def _matrix_quat(R: np.ndarray) -> np.ndarray:
    """(w, x, y, z) of a rotation matrix (3, 3): ``math3d.matrix_to_quat`` (Shepperd's method)."""
    return matrix_to_quat(np.ascontiguousarray(R, dtype=float))


_AXES = {"X": 0, "Y": 1, "Z": 2}


def _axis_index(axis) -> int:
    return _AXES[str(axis).rsplit(".", 1)[-1]]


def _along_z(axis: int) -> np.ndarray:
    """Rotation (w, x, y, z) taking z (tumble's capsule, cylinder and cone axis) to the axis."""
    h = math.sqrt(0.5)
    return [np.array([h, 0.0, h, 0.0]), np.array([h, -h, 0.0, 0.0]), np.array([1.0, 0.0, 0.0, 0.0])][axis]


# points on each rim (a frustum) or each cap's sphere (a tapered capsule): their hull's volume is
# (n / 2 pi) sin(2 pi / n) = 0.9984 of the round solid's at n = 64
TAPER_POINTS = 64


def _tapered_points(bottom: float, top: float, half: float, capsule: bool) -> np.ndarray:
    """(K, 3) points along z whose convex hull is a frustum of end radii ``bottom`` (at z = -half)
    and ``top`` (at +half), or, with ``capsule``, the hull of the two spheres of those radii there."""
    a = np.linspace(0.0, 2.0 * np.pi, TAPER_POINTS, endpoint=False)
    ring = np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=1)
    if not capsule:
        return np.concatenate([ring * bottom + (0, 0, -half), ring * top + (0, 0, half)])
    rows = []
    for z0, r in ((-half, bottom), (half, top)):
        for lat in np.linspace(-0.5 * np.pi, 0.5 * np.pi, 17):
            c, z = np.cos(lat), np.sin(lat)
            rows.append(ring * (r * c) + (0, 0, z0 + r * z))
    return np.unique(np.round(np.concatenate(rows), 15), axis=0)


def _compose(q_a: np.ndarray, q_b: np.ndarray) -> np.ndarray:
    """The product q_a q_b (w, x, y, z): q_b's rotation, then q_a's (``math3d.quat_multiply``)."""
    return quat_multiply(np.ascontiguousarray(q_a, dtype=float), np.ascontiguousarray(q_b, dtype=float))


class _Reader:
    def __init__(self, path: Path, name_prefix: str | None, placement=None):
        self.file = str(path)
        self.path = path
        self.prefix = name_prefix
        # (rotation (3, 3), translation (3,) m): where the stage's origin and axes go in the World
        self.placement = placement if placement is not None else (np.eye(3), np.zeros(3))

    def error(self, problem: str, prim=None) -> InputError:
        return InputError(problem, str(prim) if prim is not None else None, self.file)

    def on_prim(self, err: InputError, prim) -> InputError:
        """A tumble record's complaint (key: problem) as the prim's line: FILE: PRIM: key: problem."""
        return self.error(f"{err.key}: {err.problem}" if err.key else err.problem, prim)

    # -- the stage
    def open(self):
        try:
            from pxr import Tf, Usd, UsdGeom, UsdPhysics
        except ImportError:  # pragma: no cover - usd-core is a dependency
            raise self.error("reading USD needs usd-core: pip install 'tumble[usd]'") from None
        if not self.path.exists():
            raise self.error("file not found")
        if self.path.is_dir():
            raise self.error("is a folder, not a USD file")
        try:
            stage = Usd.Stage.Open(str(self.path))
        except Tf.ErrorException as exc:
            raise self.error(f"cannot read this USD file: {_usd_message(exc)}") from None
        if stage is None:
            raise self.error("cannot read this USD file")
        self.stage = stage
        self.mpu = float(UsdGeom.GetStageMetersPerUnit(stage))
        if not stage.HasAuthoredMetadata("metersPerUnit"):
            # USD's fallback is centimetres: a stage written in metres without saying so comes out
            # a hundred times too small (found loading a hand-made stage)
            warnings.warn(f"{self.file}: the stage does not give its metersPerUnit: USD's fallback, 0.01 "
                          "(centimetres), is taken", TumbleWarning, stacklevel=3)
        self.kpu = float(UsdPhysics.GetStageKilogramsPerUnit(stage))
        for value, what in ((self.mpu, "metersPerUnit"), (self.kpu, "kilogramsPerUnit")):
            # densities go by the unit cubed: a unit past 1e+-9 overflows them (the fuzz test's 1e300)
            if not (math.isfinite(value) and 1e-9 <= value <= 1e9):
                raise self.error(f"the stage's {what} must be a number from 1e-9 to 1e9, got {value:g}")
        self.up = str(UsdGeom.GetStageUpAxis(stage)).upper()
        if self.up not in ("Y", "Z"):
            raise self.error(f"the stage's upAxis must be Y or Z, got {self.up!r}")
        # Y up -> z up: +90 deg about x takes y to z (and z to -y)
        self.C = np.eye(3) if self.up == "Z" else np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
        # where the stage goes in the World: A = placement rotation after the axes' turn, then + t
        self.A = self.placement[0] @ self.C
        self.qA = _matrix_quat(self.A)
        self.t = self.placement[1]
        # OpenUSD's parser (usd-core 25.05 on); 26.x renamed it and keeps the old name, deprecated
        load = getattr(UsdPhysics, "UsdPhysicsLoadStageFromPrimRange", None) or UsdPhysics.LoadUsdPhysicsFromRange
        parsed = load(stage, ["/"])
        self.parsed = {str(kind).rsplit(".", 1)[-1]: list(zip(*descs)) for kind, descs in parsed.items()}
        self.UsdPhysics = UsdPhysics
        self.UsdGeom = UsdGeom
        self.Usd = Usd

    def descs(self, kind: str) -> list:
        return self.parsed.get(kind, [])

    # -- world frame (tumble's: z up, metres)
    def point(self, p) -> np.ndarray:
        """A stage point (its units, its axes) in the World: metres, z up, placed."""
        return self.A @ (_vec(p) * self.mpu) + self.t

    def rotation(self, q) -> np.ndarray:
        return _compose(self.qA, _quat(q))

    def name(self, prim_path) -> str:
        """A body's name: its prim's ``customData["tumble:name"]`` (what ``save_usd`` writes), else
        the prim path without its leading slash; after the prefix if one is given."""
        prim = self.stage.GetPrimAtPath(prim_path)
        own = prim.GetCustomDataByKey("tumble:name") if prim else None
        base = str(own) if own else (str(prim_path).lstrip("/") or "root")
        return f"{self.prefix}/{base}" if self.prefix else base

    # -- attributes the parser leaves out
    def attr(self, prim_path, name: str):
        prim = self.stage.GetPrimAtPath(prim_path)
        if not prim:
            return None
        a = prim.GetAttribute(name)
        if not a or not a.HasAuthoredValue():
            return None
        return a.Get()

    def positive(self, prim_path, name: str):
        v = self.attr(prim_path, name)
        if v is None:
            return None
        v = float(v)
        if not math.isfinite(v) or v < 0.0:
            raise self.error(f"{name} must be a number >= 0, got {v:g}", prim_path)
        return v if v > 0.0 else None

    def scene(self) -> np.ndarray:
        """Gravity (3,) m/s^2 in tumble's frame."""
        scenes = self.descs("Scene")
        if len(scenes) > 1:
            raise self.error(f"{len(scenes)} PhysicsScene prims; tumble runs one scene",
                             scenes[1][0])
        up = np.array([0.0, 0.0, 1.0])
        if not scenes:
            return -9.81 * up
        path, d = scenes[0]
        # read the attributes themselves: the parser turns the schema's "earth gravity" (a magnitude
        # left out or -inf) into 9.81 / metersPerUnit in single precision (981.0001 in a cm stage)
        magnitude = self.attr(path, "physics:gravityMagnitude")
        magnitude = None if magnitude is None else float(magnitude)
        if magnitude is None or not math.isfinite(magnitude) or magnitude < 0.0:
            g = 9.81
        else:
            g = _f(magnitude) * self.mpu
        direction = _vec(d.gravityDirection)
        n = float(np.linalg.norm(direction))
        if n == 0.0:
            return -g * up
        return self.C @ (direction / n) * g

    # -- shapes
    def collider_shape(self, kind: str, path, d, moving: bool):
        """``_collider_shape`` with a shape's own complaint (a size of 0, a NaN) on the prim's line."""
        try:
            return self._collider_shape(kind, path, d, moving)
        except InputError as err:
            if err.file:
                raise
            raise self.on_prim(err, path) from None

    def _collider_shape(self, kind: str, path, d, moving: bool):
        """(shape, position (3,) m, orientation (4,)) of a collider in its body's frame (or the
        world.s for a collider of no body; planes are read apart: _static_collider)."""
        s = self.mpu
        pos = _vec(d.localPos) * s
        q = _quat(d.localRot)
        for name in GEOM_SIZE_ATTRIBUTES.get(kind, ()):
            # the parser's sizes are magnitudes (a Cube of size -1 came out a unit box): the prim's own value
            v = self.attr(path, name)
            if v is not None and not (math.isfinite(float(v)) and float(v) >= 0.0):
                raise self.error(f"{name}: must be positive, got {float(v):g}", path)
        if kind == "CubeShape":
            return Box(size=tuple(2.0 * _vec(d.halfExtents) * s)), pos, q
        if kind == "SphereShape":
            return Sphere(radius=_f(d.radius) * s), pos, q
        if kind in ("CapsuleShape", "CylinderShape", "ConeShape"):
            axis = _axis_index(d.axis)
            r, half = _f(d.radius) * s, _f(d.halfHeight) * s
            turn = _along_z(axis)
            q2 = _compose(q, turn)
            if kind == "CapsuleShape":
                if half == 0.0:  # a capsule of no spine is a ball (USD allows height 0)
                    return Sphere(radius=r), pos, q
                return Capsule(radius=r, length=2.0 * half), pos, q2
            if kind == "CylinderShape":
                return Cylinder(radius=r, length=2.0 * half), pos, q2
            # USD's cone is centred on its bounding box, apex at +half; tumble's base sits on its origin
            return Cone(radius=r, height=2.0 * half), pos - _quat_matrix(q2) @ np.array([0.0, 0.0, half]), q2
        if kind in ("Capsule1Shape", "Cylinder1Shape"):
            # Capsule_1, Cylinder_1: a radius at each end. Equal: the plain shape; else a tapered
            # capsule or a frustum, as the convex hull of its rims' points (or its caps' spheres')
            axis = _axis_index(d.axis)
            top, bottom, half = _f(d.topRadius) * s, _f(d.bottomRadius) * s, _f(d.halfHeight) * s
            q2 = _compose(q, _along_z(axis))
            capsule = kind == "Capsule1Shape"
            if top == bottom:
                if capsule and half == 0.0:
                    return Sphere(radius=top), pos, q
                return (Capsule if capsule else Cylinder)(radius=top, length=2.0 * half), pos, q2
            return Convex(points=_tapered_points(bottom, top, half, capsule)), pos, q2
        if kind == "MeshShape":
            return self.mesh_shape(path, d, moving), pos, q
        raise self.error(f"collider type {kind} is not supported", path)

    def mesh_shape(self, path, d, moving: bool):
        mesh = self.UsdGeom.Mesh(self.stage.GetPrimAtPath(path))
        points = mesh.GetPointsAttr().Get() if mesh else None
        if points is None or len(points) < 4:
            raise self.error("a mesh collider needs at least 4 points", path)
        vertices = np.array(points, dtype=float) * _vec(d.meshScale) * self.mpu
        approximation = str(d.approximation).rsplit(".", 1)[-1].lower()
        if approximation in ("convexhull", "boundingcube", "boundingsphere", "meshsimplification") or (
                moving and approximation == "none"):
            if moving and approximation == "none":
                warnings.warn(f"{self.file}: {path}: a triangle mesh collider on a moving body: its convex hull "
                              "collides (PhysX's rule)", TumbleWarning, stacklevel=4)
            try:
                return Convex(points=vertices)
            except InputError as err:
                raise self.error(f"its convex hull: {err.problem}", path) from None
        counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get() or [], dtype=np.int64)
        indices = np.asarray(mesh.GetFaceVertexIndicesAttr().Get() or [], dtype=np.int64)
        if counts.sum() != len(indices) or (len(indices) and (indices.min() < 0 or indices.max() >= len(vertices))):
            raise self.error("faceVertexCounts and faceVertexIndices do not match the points", path)
        faces, k = [], 0
        for c in counts:  # fans: the polygons are convex in any mesh a physics engine takes as is
            faces.extend((indices[k], indices[k + i], indices[k + i + 1]) for i in range(1, c - 1))
            k += c
        if str(self.attr(path, "orientation") or "rightHanded") == "leftHanded":
            faces = [(a, c, b) for a, b, c in faces]
        faces = np.array(faces, dtype=np.int64).reshape(-1, 3)
        decomposed = approximation == "convexdecomposition"
        # written by tumble (export/usd_scene.py) from an open mesh: open even when its triangles close
        held_open = mesh.GetPrim().GetCustomDataByKey("tumble:closed") is False and not decomposed
        if not held_open:
            try:
                closed = Mesh(vertices=vertices, faces=faces)
            except InputError as err:
                if decomposed or "not closed" not in err.problem:
                    raise self.error(f"{err.problem} (convex pieces are cut from a closed mesh; approximation "
                                     "'convexHull' takes its hull)" if decomposed else err.problem, path) from None
                # an open triangle mesh on a static collider (a terrain sheet, a ramp): tumble's open,
                # two-sided surface (PhysX collides triangle meshes from both sides too)
            else:
                if decomposed:
                    from .decomposition import decompose

                    return decompose(closed)
                return closed
        try:
            return Mesh(vertices=vertices, faces=faces, closed=False)
        except InputError as err:
            raise self.error(err.problem, path) from None

    # -- materials, mass
    def material(self, paths) -> tuple[Material | None, float | None]:
        """(Material, density kg/m^3 or None) of the first bound physics material, or (None, None)."""
        for p in paths or ():
            for mpath, d in self.descs("RigidBodyMaterial"):
                if str(mpath) == str(p):
                    # PhysX's combine modes (PhysxSchema's PhysxMaterialAPI): tumble's modes of the same names
                    modes = {key: self.attr(mpath, f"physxMaterial:{attr}")
                             for key, attr in (("friction_combine", "frictionCombineMode"),
                                               ("restitution_combine", "restitutionCombineMode"))}
                    try:
                        mat = Material(friction=_f(d.dynamicFriction), restitution=_f(d.restitution),
                                       **{k: (str(v) if v is not None else None) for k, v in modes.items()})
                    except InputError as err:
                        raise self.error(f"{err.key}: {err.problem}", mpath) from None
                    density = _f(d.density) * self.kpu / self.mpu ** 3 if d.density > 0 else None
                    return mat, density
        return None, None

    def mass_of(self, body_path, parts) -> dict:
        """add_body's mass keywords for a body of ``parts`` [(path, shape, pos, q, density)]."""
        kpu, mpu = self.kpu, self.mpu
        body_mass = self.positive(body_path, "physics:mass")
        body_density = self.positive(body_path, "physics:density")
        given = []  # per part: (shape, pos, q, its mass kg or None, its density kg/m^3 or None)
        for path, shape, pos, q, mat_density in parts:
            own_mass = self.positive(path, "physics:mass") if str(path) != str(body_path) else None
            own_density = self.positive(path, "physics:density") if str(path) != str(body_path) else None
            if own_mass is not None:
                given.append((shape, pos, q, own_mass * kpu, None))
            else:
                rho = (own_density * kpu / mpu ** 3 if own_density is not None else
                       body_density * kpu / mpu ** 3 if body_density is not None else
                       mat_density if mat_density is not None else DEFAULT_DENSITY)
                given.append((shape, pos, q, None, rho))
        com = self.attr(body_path, "physics:centerOfMass")
        diag = self.attr(body_path, "physics:diagonalInertia")
        densities = {g[4] for g in given}
        if body_mass is None and com is None and diag is None and len(densities) == 1 and None not in densities:
            # one density throughout and nothing authored over it: add_body(density=) computes the
            # same sums (and a 1000-box stage loads in two thirds of the time)
            return {"density": densities.pop()}
        terms = []
        for shape, pos, q, m, rho in given:
            props = mass_properties(shape, mass=m) if m is not None else mass_properties(shape, density=rho)
            R = _quat_matrix(q)
            terms.append((props.mass, pos + R @ props.center, R @ props.inertia @ R.T))
        mass, center, inertia = combine_mass_properties(terms)
        if body_mass is not None:
            scale = body_mass * kpu / mass if mass > 0.0 else 0.0
            mass, inertia = body_mass * kpu, inertia * scale
        if mass <= 0.0:  # a body with no collider and no mass: PhysX's 1 kg and unit inertia
            mass, center, inertia = 1.0, np.zeros(3), np.eye(3)
        if com is not None and all(math.isfinite(float(c)) and abs(float(c)) < 1e30 for c in com):
            # the schema's "not set" is (-inf, -inf, -inf)
            center = _vec(com) * mpu
        if diag is not None and all(float(c) > 0.0 for c in diag):
            axes = self.attr(body_path, "physics:principalAxes")
            Q = _quat_matrix(_quat(axes)) if axes is not None else np.eye(3)
            inertia = Q @ np.diag(_vec(diag) * kpu * mpu * mpu) @ Q.T
        return {"mass": mass, "center_of_mass": center, "inertia": inertia}


def _tf(path):
    """pxr's Tf module (its ``ErrorException``), or the one line saying usd-core is missing."""
    try:
        from pxr import Tf
    except ImportError:  # pragma: no cover - the usd extra (and export, test) bring usd-core
        raise InputError("reading USD needs usd-core: pip install 'tumble[usd]'", None, str(path)) from None
    return Tf


def read_gravity(path) -> np.ndarray:
    """The gravity (3,) m/s^2, world (z up), of the stage at ``path``: its PhysicsScene's, or the
    schema's default; the stage opened and parsed, no body made (``InputError`` as ``load_usd``)."""
    Tf = _tf(path)
    r = _Reader(Path(path), None)
    try:
        r.open()
        return r.scene()
    except Tf.ErrorException as exc:
        raise r.error(f"USD cannot read this stage: {_usd_message(exc)}") from None


def load_usd(world, path, *, name: str | None = None, position=(0.0, 0.0, 0.0), orientation=None,
             euler_deg=None) -> UsdScene:
    """Add the rigid bodies, colliders and joints of a USD stage (the UsdPhysics schema) to ``world``.

    Args:
        world: the ``World`` to add to.
        path: a ``.usd``, ``.usda``, ``.usdc`` or ``.usdz`` file.
        name: optional prefix of the bodies' names (``"NAME/World/box"``); default none: a body is
            named by its prim path without the leading slash (``"World/box"``).
        position: (3,) m, where the stage's origin goes in the World; ``orientation`` (w, x, y, z)
            or ``euler_deg`` (as ``add_body``'s): how its axes (made z up) turn. Gravity is the
            World's, not turned. Default: the stage as it is.

    Returns:
        a ``UsdScene``: the bodies and joints by prim path, the stage's gravity and units.

    Raises:
        InputError: one line ``FILE: PRIM: problem``.
    """
    from .math3d import quat_from_euler_deg
    from .shapes import finite_vector

    path = Path(path)
    Tf = _tf(path)

    if orientation is not None and euler_deg is not None:
        raise InputError("give orientation or euler_deg, not both", "orientation", str(path))
    try:
        t = finite_vector(position, "position")
        if euler_deg is not None:
            q = quat_from_euler_deg(finite_vector(euler_deg, "euler_deg"))
        else:
            from .world import unit_quaternion

            q = unit_quaternion((1.0, 0.0, 0.0, 0.0) if orientation is None else orientation)
    except InputError as err:
        raise InputError(err.problem, err.key, str(path)) from None
    r = _Reader(path, name, (_quat_matrix(q), t))
    try:
        return _load(r, world)
    except Tf.ErrorException as exc:  # OpenUSD refusing what the stage says (an xform op it cannot read...)
        raise r.error(f"USD cannot read this stage: {_usd_message(exc)}") from None


def _load(r, world) -> UsdScene:
    """``load_usd``'s work, the reader ``r`` made."""
    r.open()
    out = UsdScene(up_axis=r.up, meters_per_unit=r.mpu, kilograms_per_unit=r.kpu)
    out.gravity = r.scene()
    shapes = {}  # collider path -> (kind, desc)
    for kind, items in r.parsed.items():
        if kind.endswith("Shape"):
            for p, d in items:
                shapes[str(p)] = (kind, d)
    bodies = {str(p): d for p, d in r.descs("RigidBody")}
    if not bodies and not shapes:
        raise r.error("no UsdPhysics rigid bodies or colliders on this stage")
    claimed = set()
    for bpath, d in bodies.items():
        # rigidBodyEnabled = false: a static body (PhysX's rule), its colliders one fixed body
        moving = bool(d.rigidBodyEnabled)
        parts = []
        for cpath in d.collisions:
            cpath = str(cpath)
            if cpath not in shapes:
                continue
            kind, cd = shapes[cpath]
            if not cd.collisionEnabled:
                claimed.add(cpath)
                continue
            if kind == "PlaneShape":
                if moving:
                    raise r.error("a plane collider on a moving body (a plane is static)", cpath)
                continue  # a fixed body of its own (below): a plane is a body's only shape
            shape, pos, q = r.collider_shape(kind, cpath, cd, moving)
            mat, density = r.material(cd.materials)
            parts.append((cpath, shape, pos, q, density, mat))
            claimed.add(cpath)
        if not parts:
            if not moving:
                continue
            raise r.error("a rigid body without a collider (tumble's bodies have a shape)", bpath)
        try:
            kw = r.mass_of(bpath, [p[:5] for p in parts]) if moving else {}
        except InputError as err:  # a density or mass past the float range (1e300 g/cm^3)
            if err.file:
                raise
            raise r.on_prim(err, bpath) from None
        shape, material = _body_shape([(p[1], p[2], p[3]) for p in parts], [p[5] for p in parts])
        # the schema's velocities are in the body's parent space (angular in degrees per second)
        prim = r.stage.GetPrimAtPath(bpath)
        parent = r.UsdGeom.Xformable(prim).ComputeParentToWorldTransform(r.Usd.TimeCode.Default()) if prim else None
        P = np.eye(3)
        if parent is not None:  # its rotation, scales and shears taken out; Gf's rows are our columns
            P = np.array(parent.RemoveScaleShear().ExtractRotationMatrix(), dtype=float).T
        with np.errstate(invalid="ignore", over="ignore"):  # an inf or NaN authored: add_body's line names it
            v = r.A @ P @ (_vec(d.linearVelocity) * r.mpu) if moving else np.zeros(3)
            w = r.A @ P @ np.radians(_vec(d.angularVelocity)) if moving else np.zeros(3)
        try:
            body = world.add_body(shape, position=r.point(d.position), orientation=r.rotation(d.rotation),
                                  velocity=v, angular_velocity=w, kinematic=moving and bool(d.kinematicBody),
                                  fixed=not moving, material=material, name=r.name(bpath), **kw)
        except InputError as err:
            raise r.on_prim(err, bpath) from None
        out.bodies[bpath] = body
        if moving and r.attr(bpath, "physxRigidBody:disableGravity"):
            # PhysX's rigid-body schema (PhysxRigidBodyAPI; what save_usd writes for a scale of 0)
            world.set_gravity_scale(body, 0.0)
        if moving:
            # PhysX's damping rates (1/s, PhysxRigidBodyAPI; unset: 0 here, as UsdPhysics has none)
            damping = {k: r.attr(bpath, f"physxRigidBody:{k}Damping") for k in ("linear", "angular")}
            if any(v is not None for v in damping.values()):
                try:
                    world.set_damping(body, linear=damping["linear"], angular=damping["angular"])
                except InputError as err:
                    raise r.on_prim(err, bpath) from None
        if moving and d.kinematicBody:
            _animation(r, world, body, bpath)
    # colliders of no enabled body: static. Those under a prim whose rigid body is disabled
    # (rigidBodyEnabled = false, what save_usd writes for a fixed body) are one fixed body at that
    # prim's pose; the others each a fixed body at its own pose (a plane always its own)
    disabled = {p: d for p, d in bodies.items() if not d.rigidBodyEnabled}
    groups: dict = {}
    for cpath, (kind, cd) in shapes.items():
        if cpath in claimed or not cd.collisionEnabled:
            continue
        if str(cd.rigidBody) in out.bodies and kind != "PlaneShape":
            continue
        owner = None
        if kind != "PlaneShape":
            parent = cpath
            while parent.count("/") > 1 and owner is None:
                parent = parent.rsplit("/", 1)[0]
                owner = parent if parent in disabled else None
            owner = owner if owner is not None or cpath not in disabled else cpath
        groups.setdefault(owner or cpath, []).append((cpath, kind, cd))
    owners = {cpath: str(cd.rigidBody) for cpath, (kind, cd) in shapes.items()}
    for key, members in groups.items():
        if key in disabled:
            _static_body(r, world, out, key, disabled[key], members)
            for cpath, _, _ in members:
                owners[cpath] = key
        else:
            (cpath, kind, cd), = members
            _static_collider(r, world, out, cpath, kind, cd)
    _filters(r, world, out, shapes, owners)
    _joints(r, world, out)
    if r.descs("Articulation") and world.joints:
        # PhysX solves an articulation in reduced coordinates, exactly: tumble's exact tree solve
        # by default (as for MJCF models), not Gauss-Seidel's soft rows
        world.exact_joints = True
    return out


def _animation(r, world, body, bpath: str):
    """A kinematic body whose transform (or an ancestor's) is animated in the stage: a
    ``KeyframePath`` through its world poses at the union of the time samples (time code tc at
    (tc - startTimeCode) / timeCodesPerSecond s; tumble moves it between keys at constant
    velocities, as ``KeyframePath`` does). PhysX moves an animated kinematic body the same way;
    a dynamic body's animation is not read (its motion is the simulation's)."""
    from .kinematic import KeyframePath

    UsdGeom, Usd = r.UsdGeom, r.Usd
    prim = r.stage.GetPrimAtPath(bpath)
    codes = set()
    p = prim
    while p and p.GetPath() != p.GetPath().absoluteRootPath:
        xf = UsdGeom.Xformable(p)
        if xf:
            codes.update(xf.GetTimeSamples())
        p = p.GetParent()
    if len(codes) < 2:
        return
    codes = sorted(codes)
    start = r.stage.GetStartTimeCode() if r.stage.HasAuthoredTimeCodeRange() else codes[0]
    rate = r.stage.GetTimeCodesPerSecond()
    xf = UsdGeom.Xformable(prim)
    positions, orientations = [], []
    for tc in codes:
        M = xf.ComputeLocalToWorldTransform(Usd.TimeCode(tc)).RemoveScaleShear()
        positions.append(r.point(M.ExtractTranslation()))
        rot = np.array(M.ExtractRotationMatrix(), dtype=float).T  # Gf's rows are our columns
        orientations.append(_compose(r.qA, _matrix_quat(rot)))
    times = (np.array(codes, dtype=float) - start) / rate
    if times[0] > 0.0:  # before its first key it holds the first pose
        times = np.concatenate([[0.0], times])
        positions.insert(0, positions[0])
        orientations.insert(0, orientations[0])
    keep = times >= 0.0
    if keep.sum() < 2:
        return
    try:
        world.add_path(KeyframePath(body.index, times[keep], np.array(positions)[keep],
                                    orientations=np.array(orientations)[keep]))
    except InputError as err:
        raise r.error(f"its animation: {err.problem}", bpath) from None


def _body_shape(parts: list, mats: list):
    """(shape, material) of a body of colliders ``parts`` [(shape, position (3,) m, orientation
    (4,))] in its frame with materials ``mats``: a lone collider at the body's origin (to 1e-12:
    a fixed body's colliders are placed by a difference of poses) is the shape itself, others a
    Compound; one material for all is the body's, different ones the parts'."""
    material = mats[0] if all(m == mats[0] for m in mats) else None
    (first, pos, q), = parts[:1]
    if len(parts) == 1 and np.allclose(pos, 0.0, rtol=0.0, atol=1e-12) and \
            np.allclose(q, (1.0, 0.0, 0.0, 0.0), rtol=0.0, atol=1e-12):
        return first, material
    return Compound(parts=parts, materials=None if material is not None or all(m is None for m in mats) else mats), \
        material


def _static_collider(r, world, out, cpath: str, kind: str, cd):
    """A collider of no body: a fixed body of its own at the collider's world pose."""
    mat, _ = r.material(cd.materials)
    if kind == "PlaneShape":
        n = r.A @ _quat_matrix(_quat(cd.localRot))[:, _axis_index(cd.axis)]
        p = r.point(cd.localPos)
        shape, pos, q = Plane(normal=tuple(n), offset=float(n @ p)), np.zeros(3), np.array([1.0, 0, 0, 0])
    else:
        shape, pos, q = r.collider_shape(kind, cpath, cd, False)
        pos, q = r.A @ pos + r.t, _compose(r.qA, q)
    try:
        body = world.add_body(shape, fixed=True, position=pos, orientation=q, material=mat, name=r.name(cpath))
    except InputError as err:
        raise r.on_prim(err, cpath) from None
    out.bodies[cpath] = body


def _static_body(r, world, out, bpath: str, d, members):
    """The colliders under a disabled rigid body's prim: one fixed body at that prim's pose (the
    parser gives such colliders their world poses: each is placed relative to the body)."""
    x_b = _vec(d.position) * r.mpu
    q_b = _quat(d.rotation)
    R_b = _quat_matrix(q_b)
    q_inv = q_b * np.array([1.0, -1.0, -1.0, -1.0])
    parts, mats = [], []
    for cpath, kind, cd in members:
        shape, pos, q = r.collider_shape(kind, cpath, cd, False)  # pos, q: the world's (the stage's axes)
        parts.append((shape, R_b.T @ (pos - x_b), _compose(q_inv, q)))
        mats.append(r.material(cd.materials)[0])
    shape, material = _body_shape(parts, mats)
    try:
        body = world.add_body(shape, fixed=True, position=r.point(d.position), orientation=r.rotation(d.rotation),
                              material=material, name=r.name(bpath))
    except InputError as err:
        raise r.on_prim(err, bpath) from None
    out.bodies[bpath] = body


def _owner(out, owners: dict, path: str):
    """The tumble body of a body or collider prim path (``owners``: collider path -> its rigid
    body's path), or None."""
    if path in out.bodies:
        return out.bodies[path]
    return out.bodies.get(owners.get(path, ""))


def _filters(r, world, out, shapes, owners):
    from .collision.filter import CollisionFilter

    # pairs: PhysicsFilteredPairsAPI on bodies and on colliders
    for kind, items in r.parsed.items():
        for p, d in items:
            for other in getattr(d, "filteredCollisions", None) or ():
                a, b = _owner(out, owners, str(p)), _owner(out, owners, str(other))
                if a is not None and b is not None and a.index != b.index:
                    world.exclude_collision(a.index, b.index)
    groups = r.descs("CollisionGroup")
    if not groups:
        return
    if len(groups) > MAX_GROUPS:
        raise r.error(f"{len(groups)} collision groups; tumble's filter bits hold {MAX_GROUPS}", groups[MAX_GROUPS][0])
    bit = {str(p): 1 << (k + 1) for k, (p, _) in enumerate(groups)}
    every = (1 << 32) - 1
    # group g collides with group h unless filtered (symmetric: a filter names a pair)
    blocked = {g: 0 for g in bit}
    for p, d in groups:
        listed = 0
        for h in d.filteredGroups:
            if str(h) not in bit:
                raise r.error(f"filteredGroups names {str(h)!r}, not a collision group", p)
            listed |= bit[str(h)]
        # the attribute itself: the parser's descriptor reports invertFilteredGroups true on groups
        # that do not author it (usd-core 26.11; its default is false)
        invert = bool(r.attr(p, "physics:invertFilteredGroups") or False)
        mine = (every & ~1 & ~listed) if invert else listed
        for h, b in bit.items():
            if mine & b:
                blocked[str(p)] |= b
                blocked[h] |= bit[str(p)]
    membership = {}  # body index -> bits
    for cpath, (kind, cd) in shapes.items():
        body = _owner(out, owners, cpath)
        if body is None:
            continue
        bits = 0
        for g in cd.collisionGroups:
            bits |= bit.get(str(g), 0)
        if body.index in membership and membership[body.index] != bits:
            raise r.error("its colliders are in different collision groups (tumble's filter is per body)",
                          [p for p, b in out.bodies.items() if b.index == body.index][0])
        membership[body.index] = bits
    for index, bits in membership.items():
        if not bits:
            continue
        mask = every
        for g, b in bit.items():
            if bits & b:
                mask &= ~blocked[g]
        world.collision_filters[index] = CollisionFilter(category=bits, mask=mask)
    world.filter_version += 1


def _joint_frame(r, out, body_path, pos, rot):
    """World anchor (3,) and frame (3, 3) of a joint's local frame on a body (or the world)."""
    p = _vec(pos) * r.mpu
    Rl = _quat_matrix(_quat(rot))
    if not body_path:
        return r.A @ p + r.t, r.A @ Rl
    if body_path not in out.bodies:
        return None
    body = out.bodies[body_path]
    # the prim's frame: the body's frame less its centre-of-mass offset (com_offset, shape frame)
    R = body.R.copy()
    origin = body.x - R @ np.asarray(body.com_offset, dtype=float)
    return origin + R @ p, R @ Rl


def _joints(r, world, out):
    kinds = ("RevoluteJoint", "PrismaticJoint", "SphericalJoint", "FixedJoint", "DistanceJoint", "D6Joint")
    for kind, items in r.parsed.items():
        if kind.endswith("Joint") and kind not in kinds:
            raise r.error(f"{kind.replace('Joint', ' joint')}s are not supported (revolute, prismatic, "
                          "spherical, fixed, distance and D6 joints that are one of those are)", items[0][0])
    # in the stage's order (its prims depth first, as a file lists them), whatever their kinds
    rank = {str(p.GetPath()): k for k, p in enumerate(r.stage.Traverse())}
    found = sorted(((jpath, kind, d) for kind in kinds for jpath, d in r.descs(kind)),
                   key=lambda item: rank.get(str(item[0]), len(rank)))
    for jpath, kind, d in found:
        if kind == "D6Joint":
            kind, d = _d6_as(r, jpath, d)
        if not d.jointEnabled:
            continue
        b0, b1 = str(d.body0), str(d.body1)
        for b in (b0, b1):
            if b and b not in out.bodies:
                raise r.error(f"its body {b!r} is not a rigid body or collider of this stage", jpath)
        for k, rel in ((0, str(d.rel0)), (1, str(d.rel1))):
            if rel and not r.stage.GetPrimAtPath(rel):  # a target not on the stage, not the world
                raise r.error(f"its body{k} <{rel}> is not on this stage", jpath)
        # a side on a static prim is the world to the parser (its local frame comes in world
        # coordinates); when that prim became a fixed body, the joint holds on to it
        s0 = out.bodies.get(str(d.rel0)) if not b0 else out.bodies[b0]
        s1 = out.bodies.get(str(d.rel1)) if not b1 else out.bodies[b1]
        if s0 is None and s1 is None:
            raise r.error("a joint needs at least one body", jpath)
        p0, F0 = _joint_frame(r, out, b0, d.localPose0Position, d.localPose0Orientation)
        p1, F1 = _joint_frame(r, out, b1, d.localPose1Position, d.localPose1Orientation)
        common = dict(max_force=_f(d.breakForce) if math.isfinite(d.breakForce) else math.inf,
                      max_torque=_f(d.breakTorque) if math.isfinite(d.breakTorque) else math.inf,
                      collide_connected=bool(d.collisionEnabled), name=str(jpath))
        # tumble's body_a is a body; body_b may be the world. Its coordinate is body_b's motion
        # relative to body_a's, the schema's body1's relative to body0's: the same but when
        # body0 is the world (then body1 is tumble's body_a and the coordinate runs the other way)
        flipped = s0 is None
        if flipped:
            common.update(body_a=s1.index, body_b=None, anchor=p1, anchor_b=p0)
        else:
            common.update(body_a=s0.index, body_b=None if s1 is None else s1.index, anchor=p0, anchor_b=p1)
        try:
            joint = _joint(r, kind, d, jpath, F0, F1, p0, p1, common, flipped)
            world.add_joint(joint)
        except InputError as err:
            raise r.on_prim(err, jpath) from None
        if kind != "DistanceJoint":
            _schema_frames(world, joint, F0, F1, _axis_index(getattr(d, "axis", "Z")), flipped)
        out.joints[str(jpath)] = joint


_DOFS = ("TransX", "TransY", "TransZ", "RotX", "RotY", "RotZ")


def _d6_as(r, jpath, d):
    """A D6 joint (the schema's generic ``PhysicsJoint``: each of its six degrees of freedom free,
    limited by a ``PhysicsLimitAPI`` or locked by one whose low is above its high) as the joint it
    is: all locked, fixed; one rotation left, revolute about it; one translation, prismatic
    along it; the three rotations free, spherical. (kind, a descriptor of that kind's fields.)"""
    from types import SimpleNamespace

    limits = {str(dof).rsplit(".", 1)[-1]: lim for dof, lim in ((p.first, p.second) for p in d.jointLimits)}
    drives = {str(dof).rsplit(".", 1)[-1]: drv for dof, drv in ((p.first, p.second) for p in d.jointDrives)}
    if "Distance" in limits:
        raise r.error("a D6 joint with a distance limit is not supported", jpath)
    locked = {k for k, lim in limits.items() if lim.enabled and lim.lower > lim.upper}
    left = [k for k in _DOFS if k not in locked]
    fields = {n: getattr(d, n) for n in ("body0", "body1", "rel0", "rel1", "breakForce", "breakTorque", "collisionEnabled",
                                          "jointEnabled", "localPose0Position", "localPose0Orientation",
                                          "localPose1Position", "localPose1Orientation")}
    off = SimpleNamespace(enabled=False, lower=0.0, upper=0.0)
    no_drive = SimpleNamespace(enabled=False, targetPosition=0.0, targetVelocity=0.0, forceLimit=math.inf, stiffness=0.0,
                               damping=0.0, acceleration=False)
    if not left:
        return "FixedJoint", SimpleNamespace(**fields)
    if len(left) == 1:
        dof = left[0]
        kind = "RevoluteJoint" if dof.startswith("Rot") else "PrismaticJoint"
        return kind, SimpleNamespace(**fields, axis=dof[-1], limit=limits.get(dof, off), drive=drives.get(dof, no_drive))
    if left == ["RotX", "RotY", "RotZ"] and not any(k in limits or k in drives for k in left):
        return "SphericalJoint", SimpleNamespace(**fields, axis="X", limit=off)
    raise r.error(f"a D6 joint with {', '.join(left)} free is not supported (tumble takes a D6 joint that is fixed, "
                  "revolute, prismatic or a free ball)", jpath)


def _schema_frames(world, joint, F0, F1, axis: int, flipped: bool):
    """Give the bound joint the schema's two frames (world (3, 3) at load, the joint axis in
    column ``axis``) as its body-fixed frames, the axis as their z (tumble's joint frames): so the
    joint's coordinate is the schema's from the start, a hinge 30 deg open at load reads 30 deg,
    and its limits stay the schema's (the way ``load_urdf`` starts a robot at its
    ``joint_positions``: frames of the zero pose, bodies where they are). ``add_joint`` made both
    frames equal to the axis' frame now: the solver has not read them yet."""
    order = [(axis + 1) % 3, (axis + 2) % 3, axis]  # a cyclic turn of the columns: still right-handed
    Fa, Fb = (F1, F0) if flipped else (F0, F1)
    b = joint.bound
    for side, F in ((b.body_a, Fa), (b.body_b, Fb)):
        R = np.eye(3) if side < 0 else np.asarray(world.R[side])
        frame = R.T @ F[:, order]
        if side == b.body_a:
            b.frame_a = frame
        else:
            b.frame_b = frame


def _joint(r, kind, d, jpath, F0, F1, p0, p1, common, flipped: bool):
    """The tumble joint of one joint descriptor (world anchors p0, p1 (3,) m and frames F0, F1
    (3, 3) of its two local frames)."""
    from .joints import BallJoint, DistanceJoint, FixedJoint, HingeJoint, SliderJoint

    if kind == "FixedJoint":
        return FixedJoint(**common)
    if kind == "DistanceJoint":
        lo = _f(d.limit.lower) * r.mpu if d.minEnabled and d.limit.lower >= 0 else None
        hi = _f(d.limit.upper) * r.mpu if d.maxEnabled and d.limit.upper >= 0 else None
        if lo is None and hi is None:
            raise r.error("a distance joint with neither minDistance nor maxDistance", jpath)
        return DistanceJoint(min_length=lo, max_length=hi, **common)
    axis = _axis_index(d.axis)
    a = F0[:, axis]
    if kind == "SphericalJoint":
        lo, hi = _f(d.limit.lower), _f(d.limit.upper)
        cone = None
        if d.limit.enabled and lo >= 0 and hi >= 0:
            if abs(lo - hi) > 1e-9 * max(1.0, abs(lo)):
                raise r.error(f"coneAngle0Limit {lo:g} and coneAngle1Limit {hi:g} differ: tumble's swing cone is round",
                              jpath)
            cone = math.radians(lo)
        return BallJoint(axis=tuple(a), cone_limit=cone, **common)
    if kind == "RevoluteJoint":
        # the joint is given the schema's frames (_schema_frames): its angle is the schema's
        start = 0.0
        scale = math.pi / 180.0
    else:
        # tumble's slider coordinate is (anchor_b - anchor_a) . axis from the anchors as given, apart
        # or not: the frames' distance along the axis at load is in it already
        start = 0.0
        scale = r.mpu
    kw = {}
    if d.limit.enabled:
        lo, hi = _f(d.limit.lower), _f(d.limit.upper)
        if math.isfinite(lo) and lo > -1e30:
            kw["lower"] = lo * scale - start
        if math.isfinite(hi) and hi < 1e30:
            kw["upper"] = hi * scale - start
    drive = d.drive
    if drive.enabled:
        if drive.acceleration:
            raise r.error("acceleration drives are not supported (force drives are)", jpath)
        stiffness, damping = _f(drive.stiffness), _f(drive.damping)
        limit = _f(drive.forceLimit)
        limit = math.inf if not math.isfinite(limit) or limit > 1e30 else limit
        # per degree in the schema for angles: N m / deg -> N m / rad
        per = 180.0 / math.pi if kind == "RevoluteJoint" else 1.0 / r.mpu
        # a velocity motor: a target velocity with no stiffness and a damping of none or PhysX's stiff
        # kind (at least STIFF_DAMPING: taken as infinite; what save_usd writes a motor as); any
        # other drive is the schema's law, stiffness (tp - q) + damping (tv - q'), tumble's drive
        # with its target velocity (session 44: a finite damping with a target velocity was read as
        # a motor, of infinite gain, and a stiffness with one was refused)
        motor = drive.targetVelocity != 0.0 and stiffness == 0.0 and not 0.0 < damping < STIFF_DAMPING
        if not motor and (stiffness > 0.0 or damping > 0.0):
            kw.update(stiffness=stiffness * per, damping=damping * per, target=_f(drive.targetPosition) * scale - start)
            kw["max_drive_torque" if kind == "RevoluteJoint" else "max_drive_force"] = limit
            if drive.targetVelocity != 0.0:
                kw["target_velocity"] = _f(drive.targetVelocity) * scale
        if motor:
            kw["motor_speed"] = _f(drive.targetVelocity) * scale
            kw["max_motor_torque" if kind == "RevoluteJoint" else "max_motor_force"] = limit
    if flipped:
        kw = _flip(kw)
    armature = r.attr(jpath, "physxJoint:armature")  # PhysX's joint schema (PhysxJointAPI): what save_usd writes
    if armature is not None and float(armature) > 0.0:
        # mass units times distance units squared about an axis, mass units along one
        kw["armature"] = _f(armature) * r.kpu * (r.mpu ** 2 if kind == "RevoluteJoint" else 1.0)
    cls = HingeJoint if kind == "RevoluteJoint" else SliderJoint
    return cls(axis=tuple(a), **common, **kw)


def _flip(kw: dict) -> dict:
    out = dict(kw)
    lo, hi = kw.get("lower"), kw.get("upper")
    out.pop("lower", None)
    out.pop("upper", None)
    if hi is not None:
        out["lower"] = -hi
    if lo is not None:
        out["upper"] = -lo
    if "target" in kw:
        out["target"] = -kw["target"]
    if "motor_speed" in kw:
        out["motor_speed"] = -kw["motor_speed"]
    return out
