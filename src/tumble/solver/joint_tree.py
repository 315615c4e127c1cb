"""The exact solve of the rigid rows of a spanning forest of joints in linear time (Baraff,
"Linear-Time Dynamics using Lagrange Multipliers", SIGGRAPH 1996): ``JointSettings.method =
"tree"``. Reads x, R, inv_mass, I_inv and the joint tables; writes v, omega (N, 3)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..joints import (
    G_MASS,
    JOINT_BALL,
    JOINT_DISTANCE,
    JOINT_GEAR,
    JOINT_HINGE,
    JOINT_SLIDER,
    JOINT_UNIVERSAL,
    P_ARMATURE,
    P_LIMIT2_ON,
    P_LIMIT_ON,
    P_LOWER,
    P_LOWER2,
    P_RIGID,
    P_UPPER,
    P_UPPER2,
)
from ..math3d import (
    JIT,
    NO_NRT,
)
from .joint_gear import free_mass, gear_entries, gear_on, gear_row, solve_gear
from .joint_math import (
    _add,
    _anchor,
    _apply_angular,
    _apply_linear,
    _axis,
    _cross,
    _dot,
    _frames,
    _inv_m,
    _mat_vec,
    _row_velocity,
    _scale,
    _sub,
)
from .joint_solve import (
    A_ARMATURE,
    A_EQUAL,
    A_LOWER,
    A_LOWER2,
    _centred_angle,
    _coordinate_row,
    _second_row,
    limit_impulse_after,
    limit_rows_idle,
    limit_side,
    solve_joints_serial_kernel,
    tree_limited,
)


# ---------------------------------------------------------------------- exact solve on trees
# Baraff, "Linear-Time Dynamics using Lagrange Multipliers", SIGGRAPH 1996: the KKT matrix
# H = [[M, J^T], [J, 0]] of a tree of bodies and joints, ordered leaves first, factors as
# L D L^T with no fill-in. Each node (a moving body: 6 dofs v, omega; a joint: up to 6 rigid
# rows, padded with identity rows) is one 6x6 block.
@njit(**NO_NRT)
def _joint_rows(j, t, a, b, x, R, local_a, local_b, frame_a, frame_b, param, Ja, Jb, C):
    """Rigid rows of joint j at the current pose into Ja[j], Jb[j] (6, 6) (rows x (v, omega)
    of body a / b) and their errors C[j] (6,) (m or rad). Returns the row count."""
    for r in range(6):
        C[j, r] = 0.0
        for c in range(6):
            Ja[j, r, c] = 0.0
            Jb[j, r, c] = 0.0
    ra, pa = _anchor(x, R, a, local_a, j)
    rb, pb = _anchor(x, R, b, local_b, j)
    d = _sub(pb, pa)
    n = 0
    if t != JOINT_BALL and t != JOINT_DISTANCE:
        xa, ya, za, xb, yb, zb = _frames(R, a, b, frame_a, frame_b, j)
        if t == JOINT_HINGE:
            e = _cross(za, zb)
            dirs = (xa, ya, za)
            errs = (_dot(e, xa), _dot(e, ya), 0.0)
            count = 2
        elif t == JOINT_UNIVERSAL:
            nn = _cross(yb, xa)
            nn = _scale(1.0 / max(math.sqrt(_dot(nn, nn)), 1e-12), nn)
            dirs = (nn, xa, ya)
            errs = (_dot(xa, yb), 0.0, 0.0)
            count = 1
        else:
            e = _scale(0.5, _add(_add(_cross(xa, xb), _cross(ya, yb)), _cross(za, zb)))
            dirs = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
            errs = e
            count = 3
        for k in range(count):
            u = dirs[k]
            for c in range(3):
                Ja[j, n, 3 + c] = -u[c]
                Jb[j, n, 3 + c] = u[c]
            C[j, n] = errs[k]
            n += 1
    if t == JOINT_DISTANCE:
        if param[j, P_RIGID] == 0.0:
            return n
        length = math.sqrt(_dot(d, d))
        if length < 1e-12:
            return n
        dirs = (_scale(1.0 / length, d), d, d)
        errs = (length - param[j, P_LOWER], 0.0, 0.0)
        count = 1
    elif t == JOINT_SLIDER:
        ra = _add(ra, d)
        p1 = _axis(R, a, frame_a, j, 0)
        p2 = _axis(R, a, frame_a, j, 1)
        dirs = (p1, p2, p2)
        errs = (_dot(d, p1), _dot(d, p2), 0.0)
        count = 2
    else:
        dirs = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
        errs = d
        count = 3
    for k in range(count):
        u = dirs[k]
        ca = _cross(ra, u)
        cb = _cross(rb, u)
        for c in range(3):
            Ja[j, n, c] = -u[c]
            Ja[j, n, 3 + c] = -ca[c]
            Jb[j, n, c] = u[c]
            Jb[j, n, 3 + c] = cb[c]
        C[j, n] = errs[k]
        n += 1
    return n


@njit(**NO_NRT)
def _gauss_jordan(A, out, n):
    """out[:n, :n] = A[:n, :n]^-1 (Gauss-Jordan, partial pivoting); A is overwritten. False if singular."""
    for r in range(n):
        for c in range(n):
            out[r, c] = 1.0 if r == c else 0.0
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(A[r, c]) > abs(A[p, c]):
                p = r
        if A[p, c] == 0.0:
            return False
        if p != c:
            for k in range(n):
                A[c, k], A[p, k] = A[p, k], A[c, k]
                out[c, k], out[p, k] = out[p, k], out[c, k]
        inv = 1.0 / A[c, c]
        for k in range(n):
            A[c, k] *= inv
            out[c, k] *= inv
        for r in range(n):
            if r != c and A[r, c] != 0.0:
                f = A[r, c]
                for k in range(n):
                    A[r, k] -= f * A[c, k]
                    out[r, k] -= f * out[c, k]
    return True


@njit(**NO_NRT)
def _invert6(A, out):
    """out = A^-1 for a 6x6 A (``_gauss_jordan``); A is overwritten. False if singular."""
    return _gauss_jordan(A, out, 6)


@njit(**NO_NRT)
def _invert3(A, out):
    """out[:3, :3] = A[:3, :3]^-1 by ``_gauss_jordan``: the bits ``_invert6`` gives for the
    block-diagonal (A, identity) a body node's inertia makes (its pivots never leave the block, and
    the identity's rows and columns add and scale only zeros), at an eighth of the work."""
    return _gauss_jordan(A, out, 3)


