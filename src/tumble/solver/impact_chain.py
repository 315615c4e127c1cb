"""Impacts through touching chains: a Newton's cradle of touching balls.

The restitution pass (``contact_solve.apply_restitution_kernel``, Box2D v3's) sets each
contact's normal speed after the step to -e times its approach speed before it. Where an
impact runs through bodies that already touch, that rule has nothing to act on: the balls
behind the struck one approach each other at 0 before the step, the step's solve (inelastic)
moves the whole row on together, and only the first contact bounces. Five touching steel
balls (e = 1, 3 m/s) then left as -0.38, -0.28, 0.83, 0.83, 2.00 m/s with 38 % of the energy
lost; hung on hinges, 44 % (measured, session 47). Every velocity-level engine shares this
(Box2D, Bullet, MuJoCo: the chain is solved as one simultaneous impact).

Here an impact that reaches a chain is solved as the sequence of pairwise impacts that a wave
through the chain makes (the sequential collision model: Guendelman, Bridson and Fedkiw 2003, "Nonconvex rigid bodies
with stacking", process the collisions pair by pair, each on the velocities the last left, before
the contacts):

1. ``chain_rows_kernel`` finds the chains: bodies joined by contacts that pushed this step,
   have restitution and join two dynamic bodies, in groups of three bodies or more, one of
   whose contacts bounces (``bounces``: approaching faster than the threshold before the step).
   A lone impact (two balls, a ball on the ground) keeps the restitution pass as it was, bit
   for bit: the sequence would give it the same outcome, and every scene without a chain is
   unchanged.
2. ``impact_chain_kernel`` takes the step's normal impulses of the chain's contacts (every
   contact that pushed this step and touches a body of the chain) back out of the velocities:
   what is left is the velocities before the impact, with the step's forces, joints and
   friction. Then each manifold approaching faster than the threshold takes its impact
   (its normal speeds set to -e times their approach speeds now, over its points as the
   restitution pass does), the manifolds passed over in order until none approaches that fast
   (at most ``max_passes`` passes): ball 1 stops ball 2, ball 2 stops ball 3, and so on, the
   last ball leaving at the first one's speed. Last, an inelastic sweep that only pushes stops
   any contact of the chain still approaching (slower than the threshold: the chain's contacts
   with the ground, whose support was taken out with the rest).

Each impact conserves momentum and, with e <= 1, never adds energy; the final sweep takes energy
out. The impacts are along the normals only: friction between the chain's bodies is the step's,
kept as solved. The positions are the step's, as the restitution pass leaves them. Contacts of
jointed bodies solved through the joint tree (``contact_tree``) take their impacts through the
tree's response, as ``restitution_tree_kernel`` does.
"""

from __future__ import annotations

from numba import njit

from ..math3d import JIT
from .contact_solve import MANIFOLD_PASS_SPEED, MANIFOLD_PASSES, _apply_impulse, bounces
from .contact_tree import _speed
from .joint_tree import apply_row_response

#: at least this many passes over a chain's manifolds in ``impact_chain_kernel`` (more for a long
#: chain: 4 per manifold): five touching balls need 4 passes with their contacts listed backwards,
#: 1 forwards; three balls of unequal masses take more impacts, finitely many (a light ball
#: between two heavy ones: 7 for masses 1, 0.1, 1 with e = 1)
MIN_CHAIN_PASSES = 32


