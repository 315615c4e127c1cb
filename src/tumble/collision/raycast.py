"""Ray casts: the first shape of a World along each of many rays (a scene query).

What PyBullet's ``rayTestBatch``, MuJoCo's ``mj_ray`` and Box2D's ``b2World_CastRay`` give their
users (sensors, range finders, picking, line of sight), over every collision shape of
``collision.geometry``: plane, sphere, capsule, cylinder, cone, box, convex hull, static
triangle mesh, and each part of a compound.

Rules (as Box2D's):
- a ray is ``origin + t * direction`` for 0 <= t <= max_distance, ``direction`` made unit, so t is
  a distance in metres;
- a solid shape whose inside holds the ray's origin is not hit (a sensor inside a body sees
  out of it). Planes are solid below their surface. Meshes are surfaces: hit from either side,
  the normal turned towards the ray;
- the normal is the shape's outward unit normal at the hit point (world frame); on an edge or a
  corner, that of the face the ray entered by (a box's, a hull's, a cylinder's cap or side).

Each ray walks a tree of the shapes' world AABBs (``build_shape_bvh``; kept between queries and
refitted to moved shapes, ``refit_shape_bvh``; planes, unbounded, are tested apart), then tests
exactly, in the shape's frame, the shapes whose boxes it crosses before its nearest hit so far
(closed forms; hulls by clipping the ray with their face planes, Cyrus and Beck 1978; meshes
through their own BVH with the Moller-Trumbore triangle test, 1997). Rays are spread over the
cores, each writing only its own row, so the bits do not depend on the thread count. Figures in
docs/benchmarks.md ("raycast").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from ..errors import InputError
from ..math3d import JIT
from ..shapes import SHAPE_BOX, SHAPE_CAPSULE, SHAPE_CONE, SHAPE_CONVEX, SHAPE_CYLINDER, SHAPE_MESH, SHAPE_PLANE, \
    SHAPE_SPHERE
from .bounds import update_bounds
from .geometry import build_shape_table

_MISS = (False, 0.0, 0.0, 0.0, 0.0)


@dataclass
class RayHits:
    """What ``ray_cast`` found, one row per ray (R rays).

    body: (R,) int64, index of the body hit, -1 where nothing was hit.
    shape: (R,) int64, row of the shape hit in the World's shape table (a compound has a row per
        part), -1 where nothing was hit.
    distance: (R,) m along the ray from its origin; inf where nothing was hit.
    point: (R, 3) m, world, the hit point; NaN where nothing was hit.
    normal: (R, 3) unit, world, the shape's outward normal at the hit; NaN where nothing was hit.
    """

    body: np.ndarray
    shape: np.ndarray
    distance: np.ndarray
    point: np.ndarray
    normal: np.ndarray

    @property
    def hit(self) -> np.ndarray:
        """(R,) bool: the ray hit a shape."""
        return self.body >= 0

    def __len__(self) -> int:
        return len(self.body)


# ---------------------------------------------------------------------- one shape, its own frame
# Each ``_ray_<shape>`` takes the ray (o, d) in the shape's frame (d unit) and the largest t worth
# reporting, and returns (hit, t, nx, ny, nz): the entry distance and outward normal, shape frame.

@njit(**JIT)
def _slab(o, d, lo, hi):
    """(t_enter, t_exit) of the line o + t d through lo <= p <= hi along one axis (-inf, inf:
    always inside; (inf, -inf): never)."""
    if d == 0.0:
        if o < lo or o > hi:
            return np.inf, -np.inf
        return -np.inf, np.inf
    t1 = (lo - o) / d
    t2 = (hi - o) / d
    if t1 > t2:
        return t2, t1
    return t1, t2


@njit(**JIT)
def _ray_plane(p, o, d, t_max):
    """Half-space n . x <= offset, p = (n, offset)."""
    height = p[0] * o[0] + p[1] * o[1] + p[2] * o[2] - p[3]
    rate = p[0] * d[0] + p[1] * d[1] + p[2] * d[2]
    if height < 0.0 or rate >= 0.0:
        return _MISS
    t = -height / rate
    if t > t_max:
        return _MISS
    return True, t, p[0], p[1], p[2]


@njit(**JIT)
def _ray_sphere(radius, cz, o, d, t_max):
    """Sphere of ``radius`` centred at (0, 0, cz) (cz: a capsule's end)."""
    oz = o[2] - cz
    b = o[0] * d[0] + o[1] * d[1] + oz * d[2]
    c = o[0] * o[0] + o[1] * o[1] + oz * oz - radius * radius
    if c < 0.0 or b > 0.0:  # inside, or outside and moving away
        return _MISS
    disc = b * b - c
    if disc < 0.0:
        return _MISS
    t = -b - math.sqrt(disc)
    if t < 0.0 or t > t_max:
        return _MISS
    return True, t, (o[0] + t * d[0]) / radius, (o[1] + t * d[1]) / radius, (oz + t * d[2]) / radius


@njit(**JIT)
def _side(radius, o, d):
    """(t_enter, t_exit) of the line through the infinite solid cylinder x^2 + y^2 <= radius^2."""
    a = d[0] * d[0] + d[1] * d[1]
    c = o[0] * o[0] + o[1] * o[1] - radius * radius
    if a == 0.0:  # along the axis
        if c > 0.0:
            return np.inf, -np.inf
        return -np.inf, np.inf
    b = o[0] * d[0] + o[1] * d[1]
    disc = b * b - a * c
    if disc < 0.0:
        return np.inf, -np.inf
    sq = math.sqrt(disc)
    return (-b - sq) / a, (-b + sq) / a


@njit(**JIT)
def _ray_box(h, o, d, t_max):
    """Box |x_i| <= h_i: the slabs' latest entry, if before their earliest exit."""
    enter = -np.inf
    leave = np.inf
    axis = -1
    for i in range(3):
        t1, t2 = _slab(o[i], d[i], -h[i], h[i])
        if t1 > enter:
            enter = t1
            axis = i
        leave = min(leave, t2)
    if axis < 0 or enter > leave or enter < 0.0 or enter > t_max:
        return _MISS
    sign = -1.0 if d[axis] > 0.0 else 1.0
    return True, enter, sign if axis == 0 else 0.0, sign if axis == 1 else 0.0, sign if axis == 2 else 0.0


@njit(**JIT)
def _ray_cylinder(radius, half, o, d, t_max):
    """Cylinder x^2 + y^2 <= r^2, |z| <= h: the side's and the caps' slab's intervals intersected."""
    s1, s2 = _side(radius, o, d)
    z1, z2 = _slab(o[2], d[2], -half, half)
    enter = max(s1, z1)
    if enter > min(s2, z2) or enter < 0.0 or enter > t_max:
        return _MISS
    if z1 >= s1:  # entered through a cap
        return True, enter, 0.0, 0.0, -1.0 if d[2] > 0.0 else 1.0
    return True, enter, (o[0] + enter * d[0]) / radius, (o[1] + enter * d[1]) / radius, 0.0


@njit(**JIT)
def _ray_capsule(radius, half, o, d, t_max):
    """Capsule: points within r of the segment |z| <= h. Origin inside: no hit; else the first of
    the side (where |z| <= h) and the two end spheres."""
    zc = min(max(o[2], -half), half)
    if o[0] * o[0] + o[1] * o[1] + (o[2] - zc) ** 2 < radius * radius:
        return _MISS
    best = _MISS
    limit = t_max
    s1, s2 = _side(radius, o, d)
    if s1 >= 0.0 and s1 <= limit and s1 <= s2 and abs(o[2] + s1 * d[2]) <= half:
        best = (True, s1, (o[0] + s1 * d[0]) / radius, (o[1] + s1 * d[1]) / radius, 0.0)
        limit = s1
    for end in (-half, half):
        hit = _ray_sphere(radius, end, o, d, limit)
        if hit[0]:
            best = hit
            limit = hit[1]
    return best


@njit(**JIT)
def _ray_cone(radius, height, o, d, t_max):
    """Cone: base disc of radius r at z = 0, apex at z = H. The solid is {z >= 0} and the solid
    infinite cone C = {rho <= k (H - z)}, k = r / H; a line meets the convex C in one interval,
    bounded by the roots of rho^2 = k^2 (H - z)^2 that lie below the apex."""
    k = radius / height
    k2 = k * k
    w = height - o[2]
    A = d[0] * d[0] + d[1] * d[1] - k2 * d[2] * d[2]
    B = 2.0 * (o[0] * d[0] + o[1] * d[1] + k2 * w * d[2])
    C = o[0] * o[0] + o[1] * o[1] - k2 * w * w
    r1 = r2 = np.inf  # the roots, ascending (inf: none)
    if A == 0.0:
        if B != 0.0:
            r1 = -C / B
    else:
        disc = B * B - 4.0 * A * C
        if disc >= 0.0:
            sq = math.sqrt(disc)
            # the numerically stable pair (no cancellation between -B and sq)
            qq = -0.5 * (B + sq) if B >= 0.0 else -0.5 * (B - sq)
            q1 = qq / A
            q2 = C / qq if qq != 0.0 else q1
            r1, r2 = min(q1, q2), max(q1, q2)
    # keep the roots on the nappe below the apex
    if r2 < np.inf and o[2] + r2 * d[2] > height:
        r2 = np.inf
    if r1 < np.inf and o[2] + r1 * d[2] > height:
        r1, r2 = r2, np.inf
    if r2 < np.inf:
        c1, c2 = r1, r2
    elif r1 < np.inf:
        t = r1 + 1.0  # a half-line: which side of the root lies inside C
        px, py, pz = o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]
        if pz <= height and px * px + py * py <= k2 * (height - pz) ** 2:
            c1, c2 = r1, np.inf
        else:
            c1, c2 = -np.inf, r1
    else:
        if o[2] <= height and C <= 0.0:  # the whole line inside C (never for a finite cone's solid)
            c1, c2 = -np.inf, np.inf
        else:
            return _MISS
    z1, z2 = _slab(o[2], d[2], 0.0, np.inf)
    enter = max(c1, z1)
    if enter > min(c2, z2) or enter < 0.0 or enter > t_max:
        return _MISS
    if z1 >= c1:  # through the base
        return True, enter, 0.0, 0.0, -1.0
    px, py = o[0] + enter * d[0], o[1] + enter * d[1]
    rho = math.sqrt(px * px + py * py)
    if rho == 0.0:  # the apex
        return True, enter, 0.0, 0.0, 1.0
    s = 1.0 / math.sqrt(1.0 + k2)
    return True, enter, px / rho * s, py / rho * s, k * s


