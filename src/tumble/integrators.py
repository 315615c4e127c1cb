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
from numba import njit, prange

from .forces import UFORCE_CONSTANT, UFORCE_DRAG, UFORCE_POINT_WORLD
from .math3d import JIT, matrix_to_quat_into, world_inertia_into

LAYOUT_QUATERNION, LAYOUT_MATRIX = 0, 1
LAYOUT_IDS = {"quaternion": LAYOUT_QUATERNION, "matrix": LAYOUT_MATRIX}
STATE_WIDTH = {LAYOUT_QUATERNION: 13, LAYOUT_MATRIX: 18}

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


# --------------------------------------------------------------------------- one body, in registers
# A body's state travels between these functions as four tuples of floats,
# (x, o, P, L): x (3,) m, o (9,) the orientation (the quaternion layout uses
# o[0:4] = q and leaves o[4:9] zero; the matrix layout has R row-major), P (3,),
# L (3,). Tuples stay in registers, where array rows would go through memory:
# PERF: the same per-body step written over (W,) array rows ran 3x slower.
# Every integrator is written once on top of these functions; the all-bodies
# kernels (springs, user callables) load rows, call the same functions and
# store rows, so every path gives the same bits.


@njit(**JIT)
def _load(layout, Y, i):
    """Row i of the packed state Y (N, W) as (x, o, P, L)."""
    x = (Y[i, 0], Y[i, 1], Y[i, 2])
    if layout == LAYOUT_MATRIX:
        o = (Y[i, 3], Y[i, 4], Y[i, 5], Y[i, 6], Y[i, 7], Y[i, 8], Y[i, 9], Y[i, 10], Y[i, 11])
        b = 12
    else:
        o = (Y[i, 3], Y[i, 4], Y[i, 5], Y[i, 6], 0.0, 0.0, 0.0, 0.0, 0.0)
        b = 7
    return x, o, (Y[i, b], Y[i, b + 1], Y[i, b + 2]), (Y[i, b + 3], Y[i, b + 4], Y[i, b + 5])


@njit(**JIT)
def _store(layout, Y, i, x, o, P, L):
    """Write (x, o, P, L) into row i of Y (N, W)."""
    for k in range(3):
        Y[i, k] = x[k]
    if layout == LAYOUT_MATRIX:
        for k in range(9):
            Y[i, 3 + k] = o[k]
        b = 12
    else:
        for k in range(4):
            Y[i, 3 + k] = o[k]
        b = 7
    for k in range(3):
        Y[i, b + k] = P[k]
        Y[i, b + 3 + k] = L[k]


@njit(**JIT)
def _mat9(A, i):
    """A[i] (3, 3) as a row-major 9-tuple."""
    return (A[i, 0, 0], A[i, 0, 1], A[i, 0, 2], A[i, 1, 0], A[i, 1, 1], A[i, 1, 2], A[i, 2, 0], A[i, 2, 1], A[i, 2, 2])


@njit(**JIT)
def _quat_matrix(w, x, y, z, s):
    """Rotation matrix (row-major 9-tuple) of the quaternion (w, x, y, z) with s = 2 / |q|^2."""
    return (
        1.0 - s * (y * y + z * z), s * (x * y - w * z), s * (x * z + w * y),
        s * (x * y + w * z), 1.0 - s * (x * x + z * z), s * (y * z - w * x),
        s * (x * z - w * y), s * (y * z + w * x), 1.0 - s * (x * x + y * y),
    )


@njit(**JIT)
def _matrix(layout, o):
    """R (row-major 9-tuple) of the orientation o. For quaternions the formula divides
    by |q|^2, so Runge-Kutta stage states (|q| off 1 by O(h^2)) still give a rotation."""
    if layout == LAYOUT_MATRIX:
        return o
    w, x, y, z = o[0], o[1], o[2], o[3]
    return _quat_matrix(w, x, y, z, 2.0 / (w * w + x * x + y * y + z * z))


