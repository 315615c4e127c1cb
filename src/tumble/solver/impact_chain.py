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

1. ``chain_rows_kernel`` finds the chains: bodies joined by contacts that carried an impact
   this step (``carries_impact``: a normal impulse well above the load they carried before),
   have restitution and join two dynamic bodies, in groups of three bodies or more, one of
   whose contacts bounces (``bounces``: approaching faster than the threshold before the step).
   A lone impact (two balls, a ball on the ground) keeps the restitution pass as it was, bit
   for bit: the sequence would give it the same outcome, and every scene without a chain is
   unchanged.
2. ``impact_chain_kernel`` takes the step's normal impulses of the chain's contacts (every
   contact that carried an impact this step and touches a body of the chain) back out of the
   velocities: what is left is the velocities before the impact, with the step's forces, joints,
   friction and the loads the other contacts carry. Then the impacts, in waves: each pass takes
   every manifold approaching faster than the threshold now, together (normal speeds set to -e
   times their approach speeds at the pass's start, over their points as the restitution pass
   does), until none approaches that fast (at most ``max_passes`` passes): ball 1 stops ball 2,
   ball 2 stops ball 3, and so on, the last ball leaving at the first one's speed. Last, an
   inelastic sweep that only pushes stops any contact of the chain still approaching (slower
   than the threshold).

Each impact conserves momentum and, with e <= 1, each wave takes energy out (WAVE_ROWS in
``impact_chain_kernel``), as does the final sweep.

