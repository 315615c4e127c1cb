"""Sensors (Box2D's sensor shapes, Bullet's ghost objects): bodies that report what overlaps them
and push nothing.

Compared with: free fall (a ball dropped through a sensor box falls as z0 - g t^2 / 2 to
round-off, and its begin and end events fall in the steps that end first after the closed-form
times of entry and exit); the closed-form distance from a point to a box (spheres placed around
a sensor box overlap it exactly when that distance is below their radius). Plus what a sensor
owes its users: it sees dynamic and kinematic bodies, not fixed ones nor other sensors, obeys
collision filters and exclusions, keeps a sleeping visitor, counts what rests in it, and a
resumed run reports the events of the whole run.
"""

import math

import numpy as np
import pytest

import tumble as tb
from tumble.errors import InputError

DT = 1.0 / 240.0
G = 9.81


def _first_step_end_after(t):
    return math.ceil(t / DT - 1e-9) * DT


def test_a_ball_falls_through_a_sensor_untouched_with_events_at_entry_and_exit():
    w = tb.World(gravity=(0, 0, -G))
    zone = w.add_body(tb.Box((1, 1, 1)), fixed=True, sensor=True, position=(0, 0, 2), name="zone")
    ball = w.add_body(tb.Sphere(0.1), mass=1, position=(0, 0, 4), name="ball")
    sim = tb.Simulator(w, dt=DT)
    traj = sim.run(1.0, frame_rate=240)
    # free fall through the sensor (RK4 is exact for constant gravity: round-off)
    np.testing.assert_allclose(traj.position[:, ball.index, 2], 4.0 - 0.5 * G * traj.time ** 2, rtol=0, atol=1e-9)
    ev = sim.sensor_events()
    t_in = math.sqrt(2 * (4.0 - 2.6) / G)  # its bottom reaches the top face, z = 2.5
    t_out = math.sqrt(2 * (4.0 - 1.4) / G)  # its top leaves the bottom face, z = 1.5
    assert ev.begin_sensor.tolist() == [zone.index] and ev.begin_visitor.tolist() == [ball.index]
    assert ev.begin_time[0] == pytest.approx(_first_step_end_after(t_in), abs=1e-12)
    assert ev.end_sensor.tolist() == [zone.index] and ev.end_visitor.tolist() == [ball.index]
    assert ev.end_time[0] == pytest.approx(_first_step_end_after(t_out), abs=1e-12)
    assert len(sim.sensor_overlaps()) == 0
    assert len(sim.sensor_events().begin_time) == 0  # drained


def _box_distance(p, half):
    """Distance (m) from a point p (3,) to the solid axis-aligned box of half sizes ``half`` at the origin."""
    return float(np.linalg.norm(np.maximum(np.abs(p) - half, 0.0)))


def test_spheres_around_a_sensor_box_overlap_it_exactly_when_closer_than_their_radius():
    # 200 spheres of radius 0.1 scattered around a turned sensor box; no gravity, so nothing
    # moves in the step. Spheres within 1 mm of touching are left out: a sphere is a ball in the
    # narrowphase, the box a box, both exact, but the test keeps clear of round-off.
    rng = np.random.default_rng(3)
    half = np.array([0.5, 0.3, 0.2])
    q = np.array([math.cos(0.3), 0.2 * math.sin(0.3), 0.5 * math.sin(0.3), math.sqrt(0.71) * math.sin(0.3)])
    w = tb.World(gravity=(0, 0, 0))
    zone = w.add_body(tb.Box(2 * half), fixed=True, sensor=True, orientation=q, name="zone")
    R = zone.R.copy()
    inside = []
    for k in range(400):
        p = rng.uniform(-0.8, 0.8, 3)
        d = _box_distance(R.T @ p, half) - 0.1
        if abs(d) < 1e-3:
            continue
        b = w.add_body(tb.Sphere(0.1), mass=1, position=p, name=f"s{k}")
        if d < 0:
            inside.append(b.index)
        if w.body_count > 200:
            break
    sim = tb.Simulator(w, dt=DT)
    sim.step(1)
    assert 20 < len(inside) < 180  # both kinds are there
    assert sim.sensor_overlaps(zone).tolist() == sorted(inside)


