"""Free-motion integration: forces, the state derivative and the ODE steppers, as Numba kernels.

The kernels work on the packed state ``Y`` (N, W): one row per body in the
course's order (Baraff 2001 §2.9, Algorithm 4 "DdtStateToArray"):

* matrix layout, W = 18:      x (3) | R (9, row-major) | P (3) | L (3)
* quaternion layout, W = 13:  x (3) | q (4, w x y z)   | P (3) | L (3)

and on the constant arrays of ``World`` (mass, inverse inertia...). They read
the force tables of ``tumble.forces`` and write forces, derivatives or a new
state. ``World`` owns the arrays; ``Simulator`` picks the integrator.

Integrators (ids are the INTEGRATOR_IDS values):

========================  =====  ==========================  ======================================
name                      order  force evaluations / step    notes
========================  =====  ==========================  ======================================
explicit-euler            1      1                           the course's; energy grows
semi-implicit-euler       1      1                           kick P, L then drift x, R; symplectic
                                                             for x; exact rotation for constant omega
midpoint                  2      2                           explicit midpoint (RK2)
rk4                       4      4                           classic Runge-Kutta
splitting                 2      2                           kick-drift-kick with the free rotation
                                                             split into exact rotations about the
                                                             principal axes (McLachlan 1993, Reich
                                                             1994, Touma & Wisdom 1994): stays on
                                                             SO(3), keeps world L to rounding without
                                                             torque, no secular energy drift
splitting4                4      6                           Yoshida's triple-jump composition of
                                                             ``splitting`` (Yoshida 1990 eq. 5.19)
rk45, dop853              5, 8   adaptive (SciPy)            solve_ivp on World.dxdt, frame to frame
========================  =====  ==========================  ======================================
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange, types
from numba.extending import overload

from .body_motion import LAYOUT_IDS, LAYOUT_QUATERNION, STATE_WIDTH  # noqa: F401 (re-exported: World, Scene, the tests)
from .body_motion import (  # one body in registers
    KICK_CONVERGED,  # noqa: F401 (the Python stages' closing kick reads it here)
    KICK_EXPLICIT,
    KICK_GO_ON,
    KICK_ITERATIONS,
    KICK_STALLED,  # noqa: F401 (as KICK_CONVERGED)
    LAYOUT_MATRIX,
    _axpy,
    _body_forces,
    _derivative,
    _drift,
    _kick,
    _closing_kick,
    _kick_change,
    _kick_forces,
    _kick_verdict,
    _load,
    _mat9,
    _project,
    _store,
    _unary_forces,
    _velocities,
    _velocity_rows,
)
from .math3d import JIT, matrix_to_quat_into, world_inertia_into

(
    EXPLICIT_EULER,
    SEMI_IMPLICIT_EULER,
    MIDPOINT,
    RK4,
    SPLITTING,
    SPLITTING4,
    RK45,
    DOP853,
) = range(8)
INTEGRATOR_IDS = {
    "explicit-euler": EXPLICIT_EULER,
    "semi-implicit-euler": SEMI_IMPLICIT_EULER,
    "midpoint": MIDPOINT,
    "rk4": RK4,
    "splitting": SPLITTING,
    "splitting4": SPLITTING4,
    "rk45": RK45,
    "dop853": DOP853,
}
ADAPTIVE = {RK45: "RK45", DOP853: "DOP853"}

# Yoshida (1990) triple jump: w1 = 1 / (2 - 2^(1/3)), w0 = 1 - 2 w1.
_YOSHIDA_W1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
_YOSHIDA_W0 = 1.0 - 2.0 * _YOSHIDA_W1


@njit(**JIT)
def _spring_forces(Y, Rs, vs, omegas, moving, spring_body, spring_anchor, spring_param, F, T):
    """Add the damped springs' forces to F, T (N, 3) (Baraff 2001 §2.7; "Particle dynamics" §3.2).

    Springs run in table order, after every body's unary forces, as the
    reference adds them (it loops over the force records in order, and a
    body's spring contributions come in spring order).
    """
    pa = np.empty(3)
    pb = np.empty(3)
    ra = np.zeros(3)
    rb = np.zeros(3)
    va = np.zeros(3)
    vb = np.zeros(3)
    for s in range(spring_body.shape[0]):
        a = spring_body[s, 0]
        b = spring_body[s, 1]
        for k in range(3):
            ra[k] = Rs[a, k, 0] * spring_anchor[s, 0, 0] + Rs[a, k, 1] * spring_anchor[s, 0, 1] + Rs[a, k, 2] * spring_anchor[s, 0, 2]
            pa[k] = Y[a, k] + ra[k]
        va[0] = vs[a, 0] + omegas[a, 1] * ra[2] - omegas[a, 2] * ra[1]
        va[1] = vs[a, 1] + omegas[a, 2] * ra[0] - omegas[a, 0] * ra[2]
        va[2] = vs[a, 2] + omegas[a, 0] * ra[1] - omegas[a, 1] * ra[0]
        if b >= 0:
            for k in range(3):
                rb[k] = Rs[b, k, 0] * spring_anchor[s, 1, 0] + Rs[b, k, 1] * spring_anchor[s, 1, 1] + Rs[b, k, 2] * spring_anchor[s, 1, 2]
                pb[k] = Y[b, k] + rb[k]
            vb[0] = vs[b, 0] + omegas[b, 1] * rb[2] - omegas[b, 2] * rb[1]
            vb[1] = vs[b, 1] + omegas[b, 2] * rb[0] - omegas[b, 0] * rb[2]
            vb[2] = vs[b, 2] + omegas[b, 0] * rb[1] - omegas[b, 1] * rb[0]
        else:
            for k in range(3):
                pb[k] = spring_anchor[s, 1, k]
                vb[k] = 0.0
        d0 = pa[0] - pb[0]
        d1 = pa[1] - pb[1]
        d2 = pa[2] - pb[2]
        length = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if length == 0.0:
            continue  # direction undefined: a zero-length spring pulls nowhere
        u0 = d0 / length
        u1 = d1 / length
        u2 = d2 / length
        closing = (va[0] - vb[0]) * u0 + (va[1] - vb[1]) * u1 + (va[2] - vb[2]) * u2
        mag = -(spring_param[s, 0] * (length - spring_param[s, 2]) + spring_param[s, 1] * closing)
        f0 = mag * u0
        f1 = mag * u1
        f2 = mag * u2
        if moving[a]:
            F[a, 0] += f0
            F[a, 1] += f1
            F[a, 2] += f2
            T[a, 0] += ra[1] * f2 - ra[2] * f1
            T[a, 1] += ra[2] * f0 - ra[0] * f2
            T[a, 2] += ra[0] * f1 - ra[1] * f0
        if b >= 0 and moving[b]:
            F[b, 0] -= f0
            F[b, 1] -= f1
            F[b, 2] -= f2
            T[b, 0] -= rb[1] * f2 - rb[2] * f1
            T[b, 1] -= rb[2] * f0 - rb[0] * f2
            T[b, 2] -= rb[0] * f1 - rb[1] * f0


# One step of one body by one integrator, in registers. Each takes (layout, h, i, x, o, P, L,
# mass, inv_mass, ib, pq, pm, gravity, uforce_kind, uforce_param, uforce_start) and returns the
# new (x, o, P, L) before the projection onto SO(3).
@njit(**JIT, inline="always")
def _step_explicit_euler(layout, h, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity, uforce_kind, uforce_param, uforce_start):
    # X(t + h) = X(t) + h dX/dt  (course, "Schéma d'Euler explicite")
    v, w, F, T = _body_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
    dx, do, dP, dL = _derivative(layout, o, v, w, F, T)
    return _axpy(x, o, P, L, h, dx, do, dP, dL)


@njit(**JIT, inline="always")
def _step_midpoint(layout, h, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity, uforce_kind, uforce_param, uforce_start):
    v, w, F, T = _body_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
    dx, do, dP, dL = _derivative(layout, o, v, w, F, T)
    x1, o1, P1, L1 = _axpy(x, o, P, L, 0.5 * h, dx, do, dP, dL)
    v, w, F, T = _body_forces(layout, i, x1, o1, P1, L1, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
    dx, do, dP, dL = _derivative(layout, o1, v, w, F, T)
    return _axpy(x, o, P, L, h, dx, do, dP, dL)


@njit(**JIT, inline="always")
def _step_rk4(layout, h, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity, uforce_kind, uforce_param, uforce_start):
    # k1..k4 with the classic weights 1/6, 1/3, 1/3, 1/6; (ax, ao, aP, aL) sums them
    v, w, F, T = _body_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
    dx, do, dP, dL = _derivative(layout, o, v, w, F, T)
    ax, ao, aP, aL = _axpy(dx, do, dP, dL, 0.0, dx, do, dP, dL)
    x1, o1, P1, L1 = _axpy(x, o, P, L, 0.5 * h, dx, do, dP, dL)
    for stage in range(3):
        v, w, F, T = _body_forces(layout, i, x1, o1, P1, L1, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
        dx, do, dP, dL = _derivative(layout, o1, v, w, F, T)
        if stage < 2:
            ax, ao, aP, aL = _axpy(ax, ao, aP, aL, 2.0, dx, do, dP, dL)
            x1, o1, P1, L1 = _axpy(x, o, P, L, 0.5 * h if stage == 0 else h, dx, do, dP, dL)
        else:
            ax, ao, aP, aL = _axpy(ax, ao, aP, aL, 1.0, dx, do, dP, dL)
    return _axpy(x, o, P, L, h / 6.0, ax, ao, aP, aL)


@njit(**JIT, inline="always")
def _step_semi_implicit_euler(layout, h, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity, uforce_kind, uforce_param, uforce_start):
    F, T = _kick_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
    P, L = _kick(P, L, F, T, h)
    x, o = _drift(layout, False, h, x, o, P, L, inv_mass, ib, pq, pm)
    return x, o, P, L


@njit(**JIT, inline="always")
def _step_splitting(n_sub, layout, h, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity, uforce_kind, uforce_param, uforce_start):
    # SPLITTING (n_sub 1), SPLITTING4 (n_sub 3): kick (h/2) - drift (h, exact free rotation) - kick (h/2)
    for sub in range(n_sub):
        hh = h if n_sub == 1 else (_YOSHIDA_W0 * h if sub == 1 else _YOSHIDA_W1 * h)
        F, T = _kick_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
        P, L = _kick(P, L, F, T, 0.5 * hh)
        x, o = _drift(layout, True, hh, x, o, P, L, inv_mass, ib, pq, pm)
        P, L = _closing_kick(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param,
                             uforce_start, 0.5 * hh)
    return x, o, P, L


def _body_step(integrator, layout, h, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity, uforce_kind, uforce_param, uforce_start):
    """One step of one body by ``integrator`` (for compiled code only: ``_body_step_overload``)."""
    raise NotImplementedError("compiled code only")


@overload(_body_step, jit_options=JIT, prefer_literal=True)
def _body_step_overload(integrator, layout, h, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity, uforce_kind, uforce_param,
                        uforce_start):
    """``_body_step`` typed for ``integrator``: a literal integrator (a constant of the kernels of
    ``_step_bodies_kernels``, its only callers) compiles that integrator's step alone. COMPILE:
    Numba does not prune the branches on a literal argument, so the whole chain was compiled for
    every run whatever its integrator: 8 s of a first run's compile (measured), where one
    integrator's step takes 1-3 s. Same operations, same bits."""
    if isinstance(integrator, types.IntegerLiteral):
        kind = integrator.literal_value
        if kind == SPLITTING or kind == SPLITTING4:
            n_sub = 1 if kind == SPLITTING else 3

            def splitting(integrator, layout, h, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity, uforce_kind,
                          uforce_param, uforce_start):
                return _step_splitting(n_sub, layout, h, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity,
                                       uforce_kind, uforce_param, uforce_start)
            return splitting
        step = {EXPLICIT_EULER: _step_explicit_euler, MIDPOINT: _step_midpoint, RK4: _step_rk4,
                SEMI_IMPLICIT_EULER: _step_semi_implicit_euler}[kind]

        def one(integrator, layout, h, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity, uforce_kind, uforce_param,
                uforce_start):
            return step(layout, h, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity, uforce_kind, uforce_param,
                        uforce_start)
        return one

    return None  # a literal integrator only: every caller is a kernel of _step_bodies_kernels


@njit(**JIT)
def _advance_body(integrator, layout, h, n_steps, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity, uforce_kind, uforce_param, uforce_start):
    """n_steps steps of one body whose forces depend on itself only (no springs), in registers:
    the same operations in the same order as ``_one_step`` over all bodies."""
    for _ in range(n_steps):
        x, o, P, L = _body_step(integrator, layout, h, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity, uforce_kind,
                                uforce_param, uforce_start)
        o = _project(layout, o)
    return x, o, P, L


# Bodies per task of the parallel loop: enough that a task is worth a thread
# hand-off, few enough that both cores get work at N = 1000.
BODY_CHUNK = 64
# Below this many bodies the serial kernel is used: launching threads costs more
# than it saves (and on oversubscribed cores each launch is slower still).
PARALLEL_MIN_BODIES = 512


@njit(**JIT)
def _advance_chunk(c, integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start):
    """``_advance_body`` for the bodies of chunk c: each row is loaded once, stepped n_steps times, stored once."""
    g = (gravity[0], gravity[1], gravity[2])
    for i in range(c * BODY_CHUNK, min(Y.shape[0], (c + 1) * BODY_CHUNK)):
        if moving[i]:
            x, o, P, L = _load(layout, Y, i)
            pq = (principal_q[i, 0], principal_q[i, 1], principal_q[i, 2], principal_q[i, 3])
            pm = (principal_moments[i, 0], principal_moments[i, 1], principal_moments[i, 2])
            x, o, P, L = _advance_body(integrator, layout, h, n_steps, i, x, o, P, L, mass[i], inv_mass[i], _mat9(inertia_body_inv, i), pq, pm, g, uforce_kind, uforce_param, uforce_start)
            _store(layout, Y, i, x, o, P, L)


def _step_bodies_kernels(integrator: int):
    """The two compiled kernels (serial, parallel) of ``step_bodies_kernel`` for one integrator.

    COMPILE: ``integrator`` is a constant of the closures, so ``_advance_body`` and
    ``_body_step_overload`` see a literal and compile that integrator's step alone (8 s of a
    first run's compile went to the others before). Numba caches each closure apart (its cache
    key hashes the closure's constants). ``numba.literally`` on an argument did the same, but
    every call from Python then went through the compiler's dispatch again (10-90 ms a call).
    """

    @njit(**JIT)
    def serial(layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
               uforce_kind, uforce_param, uforce_start):
        n_chunks = (Y.shape[0] + BODY_CHUNK - 1) // BODY_CHUNK
        for c in range(n_chunks):
            _advance_chunk(c, integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q,
                           principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start)

    @njit(**JIT, parallel=True)
    def parallel(layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving,
                 gravity, uforce_kind, uforce_param, uforce_start):
        n_chunks = (Y.shape[0] + BODY_CHUNK - 1) // BODY_CHUNK
        for c in prange(n_chunks):
            # COMPILE: prange's index is unsigned; passed as it is, it compiled _advance_chunk a
            # second time (uint64) beside the serial kernel's int64 one, for each integrator.
            _advance_chunk(np.int64(c), integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q,
                           principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start)

    return serial, parallel


_STEP_BODIES = {kind: _step_bodies_kernels(kind) for kind in
                (EXPLICIT_EULER, SEMI_IMPLICIT_EULER, MIDPOINT, RK4, SPLITTING, SPLITTING4)}


def step_bodies_parallel_kernel(integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start):
    """``step_bodies_kernel`` with the chunks spread over all cores. Each task writes only
    its own rows, so the bits are the same as the serial kernel's for any thread count."""
    _STEP_BODIES[int(integrator)][1](layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q,
                                     principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start)


def step_bodies_kernel(integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start):
    """Advance Y (N, W) in place by n_steps steps of h s when no force couples two bodies (no springs).

    Each body takes all its steps in registers (``_advance_body``): the same
    operations in the same order as ``step_kernel``, so the same bits. Called from
    Python; the compiled kernel of ``integrator`` does the work (``_step_bodies_kernels``).
    """
    _STEP_BODIES[int(integrator)][0](layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q,
                                     principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start)


# --------------------------------------------------------------------------- all bodies, stage by stage
# Used when springs couple bodies (step_kernel) and, one kernel at a time, by
# the Simulator's path for user callables and by World.dxdt / update_derived.


@njit(**JIT)
def accumulate_forces_kernel(
    layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity,
    uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param,
    # outputs
    Rs, vs, omegas, F, T,
):
    """Stage 1 of the step: derived R, v, omega and the accumulated F, T of every body.

    Inputs: Y (N, W) packed state; mass, inv_mass (N,) kg, 1/kg;
    inertia_body_inv (N, 3, 3) body frame; moving (N,) bool; gravity (3,) m/s^2.
    Outputs: Rs (N, 3, 3), vs (N, 3) m/s, omegas (N, 3) rad/s, F (N, 3) N,
    T (N, 3) N m, all world frame. Fixed bodies get zero force and torque.
    """
    g = (gravity[0], gravity[1], gravity[2])
    for i in range(Y.shape[0]):
        x, o, P, L = _load(layout, Y, i)
        R, v, omega = _velocities(layout, o, P, L, inv_mass[i], _mat9(inertia_body_inv, i))
        if moving[i]:
            Fi, Ti = _unary_forces(i, x, R, v, omega, mass[i], g, uforce_kind, uforce_param, uforce_start)
        else:
            Fi, Ti = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        for k in range(9):
            Rs[i, k // 3, k % 3] = R[k]
        for k in range(3):
            vs[i, k] = v[k]
            omegas[i, k] = omega[k]
            F[i, k] = Fi[k]
            T[i, k] = Ti[k]
    if spring_body.shape[0] > 0:
        _spring_forces(Y, Rs, vs, omegas, moving, spring_body, spring_anchor, spring_param, F, T)


@njit(**JIT)
def derivative_kernel(layout, Y, Rs, vs, omegas, moving, F, T, dY):
    """dX/dt (N, W) of all bodies from their derived quantities and forces (zero for fixed bodies)."""
    for i in range(Y.shape[0]):
        if moving[i]:
            x, o, P, L = _load(layout, Y, i)
            dx, do, dP, dL = _derivative(layout, o, (vs[i, 0], vs[i, 1], vs[i, 2]), (omegas[i, 0], omegas[i, 1], omegas[i, 2]),
                                         (F[i, 0], F[i, 1], F[i, 2]), (T[i, 0], T[i, 1], T[i, 2]))
            _store(layout, dY, i, dx, do, dP, dL)
        else:
            dY[i, :] = 0.0


@njit(**JIT)
def project_orientation_kernel(layout, Y, moving):
    """Every moving body's orientation back onto SO(3) (ERRATA 5)."""
    for i in range(Y.shape[0]):
        if moving[i]:
            x, o, P, L = _load(layout, Y, i)
            _store(layout, Y, i, x, _project(layout, o), P, L)


@njit(**JIT)
def kick_kernel(layout, Y, moving, F, T, h):
    """P += h F, L += h tau for every moving body."""
    for i in range(Y.shape[0]):
        if moving[i]:
            x, o, P, L = _load(layout, Y, i)
            P, L = _kick(P, L, (F[i, 0], F[i, 1], F[i, 2]), (T[i, 0], T[i, 1], T[i, 2]), h)
            _store(layout, Y, i, x, o, P, L)


@njit(**JIT)
def drift_kernel(layout, Y, moving, inv_mass, inertia_body_inv, principal_q, principal_moments, split, h):
    """``_drift`` for every moving body."""
    for i in range(Y.shape[0]):
        if moving[i]:
            x, o, P, L = _load(layout, Y, i)
            pq = (principal_q[i, 0], principal_q[i, 1], principal_q[i, 2], principal_q[i, 3])
            pm = (principal_moments[i, 0], principal_moments[i, 1], principal_moments[i, 2])
            x, o = _drift(layout, split, h, x, o, P, L, inv_mass[i], _mat9(inertia_body_inv, i), pq, pm)
            _store(layout, Y, i, x, o, P, L)


@njit(**JIT)
def axpy_kernel(Y0, a, dY, out):
    """out = Y0 + a dY (N, W), elementwise (the arithmetic of ``_axpy``)."""
    for i in range(Y0.shape[0]):
        for k in range(Y0.shape[1]):
            out[i, k] = Y0[i, k] + a * dY[i, k]


def step_kernel(
    integrator, layout, h, n_steps,
    Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
    uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param,
    # scratch (N, W) x 3, (N, 3, 3), (N, 3) x 4
    Y1, K, Kacc, Rs, vs, omegas, F, T,
):
    """Advance Y (N, W) in place by n_steps steps of h s, all bodies together stage by stage
    (springs couple them). The whole loop runs compiled (the kernel of ``integrator``,
    ``_step_kernels``). Built-in forces only: ``CustomForce`` takes ``Simulator``'s
    stage-by-stage path, which calls the same kernels in the same order and so gives the same
    bits."""
    _STEP_ALL[int(integrator)](layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments,
                               moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor,
                               spring_param, Y1, K, Kacc, Rs, vs, omegas, F, T)


def _step_kernels(integrator: int):
    """``step_kernel``'s compiled loop for one integrator, a constant of the closure (COMPILE: as
    ``_step_bodies_kernels``; ``_one_step_overload`` types that integrator's stages alone)."""

    @njit(**JIT)
    def loop(layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
             uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Y1, K, Kacc, Rs, vs,
             omegas, F, T):
        for _ in range(n_steps):
            _one_step(integrator, layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments,
                      moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor,
                      spring_param, Y1, K, Kacc, Rs, vs, omegas, F, T)
            project_orientation_kernel(layout, Y, moving)

    return loop


@njit(**JIT)
def _slope(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start,
           spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T, K):
    """K (N, W) = dX/dt at the state rows Y: the forces and torques at Y (F, T), then the
    derivative (course "ComputeForceAndTorque" then "Dxdt"); one stage of the explicit steppers."""
    accumulate_forces_kernel(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param,
                             uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
    derivative_kernel(layout, Y, Rs, vs, omegas, moving, F, T, K)


# One step of all bodies together by one integrator, stage by stage (springs couple them), before
# the projection onto SO(3): the implementations ``_one_step_overload`` picks from (plain functions,
# compiled only through it).
def _all_explicit_euler(integrator, layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
        uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Y1, K, Kacc, Rs, vs, omegas, F, T):
    # X(t + h) = X(t) + h dX/dt  (course, "Schéma d'Euler explicite")
    _slope(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start,
           spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T, K)
    axpy_kernel(Y, h, K, Y)


def _all_midpoint(integrator, layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
        uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Y1, K, Kacc, Rs, vs, omegas, F, T):
    _slope(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start,
           spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T, K)
    axpy_kernel(Y, 0.5 * h, K, Y1)
    _slope(layout, Y1, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start,
           spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T, K)
    axpy_kernel(Y, h, K, Y)


def _all_rk4(integrator, layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
        uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Y1, K, Kacc, Rs, vs, omegas, F, T):
    # k1..k4 with the classic weights 1/6, 1/3, 1/3, 1/6; Kacc sums them.
    _slope(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start,
           spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T, K)
    axpy_kernel(K, 0.0, K, Kacc)
    axpy_kernel(Y, 0.5 * h, K, Y1)
    for stage in range(3):
        _slope(layout, Y1, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start,
               spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T, K)
        if stage < 2:
            axpy_kernel(Kacc, 2.0, K, Kacc)
            axpy_kernel(Y, 0.5 * h if stage == 0 else h, K, Y1)
        else:
            axpy_kernel(Kacc, 1.0, K, Kacc)
    axpy_kernel(Y, h / 6.0, Kacc, Y)


def _all_semi_implicit_euler(integrator, layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
        uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Y1, K, Kacc, Rs, vs, omegas, F, T):
    accumulate_forces_kernel(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
    kick_kernel(layout, Y, moving, F, T, h)
    drift_kernel(layout, Y, moving, inv_mass, inertia_body_inv, principal_q, principal_moments, False, h)


def _all_splitting(integrator, layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
        uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Y1, K, Kacc, Rs, vs, omegas, F, T):
    _split_step(layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T, Y1, K)


def _all_splitting4(integrator, layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
        uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Y1, K, Kacc, Rs, vs, omegas, F, T):
    for sub in range(3):
        hh = _YOSHIDA_W0 * h if sub == 1 else _YOSHIDA_W1 * h
        _split_step(layout, hh, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T, Y1, K)


def _one_step(integrator, layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
        uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Y1, K, Kacc, Rs, vs, omegas, F, T):
    """One step of all bodies together (compiled code only: ``_one_step_overload``)."""
    raise NotImplementedError("compiled code only")


@overload(_one_step, jit_options=JIT, prefer_literal=True)
def _one_step_overload(integrator, layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
        uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Y1, K, Kacc, Rs, vs, omegas, F, T):
    """``_one_step`` for a literal ``integrator``: that integrator's stages alone (COMPILE: all
    six cost 6.8 s of the demo's 10 s of compile, measured). Same kernels in the same order,
    same bits."""
    impls = {EXPLICIT_EULER: _all_explicit_euler, MIDPOINT: _all_midpoint, RK4: _all_rk4,
             SEMI_IMPLICIT_EULER: _all_semi_implicit_euler, SPLITTING: _all_splitting, SPLITTING4: _all_splitting4}
    if isinstance(integrator, types.IntegerLiteral):
        return impls[integrator.literal_value]

    return None  # a literal integrator only: every caller is a loop of _step_kernels


@njit(**JIT)
def _split_step(
    layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
    uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T, Y1, K,
):
    """Kick (h/2) - drift (h, exact free rotation) - kick (h/2): Strang splitting of forces and
    free motion; the closing kick with the forces of its end momenta when a force reads the
    velocities (``body_motion._closing_kick``: fixed-point iteration over all bodies, a damped
    spring coupling two). Y1, K (N, W): scratch."""
    accumulate_forces_kernel(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
    kick_kernel(layout, Y, moving, F, T, 0.5 * h)
    drift_kernel(layout, Y, moving, inv_mass, inertia_body_inv, principal_q, principal_moments, True, h)
    accumulate_forces_kernel(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
    reads_velocity = _velocity_rows(uforce_kind, 0, uforce_kind.shape[0])
    for s in range(spring_param.shape[0]):
        if spring_param[s, 1] != 0.0:  # a damped spring
            reads_velocity = True
    if not reads_velocity:
        kick_kernel(layout, Y, moving, F, T, 0.5 * h)
        return
    Y1[:, :] = Y  # the momenta the closing kick starts from
    kick_kernel(layout, Y, moving, F, T, 0.5 * h)
    K[:, :] = Y  # the explicit kick: kept where the iteration does not contract
    # each body stops as ``_closing_kick`` stops it (the same tests): the bits of a body alone
    n = Y.shape[0]
    done = ~moving
    last = np.full(n, np.inf)
    for _ in range(KICK_ITERATIONS):
        accumulate_forces_kernel(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
        remaining = False
        for i in range(n):
            if done[i]:
                continue
            x, o, P, L = _load(layout, Y1, i)
            x1, o1, P1, L1 = _load(layout, Y, i)
            P2, L2 = _kick(P, L, (F[i, 0], F[i, 1], F[i, 2]), (T[i, 0], T[i, 1], T[i, 2]), 0.5 * h)
            change = _kick_change(P1, L1, P2, L2, P, L)
            _store(layout, Y, i, x1, o1, P2, L2)
            verdict = _kick_verdict(change, last[i])
            if verdict == KICK_GO_ON:
                last[i] = change
                remaining = True
            else:
                done[i] = True
                if verdict == KICK_EXPLICIT:
                    x0, o0, P0, L0 = _load(layout, K, i)
                    _store(layout, Y, i, x1, o1, P0, L0)
        if not remaining:
            return


_STEP_ALL = {kind: _step_kernels(kind) for kind in
             (EXPLICIT_EULER, SEMI_IMPLICIT_EULER, MIDPOINT, RK4, SPLITTING, SPLITTING4)}


@njit(**JIT)
def update_derived_kernel(
    layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity,
    uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param,
    # outputs
    q, R, v, omega, I_inv, F, T,
):
    """Everything derived from the state rows Y (N, W), world frame: the other
    orientation (q from R in the matrix layout, on the hemisphere of the previous
    q; R from q otherwise), v, omega, I^-1 = R Ibody^-1 R^T, and the built-in
    forces F, T (course "ArrayToBodies" followed by "ComputeForceAndTorque")."""
    accumulate_forces_kernel(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, R, v, omega, F, T)
    tmp = np.empty(4)
    for i in range(Y.shape[0]):
        if layout == LAYOUT_MATRIX:
            matrix_to_quat_into(R[i], tmp)
            sign = -1.0 if tmp[0] * q[i, 0] + tmp[1] * q[i, 1] + tmp[2] * q[i, 2] + tmp[3] * q[i, 3] < 0.0 else 1.0
            for k in range(4):
                q[i, k] = sign * tmp[k]
        else:
            for k in range(4):
                q[i, k] = Y[i, 3 + k]
        world_inertia_into(R[i], inertia_body_inv[i], I_inv[i])
