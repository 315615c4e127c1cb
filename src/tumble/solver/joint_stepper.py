"""``step_with_joints``: a standalone stepper of the World's built-in forces and its joints (no
contacts), in the stage order of the Simulator's soft step, and its velocity and position
updates. Reads and writes the World's state arrays x, q, R, P, L (and v, omega, I_inv)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from numba import njit

from ..math3d import (
    JIT,
    normalize_quat_inplace,
    quat_exp_multiply_inplace,
    quat_to_matrix_into,
    world_inertia_into,
)

if TYPE_CHECKING:
    from .joints import JointSolver
from .joint_math import (
    _add,
    _cross,
    _dot,
    _mat_vec,
    _scale,
    _sub,
)


@njit(**JIT)
def integrate_velocities_kernel(moving, inv_mass, I_inv, R, inertia_body, force, torque, h,
                                # outputs
                                v, omega):
    """v += h F / m; omega += h I^-1 tau, then the gyroscopic term -omega x I omega by one
    implicit Newton step in the body frame (Catto, "Numerical Methods", GDC 2015,
    https://box2d.org/files/ErinCatto_NumericalMethods_GDC2015.pdf):

        f(w) = Ib (w - w1) + h w x Ib w = 0,  Jf = Ib + h ([w1]x Ib - [Ib w1]x),  w2 = w1 - Jf^-1 f(w1)

    Stable for thin bodies (a chain link's spin about its long axis, I 12x smaller than
    across): the explicit update blew a 50-link chain apart at h = 1/240 s (I measured).
    Slightly dissipative, O(h): a free spinning body loses energy at that order."""
    for i in range(moving.shape[0]):
        if not moving[i]:
            continue
        w = _mat_vec(I_inv, i, (torque[i, 0], torque[i, 1], torque[i, 2]))
        for k in range(3):
            v[i, k] += h * inv_mass[i] * force[i, k]
            omega[i, k] += h * w[k]
        wb = _mat_vec_T(R, i, (omega[i, 0], omega[i, 1], omega[i, 2]))
        Iw = _mat_vec(inertia_body, i, wb)
        f = _scale(h, _cross(wb, Iw))
        # columns of Jf = Ib + h (S(w) Ib - S(Ib w)), S(a) b = a x b
        dw = _solve_columns3(_jacobian_column(inertia_body, i, 0, wb, Iw, h),
                             _jacobian_column(inertia_body, i, 1, wb, Iw, h),
                             _jacobian_column(inertia_body, i, 2, wb, Iw, h), f)
        wb = _sub(wb, dw)
        wn = _mat_vec(R, i, wb)
        omega[i, 0], omega[i, 1], omega[i, 2] = wn


@njit(**JIT)
def _jacobian_column(inertia_body, i, c, wb, Iw, h):
    col = (inertia_body[i, 0, c], inertia_body[i, 1, c], inertia_body[i, 2, c])
    e = (1.0 if c == 0 else 0.0, 1.0 if c == 1 else 0.0, 1.0 if c == 2 else 0.0)
    return _add(col, _scale(h, _sub(_cross(wb, col), _cross(Iw, e))))


@njit(**JIT)
def _solve_columns3(c0, c1, c2, b):
    """x with [c0 c1 c2] x = b (Cramer's rule with triple products); 0 if singular."""
    n12 = _cross(c1, c2)
    det = _dot(c0, n12)
    if det == 0.0:
        return (0.0, 0.0, 0.0)
    return (_dot(b, n12) / det, _dot(c0, _cross(b, c2)) / det, _dot(c0, _cross(c1, b)) / det)


@njit(**JIT)
def integrate_positions_kernel(moving, v, omega, h, inertia_body_inv,
                               # outputs
                               x, q, R, I_inv):
    """x += h v; q rotated exactly by omega over h (omega kept, as Box2D: the gyroscopic
    term is in the velocity update); then R = R(q) and I^-1 = R Ibody^-1 R^T."""
    for i in range(moving.shape[0]):
        if not moving[i]:
            continue
        for k in range(3):
            x[i, k] += h * v[i, k]
        quat_exp_multiply_inplace(q[i], omega[i, 0], omega[i, 1], omega[i, 2], h)
        normalize_quat_inplace(q[i])
        quat_to_matrix_into(q[i], R[i])
        world_inertia_into(R[i], inertia_body_inv[i], I_inv[i])


@njit(**JIT)
def _mat_vec_T(M, i, a):
    """M[i]^T @ a."""
    return (M[i, 0, 0] * a[0] + M[i, 1, 0] * a[1] + M[i, 2, 0] * a[2],
            M[i, 0, 1] * a[0] + M[i, 1, 1] * a[1] + M[i, 2, 1] * a[2],
            M[i, 0, 2] * a[0] + M[i, 1, 2] * a[1] + M[i, 2, 2] * a[2])


# ---------------------------------------------------------------------- standalone stepper
def step_with_joints(world, joints: JointSolver, dt: float, substeps: int = 4):
    """Advance ``world`` by ``dt`` under its built-in forces (gravity and force records,
    evaluated once at the start of the step) and its joints; no contacts, no user callables.

    Box2D v3's order: prepare; per substep integrate velocities -> warm start -> solve
    (bias) -> integrate positions (L kept, omega from it) -> relax; then the optional
    projection and store. Writes x, q, R, P, L and the derived arrays; advances ``world.t``.
    """
    h = dt / substeps
    world.update_derived()
    moving = world.moving
    v, omega, x, q, R, I_inv = world.v, world.omega, world.x, world.q, world.R, world.I_inv
    joints.prepare(world, h)
    armature = joints.has_armature()
    for k in range(substeps):
        if armature:
            # before the forces: the armature rows' target
            joints.capture_rates(v, omega, x, R, first=k == 0, carried=False)
        integrate_velocities_kernel(moving, world.inv_mass, I_inv, R, world.inertia_body, world.force, world.torque, h,
                                    v, omega)
        joints.warm_start(v, omega, x, R)
        joints.solve(v, omega, x, R, True)
        integrate_positions_kernel(moving, v, omega, h, world.inertia_body_inv, x, q, R, I_inv)
        joints.solve(v, omega, x, R, False)
    joints.project(x, q, R)
    _store_momenta_kernel(moving, world.mass, world.inertia_body, R, v, omega, world.P, world.L)
    world.t += dt
    joints.store(v, omega, x, R)
    return joints


@njit(**JIT)
def _store_momenta_kernel(moving, mass, inertia_body, R, v, omega,
                          # outputs
                          P, L):
    """P = m v, L = R Ibody R^T omega (at the final pose)."""
    for i in range(moving.shape[0]):
        if moving[i]:
            wb = _mat_vec_T(R, i, (omega[i, 0], omega[i, 1], omega[i, 2]))
            Lw = _mat_vec(R, i, _mat_vec(inertia_body, i, wb))
            for k in range(3):
                P[i, k] = mass[i] * v[i, k]
                L[i, k] = Lw[k]
