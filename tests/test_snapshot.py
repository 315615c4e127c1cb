"""In-memory snapshots (``Simulator.save_state`` / ``restore_state``, ``tumble.snapshot``).

What they are compared with: the same simulation run straight through. A restored simulation
runs the same kernels on the same bits, so every comparison is exact (state hashes, arrays,
events): any difference at all means something the next step reads was not put back. Each
test first takes the simulation somewhere else after the save (pushes, a broken joint, bodies
woken or asleep) and checks that it is somewhere else, so that a restore that did nothing fails.
"""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest

import tumble as tb
from tumble.checks import state_hash
from tumble.errors import InputError
from tumble.scene import load_scene

from .test_reliability_joints import BREAKER, joint_world

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def example(name: str, contact_events: bool = False) -> tb.Simulator:
    """The example scene's simulator as ``tumble run`` makes it (contact events on if asked)."""
    s = load_scene(EXAMPLES / f"{name}.toml")
    return tb.Simulator(s.world, dt=s.dt, integrator=s.integrator, substeps=s.substeps, rtol=s.rtol, atol=s.atol,
                        max_energy_growth=s.max_energy_growth, contact_settings=s.contact,
                        record_contacts=s.record_contacts, joint_settings=s.joint_settings,
                        record_joints=s.record_joints, contact_events=contact_events)


def push_everything(sim: tb.Simulator, seed: int = 0):
    """Kick every moving body: the run after this is not the run after the save."""
    w = sim.world
    rng = np.random.default_rng(seed)
    moving = np.flatnonzero(w.moving)
    for i in moving:
        w.body(int(i)).apply_impulse(rng.normal(size=3) * w.mass[i], point=w.x[i] + rng.normal(size=3) * 0.05)


# (scene, steps before the save, steps after): contacts and sleep (dominoes: the first falls at
# once, the last are still standing when saved), a URDF arm's drives and joints knocking a tower
# down, kinematic platforms on keyframed paths, a conveyor with a sensor.
SCENES = [("dominoes", 120, 240), ("robot_arm", 120, 120), ("platforms", 120, 120), ("conveyor", 120, 120)]


@pytest.mark.parametrize("name, before, after", SCENES, ids=[s[0] for s in SCENES])
def test_a_restored_simulation_goes_on_with_the_bits_of_the_uninterrupted_one(name, before, after):
    straight = example(name)
    straight.step(before)
    at_save = state_hash(straight.world)
    straight.step(after)
    expected = state_hash(straight.world)

    sim = example(name)
    sim.step(before)
    saved = sim.save_state()
    assert saved.t == sim.world.t and saved.step_index == before
    push_everything(sim)
    sim.step(after)
    assert state_hash(sim.world) != expected  # it went elsewhere

    table = sim.soft_step.pipeline.table
    sim.restore_state(saved)
    assert sim.soft_step.pipeline.table is table  # the shapes' table (the world's description) is kept
    assert state_hash(sim.world) == at_save and sim.step_index == before
    sim.step(after)
    assert state_hash(sim.world) == expected
    # a state is not used up: the same branch again
    push_everything(sim, seed=1)
    sim.restore_state(saved)
    sim.step(after)
    assert state_hash(sim.world) == expected


def test_sleep_joints_broken_and_warm_starts_come_back():
    """``joint_world`` (tests/test_reliability_joints.py): a motor, limits, a ball joint, a slider
    on a spring, a box at rest on the ground, and a joint that breaks at about 0.2 s. Saved at
    0.1 s (the joint whole), taken to 0.8 s (broken, the box asleep), restored: the joint is whole
    again and the steps to 0.8 s give the straight run's bits, its joint readings and its sleep state."""
    a = tb.Simulator(joint_world(), dt=1 / 240)
    a.step(192)
    assert a.world.joints[BREAKER].broken
    b = tb.Simulator(joint_world(), dt=1 / 240)
    b.step(24)
    saved = b.save_state()
    assert not b.world.joints[BREAKER].broken
    push_everything(b)
    b.step(168)
    assert b.world.joints[BREAKER].broken and state_hash(b.world) != state_hash(a.world)

    b.restore_state(saved)
    assert not b.world.joints[BREAKER].broken
    b.step(168)
    assert state_hash(b.world) == state_hash(a.world)
    for key, value in a.joint_readings().items():
        np.testing.assert_array_equal(b.joint_readings()[key], value, err_msg=key)
    for key, value in a.sleep.state().items():
        np.testing.assert_array_equal(b.sleep.state()[key], value, err_msg=key)
    assert not a.sleep.awake.all()  # something was asleep to compare


