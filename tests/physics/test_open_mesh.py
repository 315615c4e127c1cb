"""Open, two-sided triangle meshes (``tb.Mesh(..., closed=False)``): a terrain sheet, a ramp, a bowl
surface, a hollow shell; each triangle pushes a shape back to the side its centre is on
(collision/pairs/mesh.py), whatever the winding.

Compared with: the exact period of a ball rolling in a spherical bowl (a pendulum equation with
g' = 5 g / 7), Coulomb's sliding acceleration, the weight a resting body's contacts carry, and the
same scenes on solid shapes. Every scene is run with the sheet wound both ways: the results must
agree, since an open sheet has no outside.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ellipk

import tumble as tb
from tumble.collision.geometry import BACK_SHIFT, TWO_SIDED, mesh_edge_flags
from tumble.errors import InputError
from tumble.shapes import shape_to_dict

G = 9.81


def grid_sheet(n=8, size=4.0, down=False):
    """A flat square sheet in z = 0, n x n cells of two triangles each (internal edges everywhere),
    wound counter-clockwise seen from above (``down``: from below, each triangle's corners 0, 2, 1)."""
    xs = np.linspace(-size / 2, size / 2, n + 1)
    X, Y = np.meshgrid(xs, xs)
    vertices = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    index = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, 1:].ravel(), index[1:, :-1].ravel()
    faces = np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return vertices, (faces[:, [0, 2, 1]] if down else faces)  # down: each triangle turned as the narrowphase turns it


def hemisphere(R, sections, rings, inward=True):
    """The open lower half of a sphere of radius R about the origin (a bowl's surface): a pole fan and
    ``rings`` rings of quads; wound with normals towards the centre (``inward``) or away from it."""
    vertices = [(0.0, 0.0, -R)]
    for i in range(1, rings + 1):
        th = 0.5 * math.pi * i / rings
        for j in range(sections):
            ph = 2.0 * math.pi * j / sections
            vertices.append((R * math.sin(th) * math.cos(ph), R * math.sin(th) * math.sin(ph), -R * math.cos(th)))
    faces = [(0, 1 + j, 1 + (j + 1) % sections) for j in range(sections)]
    for i in range(1, rings):
        a0, a1 = 1 + (i - 1) * sections, 1 + i * sections
        for j in range(sections):
            jn = (j + 1) % sections
            faces += [(a0 + j, a1 + j, a1 + jn), (a0 + j, a1 + jn, a0 + jn)]
    V, F = np.asarray(vertices), np.asarray(faces)
    n = np.cross(V[F[0, 1]] - V[F[0, 0]], V[F[0, 2]] - V[F[0, 0]])  # the pole's first triangle: +z is inward
    return V, (F if (n[2] > 0) == inward else F[:, ::-1])


# ------------------------------------------------------------------------------------------ bowl
@pytest.mark.parametrize("inward", [True, False])
def test_a_ball_rolls_in_an_open_hemispherical_bowl_with_the_exact_rolling_period(inward):
    """A ball (r = 0.1 m) rolling without slip in a spherical bowl (R = 1 m) obeys
    (7/5)(R - r) theta'' = -g sin(theta): a pendulum of length 7 (R - r) / 5, period
    4 sqrt(7 (R - r) / (5 g)) K(sin^2(theta0 / 2)) at amplitude theta0. The bowl is an open
    hemisphere of 256 x 64 facets, wound towards the ball or away from it (the ball then meets the
    triangles' backs). Three periods from the zero crossings must each be within 0.5 % of the
    exact one: the facets make the surface a polyhedron (measured 0.06-0.16 %); a ball falling
    through the back faces, or held off them, would miss by far more."""
    R, r, th0 = 1.0, 0.1, 0.4
    V, F = hemisphere(R, 256, 64, inward=inward)
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Mesh(vertices=V, faces=F, closed=False), fixed=True, position=(0, 0, R), name="bowl")
    start = (R - r) * np.array([math.sin(th0), 0.0, -math.cos(th0)]) + (0, 0, R)
    ball = w.add_body(tb.Sphere(r), mass=1.0, position=start, name="ball", material=tb.Material(friction=0.8))
    sim = tb.Simulator(w, dt=1 / 240)
    period = 4.0 * math.sqrt(7.0 * (R - r) / (5.0 * G)) * ellipk(math.sin(th0 / 2) ** 2)
    n = int(3.6 * period * 240)
    xs, distance = np.empty(n), np.empty(n)
    for k in range(n):
        sim.step(1)
        xs[k] = ball.x[0]
        distance[k] = np.linalg.norm(ball.x - (0, 0, R))
    t = (np.arange(n) + 1) / 240
    down = np.flatnonzero((xs[:-1] > 0) & (xs[1:] <= 0))
    crossings = t[down] + (t[down + 1] - t[down]) * xs[down] / (xs[down] - xs[down + 1])
    periods = np.diff(crossings)
    assert len(periods) == 3
    assert np.all(np.abs(periods / period - 1.0) < 5e-3), periods / period - 1.0
    # the ball stays on the bowl's inside: its centre R - r from the bowl's centre, to the facets'
    # sagitta (R (1 - cos(pi / 256)) = 0.08 mm) and the contact's few-tenths-of-a-millimetre give
    assert np.all(np.abs(distance - (R - r)) < 2e-3), np.abs(distance - (R - r)).max()


