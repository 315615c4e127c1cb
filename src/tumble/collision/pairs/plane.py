"""Plane family, round and hull shapes: plane-cylinder, plane-cone, plane-ellipsoid, plane-convex (contract in ``pairs/__init__``)."""

from __future__ import annotations

import numpy as np
from numba import njit

from ...math3d import JIT
from ...shapes import SHAPE_CONVEX
from ..constants import MAX_MANIFOLD_POINTS
from .convex import CAP_SIDES, DEEPEST_MARGIN, reduce_points, supporting_face
from .gjk import support
from .sphere import plane_world


@njit(**JIT)
def collide_plane_convex_shape(tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, geometry, b,
                               normal, point, separation, feature):
    """Plane a against a cylinder, cone, ellipsoid or convex hull b.

    Hull: every vertex within ``speculative`` of the plane (feature = vertex row),
    reduced to 4. Cylinder and cone: the supporting face towards the plane (cap
    octagon, side line or a point; feature = face id * 32 + vertex) plus the deepest
    point of the round shape (feature 255) when it is deeper than those.
    """
    nx, ny, nz, d = plane_world(pos_a, rot_a, params_a)
    shape_data, hull_vertex, hull_face_first, hull_face_count, hull_face_vertex, hull_plane = geometry[:6]
    normal[0], normal[1], normal[2] = nx, ny, nz
    if tb == SHAPE_CONVEX:
        v0 = shape_data[b, 0]
        nv = shape_data[b, 1]
        cand = np.empty((nv, 3))
        seps = np.empty(nv)
        cid = np.empty(nv, dtype=np.int64)
    else:
        nv = CAP_SIDES + 1
        cand = np.empty((nv, 3))
        seps = np.empty(nv)
        cid = np.empty(nv, dtype=np.int64)
        n_face, face_id, _, _ = supporting_face(tb, pos_b, rot_b, params_b, hull_vertex[0:0], np.int64(0), np.int64(0), hull_face_first,
                                                hull_face_count, hull_face_vertex, hull_plane, hull_vertex,
                                                -nx, -ny, -nz, cand)
    count = np.int64(0)
    smin = np.inf
    if tb == SHAPE_CONVEX:
        for v in range(nv):
            row = v0 + v
            x, y, z = hull_vertex[row, 0], hull_vertex[row, 1], hull_vertex[row, 2]
            px = pos_b[0] + rot_b[0, 0] * x + rot_b[0, 1] * y + rot_b[0, 2] * z
            py = pos_b[1] + rot_b[1, 0] * x + rot_b[1, 1] * y + rot_b[1, 2] * z
            pz = pos_b[2] + rot_b[2, 0] * x + rot_b[2, 1] * y + rot_b[2, 2] * z
            s = nx * px + ny * py + nz * pz - d
            if s < speculative:
                cand[count, 0], cand[count, 1], cand[count, 2] = px, py, pz
                seps[count] = s
                cid[count] = v
                count += 1
    else:
        for v in range(n_face):
            s = nx * cand[v, 0] + ny * cand[v, 1] + nz * cand[v, 2] - d
            if s < speculative:
                for i in range(3):
                    cand[count, i] = cand[v, i]
                seps[count] = s
                smin = min(smin, s)
                cid[count] = face_id * 32 + v
                count += 1
        p = support(tb, pos_b, rot_b, params_b, hull_vertex[0:0], -nx, -ny, -nz)
        s = nx * p[0] + ny * p[1] + nz * p[2] - d
        if s < speculative and s < smin - DEEPEST_MARGIN:
            cand[count, 0], cand[count, 1], cand[count, 2] = p
            seps[count] = s
            cid[count] = 255
            count += 1
    if count == 0:
        return 0
    keep = np.arange(count)
    if count > MAX_MANIFOLD_POINTS:
        count = reduce_points(cand, seps, count, nx, ny, nz, keep)
    for c in range(count):
        j = keep[c]
        for i in range(3):
            point[c, i] = cand[j, i] - 0.5 * seps[j] * (nx, ny, nz)[i]
        separation[c] = seps[j]
        feature[c] = cid[j]
    return count
