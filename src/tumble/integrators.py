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
from .math3d import JIT, matrix_to_quat_into, normalize_quat_inplace, orthonormalize_inplace

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
INTEGRATOR_ORDER = {
    "explicit-euler": 1,
    "semi-implicit-euler": 1,
    "midpoint": 2,
    "rk4": 4,
    "splitting": 2,
    "splitting4": 4,
    "rk45": 5,
    "dop853": 8,
}
ADAPTIVE = {RK45: "RK45", DOP853: "DOP853"}

# Yoshida (1990) triple jump: w1 = 1 / (2 - 2^(1/3)), w0 = 1 - 2 w1.
_YOSHIDA_W1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
_YOSHIDA_W0 = 1.0 - 2.0 * _YOSHIDA_W1


# --------------------------------------------------------------------------- per-body helpers


@njit(**JIT)
def _orientation_matrix(layout, y, R):
    """Fill R (3, 3) from the orientation part of the state row y (W,).

    For the quaternion layout the formula divides by |q|^2, so that
    Runge-Kutta stage states (|q| off 1 by O(h^2)) still give a rotation.
    """
    if layout == LAYOUT_MATRIX:
        for r in range(3):
            for c in range(3):
                R[r, c] = y[3 + 3 * r + c]
    else:
        w, x, yy, z = y[3], y[4], y[5], y[6]
        s = 2.0 / (w * w + x * x + yy * yy + z * z)
        R[0, 0] = 1.0 - s * (yy * yy + z * z)
        R[0, 1] = s * (x * yy - w * z)
        R[0, 2] = s * (x * z + w * yy)
        R[1, 0] = s * (x * yy + w * z)
        R[1, 1] = 1.0 - s * (x * x + z * z)
        R[1, 2] = s * (yy * z - w * x)
        R[2, 0] = s * (x * z - w * yy)
        R[2, 1] = s * (yy * z + w * x)
        R[2, 2] = 1.0 - s * (x * x + yy * yy)


@njit(**JIT)
def _velocities(layout, y, inv_mass, ibody_inv, R, v, omega):
    """Derived quantities of one body (Baraff 2001 eq. 2-40; course "ArrayToBodies").

    v = P / M;  I^-1 = R Ibody^-1 R^T;  omega = I^-1 L.  Writes R, v, omega (3,).
    Computed as omega = R (Ibody^-1 (R^T L)): the same product, 2 x 9 + 9
    multiplications instead of forming I^-1 (27 + 27 + 9).
    """
    W = 13 if layout == LAYOUT_QUATERNION else 18
    _orientation_matrix(layout, y, R)
    pb = W - 6
    lb = W - 3
    for k in range(3):
        v[k] = y[pb + k] * inv_mass
    # L in the body frame: R^T L
    l0 = R[0, 0] * y[lb] + R[1, 0] * y[lb + 1] + R[2, 0] * y[lb + 2]
    l1 = R[0, 1] * y[lb] + R[1, 1] * y[lb + 1] + R[2, 1] * y[lb + 2]
    l2 = R[0, 2] * y[lb] + R[1, 2] * y[lb + 1] + R[2, 2] * y[lb + 2]
    w0 = ibody_inv[0, 0] * l0 + ibody_inv[0, 1] * l1 + ibody_inv[0, 2] * l2
    w1 = ibody_inv[1, 0] * l0 + ibody_inv[1, 1] * l1 + ibody_inv[1, 2] * l2
    w2 = ibody_inv[2, 0] * l0 + ibody_inv[2, 1] * l1 + ibody_inv[2, 2] * l2
    for k in range(3):
        omega[k] = R[k, 0] * w0 + R[k, 1] * w1 + R[k, 2] * w2


