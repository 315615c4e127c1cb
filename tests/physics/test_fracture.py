"""Pre-fractured bodies (``tb.fracture``, ``World.add_fractured``; tumble.fracturing): a convex shape
cut into Voronoi cells glued by breakable fixed joints.

Checked against: the shape's own volume, surface, mass, centre of mass and inertia tensor (the
cells must tile it exactly: their sums, with the parallel-axis theorem, are the whole's), the
Voronoi definition (a point lies in the cell of its nearest seed), momentum conservation inside
a glued whole, free fall, and runs in which a ball breaks the glue near its impact and only
there."""

import math

import numpy as np
import pytest
from scipy.spatial import ConvexHull

import tumble as tb
from tumble.errors import InputError
from tumble.fracturing import glued_faces

BOX = (1.0, 0.2, 0.8)


@pytest.fixture(scope="module")
def cells():
    return tb.fracture(tb.Box(size=BOX), pieces=24, seed=7)


def test_the_cells_tile_the_box(cells):
    """Volumes sum to the box's; surfaces to the box's plus twice the faces found between cells
    (every face of a cell is on the box or shared: the faces' detection misses none above its
    1e-8 size^2 floor); every vertex inside the box; a point lies in the cell of its nearest seed
    and in no other (10 000 random points, 1e-12 m margins). Round-off: 1e-12 relative."""
    a, b, c = (0.5 * s for s in BOX)
    assert len(cells) == 24
    assert cells.volume.sum() == pytest.approx(8 * a * b * c, rel=1e-12)
    surfaces = sum(ConvexHull(v).area for v in cells.cells)
    box_surface = 8 * (a * b + b * c + a * c)
    assert surfaces == pytest.approx(box_surface + 2 * cells.face_area.sum(), rel=1e-9)
    for v in cells.cells:
        assert np.all(np.abs(v) <= np.array([a, b, c]) + 1e-12)
    rng = np.random.default_rng(0)
    p = rng.uniform(-1, 1, size=(10000, 3)) * [a, b, c]
    nearest = np.argmin(np.linalg.norm(p[:, None, :] - cells.seeds[None, :, :], axis=2), axis=1)
    eq = [ConvexHull(v).equations for v in cells.cells]
    inside = np.array([np.all(p @ e[:, :3].T + e[:, 3] <= 1e-12, axis=1) for e in eq])  # (K, P)
    strictly = np.array([np.all(p @ e[:, :3].T + e[:, 3] < -1e-12, axis=1) for e in eq])
    assert np.all(inside[nearest, np.arange(len(p))])
    assert np.all(strictly.sum(axis=0) <= 1)


def test_the_glued_cells_have_the_mass_properties_of_the_whole(cells):
    """The cells as bodies of density rho: total mass rho V, centre of mass at the box's centre
    (the placed position), and sum_k (I_k + m_k (|d_k|^2 E - d_k d_k^T)) = the box's inertia
    m (b^2 + c^2) / 3, ... about it (polyhedral integrals of each cell against the box's closed
    form: 1e-12 relative)."""
    w = tb.World(gravity=(0, 0, 0))
    rho, at = 2500.0, np.array([0.3, -0.2, 1.1])
    bodies, joints = w.add_fractured(cells, density=rho, position=at, name="slab")
    assert [b.name for b in bodies[:2]] == ["slab/00", "slab/01"]
    m = w.mass
    M = m.sum()
    a, b, c = (0.5 * s for s in BOX)
    assert M == pytest.approx(rho * 8 * a * b * c, rel=1e-12)
    X = (m[:, None] * w.x).sum(axis=0) / M
    np.testing.assert_allclose(X, at, rtol=0, atol=1e-13)
    I = np.zeros((3, 3))
    for k in range(len(bodies)):
        d = w.x[k] - X
        I += np.linalg.inv(w.I_inv[k]) + m[k] * (d @ d * np.eye(3) - np.outer(d, d))
    expected = M / 3 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    np.testing.assert_allclose(I, expected, rtol=0, atol=1e-12 * expected.max())
    glued = glued_faces(cells)
    assert len(joints) == int(glued.sum()) and len(joints) > len(bodies)  # a connected web with loops
    # every face of a quarter of the mean face's area or more, and a spanning tree: one piece
    assert np.all(glued[cells.face_area >= 0.25 * cells.face_area.mean()])
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    i, j = cells.faces[glued].T
    assert connected_components(sp.coo_matrix((np.ones(len(i)), (i, j)), shape=(len(cells),) * 2))[0] == 1