def test_contact_events_after_a_restore_are_the_straight_runs():
    """With contact events on, the touching pairs at the save come back: the begin and end
    events of the steps after a restore are those of the straight run (a pair touching at the
    save does not begin again)."""

    def run(sim, steps):
        events = []
        for _ in range(steps):
            sim.step()
            e = sim.contact_events()
            events.append((e.begin_body_a.tolist(), e.begin_body_b.tolist(), e.end_body_a.tolist(),
                           e.end_body_b.tolist()))
        return events

    straight = example("dominoes", contact_events=True)
    straight.step(120)
    straight.contact_events()
    expected = run(straight, 120)
    assert any(e[0] for e in expected) and any(e[2] for e in expected)

    sim = example("dominoes", contact_events=True)
    sim.step(120)
    sim.contact_events()
    saved = sim.save_state()
    push_everything(sim)
    assert run(sim, 120) != expected
    sim.restore_state(saved)
    assert run(sim, 120) == expected


def test_a_pickled_state_restores_into_an_equal_simulation_made_elsewhere():
    """A state is plain data: pickled, sent (here: to a second simulation of the same scene file,
    never stepped, as a worker process would build it) and restored there, it goes on with the
    same bits as the simulation it came from."""
    origin = example("dominoes")
    origin.step(100)
    state = pickle.loads(pickle.dumps(origin.save_state()))
    origin.step(100)

    elsewhere = example("dominoes")
    elsewhere.restore_state(state)
    elsewhere.step(100)
    assert state_hash(elsewhere.world) == state_hash(origin.world)


def test_a_state_of_another_world_or_dt_is_one_line():
    sim = example("dominoes")
    sim.step(2)
    state = sim.save_state()

    bigger = example("dominoes")
    bigger.world.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(0, 0, 5))
    other_dt = tb.Simulator(example("dominoes").world, dt=sim.dt / 2)
    cases = [(bigger, state, "bodies"), (other_dt, state, "dt"), (sim, {"x": 1}, "SimState")]
    before = [state_hash(target.world) for target, _, _ in cases]
    for target, value, word in cases:
        with pytest.raises(InputError) as err:
            target.restore_state(value)
        line = str(err.value)
        assert "\n" not in line and "state" in line and word in line, line
    # a refused restore changes nothing
    assert [state_hash(target.world) for target, _, _ in cases] == before


def test_a_state_saved_the_step_before_an_island_falls_asleep_restores_and_reports_its_contacts(tmp_path):
    """A box settling on the ground, saved (in memory and to a checkpoint) at the step before it
    falls asleep: restored or loaded, the next step puts it to sleep and ``contacts()`` reports its
    resting contacts with the impulses of the run straight through, to the bit. The sleeping
    island's contacts carry the last step's impulses, which a restore had not put back: that step
    raised an IndexError (found by benchmarks/type_change.py, session 39). Its contacts are
    compared field by field, exactly."""
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    w.add_body(tb.Box(size=(0.3, 0.3, 0.3)), mass=1.0, position=(0, 0, 0.16))
    sim = tb.Simulator(w)
    saved = None
    for _ in range(600):
        saved = sim.save_state()
        sim.save_checkpoint(tmp_path / "c.npz")
        sim.step(1)
        if not sim.sleep.awake[1]:
            break
    assert not sim.sleep.awake[1]
    straight = sim.contacts()
    assert len(straight) == 4 and np.all(straight.normal_impulse > 0.0)
    sim.step(3)
    sim.restore_state(saved)
    assert sim.sleep.awake[1]
    sim.step(1)
    loaded = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    loaded.step(1)
    for again in (sim, loaded):
        assert not again.sleep.awake[1]
        c = again.contacts()
        for name in ("body_a", "body_b", "point", "normal", "separation", "normal_impulse", "friction_impulse", "force"):
            np.testing.assert_array_equal(getattr(c, name), getattr(straight, name), err_msg=name)
