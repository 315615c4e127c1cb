"""URDF robots: each link a body, each joint a joint (PyBullet's ``loadURDF``, MuJoCo's URDF import).

``load_urdf(world, path, ...)`` reads a URDF file (the ROS Unified Robot Description Format,
http://wiki.ros.org/urdf/XML) and adds its links and joints to ``world`` with the ordinary
records (``World.add_body``, ``HingeJoint``, ``SliderJoint``, ``FixedJoint``): a robot in tumble is
nothing but bodies and joints, so everything else (contacts, sleeping, checkpoints, export,
joint readings, the tree solver) applies unchanged.

What maps to what (the link and joint frames as the URDF gives them, at joint positions 0):

- ``<link>``: a body whose shape frame is the link frame. Its ``<inertial>`` (mass, the centre
  of mass at ``origin xyz``, the inertia tensor about it in the axes turned by ``origin rpy``)
  is the body's mass, centre of mass and Ibody, given whole (``add_body(center_of_mass=)``:
  nothing is computed from the collision shapes, as in every URDF consumer). Its
  ``<collision>`` elements are the shape (one part, or a ``Compound`` of them): ``box`` (size:
  full side lengths, as tumble's ``Box``), ``cylinder`` and ``capsule`` (along z), ``sphere``,
  ``mesh`` (its vertices' convex hull, scaled by ``scale``: PyBullet's default for a moving body;
  OBJ, STL, PLY through trimesh). ``<visual>`` is not read: tumble draws the collision shapes.
  A link with no collision element touches nothing (a small sphere in category 0, for drawing).
  Bullet's ``<contact>`` extension (``lateral_friction``, ``restitution``) gives the link's
  parts their material (tumble mixes frictions with sqrt, as Box2D, where Bullet multiplies).
- ``<joint>``: ``revolute`` a ``HingeJoint`` with ``<limit lower upper>``; ``continuous`` a hinge
  without limits; ``prismatic`` a ``SliderJoint``; ``fixed`` merges the child link into its
  parent's body (``merge_fixed=True``, MuJoCo's fusing and PyBullet's
  ``URDF_MERGE_FIXED_LINKS``: exact and cheaper; the masses, centres and inertias are combined
  by the parallel-axis theorem) or a ``FixedJoint`` (``merge_fixed=False``); ``floating``: no
  joint (the child is free); ``planar`` is refused. The anchor is the child link's origin,
  the axis ``<axis xyz>`` in the child link's frame (default x). The joint coordinate's zero
  is the URDF's zero, its sign the URDF's. ``<dynamics damping>`` becomes the joint's damping
  (N m s/rad or N s/m, stiffness 0) and ``<dynamics friction>`` a motor of speed 0 limited to
  that torque or force (Box2D's joint friction). ``<limit effort>`` is kept as the default
  limit of the motors ``Robot.set_motor`` and ``set_position_target`` switch on. A side of a
  ``<limit>`` that is left out is no limit on that side, and lower > upper is no limit at all
  (Bullet's convention; the URDF specification says 0, which would lock the joint).
  ``<mimic joint multiplier offset>`` makes the joint follow the named one, q = offset +
  multiplier q_joint, by a ``GearJoint`` (in ``Robot.equalities`` under the mimic joint's name;
  PyBullet does not read mimic, where a mimic joint moves on its own); a mimic joint that
  ``joint_positions`` leaves out starts on its relation. ``<calibration>`` and
  ``<safety_controller>`` are not read (nor by PyBullet).
- The root link: its body is fixed with ``fixed_base=True`` (PyBullet's ``useFixedBase``) or
  when it has no mass (PyBullet's rule for a base of mass 0; a ROS ``world`` link).
- Self-collision: off by default (PyBullet's default): no two bodies of one robot touch. With
  ``self_collision=True`` bodies touch unless a joint links them (MuJoCo's parent-child rule).

Names: body ``"{robot}/{link}"``, joint ``"{robot}/{joint}"``; ``robot`` is ``name`` or the
URDF's ``<robot name>``. A file's problems are ``InputError`` lines keyed by the element, e.g.
``arm.urdf: joint[elbow].limit.lower: expected a number, got 'abc'``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .collision.filter import CollisionFilter
from .errors import InputError
from .joints import BallJoint, FixedJoint, HingeJoint, SliderJoint, P_DAMPING, P_EFFORT, P_MAX_DRIVE, P_MAX_MOTOR, \
    P_MOTOR_ON, P_MOTOR_SPEED, P_STIFFNESS, P_TARGET, P_TARGET_RATE
from .material import Material
from .mass import combine_mass_properties
from .math3d import (
    mat_mat,
    mat_t_mat,
    mat_t_vec,
    mat_vec,
    matrix_to_quat,
    quat_from_euler_deg,
    quat_to_matrix,
    rotate_tensor,
)
from .shapes import Compound, Plane, Sphere, finite_vector
from .urdf_read import (  # noqa: F401  (the reader's names, public here too)
    JOINT_KINDS,
    UrdfJoint,
    UrdfLink,
    UrdfModel,
    read_urdf,
    resolve_mesh_path,
    rpy_matrix,
)

INERTIA_SOURCES = ("file", "balance", "shapes")
# a link without collision shapes is drawn as a sphere of this radius (m) that touches nothing
MARKER_RADIUS = 0.02
NO_CONTACT = CollisionFilter(category=0, mask=0)


@dataclass
class Robot:
    """A URDF robot in a world: its bodies and joints are ordinary ones.

    Attributes:
        name: the prefix of its body and joint names.
        model: the ``UrdfModel`` read from the file.
        links: {link name: ``Body``}: links merged into a parent share its body.
        joints: {URDF joint name: joint record} (the moving joints, and the fixed ones when not
            merged), in the file's order.
        base: the root link's body.
        link_frames: {link name: (position (3,) m, rotation (3, 3))}: the link frame in its
            body's shape frame (identity for a body's own link).
        owners: {link name: the link whose body it is part of} (itself, or the parent it was
            merged into).
        actuators: {name: actuator} of an MJCF model (``mjcf.MjcfActuator``, in the file's order:
            MuJoCo's ``ctrl`` order), driven by ``set_controls``; empty for a URDF.
        equalities: {name: joint record} of an MJCF model's ``<equality>`` constraints
            (``connect``: a ``BallJoint``, ``weld``: a ``FixedJoint``, ``joint``: a ``GearJoint``),
            or of a URDF's ``<mimic>`` joints (a ``GearJoint`` under the mimic joint's name).
        sites: {name: (link, position (3,) m, rotation (3, 3))} in the link frame: an MJCF model's
            ``<site>`` frames (``site_pose``); empty for a URDF.
        cameras: {name: ``tb.Camera``} mounted on their links' bodies: an MJCF model's fixed
            ``<camera>``s; empty for a URDF.
        keyframes: {name: (qpos, qvel, ctrl)} of an MJCF model's ``<keyframe>`` keys (each None where
            the key leaves it out), for ``reset_to_keyframe``; empty for a URDF.
        sensors: {name: ``mjcf_sensors.MjcfSensor``} of an MJCF model's ``<sensor>``s that tumble
            reads (``sensor_data``); empty for a URDF. ``sensors_left_off``: the names of the others.
        tendons: {name: ((joint, coef), ...)} of an MJCF model's fixed tendons; empty for a URDF.
        site_shapes, anchors, virtual_links, ctrl_names, qpos0: an MJCF model's site volumes {name:
            (type, size (3,))}, each body's link frame origin in its body frame {body: (3,) m}, the
            virtual links between joints of one body, the actuators' names in MuJoCo's ctrl order
            (None: left off), and MuJoCo's qpos0 (nq,) (the model's pose, world); empty (None) for a URDF.
        fluid: the ``forces.Fluid`` an MJCF model's ``<option density viscosity wind>`` added to the
            world for its bodies (None: none).
    """

    name: str
    model: UrdfModel
    world: object
    links: dict
    joints: dict
    base: object
    link_frames: dict
    owners: dict
    actuators: dict = field(default_factory=dict)
    equalities: dict = field(default_factory=dict)
    sites: dict = field(default_factory=dict)
    cameras: dict = field(default_factory=dict)
    keyframes: dict = field(default_factory=dict)
    sensors: dict = field(default_factory=dict)
    sensors_left_off: list = field(default_factory=list)
    tendons: dict = field(default_factory=dict)
    site_shapes: dict = field(default_factory=dict)
    anchors: dict = field(default_factory=dict)
    virtual_links: list = field(default_factory=list)
    ctrl_names: list = field(default_factory=list)
    qpos0: np.ndarray | None = None
    fluid: object = None

    @property
    def kinematics(self):
        """The robot's ``kinematics.Kinematics``: joint coordinates (MuJoCo's qpos, qvel), Jacobians,
        the mass matrix, inverse dynamics and inverse kinematics (made on first use)."""
        k = self.__dict__.get("_kinematics")
        if k is None:
            from .kinematics import Kinematics

            k = self.__dict__["_kinematics"] = Kinematics(self)
        return k

    def sensor_data(self, sim=None) -> dict:
        """{sensor name: values (k,)} of an MJCF model's sensors now (MuJoCo's ``data.sensor(name).data``;
        ``mjcf_sensors``); ``sim``: the Simulator stepping the world (the clock, whole turns of
        hinge readings, the contacts a touch sensor sums)."""
        from .mjcf_sensors import sensor_values

        return sensor_values(self, sim)

    def reset_to_keyframe(self, key: str, sim=None):
        """Put an MJCF model in its ``<keyframe>`` key (MuJoCo's ``mj_resetDataKeyframe``): the key's
        qpos (default the model's pose), qvel (default at rest) and ctrl (default: the controls
        unchanged), a free joint's pose and velocity from the model's frame into the world's.
        Takes effect now (``Kinematics.set_state``)."""
        from .mjcf_control import apply_keyframe

        apply_keyframe(self, key, sim)

    def link_velocity(self, link, point=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
        """The velocity (3,) m/s of a point fixed in ``link`` (``point`` (3,) m in the link frame) and
        the link's angular velocity (3,) rad/s, world, now (PyBullet's ``getLinkState`` with
        ``computeLinkVelocity``; the Jacobian times the joint rates, ``robot.kinematics``)."""
        if link not in self.links:
            raise InputError(f"unknown link {link!r} of robot {self.name!r}", "link")
        body = self.links[link]
        o, R = self.link_pose(link)
        return body.point_velocity(o + R @ finite_vector(point, "point")), np.array(body.omega, dtype=float)

    def site_pose(self, site) -> tuple[np.ndarray, np.ndarray]:
        """A site's frame now: origin (3,) m and rotation (3, 3), world (MuJoCo's ``site_xpos``,
        ``site_xmat``)."""
        if site not in self.sites:
            raise InputError(f"unknown site {site!r} of robot {self.name!r}", "site")
        link, p, R = self.sites[site]
        o, Rl = self.link_pose(link)
        return o + Rl @ p, Rl @ R

    def link_pose(self, link) -> tuple[np.ndarray, np.ndarray]:
        """The link frame now: origin (3,) m and rotation (3, 3), world."""
        body = self.links[link]
        p, R = self.link_frames[link]
        Rb = np.asarray(body.R, dtype=float)
        origin = np.asarray(body.x, dtype=float) - Rb @ np.asarray(body.com_offset, dtype=float)
        return origin + Rb @ p, Rb @ R

    def _readings(self, sim):
        """``sim.joint_readings()`` and {URDF joint name: its row in them}. Before the first step (or
        without a ``sim``), the readings of the present state (``solver.joints.present_readings``):
        the Simulator's own are zeros until a step has stored them."""
        if self._solver(sim) is None:
            from .solver.joints import present_readings

            # the robot's own joints alone (a world of many copies: each copy's read is its own)
            records = list(self.joints.values())
            return present_readings(self.world, records), {name: k for k, name in enumerate(self.joints)}
        index = {id(j): k for k, j in enumerate(self.world.joints)}
        return sim.joint_readings(), {name: index[id(j)] for name, j in self.joints.items()}

    def _solver(self, sim):
        """The simulator's JointSolver once it holds every joint of the world, else None (before the
        first step: the records are read when it is built)."""
        solver = None if sim is None or sim.soft_step is None else sim.soft_step.joints
        return solver if solver is not None and solver.count == len(self.world.joints) else None

    def joint_states(self, sim) -> dict:
        """{joint name: (position, rate)} after the last step (rad or m, rad/s or m/s): PyBullet's
        ``getJointStates``. Before the first step, those of the present state, read from the bodies'
        poses and velocities as a step reads them (a hinge's angle in (-pi, pi])."""
        r, row = self._readings(sim)
        return {name: (float(r["position"][k]), float(r["rate"][k])) for name, k in row.items()}

    def joint_reactions(self, sim) -> dict:
        """{joint name: (force (3,) N, torque (3,) N m)}: what the joint did on its child link's body
        over the last step (world; the torque without the force's moment about the child's centre
        of mass; motors, drives and limits included): PyBullet's ``jointReactionForces``."""
        r, row = self._readings(sim)
        return {name: (np.array(r["force"][k]), np.array(r["torque"][k])) for name, k in row.items()}

    def reset_joint_positions(self, sim, positions: dict):
        """Put the robot at joint ``positions`` ({joint: rad or m}; the hinges and sliders not named
        keep their positions: ``joint_states``, the last step's readings or, before the first step or
        with ``sim`` None, the present pose's; an MJCF model's ball and free joints keep their
        present rotation and offset) with its base where it is, every body of the robot at
        rest: PyBullet's ``resetJointState``, for all the joints at once. Takes effect now; the joint
        solver's warm-start impulses of the robot's joints are cleared (they belonged to the old pose)."""
        given = _joint_values(self.model, positions, "positions", f"robot {self.name!r}")
        current = {name: state[0] for name, state in self.joint_states(sim).items()}
        current.update(given)
        # a ball or free joint (MJCF) keeps its present motion too: its child's frame in the
        # joint's zero frame, read from the poses. NOTE: why: _link_frames put every joint not in
        # ``current`` at its zero, and only hinges and sliders have a coordinate there: a robot's
        # ball joints went back to the model's pose at every reset (noted in session 41).
        for j in self.model.joints:
            if j.kind in ("spherical", "floating") and j.parent in self.links and j.child in self.links:
                zero = _compose(self.link_pose(j.parent), j.origin)
                current[j.name] = _relative(zero, self.link_pose(j.child))
        base = self.link_pose(self.model.root)
        _place(self.world, self, _link_frames(self.model, base, current), self.owners)
        world = self.world
        for body in set(self.links.values()):
            if world.moving[body.index]:
                world.P[body.index] = 0.0
                world.L[body.index] = 0.0
            world.wake_requests.add(body.index)
        world.update_derived()
        self._restart_warm_starts(sim, current)

    def _restart_warm_starts(self, sim, positions: dict, rates: dict | None = None):
        """After the robot was put in a new state: clear the joint solver's warm-start impulses of its
        joints and the contact solver's of the contacts its bodies had (they belonged to the old
        state: a contact kept from the last step would start the next one with its old impulse, so
        an episode's bits would depend on the episode before), and set the readings of the joints in
        ``positions`` ({joint: rad or m}: a hinge's angle is unwrapped around it) and their rates
        (``rates`` {joint: rad/s or m/s}, default 0: placed at rest; the last step's rate was
        read after a reset, a robotics audit, session 42). Nothing before the first step."""
        soft = None if sim is None else sim.soft_step
        if soft is not None and soft.solver.old_count:
            # its moving bodies: its fixed ones (the floor of an MJCF file) may be shared (tumble.envs'
            # copies over one floor), their contacts with other robots not its to drop
            bodies = np.zeros(self.world.body_count, dtype=bool)
            bodies[[link.index for link in self.links.values()]] = True
            bodies &= self.world.inv_mass > 0.0
            soft.solver.forget(bodies, soft.pipeline.refresh().shape_body)
        solver = self._solver(sim)
        if solver is not None:
            for name, record in self.joints.items():
                j = solver.index(record)
                solver.linear_impulse[j] = 0.0
                solver.angular_impulse[j] = 0.0
                solver.axial_impulse[j] = 0.0
                solver.armature_rate[j] = np.nan  # the new state's rates are those derived from its momenta
                if name in positions:
                    solver.position[j] = positions[name]
                    solver.rate[j] = 0.0 if rates is None else rates.get(name, 0.0)

    def _urdf_joint(self, joint) -> UrdfJoint:
        for j in self.model.joints:
            if j.name == joint:
                return j
        raise InputError(f"unknown joint {joint!r} of robot {self.name!r}", "joint")

    def _write(self, sim, joint, values: dict, fields: dict | None = None):
        """Write parameter ``values`` {column: value} into the joint's rows (the record's and the
        solver's) and ``fields`` {name: value} into its record as they are, unchecked and not
        marked edited: the record says what acts (a later ``joint.motor_speed = None`` compares
        with it; a checkpoint keeps it). NOTE: why: the record's fields stayed as loaded, so
        ``motor_speed = None`` after ``set_motor`` changed nothing and the motor ran on."""
        record = self.joints.get(joint)
        if record is None or not isinstance(record, (HingeJoint, SliderJoint)):
            raise InputError(f"not a moving joint of robot {self.name!r}: {joint!r}", "joint")
        rows = [record.bound.param]
        solver = self._solver(sim)
        if solver is not None:
            rows.append(solver.param[solver.index(record)])
        for row in rows:
            for column, value in values.items():
                row[column] = value
        for name, value in (fields or {}).items():
            object.__setattr__(record, name, value)
        # its bodies woken at the next step (a sleeping robot follows a new control; Box2D's joint
        # setters wake too); the rows are written in both places already, so no record edit to take
        # (tumble.joints.mark_edited would have every step scan the joints for it)
        if sim is not None:  # (None: written before there is a Simulator, into the record alone)
            b = record.bound
            sim.world.wake_requests.update(int(i) for i in (b.body_a, b.body_b) if i >= 0)

    def set_motor(self, sim, joint: str, speed: float, max_force: float | None = None):
        """Velocity control (PyBullet's ``VELOCITY_CONTROL``): drive ``joint`` at ``speed`` rad/s or
        m/s with at most ``max_force`` N m or N (default: the URDF's effort, else unlimited).
        Takes the place of the joint's friction and of a position target (``set_position_target``:
        one control mode a joint, as PyBullet's; the joint's own damping and spring act again);
        ``speed=None`` switches the motor off (the joint's friction, if its file gives one, acts
        again)."""
        uj = self._urdf_joint(joint)
        limit = _force_limit(uj, max_force)
        if speed is None:
            self._write(sim, joint, *self._friction_motor(joint, uj))
        else:
            columns, fields = self._passive_drive(joint, uj)
            max_key = self._field(joint, "max_motor")
            speed = _finite_float(speed, "speed")
            self._write(sim, joint, {**columns, P_MOTOR_ON: 1.0, P_MOTOR_SPEED: speed, P_MAX_MOTOR: limit},
                        {**fields, "motor_speed": speed, max_key: limit})

    def _field(self, joint: str, stem: str) -> str:
        """The record's field of ``stem`` (``max_motor``, ``max_drive``): _torque or _force."""
        return f"{stem}_force" if isinstance(self.joints[joint], SliderJoint) else f"{stem}_torque"

    def _friction_motor(self, joint: str, uj: UrdfJoint) -> tuple[dict, dict]:
        """(columns, fields) of the joint's friction as its file ``uj`` gives it (a motor of speed
        0 limited to it), or of no motor."""
        friction = uj.friction
        if friction == 0.0:
            return {P_MOTOR_ON: 0.0}, {"motor_speed": None}
        return ({P_MOTOR_ON: 1.0, P_MOTOR_SPEED: 0.0, P_MAX_MOTOR: friction},
                {"motor_speed": 0.0, self._field(joint, "max_motor"): friction})

    def _passive_drive(self, joint: str, uj: UrdfJoint) -> tuple[dict, dict]:
        """(columns, fields) of the joint's own damping and spring (its file's, ``uj``), uncapped: the
        drive's, or no drive where they act as the joint's passive spring-damper already (an MJCF
        joint its file's actuators drive: ``joint_passive``)."""
        k, c, target = (0.0, 0.0, 0.0) if joint in getattr(self, "joint_passive", {}) else \
            (uj.stiffness, uj.damping, uj.target)
        return ({P_STIFFNESS: k, P_DAMPING: c, P_TARGET: target, P_TARGET_RATE: 0.0, P_MAX_DRIVE: math.inf},
                {"stiffness": k, "damping": c, "target": target, "target_velocity": 0.0,
                 self._field(joint, "max_drive"): math.inf})

    def set_joint_torque(self, sim, joint: str, torque: float):
        """Torque control (PyBullet's ``TORQUE_CONTROL``): apply ``torque`` N m (a revolute joint) or
        force N (a prismatic one) along ``joint`` from the next step on, on its child link and the
        opposite on its parent, until changed. Not clipped (as PyBullet; the URDF's effort is the
        motors' and drives' limit); any motor, drive or friction of the joint acts as well."""
        self._urdf_joint(joint)
        torque = _finite(torque, "torque")
        self._write(sim, joint, {P_EFFORT: torque},
                    {"force" if isinstance(self.joints[joint], SliderJoint) else "torque": torque})

    def set_controls(self, sim, controls: dict):
        """MuJoCo's ``data.ctrl`` by actuator name ({name: value}; MJCF models), from the next step on:
        a motor applies gear x ctrl (ctrl clipped to its ``ctrlrange``, the force to its
        ``forcerange``), a position actuator pulls its joint to ctrl, a velocity actuator drives its
        rate to ctrl, a general one applies gain ctrl + its affine bias (``mjcf.MjcfActuator``).
        Checked whole before any is set."""
        from .mjcf import apply_controls

        if not isinstance(controls, dict):
            raise InputError(f"expected a table {{actuator: value}}, got {controls!r}", "controls")
        apply_controls(self, sim, controls)

    def set_position_target(self, sim, joint: str, target: float, stiffness: float, damping: float,
                            max_force: float | None = None, target_velocity: float = 0.0):
        """Position control (PyBullet's ``POSITION_CONTROL``, a PD drive): pull ``joint`` to ``target``
        rad or m with ``stiffness`` N m/rad (N/m) and ``damping`` N m s/rad (N s/m) towards
        ``target_velocity`` rad/s (m/s; PyBullet's ``targetVelocity``, default 0), at most
        ``max_force`` (default the URDF's effort). Takes the place of the joint's damping (a URDF's, and an
        MJCF joint's without actuators; an MJCF joint that its file's actuators drive keeps its own
        damping and spring beside the drive, as its passive spring-damper, as in MuJoCo)."""
        uj = self._urdf_joint(joint)
        limit = _force_limit(uj, max_force)
        if stiffness < 0 or damping < 0 or not (math.isfinite(stiffness) and math.isfinite(damping)):
            raise InputError("stiffness and damping must be finite and >= 0", "stiffness")
        # one control mode a joint (PyBullet's POSITION_CONTROL replaces VELOCITY_CONTROL): a motor
        # of set_motor gives way to the joint's friction. NOTE: why: a running motor kept winning
        # over the target (a robotics audit, session 42)
        motor, motor_fields = self._friction_motor(joint, uj)
        target = _finite_float(target, "target")
        rate = _finite_float(target_velocity, "target_velocity")
        self._write(sim, joint, {**motor, P_STIFFNESS: float(stiffness), P_DAMPING: float(damping), P_TARGET: target,
                                 P_TARGET_RATE: rate, P_MAX_DRIVE: limit},
                    {**motor_fields, "stiffness": float(stiffness), "damping": float(damping), "target": target,
                     "target_velocity": rate, self._field(joint, "max_drive"): limit})