@njit(**NO_NRT)
def _project_accumulated(j, t, a, b, x, R, local_a, local_b, m, Jb, inv_mass, I_inv, v, omega,
                         linear_impulse, angular_impulse):
    """Put joint j's accumulated angular (hinge: 2 rows, universal: 1) and linear (slider: 2
    rows) impulses back in the span of its current rigid rows (``Jb[j]``, unit directions,
    orthogonal within a block), and take the part outside it back off the bodies (the warm
    start of this substep applied it).

    Why: the tree solve adds lambda along the rows of the current pose, which turn with the
    bodies, so the sum of a rotating direction's impulses leaves a part along the joint's
    free axes; warm started every substep, that part is a torque (or force) about a free
    axis that does work. It pumped a floating, spinning ball + universal chain up 5e4 times
    in energy in 2 s (docs/joints.md). ``_solve_rigid`` (Gauss-Seidel) keeps only the parts
    along the current rows ((o1 + i1) n) and has no such drift. With 3 rows of a kind
    (anchor, fixed, slider's angular block) the span is everything: nothing to do."""
    n_ang = 0
    n_lin = 0
    for r in range(m):
        if Jb[j, r, 0] != 0.0 or Jb[j, r, 1] != 0.0 or Jb[j, r, 2] != 0.0:
            n_lin += 1
        else:
            n_ang += 1
    if t == JOINT_DISTANCE:
        return  # its row is accumulated in axial_impulse (a scalar along the current line)
    if 0 < n_ang < 3:
        old = (angular_impulse[j, 0], angular_impulse[j, 1], angular_impulse[j, 2])
        kept = (0.0, 0.0, 0.0)
        for r in range(n_ang):
            u = (Jb[j, r, 3], Jb[j, r, 4], Jb[j, r, 5])
            kept = _add(kept, _scale(_dot(old, u), u))
        _apply_angular(omega, I_inv, a, b, _sub(kept, old))
        angular_impulse[j, 0], angular_impulse[j, 1], angular_impulse[j, 2] = kept
    if 0 < n_lin < 3:
        old = (linear_impulse[j, 0], linear_impulse[j, 1], linear_impulse[j, 2])
        kept = (0.0, 0.0, 0.0)
        for r in range(n_ang, m):
            u = (Jb[j, r, 0], Jb[j, r, 1], Jb[j, r, 2])
            kept = _add(kept, _scale(_dot(old, u), u))
        ra, pa = _anchor(x, R, a, local_a, j)
        rb, pb = _anchor(x, R, b, local_b, j)
        if t == JOINT_SLIDER:
            ra = _add(ra, _sub(pb, pa))
        _apply_linear(v, omega, inv_mass, I_inv, a, b, ra, rb, _sub(kept, old))
        for c in range(3):
            linear_impulse[j, c] = kept[c]


@njit(**NO_NRT)
def _has_armature_row(j, t, param):
    """Whether joint j's tree block has an armature row (a hinge or slider with armature)."""
    return param[j, P_ARMATURE] > 0.0 and (t == JOINT_HINGE or t == JOINT_SLIDER)


@njit(**NO_NRT)
def tree_factor_kernel(order, lo, hi, node_joint, node_body, node_parent, joint_type, joint_a, joint_b, local_a,
                       local_b, frame_a, frame_b, param, position, x, R, inv_mass, I_inv,
                       # outputs (scratch)
                       Ja, Jb, C, nrow, D, Dinv, H_up, W, work):
    """The rigid rows of the tree joints at the current pose (``Ja``, ``Jb`` (J, 6, 6), ``C`` (J, 6),
    ``nrow`` (J,)) and the block L D L^T factors of their KKT matrix H = [[M, J^T], [J, -compliance]]
    in ``order`` (leaves first) of the nodes lo..hi - 1 (a forest's, or one tree's: its node range,
    ``tree_layout``): ``Dinv`` (n, 6, 6) the pivots' inverses, ``H_up`` (n, 6, 6) each
    node's block with its parent, ``W`` = Dinv H_up (n, 6, 6) (Baraff 1996's elimination).

    Nodes: ``node_joint[k]`` >= 0 for a joint node, else ``node_body[k]`` is a body node;
    ``node_parent[k]`` (-1 for a root). They depend on the poses, masses and inertias only, so one
    factorization serves every sweep of a solve (``tree_sweeps_kernel``): only the right-hand side
    changes (``tree_substitute_kernel``).

    A hinge or slider with armature a (``param[:, P_ARMATURE]``) gets one more row in its block,
    its coordinate's rate, soft: J (u + du) + lambda_total / a = rate0 (the armature's own rate
    before this substep's forces, ``joint_solve.flywheel_rates_kernel``), i.e. the impulse
    -a (q' - q'_0) of the inertia a added to the coordinate (MuJoCo's armature), solved exactly
    with the chain: a compliance 1/a on the KKT matrix's diagonal (the soft constraint's form,
    Catto GDC 2011). Its rigid rows are at most 5, so the 6x6 block has room.
    """
    n_nodes = order.shape[0]
    for k in range(lo, hi):
        j = node_joint[k]
        if j >= 0:
            nrow[j] = _joint_rows(j, joint_type[j], joint_a[j], joint_b[j], x, R, local_a, local_b, frame_a, frame_b,
                                  param, Ja, Jb, C)
            if _has_armature_row(j, joint_type[j], param):
                m = nrow[j]
                has, lin, u, ra, rb, _pos = _coordinate_row(joint_type[j], j, joint_a[j], joint_b[j], x, R, local_a,
                                                            local_b, frame_a, frame_b, position)
                if has:
                    ca = _cross(ra, u)
                    cb = _cross(rb, u)
                    for c in range(3):
                        Ja[j, m, c] = -u[c] if lin else 0.0
                        Jb[j, m, c] = u[c] if lin else 0.0
                        Ja[j, m, 3 + c] = -ca[c] if lin else -u[c]
                        Jb[j, m, 3 + c] = cb[c] if lin else u[c]
    # diagonal blocks
    for k in range(lo, hi):
        j = node_joint[k]
        for r in range(6):
            for c in range(6):
                D[k, r, c] = 0.0
        if j >= 0:
            m = nrow[j]
            for r in range(m, 6):
                D[k, r, r] = 1.0
            if _has_armature_row(j, joint_type[j], param):
                D[k, m, m] = -1.0 / param[j, P_ARMATURE]
        else:
            i = node_body[k]
            # M = diag(m 1, I_world), I_world = I_inv^-1
            for r in range(3):
                D[k, r, r] = 1.0 / inv_mass[i]
            for r in range(3):
                for c in range(3):
                    work[r, c] = I_inv[i, r, c]
            # PERF: I_world by the 3x3 block alone (the same bits as the 6x6 of (I_inv, identity))
            _invert3(work, Dinv[k])
            for r in range(3):
                for c in range(3):
                    D[k, 3 + r, 3 + c] = Dinv[k, r, c]
    # H_up[k] = H[k, parent]: joint rows x body dofs, or its transpose
    for k in range(lo, hi):
        p = node_parent[k]
        if p < 0:
            continue
        j = node_joint[k]
        if j >= 0:
            J = Ja if joint_a[j] == node_body[p] else Jb
            for r in range(6):
                for c in range(6):
                    H_up[k, r, c] = J[j, r, c]
        else:
            jp = node_joint[p]
            J = Ja if joint_a[jp] == node_body[k] else Jb
            for r in range(6):
                for c in range(6):
                    H_up[k, r, c] = J[jp, c, r]
    # factor, leaves first: W_k = D_k^-1 H_kp, D_p -= H_kp^T W_k
    for kk in range(n_nodes):
        k = order[kk]
        for r in range(6):
            for c in range(6):
                work[r, c] = D[k, r, c]
        if not _invert6(work, Dinv[k]):
            for r in range(6):
                for c in range(6):
                    Dinv[k, r, c] = 0.0
        p = node_parent[k]
        if p < 0:
            continue
        for r in range(6):
            for c in range(6):
                s = 0.0
                for m in range(6):
                    s += Dinv[k, r, m] * H_up[k, m, c]
                W[k, r, c] = s
        for r in range(6):
            for c in range(6):
                s = 0.0
                for m in range(6):
                    s += H_up[k, m, r] * W[k, m, c]
                D[p, r, c] -= s


