"""Mesh family: a convex shape (sphere ... convex) against a static triangle mesh (contract in ``pairs/__init__``).

The mesh's BVH (``geometry.build_bvh``, stored in the ShapeTable) is walked with the
shape's box in the mesh frame (6 support points, grown by the speculative distance),
so the cost is per nearby triangle. Each triangle is a convex shape of its own
(``convex.convex_contact``: GJK/EPA and clipping, up to 4 points), and the points of
all triangles are reduced to one manifold of at most 4 (deepest first, then area).

Internal edges (a shape sliding over a flat or concave seam would catch on the edge
normal; Jolt and Bullet call these internal or inactive edges): when a triangle's
contact normal is not its face normal and the triangle point lies on an inactive edge
(flat or concave, ``ShapeTable.mesh_edge_active``) or on a vertex whose two edges in
that triangle are both inactive, the contact is replaced by the face contact: normal
-N and the depth of the shape's deepest point below the triangle's plane. Triangles
the shape is entirely behind are skipped (the mesh is closed: another face holds it).

Normals: each kept point keeps its own triangle's normal and its separation along it
(``point_normal``: the one exception to the pair contract's shared normal), so a box
bridging a crease or a ball in a groove is pushed along each face's normal, as by two
planes. The manifold's ``normal`` is their mean weighted by speculative - separation
(a summary for the record). DEAD END (sessions 13-14): one shared normal for all the
points (the mean) leans up to half the crease angle off each face: a frictionless box in a
30 degree V-groove came to rest 0.12 m off the middle with 3.5 N and 6.3 N on the two
faces for 5.66 N each, and kept moving at 0.1 m/s; a ball in the groove at 0.45 m/s after 3 s.
Feature = (triangle row mod 2**16) << 5 | the triangle contact's slot.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...math3d import NO_NRT
from ...shapes import SHAPE_BOX, SHAPE_CONE, SHAPE_CONVEX, SHAPE_CYLINDER, SHAPE_SPHERE
from ..constants import LINEAR_SLOP, MAX_MANIFOLD_POINTS, MESH_POINTS
from .convex import (
    FEATURE_SINGLE,
    SLOT_DEEPEST,
    convex_contact,
    face_manifold,
    reduce_points,
    shape_arrays,
)
from ..geometry import BACK_SHIFT, TWO_SIDED
from .gjk import SHAPE_TRIANGLE, _closest_triangle, core_radius, support

# A contact normal within this of the face normal (1 - cos) is a face contact.
FACE_COS = 1e-6
# A triangle point with a barycentric weight below this is on an edge (or a vertex).
EDGE_WEIGHT = 1e-6
SLOT_FACE = 30
# Points of two triangles closer than this (m) are one point (0.1 mm: below any useful lever arm).
SAME_POINT = 1e-4
# On faces of several planes, the points within this (m) of the deepest are the touching patch, whose
# corners the manifold keeps before any speculative point (LINEAR_SLOP: a resting body's points lie
# within micrometres of each other; a clipped side face's speculative points lie up to 2 cm away).
TOUCH = LINEAR_SLOP
# A sphere whose centre is beside a triangle, beyond its inactive (flat or concave) edges only, by at most
# this (m, measured in the triangle's plane), still gets the triangle's face contact: the plane of a face
# across a concave seam bounds the shape there as much as the face itself (near a concave seam the free
# space is the intersection of the two faces' half-spaces), and across a flat one it is the neighbour's own
# plane (the same point: ``_gather`` merges the two).
# NOTE: why (the energy of a ball in a finely faceted bowl, contact audit 6c): beside the face, the contact
# was left to the triangle the centre is over, and on a concave surface the centre's projection reaches the
# next facet only r * (the facets' turn) / 2 before the ball reaches that facet's plane: 0.2 mm for a ball of
# r 0.1 on 4 mm facets of a bowl of R 1 m (0.23 degrees). At 1/240 s the ball moves up to 0.6 mm a step (and
# sags 4.3 um into its soft contacts), so it ran into the next facet's plane within the step before that facet
# made a contact: 483 of 496 new contacts in 6 s were made at a penetration, none as speculative ones. The
# push-out then lifted it without the kinetic energy the climb costs: a frictionless ball let go 0.05 rad up
# that bowl GAINED +2.02 mJ in 15 s on a 4 mm heightfield (+18 % of its 11.0 mJ), +4.4 mJ on 2 mm cells,
# +5.5 mJ in 30 s on a 256 x 128 sheet; let go 0.2 rad (2.5 mm a step), +29.3 mJ of 176. With this contact:
# -1.29, -0.95, -1.18 and -9.2 mJ (tests/physics/test_bowl_energy.py). At 1/960 s (0.15 mm a step) and on
# coarse facets (a wider 0.2 mm) the next facet was seen in time, and energy was lost, as it should be.
# 0.2 LINEAR_SLOP = 1 mm: the step's travel at 0.24 m/s at 1/240 s (beyond the band the contact is as
# before). LEFT: larger steps outrun it (4 mm heightfield, 15 s: dt 1/120 s +5.7 mJ, before +9.8; dt 1/60 s
# +17.8, before +19.6: a strict xfail in the test). DEAD END (tried, then reverted in review, session 44): a
# band grown by the step's motion bound (the pair's speculative distance beyond the default's) cured dt 1/120 s
# (-1.9 mJ) and halved 1/60 s (+6.0), but a face's plane is a bound only near its inactive edge: a few cells
# away, past a convex crest, it cuts into free space. A frictionless ball (r 0.05) rolling at 3 and 10 m/s
# along the grooves of a fine corrugation (a heightfield of 0.08 mm rows across the path, 0.5 mm deep, 1 mm
# apart) then gained up to +97 and +235 mJ and hopped 13 and 18 mm, where this 1 mm band and the code before
# gained nothing and kept within 1.0-1.3 mm of the surface. (Over ripples across the path, 0.5 mm high and
# 5 cm long on 4 mm cells, at 3 m/s, it hopped less: 3.6 mm against 39; the 1 mm band is the one that never
# gained energy in these runs.)
# Measured on the code before, 4 mm heightfield, E - E0 at 6 s (+0.69 mJ as is): a speculative distance of
# 0.05 m: +0.69 (the band is not what leaves the facet out); contacts twice as stiff (hertz_cap_per_substep
# 0.25: a quarter of the sag): +0.63, so the sag is a small part; no warm start (impulses zeroed after
# prepare_contacts): +0.36, half (not the cause: the gain stays); the restitution pass does nothing here
# (e = 0); energy per stage (kick, warm start, biased solve, drift, relax) swings 1-80 mJ per 1.5 s in and
# out, their sum 0.1-0.25 mJ: no stage's trend shows it. Not explained: 16 solver substeps at 1/240 s (the
# same step's travel) lost 0.14 mJ instead (the audit's substep_check.py found the same).
# DEAD ENDS (session 46, the 4 mm heightfield bowl at dt 1/60 s, 15 s; +17.8 mJ as is): a 10 mm band
# (a bound everywhere on this bowl, whose surface is convex): +5.5 mJ; the same with 16 solver substeps
# (stiffer contacts): +28; the 10 mm band with a sphere's gathered points reduced to its 4 deepest
# instead of the area's choice: +24.7 at 4 substeps, -1.6 at 16. At 4 substeps (h = 1/240 s) the
# contact against the mesh is 60 Hz and the ball sags 69 um into it, deeper than the neighbouring
# facets' planes lie below the ground under it (4 mm x 0.23 degrees = 16 um a facet): whichever facets
# are kept, the set of rows pushing on the ball changes as it rolls, and a row that joins compressed
# pushes it up. The 1 mm band stays; the xfail at 1/60 s stays (tests/physics/test_bowl_energy.py).
BESIDE_SPHERE = 0.2 * LINEAR_SLOP

# COMPILE: NumPy integers, not Python literals, for the triangle's type and its empty hull range: a
# literal argument makes Numba compile convex_contact, face_manifold and everything under them
# (GJK, EPA, clipping) a second time for triangles (measured: 30 s of a first mesh run)
TRIANGLE = np.int64(SHAPE_TRIANGLE)
ZERO = np.int64(0)


@njit(**NO_NRT)
def _mesh_box(ta, pos_a, rot_a, params_a, verts_a, pos_b, rot_b, grow, lo, hi):
    """The shape's box in the mesh frame: its extreme points along the mesh axes, grown by ``grow``."""
    r = core_radius(ta, params_a) + grow
    for k in range(3):
        ax, ay, az = rot_b[0, k], rot_b[1, k], rot_b[2, k]
        p = support(ta, pos_a, rot_a, params_a, verts_a, ax, ay, az)
        q = support(ta, pos_a, rot_a, params_a, verts_a, -ax, -ay, -az)
        hi[k] = (p[0] - pos_b[0]) * ax + (p[1] - pos_b[1]) * ay + (p[2] - pos_b[2]) * az + r
        lo[k] = (q[0] - pos_b[0]) * ax + (q[1] - pos_b[1]) * ay + (q[2] - pos_b[2]) * az - r


