"""tumble.simulator: the frame loop, substeps, impulses across runs, blow-up reporting."""

import numpy as np
import pytest

import tumble as tb


def test_second_run_continues_in_time_and_applies_an_impulse_once():
    # Regression: a new Simulator on a world that has already run must go on from world.t,
    # and an impulse must act once, however many runs the world goes through.
    w = tb.World(gravity=(0, 0, 0))
    ball = w.add_body(tb.Sphere(radius=0.1), mass=1.0)
    w.add_force(tb.Impulse(ball, impulse=(1.0, 0.0, 0.0), time=0.5))
    first = tb.Simulator(w).run(1.0)
    second = tb.Simulator(w).run(1.0)
    np.testing.assert_allclose(first.time[[0, -1]], [0.0, 1.0])
    np.testing.assert_allclose(second.time[[0, -1]], [1.0, 2.0])
    assert ball.v[0] == pytest.approx(1.0, abs=1e-15)
    # x = 1 m/s * (2 - 0.5) s
    assert ball.x[0] == pytest.approx(1.5, abs=1e-12)


def test_substeps_are_steps_of_dt_over_substeps():
    # Two substeps of dt/2 are the same arithmetic as steps of dt/2 (same kernel, same h).
    def world():
        w = tb.World(gravity=(0, 0, -9.81))
        w.add_body(tb.Box(size=(0.2, 0.6, 1.0)), mass=2.0, angular_velocity=(2, 1, 3))
        w.add_force(tb.Drag(linear=0.3, angular_quadratic=0.01))
        return w

    a, b = world(), world()
    tb.Simulator(a, dt=1 / 120, substeps=2, integrator="rk4").run(1.0)
    tb.Simulator(b, dt=1 / 240, integrator="rk4").run(1.0)
    assert np.array_equal(a.pack(), b.pack())


def test_frames_at_the_frame_rate_and_whole_steps_required():
    w = tb.World()
    w.add_body(tb.Sphere(radius=0.1), mass=1.0)
    traj = tb.Simulator(w, dt=1 / 240).run(2.0, frame_rate=24)
    assert traj.frame_count == 49
    np.testing.assert_allclose(np.diff(traj.time), 1 / 24, rtol=1e-12)
    with pytest.raises(tb.InputError, match="whole number of steps"):
        tb.Simulator(w, dt=1 / 100).run(1.0, frame_rate=24)
    with pytest.raises(tb.InputError, match="must be a positive finite number"):
        tb.Simulator(w).run(-1.0)


def test_trajectory_diagnostics_and_file_round_trip(tmp_path):
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Box(size=(0.2, 0.6, 1.0)), mass=2.0, position=(0, 0, 5), velocity=(1, 0, 0), angular_velocity=(2, 1, 3), name="box")
    traj = tb.Simulator(w, integrator="rk4").run(1.0)
    # energy: KE + PE conserved by RK4 under gravity to ~1e-10 relative
    E = traj.total_energy
    assert np.abs(E / E[0] - 1).max() < 1e-9
    assert traj.orthonormality_error.max() < 1e-15
    np.testing.assert_allclose(traj.total_linear_momentum[-1], [2.0, 0.0, -2.0 * 9.81], atol=1e-12)
    path = traj.save(tmp_path / "out" / "trajectory.npz")
    back = tb.load_trajectory(path)
    for key in ("time", "position", "orientation", "velocity", "angular_velocity", "linear_momentum", "angular_momentum", "kinetic_energy", "potential_energy"):
        np.testing.assert_array_equal(getattr(back, key), getattr(traj, key))
    assert list(back.names) == ["box"]
    assert back.shape(0) == tb.Box(size=(0.2, 0.6, 1.0))  # the file alone describes the bodies
    assert list(back.fixed) == [False]
    with np.load(path, allow_pickle=False) as data:  # DESIGN.md: loadable without pickles
        assert data["position"].shape == (25, 1, 3)
    assert not list(tmp_path.glob("out/.*tmp"))  # no temporary file left behind


def test_non_finite_state_stops_the_run_naming_the_body():
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, name="rocket")

    def explode(t, body):
        return (np.array([np.inf if t > 0.2 else 0.0, 0.0, 0.0]), np.zeros(3))

    w.add_force(tb.CustomForce(explode))
    with pytest.raises(tb.InputError, match="finite"):
        tb.Simulator(w).run(1.0)

    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, name="rocket", velocity=(1e150, 0, 0))
    w.add_force(tb.Drag(quadratic=10.0))
    with pytest.raises(tb.SimulationError, match="'rocket': non-finite state at t = "):
        tb.Simulator(w, integrator="explicit-euler").run(1.0)