@njit(**JIT)
def _ray_convex(face_first, face_count, hull_plane, o, d, t_max):
    """Convex hull, the intersection of its faces' half-spaces n . x <= offset (Cyrus-Beck)."""
    enter = -np.inf
    leave = np.inf
    face = -1
    for f in range(face_first, face_first + face_count):
        p = hull_plane[f]
        rate = p[0] * d[0] + p[1] * d[1] + p[2] * d[2]
        room = p[3] - (p[0] * o[0] + p[1] * o[1] + p[2] * o[2])
        if rate == 0.0:
            if room < 0.0:
                return _MISS
        elif rate < 0.0:
            t = room / rate
            if t > enter:
                enter = t
                face = f
        else:
            leave = min(leave, room / rate)
    if face < 0 or enter > leave or enter < 0.0 or enter > t_max:
        return _MISS
    p = hull_plane[face]
    return True, enter, p[0], p[1], p[2]


@njit(**JIT)
def _ray_mesh(node_first_row, node_count, mesh_triangle, node_aabb, leaf_first, leaf_count, node_skip, o, d, t_max):
    """Static triangle mesh: the nearest triangle along the ray (either side), through the BVH."""
    best = _MISS
    limit = t_max
    i = node_first_row
    end = node_first_row + node_count
    while i < end:
        enter = 0.0
        leave = limit
        for k in range(3):
            t1, t2 = _slab(o[k], d[k], node_aabb[i, 0, k], node_aabb[i, 1, k])
            enter = max(enter, t1)
            leave = min(leave, t2)
        if enter > leave:
            i = node_skip[i]
            continue
        for t in range(leaf_first[i], leaf_first[i] + leaf_count[i]):
            tri = mesh_triangle[t]
            e1 = (tri[1, 0] - tri[0, 0], tri[1, 1] - tri[0, 1], tri[1, 2] - tri[0, 2])
            e2 = (tri[2, 0] - tri[0, 0], tri[2, 1] - tri[0, 1], tri[2, 2] - tri[0, 2])
            px = d[1] * e2[2] - d[2] * e2[1]
            py = d[2] * e2[0] - d[0] * e2[2]
            pz = d[0] * e2[1] - d[1] * e2[0]
            det = e1[0] * px + e1[1] * py + e1[2] * pz
            if det == 0.0:  # the ray in the triangle's plane
                continue
            inv = 1.0 / det
            sx, sy, sz = o[0] - tri[0, 0], o[1] - tri[0, 1], o[2] - tri[0, 2]
            u = (sx * px + sy * py + sz * pz) * inv
            if u < 0.0 or u > 1.0:
                continue
            qx = sy * e1[2] - sz * e1[1]
            qy = sz * e1[0] - sx * e1[2]
            qz = sx * e1[1] - sy * e1[0]
            v = (d[0] * qx + d[1] * qy + d[2] * qz) * inv
            if v < 0.0 or u + v > 1.0:
                continue
            hit_t = (e2[0] * qx + e2[1] * qy + e2[2] * qz) * inv
            if hit_t < 0.0 or hit_t > limit:
                continue
            nx = e1[1] * e2[2] - e1[2] * e2[1]
            ny = e1[2] * e2[0] - e1[0] * e2[2]
            nz = e1[0] * e2[1] - e1[1] * e2[0]
            norm = math.sqrt(nx * nx + ny * ny + nz * nz)
            if nx * d[0] + ny * d[1] + nz * d[2] > 0.0:  # the side the ray comes from
                norm = -norm
            best = (True, hit_t, nx / norm, ny / norm, nz / norm)
            limit = hit_t
        i += 1
    return best


