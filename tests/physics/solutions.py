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
