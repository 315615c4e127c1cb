"""Tests for tumble/cli.py: demo, run, validate; outputs, no overwriting, one-line errors with exit status 2."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tumble.cli import main
from tumble.errors import SimulationError

SRC = Path(__file__).resolve().parents[1] / "src"

SCENE = """
[simulation]
duration = 1.0
integrator = "rk4"

[[bodies]]
name = "box"
shape = { type = "box", size = [0.2, 0.6, 1.0] }
mass = 2.0
angular_velocity = [0.01, 5, 0.01]
angular_velocity_frame = "body"

[[bodies]]
name = "ball"
shape = { type = "sphere", radius = 0.1 }
mass = 1.0
position = [1, 0, 0]

[[forces]]
type = "spring"
body_a = "ball"
anchor_b = [1, 0, 1]
stiffness = 20
damping = 0.1
"""

TRAJECTORY_KEYS = {
    "time", "names", "position", "orientation", "velocity", "angular_velocity",
    "linear_momentum", "angular_momentum", "kinetic_energy", "potential_energy",
}
RUN_KEYS = {
    "frames", "steps", "wall_time_s", "energy_initial", "energy_final", "energy_drift_relative",
    "max_orthonormality_error", "largest_penetration_m", "status", "state_hash", "error", "signal",
}


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "spin.toml"
    path.write_text(SCENE)
    return path


def snapshot(folder):
    """Bytes and modification time of every file below ``folder`` (plots/ included)."""
    return {str(p.relative_to(folder)): (p.read_bytes(), p.stat().st_mtime_ns) for p in sorted(Path(folder).rglob("*")) if p.is_file()}


def check_outputs(out, frames, names):
    with np.load(out / "trajectory.npz", allow_pickle=False) as data:
        assert TRAJECTORY_KEYS <= set(data.files)
        assert data["position"].shape == (frames, len(names), 3)
        assert data["names"].tolist() == names
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary) == {"tumble_version", "scene", "settings", "versions", "run"}
    assert {"source", "data"} <= set(summary["scene"])
    assert {"dt", "integrator", "substeps", "layout", "duration", "frame_rate", "gravity"} <= set(summary["settings"])
    assert set(summary["versions"]) == {"python", "numpy", "scipy", "numba"}
    assert set(summary["run"]) == RUN_KEYS
    assert summary["run"]["frames"] == frames
    assert summary["run"]["largest_penetration_m"] is None
    return summary


def test_demo_writes_outputs_and_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--duration", "0.5"]) == 0
    stdout = capsys.readouterr().out
    assert "3 bodies" in stdout and str(out / "trajectory.npz") in stdout
    summary = check_outputs(out, 13, ["flipper", "top", "lantern"])
    assert summary["settings"]["duration"] == 0.5 and summary["settings"]["integrator"] == "rk4"
    assert summary["run"]["steps"] == 120
    assert summary["scene"]["data"]["simulation"]["duration"] == 5.0  # the scene as written
    assert (out / "scene.toml").read_text().startswith("# tumble's built-in demo")
    assert (out / "scene.toml").stat().st_mode & 0o044  # an ordinary readable file, not mkstemp's 0600

    before = snapshot(out)
    assert main(["demo", "--out", str(out), "--duration", "0.5"]) == 2
    captured = capsys.readouterr()
    assert captured.err == f"tumble: error: {out / 'trajectory.npz'}: exists (pass --force to overwrite)\n"
    assert captured.out == ""
    assert snapshot(out) == before

    for p in out.iterdir():
        os.utime(p, ns=(1, 1))
    assert main(["demo", "--out", str(out), "--duration", "0.5", "--force"]) == 0
    assert all(p.stat().st_mtime_ns > 1 for p in out.iterdir())
    check_outputs(out, 13, ["flipper", "top", "lantern"])


def test_only_summary_existing_also_refuses(tmp_path, capsys):
    out = tmp_path / "o"
    out.mkdir()
    (out / "summary.json").write_text("{}")
    assert main(["demo", "--out", str(out), "--duration", "0.5"]) == 2
    assert capsys.readouterr().err == f"tumble: error: {out / 'summary.json'}: exists (pass --force to overwrite)\n"
    assert (out / "summary.json").read_text() == "{}"
    assert not (out / "trajectory.npz").exists()


def test_run_scene_file(scene_file, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(scene_file), "--duration", "0.5", "--integrator", "splitting", "--no-progress"]) == 0
    out = tmp_path / "out" / "spin"  # default ./out/<scene stem>
    summary = check_outputs(out, 13, ["box", "ball"])
    assert summary["settings"]["integrator"] == "splitting"
    assert summary["scene"]["source"] == str(scene_file)
    assert summary["scene"]["data"]["bodies"][1]["name"] == "ball"
    assert (out / "spin.toml").exists() is False and (out / "scene.toml").read_text() == SCENE
    assert "2 bodies" in capsys.readouterr().out


def test_run_json_scene_keeps_its_suffix(tmp_path, capsys):
    import tomllib

    path = tmp_path / "spin.json"
    path.write_text(json.dumps(tomllib.loads(SCENE)))
    assert main(["run", str(path), "--out", str(tmp_path / "j"), "--duration", "0.5"]) == 0
    assert (tmp_path / "j" / "scene.json").read_text() == path.read_text()


def test_validate(scene_file, capsys):
    assert main(["validate", str(scene_file)]) == 0
    captured = capsys.readouterr()
    assert captured.out == f"{scene_file}: ok (2 bodies, 1 force, integrator rk4, duration 1 s)\n"
    assert captured.err == ""


def _bad(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


BAD = [
    # (id, scene text or None, file name, extra args, expected key in the line)
    ("unknown-key", SCENE.replace('mass = 1.0', 'mass = 1.0\ncolour = "red"'), "s.toml", [], "bodies[1].colour: unknown key"),
    ("negative-mass", SCENE.replace("mass = 2.0", "mass = -1"), "s.toml", [], "bodies[0].mass: must be positive, got -1"),
    ("zero-size", SCENE.replace("[0.2, 0.6, 1.0]", "[0.2, 0.6, 0]"), "s.toml", [], "bodies[0].shape.size[2]: must be positive, got 0"),
    ("unknown-integrator", SCENE.replace('"rk4"', '"rk5"'), "s.toml", [], "simulation.integrator: unknown integrator 'rk5'"),
    ("unknown-body", SCENE.replace('body_a = "ball"', 'body_a = "bal"'), "s.toml", [], "forces[0].body_a: unknown body 'bal'"),
    ("toml-syntax", SCENE.replace("mass = 2.0", "mass = = 2.0"), "s.toml", [], "invalid TOML: Invalid value (at line"),
    ("json-syntax", '{"bodies": [}', "s.json", [], "invalid JSON: Expecting value (at line 1, column 13)"),
    ("nan", SCENE.replace("mass = 2.0", "mass = nan"), "s.toml", [], "bodies[0].mass: must be a finite number, got nan"),
    ("missing-file", None, "nothere.toml", [], "nothere.toml: file not found"),
    ("dt", SCENE.replace('integrator = "rk4"', "dt = 0.01"), "s.toml", [], "simulation.dt: must divide 1 / frame_rate"),
]


@pytest.mark.parametrize("command", ["run", "validate"])
@pytest.mark.parametrize("text, name, extra, expected", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_input_is_one_line_and_status_2(tmp_path, capsys, command, text, name, extra, expected):
    path = tmp_path / name if text is None else _bad(tmp_path, name, text)
    args = [command, str(path)] + (["--out", str(tmp_path / "out")] if command == "run" else []) + extra
    assert main(args) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith(f"tumble: error: {path}: "), lines[0]
    assert expected in lines[0]
    assert "Traceback" not in captured.err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "args, expected",
    [
        (["run", "{scene}", "--integrator", "rk5"], "tumble: error: --integrator: unknown integrator 'rk5' (expected one of "),
        (["run", "{scene}", "--duration", "0.3"], "tumble: error: --duration: must be a whole number of frames at 24 per second, got 0.3 s"),
        (["run", "{scene}", "--duration", "-1"], "tumble run: error: argument --duration: must be a positive number of seconds, got '-1'"),
        (["run", "{scene}", "--duration", "abc"], "tumble run: error: argument --duration: expected a number of seconds, got 'abc'"),
        (["run"], "tumble run: error: the following arguments are required: SCENE"),
        (["fly"], "tumble: error: argument COMMAND: invalid choice: 'fly'"),
        ([], "tumble: error: the following arguments are required: COMMAND"),
        (["validate", "{scene}", "--force"], "tumble: error: unrecognized arguments: --force"),
        (["run", "{dir}"], "tumble: error: {dir}: unknown scene file type"),
    ],
)
def test_bad_command_line_is_one_line_and_status_2(scene_file, tmp_path, capsys, args, expected):
    folder = tmp_path / "folder"
    folder.mkdir()
    fill = {"scene": str(scene_file), "dir": str(folder)}
    args = [a.format(**fill) for a in args]
    assert main(args) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith(expected.format(**fill)), lines[0]
    assert "Traceback" not in captured.err


def test_out_is_a_file(scene_file, tmp_path, capsys):
    target = tmp_path / "taken"
    target.write_text("x")
    assert main(["run", str(scene_file), "--out", str(target), "--duration", "0.5"]) == 2
    assert capsys.readouterr().err == f"tumble: error: {target}: exists and is not a folder (choose another --out)\n"


def test_simulation_error_is_status_3(scene_file, tmp_path, capsys, monkeypatch):
    from tumble import simulator

    def blow_up(self, *args, **kwargs):
        raise SimulationError("body 'box': non-finite state at t = 0.5 s (integrator rk4, dt = 0.00416667 s)")

    monkeypatch.setattr(simulator.Simulator, "run_to_file", blow_up)  # the CLI streams its frames
    assert main(["run", str(scene_file), "--out", str(tmp_path / "o")]) == 3
    err = capsys.readouterr().err
    assert err.startswith("tumble: simulation failed: body 'box': non-finite state at t = 0.5 s (integrator rk4, dt = 0.00416667 s)")
    assert len(err.splitlines()) == 1
    assert not (tmp_path / "o" / "trajectory.npz").exists()


def test_help_and_version(capsys):
    assert main(["--help"]) == 0
    assert "demo" in capsys.readouterr().out
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("tumble ")


# ---------------------------------------------------------------------- a real process


def _tumble(*args, cwd):
    env = dict(os.environ)
    env["PYTHONPATH"] = str(SRC) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return subprocess.run([sys.executable, "-m", "tumble.cli", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


def test_python_dash_m_tumble_is_the_command(tmp_path):
    """``python -m tumble`` runs the command as the console script does (a reproducibility audit
    found it missing: "No module named tumble.__main__"): validate answers, bad input is one line
    and exit 2."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(SRC) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    good = subprocess.run([sys.executable, "-m", "tumble", "validate", str(_bad(tmp_path, "good.toml", SCENE))],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert good.returncode == 0 and good.stdout.endswith(": ok (2 bodies, 1 force, integrator rk4, duration 1 s)\n")
    path = _bad(tmp_path, "bad.toml", SCENE.replace("mass = 2.0", "mass = true"))
    bad = subprocess.run([sys.executable, "-m", "tumble", "validate", str(path)], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2
    assert bad.stderr == f"tumble: error: {path}: bodies[0].mass: expected a number, got true (a boolean)\n"


def test_subprocess_demo_then_refuse_then_force(tmp_path):
    out = tmp_path / "demo"
    first = _tumble("demo", "--out", str(out), "--duration", "0.5", cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    assert first.stderr == ""
    check_outputs(out, 13, ["flipper", "top", "lantern"])
    before = snapshot(out)

    again = _tumble("demo", "--out", str(out), "--duration", "0.5", cwd=tmp_path)
    assert again.returncode == 2
    assert again.stderr == f"tumble: error: {out / 'trajectory.npz'}: exists (pass --force to overwrite)\n"
    assert snapshot(out) == before

    forced = _tumble("demo", "--out", str(out), "--duration", "0.5", "--force", cwd=tmp_path)
    assert forced.returncode == 0, forced.stderr
    check_outputs(out, 13, ["flipper", "top", "lantern"])


def test_subprocess_bad_scene(tmp_path):
    path = _bad(tmp_path, "bad.toml", SCENE.replace("mass = 2.0", "mass = true"))
    result = _tumble("run", str(path), cwd=tmp_path)
    assert result.returncode == 2
    assert result.stdout == ""
    assert result.stderr == f"tumble: error: {path}: bodies[0].mass: expected a number, got true (a boolean)\n"
    assert not (tmp_path / "out").exists()

    ok = _tumble("validate", str(_bad(tmp_path, "good.toml", SCENE)), cwd=tmp_path)
    assert ok.returncode == 0 and ok.stdout.endswith(": ok (2 bodies, 1 force, integrator rk4, duration 1 s)\n")


def test_demo_writes_video_gltf_and_plots_and_run_takes_media_flags(tmp_path, capsys):
    # Issue 5 item 6: `tumble demo` writes the trajectory, a video, a .glb and the plots;
    # `tumble run` does the same on request (--video, --gltf, --usd, --html, --plots).
    import imageio.v3 as iio

    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--duration", "0.5", "--no-progress"]) == 0
    for name in ("video.mp4", "trajectory.glb", "plots/energy.png", "plots/momentum.png", "plots/orthonormality.png"):
        assert (out / name).stat().st_size > 0, name
    assert (out / "trajectory.glb").read_bytes()[:4] == b"glTF"
    props = iio.improps(out / "plots" / "energy.png")
    assert props.shape[0] > 100 and props.shape[1] > 100

    scene = tmp_path / "s.toml"
    scene.write_text('[simulation]\nduration = 0.25\n[[bodies]]\nname = "b"\nshape = { type = "sphere", radius = 0.2 }\nmass = 1.0\n')
    run_out = tmp_path / "run"
    assert main(["run", str(scene), "--out", str(run_out), "--gltf", "--usd", "--html", "--plots", "--no-progress"]) == 0
    assert (run_out / "trajectory.glb").exists() and (run_out / "trajectory.usdc").exists() and (run_out / "plots").is_dir()
    assert (run_out / "trajectory.html").read_text().startswith("<!doctype html>")
    assert not (run_out / "video.mp4").exists()
    capsys.readouterr()

    # an existing media file is never overwritten without --force, and is checked before running
    before = (run_out / "trajectory.glb").read_bytes()
    (run_out / "trajectory.npz").unlink()
    (run_out / "summary.json").unlink()
    (run_out / "checkpoint.npz").unlink()
    (run_out / "s.toml").unlink(missing_ok=True)
    (run_out / "scene.toml").unlink(missing_ok=True)
    assert main(["run", str(scene), "--out", str(run_out), "--gltf"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "trajectory.glb: exists (pass --force to overwrite)" in err[0]
    assert (run_out / "trajectory.glb").read_bytes() == before
    assert not (run_out / "trajectory.npz").exists()


def test_media_without_their_packages(tmp_path, capsys, monkeypatch):
    # `pip install tumble` without the render extra: `run --video` is bad input (one line,
    # exit 2, before running); `demo` writes what it can and says how to get the rest.
    from tumble import cli

    monkeypatch.setattr(cli, "_missing_modules", lambda modules: [m for m in modules if m in ("pyvista", "matplotlib")])
    scene = tmp_path / "s.toml"
    scene.write_text('[simulation]\nduration = 0.25\n[[bodies]]\nname = "b"\nshape = { type = "sphere", radius = 0.2 }\nmass = 1.0\n')
    assert main(["run", str(scene), "--out", str(tmp_path / "r"), "--video"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["tumble: error: --video: needs pyvista: pip install 'tumble[render]'"]
    assert not (tmp_path / "r" / "trajectory.npz").exists()

    out = tmp_path / "d"
    assert main(["demo", "--out", str(out), "--duration", "0.25", "--no-progress"]) == 0
    notes = capsys.readouterr().err.strip().splitlines()
    assert len(notes) == 2 and all(n.startswith("tumble: note: no ") for n in notes)
    assert (out / "trajectory.glb").exists() and not (out / "video.mp4").exists() and not (out / "plots").exists()


def test_energy_line_says_drift_only_for_a_conservative_scene(tmp_path, capsys):
    """The run's energy line calls the change a "relative drift" (the integrator's error) only when
    nothing but gravity and undamped springs acts: the torque-free Dzhanibekov box. The demo's
    hover force, torque and wind do work, so its +29 % is a "relative change" with the reason; so is
    a scene whose bodies change type (the energy of a body let go enters the sum)."""
    examples = Path(__file__).resolve().parent.parent / "examples"
    assert main(["run", str(examples / "dzhanibekov.toml"), "--out", str(tmp_path / "flip"), "--duration", "0.5"]) == 0
    line = [s for s in capsys.readouterr().out.splitlines() if s.startswith("energy:")][0]
    assert "relative drift" in line and "do work" not in line
    assert main(["demo", "--out", str(tmp_path / "demo"), "--duration", "0.5", "--no-media"]) == 0
    line = [s for s in capsys.readouterr().out.splitlines() if s.startswith("energy:")][0]
    assert "relative change" in line and "forces in this scene do work" in line
    # examples/toss.toml's ball and crate are let go from their paths: their energy enters the sum
    # then (a kinematic body counts none), which the line says rather than blaming the contacts alone
    assert main(["run", str(examples / "toss.toml"), "--out", str(tmp_path / "toss"), "--no-progress"]) == 0
    line = [s for s in capsys.readouterr().out.splitlines() if s.startswith("energy:")][0]
    assert "contacts and bodies changing type in this scene do work" in line


CAMERA_SCENE = """
[simulation]
duration = 0.5
frame_rate = 8

[[bodies]]
name = "ground"
shape = { type = "plane" }
fixed = true

[[bodies]]
name = "ball"
shape = { type = "sphere", radius = 0.3 }
mass = 1.0
position = [0.2, -0.1, 2.0]

[[cameras]]
name = "top"
position = [0, 0, 5]
target = [0, 0, 0]
up = [1, 0, 0]
width = 16
height = 12
"""


def test_resume_writes_the_media_asked_for(tmp_path, capsys):
    """``tumble run --resume DIR --gltf --html --plots --images [--usd]`` writes the media of the
    whole (resumed) run once it completes, as ``tumble run`` does; before, it wrote none and
    exited 0. The media are those of all the frames, not of the part before the checkpoint."""
    import importlib.util

    import tumble as tb

    scene = tmp_path / "cam.toml"
    scene.write_text(CAMERA_SCENE)
    out = tmp_path / "part"
    assert main(["run", str(scene), "--out", str(out), "--duration", "0.25", "--checkpoint-every", "0.125",
                 "--no-progress"]) == 0
    media = ["--gltf", "--html", "--plots", "--images"] + (["--usd"] if importlib.util.find_spec("pxr") else [])
    capsys.readouterr()
    assert main(["run", "--resume", str(out), "--duration", "0.5", "--no-progress", *media]) == 0
    stdout = capsys.readouterr().out
    traj = tb.load_trajectory(out / "trajectory.npz")
    assert traj.frame_count == 5
    for name in ("trajectory.glb", "trajectory.html", "plots/energy.png", "images/top/rgb_00004.png", "images/top.npz"):
        assert (out / name).stat().st_size > 0, name
        assert str(out / name.split("/")[0]) in stdout, name
    if "--usd" in media:
        assert (out / "trajectory.usdc").stat().st_size > 0
    with np.load(out / "images" / "top.npz", allow_pickle=False) as images:
        assert images["depth"].shape == (5, 12, 16)
    # the .glb animates all five frames: its time samples end at the last frame's time
    import struct

    data = (out / "trajectory.glb").read_bytes()
    gltf = json.loads(data[20:20 + struct.unpack_from("<I", data, 12)[0]])
    times = [a for a in gltf["accessors"] if a.get("type") == "SCALAR" and a.get("max") and a["count"] == 5]
    assert times and times[0]["max"][0] == pytest.approx(0.5)

    # a flag that cannot work is refused in one line before resuming: the scene file is gone
    scene.unlink()
    assert main(["run", "--resume", str(out), "--duration", "0.75", "--images", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("tumble: error: --images: needs the run's scene file"), err
    assert tb.load_trajectory(out / "trajectory.npz").frame_count == 5


def test_force_removes_the_replaced_runs_media_it_does_not_write(tmp_path, capsys):
    """``tumble run --force`` into the folder of an earlier run with media removes the media the new
    run does not write (a .glb, .html, plots, images of the old run beside the new trajectory would
    be a trap), one note line each, and nothing tumble did not write; the media it writes are
    replaced. Without --force the folder is left as it is (the exists check)."""
    scene = tmp_path / "cam.toml"
    scene.write_text(CAMERA_SCENE)
    out = tmp_path / "run"
    assert main(["run", str(scene), "--out", str(out), "--duration", "0.25", "--gltf", "--html", "--plots", "--images",
                 "--no-progress"]) == 0
    (out / "notes.txt").write_text("mine")
    (out / "plots" / "mine.png").write_bytes(b"x")
    (out / "images" / "top" / "sketch.png").write_bytes(b"x")
    old_glb = (out / "trajectory.glb").read_bytes()
    capsys.readouterr()

    before = snapshot(out)
    assert main(["run", str(scene), "--out", str(out), "--duration", "0.5", "--no-progress"]) == 2
    assert snapshot(out) == before and "exists (pass --force" in capsys.readouterr().err

    assert main(["run", str(scene), "--out", str(out), "--duration", "0.5", "--gltf", "--force", "--no-progress"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert sorted(err) == sorted([
        f"tumble: note: removed {out / 'trajectory.html'}: the replaced run's, which this run does not write (--force)",
        f"tumble: note: removed {out / 'plots'}/ (3 files): the replaced run's, which this run does not write (--force)",
        f"tumble: note: removed {out / 'images'}/ (4 files): the replaced run's, which this run does not write (--force)",
    ]), err
    assert not (out / "trajectory.html").exists() and not (out / "images" / "top.npz").exists()
    assert sorted(p.name for p in (out / "plots").iterdir()) == ["mine.png"]
    assert sorted(p.name for p in (out / "images" / "top").iterdir()) == ["sketch.png"]
    assert (out / "notes.txt").read_text() == "mine"
    new_glb = (out / "trajectory.glb").read_bytes()  # asked for: rewritten from the new run (5 frames, not 3)
    assert new_glb[:4] == b"glTF" and new_glb != old_glb

    # a run into a folder whose media are all gone or asked for prints no note
    (out / "plots" / "mine.png").unlink()
    (out / "images" / "top" / "sketch.png").unlink()
    assert main(["run", str(scene), "--out", str(out), "--duration", "0.25", "--gltf", "--force", "--no-progress"]) == 0
    assert "removed" not in capsys.readouterr().err
    assert (out / "plots").is_dir() and (out / "images").is_dir()  # empty folders: left as they were


BOX_ON_PLANE = """
[simulation]
duration = 1.0

[[bodies]]
name = "ground"
shape = { type = "plane" }
fixed = true

[[bodies]]
name = "box"
shape = { type = "box", size = [0.4, 0.4, 0.4] }
mass = 2.0
position = [0, 0, 0.21]
"""


def test_summary_gives_the_largest_penetration(tmp_path, capsys):
    """summary.json's ``largest_penetration_m`` (before: always null) is the deepest penetration of
    any contact point at any step: for a box dropped 1 cm onto a plane, small and positive, and
    exactly what the separations of ``sim.contacts()`` after each step give (the same value from
    the in-memory run, the streamed run and a resumed one); null for a scene without contacts."""
    import tumble as tb

    scene = tmp_path / "box.toml"
    scene.write_text(BOX_ON_PLANE)
    # step by step: the lowest separation of the contacts of each step (sim.contacts())
    sim = tb.load_scene(scene).simulator()
    low = np.inf
    for _ in range(240):
        sim.step()
        sep = sim.contacts().separation
        if len(sep):
            low = min(low, float(sep.min()))
    assert np.isfinite(low) and low < 0
    assert sim.largest_penetration == -low
    assert 0 < sim.largest_penetration < 2e-3  # a resting box: well under a few millimetres
    memory = tb.load_scene(scene).simulator()
    memory.run(1.0)
    assert memory.largest_penetration == -low

    out, part = tmp_path / "run", tmp_path / "part"
    assert main(["run", str(scene), "--out", str(out), "--no-progress"]) == 0
    assert json.loads((out / "summary.json").read_text())["run"]["largest_penetration_m"] == -low
    # a resumed run goes on from the figure in its checkpoint
    assert main(["run", str(scene), "--out", str(part), "--duration", "0.5", "--checkpoint-every", "0.25", "--no-progress"]) == 0
    first = json.loads((part / "summary.json").read_text())["run"]["largest_penetration_m"]
    assert main(["run", "--resume", str(part), "--duration", "1", "--no-progress"]) == 0
    resumed = json.loads((part / "summary.json").read_text())["run"]["largest_penetration_m"]
    assert 0 < first <= resumed == -low

    # no contacts: null (the spinning box and the ball on a spring)
    free = tmp_path / "spin.toml"
    free.write_text(SCENE)
    assert main(["run", str(free), "--out", str(tmp_path / "free"), "--duration", "0.25", "--no-progress"]) == 0
    assert json.loads((tmp_path / "free" / "summary.json").read_text())["run"]["largest_penetration_m"] is None
    free_sim = tb.load_scene(free).simulator()
    free_sim.run(0.25)
    assert free_sim.largest_penetration is None
    capsys.readouterr()
