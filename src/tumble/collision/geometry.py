"""Collision shapes as flat arrays: ``ShapeTable`` and ``build_shape_table(world)``.

Reads a World's shape records and ``com_offset``; writes nothing else. One row per
shape: a body whose shape is a ``Compound`` gets one row per part (``shape_body``
repeats, ``shape_local_pos``/``shape_local_q`` place the part in the body frame).

Supported: plane, sphere, capsule, cylinder, cone, box, ellipsoid, convex, and mesh on fixed and
kinematic bodies (on a moving body a mesh is its convex hull: ``moving_hull``). Particles
raise ``NotImplementedError`` naming the type and body (or get no row with
``skip_unsupported=True``).

``shape_params`` (S, 4), in the shape's own frame, metres:

=========  ===================================================
plane      (nx, ny, nz, offset): the plane n . p = offset, n unit
sphere     (radius, 0, 0, 0)
capsule    (radius, half_length, 0, 0): segment from -h z to +h z
cylinder   (radius, half_length, 0, 0): caps at z = -h and z = +h
cone       (radius, height, 0, 0): base disc at z = 0, apex at z = height
box        (hx, hy, hz, 0): half extents
ellipsoid  (a, b, c, 0): semi-axes along x, y, z
convex     (hx, hy, hz, 0): max |coordinate| of its vertices (bounds only)
mesh       (hx, hy, hz, 0): max |coordinate| of its vertices (bounds only)
=========  ===================================================

Convex hulls and meshes keep their data in flat arrays (kernels take arrays): see
``ShapeTable`` and ``ShapeTable.geometry``.
"""

from __future__ import annotations

import hashlib
import threading
import weakref
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from ..errors import TumbleWarning
from ..math3d import JIT, norm3, rows_dot
from ..shapes import (
    SHAPE_BOX,
    SHAPE_CAPSULE,
    SHAPE_CONE,
    SHAPE_CONVEX,
    SHAPE_CYLINDER,
    SHAPE_ELLIPSOID,
    SHAPE_MESH,
    SHAPE_PARTICLES,
    SHAPE_PLANE,
    SHAPE_SPHERE,
    Box,
    Capsule,
    Compound,
    Cone,
    Convex,
    Cylinder,
    Ellipsoid,
    Mesh,
    Plane,
    Sphere,
)

SHAPE_NAMES = {
    SHAPE_PLANE: "plane", SHAPE_SPHERE: "sphere", SHAPE_CAPSULE: "capsule", SHAPE_CYLINDER: "cylinder",
    SHAPE_CONE: "cone", SHAPE_BOX: "box", SHAPE_ELLIPSOID: "ellipsoid", SHAPE_CONVEX: "convex", SHAPE_MESH: "mesh", SHAPE_PARTICLES: "particles",
}
SUPPORTED_TYPES = (SHAPE_PLANE, SHAPE_SPHERE, SHAPE_CAPSULE, SHAPE_CYLINDER, SHAPE_CONE, SHAPE_BOX, SHAPE_ELLIPSOID,
                   SHAPE_CONVEX, SHAPE_MESH)

# Triangles per BVH leaf (a query then tests at most this many triangles per leaf it reaches).
BVH_LEAF_SIZE = 4


def _empty(shape, dtype=float):
    return lambda: np.zeros(shape, dtype=dtype)


# Families of analytic worlds: the narrowphase of a world of planes and boxes (stacks, piles,
# pyramids, dominoes) or of planes and spheres compiles only the routines it can call
# (narrowphase._family_pair_overload).
FAMILY_ALL, FAMILY_BOXES, FAMILY_SPHERES = 0, 1, 2


def analytic_family(shape_type) -> int:
    """The family of a world whose shapes (S,) SHAPE_* are all analytic: FAMILY_BOXES when they
    are planes and boxes, FAMILY_SPHERES when planes and spheres, else FAMILY_ALL."""
    present = set(np.unique(shape_type).tolist())
    if present <= {SHAPE_PLANE, SHAPE_BOX}:
        return FAMILY_BOXES
    if present <= {SHAPE_PLANE, SHAPE_SPHERE}:
        return FAMILY_SPHERES
    return FAMILY_ALL