# The frames' products are written without BLAS (math3d.mat_vec's note): a robot is placed with
# the same bits on every machine.
def _compose(a, b):
    """Frame b given in frame a, both (position, rotation): b in a's parent."""
    Ra = np.asarray(a[1], dtype=float)
    return a[0] + mat_vec(Ra, np.asarray(b[0], dtype=float)), mat_mat(Ra, np.asarray(b[1], dtype=float))


def _relative(a, b):
    """Frame b seen from frame a (both in one parent)."""
    Ra = np.asarray(a[1], dtype=float)
    return mat_t_vec(Ra, np.asarray(b[0] - a[0], dtype=float)), mat_t_mat(Ra, np.asarray(b[1], dtype=float))


def _joint_motion(joint: UrdfJoint, q: float):
    """The child's frame moved by joint coordinate ``q`` (rad or m), in the joint's zero frame."""
    if joint.kind in ("revolute", "continuous"):
        half = 0.5 * q
        quat = np.concatenate([[math.cos(half)], math.sin(half) * joint.axis])
        return np.zeros(3), quat_to_matrix(quat)
    if joint.kind == "prismatic":
        return q * joint.axis, np.eye(3)
    return np.zeros(3), np.eye(3)


def _link_frames(model: UrdfModel, base, joint_positions: dict) -> dict:
    """{link: (position, rotation)} world, with ``base`` the root's frame and the joints at
    ``joint_positions`` (0 where not given): {joint: rad or m}, or for a ball or free joint its
    child's frame in the joint's zero frame, (position (3,) m, rotation (3, 3))."""
    frames = {model.root: base}
    by_parent: dict[str, list] = {}
    for j in model.joints:
        by_parent.setdefault(j.parent, []).append(j)
    todo = [model.root]
    while todo:
        parent = todo.pop()
        for j in by_parent.get(parent, []):
            zero = _compose(frames[parent], j.origin)
            q = joint_positions.get(j.name, 0.0)
            frames[j.child] = _compose(zero, q if isinstance(q, tuple) else _joint_motion(j, q))
            todo.append(j.child)
    return frames