# ---------------------------------------------------------------------- all rays, all shapes
SHAPES_PER_LEAF = 4
RAYS_PER_CHUNK = 64  # rays per task of the parallel loop (each task allocates its traversal stack once)


@njit(**JIT)
def build_shape_bvh(aabb, items, node_aabb, node_first, node_count, node_skip):
    """A bounding volume hierarchy over the boxes aabb[items] (items (M,) shape rows, reordered in
    place so that each leaf's shapes are consecutive), in preorder with skip links (the node after
    a node's subtree: a stackless walk, as the meshes' BVH). Split at the median centroid along
    the axis the centroids spread most, down to ``SHAPES_PER_LEAF``. Outputs sized >= 2 M.
    Returns the number of nodes."""
    m = items.shape[0]
    if m == 0:
        return 0
    right = np.full(2 * m, -1, dtype=np.int64)  # an inner node's right child (its left is the next node)
    stack_lo = np.empty(2 * m, dtype=np.int64)
    stack_hi = np.empty(2 * m, dtype=np.int64)
    stack_parent = np.empty(2 * m, dtype=np.int64)  # the inner node whose right child this is (-1: a left one)
    centre = np.empty(m)
    top = 0
    stack_lo[0], stack_hi[0], stack_parent[0] = 0, m, -1
    nodes = 0
    while top >= 0:
        lo, hi, parent = stack_lo[top], stack_hi[top], stack_parent[top]
        top -= 1
        n = nodes
        nodes += 1
        if parent >= 0:
            right[parent] = n
        for k in range(3):
            node_aabb[n, 0, k] = np.inf
            node_aabb[n, 1, k] = -np.inf
        for i in range(lo, hi):
            for k in range(3):
                node_aabb[n, 0, k] = min(node_aabb[n, 0, k], aabb[items[i], 0, k])
                node_aabb[n, 1, k] = max(node_aabb[n, 1, k], aabb[items[i], 1, k])
        if hi - lo <= SHAPES_PER_LEAF:
            node_first[n] = lo
            node_count[n] = hi - lo
            continue
        node_first[n] = lo
        node_count[n] = 0
        axis = 0
        spread = -1.0
        for k in range(3):
            c_lo = np.inf
            c_hi = -np.inf
            for i in range(lo, hi):
                c = aabb[items[i], 0, k] + aabb[items[i], 1, k]
                c_lo = min(c_lo, c)
                c_hi = max(c_hi, c)
            if c_hi - c_lo > spread:
                spread = c_hi - c_lo
                axis = k
        for i in range(lo, hi):
            centre[i - lo] = aabb[items[i], 0, axis] + aabb[items[i], 1, axis]
        sorted_items = items[lo:hi][np.argsort(centre[:hi - lo], kind="mergesort")]
        items[lo:hi] = sorted_items
        mid = (lo + hi) // 2
        # the right half is pushed first, so the left one is built next: it follows its parent
        top += 1
        stack_lo[top], stack_hi[top], stack_parent[top] = mid, hi, n
        top += 1
        stack_lo[top], stack_hi[top], stack_parent[top] = lo, mid, -1
    # skip links, parents before children: a left child skips to its sibling, a right child
    # to where its parent skips
    node_skip[0] = nodes
    for n in range(nodes):
        if node_count[n] == 0:
            node_skip[n + 1] = right[n]
            node_skip[right[n]] = node_skip[n]
    return nodes


