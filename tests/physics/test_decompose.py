"""Moving concave bodies: ``tb.decompose`` (CoACD's convex pieces of a closed mesh, the mesh kept as
the compound's ``source``). Checked against geometry (the pieces cover the solid and leave its hole
open, by the chords a piece can bridge), the mesh's exact mass integrals, the closed form of a ring
at rest around a peg, and the same scene with the mesh's convex hull (PyBullet's and MuJoCo's
treatment of a moving mesh), which rests on the peg's top instead."""

import hashlib
import math
import os
import subprocess
import sys

import numpy as np
import pytest

import tumble as tb
from tumble import decomposition as D
from tumble.errors import InputError
from tumble.mass import mass_properties

pytest.importorskip("coacd")

SECTIONS = 48
R_IN, R_OUT, HEIGHT = 0.2, 0.3, 0.1  # m: a flat ring (annulus), 48-gon
PEG_RADIUS, PEG_LENGTH = 0.1, 0.6


@pytest.fixture(scope="module")
def ring():
    import trimesh

    m = trimesh.creation.annulus(r_min=R_IN, r_max=R_OUT, height=HEIGHT, sections=SECTIONS)
    return tb.Mesh(vertices=m.vertices, faces=m.faces)


@pytest.fixture(scope="module")
def pieces(ring):
    return tb.decompose(ring, cache=False)


def _inside_any(hulls, points, eps=1e-9):
    """(n,) bool: each point inside (or on) some hull, by the hulls' face planes."""
    from scipy.spatial import ConvexHull

    inside = np.zeros(len(points), dtype=bool)
    for v in hulls:
        eq = ConvexHull(v).equations  # n . p + d <= 0 inside
        inside |= (points @ eq[:, :3].T + eq[:, 3] <= eps).all(axis=1)
    return inside


def test_the_pieces_cover_the_ring_and_leave_its_hole_open(pieces):
    """Every point of the solid ring is inside some piece (CoACD cuts the mesh and hulls each cut
    part, so the union holds the solid: to the plane tolerance 1e-9 m), and the hole stays open: a
    piece's hull can bridge the inner rim only by the chord of the arc it spans, so nothing of a
    piece comes nearer the axis than R_IN cos(pi / 3) = 0.1 m unless a piece spans 120 degrees; the
    ring's convex hull fills the whole hole (checked: all the hole's points fall inside it)."""
    rng = np.random.default_rng(0)
    n = 4000
    # points of the solid 48-gon ring: radii between the inner polygon's corners' circle and the
    # outer polygon's inscribed circle
    r = rng.uniform(R_IN, R_OUT * math.cos(math.pi / SECTIONS), n)
    t = rng.uniform(0.0, 2.0 * math.pi, n)
    z = rng.uniform(-HEIGHT / 2, HEIGHT / 2, n)
    solid = np.column_stack([r * np.cos(t), r * np.sin(t), z])
    hulls = [part.vertices + pos for part, pos, _ in pieces.parts]
    assert _inside_any(hulls, solid).all()
    r = rng.uniform(0.0, R_IN * math.cos(math.pi / 3), n)
    hole = np.column_stack([r * np.cos(t), r * np.sin(t), z])
    assert not _inside_any(hulls, hole).any()
    assert _inside_any([pieces.source.vertices], hole).all()  # the hull: the test fails with it
    assert len(pieces.parts) >= 4
    for part, pos, q in pieces.parts:  # each piece about the middle of its bounds (its AABB is centred there)
        lo, hi = part.vertices.min(axis=0), part.vertices.max(axis=0)
        np.testing.assert_allclose(lo + hi, 0.0, atol=1e-12)
        assert q == (1.0, 0.0, 0.0, 0.0)


def test_a_decomposed_body_has_the_mesh_exact_mass_properties(ring, pieces):
    """The pieces' hulls over-fill the ring (they bridge its rims), so the body takes the mesh's own
    integrals: equal to the Mesh's (1e-12), and the 48-gon annulus's volume in closed form,
    (n / 2) sin(2 pi / n) (R^2 - r^2) h, to 1e-12. Without the source the parts' volumes would set
    the mass distribution (more than the ring's volume: checked)."""
    mp = mass_properties(pieces, mass=2.0)
    ref = mass_properties(ring, mass=2.0)
    assert mp.mass == ref.mass == 2.0
    np.testing.assert_allclose(mp.center, ref.center, atol=1e-12)
    np.testing.assert_allclose(mp.inertia, ref.inertia, rtol=1e-12, atol=1e-15)
    volume = mass_properties(pieces, density=1.0).mass
    polygon = SECTIONS / 2 * math.sin(2 * math.pi / SECTIONS) * (R_OUT**2 - R_IN**2) * HEIGHT
    assert volume == pytest.approx(polygon, rel=1e-12)
    parts_only = tb.Compound(parts=pieces.parts)
    assert mass_properties(parts_only, density=1.0).mass > 1.001 * polygon
    w = tb.World()
    b = w.add_body(pieces, mass=2.0)
    np.testing.assert_allclose(np.sort(np.linalg.eigvalsh(w.inertia_body[b.index])), np.sort(np.linalg.eigvalsh(ref.inertia)),
                               rtol=1e-12)


