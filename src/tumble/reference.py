"""The course's rigid-body algorithm, literally, one body at a time, in plain Python.

This is the readable oracle the fast engine is tested against (DESIGN.md,
"two layers"; STYLE 5.6 rule 9). It follows the slides of the course in
``course/`` (after Baraff, SIGGRAPH 2001 "Rigid Body Simulation") step by step:

* Algorithm 1  ``RigidBody``: constants, state, derived and computed quantities;
* Algorithm 2  ``STATE_SIZE = 18`` numbers a body (ERRATA 6);
* Algorithm 3/4 ``compute_force_and_torque``, ``ddt_state_to_array``, ``dxdt``;
* Step 3        ``solve``: explicit Euler ``X(t + h) = X(t) + h dX/dt``;
* Algorithm 5  ``run_simulation``, as corrected by ERRATA 3 (one solve a frame).

and the corrections of ``course/ERRATA.md`` (star matrix, outer product,
simulation loop, re-orthonormalising R). Slow by design: loops are Python
loops, vectors are NumPy (3,) arrays and only 3x3 products use NumPy's ``@``.
Dot products are written out (``_dot``) so that their rounding is the plain
``a0 b0 + a1 b1 + a2 b2`` a compiled kernel does, not a BLAS reduction.

Units are SI, vectors are world-frame unless a name says ``_b``/body, and
``R`` maps body to world (its columns are the body axes, course "Espaces
objet et monde").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from .errors import InputError
from .forces import ConstantForce, CustomForce, Drag, Fluid, Impulse, PointForce, Spring, fluid_box

# Algorithm 2: "#define StateSize 18" = x (3) + R (9) + P (3) + L (3) (ERRATA 6).
STATE_SIZE = 18
# Offsets of each quantity inside one body's block of the state array.
_X, _R, _P, _L = slice(0, 3), slice(3, 12), slice(12, 15), slice(15, 18)
# A float ratio is "an integer" when it is this close to one (steps, frames).
_INTEGER_TOLERANCE = 1e-9


def _vec(value) -> np.ndarray:
    return np.array(value, dtype=float).reshape(3)


def _mat(value) -> np.ndarray:
    return np.array(value, dtype=float).reshape(3, 3)


def _dot(a, b) -> float:
    """a . b for (3,) vectors, summed left to right."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


# --------------------------------------------------------------------------- Algorithm 1


@dataclass(eq=False)
class RigidBody:
    """One rigid body: the fields of the course's Algorithm 1 ("struct RigidBody").

    Constants:
        mass: M, kg. Ibody: (3, 3) inertia tensor in the body frame, kg m^2.
        Ibodyinv: (3, 3) its inverse; computed from Ibody when not given.
    State (the 18 numbers of ERRATA 6):
        x: (3,) centre of mass, world, m. R: (3, 3) body-to-world rotation.
        P: (3,) linear momentum, world, kg m/s. L: (3,) angular momentum about
        the centre of mass, world, kg m^2/s.
    Derived (``compute_derived``, course "Equation du mouvement"):
        Iinv = R Ibodyinv R^T (3, 3); v = P / M (3,), m/s; omega = Iinv L (3,), rad/s.
    Computed (``compute_force_and_torque``):
        force: (3,) N, world. torque: (3,) N m, world, about the centre of mass.
    Not in the course:
        name: used by force records to refer to the body.
        fixed: infinite mass and inertia. The body never moves: v, omega, Iinv
        are zero, it receives no force and its state derivative is zero.
    """

    mass: float = 1.0
    Ibody: np.ndarray = field(default_factory=lambda: np.eye(3))
    Ibodyinv: np.ndarray | None = None
    x: np.ndarray = field(default_factory=lambda: np.zeros(3))
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    P: np.ndarray = field(default_factory=lambda: np.zeros(3))
    L: np.ndarray = field(default_factory=lambda: np.zeros(3))
    Iinv: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    v: np.ndarray = field(default_factory=lambda: np.zeros(3))
    omega: np.ndarray = field(default_factory=lambda: np.zeros(3))
    force: np.ndarray = field(default_factory=lambda: np.zeros(3))
    torque: np.ndarray = field(default_factory=lambda: np.zeros(3))
    name: str = ""
    fixed: bool = False

    def __post_init__(self):
        self.mass = float(self.mass)
        self.Ibody = _mat(self.Ibody)
        if self.Ibodyinv is None:
            # A fixed body's inertia is infinite: its inverse is zero.
            self.Ibodyinv = np.zeros((3, 3)) if self.fixed else np.linalg.inv(self.Ibody)
        self.Ibodyinv = _mat(self.Ibodyinv)
        self.x, self.P, self.L = _vec(self.x), _vec(self.P), _vec(self.L)
        self.R = _mat(self.R)
        self.force, self.torque = _vec(self.force), _vec(self.torque)
        self.compute_derived()

    def compute_derived(self) -> None:
        """v = P / M, Iinv = R Ibodyinv R^T, omega = Iinv L (course "Calcul de dX/dt", step 2)."""
        if self.fixed:
            self.v, self.Iinv, self.omega = np.zeros(3), np.zeros((3, 3)), np.zeros(3)
            return
        self.v = self.P / self.mass
        self.Iinv = self.R @ self.Ibodyinv @ self.R.T
        self.omega = self.Iinv @ self.L

    @property
    def q(self) -> np.ndarray:
        """(4,) unit quaternion (w, x, y, z), w >= 0, of R (for ``CustomForce`` callbacks)."""
        return matrix_to_quaternion(self.R)