@dataclass
class ShapeTable:
    """Every collision shape of a World, one row each (constants: they change only when bodies are added).

    Attributes:
        shape_type: (S,) int64, ``SHAPE_*`` id of ``tumble.shapes``.
        shape_body: (S,) int64, index of the body the shape belongs to.
        shape_params: (S, 4) float, see the module docstring; metres.
        shape_local_pos: (S, 3) m, the shape origin in the body frame (``part position - com_offset``).
        shape_local_q: (S, 4) (w, x, y, z), shape frame to body frame (identity except compound parts).
        body_moving: (N,) bool, a copy of ``World.moving`` (False for fixed bodies).
        shape_data: (S, 4) int64 offsets into the arrays below: convex
            ``(vertex_first, vertex_count, face_first, face_count)``, mesh
            ``(triangle_first, triangle_count, node_first, node_count)``, else zeros.
        hull_vertex: (V, 3) m, vertices of every convex hull, shape frame.
        hull_face_first, hull_face_count: (F,) int64, face f's vertices are
            ``hull_face_vertex[first : first + count]``.
        hull_face_vertex: (K,) int64 rows of ``hull_vertex``, counter-clockwise seen from outside.
        hull_plane: (F, 4) outward unit normal and offset (n, d) of each face, n . p = d, shape frame.
        mesh_triangle: (T, 3, 3) m, triangle corners (shape frame), counter-clockwise
            seen from outside, in BVH leaf order.
        mesh_edge_active: (T,) int64, bit k set when edge k (corner k to k + 1) is a
            convex edge of the mesh (its neighbour bends away); flat and concave edges
            are inactive (no edge normals there: internal-edge fix, ``pairs/mesh``). An open
            mesh's triangles are two-sided: the ``TWO_SIDED`` bit, and the back's flags in bits
            3-5 (``mesh_edge_flags``).
        mesh_node_aabb: (B, 2, 3) m, BVH node boxes (min row, max row), shape frame, preorder.
        mesh_node_first, mesh_node_count: (B,) int64, a leaf's triangles (count 0 for inner nodes).
        mesh_node_skip: (B,) int64, the node after this node's subtree (stackless walk).
    """

    shape_type: np.ndarray
    shape_body: np.ndarray
    shape_params: np.ndarray
    shape_local_pos: np.ndarray
    shape_local_q: np.ndarray
    body_moving: np.ndarray
    shape_data: np.ndarray = None
    hull_vertex: np.ndarray = field(default_factory=_empty((0, 3)))
    hull_face_first: np.ndarray = field(default_factory=_empty(0, np.int64))
    hull_face_count: np.ndarray = field(default_factory=_empty(0, np.int64))
    hull_face_vertex: np.ndarray = field(default_factory=_empty(0, np.int64))
    hull_plane: np.ndarray = field(default_factory=_empty((0, 4)))
    mesh_triangle: np.ndarray = field(default_factory=_empty((0, 3, 3)))
    mesh_edge_active: np.ndarray = field(default_factory=_empty(0, np.int64))
    mesh_node_aabb: np.ndarray = field(default_factory=_empty((0, 2, 3)))
    mesh_node_first: np.ndarray = field(default_factory=_empty(0, np.int64))
    mesh_node_count: np.ndarray = field(default_factory=_empty(0, np.int64))
    mesh_node_skip: np.ndarray = field(default_factory=_empty(0, np.int64))
    #: (S,) a compound part's own Material (``Compound.materials``), or None: its body's
    shape_material: tuple = ()

    def __post_init__(self):
        if self.shape_data is None:
            self.shape_data = np.zeros((len(self.shape_type), 4), dtype=np.int64)
        #: every shape is a plane, sphere, capsule or box: ``collide_pairs`` then uses the kernels
        #: that dispatch to the closed-form routines alone (a smaller compile, narrowphase.py)
        self.analytic_only = bool(np.all((self.shape_type == SHAPE_PLANE) | (self.shape_type == SHAPE_SPHERE)
                                         | (self.shape_type == SHAPE_CAPSULE) | (self.shape_type == SHAPE_BOX)))
        #: which of those kernels: the routines of planes and boxes, of planes and spheres, or all
        self.analytic_family = analytic_family(self.shape_type)
        #: some shape is round: the contact solver's anchors then take the round offsets and shared
        #: points of ``solver.contact_anchor`` (else every anchor is fixed in its body)
        self.has_round = bool(np.any(np.isin(self.shape_type, (SHAPE_SPHERE, SHAPE_CAPSULE, SHAPE_CYLINDER,
                                                               SHAPE_CONE, SHAPE_ELLIPSOID))))
        #: some compound part has its own material: the contact solver then mixes per shape
        self.has_part_materials = any(m is not None for m in self.shape_material)

    def shape_materials(self, body_materials) -> dict[str, np.ndarray]:
        """{field: (S,) values} of each shape row's material (friction, restitution,
        rolling_resistance, spinning_friction; "combine": (S, 3) int64, its friction and restitution
        combine modes and condim, ``Material.combine_codes``): its part's own, else its body's
        (``body_materials``: the World's per-body list)."""
        mats = [own if own is not None else body_materials[b]
                for own, b in zip(self.shape_material or (None,) * self.shape_count, self.shape_body.tolist())]
        out = {f: np.array([getattr(m, f) for m in mats], dtype=float).reshape(-1)
               for f in ("friction", "restitution", "rolling_resistance", "spinning_friction")}
        out["combine"] = np.array([m.combine_codes() for m in mats], dtype=np.int64).reshape(-1, 3)
        return out

    @property
    def shape_count(self) -> int:
        return len(self.shape_type)

    @property
    def body_count(self) -> int:
        return len(self.body_moving)

    @property
    def geometry(self) -> tuple:
        """The extra arrays as one tuple, in the order the pair kernels unpack them (``pairs/convex.GEOMETRY``)."""
        return (self.shape_data, self.hull_vertex, self.hull_face_first, self.hull_face_count, self.hull_face_vertex,
                self.hull_plane, self.mesh_triangle, self.mesh_edge_active, self.mesh_node_aabb, self.mesh_node_first,
                self.mesh_node_count, self.mesh_node_skip)


