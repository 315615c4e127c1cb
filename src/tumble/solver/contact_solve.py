"""The contact stages' kernels (``solver.contact``'s stage list): prepare (arms, effective
masses, softness), warm start, the solve a manifold at a time (soft non-penetration, Coulomb
friction, the relax), restitution and the impulses' store. Reads x, R, inv_mass, I_inv and the
contact arrays; writes v, omega (N, 3) and the per-contact impulses."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..collision.constants import DEEP_OVERLAP
from ..material import FRICTION_DEFAULT_MODE, RESTITUTION_DEFAULT_MODE
from ..math3d import JIT, serial_twin
from .contact_anchor import _arms

# An impact is solved a manifold at a time (``_solve_contact_range``): a first pass over a
# manifold's points (normals, then friction) that changes some point's speed by more than
# MANIFOLD_IMPACT_SPEED (m/s), or, in the relax, pushes a point that came into the substep
# approaching faster than MANIFOLD_APPROACH_SPEED (m/s), is followed by more passes until none
# changes one by more than MANIFOLD_PASS_SPEED (m/s), at most MANIFOLD_PASSES in all; the
# restitution pass likewise. Other manifolds take one pass, as Box2D's. The approach speed is
# the point's normal speed at the end of the previous substep's relax (``last_normal_speed``;
# at a new contact, the speed the step began with), not the speed the sweep meets, which in a
# heavy stack carries the weight the points above have just passed down (a trigger on that cost
# 29 % on the large pyramid).
# NOTE (measured against one pass, same hour): the large pyramid (1 thread) 79.0 vs 78.7 ms a
# step with the 0.5 m/s change trigger alone; a 0.25 m/s change trigger cost 8 % there (its
# heavy boxes sag at Box3D's step, changing 0.25-0.5 m/s a pass), 0.1 cost 26 %. The 1000-box
# pile, where every box lands, costs 11-15 % more than one pass (1 thread, runs paired). The
# approach trigger adds nothing measurable to either (interleaved rounds, busy hour: pyramid
# 95 / 88 vs 99 / 108 ms, pile 4.33-4.61 vs 4.49-4.96 s). With the change trigger alone an
# impact below ~3 m/s (a quarter of it on each corner of a box) took one pass: a cube landing
# flat at 2 m/s with e = 0 in zero gravity rebounded at 1.4 cm/s, slid at 1.4 cm/s and turned
# at 0.02 rad/s; now 1e-5 m/s, 2e-4 m/s, 6e-5 rad/s (tests/physics/test_contact_impacts.py).
# Why in the relax only: the approach trigger in the biased solve as well (same residues) made
# the pile's energy rise 1.5 mJ between two frames near its end (tests/test_examples_contact.py
# allows none); the relax's passes only take velocity away, the biased ones push out overlap.
# @warning speeds: scaled for bodies of 0.1-10 m.
# Dead ends, each cheaper on the pile: passes over the normals alone until they converge, then
# the friction (0-5 %): the pile's energy then rose 6.8 mJ between two frames late in the run,
# which one pass never does (tests/test_examples_contact.py); the same with the push-out only in
# the first pass: a box deep under a plane, whose manifold passes every step, no longer climbed
# out; stopping when a pass shrank the changes by less than half: flat landings still turned.
MANIFOLD_IMPACT_SPEED = 0.5
MANIFOLD_APPROACH_SPEED = 0.1  # m/s: 2.5 g h at Box3D's substep, 10 g h at the default one
MANIFOLD_PASS_SPEED = 0.001
MANIFOLD_PASSES = 32
# A row's effective mass is computed once a step, at the arms of its start (``prepare_contacts_kernel``);
# the relax reads the arms again as the bodies move. Where the mass then exceeds 1 / (J M^-1 J^T) at
# the arms the impulse acts at by more than MASS_DRIFT times, the row takes the mass of those arms
# (``_mass_at_arms``). NOTE: why 2: a row solved with k times its true mass leaves the speed it drives
# to its target at (1 - k) times its gap from it: beyond k = 2 the speed comes out larger than it went
# in, the row adds energy, and the manifold's passes (up to MANIFOLD_PASSES) multiply it. A 1 cm cube
# at 30 m/s, 10 degrees onto a plane (dt 1/240 s) moved 3 cm a substep, the midpoint of its contacts
# (half way to the plane's anchor, which stays where the step began: ``contact_anchor``) trailed 7 cm
# behind it, and its rows were solved with 6 to 214 times their mass: omega 59 -> 12 189 rad/s in
# the step, 1.0e6 J from 4.5 J the next. The golden scenes' rows stay within 1.4 times their mass
# but one of the dice's at 2.07, which pushes nothing: all keep their hashes (docs/contact.md,
# "Fast small bodies").
MASS_DRIFT = 2.0
# a sliding contact's friction on the edge of its disc (``friction_impulses_after``): Newton's steps
# on a concave function from its left converge quadratically; 1e-12 of |new| in a few steps
FRICTION_NEWTON_STEPS = 16
FRICTION_NEWTON_TOLERANCE = 1e-12


# ---------------------------------------------------------------------- small helpers
@njit(**JIT)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(**JIT)
def _point_velocity(v, omega, i, r):
    """Velocity (3 floats) of the point at arm r (3,) of body i: v + omega x r."""
    c0, c1, c2 = _cross(omega[i, 0], omega[i, 1], omega[i, 2], r[0], r[1], r[2])
    return v[i, 0] + c0, v[i, 1] + c1, v[i, 2] + c2


@njit(**JIT)
def _apply_impulse(v, omega, inv_mass, I_inv, a, b, ra, rb, p0, p1, p2):
    """Impulse P = (p0, p1, p2) on b at arm rb and -P on a at arm ra."""
    ma = inv_mass[a]
    mb = inv_mass[b]
    v[a, 0] -= ma * p0
    v[a, 1] -= ma * p1
    v[a, 2] -= ma * p2
    v[b, 0] += mb * p0
    v[b, 1] += mb * p1
    v[b, 2] += mb * p2
    c0, c1, c2 = _cross(ra[0], ra[1], ra[2], p0, p1, p2)
    for k in range(3):
        omega[a, k] -= I_inv[a, k, 0] * c0 + I_inv[a, k, 1] * c1 + I_inv[a, k, 2] * c2
    c0, c1, c2 = _cross(rb[0], rb[1], rb[2], p0, p1, p2)
    for k in range(3):
        omega[b, k] += I_inv[b, k, 0] * c0 + I_inv[b, k, 1] * c1 + I_inv[b, k, 2] * c2


@njit(**JIT)
def _angular_term(I_inv, i, r, d0, d1, d2):
    """(r x d) . I_inv[i] (r x d)."""
    c0, c1, c2 = _cross(r[0], r[1], r[2], d0, d1, d2)
    return (c0 * (I_inv[i, 0, 0] * c0 + I_inv[i, 0, 1] * c1 + I_inv[i, 0, 2] * c2)
            + c1 * (I_inv[i, 1, 0] * c0 + I_inv[i, 1, 1] * c1 + I_inv[i, 1, 2] * c2)
            + c2 * (I_inv[i, 2, 0] * c0 + I_inv[i, 2, 1] * c1 + I_inv[i, 2, 2] * c2))


@njit(**JIT)
def _effective_mass(inv_mass, I_inv, a, b, ra, rb, d0, d1, d2):
    """1 / (J M^-1 J^T) for the direction d at arms ra, rb (0 when both bodies are fixed)."""
    k = inv_mass[a] + inv_mass[b] + _angular_term(I_inv, a, ra, d0, d1, d2) + _angular_term(I_inv, b, rb, d0, d1, d2)
    return 1.0 / k if k > 0.0 else 0.0


# ---------------------------------------------------------------------- kernels
@njit(**JIT, inline="always")
def combine_material(value_a, value_b, mode_a, mode_b, default):
    """A contact's friction or restitution from its two bodies' (or parts'): by the mode later in
    ``material.COMBINE_MODES`` of ``mode_a`` and ``mode_b`` (-1: the body sets none), ``default``
    when neither sets one (PhysX's precedence of combine modes)."""
    mode = max(mode_a, mode_b)
    if mode < 0:
        mode = default
    if mode == 0:
        return math.sqrt(value_a * value_b)
    if mode == 1:
        return 0.5 * (value_a + value_b)
    if mode == 2:
        return min(value_a, value_b)
    if mode == 3:
        return value_a * value_b
    return max(value_a, value_b)


@njit(**JIT, inline="always")
def combine_friction(value_a, value_b, codes_a0, codes_b0, condim_a, condim_b):
    """A contact's friction: ``combine_material`` of the two bodies' (or parts') by their modes
    ``codes_a0``, ``codes_b0``, or none where the pair's condim, the larger of ``condim_a`` and
    ``condim_b``, is 1 (MuJoCo's frictionless contact: ``Material.condim``)."""
    if max(condim_a, condim_b) <= 1:
        return 0.0
    return combine_material(value_a, value_b, codes_a0, codes_b0, FRICTION_DEFAULT_MODE)


@njit(**JIT)
def combine_materials_kernel(index_a, index_b, friction_of, restitution_of, combine_of,
                             # outputs
                             friction, restitution):
    """Per contact c, friction[c] and restitution[c] (C,) from the rows index_a[c], index_b[c] of
    ``friction_of``, ``restitution_of`` (K,) and ``combine_of`` (K, 3) int64 (friction mode,
    restitution mode, condim): ``combine_material`` of each (bodies' or compound parts'
    materials); no friction where the pair's condim, the larger of the two, is 1."""
    for c in range(index_a.shape[0]):
        a = index_a[c]
        b = index_b[c]
        friction[c] = combine_friction(friction_of[a], friction_of[b], combine_of[a, 0], combine_of[b, 0],
                                       combine_of[a, 2], combine_of[b, 2])
        restitution[c] = combine_material(restitution_of[a], restitution_of[b], combine_of[a, 1], combine_of[b, 1],
                                          RESTITUTION_DEFAULT_MODE)


@njit(**JIT)
def soft_from_omega(omega, zeta, h):
    """(bias_rate 1/s, mass_scale, impulse_scale) of a soft constraint of natural frequency
    ``omega`` (rad/s) and damping ratio ``zeta`` stepped implicitly over ``h`` (s)
    (``solver.contact.soft_coefficients``: Catto, GDC 2011; Box2D ``b2MakeSoft``)."""
    a1 = 2.0 * zeta + h * omega
    a2 = h * omega * a1
    a3 = 1.0 / (1.0 + a2)
    return omega / a1, a2 * a3, a3


# LOAD (opt-in: ``SoftStepSettings.load_hertz_cap_per_substep``, 0 by default): the soft contact is a
# spring of stiffness m_eff omega^2 (m_eff the row's effective mass, ``normal_mass``), so it rests
# compressed by load / (m_eff omega^2): a row holding up more than its own bodies' weight sinks in
# proportion. A 100 kg box on a 1 kg one (dt 1/60 s) sinks 27 mm into it, the boxes at the bottom of
# the 1000-box pile overlap 8-19 mm at Box3D's step. A row whose last step's normal impulse shows a
# load F = lambda / h above m_eff |g| (``load_soft``) is stiffened to omega sqrt(F / (m_eff |g|)), which
# keeps its sag at that of a body resting under its own weight, g / omega^2, up to the cap (0.1875 / h
# advised; the rows with a fixed body are at 0.25 / h already). Measured: tests/physics/test_contact_load.py,
# docs/contact.md and docs/benchmarks.md "Loaded contacts".
# DEAD END: the cap at Box2D's own bound on a contact's hertz, 0.25 / h (the same for every row is the
# "60 Hz at h = 1/240 s" that shook the 20-row pyramid: SoftStepSettings' note): with only the loaded
# rows at it, the pyramid at Box3D's step (sleeping off) still shook at 0.6 m/s after 10 s, the large
# pyramid at 2.5 m/s; at 0.1875 / h they settle (2-4 mm/s after 10 s).
# WHY NOT BY DEFAULT: an impact's impulse is read as a load too, and the stiffened rows of the MJCF
# pendulum's strike through a 4-block tower (examples/mjcf_pendulum.toml) tipped the bottom block over
# (0.1 m), where MuJoCo, on the same scene, and the soft rows leave it within 0.3 mm. DEAD END: resting
# rows only (normal speed under 0.1 m/s at the step's start): the pendulum's block stayed, but rows then
# switched between soft and stiff as boxes moved, and each switch to stiff pushes its compression out,
# raising the bodies: the pile's energy rose 19 mJ between two frames (tests/test_examples_contact.py,
# which allows none); the stiffness of every loaded row, as here, never raised it there.
LOAD_OFF = np.zeros(7)


@njit(**JIT, parallel=True)
def prepare_contacts_kernel(body_a, body_b, point, normal, separation, match, old_normal_impulse,
                            old_friction_impulse, x, R, v, omega, inv_mass, I_inv, moving,
                            body_friction, body_restitution, body_combine, body_margin, soft_dynamic, soft_static,
                            load_soft, anchor_offset,
                            # outputs
                            anchor_a, anchor_b, local_a, local_b, separation_base, tangent1, tangent2, normal_mass,
                            tangent_mass, soft, friction, restitution, relative_velocity,
                            normal_impulse, tangent_impulse, max_normal_impulse):
    """Per contact: arms, tangent basis, effective masses, softness, mixed material, the
    pre-step normal speed (for restitution) and the warm-start impulses carried over by ``match``.
    Each contact writes only its own rows: the bits do not depend on the threads. The material:
    ``body_friction``, ``body_restitution`` (N,), ``body_combine`` (N, 3) int64 (friction mode,
    restitution mode, condim: ``Material.combine_codes``), ``body_margin`` (N,) m
    (``Material.margin``: the separation the solver sees is the gap less the pair's two).
    ``load_soft`` (7,): |g| h (m/s; 0: rows keep ``soft_dynamic`` / ``soft_static``), the dynamic rows'
    omega (rad/s) and damping ratio, the static rows' omega and damping ratio, the loaded rows' cap
    on omega, h (s): a row holding more than its own weight is stiffened (LOAD above).

    The anchors that follow the bodies through the step (``local_a``, ``local_b``, body frames,
    less each round surface's world offset ``anchor_offset``: ``contact_anchor``) start at the
    contact point p (the midpoint of the two surfaces, Box2D's), a round side's on its own
    surface, and ``separation_base`` is s - n.d0 (d = pb - pa, d0 its value at the start, 0 when
    both start at p), so that ``separation_base + n.d`` is the separation as they move
    (``solve_contacts_kernel``). A contact deeper than
    ``DEEP_OVERLAP`` (collision.constants) moves each anchor towards its own body's surface by
    half the overlap beyond it, p -/+ ((s + DEEP_OVERLAP) / 2) n, and ``separation_base`` becomes
    s - n.d0 for their start d0. NOTE: why: a body deep in another (a box 100 m under a plane,
    where the README's example once left one) carried an anchor 50 m from its centre, which swung
    50 m per radian the body turned: the separation seen and the arms blew up within a step
    (v 7e3 m/s). Surface anchors for shallow contacts too fixed that, but the pile of 1000 boxes then
    gained energy between two frames (3-26 mJ of 22 563 J), which the single point never does."""
    for c in prange(body_a.shape[0]):
        a = body_a[c]
        b = body_b[c]
        n0, n1, n2 = normal[c, 0], normal[c, 1], normal[c, 2]
        # tangent basis from the normal alone, so that the same normal gives the same
        # tangents next step (friction impulses are also carried as world vectors)
        if abs(n0) >= 0.57735:
            t0, t1, t2 = n1, -n0, 0.0
        else:
            t0, t1, t2 = 0.0, n2, -n1
        inv = 1.0 / math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        t0 *= inv
        t1 *= inv
        t2 *= inv
        s0, s1, s2 = _cross(n0, n1, n2, t0, t1, t2)
        tangent1[c, 0], tangent1[c, 1], tangent1[c, 2] = t0, t1, t2
        tangent2[c, 0], tangent2[c, 1], tangent2[c, 2] = s0, s1, s2
        for k in range(3):
            anchor_a[c, k] = point[c, k] - x[a, k]
            anchor_b[c, k] = point[c, k] - x[b, k]
        # the anchors in each body's frame, to follow the separation as the bodies move: at p,
        # but for a deep overlap, where each moves towards its own surface (see the docstring),
        # and for a round side, whose anchor is its own surface point p -/+ s/2 n (its core point
        # fixed in the body, less its round offset: ``contact_anchor``). NOTE: why: at p, a ball
        # 12.5 mm above the floor at the step's start hit it with an arm 6.25 mm too long; its
        # friction then stopped the slip of a point below the ball: a ball landing at 3 m/s while
        # sliding at 2 m/s left at 1.477 m/s instead of 5/7 of 2, still slipping.
        half = 0.5 * min(separation[c] + DEEP_OVERLAP, 0.0)
        shift_a = half
        shift_b = half
        round_a = anchor_offset[c, 0] != 0.0 or anchor_offset[c, 1] != 0.0 or anchor_offset[c, 2] != 0.0
        round_b = anchor_offset[c, 3] != 0.0 or anchor_offset[c, 4] != 0.0 or anchor_offset[c, 5] != 0.0
        if round_a:
            shift_a = 0.5 * separation[c]
        if round_b:
            shift_b = 0.5 * separation[c]
        sa0 = anchor_a[c, 0] - shift_a * n0 - anchor_offset[c, 0]
        sa1 = anchor_a[c, 1] - shift_a * n1 - anchor_offset[c, 1]
        sa2 = anchor_a[c, 2] - shift_a * n2 - anchor_offset[c, 2]
        sb0 = anchor_b[c, 0] + shift_b * n0 - anchor_offset[c, 3]
        sb1 = anchor_b[c, 1] + shift_b * n1 - anchor_offset[c, 4]
        sb2 = anchor_b[c, 2] + shift_b * n2 - anchor_offset[c, 5]
        for k in range(3):
            local_a[c, k] = R[a, 0, k] * sa0 + R[a, 1, k] * sa1 + R[a, 2, k] * sa2
            local_b[c, k] = R[b, 0, k] * sb0 + R[b, 1, k] * sb1 + R[b, 2, k] * sb2
        # the solver keeps the surfaces the two margins apart (Material.margin): a contact's
        # separation as the solver sees it is the gap less them
        separation_base[c] = separation[c] - (body_margin[a] + body_margin[b])
        if half < 0.0 or round_a or round_b:  # the anchors no longer coincide: d0 = pb - pa at these poses
            # prange's c is unsigned: np.int64 for one compile of _arms
            ra, rb, d = _arms(x, R, a, b, local_a, local_b, anchor_offset, np.int64(c))
            separation_base[c] -= n0 * d[0] + n1 * d[1] + n2 * d[2]
            if round_a or round_b:  # the impulses' shared point is no longer p
                for k in range(3):
                    anchor_a[c, k] = ra[k]
                    anchor_b[c, k] = rb[k]
        # tuples, not the rows: a row is a view, whose reference count costs per contact
        ra = (anchor_a[c, 0], anchor_a[c, 1], anchor_a[c, 2])
        rb = (anchor_b[c, 0], anchor_b[c, 1], anchor_b[c, 2])
        normal_mass[c] = _effective_mass(inv_mass, I_inv, a, b, ra, rb, n0, n1, n2)
        tangent_mass[c, 0] = _effective_mass(inv_mass, I_inv, a, b, ra, rb, t0, t1, t2)
        tangent_mass[c, 1] = _effective_mass(inv_mass, I_inv, a, b, ra, rb, s0, s1, s2)
        static = not (moving[a] and moving[b])
        src = soft_static if static else soft_dynamic
        soft[c, 0], soft[c, 1], soft[c, 2] = src[0], src[1], src[2]
        friction[c] = combine_friction(body_friction[a], body_friction[b], body_combine[a, 0], body_combine[b, 0],
                                       body_combine[a, 2], body_combine[b, 2])
        restitution[c] = combine_material(body_restitution[a], body_restitution[b], body_combine[a, 1],
                                          body_combine[b, 1], RESTITUTION_DEFAULT_MODE)
        va0, va1, va2 = _point_velocity(v, omega, a, ra)
        vb0, vb1, vb2 = _point_velocity(v, omega, b, rb)
        relative_velocity[c] = n0 * (vb0 - va0) + n1 * (vb1 - va1) + n2 * (vb2 - va2)
        max_normal_impulse[c] = 0.0
        m = match[c]
        if m >= 0:
            normal_impulse[c] = old_normal_impulse[m]
            # a loaded row's stiffness (LOAD)
            weight = load_soft[0] * normal_mass[c]
            if weight > 0.0 and old_normal_impulse[m] > weight:
                w0 = load_soft[3] if static else load_soft[1]
                w = min(w0 * math.sqrt(old_normal_impulse[m] / weight), load_soft[5])
                if w > w0 * (1.0 + 1e-9):  # not a row at the cap already (the static ones by default)
                    zeta = load_soft[4] if static else load_soft[2]
                    soft[c, 0], soft[c, 1], soft[c, 2] = soft_from_omega(w, zeta, load_soft[6])
            f0, f1, f2 = old_friction_impulse[m, 0], old_friction_impulse[m, 1], old_friction_impulse[m, 2]
            tangent_impulse[c, 0] = f0 * t0 + f1 * t1 + f2 * t2
            tangent_impulse[c, 1] = f0 * s0 + f1 * s1 + f2 * s2
        else:
            normal_impulse[c] = 0.0
            tangent_impulse[c, 0] = 0.0
            tangent_impulse[c, 1] = 0.0


# PERF: a few contacts are prepared on the calling thread (``ContactSolver.prepare_contacts``): a
# parallel start cost up to 1.5 ms a step on this 2-core machine (10 boxes on the ground: 1.35 ms a
# step, 1.1 ms of it that start); each contact writes only its own rows, so the bits are the same.
prepare_contacts_serial_kernel = serial_twin(prepare_contacts_kernel, "prepare_contacts_serial_kernel")


@njit(**JIT)
def _warm_start_range(lo, hi, order, body_a, body_b, normal, tangent1, tangent2, local_a, local_b, anchor_offset,
                      normal_impulse, tangent_impulse, x, R, inv_mass, I_inv, fresh, v, omega, arm_a, arm_b, gap):
    """Contacts order[lo:hi] of ``warm_start_kernel``; the bodies' velocities in registers over a
    pair's consecutive contacts, as in ``_solve_contact_range`` (same bits as per impulse)."""
    cached_a, cached_b, va, wa, Ia, ma, vb, wb, Ib, mb = _no_pair()
    for i in range(lo, hi):
        c = order[i]
        a = body_a[c]
        b = body_b[c]
        if a != cached_a or b != cached_b:
            _store_pair(v, omega, cached_a, cached_b, va, wa, vb, wb)
            cached_a = a
            cached_b = b
            va, wa, Ia, ma, vb, wb, Ib, mb = _load_pair(v, omega, I_inv, inv_mass, a, b)
        jn = normal_impulse[c]
        j1 = tangent_impulse[c, 0]
        j2 = tangent_impulse[c, 1]
        p0 = jn * normal[c, 0] + j1 * tangent1[c, 0] + j2 * tangent2[c, 0]
        p1 = jn * normal[c, 1] + j1 * tangent1[c, 1] + j2 * tangent2[c, 1]
        p2 = jn * normal[c, 2] + j1 * tangent1[c, 2] + j2 * tangent2[c, 2]
        if fresh:
            ra, rb, d = _arms(x, R, a, b, local_a, local_b, anchor_offset, c)
            for k in range(3):
                arm_a[c, k] = ra[k]
                arm_b[c, k] = rb[k]
            gap[c] = normal[c, 0] * d[0] + normal[c, 1] * d[1] + normal[c, 2] * d[2]
        else:
            ra = (arm_a[c, 0], arm_a[c, 1], arm_a[c, 2])
            rb = (arm_b[c, 0], arm_b[c, 1], arm_b[c, 2])
        va, wa = _impulse_on(ma, Ia, ra, va, wa, -1.0, p0, p1, p2)
        vb, wb = _impulse_on(mb, Ib, rb, vb, wb, 1.0, p0, p1, p2)
    _store_pair(v, omega, cached_a, cached_b, va, wa, vb, wb)


@njit(**JIT, parallel=True)
def warm_start_kernel(order, bounds, body_a, body_b, normal, tangent1, tangent2, local_a, local_b, anchor_offset,
                      normal_impulse, tangent_impulse, x, R, inv_mass, I_inv, fresh,
                      # outputs
                      v, omega, arm_a, arm_b, gap):
    """Apply the accumulated impulses (normal and both friction directions) once, in the order
    ``order`` (C,) cut by ``bounds`` (P + 2,) as in ``solve_contacts_kernel``.

    The arms and n.d of each contact (``_arms``) at the current poses are cached in arm_a,
    arm_b (C, 3) and gap (C,): computed here when ``fresh`` (the first substep), else read from
    the last relax, which ran at the same poses. PERF: the biased solve reads them too, so
    ``_arms`` runs twice per substep instead of four times (same bits).
    """
    parts = bounds.shape[0] - 2
    if parts > 0:
        for p in prange(parts):
            _warm_start_range(bounds[p], bounds[p + 1], order, body_a, body_b, normal, tangent1, tangent2,
                              local_a, local_b, anchor_offset, normal_impulse, tangent_impulse, x, R, inv_mass, I_inv,
                              fresh, v, omega, arm_a, arm_b, gap)
    _warm_start_range(bounds[parts], bounds[parts + 1], order, body_a, body_b, normal, tangent1, tangent2, local_a,
                      local_b, anchor_offset, normal_impulse, tangent_impulse, x, R, inv_mass, I_inv, fresh, v, omega,
                      arm_a, arm_b, gap)


@njit(**JIT, inline="always")
def _load_body(v, omega, I_inv, i):
    """Body i's v (3 floats), omega (3) and world I^-1 (9, row by row), into registers."""
    return ((v[i, 0], v[i, 1], v[i, 2]), (omega[i, 0], omega[i, 1], omega[i, 2]),
            (I_inv[i, 0, 0], I_inv[i, 0, 1], I_inv[i, 0, 2], I_inv[i, 1, 0], I_inv[i, 1, 1], I_inv[i, 1, 2],
             I_inv[i, 2, 0], I_inv[i, 2, 1], I_inv[i, 2, 2]))


@njit(**JIT, inline="always")
def _store_body(v, omega, i, vi, wi):
    v[i, 0], v[i, 1], v[i, 2] = vi
    omega[i, 0], omega[i, 1], omega[i, 2] = wi


@njit(**JIT, inline="always")
def _no_pair():
    """The registers of ``_load_pair`` before any pair is loaded (bodies -1, all 0)."""
    z3 = (0.0, 0.0, 0.0)
    z9 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    return -1, -1, z3, z3, z9, 0.0, z3, z3, z9, 0.0


@njit(**JIT, inline="always")
def _load_pair(v, omega, I_inv, inv_mass, a, b):
    """Bodies a and b into registers: (va, wa, Ia, 1/ma, vb, wb, Ib, 1/mb) (``_load_body``)."""
    va, wa, Ia = _load_body(v, omega, I_inv, a)
    vb, wb, Ib = _load_body(v, omega, I_inv, b)
    return va, wa, Ia, inv_mass[a], vb, wb, Ib, inv_mass[b]


@njit(**JIT, inline="always")
def _store_pair(v, omega, a, b, va, wa, vb, wb):
    """Write the registers of the pair a, b back (a = -1: no pair loaded yet)."""
    if a >= 0:
        _store_body(v, omega, a, va, wa)
        _store_body(v, omega, b, vb, wb)


@njit(**JIT, inline="always")
def _impulse_on(inv_m, Ii, r, vi, wi, sign, p0, p1, p2):
    """vi, wi after the impulse sign * P at arm r (sign +-1: the same bits as ``_apply_impulse``)."""
    vi = (vi[0] + sign * (inv_m * p0), vi[1] + sign * (inv_m * p1), vi[2] + sign * (inv_m * p2))
    c0, c1, c2 = _cross(r[0], r[1], r[2], p0, p1, p2)
    wi = (wi[0] + sign * (Ii[0] * c0 + Ii[1] * c1 + Ii[2] * c2),
          wi[1] + sign * (Ii[3] * c0 + Ii[4] * c1 + Ii[5] * c2),
          wi[2] + sign * (Ii[6] * c0 + Ii[7] * c1 + Ii[8] * c2))
    return vi, wi


@njit(**JIT, inline="always")
def _angular_direction(Ii, r, d0, d1, d2):
    """(r x d, I^-1 (r x d)) (3 floats each) for a body with world I^-1 Ii (9, row by row): the
    angular part of a unit impulse along d at arm r. n.(w x r) = w.(r x n) reads a point's speed
    along n, and I^-1 (r x lambda n) = lambda I^-1 (r x n) is the turn an impulse lambda gives."""
    c0, c1, c2 = _cross(r[0], r[1], r[2], d0, d1, d2)
    return (c0, c1, c2), (Ii[0] * c0 + Ii[1] * c1 + Ii[2] * c2, Ii[3] * c0 + Ii[4] * c1 + Ii[5] * c2,
                          Ii[6] * c0 + Ii[7] * c1 + Ii[8] * c2)


@njit(**JIT, inline="always")
def _speed_along(va, wa, vb, wb, d0, d1, d2, ca, cb):
    """Relative speed of b's point over a's along d: d.(vb - va) + wb.(rb x d) - wa.(ra x d),
    with ca = ra x d, cb = rb x d (``_angular_direction``)."""
    return (d0 * (vb[0] - va[0]) + d1 * (vb[1] - va[1]) + d2 * (vb[2] - va[2])
            + (wb[0] * cb[0] + wb[1] * cb[1] + wb[2] * cb[2]) - (wa[0] * ca[0] + wa[1] * ca[1] + wa[2] * ca[2]))


@njit(**JIT, inline="always")
def _push(inv_m, vi, wi, j, d0, d1, d2, k):
    """vi, wi after an impulse j along d (unit) whose angular direction is k = I^-1 (r x d)."""
    return ((vi[0] + (inv_m * j) * d0, vi[1] + (inv_m * j) * d1, vi[2] + (inv_m * j) * d2),
            (wi[0] + j * k[0], wi[1] + j * k[1], wi[2] + j * k[2]))


@njit(**JIT, inline="always")
def _push2(inv_m, vi, wi, j1, j2, e0, e1, e2, f0, f1, f2, k1, k2):
    """vi, wi after impulses j1 along e and j2 along f (the two friction directions), with
    angular directions k1, k2 (``_push``)."""
    p0 = j1 * e0 + j2 * f0
    p1 = j1 * e1 + j2 * f1
    p2 = j1 * e2 + j2 * f2
    return ((vi[0] + inv_m * p0, vi[1] + inv_m * p1, vi[2] + inv_m * p2),
            (wi[0] + (j1 * k1[0] + j2 * k2[0]), wi[1] + (j1 * k1[1] + j2 * k2[1]), wi[2] + (j1 * k1[2] + j2 * k2[2])))


@njit(**JIT, inline="always")
def _mass_at_arms(mass, inv_ma, inv_mb, ca, ka, cb, kb):
    """A row's effective mass (kg) at the arms the relax has just read: ``mass`` as prepared, unless
    it exceeds 1 / k by more than ``MASS_DRIFT`` times, k = 1/ma + 1/mb + (ra x d).Ia^-1 (ra x d)
    + (rb x d).Ib^-1 (rb x d) (``inv_ma``, ``inv_mb``; ca = ra x d, ka = Ia^-1 ca, cb, kb:
    ``_angular_direction``); then 1 / k. Kept otherwise, to the bit."""
    k = inv_ma + inv_mb + (ca[0] * ka[0] + ca[1] * ka[1] + ca[2] * ka[2]) + (cb[0] * kb[0] + cb[1] * kb[1] + cb[2] * kb[2])
    if mass * k > MASS_DRIFT:
        return 1.0 / k
    return mass


@njit(**JIT, inline="always")
def normal_impulse_after(s, use_bias, soft_rate, mass_scale, impulse_scale, inv_h, contact_speed, mass, vn,
                         accumulated):
    """A contact's accumulated normal impulse (N s) after one solve of its row, at separation s (m),
    normal speed vn (m/s), effective mass ``mass`` (kg): s > 0 (speculative) lets the gap close in
    this substep and no more; s <= 0 with bias (``use_bias``) a soft spring (the contact's softness:
    bias rate, mass scale, impulse scale) pushes out at no more than ``contact_speed``; the relax
    (no bias) is rigid, and takes back push-out only (below). Shared by the free bodies' solve
    (``_solve_contact_range``) and the tree's (``contact_tree.solve_tree_contacts_kernel``)."""
    bias = 0.0
    scale = 1.0
    keep = 0.0
    if s > 0.0:
        bias = s * inv_h
    elif use_bias:
        bias = max(soft_rate * s, -contact_speed)
        scale = mass_scale
        keep = impulse_scale
    impulse = -mass * scale * (vn + bias) - keep * accumulated
    new_impulse = max(accumulated + impulse, 0.0)
    if not use_bias and s > 0.0 and accumulated == 0.0 and new_impulse > 0.0:
        # NOTE: Box2D's relax also brakes an open contact to vn = -s/h. That is not needed
        # here (the next substep's biased solve sees the gap before any position update)
        # and it slows a falling body before it lands: the step after has a smaller approach
        # speed and the bounce loses height (measured: apexes 3 and 4 of the bouncing ball
        # 1.6-1.9 % low), or the restitution pass bounces it off an open gap. The relax only
        # takes back push-out here. A contact that pushed in this substep is left free:
        # blocking any increase while its gap was open kept the second corner of an edge
        # landing from sharing the load once the first had closed (an edge impact turned
        # the box about the vertical; off the rigid impact's velocities by 3-15 %).
        new_impulse = accumulated
    return new_impulse


@njit(**JIT, inline="always")
def friction_impulses_after(old1, old2, mass1, mass2, slip1, slip2, limit):
    """A contact's accumulated friction impulses (N s) along its two tangents after one solve,
    against its slip (m/s) along them, each direction with its own effective mass (kg), within the
    disc of radius ``limit`` = mu times the normal impulse (isotropic Coulomb cone). Shared by the
    free bodies' solve and the tree's (``contact_tree.solve_tree_contacts_kernel``).

    Sticking (the impulse that stops the slip, old - mass * slip, inside the disc): that impulse.
    Sliding: the impulse on the disc's edge that opposes the slip it leaves (Coulomb's law, the
    maximum dissipation of the contact's own 2 x 2 problem with its diagonal masses). With the
    post-impulse slip s' = slip + (new - old) / mass (per direction), new = -limit s' / |s'| gives
    new_i = t_i limit / (limit + sigma mass_i), t the sticking impulse, for the sigma >= 0 (m/s:
    |s'|) that puts new on the edge: the root of psi(sigma) = 1 / |new(sigma)| - 1 / limit,
    increasing and concave, so that Newton's method from sigma = 0 climbs to it monotonically (the
    secular equation of a trust-region step, More and Sorensen 1983). Equal masses give sigma's
    factor to every direction alike: the radial clamp.

    NOTE: why: the radial clamp of old - mass * slip (Box2D's, Box3D's) points the sliding
    friction along diag(mass1, mass2) slip, not along the slip, where the tangents' masses differ
    (a box's corner: 0.25 and 0.56 kg for a 0.4 x 0.2 x 0.1 m box of 1 kg). The tangents are fixed
    in the world (``prepare_contacts_kernel``), so a box sliding at 30 or 45 degrees to them veered
    by 23-25 degrees and slowed 5.6-7.4 % less than mu g, and a block on an incline whose downhill
    direction lay between them slid 8 % too fast and drifted sideways (measured at dt 1/240 and
    1/960 alike). Aligning the first tangent with the slip (Bullet's velocity-dependent friction
    direction) was the other way out; it makes the tangents, and the warm start carried in them,
    depend on the velocity."""
    new1 = old1 - mass1 * slip1
    new2 = old2 - mass2 * slip2
    mag2 = new1 * new1 + new2 * new2
    if mag2 > limit * limit:
        if limit <= 0.0 or mass1 == mass2:  # the radial clamp is then the exact answer (and its bits)
            scale = limit / math.sqrt(mag2)
            return new1 * scale, new2 * scale
        # a start left of the root, near it: with the larger mass for both directions the edge
        # is reached at (|t| - limit) / max(mass) (the radial case's exact sigma), no later
        sigma = (math.sqrt(mag2) - limit) / max(mass1, mass2)
        for _ in range(FRICTION_NEWTON_STEPS):
            d1 = limit + sigma * mass1
            d2 = limit + sigma * mass2
            u1 = new1 / d1
            u2 = new2 / d2
            q = u1 * u1 + u2 * u2  # |new(sigma)|^2 / limit^2
            root = math.sqrt(q)
            psi = 1.0 / root - 1.0
            if psi >= -FRICTION_NEWTON_TOLERANCE:
                break
            dpsi = (u1 * u1 * mass1 / d1 + u2 * u2 * mass2 / d2) / (q * root)
            if dpsi <= 0.0:  # a tree row of no response (mass 0) holding the whole slip: no root
                break
            sigma -= psi / dpsi
        d1 = limit + sigma * mass1
        d2 = limit + sigma * mass2
        u1 = new1 / d1
        u2 = new2 / d2
        # on the edge to the bit's worth: the last Newton step's rounding scaled away
        scale = limit / math.sqrt(u1 * u1 + u2 * u2)
        return u1 * scale, u2 * scale
    return new1, new2


@njit(**JIT)
def _solve_contact_range(lo, hi, order, body_a, body_b, normal, tangent1, tangent2, local_a, local_b, anchor_offset,
                         separation, normal_mass, tangent_mass, soft, friction, surface_target, x, R, inv_mass, I_inv, inv_h,
                         contact_speed, use_bias, v, omega, normal_impulse, tangent_impulse, max_normal_impulse,
                         relative_velocity, last_normal_speed, arm_a, arm_b, gap):
    """Contacts order[lo:hi] of ``solve_contacts_kernel``, a manifold at a time (the consecutive
    contacts of one pair of bodies): the normal impulses of all its points, then their friction
    (the order of Box2D v3 and Catto's Solver2D: non-penetration, then friction).

    A first pass that changes some point's speed by more than ``MANIFOLD_IMPACT_SPEED``, or in
    the relax pushes a point that came in approaching faster than ``MANIFOLD_APPROACH_SPEED`` (an
    impact), is followed by more, until no change passes ``MANIFOLD_PASS_SPEED``. NOTE: why: one
    Gauss-Seidel pass over the four corners of a box landing flat stops the first corner alone,
    which tips the box; friction at that corner then pushes it sideways. A cube landing flat at
    20 m/s with restitution 0 came out sliding at 2.1 m/s and spinning at 2.6 rad/s about the
    vertical (which symmetry forbids). The passes converge by ~13x each on that manifold (its
    4 x 4 K is singular, but the velocities converge), so an impact is solved as one
    (tests/physics/test_contact_impacts.py: the rigid-impact velocities of an edge landing to
    1 %). The friction comes after the normals so that it reads the velocities they leave, as
    Box2D's; the passes take both, since friction at an edge below the centre turns the box and
    changes the normal speeds.

    PERF: the velocities of the two bodies stay in registers while consecutive contacts join the
    same pair (the points of a manifold): 14 % faster than reading and writing v, omega per
    impulse (large pyramid, measured). Each point's angular directions r x d and I^-1 (r x d)
    (``_angular_direction``) are computed from its arms before its speed is read, so that only
    the short chain speed -> impulse -> velocities waits on the previous point: 10-18 % faster a
    sweep than the cross product and I^-1 product of each impulse after it is known (A/B in one
    process on the large pyramid's captured contacts, 1 thread: 78-87 vs 92-96 ns a point biased,
    90-94 vs 103-115 ns in the relax). Dead ends: friction's moment on the chain (r x the summed
    2-D impulse, then one I^-1 product: fewer flops) kept only 3-6 %; in the warm start, one
    I^-1 product per manifold instead of per contact was no faster (it waits on its reads); two
    body-disjoint manifolds (one from each half of the range) solved side by side, point by point,
    which gives the same bits as solving them one after the other: 2x slower, written with
    per-point functions that Numba inlines, because each inlined call took a reference count on
    every array it was passed (191 increfs in this function's IR); writing it out by hand would
    copy the per-point code three times.
    """
    cached_a, cached_b, va, wa, Ia, ma, vb, wb, Ib, mb = _no_pair()
    i = lo
    while i < hi:
        c = order[i]
        a = body_a[c]
        b = body_b[c]
        if a != cached_a or b != cached_b:  # a new pair: store the last pair's velocities, load this one's
            _store_pair(v, omega, cached_a, cached_b, va, wa, vb, wb)
            cached_a = a
            cached_b = b
            va, wa, Ia, ma, vb, wb, Ib, mb = _load_pair(v, omega, I_inv, inv_mass, a, b)
        end = i + 1  # the manifold: order[i:end], the same pair
        while end < hi and body_a[order[end]] == a and body_b[order[end]] == b:
            end += 1
        va0, wa0, vb0, wb0 = va, wa, vb, wb  # before the manifold's impulses: its points' approach speeds
        for sweep in range(MANIFOLD_PASSES):
            again = False
            # an impact starts the passes; they go on until the manifold has converged
            speed = MANIFOLD_IMPACT_SPEED if sweep == 0 else MANIFOLD_PASS_SPEED
            for k in range(i, end):
                c = order[k]
                n0, n1, n2 = normal[c, 0], normal[c, 1], normal[c, 2]
                if use_bias or sweep > 0:  # the poses of the warm start (or of this relax's first pass)
                    ra = (arm_a[c, 0], arm_a[c, 1], arm_a[c, 2])
                    rb = (arm_b[c, 0], arm_b[c, 1], arm_b[c, 2])
                else:  # the relax, after the positions moved: new arms, cached for the next warm start
                    ra, rb, d = _arms(x, R, a, b, local_a, local_b, anchor_offset, c)
                    for q in range(3):
                        arm_a[c, q] = ra[q]
                        arm_b[c, q] = rb[q]
                    gap[c] = n0 * d[0] + n1 * d[1] + n2 * d[2]
                s = separation[c] + gap[c]
                # PERF: the angular directions depend on the arms alone, not on the velocities the
                # previous point just changed: computed off the chain point -> impulse -> velocities
                ca, ka = _angular_direction(Ia, ra, n0, n1, n2)
                cb, kb = _angular_direction(Ib, rb, n0, n1, n2)
                if not use_bias and sweep == 0:  # arms just read at the moved poses: is the mass still theirs?
                    normal_mass[c] = _mass_at_arms(normal_mass[c], ma, mb, ca, ka, cb, kb)
                vn = _speed_along(va, wa, vb, wb, n0, n1, n2, ca, cb)
                new_impulse = normal_impulse_after(s, use_bias, soft[c, 0], soft[c, 1], soft[c, 2], inv_h,
                                                   contact_speed, normal_mass[c], vn, normal_impulse[c])
                if new_impulse > 0.0:
                    # the approach speed before any point of the manifold pushed: the same for
                    # the four corners of a box landing flat, which then bounces without turning.
                    # NOTE: why not test vn (this point's speed now) against relative_velocity: a
                    # corner after the first reads a speed the first corner's push has already
                    # lowered, and kept the pre-step speed; a unit cube landing flat at 5.4 m/s
                    # bounced (e = 0.8) off corners told 5.4249 and one 5.3955 m/s, and left
                    # turning at 0.015 rad/s (frictionless), its next landings tilted.
                    u = -_speed_along(va0, wa0, vb0, wb0, n0, n1, n2, ca, cb)
                    if -u < relative_velocity[c]:
                        w0 = -last_normal_speed[c]
                        if s > 0.0 and w0 > 0.0 and u > w0:
                            accel = (u - w0) * inv_h
                            u = min(math.sqrt(w0 * w0 + 2.0 * accel * s), u)
                        relative_velocity[c] = min(-u, relative_velocity[c])
                impulse = new_impulse - normal_impulse[c]
                normal_impulse[c] = new_impulse
                max_normal_impulse[c] = max(max_normal_impulse[c], impulse)
                if abs(impulse) > speed * normal_mass[c]:
                    again = True
                if not use_bias and sweep == 0 and impulse > 0.0 and last_normal_speed[c] < -MANIFOLD_APPROACH_SPEED:
                    again = True  # it came in approaching (read before the line below overwrites it)
                if not use_bias:
                    # the normal speed this substep ends with: the next substep's speed before its kick
                    last_normal_speed[c] = vn + (impulse / normal_mass[c] if normal_mass[c] > 0.0 else 0.0)
                va, wa = _push(ma, va, wa, -impulse, n0, n1, n2, ka)
                vb, wb = _push(mb, vb, wb, impulse, n0, n1, n2, kb)

            # Coulomb friction: each direction with its own effective mass, then the accumulated
            # 2-vector clamped to the disc of radius mu * normal impulse (isotropic friction cone)
            for k in range(i, end):
                c = order[k]
                ra = (arm_a[c, 0], arm_a[c, 1], arm_a[c, 2])
                rb = (arm_b[c, 0], arm_b[c, 1], arm_b[c, 2])
                e0, e1, e2 = tangent1[c, 0], tangent1[c, 1], tangent1[c, 2]
                f0, f1, f2 = tangent2[c, 0], tangent2[c, 1], tangent2[c, 2]
                ca1, ka1 = _angular_direction(Ia, ra, e0, e1, e2)
                cb1, kb1 = _angular_direction(Ib, rb, e0, e1, e2)
                ca2, ka2 = _angular_direction(Ia, ra, f0, f1, f2)
                cb2, kb2 = _angular_direction(Ib, rb, f0, f1, f2)
                if not use_bias and sweep == 0:  # the friction rows' masses likewise (MASS_DRIFT)
                    tangent_mass[c, 0] = _mass_at_arms(tangent_mass[c, 0], ma, mb, ca1, ka1, cb1, kb1)
                    tangent_mass[c, 1] = _mass_at_arms(tangent_mass[c, 1], ma, mb, ca2, ka2, cb2, kb2)
                # the slip of the two surfaces: less the speed their own surface velocities give
                # (a conveyor belt's); x - 0.0 is x to the bit, so a world without keeps its bits
                vt1 = _speed_along(va, wa, vb, wb, e0, e1, e2, ca1, cb1) - surface_target[c, 0]
                vt2 = _speed_along(va, wa, vb, wb, f0, f1, f2, ca2, cb2) - surface_target[c, 1]
                old1 = tangent_impulse[c, 0]
                old2 = tangent_impulse[c, 1]
                new1, new2 = friction_impulses_after(old1, old2, tangent_mass[c, 0], tangent_mass[c, 1], vt1, vt2,
                                                     friction[c] * normal_impulse[c])
                tangent_impulse[c, 0] = new1
                tangent_impulse[c, 1] = new2
                j1 = new1 - old1
                j2 = new2 - old2
                if abs(j1) > speed * tangent_mass[c, 0] or abs(j2) > speed * tangent_mass[c, 1]:
                    again = True
                va, wa = _push2(ma, va, wa, -j1, -j2, e0, e1, e2, f0, f1, f2, ka1, ka2)
                vb, wb = _push2(mb, vb, wb, j1, j2, e0, e1, e2, f0, f1, f2, kb1, kb2)
            if not again:
                break
        i = end
    _store_pair(v, omega, cached_a, cached_b, va, wa, vb, wb)


@njit(**JIT)
def surface_target_kernel(body_a, body_b, tangent1, tangent2, R, surface_velocity,
                          # outputs
                          surface_target):
    """Per contact, the tangential speed t . (R_a s_a - R_b s_b) (m/s) along ``tangent1`` and
    ``tangent2`` (C, 3), s (N, 3) the bodies' ``surface_velocity`` (body frame, m/s): the slip
    friction drives to zero is then the bodies' relative tangential speed less it (Box2D's
    ``tangentSpeed`` of a conveyor belt's shape, as a vector: each contact takes its part in
    its tangent plane)."""
    for c in range(body_a.shape[0]):
        a = body_a[c]
        b = body_b[c]
        d = np.zeros(3)
        for k in range(3):
            d[k] = (R[a, k, 0] * surface_velocity[a, 0] + R[a, k, 1] * surface_velocity[a, 1]
                    + R[a, k, 2] * surface_velocity[a, 2]) \
                - (R[b, k, 0] * surface_velocity[b, 0] + R[b, k, 1] * surface_velocity[b, 1]
                   + R[b, k, 2] * surface_velocity[b, 2])
        surface_target[c, 0] = tangent1[c, 0] * d[0] + tangent1[c, 1] * d[1] + tangent1[c, 2] * d[2]
        surface_target[c, 1] = tangent2[c, 0] * d[0] + tangent2[c, 1] * d[1] + tangent2[c, 2] * d[2]


@njit(**JIT, parallel=True)  # PERF: the parallel pipeline also drops the inlined body's per-contact refcounts
def solve_contacts_kernel(order, bounds, body_a, body_b, normal, tangent1, tangent2, local_a, local_b,
                          anchor_offset, separation, normal_mass, tangent_mass, soft, friction, surface_target, x, R,
                          inv_mass, I_inv,
                          inv_h, contact_speed, use_bias,
                          # outputs
                          v, omega, normal_impulse, tangent_impulse, max_normal_impulse, relative_velocity,
                          last_normal_speed, arm_a, arm_b, gap):
    """One Gauss-Seidel sweep: per manifold the normal impulses (soft when ``use_bias``), then the
    friction; an impact's manifold passed over until it converges (``_solve_contact_range``).

    The contacts are taken in the order ``order`` (C,), cut by ``bounds`` (P + 2,) into P
    partitions, order[bounds[p]:bounds[p + 1]], and the rest, order[bounds[P]:bounds[P + 1]]
    (``partition_pairs_kernel``). The partitions are swept side by side: no two share a
    moving body, so each writes only its own bodies' v, omega and its own contacts' rows (fixed
    bodies are written too, with 0 * impulse: the value read). The rest, contacts that join two
    partitions, follow on this thread. The order depends on the partitions, never on the
    threads, so the bits are the same on any number of threads. P = 0 with order = 0..C-1 is
    the plain sweep in the narrowphase's order.

    The separation is followed as the bodies move within the step: s = s0 + n.(d - d0),
    d = (xB + RB lB + oB) - (xA + RA lA + oA) (``contact_anchor._arms``), with d0 = 0 where both
    anchors start at the contact point (for deep overlaps and round sides they do not:
    ``separation`` here is ``separation_base`` = s0 - n.d0, ``prepare_contacts_kernel``).
    ``surface_target`` (C, 2) m/s: the tangential slip friction drives each contact to
    (``surface_target_kernel``; zeros but on a conveyor belt).
    s > 0 (speculative): the bias lets the gap close in exactly this substep and no more.
    s <= 0 with bias: a soft spring pushes out at no more than ``contact_speed``.
    Relax (no bias): rigid, so the push-out velocity is taken back out and adds no energy.

    ``relative_velocity`` (the approach speed restitution reflects) is lowered to the impact
    speed of a solve that pushes. Box2D keeps the pre-step speed only; I measured that this
    loses the gravity gained within the step before impact (a sphere dropped 2 m with e = 0.8,
    dt 1/60 s: second apex 4 % low). The normal speed seen by the pushing solve, after the
    substep's kick, overshoots instead (apexes 0.6-1 % high at dt 1/240 s): the contact closes
    part way through the substep. So when the gap s is still open, the impact speed is taken
    from the approach speed w0 before the kick (``last_normal_speed``) and the kick's
    acceleration a = (w1 - w0) / h over the gap: u = sqrt(w0^2 + 2 a s), between w0 and w1.
    """
    parts = bounds.shape[0] - 2
    if parts > 0:
        for p in prange(parts):
            _solve_contact_range(bounds[p], bounds[p + 1], order, body_a, body_b, normal, tangent1, tangent2, local_a,
                                 local_b, anchor_offset, separation, normal_mass, tangent_mass, soft, friction,
                                 surface_target, x, R, inv_mass, I_inv, inv_h, contact_speed, use_bias, v, omega,
                                 normal_impulse,
                                 tangent_impulse, max_normal_impulse, relative_velocity, last_normal_speed, arm_a,
                                 arm_b, gap)
    _solve_contact_range(bounds[parts], bounds[parts + 1], order, body_a, body_b, normal, tangent1, tangent2, local_a,
                         local_b, anchor_offset, separation, normal_mass, tangent_mass, soft, friction, surface_target,
                         x, R, inv_mass, I_inv, inv_h, contact_speed, use_bias, v, omega, normal_impulse, tangent_impulse,
                         max_normal_impulse, relative_velocity, last_normal_speed, arm_a, arm_b, gap)


@njit(**JIT, inline="always")
def bounces(e, approach, pushed, threshold):
    """Whether the restitution pass acts on a contact: restitution ``e`` > 0, a pre-step approach
    speed ``approach`` (m/s, < 0 approaching) beyond ``threshold``, and a push this step (its
    largest normal impulse ``pushed``, N s). Shared by the free bodies' pass and the tree's
    (``contact_tree.restitution_tree_kernel``), for their normals and their friction alike."""
    return e != 0.0 and not approach > -threshold and pushed != 0.0


@njit(**JIT)
def apply_restitution_kernel(body_a, body_b, normal, tangent1, tangent2, local_a, local_b, normal_mass, tangent_mass,
                             restitution, friction, surface_target, relative_velocity, max_normal_impulse, threshold,
                             arm_a, arm_b, inv_mass, I_inv, skip,
                             # outputs
                             v, omega, normal_impulse, tangent_impulse):
    """After the substeps: where the pre-step approach speed was above ``threshold``
    and the contact pushed this step, set the normal speed to -e times the approach speed, and
    let friction act over the bounce's impulse too: the contact's friction solved again within mu
    times its normal impulse with the bounce's added (``friction_impulses_after``).
    Contacts with ``skip`` (C,) set are left (those of jointed bodies: ``contact_tree``'s).

    A manifold (the consecutive contacts of one pair) is passed over, its normals, until no
    impulse changes its point's speed by more than ``MANIFOLD_PASS_SPEED``, at most
    ``MANIFOLD_PASSES`` times; then its friction the same way.
    NOTE: why: one pass over a cube bouncing flat (e = 0.5, 20 m/s) left it spinning at
    4.2 rad/s and 1.8 % slow, the corners kicked one after the other (as in the solve).
    NOTE: why the friction: Coulomb's law holds over the whole impact, the restitution phase
    too (the friction impulse up to mu (1 + e) times the compression's normal impulse). A
    normal-only pass (Box2D's) capped it at mu times the compression's: a ball striking a plane at
    3 m/s down and 2 m/s across (e = 0.5, mu = 0.1) left at 1.70 m/s spinning at 7.5 rad/s instead
    of 1.55 m/s and 11.25 rad/s, and with e = 1 still slipping where it should leave rolling
    (measured at dt 1/240 and 1/960 alike).
    NOTE: why the friction after the normals, not with them: in an off-centre impact friction
    changes the normal speeds; normals passed again to -e times the approach speed then add
    energy (Kane and Levinson's paradox of Newton's restitution with friction): two ellipsoids
    meeting off-centre with e = 1, mu = 0.5 gained 1.7 % of their kinetic energy. Each friction
    solve on its own takes energy out (its impulses stop or oppose a slip), so the pass as a whole
    cannot add any; the normal speeds it leaves are the friction's to change."""
    n = body_a.shape[0]
    i = 0
    while i < n:
        a = body_a[i]
        b = body_b[i]
        end = i + 1
        while end < n and body_a[end] == a and body_b[end] == b:
            end += 1
        for _ in range(MANIFOLD_PASSES):
            again = False
            for c in range(i, end):
                e = restitution[c]
                if skip[c] or not bounces(e, relative_velocity[c], max_normal_impulse[c], threshold):
                    continue
                ra = (arm_a[c, 0], arm_a[c, 1], arm_a[c, 2])  # the last relax's, at these poses
                rb = (arm_b[c, 0], arm_b[c, 1], arm_b[c, 2])
                n0, n1, n2 = normal[c, 0], normal[c, 1], normal[c, 2]
                va0, va1, va2 = _point_velocity(v, omega, a, ra)
                vb0, vb1, vb2 = _point_velocity(v, omega, b, rb)
                vn = n0 * (vb0 - va0) + n1 * (vb1 - va1) + n2 * (vb2 - va2)
                impulse = -normal_mass[c] * (vn + e * relative_velocity[c])
                new_impulse = max(normal_impulse[c] + impulse, 0.0)
                impulse = new_impulse - normal_impulse[c]
                normal_impulse[c] = new_impulse
                if abs(impulse) > MANIFOLD_PASS_SPEED * normal_mass[c]:
                    again = True
                _apply_impulse(v, omega, inv_mass, I_inv, a, b, ra, rb, impulse * n0, impulse * n1, impulse * n2)
            if not again:
                break
        for _ in range(MANIFOLD_PASSES):
            again = False
            for c in range(i, end):
                if (skip[c] or friction[c] == 0.0
                        or not bounces(restitution[c], relative_velocity[c], max_normal_impulse[c], threshold)):
                    continue
                ra = (arm_a[c, 0], arm_a[c, 1], arm_a[c, 2])
                rb = (arm_b[c, 0], arm_b[c, 1], arm_b[c, 2])
                va0, va1, va2 = _point_velocity(v, omega, a, ra)
                vb0, vb1, vb2 = _point_velocity(v, omega, b, rb)
                e0, e1, e2 = tangent1[c, 0], tangent1[c, 1], tangent1[c, 2]
                f0, f1, f2 = tangent2[c, 0], tangent2[c, 1], tangent2[c, 2]
                vt1 = e0 * (vb0 - va0) + e1 * (vb1 - va1) + e2 * (vb2 - va2) - surface_target[c, 0]
                vt2 = f0 * (vb0 - va0) + f1 * (vb1 - va1) + f2 * (vb2 - va2) - surface_target[c, 1]
                old1 = tangent_impulse[c, 0]
                old2 = tangent_impulse[c, 1]
                new1, new2 = friction_impulses_after(old1, old2, tangent_mass[c, 0], tangent_mass[c, 1], vt1, vt2,
                                                     friction[c] * normal_impulse[c])
                tangent_impulse[c, 0] = new1
                tangent_impulse[c, 1] = new2
                j1 = new1 - old1
                j2 = new2 - old2
                if abs(j1) > MANIFOLD_PASS_SPEED * tangent_mass[c, 0] or abs(j2) > MANIFOLD_PASS_SPEED * tangent_mass[c, 1]:
                    again = True
                _apply_impulse(v, omega, inv_mass, I_inv, a, b, ra, rb, j1 * e0 + j2 * f0, j1 * e1 + j2 * f1,
                               j1 * e2 + j2 * f2)
            if not again:
                break
        i = end


@njit(**JIT)
def store_impulses_kernel(key, normal_impulse, tangent_impulse, tangent1, tangent2,
                          # outputs
                          old_key, old_normal_impulse, old_friction_impulse):
    """Keep each contact's key, normal impulse and friction impulse (as a world vector, so that
    the next step's tangent basis may differ) for the next step's warm start."""
    for c in range(key.shape[0]):
        old_key[c] = key[c]
        old_normal_impulse[c] = normal_impulse[c]
        for k in range(3):
            old_friction_impulse[c, k] = tangent_impulse[c, 0] * tangent1[c, k] + tangent_impulse[c, 1] * tangent2[c, k]