@njit(**JIT, inline="always")
def _velocities(layout, o, P, L, inv_mass, ib):
    """Derived R, v, omega of one body (Baraff 2001 eq. 2-40; course "ArrayToBodies").

    v = P / M;  I^-1 = R Ibody^-1 R^T;  omega = I^-1 L, computed as
    R (Ibody^-1 (R^T L)): the same product in 27 multiplications instead of 63.
    ib: Ibody^-1 as a row-major 9-tuple (body frame).
    """
    R = _matrix(layout, o)
    v = (P[0] * inv_mass, P[1] * inv_mass, P[2] * inv_mass)
    l0 = R[0] * L[0] + R[3] * L[1] + R[6] * L[2]
    l1 = R[1] * L[0] + R[4] * L[1] + R[7] * L[2]
    l2 = R[2] * L[0] + R[5] * L[1] + R[8] * L[2]
    w0 = ib[0] * l0 + ib[1] * l1 + ib[2] * l2
    w1 = ib[3] * l0 + ib[4] * l1 + ib[5] * l2
    w2 = ib[6] * l0 + ib[7] * l1 + ib[8] * l2
    omega = (R[0] * w0 + R[1] * w1 + R[2] * w2, R[3] * w0 + R[4] * w1 + R[5] * w2, R[6] * w0 + R[7] * w1 + R[8] * w2)
    return R, v, omega


@njit(**JIT)
def _unary_forces(i, x, R, v, omega, mass, gravity, uforce_kind, uforce_param, uforce_start):
    """Force F (3,) N and torque T (3,) N m on body i from gravity and its own rows, world frame.

    Summed in a fixed order (gravity, then rows in the order the user added
    them), as ``tumble.reference.compute_force_and_torque`` does.
    """
    F0 = mass * gravity[0]
    F1 = mass * gravity[1]
    F2 = mass * gravity[2]
    T0 = 0.0
    T1 = 0.0
    T2 = 0.0
    for r in range(uforce_start[i], uforce_start[i + 1]):
        kind = uforce_kind[r]
        p = uforce_param[r]
        if kind == UFORCE_DRAG:
            u0 = v[0] - p[4]
            u1 = v[1] - p[5]
            u2 = v[2] - p[6]
            c = p[0] + p[1] * math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
            F0 -= c * u0
            F1 -= c * u1
            F2 -= c * u2
            ca = p[2] + p[3] * math.sqrt(omega[0] ** 2 + omega[1] ** 2 + omega[2] ** 2)
            T0 -= ca * omega[0]
            T1 -= ca * omega[1]
            T2 -= ca * omega[2]
        elif kind == UFORCE_CONSTANT:
            F0 += p[0]
            F1 += p[1]
            F2 += p[2]
            T0 += p[3]
            T1 += p[4]
            T2 += p[5]
        else:
            # r = p - x: the lever arm of the force about the centre of mass
            if kind == UFORCE_POINT_WORLD:
                r0 = p[3] - x[0]
                r1 = p[4] - x[1]
                r2 = p[5] - x[2]
            else:  # UFORCE_POINT_BODY: the world point is R p_body + x, so r = R p_body
                r0 = R[0] * p[3] + R[1] * p[4] + R[2] * p[5]
                r1 = R[3] * p[3] + R[4] * p[4] + R[5] * p[5]
                r2 = R[6] * p[3] + R[7] * p[4] + R[8] * p[5]
            F0 += p[0]
            F1 += p[1]
            F2 += p[2]
            T0 += r1 * p[2] - r2 * p[1]
            T1 += r2 * p[0] - r0 * p[2]
            T2 += r0 * p[1] - r1 * p[0]
    return (F0, F1, F2), (T0, T1, T2)