def shape_params(shape) -> tuple[int, tuple[float, float, float, float]]:
    """``(SHAPE_* id, params (4,))`` of one shape record; NotImplementedError for types without collision."""
    if isinstance(shape, Plane):
        n = shape.normal
        return SHAPE_PLANE, (n[0], n[1], n[2], shape.offset)
    if isinstance(shape, Sphere):
        return SHAPE_SPHERE, (shape.radius, 0.0, 0.0, 0.0)
    if isinstance(shape, Capsule):
        return SHAPE_CAPSULE, (shape.radius, 0.5 * shape.length, 0.0, 0.0)
    if isinstance(shape, Cylinder):
        return SHAPE_CYLINDER, (shape.radius, 0.5 * shape.length, 0.0, 0.0)
    if isinstance(shape, Cone):
        return SHAPE_CONE, (shape.radius, shape.height, 0.0, 0.0)
    if isinstance(shape, Ellipsoid):
        return SHAPE_ELLIPSOID, (*shape.radii, 0.0)
    if isinstance(shape, Box):
        h = shape.half_extents
        return SHAPE_BOX, (float(h[0]), float(h[1]), float(h[2]), 0.0)
    if isinstance(shape, Mesh):  # Convex too
        h = np.max(np.abs(np.asarray(shape.vertices, dtype=float)), axis=0)
        return (SHAPE_CONVEX if isinstance(shape, Convex) else SHAPE_MESH), (float(h[0]), float(h[1]), float(h[2]), 0.0)
    type_id = getattr(shape, "type_id", None)
    name = SHAPE_NAMES.get(type_id, type(shape).__name__)
    raise NotImplementedError(f"collision shape {name!r} is not supported yet "
                              "(supported: plane, sphere, capsule, cylinder, cone, box, ellipsoid, convex, mesh)")


def _quat_mul(a, b):
    return np.array([
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ])


def _quat_rotate(q, v):
    w, x, y, z = q
    u = np.array([x, y, z])
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


def flatten_materials(shape, material):
    """The material of each of ``flatten_parts(shape)``'s parts: a compound part's own, else
    the nearest enclosing compound part's, else ``material`` (the body's)."""
    if not isinstance(shape, Compound):
        return [material]
    own = shape.materials or (None,) * len(shape.parts)
    out = []
    for (part, _, _), m in zip(shape.parts, own):
        out += flatten_materials(part, material if m is None else m)
    return out


