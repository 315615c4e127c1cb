"""Tests for tumble/mass.py: particle sums, closed forms, polyhedral integrals, mesh input checks."""

import math

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from tumble.errors import InputError
from tumble.mass import (
    MassProperties,
    box_mesh,
    convex_hull_mesh,
    load_closed_mesh,
    mass_properties,
    particle_mass_properties,
    particles_from_shape,
)
from tumble.shapes import Box, Capsule, Cone, Convex, Cylinder, Ellipsoid, Mesh, Particles, Plane, Sphere

GRID_SIZES = (4, 8, 16, 32)


def relative_inertia_error(shape, n, mass=2.5):
    """Largest entry of |I_particles - I_closed| over the largest closed-form moment."""
    exact = mass_properties(shape, mass=mass)
    approx = mass_properties(particles_from_shape(shape, n, mass))
    assert approx.mass == pytest.approx(mass, rel=1e-12)
    return np.max(np.abs(approx.inertia - exact.inertia)) / np.max(np.abs(exact.inertia))


def write_obj(path, vertices, faces):
    lines = [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def random_hull_mesh(seed=3):
    """A closed convex mesh with no symmetry at all (generic, distinct principal moments)."""
    points = np.random.default_rng(seed).normal(size=(40, 3)) * (1.0, 0.6, 0.35)
    return convex_hull_mesh(points=points)


# ---------- particles converge to the closed forms ----------


def test_box_particles_converge_as_one_over_n_squared():
    # Compared with: the box closed form m/12 (b^2 + c^2). Why this tolerance: the
    # cell-centred grid is the midpoint rule, whose sum of x_i^2 over n cells is
    # a^2/12 (1 - 1/n^2) exactly, so the relative error is exactly 1/n^2 and the
    # ratio of errors when n doubles is exactly 4 up to round-off (1e-9).
    box = Box((0.2, 0.6, 1.0))
    errors = [relative_inertia_error(box, n) for n in GRID_SIZES]
    assert all(a > b for a, b in zip(errors, errors[1:]))
    for n, err in zip(GRID_SIZES, errors):
        assert err == pytest.approx(1.0 / n**2, rel=1e-9)
    ratios = [a / b for a, b in zip(errors, errors[1:])]
    assert ratios == pytest.approx([4.0] * 3, rel=1e-9)
    assert errors[-1] < 1e-3


def test_sphere_particles_converge():
    # Compared with: 2/5 m r^2. Why this tolerance: the kept cells approximate the
    # ball by voxels, an O(1/n) surface error; measured errors are 6.3e-2, 2.5e-2,
    # 9.9e-3, 3.8e-3, so at n = 32 a bound of 5e-3 holds with margin.
    sphere = Sphere(0.3)
    errors = [relative_inertia_error(sphere, n) for n in GRID_SIZES]
    assert all(a > b for a, b in zip(errors, errors[1:])), errors
    assert errors[-1] < 5e-3


def test_cylinder_particles_converge():
    # Compared with: m/12 (3 r^2 + h^2) and m r^2 / 2. Why this tolerance: along z the
    # grid is the midpoint rule (1/n^2), but the disc cross-section is cells whose
    # centre is inside the circle, whose area and second moment fluctuate with n
    # (lattice points in a circle): the error is 6.8e-2, 1.2e-2, 1.6e-2, 4.6e-3 for
    # n = 4, 8, 16, 32. So it is not monotone at n = 16: we check that it stays under
    # an 0.3/n envelope, falls overall, and is below 1e-2 at n = 32.
    cylinder = Cylinder(radius=0.25, length=0.8)
    errors = [relative_inertia_error(cylinder, n) for n in GRID_SIZES]
    for n, err in zip(GRID_SIZES, errors):
        assert err < 0.3 / n, (n, err)
    assert errors[0] > errors[1] and errors[1] > errors[3] and errors[2] > errors[3]
    assert errors[-1] < 1e-2


def test_particles_from_shape_rejects_others():
    with pytest.raises(InputError, match="box, sphere or cylinder") as info:
        particles_from_shape(Cone(1.0, 1.0), 4, 1.0)
    assert info.value.key == "shape"
    with pytest.raises(InputError, match="whole number") as info:
        particles_from_shape(Box((1, 1, 1)), 0, 1.0)
    assert info.value.key == "n"


# ---------- the course's particle sums ----------


def test_particle_sums_match_independent_computation():
    # Compared with: the same sums written component by component with einsum,
    # I_jk = sum_i m_i (|r'_i|^2 delta_jk - r'_ij r'_ik). Why 1e-12: both are the
    # same finite sums in a different order, so they differ by round-off only.
    rng = np.random.default_rng(7)
    points = rng.normal(size=(200, 3)) + (1.0, -2.0, 0.5)
    masses = rng.uniform(0.1, 2.0, size=200)
    props = mass_properties(Particles(points, masses))

    total = masses.sum()
    center = np.einsum("i,ij->j", masses, points) / total
    rp = points - center
    inertia = np.einsum("i,i,jk->jk", masses, np.einsum("ij,ij->i", rp, rp), np.eye(3)) - np.einsum(
        "i,ij,ik->jk", masses, rp, rp
    )
    assert props.mass == pytest.approx(total, rel=1e-12)
    np.testing.assert_allclose(props.center, center, rtol=0, atol=1e-12 * np.abs(points).max())
    np.testing.assert_allclose(props.inertia, inertia, rtol=0, atol=1e-12 * np.abs(inertia).max())


def test_particle_center_and_two_point_dumbbell():
    # Compared with: a hand computation. Two masses 1 and 3 kg at x = 0 and x = 4:
    # centre at x = 3, Iyy = Izz = 1*9 + 3*1 = 12, Ixx = 0. Exact in binary, so 1e-15.
    props = particle_mass_properties([[0, 0, 0], [4, 0, 0]], [1.0, 3.0])
    np.testing.assert_allclose(props.center, [3.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(props.inertia, np.diag([0.0, 12.0, 12.0]), atol=1e-15)


def test_particles_mass_rescales():
    # Compared with: the unscaled particle set. Scaling every m_i by k keeps the
    # centre and multiplies I by k; only round-off differs (1e-12).
    rng = np.random.default_rng(1)
    shape = Particles(rng.normal(size=(30, 3)), rng.uniform(0.5, 1.5, size=30))
    base = mass_properties(shape)
    scaled = mass_properties(shape, mass=10.0)
    k = 10.0 / base.mass
    assert scaled.mass == pytest.approx(10.0, rel=1e-12)
    np.testing.assert_allclose(scaled.center, base.center, atol=1e-12)
    scale = k * np.abs(base.inertia).max()
    np.testing.assert_allclose(scaled.inertia, k * base.inertia, rtol=1e-12, atol=1e-12 * scale)


# ---------- closed forms ----------


def test_density_gives_volume_times_density():
    # Compared with: V rho for each primitive's textbook volume. Exact formulas: 1e-12.
    rho = 700.0
    cases = [
        (Sphere(0.5), 4 / 3 * math.pi * 0.125),
        (Box((0.2, 0.6, 1.0)), 0.12),
        (Cylinder(0.5, 2.0), math.pi * 0.25 * 2.0),
        (Capsule(0.5, 2.0), math.pi * 0.25 * 2.0 + 4 / 3 * math.pi * 0.125),
        (Cone(0.5, 2.0), math.pi * 0.25 * 2.0 / 3),
        (Ellipsoid((0.5, 0.3, 0.2)), 4 / 3 * math.pi * 0.03),
    ]
    for shape, volume in cases:
        assert mass_properties(shape, density=rho).mass == pytest.approx(rho * volume, rel=1e-12)


def test_capsule_closed_form_reduces_to_sphere():
    # Compared with: a sphere. A capsule of nearly zero length is a sphere, so
    # the hemisphere offsets (3r/8) must recombine to 2/5 m r^2; the residual is
    # O(length) = 1e-9 relative.
    props = mass_properties(Capsule(0.7, 1e-9), mass=3.0)
    np.testing.assert_allclose(props.inertia, np.diag([0.4 * 3.0 * 0.49] * 3), rtol=1e-8)


def test_cone_closed_form_matches_fine_mesh():
    # Compared with: the exact integrals of trimesh.creation.cone with n = 1024 sections.
    # Why this tolerance: the mesh is the cone over an inscribed regular n-gon. With
    # the mass held equal, an n-gon of circumradius r has polar moment per area
    # r^2 (2 + cos t)/6, t = 2 pi / n, against r^2/2 for the disc: the r^2 terms are
    # low by exactly (1 - cos t)/3 = 6.3e-6, and the h^2 term and the centre are exact.
    # We allow that bound plus 1e-9 for round-off.
    n, radius, height, mass = 1024, 0.4, 1.3, 2.0
    bound = (1.0 - math.cos(2.0 * math.pi / n)) / 3.0 + 1e-9
    cone = trimesh.creation.cone(radius=radius, height=height, sections=n)
    meshed = mass_properties(Mesh(vertices=cone.vertices, faces=cone.faces), mass=mass)
    exact = mass_properties(Cone(radius, height), mass=mass)
    np.testing.assert_allclose(exact.center, [0.0, 0.0, height / 4.0], atol=1e-15)
    np.testing.assert_allclose(meshed.center, exact.center, atol=1e-12)
    rel = np.abs(meshed.inertia - exact.inertia) / np.max(np.abs(exact.inertia.diagonal()))
    assert rel.max() < bound
    assert meshed.inertia[2, 2] < exact.inertia[2, 2]  # the inscribed polygon is always smaller


def test_capsule_closed_form_matches_fine_mesh():
    # Compared with: the exact integrals of trimesh.creation.capsule, count = [256, 256].
    # Why this tolerance: every latitude ring is an inscribed 256-gon, which lowers the
    # r^2 terms by (1 - cos t)/3 = 1.0e-4, t = 2 pi / 256 (as for the cone); the chords
    # along the meridians of the hemispheres add an error of the same order but smaller
    # (measured: 1.04e-4 in all). We allow twice the polygon term.
    n, radius, length, mass = 256, 0.3, 1.2, 2.0
    bound = 2.0 * (1.0 - math.cos(2.0 * math.pi / n)) / 3.0
    capsule = trimesh.creation.capsule(height=length, radius=radius, count=[n, n])
    meshed = mass_properties(Mesh(vertices=capsule.vertices, faces=capsule.faces), mass=mass)
    exact = mass_properties(Capsule(radius, length), mass=mass)
    np.testing.assert_allclose(meshed.center, exact.center, atol=1e-12)
    rel = np.abs(meshed.inertia.diagonal() - exact.inertia.diagonal()) / exact.inertia.diagonal()
    assert rel.max() < bound
    assert np.abs(meshed.inertia - np.diag(meshed.inertia.diagonal())).max() < 1e-12


# ---------- exact polyhedral integrals ----------


@pytest.mark.parametrize("kind", ["mass", "density"])
def test_box_mesh_matches_box_closed_form(kind):
    # Compared with: the box closed form. Why 1e-9: the polyhedral integrals are exact
    # for a box (polynomial integrands over planar faces), so only round-off differs.
    size = (0.2, 0.6, 1.0)
    vertices, faces = box_mesh(size)
    assert vertices.shape == (8, 3) and faces.shape == (12, 3)
    kwargs = {"mass": 2.0} if kind == "mass" else {"density": 2.0 / 0.12}
    meshed = mass_properties(Mesh(vertices=vertices, faces=faces), **kwargs)
    exact = mass_properties(Box(size), mass=2.0)
    assert meshed.mass == pytest.approx(exact.mass, rel=1e-9)
    np.testing.assert_allclose(meshed.center, exact.center, atol=1e-9 * max(size))
    np.testing.assert_allclose(meshed.inertia, exact.inertia, rtol=0, atol=1e-9 * exact.inertia.max())


def test_mesh_inertia_is_about_center_of_mass_like_trimesh():
    # Compared with: trimesh.Trimesh.moment_inertia / center_mass of the same mesh
    # moved far from its origin (trimesh returns the inertia about the centre of
    # mass). Same integrals about another reference point: round-off only, 1e-9.
    mesh = random_hull_mesh()
    mesh.apply_translation([5.0, -3.0, 8.0])
    ours = mass_properties(Mesh(vertices=mesh.vertices, faces=mesh.faces), density=1000.0)
    mesh.density = 1000.0
    np.testing.assert_allclose(ours.center, mesh.center_mass, rtol=1e-9)
    np.testing.assert_allclose(ours.inertia, mesh.moment_inertia, rtol=0, atol=1e-9 * np.abs(ours.inertia).max())
    assert ours.mass == pytest.approx(mesh.mass, rel=1e-12)


def test_moved_mesh_keeps_principal_moments():
    # Compared with: the unmoved mesh. Rotating by R and translating by t is exact
    # for the integrals: the principal moments are the same, the centre becomes
    # R c + t and the inertia R I R^T, so only round-off differs (1e-9 relative).
    mesh = random_hull_mesh()
    rotation = Rotation.from_rotvec([0.4, -1.1, 0.7]).as_matrix()
    translation = np.array([3.0, -2.0, 5.0])
    base = mass_properties(Mesh(vertices=mesh.vertices, faces=mesh.faces), mass=1.5)
    moved_vertices = mesh.vertices @ rotation.T + translation
    moved = mass_properties(Mesh(vertices=moved_vertices, faces=mesh.faces), mass=1.5)
    m0, _ = base.principal()
    m1, _ = moved.principal()
    np.testing.assert_allclose(m1, m0, rtol=1e-9)
    moved_center = rotation @ base.center + translation
    np.testing.assert_allclose(moved.center, moved_center, atol=1e-9 * np.abs(translation).max())
    scale = np.abs(base.inertia).max()
    np.testing.assert_allclose(moved.inertia, rotation @ base.inertia @ rotation.T, rtol=0, atol=1e-9 * scale)


def test_principal_is_a_proper_rotation():
    # Compared with: the inertia it came from. eigh is backward stable: 1e-12.
    props = mass_properties(Mesh(vertices=random_hull_mesh().vertices, faces=random_hull_mesh().faces), mass=1.0)
    moments, axes = props.principal()
    assert np.all(np.diff(moments) > 0)
    assert np.linalg.det(axes) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(axes @ np.diag(moments) @ axes.T, props.inertia, atol=1e-12 * moments.max())


def test_convex_shape_and_hull_of_a_file(tmp_path):
    # Compared with: the box closed form; the hull of a box's corners is the box (exact, 1e-9).
    vertices, faces = box_mesh((1.0, 2.0, 3.0))
    hull = mass_properties(Convex(points=vertices), mass=6.0)
    np.testing.assert_allclose(hull.inertia, mass_properties(Box((1.0, 2.0, 3.0)), mass=6.0).inertia, atol=1e-9)
    # a mesh file need not be closed to be hulled
    path = write_obj(tmp_path / "open.obj", vertices, faces[:-1])
    from_file = mass_properties(Convex(path=str(path)), mass=6.0)
    np.testing.assert_allclose(from_file.inertia, hull.inertia, atol=1e-9)


def test_mesh_winding_is_fixed(tmp_path):
    # Compared with: the box closed form. One face flipped, or every face flipped
    # (inside out), is repaired to the same box: exact integrals, 1e-9.
    vertices, faces = box_mesh((1.0, 2.0, 3.0))
    one_flipped = faces.copy()
    one_flipped[0] = one_flipped[0, ::-1]
    exact = mass_properties(Box((1.0, 2.0, 3.0)), density=1.0)
    for f in (one_flipped, faces[:, ::-1]):
        props = mass_properties(Mesh(vertices=vertices, faces=f), density=1.0)
        assert props.mass == pytest.approx(6.0, rel=1e-9)
        np.testing.assert_allclose(props.inertia, exact.inertia, atol=1e-9)
    path = write_obj(tmp_path / "inside_out.obj", vertices, faces[:, ::-1])
    assert load_closed_mesh(path=str(path)).volume == pytest.approx(6.0, rel=1e-9)


def test_random_flips_and_inside_out_bodies_are_fixed():
    # Compared with: the same meshes correctly wound. Repair only reorders face
    # indices, so the integrals are the same sums up to round-off (1e-9).
    sphere = trimesh.creation.icosphere(subdivisions=3)
    sphere.apply_scale([1.0, 0.7, 0.4])
    flipped = sphere.faces.copy()
    rows = np.random.default_rng(5).random(len(flipped)) < 0.4
    flipped[rows] = flipped[rows, ::-1]
    repaired = load_closed_mesh(vertices=sphere.vertices, faces=flipped)
    assert repaired.volume == pytest.approx(sphere.volume, rel=1e-9)

    # two separate boxes, the second inside out: each body is turned outward on its own
    v, f = box_mesh((1.0, 1.0, 1.0))
    vertices = np.vstack([v, v + (3.0, 0.0, 0.0)])
    faces = np.vstack([f, f[:, ::-1] + 8])
    props = mass_properties(Mesh(vertices=vertices, faces=faces), density=1.0)
    assert props.mass == pytest.approx(2.0, rel=1e-9)
    np.testing.assert_allclose(props.center, [1.5, 0.0, 0.0], atol=1e-9)


def test_mass_properties_is_frozen():
    props = mass_properties(Sphere(1.0), mass=1.0)
    assert isinstance(props, MassProperties)
    with pytest.raises(ValueError):
        props.inertia[0, 0] = 2.0
    assert props == mass_properties(Sphere(1.0), mass=1.0)


# ---------- bad input ----------


@pytest.mark.parametrize(
    "shape, kwargs, key, message",
    [
        (Sphere(1.0), {"mass": 1.0, "density": 1.0}, "mass", "either mass or density, not both"),
        (Sphere(1.0), {}, "mass", "give either mass or density"),
        (Box((1, 1, 1)), {"density": -5.0}, "density", "must be positive, got -5"),
        (Box((1, 1, 1)), {"mass": 0.0}, "mass", "must be positive, got 0"),
        (Box((1, 1, 1)), {"mass": float("nan")}, "mass", "must be positive"),
        (Cone(1.0, 1.0), {"density": float("inf")}, "density", "must be positive"),
        (Cylinder(1.0, 1.0), {"mass": "heavy"}, "mass", "expected a number"),
        (Plane(), {"mass": 1.0}, "shape", "a plane has no mass: make it fixed"),
        (Particles([[0, 0, 0]], [1.0]), {"density": 1.0}, "density", "give no density"),
        (Particles([[0, 0, 0]], [1.0]), {"mass": -1.0}, "mass", "must be positive"),
    ],
)
def test_mass_properties_bad_input(shape, kwargs, key, message):
    with pytest.raises(InputError, match=message) as info:
        mass_properties(shape, **kwargs)
    assert info.value.key == key


def test_missing_mesh_file(tmp_path):
    path = tmp_path / "nowhere.obj"
    with pytest.raises(InputError, match="mesh file not found: .*nowhere.obj") as info:
        Mesh(path=str(path))
    assert info.value.key == "path"


def test_mesh_file_not_closed(tmp_path):
    vertices, faces = box_mesh((1.0, 1.0, 1.0))
    path = write_obj(tmp_path / "open.obj", vertices, faces[:-1])  # one triangle gone: 3 open edges
    with pytest.raises(InputError, match=r"mesh is not closed \(watertight\): 3 boundary edges") as info:
        Mesh(path=str(path))
    assert info.value.key == "path"


def test_unreadable_mesh_files(tmp_path):
    empty = tmp_path / "empty.obj"
    empty.write_text("")
    with pytest.raises(InputError, match="no triangles") as info:
        load_closed_mesh(path=str(empty))
    assert info.value.key == "path"
    unknown = tmp_path / "mesh.notaformat"
    unknown.write_text("hello")
    with pytest.raises(InputError, match="cannot read mesh file") as info:
        load_closed_mesh(path=str(unknown))
    assert info.value.key == "path"


@pytest.mark.parametrize("text, expected", [
    ("this is not an obj\nv 1 2\nf 1 2 3\n", "line 2: a vertex has 2 coordinates, expected 3"),
    ("v 0 0 0\nv 1 0 0\nf 1 2 7\n", "line 3: a face refers to vertex 7 of 2"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "line 4: cannot parse the face corner 'x'"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nv a b c\nf 1 2 3\n", "line 4: cannot parse the vertex 'v a b c'"),
])
def test_an_unreadable_obj_says_what_is_wrong_with_the_file(tmp_path, text, expected):
    """An OBJ file trimesh cannot read gets one line naming the line of the file and its problem,
    not NumPy's "index 1 is out of bounds for axis 0 with size 1"."""
    path = tmp_path / "bad.obj"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        load_closed_mesh(path=str(path))
    assert info.value.key == "path" and "\n" not in str(info.value)
    assert f"cannot read mesh file {path}: {expected}" in str(info.value), str(info.value)


def test_inline_mesh_not_closed_or_flat():
    vertices, faces = box_mesh((1.0, 1.0, 1.0))
    with pytest.raises(InputError, match="not closed .*3 boundary edges") as info:
        Mesh(vertices=vertices, faces=faces[1:])
    assert info.value.key == "vertices"
    flat = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=float)  # closed tetrahedron, no volume
    tetra = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    with pytest.raises(InputError, match="no volume") as info:
        load_closed_mesh(vertices=flat, faces=tetra)
    assert info.value.key == "vertices"


@pytest.mark.parametrize(
    "vertices, faces, key, message",
    [
        (np.zeros((4, 2)), [[0, 1, 2]], "vertices", r"\(V, 3\)"),
        ([[0, 0, 0], [1, 0, 0], [0, float("nan"), 0]], [[0, 1, 2]], "vertices", "finite"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 3]], "faces", r"must lie in \[0, 2\]"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, -1]], "faces", "must lie in"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 1.5]], "faces", "whole numbers"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1]], "faces", r"\(F, 3\)"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], None, "faces", "without faces"),
    ],
)
def test_inline_mesh_bad_arrays(vertices, faces, key, message):
    with pytest.raises(InputError, match=message) as info:
        load_closed_mesh(vertices=vertices, faces=faces)
    assert info.value.key == key