@njit(**JIT, inline="always")
def _derivative(layout, o, v, omega, F, T):
    """dX/dt of one body: (v, omega* R, F, tau) (course Algorithm 4; ERRATA 1), or
    (v, 1/2 (0, omega) q, F, tau) in the quaternion layout (Baraff 2001 eq. 4-2)."""
    w0, w1, w2 = omega[0], omega[1], omega[2]
    if layout == LAYOUT_MATRIX:
        # (omega* R)[r, c] = (omega x R[:, c])[r]
        do = (
            w1 * o[6] - w2 * o[3], w1 * o[7] - w2 * o[4], w1 * o[8] - w2 * o[5],
            w2 * o[0] - w0 * o[6], w2 * o[1] - w0 * o[7], w2 * o[2] - w0 * o[8],
            w0 * o[3] - w1 * o[0], w0 * o[4] - w1 * o[1], w0 * o[5] - w1 * o[2],
        )
    else:
        qw, qx, qy, qz = o[0], o[1], o[2], o[3]
        do = (
            0.5 * (-w0 * qx - w1 * qy - w2 * qz),
            0.5 * (w0 * qw + w1 * qz - w2 * qy),
            0.5 * (-w0 * qz + w1 * qw + w2 * qx),
            0.5 * (w0 * qy - w1 * qx + w2 * qw),
            0.0, 0.0, 0.0, 0.0, 0.0,
        )
    return v, do, F, T


@njit(**JIT)
def _axpy3(a, s, b):
    return (a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2])


@njit(**JIT)
def _axpy9(a, s, b):
    return (a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2], a[3] + s * b[3], a[4] + s * b[4],
            a[5] + s * b[5], a[6] + s * b[6], a[7] + s * b[7], a[8] + s * b[8])


@njit(**JIT, inline="always")
def _axpy(x, o, P, L, s, dx, do, dP, dL):
    """(x, o, P, L) + s (dx, do, dP, dL): one Runge-Kutta combination."""
    return _axpy3(x, s, dx), _axpy9(o, s, do), _axpy3(P, s, dP), _axpy3(L, s, dL)


@njit(**JIT, inline="always")
def _project(layout, o):
    """The orientation back onto SO(3) (ERRATA 5): q / |q|, or Gram-Schmidt on the columns
    of R (the same arithmetic as ``math3d.orthonormalize_inplace`` and the reference)."""
    if layout == LAYOUT_QUATERNION:
        inv = 1.0 / math.sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2] + o[3] * o[3])
        return (o[0] * inv, o[1] * inv, o[2] * inv, o[3] * inv, 0.0, 0.0, 0.0, 0.0, 0.0)
    n0 = math.sqrt(o[0] ** 2 + o[3] ** 2 + o[6] ** 2)
    a0 = o[0] / n0
    a1 = o[3] / n0
    a2 = o[6] / n0
    d = a0 * o[1] + a1 * o[4] + a2 * o[7]
    b0 = o[1] - d * a0
    b1 = o[4] - d * a1
    b2 = o[7] - d * a2
    n1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    b0 /= n1
    b1 /= n1
    b2 /= n1
    return (a0, b0, a1 * b2 - a2 * b1, a1, b1, a2 * b0 - a0 * b2, a2, b2, a0 * b1 - a1 * b0)


# Taylor coefficients of sin and cos, as products (a division costs ~5 multiplications).
_I6, _I20, _I42, _I72 = 1.0 / 6.0, 1.0 / 20.0, 1.0 / 42.0, 1.0 / 72.0
_I2, _I12, _I30, _I56, _I90 = 0.5, 1.0 / 12.0, 1.0 / 30.0, 1.0 / 56.0, 1.0 / 90.0
SMALL_ANGLE = 0.1  # rad; below it the polynomials below are exact to about 1 ulp


@njit(**JIT)
def _sin_over_x(z):
    """sin(x) / x for z = x^2 <= SMALL_ANGLE^2: x^-1 (x - x^3/3! + ... + x^9/9!), truncation < 3e-18."""
    return 1.0 - z * _I6 * (1.0 - z * _I20 * (1.0 - z * _I42 * (1.0 - z * _I72)))


@njit(**JIT)
def _sincos(x):
    """(sin x, cos x). PERF: a step turns a body by ~0.01 rad, where Taylor polynomials
    (error below 1 ulp for |x| <= 0.1) replace two libm calls, about a third of a
    semi-implicit step's cost; they also make the result independent of the
    platform's libm. Larger angles use libm."""
    if abs(x) <= SMALL_ANGLE:
        z = x * x
        return x * _sin_over_x(z), 1.0 - z * _I2 * (1.0 - z * _I12 * (1.0 - z * _I30 * (1.0 - z * _I56 * (1.0 - z * _I90))))
    return math.sin(x), math.cos(x)


