"""Box family: plane-box, sphere-box, capsule-box (contract in ``pairs/__init__``); box-box
is ``pairs/box_box``.

A box is ``pos + rot @ l`` for ``|l_k| <= h_k``; its axes are the columns of ``rot``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...math3d import JIT
from ..constants import ABS_TOLERANCE, FEATURE_EDGE, FEATURE_FACE, MAX_MANIFOLD_POINTS, REL_EDGE_TOLERANCE
from .capsule import closest_segment_segment, lerp3, segment_ends
from .sphere import plane_world


@njit(**JIT)
def collide_plane_box(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative,
                      normal, point, separation, feature):
    """Up to 4 deepest box corners within ``speculative`` of the plane; feature = corner index."""
    nx, ny, nz, d = plane_world(pos_a, rot_a, params_a)
    # n . corner = n . pos + sum_k s_k h_k (n . axis_k): 8 sums of 3 terms
    base = nx * pos_b[0] + ny * pos_b[1] + nz * pos_b[2] - d
    e0 = params_b[0] * (nx * rot_b[0, 0] + ny * rot_b[1, 0] + nz * rot_b[2, 0])
    e1 = params_b[1] * (nx * rot_b[0, 1] + ny * rot_b[1, 1] + nz * rot_b[2, 1])
    e2 = params_b[2] * (nx * rot_b[0, 2] + ny * rot_b[1, 2] + nz * rot_b[2, 2])
    seps = np.empty(8)
    chosen = np.zeros(8, dtype=np.bool_)
    n_in = 0
    for c in range(8):
        s0 = 1.0 if c & 1 else -1.0
        s1 = 1.0 if c & 2 else -1.0
        s2 = 1.0 if c & 4 else -1.0
        seps[c] = base + s0 * e0 + s1 * e1 + s2 * e2
        if seps[c] < speculative:
            n_in += 1
    if n_in == 0:
        return 0
    # the (up to) 4 deepest; ties go to the lower corner index
    for _ in range(min(n_in, MAX_MANIFOLD_POINTS)):
        best = -1
        for c in range(8):
            if not chosen[c] and seps[c] < speculative and (best < 0 or seps[c] < seps[best]):
                best = c
        chosen[best] = True
    normal[0] = nx
    normal[1] = ny
    normal[2] = nz
    count = 0
    for c in range(8):
        if chosen[c]:
            s0 = params_b[0] if c & 1 else -params_b[0]
            s1 = params_b[1] if c & 2 else -params_b[1]
            s2 = params_b[2] if c & 4 else -params_b[2]
            sep = seps[c]
            for i in range(3):
                corner = pos_b[i] + s0 * rot_b[i, 0] + s1 * rot_b[i, 1] + s2 * rot_b[i, 2]
                point[count, i] = corner - 0.5 * sep * normal[i]
            separation[count] = sep
            feature[count] = c
            count += 1
    return count


@njit(**JIT)
def collide_sphere_box(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative,
                       normal, point, separation, feature):
    """Sphere a against box b: closest point of the box to the centre, or the shallowest face if inside.

    feature: the Voronoi region of the centre, sum_k 3^k code_k with code 0 below
    -h_k, 1 within, 2 above +h_k (face regions have one code != 1), or 27 + face
    id (2 k + side) when the centre is inside the box.
    """
    r = params_a[0]
    h = params_b
    dx, dy, dz = pos_a[0] - pos_b[0], pos_a[1] - pos_b[1], pos_a[2] - pos_b[2]
    local = np.empty(3)
    clamped = np.empty(3)
    region = 0
    scale = 1
    inside = True
    for k in range(3):
        lk = rot_b[0, k] * dx + rot_b[1, k] * dy + rot_b[2, k] * dz
        local[k] = lk
        if lk < -h[k]:
            clamped[k] = -h[k]
            code = 0
            inside = False
        elif lk > h[k]:
            clamped[k] = h[k]
            code = 2
            inside = False
        else:
            clamped[k] = lk
            code = 1
        region += code * scale
        scale *= 3
    out = np.empty(3)  # outward box normal, local
    if not inside:
        ex, ey, ez = local[0] - clamped[0], local[1] - clamped[1], local[2] - clamped[2]
        dist = math.sqrt(ex * ex + ey * ey + ez * ez)
        sep = dist - r
        if sep >= speculative:
            return 0
        out[0], out[1], out[2] = ex / dist, ey / dist, ez / dist
        fid = region
    else:
        best = 0
        depth = h[0] - abs(local[0])
        for k in range(1, 3):
            dk = h[k] - abs(local[k])
            if dk < depth:
                depth = dk
                best = k
        side = 1.0 if local[best] >= 0.0 else -1.0
        out[0], out[1], out[2] = 0.0, 0.0, 0.0
        out[best] = side
        clamped[best] = side * h[best]
        sep = -depth - r
        fid = 27 + 2 * best + (1 if side > 0.0 else 0)
    for i in range(3):
        n_out = rot_b[i, 0] * out[0] + rot_b[i, 1] * out[1] + rot_b[i, 2] * out[2]
        surface_b = pos_b[i] + rot_b[i, 0] * clamped[0] + rot_b[i, 1] * clamped[1] + rot_b[i, 2] * clamped[2]
        normal[i] = -n_out
        # midway between the box's point and the sphere's point nearest the box
        point[0, i] = 0.5 * (surface_b + pos_a[i] - r * n_out)
    separation[0] = sep
    feature[0] = fid
    return 1


@njit(**JIT)
def _clip_segment_to_slabs(p0, p1, h, skip):
    """Parameters [t0, t1] of the part of segment p0 p1 (box frame) within |l_k| <= h_k for k != skip (Liang-Barsky).

    Returns t0 > t1 when nothing is left. ``skip`` = -1 clips against all three slabs.
    """
    t0, t1 = 0.0, 1.0
    for k in range(3):
        if k == skip:
            continue
        d = p1[k] - p0[k]
        if abs(d) < 1e-15:
            if p0[k] < -h[k] or p0[k] > h[k]:
                return 1.0, 0.0
            continue
        ta = (-h[k] - p0[k]) / d
        tb = (h[k] - p0[k]) / d
        if ta > tb:
            ta, tb = tb, ta
        t0 = max(t0, ta)
        t1 = min(t1, tb)
    return t0, t1


@njit(**JIT)
def _capsule_box_face(p0, p1, r, h, k, side, rot_b, pos_b, speculative, normal, point, separation, feature):
    """Capsule core p0 p1 (box frame) against box face (k, side): the clipped core's ends, up to 2 points."""
    t0, t1 = _clip_segment_to_slabs(p0, p1, h, k)
    if t0 > t1:
        return 0
    for i in range(3):
        normal[i] = -side * rot_b[i, k]
    count = 0
    for e in range(2):
        if e == 1 and (t1 - t0) * 1e9 < 1.0:
            break  # one point only: the core touches the face's slab at a single place
        t = t0 if e == 0 else t1
        c = lerp3(p0, p1, t)
        sep = side * c[k] - h[k] - r
        if sep >= speculative:
            continue
        # box point: c moved onto the face plane; capsule point: c - r side e_k; midway
        m0, m1, m2 = c
        shift = -(0.5 * sep + r) * side
        if k == 0:
            m0 += shift
        elif k == 1:
            m1 += shift
        else:
            m2 += shift
        for i in range(3):
            point[count, i] = pos_b[i] + rot_b[i, 0] * m0 + rot_b[i, 1] * m1 + rot_b[i, 2] * m2
        separation[count] = sep
        feature[count] = FEATURE_FACE + 4 * (2 * k + (1 if side > 0 else 0)) + e
        count += 1
    return count


