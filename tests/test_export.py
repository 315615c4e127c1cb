"""Tests for tumble.export: glTF (.glb) and USD files of a trajectory, and ``tumble export``.

What is stored (and so what is compared): per body, a transform whose
translation is the centre of mass (``traj.position``) and whose rotation is
``traj.orientation``; the mesh is in the body frame (the shape shifted by
``-com_offset``). glTF keeps the z-up world under a root node rotated -90
degrees about x.

Every example scene (examples/*.toml and the built-in demo), shortened to 1 s,
plus a scene with one body of every shape type, is exported and read back with
readers that are not ours: the Khronos glTF validator (npm ``gltf-validator``),
pygltflib for the .glb's accessors, and pxr (usd-core) for USD.
"""

import dataclasses
import json
import math
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from tumble.cli import main
from tumble.export import export_gltf, export_usd
from tumble.export.meshes import (
    MARKER_RADIUS,
    body_meshes,
    continuous_quaternions,
    fixed_flags,
)
from tumble.math3d import quat_to_matrix
from tumble.scene import load_scene
from tumble.shapes import shape_to_dict

from .determinism.scenes import scene_paths

REPO = Path(__file__).resolve().parents[1]
VALIDATOR_DIR = REPO / ".ci" / "node" / "node_modules" / "gltf-validator"
VALIDATOR_VERSION = "2.0.0-dev.3.10"  # as .ci/setup.d/gltf-validator.sh
VALIDATE_JS = REPO / "tests" / "tools" / "validate_gltf.js"
# the examples of at most 100 bodies (the 1000-box pile and the pyramid would only slow this file down)
SCENES = [p for name, p in sorted(scene_paths().items()) if name != "demo"] + [REPO / "src" / "tumble" / "scenes" / "demo.toml"]
LABELS = [p.stem for p in SCENES] + ["all_shapes", "old_file"]
TOL = 1e-6  # the acceptance tolerance (m for positions, unitless for quaternions)

# One body of every shape type, some off their centre of mass (cone, mesh, convex, particles), two fixed.
ALL_SHAPES = """
[simulation]
duration = 0.5
[[bodies]]
name = "ground"
shape = { type = "plane", normal = [0, 0, 1], offset = -1.0 }
fixed = true
[[bodies]]
name = "ball"
shape = { type = "sphere", radius = 0.2 }
mass = 1.0
position = [0, 0, 1]
[[bodies]]
name = "pill"
shape = { type = "capsule", radius = 0.1, length = 0.4 }
mass = 1.0
position = [1, 0, 1]
angular_velocity = [1, 2, 3]
[[bodies]]
name = "can"
shape = { type = "cylinder", radius = 0.15, length = 0.3 }
mass = 1.0
position = [2, 0, 1]
angular_velocity = [3, 0, 1]
[[bodies]]
name = "cone"
shape = { type = "cone", radius = 0.2, height = 0.5 }
mass = 1.0
position = [3, 0, 1]
euler_deg = [30, 0, 0]
angular_velocity = [0, 3, 1]
[[bodies]]
name = "tet"
shape = { type = "mesh", vertices = [[0,0,0],[1,0,0],[0,1,0],[0,0,1]], faces = [[0,2,1],[0,1,3],[0,3,2],[1,2,3]] }
mass = 1.0
position = [4, 0, 1]
angular_velocity = [2, 2, 0]
[[bodies]]
name = "hull"
shape = { type = "convex", points = [[0,0,0],[0.4,0,0],[0,0.3,0],[0,0,0.2],[0.3,0.3,0.3]] }
mass = 1.0
position = [5, 0, 1]
[[bodies]]
name = "dots"
shape = { type = "particles", points = [[0,0,0],[0.1,0,0],[0,0.1,0]], masses = [1, 2, 3] }
position = [6, 0, 1]
angular_velocity = [0, 0, 5]
[[bodies]]
name = "a pillar/with odd name"
shape = { type = "box", size = [0.2, 0.2, 2] }
fixed = true
position = [0, 2, 0]
euler_deg = [0, 0, 45]
"""


