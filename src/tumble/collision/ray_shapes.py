"""Ray casts against one shape, in the shape's own frame (``collision.raycast`` walks the
shapes' tree and calls ``_ray_shape`` on the candidates).

Each ``_ray_<shape>`` takes the ray (o, d) in the shape's frame (d unit) and the largest t worth
reporting, and returns (hit, t, nx, ny, nz): the entry distance (m) and the outward unit normal,
shape frame; ``_MISS`` when the ray does not enter the shape before t_max. Closed forms for the
plane, sphere, box, cylinder, capsule, cone and ellipsoid; hulls by clipping the ray with their face planes
(Cyrus and Beck 1978); meshes through their own BVH with the Moller-Trumbore triangle test (1997).
The rules (origin inside a solid: no hit; meshes hit from either side) are ``collision.raycast``'s.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..math3d import NO_NRT
from ..shapes import SHAPE_BOX, SHAPE_CAPSULE, SHAPE_CONE, SHAPE_CONVEX, SHAPE_CYLINDER, SHAPE_ELLIPSOID, SHAPE_MESH, \
    SHAPE_PLANE, SHAPE_SPHERE

_MISS = (False, 0.0, 0.0, 0.0, 0.0)


@njit(**NO_NRT)
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


@njit(**NO_NRT)
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


@njit(**NO_NRT)
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


@njit(**NO_NRT)
def _ray_ellipsoid(p, o, d, t_max):
    """Ellipsoid of semi-axes p[:3]: the unit sphere's quadratic in coordinates scaled by 1 / p,
    |u + t w|^2 = 1 with u = o / p, w = d / p (t stays the distance along the unit d)."""
    u0, u1, u2 = o[0] / p[0], o[1] / p[1], o[2] / p[2]
    w0, w1, w2 = d[0] / p[0], d[1] / p[1], d[2] / p[2]
    a = w0 * w0 + w1 * w1 + w2 * w2
    b = u0 * w0 + u1 * w1 + u2 * w2
    c = u0 * u0 + u1 * u1 + u2 * u2 - 1.0
    if c < 0.0 or b > 0.0:  # inside, or outside and moving away
        return _MISS
    disc = b * b - a * c
    if disc < 0.0:
        return _MISS
    t = (-b - math.sqrt(disc)) / a
    if t < 0.0 or t > t_max:
        return _MISS
    # the outward normal: the gradient of (x/a)^2 + (y/b)^2 + (z/c)^2 at the hit point
    n0, n1, n2 = (u0 + t * w0) / p[0], (u1 + t * w1) / p[1], (u2 + t * w2) / p[2]
    n = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    return True, t, n0 / n, n1 / n, n2 / n


@njit(**NO_NRT)
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


@njit(**NO_NRT)
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


@njit(**NO_NRT)
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


@njit(**NO_NRT)
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


@njit(**NO_NRT)
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
    if A < 0.0:
        # steeper than the cone's side (d[2] != 0): the line crosses the lower nappe once and is
        # inside C on the side below that root. NOTE: why here and not from the roots' interval
        # below: along the axis the two roots are one, at the apex (a double root), and the
        # interval [apex, apex] made a ray up the axis from below miss the base and hit the apex
        # from inside (found by an audit of the scene queries, session 42); within 1e-7 m of the
        # axis rounding gave the same.
        sq = math.sqrt(max(B * B - 4.0 * A * C, 0.0))
        qq = -0.5 * (B + sq) if B >= 0.0 else -0.5 * (B - sq)
        q1 = qq / A
        q2 = C / qq if qq != 0.0 else q1
        low = q1 if o[2] + q1 * d[2] <= o[2] + q2 * d[2] else q2
        if d[2] > 0.0:
            c1, c2 = -np.inf, low
        else:
            c1, c2 = low, np.inf
        return _cone_entry(radius, height, o, d, t_max, c1, c2)
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
    return _cone_entry(radius, height, o, d, t_max, c1, c2)


@njit(**NO_NRT)
def _cone_entry(radius, height, o, d, t_max, c1, c2):
    """``_ray_cone``'s hit: the ray's parameters inside the infinite cone C are [c1, c2]; the
    solid is C above the base z = 0."""
    k = radius / height
    k2 = k * k
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


@njit(**NO_NRT)
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


@njit(**NO_NRT)
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


@njit(**NO_NRT)
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
    if t == SHAPE_ELLIPSOID:
        return _ray_ellipsoid(p, lo, dl, best)
    if t == SHAPE_CONVEX:
        return _ray_convex(shape_data[s, 2], shape_data[s, 3], hull_plane, lo, dl, best)
    if t == SHAPE_MESH:
        return _ray_mesh(shape_data[s, 2], shape_data[s, 3], mesh_triangle, node_aabb, leaf_first, leaf_count,
                         node_skip, lo, dl, best)
    return _MISS
