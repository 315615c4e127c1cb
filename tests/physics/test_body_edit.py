"""A body's material and mass changed between steps (``World.set_material``, ``body.material = ...``,
``World.set_mass``, ``body.set_mass``): PyBullet's ``changeDynamics`` and MuJoCo's model edits,
what domain randomization does between episodes and a game between frames.

Compared with the textbook on the changed values: the Coulomb acceleration on an incline and
a resting block that starts to slide when its friction is lowered (the contact issue's 1 %), the
bounce apex h e^2 with a restitution set in flight, the 1-D elastic impact's velocities with a
mass set in flight, the weight m g a resting box's contacts carry after its mass is set (0.1 %),
and the momenta P = m v, L = I omega that follow the kept velocities. Before this change a body's
material and mass could not be changed after ``add_body`` (its material was read once)."""

import math

import numpy as np
import pytest

import tumble as tb
from tumble import checks

from .test_contact import G, ground_world, incline_world


def test_a_block_held_by_friction_slides_at_the_coulomb_acceleration_once_its_friction_is_lowered():
    """mu 0.7 on 30 degrees holds the block (tan 30 = 0.577) and it falls asleep; its material
    (and the slope's: the pair mixes the two, sqrt) set to mu 0.3, it wakes and slides with
    a = g (sin 30 - 0.3 cos 30), fitted from its speed along the slope over 1.5 s (1 %, the
    contact issue's tolerance for the same formula)."""
    w, downhill, _ = incline_world(0.7)
    sim = tb.Simulator(w)
    sim.step(240 * 2)
    assert not sim.sleep.awake[1]
    x0 = w.x[1].copy()
    w.set_material("slope", tb.Material(friction=0.3))
    w.bodies[1].material = {"friction": 0.3}  # a mapping: its keys, the rest defaults
    assert w.materials[1].friction == 0.3 and w.materials[1].restitution == tb.Material().restitution
    times, speeds = [], []
    for k in range(1, 361):
        sim.step(1)
        times.append(k * sim.dt)
        speeds.append(float(w.v[1] @ downhill))
    slope = np.polyfit(times[60:], speeds[60:], 1)[0]
    assert slope == pytest.approx(G * (0.5 - 0.3 * math.cos(math.radians(30))), rel=0.01)
    assert np.linalg.norm(w.x[1] - x0) > 0.1


def test_a_restitution_set_in_flight_gives_the_textbook_bounce():
    """A sphere (r 0.5) dropped from 2 m (lowest point) onto a frictionless ground, both with
    restitution 0.5: it bounces to h e^2 = 0.5 m; past that apex both set to 0.8: the next bounce
    reaches 0.5 x 0.8^2 = 0.32 m (each 1 %, the contact issue's bounce tolerance)."""
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, material=tb.Material(friction=0.0, restitution=0.5))
    ball = w.add_body(tb.Sphere(radius=0.5), mass=1.0, position=(0, 0, 2.5),
                      material=tb.Material(friction=0.0, restitution=0.5))
    sim = tb.Simulator(w)

    def next_apex():
        """The height of the lowest point at the next apex after a bounce (m)."""
        bounced = False
        while True:
            before = w.v[1, 2]
            sim.step(1)
            bounced = bounced or (before < 0.0 and w.v[1, 2] > 0.0)
            if bounced and w.v[1, 2] <= 0.0:
                return w.x[1, 2] - 0.5

    assert next_apex() == pytest.approx(2.0 * 0.5 ** 2, rel=0.01)
    bouncy = tb.Material(friction=0.0, restitution=0.8)
    w.set_material(0, bouncy)
    ball.material = bouncy
    assert next_apex() == pytest.approx(2.0 * 0.5 ** 2 * 0.8 ** 2, rel=0.01)


