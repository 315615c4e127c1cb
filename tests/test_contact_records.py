"""Contacts as data (issue 3, deliverable 7) and the contact step's reliability contracts:
the per-frame record in the trajectory (in memory and streamed), the Python query, checkpoints
that resume bit for bit (the warm-start impulses are saved), the validated stage-by-stage path,
and run-to-run determinism of a contact scene.
"""

from __future__ import annotations

import numpy as np
import pytest

import tumble as tb
from tumble.checks import state_hash
from tumble.trajectory import load_trajectory


def boxes_on_ground():
    """Three boxes dropped on the ground, one spinning: contacts start, persist and change."""
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground", material=tb.Material(friction=0.5))
    w.add_body(tb.Box(size=(0.4, 0.4, 0.4)), mass=1.0, position=(0, 0, 0.2), name="resting")
    w.add_body(tb.Box(size=(0.3, 0.5, 0.2)), mass=2.0, position=(1, 0, 0.6), angular_velocity=(1, 2, 3), name="falling")
    w.add_body(tb.Sphere(radius=0.2), mass=0.5, position=(0.05, 0.02, 0.9), velocity=(0, 0, -1), name="ball",
               material=tb.Material(restitution=0.5))
    return w


def test_query_names_points_and_forces_of_the_last_step():
    """The resting box's contacts carry its weight: the normal impulses over one step sum to
    m g dt (to 1e-6 once settled) and the mean forces to m g; points are on the ground."""
    w = tb.World(gravity=(0, 0, -9.81))
    w.sleeping = False  # asleep after 0.5 s, the box would have no contacts to query
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    w.add_body(tb.Box(size=(0.4, 0.4, 0.4)), mass=1.5, position=(0, 0, 0.2), name="box")
    sim = tb.Simulator(w)
    sim.step(240)
    c = sim.contacts()
    assert len(c) == 4
    assert set(c.names_a) == {"ground"} and set(c.names_b) == {"box"}
    assert np.allclose(c.normal, [0, 0, 1])
    assert np.abs(c.point[:, 2]).max() < 1e-3
    assert c.normal_impulse.sum() == pytest.approx(1.5 * 9.81 * sim.dt, rel=1e-6)
    assert c.force[:, 2].sum() == pytest.approx(1.5 * 9.81, rel=1e-6)
    assert tb.Simulator(tb.World()).contacts().point.shape == (0, 3)


def test_query_names_the_part_of_a_compound_that_touches():
    """``part_a``/``part_b``: which part of a body's ``Compound`` each contact is on (PyBullet's
    link index, MuJoCo's geom). A dumbbell of a ball (part 0) and a cube (part 1) lies on the
    ground with a block on its cube: the ground's contacts with the ball are on part 0 (one
    point, under the ball's centre), those with the cube on part 1 (four, under the cube), the
    block's on part 1 from above; a shape of one part and the plane report 0. The ground
    carries the whole weight (to 1e-6, settled), the ball's share found through its part."""
    w = tb.World(gravity=(0, 0, -9.81))
    w.sleeping = False
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    dumbbell = tb.Compound([(tb.Sphere(radius=0.1), (-0.5, 0, 0), (1, 0, 0, 0)),
                            (tb.Box(size=(0.2, 0.2, 0.2)), (0.5, 0, 0), (1, 0, 0, 0))])
    w.add_body(dumbbell, mass=2.0, position=(0, 0, 0.1), name="dumbbell")
    w.add_body(tb.Box(size=(0.1, 0.1, 0.1)), mass=0.5, position=(0.5, 0, 0.25), name="block")
    sim = tb.Simulator(w)
    sim.step(240)
    c = sim.contacts()
    on_ground = c.names_a == "ground"
    assert np.all(c.part_a[on_ground] == 0)
    ball = on_ground & (c.part_b == 0)
    cube = on_ground & (c.part_b == 1)
    assert ball.sum() == 1 and cube.sum() == 4 and on_ground.sum() == 5
    assert np.all(c.names_b[on_ground] == "dumbbell")
    assert np.allclose(c.point[ball, :2], [-0.5, 0.0], atol=1e-3) and np.all(np.abs(c.point[cube, 0] - 0.5) < 0.11)
    block = ~on_ground
    assert block.sum() == 4
    pairs = {(a, pa, b, pb) for a, pa, b, pb in zip(c.names_a[block], c.part_a[block], c.names_b[block], c.part_b[block])}
    assert pairs in ({("dumbbell", 1, "block", 0)}, {("block", 0, "dumbbell", 1)})
    assert c.force[on_ground, 2].sum() == pytest.approx(2.5 * 9.81, rel=1e-6)
    assert 0.0 < c.force[ball, 2].sum() < c.force[cube, 2].sum()  # the block rests on the cube's end