@njit(**NO_NRT)
def _barycentric(tri, px, py, pz):
    """(ok, b1, b2): the barycentric weights of corners 1 and 2 of triangle ``tri`` (3, 3) for the
    projection of p onto its plane (mesh frame; corner 0's weight is 1 - b1 - b2); ok is False
    for a degenerate triangle."""
    ux, uy, uz = tri[1, 0] - tri[0, 0], tri[1, 1] - tri[0, 1], tri[1, 2] - tri[0, 2]
    vx, vy, vz = tri[2, 0] - tri[0, 0], tri[2, 1] - tri[0, 1], tri[2, 2] - tri[0, 2]
    wx, wy, wz = px - tri[0, 0], py - tri[0, 1], pz - tri[0, 2]
    d00 = ux * ux + uy * uy + uz * uz
    d01 = ux * vx + uy * vy + uz * vz
    d11 = vx * vx + vy * vy + vz * vz
    d20 = wx * ux + wy * uy + wz * uz
    d21 = wx * vx + wy * vy + wz * vz
    den = d00 * d11 - d01 * d01
    if den <= 0.0:
        return False, 0.0, 0.0
    b1 = (d11 * d20 - d01 * d21) / den
    b2 = (d00 * d21 - d01 * d20) / den
    return True, b1, b2


