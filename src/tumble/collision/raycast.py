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
exactly, in the shape's frame (``collision.ray_shapes``), the shapes whose boxes it crosses
before its nearest hit so far (closed forms; hulls by clipping the ray with their face planes,
Cyrus and Beck 1978; meshes through their own BVH with the Moller-Trumbore triangle test, 1997).
Rays are spread over the cores, each writing only its own row, so the bits do not depend on the thread count. Figures in
docs/benchmarks.md ("raycast").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from ..errors import InputError
from ..math3d import JIT, NO_NRT, argsort_stable, serial_twin
from ..shapes import SHAPE_PLANE
from .bounds import update_bounds
from .filter import ALL_CATEGORIES, CollisionFilter
from .ray_shapes import _ray_shape, _slab
from .geometry import build_shape_table

class HitRows:
    """The rows of a query's hits (``RayHits``, ``shape_query.ShapeHits``): ``body`` (K,) -1 where none."""

    body: np.ndarray

    @property
    def hit(self) -> np.ndarray:
        """(K,) bool: the row's ray or cast found a body."""
        return self.body >= 0

    def __len__(self) -> int:
        return len(self.body)


@dataclass
class RayHits(HitRows):
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
        sorted_items = items[lo:hi][argsort_stable(centre[:hi - lo])]
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


@njit(**NO_NRT)
def _box_entry(origin, direction, r, boxes, j, t_max):
    """Where ray r enters box j (boxes (B, 2, 3) min row, max row) within [0, t_max]; inf: it does not."""
    enter = 0.0
    leave = t_max
    for k in range(3):
        t1, t2 = _slab(origin[r, k], direction[r, k], boxes[j, 0, k], boxes[j, 1, k])
        enter = max(enter, t1)
        leave = min(leave, t2)
    return enter if enter <= leave else np.inf


@njit(**NO_NRT)
def _cast_one(r, origin, direction, max_distance, exclude, seen, planes, items, tree_aabb, tree_first, tree_count,
              tree_skip, shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_data, hull_plane,
              mesh_triangle, node_aabb, leaf_first, leaf_count, node_skip, stack, stack_enter, hit_shape,
              hit_distance, hit_normal):
    """Ray r of ``ray_cast_kernel``; ``stack``, ``stack_enter`` (64,) its scratch. Without reference
    counting (``math3d.NO_NRT``): a counted call increfs and decrefs its 28 arrays, per ray."""
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
        if shape_body[s] == exclude[r] or not seen[shape_body[s]]:
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
    # + 0.0: a ray starting on a surface and going in reported -0.0 for a box (0.0 for a sphere)
    hit_distance[r] = best + 0.0 if best_s >= 0 else np.inf
    hit_normal[r, 0] = n0
    hit_normal[r, 1] = n1
    hit_normal[r, 2] = n2