@pytest.mark.parametrize("controller", [None, lambda sim: None])
def test_a_step_loop_stops_at_a_non_finite_state_naming_the_body_and_stage(controller):
    # ``Simulator.step`` checks the state at the end of each call, as ``run`` does per frame (a
    # loop of step(1), MuJoCo's and PyBullet's way, went on with NaN before): the same one-line
    # SimulationError naming body, time and stage, and the World back where the call started.
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, name="rocket", velocity=(1e150, 0, 0))
    w.add_force(tb.Drag(quadratic=10.0))
    sim = tb.Simulator(w, integrator="explicit-euler", controller=controller)
    with pytest.raises(tb.SimulationError) as info:
        for _ in range(240):
            before = (w.t, w.pack())
            sim.step(1)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith("body 'rocket': non-finite state at t = ")
    assert info.value.stage in ("accumulate_forces", "integrate_free_motion")
    assert np.all(np.isfinite(w.pack())) and sim.step_index * sim.dt == pytest.approx(w.t)
    assert w.t == before[0] and np.array_equal(w.pack(), before[1])  # nothing kept of the call that blew up


def test_a_slow_first_frame_says_why_once_and_a_fast_one_says_nothing(monkeypatch, capsys):
    """With a progress bar, a first frame slower than FIRST_FRAME_NOTICE_S (a first run compiling
    the kernels) prints FIRST_FRAME_NOTICE on stderr, once; a fast first frame prints nothing.
    The slow frame here is a user force that sleeps 0.3 s on its first call (threshold 0.05 s)."""
    import time

    from tumble import recording as recording_module

    calls = []

    def slow_once(t, body):
        if not calls:
            time.sleep(0.3)
        calls.append(t)
        return np.zeros(3), np.zeros(3)

    monkeypatch.setattr(recording_module, "FIRST_FRAME_NOTICE_S", 0.05)
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Box((1, 1, 1)), mass=1.0)
    w.add_force(tb.CustomForce(slow_once))
    tb.Simulator(w, dt=0.01).run(0.1, frame_rate=20, progress=True)
    err = capsys.readouterr().err
    assert err.count(recording_module.FIRST_FRAME_NOTICE) == 1

    monkeypatch.setattr(recording_module, "FIRST_FRAME_NOTICE_S", 2.0)
    w2 = tb.World(gravity=(0, 0, 0))
    w2.add_body(tb.Box((1, 1, 1)), mass=1.0)
    tb.Simulator(w2, dt=0.01).run(0.1, frame_rate=20, progress=True)
    time.sleep(0.1)
    assert recording_module.FIRST_FRAME_NOTICE not in capsys.readouterr().err


def test_a_blow_up_inside_the_soft_step_is_reported_by_its_span_of_steps():
    # A rocket on a slider joint: its blow-up happens inside the soft step, whose solver warm starts
    # a replay would not rewind (it named the first substep whatever the step): the message gives
    # the call's span of steps and stage soft_step; the World is back where the call started.
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, name="rocket", velocity=(1e150, 0, 0))
    w.add_joint(tb.SliderJoint("rocket", None, axis=(1, 0, 0)))
    w.add_force(tb.Drag(quadratic=10.0))
    sim = tb.Simulator(w)
    start = w.pack()
    with pytest.raises(tb.SimulationError) as info:
        sim.step(24)
    assert info.value.stage == "soft_step" and "between steps 0 and 24" in str(info.value)
    assert np.array_equal(w.pack(), start) and sim.step_index == 0


@pytest.mark.parametrize("compress", [True, False])
def test_a_saved_trajectory_is_the_same_bytes_whenever_it_is_saved(compress, tmp_path, monkeypatch):
    """``Trajectory.save`` stamps its zip entries with a fixed time (as np.savez does), so the same run
    saved at two times is the same file: a checksum tells two runs apart, not two saves. Stored
    (``compress=False``: big contact recordings save 8x faster, docs/benchmarks.md "Saving a
    trajectory") or deflated, ``np.load`` reads the same arrays back, bit for bit."""
    import time
    import zipfile

    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 0.5), name="box")
    traj = tb.Simulator(w, record_contacts=True).run(0.5)
    clock = [1.0e9]
    monkeypatch.setattr(time, "time", lambda: clock[0])  # zipfile reads the clock through time.time
    first = traj.save(tmp_path / "a.npz", compress=compress).read_bytes()
    clock[0] += 3600.0  # an hour later
    second = traj.save(tmp_path / "b.npz", compress=compress).read_bytes()
    assert first == second
    with zipfile.ZipFile(tmp_path / "a.npz") as zf:
        kinds = {info.compress_type for info in zf.infolist()}
    assert kinds == ({zipfile.ZIP_DEFLATED} if compress else {zipfile.ZIP_STORED})
    back = tb.load_trajectory(tmp_path / "a.npz")
    for key in ("time", "position", "orientation", "contact_point", "contact_normal_impulse", "contact_body_a"):
        np.testing.assert_array_equal(getattr(back, key), getattr(traj, key), err_msg=key)
