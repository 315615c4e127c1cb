"""A refused ``tumble run`` / ``tumble demo`` / ``tumble run --resume`` changes nothing on disk (input audit,
groups D and E): every check that can refuse the run (the frame plan, --checkpoint-every, the disk,
a resumed run's record) is made before anything is written or removed. The refusal is one line
``tumble: error: FILE: KEY: problem`` and exit status 2; the output folder keeps its files, names and
bytes (a new one is not created), and the corrected command then works without --force."""

import collections
import json
from pathlib import Path

import numpy as np
import pytest

import tumble as tb
from tumble import runfile
from tumble.cli import main

SCENE = """
[simulation]
duration = 1.0
integrator = "rk4"

[[bodies]]
name = "box"
shape = { type = "box", size = [0.2, 0.6, 1.0] }
mass = 2.0
angular_velocity = [0.01, 5, 0.01]

[[bodies]]
name = "ball"
shape = { type = "sphere", radius = 0.1 }
mass = 1.0
position = [1, 0, 0]
"""

Usage = collections.namedtuple("Usage", "total used free")


def tree(folder):
    """Names and bytes of everything below ``folder`` (folders as None), or None when it does not exist."""
    folder = Path(folder)
    if not folder.exists():
        return None
    return {str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else None) for p in sorted(folder.rglob("*"))}


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "spin.toml"
    path.write_text(SCENE)
    return path


@pytest.fixture
def small_disk(monkeypatch):
    """A disk with 1 KiB free: every trajectory is refused by the disk check."""
    monkeypatch.setattr(runfile.shutil, "disk_usage", lambda path: Usage(10**12, 10**12 - 1024, 1024))


def refusal(capsys, start: str) -> str:
    captured = capsys.readouterr()
    err = captured.err.splitlines()
    assert len(err) == 1 and err[0].startswith(start), captured.err
    assert "Traceback" not in captured.err
    return err[0]


# ------------------------------------------------------------------ D: nothing written before the last check


def test_refused_run_leaves_no_new_folder_and_the_retry_works(tmp_path, scene, capsys, monkeypatch):
    """D1: a run refused by the disk check wrote NEW/scene.toml first, and the corrected command was then
    refused with "scene.toml: exists (pass --force to overwrite)" though no run had happened."""
    out = tmp_path / "new"
    monkeypatch.setattr(runfile.shutil, "disk_usage", lambda path: Usage(10**12, 10**12 - 1024, 1024))
    assert main(["run", str(scene), "--out", str(out), "--duration", "0.5", "--no-progress"]) == 2
    refusal(capsys, f"tumble: error: {out}: the trajectory would need about ")
    assert tree(out) is None
    monkeypatch.undo()  # the disk as it is
    assert main(["run", str(scene), "--out", str(out), "--duration", "0.5", "--no-progress"]) == 0
    assert sorted(tree(out)) == ["checkpoint.npz", "scene.toml", "summary.json", "trajectory.npz"]


def test_refused_forced_run_keeps_the_previous_run(tmp_path, scene, capsys, monkeypatch):
    """D2: ``--force`` with a refused run over a finished one deleted its trajectory.glb and replaced its
    scene.toml, next to the old trajectory and summary. Now the folder is as it was, bytes and names."""
    out = tmp_path / "run"
    assert main(["run", str(scene), "--out", str(out), "--duration", "0.25", "--gltf", "--no-progress"]) == 0
    before = tree(out)
    assert "trajectory.glb" in before
    other = tmp_path / "other.toml"
    other.write_text(SCENE.replace("mass = 2.0", "mass = 3.0"))
    capsys.readouterr()
    monkeypatch.setattr(runfile.shutil, "disk_usage", lambda path: Usage(10**12, 10**12 - 1024, 1024))
    assert main(["run", str(other), "--out", str(out), "--duration", "0.5", "--force", "--no-progress"]) == 2
    refusal(capsys, f"tumble: error: {out}: the trajectory would need about ")
    assert tree(out) == before


def test_refused_demo_changes_nothing(tmp_path, small_disk, capsys):
    """``tumble demo`` shares the path: a refused demo creates no folder, and over a folder with --force
    it leaves the files there (here one of the user's and an old scene.toml) as they were."""
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--duration", "0.5", "--no-media", "--no-progress"]) == 2
    refusal(capsys, f"tumble: error: {out}: the trajectory would need about ")
    assert tree(out) is None
    out.mkdir()
    (out / "scene.toml").write_text("# an older run's\n")
    (out / "trajectory.glb").write_bytes(b"glTF old")
    before = tree(out)
    assert main(["demo", "--out", str(out), "--duration", "0.5", "--no-media", "--force", "--no-progress"]) == 2
    refusal(capsys, f"tumble: error: {out}: the trajectory would need about ")
    assert tree(out) == before


# ------------------------------------------------------------------ E: a resumed run's record is checked


def _doctored(tmp_path, scene, capsys, edit):
    """A run of 0.25 s with a checkpoint, its checkpoint's run record (``meta.run``) changed by ``edit``."""
    out = tmp_path / "run"
    assert main(["run", str(scene), "--out", str(out), "--duration", "0.25", "--checkpoint-every", "0.125",
                 "--no-progress"]) == 0
    capsys.readouterr()
    path = out / "checkpoint.npz"
    with np.load(path, allow_pickle=False) as data:
        arrays = dict(data)
    meta = json.loads(str(arrays["meta"]))
    edit(meta)
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(path, **arrays)
    return out


def _put(value, *keys):
    def edit(meta):
        d = meta
        for k in keys[:-1]:
            d = d[k]
        d[keys[-1]] = value
    return edit


