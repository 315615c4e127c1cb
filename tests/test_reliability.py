"""Runs that can be trusted (issue 6): checkpoints and bit-identical resume, streamed frames
that survive SIGINT / SIGTERM / SIGKILL, bounded memory, blow-ups through the CLI, hostile files."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import tumble as tb
from tumble.checks import state_hash
from tumble.cli import main as cli_main
from tumble.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
DEMO = SRC / "tumble" / "scenes" / "demo.toml"
PER_FRAME = ("time", "position", "orientation", "velocity", "angular_velocity", "linear_momentum", "angular_momentum",
             "kinetic_energy", "potential_energy", "total_linear_momentum", "total_angular_momentum", "orthonormality_error")


def same_frames(a, b):
    return a.frame_count == b.frame_count and all(np.array_equal(getattr(a, k), getattr(b, k)) for k in PER_FRAME)


def env():
    e = dict(os.environ)
    e["PYTHONPATH"] = str(SRC) + (os.pathsep + e["PYTHONPATH"] if e.get("PYTHONPATH") else "")
    return e


# ---------------------------------------------------------------------- checkpoints


def busy_world():
    """Springs between bodies, a world anchor, drag, an impulse before and one after the checkpoint, a custom force."""
    w = tb.World(gravity=(0, 0, -9.81))
    a = w.add_body(tb.Box(size=(0.2, 0.6, 1.0)), mass=2.0, angular_velocity=(0.01, 5, 0.01), name="a")
    w.add_body(tb.Particles(points=[[0, 0, 0], [0.3, 0, 0], [0, 0.2, 0.1]], masses=[1, 2, 3]), position=(1, 0, 0), name="p")
    w.add_body(tb.Plane(), fixed=True, name="ground")
    w.add_force(tb.Spring(a, "p", anchor_a=(0, 0, 0.5), stiffness=30, damping=0.2))
    w.add_force(tb.Spring("p", None, anchor_b=(1, 0, 2), stiffness=20))
    w.add_force(tb.Drag(linear=0.1, bodies=["a"]))
    w.add_force(tb.Impulse("a", impulse=(0, 1, 0), point=(0, 0, 0.3), time=0.2))
    w.add_force(tb.Impulse("p", impulse=(1, 0, 0), time=0.8))
    w.add_force(tb.CustomForce(lambda t, b: (np.array([0.0, 0.0, np.sin(t)]), np.zeros(3)), bodies=["p"]))
    return w


def lift(t, body):
    return np.array([0.0, 0.0, np.sin(t)]), np.zeros(3)


@pytest.mark.parametrize("integrator", ["rk4", "splitting", "dop853"])
def test_resumed_run_matches_an_uninterrupted_one_bit_for_bit(tmp_path, integrator):
    whole = busy_world()
    tb.Simulator(whole, integrator=integrator).run(1.5)

    first = busy_world()
    sim = tb.Simulator(first, integrator=integrator)
    sim.run(0.5)
    sim.save_checkpoint(tmp_path / "c.npz")
    with pytest.raises(tb.InputError, match="1 CustomForce record"):
        tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz", custom_forces=[lift])
    assert resumed.world.names == ["a", "p", "ground"] and resumed.integrator == integrator
    assert state_hash(resumed.world) == state_hash(first)
    resumed.run(1.0)
    assert state_hash(resumed.world) == state_hash(whole)
    assert resumed.world.applied_impulses == {3, 4}  # indices into world.forces


def test_cli_resume_continues_bit_identically(tmp_path, capsys):
    full, part = tmp_path / "full", tmp_path / "part"
    assert cli_main(["run", str(DEMO), "--out", str(full), "--duration", "2", "--no-progress"]) == 0
    assert cli_main(["run", str(DEMO), "--out", str(part), "--duration", "1", "--checkpoint-every", "0.25", "--no-progress"]) == 0
    assert cli_main(["run", "--resume", str(part), "--duration", "2", "--no-progress"]) == 0
    capsys.readouterr()
    a, b = (tb.load_trajectory(d / "trajectory.npz") for d in (full, part))
    assert a.frame_count == 49 and same_frames(a, b)
    assert (full / "trajectory.npz").read_bytes() == (part / "trajectory.npz").read_bytes()
    sa, sb = (json.loads((d / "summary.json").read_text())["run"] for d in (full, part))
    assert sa["state_hash"] == sb["state_hash"] and sb["status"] == "completed" and sa["steps"] == sb["steps"] == 480
    assert not (part / ".trajectory.parts").exists()


@pytest.mark.parametrize("args, expected", [
    (["run", "--resume", "{d}", "{scene}"], "tumble run: error: SCENE cannot be given with --resume"),
    (["run", "--resume", "{d}", "--out", "x"], "tumble run: error: --out cannot be given with --resume"),
    (["run", "--resume", "{missing}"], "tumble: error: {missing}: --resume: not a folder of a run"),
    (["run", "--resume", "{d}"], "tumble: error: {d}/checkpoint.npz: checkpoint file not found"),
    (["run", "--resume", "{d}", "--duration", "0.5"], None),
])
def test_resume_errors_are_one_line(tmp_path, capsys, args, expected):
    d = tmp_path / "run"
    d.mkdir()
    if expected is None:  # the run has already gone past the requested duration
        assert cli_main(["run", str(DEMO), "--out", str(d), "--duration", "1", "--force"]) == 0
        expected = "tumble: error: --duration: the run has already reached t = 1 s"
    capsys.readouterr()
    fill = {"d": str(d), "scene": str(DEMO), "missing": str(tmp_path / "nope")}
    assert cli_main([a.format(**fill) for a in args]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and err.startswith(expected.format(**fill)), err


def test_damaged_or_hostile_checkpoint_and_trajectory_files_are_input_errors(tmp_path):
    sim = tb.Simulator(busy_world())
    path = sim.save_checkpoint(tmp_path / "c.npz")
    raw = path.read_bytes()
    (tmp_path / "cut.npz").write_bytes(raw[: len(raw) // 2])
    with pytest.raises(tb.InputError, match=r"cut.npz: not a readable checkpoint file"):
        tb.Simulator.load_checkpoint(tmp_path / "cut.npz")
    # object arrays (pickles) are never loaded
    np.savez(tmp_path / "pickled.npz", meta=np.array([{"format": "tumble-checkpoint"}], dtype=object))
    with pytest.raises(tb.InputError, match="pickled.npz: not a readable checkpoint file .*allow_pickle"):
        tb.Simulator.load_checkpoint(tmp_path / "pickled.npz")
    np.savez(tmp_path / "t.npz", time=np.array([object()], dtype=object))
    with pytest.raises(tb.InputError, match="t.npz: not a readable trajectory file"):
        tb.load_trajectory(tmp_path / "t.npz")
    # a state that breaks an invariant
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["q"] = arrays["q"] * 2.0
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(tb.InputError, match=r"bad.npz: checkpoint state is invalid: body 'a': orientation off"):
        tb.Simulator.load_checkpoint(tmp_path / "bad.npz", custom_forces=[lift])


# ---------------------------------------------------------------------- blow-ups through the CLI

BLOW_UPS = {
    "non-finite": ("""