Opt-in (``SoftStepSettings.impact_chains``, off by default): a body struck while it rests on a
support is taken as free during the strike, then bounced off the support in the next wave
(docs/contact.md, "Impacts through touching chains", says what that did to an example). The impacts are along the normals only: friction between the chain's bodies is the step's,
kept as solved within Coulomb's bound on the sequence's normal impulses. The positions are the
step's, as the restitution pass leaves them. Contacts of jointed bodies solved through the joint
tree (``contact_tree``) take their impacts through the tree's response, as
``restitution_tree_kernel`` does.
"""

from __future__ import annotations

from numba import njit

from ..math3d import JIT
from .contact_solve import MANIFOLD_PASS_SPEED, MANIFOLD_PASSES, _apply_impulse, bounces
from .contact_tree import _speed
from .island import _root
from .joint_tree import apply_row_response

#: at least this many passes (waves) over a chain's manifolds in ``impact_chain_kernel`` (more for
#: a long chain: 4 per manifold): five touching balls take 4, one a pair; balls of unequal masses
#: can meet again and take more (whatever still approaches after the last is stopped by the sweep)
MIN_CHAIN_PASSES = 32
#: m/s: a contact whose step's impulse exceeds twice its last step's load by more than its effective
#: mass times this carried an impact (``carries_impact``)
CARRY_SPEED = 0.01


@njit(**JIT)
def carries_impact(c, normal_mass, step_normal_impulse, match, old_normal_impulse, substeps):
    """Whether contact c carried an impact this step: its step's normal impulse (N s) above twice
    the load it carried before (its last step's last substep impulse times ``substeps``; 0 for a
    new contact) plus the impulse of a CARRY_SPEED change of its normal speed. NOTE: why: without
    it every contact of a pile with restitution joined the chain of an impact anywhere in it; the
    sequence then took the whole pile's support out and put back only its stop (no push-out), and
    a pile of 216 boxes (e = 0.8) still moved at 6 cm/s after 4 s where it slept without chains
    (measured). The touching balls of a cradle carry nothing before the strike."""
    j = match[c]
    before = substeps * old_normal_impulse[j] if j >= 0 else 0.0
    return step_normal_impulse[c] > 2.0 * before + CARRY_SPEED * normal_mass[c]


@njit(**JIT)
def chain_rows_kernel(body_a, body_b, restitution, relative_velocity, max_normal_impulse, threshold, inv_mass,
                      normal_mass, step_normal_impulse, match, old_normal_impulse, substeps,
                      # scratch (N,) and the output (C,)
                      parent, size, impact, chain):
    """Mark in ``chain`` (C,) bool the contacts a chain's impact takes (module docstring, 1): those
    that carried an impact this step (``carries_impact``: ``step_normal_impulse`` (C,) N s against
    the last step's load, from ``match`` (C,) int64 into ``old_normal_impulse`` (K,) N s, times
    ``substeps``; ``normal_mass`` (C,) kg) and touch a dynamic body (``inv_mass`` (N,) 1/kg,
    nonzero) of a group of 3 bodies or more joined by such contacts, with ``restitution`` (C,) > 0,
    between two dynamic bodies, one of the group's contacts bouncing (pre-step approach
    ``relative_velocity`` (C,) m/s below -``threshold``, and it pushed: ``max_normal_impulse`` (C,)
    N s nonzero). ``parent``, ``size`` (N,) int64 and ``impact`` (N,) bool scratch. Returns how
    many contacts are marked."""
    n = parent.shape[0]
    C = body_a.shape[0]
    for i in range(n):
        parent[i] = i
        size[i] = 1
        impact[i] = False
    joined = False
    for c in range(C):
        # chain[c] first holds whether c pushed and carried an impact (the marking below reads it again)
        chain[c] = max_normal_impulse[c] != 0.0 and carries_impact(c, normal_mass, step_normal_impulse, match,
                                                                   old_normal_impulse, substeps)
        a = body_a[c]
        b = body_b[c]
        if not chain[c] or restitution[c] == 0.0 or inv_mass[a] == 0.0 or inv_mass[b] == 0.0:
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
        if chain[c]:
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
def _row_mass(c, q, normal_mass, row_mass):
    """The effective mass (kg) of contact c's normal row: its free bodies' (q < 0), or its tree row q's."""
    return normal_mass[c] if q < 0 else row_mass[3 * q]


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
def impact_chain_kernel(rows, tree_row, body_a, body_b, normal, tangent1, tangent2, restitution, friction,
                        normal_mass, threshold, arm_a, arm_b, inv_mass, I_inv, slot_count, slot_ref, slot_resp,
                        row_mass, max_passes,
                        # outputs
                        v, omega, linear_impulse, angular_impulse, axial_impulse, step_normal_impulse,
                        normal_impulse, step_tangent_impulse, tangent_impulse,
                        # scratch (K,)
                        target, event, total, wave):
    """The chains' impacts as a sequence (module docstring, 2) for the contacts ``rows`` (K,) int64
    (``chain_rows_kernel``'s, in increasing order: a manifold's points are consecutive).
    ``tree_row`` (C,) int64: each contact's row in the joint tree's responses (``slot_count``,
    ``slot_ref``, ``slot_resp``, ``row_mass``: ``contact_tree.TreeContacts``'), -1 for one solved
    on its free bodies (``normal_mass`` (C,) kg). ``step_normal_impulse`` (C,) N s: the step's
    total normal impulse of each contact, taken out, then set to what the sequence applied;
    ``normal_impulse`` (C,), ``tangent_impulse`` (C, 2) the warm start: 0 where an impact acted
    (the next step starts that contact afresh). ``step_tangent_impulse`` (C, 2) N s: the step's
    friction along ``tangent1``, ``tangent2`` (C, 3), kept as solved but within ``friction`` (C,)
    times the sequence's normal impulse: the excess is taken back out. NOTE: why: the solve's
    friction was bounded by the solve's normal impulses, and a chain's contact can end with less
    (a cradle's middle contacts end with none); kept whole, it turned the bodies of a pile of 216
    balls (e = 0.8, friction 0.3), which then never slept, one of them spinning on at 0.34 rad/s
    (measured). ``target``, ``event``, ``total`` (K,) float and ``wave`` (K,) bool scratch. Returns
    the number of manifold impacts taken.

    The impacts come in waves: each pass over the chain takes every manifold then approaching faster
    than the threshold, together (their targets from their speeds at the pass's start). NOTE: why
    not one manifold at a time in the contacts' order: a ball struck on two others at once (a pool
    rack's apex) then passed the strike to whichever contact was listed first; the break of
    examples/billiards.toml sent one back corner out at 4.4 m/s and the other at 1.5 (measured).
    A cradle's balls meet one pair a wave, as before.

    WAVE_ROWS: a wave takes the points of its manifolds that approach at its start, not those
    separating then. A wave's energy changes by sum lambda (vn- + vn+) / 2 over its points; a point
    that approaches takes lambda > 0 only to end at -e vn- (or 0), so adds lambda (1 - e) vn- / 2 <=
    0, but a point separating at the start that the others' impulses turned into approaching adds
    lambda vn- / 2 > 0. In the bouncy bin (216 boxes, e = 0.8) one wave of 7 points raised the
    energy by 0.78 J, and its step by 0.71 J (measured); such a point is stopped by a later wave or
    the final sweep instead, each push of which only takes energy out."""
    K = rows.shape[0]
    for k in range(K):
        c = rows[k]
        _push(c, tree_row[c], -step_normal_impulse[c], body_a, body_b, normal, arm_a, arm_b, inv_mass, I_inv,
              slot_count, slot_ref, slot_resp, v, omega, linear_impulse, angular_impulse, axial_impulse)
        total[k] = 0.0
    impacts = 0
    for _ in range(max_passes):
        # a wave: the manifolds approaching faster than the threshold now take their impacts together,
        # their targets set from their speeds at the wave's start
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
                wave[j] = speed < 0.0  # NOTE: approaching points only (WAVE_ROWS)
                if speed < -threshold:
                    hit = True
            if hit:
                impacts += 1
                struck = True
            else:
                for j in range(k, end):
                    wave[j] = False
            k = end
        if not struck:
            break
        # the wave's points' normal speeds to their targets, passed over as the restitution pass passes
        # over a manifold (apply_restitution_kernel says why)
        for _pass in range(MANIFOLD_PASSES):
            again = False
            for j in range(K):
                if not wave[j]:
                    continue
                c = rows[j]
                q = tree_row[c]
                mass = _row_mass(c, q, normal_mass, row_mass)
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
        for j in range(K):
            if wave[j]:
                total[j] += event[j]
                if event[j] != 0.0:
                    normal_impulse[rows[j]] = 0.0
    # an inelastic sweep that only pushes: whatever still approaches (slower than the threshold) stops
    for _pass in range(MANIFOLD_PASSES):
        again = False
        for k in range(K):
            c = rows[k]
            q = tree_row[c]
            mass = _row_mass(c, q, normal_mass, row_mass)
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
        c = rows[k]
        step_normal_impulse[c] = total[k]
        if normal_impulse[c] == 0.0:
            tangent_impulse[c, 0] = 0.0
            tangent_impulse[c, 1] = 0.0
        # Coulomb's bound on the step's friction, with the sequence's normal impulse
        s1 = step_tangent_impulse[c, 0]
        s2 = step_tangent_impulse[c, 1]
        held = (s1 * s1 + s2 * s2) ** 0.5
        bound = friction[c] * total[k]
        if held > bound:
            scale = bound / held
            d1 = s1 * (scale - 1.0)
            d2 = s2 * (scale - 1.0)
            step_tangent_impulse[c, 0] = s1 * scale
            step_tangent_impulse[c, 1] = s2 * scale
            q = tree_row[c]
            if q < 0:
                ra = (arm_a[c, 0], arm_a[c, 1], arm_a[c, 2])
                rb = (arm_b[c, 0], arm_b[c, 1], arm_b[c, 2])
                _apply_impulse(v, omega, inv_mass, I_inv, body_a[c], body_b[c], ra, rb,
                               d1 * tangent1[c, 0] + d2 * tangent2[c, 0], d1 * tangent1[c, 1] + d2 * tangent2[c, 1],
                               d1 * tangent1[c, 2] + d2 * tangent2[c, 2])
            else:
                apply_row_response(3 * q + 1, d1, slot_count[3 * q + 1], slot_ref, slot_resp, v, omega,
                                   linear_impulse, angular_impulse, axial_impulse)
                apply_row_response(3 * q + 2, d2, slot_count[3 * q + 2], slot_ref, slot_resp, v, omega,
                                   linear_impulse, angular_impulse, axial_impulse)
    return impacts


def chain_passes(rows: int) -> int:
    """``impact_chain_kernel``'s cap on its passes for a chain of ``rows`` contacts."""
    return max(MIN_CHAIN_PASSES, 4 * rows)