@njit(**JIT)
def refit_shape_bvh(aabb, items, node_aabb, node_first, node_count, node_skip, nodes):
    """The boxes of a tree from ``build_shape_bvh`` made anew for the shapes' new boxes ``aabb``
    (S, 2, 3) m, world, in place, its shapes and nodes kept: each leaf the union of its shapes'
    boxes, each inner node of its two children's (the left one is the next node, the right one
    where the left skips to), children before parents by walking the preorder backwards.
    O(nodes), no allocation (Box2D's dynamic tree refits its moved leaves' ancestors the same
    way). Returns the sum of the nodes' box areas, m^2: the tree's cost measure, which grows as
    the shapes move from where the tree was built (the surface area heuristic's measure,
    MacDonald and Booth 1990)."""
    total = 0.0
    for n in range(nodes - 1, -1, -1):
        if node_count[n] > 0:
            for k in range(3):
                lo = np.inf
                hi = -np.inf
                for i in range(node_first[n], node_first[n] + node_count[n]):
                    lo = min(lo, aabb[items[i], 0, k])
                    hi = max(hi, aabb[items[i], 1, k])
                node_aabb[n, 0, k] = lo
                node_aabb[n, 1, k] = hi
        else:
            left = n + 1
            right = node_skip[n + 1]
            for k in range(3):
                node_aabb[n, 0, k] = min(node_aabb[left, 0, k], node_aabb[right, 0, k])
                node_aabb[n, 1, k] = max(node_aabb[left, 1, k], node_aabb[right, 1, k])
        ex = node_aabb[n, 1, 0] - node_aabb[n, 0, 0]
        ey = node_aabb[n, 1, 1] - node_aabb[n, 0, 1]
        ez = node_aabb[n, 1, 2] - node_aabb[n, 0, 2]
        total += 2.0 * (ex * ey + ey * ez + ez * ex)
    return total