@njit(**JIT, inline="always")
def _rotate(layout, o, omega, h):
    """Turn the orientation by the exact rotation of constant world angular velocity omega over h.

    Quaternion: q <- exp(h/2 (0, omega)) q. Matrix: R <- Rodrigues(h omega) R.
    """
    wx, wy, wz = omega[0], omega[1], omega[2]
    n = math.sqrt(wx * wx + wy * wy + wz * wz)
    half = 0.5 * h * n
    # sin(half) / n = (h/2) sin(half) / half: no 0/0 for a body at rest
    if half <= SMALL_ANGLE:
        s = 0.5 * h * _sin_over_x(half * half)
        c = _sincos(half)[1]
    else:
        s = math.sin(half) / n
        c = math.cos(half)
    dw, dx, dy, dz = c, s * wx, s * wy, s * wz
    if layout == LAYOUT_QUATERNION:
        w, x, y, z = o[0], o[1], o[2], o[3]
        return (dw * w - dx * x - dy * y - dz * z, dw * x + dx * w + dy * z - dz * y,
                dw * y - dx * z + dy * w + dz * x, dw * z + dx * y - dy * x + dz * w, 0.0, 0.0, 0.0, 0.0, 0.0)
    M = _quat_matrix(dw, dx, dy, dz, 2.0)
    return _matmul9(M, o)


@njit(**JIT)
def _matmul9(A, B):
    """A B for row-major 9-tuples."""
    return (
        A[0] * B[0] + A[1] * B[3] + A[2] * B[6], A[0] * B[1] + A[1] * B[4] + A[2] * B[7], A[0] * B[2] + A[1] * B[5] + A[2] * B[8],
        A[3] * B[0] + A[4] * B[3] + A[5] * B[6], A[3] * B[1] + A[4] * B[4] + A[5] * B[7], A[3] * B[2] + A[4] * B[5] + A[5] * B[8],
        A[6] * B[0] + A[7] * B[3] + A[8] * B[6], A[6] * B[1] + A[7] * B[4] + A[8] * B[7], A[6] * B[2] + A[7] * B[5] + A[8] * B[8],
    )


@njit(**JIT)
def _principal_flow(k, tau, Ik, l0, l1, l2, d):
    """The exact flow of H_k = Lk^2 / (2 Ik) over tau: the frame turns about principal axis k
    by theta = tau Lk / Ik. Returns L seen from the turned frame (Rot_k(theta)^T L) and
    d (cos theta/2, sin theta/2 e_k) (a body-frame turn composes on the right)."""
    d0, d1, d2, d3 = d
    lk = l0 if k == 0 else (l1 if k == 1 else l2)
    theta = tau * lk / Ik
    sh, ch = _sincos(0.5 * theta)
    c = ch * ch - sh * sh  # cos and sin of theta from those of theta / 2
    s = 2.0 * sh * ch
    if k == 0:
        l1, l2 = c * l1 + s * l2, -s * l1 + c * l2
        d = (d0 * ch - d1 * sh, d0 * sh + d1 * ch, d2 * ch + d3 * sh, d3 * ch - d2 * sh)
    elif k == 1:
        l2, l0 = c * l2 + s * l0, -s * l2 + c * l0
        d = (d0 * ch - d2 * sh, d1 * ch - d3 * sh, d0 * sh + d2 * ch, d3 * ch + d1 * sh)
    else:
        l0, l1 = c * l0 + s * l1, -s * l0 + c * l1
        d = (d0 * ch - d3 * sh, d1 * ch + d2 * sh, d2 * ch - d1 * sh, d0 * sh + d3 * ch)
    return l0, l1, l2, d