@njit(**NO_NRT)
def _on_inactive_feature(tri, px, py, pz, active):
    """Whether the triangle point p (mesh frame) lies on an inactive edge, or a vertex with both edges inactive."""
    ok, b1, b2 = _barycentric(tri, px, py, pz)
    if not ok:
        return False
    b0 = 1.0 - b1 - b2
    # edge k runs from corner k to k + 1: it is where the weight of corner k + 2 vanishes
    on0 = b2 < EDGE_WEIGHT
    on1 = b0 < EDGE_WEIGHT
    on2 = b1 < EDGE_WEIGHT
    if not (on0 or on1 or on2):
        return False  # inside the face
    for k in range(3):
        on = on0 if k == 0 else (on1 if k == 1 else on2)
        if on and (active >> k) & 1:
            return False
    return True


@njit(**NO_NRT)
def _to_mesh(x, y, z, pos_b, rot_b):
    """World point to the mesh frame."""
    qx, qy, qz = x - pos_b[0], y - pos_b[1], z - pos_b[2]
    return (rot_b[0, 0] * qx + rot_b[1, 0] * qy + rot_b[2, 0] * qz, rot_b[0, 1] * qx + rot_b[1, 1] * qy + rot_b[2, 1] * qz,
            rot_b[0, 2] * qx + rot_b[1, 2] * qy + rot_b[2, 2] * qz)


@njit(**NO_NRT)
def _box_meets(tri, lo, hi):
    """Whether the box of triangle ``tri`` (3, 3) meets the box ``lo``, ``hi`` (3,) (the same frame)."""
    for k in range(3):
        if min(tri[0, k], tri[1, k], tri[2, k]) > hi[k] or max(tri[0, k], tri[1, k], tri[2, k]) < lo[k]:
            return False
    return True


@njit(**NO_NRT)
def _box_gap2(tri, px, py, pz):
    """The squared distance (m^2) from p (mesh frame) to the box of triangle ``tri`` (3, 3): 0 inside it."""
    gap2 = 0.0
    for k in range(3):
        pk = px if k == 0 else (py if k == 1 else pz)
        g = max(min(tri[0, k], tri[1, k], tri[2, k]) - pk, pk - max(tri[0, k], tri[1, k], tri[2, k]), 0.0)
        gap2 += g * g
    return gap2


@njit(**NO_NRT)
def _over_triangle(tri, px, py, pz):
    """Whether p (mesh frame) projects into the triangle (barycentric weights >= -1e-9)."""
    ok, b1, b2 = _barycentric(tri, px, py, pz)
    if not ok:
        return False
    return b1 >= -1e-9 and b2 >= -1e-9 and 1.0 - b1 - b2 >= -1e-9