@njit(**JIT)
def _box_entry(origin, direction, r, boxes, j, t_max):
    """Where ray r enters box j (boxes (B, 2, 3) min row, max row) within [0, t_max]; inf: it does not."""
    enter = 0.0
    leave = t_max
    for k in range(3):
        t1, t2 = _slab(origin[r, k], direction[r, k], boxes[j, 0, k], boxes[j, 1, k])
        enter = max(enter, t1)
        leave = min(leave, t2)
    return enter if enter <= leave else np.inf


@njit(**JIT)
def _ray_shape(s, lo, dl, best, shape_type, shape_params, shape_data, hull_plane, mesh_triangle, node_aabb,
               leaf_first, leaf_count, node_skip):
    """Shape s against the ray (lo, dl) in its frame, up to ``best``: the ``_ray_<shape>`` it takes."""
    t = shape_type[s]
    p = shape_params[s]
    if t == SHAPE_PLANE:
        return _ray_plane(p, lo, dl, best)
    if t == SHAPE_SPHERE:
        return _ray_sphere(p[0], 0.0, lo, dl, best)
    if t == SHAPE_BOX:
        return _ray_box(p, lo, dl, best)
    if t == SHAPE_CAPSULE:
        return _ray_capsule(p[0], p[1], lo, dl, best)
    if t == SHAPE_CYLINDER:
        return _ray_cylinder(p[0], p[1], lo, dl, best)
    if t == SHAPE_CONE:
        return _ray_cone(p[0], p[1], lo, dl, best)
    if t == SHAPE_CONVEX:
        return _ray_convex(shape_data[s, 2], shape_data[s, 3], hull_plane, lo, dl, best)
    if t == SHAPE_MESH:
        return _ray_mesh(shape_data[s, 2], shape_data[s, 3], mesh_triangle, node_aabb, leaf_first, leaf_count,
                         node_skip, lo, dl, best)
    return _MISS


