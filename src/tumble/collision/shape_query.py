"""Queries with a shape that is not in the world (Box2D's ``b2World_CastShape`` and
``b2World_OverlapShape``, Bullet's ``convexSweepTest``, pymunk's ``shape_query``): where a shape
moved along a straight line first touches something, and which bodies a shape placed somewhere
overlaps. For placing an object, a character's or a gripper's path, a spawn point that is free.

The query shape is a sphere, capsule, cylinder, cone, box or convex hull (``tumble.shapes``), at
``position`` (where its shape origin is, as ``World.add_body``'s) and ``orientation`` (a unit
quaternion (w, x, y, z), identity by default). It is measured against every collision shape of
the world at the bodies' current poses by the closest-points routines (``distance.convex_to_shape``:
GJK and EPA, planes exactly, static meshes triangle by triangle), so the answers are exact to
those routines' accuracy.

Shape cast: the shape translated by ``translation`` (m, world; no rotation), fraction t in [0, 1]
of it: the first t where its distance to a shape of the world reaches zero, by conservative
advancement (Mirtich 1996; Box2D's ``b2ShapeCast`` does the same): from t, the distance d and the
normal n (from the moving shape to the other) give the next t += d / (translation . n). Along a
translation the distance between two convex shapes is a convex function of t, so each step
lands on or before the contact, never past it, and a pair moving apart (translation . n <= 0) is
never hit; it stops within ``CAST_TOLERANCE`` of touching. A static mesh is advanced against
triangle by triangle (the distance to a union of triangles is not convex). A shape that already
overlaps something at t = 0 hits it at t = 0 (Box2D's rule).

Overlap: the bodies with a shape at signed distance <= 0 from the query shape (touching counts).

Bodies whose filter does not meet the query's ``mask`` / ``category`` (as ``World.ray_cast``'s),
sensors and the ``exclude`` body are not seen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from ..errors import InputError
from ..math3d import JIT, NO_NRT, matrix_to_quat, quat_to_matrix, serial_twin
from ..shapes import SHAPE_CONVEX, SHAPE_MESH, Box, Capsule, Cone, Convex, Cylinder, Ellipsoid, Sphere
from .distance import convex_distance, convex_to_shape, shape_poses
from .filter import ALL_CATEGORIES
from .geometry import shape_params
from .pairs.gjk import core_radius, gjk_scratch, support
from .pairs.mesh import TRIANGLE
from .raycast import HitRows, _rays, _seen, rows

CAST_TOLERANCE = 1e-9  # m: a cast stops when the gap is this small
CAST_ITERATIONS = 64  # advancement steps per pair of shapes (a handful are used; a grazing approach halves its gap a step)
CASTS_PER_CHUNK = 8
PARALLEL_MIN_CASTS = 16  # fewer casts run on the calling thread


@dataclass
class ShapeHits(HitRows):
    """What ``shape_cast`` found, one row per cast (K casts).

    body: (K,) int64, the body first touched, -1 where nothing was.
    shape: (K,) int64, its shape-table row (a compound's part), -1 where nothing was.
    fraction: (K,) of the translation travelled when it touches, in [0, 1] (0: it overlapped at the
        start); inf where nothing was touched.
    position: (K, 3) m, world, where the shape's origin is then (position + fraction * translation);
        NaN where nothing was touched.
    point: (K, 3) m, world, the touching point on the body hit; NaN likewise.
    normal: (K, 3) unit, world, the hit body's surface normal there, towards the moving shape (the
        direction that would push it back out); NaN likewise.
    """

    body: np.ndarray
    shape: np.ndarray
    fraction: np.ndarray
    position: np.ndarray
    point: np.ndarray
    normal: np.ndarray


# ---------------------------------------------------------------------- kernels
@njit(**NO_NRT)
def _query_box(tq, pos, rot, params, verts, grow, box):
    """The query shape's world box (2, 3) from its supports along the world axes, grown by ``grow``."""
    r = core_radius(tq, params) + grow
    for k in range(3):
        ax = 1.0 if k == 0 else 0.0
        ay = 1.0 if k == 1 else 0.0
        az = 1.0 if k == 2 else 0.0
        p = support(tq, pos, rot, params, verts, ax, ay, az)
        q = support(tq, pos, rot, params, verts, -ax, -ay, -az)
        box[1, k] = p[k] + r
        box[0, k] = q[k] - r


