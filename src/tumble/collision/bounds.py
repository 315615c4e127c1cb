"""Stage ``update_bounds``: world poses and AABBs of every shape.

Reads body ``x`` (N, 3), ``R`` (N, 3, 3) and the ShapeTable; writes ``shape_pos``
(S, 3), ``shape_rot`` (S, 3, 3) and ``shape_aabb`` (S, 2, 3) (min row, max row).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..math3d import JIT, quat_to_matrix_into
from ..shapes import SHAPE_BOX, SHAPE_CAPSULE, SHAPE_SPHERE


@njit(**JIT)
def _update_bounds_kernel(x, R, shape_type, shape_body, shape_params, shape_local_pos, shape_local_q, margin,
                          # outputs
                          shape_pos, shape_rot, shape_aabb):
    local = np.empty((3, 3))
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
            elif t == SHAPE_BOX:
                # half width of a rotated box along world axis i: sum_j |R_ij| h_j
                e = abs(shape_rot[s, i, 0]) * p[0] + abs(shape_rot[s, i, 1]) * p[1] + abs(shape_rot[s, i, 2]) * p[2]
            else:
                # planes (and types without bounds yet) are unbounded; find_pairs skips them
                e = np.inf
            shape_aabb[s, 0, i] = shape_pos[s, i] - e - margin
            shape_aabb[s, 1, i] = shape_pos[s, i] + e + margin


def update_bounds(x, R, table, margin, shape_pos=None, shape_rot=None, shape_aabb=None):
    """World poses and AABBs of all shapes of ``table``.

    Args:
        x: (N, 3) m, centres of mass, world.
        R: (N, 3, 3) body-to-world rotations.
        table: the ``ShapeTable``.
        margin: m, added on every side (pass ``SPECULATIVE_DISTANCE``, 0.02 m: any two
            shapes closer than it then have overlapping boxes; half would do, the rest
            is slack for motion within a step).
        shape_pos, shape_rot, shape_aabb: optional output buffers (S, 3), (S, 3, 3),
            (S, 2, 3), reused when given (no allocation in the step).

    Returns:
        ``(shape_pos, shape_rot, shape_aabb)``: shape origins (world), shape-to-world
        rotations, AABBs ``[s, 0] = min``, ``[s, 1] = max`` (planes: -inf, +inf).
    """
    S = table.shape_count
    if shape_pos is None:
        shape_pos = np.empty((S, 3))
    if shape_rot is None:
        shape_rot = np.empty((S, 3, 3))
    if shape_aabb is None:
        shape_aabb = np.empty((S, 2, 3))
    _update_bounds_kernel(np.ascontiguousarray(x, dtype=np.float64), np.ascontiguousarray(R, dtype=np.float64),
                          table.shape_type, table.shape_body, table.shape_params, table.shape_local_pos,
                          table.shape_local_q, float(margin), shape_pos, shape_rot, shape_aabb)
    return shape_pos, shape_rot, shape_aabb