# ------------------------------------------------------------------------------------------ rest
@pytest.mark.parametrize("down", [False, True])
@pytest.mark.parametrize("shape", [tb.Box(size=(0.4, 0.6, 0.3)), tb.Sphere(radius=0.25), tb.Capsule(radius=0.1, length=0.5),
                                   tb.Cylinder(radius=0.2, length=0.3)], ids=["box", "sphere", "capsule", "cylinder"])
def test_a_body_resting_on_an_open_sheet_carries_its_weight_on_either_winding(shape, down):
    """A 2 kg body lying on a flat 8 x 8-cell sheet (128 triangles: it sits across internal edges),
    as on the ground (test_contact.test_resting_box_carries_its_weight): over 1 s after settling the
    normal impulses sum to m g (1 s) within 0.1 %, penetration under 1 mm, speed under 1 mm/s; the
    sheet wound up or down (its back then faces the body) gives the same."""
    V, F = grid_sheet(down=down)
    w = tb.World(gravity=(0, 0, -G))
    w.sleeping = False  # measured over 1 s of rest
    w.add_body(tb.Mesh(vertices=V, faces=F, closed=False), fixed=True, name="sheet")
    m = 2.0
    lying = (90, 0, 0) if isinstance(shape, tb.Capsule) else (0, 0, 0)  # a capsule on its side, a cylinder upright
    body = w.add_body(shape, mass=m, position=(0.13, 0.27, 0.5), euler_deg=lying, name="body",
                      material=tb.Material(friction=0.5))
    sim = tb.Simulator(w)
    sim.step(480)  # fall and settle
    total, deepest = 0.0, 0.0
    for _ in range(240):
        sim.step(1)
        c = sim.contacts()
        total += c.normal_impulse.sum()
        deepest = min(deepest, c.separation.min())
    assert total == pytest.approx(m * G, rel=1e-3)
    assert -deepest < 1e-3
    assert np.linalg.norm(body.v) < 1e-3


def test_the_winding_of_an_open_sheet_changes_not_a_bit():
    """A sheet wound up and the same sheet with each triangle turned (corners 0, 2, 1: wound down) are
    the same surface to a shape above it: the narrowphase turns each triangle behind the shape in
    just that way and takes the edges' back flags (which are the other winding's front flags), so
    a box and a ball dropped on them, 1 s with contacts, give bit-identical states."""
    states = []
    for down in (False, True):
        V, F = grid_sheet(down=down)
        w = tb.World(gravity=(0, 0, -G))
        w.add_body(tb.Mesh(vertices=V, faces=F, closed=False), fixed=True, name="sheet")
        w.add_body(tb.Box(size=(0.4, 0.6, 0.3)), mass=2.0, position=(0.13, 0.27, 0.5), euler_deg=(20, 10, 5))
        w.add_body(tb.Sphere(0.2), mass=1.0, position=(-0.6, 0.4, 0.8), velocity=(1.0, 0.5, 0))
        tb.Simulator(w).step(240)
        states.append(w.pack().copy())
    assert np.array_equal(states[0], states[1])


