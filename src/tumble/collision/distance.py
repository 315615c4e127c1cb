"""Closest points and signed distance between bodies (a scene query): PyBullet's
``getClosestPoints``, MuJoCo's ``mj_geomDistance``, Box2D's ``b2ShapeDistance``.

For each pair of bodies (a, b), over every pair of their collision shapes (each part of a
compound), at the bodies' current poses:

- the signed distance d (m): the gap between the two surfaces when they are apart (d > 0), and
  minus the penetration depth when they overlap (d < 0: the shortest translation of b that
  separates them, the quantity the contact solver works on);
- the points: ``point_a`` on a's surface and ``point_b`` on b's, with
  ``point_b = point_a + d * normal``; apart, the two closest points; overlapping, the deepest
  point of each inside the other;
- ``normal``: unit, world, from a to b (moving b by -d along it makes the shapes touch, for
  either sign of d).

The pair of shapes with the smallest d gives the body pair's row (the first in shape order on a
tie). Every collision shape of the two bodies counts (a sensor's too): it is a measurement of
geometry, so collision filters and excluded pairs do not apply. Pairs of shapes farther apart than ``max_distance`` are not measured (GJK stops as soon as
it has a lower bound beyond it), so a finite ``max_distance`` makes far pairs cheap, as
PyBullet's ``distance`` argument.

How each pair is measured:
- two convex shapes (sphere, capsule, cylinder, cone, box, convex hull): GJK on their cores
  (``pairs.gjk.gjk``: a sphere is its centre and a capsule its segment, the radius added after,
  so rounded shapes stay exact), to a relative 1e-9 (``GJK_REL``); cores that overlap go to
  EPA (``pairs.gjk.epa``, to 1e-9 m) for the depth and its direction;
- a plane and a convex shape: the shape's support point along the plane's inward normal, exact;
  a plane and a static mesh: the mesh's lowest corner;
- a convex shape and a static triangle mesh (or heightfield): GJK/EPA against each triangle
  whose box comes within the best distance so far, through the mesh's BVH. A mesh is a surface:
  a shape that crosses it gets the depth through the nearest triangle it overlaps (its EPA
  depth against that triangle), not a depth below a solid;
- two planes, or two meshes, are not measured (distance inf): both shapes are fixed in tumble
  (they never collide), and two planes have no finite answer unless parallel.

Accuracy: apart, distance, points and normal to GJK's relative 1e-9; overlapping polytopes
(boxes, hulls), the same through EPA (to 1e-9 m); overlapping where a cylinder's or cone's curved
side or rim holds the deepest point, the depth to 1e-9 m but the points and normal only to about
1e-5 m and 1e-4 rad (EPA's polytope approximates the curved surface; the depth, a minimum over
directions, is accurate to second order in the normal's error). tests/collision/test_closest_points.py.

Pairs of bodies are spread over the cores in chunks, each writing only its own rows (the bits
do not depend on the thread count); fewer than ``PARALLEL_MIN_PAIRS`` run on the calling thread.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from ..errors import InputError
from ..math3d import JIT, NO_NRT, serial_twin
from ..shapes import SHAPE_CAPSULE, SHAPE_CONVEX, SHAPE_MESH, SHAPE_PLANE
from .bounds import update_bounds, update_bounds_rows
from .filter import ALL_CATEGORIES
from .pairs.gjk import SHAPE_TRIANGLE, TOUCH, core_radius, epa, gjk, gjk_scratch, support
from .pairs.mesh import TRIANGLE
from .raycast import rows


@dataclass
class ClosestPoints:
    """What ``closest_points`` found, one row per pair of bodies (P pairs).

    distance: (P,) m, signed: the gap between the surfaces (> 0) or minus the penetration depth
        (< 0); inf where no pair of shapes is within ``max_distance`` (or a body has no shape).
    point_a: (P, 3) m, world, on body a's surface; NaN where distance is inf.
    point_b: (P, 3) m, world, on body b's surface, ``point_a + distance * normal``; NaN likewise.
    normal: (P, 3) unit, world, from a to b; NaN likewise.
    shape_a, shape_b: (P,) int64, rows of the World's shape table (a compound has a row per
        part) of the two shapes measured; -1 where distance is inf.
    body_a, body_b: (P,) int64, the bodies of each pair.
    """

    distance: np.ndarray
    point_a: np.ndarray
    point_b: np.ndarray
    normal: np.ndarray
    shape_a: np.ndarray
    shape_b: np.ndarray
    body_a: np.ndarray = None
    body_b: np.ndarray = None

    @property
    def found(self) -> np.ndarray:
        """(P,) bool: the pair was measured within ``max_distance``."""
        return np.isfinite(self.distance)

    def __len__(self) -> int:
        return len(self.distance)


# ---------------------------------------------------------------------- one pair of shapes
@njit(**NO_NRT)
def _flat_normal(ta, pos_a, rot_a, tb, pos_b, rot_b, verts_b):
    """A normal from a to b for two cores that touch where A - B has no volume (EPA cannot start):
    two capsule segments that cross (their common perpendicular), a point or segment in a mesh
    triangle (the triangle's normal, from the a side), else the centre line, else +z."""
    if tb == SHAPE_TRIANGLE:
        ux, uy, uz = verts_b[1, 0] - verts_b[0, 0], verts_b[1, 1] - verts_b[0, 1], verts_b[1, 2] - verts_b[0, 2]
        vx, vy, vz = verts_b[2, 0] - verts_b[0, 0], verts_b[2, 1] - verts_b[0, 1], verts_b[2, 2] - verts_b[0, 2]
        lx, ly, lz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        nx = rot_b[0, 0] * lx + rot_b[0, 1] * ly + rot_b[0, 2] * lz
        ny = rot_b[1, 0] * lx + rot_b[1, 1] * ly + rot_b[1, 2] * lz
        nz = rot_b[2, 0] * lx + rot_b[2, 1] * ly + rot_b[2, 2] * lz
        n = math.sqrt(nx * nx + ny * ny + nz * nz)
        if n > 0.0:
            return -nx / n, -ny / n, -nz / n  # the triangle's front (outward) side faces a
    gx, gy, gz = pos_b[0] - pos_a[0], pos_b[1] - pos_a[1], pos_b[2] - pos_a[2]
    if ta == SHAPE_CAPSULE and tb == SHAPE_CAPSULE:
        cx = rot_a[1, 2] * rot_b[2, 2] - rot_a[2, 2] * rot_b[1, 2]
        cy = rot_a[2, 2] * rot_b[0, 2] - rot_a[0, 2] * rot_b[2, 2]
        cz = rot_a[0, 2] * rot_b[1, 2] - rot_a[1, 2] * rot_b[0, 2]
        c = math.sqrt(cx * cx + cy * cy + cz * cz)
        if c > 1e-9:
            s = -1.0 if cx * gx + cy * gy + cz * gz < 0.0 else 1.0
            return s * cx / c, s * cy / c, s * cz / c
    g = math.sqrt(gx * gx + gy * gy + gz * gz)
    if g > 0.0:
        return gx / g, gy / g, gz / g
    return 0.0, 0.0, 1.0


@njit(**NO_NRT)
def convex_distance(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b, cutoff, scratch, out):
    """Signed distance (m) of two convex shapes (sphere, capsule, cylinder, cone, box, hull, or a
    mesh triangle: ``SHAPE_TRIANGLE`` with its corners as ``verts``), or inf when it is above
    ``cutoff``. Writes point_a, point_b, normal (world) into out[0:3], out[3:6], out[6:9].
    ``scratch``: a ``gjk_scratch()``."""
    ra = core_radius(ta, params_a)
    rb = core_radius(tb, params_b)
    k, dist, pa, pb = gjk(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b,
                          cutoff + ra + rb, scratch)
    if k == 0:
        return np.inf  # the cores are farther apart than the cutoff (GJK's lower bound)
    # GJK's distance down to its own touching threshold (1e-9 m), not the contacts' TOUCH_GAP (1e-7 m,
    # below which they take EPA's normal): EPA gives a depth of about 0 for cores that touch, and with
    # 1e-7 a gap of 2.6e-8 m came out as 0 (a shape cast stopped that far short, measured)
    if dist > TOUCH:
        nx, ny, nz = (pb[0] - pa[0]) / dist, (pb[1] - pa[1]) / dist, (pb[2] - pa[2]) / dist
        d = dist - ra - rb
    else:
        ok, depth, nrm, qa, qb = epa(ta, pos_a, rot_a, params_a, verts_a, tb, pos_b, rot_b, params_b, verts_b,
                                     k, scratch)
        if ok:
            pa, pb = qa, qb
        else:
            # A - B is flat (a point or segment core, a triangle): the cores touch or cross without
            # volume, so the depth is the radii's; GJK's points are where they meet
            nrm = _flat_normal(ta, pos_a, rot_a, tb, pos_b, rot_b, verts_b)
            depth = 0.0
        nx, ny, nz = nrm
        d = -depth - ra - rb
    if d > cutoff:
        return np.inf
    out[0] = pa[0] + ra * nx
    out[1] = pa[1] + ra * ny
    out[2] = pa[2] + ra * nz
    # point_b from point_a, so that point_b = point_a + d n holds to round-off (EPA's two deepest
    # points agree with its depth and normal only to its tolerance, 1e-9 m)
    out[3] = out[0] + d * nx
    out[4] = out[1] + d * ny
    out[5] = out[2] + d * nz
    out[6] = nx
    out[7] = ny
    out[8] = nz
    return d


@njit(**NO_NRT)
def _plane(pos, rot, params):
    """World unit normal (tuple) and offset of a plane shape: n . p = d on it, solid below."""
    nx = rot[0, 0] * params[0] + rot[0, 1] * params[1] + rot[0, 2] * params[2]
    ny = rot[1, 0] * params[0] + rot[1, 1] * params[1] + rot[1, 2] * params[2]
    nz = rot[2, 0] * params[0] + rot[2, 1] * params[1] + rot[2, 2] * params[2]
    return (nx, ny, nz), params[3] + nx * pos[0] + ny * pos[1] + nz * pos[2]


@njit(**NO_NRT)
def _plane_distance(pos_p, rot_p, params_p, t, pos, rot, params, verts, tri_first, tri_end, mesh_triangle, cutoff,
                    out):
    """Signed distance of shape t (convex, or a mesh: its triangles ``mesh_triangle[tri_first:
    tri_end]``) above the plane; its lowest point in out[3:6], that point's foot on the plane
    in out[0:3], the plane's normal in out[6:9] (from the plane to the shape). inf above cutoff."""
    n, off = _plane(pos_p, rot_p, params_p)
    if t == SHAPE_MESH:
        best = np.inf
        px, py, pz = 0.0, 0.0, 0.0
        for tri in range(tri_first, tri_end):
            for c in range(3):
                lx, ly, lz = mesh_triangle[tri, c, 0], mesh_triangle[tri, c, 1], mesh_triangle[tri, c, 2]
                wx = pos[0] + rot[0, 0] * lx + rot[0, 1] * ly + rot[0, 2] * lz
                wy = pos[1] + rot[1, 0] * lx + rot[1, 1] * ly + rot[1, 2] * lz
                wz = pos[2] + rot[2, 0] * lx + rot[2, 1] * ly + rot[2, 2] * lz
                h = n[0] * wx + n[1] * wy + n[2] * wz - off
                if h < best:
                    best, px, py, pz = h, wx, wy, wz
        d = best
    else:
        r = core_radius(t, params)
        s = support(t, pos, rot, params, verts, -n[0], -n[1], -n[2])
        px, py, pz = s[0] - r * n[0], s[1] - r * n[1], s[2] - r * n[2]
        d = n[0] * px + n[1] * py + n[2] * pz - off
    if d > cutoff:
        return np.inf
    out[0], out[1], out[2] = px - d * n[0], py - d * n[1], pz - d * n[2]
    out[3], out[4], out[5] = px, py, pz
    out[6], out[7], out[8] = n[0], n[1], n[2]
    return d


@njit(**NO_NRT)
def _node_gap(node_aabb, i, lo, hi):
    """Squared distances from the box ``lo``, ``hi`` to node i's box, and from its centre to node i's box."""
    gap = 0.0
    centre = 0.0
    for k in range(3):
        g = max(node_aabb[i, 0, k] - hi[k], lo[k] - node_aabb[i, 1, k], 0.0)
        gap += g * g
        c = 0.5 * (lo[k] + hi[k])
        g = max(node_aabb[i, 0, k] - c, c - node_aabb[i, 1, k], 0.0)
        centre += g * g
    return gap, centre


@njit(**NO_NRT)
def _leaf_distance(ta, pos_a, rot_a, params_a, verts_a, pos_m, rot_m, params_m, mesh_triangle, t0, t1, lo, hi, best,
                   found, found_t, scratch, work, out):
    """Triangles t0 to t1 - 1 of a leaf against convex shape a, whose box in the mesh frame is ``lo``,
    ``hi`` (``_mesh_distance``): the smallest distance, the first triangle on a tie, updates ``found``
    (its points in ``out``), ``found_t`` and ``best`` (the cutoff of the triangles after it). A
    triangle whose own box is farther than ``best`` from a's is passed over as a node is: a
    heightfield's leaves can mix its surface with its long base and side triangles, boxes that span
    the field (a box resting on 8192 triangles: 68 triangles in the leaves the walk reaches, 3 within
    reach by their own boxes)."""
    for t in range(t0, t1):
        gap = 0.0
        for k in range(3):
            tlo = min(mesh_triangle[t, 0, k], mesh_triangle[t, 1, k], mesh_triangle[t, 2, k])
            thi = max(mesh_triangle[t, 0, k], mesh_triangle[t, 1, k], mesh_triangle[t, 2, k])
            g = max(tlo - hi[k], lo[k] - thi, 0.0)
            gap += g * g
        if gap > 0.0 and math.sqrt(gap) > best:
            continue
        d = convex_distance(ta, pos_a, rot_a, params_a, verts_a, TRIANGLE, pos_m, rot_m, params_m,
                            mesh_triangle[t], best, scratch, work)
        if d < found or (d == found and t < found_t):
            found = d
            found_t = t
            best = min(best, d)
            for c in range(9):
                out[c] = work[c]
    return best, found, found_t


@njit(**NO_NRT)
def _mesh_distance(ta, pos_a, rot_a, params_a, verts_a, pos_m, rot_m, params_m, m, shape_data, mesh_triangle,
                   node_aabb, node_first, node_count, node_skip, cutoff, scratch, lo, hi, work, out):
    """Signed distance of convex shape a to static mesh shape row m (module docstring: through the
    nearest triangle), inf above cutoff; points and normal (a to the mesh) in ``out`` as
    ``convex_distance``. ``lo``, ``hi`` (3,), ``work`` (9,) scratch. Walks the mesh's BVH, passing over
    nodes whose box is farther from a's box (mesh frame) than the best distance so far.

    Nearest first: the best distance starts at the triangles of the leaf reached by going down to
    the nearer child each time (by their boxes' distance to a's box, then to its centre), so the walk
    prunes from its first node (before, it started at the cutoff, inf by default: 0.3-1.2 ms per
    box-heightfield pair at any height), and in a leaf only the triangles whose own box is within
    reach are measured (``_leaf_distance``). The answer is the smallest triangle distance, the lowest
    triangle on a tie (the walk's order before): the same bits as the walk from the cutoff on 1200
    random pairs (box, sphere, capsule, cylinder, hull against a heightfield, a flat grid, a torus).
    Both prune by boxes, so of two triangles within round-off of each other (meeting at the nearest
    corner) either may answer, the points then differing in the last bits."""
    ra = core_radius(ta, params_a)
    for k in range(3):  # a's box in the mesh frame, from its supports along the mesh axes
        ax, ay, az = rot_m[0, k], rot_m[1, k], rot_m[2, k]
        p = support(ta, pos_a, rot_a, params_a, verts_a, ax, ay, az)
        q = support(ta, pos_a, rot_a, params_a, verts_a, -ax, -ay, -az)
        hi[k] = (p[0] - pos_m[0]) * ax + (p[1] - pos_m[1]) * ay + (p[2] - pos_m[2]) * az + ra
        lo[k] = (q[0] - pos_m[0]) * ax + (q[1] - pos_m[1]) * ay + (q[2] - pos_m[2]) * az - ra
    best = cutoff
    found = np.inf
    found_t = -1
    root = shape_data[m, 2]
    n_end = root + shape_data[m, 3]
    seed = root  # the nearer child down to a leaf (preorder: the left child is next, the right after its subtree)
    while node_count[seed] == 0:
        left = seed + 1
        right = node_skip[left]
        gl, cl = _node_gap(node_aabb, left, lo, hi)
        gr, cr = _node_gap(node_aabb, right, lo, hi)
        seed = right if gr < gl or (gr == gl and cr < cl) else left
    best, found, found_t = _leaf_distance(ta, pos_a, rot_a, params_a, verts_a, pos_m, rot_m, params_m, mesh_triangle,
                                          node_first[seed], node_first[seed] + node_count[seed], lo, hi, best, found,
                                          found_t, scratch, work, out)
    i = root
    while i < n_end:
        # the boxes' distance is a lower bound of any triangle's under the node
        gap = 0.0
        for k in range(3):
            g = max(node_aabb[i, 0, k] - hi[k], lo[k] - node_aabb[i, 1, k], 0.0)
            gap += g * g
        if gap > 0.0 and math.sqrt(gap) > best:
            i = node_skip[i]
            continue
        if node_count[i] > 0 and i != seed:
            best, found, found_t = _leaf_distance(ta, pos_a, rot_a, params_a, verts_a, pos_m, rot_m, params_m,
                                                  mesh_triangle, node_first[i], node_first[i] + node_count[i], lo, hi, best,
                                                  found, found_t, scratch, work, out)
        i += 1
    return found


@njit(**NO_NRT)
def _swap(out):
    """Turn a result of (b, a) into one of (a, b): the points change places, the normal turns."""
    for c in range(3):
        out[c], out[3 + c] = out[3 + c], out[c]
        out[6 + c] = -out[6 + c]


@njit(**NO_NRT)
def convex_to_shape(ta, pos_a, rot_a, params_a, verts_a, sb, shape_type, shape_params, shape_pos, shape_rot,
                    shape_data, hull_vertex, mesh_triangle, node_aabb, node_first, node_count, node_skip, cutoff,
                    scratch, lo, hi, work, out):
    """Signed distance (m) of a convex shape a (sphere, capsule, cylinder, cone, box or hull, given by
    its type, pose, params and hull vertices) to shape row sb (any type), or inf above ``cutoff``;
    points and normal (from a to sb) in ``out`` (9,) as ``convex_distance``. Shared by the pairs of
    bodies (``shape_distance``) and the queries of a shape not in the world (``shape_query``)."""
    tb = shape_type[sb]
    vb0 = shape_data[sb, 0]
    verts_b = hull_vertex[vb0:vb0 + shape_data[sb, 1]] if tb == SHAPE_CONVEX else hull_vertex[0:0]
    if tb == SHAPE_PLANE:
        d = _plane_distance(shape_pos[sb], shape_rot[sb], shape_params[sb], ta, pos_a, rot_a, params_a, verts_a,
                            np.int64(0), np.int64(0), mesh_triangle, cutoff, out)
        _swap(out)
        return d
    if tb == SHAPE_MESH:
        return _mesh_distance(ta, pos_a, rot_a, params_a, verts_a, shape_pos[sb], shape_rot[sb], shape_params[sb], sb,
                              shape_data, mesh_triangle, node_aabb, node_first, node_count, node_skip, cutoff, scratch,
                              lo, hi, work, out)
    return convex_distance(ta, pos_a, rot_a, params_a, verts_a, tb, shape_pos[sb], shape_rot[sb], shape_params[sb],
                           verts_b, cutoff, scratch, out)


@njit(**NO_NRT)
def shape_distance(sa, sb, shape_type, shape_params, shape_pos, shape_rot, shape_data, hull_vertex, mesh_triangle,
                   node_aabb, node_first, node_count, node_skip, cutoff, scratch, lo, hi, work, out):
    """Signed distance (m) between shape rows sa and sb at poses ``shape_pos``, ``shape_rot``, or inf
    (above ``cutoff``, or a pair not measured: plane-plane, mesh-mesh); points and normal (from sa
    to sb) in ``out`` (9,) as ``convex_distance``."""
    ta = shape_type[sa]
    tb = shape_type[sb]
    static_a = ta == SHAPE_PLANE or ta == SHAPE_MESH
    static_b = tb == SHAPE_PLANE or tb == SHAPE_MESH
    if static_a and static_b:
        if ta == tb:
            return np.inf
        # a plane and a mesh: the mesh's triangles' corners against the plane
        if ta == SHAPE_PLANE:
            return _plane_distance(shape_pos[sa], shape_rot[sa], shape_params[sa], tb, shape_pos[sb], shape_rot[sb],
                                   shape_params[sb], hull_vertex[0:0], shape_data[sb, 0],
                                   shape_data[sb, 0] + shape_data[sb, 1], mesh_triangle, cutoff, out)
        d = _plane_distance(shape_pos[sb], shape_rot[sb], shape_params[sb], ta, shape_pos[sa], shape_rot[sa],
                            shape_params[sa], hull_vertex[0:0], shape_data[sa, 0],
                            shape_data[sa, 0] + shape_data[sa, 1], mesh_triangle, cutoff, out)
        _swap(out)
        return d
    if static_a:  # the convex one first, then turned round
        vb0 = shape_data[sb, 0]
        verts_b = hull_vertex[vb0:vb0 + shape_data[sb, 1]] if tb == SHAPE_CONVEX else hull_vertex[0:0]
        d = convex_to_shape(tb, shape_pos[sb], shape_rot[sb], shape_params[sb], verts_b, sa, shape_type, shape_params,
                            shape_pos, shape_rot, shape_data, hull_vertex, mesh_triangle, node_aabb, node_first,
                            node_count, node_skip, cutoff, scratch, lo, hi, work, out)
        _swap(out)
        return d
    va0 = shape_data[sa, 0]
    verts_a = hull_vertex[va0:va0 + shape_data[sa, 1]] if ta == SHAPE_CONVEX else hull_vertex[0:0]
    return convex_to_shape(ta, shape_pos[sa], shape_rot[sa], shape_params[sa], verts_a, sb, shape_type, shape_params,
                           shape_pos, shape_rot, shape_data, hull_vertex, mesh_triangle, node_aabb, node_first,
                           node_count, node_skip, cutoff, scratch, lo, hi, work, out)


# ---------------------------------------------------------------------- pairs of bodies
PAIRS_PER_CHUNK = 32
# a query about fewer than 1/FEW_BODIES_FACTOR of the bodies of a world of FEW_BODIES_MIN_SHAPES shapes
# or more brings only their shapes' poses up to date (gathering their rows costs ~30 us: in a smaller
# world updating every shape is cheaper; one pair among 1000 / 10 000 boxes: 60 -> 51 / 357 -> 53 us)
FEW_BODIES_FACTOR = 8
FEW_BODIES_MIN_SHAPES = 512
PARALLEL_MIN_PAIRS = 64  # fewer pairs run on the calling thread (starting the threads costs more)


@njit(**NO_NRT)
def _body_pair(p, body_a, body_b, max_distance, shape_first, shape_count, shape_order, shape_type, shape_params,
               shape_pos, shape_rot, shape_aabb, shape_data, hull_vertex, mesh_triangle, node_aabb, node_first,
               node_count, node_skip, scratch, lo, hi, work, res,
               # outputs
               distance, shape_a, shape_b, points):
    """Row p: the closest pair of shapes of bodies body_a[p], body_b[p] (``closest_points_kernel``)."""
    best = max_distance[p]
    found = np.inf
    a = body_a[p]
    b = body_b[p]
    shape_a[p] = -1
    shape_b[p] = -1
    for i in range(shape_first[a], shape_first[a] + shape_count[a]):
        sa = shape_order[i]
        for j in range(shape_first[b], shape_first[b] + shape_count[b]):
            sb = shape_order[j]
            # the shapes' boxes' distance bounds theirs from below (planes' boxes are unbounded: 0)
            gap = 0.0
            for k in range(3):
                g = max(shape_aabb[sb, 0, k] - shape_aabb[sa, 1, k], shape_aabb[sa, 0, k] - shape_aabb[sb, 1, k], 0.0)
                gap += g * g
            if gap > 0.0 and math.sqrt(gap) > best:
                continue
            d = shape_distance(sa, sb, shape_type, shape_params, shape_pos, shape_rot, shape_data, hull_vertex,
                               mesh_triangle, node_aabb, node_first, node_count, node_skip, best, scratch, lo, hi,
                               work, res)
            if d < found:
                found = d
                best = min(best, d)
                shape_a[p] = sa
                shape_b[p] = sb
                for c in range(9):
                    points[p, c] = res[c]
    distance[p] = found
    if found == np.inf:
        for c in range(9):
            points[p, c] = np.nan


@njit(**JIT, parallel=True)
def closest_points_kernel(body_a, body_b, max_distance, shape_first, shape_count, shape_order, shape_type,
                          shape_params, shape_pos, shape_rot, shape_aabb, shape_data, hull_vertex, mesh_triangle,
                          node_aabb, node_first, node_count, node_skip,
                          # outputs
                          distance, shape_a, shape_b, points):
    """For each pair p of bodies (body_a, body_b (P,) int64): the signed distance[p] (m) of their
    closest shapes (inf: none within max_distance[p] (P,) m), the shape rows shape_a[p], shape_b[p]
    (-1: none) and points[p] (9,): point on a, point on b, unit normal a to b (world). A body's
    shapes are shape_order[shape_first[i]: shape_first[i] + shape_count[i]]; shape poses and boxes
    as ``update_bounds`` leaves them; the mesh BVH as ``ShapeTable``'s."""
    count = body_a.shape[0]
    chunks = (count + PAIRS_PER_CHUNK - 1) // PAIRS_PER_CHUNK
    for chunk in prange(chunks):
        scratch = gjk_scratch()
        lo = np.empty(3)
        hi = np.empty(3)
        work = np.empty(9)
        res = np.empty(9)
        for p in range(chunk * PAIRS_PER_CHUNK, min(count, (chunk + 1) * PAIRS_PER_CHUNK)):
            _body_pair(p, body_a, body_b, max_distance, shape_first, shape_count, shape_order, shape_type, shape_params,
                       shape_pos, shape_rot, shape_aabb, shape_data, hull_vertex, mesh_triangle, node_aabb, node_first,
                       node_count, node_skip, scratch, lo, hi, work, res, distance, shape_a, shape_b, points)


closest_points_serial_kernel = serial_twin(closest_points_kernel, "closest_points_serial_kernel")


# ---------------------------------------------------------------------- the query
def _bodies(world, name: str, value) -> np.ndarray:
    """(K,) int64 body indices from a body (``Body``, name or index) or a sequence of them.
    PERF: an integer array is checked as a whole (one ``index_of`` per body cost 1 us a pair)."""
    if isinstance(value, (str, int, np.integer)) or not hasattr(value, "__len__"):
        try:
            return np.array([world.index_of(value)], dtype=np.int64)
        except InputError as err:
            raise InputError(err.problem, name) from None
    if not isinstance(value, np.ndarray):
        try:
            as_array = np.asarray(value)
        except (TypeError, ValueError):
            as_array = None
        value = as_array if as_array is not None and as_array.dtype.kind in "iu" else value
    if isinstance(value, np.ndarray) and value.dtype.kind in "iu":
        index = value.astype(np.int64).reshape(-1)
        bad = (index < 0) | (index >= world.body_count)
        if bad.any():
            raise InputError(f"unknown body {int(index[bad][0])}", name)
        return index
    out = []
    for item in value:
        try:
            out.append(world.index_of(item.item() if isinstance(item, np.generic) else item))
        except InputError as err:
            raise InputError(err.problem, name) from None
    return np.array(out, dtype=np.int64).reshape(-1)


def _shapes_of_bodies(scene, body_count: int):
    """(first, count, order): body i's shape rows are order[first[i]: first[i] + count[i]], kept on
    the query scene (its table changes only when bodies are added)."""
    kept = getattr(scene, "_body_shapes", None)
    if kept is None:
        owner = scene.table.shape_body
        order = np.argsort(owner, kind="stable").astype(np.int64)
        count = np.bincount(owner, minlength=body_count).astype(np.int64)
        first = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
        kept = scene._body_shapes = (first, count, order)
    return kept


def shape_poses(world, bodies=None):
    """(scene, shape_pos (S, 3), shape_rot (S, 3, 3), shape_aabb (S, 2, 3)) at the world's current
    poses: the query scene kept on the world (``raycast.kept_scene``: its ``ShapeTable``) and the
    shapes' world poses and boxes without margin, in buffers kept with the scene (no allocation
    per query; the next query overwrites them). ``bodies`` (arrays of body indices): only those
    bodies' shape rows are brought up to date when they are few in a large world (a pair among
    thousands), the others left as the last query wrote them.

    PERF: updating every shape cost a single pair's query in a world of 10 000 boxes 0.36 ms, 20x
    the pair itself; a first version ran the per-shape routine, split out of the step's kernel,
    on the rows: the step's update of 10 000 boxes went 0.44 -> 1.3 ms (0.8 inlined), so the
    rows' columns are gathered for the step's own kernel instead (docs/benchmarks.md, "closest
    points")."""
    from .raycast import kept_scene

    scene = kept_scene(world)
    table = scene.table
    S = table.shape_count
    buffers = getattr(scene, "_distance_buffers", None)
    if buffers is None or len(buffers[0]) != S:
        buffers = scene._distance_buffers = (np.empty((S, 3)), np.empty((S, 3, 3)), np.empty((S, 2, 3)), np.empty(S))
    if S >= FEW_BODIES_MIN_SHAPES and bodies is not None and sum(map(len, bodies)) * FEW_BODIES_FACTOR < world.body_count:
        few = np.unique(np.concatenate(bodies))
        first, count, order = _shapes_of_bodies(scene, world.body_count)
        c = count[few]  # their shape rows: order[first[b]:first[b] + count[b]] for each, in one index
        rows = order[np.repeat(first[few] - np.cumsum(c) + c, c) + np.arange(c.sum())]
        update_bounds_rows(world.x, world.R, table, rows, *buffers)
    elif S:
        update_bounds(world.x, world.R, table, 0.0, *buffers[:3], shape_margin=buffers[3])
    return scene, buffers[0], buffers[1], buffers[2]


def closest_points(world, body_a, body_b, max_distance=np.inf) -> ClosestPoints:
    """The closest points and signed distance of each pair of bodies at their current poses
    (module docstring).

    Args:
        world: a ``tumble.World``; a body without a collision shape gives distance inf.
        body_a, body_b: a body (``Body``, name or index) or a sequence of P of them; one body
            against P pairs with each of the other side's (broadcast).
        max_distance: m, a number or (P,): pairs of shapes farther apart are not measured (their
            row gets inf); inf by default (always measured).

    Returns:
        ``ClosestPoints`` with a row per pair.

    Raises:
        InputError: an unknown body, a body paired with itself, sides of different lengths, a NaN
            max_distance; one line naming the argument.
    """
    a = _bodies(world, "body_a", body_a)
    b = _bodies(world, "body_b", body_b)
    P = max(len(a), len(b))
    if len(a) != len(b):
        if 1 not in (len(a), len(b)):
            raise InputError(f"has {len(b)} bodies but body_a has {len(a)}", "body_b")
        a = np.full(P, a[0], dtype=np.int64) if len(a) == 1 else a
        b = np.full(P, b[0], dtype=np.int64) if len(b) == 1 else b
    same = a == b
    if same.any():
        first_same = int(np.argmax(same))
        raise InputError(f"body {int(a[first_same])} is paired with itself (pair {first_same})", "body_b")
    if isinstance(max_distance, (float, int)):
        if math.isnan(max_distance):
            raise InputError("must not be NaN", "max_distance")
        dist = np.full(P, float(max_distance))
    else:
        dist = np.asarray(max_distance, dtype=float)
        if dist.ndim > 1 or (dist.ndim == 1 and len(dist) != P):
            raise InputError(f"must be a number or one per pair ({P}), got shape {dist.shape}", "max_distance")
        if np.isnan(dist).any():
            raise InputError("must not be NaN", "max_distance")
        dist = rows(dist, P)

    scene, pos, rot, aabb = shape_poses(world, (a, b))
    table = scene.table
    first, count, order = _shapes_of_bodies(scene, world.body_count)
    distance = np.empty(P)
    shape_a = np.empty(P, dtype=np.int64)
    shape_b = np.empty(P, dtype=np.int64)
    points = np.empty((P, 9))
    if table.shape_count == 0:
        distance[:] = np.inf
        shape_a[:] = shape_b[:] = -1
        points[:] = np.nan
    else:
        kernel = closest_points_kernel if P >= PARALLEL_MIN_PAIRS else closest_points_serial_kernel
        kernel(a, b, dist, first, count, order, table.shape_type, table.shape_params, pos, rot, aabb, table.shape_data,
               table.hull_vertex, table.mesh_triangle, table.mesh_node_aabb, table.mesh_node_first,
               table.mesh_node_count, table.mesh_node_skip, distance, shape_a, shape_b, points)
    return ClosestPoints(distance=distance, point_a=points[:, 0:3], point_b=points[:, 3:6], normal=points[:, 6:9],
                         shape_a=shape_a, shape_b=shape_b, body_a=a, body_b=b)


def near_pairs(world, max_distance: float, mask=ALL_CATEGORIES, category=ALL_CATEGORIES) -> ClosestPoints:
    """Every pair of bodies whose shapes come within ``max_distance`` (m) of each other at their
    current poses, or overlap, measured as ``closest_points`` (a proximity query over the whole
    world: MuJoCo's contacts within a geom margin, Bullet's contact test with a distance). The
    candidates come from the broadphase (``broadphase.find_pairs``) on the shapes' boxes grown by
    half of ``max_distance`` on every side, and every plane against every other shape; pairs of two
    fixed bodies are left out (they never move), and so are sensors and bodies whose filter does not
    meet ``mask`` / ``category`` (as ``ray_cast``). Rows sorted by (body_a, body_b), body_a < body_b.

    Raises:
        InputError: a max_distance that is negative, NaN or infinite.
    """
    from .broadphase import find_pairs
    from .raycast import _seen

    if not (isinstance(max_distance, (int, float, np.floating, np.integer)) and math.isfinite(max_distance)
            and max_distance >= 0):
        raise InputError(f"must be a finite number of metres >= 0, got {max_distance!r}", "max_distance")
    seen = _seen(world, mask, category)
    scene, pos, rot, aabb = shape_poses(world)
    table = scene.table
    free = np.asarray(world.moving, dtype=bool) | np.asarray(world.kinematic, dtype=bool)
    pairs = np.zeros((0, 2), dtype=np.int64)
    if table.shape_count:
        grown = aabb.copy()
        grown[:, 0] -= 0.5 * max_distance
        grown[:, 1] += 0.5 * max_distance
        pa, pb = find_pairs(grown, table.shape_type, table.shape_body, free)
        owner = table.shape_body
        found = [np.column_stack([owner[pa], owner[pb]])]
        planes = np.flatnonzero(table.shape_type == SHAPE_PLANE)
        others = np.flatnonzero(table.shape_type != SHAPE_PLANE)
        for p in planes:  # planes are unbounded: every other shape of a body that moves is a candidate
            near = others[(owner[others] != owner[p]) & (free[owner[others]] | free[owner[p]])]
            found.append(np.column_stack([np.full(len(near), owner[p]), owner[near]]))
        pairs = np.sort(np.concatenate(found), axis=1)
        pairs = pairs[(pairs[:, 0] != pairs[:, 1]) & seen[pairs[:, 0]] & seen[pairs[:, 1]]]
        pairs = np.unique(pairs, axis=0)
    r = closest_points(world, pairs[:, 0], pairs[:, 1], float(max_distance)) if len(pairs) else None
    if r is None:
        empty = np.zeros((0, 3))
        none = np.zeros(0, dtype=np.int64)
        return ClosestPoints(distance=np.zeros(0), point_a=empty, point_b=empty.copy(), normal=empty.copy(),
                             shape_a=none, shape_b=none.copy(), body_a=none.copy(), body_b=none.copy())
    keep = r.found
    return ClosestPoints(distance=r.distance[keep], point_a=r.point_a[keep], point_b=r.point_b[keep],
                         normal=r.normal[keep], shape_a=r.shape_a[keep], shape_b=r.shape_b[keep],
                         body_a=r.body_a[keep], body_b=r.body_b[keep])
