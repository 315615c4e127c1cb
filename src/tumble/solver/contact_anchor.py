"""Where a contact's impulses act while the bodies move within a step: the anchors that follow
each body, the round surfaces whose contact point does not turn with them, and the one point
both impulses share.

Contacts are found once a step, on the poses at its start (``collide_pairs``); the substeps move
the bodies on. Each contact keeps one anchor per body, which follows that body: the separation
is read from them as the bodies move, and the impulses act at one point between them,
``_arms``. An anchor is a point fixed in its body, plus, where the body's surface is round
there, a world offset that does not turn with it (``anchor_offset``, written by
``anchor_offsets_kernel``):

    pa = xa + Ra la + oa,    pb = xb + Rb lb + ob,    m = pa + w (pb - pa)

NOTE: why the offsets: the contact point of a rolling ball is not a point of the ball. With the
anchor fixed in the ball (as a box's corner is), a ball rolling at 2 m/s on a plane turned its
anchor up and back 0.13 rad a step (dt 1/240 s): the normal impulse then acted off the centre,
and the ball lost 27 % of its speed in 1 s, a frictionless ball spun in place lost 22 % of its
spin, and a frictionless ball sliding at 2 m/s started to spin (2.4 rad/s in 1 s); all of it
first order in dt. A round surface is its core (a sphere's centre, a capsule's segment, a
cylinder's or a cone's axis) grown by a radius: its anchor is the core point, fixed in the body,
plus the radius along the direction from the core to the contact, fixed in the world for the
step. Then a ball's anchor stays at its lowest point however it turns, and a capsule's at its
segment ends turning with it about any other axis. A round side's anchor starts on its own
surface, not at the contact's midpoint (``prepare_contacts_kernel``), so that its arm is its
radius from the first substep of an impact.

NOTE: why the weight w: the two impulses must act at one point m, or they change the total
angular momentum (with an arm fixed to each body, as Box2D, sum(x x P) + L changed by 4 % in an
off-centre sphere collision). Where a round side touches a side that is not (a ball on a plane,
a box's face or a mesh), the contact moves with the round body over the other's face, so m is
the round body's anchor (w = 1 for b's, 0 for a's); elsewhere (box on plane or box, ball on
ball) it is their midpoint, w = 1/2, the contact point at the start of the step. Dead end: m on
a box's corner against a plane too (the corner is where that contact is): the rigid-impact tests
drifted from the instantaneous impact they compare with, which a step spreads over a substep
in which the corner's arm turns (an edge landing at 20 m/s, mu 1: omega off by 0.68 % of the
speed instead of 0.02 %; frictionless corners 0.39 % in v instead of 0.24 %), and sliding boxes
gained nothing (slide distances the same to 1e-6). A contact deeper than ``DEEP_OVERLAP``
keeps the midpoint too: its anchors sit on the two surfaces (``prepare_contacts_kernel``), so
the midpoint is far from the body, and a friction impulse there turns it little.
"""

from __future__ import annotations

import math

from numba import njit, prange

from ..collision.constants import DEEP_OVERLAP
from ..math3d import JIT, serial_twin, unit_tangent
from ..shapes import SHAPE_CAPSULE, SHAPE_CONE, SHAPE_CYLINDER, SHAPE_ELLIPSOID, SHAPE_SPHERE

# A contact on a cylinder or a cone counts as on its round side or rim when its surface point
# lies within ROUND_RIM_FRACTION of the radius from the axis and its direction from the axis is
# within ROUND_ALIGNMENT (cosine) of the direction the body touches in, i.e. it is the rim's or
# the side's support point; contacts on a flat cap (a cylinder standing, whose four points lie
# on the rim but touch along the axis) keep anchors fixed in the body.
ROUND_RIM_FRACTION = 0.99
ROUND_ALIGNMENT = 0.999

#: columns of ``anchor_offset`` (C, 7): a's world offset (3), b's (3), and w - 1/2, where w is the
#: weight of b's anchor in the shared point m (so that a row of zeros is the midpoint)
OFFSET_SHIFT = 6


