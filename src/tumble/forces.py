"""Force generators (Baraff 2001 §2.7 "force and torque"): public records and their tables.

The records below are what users and scene files create. ``World`` turns them
into flat tables that the kernels read (``build_force_tables``):

* unary forces, one row per (generator, body), sorted by body with CSR offsets
  ``uforce_start`` (N+1,), so a kernel can sum a body's forces alone;
* springs, one row per spring (they couple two bodies);
* gravity is a world vector applied as m g to every moving body.

Impulses and explosions happen at one instant and are applied between steps by
the simulator; ``CustomForce`` calls user Python and takes the slow path.
``tumble.reference.compute_force_and_torque`` evaluates the same records per
body in plain Python, and the tests compare the two.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Sequence

import math

import numpy as np

from .errors import InputError
from .math3d import matrix_to_quat
from .shapes import finite_vector

# Unary force kinds (column 0 of the table is the kind, the rest parameters).
UFORCE_DRAG, UFORCE_CONSTANT, UFORCE_POINT_WORLD, UFORCE_POINT_BODY, UFORCE_FLUID, UFORCE_DAMPING = range(6)
UFORCE_PARAMS = 12
# MuJoCo's mjMINVAL: the floor of an equivalent box's squared side (times m / 6)
FLUID_MINVAL = 1e-15


# the count of edits of force records already added to a world, in this process (``_ForceRecord``):
# a World rebuilds its force tables, and a Simulator wakes the edited records' bodies, when it moved
_EDITS = [0]
# fields naming the bodies a record acts on: resolved against the world at ``add_force``
_BODY_FIELDS = frozenset({"body", "body_a", "body_b", "bodies"})


def force_edit_count() -> int:
    """The number of edits of added force records so far in this process."""
    return _EDITS[0]


class _ForceRecord:
    """The force records' base: a field set on a record already added to a world (``World.add_force``)
    is checked as the constructor checks it (InputError, the record as it was) and acts from the
    next step: the world's force tables are rebuilt and the Simulator wakes the record's bodies
    (``f.force = (0, 0, 5)``, ``spring.stiffness = 80``, ``wind.wind = (3, 0, 0)``). Before,
    such a set did nothing until ``World.forces_changed()`` was called. The bodies a record acts
    on are fixed once it is added (remove it and add another)."""

    _edit_stamp: ClassVar[int] = 0  # force_edit_count() at this record's last edit (0: never)

    def __setattr__(self, name, value):
        d = self.__dict__
        if not d.get("_added") or d.get("_checking") or name not in self.__dataclass_fields__:
            object.__setattr__(self, name, value)
            return
        if name in _BODY_FIELDS:
            raise InputError("fixed when the force was added: remove it and add a new one for other bodies", name)
        if name == "rest_length" and value is None:
            raise InputError("a spring takes its length at add_force only: give a length in m", name)
        saved = dict(d)
        object.__setattr__(self, name, value)
        d["_checking"] = True
        try:
            self.__post_init__()  # the constructor's checks, and its normal forms (tuples of floats)
        except InputError:
            d.clear()
            d.update(saved)
            raise
        del d["_checking"]
        _EDITS[0] += 1
        d["_edit_stamp"] = _EDITS[0]


def _nonnegative(value, key):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"expected a number, got {value!r}", key) from None
    if not math.isfinite(v) or v < 0.0:
        raise InputError(f"must be a finite number >= 0, got {v}", key)
    return v


@dataclass
class Drag(_ForceRecord):
    """Drag relative to the air, which moves at ``wind`` (m/s, world).

    Force  F   = -(linear + quadratic |u|) u,           u = v - wind       (N)
    Torque tau = -(angular_linear + angular_quadratic |omega|) omega       (N m)

    Args:
        linear: N s/m. quadratic: N s^2/m^2. angular_linear: N m s.
        angular_quadratic: N m s^2. wind: (3,) m/s, world.
        bodies: bodies (or names) it acts on; None means every moving body.
    """

    linear: float = 0.0
    quadratic: float = 0.0
    angular_linear: float = 0.0
    angular_quadratic: float = 0.0
    wind: Sequence[float] = (0.0, 0.0, 0.0)
    bodies: Sequence[Any] | None = None

    def __post_init__(self):
        for key in ("linear", "quadratic", "angular_linear", "angular_quadratic"):
            setattr(self, key, _nonnegative(getattr(self, key), key))
        self.wind = tuple(finite_vector(self.wind, "wind"))


def Wind(velocity=(0.0, 0.0, 0.0), linear=0.0, quadratic=0.0, bodies=None) -> Drag:
    """Wind: drag relative to air moving at ``velocity`` (m/s, world). A ``Drag`` with a wind."""
    return Drag(linear=linear, quadratic=quadratic, wind=velocity, bodies=bodies)


@dataclass
class Buoyancy(_ForceRecord):
    """A still body of fluid (water) filling the world below a level surface: Archimedes' buoyancy on
    the part of each body under it, and drag there (tumble.buoyancy).

    The surface is the plane at height ``level`` along "up" (-gravity), so it is level whatever
    gravity's direction. On each body it acts on, each step:

    Buoyancy  F_b = density |g| V up, at the centre of buoyancy c (the submerged part's centroid):
              torque (c - x) x F_b                                                   (N, N m)
    Drag      F_d = -f (linear + quadratic |u|) u,  u = v - flow
              tau_d = -f (angular_linear + angular_quadratic |omega|) omega          (N, N m)

    V (m^3) is the volume of the body's shape below the surface, f = V / (its whole volume) the
    submerged fraction. Evaluated once per step, at the pose the body reaches by mid-step at its
    velocities (so the step is position Verlet for it: tumble.buoyancy.buoyancy_kernel), and held
    over the step's substeps.

    Args:
        density: kg/m^3 of the fluid (1000: water).
        level: m, the surface's height along up.
        linear, quadratic, angular_linear, angular_quadratic: the drag coefficients of a body wholly
            under the surface, as ``Drag``'s (N s/m, N s^2/m^2, N m s, N m s^2).
        flow: (3,) m/s, world: the fluid's velocity (a current); drag is relative to it.
        bodies: bodies (or names) it acts on; None: every moving body with a volume.
    """

    density: float = 1000.0
    level: float = 0.0
    linear: float = 0.0
    quadratic: float = 0.0
    angular_linear: float = 0.0
    angular_quadratic: float = 0.0
    flow: Sequence[float] = (0.0, 0.0, 0.0)
    bodies: Sequence[Any] | None = None

    def __post_init__(self):
        for key in ("density", "linear", "quadratic", "angular_linear", "angular_quadratic"):
            setattr(self, key, _nonnegative(getattr(self, key), key))
        try:
            level = float(self.level)
        except (TypeError, ValueError):
            raise InputError(f"expected a number, got {self.level!r}", "level") from None
        if not math.isfinite(level):
            raise InputError(f"must be a finite number, got {level}", "level")
        self.level = level
        self.flow = tuple(finite_vector(self.flow, "flow"))


@dataclass
class Fluid(_ForceRecord):
    """A fluid filling the world, as MuJoCo's inertia-box model (``<option density viscosity wind>``;
    MuJoCo's documentation, "Fluid forces"): Gymnasium's swimmer swims in it.

    Each body it acts on is taken, for the fluid, as its equivalent inertia box: the uniform box of
    its mass m with its principal moments (I0, I1, I2) about its principal axes, of sides
    b0 = sqrt(6 max(I1 + I2 - I0, 1e-15) / m), b1, b2 likewise. With u = the centre of mass's
    velocity relative to the wind and omega the angular velocity, both in the box's axes, the
    force and torque at the centre of mass are, per axis i (j, k the other two):

    viscous (Stokes)   F_i = -3 pi beta d u_i,    tau_i = -pi beta d^3 omega_i,   d = (b0+b1+b2)/3
    quadratic drag     F_i = -1/2 rho b_j b_k |u_i| u_i,
                       tau_i = -rho b_i (b_j^4 + b_k^4) |omega_i| omega_i / 64

    Args:
        density: rho, kg/m^3 (MuJoCo's ``density``; water 1000, the swimmer's 4000).
        viscosity: beta, Pa s (MuJoCo's ``viscosity``; water 0.0009, the swimmer's 0.1).
        wind: (3,) m/s, world: the fluid's velocity.
        bodies: bodies (or names) it acts on; None: every moving body.
        frames: None, or for each of ``bodies`` a (3, 3) rotation whose columns are the box's axes
            in the body's frame. None: the principal axes of the body's inertia (``numpy.linalg.
            eigh``). The quadratic terms are not invariant under a turn of the axes, so a body whose
            moments are equal (a capsule, a cylinder) needs its axes given to meet another engine's:
            ``load_mjcf`` gives MuJoCo's (a single geom's frame, as MuJoCo's compiler takes it).

    The box is made from the body's mass and inertia when the world's force tables are built.
    """

    density: float = 0.0
    viscosity: float = 0.0
    wind: Sequence[float] = (0.0, 0.0, 0.0)
    bodies: Sequence[Any] | None = None
    frames: Sequence[Any] | None = None

    def __post_init__(self):
        for key in ("density", "viscosity"):
            setattr(self, key, _nonnegative(getattr(self, key), key))
        self.wind = tuple(finite_vector(self.wind, "wind"))
        if self.frames is not None:
            if self.bodies is None:
                raise InputError("frames need the bodies they belong to", "frames")
            frames = []
            for k, frame in enumerate(self.frames):
                try:
                    M = np.array(frame, dtype=float).reshape(3, 3)
                except (TypeError, ValueError):
                    raise InputError(f"expected a 3x3 rotation, got {frame!r}", f"frames[{k}]") from None
                if not np.all(np.isfinite(M)) or np.abs(M @ M.T - np.eye(3)).max() > 1e-9 or np.linalg.det(M) < 0:
                    raise InputError("expected a 3x3 rotation (orthonormal, determinant 1)", f"frames[{k}]")
                frames.append(M.tolist())
            if len(frames) != len(self.bodies):
                raise InputError(f"{len(frames)} frames for {len(self.bodies)} bodies", "frames")
            self.frames = frames


def fluid_box(mass: float, inertia_body, frame=None):
    """(sides (3,) m, axes (3, 3)) of a body's equivalent inertia box (``Fluid``): the axes' columns
    in the body frame (``frame``, or the principal axes of ``inertia_body`` (3, 3) kg m^2, body
    frame), the sides from the moments about them and ``mass`` kg."""
    I = np.asarray(inertia_body, dtype=float)
    if frame is None:
        _moments, axes = np.linalg.eigh(0.5 * (I + I.T))
        if np.linalg.det(axes) < 0:
            axes[:, 2] = -axes[:, 2]
    else:
        axes = np.asarray(frame, dtype=float)
    moments = np.array([axes[:, i] @ I @ axes[:, i] for i in range(3)])
    sides = np.array([math.sqrt(max(FLUID_MINVAL, moments[(i + 1) % 3] + moments[(i + 2) % 3] - moments[i])
                                / mass * 6.0) for i in range(3)])
    return sides, axes


@dataclass
class ConstantForce(_ForceRecord):
    """Constant ``force`` (N) through the centre of mass and ``torque`` (N m), both world frame, on ``body``."""

    body: Any
    force: Sequence[float] = (0.0, 0.0, 0.0)
    torque: Sequence[float] = (0.0, 0.0, 0.0)

    def __post_init__(self):
        self.force = tuple(finite_vector(self.force, "force"))
        self.torque = tuple(finite_vector(self.torque, "torque"))


@dataclass
class PointForce(_ForceRecord):
    """Constant ``force`` (N, world) applied at ``point`` (m), giving torque (p - x) x F (Baraff 2001 eq. 2-37).

    ``frame="world"``: the point is fixed in the world (e.g. a thruster's
    target). ``frame="body"``: the point is fixed on the body, given in the
    body frame (centre-of-mass origin), and moves with it.
    """

    body: Any
    force: Sequence[float]
    point: Sequence[float]
    frame: str = "world"

    def __post_init__(self):
        self.force = tuple(finite_vector(self.force, "force"))
        self.point = tuple(finite_vector(self.point, "point"))
        if self.frame not in ("world", "body"):
            raise InputError(f"must be 'world' or 'body', got {self.frame!r}", "frame")


@dataclass
class Spring(_ForceRecord):
    """Damped spring between a point on ``body_a`` and a point on ``body_b`` (or a world anchor).

    Baraff's damped spring: with d = p_a - p_b, l = |d|, u = d / l,
        F_a = -(stiffness (l - rest_length) + damping (v_pa - v_pb) . u) u,  F_b = -F_a,
    applied at p_a and p_b (each giving torque about its body's centre).

    Args:
        body_a: body (or name). anchor_a: (3,) m, body_a's frame (centre-of-mass origin).
        body_b: body (or name), or None for a world anchor.
        anchor_b: (3,) m, body_b's frame, or world coordinates when body_b is None.
        stiffness: N/m, >= 0. damping: N s/m, >= 0.
        rest_length: m, >= 0; None means the distance when the spring is added.
    """

    body_a: Any
    body_b: Any = None
    anchor_a: Sequence[float] = (0.0, 0.0, 0.0)
    anchor_b: Sequence[float] = (0.0, 0.0, 0.0)
    stiffness: float = 0.0
    damping: float = 0.0
    rest_length: float | None = None

    def __post_init__(self):
        self.anchor_a = tuple(finite_vector(self.anchor_a, "anchor_a"))
        self.anchor_b = tuple(finite_vector(self.anchor_b, "anchor_b"))
        self.stiffness = _nonnegative(self.stiffness, "stiffness")
        self.damping = _nonnegative(self.damping, "damping")
        if self.rest_length is not None:
            self.rest_length = _nonnegative(self.rest_length, "rest_length")


@dataclass
class Impulse(_ForceRecord):
    """Instantaneous ``impulse`` (N s, world) on ``body`` at world ``point`` (None: the centre of mass).

    Applied once, before the first step that starts at or after ``time`` (s):
    P += J, L += (p - x) x J.
    """

    body: Any
    impulse: Sequence[float]
    point: Sequence[float] | None = None
    time: float = 0.0

    def __post_init__(self):
        self.impulse = tuple(finite_vector(self.impulse, "impulse"))
        if self.point is not None:
            self.point = tuple(finite_vector(self.point, "point"))
        self.time = _nonnegative(self.time, "time")


@dataclass
class Switch(_ForceRecord):
    """``body`` taken out of the simulation (``enabled=False``) or put back (``True``) at
    ``time`` (s): ``World.set_enabled`` before the first step that starts at or after ``time``,
    once, as an ``Impulse`` is applied. A body that appears later is added with ``enabled=False``
    and given a Switch; one that vanishes, a Switch to False (a part thrown away, a spawn wave).
    Not a force: a record of the run's timeline kept with the impulses (checkpoints, snapshots
    and the scene file's ``enable_at`` / ``disable_at`` keys go through it).
    """

    body: Any
    enabled: bool = True
    time: float = 0.0

    def __post_init__(self):
        if not isinstance(self.enabled, (bool, np.bool_)):
            raise InputError(f"expected true or false, got {self.enabled!r}", "enabled")
        self.enabled = bool(self.enabled)
        self.time = _nonnegative(self.time, "time")


@dataclass
class Explosion(_ForceRecord):
    """A blast at world ``position`` (m) at ``time`` (s): Box2D v3's ``b2World_Explode`` in 3-D.

    Every shape of a dynamic body within ``radius + falloff`` (m) of the centre takes an impulse
    ``impulse_per_area`` (N s / m^2, the blast's pressure impulse; negative: an implosion) times
    the area of its shadow seen from the centre, the area projected along the direction d from
    the centre to the shape's closest point, at that point and along d; ``falloff`` (m) ramps it
    linearly from full at ``radius`` to nothing at ``radius + falloff``. Bodies whose collision
    category does not meet ``mask`` are not touched (the filters' bits, ``tb.CollisionFilter``);
    sensors never. Applied once, before the first step that starts at or after ``time``, as an
    ``Impulse`` is (``tumble.collision.explosion`` gives the rules and the shadow areas).
    ``shaded``: a shape hidden from the centre by other bodies takes only the part of its push
    that the rays from the centre to a few of its points let through (Box2D's blast is not shaded:
    the default).
    """

    position: Sequence[float]
    radius: float
    impulse_per_area: float
    falloff: float = 0.0
    time: float = 0.0
    mask: int = 0xFFFFFFFF
    shaded: bool = False

    def __post_init__(self):
        from .collision.filter import ALL_CATEGORIES, _int

        self.position = tuple(finite_vector(self.position, "position"))
        self.radius = _nonnegative(self.radius, "radius")
        self.falloff = _nonnegative(self.falloff, "falloff")
        if self.radius + self.falloff <= 0.0:
            raise InputError("radius + falloff must be positive (the blast reaches nothing)", "radius")
        try:
            impulse = float(self.impulse_per_area)
        except (TypeError, ValueError):
            raise InputError(f"expected a number, got {self.impulse_per_area!r}", "impulse_per_area") from None
        if not math.isfinite(impulse):
            raise InputError(f"must be a finite number, got {impulse}", "impulse_per_area")
        self.impulse_per_area = impulse
        self.time = _nonnegative(self.time, "time")
        self.mask = _int(self.mask, "mask", 0, ALL_CATEGORIES)
        if not isinstance(self.shaded, (bool, np.bool_)):
            raise InputError(f"expected true or false, got {self.shaded!r}", "shaded")
        self.shaded = bool(self.shaded)


@dataclass
class CustomForce(_ForceRecord):
    """A user Python function adding force and torque (slow path: called every stage).

    ``function(t, body) -> (force (3,), torque (3,))`` in N and N m, world
    frame, torque about the centre of mass. ``body`` has read-only attributes
    ``x, R, q, P, L, v, omega, mass`` for the state being evaluated (so it is
    right inside Runge-Kutta stages). ``bodies=None`` means every moving body.
    """

    function: Callable
    bodies: Sequence[Any] | None = None

    def __post_init__(self):
        if not callable(self.function):
            raise InputError(f"must be callable, got {self.function!r}", "function")


FORCE_TYPES = {
    "drag": Drag,
    "wind": Wind,
    "constant": ConstantForce,
    "point": PointForce,
    "spring": Spring,
    "impulse": Impulse,
    "explosion": Explosion,
}


@dataclass
class ForceTables:
    """Flat arrays the kernels read. U unary rows, S springs; N bodies.

    uforce_kind: (U,) int64 kind ids. uforce_param: (U, UFORCE_PARAMS = 12) parameters:
      drag [linear, quadratic, angular_linear, angular_quadratic, wind xyz];
      constant [F xyz, tau xyz]; point [F xyz, p xyz];
      fluid [box sides (3,) m, density, viscosity, wind xyz, the box's axes in the body frame as a
      unit quaternion (w, x, y, z)];
      damping [c m (kg/s), c_angular (1/s), Ibody (9,) row-major, kg m^2]: F = -c m v,
      tau = -c_angular R Ibody R^T omega (= -c_angular L) (``World.set_damping``).
    uforce_start: (N+1,) int64: rows of body i are uforce_start[i]:uforce_start[i+1].
    spring_body: (S, 2) int64 (-1: world). spring_anchor: (S, 2, 3) m.
    spring_param: (S, 3) [stiffness, damping, rest_length].
    """

    uforce_kind: np.ndarray
    uforce_param: np.ndarray
    uforce_start: np.ndarray
    spring_body: np.ndarray
    spring_anchor: np.ndarray
    spring_param: np.ndarray
    custom: list = field(default_factory=list)  # (CustomForce, body index array)
    # (Buoyancy, body index array, uforce row array): constant rows that tumble.buoyancy fills each step
    buoyancy: list = field(default_factory=list)


def build_force_tables(forces, body_count: int, moving: np.ndarray, resolve, mass=None,
                       inertia_body=None, disabled=None, gravity=None, gravity_scale=None,
                       damping=None) -> ForceTables:
    """Turn force records into ``ForceTables``.

    Args:
        forces: the records, in the order they were added.
        body_count: N.
        moving: (N,) bool, False for fixed bodies (they get no forces).
        resolve: function mapping a body, a name or an index to an index.
        mass: (N,) kg and inertia_body: (N, 3, 3) kg m^2, body frame: ``Fluid``'s boxes (needed
            only with a Fluid).
        disabled: (N,) bool or None: the bodies out of the simulation (``World.set_enabled``):
            a spring with a disabled end pulls nothing (the other forces act on moving bodies
            only, which a disabled body is not).
        gravity: (3,) m/s^2 and gravity_scale: (N,) or None: a moving body whose scale s is not 1
            gets a constant row (s - 1) m g first among its rows (``World.set_gravity_scale``:
            the kernels apply m g to every moving body, so the body feels s m g in all).
        damping: (N, 2) 1/s or None: a moving body's linear and angular damping rates (c, c_a), a
            row F = -c m v, tau = -c_a L after the gravity scale's (``World.set_damping``).
    """
    rows = []  # (body, order, kind, params[, the Buoyancy record that fills the row])
    springs = []
    custom = []
    all_moving = np.flatnonzero(moving)
    if gravity_scale is not None:
        g = np.asarray(gravity, dtype=float)
        for i in np.flatnonzero(moving & (gravity_scale != 1.0)):
            # order -1: before the user's records; (s - 1) m g, so that s = 0 cancels m g exactly
            rows.append((int(i), -1, UFORCE_CONSTANT, [*((gravity_scale[i] - 1.0) * mass[i] * g), 0.0, 0.0, 0.0]))
    if damping is not None:
        for i in np.flatnonzero(moving & np.any(damping != 0.0, axis=1)):
            rows.append((int(i), -1, UFORCE_DAMPING, [float(damping[i, 0] * mass[i]), float(damping[i, 1]),
                                                      *np.asarray(inertia_body[i], dtype=float).ravel()]))
    for order, f in enumerate(forces):
        if isinstance(f, Drag):
            targets = all_moving if f.bodies is None else [resolve(b) for b in f.bodies]
            params = [f.linear, f.quadratic, f.angular_linear, f.angular_quadratic, *f.wind]
            rows += [(int(i), order, UFORCE_DRAG, params) for i in targets]
        elif isinstance(f, Fluid):
            targets = all_moving if f.bodies is None else [resolve(b) for b in f.bodies]
            for k, i in enumerate(targets):
                i = int(i)
                if not moving[i] or mass[i] <= 0.0:
                    continue
                sides, axes = fluid_box(float(mass[i]), inertia_body[i], None if f.frames is None else f.frames[k])
                q = matrix_to_quat(np.ascontiguousarray(axes))
                rows.append((i, order, UFORCE_FLUID, [*sides, f.density, f.viscosity, *f.wind, *q]))
        elif isinstance(f, ConstantForce):
            rows.append((resolve(f.body), order, UFORCE_CONSTANT, [*f.force, *f.torque]))
        elif isinstance(f, PointForce):
            kind = UFORCE_POINT_WORLD if f.frame == "world" else UFORCE_POINT_BODY
            rows.append((resolve(f.body), order, kind, [*f.force, *f.point]))
        elif isinstance(f, Spring):
            a = resolve(f.body_a)
            b = -1 if f.body_b is None else resolve(f.body_b)
            if disabled is not None and (disabled[a] or (b >= 0 and disabled[b])):
                continue
            springs.append((a, b, f.anchor_a, f.anchor_b, [f.stiffness, f.damping, f.rest_length]))
        elif isinstance(f, Buoyancy):
            targets = all_moving if f.bodies is None else [resolve(b) for b in f.bodies]
            rows += [(int(i), order, UFORCE_CONSTANT, [0.0] * 6, f) for i in targets]
        elif isinstance(f, CustomForce):
            targets = all_moving if f.bodies is None else np.array([resolve(b) for b in f.bodies], dtype=np.int64)
            custom.append((f, np.asarray(targets, dtype=np.int64)))
        elif isinstance(f, (Impulse, Explosion, Switch)):
            continue  # applied by the simulator between steps
        else:
            raise InputError(f"unknown force record {f!r}", "forces")
    rows = [r for r in rows if moving[r[0]]]
    # Sort by body, then by the order the user added the generators: a body's
    # force is summed in that fixed order, so results are reproducible.
    rows.sort(key=lambda r: (r[0], r[1]))
    U = len(rows)
    kind = np.array([r[2] for r in rows], dtype=np.int64)
    param = np.zeros((U, UFORCE_PARAMS))
    for k, r in enumerate(rows):
        param[k, : len(r[3])] = r[3]
    counts = np.bincount(np.array([r[0] for r in rows], dtype=np.int64), minlength=body_count) if U else np.zeros(body_count, np.int64)
    start = np.zeros(body_count + 1, dtype=np.int64)
    start[1:] = np.cumsum(counts)
    buoyancy = []
    for f in forces:
        if isinstance(f, Buoyancy):
            mine = [k for k, r in enumerate(rows) if len(r) > 4 and r[4] is f]
            buoyancy.append((f, np.array([rows[k][0] for k in mine], dtype=np.int64), np.array(mine, dtype=np.int64)))
    S = len(springs)
    spring_body = np.array([[s[0], s[1]] for s in springs], dtype=np.int64).reshape(S, 2)
    spring_anchor = np.array([[s[2], s[3]] for s in springs], dtype=float).reshape(S, 2, 3)
    spring_param = np.array([s[4] for s in springs], dtype=float).reshape(S, 3)
    return ForceTables(kind, param, start, spring_body, spring_anchor, spring_param, custom, buoyancy)