@njit(**JIT)
def _unary_forces(i, y, R, v, omega, mass, gravity, uforce_kind, uforce_param, uforce_start, F, T):
    """Force F (3,) N and torque T (3,) N m on body i from gravity and its unary rows, world frame.

    Summed in a fixed order (gravity, then rows in the order the user added
    them), as ``tumble.reference.compute_force_and_torque`` does.
    """
    for k in range(3):
        F[k] = mass * gravity[k]
        T[k] = 0.0
    for r in range(uforce_start[i], uforce_start[i + 1]):
        kind = uforce_kind[r]
        p = uforce_param[r]
        if kind == UFORCE_DRAG:
            u0 = v[0] - p[4]
            u1 = v[1] - p[5]
            u2 = v[2] - p[6]
            c = p[0] + p[1] * math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
            F[0] -= c * u0
            F[1] -= c * u1
            F[2] -= c * u2
            ca = p[2] + p[3] * math.sqrt(omega[0] ** 2 + omega[1] ** 2 + omega[2] ** 2)
            T[0] -= ca * omega[0]
            T[1] -= ca * omega[1]
            T[2] -= ca * omega[2]
        elif kind == UFORCE_CONSTANT:
            for k in range(3):
                F[k] += p[k]
                T[k] += p[3 + k]
        else:
            # r = p - x: the lever arm of the force about the centre of mass
            if kind == UFORCE_POINT_WORLD:
                r0 = p[3] - y[0]
                r1 = p[4] - y[1]
                r2 = p[5] - y[2]
            else:  # UFORCE_POINT_BODY: world point R p_body + x, so r = R p_body
                r0 = R[0, 0] * p[3] + R[0, 1] * p[4] + R[0, 2] * p[5]
                r1 = R[1, 0] * p[3] + R[1, 1] * p[4] + R[1, 2] * p[5]
                r2 = R[2, 0] * p[3] + R[2, 1] * p[4] + R[2, 2] * p[5]
            F[0] += p[0]
            F[1] += p[1]
            F[2] += p[2]
            T[0] += r1 * p[2] - r2 * p[1]
            T[1] += r2 * p[0] - r0 * p[2]
            T[2] += r0 * p[1] - r1 * p[0]


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


# --------------------------------------------------------------------------- stage kernels


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
    n = Y.shape[0]
    for i in range(n):
        _velocities(layout, Y[i], inv_mass[i], inertia_body_inv[i], Rs[i], vs[i], omegas[i])
        if moving[i]:
            _unary_forces(i, Y[i], Rs[i], vs[i], omegas[i], mass[i], gravity, uforce_kind, uforce_param, uforce_start, F[i], T[i])
        else:
            for k in range(3):
                F[i, k] = 0.0
                T[i, k] = 0.0
    if spring_body.shape[0] > 0:
        _spring_forces(Y, Rs, vs, omegas, moving, spring_body, spring_anchor, spring_param, F, T)


# --------------------------------------------------------------------------- per-row operations
# Every integrator is written once in terms of these row functions; the
# all-bodies kernels below and the per-body fast path (``_advance_body``) call
# the same functions in the same order, so both give the same bits.


@njit(**JIT)
def _row_derivative(layout, y, v, omega, F, T, dy):
    """dX/dt of one body: (v, omega* R, F, tau) (course Algorithm 4; ERRATA 1), or
    (v, 1/2 (0, omega) q, F, tau) in the quaternion layout (Baraff 2001 eq. 4-2)."""
    W = y.shape[0]
    w0, w1, w2 = omega[0], omega[1], omega[2]
    for k in range(3):
        dy[k] = v[k]
    if layout == LAYOUT_MATRIX:
        # (omega* R)[r, c] = (omega x R[:, c])[r]
        for c in range(3):
            r0, r1, r2 = y[3 + c], y[6 + c], y[9 + c]
            dy[3 + c] = w1 * r2 - w2 * r1
            dy[6 + c] = w2 * r0 - w0 * r2
            dy[9 + c] = w0 * r1 - w1 * r0
    else:
        qw, qx, qy, qz = y[3], y[4], y[5], y[6]
        dy[3] = 0.5 * (-w0 * qx - w1 * qy - w2 * qz)
        dy[4] = 0.5 * (w0 * qw + w1 * qz - w2 * qy)
        dy[5] = 0.5 * (-w0 * qz + w1 * qw + w2 * qx)
        dy[6] = 0.5 * (w0 * qy - w1 * qx + w2 * qw)
    for k in range(3):
        dy[W - 6 + k] = F[k]
        dy[W - 3 + k] = T[k]


@njit(**JIT)
def _axpy_row(y0, a, dy, out):
    """out = y0 + a dy for one row (W,)."""
    for k in range(y0.shape[0]):
        out[k] = y0[k] + a * dy[k]


@njit(**JIT)
def _kick_row(y, F, T, h):
    """P += h F, L += h tau (the 'kick' of the symplectic methods)."""
    W = y.shape[0]
    for k in range(3):
        y[W - 6 + k] += h * F[k]
        y[W - 3 + k] += h * T[k]


@njit(**JIT)
def _project_row(layout, y):
    """Pull the orientation back onto SO(3) (ERRATA 5): normalise q, or Gram-Schmidt R."""
    if layout == LAYOUT_MATRIX:
        orthonormalize_inplace(y[3:12].reshape((3, 3)))
    else:
        normalize_quat_inplace(y[3:7])


