"""Bodies at rest on open (two-sided) triangle meshes, ``tb.Mesh(..., closed=False)``
(collision/pairs/mesh.py), against the same scenes on a closed heightfield or on solid boxes, and
against the closed-form resting height.

Regressions from the contact audit of 2026-12-07 (/work/notes/findings_contact2.md, rows 2b and 4b).
"""

from __future__ import annotations

import numpy as np
import pytest

import tumble as tb

G = 9.81


def grid_sheet(n=8, size=2.0):
    """A flat square sheet in z = 0, n x n cells of two triangles each (internal edges everywhere),
    wound counter-clockwise seen from above."""
    xs = np.linspace(-size / 2, size / 2, n + 1)
    X, Y = np.meshgrid(xs, xs)
    vertices = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    index = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, 1:].ravel(), index[1:, :-1].ravel()
    return vertices, np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])


def _hull_on_its_origin():
    """A 0.2 x 0.2 x 0.1 m box as a convex hull whose frame origin is the middle of its bottom face
    (its centre of mass 0.05 m above it)."""
    pts = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (0.0, 0.1)])
    return tb.Convex(points=pts)


# shape, the height of its centre of mass above its base when it stands on it (closed form):
# a cone's centroid is h / 4 above its base; the hull's is half its height
SHAPES_ON_BASE = {
    "cone": (lambda: tb.Cone(0.1, 0.2), 0.2 / 4),
    "hull": (_hull_on_its_origin, 0.05),
}


def _rest(shape, floor, z0, dt=1 / 240, seconds=1.0):
    w = tb.World(gravity=(0, 0, -G))
    w.sleeping = False
    if floor == "sheet":
        V, F = grid_sheet()
        w.add_body(tb.Mesh(vertices=V, faces=F, closed=False), fixed=True)
    else:
        w.add_body(tb.heightfield(np.zeros((9, 9)), (2.0, 2.0)), fixed=True)
    b = w.add_body(shape, mass=1.0, position=(0.03, 0.02, z0))
    sim = tb.Simulator(w, dt=dt)
    sim.step(int(round(seconds / dt)))
    return float(b.x[2]), float(np.linalg.norm(b.v))


@pytest.mark.parametrize("z0", [0.0, 0.05], ids=["placed", "dropped_5cm"])
@pytest.mark.parametrize("kind", sorted(SHAPES_ON_BASE))
def test_a_shape_whose_origin_is_on_its_base_rests_on_an_open_sheet(kind, z0):
    """An upright cone (its frame origin the middle of its base) and a hull whose origin is on its
    bottom face, placed on or dropped 5 cm onto an open sheet, rest with their centre of mass at the
    closed-form height (h / 4 above the base for the cone, half the height for the hull), as on the
    same grid built as a closed heightfield.

    Compared with: the closed-form height and the heightfield's run. Tolerance 1 mm: the soft
    contact's sag under m g is about 1e-5 m at the default step (docs/contact.md), the heightfield's
    run is within 1e-5 m of the closed form; before the fix the shape fell through the sheet (its
    origin, in the sheet's plane, was taken to be behind it after the first sag: com z -4.9 m after 1 s).
    """
    make, height = SHAPES_ON_BASE[kind]
    z_sheet, v_sheet = _rest(make(), "sheet", z0)
    z_field, _ = _rest(make(), "heightfield", z0)
    assert abs(z_field - height) < 1e-3
    assert abs(z_sheet - height) < 1e-3, f"com z {z_sheet:.4f} m on the open sheet (heightfield {z_field:.5f})"
    assert abs(z_sheet - z_field) < 1e-3
    assert v_sheet < 1e-2


# ------------------------------------------------------------------------------------------ wedged
def _v_groove_sheet(w, mat):
    """A 60 degree V-groove (faces 60 degrees from the horizontal, 0.5 m deep, 2 m long) as an open
    sheet of 4 triangles (each face split along a diagonal that runs under a resting box)."""
    x = 0.5 * np.tan(np.radians(30))
    V = np.array([[-x, -1, 0.5], [0, -1, 0], [x, -1, 0.5], [-x, 1, 0.5], [0, 1, 0], [x, 1, 0.5]], float)
    F = np.array([[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]])
    w.add_body(tb.Mesh(vertices=V, faces=F, closed=False), fixed=True, material=mat)


def _v_groove_boxes(w, mat):
    """The same V made of two static 0.1 m slabs whose top faces are the groove's faces."""
    for s in (-1, 1):
        ang = np.radians(s * 60.0)
        n = np.array([-np.sin(ang), 0.0, np.cos(ang)])
        c = np.array([s * 0.25 * np.cos(np.radians(60)), 0.0, 0.25 * np.sin(np.radians(60))]) - 0.05 * n
        w.add_body(tb.Box((0.6, 2.0, 0.1)), fixed=True, position=tuple(c), euler_deg=(0, -s * 60.0, 0), material=mat)


