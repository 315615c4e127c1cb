"""Stage ``collide_pairs``: contact manifolds of the broadphase pairs and of every plane against every moving shape.

Reads the pair arrays, the ShapeTable and ``shape_pos``, ``shape_rot``, ``shape_aabb``
from ``update_bounds``; writes a ``ContactManifolds``.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange, types
from numba.extending import overload

from ..math3d import JIT, NO_NRT
from ..shapes import (SHAPE_BOX, SHAPE_CAPSULE, SHAPE_CONE, SHAPE_CONVEX, SHAPE_CYLINDER, SHAPE_ELLIPSOID, SHAPE_MESH, SHAPE_PLANE,
                      SHAPE_SPHERE)
from .geometry import FAMILY_ALL, FAMILY_BOXES, FAMILY_SPHERES
from .filter import NO_FILTER, filter_allows
from .manifold import KEY_BITS, ContactManifolds
from .pairs.box import collide_capsule_box, collide_plane_box, collide_sphere_box
from .pairs.box_box import BOX_WORK_ROWS, box_box_contact
from .pairs.capsule import collide_capsule_capsule, collide_plane_capsule, collide_sphere_capsule
from .pairs.convex import apart_on_centre_line, collide_convex_pair, convex_scratch, shape_arrays
from .pairs.gjk import core_radius
from .pairs.plane import collide_plane_convex_shape
from .pairs.mesh import collide_convex_mesh
from .pairs.sphere import collide_plane_sphere, collide_sphere_sphere


@njit(**JIT)
def is_analytic_shape(t):
    """True for the shapes whose pairs have closed-form routines: plane, sphere, capsule, box."""
    return t == SHAPE_PLANE or t == SHAPE_SPHERE or t == SHAPE_CAPSULE or t == SHAPE_BOX


@njit(**JIT)
def collide_analytic_pair(ta, tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative,
                          normal, point, separation, feature, work):
    """Dispatch one pair of plane, sphere, capsule and box shapes (``ta <= tb`` in SHAPE_* order) to
    its closed-form ``collide_<a>_<b>``; 0 for plane-plane.

    Kept apart from ``collide_shapes`` so that a world of these shapes alone compiles only these
    routines (``collide_pairs`` picks the analytic kernels): the GJK/EPA, hull and mesh routines
    are most of the narrowphase's compile time (measured cold: 108 s for the first step of a
    box and a sphere on a plane with every routine, of which ~45 s mesh and convex).
    ``work``: a (PAIR_WORK_ROWS, 3) scratch for the routines' intermediate polygons.
    """
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
        return 0
    if ta == SHAPE_CAPSULE:
        if tb == SHAPE_CAPSULE:
            return collide_capsule_capsule(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal,
                                           point, separation, feature)
        if tb == SHAPE_BOX:
            return collide_capsule_box(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                                       separation, feature)
        return 0
    if ta == SHAPE_BOX and tb == SHAPE_BOX:
        return box_box_contact(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                               separation, feature, work)
    return 0


def _family_pair(family, ta, tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                 separation, feature, work):
    """``collide_analytic_pair`` for a world of one family (compiled code only: the overload below)."""
    raise NotImplementedError("compiled code only")


@overload(_family_pair, jit_options=JIT, prefer_literal=True)
def _family_pair_overload(family, ta, tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal,
                          point, separation, feature, work):
    """The routines a literal ``family`` can meet, and no others. COMPILE: the analytic
    dispatch compiles every plane, sphere, capsule and box routine (box-box, capsule-box and the
    sphere pairs: 9 s of a first run's compile of planes and boxes, measured); a family compiles
    its own two. Same routines, same bits."""
    kind = family.literal_value if isinstance(family, types.IntegerLiteral) else FAMILY_ALL
    if kind == FAMILY_BOXES:
        def boxes(family, ta, tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                  separation, feature, work):
            if ta == SHAPE_PLANE and tb == SHAPE_BOX:
                return collide_plane_box(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                                         separation, feature)
            if ta == SHAPE_BOX and tb == SHAPE_BOX:
                return box_box_contact(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                                       separation, feature, work)
            return 0
        return boxes
    if kind == FAMILY_SPHERES:
        def spheres(family, ta, tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point,
                    separation, feature, work):
            if ta == SHAPE_PLANE and tb == SHAPE_SPHERE:
                return collide_plane_sphere(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal,
                                            point, separation, feature)
            if ta == SHAPE_SPHERE and tb == SHAPE_SPHERE:
                return collide_sphere_sphere(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal,
                                             point, separation, feature)
            return 0
        return spheres

    def every(family, ta, tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal, point, separation,
              feature, work):
        return collide_analytic_pair(ta, tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal,
                                     point, separation, feature, work)
    return every


@njit(**NO_NRT)
def collide_shapes(ta, tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, geometry, a, b,
                   normal, point, separation, feature, work, point_normal, scratch):
    """Dispatch one pair with ``ta <= tb`` in SHAPE_* order to its ``collide_<a>_<b>``; 0 for pairs without a routine.

    ``geometry`` is ``ShapeTable.geometry`` (hull and mesh arrays) and a, b the shape rows
    (only the convex and mesh routines read them); ``work`` a (PAIR_WORK_ROWS, 3) scratch;
    ``point_normal`` (4, 3): each point's own normal, written by the mesh routine only (the
    other pairs' points share ``normal``); ``scratch``: a ``convex_scratch()`` for the convex
    and mesh routines.
    """
    if is_analytic_shape(ta) and is_analytic_shape(tb):
        return collide_analytic_pair(ta, tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, normal,
                                     point, separation, feature, work)
    if tb == SHAPE_MESH:
        if ta == SHAPE_PLANE or ta == SHAPE_MESH:
            return 0  # both fixed
        return collide_convex_mesh(ta, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, geometry, a, b,
                                   normal, point, separation, feature, point_normal, scratch)
    if ta == SHAPE_PLANE:
        if tb == SHAPE_CYLINDER or tb == SHAPE_CONE or tb == SHAPE_CONVEX or tb == SHAPE_ELLIPSOID:
            # collide_plane_cylinder, collide_plane_cone, collide_plane_convex, collide_plane_ellipsoid
            return collide_plane_convex_shape(tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative,
                                              geometry, b, normal, point, separation, feature)
        return 0
    if ta >= SHAPE_SPHERE and tb <= SHAPE_CONVEX:
        # every other pair of sphere, capsule, cylinder, cone, box, convex: GJK/EPA and face clipping
        # (collide_sphere_cylinder ... collide_convex_convex, pairs/convex.py)
        return collide_convex_pair(ta, tb, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, geometry, a,
                                   b, normal, point, separation, feature, scratch)
    return 0


CHUNK = 64  # candidate pairs per parallel task
PAIR_WORK_ROWS = BOX_WORK_ROWS  # rows of the (R, 3) scratch each task lends its pair routines
_NO_PAIRS = np.zeros(0, dtype=np.int64)
PARALLEL_MIN_CANDIDATES = 1024  # fewer candidate pairs are collided on one thread


# PERF: _candidate_pair and _collide_analytic_candidate are inlined into their kernels (Numba IR
# inlining): a call with some twenty array arguments passes each array's whole struct, and the
# calls cost 22 % of the large pyramid's narrowphase (11.7 -> 9.1 ms, min of 25 A/B in one
# process, the same manifolds; the 210-box pyramid 1.12 -> 0.92 ms).
@njit(**JIT, inline="always")
def _candidate_pair(k, pair_a, pair_b, planes, shape_type, shape_body, shape_params, shape_pos, shape_rot,
                    shape_aabb, body_moving, speculative, shape_margin, excluded, body_filter,
                    # outputs
                    out_a, out_b, out_count):
    """Candidate k of collide_pairs: k < P a sweep pair, then (plane, shape) for each plane and
    each shape. Returns (a, b, pair_speculative): the shape rows ordered by SHAPE_* type (also
    written to out_a, out_b) and the gap (m) below which the pair keeps contacts,
    margin_a + margin_b - speculative (the speculative distance plus how far the two can close
    in the step, bounds.py); a = -1 when the candidate is culled (out_count[k] = 0 either way:
    the caller writes the point count). Body pairs whose key lo * N + hi is in ``excluded``
    (sorted: jointed bodies, ``World.exclude_collision``) are culled, and so are pairs whose
    filters do not meet (``body_filter`` (N, 3) or empty, ``filter.filter_allows``)."""
    S = shape_type.shape[0]
    N = body_moving.shape[0]
    n_sweep = pair_a.shape[0]
    out_count[k] = 0
    if k < n_sweep:
        a = pair_a[k]
        b = pair_b[k]
    else:
        a = planes[(k - n_sweep) // S]
        b = (k - n_sweep) % S
        if shape_type[b] == SHAPE_PLANE or not body_moving[shape_body[b]] or shape_body[b] == shape_body[a]:
            return -1, -1, 0.0
        # cull by the AABB (grown by the margin): its lowest corner along n above the plane
        p = shape_params[a]
        r = shape_rot[a]
        nx = r[0, 0] * p[0] + r[0, 1] * p[1] + r[0, 2] * p[2]
        ny = r[1, 0] * p[0] + r[1, 1] * p[1] + r[1, 2] * p[2]
        nz = r[2, 0] * p[0] + r[2, 1] * p[1] + r[2, 2] * p[2]
        d = p[3] + nx * shape_pos[a, 0] + ny * shape_pos[a, 1] + nz * shape_pos[a, 2]
        low = nx * (shape_aabb[b, 0, 0] if nx > 0.0 else shape_aabb[b, 1, 0]) \
            + ny * (shape_aabb[b, 0, 1] if ny > 0.0 else shape_aabb[b, 1, 1]) \
            + nz * (shape_aabb[b, 0, 2] if nz > 0.0 else shape_aabb[b, 1, 2])
        if low - d > shape_margin[b] + shape_margin[a] - speculative:
            return -1, -1, 0.0
    if excluded.shape[0] > 0:
        ba = shape_body[a]
        bb = shape_body[b]
        pair_key = min(ba, bb) * N + max(ba, bb)
        i = np.searchsorted(excluded, pair_key)
        if i < excluded.shape[0] and excluded[i] == pair_key:
            return -1, -1, 0.0
    if not filter_allows(body_filter, shape_body[a], shape_body[b]):
        return -1, -1, 0.0
    if shape_type[a] > shape_type[b]:
        a, b = b, a
    out_a[k] = a
    out_b[k] = b
    return a, b, shape_margin[a] + shape_margin[b] - speculative


@njit(**NO_NRT)
def _collide_candidate(k, pair_a, pair_b, planes, shape_type, shape_body, shape_params, shape_pos, shape_rot,
                       shape_aabb, body_moving, speculative, shape_margin, geometry, excluded, body_filter,
                       # outputs
                       out_a, out_b, out_count, out_normal, out_point, out_separation, out_feature, out_point_normal, work,
                       # scratch
                       scratch):
    """Candidate k with every shape routine (``collide_shapes``): row k gets the pair, its point
    count (0: no contact) and its points. Without reference counting (``math3d.NO_NRT``): its
    per-candidate views of the shape arrays cost two atomic operations each otherwise."""
    a, b, pair_speculative = _candidate_pair(k, pair_a, pair_b, planes, shape_type, shape_body, shape_params,
                                             shape_pos, shape_rot, shape_aabb, body_moving, speculative,
                                             shape_margin, excluded, body_filter, out_a, out_b, out_count)
    if a < 0:
        return
    ta = shape_type[a]
    tb = shape_type[b]
    if ta >= SHAPE_SPHERE and tb <= SHAPE_CONVEX and not (is_analytic_shape(ta) and is_analytic_shape(tb)):
        # PERF: GJK's first test here, before the routine's call chain (collide_convex_pair ->
        # convex_contact -> gjk, their scratch arrays): most candidates of a pile of hulls end on it
        # (80 % of the convex pile's pairs: 1.64 -> 0.70 us each, the same manifolds)
        va, _fa, _na = shape_arrays(ta, a, geometry[0], geometry[1])
        vb, _fb, _nb = shape_arrays(tb, b, geometry[0], geometry[1])
        if apart_on_centre_line(ta, shape_pos[a], shape_rot[a], shape_params[a], va, tb, shape_pos[b], shape_rot[b],
                                shape_params[b], vb, pair_speculative + core_radius(ta, shape_params[a])
                                + core_radius(tb, shape_params[b])):
            return
    out_count[k] = collide_shapes(ta, tb, shape_pos[a], shape_rot[a], shape_params[a],
                                  shape_pos[b], shape_rot[b], shape_params[b], pair_speculative, geometry,
                                  a, b, out_normal[k], out_point[k], out_separation[k], out_feature[k], work,
                                  out_point_normal[k], scratch)


@njit(**JIT, inline="always")
def _collide_analytic_candidate(family, k, pair_a, pair_b, planes, shape_type, shape_body, shape_params, shape_pos,
                                shape_rot, shape_aabb, body_moving, speculative, shape_margin, geometry, excluded, body_filter,
                                # outputs
                                out_a, out_b, out_count, out_normal, out_point, out_separation, out_feature, out_point_normal, work):
    """``_collide_candidate`` for worlds of plane, sphere, capsule and box shapes only
    (``collide_analytic_pair``, or the routines of one ``family``: the same routines, so the
    same bits)."""
    a, b, pair_speculative = _candidate_pair(k, pair_a, pair_b, planes, shape_type, shape_body, shape_params,
                                             shape_pos, shape_rot, shape_aabb, body_moving, speculative,
                                             shape_margin, excluded, body_filter, out_a, out_b, out_count)
    if a >= 0:
        out_count[k] = _family_pair(family, shape_type[a], shape_type[b], shape_pos[a], shape_rot[a],
                                    shape_params[a], shape_pos[b], shape_rot[b], shape_params[b], pair_speculative,
                                    out_normal[k], out_point[k], out_separation[k], out_feature[k], work)


# Kernels of every routine, or of the analytic ones only (a smaller compile: ``_analytic_kernels``,
# per family), each on all threads in chunks or on this one. The loops are the same; the
# candidate function differs.
@njit(**JIT, parallel=True)
def _collide_candidates_parallel_kernel(pair_a, pair_b, planes, shape_type, shape_body, shape_params, shape_pos,
                                        shape_rot, shape_aabb, body_moving, speculative, shape_margin, geometry,
                                        excluded, body_filter,
                                        # outputs
                                        out_a, out_b, out_count, out_normal, out_point, out_separation, out_feature, out_point_normal):
    """Every candidate, in parallel chunks: each task writes only its own rows, so the result
    does not depend on the threads (STYLE 5.6 rule 6)."""
    total = out_count.shape[0]
    n_chunks = (total + CHUNK - 1) // CHUNK
    for chunk in prange(n_chunks):
        work = np.empty((PAIR_WORK_ROWS, 3))  # one scratch per task, lent to its pairs
        scratch = convex_scratch()
        for k in range(chunk * CHUNK, min(total, (chunk + 1) * CHUNK)):
            _collide_candidate(k, pair_a, pair_b, planes, shape_type, shape_body, shape_params, shape_pos, shape_rot,
                               shape_aabb, body_moving, speculative, shape_margin, geometry, excluded, body_filter,
                               out_a, out_b, out_count, out_normal, out_point, out_separation, out_feature, out_point_normal, work,
                               scratch)


@njit(**JIT)
def _collide_candidates_kernel(pair_a, pair_b, planes, shape_type, shape_body, shape_params, shape_pos, shape_rot,
                               shape_aabb, body_moving, speculative, shape_margin, geometry, excluded, body_filter,
                               # outputs
                               out_a, out_b, out_count, out_normal, out_point, out_separation, out_feature, out_point_normal):
    """Every candidate, on this thread (small worlds: the threads' start-up cost more than the
    pairs; measured 15 ms a step for 5 balls on a busy machine)."""
    work = np.empty((PAIR_WORK_ROWS, 3))
    scratch = convex_scratch()
    for k in range(out_count.shape[0]):
        _collide_candidate(k, pair_a, pair_b, planes, shape_type, shape_body, shape_params, shape_pos, shape_rot,
                           shape_aabb, body_moving, speculative, shape_margin, geometry, excluded, body_filter,
                           out_a, out_b, out_count, out_normal, out_point, out_separation, out_feature, out_point_normal, work,
                           scratch)


def _analytic_kernels(family: int):
    """(parallel, serial) kernels of the analytic candidates for one ``family`` (a constant of
    the closures, so ``_family_pair`` sees a literal; Numba caches each closure apart)."""

    @njit(**JIT, parallel=True)
    def parallel(pair_a, pair_b, planes, shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_aabb,
                 body_moving, speculative, shape_margin, geometry, excluded, body_filter,
                 # outputs
                 out_a, out_b, out_count, out_normal, out_point, out_separation, out_feature, out_point_normal):
        """``_collide_candidates_parallel_kernel`` with the analytic routines only."""
        total = out_count.shape[0]
        n_chunks = (total + CHUNK - 1) // CHUNK
        for chunk in prange(n_chunks):
            work = np.empty((PAIR_WORK_ROWS, 3))
            for k in range(chunk * CHUNK, min(total, (chunk + 1) * CHUNK)):
                _collide_analytic_candidate(family, k, pair_a, pair_b, planes, shape_type, shape_body, shape_params,
                                            shape_pos, shape_rot, shape_aabb, body_moving, speculative, shape_margin,
                                            geometry, excluded, body_filter, out_a, out_b, out_count, out_normal, out_point,
                                            out_separation, out_feature, out_point_normal, work)

    @njit(**JIT)
    def serial(pair_a, pair_b, planes, shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_aabb,
               body_moving, speculative, shape_margin, geometry, excluded, body_filter,
               # outputs
               out_a, out_b, out_count, out_normal, out_point, out_separation, out_feature, out_point_normal):
        """``_collide_candidates_kernel`` with the analytic routines only."""
        work = np.empty((PAIR_WORK_ROWS, 3))
        for k in range(out_count.shape[0]):
            _collide_analytic_candidate(family, k, pair_a, pair_b, planes, shape_type, shape_body, shape_params,
                                        shape_pos, shape_rot, shape_aabb, body_moving, speculative, shape_margin,
                                        geometry, excluded, body_filter, out_a, out_b, out_count, out_normal, out_point,
                                        out_separation, out_feature, out_point_normal, work)

    return parallel, serial


_ANALYTIC_KERNELS = {family: _analytic_kernels(family) for family in (FAMILY_ALL, FAMILY_BOXES, FAMILY_SPHERES)}


@njit(**JIT)
def _compact_manifolds_kernel(cand_a, cand_b, cand_count, cand_normal, cand_point, cand_separation, cand_feature,
                              cand_point_normal, shape_type, shape_body,
                              # outputs
                              m_shape_a, m_shape_b, m_body_a, m_body_b, m_normal, m_first, m_count,
                              c_manifold, c_body_a, c_body_b, c_point, c_normal, c_separation, c_feature, c_key):
    """Stage two, serial: the candidates with contact points, in candidate order, into the flat
    manifold and contact arrays; returns (manifolds, contacts). A contact's normal is its
    manifold's, or, against a triangle mesh, its own triangle's (pairs/mesh.py)."""
    m = 0
    c = 0
    for k in range(cand_count.shape[0]):
        n = cand_count[k]
        if n == 0:
            continue
        a = cand_a[k]
        b = cand_b[k]
        body_a = shape_body[a]
        body_b = shape_body[b]
        m_shape_a[m] = a
        m_shape_b[m] = b
        m_body_a[m] = body_a
        m_body_b[m] = body_b
        m_first[m] = c
        m_count[m] = n
        for i in range(3):
            m_normal[m, i] = cand_normal[k, i]
        key = (a << (2 * KEY_BITS)) | (b << KEY_BITS)
        own_normals = shape_type[b] == SHAPE_MESH
        for j in range(n):
            c_manifold[c] = m
            c_body_a[c] = body_a
            c_body_b[c] = body_b
            for i in range(3):
                c_point[c, i] = cand_point[k, j, i]
                c_normal[c, i] = cand_point_normal[k, j, i] if own_normals else cand_normal[k, i]
            c_separation[c] = cand_separation[k, j]
            c_feature[c] = cand_feature[k, j]
            c_key[c] = key | cand_feature[k, j]
            c += 1
        m += 1
    return m, c


def collide_pairs(pair_a, pair_b, table, shape_pos, shape_rot, shape_aabb, speculative,
                  out: ContactManifolds | None = None, shape_margin=None, excluded_pairs=None,
                  body_filter=None) -> ContactManifolds:
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
        excluded_pairs: sorted (K,) int64 keys lo * N + hi of body pairs that get no contact.
        body_filter: (N, 3) int64 rows (category, mask, group) of the bodies' collision
            filters (``filter.filter_table``), or None / (0, 3): every pair may collide.

    Returns:
        ``out``, filled: manifolds in pair order (sweep pairs by (a, b), then planes).
    """
    if out is None:
        out = ContactManifolds()
    S = table.shape_count
    if S >= 1 << KEY_BITS:
        raise ValueError(f"contact keys hold shape indices below {1 << KEY_BITS}; got {S} shapes")
    planes = np.flatnonzero(table.shape_type == SHAPE_PLANE).astype(np.int64)
    total = len(pair_a) + len(planes) * S
    if total == 0:  # nothing near anything: no call, so a world without contacts never compiles the pair routines
        out.manifold_count = out.contact_count = 0
        return out
    out.reserve(total)
    cand = out.candidates(total)
    if shape_margin is None:
        shape_margin = np.full(S, float(speculative))
    parallel = total >= PARALLEL_MIN_CANDIDATES
    if table.analytic_only:
        kernel = _ANALYTIC_KERNELS[table.analytic_family][0 if parallel else 1]
    else:
        kernel = _collide_candidates_parallel_kernel if parallel else _collide_candidates_kernel
    kernel(np.ascontiguousarray(pair_a, dtype=np.int64), np.ascontiguousarray(pair_b, dtype=np.int64),
                               planes, table.shape_type, table.shape_body, table.shape_params, shape_pos, shape_rot,
                               shape_aabb, table.body_moving, float(speculative), shape_margin, table.geometry,
                               _NO_PAIRS if excluded_pairs is None else excluded_pairs,
                               NO_FILTER if body_filter is None else body_filter, *cand)
    m, c = _compact_manifolds_kernel(*cand, table.shape_type, table.shape_body, *out.buffers())
    out.manifold_count = m
    out.contact_count = c
    return out