@njit(**JIT)
def _root(parent, i):
    """The root of body i's group (union-find with path halving)."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(**JIT)
def chain_rows_kernel(body_a, body_b, restitution, relative_velocity, max_normal_impulse, threshold, inv_mass,
                      # scratch (N,) and the output (C,)
                      parent, size, impact, chain):
    """Mark in ``chain`` (C,) bool the contacts a chain's impact takes (module docstring, 1):
    those that pushed this step (``max_normal_impulse`` (C,) N s, nonzero) and touch a dynamic
    body (``inv_mass`` (N,) 1/kg, nonzero) of a group of 3 bodies or more joined by contacts that
    pushed, with ``restitution`` (C,) > 0, between two dynamic bodies, one of the group's contacts
    bouncing (pre-step approach ``relative_velocity`` (C,) m/s below -``threshold``). ``parent``,
    ``size`` (N,) int64 and ``impact`` (N,) bool scratch. Returns how many contacts are marked."""
    n = parent.shape[0]
    C = body_a.shape[0]
    for i in range(n):
        parent[i] = i
        size[i] = 1
        impact[i] = False
    joined = False
    for c in range(C):
        a = body_a[c]
        b = body_b[c]
        if max_normal_impulse[c] == 0.0 or restitution[c] == 0.0 or inv_mass[a] == 0.0 or inv_mass[b] == 0.0:
            continue
        ra = _root(parent, a)
        rb = _root(parent, b)
        if ra == rb:
            continue
        if size[ra] < size[rb]:
            ra, rb = rb, ra
        parent[rb] = ra
        size[ra] += size[rb]
        joined = True
    count = 0
    if not joined:  # no two dynamic bodies pushing on each other with restitution: nothing to mark
        for c in range(C):
            chain[c] = False
        return count
    for c in range(C):
        if bounces(restitution[c], relative_velocity[c], max_normal_impulse[c], threshold):
            for i in (body_a[c], body_b[c]):
                if inv_mass[i] != 0.0:
                    impact[_root(parent, i)] = True
    for c in range(C):
        marked = False
        if max_normal_impulse[c] != 0.0:
            for i in (body_a[c], body_b[c]):
                if inv_mass[i] != 0.0:
                    r = _root(parent, i)
                    if size[r] >= 3 and impact[r]:
                        marked = True
        chain[c] = marked
        if marked:
            count += 1
    return count


@njit(**JIT)
def _row_speed(c, v, omega, body_a, body_b, normal, arm_a, arm_b):
    """The normal speed (m/s) of contact c's point on b over a's (< 0: approaching)."""
    return _speed(v, omega, body_a[c], body_b[c], (arm_a[c, 0], arm_a[c, 1], arm_a[c, 2]),
                  (arm_b[c, 0], arm_b[c, 1], arm_b[c, 2]), (normal[c, 0], normal[c, 1], normal[c, 2]))


@njit(**JIT)
def _push(c, q, impulse, body_a, body_b, normal, arm_a, arm_b, inv_mass, I_inv, slot_count, slot_ref, slot_resp, v,
          omega, linear_impulse, angular_impulse, axial_impulse):
    """A normal impulse (N s) on contact c: on its free bodies (q < 0), or through the joint tree
    as its tree row q (``contact_tree``)."""
    if q < 0:
        ra = (arm_a[c, 0], arm_a[c, 1], arm_a[c, 2])
        rb = (arm_b[c, 0], arm_b[c, 1], arm_b[c, 2])
        _apply_impulse(v, omega, inv_mass, I_inv, body_a[c], body_b[c], ra, rb, impulse * normal[c, 0],
                       impulse * normal[c, 1], impulse * normal[c, 2])
    else:
        apply_row_response(3 * q, impulse, slot_count[3 * q], slot_ref, slot_resp, v, omega, linear_impulse,
                           angular_impulse, axial_impulse)


@njit(**JIT)
def impact_chain_kernel(rows, tree_row, body_a, body_b, normal, restitution, normal_mass, threshold, arm_a, arm_b,
                        inv_mass, I_inv, slot_count, slot_ref, slot_resp, row_mass, max_passes,
                        # outputs
                        v, omega, linear_impulse, angular_impulse, axial_impulse, step_normal_impulse,
                        normal_impulse,
                        # scratch (K,)
                        target, event, total):
    """The chains' impacts as a sequence (module docstring, 2) for the contacts ``rows`` (K,) int64
    (``chain_rows_kernel``'s, in increasing order: a manifold's points are consecutive).
    ``tree_row`` (C,) int64: each contact's row in the joint tree's responses (``slot_count``,
    ``slot_ref``, ``slot_resp``, ``row_mass``: ``contact_tree.TreeContacts``'), -1 for one solved
    on its free bodies (``normal_mass`` (C,) kg). ``step_normal_impulse`` (C,) N s: the step's
    total normal impulse of each contact, taken out, then set to what the sequence applied;
    ``normal_impulse`` (C,) the warm start: 0 where an impact acted (the next step starts that
    contact afresh). ``target``, ``event``, ``total`` (K,) float scratch. Returns the number of
    impacts taken."""
    K = rows.shape[0]
    for k in range(K):
        c = rows[k]
        _push(c, tree_row[c], -step_normal_impulse[c], body_a, body_b, normal, arm_a, arm_b, inv_mass, I_inv,
              slot_count, slot_ref, slot_resp, v, omega, linear_impulse, angular_impulse, axial_impulse)
        total[k] = 0.0
    impacts = 0
    for _ in range(max_passes):
        struck = False
        k = 0
        while k < K:
            c0 = rows[k]
            end = k + 1
            while (end < K and rows[end] == rows[end - 1] + 1 and body_a[rows[end]] == body_a[c0]
                   and body_b[rows[end]] == body_b[c0]):
                end += 1
            hit = False
            for j in range(k, end):
                c = rows[j]
                speed = _row_speed(c, v, omega, body_a, body_b, normal, arm_a, arm_b)
                target[j] = -restitution[c] * speed if speed < -threshold else 0.0
                event[j] = 0.0
                if speed < -threshold:
                    hit = True
            if hit:
                impacts += 1
                struck = True
                # the manifold's impact: its points' normal speeds to their targets, passed over as the
                # restitution pass passes over a manifold (apply_restitution_kernel says why)
                for _pass in range(MANIFOLD_PASSES):
                    again = False
                    for j in range(k, end):
                        c = rows[j]
                        q = tree_row[c]
                        mass = normal_mass[c] if q < 0 else row_mass[3 * q]
                        if mass == 0.0:
                            continue
                        speed = _row_speed(c, v, omega, body_a, body_b, normal, arm_a, arm_b)
                        new = max(event[j] - mass * (speed - target[j]), 0.0)
                        d = new - event[j]
                        event[j] = new
                        if abs(d) > MANIFOLD_PASS_SPEED * mass:
                            again = True
                        _push(c, q, d, body_a, body_b, normal, arm_a, arm_b, inv_mass, I_inv, slot_count, slot_ref,
                              slot_resp, v, omega, linear_impulse, angular_impulse, axial_impulse)
                    if not again:
                        break
                for j in range(k, end):
                    total[j] += event[j]
                    if event[j] != 0.0:
                        normal_impulse[rows[j]] = 0.0
            k = end
        if not struck:
            break
    # an inelastic sweep that only pushes: whatever still approaches (slower than the threshold) stops
    for _pass in range(MANIFOLD_PASSES):
        again = False
        for k in range(K):
            c = rows[k]
            q = tree_row[c]
            mass = normal_mass[c] if q < 0 else row_mass[3 * q]
            if mass == 0.0:
                continue
            speed = _row_speed(c, v, omega, body_a, body_b, normal, arm_a, arm_b)
            if speed < 0.0:
                d = -mass * speed
                total[k] += d
                if d > MANIFOLD_PASS_SPEED * mass:
                    again = True
                _push(c, q, d, body_a, body_b, normal, arm_a, arm_b, inv_mass, I_inv, slot_count, slot_ref, slot_resp,
                      v, omega, linear_impulse, angular_impulse, axial_impulse)
        if not again:
            break
    for k in range(K):
        step_normal_impulse[rows[k]] = total[k]
    return impacts


def chain_passes(rows: int) -> int:
    """``impact_chain_kernel``'s cap on its passes for a chain of ``rows`` contacts."""
    return max(MIN_CHAIN_PASSES, 4 * rows)