def _funnel_sheet(w, mat, half_angle=30.0, R=0.5, sections=48, rings=12):
    """A cone funnel (apex down at the origin, 30 degree half-angle) as an open sheet."""
    t = np.radians(half_angle)
    V, F = [[0.0, 0.0, 0.0]], []
    for k in range(1, rings + 1):
        r = R * k / rings
        V += [[r * np.cos(2 * np.pi * j / sections), r * np.sin(2 * np.pi * j / sections), r / np.tan(t)]
              for j in range(sections)]
    F += [[0, 1 + j, 1 + (j + 1) % sections] for j in range(sections)]
    for k in range(rings - 1):
        for j in range(sections):
            a, b = 1 + k * sections + j, 1 + k * sections + (j + 1) % sections
            F += [[a, a + sections, b + sections], [a, b + sections, b]]
    w.add_body(tb.Mesh(vertices=np.array(V), faces=np.array(F), closed=False), fixed=True, material=mat)


def _wedged(floor, sleeping=False, settle=3.0, watch=1.0, dt=1 / 240):
    """(max |v|, max |omega|, changes of the manifold's contact keys) over ``watch`` s after ``settle`` s
    of a box wedged in ``floor`` (mu 0.5); and whether it was asleep at the end."""
    w = tb.World(gravity=(0, 0, -G))
    w.sleeping = sleeping
    mat = tb.Material(friction=0.5)
    if floor == "funnel":
        _funnel_sheet(w, mat)
        b = w.add_body(tb.Box((0.15, 0.15, 0.15)), mass=1.0, position=(0.0, 0.0, 0.6), euler_deg=(20, 30, 0),
                       material=mat)
    else:
        (_v_groove_sheet if floor == "v_sheet" else _v_groove_boxes)(w, mat)
        b = w.add_body(tb.Box((0.3, 0.3, 0.3)), mass=1.0, position=(0, 0, 0.45), material=mat)
    sim = tb.Simulator(w, dt=dt)
    sim.step(int(round(settle / dt)))
    vmax = wmax = 0.0
    changes, prev = 0, None
    for _ in range(int(round(watch / dt))):
        sim.step(1)
        vmax = max(vmax, float(np.linalg.norm(b.v)))
        wmax = max(wmax, float(np.linalg.norm(b.omega)))
        c = sim.soft_step.contacts
        keys = None if c is None else tuple(sorted(c.contact_key[:c.contact_count].tolist()))
        changes += prev is not None and keys != prev
        prev = keys
    return vmax, wmax, changes, bool(np.all(b.v == 0) and np.all(b.omega == 0))


@pytest.mark.parametrize("floor", ["v_sheet", "funnel"])
def test_a_box_wedged_in_a_mesh_groove_comes_to_rest(floor):
    """A 0.3 m box wedged on its two lower edges in a 60 degree V-groove of an open sheet, and a 0.15 m
    cube dropped turned into a 30 degree cone funnel, stop moving, as the same box does in the same V
    made of two static boxes (2e-15 m/s there), and their manifold keeps the same points (contact
    keys) from step to step, so warm starting holds them.

    Compared with: the two-box V (run here too). Tolerance 1e-4 m/s and 1e-3 rad/s over 3-4 s: the
    round-off of a resting manifold is 1e-15; before the fix the points were chosen anew every step
    (a speculative point of the box's steep side face, 18 mm off, taken as the farthest point, and
    the deepest face alternating), the box moved at 1.3 cm/s and 0.06 rad/s and the cube at 1.2-3.4
    cm/s, their contact keys changing on every step.
    """
    v_ref, w_ref, _, _ = _wedged("v_boxes")
    assert v_ref < 1e-4 and w_ref < 1e-3
    vmax, wmax, changes, _ = _wedged(floor)
    assert vmax < 1e-4, f"|v| up to {vmax:.2e} m/s (two-box V: {v_ref:.1e})"
    assert wmax < 1e-3, f"|omega| up to {wmax:.2e} rad/s"
    assert changes == 0


def test_a_box_wedged_in_a_mesh_groove_falls_asleep():
    """With sleeping on (the default), the box wedged in the open sheet's V-groove falls asleep within
    4 s, as it does in the two-box V; before the fix it never slept (its angular speed stayed above the
    sleep tolerance for 20 s)."""
    assert _wedged("v_boxes", sleeping=True)[3]
    assert _wedged("v_sheet", sleeping=True)[3]
