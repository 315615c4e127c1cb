"""Absurd sizes in a scene (an input audit, session 42: its cases H2-H5, H7): one line naming the key the
file has, a plain problem, exit status 2, and nothing else on stderr (no NumPy or trimesh
RuntimeWarning before it). Before: a box of size 1e308 was blamed on ``bodies[1].inertia`` (a key
the file does not have); an OBJ of 1e308 coordinates and a heightfield height of 1e308 printed 22
and 4 warning lines before an internal ``OverflowError`` text; a fractured body of size 1e308 said
``cannot read this value (QhullError: ...)``; a USD Cube of size -1 was accepted."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import tomllib
import warnings
from pathlib import Path

import pytest

import tumble as tb
from tumble.cli import main
from tumble.scene import parse_scene

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SRC = Path(__file__).resolve().parents[1] / "src"

BASE = textwrap.dedent("""\
    [simulation]
    duration = 0.5
    [[bodies]]
    name = "ground"
    shape = { type = "plane" }
    fixed = true
    [[bodies]]
    name = "b"
    shape = { type = "box", size = [0.2, 0.2, 0.2] }
    mass = 1.0
    position = [0, 0, 1]
    """)

HUGE_OBJ = "v 0 0 0\nv 1e308 0 0\nv 0 1e308 0\nv 0 0 1e308\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


def validate_one_line(path, capsys) -> str:
    """``tumble validate PATH``: exit 2, exactly one line on stderr, no warning raised on the way."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code = main(["validate", str(path)])
    captured = capsys.readouterr()
    assert code == 2, captured
    assert captured.err.startswith("tumble: error: ") and captured.err.count("\n") == 1, captured.err
    assert not [w for w in caught if issubclass(w.category, RuntimeWarning)], [str(w.message) for w in caught]
    assert "Traceback" not in captured.err and "cannot read this value" not in captured.err
    assert "Error" not in captured.err.split(": ", 2)[-1]  # no exception's name (OverflowError, QhullError)
    return captured.err


def test_h2_a_box_too_large_for_its_inertia_is_blamed_on_its_size(tmp_path, capsys):
    p = tmp_path / "h2.toml"
    p.write_text(BASE.replace("size = [0.2, 0.2, 0.2]", "size = [1e308, 0.2, 0.2]"))
    err = validate_one_line(p, capsys)
    assert err == f"tumble: error: {p}: bodies[1].shape.size: too large: the shape's mass properties (volume, inertia) " \
                  "overflow a float\n"
    # the library: the same key, relative to add_body's arguments
    with pytest.raises(tb.InputError) as info:
        tb.World().add_body(tb.Cylinder(radius=0.1, length=1e200), mass=1.0)
    assert info.value.key == "shape.length"