def test_a_mass_set_in_flight_gives_the_elastic_impacts_velocities():
    """Two spheres (made 1 kg and 1 kg) head on, e = 1, no friction, no gravity; in flight the
    second set to 3 kg: its velocity is kept (P = 3 v) and the impact gives the 1-D elastic
    velocities of 1 and 3 kg, v1' = ((m1 - m2) v1 + 2 m2 v2) / (m1 + m2) (to 1e-9, as the contact
    tests hold the impact made with those masses), kinetic energy kept to 1e-6."""
    w = tb.World(gravity=(0, 0, 0))
    mat = tb.Material(friction=0.0, restitution=1.0)
    m1, m2, v1, v2 = 1.0, 3.0, 4.0, -1.0
    w.add_body(tb.Sphere(radius=0.3), mass=1.0, position=(-1, 0, 0), velocity=(v1, 0, 0), material=mat, name="a")
    b = w.add_body(tb.Sphere(radius=0.4), mass=1.0, position=(1, 0, 0), velocity=(v2, 0, 0), material=mat, name="b")
    sim = tb.Simulator(w)
    sim.step(12)
    b.set_mass(m2)
    assert w.v[1, 0] == pytest.approx(v2, abs=1e-15) and w.P[1, 0] == pytest.approx(m2 * v2, abs=1e-15)
    assert b.inertia_body[0, 0] == pytest.approx(0.4 * m2 * 0.4 ** 2, rel=1e-12)  # a solid sphere's, scaled
    e0 = w.kinetic_energy()
    sim.run(1.0, frame_rate=24)
    assert w.kinetic_energy() == pytest.approx(e0, rel=1e-6)
    assert w.v[0, 0] == pytest.approx(((m1 - m2) * v1 + 2 * m2 * v2) / (m1 + m2), abs=1e-9)
    assert w.v[1, 0] == pytest.approx(((m2 - m1) * v2 + 2 * m1 * v1) / (m1 + m2), abs=1e-9)


def test_a_resting_box_given_a_new_mass_carries_its_new_weight():
    """A 2 kg box asleep on the ground set to 5 kg: it wakes and, over 1 s of rest, its contacts'
    normal impulses sum to 5 g (1 s) within 0.1 % (the contact issue's resting test)."""
    w = ground_world()
    box = w.add_body(tb.Box(size=(0.4, 0.6, 0.3)), mass=2.0, position=(0, 0, 0.15), material=tb.Material(friction=0.5))
    sim = tb.Simulator(w)
    sim.step(240 * 2)
    assert not sim.sleep.awake[1]
    box.mass = 5.0  # Body.mass's setter: World.set_mass
    assert w.mass[1] == 5.0 and box.inertia_body[0, 0] == pytest.approx(5.0 / 12 * (0.6 ** 2 + 0.3 ** 2), rel=1e-12)
    w.sleeping = False  # measured over 1 s of rest: a sleeping box has no contacts to measure
    sim.step(240)
    total = 0.0
    for _ in range(240):
        sim.step(1)
        total += sim.contacts().normal_impulse.sum()
    assert total == pytest.approx(5.0 * G, rel=1e-3)


def test_an_inertia_given_keeps_the_angular_velocity_and_its_momentum_follows():
    """A spinning, tumbling box given mass 3 kg and a diagonal inertia: v and omega kept, P = m v,
    L = R I R^T omega (1e-12 relative), and the torque-free motion after it keeps that L (1e-9)."""
    w = tb.World(gravity=(0, 0, 0))
    box = w.add_body(tb.Box(size=(1, 2, 3)), mass=1.0, velocity=(0.1, 0.2, 0.3), angular_velocity=(0.3, 2.0, 0.1),
                     euler_deg=(10, 20, 30))
    sim = tb.Simulator(w)
    sim.step(24)
    v, omega, R = w.v[0].copy(), w.omega[0].copy(), w.R[0].copy()
    box.set_mass(3.0, inertia=(0.5, 0.4, 0.3))
    np.testing.assert_allclose(w.v[0], v, rtol=1e-12)
    np.testing.assert_allclose(w.omega[0], omega, rtol=1e-12)
    np.testing.assert_allclose(w.P[0], 3.0 * v, rtol=1e-12)
    L = R @ np.diag([0.5, 0.4, 0.3]) @ R.T @ omega
    np.testing.assert_allclose(w.L[0], L, rtol=1e-12)
    sim.step(240)
    np.testing.assert_allclose(w.L[0], L, rtol=1e-9)


