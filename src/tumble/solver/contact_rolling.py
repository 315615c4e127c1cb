"""Rolling resistance and spinning friction: three angular rows beside a contact point.

A rigid ball rolls on for ever: its contact point is at rest, so Coulomb friction does no
work (tests/physics/test_contact_rolling.py holds tumble to that). Real balls stop because
the surfaces deform; engines model it with a torque against the relative turning of the two
bodies, bounded by the normal force, as Coulomb bounds friction:

- rolling, about the two tangent axes t1, t2 of the contact: the 2-vector of angular impulse
  is clamped to the disc of radius ``c r lambda_n`` (c = max of the two materials'
  ``rolling_resistance``, dimensionless, Box2D v3 / Box3D's ``rollingResistance``; r the
  radius of the round surface at the contact, the larger of the two: the length of its
  ``anchor_offset``; 0 for a flat face, which does not roll);
- spinning, about the normal n: clamped to ``+- s lambda_n`` (s = max of the two materials'
  ``spinning_friction``, m, MuJoCo's torsional friction coefficient).

lambda_n is the contact point's accumulated normal impulse of the substep, so the torque
bound is c r N, as the friction bound is mu N. Each row's effective mass is
1 / (d . (Ia^-1 + Ib^-1) d) for its world axis d (exact for a ball, whose I^-1 is isotropic).

In the soft step the rows follow their contacts: applied after the contacts' warm start
(``warm_start_rolling_kernel``) and solved after each contact sweep, biased and relax alike
(``solve_rolling_kernel``; velocity rows with no position error, as Box2D's rolling
resistance). Their accumulated impulses are warm started from step to step through the
contacts' keys, as world vectors (``store_rolling_kernel``). NOTE: why the warm start: each
step from zero, the rows come after the contact sweep, so a substep's gravity kick was first
turned into spin by friction and only then taken back by the row: a ball held on a 30 degree
slope by rolling resistance (c = 0.7, mu = 1) slid 1.2 mm before it fell asleep, 9 um with
the warm start (whose impulses balance the kick from the start of each substep, as a box's
friction does on a slope); a rolling cylinder's deceleration was 5e-10 off c g / (1 + k)
instead of round-off (tests/physics/test_contact_rolling_resistance.py fails without it).

Only contacts with a body whose material has ``resists_rolling`` get rows
(``ContactSolver``); a world without one runs none of this and keeps its bits.
"""

from __future__ import annotations

import math

from numba import njit

from ..math3d import JIT


@njit(**JIT, inline="always")
def _axis_mass(I_inv, a, b, d0, d1, d2):
    """1 / (d . (Ia^-1 + Ib^-1) d): the effective mass of an angular impulse along unit d."""
    k = 0.0
    for i in (a, b):
        k += (d0 * (I_inv[i, 0, 0] * d0 + I_inv[i, 0, 1] * d1 + I_inv[i, 0, 2] * d2)
              + d1 * (I_inv[i, 1, 0] * d0 + I_inv[i, 1, 1] * d1 + I_inv[i, 1, 2] * d2)
              + d2 * (I_inv[i, 2, 0] * d0 + I_inv[i, 2, 1] * d1 + I_inv[i, 2, 2] * d2))
    return 1.0 / k if k > 0.0 else 0.0


@njit(**JIT, inline="always")
def _turn(I_inv, omega, i, sign, p0, p1, p2):
    """omega[i] += sign * I^-1[i] p (an angular impulse p on body i)."""
    for r in range(3):
        omega[i, r] += sign * (I_inv[i, r, 0] * p0 + I_inv[i, r, 1] * p1 + I_inv[i, r, 2] * p2)


@njit(**JIT)
def prepare_rolling_kernel(rows, body_a, body_b, normal, tangent1, tangent2, anchor_offset, match,
                           old_rolling_impulse, I_inv, body_rolling, body_spinning,
                           # outputs
                           rolling_mass, rolling_limit, rolling_impulse):
    """Per contact row c in ``rows`` (R,): the effective masses (C, 3) about t1, t2, n, the
    limits per unit normal impulse (C, 2): c r (m) and s (m), and the accumulated impulses
    (C, 3) N m s about t1, t2, n carried over from the old contact ``match[c]`` (-1: none)."""
    for i in range(rows.shape[0]):
        c = rows[i]
        a = body_a[c]
        b = body_b[c]
        ra = math.sqrt(anchor_offset[c, 0] ** 2 + anchor_offset[c, 1] ** 2 + anchor_offset[c, 2] ** 2)
        rb = math.sqrt(anchor_offset[c, 3] ** 2 + anchor_offset[c, 4] ** 2 + anchor_offset[c, 5] ** 2)
        rolling_limit[c, 0] = max(body_rolling[a], body_rolling[b]) * max(ra, rb)
        rolling_limit[c, 1] = max(body_spinning[a], body_spinning[b])
        t0, t1, t2 = tangent1[c, 0], tangent1[c, 1], tangent1[c, 2]
        s0, s1, s2 = tangent2[c, 0], tangent2[c, 1], tangent2[c, 2]
        n0, n1, n2 = normal[c, 0], normal[c, 1], normal[c, 2]
        rolling_mass[c, 0] = _axis_mass(I_inv, a, b, t0, t1, t2)
        rolling_mass[c, 1] = _axis_mass(I_inv, a, b, s0, s1, s2)
        rolling_mass[c, 2] = _axis_mass(I_inv, a, b, n0, n1, n2)
        m = match[c]
        if m >= 0:
            p0, p1, p2 = old_rolling_impulse[m, 0], old_rolling_impulse[m, 1], old_rolling_impulse[m, 2]
            rolling_impulse[c, 0] = p0 * t0 + p1 * t1 + p2 * t2
            rolling_impulse[c, 1] = p0 * s0 + p1 * s1 + p2 * s2
            rolling_impulse[c, 2] = p0 * n0 + p1 * n1 + p2 * n2
        else:
            rolling_impulse[c, 0] = 0.0
            rolling_impulse[c, 1] = 0.0
            rolling_impulse[c, 2] = 0.0