@njit(**JIT)
def _cast_one(r, origin, direction, max_distance, exclude, planes, items, tree_aabb, tree_first, tree_count,
              tree_skip, shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_data, hull_plane,
              mesh_triangle, node_aabb, leaf_first, leaf_count, node_skip, stack, stack_enter, hit_shape,
              hit_distance, hit_normal):
    """Ray r of ``ray_cast_kernel``; ``stack``, ``stack_enter`` (64,) its scratch."""
    nodes = tree_first.shape[0]
    o0, o1, o2 = origin[r, 0], origin[r, 1], origin[r, 2]
    e0, e1, e2 = direction[r, 0], direction[r, 1], direction[r, 2]
    best = max_distance[r]
    best_s = -1
    n0 = n1 = n2 = 0.0
    sp = 0
    if nodes > 0:
        stack[0] = 0
        stack_enter[0] = 0.0
        sp = 1
    j = -len(planes)  # the planes first
    leaf_at = 0
    leaf_end = 0
    while True:
        if j < 0:
            s = planes[len(planes) + j]
            j += 1
        elif leaf_at < leaf_end:  # the next shape of the current leaf
            s = items[leaf_at]
            leaf_at += 1
        elif sp > 0:
            sp -= 1
            node = stack[sp]
            if stack_enter[sp] > best:
                continue
            if tree_count[node] > 0:
                leaf_at = tree_first[node]
                leaf_end = leaf_at + tree_count[node]
                continue
            near = node + 1
            far = tree_skip[node + 1]
            t_near = _box_entry(origin, direction, r, tree_aabb, near, best)
            t_far = _box_entry(origin, direction, r, tree_aabb, far, best)
            if t_far < t_near:
                near, far = far, near
                t_near, t_far = t_far, t_near
            if t_far < np.inf:
                stack[sp] = far
                stack_enter[sp] = t_far
                sp += 1
            if t_near < np.inf:
                stack[sp] = near
                stack_enter[sp] = t_near
                sp += 1
            continue
        else:
            break
        if shape_body[s] == exclude[r]:
            continue
        # the ray in the shape's frame: o' = Rs^T (o - ps), d' = Rs^T d
        w0 = o0 - shape_pos[s, 0]
        w1 = o1 - shape_pos[s, 1]
        w2 = o2 - shape_pos[s, 2]
        rs = shape_rot[s]
        lo = (rs[0, 0] * w0 + rs[1, 0] * w1 + rs[2, 0] * w2, rs[0, 1] * w0 + rs[1, 1] * w1 + rs[2, 1] * w2,
              rs[0, 2] * w0 + rs[1, 2] * w1 + rs[2, 2] * w2)
        dl = (rs[0, 0] * e0 + rs[1, 0] * e1 + rs[2, 0] * e2, rs[0, 1] * e0 + rs[1, 1] * e1 + rs[2, 1] * e2,
              rs[0, 2] * e0 + rs[1, 2] * e1 + rs[2, 2] * e2)
        hit = _ray_shape(s, lo, dl, best, shape_type, shape_params, shape_data, hull_plane, mesh_triangle,
                         node_aabb, leaf_first, leaf_count, node_skip)
        if hit[0] and hit[1] <= best:
            best = hit[1]
            best_s = s
            # the normal back to the world: n = Rs n'
            n0 = rs[0, 0] * hit[2] + rs[0, 1] * hit[3] + rs[0, 2] * hit[4]
            n1 = rs[1, 0] * hit[2] + rs[1, 1] * hit[3] + rs[1, 2] * hit[4]
            n2 = rs[2, 0] * hit[2] + rs[2, 1] * hit[3] + rs[2, 2] * hit[4]
    hit_shape[r] = best_s
    hit_distance[r] = best if best_s >= 0 else np.inf
    hit_normal[r, 0] = n0
    hit_normal[r, 1] = n1
    hit_normal[r, 2] = n2