def test_a_glued_whole_falls_spins_and_lands_in_one_piece(cells):
    """Thrown spinning in free fall (no ground): the joints are internal, so the total momentum
    rises by M g t (1e-9 relative) and the angular momentum about the centre of mass stays (1e-4:
    the soft anchors' gap, below), and
    the cells keep their distances (1 mm: soft joints); then, unbreakable, dropped 0.5 m onto the
    ground: no glue breaks and the cells keep their distances to 2 mm."""
    w = tb.World(gravity=(0, 0, -9.81))
    bodies, joints = w.add_fractured(cells, density=1000.0, position=(0, 0, 5), velocity=(1.0, 0, 2.0),
                                     angular_velocity=(0.5, 2.0, 0.3), name="slab")
    M = w.mass.sum()
    gaps0 = np.linalg.norm(w.x[:, None] - w.x[None], axis=2)

    def L_about_centre():
        X = (w.mass[:, None] * w.x).sum(axis=0) / M
        return w.L.sum(axis=0) + np.cross(w.x - X, w.P).sum(axis=0)

    P0, L0 = w.P.sum(axis=0).copy(), L_about_centre()
    sim = tb.Simulator(w, dt=1 / 240)
    sim.step(120)
    np.testing.assert_allclose(w.P.sum(axis=0), P0 + M * np.array([0, 0, -9.81]) * 0.5, rtol=1e-9, atol=1e-9 * M)
    # a soft joint's impulse pair acts across its anchors' gap: a torque of (p_a - p_b) x J, so L
    # moves by up to ~6e-6 of L0 a joint stage (docs/joints.md, accuracy table); 3.1e-5 measured here
    np.testing.assert_allclose(L_about_centre(), L0, rtol=0, atol=1e-4 * np.linalg.norm(L0))
    assert np.abs(np.linalg.norm(w.x[:, None] - w.x[None], axis=2) - gaps0).max() < 1e-3

    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(), fixed=True, name="ground")
    bodies, joints = w.add_fractured(cells, density=1000.0, position=(0, 0, 0.9), name="slab")
    rows = [b.index for b in bodies]
    gaps0 = np.linalg.norm(w.x[rows][:, None] - w.x[rows][None], axis=2)
    tb.Simulator(w, dt=1 / 240).step(360)
    assert not any(j.broken for j in joints)
    # the joints' soft rows (60 Hz, Box2D v3's) give under the landing and the slab's own weight:
    # 1.07 mm measured between the farthest cells, 1e-4 of the slab's size
    assert np.abs(np.linalg.norm(w.x[rows][:, None] - w.x[rows][None], axis=2) - gaps0).max() < 2e-3
    assert w.x[rows, 2].min() > 0.0 and w.x[rows, 2].max() < 0.8  # it landed


def _pane_hit(strength, steps=240):
    w = tb.World(gravity=(0, 0, -9.81))
    w.add_body(tb.Plane(), fixed=True, name="ground")
    pane = tb.fracture(tb.Box(size=(1.0, 0.1, 1.0)), pieces=20, seed=1)
    bodies, joints = w.add_fractured(pane, density=2500, position=(0, 0, 0.5), strength=strength, name="pane")
    w.add_body(tb.Sphere(0.12), density=7800, position=(0.2, 1.0, 0.6), velocity=(0, -8, 0), name="ball")
    sim = tb.Simulator(w, dt=1 / 240)
    sim.step(steps)
    return w, pane, bodies, joints, sim


def test_a_ball_breaks_the_glue_near_its_impact_and_the_cells_then_collide():
    """A 56 kg steel ball (r 12 cm) at 8 m/s into a standing pane of 20 cells (1 m x 1 m x 10 cm,
    glass's density): unbreakable, nothing breaks; at 2 MPa some glue breaks, and more at 0.5 MPa;
    there, the broken glues' faces lie nearer the impact, on average, than the unbroken ones'
    median; and the freed cells collide with each other (no two overlap 5 mm: once its joint
    breaks a pair is no longer excluded from contact)."""
    broken = {}
    for strength in (math.inf, 2e6, 5e5):
        w, pane, bodies, joints, sim = _pane_hit(strength)
        broken[strength] = [j for j in joints if j.broken]
    impact = np.array([0.2, 0.05, 0.6])
    faces = pane.face_centroid[glued_faces(pane)] + [0, 0, 0.5]  # the glued faces' centroids, world
    d = np.linalg.norm(faces - impact, axis=1)
    cut = np.array([j.broken for j in joints])
    assert cut.any() and (~cut).any()
    assert d[cut].mean() < np.median(d[~cut])
    rows = [b.index for b in bodies]
    pairs = [(a, b) for a in rows for b in rows if a < b]
    cp = w.closest_points([a for a, _ in pairs], [b for _, b in pairs])
    assert cp.distance.min() > -0.005
    assert not broken[math.inf]
    assert 0 < len(broken[2e6]) < len(broken[5e5])