@njit(**JIT)
def warm_start_rolling_kernel(rows, body_a, body_b, normal, tangent1, tangent2, rolling_impulse, I_inv,
                              # output
                              omega):
    """Apply each row's accumulated angular impulse once (b gets +P, a gets -P)."""
    for i in range(rows.shape[0]):
        c = rows[i]
        j1, j2, jn = rolling_impulse[c, 0], rolling_impulse[c, 1], rolling_impulse[c, 2]
        p0 = j1 * tangent1[c, 0] + j2 * tangent2[c, 0] + jn * normal[c, 0]
        p1 = j1 * tangent1[c, 1] + j2 * tangent2[c, 1] + jn * normal[c, 1]
        p2 = j1 * tangent1[c, 2] + j2 * tangent2[c, 2] + jn * normal[c, 2]
        _turn(I_inv, omega, body_a[c], -1.0, p0, p1, p2)
        _turn(I_inv, omega, body_b[c], 1.0, p0, p1, p2)


@njit(**JIT)
def solve_rolling_kernel(rows, body_a, body_b, normal, tangent1, tangent2, normal_impulse, rolling_mass,
                         rolling_limit, I_inv,
                         # outputs
                         omega, rolling_impulse):
    """One sweep over the rows: the relative angular velocity wb - wa about t1, t2 driven to 0
    within the disc of radius rolling_limit[c, 0] * lambda_n, about n within
    +- rolling_limit[c, 1] * lambda_n."""
    for i in range(rows.shape[0]):
        c = rows[i]
        a = body_a[c]
        b = body_b[c]
        w0 = omega[b, 0] - omega[a, 0]
        w1 = omega[b, 1] - omega[a, 1]
        w2 = omega[b, 2] - omega[a, 2]
        e0, e1, e2 = tangent1[c, 0], tangent1[c, 1], tangent1[c, 2]
        f0, f1, f2 = tangent2[c, 0], tangent2[c, 1], tangent2[c, 2]
        n0, n1, n2 = normal[c, 0], normal[c, 1], normal[c, 2]
        old1, old2, oldn = rolling_impulse[c, 0], rolling_impulse[c, 1], rolling_impulse[c, 2]
        new1 = old1 - rolling_mass[c, 0] * (w0 * e0 + w1 * e1 + w2 * e2)
        new2 = old2 - rolling_mass[c, 1] * (w0 * f0 + w1 * f1 + w2 * f2)
        limit = rolling_limit[c, 0] * normal_impulse[c]
        mag2 = new1 * new1 + new2 * new2
        if mag2 > limit * limit:
            scale = limit / math.sqrt(mag2) if mag2 > 0.0 else 0.0
            new1 *= scale
            new2 *= scale
        limit_n = rolling_limit[c, 1] * normal_impulse[c]
        newn = min(max(oldn - rolling_mass[c, 2] * (w0 * n0 + w1 * n1 + w2 * n2), -limit_n), limit_n)
        rolling_impulse[c, 0] = new1
        rolling_impulse[c, 1] = new2
        rolling_impulse[c, 2] = newn
        j1 = new1 - old1
        j2 = new2 - old2
        jn = newn - oldn
        p0 = j1 * e0 + j2 * f0 + jn * n0
        p1 = j1 * e1 + j2 * f1 + jn * n1
        p2 = j1 * e2 + j2 * f2 + jn * n2
        _turn(I_inv, omega, a, -1.0, p0, p1, p2)
        _turn(I_inv, omega, b, 1.0, p0, p1, p2)


@njit(**JIT)
def store_rolling_kernel(count, normal, tangent1, tangent2, rolling_impulse,
                         # output
                         old_rolling_impulse):
    """Each of the first ``count`` contacts' accumulated angular impulse as a world vector
    (N m s), in the rows of the keys ``store_impulses_kernel`` keeps."""
    for c in range(count):
        j1, j2, jn = rolling_impulse[c, 0], rolling_impulse[c, 1], rolling_impulse[c, 2]
        for k in range(3):
            old_rolling_impulse[c, k] = j1 * tangent1[c, k] + j2 * tangent2[c, k] + jn * normal[c, k]