@njit(**JIT, parallel=True)
def ray_cast_kernel(origin, direction, max_distance, exclude, planes, items, tree_aabb, tree_first, tree_count,
                    tree_skip, shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_data, hull_plane,
                    mesh_triangle, node_aabb, leaf_first, leaf_count, node_skip,
                    # outputs
                    hit_shape, hit_distance, hit_normal):
    """Per ray r: the nearest shape s (hit_shape[r], -1: none) within max_distance[r] along the unit
    ``direction[r]`` from ``origin[r]`` (R, 3) m, skipping the body ``exclude[r]`` (-1: none);
    its distance (R,) m and outward normal (R, 3), world.

    The shapes: ``planes`` (P,) rows, each tested, and the rest through the tree
    (``build_shape_bvh``: its nodes tree_* and the shape rows ``items`` its leaves point into),
    walked front to back, its boxes passed over once they start beyond the nearest hit so far.
    Shape poses as ``update_bounds`` leaves them; meshes' own BVHs in node_aabb, leaf_first,
    leaf_count, node_skip.
    """
    count = origin.shape[0]
    chunks = (count + RAYS_PER_CHUNK - 1) // RAYS_PER_CHUNK
    for chunk in prange(chunks):
        # the tree front to back: a node's nearer child first, and nodes whose box starts beyond
        # the nearest hit so far are passed over (a stack of (node, entry distance), one per chunk)
        # 64: the stack holds at most one node per level plus one, and the median split keeps the
        # depth at log2(shapes / SHAPES_PER_LEAF) + 1
        stack = np.empty(64, dtype=np.int64)
        stack_enter = np.empty(64)
        for r in range(chunk * RAYS_PER_CHUNK, min(count, (chunk + 1) * RAYS_PER_CHUNK)):
            _cast_one(r, origin, direction, max_distance, exclude, planes, items, tree_aabb, tree_first, tree_count,
                      tree_skip, shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_data, hull_plane,
                      mesh_triangle, node_aabb, leaf_first, leaf_count, node_skip, stack, stack_enter, hit_shape,
                      hit_distance, hit_normal)


# ---------------------------------------------------------------------- the query
def _rays(name: str, value, count: int | None) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != 3:
        raise InputError(f"must be a 3-vector or an (R, 3) array, got shape {np.shape(value)}", name)
    if count is not None and count > 1 and len(a) not in (1, count):
        raise InputError(f"has {len(a)} rows but origin has {count}", name)
    if not np.all(np.isfinite(a)):
        raise InputError("must be finite", name)
    return a


# A kept tree is refitted to moved shapes (``refit_shape_bvh``) until the sum of its boxes' areas
# passes REFIT_GROWTH times what it was when built, then built anew: a cast after a pose change
# costs 2.9-8.2x less with a refit than with a new tree (1000-100 000 cubes, docs/benchmarks.md
# "raycast"), but the boxes of a refitted tree overlap more as its shapes move apart, and each
# ray then tests more of them. Either way the hits are the same (the tree only orders and
# prunes the exact tests).
REFIT_GROWTH = 2.0


class _RayScene:
    """What ray casts need of a world besides the rays: its ``ShapeTable`` (built in Python, 7.6 ms
    for 1000 boxes: more than 10 000 rays take, and constant until bodies are added) and, for the
    poses of the last query, the shapes' world poses and the tree of their boxes: kept while x and
    R stay as they were, so that many small queries between two steps pay for it once, and
    refitted when they moved (a query after every step), rebuilt when refitting has let it grow
    past ``REFIT_GROWTH``."""

    def __init__(self, world, table=None):
        self.body_count = world.body_count
        self.table = build_shape_table(world, skip_unsupported=True) if table is None else table
        self.x = self.R = None
        self._tree = None
        self.built_area = 0.0
        self.builds = self.refits = 0

    def tree(self, world):
        """(shape_pos (S, 3), shape_rot (S, 3, 3), planes (P,), items (M,), (tree_aabb, tree_first,
        tree_count, tree_skip)) at the world's current poses."""
        x, R = np.asarray(world.x), np.asarray(world.R)
        if self.x is not None and np.array_equal(self.x, x) and np.array_equal(self.R, R):
            return self._tree
        table = self.table
        pos, rot, aabb = update_bounds(x, R, table, 0.0)
        tree = None
        if self._tree is not None:  # the poses moved: refit the kept tree, unless it grew too loose
            _, _, planes, items, tree = self._tree
            if refit_shape_bvh(aabb, items, *tree, len(tree[0])) <= REFIT_GROWTH * self.built_area:
                self.refits += 1
            else:
                tree = None
        if tree is None:
            planes = np.flatnonzero(table.shape_type == SHAPE_PLANE).astype(np.int64)
            items = np.flatnonzero(table.shape_type != SHAPE_PLANE).astype(np.int64)
            M = max(2 * len(items), 1)
            tree = (np.empty((M, 2, 3)), np.empty(M, dtype=np.int64), np.empty(M, dtype=np.int64),
                    np.empty(M, dtype=np.int64))
            nodes = build_shape_bvh(aabb, items, *tree)
            tree = tuple(a[:nodes] for a in tree)
            self.built_area = refit_shape_bvh(aabb, items, *tree, nodes)  # the same boxes: its area as built
            self.builds += 1
        self._tree = pos, rot, planes, items, tree
        self.x, self.R = x.copy(), R.copy()
        return self._tree


