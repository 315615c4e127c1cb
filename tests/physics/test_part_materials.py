"""A compound's parts with their own materials (MuJoCo's per-geom friction, Box2D's per-shape
material): each contact takes the materials of the two shapes that touch.

Compared with: Coulomb's law for a block sliding to rest on the ground (deceleration
sqrt(f_part f_ground) g, stopping distance v0^2 / (2 mu g)), on the part that touches; the
textbook bounce on the part that touches (the apex e^2 h). The same body, turned over, slides
or bounces by its other part's material. A compound whose parts have no material of their own
gives the same bits as before (the mix is the same formula).
"""

import math

import numpy as np
import pytest

import tumble as tb
from tumble.checks import state_hash
from tumble.errors import InputError

DT = 1.0 / 240.0
G = 9.81
RUBBER = tb.Material(friction=0.8, restitution=0.0)
ICE = tb.Material(friction=0.0, restitution=0.5)


def _sled(world, upside_down=False, **kw):
    """A slab of rubber (0.6 x 0.6 x 0.1) under a slab of ice, as one compound body."""
    parts = [(tb.Box((0.6, 0.6, 0.1)), (0, 0, -0.05), (1, 0, 0, 0), RUBBER),
             (tb.Box((0.6, 0.6, 0.1)), (0, 0, 0.05), (1, 0, 0, 0), ICE)]
    return world.add_body(tb.Compound(parts), mass=2.0, euler_deg=(180, 0, 0) if upside_down else None,
                          material=tb.Material(friction=0.3, restitution=0.0), **kw)


def _ground(world):
    return world.add_body(tb.Plane(), fixed=True, material=tb.Material(friction=0.5, restitution=1.0), name="ground")


@pytest.mark.parametrize("upside_down, mu", [(False, math.sqrt(0.8 * 0.5)), (True, 0.0)])
def test_a_sled_slides_by_the_material_of_the_part_that_touches(upside_down, mu):
    v0 = 2.0
    w = tb.World(gravity=(0, 0, -G))
    _ground(w)
    sled = _sled(w, upside_down, position=(0, 0, 0.1), velocity=(v0, 0, 0), name="sled")
    traj = tb.Simulator(w, dt=DT).run(1.0, frame_rate=240)
    t = traj.time
    vx = traj.velocity[:, sled.index, 0]
    if mu == 0.0:  # ice down: it glides on
        np.testing.assert_allclose(vx, v0, rtol=0, atol=1e-9)
        return
    sliding = t < 0.9 * v0 / (mu * G)
    # decelerates at mu g (the rubber's friction with the ground's, not the body's 0.3)
    np.testing.assert_allclose(vx[sliding], v0 - mu * G * t[sliding], rtol=0, atol=1e-4)
    assert sled.x[0] == pytest.approx(v0 ** 2 / (2 * mu * G), abs=2e-3)
    assert np.linalg.norm(sled.v) < 1e-6


@pytest.mark.parametrize("upside_down, e", [(False, 0.0), (True, 0.5)])
def test_a_sled_bounces_by_the_material_of_the_part_that_lands(upside_down, e):
    # dropped flat from 1 m onto a ground of restitution 0 (a contact takes the larger of its
    # two materials' restitutions: the part's own shows): the ice part bounces to e^2 h, the
    # rubber part stays down (the body's own material has e = 0 too: only the part's 0.5 bounces)
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Plane(), fixed=True, material=tb.Material(friction=0.5, restitution=0.0), name="ground")
    sled = _sled(w, upside_down, position=(0, 0, 1.1), name="sled")
    traj = tb.Simulator(w, dt=DT).run(1.2, frame_rate=240)
    z = traj.position[:, sled.index, 2]
    if upside_down:  # the ice part lands: e = 0.5, the apex at e^2 h = 0.25 m above the rest height
        land = np.argmax(traj.velocity[:, sled.index, 2] > 0)
        apex = z[land:].max() - 0.1
        assert apex == pytest.approx(0.25, rel=0.02)
    else:  # the rubber part lands: e = 0, it stays down
        assert traj.velocity[:, sled.index, 2].max() < 0.01
        assert abs(z[-1] - 0.1) < 1e-3


