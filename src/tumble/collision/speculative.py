"""Stage ``delay_speculative_ghosts``: a speculative contact closes its gap no earlier than a sweep says it touches.

Why. A speculative contact (Catto, GDC 2014; ``bounds.py``) is a linearization: the solver
follows its gap as s(t) = s0 - w t / dt along its normal n, w = T . n the step's closing
(T the relative translation over the step), and stops the bodies where s(t) reaches 0. For a
face of a plane or of a box met head-on that is the true gap. For an edge or a corner it is
not: the true distance to a point or a line along a straight path is a convex function of t
(its tangent is the linearization), so the linear gap closes first, and where the body passes
by the edge it closes while the body never touches at all. The solver then stops the body
on a normal tilted towards it. A speculative distance that grows with the step's motion (here
the margin is 2 cm plus dt (|v| + |omega| r), 44 mm at 10 m/s) makes such contacts common for
fast bodies: a frictionless ball at 10 m/s over a finely gridded rippled heightfield (4 mm
cells, ripples 3 mm high and 20 cm long) met the crest edge ahead, 9 mm below its bottom and
tilted some 35 degrees back, in its contact list; the solver closed that gap: vz -0.08 ->
+4.5 m/s, vx 10 -> 6.7 in one step, launched 1.05 m high where it can rise at most 5 cm
(tests/physics/test_speculative_ghosts.py). Box2D's speculative contacts have this ghost too
(Catto, "Physics for game programmers: continuous collision", GDC 2014: "ghost collisions"
of speculative contacts, the fast body stopping short at a corner it would have missed);
Jolt keeps its speculative distance fixed (2 cm) and casts fast bodies linearly instead
(``EMotionQuality::LinearCast``); Bullet's and PhysX's CCD sweep the shape.

The rule, for each contact point of a manifold with separation s > the cast's tolerance whose
linear gap closes within the step (w > s): sweep shape a relative to shape b along T by
conservative advancement (Mirtich 1996: the distance of two convex shapes along a translation is
a convex function of t, so advancing by d / (T . n) never passes the first touch;
``shape_query`` does the same for the user's casts) against shape b, or, against a mesh, against
the point's own triangle (its feature). The first fraction t* in [0, 1) at which they come within
the tolerance gives the contact the gap its linearization may close before then: s_eff =
max(s, w t*). When they never come that near within the step, s_eff = w + s: the linear gap at
the step's end is the gap it starts with (w alone closed it just at the step's end, where the
step's gravity tipped it below 0, and a closed contact stops the whole approach: the ball above
still left at 4.5 m/s). So the solver stops the bodies no earlier than the sweep touches; the
contact is kept (a body pushed towards the edge within the step still meets it, up to s_eff - s
late), and its true separation is kept in
``contact_separation`` (what queries and recordings read): the extra, s_eff - s, is
``ContactManifolds.contact_allowance``, which the solver adds to the gap it follows
(``solver.contact.ContactSolver.prepare_contacts``).

The sweep's tolerance holds what a straight translation of the shape's centre leaves out, so
that t* is never late: the shapes' turning over the step, dt (|omega_a| rho_a + |omega_b|
rho_b) (rho the farthest core point from the shape's origin: 0 for a sphere, whose turning
does not move its surface), the centre's arc about the body's centre of mass, dt^2 |omega|^2 l
/ 2, and the step's acceleration, dt^2 |F| / m / 2 for each body (its applied forces and
gravity at the step's start; joint and contact forces within the step are not known here), plus
``SWEEP_SLOP``. A contact already touching (s within the tolerance) is left alone, as are
planes (a plane's gap is linear in any translation), pairs not closing, and pairs of two dynamic
bodies: each may be turned within the step by its other contacts, which the straight sweep does
not see (in a pile all are), and a contact made to wait met a deeper overlap: the 1000-box pile's
energy rose between two frames (7.8 mJ of 22 563 J), which it never does. So the stage is for a
body passing by fixed and kinematic ones (terrain, level geometry, a moving platform), where the
ghosts were found.

Cost: only points whose linear gap closes within the step are swept: none for bodies at rest,
sliding along faces or falling onto a plane. Each sweep is a few GJK distances.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..math3d import JIT
from ..shapes import (SHAPE_PLANE, SHAPE_CAPSULE, SHAPE_CONE, SHAPE_CONVEX, SHAPE_CYLINDER, SHAPE_ELLIPSOID, SHAPE_MESH,
                      SHAPE_SPHERE)
from .distance import convex_distance
from .pairs.convex import shape_arrays
from .pairs.gjk import core_radius, gjk_scratch
from .pairs.mesh import TRIANGLE, _box_meets, _on_inactive_feature, _to_mesh
from .constants import LINEAR_SLOP, MAX_MANIFOLD_POINTS
from .seams import FACE_COS, MESH_FEATURE_TRIANGLES, _mesh_triangle_row, _triangle_normal
from .geometry import BACK_SHIFT, TWO_SIDED

# m: what the sweep's tolerance adds to the motion it leaves out (above); a contact whose gap is
# below the tolerance is touching and kept as it is. 0.1 mm: far below the solver's slop (5 mm),
# far above GJK's (1e-9 m).
SWEEP_SLOP = 1e-4
# Advancement steps per sweep: each lands on or before the touch; a grazing path halves its gap a
# step, and one that has not arrived after these is taken as touching there (early, never late).
SWEEP_ITERATIONS = 32


@njit(**JIT)
def _turning_radius(t, params):
    """The farthest core point of a shape from its origin (m): how far its turning moves its surface."""
    if t == SHAPE_SPHERE:
        return 0.0
    if t == SHAPE_CAPSULE:
        return params[1]
    if t == SHAPE_CYLINDER or t == SHAPE_CONE:
        return math.sqrt(params[0] ** 2 + params[1] ** 2)
    if t == SHAPE_ELLIPSOID:
        return max(params[0], params[1], params[2])
    # box half sizes; a hull's or mesh's box around its origin that holds every vertex (bounds.py)
    return math.sqrt(params[0] ** 2 + params[1] ** 2 + params[2] ** 2)


@njit(**JIT)
def _sweep(ta, pos_a, rot_a, params_a, verts_a, sb, tri, T, tol, shape_type, shape_params, shape_pos, shape_rot,
           shape_data, hull_vertex, mesh_triangle, scratch, pos, out):
    """The first fraction t in [0, 1) of translation T (3,) (m, world) at which convex shape a comes
    within ``tol`` of shape row sb (of its triangle row ``tri`` when tri >= 0), or inf when it does
    not within the step. Conservative advancement (module docstring)."""
    length = math.sqrt(T[0] ** 2 + T[1] ** 2 + T[2] ** 2)
    t = 0.0
    for _ in range(SWEEP_ITERATIONS):
        for k in range(3):
            pos[k] = pos_a[k] + t * T[k]
        cutoff = (1.0 - t) * length + tol
        if tri >= 0:
            d = convex_distance(ta, pos, rot_a, params_a, verts_a, TRIANGLE, shape_pos[sb], shape_rot[sb],
                                shape_params[sb], mesh_triangle[tri], cutoff, scratch, out)
        else:
            # b is convex here (a plane is never swept, a mesh triangle by triangle): GJK alone (PERF: not
            # distance.convex_to_shape, whose mesh and plane branches cost a first run seconds of compilation)
            d = convex_distance(ta, pos, rot_a, params_a, verts_a, shape_type[sb], shape_pos[sb], shape_rot[sb],
                                shape_params[sb], shape_arrays(shape_type[sb], sb, shape_data, hull_vertex)[0],
                                cutoff, scratch, out)
        if d == np.inf:
            return np.inf
        if d <= tol:
            return t
        closing = T[0] * out[6] + T[1] * out[7] + T[2] * out[8]
        if closing <= 0.0:
            return np.inf  # moving apart: along a translation the distance is convex, it only grows now
        t += (d - tol) / closing
        if t >= 1.0:
            return np.inf
    return t


@njit(**JIT)
def _point_triangles(s, feature, shape_data, mesh_triangle, a, shape_pos, shape_rot, shape_type, shape_params, T, grow,
                     box_lo, box_hi, rows):
    """The triangle rows of mesh row s that a contact's feature may name (pairs/mesh: the row mod 2**16):
    one for a mesh of up to 2**16 triangles; beyond, those whose box (mesh frame) meets shape a's
    box swept by T (3,) and grown by ``grow`` (m). Written into ``rows``; their number returned."""
    row = _mesh_triangle_row(s, feature, shape_data)
    if row >= 0:
        rows[0] = row
        return 1
    first = shape_data[s, 0]
    count = shape_data[s, 1]
    row = first + ((((feature >> 5) & 0xFFFF) - first) & 0xFFFF)  # the lowest row of that residue
    # a's box in the mesh frame: a ball of its reach around its origin, swept by T
    ta = shape_type[a]
    reach = _turning_radius(ta, shape_params[a]) + core_radius(ta, shape_params[a]) + grow
    rot_m = shape_rot[s]
    for k in range(3):
        ck = (shape_pos[a, 0] - shape_pos[s, 0]) * rot_m[0, k] + (shape_pos[a, 1] - shape_pos[s, 1]) * rot_m[1, k] \
            + (shape_pos[a, 2] - shape_pos[s, 2]) * rot_m[2, k]
        tk = T[0] * rot_m[0, k] + T[1] * rot_m[1, k] + T[2] * rot_m[2, k]
        box_lo[k] = ck - reach + min(tk, 0.0)
        box_hi[k] = ck + reach + max(tk, 0.0)
    n = 0
    while row < first + count and n < rows.shape[0]:
        if _box_meets(mesh_triangle[row], box_lo, box_hi):
            rows[n] = row
            n += 1
        row += MESH_FEATURE_TRIANGLES
    return n


@njit(**JIT)
def _is_face(normal, rows, n, mesh_triangle, rot_m):
    """Whether a mesh contact's ``normal`` (3,) is the face normal (either side) of one of the ``n``
    triangle rows ``rows`` its feature names (``_point_triangles``): a face contact, whose gap is its
    plane's."""
    for i in range(n):
        nx, ny, nz = _triangle_normal(mesh_triangle[rows[i]], rot_m)
        if abs(nx * normal[0] + ny * normal[1] + nz * normal[2]) >= 1.0 - FACE_COS:
            return True
    return False