def test_h3_a_mesh_file_with_huge_coordinates_is_one_plain_line(tmp_path, capsys):
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "huge.obj").write_text(HUGE_OBJ)
    p = tmp_path / "h3.toml"
    p.write_text(BASE + '[[bodies]]\nname = "m"\nshape = { type = "mesh", path = "m/huge.obj" }\nmass = 1.0\n')
    err = validate_one_line(p, capsys)
    assert err.startswith(f"tumble: error: {p}: bodies[2].shape.path: mesh file ")
    assert "huge.obj: vertex coordinates must be at most 1e+10 m in magnitude, got 1e+308" in err
    # inline vertices and hull points: the same bound
    with pytest.raises(tb.InputError, match="vertices must be at most 1e\\+10 m") as info:
        tb.Mesh(vertices=[[0, 0, 0], [2e10, 0, 0], [0, 1, 0], [0, 0, 1]], faces=[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    assert info.value.key == "vertices"
    with pytest.raises(tb.InputError) as info:
        tb.Convex(points=[[0, 0, 0], [1e300, 0, 0], [0, 1, 0], [0, 0, 1]])
    assert info.value.key == "points"


def test_h3_a_mesh_within_the_bound_still_loads():
    from tumble.shapes import MAX_COORDINATE

    s = 0.5 * MAX_COORDINATE
    m = tb.Mesh(vertices=[[0, 0, 0], [s, 0, 0], [0, s, 0], [0, 0, s]], faces=[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    assert m.vertices.max() == s


def test_h3_no_warning_line_in_the_real_command(tmp_path):
    # the CLI in its own process, as a user runs it: stderr is the error line and nothing else
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "huge.obj").write_text(HUGE_OBJ)
    p = tmp_path / "h3.toml"
    p.write_text(BASE + '[[bodies]]\nname = "m"\nshape = { type = "mesh", path = "m/huge.obj" }\nmass = 1.0\n')
    r = subprocess.run([sys.executable, "-m", "tumble", "validate", str(p)], capture_output=True, text=True,
                       env={"PYTHONPATH": str(SRC), "PATH": "/usr/bin:/bin"}, timeout=120)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "bodies[2].shape.path" in r.stderr, r.stderr


@pytest.mark.parametrize("field, expect", [
    ("heights = [[0, 0], [0, 1e308]]", "bodies[2].shape.heights: heights must be at most 1e+10 m in magnitude, got "
                                       "1e+308 (row 1, column 1)"),
    ("heights = [[0, 0], [0, 1]], size = [1e308, 1]", "bodies[2].shape.size: size must be at most 1e+10 m"),
])
def test_h4_a_heightfield_with_a_huge_value_is_one_plain_line(field, expect, tmp_path, capsys):
    size = "" if "size" in field else ", size = [1, 1]"
    p = tmp_path / "h4.toml"
    p.write_text(BASE + f'[[bodies]]\nname = "t"\nfixed = true\nshape = {{ type = "heightfield"{size}, {field} }}\n')
    err = validate_one_line(p, capsys)
    assert err.startswith(f"tumble: error: {p}: {expect}"), err


def wrecking_ball(shape=None, size0=None) -> dict:
    d = tomllib.loads((EXAMPLES / "wrecking_ball.toml").read_text())
    if shape is not None:
        d["bodies"][1]["shape"] = shape
    if size0 is not None:
        d["bodies"][1]["shape"]["size"][0] = size0
    return d


@pytest.mark.parametrize("change, key, words", [
    ({"size0": 1e308}, "bodies[1].shape.size", "too large to fracture: "),
    ({"size0": 10**30}, "bodies[1].shape.size", "too large to fracture: 1e+30 m across (at most 1e+10 m)"),
    ({"shape": {"type": "sphere", "radius": 1e308}}, "bodies[1].shape.radius", "too large to fracture"),
])
def test_h5_a_fractured_body_too_large_is_a_plain_keyed_line(change, key, words):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(tb.InputError) as info:
            parse_scene(wrecking_ball(**change), "wrecking_ball.toml", EXAMPLES)
    assert info.value.key == key and words in info.value.problem, str(info.value)
    assert "Qhull" not in str(info.value) and "cannot read" not in str(info.value)


def test_h5_a_fractured_body_too_thin_to_cut_is_refused_not_sampled_forever():
    # a wall 1e-9 m thick: no random point lies inside it at the sampler's margin; the search used to
    # go on for ever (in its own process, so that the old code's endless loop fails the test)
    code = ("import tomllib, tumble as tb\nfrom tumble.scene import parse_scene\n"
            f"d = tomllib.loads(open({str(EXAMPLES / 'wrecking_ball.toml')!r}).read())\n"
            "d['bodies'][1]['shape']['size'][1] = 1e-9\n"
            "try:\n    parse_scene(d, 'w.toml', '.')\nexcept tb.InputError as e:\n    print(e)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                       env={"PYTHONPATH": str(SRC), "PATH": "/usr/bin:/bin"})
    assert r.stdout.startswith("w.toml: bodies[1].shape.size: too thin to cut into cells"), (r.stdout, r.stderr)
    assert r.stderr == ""


USD_CASES = [  # (replace this, with this, once): the prim and attribute named in the line
    ("double size = 1", "double size = -1", "/World/ground: size: must be positive, got -1"),
    ("double radius = 10", "double radius = -10", "/World/ball: radius: must be positive, got -10"),
    ("double size = 1", "double size = nan", "/World/ground: size: must be positive, got nan"),
]


@pytest.mark.parametrize("old, new, words", USD_CASES)
def test_h7_a_usd_shape_of_negative_size_is_refused(old, new, words, tmp_path, capsys):
    pytest.importorskip("pxr")
    text = (EXAMPLES / "usd" / "catapult.usda").read_text()
    assert old in text
    p = tmp_path / "h7.usda"
    p.write_text(text.replace(old, new, 1))
    with pytest.raises(tb.InputError) as info:
        tb.load_usd(tb.World(), p)
    assert str(info.value) == f"{p}: {words}"
    err = validate_one_line(p, capsys)
    assert err.endswith(f"{words}\n"), err