@njit(**NO_NRT)
def _drop_deepest_beside(tri, n, px, py, pz, pos_b, rot_b, tn, tp, ts, tf):
    """The clipped manifold of one triangle without its added deepest point (slot SLOT_DEEPEST,
    the shape's deepest point along the triangle's normal, projected to p on its plane) when p is
    not over the triangle: that point belongs to the neighbour the shape is over, measured along
    the neighbour's normal. Returns the new count.

    DEAD END (session 14): kept, it gave a box lying on a terrain's ridge a second point at the
    ridge, measured against the plane of a triangle beside it (4 mm deeper than the triangle under
    it), traded from step to step with the true one: the box rocked at 2-3 cm/s for ever."""
    mx, my, mz = _to_mesh(px, py, pz, pos_b, rot_b)
    if _over_triangle(tri, mx, my, mz):
        return n
    out = 0
    for m in range(n):
        if (tf[m] & 31) == SLOT_DEEPEST:
            continue
        if out != m:
            for k in range(3):
                tp[out, k] = tp[m, k]
            ts[out] = ts[m]
            tf[out] = tf[m]
        out += 1
    return out


@njit(**NO_NRT)
def _sphere_triangle(c, r, pos_b, rot_b, tri, Nx, Ny, Nz, speculative, W, lam, sub, normal, point, separation,
                     feature):
    """A sphere against one triangle: the closest point of the triangle to the centre (exact; no GJK).
    W (3, 3), lam (3,), sub (4,) int: scratch."""
    for v in range(3):
        for i in range(3):
            W[v, i] = pos_b[i] + rot_b[i, 0] * tri[v, 0] + rot_b[i, 1] * tri[v, 1] + rot_b[i, 2] * tri[v, 2] - c[i]
    k, dd = _closest_triangle(W, ZERO, np.int64(1), np.int64(2), lam, sub)
    dist = math.sqrt(dd)
    if dist - r >= speculative:
        return 0
    qx, qy, qz = 0.0, 0.0, 0.0
    for j in range(k):
        qx += lam[j] * W[sub[j], 0]
        qy += lam[j] * W[sub[j], 1]
        qz += lam[j] * W[sub[j], 2]
    if dist > 1e-12:
        nx, ny, nz = qx / dist, qy / dist, qz / dist
    else:
        nx, ny, nz = -Nx, -Ny, -Nz
    normal[0], normal[1], normal[2] = nx, ny, nz
    sep = dist - r
    point[0, 0] = c[0] + (r + 0.5 * sep) * nx
    point[0, 1] = c[1] + (r + 0.5 * sep) * ny
    point[0, 2] = c[2] + (r + 0.5 * sep) * nz
    separation[0] = sep
    feature[0] = 0
    return 1


@njit(**NO_NRT)
def _fix_internal_edge(tri, active, n, Nx, Ny, Nz, low, depth_sep, ra, pos_b, rot_b, speculative, beside, tn, tp,
                       ts, tf):
    """The internal-edge and back-face rule (module docstring) on one triangle's contact; returns its new count.
    ``beside`` (m): a sphere's centre beside the face, beyond inactive edges only, by at most this, still
    gets the face contact (BESIDE_SPHERE); 0: none."""
    facing = tn[0] * Nx + tn[1] * Ny + tn[2] * Nz
    if facing > -(1.0 - FACE_COS):
        # not a face contact: on an inactive edge or vertex take the face normal instead; so too
        # when the normal would push the shape through to the back (one-sided triangles)
        j = 0
        for m in range(1, n):
            if ts[m] < ts[j]:
                j = m
        # the triangle's point of contact j, in the mesh frame
        qx = tp[j, 0] + 0.5 * ts[j] * tn[0] - pos_b[0]
        qy = tp[j, 1] + 0.5 * ts[j] * tn[1] - pos_b[1]
        qz = tp[j, 2] + 0.5 * ts[j] * tn[2] - pos_b[2]
        mx = rot_b[0, 0] * qx + rot_b[1, 0] * qy + rot_b[2, 0] * qz
        my = rot_b[0, 1] * qx + rot_b[1, 1] * qy + rot_b[2, 1] * qz
        mz = rot_b[0, 2] * qx + rot_b[1, 2] * qy + rot_b[2, 2] * qz
        inactive = _on_inactive_feature(tri, mx, my, mz, active)
        if facing >= 0.0 or inactive:
            tn[0], tn[1], tn[2] = -Nx, -Ny, -Nz
            # the shape's deepest point below the plane, in the mesh frame
            qx, qy, qz = low[0] - pos_b[0], low[1] - pos_b[1], low[2] - pos_b[2]
            mx = rot_b[0, 0] * qx + rot_b[1, 0] * qy + rot_b[2, 0] * qz
            my = rot_b[0, 1] * qx + rot_b[1, 1] * qy + rot_b[2, 1] * qz
            mz = rot_b[0, 2] * qx + rot_b[1, 2] * qy + rot_b[2, 2] * qz
            # the centre's distance from the face's plane along it, beside the triangle (a sphere: n = 1)
            near = (beside > 0.0 and inactive and facing < 0.0
                    and (ts[j] + ra) ** 2 - (depth_sep + ra) ** 2 <= beside * beside)
            if near or _over_triangle(tri, mx, my, mz):
                # over the face: a face contact at the plane's depth
                ts[0] = depth_sep
                for k in range(3):
                    # the shape's deepest point, moved half the separation towards the plane
                    tp[0, k] = low[k] - (ra + 0.5 * depth_sep) * (Nx, Ny, Nz)[k]
                n = 1 if depth_sep < speculative else 0
                tf[0] = SLOT_FACE
            else:
                # beside the face, on a flat or concave seam: the neighbour that the shape is over
                # gives the contact (this plane's depth would be too deep: it runs on under the shape)
                n = 0
    return n