def load_urdf(world, path, *, position=(0.0, 0.0, 0.0), orientation=None, euler_deg=None, fixed_base=False,
              merge_fixed=True, self_collision=False, joint_positions=None, material=None, collision_filter=None,
              name=None, package_dirs=(), inertia="file", joint_motors=None, joint_targets=None) -> Robot:
    """Add the robot of a URDF file to ``world`` (module docstring) and return it.

    Args:
        world: the ``World``.
        path: the URDF file.
        position: (3,) m, world: where the root link's frame goes.
        orientation: (4,) unit quaternion (w, x, y, z), or ``euler_deg`` (roll, pitch, yaw,
            degrees, as ``add_body``): the root link frame's orientation.
        fixed_base: the root link's body is fixed (PyBullet's ``useFixedBase``).
        merge_fixed: fuse links joined by fixed joints into one body (default) or join them by
            ``FixedJoint``.
        self_collision: let the robot's bodies touch each other (not those a joint links).
        joint_positions: {joint name: rad or m}: start there (the joints' zero stays the URDF's).
        joint_motors: {joint name: {"speed": rad/s or m/s, "max_force": N m or N}}: velocity
            motors on from the start (``max_force`` default: the URDF's effort, else unlimited);
            as ``Robot.set_motor``.
        joint_targets: {joint name: {"position", "stiffness", "damping", "max_force"}}: PD drives
            from the start, as ``Robot.set_position_target``.
        material: ``Material`` (or mapping) of every link without its own ``<contact>``.
        collision_filter: ``CollisionFilter`` of every body (default: the default filter).
        name: the robot's name (default the URDF's ``<robot name>``): prefix of the body names.
        package_dirs: folders in which ``package://`` mesh paths are looked up.
        inertia: where each link's centre of mass and inertia come from: ``"file"`` (its
            ``<inertial>``, which must be physical: positive moments with A + B >= C), ``"balance"``
            (the file's, its principal moments raised where they break that: MuJoCo's
            ``balanceinertia``) or ``"shapes"`` (the collision shapes', uniform density at the
            file's mass: PyBullet's default without ``URDF_USE_INERTIA_FROM_FILE``). Many
            published URDFs need one of the last two.

    Raises:
        InputError: a bad file or argument, one line (file, element, problem).
    """
    model = read_urdf(path, package_dirs)
    return build_robot(world, model, position=position, orientation=orientation, euler_deg=euler_deg,
                       fixed_base=fixed_base, merge_fixed=merge_fixed, self_collision=self_collision,
                       joint_positions=joint_positions, material=material, collision_filter=collision_filter,
                       name=name, inertia=inertia, joint_motors=joint_motors, joint_targets=joint_targets)


