"""Stage ``collide_pairs``: contact manifolds of the broadphase pairs and of every plane against every moving shape.

Reads the pair arrays, the ShapeTable and ``shape_pos``, ``shape_rot``, ``shape_aabb``
from ``update_bounds``; writes a ``ContactManifolds``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..math3d import JIT
from ..shapes import (SHAPE_BOX, SHAPE_CAPSULE, SHAPE_CONE, SHAPE_CONVEX, SHAPE_CYLINDER, SHAPE_MESH, SHAPE_PLANE,
                      SHAPE_SPHERE)
from .constants import MAX_MANIFOLD_POINTS
from .manifold import KEY_BITS, ContactManifolds
from .pairs.box import collide_box_box, collide_capsule_box, collide_plane_box, collide_sphere_box
from .pairs.capsule import collide_capsule_capsule, collide_plane_capsule, collide_sphere_capsule
from .pairs.convex import collide_convex_pair, collide_plane_convex_shape
from .pairs.mesh import collide_convex_mesh
from .pairs.sphere import collide_plane_sphere, collide_sphere_sphere


@njit(**JIT)
def collide_shapes(ta, tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, geometry, a, b,
                   normal, point, separation, feature):
    """Dispatch one pair with ``ta <= tb`` in SHAPE_* order to its ``collide_<a>_<b>``; 0 for pairs without a routine.

    ``geometry`` is ``ShapeTable.geometry`` (hull and mesh arrays) and a, b the shape rows
    (only the convex and mesh routines read them).
    """
    if tb == SHAPE_MESH:
        if ta == SHAPE_PLANE or ta == SHAPE_MESH:
            return 0  # both fixed
        return collide_convex_mesh(ta, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, geometry, a, b,
                                   normal, point, separation, feature)
    if ta == SHAPE_PLANE:
        if tb == SHAPE_SPHERE:
            return collide_plane_sphere(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                                        separation, feature)
        if tb == SHAPE_CAPSULE:
            return collide_plane_capsule(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                                         separation, feature)
        if tb == SHAPE_BOX:
            return collide_plane_box(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                                     separation, feature)
        if tb == SHAPE_CYLINDER or tb == SHAPE_CONE or tb == SHAPE_CONVEX:
            # collide_plane_cylinder, collide_plane_cone, collide_plane_convex
            return collide_plane_convex_shape(tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative,
                                              geometry, b, normal, point, separation, feature)
        return 0
    if ta == SHAPE_SPHERE:
        if tb == SHAPE_SPHERE:
            return collide_sphere_sphere(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                                         separation, feature)
        if tb == SHAPE_CAPSULE:
            return collide_sphere_capsule(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                                          separation, feature)
        if tb == SHAPE_BOX:
            return collide_sphere_box(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                                      separation, feature)
    elif ta == SHAPE_CAPSULE:
        if tb == SHAPE_CAPSULE:
            return collide_capsule_capsule(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal,
                                           point, separation, feature)
        if tb == SHAPE_BOX:
            return collide_capsule_box(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                                       separation, feature)
    elif ta == SHAPE_BOX:
        if tb == SHAPE_BOX:
            return collide_box_box(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                                   separation, feature)
    if ta >= SHAPE_SPHERE and tb <= SHAPE_CONVEX:
        # every other pair of sphere, capsule, cylinder, cone, box, convex: GJK/EPA and face clipping
        # (collide_sphere_cylinder ... collide_convex_convex, pairs/convex.py)
        return collide_convex_pair(ta, tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, geometry, a,
                                   b, normal, point, separation, feature)
    return 0


@njit(**JIT)
def _collide_pairs_kernel(pair_a, pair_b, shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_aabb,
                          body_moving, speculative, shape_margin, geometry,
                          # outputs
                          m_shape_a, m_shape_b, m_body_a, m_body_b, m_normal, m_first, m_count,
                          c_manifold, c_body_a, c_body_b, c_point, c_normal, c_separation, c_feature, c_key):
    """Narrowphase over the sweep pairs, then over (plane, moving shape) pairs; returns (manifolds, contacts).

    Serial so that the output order is the pair order (determinism). The buffers
    must hold one manifold per candidate pair (the wrapper reserves them).
    A pair keeps contacts while its gap is below margin_a + margin_b - speculative: the
    speculative distance plus how far the two can close in the step (bounds.py).
    PERF: two passes (count, prefix sum, fill) would allow prange.
    """
    normal = np.empty(3)
    point = np.empty((MAX_MANIFOLD_POINTS, 3))
    separation = np.empty(MAX_MANIFOLD_POINTS)
    feature = np.empty(MAX_MANIFOLD_POINTS, dtype=np.int64)
    S = shape_type.shape[0]
    n_sweep = pair_a.shape[0]
    m = 0
    c = 0
    # planes: indices, to walk (plane, shape) pairs after the sweep pairs
    planes = np.empty(S, dtype=np.int64)
    n_planes = 0
    for s in range(S):
        if shape_type[s] == SHAPE_PLANE:
            planes[n_planes] = s
            n_planes += 1
    total = n_sweep + n_planes * S
    for k in range(total):
        if k < n_sweep:
            a = pair_a[k]
            b = pair_b[k]
        else:
            a = planes[(k - n_sweep) // S]
            b = (k - n_sweep) % S
            if shape_type[b] == SHAPE_PLANE or not body_moving[shape_body[b]] or shape_body[b] == shape_body[a]:
                continue
            # cull by the AABB (grown by the margin): its lowest corner along n above the plane
            p = shape_params[a]
            r = shape_rot[a]
            nx = r[0, 0] * p[0] + r[0, 1] * p[1] + r[0, 2] * p[2]
            ny = r[1, 0] * p[0] + r[1, 1] * p[1] + r[1, 2] * p[2]
            nz = r[2, 0] * p[0] + r[2, 1] * p[1] + r[2, 2] * p[2]
            d = p[3] + nx * shape_pos[a, 0] + ny * shape_pos[a, 1] + nz * shape_pos[a, 2]
            low = 0.0
            for i in range(3):
                ni = (nx, ny, nz)[i]
                low += ni * (shape_aabb[b, 0, i] if ni > 0.0 else shape_aabb[b, 1, i])
            if low - d > shape_margin[b] + shape_margin[a] - speculative:
                continue
        if shape_type[a] > shape_type[b]:
            a, b = b, a
        pair_speculative = shape_margin[a] + shape_margin[b] - speculative
        n = collide_shapes(shape_type[a], shape_type[b], shape_pos[a], shape_rot[a], shape_params[a],
                           shape_pos[b], shape_rot[b], shape_params[b], pair_speculative, geometry, a, b,
                           normal, point, separation, feature)
        if n == 0:
            continue
        body_a = shape_body[a]
        body_b = shape_body[b]
        m_shape_a[m] = a
        m_shape_b[m] = b
        m_body_a[m] = body_a
        m_body_b[m] = body_b
        m_first[m] = c
        m_count[m] = n
        for i in range(3):
            m_normal[m, i] = normal[i]
        key = (a << (2 * KEY_BITS)) | (b << KEY_BITS)
        for j in range(n):
            c_manifold[c] = m
            c_body_a[c] = body_a
            c_body_b[c] = body_b
            for i in range(3):
                c_point[c, i] = point[j, i]
                c_normal[c, i] = normal[i]
            c_separation[c] = separation[j]
            c_feature[c] = feature[j]
            c_key[c] = key | feature[j]
            c += 1
        m += 1
    return m, c


def collide_pairs(pair_a, pair_b, table, shape_pos, shape_rot, shape_aabb, speculative,
                  out: ContactManifolds | None = None, shape_margin=None) -> ContactManifolds:
    """Contact manifolds of the broadphase pairs, and of each plane against each moving shape.

    Args:
        pair_a, pair_b: (P,) int64 from ``find_pairs``.
        table: the ``ShapeTable``.
        shape_pos, shape_rot, shape_aabb: (S, 3), (S, 3, 3), (S, 2, 3) from ``update_bounds``.
        speculative: m, contacts are kept while their separation is below it
            (``SPECULATIVE_DISTANCE``, 0.02 m).
        out: a ``ContactManifolds`` to reuse (grown by doubling).
        shape_margin: (S,) m from ``update_bounds`` (speculative distance plus motion bound);
            None: ``speculative`` for every shape.

    Returns:
        ``out``, filled: manifolds in pair order (sweep pairs by (a, b), then planes).
    """
    if out is None:
        out = ContactManifolds()
    S = table.shape_count
    if S >= 1 << KEY_BITS:
        raise ValueError(f"contact keys hold shape indices below {1 << KEY_BITS}; got {S} shapes")
    n_planes = int(np.count_nonzero(table.shape_type == SHAPE_PLANE))
    out.reserve(len(pair_a) + n_planes * max(S - n_planes, 0))
    if shape_margin is None:
        shape_margin = np.full(S, float(speculative))
    m, c = _collide_pairs_kernel(np.ascontiguousarray(pair_a, dtype=np.int64), np.ascontiguousarray(pair_b, dtype=np.int64),
                                 table.shape_type, table.shape_body, table.shape_params, shape_pos, shape_rot,
                                 shape_aabb, table.body_moving, float(speculative), shape_margin, table.geometry,
                                 *out.buffers())
    out.manifold_count = m
    out.contact_count = c
    return out