def test_parts_without_materials_change_no_bit():
    def world(parts_with_body_material):
        w = tb.World(gravity=(0, 0, -G))
        _ground(w)
        m = tb.Material(friction=0.3, restitution=0.0)
        parts = [(tb.Box((0.6, 0.6, 0.1)), (0, 0, -0.05), (1, 0, 0, 0)) + ((m,) if parts_with_body_material else ()),
                 (tb.Sphere(0.2), (0.2, 0, 0.2), (1, 0, 0, 0))]
        w.add_body(tb.Compound(parts), mass=2.0, position=(0, 0, 0.3), velocity=(1, 0.5, 0), angular_velocity=(1, 2, 3),
                   material=m, name="thing")
        return w

    a, b = world(False), world(True)
    tb.Simulator(a, dt=DT).run(1.0, frame_rate=24)
    tb.Simulator(b, dt=DT).run(1.0, frame_rate=24)
    assert state_hash(a) == state_hash(b)


def test_part_materials_survive_a_checkpoint_and_a_scene_file(tmp_path):
    w = tb.World(gravity=(0, 0, -G))
    _ground(w)
    _sled(w, position=(0, 0, 0.1), velocity=(2, 0, 0), name="sled")
    sim = tb.Simulator(w, dt=DT)
    sim.run(0.25, frame_rate=24)
    sim.save_checkpoint(tmp_path / "c.npz")
    loaded = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    assert loaded.world.body("sled").shape.materials == (RUBBER, ICE)
    path = tmp_path / "s.toml"
    path.write_text('[[bodies]]\nname = "sled"\nmass = 2\nshape = { type = "compound", parts = [\n'
                    '  { shape = { type = "box", size = [0.6, 0.6, 0.1] }, position = [0, 0, -0.05], '
                    'material = { friction = 0.8 } },\n'
                    '  { shape = { type = "box", size = [0.6, 0.6, 0.1] }, position = [0, 0, 0.05] } ] }\n')
    scene = tb.load_scene(path)
    assert scene.world.body("sled").shape.materials == (tb.Material(friction=0.8), None)
    path.write_text(path.read_text().replace("friction = 0.8", "friction = -1"))
    with pytest.raises(InputError, match=r"bodies\[0\]\.shape\.parts\[0\]\.material"):
        tb.load_scene(path)


def test_a_parts_rolling_resistance_slows_it_as_a_body_material_would():
    # a ball rolling at 2 m/s whose only part carries rolling resistance 0.05 (its body none)
    # slows at c g / (1 + k), k = 2/5, exactly as a ball whose body material has it
    # (tests/physics/test_contact_rolling_resistance.py): the two runs agree to 1e-9 m/s
    r, c, v0 = 0.1, 0.05, 2.0

    def roll(as_part):
        w = tb.World(gravity=(0, 0, -G))
        w.add_body(tb.Plane(), fixed=True, material=tb.Material(friction=0.8), name="ground")
        m = tb.Material(friction=0.8, rolling_resistance=c)
        shape = tb.Compound([(tb.Sphere(r), (0, 0, 0), (1, 0, 0, 0), m)]) if as_part else tb.Sphere(r)
        ball = w.add_body(shape, mass=1.0, position=(0, 0, r), velocity=(v0, 0, 0), angular_velocity=(0, v0 / r, 0),
                          material=tb.Material(friction=0.8) if as_part else m, name="ball")
        traj = tb.Simulator(w, dt=DT).run(1.0, frame_rate=24)
        return traj.velocity[:, ball.index, 0], traj.time

    part, t = roll(True)
    body, _ = roll(False)
    np.testing.assert_allclose(part, body, rtol=0, atol=1e-9)
    np.testing.assert_allclose(part, v0 - c * G / 1.4 * t, rtol=0, atol=1e-6)