def _drop_on_peg(shape, offset=0.01, duration=2.0):
    w = tb.World(gravity=(0.0, 0.0, -9.81))
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    w.add_body(tb.Cylinder(PEG_RADIUS, PEG_LENGTH), fixed=True, position=(0, 0, PEG_LENGTH / 2), name="peg")
    b = w.add_body(shape, mass=1.0, position=(offset, 0.0, 1.0), name="ring")
    tb.Simulator(w).run(duration)
    return b


def test_a_decomposed_ring_falls_around_a_peg_where_its_hull_rests_on_top(ring, pieces):
    """A ring dropped over a peg (hole radius 0.2 m, peg 0.1 m) slides down it and lies on the
    ground: its centre at h / 2 = 0.05 m (to 1 mm: the soft contact's give under 1 kg is 0.1 mm),
    flat (its axis vertical to 1e-3), at rest (1 mm/s), the peg through its hole. The ring's convex
    hull (what PyBullet and MuJoCo collide a moving mesh as) stops on the peg's top, 0.65 m."""
    b = _drop_on_peg(pieces)
    assert b.x[2] == pytest.approx(HEIGHT / 2, abs=1e-3)
    assert np.hypot(b.x[0], b.x[1]) < R_IN - PEG_RADIUS
    assert abs(b.R[2, 2]) > 1 - 1e-3
    assert np.linalg.norm(b.v) < 1e-3
    hull = _drop_on_peg(tb.Convex(points=ring.vertices))
    assert hull.x[2] == pytest.approx(PEG_LENGTH + HEIGHT / 2, abs=1e-3)


def _digest(compound):
    h = hashlib.sha256()
    for part, pos, _ in compound.parts:
        h.update(np.ascontiguousarray(part.vertices).tobytes() + np.ascontiguousarray(pos).tobytes())
    return h.hexdigest()


