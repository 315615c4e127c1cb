"""Collision filters through the whole step: a filtered pair is not there at all.

A body that may not touch the ground falls as in free fall (compared with z0 - g t^2 / 2,
which RK4 integrates exactly for a constant force: the tolerance is round-off over the run),
while its unfiltered twin rests (a test that could pass by accident if nothing touched);
debris started in one place lands on the ground without pushing itself apart, where the same
boxes unfiltered fly apart; a positive group beats the bits, a negative one forbids; a body
passing through a sleeper does not wake it; a filtered run resumes bit for bit.
"""

import numpy as np
import pytest

import tumble as tb
from tumble.checks import state_hash

from .solutions import resumed_run

DT = 1.0 / 240.0
G = 9.81
F = tb.CollisionFilter


def _ground(world, **kw):
    return world.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground", **kw)


def test_body_masked_off_the_ground_falls_freely_while_its_twin_rests():
    w = tb.World(gravity=(0, 0, -G))
    _ground(w, collision_filter=F(category=2))
    ghost = w.add_body(tb.Box((0.5, 0.5, 0.5)), mass=1, position=(0, 0, 1), name="ghost",
                       collision_filter=F(mask=1))  # touches category 1 only: not the ground
    twin = w.add_body(tb.Box((0.5, 0.5, 0.5)), mass=1, position=(2, 0, 1), name="twin")
    sim = tb.Simulator(w, dt=DT)
    traj = sim.run(2.0, frame_rate=24)
    t = traj.time
    np.testing.assert_allclose(traj.position[:, ghost.index, 2], 1.0 - 0.5 * G * t ** 2, rtol=0, atol=1e-9)
    assert np.all(traj.position[:, ghost.index, :2] == 0.0)
    assert abs(twin.x[2] - 0.25) < 1e-3 and np.linalg.norm(twin.v) < 1e-3


def _debris(filtered: bool, n=8):
    """n boxes started in one place, overlapping each other, 0.3 m above the ground."""
    w = tb.World(gravity=(0, 0, -G))
    _ground(w)
    for i in range(n):
        w.add_body(tb.Box((0.2, 0.2, 0.2)), mass=1, position=(0, 0, 0.4), name=f"d{i}",
                   collision_filter=F(category=2, mask=1) if filtered else None)
    return w


def test_debris_lands_on_the_ground_without_pushing_itself_apart():
    w = _debris(filtered=True)
    sim = tb.Simulator(w, dt=DT, record_contacts=True)
    traj = sim.run(1.5, frame_rate=24)
    # every recorded contact is with the ground (body 0)
    a, b = traj.contact_body_a, traj.contact_body_b
    touching = a >= 0
    assert touching.any()
    assert np.all((a[touching] == 0) | (b[touching] == 0))
    # each of the eight lands exactly as one box alone would, to the bit (its contacts are its
    # own with the ground), all in one place on the ground
    lone = tb.World(gravity=(0, 0, -G))
    _ground(lone)
    lone.add_body(tb.Box((0.2, 0.2, 0.2)), mass=1, position=(0, 0, 0.4))
    tb.Simulator(lone, dt=DT).run(1.5)
    assert np.all(w.x[1:] == lone.x[1]) and np.all(w.q[1:] == lone.q[1])
    assert abs(lone.x[1, 2] - 0.1) < 1e-3 and np.max(np.abs(lone.x[1, :2])) < 1e-6

    # unfiltered, the same boxes push each other out (so the checks above can fail)
    w2 = _debris(filtered=False)
    tb.Simulator(w2, dt=DT).run(0.25)
    assert np.max(np.abs(w2.x[1:, :2])) > 0.05