@njit(**JIT)
def _face_if_inactive(tri, active, pos_m, rot_m, touch, turned):
    """The normal (world, from the swept shape to the mesh) of a sweep's touch ``touch`` (9,) with
    triangle ``tri`` (mesh frame): its face's where the touch is on an edge or corner the mesh's
    internal-edge flags ``active`` call inactive (flat or concave: pairs/mesh.py's rule; a sweep
    reaches such a triangle's rim ahead of the face beside it, which goes on in the same plane),
    else the touch's own."""
    nx, ny, nz = touch[6], touch[7], touch[8]
    fx, fy, fz = _triangle_normal(tri, rot_m)
    facing = fx * nx + fy * ny + fz * nz  # < 0: the shape is on the face's front
    if facing > 0.0 and active & TWO_SIDED:
        # behind an open mesh's triangle: the turned triangle (corners 0, 2, 1) and its back's flags
        for k in range(3):
            turned[0, k] = tri[0, k]
            turned[1, k] = tri[2, k]
            turned[2, k] = tri[1, k]
        tri = turned
        bits = (active >> BACK_SHIFT) & 7
        fx, fy, fz = -fx, -fy, -fz
    elif facing > 0.0:
        return nx, ny, nz  # inside a closed mesh: its own rule (pairs/mesh.py) has the say
    else:
        bits = active & 7
    mx, my, mz = _to_mesh(touch[3], touch[4], touch[5], pos_m, rot_m)
    if _on_inactive_feature(tri, mx, my, mz, bits):
        return -fx, -fy, -fz
    return nx, ny, nz


