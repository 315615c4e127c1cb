"""Buoyancy and drag of a still fluid below a level surface (``tb.Buoyancy``): Archimedes' principle on
each body's submerged part.

The part of a body under the surface is its closed surface clipped by the surface's plane. For a
closed, outward-wound triangle surface, the volume of the solid below a plane and its centroid are
sums over the clipped triangles of the tetrahedra they make with one point p0 ON the plane: the cap
the plane cuts lies in the plane through p0, so its tetrahedra have no volume and it need not be
built (the divergence theorem; Eberly, "Polyhedral mass properties", with the apex on the cut).
So each body costs one pass over its triangles; a lone sphere takes the spherical cap's closed form.

Bodies' surfaces in the body frame (origin at the centre of mass, the shape frame's axes): boxes,
hulls and closed meshes exactly (their own triangles; a decomposed compound its source mesh);
cylinders, capsules, cones and ellipsoids as fine tessellations (``SECTIONS`` segments round,
icospheres of ``SUBDIVISIONS`` levels: their volume short of the exact one by 0.03 % at most, the
mass properties being exact; ``surface_volume`` reports it); compounds part by part. A body of
particles, with no surface, floats not at all.

``apply_buoyancy`` writes each body's force and torque, taken at its mid-step pose
(``buoyancy_kernel``), into its ``UFORCE_CONSTANT`` row of the world's force tables
(``forces.build_force_tables``) before each step (the Simulator steps one step at a time when the
world has a Buoyancy record); every integrator and the soft step read those rows as they read a
``ConstantForce``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .body_motion import _load, _mat9, _matrix, _rotate, _velocities
from .math3d import JIT
from .shapes import Compound, Particles, Sphere

SECTIONS = 192  # segments round a cylinder, capsule or cone: volume within 0.02 % (1 - sin(2 pi / n) n / (2 pi))
SUBDIVISIONS = 5  # icosphere levels of an ellipsoid (or a compound's ball): 10 242 vertices, volume within 0.03 %


def _surface(shape) -> tuple[np.ndarray, np.ndarray, float]:
    """((V, 3) corners in the shape frame, m; (T, 3) int64 outward-wound triangles; sphere radius or 0):
    the closed surface buoyancy clips (module docstring)."""
    from .visual import shape_trimesh

    none = (np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))
    if isinstance(shape, Sphere):
        return *none, float(shape.radius)
    if isinstance(shape, Particles):
        return *none, 0.0
    if isinstance(shape, Compound) and shape.source is None and any(isinstance(p[0], Particles) for p in shape.parts):
        return *none, 0.0
    mesh = shape_trimesh(shape, sections=SECTIONS, subdivisions=SUBDIVISIONS)
    return np.asarray(mesh.vertices, dtype=float), np.asarray(mesh.faces, dtype=np.int64), 0.0


class BuoyancyGeometry:
    """Per body of a world, its surface for buoyancy (built when first needed, kept per shape record).

    Attributes (N bodies): ``first``, ``count`` (N,) int64 rows of ``faces`` (T, 3) int64, rows of
    ``vertices`` (V, 3) m, body frame, whose own rows are ``vfirst``, ``vcount`` (N,); ``radius``
    (N,) m, a lone sphere's radius (its centre at ``centre`` (N, 3), body frame) or 0; ``volume`` (N,) m^3, the whole surface's volume (0: no surface); ``reach`` (N,) m, the
    farthest corner from the centre of mass, and ``centroid`` (N, 3) m, body frame, the whole
    surface's centroid: a body wholly above or under the surface costs no triangle.
    """

    def __init__(self, world):
        n = world.body_count
        parts, corners, cache = [], [], {}
        self.first = np.zeros(n, dtype=np.int64)
        self.count = np.zeros(n, dtype=np.int64)
        self.vfirst = np.zeros(n, dtype=np.int64)
        self.vcount = np.zeros(n, dtype=np.int64)
        vtotal = 0
        self.radius = np.zeros(n)
        self.centre = np.zeros((n, 3))
        self.volume = np.zeros(n)
        self.reach = np.zeros(n)
        self.centroid = np.zeros((n, 3))
        total = 0
        for i in range(n):
            shape = world.shapes[i]
            key = id(shape)
            if key not in cache:
                cache[key] = (shape, *_surface(shape))  # the record kept alive with its id
            _, points, faces, radius = cache[key]
            offset = -np.asarray(world.com_offset[i], dtype=float)  # the shape origin in the body frame
            self.centre[i] = offset
            self.radius[i] = radius
            if radius > 0.0:
                self.volume[i] = 4.0 / 3.0 * math.pi * radius**3
                self.centroid[i] = offset
                self.reach[i] = float(np.linalg.norm(offset)) + radius
                continue
            if len(faces) == 0:
                continue
            points = points + offset
            tri = points[faces]
            parts.append(faces + vtotal)
            corners.append(points)
            self.first[i], self.count[i] = total, len(faces)
            self.vfirst[i], self.vcount[i] = vtotal, len(points)
            total += len(faces)
            vtotal += len(points)
            tets = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])) / 6.0
            self.volume[i] = float(tets.sum())
            self.centroid[i] = (tets[:, None] * tri.sum(axis=1) / 4.0).sum(axis=0) / self.volume[i]
            self.reach[i] = float(np.linalg.norm(tri.reshape(-1, 3), axis=1).max())
        self.faces = np.ascontiguousarray(np.concatenate(parts) if parts else np.zeros((0, 3), dtype=np.int64))
        self.vertices = np.ascontiguousarray(np.concatenate(corners) if corners else np.zeros((0, 3)))
        self.most_vertices = int(self.vcount.max()) if n else 0
        self.body_count = n


def geometry(world) -> BuoyancyGeometry:
    """The world's BuoyancyGeometry, made again when bodies were added."""
    g = world.__dict__.get("_buoyancy_geometry")
    if g is None or g.body_count != world.body_count:
        g = BuoyancyGeometry(world)
        world.__dict__["_buoyancy_geometry"] = g
    return g


