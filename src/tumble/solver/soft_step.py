"""The step of bodies in contact: Box2D v3's soft step over the packed state Y.

Reads and writes the packed state ``Y`` (N, W) of the bodies in ``active`` (moving bodies
that have a contact this step); other bodies are left to the Simulator's integrator. Stages,
per step of dt made of ``substeps`` substeps h (``Simulator.substeps * SoftStepSettings.substeps``; Catto, "Solver2D", 2024; Box2D v3
``b2SolverStage``; BENCHMARKS.md "Settings shared by every scene"):

    collide (once, on the poses at the start of the step)   CollisionPipeline.detect
    prepare_contacts
    per substep:
        accumulate_forces        the World's forces at the substep's state (F, T)
        integrate_velocities     P += h F, L += h T; then v, omega, I^-1 from them
        warm_start               the accumulated impulses of the last substep
        solve_joints(bias)       (the first substep: the responses of the contacts of
                                 jointed bodies through the joint tree, contact_tree)
        solve_contacts(bias)     soft non-penetration, Coulomb friction; the contacts of
                                 jointed bodies last, through the tree
        integrate_positions      x += h v, the orientation by the exact rotation of omega h
        relax_joints
        relax_contacts           solve without bias: the push-out speed leaves again
        relax_joints             again, when a joint has armature: the rates its flywheel has
                                 (joint_solve.flywheel_rates_kernel)
        store_momenta            P = m v, L = I omega (I at the substep's start, the
                                 inverse of the I^-1 the solve used)
    apply_restitution            (the contacts of jointed bodies through the tree)
    store_momenta, store_impulses

The substep loop runs in one compiled call, ``substeps_kernel`` (the same stages in the same
order, so the same bits), unless a stage check watches it (``TUMBLE_VALIDATE``, the blow-up
diagnosis), a force is a Python callable, or the joints are solved in slabs on both cores.

The velocity update is semi-implicit Euler (Box2D's); L is the state, so a body spinning
while it slides keeps its angular momentum, and omega = I^-1 L follows the rotating inertia
(the gyroscopic effect, which Box2D leaves out). Bodies without contacts in a step move by the
chosen integrator (rk4 by default), so a projectile is exact until it comes within a
speculative margin of something.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..collision.manifold import KEY_BITS, match_contacts
from ..collision.pipeline import CollisionPipeline, any_at_kernel, any_pair_moving_kernel
# PERF: at the top, not in ``_refresh_joints``: an import statement run every step cost ~1 us
from ..joints import jointed_body_pairs, pair_edit_count
from ..body_motion import _load, _mat9, _matrix, _project, _rotate, _store, _velocities
from ..integrators import accumulate_forces_kernel
from ..math3d import JIT, start_threads
from ..world import Scratch
from . import contact as C
from .joint_solve import (first_substep_rates_kernel, flywheel_rates_kernel, joint_rates_kernel,
                          solve_joints_serial_kernel, warm_start_joints_kernel)
from .contact_tree import (
    TreeContacts,
    solve_tree_contacts_groups_kernel,
    solve_tree_contacts_kernel,
    tree_contact_responses_groups_kernel,
    tree_contact_responses_kernel,
)
from .joint_tree import tree_sweeps_kernel
from .contact_rolling import solve_rolling_kernel, warm_start_rolling_kernel
from .contact_solve import solve_contacts_kernel, warm_start_kernel


# ---------------------------------------------------------------------- kernels over Y
@njit(**JIT)
def integrate_velocities_kernel(layout, Y, active, inv_mass, inertia_body, inertia_body_inv, F, T, h,
                                kinematic_v, kinematic_omega,
                                # outputs
                                R, v, omega, I_inv, I_world):
    """Kick the active bodies by their forces over h (P += h F, L += h T) and derive R, v, omega.

    Y (N, W) packed state; F, T (N, 3) N, N m, world. Writes R (N, 3, 3), v (N, 3) m/s,
    omega (N, 3) rad/s, I_inv and I_world (N, 3, 3) = R Ibody^-1 R^T and R Ibody R^T.
    Other bodies get I_inv = 0 and v, omega = ``kinematic_v``, ``kinematic_omega`` (N, 3)
    (zero but for kinematic bodies): the solver sees them as immovable, moving at those
    velocities (fixed and kinematic bodies; moving bodies outside ``active`` have no contact
    this step).
    """
    for i in range(Y.shape[0]):
        if not active[i]:
            for k in range(3):
                v[i, k] = kinematic_v[i, k]
                omega[i, k] = kinematic_omega[i, k]
                for j in range(3):
                    I_inv[i, k, j] = 0.0
            continue
        x, o, P, L = _load(layout, Y, i)
        P = (P[0] + h * F[i, 0], P[1] + h * F[i, 1], P[2] + h * F[i, 2])
        L = (L[0] + h * T[i, 0], L[1] + h * T[i, 1], L[2] + h * T[i, 2])
        _store(layout, Y, i, x, o, P, L)
        Rm, vi, wi = _velocities(layout, o, P, L, inv_mass[i], _mat9(inertia_body_inv, i))
        for k in range(3):
            v[i, k] = vi[k]
            omega[i, k] = wi[k]
            for j in range(3):
                R[i, k, j] = Rm[3 * k + j]
        for k in range(3):
            for j in range(3):
                a = 0.0
                b = 0.0
                for m in range(3):
                    # (R B R^T)_kj = sum_m R_km (B R^T)_mj = sum_m R_km sum_n B_mn R_jn
                    bi = inertia_body_inv[i, m, 0] * Rm[3 * j] + inertia_body_inv[i, m, 1] * Rm[3 * j + 1] \
                        + inertia_body_inv[i, m, 2] * Rm[3 * j + 2]
                    bw = inertia_body[i, m, 0] * Rm[3 * j] + inertia_body[i, m, 1] * Rm[3 * j + 1] \
                        + inertia_body[i, m, 2] * Rm[3 * j + 2]
                    a += Rm[3 * k + m] * bi
                    b += Rm[3 * k + m] * bw
                I_inv[i, k, j] = a
                I_world[i, k, j] = b


@njit(**JIT, inline="always")
def _place_row(layout, Y, i, x, o, P, L, R):
    """Row i of Y set to (x, o, P, L); R[i] from its orientation o."""
    _store(layout, Y, i, x, o, P, L)
    Rm = _matrix(layout, o)
    for k in range(9):
        R[i, k // 3, k % 3] = Rm[k]


@njit(**JIT, inline="always")
def _drift_row(layout, Y, i, v0, v1, v2, w0, w1, w2, h, R):
    """Row i of Y: x += h v; the orientation turned by the exact rotation of omega over h and
    put back on SO(3); R[i] from it."""
    x, o, P, L = _load(layout, Y, i)
    x = (x[0] + h * v0, x[1] + h * v1, x[2] + h * v2)
    o = _project(layout, _rotate(layout, o, (w0, w1, w2), h))
    _place_row(layout, Y, i, x, o, P, L, R)


# rad: a moving body's turn in a substep is taken in pieces of at most this (``_turn_free``): the
# fixed-point iteration of its midpoint rule contracts by about the turn times the inertia's spread.
TURN_MAX = 0.25
# The midpoint's fixed-point iteration stops when a step changes L_mid by at most this relative to |L|
# (a few ulps), or after TURN_ITERATIONS steps.
TURN_TOLERANCE = 4e-16
TURN_ITERATIONS = 60


@njit(**JIT, inline="always")
def _turn_free(layout, o, L0, L1, L2, inertia_body_inv, h):
    """The orientation o after h of torque-free rotation with angular momentum L = (L0, L1, L2) (world,
    held): the implicit midpoint rule on Euler's equations in the body frame, dL_b/dt = L_b x
    (Ibody^-1 L_b), which keeps both |L_b| and the energy L_b . Ibody^-1 L_b / 2 (quadratic
    invariants), and the orientation turned with it so that R L_b = L stays (R_{n+1} = R_n
    cay(h W_mid)^T: the body turns about omega_mid by 2 atan(h |omega_mid| / 2)). In pieces of at
    most ``TURN_MAX``.

    NOTE: why: the turn at constant omega (a Lie-Euler step, what this replaced) is first order and
    its energy error grows with every step for a body tumbling about no principal axis: a 0.3 x 0.1 x
    0.02 m plank tumbling at 100 rad/s 20 cm above a plane (in the soft step: its speculative contact)
    ended 1 s later with 8.8 times its energy, all of it spin about its long axis (measured, session
    45); capsules knocked into a tumble of hundreds of rad/s by a plate's edge gained up to 56 % of
    their energy (a fuzz of fast bodies). Box2D and Box3D hold omega instead of L (their energy stays
    bounded, but L turns); tumble holds L, as the course's state X = (x, R, P, L) does, so it takes the
    midpoint (Austin, Krishnaprasad and Wang 1993, "Almost Poisson integration of rigid body
    systems"; Hairer, Lubich and Wanner, Geometric Numerical Integration, VII.5)."""
    Rm = _matrix(layout, o)
    # L in the body frame, L_b = R^T L
    b0 = Rm[0] * L0 + Rm[3] * L1 + Rm[6] * L2
    b1 = Rm[1] * L0 + Rm[4] * L1 + Rm[7] * L2
    b2 = Rm[2] * L0 + Rm[5] * L1 + Rm[8] * L2
    c0 = inertia_body_inv[0, 0] * b0 + inertia_body_inv[0, 1] * b1 + inertia_body_inv[0, 2] * b2
    c1 = inertia_body_inv[1, 0] * b0 + inertia_body_inv[1, 1] * b1 + inertia_body_inv[1, 2] * b2
    c2 = inertia_body_inv[2, 0] * b0 + inertia_body_inv[2, 1] * b1 + inertia_body_inv[2, 2] * b2
    turn = h * math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    pieces = max(1, int(math.ceil(turn / TURN_MAX)))
    hp = h / pieces
    size = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    for _ in range(pieces):
        # L_mid = L_n + (h/2) L_mid x (Ibody^-1 L_mid), by fixed-point iteration from L_n
        m0, m1, m2 = b0, b1, b2
        for _ in range(TURN_ITERATIONS):
            w0 = inertia_body_inv[0, 0] * m0 + inertia_body_inv[0, 1] * m1 + inertia_body_inv[0, 2] * m2
            w1 = inertia_body_inv[1, 0] * m0 + inertia_body_inv[1, 1] * m1 + inertia_body_inv[1, 2] * m2
            w2 = inertia_body_inv[2, 0] * m0 + inertia_body_inv[2, 1] * m1 + inertia_body_inv[2, 2] * m2
            n0 = b0 + 0.5 * hp * (m1 * w2 - m2 * w1)
            n1 = b1 + 0.5 * hp * (m2 * w0 - m0 * w2)
            n2 = b2 + 0.5 * hp * (m0 * w1 - m1 * w0)
            change = abs(n0 - m0) + abs(n1 - m1) + abs(n2 - m2)
            m0, m1, m2 = n0, n1, n2
            if change <= TURN_TOLERANCE * size:
                break
        w0 = inertia_body_inv[0, 0] * m0 + inertia_body_inv[0, 1] * m1 + inertia_body_inv[0, 2] * m2
        w1 = inertia_body_inv[1, 0] * m0 + inertia_body_inv[1, 1] * m1 + inertia_body_inv[1, 2] * m2
        w2 = inertia_body_inv[2, 0] * m0 + inertia_body_inv[2, 1] * m1 + inertia_body_inv[2, 2] * m2
        speed = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        b0, b1, b2 = 2.0 * m0 - b0, 2.0 * m1 - b1, 2.0 * m2 - b2
        if speed == 0.0:
            continue
        # the body turns about omega_mid (body frame; world: R omega_mid) by 2 atan(hp |omega_mid| / 2):
        # the exact rotation of a world omega of that direction and size angle / hp
        scale = 2.0 * math.atan(0.5 * hp * speed) / (hp * speed)
        Rm = _matrix(layout, o)
        ww = (scale * (Rm[0] * w0 + Rm[1] * w1 + Rm[2] * w2), scale * (Rm[3] * w0 + Rm[4] * w1 + Rm[5] * w2),
              scale * (Rm[6] * w0 + Rm[7] * w1 + Rm[8] * w2))
        o = _project(layout, _rotate(layout, o, ww, hp))
    return o


@njit(**JIT)
def integrate_positions_kernel(layout, Y, active, kinematic, jointed, v, omega, h, I_world, inertia_body_inv,
                               # outputs
                               R):
    """The active and the ``kinematic`` (N,) bool bodies: x += h v; the orientation put back on
    SO(3) after its turn; R from it. A kinematic body turns by the exact rotation of its constant
    omega over h (its path is given), and so does a ``jointed`` one (N,) bool (its solved omega is
    what its joints' rows hold it to: turned otherwise, a pusher's wrist against MuJoCo's RK4 was
    2.5 times as far off at each step, still first order); any other moving one by the torque-free
    motion of the angular momentum of its solved velocities, L = I_world omega (``I_world`` (N, 3, 3)
    at the substep's start, what ``store_momenta_kernel`` stores L with), by the midpoint rule
    (``_turn_free``)."""
    for i in range(Y.shape[0]):
        if not (active[i] or kinematic[i]):
            continue
        w0, w1, w2 = omega[i, 0], omega[i, 1], omega[i, 2]
        if kinematic[i] or jointed[i]:
            _drift_row(layout, Y, i, v[i, 0], v[i, 1], v[i, 2], w0, w1, w2, h, R)
            continue
        x, o, P, L = _load(layout, Y, i)
        L0 = I_world[i, 0, 0] * w0 + I_world[i, 0, 1] * w1 + I_world[i, 0, 2] * w2
        L1 = I_world[i, 1, 0] * w0 + I_world[i, 1, 1] * w1 + I_world[i, 1, 2] * w2
        L2 = I_world[i, 2, 0] * w0 + I_world[i, 2, 1] * w1 + I_world[i, 2, 2] * w2
        o = _turn_free(layout, o, L0, L1, L2, inertia_body_inv[i], h)
        x = (x[0] + h * v[i, 0], x[1] + h * v[i, 1], x[2] + h * v[i, 2])
        _place_row(layout, Y, i, x, o, P, L, R)


@njit(**JIT)
def advance_kinematic_kernel(layout, Y, kinematic, kinematic_v, kinematic_omega, h, n,
                             # outputs
                             R):
    """n substeps h of the ``kinematic`` (N,) bool bodies of Y at ``kinematic_v``,
    ``kinematic_omega`` (N, 3) m/s, rad/s: the arithmetic ``integrate_positions_kernel`` gives
    them inside the soft step, so their path is the same to the bit whether or not anything
    touched them in a step. R (N, 3, 3) gets their final orientations."""
    for i in range(Y.shape[0]):
        if not kinematic[i]:
            continue
        for _ in range(n):
            _drift_row(layout, Y, i, kinematic_v[i, 0], kinematic_v[i, 1], kinematic_v[i, 2],
                       kinematic_omega[i, 0], kinematic_omega[i, 1], kinematic_omega[i, 2], h, R)


@njit(**JIT)
def store_momenta_kernel(layout, Y, active, mass, v, omega, I_world):
    """P = m v, L = I_world omega for the active bodies (the momenta of the solved velocities)."""
    for i in range(Y.shape[0]):
        if not active[i]:
            continue
        x, o, P, L = _load(layout, Y, i)
        P = (mass[i] * v[i, 0], mass[i] * v[i, 1], mass[i] * v[i, 2])
        L = (I_world[i, 0, 0] * omega[i, 0] + I_world[i, 0, 1] * omega[i, 1] + I_world[i, 0, 2] * omega[i, 2],
             I_world[i, 1, 0] * omega[i, 0] + I_world[i, 1, 1] * omega[i, 1] + I_world[i, 1, 2] * omega[i, 2],
             I_world[i, 2, 0] * omega[i, 0] + I_world[i, 2, 1] * omega[i, 1] + I_world[i, 2, 2] * omega[i, 2])
        _store(layout, Y, i, x, o, P, L)


@njit(**JIT)
def _solve_joints(tree, iterations, soft, x, R, inv_mass, I_inv, h, joints, tree_parts, v, omega, impulses, factor):
    """One joint solve of the fused substeps: ``JointSolver.solve``'s Gauss-Seidel sweeps, or its tree sweeps
    (``factor``: ``tree_sweeps_kernel``'s)."""
    (order, bounds, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, enabled, gauss_seidel,
     position, rate0) = joints
    linear_impulse, angular_impulse, axial_impulse = impulses
    if not tree:
        solve_joints_serial_kernel(order, bounds, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b,
                                   param, enabled, gauss_seidel, position, rate0, x, R, inv_mass, I_inv, h, soft,
                                   iterations, v, omega, linear_impulse, angular_impulse, axial_impulse)
        return
    (limits, max_sweeps, tolerance, node_order, node_joint, node_body, node_parent, Ja, Jb, C, nrow, D, Dinv, H_up,
     W, y, sol, work, before, joint_group, body_group, group_change, group_largest, group_done, node_skip, sub_order,
     sub_bounds, layout, limit_rows, groups) = tree_parts
    tree_sweeps_kernel(iterations, limits, max_sweeps, tolerance, order, bounds, joint_type, joint_a, joint_b,
                       local_a, local_b, frame_a, frame_b, param, enabled, gauss_seidel, position, rate0, x, R,
                       inv_mass, I_inv, h, soft, node_order, node_joint, node_body, node_parent, factor, Ja, Jb, C, nrow,
                       D, Dinv,
                       H_up, W, y, sol, work, before, joint_group, body_group, group_change, group_largest, group_done,
                       node_skip, sub_order, sub_bounds, layout, limit_rows, groups, v, omega, linear_impulse,
                       angular_impulse, axial_impulse)


@njit(**JIT)
def _solve_contacts(use_bias, contacts, order, bounds, rolling, x, R, inv_mass, I_inv, inv_h, contact_speed, v, omega):
    """One contact sweep of the fused substeps: ``ContactSolver.solve_contacts`` in ``order`` cut by
    ``bounds`` (the contacts of jointed bodies left to ``_solve_tree_contacts``)."""
    (_order, _bounds, body_a, body_b, normal, tangent1, tangent2, local_a, local_b, anchor_offset, separation,
     normal_mass, tangent_mass, soft, friction, surface_target, normal_impulse, tangent_impulse, max_normal_impulse,
     relative_velocity, last_normal_speed, arm_a, arm_b, gap, _step_normal, _step_tangent) = contacts
    solve_contacts_kernel(order, bounds, body_a, body_b, normal, tangent1, tangent2, local_a, local_b, anchor_offset,
                          separation, normal_mass, tangent_mass, soft, friction, surface_target, x, R, inv_mass,
                          I_inv, inv_h, contact_speed, use_bias, v, omega, normal_impulse, tangent_impulse,
                          max_normal_impulse, relative_velocity, last_normal_speed, arm_a, arm_b, gap)
    rows, rolling_impulse, rolling_mass, rolling_limit = rolling
    if rows.shape[0]:  # after the contacts, whose normal impulses bound them
        solve_rolling_kernel(rows, body_a, body_b, normal, tangent1, tangent2, normal_impulse, rolling_mass,
                             rolling_limit, I_inv, omega, rolling_impulse)


@njit(**JIT)
def _tree_responses(tree_contacts, contacts, joints, tree_parts, inv_mass, I_inv):
    """The responses of the contacts of jointed bodies through the tree (``contact_tree``), on the
    factors of the joint solve just made."""
    (_order, _bounds, listed, slot_count, slot_ref, slot_resp, row_mass, body_node, node_tree, tree_lo, tree_hi,
     no_skip, positions, group_start, group_q, group_work, group_mode) = tree_contacts
    (_c_order, _c_bounds, body_a, body_b, normal, tangent1, tangent2, _local_a, _local_b, _anchor_offset, _separation,
     _normal_mass, _tangent_mass, _soft, _friction, _surface_target, _normal_impulse, _tangent_impulse,
     _max_normal_impulse, _relative_velocity, _last_normal_speed, arm_a, arm_b, _gap, _step_normal,
     _step_tangent) = contacts
    (_j_order, _j_bounds, joint_type, joint_a, joint_b, _j_local_a, _j_local_b, _frame_a, _frame_b, param, _enabled,
     _gauss_seidel, _position, _rate0) = joints
    (_limits, _max_sweeps, _tolerance, node_order, node_joint, node_body, node_parent, Ja, Jb, _C, nrow, _D, Dinv,
     H_up, W, y, sol, work) = tree_parts[:18]
    if group_mode:  # the joint groups' contacts side by side (contact_tree.group_contacts_kernel)
        tree_contact_responses_groups_kernel(group_start, group_q, group_work, listed, body_a, body_b, normal, tangent1,
                                             tangent2, arm_a, arm_b, inv_mass, I_inv, body_node, node_tree, tree_lo,
                                             tree_hi, node_order, node_joint, node_body, node_parent, joint_type,
                                             joint_a, joint_b, param, Ja, Jb, nrow, Dinv, H_up, W, y, sol, no_skip,
                                             slot_count, slot_ref, slot_resp, row_mass)
        return
    tree_contact_responses_kernel(positions, listed, body_a, body_b, normal, tangent1, tangent2, arm_a, arm_b,
                                  inv_mass, I_inv, body_node, node_tree, tree_lo, tree_hi, node_order, node_joint,
                                  node_body, node_parent, joint_type, joint_a, joint_b, param, Ja, Jb, nrow, Dinv,
                                  H_up, W, y, sol, work, no_skip, slot_count, slot_ref, slot_resp, row_mass)


@njit(**JIT)
def _solve_tree_contacts(use_bias, tree_contacts, contacts, x, R, inv_h, contact_speed, v, omega, impulses):
    """One sweep over the contacts of jointed bodies, through the tree (``contact_tree``)."""
    (_order, _bounds, listed, slot_count, slot_ref, slot_resp, row_mass, _body_node, _node_tree, _tree_lo,
     _tree_hi, _no_skip, positions, group_start, group_q, _group_work, group_mode) = tree_contacts
    (_c_order, _c_bounds, body_a, body_b, normal, tangent1, tangent2, local_a, local_b, anchor_offset, separation,
     _normal_mass, _tangent_mass, soft, friction, surface_target, normal_impulse, tangent_impulse, max_normal_impulse,
     relative_velocity, last_normal_speed, arm_a, arm_b, gap, _step_normal, _step_tangent) = contacts
    linear_impulse, angular_impulse, axial_impulse = impulses
    if group_mode:  # the joint groups' contacts side by side (contact_tree.group_contacts_kernel)
        solve_tree_contacts_groups_kernel(group_start, group_q, listed, body_a, body_b, normal, tangent1, tangent2,
                                          local_a, local_b, anchor_offset, separation, soft, friction,
                                          surface_target, x, R, inv_h, contact_speed, use_bias, slot_count, slot_ref,
                                          slot_resp, row_mass, v, omega, linear_impulse, angular_impulse,
                                          axial_impulse, normal_impulse, tangent_impulse, max_normal_impulse,
                                          relative_velocity, last_normal_speed, arm_a, arm_b, gap)
        return
    solve_tree_contacts_kernel(positions, listed, body_a, body_b, normal, tangent1, tangent2, local_a, local_b,
                               anchor_offset, separation, soft, friction, surface_target, x, R, inv_h, contact_speed,
                               use_bias, slot_count, slot_ref, slot_resp, row_mass, v, omega, linear_impulse,
                               angular_impulse, axial_impulse, normal_impulse, tangent_impulse, max_normal_impulse,
                               relative_velocity, last_normal_speed, arm_a, arm_b, gap)


def _substeps_kernel(with_joints: bool):
    """``substeps_kernel`` compiled with or without its joint stages (``with_joints``, a constant of
    the closure: Numba prunes the branches it decides, so a world without joints does not compile the
    joint solver into its substeps: a tower's first run 51 -> 22 s, measured)."""

    @njit(**JIT)
    def substeps_kernel(layout, Y, active, kinematic, jointed, mass, inv_mass, inertia_body, inertia_body_inv, moving,
                        gravity, forces, kinematic_v, kinematic_omega, h, substeps,
                        joints, tree, tree_parts, soft_bias, soft_relax, velocity_iterations, relax_iterations, armature,
                        armature_rate, contacts, rolling, contact_speed, tree_contacts,
                        # outputs and scratch
                        R, v, omega, F, T, I_inv, I_world, impulses):
        """The substeps of a step, in one call: ``SoftStep.step``'s loop, the same kernels in the
        same order (so the same bits), for the steps whose joints sit in one partition (on the calling
        thread; the contacts' slabs, when there are, run in parallel inside) and whose forces are all
        compiled.

        PERF: a small scene spends most of its step in Python between a dozen kernel calls per
        substep (about 4 us each): a robot arm alone 111 us a step against PyBullet's 3 us (85 us
        with its joint substeps fused, session 14); the free ant standing on its feet 510 us against
        MuJoCo's 29 (docs/benchmarks.md, "small scenes"). ``forces``: ``accumulate_forces_kernel``'s
        tables (the caller takes the Python loop when there are custom forces); F, T (N, 3) hold the
        first substep's forces on entry. ``joints``: ``JointSolver``'s tables (a tuple, as
        ``_solve_joints`` unpacks it; empty arrays for a world without joints), ``tree``: its method
        is the tree's, whose arrays are ``tree_parts``; ``impulses``: its accumulated impulses
        (linear, angular, axial); ``armature``: some joint has armature (take the rates before each
        substep's forces; the first substep's from ``armature_rate`` (J,) where known).
        ``contacts``: ``ContactSolver``'s per-contact arrays as
        ``contact_solve.solve_contacts_kernel`` takes them, then the step's impulse totals (C rows;
        C = 0: none), ``rolling``: its rolling-resistance rows. The kernel without joints
        (``with_joints`` False) reads none of the joint arguments: ``joints``, ``tree_parts``,
        ``soft_bias``, ``soft_relax``, ``armature_rate`` and ``impulses`` are None there. PERF: a call
        unboxes each array of its arguments (about 60 ns each, 100 arrays a call for a box on a plane,
        47 of them an empty joint solver's): a world without joints passes none of those.
        """
        uforce_kind, uforce_param, uforce_start, spring_body, spring_anchor, spring_param = forces
        n_joints = 0
        if with_joints:  # (pruned without joints, whose tables are then None)
            (order, bounds, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, enabled,
             gauss_seidel, position, rate0) = joints
            linear_impulse, angular_impulse, axial_impulse = impulses
            n_joints = joint_type.shape[0]
        (c_order, c_bounds, body_a, body_b, normal, tangent1, tangent2, c_local_a, c_local_b, anchor_offset, separation,
         normal_mass, tangent_mass, soft, friction, surface_target, normal_impulse, tangent_impulse, max_normal_impulse,
         relative_velocity, last_normal_speed, arm_a, arm_b, gap, step_normal_impulse, step_tangent_impulse) = contacts
        rolling_rows, rolling_impulse, rolling_mass, rolling_limit = rolling
        s_order, s_bounds, tree_listed = tree_contacts[0], tree_contacts[1], tree_contacts[2]
        n_tree = tree_listed.shape[0]
        n_contacts = c_order.shape[0]
        n_rolling = rolling_rows.shape[0]
        inv_h = 1.0 / h
        for k in range(substeps):
            if with_joints and armature:
                # before the forces derive omega again from L (first_substep_rates_kernel says why)
                if k == 0:
                    joint_rates_kernel(joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, enabled,
                                       position, Y, R, v, omega, rate0)
                    first_substep_rates_kernel(armature_rate, rate0)
                else:
                    flywheel_rates_kernel(param, enabled, axial_impulse, rate0, rate0)  # the last substep's
            if k > 0:
                accumulate_forces_kernel(layout, Y, mass, inv_mass, inertia_body_inv, moving, gravity, uforce_kind,
                                         uforce_param, uforce_start, spring_body, spring_anchor, spring_param,
                                         R, v, omega, F, T)
            integrate_velocities_kernel(layout, Y, active, inv_mass, inertia_body, inertia_body_inv, F, T, h,
                                        kinematic_v, kinematic_omega, R, v, omega, I_inv, I_world)
            if with_joints and n_joints:
                warm_start_joints_kernel(joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, enabled,
                                         position, Y, R, inv_mass, I_inv, h, linear_impulse, angular_impulse,
                                         axial_impulse, v, omega)
            if n_contacts:
                warm_start_kernel(c_order, c_bounds, body_a, body_b, normal, tangent1, tangent2, c_local_a, c_local_b,
                                  anchor_offset, normal_impulse, tangent_impulse, Y, R, inv_mass, I_inv, k == 0, v, omega,
                                  arm_a, arm_b, gap)
                if n_rolling:
                    warm_start_rolling_kernel(rolling_rows, body_a, body_b, normal, tangent1, tangent2, rolling_impulse,
                                              I_inv, omega)
            if with_joints and n_joints:
                # with armature, the velocities made consistent with the tree first (tree_sweeps_kernel)
                _solve_joints(tree, velocity_iterations, soft_bias, Y, R, inv_mass, I_inv, h, joints, tree_parts, v,
                              omega, impulses, np.int64(2 if armature else 1))
                if n_tree and k == 0:  # on the factors just made (contact_tree: once a step)
                    _tree_responses(tree_contacts, contacts, joints, tree_parts, inv_mass, I_inv)
            if n_contacts:
                _solve_contacts(True, contacts, s_order, s_bounds, rolling, Y, R, inv_mass, I_inv, inv_h, contact_speed,
                                v, omega)
                if with_joints and n_tree:
                    _solve_tree_contacts(True, tree_contacts, contacts, Y, R, inv_h, contact_speed, v, omega, impulses)
            integrate_positions_kernel(layout, Y, active, kinematic, jointed, v, omega, h, I_world, inertia_body_inv, R)
            if with_joints and n_joints:
                _solve_joints(tree, relax_iterations, soft_relax, Y, R, inv_mass, I_inv, h, joints, tree_parts, v, omega,
                              impulses, np.int64(1))
            if n_contacts:
                _solve_contacts(False, contacts, s_order, s_bounds, rolling, Y, R, inv_mass, I_inv, inv_h,
                                contact_speed, v, omega)
                if with_joints and n_tree:
                    _solve_tree_contacts(False, tree_contacts, contacts, Y, R, inv_h, contact_speed, v, omega, impulses)
            if with_joints and armature:
                # the joints last, so that each coordinate with armature ends the substep at its flywheel's rate
                # (joint_solve.flywheel_rates_kernel). Without it (the flywheel carried) the ant's legs kicked
                # 1 rad/s for a step at each contact change, where the rates were the contacts' (0.1 rad/s
                # before and after, 2.5 J of 5 J in and out); with the contacts solved after the joints'
                # velocity pass and before their relax pass instead (no solve more), the landing threw the
                # ant up again, 2 J a bounce (measured). Every substep, contacts or not: a copy of a vector
                # environment must take the same solves as the single one.
                # PERF: on the relax solve's factors (the poses have not moved since), the relax's sweeps but no
                # limit re-sweeps (the relax has just converged them: tree_sweeps_kernel). Measured against the
                # step without this solve (docs/benchmarks.md, "the armature's flywheel"): +17-23 % a runner
                # or pusher environment step (with the limit re-sweeps +19-23 %: not the cost); one sweep
                # +6-12 %, but the ant of test_mjcf.py then moved its legs at up to 0.54 rad/s against 0.47
                # with two (MuJoCo's 0.24)
                _solve_joints(tree, relax_iterations, soft_relax, Y, R, inv_mass, I_inv, h, joints, tree_parts, v,
                              omega, impulses, np.int64(0))
            store_momenta_kernel(layout, Y, active, mass, v, omega, I_world)
            for c in range(n_contacts):  # ``ContactSolver.accumulate_step_impulses``
                step_normal_impulse[c] += normal_impulse[c]
                for i in range(tangent_impulse.shape[1]):
                    step_tangent_impulse[c, i] += tangent_impulse[c, i]

    return substeps_kernel


# one kernel per kind of world: with joints (their stages and the contacts') and without
SUBSTEPS_KERNELS = {True: _substeps_kernel(True), False: _substeps_kernel(False)}
substeps_kernel = SUBSTEPS_KERNELS[True]


@njit(**JIT)
def mark_active_kernel(body_a, body_b, moving,
                       # outputs
                       active):
    """active[i]: body i is moving and has at least one contact."""
    for i in range(active.shape[0]):
        active[i] = False
    for c in range(body_a.shape[0]):
        active[body_a[c]] = moving[body_a[c]]
        active[body_b[c]] = moving[body_b[c]]


@njit(**JIT)
def spread_active_kernel(spring_body, moving,
                         # outputs
                         active):
    """Make every moving body joined by springs to an active body active too.

    A spring's two ends must take the same step: with one end in the soft step and the other
    in the integrator's, the spring force would be taken at different states for the two and
    the total momentum would no longer be conserved (measured: 1e-3 kg m/s in 0.25 s).
    Repeats until nothing changes (at most one pass per spring).
    """
    changed = True
    while changed:
        changed = False
        for k in range(spring_body.shape[0]):
            a = spring_body[k, 0]
            b = spring_body[k, 1]
            if a < 0 or b < 0:
                continue
            if active[a] and not active[b] and moving[b]:
                active[b] = True
                changed = True
            elif active[b] and not active[a] and moving[a]:
                active[a] = True
                changed = True


# ---------------------------------------------------------------------- contacts as data
@dataclass
class Contacts:
    """The contact points of the last step (``Simulator.contacts()``), C rows, world frame.

    Attributes:
        body_a, body_b: (C,) int64 body indices; the normal points from a to b.
        names_a, names_b: (C,) the bodies' names.
        point: (C, 3) m, midway between the surfaces at the start of the step.
        normal: (C, 3) unit, from a to b.
        separation: (C,) m, signed gap at the start of the step (< 0: penetration).
        normal_impulse: (C,) N s on b along the normal over the whole step (a gets the opposite).
        friction_impulse: (C, 3) N s on b, tangential, over the whole step.
        force: (C, 3) N, the mean force on b over the step: (normal + friction impulse) / dt.
        part_a, part_b: (C,) int64, which part of each body's shape touches: its index in the
            body's ``Compound`` (nested compounds flattened, in order), 0 for a shape of one part
            (PyBullet's ``linkIndexA``, MuJoCo's geom of a body: an MJCF or URDF body made of
            several links' or geoms' shapes tells them apart by it).
    """

    body_a: np.ndarray
    body_b: np.ndarray
    names_a: np.ndarray
    names_b: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    separation: np.ndarray
    normal_impulse: np.ndarray
    friction_impulse: np.ndarray
    force: np.ndarray
    part_a: np.ndarray = None
    part_b: np.ndarray = None

    def __len__(self):
        return len(self.body_a)


# ---------------------------------------------------------------------- the stepper
class SoftStep:
    """Contact stepping of one World: the collision pipeline, the contact solver, their buffers.

    Args:
        world: the World. settings: ``contact.SoftStepSettings`` (defaults: Box3D's).
    """

    fuse = True  # run the substeps in one kernel when they can (``substeps_kernel``); False: the stage loop

    def __init__(self, world, settings: C.SoftStepSettings | None = None, joint_settings=None):
        self.world = world
        self.settings = settings or C.SoftStepSettings()
        self.pipeline = CollisionPipeline(world, self.settings.speculative_distance, skip_unsupported=True)
        self.joint_settings = joint_settings
        self.joints = None  # JointSolver, made when the world has joints
        self._joint_key = None
        self.solver = C.ContactSolver(self.settings)
        self.tree_contacts = TreeContacts()  # this step's contacts of jointed bodies (contact_tree)
        self._n = -1
        self.dt = 0.0
        self.contacts = None
        self._live_key = None  # (table, World.filter_version, body count) of _live_bodies_rows
        self._live_bodies_rows = None

    def _buffers(self):
        n = self.world.body_count
        if n != self._n:
            self.scratch = Scratch(n, self.world.state_size)
            self.I_inv = np.zeros((n, 3, 3))
            self.I_world = np.zeros((n, 3, 3))
            self.active = np.zeros(n, dtype=bool)
            self.no_kinematic = np.zeros(n, dtype=bool)
            self.no_force = np.zeros((n, 3))  # F = T = 0 for _inverse_inertia's kick of zero
            self._n = n

    def has_collisions(self) -> bool:
        """True when collisions are on and at least two shapes can touch (one of them on a moving
        body, or on a moving kinematic body: the bodies it nears must be woken)."""
        w = self.world
        if not getattr(w, "collisions", True):
            return False
        table = self.pipeline.refresh()
        bodies = self._live_bodies(table)
        if bodies is None:
            return False
        # PERF: the bodies of the live shapes are kept (``_live_bodies``); asked twice a step (the
        # Simulator's ``_contact_on``, then ``collide`` with the sleepers masked out): 2.4 and
        # 4.8 us a call for a box on a plane and the cartpole, with its NumPy indexing each time
        return bool(any_at_kernel(table.body_moving, bodies)) or bool(w.kinematic.any() and w.kinematic_moving.any())

    def _live_bodies(self, table):
        """(K,) int64 the body of each live shape (``CollisionPipeline.live_shapes``: all shapes
        under the default filters), or None when fewer than two shapes are live. Kept until the
        table, the filters or the body count change (``World.filter_version``: a filter set, a
        body disabled or retyped)."""
        w = self.world
        key = self._live_key
        if key is None or key[0] is not table or key[1] != w.filter_version or key[2] != w.body_count:
            bodies = None
            if table.shape_count >= 2:
                live = self.pipeline.live_shapes()  # shapes whose filter meets some body (None: all)
                # PERF: a robot whose links have no collision shape (marker spheres that touch nothing) ran the
                # collision stages every step for nothing: an MJCF cable of visual geoms, minima of
                # 15 runs each: 10 links 140 -> 113 us a step, 30 links 244 -> 196 (benchmarks/ball_drive.py's cable)
                if live is None:
                    bodies = np.ascontiguousarray(table.shape_body, dtype=np.int64)
                elif np.count_nonzero(live) >= 2:
                    bodies = np.ascontiguousarray(table.shape_body[live], dtype=np.int64)
            self._live_bodies_rows = bodies
            self._live_key = (table, w.filter_version, w.body_count)
        return self._live_bodies_rows

    def _can_touch(self) -> bool:
        """``has_collisions``, and some pair of shapes that the filters and the exclusions let meet
        (``CollisionPipeline.meeting_pairs``) has a moving body: else the collision stages could
        find no contact. PERF: the cartpole's cart and pole are jointed to each other and the rail
        (no contact between them), and the collision stages ran every step to find nothing (19 us of
        its step; the performance audit's S2). A moving kinematic body keeps them (its margins wake
        the sleepers it nears: kinematic.touched_by_kinematic)."""
        if not self.has_collisions():
            return False
        w = self.world
        if w.kinematic.any() and w.kinematic_moving.any():
            return True
        pairs = self.pipeline.meeting_pairs()
        return pairs is None or bool(any_pair_moving_kernel(pairs, self.pipeline.table.body_moving))

    def has_joints(self) -> bool:
        return bool(getattr(self.world, "joints", None))

    def _refresh_joints(self):
        """The JointSolver and the sorted keys lo * N + hi of the body pairs that must not collide
        (joints with collide_connected=False); rebuilt when joints are added or break, or a
        record's collide_connected is set."""
        w = self.world
        key = (len(w.joints), sum(1 for j in w.joints if j.broken), w.body_count, pair_edit_count())
        if key == self._joint_key:
            return
        from .joints import JointSolver  # (here: made on the first step with joints)

        if self.joints is None:
            self.joints = JointSolver(self.joint_settings) if self.joint_settings is not None else JointSolver()
        pairs = jointed_body_pairs(w)
        self.pipeline.excluded_pairs = np.sort(pairs[:, 0] * w.body_count + pairs[:, 1]).astype(np.int64)
        jb = np.array([(j.bound.body_a, j.bound.body_b) for j in w.joints if not j.broken and j.bound is not None],
                      dtype=np.int64).reshape(-1, 2)
        self.jointed = np.zeros(w.body_count, dtype=bool)
        for col in (0, 1):
            ids = jb[:, col]
            self.jointed[ids[ids >= 0]] = True
        self._joint_key = key

    def collide(self, Y, t: float, dt: float):
        """Forces at the start of the step, then the collision stages on Y's poses; marks ``active``."""
        self._buffers()
        w = self.world
        s = self.scratch
        w.evaluate_forces(t, Y, s)  # R, v, omega of every body, and the step's first F, T
        w._kinematic_velocities(s.v, s.omega)  # their margins grow by the way they move (bounds.py)
        if self.has_joints():
            self._refresh_joints()
        else:
            self.pipeline.excluded_pairs = None
        if self._can_touch():
            self.contacts = self.pipeline.detect(Y, s.R, s.v, s.omega, dt, force=s.F)
        else:
            self.contacts = self.pipeline.contacts
            self.contacts.manifold_count = self.contacts.contact_count = 0
        mark_active_kernel(self.contacts.contact_body_a, self.contacts.contact_body_b, w.moving, self.active)
        if self.has_joints():
            # jointed bodies always take this step (their joints are solved here)
            self.active |= self.jointed & w.moving
        springs = w.tables.spring_body
        if len(springs):
            spread_active_kernel(springs, w.moving, self.active)
        return self.active

    def step(self, Y, t: float, dt: float, substeps: int, check=None, kinematic=None):
        """Advance the active bodies of Y by dt in ``substeps * settings.substeps`` substeps
        (``collide`` must have run on this Y at t), and the ``kinematic`` (N,) bool bodies (the
        moving kinematic ones; default none) at their velocities in the same substeps."""
        substeps = int(substeps) * int(self.settings.substeps)
        w = self.world
        s = self.scratch
        active = self.active
        if kinematic is None:
            kinematic = self.no_kinematic
        layout = w.layout_id
        h = dt / substeps
        self.dt = dt
        solver = self.solver
        # v, omega before the step: the approach speeds restitution reflects
        solver.prepare_contacts(w, self.contacts, h, s.v, s.omega, x=Y, R=s.R, I_inv=self._inverse_inertia(Y),
                                shapes=self.pipeline)
        # joints (Box2D's order: joints before contacts in each solve); x is read from Y's first columns
        joints = self.joints if self.has_joints() else None
        if joints is not None:
            joints.prepare(w, h, w.inv_mass, self.I_inv, x=Y)
        armature = joints is not None and joints.has_armature()
        tree = self.tree_contacts
        tree.split(solver, joints)  # the contacts of jointed bodies, solved through the tree (contact_tree)
        if armature:
            joints.check_armature_rates(Y)  # the last step's rates, unless something moved the bodies since
        if self.fuse and check is None and not w.tables.custom and (joints is None or joints.fusable()):
            self._fused_substeps(Y, h, substeps, kinematic, joints, armature)
            substeps = 0  # done: the same stages as the loop below, compiled together
        for k in range(substeps):
            if armature:
                # the armature rows' target: before the forces derive omega again from L
                # (joint_solve.first_substep_rates_kernel says why)
                joints.capture_rates(s.v, s.omega, Y, s.R, first=k == 0)
            if k > 0:
                w.evaluate_forces(t + k * h, Y, s)
            if check is not None:
                check("accumulate_forces", t + k * h, F=s.F, T=s.T)
            integrate_velocities_kernel(layout, Y, active, w.inv_mass, w.inertia_body, w.inertia_body_inv, s.F, s.T, h,
                                        w.kinematic_v, w.kinematic_omega, s.R, s.v, s.omega, self.I_inv, self.I_world)
            if joints is not None:
                joints.warm_start(s.v, s.omega, Y, s.R)
            solver.warm_start(fresh=k == 0)
            if joints is not None:
                joints.solve(s.v, s.omega, Y, s.R, True)
                if len(tree.contacts) and k == 0:
                    _tree_responses(tree.parts(), self._contact_tables()[0], self._joint_tables(joints),
                                    joints.tree_parts(), w.inv_mass, self.I_inv)
            self._solve_contacts(True, joints)
            integrate_positions_kernel(layout, Y, active, kinematic, self._jointed(), s.v, s.omega, h, self.I_world,
                                       w.inertia_body_inv, s.R)
            if joints is not None:
                joints.solve(s.v, s.omega, Y, s.R, False)
            self._solve_contacts(False, joints)
            if armature:  # the joints last (substeps_kernel says why), on the relax solve's factors
                joints.solve(s.v, s.omega, Y, s.R, False, factor=False)
            store_momenta_kernel(layout, Y, active, w.mass, s.v, s.omega, self.I_world)
            solver.accumulate_step_impulses()
            if check is not None:
                check("solve_contacts", t + (k + 1) * h, Y=Y)
        solver.apply_restitution(tree, joints, int(round(dt / h)))
        store_momenta_kernel(layout, Y, active, w.mass, s.v, s.omega, self.I_world)
        solver.store_impulses()
        if joints is not None:
            joints.store(s.v, s.omega, Y, s.R)

    def _fused_substeps(self, Y, h: float, substeps: int, kinematic, joints, armature: bool):
        """The substep loop of ``step`` in one kernel (``substeps_kernel``): the same stages."""
        # The contact kernels it calls are compiled with ``parallel`` (slabs on both cores), and
        # Numba starts its thread pool only when a parallel function is compiled or loaded through
        # its own dispatcher: called from this kernel before any parallel kernel had run in the
        # process (a small scene prepares its contacts on the calling thread), they crashed
        # (a segmentation fault; found by tests/physics/test_kinematic.py, reproduced by a script
        # stepping a box on a kinematic platform, and gone when the pool is started first).
        start_threads()
        w = self.world
        s = self.scratch
        tb = w.tables
        contacts, rolling = self._contact_tables()
        forces = (tb.uforce_kind, tb.uforce_param, tb.uforce_start, tb.spring_body, tb.spring_anchor, tb.spring_param)
        if joints is None:  # the kernel without joint stages reads none of the joint arguments
            joint_args, impulses = (None, False, None, None, None, 0, 0, False, None), None
        else:
            st = joints.settings
            joint_args = (self._joint_tables(joints), st.method == "tree", joints.tree_parts(), joints.soft_bias,
                          joints.soft_relax, int(st.velocity_iterations), int(st.relax_iterations), armature,
                          joints.armature_rate)
            impulses = (joints.linear_impulse, joints.angular_impulse, joints.axial_impulse)
        SUBSTEPS_KERNELS[joints is not None](
            w.layout_id, Y, self.active, kinematic, self._jointed(), w.mass, w.inv_mass, w.inertia_body, w.inertia_body_inv,
            w.moving, w.gravity, forces, w.kinematic_v, w.kinematic_omega, h, substeps, *joint_args, contacts, rolling,
            float(self.settings.contact_speed), self.tree_contacts.parts(), s.R, s.v, s.omega, s.F, s.T, self.I_inv,
            self.I_world, impulses)

    def _jointed(self) -> np.ndarray:
        """(N,) bool: the bodies in a joint (they turn at their solved omega: ``integrate_positions_kernel``)."""
        return self.jointed if self.has_joints() else self.no_kinematic

    @staticmethod
    def _joint_tables(joints) -> tuple:
        """``JointSolver``'s tables as ``substeps_kernel`` takes them (``_solve_joints`` unpacks them)."""
        n = joints.count
        return (joints.sweep.order[:n], joints.sweep.bounds, joints.joint_type, joints.joint_a, joints.joint_b,
                joints.local_a, joints.local_b, joints.frame_a, joints.frame_b, joints.param, joints.enabled,
                joints.gauss_seidel, joints.position, joints.rate0)

    def _contact_tables(self) -> tuple:
        """(contacts, rolling): ``ContactSolver``'s arrays as ``substeps_kernel`` takes them."""
        sol = self.solver
        m = sol.count
        if not m:
            return self._no_contacts()
        c = sol.contacts
        contacts = (sol.sweep.order[:m], sol.sweep.bounds, c.contact_body_a, c.contact_body_b, c.contact_normal,
                    sol.tangent1, sol.tangent2, sol.local_a, sol.local_b, sol.anchor_offset, sol.separation_base,
                    sol.normal_mass, sol.tangent_mass, sol.soft, sol.friction, sol.surface_target,
                    sol.normal_impulse, sol.tangent_impulse, sol.max_normal_impulse, sol.relative_velocity,
                    sol.last_normal_speed, sol.arm_a, sol.arm_b, sol.gap, sol.step_normal_impulse,
                    sol.step_tangent_impulse)
        return contacts, (sol.rolling_rows, sol.rolling_impulse, sol.rolling_mass, sol.rolling_limit)

    def _solve_contacts(self, use_bias: bool, joints):
        """One contact sweep of ``step``'s loop: the contact solver's, then the contacts of jointed bodies
        through the tree (``substeps_kernel``'s order)."""
        tree = self.tree_contacts
        self.solver.solve_contacts(use_bias, tree.order, tree.bounds)
        if len(tree.contacts):
            sol = self.solver
            _solve_tree_contacts(bool(use_bias), tree.parts(), self._contact_tables()[0], sol.x, sol.R, 1.0 / sol.h,
                                 float(self.settings.contact_speed), sol.v, sol.omega,
                                 (joints.linear_impulse, joints.angular_impulse, joints.axial_impulse))

    def _no_contacts(self):
        """``substeps_kernel``'s contact tables with no rows (the types of ``ContactSolver``'s)."""
        if self.__dict__.get("_empty_contacts") is None:
            z = np.zeros
            i64 = np.int64
            contacts = (z(0, i64), z(2, i64), z(0, i64), z(0, i64), z((0, 3)), z((0, 3)), z((0, 3)), z((0, 3)),
                        z((0, 3)), z((0, 7)), z(0), z(0), z((0, 2)), z((0, 3)), z(0), z((0, 2)), z(0), z((0, 2)),
                        z(0), z(0), z(0), z((0, 3)), z((0, 3)), z(0), z(0), z((0, 2)))
            self._empty_contacts = (contacts, (z(0, i64), z((0, 3)), z((0, 3)), z((0, 2))))
        return self._empty_contacts

    def _inverse_inertia(self, Y):
        """I^-1 (N, 3, 3) of the active bodies at the start of the step (0 elsewhere), for prepare_contacts."""
        w = self.world
        s = self.scratch
        # a kick of zero fills R, v, omega, I_inv, I_world from Y without changing it
        integrate_velocities_kernel(w.layout_id, Y, self.active, w.inv_mass, w.inertia_body, w.inertia_body_inv,
                                    self.no_force, self.no_force, 0.0, w.kinematic_v, w.kinematic_omega,
                                    s.R, s.v, s.omega, self.I_inv, self.I_world)
        return self.I_inv

    # -- contacts as data ------------------------------------------------------------
    def query(self) -> Contacts:
        """The contacts of the last step, as a ``Contacts`` record (copies)."""
        fields = self.contact_fields()
        names = np.asarray(self.world.names, dtype=str)
        return Contacts(names_a=names[fields["body_a"]], names_b=names[fields["body_b"]], **fields)

    def contact_fields(self) -> dict:
        """``Contacts``' fields but the names, {field: (C,) or (C, 3)} (copies), of the last step's
        contacts."""
        c = self.contacts
        if c is None or c.contact_count == 0:
            z = np.zeros(0, dtype=np.int64)
            return dict(body_a=z, body_b=z, point=np.zeros((0, 3)), normal=np.zeros((0, 3)), separation=np.zeros(0),
                        normal_impulse=np.zeros(0), friction_impulse=np.zeros((0, 3)), force=np.zeros((0, 3)),
                        part_a=z, part_b=z)
        sol = self.solver
        body_a, body_b = c.contact_body_a.copy(), c.contact_body_b.copy()
        normal = c.contact_normal.copy()
        jn = sol.step_normal_impulse.copy()
        jt = sol.step_tangent_impulse
        friction = jt[:, 0:1] * sol.tangent1 + jt[:, 1:2] * sol.tangent2
        dt = self.dt if self.dt > 0 else 1.0
        part_a, part_b = self._parts(c.contact_key, body_a, body_b)
        return dict(body_a=body_a, body_b=body_b, point=c.contact_point.copy(), normal=normal,
                    separation=c.contact_separation.copy(), normal_impulse=jn, friction_impulse=friction,
                    force=(jn[:, None] * normal + friction) / dt, part_a=part_a, part_b=part_b)

    def _parts(self, key, body_a, body_b):
        """(part_a, part_b) (C,) int64 of contacts with ``key`` (C,) between ``body_a``, ``body_b``:
        the shapes from the key ((shape_a << 42) | (shape_b << 21) | feature), each less its body's
        first row of the shape table (rows in body order, one per part)."""
        shape_body = self.pipeline.table.shape_body
        mask = (1 << KEY_BITS) - 1
        return (((key >> (2 * KEY_BITS)) & mask) - np.searchsorted(shape_body, body_a),
                ((key >> KEY_BITS) & mask) - np.searchsorted(shape_body, body_b))

    def resting_fields(self, bodies, dt: float | None = None) -> dict:
        """The contacts of ``bodies`` (N,) bool (an island falling asleep), as ``contact_fields``:
        those ``collide`` has just found (the poses at the start of this step: the last step's
        end), with the last step's impulses of the same contact (by ``contact_key``: the solver
        still holds them until this step's ``prepare_contacts``; none for a contact new now).
        Only when an island falls asleep (``SleepState.keep_resting``), so a step pays nothing
        for it (a copy of the last step's contacts each step near sleep cost the 1000-box pile
        8 % of its time: measured)."""
        c = self.contacts
        if c is None or c.contact_count == 0:
            return self.contact_fields()  # empty
        rows = np.flatnonzero(bodies[c.contact_body_a] | bodies[c.contact_body_b])
        key = c.contact_key[rows]
        normal = c.contact_normal[rows].copy()
        jn, friction = np.zeros(len(rows)), np.zeros((len(rows), 3))
        sol = self.solver
        # the last step's row of each (sol.old_key[:old_count], in the order of its impulse arrays)
        j = match_contacts(sol.old_key[:sol.old_count], key)
        found = j >= 0
        j = j[found]
        jn[found], friction[found] = sol.last_step_impulses(j)
        # the step's dt (s) for the mean forces: given by the Simulator (a soft step made anew by a
        # restore has taken no step to know it from; its forces were the impulses per second)
        dt = dt if dt else self.dt if self.dt > 0 else 1.0
        body_a, body_b = c.contact_body_a[rows].copy(), c.contact_body_b[rows].copy()
        part_a, part_b = self._parts(key, body_a, body_b)
        return dict(body_a=body_a, body_b=body_b, point=c.contact_point[rows].copy(), normal=normal,
                    separation=c.contact_separation[rows].copy(), normal_impulse=jn, friction_impulse=friction,
                    force=(jn[:, None] * normal + friction) / dt, part_a=part_a, part_b=part_b)