@njit(**NO_NRT)
def _gather(t, n, tn, tp, ts, tf, count, cand, cand_n, seps, feats):
    """Add one triangle's n points to the pair's list (merging repeats, keeping the deepest when full)."""
    for m in range(n):
        # the same place found through two triangles (a shared edge or vertex): keep the first
        dup = False
        for q in range(count):
            if (cand[q, 0] - tp[m, 0]) ** 2 + (cand[q, 1] - tp[m, 1]) ** 2 + (cand[q, 2] - tp[m, 2]) ** 2 \
                    < SAME_POINT * SAME_POINT:
                dup = True
                seps[q] = min(seps[q], ts[m])
        if dup:
            continue
        slot = count
        if count == MESH_POINTS:
            # full: replace the shallowest point if this one is deeper
            slot = 0
            for q in range(1, MESH_POINTS):
                if seps[q] > seps[slot]:
                    slot = q
            if ts[m] >= seps[slot]:
                continue
        else:
            count += 1
        for k in range(3):
            cand[slot, k] = tp[m, k]
            cand_n[slot, k] = tn[k]
        seps[slot] = ts[m]
        feats[slot] = ((t & 0xFFFF) << 5) | (tf[m] & 31)
    return count


@njit(**NO_NRT)
def _touching_first(count, cand, cand_n, seps, feats, bound):
    """Moves the gathered points whose separation is at most ``bound`` to the front, each group in its
    order (a stable partition); returns how many there are."""
    near = 0
    for m in range(count):
        if seps[m] > bound:
            continue
        if m != near:
            px, py, pz = cand[m, 0], cand[m, 1], cand[m, 2]
            qx, qy, qz = cand_n[m, 0], cand_n[m, 1], cand_n[m, 2]
            sm, fm = seps[m], feats[m]
            for q in range(m, near, -1):
                for k in range(3):
                    cand[q, k] = cand[q - 1, k]
                    cand_n[q, k] = cand_n[q - 1, k]
                seps[q] = seps[q - 1]
                feats[q] = feats[q - 1]
            cand[near, 0], cand[near, 1], cand[near, 2] = px, py, pz
            cand_n[near, 0], cand_n[near, 1], cand_n[near, 2] = qx, qy, qz
            seps[near], feats[near] = sm, fm
        near += 1
    return near


@njit(**NO_NRT)
def _wastes_a_slot(count, total, seps, keep, bound):
    """Whether the ``count`` points kept (``keep``) of ``total`` hold one whose separation passes ``bound``
    (a speculative one) while a point within it is left out."""
    far = 0
    near_kept = 0
    for c in range(count):
        if seps[keep[c]] > bound:
            far += 1
        else:
            near_kept += 1
    if far == 0:
        return False
    near = 0
    for m in range(total):
        if seps[m] <= bound:
            near += 1
    return near > near_kept


