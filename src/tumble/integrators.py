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
from numba import njit

from .forces import UFORCE_CONSTANT, UFORCE_DRAG, UFORCE_POINT_BODY, UFORCE_POINT_WORLD
from .math3d import JIT, normalize_quat_inplace, orthonormalize_inplace

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


@njit(**JIT)
def derivative_kernel(layout, Y, Rs, vs, omegas, moving, F, T, dY):
    """dX/dt = (v, omega* R, F, tau) per body (course Algorithm 4; ERRATA 1), or
    (v, 1/2 (0, omega) q, F, tau) in the quaternion layout (Baraff 2001 eq. 4-2).

    Writes dY (N, W). Fixed bodies have a zero derivative.
    """
    n = Y.shape[0]
    W = Y.shape[1]
    for i in range(n):
        if not moving[i]:
            for k in range(W):
                dY[i, k] = 0.0
            continue
        w0, w1, w2 = omegas[i, 0], omegas[i, 1], omegas[i, 2]
        for k in range(3):
            dY[i, k] = vs[i, k]
        if layout == LAYOUT_MATRIX:
            # (omega* R)[r, c] = (omega x R[:, c])[r]
            for c in range(3):
                r0, r1, r2 = Y[i, 3 + c], Y[i, 6 + c], Y[i, 9 + c]
                dY[i, 3 + c] = w1 * r2 - w2 * r1
                dY[i, 6 + c] = w2 * r0 - w0 * r2
                dY[i, 9 + c] = w0 * r1 - w1 * r0
        else:
            qw, qx, qy, qz = Y[i, 3], Y[i, 4], Y[i, 5], Y[i, 6]
            dY[i, 3] = 0.5 * (-w0 * qx - w1 * qy - w2 * qz)
            dY[i, 4] = 0.5 * (w0 * qw + w1 * qz - w2 * qy)
            dY[i, 5] = 0.5 * (-w0 * qz + w1 * qw + w2 * qx)
            dY[i, 6] = 0.5 * (w0 * qy - w1 * qx + w2 * qw)
        for k in range(3):
            dY[i, W - 6 + k] = F[i, k]
            dY[i, W - 3 + k] = T[i, k]


@njit(**JIT)
def project_orientation_kernel(layout, Y, moving):
    """Pull every orientation back onto SO(3) (ERRATA 5): normalise q, or Gram-Schmidt R."""
    for i in range(Y.shape[0]):
        if not moving[i]:
            continue
        if layout == LAYOUT_MATRIX:
            R = Y[i, 3:12].reshape((3, 3))
            orthonormalize_inplace(R)
        else:
            normalize_quat_inplace(Y[i, 3:7])


@njit(**JIT)
def _rotate_orientation(layout, y, wx, wy, wz, h):
    """Apply the exact rotation of constant world angular velocity w over h to the orientation of row y.

    Quaternion: q <- exp(h/2 (0, w)) q. Matrix: R <- Rodrigues(h w) R.
    """
    n = math.sqrt(wx * wx + wy * wy + wz * wz)
    angle = h * n
    if layout == LAYOUT_QUATERNION:
        half = 0.5 * angle
        c = math.cos(half)
        s = math.sin(half) / n if half > 1e-4 else 0.5 * h * (1.0 - half * half / 6.0)
        dw, dx, dy, dz = c, s * wx, s * wy, s * wz
        w, x, yy, z = y[3], y[4], y[5], y[6]
        y[3] = dw * w - dx * x - dy * yy - dz * z
        y[4] = dw * x + dx * w + dy * z - dz * yy
        y[5] = dw * yy - dx * z + dy * w + dz * x
        y[6] = dw * z + dx * yy - dy * x + dz * w
    else:
        if angle == 0.0:
            return
        ax, ay, az = wx / n, wy / n, wz / n
        c = math.cos(angle)
        s = math.sin(angle)
        t = 1.0 - c
        Q = np.empty((3, 3))
        Q[0, 0] = c + ax * ax * t
        Q[0, 1] = ax * ay * t - az * s
        Q[0, 2] = ax * az * t + ay * s
        Q[1, 0] = ay * ax * t + az * s
        Q[1, 1] = c + ay * ay * t
        Q[1, 2] = ay * az * t - ax * s
        Q[2, 0] = az * ax * t - ay * s
        Q[2, 1] = az * ay * t + ax * s
        Q[2, 2] = c + az * az * t
        _left_multiply_rows(y, Q)