def matrix_to_quaternion(R) -> np.ndarray:
    """Unit quaternion (4,) (w, x, y, z) with w >= 0 of a rotation matrix R (3, 3).

    Shepperd's method (the same arithmetic as ``tumble.math3d.matrix_to_quat``):
    divide by the largest of the four components, so every rotation is accurate.
    """
    t = R[0, 0] + R[1, 1] + R[2, 2]
    if t >= R[0, 0] and t >= R[1, 1] and t >= R[2, 2]:
        s = math.sqrt(1.0 + t) * 2.0
        q = [0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif R[0, 0] >= R[1, 1] and R[0, 0] >= R[2, 2]:
        s = math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2]) * 2.0
        q = [(R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif R[1, 1] >= R[2, 2]:
        s = math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2]) * 2.0
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s]
    else:
        s = math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1]) * 2.0
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s]
    n = math.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2)
    sign = -1.0 if q[0] < 0.0 else 1.0
    return np.array([sign * c / n for c in q])


# --------------------------------------------------------------------------- the star matrix


def star(a) -> np.ndarray:
    """The matrix a* of the cross product: ``star(a) @ b == cross(a, b)`` (course "dR/dt = omega* R").

    ERRATA 1: the slide prints ``[[0,-az,-ay],[-az,0,-ax],[-ay,-ax,0]]`` and calls
    it ``-(a x)``; that matrix is symmetric, and no symmetric matrix is a cross
    product. The correct one is skew-symmetric (Baraff 2001 eq. 2-8).

    Args:
        a: (3,) vector.
    Returns:
        (3, 3) skew-symmetric matrix.
    """
    return np.array([
        [0.0, -a[2], a[1]],
        [a[2], 0.0, -a[0]],
        [-a[1], a[0], 0.0],
    ])


# --------------------------------------------------------------------------- state <-> bodies


def state_to_array(body: RigidBody, y: np.ndarray) -> None:
    """Write one body's state (x, R row-major, P, L) into ``y`` (18,) (course "StateToArray")."""
    y[_X] = body.x
    y[_R] = body.R.reshape(9)  # row-major: R[0,0], R[0,1], R[0,2], R[1,0], ...
    y[_P] = body.P
    y[_L] = body.L


def array_to_state(body: RigidBody, y: np.ndarray) -> None:
    """Copy ``y`` (18,) into one body's x, R, P, L and compute v, Iinv, omega (course "ArrayToState")."""
    body.x = y[_X].copy()
    body.R = y[_R].reshape(3, 3).copy()
    body.P = y[_P].copy()
    body.L = y[_L].copy()
    body.compute_derived()


