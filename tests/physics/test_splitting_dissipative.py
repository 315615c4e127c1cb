"""The splitting integrators' orders under forces that read the velocities (drag, damping, a
damped spring, a user's force): 2 for ``splitting``, 4 for ``splitting4``, as docs/integrators.md
says of them.

Compared with closed forms: a body under linear drag c slows as v0 exp(-c t / m); a spinning
sphere under angular damping c_a (tau = -c_a L) as omega0 exp(-c_a t); two bodies joined by a
damped spring along x move apart as an underdamped oscillator of the reduced mass. Each runs in
one of the step's three code paths: one body's registers (``integrators._step_splitting``), all
bodies together (``_split_step``, a spring couples them) and the Python stages (a
``CustomForce``). Before session 42 both splittings measured order 1 in all three (the closing
half-kick took the forces of its starting momenta, an explicit kick, so the step was not
symmetric; found by a course audit). Orders are log2 of successive error ratios over a halving
dt, within 0.25 of the theory (as tests/physics/test_free_rigid_body.py's), at steps in the
asymptotic range and with errors far above rounding (1e-12 and more).
"""

import math

import numpy as np
import pytest

import tumble as tb

ORDERS = [("splitting", 2, [1 / 60, 1 / 120, 1 / 240]), ("splitting4", 4, [1 / 30, 1 / 60, 1 / 120])]
T_END = 1.0


def measured_orders(errors):
    return np.log2(np.array(errors[:-1]) / np.array(errors[1:]))


def drag_error(integrator, dt, custom=False):
    """|v(1) - v0 exp(-c / m)| for a ball of m = 1.5 kg at v0 = 1 m/s under linear drag c = 2
    N s/m, as ``tb.Drag`` or as a Python ``CustomForce`` (the Python stages' path)."""
    m, c, v0 = 1.5, 2.0, 1.0
    w = tb.World(gravity=(0, 0, 0))
    ball = w.add_body(tb.Sphere(0.1), mass=m, velocity=(v0, 0, 0))
    if custom:
        w.add_force(tb.CustomForce(lambda t, body: (-c * body.v, np.zeros(3)), bodies=[ball]))
    else:
        w.add_force(tb.Drag(linear=c))
    n = round(T_END / dt)
    tb.Simulator(w, dt=dt, integrator=integrator).step(n)
    w.update_derived()
    return abs(ball.v[0] - v0 * math.exp(-c * T_END / m))


@pytest.mark.parametrize("integrator, order, dts", ORDERS)
@pytest.mark.parametrize("custom", [False, True], ids=["drag", "python-force"])
def test_splittings_keep_their_order_under_linear_drag(integrator, order, dts, custom):
    errors = [drag_error(integrator, dt, custom) for dt in dts]
    assert np.all(np.abs(measured_orders(errors) - order) < 0.25), errors


def damping_error(integrator, dt):
    """|omega(1) - omega0 exp(-c_a)| of a ball spinning at 5 rad/s about a tilted axis under
    angular damping c_a = 1.5 /s (``body.angular_damping``, tau = -c_a L), with linear damping
    0.7 /s on its velocity (1, 2, 0) m/s: both rates, in one body's registers."""
    w = tb.World(gravity=(0, 0, 0))
    omega0 = 5.0 * np.array([0.6, 0.0, 0.8])
    ball = w.add_body(tb.Sphere(0.1), mass=1.0, velocity=(1, 2, 0), angular_velocity=omega0)
    ball.angular_damping = 1.5
    ball.linear_damping = 0.7
    tb.Simulator(w, dt=dt, integrator=integrator).step(round(T_END / dt))
    w.update_derived()
    return max(np.abs(ball.omega - omega0 * math.exp(-1.5 * T_END)).max(),
               np.abs(ball.v - np.array([1, 2, 0]) * math.exp(-0.7 * T_END)).max())


@pytest.mark.parametrize("integrator, order, dts", ORDERS)
def test_splittings_keep_their_order_under_body_damping(integrator, order, dts):
    errors = [damping_error(integrator, dt) for dt in dts]
    assert np.all(np.abs(measured_orders(errors) - order) < 0.25), errors


def spring_error(integrator, dt):
    """Two balls (1 and 3 kg) on the x axis joined at their centres by a spring (k = 40 N/m, c = 1.2
    N s/m, rest 1 m), started 1.3 m apart and at rest: their separation s obeys mu s'' = -k (s -
    1) - c s' with mu = 0.75 kg, an underdamped oscillator (closed form below). Error of s(1)."""
    m1, m2, k, c = 1.0, 3.0, 40.0, 1.2
    w = tb.World(gravity=(0, 0, 0))
    a = w.add_body(tb.Sphere(0.1), mass=m1, position=(0, 0, 0))
    b = w.add_body(tb.Sphere(0.1), mass=m2, position=(1.3, 0, 0))
    w.collisions = False
    w.add_force(tb.Spring(a, b, stiffness=k, damping=c, rest_length=1.0))
    tb.Simulator(w, dt=dt, integrator=integrator).step(round(T_END / dt))
    mu = m1 * m2 / (m1 + m2)
    zeta_w = c / (2 * mu)
    wd = math.sqrt(k / mu - zeta_w ** 2)
    s = 1.0 + 0.3 * math.exp(-zeta_w * T_END) * (math.cos(wd * T_END) + zeta_w / wd * math.sin(wd * T_END))
    return abs((b.x[0] - a.x[0]) - s)


@pytest.mark.parametrize("integrator, order, dts", ORDERS)
def test_splittings_keep_their_order_with_a_damped_spring_between_two_bodies(integrator, order, dts):
    errors = [spring_error(integrator, dt) for dt in dts]
    assert np.all(np.abs(measured_orders(errors) - order) < 0.25), errors


def test_a_stiff_damping_the_iteration_cannot_solve_keeps_the_explicit_kick():
    """Where the closing kick's fixed-point iteration does not contract (h c / 2m = 1.5 > 1: a
    rate of 720 /s at dt 1/240), the step keeps the explicit kick, as before: the ball's speed
    after one step is the explicit splitting's (1 - h c / 2)^2 v0 to 1e-15, finite."""
    w = tb.World(gravity=(0, 0, 0))
    ball = w.add_body(tb.Sphere(0.1), mass=1.0, velocity=(1, 0, 0))
    ball.linear_damping = 720.0
    tb.Simulator(w, dt=1 / 240, integrator="splitting").step(1)
    w.update_derived()
    assert ball.v[0] == pytest.approx((1 - 1.5) ** 2, abs=1e-15)
