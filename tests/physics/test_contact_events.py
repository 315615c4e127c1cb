"""Contact events (``solver.contact_events``) against the bouncing ball's textbook impacts, and
through sleeping.

A ball dropped from height h with restitution e hits the ground at t1 = sqrt(2 h / g) with
v1 = sqrt(2 g h), then every 2 e^k v1 / g later at e^k v1. Each impact must begin a touch in the
step that holds it (begin time, the step's end, within [t_k, t_k + dt] for the first; the
later impacts drift by the bounce model's error, within 1 % of t_k, as the apex heights of
tests/physics/test_contact.py) at the approach speed e^k v1 (within 1 %: the apex heights are
held to 1 %, and speed goes as the square root of height), and end it a step or two later.
"""

import numpy as np
import pytest

import tumble as tb

G = 9.81
DT = 1.0 / 240.0


def _bouncing_ball(e=0.8, drop=2.0, r=0.5):
    w = tb.World(gravity=(0, 0, -G))
    material = tb.Material(friction=0.0, restitution=e)
    w.add_body(tb.Plane(), fixed=True, material=material, name="ground")
    w.add_body(tb.Sphere(r), mass=1.0, position=(0, 0, drop + r), material=material, name="ball")
    return w


def test_each_bounce_begins_and_ends_a_touch_at_the_textbook_time_and_speed():
    e, drop = 0.8, 2.0
    sim = tb.Simulator(_bouncing_ball(e, drop), dt=DT, contact_events=True)
    sim.run(4.0)
    ev = sim.contact_events()
    v1 = np.sqrt(2 * G * drop)
    t = [v1 / G]
    for k in range(1, 5):
        t.append(t[-1] + 2 * e**k * v1 / G)
    t = np.array(t)
    speed = v1 * e ** np.arange(5)
    assert len(ev.begin_time) >= 5
    assert np.all(ev.begin_body_a[:5] == 0) and np.all(ev.begin_body_b[:5] == 1)
    assert t[0] <= ev.begin_time[0] <= t[0] + DT
    np.testing.assert_allclose(ev.begin_time[:5], t, rtol=0.01)
    np.testing.assert_allclose(ev.begin_approach_speed[:5], speed, rtol=0.01)
    # the point is under the ball, on the ground (within the soft contact's overlap)
    assert np.all(np.abs(ev.begin_point[:5, :2]) < 1e-9) and np.all(np.abs(ev.begin_point[:5, 2]) < 0.01)
    # every bounce ends: one end per begin, a step or two after it, before the next begin
    n = len(ev.begin_time)
    assert len(ev.end_time) in (n, n - 1)
    gaps = ev.end_time[:5] - ev.begin_time[:5]
    assert np.all(gaps > 0) and np.all(gaps <= 3 * DT + 1e-12)
    assert np.all(ev.end_time[:4] < ev.begin_time[1:5])
    # drained: nothing new until the next step
    again = sim.contact_events()
    assert len(again.begin_time) == 0 and len(again.end_time) == 0


def test_falling_asleep_ends_nothing_and_a_new_pair_begins():
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Plane(), fixed=True, name="ground")
    w.add_body(tb.Box((1, 1, 1)), mass=1.0, position=(0, 0, 0.5), name="box")
    sim = tb.Simulator(w, dt=DT, contact_events=True)
    sim.run(1.5)  # it rests from the start and sleeps at 0.5 s
    assert not sim.sleep.awake[1]
    ev = sim.contact_events()
    assert ev.begin_body_a.tolist() == [0] and ev.begin_body_b.tolist() == [1]
    # it starts touching at rest: the approach speed is at most a step's gravity kick
    assert ev.begin_time[0] == pytest.approx(DT) and ev.begin_approach_speed[0] < G * DT
    assert len(ev.end_time) == 0  # asleep, the box still touches the ground
    # a second box dropped on it wakes it: the new pair begins, the old one neither ends nor begins
    w.add_body(tb.Box((1, 1, 1)), mass=1.0, position=(0, 0, 2.0), name="top")
    sim.run(1.0)
    ev = sim.contact_events()
    # (the top box lands, lifts off by about a millimetre for a few steps as the woken stack
    # springs back from its soft contacts, and lands again: both are events of that pair)
    assert set(zip(ev.begin_body_a.tolist(), ev.begin_body_b.tolist())) == {(1, 2)}
    assert set(zip(ev.end_body_a.tolist(), ev.end_body_b.tolist())) <= {(1, 2)}
    # it fell 0.5 m: sqrt(2 g 0.5) = 3.13 m/s, within the step's gravity kick, at 1.5 + sqrt(2 0.5 / g) s
    assert ev.begin_approach_speed[0] == pytest.approx(np.sqrt(2 * G * 0.5), abs=G * DT)
    assert ev.begin_time[0] == pytest.approx(1.5 + np.sqrt(2 * 0.5 / G), abs=2 * DT)


def test_events_are_off_unless_asked_for():
    sim = tb.Simulator(_bouncing_ball())
    sim.run(1.0)
    with pytest.raises(tb.InputError, match="contact_events: contact events are off"):
        sim.contact_events()


def test_a_resumed_run_reports_the_events_of_the_whole_run(tmp_path):
    """The touching pairs are checkpointed: resumed while the ball rests between bounces or
    sits on the ground, the continuation reports exactly the events of the uninterrupted run."""
    def scene():
        w = _bouncing_ball(e=0.5)
        w.sleeping = False  # the resting ball stays in the step (asleep, its pair would keep its state anyway)
        return w
    whole = tb.Simulator(scene(), dt=DT, contact_events=True)
    whole.run(3.0)
    want = whole.contact_events()
    first = tb.Simulator(scene(), dt=DT, contact_events=True)
    first.run(2.5)  # the bounces have died out (at about 1.9 s): the ball sits on the ground
    got_first = first.contact_events()
    assert first._event_log.pairs() == [[0, 1]]
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    resumed.run(0.5)
    got = resumed.contact_events()
    begins = np.concatenate([got_first.begin_time, got.begin_time])
    ends = np.concatenate([got_first.end_time, got.end_time])
    assert np.array_equal(begins, want.begin_time) and np.array_equal(ends, want.end_time)
    assert np.array_equal(np.concatenate([got_first.begin_approach_speed, got.begin_approach_speed]),
                          want.begin_approach_speed)
    assert len(got.begin_time) == 0  # without the saved pairs its first step would begin the touch again