@njit(**JIT)
def _left_multiply_rows(y, Q):
    """R <- Q R for the row-major R stored at y[3:12]."""
    R = np.empty((3, 3))
    for r in range(3):
        for c in range(3):
            R[r, c] = y[3 + 3 * r + c]
    for r in range(3):
        for c in range(3):
            y[3 + 3 * r + c] = Q[r, 0] * R[0, c] + Q[r, 1] * R[1, c] + Q[r, 2] * R[2, c]


@njit(**JIT)
def _free_rotation_split(layout, y, principal_q, principal_moments, h):
    """Free rigid-body rotation over h by Strang splitting into exact principal-axis rotations.

    The torque-free Hamiltonian H = sum_k Lk^2 / (2 Ik) (L in the principal
    body frame) splits into three parts, each of which is a rotation about one
    principal axis at the constant rate Lk / Ik: the body turns, world L
    stays. Composition 1(h/2) 2(h/2) 3(h) 2(h/2) 1(h/2) is symmetric, so
    second order and time-reversible; every factor is a rotation, so R stays on
    SO(3), and world L is never written, so it is conserved to the bit.
    McLachlan, "Explicit Lie-Poisson integration and the Euler equations",
    PRL 71 (1993); Touma & Wisdom, AJ 107 (1994); Dullweber, Leimkuhler &
    McLachlan, J. Chem. Phys. 107 (1997) §3.

    NOTE: the axis order (largest moment in the middle) follows Dullweber et al.,
    whose experiments found it the most accurate; principal_moments are sorted
    ascending, so the middle flow is the largest moment.

    principal_q (4,): rotation from principal axes to body axes. principal_moments (3,) kg m^2.
    """
    W = 13 if layout == LAYOUT_QUATERNION else 18
    lb = W - 3
    # Rp = R Qp: principal axes in world coordinates.
    Rb = np.empty((3, 3))
    _orientation_matrix(layout, y, Rb)
    Qp = np.empty((3, 3))
    pw, px, py, pz = principal_q[0], principal_q[1], principal_q[2], principal_q[3]
    Qp[0, 0] = 1.0 - 2.0 * (py * py + pz * pz)
    Qp[0, 1] = 2.0 * (px * py - pw * pz)
    Qp[0, 2] = 2.0 * (px * pz + pw * py)
    Qp[1, 0] = 2.0 * (px * py + pw * pz)
    Qp[1, 1] = 1.0 - 2.0 * (px * px + pz * pz)
    Qp[1, 2] = 2.0 * (py * pz - pw * px)
    Qp[2, 0] = 2.0 * (px * pz - pw * py)
    Qp[2, 1] = 2.0 * (py * pz + pw * px)
    Qp[2, 2] = 1.0 - 2.0 * (px * px + py * py)
    Rp = Rb @ Qp
    Lw = y[lb:lb + 3]
    Lp = Rp.T @ Lw  # L in the principal frame
    # The five sub-flows: (axis, fraction of h)
    for stage in range(5):
        if stage == 0 or stage == 4:
            k, frac = 0, 0.5
        elif stage == 1 or stage == 3:
            k, frac = 1, 0.5
        else:
            k, frac = 2, 1.0
        theta = frac * h * Lp[k] / principal_moments[k]
        c = math.cos(theta)
        s = math.sin(theta)
        a = (k + 1) % 3
        b = (k + 2) % 3
        # Rp <- Rp Rot_k(theta): columns a, b of Rp turn about column k.
        for r in range(3):
            ra = Rp[r, a]
            rbv = Rp[r, b]
            Rp[r, a] = c * ra + s * rbv
            Rp[r, b] = -s * ra + c * rbv
        # Lp <- Rot_k(theta)^T Lp (the same world vector seen from the turned frame)
        la = Lp[a]
        lbv = Lp[b]
        Lp[a] = c * la + s * lbv
        Lp[b] = -s * la + c * lbv
    Rnew = Rp @ Qp.T
    if layout == LAYOUT_MATRIX:
        for r in range(3):
            for cc in range(3):
                y[3 + 3 * r + cc] = Rnew[r, cc]
    else:
        qn = np.empty(4)
        _matrix_to_quat_signed(Rnew, y[3:7], qn)
        for k in range(4):
            y[3 + k] = qn[k]