def surface_volume(world, body) -> float:
    """m^3: the volume of the surface buoyancy sees for ``body`` (an index or a Body): the shape's own
    for spheres, boxes, hulls and meshes, a tessellation's for round shapes (module docstring)."""
    i = int(getattr(body, "index", body))
    return float(geometry(world).volume[i])


@njit(**JIT)
def _clip_add(ax, ay, az, bx, by, bz, cx, cy, cz, p0, acc):
    """Add the tetrahedron (p0, a, b, c)'s signed volume and volume-weighted centroid to acc (4,)."""
    ux, uy, uz = ax - p0[0], ay - p0[1], az - p0[2]
    vx, vy, vz = bx - p0[0], by - p0[1], bz - p0[2]
    wx, wy, wz = cx - p0[0], cy - p0[1], cz - p0[2]
    vol = (ux * (vy * wz - vz * wy) + uy * (vz * wx - vx * wz) + uz * (vx * wy - vy * wx)) / 6.0
    acc[0] += vol
    acc[1] += vol * 0.25 * (p0[0] + ax + bx + cx)
    acc[2] += vol * 0.25 * (p0[1] + ay + by + cy)
    acc[3] += vol * 0.25 * (p0[2] + az + bz + cz)


@njit(**JIT)
def submerged_part(x, R, first, count, faces, vfirst, vcount, vertices, radius, centre, volume, reach, centroid, up,
                   level, acc, wv, depth):
    """Volume (m^3) of one body's surface below the plane up . p = level, and its centroid (world)
    times the volume, in acc (4,) = (V, V cx, V cy, V cz). x (3,), R (3, 3): the body's pose;
    wv (>= vcount, 3), depth (>= vcount,): scratch, its corners in the world and their heights over
    the surface (each corner once: a corner is in about six triangles). The body's volume, reach
    and centroid (BuoyancyGeometry's) skip the triangles of a body wholly out of the fluid or wholly
    in it."""
    acc[:] = 0.0
    height = up[0] * x[0] + up[1] * x[1] + up[2] * x[2] - level
    if height - reach >= 0.0 or volume <= 0.0:
        return  # dry
    if height + reach <= 0.0 and radius == 0.0:  # wholly under: the whole surface's centroid
        for k in range(3):
            acc[1 + k] = volume * (x[k] + R[k, 0] * centroid[0] + R[k, 1] * centroid[1] + R[k, 2] * centroid[2])
        acc[0] = volume
        return
    if radius > 0.0:  # a sphere: the cap's closed form
        cx = x[0] + R[0, 0] * centre[0] + R[0, 1] * centre[1] + R[0, 2] * centre[2]
        cy = x[1] + R[1, 0] * centre[0] + R[1, 1] * centre[1] + R[1, 2] * centre[2]
        cz = x[2] + R[2, 0] * centre[0] + R[2, 1] * centre[1] + R[2, 2] * centre[2]
        h = level - (up[0] * cx + up[1] * cy + up[2] * cz - radius)  # depth of its lowest point
        if h <= 0.0:
            return
        h = min(h, 2.0 * radius)
        vol = math.pi * h * h * (3.0 * radius - h) / 3.0
        # the cap's centroid lies 3 (2r - h)^2 / (4 (3r - h)) below the centre
        down = 3.0 * (2.0 * radius - h) ** 2 / (4.0 * (3.0 * radius - h))
        acc[0] = vol
        acc[1] = vol * (cx - down * up[0])
        acc[2] = vol * (cy - down * up[1])
        acc[3] = vol * (cz - down * up[2])
        return
    # p0: the body's centre dropped onto the plane (any point of the plane would do; one near the
    # body keeps the tetrahedra small, so their sum loses little to rounding)
    p0 = (x[0] - height * up[0], x[1] - height * up[1], x[2] - height * up[2])
    # the corners in the world and their heights above the surface
    for j in range(vcount):
        lx, ly, lz = vertices[vfirst + j, 0], vertices[vfirst + j, 1], vertices[vfirst + j, 2]
        wv[j, 0] = x[0] + R[0, 0] * lx + R[0, 1] * ly + R[0, 2] * lz
        wv[j, 1] = x[1] + R[1, 0] * lx + R[1, 1] * ly + R[1, 2] * lz
        wv[j, 2] = x[2] + R[2, 0] * lx + R[2, 1] * ly + R[2, 2] * lz
        depth[j] = up[0] * wv[j, 0] + up[1] * wv[j, 1] + up[2] * wv[j, 2] - level
    for t in range(first, first + count):
        c0, c1, c2 = faces[t, 0] - vfirst, faces[t, 1] - vfirst, faces[t, 2] - vfirst
        d0, d1, d2 = depth[c0], depth[c1], depth[c2]
        under = 0
        for dk in (d0, d1, d2):
            if dk <= 0.0:
                under += 1
        if under == 0:
            continue
        if under == 3:
            _clip_add(wv[c0, 0], wv[c0, 1], wv[c0, 2], wv[c1, 0], wv[c1, 1], wv[c1, 2],
                      wv[c2, 0], wv[c2, 1], wv[c2, 2], p0, acc)
            continue
        # one or two corners under: turn the corners so that corner 0 is the odd one out (alone
        # under, or alone above), keeping the winding; then the part under is a triangle or a quad
        d = (d0, d1, d2)
        odd = 0
        for k in range(3):
            if (d[k] <= 0.0) == (under == 1):
                odd = k
        c = (c0, c1, c2)
        i0, i1, i2 = c[odd], c[(odd + 1) % 3], c[(odd + 2) % 3]
        e0, e1, e2 = d[odd], d[(odd + 1) % 3], d[(odd + 2) % 3]
        ax, ay, az = wv[i0, 0], wv[i0, 1], wv[i0, 2]
        bx, by, bz = wv[i1, 0], wv[i1, 1], wv[i1, 2]
        cx, cy, cz = wv[i2, 0], wv[i2, 1], wv[i2, 2]
        # where the edges from corner 0 cross the surface
        s1 = e0 / (e0 - e1)
        s2 = e0 / (e0 - e2)
        qx, qy, qz = ax + s1 * (bx - ax), ay + s1 * (by - ay), az + s1 * (bz - az)
        rx, ry, rz = ax + s2 * (cx - ax), ay + s2 * (cy - ay), az + s2 * (cz - az)
        if under == 1:  # corner 0 alone under: the triangle (a, q, r)
            _clip_add(ax, ay, az, qx, qy, qz, rx, ry, rz, p0, acc)
        else:  # corner 0 alone above: the quad (q, b, c, r)
            _clip_add(qx, qy, qz, bx, by, bz, cx, cy, cz, p0, acc)
            _clip_add(qx, qy, qz, cx, cy, cz, rx, ry, rz, p0, acc)