def test_sleeping_bodies_keep_the_contacts_they_rest_on():
    """An island asleep still rests on its contacts (Box2D keeps a sleeping body's contacts,
    PyBullet's getContactPoints returns them): two stacked boxes asleep after 1.5 s report the 8
    contacts of their last step awake, their forces carrying the weights (the ground's 2 m g, the
    lower box's m g to 1e-6: at rest the step's impulses balance gravity), the same at 3 s, and in
    the recorded frames; before session 34 ``contacts()`` was empty once they slept. A ball
    dropped on the stack wakes it: the contacts are detected again, none kept twice (each pair's
    points once: 4 + 4 + the ball's). A user's push wakes it too, and its kept contacts go."""
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    w.add_body(tb.Box(size=(0.4, 0.4, 0.4)), mass=1.5, position=(0, 0, 0.2), name="low")
    w.add_body(tb.Box(size=(0.4, 0.4, 0.4)), mass=1.5, position=(0, 0, 0.6), name="top")
    sim = tb.Simulator(w, record_contacts=True)
    traj = sim.run(1.5, frame_rate=24)
    assert not sim.sleep.awake[1:].any()  # both asleep
    for _ in range(2):
        c = sim.contacts()
        assert len(c) == 8
        ground = c.names_a == "ground"
        assert ground.sum() == 4 and set(c.names_b[ground]) == {"low"}
        assert c.force[ground, 2].sum() == pytest.approx(2 * 1.5 * 9.81, rel=1e-6)
        stacked = ~ground
        on_top = np.where(c.names_b[stacked] == "top", 1.0, -1.0)  # the force on b, b = top or low
        assert (on_top * c.force[stacked, 2]).sum() == pytest.approx(1.5 * 9.81, rel=1e-6)
        sim.step(360)  # 1.5 s more, asleep
    assert traj.contact_count[-1] == 8
    # a ball dropped on the stack wakes it: detected contacts, none doubled
    w.add_body(tb.Sphere(radius=0.05), mass=0.2, position=(0.1, 0, 0.9), name="ball")
    assert len(sim.contacts()) == 8  # a body added: the stack still asleep on its contacts
    sim.step(60)
    c = sim.contacts()
    pairs = [tuple(sorted(p)) for p in zip(c.names_a.tolist(), c.names_b.tolist())]
    assert sim.sleep.awake[1:3].all()
    assert pairs.count(("ground", "low")) == 4 and pairs.count(("low", "top")) == 4
    assert len(pairs) == 8 + pairs.count(("ball", "top"))
    # asleep again, then a push: the kept contacts go with the sleep
    sim.step(480)
    assert not sim.sleep.awake[1:].any() and len(sim.contacts()) >= 8
    w.body(2).apply_impulse((0.0, 0.0, 0.01))
    sim.step(1)
    c = sim.contacts()
    pairs = [tuple(sorted(p)) for p in zip(c.names_a.tolist(), c.names_b.tolist())]
    assert sim.sleep.awake[2] and pairs.count(("ground", "low")) == 4 and pairs.count(("low", "top")) == 4


def test_a_sleeping_stacks_contacts_survive_a_checkpoint_and_a_snapshot(tmp_path):
    """The kept contacts of a sleeping island are part of the sleep state (``sleep_resting_*`` in a
    checkpoint and a snapshot): a run of the stack checkpointed at 1.5 s, asleep, and resumed to
    2.5 s records the same contacts frame by frame as the run uninterrupted (8 in its last
    frames), and a snapshot restored after a wake gives back the sleeping stack's contacts."""
    def stack():
        w = tb.World(gravity=(0, 0, -9.81))
        w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
        w.add_body(tb.Box(size=(0.4, 0.4, 0.4)), mass=1.5, position=(0, 0, 0.2), name="low")
        w.add_body(tb.Box(size=(0.4, 0.4, 0.4)), mass=1.5, position=(0, 0, 0.6), name="top")
        return w

    whole = tb.Simulator(stack(), record_contacts=True)
    traj = whole.run(2.5, frame_rate=24)
    first = tb.Simulator(stack(), record_contacts=True)
    assert first.run_to_file(tmp_path / "run", 1.5, frame_rate=24).status == "completed"
    resumed = tb.Simulator.load_checkpoint(tmp_path / "run" / "checkpoint.npz")
    assert len(resumed.contacts()) == 8  # asleep on them, before a step
    resumed.run_to_file(tmp_path / "run", 2.5, frame_rate=24, resume=True)
    streamed = load_trajectory(tmp_path / "run" / "trajectory.npz")
    assert traj.contact_count[-1] == 8
    assert np.array_equal(streamed.contact_count, traj.contact_count)
    assert np.array_equal(streamed.contact_force, traj.contact_force, equal_nan=True)
    saved = whole.save_state()
    before = whole.contacts()
    whole.world.body(2).apply_impulse((0.0, 0.0, 1.0))
    whole.step(30)
    whole.restore_state(saved)
    after = whole.contacts()
    assert len(after) == 8 and np.array_equal(after.force, before.force)