@njit(**NO_NRT)
def _touching_first_reduce(total, cand, cand_n, seps, feats, nx, ny, nz, bound, keep):
    """The touching points (separation within ``bound``) moved to the front, their corners kept
    (``reduce_points``), then the deepest of the others in what slots are left; returns the count kept."""
    near = _touching_first(total, cand, cand_n, seps, feats, bound)
    for c in range(near):
        keep[c] = c
    kept = near
    if near > 2:
        kept = reduce_points(cand, seps, near, nx, ny, nz, keep)
    for _ in range(MAX_MANIFOLD_POINTS - kept):
        j = -1
        for m in range(near, total):
            if j < 0 or seps[m] < seps[j]:
                used = False
                for q in range(kept):
                    if keep[q] == m:
                        used = True
                if not used:
                    j = m
        if j < 0:
            break
        keep[kept] = j
        kept += 1
    return kept


@njit(**NO_NRT)
def _finish(count, cand, cand_n, seps, feats, speculative, normal, point, separation, feature, point_normal, keep,
            faceted):
    """Reduce the gathered points to a manifold (each point with its own triangle's normal, and the
    manifold's normal their weighted mean); returns its point count. keep: (MESH_POINTS,) int scratch.
    ``faceted``: the shape has flat faces (a box, hull, cylinder or cone), whose clipping can leave a side
    face's points in the speculative band."""
    deepest = 0
    for m in range(1, count):
        if seps[m] < seps[deepest]:
            deepest = m
    nx, ny, nz = cand_n[deepest, 0], cand_n[deepest, 1], cand_n[deepest, 2]
    for c in range(count):
        keep[c] = c
    total = count
    if count > 2:
        count = reduce_points(cand, seps, count, nx, ny, nz, keep)
    # the points kept leave a touching one (within TOUCH of the deepest) out for one in the speculative band,
    # on faces of more than one plane (a crease, a groove, a funnel): the touching points first, in their
    # order, their corners kept, then the deepest of the others in what slots are left. A sphere, ellipsoid or
    # capsule has no flat side face to clip (its points are its lowest point or segment on each triangle):
    # those keep the one reduction, and their bits.
    # DEAD END (before session 43): the one reduction alone. A box wedged on its edges in a V-groove clips
    # its steep side face against each face, leaving a speculative point 18 mm off that was the farthest
    # from the deepest and so always kept; the box then stood on three of its four edge ends, the deepest
    # face alternated, the kept points with it every step (no warm start), and the box rocked at 1.3 cm/s
    # for ever (tests/collision/test_open_mesh_rest.py).
    bound = seps[deepest] + TOUCH
    if faceted and _wastes_a_slot(count, total, seps, keep, bound):
        for m in range(total):
            if cand_n[m, 0] * nx + cand_n[m, 1] * ny + cand_n[m, 2] * nz < 1.0 - FACE_COS:
                count = _touching_first_reduce(total, cand, cand_n, seps, feats, nx, ny, nz, bound, keep)
                break
    # the manifold's normal (a summary for the record; the solver pushes each point along its own):
    # the kept points' normals weighted by how far inside the speculative band they are
    sx, sy, sz = 0.0, 0.0, 0.0
    for c in range(count):
        j = keep[c]
        wgt = speculative - seps[j]
        sx += wgt * cand_n[j, 0]
        sy += wgt * cand_n[j, 1]
        sz += wgt * cand_n[j, 2]
    ln = math.sqrt(sx * sx + sy * sy + sz * sz)
    if ln > 1e-12:
        nx, ny, nz = sx / ln, sy / ln, sz / ln
    normal[0], normal[1], normal[2] = nx, ny, nz
    out = 0
    for c in range(count):
        j = keep[c]
        dup = False
        for q in range(out):
            if feature[q] == feats[j]:
                dup = True
        if dup:
            continue
        for k in range(3):
            point[out, k] = cand[j, k]
            point_normal[out, k] = cand_n[j, k]
        separation[out] = seps[j]
        feature[out] = feats[j]
        out += 1
    return out