@njit(**JIT)
def buoyancy_kernel(layout, Y, bodies, rows, first, count, faces, vfirst, vcount, vertices, most_vertices, radius, centre,
                    volume, reach, centroid, inv_mass, inertia_body_inv, up, level, rho_g, drag, flow, half,
                    uforce_param, submerged):
    """Fill the constant-force rows ``rows`` of ``bodies`` with their buoyancy and drag (Buoyancy's
    docstring) from the packed state Y; ``submerged`` (B,) m^3 gets each body's volume under the
    surface. drag (4,): linear, quadratic, angular_linear, angular_quadratic.

    The buoyancy is taken at the pose the body reaches in ``half`` (s, half the step) at its present
    velocities: held over the step, a force of the mid-step pose makes the step position Verlet
    for it (x_n+1 = x_n + h v_n + h^2 / 2 a(x_n+1/2)): symplectic, second order, a floating body's
    bobbing kept (measured on a slab, omega h = 0.026: its amplitude to 2e-6 over 5 periods, its
    period short by 2.8e-5 = (omega h)^2 / 24, position Verlet's). DEAD END (session 26): the force of
    the step's start, held over the step, is explicit Euler's for it: the bobbing grew 23 % in 5
    periods at dt 1/240 s (tests/physics/test_buoyancy.py caught it)."""
    Rm = np.empty((3, 3))
    acc = np.empty(4)
    wv = np.empty((most_vertices, 3))
    depth = np.empty(most_vertices)
    xm = np.empty(3)
    for k in range(bodies.shape[0]):
        i = bodies[k]
        # the body's pose and velocities as the integrators derive them (body_motion), and its pose
        # at mid-step: x + v h/2, the orientation turned by omega h/2
        x, o, P, L = _load(layout, Y, i)
        _, v, omega = _velocities(layout, o, P, L, inv_mass[i], _mat9(inertia_body_inv, i))
        Rt = _matrix(layout, _rotate(layout, o, omega, half))
        for a in range(3):
            xm[a] = x[a] + half * v[a]
            for b in range(3):
                Rm[a, b] = Rt[3 * a + b]
        submerged_part(xm, Rm, first[i], count[i], faces, vfirst[i], vcount[i], vertices, radius[i], centre[i],
                       volume[i], reach[i], centroid[i], up, level, acc, wv, depth)
        V = acc[0]
        row = rows[k]
        for c in range(6):
            uforce_param[row, c] = 0.0
        submerged[k] = V
        if V <= 0.0 or volume[i] <= 0.0:
            continue
        cbx, cby, cbz = acc[1] / V - xm[0], acc[2] / V - xm[1], acc[3] / V - xm[2]
        fb = rho_g * V
        Fx, Fy, Fz = fb * up[0], fb * up[1], fb * up[2]
        Tx, Ty, Tz = cby * Fz - cbz * Fy, cbz * Fx - cbx * Fz, cbx * Fy - cby * Fx
        # drag in the fluid, in proportion to the part under it
        f = min(V / volume[i], 1.0)
        ox, oy, oz = omega
        spin = math.sqrt(ox * ox + oy * oy + oz * oz)
        ux, uy, uz = v[0] - flow[0], v[1] - flow[1], v[2] - flow[2]
        speed = math.sqrt(ux * ux + uy * uy + uz * uz)
        kl = f * (drag[0] + drag[1] * speed)
        ka = f * (drag[2] + drag[3] * spin)
        uforce_param[row, 0] = Fx - kl * ux
        uforce_param[row, 1] = Fy - kl * uy
        uforce_param[row, 2] = Fz - kl * uz
        uforce_param[row, 3] = Tx - ka * ox
        uforce_param[row, 4] = Ty - ka * oy
        uforce_param[row, 5] = Tz - ka * oz