# ---------------------------------------------------------------------- fixtures


@pytest.fixture(scope="module")
def trajectories(tmp_path_factory):
    """{label: Trajectory}: every example scene and the demo run for 1 s, and the all-shapes scene."""
    out = {}
    for path in SCENES:
        scene = load_scene(path)
        scene.duration = 1.0  # 25 frames at 24 fps: enough motion, keeps the file fast
        scene.check()
        out[path.stem] = scene.run(progress=False)
    shapes = tmp_path_factory.mktemp("scenes") / "all_shapes.toml"
    shapes.write_text(ALL_SHAPES)
    out["all_shapes"] = load_scene(shapes).run(progress=False)
    # a file written before trajectories carried shapes and fixed flags: bodies become marker spheres
    out["old_file"] = dataclasses.replace(out["projectile"], shapes=None, fixed=None)
    return out


@pytest.fixture(scope="module")
def glb_files(trajectories, tmp_path_factory):
    folder = tmp_path_factory.mktemp("glb")
    return {label: export_gltf(traj, folder / f"{label}.glb") for label, traj in trajectories.items()}


def _unavailable(message):
    """No node or npm: a failure in CI (CI is set there), a skip on a developer's machine."""
    if os.environ.get("CI"):
        pytest.fail(message)
    pytest.skip(message)


@pytest.fixture(scope="session")
def gltf_validator():
    """The command that runs tests/tools/validate_gltf.js, installing the validator first if needed."""
    node = shutil.which("node")
    if node is None:
        _unavailable("node is not installed: cannot run the Khronos glTF validator")
    if not (VALIDATOR_DIR / "package.json").is_file():  # a fresh clone without .ci/setup.d having run
        npm = shutil.which("npm")
        if npm is None:
            _unavailable("npm is not installed: cannot install the Khronos glTF validator")
        cmd = [npm, "install", "--prefix", str(REPO / ".ci" / "node"), "--no-audit", "--no-fund", "--no-save",
               f"gltf-validator@{VALIDATOR_VERSION}"]
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
        except subprocess.TimeoutExpired:
            _unavailable("npm install gltf-validator timed out")
        if done.returncode != 0 or not (VALIDATOR_DIR / "package.json").is_file():
            _unavailable(f"npm install gltf-validator failed: {done.stderr.strip()[-500:]}")
    return [node, str(VALIDATE_JS)]


# ---------------------------------------------------------------------- reading a .glb back (pygltflib)


def load_glb(path):
    import pygltflib

    gltf = pygltflib.GLTF2.load_binary(str(path))
    return gltf, gltf.binary_blob()


def read_accessor(gltf, blob, index):
    """The values of accessor ``index`` as a NumPy array ((count,) or (count, k)), straight from the buffer."""
    acc = gltf.accessors[index]
    view = gltf.bufferViews[acc.bufferView]
    k = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[acc.type]
    dtype = {5126: np.float32, 5125: np.uint32, 5123: np.uint16}[acc.componentType]
    assert view.byteStride in (None, 0, k * np.dtype(dtype).itemsize)  # tightly packed
    start = (view.byteOffset or 0) + (acc.byteOffset or 0)
    data = np.frombuffer(blob, dtype=dtype, count=acc.count * k, offset=start)
    return data if k == 1 else data.reshape(acc.count, k)


def animated(gltf, blob, node_index):
    """{path: (times, values)} of the channels that target node ``node_index``."""
    out = {}
    for anim in gltf.animations:
        for ch in anim.channels:
            if ch.target.node == node_index:
                s = anim.samplers[ch.sampler]
                # a body disabled at some frames is hidden there by a scale track that pops (STEP)
                assert s.interpolation == ("STEP" if ch.target.path == "scale" else "LINEAR")
                out[ch.target.path] = (read_accessor(gltf, blob, s.input), read_accessor(gltf, blob, s.output))
    return out


# ---------------------------------------------------------------------- glTF


