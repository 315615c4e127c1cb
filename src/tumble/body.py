"""``Body``: a view of one body of a World, its reads and writes going to the World's arrays.

The course's names (x, q, R, P, L, v, omega) read the current rows; setting them changes the
state (and wakes the body at the next step: ``World.wake_requests``). Kinematic bodies read and
set their velocities here (``v``, ``omega``, ``set_target``); dynamic bodies take impulses
(``apply_impulse``).
"""

from __future__ import annotations

import math

import numpy as np

from .collision.filter import CollisionFilter
from .errors import InputError
from .math3d import matrix_to_quat, quat_from_euler_deg, quat_to_matrix
from .shapes import finite_vector


def _unit_quaternion(value, key="orientation"):
    from .world import unit_quaternion

    return unit_quaternion(value, key)


class Body:
    """A view of one body: reads and writes go to the World's arrays (never a copy that can fall out of sync).

    Reading ``x``, ``q``, ``R``, ``P``, ``L``, ``v``, ``omega``, ``force``,
    ``torque`` gives (3,) / (4,) / (3, 3) views of the current rows. Setting
    ``x``, ``q``, ``R``, ``P``, ``L``, ``v`` (P = m v) or ``omega`` (L = I omega)
    updates the state and the derived quantities. A kinematic body's ``v`` and
    ``omega`` set the velocities it moves at (it has no P, L: infinite mass).
    """

    __slots__ = ("world", "index")

    def __init__(self, world, index: int):
        self.world = world
        self.index = index

    def __repr__(self):
        return f"Body({self.name!r}, x={self.x.tolist()})"

    def __eq__(self, other):
        return isinstance(other, Body) and other.world is self.world and other.index == self.index

    def __hash__(self):
        return hash((id(self.world), self.index))

    name = property(lambda self: self.world.names[self.index])
    shape = property(lambda self: self.world.shapes[self.index])
    material = property(lambda self: self.world.materials[self.index],
                        lambda self, value: self.world.set_material(self.index, value),
                        doc="The body's ``Material``; set it between steps (``World.set_material``).")

    @property
    def collision_filter(self) -> CollisionFilter:
        return self.world.collision_filters[self.index]

    @collision_filter.setter
    def collision_filter(self, value):
        try:
            self.world.collision_filters[self.index] = CollisionFilter.coerce(value)
        except InputError as err:
            raise err.within("collision_filter") from None
        self.world.filter_version += 1
        # NOTE: why: a sleeping body kept its island's resting contacts under a filter that no
        # longer lets them touch, and hovered (Box2D's b2Shape_SetFilter wakes too; session 42's audit)
        self.world.wake_requests.add(self.index)

    fixed = property(lambda self: not (self.world.moving[self.index] or self.world.kinematic[self.index]))
    type = property(lambda self: self.world.body_type(self.index),
                    lambda self, value: self.world.set_body_type(self.index, value),
                    doc='``"dynamic"``, ``"kinematic"`` or ``"fixed"``; set it between steps '
                        '(``World.set_body_type``: a carried body let go, a falling one frozen).')
    kinematic = property(lambda self: bool(self.world.kinematic[self.index]))
    gravity_scale = property(lambda self: float(self.world.gravity_scale[self.index]),
                             lambda self, value: self.world.set_gravity_scale(self.index, value),
                             doc="The fraction of its weight the body feels (``World.set_gravity_scale``; 1 by "
                                 "default, 0 floats, negative rises).")
    linear_damping = property(lambda self: float(self.world.damping[self.index, 0]),
                              lambda self, value: self.world.set_damping(self.index, linear=value),
                              doc="1/s: the rate its velocity decays at (``World.set_damping``; 0 by default).")
    angular_damping = property(lambda self: float(self.world.damping[self.index, 1]),
                               lambda self, value: self.world.set_damping(self.index, angular=value),
                               doc="1/s: the rate its angular momentum decays at (``World.set_damping``).")
    enabled = property(lambda self: not self.world.disabled[self.index],
                       lambda self, value: self.world.set_enabled(self.index, value),
                       doc="False while the body is out of the simulation; set it between steps "
                           "(``World.set_enabled``: a body despawned, and spawned again).")
    sensor = property(lambda self: bool(self.world.sensor[self.index]))

    @property
    def surface_velocity(self) -> np.ndarray:
        """(3,) m/s, body frame: how fast the body's surface slides along itself in its contacts."""
        return self.world.surface_velocity[self.index]

    @surface_velocity.setter
    def surface_velocity(self, value):
        self.world.surface_velocity[self.index] = finite_vector(value, "surface_velocity")
    mass = property(lambda self: float(self.world.mass[self.index]),
                    lambda self, value: self.world.set_mass(self.index, value),
                    doc="kg (inf: fixed or kinematic). Set: ``World.set_mass`` (the inertia scaled with it).")

    def set_mass(self, mass: float, inertia=None):
        """``World.set_mass`` of this body: mass kg and inertia kg m^2 (None: scaled with the mass),
        velocities kept, woken."""
        self.world.set_mass(self.index, mass, inertia)
    inertia_body = property(lambda self: self.world.inertia_body[self.index])
    inertia_body_inv = property(lambda self: self.world.inertia_body_inv[self.index])
    com_offset = property(lambda self: self.world.com_offset[self.index])
    I_inv = property(lambda self: self.world.I_inv[self.index])
    force = property(lambda self: self.world.force[self.index])
    torque = property(lambda self: self.world.torque[self.index])

    def _set(self, name, value, shape):
        if name in ("P", "L") and self.world.disabled[self.index]:
            raise InputError(f"body {self.name!r} is disabled: set v or omega (the velocities it comes back with) "
                             f"instead of {name}", name)
        if name in ("P", "L") and self.kinematic:
            raise InputError(f"a kinematic body has infinite mass and no momentum: set v or omega instead of {name}", name)
        arr = np.asarray(value, dtype=float)
        if arr.shape != shape or not np.all(np.isfinite(arr)):
            raise InputError(f"expected finite numbers of shape {shape}, got {value!r}", name)
        getattr(self.world, name)[self.index] = arr
        self.world.wake_requests.add(self.index)
        if name == "q":
            self.world.R[self.index] = quat_to_matrix(_unit_quaternion(arr, "q"))
            self.world.q[self.index] = _unit_quaternion(arr, "q")
        elif name == "R":
            self.world.q[self.index] = matrix_to_quat(np.ascontiguousarray(arr))
        self.world.update_derived()

    x = property(lambda self: self.world.x[self.index], lambda self, v: self._set("x", v, (3,)))
    q = property(lambda self: self.world.q[self.index], lambda self, v: self._set("q", v, (4,)))
    R = property(lambda self: self.world.R[self.index], lambda self, v: self._set("R", v, (3, 3)))
    P = property(lambda self: self.world.P[self.index], lambda self, v: self._set("P", v, (3,)))
    L = property(lambda self: self.world.L[self.index], lambda self, v: self._set("L", v, (3,)))

    @property
    def v(self):
        return self.world.v[self.index]

    @v.setter
    def v(self, value):
        if self.world.disabled[self.index]:  # the velocity it comes back with (World.set_enabled)
            self.world.held_v[self.index] = finite_vector(value, "v")
            return
        if self.kinematic:
            self.world.kinematic_v[self.index] = finite_vector(value, "v")
            self.world.update_derived()
            return
        self.P = self.mass * finite_vector(value, "v")

    @property
    def omega(self):
        return self.world.omega[self.index]

    def point_velocity(self, point) -> np.ndarray:
        """The velocity (3,) m/s of the world point ``point`` (3,) m moving with the body, now:
        v + omega x (p - x) (Box2D's b2Body_GetWorldPointVelocity)."""
        w = self.world
        i = self.index
        return w.v[i] + np.cross(w.omega[i], finite_vector(point, "point") - w.x[i])

    def apply_impulse(self, impulse, point=None):
        """Change the body's momenta now by an impulse ``impulse`` (3,) N s, world, at ``point`` (3,)
        m, world (default the centre of mass): P += J, L += (p - x) x J (Box2D's
        b2Body_ApplyLinearImpulse, PyBullet's applyExternalForce over one step). A sleeping body
        given one wakes at the next step. Only for dynamic bodies."""
        if not self.world.moving[self.index]:
            kind = "disabled" if self.world.disabled[self.index] else "kinematic" if self.kinematic else "fixed"
            raise InputError(f"body {self.name!r} is {kind}: an impulse moves only a dynamic body", "impulse")
        J = finite_vector(impulse, "impulse")
        p = self.x if point is None else finite_vector(point, "point")
        w = self.world
        w.P[self.index] += J
        w.L[self.index] += np.cross(p - self.x, J)
        w.wake_requests.add(self.index)
        w.update_derived()

    def set_target(self, position, orientation=None, *, euler_deg=None, time: float):
        """Kinematic body: set v and omega so that it reaches a pose in ``time`` seconds
        (Box2D's b2Body_SetTargetTransform): ``position`` (3,) m, world, of the shape origin as
        in ``World.add_body``, ``orientation`` (4,) (w, x, y, z) or ``euler_deg``; default the
        current orientation. The turn is the shortest rotation, at constant omega."""
        if not self.kinematic:
            raise InputError(f"body {self.name!r} is not kinematic: only a kinematic body follows targets", "kinematic")
        if not (isinstance(time, (int, float)) and math.isfinite(time) and time > 0.0):
            raise InputError(f"must be a positive number of seconds, got {time!r}", "time")
        if orientation is not None and euler_deg is not None:
            raise InputError("give orientation or euler_deg, not both", "orientation")
        if euler_deg is not None:
            q1 = quat_from_euler_deg(finite_vector(euler_deg, "euler_deg"))
        elif orientation is not None:
            q1 = _unit_quaternion(orientation)
        else:
            q1 = np.array(self.q, dtype=float)
        from .kinematic import velocities_to

        x1 = finite_vector(position, "position") + quat_to_matrix(q1) @ self.com_offset
        w = self.world
        w.kinematic_v[self.index], w.kinematic_omega[self.index] = velocities_to(self.x, self.q, x1, q1, time)
        w.update_derived()

    @omega.setter
    def omega(self, value):
        w = finite_vector(value, "omega")
        if self.world.disabled[self.index]:  # the angular velocity it comes back with (World.set_enabled)
            self.world.held_omega[self.index] = w
            return
        if self.kinematic:
            self.world.kinematic_omega[self.index] = w
            self.world.update_derived()
            return
        R = self.R
        self.L = R @ self.inertia_body @ R.T @ w