@njit(**NO_NRT)
def _substitute(order, node_parent, Dinv, H_up, W, y, sol, work, skip):
    """sol = H^-1 y on the factors (n, 6, 6) of ``tree_factor_kernel``; y (n, 6) is overwritten.
    Nodes with ``skip`` (n,) set are left out (whole trees: a node's parent is in its tree)."""
    n_nodes = order.shape[0]
    # forward substitution, leaves first: y_p -= W_k^T y_k
    for kk in range(n_nodes):
        k = order[kk]
        p = node_parent[k]
        if p < 0 or skip[k]:
            continue
        for r in range(6):
            s = 0.0
            for m in range(6):
                s += W[k, m, r] * y[k, m]
            y[p, r] -= s
    # back substitution, roots first: sol_k = D_k^-1 (y_k - H_kp sol_p)
    for kk in range(n_nodes - 1, -1, -1):
        k = order[kk]
        if skip[k]:
            continue
        p = node_parent[k]
        for r in range(6):
            s = y[k, r]
            if p >= 0:
                for m in range(6):
                    s -= H_up[k, r, m] * sol[p, m]
            work[0, r] = s
        for r in range(6):
            s = 0.0
            for m in range(6):
                s += Dinv[k, r, m] * work[0, m]
            sol[k, r] = s


# ---------------------------------------------------------------------- rows solved through the tree
# A row outside the tree's rigid rows (a contact: contact_tree; a hinge's or slider's limit:
# tree_limits_kernel) solved as a row of the whole tree: its response M_art^-1 J^T, the change of
# every velocity of the tree and of every joint's impulse under a unit impulse along it, is the
# free bodies' response followed by the exact joint solve it calls for: one substitution on the
# factors. Applied with it, an impulse leaves the velocities consistent with the joints, and the
# row's mass 1 / (J M_art^-1 J^T) is the inertia behind it. Slots: a body i >= 0 with (dv, dw, 0, 0)
# or a joint -(j + 1) with (linear, angular, A_EQUAL, A_ARMATURE impulses), per unit impulse.
@njit(**NO_NRT)
def _free_response(i, a, b, dva, dwa, dvb, dwb):
    """Body i's free velocity change (dv, dw) under the row's unit impulse: a's or b's (zero for
    any other body, the world included)."""
    if i >= 0 and i == a:
        return dva, dwa
    if i >= 0 and i == b:
        return dvb, dwb
    return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)


@njit(**NO_NRT)
def tree_row_response(t, a, b, dva, dwa, dvb, dwb, tree_lo, tree_hi, node_order, node_joint, node_body, node_parent,
                      joint_type, joint_a, joint_b, param, Ja, Jb, nrow, Dinv, H_up, W, y, sol, work, no_skip,
                      slot_ref, slot_resp, r, count):
    """Row r's response over tree t's nodes into its slots from ``count`` on (returns the new count):
    bodies a and b (-1: none) move by (dva, dwa), (dvb, dwb) under the row's unit impulse as free
    bodies; each joint of the tree reads that, and the exact solve (``_substitute`` on the tree's
    own nodes, leaves first: node_order[n - hi:n - lo]) answers. ``no_skip`` (n,) all False."""
    n_nodes = node_order.shape[0]
    lo = tree_lo[t]
    hi = tree_hi[t]
    for kk in range(lo, hi):
        for m in range(6):
            y[kk, m] = 0.0
        j = node_joint[kk]
        if j < 0:
            continue
        dv1, dw1 = _free_response(joint_a[j], a, b, dva, dwa, dvb, dwb)
        dv2, dw2 = _free_response(joint_b[j], a, b, dva, dwa, dvb, dwb)
        rows = nrow[j] + 1 if _has_armature_row(j, joint_type[j], param) else nrow[j]
        for m in range(rows):
            acc = 0.0
            for e in range(3):
                acc += Ja[j, m, e] * dv1[e] + Ja[j, m, 3 + e] * dw1[e] + Jb[j, m, e] * dv2[e] + Jb[j, m, 3 + e] * dw2[e]
            y[kk, m] = -acc
    _substitute(node_order[n_nodes - hi:n_nodes - lo], node_parent, Dinv, H_up, W, y, sol, work, no_skip)
    for kk in range(lo, hi):
        j = node_joint[kk]
        for m in range(8):
            slot_resp[r, count, m] = 0.0
        if j < 0:
            i = node_body[kk]
            dv, dw = _free_response(i, a, b, dva, dwa, dvb, dwb)
            for e in range(3):
                slot_resp[r, count, e] = sol[kk, e] + dv[e]
                slot_resp[r, count, 3 + e] = sol[kk, 3 + e] + dw[e]
            slot_ref[r, count] = i
        else:
            # the joint's impulses as the exact solve adds them (tree_substitute_kernel)
            m_rows = nrow[j]
            if _has_armature_row(j, joint_type[j], param):
                slot_resp[r, count, 7] = -sol[kk, m_rows]
            for m in range(m_rows):
                lam = -sol[kk, m]
                lin = Jb[j, m, 0] != 0.0 or Jb[j, m, 1] != 0.0 or Jb[j, m, 2] != 0.0
                if joint_type[j] == JOINT_DISTANCE:
                    slot_resp[r, count, 6] += lam
                elif lin:
                    for e in range(3):
                        slot_resp[r, count, e] += lam * Jb[j, m, e]
                else:
                    for e in range(3):
                        slot_resp[r, count, 3 + e] += lam * Jb[j, m, 3 + e]
            slot_ref[r, count] = -(j + 1)
        count += 1
    return count


@njit(**NO_NRT)
def slot_rate(r, count, slot_ref, slot_resp, i, ja, jw):
    """The rate (ja . dv + jw . dw) of body i's slots of row r (the first ``count``): body i's part
    of J M_art^-1 J^T for its Jacobian (ja, jw)."""
    s = 0.0
    if i < 0:
        return s
    for q in range(count):
        if slot_ref[r, q] == i:
            for e in range(3):
                s += ja[e] * slot_resp[r, q, e] + jw[e] * slot_resp[r, q, 3 + e]
    return s


@njit(**NO_NRT)
def apply_row_response(r, impulse, count, slot_ref, slot_resp, v, omega, linear_impulse, angular_impulse,
                       axial_impulse):
    """An impulse (N s or N m s) along row r: every velocity and joint impulse of its slots (the first
    ``count``) by the row's response."""
    for q in range(count):
        ref = slot_ref[r, q]
        if ref >= 0:
            for e in range(3):
                v[ref, e] += impulse * slot_resp[r, q, e]
                omega[ref, e] += impulse * slot_resp[r, q, 3 + e]
        else:
            j = -ref - 1
            for e in range(3):
                linear_impulse[j, e] += impulse * slot_resp[r, q, e]
                angular_impulse[j, e] += impulse * slot_resp[r, q, 3 + e]
            axial_impulse[j, A_EQUAL] += impulse * slot_resp[r, q, 6]
            axial_impulse[j, A_ARMATURE] += impulse * slot_resp[r, q, 7]


#: a row whose response through the tree is below this fraction of its free bodies' is held by the joints
#: (a hinged rod's point along the hinge's axis answers with rounding, 4e-17 of it: no mass, not 1 / rounding)
RESPONSE_FLOOR = 1e-12


@njit(**NO_NRT)
def _tree_of(i, body_node, node_tree):
    """The tree of body i (-1: the world, a fixed body, a body in no tree)."""
    if i < 0:
        return -1
    k = body_node[i]
    return node_tree[k] if k >= 0 else -1