def test_validator_reports_zero_errors_on_every_example(glb_files, trajectories, gltf_validator):
    # The Khronos validator is the reference for "valid glTF 2.0" (Blender's and three.js's importers
    # are written to it). Zero errors is the acceptance item; zero warnings is checked too, because
    # the validator version is pinned, so a new warning means the writer changed.
    done = subprocess.run(gltf_validator + [str(p) for p in glb_files.values()], capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["validatorVersion"] == VALIDATOR_VERSION
    reports = result["reports"]
    assert len(reports) == len(glb_files) == len(LABELS)
    for label, path in glb_files.items():
        issues = reports[str(path)]["issues"]
        messages = [f"{m['code']}: {m['message']} ({m.get('pointer', '')})" for m in issues["messages"]]
        assert issues["numErrors"] == 0, (label, messages)
        assert issues["numWarnings"] == 0, (label, messages)
        info = reports[str(path)]["info"]
        assert info["animationCount"] == 1
        assert info["drawCallCount"] == len(trajectories[label].names)


@pytest.mark.parametrize("label", LABELS)
def test_glb_gives_back_the_trajectory(label, trajectories, glb_files):
    # Reads the .glb with pygltflib (not our writer's code) and compares each body node's animation
    # with the trajectory. glTF stores float32 only, so the exact expectation is "the trajectory's
    # value rounded to float32": checked bit for bit. The acceptance tolerance 1e-6 then holds as
    # long as coordinates stay below 32 m (half a float32 ulp is 2^-24 |x| <= 9.5e-7 there); these
    # 1 s runs stay within that, which the test also checks so that 1e-6 is not met by luck.
    traj = trajectories[label]
    gltf, blob = load_glb(glb_files[label])
    root = gltf.nodes[gltf.scenes[gltf.scene].nodes[0]]
    # the root turns z up into y up: -90 degrees about x, as (x, y, z, w)
    np.testing.assert_allclose(root.rotation, [-math.sqrt(0.5), 0, 0, math.sqrt(0.5)], rtol=0, atol=1e-15)
    assert len(root.children) == len(traj.names)
    assert np.abs(traj.position).max() < 32.0
    time32 = traj.time.astype(np.float32)
    for i, node_index in enumerate(root.children):
        node = gltf.nodes[node_index]
        assert node.name == str(traj.names[i])
        channels = animated(gltf, blob, node_index)
        if "scale" in channels:  # disabled at some frames: (0, 0, 0) there, (1, 1, 1) elsewhere
            np.testing.assert_array_equal(channels.pop("scale")[1], np.repeat(traj.enabled[:, i, None], 3, axis=1))
        if fixed_flags(traj)[i]:
            # static transform, stored in JSON as double: equal to the trajectory's first frame
            assert channels == {}
            np.testing.assert_array_equal(node.translation, traj.position[0, i])
            q = np.array([node.rotation[3], *node.rotation[:3]])
            assert min(np.abs(q - traj.orientation[0, i]).max(), np.abs(q + traj.orientation[0, i]).max()) <= 1e-15
            continue
        t, x = channels["translation"]
        t2, r = channels["rotation"]
        np.testing.assert_array_equal(t, time32)
        np.testing.assert_array_equal(t2, time32)
        assert np.abs(t - traj.time).max() <= TOL
        # translation = centre of mass: float32 of the trajectory's, exactly, and within 1e-6
        np.testing.assert_array_equal(x, traj.position[:, i].astype(np.float32))
        assert np.abs(x - traj.position[:, i]).max() <= TOL
        # rotation: glTF (x, y, z, w) back to (w, x, y, z); each key is +q or -q (the same rotation),
        # chosen so that consecutive keys have a non-negative dot product (interpolation takes the short way)
        q = r[:, [3, 0, 1, 2]].astype(float)
        sign = np.sign(np.einsum("fk,fk->f", q, traj.orientation[:, i]))
        assert np.all(sign != 0)
        np.testing.assert_array_equal(q, (sign[:, None] * traj.orientation[:, i]).astype(np.float32))
        assert np.abs(q - sign[:, None] * traj.orientation[:, i]).max() <= TOL
        assert np.all(np.einsum("fk,fk->f", q[1:], q[:-1]) >= 0)


def test_glb_mesh_is_where_the_user_put_the_shape(trajectories, glb_files):
    # World position of mesh vertices at a frame, computed the glTF way (root rotation, then the node's
    # translation and rotation read back from the file), equals the shape's own geometry placed with
    # DESIGN.md's pose: shape origin at position - R com_offset. For the box of the all-shapes scene the
    # corners are exactly +-size/2 about the shape origin; for the cone the apex is at z = height in its
    # frame. Tolerance 1e-5 m: float32 vertices and keys around coordinates of a few metres.
    traj = trajectories["all_shapes"]
    gltf, blob = load_glb(glb_files["all_shapes"])
    root = gltf.nodes[0]
    y_up = np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], dtype=float)  # z-up world (x, y, z) -> glTF (x, z, -y)
    np.testing.assert_allclose(quat_to_matrix(np.array([root.rotation[3], *root.rotation[:3]])), y_up, atol=1e-15)
    for name, local_points in (("a pillar/with odd name", "box"), ("cone", "apex")):
        i = traj.body(name)
        node = gltf.nodes[root.children[i]]
        prim = gltf.meshes[node.mesh].primitives[0]
        vertices = read_accessor(gltf, blob, prim.attributes.POSITION).astype(float)
        f = len(traj.time) - 1
        ch = animated(gltf, blob, root.children[i])
        if ch:
            x, r = ch["translation"][1][f], ch["rotation"][1][f]
        else:
            x, r = node.translation, node.rotation
        R = quat_to_matrix(np.array([r[3], *r[:3]], dtype=float) / np.linalg.norm(r))
        world_gltf = (y_up @ (vertices @ R.T + np.asarray(x, dtype=float)).T).T
        Rt = quat_to_matrix(traj.orientation[f, i])
        origin = traj.position[f, i] - Rt @ traj.com_offset[i]
        if local_points == "box":
            corners = np.array([[sx, sy, sz] for sx in (-.1, .1) for sy in (-.1, .1) for sz in (-1, 1)])
        else:
            corners = np.array([[0, 0, 0.5]])
        expected = (y_up @ (corners @ Rt.T + origin).T).T
        for c in expected:  # every expected point is a vertex of the exported mesh
            assert np.linalg.norm(world_gltf - c, axis=1).min() < 1e-5, (name, c)


