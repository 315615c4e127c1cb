"""A body's linear and angular damping (``World.set_damping``, ``body.linear_damping``,
``body.angular_damping``, the scene keys of the same names): Box2D's and PhysX's damping rates,
what PyBullet and Blender give every body by default (as a fraction per second). Before, damping
was only a ``tb.Drag`` record (a force -k v and a torque -k omega, not scaled by the body's mass
and inertia).

Compared with closed forms: with nothing else acting, dv/dt = -c v and dL/dt = -c_a L, so
v = v0 e^(-c t) and L = L0 e^(-c_a t) (the world-frame angular momentum keeps its direction while
an unsymmetric body tumbles); under gravity, v_z = -(g / c)(1 - e^(-c t)). The rk4 step's error
on these over 1.5-2 s at dt 1/240 is round-off and h^4 (measured 1.2e-14 to 6.4e-12 relative):
the tolerances are 1e-10."""

import math

import numpy as np
import pytest

import tumble as tb
from tumble.checks import state_hash

from .test_contact import G, ground_world

DT = 1.0 / 240.0


def test_a_tumbling_body_loses_velocity_and_angular_momentum_as_e_to_the_minus_c_t():
    """A 1 x 0.5 x 0.2 m box spinning about an axis between its principal ones (it tumbles) and
    moving at (1, 2, -0.5) m/s in zero gravity, damping 0.7 and 0.3 1/s: after 2 s, v = v0 e^(-1.4)
    and L = L0 e^(-0.6) as vectors (1e-10 relative); its kinetic energy fell. A Drag of the same
    numbers (torque -k omega) would not keep L's direction on this body."""
    w = tb.World(gravity=(0, 0, 0))
    box = w.add_body(tb.Box(size=(1.0, 0.5, 0.2)), mass=3.0, velocity=(1, 2, -0.5), angular_velocity=(0.3, 4.0, 0.5),
                     linear_damping=0.7, angular_damping=0.3)
    v0, L0, e0 = box.v.copy(), box.L.copy(), w.kinetic_energy()
    tb.Simulator(w, dt=DT).step(480)
    np.testing.assert_allclose(box.v, v0 * math.exp(-1.4), rtol=1e-10)
    np.testing.assert_allclose(box.L, L0 * math.exp(-0.6), rtol=1e-10, atol=1e-10 * np.linalg.norm(L0))
    assert w.kinetic_energy() < 0.3 * e0


def test_a_damped_body_falls_to_its_terminal_velocity():
    """Dropped from rest under gravity with linear damping 2 1/s: v_z = -(g / 2)(1 - e^(-2 t)) after
    1.5 s (1e-10 relative), near its terminal velocity g / c = 4.9 m/s; z = z0 - (g / c)(t - (1 -
    e^(-c t)) / c)."""
    w = tb.World(gravity=(0, 0, -G))
    ball = w.add_body(tb.Sphere(radius=0.1), mass=0.5, position=(0, 0, 10), linear_damping=2.0)
    tb.Simulator(w, dt=DT).step(360)
    t, c = 1.5, 2.0
    assert ball.v[2] == pytest.approx(-(G / c) * (1 - math.exp(-c * t)), rel=1e-10)
    assert ball.x[2] == pytest.approx(10 - (G / c) * (t - (1 - math.exp(-c * t)) / c), rel=1e-10)


def test_damping_set_between_steps_takes_the_new_rate_and_none_keeps_the_other():
    """``set_damping(linear=...)`` keeps the angular rate, and the body decays at the new rate from
    then on: v(2 s) = v0 e^(-0.5 - 1.5) (1e-10); a mass change keeps the rate (the row's c m is
    made again): the rate is the body's, not a force coefficient."""
    w = tb.World(gravity=(0, 0, 0))
    b = w.add_body(tb.Sphere(radius=0.1), mass=1.0, velocity=(3, 0, 0), linear_damping=0.5, angular_damping=0.2)
    sim = tb.Simulator(w, dt=DT)
    sim.step(240)
    w.set_damping(b, linear=1.5)
    assert b.linear_damping == 1.5 and b.angular_damping == 0.2
    b.mass = 4.0  # velocity kept (set_mass)
    sim.step(240)
    assert b.v[0] == pytest.approx(3 * math.exp(-0.5 - 1.5), rel=1e-10)


def test_a_damped_box_still_rests_on_the_ground_with_its_weight():
    """Damping takes nothing from a body at rest: a damped box settles on the ground (speed under
    1 mm/s), its contacts carrying m g (0.1 %)."""
    w = ground_world()
    box = w.add_body(tb.Box(size=(0.4, 0.4, 0.4)), mass=2.0, position=(0, 0, 0.25), linear_damping=5.0,
                     angular_damping=5.0)
    sim = tb.Simulator(w, dt=DT)
    sim.step(240)
    assert np.linalg.norm(box.v) < 1e-3
    assert sim.contacts().force[:, 2].sum() == pytest.approx(2.0 * G, rel=1e-3)


def test_a_checkpoint_keeps_the_damping_and_resumes_bit_for_bit(tmp_path):
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Box(size=(0.3, 0.2, 0.1)), mass=1.0, position=(0, 0, 1), velocity=(1, 0, 2),
               angular_velocity=(1, 2, 3), linear_damping=0.4, angular_damping=0.9, name="box")
    sim = tb.Simulator(w, dt=DT)
    sim.step(60)
    sim.save_checkpoint(tmp_path / "c.npz")
    sim.step(60)
    loaded = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    b = loaded.world.body("box")
    assert (b.linear_damping, b.angular_damping) == (0.4, 0.9)
    loaded.step(60)
    assert state_hash(loaded.world) == state_hash(w)


@pytest.mark.parametrize("value", [-0.1, math.nan, math.inf, "much", True])
def test_a_bad_damping_is_refused_with_one_line_and_nothing_changes(value):
    w = tb.World()
    b = w.add_body(tb.Sphere(radius=0.1), mass=1.0, linear_damping=0.5)
    for set_ in (lambda: setattr(b, "linear_damping", value), lambda: w.set_damping(b, angular=value)):
        with pytest.raises(tb.InputError, match=r"_damping: must be a finite rate >= 0 in 1/s") as err:
            set_()
        assert "\n" not in str(err.value)
    assert (b.linear_damping, b.angular_damping) == (0.5, 0.0)
    with pytest.raises(tb.InputError, match="angular_damping: must be a finite rate"):
        w.add_body(tb.Sphere(radius=0.1), mass=1.0, angular_damping=value)
    assert w.body_count == 1


def test_a_scene_files_damping_and_its_bad_value(tmp_path, capsys):
    from tumble.cli import main as cli_main
    from tumble.scene import load_scene

    text = '[[bodies]]\nname = "ball"\nshape = { type = "sphere", radius = 0.1 }\nmass = 1.0\nEXTRA\n'
    path = tmp_path / "s.toml"
    path.write_text(text.replace("EXTRA", "linear_damping = 0.04\nangular_damping = 0.1"))
    b = load_scene(path).world.body("ball")
    assert (b.linear_damping, b.angular_damping) == (0.04, 0.1)
    path.write_text(text.replace("EXTRA", "angular_damping = -1"))
    assert cli_main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(path) in err and "bodies[0].angular_damping" in err, err