def test_what_a_sensor_sees():
    # dynamic and kinematic bodies, whatever their filters allow; not fixed bodies, other
    # sensors, excluded bodies, nor a body whose mask leaves out the sensor's category
    w = tb.World(gravity=(0, 0, 0))
    zone = w.add_body(tb.Box((2, 2, 2)), fixed=True, sensor=True, name="zone",
                      collision_filter=tb.CollisionFilter(category=4))
    seen = [w.add_body(tb.Sphere(0.1), mass=1, position=(0.5, 0, 0), name="dynamic"),
            w.add_body(tb.Box((0.2, 0.2, 0.2)), kinematic=True, position=(-0.5, 0, 0), name="kinematic")]
    unseen = [w.add_body(tb.Box((0.2, 0.2, 0.2)), fixed=True, position=(0, 0.5, 0), name="fixed"),
              w.add_body(tb.Sphere(0.2), fixed=True, sensor=True, position=(0, -0.5, 0), name="other_sensor"),
              w.add_body(tb.Sphere(0.1), mass=1, position=(0, 0, 0.5), name="masked",
                         collision_filter=tb.CollisionFilter(mask=1)),
              w.add_body(tb.Sphere(0.1), mass=1, position=(0, 0, -0.5), name="excluded")]
    w.exclude_collision(zone, "excluded")
    sim = tb.Simulator(w, dt=DT, record_contacts=True)
    traj = sim.run(0.25, frame_rate=24)
    assert sim.sensor_overlaps(zone).tolist() == sorted(b.index for b in seen)
    assert sim.sensor_overlaps("other_sensor").tolist() == []  # inside the zone, but sensors see no sensors
    # and it touches none of them: no contacts at all, nothing moved
    assert np.all(traj.contact_count == 0)
    for b in seen + unseen:
        assert np.all(traj.position[:, b.index] == traj.position[0, b.index])


def test_a_bin_counts_the_balls_that_rest_in_it_and_keeps_them_when_they_sleep():
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Plane(), fixed=True, name="ground")
    bin_zone = w.add_body(tb.Box((1, 1, 0.5)), fixed=True, sensor=True, position=(0, 0, 0.25), name="bin")
    xs = [-0.3, 0.0, 0.3, 1.2, -1.5]
    for k, x in enumerate(xs):
        w.add_body(tb.Sphere(0.1), mass=1, position=(x, 0, 1.0 + 0.3 * k), name=f"ball{k}",
                   material=tb.Material(rolling_resistance=0.2))
    sim = tb.Simulator(w, dt=DT)
    sim.run(4.0, frame_rate=24)
    inside = [w.index_of(f"ball{k}") for k, x in enumerate(xs) if abs(x) < 0.5]
    assert sim.sensor_overlaps(bin_zone).tolist() == inside
    assert not sim.sleep.awake[inside].any()  # asleep in the bin, still counted
    ev = sim.sensor_events()
    assert sorted(ev.begin_visitor.tolist()) == inside and len(ev.end_visitor) == 0


def test_a_dynamic_sensor_falls_through_the_ground():
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Plane(), fixed=True, name="ground")
    ghost = w.add_body(tb.Sphere(0.2), mass=1, sensor=True, position=(0, 0, 1), name="ghost")
    box = w.add_body(tb.Box((0.4, 0.4, 0.4)), mass=1, position=(0, 0, 0.2), name="box")
    sim = tb.Simulator(w, dt=DT)
    traj = sim.run(1.0, frame_rate=24)
    np.testing.assert_allclose(traj.position[:, ghost.index, 2], 1.0 - 0.5 * G * traj.time ** 2, rtol=0, atol=1e-9)
    ev = sim.sensor_events()
    assert ev.begin_visitor.tolist() == [box.index] and ev.end_visitor.tolist() == [box.index]
    assert box.x[2] == pytest.approx(0.2, abs=1e-3)  # the box it passed through never noticed


def test_a_resumed_run_reports_the_sensor_events_of_the_whole_run(tmp_path):
    def world():
        w = tb.World(gravity=(0, 0, -G))
        w.add_body(tb.Plane(), fixed=True, name="ground")
        w.add_body(tb.Box((3, 3, 1)), fixed=True, sensor=True, position=(0, 0, 0.5), name="zone")
        for k in range(4):
            w.add_body(tb.Sphere(0.1), mass=1, position=(0.4 * k - 0.6, 0, 1.2 + 0.5 * k), name=f"b{k}",
                       velocity=(0.5 * k, 0, 0))
        return w

    whole = tb.Simulator(world(), dt=DT)
    whole.run(2.0, frame_rate=24)
    expected = whole.sensor_events()
    first = tb.Simulator(world(), dt=DT)
    first.run(0.75, frame_rate=24)
    part = first.sensor_events()
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    resumed.run(1.25, frame_rate=24)
    rest = resumed.sensor_events()
    for name in ("begin_visitor", "begin_time", "end_visitor", "end_time"):
        np.testing.assert_array_equal(np.concatenate([getattr(part, name), getattr(rest, name)]), getattr(expected, name))
    assert len(expected.begin_time) >= 4 and len(expected.end_time) >= 1  # entries and a roll-out


def test_sensor_bad_input_is_one_line():
    w = tb.World()
    with pytest.raises(InputError, match="a plane cannot be a sensor"):
        w.add_body(tb.Plane(), fixed=True, sensor=True)
    with pytest.raises(InputError, match="expected True or False"):
        w.add_body(tb.Box((1, 1, 1)), fixed=True, sensor="yes")
    w.add_body(tb.Box((1, 1, 1)), mass=1, name="b")
    sim = tb.Simulator(w)
    with pytest.raises(InputError, match="no sensor"):
        sim.sensor_events()