@njit(**NO_NRT)
def _may_touch(s, exclude, seen, shape_body, shape_aabb, box):
    """Shape row s is seen by the query (its body not ``exclude``, ``seen``) and its box meets ``box`` (2, 3)."""
    b = shape_body[s]
    if b == exclude or not seen[b]:
        return False
    for k in range(3):
        if shape_aabb[s, 0, k] > box[1, k] or shape_aabb[s, 1, k] < box[0, k]:
            return False
    return True


@njit(**NO_NRT)
def _first_touch(tq, p0, rot_q, params_q, verts_q, trans, length, s, tri, shape_type, shape_params, shape_pos,
                 shape_rot, shape_data, hull_vertex, mesh_triangle, node_aabb, node_first, node_count, node_skip,
                 t_limit, scratch, lo, hi, work, pos, out):
    """Conservative advancement (module docstring) of the query shape from p0 along ``trans`` (3,)
    (``length`` its norm, m) against shape row s, or against triangle ``tri`` of mesh row s (tri >=
    0): the first fraction t <= t_limit at which they touch, inf if none; ``out`` (9,) then holds
    the points and normal (query to s) there."""
    t = 0.0
    for _ in range(CAST_ITERATIONS):
        for k in range(3):
            pos[k] = p0[k] + t * trans[k]
        # farther than the path left before the best hit so far: no earlier hit here
        cutoff = (t_limit - t) * length + CAST_TOLERANCE
        if tri >= 0:
            d = convex_distance(tq, pos, rot_q, params_q, verts_q, TRIANGLE, shape_pos[s], shape_rot[s],
                                shape_params[s], mesh_triangle[tri], cutoff, scratch, out)
        else:
            d = convex_to_shape(tq, pos, rot_q, params_q, verts_q, s, shape_type, shape_params, shape_pos, shape_rot,
                                shape_data, hull_vertex, mesh_triangle, node_aabb, node_first, node_count, node_skip,
                                cutoff, scratch, lo, hi, work, out)
        if d == np.inf:
            return np.inf
        if d <= CAST_TOLERANCE:
            return t
        closing = trans[0] * out[6] + trans[1] * out[7] + trans[2] * out[8]
        if closing <= 0.0:
            return np.inf  # moving apart: the distance along a translation is convex, it only grows now
        t += d / closing
        if t > t_limit:
            return np.inf
    return t  # not closer than CAST_TOLERANCE after CAST_ITERATIONS steps: still before the contact


@njit(**NO_NRT)
def _keep_first(t, best, found, s, c, out, hit_point, hit_normal):
    """(best, found) after a touch of shape s at fraction t: kept, with its point and normal (the hit
    shape's, towards the cast shape) in row c, when it is the first so far (ties: the first shape)."""
    if t < best or (found < 0 and t <= best):
        for k in range(3):
            hit_point[c, k] = out[3 + k]
            hit_normal[c, k] = -out[6 + k]
        return t, s
    return best, found