def bodies_to_array(bodies: Sequence[RigidBody]) -> np.ndarray:
    """The state vector X of all bodies (Algorithm 5 "BodiesToArray", ERRATA 6).

    Returns:
        (18 N,) float array: per body, in order, x (3), R (9, row-major), P (3), L (3).
    """
    y = np.empty(STATE_SIZE * len(bodies))
    for i, body in enumerate(bodies):
        state_to_array(body, y[i * STATE_SIZE:(i + 1) * STATE_SIZE])
    return y


def array_to_bodies(y: np.ndarray, bodies: Sequence[RigidBody]) -> None:
    """Copy the state vector into the bodies and compute their derived quantities (Algorithm 4 "ArrayToBodies").

    Args:
        y: (18 N,) state vector, layout of ``bodies_to_array``.
        bodies: the N bodies, updated in place (x, R, P, L, then v, Iinv, omega).
    """
    y = np.asarray(y, dtype=float)
    if y.shape != (STATE_SIZE * len(bodies),):
        raise ValueError(f"state has shape {y.shape}, expected ({STATE_SIZE * len(bodies)},)")
    for i, body in enumerate(bodies):
        array_to_state(body, y[i * STATE_SIZE:(i + 1) * STATE_SIZE])


# --------------------------------------------------------------------------- forces (Algorithm 3)


def resolve_body(ref, bodies: Sequence[RigidBody]) -> int:
    """Index into ``bodies`` of a force record's body reference: a RigidBody, an int index or a name."""
    if isinstance(ref, RigidBody):
        for i, body in enumerate(bodies):
            if body is ref:
                return i
        raise InputError(f"body {ref.name or ref!r} is not among the simulated bodies", "body")
    if isinstance(ref, (int, np.integer)) and not isinstance(ref, bool):
        if not 0 <= ref < len(bodies):
            raise InputError(f"body index {ref} out of range 0..{len(bodies) - 1}", "body")
        return int(ref)
    if isinstance(ref, str):
        matches = [i for i, body in enumerate(bodies) if body.name == ref]
        if len(matches) != 1:
            problem = "no body" if not matches else f"{len(matches)} bodies"
            raise InputError(f"{problem} named {ref!r}", "body")
        return matches[0]
    raise InputError(f"expected a body, an index or a name, got {ref!r}", "body")


def _targets(record_bodies, bodies) -> list[int]:
    """Indices a Drag/CustomForce acts on: None means every moving body; repeats count twice, as in the engine's tables."""
    if record_bodies is None:
        return [i for i, body in enumerate(bodies) if not body.fixed]
    return [resolve_body(b, bodies) for b in record_bodies]


def _world_point(body: RigidBody, p_body) -> np.ndarray:
    """p = R p_b + x: a point fixed in the body frame, in world coordinates (course "Espaces objet et monde")."""
    return body.R @ _vec(p_body) + body.x


def _point_velocity(body: RigidBody, p) -> np.ndarray:
    """Velocity of the body's material point at world p: v + omega x (p - x) (course "Vitesse d'une particule")."""
    return body.v + np.cross(body.omega, p - body.x)


def spring_points(spring: Spring, bodies: Sequence[RigidBody]):
    """World attachment points and their velocities of a spring: (p_a, p_b, v_pa, v_pb), each (3,).

    body_b None: anchor_b is a world point with zero velocity.
    """
    a = bodies[resolve_body(spring.body_a, bodies)]
    p_a = _world_point(a, spring.anchor_a)
    v_pa = _point_velocity(a, p_a)
    if spring.body_b is None:
        p_b, v_pb = _vec(spring.anchor_b), np.zeros(3)
    else:
        b = bodies[resolve_body(spring.body_b, bodies)]
        p_b = _world_point(b, spring.anchor_b)
        v_pb = _point_velocity(b, p_b)
    return p_a, p_b, v_pa, v_pb


