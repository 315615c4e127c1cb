"""Property-based tests of the scene loader (hypothesis): random and malformed scenes never end in a
traceback (>= 2000 generated inputs in all; every rejection is one ``InputError`` line, and
status 2 with one line through the CLI), and random valid scenes keep the invariants."""

import contextlib
import copy
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tumble.cli import main as cli_main
from tumble.errors import InputError
from tumble.scene import load_scene, parse_scene

FILE = "fuzz.toml"
SETTINGS = dict(deadline=None, database=None, derandomize=True, suppress_health_check=list(HealthCheck))

BASE = {
    "simulation": {"duration": 0.5, "frame_rate": 24, "dt": 1 / 240, "integrator": "rk4", "gravity": [0, 0, -9.81]},
    "bodies": [
        {"name": "box", "shape": {"type": "box", "size": [0.2, 0.6, 1.0]}, "mass": 2.0, "position": [0, 0, 1],
         "angular_velocity": [0.01, 5, 0.01], "angular_velocity_frame": "body",
         "material": {"friction": 0.5, "restitution": 0.3, "rolling_resistance": 0.01, "spinning_friction": 0.001},
         "collision_filter": {"category": 2, "mask": 3, "group": -1}},
        {"name": "ell", "shape": {"type": "particles", "points": [[0, 0, 0], [0.1, 0, 0], [0, 0.2, 0]], "masses": [1, 2, 3]},
         "euler_deg": [10, 20, 30], "velocity": [1, 0, 0]},
        {"name": "hull", "shape": {"type": "convex", "points": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]]}, "density": 100},
        {"name": "tet", "shape": {"type": "mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
                                  "faces": [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]}, "mass": 1.0, "inertia": [1, 1, 1]},
        {"name": "ground", "shape": {"type": "plane", "normal": [0, 0, 1], "offset": 0}, "fixed": True},
        {"name": "sheet", "shape": {"type": "mesh", "vertices": [[0, 0, 0], [1, 0, 0], [1, 1, 0.2], [0, 1, 0]],
                                    "faces": [[0, 1, 2], [0, 2, 3]], "closed": False}, "fixed": True, "position": [0, -3, 0.5]},
        {"name": "rod", "shape": {"type": "capsule", "radius": 0.1, "length": 1.0}, "mass": 1.0, "orientation": [1, 0, 0, 0],
         "gravity_scale": 0.5, "linear_damping": 0.04, "angular_damping": 0.1},
        {"name": "ghost", "shape": {"type": "sphere", "radius": 0.1}, "mass": 0.5, "position": [-3, 0, 1],
         "enable_at": [0.1, 0.3], "disable_at": 0.2},
        {"name": "belt", "shape": {"type": "box", "size": [2, 1, 0.1]}, "kinematic": True, "velocity": [0.5, 0, 0],
         "angular_velocity": [0, 0, 0.1], "surface_velocity": [0, 1, 0]},
        {"name": "zone", "shape": {"type": "box", "size": [1, 1, 1]}, "fixed": True, "sensor": True, "position": [0, 0, 0.5]},
        {"name": "slab", "shape": {"type": "box", "size": [0.6, 0.1, 0.4]}, "density": 2000, "position": [0, 3, 0.2],
         "fracture": {"pieces": 4, "seed": 2, "strength": 1e6, "min_face": 0.1}},
        {"name": "lift", "shape": {"type": "sphere", "radius": 0.2}, "kinematic": True,
         "path": {"times": [0, 0.25, 0.5], "positions": [[3, 0, 0], [3, 0, 1], [3, 1, 1]],
                  "euler_deg": [[0, 0, 0], [0, 0, 90], [0, 0, 0]], "repeat": True}},
    ],
    "forces": [
        {"type": "drag", "linear": 0.1, "bodies": ["box"]},
        {"type": "wind", "velocity": [0, 3, 0], "linear": 0.3},
        {"type": "constant", "body": "box", "force": [0, 0, 19.62], "torque": [0, 0, 0]},
        {"type": "point", "body": "rod", "force": [1, 0, 0], "point": [0, 0, 0.5], "frame": "body"},
        {"type": "spring", "body_a": "ell", "body_b": "box", "anchor_a": [0, 0, 0], "stiffness": 20, "damping": 0.1, "rest_length": 1},
        {"type": "impulse", "body": "rod", "impulse": [0, 1, 0], "time": 0.1},
        {"type": "explosion", "position": [0, 0, 0.5], "radius": 1.0, "falloff": 0.5, "impulse_per_area": 2.0,
         "time": 0.2, "mask": 3},
        {"type": "buoyancy", "density": 1000, "level": 0.3, "linear": 1, "quadratic": 0.5, "angular_linear": 0.1,
         "angular_quadratic": 0.1, "flow": [0.1, 0, 0]},
    ],
    "collision_exclusions": [{"bodies": ["box", "rod"]}],
    "joints": [
        {"type": "hinge", "name": "h1", "body_a": "rod", "anchor": [0, 0, 1], "axis": [0, 1, 0], "lower_deg": -90,
         "upper_deg": 90, "torque": 0.1},
        {"type": "slider", "name": "s1", "body_a": "hull", "anchor": [0, 0, 0], "axis": [1, 0, 0], "armature": 0.1},
        {"type": "gear", "name": "g1", "joint": "s1", "follows": "h1", "ratio": 0.5, "offset": 0.01},
        {"type": "gear", "joint": "h1", "polynomial": [0.1]},
        {"type": "ball", "name": "b1", "body_a": "world", "body_b": "tet", "anchor": [0, 0, 0.5], "stiffness": 3.0,
         "damping": 0.1, "target": [0.1, 0.2, 0.3], "target_velocity": [0, 0, 0.5], "max_drive_torque": 10.0,
         "cone_limit_deg": 60},
    ],
    "joint_solver": {"method": "tree", "hertz": 0},
    "cameras": [{"name": "cam", "position": [0, 0, 0.5], "target": [1, 0, 0.5], "width": 8, "height": 6, "body": "box",
                 "track": "point"}],
}

