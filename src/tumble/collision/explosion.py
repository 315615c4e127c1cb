"""Explosions: a blast that pushes every dynamic shape near it (Box2D v3's ``b2World_Explode``,
in 3-D), ``World.explode`` now or a ``tb.Explosion`` record at a time of the run.

The rule (Box2D v3's, with its perimeter made an area): for each collision shape of a dynamic
body (a compound's parts one by one; sensors, fixed and kinematic bodies never), the signed
distance d from the blast's centre c to the shape and the shape's closest point p
(``distance.convex_to_shape`` with a point: GJK, EPA). A shape with d > radius + falloff is not
touched. Otherwise the impulse

    J = impulse_per_area * A(u) * s * u,   u = (p - c) / |p - c|,
    s = 1 when d <= radius, else (radius + falloff - d) / falloff,

acts at p: P += J, L += (p - x) x J. A(u) (m^2) is the area of the shape's shadow on a plane
normal to u, its projected area: the blast's pressure impulse (N s / m^2) times the area it
meets, so a box face-on takes more than edge-on and a long rod more side-on than end-on. The
shadow of the whole shape counts, also where part of it lies beyond the reach, and nothing
shades anything (a box behind another takes its whole impulse): Box2D's model, a blast's
first push, not a pressure field. With ``shaded`` (``tb.Explosion(shaded=True)``,
``World.explode(..., shaded=True)``) each shape's push is scaled by the part of six rays from the
centre to its points that reach it unblocked (``visible_fraction``): a brick behind a wall is
spared, one half behind another takes part of its push.

A(u) in the shape's frame, u = (ux, uy, uz) unit (``projected_area``):

* sphere of radius r: pi r^2;
* box of half extents (a, b, c): 4 (b c |ux| + a c |uy| + a b |uz|) (half the surface's
  |u . n| dA: Cauchy's projection formula, each face pair counted once);
* capsule of radius r and segment length l: pi r^2 + 2 r l sin(theta), theta the angle of u to
  the axis;
* cylinder: pi r^2 |cos(theta)| + 2 r l sin(theta);
* cone of base radius r and height h: its base projects to an ellipse of semi-axes r and
  b = r |cos(theta)|, its apex to a point at e = h sin(theta) from the ellipse's centre along
  the short axis; the shadow is their convex hull: pi r b when e <= b, else
  r b (pi - arccos(b / e)) + r sqrt(e^2 - b^2) (the ellipse as a circle stretched along the
  short axis: the circle's hull with a point, pi r^2 - phi r^2 + r sqrt(D^2 - r^2),
  cos(phi) = r / D, scaled by b / r);
* ellipsoid of semi-axes (a, b, c): pi sqrt((b c ux)^2 + (a c uy)^2 + (a b uz)^2);
* convex hull: the area of the 2-D convex hull of its vertices projected on the plane
  (``scipy.spatial.ConvexHull``).

A centre inside a shape (d <= 0) has no closest point outside: the impulse then acts at the
body's centre of mass, along the centre-to-centre-of-mass direction, at full strength; with the
blast exactly at the centre of mass it pushes every way at once and moves nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..errors import InputError
from ..math3d import JIT
from ..shapes import (
    SHAPE_BOX,
    SHAPE_CAPSULE,
    SHAPE_CONE,
    SHAPE_CONVEX,
    SHAPE_CYLINDER,
    SHAPE_ELLIPSOID,
    SHAPE_SPHERE,
)
from .bounds import update_bounds
from .distance import convex_to_shape
from .pairs.gjk import gjk_scratch

# a centre closer than this to a body's centre of mass, inside the body, gives no direction (m)
CENTRE_TOLERANCE = 1e-12
# COMPILE: the centre's shape type as an int64, not the literal SHAPE_SPHERE, which compiled
# convex_distance, GJK and EPA a second time for the literal (as mesh.TRIANGLE, session 23)
POINT = np.int64(SHAPE_SPHERE)


@dataclass
class Blast:
    """The impulses an explosion gave, one row per shape it touched (K rows, in shape-table order).

    body: (K,) int64, the body of each shape.
    shape: (K,) int64, the shape-table row (a compound's part).
    distance: (K,) m, the signed distance from the centre to the shape (<= 0: the centre inside).
    point: (K, 3) m, world, where the impulse acted (the shape's closest point; the body's centre
        of mass for a centre inside it).
    area: (K,) m^2, the shape's shadow area along the push.
    impulse: (K, 3) N s, world, the impulse given.
    """

    body: np.ndarray
    shape: np.ndarray
    distance: np.ndarray
    point: np.ndarray
    area: np.ndarray
    impulse: np.ndarray

    def __len__(self) -> int:
        return len(self.body)


@njit(**JIT)
def blast_distance_kernel(centre, reach, hit, shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_aabb,
                          shape_data, hull_vertex, mesh_triangle, node_aabb, node_first, node_count, node_skip,
                          # outputs
                          distance, point):
    """distance[s] (S,) m: signed distance from ``centre`` (3,) m, world, to shape s when its body is
    ``hit`` (N,) bool and it lies within ``reach`` m (inf otherwise); point[s] (S, 3) its closest
    point, world. The centre is a sphere of radius 0 (a point core) for ``convex_to_shape``."""
    scratch = gjk_scratch()
    lo = np.empty(3)
    hi = np.empty(3)
    work = np.empty(9)
    out = np.empty(9)
    rot = np.eye(3)
    params = np.zeros(4)
    verts = np.zeros((0, 3))
    for s in range(shape_type.shape[0]):
        distance[s] = np.inf
        if not hit[shape_body[s]]:
            continue
        gap = 0.0  # the centre's distance to the shape's box: a lower bound of its distance to the shape
        for i in range(3):
            g = max(shape_aabb[s, 0, i] - centre[i], centre[i] - shape_aabb[s, 1, i], 0.0)
            gap += g * g
        if math.sqrt(gap) > reach:
            continue
        d = convex_to_shape(POINT, centre, rot, params, verts, s, shape_type, shape_params, shape_pos,
                            shape_rot, shape_data, hull_vertex, mesh_triangle, node_aabb, node_first, node_count,
                            node_skip, reach, scratch, lo, hi, work, out)
        distance[s] = d
        for i in range(3):
            point[s, i] = out[3 + i]


def projected_areas(shape_type, params, u, hulls=None) -> np.ndarray:
    """The areas (K,) m^2 of K convex shapes' shadows on planes normal to ``u`` (K, 3) unit, each in
    its shape's frame (module docstring): ``shape_type`` (K,) ``SHAPE_*`` ids, ``params`` (K, 4)
    their shape-table parameters, ``hulls`` a list of K hull vertex arrays (V, 3) m, shape frame,
    read where the type is ``SHAPE_CONVEX`` (else None). The closed forms vectorised by type.

    PERF: a Python call per shape cost 7.5 us a body reached (3777 boxes of a 10 000-box pile: 28.6
    ms); by type over the arrays 2.6-3.9 ms (benchmarks/explosion.py, docs/benchmarks.md)."""
    t = np.asarray(shape_type, dtype=np.int64)
    p = np.asarray(params, dtype=float).reshape(len(t), 4)
    u = np.asarray(u, dtype=float).reshape(len(t), 3)
    ax, ay = np.abs(u[:, 0]), np.abs(u[:, 1])
    axial = np.minimum(np.abs(u[:, 2]), 1.0)
    side = np.sqrt(np.maximum(0.0, 1.0 - axial * axial))
    a, b, c = p[:, 0], p[:, 1], p[:, 2]
    area = np.full(len(t), np.nan)
    k = t == SHAPE_SPHERE
    area[k] = np.pi * a[k] ** 2
    k = t == SHAPE_BOX
    area[k] = 4.0 * (b[k] * c[k] * ax[k] + a[k] * c[k] * ay[k] + a[k] * b[k] * axial[k])
    k = t == SHAPE_CAPSULE  # (radius, half length)
    area[k] = np.pi * a[k] ** 2 + 4.0 * a[k] * b[k] * side[k]
    k = t == SHAPE_CYLINDER
    area[k] = np.pi * a[k] ** 2 * axial[k] + 4.0 * a[k] * b[k] * side[k]
    k = np.flatnonzero(t == SHAPE_CONE)  # (radius, height)
    if len(k):
        r, minor, e = a[k], a[k] * axial[k], b[k] * side[k]
        inside = e <= minor
        with np.errstate(divide="ignore", invalid="ignore"):
            phi = np.arccos(np.clip(minor / e, 0.0, 1.0))
            hull = r * minor * (np.pi - phi) + r * np.sqrt(np.maximum(e * e - minor * minor, 0.0))
        area[k] = np.where(inside, np.pi * r * minor, hull)
    k = t == SHAPE_ELLIPSOID
    area[k] = np.pi * np.sqrt((b[k] * c[k] * u[k, 0]) ** 2 + (a[k] * c[k] * u[k, 1]) ** 2
                              + (a[k] * b[k] * u[k, 2]) ** 2)
    for i in np.flatnonzero(t == SHAPE_CONVEX):
        area[i] = _hull_shadow(hulls[i], u[i]) if u[i].any() else 0.0  # no push, no shadow
    if np.isnan(area).any():
        bad = int(t[np.isnan(area)][0])
        raise InputError(f"shape type {bad} has no projected area", "shape")
    return area


def _hull_shadow(vertices, u) -> float:
    """The area of the 2-D convex hull of ``vertices`` (V, 3) projected on the plane normal to u."""
    from scipy.spatial import ConvexHull, QhullError

    e1 = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    flat = np.asarray(vertices, dtype=float) @ np.stack([e1, e2], axis=1)
    try:
        return float(ConvexHull(flat).volume)  # a 2-D hull's "volume" is its area
    except (QhullError, ValueError):  # the vertices project onto a line: no area
        return 0.0


def projected_area(shape_type: int, params, vertices, u) -> float:
    """``projected_areas`` of one shape: ``vertices`` (V, 3) a hull's (else unused), ``u`` (3,)."""
    return float(projected_areas([shape_type], [params], [u], [vertices])[0])


def blast(world, explosion, x=None, R=None) -> Blast:
    """The impulses of ``explosion`` (a ``tb.Explosion``) on ``world``'s bodies at poses ``x``
    (N, 3) m and ``R`` (N, 3, 3) (default: the world's own), not applied (module docstring)."""
    from .raycast import _seen, kept_scene

    x = world.x if x is None else x
    R = world.R if R is None else R
    scene = kept_scene(world)
    table = scene.table
    S = table.shape_count
    hit = world.moving & _seen(world, explosion.mask)
    empty = Blast(body=np.zeros(0, np.int64), shape=np.zeros(0, np.int64), distance=np.zeros(0),
                  point=np.zeros((0, 3)), area=np.zeros(0), impulse=np.zeros((0, 3)))
    if S == 0 or not hit.any():
        return empty
    pos, rot, aabb, margin = np.empty((S, 3)), np.empty((S, 3, 3)), np.empty((S, 2, 3)), np.empty(S)
    update_bounds(np.ascontiguousarray(x), np.ascontiguousarray(R), table, 0.0, pos, rot, aabb, shape_margin=margin)
    centre = np.array(explosion.position, dtype=float)
    reach = explosion.radius + explosion.falloff
    distance = np.empty(S)
    point = np.empty((S, 3))
    blast_distance_kernel(centre, float(reach), hit, table.shape_type, table.shape_body, table.shape_params, pos, rot,
                          aabb, table.shape_data, table.hull_vertex, table.mesh_triangle, table.mesh_node_aabb,
                          table.mesh_node_first, table.mesh_node_count, table.mesh_node_skip, distance, point)
    touched = np.flatnonzero(distance <= reach)
    if len(touched) == 0:
        return empty
    body = table.shape_body[touched].astype(np.int64)
    d = distance[touched]
    p = point[touched].copy()
    inside = d <= 0.0
    p[inside] = x[body[inside]]  # no closest point outside: the body's centre of mass (docstring)
    direction = p - centre
    length = np.linalg.norm(direction, axis=1)
    u = np.zeros_like(direction)
    ok = length > CENTRE_TOLERANCE
    u[ok] = direction[ok] / length[ok, None]
    types = table.shape_type[touched]
    hulls = [table.hull_vertex[table.shape_data[s, 0]:table.shape_data[s, 0] + table.shape_data[s, 1]]
             if types[k] == SHAPE_CONVEX else None for k, s in enumerate(touched)]
    u_local = np.einsum("kji,kj->ki", rot[touched], u)  # R^T u: the push in each shape's frame
    area = np.where(ok, projected_areas(types, table.shape_params[touched], u_local, hulls), 0.0)
    scale = np.ones(len(touched))
    if explosion.falloff > 0.0:  # (reach - d) / falloff >= 1 exactly when d <= radius: the clip gives both parts
        scale = np.clip((reach - d) / explosion.falloff, 0.0, 1.0)
    if explosion.shaded:
        scale = scale * visible_fraction(world, centre, touched, body, p, inside, pos, aabb, u, x, R)
    impulse = (explosion.impulse_per_area * area * scale)[:, None] * u
    return Blast(body=body, shape=touched.astype(np.int64), distance=d, point=p, area=area, impulse=impulse)


# the points of a shape a shaded blast looks for: its closest point, its centre, and its centre
# moved across the blast's direction by this part of its box's smallest half extent, four ways
SHADE_OFFSET = 0.5


def visible_fraction(world, centre, shapes, body, point, inside, pos, aabb, u, x, R) -> np.ndarray:
    """(K,) the part of each shape's push a shaded blast lets through: of the rays from the
    centre to six points of the shape (its closest point, its centre, the centre moved across the
    blast's direction four ways), those whose first hit is the shape's own body, or nothing short
    of the point, see it. A shape with the centre inside it (``inside``) is not shaded. The rays
    are cast at the poses x (N, 3), R (N, 3, 3), through every body but sensors.

    Six points are a coarse shadow (a shape one third hidden takes one third or one half of its
    push); the aim is that what stands behind a wall, or behind a heavier block, is spared."""
    from .raycast import _seen, kept_scene

    K = len(shapes)
    c = pos[shapes]
    half = 0.5 * (aabb[shapes, 1] - aabb[shapes, 0])
    a = SHADE_OFFSET * half.min(axis=1)
    helper = np.where(np.abs(u[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    e1 = np.cross(u, helper)
    e1 /= np.maximum(np.linalg.norm(e1, axis=1), 1e-300)[:, None]
    e2 = np.cross(u, e1)
    targets = np.stack([point, c, c + a[:, None] * e1, c - a[:, None] * e1, c + a[:, None] * e2,
                        c - a[:, None] * e2], axis=1)  # (K, 6, 3)
    o = np.repeat(centre[None, :], 6 * K, axis=0)
    d = targets.reshape(-1, 3) - o
    length = np.linalg.norm(d, axis=1)
    ok = length > CENTRE_TOLERANCE
    d[ok] /= length[ok, None]
    d[~ok] = (0.0, 0.0, 1.0)
    scene = kept_scene(world)
    table = scene.table
    # each ray looks as far as its point, a hair short of it: what lies beyond does not shade
    reach = np.maximum(length * (1.0 - 1e-9) - 1e-9, 0.0)
    hit_shape, _, _ = scene.cast(world, o, d, reach, np.full(6 * K, -1, dtype=np.int64), _seen(world, 0xFFFFFFFF),
                                 x, R)
    own = np.repeat(body, 6)
    seen = (hit_shape < 0) | (table.shape_body[np.maximum(hit_shape, 0)] == own) | ~ok
    fraction = seen.reshape(K, 6).mean(axis=1)
    return np.where(inside, 1.0, fraction)


def apply_blast(result: Blast, x, P, L):
    """P += J, L += (p - x) x J for each row of ``result``, in row order, on the (N, 3) arrays
    ``P``, ``L`` (kg m/s, kg m^2/s, world) of bodies at centres ``x`` (N, 3) m."""
    for k in range(len(result)):
        i = result.body[k]
        J = result.impulse[k]
        P[i] += J
        L[i] += np.cross(result.point[k] - x[i], J)


def explode(world, position, radius, impulse_per_area, falloff=0.0, mask=None, shaded=False) -> Blast:
    """``World.explode``: an explosion now, at the bodies' current poses; returns what it gave."""
    from ..forces import Explosion

    kw = {} if mask is None else {"mask": mask}
    record = Explosion(position=position, radius=radius, impulse_per_area=impulse_per_area, falloff=falloff,
                       shaded=shaded, **kw)
    result = blast(world, record)
    if len(result):
        apply_blast(result, world.x, world.P, world.L)
        world.wake_requests.update(int(i) for i in np.unique(result.body))
        world.update_derived()
    return result
