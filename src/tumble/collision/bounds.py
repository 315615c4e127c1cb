"""Stage ``update_bounds``: world poses and AABBs of every shape.

Reads body ``x`` (N, 3), ``R`` (N, 3, 3), optionally ``v``, ``omega`` (N, 3) and the
ShapeTable; writes ``shape_pos`` (S, 3), ``shape_rot`` (S, 3, 3), ``shape_aabb`` (S, 2, 3)
(min row, max row) and ``shape_margin`` (S,).

Continuous collision (issue 3, deliverable 5) is by speculative margins (Catto, GDC 2014
"Continuous Collision"): a shape's margin is the speculative distance plus the farthest any
point of it can travel in the step, dt (|v| + |omega| r), r its farthest point from the
centre of mass. Two shapes whose gap is below the sum of their margins get contacts, and
the solver lets such a contact close its gap and no more, so a fast body stops at a thin
wall instead of passing it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..math3d import JIT, quat_to_matrix_into
from ..shapes import SHAPE_BOX, SHAPE_CAPSULE, SHAPE_CONE, SHAPE_CONVEX, SHAPE_CYLINDER, SHAPE_ELLIPSOID, SHAPE_MESH, SHAPE_SPHERE


@njit(**JIT)
def _update_bounds_kernel(x, R, v, omega, dt, shape_type, shape_body, shape_params, shape_local_pos, shape_local_q,
                          margin, shape_rest,
                          # outputs
                          shape_pos, shape_rot, shape_aabb, shape_margin):
    """x may be any (N, >= 3) array whose first three columns are the centres of mass (the packed state Y);
    ``shape_rest`` (S,) m or (0,): each shape's body's ``Material.margin`` (none: 0)."""
    local = np.empty((3, 3))
    extent = np.empty(3)
    for s in range(shape_type.shape[0]):
        b = shape_body[s]
        quat_to_matrix_into(shape_local_q[s], local)
        # shape pose in the world: p = x + R p_local, Rs = R Rlocal (DESIGN.md: p_world = R p_body + x)
        for i in range(3):
            shape_pos[s, i] = x[b, i] + R[b, i, 0] * shape_local_pos[s, 0] + R[b, i, 1] * shape_local_pos[s, 1] \
                + R[b, i, 2] * shape_local_pos[s, 2]
            for j in range(3):
                shape_rot[s, i, j] = R[b, i, 0] * local[0, j] + R[b, i, 1] * local[1, j] + R[b, i, 2] * local[2, j]
        t = shape_type[s]
        p = shape_params[s]
        for i in range(3):
            if t == SHAPE_SPHERE:
                e = p[0]
            elif t == SHAPE_CAPSULE:
                e = abs(shape_rot[s, i, 2]) * p[1] + p[0]
            elif t == SHAPE_BOX or t == SHAPE_CONVEX or t == SHAPE_MESH:
                # half width of a rotated box along world axis i: sum_j |R_ij| h_j (convex, mesh: the box
                # |l_j| <= h_j around the shape origin that holds every vertex)
                e = abs(shape_rot[s, i, 0]) * p[0] + abs(shape_rot[s, i, 1]) * p[1] + abs(shape_rot[s, i, 2]) * p[2]
            elif t == SHAPE_CYLINDER:
                # a disc of radius r with normal u spans r sqrt(1 - u_i^2) along axis i; plus the axis h |u_i|
                u = shape_rot[s, i, 2]
                e = abs(u) * p[1] + p[0] * np.sqrt(max(0.0, 1.0 - u * u))
            elif t == SHAPE_CONE:
                # base disc at the origin, apex at height H along u: a cylinder of half length H around the
                # origin holds it (loose by up to H along the axis; the AABB stays centred on the shape origin)
                u = shape_rot[s, i, 2]
                e = abs(u) * p[1] + p[0] * np.sqrt(max(0.0, 1.0 - u * u))
            elif t == SHAPE_ELLIPSOID:
                # the support along world axis i: sqrt(sum_j (R_ij r_j)^2) (gjk.support's p . e_i)
                e = np.sqrt((shape_rot[s, i, 0] * p[0]) ** 2 + (shape_rot[s, i, 1] * p[1]) ** 2
                            + (shape_rot[s, i, 2] * p[2]) ** 2)
            else:
                # planes (and types without bounds yet) are unbounded; find_pairs skips them
                e = np.inf
            extent[i] = e
        # motion bound over the step: |v| dt + |omega| dt r, r = |shape origin - x| + |half extents|
        speed = math.sqrt(v[b, 0] ** 2 + v[b, 1] ** 2 + v[b, 2] ** 2)
        spin = math.sqrt(omega[b, 0] ** 2 + omega[b, 1] ** 2 + omega[b, 2] ** 2)
        sweep = 0.0
        if speed > 0.0 or spin > 0.0:
            r = math.sqrt(extent[0] ** 2 + extent[1] ** 2 + extent[2] ** 2) + math.sqrt(
                (shape_pos[s, 0] - x[b, 0]) ** 2 + (shape_pos[s, 1] - x[b, 1]) ** 2 + (shape_pos[s, 2] - x[b, 2]) ** 2)
            sweep = dt * (speed + spin * r)
        shape_margin[s] = margin + sweep
        if shape_rest.shape[0]:  # its contacts rest the margins apart: they start that much earlier
            shape_margin[s] += shape_rest[s]
        for i in range(3):
            shape_aabb[s, 0, i] = shape_pos[s, i] - extent[i] - shape_margin[s]
            shape_aabb[s, 1, i] = shape_pos[s, i] + extent[i] + shape_margin[s]


def update_bounds(x, R, table, margin, shape_pos=None, shape_rot=None, shape_aabb=None, v=None, omega=None,
                  dt: float = 0.0, shape_margin=None, shape_rest=None):
    """World poses, AABBs and speculative margins of all shapes of ``table``.

    Args:
        x: (N, 3) m, centres of mass, world (or the packed state (N, W): its first 3 columns).
        R: (N, 3, 3) body-to-world rotations.
        v, omega: (N, 3) m/s, rad/s, world; with ``dt`` (s) they widen each shape's margin
            by the distance it can travel in the step (None: no widening).
        table: the ``ShapeTable``.
        margin: m, added on every side (pass ``SPECULATIVE_DISTANCE``, 0.02 m: any two
            shapes closer than it then have overlapping boxes; half would do, the rest
            is slack for motion within a step).
        shape_pos, shape_rot, shape_aabb, shape_margin: optional output buffers (S, 3),
            (S, 3, 3), (S, 2, 3), (S,), reused when given (no allocation in the step).
        shape_rest: (S,) m, each shape's body's ``Material.margin``, added to its margin (a
            contact that rests that far apart must be found there); None: none.

    Returns:
        ``(shape_pos, shape_rot, shape_aabb)``: shape origins (world), shape-to-world
        rotations, AABBs ``[s, 0] = min``, ``[s, 1] = max`` (planes: -inf, +inf), grown
        by each shape's margin. With ``shape_margin`` given, it is filled too: m, the
        speculative distance plus the shape's motion bound over ``dt``.
    """
    S = table.shape_count
    if shape_pos is None:
        shape_pos = np.empty((S, 3))
    if shape_rot is None:
        shape_rot = np.empty((S, 3, 3))
    if shape_aabb is None:
        shape_aabb = np.empty((S, 2, 3))
    if shape_margin is None:
        shape_margin = np.empty(S)
    x = np.ascontiguousarray(x, dtype=np.float64)
    if v is None or omega is None:
        v = omega = np.zeros((1, 3)) if len(x) == 0 else np.zeros((len(x), 3))
        dt = 0.0
    _update_bounds_kernel(x, np.ascontiguousarray(R, dtype=np.float64),
                          np.ascontiguousarray(v, dtype=np.float64), np.ascontiguousarray(omega, dtype=np.float64),
                          float(dt), table.shape_type, table.shape_body, table.shape_params, table.shape_local_pos,
                          table.shape_local_q, float(margin), _NO_REST if shape_rest is None else shape_rest, shape_pos,
                          shape_rot, shape_aabb, shape_margin)
    return shape_pos, shape_rot, shape_aabb


_NO_REST = np.zeros(0)


def update_bounds_rows(x, R, table, rows, shape_pos, shape_rot, shape_aabb, shape_margin):
    """``update_bounds`` (at rest, no margin) of the shape rows ``rows`` (K,) int64 only, into the
    given (S, ...) buffers; the other rows are left as they were. The rows' table columns are
    gathered and the whole-table kernel run on them: a query about a few bodies of a large world
    (``distance.shape_poses``) then costs what their shapes cost."""
    from types import SimpleNamespace

    part = SimpleNamespace(shape_count=len(rows), shape_type=table.shape_type[rows], shape_body=table.shape_body[rows],
                           shape_params=table.shape_params[rows], shape_local_pos=table.shape_local_pos[rows],
                           shape_local_q=table.shape_local_q[rows])
    pos, rot, aabb = update_bounds(x, R, part, 0.0)
    shape_pos[rows], shape_rot[rows], shape_aabb[rows], shape_margin[rows] = pos, rot, aabb, 0.0