def build_robot(world, model: UrdfModel, *, position=(0.0, 0.0, 0.0), orientation=None, euler_deg=None,
                fixed_base=False, merge_fixed=True, self_collision=False, joint_positions=None, material=None,
                collision_filter=None, name=None, inertia="file", joint_motors=None, joint_targets=None) -> Robot:
    """Add the robot of a parsed model (a URDF's, or an MJCF file's: ``tumble.mjcf``) to ``world``;
    the options as ``load_urdf``'s."""
    if inertia not in INERTIA_SOURCES:
        raise InputError(f"must be one of {', '.join(INERTIA_SOURCES)}, got {inertia!r}", "inertia")
    for link in model.links.values():
        if link.mass > 0.0 and inertia == "balance":
            link.inertia = balanced_inertia(link.inertia)
        elif link.mass > 0.0 and inertia == "shapes" and link.parts:
            link.center, link.inertia = _shape_inertia(link, model.source)
    prefix = model.name if name is None else name
    if not isinstance(prefix, str) or not prefix:
        raise InputError(f"must be a non-empty string, got {prefix!r}", "name")
    if orientation is not None and euler_deg is not None:
        raise InputError("give orientation or euler_deg, not both", "orientation")
    from .world import unit_quaternion

    q0 = quat_from_euler_deg(finite_vector(euler_deg, "euler_deg")) if euler_deg is not None else \
        unit_quaternion((1.0, 0.0, 0.0, 0.0) if orientation is None else orientation)
    base = (finite_vector(position, "position"), quat_to_matrix(q0))
    joint_positions = _joint_values(model, joint_positions or {}, "joint_positions", model.source)
    known = {j.name: j for j in model.joints}
    controls = _controls(known, joint_motors, joint_targets)
    material = Material.coerce(material)
    collision_filter = CollisionFilter.coerce(collision_filter)

    # which body each link belongs to: its own, or (fixed joint, merged) its parent's
    owner = {model.root: model.root}
    for j in _tree_order(model):
        owner[j.child] = owner[j.parent] if (j.kind == "fixed" and merge_fixed) else j.child
    zero = _link_frames(model, base, {})
    link_frames = {link: _relative(zero[owner[link]], zero[link]) for link in model.links}

    bodies = {}
    for body_link in dict.fromkeys(owner[link] for link in model.links):
        members = [link for link in model.links if owner[link] == body_link]
        is_root = body_link == model.root
        fixed = is_root and (fixed_base or model.links[model.root].mass == 0.0)
        bodies[body_link] = _add_link_body(world, model, members, link_frames, zero[body_link], fixed,
                                           f"{prefix}/{body_link}", material, collision_filter)
    links = {link: bodies[owner[link]] for link in model.links}

    joints = {}
    for j in model.joints:
        if j.kind == "floating" or (j.kind == "fixed" and merge_fixed):
            continue
        anchor, R_child = zero[j.child]
        common = dict(body_a=links[j.parent], body_b=links[j.child], anchor=anchor, name=f"{prefix}/{j.name}")
        axis = mat_vec(np.asarray(R_child, dtype=float), np.asarray(j.axis, dtype=float))
        if j.kind == "fixed":
            record = FixedJoint(**common)
        elif j.kind == "spherical":  # Bullet's extension (its limit attributes are not read); MJCF's ball
            # MJCF's stiffness pulls to the model's pose (MuJoCo's qpos_spring of a ball is its qpos0:
            # springref is a hinge's and a slide's), the pose the joint is bound at
            record = BallJoint(**common, cone_limit=j.cone_limit, stiffness=j.stiffness, damping=j.damping)
        else:
            cls = SliderJoint if j.kind == "prismatic" else HingeJoint
            extra = {} if j.friction == 0.0 else {"motor_speed": 0.0,
                                                  ("max_motor_force" if cls is SliderJoint else "max_motor_torque"): j.friction}
            record = cls(**common, axis=axis, lower=j.lower, upper=j.upper, damping=j.damping, stiffness=j.stiffness,
                         target=j.target, armature=j.armature, **extra)
            torque_or_force = "force" if cls is SliderJoint else "torque"
            for field_name, value in controls.get(j.name, {}).items():
                if field_name in ("max_motor", "max_drive"):  # max_motor_torque, max_drive_force, ...
                    field_name = f"{field_name}_{torque_or_force}"
                setattr(record, field_name, value)
        try:
            world.add_joint(record)
        except InputError as err:
            raise InputError(err.problem, f"joint[{j.name}].{err.key}" if err.key else f"joint[{j.name}]",
                             model.source) from None
        joints[j.name] = record

    gears = _add_mimics(world, model, joints, prefix)
    if not self_collision:
        own = list(bodies.values())
        for a in range(len(own)):
            for b in range(a + 1, len(own)):
                world.exclude_collision(own[a], own[b])
    robot = Robot(prefix, model, world, links, joints, bodies[model.root], link_frames, owner)
    robot.equalities.update(gears)
    for j in model.joints:  # a mimic joint not placed by the caller starts on its relation
        if j.mimic is not None and j.name not in joint_positions and (j.mimic[0] in joint_positions or j.mimic[2]):
            joint_positions[j.name] = j.mimic[2] + j.mimic[1] * joint_positions.get(j.mimic[0], 0.0)
    if joint_positions:
        _place(world, robot, _link_frames(model, base, joint_positions), owner)
    return robot