@njit(**NO_NRT)
def _cast_one(c, tq, params_q, verts_q, rot_q, start, translation, exclude, seen, shape_type, shape_body, shape_params,
              shape_pos, shape_rot, shape_aabb, shape_data, hull_vertex, mesh_triangle, node_aabb, node_first,
              node_count, node_skip, scratch, lo, hi, work, pos, out, box, swept,
              # outputs
              hit_shape, hit_fraction, hit_point, hit_normal):
    """Cast c of ``shape_cast_kernel``."""
    trans = translation[c]
    length = math.sqrt(trans[0] ** 2 + trans[1] ** 2 + trans[2] ** 2)
    _query_box(tq, start[c], rot_q, params_q, verts_q, CAST_TOLERANCE, box)
    for k in range(3):  # the box the shape sweeps
        swept[0, k] = box[0, k] + min(trans[k], 0.0)
        swept[1, k] = box[1, k] + max(trans[k], 0.0)
    best = 1.0
    found = -1
    for s in range(shape_type.shape[0]):
        if not _may_touch(s, exclude[c], seen, shape_body, shape_aabb, swept):
            continue
        if shape_type[s] == SHAPE_MESH:
            # triangle by triangle, those whose box meets the swept box (mesh frame: the swept box's
            # corners taken into it)
            rs = shape_rot[s]
            ps = shape_pos[s]
            for k in range(3):
                lo[k] = np.inf
                hi[k] = -np.inf
            for corner in range(8):
                cx = swept[(corner >> 0) & 1, 0] - ps[0]
                cy = swept[(corner >> 1) & 1, 1] - ps[1]
                cz = swept[(corner >> 2) & 1, 2] - ps[2]
                for k in range(3):
                    v = rs[0, k] * cx + rs[1, k] * cy + rs[2, k] * cz
                    lo[k] = min(lo[k], v)
                    hi[k] = max(hi[k], v)
            box[0, 0], box[0, 1], box[0, 2] = lo[0], lo[1], lo[2]
            box[1, 0], box[1, 1], box[1, 2] = hi[0], hi[1], hi[2]
            i = shape_data[s, 2]
            n_end = i + shape_data[s, 3]
            while i < n_end:
                meets = True
                for k in range(3):
                    if node_aabb[i, 0, k] > box[1, k] or node_aabb[i, 1, k] < box[0, k]:
                        meets = False
                if not meets:
                    i = node_skip[i]
                    continue
                for tri in range(node_first[i], node_first[i] + node_count[i]):
                    t = _first_touch(tq, start[c], rot_q, params_q, verts_q, trans, length, s, tri, shape_type,
                                     shape_params, shape_pos, shape_rot, shape_data, hull_vertex, mesh_triangle,
                                     node_aabb, node_first, node_count, node_skip, best, scratch, lo, hi, work, pos,
                                     out)
                    best, found = _keep_first(t, best, found, s, c, out, hit_point, hit_normal)
                i += 1
            continue
        t = _first_touch(tq, start[c], rot_q, params_q, verts_q, trans, length, s, np.int64(-1), shape_type,
                         shape_params, shape_pos, shape_rot, shape_data, hull_vertex, mesh_triangle, node_aabb,
                         node_first, node_count, node_skip, best, scratch, lo, hi, work, pos, out)
        best, found = _keep_first(t, best, found, s, c, out, hit_point, hit_normal)
    hit_shape[c] = found
    hit_fraction[c] = best if found >= 0 else np.inf


@njit(**JIT, parallel=True)
def shape_cast_kernel(tq, params_q, verts_q, rot_q, start, translation, exclude, seen, shape_type, shape_body,
                      shape_params, shape_pos, shape_rot, shape_aabb, shape_data, hull_vertex, mesh_triangle,
                      node_aabb, node_first, node_count, node_skip,
                      # outputs
                      hit_shape, hit_fraction, hit_point, hit_normal):
    """For each cast c: the query shape (type tq, params (4,), hull vertices (V, 3), rotation (3, 3))
    from start[c] (K, 3) m along translation[c] (K, 3) m: the first shape it touches (hit_shape[c],
    -1: none; bodies ``exclude[c]`` and those with ``seen`` False skipped), the fraction, the
    point on that shape and its normal towards the query shape (module docstring). Shape poses
    and boxes as ``update_bounds`` leaves them."""
    count = start.shape[0]
    chunks = (count + CASTS_PER_CHUNK - 1) // CASTS_PER_CHUNK
    for chunk in prange(chunks):
        scratch = gjk_scratch()
        lo = np.empty(3)
        hi = np.empty(3)
        work = np.empty(9)
        pos = np.empty(3)
        out = np.empty(9)
        box = np.empty((2, 3))
        swept = np.empty((2, 3))
        for c in range(chunk * CASTS_PER_CHUNK, min(count, (chunk + 1) * CASTS_PER_CHUNK)):
            _cast_one(c, tq, params_q, verts_q, rot_q, start, translation, exclude, seen, shape_type, shape_body,
                      shape_params, shape_pos, shape_rot, shape_aabb, shape_data, hull_vertex, mesh_triangle,
                      node_aabb, node_first, node_count, node_skip, scratch, lo, hi, work, pos, out, box, swept,
                      hit_shape, hit_fraction, hit_point, hit_normal)


shape_cast_serial_kernel = serial_twin(shape_cast_kernel, "shape_cast_serial_kernel")


@njit(**JIT)
def overlap_shape_kernel(tq, params_q, verts_q, pos_q, rot_q, exclude, seen, shape_type, shape_body, shape_params,
                         shape_pos, shape_rot, shape_aabb, shape_data, hull_vertex, mesh_triangle, node_aabb,
                         node_first, node_count, node_skip,
                         # output
                         touched):
    """touched[b] (N,) bool set for each body b (seen, not ``exclude``) with a shape at signed distance
    <= 0 from the query shape at pos_q, rot_q."""
    scratch = gjk_scratch()
    lo = np.empty(3)
    hi = np.empty(3)
    work = np.empty(9)
    out = np.empty(9)
    box = np.empty((2, 3))
    _query_box(tq, pos_q, rot_q, params_q, verts_q, CAST_TOLERANCE, box)
    for s in range(shape_type.shape[0]):
        b = shape_body[s]
        if touched[b] or not _may_touch(s, exclude, seen, shape_body, shape_aabb, box):
            continue
        d = convex_to_shape(tq, pos_q, rot_q, params_q, verts_q, s, shape_type, shape_params, shape_pos, shape_rot,
                            shape_data, hull_vertex, mesh_triangle, node_aabb, node_first, node_count, node_skip, 0.0,
                            scratch, lo, hi, work, out)
        if d <= 0.0:
            touched[b] = True