@njit(**JIT)
def _matrix_to_quat_signed(R, q_old, out):
    """Quaternion of R (3, 3) on the same hemisphere as q_old (4,), so q stays continuous in time."""
    t = R[0, 0] + R[1, 1] + R[2, 2]
    if t >= R[0, 0] and t >= R[1, 1] and t >= R[2, 2]:
        s = math.sqrt(1.0 + t) * 2.0
        out[0] = 0.25 * s
        out[1] = (R[2, 1] - R[1, 2]) / s
        out[2] = (R[0, 2] - R[2, 0]) / s
        out[3] = (R[1, 0] - R[0, 1]) / s
    elif R[0, 0] >= R[1, 1] and R[0, 0] >= R[2, 2]:
        s = math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2]) * 2.0
        out[0] = (R[2, 1] - R[1, 2]) / s
        out[1] = 0.25 * s
        out[2] = (R[0, 1] + R[1, 0]) / s
        out[3] = (R[0, 2] + R[2, 0]) / s
    elif R[1, 1] >= R[2, 2]:
        s = math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2]) * 2.0
        out[0] = (R[0, 2] - R[2, 0]) / s
        out[1] = (R[0, 1] + R[1, 0]) / s
        out[2] = 0.25 * s
        out[3] = (R[1, 2] + R[2, 1]) / s
    else:
        s = math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1]) * 2.0
        out[0] = (R[1, 0] - R[0, 1]) / s
        out[1] = (R[0, 2] + R[2, 0]) / s
        out[2] = (R[1, 2] + R[2, 1]) / s
        out[3] = 0.25 * s
    n = math.sqrt(out[0] ** 2 + out[1] ** 2 + out[2] ** 2 + out[3] ** 2)
    dot = out[0] * q_old[0] + out[1] * q_old[1] + out[2] * q_old[2] + out[3] * q_old[3]
    sign = -1.0 if dot < 0.0 else 1.0
    for k in range(4):
        out[k] = sign * out[k] / n


@njit(**JIT)
def kick_kernel(layout, Y, moving, F, T, h):
    """P += h F, L += h tau for every moving body (the 'kick' of symplectic methods)."""
    W = Y.shape[1]
    for i in range(Y.shape[0]):
        if moving[i]:
            for k in range(3):
                Y[i, W - 6 + k] += h * F[i, k]
                Y[i, W - 3 + k] += h * T[i, k]


@njit(**JIT)
def drift_kernel(layout, Y, moving, inv_mass, inertia_body_inv, principal_q, principal_moments, split, h):
    """x += h P / M, and the orientation turned by the current angular momentum over h.

    split=False: exact rotation at the constant omega = I^-1(R) L (semi-implicit Euler).
    split=True: the free-rotation splitting (see ``_free_rotation_split``).
    """
    W = Y.shape[1]
    R = np.empty((3, 3))
    v = np.empty(3)
    omega = np.empty(3)
    for i in range(Y.shape[0]):
        if not moving[i]:
            continue
        for k in range(3):
            Y[i, k] += h * Y[i, W - 6 + k] * inv_mass[i]
        if split:
            _free_rotation_split(layout, Y[i], principal_q[i], principal_moments[i], h)
        else:
            _velocities(layout, Y[i], inv_mass[i], inertia_body_inv[i], R, v, omega)
            _rotate_orientation(layout, Y[i], omega[0], omega[1], omega[2], h)


@njit(**JIT)
def axpy_kernel(Y0, a, dY, out):
    """out = Y0 + a dY (N, W), elementwise; the building block of the Runge-Kutta stages."""
    for i in range(Y0.shape[0]):
        for k in range(Y0.shape[1]):
            out[i, k] = Y0[i, k] + a * dY[i, k]


# --------------------------------------------------------------------------- fused stepping


@njit(**JIT)
def step_kernel(
    integrator, layout, h, n_steps,
    Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity,
    uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param,
    # scratch (N, W) x 3 and (N, 3, 3), (N, 3) x 4
    Y1, K, Kacc, Rs, vs, omegas, F, T,
):
    """Advance Y (N, W) by n_steps steps of h seconds with a fixed-step integrator, in place.

    The whole loop runs compiled: no Python between steps. Built-in forces only
    (``CustomForce`` takes ``Simulator``'s stage-by-stage path, which calls the
    same kernels in the same order and so gives the same bits).
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
        for w in (_YOSHIDA_W1, _YOSHIDA_W0, _YOSHIDA_W1):
            _split_step(layout, w * h, Y, mass, inv_mass, inertia_body_inv, principal_q, principal_moments, moving, gravity, uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param, Rs, vs, omegas, F, T)
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
