"""World: every body's quantities as structure-of-arrays, and ``Body`` views onto their rows.

Four groups of arrays (STYLE 5.6 rule 2), bodies along axis 0:

constants  ``mass`` (N,) kg, ``inv_mass`` (N,) 1/kg (0 for fixed bodies),
           ``inertia_body`` (N, 3, 3) kg m^2 and ``inertia_body_inv`` (N, 3, 3)
           (Ibody, Ibody^-1, body frame), ``principal_q`` (N, 4) principal axes
           to body axes, ``principal_moments`` (N, 3) ascending, ``moving`` (N,)
           bool (dynamic: moved by forces and contacts), ``kinematic`` (N,) bool,
           ``sensor`` (N,) bool (detects overlaps, touches nothing: collision/sensor.py),
           ``com_offset`` (N, 3) m: the shape origin's place in the
           body frame is ``-com_offset`` (the centre of mass seen from the
           shape origin is ``com_offset``).
kinematic  ``kinematic_v`` (N, 3) m/s and ``kinematic_omega`` (N, 3) rad/s, world: the
           velocities a kinematic body moves at (zero for the others). A kinematic body
           (Box2D's b2_kinematicBody, MuJoCo's mocap body) has infinite mass (``inv_mass``
           0, P = L = 0): forces, contacts and joints do not move it; it moves at the
           velocities the user sets, and the bodies it touches feel them.
           ``surface_velocity`` (N, 3) m/s, body frame: how fast each body's surface slides
           along itself in its contacts (a conveyor belt; zero for most bodies).
state      ``x`` (N, 3) m, ``q`` (N, 4) (w, x, y, z) or ``R`` (N, 3, 3), ``P``
           (N, 3) kg m/s, ``L`` (N, 3) kg m^2/s, all world frame; the layout
           ("quaternion", 13 numbers a body, or the course's "matrix", 18)
           says which of q and R is state; the other is kept in step.
derived    ``v`` (N, 3) m/s, ``omega`` (N, 3) rad/s, ``I_inv`` (N, 3, 3) world.
accumulated ``force`` (N, 3) N, ``torque`` (N, 3) N m, world, about the centre of mass,
           from the built-in forces at the current state (user ``CustomForce``
           functions are called inside steps only, never by reading the world).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import integrators as K
from .errors import InputError
from .collision.filter import ALL_CATEGORIES, NOTHING_FILTER, CollisionFilter
from .forces import (
    Buoyancy,
    Fluid,
    ConstantForce,
    CustomForce,
    Drag,
    Explosion,
    Impulse,
    Switch,
    PointForce,
    Spring,
    build_force_tables,
    force_edit_count,
)
from .mass import MassProperties, mass_properties
from .material import Material
from .math3d import inverse3, mat_vec, matrix_to_quat, norm3, quat_from_euler_deg, quat_to_matrix, rotate_tensor
from .shapes import Mesh, Particles, Plane, finite_vector


def unit_quaternion(value, key="orientation") -> np.ndarray:
    """(4,) unit quaternion from ``value`` (w, x, y, z); refuses the zero quaternion."""
    q = finite_vector(value, key, 4)
    n = float(norm3(q))  # no BLAS (math3d.mat_vec's note)
    if n < 1e-12:
        raise InputError("quaternion must not be zero (w, x, y, z = 0, 0, 0, 0)", key)
    return q / n


_CONSTANT_ARRAYS = {
    "mass": (), "inv_mass": (), "inertia_body": (3, 3), "inertia_body_inv": (3, 3),
    "principal_q": (4,), "principal_moments": (3,), "com_offset": (3,),
    # kg: the mass the body has as a dynamic body: ``mass`` when it is dynamic; the mass given at
    # add_body, or held from when it was dynamic, when it is fixed or kinematic (whose ``mass`` is
    # inf); NaN for none. ``set_body_type`` makes a body dynamic with it (its inertia is then
    # ``inertia_body``, kept finite for such a body).
    "dynamic_mass": (),
    # the fraction of m g the body feels (``World.set_gravity_scale``: Box2D's gravity scale,
    # 1 - MuJoCo's gravcomp); 1 by default
    "gravity_scale": (),
    # 1/s: the rates at which the body's velocity and angular momentum decay under nothing else
    # (``World.set_damping``: Box2D's and PhysX's linear and angular damping); 0 by default
    "damping": (2,),
}
#: a body's types (``World.set_body_type``): moved by forces and contacts; moved at set
#: velocities whatever pushes it (infinite mass); never moved
BODY_TYPES = ("dynamic", "kinematic", "fixed")
_STATE_ARRAYS = {"x": (3,), "q": (4,), "R": (3, 3), "P": (3,), "L": (3,)}
_DERIVED_ARRAYS = {"v": (3,), "omega": (3,), "I_inv": (3, 3), "force": (3,), "torque": (3,)}
_KINEMATIC_ARRAYS = {
    "kinematic_v": (3,), "kinematic_omega": (3,), "surface_velocity": (3,),
    # a disabled body's (``World.set_enabled``): the type it comes back as (0 dynamic, 1
    # kinematic, 2 fixed: BODY_TYPES' index) and the velocities it comes back with, m/s and
    # rad/s, world (its centre of mass); zero for an enabled body
    "held_type": (), "held_v": (3,), "held_omega": (3,),
}
#: ``disabled``: out of the simulation (World.set_enabled): moves with nothing, touches nothing
_FLAG_ARRAYS = ("moving", "kinematic", "sensor", "disabled")


class World:
    """All bodies of a scene, their forces and gravity.

    Args:
        gravity: (3,) m/s^2, world frame. Default (0, 0, -9.81), z up.
        layout: "quaternion" (13 numbers a body, the default) or "matrix" (the
            course's 18: x, R, P, L). Both are kept on SO(3) after every step.
    """

    def __init__(self, gravity=(0.0, 0.0, -9.81), layout: str = "quaternion"):
        self.gravity = finite_vector(gravity, "gravity")
        if layout not in K.LAYOUT_IDS:
            raise InputError(f"unknown layout {layout!r} (expected 'quaternion' or 'matrix')", "layout")
        self.layout = layout
        self.t = 0.0
        # bodies with collision shapes touch (contact, issue 3); False lets them pass through each other
        self.collisions = True
        # islands at rest fall asleep (stop moving, cost nothing) and wake when touched (solver/island.py)
        self.sleeping = True
        self._body_count = 0
        self.body_count = 0
        self._capacity = 0
        self._arrays: dict[str, np.ndarray] = {}
        self._allocate(8)
        self.names: list[str] = []
        self._index_by_name: dict[str, int] = {}
        self.shapes: list[Any] = []
        self.materials: list[Material] = []
        self.collision_filters: list[CollisionFilter] = []  # per body (collision/filter.py)
        self.excluded_collisions: set[tuple[int, int]] = set()  # (lo, hi) body rows that never touch
        self.pair_materials: dict[tuple[int, int], Material] = {}  # (lo, hi) body rows: their contacts' material
        self.pair_material_version = 0  # bumped when they change: the contact solver rereads them
        self.material_version = 0  # bumped by set_material: the contact solver and pipeline reread materials
        self._force_edits = 0  # forces.force_edit_count() when the force tables were built
        # True when a body hangs between two joints with next to no mass (an MJCF body with several
        # joints, tumble.mjcf) or a joint has armature (add_joint): the Simulator then solves joints
        # exactly by default (the tree method)
        self.exact_joints = False
        self.filter_version = 0  # bumped when either changes: the collision pipeline rereads them
        # body rows whose type was changed (set_body_type), in order: a Simulator takes those
        # after the ones it has seen and builds its contact and joint stages again
        self.type_changes: list[int] = []
        # indices into ``joints`` of the joints switched off because a body of theirs was
        # disabled (set_enabled): switched on again when both their bodies are enabled
        self.joints_switched_off: set[int] = set()
        self.forces: list[Any] = []
        self.switch_count = 0  # Switch records among ``forces``: none, and a step looks for none
        self.joints: list[Any] = []  # joint records of tumble.joints, bound (add_joint)
        self.paths: list[Any] = []  # keyframed paths of kinematic bodies (tumble.kinematic, add_path)
        # rows a user changed between steps (a pose, a velocity, an impulse): the Simulator wakes
        # them and their islands before its next step (Box2D's setters wake the body)
        self.wake_requests: set[int] = set()
        # indices into ``forces`` of the Impulse records already applied (once each); plain
        # integers, so that a checkpoint can save them
        self.applied_impulses: set[int] = set()
        self._tables = None
        self._tables_gravity = None  # the gravity the tables' gravity-scale rows were made with (None: no such row)

    # ------------------------------------------------------------------ storage
    def _allocate(self, capacity: int):
        new = {}
        for group in (_CONSTANT_ARRAYS, _STATE_ARRAYS, _DERIVED_ARRAYS, _KINEMATIC_ARRAYS):
            for name, shape in group.items():
                arr = np.zeros((capacity,) + shape)
                if name in self._arrays:
                    arr[: self.body_count] = self._arrays[name][: self.body_count]
                new[name] = arr
        for name in _FLAG_ARRAYS:
            flag = np.zeros(capacity, dtype=bool)
            if name in self._arrays:
                flag[: self.body_count] = self._arrays[name][: self.body_count]
            new[name] = flag
        self._arrays = new
        self._drop_views()  # views of the old storage
        self._capacity = capacity

    @property
    def body_count(self) -> int:
        """How many bodies the world holds (the rows of the array properties)."""
        return self._body_count

    @body_count.setter
    def body_count(self, n: int):
        self._body_count = n
        self._drop_views()  # views of the old row count

    def _drop_views(self):
        """Forget the kept views of the array properties (``_ArrayView``): made again at their next read."""
        d = self.__dict__
        for name in _ARRAY_NAMES.intersection(d):
            del d[name]

    def __setattr__(self, name, value):
        if name in _ARRAY_NAMES:  # the array properties are read-only (their rows are written in place)
            raise AttributeError(f"property {name!r} of 'World' object has no setter")
        object.__setattr__(self, name, value)

    def __getstate__(self):
        # the kept views are left out: a copy's views must be of the copy's storage, made anew
        return {k: v for k, v in self.__dict__.items() if k not in _ARRAY_NAMES}

    @property
    def fixed(self) -> np.ndarray:
        """(N,) bool: True for fixed (static) bodies: neither dynamic nor kinematic."""
        return ~(self.moving | self.kinematic)

    @property
    def kinematic_moving(self) -> np.ndarray:
        """(N,) bool: the kinematic bodies that move: a velocity not zero, or a path."""
        k = self.kinematic
        if not self.paths and not k.any():
            return k.copy()  # PERF: no kinematic body (most worlds): 5.8 -> 1 us, asked once or twice a step
        moving = k & (np.any(self.kinematic_v != 0.0, axis=1) | np.any(self.kinematic_omega != 0.0, axis=1))
        for path in self.paths:
            moving[self.index_of(path.body)] = True
        return moving

    # ------------------------------------------------------------------ building
    @property
    def gravity(self) -> np.ndarray:
        """(3,) m/s^2, world frame: the acceleration applied to every moving body (as m g)."""
        return self._gravity

    @gravity.setter
    def gravity(self, value):
        """Set between steps too (a maze tilted, a moon's 1.62 m/s^2): checked (InputError keyed
        ``gravity``), and a change wakes every moving body (a sleeping pile would not feel it)."""
        g = finite_vector(value, "gravity")
        old = self.__dict__.get("_gravity")
        self._gravity = g
        if old is not None and not np.array_equal(old, g) and self.body_count:
            self.wake_requests.update(int(i) for i in np.flatnonzero(self.moving))
            self._tables = None  # a gravity scale's row is (s - 1) m g

    def add_body(
        self,
        shape,
        *,
        mass: float | None = None,
        density: float | None = None,
        inertia=None,
        center_of_mass=None,
        position=(0.0, 0.0, 0.0),
        orientation=None,
        euler_deg=None,
        velocity=(0.0, 0.0, 0.0),
        angular_velocity=(0.0, 0.0, 0.0),
        angular_velocity_frame: str = "world",
        material=None,
        collision_filter=None,
        fixed: bool = False,
        kinematic: bool = False,
        surface_velocity=(0.0, 0.0, 0.0),
        sensor: bool = False,
        enabled: bool = True,
        gravity_scale: float = 1.0,
        linear_damping: float = 0.0,
        angular_damping: float = 0.0,
        name: str | None = None,
    ) -> "Body":
        """Add one body and return its view.

        Args:
            shape: a shape record of ``tumble.shapes`` (Plane only with fixed=True).
            mass: kg, or ``density`` kg/m^3 (exactly one; neither for particles
                or fixed bodies).
            position: (3,) m, world: where the shape's origin is. When the
                centre of mass is off the origin, the body frame moves to it
                (``com_offset`` keeps the difference for display and export).
            orientation: (4,) unit quaternion (w, x, y, z), body to world, or
                ``euler_deg`` (roll x, pitch y, yaw z in degrees, applied z-y'-x'').
            velocity: (3,) m/s of the centre of mass, world.
            angular_velocity: (3,) rad/s, world (or body axes with
                ``angular_velocity_frame="body"``).
            inertia: optional override of Ibody, kg m^2, body frame about the
                centre of mass: (3, 3) symmetric positive definite, or (3,) the
                diagonal. The shape still gives the mass and centre of mass.
            center_of_mass: (3,) m, shape frame, optional: the centre of mass, given with
                ``mass`` and ``inertia`` (about it, along the shape axes); then the shape's
                own mass properties are not computed at all (Box2D's ``b2MassData``, a URDF
                link's ``<inertial>``, MuJoCo's ``<inertial>``): the shape only collides.
            material: ``Material`` or a mapping with its keys.
            collision_filter: ``CollisionFilter`` (category, mask, group: which bodies this
                one touches, Box2D's rule; collision/filter.py) or a mapping with its keys;
                default: touches every body with the default filter.
            fixed: a static body: infinite mass, never moves.
            kinematic: a body of infinite mass that moves at ``velocity`` and
                ``angular_velocity`` (about its centre of mass; set them between steps
                with ``Body.v``, ``Body.omega`` or ``Body.set_target``) whatever pushes
                on it: a moving platform, a conveyor, a paddle. Mass or density are
                optional (they place the centre of mass), as for a fixed body.
            surface_velocity: (3,) m/s, body frame: the surface of the body slides along itself
                at this velocity in its contacts (each contact takes its part in its tangent
                plane), while the body stays where it is: a conveyor belt (Box2D's tangentSpeed).
                Friction drives what touches it to that speed.
            sensor: the body touches nothing and reports the dynamic and kinematic bodies that
                overlap it (``Simulator.sensor_events``, ``sensor_overlaps``; Box2D's sensor
                shapes): a trigger zone. It may be fixed, kinematic or dynamic.
            enabled: False adds the body out of the simulation (``set_enabled``): it waits,
                hidden in exports, touching nothing, until enabled (a body that appears later).
            gravity_scale: the fraction of its weight m g the body feels (``set_gravity_scale``):
                0 floats, 0.5 falls at g / 2, negative rises (a balloon); default 1.
            linear_damping, angular_damping: 1/s, the rates at which the body's velocity and angular
                momentum decay (``set_damping``); default 0.
            name: unique; default "body<i>".
        """
        if name is None:
            name = f"body{self.body_count}"
        if not isinstance(name, str) or not name:
            raise InputError(f"must be a non-empty string, got {name!r}", "name")
        if name in self._index_by_name:
            raise InputError(f"duplicate body name {name!r}", "name")
        if orientation is not None and euler_deg is not None:
            raise InputError("give orientation or euler_deg, not both", "orientation")
        if euler_deg is not None:
            q = quat_from_euler_deg(finite_vector(euler_deg, "euler_deg"))
        else:
            q = unit_quaternion((1.0, 0.0, 0.0, 0.0) if orientation is None else orientation)
        position = finite_vector(position, "position")
        velocity = finite_vector(velocity, "velocity")
        angular_velocity = finite_vector(angular_velocity, "angular_velocity")
        surface_velocity = finite_vector(surface_velocity, "surface_velocity")
        if angular_velocity_frame not in ("world", "body"):
            raise InputError(f"must be 'world' or 'body', got {angular_velocity_frame!r}", "angular_velocity_frame")
        try:
            material = Material.coerce(material)
        except InputError as err:
            raise err.within("material") from None
        try:
            collision_filter = CollisionFilter.coerce(collision_filter)
        except InputError as err:
            raise err.within("collision_filter") from None
        R = quat_to_matrix(q)
        if fixed and kinematic:
            raise InputError("a body is fixed or kinematic, not both", "kinematic")
        if not isinstance(sensor, (bool, np.bool_)):
            raise InputError(f"expected True or False, got {sensor!r}", "sensor")
        gravity_scale = _gravity_scale(gravity_scale)
        damping = (_rate(linear_damping, "linear_damping"), _rate(angular_damping, "angular_damping"))
        if not isinstance(enabled, (bool, np.bool_)):
            raise InputError(f"expected True or False, got {enabled!r}", "enabled")
        if not enabled:
            _check_can_disable(shape)
        if sensor and isinstance(shape, Plane):
            raise InputError("a plane cannot be a sensor (it has no inside to enter)", "sensor")
        if kinematic and isinstance(shape, Plane):
            raise InputError("a plane can only be a fixed body (set fixed = true)", "kinematic")
        if isinstance(shape, Mesh) and not shape.closed:
            # an open surface collides as triangles only where the mesh pairs take it (a fixed or kinematic
            # body: collision/pairs/mesh.py); a moving mesh collides as its hull, which a sheet may not have
            if sensor:
                raise InputError("an open mesh (closed = false) cannot be a sensor (it has no inside to enter)", "sensor")
            if not (fixed or kinematic):
                raise InputError("an open mesh (closed = false) can only be on a fixed or kinematic body (set fixed = true)",
                                 "fixed")

        if center_of_mass is not None:
            if isinstance(shape, Plane):
                raise InputError("a plane has no centre of mass (it can only be a fixed body)", "center_of_mass")
            props = _given_mass_properties(mass, density, inertia, center_of_mass)
            if not (fixed or kinematic):
                _check_inertia(props.inertia)
        elif fixed or kinematic:
            if isinstance(shape, Plane) or (mass is None and density is None):
                props = None
            else:
                props = mass_properties(shape, mass=mass, density=density)
        else:
            if isinstance(shape, Plane):
                raise InputError("a plane can only be a fixed body (set fixed = true)", "fixed")
            props = mass_properties(shape, mass=mass, density=density)
            if inertia is not None:
                props = _override_inertia(props, inertia)
            _check_inertia(props.inertia)

        i = self.body_count
        if i == self._capacity:
            self._allocate(2 * self._capacity)
        self.body_count += 1
        a = self._arrays
        center = np.zeros(3) if props is None else np.asarray(props.center, dtype=float)
        a["com_offset"][i] = center
        # products without BLAS (math3d.mat_vec's note): the same bits on every machine
        a["x"][i] = position + mat_vec(R, center)
        a["q"][i] = q
        a["R"][i] = R
        a["moving"][i] = not (fixed or kinematic)
        a["kinematic"][i] = kinematic
        a["sensor"][i] = bool(sensor)
        a["disabled"][i] = False
        a["gravity_scale"][i] = gravity_scale
        a["damping"][i] = damping
        a["held_type"][i] = 0.0
        a["held_v"][i] = 0.0
        a["held_omega"][i] = 0.0
        a["kinematic_v"][i] = 0.0
        a["kinematic_omega"][i] = 0.0
        a["surface_velocity"][i] = surface_velocity
        if kinematic:
            omega = angular_velocity if angular_velocity_frame == "world" else mat_vec(R, angular_velocity)
            a["kinematic_v"][i] = velocity
            a["kinematic_omega"][i] = omega
            a["v"][i] = velocity
            a["omega"][i] = omega
        if fixed or kinematic or props is None:
            self._write_infinite_mass(i)
            a["inertia_body"][i] = np.diag([math.inf] * 3) if props is None else props.inertia
            a["dynamic_mass"][i] = math.nan if props is None else props.mass
        else:
            omega = angular_velocity if angular_velocity_frame == "world" else mat_vec(R, angular_velocity)
            self._write_mass_properties(i, props, velocity, omega)
            a["v"][i] = velocity
            a["omega"][i] = omega
            a["I_inv"][i] = rotate_tensor(R, a["inertia_body_inv"][i])
        self.names.append(name)
        self._index_by_name[name] = i
        self.shapes.append(shape)
        self.materials.append(material)
        self.collision_filters.append(collision_filter)
        self._tables = None
        if not enabled:
            self.set_enabled(i, False)
        # force/torque are filled by the simulator's first evaluation (or update_derived())
        return Body(self, i)

    def add_force(self, force):
        """Add a force record of ``tumble.forces`` (Drag, Wind, ConstantForce, PointForce,
        Spring, Impulse, Explosion, Buoyancy, Fluid, CustomForce), or a ``Switch`` (a body taken out or
        put back at a time). A spring with ``rest_length=None`` takes the distance between its anchors now."""
        if not isinstance(force, (Drag, ConstantForce, PointForce, Spring, Impulse, Explosion, Buoyancy, Fluid,
                                  CustomForce, Switch)):
            raise InputError(f"not a force record: {force!r}", "forces")
        self.force_bodies(force)  # each known (InputError)
        if isinstance(force, Switch):
            _check_can_disable(self.shapes[self.index_of(force.body)])
            self.switch_count += 1
        if isinstance(force, Spring) and force.rest_length is None:
            pa, pb = self.spring_endpoints(force)
            force.rest_length = float(np.linalg.norm(pa - pb))
        self.forces.append(force)
        object.__setattr__(force, "_added", True)  # its fields' edits rebuild the tables (forces._ForceRecord)
        self._tables = None
        return force

    def remove_force(self, force):
        """Remove a force record added by ``add_force`` (that very object): a spring let go, a
        wind stopped. An ``Impulse``, ``Explosion`` or ``Switch`` stays (it is part of the run's
        history: the records applied are counted by their place in the list)."""
        if isinstance(force, (Impulse, Explosion, Switch)):
            kind = {Impulse: "an impulse", Explosion: "an explosion", Switch: "a switch"}[type(force)]
            raise InputError(f"{kind} cannot be removed (it is applied once, at its time)", "forces")
        for k, f in enumerate(self.forces):
            if f is force:
                del self.forces[k]
                object.__setattr__(force, "_added", False)
                # the applied impulses are counted by their place in ``forces``: those after k move up one
                self.applied_impulses = {j - 1 if j > k else j for j in self.applied_impulses}
                self._tables = None
                return
        raise InputError(f"not a force of this world: {force!r}", "forces")

    def force_bodies(self, force) -> list[int]:
        """The rows of the bodies a force record names (``body``, ``body_a``, ``body_b``,
        ``bodies``; a record over every moving body, ``bodies=None``, names none). InputError:
        one unknown."""
        rows = [self.index_of(b) for b in (getattr(force, k, None) for k in ("body", "body_a", "body_b"))
                if b is not None]
        return rows + [self.index_of(b) for b in getattr(force, "bodies", None) or ()]

    def forces_changed(self):
        """Say that force records were changed in place: the kernels' force tables are rebuilt
        before the next step. (A field set on an added record does this itself.)"""
        self._tables = None

    def add_joint(self, joint):
        """Add a joint record of ``tumble.joints`` (BallJoint, HingeJoint, ...): checks it and
        resolves its anchors and axes into the bodies' frames at their current poses."""
        from .joints import JOINT_GEAR, P_ARMATURE, bind_joint

        bound = bind_joint(self, joint)
        if bound.type_id == JOINT_GEAR:
            # Gauss-Seidel takes a gear's effective mass over the free bodies: a pendulum geared 3:1 to a
            # flywheel slipped 0.081 rad in 2 s with Box2D's soft rows and blew up within 0.2 s with rigid
            # ones; the tree method takes it through the tree (2e-15 rad; measured): the default
            self.exact_joints = True
        if bound.param[P_ARMATURE] > 0.0:
            # Gauss-Seidel converges slowly, and with limits not at all, where the armature dwarfs the
            # links' inertia (two 0.1 kg links of 0.4 m with armature 1 swung twice the exact angle in
            # 1 s; 0.04 kg links against a limit went to NaN; measured): the exact tree solve by default
            # (an armature set on the record later: Simulator's default looks at the rows too)
            self.exact_joints = True
        self.joints.append(joint)
        return joint

    def add_path(self, path, place: bool = True):
        """Add a ``tumble.kinematic.KeyframePath``: before each step the Simulator sets its
        kinematic body's velocities to reach the path's pose at the step's end. ``place``: put
        the body at the path's pose now (at ``t``), at rest; a checkpoint's load does not."""
        from .kinematic import KeyframePath, bind_path

        if not isinstance(path, KeyframePath):
            raise InputError(f"not a KeyframePath: {path!r}", "paths")
        i = bind_path(self, path)
        if place:
            p, q = path.pose(self.t)
            q = self.q[i].copy() if q is None else q
            R = quat_to_matrix(q)
            self.q[i] = q
            self.R[i] = R
            self.x[i] = p + mat_vec(R, self.com_offset[i])
            self.kinematic_v[i] = 0.0
            self.kinematic_omega[i] = 0.0
            self.update_derived()
        self.paths.append(path)
        return path

    def index_of(self, body) -> int:
        """Index of a body given as a ``Body``, a name or an index."""
        if isinstance(body, Body):
            if body.world is not self:
                raise InputError("body belongs to another world", "body")
            return body.index
        if isinstance(body, str):
            try:
                return self._index_by_name[body]
            except KeyError:
                raise InputError(f"unknown body {body!r}", "body") from None
        if isinstance(body, (int, np.integer)) and 0 <= int(body) < self.body_count:
            return int(body)
        raise InputError(f"unknown body {body!r}", "body")

    def ray_cast(self, origin, direction, max_distance=math.inf, exclude=None, mask=ALL_CATEGORIES,
                 category=ALL_CATEGORIES):
        """The first shape along each ray at the bodies' current poses: ``collision.raycast.ray_cast``
        (origin, direction (3,) or (R, 3), world; returns a ``RayHits`` of body, distance m, point,
        normal per ray; a solid shape that holds the origin is not hit; only bodies whose
        collision category meets ``mask`` and whose mask meets ``category`` are seen, never
        sensors)."""
        from .collision.raycast import ray_cast

        return ray_cast(self, origin, direction, max_distance, exclude, mask=mask, category=category)

    def overlap_aabb(self, lower, upper, mask=ALL_CATEGORIES, category=ALL_CATEGORIES) -> np.ndarray:
        """Sorted (K,) int64 indices of the bodies whose shapes' bounding boxes overlap the box
        ``lower`` .. ``upper`` ((3,) m, world) at their current poses: ``collision.query``
        (Box2D's OverlapAABB, PyBullet's getOverlappingObjects; ``mask`` as in ``ray_cast``)."""
        from .collision.query import overlap_aabb

        return overlap_aabb(self, lower, upper, mask, category)

    def closest_points(self, body_a, body_b, max_distance=math.inf):
        """Signed distance, closest points and normal of each pair of bodies at their current poses:
        ``collision.distance.closest_points`` (PyBullet's getClosestPoints, MuJoCo's
        mj_geomDistance; body_a, body_b a body or P of them; returns a ``ClosestPoints`` with a
        row per pair: distance (P,) m, negative when they overlap, point_a, point_b, normal (P, 3)
        world)."""
        from .collision.distance import closest_points

        return closest_points(self, body_a, body_b, max_distance)

    def near_pairs(self, max_distance: float, mask=ALL_CATEGORIES, category=ALL_CATEGORIES):
        """Every pair of bodies whose shapes come within ``max_distance`` m of each other (or overlap),
        with their signed distance, points and normal: ``collision.distance.near_pairs`` (a
        ``ClosestPoints`` whose ``body_a``, ``body_b`` name each row's pair)."""
        from .collision.distance import near_pairs

        return near_pairs(self, max_distance, mask, category)

    def shape_cast(self, shape, position, translation, orientation=None, exclude=None, mask=ALL_CATEGORIES,
                   category=ALL_CATEGORIES):
        """Where ``shape`` (a Sphere, Capsule, Cylinder, Cone, Box, Ellipsoid or Convex not in the world) moved from
        ``position`` by ``translation`` ((3,) or (K, 3) m, world) first touches a body:
        ``collision.shape_query.shape_cast`` (Box2D's b2World_CastShape; returns a ``ShapeHits``:
        body, fraction of the translation, position, point and normal per cast)."""
        from .collision.shape_query import shape_cast

        return shape_cast(self, shape, position, translation, orientation, exclude, mask, category)

    def overlap_shape(self, shape, position, orientation=None, exclude=None, mask=ALL_CATEGORIES,
                      category=ALL_CATEGORIES) -> np.ndarray:
        """Sorted (K,) int64 indices of the bodies that ``shape`` (not in the world) placed at
        ``position`` (its origin, (3,) m, world) overlaps or touches: ``collision.shape_query``
        (Box2D's b2World_OverlapShape, pymunk's shape_query)."""
        from .collision.shape_query import overlap_shape

        return overlap_shape(self, shape, position, orientation, exclude, mask, category)

    def drop(self, body, direction=None, max_distance: float = 1000.0) -> float:
        """Move ``body`` straight along ``direction`` (default gravity's) until it touches another body;
        returns the distance moved: ``collision.shape_query.drop`` (a scene's ``drop = true``)."""
        from .collision.shape_query import drop

        return drop(self, body, direction, max_distance)

    def add_fractured(self, fractured, *, density: float, position=(0.0, 0.0, 0.0), orientation=None, euler_deg=None,
                      strength: float = math.inf, min_face: float | None = None, name: str = "piece", **body_options):
        """Add a ``tb.fracture(shape, ...)`` as bodies ``{name}/{k}``, one per cell, glued by breakable
        fixed joints on the faces they share (a glue of tensile ``strength`` Pa); returns (bodies,
        joints). ``tumble.fracturing``."""
        from .fracturing import MIN_FACE, add_fractured

        return add_fractured(self, fractured, density=density, position=position, orientation=orientation,
                             euler_deg=euler_deg, strength=strength, min_face=MIN_FACE if min_face is None else min_face,
                             name=name, **body_options)

    def explode(self, position, radius: float, impulse_per_area: float, falloff: float = 0.0, mask=None,
                shaded: bool = False):
        """A blast now at ``position`` ((3,) m, world), Box2D v3's ``b2World_Explode`` in 3-D: each
        shape of a dynamic body within ``radius + falloff`` m takes ``impulse_per_area`` (N s / m^2)
        times its shadow's area, at its closest point, away from the centre (full within
        ``radius``, fading linearly to nothing over ``falloff``); bodies whose category misses
        ``mask`` are spared; with ``shaded``, a shape hidden from the centre by other bodies takes
        only the part of its push that rays from the centre to six of its points let through.
        Sleeping bodies hit wake at the next step. Returns the ``Blast``: the bodies, points, areas
        and impulses (``collision.explosion``; a timed one is a ``tb.Explosion`` record)."""
        from .collision.explosion import explode

        return explode(self, position, radius, impulse_per_area, falloff, mask, shaded)

    def exclude_collision(self, body_a, body_b):
        """Bodies ``body_a`` and ``body_b`` (``Body``, name or index) never touch each other,
        whatever their filters (MuJoCo's ``<exclude>``, PyBullet's ``setCollisionFilterPair``)."""
        a, b = self.index_of(body_a), self.index_of(body_b)
        if a == b:
            raise InputError(f"a body cannot be excluded from itself ({self.names[a]!r})", "body_b")
        self.excluded_collisions.add((min(a, b), max(a, b)))
        self.filter_version += 1
        self.wake_requests.update((a, b))  # a sleeping pair must let go of its kept contacts (as a filter change)

    def set_material(self, body, material):
        """Give ``body`` (a ``Body``, name or index) another ``Material`` (or a mapping with its
        keys, the rest defaults) from the next step on: PyBullet's ``changeDynamics(lateralFriction=,
        restitution=, rollingFriction=, spinningFriction=)``, MuJoCo's ``model.geom_friction`` edited
        between steps (domain randomization). A compound's parts with materials of their own keep
        them. The body is woken (a resting box given less friction slides). ``body.material = ...``
        does the same. InputError (key ``material``), nothing changed: a bad material."""
        i = self.index_of(body)
        try:
            material = Material.coerce(material)
        except InputError as err:
            raise err.within("material") from None
        self.materials[i] = material
        self.material_version += 1
        self.wake_requests.add(i)

    def set_mass(self, body, mass, inertia=None):
        """Give a moving ``body`` (a ``Body``, name or index) the mass ``mass`` kg and the inertia
        ``inertia`` kg m^2 about its centre of mass (body frame: (3,) principal moments along the
        body axes or a symmetric (3, 3); None: the present inertia scaled by the new mass over the
        old, the same shape of the same density throughout) from now on: PyBullet's
        ``changeDynamics(mass=, localInertiaDiagonal=)``, MuJoCo's ``model.body_mass`` and
        ``body_inertia`` edited between steps. Its velocity and angular velocity are kept (its
        momenta P = m v and L = I omega follow, as PyBullet keeps a body's velocity); its centre
        of mass stays where it is. The body is woken. InputError (key ``mass`` or ``inertia``),
        nothing changed: a fixed or kinematic body, a mass not positive and finite, an inertia not
        symmetric positive definite or breaking the triangle inequality."""
        i = self.index_of(body)
        self._refuse_disabled(i, "mass", "its mass")
        if not self.moving[i]:
            raise InputError("a fixed or kinematic body has no mass to set (infinite: it is not moved by forces)",
                             "mass")
        mass = _positive_mass(mass)
        props = MassProperties(mass, np.zeros(3), self.inertia_body[i] * (mass / self.mass[i]))
        if inertia is not None:
            props = _override_inertia(props, inertia)
        _check_inertia(props.inertia)
        self._write_mass_properties(i, props, self.v[i].copy(), self.omega[i].copy())
        self._tables = None  # force tables may hold what a body's mass decides (a fluid's inertia box)
        self.wake_requests.add(i)
        self.update_derived()

    def _write_mass_properties(self, i: int, props: MassProperties, v, omega):
        """Body row i's mass, inverse mass, inertia, its inverse and principal axes from ``props``
        (a moving body's: add_body, set_mass, set_body_type), and its momenta from its velocity
        ``v`` (3,) m/s and angular velocity ``omega`` (3,) rad/s, world: P = m v, L = R Ibody R^T
        omega (R the body's orientation row, already written)."""
        a = self._arrays
        a["P"][i] = props.mass * v
        a["L"][i] = mat_vec(rotate_tensor(a["R"][i], np.asarray(props.inertia, dtype=float)), omega)
        a["mass"][i] = props.mass
        a["dynamic_mass"][i] = props.mass
        a["inv_mass"][i] = 1.0 / props.mass
        a["inertia_body"][i] = props.inertia
        a["inertia_body_inv"][i] = inverse3(np.asarray(props.inertia, dtype=float))
        moments, axes = props.principal()
        a["principal_q"][i] = matrix_to_quat(np.ascontiguousarray(axes))
        a["principal_moments"][i] = moments

    def _write_infinite_mass(self, i: int):
        """Body row i's mass rows as a fixed or kinematic body's: infinite mass and inertia (the
        ``inertia_body`` row is the caller's: the inertia given or held, or inf)."""
        a = self._arrays
        a["mass"][i] = math.inf
        a["inv_mass"][i] = 0.0
        a["inertia_body_inv"][i] = 0.0
        a["principal_q"][i] = (1.0, 0.0, 0.0, 0.0)
        a["principal_moments"][i] = math.inf

    def body_type(self, body) -> str:
        """``"dynamic"``, ``"kinematic"`` or ``"fixed"``: the type of ``body`` (``Body``, name or
        index); a disabled body's is the type it comes back as (``set_enabled``)."""
        i = self.index_of(body)
        if self.disabled[i]:
            return BODY_TYPES[int(self.held_type[i])]
        return "dynamic" if self.moving[i] else "kinematic" if self.kinematic[i] else "fixed"

    def body_types(self) -> np.ndarray:
        """(N,) str: every body's ``body_type`` at once (a disabled body's, the type it comes back as)."""
        now = np.where(self.moving, "dynamic", np.where(self.kinematic, "kinematic", "fixed"))
        return np.where(self.disabled, np.array(BODY_TYPES)[self.held_type.astype(np.int64)], now)

    def set_gravity_scale(self, body, scale: float):
        """The fraction ``scale`` of its weight m g that ``body`` (``Body``, name or index) feels
        from the next step on: Box2D's ``b2Body_SetGravityScale``, Bullet's per-body gravity,
        MuJoCo's ``gravcomp`` (a scale of 1 - gravcomp: an arm that holds its pose, a payload
        lifted by a crane's compensator). 0: the body floats (m g cancelled exactly); 0.5: it falls
        at g / 2; negative: it rises (a balloon). Applied as a constant force (scale - 1) m g at
        its centre of mass besides gravity, so it follows the world's gravity and the body's mass
        as they change; its potential energy is scale m g h (``potential_energy``). A fixed or
        kinematic body keeps its scale for when it moves. The body is woken. InputError (key
        ``gravity_scale``), nothing changed: not a finite number."""
        i = self.index_of(body)
        self._arrays["gravity_scale"][i] = _gravity_scale(scale)
        self._tables = None
        self.wake_requests.add(i)

    def set_damping(self, body, linear: float | None = None, angular: float | None = None):
        """The rates (1/s) at which ``body``'s velocity and angular momentum decay from the next step
        on: a force -c m v and a torque -c_a L at its centre of mass (Box2D's and PhysX's
        ``linearDamping`` and ``angularDamping``; under nothing else v = v0 e^(-c t) and
        L = L0 e^(-c_a t), whatever its shape). ``None`` keeps that one. Bullet's, PyBullet's and
        Blender's damping d is a fraction of the velocity lost per second: c = -ln(1 - d) (PyBullet's
        default 0.04 is c = 0.0408, Blender's 0.04 and 0.1 are 0.0408 and 0.105). Air drag that grows
        with speed, or wind: ``tb.Drag``. The body is woken. InputError (key ``linear_damping`` or
        ``angular_damping``), nothing changed: not a finite number >= 0."""
        i = self.index_of(body)
        row = self._arrays["damping"][i]
        c = float(row[0]) if linear is None else _rate(linear, "linear_damping")
        ca = float(row[1]) if angular is None else _rate(angular, "angular_damping")
        row[:] = (c, ca)
        self._tables = None
        self.wake_requests.add(i)

    @property
    def enabled(self) -> np.ndarray:
        """(N,) bool: False for the bodies out of the simulation (``set_enabled``); a new array."""
        return ~self.disabled

    def _refuse_disabled(self, i: int, key: str, what: str):
        if self.disabled[i]:
            raise InputError(f"body {self.names[i]!r} is disabled: enable it before changing {what}", key)

    def set_enabled(self, body, enabled: bool):
        """Take ``body`` (``Body``, name or index) out of the simulation (``enabled=False``) or put
        it back (Box2D's ``b2Body_Disable`` / ``b2Body_Enable``; what PyBullet's ``removeBody``
        and a game's despawn and spawn are for), from the next step on.

        A disabled body stays where it is, moved by nothing, and touches nothing: no contact, no
        sensor overlap, no ray or shape query sees it; its joints are switched off (``broken``,
        switched on again when both their bodies are enabled) and its springs pull nothing; the
        recorded trajectory marks it absent from the frame it left (``Trajectory.enabled``), and
        the exports hide it there (glTF scale, USD visibility, videos, the viewer). It keeps its
        row, name and type: ``body_type`` says the type it comes back as (while it is out it is
        held as a fixed body: ``World.fixed`` and ``Body.fixed`` say so). Enabled again, it comes
        back as that type at the pose it has (set it while disabled: a body respawned elsewhere)
        with the velocity it left with (or one set while disabled: ``Body.v``, ``Body.omega``),
        woken. A kinematic body's keyframed path ends when it is disabled (as with a type
        change). The bodies that touched it are woken (a box asleep on a shelf that vanishes
        falls). The Simulator builds its contact and joint stages again at its next step, as
        for a type change (``set_body_type``).

        Raises:
            InputError (key ``enabled``), nothing changed: not True or False; a plane.
        """
        i = self.index_of(body)
        if not isinstance(enabled, (bool, np.bool_)):
            raise InputError(f"expected True or False, got {enabled!r}", "enabled")
        if not enabled:
            _check_can_disable(self.shapes[i])
        if bool(enabled) == (not self.disabled[i]):
            return  # already so
        a = self._arrays
        if not enabled:
            a["held_type"][i] = BODY_TYPES.index(self.body_type(i))
            a["held_v"][i] = self.v[i]
            a["held_omega"][i] = self.omega[i]
            # as a fixed body in every stage (its mass held: dynamic_mass, inertia_body), and
            # out of the collision pipeline by its filter (collision_filters_in_effect)
            self._write_type(i, "fixed", None, None, None)
            a["disabled"][i] = True
            self._switch_joints(i, on=False)
        else:
            kind = BODY_TYPES[int(a["held_type"][i])]
            v, omega = a["held_v"][i].copy(), a["held_omega"][i].copy()
            a["disabled"][i] = False
            a["held_type"][i] = 0.0
            a["held_v"][i] = 0.0
            a["held_omega"][i] = 0.0
            # the mass it held (dynamic_mass, inertia_body), as set_body_type would take it
            props = self._type_mass(i, None, None, None) if kind == "dynamic" else None
            self._write_type(i, kind, props, v, omega)
            self._switch_joints(i, on=True)
            self.wake_requests.add(i)
        self._retyped([i])
        self.update_derived()

    def _switch_joints(self, i: int, on: bool):
        """Switch off the joints of body row i that act (``joints_switched_off`` lists them), or
        on again those of them whose bodies are now both enabled (``joints.set_broken``: their
        bodies woken, the solver's row taken at the next step)."""
        from .joints import set_broken

        for k, joint in enumerate(self.joints):
            b = joint.bound
            if b is None or i not in (b.body_a, b.body_b):
                continue
            if not on and not joint.broken:
                set_broken(joint, True)
                self.joints_switched_off.add(k)
            elif on and k in self.joints_switched_off and not any(r >= 0 and self.disabled[r] for r in (b.body_a, b.body_b)):
                set_broken(joint, False)
                self.joints_switched_off.discard(k)

    def collision_filters_in_effect(self) -> list:
        """The bodies' collision filters as the collision pipeline and the queries read them:
        a disabled body's is ``NOTHING_FILTER`` (it meets no other; ``set_enabled``)."""
        filters = self.collision_filters[: self.body_count]
        disabled = self.disabled
        if not disabled.any():
            return filters
        return [NOTHING_FILTER if off else f for f, off in zip(filters, disabled)]

    def set_body_type(self, body, body_type: str, *, mass=None, density=None, inertia=None):
        """Make ``body`` (``Body``, name or index) ``"dynamic"``, ``"kinematic"`` or ``"fixed"``
        from the next step on (Box2D's ``b2Body_SetType``, Bullet's kinematic flag set and
        cleared, Blender's "Animated" box unticked at a frame: a body carried, then let go).

        Its velocity is kept where the new type has one: a kinematic body made dynamic goes on at
        the velocity it moved at (P = m v, L = I omega: a thrown ball leaves the hand at the
        hand's speed), a dynamic body made kinematic moves on at its velocity, whatever pushes it;
        a body made fixed stops. A body made dynamic takes the mass given here (``mass`` kg or
        ``density`` kg/m^3, as in ``add_body``; ``inertia`` to override the shape's), else the one
        it had (given at ``add_body`` to a fixed or kinematic body, or held from when it was
        dynamic: ``dynamic_mass``). A kinematic body's keyframed path ends with the type. A body
        made dynamic is woken (the sleeping bodies it touches wake as an awake body's touch wakes
        them); the Simulator builds its contact and joint stages again at its next step (the
        contacts' warm start kept: an expensive call, as Box2D says of its own).

        Raises:
            InputError (key ``type``, ``mass``, ``density`` or ``inertia``), nothing changed: an
            unknown type; a plane or an open mesh made other than fixed (or kinematic, for an open
            mesh); a body made dynamic with no mass known; a mass with its centre away from the
            body's frame (a body added without a mass has its frame at the shape's origin: give
            the mass at ``add_body``); a mass for a body that is dynamic already (``set_mass``).
        """
        i = self.index_of(body)
        if body_type not in BODY_TYPES:
            raise InputError(f"must be one of {', '.join(BODY_TYPES)}, got {body_type!r}", "type")
        self._refuse_disabled(i, "type", "its type")
        old = self.body_type(i)
        shape = self.shapes[i]
        if isinstance(shape, Plane) and body_type != "fixed":
            raise InputError("a plane can only be a fixed body", "type")
        if isinstance(shape, Mesh) and not shape.closed and body_type == "dynamic":
            raise InputError("an open mesh (closed = false) can only be on a fixed or kinematic body", "type")
        given = mass is not None or density is not None or inertia is not None
        if given and old == "dynamic":
            raise InputError(f"body {self.names[i]!r} is dynamic: set its mass with set_mass", "mass")
        props = self._type_mass(i, mass, density, inertia) if given or (body_type == "dynamic" and old != "dynamic") \
            else None
        if body_type == old and props is None:
            return
        self._write_type(i, body_type, props, self.v[i].copy(), self.omega[i].copy())
        if body_type != old:
            self._retyped([i])
        if body_type == "dynamic":
            self.wake_requests.add(i)
        self.update_derived()

    def _write_type(self, i: int, body_type: str, props, v, omega):
        """Body row i's arrays as a ``body_type`` body moving at ``v`` (3,) m/s and ``omega`` (3,)
        rad/s, world, where the type has a velocity (set_body_type, set_enabled): a dynamic body's
        mass rows from ``props`` and its momenta; a fixed or kinematic body's infinite mass (its
        ``props``, when given, held as ``dynamic_mass`` and ``inertia_body`` for a later switch to
        dynamic), no momentum, a kinematic body's velocities; a keyframed path kept only by a
        kinematic body."""
        a = self._arrays
        a["kinematic_v"][i] = 0.0
        a["kinematic_omega"][i] = 0.0
        if body_type == "dynamic":
            self._write_mass_properties(i, props, v, omega)
        else:
            if props is not None:  # held for a later switch to dynamic
                a["dynamic_mass"][i] = props.mass
                a["inertia_body"][i] = props.inertia
            self._write_infinite_mass(i)
            a["P"][i] = 0.0
            a["L"][i] = 0.0
            if body_type == "kinematic":
                a["kinematic_v"][i] = v
                a["kinematic_omega"][i] = omega
        a["moving"][i] = body_type == "dynamic"
        a["kinematic"][i] = body_type == "kinematic"
        if body_type != "kinematic":
            self.paths = [p for p in self.paths if self.index_of(p.body) != i]

    def _retyped(self, rows):
        """Note that the bodies ``rows`` changed type or were taken out or put back (set_body_type,
        set_enabled, a snapshot's restore): listed in ``type_changes`` for the Simulator; the force
        tables (which list the moving bodies), the queries' shape table and the filters the
        pipeline and the queries read (a disabled body's: ``collision_filters_in_effect``) made
        again when next needed."""
        self.type_changes.extend(int(i) for i in rows)
        self._tables = None
        self.__dict__.pop("_ray_scene", None)
        self.filter_version += 1

    def _type_mass(self, i: int, mass, density, inertia) -> MassProperties:
        """The mass properties body row i takes as a dynamic body (set_body_type): from ``mass``
        or ``density``, else those it has (``dynamic_mass``, ``inertia_body``, or a particle
        set's own), ``inertia`` overriding; about the body frame's origin (its centre of mass)."""
        shape = self.shapes[i]
        if mass is None and density is None:
            if inertia is not None and not math.isfinite(self.dynamic_mass[i]):
                raise InputError("give inertia with a mass or density", "inertia")
            if math.isfinite(self.dynamic_mass[i]):
                props = MassProperties(float(self.dynamic_mass[i]), self.com_offset[i].copy(), self.inertia_body[i].copy())
            elif isinstance(shape, Particles):
                props = mass_properties(shape)
            else:
                raise InputError(f"body {self.names[i]!r} has no mass (fixed or kinematic, added without one): "
                                 "give mass or density", "mass")
        else:
            props = mass_properties(shape, mass=mass, density=density)
        center = np.asarray(props.center, dtype=float)
        scale = max(1.0, float(np.max(np.abs(center))))
        if np.max(np.abs(center - self.com_offset[i])) > 1e-9 * scale:
            raise InputError(f"the centre of mass {center.tolist()} (shape frame) is not the body frame's origin "
                             f"{self.com_offset[i].tolist()}: give the body its mass at add_body, which places its frame",
                             "mass")
        if inertia is not None:
            props = _override_inertia(props, inertia)
        _check_inertia(props.inertia)
        return props

    def set_pair_material(self, body_a, body_b, material):
        """The contacts between ``body_a`` and ``body_b`` (``Body``, name or index) take
        ``material``'s friction, restitution and condim instead of mixing the two bodies' (MuJoCo's
        ``<contact><pair>``, Box2D's and PhysX's per-pair contact modification): its friction and
        restitution as they are, no friction where its condim is 1, no spinning friction below 4
        and no rolling resistance below 6 (its own rolling and spinning coefficients are not read:
        the bodies' mix). Its margin is not read (the bodies' margins apply). ``material``: a
        ``Material`` or a mapping of its keys; None removes the pair's."""
        a, b = self.index_of(body_a), self.index_of(body_b)
        if a == b:
            raise InputError(f"a body has no contacts with itself ({self.names[a]!r})", "body_b")
        pair = (min(a, b), max(a, b))
        if material is None:
            self.pair_materials.pop(pair, None)
        else:
            self.pair_materials[pair] = Material.coerce(material)
        self.pair_material_version += 1

    def should_collide(self, body_a, body_b) -> bool:
        """Whether contact between two bodies is allowed: their filters meet, the pair is not
        excluded and no joint between them has ``collide_connected=False``."""
        from .joints import jointed_body_pairs

        a, b = self.index_of(body_a), self.index_of(body_b)
        pair = (min(a, b), max(a, b))
        if a == b or pair in self.excluded_collisions or list(pair) in jointed_body_pairs(self).tolist():
            return False
        return self.collision_filters[a].collides_with(self.collision_filters[b])

    def body(self, key) -> "Body":
        """The view of a body by name or index."""
        return Body(self, self.index_of(key))

    @property
    def bodies(self) -> list["Body"]:
        return [Body(self, i) for i in range(self.body_count)]

    def spring_endpoints(self, spring: Spring):
        """World points (3,), (3,) m at the two ends of ``spring``."""
        a = self.index_of(spring.body_a)
        pa = self.R[a] @ np.asarray(spring.anchor_a) + self.x[a]
        if spring.body_b is None:
            return pa, np.asarray(spring.anchor_b, dtype=float)
        b = self.index_of(spring.body_b)
        return pa, self.R[b] @ np.asarray(spring.anchor_b) + self.x[b]

    @property
    def tables(self):
        """The force tables the kernels read (rebuilt when forces or bodies change)."""
        if self._tables is not None and self._tables_gravity is not None and not np.array_equal(self._tables_gravity,
                                                                                              self._gravity):
            self._tables = None  # gravity changed in place (world.gravity[2] = ...) under a scaled body's row
        if self._tables is None or self._force_edits != force_edit_count():
            self._force_edits = force_edit_count()  # (any world's record edited: rebuilt, the same tables or new)
            scale = self.gravity_scale
            scaled = bool(np.any(scale != 1.0))
            damping = self.damping
            self._tables = build_force_tables(self.forces, self.body_count, self.moving, self.index_of, self.mass,
                                              self.inertia_body, disabled=self.disabled, gravity=self._gravity,
                                              gravity_scale=scale if scaled else None,
                                              damping=damping if np.any(damping != 0.0) else None)
            self._tables_gravity = self._gravity.copy() if scaled else None
        return self._tables

    @property
    def impulses(self) -> list:
        """The records applied once at their ``time``: ``Impulse``, ``Explosion`` and ``Switch``."""
        return [f for f in self.forces if isinstance(f, (Impulse, Explosion, Switch))]

    # ------------------------------------------------------------------ the course's state vector
    @property
    def layout_id(self) -> int:
        return K.LAYOUT_IDS[self.layout]

    @property
    def state_size(self) -> int:
        """Numbers per body in ``state()``: 13 (quaternion layout) or 18 (matrix layout, ERRATA 6)."""
        return K.STATE_WIDTH[self.layout_id]

    def pack(self) -> np.ndarray:
        """The state as (N, W) rows x | R (row-major) or q | P | L (a new array)."""
        n = self.body_count
        orient = self.R.reshape(n, 9) if self.layout == "matrix" else self.q
        return np.ascontiguousarray(np.concatenate([self.x, orient, self.P, self.L], axis=1))

    def unpack(self, Y: np.ndarray):
        """Set x, R or q, P, L from (N, W) rows, and bring the other orientation and derived quantities up to date."""
        n = self.body_count
        W = self.state_size
        Y = np.asarray(Y, dtype=float).reshape(n, W)
        self.x[:] = Y[:, :3]
        if self.layout == "matrix":
            self.R[:] = Y[:, 3:12].reshape(n, 3, 3)
        else:
            self.q[:] = Y[:, 3:7]
        self.P[:] = Y[:, W - 6:W - 3]
        self.L[:] = Y[:, W - 3:]
        self.update_derived(np.ascontiguousarray(Y))

    def state(self) -> np.ndarray:
        """The course's state vector X (N * W,): per body x, R or q, P, L (Algorithm 2, "BodiesToArray")."""
        return self.pack().ravel()

    def set_state(self, X):
        """Inverse of ``state()`` (the course's "ArrayToBodies")."""
        self.unpack(np.asarray(X, dtype=float).reshape(self.body_count, self.state_size))

    def dxdt(self, t: float, X: np.ndarray) -> np.ndarray:
        """dX/dt at time t for the state vector X (N * W,), without touching the world's state.

        Course Algorithm 4 ("Dxdt"): derived quantities, forces and torques,
        then (v, omega* R, F, tau) per body. Suitable for
        ``scipy.integrate.solve_ivp(world.dxdt, ...)``.
        """
        n = self.body_count
        Y = np.ascontiguousarray(np.asarray(X, dtype=float).reshape(n, self.state_size))
        scratch = Scratch(n, self.state_size)
        self.evaluate_forces(t, Y, scratch)
        dY = np.empty_like(Y)
        K.derivative_kernel(self.layout_id, Y, scratch.R, scratch.v, scratch.omega, self.moving, scratch.F, scratch.T, dY)
        return dY.ravel()

    def evaluate_forces(self, t: float, Y: np.ndarray, scratch: "Scratch"):
        """Fill scratch.R, v, omega, F, T for the state rows Y (N, W) at time t: kernels, then user callables."""
        tb = self.tables
        K.accumulate_forces_kernel(
            self.layout_id, Y, self.mass, self.inv_mass, self.inertia_body_inv, self.moving, self.gravity,
            tb.uforce_kind, tb.uforce_param, tb.uforce_start, tb.spring_body, tb.spring_anchor, tb.spring_param,
            scratch.R, scratch.v, scratch.omega, scratch.F, scratch.T,
        )
        for force, targets in tb.custom:
            for i in targets:
                view = _StageBody(self, i, Y, scratch)
                f, tau = force.function(t, view)
                f = np.asarray(f, dtype=float)
                tau = np.asarray(tau, dtype=float)
                if f.shape != (3,) or tau.shape != (3,) or not (np.all(np.isfinite(f)) and np.all(np.isfinite(tau))):
                    raise InputError(f"custom force must return two finite (3,) vectors, got {f!r}, {tau!r}", "forces")
                scratch.F[i] += f
                scratch.T[i] += tau

    def update_derived(self, Y: np.ndarray | None = None):
        """Recompute the non-state orientation, v, omega, I^-1 and the accumulated forces
        (built-in ones; user callables are called inside steps only) from the state."""
        if self.body_count == 0:
            return
        if Y is None:
            Y = self.pack()
        tb = self.tables
        K.update_derived_kernel(
            self.layout_id, Y, self.mass, self.inv_mass, self.inertia_body_inv, self.moving, self.gravity,
            tb.uforce_kind, tb.uforce_param, tb.uforce_start, tb.spring_body, tb.spring_anchor, tb.spring_param,
            self.q, self.R, self.v, self.omega, self.I_inv, self.force, self.torque,
        )
        self._kinematic_velocities(self.v, self.omega)

    def _kinematic_velocities(self, v: np.ndarray, omega: np.ndarray):
        """Write the kinematic bodies' velocities into v, omega (N, 3) (kernels derive v = P / m,
        which is 0 at infinite mass)."""
        k = self.kinematic
        if k.any():
            v[: self.body_count][k] = self.kinematic_v[k]
            omega[: self.body_count][k] = self.kinematic_omega[k]

    # ------------------------------------------------------------------ diagnostics
    def kinetic_energy(self) -> float:
        """Total 1/2 P.v + 1/2 L.omega, J (moving bodies)."""
        m = self.moving
        return float(0.5 * np.sum(self.P[m] * self.v[m]) + 0.5 * np.sum(self.L[m] * self.omega[m]))

    def potential_energy(self) -> float:
        """Total -s m g.x over moving bodies (s: their gravity scales) plus 1/2 k (l - l0)^2 over springs and the joints' springs
        (hinge, slider and distance stiffness, ball joint drives: ``solver.joints.joint_spring_energy``), J."""
        m = self.moving
        # s m g h (set_gravity_scale; s = 1 multiplies m exactly: the bits of m g h)
        e = float(-np.sum(self.gravity_scale[m] * self.mass[m] * (self.x[m] @ self.gravity)))
        disabled = self.disabled
        for f in self.forces:
            if isinstance(f, Spring) and not (disabled[self.index_of(f.body_a)]
                                              or (f.body_b is not None and disabled[self.index_of(f.body_b)])):
                pa, pb = self.spring_endpoints(f)
                e += 0.5 * f.stiffness * (float(np.linalg.norm(pa - pb)) - f.rest_length) ** 2
        if self.joints:
            from .solver.joints import joint_spring_energy

            e += joint_spring_energy(self)
        return e

    def linear_momentum(self) -> np.ndarray:
        """Total P (3,) kg m/s of moving bodies."""
        return self.P[self.moving].sum(axis=0)

    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum (3,) about the world origin: sum of L + x cross P, kg m^2/s."""
        m = self.moving
        return (self.L[m] + np.cross(self.x[m], self.P[m])).sum(axis=0)

    def orthonormality_error(self) -> float:
        """How far the state's orientations are off SO(3), over all bodies: the largest
        |R^T R - 1| entry (matrix layout) or the largest ||q|^2 - 1| (quaternion layout, whose R
        is made from q and is orthonormal to rounding)."""
        if self.body_count == 0:
            return 0.0
        if self.layout == "quaternion":
            return float(np.max(np.abs(np.linalg.norm(self.q, axis=1) ** 2 - 1.0)))
        RtR = np.einsum("nji,njk->nik", self.R, self.R)
        return float(np.max(np.abs(RtR - np.eye(3))))


def _given_mass_properties(mass, density, inertia, center_of_mass):
    """The mass properties given whole (``add_body``'s ``center_of_mass`` with ``mass`` and
    ``inertia``): nothing is computed from the shape."""
    if mass is None or inertia is None or density is not None:
        raise InputError("give center_of_mass with mass and inertia (not density): the shape's own are then not used",
                         "center_of_mass")
    center = finite_vector(center_of_mass, "center_of_mass")
    return _override_inertia(MassProperties(_positive_mass(mass), center, np.eye(3)), inertia)


def _positive_mass(mass) -> float:
    """``mass`` as a float, kg (InputError keyed ``mass``: not a positive finite number)."""
    if isinstance(mass, bool) or not isinstance(mass, (int, float, np.floating, np.integer)) \
            or not math.isfinite(mass) or mass <= 0:
        raise InputError(f"must be a positive number, got {mass!r}", "mass")
    return float(mass)


def _override_inertia(props, inertia):
    from dataclasses import replace

    try:
        I = np.asarray(inertia, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"expected 3 numbers or a 3x3 matrix, got {inertia!r}", "inertia") from None
    if I.shape == (3,):
        I = np.diag(I)
    if I.shape != (3, 3):
        raise InputError(f"expected 3 numbers or a 3x3 matrix, got shape {I.shape}", "inertia")
    if not np.all(np.isfinite(I)):
        raise InputError("must be finite numbers", "inertia")
    # NOTE: only rounding is forgiven (MassProperties symmetrises what is left): a matrix whose
    # off-diagonal pairs differ by more was silently averaged into another body's inertia
    asym = np.abs(I - I.T)
    if asym.max() > 1e-9 * np.abs(I).max():
        i, j = np.unravel_index(int(np.argmax(asym)), asym.shape)
        raise InputError(f"must be a symmetric matrix, got [{i}][{j}] = {I[i, j]:g} but [{j}][{i}] = {I[j, i]:g}", "inertia")
    return replace(props, inertia=I)


class _ArrayView:
    """A World array property: ``world.x`` is a view of the rows of the existing bodies.

    PERF: the view is made at the first read and kept in the instance's ``__dict__`` (this
    descriptor has no ``__set__``, so the kept view is found without a call), until the storage or
    the body count changes (``World._drop_views``: ``_allocate``, the ``body_count`` setter): a box
    on a plane read 49 views a step and the cartpole 105, each made anew by a property (the
    performance audit's S2). The kept view shares the storage, so an edit through it or through a
    Body handle is the world's at once. Setting one (``world.x = ...``) stays an AttributeError
    (``World.__setattr__``), as with the property it replaces."""

    def __init__(self, name: str):
        self.name = name
        self.__doc__ = f"``{name}``: a view of the rows of the existing bodies."

    def __get__(self, world, owner=None):
        if world is None:
            return self
        view = world.__dict__[self.name] = world._arrays[self.name][: world._body_count]
        return view


_ARRAY_NAMES = frozenset((*_CONSTANT_ARRAYS, *_STATE_ARRAYS, *_DERIVED_ARRAYS, *_KINEMATIC_ARRAYS, *_FLAG_ARRAYS))
for _name in _ARRAY_NAMES:
    setattr(World, _name, _ArrayView(_name))


def _check_can_disable(shape):
    """InputError (key ``enabled``): a body of ``shape`` cannot be taken out (``set_enabled``)."""
    if isinstance(shape, Plane):
        raise InputError("a plane cannot be disabled (it is the ground of everything)", "enabled")


def _gravity_scale(value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) or not math.isfinite(value):
        raise InputError(f"must be a finite number (1: the whole weight, 0: none), got {value!r}", "gravity_scale")
    return float(value)


def _rate(value, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) or not (
            math.isfinite(value) and value >= 0.0):
        raise InputError(f"must be a finite rate >= 0 in 1/s, got {value!r}", key)
    return float(value)


def _check_inertia(I):
    I = np.asarray(I, dtype=float)
    if I.shape != (3, 3) or not np.all(np.isfinite(I)) or not np.allclose(I, I.T, rtol=1e-9, atol=1e-15):
        raise InputError("inertia must be a finite symmetric 3x3 matrix", "inertia")
    eig = np.linalg.eigvalsh(I)
    if eig[0] <= 0.0 or eig[0] <= 1e-14 * eig[-1]:
        raise InputError(f"inertia is not positive definite (eigenvalues {eig.tolist()})", "inertia")
    # triangle inequality of principal moments: a real body has I1 + I2 >= I3
    if eig[0] + eig[1] < eig[2] * (1 - 1e-9):
        raise InputError(f"inertia violates the triangle inequality I1 + I2 >= I3 (eigenvalues {eig.tolist()})", "inertia")


class Scratch:
    """Work arrays for one force/derivative evaluation of N bodies (allocated once per run):
    R (N, 3, 3), v, omega, F, T (N, 3), Y1, K, Kacc (N, W), zeros.

    PERF: each is allocated at its first read (``__getattr__``), zeros as before: a
    ``Simulator.step()`` makes one for the call and a body in contact never reads it (the soft
    step has its own), 8 allocations a step for nothing (the performance audit's S2)."""

    _SHAPES = {"R": (3, 3), "v": (3,), "omega": (3,), "F": (3,), "T": (3,), "Y1": None, "K": None, "Kacc": None}

    def __init__(self, n: int, width: int):
        self._n = n
        self._width = width

    def __getattr__(self, name):  # (only for an array not read yet)
        shapes = Scratch._SHAPES
        if name not in shapes:
            raise AttributeError(name)
        tail = shapes[name]
        arr = np.zeros((self._n,) + (tail if tail is not None else (self._width,)))
        setattr(self, name, arr)
        return arr


class _StageBody:
    """Read-only view of one body at a stage state, handed to ``CustomForce`` functions."""

    def __init__(self, world, i, Y, scratch):
        W = Y.shape[1]
        self.index = int(i)
        self.name = world.names[i]
        self.mass = float(world.mass[i])
        self.x = Y[i, :3].copy()
        self.R = scratch.R[i].copy()
        self.q = Y[i, 3:7].copy() if W == 13 else matrix_to_quat(np.ascontiguousarray(self.R))
        self.P = Y[i, W - 6:W - 3].copy()
        self.L = Y[i, W - 3:].copy()
        self.v = scratch.v[i].copy()
        self.omega = scratch.omega[i].copy()


from .body import Body  # noqa: E402  (body.py reads the World's arrays; World returns its views)