@njit(**JIT)
def _arms(x, R, a, b, local_a, local_b, anchor_offset, c):
    """(ra, rb, d) of contact c at the current poses: the anchors pa = xa + Ra la + oa and
    pb = xb + Rb lb + ob, the shared point m = (pa + pb) / 2 + (w - 1/2) (pb - pa), the arms
    ra = m - xa, rb = m - xb, and d = pb - pa (m, world).

    Both impulses of a contact act at the one point m, so they cancel in the total angular
    momentum about any point (the module docstring says why m is where it is). A row of zeros
    is an anchor fixed in each body and m their midpoint, with the bits of that formula alone:
    the rows of a world without round shapes stay zero (``ContactSolver``), and so do those of
    contacts without a round side (a box on a plane) in a world with some.
    PERF: a branch here on whether the world has offsets cost 6 ms a large-pyramid step (its
    60 000 contacts); reading the zeros costs about 0.5 ms (its relax 20.6-20.9 against
    20.1-20.3 ms before the offsets).
    """
    pa0 = (x[a, 0] + R[a, 0, 0] * local_a[c, 0] + R[a, 0, 1] * local_a[c, 1] + R[a, 0, 2] * local_a[c, 2]
           + anchor_offset[c, 0])
    pa1 = (x[a, 1] + R[a, 1, 0] * local_a[c, 0] + R[a, 1, 1] * local_a[c, 1] + R[a, 1, 2] * local_a[c, 2]
           + anchor_offset[c, 1])
    pa2 = (x[a, 2] + R[a, 2, 0] * local_a[c, 0] + R[a, 2, 1] * local_a[c, 1] + R[a, 2, 2] * local_a[c, 2]
           + anchor_offset[c, 2])
    pb0 = (x[b, 0] + R[b, 0, 0] * local_b[c, 0] + R[b, 0, 1] * local_b[c, 1] + R[b, 0, 2] * local_b[c, 2]
           + anchor_offset[c, 3])
    pb1 = (x[b, 1] + R[b, 1, 0] * local_b[c, 0] + R[b, 1, 1] * local_b[c, 1] + R[b, 1, 2] * local_b[c, 2]
           + anchor_offset[c, 4])
    pb2 = (x[b, 2] + R[b, 2, 0] * local_b[c, 0] + R[b, 2, 1] * local_b[c, 1] + R[b, 2, 2] * local_b[c, 2]
           + anchor_offset[c, 5])
    d0, d1, d2 = pb0 - pa0, pb1 - pa1, pb2 - pa2
    shift = anchor_offset[c, OFFSET_SHIFT]
    m0 = 0.5 * (pa0 + pb0) + shift * d0
    m1 = 0.5 * (pa1 + pb1) + shift * d1
    m2 = 0.5 * (pa2 + pb2) + shift * d2
    ra = (m0 - x[a, 0], m1 - x[a, 1], m2 - x[a, 2])
    rb = (m0 - x[b, 0], m1 - x[b, 1], m2 - x[b, 2])
    return ra, rb, (d0, d1, d2)


