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