@njit(**NO_NRT)
def tree_row(r, a, b, ja, jwa, jb, jwb, inv_mass, I_inv, body_node, node_tree, tree_lo, tree_hi, node_order,
             node_joint, node_body, node_parent, joint_type, joint_a, joint_b, param, Ja, Jb, nrow, Dinv, H_up, W, y,
             sol, work, no_skip, slot_count, slot_ref, slot_resp):
    """Row r with Jacobian (ja, jwa) on body a and (jb, jwb) on body b (-1: the world): its response
    through the trees of a and b (``tree_row_response``), and for a moving side outside every tree
    its free response, into its slots (``slot_count[r]`` of them). Returns its mass
    1 / (J M_art^-1 J^T) (kg, or kg m^2 for an angular row), 0 for a direction the joints hold
    (``RESPONSE_FLOOR``)."""
    dva = _scale(_inv_m(inv_mass, a), ja)
    dwa = _mat_vec(I_inv, a, jwa)
    dvb = _scale(_inv_m(inv_mass, b), jb)
    dwb = _mat_vec(I_inv, b, jwb)
    ta = _tree_of(a, body_node, node_tree)
    tb = _tree_of(b, body_node, node_tree)
    count = 0
    if ta >= 0:
        count = tree_row_response(ta, a, b, dva, dwa, dvb, dwb, tree_lo, tree_hi, node_order, node_joint, node_body,
                                  node_parent, joint_type, joint_a, joint_b, param, Ja, Jb, nrow, Dinv, H_up, W, y,
                                  sol, work, no_skip, slot_ref, slot_resp, r, count)
    if tb >= 0 and tb != ta:
        count = tree_row_response(tb, a, b, dva, dwa, dvb, dwb, tree_lo, tree_hi, node_order, node_joint, node_body,
                                  node_parent, joint_type, joint_a, joint_b, param, Ja, Jb, nrow, Dinv, H_up, W, y,
                                  sol, work, no_skip, slot_ref, slot_resp, r, count)
    for side in range(2):  # a side outside every tree: its free response (nothing for the world or a fixed body)
        i = a if side == 0 else b
        if (ta if side == 0 else tb) >= 0 or _inv_m(inv_mass, i) == 0.0:
            continue
        dv, dw = (dva, dwa) if side == 0 else (dvb, dwb)
        for e in range(3):
            slot_resp[r, count, e] = dv[e]
            slot_resp[r, count, 3 + e] = dw[e]
        slot_resp[r, count, 6] = 0.0
        slot_resp[r, count, 7] = 0.0
        slot_ref[r, count] = i
        count += 1
    slot_count[r] = count
    k = slot_rate(r, count, slot_ref, slot_resp, a, ja, jwa) + slot_rate(r, count, slot_ref, slot_resp, b, jb, jwb)
    k_free = _dot(ja, dva) + _dot(jwa, dwa) + _dot(jb, dvb) + _dot(jwb, dwb)
    return 1.0 / k if k > RESPONSE_FLOOR * k_free else 0.0


def tree_layout(node_body: np.ndarray, node_parent: np.ndarray, body_count: int):
    """``body_node`` (N,), ``node_tree`` (n,), ``tree_lo``, ``tree_hi`` (T,) of the forest whose nodes
    were made parents first, a tree at a time (``JointSolver._build_tree``): each body's node (-1:
    none), each node's tree, each tree's node range."""
    n = node_parent.shape[0]
    roots = np.flatnonzero(node_parent < 0)
    tree_lo = roots.astype(np.int64)
    tree_hi = np.append(roots[1:], n).astype(np.int64)
    node_tree = np.zeros(n, dtype=np.int64)
    for t, (lo, hi) in enumerate(zip(tree_lo, tree_hi)):
        node_tree[lo:hi] = t
    body_node = np.full(body_count, -1, dtype=np.int64)
    bodies = np.flatnonzero(node_body >= 0)
    body_node[node_body[bodies]] = bodies
    return body_node, node_tree, tree_lo, tree_hi


@njit(**NO_NRT)
def tree_substitute_kernel(order, lo, hi, node_joint, node_body, node_parent, joint_type, joint_a, joint_b, local_a,
                           local_b, param, rate0, x, R, inv_mass, I_inv, bias_rate, Ja, Jb, C, nrow, Dinv, H_up, W,
                           # scratch
                           y, sol, work, skip,
                           # outputs
                           v, omega, linear_impulse, angular_impulse, axial_impulse):
    """One exact solve of the rigid rows of the tree joints on the factors of ``tree_factor_kernel``:
    J (u + du) = -bias_rate C, M du = J^T lambda (and the armature rows), by forward and back
    substitution in ``order`` (leaves first) of the nodes lo..hi - 1 (as ``tree_factor_kernel``'s).
    Adds lambda to the joints' accumulated impulses. The nodes with ``skip`` (n,) set (trees whose
    sweeps have settled, ``tree_sweeps_kernel``) are left as they are."""
    # the accumulated impulses put back in the span of the current rows (all joints first: the
    # undo changes velocities the right-hand sides read)
    for k in range(lo, hi):
        j = node_joint[k]
        if j >= 0 and not skip[k]:
            _project_accumulated(j, joint_type[j], joint_a[j], joint_b[j], x, R, local_a, local_b, nrow[j], Jb,
                                 inv_mass, I_inv, v, omega, linear_impulse, angular_impulse)
    # right-hand sides
    for k in range(lo, hi):
        j = node_joint[k]
        if skip[k]:
            continue
        for r in range(6):
            y[k, r] = 0.0
        if j < 0:
            continue
        a = joint_a[j]
        b = joint_b[j]
        m = nrow[j]
        armature = _has_armature_row(j, joint_type[j], param)
        for r in range(m + 1 if armature else m):
            s = bias_rate * C[j, r] if r < m else 0.0
            for c in range(3):
                if a >= 0:
                    s += Ja[j, r, c] * v[a, c] + Ja[j, r, 3 + c] * omega[a, c]
                if b >= 0:
                    s += Jb[j, r, c] * v[b, c] + Jb[j, r, 3 + c] * omega[b, c]
            y[k, r] = -s
        if armature:
            inv_arm = 1.0 / param[j, P_ARMATURE]
            y[k, m] += rate0[j] - inv_arm * axial_impulse[j, A_ARMATURE]
    _substitute(order, node_parent, Dinv, H_up, W, y, sol, work, skip)
    # apply: body nodes take du; joint nodes give lambda = -mu
    for k in range(lo, hi):
        j = node_joint[k]
        if skip[k]:
            continue
        if j < 0:
            i = node_body[k]
            for c in range(3):
                v[i, c] += sol[k, c]
                omega[i, c] += sol[k, 3 + c]
            continue
        t = joint_type[j]
        m = nrow[j]
        if _has_armature_row(j, t, param):
            axial_impulse[j, A_ARMATURE] -= sol[k, m]
        for r in range(m):
            lam = -sol[k, r]
            # a row's world direction is body b's Jacobian: linear part for linear rows,
            # angular part for angular rows (rows are angular first, see _joint_rows)
            lin = Jb[j, r, 0] != 0.0 or Jb[j, r, 1] != 0.0 or Jb[j, r, 2] != 0.0
            if t == JOINT_DISTANCE:
                axial_impulse[j, A_EQUAL] += lam
            elif lin:
                for c in range(3):
                    linear_impulse[j, c] += lam * Jb[j, r, c]
            else:
                for c in range(3):
                    angular_impulse[j, c] += lam * Jb[j, r, 3 + c]


@njit(**NO_NRT)
def _gear_response(i, bodies, scale, lins, angs, inv_mass, I_inv):
    """(dv, dw): body i's part of M^-1 J^T, its velocity change under a unit impulse along a gear's J
    (``joint_gear.gear_entries``)."""
    dv = (0.0, 0.0, 0.0)
    dw = (0.0, 0.0, 0.0)
    if i < 0:
        return dv, dw
    for e in range(4):
        if bodies[e] == i:
            dv = _add(dv, _scale(scale[e] * inv_mass[i], lins[e]))
            dw = _add(dw, _scale(scale[e], _mat_vec(I_inv, i, angs[e])))
    return dv, dw


