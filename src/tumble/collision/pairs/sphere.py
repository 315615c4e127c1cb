"""Sphere family: plane-sphere, sphere-sphere (contract in ``pairs/__init__``)."""

from __future__ import annotations

import math

from numba import njit

from ...math3d import JIT


@njit(**JIT)
def plane_world(pos, rot, params):
    """World normal n (tuple) and offset d of a plane shape: n . p = d."""
    nx = rot[0, 0] * params[0] + rot[0, 1] * params[1] + rot[0, 2] * params[2]
    ny = rot[1, 0] * params[0] + rot[1, 1] * params[1] + rot[1, 2] * params[2]
    nz = rot[2, 0] * params[0] + rot[2, 1] * params[1] + rot[2, 2] * params[2]
    d = params[3] + nx * pos[0] + ny * pos[1] + nz * pos[2]
    return nx, ny, nz, d


@njit(**JIT)
def collide_plane_sphere(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative,
                         normal, point, separation, feature):
    nx, ny, nz, d = plane_world(pos_a, rot_a, params_a)
    r = params_b[0]
    sep = nx * pos_b[0] + ny * pos_b[1] + nz * pos_b[2] - d - r
    if sep >= speculative:
        return 0
    normal[0] = nx
    normal[1] = ny
    normal[2] = nz
    # midway between the sphere's lowest point c - r n and its projection on the plane
    k = r + 0.5 * sep
    point[0, 0] = pos_b[0] - k * nx
    point[0, 1] = pos_b[1] - k * ny
    point[0, 2] = pos_b[2] - k * nz
    separation[0] = sep
    feature[0] = 0
    return 1


@njit(**JIT)
def sphere_sphere_core(ca, ra, cb, rb, speculative, normal, point, separation, feature, slot, fid):
    """Two spheres (centres (3,) and radii): writes contact ``slot``; returns 1 or 0.

    Shared by the sphere-capsule and capsule-capsule routines (closest points of
    their segments are sphere centres). Concentric spheres take the normal +z.
    """
    dx = cb[0] - ca[0]
    dy = cb[1] - ca[1]
    dz = cb[2] - ca[2]
    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
    sep = dist - ra - rb
    if sep >= speculative:
        return 0
    if dist > 1e-12:
        nx, ny, nz = dx / dist, dy / dist, dz / dist
    else:
        nx, ny, nz = 0.0, 0.0, 1.0
    normal[0] = nx
    normal[1] = ny
    normal[2] = nz
    k = ra + 0.5 * sep
    point[slot, 0] = ca[0] + k * nx
    point[slot, 1] = ca[1] + k * ny
    point[slot, 2] = ca[2] + k * nz
    separation[slot] = sep
    feature[slot] = fid
    return 1


@njit(**JIT)
def collide_sphere_sphere(pos_a, rot_a, params_a, pos_b, rot_b, params_b, speculative,
                          normal, point, separation, feature):
    return sphere_sphere_core(pos_a, params_a[0], pos_b, params_b[0], speculative, normal, point, separation,
                              feature, 0, 0)