def test_meshes_in_the_body_frame_have_the_shape_bounds(trajectories):
    # The visual mesh of each shape, moved back by +com_offset, has the bounds of the shape itself
    # (in its own frame). Tolerances: exact for flat-faced shapes; round ones are tessellated with
    # vertices on the surface, so their bounds match to 1e-12 along the axes where vertices fall on the poles.
    traj = trajectories["all_shapes"]
    meshes = body_meshes(traj)
    expected = {
        "ball": ([-.2, -.2, -.2], [.2, .2, .2]),
        "pill": ([-.1, -.1, -.3], [.1, .1, .3]),
        "can": ([-.15, -.15, -.15], [.15, .15, .15]),
        "cone": ([-.2, -.2, 0], [.2, .2, .5]),
        "tet": ([0, 0, 0], [1, 1, 1]),
        "hull": ([0, 0, 0], [.4, .3, .3]),
        "a pillar/with odd name": ([-.1, -.1, -1], [.1, .1, 1]),
    }
    for name, (lo, hi) in expected.items():
        i = traj.body(name)
        v = meshes[i][0].vertices + traj.com_offset[i]
        np.testing.assert_allclose(v.min(axis=0), lo, atol=1e-12, err_msg=name)
        np.testing.assert_allclose(v.max(axis=0), hi, atol=1e-12, err_msg=name)
        n = meshes[i][0].normals
        np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)
    # the plane: a flat quad at z = -1, at least 20 m across, centred under the origin
    g = meshes[traj.body("ground")][0]
    np.testing.assert_array_equal(g.vertices[:, 2], -1.0)
    assert np.ptp(g.vertices[:, 0]) >= 20 and np.allclose(g.vertices[:, :2].mean(axis=0), 0)
    assert g.double_sided and np.allclose(g.normals, [0, 0, 1])
    # particles: one sphere around each point (the heaviest 0.35 x the nearest spacing across)
    i = traj.body("dots")
    v = meshes[i][0].vertices + traj.com_offset[i]
    for p in ([0, 0, 0], [0.1, 0, 0], [0, 0.1, 0]):
        assert np.linalg.norm(v - p, axis=1).min() <= 0.035 + 1e-12