def test_mesh_path_and_arrays_are_exclusive(tmp_path):
    vertices, faces = box_mesh((1.0, 1.0, 1.0))
    path = write_obj(tmp_path / "box.obj", vertices, faces)
    with pytest.raises(InputError, match="not both") as info:
        load_closed_mesh(path=str(path), vertices=vertices, faces=faces)
    assert info.value.key == "path"
    with pytest.raises(InputError, match="give a mesh file path or inline") as info:
        load_closed_mesh()
    assert info.value.key == "path"


@pytest.mark.parametrize(
    "points",
    [
        [[0, 0, 0], [1, 0, 0], [0, 1, 0]],  # too few
        [[x, y, 0.0] for x in range(3) for y in range(3)],  # all in the plane z = 0
        [[t, 2 * t, -t] for t in range(6)],  # on a line
    ],
)
def test_degenerate_convex_hull(points):
    with pytest.raises(InputError, match="convex hull needs at least 4 points not all in one plane") as info:
        Convex(points=points)
    assert info.value.key == "points"


def test_convex_hull_bad_points():
    with pytest.raises(InputError, match="finite") as info:
        convex_hull_mesh(points=[[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, float("inf")]])
    assert info.value.key == "points"


@pytest.mark.parametrize("shape, amount", [(Capsule(1e300, 1.0), {"density": 1.0}), (Sphere(1e200), {"mass": 1.0}),
                                           (Cylinder(1e160, 1.0), {"density": 1.0})])