def test_recorded_contacts_are_the_query_of_each_frame(tmp_path):
    """record_contacts=True: frame k of the trajectory holds the contacts sim.contacts() gave after
    the steps of frame k, padded to the largest count; it survives save and load."""
    w = boxes_on_ground()
    sim = tb.Simulator(w, record_contacts=True)
    traj = sim.run(1.0, frame_rate=24)
    assert traj.contact_count.shape == (25,) and traj.contact_count[0] == len(tb.Simulator(boxes_on_ground()).contacts())
    C = traj.contact_count.max()
    assert C > 0 and traj.contact_point.shape == (25, C, 3) and traj.contact_body_a.shape == (25, C)
    last = sim.contacts()
    k = traj.contact_count[-1]
    assert k == len(last)
    assert np.array_equal(traj.contact_point[-1, :k], last.point)
    assert np.array_equal(traj.contact_force[-1, :k], last.force)
    assert np.all(traj.contact_body_a[-1, k:] == -1) and np.all(np.isnan(traj.contact_point[-1, k:]))
    path = traj.save(tmp_path / "t.npz")
    back = load_trajectory(path)
    for key in ("contact_count", "contact_body_a", "contact_point", "contact_normal_impulse", "contact_force"):
        assert np.array_equal(getattr(back, key), getattr(traj, key), equal_nan=True), key
    # without the flag there are no contact keys
    plain = tb.Simulator(boxes_on_ground()).run(0.25)
    assert plain.contact_count is None


def test_streamed_run_records_the_same_contacts_and_resumes_bit_for_bit(tmp_path):
    """run_to_file with record_contacts streams the same padded arrays as run(); a run resumed
    from its checkpoint (warm-start impulses included) ends with the same state hash and the same
    contact records as an uninterrupted one."""
    whole = tb.Simulator(boxes_on_ground(), record_contacts=True)
    traj = whole.run(1.0, frame_rate=24)

    first = tb.Simulator(boxes_on_ground(), record_contacts=True)
    result = first.run_to_file(tmp_path / "run", 0.5, frame_rate=24)
    assert result.status == "completed"
    resumed = tb.Simulator.load_checkpoint(tmp_path / "run" / "checkpoint.npz")
    assert resumed.record_contacts
    assert len(resumed.soft_step.solver.old_key) > 0  # warm start restored
    resumed.run_to_file(tmp_path / "run", 1.0, frame_rate=24, resume=True)
    assert state_hash(resumed.world) == state_hash(whole.world)
    streamed = load_trajectory(tmp_path / "run" / "trajectory.npz")
    assert np.array_equal(streamed.contact_count, traj.contact_count)
    assert np.array_equal(streamed.contact_point, traj.contact_point, equal_nan=True)
    assert np.array_equal(streamed.contact_friction_impulse, traj.contact_friction_impulse, equal_nan=True)


def test_checkpoint_without_warm_start_would_differ(tmp_path):
    """The saved warm-start impulses matter: dropping them changes the continuation's bits
    (so the bit-identical resume above is a real check)."""
    whole = tb.Simulator(boxes_on_ground())
    whole.run(1.0)
    first = tb.Simulator(boxes_on_ground())
    first.run(0.5)
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    resumed.soft_step.solver.set_warm_start_state({"key": np.zeros(0, np.int64), "normal_impulse": np.zeros(0),
                                                   "friction_impulse": np.zeros((0, 3))})
    resumed.run(0.5)
    assert state_hash(resumed.world) != state_hash(whole.world)


def test_validated_path_gives_the_same_bits_with_contacts(monkeypatch):
    """TUMBLE_VALIDATE=1 runs validate_world after every stage of the contact step too, and
    changes no bit."""
    def run(validate):
        monkeypatch.setenv("TUMBLE_VALIDATE", "1" if validate else "0")
        w = boxes_on_ground()
        sim = tb.Simulator(w)
        assert sim.validate is validate
        sim.run(0.5)
        return state_hash(w)

    assert run(False) == run(True)


def test_same_contact_scene_twice_gives_the_same_bits():
    """Issue: same scene, same version, bit-identical trajectory from run to run."""
    a = tb.Simulator(boxes_on_ground(), record_contacts=True).run(1.0)
    b = tb.Simulator(boxes_on_ground(), record_contacts=True).run(1.0)
    for key in ("position", "orientation", "velocity", "angular_velocity", "contact_point", "contact_force"):
        assert np.array_equal(getattr(a, key), getattr(b, key), equal_nan=True), key