def _pop(*keys):
    def edit(meta):
        d = meta
        for k in keys[:-1]:
            d = d[k]
        del d[keys[-1]]
    return edit


DAMAGED = [  # audit case, edit of meta, the key the line names
    ("E1", _put([1, 2], "run"), "run"),
    ("E2", _put("x", "run"), "run"),
    ("no-run", _put(None, "run"), "run"),
    ("E3", _pop("run", "frame_rate"), "run.frame_rate"),
    ("E4", _pop("run", "figures"), "run.figures"),
    ("E5", _put([1], "run", "figures"), "run.figures"),
    ("figure", _put("x", "run", "figures", "wall_time_s"), "run.figures.wall_time_s"),
    ("E6", _pop("run", "t_start"), "run.t_start"),
    ("E7", _put("four", "run", "frames"), "run.frames"),
    ("frames-float", _put(2.5, "run", "frames"), "run.frames"),
    ("E8", _put([[1]], "run", "enabled_changes"), "run.enabled_changes[0]"),
    ("fixed", _put([True], "run", "fixed"), "run.fixed"),
    ("duration", _put(-1, "run", "duration"), "run.duration"),
    ("every", _put("often", "run", "checkpoint_every"), "run.checkpoint_every"),
    ("E9", _put([1], "run", "info", "settings"), "run.info.settings"),
    ("E10", _pop("run", "info", "label"), "run.info.label"),
    ("E11", _pop("run", "info", "copy"), "run.info.copy"),
    ("copy-path", _put("../../x.toml", "run", "info", "copy"), "run.info.copy"),
    ("info", _put(7, "run", "info"), "run.info"),
    ("E12", _put("fast", "run", "frame_rate"), "run.frame_rate"),
    ("E12-negative", _put(-24, "run", "frame_rate"), "run.frame_rate"),
]


@pytest.mark.parametrize("case, edit, key", DAMAGED, ids=[c[0] for c in DAMAGED])
def test_resume_refuses_a_damaged_run_record_before_writing(tmp_path, scene, capsys, case, edit, key):
    """E1-E12: ``tumble run --resume DIR`` read the checkpoint's run record unchecked: tracebacks
    (AttributeError, KeyError, TypeError, ValueError), E11 rewrote the run's files before its KeyError,
    E12 blamed ``simulation.duration`` and no file. Now: one line naming the checkpoint and the
    record's key, exit 2, the folder as it was."""
    out = _doctored(tmp_path, scene, capsys, edit)
    before = tree(out)
    assert main(["run", "--resume", str(out), "--duration", "0.5", "--no-progress"]) == 2
    refusal(capsys, f"tumble: error: {out / 'checkpoint.npz'}: {key}: ")
    assert tree(out) == before


@pytest.mark.parametrize("entry", ["settings", "names"])
def test_resume_names_an_entry_missing_from_the_checkpoint(tmp_path, scene, capsys, entry):
    """An entry the rebuild needs taken out of the checkpoint's record: one line naming it (it said
    "checkpoint does not rebuild (KeyError: 'settings')"), exit 2, the folder as it was."""
    out = _doctored(tmp_path, scene, capsys, _pop(entry))
    before = tree(out)
    assert main(["run", "--resume", str(out), "--duration", "0.5", "--no-progress"]) == 2
    refusal(capsys, f"tumble: error: {out / 'checkpoint.npz'}: {entry}: missing from the checkpoint")
    assert tree(out) == before


def test_resume_of_an_intact_record_still_continues(tmp_path, scene, capsys):
    """The checks accept what tumble run writes: the same run resumes to its end."""
    out = _doctored(tmp_path, scene, capsys, lambda meta: None)
    assert main(["run", "--resume", str(out), "--duration", "0.5", "--no-progress"]) == 0
    assert tb.load_trajectory(out / "trajectory.npz").frame_count == 13


def test_library_resume_refuses_a_damaged_record(tmp_path, scene, capsys):
    """``Simulator.run_to_file(resume=True)`` checks the record too (InputError naming file and key)
    and writes nothing."""
    out = _doctored(tmp_path, scene, capsys, _put("four", "run", "frames"))
    before = tree(out)
    sim = tb.Simulator.load_checkpoint(out / "checkpoint.npz")
    with pytest.raises(tb.InputError) as err:
        sim.run_to_file(out, 0.5, 24.0, resume=True)
    assert str(err.value).startswith(f"{out / 'checkpoint.npz'}: run.frames: ")
    assert tree(out) == before


WORLD_RECORD = [  # the simulator's own entries, read by load_checkpoint and used only once the run goes on
    ("stats-steps", _put("x", "stats", "steps"), "stats.steps"),
    ("stats-table", _put([1], "stats"), "stats"),
    ("energy-reference", _put("x", "energy_reference"), "energy_reference"),
    ("energy-reference-short", _put([1.0], "energy_reference"), "energy_reference"),
]


@pytest.mark.parametrize("case, edit, key", WORLD_RECORD, ids=[c[0] for c in WORLD_RECORD])
def test_resume_refuses_damaged_statistics_before_writing(tmp_path, scene, capsys, case, edit, key):
    """A checkpoint's ``energy_reference`` or ``stats`` damaged: a ValueError (energy check) or TypeError
    (step count) traceback once the run went on, or a line without the key (``stats`` not a table).
    Now load_checkpoint refuses them: one line naming the file and key, the folder as it was."""
    out = _doctored(tmp_path, scene, capsys, edit)
    before = tree(out)
    assert main(["run", "--resume", str(out), "--duration", "0.5", "--no-progress"]) == 2
    refusal(capsys, f"tumble: error: {out / 'checkpoint.npz'}: checkpoint does not rebuild: {key}: ")
    assert tree(out) == before
