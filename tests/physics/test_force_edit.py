"""Force records edited after ``World.add_force`` (``forces._ForceRecord``): a field set on an added
record acts from the next step and wakes its bodies, as a joint record's does (docs/forces.md).

Compared with closed forms on the changed values: the velocity a constant force gives a free
body (v = F t / m, exact to round-off: the integrators are exact for constant forces), the rest
length of a weight on a spring (m g / k), and the constructor's own checks for bad values."""

import math
import pickle

import numpy as np
import pytest

import tumble as tb
from tumble import checks
from tumble.forces import force_edit_count
from tumble.solver.island import LINEAR_SLEEP_TOLERANCE


def test_a_constant_force_set_mid_run_changes_the_acceleration_at_once():
    """A 2 kg body, no gravity, pushed by 4 N along x for 1 s, then the record's force set to
    (-2, 6, 0) N for 0.5 s: v = (2 - 0.5, 1.5, 0) m/s, the sum of F t / m (1e-12: exact to
    round-off for constant forces)."""
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Sphere(radius=0.1), mass=2.0, name="ball")
    push = w.add_force(tb.ConstantForce("ball", force=(4.0, 0.0, 0.0)))
    sim = tb.Simulator(w, dt=1 / 240)
    sim.step(240)
    count = force_edit_count()
    push.force = (-2.0, 6.0, 0.0)
    assert force_edit_count() == count + 1 and push.force == (-2.0, 6.0, 0.0)
    sim.step(120)
    np.testing.assert_allclose(w.v[0], [4.0 / 2.0 * 1.0 - 2.0 / 2.0 * 0.5, 6.0 / 2.0 * 0.5, 0.0], rtol=0, atol=1e-12)


def test_a_stiffer_spring_wakes_a_sleeping_weight_and_it_hangs_at_m_g_over_k():
    """A 1 kg ball hanging on a damped spring (k 50 N/m, rest length 1 m) from a world anchor
    falls asleep at its rest, 1 + g / 50 m below the anchor; the record's stiffness set to 200 N/m,
    it wakes and comes to rest at 1 + g / 200. Asleep, a body stops where its speed fell under the
    sleep tolerance: within that speed over the spring's angular frequency sqrt(k / m) of its rest
    (7 mm at 50 N/m, 3.5 mm at 200; measured 1.6 mm at 200)."""
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)  # contacts: the step with sleeping
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(0, 0, 5.0 - 1.0 - 9.81 / 50), name="ball")
    spring = w.add_force(tb.Spring("ball", None, anchor_b=(0, 0, 5.0), stiffness=50.0, damping=4.0, rest_length=1.0))
    sim = tb.Simulator(w)
    for k in (50.0, 200.0):
        spring.stiffness = k
        sim.step(1)
        assert sim.sleep.awake[1]  # woken by the edit (the first: awake anyway)
        sim.step(240 * 5)
        assert not sim.sleep.awake[1]
        assert 5.0 - w.x[1, 2] == pytest.approx(1.0 + 9.81 / k, abs=LINEAR_SLEEP_TOLERANCE / math.sqrt(k))


@pytest.mark.parametrize("field, value, key, problem", [
    ("stiffness", -1.0, "stiffness", ">= 0"),
    ("anchor_b", (1.0, 2.0), "anchor_b", "3"),
    ("rest_length", None, "rest_length", "at add_force only"),
    ("body_a", "other", "body_a", "fixed when the force was added"),
])
def test_a_bad_edit_is_refused_and_the_record_stays_as_it_was(field, value, key, problem):
    w = tb.World()
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, name="ball")
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(1, 0, 0), name="other")
    spring = w.add_force(tb.Spring("ball", None, anchor_b=(0, 0, 1.0), stiffness=50.0, rest_length=1.0))
    before, count = dict(spring.__dict__), force_edit_count()
    with pytest.raises(tb.InputError, match=problem) as err:
        setattr(spring, field, value)
    assert err.value.key == key
    assert spring.__dict__ == before and force_edit_count() == count


def test_a_removed_or_never_added_record_is_a_plain_record_and_worlds_with_forces_pickle():
    w = tb.World()
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, name="ball")
    loose = tb.ConstantForce("ball", force=(1.0, 0.0, 0.0))
    count = force_edit_count()
    loose.force = (2.0, 0.0, 0.0)  # not added: no edit, no check beyond the constructor's
    added = w.add_force(tb.ConstantForce("ball", force=(1.0, 0.0, 0.0)))
    w.remove_force(added)
    added.force = (3.0, 0.0, 0.0)
    assert force_edit_count() == count
    w.add_force(loose)
    loose.force = (0.5, 0.0, 0.0)
    copy = pickle.loads(pickle.dumps(w))
    for world in (w, copy):
        tb.Simulator(world, dt=1 / 240).step(24)
    assert checks.state_hash(copy) == checks.state_hash(w)
    assert w.v[0, 0] == pytest.approx(0.5 * 0.1, abs=1e-12) and math.isfinite(w.x[0, 0])


def test_a_wind_over_every_body_set_on_a_sleeping_world_wakes_them_and_drags_them_along():
    """A drag over every moving body (``bodies=None``) with still air; two boxes asleep on a
    frictionless ground; the wind set to 2 m/s along x: both wake and follow
    v = w (1 - exp(-c t / m)) (linear drag c = 1 N s/m, m = 2 kg), at 1 s to 1e-3 relative (the
    step's first-order velocity update of a velocity-dependent force; measured 2e-4)."""
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, material=tb.Material(friction=0.0))
    for x in (0.0, 2.0):
        w.add_body(tb.Box(size=(0.4, 0.4, 0.4)), mass=2.0, position=(x, 0, 0.2), material=tb.Material(friction=0.0))
    wind = w.add_force(tb.Wind(velocity=(0.0, 0.0, 0.0), linear=1.0))
    sim = tb.Simulator(w)
    sim.step(240 * 2)
    assert not sim.sleep.awake[1:].any()
    wind.wind = (2.0, 0.0, 0.0)
    sim.step(240)
    expected = 2.0 * (1.0 - math.exp(-1.0 * 1.0 / 2.0))
    np.testing.assert_allclose(w.v[1:, 0], [expected, expected], rtol=1e-3)
