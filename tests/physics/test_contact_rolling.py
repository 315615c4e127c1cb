"""Rolling contact against the textbook: a ball, a cylinder and a capsule launched sliding roll
from the time Coulomb friction says at the speed angular momentum about the contact point
says; bodies that roll keep rolling (no rolling resistance is modelled); frictionless balls
keep their spin and never start one; a ball rolls down an incline at 5/7 g sin(theta) and slips
where mu < 2/7 tan(theta).

Why these exist: the contact point of a rolling body is not a point of the body. With anchors
fixed in the body (as a box's corner is), a ball rolling at 2 m/s lost 27 % of its speed in
1 s, a frictionless one spinning in place lost 22 % of its spin, and a frictionless one sliding
at 2 m/s started to spin (solver/contact_anchor.py has the story). Every test below fails on
that code.

Every run uses the Simulator's defaults (dt 1/240 s, 4 solver substeps, h = 1/960 s). The
tolerances are what one substep can hold: friction switches from slip to stick within a
substep, in which it changes the speed by at most mu g h (2e-3 m/s at mu = 0.2), and the
positions see the gravity of a substep (g h^2 ~ 1e-5 m).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

import tumble as tb

G = 9.81
R = 0.1  # m, the radius of every rolling body
H = 1.0 / 960.0  # s, the default substep


def _world(floor: str = "plane", friction: float = 0.2, normal=(0.0, 0.0, 1.0)):
    w = tb.World(gravity=(0.0, 0.0, -G))
    material = tb.Material(friction=friction, restitution=0.0)
    if floor == "plane":
        w.add_body(tb.Plane(normal=normal), fixed=True, name="floor", material=material)
    elif floor == "box":  # a static box 40 m long whose top face is z = 0
        w.add_body(tb.Box(size=(40.0, 4.0, 0.5)), fixed=True, position=(0, 0, -0.25), name="floor",
                   material=material)
    else:  # a static triangle mesh of the same slab
        slab = trimesh.creation.box(extents=(40.0, 4.0, 0.5))
        w.add_body(tb.Mesh(vertices=slab.vertices, faces=slab.faces), fixed=True, position=(0, 0, -0.25),
                   name="floor", material=material)
    return w, material


_LYING = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)  # a z axis turned onto -y: rolls along x


def _shapes():
    return {
        "sphere": (tb.Sphere(radius=R), None),
        "cylinder": (tb.Cylinder(radius=R, length=0.3), _LYING),
        "capsule": (tb.Capsule(radius=R, length=0.3), _LYING),
    }


def _run(world, duration, frame_rate=240):
    return tb.Simulator(world).run(duration, frame_rate=frame_rate)


# ---------------------------------------------------------------------- sliding, then rolling
@pytest.mark.parametrize("name", ["sphere", "cylinder", "capsule"])
def test_a_body_launched_sliding_rolls_at_the_speed_and_time_coulomb_gives(name):
    """Launched at v0 = 3 m/s without spin on a plane (mu = 0.2). Friction mu m g decelerates
    the centre and spins the body up until the contact point stops slipping: with
    k = I / (m r^2) about the rolling axis, angular momentum about the contact point is kept,
    so it rolls on at v0 / (1 + k) from t* = k v0 / ((1 + k) mu g) (5/7 v0 for a ball; 2/3 for
    a cylinder; the capsule's k from the World's inertia, 0.469). Tolerances: the speed to
    mu g h (one substep of friction: 2e-3 m/s) over the 2.14-2.04 m/s; t* to a frame (1/240 s)
    and a substep; then omega r = v to 1e-4 m/s; the slipping deceleration to 0.1 %. Measured:
    the ball's speed to 2e-14 m/s, the cylinder's and capsule's to 3e-11, t* within 3.4 ms
    (the frame after the slip ends), the deceleration within 3e-6. The code before ended the
    ball at 1.26 m/s."""
    v0, mu = 3.0, 0.2
    w, material = _world(friction=mu)
    shape, orientation = _shapes()[name]
    body = w.add_body(shape, mass=1.0, position=(0, 0, R), orientation=orientation, velocity=(v0, 0, 0),
                      material=material)
    Rb = np.array(body.R)
    I_world = Rb @ np.array(body.inertia_body) @ Rb.T
    k = float(I_world[1, 1]) / R**2  # about world y, the rolling axis (mass 1 kg)
    traj = _run(w, 1.5)
    v = traj.velocity[:, 1, 0]
    omega_r = traj.angular_velocity[:, 1, 1] * R
    expected = v0 / (1.0 + k)
    t_star = k * v0 / ((1.0 + k) * mu * G)
    assert abs(v[-1] - expected) < mu * G * H, (v[-1], expected)
    assert abs(omega_r[-1] - v[-1]) < 1e-4
    rolling = np.flatnonzero(np.abs(v - omega_r) < 1e-3)
    assert abs(traj.time[rolling[0]] - t_star) <= 1.0 / 240.0 + H, (traj.time[rolling[0]], t_star)
    # while it slips, the centre decelerates at mu g (the slip's kinetic friction)
    slipping = traj.time < t_star - 0.02
    slope = np.polyfit(traj.time[slipping], v[slipping], 1)[0]
    assert abs(slope + mu * G) < 1e-3 * mu * G, slope


def test_a_ball_spun_in_place_rolls_off_at_two_sevenths_of_its_spin():
    """A ball spinning at omega0 = 15 rad/s about a horizontal axis, set down without speed
    (mu = 0.5): angular momentum about the contact point, I omega0, is kept, so it rolls off at
    v = (2/7) omega0 r (0.4286 m/s). Tolerance mu g h (5e-3 m/s); measured within 2e-15 m/s
    (the code before: 0.446 m/s)."""
    omega0, mu = 15.0, 0.5
    w, material = _world(friction=mu)
    ball = w.add_body(tb.Sphere(radius=R), mass=1.0, position=(0, 0, R), angular_velocity=(0, omega0, 0),
                      material=material)
    _run(w, 1.0, frame_rate=24)
    assert abs(ball.v[0] - 2.0 / 7.0 * omega0 * R) < mu * G * H
    assert abs(ball.omega[1] * R - ball.v[0]) < 1e-4


# ---------------------------------------------------------------------- rolling goes on
@pytest.mark.parametrize("floor", ["plane", "box", "mesh"])
def test_a_rolling_ball_keeps_rolling_on_a_plane_a_box_and_a_mesh(floor):
    """A ball rolling at 2 m/s (omega r = v) on a level floor, 3 s: no force does work on it,
    so its speed and spin stay (tumble models no rolling resistance, as PyBullet's and MuJoCo's
    defaults), on a plane, on a static box's face and on a static mesh's triangles. Tolerance
    1e-3 of the speed (measured 2e-14 m/s on all three floors) over the 6 m; the old anchors lost
    27 % in the first second. The centre stays at z = r within 0.1 mm (the soft contact's sag
    under the ball's weight: 4 micrometres)."""
    w, material = _world(floor, friction=0.5)
    ball = w.add_body(tb.Sphere(radius=R), mass=1.0, position=(-3.0, 0, R), velocity=(2.0, 0, 0),
                      angular_velocity=(0, 2.0 / R, 0), material=material)
    traj = _run(w, 3.0, frame_rate=24)
    v = traj.velocity[:, 1]
    assert np.max(np.abs(v[:, 0] - 2.0)) < 2e-3, np.max(np.abs(v[:, 0] - 2.0))
    assert np.max(np.abs(traj.angular_velocity[:, 1, 1] * R - 2.0)) < 2e-3
    assert np.max(np.abs(traj.position[:, 1, 2] - R)) < 1e-4
    assert abs(ball.x[0] - 3.0) < 6e-3


def test_a_frictionless_ball_keeps_its_spin_and_never_starts_one():
    """No friction: the plane's force on a ball passes through its centre, so a ball spinning in
    place keeps omega exactly as it was and a ball sliding keeps its speed without turning. The
    code before lost 22 % of a 15 rad/s spin in 1 s and spun a ball sliding at 2 m/s up to
    2.4 rad/s. Bounds: 1e-4 relative (measured: the spin unchanged to the bit, 3e-30 rad/s of
    spin on the sliding ball)."""
    w, material = _world(friction=0.0)
    spinning = w.add_body(tb.Sphere(radius=R), mass=1.0, position=(0, -2, R), angular_velocity=(0, 15.0, 0),
                          material=material)
    sliding = w.add_body(tb.Sphere(radius=R), mass=1.0, position=(0, 2, R), velocity=(2.0, 0, 0),
                         material=material)
    _run(w, 1.0, frame_rate=24)
    assert abs(spinning.omega[1] - 15.0) < 1.5e-3
    assert np.linalg.norm(spinning.v) < 1e-4
    assert np.linalg.norm(sliding.omega) < 1e-4
    assert abs(sliding.v[0] - 2.0) < 2e-4


# ---------------------------------------------------------------------- down an incline
@pytest.mark.parametrize("mu, rolls", [(0.5, True), (0.1, False)])
def test_a_ball_on_an_incline_rolls_at_five_sevenths_g_sin_or_slips(mu, rolls):
    """A ball released on a 30 degree plane. Rolling needs a friction force (2/7) m g sin(theta),
    which mu m g cos(theta) can give when mu >= (2/7) tan(theta) = 0.165: then it rolls with
    a = (5/7) g sin(theta) (3.504 m/s^2). Below, it slips, with a = g (sin - mu cos) (4.055
    m/s^2 at mu = 0.1) and an angular acceleration 5 mu g cos / (2 r). Accelerations from a line
    through 1 s of speeds along the slope (from 0.1 s on, once the contact's soft sag has
    settled), to 0.2 %; measured within 6e-15. The code before rolled at 2.81 m/s^2, 20 % slow."""
    theta = math.radians(30.0)
    normal = (0.0, math.sin(theta), math.cos(theta))  # the slope goes down towards +y
    w, material = _world(friction=mu, normal=normal)
    n = np.array(normal)
    w.add_body(tb.Sphere(radius=R), mass=1.0, position=tuple(R * n), material=material)
    traj = _run(w, 1.0)
    down = np.array([0.0, math.cos(theta), -math.sin(theta)])
    speed = traj.velocity[:, 1] @ down
    axis = np.cross(n, down)  # a ball rolling down turns about n x down
    spin = traj.angular_velocity[:, 1] @ axis * R
    late = traj.time > 0.1
    a = np.polyfit(traj.time[late], speed[late], 1)[0]
    alpha_r = np.polyfit(traj.time[late], spin[late], 1)[0]
    if rolls:
        expected, expected_spin = 5.0 / 7.0 * G * math.sin(theta), 5.0 / 7.0 * G * math.sin(theta)
    else:
        expected = G * (math.sin(theta) - mu * math.cos(theta))
        expected_spin = 2.5 * mu * G * math.cos(theta)
    assert abs(a - expected) < 2e-3 * expected, (a, expected)
    assert abs(alpha_r - expected_spin) < 2e-3 * expected_spin, (alpha_r, expected_spin)
    assert np.max(np.abs(traj.position[:, 1] @ n - R)) < 1e-4  # on the slope throughout


# ---------------------------------------------------------------------- a rough bounce
@pytest.mark.parametrize("dt", [1.0 / 240.0, 1.0 / 60.0])
def test_a_ball_landing_while_sliding_leaves_rolling_at_five_sevenths(dt):
    """A ball meets the floor at 3 m/s down and 2 m/s along it, without spin, no gravity,
    e = 0.5, mu = 1 (enough to stop the slip within the impact: it needs a friction impulse of
    2/7 of m 2 m/s, the normal impulse is m 4.5 m/s). A rigid impact with sticking friction keeps
    the ball's angular momentum about the contact point: it leaves at 5/7 of 2 m/s, rolling
    (omega r = v), and at e 3 m/s up. Tolerance 1e-9 m/s (round-off; measured 1e-15), at the
    default dt and at Box3D's 1/60 s. The anchor at the contact's midpoint, 6.25 mm below the ball
    when the step began 12.5 mm above the floor, left it at 1.477 m/s, still slipping."""
    w = tb.World(gravity=(0.0, 0.0, 0.0))
    material = tb.Material(friction=1.0, restitution=0.5)
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, material=material)
    ball = w.add_body(tb.Sphere(radius=R), mass=1.0, position=(0, 0, R + 0.05), velocity=(2.0, 0, -3.0),
                      material=material)
    tb.Simulator(w, dt=dt).run(0.25, frame_rate=12)
    assert abs(ball.v[0] - 5.0 / 7.0 * 2.0) < 1e-9, ball.v
    assert abs(ball.v[2] - 1.5) < 1e-9, ball.v
    assert abs(ball.omega[1] * R - ball.v[0]) < 1e-9, ball.omega