@njit(**JIT)
def _set_matrix_of_quat(q0, q1, q2, q3, M):
    """M (3, 3) <- rotation matrix of the unit quaternion (q0, q1, q2, q3)."""
    M[0, 0] = 1.0 - 2.0 * (q2 * q2 + q3 * q3)
    M[0, 1] = 2.0 * (q1 * q2 - q0 * q3)
    M[0, 2] = 2.0 * (q1 * q3 + q0 * q2)
    M[1, 0] = 2.0 * (q1 * q2 + q0 * q3)
    M[1, 1] = 1.0 - 2.0 * (q1 * q1 + q3 * q3)
    M[1, 2] = 2.0 * (q2 * q3 - q0 * q1)
    M[2, 0] = 2.0 * (q1 * q3 - q0 * q2)
    M[2, 1] = 2.0 * (q2 * q3 + q0 * q1)
    M[2, 2] = 1.0 - 2.0 * (q1 * q1 + q2 * q2)


@njit(**JIT)
def _rotate_row(layout, y, wx, wy, wz, h, M):
    """Turn the orientation of row y by the exact rotation of constant world angular velocity w over h.

    Quaternion: q <- exp(h/2 (0, w)) q. Matrix: R <- Rodrigues(h w) R.
    M (3, 3) is scratch.
    """
    n = math.sqrt(wx * wx + wy * wy + wz * wz)
    half = 0.5 * h * n
    c = math.cos(half)
    # sin(half)/n, with its series for tiny |w| (no 0/0, full precision)
    s = math.sin(half) / n if half > 1e-4 else 0.5 * h * (1.0 - half * half / 6.0)
    dw, dx, dy, dz = c, s * wx, s * wy, s * wz
    if layout == LAYOUT_QUATERNION:
        w, x, yy, z = y[3], y[4], y[5], y[6]
        y[3] = dw * w - dx * x - dy * yy - dz * z
        y[4] = dw * x + dx * w + dy * z - dz * yy
        y[5] = dw * yy - dx * z + dy * w + dz * x
        y[6] = dw * z + dx * yy - dy * x + dz * w
    else:
        _set_matrix_of_quat(dw, dx, dy, dz, M)
        for col in range(3):
            r0, r1, r2 = y[3 + col], y[6 + col], y[9 + col]
            y[3 + col] = M[0, 0] * r0 + M[0, 1] * r1 + M[0, 2] * r2
            y[6 + col] = M[1, 0] * r0 + M[1, 1] * r1 + M[1, 2] * r2
            y[9 + col] = M[2, 0] * r0 + M[2, 1] * r1 + M[2, 2] * r2


@njit(**JIT)
def _principal_flow(k, tau, Ik, l0, l1, l2, d):
    """The exact flow of H_k = Lk^2 / (2 Ik) over tau: the frame turns about principal axis k
    by theta = tau Lk / Ik. Returns L seen from the turned frame (Rot_k(theta)^T L) and
    d (cos theta/2, sin theta/2 e_k) (a body-frame turn composes on the right)."""
    d0, d1, d2, d3 = d
    lk = l0 if k == 0 else (l1 if k == 1 else l2)
    theta = tau * lk / Ik
    c = math.cos(theta)
    s = math.sin(theta)
    ch = math.cos(0.5 * theta)
    sh = math.sin(0.5 * theta)
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


