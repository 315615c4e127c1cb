"""Capsule family: plane-capsule, sphere-capsule, capsule-capsule; segment helpers (contract in ``pairs/__init__``).

A capsule is the set of points within ``radius`` of its core segment
``pos +- half_length * rot[:, 2]``.
"""

from __future__ import annotations

import math

from numba import njit

from ...math3d import JIT
from .sphere import plane_world, sphere_sphere_core


@njit(**JIT)
def clamp01(v):
    return 0.0 if v < 0.0 else (1.0 if v > 1.0 else v)


@njit(**JIT)
def segment_ends(pos, rot, half):
    """The core segment of a capsule: (p0, p1) as tuples, p1 - p0 along +z of the shape."""
    ux, uy, uz = rot[0, 2] * half, rot[1, 2] * half, rot[2, 2] * half
    return (pos[0] - ux, pos[1] - uy, pos[2] - uz), (pos[0] + ux, pos[1] + uy, pos[2] + uz)


@njit(**JIT)
def closest_segment_segment(p1, q1, p2, q2):
    """Parameters (s, t) in [0, 1] of the closest points p1 + s (q1 - p1) and p2 + t (q2 - p2).

    Ericson, Real-Time Collision Detection (2005) §5.1.9. Parallel segments take
    s = 0 (then t from it): the caller handles the parallel case itself when it
    needs more than one point.
    """
    d1 = (q1[0] - p1[0], q1[1] - p1[1], q1[2] - p1[2])
    d2 = (q2[0] - p2[0], q2[1] - p2[1], q2[2] - p2[2])
    r = (p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2])
    a = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]
    e = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2]
    f = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2]
    eps = 1e-24
    if a <= eps and e <= eps:
        return 0.0, 0.0
    if a <= eps:
        return 0.0, clamp01(f / e)
    c = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2]
    if e <= eps:
        return clamp01(-c / a), 0.0
    b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]
    denom = a * e - b * b
    s = clamp01((b * f - c * e) / denom) if denom > 1e-12 * a * e else 0.0
    t = (b * s + f) / e
    if t < 0.0:
        t = 0.0
        s = clamp01(-c / a)
    elif t > 1.0:
        t = 1.0
        s = clamp01((b - c) / a)
    return s, t


@njit(**JIT)
def lerp3(p, q, s):
    return (p[0] + s * (q[0] - p[0]), p[1] + s * (q[1] - p[1]), p[2] + s * (q[2] - p[2]))


@njit(**JIT)
def collide_plane_capsule(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative,
                          normal, point, separation, feature):
    nx, ny, nz, d = plane_world(pos_a, rot_a, params_a)
    r = params_b[0]
    p0, p1 = segment_ends(pos_b, rot_b, params_b[1])
    normal[0] = nx
    normal[1] = ny
    normal[2] = nz
    count = 0
    for k in range(2):
        e = p0 if k == 0 else p1
        sep = nx * e[0] + ny * e[1] + nz * e[2] - d - r
        if sep < speculative:
            h = r + 0.5 * sep
            point[count, 0] = e[0] - h * nx
            point[count, 1] = e[1] - h * ny
            point[count, 2] = e[2] - h * nz
            separation[count] = sep
            feature[count] = k
            count += 1
    return count


@njit(**JIT)
def collide_sphere_capsule(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative,
                           normal, point, separation, feature):
    p0, p1 = segment_ends(pos_b, rot_b, params_b[1])
    dx, dy, dz = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    dd = dx * dx + dy * dy + dz * dz
    t = 0.5
    if dd > 0.0:
        t = clamp01(((pos_a[0] - p0[0]) * dx + (pos_a[1] - p0[1]) * dy + (pos_a[2] - p0[2]) * dz) / dd)
    c = lerp3(p0, p1, t)
    return sphere_sphere_core(pos_a, params_a[0], c, params_b[0], speculative, normal, point, separation,
                              feature, 0, 0)


# Two capsules whose axes are closer to parallel than this (sin^2 of the angle, about
# 3 degrees) and whose segments overlap along the axis get two points, like a capsule
# lying on another (Box2D v3 b2CollideCapsules does the same in 2-D).
PARALLEL_SIN2 = 0.0025


