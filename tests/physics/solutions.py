"""Independent high-accuracy solutions shared by the physics tests."""

import numpy as np
from scipy.integrate import solve_ivp


def euler_top_dop853(I_body_diag, omega0_body, duration, t_eval=None, rtol=1e-12, atol=1e-14):
    """Torque-free rigid body, written independently of tumble: Euler's equations
    I dw/dt = (I w) x w in the principal body frame, with the orientation quaternion
    dq/dt = 1/2 q (0, w_body), integrated by SciPy's DOP853 at tight tolerance.

    Returns (t (F,), q (F, 4) w-first body->world, omega_body (F, 3)).
    """
    I = np.asarray(I_body_diag, dtype=float)

    def f(t, y):
        w = y[:3]
        q = y[3:]
        dw = np.cross(I * w, w) / I
        qw, qx, qy, qz = q
        wx, wy, wz = w
        dq = 0.5 * np.array([
            -qx * wx - qy * wy - qz * wz,
            qw * wx + qy * wz - qz * wy,
            qw * wy - qx * wz + qz * wx,
            qw * wz + qx * wy - qy * wx,
        ])
        return np.concatenate([dw, dq])

    y0 = np.concatenate([omega0_body, [1.0, 0.0, 0.0, 0.0]])
    sol = solve_ivp(f, (0.0, duration), y0, method="DOP853", rtol=rtol, atol=atol, t_eval=t_eval)
    assert sol.success
    q = sol.y[3:].T
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return sol.t, q, sol.y[:3].T


def rotation_angle_between(q1, q2):
    """Angle (rad) of the rotation taking q1 to q2 ((..., 4) w-first).

    From the relative quaternion d = conj(q1) q2 as 2 atan2(|d_xyz|, |d_w|): unlike
    arccos(|q1.q2|), this keeps full precision for tiny angles.
    """
    q1 = np.asarray(q1, dtype=float)
    q2 = np.asarray(q2, dtype=float)
    w1, v1 = q1[..., :1], q1[..., 1:]
    w2, v2 = q2[..., :1], q2[..., 1:]
    dw = w1 * w2 + np.sum(v1 * v2, axis=-1, keepdims=True)
    dv = w1 * v2 - w2 * v1 - np.cross(v1, v2)
    return 2.0 * np.arctan2(np.linalg.norm(dv, axis=-1), np.abs(dw[..., 0]))


def assert_dragged_to_belt_speed(traj, index, mu, u, g, slide_atol, ride_atol, ride_from=0.5):
    """Coulomb's law for a box dropped at rest on a belt whose surface moves at u along x: while it
    slides (t < 0.9 t*, t* = u / (mu g)) it speeds up at mu g, v = mu g t (within ``slide_atol``
    m/s); from ``ride_from`` s it moves at (u, 0, 0) (within ``ride_atol``). ``traj`` a Trajectory,
    ``index`` the box's column."""
    t = traj.time
    sliding = t < 0.9 * u / (mu * g)
    np.testing.assert_allclose(traj.velocity[sliding, index, 0], mu * g * t[sliding], rtol=0, atol=slide_atol)
    riding = t > ride_from
    np.testing.assert_allclose(traj.velocity[riding, index], np.broadcast_to((u, 0.0, 0.0), (riding.sum(), 3)),
                               rtol=0, atol=ride_atol)


def resumed_run(make_world, tmp_path, duration, dt, **simulator):
    """Run ``make_world()`` for ``duration`` s in one go, and another ``make_world()`` for half
    of it, saved to a checkpoint, loaded and run for the other half. Returns (whole, resumed):
    the two Simulators, for the caller to compare (``checks.state_hash`` of their worlds: bit for
    bit) and to look into what the checkpoint carried."""
    import tumble as tb

    whole = tb.Simulator(make_world(), dt=dt, **simulator)
    whole.run(duration, frame_rate=24)
    first = tb.Simulator(make_world(), dt=dt, **simulator)
    first.run(duration / 2, frame_rate=24)
    first.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    resumed.run(duration / 2, frame_rate=24)
    return whole, resumed


def planar_chain_dop853(pieces, joint_origins, theta0, duration, t_eval, g=9.81, damping=None, armature=None):
    """A chain of hinges about the world y axis, written independently of tumble: Lagrange's
    equations M(q) q'' = tau - C(q, q'), integrated by SciPy's DOP853 at rtol 1e-12.

    Joint 0 sits at ``joint_origins[0]`` = (x, z) world; joint k > 0 at ``joint_origins[k]`` in
    link k-1's frame; link k turns by phi_k = q_0 + ... + q_k about +y (x, z) -> (x cos + z sin,
    -x sin + z cos). ``pieces``: (link k, mass kg, centre (x, z) m in link k's frame, I_yy kg m^2
    about the centre). A piece's centre velocity is J q' with column i <= k the geometric
    Jacobian e_y x (p - joint_i) = (dz, -dx); its spin is the sum of q'_i, i <= k. So M =
    sum m J^T J + I_yy a a^T (+ diag(``armature``): MuJoCo's joint armature, a constant inertia
    on each coordinate); gravity tau_i = -m g dz/dq_i; viscous joint damping -c_i q'_i.
    The Coriolis terms C_k = sum_ij (dM_kj/dq_i - dM_ij/dq_k / 2) q'_i q'_j take dM/dq by
    central differences (step 1e-6: error ~1e-12 relative, far below what the tests compare).

    Returns (t (F,), q (F, n)).
    """
    n = len(joint_origins)
    damping = np.zeros(n) if damping is None else np.asarray(damping, dtype=float)

    def rot(phi, v):
        c, s = np.cos(phi), np.sin(phi)
        return np.array([v[0] * c + v[1] * s, -v[0] * s + v[1] * c])

    def kinematics(q):
        phi = np.cumsum(q)
        joints = [np.asarray(joint_origins[0], dtype=float)]
        for k in range(1, n):
            joints.append(joints[k - 1] + rot(phi[k - 1], joint_origins[k]))
        rows = []
        for k, m, c, Iyy in pieces:
            p = joints[k] + rot(phi[k], c)
            J = np.zeros((2, n))
            for i in range(k + 1):
                d = p - joints[i]
                J[:, i] = (d[1], -d[0])
            a = np.array([1.0 if i <= k else 0.0 for i in range(n)])
            rows.append((m, J, a, Iyy))
        return rows

    extra = np.zeros((n, n)) if armature is None else np.diag(np.asarray(armature, dtype=float))

    def mass_matrix(q):
        return extra + sum(m * J.T @ J + Iyy * np.outer(a, a) for m, J, a, Iyy in kinematics(q))

    def f(t, y):
        q, qd = y[:n], y[n:]
        M = mass_matrix(q)
        dM = np.empty((n, n, n))
        for i in range(n):
            e = np.zeros(n)
            e[i] = 1e-6
            dM[i] = (mass_matrix(q + e) - mass_matrix(q - e)) / 2e-6
        C = np.array([qd @ dM[:, k, :] @ qd - 0.5 * qd @ dM[k] @ qd for k in range(n)])
        tau = -sum(m * g * J[1] for m, J, a, Iyy in kinematics(q)) - damping * qd
        return np.concatenate([qd, np.linalg.solve(M, tau - C)])

    sol = solve_ivp(f, (0.0, duration), np.concatenate([theta0, np.zeros(n)]), method="DOP853",
                    rtol=1e-12, atol=1e-12, t_eval=t_eval)
    assert sol.success
    return sol.t, sol.y[:n].T