scalars = st.one_of(
    st.none(), st.booleans(), st.integers(), st.integers(min_value=-2**70, max_value=2**70) | st.just(10**400),
    st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0, -1, 1e-300, 1e300, 0.5, 3, 24, 240]),
    st.text(max_size=12), st.sampled_from(["box", "sphere", "rk4", "spring", "drag", "mesh", "convex", "particles", "plane",
                                            "world", "body", "quaternion", "matrix", "__import__('os')", "box2", ""]),
)
values = st.recursive(scalars, lambda inner: st.lists(inner, max_size=5) | st.dictionaries(st.text(max_size=8) | st.sampled_from(
    ["type", "name", "shape", "mass", "bodies", "size", "radius", "points", "masses", "body_a", "forces", "simulation"]), inner, max_size=5),
    max_leaves=20)


def paths(doc, prefix=()):
    """Every path into the document (dict keys and list indices)."""
    yield prefix
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from paths(v, prefix + (i,))


ALL_PATHS = list(paths(BASE))[1:]


@st.composite
def mutated_scenes(draw):
    doc = copy.deepcopy(BASE)
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(ALL_PATHS))
        parent = doc
        try:
            for k in path[:-1]:
                parent = parent[k]
            action = draw(st.sampled_from(["replace", "delete", "add", "wrap"]))
            last = path[-1]
            if action == "replace":
                parent[last] = draw(values)
            elif action == "delete":
                del parent[last]
            elif action == "wrap":
                parent[last] = [parent[last]]
            elif isinstance(parent, dict):
                parent[draw(st.text(max_size=6))] = draw(values)
            else:
                parent.append(draw(values))
        except (KeyError, IndexError, TypeError, AttributeError):
            continue  # an earlier mutation removed or replaced this path (e.g. by null)
    return doc