def flatten_parts(shape, pos=None, q=None):
    """``[(shape, position (3,), orientation (4,))]`` of a shape, nested compounds expanded (shape frame)."""
    pos = np.zeros(3) if pos is None else pos
    q = np.array([1.0, 0.0, 0.0, 0.0]) if q is None else q
    if not isinstance(shape, Compound):
        return [(shape, pos, q)]
    out = []
    for part, p, pq in shape.parts:
        out += flatten_parts(part, pos + _quat_rotate(q, np.asarray(p, dtype=float)), _quat_mul(q, np.asarray(pq)))
    return out


def hull_polygons(vertices, faces):
    """Merge a convex hull's triangles into polygonal faces.

    Returns ``(planes (F, 4), polygons)``: outward unit normal and offset per face,
    and per face the vertex rows counter-clockwise seen from outside (sorted by
    angle about the face centroid; a hull face is convex, so that is its boundary).
    """
    import trimesh

    v = np.asarray(vertices, dtype=float)
    tri = v[np.asarray(faces)]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    # coplanar neighbours: trimesh's facets (adjacent faces with parallel normals), then the single faces
    groups = [list(map(int, g)) for g in trimesh.Trimesh(vertices=v, faces=np.asarray(faces), process=False).facets]
    grouped = np.zeros(len(tri), dtype=bool)
    for g in groups:
        grouped[g] = True
    groups += [[t] for t in np.flatnonzero(~grouped).tolist()]
    planes, polygons = [], []
    # products without BLAS (math3d.rows_dot): the planes' last bits are the same on every machine
    for g in groups:
        normal = n[g].mean(axis=0)
        normal /= norm3(normal)
        ids = np.unique(np.asarray(faces)[g].ravel())
        pts = v[ids]
        centre = pts.mean(axis=0)
        t1 = pts[np.argmax(np.linalg.norm(pts - centre, axis=1))] - centre
        t1 -= float(rows_dot(t1[None, :], normal)[0]) * normal
        t1 /= norm3(t1)
        t2 = np.cross(normal, t1)
        angle = np.arctan2(rows_dot(pts - centre, t2), rows_dot(pts - centre, t1))
        polygons.append(ids[np.argsort(angle, kind="stable")])
        planes.append([*normal, float(np.max(rows_dot(pts, normal)))])
    return np.asarray(planes, dtype=float).reshape(-1, 4), polygons


def hull_faces(convex):
    """``hull_polygons`` of a ``Convex`` record, merged on the first call and then kept on the record
    with a digest of the arrays it was merged from (an array edited in place has another digest and
    is merged again). Every shape table (each Simulator's first step, each step after a spawn, a ray
    cast's) took each distinct hull's faces anew: 7-8 ms a hull in trimesh's facets, so a spawn into
    a world of 1000 distinct hulls (fractured cells, decomposed pieces, rocks) stalled 7.5 s
    (docs/benchmarks.md, "Hull faces kept")."""
    v = np.ascontiguousarray(convex.vertices, dtype=float)
    f = np.ascontiguousarray(convex.faces, dtype=np.int64)
    key = _mesh_digest(v, f, True)  # (a hull is closed)
    kept = convex.__dict__.get("_hull_faces")
    if kept is not None and kept[0] == key:
        return kept[1], kept[2]
    planes, polygons = hull_polygons(v, f)
    planes.setflags(write=False)
    for poly in polygons:
        poly.setflags(write=False)
    object.__setattr__(convex, "_hull_faces", (key, planes, polygons))
    return planes, polygons


# mesh_edge_active bit of a two-sided triangle (an open mesh's, ``Mesh(closed=False)``): bits 0-2 hold its
# edges' activity seen from the front, bits 3-5 seen from the back, numbered as the edges of the turned
# triangle (corners 0, 2, 1) that collision/pairs/mesh.py collides a shape behind it with
TWO_SIDED = 64
BACK_SHIFT = 3