def test_glb_rotation_keys_take_the_short_way_when_the_trajectory_flips_sign(trajectories, tmp_path):
    # q and -q are the same orientation, and a trajectory may hold either; a viewer interpolating
    # between keys of opposite sign would spin the body the long way round. Here every other frame of
    # a real run is negated: the keys read back must still be +-q (float32 of it) and consecutive keys
    # must have a positive dot product.
    traj = trajectories["projectile"]
    flipped = traj.orientation.copy()
    flipped[1::2] *= -1
    path = export_gltf(dataclasses.replace(traj, orientation=flipped), tmp_path / "flipped.glb")
    gltf, blob = load_glb(path)
    for i, node_index in enumerate(gltf.nodes[0].children):
        r = animated(gltf, blob, node_index)["rotation"][1]
        q = r[:, [3, 0, 1, 2]].astype(float)
        assert np.all(np.einsum("fk,fk->f", q[1:], q[:-1]) > 0)
        sign = np.sign(np.einsum("fk,fk->f", q, traj.orientation[:, i]))
        np.testing.assert_array_equal(q, (sign[:, None] * traj.orientation[:, i]).astype(np.float32))


def test_old_trajectory_without_shapes_gets_marker_spheres(trajectories):
    # Files written before trajectories carried shapes still export (the motion is what matters):
    # every body is a sphere of MARKER_RADIUS about its centre of mass. (Validity and the animation are
    # checked with the other files above.)
    for mesh, _ in body_meshes(trajectories["old_file"]):
        np.testing.assert_allclose(np.linalg.norm(mesh.vertices, axis=1), MARKER_RADIUS, rtol=1e-12)


def test_continuous_quaternions_take_the_short_way():
    # A rotation about z sampled with alternating signs (a sign-agnostic integrator may do this):
    # afterwards every consecutive pair has a positive dot product and each key is the same rotation.
    angles = np.linspace(0, 3 * np.pi, 40)
    q = np.stack([np.cos(angles / 2), 0 * angles, 0 * angles, np.sin(angles / 2)], axis=1)[:, None, :]
    q[1::2] *= -1
    out = continuous_quaternions(q)
    assert np.all(np.einsum("fnk,fnk->fn", out[1:], out[:-1]) > 0)
    np.testing.assert_allclose(np.abs(np.einsum("fnk,fnk->fn", out, q)), 1.0, atol=1e-15)


# ---------------------------------------------------------------------- USD