def spring_force(spring: Spring, bodies: Sequence[RigidBody]):
    """Damped spring force on body_a (forces.Spring docstring, Baraff 2001 "Particle dynamics" §4).

    d = p_a - p_b, l = |d|, u = d / l,
    F_a = -(k (l - l0) + c (v_pa - v_pb) . u) u; body_b gets -F_a.

    Returns:
        (F_a (3,) N, p_a (3,) m, p_b (3,) m), world. When l == 0 the direction
        is undefined and F_a is zero.
    """
    if spring.rest_length is None:
        raise ValueError("Spring.rest_length is None: resolve it (the distance when added) before simulating")
    p_a, p_b, v_pa, v_pb = spring_points(spring, bodies)
    d = p_a - p_b
    l = math.sqrt(_dot(d, d))
    if l == 0.0:
        return np.zeros(3), p_a, p_b
    u = d / l
    vrel = v_pa - v_pb
    F_a = -(spring.stiffness * (l - spring.rest_length) + spring.damping * _dot(vrel, u)) * u
    return F_a, p_a, p_b


def fluid_force(fluid: Fluid, body: RigidBody, frame=None):
    """(F, tau) (3,) N, N m, world, at the centre of mass: ``Fluid`` (MuJoCo's inertia-box model) on
    one body, written with matrices: the box's axes E = R A (A its axes in the body frame), the
    velocities in them, the per-axis terms of ``Fluid``'s docstring, and back to the world."""
    sides, A = fluid_box(body.mass, body.Ibody, frame)
    E = body.R @ A
    u = E.T @ (body.v - _vec(fluid.wind))
    w = E.T @ body.omega
    d = sides.mean()
    rho, beta = fluid.density, fluid.viscosity
    area = np.array([sides[1] * sides[2], sides[0] * sides[2], sides[0] * sides[1]])
    fourth = sides**4
    arm = np.array([sides[0] * (fourth[1] + fourth[2]), sides[1] * (fourth[0] + fourth[2]),
                    sides[2] * (fourth[0] + fourth[1])])
    f = -3.0 * math.pi * d * beta * u - 0.5 * rho * area * np.abs(u) * u
    t = -math.pi * d**3 * beta * w - rho * arm * np.abs(w) * w / 64.0
    return E @ f, E @ t


def compute_force_and_torque(t: float, body: RigidBody, bodies: Sequence[RigidBody], forces, gravity) -> None:
    """Sum the force and torque on ONE body (Algorithm 3 "ComputeForceAndTorque"; Baraff 2001 §2.7).

    F = sum F_i, tau = sum (p_i - x) x F_i (course "Moment de la force"),
    added in a fixed order: gravity M g first, then the records of ``forces``
    in the order given (the engine sums a body's forces in the same order).

    Args:
        t: time, s (passed to CustomForce functions).
        body: the body, one of ``bodies``; its derived quantities must be current
            (call ``array_to_bodies`` first). Writes body.force, body.torque.
        bodies: all bodies (records refer to them by object, index or name).
        forces: records of ``tumble.forces``. Impulse records are skipped here
            (``run_simulation`` applies them between steps).
        gravity: (3,) m/s^2, world.
    """
    F = np.zeros(3)
    tau = np.zeros(3)
    if body.fixed:
        body.force, body.torque = F, tau
        return
    me = resolve_body(body, bodies)
    F = F + body.mass * _vec(gravity)
    for f in forces:
        if isinstance(f, Drag):
            u = body.v - _vec(f.wind)
            omega = body.omega
            for i in _targets(f.bodies, bodies):
                if i == me:
                    F = F + -(f.linear + f.quadratic * math.sqrt(_dot(u, u))) * u
                    tau = tau + -(f.angular_linear + f.angular_quadratic * math.sqrt(_dot(omega, omega))) * omega
        elif isinstance(f, Fluid):
            for k, i in enumerate(_targets(f.bodies, bodies)):
                if i == me:
                    Fi, taui = fluid_force(f, body, None if f.frames is None else f.frames[k])
                    F = F + Fi
                    tau = tau + taui
        elif isinstance(f, ConstantForce):
            if resolve_body(f.body, bodies) == me:
                F = F + _vec(f.force)
                tau = tau + _vec(f.torque)
        elif isinstance(f, PointForce):
            if resolve_body(f.body, bodies) == me:
                p = _vec(f.point) if f.frame == "world" else _world_point(body, f.point)
                Fi = _vec(f.force)
                F = F + Fi
                tau = tau + np.cross(p - body.x, Fi)
        elif isinstance(f, Spring):
            a = resolve_body(f.body_a, bodies)
            b = None if f.body_b is None else resolve_body(f.body_b, bodies)
            if me == a or me == b:
                F_a, p_a, p_b = spring_force(f, bodies)
                if me == a:
                    F = F + F_a
                    tau = tau + np.cross(p_a - body.x, F_a)
                if me == b:
                    F = F + -F_a
                    tau = tau + np.cross(p_b - body.x, -F_a)
        elif isinstance(f, CustomForce):
            for i in _targets(f.bodies, bodies):
                if i == me:
                    Fi, taui = f.function(t, body)
                    F = F + _vec(Fi)
                    tau = tau + _vec(taui)
        elif isinstance(f, Impulse):
            continue
        else:
            raise InputError(f"unknown force record {f!r}", "forces")
    body.force, body.torque = F, tau