def mesh_edge_flags(vertices, faces, flat_cos: float = 1.0 - 1e-6, two_sided: bool = False):
    """(F,) int64: bit k set when edge k of face f (corner k to k + 1) is convex (an active edge).

    An edge is inactive when its neighbour face is coplanar (normals closer than
    ``flat_cos``) or bends up (its far corner above this face's plane): contacts
    there take the face normal. Edges without exactly one neighbour stay active.
    ``two_sided``: also the activity seen from the back (the far corner below the plane), in bits
    ``BACK_SHIFT + j`` for edge j of the turned triangle (corners 0, 2, 1: its edge j is edge 2 - j),
    and the ``TWO_SIDED`` bit. Neither test needs the neighbour wound as this face: the far corner's
    side of this face's plane decides, and a coplanar neighbour wound the other way is neither
    convex nor concave (inactive, as a flat one).
    """
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    F = len(f)
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    size = float(np.max(np.abs(v))) or 1.0
    # every (face, edge) by its undirected edge's key; an edge held by exactly two different faces has
    # a neighbour, any other (a border, or three faces and more) stays active on both sides.
    # PERF: by sorting, not a dict of lists (a Python loop: 1.6 s for an 80 000-triangle terrain)
    a, b = f, np.roll(f, -1, axis=1)  # edge k of face t runs from corner k to k + 1
    key = (np.minimum(a, b) * (int(f.max()) + 1 if F else 1) + np.maximum(a, b)).ravel()
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    starts = np.flatnonzero(np.r_[True, sorted_key[1:] != sorted_key[:-1]])
    counts = np.diff(np.r_[starts, len(key)])
    pair = starts[counts == 2]
    first, second = order[pair], order[pair + 1]  # flat indices t * 3 + k
    distinct = first // 3 != second // 3
    first, second = first[distinct], second[distinct]
    this = np.r_[first, second]
    other = np.r_[second, first]
    t, k = this // 3, this % 3
    u, ku = other // 3, other % 3
    active = np.ones((F, 3), dtype=bool)
    active[t, k] = False
    back = active.copy()
    far = v[f[u, (ku + 2) % 3]]
    flat = np.einsum("ij,ij->i", n[t], n[u]) > flat_cos
    height = np.einsum("ij,ij->i", n[t], far - tri[t, 0])
    active[t, k] = (height < -1e-9 * size) & ~flat
    back[t, k] = (height > 1e-9 * size) & ~flat
    flags = (active.astype(np.int64) << np.arange(3)).sum(axis=1)
    if two_sided:
        # back edge j is edge 2 - j of the face (the turned triangle's numbering)
        flags |= (back[:, ::-1].astype(np.int64) << (BACK_SHIFT + np.arange(3))).sum(axis=1)
        flags |= TWO_SIDED
    return flags


@njit(**JIT)
def _bvh_kernel(centroid, lo_t, hi_t, leaf_size):
    """``build_bvh``'s tree, compiled and iterative (a stack of (start, stop) ranges, the left child's
    on top) instead of the recursive Python closure it was before (2.2 s for a 102 134-triangle heightfield): the same median
    splits and the same stable sorts (mergesort is stable, as NumPy's ``kind="stable"``), so the
    same preorder arrays, bit for bit."""
    T = centroid.shape[0]
    order = np.arange(T)
    cap = max(2 * T - 1, 1)  # each leaf holds at least one triangle: at most 2T - 1 nodes
    aabb = np.empty((cap, 2, 3))
    first = np.zeros(cap, dtype=np.int64)
    count = np.zeros(cap, dtype=np.int64)
    skip = np.zeros(cap, dtype=np.int64)
    stack = np.empty((128, 2), dtype=np.int64)  # depth ~ log2(T / leaf_size) + 1
    stack[0, 0], stack[0, 1] = 0, T
    top = 1
    n = 0
    while top > 0:
        top -= 1
        start, stop = stack[top, 0], stack[top, 1]
        me = n
        n += 1
        for k in range(3):
            lo = lo_t[order[start], k]
            hi = hi_t[order[start], k]
            for j in range(start + 1, stop):
                t = order[j]
                if lo_t[t, k] < lo:
                    lo = lo_t[t, k]
                if hi_t[t, k] > hi:
                    hi = hi_t[t, k]
            aabb[me, 0, k] = lo
            aabb[me, 1, k] = hi
        first[me] = start
        if stop - start <= leaf_size:
            count[me] = stop - start
            continue
        axis = 0
        widest = -np.inf
        for k in range(3):  # the centroids' widest extent (the first axis on a tie, as np.argmax)
            lo = centroid[order[start], k]
            hi = lo
            for j in range(start + 1, stop):
                c = centroid[order[j], k]
                if c < lo:
                    lo = c
                if c > hi:
                    hi = c
            if hi - lo > widest:
                widest = hi - lo
                axis = k
        m = stop - start
        key = np.empty(m)
        idx = order[start:stop].copy()
        for j in range(m):
            key[j] = centroid[idx[j], axis]
        perm = np.argsort(key, kind="mergesort")
        for j in range(m):
            order[start + j] = idx[perm[j]]
        mid = (start + stop) // 2
        if top + 2 > stack.shape[0]:
            grown = np.empty((2 * stack.shape[0], 2), dtype=np.int64)
            grown[:top] = stack[:top]
            stack = grown
        stack[top, 0], stack[top, 1] = mid, stop
        stack[top + 1, 0], stack[top + 1, 1] = start, mid
        top += 2
    # the node after each subtree, children before parents: a leaf's is the next node, an inner
    # node's that of its right child (the node after its left child's subtree)
    for i in range(n - 1, -1, -1):
        skip[i] = i + 1 if count[i] > 0 else skip[skip[i + 1]]
    return order, aabb[:n].copy(), first[:n].copy(), count[:n].copy(), skip[:n].copy()