@njit(**JIT, inline="always")
def _split_rotation(layout, o, L, pq, pm, h):
    """Free rigid-body rotation over h by Strang splitting into exact principal-axis rotations.

    The torque-free Hamiltonian H = sum_k Lk^2 / (2 Ik) (L in the principal
    body frame) splits into three parts, each a rotation about one principal
    axis at the constant rate Lk / Ik: the body turns, world L stays. The
    composition 1(h/2) 2(h/2) 3(h) 2(h/2) 1(h/2) is symmetric, so second order
    and time-reversible; every factor is a rotation, so R stays on SO(3); and
    world L is never written, so without torque it is conserved to the bit.
    McLachlan, "Explicit Lie-Poisson integration and the Euler equations",
    PRL 71 (1993); Touma & Wisdom, AJ 107 (1994); Dullweber, Leimkuhler &
    McLachlan, J. Chem. Phys. 107 (1997) §3.

    pq (4,): principal axes to body axes (Ibody = Q diag(I) Q^T); pm (3,)
    kg m^2, ascending, so the middle (full-h) flow is about the largest moment.
    """
    R = _matrix(layout, o)
    pw, px, py, pz = pq[0], pq[1], pq[2], pq[3]
    Q = _quat_matrix(pw, px, py, pz, 2.0)
    # L in the principal frame: Q^T R^T L
    b0 = R[0] * L[0] + R[3] * L[1] + R[6] * L[2]
    b1 = R[1] * L[0] + R[4] * L[1] + R[7] * L[2]
    b2 = R[2] * L[0] + R[5] * L[1] + R[8] * L[2]
    l0 = Q[0] * b0 + Q[3] * b1 + Q[6] * b2
    l1 = Q[1] * b0 + Q[4] * b1 + Q[7] * b2
    l2 = Q[2] * b0 + Q[5] * b1 + Q[8] * b2
    # d: the turn of the principal frame over h, as a quaternion, from the five flows
    d = (1.0, 0.0, 0.0, 0.0)
    l0, l1, l2, d = _principal_flow(0, 0.5 * h, pm[0], l0, l1, l2, d)
    l0, l1, l2, d = _principal_flow(1, 0.5 * h, pm[1], l0, l1, l2, d)
    l0, l1, l2, d = _principal_flow(2, h, pm[2], l0, l1, l2, d)
    l0, l1, l2, d = _principal_flow(1, 0.5 * h, pm[1], l0, l1, l2, d)
    l0, l1, l2, d = _principal_flow(0, 0.5 * h, pm[0], l0, l1, l2, d)
    # the same turn in body axes: g = pq d conj(pq)
    d0, d1, d2, d3 = d
    t0 = pw * d0 - px * d1 - py * d2 - pz * d3
    t1 = pw * d1 + px * d0 + py * d3 - pz * d2
    t2 = pw * d2 - px * d3 + py * d0 + pz * d1
    t3 = pw * d3 + px * d2 - py * d1 + pz * d0
    g0 = t0 * pw + t1 * px + t2 * py + t3 * pz
    g1 = -t0 * px + t1 * pw - t2 * pz + t3 * py
    g2 = -t0 * py + t1 * pz + t2 * pw - t3 * px
    g3 = -t0 * pz - t1 * py + t2 * px + t3 * pw
    if layout == LAYOUT_QUATERNION:
        w, x, y, z = o[0], o[1], o[2], o[3]  # q <- q g
        return (w * g0 - x * g1 - y * g2 - z * g3, w * g1 + x * g0 + y * g3 - z * g2,
                w * g2 - x * g3 + y * g0 + z * g1, w * g3 + x * g2 - y * g1 + z * g0, 0.0, 0.0, 0.0, 0.0, 0.0)
    return _matmul9(o, _quat_matrix(g0, g1, g2, g3, 2.0))  # R <- R M(g)


@njit(**JIT, inline="always")
def _drift(layout, split, h, x, o, P, L, inv_mass, ib, pq, pm):
    """x += h P / M, and the orientation turned over h: at the constant omega = I^-1(R) L
    (split=False, semi-implicit Euler) or by the free-rotation splitting (split=True)."""
    x = (x[0] + h * P[0] * inv_mass, x[1] + h * P[1] * inv_mass, x[2] + h * P[2] * inv_mass)
    if split:
        return x, _split_rotation(layout, o, L, pq, pm, h)
    R, v, omega = _velocities(layout, o, P, L, inv_mass, ib)
    return x, _rotate(layout, o, omega, h)


