"""The contact solve in spatial slabs (``SoftStepSettings.partitions``,
``solver.partition.partition_pairs_kernel``): a large step's contacts are swept slab by slab on
both cores, then the contacts that join two slabs.

What is checked: the partitions share no moving body (else two threads would write one body's
velocity), the order is a stable permutation, the bits do not depend on the number of threads,
and the solve in slabs holds a stack and a pyramid as the plain sweep does (a different
Gauss-Seidel order: the same physics, other bits).
"""

import numba
import numpy as np
import pytest

import tumble as tb
from tumble.solver.contact import SoftStepSettings
from tumble.solver.partition import partition_pairs_kernel

from ..threads import numba_threads


def _partition(body_a, body_b, moving, x, parts):
    n = len(moving)
    body_part = np.zeros(n, dtype=np.int64)
    order = np.zeros(len(body_a), dtype=np.int64)
    bounds = np.zeros(parts + 2, dtype=np.int64)
    partition_pairs_kernel(np.asarray(body_a, dtype=np.int64), np.asarray(body_b, dtype=np.int64),
                              np.asarray(moving), np.asarray(x, dtype=float), parts, body_part, order, bounds)
    return body_part, order, bounds


@pytest.mark.parametrize("parts", [2, 3, 5])
def test_partitions_share_no_moving_body_and_keep_the_contacts_order(parts):
    # random contacts among 200 bodies scattered in a long box (x spreads most), body 0 fixed
    # (the ground: in contacts of every slab); compared with the definition, contact by contact
    rng = np.random.default_rng(7)
    n, c = 200, 1500
    x = rng.uniform((-20, -2, 0), (20, 2, 3), size=(n, 3))
    x = x[np.argsort(x[:, 0])]  # so that bodies close in index are close in space, as in contact
    moving = np.ones(n, dtype=bool)
    moving[0] = False
    body_a = rng.integers(0, n, size=c)
    body_b = (body_a + rng.integers(1, 12, size=c)) % n  # near neighbours (and a few across the wrap)
    body_part, order, bounds = _partition(body_a, body_b, moving, x, parts)

    assert sorted(order) == list(range(c))  # a permutation
    assert bounds[0] == 0 and bounds[-1] == c and np.all(np.diff(bounds) >= 0)
    # slabs along x, of equal counts (within one body), cut in the order of x
    involved = np.unique(np.concatenate([body_a, body_b]))
    involved = involved[moving[involved]]
    assert body_part[0] == -1
    counts = np.bincount(body_part[involved], minlength=parts)
    assert counts.max() - counts.min() <= 1
    for p in range(parts - 1):
        assert x[involved[body_part[involved] == p], 0].max() <= x[involved[body_part[involved] == p + 1], 0].min()
    # each group holds the contacts of its definition, in their own order (stable)
    owner = {}
    for g in range(parts + 1):
        rows = order[bounds[g]:bounds[g + 1]]
        assert np.all(np.diff(rows) > 0)
        for r in rows:
            pa = body_part[body_a[r]] if moving[body_a[r]] else -1
            pb = body_part[body_b[r]] if moving[body_b[r]] else -1
            expect = pa if pb in (-1, pa) else (pb if pa == -1 else parts)
            assert g == expect
            if g < parts:  # no moving body in two partitions
                for b in (body_a[r], body_b[r]):
                    if moving[b]:
                        assert owner.setdefault(b, g) == g
    assert bounds[parts + 1] - bounds[parts] < c / 4  # few contacts cross a cut: the point of slabs


