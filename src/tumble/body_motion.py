"""One body's free motion in registers: the building blocks of every integrator.

A body's state travels between these functions as four tuples of floats,
(x, o, P, L): x (3,) m, o (9,) the orientation (the quaternion layout uses
o[0:4] = q, w x y z, and leaves o[4:9] zero; the matrix layout has R row-major),
P (3,) kg m/s, L (3,) kg m^2/s, all world frame. Tuples stay in registers, where
array rows would go through memory: PERF: the same per-body step written over
(W,) array rows ran 3x slower. Every integrator (``tumble.integrators``) and the
contact step (``solver.soft_step``) is written on top of these functions; the
all-bodies kernels load rows, call the same functions and store rows, so every
path gives the same bits.

Here: the state row's load and store, the derived R, v, omega (course
"ArrayToBodies"), a body's own forces (gravity, drag, constant and point forces),
dX/dt (course Algorithm 4), the Runge-Kutta combination, the projection back onto
SO(3) (ERRATA 5), the exact rotation at constant omega, and the free rotation
split into principal-axis flows.
"""

from __future__ import annotations

import math

from numba import njit

from .forces import UFORCE_CONSTANT, UFORCE_DAMPING, UFORCE_DRAG, UFORCE_FLUID, UFORCE_POINT_WORLD
from .math3d import JIT

LAYOUT_QUATERNION, LAYOUT_MATRIX = 0, 1
LAYOUT_IDS = {"quaternion": LAYOUT_QUATERNION, "matrix": LAYOUT_MATRIX}
STATE_WIDTH = {LAYOUT_QUATERNION: 13, LAYOUT_MATRIX: 18}


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
    omega = _mat_vec9(R, _mat_vec9(ib, _mat_t_vec9(R, L)))
    return R, v, omega


@njit(**JIT, inline="always")
def _fluid_force(R, v, omega, p):
    """``forces.Fluid`` on one body: (F (3,) N, T (3,) N m), world, at the centre of mass, from R (9,)
    row-major body-to-world, v, omega (3,) world and its table row p (``ForceTables``: box sides,
    density, viscosity, wind, the box's axes in the body frame as a quaternion). MuJoCo's
    inertia-box model (``mj_inertiaBoxFluidModel``: engine_passive.c), in the box's axes."""
    b0, b1, b2, rho, beta = p[0], p[1], p[2], p[3], p[4]
    # E: the box's axes (columns) in the world, R A (A: in the body frame, from its quaternion)
    E = _matmul9(R, _quat_matrix(p[8], p[9], p[10], p[11], 2.0))
    # in the box's axes: u = E^T (v - wind), w = E^T omega
    u = _mat_t_vec9(E, (v[0] - p[5], v[1] - p[6], v[2] - p[7]))
    w = _mat_t_vec9(E, omega)
    d = (b0 + b1 + b2) / 3.0
    lin = 3.0 * math.pi * d * beta
    ang = math.pi * d * d * d * beta
    b04, b14, b24 = b0 * b0 * b0 * b0, b1 * b1 * b1 * b1, b2 * b2 * b2 * b2
    f = (-lin * u[0] - 0.5 * rho * b1 * b2 * abs(u[0]) * u[0],
         -lin * u[1] - 0.5 * rho * b0 * b2 * abs(u[1]) * u[1],
         -lin * u[2] - 0.5 * rho * b0 * b1 * abs(u[2]) * u[2])
    t = (-ang * w[0] - rho * b0 * (b14 + b24) * abs(w[0]) * w[0] / 64.0,
         -ang * w[1] - rho * b1 * (b04 + b24) * abs(w[1]) * w[1] / 64.0,
         -ang * w[2] - rho * b2 * (b04 + b14) * abs(w[2]) * w[2] / 64.0)
    return _mat_vec9(E, f), _mat_vec9(E, t)


@njit(**JIT, inline="always")
def _mat_vec9(M, a):
    """M a for a row-major 9-tuple M and a 3-vector a."""
    return (M[0] * a[0] + M[1] * a[1] + M[2] * a[2], M[3] * a[0] + M[4] * a[1] + M[5] * a[2],
            M[6] * a[0] + M[7] * a[1] + M[8] * a[2])


@njit(**JIT, inline="always")
def _mat_t_vec9(M, a):
    """M^T a for a row-major 9-tuple M and a 3-vector a."""
    return (M[0] * a[0] + M[3] * a[1] + M[6] * a[2], M[1] * a[0] + M[4] * a[1] + M[7] * a[2],
            M[2] * a[0] + M[5] * a[1] + M[8] * a[2])


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
        elif kind == UFORCE_FLUID:
            f, t = _fluid_force(R, v, omega, p)
            F0 += f[0]
            F1 += f[1]
            F2 += f[2]
            T0 += t[0]
            T1 += t[1]
            T2 += t[2]
        elif kind == UFORCE_DAMPING:
            # F = -c m v; tau = -c_a L with L = R Ibody R^T omega (World.set_damping): the velocity
            # and the angular momentum decay as e^(-c t), e^(-c_a t) under nothing else
            F0 -= p[0] * v[0]
            F1 -= p[0] * v[1]
            F2 -= p[0] * v[2]
            wb0, wb1, wb2 = _mat_t_vec9(R, omega)  # omega in the body axes
            lb0 = p[2] * wb0 + p[3] * wb1 + p[4] * wb2
            lb1 = p[5] * wb0 + p[6] * wb1 + p[7] * wb2
            lb2 = p[8] * wb0 + p[9] * wb1 + p[10] * wb2
            l0, l1, l2 = _mat_vec9(R, (lb0, lb1, lb2))
            T0 -= p[1] * l0
            T1 -= p[1] * l1
            T2 -= p[1] * l2
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
                r0, r1, r2 = _mat_vec9(R, (p[3], p[4], p[5]))
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
    l0, l1, l2 = _mat_t_vec9(Q, _mat_t_vec9(R, L))
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


