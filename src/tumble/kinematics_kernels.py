"""The compiled kernels of ``tumble.kinematics``: a robot's links as arrays in tree order (every
link after its parent), the joint coordinates MuJoCo's qpos/qvel.

Link arrays (L links, root first): ``parent`` (L,) int (-1: the root), ``kind`` (L,) int
(``FIXED``, ``HINGE``, ``SLIDE``, ``BALL``, ``FREE``: the joint that moves the link from its
parent), ``origin_p`` (L, 3) m and ``origin_R`` (L, 3, 3): the joint's zero frame in the parent's
link frame, ``axis`` (L, 3) unit in the link frame, ``qadr``/``vadr`` (L,) int: where the
joint's positions and rates start in qpos and qvel (-1: none). Frames ``o`` (L, 3) m and ``R``
(L, 3, 3), world. ``ancestor`` (L, L) bool: ancestor[l, a] when link a's joint moves link l (a
is l or above it, up to the first free joint). Rate columns (nv): ``dof_link`` the link whose
joint the rate belongs to; ``col_rot`` a rotation (True) or a translation; ``col_o`` (nv, 3) m a
point on its line; ``col_d`` (nv, 3) its direction, world. Bodies (B, the moving ones):
``body_link`` (B,) the link whose frame they follow, ``mass`` (B,) kg, ``com`` (B, 3) m and
``I_world`` (B, 3, 3) kg m^2, world.

Written with explicit 3-vector arithmetic (no small np.dot calls: each would be a BLAS call).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .math3d import JIT, matrix_to_quat_into, quat_to_matrix_into

FIXED, HINGE, SLIDE, BALL, FREE = 0, 1, 2, 3, 4


@njit(**JIT)
def _mat_vec(R, v):
    return (R[0, 0] * v[0] + R[0, 1] * v[1] + R[0, 2] * v[2],
            R[1, 0] * v[0] + R[1, 1] * v[1] + R[1, 2] * v[2],
            R[2, 0] * v[0] + R[2, 1] * v[1] + R[2, 2] * v[2])


@njit(**JIT)
def _mat_mat_into(A, B, out):
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@njit(**JIT)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(**JIT)
def _unit_quat_matrix(q, start, out):
    """``out`` (3, 3): the rotation of the quaternion q[start:start + 4], normalised first."""
    n = math.sqrt(q[start] ** 2 + q[start + 1] ** 2 + q[start + 2] ** 2 + q[start + 3] ** 2)
    u = np.empty(4)
    for k in range(4):
        u[k] = q[start + k] / n
    quat_to_matrix_into(u, out)


@njit(**JIT)
def forward_kinematics_kernel(qpos, root_o, root_R, parent, kind, origin_p, origin_R, axis, qadr,
                              # outputs
                              o, R):
    """Every link's frame (o, R) at qpos; a root without a free joint at (root_o, root_R)."""
    turn = np.empty((3, 3))
    zR = np.empty((3, 3))
    for link in range(parent.shape[0]):
        k = kind[link]
        a = qadr[link]
        if k == FREE:  # MuJoCo's free joint: the frame's world position, then its quaternion
            for i in range(3):
                o[link, i] = qpos[a + i]
            _unit_quat_matrix(qpos, a + 3, R[link])
            continue
        P = parent[link]
        if P < 0:
            o[link] = root_o
            R[link] = root_R
            continue
        d = _mat_vec(R[P], origin_p[link])
        _mat_mat_into(R[P], origin_R[link], zR)
        for i in range(3):
            o[link, i] = o[P, i] + d[i]
        if k == HINGE:  # a turn by q about the axis (link frame)
            half = 0.5 * qpos[a]
            s = math.sin(half)
            u = np.array([math.cos(half), s * axis[link, 0], s * axis[link, 1], s * axis[link, 2]])
            quat_to_matrix_into(u, turn)
            _mat_mat_into(zR, turn, R[link])
        elif k == BALL:
            _unit_quat_matrix(qpos, a, turn)
            _mat_mat_into(zR, turn, R[link])
        else:
            R[link] = zR
            if k == SLIDE:
                d = _mat_vec(zR, axis[link])
                for i in range(3):
                    o[link, i] += qpos[a] * d[i]


