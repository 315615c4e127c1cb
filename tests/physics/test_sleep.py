"""Sleeping through the Simulator (issue 3, deliverable 6): a box at rest falls asleep after
``TIME_TO_SLEEP`` and costs nothing, a box dropped onto it wakes it, and the two fall asleep
together. Assumes the lead's wiring exposes the ``SleepState`` as ``Simulator.sleep``.
"""

from __future__ import annotations

import numpy as np
import pytest

import tumble as tb
from tumble.solver.island import TIME_TO_SLEEP


DT = 1.0 / 240.0


def resting_box_world():
    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, position=(0, 0, 0.5), name="box")
    return w


def steps(seconds):
    return round(seconds / DT)


def test_box_at_rest_falls_asleep_after_the_time_to_sleep_and_stops_costing():
    """Still from the start (residual speed ~1e-6 m/s after a few steps), so its timer runs from
    t = 0 and it sleeps at 0.5 s, within a step or two. Asleep, its state is frozen bit for bit,
    its velocity is zero and no contact is solved."""
    w = resting_box_world()
    sim = tb.Simulator(w, dt=DT)
    sim.step(steps(TIME_TO_SLEEP - 0.05))
    assert sim.sleep.awake[1]
    sim.step(steps(0.1))
    assert not sim.sleep.awake[1]
    frozen = w.pack().copy()
    assert np.all(w.v[1] == 0.0) and np.all(w.omega[1] == 0.0)
    sim.step(steps(1.0))
    assert np.array_equal(w.pack(), frozen)
    assert len(sim.soft_step.query()) == 0  # none detected, none solved
    kept = sim.contacts()  # the four it fell asleep on, still reported (SleepState.keep_resting)
    assert len(kept) == 4 and kept.force[:, 2].sum() == pytest.approx(9.81, rel=1e-6)
    assert abs(w.x[1, 2] - 0.5) < 1e-3


def test_box_dropped_onto_a_sleeping_box_wakes_it_and_both_sleep_together():
    w = resting_box_world()
    sim = tb.Simulator(w, dt=DT)
    sim.step(steps(1.0))
    assert not sim.sleep.awake[1]
    # the lead's Simulator must grow the SleepState with the bodies added between steps
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, position=(0.2, 0.0, 2.0), name="dropped")
    sim.step(1)
    assert sim.sleep.awake[2] and not sim.sleep.awake[1]
    # 0.5 m of free fall takes 0.32 s: the lower box wakes when the upper one comes within the
    # speculative distance, and carries it
    woke_at = None
    for k in range(steps(0.5)):
        sim.step(1)
        if woke_at is None and sim.sleep.awake[1]:
            woke_at = w.t
            assert w.x[2, 2] < 1.5 + 0.05  # it woke on touch, not before
    assert woke_at is not None
    assert w.x[2, 2] == pytest.approx(1.5, abs=2e-3)
    assert w.x[1, 2] == pytest.approx(0.5, abs=2e-3)
    # an island sleeps whole: the two boxes fall asleep in the same step
    for _ in range(steps(2.0)):
        sim.step(1)
        assert sim.sleep.awake[1] == sim.sleep.awake[2]
    assert not sim.sleep.awake[1] and not sim.sleep.awake[2]


def test_wake_puts_a_sleeping_box_back_into_the_step():
    """``sim.sleep.wake`` (what an applied impulse or a set velocity must call) wakes the box: a
    velocity set on it then moves it."""
    w = resting_box_world()
    sim = tb.Simulator(w, dt=DT)
    sim.step(steps(1.0))
    assert not sim.sleep.awake[1]
    w.body("box").v = (0.0, 0.0, 2.0)
    sim.sleep.wake([1])
    sim.step(steps(0.1))
    assert sim.sleep.awake[1]
    assert w.x[1, 2] > 0.6


