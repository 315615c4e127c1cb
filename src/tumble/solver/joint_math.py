"""Joint rows' arithmetic: 3-vectors as tuples, a body's anchor and frame axes in the world,
point velocities and impulses on the two bodies of a joint, rows' effective masses and the
small exact block solves (2x2, 3x3) the joint solver is built from (``solver.joints``).
Arrays: x (N, 3) m, R (N, 3, 3) body to world, v, omega (N, 3), inv_mass (N,), I_inv (N, 3, 3)
world; a body index of -1 is the world (no velocity, infinite mass)."""

from __future__ import annotations

import math

from numba import njit

from ..joints import JOINT_BALL, JOINT_DISTANCE, JOINT_HINGE, JOINT_SLIDER, JOINT_UNIVERSAL
from ..math3d import (
    NO_NRT,
)


# ---------------------------------------------------------------------- vector helpers (tuples)
@njit(**NO_NRT)
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(**NO_NRT)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(**NO_NRT)
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(**NO_NRT)
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(**NO_NRT)
def _scale(s, a):
    return (s * a[0], s * a[1], s * a[2])


@njit(**NO_NRT)
def _mat_vec(M, i, a):
    """M[i] @ a, or 0 for the world (i < 0)."""
    if i < 0:
        return (0.0, 0.0, 0.0)
    return (M[i, 0, 0] * a[0] + M[i, 0, 1] * a[1] + M[i, 0, 2] * a[2],
            M[i, 1, 0] * a[0] + M[i, 1, 1] * a[1] + M[i, 1, 2] * a[2],
            M[i, 2, 0] * a[0] + M[i, 2, 1] * a[1] + M[i, 2, 2] * a[2])


@njit(**NO_NRT)
def _anchor(x, R, i, local, j):
    """(arm, point): arm R_i l from the centre of mass and the world point, of local[j]."""
    lj = (local[j, 0], local[j, 1], local[j, 2])
    if i < 0:
        return (0.0, 0.0, 0.0), lj
    r = _mat_vec(R, i, lj)
    return r, (r[0] + x[i, 0], r[1] + x[i, 1], r[2] + x[i, 2])


@njit(**NO_NRT)
def _axis(R, i, frame, j, col):
    """World direction of column ``col`` of the joint frame ``frame[j]`` of body i."""
    f = (frame[j, 0, col], frame[j, 1, col], frame[j, 2, col])
    if i < 0:
        return f
    return _mat_vec(R, i, f)


@njit(**NO_NRT)
def _frames(R, a, b, frame_a, frame_b, j):
    """The world axes (x, y, z) of joint j's frame on body a, then on body b: six unit 3-vectors
    (columns of R frame; the world's own frame where a body is -1)."""
    return (_axis(R, a, frame_a, j, 0), _axis(R, a, frame_a, j, 1), _axis(R, a, frame_a, j, 2),
            _axis(R, b, frame_b, j, 0), _axis(R, b, frame_b, j, 1), _axis(R, b, frame_b, j, 2))


@njit(**NO_NRT)
def _inv_m(inv_mass, i):
    return inv_mass[i] if i >= 0 else 0.0


@njit(**NO_NRT)
def _point_velocity(v, omega, i, r):
    if i < 0:
        return (0.0, 0.0, 0.0)
    w = (omega[i, 0], omega[i, 1], omega[i, 2])
    c = _cross(w, r)
    return (v[i, 0] + c[0], v[i, 1] + c[1], v[i, 2] + c[2])


@njit(**NO_NRT)
def _angular_velocity(omega, i):
    if i < 0:
        return (0.0, 0.0, 0.0)
    return (omega[i, 0], omega[i, 1], omega[i, 2])


@njit(**NO_NRT)
def _apply_linear(v, omega, inv_mass, I_inv, a, b, ra, rb, p):
    """Impulse p (world) on b at arm rb and -p on a at arm ra."""
    if a >= 0:
        ma = inv_mass[a]
        w = _mat_vec(I_inv, a, _cross(ra, p))
        for k in range(3):
            v[a, k] -= ma * p[k]
            omega[a, k] -= w[k]
    if b >= 0:
        mb = inv_mass[b]
        w = _mat_vec(I_inv, b, _cross(rb, p))
        for k in range(3):
            v[b, k] += mb * p[k]
            omega[b, k] += w[k]