@pytest.mark.parametrize("label", LABELS)
def test_usd_samples_equal_the_trajectory(label, trajectories, tmp_path):
    # Reopened with pxr: metadata (z up, metres, time codes per second = the frame rate), then the translate and
    # orient ops at each time code (= frame index) against the trajectory. The ops are double precision,
    # so the samples are the trajectory's to rounding (1e-12); the acceptance tolerance is 1e-6. The
    # world transform USD computes for the mesh (op order included) is checked against R p + x.
    from pxr import Usd, UsdGeom

    traj = trajectories[label]
    suffix = ".usda" if label == "all_shapes" else ".usd"
    path = export_usd(traj, tmp_path / f"{label}{suffix}")
    stage = Usd.Stage.Open(str(path))
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    fps = 1.0 / (traj.time[1] - traj.time[0])  # the scene's frame rate (24 unless it says otherwise)
    assert stage.GetTimeCodesPerSecond() == pytest.approx(fps) and stage.GetFramesPerSecond() == pytest.approx(fps)
    assert stage.GetStartTimeCode() == 0 and stage.GetEndTimeCode() == len(traj.time) - 1
    bodies = stage.GetDefaultPrim().GetChildren()
    assert len(bodies) == len(traj.names)
    names = [p.GetName() for p in bodies]
    assert len(set(names)) == len(names)
    cache = UsdGeom.XformCache()
    for i, prim in enumerate(bodies):
        assert prim.GetCustomDataByKey("tumble:name") == str(traj.names[i])
        ops = UsdGeom.Xformable(prim).GetOrderedXformOps()
        assert [op.GetOpType() for op in ops] == [UsdGeom.XformOp.TypeTranslate, UsdGeom.XformOp.TypeOrient]
        translate, orient = ops
        fixed = bool(fixed_flags(traj)[i])
        assert translate.GetAttr().GetNumTimeSamples() == (0 if fixed else len(traj.time))
        mesh = UsdGeom.Mesh(prim.GetChild("mesh"))
        points = np.array(mesh.GetPointsAttr().Get(), dtype=float)
        counts = np.array(mesh.GetFaceVertexCountsAttr().Get())
        assert np.all(counts == 3) and len(mesh.GetFaceVertexIndicesAttr().Get()) == 3 * len(counts)
        assert len(mesh.GetDisplayColorAttr().Get()) == 1
        for f in range(len(traj.time)):
            x = np.array(translate.Get(f))
            qd = orient.Get(f)
            q = np.array([qd.GetReal(), *qd.GetImaginary()])
            assert np.abs(x - traj.position[f, i]).max() <= 1e-12 <= TOL
            assert np.abs(q - traj.orientation[f, i]).max() <= 1e-12
            if f in (0, len(traj.time) - 1):
                cache.SetTime(f)
                M = np.array(cache.GetLocalToWorldTransform(mesh.GetPrim()))  # row vectors: p M
                world = points[:4] @ M[:3, :3] + M[3, :3]
                R = quat_to_matrix(traj.orientation[f, i])
                np.testing.assert_allclose(world, points[:4] @ R.T + traj.position[f, i], rtol=0, atol=1e-9)


def test_usd_names_are_valid_and_unique():
    from tumble.export.usd import prim_names

    assert prim_names(["box", "box", "1st", "a b/c", ""]) == ["box", "box_2", "_1st", "a_b_c", "_"]
    names = prim_names(["box", "box", "box_2", "é", "ü"])  # clashes after sanitising are resolved too
    assert len(set(names)) == 5 and all(n.isidentifier() and n.isascii() for n in names)


# ---------------------------------------------------------------------- CLI


@pytest.fixture
def traj_file(trajectories, tmp_path):
    return trajectories["projectile"].save(tmp_path / "run" / "trajectory.npz")


def one_line_error(capsys, code, prefix="tumble: error:"):
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith(prefix) and err.count("\n") == 1, err
    return err


@pytest.mark.parametrize("suffix", [".glb", ".usda", ".usdc", ".usd"])
def test_cli_export_writes_the_file(traj_file, tmp_path, capsys, suffix):
    out = tmp_path / f"out{suffix}"
    assert main(["export", str(traj_file), "-o", str(out)]) == 0
    assert out.is_file() and out.stat().st_size > 0
    assert f"wrote {out}" in capsys.readouterr().out
    if suffix == ".glb":
        assert out.read_bytes()[:4] == b"glTF"
    elif suffix == ".usda":
        assert out.read_text().startswith("#usda 1.0")
    else:
        assert out.read_bytes()[:8] == b"PXR-USDC"


def test_cli_export_takes_a_run_folder(traj_file, tmp_path):
    assert main(["export", str(traj_file.parent), "-o", str(tmp_path / "a.glb")]) == 0