@njit(**JIT)
def columns_kernel(o, R, kind, axis, vadr,
                   # outputs
                   col_rot, col_o, col_d):
    """Each rate's line: free joints three translations along the world axes then three turns
    about the link frame's axes (MuJoCo's), balls three turns about the link frame's axes, a
    hinge a turn and a slider a translation along R axis."""
    for link in range(kind.shape[0]):
        k = kind[link]
        s = vadr[link]
        if k == FIXED:
            continue
        if k == FREE:
            for j in range(3):
                col_rot[s + j] = False
                col_rot[s + 3 + j] = True
                for i in range(3):
                    col_o[s + j, i] = o[link, i]
                    col_o[s + 3 + j, i] = o[link, i]
                    col_d[s + j, i] = 1.0 if i == j else 0.0
                    col_d[s + 3 + j, i] = R[link, i, j]
        elif k == BALL:
            for j in range(3):
                col_rot[s + j] = True
                for i in range(3):
                    col_o[s + j, i] = o[link, i]
                    col_d[s + j, i] = R[link, i, j]
        else:
            col_rot[s] = k == HINGE
            d = _mat_vec(R[link], axis[link])
            for i in range(3):
                col_o[s, i] = o[link, i]
                col_d[s, i] = d[i]


@njit(**JIT)
def jacobian_kernel(link, p, ancestor, dof_link, col_rot, col_o, col_d,
                    # outputs
                    J):
    """J (6, nv): the velocity of the world point p (3,) moving with ``link`` (rows 0-2) and the
    link's angular velocity (rows 3-5) per rate: d x (p - o) and d for a turn, d and 0 for a
    translation."""
    for k in range(J.shape[1]):
        for i in range(6):
            J[i, k] = 0.0
        if not ancestor[link, dof_link[k]]:
            continue
        d = col_d[k]
        if col_rot[k]:
            c = _cross(d[0], d[1], d[2], p[0] - col_o[k, 0], p[1] - col_o[k, 1], p[2] - col_o[k, 2])
            for i in range(3):
                J[i, k] = c[i]
                J[3 + i, k] = d[i]
        else:
            for i in range(3):
                J[i, k] = d[i]


