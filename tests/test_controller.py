"""A controller called before every step (MuJoCo's control callback, the body of a PyBullet
loop), and ``Body.apply_impulse``.

Compared with: the same runs without a controller (a controller that does nothing changes no
bit); the closed form of an impulse on a free body (v = J / m, omega = I^-1 (r x J), exact to
round-off); a kinematic body steered along a sine by ``set_target`` each step (on the curve at
every step's end to round-off); a proportional-derivative controller, whose discrete closed
loop is a damped oscillator (x_k of the linear recurrence it makes, to round-off).
"""

import math

import numpy as np
import pytest

import tumble as tb
from tumble.checks import state_hash
from tumble.errors import InputError

DT = 1.0 / 240.0


def _scene():
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(), fixed=True, name="ground")
    for k in range(4):
        w.add_body(tb.Box((0.3, 0.3, 0.3)), mass=1, position=(0.1 * k, 0, 0.3 + 0.35 * k), euler_deg=(0, 0, 10 * k),
                   name=f"box{k}")
    w.add_body(tb.Sphere(0.1), mass=1, position=(3, 0, 2), velocity=(1, 0, 0), angular_velocity=(0, 3, 1), name="flyer")
    return w


def test_a_controller_that_does_nothing_changes_no_bit():
    plain = _scene()
    tb.Simulator(plain, dt=DT).run(1.0, frame_rate=24)
    calls = []
    controlled = _scene()
    sim = tb.Simulator(controlled, dt=DT, controller=lambda s: calls.append(s.world.t))
    sim.run(1.0, frame_rate=24)
    assert state_hash(controlled) == state_hash(plain)
    assert len(calls) == 240 and calls[0] == 0.0 and calls[-1] == pytest.approx(239 * DT, abs=1e-12)


def test_an_impulse_sets_the_textbook_velocities():
    w = tb.World(gravity=(0, 0, 0))
    box = w.add_body(tb.Box((0.4, 0.2, 0.1)), mass=2.0, position=(1, 2, 3), euler_deg=(10, 20, 30), name="box")
    J, p = np.array([0.3, -1.0, 2.0]), np.array([1.1, 2.05, 2.9])
    box.apply_impulse(J, point=p)
    I_inv = box.R @ np.linalg.inv(box.inertia_body) @ box.R.T
    np.testing.assert_allclose(box.v, J / 2.0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(box.omega, I_inv @ np.cross(p - box.x, J), rtol=1e-13, atol=1e-15)


def test_a_pd_controller_closes_the_loop_as_its_recurrence():
    # a box on frictionless ice pushed by u = -k (x - target) - c v as an impulse u dt before each
    # step: semi-implicit Euler of a damped oscillator, v' = v + u dt / m, x' = x + v' dt (the
    # soft step's update, the box resting on the ground), which the test iterates itself.
    k, c, m, target = 40.0, 8.0, 1.0, 1.0
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(), fixed=True, material=tb.Material(friction=0.0), name="ice")
    box = w.add_body(tb.Box((0.2, 0.2, 0.2)), mass=m, position=(0, 0, 0.1), material=tb.Material(friction=0.0),
                     name="box")

    def pd(sim):
        b = sim.world.body("box")
        b.apply_impulse((DT * (-k * (b.x[0] - target) - c * b.v[0]), 0.0, 0.0))

    traj = tb.Simulator(w, dt=DT, controller=pd).run(2.0, frame_rate=240)
    x, v = 0.0, 0.0
    expected = [x]
    for _ in range(480):
        v += DT * (-k * (x - target) - c * v) / m
        x += DT * v
        expected.append(x)
    np.testing.assert_allclose(traj.position[:, box.index, 0], expected, rtol=0, atol=1e-12)
    assert abs(box.x[0] - target) < 0.01


