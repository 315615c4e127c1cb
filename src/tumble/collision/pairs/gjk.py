"""Support functions, GJK distance and EPA penetration for any two convex shapes (world frame, metres).

A shape here is its *core*: a sphere is its centre and a capsule its segment, with
``core_radius`` added by the caller (Bullet's margins, Box2D's rounded shapes): GJK
then stays exact for them. Cylinder, cone, box, convex hull and triangle are their
own cores (radius 0).

GJK: Gilbert, Johnson, Keerthi (1988); the simplex sub-steps are Ericson, Real-Time
Collision Detection (2005) §9.5 and §5.1.5 (closest point of a triangle), written with
barycentric weights so that the witness points come out. EPA: van den Bergen,
"Proximity Queries and Penetration Depth Computation on 3D Game Objects" (GDC 2001),
with the horizon walk of Ericson §9.5.2 / Bullet's ``btGjkEpa``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...math3d import JIT, NO_NRT, unit_tangent
from ...shapes import (
    SHAPE_BOX,
    SHAPE_CAPSULE,
    SHAPE_CONE,
    SHAPE_CONVEX,
    SHAPE_CYLINDER,
    SHAPE_ELLIPSOID,
    SHAPE_SPHERE,
)

# Internal type id of one mesh triangle seen as a convex shape (its 3 corners in ``verts``).
SHAPE_TRIANGLE = 100

GJK_ITERATIONS = 64
# GJK stops when the support point improves the distance by less than this fraction
# (squared: |v|^2 - v.w <= GJK_REL^2 |v|^2).
GJK_REL = 1e-9
# ... or by less than this times |w|^2, the round-off floor of |v|^2 - v.w (m^2 per m^2).
GJK_ROUND = 1e-13
# Cores closer than this (m) are treated as touching: EPA gives the normal.
TOUCH = 1e-9
EPA_ITERATIONS = 64
EPA_MAX_VERTS = 68
EPA_MAX_FACES = 256
# EPA stops when the support point is less than this (m) beyond the closest face.
EPA_TOLERANCE = 1e-9


@njit(**NO_NRT)
def core_radius(t, params):
    """The radius a core is grown by: spheres and capsules; 0 for the others."""
    if t == SHAPE_SPHERE or t == SHAPE_CAPSULE:
        return params[0]
    return 0.0


@njit(**NO_NRT)
def support(t, pos, rot, params, verts, dx, dy, dz):
    """The point of the core of shape (t, pos, rot, params, verts) farthest along world (dx, dy, dz); a tuple."""
    lx = rot[0, 0] * dx + rot[1, 0] * dy + rot[2, 0] * dz
    ly = rot[0, 1] * dx + rot[1, 1] * dy + rot[2, 1] * dz
    lz = rot[0, 2] * dx + rot[1, 2] * dy + rot[2, 2] * dz
    px, py, pz = 0.0, 0.0, 0.0
    if t == SHAPE_CAPSULE:
        pz = params[1] if lz >= 0.0 else -params[1]
    elif t == SHAPE_CYLINDER or t == SHAPE_CONE:
        rr = math.sqrt(lx * lx + ly * ly)
        ll = math.sqrt(lx * lx + ly * ly + lz * lz)
        ux, uy = 0.0, 0.0
        if rr > 1e-12 * ll:
            ux, uy = lx / rr, ly / rr
        if t == SHAPE_CYLINDER:
            px, py = params[0] * ux, params[0] * uy
            pz = params[1] if lz >= 0.0 else -params[1]
        elif params[1] * lz > params[0] * rr:
            pz = params[1]  # the apex
        else:
            px, py = params[0] * ux, params[0] * uy  # a point of the base rim
    elif t == SHAPE_ELLIPSOID:
        # the point of (x/a)^2 + (y/b)^2 + (z/c)^2 = 1 whose normal is l: p = A^2 l / |A l|, A = diag(a, b, c)
        ax, ay, az = params[0] * lx, params[1] * ly, params[2] * lz
        n = math.sqrt(ax * ax + ay * ay + az * az)
        if n > 0.0:
            px, py, pz = params[0] * ax / n, params[1] * ay / n, params[2] * az / n
    elif t == SHAPE_BOX:
        px = params[0] if lx >= 0.0 else -params[0]
        py = params[1] if ly >= 0.0 else -params[1]
        pz = params[2] if lz >= 0.0 else -params[2]
    elif t == SHAPE_CONVEX or t == SHAPE_TRIANGLE:
        best = -np.inf
        for k in range(verts.shape[0]):
            d = verts[k, 0] * lx + verts[k, 1] * ly + verts[k, 2] * lz
            if d > best:
                best = d
                px, py, pz = verts[k, 0], verts[k, 1], verts[k, 2]
    return (pos[0] + rot[0, 0] * px + rot[0, 1] * py + rot[0, 2] * pz,
            pos[1] + rot[1, 0] * px + rot[1, 1] * py + rot[1, 2] * pz,
            pos[2] + rot[2, 0] * px + rot[2, 1] * py + rot[2, 2] * pz)


@njit(**NO_NRT)
def _dot(W, i, x, y, z):
    return W[i, 0] * x + W[i, 1] * y + W[i, 2] * z


@njit(**NO_NRT)
def _keep(W, SA, SB, ids, n, tmp):
    """Compact the simplex to rows ``ids[:n]`` (in that order; ids may repeat none but come in any order).

    tmp: (>= n, 9) scratch.
    """
    for j in range(n):
        i = ids[j]
        for c in range(3):
            tmp[j, c] = W[i, c]
            tmp[j, 3 + c] = SA[i, c]
            tmp[j, 6 + c] = SB[i, c]
    for j in range(n):
        for c in range(3):
            W[j, c] = tmp[j, c]
            SA[j, c] = tmp[j, 3 + c]
            SB[j, c] = tmp[j, 6 + c]
    return n


@njit(**NO_NRT)
def _closest_triangle(W, i0, i1, i2, lam3, sub):
    """Closest point of triangle W[i0] W[i1] W[i2] to the origin (Ericson §5.1.5).

    Writes the weights of the rows kept into lam3 and the rows into sub; returns
    (count kept, squared distance).
    """
    ax, ay, az = W[i0, 0], W[i0, 1], W[i0, 2]
    abx, aby, abz = W[i1, 0] - ax, W[i1, 1] - ay, W[i1, 2] - az
    acx, acy, acz = W[i2, 0] - ax, W[i2, 1] - ay, W[i2, 2] - az
    # p = origin: ap = -a
    d1 = -(abx * ax + aby * ay + abz * az)
    d2 = -(acx * ax + acy * ay + acz * az)
    if d1 <= 0.0 and d2 <= 0.0:
        sub[0] = i0
        lam3[0] = 1.0
        return 1, ax * ax + ay * ay + az * az
    bx, by, bz = W[i1, 0], W[i1, 1], W[i1, 2]
    d3 = -(abx * bx + aby * by + abz * bz)
    d4 = -(acx * bx + acy * by + acz * bz)
    if d3 >= 0.0 and d4 <= d3:
        sub[0] = i1
        lam3[0] = 1.0
        return 1, bx * bx + by * by + bz * bz
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        sub[0], sub[1] = i0, i1
        lam3[0], lam3[1] = 1.0 - v, v
        x, y, z = ax + v * abx, ay + v * aby, az + v * abz
        return 2, x * x + y * y + z * z
    cx, cy, cz = W[i2, 0], W[i2, 1], W[i2, 2]
    d5 = -(abx * cx + aby * cy + abz * cz)
    d6 = -(acx * cx + acy * cy + acz * cz)
    if d6 >= 0.0 and d5 <= d6:
        sub[0] = i2
        lam3[0] = 1.0
        return 1, cx * cx + cy * cy + cz * cz
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        sub[0], sub[1] = i0, i2
        lam3[0], lam3[1] = 1.0 - w, w
        x, y, z = ax + w * acx, ay + w * acy, az + w * acz
        return 2, x * x + y * y + z * z
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        sub[0], sub[1] = i1, i2
        lam3[0], lam3[1] = 1.0 - w, w
        x, y, z = bx + w * (cx - bx), by + w * (cy - by), bz + w * (cz - bz)
        return 2, x * x + y * y + z * z
    denom = va + vb + vc
    if denom == 0.0:
        # a degenerate triangle: fall back to its best edge
        sub[0] = i0
        lam3[0] = 1.0
        return 1, ax * ax + ay * ay + az * az
    # Inside: the origin's foot on the triangle's plane, and its weights as the areas of the three
    # triangles it makes with the edges. Ericson's weights vb / denom, vc / denom are differences of
    # products of dot products: on a thin triangle (two support points 1.6e-6 m apart on a cone's
    # rim, the third 0.6 m off) they cancel, and the far corner's weight came out 3e-7 wrong, the
    # closest point 2e-7 m off and GJK's normal 1.3e-6 rad off (tests/collision/test_closest_points.py,
    # two cones). The cross product n = ab x ac keeps its relative accuracy on a thin triangle, and
    # so do the areas (Montanari, Petrinic, Barbieri, "Improving the GJK algorithm", ACM TOG 2017,
    # compute the sub-simplices' weights from signed areas for the same reason).
    nx, ny, nz = aby * acz - abz * acy, abz * acx - abx * acz, abx * acy - aby * acx
    nn = nx * nx + ny * ny + nz * nz
    if nn == 0.0:
        v = vb / denom
        w = vc / denom
        sub[0], sub[1], sub[2] = i0, i1, i2
        lam3[0], lam3[1], lam3[2] = 1.0 - v - w, v, w
        x, y, z = ax + v * abx + w * acx, ay + v * aby + w * acy, az + v * abz + w * acz
        return 3, x * x + y * y + z * z
    t = (nx * ax + ny * ay + nz * az) / nn
    x, y, z = t * nx, t * ny, t * nz  # the foot
    l0 = _area_weight(nx, ny, nz, bx - x, by - y, bz - z, cx - x, cy - y, cz - z)
    l1 = _area_weight(nx, ny, nz, cx - x, cy - y, cz - z, ax - x, ay - y, az - z)
    l2 = _area_weight(nx, ny, nz, ax - x, ay - y, az - z, bx - x, by - y, bz - z)
    total = l0 + l1 + l2
    sub[0], sub[1], sub[2] = i0, i1, i2
    lam3[0], lam3[1], lam3[2] = l0 / total, l1 / total, l2 / total
    return 3, x * x + y * y + z * z


@njit(**NO_NRT)
def _area_weight(nx, ny, nz, ux, uy, uz, vx, vy, vz):
    """n . (u x v): twice the signed area of the triangle spanned by u and v, times |n|."""
    return nx * (uy * vz - uz * vy) + ny * (uz * vx - ux * vz) + nz * (ux * vy - uy * vx)


@njit(**NO_NRT)
def _reduce_simplex(W, SA, SB, k, lam, sub, lam3, best_sub, best_lam, tmp):
    """Reduce the simplex (k rows of W = SA - SB) to the rows that support its closest point to the origin.

    Sets ``lam`` (barycentric weights) and returns the new size; 4 means the
    origin is inside the tetrahedron. sub (4,) int, lam3 (3,), best_sub (3,) int, best_lam (3,),
    tmp (4, 9): scratch (``gjk_scratch``, lent once per narrowphase task).
    """
    if k == 1:
        lam[0] = 1.0
        return 1
    if k == 2:
        ex, ey, ez = W[1, 0] - W[0, 0], W[1, 1] - W[0, 1], W[1, 2] - W[0, 2]
        ee = ex * ex + ey * ey + ez * ez
        t = -_dot(W, np.int64(0), ex, ey, ez) / ee if ee > 0.0 else 0.0
        if t <= 0.0:
            lam[0] = 1.0
            return 1
        if t >= 1.0:
            sub[0] = 1
            _keep(W, SA, SB, sub, np.int64(1), tmp)
            lam[0] = 1.0
            return 1
        lam[0], lam[1] = 1.0 - t, t
        return 2
    if k == 3:
        n, _ = _closest_triangle(W, np.int64(0), np.int64(1), np.int64(2), lam3, sub)
        _keep(W, SA, SB, sub, n, tmp)
        for j in range(n):
            lam[j] = lam3[j]
        return n
    # tetrahedron: the faces whose plane separates the origin from the opposite vertex
    best = np.inf
    best_n = np.int64(0)  # np.int64, not literals: one compile of each callee
    outside_any = False
    # a flat tetrahedron (4 coplanar points: two parallel faces) cannot hold the origin: try every face
    size = 0.0
    for i in range(4):
        size = max(size, abs(W[i, 0] - W[0, 0]) + abs(W[i, 1] - W[0, 1]) + abs(W[i, 2] - W[0, 2]))
    flat_volume = 1e-12 * size * size * size
    for f in range(4):
        i0, i1, i2 = (f + 1) % 4, (f + 2) % 4, (f + 3) % 4
        ux, uy, uz = W[i1, 0] - W[i0, 0], W[i1, 1] - W[i0, 1], W[i1, 2] - W[i0, 2]
        vx, vy, vz = W[i2, 0] - W[i0, 0], W[i2, 1] - W[i0, 1], W[i2, 2] - W[i0, 2]
        nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        s_origin = -_dot(W, i0, nx, ny, nz)
        s_other = (W[f, 0] - W[i0, 0]) * nx + (W[f, 1] - W[i0, 1]) * ny + (W[f, 2] - W[i0, 2]) * nz
        if s_origin * s_other < 0.0 or abs(s_other) <= flat_volume:
            outside_any = True
            n, dd = _closest_triangle(W, i0, i1, i2, lam3, sub)
            if dd < best:
                best = dd
                best_n = n
                for j in range(n):
                    best_sub[j] = sub[j]
                    best_lam[j] = lam3[j]
    if not outside_any:
        return 4
    for j in range(best_n):
        sub[j] = best_sub[j]
    _keep(W, SA, SB, sub, best_n, tmp)
    for j in range(best_n):
        lam[j] = best_lam[j]
    return best_n


@njit(**JIT)
def gjk_scratch():
    """The arrays one GJK and EPA call work in (allocated once per narrowphase task and lent to its
    pairs: ``gjk`` and ``epa`` run without Numba's reference counting, ``math3d.NO_NRT``, so they
    allocate nothing). Rows: 0-3 the simplex W, SA, SB (4, 3) and its weights lam (4,); 4-8 the
    simplex reduction's sub (4,), best_sub (3,) int, lam3, best_lam (3,), tmp (4, 9); 9-11 EPA's
    polytope V, VA, VB (EPA_MAX_VERTS, 3); 12-16 its faces F (EPA_MAX_FACES, 3) int, N (.., 3),
    D (..,), alive (..,) bool and its horizon edges (3 EPA_MAX_FACES, 2) int; 17 GJK's simplex before
    its last step, rows W, SA, SB, lam (4, 10)."""
    return (np.empty((4, 3)), np.empty((4, 3)), np.empty((4, 3)), np.empty(4),
            np.empty(4, dtype=np.int64), np.empty(3, dtype=np.int64), np.empty(3), np.empty(3), np.empty((4, 9)),
            np.empty((EPA_MAX_VERTS, 3)), np.empty((EPA_MAX_VERTS, 3)), np.empty((EPA_MAX_VERTS, 3)),
            np.empty((EPA_MAX_FACES, 3), dtype=np.int64), np.empty((EPA_MAX_FACES, 3)), np.empty(EPA_MAX_FACES),
            np.zeros(EPA_MAX_FACES, dtype=np.bool_), np.empty((3 * EPA_MAX_FACES, 2), dtype=np.int64),
            np.empty((4, 10)))


@njit(**NO_NRT)
def gjk(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b, cutoff, scratch):
    """GJK distance between the cores of a and b.

    Args: the two shapes; ``cutoff`` (m): a distance beyond which the caller has no use for
    the exact one; ``scratch``: a ``gjk_scratch()`` (its W, SA, SB (4, 3) and lam (4,) hold the
    final simplex, W = SA - SB, points of A - B, and its weights: ``epa`` starts from them).

    Returns:
        (k, distance, pa (tuple), pb (tuple)): simplex size, distance of the cores
        (0 when they overlap: k = 4, or touch), closest points of the cores. When the
        cores are found farther apart than ``cutoff``: (0, a lower bound of the distance
        above ``cutoff``, origin, origin).
    """
    vx, vy, vz = pos_a[0] - pos_b[0], pos_a[1] - pos_b[1], pos_a[2] - pos_b[2]
    if vx * vx + vy * vy + vz * vz < 1e-24:
        vx, vy, vz = 1.0, 0.0, 0.0
    k = 0
    prev = np.inf
    W, SA, SB, lam = scratch[0], scratch[1], scratch[2], scratch[3]
    sub, best_sub, lam3, best_lam, tmp = scratch[4], scratch[5], scratch[6], scratch[7], scratch[8]
    before = scratch[17]
    for _ in range(GJK_ITERATIONS):
        sa = support(ta, pos_a, rot_a, params_a, verts_a, -vx, -vy, -vz)
        sb = support(tb, pos_b, rot_b, params_b, verts_b, vx, vy, vz)
        wx, wy, wz = sa[0] - sb[0], sa[1] - sb[1], sa[2] - sb[2]
        vv = vx * vx + vy * vy + vz * vz
        ww = wx * wx + wy * wy + wz * wz
        # every point p of A - B has p . v >= w . v, so the distance is at least w . v / |v|: past
        # the cutoff the pair is apart, whatever the exact distance (the speculative contacts' test
        # needs no more). PERF: GJK on a curved core converges linearly to GJK_REL; a cylinder peg
        # beside a ring's pieces took 6 us a pair to find no contact (benchmarks/decompose.py)
        vw = vx * wx + vy * wy + vz * wz
        if vw > 0.0 and vw * vw > cutoff * cutoff * vv:
            return 0, vw / math.sqrt(vv), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        # no progress: relative to |v|, and to the round-off of v . w (v is a weighted sum of
        # points of size |w|: its dot with w carries errors of about 1e-16 |w|^2)
        if k > 0 and vv - (vx * wx + vy * wy + vz * wz) <= GJK_REL * GJK_REL * vv + GJK_ROUND * ww:
            break
        dup = False
        for j in range(k):
            if (W[j, 0] - wx) ** 2 + (W[j, 1] - wy) ** 2 + (W[j, 2] - wz) ** 2 <= GJK_ROUND * ww:
                dup = True
        if dup:
            break
        # the simplex as it is, to go back to if the step below does not bring it closer
        k_before = k
        for j in range(k):
            for c in range(3):
                before[j, c] = W[j, c]
                before[j, 3 + c] = SA[j, c]
                before[j, 6 + c] = SB[j, c]
            before[j, 9] = lam[j]
        W[k, 0], W[k, 1], W[k, 2] = wx, wy, wz
        for c in range(3):
            SA[k, c] = sa[c]
            SB[k, c] = sb[c]
        k = _reduce_simplex(W, SA, SB, k + 1, lam, sub, lam3, best_sub, best_lam, tmp)
        if k == 4:
            break
        vx, vy, vz = 0.0, 0.0, 0.0
        for j in range(k):
            vx += lam[j] * W[j, 0]
            vy += lam[j] * W[j, 1]
            vz += lam[j] * W[j, 2]
        vv = vx * vx + vy * vy + vz * vz
        if vv >= prev and vv >= TOUCH * TOUCH:
            # Round-off: the new simplex is no closer than the last (its exact closest point
            # would be). Keep the last one. The new one is typically a thin triangle (two support
            # points 1e-6 m apart on a cone's rim, one far off) whose closest point is as far to
            # 1e-12 m but whose direction is off: returned, it gave a normal 1.5e-4 rad from the
            # best (a support gap of 8e-6 m for a box corner 5.5 cm from a cone's rim), where
            # the last simplex's is within 1e-12 m (tests/collision/test_closest_points.py)
            for j in range(k_before):
                for c in range(3):
                    W[j, c] = before[j, c]
                    SA[j, c] = before[j, 3 + c]
                    SB[j, c] = before[j, 6 + c]
                lam[j] = before[j, 9]
            k = k_before
            break
        if vv < TOUCH * TOUCH:
            break
        prev = vv
    pa0, pa1, pa2, pb0, pb1, pb2 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if k == 4:
        return 4, 0.0, (pa0, pa1, pa2), (pb0, pb1, pb2)
    for j in range(k):
        pa0 += lam[j] * SA[j, 0]
        pa1 += lam[j] * SA[j, 1]
        pa2 += lam[j] * SA[j, 2]
        pb0 += lam[j] * SB[j, 0]
        pb1 += lam[j] * SB[j, 1]
        pb2 += lam[j] * SB[j, 2]
    dist = math.sqrt((pa0 - pb0) ** 2 + (pa1 - pb1) ** 2 + (pa2 - pb2) ** 2)
    return k, dist, (pa0, pa1, pa2), (pb0, pb1, pb2)


@njit(**NO_NRT)
def _add_support(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b, dx, dy, dz, V, VA, VB, i):
    sa = support(ta, pos_a, rot_a, params_a, verts_a, dx, dy, dz)
    sb = support(tb, pos_b, rot_b, params_b, verts_b, -dx, -dy, -dz)
    for c in range(3):
        VA[i, c] = sa[c]
        VB[i, c] = sb[c]
        V[i, c] = sa[c] - sb[c]


@njit(**NO_NRT)
def _face(V, F, N, D, f, i0, i1, i2):
    """Set face f = (i0, i1, i2) with its unit normal and distance; a degenerate face gets D = inf."""
    F[f, 0], F[f, 1], F[f, 2] = i0, i1, i2
    ux, uy, uz = V[i1, 0] - V[i0, 0], V[i1, 1] - V[i0, 1], V[i1, 2] - V[i0, 2]
    vx, vy, vz = V[i2, 0] - V[i0, 0], V[i2, 1] - V[i0, 1], V[i2, 2] - V[i0, 2]
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    ln = math.sqrt(nx * nx + ny * ny + nz * nz)
    if ln < 1e-30:
        N[f, 0], N[f, 1], N[f, 2] = 0.0, 0.0, 0.0
        D[f] = np.inf
        return
    N[f, 0], N[f, 1], N[f, 2] = nx / ln, ny / ln, nz / ln
    D[f] = (N[f, 0] * V[i0, 0] + N[f, 1] * V[i0, 1] + N[f, 2] * V[i0, 2])


@njit(**NO_NRT)
def epa(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b, k, scratch):
    """Penetration of two overlapping (or touching) cores, from GJK's final simplex (k rows of W, SA,
    SB in ``scratch``, the ``gjk_scratch()`` that ``gjk`` has just used).

    Returns (ok, depth, normal (tuple), pa, pb): depth >= 0 along ``normal`` (from a
    to b: moving b by depth * normal separates the cores), and the deepest points
    of the cores. ok is False when A - B is flat (no tetrahedron found).

    Two smooth cores (an ellipsoid against an ellipsoid or a sphere's centre): a coarse EPA, then
    Newton on the support functions (``_smooth_depth``); EPA alone otherwise.
    """
    if _is_smooth(ta) and _is_smooth(tb):
        # COMPILE: the iteration counts as int64: as literals (12, 64) they compiled _epa twice
        ok, depth, nrm, pa, pb = _epa(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b, k,
                                      scratch, np.int64(SMOOTH_EPA_ITERATIONS))
        if ok:
            # the Hessians in rows of EPA's face normals, free once EPA is done (a rerun rewrites them)
            done, d2, n2, pa2, pb2 = _smooth_depth(ta, pos_a, rot_a, params_a, tb, pos_b, rot_b, params_b, nrm,
                                                   scratch[13][0:3], scratch[13][3:6])
            if done:
                return True, d2, n2, pa2, pb2
    return _epa(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b, k, scratch,
                np.int64(EPA_ITERATIONS))


@njit(**NO_NRT)
def _is_smooth(t):
    """A core whose support function is smooth with a Hessian in closed form: an ellipsoid, or a
    sphere's centre (the sphere's radius is added after)."""
    return t == SHAPE_ELLIPSOID or t == SHAPE_SPHERE


@njit(**NO_NRT)
def _smooth_support(t, pos, rot, params, nx, ny, nz, H):
    """(h, gx, gy, gz) of a smooth core along n = (nx, ny, nz): its support function h(n) = max p . n,
    its gradient (the support point) and, into H (3, 3), its Hessian. An ellipsoid of centre c and
    M = R diag(r^2) R^T: h = c . n + sqrt(n' M n), grad = c + M n / q, Hess = M / q - (M n)(M n)' / q^3,
    q = sqrt(n' M n); a point c: h = c . n, grad = c, Hess = 0."""
    if t == SHAPE_SPHERE:
        for i in range(3):
            for j in range(3):
                H[i, j] = 0.0
        return pos[0] * nx + pos[1] * ny + pos[2] * nz, pos[0], pos[1], pos[2]
    a2, b2, c2 = params[0] * params[0], params[1] * params[1], params[2] * params[2]
    for i in range(3):
        for j in range(3):
            H[i, j] = rot[i, 0] * a2 * rot[j, 0] + rot[i, 1] * b2 * rot[j, 1] + rot[i, 2] * c2 * rot[j, 2]
    mx = H[0, 0] * nx + H[0, 1] * ny + H[0, 2] * nz
    my = H[1, 0] * nx + H[1, 1] * ny + H[1, 2] * nz
    mz = H[2, 0] * nx + H[2, 1] * ny + H[2, 2] * nz
    q = math.sqrt(max(nx * mx + ny * my + nz * mz, 0.0))
    m = (mx, my, mz)
    for i in range(3):
        for j in range(3):
            H[i, j] = H[i, j] / q - m[i] * m[j] / (q * q * q)
    return (pos[0] * nx + pos[1] * ny + pos[2] * nz + q, pos[0] + mx / q, pos[1] + my / q, pos[2] + mz / q)


# EPA's iterations before Newton takes over, for two smooth cores (``epa``): on curved surfaces EPA
# converges slowly (its polytope grows a vertex an iteration), and these are enough for Newton's
# start. Newton's steps: it converges quadratically from there (3-4 steps measured).
SMOOTH_EPA_ITERATIONS = 12
NEWTON_ITERATIONS = 12
NEWTON_STEP = 1e-13  # rad: a step this small ends it


@njit(**NO_NRT)
def _smooth_depth(ta, pos_a, rot_a, params_a, tb, pos_b, rot_b, params_b, n0, HA, HB):
    """(done, depth, normal, pa, pb) of two overlapping smooth cores: the minimum over unit n of
    h_D(n) = h_A(n) + h_B(-n), the support function of A - B (the origin is inside it: the
    penetration is the distance from the origin to its boundary along the best n), by Newton on
    the sphere of directions from EPA's n0. Tangent plane gradient t . grad h, Hessian
    t' (Hess h) s - h t . s (the sphere's curvature: n . grad h = h, h being of degree 1).
    NOTE: EPA's inscribed polytope bounds the depth below and h_D at EPA's normal above; a
    Newton answer above that bound is another stationary point: not done (EPA is used).
    pa, pb: the support points (grad h_A(n), grad h_B(-n)), the cores' deepest points. HA, HB:
    (3, 3) scratch for the two Hessians."""
    nx, ny, nz = n0
    bound = 0.0  # h_D(n0), set on the first step: the depth is at most that
    done = False
    for step in range(NEWTON_ITERATIONS):
        ha, gax, gay, gaz = _smooth_support(ta, pos_a, rot_a, params_a, nx, ny, nz, HA)
        hb, gbx, gby, gbz = _smooth_support(tb, pos_b, rot_b, params_b, -nx, -ny, -nz, HB)
        h = ha + hb
        if step == 0:
            bound = h
        gx, gy, gz = gax - gbx, gay - gby, gaz - gbz
        t1x, t1y, t1z = unit_tangent(nx, ny, nz)  # a tangent basis at n: t1, then n x t1
        t2x, t2y, t2z = ny * t1z - nz * t1y, nz * t1x - nx * t1z, nx * t1y - ny * t1x
        t1 = (t1x, t1y, t1z)
        t2 = (t2x, t2y, t2z)
        a11 = -h
        a12 = 0.0
        a22 = -h
        for i in range(3):
            for j in range(3):
                Hij = HA[i, j] + HB[i, j]
                a11 += t1[i] * Hij * t1[j]
                a12 += t1[i] * Hij * t2[j]
                a22 += t2[i] * Hij * t2[j]
        det = a11 * a22 - a12 * a12
        if not (a11 > 0.0 and det > 0.0):
            return False, 0.0, (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        b1 = -(t1x * gx + t1y * gy + t1z * gz)
        b2 = -(t2x * gx + t2y * gy + t2z * gz)
        d1 = (b1 * a22 - b2 * a12) / det
        d2 = (a11 * b2 - a12 * b1) / det
        nx, ny, nz = nx + d1 * t1x + d2 * t2x, ny + d1 * t1y + d2 * t2y, nz + d1 * t1z + d2 * t2z
        ln = math.sqrt(nx * nx + ny * ny + nz * nz)
        nx, ny, nz = nx / ln, ny / ln, nz / ln
        if d1 * d1 + d2 * d2 < NEWTON_STEP * NEWTON_STEP:
            done = True
            break
    if not done:
        return False, 0.0, (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    ha, gax, gay, gaz = _smooth_support(ta, pos_a, rot_a, params_a, nx, ny, nz, HA)
    hb, gbx, gby, gbz = _smooth_support(tb, pos_b, rot_b, params_b, -nx, -ny, -nz, HB)
    depth = ha + hb
    if depth > bound + 1e-12 * (1.0 + abs(bound)) or depth < 0.0:
        return False, 0.0, (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    return True, depth, (nx, ny, nz), (gax, gay, gaz), (gbx, gby, gbz)


@njit(**NO_NRT)
def _epa(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b, k, scratch, iterations):
    """``epa``'s polytope expansion, ``iterations`` at most."""
    W, SA, SB = scratch[0], scratch[1], scratch[2]
    V, VA, VB = scratch[9], scratch[10], scratch[11]
    for i in range(k):
        for c in range(3):
            V[i, c] = W[i, c]
            VA[i, c] = SA[i, c]
            VB[i, c] = SB[i, c]
    # grow the simplex to a tetrahedron (the origin stays inside or on it)
    scale = 1e-10
    for i in range(k):
        scale = max(scale, abs(V[i, 0]) + abs(V[i, 1]) + abs(V[i, 2]))
    eps = 1e-9 * scale
    if k == 1:
        for j in range(6):
            s = 1.0 if j < 3 else -1.0
            _add_support(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b,
                         s if j % 3 == 0 else 0.0, s if j % 3 == 1 else 0.0, s if j % 3 == 2 else 0.0, V, VA, VB, np.int64(1))
            if abs(V[1, 0] - V[0, 0]) + abs(V[1, 1] - V[0, 1]) + abs(V[1, 2] - V[0, 2]) > eps:
                k = 2
                break
        if k < 2:
            return False, 0.0, (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    if k == 2:
        ex, ey, ez = V[1, 0] - V[0, 0], V[1, 1] - V[0, 1], V[1, 2] - V[0, 2]
        # a direction normal to e, then turned about e in 60 degree steps
        if abs(ex) <= abs(ey) and abs(ex) <= abs(ez):
            px, py, pz = 0.0, ez, -ey
        elif abs(ey) <= abs(ez):
            px, py, pz = -ez, 0.0, ex
        else:
            px, py, pz = ey, -ex, 0.0
        le = math.sqrt(ex * ex + ey * ey + ez * ez)
        qx, qy, qz = (ey * pz - ez * py) / le, (ez * px - ex * pz) / le, (ex * py - ey * px) / le
        for j in range(6):
            c, s = math.cos(j * math.pi / 3.0), math.sin(j * math.pi / 3.0)
            _add_support(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b,
                         c * px + s * qx, c * py + s * qy, c * pz + s * qz, V, VA, VB, np.int64(2))
            fx, fy, fz = V[2, 0] - V[0, 0], V[2, 1] - V[0, 1], V[2, 2] - V[0, 2]
            cx, cy, cz = ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx
            if math.sqrt(cx * cx + cy * cy + cz * cz) > eps * le:
                k = 3
                break
        if k < 3:
            return False, 0.0, (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    if k == 3:
        ux, uy, uz = V[1, 0] - V[0, 0], V[1, 1] - V[0, 1], V[1, 2] - V[0, 2]
        vx, vy, vz = V[2, 0] - V[0, 0], V[2, 1] - V[0, 1], V[2, 2] - V[0, 2]
        nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        ln = math.sqrt(nx * nx + ny * ny + nz * nz)
        for j in range(2):
            s = 1.0 if j == 0 else -1.0
            _add_support(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b,
                         s * nx, s * ny, s * nz, V, VA, VB, np.int64(3))
            h = ((V[3, 0] - V[0, 0]) * nx + (V[3, 1] - V[0, 1]) * ny + (V[3, 2] - V[0, 2]) * nz) / ln
            if abs(h) > eps:
                k = 4
                break
        if k < 4:
            return False, 0.0, (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    # faces f < n_faces only are read, each set when made: no clearing needed
    F, N, D, alive = scratch[12], scratch[13], scratch[14], scratch[15]
    # the four faces, each wound so that its normal points away from the fourth vertex
    for f in range(4):
        i0, i1, i2 = (f + 1) % 4, (f + 2) % 4, (f + 3) % 4
        _face(V, F, N, D, f, i0, i1, i2)
        if N[f, 0] * (V[f, 0] - V[i0, 0]) + N[f, 1] * (V[f, 1] - V[i0, 1]) + N[f, 2] * (V[f, 2] - V[i0, 2]) > 0.0:
            _face(V, F, N, D, f, i0, i2, i1)
        alive[f] = True
    n_faces = np.int64(4)
    n_verts = np.int64(4)
    for i in range(4):
        scale = max(scale, abs(V[i, 0]) + abs(V[i, 1]) + abs(V[i, 2]))
    visible = 1e-10 * scale
    edges = scratch[16]
    best = 0
    for _ in range(iterations):
        best = -1
        for f in range(n_faces):
            if alive[f] and (best < 0 or D[f] < D[best]):
                best = f
        if D[best] == np.inf:
            break
        nx, ny, nz = N[best, 0], N[best, 1], N[best, 2]
        if n_verts == EPA_MAX_VERTS:
            break
        _add_support(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b, nx, ny, nz,
                     V, VA, VB, n_verts)
        w = n_verts
        if nx * V[w, 0] + ny * V[w, 1] + nz * V[w, 2] - D[best] <= EPA_TOLERANCE * (1.0 + abs(D[best])):
            break
        n_verts += 1
        # remove the faces that see w; the boundary of the removed region is the horizon
        n_edges = 0
        for f in range(n_faces):
            if not alive[f]:
                continue
            i0 = F[f, 0]
            # NOTE: a tolerance, so that w coplanar with a face (a cylinder cap, a box face: many support
            # points in one plane) does not see it by round-off: that made faces fold over the origin.
            if f == best or N[f, 0] * (V[w, 0] - V[i0, 0]) + N[f, 1] * (V[w, 1] - V[i0, 1]) \
                    + N[f, 2] * (V[w, 2] - V[i0, 2]) > visible:
                alive[f] = False
                for e in range(3):
                    a = F[f, e]
                    b = F[f, (e + 1) % 3]
                    found = -1
                    for j in range(n_edges):
                        if edges[j, 0] == b and edges[j, 1] == a:
                            found = j
                            break
                    if found >= 0:
                        n_edges -= 1
                        edges[found, 0] = edges[n_edges, 0]
                        edges[found, 1] = edges[n_edges, 1]
                    else:
                        edges[n_edges, 0] = a
                        edges[n_edges, 1] = b
                        n_edges += 1
        if n_faces + n_edges > EPA_MAX_FACES:
            break
        for j in range(n_edges):
            _face(V, F, N, D, n_faces, edges[j, 0], edges[j, 1], w)
            alive[n_faces] = True
            n_faces += 1
    if best < 0:
        return False, 0.0, (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    # barycentric weights of the origin's projection D n on the closest face
    i0, i1, i2 = F[best, 0], F[best, 1], F[best, 2]
    nx, ny, nz = N[best, 0], N[best, 1], N[best, 2]
    depth = max(D[best], 0.0)
    px, py, pz = depth * nx, depth * ny, depth * nz
    l0, l1, l2 = _barycentric(V, i0, i1, i2, px, py, pz)
    pa = (l0 * VA[i0, 0] + l1 * VA[i1, 0] + l2 * VA[i2, 0], l0 * VA[i0, 1] + l1 * VA[i1, 1] + l2 * VA[i2, 1],
          l0 * VA[i0, 2] + l1 * VA[i1, 2] + l2 * VA[i2, 2])
    pb = (l0 * VB[i0, 0] + l1 * VB[i1, 0] + l2 * VB[i2, 0], l0 * VB[i0, 1] + l1 * VB[i1, 1] + l2 * VB[i2, 1],
          l0 * VB[i0, 2] + l1 * VB[i1, 2] + l2 * VB[i2, 2])
    return True, depth, (nx, ny, nz), pa, pb


@njit(**NO_NRT)
def _barycentric(V, i0, i1, i2, px, py, pz):
    """Weights of p in triangle V[i0] V[i1] V[i2] (Ericson §3.4), clamped to the triangle's centroid if degenerate."""
    v0x, v0y, v0z = V[i1, 0] - V[i0, 0], V[i1, 1] - V[i0, 1], V[i1, 2] - V[i0, 2]
    v1x, v1y, v1z = V[i2, 0] - V[i0, 0], V[i2, 1] - V[i0, 1], V[i2, 2] - V[i0, 2]
    v2x, v2y, v2z = px - V[i0, 0], py - V[i0, 1], pz - V[i0, 2]
    d00 = v0x * v0x + v0y * v0y + v0z * v0z
    d01 = v0x * v1x + v0y * v1y + v0z * v1z
    d11 = v1x * v1x + v1y * v1y + v1z * v1z
    d20 = v2x * v0x + v2y * v0y + v2z * v0z
    d21 = v2x * v1x + v2y * v1y + v2z * v1z
    den = d00 * d11 - d01 * d01
    if den <= 1e-300:
        return 1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    return 1.0 - v - w, v, w
