"""Islands and sleeping (Box2D v3 / Box3D semantics), once per step after ``collide``, before stepping.

Reads the step's contact pairs (C,), the coupling pairs (joints, springs) (K, 2), the packed
state ``Y`` (N, W) and ``World.moving``; writes ``SleepState`` (timers, awake, sleeping islands)
and zeroes P, L in ``Y`` of the bodies it puts to sleep.

Call order inside one step of dt (the lead's wiring, ``Simulator._advance_with_contacts``;
``all_moving`` is ``World.moving`` before masking, ``table = soft.pipeline.refresh()``)::

    sleep.resize(world.body_count)
    moving[:] = all_moving & sleep.awake        # sleeping bodies count as fixed from here on
    table.body_moving[:] = moving               # broadphase skips sleeping-sleeping/-fixed pairs
    active = soft.collide(Y, t, dt)             # still finds awake-sleeping contacts
    c = soft.contacts
    sleep.update(world, Y, c.contact_body_a, c.contact_body_b, dt, moving=all_moving)
    if sleep.woke.any() or sleep.fell_asleep.any():   # rare: the contact set changes
        moving[:] = all_moving & sleep.awake
        table.body_moving[:] = moving
        active = soft.collide(Y, t, dt)         # the woken islands' inner contacts
    soft.step(...) on active; the integrator for moving & ~active; then
    moving[:] = all_moving; table.body_moving[:] = all_moving   (also in ``finally``)

Restoring ``table.body_moving`` matters: ``SoftStep.has_collisions`` reads it, and with every
body asleep the free path would otherwise integrate them. Instead of colliding again, the
contacts may be filtered by ``contact_mask`` (any contact with an awake moving body is kept).
A user's velocity, pose change or impulse should call ``SleepState.wake``; a non-zero velocity
found on a sleeping body at ``update`` wakes it anyway.

``update`` uses the velocities at the start of the step (those the last step left), so a timer
lags Box2D's end-of-step timer by one step; the first ``update`` sees the initial velocities.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..forces import ConstantForce, CustomForce, PointForce
from ..body_motion import _load, _mat9, _velocities
from ..math3d import JIT

# Box3D's body sleep threshold (b3BodyDef.sleepThreshold, 0.05 m/s; Box2D v3's is the same).
LINEAR_SLEEP_TOLERANCE = 0.05  # m/s
# Box2D v2.4's b2_angularSleepTolerance: 2 degrees/s. For a 1 m cube (corner 0.87 m from its
# centre) this is a corner speed of 0.03 m/s, under the linear tolerance: neither test is much
# looser than the other for metre-sized bodies. NOTE: Box2D v3 instead compares
# max(|v|, extent |omega|) with the one threshold; a separate angular test needs no extent.
ANGULAR_SLEEP_TOLERANCE = math.radians(2.0)  # rad/s
# Box2D's b2_timeToSleep (v2.4 and v3): an island sleeps after 0.5 s below both tolerances.
TIME_TO_SLEEP = 0.5  # s
# A timer is summed from dt, so 0.5 s of 1/240 s steps may land just under 0.5: accept it.
_TIMER_ROUNDOFF = 1e-9

_NO_PAIRS = np.zeros((0, 2), dtype=np.int64)


# ---------------------------------------------------------------------- kernels
@njit(**JIT)
def _root(parent, i):
    """The root of i, halving the path on the way (Tarjan's path halving)."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(**JIT)
def _join(parent, moving, a, b):
    """Union of a's and b's sets when both are moving bodies (fixed ones do not link islands,
    Box2D). The larger root points to the smaller, so a root is its set's smallest index
    whatever the order of the pairs: ids are deterministic."""
    if a < 0 or b < 0 or a == b or not moving[a] or not moving[b]:
        return
    ra = _root(parent, a)
    rb = _root(parent, b)
    if ra < rb:
        parent[rb] = ra
    elif rb < ra:
        parent[ra] = rb


@njit(**JIT)
def _find_islands_kernel(body_a, body_b, extra_pairs, sleeping_island, moving,
                         # outputs
                         island):
    """island[i]: smallest body index of i's component (-1 for fixed bodies).

    Edges: contacts (body_a[c], body_b[c]), extra pairs (K, 2) (-1 ends: the world, ignored),
    and each sleeping body to the island it fell asleep with (``sleeping_island`` >= 0), so a
    sleeping island stays whole even when its inner contacts are no longer detected.
    """
    n = moving.shape[0]
    for i in range(n):
        island[i] = i
    for c in range(body_a.shape[0]):
        _join(island, moving, body_a[c], body_b[c])
    for k in range(extra_pairs.shape[0]):
        _join(island, moving, extra_pairs[k, 0], extra_pairs[k, 1])
    for i in range(n):
        _join(island, moving, i, sleeping_island[i])
    # ascending order: island[root] = root is final before any body of its set is reached
    for i in range(n):
        island[i] = _root(island, i) if moving[i] else -1


@njit(**JIT)
def _update_sleep_kernel(island, moving, allow_sleep, keep_awake, speed, angular_speed, dt,
                         linear_tolerance, angular_tolerance, time_to_sleep, enabled,
                         # outputs
                         timer, awake, sleeping_island, woke, fell_asleep, island_awake, island_timer):
    """Wake touched islands, tick the timers, put islands to sleep whose smallest timer is due.

    island (N,) from ``_find_islands_kernel``; speed, angular_speed (N,) m/s, rad/s at the start
    of the step. A sleeping body with a non-zero speed was moved by the user (a velocity set,
    an impulse): it wakes, and so does every body kept awake (``keep_awake``, driven bodies).
    """
    n = moving.shape[0]
    for i in range(n):
        island_awake[i] = False
        island_timer[i] = np.inf
        woke[i] = False
        fell_asleep[i] = False
    # 1. a component with one awake (or disturbed) body wakes whole (Box2D b2WakeIslands)
    for i in range(n):
        if not moving[i]:
            continue
        if awake[i] or not enabled or not allow_sleep[i] or keep_awake[i] or speed[i] > 0.0 \
                or angular_speed[i] > 0.0:
            island_awake[island[i]] = True
    for i in range(n):
        if moving[i] and not awake[i] and island_awake[island[i]]:
            awake[i] = True
            woke[i] = True
            timer[i] = 0.0
    # 2. timers of the awake bodies (Box2D v3 b2FinalizeBodies); the smallest per island
    for i in range(n):
        if not moving[i]:
            awake[i] = True
            timer[i] = 0.0
            sleeping_island[i] = -1
            continue
        if not awake[i]:
            continue
        sleeping_island[i] = -1
        still = speed[i] < linear_tolerance and angular_speed[i] < angular_tolerance
        if enabled and allow_sleep[i] and not keep_awake[i] and still and not woke[i]:
            timer[i] += dt
        else:
            timer[i] = 0.0
        r = island[i]
        island_timer[r] = min(island_timer[r], timer[i])
    # 3. an island whose every body has rested time_to_sleep falls asleep together
    due = time_to_sleep * (1.0 - _TIMER_ROUNDOFF)
    for i in range(n):
        if moving[i] and awake[i] and island_timer[island[i]] >= due:
            awake[i] = False
            fell_asleep[i] = True
            sleeping_island[i] = island[i]


@njit(**JIT)
def _speeds_kernel(layout, Y, inv_mass, inertia_body_inv, moving,
                   # outputs
                   speed, angular_speed):
    """|v| = |P| / m (m/s) and |omega| = |I^-1 L| (rad/s) of each moving body of Y (N, W)."""
    for i in range(Y.shape[0]):
        if not moving[i]:
            speed[i] = 0.0
            angular_speed[i] = 0.0
            continue
        _x, o, P, L = _load(layout, Y, i)
        _R, v, w = _velocities(layout, o, P, L, inv_mass[i], _mat9(inertia_body_inv, i))
        speed[i] = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
        angular_speed[i] = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])