@njit(**JIT)
def round_offset(shape_type, params, centre, rot, s, p0, p1, p2, u0, u1, u2, w0, w1, w2):
    """(o0, o1, o2, round) for a contact whose surface point p (m, world) lies on shape ``s``
    touching the other body in the unit direction u (world): where the shape is round at p,
    the offset o from its core to p (radius long), else (0, 0, 0, False).

    shape_type, params: of shape s (``shape_params`` row: radius and half length in columns 0
    and 1; a cone's column 1 is its height, unused here; an ellipsoid's semi-axes); centre (S, 3)
    m and rot (S, 3, 3) its pose at the step's start (``update_bounds``): the axis is rot[:, 2];
    w (rad/s, world): the body's angular velocity less the other body's (an ellipsoid's rolling).
    """
    radius = params[0]
    half_length = params[1]
    q0 = p0 - centre[s, 0]
    q1 = p1 - centre[s, 1]
    q2 = p2 - centre[s, 2]
    if shape_type == SHAPE_SPHERE:
        length = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
        if length == 0.0:
            return 0.0, 0.0, 0.0, False
        k = radius / length
        return k * q0, k * q1, k * q2, True
    if shape_type == SHAPE_ELLIPSOID:
        return _ellipsoid_offset(rot, s, params, q0, q1, q2, w0, w1, w2)
    if shape_type != SHAPE_CAPSULE and shape_type != SHAPE_CYLINDER and shape_type != SHAPE_CONE:
        return 0.0, 0.0, 0.0, False
    k0, k1, k2 = rot[s, 0, 2], rot[s, 1, 2], rot[s, 2, 2]
    z = q0 * k0 + q1 * k1 + q2 * k2
    if shape_type == SHAPE_CAPSULE:  # the core is the segment: from its nearest point to p
        z = min(max(z, -half_length), half_length)
    r0, r1, r2 = q0 - z * k0, q1 - z * k1, q2 - z * k2
    rho = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    if shape_type == SHAPE_CAPSULE:
        if rho == 0.0:
            return 0.0, 0.0, 0.0, False
        k = radius / rho
        return k * r0, k * r1, k * r2, True
    # cylinder or cone: round only at the support point of its side or rim
    uz = u0 * k0 + u1 * k1 + u2 * k2
    w0, w1, w2 = u0 - uz * k0, u1 - uz * k1, u2 - uz * k2
    across = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if rho < ROUND_RIM_FRACTION * radius or across == 0.0:
        return 0.0, 0.0, 0.0, False
    if r0 * w0 + r1 * w1 + r2 * w2 < ROUND_ALIGNMENT * rho * across:
        return 0.0, 0.0, 0.0, False
    k = radius / rho
    return k * r0, k * r1, k * r2, True


@njit(**JIT)
def _ellipsoid_offset(rot, s, params, q0, q1, q2, w0, w1, w2):
    """The round offset at surface point q (world, from the centre) of ellipsoid s: its radius of
    curvature rho along the way the contact runs over it, times its outward unit normal there.

    NOTE: an ellipsoid has no core that a radius grows into it; its surface near q is the
    osculating circle, of centre q - rho n, in the plane of n and the direction t the contact
    point runs along the surface, t = n x w (w the rolling: the relative angular velocity). Its
    anchor is that centre, fixed in the body, plus rho n held in the world: the sphere's rule with
    the local sphere. Dead ends (an egg rocking 0.05 rad on its short axis, rolling without
    slipping, amplitude after 2 s at dt 1/240 s; it must stay 0.05): an anchor fixed in the body
    0.065, the offset from the centre held in the world (Box2D's anchors) 0.060: both gain
    energy at first order in dt. The normal curvature along unit t (shape frame), F = sum
    x_i^2 / a_i^2: kappa = t' (Hess F) t / |grad F| = sum t_i^2 / a_i^2 / |x / a^2|.
    Without rolling (w along n, or none) any tangent serves: the contact does not move."""
    a, b, c = params[0], params[1], params[2]
    # the point and w in the shape frame
    x = rot[s, 0, 0] * q0 + rot[s, 1, 0] * q1 + rot[s, 2, 0] * q2
    y = rot[s, 0, 1] * q0 + rot[s, 1, 1] * q1 + rot[s, 2, 1] * q2
    z = rot[s, 0, 2] * q0 + rot[s, 1, 2] * q1 + rot[s, 2, 2] * q2
    wx = rot[s, 0, 0] * w0 + rot[s, 1, 0] * w1 + rot[s, 2, 0] * w2
    wy = rot[s, 0, 1] * w0 + rot[s, 1, 1] * w1 + rot[s, 2, 1] * w2
    wz = rot[s, 0, 2] * w0 + rot[s, 1, 2] * w1 + rot[s, 2, 2] * w2
    gx, gy, gz = x / (a * a), y / (b * b), z / (c * c)
    g = math.sqrt(gx * gx + gy * gy + gz * gz)
    if g == 0.0:
        return 0.0, 0.0, 0.0, False
    nx, ny, nz = gx / g, gy / g, gz / g
    tx, ty, tz = ny * wz - nz * wy, nz * wx - nx * wz, nx * wy - ny * wx
    t = math.sqrt(tx * tx + ty * ty + tz * tz)
    if t <= 1e-12 * math.sqrt(wx * wx + wy * wy + wz * wz) or t == 0.0:
        tx, ty, tz = unit_tangent(nx, ny, nz)  # any tangent
    else:
        tx, ty, tz = tx / t, ty / t, tz / t
    rho = g / (tx * tx / (a * a) + ty * ty / (b * b) + tz * tz / (c * c))
    return (rho * (rot[s, 0, 0] * nx + rot[s, 0, 1] * ny + rot[s, 0, 2] * nz),
            rho * (rot[s, 1, 0] * nx + rot[s, 1, 1] * ny + rot[s, 1, 2] * nz),
            rho * (rot[s, 2, 0] * nx + rot[s, 2, 1] * ny + rot[s, 2, 2] * nz), True)