COUNT = {"inputs": 0}


def check_loader(doc):
    """parse_scene accepts the document or raises InputError with one line naming the file; nothing else."""
    COUNT["inputs"] += 1
    try:
        parse_scene(doc, FILE)
    except InputError as err:
        line = str(err)
        assert "\n" not in line and line.startswith(f"{FILE}: "), line
        assert "Traceback" not in line


def run_examples(test, n):
    before = COUNT["inputs"]
    test()
    assert COUNT["inputs"] - before >= n


def test_loader_on_arbitrary_documents():
    @settings(max_examples=700, **SETTINGS)
    @given(values | st.dictionaries(st.sampled_from(["simulation", "bodies", "forces", "extra"]), values, max_size=3))
    def inner(doc):
        check_loader(doc)

    run_examples(inner, 700)


def test_loader_on_mutated_valid_scenes():
    @settings(max_examples=1100, **SETTINGS)
    @given(mutated_scenes())
    def inner(doc):
        check_loader(doc)

    run_examples(inner, 1100)


VALID_TOML = Path(__file__).resolve().parents[1] / "examples" / "wind_springs.toml"


@st.composite
def mutated_texts(draw):
    text = VALID_TOML.read_bytes()
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, len(text)))
        kind = draw(st.sampled_from(["insert", "delete", "replace"]))
        chunk = draw(st.binary(max_size=8) | st.sampled_from([b"[", b"]", b"{", b"=", b'"', b"\n", b"nan", b"1e999", b"[[bodies]]", b"\xff", b"[" * 2000]))
        if kind == "insert":
            text = text[:i] + chunk + text[i:]
        elif kind == "delete":
            text = text[:i] + text[i + len(chunk):]
        else:
            text = text[:i] + chunk + text[i + len(chunk):]
    return text


def test_loader_on_mutated_files(tmp_path):
    path = tmp_path / FILE

    @settings(max_examples=300, **SETTINGS)
    @given(mutated_texts())
    def inner(raw):
        COUNT["inputs"] += 1
        path.write_bytes(raw)
        try:
            load_scene(path)
        except InputError as err:
            assert "\n" not in str(err) and str(err).startswith(f"{path}"), str(err)

    run_examples(inner, 300)


def test_at_least_2000_generated_inputs_in_all():
    # the three tests above run first (file order); each also checks its own count
    assert COUNT["inputs"] >= 2000 or os.environ.get("PYTEST_XDIST_WORKER")


def test_a_sample_through_the_cli_is_status_2_with_one_line(tmp_path):
    path = tmp_path / "s.json"
    rejected = []

    @settings(max_examples=60, **SETTINGS)
    @given(mutated_scenes())
    def inner(doc):
        try:
            text = json.dumps(doc, allow_nan=False)
        except ValueError:
            return
        path.write_text(text)
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            status = cli_main(["validate", str(path)])
        if status != 0:
            assert status == 2
            lines = err.getvalue().splitlines()
            assert len(lines) == 1 and lines[0].startswith(f"tumble: error: {path}: "), err.getvalue()
            assert out.getvalue() == ""
            rejected.append(text)

    inner()
    assert len(rejected) >= 20
    # a few in real processes: exit status, one line, no traceback, no warnings
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1] / "src"))
    for k, text in enumerate(rejected[:3]):
        p = tmp_path / f"bad{k}.json"
        p.write_text(text)
        r = subprocess.run([sys.executable, "-m", "tumble.cli", "run", str(p), "--out", str(tmp_path / "o")], env=env,
                           capture_output=True, text=True, timeout=120)
        assert r.returncode == 2 and len(r.stderr.splitlines()) == 1 and r.stderr.startswith("tumble: error: "), r.stderr