@njit(**JIT)
def delay_speculative_kernel(shape_type, shape_body, shape_params, shape_pos, shape_rot, shape_data, hull_vertex,
                             mesh_triangle, mesh_edge_active, x, v, omega, gravity, dt,
                             manifold_count, m_shape_a, m_shape_b, m_normal, m_first, m_count, c_point, c_normal,
                             c_separation, c_feature, inv_mass, force,
                             # output
                             allowance):
    """The module docstring's rule over the first ``manifold_count`` manifolds: ``allowance`` (C,) m,
    the gap each contact's linearization may close beyond its separation (0 for most). ``x`` (N, >= 3)
    m, ``v``, ``omega`` (N, 3) m/s, rad/s at the step's start; ``force`` (N, 3) N, the step's first
    applied forces (``Scratch.F``), or (0, 3) for ``gravity`` (3,) m/s^2 alone; dt s. Returns the
    number of contacts given an allowance."""
    scratch = gjk_scratch()
    pos = np.empty(3)
    out = np.empty(9)
    T = np.empty(3)
    box_lo = np.empty(3)
    box_hi = np.empty(3)
    point_rows = np.empty((MAX_MANIFOLD_POINTS, 16), dtype=np.int64)
    point_n = np.zeros(MAX_MANIFOLD_POINTS, dtype=np.int64)
    touch = np.empty(9)
    path = np.empty(3)
    lead = np.empty(3)
    start = np.empty(3)
    face_point = np.zeros(MAX_MANIFOLD_POINTS, dtype=np.bool_)
    turned = np.empty((3, 3))
    hit_row = np.int64(-1)
    changed = 0
    for m in range(manifold_count):
        f = m_first[m]
        for c in range(f, f + m_count[m]):
            allowance[c] = 0.0
        a = m_shape_a[m]
        b = m_shape_b[m]
        ta = shape_type[a]
        tb = shape_type[b]
        if ta < SHAPE_SPHERE or ta > SHAPE_CONVEX or tb < SHAPE_SPHERE or tb > SHAPE_MESH:
            continue  # a plane's gap is linear in any translation; particles are not swept
        ba = shape_body[a]
        bb = shape_body[b]
        if inv_mass[ba] > 0.0 and inv_mass[bb] > 0.0:
            # two dynamic bodies: each may be turned within the step by its other contacts (a pile's boxes
            # all are), which the straight sweep does not see; a contact made to wait for it then met a
            # deeper overlap, and the 1000-box pile's energy rose between frames (7.8 mJ of 22 563 J)
            continue
        # the relative translation of the shapes' origins over the step, at the step's start velocities
        for k in range(3):
            T[k] = 0.0
        arc = 0.0
        turn = 0.0
        for side in range(2):
            body = ba if side == 0 else bb
            s = a if side == 0 else b
            sign = 1.0 if side == 0 else -1.0
            rx = shape_pos[s, 0] - x[body, 0]
            ry = shape_pos[s, 1] - x[body, 1]
            rz = shape_pos[s, 2] - x[body, 2]
            wx, wy, wz = omega[body, 0], omega[body, 1], omega[body, 2]
            T[0] += sign * dt * (v[body, 0] + wy * rz - wz * ry)
            T[1] += sign * dt * (v[body, 1] + wz * rx - wx * rz)
            T[2] += sign * dt * (v[body, 2] + wx * ry - wy * rx)
            spin2 = wx * wx + wy * wy + wz * wz
            turn += dt * math.sqrt(spin2) * _turning_radius(shape_type[s], shape_params[s])
            if force.shape[0]:
                accel = inv_mass[body] * math.sqrt(force[body, 0] ** 2 + force[body, 1] ** 2 + force[body, 2] ** 2)
            else:
                accel = math.sqrt(gravity[0] ** 2 + gravity[1] ** 2 + gravity[2] ** 2) if inv_mass[body] > 0.0 else 0.0
            arc += 0.5 * dt * dt * (spin2 * math.sqrt(rx * rx + ry * ry + rz * rz) + accel)
        tol = turn + arc + SWEEP_SLOP
        verts_a = shape_arrays(ta, a, shape_data, hull_vertex)[0]
        alone = m_count[m] == 1
        if tb == SHAPE_MESH:
            # A sphere's path swept is the one this manifold's face contacts leave it. A face contact is
            # linear (its plane's gap), so the solver holds it to the letter: the shape lands on the first
            # face its path closes on, at t_land = s / w, and then slides along its plane (swept straight
            # into the plane, a ball rolling up a face met the crest edge ahead from below, at a tilted
            # normal: the ghost again). ``lead`` (3,) is T up to t_land, ``path`` (3,) the rest, less what
            # goes into the faces it lands on. ``reach``: the depth the shape is already in the surface
            # (a triangle ahead is met at that depth too: a ball 0.45 mm into a face, rolling up along its
            # plane, met the crest edge 24 mm ahead), at most LINEAR_SLOP.
            land = 1.0
            reach = tol
            # (a sphere alone: held at one point, another shape turns about it, and the rest of it goes on
            # down; swept along its landing face, a hull's other corners met nothing and lost their contacts:
            # one thrown at 16 m/s at a heightfield went in 39 mm, spun up to 325 rad/s and fell through)
            round_a = ta == SHAPE_SPHERE
            for c in range(f, f + m_count[m]):
                # each point's triangle rows, found once (the sweeps below use them)
                point_n[c - f] = _point_triangles(b, c_feature[c], shape_data, mesh_triangle, a, shape_pos, shape_rot,
                                                  shape_type, shape_params, T, tol + c_separation[c], box_lo, box_hi,
                                                  point_rows[c - f])
                face_point[c - f] = _is_face(c_normal[c], point_rows[c - f], point_n[c - f], mesh_triangle,
                                             shape_rot[b])
                if round_a:
                    reach = min(reach, tol + max(c_separation[c], -LINEAR_SLOP))
                w = T[0] * c_normal[c, 0] + T[1] * c_normal[c, 1] + T[2] * c_normal[c, 2]
                if round_a and face_point[c - f] and w > 0.0:
                    land = min(land, max(c_separation[c] - tol, 0.0) / w)
            for k in range(3):
                lead[k] = land * T[k]
                path[k] = (1.0 - land) * T[k]
            for c in range(f, f + m_count[m]):
                w = T[0] * c_normal[c, 0] + T[1] * c_normal[c, 1] + T[2] * c_normal[c, 2]
                if round_a and face_point[c - f] and w > 0.0 and max(c_separation[c] - tol, 0.0) <= land * w:
                    into = path[0] * c_normal[c, 0] + path[1] * c_normal[c, 1] + path[2] * c_normal[c, 2]
                    if into > 0.0:
                        for k in range(3):
                            path[k] -= into * c_normal[c, k]
        whole = -1.0  # the sweep against the whole of a convex shape b, once per manifold (not yet made)
        for c in range(f, f + m_count[m]):
            s0 = c_separation[c]
            w = T[0] * c_normal[c, 0] + T[1] * c_normal[c, 1] + T[2] * c_normal[c, 2]
            if s0 <= tol or w + tol <= s0:
                continue  # touching, or its linear gap does not close within the step (nor with what T leaves out)
            if tb == SHAPE_MESH:
                # a face's contact is its plane's: linear in any translation, and the plane goes on in the
                # triangles beside it (which a pass beyond this one triangle would meet without a contact)
                if face_point[c - f]:
                    continue
                rows = point_rows[c - f]
                first = np.inf
                for i in range(point_n[c - f]):
                    # the lead up to t_land, then the path beyond it from where the lead ends
                    t = _sweep(ta, shape_pos[a], shape_rot[a], shape_params[a], verts_a, b, rows[i], lead, reach,
                               shape_type, shape_params, shape_pos, shape_rot, shape_data, hull_vertex, mesh_triangle,
                               scratch, pos, out)
                    if t < np.inf:
                        t *= land
                    else:
                        for k in range(3):
                            start[k] = shape_pos[a, k] + lead[k]
                        t = _sweep(ta, start, shape_rot[a], shape_params[a], verts_a, b, rows[i], path, reach,
                                   shape_type, shape_params, shape_pos, shape_rot, shape_data, hull_vertex,
                                   mesh_triangle, scratch, pos, out)
                        t = land + (1.0 - land) * t
                    if t < first:
                        first = t
                        hit_row = rows[i]
                        for k in range(9):
                            touch[k] = out[k]
                retarget = True
            else:
                if whole < 0.0:
                    whole = _sweep(ta, shape_pos[a], shape_rot[a], shape_params[a], verts_a, b, np.int64(-1), T, tol,
                                   shape_type, shape_params, shape_pos, shape_rot, shape_data, hull_vertex,
                                   mesh_triangle, scratch, pos, out)
                    for k in range(9):
                        touch[k] = out[k]
                    land = 1.0
                    for k in range(3):
                        lead[k] = T[k]
                        path[k] = 0.0
                first = whole
                retarget = alone
            if first == np.inf:
                # never that near within the step: the linear gap ends the step where it starts it
                allowance[c] = w
                changed += 1
            elif retarget:
                # the contact the sweep makes: its normal at the touch, the gap between the two points that
                # touch then (a's taken back to the step's start), so that its linear gap closes at t*
                nx, ny, nz = touch[6], touch[7], touch[8]
                if tb == SHAPE_MESH:
                    nx, ny, nz = _face_if_inactive(mesh_triangle[hit_row], mesh_edge_active[hit_row], shape_pos[b],
                                                   shape_rot[b], touch, turned)
                lead_part = min(first, land) / land if land > 0.0 else 1.0
                path_part = (first - land) / (1.0 - land) if first > land else 0.0
                ax = touch[0] - lead_part * lead[0] - path_part * path[0]
                ay = touch[1] - lead_part * lead[1] - path_part * path[1]
                az = touch[2] - lead_part * lead[2] - path_part * path[2]
                gap = nx * (touch[3] - ax) + ny * (touch[4] - ay) + nz * (touch[5] - az)
                c_normal[c, 0], c_normal[c, 1], c_normal[c, 2] = nx, ny, nz
                c_separation[c] = gap
                c_point[c, 0] = ax + 0.5 * gap * nx
                c_point[c, 1] = ay + 0.5 * gap * ny
                c_point[c, 2] = az + 0.5 * gap * nz
                if alone:
                    m_normal[m, 0], m_normal[m, 1], m_normal[m, 2] = nx, ny, nz
                changed += 1
            elif w * first > s0:
                allowance[c] = w * first - s0
                changed += 1
    return changed