@njit(**JIT)
def _zero_momenta_kernel(Y, bodies):
    """P = L = 0 (the last six columns of Y (N, W)) for the bodies where ``bodies`` (N,) is True."""
    W = Y.shape[1]
    for i in range(Y.shape[0]):
        if bodies[i]:
            for k in range(W - 6, W):
                Y[i, k] = 0.0


@njit(**JIT)
def _held_kernel(contact_a, contact_b, support_pairs, moving, island, keep,
                 # outputs
                 held, keep_out):
    """The sleep stage's support rule (``SleepState.update_arrays``): ``held`` (n,) bool, zeroed by
    the caller, set for each island with a moving body that a contact (``contact_a``, ``contact_b``
    (C,)) or a support pair (``support_pairs`` (S, 2), -1: the world) joins to something that does not
    move (out of range: the world; or a body not ``moving``); ``keep_out`` (n,) = ``keep`` or a moving
    body whose island is not held. PERF: one compiled pass; the NumPy form (15 small array
    operations) took 20 us of a cartpole's 150 us step (a performance audit, session 43)."""
    n = moving.shape[0]
    C = contact_a.shape[0]
    for k in range(C + support_pairs.shape[0]):
        if k < C:
            x, y = contact_a[k], contact_b[k]
        else:
            x, y = support_pairs[k - C, 0], support_pairs[k - C, 1]
        for side in range(2):
            this, other = (x, y) if side == 0 else (y, x)
            if this >= 0 and this < n and moving[this] and (other < 0 or other >= n or not moving[other]):
                held[island[this]] = True
    for i in range(n):
        keep_out[i] = keep[i] or (moving[i] and not held[max(island[i], 0)])