MOVING_KINDS = ("revolute", "continuous", "prismatic")


def _add_mimics(world, model: UrdfModel, joints: dict, prefix: str) -> dict:
    """``<mimic joint multiplier offset>``: a ``GearJoint`` making the joint follow the named one,
    q = offset + multiplier q_joint (URDF's mimic, as Drake and Gazebo read it; PyBullet does not),
    named "ROBOT/JOINT/mimic". Returns {joint name: gear record}."""
    from .joints import GearJoint

    known = {j.name: j for j in model.joints}
    gears = {}
    for j in model.joints:
        if j.mimic is None:
            continue
        key = f"joint[{j.name}].mimic"
        leader, multiplier, offset = j.mimic
        if j.kind not in MOVING_KINDS:
            raise InputError(f"only a revolute, continuous or prismatic joint can mimic, not a {j.kind} one", key,
                             model.source)
        if leader not in known:
            raise InputError(f"unknown joint {leader!r}", f"{key}.joint", model.source)
        if known[leader].kind not in MOVING_KINDS:
            raise InputError(f"the joint followed must be revolute, continuous or prismatic, not {known[leader].kind}",
                             f"{key}.joint", model.source)
        record = GearJoint(joint=joints[j.name], follows=joints[leader], ratio=multiplier, offset=offset,
                           name=f"{prefix}/{j.name}/mimic")
        try:
            world.add_joint(record)
        except InputError as err:
            raise InputError(err.problem, f"{key}.{err.key}" if err.key else key, model.source) from None
        gears[j.name] = record
    return gears