@njit(**JIT, parallel=True)
def ray_cast_kernel(origin, direction, max_distance, exclude, seen, planes, items, tree_aabb, tree_first, tree_count,
                    tree_skip, shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_data, hull_plane,
                    mesh_triangle, node_aabb, leaf_first, leaf_count, node_skip,
                    # outputs
                    hit_shape, hit_distance, hit_normal):
    """Per ray r: the nearest shape s (hit_shape[r], -1: none) within max_distance[r] along the unit
    ``direction[r]`` from ``origin[r]`` (R, 3) m, skipping the body ``exclude[r]`` (-1: none)
    and every body b with ``seen[b]`` False ((N,) bool: the query's mask);
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
            _cast_one(r, origin, direction, max_distance, exclude, seen, planes, items, tree_aabb, tree_first, tree_count,
                      tree_skip, shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_data, hull_plane,
                      mesh_triangle, node_aabb, leaf_first, leaf_count, node_skip, stack, stack_enter, hit_shape,
                      hit_distance, hit_normal)


ray_cast_serial = serial_twin(ray_cast_kernel, "ray_cast_serial")  # a chunk or less of rays (``_RayScene.cast``)


@njit(**JIT, parallel=True)
def image_kernel(centre, axes, focal, cx, cy, max_distance, exclude, seen, planes, items, tree_aabb, tree_first,
                 tree_count, tree_skip, shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_data,
                 hull_plane, mesh_triangle, node_aabb, leaf_first, leaf_count, node_skip, colors, sky, ambient,
                 diffuse,
                 # outputs (H rows, W columns)
                 depth, distance, body, point, normal, rgb):
    """A pinhole camera's images by one ray per pixel (``tumble.camera``), in one pass: the rays,
    the casts (``_cast_one``, as ``ray_cast_kernel``'s), the hit points and the shaded colours,
    rows spread over the cores (each writing its own rows). PERF: as ``Camera.capture``'s NumPy
    around ``ray_cast`` it was 95 ms a 640 x 480 capture, of which the casts 18 ms.

    centre (3,) m and axes (3, 3) (columns x right, y down, z forward), world; focal (pixels) and
    the principal point cx, cy: pixel (u, v) looks along (u + 1/2 - cx, v + 1/2 - cy, focal) in the
    camera frame. ``exclude``: a body not seen (-1: none); ``seen`` (N,) bool; the shapes and the
    tree as ``ray_cast_kernel`` takes them; ``colors`` (N, 3) uint8 each body's colour, ``sky``
    (3,) uint8, lit by ambient + diffuse |n . d|. Outputs: depth (z in the camera frame), distance
    (H, W) m (inf: no hit), body (H, W) int64 (-1), point, normal (H, W, 3) world (NaN), rgb
    (H, W, 3) uint8."""
    H, W = depth.shape
    for v in prange(H):
        origin = np.empty((W, 3))
        direction = np.empty((W, 3))
        reach = np.full(W, max_distance)
        skip = np.full(W, exclude)
        hit_shape = np.empty(W, dtype=np.int64)
        hit_distance = np.empty(W)
        hit_normal = np.empty((W, 3))
        stack = np.empty(64, dtype=np.int64)
        stack_enter = np.empty(64)
        y = (v + 0.5 - cy) / focal
        for u in range(W):
            x = (u + 0.5 - cx) / focal
            n = math.sqrt(x * x + y * y + 1.0)
            dx, dy, dz = x / n, y / n, 1.0 / n
            for k in range(3):
                origin[u, k] = centre[k]
                direction[u, k] = axes[k, 0] * dx + axes[k, 1] * dy + axes[k, 2] * dz
            _cast_one(u, origin, direction, reach, skip, seen, planes, items, tree_aabb, tree_first, tree_count,
                      tree_skip, shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_data, hull_plane,
                      mesh_triangle, node_aabb, leaf_first, leaf_count, node_skip, stack, stack_enter, hit_shape,
                      hit_distance, hit_normal)
            s = hit_shape[u]
            if s < 0:
                depth[v, u] = np.inf
                distance[v, u] = np.inf
                body[v, u] = -1
                for k in range(3):
                    point[v, u, k] = np.nan
                    normal[v, u, k] = np.nan
                    rgb[v, u, k] = sky[k]
                continue
            t = hit_distance[u]
            b = shape_body[s]
            distance[v, u] = t
            depth[v, u] = t * (direction[u, 0] * axes[0, 2] + direction[u, 1] * axes[1, 2]
                               + direction[u, 2] * axes[2, 2])
            body[v, u] = b
            facing = 0.0
            for k in range(3):
                point[v, u, k] = centre[k] + t * direction[u, k]
                normal[v, u, k] = hit_normal[u, k]
                facing += hit_normal[u, k] * direction[u, k]
            light = ambient + diffuse * abs(facing)
            for k in range(3):
                rgb[v, u, k] = np.uint8(min(max(np.rint(colors[b, k] * light), 0.0), 255.0))


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
    return np.array(a, order="C")  # a new writable C array: see ``rows``


def rows(a: np.ndarray, n: int, dtype=float) -> np.ndarray:
    """``a`` broadcast to n rows, as a new writable C-contiguous array of ``dtype``.

    COMPILE: a Numba kernel is compiled once per layout of its array arguments; a read-only
    broadcast view or a transposed (Fortran-order) array given by a caller compiled the ray
    cast again (3-7 s each, measured at four layouts in the test suite), so every query hands
    its kernels this one layout."""
    return np.array(np.broadcast_to(a, (n,) + np.shape(a)[1:]), dtype=dtype, order="C")


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

    def tree(self, world, x=None, R=None):
        """(shape_pos (S, 3), shape_rot (S, 3, 3), planes (P,), items (M,), (tree_aabb, tree_first,
        tree_count, tree_skip)) at the world's current poses, or at the poses ``x`` (N, 3) m and
        ``R`` (N, 3, 3) given (a state inside a run: a timed explosion's shading)."""
        # C order: a run's state rows are strided views, and the bounds kernel takes one layout
        x = np.ascontiguousarray(world.x if x is None else x)
        R = np.ascontiguousarray(world.R if R is None else R)
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


    def cast(self, world, origin, direction, max_distance, exclude, seen, x=None, R=None):
        """``ray_cast_kernel`` over this scene's shapes at the world's poses (or ``x``, ``R``):
        origin, direction (unit) (K, 3), max_distance (K,) m, exclude (K,) int64 body or -1, seen
        (N,) bool. Returns (shape (K,) int64, -1 for none; distance (K,) m; normal (K, 3))."""
        pos, rot, planes, items, tree = self.tree(world, x, R)
        K = len(origin)
        shape = np.empty(K, dtype=np.int64)
        distance = np.empty(K)
        normal = np.empty((K, 3))
        table = self.table
        # PERF: a chunk of rays (a single ray: a sensor loop, a pick) on the calling thread: a parallel
        # region for it cost 1.4 ms a call instead of 14 us when another process kept the cores busy
        # (GNU OpenMP's waiting threads; a performance audit, session 43)
        kernel = ray_cast_kernel if K > RAYS_PER_CHUNK else ray_cast_serial
        kernel(origin, direction, max_distance, exclude, seen, planes, items, *tree, table.shape_type,
                        table.shape_body, table.shape_params, pos, rot, table.shape_data, table.hull_plane,
                        table.mesh_triangle, table.mesh_node_aabb, table.mesh_node_first, table.mesh_node_count,
                        table.mesh_node_skip, shape, distance, normal)
        return shape, distance, normal


def kept_scene(world) -> _RayScene:
    """The ``_RayScene`` kept on ``world`` between queries (ray casts, area queries), made anew
    when bodies were added."""
    scene = getattr(world, "_ray_scene", None)
    if scene is None or scene.body_count != world.body_count:
        scene = world._ray_scene = _RayScene(world)
    return scene


def _seen(world, mask, category=ALL_CATEGORIES) -> np.ndarray:
    """(N,) bool: the bodies a query sees: their collision category meets the query's ``mask``
    and their mask meets its ``category`` (Box2D's b2ShouldQueryShape), and they are not sensors
    (sensors are not solid: rays and area queries pass through them). The
    filters are read once per change (``World.filter_version``): a list comprehension per call
    cost ~0.1 ms at 1000 bodies, more than a single ray's cast."""
    query = CollisionFilter(category=category, mask=mask)  # the same checks and messages as a filter's
    key = (world.body_count, world.filter_version)
    cached = getattr(world, "_query_categories", None)
    if cached is None or cached[0] != key:
        filters = world.collision_filters_in_effect()  # a disabled body's meets no query
        cached = world._query_categories = (key, np.array([f.category for f in filters], dtype=np.int64),
                                            np.array([f.mask for f in filters], dtype=np.int64))
    return ((cached[1] & query.mask) != 0) & ((cached[2] & query.category) != 0) & ~world.sensor


def ray_cast(world, origin, direction, max_distance=np.inf, exclude=None, table=None,
             mask=ALL_CATEGORIES, category=ALL_CATEGORIES) -> RayHits:
    """The first shape of ``world`` along each ray, at the bodies' current poses.

    Args:
        world: a ``tumble.World``; bodies without a collision shape (particles, or no shape)
            are not seen.
        origin: (3,) or (R, 3) m, world, where each ray starts.
        direction: (3,) or (R, 3), world, not zero; made unit (distances are in metres).
        max_distance: m, a number or (R,), how far each ray looks (inf: without end).
        exclude: a body (``Body``, name or index) or (R,) body indices (-1: none) that the
            rays do not see, e.g. the body a sensor is mounted on.
        mask, category: the query's filter (Box2D's b2QueryFilter): a body is seen when its
            ``CollisionFilter.category`` meets ``mask`` and its ``mask`` meets ``category``
            (both default all: every body). Sensors are never seen.
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
    o = rows(o, R)
    d = rows(d, R)
    length = np.linalg.norm(d, axis=1)
    if np.any(length == 0.0):
        raise InputError("must not be zero", "direction")
    d /= length[:, None]
    dist = np.asarray(max_distance, dtype=float)
    if dist.ndim > 1 or (dist.ndim == 1 and len(dist) != R):
        raise InputError(f"must be a number or one per ray ({R}), got shape {dist.shape}", "max_distance")
    if np.any(np.isnan(dist)) or np.any(dist < 0.0):
        raise InputError("must be >= 0", "max_distance")
    dist = rows(dist, R)
    if exclude is None:
        skip = np.full(R, -1, dtype=np.int64)
    elif np.ndim(exclude) == 0:  # one body, as a Body, a name or an index
        try:
            skip = np.full(R, world.index_of(exclude), dtype=np.int64)
        except InputError as err:
            raise InputError(err.problem, "exclude") from None
    else:
        skip = np.array(exclude, dtype=np.int64, order="C")
        if skip.shape != (R,):
            raise InputError(f"must be one body or one index per ray ({R}), got shape {skip.shape}", "exclude")
    seen = _seen(world, mask, category)
    if table is None:
        scene = kept_scene(world)
    else:
        scene = _RayScene(world, table)
    shape, distance, normal = scene.cast(world, o, d, dist, skip, seen)
    table = scene.table
    hit = shape >= 0
    body = np.full(R, -1, dtype=np.int64)
    body[hit] = table.shape_body[shape[hit]]
    point = np.full((R, 3), np.nan)
    point[hit] = o[hit] + distance[hit, None] * d[hit]
    normal[~hit] = np.nan
    return RayHits(body=body, shape=shape, distance=distance, point=point, normal=normal)


def cast_image(world, centre, axes, focal: float, cx: float, cy: float, width: int, height: int,
               max_distance: float, exclude: int, mask: int, colors: np.ndarray, sky, ambient: float,
               diffuse: float) -> tuple:
    """The images of a pinhole camera by ``image_kernel`` (its docstring) at the world's present
    poses: (depth, distance, body, point, normal, rgb). ``exclude``: a body index or -1."""
    seen = _seen(world, mask)
    scene = kept_scene(world)
    pos, rot, planes, items, tree = scene.tree(world)
    table = scene.table
    H, W = int(height), int(width)
    out = (np.empty((H, W)), np.empty((H, W)), np.empty((H, W), dtype=np.int64), np.empty((H, W, 3)),
           np.empty((H, W, 3)), np.empty((H, W, 3), dtype=np.uint8))
    image_kernel(np.ascontiguousarray(centre, dtype=float), np.ascontiguousarray(axes, dtype=float), float(focal),
                 float(cx), float(cy), float(max_distance), int(exclude), seen, planes, items, *tree, table.shape_type,
                 table.shape_body, table.shape_params, pos, rot, table.shape_data, table.hull_plane,
                 table.mesh_triangle, table.mesh_node_aabb, table.mesh_node_first, table.mesh_node_count,
                 table.mesh_node_skip, np.ascontiguousarray(colors, dtype=np.uint8),
                 np.asarray(sky, dtype=np.uint8), float(ambient), float(diffuse), *out)
    return out
