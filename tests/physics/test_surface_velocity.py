"""Surface velocity (conveyor belts, Box2D's tangentSpeed): a body whose surface slides along
itself while the body stays put; friction drives what touches it to the surface's speed.

Compared with: Coulomb's law (a box dropped on a belt speeds up at mu g until it moves with the
surface, then rides at its speed exactly); the conservation of angular momentum about the
contact point for a ball dropped on a belt (it ends rolling at k / (1 + k) u = 2/7 u, spinning
backwards); statics on an inclined belt (a box carried up at the belt's speed where tan(angle)
< mu). Plus: the belt does not move, its surface velocity turns with it, a run resumes bit for
bit, bad values are one line.
"""

import math

import numpy as np
import pytest

import tumble as tb
from tumble.checks import state_hash
from tumble.errors import InputError

from .solutions import assert_dragged_to_belt_speed, resumed_run

DT = 1.0 / 240.0
G = 9.81


def _belt(world, u=1.0, mu=0.5, **kw):
    return world.add_body(tb.Box((20, 2, 0.2)), fixed=True, position=kw.pop("position", (0, 0, -0.1)),
                          surface_velocity=(u, 0, 0), material=tb.Material(friction=mu, restitution=0.0),
                          name="belt", **kw)


def test_a_box_on_a_belt_speeds_up_at_mu_g_then_rides_at_the_belt_speed():
    mu, u = 0.5, 1.0
    w = tb.World(gravity=(0, 0, -G))
    belt = _belt(w, u, mu)
    box = w.add_body(tb.Box((0.4, 0.4, 0.4)), mass=2, position=(0, 0, 0.2),
                     material=tb.Material(friction=mu, restitution=0.0), name="box")
    traj = tb.Simulator(w, dt=DT).run(1.0, frame_rate=240)
    # sliding: measured 1e-5 m/s off mu g t (the first steps' settling on the belt).
    # riding: at the surface's speed to 1e-5 m/s. NOTE: measured 7.7e-7 m/s along, 1.7e-6 m/s
    # across and a spin of 8e-6 rad/s, steady: a box that slides over a fixed body carries this
    # (a frictionless box coasting at 1 m/s on the ground: 7.7e-8 m/s up, 5e-7 rad/s), since the
    # contact's anchor on the fixed side stays where the step began while the box moves on (up
    # to v dt / 2 between them). On a kinematic belt moving with the box there is no such lag:
    # exact to 1e-12 (tests/physics/test_kinematic.py).
    assert_dragged_to_belt_speed(traj, box.index, mu, u, G, slide_atol=1e-4, ride_atol=1e-5)
    # the belt itself stays where it is, and reads no velocity
    assert np.all(belt.x == (0, 0, -0.1)) and np.all(belt.v == 0.0)
    # how far it went: the slide's u t* / 2, then u (1 - t*)
    t_star = u / (mu * G)
    assert box.x[0] == pytest.approx(u * t_star / 2 + u * (1.0 - t_star), abs=1e-3)


def test_a_ball_dropped_on_a_belt_ends_rolling_at_two_sevenths_of_its_speed():
    # angular momentum about the contact point is conserved (friction acts there, gravity and
    # the normal force on the vertical through it): I omega + m r v = 0, so the slip ends when
    # v + v / k = u, at v = k u / (1 + k) = 2/7 u for a ball (k = 2/5), spinning back at v / (k r).
    u, r = 1.4, 0.1
    w = tb.World(gravity=(0, 0, -G))
    _belt(w, u, 0.4)
    ball = w.add_body(tb.Sphere(r), mass=1, position=(0, 0, r), material=tb.Material(friction=0.4), name="ball")
    traj = tb.Simulator(w, dt=DT).run(1.0, frame_rate=24)
    late = traj.time > 0.5
    np.testing.assert_allclose(traj.velocity[late, ball.index], np.broadcast_to((2 / 7 * u, 0, 0), (late.sum(), 3)),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(ball.omega, (0, -(2 / 7 * u) / (0.4 * r), 0), rtol=1e-9, atol=1e-9)


def test_a_belt_turned_about_z_carries_along_its_own_axis():
    # the surface velocity is in the belt's frame: a belt turned 90 degrees carries along world y
    w = tb.World(gravity=(0, 0, -G))
    _belt(w, 1.0, 0.5, euler_deg=(0, 0, 90))
    box = w.add_body(tb.Box((0.4, 0.4, 0.4)), mass=1, position=(0, 0, 0.2), material=tb.Material(friction=0.5))
    tb.Simulator(w, dt=DT).run(1.0, frame_rate=24)
    np.testing.assert_allclose(box.v, (0, 1.0, 0), rtol=0, atol=1e-5)  # the sliding box's lag, as above


def test_an_inclined_belt_carries_a_box_uphill_at_its_speed():
    # a belt tilted 15 degrees about y, surface moving up the slope at 0.5 m/s; mu 0.8 > tan 15
    # = 0.27: the box is carried up at 0.5 m/s along the slope, and never slides back.
    angle = math.radians(15.0)
    u = 0.5
    w = tb.World(gravity=(0, 0, -G))
    mat = tb.Material(friction=0.8, restitution=0.0)
    # body x along the slope, pointing up it (a turn of -15 degrees about y lifts +x)
    w.add_body(tb.Box((20, 2, 0.2)), fixed=True, euler_deg=(0, -15, 0), surface_velocity=(u, 0, 0),
               material=mat, name="belt")
    up = np.array([math.cos(angle), 0, math.sin(angle)])
    normal = np.array([-math.sin(angle), 0, math.cos(angle)])
    box = w.add_body(tb.Box((0.4, 0.4, 0.4)), mass=1, position=0.301 * normal, euler_deg=(0, -15, 0),
                     material=mat, name="box")
    traj = tb.Simulator(w, dt=DT).run(2.0, frame_rate=24)
    late = traj.time > 0.5
    np.testing.assert_allclose(traj.velocity[late, box.index], np.broadcast_to(u * up, (late.sum(), 3)),
                               rtol=0, atol=1e-5)  # the sliding box's lag, as above (measured 8e-7 m/s)
    assert box.x @ up > 0.8  # it went up the slope


def test_a_belt_run_resumes_bit_for_bit(tmp_path):
    def world():
        w = tb.World(gravity=(0, 0, -G))
        _belt(w)
        for k in range(3):
            w.add_body(tb.Box((0.3, 0.3, 0.3)), mass=1, position=(0.5 * k, 0.1 * k, 0.5 + 0.4 * k), name=f"box{k}")
        return w

    whole, resumed = resumed_run(world, tmp_path, 1.0, DT)
    np.testing.assert_array_equal(resumed.world.body("belt").surface_velocity, (1, 0, 0))
    assert state_hash(resumed.world) == state_hash(whole.world)


def test_surface_velocity_bad_input_is_one_line():
    w = tb.World()
    with pytest.raises(InputError, match="surface_velocity"):
        w.add_body(tb.Box((1, 1, 1)), fixed=True, surface_velocity=(1, 0))
    b = w.add_body(tb.Box((1, 1, 1)), fixed=True, name="b")
    with pytest.raises(InputError, match="surface_velocity"):
        b.surface_velocity = (float("nan"), 0, 0)
