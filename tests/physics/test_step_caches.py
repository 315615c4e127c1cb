"""What a step keeps from the last one to save its fixed cost (the performance audit's S2) must follow
the world's edits between steps: the World's array views (``world._ArrayView``: kept until
the storage or the body count changes), the bodies of the live shapes (``SoftStep._live_bodies``:
until the table, the filters or the body count change) and the shape pairs that may meet
(``CollisionPipeline.meeting_pairs``: until the table, the filters or the exclusions change).

Each test edits a world between steps (a spawn past the storage's capacity, a mass and a pose, a
collision filter, a joint broken) and compares the steps after with a fresh world's from the same
state, bit for bit, or with what the edit must do (a box let collide lands, bodies let touch are
pushed apart). Each fails when its cache is kept stale on purpose (checked by hand when written)."""

import numpy as np

import tumble as tb
from tumble.joints import FixedJoint

BOX = (0.2, 0.2, 0.2)


def _plane_world():
    w = tb.World(gravity=(0.0, 0.0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    return w


def test_bodies_spawned_past_the_storage_step_as_in_a_world_built_with_them():
    """One box stepped (its views read and kept), then nine more spawned between steps, the
    positions read after each spawn (past the 8 rows the storage starts with: new storage; each
    spawn: one row more) and a new Simulator: 120 steps of the ten falling onto the plane are those
    of a world that had all ten from the start."""
    def spawn(w, k):
        w.add_body(tb.Box(size=BOX), mass=1.0, position=(0.3 * k, 0.0, 0.5 + 0.05 * k))

    a = _plane_world()
    spawn(a, 0)
    tb.Simulator(a).step(0)  # nothing moves; the views are made
    assert a.x.shape == (2, 3)
    for k in range(1, 10):
        spawn(a, k)
        assert a.x.shape == (k + 2, 3) and a.x[-1, 0] == 0.3 * k  # read between spawns, as a user does
    assert np.shares_memory(a.x, a._arrays["x"])
    b = _plane_world()
    for k in range(10):
        spawn(b, k)
    sa, sb = tb.Simulator(a), tb.Simulator(b)
    for _ in range(120):
        sa.step()
        sb.step()
    assert np.array_equal(a.pack(), b.pack())
    assert a.x[1:, 2].max() < 0.2  # landed


def test_a_mass_and_a_pose_set_between_steps_step_as_a_fresh_world_from_the_same_state():
    """A box falling (no contact yet) given a new mass and moved between steps: its next 150 steps
    (it lands on the plane) are those of a fresh world of that mass from the same state."""
    a = _plane_world()
    a.add_body(tb.Box(size=BOX), mass=1.0, position=(0.0, 0.0, 0.6), angular_velocity=(0.5, 0.2, 0.0))
    sa = tb.Simulator(a)
    sa.step(5)
    a.set_mass(1, 2.5)
    a.bodies[1].x = (0.4, -0.2, 0.5)
    b = _plane_world()
    b.add_body(tb.Box(size=BOX), mass=2.5, position=(0.0, 0.0, 0.6))
    b.set_state(a.state())
    sb = tb.Simulator(b)
    for _ in range(150):
        sa.step()
        sb.step()
    assert np.array_equal(a.pack(), b.pack())
    assert abs(a.x[1, 2] - 0.1) < 0.01  # resting on the plane


def test_a_collision_filter_set_between_steps_lets_the_box_land_as_in_a_fresh_world():
    """A box that touches nothing (category 0, mask 0: no live shape pair, so the collision stages
    are skipped) given the default filter between steps, 0.3 m above the plane: it lands as a
    fresh world's box from the same state does, bit for bit (a stale list of live shapes or of the
    pairs that may meet let it fall through the plane)."""
    a = _plane_world()
    a.add_body(tb.Box(size=BOX), mass=1.0, position=(0.0, 0.0, 0.5),
               collision_filter=tb.CollisionFilter(category=0, mask=0))
    sa = tb.Simulator(a)
    sa.step(3)
    assert len(sa.contacts()) == 0
    a.bodies[1].collision_filter = tb.CollisionFilter()
    b = _plane_world()
    b.add_body(tb.Box(size=BOX), mass=1.0, position=(0.0, 0.0, 0.5))
    b.set_state(a.state())
    sb = tb.Simulator(b)
    for _ in range(200):
        sa.step()
        sb.step()
    assert np.array_equal(a.pack(), b.pack())
    assert abs(a.x[1, 2] - 0.1) < 0.01  # on the plane, not through it


def test_a_joint_broken_between_steps_lets_its_bodies_touch():
    """Two boxes jointed (no contact between them: the pair is excluded, so nothing may meet and
    the collision stages are skipped), one inside the other; the joint broken between steps, the
    pair may meet again: the next step has their contacts and they are pushed apart."""
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    w.add_body(tb.Box(size=BOX), fixed=True, name="a")
    w.add_body(tb.Box(size=BOX), mass=1.0, position=(0.0, 0.0, 0.1), name="b")
    grip = w.add_joint(FixedJoint("a", "b", anchor=(0.0, 0.0, 0.05)))
    sim = tb.Simulator(w)
    sim.step(5)
    assert len(sim.contacts()) == 0
    z0 = w.x[1, 2]
    grip.broken = True
    sim.step()
    assert len(sim.contacts()) > 0
    sim.step(30)
    assert w.x[1, 2] > z0 + 0.05


def test_a_pickled_simulator_in_contact_goes_on_bit_for_bit():
    """A box on a plane pickled mid-run (its contact solver's and manifolds' views, kept while their
    counts stay, become arrays of their own in the copy: ``__setstate__`` makes them views of the
    copy's buffers again): the copy's next 60 steps are the original's, bit for bit."""
    import pickle

    w = _plane_world()
    w.add_body(tb.Box(size=BOX), mass=1.0, position=(0.0, 0.0, 0.1))
    w.sleeping = False
    sim = tb.Simulator(w)
    sim.step(10)
    copy = pickle.loads(pickle.dumps(sim))
    for _ in range(60):
        sim.step()
        copy.step()
    assert np.array_equal(sim.world.pack(), copy.world.pack())