@njit(**JIT, parallel=True)
def anchor_offsets_kernel(contact_manifold, manifold_shape_a, manifold_shape_b, point, normal, separation,
                          contact_body_a, contact_body_b, omega, shape_type, shape_params, shape_pos, shape_rot,
                          # output
                          anchor_offset):
    """Per contact (C): the round offsets of both anchors and the weight w of b's anchor in the
    shared point (``anchor_offset`` (C, 7), columns 0-2 a's offset, 3-5 b's, m, world; 6 w - 1/2).

    point (C, 3) m midway between the surfaces, normal (C, 3) from a to b, separation (C,) m:
    a's surface point is point - s/2 n (touching b along +n), b's point + s/2 n (along -n).
    contact_body_a, contact_body_b (C,): the bodies; omega (N, 3) rad/s, world, at the step's start.
    """
    for c in prange(point.shape[0]):
        mf = contact_manifold[c]
        sa = manifold_shape_a[mf]
        sb = manifold_shape_b[mf]
        n0, n1, n2 = normal[c, 0], normal[c, 1], normal[c, 2]
        half = 0.5 * separation[c]
        ta = shape_type[sa]
        tb = shape_type[sb]
        ba = contact_body_a[c]
        bb = contact_body_b[c]
        w0, w1, w2 = omega[ba, 0] - omega[bb, 0], omega[ba, 1] - omega[bb, 1], omega[ba, 2] - omega[bb, 2]
        oa0, oa1, oa2, round_a = round_offset(ta, shape_params[sa], shape_pos, shape_rot, sa,
                                              point[c, 0] - half * n0, point[c, 1] - half * n1,
                                              point[c, 2] - half * n2, n0, n1, n2, w0, w1, w2)
        ob0, ob1, ob2, round_b = round_offset(tb, shape_params[sb], shape_pos, shape_rot, sb,
                                              point[c, 0] + half * n0, point[c, 1] + half * n1,
                                              point[c, 2] + half * n2, -n0, -n1, -n2, -w0, -w1, -w2)
        if separation[c] < -DEEP_OVERLAP:
            w = 0.5  # the midpoint, far from both (see the module docstring)
        elif round_b and not round_a:
            w = 1.0
        elif round_a and not round_b:
            w = 0.0
        else:
            w = 0.5
        anchor_offset[c, 0], anchor_offset[c, 1], anchor_offset[c, 2] = oa0, oa1, oa2
        anchor_offset[c, 3], anchor_offset[c, 4], anchor_offset[c, 5] = ob0, ob1, ob2
        anchor_offset[c, OFFSET_SHIFT] = w - 0.5


# a few contacts on the calling thread (``contact_solve.prepare_contacts_serial_kernel``): the same bits
anchor_offsets_serial_kernel = serial_twin(anchor_offsets_kernel, "anchor_offsets_serial_kernel")