def _moving_joint(known: dict, name, key: str, whose: str) -> UrdfJoint:
    """The URDF joint ``name`` of ``known`` if it moves (revolute, continuous, prismatic), else an
    InputError keyed ``key``."""
    if name not in known or known[name].kind not in MOVING_KINDS:
        raise InputError(f"not a revolute, continuous or prismatic joint of {whose}", key)
    return known[name]


def _finite_float(value, key: str) -> float:
    """``float(value)`` (NumPy scalars too), finite, else one InputError under ``key``."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(f"expected a finite number, got {value!r}", key) from None
    if isinstance(value, bool) or not math.isfinite(number):
        raise InputError(f"expected a finite number, got {value!r}", key)
    return number


def _finite(value, key: str, nonnegative: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or (nonnegative and value < 0):
        raise InputError(f"expected a finite number{' >= 0' if nonnegative else ''}, got {value!r}", key)
    return float(value)


def _joint_values(model: UrdfModel, values: dict, option: str, whose: str) -> dict:
    """{joint: rad or m} checked: moving joints of ``model``, finite numbers (keys ``option.joint``)."""
    known = {j.name: j for j in model.joints}
    for name, value in values.items():
        _moving_joint(known, name, f"{option}.{name}", whose)
    return {name: _finite(value, f"{option}.{name}") for name, value in values.items()}


def _force_limit(joint: UrdfJoint, max_force=None) -> float:
    """A motor's or drive's limit, N m or N: ``max_force``, else the URDF's effort, else unlimited."""
    if max_force is not None:
        return float(max_force)
    return math.inf if joint.effort is None else joint.effort