@njit(**NO_NRT)
def collide_convex_mesh(ta, pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative, geometry, a, b,
                        normal, point, separation, feature, point_normal, scratch):
    """Sphere, capsule, cylinder, cone, box or convex a against the fixed mesh b (collide_<a>_mesh);
    ``point_normal`` (4, 3) gets each point's own normal (unit, world, from a to b); ``scratch``: a
    ``convex.convex_scratch()`` for the convex routines."""
    shape_data, hull_vertex, hull_face_first, hull_face_count, hull_face_vertex, hull_plane = geometry[:6]
    mesh_triangle, mesh_edge_active, node_aabb, node_first, node_count, node_skip = geometry[6:]
    verts_a, fa0, fna = shape_arrays(ta, a, shape_data, hull_vertex)
    ra = core_radius(ta, params_a)
    # the routine's arrays: the mesh part of the convex scratch (convex.convex_scratch)
    lo, hi, cand, cand_n, seps, feats, tn, tp, ts, tf, W, lam, sub, keep, turned = scratch[11]
    _mesh_box(ta, pos_a, rot_a, params_a, verts_a, pos_b, rot_b, speculative, lo, hi)
    count = np.int64(0)  # not a literal (see TRIANGLE)
    # a sphere's centre in the mesh frame, and the reach within which a triangle can give it a contact
    cmx, cmy, cmz = _to_mesh(pos_a[0], pos_a[1], pos_a[2], pos_b, rot_b)
    reach2 = (ra + speculative) ** 2
    n0 = shape_data[b, 2]
    n_end = n0 + shape_data[b, 3]
    i = n0
    while i < n_end:
        hit = True
        for k in range(3):
            if node_aabb[i, 0, k] > hi[k] or node_aabb[i, 1, k] < lo[k]:
                hit = False
        if not hit:
            i = node_skip[i]
            continue
        for t in range(node_first[i], node_first[i] + node_count[i]):
            tri = mesh_triangle[t]
            # the triangle's own box against the shape's (a leaf holds several triangles)
            if not _box_meets(tri, lo, hi):
                continue
            if ta == SHAPE_SPHERE:
                # PERF: a triangle whose box is farther from the centre than r + speculative has no point that
                # near (_sphere_triangle would return 0 for it): the corners of the shape's box, about half of
                # its triangles on a fine grid under a ball (a ball on 4 mm heightfield cells: ~2700 in its box)
                if _box_gap2(tri, cmx, cmy, cmz) >= reach2:
                    continue
            # face normal N (world) and the shape's extent along it
            ux, uy, uz = tri[1, 0] - tri[0, 0], tri[1, 1] - tri[0, 1], tri[1, 2] - tri[0, 2]
            vx, vy, vz = tri[2, 0] - tri[0, 0], tri[2, 1] - tri[0, 1], tri[2, 2] - tri[0, 2]
            lx, ly, lz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            ln = math.sqrt(lx * lx + ly * ly + lz * lz)
            if ln == 0.0:
                continue
            lx, ly, lz = lx / ln, ly / ln, lz / ln
            Nx = rot_b[0, 0] * lx + rot_b[0, 1] * ly + rot_b[0, 2] * lz
            Ny = rot_b[1, 0] * lx + rot_b[1, 1] * ly + rot_b[1, 2] * lz
            Nz = rot_b[2, 0] * lx + rot_b[2, 1] * ly + rot_b[2, 2] * lz
            c0x = pos_b[0] + rot_b[0, 0] * tri[0, 0] + rot_b[0, 1] * tri[0, 1] + rot_b[0, 2] * tri[0, 2]
            c0y = pos_b[1] + rot_b[1, 0] * tri[0, 0] + rot_b[1, 1] * tri[0, 1] + rot_b[1, 2] * tri[0, 2]
            c0z = pos_b[2] + rot_b[2, 0] * tri[0, 0] + rot_b[2, 1] * tri[0, 1] + rot_b[2, 2] * tri[0, 2]
            active = mesh_edge_active[t]
            low = support(ta, pos_a, rot_a, params_a, verts_a, -Nx, -Ny, -Nz)
            high = support(ta, pos_a, rot_a, params_a, verts_a, Nx, Ny, Nz)
            if active & TWO_SIDED:
                # an open mesh's triangle (Mesh(closed=False)) is solid on the side the middle of the
                # shape's extent along N is on: behind it, the triangle is turned (corners 0, 2, 1: the same
                # plane, the other normal) and its edges take their activity seen from the back
                # (geometry.mesh_edge_flags). Bullet's triangle meshes and PhysX's double-sided ones decide
                # so too; a shape pushed more than half through the sheet is then pushed on out the other
                # side (speculative contacts keep a fast body from getting there: tests/physics/test_open_mesh.py).
                # DEAD END (session 43): the side of the shape's origin (pos_a). A cone's origin is on its
                # base, and a hull's may be on a face: resting flat on the sheet, the origin lies in its plane,
                # and the first 1e-6 m of sag put it behind; the sheet then pushed the cone down through
                # itself (free fall, tests/collision/test_open_mesh_rest.py). The middle of the extent is the
                # centre for a sphere, box, capsule or cylinder.
                mid = 0.5 * (Nx * (low[0] + high[0] - 2.0 * c0x) + Ny * (low[1] + high[1] - 2.0 * c0y)
                             + Nz * (low[2] + high[2] - 2.0 * c0z))
                if mid < 0.0:
                    for k in range(3):
                        turned[0, k] = tri[0, k]
                        turned[1, k] = tri[2, k]
                        turned[2, k] = tri[1, k]
                    tri = turned
                    Nx, Ny, Nz = -Nx, -Ny, -Nz
                    active = (active >> BACK_SHIFT) & 7
                    low, high = high, low
                else:
                    active = active & 7
            depth_sep = Nx * (low[0] - c0x) + Ny * (low[1] - c0y) + Nz * (low[2] - c0z) - ra
            if depth_sep >= speculative:
                continue  # the whole shape is above the triangle's plane
            if Nx * (high[0] - c0x) + Ny * (high[1] - c0y) + Nz * (high[2] - c0z) + ra < 0.0:
                continue  # entirely behind it
            if ta == SHAPE_SPHERE and (active & 7) == 0:
                # PERF: a triangle with no active edge gives a sphere only a face contact, and only where the
                # centre's projection on its plane is over it or within BESIDE_SPHERE of it (_fix_internal_edge):
                # farther than that from the triangle's box, no contact (on a fine grid, most triangles under
                # a ball; the same contacts as the full test)
                d = lx * (cmx - tri[0, 0]) + ly * (cmy - tri[0, 1]) + lz * (cmz - tri[0, 2])
                beside2 = _box_gap2(tri, cmx - d * lx, cmy - d * ly, cmz - d * lz)
                if beside2 > BESIDE_SPHERE * BESIDE_SPHERE * (1.0 + 1e-9):
                    continue
            if ta != SHAPE_SPHERE and active == 0:
                # PERF: inside a flat or concave patch (no active edge) the normal is the face's (the
                # internal-edge rule below would pick it anyway): no GJK/EPA, straight to the face clipping.
                # The clip keeps the part of the shape over this triangle; a shape beside it gets only the
                # one-point fallback, kept only if that point is over the triangle (else a neighbour's job).
                core = depth_sep + ra
                px, py, pz = low[0] - core * Nx, low[1] - core * Ny, low[2] - core * Nz
                n = face_manifold(ta, pos_a, rot_a, params_a, verts_a, fa0, fna, TRIANGLE, pos_b, rot_b,
                                  params_b, tri, ZERO, ZERO, hull_face_first, hull_face_count, hull_face_vertex, hull_plane,
                                  hull_vertex, speculative, -Nx, -Ny, -Nz, depth_sep, core, low, (px, py, pz),
                                  tn, tp, ts, tf, scratch)
                if n == 1 and tf[0] == FEATURE_SINGLE:
                    mx, my, mz = _to_mesh(px, py, pz, pos_b, rot_b)
                    if not _over_triangle(tri, mx, my, mz):
                        n = 0
                    tf[0] = SLOT_FACE
                elif n > 1:
                    n = _drop_deepest_beside(tri, n, px, py, pz, pos_b, rot_b, tn, tp, ts, tf)
            elif ta == SHAPE_SPHERE:
                n = _sphere_triangle(pos_a, ra, pos_b, rot_b, tri, Nx, Ny, Nz, speculative, W, lam, sub, tn, tp, ts,
                                     tf)
            else:
                n = convex_contact(ta, pos_a, rot_a, params_a, verts_a, fa0, fna, TRIANGLE, pos_b, rot_b,
                                   params_b, tri, ZERO, ZERO, hull_face_first, hull_face_count, hull_face_vertex, hull_plane,
                                   hull_vertex, speculative, tn, tp, ts, tf, scratch)
            if n == 0:
                continue
            n = _fix_internal_edge(tri, active, n, Nx, Ny, Nz, low, depth_sep, ra, pos_b, rot_b,
                                   speculative, BESIDE_SPHERE if ta == SHAPE_SPHERE else 0.0, tn, tp, ts, tf)
            count = _gather(t, n, tn, tp, ts, tf, count, cand, cand_n, seps, feats)
        i += 1
    if count == 0:
        return 0
    return _finish(count, cand, cand_n, seps, feats, speculative, normal, point, separation, feature, point_normal,
                   keep, ta == SHAPE_BOX or ta == SHAPE_CONVEX or ta == SHAPE_CYLINDER or ta == SHAPE_CONE)
