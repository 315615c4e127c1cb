"""Each force type of tumble.forces against an analytic solution, through the engine (World, Simulator).

Unless a test says otherwise: RK4 at dt = 1/240 s, one frame per step (so
every step is recorded), gravity off so that only the force under test acts.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tumble as tb

DT = 1.0 / 240.0


def simulate(world, duration, integrator="rk4", dt=DT):
    """Run ``world`` recording every step; returns the Trajectory."""
    return tb.Simulator(world, dt=dt, integrator=integrator).run(duration=duration, frame_rate=1.0 / dt, progress=False)


def sphere_world(mass=2.0, radius=0.5, gravity=(0, 0, 0), **body):
    w = tb.World(gravity=gravity)
    b = w.add_body(tb.Sphere(radius), mass=mass, **body)
    return w, b


# ---------------------------------------------------------------------- gravity


def test_free_fall_is_exact_with_rk4():
    w, b = sphere_world(gravity=(0.3, -0.2, -9.81), position=(1, 2, 3), velocity=(2, -1, 7))
    traj = simulate(w, 2.0)
    t = traj.time[:, None]
    g = np.array([0.3, -0.2, -9.81])
    # x(t) = x0 + v0 t + g t^2 / 2 is a polynomial of degree 2: RK4 is exact on
    # it, only rounding is left (~1e-15 per step, 480 steps) -> 1e-12.
    np.testing.assert_allclose(traj.position[:, 0], [1, 2, 3] + np.array([2, -1, 7]) * t + 0.5 * g * t**2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.velocity[:, 0], [2, -1, 7] + g * t, rtol=0, atol=1e-12)


# ---------------------------------------------------------------------- drag and wind


def test_linear_drag_decays_exponentially():
    m, k = 2.0, 1.5
    v0 = np.array([3.0, -2.0, 1.0])
    w, b = sphere_world(mass=m, velocity=v0)
    w.add_force(tb.Drag(linear=k))
    traj = simulate(w, 2.0)
    exact = v0 * np.exp(-k * traj.time / m)[:, None]
    # m dv/dt = -k v: v0 exp(-k t / m). RK4's error per step is
    # (k h / m)^5 / 120 ~ 1e-14 relative: 1e-9 over 480 steps is a wide margin
    # and still fails for any lower-order scheme (Euler: ~1e-3).
    rel = np.linalg.norm(traj.velocity[:, 0] - exact, axis=1) / np.linalg.norm(exact, axis=1)
    assert rel.max() < 1e-9
    # and x(t) = x0 + m v0 / k (1 - exp(-k t / m))
    x_exact = v0 * (m / k) * (1 - np.exp(-k * traj.time / m))[:, None]
    np.testing.assert_allclose(traj.position[:, 0], x_exact, rtol=0, atol=1e-9)


def test_wind_with_linear_drag_carries_a_body_along():
    m, k = 0.5, 0.8
    wind = np.array([4.0, 1.0, -0.5])
    for record in (tb.Wind(velocity=wind, linear=k), tb.Drag(linear=k, wind=wind)):
        w, b = sphere_world(mass=m)
        w.add_force(record)
        traj = simulate(w, 2.0)
        # m dv/dt = -k (v - w), v(0) = 0: v = w (1 - exp(-k t / m)). Same
        # RK4 error argument as plain linear drag (k/m = 1.6 /s): 1e-9 relative to |w|.
        exact = wind * (1 - np.exp(-k * traj.time / m))[:, None]
        assert np.max(np.linalg.norm(traj.velocity[:, 0] - exact, axis=1)) < 1e-9 * np.linalg.norm(wind)


def test_quadratic_drag_reaches_terminal_speed():
    m, c, g = 1.0, 0.4, 9.81
    vt = math.sqrt(m * g / c)  # 4.95 m/s
    tau = vt / g  # time constant of the fall, 0.505 s
    w, b = sphere_world(mass=m, gravity=(0, 0, -g))
    w.add_force(tb.Drag(quadratic=c))
    duration = 10.5  # > 20 time constants, a whole number of steps
    assert duration > 20 * tau
    traj = simulate(w, duration)
    speed_down = -traj.velocity[:, 0, 2]
    # m dv/dt = m g - c v^2 from rest: v(t) = vt tanh(g t / vt). RK4 at h/tau
    # ~ 1/120 has a global error ~1e-10 m/s; 1e-8 m/s.
    assert np.max(np.abs(speed_down - vt * np.tanh(g * traj.time / vt))) < 1e-8
    # the fall stays vertical
    assert np.max(np.abs(traj.velocity[:, 0, :2])) == 0.0
    # after 20 time constants tanh(20) = 1 - 8e-18: the terminal speed itself
    assert abs(speed_down[-1] - vt) < 1e-6


def test_angular_drag_decays_spin_exponentially():
    m, r, c = 3.0, 0.2, 0.05
    I = 0.4 * m * r**2  # solid sphere, 0.048 kg m^2
    omega0 = np.array([1.0, -4.0, 2.5])
    w, b = sphere_world(mass=m, radius=r, angular_velocity=omega0)
    w.add_force(tb.Drag(angular_linear=c))
    traj = simulate(w, 2.0)
    # I domega/dt = -c omega (a sphere: I is isotropic, omega stays parallel
    # to L): omega0 exp(-c t / I); c / I ~ 1 /s, RK4 error as for linear drag.
    exact = omega0 * np.exp(-c * traj.time / I)[:, None]
    rel = np.linalg.norm(traj.angular_velocity[:, 0] - exact, axis=1) / np.linalg.norm(exact, axis=1)
    assert rel.max() < 1e-9
    # angular drag gives no force
    assert np.max(np.abs(traj.position[:, 0])) == 0.0


# ---------------------------------------------------------------------- springs


def test_damped_spring_to_a_world_anchor_matches_the_oscillator():
    m, k, c, l0, A = 1.5, 40.0, 1.2, 1.0, 0.3
    w, b = sphere_world(mass=m, position=(l0 + A, 0, 0))
    w.add_force(tb.Spring(b, None, anchor_b=(0, 0, 0), stiffness=k, damping=c, rest_length=l0))
    traj = simulate(w, 3.0)
    # 1-D along x (anchor at the origin, the body on +x, never reaching it):
    # m x'' = -k (x - l0) - c x', underdamped (zeta = 0.077), released at rest:
    # x - l0 = A exp(-zeta w0 t) (cos wd t + zeta w0 / wd sin wd t).
    w0 = math.sqrt(k / m)
    zeta = c / (2 * math.sqrt(k * m))
    assert zeta < 1
    wd = w0 * math.sqrt(1 - zeta**2)
    t = traj.time
    x = l0 + A * np.exp(-zeta * w0 * t) * (np.cos(wd * t) + zeta * w0 / wd * np.sin(wd * t))
    # RK4 at w0 h = 0.022 over 3 s (8 periods): the error is ~3e-9 m; 1e-8.
    assert np.max(np.abs(traj.position[:, 0, 0] - x)) < 1e-8
    assert np.max(np.abs(traj.position[:, 0, 1:])) == 0.0
    # a spring through the centre of mass gives no torque
    assert np.max(np.abs(traj.angular_momentum)) == 0.0


def test_spring_between_two_free_bodies_conserves_momentum():
    w = tb.World(gravity=(0, 0, 0))
    a = w.add_body(tb.Box((0.2, 0.3, 0.4)), mass=1.0, position=(0, 0, 0), velocity=(0.5, 1.0, 0.0), angular_velocity=(0, 1, 2))
    b = w.add_body(tb.Sphere(0.1), mass=3.0, position=(1.2, 0.3, -0.1), velocity=(-0.2, 0.0, 0.4))
    # off-centre anchors: the spring also gives torques, and a pull along a line
    # that does not go through the centres
    w.add_force(tb.Spring(a, b, anchor_a=(0.1, 0.15, 0.2), anchor_b=(0.0, 0.05, 0.0), stiffness=30.0, damping=0.5, rest_length=0.8))
    traj = simulate(w, 3.0)
    M = 4.0
    P = traj.total_linear_momentum
    # F_b = -F_a exactly in every stage: total P is constant, to rounding
    # (|P| ~ 1.4 kg m/s, 720 steps of ~1e-16): 1e-12 kg m/s.
    assert np.max(np.abs(P - P[0])) < 1e-12
    # hence the centre of mass moves uniformly: x_c(t) = x_c(0) + P t / M
    # (1e-12 m: the position is a sum of steps, rounding only)
    xc = (1.0 * traj.position[:, 0] + 3.0 * traj.position[:, 1]) / M
    np.testing.assert_allclose(xc, xc[0] + np.outer(traj.time, P[0] / M), rtol=0, atol=1e-12)
    # while each body on its own does not (the spring does work on them)
    assert np.max(np.abs(traj.position[:, 0] - (traj.position[0, 0] + np.outer(traj.time, traj.velocity[0, 0])))) > 0.05


# ---------------------------------------------------------------------- constant, point


def test_constant_force_and_torque():
    m, r = 2.0, 0.3
    I = 0.4 * m * r**2
    F = np.array([1.0, -2.0, 0.5])
    tau = np.array([0.02, 0.05, -0.03])
    w, b = sphere_world(mass=m, radius=r, position=(0.5, 0, 1))
    w.add_force(tb.ConstantForce(b, force=F, torque=tau))
    traj = simulate(w, 1.0)
    t = traj.time[:, None]
    # a = F / m: x = x0 + F t^2 / (2 m), degree 2, exact under RK4 (rounding: 1e-12)
    np.testing.assert_allclose(traj.position[:, 0], [0.5, 0, 1] + F * t**2 / (2 * m), rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.velocity[:, 0], F * t / m, rtol=0, atol=1e-12)
    # L = tau t exactly, and for a sphere (isotropic I) omega = tau t / I
    np.testing.assert_allclose(traj.angular_momentum[:, 0], tau * t, rtol=0, atol=1e-14)
    np.testing.assert_allclose(traj.angular_velocity[:, 0], tau * t / I, rtol=0, atol=1e-12)


@pytest.mark.parametrize("frame", ["world", "body"])
def test_point_force_torque(frame):
    w = tb.World(gravity=(0, 0, 0))
    b = w.add_body(tb.Box((0.2, 0.4, 0.6)), mass=1.5, position=(0.3, -0.2, 1.1), euler_deg=(20, -35, 60))
    F = np.array([2.0, -1.0, 3.0])
    p = np.array([0.4, 0.1, -0.3])
    w.add_force(tb.PointForce(b, force=F, point=p, frame=frame))
    w.update_derived()
    x, R = b.x.copy(), b.R.copy()
    # Baraff 2001 eq. 2-37: tau = (p - x) x F, with p the world point, or
    # p = R p_body + x for a point fixed on the body. One evaluation, rounding only.
    lever = p - x if frame == "world" else R @ p
    np.testing.assert_allclose(w.force[0], F, rtol=0, atol=1e-15)
    np.testing.assert_allclose(w.torque[0], np.cross(lever, F), rtol=0, atol=1e-14)
    assert np.linalg.norm(np.cross(p - x, F) - np.cross(R @ p, F)) > 0.1  # the two frames differ here

    # After the body has turned, the body point turns with it; the world point stays.
    b.q = tb.math3d.quat_from_euler_deg(np.array([-50.0, 10.0, 5.0]))
    b.x = (1.0, 2.0, 0.5)
    x, R = b.x.copy(), b.R.copy()
    lever = p - x if frame == "world" else R @ p
    np.testing.assert_allclose(w.torque[0], np.cross(lever, F), rtol=0, atol=1e-14)


# ---------------------------------------------------------------------- impulse


@pytest.mark.parametrize("time, step", [(0.1, 24), (0.1021, 25), (0.0, 0)])
def test_impulse_jumps_momentum_at_its_step(time, step):
    m = 1.5
    w = tb.World(gravity=(0, 0, 0))
    b = w.add_body(tb.Box((0.2, 0.4, 0.6)), mass=m, position=(0, 0, 1), velocity=(1.0, 0.0, 0.5), angular_velocity=(0.3, -0.2, 0.1))
    J = np.array([0.5, -1.0, 2.0])
    p = np.array([0.1, 0.2, 1.3])
    w.add_force(tb.Impulse(b, impulse=J, point=p, time=time))
    traj = simulate(w, 0.25)
    # Frame k is the state after k steps (t = k dt). The impulse acts before
    # the first step that starts at or after its time, step = ceil(time / dt):
    # frame `step` is still without it, frame `step + 1` has it.
    assert math.isclose(traj.time[step], step * DT)
    P, L, v = traj.linear_momentum[:, 0], traj.angular_momentum[:, 0], traj.velocity[:, 0]
    # no force between the frames: P and L constant apart from the jump (exact: rounding only)
    np.testing.assert_allclose(P[: step + 1], np.broadcast_to(P[0], P[: step + 1].shape), rtol=0, atol=1e-15)
    np.testing.assert_allclose(L[: step + 1], np.broadcast_to(L[0], L[: step + 1].shape), rtol=0, atol=1e-15)
    # the jump: v by J / m, P by J, L by (p - x) x J with x where the body was at that instant
    x_at = traj.position[step, 0]
    np.testing.assert_allclose(v[step + 1] - v[step], J / m, rtol=0, atol=1e-14)
    np.testing.assert_allclose(P[step + 1] - P[step], J, rtol=0, atol=1e-14)
    np.testing.assert_allclose(L[step + 1] - L[step], np.cross(p - x_at, J), rtol=0, atol=1e-14)
    # and only once
    np.testing.assert_allclose(P[step + 1:], np.broadcast_to(P[step + 1], P[step + 1:].shape), rtol=0, atol=1e-15)
    np.testing.assert_allclose(L[step + 1:], np.broadcast_to(L[step + 1], L[step + 1:].shape), rtol=0, atol=1e-14)


def test_impulse_without_point_acts_at_the_centre_of_mass():
    w, b = sphere_world(mass=2.0, angular_velocity=(0, 0, 1))
    w.add_force(tb.Impulse(b, impulse=(0, 4, 0), time=0.05))
    traj = simulate(w, 0.1)
    np.testing.assert_allclose(traj.velocity[-1, 0], [0, 2, 0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(traj.angular_momentum[-1, 0], traj.angular_momentum[0, 0], rtol=0, atol=1e-15)


# ---------------------------------------------------------------------- custom


def test_custom_force_spring_matches_builtin_spring():
    k, c, l0 = 25.0, 0.7, 0.4
    anchor = np.array([0.0, 0.0, 2.0])
    start = dict(position=(0.5, 0.2, 1.0), velocity=(0.0, 1.0, 0.3), angular_velocity=(0.5, 1.0, -2.0))

    def world():
        w = tb.World()  # with gravity: the spring hangs and swings in 3-D
        b = w.add_body(tb.Box((0.2, 0.3, 0.4)), mass=1.2, **start)
        return w, b

    w1, b1 = world()
    w1.add_force(tb.Spring(b1, None, anchor_b=anchor, stiffness=k, damping=c, rest_length=l0))
    t1 = simulate(w1, 2.0)

    calls = []

    def spring(t, body):
        # Baraff's damped spring between the centre of mass and a world anchor,
        # written from the stage state handed to the callable.
        calls.append((t, body.x.copy(), body.v.copy()))
        d = body.x - anchor
        l = np.linalg.norm(d)
        u = d / l
        f = -(k * (l - l0) + c * np.dot(body.v, u)) * u
        return f, np.zeros(3)

    w2, b2 = world()
    w2.add_force(tb.CustomForce(spring))
    sim = tb.Simulator(w2, dt=DT, integrator="rk4")
    t2 = sim.run(duration=2.0, frame_rate=1 / DT, progress=False)

    # Same forces through a different path (Python stage by stage vs the
    # compiled kernel): the same arithmetic, so the same trajectory to
    # rounding (1e-12 over 480 steps of a motion of size ~1).
    np.testing.assert_allclose(t2.position, t1.position, rtol=0, atol=1e-12)
    np.testing.assert_allclose(t2.velocity, t1.velocity, rtol=0, atol=1e-12)
    np.testing.assert_allclose(t2.orientation, t1.orientation, rtol=0, atol=1e-12)
    np.testing.assert_allclose(t2.angular_momentum, t1.angular_momentum, rtol=0, atol=1e-12)
    assert np.max(np.abs(t1.position[:, 0] - t1.position[0, 0])) > 0.1  # it did move

    # Called once per RK4 stage: 4 times a step, at t, t + h/2, t + h/2, t + h ...
    steps = 480
    assert sim.stats["steps"] == steps
    assert len(calls) == 4 * steps
    times = np.array([ct for ct, _, _ in calls]).reshape(steps, 4)
    t0 = np.arange(steps) * DT
    np.testing.assert_allclose(times, t0[:, None] + np.array([0.0, 0.5, 0.5, 1.0]) * DT, rtol=0, atol=1e-12)
    # ... with the stage state, not the step's: stage 2 is x_n + h/2 v_n (RK4's
    # k1 for x is v), stage 1 is the recorded frame.
    for n in (0, 1, 100, 479):
        (_, x1, v1), (_, x2, _), (_, x3, _) = calls[4 * n: 4 * n + 3]
        np.testing.assert_allclose(x1, t2.position[n, 0], rtol=0, atol=1e-15)
        np.testing.assert_allclose(x2, x1 + 0.5 * DT * v1, rtol=0, atol=1e-15)
        assert np.linalg.norm(x3 - x2) > 0  # stage 3 is yet another state


# ---------------------------------------------------------------------- removing and changing forces
def test_remove_force_stops_it_and_keeps_the_applied_impulses_applied():
    """World.remove_force: the removed spring no longer acts (a free body then moves at its
    constant velocity, exactly), and an impulse after it in the list, already applied, is not
    applied again (the applied ones are counted by their place in the list)."""
    world = tb.World(gravity=(0, 0, 0))
    body = world.add_body(tb.Sphere(0.1), mass=2.0)
    spring = world.add_force(tb.Spring(body_a=0, anchor_b=(1.0, 0, 0), stiffness=50.0, rest_length=0.0))
    world.add_force(tb.Impulse(body=0, impulse=(0, 0.4, 0), time=0.0))
    sim = tb.Simulator(world, dt=1 / 240)
    sim.step(24)
    assert world.applied_impulses == {1}
    world.remove_force(spring)
    assert world.applied_impulses == {0} and len(world.forces) == 1
    v = body.v.copy()
    x = body.x.copy()
    sim.step(24)
    np.testing.assert_array_equal(body.v, v)  # no force left, the impulse not applied twice
    np.testing.assert_allclose(body.x, x + 0.1 * v, rtol=0, atol=1e-15)
    with pytest.raises(tb.InputError, match="cannot be removed"):
        world.remove_force(world.forces[0])
    with pytest.raises(tb.InputError, match="not a force of this world"):
        world.remove_force(spring)


def test_forces_changed_makes_a_moved_anchor_act():
    """A spring's world anchor moved in place acts from the next step once ``forces_changed`` is
    said: the force on a body at rest at the old anchor is stiffness * (new anchor - x)."""
    world = tb.World(gravity=(0, 0, 0))
    body = world.add_body(tb.Sphere(0.1), mass=1.0)
    spring = world.add_force(tb.Spring(body_a=0, anchor_b=(0, 0, 0), stiffness=10.0, rest_length=0.0))
    sim = tb.Simulator(world, dt=1 / 240, integrator="semi-implicit-euler")
    sim.step(1)
    assert np.all(body.v == 0)
    spring.anchor_b = (0.5, 0.0, 0.0)
    world.forces_changed()
    sim.step(1)
    np.testing.assert_allclose(body.v, [10.0 * 0.5 / 240, 0, 0], rtol=1e-12)


# ---------------------------------------------------------------------- fluid (MuJoCo's inertia-box model)

FLUID_BODY = """<mujoco><option density="1.2" viscosity="0.3" wind="0.4 -0.2 0.1" gravity="0 0 0"/>
<worldbody><body name="b" pos="0 0 1"><freejoint/>
<geom type="box" size="0.3 0.1 0.05" pos="0.1 0.2 0" euler="10 20 30" density="500"/>
<geom type="sphere" size="0.1" pos="-0.2 0 0.1" density="800"/>
</body></worldbody></mujoco>"""


def test_fluid_force_equals_mujocos_on_a_free_body():
    """``tb.Fluid`` on a body of two geoms (a tilted box and a sphere: no symmetry, its inertial frame
    turned from its geoms'), at random poses and velocities in a wind, against MuJoCo's own
    ``qfrc_passive`` (the free joint's force, world, and torque about the body's origin, local) with
    MuJoCo's mass, inertia and inertial frame: 1e-12 relative (rounding; measured 3e-15 absolute on
    forces of order 1). The same record through ``tumble.reference.fluid_force`` (written with
    matrices) gives the same to 1e-12."""
    mujoco = pytest.importorskip("mujoco")
    from tumble import reference

    m = mujoco.MjModel.from_xml_string(FLUID_BODY)
    d = mujoco.MjData(m)
    frame = np.zeros(9)
    mujoco.mju_quat2Mat(frame, m.body_iquat[1])
    frame = frame.reshape(3, 3)
    I_body = frame @ np.diag(m.body_inertia[1]) @ frame.T
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        d.qpos[:] = [*rng.normal(size=3), *q]
        d.qvel[:] = rng.normal(size=6) * 2
        mujoco.mj_forward(m, d)
        R = d.xmat[1].reshape(3, 3)
        arm = d.xipos[1] - d.xpos[1]
        force = d.qfrc_passive[:3]
        torque = R @ d.qfrc_passive[3:] - np.cross(arm, force)  # about the centre of mass, world
        omega = R @ d.qvel[3:]
        v = d.qvel[:3] + np.cross(omega, arm)
        world = tb.World(gravity=(0, 0, 0))
        body = world.add_body(tb.Sphere(0.1), mass=m.body_mass[1], inertia=I_body, position=d.xipos[1], orientation=q)
        body.P = m.body_mass[1] * v
        body.L = R @ I_body @ R.T @ omega
        fluid = world.add_force(tb.Fluid(density=1.2, viscosity=0.3, wind=(0.4, -0.2, 0.1), bodies=[body],
                                         frames=[frame]))
        dY = world.dxdt(0.0, world.state()).reshape(1, -1)
        scale = max(np.abs(force).max(), np.abs(torque).max())
        np.testing.assert_allclose(dY[0, 7:10], force, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(dY[0, 10:13], torque, rtol=0, atol=1e-12 * scale)
        ref_body = reference.RigidBody(mass=m.body_mass[1], Ibody=I_body, x=d.xipos[1], R=R, P=body.P, L=body.L)
        F, T = reference.fluid_force(fluid, ref_body, frame)
        np.testing.assert_allclose(F, force, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(T, torque, rtol=0, atol=1e-12 * scale)


def test_fluid_without_frames_takes_the_principal_axes():
    """Without ``frames`` each box lies along its body's principal axes: a box body turned in its own
    frame (its inertia tensor full there) meets the same force as the same box with its frame along
    its edges, at the same world motion (to 1e-12: the boxes' sides, the axes' signs and order may
    differ, the force may not)."""
    rng = np.random.default_rng(5)
    turn = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    turn *= np.sign(np.linalg.det(turn))
    size = np.array([0.6, 0.3, 0.2])
    m = 2.0
    I_edges = m / 12 * np.diag([size[1] ** 2 + size[2] ** 2, size[0] ** 2 + size[2] ** 2, size[0] ** 2 + size[1] ** 2])
    forces = []
    for inertia, R in ((I_edges, np.eye(3)), (turn @ I_edges @ turn.T, turn.T)):
        world = tb.World(gravity=(0, 0, 0))
        # body frame R: the box's edges are the world axes in both worlds
        body = world.add_body(tb.Sphere(0.1), mass=m, inertia=inertia, orientation=tb.math3d.matrix_to_quat(R))
        body.P = m * np.array([0.3, -1.2, 0.7])
        body.L = body.R @ inertia @ body.R.T @ np.array([1.5, 0.4, -2.0])
        world.add_force(tb.Fluid(density=1000.0, viscosity=0.01))
        forces.append(world.dxdt(0.0, world.state())[7:13])
    np.testing.assert_allclose(forces[1], forces[0], rtol=1e-12, atol=1e-12)


def test_fluid_sphere_falls_at_its_terminal_speed():
    """A sphere falling through the fluid: its box is a cube of side r sqrt(12/5) (b, from I = 2/5 m
    r^2), so it falls at the speed where m g = 3 pi beta b v + 1/2 rho b^2 v^2 (the Stokes and the
    quadratic terms; the root of that quadratic). After 40 of its time constants (v_t / g) the
    engine's speed (RK4 at 1/240 s) is that root to 1e-9 relative."""
    m, r, rho, beta, g = 0.5, 0.05, 1000.0, 0.5, 9.81
    b = r * math.sqrt(12 / 5)
    lin, quad = 3 * math.pi * beta * b, 0.5 * rho * b * b
    vt = (-lin + math.sqrt(lin * lin + 4 * quad * m * g)) / (2 * quad)
    w, body = sphere_world(mass=m, radius=r, gravity=(0, 0, -g))
    w.add_force(tb.Fluid(density=rho, viscosity=beta))
    duration = math.ceil(40 * vt / g * 240) / 240
    traj = simulate(w, duration)
    assert -traj.velocity[-1, 0, 2] == pytest.approx(vt, rel=1e-9)
    assert np.all(traj.velocity[:, 0, :2] == 0.0)