@njit(**JIT)
def _body_rotation_into(R_link, Rl, out):
    """out (3, 3) = R_link Rl^T: a body's rotation from its link's R_link (3, 3) and the link's
    rotation Rl (3, 3) in the body (sums in index order)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = R_link[i, 0] * Rl[j, 0] + R_link[i, 1] * Rl[j, 1] + R_link[i, 2] * Rl[j, 2]


@njit(**JIT)
def body_frames_kernel(o, R, body_link, body_p, body_Rl, com_offset, inertia_body,
                       # outputs
                       com, I_world):
    """Each body's centre of mass and world inertia from its link's frame: the body frame is
    R_link Rl^T, its origin o_link - R_body p (``Robot.link_frames``: the link in the body)."""
    Rb = np.empty((3, 3))
    tmp = np.empty((3, 3))
    for b in range(body_link.shape[0]):
        link = body_link[b]
        _body_rotation_into(R[link], body_Rl[b], Rb)
        p = _mat_vec(Rb, body_p[b])
        c = _mat_vec(Rb, com_offset[b])
        for i in range(3):
            com[b, i] = o[link, i] - p[i] + c[i]
        _mat_mat_into(Rb, inertia_body[b], tmp)
        for i in range(3):
            for j in range(3):
                I_world[b, i, j] = tmp[i, 0] * Rb[j, 0] + tmp[i, 1] * Rb[j, 1] + tmp[i, 2] * Rb[j, 2]


@njit(**JIT)
def mass_matrix_kernel(body_link, mass, com, I_world, ancestor, dof_link, col_rot, col_o, col_d, armature,
                       # outputs
                       M):
    """M (nv, nv) = sum over the bodies of m Jv^T Jv + Jw^T I Jw at their centres of mass, plus
    the armature on the diagonal."""
    nv = M.shape[0]
    for a in range(nv):
        for b in range(nv):
            M[a, b] = 0.0
        M[a, a] = armature[a]
    J = np.empty((6, nv))
    IJ = np.empty((3, nv))
    for b in range(body_link.shape[0]):
        jacobian_kernel(body_link[b], com[b], ancestor, dof_link, col_rot, col_o, col_d, J)
        for k in range(nv):
            for i in range(3):
                IJ[i, k] = I_world[b, i, 0] * J[3, k] + I_world[b, i, 1] * J[4, k] + I_world[b, i, 2] * J[5, k]
        m = mass[b]
        for r in range(nv):
            if not ancestor[body_link[b], dof_link[r]]:
                continue
            for c in range(r, nv):
                if not ancestor[body_link[b], dof_link[c]]:
                    continue
                v = m * (J[0, r] * J[0, c] + J[1, r] * J[1, c] + J[2, r] * J[2, c]) \
                    + J[3, r] * IJ[0, c] + J[4, r] * IJ[1, c] + J[5, r] * IJ[2, c]
                M[r, c] += v
                if c != r:
                    M[c, r] += v


@njit(**JIT)
def link_motion_kernel(qvel, qacc, o, R, parent, kind, axis, vadr,
                       # outputs
                       w, al, v, a):
    """The forward pass of the recursive Newton-Euler algorithm: out from the base, each link's
    angular velocity w and acceleration al (L, 3), its origin's velocity v and acceleration a
    (L, 3), world, from its parent's through the joint at rates qvel and accelerations qacc."""
    L = parent.shape[0]
    for link in range(L):
        for i in range(3):
            w[link, i] = al[link, i] = v[link, i] = a[link, i] = 0.0
    for link in range(L):
        k = kind[link]
        s = vadr[link]
        P = parent[link]
        if k == FREE:  # rates: the origin's velocity (world), the angular velocity (link frame)
            wl = _mat_vec(R[link], qvel[s + 3:s + 6])
            # d/dt (R w_local) = R dw_local: the term w x (R w_local) is w x w = 0
            al_l = _mat_vec(R[link], qacc[s + 3:s + 6])
            for i in range(3):
                w[link, i] = wl[i]
                al[link, i] = al_l[i]
                v[link, i] = qvel[s + i]
                a[link, i] = qacc[s + i]
            continue
        if P < 0:
            continue  # a fixed root: at rest
        r = (o[link, 0] - o[P, 0], o[link, 1] - o[P, 1], o[link, 2] - o[P, 2])
        wP = (w[P, 0], w[P, 1], w[P, 2])
        aP = (al[P, 0], al[P, 1], al[P, 2])
        # the parent's point at this link's origin
        wr = _cross(wP[0], wP[1], wP[2], r[0], r[1], r[2])
        ar = _cross(aP[0], aP[1], aP[2], r[0], r[1], r[2])
        wwr = _cross(wP[0], wP[1], wP[2], wr[0], wr[1], wr[2])
        for i in range(3):
            v[link, i] = v[P, i] + wr[i]
            a[link, i] = a[P, i] + ar[i] + wwr[i]
            w[link, i] = wP[i]
            al[link, i] = aP[i]
        if k == SLIDE:
            d = _mat_vec(R[link], axis[link])
            c = _cross(wP[0], wP[1], wP[2], d[0], d[1], d[2])
            for i in range(3):
                v[link, i] += d[i] * qvel[s]
                # Coriolis: the axis turns with the parent (w x d qd), and so does the offset (again)
                a[link, i] += d[i] * qacc[s] + 2.0 * c[i] * qvel[s]
        elif k == HINGE or k == BALL:
            if k == HINGE:
                d = _mat_vec(R[link], axis[link])
                rel = (d[0] * qvel[s], d[1] * qvel[s], d[2] * qvel[s])
                rel_acc = (d[0] * qacc[s], d[1] * qacc[s], d[2] * qacc[s])
            else:  # the rates in the link frame (MuJoCo's ball)
                rel = _mat_vec(R[link], qvel[s:s + 3])
                rel_acc = _mat_vec(R[link], qacc[s:s + 3])
            c = _cross(wP[0], wP[1], wP[2], rel[0], rel[1], rel[2])
            for i in range(3):
                w[link, i] += rel[i]
                al[link, i] += rel_acc[i] + c[i]