# The splitting's closing half-kick P = P_half + h/2 F(x, P) is solved by fixed-point iteration
# when a force reads the velocities: at most this many passes (each contracts by h c / 2m for a
# linear damping c: 0.02 at a rate of 10/s and dt 1/240, converged in 9 passes).
KICK_ITERATIONS = 32
# A pass that changes the momenta by at most this (relative, ``_kick_change``) has converged; one
# that stops contracting above KICK_STALLED keeps the explicit kick (below it, rounding near the root).
KICK_CONVERGED = 4.0 * 2.220446049250313e-16
KICK_STALLED = 1e-12
# what the next pass does (``_kick_verdict``)
KICK_GO_ON, KICK_KEEP, KICK_EXPLICIT = 0, 1, 2


@njit(**JIT, inline="always")
def _velocity_rows(uforce_kind, first, stop):
    """Whether a force row among ``first:stop`` reads the velocities (drag, wind, fluid, damping)."""
    for r in range(first, stop):
        kind = uforce_kind[r]
        if kind == UFORCE_DRAG or kind == UFORCE_FLUID or kind == UFORCE_DAMPING:
            return True
    return False


@njit(**JIT, inline="always")
def _kick_verdict(change, last):
    """After a pass of the closing kick's iteration that changed the momenta by ``change`` (the
    pass before: ``last``): KICK_GO_ON, KICK_KEEP (converged, or stalled at rounding) or
    KICK_EXPLICIT (not contracting: the explicit kick)."""
    if change <= KICK_CONVERGED:
        return KICK_KEEP
    if change >= last:
        return KICK_KEEP if change <= KICK_STALLED else KICK_EXPLICIT
    return KICK_GO_ON


@njit(**JIT, inline="always")
def _closing_kick(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start, h):
    """The splitting's closing half-kick (P, L) + h (F, tau) with the forces of its END momenta,
    solved by fixed-point iteration when a force reads the velocities (else one explicit kick:
    the forces do not depend on P, L and the two are the same).

    NOTE: why: the opening kick is explicit Euler E(h/2) on the momenta; closing with its adjoint,
    implicit Euler E*(h/2), makes E*(h/2) o drift(h) o E(h/2) symmetric, hence of order 2 and
    Yoshida's composition of order 4 (Hairer, Lubich and Wanner, Geometric Numerical
    Integration, II.3 and V.3: the Stormer-Verlet scheme of a non-separable system). Two
    explicit kicks were not symmetric under drag or damping: both splittings measured order 1
    (a course audit, session 42). Where the iteration does not contract (h c / 2m >= 1 for a
    damping c) the explicit kick is kept, as before."""
    F, T = _kick_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
    P0, L0 = _kick(P, L, F, T, h)
    if not _velocity_rows(uforce_kind, uforce_start[i], uforce_start[i + 1]):
        return P0, L0
    P1, L1 = P0, L0
    last = math.inf
    for _ in range(KICK_ITERATIONS):
        F, T = _kick_forces(layout, i, x, o, P1, L1, mass, inv_mass, ib, gravity, uforce_kind, uforce_param,
                            uforce_start)
        P2, L2 = _kick(P, L, F, T, h)
        change = _kick_change(P1, L1, P2, L2, P, L)
        P1, L1 = P2, L2
        verdict = _kick_verdict(change, last)
        if verdict == KICK_KEEP:
            return P1, L1
        if verdict == KICK_EXPLICIT:
            return P0, L0
        last = change
    return P1, L1


@njit(**JIT, inline="always")
def _kick_change(P1, L1, P2, L2, P, L):
    """The larger of |P2 - P1| and |L2 - L1| relative to the momenta the kick starts from and
    gives (P, L and P2, L2; max norms; 0 where a change is 0)."""
    dP = max(abs(P2[0] - P1[0]), abs(P2[1] - P1[1]), abs(P2[2] - P1[2]))
    dL = max(abs(L2[0] - L1[0]), abs(L2[1] - L1[1]), abs(L2[2] - L1[2]))
    sP = max(abs(P2[0]), abs(P2[1]), abs(P2[2]), abs(P[0]), abs(P[1]), abs(P[2]))
    sL = max(abs(L2[0]), abs(L2[1]), abs(L2[2]), abs(L[0]), abs(L[1]), abs(L[2]))
    return max(dP / sP if dP > 0.0 else 0.0, dL / sL if dL > 0.0 else 0.0)


@njit(**JIT, inline="always")
def _kick_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start):
    """F, T for a kick, which needs no velocities: under gravity alone (no rows of its
    own) they are m g and 0, and the derived quantities are not computed.
    PERF: halves the cost of a semi-implicit step of a body under gravity only."""
    if uforce_start[i] == uforce_start[i + 1]:
        return (mass * gravity[0], mass * gravity[1], mass * gravity[2]), (0.0, 0.0, 0.0)
    v, omega, F, T = _body_forces(layout, i, x, o, P, L, mass, inv_mass, ib, gravity, uforce_kind, uforce_param, uforce_start)
    return F, T