@pytest.mark.parametrize("upper_filter, lands_on_lower", [
    (F(category=4, mask=4, group=3), True),    # bits refuse, the shared positive group allows
    (F(category=4, mask=4), False),            # no group: bits refuse
    (F(group=-3), False),                      # shared negative group forbids, bits would allow
    (F(group=-4), True),                       # different negative groups: bits allow
])
def test_groups_override_the_bits(upper_filter, lands_on_lower):
    w = tb.World(gravity=(0, 0, -G))
    _ground(w, collision_filter=F(category=1 | 8))
    lower_filter = F(category=1, mask=1 | 8, group=3 if upper_filter.group == 3 else -3)
    lower = w.add_body(tb.Box((1, 1, 1)), mass=1, position=(0, 0, 0.5), collision_filter=lower_filter)
    upper = w.add_body(tb.Box((1, 1, 1)), mass=1, position=(0, 0, 2.0), collision_filter=upper_filter)
    tb.Simulator(w, dt=DT).run(1.5)
    assert abs(lower.x[2] - 0.5) < 1e-3  # the lower box rests on the ground in every case
    if lands_on_lower:
        assert abs(upper.x[2] - 1.5) < 2e-3
    else:
        # through the lower box; the upper touches the ground only where its bits let it
        assert upper.x[2] < 0.51
        assert w.should_collide(upper, 0) == (upper.x[2] > -0.01)


def test_excluded_pair_passes_through_and_others_still_touch():
    w = tb.World(gravity=(0, 0, -G))
    _ground(w)
    a = w.add_body(tb.Sphere(0.25), mass=1, position=(0, 0, 1), name="a")
    b = w.add_body(tb.Sphere(0.25), mass=1, position=(0, 0, 2), name="b")
    w.exclude_collision("a", "ground")
    traj = tb.Simulator(w, dt=DT).run(0.75, frame_rate=24)
    # a falls through the ground freely until b (not excluded from a) could catch it: b falls
    # behind it at the same acceleration 1 m above, so they never meet
    np.testing.assert_allclose(traj.position[:, a.index, 2], 1.0 - 0.5 * G * traj.time ** 2, rtol=0, atol=1e-9)
    assert abs(b.x[2] - 0.25) < 1e-3


def test_a_body_passing_through_a_sleeper_does_not_wake_it():
    """Contact links islands and wakes sleepers; a filtered pair has no contact, so a ghost
    falling through a sleeping box leaves it asleep, its state frozen to the bit (while an
    unfiltered ball dropped the same way wakes it: tests/physics/test_sleep.py)."""
    w = tb.World(gravity=(0, 0, -G))
    _ground(w)
    box = w.add_body(tb.Box((1, 1, 1)), mass=1, position=(0, 0, 0.5), name="box", collision_filter=F(category=2))
    sim = tb.Simulator(w, dt=DT)
    sim.run(1.0)
    assert not sim.sleep.awake[box.index]
    frozen = box.x.copy(), box.q.copy()
    ghost = w.add_body(tb.Sphere(0.2), mass=1, position=(0, 0, 2), name="ghost", collision_filter=F(mask=1))
    for _ in range(int(0.75 / DT)):
        sim.step(1)
        assert not sim.sleep.awake[box.index]
    assert abs(ghost.x[2] - 0.2) < 1e-3  # through the box, onto the ground (category 1) inside it
    assert np.array_equal(box.x, frozen[0]) and np.array_equal(box.q, frozen[1])


def _filtered_scene():
    """Four debris boxes in one place, and a lid that lands on them but passes through d0."""
    w = _debris(filtered=True, n=4)
    w.add_body(tb.Box((0.3, 0.3, 0.3)), mass=1, position=(0.05, 0, 1.0), name="lid")
    w.exclude_collision("lid", "d0")
    return w


def test_filtered_run_resumes_bit_for_bit(tmp_path):
    """The checkpoint carries the filters and the exclusions: without them the resumed lid
    would meet d0 (or the debris each other) and the hashes would differ."""
    whole, resumed = resumed_run(_filtered_scene, tmp_path, 1.0, DT)
    assert resumed.world.collision_filters == whole.world.collision_filters
    assert resumed.world.excluded_collisions == {(1, 5)}
    assert state_hash(resumed.world) == state_hash(whole.world)