@njit(**NO_NRT)
def tree_gear_masses(order, node_joint, node_body, node_parent, joint_type, joint_a, joint_b, local_a, local_b,
                     frame_a, frame_b, param, enabled, position, x, R, inv_mass, I_inv, Ja, Jb, nrow, Dinv, H_up, W,
                     y, sol, work, skip):
    """Each acting gear's J M^-1 J^T through the tree into ``param[g, G_MASS]``: the rate of the gear
    row after a unit impulse along it and the exact tree solve that follows (the response of the
    articulated bodies, not of the free ones). The gear is a Gauss-Seidel row around the tree solve;
    with the free bodies' mass, a gear between two pendulums (a 1 kg bob on 0.5 m geared 3:1 to a
    flywheel) converged by about 0.4 % a sweep (the bob's own I about its centre is 1/250 of its
    inertia about the hinge), and the gear slipped 0.34 rad in 2 s with the tree's 32 sweeps
    (measured); with this mass one sweep after the velocities are the tree's meets it (the Schur
    complement of the loop-closing row, as Baraff 1996 treats loops: there by an iteration on the
    whole KKT system). Needs the factors of ``tree_factor_kernel`` at the current poses."""
    n_nodes = order.shape[0]
    for g in range(joint_type.shape[0]):
        if joint_type[g] != JOINT_GEAR or not enabled[g] or not gear_on(g, param, enabled):
            continue
        (_j1, a1, b1, lin1, n1, ra1, rb1, _j2, a2, b2, lin2, n2, ra2, rb2, _C,
         s) = gear_row(g, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position, x, R)
        bodies, scale, lins, angs = gear_entries(a1, b1, lin1, n1, ra1, rb1, a2, b2, lin2, n2, ra2, rb2, s)
        k = free_mass(inv_mass, I_inv, a1, b1, lin1, n1, ra1, rb1, a2, b2, lin2, n2, ra2, rb2, s)
        for kk in range(n_nodes):
            for r in range(6):
                y[kk, r] = 0.0
            j = node_joint[kk]
            if j < 0:
                continue
            a = joint_a[j]
            b = joint_b[j]
            dva, dwa = _gear_response(a, bodies, scale, lins, angs, inv_mass, I_inv)
            dvb, dwb = _gear_response(b, bodies, scale, lins, angs, inv_mass, I_inv)
            rows = nrow[j] + 1 if _has_armature_row(j, joint_type[j], param) else nrow[j]
            for r in range(rows):
                acc = 0.0
                for c in range(3):
                    acc += (Ja[j, r, c] * dva[c] + Ja[j, r, 3 + c] * dwa[c] + Jb[j, r, c] * dvb[c]
                            + Jb[j, r, 3 + c] * dwb[c])
                y[kk, r] = -acc
        _substitute(order, node_parent, Dinv, H_up, W, y, sol, work, skip)
        for kk in range(n_nodes):
            i = node_body[kk]
            if i < 0:
                continue
            for e in range(4):
                if bodies[e] == i:
                    k += scale[e] * (_dot(lins[e], (sol[kk, 0], sol[kk, 1], sol[kk, 2]))
                                     + _dot(angs[e], (sol[kk, 3], sol[kk, 4], sol[kk, 5])))
        param[g, G_MASS] = k if k > 0.0 else 0.0


@njit(**NO_NRT)
def tree_limits_kernel(joints, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, enabled,
                       gauss_seidel, position, x, R, inv_mass, I_inv, h, soft, node_order, node_joint, node_body,
                       node_parent, Ja, Jb, nrow, Dinv, H_up, W, y, sol, work, joint_group, group_done, layout,
                       limit_rows,
                       # outputs
                       v, omega, linear_impulse, angular_impulse, axial_impulse):
    """The limit rows of the tree's joints, each through the tree (``tree_row``), on velocities the
    exact solve has just made consistent: a hinge's or slider's coordinate, a ball joint's cone
    (its swing) and twist, a universal joint's two angles, a distance joint's length (a rope's
    slack and taut ends); the rules of
    ``joint_solve._solve_limit_rows`` (speculative while apart, soft once crossed: ``soft``, the
    solve's (3,)), with the mass of the articulated bodies and the armature behind the coordinate
    (which the Gauss-Seidel row only approximated: the anchor block and ``keep``), and its impulse
    moving the whole tree.

    NOTE: why: as Gauss-Seidel rows around the exact solve, with the free bodies' masses, the limits
    converged slowly (tree_sweeps_kernel's re-sweeps), and beside contacts solved through the tree
    (contact_tree) the two disagreed at rest: Gymnasium's humanoid lying on its arm moved at 0.11
    rad/s with the limits so solved, at 1e-13 with its limits off (measured, session 35). The ball
    joints' cones and twists stayed such rows until session 37: four ragdolls lying in a heap
    (tumble.scenes.ragdolls, the tree method) then never came to rest, a head held on its neck's
    cone limit against the ground rocking with its energy rising from 0.03 J at 8 s to 0.24 J at
    14 s (measured; tests/physics/test_joints_tree_limits.py).

    ``layout``: (body_node, node_tree, tree_lo, tree_hi, no_skip) (``JointSolver.tree_layout``);
    ``limit_rows``: (slot_count, slot_ref (2J, S), slot_resp (2J, S, 8), mass (2J,), valid (2J,)
    bool, soft_limit (3,)): a coordinate's row response (row j the joint's first coordinate, J + j
    its second), taken once per factorization when its limits first act (``valid`` cleared by the
    caller when it factors), and the softness a crossed limit is pushed back at in a biased solve
    (``soft[0] > 0``; ``JointSettings.limit_hertz``). The joints ``joints`` in that order (all, or
    one group's: ``_sweep_group``), each its first coordinate then its second; those of a settled
    group (``group_done``) are left.

    PERF: the row's rules written in this loop, not called per joint: as a function of 40 arguments
    called for every joint and sweep (most return at once: no limit acting), a single hopper's
    compiled substeps took 7-8 % longer (measured, interleaved, session 36)."""
    body_node, node_tree, tree_lo, tree_hi, no_skip = layout
    slot_count, slot_ref, slot_resp, mass, valid, soft_limit = limit_rows
    inv_h = 1.0 / h
    J = joint_type.shape[0]
    for idx in range(joints.shape[0]):
        j = joints[idx]
        t = joint_type[j]
        if gauss_seidel[j] or not enabled[j] or not tree_limited(t):
            continue
        g = joint_group[j]
        if g >= 0 and group_done[g]:
            continue
        a = joint_a[j]
        b = joint_b[j]
        for coordinate in range(2):
            # the first coordinate (a hinge's angle, a slider's length, a ball's swing, a universal's
            # angle about its axis, a distance joint's length), then the second (a ball's twist, a
            # universal's angle about axis_b)
            if coordinate == 0:
                if param[j, P_LIMIT_ON] == 0.0 or param[j, P_RIGID] != 0.0:
                    continue  # (a rigid distance joint's length is a row of the tree itself)
                lower, upper, slot0, r = param[j, P_LOWER], param[j, P_UPPER], A_LOWER, j
                has, lin, u, ra, rb, pos = _coordinate_row(t, j, a, b, x, R, local_a, local_b, frame_a, frame_b,
                                                           position)
                if t == JOINT_UNIVERSAL:
                    pos = _centred_angle(pos, lower, upper)
            else:
                if param[j, P_LIMIT2_ON] == 0.0:  # (set by ball and universal joints only)
                    continue
                lower, upper, slot0, r = param[j, P_LOWER2], param[j, P_UPPER2], A_LOWER2, J + j
                has, u, pos = _second_row(t, j, a, b, R, frame_a, frame_b)
                lin = False
                ra = rb = (0.0, 0.0, 0.0)  # an angular row: its rate (wb - wa) . u needs no arm
                pos = _centred_angle(pos, lower, upper)
            if not has:
                continue
            cdot = _row_velocity(v, omega, a, b, lin, u, ra, rb)
            if limit_rows_idle(j, slot0, lower, upper, pos, cdot, inv_h, axial_impulse):
                continue
            # the coordinate's Jacobian: (ja, jwa) on a, (jb, jwb) on b
            z = (0.0, 0.0, 0.0)
            ja = _scale(-1.0, u) if lin else z
            jwa = _scale(-1.0, _cross(ra, u)) if lin else _scale(-1.0, u)
            jb = u if lin else z
            jwb = _cross(rb, u) if lin else u
            if not valid[r]:
                mass[r] = tree_row(r, a, b, ja, jwa, jb, jwb, inv_mass, I_inv, body_node, node_tree, tree_lo, tree_hi,
                                   node_order, node_joint, node_body, node_parent, joint_type, joint_a, joint_b, param,
                                   Ja, Jb, nrow, Dinv, H_up, W, y, sol, work, no_skip, slot_count, slot_ref, slot_resp)
                valid[r] = True
            if mass[r] == 0.0:
                continue
            for side in range(2):
                sign, C = limit_side(side, lower, upper, pos)
                if math.isinf(C):
                    continue
                slot = slot0 + side
                rate = sign * _row_velocity(v, omega, a, b, lin, u, ra, rb)
                old = axial_impulse[j, slot]
                # the biased solve (soft[0] > 0) pushes a crossed limit back at the limits' own softness
                new = limit_impulse_after(C, inv_h, soft_limit if soft[0] > 0.0 else soft, mass[r], rate, old)
                axial_impulse[j, slot] = new
                apply_row_response(r, sign * (new - old), slot_count[r], slot_ref, slot_resp, v, omega,
                                   linear_impulse, angular_impulse, axial_impulse)