MOTOR_KEYS = ("speed", "max_force")
TARGET_KEYS = ("position", "stiffness", "damping", "max_force")


def _controls(known: dict, motors, targets) -> dict:
    """{joint: {record field: value}} of ``joint_motors`` and ``joint_targets`` (checked)."""
    out: dict[str, dict] = {}
    for option, given, keys, required in (("joint_motors", motors, MOTOR_KEYS, ("speed",)),
                                          ("joint_targets", targets, TARGET_KEYS, ("position", "stiffness"))):
        for jname, spec in (given or {}).items():
            key = f"{option}.{jname}"
            _moving_joint(known, jname, key, "the robot")
            if not isinstance(spec, dict) or set(spec) - set(keys) or set(required) - set(spec):
                raise InputError(f"expected a table with {', '.join(required)} (and optionally "
                                 f"{', '.join(k for k in keys if k not in required)}), got {spec!r}", key)
            values = {k: _finite(v, f"{key}.{k}", nonnegative=k in ("stiffness", "damping", "max_force"))
                      for k, v in spec.items()}
            limit = _force_limit(known[jname], values.get("max_force"))
            entry = out.setdefault(jname, {})
            if option == "joint_motors":
                entry.update(motor_speed=values["speed"], max_motor=limit)
            else:
                entry.update(target=values["position"], stiffness=values["stiffness"],
                             damping=values.get("damping", 0.0), max_drive=limit)
    return out


