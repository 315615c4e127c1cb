"""Contact events: which pairs of bodies began and ended touching, step by step (Box2D v3's
``b2World_GetContactEvents``: begin and end touch, with a hit's approach speed).

A pair of bodies *touches* in a step when the contact solver pushed between them in that step
(the step's normal impulse of one of their points is above zero): a resting box touches the
ground, a ball passing within the speculative distance without landing does not. A pair begins
touching in the first step it touches and ends in the first step it no longer does. A pair
whose two bodies are out of the step (asleep, or fixed) keeps the state it had: an island
falling asleep on the ground ends nothing, and its waking begins nothing.

Each begin event carries the end time of its step (s), the point of the pair's contact that
pushed hardest (m, world) and the approach speed (m/s): the largest normal speed at which the
pair's points closed at the step's start (``relative_velocity``, the speed restitution
reflects), the figure to scale an impact sound or a damage model by (Box2D's hit events).
Each end event carries its time.

Opt-in (``Simulator(..., contact_events=True)``): the bookkeeping is a sort of the step's
touching pairs, NumPy work of the order of the contact count every step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_EMPTY = np.zeros(0, dtype=np.int64)


@dataclass
class ContactEvents:
    """Events since the last read, in the order they happened (within a step by body pair).

    Attributes:
        begin_body_a, begin_body_b: (B,) int64 body indices (a < b) of the pairs that began touching.
        begin_time: (B,) s, the end of the step in which they did.
        begin_point: (B, 3) m, world, the contact point that pushed hardest.
        begin_approach_speed: (B,) m/s >= 0, how fast the pair closed at the step's start.
        end_body_a, end_body_b: (E,) int64 (a < b) of the pairs that stopped touching.
        end_time: (E,) s.
    """

    begin_body_a: np.ndarray
    begin_body_b: np.ndarray
    begin_time: np.ndarray
    begin_point: np.ndarray
    begin_approach_speed: np.ndarray
    end_body_a: np.ndarray
    end_body_b: np.ndarray
    end_time: np.ndarray


class ContactEventLog:
    """The touching pairs of the last step (sorted keys lo * N + hi) and the events not yet read."""

    def __init__(self):
        self.touching = _EMPTY
        self.body_count = 0
        self._begin: list[tuple] = []
        self._end: list[tuple] = []

    def after_step(self, soft, awake_moving: np.ndarray, t_end: float):
        """Update from the soft step's last contacts (``soft.contacts``, the solver's per-point
        ``step_normal_impulse`` and ``relative_velocity``); ``awake_moving`` (N,) bool: the bodies
        this step moved (neither fixed nor asleep)."""
        N = awake_moving.shape[0]
        prev = self.touching
        if N != self.body_count and len(prev):  # bodies were added: the keys' base changes
            lo, hi = np.divmod(prev, self.body_count)
            prev = lo * N + hi
        self.body_count = N
        c = soft.contacts
        if c is None or c.contact_count == 0 or soft.solver.count != c.contact_count:  # (no solve this step)
            keys = _EMPTY
            pushed = np.zeros(0, dtype=bool)
        else:
            a, b = c.contact_body_a, c.contact_body_b
            keys = np.minimum(a, b) * N + np.maximum(a, b)
            pushed = soft.solver.step_normal_impulse > 0.0
        now = np.unique(keys[pushed])
        plo, phi = np.divmod(prev, N) if len(prev) else (_EMPTY, _EMPTY)
        kept = prev[~awake_moving[plo] & ~awake_moving[phi]]  # both out of the step: unchanged
        now = np.union1d(now, kept)
        begin = np.setdiff1d(now, prev, assume_unique=True)
        end = np.setdiff1d(prev, now, assume_unique=True)
        if len(begin):
            sol = soft.solver
            jn = sol.step_normal_impulse
            approach = -sol.relative_velocity
            # each begun pair's points: a range of the contacts sorted by pair (not a scan of all
            # contacts per pair: a pile landing begins a thousand pairs in a step)
            order = np.argsort(keys, kind="stable")
            first = np.searchsorted(keys[order], begin, side="left")
            last = np.searchsorted(keys[order], begin, side="right")
            for key, i, j in zip(begin, first, last):
                rows = order[i:j]
                rows = rows[pushed[rows]]
                strongest = rows[np.argmax(jn[rows])]
                self._begin.append((key // N, key % N, t_end, c.contact_point[strongest].copy(),
                                    max(0.0, float(approach[rows].max()))))
        for key in end:
            self._end.append((key // N, key % N, t_end))
        self.touching = now

    def pairs(self) -> list[list[int]]:
        """The touching pairs [a, b] (a < b) after the last step (for checkpoints)."""
        if not len(self.touching):
            return []
        lo, hi = np.divmod(self.touching, self.body_count)
        return [[int(a), int(b)] for a, b in zip(lo, hi)]

    def set_pairs(self, pairs, body_count: int):
        """Inverse of ``pairs``: a resumed run begins no touch that was already on."""
        self.body_count = int(body_count)
        self.touching = np.unique(np.array([a * body_count + b for a, b in pairs], dtype=np.int64))

    def drain(self) -> ContactEvents:
        """The events since the last call, and forget them."""
        b, e = self._begin, self._end
        self._begin, self._end = [], []
        return ContactEvents(
            begin_body_a=np.array([x[0] for x in b], dtype=np.int64),
            begin_body_b=np.array([x[1] for x in b], dtype=np.int64),
            begin_time=np.array([x[2] for x in b], dtype=float),
            begin_point=np.array([x[3] for x in b], dtype=float).reshape(-1, 3),
            begin_approach_speed=np.array([x[4] for x in b], dtype=float),
            end_body_a=np.array([x[0] for x in e], dtype=np.int64),
            end_body_b=np.array([x[1] for x in e], dtype=np.int64),
            end_time=np.array([x[2] for x in e], dtype=float),
        )