@njit(**NO_NRT)
def tree_sweeps_kernel(iterations, limits, max_sweeps, tolerance, order, bounds, joint_type, joint_a, joint_b,
                       local_a, local_b, frame_a, frame_b, param, enabled, gauss_seidel, position, rate0, x, R,
                       inv_mass, I_inv, h, soft, node_order, node_joint, node_body, node_parent, factor,
                       # scratch
                       Ja, Jb, C, nrow, D, Dinv, H_up, W, y, sol, work, before,
                       joint_group, body_group, group_change, group_largest, group_done, node_skip, sub_order,
                       sub_bounds, layout, limit_rows, groups,
                       # outputs
                       v, omega, linear_impulse, angular_impulse, axial_impulse):
    """One solve of the tree method: ``iterations`` sweeps, each the Gauss-Seidel rows (the
    coordinate rows; the rigid rows of joints outside the tree) then the exact tree solve
    (``tree_substitute_kernel`` on the factors ``tree_factor_kernel`` makes once), and while a limit row's impulse still changes, more sweeps.

    Limit rows are Gauss-Seidel rows around the exact solve, which undoes part of each limit
    impulse as it re-solves the chain: two sweeps leave a limit that a fast chain strikes
    unconverged, and the unconverged impulse comes back as a bounce (a 7-joint arm striking a
    shoulder limit at 7.8 rad/s left it at -7 rad/s, restitution 0.9, with ACCURATE; 30 sweeps:
    0.0). So while an impulse of the ``limits`` columns (L,) of ``axial_impulse`` changes by more
    than ``tolerance`` of the largest, sweep on, up to ``max_sweeps`` (Baraff 1996 solves the
    active limits in the block; this is the fixed point of the same equations, reached slowly:
    that arm pressing on its limit costs 1.3 ms a step against 0.5 ms with two sweeps and
    rebounds at -0.004 rad/s; a 0.1 % tolerance costs 3.0 ms for 0.003 rad/s). Worlds whose
    limits are idle keep their bits. ``before`` (J, L) scratch; soft (3,) as
    ``solve_joints_kernel``'s, its bias rate the tree solve's. ``factor`` (int64): 1 to factor the
    tree at the current poses (2: and make the velocities consistent with the tree before the first
    Gauss-Seidel rows: the biased solve of a substep with armature, whose velocities are each
    body's own after the substep's forces), 0 to solve on the factors (and gear masses) the last call made,
    when nothing they depend on (poses, masses, inertias, parameters) has changed since: the same
    numbers, so the same bits (the soft step's last relax solve of a substep with armature), and
    then with no limit re-sweeps (that last call has just converged them).

    The test is made per group of joints that share moving bodies (``joint_group`` (J,),
    ``body_group`` (N,): ``JointSolver._groups``; -1 outside any): the sweeps after a group has
    settled leave it out (its joints out of the Gauss-Seidel order ``sub_order`` (J,) cut by
    ``sub_bounds`` (as ``bounds``), its tree's nodes ``node_skip`` (n,) in the substitution), so
    each robot of a world ends as it would alone, and a robot that settled costs nothing more.
    With one test over the world, a robot's sweep count, and so its last bits, followed the other
    robots' limits (the copies of a vector environment, ``tumble.envs``, drifted 1e-7 from their
    single environments in one step, measured), and every robot was swept as long as the slowest.
    ``group_change``, ``group_largest`` (G,) float and ``group_done`` (G,) bool scratch.

    ``groups``: the groups' own tables (``JointSolver._group_tables``); when its mode says so and
    the groups are apart (``_groups_apart``), each group is swept on its own, the groups side by
    side on the threads (``_tree_sweeps_groups``): the same operations on each group in the same
    order, so the same bits as this serial loop over the world (each group's rows touch its own
    bodies and joints only).
    """
    L = limits.shape[0]
    G = group_done.shape[0]
    sweeps = iterations
    if L > 0 and iterations > 0 and factor:
        sweeps = max(iterations, max_sweeps)
    for g in range(G):
        group_done[g] = False
    if groups[0] and _groups_apart(joint_a, joint_b, enabled, joint_group, body_group, inv_mass, I_inv):
        _group_orders(order, bounds, joint_group, groups)
        _tree_sweeps_groups(iterations, sweeps, limits, tolerance, joint_type, joint_a, joint_b, local_a, local_b,
                            frame_a, frame_b, param, enabled, gauss_seidel, position, rate0, x, R, inv_mass, I_inv,
                            h, soft, node_order, node_joint, node_body, node_parent, factor, Ja, Jb, C, nrow, D,
                            Dinv, H_up, W, y, sol, before, joint_group, group_done, layout, limit_rows, groups, v,
                            omega, linear_impulse, angular_impulse, axial_impulse)
        return
    n_nodes = node_order.shape[0]
    for k in range(n_nodes):
        node_skip[k] = False
    for idx in range(order.shape[0]):
        sub_order[idx] = order[idx]
    for p in range(bounds.shape[0]):
        sub_bounds[p] = bounds[p]
    for sweep in range(sweeps):
        if sweep >= iterations:
            for g in range(G):
                group_change[g] = 0.0
                group_largest[g] = 0.0
            for j in range(before.shape[0]):
                g = joint_group[j]
                if g < 0:
                    continue
                for c in range(L):
                    group_change[g] = max(group_change[g], abs(axial_impulse[j, limits[c]] - before[j, c]))
                    group_largest[g] = max(group_largest[g], abs(before[j, c]))
            settled = True
            newly = False
            for g in range(G):
                if not group_done[g]:
                    if group_change[g] <= tolerance * max(group_largest[g], 1e-9):
                        group_done[g] = True
                        newly = True
                    else:
                        settled = False
            if settled:
                break
            if newly:  # the groups settled so far leave the sweeps (the order of the others kept)
                for k in range(n_nodes):
                    j = node_joint[k]
                    g = joint_group[j] if j >= 0 else body_group[node_body[k]]
                    node_skip[k] = g >= 0 and group_done[g]
                count = 0
                for p in range(bounds.shape[0] - 1):
                    for idx in range(bounds[p], bounds[p + 1]):
                        j = order[idx]
                        g = joint_group[j]
                        if g < 0 or not group_done[g]:
                            sub_order[count] = j
                            count += 1
                    sub_bounds[p + 1] = count
        if L > 0 and sweep >= iterations - 1:
            for j in range(before.shape[0]):
                for c in range(L):
                    before[j, c] = axial_impulse[j, limits[c]]
        if sweep == 0 and factor:
            # PERF: the factors depend on the poses, masses and inertias, fixed over the sweeps: once
            # per solve (it was once per sweep: the same numbers, so the same bits)
            tree_factor_kernel(node_order, 0, n_nodes, node_joint, node_body, node_parent, joint_type, joint_a,
                               joint_b, local_a, local_b, frame_a, frame_b, param, position, x, R, inv_mass, I_inv, Ja,
                               Jb, C, nrow, D, Dinv, H_up, W, work)
            tree_gear_masses(node_order, node_joint, node_body, node_parent, joint_type, joint_a, joint_b, local_a,
                             local_b, frame_a, frame_b, param, enabled, position, x, R, inv_mass, I_inv, Ja, Jb, nrow,
                             Dinv, H_up, W, y, sol, work, node_skip)
            valid = limit_rows[4]
            for j in range(valid.shape[0]):
                valid[j] = False  # the limits' responses were the last factors' (tree_limits_kernel)
            # the velocities made consistent with the tree before the first Gauss-Seidel rows read
            # them: after the forces of a substep they are each body's own, and a light body between
            # two joints of one MuJoCo body (a virtual link, 1e-3 of the body) spins at hundreds of
            # rad/s under a motor's torque until the tree solve shares it out. A limit row that read
            # that rate judged its joint about to strike a limit 0.6 rad away, pushed, and the sweeps
            # (GS limit rows around the exact solve converge slowly) left part of that push: with
            # armature carrying it from substep to substep, Gymnasium's humanoid under random
            # controls blew up (its hip at 1e3, 1e5, 1e7 rad/s over three substeps; measured)
            # (the biased solve's, ``factor`` 2: after the relax's position step the contacts have
            # changed the velocities instead, and projecting those first let the ant of
            # tests/physics/test_mjcf.py gain 0.063 J in a step against 0.033 J; and only with
            # armature, whose flywheel carried the leftover: without, the limit's push is undone by
            # the sweeps and the step is as it was (a gripper squeezing a box by a gear held it
            # at 0.1-1.4 mm/s before, 0.1-2.1 mm/s with the projection: measured, left))
            if factor == 2:
                tree_substitute_kernel(node_order, 0, n_nodes, node_joint, node_body, node_parent, joint_type,
                                       joint_a, joint_b, local_a, local_b, param, rate0, x, R, inv_mass, I_inv,
                                       soft[0], Ja, Jb, C, nrow, Dinv, H_up, W, y, sol, work, node_skip, v, omega,
                                       linear_impulse, angular_impulse, axial_impulse)
        # COMPILE: one sweep as an int64, not the literal 1: the literal compiled the joint sweeps a
        # second time beside the Gauss-Seidel solve's (their compile 27.8 -> 13.9 s in robot_arm's
        # first run; docs/benchmarks.md "compile time")
        solve_joints_serial_kernel(sub_order, sub_bounds, joint_type, joint_a, joint_b, local_a, local_b, frame_a,
                                   frame_b, param, enabled, gauss_seidel, position, rate0, x, R, inv_mass, I_inv, h,
                                   soft, np.int64(1), v, omega, linear_impulse, angular_impulse, axial_impulse)
        for g in range(joint_type.shape[0]):
            # each gear on velocities the tree solve has just made consistent, with its mass through the
            # tree: block Gauss-Seidel on the gears' Schur complement, which converges. Solved beside the
            # other rows (on velocities another gear had left inconsistent), a lock and a gear on one
            # hinge drifted apart: the lock 0.97 rad and the gear 1.4 rad off in 0.25 s, and blew up
            # beside contacts (measured; tests/physics/test_joints_gear.py)
            if joint_type[g] == JOINT_GEAR and gear_on(g, param, enabled):
                tree_substitute_kernel(node_order, 0, n_nodes, node_joint, node_body, node_parent, joint_type,
                                       joint_a, joint_b, local_a, local_b, param, rate0, x, R, inv_mass, I_inv,
                                       soft[0], Ja, Jb, C, nrow, Dinv, H_up, W, y, sol, work, node_skip, v, omega,
                                       linear_impulse, angular_impulse, axial_impulse)
                solve_gear(g, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position, x, R,
                           inv_mass, I_inv, soft, v, omega, axial_impulse)
        tree_substitute_kernel(node_order, 0, n_nodes, node_joint, node_body, node_parent, joint_type, joint_a,
                               joint_b, local_a, local_b, param, rate0, x, R, inv_mass, I_inv, soft[0], Ja, Jb, C,
                               nrow, Dinv, H_up, W, y, sol, work, node_skip, v, omega, linear_impulse,
                               angular_impulse, axial_impulse)
        if L > 0:
            tree_limits_kernel(groups[9], joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param,
                               enabled, gauss_seidel, position, x, R, inv_mass, I_inv, h, soft, node_order,
                               node_joint, node_body, node_parent, Ja, Jb, nrow, Dinv, H_up, W, y, sol, work,
                               joint_group, group_done, layout, limit_rows, v, omega, linear_impulse, angular_impulse,
                               axial_impulse)


