"""Bad input to the library and the scene check: one InputError line, never another exception
(an input audit, session 42: its groups A, B, C, G, H1)."""

import json
import subprocess
import sys

import numpy as np
import pytest

import tumble as tb
from tumble.scene import load_scene, parse_scene

from .refusals import refused


def ball_world():
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Sphere(radius=0.1), mass=1.0)
    return w




# ---------------------------------------------------------------------- G: Simulator arguments


@pytest.mark.parametrize("kwargs, key, problem", [
    ({"substeps": float("nan")}, "simulation.substeps", "must be a whole number >= 1, got nan"),  # G1
    ({"substeps": 1.5}, "simulation.substeps", "whole number"),
    ({"substeps": "2"}, "simulation.substeps", "whole number"),
    ({"substeps": 10**30}, "simulation.substeps", "must be at most"),  # B1's value, in the library
    ({"integrator": "rk45", "rtol": "x"}, "simulation.rtol", "expected a number, got 'x'"),  # G2
    ({"integrator": "rk45", "rtol": -1}, "simulation.rtol", "must be positive, got -1"),  # G3
    ({"integrator": "rk45", "atol": float("nan")}, "simulation.atol", "must be a finite number, got nan"),  # G4
    ({"atol": 0.0}, "simulation.atol", "must be positive"),
    ({"contact_settings": 5}, "contact_settings", "SoftStepSettings or None, got 5"),  # G5
    ({"joint_settings": 5}, "joint_settings", "JointSettings or None, got 5"),  # G6
])
def test_simulator_refuses_bad_arguments_at_construction(kwargs, key, problem):
    refused(lambda: tb.Simulator(ball_world(), **kwargs), key, problem)


def test_simulator_takes_good_arguments_as_before():
    sim = tb.Simulator(ball_world(), substeps=np.int64(2), rtol=np.float64(1e-8), atol=1, integrator="rk45")
    assert (sim.substeps, sim.rtol, sim.atol) == (2, 1e-8, 1.0)
    assert type(sim.substeps) is int
    assert tb.Simulator(ball_world(), substeps=3.0).substeps == 3
    from tumble.solver.contact import SoftStepSettings
    from tumble.solver.joints import ACCURATE

    tb.Simulator(ball_world(), contact_settings=SoftStepSettings(), joint_settings=ACCURATE)


@pytest.mark.parametrize("count", [float("nan"), -3, 1.5, 2.0, "a", None, True, [1]])  # G7-G10
def test_step_takes_a_whole_number_of_steps(count):
    w = ball_world()
    sim = tb.Simulator(w)
    refused(lambda: sim.step(count), "count", "must be a whole number >= 0")
    assert w.t == 0.0 and sim.step_index == 0


def test_step_takes_ints_and_numpy_integers():
    w = ball_world()
    sim = tb.Simulator(w)
    sim.step(0)
    assert sim.step_index == 0
    sim.step(np.int32(2))
    sim.step()
    assert sim.step_index == 3 and type(sim.step_index) is int
    assert w.t == pytest.approx(3 / 240)


def test_step_refuses_more_than_the_step_limit_in_one_call():
    from tumble.simulator import MAX_RUN_STEPS

    sim = tb.Simulator(ball_world(), substeps=10)
    refused(lambda: sim.step(MAX_RUN_STEPS), "count", "more than the limit")
    refused(lambda: sim.step(10**30), "count", "more than the limit")


def test_save_checkpoint_to_a_folder_is_one_line(tmp_path):  # G12
    sim = tb.Simulator(ball_world())
    err = refused(lambda: sim.save_checkpoint(tmp_path), None, "is a folder")
    assert err.file == str(tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_a_non_symmetric_inertia_is_refused_in_the_library():  # G11
    w = tb.World()
    refused(lambda: w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, inertia=[[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]),
            "inertia", "must be a symmetric matrix, got [0][1] = 0.5 but [1][0] = 0")
    b = w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0)
    refused(lambda: w.set_mass(b, 2.0, inertia=[[1, 0, 0], [0, 1, 0.1], [0, 0, 1]]), "inertia", "symmetric")
    # rounding is forgiven (and symmetrised)
    w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, inertia=[[1, 0.1, 0], [0.1 + 1e-12, 1, 0], [0, 0, 1]])


def test_a_non_symmetric_inertia_is_refused_in_a_scene():  # G11
    doc = {"bodies": [{"name": "b", "shape": {"type": "box", "size": [1, 1, 1]}, "mass": 1.0,
                       "inertia": [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]}]}
    err = refused(lambda: parse_scene(doc, "s.toml"), "bodies[0].inertia", "must be a symmetric matrix")
    assert str(err) == "s.toml: bodies[0].inertia: must be a symmetric matrix, got [0][1] = 0.5 but [1][0] = 0"


# ---------------------------------------------------------------------- C: a bound on a run's steps

SCENE = """\
[simulation]
duration = 0.5
{line}
[[bodies]]
name = "b"
shape = {{ type = "box", size = [0.2, 0.2, 0.2] }}
mass = 1.0
"""


