"""tumble.world: the SoA arrays, Body views, the course's state vector, re-centring, bad input."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import tumble as tb
from tumble.math3d import star


def test_body_is_a_view_onto_the_world_arrays():
    w = tb.World()
    box = w.add_body(tb.Box(size=(1, 2, 3)), mass=6.0, position=(1, 2, 3), velocity=(1, 0, 0))
    assert np.shares_memory(box.x, w.x)
    w.x[0, 2] = 7.0
    assert box.x[2] == 7.0
    box.v = (0.0, 2.0, 0.0)
    np.testing.assert_array_equal(w.P[0], [0.0, 12.0, 0.0])
    box.omega = (0.0, 0.0, 1.0)
    np.testing.assert_allclose(box.L, box.inertia_body @ [0, 0, 1], rtol=1e-15)
    np.testing.assert_allclose(box.omega, [0, 0, 1], atol=1e-15)
    # the views survive growth of the arrays (they are looked up, not kept)
    for i in range(20):
        w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(0, 0, i))
    assert box.x[2] == 7.0 and w.body_count == 21


@pytest.mark.parametrize("layout, size", [("matrix", 18), ("quaternion", 13)])
def test_state_vector_layout_and_round_trip(layout, size):
    # ERRATA 6: 18 numbers a body in the course's layout x, R (row-major), P, L; 13 with q.
    w = tb.World(layout=layout)
    w.add_body(tb.Box(size=(0.2, 0.6, 1.0)), mass=2.0, position=(1, 2, 3), euler_deg=(10, 20, 30), velocity=(1, 1, 0), angular_velocity=(2, 1, 3))
    w.add_body(tb.Sphere(radius=0.5), mass=1.0)
    X = w.state()
    assert X.shape == (2 * size,)
    np.testing.assert_array_equal(X[:3], w.x[0])
    if layout == "matrix":
        np.testing.assert_array_equal(X[3:12], w.R[0].ravel())
    else:
        np.testing.assert_array_equal(X[3:7], w.q[0])
    np.testing.assert_array_equal(X[size - 6:size - 3], w.P[0])
    np.testing.assert_array_equal(X[size - 3:size], w.L[0])
    w.set_state(X)
    np.testing.assert_array_equal(w.state(), X)


def test_matrix_layout_derivative_is_v_star_omega_R_F_tau_per_body():
    # The course's dX/dt = (v, omega* R, F, tau) (Algorithm 4), in its order, computed by hand here.
    w = tb.World(layout="matrix")
    a = w.add_body(tb.Box(size=(0.2, 0.6, 1.0)), mass=2.0, euler_deg=(10, 20, 30), velocity=(1, 2, 3), angular_velocity=(2, 1, 3))
    b = w.add_body(tb.Cylinder(radius=0.2, length=1.0), mass=3.0, position=(1, 0, 0), angular_velocity=(0, 4, 1))
    w.add_force(tb.Drag(linear=0.5, angular_linear=0.1))
    w.add_force(tb.PointForce(a, force=(0, 0, 5), point=(0.1, 0.2, 0.3), frame="body"))
    X = w.state()
    d = w.dxdt(0.0, X).reshape(2, 18)
    for i, body in enumerate((a, b)):
        v = body.P / body.mass
        I_inv = body.R @ body.inertia_body_inv @ body.R.T
        omega = I_inv @ body.L
        F = body.mass * w.gravity - 0.5 * v
        tau = -0.1 * omega
        if i == 0:
            F = F + [0, 0, 5]
            tau = tau + np.cross(body.R @ [0.1, 0.2, 0.3], [0, 0, 5])
        np.testing.assert_allclose(d[i, 0:3], v, rtol=1e-15)
        np.testing.assert_allclose(d[i, 3:12], (star(omega) @ body.R).ravel(), atol=1e-14)
        np.testing.assert_allclose(d[i, 12:15], F, atol=1e-14)
        np.testing.assert_allclose(d[i, 15:18], tau, atol=1e-14)


def test_dxdt_drives_solve_ivp():
    # world.dxdt is the course's state-vector interface: SciPy integrates it directly, and it
    # agrees with the engine's own DOP853 integrator (same equations, same tolerance).
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Box(size=(0.2, 0.6, 1.0)), mass=2.0, velocity=(1, 0, 5), angular_velocity=(2, 1, 3))
    X0 = w.state()
    sol = solve_ivp(w.dxdt, (0, 1.0), X0, method="DOP853", rtol=1e-12, atol=1e-12)
    tb.Simulator(w, integrator="dop853", rtol=1e-12, atol=1e-12).step(240)
    np.testing.assert_allclose(w.x[0], sol.y[:3, -1], atol=1e-10)
    np.testing.assert_allclose(w.x[0], [1.0, 0.0, 5.0 - 9.81 / 2], atol=1e-10)


def test_off_centre_shapes_are_recentred_and_keep_their_offset():
    w = tb.World()
    cone = w.add_body(tb.Cone(radius=0.5, height=2.0), mass=1.0, position=(1, 1, 1), euler_deg=(90, 0, 0))
    # the centre of mass is h/4 up the cone's axis, which the 90 degree roll turns to -y
    np.testing.assert_allclose(cone.com_offset, [0, 0, 0.5], atol=1e-15)
    np.testing.assert_allclose(cone.x, [1, 0.5, 1], atol=1e-15)
    pts = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2.0]])
    body = w.add_body(tb.Particles(points=pts, masses=[1, 1, 1, 1]), position=(0, 0, 0))
    np.testing.assert_allclose(body.x, [0.5, 0.5, 0.5])
    assert body.mass == 4.0
    r = pts - [0.5, 0.5, 0.5]
    I = sum(np.dot(ri, ri) * np.eye(3) - np.outer(ri, ri) for ri in r)  # the course's sum
    np.testing.assert_allclose(body.inertia_body, I, rtol=1e-15)


def test_fixed_bodies_never_move():
    w = tb.World()
    ground = w.add_body(tb.Plane(), fixed=True, name="ground")
    post = w.add_body(tb.Box(size=(1, 1, 1)), fixed=True, position=(0, 0, 3), name="post")
    ball = w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(0, 0, 10))
    w.add_force(tb.Spring(post, ball, stiffness=10.0))
    X0 = w.state()
    tb.Simulator(w, integrator="rk4").run(1.0)
    np.testing.assert_array_equal(w.x[:2], X0.reshape(3, 13)[:2, :3])
    assert ground.fixed and post.fixed and not ball.fixed
    assert ball.x[2] < 10.0


@pytest.mark.parametrize(
    "call, key, message",
    [
        (lambda w: w.add_body(tb.Sphere(radius=1), mass=-1.0), "mass", "must be positive"),
        (lambda w: w.add_body(tb.Sphere(radius=1), mass=1.0, orientation=(0, 0, 0, 0)), "orientation", "must not be zero"),
        (lambda w: w.add_body(tb.Plane(), mass=1.0), "fixed", "plane can only be a fixed body"),
        (lambda w: w.add_body(tb.Sphere(radius=1), mass=1.0, inertia=(1.0, -1.0, 1.0)), "inertia", "not positive definite"),
        (lambda w: w.add_body(tb.Sphere(radius=1), mass=1.0, inertia=(1.0, 1.0, 5.0)), "inertia", "triangle inequality"),
        (lambda w: w.add_body(tb.Sphere(radius=1), mass=1.0, position=(0, float("nan"), 0)), "position", "finite"),
        (lambda w: w.add_body(tb.Sphere(radius=1), mass=1.0, name="a") and w.add_body(tb.Sphere(radius=1), mass=1.0, name="a"), "name", "duplicate"),
        (lambda w: w.add_force(tb.ConstantForce("nobody", force=(1, 0, 0))), "body", "unknown body"),
        (lambda w: tb.Simulator(w, integrator="rk5"), "simulation.integrator", "unknown integrator"),
        (lambda w: tb.Box(size=(1, 0, 1)), "size[1]", "must be positive"),
    ],
)
def test_bad_input_raises_input_error_naming_the_key(call, key, message):
    w = tb.World()
    with pytest.raises(tb.InputError, match=message) as err:
        call(w)
    assert err.value.key == key
    assert "\n" not in str(err.value)