# ---------------------------------------------------------------------- the queries
QUERY_SHAPES = (Sphere, Capsule, Cylinder, Cone, Box, Ellipsoid, Convex)


def _query_shape(shape):
    """(type, params (4,), hull vertices (V, 3)) of a query shape, or InputError."""
    if not isinstance(shape, QUERY_SHAPES):
        raise InputError(f"must be a Sphere, Capsule, Cylinder, Cone, Box, Ellipsoid or Convex, got {type(shape).__name__}",
                         "shape")
    t, p = shape_params(shape)
    verts = np.ascontiguousarray(shape.vertices, dtype=float) if t == SHAPE_CONVEX else np.zeros((0, 3))
    return t, np.array(p, dtype=float), verts


def _rotation(orientation) -> np.ndarray:
    if orientation is None:
        return np.eye(3)
    q = np.asarray(orientation, dtype=float)
    if q.shape != (4,) or not np.all(np.isfinite(q)) or np.linalg.norm(q) == 0.0:
        raise InputError(f"must be a quaternion (w, x, y, z), got {orientation!r}", "orientation")
    return quat_to_matrix(q / np.linalg.norm(q))


def _points(name: str, value) -> np.ndarray:
    """(K, 3) finite m from a 3-vector or a (K, 3) array: the ray casts' own check (``raycast._rays``)."""
    return _rays(name, value, None)


def _exclude(world, exclude) -> int:
    if exclude is None:
        return -1
    try:
        return world.index_of(exclude)
    except InputError as err:
        raise InputError(err.problem, "exclude") from None


def shape_cast(world, shape, position, translation, orientation=None, exclude=None, mask=ALL_CATEGORIES,
               category=ALL_CATEGORIES) -> ShapeHits:
    """Where ``shape`` moved from ``position`` by ``translation`` first touches a body (module docstring).

    Args:
        world: a ``tumble.World``, at its bodies' current poses.
        shape: a Sphere, Capsule, Cylinder, Cone, Box, Ellipsoid or Convex record (not added to the world).
        position: (3,) or (K, 3) m, world: where the shape's origin starts.
        translation: (3,) or (K, 3) m, world: the straight move (no rotation); K casts at once.
        orientation: (4,) unit quaternion (w, x, y, z), the shape's turn (default none).
        exclude: a body (``Body``, name or index) the casts do not see.
        mask, category: the query's filter, as ``World.ray_cast``'s. Sensors are never seen.

    Returns:
        ``ShapeHits`` with a row per cast.
    """
    tq, params, verts = _query_shape(shape)
    rot = _rotation(orientation)
    start = _points("position", position)
    trans = _points("translation", translation)
    if len(start) != len(trans) and 1 not in (len(start), len(trans)):
        raise InputError(f"has {len(trans)} rows but position has {len(start)}", "translation")
    K = max(len(start), len(trans))
    start = rows(start, K)
    trans = rows(trans, K)
    skip = np.full(K, _exclude(world, exclude), dtype=np.int64)
    seen = _seen(world, mask, category)
    scene, pos, rot_s, aabb = shape_poses(world)
    table = scene.table
    shape_row = np.full(K, -1, dtype=np.int64)
    fraction = np.full(K, np.inf)
    point = np.full((K, 3), np.nan)
    normal = np.full((K, 3), np.nan)
    if table.shape_count:
        kernel = shape_cast_kernel if K >= PARALLEL_MIN_CASTS else shape_cast_serial_kernel
        kernel(tq, params, verts, rot, start, trans, skip, seen, table.shape_type, table.shape_body, table.shape_params,
               pos, rot_s, aabb, table.shape_data, table.hull_vertex, table.mesh_triangle, table.mesh_node_aabb,
               table.mesh_node_first, table.mesh_node_count, table.mesh_node_skip, shape_row, fraction, point, normal)
    hit = shape_row >= 0
    body = np.full(K, -1, dtype=np.int64)
    body[hit] = table.shape_body[shape_row[hit]]
    point[~hit] = np.nan
    normal[~hit] = np.nan
    where = np.full((K, 3), np.nan)
    where[hit] = start[hit] + fraction[hit, None] * trans[hit]
    return ShapeHits(body=body, shape=shape_row, fraction=fraction, position=where, point=point, normal=normal)


