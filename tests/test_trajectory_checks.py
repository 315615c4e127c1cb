"""A trajectory file whose values cannot be drawn (NaN positions or times, times not increasing,
orientations that are not unit quaternions, a shape text that is not a shape) is refused when it is
loaded for export, render, plot or view: one line ``FILE: KEY: problem``, exit status 2, no output
file (an input audit, session 42: its cases F1-F5). Before, export failed inside ``json.dumps`` with a
traceback (F1-F4) or wrote an invalid glTF (F5)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import tumble as tb
from tumble.cli import main
from tumble.export import export_gltf
from tumble.shapes import Box, Sphere, shape_to_dict
from tumble.trajectory import Trajectory, frame_shapes, load_trajectory


def good_arrays(frames: int = 6, bodies: int = 2) -> dict:
    """The arrays of a small valid trajectory (two bodies falling), built without a run."""
    t = np.arange(frames) / 24.0
    values = {k: np.zeros((frames,) + s) for k, s in frame_shapes(bodies).items()}
    values["time"] = t
    values["position"][:, :, 2] = 1.0 - 0.5 * 9.81 * t[:, None] ** 2
    values["position"][:, 1, 0] = 0.5
    values["orientation"][..., 0] = 1.0
    table = np.array([json.dumps(shape_to_dict(Box(size=(0.2, 0.2, 0.2)))), json.dumps(shape_to_dict(Sphere(0.1)))])
    return dict(values, names=np.array(["box", "ball"]), com_offset=np.zeros((bodies, 3)), shape_table=table,
                shape_index=np.array([0, 1], dtype=np.int64), fixed=np.zeros(bodies, dtype=bool))


def nan_position(z):
    z["position"][3, 1, 2] = np.nan


def nan_time(z):
    z["time"][2] = np.nan


def zero_orientation(z):
    z["orientation"][:] = 0.0


def time_decreasing(z):
    z["time"] = z["time"][::-1].copy()


def time_repeated(z):
    z["time"][4] = z["time"][3]


def shape_not_json(z):
    z["shape_table"] = np.array(["garbage{", z["shape_table"][1]])


def shape_not_a_shape(z):
    z["shape_table"] = np.array(['{"type": "teapot"}', z["shape_table"][1]])


CASES = {  # name: (change, key, words of the problem)
    "F1 position NaN": (nan_position, "position", "not finite at frame 3, body 1"),
    "F2 time NaN": (nan_time, "time", "not finite at frame 2"),
    "F3 orientation zero": (zero_orientation, "orientation", "not a unit quaternion at frame 0, body 0"),
    "F4 shape_table not JSON": (shape_not_json, "shape_table", "row 0 is not JSON"),
    "F4 shape_table not a shape": (shape_not_a_shape, "shape_table", "row 0 is not a shape"),
    "F5 time decreasing": (time_decreasing, "time", "not increasing at frame 1"),
    "F5 time repeated": (time_repeated, "time", "not increasing at frame 4"),
}


def damaged_file(tmp_path, change) -> "Path":  # noqa: F821
    z = good_arrays()
    change(z)
    path = tmp_path / "run" / "trajectory.npz"
    path.parent.mkdir()
    np.savez(path, **z)
    return path


def one_line(capsys, code) -> str:
    captured = capsys.readouterr()
    assert code == 2, captured
    assert captured.err.startswith("tumble: error: ") and captured.err.count("\n") == 1, captured.err
    assert "Traceback" not in captured.err
    return captured.err


def left_in(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_a_good_trajectory_loads_and_exports(tmp_path, capsys):
    path = damaged_file(tmp_path, lambda z: None)
    traj = load_trajectory(path)
    assert traj.frame_count == 6
    for suffix in (".glb", ".html"):
        assert main(["export", str(path.parent), "-o", str(tmp_path / f"out{suffix}")]) == 0
    assert (tmp_path / "out.glb").read_bytes()[:4] == b"glTF"


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("suffix", [".glb", ".html"])
def test_export_refuses_a_damaged_trajectory_in_one_line(case, suffix, tmp_path, capsys):
    change, key, words = CASES[case]
    path = damaged_file(tmp_path, change)
    out = tmp_path / "out" / f"x{suffix}"
    out.parent.mkdir()
    err = one_line(capsys, main(["export", str(path.parent), "-o", str(out)]))
    assert err.startswith(f"tumble: error: {path}: {key}: "), err
    assert words in err
    assert left_in(out.parent) == []  # no output, no temporary file


@pytest.mark.parametrize("case", ["F1 position NaN", "F4 shape_table not JSON", "F5 time decreasing"])
def test_plot_and_render_refuse_a_damaged_trajectory_in_one_line(case, tmp_path, capsys):
    change, key, words = CASES[case]
    path = damaged_file(tmp_path, change)
    out = tmp_path / "out"
    out.mkdir()
    err = one_line(capsys, main(["plot", str(path), "-o", str(out / "plots")]))
    assert err.startswith(f"tumble: error: {path}: {key}: ") and words in err, err
    err = one_line(capsys, main(["render", str(path), "-o", str(out / "v.mp4"), "--no-progress"]))
    assert err.startswith(f"tumble: error: {path}: {key}: ") and words in err, err
    assert left_in(out) == []


@pytest.mark.parametrize("case", list(CASES))
def test_library_raises_input_error_with_the_key(case, tmp_path):
    change, key, words = CASES[case]
    path = damaged_file(tmp_path, change)
    with pytest.raises(tb.InputError) as info:
        load_trajectory(path)
    assert info.value.key == key and info.value.file == str(path) and words in info.value.problem
    from tumble.viewer.app import load_input  # tumble view's reader

    with pytest.raises(tb.InputError) as info:
        load_input(path)
    assert info.value.key == key
    # an in-memory trajectory given to an exporter: the same check, keyed
    z = good_arrays()
    change(z)
    with pytest.raises(tb.InputError) as info:
        export_gltf(Trajectory(**z), tmp_path / "lib.glb")
    assert info.value.key == key and words in info.value.problem
    assert not (tmp_path / "lib.glb").exists()
    assert load_trajectory(path, check=False).frame_count == 6  # the raw arrays stay readable


def test_a_shape_text_that_cannot_be_drawn_is_one_line(tmp_path, capsys):
    # valid JSON, a known type, parameters no shape has: named as the shape_table row, not a traceback
    def bad_box(z):
        z["shape_table"] = np.array(['{"type": "box", "size": "big"}', z["shape_table"][1]])

    path = damaged_file(tmp_path, bad_box)
    out = tmp_path / "out"
    out.mkdir()
    for name in ("x.glb", "x.html"):
        err = one_line(capsys, main(["export", str(path), "-o", str(out / name)]))
        assert err.startswith(f"tumble: error: {path}: shape_table: row 0 (body 0) is not a shape"), err
    err = one_line(capsys, main(["render", str(path), "-o", str(out / "v.mp4"), "--no-progress"]))
    assert err.startswith(f"tumble: error: {path}: shape_table: row 0 (body 0) is not a shape"), err
    assert left_in(out) == []


def test_positions_beyond_float32_are_refused_by_gltf(tmp_path, capsys):
    # finite in the file, infinite in glTF's float32 accessors: refused, keyed, nothing written
    def far(z):
        z["time"] = z["time"] * 1e300

    path = damaged_file(tmp_path, far)
    out = tmp_path / "out"
    out.mkdir()
    err = one_line(capsys, main(["export", str(path), "-o", str(out / "x.glb")]))
    assert err.startswith(f"tumble: error: {path}: time: too large for glTF's 32-bit floats"), err
    assert left_in(out) == []