def ray_cast(world, origin, direction, max_distance=np.inf, exclude=None, table=None) -> RayHits:
    """The first shape of ``world`` along each ray, at the bodies' current poses.

    Args:
        world: a ``tumble.World``; bodies without a collision shape (particles, or no shape)
            are not seen.
        origin: (3,) or (R, 3) m, world, where each ray starts.
        direction: (3,) or (R, 3), world, not zero; made unit (distances are in metres).
        max_distance: m, a number or (R,), how far each ray looks (inf: without end).
        exclude: a body (``Body``, name or index) or (R,) body indices (-1: none) that the
            rays do not see, e.g. the body a sensor is mounted on.
        table: a ``ShapeTable`` of ``world`` to use (default: built from the world at the first
            cast and kept until bodies are added).

    Returns:
        ``RayHits`` with a row per ray.

    Raises:
        InputError: shapes that do not fit, a zero or non-finite direction, a negative
            max_distance, an unknown body; one line naming the argument.
    """
    o = _rays("origin", origin, None)
    d = _rays("direction", direction, len(o))
    R = max(len(o), len(d))
    o = np.ascontiguousarray(np.broadcast_to(o, (R, 3)))
    d = np.array(np.broadcast_to(d, (R, 3)))
    length = np.linalg.norm(d, axis=1)
    if np.any(length == 0.0):
        raise InputError("must not be zero", "direction")
    d /= length[:, None]
    dist = np.asarray(max_distance, dtype=float)
    if dist.ndim > 1 or (dist.ndim == 1 and len(dist) != R):
        raise InputError(f"must be a number or one per ray ({R}), got shape {dist.shape}", "max_distance")
    if np.any(np.isnan(dist)) or np.any(dist < 0.0):
        raise InputError("must be >= 0", "max_distance")
    dist = np.ascontiguousarray(np.broadcast_to(dist, (R,)))
    if exclude is None:
        skip = np.full(R, -1, dtype=np.int64)
    elif np.ndim(exclude) == 0:  # one body, as a Body, a name or an index
        try:
            skip = np.full(R, world.index_of(exclude), dtype=np.int64)
        except InputError as err:
            raise InputError(err.problem, "exclude") from None
    else:
        skip = np.asarray(exclude, dtype=np.int64)
        if skip.shape != (R,):
            raise InputError(f"must be one body or one index per ray ({R}), got shape {skip.shape}", "exclude")
    if table is None:
        scene = getattr(world, "_ray_scene", None)
        if scene is None or scene.body_count != world.body_count:
            scene = world._ray_scene = _RayScene(world)
    else:
        scene = _RayScene(world, table)
    pos, rot, planes, items, tree = scene.tree(world)
    shape = np.empty(R, dtype=np.int64)
    distance = np.empty(R)
    normal = np.empty((R, 3))
    table = scene.table
    ray_cast_kernel(o, d, dist, skip, planes, items, *tree, table.shape_type, table.shape_body, table.shape_params,
                    pos, rot, table.shape_data, table.hull_plane, table.mesh_triangle, table.mesh_node_aabb,
                    table.mesh_node_first, table.mesh_node_count, table.mesh_node_skip, shape, distance, normal)
    hit = shape >= 0
    body = np.full(R, -1, dtype=np.int64)
    body[hit] = table.shape_body[shape[hit]]
    point = np.full((R, 3), np.nan)
    point[hit] = o[hit] + distance[hit, None] * d[hit]
    normal[~hit] = np.nan
    return RayHits(body=body, shape=shape, distance=distance, point=point, normal=normal)