def build_bvh(triangles, leaf_size: int = BVH_LEAF_SIZE):
    """A median-split AABB tree over triangles (T, 3, 3), laid out in preorder.

    Returns ``(order (T,), node_aabb (B, 2, 3), node_first (B,), node_count (B,),
    node_skip (B,))``: triangles must be stored as ``triangles[order]``; a leaf
    holds ``node_count`` of them from ``node_first``; inner nodes have count 0
    and their left child next in the arrays; ``node_skip`` is the node after the
    subtree (``B`` for the last).

    Each node over ``order[start:stop]`` with more than ``leaf_size`` triangles sorts them (stably)
    by their centroids along the axis where the centroids spread widest and splits at
    ``(start + stop) // 2``. Compiled (``_bvh_kernel``): 102 134 triangles 35x faster than the
    recursive Python closure it replaced (docs/benchmarks.md, "Static mesh trees"); the same arrays. A world builds a mesh's
    tree once (``mesh_tree``).
    """
    triangles = np.asarray(triangles, dtype=float)
    if len(triangles) == 0:
        raise ValueError("a BVH needs at least one triangle")
    centroid = np.ascontiguousarray(triangles.mean(axis=1))
    lo_t = np.ascontiguousarray(triangles.min(axis=1))
    hi_t = np.ascontiguousarray(triangles.max(axis=1))
    return _bvh_kernel(centroid, lo_t, hi_t, np.int64(leaf_size))


class MeshTree:
    """A static mesh's collision data, as its rows of the ShapeTable hold it: ``triangle`` (T, 3, 3) in
    BVH leaf order, ``edge_flags`` (T,) (``mesh_edge_flags``, same order), and the BVH's
    ``node_aabb``, ``node_first``, ``node_count``, ``node_skip`` (``build_bvh``). Read-only arrays."""

    __slots__ = ("triangle", "edge_flags", "node_aabb", "node_first", "node_count", "node_skip", "__weakref__")

    def __init__(self, triangle, edge_flags, node_aabb, node_first, node_count, node_skip):
        for name, value in zip(self.__slots__, (triangle, edge_flags, node_aabb, node_first, node_count, node_skip)):
            value = np.ascontiguousarray(value)
            value.setflags(write=False)
            setattr(self, name, value)


# Trees made, by the content they were made from (a digest of the vertices, faces, closed and the
# leaf size): a World's every shape table (each Simulator's, a ray cast's, each one after a spawn)
# takes a mesh's tree from here instead of building it again (each used to build it again: 2.2 s
# for a 102 134-triangle heightfield). Weak: a tree lives as long as a record that took it
# (``_TREE_OF_RECORD``, weak on the record), so nothing is kept past its meshes and a pickled
# record carries no tree (it finds it here again by content, or builds it). A record whose arrays
# were edited in place has another digest, so it is never served its old tree.
_TREE_BY_CONTENT: weakref.WeakValueDictionary = weakref.WeakValueDictionary()
_TREE_OF_RECORD: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_TREE_LOCK = threading.Lock()


def _mesh_digest(vertices, faces, closed: bool) -> bytes:
    h = hashlib.blake2b(digest_size=20)
    h.update(np.array([vertices.shape[0], faces.shape[0], int(closed), BVH_LEAF_SIZE], dtype=np.int64).tobytes())
    h.update(memoryview(vertices).cast("B"))
    h.update(memoryview(faces).cast("B"))
    return h.digest()


