"""The gear row (``tumble.joints.GearJoint``): one velocity row coupling the 1-D coordinates of
two hinge or slider joints, q_1 = p(q_2) with p(q) = a0 + a1 q + ... + a4 q^4 (the coefficients in
``param[g, G_COEF:G_COEF + 5]``, the joints' indices in ``param[g, G_JOINT]``, ``G_FOLLOWS``).

Its Jacobian is J = J_1 - p'(q_2) J_2, where J_k is joint k's coordinate row (``_coordinate_row``:
a hinge's angular row about its axis, a slider's linear row at Box2D's prismatic arms) over that
joint's two bodies; it spans up to four bodies, two of which may be the same (a gripper's two
fingers on one hand), so its effective mass J M^-1 J^T = K_1 + s^2 K_2 - 2 s J_1 M^-1 J_2^T has a
cross term from each body the two joints share (Box2D v2's b2GearJoint, which couples the two
joints' bodies the same way). The accumulated impulse is kept in the gear's ``A_SPRING`` column
of ``axial_impulse`` (its other columns stay 0).

Arrays as in ``joint_solve``: x (N, 3) m, R (N, 3, 3), v, omega (N, 3) world, inv_mass (N,) 1/kg,
I_inv (N, 3, 3) world 1/(kg m^2); body -1 is the world.
"""

from __future__ import annotations

from numba import njit

from ..joints import G_COEF, G_FOLLOWS, G_JOINT, G_MASS
from ..math3d import NO_NRT
from .joint_math import _coordinate_row, _cross, _dot, _mat_vec, _row_apply, _row_velocity

GEAR_COLUMN = 0  # = joint_solve.A_SPRING: the gear's accumulated impulse (N s or N m s, along J)


@njit(**NO_NRT)
def gear_on(g, param, enabled):
    """Whether gear g acts: both its joints do (a broken joint stops its gear); a lock (no joint
    followed: ``G_FOLLOWS`` -1) while its joint does."""
    k = int(param[g, G_FOLLOWS])
    return enabled[int(param[g, G_JOINT])] and (k < 0 or enabled[k])


@njit(**NO_NRT)
def _entry(linear, n, r):
    """(linear part, angular part) of a coordinate row on its body b (on body a: the negatives)."""
    if linear:
        return n, _cross(r, n)
    return (0.0, 0.0, 0.0), n


@njit(**NO_NRT)
def gear_entries(a1, b1, lin1, n1, ra1, rb1, a2, b2, lin2, n2, ra2, rb2, s):
    """The gear row's J as four (body, linear part, angular part) entries: b1, a1, b2, a2 (the
    signs and joint 2's factor -s folded in); J (v, omega) = sum of l . v_body + g . omega_body."""
    lb1, gb1 = _entry(lin1, n1, rb1)
    la1, ga1 = _entry(lin1, n1, ra1)
    lb2, gb2 = _entry(lin2, n2, rb2)
    la2, ga2 = _entry(lin2, n2, ra2)
    bodies = (b1, a1, b2, a2)
    scale = (1.0, -1.0, -s, s)
    lins = (lb1, la1, lb2, la2)
    angs = (gb1, ga1, gb2, ga2)
    return bodies, scale, lins, angs


@njit(**NO_NRT)
def free_mass(inv_mass, I_inv, a1, b1, lin1, n1, ra1, rb1, a2, b2, lin2, n2, ra2, rb2, s):
    """J M^-1 J^T of the gear row over its free bodies (1/kg, 1/(kg m^2) or mixed): the sum over
    pairs of its entries on one body, so a body the two joints share (a gripper's hand) gives the
    cross terms."""
    bodies, scale, lins, angs = gear_entries(a1, b1, lin1, n1, ra1, rb1, a2, b2, lin2, n2, ra2, rb2, s)
    total = 0.0
    for e in range(4):
        i = bodies[e]
        if i < 0:
            continue
        for f in range(4):
            if bodies[f] == i:
                total += scale[e] * scale[f] * (inv_mass[i] * _dot(lins[e], lins[f])
                                                + _dot(angs[e], _mat_vec(I_inv, i, angs[f])))
    return total