@njit(**JIT)
def _box_edge(h, k, code):
    """Endpoints (box frame) of the box edge along axis k; bits of ``code`` give the signs of the other axes."""
    j1 = (k + 1) % 3
    j2 = (k + 2) % 3
    a = np.zeros(3)
    b = np.zeros(3)
    s1 = h[j1] if code & 1 else -h[j1]
    s2 = h[j2] if code & 2 else -h[j2]
    a[j1] = s1
    b[j1] = s1
    a[j2] = s2
    b[j2] = s2
    a[k] = -h[k]
    b[k] = h[k]
    return (a[0], a[1], a[2]), (b[0], b[1], b[2])


@njit(**JIT)
def collide_capsule_box(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative,
                        normal, point, separation, feature):
    """Capsule a against box b, in the box frame.

    Core outside the box: exact closest points (core ends against the box, core
    against the 12 edges; Ericson 2005 §5.1.9), and 2 points by clipping the core
    to the face when the closest feature is a face (a capsule lying on a box).
    Core inside: SAT over the 3 face axes and the 3 axes core x edge.
    """
    r = params_a[0]
    h = params_b
    w0, w1 = segment_ends(pos_a, rot_a, params_a[1])
    # core ends in the box frame
    l0 = np.empty(3)
    l1 = np.empty(3)
    for k in range(3):
        l0[k] = rot_b[0, k] * (w0[0] - pos_b[0]) + rot_b[1, k] * (w0[1] - pos_b[1]) + rot_b[2, k] * (w0[2] - pos_b[2])
        l1[k] = rot_b[0, k] * (w1[0] - pos_b[0]) + rot_b[1, k] * (w1[1] - pos_b[1]) + rot_b[2, k] * (w1[2] - pos_b[2])
    p0 = (l0[0], l0[1], l0[2])
    p1 = (l1[0], l1[1], l1[2])
    t0, t1 = _clip_segment_to_slabs(p0, p1, h, np.int64(-1))
    core_inside = t0 <= t1
    out = (0.0, 0.0, 1.0)
    s_pt = (0.0, 0.0, 0.0)
    b_pt = (0.0, 0.0, 0.0)
    sep = 0.0
    fid = 0
    if not core_inside:
        best = np.inf
        for e in range(2):
            c = p0 if e == 0 else p1
            q = (min(max(c[0], -h[0]), h[0]), min(max(c[1], -h[1]), h[1]), min(max(c[2], -h[2]), h[2]))
            dd = (c[0] - q[0]) ** 2 + (c[1] - q[1]) ** 2 + (c[2] - q[2]) ** 2
            if dd < best:
                best, s_pt, b_pt, fid = dd, c, q, e
        for k in range(3):
            for code in range(4):
                ea, eb = _box_edge(h, k, code)
                s, t = closest_segment_segment(p0, p1, ea, eb)
                c = lerp3(p0, p1, s)
                q = lerp3(ea, eb, t)
                dd = (c[0] - q[0]) ** 2 + (c[1] - q[1]) ** 2 + (c[2] - q[2]) ** 2
                if dd < best:
                    best, s_pt, b_pt, fid = dd, c, q, FEATURE_EDGE + 4 * k + code
        dist = math.sqrt(best)
        if dist - r >= speculative:
            return 0
        if dist > 1e-12:
            out = ((s_pt[0] - b_pt[0]) / dist, (s_pt[1] - b_pt[1]) / dist, (s_pt[2] - b_pt[2]) / dist)
            # closest feature a face (the normal is a face normal): clip the core to that face
            for k in range(3):
                if abs(out[k]) > 1.0 - 1e-9:
                    n = _capsule_box_face(p0, p1, r, h, k, 1.0 if out[k] > 0 else -1.0, rot_b, pos_b, speculative,
                                          normal, point, separation, feature)
                    if n > 0:
                        return n
            sep = dist - r
        else:
            core_inside = True
    if core_inside:
        # SAT on the core: face axes, then core x edge axes; an edge must win clearly
        u = (p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2])
        best_face, face_k, face_side = np.inf, np.int64(0), 1.0  # np.int64: see _reduce_manifold
        for k in range(3):
            lo = min(p0[k], p1[k])
            hi = max(p0[k], p1[k])
            up = h[k] - lo   # push the core out through +face k
            down = hi + h[k]  # ... through -face k
            if up < best_face:
                best_face, face_k, face_side = up, k, 1.0
            if down < best_face:
                best_face, face_k, face_side = down, k, -1.0
        best_edge, edge_k = np.inf, np.int64(-1)
        edge_n = (0.0, 0.0, 0.0)
        for k in range(3):
            # n = u x e_k
            if k == 0:
                nx, ny, nz = 0.0, u[2], -u[1]
            elif k == 1:
                nx, ny, nz = -u[2], 0.0, u[0]
            else:
                nx, ny, nz = u[1], -u[0], 0.0
            ln = math.sqrt(nx * nx + ny * ny + nz * nz)
            if ln < 1e-6:
                continue
            nx, ny, nz = nx / ln, ny / ln, nz / ln
            c = nx * p0[0] + ny * p0[1] + nz * p0[2]
            ext = abs(nx) * h[0] + abs(ny) * h[1] + abs(nz) * h[2]
            if ext - c < best_edge:
                best_edge, edge_k, edge_n = ext - c, k, (nx, ny, nz)
            if ext + c < best_edge:
                best_edge, edge_k, edge_n = ext + c, k, (-nx, -ny, -nz)
        if edge_k < 0 or best_edge > REL_EDGE_TOLERANCE * best_face - ABS_TOLERANCE:
            n = _capsule_box_face(p0, p1, r, h, face_k, face_side, rot_b, pos_b, np.inf, normal, point,
                                  separation, feature)
            # separations of the clipped ends are their own depths; keep those below speculative
            count = 0
            for m in range(n):
                if separation[m] < speculative:
                    for i in range(3):
                        point[count, i] = point[m, i]
                    separation[count] = separation[m]
                    feature[count] = feature[m]
                    count += 1
            if count > 0:
                return count
            # NOTE: cannot happen (the core is inside); fall back to the core's midpoint
        out = edge_n
        code = (1 if out[(edge_k + 1) % 3] > 0 else 0) + (2 if out[(edge_k + 2) % 3] > 0 else 0)
        ea, eb = _box_edge(h, edge_k, code)
        s, t = closest_segment_segment(p0, p1, ea, eb)
        s_pt = lerp3(p0, p1, s)
        b_pt = lerp3(ea, eb, t)
        sep = -best_edge - r
        fid = FEATURE_EDGE + 4 * edge_k + code
    # one point: midway between the box point and the capsule point s_pt - r out
    for i in range(3):
        n_out = rot_b[i, 0] * out[0] + rot_b[i, 1] * out[1] + rot_b[i, 2] * out[2]
        normal[i] = -n_out
        pb = b_pt[0] * rot_b[i, 0] + b_pt[1] * rot_b[i, 1] + b_pt[2] * rot_b[i, 2]
        pa = s_pt[0] * rot_b[i, 0] + s_pt[1] * rot_b[i, 1] + s_pt[2] * rot_b[i, 2] - r * n_out
        point[0, i] = pos_b[i] + 0.5 * (pa + pb)
    separation[0] = sep
    feature[0] = fid
    return 1
