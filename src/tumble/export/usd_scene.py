"""A World written as a USD stage with physics (the UsdPhysics schema): ``save_usd``.

The other direction of ``tumble.usd_physics.load_usd``: what a scene file, a URDF or an MJCF
model built in tumble becomes for Omniverse, Isaac Sim or PhysX, or for tumble again (``load_usd``
of the written stage gives back the same bodies, to the schema's single precision). The stage:

* metadata: z up, metres, kilograms; ``/World`` the default prim; a ``PhysicsScene`` with the
  World's gravity.
* one Xform per body under ``/World`` (named as ``export.usd.prim_names`` names them; the body's
  name in ``customData["tumble:name"]``) at its centre of mass and orientation (translate and
  orient, doubles), with ``PhysicsRigidBodyAPI`` (velocity in m/s and angular velocity in deg/s,
  both world: ``/World`` is not transformed), ``kinematicEnabled`` for a kinematic body, and
  ``PhysicsMassAPI``: mass, ``centerOfMass`` (0: the Xform sits on it), ``diagonalInertia`` and
  ``principalAxes`` (the principal moments and axes of Ibody). A fixed body has
  ``rigidBodyEnabled = false`` (a static body: its colliders one body, as ``load_usd`` reads it).
* its colliders under it, where the shape sits in the body frame (``-com_offset``): ``Cube``
  (size 1, scaled), ``Sphere``, ``Capsule``, ``Cylinder`` (axis Z), ``Cone`` (axis Z, moved half its
  height: USD's is centred), convex hulls and meshes as ``Mesh`` with ``PhysicsMeshCollisionAPI``
  (``convexHull`` on a moving body, ``none`` on a fixed one), a compound's parts each its own
  prim, an ellipsoid as the hull of 642 of its surface points; a plane as a ``Plane`` prim; each
  with a physics material (``staticFriction`` = ``dynamicFriction`` = the friction, ``restitution``)
  shared by the colliders that have the same one.
* joints under ``/World/joints``: hinge -> ``PhysicsRevoluteJoint``, slider -> ``PhysicsPrismaticJoint``,
  ball -> ``PhysicsSphericalJoint``, fixed -> ``PhysicsFixedJoint``, distance ->
  ``PhysicsDistanceJoint``, each with its two body frames (``localPos0/1``, ``localRot0/1``: the
  joint frames fixed in each body at its creation, axis Z), limits (degrees for angles), drives
  (stiffness and damping per degree; a velocity motor as a drive with a target velocity and a
  damping of 1e10, PhysX's stiff velocity drive), break force and torque, ``collisionEnabled``;
  a broken joint with ``jointEnabled = false``; joint armature (MuJoCo's) as PhysX's
  ``physxJoint:armature`` (``PhysxJointAPI``, which Isaac Sim reads and ``load_usd`` reads back).
* excluded pairs as ``PhysicsFilteredPairsAPI``.

* collision filters (Box2D's category, mask and group) as ``PhysicsCollisionGroup`` prims: one
  per distinct filter, each filtering the groups its filter does not collide with (exact).

A body's gravity scale (``World.set_gravity_scale``) of 0 is written as PhysX's
``physxRigidBody:disableGravity`` and its damping rates (``World.set_damping``) as
``physxRigidBody:linearDamping`` and ``angularDamping`` (``PhysxRigidBodyAPI``, read back by
``load_usd``); a scale other than 0 and 1 is named in the warning below (PhysX has none).

A disabled body (``World.set_enabled``) is written as it is held, a fixed body, with its Xform's
``visibility`` ``invisible`` (hidden, as in every export); the schema has no body out of the
simulation, so the warning below names it (and ``load_usd`` reads it back a fixed body).

What the schema has no place for is left out with one ``TumbleWarning`` naming it: sensors,
surface velocities, rolling resistance and spinning friction, a ball joint's twist limits and drive, joint
springs of distance joints, applied joint efforts, universal and gear joints, the repetition of
a repeating keyframed path, forces other than gravity. A kinematic body's keyframed path is written as time samples of its transform (24
codes a second), which ``load_usd`` reads back as a path.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np

from ..collision.filter import CollisionFilter
from ..errors import InputError, TumbleWarning
from ..joints import (JOINT_BALL, JOINT_DISTANCE, JOINT_FIXED, JOINT_HINGE, JOINT_SLIDER, P_BALL_DAMPING,
                      P_BALL_STIFFNESS, P_DAMPING, P_LIMIT_ON,
                      P_LOWER, P_LIMIT2_ON, P_MAX_DRIVE, P_MAX_FORCE, P_MAX_MOTOR, P_MAX_TORQUE, P_MOTOR_ON,
                      P_MOTOR_SPEED, P_STIFFNESS, P_TARGET, P_TARGET_RATE, P_UPPER, P_EFFORT, P_ARMATURE, P_PASSIVE_DAMPING,
                      P_PASSIVE_STIFFNESS, P_SPRINGREF)
from ..joints import _frame_from_z
from ..mass import _quat_matrix
from ..math3d import matrix_to_quat
from ..shapes import Box, Capsule, Compound, Cone, Convex, Cylinder, Ellipsoid, Mesh, Particles, Plane, Sphere
from .usd import SUFFIXES, prim_names, write_stage

# PhysX's velocity drive made stiff: a drive of this damping holds its target velocity (tumble's motor)
MOTOR_DAMPING = 1e10


def _matrix_quat(R):
    return matrix_to_quat(np.ascontiguousarray(R, dtype=float))


def save_usd(world, path) -> Path:
    """Write ``world`` (its bodies at their current state, its joints) as a UsdPhysics stage at
    ``path`` (``.usda`` text, ``.usd`` / ``.usdc`` binary). See the module's docstring.

    Raises:
        InputError: a body tumble cannot write (particles: the schema's bodies collide with shapes).
    """
    from pxr import Usd

    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise InputError(f"a USD file name ends in {', '.join(SUFFIXES)}", None, str(path))
    stage = Usd.Stage.CreateInMemory()
    build_physics_stage(world, stage)
    return write_stage(stage, path)


class _Writer:
    def __init__(self, world, stage):
        from pxr import Gf, Sdf, UsdGeom, UsdPhysics, UsdShade, Vt

        self.world, self.stage = world, stage
        self.Gf, self.Sdf, self.UsdGeom, self.UsdPhysics, self.UsdShade, self.Vt = Gf, Sdf, UsdGeom, UsdPhysics, UsdShade, Vt
        self.materials = {}
        self.left_out = set()

    def vec(self, v):
        return self.Gf.Vec3d(*map(float, v))

    def vecf(self, v):
        return self.Gf.Vec3f(*map(float, v))

    def quat(self, q):
        return self.Gf.Quatd(*map(float, q))

    def quatf(self, q):
        return self.Gf.Quatf(*map(float, q))

    def material(self, mat):
        if mat is None:
            return None
        if mat.rolling_resistance or mat.spinning_friction:
            self.left_out.add("rolling resistance and spinning friction")
        if mat.margin:
            self.left_out.add("margins")
        if mat.condim is not None:
            self.left_out.add("MuJoCo's condim")
        key = (float(mat.friction), float(mat.restitution), mat.friction_combine, mat.restitution_combine)
        if key not in self.materials:
            m = self.UsdShade.Material.Define(self.stage, f"/World/Looks/physics{len(self.materials)}")
            api = self.UsdPhysics.MaterialAPI.Apply(m.GetPrim())
            api.CreateStaticFrictionAttr(key[0])
            api.CreateDynamicFrictionAttr(key[0])
            api.CreateRestitutionAttr(key[1])
            for mode, attr in zip(key[2:], ("frictionCombineMode", "restitutionCombineMode")):
                if mode == "geometric":  # tumble's own, not one of PhysX's
                    self.left_out.add("the geometric combine mode")
                elif mode is not None:  # PhysX's attribute (PhysxSchema's PhysxMaterialAPI), as a token
                    m.GetPrim().CreateAttribute(f"physxMaterial:{attr}", self.Sdf.ValueTypeNames.Token).Set(mode)
            self.materials[key] = m
        return self.materials[key]

    def bind(self, prim, mat):
        m = self.material(mat)
        if m is not None:
            self.UsdShade.MaterialBindingAPI.Apply(prim).Bind(m, self.UsdShade.Tokens.weakerThanDescendants, "physics")

    def place(self, geom, pos, q):
        geom.AddTranslateOp(self.UsdGeom.XformOp.PrecisionDouble).Set(self.vec(pos))
        geom.AddOrientOp(self.UsdGeom.XformOp.PrecisionDouble).Set(self.quat(q))

    def collider(self, path, shape, pos, q, moving: bool, material, name: str):
        """One collider prim at ``path`` (its shape at pos, q in the body frame)."""
        G, P = self.UsdGeom, self.UsdPhysics
        pos, q = np.asarray(pos, dtype=float), np.asarray(q, dtype=float)
        if isinstance(shape, Box):
            g = G.Cube.Define(self.stage, path)
            g.GetSizeAttr().Set(1.0)
            self.place(g, pos, q)
            g.AddScaleOp(G.XformOp.PrecisionDouble).Set(self.vec(shape.size))
        elif isinstance(shape, Sphere):
            g = G.Sphere.Define(self.stage, path)
            g.GetRadiusAttr().Set(float(shape.radius))
            self.place(g, pos, q)
        elif isinstance(shape, (Capsule, Cylinder)):
            g = (G.Capsule if isinstance(shape, Capsule) else G.Cylinder).Define(self.stage, path)
            g.GetRadiusAttr().Set(float(shape.radius))
            g.GetHeightAttr().Set(float(shape.length))
            g.GetAxisAttr().Set("Z")
            self.place(g, pos, q)
        elif isinstance(shape, Cone):
            g = G.Cone.Define(self.stage, path)
            g.GetRadiusAttr().Set(float(shape.radius))
            g.GetHeightAttr().Set(float(shape.height))
            g.GetAxisAttr().Set("Z")
            # USD's cone is centred on its bounding box: its centre half the height up tumble's
            self.place(g, pos + _quat_matrix(q) @ np.array([0.0, 0.0, 0.5 * shape.height]), q)
        elif isinstance(shape, (Mesh, Ellipsoid)):
            if isinstance(shape, Ellipsoid):
                import trimesh

                sphere = trimesh.creation.icosphere(subdivisions=3)
                vertices, faces = sphere.vertices * np.asarray(shape.radii), sphere.faces
                hull = True
                self.left_out.add("ellipsoids (written as the convex hull of 642 surface points)")
            else:
                vertices, faces = shape.vertices, shape.faces
                hull = moving or isinstance(shape, Convex)
            g = G.Mesh.Define(self.stage, path)
            g.CreatePointsAttr(self.Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(vertices, dtype=np.float32)))
            g.CreateFaceVertexCountsAttr(self.Vt.IntArray.FromNumpy(np.full(len(faces), 3, dtype=np.int32)))
            g.CreateFaceVertexIndicesAttr(self.Vt.IntArray.FromNumpy(np.ascontiguousarray(
                np.asarray(faces).reshape(-1), dtype=np.int32)))
            g.CreateSubdivisionSchemeAttr(G.Tokens.none)
            if isinstance(shape, Mesh) and not shape.closed:
                # an open, two-sided surface (Mesh(closed=False)): drawn from both sides, and marked so that
                # a closed shell held open (bodies inside it) comes back open, not as a solid
                g.CreateDoubleSidedAttr(True)
                g.GetPrim().SetCustomDataByKey("tumble:closed", False)
            self.place(g, pos, q)
            P.MeshCollisionAPI.Apply(g.GetPrim()).CreateApproximationAttr("convexHull" if hull else "none")
        else:
            raise InputError(f"a {type(shape).__name__} has no UsdPhysics collider", name)
        P.CollisionAPI.Apply(g.GetPrim())
        self.bind(g.GetPrim(), material)
        return g

    def body(self, i: int, prim_name: str):
        w, G, P = self.world, self.UsdGeom, self.UsdPhysics
        name = w.names[i]
        shape = w.shapes[i]
        material = w.materials[i]
        if isinstance(shape, Plane):
            # the plane n . p = offset of the shape's frame, in the world: a Plane prim (axis Z) there
            R = np.asarray(w.R[i])
            origin = np.asarray(w.x[i]) - R @ np.asarray(w.com_offset[i])
            n = R @ np.asarray(shape.normal)
            offset = shape.offset + float(n @ origin)
            g = G.Plane.Define(self.stage, f"/World/{prim_name}")
            g.GetAxisAttr().Set("Z")
            self.place(g, offset * n, _matrix_quat(_frame_from_z(n)))
            P.CollisionAPI.Apply(g.GetPrim())
            self.bind(g.GetPrim(), material)
            g.GetPrim().SetCustomDataByKey("tumble:name", name)
            return
        if isinstance(shape, Particles) or shape is None:
            raise InputError("a body of particles has no collider to write (UsdPhysics bodies collide by their shapes)",
                             name)
        xf = G.Xform.Define(self.stage, f"/World/{prim_name}")
        prim = xf.GetPrim()
        prim.SetCustomDataByKey("tumble:name", name)
        self.place(xf, w.x[i], w.q[i])
        moving = bool(w.moving[i])
        kinematic = bool(w.kinematic[i])
        rb = P.RigidBodyAPI.Apply(prim)
        if moving or kinematic:
            rb.CreateVelocityAttr(self.vecf(w.v[i]))
            rb.CreateAngularVelocityAttr(self.vecf(np.degrees(w.omega[i])))
            if kinematic:
                rb.CreateKinematicEnabledAttr(True)
        else:  # a static body (PhysX's rule): its colliders stay together as one body
            rb.CreateRigidBodyEnabledAttr(False)
        if moving:
            m = P.MassAPI.Apply(prim)
            m.CreateMassAttr(float(w.mass[i]))
            m.CreateCenterOfMassAttr(self.vecf((0.0, 0.0, 0.0)))
            m.CreateDiagonalInertiaAttr(self.vecf(w.principal_moments[i]))
            m.CreatePrincipalAxesAttr(self.quatf(w.principal_q[i]))
        scale = float(w.gravity_scale[i])
        damping = [float(c) for c in w.damping[i]]
        if scale == 0.0 or any(damping):
            # PhysX's rigid-body schema (PhysxRigidBodyAPI), which Isaac Sim and load_usd read; applied
            # by name (USD keeps an applied schema it does not know)
            prim.AddAppliedSchema("PhysxRigidBodyAPI")
        if scale == 0.0:
            prim.CreateAttribute("physxRigidBody:disableGravity", self.Sdf.ValueTypeNames.Bool).Set(True)
        for kind, c in zip(("linear", "angular"), damping):
            if c:
                prim.CreateAttribute(f"physxRigidBody:{kind}Damping", self.Sdf.ValueTypeNames.Float).Set(c)
        if scale not in (0.0, 1.0):
            self.left_out.add("gravity scales other than 0 and 1 (the body feels the whole of m g)")
        if w.sensor[i]:
            self.left_out.add("sensors (written as ordinary colliders)")
        if w.disabled[i]:  # held as a fixed body touching nothing: hidden, and named in the warning
            xf.CreateVisibilityAttr(G.Tokens.invisible)
            self.left_out.add("disabled bodies (written as hidden fixed bodies)")
        if np.any(w.surface_velocity[i]):
            self.left_out.add("surface velocities (conveyor belts)")
        shift = -np.asarray(w.com_offset[i], dtype=float)
        if isinstance(shape, Compound):
            mats = shape.materials or [None] * len(shape.parts)
            for k, (part, pos, q) in enumerate(shape.parts):
                self.collider(f"/World/{prim_name}/part{k}", part, shift + np.asarray(pos), q, moving or kinematic,
                              mats[k] if mats[k] is not None else material, name)
        else:
            self.collider(f"/World/{prim_name}/collider", shape, shift, (1.0, 0.0, 0.0, 0.0), moving or kinematic,
                          material, name)

    def joint(self, k: int, joint, paths: list[str]):
        P = self.UsdPhysics
        b = joint.bound
        kinds = {JOINT_HINGE: P.RevoluteJoint, JOINT_SLIDER: P.PrismaticJoint, JOINT_BALL: P.SphericalJoint,
                 JOINT_FIXED: P.FixedJoint, JOINT_DISTANCE: P.DistanceJoint}
        if b is None or b.type_id not in kinds:
            self.left_out.add(f"{joint.kind} joints")
            return
        j = kinds[b.type_id].Define(self.stage, f"/World/joints/joint{k}")
        prim = j.GetPrim()
        if joint.name:
            prim.SetCustomDataByKey("tumble:name", str(joint.name))
        p = b.param
        for side, body, local, frame in ((0, b.body_a, b.local_a, b.frame_a), (1, b.body_b, b.local_b, b.frame_b)):
            if body >= 0:
                (j.CreateBody0Rel() if side == 0 else j.CreateBody1Rel()).SetTargets([self.Sdf.Path(paths[body])])
            (j.CreateLocalPos0Attr if side == 0 else j.CreateLocalPos1Attr)(self.vecf(local))
            (j.CreateLocalRot0Attr if side == 0 else j.CreateLocalRot1Attr)(self.quatf(_matrix_quat(frame)))
        j.CreateCollisionEnabledAttr(bool(joint.collide_connected))
        if math.isfinite(p[P_MAX_FORCE]):
            j.CreateBreakForceAttr(float(p[P_MAX_FORCE]))
        if math.isfinite(p[P_MAX_TORQUE]):
            j.CreateBreakTorqueAttr(float(p[P_MAX_TORQUE]))
        if joint.broken:
            j.CreateJointEnabledAttr(False)
        if p[P_EFFORT] != 0.0:
            self.left_out.add("applied joint efforts")
        if p[P_ARMATURE] != 0.0:
            # not in UsdPhysics: PhysX's own joint schema (PhysxSchema.PhysxJointAPI, which Isaac Sim
            # reads) has it; applied by name (USD keeps an applied schema it does not know)
            prim.AddAppliedSchema("PhysxJointAPI")
            prim.CreateAttribute("physxJoint:armature", self.Sdf.ValueTypeNames.Float).Set(float(p[P_ARMATURE]))
        if b.type_id in (JOINT_HINGE, JOINT_SLIDER):
            angular = b.type_id == JOINT_HINGE
            unit = 180.0 / math.pi if angular else 1.0  # the schema's angles are degrees
            j.CreateAxisAttr("Z")
            if p[P_LIMIT_ON]:
                if math.isfinite(p[P_LOWER]):
                    j.CreateLowerLimitAttr(float(p[P_LOWER] * unit))
                if math.isfinite(p[P_UPPER]):
                    j.CreateUpperLimitAttr(float(p[P_UPPER] * unit))
            # the drive and the joint's passive spring-damper (``passive_*``): the schema has one drive a
            # joint, so the two go out summed (linear in q and q': the same law below the cap), the
            # target their stiffness-weighted rest; a drive's cap then holds the sum (PhysX's, as
            # tumble's MJCF reader did before session 43)
            stiffness, damping, target = p[P_STIFFNESS], p[P_DAMPING], p[P_TARGET]
            # the drive's target velocity w: its damping's pull c w, over the damping written
            rate_pull = p[P_DAMPING] * p[P_TARGET_RATE]
            if p[P_PASSIVE_STIFFNESS] != 0.0 or p[P_PASSIVE_DAMPING] != 0.0:
                stiffness, damping = stiffness + p[P_PASSIVE_STIFFNESS], damping + p[P_PASSIVE_DAMPING]
                if stiffness > 0.0:
                    target = (p[P_STIFFNESS] * p[P_TARGET] + p[P_PASSIVE_STIFFNESS] * p[P_SPRINGREF]) / stiffness
                if math.isfinite(p[P_MAX_DRIVE]):
                    self.left_out.add("a joint's passive spring and damper beside a capped drive (written summed "
                                      "into the drive, under its cap)")
            pd = stiffness > 0.0 or damping > 0.0
            if pd or p[P_MOTOR_ON]:
                drive = P.DriveAPI.Apply(prim, "angular" if angular else "linear")
                drive.CreateTypeAttr("force")
                if pd:  # gains per degree for angles
                    drive.CreateStiffnessAttr(float(stiffness / unit))
                    drive.CreateDampingAttr(float(damping / unit))
                    drive.CreateTargetPositionAttr(float(target * unit))
                    if rate_pull != 0.0:
                        drive.CreateTargetVelocityAttr(float(rate_pull / damping * unit))
                    if math.isfinite(p[P_MAX_DRIVE]):
                        drive.CreateMaxForceAttr(float(p[P_MAX_DRIVE]))
                    if p[P_MOTOR_ON]:
                        self.left_out.add("a velocity motor beside a PD drive on one joint (the drive is written)")
                else:
                    drive.CreateDampingAttr(MOTOR_DAMPING)
                    drive.CreateTargetVelocityAttr(float(p[P_MOTOR_SPEED] * unit))
                    if math.isfinite(p[P_MAX_MOTOR]):
                        drive.CreateMaxForceAttr(float(p[P_MAX_MOTOR]))
        elif b.type_id == JOINT_BALL:
            j.CreateAxisAttr("Z")
            if p[P_LIMIT_ON]:
                cone = float(np.degrees(p[P_UPPER]))
                j.CreateConeAngle0LimitAttr(cone)
                j.CreateConeAngle1LimitAttr(cone)
            if p[P_LIMIT2_ON]:
                self.left_out.add("ball joints' twist limits")
            if p[P_BALL_STIFFNESS] > 0.0 or p[P_BALL_DAMPING] > 0.0:
                # a spherical joint has no drive in the schema (PhysX drives a D6 joint's rotX/Y/Z or
                # slerp through its own schema)
                self.left_out.add("ball joints' drives")
        elif b.type_id == JOINT_DISTANCE:
            if p[P_LOWER] > 0.0:
                j.CreateMinDistanceAttr(float(p[P_LOWER]))
            if math.isfinite(p[P_UPPER]):
                j.CreateMaxDistanceAttr(float(p[P_UPPER]))
            if p[P_STIFFNESS] > 0.0 or p[P_DAMPING] > 0.0:
                self.left_out.add("distance joints' springs")


# collision groups the schema's filters can hold: tumble's loader gives each group one of 31 bits
MAX_GROUPS = 31


def _collision_groups(world, stage, wr, paths: list[str]) -> None:
    """Box2D's filters (category, mask, group) as ``PhysicsCollisionGroup`` prims, exactly: one
    group per distinct filter among the bodies, and group i filters group j (i = j too) when
    their filters do not collide by Box2D's rule. Nothing when every body has the default."""
    from pxr import UsdPhysics

    filters = list(world.collision_filters)
    if all(f == CollisionFilter() for f in filters):
        return
    classes = sorted(set(filters), key=lambda f: (f.category, f.mask, f.group, f.env))
    if len(classes) > MAX_GROUPS:
        wr.left_out.add(f"collision filters of more than {MAX_GROUPS} kinds")
        return
    groups = []
    for k, f in enumerate(classes):
        g = UsdPhysics.CollisionGroup.Define(stage, f"/World/collision_groups/group{k}")
        g.GetPrim().SetCustomDataByKey("tumble:filter", {"category": f.category, "mask": f.mask, "group": f.group,
                                                                 "env": f.env})
        groups.append(g)
    for k, f in enumerate(classes):
        members = [paths[i] for i, g in enumerate(filters) if g == f]
        groups[k].GetCollidersCollectionAPI().CreateIncludesRel().SetTargets(members)
        blocked = [groups[m].GetPath() for m, h in enumerate(classes) if not f.collides_with(h)]
        if blocked:
            groups[k].CreateFilteredGroupsRel().SetTargets(blocked)


# time codes of the stage's animations (keyframed paths): 24 a second, Blender's and USD's usual
TIME_CODES_PER_SECOND = 24.0


def _animations(world, stage, wr, paths: list[str]) -> None:
    """Each kinematic body's keyframed path (``World.add_path``) as time samples of its Xform's
    translate (its centre of mass) and orient, at time code t * 24 (what ``load_usd`` reads back
    as a path through the same poses). A repeating path is written once round."""
    from pxr import Gf, Usd, UsdGeom

    if not world.paths:
        return
    stage.SetTimeCodesPerSecond(TIME_CODES_PER_SECOND)
    stage.SetStartTimeCode(0.0)
    end = 0.0
    for path in world.paths:
        i = world.index_of(path.body)
        ops = {op.GetOpType(): op for op in UsdGeom.Xformable(stage.GetPrimAtPath(paths[i])).GetOrderedXformOps()}
        translate, orient = ops[UsdGeom.XformOp.TypeTranslate], ops[UsdGeom.XformOp.TypeOrient]
        offset = np.asarray(world.com_offset[i], dtype=float)
        for t, p, q in zip(path.times, path.positions,
                           path.orientations if path.orientations is not None else [world.q[i]] * len(path.times)):
            code = Usd.TimeCode(float(t) * TIME_CODES_PER_SECOND)
            R = _quat_matrix(q)
            translate.Set(Gf.Vec3d(*map(float, np.asarray(p) + R @ offset)), code)
            orient.Set(Gf.Quatd(*map(float, q)), code)
        end = max(end, float(path.times[-1]) * TIME_CODES_PER_SECOND)
        if path.repeat:
            wr.left_out.add("the repetition of repeating keyframed paths (written once round)")
        if path.release:  # PhysX's kinematic flag is a constant of the stage
            wr.left_out.add("the release of keyframed paths that let their body go (it stays kinematic at its last key)")
    stage.SetEndTimeCode(end)


def build_physics_stage(world, stage) -> None:
    """Fill ``stage`` (an empty ``Usd.Stage``) with ``world``: see the module's docstring."""
    from pxr import Gf, UsdGeom, UsdPhysics

    from .. import __version__

    wr = _Writer(world, stage)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, UsdGeom.LinearUnits.meters)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    stage.GetRootLayer().documentation = f"tumble {__version__}: a World as a UsdPhysics stage (z up, metres, kilograms)"
    root = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(root.GetPrim())
    scene = UsdPhysics.Scene.Define(stage, "/World/physicsScene")
    g = np.asarray(world.gravity, dtype=float)
    magnitude = float(np.linalg.norm(g))
    scene.CreateGravityDirectionAttr(Gf.Vec3f(*map(float, g / magnitude)) if magnitude else Gf.Vec3f(0, 0, -1))
    scene.CreateGravityMagnitudeAttr(magnitude)
    names = prim_names(world.names)
    paths = [f"/World/{n}" for n in names]
    for i, prim_name in enumerate(names):
        wr.body(i, prim_name)
    for k, joint in enumerate(getattr(world, "joints", ()) or ()):
        wr.joint(k, joint, paths)
    if world.pair_materials:
        wr.left_out.add("pair materials (World.set_pair_material)")
    for a, b in sorted(world.excluded_collisions):
        api = UsdPhysics.FilteredPairsAPI.Apply(stage.GetPrimAtPath(paths[a]))
        rel = api.GetFilteredPairsRel() or api.CreateFilteredPairsRel()
        rel.AddTarget(paths[b])
    _collision_groups(world, stage, wr, paths)
    from ..forces import Switch

    if any(not isinstance(f, Switch) for f in world.forces):
        wr.left_out.add("forces other than gravity")
    if any(isinstance(f, Switch) for f in world.forces):
        wr.left_out.add("the times bodies are switched in or out of the simulation (Switch records)")
    _animations(world, stage, wr, paths)
    if wr.left_out:
        warnings.warn("the UsdPhysics schema has no place for: " + "; ".join(sorted(wr.left_out)) + " (left out)",
                      TumbleWarning, stacklevel=3)