@njit(**JIT)
def _split_rotation_row(layout, y, principal_q, principal_moments, h, R, M):
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

    principal_q (4,): principal axes to body axes (Ibody = Q diag(I) Q^T);
    principal_moments (3,) kg m^2, ascending, so the middle (full-h) flow is
    about the largest moment. R, M (3, 3) are scratch.
    """
    W = y.shape[0]
    _orientation_matrix(layout, y, R)
    pw, px, py, pz = principal_q[0], principal_q[1], principal_q[2], principal_q[3]
    _set_matrix_of_quat(pw, px, py, pz, M)
    # L in the principal frame: Lp = Q^T R^T L
    L0, L1, L2 = y[W - 3], y[W - 2], y[W - 1]
    b0 = R[0, 0] * L0 + R[1, 0] * L1 + R[2, 0] * L2
    b1 = R[0, 1] * L0 + R[1, 1] * L1 + R[2, 1] * L2
    b2 = R[0, 2] * L0 + R[1, 2] * L1 + R[2, 2] * L2
    l0 = M[0, 0] * b0 + M[1, 0] * b1 + M[2, 0] * b2
    l1 = M[0, 1] * b0 + M[1, 1] * b1 + M[2, 1] * b2
    l2 = M[0, 2] * b0 + M[1, 2] * b1 + M[2, 2] * b2
    # d: the turn of the principal frame over h, as a quaternion, from the five flows
    I0, I1, I2 = principal_moments[0], principal_moments[1], principal_moments[2]
    d = (1.0, 0.0, 0.0, 0.0)
    l0, l1, l2, d = _principal_flow(0, 0.5 * h, I0, l0, l1, l2, d)
    l0, l1, l2, d = _principal_flow(1, 0.5 * h, I1, l0, l1, l2, d)
    l0, l1, l2, d = _principal_flow(2, h, I2, l0, l1, l2, d)
    l0, l1, l2, d = _principal_flow(1, 0.5 * h, I1, l0, l1, l2, d)
    l0, l1, l2, d = _principal_flow(0, 0.5 * h, I0, l0, l1, l2, d)
    # the same rotation in body axes: g = pq d conj(pq)
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
        # q <- q g
        w, x, yy, z = y[3], y[4], y[5], y[6]
        y[3] = w * g0 - x * g1 - yy * g2 - z * g3
        y[4] = w * g1 + x * g0 + yy * g3 - z * g2
        y[5] = w * g2 - x * g3 + yy * g0 + z * g1
        y[6] = w * g3 + x * g2 - yy * g1 + z * g0
    else:
        # R <- R M(g)
        _set_matrix_of_quat(g0, g1, g2, g3, M)
        for r in range(3):
            r0, r1, r2 = y[3 + 3 * r], y[4 + 3 * r], y[5 + 3 * r]
            y[3 + 3 * r] = r0 * M[0, 0] + r1 * M[1, 0] + r2 * M[2, 0]
            y[4 + 3 * r] = r0 * M[0, 1] + r1 * M[1, 1] + r2 * M[2, 1]
            y[5 + 3 * r] = r0 * M[0, 2] + r1 * M[1, 2] + r2 * M[2, 2]


@njit(**JIT)
def _drift_row(layout, split, h, y, inv_mass, ibody_inv, principal_q, principal_moments, R, v, omega, M):
    """x += h P / M, and the orientation turned over h: at the constant omega = I^-1(R) L
    (split=False, semi-implicit Euler) or by the free-rotation splitting (split=True)."""
    W = y.shape[0]
    for k in range(3):
        y[k] += h * y[W - 6 + k] * inv_mass
    if split:
        _split_rotation_row(layout, y, principal_q, principal_moments, h, R, M)
    else:
        _velocities(layout, y, inv_mass, ibody_inv, R, v, omega)
        _rotate_row(layout, y, omega[0], omega[1], omega[2], h, M)


# --------------------------------------------------------------------------- all-bodies kernels


@njit(**JIT)
def derivative_kernel(layout, Y, Rs, vs, omegas, moving, F, T, dY):
    """dX/dt (N, W) for all bodies from the derived quantities and forces (zero for fixed bodies)."""
    for i in range(Y.shape[0]):
        if moving[i]:
            _row_derivative(layout, Y[i], vs[i], omegas[i], F[i], T[i], dY[i])
        else:
            dY[i, :] = 0.0


@njit(**JIT)
def project_orientation_kernel(layout, Y, moving):
    """Every moving body's orientation back onto SO(3) (ERRATA 5)."""
    for i in range(Y.shape[0]):
        if moving[i]:
            _project_row(layout, Y[i])


@njit(**JIT)
def kick_kernel(layout, Y, moving, F, T, h):
    """P += h F, L += h tau for every moving body."""
    for i in range(Y.shape[0]):
        if moving[i]:
            _kick_row(Y[i], F[i], T[i], h)


@njit(**JIT)
def drift_kernel(layout, Y, moving, inv_mass, inertia_body_inv, principal_q, principal_moments, split, h):
    """``_drift_row`` for every moving body."""
    R = np.empty((3, 3))
    M = np.empty((3, 3))
    v = np.empty(3)
    omega = np.empty(3)
    for i in range(Y.shape[0]):
        if moving[i]:
            _drift_row(layout, split, h, Y[i], inv_mass[i], inertia_body_inv[i], principal_q[i], principal_moments[i], R, v, omega, M)


