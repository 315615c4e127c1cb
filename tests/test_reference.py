"""Tests for tumble/reference.py: the course's algorithm, each ERRATA item, and analytic motions.

Tolerances: "exact" means bit-for-bit (array_equal) where the same floating
operations are done on both sides; otherwise each test says which rounding
or discretisation error it allows, and why.
"""

import math

import numpy as np
import pytest

from tumble import reference as ref
from tumble.forces import ConstantForce, CustomForce, Drag, Impulse, PointForce, Spring

G = np.array([0.0, 0.0, -9.81])
EPS = np.finfo(float).eps


def random_rotation(rng):
    """A random rotation matrix (QR of a Gaussian matrix, det +1)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def box_inertia(mass, size):
    """Ibody (3, 3) of a solid box of full side lengths size (closed form)."""
    a, b, c = size
    return mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])


def spinning_box(omega=(2.0, 1.0, 3.0), mass=2.0, size=(0.2, 0.6, 1.0), R=None, x=(0.0, 0.0, 1.0), P=(0.0, 0.0, 0.0), name="box"):
    """A box body with angular velocity omega (world): L = I omega, I = R Ibody R^T."""
    Ibody = box_inertia(mass, size)
    R = np.eye(3) if R is None else R
    L = R @ Ibody @ R.T @ np.asarray(omega, dtype=float)
    return ref.RigidBody(mass=mass, Ibody=Ibody, x=x, R=R, P=P, L=L, name=name)


def random_body(rng, name=""):
    """A body with random mass, positive-definite inertia and random state."""
    A = rng.normal(size=(3, 3))
    Ibody = A @ A.T + 0.5 * np.eye(3)
    return ref.RigidBody(mass=rng.uniform(0.5, 3.0), Ibody=Ibody, x=rng.normal(size=3), R=random_rotation(rng),
                         P=rng.normal(size=3), L=rng.normal(size=3), name=name)


# --------------------------------------------------------------------------- ERRATA 1


def test_errata1_star_is_the_cross_product():
    # Compared with np.cross. Both compute the same three a_i b_j - a_k b_l per
    # component, but the matrix product adds an exact 0 * b term and BLAS may
    # fuse multiply-adds, so allow a few ulps of the operands' scale (1e-15 x |w||a|).
    rng = np.random.default_rng(1)
    for _ in range(100):
        w, a = rng.normal(size=3), rng.normal(size=3)
        scale = np.linalg.norm(w) * np.linalg.norm(a)
        np.testing.assert_allclose(ref.star(w) @ a, np.cross(w, a), rtol=0, atol=1e-15 * max(scale, 1.0))
        assert np.array_equal(ref.star(w), -ref.star(w).T)  # skew-symmetric


def test_errata1_slide_matrix_is_not_a_cross_product():
    # The slide's matrix is symmetric; a cross product matrix is skew, and
    # (S w) . w = w x w . w = 0 would hold for a cross product. Show both fail.
    w = np.array([0.3, -1.2, 2.0])
    wx, wy, wz = w
    slide = np.array([[0, -wz, -wy], [-wz, 0, -wx], [-wy, -wx, 0]])
    assert np.array_equal(slide, slide.T)
    a = np.array([1.0, 2.0, 3.0])
    assert not np.allclose(slide @ a, np.cross(w, a))
    assert not np.allclose(slide @ a, -np.cross(w, a))  # nor "-(w x)" as the slide says
    assert abs((slide @ w) @ w) > 1.0  # a cross product would give w . (w x w) = 0


# --------------------------------------------------------------------------- ERRATA 2


def test_errata2_outer_product_has_positive_off_diagonals():
    # r r^T has entries r_i r_j: for a vector with positive components every entry is positive.
    r = np.array([1.0, 2.0, 3.0])
    outer = np.outer(r, r)
    assert np.all(outer > 0)
    assert outer[0, 1] == r[0] * r[1]


def test_errata2_particle_inertia_matches_component_formula():
    # Compared with the slide's component formula (Ixx = sum m (y^2 + z^2),
    # Ixy = -sum m x y, ...). Same products summed in a different grouping:
    # rounding of a few ulps of sum m |r|^2, so 1e-13 relative.
    rng = np.random.default_rng(2)
    masses = rng.uniform(0.1, 2.0, size=20)
    points = rng.normal(size=(20, 3)) + np.array([1.0, -2.0, 0.5])
    M, center, Ibody = ref.body_from_particles(masses, points)
    assert M == pytest.approx(masses.sum(), rel=1e-15)
    np.testing.assert_allclose(center, (masses[:, None] * points).sum(0) / masses.sum(), rtol=1e-14)
    r = points - center
    x, y, z = r[:, 0], r[:, 1], r[:, 2]
    expected = np.array([
        [np.sum(masses * (y * y + z * z)), -np.sum(masses * x * y), -np.sum(masses * x * z)],
        [-np.sum(masses * y * x), np.sum(masses * (x * x + z * z)), -np.sum(masses * y * z)],
        [-np.sum(masses * z * x), -np.sum(masses * z * y), np.sum(masses * (x * x + y * y))],
    ])
    np.testing.assert_allclose(Ibody, expected, rtol=0, atol=1e-13 * np.abs(expected).max())
    # Two unit masses on the diagonal x = y: the product of inertia Ixy is negative.
    _, _, I2 = ref.body_from_particles([1.0, 1.0], [[1.0, 1.0, 0.0], [-1.0, -1.0, 0.0]])
    assert I2[0, 1] == -2.0 and I2[0, 0] == 2.0 and I2[2, 2] == 4.0


# --------------------------------------------------------------------------- ERRATA 3


def test_errata3_one_solve_per_frame():
    # Compared with the corrected Algorithm 5 written out by hand: one solve per
    # frame from k/24 to (k+1)/24. Forces here do not depend on t, so the same
    # Euler arithmetic runs on both sides: exact equality.
    bodies = [spinning_box(P=(0.4, 0.0, 1.0)), random_body(np.random.default_rng(3), "other")]
    forces = [Drag(linear=0.1, angular_linear=0.05, wind=(1.0, 0.0, 0.0))]
    dt = 1.0 / 240.0
    start = ref.bodies_to_array(bodies)
    times, states = ref.run_simulation(bodies, forces, G, duration=1.0, dt=dt, frame_rate=24)
    assert times.shape == (25,) and states.shape == (25, 36)
    assert np.array_equal(times, np.arange(25) / 24)
    assert np.array_equal(states[0], start)

    copies = [ref.RigidBody(mass=b.mass, Ibody=b.Ibody, Ibodyinv=b.Ibodyinv, name=b.name) for b in bodies]
    y = start.copy()
    for k in range(24):
        x0 = y.copy()  # "copy xFinal back to x0": the whole state, once a frame
        y = ref.solve(x0, k / 24, (k + 1) / 24, lambda t, s: ref.dxdt(t, s, copies, forces, G), dt, bodies=copies)
        assert np.array_equal(states[k + 1], y), f"frame {k + 1}"
    # run_simulation leaves the bodies holding the last frame ("DisplayBodies").
    assert np.array_equal(ref.bodies_to_array(bodies), states[-1])


def test_run_simulation_rejects_dt_not_dividing_a_frame():
    with pytest.raises(ValueError):
        ref.run_simulation([spinning_box()], [], G, duration=1.0, dt=1.0 / 250.0, frame_rate=24)
    with pytest.raises(ValueError):
        ref.solve(np.zeros(18), 0.0, 0.1, lambda t, y: y, 0.03)


def test_impulse_applied_at_its_step():
    # Compared with applying P += J, L += (p - x) x J by hand before global step
    # k = ceil(time/dt): the same operations in the same order, so exact.
    dt = 0.01
    J = np.array([0.0, 1.0, 0.5])
    p = np.array([0.1, 0.0, 1.2])
    imp = Impulse(body="box", impulse=J, point=p, time=0.025)  # k = 3
    body = spinning_box()
    _, states = ref.run_simulation([body], [], G, duration=0.1, dt=dt, frame_rate=10, impulses=[imp])

    manual = [spinning_box()]
    y = ref.bodies_to_array(manual)
    for k in range(10):
        if k == 3:
            x = y[0:3].copy()
            y[12:15] = y[12:15] + J
            y[15:18] = y[15:18] + np.cross(p - x, J)
        y = ref.euler_step(y, k * dt, dt, lambda t, s: ref.dxdt(t, s, manual, [], G), True, manual)
    assert np.array_equal(states[1], y)


# --------------------------------------------------------------------------- ERRATA 4


@pytest.mark.parametrize("frame", ["world", "body"])
def test_errata4_dL_dt_is_torque(frame):
    # Compared with tau = (p - x) x F. One Euler step of h: L1 = L0 + h tau, so
    # (L1 - L0)/h = tau up to the rounding of L0 + h tau, about eps |L0| / h
    # = 2e-16 * 1 / 1e-6 = 2e-10 relative to |tau| ~ 1: tolerance 1e-9.
    body = spinning_box(omega=(0.5, -0.2, 0.1))
    F = np.array([0.0, 3.0, -1.0])
    point = np.array([0.1, -0.2, 0.4])
    forces = [PointForce(body=0, force=F, point=point, frame=frame)]
    h = 1e-6
    y0 = ref.bodies_to_array([body])
    p = point if frame == "world" else body.R @ point + body.x
    tau = np.cross(p - body.x, F)
    y1 = ref.solve(y0, 0.0, h, lambda t, s: ref.dxdt(t, s, [body], forces, np.zeros(3)), h)
    np.testing.assert_allclose((y1[15:18] - y0[15:18]) / h, tau, rtol=0, atol=1e-9)
    np.testing.assert_allclose((y1[12:15] - y0[12:15]) / h, F, rtol=0, atol=1e-9)  # dP/dt = F


# --------------------------------------------------------------------------- ERRATA 5


def test_errata5_R_drifts_without_orthonormalisation():
    # Compared with R^T R = 1. Explicit Euler on dR/dt = w* R multiplies the
    # column norms by sqrt(1 + h^2 |w|^2) a step: with |w| = 3.7 rad/s and
    # h = 1/240 that is ~2e-4 a step; after 2400 steps the error is ~0.5, far above 1e-3.
    # Gram-Schmidt makes columns orthonormal to a few ulps each step: 1e-12.
    h, steps = 1.0 / 240.0, 2400
    for flag, check in ((False, lambda e: e > 1e-3), (True, lambda e: e < 1e-12)):
        body = spinning_box()
        y0 = ref.bodies_to_array([body])
        y = ref.solve(y0, 0.0, steps * h, lambda t, s: ref.dxdt(t, s, [body], [], np.zeros(3)), h, orthonormalize_R=flag)
        R = y[3:12].reshape(3, 3)
        err = np.abs(R.T @ R - np.eye(3)).max()
        assert check(err), (flag, err)
        assert np.linalg.det(R) > 0


def test_orthonormalize_matches_math3d():
    # Compared with the engine's kernel, which the reference mirrors operation
    # for operation (same Gram-Schmidt order): exact equality.
    from tumble.math3d import orthonormalize_inplace

    rng = np.random.default_rng(5)
    for _ in range(20):
        R = random_rotation(rng) + 0.05 * rng.normal(size=(3, 3))
        kernel = R.copy()
        orthonormalize_inplace(kernel)
        assert np.array_equal(ref.orthonormalize(R), kernel)


def test_quaternion_property_matches_math3d():
    # Compared with the engine's Shepperd kernel: same arithmetic, exact.
    from tumble.math3d import matrix_to_quat

    rng = np.random.default_rng(6)
    for _ in range(20):
        body = random_body(rng)
        assert np.array_equal(body.q, matrix_to_quat(body.R))
        assert body.q[0] >= 0


# --------------------------------------------------------------------------- ERRATA 6


def test_errata6_state_layout_and_round_trip():
    # Compared with the layout the course defines: pure copies, so exact.
    assert ref.STATE_SIZE == 18
    rng = np.random.default_rng(7)
    bodies = [random_body(rng, f"b{i}") for i in range(3)]
    y = ref.bodies_to_array(bodies)
    assert y.shape == (18 * 3,)
    for i, b in enumerate(bodies):
        block = y[18 * i:18 * (i + 1)]
        assert np.array_equal(block[0:3], b.x)
        assert np.array_equal(block[3:12], [b.R[0, 0], b.R[0, 1], b.R[0, 2], b.R[1, 0], b.R[1, 1], b.R[1, 2],
                                             b.R[2, 0], b.R[2, 1], b.R[2, 2]])  # row-major
        assert np.array_equal(block[12:15], b.P)
        assert np.array_equal(block[15:18], b.L)
    others = [ref.RigidBody(mass=b.mass, Ibody=b.Ibody) for b in bodies]
    ref.array_to_bodies(y, others)
    assert np.array_equal(ref.bodies_to_array(others), y)
    for b, o in zip(bodies, others):
        # derived quantities recomputed from the copied state: same operations, exact
        assert np.array_equal(o.v, b.P / b.mass)
        assert np.array_equal(o.Iinv, b.R @ b.Ibodyinv @ b.R.T)
        assert np.array_equal(o.omega, o.Iinv @ b.L)


def test_derivative_layout():
    # Compared with (v, star(omega) R, F, tau) computed by hand from the bodies'
    # quantities: the same operations, so exact.
    rng = np.random.default_rng(8)
    bodies = [random_body(rng, f"b{i}") for i in range(4)]
    forces = [ConstantForce(body=1, force=(1.0, 2.0, 3.0), torque=(0.1, 0.0, -0.2)),
              Drag(linear=0.3, quadratic=0.1, angular_quadratic=0.2)]
    y = ref.bodies_to_array(bodies)
    ydot = ref.dxdt(0.0, y, bodies, forces, G)
    assert ydot.shape == (72,)
    for i, b in enumerate(bodies):
        block = ydot[18 * i:18 * (i + 1)]
        assert np.array_equal(block[0:3], b.P / b.mass)
        assert np.array_equal(block[3:12], (ref.star(b.omega) @ b.R).reshape(9))
        assert np.array_equal(block[12:15], b.force)
        assert np.array_equal(block[15:18], b.torque)
    # forces as the docstrings of tumble.forces write them (here summed by hand, 1e-13 scale)
    b = bodies[1]
    speed, spin = np.linalg.norm(b.v), np.linalg.norm(b.omega)
    F = b.mass * G + np.array([1.0, 2.0, 3.0]) - (0.3 + 0.1 * speed) * b.v
    tau = np.array([0.1, 0.0, -0.2]) - 0.2 * spin * b.omega
    np.testing.assert_allclose(b.force, F, rtol=0, atol=1e-13 * np.abs(F).max())
    np.testing.assert_allclose(b.torque, tau, rtol=0, atol=1e-13 * max(np.abs(tau).max(), 1.0))


def test_fixed_body_and_force_references():
    # A fixed body gets no force and a zero derivative; records may name bodies
    # by object, index or name; Impulse records are not forces. Exact.
    rng = np.random.default_rng(9)
    ground = ref.RigidBody(mass=1.0, Ibody=np.eye(3), x=(0, 0, -1), name="ground", fixed=True)
    a, b = random_body(rng, "a"), random_body(rng, "b")
    bodies = [ground, a, b]
    calls = []

    def custom(t, body):
        calls.append((t, body.name, body.q.shape))
        return (0.0, 0.0, 1.0), (0.0, 0.0, 0.0)

    forces = [ConstantForce(body=a, force=(1.0, 0.0, 0.0)), ConstantForce(body="b", force=(0.0, 1.0, 0.0)),
              ConstantForce(body=0, force=(5.0, 5.0, 5.0)), CustomForce(custom), Impulse(body=1, impulse=(9.0, 9.0, 9.0))]
    ydot = ref.dxdt(0.5, ref.bodies_to_array(bodies), bodies, forces, G)
    assert np.array_equal(ydot[0:18], np.zeros(18))
    assert np.array_equal(a.force, a.mass * G + np.array([1.0, 0.0, 0.0]) + np.array([0.0, 0.0, 1.0]))
    assert np.array_equal(b.force, b.mass * G + np.array([0.0, 1.0, 0.0]) + np.array([0.0, 0.0, 1.0]))
    assert calls == [(0.5, "a", (4,)), (0.5, "b", (4,))]
    with pytest.raises(ValueError):
        ref.dxdt(0.0, ref.bodies_to_array(bodies), bodies, [ConstantForce(body="nobody")], G)


# --------------------------------------------------------------------------- analytic motions


def test_free_fall_matches_euler_sum():
    # Compared with the closed form of explicit Euler from rest: v_k = k h g,
    # x_n = x0 + h sum_{k<n} v_k = x0 + g h^2 n (n - 1) / 2. Only rounding of
    # the running sums separates them (~n eps |z|): 1e-12 m.
    h, n = 1.0 / 240.0, 240
    body = spinning_box(omega=(0.0, 0.0, 0.0), x=(1.0, 2.0, 10.0))
    _, states = ref.run_simulation([body], [], G, duration=1.0, dt=h, frame_rate=24)
    x = states[-1][0:3]
    np.testing.assert_allclose(x, [1.0, 2.0, 10.0 - 9.81 * h * h * n * (n - 1) / 2], rtol=0, atol=1e-12)
    np.testing.assert_allclose(states[-1][12:15], body.mass * G * n * h, rtol=0, atol=1e-12)


def test_torque_free_L_is_constant():
    # Gravity acts at the centre of mass and no other force acts: tau = 0, so
    # L + h * 0 == L in floating point. Exact, for every frame.
    rng = np.random.default_rng(10)
    body = random_body(rng)
    L0 = body.L.copy()
    _, states = ref.run_simulation([body], [], G, duration=0.5, dt=1.0 / 240.0, frame_rate=24)
    assert np.all(states[:, 15:18] == L0)


def test_spring_period():
    # Compared with the harmonic period 2 pi sqrt(m/k) = 1 s. The motion stays
    # on the x axis, where the spring force is exactly linear in the stretch.
    # Explicit Euler turns each step into a rotation by atan(h w) (plus growth
    # sqrt(1 + h^2 w^2), which does not move zero crossings), so the period is
    # too long by (h w)^2 / 3 ~ 1e-5 with h = 1e-3 s; the crossing times are
    # interpolated linearly within a step (error << h). 1% is a wide margin.
    m, k, l0, h = 1.0, 4.0 * math.pi ** 2, 1.0, 1e-3
    body = ref.RigidBody(mass=m, Ibody=np.eye(3) * 0.1, x=(l0 + 0.1, 0.0, 0.0), name="bob")
    forces = [Spring(body_a="bob", anchor_a=(0, 0, 0), body_b=None, anchor_b=(0, 0, 0), stiffness=k, rest_length=l0)]
    times, states = ref.run_simulation([body], forces, np.zeros(3), duration=2.5, dt=h, frame_rate=1000)
    s = states[:, 0] - l0
    i = np.flatnonzero((s[:-1] > 0) & (s[1:] <= 0))  # downward zero crossings
    crossings = times[i] + h * s[i] / (s[i] - s[i + 1])
    assert len(crossings) >= 2
    period = np.diff(crossings).mean()
    assert period == pytest.approx(2 * math.pi * math.sqrt(m / k), rel=0.01)
    assert np.all(states[:, 1:3] == 0.0)  # stays on the axis


def test_spring_between_bodies_is_equal_and_opposite():
    # Newton's third law: F_b = -F_a exactly (negation is exact); the spring
    # potential is 1/2 k (l - l0)^2 (the same formula written by hand).
    rng = np.random.default_rng(11)
    a, b = random_body(rng, "a"), random_body(rng, "b")
    spring = Spring(body_a=a, body_b=b, anchor_a=(0.1, 0, 0), anchor_b=(0, 0.2, 0), stiffness=3.0, damping=0.5, rest_length=0.7)
    ref.dxdt(0.0, ref.bodies_to_array([a, b]), [a, b], [spring], np.zeros(3))
    assert np.array_equal(a.force, -b.force)
    d = (a.R @ [0.1, 0, 0] + a.x) - (b.R @ [0, 0.2, 0] + b.x)
    assert ref.potential_energy([a, b], [spring], np.zeros(3)) == pytest.approx(0.5 * 3.0 * (np.linalg.norm(d) - 0.7) ** 2, rel=1e-14)
    with pytest.raises(ValueError):
        ref.dxdt(0.0, ref.bodies_to_array([a, b]), [a, b], [Spring(body_a=a, stiffness=1.0)], np.zeros(3))


def test_energy_of_free_rigid_rotation():
    # 1/2 P.v + 1/2 L.omega equals 1/2 m |v|^2 + 1/2 omega^T I omega (the same
    # quantity written another way): rounding only, 1e-13 relative.
    body = spinning_box(P=(1.0, 2.0, 0.0))
    kinetic, potential = ref.energy([body], [], G)
    I = body.R @ body.Ibody @ body.R.T
    expected = 0.5 * body.mass * body.v @ body.v + 0.5 * body.omega @ I @ body.omega
    assert kinetic == pytest.approx(expected, rel=1e-13)
    assert potential == pytest.approx(body.mass * 9.81 * body.x[2], rel=1e-15)
