"""Kinematic bodies (Box2D's b2_kinematicBody, MuJoCo's mocap bodies): infinite mass, moved by
the velocities the user sets, felt by the bodies they touch.

Compared with: the closed form of motion at constant velocity (x0 + v t and the exact turn
about a fixed axis, which the step integrates without truncation: the tolerance is round-off
over the run); Coulomb's law for a box dragged by a conveyor (it speeds up at mu g until it
moves with the belt, then rides at the belt's speed exactly); the textbook collision with an
infinitely heavy paddle (a ball at rest leaves at (1 + e) u); Galilean invariance (a pendulum
on a pivot moving at constant velocity swings exactly as on a fixed one); circular motion on a
turntable (a box that sticks goes round at omega r). Plus what the engine owes a kinematic body:
nothing it touches or feels moves it, it passes through fixed and kinematic bodies, it wakes the
sleepers it meets, a fast one does not tunnel, a target pose is reached exactly, and a run
resumes bit for bit.
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


def _ground(world):
    return world.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")


def _quat_z(angle):
    return np.array([math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)])


@pytest.mark.parametrize("layout", ["quaternion", "matrix"])
def test_a_kinematic_body_moves_at_its_velocity_whatever_acts_on_it(layout):
    # gravity, a drag on every body and a box landing on it: none of them moves it. The closed
    # form is exact for the step (x += h v, the exact turn of omega h): round-off over 480 steps.
    w = tb.World(gravity=(0, 0, -G), layout=layout)
    _ground(w)
    v, spin = np.array([0.5, -0.25, 0.0]), 2.0
    plat = w.add_body(tb.Box((2, 2, 0.2)), kinematic=True, position=(0, 0, 1), velocity=v,
                      angular_velocity=(0, 0, spin), name="platform")
    box = w.add_body(tb.Box((0.3, 0.3, 0.3)), mass=1, position=(0, 0, 1.5), name="box")
    w.add_force(tb.Drag(linear=0.5))
    sim = tb.Simulator(w, dt=DT)
    traj = sim.run(2.0, frame_rate=24)
    t = traj.time
    k = plat.index
    np.testing.assert_allclose(traj.position[:, k], np.array([0, 0, 1.0]) + t[:, None] * v, rtol=0, atol=1e-12)
    q = np.array([_quat_z(spin * ti) for ti in t])
    np.testing.assert_allclose(traj.orientation[:, k] * np.sign(traj.orientation[:, k, :1]), q * np.sign(q[:, :1]),
                               rtol=0, atol=1e-12)
    np.testing.assert_array_equal(traj.velocity[:, k], np.broadcast_to(v, (len(t), 3)))
    np.testing.assert_array_equal(traj.angular_velocity[:, k], np.broadcast_to((0, 0, spin), (len(t), 3)))
    assert np.all(traj.linear_momentum[:, k] == 0.0) and np.all(traj.angular_momentum[:, k] == 0.0)
    assert not traj.fixed[k] and traj.fixed[0] and plat.kinematic and not plat.fixed
    # the box landed on it and is carried round (it touched the platform: the test is not empty)
    assert box.x[2] > 1.1 and np.linalg.norm(box.v[:2]) > 0.1


def test_a_kinematic_path_is_the_same_bits_whether_or_not_anything_touches_it():
    def run(with_box):
        w = tb.World(gravity=(0, 0, -G))
        plat = w.add_body(tb.Box((2, 2, 0.2)), kinematic=True, position=(0, 0, 0), velocity=(0.3, 0, 0.1),
                          angular_velocity=(0.2, 0.1, 1.0), name="platform")
        if with_box:
            w.add_body(tb.Box((0.3, 0.3, 0.3)), mass=1, position=(0, 0, 0.3), name="box")
        sim = tb.Simulator(w, dt=DT)
        traj = sim.run(1.0, frame_rate=24)
        return traj.position[:, plat.index], traj.orientation[:, plat.index]

    alone, touched = run(False), run(True)
    np.testing.assert_array_equal(alone[0], touched[0])
    np.testing.assert_array_equal(alone[1], touched[1])


def _conveyor(friction=0.5, speed=1.0):
    w = tb.World(gravity=(0, 0, -G))
    _ground(w)
    mat = tb.Material(friction=friction, restitution=0.0)
    belt = w.add_body(tb.Box((8, 2, 0.2)), kinematic=True, position=(0, 0, 0.5), velocity=(speed, 0, 0),
                      material=mat, name="belt")
    box = w.add_body(tb.Box((0.4, 0.4, 0.4)), mass=2, position=(0, 0, 0.8), material=mat, name="box")
    return w, belt, box


def test_a_conveyor_drags_a_box_at_mu_g_until_it_rides_at_the_belt_speed():
    # Coulomb: the belt slides under the box, kinetic friction mu m g speeds it up at mu g until
    # t* = u / (mu g) = 0.204 s; then static friction holds it at u exactly.
    mu, u = 0.5, 1.0
    w, belt, box = _conveyor(mu, u)
    sim = tb.Simulator(w, dt=DT)
    traj = sim.run(1.0, frame_rate=240)
    # sliding: the soft step's velocities are exact for constant friction (semi-implicit Euler):
    # the tolerance is the first steps' settling onto the belt (measured 8e-6 m/s). Riding:
    # static friction takes over from t*, the soft friction row pulling the last 2e-5 m/s in
    # geometrically (under 1e-9 from 0.34 s, 1e-12 from 0.43 s)
    assert_dragged_to_belt_speed(traj, box.index, mu, u, G, slide_atol=1e-4, ride_atol=1e-9)
    # it lags the belt by the distance it slid, u^2 / (2 mu g) = 0.102 m (measured 0.5 mm
    # less: the semi-implicit position update leads by h v / 2 over the slide)
    lag = belt.x[0] - box.x[0]
    assert abs(lag - u ** 2 / (2 * mu * G)) < 1e-3


@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_a_paddle_of_infinite_mass_sends_a_ball_off_at_one_plus_e_times_its_speed(e):
    # no gravity; a ball at rest, a kinematic paddle moving at u: the textbook collision with
    # an infinite mass leaves the ball at (1 + e) u and the paddle at u.
    u = 3.0
    w = tb.World(gravity=(0, 0, 0))
    mat = tb.Material(friction=0.0, restitution=e)
    paddle = w.add_body(tb.Box((0.1, 1, 1)), kinematic=True, position=(-1, 0, 0), velocity=(u, 0, 0),
                        material=mat, name="paddle")
    ball = w.add_body(tb.Sphere(0.1), mass=0.2, position=(0, 0, 0), material=mat, name="ball")
    sim = tb.Simulator(w, dt=DT)
    sim.run(1.0, frame_rate=24)
    # measured: exact to round-off (1.5e-16 relative) for all three
    np.testing.assert_allclose(ball.v, ((1 + e) * u, 0, 0), rtol=0, atol=1e-9)
    assert np.all(paddle.v == (u, 0, 0))
    assert ball.x[0] > paddle.x[0] + 0.15 - 1e-3  # in front of it, not through it


def test_a_fast_thin_kinematic_bat_does_not_pass_a_small_ball():
    # a 1 cm bat at 100 m/s (0.42 m a step, 42 times its thickness) against a 1 cm ball
    u = 100.0
    w = tb.World(gravity=(0, 0, 0))
    mat = tb.Material(friction=0.0, restitution=0.0)
    bat = w.add_body(tb.Box((0.01, 0.5, 0.5)), kinematic=True, position=(-2, 0, 0), velocity=(u, 0, 0),
                     material=mat, name="bat")
    ball = w.add_body(tb.Sphere(0.005), mass=0.01, position=(0, 0, 0), material=mat, name="ball")
    traj = tb.Simulator(w, dt=DT).run(0.5, frame_rate=240)
    ahead = traj.position[:, ball.index, 0] - traj.position[:, bat.index, 0]
    assert np.all(ahead > 0.0)
    np.testing.assert_allclose(ball.v, (u, 0, 0), rtol=0, atol=1e-6)


@pytest.mark.parametrize("method", ["gauss-seidel", "tree"])
def test_a_pendulum_on_a_moving_pivot_swings_as_on_a_fixed_one(method):
    # Galilean invariance: a pivot moving at constant V is an inertial frame. The two runs
    # differ only by round-off in positions that grow as V t (tolerance 1e-9 rad over 3 s;
    # measured 1e-13). Both joint solvers: the tree solve takes the kinematic pivot as its
    # ground, which must move at the pivot's velocity.
    from tumble.solver.joints import JointSettings

    settings = JointSettings(method=method, hertz=0.0 if method == "tree" else JointSettings().hertz)

    def swing(V):
        w = tb.World(gravity=(0, 0, -G))
        if V is None:
            pivot = w.add_body(tb.Sphere(0.05), fixed=True, position=(0, 0, 2), name="pivot")
        else:
            pivot = w.add_body(tb.Sphere(0.05), kinematic=True, position=(0, 0, 2), velocity=V, name="pivot")
        # the bob starts at rest in the pivot's frame
        bob = w.add_body(tb.Box((0.1, 0.1, 0.1)), mass=1, position=(0.8, 0, 1.4), name="bob",
                         velocity=(0, 0, 0) if V is None else V)
        w.add_joint(tb.HingeJoint(pivot, bob, anchor=(0, 0, 2), axis=(0, 1, 0)))
        traj = tb.Simulator(w, dt=DT, joint_settings=settings).run(3.0, frame_rate=24)
        rel = traj.position[:, bob.index] - traj.position[:, pivot.index]
        return np.arctan2(rel[:, 0], -rel[:, 2]), traj.position[:, pivot.index]

    still, _ = swing(None)
    moving, pivot_path = swing((1.5, 0.0, 0.0))
    assert np.ptp(still) > 1.0  # it swings
    np.testing.assert_allclose(moving, still, rtol=0, atol=1e-9)
    assert pivot_path[-1, 0] == pytest.approx(4.5, abs=1e-12)


@pytest.mark.parametrize("omega,dt", [(1.0, DT), (1.0, DT / 2), (2.0, DT)])
def test_a_box_on_a_turntable_goes_round_at_omega_r(omega, dt):
    # a kinematic disc spinning at omega; a box at radius r moving with it (velocity omega r,
    # spin omega) and with friction to spare (omega^2 r <= 4 m/s^2 < mu g) sticks and goes round
    # with the disc: its angle follows omega t and its speed is omega r.
    # The engine's known error, checked here to its predicted size: friction holds velocities,
    # not positions (Box2D's too), and in each substep h the box moves along a straight chord
    # while the disc turns, so it creeps outwards at r omega^2 h / 2 (first order in h, as
    # semi-implicit Euler; 0.52 mm/s at omega 1 rad/s and Box3D's h = 1/960 s). Measured within 3 %
    # of that rate at all three settings; the test allows 10 %.
    r = 1.0
    h = dt / 4  # the soft step's four substeps
    w = tb.World(gravity=(0, 0, -G))
    mat = tb.Material(friction=1.0, restitution=0.0)
    w.add_body(tb.Cylinder(radius=2.5, length=0.2), kinematic=True, position=(0, 0, 0.1),
               angular_velocity=(0, 0, omega), material=mat, name="disc")
    box = w.add_body(tb.Box((0.2, 0.2, 0.2)), mass=1, position=(r, 0, 0.3), velocity=(0, omega * r, 0),
                     angular_velocity=(0, 0, omega), material=mat, name="box")
    traj = tb.Simulator(w, dt=dt).run(6.0, frame_rate=24)
    t = traj.time
    p = traj.position[:, box.index]
    radius = np.hypot(p[:, 0], p[:, 1])
    rate = np.polyfit(t[24:], radius[24:], 1)[0]
    assert rate == pytest.approx(r * omega ** 2 * h / 2, rel=0.1)
    assert np.all(np.abs(radius - r) <= 1.1 * r * omega ** 2 * h / 2 * t + 1e-4)
    angle = np.unwrap(np.arctan2(p[:, 1], p[:, 0]))
    np.testing.assert_allclose(angle, omega * t, rtol=0, atol=1e-3)
    speed = np.linalg.norm(traj.velocity[:, box.index, :2], axis=1)
    np.testing.assert_allclose(speed, omega * radius, rtol=1e-3)


def test_a_kinematic_body_passes_through_fixed_and_kinematic_bodies():
    w = tb.World(gravity=(0, 0, -G))
    _ground(w)
    wall = w.add_body(tb.Box((0.2, 2, 2)), fixed=True, position=(1, 0, 1), name="wall")
    a = w.add_body(tb.Box((0.5, 0.5, 0.5)), kinematic=True, position=(0, 0, 0.2), velocity=(2, 0, -0.5), name="a")
    b = w.add_body(tb.Sphere(0.3), kinematic=True, position=(3, 0, 0.2), velocity=(-2, 0, 0), name="b")
    sim = tb.Simulator(w, dt=DT, record_contacts=True)
    traj = sim.run(1.5, frame_rate=24)
    assert np.all(traj.contact_count == 0)
    np.testing.assert_allclose(a.x, (3.0, 0, 0.2 - 0.75), rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.x, (0.0, 0, 0.2), rtol=0, atol=1e-12)
    assert wall.fixed


def test_a_box_asleep_on_a_platform_wakes_when_the_platform_moves():
    w = tb.World(gravity=(0, 0, -G))
    mat = tb.Material(friction=0.8, restitution=0.0)
    plat = w.add_body(tb.Box((4, 4, 0.2)), kinematic=True, position=(0, 0, 0), material=mat, name="platform")
    box = w.add_body(tb.Box((0.4, 0.4, 0.4)), mass=1, position=(0, 0, 0.3), material=mat, name="box")
    sim = tb.Simulator(w, dt=DT)
    sim.run(2.0, frame_rate=24)
    assert not sim.sleep.awake[box.index]  # at rest on a still platform: asleep
    x0 = box.x.copy()
    plat.v = (0.5, 0.0, 0.0)
    sim.run(1.0, frame_rate=24)
    # carried along (after a short slip at the start: 0.5 / (0.8 g) = 0.06 s)
    assert box.x[0] - x0[0] == pytest.approx(0.5 - 0.5 ** 2 / (2 * 0.8 * G), abs=5e-3)
    assert sim.sleep.awake[box.index]


def test_a_slow_platform_keeps_its_passenger_awake():
    # 2 cm/s is under the sleep tolerance (5 cm/s): the box would sleep and be left floating
    # behind, were contact with a moving kinematic body not keeping it awake.
    w = tb.World(gravity=(0, 0, -G))
    mat = tb.Material(friction=0.8, restitution=0.0)
    w.add_body(tb.Box((4, 4, 0.2)), kinematic=True, position=(0, 0, 0), velocity=(0.02, 0, 0), material=mat,
               name="platform")
    box = w.add_body(tb.Box((0.4, 0.4, 0.4)), mass=1, position=(0, 0, 0.3), material=mat, name="box")
    sim = tb.Simulator(w, dt=DT)
    sim.run(4.0, frame_rate=24)
    assert sim.sleep.awake[box.index]
    assert box.x[0] == pytest.approx(0.08, abs=1e-3)
    assert box.x[2] == pytest.approx(0.3, abs=1e-3)


def test_a_pusher_wakes_the_sleeping_box_it_reaches():
    w = tb.World(gravity=(0, 0, -G))
    _ground(w)
    box = w.add_body(tb.Box((0.4, 0.4, 0.4)), mass=1, position=(0, 0, 0.2), name="box",
                     material=tb.Material(friction=0.3))
    pusher = w.add_body(tb.Box((0.2, 1, 0.3)), kinematic=True, position=(-2, 0, 0.2), name="pusher")
    sim = tb.Simulator(w, dt=DT)
    sim.run(1.0, frame_rate=24)
    assert not sim.sleep.awake[box.index]
    pusher.v = (1.0, 0, 0)
    sim.run(3.0, frame_rate=24)
    # the pusher's face reached the box at 1.7 s and pushed it 1.3 m
    assert box.x[0] == pytest.approx(pusher.x[0] + 0.3, abs=2e-3)
    assert box.v[0] == pytest.approx(1.0, abs=1e-6)


def test_set_target_reaches_the_pose_in_the_time_given():
    w = tb.World(gravity=(0, 0, -G))
    # a cone's centre of mass is off its origin: the target is the shape origin's, as add_body's
    cone = w.add_body(tb.Cone(radius=0.3, height=0.6), kinematic=True, density=1000, position=(1, 2, 3),
                      euler_deg=(0, 0, 30), name="cone")
    assert np.linalg.norm(cone.com_offset) > 0.1
    cone.set_target((2, 1, 3.5), euler_deg=(40, -20, 100), time=0.5)
    sim = tb.Simulator(w, dt=DT)
    sim.run(0.5, frame_rate=24)
    target = tb.World()
    ref = target.add_body(tb.Cone(radius=0.3, height=0.6), fixed=True, density=1000, position=(2, 1, 3.5),
                          euler_deg=(40, -20, 100))
    np.testing.assert_allclose(cone.x, ref.x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cone.R, ref.R, rtol=0, atol=1e-12)


def test_a_run_with_kinematic_bodies_resumes_bit_for_bit(tmp_path):
    whole, resumed = resumed_run(lambda: _conveyor()[0], tmp_path, 1.0, DT)
    assert resumed.world.body("belt").kinematic
    assert state_hash(resumed.world) == state_hash(whole.world)


def test_kinematic_bad_input_is_one_line():
    w = tb.World()
    with pytest.raises(InputError, match="fixed or kinematic, not both"):
        w.add_body(tb.Box((1, 1, 1)), fixed=True, kinematic=True)
    with pytest.raises(InputError, match="a plane can only be a fixed body"):
        w.add_body(tb.Plane(), kinematic=True)
    k = w.add_body(tb.Box((1, 1, 1)), kinematic=True, name="k")
    d = w.add_body(tb.Box((1, 1, 1)), mass=1, name="d")
    with pytest.raises(InputError, match="no momentum"):
        k.P = (1, 0, 0)
    with pytest.raises(InputError, match="not kinematic"):
        d.set_target((0, 0, 0), time=1.0)
    with pytest.raises(InputError, match="positive number of seconds"):
        k.set_target((0, 0, 0), time=0.0)


def test_a_kinematic_triangle_mesh_lifts_what_lies_on_it():
    # a static-mesh shape may be kinematic (a moving floor, a rotating bowl): a slab of 12
    # triangles rising at 0.5 m/s while drifting and turning carries a ball and a box up at its
    # speed. Measured: both ride at the slab's vertical speed to 1e-9 m/s, their heights above
    # it to 5 um (the soft contact's give under the weight).
    trimesh = pytest.importorskip("trimesh")
    slab = trimesh.creation.box(extents=(4, 4, 0.2))
    w = tb.World(gravity=(0, 0, -G))
    mat = tb.Material(friction=0.8)
    tray = w.add_body(tb.Mesh(vertices=slab.vertices, faces=slab.faces), kinematic=True, position=(0, 0, -0.1),
                      velocity=(0.3, 0, 0.5), angular_velocity=(0, 0, 0.2), material=mat, name="tray")
    ball = w.add_body(tb.Sphere(0.2), mass=1, position=(0, 0, 0.2), material=mat, name="ball")
    box = w.add_body(tb.Box((0.3, 0.3, 0.3)), mass=1, position=(1, 0, 0.15), material=mat, name="box")
    tb.Simulator(w, dt=DT).run(2.0, frame_rate=24)
    np.testing.assert_allclose(tray.x, (0.6, 0, 0.9), rtol=0, atol=1e-12)
    top = tray.x[2] + 0.1
    assert ball.x[2] - top == pytest.approx(0.2, abs=5e-5)
    assert box.x[2] - top == pytest.approx(0.15, abs=5e-5)
    assert ball.v[2] == pytest.approx(0.5, abs=1e-9) and box.v[2] == pytest.approx(0.5, abs=1e-9)


# ---------------------------------------------------------------------- keyframed paths

def _slerp_z(a0, a1, s):
    return _quat_z((1 - s) * a0 + s * a1)


@pytest.mark.parametrize("layout", ["quaternion", "matrix"])
def test_a_path_body_passes_through_its_keyframes_and_holds_the_last(layout):
    # keys at 0, 0.5, 1.25 s: positions interpolated linearly, the turn about z by slerp (for a
    # fixed axis, the angle linear in time). Each step moves the body to the path's pose at the
    # step's end from where it is: the poses at step ends are the path's to round-off (1e-12).
    w = tb.World(gravity=(0, 0, -G), layout=layout)
    pad = w.add_body(tb.Box((1, 1, 0.1)), kinematic=True, name="pad")
    times, pos = [0.0, 0.5, 1.25], np.array([[0, 0, 1.0], [1, 0, 1.5], [1, 2, 1.0]])
    yaw = [0.0, 90.0, 45.0]
    w.add_path(tb.KeyframePath(pad, times=times, positions=pos, euler_deg=[[0, 0, a] for a in yaw]))
    traj = tb.Simulator(w, dt=DT).run(2.0, frame_rate=240)
    t = traj.time
    for (t0, t1), (p0, p1), (a0, a1) in zip(zip(times, times[1:]), zip(pos, pos[1:]), zip(yaw, yaw[1:])):
        seg = (t >= t0) & (t <= t1)
        s = ((t[seg] - t0) / (t1 - t0))[:, None]
        np.testing.assert_allclose(traj.position[seg, 0], (1 - s) * p0 + s * p1, rtol=0, atol=1e-12)
        q = np.array([_slerp_z(np.radians(a0), np.radians(a1), si) for si in s[:, 0]])
        np.testing.assert_allclose(traj.orientation[seg, 0], q, rtol=0, atol=1e-12)
    held = t > times[-1] + DT
    np.testing.assert_allclose(traj.position[held, 0], np.broadcast_to(pos[-1], (held.sum(), 3)), rtol=0, atol=1e-12)
    # still, but for the turn that takes back the round-off of the orientation (1e-13 rad/s)
    assert np.all(traj.velocity[held, 0] == 0.0)
    np.testing.assert_allclose(traj.angular_velocity[held, 0], 0.0, rtol=0, atol=1e-10)
    # within a segment the velocity is the segment's: (p1 - p0) / (t1 - t0)
    mid = (t > 0.6) & (t < 1.2)
    np.testing.assert_allclose(traj.velocity[mid, 0], np.broadcast_to((0, 2 / 0.75, -0.5 / 0.75), (mid.sum(), 3)),
                               rtol=0, atol=1e-9)


def test_a_repeating_shuttle_carries_its_passenger_back_and_forth():
    # a platform shuttling 1 m along x and back every 4 s (0.5 m/s out and back) with a box on
    # it that friction holds but for a slip at each change of velocity: a jump dv in one step
    # makes the box slide dv^2 / (2 mu g) over it, braked at mu g. So it starts 0.5^2 / (2 mu g)
    # = 1.6 cm behind (the start from rest), then at each turn (dv = 1 m/s) slides 6.4 cm the
    # other way: relative to the platform it sits at -0.25 / (2 mu g) on the way out and at
    # +0.75 / (2 mu g) on the way back, period after period (measured within 0.3 mm).
    mu = 0.8
    w = tb.World(gravity=(0, 0, -G))
    mat = tb.Material(friction=mu)
    plat = w.add_body(tb.Box((2, 1, 0.2)), kinematic=True, material=mat, name="shuttle")
    w.add_path(tb.KeyframePath(plat, times=[0, 2, 4], positions=[[0, 0, 0.5], [1, 0, 0.5], [0, 0, 0.5]], repeat=True))
    box = w.add_body(tb.Box((0.3, 0.3, 0.3)), mass=1, position=(0, 0, 0.75), material=mat, name="box")
    traj = tb.Simulator(w, dt=DT).run(12.0, frame_rate=24)
    t = traj.time
    np.testing.assert_allclose(plat.x, (0, 0, 0.5), rtol=0, atol=1e-12)
    # the platform's x follows the triangle wave of period 4 s
    phase = np.mod(t, 4.0)
    wave = np.where(phase <= 2.0, phase / 2.0, 2.0 - phase / 2.0)
    np.testing.assert_allclose(traj.position[:, plat.index, 0], wave, rtol=0, atol=1e-12)
    rel = traj.position[:, box.index, 0] - traj.position[:, plat.index, 0]
    out = (phase > 0.3) & (phase < 1.95)
    back = (phase > 2.3) & (phase < 3.95)
    np.testing.assert_allclose(rel[out], -0.25 / (2 * mu * G), rtol=0, atol=1e-3)
    np.testing.assert_allclose(rel[back], 0.75 / (2 * mu * G), rtol=0, atol=1e-3)
    assert box.x[2] == pytest.approx(0.75, abs=1e-4)


def test_a_run_with_a_path_resumes_bit_for_bit(tmp_path):
    def world():
        w = tb.World(gravity=(0, 0, -G))
        _ground(w)
        paddle = w.add_body(tb.Box((0.1, 1, 0.4)), kinematic=True, name="paddle")
        w.add_path(tb.KeyframePath(paddle, times=[0, 1, 2], positions=[[-1, 0, 0.2], [1, 0, 0.2], [-1, 0, 0.2]],
                                   euler_deg=[[0, 0, 0], [0, 0, 60], [0, 0, 0]], repeat=True))
        for k in range(4):
            w.add_body(tb.Sphere(0.1), mass=0.5, position=(-0.6 + 0.4 * k, 0.1 * k, 0.1), name=f"ball{k}")
        return w

    whole, resumed = resumed_run(world, tmp_path, 2.5, DT)
    assert len(resumed.world.paths) == 1
    assert state_hash(resumed.world) == state_hash(whole.world)


def test_path_bad_input_is_one_line():
    w = tb.World()
    k = w.add_body(tb.Box((1, 1, 1)), kinematic=True, name="k")
    d = w.add_body(tb.Box((1, 1, 1)), mass=1, name="d")
    with pytest.raises(InputError, match="not kinematic"):
        w.add_path(tb.KeyframePath(d, times=[0, 1], positions=[[0, 0, 0], [1, 0, 0]]))
    with pytest.raises(InputError, match="times must increase strictly"):
        tb.KeyframePath(k, times=[0, 1, 1], positions=[[0, 0, 0]] * 3)
    with pytest.raises(InputError, match="at least 2"):
        tb.KeyframePath(k, times=[0], positions=[[0, 0, 0]])
    with pytest.raises(InputError, match=r"expected 2 rows of 3 finite numbers \(one per time\), got shape \[3, 3\]"):
        tb.KeyframePath(k, times=[0, 1], positions=[[0, 0, 0]] * 3)
    with pytest.raises(InputError, match="orientations or euler_deg, not both"):
        tb.KeyframePath(k, times=[0, 1], positions=[[0, 0, 0]] * 2, orientations=[[1, 0, 0, 0]] * 2,
                        euler_deg=[[0, 0, 0]] * 2)
    w.add_path(tb.KeyframePath(k, times=[0, 1], positions=[[0, 0, 0], [1, 0, 0]]))
    with pytest.raises(InputError, match="already has a path"):
        w.add_path(tb.KeyframePath(k, times=[0, 1], positions=[[0, 0, 0], [1, 0, 0]]))
