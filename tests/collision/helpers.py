"""Shared helpers of the collision tests: call one pair routine, rotations, box distances in plain NumPy."""

from __future__ import annotations

import numpy as np

import tumble as tb
from tumble.collision.geometry import _Builder
from tumble.collision.narrowphase import PAIR_WORK_ROWS, collide_shapes
from tumble.collision.pairs.convex import convex_scratch
from tumble.math3d import quat_to_matrix
from tumble.shapes import (
    SHAPE_BOX,
    SHAPE_CAPSULE,
    SHAPE_CONE,
    SHAPE_CONVEX,
    SHAPE_CYLINDER,
    SHAPE_MESH,
    SHAPE_PLANE,
    SHAPE_SPHERE,
)

SPEC = 0.02


def rot(axis, angle):
    """(3, 3) rotation about ``axis`` by ``angle`` rad (Rodrigues)."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    q = np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])
    return quat_to_matrix(q)


def random_rotation(rng):
    q = rng.normal(size=4)
    return quat_to_matrix(q / np.linalg.norm(q))


def plane(normal=(0, 0, 1), offset=0.0):
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    return SHAPE_PLANE, np.zeros(3), np.eye(3), np.array([*n, offset])


def sphere(pos, r):
    return SHAPE_SPHERE, np.asarray(pos, float), np.eye(3), np.array([r, 0, 0, 0.0])


def capsule(pos, R, r, half):
    return SHAPE_CAPSULE, np.asarray(pos, float), np.asarray(R, float), np.array([r, half, 0, 0.0])


def box(pos, R, h):
    return SHAPE_BOX, np.asarray(pos, float), np.asarray(R, float), np.array([*h, 0.0])


def cylinder(pos, R, r, half):
    return SHAPE_CYLINDER, np.asarray(pos, float), np.asarray(R, float), np.array([r, half, 0, 0.0]), tb.Cylinder(r, 2 * half)


def cone(pos, R, r, height):
    """A cone with its base centre at ``pos`` (the shape origin), apex at pos + height R z."""
    return SHAPE_CONE, np.asarray(pos, float), np.asarray(R, float), np.array([r, height, 0, 0.0]), tb.Cone(r, height)


def convex(pos, R, points):
    record = points if isinstance(points, tb.Convex) else tb.Convex(points=np.asarray(points, float))
    h = np.max(np.abs(record.vertices), axis=0)
    return SHAPE_CONVEX, np.asarray(pos, float), np.asarray(R, float), np.array([*h, 0.0]), record


def mesh(pos, R, vertices, faces):
    record = tb.Mesh(vertices=np.asarray(vertices, float), faces=np.asarray(faces))
    h = np.max(np.abs(record.vertices), axis=0)
    return SHAPE_MESH, np.asarray(pos, float), np.asarray(R, float), np.array([*h, 0.0]), record


_GEOMETRY_CACHE = {}


def geometry_of(*shapes):
    """``ShapeTable.geometry`` with one row per shape (hull / mesh data where the tuple carries a record)."""
    key = tuple((s[0], id(s[4]) if len(s) > 4 else None) for s in shapes)
    if key in _GEOMETRY_CACHE and all(len(s) <= 4 or _GEOMETRY_CACHE[key][1][k] is s[4] for k, s in enumerate(shapes)):
        return _GEOMETRY_CACHE[key][0]
    builder = _Builder()
    for k, s in enumerate(shapes):
        record = s[4] if len(s) > 4 else tb.Sphere(1.0)  # primitives: a placeholder row, no extra data
        builder.add(record, k, np.zeros(3), np.array([1.0, 0, 0, 0]), s[0] != SHAPE_MESH, f"shape{k}")
    geometry = builder.table(np.ones(len(shapes), dtype=bool)).geometry
    _GEOMETRY_CACHE[key] = (geometry, [s[4] if len(s) > 4 else None for s in shapes])
    return geometry


def collide(a, b, spec=SPEC, geometry=None):
    """Run the routine of shapes a, b (each (type, pos, R, params[, record])), a's type <= b's.

    Returns (normal (3,), points (n, 3), separations (n,), features (n,)).
    """
    assert a[0] <= b[0]
    if geometry is None:
        geometry = geometry_of(a, b)
    normal = np.zeros(3)
    point = np.zeros((4, 3))
    sep = np.zeros(4)
    feat = np.zeros(4, dtype=np.int64)
    n = collide_shapes(a[0], b[0], np.ascontiguousarray(a[1]), np.ascontiguousarray(a[2]), a[3],
                       np.ascontiguousarray(b[1]), np.ascontiguousarray(b[2]), b[3], spec, geometry, 0, 1,
                       normal, point, sep, feat, np.empty((PAIR_WORK_ROWS, 3)), np.zeros((4, 3)), convex_scratch())
    return normal, point[:n].copy(), sep[:n].copy(), feat[:n].copy()


def box_sdf(p, pos, R, h):
    """Signed distance of points p (..., 3) to a box (exact)."""
    local = (np.asarray(p) - pos) @ R
    q = np.abs(local) - h
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=-1)
    inside = np.minimum(np.max(q, axis=-1), 0.0)
    return outside + inside


def box_corners(pos, R, h):
    s = np.array([[(c >> k) & 1 for k in range(3)] for c in range(8)]) * 2.0 - 1.0
    return pos + (s * h) @ R.T


def box_edges(pos, R, h):
    """(12, 2, 3) edge endpoints of a box."""
    c = box_corners(pos, R, h)
    edges = []
    for a in range(8):
        for k in range(3):
            if not (a >> k) & 1:
                edges.append((c[a], c[a | (1 << k)]))
    return np.array(edges)


def segment_distance(p1, q1, p2, q2, samples=201):
    """Distance between two segments, by dense sampling plus a local exact projection (test oracle)."""
    t = np.linspace(0, 1, samples)
    a = p1 + t[:, None] * (q1 - p1)
    d2 = q2 - p2
    u = np.clip(((a - p2) @ d2) / max(d2 @ d2, 1e-300), 0, 1)
    b = p2 + u[:, None] * d2
    return np.min(np.linalg.norm(a - b, axis=1))


def box_box_distance(A, B):
    """Distance between two disjoint boxes: vertices against boxes, edges against edges (brute force)."""
    _, pa, Ra, ha = A
    _, pb, Rb, hb = B
    ha, hb = ha[:3], hb[:3]
    d = min(np.min(box_sdf(box_corners(pa, Ra, ha), pb, Rb, hb)), np.min(box_sdf(box_corners(pb, Rb, hb), pa, Ra, ha)))
    for ea in box_edges(pa, Ra, ha):
        for eb in box_edges(pb, Rb, hb):
            d = min(d, segment_distance(ea[0], ea[1], eb[0], eb[1], 101))
    return d


def boxes_intersect(A, B):
    """Whether two boxes share a point: a linear feasibility problem (SciPy linprog)."""
    from scipy.optimize import linprog

    rows, rhs = [], []
    for _, p, R, h in (A, B):
        for k in range(3):
            rows += [R[:, k], -R[:, k]]
            rhs += [h[k] + R[:, k] @ p, h[k] - R[:, k] @ p]
    res = linprog(np.zeros(3), A_ub=np.array(rows), b_ub=np.array(rhs), bounds=[(None, None)] * 3, method="highs")
    return res.status == 0


def penetration_depth(A, B, rng, samples=4000):
    """Minimum translation distance of two intersecting boxes: min over directions d of
    h_A(d) + h_B(-d) (support functions), by sampling directions then a local refinement."""
    from scipy.optimize import minimize

    _, pa, Ra, ha = A
    _, pb, Rb, hb = B

    def overlap(d):
        d = d / np.linalg.norm(d)
        sa = d @ pa + np.sum(np.abs(d @ Ra) * ha[:3])
        sb = -(d @ pb) + np.sum(np.abs(d @ Rb) * hb[:3])
        return sa + sb

    dirs = rng.normal(size=(samples, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    # the 15 SAT axes are not given to the oracle: it searches directions blindly
    vals = np.array([overlap(d) for d in dirs])
    best = np.inf
    for i in np.argsort(vals)[:5]:
        res = minimize(overlap, dirs[i], method="Nelder-Mead", options=dict(xatol=1e-10, fatol=1e-12, maxiter=4000))
        best = min(best, res.fun)
    return best