def test_scene_keys_turn_collisions_off_and_record_contacts():
    from tumble.scene import parse_scene

    doc = {
        "simulation": {"duration": 0.5, "record_contacts": True},
        "contact": {"substeps": 2, "restitution_threshold": 0.5},
        "bodies": [{"name": "g", "shape": {"type": "plane"}, "fixed": True},
                   {"name": "b", "shape": {"type": "sphere", "radius": 0.1}, "mass": 1, "position": [0, 0, 0.1]}],
    }
    scene = parse_scene(doc, "s.toml")
    sim = scene.simulator()
    assert sim.record_contacts and sim.contact_settings.substeps == 2 and sim.contact_settings.restitution_threshold == 0.5
    traj = scene.run(progress=False)
    # asleep by 0.5 s, the ball still rests on its contact (kept for sleeping islands since session 34)
    assert traj.contact_count[1] == 1 and traj.contact_count[-1] == 1
    doc["simulation"]["sleeping"] = False
    assert parse_scene(doc, "s.toml").run(progress=False).contact_count[-1] == 1
    doc["simulation"]["collisions"] = False
    scene = parse_scene(doc, "s.toml")
    scene.run(progress=False)
    assert scene.world.x[1, 2] < 0  # fell through the ground
    doc["contact"] = {"substeps": 0}
    with pytest.raises(tb.InputError, match="contact.substeps: must be >= 1"):
        parse_scene(doc, "s.toml")
    doc["contact"] = {"partitions": 0}
    with pytest.raises(tb.InputError, match="contact.partitions: must be >= 1"):
        parse_scene(doc, "s.toml")
    doc["contact"] = {"partition_min_contacts": -1}
    with pytest.raises(tb.InputError, match="contact.partition_min_contacts: must be >= 0"):
        parse_scene(doc, "s.toml")
    doc["contact"] = {"partitions": 3, "partition_min_contacts": 0}
    settings = parse_scene(doc, "s.toml").simulator().contact_settings
    assert settings.partitions == 3 and settings.partition_min_contacts == 0


def test_a_body_moved_just_before_a_checkpoint_wakes_after_the_resume(tmp_path):
    """``World.wake_requests`` (bodies moved, pushed or placed since the last step: the next step
    wakes them) is in the checkpoint. A box asleep on the ground, lifted 0.5 m by hand and saved,
    falls after the resume as it does in the run that was not saved; without the requests the
    resumed box slept on in the air (found by tests/test_snapshot.py's in-memory states, which
    hold them too)."""

    def lifted():
        w = tb.World(gravity=(0, 0, -9.81))
        w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
        box = w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 0.1))
        sim = tb.Simulator(w, dt=1 / 60)
        sim.step(240)
        assert not sim.sleep.awake[1]
        box.x = box.x + (0, 0, 0.5)
        return sim

    straight = lifted()
    straight.step(30)
    assert straight.world.x[1, 2] < 0.4  # it fell

    saved = lifted()
    saved.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    resumed.step(30)
    assert state_hash(resumed.world) == state_hash(straight.world)


def test_a_recording_keeps_the_contact_rows_alone_and_pads_them_as_before():
    """The in-memory recording keeps each frame's ``CONTACT_FIELDS`` rows, not the whole
    ``Contacts`` (whose body names and parts made a 1000-box, 60 s run hold 1.8 GB for 1.2 GB of
    contact data; peak 4.75 GB with the padding's copies: a performance audit, session 43); the
    padded arrays are each frame's rows then the field's padding, bit for bit."""
    from tumble.trajectory import CONTACT_FIELDS

    from tumble.recording import _Recorder

    sim = tb.Simulator(boxes_on_ground(), record_contacts=True)
    recorder = _Recorder(sim.world, 25, contacts_of=sim)
    for _ in range(25):
        sim.step(10)
        recorder.record()
    traj = recorder.trajectory()
    frames = recorder.contact_frames
    assert all(isinstance(f, tuple) and len(f) == len(CONTACT_FIELDS) for f in frames)
    assert sum(len(f[0]) for f in frames) > 25  # the boxes touch the ground in most frames
    # the padded arrays written out here, by hand: each frame's rows, then the field's padding
    C = max(len(f[0]) for f in frames)
    for i, (key, shape, dtype, pad) in enumerate(CONTACT_FIELDS.values()):
        expected = np.full((len(frames), C) + shape, pad, dtype=dtype)
        for k, f in enumerate(frames):
            expected[k, :len(f[0])] = f[i]
        np.testing.assert_array_equal(getattr(traj, key), expected)
    np.testing.assert_array_equal(traj.contact_count, [len(f[0]) for f in frames])