@njit(**NO_NRT)
def gear_row(g, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position, x, R):
    """Gear g's two coordinate rows at the current poses: (j1, a1, b1, linear1, n1, ra1, rb1, j2,
    a2, b2, linear2, n2, ra2, rb2, C, s) with C = q_1 - p(q_2) (rad or m) its error and s = p'(q_2)
    the factor of joint 2's row in J. The hinges' angles are unwrapped around ``position``."""
    j1 = int(param[g, G_JOINT])
    j2 = int(param[g, G_FOLLOWS])
    a1 = joint_a[j1]
    b1 = joint_b[j1]
    _h1, lin1, n1, ra1, rb1, q1 = _coordinate_row(joint_type[j1], j1, a1, b1, x, R, local_a, local_b, frame_a,
                                                  frame_b, position)
    if j2 < 0:  # a lock, q_1 = a0: joint 2's row on no body (the world twice: no velocity, no mass)
        a2 = -1
        b2 = -1
        lin2 = False
        n2 = (0.0, 0.0, 0.0)
        ra2 = n2
        rb2 = n2
        q2 = 0.0
    else:
        a2 = joint_a[j2]
        b2 = joint_b[j2]
        _h2, lin2, n2, ra2, rb2, q2 = _coordinate_row(joint_type[j2], j2, a2, b2, x, R, local_a, local_b, frame_a,
                                                      frame_b, position)
    c0 = param[g, G_COEF]
    c1 = param[g, G_COEF + 1]
    c2 = param[g, G_COEF + 2]
    c3 = param[g, G_COEF + 3]
    c4 = param[g, G_COEF + 4]
    p = c0 + q2 * (c1 + q2 * (c2 + q2 * (c3 + q2 * c4)))
    s = c1 + q2 * (2.0 * c2 + q2 * (3.0 * c3 + q2 * 4.0 * c4))
    return j1, a1, b1, lin1, n1, ra1, rb1, j2, a2, b2, lin2, n2, ra2, rb2, q1 - p, s


@njit(**NO_NRT)
def gear_rate(g, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position, x, R, v, omega):
    """(C, Cdot): gear g's error (rad or m) and its rate J (v, omega)."""
    (_j1, a1, b1, lin1, n1, ra1, rb1, _j2, a2, b2, lin2, n2, ra2, rb2, C,
     s) = gear_row(g, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position, x, R)
    return C, (_row_velocity(v, omega, a1, b1, lin1, n1, ra1, rb1)
               - s * _row_velocity(v, omega, a2, b2, lin2, n2, ra2, rb2))


@njit(**NO_NRT)
def gear_axis(g, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position, x, R):
    """(linear, n): the coordinate row of the joint gear g moves (its ``joint``): a slider's axis
    (linear) or a hinge's (world), along which the gear's impulse acts on that joint's body b."""
    (_j1, _a1, _b1, lin1, n1, _ra1, _rb1, _j2, _a2, _b2, _lin2, _n2, _ra2, _rb2, _C,
     _s) = gear_row(g, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position, x, R)
    return lin1, n1


@njit(**NO_NRT)
def gear_apply(g, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position, x, R, inv_mass,
               I_inv, impulse, v, omega):
    """Apply ``impulse`` along gear g's J to v, omega (the warm start)."""
    (_j1, a1, b1, lin1, n1, ra1, rb1, _j2, a2, b2, lin2, n2, ra2, rb2, _C,
     s) = gear_row(g, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position, x, R)
    _row_apply(v, omega, inv_mass, I_inv, a1, b1, lin1, n1, ra1, rb1, impulse)
    _row_apply(v, omega, inv_mass, I_inv, a2, b2, lin2, n2, ra2, rb2, -s * impulse)


@njit(**NO_NRT)
def solve_gear(g, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position, x, R, inv_mass,
               I_inv, soft, v, omega, axial_impulse):
    """One Gauss-Seidel update of gear g: the soft row (Box2D v3's b2Softness ``soft`` = (bias rate,
    mass scale, impulse scale); (0, 1, 0) in the relax) on its accumulated impulse."""
    (_j1, a1, b1, lin1, n1, ra1, rb1, _j2, a2, b2, lin2, n2, ra2, rb2, C,
     s) = gear_row(g, joint_type, joint_a, joint_b, local_a, local_b, frame_a, frame_b, param, position, x, R)
    k = param[g, G_MASS]
    if k == 0.0:
        k = free_mass(inv_mass, I_inv, a1, b1, lin1, n1, ra1, rb1, a2, b2, lin2, n2, ra2, rb2, s)
    if k <= 0.0:
        return
    cdot = _row_velocity(v, omega, a1, b1, lin1, n1, ra1, rb1) - s * _row_velocity(v, omega, a2, b2, lin2, n2, ra2, rb2)
    old = axial_impulse[g, GEAR_COLUMN]
    imp = -soft[1] * (cdot + soft[0] * C) / k - soft[2] * old
    axial_impulse[g, GEAR_COLUMN] = old + imp
    _row_apply(v, omega, inv_mass, I_inv, a1, b1, lin1, n1, ra1, rb1, imp)
    _row_apply(v, omega, inv_mass, I_inv, a2, b2, lin2, n2, ra2, rb2, -s * imp)
