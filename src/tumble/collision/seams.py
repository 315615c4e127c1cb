"""Stage ``flatten_seam_ghosts``: contacts at the seam between two flush static shapes take the floor's normal.

Why. Two static boxes (or mesh tiles, or heightfield tiles) laid side by side with their tops
flush make one flat floor, but each pair routine sees only its own shape: for a box sliding
over the seam the box-box SAT between the slider and the box ahead finds its largest
separation along the side face of that box (a few mm ahead) and returns a speculative
manifold with a horizontal normal, as if the seam were a wall; for a ball the closest
feature is the top edge ahead, whose normal tilts up to 23 degrees while the gap is still
8 mm. The solver closes the gap and stops the body on that normal: the box trips (41 mm hop
at 3 m/s, 229 mm at 10 m/s), the ball jumps (680 mm at 10 m/s). Within ONE mesh the
internal-edge flags handle this (``pairs/mesh.py``); between separate bodies no single pair
routine can, so this stage looks at all of one body's contacts with static shapes at once.
Box2D calls these "ghost collisions" (Catto, "Ghost Collisions",
https://box2d.org/posts/2020/06/ghost-collisions/: a box sliding over two connected edges is
pushed back by the second; the chain shape's ghost vertices are its answer within one shape).
Jolt's "enhanced internal edge removal" (``InternalEdgeRemovingCollector``, after Terdiman,
"Contact generation for meshes", https://www.codercorner.com/MeshContacts.pdf) does it across
the sub-shapes of one body pair: a face contact voids its face's vertices, and a later edge or
vertex contact on voided vertices is dropped; it matches vertices, so tiles of different
tessellation (T-edges) escape it (jrouwe/JoltPhysics discussion 2047). Bullet's
``btAdjustInternalEdgeContacts`` bends a triangle's edge normal towards its neighbour's face.
This stage is our own form of the rule, across bodies, and on planes rather than shared
vertices (two tiles need not share their vertices along the seam).

The rule, for one moving body and its contacts this step with fixed shapes. A contact S
(the "support") is a face contact: its normal is a face normal of its static shape (a
plane, a box face, a hull face or a mesh triangle), n_f pointing towards the moving body,
and the static surface point s_S on the face's plane n_f . x = d_f. Another contact G, with
a different static shape, whose normal is not n_f, is a seam ghost when:

1. its point on its static shape (the contact point moved half the separation back along
   its normal) lies on that plane: |n_f . s_G - d_f| <= ``SEAM_TOLERANCE``;
2. its static feature does not rise above the plane: the shape's support along n_f (a mesh:
   the touched triangle's corners) is at most d_f + ``SEAM_TOLERANCE``. So nothing of it
   stands above the floor there: a real step (1 cm higher) or a wall rises above and keeps
   its contact;
3. the moving body's point of G is not sunk below the plane by more than ``LINEAR_SLOP``
   (a body that has fallen into a gap between the two touches a real side face).

A ghost's normal becomes n_f, its separation the plane distance of the moving body's point
(n_f . m - d_f), its point the midpoint of that gap: the floor extended over the seam, as
if the two shapes were one (a box resting across the seam already has two such face
contacts). The contact is kept, not dropped, so that it still holds the body up along n_f
(a speculative contact of a fast body stays a speculative contact) and its key (warm
starting) stays. Dropping it would do the same for the box's wall ghost; for the ball the
edge contact is the one that carries it over the seam.

Cost: one pass over the manifolds marks the moving bodies touching two or more static
shapes (none in a pile on one floor: the stage ends there); only their contacts are
grouped and compared, pairwise within the body (a few contacts each).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..math3d import JIT
from ..shapes import SHAPE_BOX, SHAPE_CONVEX, SHAPE_MESH, SHAPE_PLANE
from .constants import LINEAR_SLOP
from .pairs.convex import shape_arrays
from .pairs.gjk import core_radius, support

# Two static surfaces within this (m) of one plane are flush: a step lower than this is a seam.
# 1 mm: far below any step a body should feel (the solver's own slop is 5 mm), far above the
# rounding of placed tiles (1e-12 m) and of heightfield or mesh coordinates stored as float32
# (~1e-7 m at 1 km).
SEAM_TOLERANCE = 1e-3
# A normal within this (1 - cos) of a face normal is that face's (0.08 degrees; pairs/mesh.FACE_COS).
FACE_COS = 1e-6
# No triangle id in a mesh feature above this many triangles (pairs/mesh: the feature holds t mod 2**16).
MESH_FEATURE_TRIANGLES = 1 << 16


@njit(**JIT)
def _mesh_triangle_row(s, feature, shape_data):
    """The mesh triangle row of a mesh contact's feature (pairs/mesh: ``(t & 0xFFFF) << 5 | slot``),
    or -1 when the mesh has too many triangles for the feature to name one."""
    first = shape_data[s, 0]
    count = shape_data[s, 1]
    if count > MESH_FEATURE_TRIANGLES:
        return -1
    t = (feature >> 5) & 0xFFFF
    return first + ((t - first) & 0xFFFF)


@njit(**JIT)
def _triangle_normal(tri, rot):
    """The unit normal (world) of triangle ``tri`` (shape frame) under ``rot``; zeros when degenerate."""
    ux, uy, uz = tri[1, 0] - tri[0, 0], tri[1, 1] - tri[0, 1], tri[1, 2] - tri[0, 2]
    vx, vy, vz = tri[2, 0] - tri[0, 0], tri[2, 1] - tri[0, 1], tri[2, 2] - tri[0, 2]
    lx, ly, lz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    ln = math.sqrt(lx * lx + ly * ly + lz * lz)
    if ln == 0.0:
        return 0.0, 0.0, 0.0
    lx, ly, lz = lx / ln, ly / ln, lz / ln
    return (rot[0, 0] * lx + rot[0, 1] * ly + rot[0, 2] * lz, rot[1, 0] * lx + rot[1, 1] * ly + rot[1, 2] * lz,
            rot[2, 0] * lx + rot[2, 1] * ly + rot[2, 2] * lz)


@njit(**JIT)
def _is_face_normal(s, feature, nx, ny, nz, shape_type, shape_rot, shape_data, hull_plane, mesh_triangle):
    """True when (nx, ny, nz) (unit, world, out of static shape s) is one of s's face normals: a
    plane's, a box face's, a hull face's, or (a mesh) the touched triangle's, either side."""
    t = shape_type[s]
    if t == SHAPE_PLANE:
        return True
    rot = shape_rot[s]
    if t == SHAPE_BOX:
        for k in range(3):
            if abs(rot[0, k] * nx + rot[1, k] * ny + rot[2, k] * nz) >= 1.0 - FACE_COS:
                return True
        return False
    if t == SHAPE_CONVEX:
        f0 = shape_data[s, 2]
        for f in range(f0, f0 + shape_data[s, 3]):
            p = hull_plane[f]
            if rot[0, 0] * p[0] * nx + rot[1, 0] * p[0] * ny + rot[2, 0] * p[0] * nz \
                    + rot[0, 1] * p[1] * nx + rot[1, 1] * p[1] * ny + rot[2, 1] * p[1] * nz \
                    + rot[0, 2] * p[2] * nx + rot[1, 2] * p[2] * ny + rot[2, 2] * p[2] * nz >= 1.0 - FACE_COS:
                return True
        return False
    if t == SHAPE_MESH:
        row = _mesh_triangle_row(s, feature, shape_data)
        if row < 0:
            return False
        Nx, Ny, Nz = _triangle_normal(mesh_triangle[row], rot)
        return abs(Nx * nx + Ny * ny + Nz * nz) >= 1.0 - FACE_COS
    return False


@njit(**JIT)
def _height_over(s, feature, nx, ny, nz, shape_type, shape_params, shape_pos, shape_rot, shape_data, hull_vertex,
                 mesh_triangle):
    """How far static shape s (a mesh: the triangle its contact ``feature`` names) reaches along the
    unit (nx, ny, nz): max n . x over it; +inf when unknown (a plane, a mesh too large to name)."""
    t = shape_type[s]
    if t == SHAPE_PLANE:
        return np.inf
    pos = shape_pos[s]
    rot = shape_rot[s]
    if t == SHAPE_MESH:
        row = _mesh_triangle_row(s, feature, shape_data)
        if row < 0:
            return np.inf
        tri = mesh_triangle[row]
        high = -np.inf
        for v in range(3):
            h = 0.0
            for i in range(3):
                h += (pos[i] + rot[i, 0] * tri[v, 0] + rot[i, 1] * tri[v, 1] + rot[i, 2] * tri[v, 2]) * (nx, ny, nz)[i]
            high = max(high, h)
        return high
    verts, _f0, _nf = shape_arrays(t, s, shape_data, hull_vertex)
    p = support(t, pos, rot, shape_params[s], verts, nx, ny, nz)
    return p[0] * nx + p[1] * ny + p[2] * nz + core_radius(t, shape_params[s])


@njit(**JIT)
def flatten_seam_ghosts_kernel(shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_data, hull_vertex,
                               hull_plane, mesh_triangle, body_fixed, manifold_count,
                               m_shape_a, m_shape_b, m_normal, m_first, m_count,
                               c_point, c_normal, c_separation, c_feature):
    """The module docstring's rule over the first ``manifold_count`` manifolds, in place: the ghosts'
    ``c_normal``, ``c_separation`` and ``c_point`` (and ``m_normal`` of a manifold all of whose points
    are ghosts). Returns the number of contacts changed."""
    N = body_fixed.shape[0]
    first_static = np.full(N, -1, dtype=np.int64)
    several = np.zeros(N, dtype=np.bool_)
    # pass 1 (every manifold, O(M)): the moving bodies that touch two or more static shapes
    candidates = 0
    for m in range(manifold_count):
        a = m_shape_a[m]
        b = m_shape_b[m]
        fa = body_fixed[shape_body[a]]
        fb = body_fixed[shape_body[b]]
        if fa == fb:
            continue
        s = a if fa else b
        body = shape_body[b] if fa else shape_body[a]
        if first_static[body] < 0:
            first_static[body] = s
        elif first_static[body] != s:
            if not several[body]:
                candidates += 1
            several[body] = True
    if candidates == 0:
        return 0
    # pass 2: those bodies' static manifolds, grouped by body (stable: manifold order within a body)
    group = np.empty(manifold_count, dtype=np.int64)
    group_body = np.empty(manifold_count, dtype=np.int64)
    rows = 0
    for m in range(manifold_count):
        a = m_shape_a[m]
        b = m_shape_b[m]
        fa = body_fixed[shape_body[a]]
        body = shape_body[b] if fa else shape_body[a]
        if fa != body_fixed[shape_body[b]] and several[body]:
            group[rows] = m
            group_body[rows] = body
            rows += 1
    order = np.argsort(group_body[:rows], kind="mergesort")
    # per contact of the group: normal towards the moving body, and the face planes (n_f, d_f)
    changed = 0
    start = 0
    while start < rows:
        body = group_body[order[start]]
        end = start
        while end < rows and group_body[order[end]] == body:
            end += 1
        # the body's support contacts: face contacts, their plane (n_f, d_f) and static shape
        n_sup = 0
        for k in range(start, end):
            n_sup += m_count[group[order[k]]]
        sup_n = np.empty((n_sup, 3))
        sup_d = np.empty(n_sup)
        sup_shape = np.empty(n_sup, dtype=np.int64)
        n_sup = 0
        for k in range(start, end):
            m = group[order[k]]
            static_a = body_fixed[shape_body[m_shape_a[m]]]
            s = m_shape_a[m] if static_a else m_shape_b[m]
            sign = 1.0 if static_a else -1.0  # normals run from a to b: towards the body when a is static
            for c in range(m_first[m], m_first[m] + m_count[m]):
                nx, ny, nz = sign * c_normal[c, 0], sign * c_normal[c, 1], sign * c_normal[c, 2]
                if _is_face_normal(s, c_feature[c], nx, ny, nz, shape_type, shape_rot, shape_data, hull_plane,
                                   mesh_triangle):
                    h = 0.5 * c_separation[c]
                    sup_n[n_sup, 0], sup_n[n_sup, 1], sup_n[n_sup, 2] = nx, ny, nz
                    # the static surface point lies on the face's plane
                    sup_d[n_sup] = nx * (c_point[c, 0] - h * nx) + ny * (c_point[c, 1] - h * ny) \
                        + nz * (c_point[c, 2] - h * nz)
                    sup_shape[n_sup] = s
                    n_sup += 1
        if n_sup > 0:
            for k in range(start, end):
                m = group[order[k]]
                static_a = body_fixed[shape_body[m_shape_a[m]]]
                s = m_shape_a[m] if static_a else m_shape_b[m]
                sign = 1.0 if static_a else -1.0
                ghosts = 0
                for c in range(m_first[m], m_first[m] + m_count[m]):
                    nx, ny, nz = sign * c_normal[c, 0], sign * c_normal[c, 1], sign * c_normal[c, 2]
                    h = 0.5 * c_separation[c]
                    # the contact's point on the static shape and on the moving body
                    gx, gy, gz = c_point[c, 0] - h * nx, c_point[c, 1] - h * ny, c_point[c, 2] - h * nz
                    bx, by, bz = c_point[c, 0] + h * nx, c_point[c, 1] + h * ny, c_point[c, 2] + h * nz
                    for q in range(n_sup):
                        if sup_shape[q] == s:
                            continue
                        fx, fy, fz = sup_n[q, 0], sup_n[q, 1], sup_n[q, 2]
                        if nx * fx + ny * fy + nz * fz >= 1.0 - FACE_COS:
                            break  # already the floor's normal: nothing to do
                        d = sup_d[q]
                        if abs(fx * gx + fy * gy + fz * gz - d) > SEAM_TOLERANCE:
                            continue  # (1) not at the floor's level
                        lift = fx * bx + fy * by + fz * bz - d
                        if lift < -LINEAR_SLOP:
                            continue  # (3) the body is down beside the floor: a real side
                        if _height_over(s, c_feature[c], fx, fy, fz, shape_type, shape_params, shape_pos, shape_rot,
                                        shape_data, hull_vertex, mesh_triangle) > d + SEAM_TOLERANCE:
                            continue  # (2) the shape rises above the floor: a step or a wall
                        # a ghost: the floor's contact at the body's point, as if the floor went on
                        c_normal[c, 0], c_normal[c, 1], c_normal[c, 2] = sign * fx, sign * fy, sign * fz
                        c_separation[c] = lift
                        c_point[c, 0] = bx - 0.5 * lift * fx
                        c_point[c, 1] = by - 0.5 * lift * fy
                        c_point[c, 2] = bz - 0.5 * lift * fz
                        ghosts += 1
                        changed += 1
                        break
                if ghosts == m_count[m]:
                    c = m_first[m]
                    for i in range(3):
                        m_normal[m, i] = c_normal[c, i]
        start = end
    return changed


def flatten_seam_ghosts(contacts, table, shape_pos, shape_rot, body_fixed) -> int:
    """Stage four of ``CollisionPipeline.detect``: the seam ghosts of ``contacts`` (the module
    docstring) take their floor's normal, in place. ``body_fixed``: (N,) bool, the fixed bodies
    (``World.fixed``). Returns the number of contact points changed."""
    if contacts.manifold_count == 0:
        return 0
    # PERF: a seam needs two fixed shapes; a world of one floor (the 1000-box pile on its plane)
    # stops here, without the kernel's call (its 20 arguments: ~30 us on the pile, measured)
    if np.count_nonzero(body_fixed[table.shape_body]) < 2:
        return 0
    g = table.geometry
    m_shape_a, m_shape_b, _ba, _bb, m_normal, m_first, m_count, _cm, _cba, _cbb, c_point, c_normal, c_separation, \
        c_feature, _ck = contacts.buffers()
    return int(flatten_seam_ghosts_kernel(table.shape_type, table.shape_body, table.shape_params, shape_pos, shape_rot,
                                          g[0], g[1], g[5], g[6], np.ascontiguousarray(body_fixed, dtype=np.bool_),
                                          contacts.manifold_count, m_shape_a, m_shape_b, m_normal, m_first, m_count,
                                          c_point, c_normal, c_separation, c_feature))