@njit(**JIT)
def inverse_dynamics_kernel(qvel, qacc, gravity, o, R, parent, kind, axis, vadr, body_link, mass, com, I_world,
                            armature,
                            # outputs
                            tau):
    """tau (nv,) = M(q) qacc + c(q, qvel): the recursive Newton-Euler algorithm (Featherstone 2008,
    ch. 5) with world-frame vectors at the link origins. Out from the base (``link_motion_kernel``):
    each link's angular velocity w and acceleration al, its origin's velocity v and acceleration a.
    Back to the base: each body's force m (a_com - g) and moment about its link's origin
    I al + w x I w + r x f, summed over the subtree and projected on the joint's rate columns."""
    L = parent.shape[0]
    w = np.empty((L, 3))
    al = np.empty((L, 3))
    v = np.empty((L, 3))
    a = np.empty((L, 3))
    link_motion_kernel(qvel, qacc, o, R, parent, kind, axis, vadr, w, al, v, a)
    force = np.zeros((L, 3))
    moment = np.zeros((L, 3))
    for b in range(body_link.shape[0]):
        link = body_link[b]
        m = mass[b]
        r = (com[b, 0] - o[link, 0], com[b, 1] - o[link, 1], com[b, 2] - o[link, 2])
        wl = (w[link, 0], w[link, 1], w[link, 2])
        all_ = (al[link, 0], al[link, 1], al[link, 2])
        ar = _cross(all_[0], all_[1], all_[2], r[0], r[1], r[2])
        wr = _cross(wl[0], wl[1], wl[2], r[0], r[1], r[2])
        wwr = _cross(wl[0], wl[1], wl[2], wr[0], wr[1], wr[2])
        f = (m * (a[link, 0] + ar[0] + wwr[0] - gravity[0]), m * (a[link, 1] + ar[1] + wwr[1] - gravity[1]),
             m * (a[link, 2] + ar[2] + wwr[2] - gravity[2]))
        Ia = _mat_vec(I_world[b], all_)
        Iw = _mat_vec(I_world[b], wl)
        gyro = _cross(wl[0], wl[1], wl[2], Iw[0], Iw[1], Iw[2])
        rf = _cross(r[0], r[1], r[2], f[0], f[1], f[2])
        for i in range(3):
            force[link, i] += f[i]
            moment[link, i] += Ia[i] + gyro[i] + rf[i]
    for link in range(L - 1, -1, -1):
        k = kind[link]
        s = vadr[link]
        F = force[link]
        N = moment[link]
        if k == FREE:  # the force (world), the moment about the origin in the link frame
            for j in range(3):
                tau[s + j] = F[j]
                tau[s + 3 + j] = R[link, 0, j] * N[0] + R[link, 1, j] * N[1] + R[link, 2, j] * N[2]
        elif k == BALL:
            for j in range(3):
                tau[s + j] = R[link, 0, j] * N[0] + R[link, 1, j] * N[1] + R[link, 2, j] * N[2]
        elif k == HINGE or k == SLIDE:
            d = _mat_vec(R[link], axis[link])
            G = N if k == HINGE else F
            tau[s] = d[0] * G[0] + d[1] * G[1] + d[2] * G[2]
        P = parent[link]
        if P >= 0 and k != FREE:  # a free link hands nothing to its parent
            r = (o[link, 0] - o[P, 0], o[link, 1] - o[P, 1], o[link, 2] - o[P, 2])
            rF = _cross(r[0], r[1], r[2], F[0], F[1], F[2])
            for i in range(3):
                force[P, i] += F[i]
                moment[P, i] += N[i] + rF[i]
    for k in range(tau.shape[0]):
        tau[k] += armature[k] * qacc[k]


@njit(**JIT)
def place_bodies_kernel(R, body_link, link_Rl, com, mass, inertia_body, qd, ancestor, dof_link, col_rot, col_o,
                        col_d,
                        # outputs
                        q_out, R_out, P_out, L_out):
    """The moving bodies' state at link frames R (L, 3, 3) and joint rates qd (nv,) (``Kinematics.
    set_state``): each body's rotation R_link Rl^T as a unit quaternion q_out (B, 4) and its
    matrix R_out (B, 3, 3) (from q, as the World keeps them), its momentum P_out = m J_v qd (B, 3)
    kg m/s and angular momentum L_out = R I_body R^T J_w qd (B, 3) kg m^2/s, J (6, nv) at its
    centre of mass com (B, 3) m. The sums in index order: the same bits on every BLAS (NumPy's
    ``@`` on these 3x3 products went through it, so their last bits followed its kernel)."""
    nv = qd.shape[0]
    J = np.empty((6, nv))
    Rb = np.empty((3, 3))
    tmp = np.empty((3, 3))
    Iw = np.empty((3, 3))
    for b in range(body_link.shape[0]):
        link = body_link[b]
        _body_rotation_into(R[link], link_Rl[b], Rb)
        matrix_to_quat_into(Rb, q_out[b])
        quat_to_matrix_into(q_out[b], R_out[b])
        jacobian_kernel(link, com[b], ancestor, dof_link, col_rot, col_o, col_d, J)
        w = np.zeros(3)
        for i in range(3):
            v = 0.0
            for k in range(nv):
                v += J[i, k] * qd[k]
                w[i] += J[3 + i, k] * qd[k]
            P_out[b, i] = mass[b] * v
        _mat_mat_into(R_out[b], inertia_body[b], tmp)
        for i in range(3):
            for j in range(3):
                Iw[i, j] = tmp[i, 0] * R_out[b, j, 0] + tmp[i, 1] * R_out[b, j, 1] + tmp[i, 2] * R_out[b, j, 2]
        for i in range(3):
            L_out[b, i] = Iw[i, 0] * w[0] + Iw[i, 1] * w[1] + Iw[i, 2] * w[2]