@njit(**JIT, inline="always")
def _kick(P, L, F, T, h):
    """P += h F, L += h tau (the 'kick' of the symplectic methods)."""
    return _axpy3(P, h, F), _axpy3(L, h, T)


@njit(**JIT, inline="always")
def _body_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start):
    """Force and torque on body i alone (no springs), and the derivative's v, omega."""
    R, v, omega = _velocities(layout, o, P, L, inv_mass, ib)
    F, T = _unary_forces(i, x, R, v, omega, mass, gravity, uforce_kind, uforce_param, uforce_start)
    return v, omega, F, T


@njit(**JIT, inline="always")
def _kick_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start):
    """F, T for a kick, which needs no velocities: under gravity alone (no rows of its
    own) they are m g and 0, and the derived quantities are not computed.
    PERF: halves the cost of a semi-implicit step of a body under gravity only."""
    if uforce_start[i] == uforce_start[i + 1]:
        return (mass * gravity[0], mass * gravity[1], mass * gravity[2]), (0.0, 0.0, 0.0)
    v, omega, F, T = _body_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
    return F, T


@njit(**JIT)
def _advance_body(integrator, layout, h, n_steps, i, x, o, P, L, mass, inv_mass, ib, pq, pm, gravity, uforce_kind, uforce_param, uforce_start):
    """n_steps steps of one body whose forces depend on itself only (no springs), in registers:
    the same operations in the same order as ``_one_step`` over all bodies."""
    for _ in range(n_steps):
        if integrator == EXPLICIT_EULER:
            # X(t + h) = X(t) + h dX/dt  (course, "Schéma d'Euler explicite")
            v, w, F, T = _body_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
            dx, do, dP, dL = _derivative(layout, o, v, w, F, T)
            x, o, P, L = _axpy(x, o, P, L, h, dx, do, dP, dL)
        elif integrator == MIDPOINT:
            v, w, F, T = _body_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
            dx, do, dP, dL = _derivative(layout, o, v, w, F, T)
            x1, o1, P1, L1 = _axpy(x, o, P, L, 0.5 * h, dx, do, dP, dL)
            v, w, F, T = _body_forces(layout, i, x1, o1, P1, L1, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
            dx, do, dP, dL = _derivative(layout, o1, v, w, F, T)
            x, o, P, L = _axpy(x, o, P, L, h, dx, do, dP, dL)
        elif integrator == RK4:
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
            x, o, P, L = _axpy(x, o, P, L, h / 6.0, ax, ao, aP, aL)
        elif integrator == SEMI_IMPLICIT_EULER:
            F, T = _kick_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
            P, L = _kick(P, L, F, T, h)
            x, o = _drift(layout, False, h, x, o, P, L, inv_mass, ib, pq, pm)
        else:  # SPLITTING, SPLITTING4: kick (h/2) - drift (h, exact free rotation) - kick (h/2)
            n_sub = 1 if integrator == SPLITTING else 3
            for sub in range(n_sub):
                hh = h if n_sub == 1 else (_YOSHIDA_W0 * h if sub == 1 else _YOSHIDA_W1 * h)
                F, T = _kick_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
                P, L = _kick(P, L, F, T, 0.5 * hh)
                x, o = _drift(layout, True, hh, x, o, P, L, inv_mass, ib, pq, pm)
                F, T = _kick_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
                P, L = _kick(P, L, F, T, 0.5 * hh)
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


@njit(**JIT, parallel=True)
def step_bodies_parallel_kernel(integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start):
    """``step_bodies_kernel`` with the chunks spread over all cores. Each task writes only
    its own rows, so the bits are the same as the serial kernel's for any thread count."""
    n_chunks = (Y.shape[0] + BODY_CHUNK - 1) // BODY_CHUNK
    for c in prange(n_chunks):
        _advance_chunk(c, integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start)


@njit(**JIT)
def step_bodies_kernel(integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start):
    """Advance Y (N, W) in place by n_steps steps of h s when no force couples two bodies (no springs).

    Each body takes all its steps in registers (``_advance_body``): the same
    operations in the same order as ``step_kernel``, so the same bits.
    """
    n_chunks = (Y.shape[0] + BODY_CHUNK - 1) // BODY_CHUNK
    for c in range(n_chunks):
        _advance_chunk(c, integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start)


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


@njit(**JIT)
def step_kernel(
    integrator, layout, h, n_steps,
    Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
    uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param,
    # scratch (N, W) x 3, (N, 3, 3), (N, 3) x 4
    Y1, K, Kacc, Rs, vs, omegas, F, T,
):
    """Advance Y (N, W) in place by n_steps steps of h s, all bodies together stage by stage
    (springs couple them). The whole loop runs compiled. Built-in forces only:
    ``CustomForce`` takes ``Simulator``'s stage-by-stage path, which calls the same
    kernels in the same order and so gives the same bits."""
    for _ in range(n_steps):
        _one_step(
            integrator, layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
            uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param,
            Y1, K, Kacc, Rs, vs, omegas, F, T,
        )


@njit(**JIT)
def _one_step(
    integrator, layout, h,
    Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
    uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param,
    Y1, K, Kacc, Rs, vs, omegas, F, T,
):
    """One step of all bodies together, stage by stage (springs couple them)."""
    if integrator == EXPLICIT_EULER:
        # X(t + h) = X(t) + h dX/dt  (course, "Schéma d'Euler explicite")
        accumulate_forces_kernel(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
        derivative_kernel(layout, Y, Rs, vs, omegas, moving, F, T, K)
        axpy_kernel(Y, h, K, Y)
    elif integrator == MIDPOINT:
        accumulate_forces_kernel(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
        derivative_kernel(layout, Y, Rs, vs, omegas, moving, F, T, K)
        axpy_kernel(Y, 0.5 * h, K, Y1)
        accumulate_forces_kernel(layout, Y1, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
        derivative_kernel(layout, Y1, Rs, vs, omegas, moving, F, T, K)
        axpy_kernel(Y, h, K, Y)
    elif integrator == RK4:
        # k1..k4 with the classic weights 1/6, 1/3, 1/3, 1/6; Kacc sums them.
        accumulate_forces_kernel(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
        derivative_kernel(layout, Y, Rs, vs, omegas, moving, F, T, K)
        axpy_kernel(K, 0.0, K, Kacc)
        axpy_kernel(Y, 0.5 * h, K, Y1)
        for stage in range(3):
            accumulate_forces_kernel(layout, Y1, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
            derivative_kernel(layout, Y1, Rs, vs, omegas, moving, F, T, K)
            if stage < 2:
                axpy_kernel(Kacc, 2.0, K, Kacc)
                axpy_kernel(Y, 0.5 * h if stage == 0 else h, K, Y1)
            else:
                axpy_kernel(Kacc, 1.0, K, Kacc)
        axpy_kernel(Y, h / 6.0, Kacc, Y)
    elif integrator == SEMI_IMPLICIT_EULER:
        accumulate_forces_kernel(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
        kick_kernel(layout, Y, moving, F, T, h)
        drift_kernel(layout, Y, moving, inv_mass, inertia_body_inv, principal_q, principal_moments, False, h)
    elif integrator == SPLITTING:
        _split_step(layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
    elif integrator == SPLITTING4:
        for sub in range(3):
            hh = _YOSHIDA_W0 * h if sub == 1 else _YOSHIDA_W1 * h
            _split_step(layout, hh, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
    project_orientation_kernel(layout, Y, moving)


@njit(**JIT)
def _split_step(
    layout, h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
    uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T,
):
    """Kick (h/2) - drift (h, exact free rotation) - kick (h/2): Strang splitting of forces and free motion."""
    accumulate_forces_kernel(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
    kick_kernel(layout, Y, moving, F, T, 0.5 * h)
    drift_kernel(layout, Y, moving, inv_mass, inertia_body_inv, principal_q, principal_moments, True, h)
    accumulate_forces_kernel(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
    kick_kernel(layout, Y, moving, F, T, 0.5 * h)


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