# --------------------------------------------------------------------------- dX/dt (Algorithm 4)


def ddt_state_to_array(body: RigidBody, ydot: np.ndarray) -> None:
    """Write dX/dt = (v, omega* R, F, tau) of one body into ``ydot`` (18,) (Algorithm 3 "DdtStateToArray").

    dR/dt = star(omega) R (ERRATA 1), stored row-major like R. A fixed body's derivative is zero.
    """
    if body.fixed:
        ydot[:] = 0.0
        return
    ydot[_X] = body.v
    ydot[_R] = (star(body.omega) @ body.R).reshape(9)
    ydot[_P] = body.force
    ydot[_L] = body.torque


def dxdt(t: float, y: np.ndarray, bodies: Sequence[RigidBody], forces, gravity) -> np.ndarray:
    """dX/dt of all bodies (Algorithm 4 "Dxdt").

    ArrayToBodies(y); then for each body ComputeForceAndTorque and DdtStateToArray.

    Args:
        t: time, s. y: (18 N,) state vector. bodies: the N bodies (overwritten
        with the state y, as the course's global ``Bodies`` array is).
        forces: force records. gravity: (3,) m/s^2.
    Returns:
        (18 N,) derivative, per body (v, omega* R row-major, F, tau).
    """
    array_to_bodies(y, bodies)
    ydot = np.empty(STATE_SIZE * len(bodies))
    for i, body in enumerate(bodies):
        compute_force_and_torque(t, body, bodies, forces, gravity)
        ddt_state_to_array(body, ydot[i * STATE_SIZE:(i + 1) * STATE_SIZE])
    return ydot


# --------------------------------------------------------------------------- solve (step 3)


def orthonormalize(R) -> np.ndarray:
    """Gram-Schmidt on the COLUMNS of R (3, 3); returns a new (3, 3) rotation (ERRATA 5).

    The columns are the body axes (course "R(t) = [x' y' z']"): axis x keeps its
    direction, y loses its component along x, z = x cross y (right-handed).
    Same arithmetic as ``tumble.math3d.orthonormalize_inplace``.
    """
    R = _mat(R)
    c0, c1 = R[:, 0], R[:, 1]
    a = c0 / math.sqrt(c0[0] ** 2 + c0[1] ** 2 + c0[2] ** 2)
    d = _dot(a, c1)
    b = c1 - d * a
    b = b / math.sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2])
    c = np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])
    return np.column_stack([a, b, c])