@njit(**NO_NRT)
def _apply_angular(omega, I_inv, a, b, t):
    """Angular impulse t (world) on b and -t on a."""
    if a >= 0:
        w = _mat_vec(I_inv, a, t)
        for k in range(3):
            omega[a, k] -= w[k]
    if b >= 0:
        w = _mat_vec(I_inv, b, t)
        for k in range(3):
            omega[b, k] += w[k]


@njit(**NO_NRT)
def _row_mass(inv_mass, I_inv, a, b, linear, n, ra, rb):
    """J M^-1 J^T of a row: linear along n at arms ra, rb, or angular about n."""
    if linear:
        ca = _cross(ra, n)
        cb = _cross(rb, n)
        return (_inv_m(inv_mass, a) + _inv_m(inv_mass, b)
                + _dot(ca, _mat_vec(I_inv, a, ca)) + _dot(cb, _mat_vec(I_inv, b, cb)))
    return _dot(n, _mat_vec(I_inv, a, n)) + _dot(n, _mat_vec(I_inv, b, n))


@njit(**NO_NRT)
def _slider_rows(inv_mass, I_inv, R, a, b, frame_a, j, ra, rb):
    """A slider's two linear rows, across its axis: the unit axes p1, p2 (3,) (world frame;
    columns 0 and 1 of joint j's frame on body a) and the rows' 2x2 K = J M^-1 J^T as k11, k12,
    k22 (1/kg), at arms ra (a's centre to b's anchor) and rb (m, world frame). Shared by the
    velocity solve and the position projection."""
    p1 = _axis(R, a, frame_a, j, 0)
    p2 = _axis(R, a, frame_a, j, 1)
    k11 = _row_mass(inv_mass, I_inv, a, b, True, p1, ra, rb)
    k22 = _row_mass(inv_mass, I_inv, a, b, True, p2, ra, rb)
    k12 = (_dot(_cross(ra, p1), _mat_vec(I_inv, a, _cross(ra, p2)))
           + _dot(_cross(rb, p1), _mat_vec(I_inv, b, _cross(rb, p2))))
    return p1, p2, k11, k12, k22


@njit(**NO_NRT)
def _row_velocity(v, omega, a, b, linear, n, ra, rb):
    if linear:
        return _dot(n, _sub(_point_velocity(v, omega, b, rb), _point_velocity(v, omega, a, ra)))
    return _dot(n, _sub(_angular_velocity(omega, b), _angular_velocity(omega, a)))


@njit(**NO_NRT)
def _row_apply(v, omega, inv_mass, I_inv, a, b, linear, n, ra, rb, impulse):
    if linear:
        _apply_linear(v, omega, inv_mass, I_inv, a, b, ra, rb, _scale(impulse, n))
    else:
        _apply_angular(omega, I_inv, a, b, _scale(impulse, n))


@njit(**NO_NRT)
def _solve3(K, r):
    """K^-1 r for a symmetric 3x3 K given as 6 numbers (k00, k01, k02, k11, k12, k22); 0 if singular."""
    k00, k01, k02, k11, k12, k22 = K
    c00 = k11 * k22 - k12 * k12
    c01 = k02 * k12 - k01 * k22
    c02 = k01 * k12 - k02 * k11
    det = k00 * c00 + k01 * c01 + k02 * c02
    if det == 0.0:
        return (0.0, 0.0, 0.0)
    c11 = k00 * k22 - k02 * k02
    c12 = k01 * k02 - k00 * k12
    c22 = k00 * k11 - k01 * k01
    inv = 1.0 / det
    return ((c00 * r[0] + c01 * r[1] + c02 * r[2]) * inv,
            (c01 * r[0] + c11 * r[1] + c12 * r[2]) * inv,
            (c02 * r[0] + c12 * r[1] + c22 * r[2]) * inv)


@njit(**NO_NRT)
def _point_K(inv_mass, I_inv, a, b, ra, rb):
    """K = (ma + mb) 1 + S_a Ia S_a^T + S_b Ib S_b^T, S = [r]x, as (k00, k01, k02, k11, k12, k22)."""
    m = _inv_m(inv_mass, a) + _inv_m(inv_mass, b)
    k00, k01, k02, k11, k12, k22 = m, 0.0, 0.0, m, 0.0, m
    for side in range(2):
        i = a if side == 0 else b
        if i < 0:
            continue
        r = ra if side == 0 else rb
        # rows of [r]x
        s0 = (0.0, -r[2], r[1])
        s1 = (r[2], 0.0, -r[0])
        s2 = (-r[1], r[0], 0.0)
        t0 = _mat_vec(I_inv, i, s0)
        t1 = _mat_vec(I_inv, i, s1)
        t2 = _mat_vec(I_inv, i, s2)
        k00 += _dot(s0, t0)
        k01 += _dot(s0, t1)
        k02 += _dot(s0, t2)
        k11 += _dot(s1, t1)
        k12 += _dot(s1, t2)
        k22 += _dot(s2, t2)
    return (k00, k01, k02, k11, k12, k22)