def test_the_trajectory_counts_each_sensors_visitors_per_frame(tmp_path):
    # a ball starting inside a sensor (counted from frame 0: the run's start is sensed), a second
    # ball falling into it, then both falling out of its bottom; the same counts in run() and in
    # the streamed file of run_to_file
    def world():
        w = tb.World(gravity=(0, 0, -G))
        w.add_body(tb.Box((1, 1, 1)), fixed=True, sensor=True, position=(0, 0, 2), name="zone")
        w.add_body(tb.Sphere(0.1), mass=1, position=(0, 0, 2.2), name="inside")
        w.add_body(tb.Sphere(0.1), mass=1, position=(0.2, 0, 3.0), name="above")
        return w

    traj = tb.Simulator(world(), dt=DT).run(1.0, frame_rate=24)
    counts = traj.sensor_visitors[:, 0]
    assert traj.sensor_visitors.shape == (25, 1) and counts[0] == 1
    t = traj.time
    # the closed form of each ball's overlap: "inside" until its top leaves z = 1.5 (centre 1.4),
    # "above" from its bottom at z = 2.5 (centre 2.6) until its centre reaches 1.4
    inside = t < math.sqrt(2 * 0.8 / G)
    above = (t >= math.sqrt(2 * 0.4 / G)) & (t < math.sqrt(2 * 1.6 / G))
    np.testing.assert_array_equal(counts, inside.astype(float) + above.astype(float))
    result = tb.Simulator(world(), dt=DT).run_to_file(tmp_path / "run", 1.0, frame_rate=24)
    streamed = tb.load_trajectory(result.out_dir / "trajectory.npz")
    np.testing.assert_array_equal(streamed.sensor_visitors, traj.sensor_visitors)


@pytest.mark.parametrize("speed", [100.0, 400.0])
def test_a_bullet_through_a_thin_sensor_is_seen_in_the_step_it_crosses(speed):
    # a 1 cm ball at 100 and 400 m/s (0.42 and 1.7 m a step) through a 1 cm sensor plate at
    # x = 1: no step ends with them overlapping, yet the pass is reported, begin and end in the
    # step that carries the ball across (the first step ending after 1 / speed s); a ball
    # passing 5 cm beside the plate's edge is not. The ball is not touched (free flight, no
    # gravity: x = v t to round-off).
    w = tb.World(gravity=(0, 0, 0))
    plate = w.add_body(tb.Box((0.01, 0.5, 0.5)), fixed=True, sensor=True, position=(1.0, 0, 0), name="plate")
    bullet = w.add_body(tb.Sphere(0.005), mass=0.01, position=(0, 0, 0), velocity=(speed, 0, 0), name="bullet")
    w.add_body(tb.Sphere(0.005), mass=0.01, position=(0, 0.3, 0), velocity=(speed, 0, 0), name="beside")
    sim = tb.Simulator(w, dt=DT)
    traj = sim.run(0.025, frame_rate=240)
    assert np.all(traj.sensor_visitors == 0)  # never overlapping at a step's end
    ev = sim.sensor_events()
    t_cross = _first_step_end_after(1.0 / speed)
    assert ev.begin_sensor.tolist() == [plate.index] and ev.begin_visitor.tolist() == [bullet.index]
    assert ev.end_visitor.tolist() == [bullet.index]
    assert ev.begin_time[0] == pytest.approx(t_cross, abs=1e-12) and ev.end_time[0] == pytest.approx(t_cross, abs=1e-12)
    np.testing.assert_allclose(traj.position[:, bullet.index, 0], speed * traj.time, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("far_pair", [False, True])
@pytest.mark.parametrize("change", ["disabled", "fixed", "mask 0"])
def test_a_zones_only_visitor_taken_away_ends_its_overlap(change, far_pair):
    """A zone and the one crate inside it (no gravity); the crate disabled, made fixed or given a
    filter that no longer meets the zone's, between steps: the zone reports no visitor and one end
    event (docs/contact.md: sensors see dynamic and kinematic bodies as the filters allow; a
    disabled body overlaps nothing). Before, with nothing else in the world that could touch, the
    run took the free flight, which never looked at the sensors again: the zone kept its visitor
    and no end event came (the despawned player never left the trigger); with a far pair of balls
    it was right."""
    w = tb.World(gravity=(0, 0, 0))
    zone = w.add_body(tb.Box(size=(1, 1, 1)), fixed=True, sensor=True, name="zone")
    crate = w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, name="crate")
    if far_pair:
        w.add_body(tb.Sphere(0.1), mass=1.0, position=(10, 0, 0))
        w.add_body(tb.Sphere(0.1), mass=1.0, position=(10, 0, 0.19))
    sim = tb.Simulator(w)
    sim.step(10)
    assert list(sim.sensor_overlaps(zone)) == [crate.index]
    sim.sensor_events()
    if change == "disabled":
        crate.enabled = False
    elif change == "fixed":
        crate.type = "fixed"
    else:
        crate.collision_filter = {"mask": 0}
    sim.step(10)
    assert list(sim.sensor_overlaps(zone)) == []
    events = sim.sensor_events()
    assert list(events.end_visitor) == [crate.index]
    assert len(events.begin_visitor) == 0