@njit(**JIT)
def axpy_kernel(Y0, a, dY, out):
    """out = Y0 + a dY (N, W), row by row; the building block of the Runge-Kutta stages."""
    for i in range(Y0.shape[0]):
        _axpy_row(Y0[i], a, dY[i], out[i])


# --------------------------------------------------------------------------- stepping


@njit(**JIT)
def _body_forces(layout, i, y, mass, inv_mass, ibody_inv, gravity, uforce_kind, uforce_param, uforce_start, R, v, omega, F, T):
    """Derived R, v, omega and the force and torque on body i alone (no springs)."""
    _velocities(layout, y, inv_mass, ibody_inv, R, v, omega)
    _unary_forces(i, y, R, v, omega, mass, gravity, uforce_kind, uforce_param, uforce_start, F, T)


@njit(**JIT)
def _body_kick_forces(layout, i, y, mass, inv_mass, ibody_inv, gravity, uforce_kind, uforce_param, uforce_start, R, v, omega, F, T):
    """F, T on body i for a kick, which needs no velocities: with gravity alone
    (no rows of its own) they are m g and 0, and the derived quantities are skipped.
    PERF: halves the cost of a semi-implicit step of a body under gravity only."""
    if uforce_start[i] == uforce_start[i + 1]:
        for k in range(3):
            F[k] = mass * gravity[k]
            T[k] = 0.0
    else:
        _body_forces(layout, i, y, mass, inv_mass, ibody_inv, gravity, uforce_kind, uforce_param, uforce_start, R, v, omega, F, T)


@njit(**JIT)
def _advance_body(
    integrator, layout, h, n_steps, i, y, mass, inv_mass, ibody_inv, principal_q, principal_moments, gravity,
    uforce_kind, uforce_param, uforce_start,
    # scratch
    y1, k, kacc, R, v, omega, F, T, M,
):
    """n_steps steps of one body whose forces depend on itself only (no springs):
    the same row operations, in the same order, as ``_one_step`` over all bodies."""
    for _ in range(n_steps):
        if integrator == EXPLICIT_EULER:
            _body_forces(layout, i, y, mass, inv_mass, ibody_inv, gravity, uforce_kind, uforce_param, uforce_start, R, v, omega, F, T)
            _row_derivative(layout, y, v, omega, F, T, k)
            _axpy_row(y, h, k, y)
        elif integrator == MIDPOINT:
            _body_forces(layout, i, y, mass, inv_mass, ibody_inv, gravity, uforce_kind, uforce_param, uforce_start, R, v, omega, F, T)
            _row_derivative(layout, y, v, omega, F, T, k)
            _axpy_row(y, 0.5 * h, k, y1)
            _body_forces(layout, i, y1, mass, inv_mass, ibody_inv, gravity, uforce_kind, uforce_param, uforce_start, R, v, omega, F, T)
            _row_derivative(layout, y1, v, omega, F, T, k)
            _axpy_row(y, h, k, y)
        elif integrator == RK4:
            _body_forces(layout, i, y, mass, inv_mass, ibody_inv, gravity, uforce_kind, uforce_param, uforce_start, R, v, omega, F, T)
            _row_derivative(layout, y, v, omega, F, T, k)
            _axpy_row(k, 0.0, k, kacc)
            _axpy_row(y, 0.5 * h, k, y1)
            for stage in range(3):
                _body_forces(layout, i, y1, mass, inv_mass, ibody_inv, gravity, uforce_kind, uforce_param, uforce_start, R, v, omega, F, T)
                _row_derivative(layout, y1, v, omega, F, T, k)
                if stage < 2:
                    _axpy_row(kacc, 2.0, k, kacc)
                    _axpy_row(y, 0.5 * h if stage == 0 else h, k, y1)
                else:
                    _axpy_row(kacc, 1.0, k, kacc)
            _axpy_row(y, h / 6.0, kacc, y)
        elif integrator == SEMI_IMPLICIT_EULER:
            _body_kick_forces(layout, i, y, mass, inv_mass, ibody_inv, gravity, uforce_kind, uforce_param, uforce_start, R, v, omega, F, T)
            _kick_row(y, F, T, h)
            _drift_row(layout, False, h, y, inv_mass, ibody_inv, principal_q, principal_moments, R, v, omega, M)
        else:  # SPLITTING, SPLITTING4
            n_sub = 1 if integrator == SPLITTING else 3
            for sub in range(n_sub):
                hh = h if n_sub == 1 else (_YOSHIDA_W0 * h if sub == 1 else _YOSHIDA_W1 * h)
                _body_kick_forces(layout, i, y, mass, inv_mass, ibody_inv, gravity, uforce_kind, uforce_param, uforce_start, R, v, omega, F, T)
                _kick_row(y, F, T, 0.5 * hh)
                _drift_row(layout, True, hh, y, inv_mass, ibody_inv, principal_q, principal_moments, R, v, omega, M)
                _body_kick_forces(layout, i, y, mass, inv_mass, ibody_inv, gravity, uforce_kind, uforce_param, uforce_start, R, v, omega, F, T)
                _kick_row(y, F, T, 0.5 * hh)
        _project_row(layout, y)


