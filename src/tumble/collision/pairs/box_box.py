"""Box-box contact (contract in ``pairs/__init__``): Gregorius, "The Separating Axis Test
between Convex Polyhedra" (GDC 2013) and "Robust Contact Creation for Physics Simulations"
(GDC 2015): SAT over the 15 axes, a face contact by clipping the incident face against the
reference face's side planes (Sutherland-Hodgman), an edge contact from the closest points of
the two edges, and a reduction to 4 points (shared with the convex hulls: ``pairs/convex``).

A box is ``pos + rot @ l`` for ``|l_k| <= h_k``; its axes are the columns of ``rot``. The face
and edge tolerances of the axis choice and the feature-id bases are in ``collision.constants``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...math3d import JIT
from ..constants import (ABS_TOLERANCE, FEATURE_EDGE, FEATURE_FACE, MAX_MANIFOLD_POINTS, REL_EDGE_TOLERANCE,
                         REL_FACE_TOLERANCE)
from .capsule import closest_segment_segment, lerp3


@njit(**JIT)
def _clip_polygon(work, src, n_in, nx, ny, nz, offset, dst):
    """Sutherland-Hodgman: the part of the polygon in rows src .. src + n_in - 1 of ``work``
    where n . p <= offset, written from row dst; returns its size. (Rows, not slices: a slice is
    a view whose reference count costs as much as a clip, see ``box_box_contact``.)"""
    n_out = 0
    if n_in == 0:
        return 0
    prev = src + n_in - 1
    d_prev = nx * work[prev, 0] + ny * work[prev, 1] + nz * work[prev, 2] - offset
    for cur in range(src, src + n_in):
        d_cur = nx * work[cur, 0] + ny * work[cur, 1] + nz * work[cur, 2] - offset
        if (d_prev <= 0.0) != (d_cur <= 0.0):
            # the edge crosses the plane: add the crossing point
            s = d_prev / (d_prev - d_cur)
            for i in range(3):
                work[dst + n_out, i] = work[prev, i] + s * (work[cur, i] - work[prev, i])
            n_out += 1
        if d_cur <= 0.0:
            for i in range(3):
                work[dst + n_out, i] = work[cur, i]
            n_out += 1
        prev = cur
        d_prev = d_cur
    return n_out


@njit(**JIT)
def _reduce_manifold(pts, seps, n, nx, ny, nz, keep):
    """Indices (into keep[:4]) of at most 4 of n points that span the largest area, the deepest first.

    Deepest point; the point farthest from it; the points of largest positive and
    negative triangle area (about the normal) with those two. Gregorius 2015,
    "Contact reduction"; Box3D reduces the same way. Ties go to the lower index.
    """
    # COMPILE: integers that reach a call start as np.int64, not a literal: Numba compiles the
    # callee once more for each literal value its arguments are typed with on the way (measured:
    # the box-box routines compiled 2-4 times each, 11 s of a first run's 78 s)
    i1 = np.int64(0)
    for k in range(1, n):
        if seps[k] < seps[i1]:
            i1 = k
    i2 = np.int64(-1)
    best = -1.0
    for k in range(n):
        d = (pts[k, 0] - pts[i1, 0]) ** 2 + (pts[k, 1] - pts[i1, 1]) ** 2 + (pts[k, 2] - pts[i1, 2]) ** 2
        if k != i1 and d > best:
            best, i2 = d, k
    keep[0] = i1
    m = 1
    if i2 < 0 or best <= 0.0:
        return m
    keep[1] = i2
    return add_widest_triangle_points(pts, n, i1, i2, nx, ny, nz, 0.0, keep)


@njit(**JIT)
def add_widest_triangle_points(pts, n, i1, i2, nx, ny, nz, min_area, keep):
    """The last two points of a reduced manifold (``keep[0] = i1``, ``keep[1] = i2`` already):
    of ``pts[:n]`` (n, 3) m, the point of largest positive and the one of largest negative doubled
    triangle area (p_i1, p_i2, p_k) about the normal (nx, ny, nz), each kept if its area's magnitude
    passes ``min_area`` (m^2; 0 keeps any point off the line). Returns the count kept in ``keep``
    (2 to 4). Shared by the box (min_area 0) and convex (a fraction of the span) reductions."""
    m = 2
    ex, ey, ez = pts[i2, 0] - pts[i1, 0], pts[i2, 1] - pts[i1, 1], pts[i2, 2] - pts[i1, 2]
    i3, i4 = -1, -1
    amax, amin = min_area, -min_area
    for k in range(n):
        fx, fy, fz = pts[k, 0] - pts[i1, 0], pts[k, 1] - pts[i1, 1], pts[k, 2] - pts[i1, 2]
        # signed doubled area of triangle (p1, p2, pk) about the normal
        area = nx * (ey * fz - ez * fy) + ny * (ez * fx - ex * fz) + nz * (ex * fy - ey * fx)
        if area > amax:
            amax, i3 = area, k
        if area < amin:
            amin, i4 = area, k
    if i3 >= 0:
        keep[m] = i3
        m += 1
    if i4 >= 0:
        keep[m] = i4
        m += 1
    return m


# PERF: inlined into box_box_contact (Numba IR inlining): the call passed ten arrays' structs;
# a box-box pair 708 -> 571 ns on the large pyramid (min of 25 interleaved runs, same manifolds).
@njit(**JIT, inline="always")
def _box_face_contact(ref_pos, ref_rot, ref_h, inc_pos, inc_rot, inc_h, axis, ref_is_b, speculative,
                      normal, point, separation, feature, work):
    """Face contact: reference face ``axis`` of the ref box (the side facing the other box), clip the incident face.

    Feature: (reference face, incident face, quadrant of the point in the incident
    face's frame). The quadrant, not the clip topology, names a point, so a point
    that is sometimes an incident corner and sometimes its clipped neighbour (a box
    on a box of the same size) keeps its id.
    """
    tx, ty, tz = inc_pos[0] - ref_pos[0], inc_pos[1] - ref_pos[1], inc_pos[2] - ref_pos[2]
    side = 1.0 if tx * ref_rot[0, axis] + ty * ref_rot[1, axis] + tz * ref_rot[2, axis] >= 0.0 else -1.0
    nx, ny, nz = side * ref_rot[0, axis], side * ref_rot[1, axis], side * ref_rot[2, axis]
    # incident face: the face of the other box most anti-parallel to n
    inc = 0
    best = -1.0
    for j in range(3):
        c = abs(nx * inc_rot[0, j] + ny * inc_rot[1, j] + nz * inc_rot[2, j])
        if c > best:
            best, inc = c, j
    inc_side = -1.0 if nx * inc_rot[0, inc] + ny * inc_rot[1, inc] + nz * inc_rot[2, inc] >= 0.0 else 1.0
    j1 = (inc + 1) % 3
    j2 = (inc + 2) % 3
    for i in range(3):  # the incident face's centre
        work[CENTRE, i] = inc_pos[i] + inc_side * inc_h[inc] * inc_rot[i, inc]
    for v in range(4):
        s1 = 1.0 if v == 0 or v == 3 else -1.0  # (+,+) (-,+) (-,-) (+,-): around the face
        s2 = 1.0 if v < 2 else -1.0
        for i in range(3):
            work[POLY + v, i] = work[CENTRE, i] + s1 * inc_h[j1] * inc_rot[i, j1] + s2 * inc_h[j2] * inc_rot[i, j2]
    n = np.int64(4)
    # side planes of the reference face: +-axis k1, +-axis k2
    for step in range(1, 3):
        k = (axis + step) % 3
        ax, ay, az = ref_rot[0, k], ref_rot[1, k], ref_rot[2, k]
        c = ax * ref_pos[0] + ay * ref_pos[1] + az * ref_pos[2]
        n = _clip_polygon(work, POLY, n, ax, ay, az, c + ref_h[k], CLIPPED)
        n = _clip_polygon(work, CLIPPED, n, -ax, -ay, -az, -c + ref_h[k], POLY)
    # keep the points below the speculative distance (rows CLIPPED.., separations in column 0 of
    # rows SEPS..); separation along n from the reference face
    face_offset = nx * ref_pos[0] + ny * ref_pos[1] + nz * ref_pos[2] + ref_h[axis]
    m = np.int64(0)
    for v in range(n):
        sep = nx * work[POLY + v, 0] + ny * work[POLY + v, 1] + nz * work[POLY + v, 2] - face_offset
        if sep < speculative:
            for i in range(3):
                work[CLIPPED + m, i] = work[POLY + v, i] - 0.5 * sep * (nx if i == 0 else (ny if i == 1 else nz))
            work[SEPS + m, 0] = sep
            m += 1
    if m == 0:
        return 0
    pts = CLIPPED  # the first row of the points kept, and the column of their separations
    col = 0
    if m > MAX_MANIFOLD_POINTS:  # rare (a deep clip): the 4 kept, in keep's order, to POLY and column 1
        keep = np.arange(8)
        m = _reduce_manifold(work[CLIPPED:CLIPPED + 8], work[SEPS:SEPS + 8, 0], m, nx, ny, nz, keep)
        for c in range(m):
            for i in range(3):
                work[POLY + c, i] = work[CLIPPED + keep[c], i]
            work[SEPS + c, 1] = work[SEPS + keep[c], 0]
        pts = POLY
        col = 1
    sign = -1.0 if ref_is_b else 1.0
    normal[0], normal[1], normal[2] = sign * nx, sign * ny, sign * nz
    ref_face = 6 * (1 if ref_is_b else 0) + 2 * axis + (1 if side > 0 else 0)
    inc_face = 2 * inc + (1 if inc_side > 0 else 0)
    base = FEATURE_FACE + 64 * (6 * ref_face + inc_face)
    used = 0
    for c in range(m):
        u = 0.0
        w = 0.0
        for i in range(3):
            u += (work[pts + c, i] - work[CENTRE, i]) * inc_rot[i, j1]
            w += (work[pts + c, i] - work[CENTRE, i]) * inc_rot[i, j2]
        slot = (1 if u >= 0.0 else 0) + (2 if w >= 0.0 else 0)
        while used & (1 << slot):
            slot = (slot + 1) % 8  # two points in one quadrant (a deep clip): next free id
        used |= 1 << slot
        for i in range(3):
            point[c, i] = work[pts + c, i]
        separation[c] = work[SEPS + c, col]
        feature[c] = base + slot
    return m


# Rows of the (BOX_WORK_ROWS, 3) scratch of box_box_contact: the clipped polygon and its copy
# (8 rows each from POLY and CLIPPED), the incident face's centre (CENTRE), separations (8 rows
# from SEPS, column 0; column 1 holds the 4 kept after a reduction). The edge contact reuses
# rows 0 and 1. The SAT, done before either, uses 7 rows: a_i . b_j (3 from RAB), |a_i . b_j|
# (3 from ABS_RAB), t in a's frame (TA).
BOX_WORK_ROWS = 28
POLY, CLIPPED, CENTRE, SEPS = 0, 8, 19, 20
RAB, ABS_RAB, TA = 16, 19, 22


@njit(**JIT)
def collide_box_box(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative,
                    normal, point, separation, feature):
    """SAT over the 15 axes (3 + 3 faces, 9 edge pairs), then a face or an edge contact
    (``box_box_contact`` with a scratch of its own)."""
    return box_box_contact(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point, separation,
                           feature, np.empty((BOX_WORK_ROWS, 3)))


@njit(**JIT)
def box_box_contact(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative,
                    normal, point, separation, feature, work):
    """``collide_box_box`` writing its intermediate polygons into ``work`` (BOX_WORK_ROWS, 3),
    given by the caller. PERF: the narrowphase passes one scratch per chunk of pairs; the six
    small arrays this allocated per pair took a third of its time (940 -> 630 ns per face
    contact, measured), more when threads shared the allocator."""
    ha, hb = params_a, params_b
    tx, ty, tz = pos_b[0] - pos_a[0], pos_b[1] - pos_a[1], pos_b[2] - pos_a[2]
    # work[RAB + i, j] = a_i . b_j (b's axes in a's frame), work[ABS_RAB + i, j] its magnitude,
    # work[TA] = t in a's frame
    # (in rows RAB, ABS_RAB and TA of work, indexed in place: a slice is a view, whose reference
    # count cost more than the arithmetic here: 6-7 % of a pair, measured)
    for i in range(3):
        for j in range(3):
            work[RAB + i, j] = rot_a[0, i] * rot_b[0, j] + rot_a[1, i] * rot_b[1, j] + rot_a[2, i] * rot_b[2, j]
            work[ABS_RAB + i, j] = abs(work[RAB + i, j])
    # separation along an axis: |t . n| minus both boxes' half widths along n
    face_a, axis_a = -np.inf, np.int64(0)  # np.int64: see _reduce_manifold
    for i in range(3):
        work[TA, i] = tx * rot_a[0, i] + ty * rot_a[1, i] + tz * rot_a[2, i]
        sep = abs(work[TA, i]) - ha[i] - (work[ABS_RAB + i, 0] * hb[0] + work[ABS_RAB + i, 1] * hb[1]
                                          + work[ABS_RAB + i, 2] * hb[2])
        if sep > speculative:
            return 0
        if sep > face_a:
            face_a, axis_a = sep, i
    face_b, axis_b = -np.inf, np.int64(0)
    for j in range(3):
        d = abs(tx * rot_b[0, j] + ty * rot_b[1, j] + tz * rot_b[2, j])
        sep = d - hb[j] - (work[ABS_RAB, j] * ha[0] + work[ABS_RAB + 1, j] * ha[1] + work[ABS_RAB + 2, j] * ha[2])
        if sep > speculative:
            return 0
        if sep > face_b:
            face_b, axis_b = sep, j
    # the edge axes n = a_i x b_j in a's frame (Gottschalk et al. 1996, "OBBTree", table 1):
    # t . n, each box's half width along n and |n| from a.b and t in a's frame alone, no
    # normalized axis until one is chosen (the world-frame axis, normalized, took 3 divisions
    # and 18 products more a pair of edges). PERF: box_box_contact over the large pyramid's
    # 14 950 pairs 884-907 -> 820-839 ns a pair, the same manifolds. Measured there too: much of
    # a pair's time is not the geometry but the array views of the calls and their reference
    # counts (an early return at the top still costs 330 ns a pair; scratch copies instead of
    # views 200 ns).
    edge, edge_i, edge_j = -np.inf, np.int64(-1), np.int64(-1)
    for i in range(3):
        i1 = (i + 1) % 3
        i2 = (i + 2) % 3
        for j in range(3):
            j1 = (j + 1) % 3
            j2 = (j + 2) % 3
            ln = math.sqrt(work[RAB + i1, j] * work[RAB + i1, j] + work[RAB + i2, j] * work[RAB + i2, j])
            if ln < 1e-6:  # parallel edges give no axis (the face axes cover them)
                continue
            tn = abs(work[TA, i2] * work[RAB + i1, j] - work[TA, i1] * work[RAB + i2, j])
            ext = (ha[i1] * work[ABS_RAB + i2, j] + ha[i2] * work[ABS_RAB + i1, j]
                   + hb[j1] * work[ABS_RAB + i, j2] + hb[j2] * work[ABS_RAB + i, j1])
            sep = (tn - ext) / ln
            if sep > speculative:
                return 0
            if sep > edge:
                edge, edge_i, edge_j = sep, i, j
    en = (0.0, 0.0, 0.0)
    if edge_i >= 0:  # the chosen edge axis in the world frame, pointing from a to b
        i, j = edge_i, edge_j
        nx = rot_a[1, i] * rot_b[2, j] - rot_a[2, i] * rot_b[1, j]
        ny = rot_a[2, i] * rot_b[0, j] - rot_a[0, i] * rot_b[2, j]
        nz = rot_a[0, i] * rot_b[1, j] - rot_a[1, i] * rot_b[0, j]
        ln = math.sqrt(nx * nx + ny * ny + nz * nz)
        nx, ny, nz = nx / ln, ny / ln, nz / ln
        if tx * nx + ty * ny + tz * nz < 0.0:
            nx, ny, nz = -nx, -ny, -nz
        en = (nx, ny, nz)
    if edge_i >= 0 and edge > REL_EDGE_TOLERANCE * max(face_a, face_b) + ABS_TOLERANCE:
        return _box_edge_contact(pos_a, rot_a, ha, pos_b, rot_b, hb, edge_i, edge_j, en, edge,
                                 normal, point, separation, feature, work)
    if face_b > REL_FACE_TOLERANCE * face_a + ABS_TOLERANCE:
        return _box_face_contact(pos_b, rot_b, hb, pos_a, rot_a, ha, axis_b, np.bool_(True), speculative,
                                 normal, point, separation, feature, work)
    return _box_face_contact(pos_a, rot_a, ha, pos_b, rot_b, hb, axis_a, np.bool_(False), speculative,
                             normal, point, separation, feature, work)


@njit(**JIT)
def _box_edge_contact(pos_a, rot_a, ha, pos_b, rot_b, hb, i, j, n, sep, normal, point, separation, feature,
                      work):
    """Edge contact: the closest points of a's edge along a_i supporting +n and b's edge along b_j supporting -n."""
    code_a = 0
    code_b = 0
    ca = work[0]
    cb = work[1]
    for m in range(3):
        ca[m] = pos_a[m]
        cb[m] = pos_b[m]
    for bit in range(2):
        k = (i + 1 + bit) % 3
        s = 1.0 if n[0] * rot_a[0, k] + n[1] * rot_a[1, k] + n[2] * rot_a[2, k] >= 0.0 else -1.0
        code_a |= (1 << bit) if s > 0 else 0
        for m in range(3):
            ca[m] += s * ha[k] * rot_a[m, k]
    for bit in range(2):
        k = (j + 1 + bit) % 3
        s = -1.0 if n[0] * rot_b[0, k] + n[1] * rot_b[1, k] + n[2] * rot_b[2, k] >= 0.0 else 1.0
        code_b |= (1 << bit) if s > 0 else 0
        for m in range(3):
            cb[m] += s * hb[k] * rot_b[m, k]
    a0 = (ca[0] - ha[i] * rot_a[0, i], ca[1] - ha[i] * rot_a[1, i], ca[2] - ha[i] * rot_a[2, i])
    a1 = (ca[0] + ha[i] * rot_a[0, i], ca[1] + ha[i] * rot_a[1, i], ca[2] + ha[i] * rot_a[2, i])
    b0 = (cb[0] - hb[j] * rot_b[0, j], cb[1] - hb[j] * rot_b[1, j], cb[2] - hb[j] * rot_b[2, j])
    b1 = (cb[0] + hb[j] * rot_b[0, j], cb[1] + hb[j] * rot_b[1, j], cb[2] + hb[j] * rot_b[2, j])
    s, t = closest_segment_segment(a0, a1, b0, b1)
    pa = lerp3(a0, a1, s)
    pb = lerp3(b0, b1, t)
    for m in range(3):
        normal[m] = n[m]
        point[0, m] = 0.5 * (pa[m] + pb[m])
    separation[0] = sep
    feature[0] = FEATURE_EDGE + 16 * (4 * i + code_a) + 4 * j + code_b
    return 1