def test_a_controller_steers_a_kinematic_body_along_a_sine():
    w = tb.World(gravity=(0, 0, 0))
    paddle = w.add_body(tb.Box((0.1, 1, 0.3)), kinematic=True, name="paddle")

    def steer(sim):
        t1 = sim.world.t + sim.dt
        sim.world.body("paddle").set_target((math.sin(2 * t1), 0, 0), euler_deg=(0, 0, 30 * math.sin(t1)), time=sim.dt)

    traj = tb.Simulator(w, dt=DT, controller=steer).run(2.0, frame_rate=24)
    np.testing.assert_allclose(traj.position[:, paddle.index, 0], np.sin(2 * traj.time), rtol=0, atol=1e-12)
    yaw = np.degrees(2 * np.arctan2(traj.orientation[:, paddle.index, 3], traj.orientation[:, paddle.index, 0]))
    np.testing.assert_allclose(yaw, 30 * np.sin(traj.time), rtol=0, atol=1e-10)


def test_a_failing_controller_leaves_the_world_at_the_last_frame():
    w = _scene()

    def fail(sim):
        if sim.world.t > 0.3:
            raise RuntimeError("sensor offline")

    sim = tb.Simulator(w, dt=DT, controller=fail)
    with pytest.raises(RuntimeError, match="sensor offline"):
        sim.run(1.0, frame_rate=24)
    assert w.t == pytest.approx(7 / 24)  # the last frame before 0.3 s


def test_controller_and_impulse_bad_input_is_one_line():
    w = _scene()
    with pytest.raises(InputError, match="expected a function"):
        tb.Simulator(w, controller=3)
    with pytest.raises(InputError, match="fixed: an impulse moves only a dynamic body"):
        w.body("ground").apply_impulse((1, 0, 0))
    with pytest.raises(InputError, match="impulse"):
        w.body("box0").apply_impulse((1, 0))


def test_a_sleeping_body_moved_by_the_user_wakes_and_falls():
    # Box2D's setters wake the body: a box asleep on the ground, lifted to 1 m between runs,
    # falls again (asleep it would hang in the air: nothing else would wake it)
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(), fixed=True, name="ground")
    box = w.add_body(tb.Box((0.3, 0.3, 0.3)), mass=1, position=(0, 0, 0.15), name="box")
    sim = tb.Simulator(w, dt=DT)
    sim.run(1.0, frame_rate=24)
    assert not sim.sleep.awake[box.index]
    box.x = (0, 0, 1.0)
    traj = sim.run(0.25, frame_rate=24)
    np.testing.assert_allclose(traj.position[:, box.index, 2], 1.0 - 0.5 * 9.81 * (traj.time - 1.0) ** 2,
                               rtol=0, atol=1e-9)


def test_a_controller_that_adds_a_body_inside_a_run_is_refused_with_one_line():
    """A controller that spawns a body during ``sim.run`` (a run's frames and a call's arrays are
    sized for the bodies it began with): one InputError keyed ``controller`` naming the time, the
    world left at the last recorded frame with the new body in it, and a new run then records it.
    Before, the run failed with a NumPy broadcast error from deep in the step. A loop of
    ``sim.step()`` adding bodies between calls (PyBullet's way) works."""
    w = tb.World()
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(0, 0, 1), name="first")

    def spawn(sim):
        if sim.step_index == 30 and sim.world.body_count == 1:
            sim.world.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(1, 0, 1), name="second")

    sim = tb.Simulator(w, controller=spawn)
    with pytest.raises(tb.InputError) as err:
        sim.run(0.5)
    assert err.value.key == "controller" and "t = 0.125 s" in str(err.value) and "\n" not in str(err.value)
    assert w.body_count == 2 and w.t == pytest.approx(3 / 24)  # the frame before, the new body kept
    assert w.x[1].tolist() == [1.0, 0.0, 1.0]
    traj = sim.run(0.25)
    assert traj.position.shape[1] == 2
    loop = tb.World()
    loop.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(0, 0, 1))
    stepper = tb.Simulator(loop)
    for k in range(60):
        if k == 30:
            loop.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(1, 0, 1))
        stepper.step()
    assert loop.body_count == 2 and loop.x[1, 2] < 1.0