def test_scene_files_are_data_only(tmp_path):
    marker = tmp_path / "pwned"
    path = tmp_path / "s.toml"
    path.write_text(f'[[bodies]]\nname = "b"\nshape = {{ type = "sphere", radius = "__import__(\'os\').system(\'touch {marker}\')" }}\nmass = 1\n')
    with pytest.raises(InputError, match=r"bodies\[0\].shape.radius: expected a number, got"):
        load_scene(path)
    assert not marker.exists()


# ---------------------------------------------------------------------- random valid scenes

vec = lambda lo, hi: st.lists(st.floats(lo, hi, allow_nan=False), min_size=3, max_size=3)  # noqa: E731
shapes = st.one_of(
    st.builds(lambda r: {"type": "sphere", "radius": r}, st.floats(0.05, 1.0)),
    st.builds(lambda s: {"type": "box", "size": s}, vec(0.05, 1.0)),
    st.builds(lambda r, l: {"type": "capsule", "radius": r, "length": l}, st.floats(0.05, 0.5), st.floats(0.05, 1.0)),
    st.builds(lambda r, l: {"type": "cylinder", "radius": r, "length": l}, st.floats(0.05, 0.5), st.floats(0.05, 1.0)),
    st.builds(lambda r: {"type": "ellipsoid", "radii": r}, vec(0.05, 1.0)),
    # a tetrahedron of particles, jittered (never flat: a valid body has positive principal moments)
    st.builds(lambda jit, m: {"type": "particles", "points": (np.array([[0, 0, 0], [0.3, 0, 0], [0, 0.3, 0], [0, 0, 0.3]]) + jit).tolist(),
                              "masses": m}, st.lists(vec(-0.05, 0.05), min_size=4, max_size=4), st.lists(st.floats(0.2, 2), min_size=4, max_size=4)),
)


@st.composite
def valid_scenes(draw):
    n = draw(st.integers(2, 5))
    bodies = []
    for i in range(n):
        b = {"name": f"b{i}", "shape": draw(shapes), "position": draw(vec(-2, 2)), "velocity": draw(vec(-2, 2)),
             "angular_velocity": draw(vec(-5, 5)), "euler_deg": draw(vec(-180, 180))}
        if b["shape"]["type"] != "particles":
            b["mass"] = draw(st.floats(0.5, 5.0))
        bodies.append(b)
    forces = []
    for _ in range(draw(st.integers(1, 4))):
        a, b = draw(st.lists(st.integers(0, n - 1), min_size=2, max_size=2, unique=True))
        forces.append({"type": "spring", "body_a": f"b{a}", "body_b": f"b{b}", "anchor_a": draw(vec(-0.05, 0.05)),
                       "anchor_b": draw(vec(-0.05, 0.05)), "stiffness": draw(st.floats(0, 50)), "damping": draw(st.floats(0, 0.5))})
    integrator = draw(st.sampled_from(["rk4", "splitting", "midpoint", "semi-implicit-euler"]))
    return {"simulation": {"duration": 0.25, "integrator": integrator, "gravity": [0, 0, 0]}, "bodies": bodies, "forces": forces}


def test_random_valid_scenes_keep_the_invariants():
    @settings(max_examples=100, **SETTINGS)
    @given(valid_scenes())
    def inner(doc):
        scene = parse_scene(doc, FILE)
        traj = scene.run(progress=False)
        w = scene.world
        assert np.all(np.isfinite(w.pack()))
        assert np.abs(np.linalg.norm(traj.orientation, axis=2) - 1).max() < 1e-12
        # springs between free bodies only: total linear momentum is conserved (equal and opposite forces)
        P = traj.total_linear_momentum
        scale = 1.0 + np.abs(traj.linear_momentum).max()
        assert np.abs(P - P[0]).max() <= 1e-10 * scale, np.abs(P - P[0]).max()
        # (energy is not asserted: first-order integrators on stiff random springs drift by design)

    inner()