def test_a_shape_too_large_for_a_float_is_one_input_error(shape, amount):
    # Python's float power raises OverflowError where NumPy gives inf (found by the URDF fuzz: a
    # capsule of radius 1e300 in a URDF loaded with inertia="shapes" ended in a traceback)
    with pytest.raises(InputError, match="too large"):
        mass_properties(shape, **amount)


def test_a_compound_part_past_the_float_range_is_one_line():
    # A ball of radius 1e80 m has a volume of 4e240 and moments past the float range: the sums
    # gave NaN with a RuntimeWarning (found by the URDF fuzz test); now a typed error naming the part.
    import tumble as tb
    from tumble.errors import InputError
    from tumble.mass import mass_properties

    huge = tb.Compound([(tb.Sphere(1e80), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0)),
                        (tb.Sphere(0.1), (1.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))])
    with pytest.raises(InputError, match="part 0 is too large"):
        mass_properties(huge, mass=1.0)


def test_a_compound_of_parts_too_small_for_floating_point_is_one_line():
    # Balls of radius 1e-110 m have a volume of 0 in floating point (4e-330 underflows): the density
    # mass / volume divided by zero (found by the URDF fuzz with a mesh scaled by 3.9e-234); now a
    # typed error.
    import tumble as tb
    from tumble.errors import InputError
    from tumble.mass import mass_properties

    tiny = tb.Compound([(tb.Sphere(1e-110), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0)),
                        (tb.Sphere(1e-110), (1.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))])
    with pytest.raises(InputError, match="too small: their volume is 0"):
        mass_properties(tiny, mass=1.0)