@pytest.mark.parametrize("call, key, problem", [
    (lambda w: w.set_mass("ground", 1.0), "mass", "fixed or kinematic"),
    (lambda w: w.set_mass("box", -1.0), "mass", "positive"),
    (lambda w: w.set_mass("box", math.nan), "mass", "positive"),
    (lambda w: w.set_mass("box", 1.0, inertia=(1.0, 1.0, 5.0)), "inertia", "triangle"),
    (lambda w: w.set_mass("box", 1.0, inertia=(1.0, -1.0, 1.0)), "inertia", "positive definite"),
    (lambda w: w.set_mass("box", 1.0, inertia="heavy"), "inertia", "3 numbers"),
    (lambda w: w.set_material("box", {"friction": -0.5}), "material.friction", ">= 0"),
    (lambda w: w.set_material("box", {"stickiness": 1.0}), "material", "unknown key .stickiness."),
    (lambda w: w.set_material("nobody", tb.Material()), "body", "unknown body"),
])
def test_bad_edits_are_one_clear_error_and_change_nothing(call, key, problem):
    w = ground_world()
    w.add_body(tb.Box(size=(0.4, 0.6, 0.3)), mass=2.0, position=(0, 0, 0.15), name="box")
    before = (checks.state_hash(w), w.mass.copy(), w.inertia_body.copy(), list(w.materials), w.material_version)
    with pytest.raises(tb.InputError, match=problem) as err:
        call(w)
    assert err.value.key == key
    after = (checks.state_hash(w), w.mass.copy(), w.inertia_body.copy(), list(w.materials), w.material_version)
    assert before[0] == after[0] and before[3] == after[3] and before[4] == after[4]
    np.testing.assert_array_equal(before[1], after[1])
    np.testing.assert_array_equal(before[2], after[2])


def test_a_run_with_edited_bodies_resumes_bit_for_bit(tmp_path):
    """A checkpoint after a mass and a material were set carries them: the resumed run equals the
    uninterrupted one."""
    def start():
        w = ground_world()
        w.add_body(tb.Box(size=(0.4, 0.6, 0.3)), mass=2.0, position=(0, 0, 0.5), velocity=(1, 0, 0), name="box")
        sim = tb.Simulator(w)
        sim.step(60)
        w.set_mass("box", 4.0)
        w.set_material("box", tb.Material(friction=0.1, restitution=0.3))
        sim.step(60)
        return sim

    whole, first = start(), start()
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    assert resumed.world.mass[1] == 4.0 and resumed.world.materials[1].friction == 0.1
    whole.step(240)
    resumed.step(240)
    assert checks.state_hash(resumed.world) == checks.state_hash(whole.world)


def test_a_margin_set_on_a_resting_box_lifts_it_by_the_margin():
    """A box resting on the ground given a material with margin 20 cm (MuJoCo's geom margin: a pair
    rests the sum of its margins apart) rises to rest 20 cm higher, within 1 mm (the resting
    contact's depth, the contact issue's penetration bound)."""
    w = ground_world()
    box = w.add_body(tb.Box(size=(0.4, 0.6, 0.3)), mass=2.0, position=(0, 0, 0.15))
    sim = tb.Simulator(w)
    sim.step(240)
    z0 = w.x[1, 2]
    box.material = tb.Material(margin=0.2)
    sim.step(240 * 2)
    assert w.x[1, 2] - z0 == pytest.approx(0.2, abs=1e-3)


def test_gravity_set_between_steps_wakes_a_sleeping_box_and_it_slides_as_coulomb_says():
    """A box (friction 0.2 on the ground) asleep; gravity set to (3, 0, -9.81) (a board tilted, as
    a maze game does): it wakes and slides with a = 3 - 0.2 x 9.81 along x, fitted from its speed
    over 1 s (1 %, the contact issue's tolerance for the incline). A bad value is one InputError
    and gravity stays."""
    w = ground_world()
    w.set_material(0, tb.Material(friction=0.2))
    w.add_body(tb.Box(size=(0.4, 0.6, 0.3)), mass=2.0, position=(0, 0, 0.15), material=tb.Material(friction=0.2))
    sim = tb.Simulator(w)
    sim.step(240 * 2)
    assert not sim.sleep.awake[1]
    w.gravity = (3.0, 0.0, -G)
    times, speeds = [], []
    for k in range(1, 241):
        sim.step(1)
        times.append(k * sim.dt)
        speeds.append(float(w.v[1, 0]))
    assert np.polyfit(times[24:], speeds[24:], 1)[0] == pytest.approx(3.0 - 0.2 * G, rel=0.01)
    with pytest.raises(tb.InputError, match="3 numbers") as err:
        w.gravity = "down"
    assert err.value.key == "gravity"
    np.testing.assert_array_equal(w.gravity, [3.0, 0.0, -G])