@njit(**JIT)
def _contact_mask_kernel(body_a, body_b, awake, moving,
                         # outputs
                         keep):
    for c in range(body_a.shape[0]):
        a = body_a[c]
        b = body_b[c]
        keep[c] = (moving[a] and awake[a]) or (moving[b] and awake[b])


# ---------------------------------------------------------------------- functions
def _pairs(extra_pairs) -> np.ndarray:
    if extra_pairs is None or len(extra_pairs) == 0:
        return _NO_PAIRS
    return np.ascontiguousarray(np.asarray(extra_pairs, dtype=np.int64).reshape(-1, 2))


def _indices(a) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(a, dtype=np.int64).reshape(-1))


def find_islands(body_a, body_b, moving, extra_pairs=None) -> np.ndarray:
    """Islands: connected components of moving bodies through contacts and extra pairs.

    Args:
        body_a, body_b: (C,) int64 body indices of the step's contacts (``contact_body_a/b``).
        moving: (N,) bool, ``World.moving``; fixed bodies do not connect islands (Box2D).
        extra_pairs: (K, 2) int64 body pairs that also connect (joints, springs); -1 is the
            world and connects nothing. Default: none.

    Returns:
        (N,) int64: per body the smallest body index of its island, -1 for fixed bodies.
    """
    moving = np.ascontiguousarray(moving, dtype=np.bool_)
    island = np.empty(len(moving), dtype=np.int64)
    none = np.full(len(moving), -1, dtype=np.int64)
    _find_islands_kernel(_indices(body_a), _indices(body_b), _pairs(extra_pairs), none, moving, island)
    return island


def contact_mask(body_a, body_b, awake, moving) -> np.ndarray:
    """(C,) bool: the contacts to solve, those with at least one awake moving body.

    After ``SleepState.update`` a contact between an awake and a sleeping body cannot remain
    (it woke the sleeping island), so the dropped ones are sleeping-sleeping and sleeping-fixed.
    Args: body_a, body_b (C,) int64; awake, moving (N,) bool.
    """
    body_a = _indices(body_a)
    keep = np.empty(len(body_a), dtype=np.bool_)
    _contact_mask_kernel(body_a, _indices(body_b), np.ascontiguousarray(awake, dtype=np.bool_),
                         np.ascontiguousarray(moving, dtype=np.bool_), keep)
    return keep


def coupling_pairs(world) -> np.ndarray:
    """(K, 2) int64 body pairs that join islands besides contacts: every joint of ``world.joints``
    and every spring of the world's force tables (-1: the world end)."""
    rows = []
    for j in world.joints:
        if j.bound is not None:  # (a gear's bodies are its joints', in its bound row)
            rows.append([j.bound.body_a, j.bound.body_b])
            continue
        ends = []
        for body in (j.body_a, j.body_b):
            ends.append(-1 if body is None or (isinstance(body, str) and body == "world") else world.index_of(body))
        rows.append(ends)
    springs = world.tables.spring_body
    pairs = np.array(rows, dtype=np.int64).reshape(-1, 2)
    return np.ascontiguousarray(np.concatenate([pairs, springs.reshape(-1, 2)]).astype(np.int64))