def test_checkpoints_keep_the_broken_glue(tmp_path):
    """Split at 0.15 s (the ball through the pane, glue broken) by a checkpoint file: the resumed
    run ends with the whole run's state hash."""
    from tumble.checks import state_hash

    w, *_, sim = _pane_hit(5e5, steps=36)
    assert any(j.broken for j in w.joints)
    sim.save_checkpoint(tmp_path / "c.npz")
    resumed = tb.Simulator.load_checkpoint(tmp_path / "c.npz")
    resumed.step(36)
    whole = _pane_hit(5e5, steps=72)
    assert state_hash(resumed.world) == state_hash(whole[0])


def test_other_shapes_fracture_by_their_hull_and_bad_input_is_one_line():
    """A sphere, a cylinder and a cone cut by their drawn meshes' hulls: volumes sum to the hull's;
    given points make the cells of those points; bad input is one line each."""
    for shape in (tb.Sphere(0.3), tb.Cylinder(0.2, 0.5), tb.Cone(0.3, 0.6), tb.Ellipsoid(radii=(0.3, 0.2, 0.1))):
        from tumble.visual import shape_trimesh

        hull = ConvexHull(np.asarray(shape_trimesh(shape).vertices))
        fr = tb.fracture(shape, pieces=6, seed=2)
        assert fr.volume.sum() == pytest.approx(hull.volume, rel=1e-12)
    fr = tb.fracture(tb.Box(size=(1, 1, 1)), points=[[-0.25, 0, 0], [0.25, 0, 0]])
    assert len(fr) == 2 and len(fr.faces) == 1 and fr.face_area[0] == pytest.approx(1.0, rel=1e-12)
    np.testing.assert_allclose(fr.face_centroid[0], 0.0, atol=1e-12)
    with pytest.raises(InputError, match="pieces"):
        tb.fracture(tb.Box(size=(1, 1, 1)), pieces=1)
    with pytest.raises(InputError, match="pieces"):
        tb.fracture(tb.Box(size=(1, 1, 1)), pieces=5000)
    with pytest.raises(InputError, match="seed"):
        tb.fracture(tb.Box(size=(1, 1, 1)), pieces=3, seed=-1)
    with pytest.raises(InputError, match="inside the shape"):
        tb.fracture(tb.Box(size=(1, 1, 1)), points=[[0, 0, 0], [2, 0, 0]])
    with pytest.raises(InputError, match="cannot fracture"):
        tb.fracture(tb.Plane(), pieces=3)
    with pytest.raises(InputError, match="strength"):
        tb.World().add_fractured(fr, density=1.0, strength=-1.0)


SCENE = """
[simulation]
duration = 0.25
[[bodies]]
name = "ground"
shape = {type = "plane"}
fixed = true
[[bodies]]
name = "slab"
shape = {type = "box", size = [1, 0.2, 0.8]}
MASS
position = [0, 0, 0.4]
FRACTURE
"""


@pytest.mark.parametrize("mass, fracture, problem", [
    ("mass = 400", "fracture = {pieces = 12, seed = 3, strength = 1e6}", None),
    ("density = 2500", "fracture = {pieces = 12}", None),
    ("mass = 400", "fracture = {pieces = 1}", "bodies[1].fracture.pieces: must be >= 2, got 1"),
    ("mass = 400", "fracture = {pieces = 5000}", "bodies[1].fracture.pieces: must be a whole number from 2 to 1000"),
    ("mass = 400", "fracture = {strength = -3}", "bodies[1].fracture.strength: must be positive"),
    ("mass = 400", "fracture = {shards = 3}", "bodies[1].fracture.shards: unknown key (expected one of pieces, seed, strength, min_face)"),
    ("mass = 400\nfixed = true", "fracture = {pieces = 3}", "bodies[1].fracture: only a dynamic body can be fractured"),
])
def test_scene_files_take_fractured_bodies(tmp_path, mass, fracture, problem):
    path = tmp_path / "slab.toml"
    path.write_text(SCENE.replace("MASS", mass).replace("FRACTURE", fracture))
    if problem is None:
        scene = tb.load_scene(path)
        w = scene.world
        assert w.names[1:3] == ["slab/00", "slab/01"] and w.body_count == 13
        assert w.mass[1:].sum() == pytest.approx(400.0 if "mass" in mass else 2500 * 0.16, rel=1e-12)
        assert len(w.joints) > 12
        scene.run(progress=False)
        return
    with pytest.raises(InputError) as err:
        tb.load_scene(path)
    assert str(err.value).startswith(f"{path}: {problem}"), str(err.value)
    assert "\n" not in str(err.value)