def _up(world) -> tuple[np.ndarray, float]:
    """(up (3,), |g| m/s^2): the unit vector against gravity (+z without gravity) and gravity's size."""
    gravity = np.asarray(world.gravity, dtype=float)
    gn = float(np.linalg.norm(gravity))
    return (-gravity / gn if gn > 0.0 else np.array([0.0, 0.0, 1.0])), gn


def apply_buoyancy(world, Y, dt: float) -> None:
    """Fill the world's Buoyancy rows from the packed state Y (N, W) for a step of dt (s) (module
    docstring; ``buoyancy_kernel``)."""
    tables = world.tables
    if not tables.buoyancy:
        return
    g = geometry(world)
    up, gn = _up(world)
    for record, bodies, rows in tables.buoyancy:
        drag = np.array([record.linear, record.quadratic, record.angular_linear, record.angular_quadratic])
        submerged = np.empty(len(bodies))
        buoyancy_kernel(world.layout_id, Y, bodies, rows, g.first, g.count, g.faces, g.vfirst, g.vcount, g.vertices,
                        g.most_vertices, g.radius, g.centre, g.volume, g.reach, g.centroid, world.inv_mass,
                        world.inertia_body_inv, up, record.level, record.density * gn, drag,
                        np.asarray(record.flow, dtype=float), 0.5 * float(dt),
                        tables.uforce_param, submerged)


def submerged_volume(world, body=None) -> np.ndarray | float:
    """m^3 under the surface of the world's first Buoyancy record at the world's current state: for
    ``body`` (an index or a Body), or (N,) for every body."""
    tables = world.tables
    if not tables.buoyancy:
        raise ValueError("the world has no Buoyancy record")
    record = tables.buoyancy[0][0]
    g = geometry(world)
    up, _ = _up(world)
    acc, wv, depth = np.empty(4), np.empty((g.most_vertices, 3)), np.empty(g.most_vertices)
    ids = range(world.body_count) if body is None else [int(getattr(body, "index", body))]
    out = np.zeros(len(ids))
    for k, i in enumerate(ids):
        submerged_part(np.ascontiguousarray(world.x[i]), np.ascontiguousarray(world.R[i]), g.first[i], g.count[i],
                       g.faces, g.vfirst[i], g.vcount[i], g.vertices, g.radius[i], np.ascontiguousarray(g.centre[i]),
                       g.volume[i], g.reach[i], np.ascontiguousarray(g.centroid[i]), up, record.level, acc, wv, depth)
        out[k] = acc[0]
    return out if body is None else float(out[0])
