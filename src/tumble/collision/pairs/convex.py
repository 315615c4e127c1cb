"""Convex family: cylinder, cone, ellipsoid and convex hull against every convex shape (contract in ``pairs/__init__``).

Any two convex shapes (sphere, capsule, cylinder, cone, box, ellipsoid, convex hull, mesh
triangle): GJK on their cores gives the distance and the normal when they are apart,
EPA when the cores overlap (``pairs/gjk``). The manifold then comes from the two
*supporting faces* (the feature of each shape most facing the other along the
normal: a hull or box face, a cylinder cap or side line, a cone base or side line, a
capsule's segment, a point): the face more aligned with the normal is the reference,
the other one is clipped against its side planes (Sutherland-Hodgman), and each
clipped point is measured along the normal to the reference plane (Jolt's
``ManifoldBetweenTwoFaces``; Box3D/Bullet clip the same way). Up to 4 points are kept
(``box._reduce_manifold``). The GJK/EPA point itself is added when it is deeper than
every clipped point, so a contact is never shallower than the true one.

NOTE: a cylinder cap and a cone base are regular octagons of rim points when they
are the reference or incident face: a manifold point on the cap outline lies on the
real rim (its depth is exact) but the clipped patch is the inscribed octagon, at most
r (1 - cos 22.5 deg) = 7.6 % of r inside the circle. GJK/EPA use the exact round shapes.

Feature ids (below 2**21): bits 0-4 the point's slot (the incident face vertex nearest
to the point; a taken slot moves to the next free one), bits 5-11 the incident face, 12-18 the
reference face, bit 19 set when b holds the reference face; the GJK/EPA point alone is
``1 << 20`` (+ slot 31 when added to a clipped manifold).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...math3d import JIT, NO_NRT
from ...shapes import (
    SHAPE_BOX,
    SHAPE_CAPSULE,
    SHAPE_CONE,
    SHAPE_CONVEX,
    SHAPE_CYLINDER,
    SHAPE_ELLIPSOID,
    SHAPE_SPHERE,
)
from ..constants import MAX_MANIFOLD_POINTS, MESH_POINTS
from .box_box import add_widest_triangle_points
from .gjk import SHAPE_TRIANGLE, core_radius, epa, gjk, gjk_scratch, support

# Vertices of a cylinder cap or cone base used as a polygon (a regular polygon of rim points).
CAP_SIDES = 8
# Largest face polygon used for clipping (hull faces with more vertices are thinned evenly).
MAX_FACE = 32
# A capsule's segment, a cylinder's or cone's side line is a supporting face when the
# direction is this close to its normal: |cos| of the axis below 0.02 (1.1 degrees).
SIDE_TOLERANCE = 0.02
# b's face becomes the reference only when it is more aligned with the normal than a's by this.
REFERENCE_TOLERANCE = 1e-3
# A reference face more oblique than this to the normal gives no clipped points (the GJK/EPA point only).
MIN_ALIGNMENT = 0.2
# The GJK/EPA point joins a clipped manifold when it is this much deeper than every clipped point (m):
# an oblique reference face measures its clipped points a little shallower than the true closest
# points (up to ~1e-4 m seen in the fuzz tests); resting flat, the two agree to ~1e-12 m.
DEEPEST_MARGIN = 1e-6

FEATURE_SINGLE = 1 << 20
SLOT_DEEPEST = 31


# Rows of the clipping scratch: two faces' points and the clipped polygon (which grows by one
# point per side plane), its copy, their ids, then the measured candidates (one more: the GJK/EPA point).
CLIP_ROWS = 2 * MAX_FACE + 8


@njit(**JIT)
def convex_scratch():
    """The arrays of one convex pair routine (allocated once per narrowphase task and lent to its
    pairs; the routines run without reference counting, ``math3d.NO_NRT``): 0 ``gjk_scratch()``;
    1, 2 the supporting faces (MAX_FACE, 3); 3, 4 the clipped polygon and its copy (CLIP_ROWS, 3);
    5, 6 their ids (CLIP_ROWS,) int; 7-9 the candidate points (CLIP_ROWS + 1, 3), separations and
    ids; 10 the kept rows (CLIP_ROWS + 2,) int; 11 the mesh routine's (``mesh.collide_convex_mesh``):
    its box lo, hi (3,), gathered points, normals (MESH_POINTS, 3), separations and features, one
    triangle's normal (3,), points (4, 3), separations and features, the sphere-triangle simplex
    (3, 3), its weights (3,) and rows (4,) int, the kept rows (MESH_POINTS,) int, a two-sided
    triangle turned to face the shape (3, 3)."""
    return (gjk_scratch(), np.empty((MAX_FACE, 3)), np.empty((MAX_FACE, 3)), np.empty((CLIP_ROWS, 3)),
            np.empty((CLIP_ROWS, 3)), np.empty(CLIP_ROWS, dtype=np.int64), np.empty(CLIP_ROWS, dtype=np.int64),
            np.empty((CLIP_ROWS + 1, 3)), np.empty(CLIP_ROWS + 1), np.empty(CLIP_ROWS + 1, dtype=np.int64),
            np.empty(CLIP_ROWS + 2, dtype=np.int64),
            (np.empty(3), np.empty(3), np.empty((MESH_POINTS, 3)), np.empty((MESH_POINTS, 3)), np.empty(MESH_POINTS),
             np.empty(MESH_POINTS, dtype=np.int64), np.empty(3), np.empty((MAX_MANIFOLD_POINTS, 3)),
             np.empty(MAX_MANIFOLD_POINTS), np.empty(MAX_MANIFOLD_POINTS, dtype=np.int64), np.empty((3, 3)),
             np.empty(3), np.empty(4, dtype=np.int64), np.empty(MESH_POINTS, dtype=np.int64), np.empty((3, 3))))


@njit(**NO_NRT)
def reduce_points(pts, seps, n, nx, ny, nz, keep):
    """Indices (into keep[:4]) of at most 4 of n points: the deepest (ties: the outermost), the farthest from it,
    then the two of
    largest positive and negative area about the normal (Gregorius 2015, as ``box._reduce_manifold``).

    Unlike the box version, areas below 1e-3 of the
    squared span are ignored, so collinear points (a capsule on a tessellated floor) give 2, not 4.
    """
    i1 = np.int64(0)  # np.int64: a literal would compile the callee again (box._reduce_manifold)
    for k in range(1, n):
        if seps[k] < seps[i1]:
            i1 = k
    # among points as deep as the deepest (to 1e-9 m: resting flat), the one farthest from the centroid,
    # so that a flat box on a tessellated floor starts from a corner, not from an inner triangle's point
    cx, cy, cz = 0.0, 0.0, 0.0
    for k in range(n):
        cx += pts[k, 0] / n
        cy += pts[k, 1] / n
        cz += pts[k, 2] / n
    far = -1.0
    deepest = seps[i1]
    for k in range(n):
        if seps[k] <= deepest + 1e-9:
            d = (pts[k, 0] - cx) ** 2 + (pts[k, 1] - cy) ** 2 + (pts[k, 2] - cz) ** 2
            if d > far * (1.0 + 1e-12):
                far, i1 = d, k
    keep[0] = i1
    i2 = np.int64(-1)
    best = 1e-18
    for k in range(n):
        d = (pts[k, 0] - pts[i1, 0]) ** 2 + (pts[k, 1] - pts[i1, 1]) ** 2 + (pts[k, 2] - pts[i1, 2]) ** 2
        if d > best:
            best, i2 = d, k
    if i2 < 0:
        return 1
    keep[1] = i2
    return add_widest_triangle_points(pts, n, i1, i2, nx, ny, nz, 1e-3 * best, keep)


# inline: it returns views, which carry a reference only when the caller counts them (NO_NRT's rule)
@njit(**JIT, inline="always")
def shape_arrays(t, s, shape_data, hull_vertex):
    """(verts, face_first, face_count) of shape row s: a hull's vertex rows, or an empty slice."""
    if t == SHAPE_CONVEX:
        v0 = shape_data[s, 0]
        return hull_vertex[v0:v0 + shape_data[s, 1]], shape_data[s, 2], shape_data[s, 3]
    return hull_vertex[0:0], 0, 0