def overlap_shape(world, shape, position, orientation=None, exclude=None, mask=ALL_CATEGORIES,
                  category=ALL_CATEGORIES) -> np.ndarray:
    """Sorted (K,) int64 indices of the bodies with a shape that ``shape`` at ``position`` ((3,) m,
    world, its origin) and ``orientation`` overlaps or touches (signed distance <= 0), at the
    bodies' current poses; ``exclude``, ``mask`` and ``category`` as ``shape_cast``'s. A static mesh
    is a surface: a shape wholly inside a closed mesh, touching none of its triangles, is not
    found."""
    tq, params, verts = _query_shape(shape)
    rot = _rotation(orientation)
    p = _points("position", position)
    if len(p) != 1:
        raise InputError(f"must be one 3-vector, got shape {np.shape(position)}", "position")
    seen = _seen(world, mask, category)
    scene, pos, rot_s, aabb = shape_poses(world)
    table = scene.table
    touched = np.zeros(world.body_count, dtype=bool)
    if table.shape_count:
        overlap_shape_kernel(tq, params, verts, p[0], rot, _exclude(world, exclude), seen, table.shape_type,
                             table.shape_body, table.shape_params, pos, rot_s, aabb, table.shape_data,
                             table.hull_vertex, table.mesh_triangle, table.mesh_node_aabb, table.mesh_node_first,
                             table.mesh_node_count, table.mesh_node_skip, touched)
    return np.flatnonzero(touched).astype(np.int64)


def drop(world, body, direction=None, max_distance: float = 1000.0) -> float:
    """Move ``body`` (``Body``, name or index) straight along ``direction`` (default: gravity's; -z
    without gravity) until it touches another body, as a shape cast of each of its shapes (each part
    of a compound); returns the distance moved (m; 0 if it already touches something). Only what the
    body itself would collide with stops it (its collision filter, as the query's mask and
    category); sensors never do. For setting a scene up (``drop = true`` in a scene file): dice on a
    table, rocks on a terrain, a stack laid from the bottom up.

    Raises:
        InputError: an unknown body, a shape that cannot be cast (plane, mesh, particles), a zero
            direction, or nothing within ``max_distance`` m (the key ``drop``).
    """
    from .geometry import flatten_parts

    i = world.index_of(body)
    d = np.asarray(world.gravity if direction is None else direction, dtype=float)
    if d.shape != (3,) or not np.all(np.isfinite(d)):
        raise InputError(f"must be a 3-vector, got {direction!r}", "direction")
    if not np.any(d):
        if direction is not None:
            raise InputError("must not be zero", "direction")
        d = np.array([0.0, 0.0, -1.0])
    if not (max_distance > 0.0 and math.isfinite(max_distance)):
        raise InputError(f"must be a positive number of metres, got {max_distance!r}", "max_distance")
    translation = d / np.linalg.norm(d) * max_distance
    R = np.asarray(world.R[i], dtype=float)
    origin = np.asarray(world.x[i], dtype=float) - R @ np.asarray(world.com_offset[i], dtype=float)
    own = world.collision_filters[i]
    best = np.inf
    for part, p, q in flatten_parts(world.shapes[i]):
        if not isinstance(part, QUERY_SHAPES):
            raise InputError(f"a body of {type(part).__name__} shape cannot be dropped (only spheres, capsules, "
                             "cylinders, cones, boxes, convex hulls and compounds of them)", "drop")
        Rp = R @ quat_to_matrix(np.asarray(q, dtype=float))
        hit = shape_cast(world, part, origin + R @ np.asarray(p, dtype=float), translation,
                         orientation=matrix_to_quat(np.ascontiguousarray(Rp)), exclude=i, mask=own.mask, category=own.category)
        if hit.hit[0]:
            best = min(best, float(hit.fraction[0]))
    if not math.isfinite(best):
        raise InputError(f"nothing to land on within {max_distance:g} m along {d.tolist()}", "drop")
    moved = best * max_distance
    world.body(i).x = np.asarray(world.x[i]) + best * translation
    return moved