[simulation]
duration = 2.0
integrator = "explicit-euler"
gravity = [0, 0, 0]
[[bodies]]
name = "rocket"
shape = { type = "sphere", radius = 0.1 }
mass = 1.0
velocity = [1e150, 0, 0]
[[forces]]
type = "drag"
quadratic = 10.0
""", "body 'rocket': non-finite state at t = 0.004166666667 s: non-finite force F", 1),
    "energy": ("""
[simulation]
duration = 5.0
integrator = "explicit-euler"
gravity = [0, 0, 0]
[[bodies]]
name = "bob"
shape = { type = "sphere", radius = 0.1 }
mass = 1.0
position = [0.1, 0, 0]
[[forces]]
type = "spring"
body_a = "bob"
stiffness = 1e4
rest_length = 0.0
""", "body 'bob': energy growing past its bound at t = 0.375 s", 10),
}


@pytest.mark.parametrize("kind", sorted(BLOW_UPS))
def test_blow_up_exits_3_with_one_line_and_keeps_the_frames(tmp_path, kind):
    text, expected, frames = BLOW_UPS[kind]
    scene = tmp_path / "s.toml"
    scene.write_text(text)
    out = tmp_path / "out"
    result = subprocess.run([sys.executable, "-m", "tumble.cli", "run", str(scene), "--out", str(out)], env=env(),
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 3, result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"tumble: simulation failed: {expected}"), result.stderr
    assert lines[0].endswith(f"[frames before it kept in {out / 'trajectory.npz'}]")
    assert tb.load_trajectory(out / "trajectory.npz").frame_count == frames
    summary = json.loads((out / "summary.json").read_text())["run"]
    assert summary["status"] == "failed" and summary["error"].startswith(expected)


# ---------------------------------------------------------------------- signals

SLOW_SCENE_BODIES = 1500


def slow_scene(path: Path, duration=3600.0):
    """Bodies in pairs joined by springs (the all-bodies kernel): tens of seconds of wall time per
    hundred simulated seconds, so a signal always lands mid-run."""
    bodies, forces = [], []
    for i in range(SLOW_SCENE_BODIES):
        bodies.append({"name": f"b{i}", "shape": {"type": "box", "size": [0.2, 0.3, 0.4]}, "mass": 1.0,
                       "position": [float(i), 0.0, 0.0], "angular_velocity": [0.1 * (i % 7), 1.0, 0.3]})
        if i % 2:
            forces.append({"type": "spring", "body_a": f"b{i - 1}", "body_b": f"b{i}", "anchor_a": [0, 0, 0.2],
                           "stiffness": 40.0, "damping": 0.1, "rest_length": 0.8})
    doc = {"simulation": {"duration": duration, "frame_rate": 4, "dt": 1 / 240, "gravity": [0, 0, 0]}, "bodies": bodies, "forces": forces}
    path.write_text(json.dumps(doc))
    return path


def start_and_wait_for_checkpoints(tmp_path, flushes=2):
    scene = slow_scene(tmp_path / "slow.json")
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "tumble.cli", "run", str(scene), "--out", str(out), "--checkpoint-every", "0.5"],
                            env=env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        try:
            frames = json.loads((out / "summary.json").read_text())["run"]["frames"]
        except (OSError, ValueError, KeyError):
            frames = 0
        if frames >= 1 + 2 * flushes:
            return scene, out, proc
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.05)
    proc.kill()
    raise AssertionError("no checkpoint within 120 s")


def check_no_partial_files(out: Path):
    for name in ("trajectory.npz", "checkpoint.npz"):
        with np.load(out / name, allow_pickle=False) as data:
            for key in data.files:
                data[key]  # every entry reads in full
    json.loads((out / "summary.json").read_text())


def check_resume_matches(scene, out, frames_kept, tmp_path):
    """Resume the interrupted run 1 s further and compare it with an uninterrupted run of that length."""
    end = (frames_kept - 1) / 4 + 1.0
    r = subprocess.run([sys.executable, "-m", "tumble.cli", "run", "--resume", str(out), "--duration", repr(end)], env=env(),
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    s = load_scene(scene)
    s.duration = end
    traj = s.run(progress=False)
    resumed = tb.load_trajectory(out / "trajectory.npz")
    assert same_frames(traj, resumed)
    assert json.loads((out / "summary.json").read_text())["run"]["state_hash"] == state_hash(s.world)


@pytest.mark.slow
@pytest.mark.parametrize("sig, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_sigint_and_sigterm_leave_every_finished_frame_a_checkpoint_and_a_summary(tmp_path, sig, status):
    scene, out, proc = start_and_wait_for_checkpoints(tmp_path)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == status, err
    assert err.startswith(f"tumble: interrupted by {sig.name} at t = ") and len(err.splitlines()) == 1
    check_no_partial_files(out)
    traj = tb.load_trajectory(out / "trajectory.npz")
    summary = json.loads((out / "summary.json").read_text())["run"]
    assert summary["status"] == "interrupted" and summary["signal"] == sig.name
    ckpt = tb.Simulator.load_checkpoint(out / "checkpoint.npz")
    # every finished frame: the checkpoint is at the last one, and the file holds all before it
    assert traj.frame_count == summary["frames"] == ckpt.checkpoint_run["frames"] >= 5
    np.testing.assert_array_equal(traj.time, np.arange(traj.frame_count) * 0.25)
    assert ckpt.world.t == traj.time[-1]
    assert not list(out.glob(".*.tmp"))
    if sig == signal.SIGINT:
        check_resume_matches(scene, out, traj.frame_count, tmp_path)


@pytest.mark.slow
def test_sigkill_leaves_every_frame_up_to_the_last_flush(tmp_path):
    scene, out, proc = start_and_wait_for_checkpoints(tmp_path)
    proc.kill()
    proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGKILL
    check_no_partial_files(out)
    traj = tb.load_trajectory(out / "trajectory.npz")
    ckpt = tb.Simulator.load_checkpoint(out / "checkpoint.npz")
    kept = ckpt.checkpoint_run["frames"]
    # flushed in the order trajectory, checkpoint: the file holds at least the checkpoint's frames
    assert traj.frame_count >= kept >= 5 and (traj.frame_count - 1) % 2 == 0
    np.testing.assert_array_equal(traj.time, np.arange(traj.frame_count) * 0.25)
    check_resume_matches(scene, out, kept, tmp_path)


# ---------------------------------------------------------------------- memory

MEMORY_BODIES = 10_000


def free_bodies_scene(path: Path):
    rng = np.random.default_rng(1)
    bodies = [{"name": f"b{i}", "shape": {"type": "box", "size": [0.2, 0.4, 0.8]}, "mass": 1.0,
               "position": [float(i % 100), float(i // 100), 0.0], "velocity": rng.normal(size=3).round(3).tolist(),
               "angular_velocity": rng.normal(scale=3, size=3).round(3).tolist()} for i in range(MEMORY_BODIES)]
    doc = {"simulation": {"duration": 10.0, "frame_rate": 1, "dt": 0.1, "integrator": "rk4", "gravity": [0, 0, 0]}, "bodies": bodies}
    path.write_text(json.dumps(doc))
    return path


def peak_rss_kib(scene, out, duration):
    code = ("import resource, sys\nfrom tumble.cli import main\n"
            f"rc = main(['run', {str(scene)!r}, '--out', {str(out)!r}, '--duration', '{duration}', '--checkpoint-every', '20', '--no-progress'])\n"
            "print('MAXRSS', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, rc)\n")
    r = subprocess.run([sys.executable, "-c", code], env=env(), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    _, kib, rc = r.stdout.strip().splitlines()[-1].split()
    assert rc == "0"
    return int(kib)


@pytest.mark.slow
def test_peak_memory_of_a_10000_body_run_does_not_grow_with_its_duration(tmp_path):
    scene = free_bodies_scene(tmp_path / "free.json")
    short = peak_rss_kib(scene, tmp_path / "s", 10)
    long = peak_rss_kib(scene, tmp_path / "l", 60)
    frames_extra_mib = 50 * MEMORY_BODIES * 19 * 8 / 2**20  # what 50 more in-memory frames would cost: 72 MiB
    print(f"peak RSS: {short / 1024:.1f} MiB at 10 s, {long / 1024:.1f} MiB at 60 s of simulated time")
    assert tb.load_trajectory(tmp_path / "l" / "trajectory.npz").frame_count == 61
    assert (long - short) / 1024 < 0.25 * frames_extra_mib, (short, long)


# ---------------------------------------------------------------------- hostile mesh files and sizes


@pytest.mark.parametrize("name, content, expected", [
    ("empty.stl", b"", "mesh file is empty"),
    ("garbage.stl", b"\x00\xffnot a mesh at all" * 10, "cannot read mesh file|mesh file holds no triangles"),
    ("broken.obj", b"v 0 0 0\nv 1 0 0\nf 1 2 7\n", "cannot read mesh file|mesh file holds no triangles|not closed|no volume"),
    ("flat.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "not closed|no volume|edge"),
])
def test_broken_empty_mesh_files_are_one_line_errors(tmp_path, name, content, expected):
    (tmp_path / name).write_bytes(content)
    scene = tmp_path / "s.toml"
    scene.write_text(f'[[bodies]]\nname = "m"\nshape = {{ type = "mesh", path = "{name}" }}\nmass = 1\n')
    with pytest.raises(tb.InputError) as info:
        load_scene(scene)
    line = str(info.value)
    assert "\n" not in line and line.startswith(f"{scene}: bodies[0].shape.path: ")
    import re

    assert re.search(expected, line), line


def test_huge_files_and_counts_are_refused_before_reading(tmp_path, monkeypatch):
    (tmp_path / "big.stl").write_bytes(b"solid x\n" + b" " * 200_000)
    scene = tmp_path / "s.toml"
    scene.write_text('[[bodies]]\nname = "m"\nshape = { type = "mesh", path = "big.stl" }\nmass = 1\n')
    monkeypatch.setenv("TUMBLE_MAX_MEMORY", "4M")
    with pytest.raises(tb.InputError, match=r"bodies\[0\].shape.path: reading the 195 KiB mesh file .* would need about 7.63 MiB, "
                                            r"above the memory limit of 4 MiB \(set TUMBLE_MAX_MEMORY"):
        load_scene(scene)
    doc = {"bodies": [{"name": f"b{i}", "shape": {"type": "sphere", "radius": 1}, "mass": 1} for i in range(2000)]}
    with pytest.raises(tb.InputError, match=r"^bodies: 2000 bodies with 0 particles and mesh rows would need about 7.81 MiB"):
        tb.scene.parse_scene(doc)
    (tmp_path / "huge.json").write_text(json.dumps(doc))
    with pytest.raises(tb.InputError, match=r"huge.json: reading this .* scene file would need about"):
        load_scene(tmp_path / "huge.json")
    r = subprocess.run([sys.executable, "-m", "tumble.cli", "run", str(tmp_path / "huge.json"), "--max-memory", "1M"], env=env(),
                       capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1 and "above the memory limit of 1 MiB" in r.stderr, r.stderr


def test_runs_without_checkpoint_every_still_flush_on_the_wall_clock(tmp_path, monkeypatch):
    # Without --checkpoint-every a long run is still flushed every FLUSH_WALL_SECONDS of wall
    # time (so a SIGKILL leaves a loadable trajectory); a short run flushes only at its end.
    import tumble as tb
    from tumble import runfile

    def count_checkpoints(every_seconds, out):
        w = tb.World(gravity=(0, 0, 0))
        w.add_body(tb.Box(size=(0.2, 0.6, 1.0)), mass=2.0, angular_velocity=(2, 1, 3))
        sim = tb.Simulator(w)
        calls = []
        original = sim.save_checkpoint
        monkeypatch.setattr(sim, "save_checkpoint", lambda path, **kw: (calls.append(path), original(path, **kw))[1])
        monkeypatch.setattr(runfile, "FLUSH_WALL_SECONDS", every_seconds)
        sim.run_to_file(out, 1.0, 24)
        return len(calls)

    assert count_checkpoints(60.0, tmp_path / "a") == 1  # the final flush only
    assert count_checkpoints(0.0, tmp_path / "b") == 25  # after each of the 24 frames, and the final one
    assert tb.load_trajectory(tmp_path / "b" / "trajectory.npz").frame_count == 25