# ---------------------------------------------------------------------- the groups side by side
# The joints of a world with several robots (a vector environment's copies, tumble.envs) fall into
# groups that share no moving body (JointSolver._groups). The tree sweeps of one group touch its own
# bodies, joints and tree nodes only, so the groups can be swept side by side on the threads, each
# as tree_sweeps_kernel sweeps it within the world (its rows in the same order, its own settling
# test): the same bits on any number of threads.
@njit(**NO_NRT)
def _groups_apart(joint_a, joint_b, enabled, joint_group, body_group, inv_mass, I_inv):
    """Whether every enabled joint is in a group and its other end, if outside the group, cannot move
    (no inverse mass or inertia: the world, a fixed or kinematic body; not a sleeping body, which
    the rows of two groups could both push)."""
    for j in range(joint_a.shape[0]):
        if not enabled[j]:
            continue
        g = joint_group[j]
        if g < 0:
            return False
        for side in range(2):
            i = joint_a[j] if side == 0 else joint_b[j]
            if i >= 0 and body_group[i] != g and movable(i, inv_mass, I_inv):
                return False
    return True


@njit(**NO_NRT)
def movable(i, inv_mass, I_inv):
    """Whether a row's impulse can move body i (an inverse mass or inertia; the world, fixed and
    kinematic bodies have neither)."""
    if inv_mass[i] != 0.0:
        return True
    for r in range(3):
        for c in range(3):
            if I_inv[i, r, c] != 0.0:
                return True
    return False