@njit(**JIT)
def collide_capsule_capsule(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative,
                            normal, point, separation, feature):
    ra, rb = params_a[0], params_b[0]
    a0, a1 = segment_ends(pos_a, rot_a, params_a[1])
    b0, b1 = segment_ends(pos_b, rot_b, params_b[1])
    s, t = closest_segment_segment(a0, a1, b0, b1)
    ca = lerp3(a0, a1, s)
    cb = lerp3(b0, b1, t)
    dx, dy, dz = cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2]
    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
    if dist - ra - rb >= speculative:
        return 0
    ua = (rot_a[0, 2], rot_a[1, 2], rot_a[2, 2])
    ub = (rot_b[0, 2], rot_b[1, 2], rot_b[2, 2])
    cx = ua[1] * ub[2] - ua[2] * ub[1]
    cy = ua[2] * ub[0] - ua[0] * ub[2]
    cz = ua[0] * ub[1] - ua[1] * ub[0]
    sin2 = cx * cx + cy * cy + cz * cz
    if dist > 1e-9:
        nx, ny, nz = dx / dist, dy / dist, dz / dist
    else:
        # the core segments cross: the normal of both axes, pointing from a to b
        if sin2 > 1e-12:
            w = math.sqrt(sin2)
            nx, ny, nz = cx / w, cy / w, cz / w
        else:
            # collinear cores: any direction normal to the axis
            if abs(ua[0]) < 0.6:
                nx, ny, nz = 0.0, ua[2], -ua[1]
            else:
                nx, ny, nz = -ua[2], 0.0, ua[0]
            w = math.sqrt(nx * nx + ny * ny + nz * nz)
            nx, ny, nz = nx / w, ny / w, nz / w
        gx, gy, gz = pos_b[0] - pos_a[0], pos_b[1] - pos_a[1], pos_b[2] - pos_a[2]
        if nx * gx + ny * gy + nz * gz < 0.0:
            nx, ny, nz = -nx, -ny, -nz
    normal[0] = nx
    normal[1] = ny
    normal[2] = nz
    if sin2 < PARALLEL_SIN2:
        # overlap of b's segment projected on a's axis, as parameters along a
        la = 2.0 * params_a[1]
        if la > 0.0:
            t0 = ((b0[0] - a0[0]) * ua[0] + (b0[1] - a0[1]) * ua[1] + (b0[2] - a0[2]) * ua[2]) / la
            t1 = ((b1[0] - a0[0]) * ua[0] + (b1[1] - a0[1]) * ua[1] + (b1[2] - a0[2]) * ua[2]) / la
            lo = clamp01(min(t0, t1))
            hi = clamp01(max(t0, t1))
            if (hi - lo) * la > 1e-3 * (ra + rb):
                count = 0
                for k in range(2):
                    pa = lerp3(a0, a1, lo if k == 0 else hi)
                    # closest point of b's segment to pa
                    ex, ey, ez = b1[0] - b0[0], b1[1] - b0[1], b1[2] - b0[2]
                    ee = ex * ex + ey * ey + ez * ez
                    u = 0.5
                    if ee > 0.0:
                        u = clamp01(((pa[0] - b0[0]) * ex + (pa[1] - b0[1]) * ey + (pa[2] - b0[2]) * ez) / ee)
                    pb = lerp3(b0, b1, u)
                    sep = (pb[0] - pa[0]) * nx + (pb[1] - pa[1]) * ny + (pb[2] - pa[2]) * nz - ra - rb
                    if sep < speculative:
                        # midway between the surface points pa + ra n and pb - rb n
                        point[count, 0] = 0.5 * (pa[0] + pb[0]) + 0.5 * (ra - rb) * nx
                        point[count, 1] = 0.5 * (pa[1] + pb[1]) + 0.5 * (ra - rb) * ny
                        point[count, 2] = 0.5 * (pa[2] + pb[2]) + 0.5 * (ra - rb) * nz
                        separation[count] = sep
                        feature[count] = 1 + k
                        count += 1
                if count > 0:
                    return count
    sep = dist - ra - rb if dist > 1e-9 else -ra - rb
    # midway between the surface points ca + ra n and cb - rb n
    point[0, 0] = 0.5 * (ca[0] + cb[0]) + 0.5 * (ra - rb) * nx
    point[0, 1] = 0.5 * (ca[1] + cb[1]) + 0.5 * (ra - rb) * ny
    point[0, 2] = 0.5 * (ca[2] + cb[2]) + 0.5 * (ra - rb) * nz
    separation[0] = sep
    feature[0] = 0
    return 1