def mesh_tree(mesh) -> MeshTree:
    """The ``MeshTree`` of a triangle ``Mesh`` record (a fixed or kinematic body's), built on the first
    call for its content and then shared (``_TREE_BY_CONTENT``): hashing the arrays costs a few ms
    (7 ms for 102 134 triangles on a loaded 2-core machine)."""
    v = np.ascontiguousarray(mesh.vertices, dtype=float)
    f = np.ascontiguousarray(mesh.faces, dtype=np.int64)
    closed = bool(mesh.closed)
    key = _mesh_digest(v, f, closed)
    with _TREE_LOCK:
        tree = _TREE_BY_CONTENT.get(key)
    if tree is None:
        tri = v[f]
        flags = mesh_edge_flags(v, f, two_sided=not closed)
        order, aabb, first, count, skip = build_bvh(tri)
        tree = MeshTree(tri[order], flags[order], aabb, first, count, skip)
        with _TREE_LOCK:
            tree = _TREE_BY_CONTENT.setdefault(key, tree)
    try:
        with _TREE_LOCK:
            _TREE_OF_RECORD[mesh] = tree
    except TypeError:  # a record that takes no weak reference: its tree is not kept (built again next time)
        pass
    return tree


def moving_hull(mesh, name):
    """The ``Convex`` a triangle mesh on a moving body collides as: its convex hull (PyBullet's and
    MuJoCo's treatment of a moving mesh), made once per record. Triangle meshes collide as such only
    on fixed and kinematic bodies (the mesh pairs take the mesh as static). A concave mesh's hull
    fills its hollows (a ring's hull rests on a peg's top), so then a ``TumbleWarning`` names the
    body and ``tumble.decompose``, once per record. (Before session 18 a moving mesh collided with
    nothing, without a word: a ring dropped on the ground fell through it.)"""
    hull = mesh.__dict__.get("_moving_hull")
    if hull is None:
        hull = Convex(points=mesh.vertices)
        object.__setattr__(mesh, "_moving_hull", hull)
        volume, hull_volume = abs(float(mesh.trimesh.volume)), abs(float(hull.trimesh.volume))
        if hull_volume > volume * (1.0 + 1e-6):
            import warnings

            warnings.warn(f"body {name!r}: a moving triangle mesh collides as its convex hull, "
                          f"{100.0 * (hull_volume / volume - 1.0):.3g} % more volume than the mesh; cut it into convex "
                          "pieces with tumble.decompose (scene files: decompose = true)", TumbleWarning, stacklevel=2)
    return hull