def delay_speculative_ghosts(contacts, table, shape_pos, shape_rot, x, v, omega, dt: float, inv_mass, gravity,
                             force=None) -> int:
    """Stage five of ``CollisionPipeline.detect``: ``contacts.contact_allowance`` (the module
    docstring). ``x`` (N, >= 3) m, ``v``, ``omega`` (N, 3) at the step's start, ``dt`` s,
    ``inv_mass`` (N,) 1/kg, ``gravity`` (3,) m/s^2 and ``force`` (N, 3) N, the step's first applied
    forces (default: gravity alone). Returns the number of contacts given an allowance."""
    C = contacts.contact_count
    contacts.allowance_count = 0
    if C == 0 or dt <= 0.0:
        return 0
    m_shape_a, m_shape_b, _ba, _bb, m_normal, m_first, m_count, _cm, _cba, _cbb, c_point, c_normal, c_separation, \
        c_feature, _ck = contacts.buffers()
    # PERF: only a speculative point can be swept (a box resting on a plane: none, and no kernel call)
    if not (c_separation[:C] > SWEEP_SLOP).any():
        return 0
    # PERF: and only a pair of a moving shape and a fixed or kinematic one, neither a plane (boxes on a
    # plane, the 1000-box pile: none, and no kernel call: it and the GJK routines it calls cost a first
    # run 18 s of compilation, and a step ~20 us)
    M = contacts.manifold_count
    sa, sb = m_shape_a[:M], m_shape_b[:M]
    types = table.shape_type
    swept = (types[sa] != SHAPE_PLANE) & (types[sb] != SHAPE_PLANE) & (types[sb] <= SHAPE_MESH)
    if not swept.any():
        return 0
    body = table.shape_body
    if not (swept & ((inv_mass[body[sa]] == 0.0) | (inv_mass[body[sb]] == 0.0))).any():
        return 0
    allowance = contacts.allowance_buffer()
    g = table.geometry
    force = _NO_FORCE if force is None else force
    changed = int(delay_speculative_kernel(table.shape_type, table.shape_body, table.shape_params, shape_pos, shape_rot,
                                           g[0], g[1], g[6], g[7], x, v, omega,
                                           np.asarray(gravity, dtype=float), float(dt), contacts.manifold_count,
                                           m_shape_a, m_shape_b, m_normal, m_first, m_count, c_point, c_normal,
                                           c_separation, c_feature, inv_mass, force, allowance))
    contacts.allowance_count = changed
    return changed


_NO_FORCE = np.zeros((0, 3))