# ------------------------------------------------------------------------------------------ ramp
@pytest.mark.parametrize("down", [False, True])
def test_a_box_slides_down_an_open_ramp_sheet_at_the_coulomb_acceleration(down):
    """mu = 0.3 on a 30 degree ramp made of a 20 x 2-cell sheet (the box crosses internal edges all the
    way): a = g (sin 30 - mu cos 30) within 1 %, fitted from 0.5 s to 2 s (test_contact's incline on a
    solid slab); with mu = 0.7 > tan 30 it stays, drifting under 1 mm in 2 s."""
    a = math.radians(30.0)
    q = (math.cos(a / 2), 0.0, math.sin(a / 2), 0.0)
    normal = np.array([math.sin(a), 0.0, math.cos(a)])
    downhill = np.array([math.cos(a), 0.0, -math.sin(a)])
    for mu in (0.3, 0.7):
        V, F = grid_sheet(n=20, size=20.0, down=down)
        w = tb.World(gravity=(0, 0, -G))
        w.add_body(tb.Mesh(vertices=V, faces=F, closed=False), fixed=True, orientation=q, name="ramp",
                   material=tb.Material(friction=mu))
        box = w.add_body(tb.Box(size=(1, 1, 1)), mass=1.0, orientation=q, position=tuple(0.5 * normal + 0.3 * downhill),
                         name="block", material=tb.Material(friction=mu))
        x0 = box.x.copy()
        traj = tb.Simulator(w).run(2.0, frame_rate=48)
        if mu == 0.3:
            sel = traj.time >= 0.5
            slope = np.polyfit(traj.time[sel], traj.velocity[sel, 1] @ downhill, 1)[0]
            assert slope == pytest.approx(G * (math.sin(a) - mu * math.cos(a)), rel=0.01)
            # it slid on the face: no hop over the edges (height above the ramp within 1 mm of 0.5 m)
            assert np.all(np.abs((traj.position[:, 1] @ normal) - 0.5) < 1e-3)
        else:
            assert np.linalg.norm(box.x - x0) < 1e-3


# ------------------------------------------------------------------------------------------ kinematic
def test_a_kinematic_open_sheet_lifts_and_turns_what_rests_on_it():
    """An open sheet on a kinematic body (wound facing down, the box on its back) rising at 0.5 m/s
    while turning at 1 rad/s about z carries a box at rest on it: after 2 s the box has risen 1 m
    with it (1 mm: the soft contact's give under the box's weight and its lift) and turned 2 rad
    with it (2e-3 rad), as on a kinematic platform (tests/physics/test_kinematic.py)."""
    V, F = grid_sheet(n=4, size=2.0, down=True)
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Mesh(vertices=V, faces=F, closed=False), kinematic=True, velocity=(0, 0, 0.5),
               angular_velocity=(0, 0, 1.0), name="lift", material=tb.Material(friction=1.0))
    box = w.add_body(tb.Box(size=(0.3, 0.2, 0.1)), mass=1.0, position=(0.25, 0.1, 0.05), name="box",
                     material=tb.Material(friction=1.0))
    tb.Simulator(w).run(2.0, frame_rate=4)
    assert box.x[2] == pytest.approx(1.0 + 0.05, abs=1e-3)
    angle = math.atan2(box.R[1, 0], box.R[0, 0])
    assert angle == pytest.approx(2.0, abs=2e-3)
    assert np.hypot(*box.x[:2]) == pytest.approx(math.hypot(0.25, 0.1), abs=2e-3)


# ------------------------------------------------------------------------------------------ tunnelling
@pytest.mark.parametrize("side", [1.0, -1.0])
def test_a_fast_small_sphere_does_not_pass_through_a_sheet_of_no_thickness(side):
    """A 1 cm sphere at 100 m/s fired at a two-triangle sheet of zero thickness, from above and from
    below (test_contact's thin wall, thinner): the speculative contact stops it on its own side."""
    w = tb.World(gravity=(0, 0, 0))
    V = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=float)
    w.add_body(tb.Mesh(vertices=V, faces=[[0, 1, 2], [0, 2, 3]], closed=False), fixed=True, name="sheet")
    bullet = w.add_body(tb.Sphere(radius=0.005), mass=0.001, position=(0.1, 0.2, 3.0 * side),
                        velocity=(0, 0, -100.0 * side), name="bullet")
    tb.Simulator(w).run(0.125, frame_rate=8)
    assert bullet.x[2] * side > 0.0