@pytest.mark.parametrize("line, key, steps", [
    ("substeps = 1000000000000", "simulation.substeps", "about 1.2e+14"),  # C1
    ("dt = 1e-300", "simulation.dt", "about 5e+299"),  # C2
    ("dt = 1e-320", "simulation.dt", "more than 1e308"),
])
def test_the_scene_check_refuses_a_run_of_too_many_steps(tmp_path, line, key, steps):
    path = tmp_path / "s.toml"
    path.write_text(SCENE.format(line=line))
    err = refused(lambda: load_scene(path), key, f"the run would take {steps} integrator steps")
    assert err.file == str(path)
    assert "more than the limit of 1e+09" in err.problem


def test_the_step_limit_names_the_duration_and_refuses_1e308_plainly(tmp_path):  # H1
    path = tmp_path / "s.toml"
    path.write_text(SCENE.format(line="").replace("duration = 0.5", "duration = 1e308"))
    err = refused(lambda: load_scene(path), "simulation.duration")
    assert str(err) == (f"{path}: simulation.duration: the run would take more than 1e308 integrator steps (1e+308 s at 24 "
                        "frames a second, 10 steps of dt a frame, 1 substeps a step), more than the limit of 1e+09; shorten the run")
    path.write_text(SCENE.format(line=""))
    scene = load_scene(path)
    scene.duration = 1e7
    refused(scene.check, "simulation.duration", "about 2.4e+09")


def test_the_cli_validate_refuses_a_run_of_too_many_steps(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(SCENE.format(line="substeps = 1000000000000"))
    p = subprocess.run([sys.executable, "-m", "tumble", "validate", str(path)], capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and p.stdout == ""
    assert p.stderr.splitlines() == [f"tumble: error: {path}: simulation.substeps: the run would take about 1.2e+14 integrator "
                                     "steps (0.5 s at 24 frames a second, 10 steps of dt a frame, 1e+12 substeps a step), more "
                                     "than the limit of 1e+09; use fewer substeps"]


@pytest.mark.parametrize("kwargs, duration, key", [
    ({"substeps": 10**6}, 10.0, "simulation.substeps"),
    ({"dt": 1e-12}, 0.125, "simulation.dt"),
    ({}, 1e308, "simulation.duration"),
    ({}, 1e7, "simulation.duration"),
])
def test_simulator_run_refuses_a_run_of_too_many_steps(kwargs, duration, key):
    w = ball_world()
    refused(lambda: tb.Simulator(w, **kwargs).run(duration), key, "more than the limit of 1e+09")
    assert w.t == 0.0


def test_runs_below_the_step_limit_are_taken():
    w = ball_world()
    traj = tb.Simulator(w, substeps=1000).run(1 / 24)
    assert len(traj.time) == 2


# ---------------------------------------------------------------------- A, B: integers too large to read or to use

BIG = "1" + "0" * 5000  # over Python's 4300-digit limit on reading an integer


def test_a_toml_integer_over_4300_digits_is_one_line(tmp_path):  # A1
    path = tmp_path / "s.toml"
    path.write_text(SCENE.format(line="").replace("mass = 1.0", f"mass = {BIG}"))
    err = refused(lambda: load_scene(path), None)
    assert str(err) == (f"{path}: invalid TOML: an integer of more than 4300 digits "
                        "(write a number that large as a float, e.g. 1e5000)")


def test_a_json_integer_over_4300_digits_is_one_line(tmp_path):  # A2
    path = tmp_path / "s.json"
    doc = json.dumps({"bodies": [{"name": "b", "shape": {"type": "sphere", "radius": 0.1}, "mass": 1.0}]})
    path.write_text(doc.replace('"mass": 1.0', f'"mass": {BIG}'))
    err = refused(lambda: load_scene(path), None)
    assert str(err) == (f"{path}: invalid JSON: an integer of more than 4300 digits "
                        "(write a number that large as a float, e.g. 1e5000)")


def test_a_whole_number_beyond_int64_is_refused_at_reading(tmp_path):  # B1
    path = tmp_path / "s.toml"
    path.write_text(SCENE.format(line="substeps = 1000000000000000000000000000000"))
    err = refused(lambda: load_scene(path), "simulation.substeps")
    assert str(err) == f"{path}: simulation.substeps: must be at most 2^63 - 1, got an integer of 31 digits"
    path.write_text(SCENE.format(line="substeps = 9223372036854775808"))  # 2^63
    refused(lambda: load_scene(path), "simulation.substeps", "must be at most 2^63 - 1")


def test_a_huge_python_integer_in_a_document_is_one_line():
    # parse_scene of a dict (no text limit): str() of it would raise ValueError itself
    doc = {"bodies": [{"name": "b", "shape": {"type": "sphere", "radius": 0.1}, "mass": 10**5000}]}
    err = refused(lambda: parse_scene(doc, "s.toml"), "bodies[0].mass")
    assert "integer of 5001 digits" in err.problem
    doc = {"simulation": {"substeps": -10**5000}, "bodies": doc["bodies"]}
    err = refused(lambda: parse_scene(doc, "s.toml"), "simulation.substeps")
    assert "integer of 5001 digits" in err.problem