def _pile_bits(threads, **settings):
    from tumble.scenes.contact import pile

    with numba_threads(threads):
        w, _ = pile(125)
        w.sleeping = False
        sim = tb.Simulator(w, dt=1.0 / 60.0, contact_settings=SoftStepSettings(**settings))
        sim.run(1.0, frame_rate=4)
        return w.pack().tobytes(), sim.soft_step.solver


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two threads")
def test_partitioned_solve_gives_the_same_bits_on_one_and_two_threads():
    # 125 boxes falling into a pile, 1 s at dt 1/60 s: about 500 contact points at the end, every
    # step partitioned (partition_min_contacts = 0); the state must be equal bit for bit
    two, solver = _pile_bits(2, partition_min_contacts=0)
    one, _ = _pile_bits(1, partition_min_contacts=0)
    bounds = solver.sweep.bounds
    assert solver.sweep.partitioned and bounds[1] > 0 and bounds[2] > bounds[1]
    assert two == one
    # and the order matters: the plain sweep (partitions = 1) is another Gauss-Seidel order
    plain, solver = _pile_bits(2, partitions=1)
    assert not solver.sweep.partitioned
    assert plain != two


def test_small_steps_keep_the_plain_order():
    # below partition_min_contacts the sweep is the narrowphase's order: bounds [0, C]
    _, solver = _pile_bits(2)
    assert solver.count < SoftStepSettings().partition_min_contacts
    assert not solver.sweep.partitioned
    assert list(solver.sweep.bounds) == [0, solver.count]
    assert np.array_equal(solver.sweep.order[:solver.count], np.arange(solver.count))
    # and after partitioned steps, a step below the threshold goes back to that order
    _, solver = _pile_bits(2, partition_min_contacts=0)
    assert solver.sweep.partitioned
    assert not np.array_equal(solver.sweep.order[:solver.count], np.arange(solver.count))
    c = solver.contacts
    solver.sweep.update(c.contact_body_a, c.contact_body_b, solver.world.moving, solver.x, 2,
                        solver.count + 1)
    assert not solver.sweep.partitioned and list(solver.sweep.bounds) == [0, solver.count]
    assert np.array_equal(solver.sweep.order[:solver.count], np.arange(solver.count))


@pytest.mark.slow
def test_tower_and_pyramid_stand_when_solved_in_slabs():
    # Issue 3's tower (10 cubes, cut between the 5th and 6th: the seam is the contact there)
    # and the 20-row pyramid (cut down its middle), every step in two slabs, at the default dt,
    # against the acceptance bounds that the plain sweep meets (tests/physics/test_contact.py):
    # tower top under 1 cm in 30 s, pyramid boxes under 1 cm in 10 s and at rest. Sleeping off,
    # so that every step is solved in slabs.
    from tumble.scenes.contact import pyramid, tower

    settings = SoftStepSettings(partition_min_contacts=0)
    w, _ = tower(10)
    w.sleeping = False
    top0 = w.x[-1].copy()
    sim = tb.Simulator(w, contact_settings=settings)
    sim.run(30.0, frame_rate=1)
    assert sim.soft_step.solver.sweep.partitioned
    assert np.linalg.norm(w.x[-1] - top0) < 0.01

    w, _ = pyramid(20)
    w.sleeping = False
    x0 = w.x.copy()
    sim = tb.Simulator(w, contact_settings=settings)
    sim.run(10.0, frame_rate=2)
    assert sim.soft_step.solver.sweep.partitioned
    assert np.linalg.norm(w.x - x0, axis=1).max() < 0.01
    assert np.abs(w.v).max() < 0.01


def test_partitioned_run_resumes_from_a_checkpoint_bit_for_bit(tmp_path):
    # the slabs are derived from the state at each step and the settings are saved with the
    # checkpoint, so a resumed partitioned run continues with the same bits (125 boxes, every
    # step partitioned, 0.5 s then 0.5 s against 1 s in one go)
    from tumble.checks import state_hash
    from tumble.scenes.contact import pile

    settings = SoftStepSettings(partition_min_contacts=0)

    def start():
        w, _ = pile(125)
        return tb.Simulator(w, dt=1.0 / 60.0, contact_settings=settings)

    whole = start()
    whole.run(1.0, frame_rate=4)
    first = start()
    first.run(0.5, frame_rate=4)
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    assert resumed.soft_step.solver.settings.partition_min_contacts == 0
    resumed.run(0.5, frame_rate=4)
    assert resumed.soft_step.solver.sweep.partitioned
    assert state_hash(resumed.world) == state_hash(whole.world)