def test_a_box_woken_and_asleep_elsewhere_reports_only_the_contacts_it_rests_on_there():
    """A box asleep near a fixed shelf's edge, pushed off by an impulse (which wakes it from
    outside the sleep update), falls and sleeps on the ground: ``contacts()`` lists only its
    contacts with the ground, carrying m g (0.1 %, the resting box's tolerance). Before, the four
    shelf contacts kept when it first fell asleep came back beside them (and their forces with
    them: 2 m g in all)."""
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    w.add_body(tb.Box(size=(1, 1, 0.1)), fixed=True, position=(0, 0, 1.0), name="shelf")
    box = w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0, 0.35, 1.15), name="box")
    sim = tb.Simulator(w, dt=DT)
    sim.step(480)
    assert not sim.sleep.awake[2] and set(sim.contacts().body_a.tolist()) == {1}
    box.apply_impulse((0, 2.0, 0))
    sim.step(1200)
    assert not sim.sleep.awake[2] and box.x[1] > 0.6 and abs(box.x[2] - 0.1) < 1e-3
    c = sim.contacts()
    assert set(c.body_a.tolist()) == {0}
    assert c.force[:, 2].sum() == pytest.approx(9.81, rel=1e-3)


G = 9.81


def ball_asleep_on_a_platform(far_pair: bool):
    """A 0.2 m ball asleep on a fixed 1 x 1 x 0.2 m platform (600 steps), the ground 3 m below;
    with ``far_pair`` a second ball resting on the ground 5 m away, so that some pair can still
    touch after the ball's and the platform's can no longer."""
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Plane(), fixed=True, position=(0, 0, -3), name="ground")
    w.add_body(tb.Box(size=(1, 1, 0.2)), fixed=True, name="platform")
    w.add_body(tb.Sphere(0.2), mass=1.0, position=(0, 0, 0.3), name="ball")
    if far_pair:
        w.add_body(tb.Sphere(0.2), mass=1.0, position=(5, 0, -2.8), name="far")
    sim = tb.Simulator(w, dt=DT, contact_events=True)
    sim.step(600)
    assert not sim.sleep.awake[w.index_of("ball")]
    return w, sim


@pytest.mark.parametrize("far_pair", [True, False])
@pytest.mark.parametrize("change", ["ball mask 0", "platform category 0", "exclude"])
def test_a_filter_change_under_a_sleeping_body_lets_it_fall(change, far_pair):
    """A filter or an exclusion that parts a sleeping ball from its platform, between steps: the
    ball falls freely, z0 - g t^2 / 2 after t = 0.25 s (to 1e-9 m: the steps are exact for
    constant gravity but for the semi-implicit update's dt g t / 2, 5e-3 m here, which the
    reference takes from a run of the same ball alone with no platform), awake, with no contact
    reported and one end event. Box2D's b2Shape_SetFilter wakes the body. Before, the ball hovered
    asleep on its kept contacts (with a pair elsewhere), or fell flagged asleep still reporting its
    platform contact 4.6 m away (alone: the free flight of a world where nothing can touch)."""
    w, sim = ball_asleep_on_a_platform(far_pair)
    ball, platform = w.index_of("ball"), w.index_of("platform")
    z0 = w.x[ball, 2]
    sim.contact_events()
    if change == "ball mask 0":
        w.body(ball).collision_filter = {"mask": 0}
    elif change == "platform category 0":
        w.body(platform).collision_filter = {"category": 0}
    else:
        w.exclude_collision("platform", "ball")
    sim.step(60)
    alone = tb.World(gravity=(0, 0, -G))
    alone.add_body(tb.Sphere(0.2), mass=1.0, position=(0, 0, z0))
    tb.Simulator(alone, dt=DT).step(60)
    assert w.x[ball, 2] == pytest.approx(alone.x[0, 2], abs=1e-9)
    assert w.x[ball, 2] < z0 - 0.25
    assert sim.sleep.awake[ball]
    c = sim.contacts()
    assert not np.any((c.body_a == ball) | (c.body_b == ball))
    ends = sim.contact_events()
    assert sorted(zip(ends.end_body_a, ends.end_body_b)) == [(platform, ball)]