# ------------------------------------------------------------------------------------------ shell
def test_bodies_inside_a_closed_shell_held_open_stay_inside():
    """A closed icosphere (radius 1 m, wound outwards) given as closed = false is a hollow shell: balls
    and boxes dropped inside it meet the triangles' backs and come to rest on its inside bottom,
    every point of them within the sphere (a solid mesh would throw them out). Run 4 s: at 3 s a body
    of the six thrown at random still moves at over 0.05 m/s on 4 of seeds 0-9 (0.10-0.39 m/s; a
    chaotic scene: session 43's crease reduction in the mesh manifold moved this seed's 0.033 m/s to
    0.073); this seed's bodies are all asleep at 4 s, with and without it."""
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    w = tb.World(gravity=(0, 0, -G))
    w.add_body(tb.Mesh(vertices=sphere.vertices, faces=sphere.faces, closed=False), fixed=True, name="shell")
    rng = np.random.default_rng(3)
    for k in range(6):
        shape = tb.Sphere(0.12) if k % 2 else tb.Box(size=(0.2, 0.15, 0.1))
        w.add_body(shape, mass=1.0, position=rng.uniform(-0.3, 0.3, 3), velocity=rng.uniform(-2, 2, 3), name=f"b{k}")
    tb.Simulator(w).run(4.0, frame_rate=8)
    corners = 0.5 * np.array([[sx * 0.2, sy * 0.15, sz * 0.1] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    for i in range(1, w.body_count):
        if isinstance(w.shapes[i], tb.Sphere):
            reach = np.linalg.norm(w.x[i]) + 0.12
        else:
            reach = np.linalg.norm(w.x[i] + corners @ w.R[i].T, axis=1).max()
        # the facets lie inside the unit sphere (their corners on it): 1 m plus the contact's 1 mm
        assert reach < 1.0 + 1e-3
        assert np.linalg.norm(w.v[i]) < 0.05
    assert w.x[1:, 2].max() < -0.5  # on the bottom


# ------------------------------------------------------------------------------------------ queries
def test_rays_and_closest_points_meet_an_open_sheet_from_both_sides():
    """world.ray_cast hits the sheet from above and from below at the plane z = 0.5; world.closest_points
    gives a ball's distance to it from either side (|z - 0.5| - r, exact for a flat sheet)."""
    V, F = grid_sheet(n=4, size=2.0)
    w = tb.World(gravity=(0, 0, 0))
    w.add_body(tb.Mesh(vertices=V, faces=F, closed=False), fixed=True, position=(0, 0, 0.5), name="sheet")
    for z, direction in ((2.0, -1.0), (-1.0, 1.0)):
        hit = w.ray_cast(origin=(0.1, 0.2, z), direction=(0, 0, direction))
        assert hit.body[0] == 0 and hit.distance[0] == pytest.approx(abs(z - 0.5), abs=1e-12)
        assert hit.normal[0] @ (0, 0, direction) < 0  # facing the ray
    for z in (0.9, 0.1):
        w2 = tb.World(gravity=(0, 0, 0))
        w2.add_body(tb.Mesh(vertices=V, faces=F, closed=False), fixed=True, position=(0, 0, 0.5))
        w2.add_body(tb.Sphere(0.1), mass=1.0, position=(0.1, 0.2, z))
        assert w2.closest_points(1, 0).distance[0] == pytest.approx(abs(z - 0.5) - 0.1, abs=1e-9)


# ------------------------------------------------------------------------------------------ edge flags
def test_an_open_sheets_edge_flags_see_a_ridge_as_convex_from_the_front_and_concave_from_the_back():
    """Two triangles meeting at a ridge along y (a tent): the shared edge is convex seen from above
    (active in the front bits) and concave from below (inactive in the back bits); the open boundary
    edges are active on both sides; a flat fold is inactive on both."""
    V = np.array([[0, 0, 1], [0, 1, 1], [-1, 0, 0], [1, 0, 0]], dtype=float)  # ridge from corner 0 to 1
    F = np.array([[0, 1, 2], [0, 3, 1]])  # both wound counter-clockwise seen from above (normals up)
    flags = mesh_edge_flags(V, F, two_sided=True)
    assert np.all(flags & TWO_SIDED)
    # triangle 0 (0, 1, 2): edge 0 runs 0 -> 1, the ridge; triangle 1 (0, 3, 1): edge 2 runs 1 -> 0
    assert flags[0] & 7 == 0b111 and flags[1] & 7 == 0b111  # from above the ridge is convex: all active
    back0, back1 = (flags >> BACK_SHIFT) & 7
    # the turned triangle's edge j is the original's edge 2 - j: the ridge is back edge 2 of
    # triangle 0 and back edge 0 of triangle 1, concave from below: inactive; the boundary active
    assert back0 == 0b011 and back1 == 0b110
    # a closed mesh's flags are as they were: no back bits, no TWO_SIDED
    assert np.all(mesh_edge_flags(V, F) == flags & 7)
    flat = mesh_edge_flags(*grid_sheet(n=1), two_sided=True)
    assert list(flat & 7) == [0b011, 0b110] and list((flat >> BACK_SHIFT) & 7) == [0b110, 0b011]


# ------------------------------------------------------------------------------------------ input
def test_open_meshes_are_refused_where_they_cannot_go():
    """Each refusal one InputError with its key: a closed mesh expected (the hint names closed =
    false); an open mesh on a moving or sensor body; with a mass; decomposed; a hull
    held open; closed not a bool; a surface of only zero-area triangles (one of zero area dropped)."""
    V, F = grid_sheet(n=2)
    with pytest.raises(InputError, match=r"not closed .*closed = false"):
        tb.Mesh(vertices=V, faces=F)
    sheet = tb.Mesh(vertices=V, faces=F, closed=False)
    w = tb.World()
    for kw, key in ((dict(mass=1.0), "fixed"), (dict(), "fixed"), (dict(fixed=True, sensor=True), "sensor")):
        with pytest.raises(InputError, match="open mesh") as info:
            w.add_body(sheet, **kw)
        assert info.value.key == key
    with pytest.raises(InputError, match="no volume, so it has no mass") as info:
        w.add_body(sheet, fixed=True, mass=1.0)
    assert w.body_count == 0
    with pytest.raises(InputError, match="no inside to cut"):
        tb.decompose(sheet)
    with pytest.raises(InputError, match="always closed"):
        tb.Convex(points=V + np.random.default_rng(0).normal(0, 0.1, V.shape), closed=False)
    with pytest.raises(InputError, match="true or false") as info:
        tb.Mesh(vertices=V, faces=F, closed="no")
    assert info.value.key == "closed"
    with pytest.raises(InputError, match="no non-degenerate triangles"):
        tb.Mesh(vertices=[[0, 0, 0], [1, 0, 0], [2, 0, 0]], faces=[[0, 1, 2]], closed=False)
    # what is kept: duplicates merged, a zero-area triangle dropped
    kept = tb.Mesh(vertices=np.vstack([V, V[:1]]), faces=np.vstack([F, [[0, 1, 9]]]), closed=False)
    assert len(kept.faces) == len(F) and len(kept.vertices) == len(V)


def test_an_open_mesh_goes_through_a_scene_file_a_trajectory_and_a_snapshot(tmp_path):
    """A scene's ``closed = false`` makes the open sheet; the trajectory's shape record keeps it open
    (``shape_to_dict`` writes ``closed = false`` only then) and its glTF material is double-sided; a
    snapshot restored repeats the run bit for bit."""
    V, F = grid_sheet(n=2)
    (tmp_path / "sheet.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in V)
                                        + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F))
    (tmp_path / "scene.toml").write_text(
        '[simulation]\nduration = 0.5\n[[bodies]]\nname = "sheet"\nfixed = true\n'
        'shape = { type = "mesh", path = "sheet.obj", closed = false }\n'
        '[[bodies]]\nname = "ball"\nmass = 1\nposition = [0, 0, 1]\nshape = { type = "sphere", radius = 0.2 }\n')
    scene = tb.load_scene(tmp_path / "scene.toml")
    sheet = scene.world.shapes[0]
    assert isinstance(sheet, tb.Mesh) and not sheet.closed
    assert shape_to_dict(sheet)["closed"] is False and "closed" not in shape_to_dict(tb.Convex(points=np.vstack([np.eye(3), 0.0 * np.eye(3)[:1]])))
    sim = scene.simulator()
    traj = sim.run(0.5)
    traj.save(tmp_path / "t.npz")
    again = tb.load_trajectory(tmp_path / "t.npz").shape(0)
    assert isinstance(again, tb.Mesh) and not again.closed and np.array_equal(again.faces, sheet.faces)
    # drawn from both sides: the sheet's glTF material is double-sided, the ball's not
    from tumble.export.gltf import gltf_document

    doc, _ = gltf_document(traj)
    sides = [doc["materials"][p["material"]]["doubleSided"] for m in doc["meshes"] for p in m["primitives"]]
    assert sorted(sides) == [False, True]
    saved = sim.save_state()
    sim.step(60)
    first = scene.world.pack().copy()
    sim.restore_state(saved)
    sim.step(60)
    assert np.array_equal(scene.world.pack(), first)
    assert scene.world.x[1, 2] == pytest.approx(0.2, abs=1e-3)  # resting on the sheet
