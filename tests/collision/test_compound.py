"""Compound bodies: the shape record, its mass properties, one ShapeTable row per part, contacts per part.

Mass properties are compared with trimesh's exact polyhedral integrals of the parts'
meshes placed the same way (rtol 1e-9: both are closed forms, only round-off differs)
and with closed forms (a box split in two is the whole box; a part turned by 90 degrees
swaps its moments).
"""

import numpy as np
import pytest
import trimesh

import tumble as tb
from tumble.collision import CollisionPipeline, build_shape_table, update_bounds
from tumble.errors import InputError
from tumble.mass import mass_properties
from tumble.math3d import quat_to_matrix
from tumble.shapes import (
    SHAPE_BOX,
    SHAPE_CONVEX,
    SHAPE_CYLINDER,
    SHAPE_MESH,
    SHAPE_SPHERE,
    Compound,
    shape_from_dict,
    shape_to_dict,
)


def q_axis(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return (np.cos(angle / 2), *(np.sin(angle / 2) * axis))


PARTS = [
    (tb.Box((0.4, 0.2, 0.3)), (0.5, 0.0, 0.1), q_axis((0, 0, 1), 0.3)),
    (tb.Box((0.2, 0.6, 0.2)), (-0.4, 0.2, 0.0), q_axis((1, 1, 0), 0.7)),
    (tb.Box((0.3, 0.3, 0.1)), (0.0, -0.2, 0.6), (1.0, 0.0, 0.0, 0.0)),
]


def test_mass_matches_trimesh_of_the_placed_parts():
    meshes = []
    for shape, pos, q in PARTS:
        m = trimesh.creation.box(extents=shape.size)
        T = np.eye(4)
        T[:3, :3] = quat_to_matrix(np.asarray(q))
        T[:3, 3] = pos
        m.apply_transform(T)
        meshes.append(m)
    ref = trimesh.util.concatenate(meshes)
    ref.density = 700.0
    props = mass_properties(Compound(PARTS), density=700.0)
    assert props.mass == pytest.approx(ref.mass, rel=1e-12)
    np.testing.assert_allclose(props.center, ref.center_mass, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(props.inertia, ref.moment_inertia, rtol=1e-9, atol=1e-12)
    # by mass: the same density, scaled
    props_m = mass_properties(Compound(PARTS), mass=2.0)
    np.testing.assert_allclose(props_m.inertia, props.inertia * 2.0 / props.mass, rtol=1e-12)


def test_closed_forms():
    # a 2 x 1 x 1 box cut in two halves
    halves = Compound([(tb.Box((1, 1, 1)), (0.5, 0, 0), (1, 0, 0, 0)), (tb.Box((1, 1, 1)), (-0.5, 0, 0), (1, 0, 0, 0))])
    a, b = mass_properties(halves, mass=3.0), mass_properties(tb.Box((2, 1, 1)), mass=3.0)
    np.testing.assert_allclose(a.center, 0.0, atol=1e-15)
    np.testing.assert_allclose(a.inertia, b.inertia, rtol=1e-12)
    # a cylinder turned onto the x axis, off centre: centre moves, moments swap (x <-> z)
    cyl = tb.Cylinder(0.2, 1.0)
    one = Compound([(cyl, (0.0, 0.3, 0.0), q_axis((0, 1, 0), np.pi / 2))])
    p, c = mass_properties(one, mass=1.0), mass_properties(cyl, mass=1.0)
    np.testing.assert_allclose(p.center, (0.0, 0.3, 0.0), atol=1e-15)
    np.testing.assert_allclose(np.diag(p.inertia), np.diag(c.inertia)[[2, 1, 0]], rtol=1e-12)
    # a cone keeps its own centre of mass (height / 4 up its axis) inside the compound
    cone = Compound([(tb.Cone(0.3, 0.8), (1.0, 0, 0), (1, 0, 0, 0))])
    np.testing.assert_allclose(mass_properties(cone, mass=1.0).center, (1.0, 0, 0.2), atol=1e-15)


def test_nested_compound_equals_flat():
    inner = Compound(PARTS[:2])
    nested = Compound([(inner, (0.1, 0.2, 0.3), q_axis((0, 0, 1), 0.5)), PARTS[2]])
    R = quat_to_matrix(np.asarray(q_axis((0, 0, 1), 0.5)))
    from tumble.collision.geometry import _quat_mul

    flat = Compound([(s, np.array([0.1, 0.2, 0.3]) + R @ np.asarray(p), tuple(_quat_mul(np.array(q_axis((0, 0, 1), 0.5)),
                                                                                        np.asarray(q))))
                     for s, p, q in PARTS[:2]] + [PARTS[2]])
    a, b = mass_properties(nested, density=1.0), mass_properties(flat, density=1.0)
    np.testing.assert_allclose(a.center, b.center, atol=1e-14)
    np.testing.assert_allclose(a.inertia, b.inertia, atol=1e-14)


def test_dict_round_trip_and_input_errors():
    c = Compound(PARTS)
    d = shape_to_dict(c)
    assert d["type"] == "compound" and len(d["parts"]) == 3
    back = shape_from_dict(d)
    assert all(type(a[0]) is type(b[0]) and np.allclose(a[1], b[1]) and np.allclose(a[2], b[2])
               for a, b in zip(c.parts, back.parts))
    # parts as mappings (scene files), with defaults
    m = Compound([{"shape": {"type": "sphere", "radius": 0.1}}, {"shape": tb.Box((1, 1, 1)), "position": (1, 0, 0)}])
    assert m.parts[0][2] == (1.0, 0.0, 0.0, 0.0) and m.parts[1][1].tolist() == [1, 0, 0]
    with pytest.raises(InputError, match="at least one part"):
        Compound([])
    with pytest.raises(InputError, match="solid shape"):
        Compound([(tb.Plane(), (0, 0, 0), (1, 0, 0, 0))])
    with pytest.raises(InputError, match="zero quaternion"):
        Compound([(tb.Sphere(1), (0, 0, 0), (0, 0, 0, 0))])
    with pytest.raises(InputError, match="parts\\[0\\].position"):
        Compound([(tb.Sphere(1), (0, np.nan, 0), (1, 0, 0, 0))])


def dumbbell():
    return Compound([(tb.Sphere(0.2), (-0.5, 0, 0), (1, 0, 0, 0)), (tb.Sphere(0.2), (0.5, 0, 0), (1, 0, 0, 0)),
                     (tb.Cylinder(0.05, 1.0), (0, 0, 0), q_axis((0, 1, 0), np.pi / 2))])


def test_table_rows_per_part_with_com_offset():
    w = tb.World()
    w.add_body(tb.Plane(), fixed=True, name="ground")
    # asymmetric: the centre of mass is off the compound's origin
    shape = Compound([(tb.Box((0.4, 0.4, 0.4)), (0.3, 0, 0), (1, 0, 0, 0)),
                      (tb.Sphere(0.1), (-0.4, 0, 0), (1, 0, 0, 0))])
    q = q_axis((0, 0, 1), 0.4)
    w.add_body(shape, density=500.0, position=(1.0, 2.0, 0.5), orientation=q, name="thing")
    t = build_shape_table(w)
    assert t.shape_type.tolist()[1:] == [SHAPE_BOX, SHAPE_SPHERE]
    assert t.shape_body.tolist() == [0, 1, 1]
    com = mass_properties(shape, density=500.0).center
    np.testing.assert_allclose(t.shape_local_pos[1:], [np.array([0.3, 0, 0]) - com, np.array([-0.4, 0, 0]) - com])
    # the parts sit where the user put them: position + R part_position
    pos, _, _ = update_bounds(w.x, w.R, t, 0.0)
    R = quat_to_matrix(np.asarray(q))
    np.testing.assert_allclose(pos[1], np.array([1.0, 2.0, 0.5]) + R @ [0.3, 0, 0], atol=1e-12)
    np.testing.assert_allclose(pos[2], np.array([1.0, 2.0, 0.5]) + R @ [-0.4, 0, 0], atol=1e-12)


def test_dumbbell_on_the_ground_and_parts_never_collide_with_each_other():
    w = tb.World()
    w.add_body(tb.Plane(), fixed=True, name="ground")
    # the bar overlaps both balls: parts of one body must not make contacts with each other
    w.add_body(dumbbell(), mass=1.0, position=(0, 0, 0.199), name="dumbbell")
    t = build_shape_table(w)
    assert t.shape_type.tolist() == [0, SHAPE_SPHERE, SHAPE_SPHERE, SHAPE_CYLINDER]
    c = CollisionPipeline(w).detect()
    pairs = sorted(zip(c.manifold_shape_a.tolist(), c.manifold_shape_b.tolist()))
    assert pairs == [(0, 1), (0, 2)]  # each ball on the plane; the bar (radius 0.05) is 0.149 above it
    np.testing.assert_allclose(c.contact_separation, -0.001, atol=1e-12)
    assert set(c.manifold_body_b.tolist()) == {1}


def test_compound_against_another_body_and_a_convex_part():
    w = tb.World()
    hull = tb.Convex(points=np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * 0.2)
    w.add_body(tb.Box((4, 4, 1)), fixed=True, position=(0, 0, -0.5), name="table")
    w.add_body(Compound([(hull, (0, 0, 0), (1, 0, 0, 0)), (tb.Cylinder(0.1, 0.4), (0, 0, 0.4), (1, 0, 0, 0))]),
               mass=1.0, position=(0, 0, 0.199), name="lamp")
    c = CollisionPipeline(w).detect()
    assert c.manifold_count == 1  # the hull foot on the table; the cylinder is above it
    assert c.manifold_point_count[0] == 4
    np.testing.assert_allclose(c.contact_separation, -0.001, atol=1e-12)


def test_mesh_parts_are_triangles_on_fixed_bodies_and_hulls_on_moving_ones():
    from tumble.mass import box_mesh

    v, f = box_mesh((1, 1, 0.2))
    ramp = Compound([(tb.Mesh(vertices=v, faces=f), (0, 0, 0), q_axis((0, 1, 0), 0.2)),
                      (tb.Box((1, 1, 0.2)), (1.0, 0, 0), (1, 0, 0, 0))])
    w = tb.World()
    w.add_body(ramp, fixed=True, name="ramp")
    t = build_shape_table(w)
    assert t.shape_body.tolist() == [0, 0] and t.mesh_triangle.shape == (12, 3, 3)
    w.add_body(ramp, mass=1.0, position=(0, 0, 3), name="flying ramp")
    t = build_shape_table(w)  # a box's mesh is convex: its hull is exact, nothing to say
    assert t.shape_type.tolist() == [SHAPE_MESH, SHAPE_BOX, SHAPE_CONVEX, SHAPE_BOX]
    assert t.mesh_triangle.shape == (12, 3, 3) and len(t.hull_plane) == 6