def test_cli_export_bad_input_is_one_line_exit_2(traj_file, tmp_path, capsys):
    err = one_line_error(capsys, main(["export", str(traj_file), "-o", str(tmp_path / "out.obj")]))
    assert "out.obj" in err and ".obj" in err and ".glb" in err
    assert not (tmp_path / "out.obj").exists()
    err = one_line_error(capsys, main(["export", str(tmp_path / "missing.npz"), "-o", str(tmp_path / "a.glb")]))
    assert "missing.npz" in err and "not found" in err
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip file")
    err = one_line_error(capsys, main(["export", str(junk), "-o", str(tmp_path / "a.glb")]))
    assert "junk.npz" in err
    one_line_error(capsys, main(["export", str(traj_file)]), "tumble export: error:")  # no -o: a usage error
    assert not (tmp_path / "a.glb").exists()


def test_cli_export_never_overwrites_without_force(traj_file, tmp_path, capsys):
    out = tmp_path / "out.glb"
    out.write_bytes(b"precious")
    err = one_line_error(capsys, main(["export", str(traj_file), "-o", str(out)]))
    assert "--force" in err and str(out) in err
    assert out.read_bytes() == b"precious"
    assert main(["export", str(traj_file), "-o", str(out), "--force"]) == 0
    assert out.read_bytes()[:4] == b"glTF"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no temporary files left


def test_compound_mesh_is_its_parts_in_place():
    """A compound's display mesh is its parts' meshes moved to their positions and orientations
    (bounds checked against the parts' extents: a box turned 90 degrees about x and a sphere)."""
    from tumble.shapes import Box, Compound, Sphere
    from tumble.visual import shape_trimesh

    c = Compound(parts=[(Sphere(0.1), (0, 0, 0.2), (1, 0, 0, 0)),
                        (Box(size=(0.1, 0.1, 0.3)), (0, 0, 0), (math.cos(math.pi / 4), math.sin(math.pi / 4), 0, 0))])
    bounds = shape_trimesh(c).bounds
    assert np.allclose(bounds, [[-0.1, -0.15, -0.05], [0.1, 0.15, 0.3]], atol=2e-3)


def test_sensors_are_drawn_translucent(trajectories, glb_files, tmp_path):
    # examples/conveyor.toml's bin sensor: in the trajectory file's ``sensor`` flags, a glTF
    # material with alpha 0.25 blended (the Khronos validator checks the file with the others) and
    # extras "sensor", a USD displayOpacity of 0.25; every other body opaque.
    from pxr import Usd, UsdGeom

    traj = trajectories["conveyor"]
    assert traj.sensor is not None
    sensor = np.flatnonzero(traj.sensor)
    assert [str(traj.names[i]) for i in sensor] == ["bin_sensor"]
    assert trajectories["tower"].sensor is None  # a world without sensors writes no flags
    gltf, _ = load_glb(glb_files["conveyor"])
    root = gltf.nodes[gltf.scenes[gltf.scene].nodes[0]]
    for i, node_index in enumerate(root.children):
        node = gltf.nodes[node_index]
        material = gltf.materials[gltf.meshes[node.mesh].primitives[0].material]
        if i in sensor:
            assert node.extras["sensor"] is True
            assert material.alphaMode == "BLEND" and material.pbrMetallicRoughness.baseColorFactor[3] == 0.25
        else:
            assert "sensor" not in node.extras
            assert material.alphaMode in (None, "OPAQUE") and material.pbrMetallicRoughness.baseColorFactor[3] == 1.0
    stage = Usd.Stage.Open(str(export_usd(traj, tmp_path / "conveyor.usda")))
    for i, prim in enumerate(stage.GetDefaultPrim().GetChildren()):
        opacity = UsdGeom.Mesh(prim.GetChild("mesh")).GetDisplayOpacityAttr().Get()
        if i in sensor:
            assert list(opacity) == [pytest.approx(0.25)] and prim.GetCustomDataByKey("tumble:sensor") is True
        else:
            assert opacity is None