def balanced_inertia(I: np.ndarray) -> np.ndarray:
    """``I`` (3, 3) with its principal moments made physical (``inertia="balance"``): a moment below
    1e-6 of the largest is raised to that, then if the two smaller sum to less than the largest
    (A + B < C: no mass distribution has it) each is raised by half the shortfall; the principal
    axes are kept."""
    with np.errstate(all="ignore"):  # a huge or non-finite tensor is left as it is: the checks name it
        S = 0.5 * (I + I.T)
        if not np.all(np.isfinite(S)):
            return I
        moments, axes = np.linalg.eigh(S)
        largest = max(float(moments[2]), 1e-12)
        moments = np.maximum(moments, 1e-6 * largest)
        shortfall = moments[2] - moments[0] - moments[1]
        if shortfall > 0:
            moments[:2] += 0.5 * shortfall
        return axes @ np.diag(moments) @ axes.T


def _shape_inertia(link: UrdfLink, source: str):
    """Centre of mass and inertia (link frame) of the link's collision shapes at its mass."""
    from .mass import mass_properties

    if any(isinstance(shape, Plane) for shape, *_ in link.parts):
        return link.center, link.inertia
    parts = [(shape, p, matrix_to_quat(np.ascontiguousarray(R))) for shape, p, R in link.parts]
    try:
        props = mass_properties(Compound(parts), mass=link.mass)
    except InputError as err:
        raise InputError(err.problem, f"link[{link.name}].collision", source) from None
    return np.array(props.center), np.array(props.inertia)


def _tree_order(model: UrdfModel) -> list:
    """The joints, each after the joint of its parent link (parents before children)."""
    by_parent: dict[str, list] = {}
    for j in model.joints:
        by_parent.setdefault(j.parent, []).append(j)
    order, todo = [], [model.root]
    while todo:
        for j in by_parent.get(todo.pop(0), []):
            order.append(j)
            todo.append(j.child)
    return order


def _add_link_body(world, model, members, link_frames, frame, fixed, body_name, material, collision_filter):
    """One body for the links ``members`` (the first its own link): shape parts and mass
    properties combined in the first link's frame."""
    parts, inertia_terms = [], []
    for link_name in members:
        link = model.links[link_name]
        p, R = link_frames[link_name]
        R = np.asarray(R, dtype=float)
        for shape, position, rotation in link.parts:
            parts.append((shape, p + mat_vec(R, np.asarray(position, dtype=float)),
                          matrix_to_quat(mat_mat(R, np.asarray(rotation, dtype=float))), link.material))
        if link.mass > 0.0:
            c = p + mat_vec(R, np.asarray(link.center, dtype=float))
            inertia_terms.append((link.mass, c, rotate_tensor(R, np.asarray(link.inertia, dtype=float))))
    key = f"link[{members[0]}]"
    filt = collision_filter
    materials = [m for (*_, m) in parts]
    if materials and all(m == materials[0] for m in materials):  # one material (or none) for all: the body's
        material = material if materials[0] is None else materials[0]
        parts = [(shape, p, q, None) for shape, p, q, _ in parts]
    elif any(m is not None and m.margin for m in materials):
        # a margin is the body's (Material.margin), not a part's: the first part's that has a material
        margin = next(m.margin for m in materials if m is not None)
        material = replace(material if material is not None else Material(), margin=margin)
        parts = [(shape, p, q, None if m is None else replace(m, margin=0.0)) for shape, p, q, m in parts]
    if not parts:
        shape, filt = Sphere(radius=MARKER_RADIUS), NO_CONTACT
    elif any(isinstance(part[0], Plane) for part in parts):
        if len(parts) != 1 or not fixed:
            raise InputError("a plane must be the only collision shape of a fixed link", key, model.source)
        plane, p, q, _ = parts[0]
        n = mat_vec(quat_to_matrix(q), np.asarray(plane.normal, dtype=float))
        shape = Plane(normal=n, offset=float(n[0] * p[0] + n[1] * p[1] + n[2] * p[2]) + plane.offset)
    elif len(parts) == 1 and np.allclose(parts[0][1], 0.0) and abs(parts[0][2][0]) == 1.0 and parts[0][3] is None:
        shape = parts[0][0]
    else:
        shape = Compound(parts)
    kwargs = {}
    if not fixed:
        mass, center, inertia = combine_mass_properties(inertia_terms)
        if mass <= 0.0:
            raise InputError("a link that moves needs an <inertial> with a mass > 0", key, model.source)
        kwargs = dict(mass=mass, center_of_mass=center, inertia=inertia)
    try:
        return world.add_body(shape, position=frame[0], orientation=matrix_to_quat(np.ascontiguousarray(frame[1])),
                              fixed=fixed, material=material, collision_filter=filt, name=body_name, **kwargs)
    except InputError as err:
        problem = err.problem
        if err.key == "inertia":
            problem += ('; load it with inertia="balance" (raise the small moments, MuJoCo\'s balanceinertia)'
                        ' or inertia="shapes" (from the collision shapes, PyBullet\'s default)')
        raise InputError(problem, f"{key}.{err.key}" if err.key else key, model.source) from None


def _place(world, robot: Robot, frames: dict, owner: dict):
    """Move every body to its links' frames at the start joint positions (bodies at rest). Bodies
    outside the link tree (an MJCF model's worldbody geoms: fixed bodies of their own) stay."""
    for link, body in robot.links.items():
        if owner.get(link) != link:
            continue
        p, R = frames[link]
        i = body.index
        q = matrix_to_quat(np.ascontiguousarray(R))
        world.q[i] = q
        world.R[i] = quat_to_matrix(q)
        world.x[i] = p + mat_vec(world.R[i], world.com_offset[i])
    world.update_derived()