@pytest.mark.parametrize("kwargs, message", [
    ({"density": -1.0}, "density: must be a finite number >= 0, got -1.0"),
    ({"viscosity": float("nan")}, "viscosity: must be a finite number >= 0, got nan"),
    ({"wind": (0, 1)}, "wind:"),
    ({"frames": [np.eye(3)]}, "frames: frames need the bodies they belong to"),
    ({"bodies": [0], "frames": [2 * np.eye(3)]}, r"frames\[0\]: expected a 3x3 rotation"),
    ({"bodies": [0, 1], "frames": [np.eye(3)]}, "frames: 1 frames for 2 bodies"),
])
def test_fluid_bad_input_is_one_line(kwargs, message):
    with pytest.raises(tb.InputError, match=message):
        tb.Fluid(**kwargs)


def test_fluid_is_kept_by_checkpoints_and_read_from_scene_files(tmp_path):
    """A fluid in a scene file (``type = "fluid"``) acts as the record does, and a checkpoint of the
    world carries it: the resumed run keeps the straight run's bits."""
    scene = tmp_path / "s.toml"
    scene.write_text('[simulation]\nduration = 1.0\ngravity = [0, 0, -9.81]\n[[bodies]]\nname = "ball"\n'
                     'shape = { type = "sphere", radius = 0.05 }\nmass = 0.5\nvelocity = [1, 0, 0]\n[[forces]]\n'
                     'type = "fluid"\ndensity = 1000\nviscosity = 0.5\nwind = [0, 0.5, 0]\n')
    sim = tb.load_scene(scene).simulator()
    fluid = sim.world.forces[0]
    assert isinstance(fluid, tb.Fluid) and fluid.density == 1000 and fluid.wind == (0, 0.5, 0)
    sim.step(24)
    sim.save_checkpoint(tmp_path / "c.npz")
    sim.step(24)
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    resumed.step(24)
    np.testing.assert_array_equal(resumed.world.state(), sim.world.state())
    assert sim.world.body("ball").v[1] > 0  # the wind carries it along y


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), given_frames=st.booleans())
def test_fluid_engine_and_reference_agree_on_random_bodies(seed, given_frames):
    """Property: for random boxes (sides 0.05-2 m, 0.1-10 kg, turned in their body frame), poses,
    velocities, winds, densities and viscosities, with frames given or taken from the inertia, the
    compiled force (``body_motion._fluid_force``, through ``World.dxdt``) equals
    ``reference.fluid_force`` (written with matrices) to 1e-11 of its size: the same formula,
    rounding apart."""
    from tumble import reference

    rng = np.random.default_rng(seed)
    size, m = rng.uniform(0.05, 2.0, 3), rng.uniform(0.1, 10.0)
    turn = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    turn *= np.sign(np.linalg.det(turn))
    I_edges = m / 12 * np.diag([size[1] ** 2 + size[2] ** 2, size[0] ** 2 + size[2] ** 2, size[0] ** 2 + size[1] ** 2])
    inertia = turn @ I_edges @ turn.T
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    world = tb.World(gravity=(0, 0, 0))
    body = world.add_body(tb.Sphere(0.1), mass=m, inertia=inertia, orientation=q)
    body.P = m * rng.normal(size=3) * 3
    body.L = rng.normal(size=3) * m
    frames = [turn] if given_frames else None
    fluid = world.add_force(tb.Fluid(density=rng.uniform(0, 2000), viscosity=rng.uniform(0, 1),
                                     wind=tuple(rng.normal(size=3)), bodies=[body], frames=frames))
    dY = world.dxdt(0.0, world.state())
    ref_body = reference.RigidBody(mass=m, Ibody=inertia, x=body.x, R=body.R, P=body.P, L=body.L)
    F, T = reference.fluid_force(fluid, ref_body, turn if given_frames else None)
    scale = max(np.abs(F).max(), np.abs(T).max(), 1e-300)
    np.testing.assert_allclose(dY[7:10], F, rtol=0, atol=1e-11 * scale)
    np.testing.assert_allclose(dY[10:13], T, rtol=0, atol=1e-11 * scale)