def test_many_bodies_over_one_mesh_store_the_mesh_once(tmp_path, capsys):
    """trajectory.npz keeps each distinct shape JSON once (``shape_table`` (K,) str, ``shape_index``
    (N,) int64), in the in-memory file and the streamed one: 300 small balls over one large mesh
    are a small file, not N x the mesh's JSON padded to its length (before: a fixed-width (N,)
    ``shapes`` array, 136 MB for 300 balls over a 3072-face bowl). The shapes round-trip exactly,
    ``Trajectory.shapes`` still gives the (N,) texts, and a file of the old form (a ``shapes``
    array) still loads, exports and views the same."""
    import trimesh

    import tumble as tb
    from tumble.trajectory import load_trajectory

    bowl = trimesh.creation.icosphere(subdivisions=4, radius=3.0)  # 5120 faces
    world = tb.World(gravity=(0, 0, 0))
    world.add_body(tb.Mesh(vertices=bowl.vertices, faces=bowl.faces), fixed=True, name="bowl")
    for k in range(300):
        world.add_body(tb.Sphere(radius=0.02), mass=0.1, position=(0.1 * (k % 20), 0.1 * (k // 20), 5.0), name=f"b{k}")
    texts = [json.dumps(shape_to_dict(sh)) for sh in world.shapes]
    longest = max(len(t) for t in texts)
    padded_bytes = 4 * longest * len(texts)  # the old (N,) fixed-width array
    assert padded_bytes > 50e6

    sim = tb.Simulator(world, dt=1 / 240)
    result = sim.run_to_file(tmp_path / "streamed", 1 / 24, 24, progress=False)
    assert result.status == "completed"
    memory = sim.run(1 / 24, 24)
    saved = memory.save(tmp_path / "memory.npz")
    for path in (tmp_path / "streamed" / "trajectory.npz", saved):
        size = path.stat().st_size
        assert size < 2e6 and size < padded_bytes / 100, (path, size)
        with np.load(path, allow_pickle=False) as data:
            assert "shapes" not in data.files
            assert data["shape_table"].shape == (2,) and data["shape_index"].dtype == np.int64
            assert data["shape_index"].tolist() == [0] + [1] * 300
        traj = load_trajectory(path)
        assert [traj.shape_text(i) for i in range(301)] == texts
        assert traj.shapes.shape == (301,) and traj.shapes.tolist() == texts
        assert json.dumps(shape_to_dict(traj.shape(0))) == texts[0] and traj.shape(7) == world.shapes[7]

    # the old form: a (N,) fixed-width `shapes` array beside the frames (what tumble 0.1.0 wrote)
    small = tb.World(gravity=(0, 0, -9.81))
    small.add_body(tb.Plane(), fixed=True, name="ground")
    small.add_body(tb.Box(size=(0.2, 0.3, 0.4)), mass=1.0, position=(0, 0, 1), name="box")
    small.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(1, 0, 1), name="ball")
    new = tb.Simulator(small).run(0.25, 24)
    new_path = new.save(tmp_path / "new" / "trajectory.npz")
    with np.load(new_path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files if k not in ("shape_table", "shape_index")}
    arrays["shapes"] = np.array([json.dumps(shape_to_dict(sh)) for sh in small.shapes], dtype=str)
    old_path = tmp_path / "old" / "trajectory.npz"
    old_path.parent.mkdir()
    np.savez(old_path, **arrays)
    old = load_trajectory(old_path)
    assert old.shapes.tolist() == arrays["shapes"].tolist() and old.shape(1) == small.shapes[1]
    assert old.shape_table.shape == (3,) and old.shape_index.tolist() == [0, 1, 2]
    for suffix in (".glb", ".html"):
        assert main(["export", str(old_path), "-o", str(tmp_path / f"old{suffix}")]) == 0
        assert main(["export", str(new_path), "-o", str(tmp_path / f"new{suffix}")]) == 0
        assert (tmp_path / f"old{suffix}").read_bytes() == (tmp_path / f"new{suffix}").read_bytes()
    capsys.readouterr()
    # the API: Trajectory(shapes=...) builds the table, assigning None drops the shapes
    rebuilt = dataclasses.replace(new, shapes=list(arrays["shapes"]))
    assert rebuilt.shape_table.tolist() == arrays["shapes"].tolist() and rebuilt.shape_index.tolist() == [0, 1, 2]
    assert dataclasses.replace(new, shapes=None).shape(1) is None