def test_a_body_in_free_flight_never_sleeps_however_slow():
    """No gravity: a box drifting at 2 cm/s and turning at 0.01 rad/s (both under the sleep
    tolerances) with a second shape 17 m away: after 3 s it is at x = 0.06 m with its velocity
    (free flight: exact but for rounding, 1e-12). Box2D's rule (any island under the tolerances
    for 0.5 s sleeps) stopped it at 0.0099 m (a course audit, session 42): only an island held by
    something that does not move sleeps. And two balls (1 kg each) on a soft spring (k = 0.5 N/m,
    so the separation oscillates at sqrt(2 k / m) = 1 rad/s) started 1 mm from its rest length,
    their speeds under 1 mm/s: held by nothing fixed, they oscillate on as 1 + 0.001 cos t (1e-7
    m: RK4 at dt 1/240 over 6 s); they froze with the spring stretched."""
    w = tb.World(gravity=(0, 0, 0))
    box = w.add_body(tb.Box((0.2, 0.6, 1.0)), mass=2.0, velocity=(0.02, 0, 0), angular_velocity=(0, 0, 0.01))
    w.add_body(tb.Sphere(0.1), mass=1.0, position=(10, 10, 10))
    sim = tb.Simulator(w, dt=DT)
    sim.step(steps(3.0))
    assert box.x[0] == pytest.approx(0.06, abs=1e-12)
    np.testing.assert_allclose(box.v, [0.02, 0, 0], atol=1e-15)
    assert sim.sleep.awake.all()

    w = tb.World(gravity=(0, 0, 0))
    a = w.add_body(tb.Sphere(0.1), mass=1.0, position=(0, 0, 0))
    b = w.add_body(tb.Sphere(0.1), mass=1.0, position=(1.001, 0, 0))
    w.add_force(tb.Spring(a, b, stiffness=0.5, rest_length=1.0))
    sim = tb.Simulator(w, dt=DT)
    for t in (1.5, 3.0, 4.5, 6.0):
        sim.step(steps(1.5))
        assert b.x[0] - a.x[0] == pytest.approx(1 + 0.001 * np.cos(t), abs=1e-7), t


def test_what_holds_an_island_up_lets_it_sleep():
    """A ball hanging at rest on a ball joint to the world falls asleep after TIME_TO_SLEEP (a
    joint to the world holds it up), as a box at rest on the ground does (the tests above) and a
    weight on a spring to the world (tests/physics/test_force_edit.py). And
    two boxes asleep on the ground, one woken by an impulse: the other stays asleep on its four
    kept ground contacts (``sim.contacts()`` reports them, summing m g to 1e-9 N). Before, waking a
    box on the ground forgot every island's kept contacts with the ground."""
    w = tb.World()
    w.add_body(tb.Sphere(0.1), mass=1.0, position=(0, 0, 1.0), name="bob")
    w.add_joint(tb.BallJoint("bob", None, anchor=(0, 0, 1.5)))
    sim = tb.Simulator(w, dt=DT)
    sim.step(steps(TIME_TO_SLEEP + 0.1))
    assert not sim.sleep.awake[0]

    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    a = w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, position=(0, 0, 0.5), name="a")
    b = w.add_body(tb.Box(size=(1, 1, 1)), mass=2.0, position=(5, 0, 0.5), name="b")
    sim = tb.Simulator(w, dt=DT)
    sim.step(steps(TIME_TO_SLEEP + 0.1))
    assert not sim.sleep.awake[1] and not sim.sleep.awake[2]
    a.apply_impulse((0, 0, 1.0))
    sim.step(1)
    assert sim.sleep.awake[a.index] and not sim.sleep.awake[b.index]
    c = sim.contacts()
    on_b = (c.body_a == b.index) | (c.body_b == b.index)
    assert np.count_nonzero(on_b) == 4
    assert c.force[on_b].sum(axis=0)[2] == pytest.approx(2.0 * 9.81, abs=1e-9)