@njit(**NO_NRT)
def bucket_by_group(items, item_group, start, out, cursor):
    """A stable counting sort: the ``items`` (A,) (int64 indices) whose group ``item_group[item]`` is
    >= 0 into ``out``, group 0's first, each group's in the items' order, cut by ``start`` (G + 1,);
    ``cursor`` (G,) ends with each group's count. (The joints' sweep order here, the tree contacts'
    order in ``contact_tree.group_contacts_kernel``.)"""
    G = cursor.shape[0]
    for g in range(G + 1):
        start[g] = 0
    for idx in range(items.shape[0]):
        g = item_group[items[idx]]
        if g >= 0:
            start[g + 1] += 1
    for g in range(G):
        start[g + 1] += start[g]
        cursor[g] = 0
    for idx in range(items.shape[0]):
        g = item_group[items[idx]]
        if g >= 0:
            out[start[g] + cursor[g]] = items[idx]
            cursor[g] += 1


@njit(**NO_NRT)
def _group_orders(order, bounds, joint_group, groups):
    """Each group's Gauss-Seidel order: the joints of ``order`` cut by ``bounds`` (the world's sweep,
    partitions one after another: order[bounds[0]:bounds[-1]]) that are in the group, in the same
    order, into ``groups``' (order_start (G + 1,), order (J,)), and (0, count) into its sweep bounds
    (G, 2)."""
    (_mode, _joint_start, _joints, _tree_start, _trees, order_start, group_order, group_bounds, _work,
     _all_joints) = groups
    for g in range(group_bounds.shape[0]):
        group_bounds[g, 0] = 0
    bucket_by_group(order[bounds[0]:bounds[bounds.shape[0] - 1]], joint_group, order_start, group_order,
                    group_bounds[:, 1])


@njit(**JIT, parallel=True)
def _tree_sweeps_groups(iterations, sweeps, limits, tolerance, joint_type, joint_a, joint_b, local_a, local_b,
                        frame_a, frame_b, param, enabled, gauss_seidel, position, rate0, x, R, inv_mass, I_inv, h,
                        soft, node_order, node_joint, node_body, node_parent, factor, Ja, Jb, C, nrow, D, Dinv, H_up,
                        W, y, sol, before, joint_group, group_done, layout, limit_rows, groups,
                        # outputs
                        v, omega, linear_impulse, angular_impulse, axial_impulse):
    """``tree_sweeps_kernel``'s solve, the groups side by side (``_sweep_group`` each)."""
    G = groups[7].shape[0]
    for g in prange(G):
        _sweep_group(g, iterations, sweeps, limits, tolerance, joint_type, joint_a, joint_b, local_a, local_b,
                     frame_a, frame_b, param, enabled, gauss_seidel, position, rate0, x, R, inv_mass, I_inv, h, soft,
                     node_order, node_joint, node_body, node_parent, factor, Ja, Jb, C, nrow, D, Dinv, H_up, W, y,
                     sol, before, joint_group, group_done, layout, limit_rows, groups, v, omega, linear_impulse,
                     angular_impulse, axial_impulse)


@njit(**NO_NRT)
def _sweep_group(g, iterations, sweeps, limits, tolerance, joint_type, joint_a, joint_b, local_a, local_b, frame_a,
                 frame_b, param, enabled, gauss_seidel, position, rate0, x, R, inv_mass, I_inv, h, soft, node_order,
                 node_joint, node_body, node_parent, factor, Ja, Jb, C, nrow, D, Dinv, H_up, W, y, sol, before,
                 joint_group, group_done, layout, limit_rows, groups,
                 # outputs
                 v, omega, linear_impulse, angular_impulse, axial_impulse):
    """Group g's part of ``tree_sweeps_kernel``'s solve, alone: its steps in its order (its
    Gauss-Seidel rows, its trees' factors and substitutions, its limits in joint order), sweeping
    until its own limit impulses settle (the world's loop leaves a settled group out the same way)."""
    (_mode, joint_start, group_joints, tree_start, group_trees, order_start, group_order, group_bounds,
     group_work, _all_joints) = groups
    _body_node, _node_tree, tree_lo, tree_hi, no_skip = layout
    valid = limit_rows[4]
    work = group_work[g]
    n_nodes = node_order.shape[0]
    L = limits.shape[0]
    j0, j1 = joint_start[g], joint_start[g + 1]
    t0, t1 = tree_start[g], tree_start[g + 1]
    own_order = group_order[order_start[g]:order_start[g + 1]]
    own_bounds = group_bounds[g]
    for sweep in range(sweeps):
        if sweep >= iterations:
            change = 0.0
            largest = 0.0
            for idx in range(j0, j1):
                j = group_joints[idx]
                for c in range(L):
                    change = max(change, abs(axial_impulse[j, limits[c]] - before[j, c]))
                    largest = max(largest, abs(before[j, c]))
            if change <= tolerance * max(largest, 1e-9):
                break
        if L > 0 and sweep >= iterations - 1:
            for idx in range(j0, j1):
                j = group_joints[idx]
                for c in range(L):
                    before[j, c] = axial_impulse[j, limits[c]]
        if sweep == 0 and factor:
            for q in range(t0, t1):
                t = group_trees[q]
                lo, hi = tree_lo[t], tree_hi[t]
                tree_factor_kernel(node_order[n_nodes - hi:n_nodes - lo], lo, hi, node_joint, node_body, node_parent,
                                   joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position,
                                   x, R, inv_mass, I_inv, Ja, Jb, C, nrow, D, Dinv, H_up, W, work)
            for idx in range(j0, j1):
                valid[group_joints[idx]] = False  # its first coordinate's row, and its second's
                valid[joint_type.shape[0] + group_joints[idx]] = False
            if factor == 2:
                for q in range(t0, t1):
                    t = group_trees[q]
                    lo, hi = tree_lo[t], tree_hi[t]
                    tree_substitute_kernel(node_order[n_nodes - hi:n_nodes - lo], lo, hi, node_joint, node_body,
                                           node_parent, joint_type, joint_a, joint_b, local_a, local_b, param, rate0,
                                           x, R, inv_mass, I_inv, soft[0], Ja, Jb, C, nrow, Dinv, H_up, W, y, sol,
                                           work, no_skip, v, omega, linear_impulse, angular_impulse, axial_impulse)
        solve_joints_serial_kernel(own_order, own_bounds, joint_type, joint_a, joint_b, local_a, local_b, frame_a,
                                   frame_b, param, enabled, gauss_seidel, position, rate0, x, R, inv_mass, I_inv, h,
                                   soft, np.int64(1), v, omega, linear_impulse, angular_impulse, axial_impulse)
        for q in range(t0, t1):
            t = group_trees[q]
            lo, hi = tree_lo[t], tree_hi[t]
            tree_substitute_kernel(node_order[n_nodes - hi:n_nodes - lo], lo, hi, node_joint, node_body, node_parent,
                                   joint_type, joint_a, joint_b, local_a, local_b, param, rate0, x, R, inv_mass,
                                   I_inv, soft[0], Ja, Jb, C, nrow, Dinv, H_up, W, y, sol, work, no_skip, v, omega,
                                   linear_impulse, angular_impulse, axial_impulse)
        if L > 0:  # (group_done is all False here: a group leaves its own loop when it settles)
            tree_limits_kernel(group_joints[j0:j1], joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b,
                               param, enabled, gauss_seidel, position, x, R, inv_mass, I_inv, h, soft, node_order,
                               node_joint, node_body, node_parent, Ja, Jb, nrow, Dinv, H_up, W, y, sol, work,
                               joint_group, group_done, layout, limit_rows, v, omega, linear_impulse, angular_impulse,
                               axial_impulse)