def driven_bodies(world) -> np.ndarray:
    """(N,) bool: bodies under a ConstantForce, PointForce or CustomForce. Box2D wakes a body each
    time a force is applied to it; a force record acts every step, so these bodies never sleep.
    (Drag and gravity do not keep a body awake; springs join islands instead, ``coupling_pairs``.)"""
    driven = np.zeros(world.body_count, dtype=bool)
    for f in world.forces:
        if isinstance(f, (ConstantForce, PointForce)):
            driven[world.index_of(f.body)] = True
        elif isinstance(f, CustomForce):
            if f.bodies is None:
                driven[:] = True
            else:
                for b in f.bodies:
                    driven[world.index_of(b)] = True
    return driven


# ---------------------------------------------------------------------- state
class SleepState:
    """Per-body sleep bookkeeping of one World (Box2D v3 semantics; see the module docstring).

    Args:
        body_count: N (grows with ``resize``; new bodies start awake).
        enabled: world-level switch (default True); off, every body is awake and no timer runs.
        linear_tolerance: m/s (default 0.05, Box3D's). angular_tolerance: rad/s (default 2 deg/s,
            Box2D's b2_angularSleepTolerance). time_to_sleep: s (default 0.5, Box2D's).

    Attributes, (N,) each, body order:
        sleep_timer: float, s a body has stayed under both tolerances (state).
        awake: bool, False for a sleeping moving body; fixed bodies count as awake (state).
        allow_sleep: bool, per-body switch (default True; ``set_allow_sleep``) (state).
        sleeping_island: int64, the island id a sleeping body fell asleep with, -1 if awake (state).
        island: int64, the islands of the last ``update`` (-1: fixed).
        woke, fell_asleep: bool, what the last ``update`` changed.
        speed, angular_speed: float, m/s and rad/s at the start of the last ``update``'s step.
        resting: {field: (C,) or (C, 3)} the contacts of the sleeping islands (``Contacts``' fields
            but the names; ``keep_resting``: the contacts found as an island falls asleep, with
            its last step's impulses): a body asleep
            still rests on what it rests on, and ``Simulator.contacts()`` reports it (Box2D keeps
            a sleeping body's contacts; PyBullet's getContactPoints returns them) (state).
    """

    STATE_KEYS = ("sleep_timer", "awake", "allow_sleep", "sleeping_island")
    # the resting contacts' fields: (name, dtype, trailing shape)
    RESTING_FIELDS = (("body_a", np.int64, ()), ("body_b", np.int64, ()), ("part_a", np.int64, ()),
                      ("part_b", np.int64, ()), ("point", float, (3,)), ("normal", float, (3,)),
                      ("separation", float, ()), ("normal_impulse", float, ()), ("friction_impulse", float, (3,)),
                      ("force", float, (3,)))

    def __init__(self, body_count: int = 0, enabled: bool = True, linear_tolerance: float = LINEAR_SLEEP_TOLERANCE,
                 angular_tolerance: float = ANGULAR_SLEEP_TOLERANCE, time_to_sleep: float = TIME_TO_SLEEP):
        self.enabled = bool(enabled)
        self.linear_tolerance = float(linear_tolerance)
        self.angular_tolerance = float(angular_tolerance)
        self.time_to_sleep = float(time_to_sleep)
        self.body_count = 0
        self.sleep_timer = np.zeros(0)
        self.awake = np.ones(0, dtype=bool)
        self.allow_sleep = np.ones(0, dtype=bool)
        self.sleeping_island = np.full(0, -1, dtype=np.int64)
        self._coupling_key = None
        self._coupling = (_NO_PAIRS, np.zeros(0, dtype=bool))
        self.resting = {name: np.zeros((0,) + shape, dtype=dtype) for name, dtype, shape in self.RESTING_FIELDS}
        self.resize(body_count)

    # -- sizes -----------------------------------------------------------------------
    def resize(self, body_count: int):
        """Grow (or shrink) to N bodies; new bodies are awake, with timer 0 and sleep allowed.
        Allocates only when N changes (the step's scratch arrays live here)."""
        n = int(body_count)
        if n == self.body_count and len(self.sleep_timer) == n:
            return
        m = min(n, self.body_count)

        def grown(old, fill, dtype):
            new = np.full(n, fill, dtype=dtype)
            new[:m] = old[:m]
            return new

        self.sleep_timer = grown(self.sleep_timer, 0.0, float)
        self.awake = grown(self.awake, True, bool)
        self.allow_sleep = grown(self.allow_sleep, True, bool)
        self.sleeping_island = grown(self.sleeping_island, -1, np.int64)
        self.island = np.full(n, -1, dtype=np.int64)
        self.woke = np.zeros(n, dtype=bool)
        self.fell_asleep = np.zeros(n, dtype=bool)
        self.speed = np.zeros(n)
        self.angular_speed = np.zeros(n)
        self._island_awake = np.zeros(n, dtype=bool)
        self._island_timer = np.zeros(n)
        self._no_driven = np.zeros(n, dtype=bool)
        self.body_count = n

    @property
    def sleeping(self) -> np.ndarray:
        """(N,) bool: the sleeping bodies (never a fixed one)."""
        return ~self.awake

    # -- the step --------------------------------------------------------------------
    def update(self, world, Y, contact_body_a, contact_body_b, dt: float, extra_pairs=None, keep_awake=None,
               moving=None, also_awake=None) -> np.ndarray:
        """The sleep stage of one step, after ``collide`` and before the bodies move.

        Args:
            world: the World (``moving``, ``inv_mass``, ``inertia_body_inv``, joints, forces).
            Y: (N, W) the packed state at the start of the step; the P, L of the bodies put to
                sleep are set to zero in place.
            contact_body_a, contact_body_b: (C,) int64, the step's contacts (all of them).
            dt: s, the step.
            extra_pairs: (K, 2) int64 pairs that join islands; default ``coupling_pairs(world)``.
            keep_awake: (N,) bool bodies that may not sleep; default ``driven_bodies(world)``.
            moving: (N,) bool, the World's ``moving`` before any masking by the step (sleeping
                bodies included); default ``world.moving`` (right only when it is not masked).
            also_awake: (N,) bool bodies kept awake this step on top of ``keep_awake`` (those a
                moving kinematic body touches or nears: ``Simulator._touched_by_kinematic``).

        Returns:
            ``awake`` (N,) bool (the state's own array: copy it to keep it).
        """
        self.resize(world.body_count)
        pairs, driven = self._world_coupling(world)
        extra_pairs = pairs if extra_pairs is None else extra_pairs
        keep_awake = driven if keep_awake is None else keep_awake
        if also_awake is not None:
            keep_awake = np.asarray(keep_awake, dtype=bool) | also_awake
        moving = world.moving if moving is None else moving
        moving = np.ascontiguousarray(moving, dtype=np.bool_)
        _speeds_kernel(world.layout_id, Y, world.inv_mass, world.inertia_body_inv, moving, self.speed, self.angular_speed)
        # what holds the islands up besides the step's contacts: the joints and springs (to the
        # world or to a fixed body) and the kept contacts of the sleeping islands (not collided again)
        resting_a = self.resting["body_a"]
        support = pairs if len(resting_a) == 0 else \
            np.concatenate([pairs, np.stack([resting_a, self.resting["body_b"]], axis=1).astype(np.int64).reshape(-1, 2)])
        awake = self.update_arrays(moving, self.speed, self.angular_speed, contact_body_a, contact_body_b, dt,
                                   extra_pairs, keep_awake, support)
        if self.fell_asleep.any():
            _zero_momenta_kernel(Y, self.fell_asleep)
        return awake

    def update_arrays(self, moving, speed, angular_speed, contact_body_a, contact_body_b, dt: float,
                      extra_pairs=None, keep_awake=None, support_pairs=None) -> np.ndarray:
        """``update`` on plain arrays (no World, no state to zero): moving (N,) bool; speed,
        angular_speed (N,) m/s, rad/s; contacts (C,) int64; extra_pairs (K, 2) int64 or None;
        keep_awake (N,) bool or None; support_pairs (S, 2) int64 (-1: the world) or None: with
        them, only an island held by something that does not move may sleep (below). The
        caller zeroes the velocities of ``fell_asleep``."""
        n = len(moving)
        self.resize(n)
        moving = np.ascontiguousarray(moving, dtype=np.bool_)
        keep = self._no_driven if keep_awake is None else np.ascontiguousarray(keep_awake, dtype=np.bool_)
        _find_islands_kernel(_indices(contact_body_a), _indices(contact_body_b), _pairs(extra_pairs),
                             self.sleeping_island, moving, self.island)
        if support_pairs is not None:
            # Only an island held by something that does not move (a contact with a fixed or
            # kinematic body, a joint or a spring to the world or to one) may sleep: a body in free
            # flight keeps its momentum. NOTE: why: Box2D's rule (any island slower than the
            # tolerances for 0.5 s) stopped a box drifting at 2 cm/s with no gravity, in any world
            # with a second shape (a course audit, session 42): sleeping is for bodies at rest on
            # or hanging from something.
            held = np.zeros(n, dtype=np.bool_)
            keep_out = np.empty(n, dtype=np.bool_)
            _held_kernel(_indices(contact_body_a), _indices(contact_body_b), _pairs(support_pairs), moving,
                         self.island, keep, held, keep_out)
            keep = keep_out
        _update_sleep_kernel(self.island, moving, self.allow_sleep, keep,
                             np.ascontiguousarray(speed, dtype=float), np.ascontiguousarray(angular_speed, dtype=float),
                             float(dt), self.linear_tolerance, self.angular_tolerance, self.time_to_sleep, self.enabled,
                             self.sleep_timer, self.awake, self.sleeping_island, self.woke, self.fell_asleep,
                             self._island_awake, self._island_timer)
        return self.awake

    def _world_coupling(self, world):
        """``coupling_pairs`` and ``driven_bodies`` of the world, rebuilt when its forces, joints or
        bodies change (the force tables are a new object then)."""
        key = (world.tables, len(world.joints), world.body_count)
        old = self._coupling_key
        if old is None or old[0] is not key[0] or old[1:] != key[1:]:
            self._coupling = (coupling_pairs(world), driven_bodies(world))
            self._coupling_key = key
        return self._coupling

    # -- the user's side -------------------------------------------------------------
    def _mask(self, bodies) -> np.ndarray:
        """(N,) bool of ``bodies``: a bool mask (N,), indices, or objects with ``.index`` (Body)."""
        if isinstance(bodies, np.ndarray) and bodies.dtype == np.bool_:
            return bodies.reshape(-1)[: self.body_count].copy()
        def is_body(b):
            return isinstance(getattr(b, "index", None), (int, np.integer))

        if np.isscalar(bodies) or is_body(bodies):
            bodies = [bodies]
        idx = [int(b.index) if is_body(b) else int(b) for b in bodies]
        mask = np.zeros(self.body_count, dtype=bool)
        mask[idx] = True
        return mask

    def wake(self, bodies):
        """Wake ``bodies`` and, with each, the whole island it sleeps in (timers back to 0).

        Call it when the user applies a force or an impulse, or sets a velocity or a pose
        (Box2D's b2Body_ApplyForce / SetLinearVelocity wake the body). A non-zero velocity
        found on a sleeping body at ``update`` wakes it as well.
        """
        mask = self._mask(bodies)
        # the sleepers resting on a woken body wake with it: a fixed body (a shelf, a platform) is
        # in no island. NOTE: why: a fixed platform's filter changed under a ball asleep on it
        # left the ball hovering on its kept contacts (session 42's audit); a moving body's
        # resting partners are in its island already.
        a, b = self.resting["body_a"], self.resting["body_b"]
        if len(a):
            n = self.body_count
            ia, ib = (a >= 0) & (a < n), (b >= 0) & (b < n)
            touching = np.zeros(len(a), dtype=bool)
            touching[ia] |= mask[a[ia]]
            touching[ib] |= mask[b[ib]]
            # only the sleepers: a woken brick's ground in the mask forgot every other island's
            # contacts with the ground (a crate tower asleep far away lost what it rests on)
            for ends, inside in ((a, ia), (b, ib)):
                pick = ends[touching & inside]
                mask[pick[self.sleeping_island[pick] >= 0]] = True
        islands = np.unique(self.sleeping_island[mask & ~self.awake])
        mask |= np.isin(self.sleeping_island, islands[islands >= 0])
        self.awake[mask] = True
        self.sleep_timer[mask] = 0.0
        self.sleeping_island[mask] = -1
        self._forget_resting(mask)

    def wake_all(self):
        """Every body awake, every timer at 0 (as Box2D does when sleeping is switched off)."""
        self.awake[:] = True
        self.sleep_timer[:] = 0.0
        self.sleeping_island[:] = -1
        self._forget_resting(np.ones(self.body_count, dtype=bool))

    def _forget_resting(self, woken):
        """Drop the resting contacts of the bodies ``woken`` (N,) bool: they are found again by the
        collide while awake, and kept anew if the body falls asleep. Kept, they came back as the
        body fell asleep elsewhere (``resting_contacts`` reads whether the bodies sleep, not
        where): a box woken by an impulse, slid off its shelf and asleep on the ground reported its
        four shelf contacts beside the ground's (``keep_resting`` runs only when ``update`` wakes
        or puts a body to sleep, not after a wake from outside)."""
        a, b = self.resting["body_a"], self.resting["body_b"]
        if len(a) == 0:
            return
        n = len(woken)
        gone = np.zeros(len(a), dtype=bool)
        for rows in (a, b):
            inside = (rows >= 0) & (rows < n)
            gone[inside] |= woken[rows[inside]]
        if gone.any():
            self.resting = {k: v[~gone] for k, v in self.resting.items()}

    def set_allow_sleep(self, bodies, flag: bool):
        """Per-body switch; forbidding sleep wakes the body and its island (Box2D b2Body_EnableSleep)."""
        mask = self._mask(bodies)
        self.allow_sleep[mask] = bool(flag)
        if not flag:
            self.wake(mask)

    # -- checkpoints -----------------------------------------------------------------
    def state(self) -> dict:
        """Copies of the state arrays: sleep_timer (N,) s, awake (N,), allow_sleep (N,), sleeping_island
        (N,), and the resting contacts as ``resting_FIELD`` (C,) or (C, 3)."""
        out = {k: getattr(self, k).copy() for k in self.STATE_KEYS}
        out.update({"resting_" + k: v.copy() for k, v in self.resting.items()})
        return out

    # -- the contacts of sleeping islands ------------------------------------------------
    def keep_resting(self, contacts, moving):
        """After an ``update``: forget the resting contacts of bodies awake again, and keep those of
        ``contacts`` (those of the bodies fallen asleep, {field: array} as
        ``SoftStep.resting_fields``; None: none kept) whose two bodies are each asleep or fixed,
        one of them fallen asleep at this update. ``moving`` (N,) bool: the world's moving bodies."""
        r = self.resting
        parts = [self.resting_contacts(moving)]
        if contacts is not None and len(contacts["body_a"]) and self.fell_asleep.any():
            a, b = contacts["body_a"], contacts["body_b"]
            new = self._asleep_or_fixed(moving, a, b) & (self.fell_asleep[a] | self.fell_asleep[b])
            parts.append({name: contacts[name][new] for name, _dtype, _shape in self.RESTING_FIELDS})
        self.resting = {k: np.concatenate([p[k] for p in parts]) for k in r}

    def resting_contacts(self, moving) -> dict:
        """The resting contacts whose bodies are still each asleep or fixed (a body woken since by
        the user, ``wake``, is left out): {field: array}."""
        a, b = self.resting["body_a"], self.resting["body_b"]
        if len(a) == 0 or len(moving) < self.body_count:
            return {k: v[:0] for k, v in self.resting.items()}
        # (bodies added since the last update come after these rows' bodies: ``moving`` may be longer)
        keep = self._asleep_or_fixed(moving, a, b)
        return {k: v[keep] for k, v in self.resting.items()}

    def _asleep_or_fixed(self, moving, a, b) -> np.ndarray:
        """(C,) bool: contacts between bodies ``a`` and ``b`` (C,) that are each asleep or fixed."""
        return (~moving[a] | ~self.awake[a]) & (~moving[b] | ~self.awake[b])

    def set_state(self, state: dict):
        """Restore ``state()``. All arrays must have one length N. Without ``sleeping_island``
        (an older checkpoint) each sleeping body is its own island until contacts join them."""
        n = len(state["awake"])
        self.resize(n)
        for key, dtype in (("sleep_timer", float), ("awake", bool), ("allow_sleep", bool)):
            value = np.asarray(state[key], dtype=dtype).reshape(-1)
            if len(value) != n:
                raise ValueError(f"sleep state {key!r} has {len(value)} rows, expected {n}")
            getattr(self, key)[:] = value
        if "sleeping_island" in state:
            self.sleeping_island[:] = np.asarray(state["sleeping_island"], dtype=np.int64).reshape(n)
        else:
            self.sleeping_island[:] = np.where(self.awake, -1, np.arange(n))
        # the resting contacts (none in a checkpoint made before session 34)
        self.resting = {name: np.asarray(state.get("resting_" + name, np.zeros((0,) + shape)),
                                         dtype=dtype).reshape((-1,) + shape)
                        for name, dtype, shape in self.RESTING_FIELDS}
