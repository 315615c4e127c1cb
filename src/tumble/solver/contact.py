"""Velocity-level contact solver: Box2D v3's soft step, in kernels over contact arrays.

The stages follow Box2D v3's solver (``src/solver.c``, ``src/contact_solver.c``; Catto,
"Solver2D", https://box2d.org/posts/2024/02/solver2d/), written afresh for 3-D:

    prepare_contacts                 once a step, after the narrowphase
    per substep h = dt / substeps:
        integrate_velocities         forces of the step (solver.soft_step)
        warm_start                   last substep's accumulated impulses
        solve_contacts(use_bias=1)   soft non-penetration + Coulomb friction, a manifold at a time
        integrate_positions          x += h v, rotation by the exact rotation of omega h (soft_step)
        solve_contacts(use_bias=0)   relax: removes the push-out velocity (no energy added)
    apply_restitution                v+ = -e v- above RESTITUTION_THRESHOLD, a manifold at a time
    store_impulses                   keyed by ``contact_key`` for the next step's warm start

This module holds the settings and ``ContactSolver``, which keeps the contact arrays and calls
the stages' kernels (``solver.contact_solve``; the sweeps' slabs: ``solver.partition``);
``solver.soft_step.SoftStep`` runs them with the integration and the joints inside
``Simulator.step``.

Combine rules (per contact, from the two bodies' ``Material``): friction sqrt(fa fb),
restitution max(ea, eb) (Box2D's defaults).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..collision.constants import SPECULATIVE_DISTANCE
from ..collision.manifold import KEY_BITS, match_contacts
from .contact_anchor import anchor_offsets_kernel, anchor_offsets_serial_kernel
from .contact_rolling import (
    prepare_rolling_kernel,
    solve_rolling_kernel,
    store_rolling_kernel,
    warm_start_rolling_kernel,
)
from .contact_solve import (
    LOAD_OFF,
    apply_restitution_kernel,
    combine_materials_kernel,
    prepare_contacts_kernel,
    prepare_contacts_serial_kernel,
    soft_from_omega,
    solve_contacts_kernel,
    surface_target_kernel,
    store_impulses_kernel,
    warm_start_kernel,
)
from .contact_tree import restitution_tree_kernel
from .impact_chain import chain_passes, chain_rows_kernel, impact_chain_kernel
from .joint_solve import AXIAL_COUNT
from .partition import (
    SweepOrder,
)

# Relative normal speed (m/s) below which restitution is ignored: slower impacts end
# inelastic, so resting and slowly bouncing contacts settle instead of chattering.
# Box2D's b2_restitutionThreshold / Box3D's default, 1 m/s. @warning a scene of small,
# slow bodies (marbles) needs a lower value to bounce at all.
RESTITUTION_THRESHOLD = 1.0


@dataclass
class SoftStepSettings:
    """The soft step's tuning (BENCHMARKS.md "Settings shared by every scene").

    substeps: solver substeps per step of the Simulator (4, Box3D's): the contact bodies' step
        of dt is made of ``Simulator.substeps * substeps`` substeps h. At dt = 1/60 s this is
        Box3D's step (h = 1/240 s); at the default dt of 1/240 s, h = 1/960 s.
    contact_hertz: Hz, stiffness of contacts between two moving bodies; None (the default):
        ``hertz_cap_per_substep / h`` (0.125 / h: 30 Hz at h = 1/240 s as Box3D, 120 Hz at
        1/960 s); a number is used up to that cap.
    contact_damping_ratio: (10) heavily over-damped: penetration is pushed out, never bounced.
    static_hertz_scale, static_damping_ratio: contacts against fixed bodies use
        2 x the contact hertz with damping ratio 5 (BENCHMARKS.md; stiffer, since the
        fixed side cannot move away).
    load_hertz_cap_per_substep: 0 (off, Box3D's); a number c (0.1875 advised): a contact holding up
        more than its own bodies' weight (its last step's normal impulse above m_eff |g| h) is
        stiffened so that it sags no more than a body resting under its own weight, up to c / h
        (contacts with a fixed body have 0.25 / h by default). A 100 kg box on a 1 kg one at dt
        1/60 s then sinks 12.3 mm into it instead of 27. Off by default: an impact's impulse reads
        as a load too, and strikes play out otherwise (contact_solve's LOAD note, docs/contact.md
        "Loaded contacts").
    contact_speed: m/s, largest push-out speed of the bias (Box2D ``contactSpeed``, 3).
    restitution_threshold: m/s, see RESTITUTION_THRESHOLD.
    impact_chains: (False) True: an impact reaching bodies that already touch (three bodies or
        more, with restitution) is solved as the sequence of pairwise impacts the wave through
        them makes: a Newton's cradle of touching balls sends the last ball out, a pool break
        runs through the rack. False: the restitution pass alone (Box2D's), under which the
        touching row moves on together. Off by default: a body struck while it rests on a
        support is taken as free during the strike, then bounced off the support (``impact_chain``;
        docs/contact.md "Impacts through touching chains").
    speculative_distance: m, contacts are made this far apart (plus the motion bound of the
        step) and AABBs grown by it (collision.constants.SPECULATIVE_DISTANCE, 0.02).
    partitions: (2) a step with at least ``partition_min_contacts`` (1024) contact points solves
        them in this many spatial slabs side by side, then the contacts joining two slabs
        (``partition_pairs_kernel``): one slab per core. The order of the Gauss-Seidel sweep,
        and so the bits, follow these two settings, never the number of threads; 1 solves every
        contact in the narrowphase's order on one thread (as smaller steps always are).

    NOTE (why the hertz follows h): a soft contact is a spring of stiffness m omega^2, so a
    stack rests compressed by load / (m omega^2) at each contact: 0.28 mm per box of load at
    30 Hz, which summed to 2.5 cm down the 10-box tower. The soft step behaves the same for the
    same omega h, so a smaller h allows a stiffer, equally stable contact: at h = 1/960 s,
    120 Hz, the tower sags 1.6 mm. Tried and dropped: 60 Hz at h = 1/240 s (the 20-row pyramid
    shook, 0.45 m/s after 10 s); halving the softness leak (tower 1.3 cm, pyramid still; a
    quarter shook); a position-correction pass after the step (Box2D v2.4's, translation
    with or without rotation: the tower fell within 30 s).
    """

    substeps: int = 4
    contact_hertz: float | None = None
    contact_damping_ratio: float = 10.0
    static_hertz_scale: float = 2.0
    static_damping_ratio: float = 5.0
    hertz_cap_per_substep: float = 0.125
    load_hertz_cap_per_substep: float = 0.0
    contact_speed: float = 3.0
    restitution_threshold: float = RESTITUTION_THRESHOLD
    impact_chains: bool = False
    speculative_distance: float = SPECULATIVE_DISTANCE
    partitions: int = 2
    partition_min_contacts: int = 1024


def soft_coefficients(hertz: float, zeta: float, h: float):
    """(bias_rate 1/s, mass_scale, impulse_scale) of a soft constraint (Catto, GDC 2011,
    https://box2d.org/files/ErinCatto_SoftConstraints_GDC2011.pdf; Box2D ``b2MakeSoft``).

    A spring-damper of natural frequency omega = 2 pi hertz and damping ratio zeta, stepped
    implicitly over h, turns the rigid impulse -m (vn + bias) into
    -mass_scale m (vn + bias_rate s) - impulse_scale * accumulated.
    """
    if hertz <= 0.0:
        return 0.0, 1.0, 0.0
    return soft_from_omega(2.0 * math.pi * hertz, zeta, h)


_NO_ROWS = np.zeros(0, dtype=np.int64)
# fewer contacts are prepared on this thread (as the narrowphase's PARALLEL_MIN_CANDIDATES)
PARALLEL_MIN_CONTACTS = 1024


# ---------------------------------------------------------------------- the solver object
_C_FLOAT = {
    "anchor_a": (3,), "anchor_b": (3,), "local_a": (3,), "local_b": (3,), "anchor_offset": (7,),
    "separation_base": (), "tangent1": (3,),
    "tangent2": (3,),
    "normal_mass": (), "tangent_mass": (2,), "soft": (3,), "friction": (), "restitution": (),
    "relative_velocity": (), "last_normal_speed": (), "normal_impulse": (), "tangent_impulse": (2,), "max_normal_impulse": (),
    "old_normal_impulse": (), "old_friction_impulse": (3,),
    "step_normal_impulse": (), "step_tangent_impulse": (2,),
    "arm_a": (3,), "arm_b": (3,), "gap": (),
    # the tangential speed friction drives each contact to, from the bodies' surface velocities
    # (conveyor belts): written only in a world that has one, zero otherwise
    "surface_target": (2,),
    # rolling and spinning rows (solver.contact_rolling), written only where a material resists rolling
    "rolling_mass": (3,), "rolling_limit": (2,), "rolling_impulse": (3,), "old_rolling_impulse": (3,),
}


# the buffers' rows this step's contacts use (``count``) and those the last step kept (``old_count``)
_OLD_ROWS = tuple(name for name in _C_FLOAT if name.startswith("old_"))
_NEW_ROWS = tuple(name for name in _C_FLOAT if not name.startswith("old_"))


class ContactSolver:
    """Per-contact solver arrays, kept between steps (buffers grow by doubling), and the
    impulses stored by key for warm starting.

    Usage per step: ``prepare_contacts(world, contacts, h)``, then per substep
    ``warm_start`` / ``solve_contacts(True)`` / (positions) / ``solve_contacts(False)``,
    then ``apply_restitution`` and ``store_impulses``. The kernels read and write the
    caller's velocity arrays ``v`` and ``omega`` (N, 3) given to ``prepare_contacts``.
    """

    def __init__(self, settings: SoftStepSettings | None = None, capacity: int = 64):
        self.settings = settings or SoftStepSettings()
        self.count = 0
        self.old_count = 0
        self._capacity = 0
        self._buf: dict[str, np.ndarray] = {}
        self._reserve(capacity)
        self.old_key = np.zeros(0, dtype=np.int64)
        self.contacts = None
        self._material_bodies = None  # (body count, World.material_version) of the body_* material arrays
        self._pair_rows = None  # (rows, condims) of the contacts whose body pair has its own material
        self._pair_key = None  # (World.pair_material_version, body count) of ``_pair_table``
        self.rolling_rows = _NO_ROWS  # contacts with rolling and spinning rows this step
        self._surface_written = False  # whether surface_target holds anything but zeros
        self._part_material_key = None  # (table, body count) of the per-shape materials below
        self._rolling_stored = False  # whether old_rolling_impulse holds the last step's
        # (normal (K,) N s, friction (K, 3) N s world): the last step's impulses of its K contacts
        # when they came from a checkpoint or snapshot (set_warm_start_state) rather than from a
        # step this solver took; dropped by the next prepare (last_step_impulses)
        self._restored_step = None
        self.sweep = SweepOrder()  # the order of this step's sweeps (slabs for a large step)

    def _reserve(self, n: int):
        cap = max(self._capacity, 1)
        while cap < n:
            cap *= 2
        if cap == self._capacity:
            return
        new = {name: np.zeros((cap,) + shape) for name, shape in _C_FLOAT.items()}
        for name, arr in self._buf.items():
            new[name][: len(arr)] = arr
        self._buf = new
        self._capacity = cap
        self._refresh_views()

    # The per-contact arrays are read as attributes (``self.normal_impulse``: the first ``count``
    # rows of a buffer, ``old_*`` the first ``old_count``). PERF: views kept in the instance and
    # renewed when a count or the buffers change; building them on each read (``__getattr__``)
    # was 240 calls and 190 us a step for 10 boxes on the ground.
    @property
    def count(self) -> int:
        return self._count

    # PERF: a count set again to its value keeps its views (the buffers are replaced only by
    # ``_reserve``, which renews every view itself): two renewals of 27 and 3 views a step, 4 us each
    # under the profiler, for a box on a plane whose count never changed
    @count.setter
    def count(self, n: int):
        if self.__dict__.get("_count") == n:
            return
        self._count = n
        self._refresh_views(old=False)

    @property
    def old_count(self) -> int:
        return self._old_count

    @old_count.setter
    def old_count(self, n: int):
        if self.__dict__.get("_old_count") == n:
            return
        self._old_count = n
        self._refresh_views(new=False)

    def __setstate__(self, state):
        # a pickled or deep-copied view is an array of its own: made again from the buffers (the
        # count setters keep views while a count stays, so a copy's must be its buffers')
        self.__dict__.update(state)
        self._refresh_views()

    def _refresh_views(self, new: bool = True, old: bool = True):
        d = self.__dict__
        buf = d.get("_buf")
        if buf is None:
            return
        if new:
            n = d.get("_count", 0)
            for name in _NEW_ROWS:
                d[name] = buf[name][:n]
        if old:
            k = d.get("_old_count", 0)
            for name in _OLD_ROWS:
                d[name] = buf[name][:k]

    def __getattr__(self, name):
        buf = self.__dict__.get("_buf", {})
        if name in buf:
            n = self.old_count if name.startswith("old_") else self.count
            return buf[name][:n]
        raise AttributeError(name)

    def _load_soft(self, world, hertz: float, h: float) -> np.ndarray:
        """``prepare_contacts_kernel``'s ``load_soft`` (7,) for contacts of ``hertz`` (Hz) at substep
        ``h`` (s): LOAD_OFF without gravity or with the stiffening off (its cap at or below them)."""
        st = self.settings
        g = math.sqrt(sum(float(c) ** 2 for c in world.gravity))
        cap = 2.0 * math.pi * (st.load_hertz_cap_per_substep / h)  # as omega is made from a hertz
        static = st.static_hertz_scale * hertz
        if g == 0.0 or hertz <= 0.0 or cap <= 2.0 * math.pi * min(hertz, static):
            return LOAD_OFF
        return np.array([g * h, 2.0 * math.pi * hertz, st.contact_damping_ratio, 2.0 * math.pi * static,
                         st.static_damping_ratio, cap, h])

    # -- stages --------------------------------------------------------------------------
    def prepare_contacts(self, world, contacts, h: float, v: np.ndarray, omega: np.ndarray, x=None, R=None,
                         I_inv=None, *, shapes):
        """Set up this step's contacts from ``contacts`` (a ContactManifolds) at substep ``h``.

        shapes: the ``CollisionPipeline`` that found them (its ShapeTable and the shapes' poses
        ``shape_pos``, ``shape_rot`` at the step's start), for the anchors' round offsets
        (``contact_anchor``).

        v, omega: (N, 3) the velocity arrays the solve will change (m/s, rad/s, world).
        x: (N, >= 3) centres of mass (or the packed state), R: (N, 3, 3), I_inv: (N, 3, 3)
        world inverse inertia (0 for bodies the solver must not move); default the world's.
        """
        st = self.settings
        self.contacts = contacts
        self.world = world
        self.v = v
        self.omega = omega
        self.h = h
        self.x = world.x if x is None else x
        self.R = world.R if R is None else R
        self.I_inv = world.I_inv if I_inv is None else I_inv
        n = contacts.contact_count
        self._reserve(max(n, self.old_count))
        self.count = n
        if n == 0:  # PERF: nothing touches (a robot in the air): no rows to set up; the sweep as always
            self.rolling_rows = _NO_ROWS
            self._contact_shapes = None
            self.sweep.update(contacts.contact_body_a, contacts.contact_body_b, world.moving, self.x,
                              int(st.partitions), st.partition_min_contacts)
            return
        cap = st.hertz_cap_per_substep / h
        hertz = cap if st.contact_hertz is None else min(st.contact_hertz, cap)
        self.soft_dynamic = np.array(soft_coefficients(hertz, st.contact_damping_ratio, h))
        self.soft_static = np.array(soft_coefficients(st.static_hertz_scale * hertz, st.static_damping_ratio, h))
        self.load_soft = self._load_soft(world, hertz, h)
        match = match_contacts(self.old_key, contacts.contact_key)
        nb = world.body_count
        if (nb, world.material_version) != self._material_bodies:  # read again when bodies are added or set
            self.body_friction = np.array([m.friction for m in world.materials[:nb]], dtype=float)
            self.body_restitution = np.array([m.restitution for m in world.materials[:nb]], dtype=float)
            self.body_rolling = np.array([m.rolling_resistance for m in world.materials[:nb]], dtype=float)
            self.body_spinning = np.array([m.spinning_friction for m in world.materials[:nb]], dtype=float)
            self.body_combine = np.array([m.combine_codes() for m in world.materials[:nb]], dtype=np.int64).reshape(nb, 3)
            self.body_margin = np.array([m.margin for m in world.materials[:nb]], dtype=float)
            self.body_resists_rolling = np.array([m.resists_rolling for m in world.materials[:nb]], dtype=bool)
            self.any_resists_rolling = bool(self.body_resists_rolling.any())
            self.any_restitution = bool(self.body_restitution.any())  # (else no chain: _impact_chains)
            self._material_bodies = (nb, world.material_version)
        b = self._buf
        b["step_normal_impulse"][:n] = 0.0
        b["step_tangent_impulse"][:n] = 0.0
        self._restored_step = None
        table = shapes.table
        # Without a round shape the rows of ``anchor_offset`` stay as allocated, zeros (anchors fixed
        # in the bodies, m their midpoint): a world's shapes are only ever added to, so once it has
        # a round one this kernel writes every row, every step.
        # PERF: a few contacts on this thread: a parallel start cost up to 1.5 ms (same bits)
        parallel = n >= PARALLEL_MIN_CONTACTS
        if table.has_round:
            anchor_offsets = anchor_offsets_kernel if parallel else anchor_offsets_serial_kernel
            anchor_offsets(contacts.contact_manifold, contacts.manifold_shape_a, contacts.manifold_shape_b,
                           contacts.contact_point, contacts.contact_normal, contacts.contact_separation,
                           contacts.contact_body_a, contacts.contact_body_b, omega,
                           table.shape_type, table.shape_params, shapes.shape_pos, shapes.shape_rot,
                           self.anchor_offset)
        (prepare_contacts_kernel if parallel else prepare_contacts_serial_kernel)(
            contacts.contact_body_a, contacts.contact_body_b, contacts.contact_point, contacts.contact_normal,
            contacts.contact_separation, match, b["old_normal_impulse"][: self.old_count],
            b["old_friction_impulse"][: self.old_count], self.x, self.R, v, omega, world.inv_mass, self.I_inv,
            world.moving, self.body_friction, self.body_restitution, self.body_combine, self.body_margin,
            self.soft_dynamic, self.soft_static, self.load_soft,
            self.anchor_offset, self.anchor_a, self.anchor_b, self.local_a, self.local_b, self.separation_base,
            self.tangent1, self.tangent2, self.normal_mass, self.tangent_mass, self.soft, self.friction, self.restitution,
            self.relative_velocity, self.normal_impulse, self.tangent_impulse, self.max_normal_impulse,
        )
        self._match = match  # the last step's row of each contact (-1: new), for the impact chains' loads
        if contacts.allowance_count:  # speculative gaps a sweep shows closing later (collision/speculative.py)
            self.separation_base[:n] += contacts.contact_allowance
        b["last_normal_speed"][:n] = b["relative_velocity"][:n]
        self._contact_shapes = None
        if table.has_part_materials:
            self._mix_part_materials(world, contacts, table)
        self._pair_rows = self._apply_pair_materials(world, contacts) if world.pair_materials else None
        self._prepare_surface(world, contacts)
        self._prepare_rolling(contacts, match)
        self.sweep.update(contacts.contact_body_a, contacts.contact_body_b, world.moving, self.x, int(st.partitions),
                          st.partition_min_contacts)

    def _mix_part_materials(self, world, contacts, table):
        """Friction and restitution of each contact from its two shapes' materials (a compound
        part's own, else its body's) by their combine modes, in place of the bodies' that
        ``prepare_contacts_kernel`` mixed: the same function (``combine_material``), so a part
        without its own material gives the same numbers. Keeps the contacts' shapes for ``_prepare_rolling``."""
        key = (id(table), world.body_count, world.material_version)
        if self._part_material_key != key:
            self._shape_material = table.shape_materials(world.materials)
            self._part_material_key = key
        m = contacts.contact_manifold
        sa, sb = contacts.manifold_shape_a[m], contacts.manifold_shape_b[m]
        mat = self._shape_material
        combine_materials_kernel(sa, sb, mat["friction"], mat["restitution"], mat["combine"], self.friction,
                                 self.restitution)
        self._contact_shapes = (sa, sb)

    def _apply_pair_materials(self, world, contacts):
        """The contacts of body pairs that have a material of their own (``World.set_pair_material``)
        take its friction (0 where its condim is 1) and restitution. Returns (rows (K,), their
        pairs' condims (K,)) for ``_prepare_rolling``."""
        nb = world.body_count
        key = (world.pair_material_version, nb)
        if key != self._pair_key:
            items = sorted(world.pair_materials.items())
            self._pair_table = (np.array([lo * nb + hi for (lo, hi), _ in items], dtype=np.int64),
                                np.array([m.friction for _, m in items], dtype=float),
                                np.array([m.restitution for _, m in items], dtype=float),
                                np.array([m.combine_codes()[2] for _, m in items], dtype=np.int64))
            self._pair_key = key
        keys, friction, restitution, condim = self._pair_table
        n = self.count
        a, b = contacts.contact_body_a[:n], contacts.contact_body_b[:n]
        k = np.minimum(a, b) * nb + np.maximum(a, b)
        i = np.minimum(np.searchsorted(keys, k), len(keys) - 1)
        rows = np.flatnonzero(keys[i] == k)
        which = i[rows]
        self.friction[rows] = np.where(condim[which] > 1, friction[which], 0.0)
        self.restitution[rows] = restitution[which]
        return rows, condim[which]

    def _prepare_surface(self, world, contacts):
        """``surface_target`` (C, 2) m/s: t . (R_a s_a - R_b s_b) along the two tangents, s the
        bodies' ``surface_velocity`` (body frame); zeros (left as they are) in a world without one."""
        n = self.count
        used = bool(world.surface_velocity.any())  # (not np.any: its Python wrapper, every step)
        if used:
            surface_target_kernel(contacts.contact_body_a, contacts.contact_body_b, self.tangent1, self.tangent2,
                                  self.R, world.surface_velocity, self.surface_target)
        elif self._surface_written:
            self._buf["surface_target"][:] = 0.0
        self._surface_written = used
        return n

    def _prepare_rolling(self, contacts, match):
        """The rolling and spinning rows (``contact_rolling``) of the contacts that touch a body
        whose material resists rolling; none (and nothing run) in a world without one."""
        n = self.count
        parts = self._contact_shapes is not None  # per compound part (_mix_part_materials)
        if parts:
            sa, sb = self._contact_shapes
            roll, spin = self._shape_material["rolling_resistance"], self._shape_material["spinning_friction"]
            shape_resists = (roll > 0.0) | (spin > 0.0)
            if not shape_resists.any():
                self.rolling_rows = _NO_ROWS
                return
            self.rolling_rows = np.flatnonzero(shape_resists[sa] | shape_resists[sb])
        elif not self.any_resists_rolling:
            self.rolling_rows = _NO_ROWS
            return
        else:
            resists = self.body_resists_rolling
            self.rolling_rows = np.flatnonzero(resists[contacts.contact_body_a] | resists[contacts.contact_body_b])
        self._buf["rolling_impulse"][:n] = 0.0  # the rows' impulses are stored for every contact
        if not self._rolling_stored:  # the last step kept none: start from zero
            match = np.full(n, -1, dtype=np.int64)
        prepare_rolling_kernel(self.rolling_rows, contacts.contact_body_a, contacts.contact_body_b,
                               contacts.contact_normal, self.tangent1, self.tangent2, self.anchor_offset, match,
                               self._buf["old_rolling_impulse"][: self.old_count], self.I_inv, self.body_rolling,
                               self.body_spinning, self.rolling_mass, self.rolling_limit, self.rolling_impulse)
        if parts:  # the limits of the shapes that touch: c r N and s N as the kernel's, per shape
            rows = self.rolling_rows
            off = self.anchor_offset[rows]
            r = np.maximum(np.linalg.norm(off[:, 0:3], axis=1), np.linalg.norm(off[:, 3:6], axis=1))
            self.rolling_limit[rows, 0] = np.maximum(roll[sa[rows]], roll[sb[rows]]) * r
            self.rolling_limit[rows, 1] = np.maximum(spin[sa[rows]], spin[sb[rows]])
        # MuJoCo's condim (Material.condim), the larger of the pair's: below 6 no rolling, below 4 no
        # spinning friction (a world that sets none: every condim 6, nothing changes)
        rows = self.rolling_rows
        condim = self._shape_material["combine"][:, 2] if parts else self.body_combine[:, 2]
        ia, ib = (sa[rows], sb[rows]) if parts else (contacts.contact_body_a[rows], contacts.contact_body_b[rows])
        pair = np.maximum(condim[ia], condim[ib])
        if self._pair_rows is not None and len(self._pair_rows[0]):  # a pair's own condim instead
            own = np.zeros(n, dtype=np.int64)
            own[self._pair_rows[0]] = self._pair_rows[1]
            pair = np.where(own[rows] > 0, own[rows], pair)
        if (pair < 6).any():
            self.rolling_limit[rows[pair < 6], 0] = 0.0
            self.rolling_limit[rows[pair < 4], 1] = 0.0

    def warm_start(self, fresh: bool = True):
        """Apply the accumulated impulses; ``fresh=False`` when the poses are those of the last
        relax (the substeps after the first), whose cached arms are then used."""
        if not self.count:  # PERF: a world of joints without contacts (a robot) skips the call
            return
        c = self.contacts
        warm_start_kernel(self.sweep.order[:self.count], self.sweep.bounds, c.contact_body_a, c.contact_body_b,
                          c.contact_normal, self.tangent1, self.tangent2, self.local_a, self.local_b,
                          self.anchor_offset, self.normal_impulse, self.tangent_impulse, self.x, self.R,
                          self.world.inv_mass, self.I_inv, bool(fresh), self.v, self.omega, self.arm_a, self.arm_b, self.gap)
        if len(self.rolling_rows):
            warm_start_rolling_kernel(self.rolling_rows, c.contact_body_a, c.contact_body_b, c.contact_normal,
                                      self.tangent1, self.tangent2, self.rolling_impulse, self.I_inv, self.omega)

    def solve_contacts(self, use_bias: bool, order: np.ndarray | None = None, bounds: np.ndarray | None = None):
        """One sweep of ``solve_contacts_kernel`` in the sweep's order, or in ``order`` cut by ``bounds``
        (the contacts of jointed bodies taken out: ``contact_tree.TreeContacts``)."""
        if not self.count:
            return
        c = self.contacts
        w = self.world
        if order is None:
            order, bounds = self.sweep.order[:self.count], self.sweep.bounds
        solve_contacts_kernel(order, bounds, c.contact_body_a, c.contact_body_b,
                              c.contact_normal, self.tangent1, self.tangent2, self.local_a, self.local_b,
                              self.anchor_offset, self.separation_base, self.normal_mass, self.tangent_mass, self.soft,
                              self.friction, self.surface_target, self.x, self.R, w.inv_mass, self.I_inv, 1.0 / self.h,
                              self.settings.contact_speed,
                              bool(use_bias), self.v, self.omega, self.normal_impulse, self.tangent_impulse,
                              self.max_normal_impulse, self.relative_velocity, self.last_normal_speed,
                              self.arm_a, self.arm_b, self.gap)
        if len(self.rolling_rows):  # after the contacts, whose normal impulses bound them
            solve_rolling_kernel(self.rolling_rows, c.contact_body_a, c.contact_body_b, c.contact_normal,
                                 self.tangent1, self.tangent2, self.normal_impulse, self.rolling_mass,
                                 self.rolling_limit, self.I_inv, self.omega, self.rolling_impulse)

    def apply_restitution(self, tree=None, joints=None, substeps: int = 1):
        """The restitution pass; the contacts of jointed bodies (``tree``, a split
        ``contact_tree.TreeContacts``, and its ``joints``) through the tree; then the impacts through
        touching chains (``impact_chain``; ``substeps``: the step's substeps, for the loads the
        contacts carried in the last step)."""
        if not self.count:
            return
        c = self.contacts
        n = self.count
        skip = self.__dict__.get("_no_skip")
        if skip is None or skip.shape[0] < n:
            skip = self._no_skip = np.zeros(2 * n, dtype=bool)
        listed = tree.contacts if tree is not None else ()
        chains = self._impact_chains(n, substeps)  # (C,) bool, the contacts of impacts through touching chains, or None
        if chains is not None:
            skip[:n] = chains  # left to impact_chain_kernel, below
        if len(listed):
            skip[listed] = True
        # the restitution pass adds to the accumulated impulse: count the increment in the step's total
        self.step_normal_impulse[:] -= self.normal_impulse
        self.step_tangent_impulse[:] -= self.tangent_impulse
        apply_restitution_kernel(c.contact_body_a, c.contact_body_b, c.contact_normal, self.tangent1, self.tangent2,
                                 self.local_a, self.local_b, self.normal_mass, self.tangent_mass, self.restitution,
                                 self.friction, self.surface_target, self.relative_velocity,
                                 self.max_normal_impulse, self.settings.restitution_threshold,
                                 self.arm_a, self.arm_b, self.world.inv_mass, self.I_inv, skip[:n], self.v, self.omega,
                                 self.normal_impulse, self.tangent_impulse)
        if len(listed):
            skip[listed] = False
            restitution_tree_kernel(listed, c.contact_body_a, c.contact_body_b, c.contact_normal, self.tangent1,
                                    self.tangent2, self.restitution, self.friction, self.surface_target,
                                    self.relative_velocity, self.max_normal_impulse,
                                    self.settings.restitution_threshold, self.arm_a, self.arm_b, tree.slot_count,
                                    tree.slot_ref, tree.slot_resp, tree.row_mass,
                                    skip[:n] if chains is None else chains, self.v, self.omega,
                                    joints.linear_impulse, joints.angular_impulse, joints.axial_impulse,
                                    self.normal_impulse, self.tangent_impulse)
        self.step_normal_impulse[:] += self.normal_impulse
        self.step_tangent_impulse[:] += self.tangent_impulse
        if chains is not None:
            skip[:n] = False
            self._impact_chain(n, chains, listed, tree, joints)

    def _impact_chains(self, n: int, substeps: int = 1):
        """(C,) bool: the contacts of this step's impacts through touching chains (``impact_chain.
        chain_rows_kernel``), or None when there are none (or ``settings.impact_chains`` is off):
        then the restitution pass is as it was, bit for bit. A contact's load before the step: its
        last step's last substep impulse (``old_normal_impulse`` by ``match``) times ``substeps``."""
        if not self.settings.impact_chains:
            return None
        if not (self.__dict__.get("any_restitution", True) or self.world.pair_materials):
            return None  # PERF: no body has restitution, and no pair a material of its own: no chain (3.4 us a step)
        sc = self.__dict__.get("_chain_scratch")
        N = self.world.body_count
        if sc is None or sc[0].shape[0] != N or sc[3].shape[0] < n:
            sc = self._chain_scratch = (np.zeros(N, dtype=np.int64), np.zeros(N, dtype=np.int64),
                                        np.zeros(N, dtype=bool), np.zeros(2 * n, dtype=bool))
        c = self.contacts
        chain = sc[3][:n]
        count = chain_rows_kernel(c.contact_body_a, c.contact_body_b, self.restitution, self.relative_velocity,
                                  self.max_normal_impulse, self.settings.restitution_threshold, self.world.inv_mass,
                                  self.normal_mass, self.step_normal_impulse, self._match,
                                  self._buf["old_normal_impulse"][: self.old_count], float(substeps),
                                  sc[0], sc[1], sc[2], chain)
        return chain if count else None

    def _impact_chain(self, n: int, chains, listed, tree, joints):
        """The impacts through the touching chains ``chains`` (C,) bool, in sequence
        (``impact_chain.impact_chain_kernel``), after the restitution pass has done the rest."""
        c = self.contacts
        rows = np.flatnonzero(chains)
        tree_row = np.full(n, -1, dtype=np.int64)
        if len(listed):
            tree_row[listed] = np.arange(len(listed))
            slots = (tree.slot_count, tree.slot_ref, tree.slot_resp, tree.row_mass)
            impulses = (joints.linear_impulse, joints.angular_impulse, joints.axial_impulse)
        else:
            slots = (np.zeros(0, dtype=np.int64), np.zeros((0, 0), dtype=np.int64), np.zeros((0, 0, 8)), np.zeros(0))
            impulses = (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, AXIAL_COUNT)))
        K = len(rows)
        impact_chain_kernel(rows, tree_row, c.contact_body_a, c.contact_body_b, c.contact_normal, self.tangent1,
                            self.tangent2, self.restitution, self.friction, self.normal_mass,
                            self.settings.restitution_threshold, self.arm_a, self.arm_b, self.world.inv_mass,
                            self.I_inv, *slots, chain_passes(K), self.v, self.omega, *impulses,
                            self.step_normal_impulse, self.normal_impulse, self.step_tangent_impulse,
                            self.tangent_impulse, np.zeros(K), np.zeros(K), np.zeros(K), np.zeros(K, dtype=bool))

    def accumulate_step_impulses(self):
        """After a substep's relax: the accumulated impulses are what this substep applied
        (its warm start applied the last value, its solves the increments); add them to the step's total."""
        if not self.count:
            return
        self.step_normal_impulse[:] += self.normal_impulse
        self.step_tangent_impulse[:] += self.tangent_impulse

    def last_step_impulses(self, rows=None) -> tuple[np.ndarray, np.ndarray]:
        """(normal (M,) N s, friction (M, 3) N s, world): the whole last step's impulses of its
        contacts ``rows`` (M,) (rows of ``old_key``: the last step's contacts, in its order; None:
        all of them, as whole arrays), from the step's totals, or from the arrays a checkpoint or
        snapshot restored when no step has been taken since (``SoftStep.resting_fields``: an
        island falling asleep at the first step after a restore; that step's totals are not made
        yet: an IndexError before session 39)."""
        # PERF: None reads whole arrays, no gather (a snapshot's save at 1000 boxes, 4000 contacts:
        # 0.19 -> 0.05 ms)
        sel = slice(None) if rows is None else rows
        if self._restored_step is not None:
            normal, friction = self._restored_step
            return normal[sel], friction[sel]
        jt = self.step_tangent_impulse[sel]
        return self.step_normal_impulse[sel], jt[:, 0:1] * self.tangent1[sel] + jt[:, 1:2] * self.tangent2[sel]

    def warm_start_state(self) -> dict:
        """The impulses kept for the next step's warm start, as arrays (for checkpoints): the keys
        (K,) int64, normal impulses (K,) N s and friction impulses (K, 3) N s, world; and the
        whole last step's impulses of the same contacts, ``step_normal_impulse`` (K,) and
        ``step_friction_impulse`` (K, 3) (``last_step_impulses``: what the contacts of an island
        falling asleep at the next step report)."""
        k = self.old_count
        rolling = self._buf["old_rolling_impulse"][:k].copy() if self._rolling_stored else np.zeros((k, 3))
        # the last step's K rows, in order (its totals hold them all between steps: count == K)
        whole = self._restored_step is not None or self.count == k
        step_normal, step_friction = self.last_step_impulses(None if whole else np.arange(k))
        return {"key": self.old_key[:k].copy(), "normal_impulse": self._buf["old_normal_impulse"][:k].copy(),
                "friction_impulse": self._buf["old_friction_impulse"][:k].copy(), "rolling_impulse": rolling,
                "step_normal_impulse": np.array(step_normal), "step_friction_impulse": np.array(step_friction)}

    def set_warm_start_state(self, state: dict):
        """Inverse of ``warm_start_state``."""
        key = np.asarray(state["key"], dtype=np.int64)
        k = len(key)
        self._reserve(max(k, self.count))
        self._buf["old_normal_impulse"][:k] = state["normal_impulse"]
        self._buf["old_friction_impulse"][:k] = state["friction_impulse"]
        # (K, 3) N m s, world, of the rolling and spinning rows; absent (older checkpoints): zeros
        self._buf["old_rolling_impulse"][:k] = state.get("rolling_impulse", 0.0)
        self._rolling_stored = True
        self.old_key = key.copy()
        self.old_count = k
        # absent (checkpoints written before session 39): zeros, what a first step reports
        self._restored_step = (np.array(state.get("step_normal_impulse", np.zeros(k)), dtype=float),
                               np.array(state.get("step_friction_impulse", np.zeros((k, 3))), dtype=float))

    def forget(self, bodies: np.ndarray, shape_body: np.ndarray):
        """Drop the warm start of the stored contacts (last step's) that touch ``bodies`` (N,) bool,
        ``shape_body`` (S,) the shapes' bodies: bodies put in a new state (``Kinematics.set_state``).
        Their keys are made negative (each its own: keys stay unique), so they match no contact of
        the next step, which starts from zero impulses as a first step does."""
        k = self.old_count
        keys = self.old_key[:k]
        live = np.flatnonzero(keys >= 0)
        shape_mask = (1 << KEY_BITS) - 1  # manifold.py's key: (shape_a << 42) | (shape_b << 21) | feature
        a = shape_body[keys[live] >> (2 * KEY_BITS)]
        b = shape_body[(keys[live] >> KEY_BITS) & shape_mask]
        hit = live[bodies[a] | bodies[b]]
        keys[hit] = -1 - hit

    def store_impulses(self):
        """Keep this step's impulses by ``contact_key``: normal as a number, friction as a world vector."""
        n = self.count
        b = self._buf
        keys = self.__dict__.get("_old_key_buffer")
        if keys is None or len(keys) < n:
            keys = self._old_key_buffer = np.zeros(max(2 * n, 64), dtype=np.int64)
        store_impulses_kernel(self.contacts.contact_key, self.normal_impulse, self.tangent_impulse, self.tangent1,
                              self.tangent2, keys, b["old_normal_impulse"], b["old_friction_impulse"])
        self._rolling_stored = len(self.rolling_rows) > 0
        if self._rolling_stored:
            store_rolling_kernel(n, self.contacts.contact_normal, self.tangent1, self.tangent2, self.rolling_impulse,
                                 b["old_rolling_impulse"])
        self.old_key = keys[:n]  # a view: prepare_contacts reads it before the next store writes
        self.old_count = n