class _Builder:
    """Collects the rows and the flat hull / mesh arrays."""

    def __init__(self):
        self.rows = []  # (type, body, params, local_pos, local_q, data)
        self.hv, self.hff, self.hfc, self.hfv, self.hp = [], [], [], [], []
        self.mt, self.me, self.na, self.nf, self.nc, self.ns = [], [], [], [], [], []
        self.n_hv = self.n_hf = self.n_hfv = self.n_t = self.n_n = 0
        # rows of hull / mesh data already stored, by record: bodies sharing a record share its data
        self.seen: dict[int, tuple] = {}

    def add(self, shape, body, local_pos, local_q, moving, name):
        type_id, p = shape_params(shape)
        data = (0, 0, 0, 0)
        if type_id == SHAPE_MESH and moving:
            shape = moving_hull(shape, name)
            type_id, p = shape_params(shape)
        if type_id in (SHAPE_CONVEX, SHAPE_MESH) and id(shape) in self.seen:
            data = self.seen[id(shape)][1]
        elif type_id == SHAPE_CONVEX:
            planes, polygons = hull_faces(shape)  # merged once per record and content, not per table
            v = np.asarray(shape.vertices, dtype=float)
            data = (self.n_hv, len(v), self.n_hf, len(planes))
            for poly in polygons:
                self.hff.append(self.n_hfv)
                self.hfc.append(len(poly))
                self.hfv.append(np.asarray(poly, dtype=np.int64) + self.n_hv)
                self.n_hfv += len(poly)
            self.hv.append(v)
            self.hp.append(planes)
            self.n_hv += len(v)
            self.n_hf += len(planes)
        elif type_id == SHAPE_MESH:
            tree = mesh_tree(shape)  # built once per mesh content, not per table
            data = (self.n_t, len(tree.triangle), self.n_n, len(tree.node_aabb))
            self.mt.append(tree.triangle)
            self.me.append(tree.edge_flags)
            self.na.append(tree.node_aabb)
            self.nf.append(tree.node_first + self.n_t)
            self.nc.append(tree.node_count)
            self.ns.append(tree.node_skip + self.n_n)
            self.n_t += len(tree.triangle)
            self.n_n += len(tree.node_aabb)
        if type_id in (SHAPE_CONVEX, SHAPE_MESH):
            self.seen[id(shape)] = (shape, data)  # the record is kept alive with its id
        self.rows.append((type_id, body, p, local_pos, local_q, data))

    def table(self, moving, materials=()) -> ShapeTable:
        s = len(self.rows)

        def cat(parts, shape, dtype=float):
            return np.ascontiguousarray(np.concatenate(parts) if parts else np.zeros(shape, dtype=dtype), dtype=dtype)

        return ShapeTable(
            shape_type=np.array([r[0] for r in self.rows], dtype=np.int64).reshape(s),
            shape_body=np.array([r[1] for r in self.rows], dtype=np.int64).reshape(s),
            shape_params=np.array([r[2] for r in self.rows], dtype=float).reshape(s, 4),
            shape_local_pos=np.array([r[3] for r in self.rows], dtype=float).reshape(s, 3),
            shape_local_q=np.array([r[4] for r in self.rows], dtype=float).reshape(s, 4),
            body_moving=np.array(moving, dtype=bool),
            shape_data=np.array([r[5] for r in self.rows], dtype=np.int64).reshape(s, 4),
            hull_vertex=cat(self.hv, (0, 3)),
            hull_face_first=np.array(self.hff, dtype=np.int64),
            hull_face_count=np.array(self.hfc, dtype=np.int64),
            hull_face_vertex=cat(self.hfv, (0,), np.int64),
            hull_plane=cat(self.hp, (0, 4)),
            mesh_triangle=cat(self.mt, (0, 3, 3)),
            mesh_edge_active=cat(self.me, (0,), np.int64),
            mesh_node_aabb=cat(self.na, (0, 2, 3)),
            mesh_node_first=cat(self.nf, (0,), np.int64),
            mesh_node_count=cat(self.nc, (0,), np.int64),
            mesh_node_skip=cat(self.ns, (0,), np.int64),
            shape_material=tuple(materials),
        )


def build_shape_table(world, skip_unsupported: bool = False) -> ShapeTable:
    """The ``ShapeTable`` of ``world``: one row per shape (per part of a compound), in body order.

    Args:
        world: a ``tumble.World``.
        skip_unsupported: if True, bodies with a shape (or a part) that has no
            collision support get no rows (they collide with nothing) instead of raising.

    Raises:
        NotImplementedError: a body's shape type has no collision support (particles); the
            message names the type and the body.
    """
    builder = _Builder()
    com_offset = np.asarray(world.com_offset)
    moving = np.asarray(world.moving, dtype=bool)
    materials = []  # per row: a compound part's own material, or None
    for i, shape in enumerate(world.shapes):
        parts = flatten_parts(shape)
        mark = len(builder.rows), (builder.n_hv, builder.n_hf, builder.n_hfv, builder.n_t, builder.n_n)
        lists = [builder.hv, builder.hff, builder.hfc, builder.hfv, builder.hp,
                 builder.mt, builder.me, builder.na, builder.nf, builder.nc, builder.ns]
        sizes = [len(x) for x in lists]
        seen = dict(builder.seen)
        try:
            for part, pos, q in parts:
                builder.add(part, i, np.asarray(pos, dtype=float) - com_offset[i], np.asarray(q, dtype=float),
                            bool(moving[i]), world.names[i])
            materials += flatten_materials(shape, None)
        except NotImplementedError as err:
            if not skip_unsupported:
                msg = str(err)
                raise NotImplementedError(msg if msg.startswith("body ") else f"body {world.names[i]!r}: {msg}") from None
            # drop this body's rows and data
            del builder.rows[mark[0]:]
            for x, n in zip(lists, sizes):
                del x[n:]
            builder.n_hv, builder.n_hf, builder.n_hfv, builder.n_t, builder.n_n = mark[1]
            builder.seen = seen
    assert len(materials) == len(builder.rows)  # one row per part
    return builder.table(world.moving, materials)