def test_decompositions_are_deterministic_and_kept(ring, pieces, tmp_path, monkeypatch):
    """The same mesh and settings give the same pieces, bit for bit: again in this process, in
    another with one thread (CoACD's search is seeded), and from the cache on disk; in one process
    the same Compound record (bodies sharing it share its collision data); a cache file cut short
    (a run killed while writing it) is made again, not read."""
    again = tb.decompose(ring, cache=False)
    assert _digest(again) == _digest(pieces)
    code = ("import sys, trimesh, tumble as tb\n"
            f"from tests.physics.test_decompose import _digest\n"
            f"m = trimesh.creation.annulus(r_min={R_IN}, r_max={R_OUT}, height={HEIGHT}, sections={SECTIONS})\n"
            "print(_digest(tb.decompose(tb.Mesh(vertices=m.vertices, faces=m.faces), cache=False)))\n")
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=os.pathsep.join([os.path.join(root, "src"), root]))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=root, check=True)
    assert out.stdout.strip().splitlines()[-1] == _digest(pieces)

    monkeypatch.setenv("TUMBLE_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(D, "_memory", {})
    first = tb.decompose(ring)
    assert tb.decompose(tb.Mesh(vertices=ring.vertices, faces=ring.faces)) is first  # one record, kept
    files = list((tmp_path / "decompositions").glob("*.npz"))
    assert len(files) == 1 and _digest(first) == _digest(pieces)
    monkeypatch.setattr(D, "_memory", {})
    calls = []
    monkeypatch.setattr(D, "_run_coacd", lambda *a: calls.append(a) or ())
    assert _digest(tb.decompose(ring)) == _digest(pieces) and not calls  # read from disk, CoACD not run
    files[0].write_bytes(files[0].read_bytes()[:100])
    monkeypatch.setattr(D, "_memory", {})
    monkeypatch.undo()
    monkeypatch.setenv("TUMBLE_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(D, "_memory", {})
    again = tb.decompose(ring)
    assert _digest(again) == _digest(pieces)
    assert D._read(files[0]) is not None  # written whole again
    assert tb.decompose(ring, threshold=0.1, cache=False) is not again


def test_a_moving_mesh_collides_as_its_hull_and_says_so_when_concave(ring):
    """A plain mesh on a moving body collides as its convex hull (PyBullet's and MuJoCo's treatment:
    the ring stops on the peg's top), keeping the mesh's mass properties, and a concave one warns
    once, naming the body and ``tb.decompose``; a convex mesh's hull is exact: no warning. Before, a moving mesh collided
    with nothing: the ring fell through the ground without a word."""
    import warnings

    with pytest.warns(tb.TumbleWarning, match=r"^body 'ring': a moving triangle mesh collides as its convex hull, "
                                              r"80 % more volume than the mesh; cut it into convex pieces with "
                                              r"tumble.decompose \(scene files: decompose = true\)$") as record:
        b = _drop_on_peg(ring)
    assert len(record) == 1
    assert b.x[2] == pytest.approx(PEG_LENGTH + HEIGHT / 2, abs=1e-3)
    from tumble.mass import box_mesh

    v, f = box_mesh((0.3, 0.3, 0.3))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cube = _drop_on_peg(tb.Mesh(vertices=v, faces=f), offset=0.0)
    assert cube.x[2] == pytest.approx(PEG_LENGTH + 0.15, abs=1e-3)


@pytest.mark.parametrize("kw, key, problem", [
    ({"threshold": 0.0}, "threshold", "must be between 0.01 and 1.0, got 0.0"),
    ({"threshold": 2}, "threshold", "must be between 0.01 and 1.0, got 2.0"),
    ({"threshold": "fine"}, "threshold", "expected a number, got 'fine'"),
    ({"threshold": True}, "threshold", "expected a number, got True"),
    ({"max_parts": 0}, "max_parts", "expected a whole number of at least 1, got 0"),
    ({"max_hull_vertices": 3}, "max_hull_vertices", "expected a whole number of at least 4, got 3"),
    ({"seed": -1}, "seed", "expected a whole number of at least 0, got -1"),
    ({"seed": None}, "seed", "expected a whole number of at least 0, got None"),
])
def test_bad_settings_are_one_line(ring, kw, key, problem):
    with pytest.raises(InputError) as err:
        tb.decompose(ring, **kw)
    assert str(err.value) == f"{key}: {problem}"


def test_bad_meshes_and_a_missing_coacd_are_one_line(ring, tmp_path, monkeypatch):
    with pytest.raises(InputError, match=r"^mesh: expected a closed tumble.Mesh or a mesh file's path, got Box$"):
        tb.decompose(tb.Box((1, 1, 1)))
    with pytest.raises(InputError, match=r"got Convex$"):
        tb.decompose(tb.Convex(points=ring.vertices))
    with pytest.raises(InputError, match="mesh"):
        tb.decompose(tmp_path / "missing.obj")
    monkeypatch.setitem(sys.modules, "coacd", None)  # import coacd raises ImportError
    with pytest.raises(InputError, match=r"^mesh: decomposing a mesh needs coacd: pip install 'tumble\[decompose\]'$"):
        tb.decompose(ring, cache=False)


def test_the_source_is_drawn_and_kept_through_files(pieces, tmp_path):
    """Exports draw the mesh, not its pieces; a trajectory file keeps pieces and source (a run's
    file alone draws and re-simulates it)."""
    from tumble.shapes import shape_from_dict, shape_to_dict
    from tumble.visual import shape_trimesh

    drawn = shape_trimesh(pieces)
    assert len(drawn.vertices) == len(pieces.source.vertices)
    back = shape_from_dict(shape_to_dict(pieces))
    assert _digest(back) == _digest(pieces)
    np.testing.assert_array_equal(back.source.vertices, pieces.source.vertices)
    np.testing.assert_array_equal(back.source.faces, pieces.source.faces)
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(pieces, mass=1.0, position=(0, 0, 1), name="ring")
    path = tmp_path / "t.npz"
    tb.Simulator(w).run(0.125).save(path)
    shape = tb.load_trajectory(path).shape(0)
    assert shape.source is not None and len(shape.parts) == len(pieces.parts)


SCENE = """
[simulation]
duration = 0.25
gravity = [0, 0, -9.81]

[[bodies]]
name = "ground"
shape = {{ type = "plane" }}
fixed = true

[[bodies]]
name = "ring"
shape = {{ type = "mesh", path = "ring.obj"{decompose} }}
mass = 1.0
position = [0, 0, 1]
"""


@pytest.fixture
def scene_dir(tmp_path):
    import trimesh

    trimesh.creation.annulus(r_min=R_IN, r_max=R_OUT, height=HEIGHT, sections=SECTIONS).export(tmp_path / "ring.obj")
    return tmp_path


def test_scene_files_decompose_a_moving_mesh(scene_dir, pieces):
    """``decompose = true`` (or a table of settings) makes the scene's mesh the same compound as
    ``tb.decompose`` on the same mesh (same pieces, bit for bit), and ``false`` keeps the mesh."""
    from tumble.scene import load_scene

    path = scene_dir / "s.toml"
    for value, threshold in ((", decompose = true", 0.05), (", decompose = { threshold = 0.1, seed = 1 }", 0.1)):
        path.write_text(SCENE.format(decompose=value))
        shape = load_scene(path).world.shapes[1]
        assert isinstance(shape, tb.Compound) and shape.source is not None
        same = tb.decompose(shape.source, threshold=threshold, seed=0 if threshold == 0.05 else 1)
        assert _digest(shape) == _digest(same)
    assert _digest(load_scene(path).world.shapes[1]) != _digest(pieces)  # the settings are passed on
    path.write_text(SCENE.format(decompose=", decompose = false").replace("mass = 1.0", "fixed = true"))
    assert type(load_scene(path).world.shapes[1]) is tb.Mesh


def test_the_command_line_notes_a_moving_concave_mesh(scene_dir, capsys):
    """``tumble run`` on a scene with a plain moving concave mesh runs (exit 0) and prints the
    warning as one note line."""
    from tumble.cli import main

    path = scene_dir / "s.toml"
    path.write_text(SCENE.format(decompose=""))
    assert main(["run", str(path), "--out", str(scene_dir / "out")]) == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if line.startswith("tumble: note:")]
    assert notes == ["tumble: note: body 'ring': a moving triangle mesh collides as its convex hull, 80 % more "
                     "volume than the mesh; cut it into convex pieces with tumble.decompose (scene files: "
                     "decompose = true)"]


@pytest.mark.parametrize("decompose, line", [
    (", decompose = 3", "bodies[1].shape.decompose: expected true, false or a table of decomposition settings, "
                        "got 3 (a number)"),
    (", decompose = { threshold = 0.001 }", "bodies[1].shape.decompose.threshold: must be between 0.01 and 1.0, "
                                            "got 0.001"),
    (", decompose = { parts = 3 }", "bodies[1].shape.decompose.parts: unknown key (expected one of threshold, "
                                    "max_parts, max_hull_vertices, seed)"),
    (", decompose = { max_parts = 0 }", "bodies[1].shape.decompose.max_parts: expected a whole number of at least 1, "
                                        "got 0"),
])
def test_bad_decompositions_in_scene_files_are_one_line(scene_dir, decompose, line, capsys):
    """One line ``FILE: KEY: problem`` and exit status 2 from ``tumble run``, nothing written."""
    from tumble.cli import main

    path = scene_dir / "s.toml"
    path.write_text(SCENE.format(decompose=decompose))
    out = scene_dir / "out"
    assert main(["run", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"tumble: error: {path}: {line}"
    assert not out.exists()


def test_the_decompose_command_writes_the_pieces_as_one_obj(scene_dir, capsys):
    """``tumble decompose MESH -o OUT.obj`` writes one object per piece, in the mesh's frame: read
    back (trimesh), each object's vertices are a piece's, placed (to the 17 digits written); it
    prints the count and the hulls' volume over the mesh's; OUT is not overwritten without
    --force; bad input is one line, exit 2, nothing written."""
    import trimesh

    from tumble.cli import main

    out = scene_dir / "pieces.obj"
    pieces = tb.decompose(scene_dir / "ring.obj")  # the file's (rounded) vertices: its own pieces
    assert main(["decompose", str(scene_dir / "ring.obj"), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"wrote {out} ({len(pieces.parts)} convex pieces of" in printed and "x the mesh's volume" in printed
    scene = trimesh.load_scene(out, process=False, split_objects=True, group_material=False)
    got = sorted(np.round(g.vertices, 12).tolist() for g in scene.geometry.values())
    want = sorted(np.round(part.vertices + pos, 12).tolist() for part, pos, _ in pieces.parts)
    assert got == want
    for args, line in (([], f"{out}: exists (pass --force to overwrite)"),
                       (["--threshold", "0"], "--threshold: must be between 0.01 and 1.0, got 0.0"),
                       (["--max-parts", "0"], "--max-parts: expected a whole number of at least 1, got 0")):
        target = out if not args else scene_dir / "other.obj"
        assert main(["decompose", str(scene_dir / "ring.obj"), "-o", str(target), *args]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("tumble: error: ") and err.endswith(line) and "\n" not in err
        assert not (scene_dir / "other.obj").exists()
    assert main(["decompose", str(scene_dir / "ring.obj"), "-o", str(scene_dir / "p.stl")]) == 2
    assert "expected an .obj file" in capsys.readouterr().err