@njit(**NO_NRT)
def _angular_K(I_inv, a, b):
    k00 = k01 = k02 = k11 = k12 = k22 = 0.0
    for side in range(2):
        i = a if side == 0 else b
        if i >= 0:
            k00 += I_inv[i, 0, 0]
            k01 += I_inv[i, 0, 1]
            k02 += I_inv[i, 0, 2]
            k11 += I_inv[i, 1, 1]
            k12 += I_inv[i, 1, 2]
            k22 += I_inv[i, 2, 2]
    return (k00, k01, k02, k11, k12, k22)


@njit(**NO_NRT)
def _solve2(k00, k01, k11, r0, r1):
    det = k00 * k11 - k01 * k01
    if det == 0.0:
        return 0.0, 0.0
    inv = 1.0 / det
    return (k11 * r0 - k01 * r1) * inv, (k00 * r1 - k01 * r0) * inv


@njit(**NO_NRT)
def _wrap(angle):
    return angle - 2.0 * math.pi * math.floor((angle + math.pi) / (2.0 * math.pi))


@njit(**NO_NRT)
def _coordinate_row(t, j, a, b, x, R, local_a, local_b, frame_a, frame_b, last_position):
    """The joint's 1-D coordinate: (has_row, linear, n, arm_a, arm_b, position).

    hinge: angle of b about the axis (rad), unwrapped around ``last_position``;
    slider: displacement along the axis (m), arm of a is ra + d (Box2D prismatic);
    distance: length (m) along the unit line a -> b; ball: swing angle between the cone
    axes (rad), about their common normal; universal: the angle about ``axis`` (rad, in
    (-pi, pi], ``tumble.joints.UniversalJoint``), rate about a's axis.
    """
    ra, pa = _anchor(x, R, a, local_a, j)
    rb, pb = _anchor(x, R, b, local_b, j)
    d = _sub(pb, pa)
    za = _axis(R, a, frame_a, j, 2)
    if t == JOINT_HINGE:
        xa = _axis(R, a, frame_a, j, 0)
        ya = _axis(R, a, frame_a, j, 1)
        xb = _axis(R, b, frame_b, j, 0)
        yb = _axis(R, b, frame_b, j, 1)
        angle = math.atan2(_dot(ya, xb) - _dot(xa, yb), _dot(xa, xb) + _dot(ya, yb))
        # the nearest turn of the angle to the last reading, as the angle plus whole turns: the
        # principal angle itself where no turn is crossed, whatever the reading (base + wrap(angle -
        # base) rounded by the reading: an episode after a reset, whose readings are its start's
        # qpos, parted from a fresh world's (readings 0) at 1e-15 rad/s in the first step)
        base = last_position[j]
        return True, False, za, ra, rb, angle - 2.0 * math.pi * math.floor((angle - base + math.pi) / (2.0 * math.pi))
    if t == JOINT_SLIDER:
        return True, True, za, _add(ra, d), rb, _dot(d, za)
    if t == JOINT_DISTANCE:
        length = math.sqrt(_dot(d, d))
        if length < 1e-12:
            return False, True, za, ra, rb, 0.0
        return True, True, _scale(1.0 / length, d), ra, rb, length
    if t == JOINT_BALL:
        zb = _axis(R, b, frame_b, j, 2)
        s = _cross(za, zb)
        sn = math.sqrt(_dot(s, s))
        if sn < 1e-12:
            return False, False, za, ra, rb, 0.0 if _dot(za, zb) > 0 else math.pi
        return True, False, _scale(1.0 / sn, s), ra, rb, math.atan2(sn, _dot(za, zb))
    if t == JOINT_UNIVERSAL:
        # Q = Fa^T Fb = Rx(angle) Ry(angle_b): b's y axis in a's joint frame is (0, cos, sin)
        xa = _axis(R, a, frame_a, j, 0)
        ya = _axis(R, a, frame_a, j, 1)
        yb = _axis(R, b, frame_b, j, 1)
        return True, False, xa, ra, rb, math.atan2(_dot(za, yb), _dot(ya, yb))
    return False, False, za, ra, rb, 0.0
