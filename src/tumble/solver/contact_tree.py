"""Contacts of jointed bodies solved through the joint tree: each contact row's response is the
articulated bodies', not the free body's.

With the tree method (``JointSettings.method = "tree"``) the joints' rigid rows are solved
exactly (``joint_tree``), and a contact solved with the free bodies' masses then disagrees with
them: the contact stops its own body, the next joint solve shares that change out over the
tree, the contact pushes again. One pass of each per substep does not converge to the pair's
fixed point; with armature (a motor's rotor inertia, Gymnasium's ant and humanoid) the two
settle into a cycle: the ant resting on its hips oscillated at about 3e-3 rad/s, the humanoid
lying on its arm at 0.13 rad/s (MuJoCo's 0.01), and repeating the two solves within a substep
took 40 passes to reach rest (measured, session 32; docs/joints.md).

Here a contact that touches a body of the joint tree is solved as a row of the whole tree
(Rapier's multibody contacts, PhysX's articulations): its response M_art^-1 J^T, the change of
every velocity of the tree (and of every joint's impulse) under a unit impulse along the row,
is one forward and back substitution on the tree's factors (``joint_tree._substitute``: the
unit impulse on the free bodies, then the exact joint solve that follows it), its effective
mass 1 / (J M_art^-1 J^T). Applying an impulse then moves the whole tree at once, so the
velocities stay consistent with the joints and the contact sees the inertia behind its body.

The responses are taken once a step (on the factors of the first substep's joint solve, at the
arms of the step's start), as Rapier takes its multibody Jacobians once a step; within the step
the arms and joints move a little, and the joints' solves of the later substeps take the
difference up.

Arrays, for the A contacts of this step that touch a tree (``contacts`` (A,), indices into the
contact solver's rows, in its sweep order) and their 3 A rows (contact q: 3 q the normal,
3 q + 1, 3 q + 2 the two friction directions ``tangent1``, ``tangent2``):

- ``slot_count`` (3A,): how many slots row r has; ``slot_ref`` (3A, S): body i >= 0 or joint
  -(j + 1) per slot; ``slot_resp`` (3A, S, 8): per unit impulse, a body's (dv (m/s), dw (rad/s),
  0, 0) or a joint's (linear impulse (N s), angular impulse (N m s), ``A_EQUAL``, ``A_ARMATURE``
  axial impulses), world frame;
- ``row_mass`` (3A,): 1 / (J M_art^-1 J^T) (kg for the rows' unit directions).

Tree layout (``JointSolver._build_tree``): ``body_node`` (N,) each moving body's node (-1: not in
the tree), ``node_tree`` (n,) its tree, ``tree_lo``, ``tree_hi`` (T,) each tree's node range (its
nodes were made parents first, so ``node_order[n - hi:n - lo]`` is the tree leaves first).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..math3d import JIT
from .contact_anchor import _arms
from .contact_solve import MANIFOLD_PASS_SPEED, MANIFOLD_PASSES, bounces, friction_impulses_after, normal_impulse_after
from .joint_math import _cross, _scale
from .joint_tree import apply_row_response, bucket_by_group, movable, tree_row


@njit(**JIT)
def tree_contact_responses_kernel(qs, contacts, body_a, body_b, normal, tangent1, tangent2, arm_a, arm_b, inv_mass,
                                  I_inv, body_node, node_tree, tree_lo, tree_hi, node_order, node_joint, node_body,
                                  node_parent, joint_type, joint_a, joint_b, param, Ja, Jb, nrow, Dinv, H_up, W,
                                  y, sol, work, no_skip,
                                  # outputs
                                  slot_count, slot_ref, slot_resp, row_mass):
    """Each row's response through the tree and its effective mass (the module docstring's arrays;
    ``joint_tree.tree_row``), on the factors ``joint_tree.tree_factor_kernel`` made at the current
    poses (``Ja``, ``Jb``, ``nrow``, ``Dinv``, ``H_up``, ``W``); ``y``, ``sol`` (n, 6), ``work``
    (6, 6) scratch, ``no_skip`` (n,) all False. The listed contacts at positions ``qs`` (all, or one
    joint group's: ``tree_contact_responses_groups_kernel``)."""
    for idx in range(qs.shape[0]):
        q = qs[idx]
        c = contacts[q]
        a = body_a[c]
        b = body_b[c]
        ra = (arm_a[c, 0], arm_a[c, 1], arm_a[c, 2])
        rb = (arm_b[c, 0], arm_b[c, 1], arm_b[c, 2])
        for d in range(3):
            if d == 0:
                u = (normal[c, 0], normal[c, 1], normal[c, 2])
            elif d == 1:
                u = (tangent1[c, 0], tangent1[c, 1], tangent1[c, 2])
            else:
                u = (tangent2[c, 0], tangent2[c, 1], tangent2[c, 2])
            # the row's Jacobian: -u at a's arm, +u at b's
            row_mass[3 * q + d] = tree_row(3 * q + d, a, b, _scale(-1.0, u), _scale(-1.0, _cross(ra, u)), u,
                                           _cross(rb, u), inv_mass, I_inv, body_node, node_tree, tree_lo, tree_hi,
                                           node_order, node_joint, node_body, node_parent, joint_type, joint_a,
                                           joint_b, param, Ja, Jb, nrow, Dinv, H_up, W, y, sol, work, no_skip,
                                           slot_count, slot_ref, slot_resp)


@njit(**JIT, parallel=True)
def tree_contact_responses_groups_kernel(group_start, group_q, group_work, contacts, body_a, body_b, normal,
                                         tangent1, tangent2, arm_a, arm_b, inv_mass, I_inv, body_node, node_tree,
                                         tree_lo, tree_hi, node_order, node_joint, node_body, node_parent,
                                         joint_type, joint_a, joint_b, param, Ja, Jb, nrow, Dinv, H_up, W, y, sol,
                                         no_skip,
                                         # outputs
                                         slot_count, slot_ref, slot_resp, row_mass):
    """``tree_contact_responses_kernel`` with the contacts of each joint group (``group_contacts_kernel``)
    side by side on the threads, each group's with its own ``group_work`` (G, 6, 6): the same rows."""
    for g in prange(group_start.shape[0] - 1):
        tree_contact_responses_kernel(group_q[group_start[g]:group_start[g + 1]], contacts, body_a, body_b, normal,
                                      tangent1, tangent2, arm_a, arm_b, inv_mass, I_inv, body_node, node_tree,
                                      tree_lo, tree_hi, node_order, node_joint, node_body, node_parent, joint_type,
                                      joint_a, joint_b, param, Ja, Jb, nrow, Dinv, H_up, W, y, sol, group_work[g],
                                      no_skip, slot_count, slot_ref, slot_resp, row_mass)


@njit(**JIT)
def _speed(v, omega, a, b, ra, rb, u):
    """The speed of b's point over a's along u (m/s)."""
    s = 0.0
    wa = (omega[a, 0], omega[a, 1], omega[a, 2])
    wb = (omega[b, 0], omega[b, 1], omega[b, 2])
    pa = (v[a, 0] + wa[1] * ra[2] - wa[2] * ra[1], v[a, 1] + wa[2] * ra[0] - wa[0] * ra[2],
          v[a, 2] + wa[0] * ra[1] - wa[1] * ra[0])
    pb = (v[b, 0] + wb[1] * rb[2] - wb[2] * rb[1], v[b, 1] + wb[2] * rb[0] - wb[0] * rb[2],
          v[b, 2] + wb[0] * rb[1] - wb[1] * rb[0])
    for e in range(3):
        s += u[e] * (pb[e] - pa[e])
    return s


@njit(**JIT)
def solve_tree_contacts_kernel(qs, contacts, body_a, body_b, normal, tangent1, tangent2, local_a, local_b,
                               anchor_offset, separation, soft, friction, surface_target, x, R, inv_h, contact_speed,
                               use_bias, slot_count, slot_ref, slot_resp, row_mass,
                               # outputs
                               v, omega, linear_impulse, angular_impulse, axial_impulse, normal_impulse,
                               tangent_impulse, max_normal_impulse, relative_velocity, last_normal_speed, arm_a,
                               arm_b, gap):
    """One Gauss-Seidel sweep over the contacts of jointed bodies, each row through the tree (the
    module docstring): per contact the normal impulse (soft when ``use_bias``), then the friction,
    with the contact solve's rules (``contact_solve.solve_contacts_kernel``: the speculative gap,
    the soft push-out capped at ``contact_speed``, the rigid relax that takes the push-out back,
    the approach speed for restitution, Coulomb's disc) and its arrays. The relax reads the arms
    at the moved poses (and caches them, as that kernel does). The listed contacts at positions ``qs``
    in that order (all, or one joint group's: ``solve_tree_contacts_groups_kernel``)."""
    for idx in range(qs.shape[0]):
        q = qs[idx]
        c = contacts[q]
        a = body_a[c]
        b = body_b[c]
        if use_bias:
            ra = (arm_a[c, 0], arm_a[c, 1], arm_a[c, 2])
            rb = (arm_b[c, 0], arm_b[c, 1], arm_b[c, 2])
        else:
            ra, rb, dd = _arms(x, R, a, b, local_a, local_b, anchor_offset, c)
            for e in range(3):
                arm_a[c, e] = ra[e]
                arm_b[c, e] = rb[e]
            gap[c] = normal[c, 0] * dd[0] + normal[c, 1] * dd[1] + normal[c, 2] * dd[2]
        n = (normal[c, 0], normal[c, 1], normal[c, 2])
        s = separation[c] + gap[c]
        mass = row_mass[3 * q]
        vn = _speed(v, omega, a, b, ra, rb, n)
        new_impulse = normal_impulse_after(s, use_bias, soft[c, 0], soft[c, 1], soft[c, 2], inv_h, contact_speed,
                                           mass, vn, normal_impulse[c])
        if new_impulse > 0.0 and vn < relative_velocity[c]:
            u = -vn  # the approach speed restitution reflects, as in _solve_contact_range
            w0 = -last_normal_speed[c]
            if s > 0.0 and w0 > 0.0 and u > w0:
                u = min(math.sqrt(w0 * w0 + 2.0 * ((u - w0) * inv_h) * s), u)
            relative_velocity[c] = min(-u, relative_velocity[c])
        impulse = new_impulse - normal_impulse[c]
        normal_impulse[c] = new_impulse
        max_normal_impulse[c] = max(max_normal_impulse[c], impulse)
        if not use_bias:
            last_normal_speed[c] = vn + (impulse / mass if mass > 0.0 else 0.0)
        apply_row_response(3 * q, impulse, slot_count[3 * q], slot_ref, slot_resp, v, omega, linear_impulse,
                           angular_impulse, axial_impulse)
        # Coulomb friction: each direction with its own mass, the 2-vector clamped to mu times the normal impulse
        t1 = (tangent1[c, 0], tangent1[c, 1], tangent1[c, 2])
        t2 = (tangent2[c, 0], tangent2[c, 1], tangent2[c, 2])
        vt1 = _speed(v, omega, a, b, ra, rb, t1) - surface_target[c, 0]
        vt2 = _speed(v, omega, a, b, ra, rb, t2) - surface_target[c, 1]
        old1 = tangent_impulse[c, 0]
        old2 = tangent_impulse[c, 1]
        new1, new2 = friction_impulses_after(old1, old2, row_mass[3 * q + 1], row_mass[3 * q + 2], vt1, vt2,
                                             friction[c] * normal_impulse[c])
        tangent_impulse[c, 0] = new1
        tangent_impulse[c, 1] = new2
        apply_row_response(3 * q + 1, new1 - old1, slot_count[3 * q + 1], slot_ref, slot_resp, v, omega,
                           linear_impulse, angular_impulse, axial_impulse)
        apply_row_response(3 * q + 2, new2 - old2, slot_count[3 * q + 2], slot_ref, slot_resp, v, omega,
                           linear_impulse, angular_impulse, axial_impulse)


@njit(**JIT, parallel=True)
def solve_tree_contacts_groups_kernel(group_start, group_q, contacts, body_a, body_b, normal, tangent1, tangent2,
                                      local_a, local_b, anchor_offset, separation, soft, friction, surface_target, x,
                                      R, inv_h, contact_speed, use_bias, slot_count, slot_ref, slot_resp, row_mass,
                                      # outputs
                                      v, omega, linear_impulse, angular_impulse, axial_impulse, normal_impulse,
                                      tangent_impulse, max_normal_impulse, relative_velocity, last_normal_speed,
                                      arm_a, arm_b, gap):
    """``solve_tree_contacts_kernel`` with the contacts of each joint group side by side on the threads
    (``group_contacts_kernel``), each group's in the listed order: the same sweep."""
    for g in prange(group_start.shape[0] - 1):
        solve_tree_contacts_kernel(group_q[group_start[g]:group_start[g + 1]], contacts, body_a, body_b, normal,
                                   tangent1, tangent2, local_a, local_b, anchor_offset, separation, soft, friction,
                                   surface_target, x, R, inv_h, contact_speed, use_bias, slot_count, slot_ref,
                                   slot_resp, row_mass, v, omega, linear_impulse, angular_impulse, axial_impulse,
                                   normal_impulse, tangent_impulse, max_normal_impulse, relative_velocity,
                                   last_normal_speed, arm_a, arm_b, gap)


@njit(**JIT)
def restitution_tree_kernel(contacts, body_a, body_b, normal, tangent1, tangent2, restitution, friction,
                            surface_target, relative_velocity, max_normal_impulse, threshold, arm_a, arm_b, slot_count,
                            slot_ref, slot_resp, row_mass, skip,
                            # outputs
                            v, omega, linear_impulse, angular_impulse, axial_impulse, normal_impulse, tangent_impulse):
    """The restitution pass of the contacts of jointed bodies (``contact_solve.apply_restitution_kernel``'s
    rule: where the approach speed was above ``threshold`` and the contact pushed this step, the normal
    speed set to -e times it; then the friction solved again within mu times the normal impulse the
    bounce added to), each row through the tree, passed over until no impulse changes a
    speed by more than MANIFOLD_PASS_SPEED (at most MANIFOLD_PASSES); contacts with ``skip`` (C,) set
    are left (a chain's: ``impact_chain``). NOTE: why: with the free bodies'
    masses, a ball (1 kg, 3 m/s, e = 1) striking a hinged bar (0.2 kg, 1 m) 0.8 m from its hinge left
    at 2.452 m/s against the 2.433 of the bar's inertia about the hinge, 1.2 % of the energy lost
    (measured, session 35)."""
    for _ in range(MANIFOLD_PASSES):
        again = False
        for q in range(contacts.shape[0]):
            c = contacts[q]
            e = restitution[c]
            if skip[c] or not bounces(e, relative_velocity[c], max_normal_impulse[c], threshold):
                continue
            mass = row_mass[3 * q]
            if mass == 0.0:
                continue
            ra = (arm_a[c, 0], arm_a[c, 1], arm_a[c, 2])  # the last relax's, at these poses
            rb = (arm_b[c, 0], arm_b[c, 1], arm_b[c, 2])
            vn = _speed(v, omega, body_a[c], body_b[c], ra, rb, (normal[c, 0], normal[c, 1], normal[c, 2]))
            new_impulse = max(normal_impulse[c] - mass * (vn + e * relative_velocity[c]), 0.0)
            impulse = new_impulse - normal_impulse[c]
            normal_impulse[c] = new_impulse
            if abs(impulse) > MANIFOLD_PASS_SPEED * mass:
                again = True
            apply_row_response(3 * q, impulse, slot_count[3 * q], slot_ref, slot_resp, v, omega, linear_impulse,
                               angular_impulse, axial_impulse)
        if not again:
            break
    for _ in range(MANIFOLD_PASSES):  # then the friction (apply_restitution_kernel's order and why)
        again = False
        for q in range(contacts.shape[0]):
            c = contacts[q]
            if (skip[c] or friction[c] == 0.0 or row_mass[3 * q] == 0.0
                    or not bounces(restitution[c], relative_velocity[c], max_normal_impulse[c], threshold)):
                continue
            ra = (arm_a[c, 0], arm_a[c, 1], arm_a[c, 2])
            rb = (arm_b[c, 0], arm_b[c, 1], arm_b[c, 2])
            t1 = (tangent1[c, 0], tangent1[c, 1], tangent1[c, 2])
            t2 = (tangent2[c, 0], tangent2[c, 1], tangent2[c, 2])
            vt1 = _speed(v, omega, body_a[c], body_b[c], ra, rb, t1) - surface_target[c, 0]
            vt2 = _speed(v, omega, body_a[c], body_b[c], ra, rb, t2) - surface_target[c, 1]
            old1 = tangent_impulse[c, 0]
            old2 = tangent_impulse[c, 1]
            new1, new2 = friction_impulses_after(old1, old2, row_mass[3 * q + 1], row_mass[3 * q + 2], vt1, vt2,
                                                 friction[c] * normal_impulse[c])
            tangent_impulse[c, 0] = new1
            tangent_impulse[c, 1] = new2
            if (abs(new1 - old1) > MANIFOLD_PASS_SPEED * row_mass[3 * q + 1]
                    or abs(new2 - old2) > MANIFOLD_PASS_SPEED * row_mass[3 * q + 2]):
                again = True
            apply_row_response(3 * q + 1, new1 - old1, slot_count[3 * q + 1], slot_ref, slot_resp, v, omega,
                               linear_impulse, angular_impulse, axial_impulse)
            apply_row_response(3 * q + 2, new2 - old2, slot_count[3 * q + 2], slot_ref, slot_resp, v, omega,
                               linear_impulse, angular_impulse, axial_impulse)
        if not again:
            break


@njit(**JIT)
def split_kernel(order, bounds, body_a, body_b, body_node,
                 # outputs
                 kept_order, kept_bounds, listed):
    """The contacts of ``order`` cut by ``bounds`` (``ContactSolver.sweep``'s) that touch a body of the
    tree (``body_node`` >= 0) into ``listed``, in that order, and the others into ``kept_order`` cut by
    ``kept_bounds`` (the same cuts). Returns how many were listed."""
    n_kept = 0
    n_listed = 0
    kept_bounds[0] = 0
    for p in range(bounds.shape[0] - 1):
        for idx in range(bounds[p], bounds[p + 1]):
            c = order[idx]
            if body_node[body_a[c]] >= 0 or body_node[body_b[c]] >= 0:
                listed[n_listed] = c
                n_listed += 1
            else:
                kept_order[n_kept] = c
                n_kept += 1
        kept_bounds[p + 1] = n_kept
    return n_listed


@njit(**JIT)
def group_contacts_kernel(listed, body_a, body_b, body_node, body_group, inv_mass, I_inv,
                          # outputs
                          group_start, group_q):
    """The listed contacts (A,) by joint group, for solving the groups side by side: ``group_q`` (A,)
    the positions q of group 0's contacts in the listed order, then group 1's, ..., cut by
    ``group_start`` (G + 1,). Returns False (and the serial sweep is kept) when a contact touches
    two groups (two robots touching) or a body outside every tree that can move (a box two robots
    could both push): then the groups' rows are not apart."""
    G = group_start.shape[0] - 1
    A = listed.shape[0]
    group_of = np.empty(A, dtype=np.int64)
    for q in range(A):
        c = listed[q]
        g = -1
        for side in range(2):
            i = body_a[c] if side == 0 else body_b[c]
            if i < 0:
                continue
            if body_node[i] >= 0:
                if body_group[i] < 0 or (g >= 0 and body_group[i] != g):
                    return False
                g = body_group[i]
                continue
            if movable(i, inv_mass, I_inv):
                return False
        if g < 0:
            return False
        group_of[q] = g
    bucket_by_group(np.arange(A), group_of, group_start, group_q, np.zeros(G, dtype=np.int64))
    return True


class TreeContacts:
    """This step's contacts that touch the joint tree (``split``), their responses and the rest of
    the contact solver's sweep order: ``order``, ``bounds`` (as ``ContactSolver.sweep``'s, without
    them), ``contacts`` (A,) and the module docstring's arrays."""

    def __init__(self):
        self.contacts = np.zeros(0, dtype=np.int64)
        self.order = np.zeros(0, dtype=np.int64)
        self.bounds = np.zeros(2, dtype=np.int64)
        self.layout = (np.zeros(0, dtype=np.int64),) * 4
        self.no_skip = np.zeros(0, dtype=bool)
        self._kept = self._listed = np.zeros(0, dtype=np.int64)  # split's buffers
        self._kept_bounds = np.zeros(0, dtype=np.int64)
        self._buffers(0, 0)
        # the listed contacts by joint group (group_contacts_kernel), when the groups are swept side by side
        self.group_start = np.zeros(1, dtype=np.int64)
        self.group_q = np.zeros(0, dtype=np.int64)
        self.group_work = np.zeros((0, 6, 6))
        self.group_mode = 0
        self._positions = np.zeros(0, dtype=np.int64)  # 0, 1, ...: every listed contact, in order

    def _buffers(self, rows: int, width: int):
        old = self.__dict__.get("slot_ref")
        if old is None or old.shape[0] < rows or old.shape[1] < width:
            rows = max(rows, 2 * (old.shape[0] if old is not None else 0))
            self.slot_count = np.zeros(rows, dtype=np.int64)
            self.slot_ref = np.zeros((rows, width), dtype=np.int64)
            self.slot_resp = np.zeros((rows, width, 8))
            self.row_mass = np.zeros(rows)

    def split(self, solver, joints) -> int:
        """Take the contacts of ``solver`` (a prepared ``ContactSolver``) that touch a moving body of
        ``joints``' tree (tree method) out of its sweep order; returns how many."""
        m = solver.count
        order = solver.sweep.order[:m]
        bounds = solver.sweep.bounds
        layout = None if joints is None else joints.tree_layout
        self.order, self.bounds = order, bounds
        self.contacts = self.contacts[:0]
        self.group_mode = 0
        if layout is None or m == 0 or bounds[0] != 0:
            return 0
        if self._kept.shape[0] < m or self._kept_bounds.shape[0] != bounds.shape[0]:
            self._kept = np.zeros(2 * m, dtype=np.int64)
            self._listed = np.zeros(2 * m, dtype=np.int64)
            self._kept_bounds = np.zeros(bounds.shape[0], dtype=np.int64)
        c = solver.contacts
        # PERF: one kernel (it was a dozen NumPy calls: 6.8 -> 2.2 us a step on Ant-v5, measured)
        n = split_kernel(order, bounds, c.contact_body_a, c.contact_body_b, layout[0], self._kept, self._kept_bounds,
                         self._listed)
        if n == 0:
            return 0
        self.order = self._kept[:m - n]
        self.bounds = self._kept_bounds
        self.contacts = self._listed[:n]
        self.layout = layout
        self.no_skip = joints._scratch["no_skip"]
        self._buffers(3 * len(self.contacts), 2 * joints.tree_width + 2)
        if self._positions.shape[0] < n:
            self._positions = np.arange(2 * n, dtype=np.int64)
        groups = joints._groups_table
        if groups[0]:  # the joint groups are swept side by side: their contacts too, if apart
            G = groups[8].shape[0]
            if self.group_start.shape[0] != G + 1:
                self.group_start = np.zeros(G + 1, dtype=np.int64)
            if self.group_q.shape[0] < n:
                self.group_q = np.zeros(2 * n, dtype=np.int64)
            self.group_work = groups[8]
            self.group_mode = int(group_contacts_kernel(self.contacts, c.contact_body_a, c.contact_body_b, layout[0],
                                                        joints.body_group, solver.world.inv_mass, solver.I_inv,
                                                        self.group_start, self.group_q[:n]))
        return len(self.contacts)

    def parts(self) -> tuple:
        """The arrays ``soft_step.substeps_kernel`` takes (``split``'s, the responses', the layout)."""
        return (self.order, self.bounds, self.contacts, self.slot_count, self.slot_ref, self.slot_resp,
                self.row_mass, *self.layout, self.no_skip, self._positions[:len(self.contacts)], self.group_start,
                self.group_q[:len(self.contacts)], self.group_work, self.group_mode)