@njit(**NO_NRT)
def _world(pos, rot, x, y, z, poly, k):
    for i in range(3):
        poly[k, i] = pos[i] + rot[i, 0] * x + rot[i, 1] * y + rot[i, 2] * z


@njit(**NO_NRT)
def supporting_face(t, pos, rot, params, verts, f0, nf, hull_face_first, hull_face_count, hull_face_vertex,
                    hull_plane, hull_vertex, dx, dy, dz,
                    # outputs
                    poly):
    """The feature of the core most facing unit direction d (world): writes its points (world) into ``poly``.

    Returns (count, face id, face normal (tuple, world, outward), alignment = normal . d).
    A count of 1 or 2 (point, segment) has no normal (alignment -1).
    """
    lx = rot[0, 0] * dx + rot[1, 0] * dy + rot[2, 0] * dz
    ly = rot[0, 1] * dx + rot[1, 1] * dy + rot[2, 1] * dz
    lz = rot[0, 2] * dx + rot[1, 2] * dy + rot[2, 2] * dz
    none = (0.0, 0.0, 0.0)
    if t == SHAPE_CAPSULE:
        h = params[1]
        if abs(lz) < SIDE_TOLERANCE:
            _world(pos, rot, 0.0, 0.0, -h, poly, np.int64(0))
            _world(pos, rot, 0.0, 0.0, h, poly, np.int64(1))
            return 2, 2, none, -1.0
        _world(pos, rot, 0.0, 0.0, h if lz > 0.0 else -h, poly, np.int64(0))
        return 1, 1 if lz > 0.0 else 0, none, -1.0
    if t == SHAPE_BOX:
        k = 0
        for j in range(1, 3):
            if abs((lx, ly, lz)[j]) > abs((lx, ly, lz)[k]):
                k = j
        side = 1.0 if (lx, ly, lz)[k] >= 0.0 else -1.0
        j1 = (k + 1) % 3
        j2 = (k + 2) % 3
        for v in range(4):
            s1 = 1.0 if v == 0 or v == 3 else -1.0
            s2 = 1.0 if v < 2 else -1.0
            ck = side * params[k]
            c1 = s1 * params[j1]
            c2 = s2 * side * params[j2]  # counter-clockwise seen from outside on both sides
            # the corner's local coordinates: ck on axis k, c1 on j1, c2 on j2
            _world(pos, rot, ck if k == 0 else (c1 if j1 == 0 else c2), ck if k == 1 else (c1 if j1 == 1 else c2),
                   ck if k == 2 else (c1 if j1 == 2 else c2), poly, v)
        n = (side * rot[0, k], side * rot[1, k], side * rot[2, k])
        return 4, 2 * k + (1 if side > 0.0 else 0), n, n[0] * dx + n[1] * dy + n[2] * dz
    if t == SHAPE_CYLINDER or t == SHAPE_CONE:
        r = params[0]
        rr = math.sqrt(lx * lx + ly * ly)
        cx, cy = (lx / rr, ly / rr) if rr > 1e-12 else (1.0, 0.0)
        if t == SHAPE_CYLINDER:
            cap_align = abs(lz)
            side_align = rr
            zc = params[1] if lz >= 0.0 else -params[1]
            cap_id = 1 if lz >= 0.0 else 0
            cap_sign = 1.0 if lz >= 0.0 else -1.0
        else:
            L = math.sqrt(params[1] * params[1] + r * r)
            cap_align = -lz
            side_align = (params[1] * rr + r * lz) / L
            zc = 0.0
            cap_id = 0
            cap_sign = -1.0
        if cap_align >= side_align:
            for v in range(CAP_SIDES):
                # counter-clockwise about the cap's outward normal cap_sign * z
                a = cap_sign * 2.0 * math.pi * v / CAP_SIDES
                _world(pos, rot, r * math.cos(a), r * math.sin(a), zc, poly, v)
            n = (cap_sign * rot[0, 2], cap_sign * rot[1, 2], cap_sign * rot[2, 2])
            return CAP_SIDES, cap_id, n, cap_align
        if side_align > 1.0 - 0.5 * SIDE_TOLERANCE * SIDE_TOLERANCE:
            if t == SHAPE_CYLINDER:
                _world(pos, rot, r * cx, r * cy, -params[1], poly, np.int64(0))
                _world(pos, rot, r * cx, r * cy, params[1], poly, np.int64(1))
            else:
                _world(pos, rot, r * cx, r * cy, 0.0, poly, np.int64(0))
                _world(pos, rot, 0.0, 0.0, params[1], poly, np.int64(1))
            return 2, 2, none, -1.0
        p = support(t, pos, rot, params, verts, dx, dy, dz)
        for i in range(3):
            poly[0, i] = p[i]
        return 1, 3, none, -1.0
    if t == SHAPE_CONVEX:
        best = -np.inf
        fb = f0
        for f in range(f0, f0 + nf):
            c = hull_plane[f, 0] * lx + hull_plane[f, 1] * ly + hull_plane[f, 2] * lz
            if c > best:
                best, fb = c, f
        count = hull_face_count[fb]
        m = min(count, MAX_FACE)
        for v in range(m):
            row = hull_face_vertex[hull_face_first[fb] + (v * count) // m]
            _world(pos, rot, hull_vertex[row, 0], hull_vertex[row, 1], hull_vertex[row, 2], poly, v)
        p = hull_plane[fb]
        n = (rot[0, 0] * p[0] + rot[0, 1] * p[1] + rot[0, 2] * p[2], rot[1, 0] * p[0] + rot[1, 1] * p[1] + rot[1, 2] * p[2],
             rot[2, 0] * p[0] + rot[2, 1] * p[1] + rot[2, 2] * p[2])
        return m, (fb - f0) & 127, n, best
    if t == SHAPE_TRIANGLE:
        for v in range(3):
            _world(pos, rot, verts[v, 0], verts[v, 1], verts[v, 2], poly, v)
        ux, uy, uz = poly[1, 0] - poly[0, 0], poly[1, 1] - poly[0, 1], poly[1, 2] - poly[0, 2]
        wx, wy, wz = poly[2, 0] - poly[0, 0], poly[2, 1] - poly[0, 1], poly[2, 2] - poly[0, 2]
        nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
        ln = math.sqrt(nx * nx + ny * ny + nz * nz)
        nx, ny, nz = nx / ln, ny / ln, nz / ln
        c = nx * dx + ny * dy + nz * dz
        if c < 0.0:
            # the back side: reverse the winding so that it stays counter-clockwise about the normal
            for i in range(3):
                poly[1, i], poly[2, i] = poly[2, i], poly[1, i]
            return 3, 1, (-nx, -ny, -nz), -c
        return 3, 0, (nx, ny, nz), c
    if t == SHAPE_ELLIPSOID:  # smooth everywhere: its one support point
        p = support(t, pos, rot, params, verts, dx, dy, dz)
        for i in range(3):
            poly[0, i] = p[i]
        return 1, 0, none, -1.0
    # sphere
    for i in range(3):
        poly[0, i] = pos[i]
    return 1, 0, none, -1.0


@njit(**NO_NRT)
def _clip(poly_in, id_in, n_in, sx, sy, sz, off, plane_id, poly_out, id_out):
    """Sutherland-Hodgman against s . p <= off, carrying point ids (crossings get 8 + or 16 + plane_id)."""
    if n_in == 0:
        return 0
    n_out = 0
    prev = n_in - 1
    d_prev = sx * poly_in[prev, 0] + sy * poly_in[prev, 1] + sz * poly_in[prev, 2] - off
    for cur in range(n_in):
        d_cur = sx * poly_in[cur, 0] + sy * poly_in[cur, 1] + sz * poly_in[cur, 2] - off
        if (d_prev <= 0.0) != (d_cur <= 0.0):
            s = d_prev / (d_prev - d_cur)
            for i in range(3):
                poly_out[n_out, i] = poly_in[prev, i] + s * (poly_in[cur, i] - poly_in[prev, i])
            id_out[n_out] = (8 if d_cur <= 0.0 else 16) + (plane_id & 7)
            n_out += 1
        if d_cur <= 0.0:
            for i in range(3):
                poly_out[n_out, i] = poly_in[cur, i]
            id_out[n_out] = id_in[cur]
            n_out += 1
        prev = cur
        d_prev = d_cur
    return n_out


@njit(**NO_NRT)
def _clip_to_face(ref, m, rnx, rny, rnz, inc, k, pts, ids, tmp, tmp_ids):
    """Clip the incident polygon or segment (k points) to the prism along direction rn over the reference polygon (m points).

    Writes the result into pts / ids; returns its size.
    """
    cx, cy, cz = 0.0, 0.0, 0.0
    for v in range(m):
        cx += ref[v, 0] / m
        cy += ref[v, 1] / m
        cz += ref[v, 2] / m
    if k == 2:
        t0, t1 = 0.0, 1.0
        id0, id1 = 0, 1
    else:
        for v in range(k):
            for i in range(3):
                pts[v, i] = inc[v, i]
            ids[v] = v & 7
    n = k
    for j in range(m):
        jn = (j + 1) % m
        ex, ey, ez = ref[jn, 0] - ref[j, 0], ref[jn, 1] - ref[j, 1], ref[jn, 2] - ref[j, 2]
        sx, sy, sz = ey * rnz - ez * rny, ez * rnx - ex * rnz, ex * rny - ey * rnx
        if sx * (cx - ref[j, 0]) + sy * (cy - ref[j, 1]) + sz * (cz - ref[j, 2]) > 0.0:
            sx, sy, sz = -sx, -sy, -sz
        off = sx * ref[j, 0] + sy * ref[j, 1] + sz * ref[j, 2]
        if k == 2:
            # Liang-Barsky on the segment inc[0] inc[1]
            d0 = sx * inc[0, 0] + sy * inc[0, 1] + sz * inc[0, 2] - off
            d1 = sx * inc[1, 0] + sy * inc[1, 1] + sz * inc[1, 2] - off
            if d0 > 0.0 and d1 > 0.0:
                return 0
            if d0 > 0.0:
                t = d0 / (d0 - d1)
                if t > t0:
                    t0, id0 = t, 8 + (j & 7)
            elif d1 > 0.0:
                t = d0 / (d0 - d1)
                if t < t1:
                    t1, id1 = t, 16 + (j & 7)
            if t0 > t1:
                return 0
        else:
            n = _clip(pts, ids, n, sx, sy, sz, off, j, tmp, tmp_ids)
            for v in range(n):
                for i in range(3):
                    pts[v, i] = tmp[v, i]
                ids[v] = tmp_ids[v]
    if k == 2:
        n = 0
        for e in range(2):
            if e == 1 and t1 - t0 < 1e-9:
                break
            t = t0 if e == 0 else t1
            for i in range(3):
                pts[n, i] = inc[0, i] + t * (inc[1, i] - inc[0, i])
            ids[n] = id0 if e == 0 else id1
            n += 1
    return n


@njit(**JIT, inline="always")
def apart_on_centre_line(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b, cutoff):
    """Whether GJK's first step already finds the cores of a and b farther apart than ``cutoff`` (m):
    the supports along the line between the shapes' centres, w = s_a(-v) - s_b(v) with v = pos_a -
    pos_b, bound the distance below by w . v / |v| (``gjk``'s own first test, the same arithmetic,
    so the same answer). PERF: most candidate pairs of a pile of hulls end here (80 % of the convex
    pile's), and the routine's call chain with its scratch arrays cost three times this test."""
    vx, vy, vz = pos_a[0] - pos_b[0], pos_a[1] - pos_b[1], pos_a[2] - pos_b[2]
    if vx * vx + vy * vy + vz * vz < 1e-24:
        vx, vy, vz = 1.0, 0.0, 0.0
    sa = support(ta, pos_a, rot_a, params_a, verts_a, -vx, -vy, -vz)
    sb = support(tb, pos_b, rot_b, params_b, verts_b, vx, vy, vz)
    wx, wy, wz = sa[0] - sb[0], sa[1] - sb[1], sa[2] - sb[2]
    vv = vx * vx + vy * vy + vz * vz
    vw = vx * wx + vy * wy + vz * wz
    return vw > 0.0 and vw * vw > cutoff * cutoff * vv


@njit(**NO_NRT)
def convex_contact(ta, pos_a, rot_a, params_a, verts_a, fa0, fna, tb, pos_b, rot_b, params_b, verts_b, fb0, fnb,
                   hull_face_first, hull_face_count, hull_face_vertex, hull_plane, hull_vertex, speculative,
                   # outputs
                   normal, point, separation, feature,
                   # scratch
                   scratch):
    """Contact manifold of two convex shapes (see the module docstring); returns the point count.
    ``scratch``: a ``convex_scratch()``."""
    ra = core_radius(ta, params_a)
    rb = core_radius(tb, params_b)
    k, dist, pa, pb = gjk(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b,
                          speculative + ra + rb, scratch[0])
    if dist > TOUCH_GAP:
        sep0 = dist - ra - rb
        if sep0 >= speculative:
            return 0
        nx, ny, nz = (pb[0] - pa[0]) / dist, (pb[1] - pa[1]) / dist, (pb[2] - pa[2]) / dist
        core_sep = dist
    else:
        ok, depth, nrm, pa, pb = epa(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b,
                                     k, scratch[0])
        if not ok:
            # A - B is flat (the cores touch without volume): the centre line is the normal
            gx, gy, gz = pos_b[0] - pos_a[0], pos_b[1] - pos_a[1], pos_b[2] - pos_a[2]
            g = math.sqrt(gx * gx + gy * gy + gz * gz)
            nrm = (gx / g, gy / g, gz / g) if g > 0.0 else (0.0, 0.0, 1.0)
            depth = 0.0
        nx, ny, nz = nrm
        core_sep = -depth
        sep0 = core_sep - ra - rb
    return face_manifold(ta, pos_a, rot_a, params_a, verts_a, fa0, fna, tb, pos_b, rot_b, params_b, verts_b, fb0, fnb,
                         hull_face_first, hull_face_count, hull_face_vertex, hull_plane, hull_vertex, speculative,
                         nx, ny, nz, sep0, core_sep, pa, pb, normal, point, separation, feature, scratch)


@njit(**NO_NRT)
def _segment_reference(ref, nx, ny, nz):
    """Two segments: turn the reference segment ref[0] ref[1] into a thin rectangle (4 rows of ref) in the
    plane through it normal to n's part across it, whose side planes are the segment's end planes.

    Returns (ok, plane normal rn, alignment |rn . n|).
    """
    ex, ey, ez = ref[1, 0] - ref[0, 0], ref[1, 1] - ref[0, 1], ref[1, 2] - ref[0, 2]
    cx, cy, cz = ey * nz - ez * ny, ez * nx - ex * nz, ex * ny - ey * nx
    rx, ry, rz = cy * ez - cz * ey, cz * ex - cx * ez, cx * ey - cy * ex
    lr = math.sqrt(rx * rx + ry * ry + rz * rz)
    if lr <= 1e-12:
        return False, (0.0, 0.0, 1.0), 0.0
    rn = (rx / lr, ry / lr, rz / lr)
    # the rectangle spans e and a long vector across (in the plane): only the two end planes bind
    ux, uy, uz = ey * rn[2] - ez * rn[1], ez * rn[0] - ex * rn[2], ex * rn[1] - ey * rn[0]
    lu = math.sqrt(ux * ux + uy * uy + uz * uz)
    big = 1e6 * (1.0 + math.sqrt(ex * ex + ey * ey + ez * ez))
    for i in range(3):
        u = (ux, uy, uz)[i] / lu * big
        e0 = ref[0, i]
        e1 = ref[1, i]
        ref[0, i] = e0 - u
        ref[1, i] = e1 - u
        ref[2, i] = e1 + u
        ref[3, i] = e0 + u
    return True, rn, abs(rn[0] * nx + rn[1] * ny + rn[2] * nz)


@njit(**NO_NRT)
def _measure_clipped(pts, n, ref, rn, inc, kin, ref_is_b, nx, ny, nz, ra, rb, core_sep, speculative,
                     # outputs
                     cand, seps, cid):
    """Clipped incident points -> contact points (midway), separations along n and slot ids; returns the count."""
    dn = nx * rn[0] + ny * rn[1] + nz * rn[2]
    count = np.int64(0)  # not a literal: one compile of reduce_points
    for v in range(n):
        t = ((pts[v, 0] - ref[0, 0]) * rn[0] + (pts[v, 1] - ref[0, 1]) * rn[1] + (pts[v, 2] - ref[0, 2]) * rn[2]) / dn
        s = -t if ref_is_b else t
        if s - ra - rb >= speculative:
            continue
        # deeper than the overlap along n (GJK/EPA's, exact) only through a tilted reference
        # plane (its point q outside the reference face): no deeper than the overlap
        s = max(s, core_sep)
        # inc point p, its partner on the reference plane q = p - t n; then the radii
        for i in range(3):
            ni = (nx, ny, nz)[i]
            p_i = pts[v, i]
            q_i = p_i - t * ni
            a_i = (p_i if ref_is_b else q_i) + ra * ni
            b_i = (q_i if ref_is_b else p_i) - rb * ni
            cand[count, i] = 0.5 * (a_i + b_i)
        seps[count] = s - ra - rb
        # the point's name: the incident vertex nearest to it, so that a corner and the clipped
        # point next to it (a face on a face of the same size) keep one id (box_box.py's quadrants)
        near = 0
        dmin = np.inf
        for u in range(kin):
            dd = (inc[u, 0] - pts[v, 0]) ** 2 + (inc[u, 1] - pts[v, 1]) ** 2 + (inc[u, 2] - pts[v, 2]) ** 2
            if dd < dmin:
                dmin, near = dd, u
        cid[count] = near % SLOT_DEEPEST
        count += 1
    return count


@njit(**NO_NRT)
def _write_manifold(cand, seps, cid, count, base, sep0, pa, pb, ra, rb, nx, ny, nz, point, separation, feature, keep):
    """Add the GJK/EPA point if clearly deeper, reduce to 4, write the outputs with unique slots; returns the count.
    ``keep``: (>= count + 1,) int scratch."""
    smin = seps[0]
    for v in range(1, count):
        smin = min(smin, seps[v])
    if sep0 < smin - DEEPEST_MARGIN:
        for i in range(3):
            cand[count, i] = 0.5 * (pa[i] + ra * (nx, ny, nz)[i] + pb[i] - rb * (nx, ny, nz)[i])
        seps[count] = sep0
        cid[count] = SLOT_DEEPEST
        count += 1
    for c in range(count):
        keep[c] = c
    if count > MAX_MANIFOLD_POINTS:
        count = reduce_points(cand, seps, count, nx, ny, nz, keep)
    used = 0
    for c in range(count):
        j = keep[c]
        slot = cid[j]
        while used & (1 << slot):
            slot = (slot + 1) & 31
        used |= 1 << slot
        for i in range(3):
            point[c, i] = cand[j, i]
        separation[c] = seps[j]
        feature[c] = base | slot
    return count


@njit(**NO_NRT)
def face_manifold(ta, pos_a, rot_a, params_a, verts_a, fa0, fna, tb, pos_b, rot_b, params_b, verts_b, fb0, fnb,
                  hull_face_first, hull_face_count, hull_face_vertex, hull_plane, hull_vertex, speculative,
                  nx, ny, nz, sep0, core_sep, pa, pb,
                  # outputs
                  normal, point, separation, feature,
                  # scratch
                  scratch):
    """The manifold along a known normal n (a to b): supporting faces, clip, reduce (module docstring).

    sep0: the deepest separation (radii included); core_sep: the cores' along n; pa, pb
    (tuples): the cores' deepest points (the single-point fallback); scratch: a ``convex_scratch()``.
    """
    ra = core_radius(ta, params_a)
    rb = core_radius(tb, params_b)
    normal[0], normal[1], normal[2] = nx, ny, nz
    if ta != SHAPE_SPHERE and tb != SHAPE_SPHERE and ta != SHAPE_ELLIPSOID and tb != SHAPE_ELLIPSOID:
        # (a sphere or an ellipsoid touches at one point: no faces to clip)
        face_a, face_b = scratch[1], scratch[2]
        ka, ida, nfa, align_a = supporting_face(ta, pos_a, rot_a, params_a, verts_a, fa0, fna, hull_face_first,
                                                hull_face_count, hull_face_vertex, hull_plane, hull_vertex,
                                                nx, ny, nz, face_a)
        kb, idb, nfb, align_b = supporting_face(tb, pos_b, rot_b, params_b, verts_b, fb0, fnb, hull_face_first,
                                                hull_face_count, hull_face_vertex, hull_plane, hull_vertex,
                                                -nx, -ny, -nz, face_b)
        if ka >= 2 and kb >= 2:
            if tb == SHAPE_TRIANGLE:
                # a mesh triangle is the reference on ties: the shape's face is clipped to each triangle,
                # so its corners (the points that span a manifold on a tessellated floor) are among the points
                ref_is_b = kb >= 3 and (ka < 3 or align_b > align_a - REFERENCE_TOLERANCE)
            else:
                ref_is_b = kb >= 3 and (ka < 3 or align_b > align_a + REFERENCE_TOLERANCE)
            if ref_is_b:
                ref, m, rn, inc, kin, align = face_b, kb, nfb, face_a, ka, align_b
            else:
                ref, m, rn, inc, kin, align = face_a, ka, nfa, face_b, kb, align_a
            if m == 2:
                _, rn, align = _segment_reference(ref, nx, ny, nz)
                m = 4
            if align > MIN_ALIGNMENT:
                pts, tmp, ids, tmp_ids = scratch[3], scratch[4], scratch[5], scratch[6]
                # side planes through the reference edges and n (Jolt's ClipPolyVsPoly): a clipped point moved
                # along n onto the reference plane stays on the reference face, even for an oblique face
                n = _clip_to_face(ref, m, nx, ny, nz, inc, kin, pts, ids, tmp, tmp_ids)
                cand, seps, cid = scratch[7], scratch[8], scratch[9]
                count = _measure_clipped(pts, n, ref, rn, inc, kin, ref_is_b, nx, ny, nz, ra, rb, core_sep,
                                         speculative, cand, seps, cid)
                if count > 0:
                    base = ((1 << 19) if ref_is_b else 0) | ((idb if ref_is_b else ida) << 12) \
                        | ((ida if ref_is_b else idb) << 5)
                    return _write_manifold(cand, seps, cid, count, base, sep0, pa, pb, ra, rb, nx, ny, nz,
                                           point, separation, feature, scratch[10])
    # one point: midway between the two surface points
    for i in range(3):
        ni = (nx, ny, nz)[i]
        point[0, i] = 0.5 * (pa[i] + ra * ni + pb[i] - rb * ni)
    separation[0] = sep0
    feature[0] = FEATURE_SINGLE
    return 1


# Cores apart by more than this (m) take GJK's normal; closer, EPA's (GJK's direction is noise at contact).
TOUCH_GAP = 1e-7


@njit(**NO_NRT)
def collide_convex_pair(ta, tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, geometry, a, b,
                        normal, point, separation, feature, scratch):
    """Any two of sphere, capsule, cylinder, cone, box, convex (the dispatch's shared routine);
    ``scratch``: a ``convex_scratch()``."""
    shape_data, hull_vertex, hull_face_first, hull_face_count, hull_face_vertex, hull_plane = geometry[:6]
    va, fa0, fna = shape_arrays(ta, a, shape_data, hull_vertex)
    vb, fb0, fnb = shape_arrays(tb, b, shape_data, hull_vertex)
    return convex_contact(ta, pos_a, rot_a, params_a, va, fa0, fna, tb, pos_b, rot_b, params_b, vb, fb0, fnb,
                          hull_face_first, hull_face_count, hull_face_vertex, hull_plane, hull_vertex, speculative,
                          normal, point, separation, feature, scratch)