# Bodies per task of the parallel loop: large enough that the scratch allocations
# are amortised, small enough that both cores get work at N = 1000.
BODY_CHUNK = 64
# Below this many bodies the serial kernel is used: launching threads costs more
# than it saves (and oversubscribed cores make each launch slower still).
PARALLEL_MIN_BODIES = 512


@njit(**JIT)
def _advance_chunk(
    c, integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
    uforce_kind, uforce_param, uforce_start,
):
    """``_advance_body`` for the bodies of chunk c, with scratch allocated once for the chunk."""
    W = Y.shape[1]
    n = Y.shape[0]
    y1 = np.empty(W)
    k = np.empty(W)
    kacc = np.empty(W)
    R = np.empty((3, 3))
    M = np.empty((3, 3))
    v = np.empty(3)
    omega = np.empty(3)
    F = np.empty(3)
    T = np.empty(3)
    for i in range(c * BODY_CHUNK, min(n, (c + 1) * BODY_CHUNK)):
        if moving[i]:
            _advance_body(
                integrator, layout, h, n_steps, i, Y[i], mass[i], inv_mass[i], inertia_body_inv[i],
                principal_q[i], principal_moments[i], gravity, uforce_kind, uforce_param, uforce_start,
                y1, k, kacc, R, v, omega, F, T, M,
            )


@njit(cache=True, nogil=True, fastmath=False, parallel=True)
def step_bodies_parallel_kernel(
    integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
    uforce_kind, uforce_param, uforce_start,
):
    """``step_bodies_kernel`` with the chunks spread over all cores. Each task writes only
    its own rows, so the bits are the same as the serial kernel's for any thread count."""
    n_chunks = (Y.shape[0] + BODY_CHUNK - 1) // BODY_CHUNK
    for c in prange(n_chunks):
        _advance_chunk(c, integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start)


@njit(**JIT)
def step_bodies_kernel(
    integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
    uforce_kind, uforce_param, uforce_start,
):
    """Advance Y (N, W) by n_steps steps of h when no force couples two bodies (no springs).

    Each body takes all its steps while its row is in cache (``_advance_body``):
    the same row operations in the same order as ``step_kernel``, so the same bits.
    """
    n_chunks = (Y.shape[0] + BODY_CHUNK - 1) // BODY_CHUNK
    for c in range(n_chunks):
        _advance_chunk(c, integrator, layout, h, n_steps, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start)


@njit(**JIT)
def step_kernel(
    integrator, layout, h, n_steps,
    Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
    uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param,
    # scratch (N, W) x 3, (N, 3, 3), (N, 3) x 4
    Y1, K, Kacc, Rs, vs, omegas, F, T,
):
    """Advance Y (N, W) by n_steps steps of h seconds with a fixed-step integrator, in place,
    all bodies together stage by stage (springs couple them).

    The whole loop runs compiled: no Python between steps. Built-in forces only:
    ``CustomForce`` takes ``Simulator``'s stage-by-stage path, which calls the
    same kernels in the same order and so gives the same bits.
    """
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
def matrices_to_quaternions_kernel(R, q_prev, out):
    """out (N, 4): unit quaternions of R (N, 3, 3), each on the hemisphere of q_prev (N, 4)
    so that recorded orientations never jump sign between frames."""
    for i in range(R.shape[0]):
        matrix_to_quat_into(R[i], out[i])
        dot = out[i, 0] * q_prev[i, 0] + out[i, 1] * q_prev[i, 1] + out[i, 2] * q_prev[i, 2] + out[i, 3] * q_prev[i, 3]
        if dot < 0.0:
            for k in range(4):
                out[i, k] = -out[i, k]


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
        for r in range(3):
            for c in range(3):
                acc = 0.0
                for a in range(3):
                    for b in range(3):
                        acc += R[i, r, a] * inertia_body_inv[i, a, b] * R[i, c, b]
                I_inv[i, r, c] = acc