def orthonormalize_state(y: np.ndarray, bodies: Sequence[RigidBody] | None = None) -> None:
    """Re-orthonormalise every body's R in the state vector y (18 N,), in place (ERRATA 5).

    Fixed bodies (when ``bodies`` is given) are left untouched: they never move.
    """
    for i in range(len(y) // STATE_SIZE):
        if bodies is not None and bodies[i].fixed:
            continue
        block = y[i * STATE_SIZE:(i + 1) * STATE_SIZE]
        block[_R] = orthonormalize(block[_R].reshape(3, 3)).reshape(9)


def euler_step(y: np.ndarray, t: float, h: float, dxdt_fn: Callable, orthonormalize_R=True, bodies=None) -> np.ndarray:
    """One explicit Euler step X(t + h) = X(t) + h dX/dt(t, X) (course step 3); returns a new (18 N,) array."""
    y_new = y + h * dxdt_fn(t, y)
    if orthonormalize_R:
        orthonormalize_state(y_new, bodies)
    return y_new


def _whole_ratio(num: float, den: float, what: str) -> int:
    ratio = num / den
    n = round(ratio)
    if abs(ratio - n) > _INTEGER_TOLERANCE:
        raise ValueError(f"{what}: {num!r} / {den!r} = {ratio!r} is not an integer")
    return n


def solve(y0, t0: float, t1: float, dxdt_fn: Callable, h: float, orthonormalize_R: bool = True, bodies=None) -> np.ndarray:
    """Integrate from t0 to t1 with explicit Euler substeps of h (course step 3, "solve").

    X(t + h) = X(t) + h dX/dt. With ``orthonormalize_R`` each body's R is
    re-orthonormalised after each substep (ERRATA 5); with False this is the
    course-literal scheme, whose R drifts off SO(3).

    Args:
        y0: (18 N,) state at t0 (not modified).
        t0, t1: s. (t1 - t0) / h must be an integer (within 1e-9) or ValueError.
        dxdt_fn: f(t, y) -> (18 N,) derivative, e.g. ``lambda t, y: dxdt(t, y, bodies, forces, g)``.
        h: substep, s, > 0. Substep i is evaluated at t = t0 + i h.
        bodies: optional; fixed bodies' R are then not re-orthonormalised.
    Returns:
        (18 N,) state at t1.
    """
    if not h > 0.0:
        raise ValueError(f"h must be > 0, got {h!r}")
    steps = _whole_ratio(t1 - t0, h, "solve: (t1 - t0) / h")
    if steps < 0:
        raise ValueError(f"solve: t1 = {t1!r} < t0 = {t0!r}")
    y = np.array(y0, dtype=float)
    for i in range(steps):
        y = euler_step(y, t0 + i * h, h, dxdt_fn, orthonormalize_R, bodies)
    return y


# --------------------------------------------------------------------------- Algorithm 5


def apply_impulse(y: np.ndarray, impulse: Impulse, bodies: Sequence[RigidBody]) -> None:
    """P += J, L += (p - x) x J on the impulse's body, in the state vector y (18 N,), in place.

    p is ``impulse.point`` (world) or the centre of mass x when None. Fixed bodies ignore impulses.
    """
    i = resolve_body(impulse.body, bodies)
    if bodies[i].fixed:
        return
    block = y[i * STATE_SIZE:(i + 1) * STATE_SIZE]
    J = _vec(impulse.impulse)
    x = block[_X].copy()
    p = x if impulse.point is None else _vec(impulse.point)
    block[_P] = block[_P] + J
    block[_L] = block[_L] + np.cross(p - x, J)


def run_simulation(bodies: Sequence[RigidBody], forces, gravity, duration: float, dt: float,
                   frame_rate: float = 24, impulses=(), orthonormalize_R: bool = True):
    """The simulation loop: Algorithm 5 as corrected by ERRATA 3.

    Each frame: copy the whole state, call ``solve`` once from t to
    t + 1/frame_rate with substeps dt, then "display" (record the state and
    copy it into ``bodies``). The loop runs over global steps k of size dt
    (derivative evaluated at t = k dt), which is the same arithmetic as one
    ``solve`` per frame; a frame is recorded every 1/(frame_rate dt) steps.

    Impulses (the ``impulses`` argument and any Impulse records in ``forces``,
    in that order) are applied at the start of global step
    k = ceil(time / dt - 1e-9), before its derivative is evaluated, so a frame
    recorded at time T shows the state before impulses at T. Impulses due at
    or after the last step never apply.

    Args:
        bodies: the N bodies, initial state; left holding the final state.
        forces: force records. gravity: (3,) m/s^2.
        duration: s; frames at k / frame_rate for k = 0 .. floor(duration frame_rate).
        dt: internal step, s; 1 / frame_rate must be an integer multiple of it (within 1e-9).
        frame_rate: frames per second (the course's 24).
        orthonormalize_R: re-orthonormalise R after each step (ERRATA 5).
    Returns:
        times (F,) s, and states (F, 18 N); frame 0 is the initial state at t = 0.
    """
    if not dt > 0.0 or not frame_rate > 0 or not duration >= 0.0:
        raise ValueError(f"need dt > 0, frame_rate > 0, duration >= 0; got {dt!r}, {frame_rate!r}, {duration!r}")
    steps_per_frame = _whole_ratio(1.0 / frame_rate, dt, "run_simulation: (1 / frame_rate) / dt")
    if steps_per_frame < 1:
        raise ValueError(f"run_simulation: dt = {dt!r} is longer than a frame")
    frame_count = math.floor(duration * frame_rate + _INTEGER_TOLERANCE) + 1
    step_count = (frame_count - 1) * steps_per_frame

    pending = list(impulses) + [f for f in forces if isinstance(f, Impulse) and not any(f is g for g in impulses)]
    due = {}
    for imp in pending:  # stable: impulses due at the same step keep their order
        due.setdefault(math.ceil(imp.time / dt - _INTEGER_TOLERANCE), []).append(imp)

    def derivative(t, y):
        return dxdt(t, y, bodies, forces, gravity)

    y = bodies_to_array(bodies)
    times = np.arange(frame_count) / frame_rate
    states = np.empty((frame_count, y.size))
    states[0] = y
    for k in range(step_count):
        for imp in due.get(k, ()):
            apply_impulse(y, imp, bodies)
        y = euler_step(y, k * dt, dt, derivative, orthonormalize_R, bodies)
        if (k + 1) % steps_per_frame == 0:
            states[(k + 1) // steps_per_frame] = y  # "DisplayBodies"
    array_to_bodies(y, bodies)
    return times, states


# --------------------------------------------------------------------------- energy


def kinetic_energy(bodies: Sequence[RigidBody]) -> float:
    """Sum over bodies of 1/2 P.v + 1/2 L.omega, J (derived quantities must be current)."""
    total = 0.0
    for body in bodies:
        if not body.fixed:
            total += 0.5 * _dot(body.P, body.v) + 0.5 * _dot(body.L, body.omega)
    return total


def potential_energy(bodies: Sequence[RigidBody], forces, gravity) -> float:
    """-M g.x summed over moving bodies, plus 1/2 k (l - l0)^2 for each spring, J."""
    g = _vec(gravity)
    total = 0.0
    for body in bodies:
        if not body.fixed:
            total += -body.mass * _dot(g, body.x)
    for f in forces:
        if isinstance(f, Spring):
            if f.rest_length is None:
                raise ValueError("Spring.rest_length is None: resolve it before computing energy")
            p_a, p_b, _, _ = spring_points(f, bodies)
            d = p_a - p_b
            stretch = math.sqrt(_dot(d, d)) - f.rest_length
            total += 0.5 * f.stiffness * stretch * stretch
    return total


def energy(bodies: Sequence[RigidBody], forces, gravity) -> tuple[float, float]:
    """(kinetic, potential) energy of the bodies' current state, J."""
    return kinetic_energy(bodies), potential_energy(bodies, forces, gravity)


# --------------------------------------------------------------------------- mass properties


def body_from_particles(masses, points):
    """Mass properties of the course's body discretised into particles ("Discrétisation").

    M = sum m_i; centre c = sum m_i r_i / M; with r0_i = r_i - c,
    Ibody = sum m_i ((r0_i^T r0_i) 1 - r0_i r0_i^T). ERRATA 2: the outer product
    r0 r0^T has entries r_i r_j (the slide prints its off-diagonals negative);
    the minus sign of the formula makes the products of inertia negative.

    Args:
        masses: (n,) kg. points: (n, 3) m, in the body's modelling frame.
    Returns:
        (mass kg, center (3,) m, Ibody (3, 3) kg m^2 about the centre, body axes).
    """
    masses = np.asarray(masses, dtype=float).reshape(-1)
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    if masses.size != points.shape[0] or masses.size == 0:
        raise ValueError(f"need as many masses as points (>= 1); got {masses.size} and {points.shape[0]}")
    M = 0.0
    weighted = np.zeros(3)
    for m, r in zip(masses, points):
        M += m
        weighted = weighted + m * r
    center = weighted / M
    Ibody = np.zeros((3, 3))
    for m, r in zip(masses, points):
        r0 = r - center
        Ibody = Ibody + m * (_dot(r0, r0) * np.eye(3) - np.outer(r0, r0))
    return M, center, Ibody
