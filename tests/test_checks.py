"""tumble.checks: state_hash, blow-up diagnosis (each kind provoked), validate_world, TUMBLE_VALIDATE, limits."""

import numpy as np
import pytest

import tumble as tb
from tumble import checks


def rocket():
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, name="rocket", velocity=(1e150, 0, 0))
    w.add_force(tb.Drag(quadratic=10.0))
    return w


def stiff_spring():
    # explicit Euler on a spring with h omega = 100/240: the amplitude grows ~8 % a step
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, name="bob", position=(0.1, 0, 0))
    w.add_force(tb.Spring("bob", None, stiffness=1e4, rest_length=0.0))
    return w


def test_state_hash_covers_the_state_and_only_the_state():
    w = stiff_spring()
    h = checks.state_hash(w)
    assert h == checks.state_hash(w) and len(h) == 64
    w.force[0] = 99.0  # accumulated, not state
    assert checks.state_hash(w) == h
    w.P[0, 1] = np.nextafter(0.0, 1.0)  # one bit of state
    assert checks.state_hash(w) != h


def test_non_finite_state_names_body_time_quantity_and_stage():
    w = rocket()
    with pytest.raises(tb.SimulationError) as info:
        tb.Simulator(w, integrator="explicit-euler").run(1.0)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith("body 'rocket': non-finite state at t = 0.004166666667 s: non-finite force F = [inf")
    assert "(stage accumulate_forces, step 2, explicit-euler" in msg
    err = info.value
    assert (err.body, err.stage) == ("rocket", "accumulate_forces") and err.time == pytest.approx(1 / 240)
    assert w.t == 0.0 and np.all(np.isfinite(w.pack()))  # the world is back at the last good frame


def test_quaternion_off_unit_length_is_reported():
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, name="spinner", angular_velocity=(1, 2, 3))
    w.q[0] = [1.5, 0, 0, 0]  # written around the Body setter, which would normalise it
    with pytest.raises(tb.SimulationError, match=r"^body 'spinner': orientation off its manifold at t = 0 s: "
                       r"quaternion off unit length: \|q\| = 1\.5 \(tolerance 1e-09\) \(stage check_state"):
        tb.Simulator(w).run(1.0)


def test_rotation_matrix_off_so3_is_reported():
    w = tb.World(gravity=(0, 0, 0), layout="matrix")
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, name="slab")
    w.R[0] = np.diag([1.0, 1.0, 1.1])
    with pytest.raises(tb.SimulationError, match=r"'slab': orientation off its manifold .* rotation matrix off SO\(3\)"):
        tb.Simulator(w).run(1.0)


def test_energy_growth_past_the_bound_is_reported_and_the_frames_kept(tmp_path):
    w = stiff_spring()
    sim = tb.Simulator(w, integrator="explicit-euler")
    with pytest.raises(tb.SimulationError) as info:
        sim.run_to_file(tmp_path, 5.0)
    msg = str(info.value)
    assert msg.startswith("body 'bob': energy growing past its bound at t = 0.375 s: energy E = ")
    assert "max_energy_growth = 1e+06" in msg and "(stage check_energy, end of step 90" in msg
    traj = tb.load_trajectory(tmp_path / "trajectory.npz")
    assert traj.frame_count == 10 and traj.time[-1] == pytest.approx(0.375)
    import json

    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["run"]["status"] == "failed" and summary["run"]["error"] == msg
    # a lower factor stops it sooner; rk4 at the same dt is stable and runs through
    with pytest.raises(tb.SimulationError, match="max_energy_growth = 10\\)"):
        tb.Simulator(stiff_spring(), integrator="explicit-euler", max_energy_growth=10).run(5.0)
    tb.Simulator(stiff_spring(), integrator="rk4").run(5.0)
    with pytest.raises(tb.InputError, match="max_energy_growth: must be a number >= 1"):
        tb.Simulator(w, max_energy_growth=0.5)


def test_an_impulse_rebases_the_energy_bound():
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, name="ball")
    w.add_force(tb.Impulse("ball", impulse=(1e4, 0, 0), time=0.5))  # KE 5e7 J >> 1e6 x 0.5 J
    tb.Simulator(w).run(1.0)
    assert w.body("ball").v[0] == pytest.approx(1e4)


def test_validate_world_finds_inconsistent_derived_quantities():
    w = stiff_spring()
    w.update_derived()
    checks.validate_world(w)
    w.v[0, 0] += 1.0
    with pytest.raises(tb.SimulationError, match="'bob': .*inconsistent derived quantity: velocity v != P / m"):
        checks.validate_world(w, "test")
    w.update_derived()
    w.x[0, 2] = np.nan
    with pytest.raises(tb.SimulationError, match="non-finite position x"):
        checks.validate_world(w)


def test_tumble_validate_checks_every_stage(monkeypatch):
    monkeypatch.setenv("TUMBLE_VALIDATE", "1")
    sim = tb.Simulator(rocket(), integrator="explicit-euler")
    assert sim.validate
    calls = []
    original = checks.validate_world

    def spy(world, stage="validate_world", check_unit=True):
        calls.append(stage)
        return original(world, stage, check_unit)

    monkeypatch.setattr(checks, "validate_world", spy)
    with pytest.raises(tb.SimulationError, match="stage accumulate_forces, step 2"):
        sim.run(1.0)
    assert calls == ["project_orientation"]  # after step 1; step 2 stopped at its forces
    w = stiff_spring()
    tb.Simulator(w, integrator="rk4").run(0.25)
    assert len(calls) == 1 + 60


def test_memory_limit_refuses_a_run_too_big_for_memory(monkeypatch):
    w = tb.World(gravity=(0, 0, 0))
    for i in range(100):
        w.add_body(tb.Sphere(radius=0.1), mass=1.0)
    monkeypatch.setenv("TUMBLE_MAX_MEMORY", "1M")
    with pytest.raises(tb.InputError, match=r"^simulation.duration: keeping 2401 frames of 100 bodies in memory would need about 70 MiB, "
                       r"above the memory limit of 1 MiB \(set TUMBLE_MAX_MEMORY"):
        tb.Simulator(w).run(100.0)
    monkeypatch.setenv("TUMBLE_MAX_MEMORY", "none")
    assert checks.memory_limit() is None
    monkeypatch.setenv("TUMBLE_MAX_MEMORY", "lots")
    with pytest.raises(tb.InputError, match="TUMBLE_MAX_MEMORY: expected a size"):
        checks.memory_limit()
    assert checks.parse_size("1.5G", "k") == 3 << 29
