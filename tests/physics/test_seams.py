"""Seams between separate flush static bodies (collision/seams.py, stage ``flatten_seam_ghosts``).

Two static boxes (or two open mesh tiles, or two heightfield tiles) laid side by side with
their tops flush at z = 0 make one flat floor. Before the stage, a box sliding over the seam
met a speculative "wall" on the side face of the box ahead (box-box SAT: its largest
separation is along x, 8.8 mm ahead) and tripped (41 mm hop at 3 m/s, 229 mm at 10 m/s, at
1/240 s), and a ball rolling at 10 m/s jumped 680 mm off the top edge ahead (audit B1,
/work/notes/findings_contact2.md). PyBullet on the same: no hop of the box, 0.7 mm of the
ball; MuJoCo: 1.5 mm (box, 3 m/s) to 15.5 mm (box, 10 m/s), ball 0.

Compared with: the same slide over ONE static body of the same extent (a 20 m box, one
10 m sheet, one 10 m heightfield), which is the physical reference (a seam between two
flush bodies is not a feature of the floor). On it the box slides flat and the ball rolls on
(hop 0 to the micrometre). Tolerance: the seam's hop may exceed the reference's by 1 mm. That
is 40 times below the smallest hop of the bug (41 mm), below MuJoCo's 1.5 mm at 3 m/s, and far
above what a flat floor leaves (the soft contact's sag is micrometres). The body must also
have crossed the seam (else a body stopped before it would pass).

Negative controls (pass before and after the stage; they guard against a stage that flattens
too much): a step of 1 cm and of 5 cm still meets the box's leading face (it is slowed and
lifted, or stopped); a wall standing on the floor stops the box; a box resting across the
seam stays at rest; a 1 cm ball at 100 m/s along the floor does not pass through a 1 cm
thick static plate (the speculative contact that prevents tunnelling is kept: the plate
rises above the floor).
"""

from __future__ import annotations

import numpy as np
import pytest

import tumble as tb

G = 9.81
DT = 1.0 / 240.0
HOP_TOLERANCE = 1e-3  # m over the one-body reference (module docstring)


def _sheet(nx, ny, sx, sy, x0):
    """A flat open sheet in z = 0, nx x ny cells of two triangles, centred on (x0, 0)."""
    xs = np.linspace(-sx / 2, sx / 2, nx + 1) + x0
    ys = np.linspace(-sy / 2, sy / 2, ny + 1)
    X, Y = np.meshgrid(xs, ys)
    vertices = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    index = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    a, b, c, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, :-1].ravel(), index[1:, 1:].ravel()
    faces = np.vstack([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    return tb.Mesh(vertices=vertices, faces=faces, closed=False)


def _floor(world, kind, material, step=0.0):
    """The floor, top at z = 0 (the right-hand part ``step`` m higher): one body or two flush at x = 0."""
    if kind == "box":
        world.add_body(tb.Box((20, 4, 1)), fixed=True, position=(0, 0, -0.5), material=material)
    elif kind == "boxes":
        world.add_body(tb.Box((10, 4, 1)), fixed=True, position=(-5, 0, -0.5), material=material)
        world.add_body(tb.Box((10, 4, 1)), fixed=True, position=(5, 0, -0.5 + step), material=material)
    elif kind == "compound":
        # one fixed body of two flush box parts: the seam between two shapes of one body
        parts = [(tb.Box((10, 4, 1)), (-5, 0, 0), (1, 0, 0, 0)), (tb.Box((10, 4, 1)), (5, 0, 0), (1, 0, 0, 0))]
        world.add_body(tb.Compound(parts), fixed=True, position=(0, 0, -0.5), material=material)
    elif kind == "sheet":
        world.add_body(_sheet(40, 8, 10, 2, 0.0), fixed=True, material=material)
    elif kind == "sheets":
        for x0 in (-2.5, 2.5):
            world.add_body(_sheet(20, 8, 5, 2, x0), fixed=True, material=material)
    elif kind == "sheets_mixed":
        # tiles of different tessellation (their vertices along the seam differ: T-edges)
        world.add_body(_sheet(20, 8, 5, 2, -2.5), fixed=True, material=material)
        world.add_body(_sheet(7, 3, 5, 2, 2.5), fixed=True, material=material)
    elif kind == "heightfield":
        world.add_body(tb.heightfield(np.zeros((9, 41)), (10, 2)), fixed=True, material=material)
    elif kind == "heightfields":
        for x0 in (-2.5, 2.5):
            world.add_body(tb.heightfield(np.zeros((9, 21)), (5, 2)), fixed=True, position=(x0, 0, 0),
                           material=material)
    else:
        raise ValueError(kind)


def _slide(kind, shape, v0, duration=0.8, step=0.0):
    """A 0.2 m box (sliding) or a 0.1 m ball (rolling) starting at x = -1 m at v0 (m/s) over the floor;
    (hop m: the highest its centre rose, max |vz| m/s, max |omega_y| rad/s, final x m, final vx m/s)."""
    world = tb.World(gravity=(0, 0, -G))
    world.sleeping = False
    material = tb.Material(friction=0.1)
    _floor(world, kind, material, step)
    if shape == "box":
        body = world.add_body(tb.Box((0.2, 0.2, 0.2)), mass=1.0, position=(-1, 0, 0.1), velocity=(v0, 0, 0),
                              material=material)
    else:
        body = world.add_body(tb.Sphere(0.1), mass=1.0, position=(-1, 0, 0.1), velocity=(v0, 0, 0),
                              angular_velocity=(0, v0 / 0.1, 0), material=material)
    sim = tb.Simulator(world, dt=DT)
    hop = vz = spin = 0.0
    for _ in range(int(round(duration / DT))):
        sim.step(1)
        hop = max(hop, body.x[2] - 0.1)
        vz = max(vz, abs(body.v[2]))
        if shape == "box":
            spin = max(spin, abs(body.omega[1]))
    return hop, vz, spin, float(body.x[0]), float(body.v[0])


@pytest.mark.parametrize("kind", ["boxes", "compound"])
@pytest.mark.parametrize("shape, v0", [("box", 3.0), ("box", 10.0), ("sphere", 10.0)])
def test_slide_over_two_flush_static_boxes_is_that_over_one(kind, shape, v0):
    """Two fixed boxes, or one fixed body of two box parts. Before the stage (two bodies): box 41 /
    229 mm hop (3 / 10 m/s), ball 680 mm; now the one box's 0."""
    hop, vz, spin, x, _ = _slide(kind, shape, v0)
    ref_hop, ref_vz, ref_spin, _, _ = _slide("box", shape, v0)
    assert x > 0.15, "crossed the seam (the whole box is past it at x > 0.1 m)"
    assert hop <= ref_hop + HOP_TOLERANCE, (hop, ref_hop)
    # the trip also showed as a vertical speed (0.78 m/s at 3 m/s) and a tumble (15 rad/s): 0.05 m/s
    # and 0.5 rad/s are 15 and 30 times below them, and well above a flat slide's (0 and 0)
    assert vz <= ref_vz + 0.05, (vz, ref_vz)
    assert spin <= ref_spin + 0.5, (spin, ref_spin)


@pytest.mark.parametrize("kind, reference", [("sheets", "sheet"), ("sheets_mixed", "sheet"),
                                             ("heightfields", "heightfield")])
@pytest.mark.parametrize("shape, v0", [("box", 3.0), ("sphere", 10.0)])
def test_slide_over_two_flush_tiles_is_that_over_one(kind, reference, shape, v0):
    """Two open mesh tiles (of the same or of different tessellation) or two heightfield tiles
    (terrain chunks) against one of twice the size: before the stage the box hopped 56-58 mm at
    3 m/s and the ball 680 mm at 10 m/s."""
    # 0.5 s: the ball at 10 m/s is then at x = 4 m, still on the 10 m floor
    hop, vz, _, x, _ = _slide(kind, shape, v0, duration=0.5)
    ref_hop, ref_vz, _, _, _ = _slide(reference, shape, v0, duration=0.5)
    assert x > 0.15, "crossed the seam (the whole box is past it at x > 0.1 m)"
    assert hop <= ref_hop + HOP_TOLERANCE, (hop, ref_hop)
    assert vz <= ref_vz + 0.05, (vz, ref_vz)


@pytest.mark.parametrize("step", [0.01, 0.05])
def test_a_real_step_still_meets_the_box(step):
    """A right-hand box 1 or 5 cm higher is a step, not a seam (it rises above the floor's plane):
    the box sliding at 3 m/s must hit its face. Compared with one flat box, where it keeps its
    speed (2.22 m/s after 0.8 s, friction alone): at the step it ends at least 0.5 m/s slower
    (measured: 0.52 m/s at 1 cm, bounced back at 5 cm), or stops before it, and is thrown up by at
    least the step's height (measured 51 and 41 mm) or stays before it."""
    hop, _, _, x, vx = _slide("boxes", "box", 3.0, step=step)
    _, _, _, _, flat_vx = _slide("box", "box", 3.0)
    assert vx < flat_vx - 0.5 or x < 0.0, (x, vx, flat_vx)
    assert hop >= step or x < 0.0, (hop, x)


def test_a_wall_on_the_floor_stops_the_box():
    """A static wall (0.2 m thick, 0.5 m tall) standing on a static floor box, its face at x = 1 m:
    the box sliding at 3 m/s touches two static shapes (floor and wall), whose wall contact is not
    a seam (the wall rises above the floor's plane): it must stop at the wall, not pass (its centre
    stays 0.1 m before the face, to the solver's slop) and not bounce back fast (restitution 0)."""
    world = tb.World(gravity=(0, 0, -G))
    world.sleeping = False
    material = tb.Material(friction=0.1)
    _floor(world, "box", material)
    world.add_body(tb.Box((0.2, 4, 0.5)), fixed=True, position=(1.1, 0, 0.25), material=material)
    body = world.add_body(tb.Box((0.2, 0.2, 0.2)), mass=1.0, position=(-1, 0, 0.1), velocity=(3, 0, 0),
                          material=material)
    sim = tb.Simulator(world, dt=DT)
    for _ in range(240):
        sim.step(1)
    assert body.x[0] <= 1.0 - 0.1 + 0.005, body.x
    assert abs(body.v[0]) < 0.5


def test_a_box_resting_across_the_seam_rests():
    """A box centred on the seam, half on each static box, at rest for 2 s (sleeping off, so the solver
    must hold it): it stays still, as on one box (speed below 1e-6 m/s)."""
    world = tb.World(gravity=(0, 0, -G))
    world.sleeping = False
    material = tb.Material(friction=0.5)
    _floor(world, "boxes", material)
    body = world.add_body(tb.Box((0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 0.1), material=material)
    sim = tb.Simulator(world, dt=DT)
    for _ in range(480):
        sim.step(1)
    assert np.linalg.norm(body.v) < 1e-6 and np.linalg.norm(body.omega) < 1e-6, (body.v, body.omega)
    assert abs(body.x[0]) < 1e-6 and abs(body.x[2] - 0.1) < 1e-3, body.x


def test_a_fast_small_ball_along_the_floor_does_not_pass_a_thin_plate():
    """A 1 cm ball at 100 m/s along a floor of two flush static boxes, into a 1 cm thick static plate
    standing on the floor: the plate's speculative contact (the ball moves 0.42 m a step) must stop
    it. The ball touches two static shapes here (floor and plate), so the stage sees the plate's
    contact: the plate rises above the floor, so it is kept."""
    world = tb.World(gravity=(0, 0, -G))
    world.sleeping = False
    material = tb.Material(friction=0.1)
    _floor(world, "boxes", material)
    world.add_body(tb.Box((0.01, 4, 0.5)), fixed=True, position=(2.005, 0, 0.25), material=material)
    body = world.add_body(tb.Sphere(0.005), mass=0.01, position=(-1, 0, 0.005), velocity=(100, 0, 0),
                          material=material)
    sim = tb.Simulator(world, dt=DT)
    for _ in range(60):
        sim.step(1)
        assert body.x[0] < 2.0, body.x


def test_the_slider_s_contacts_at_the_seam_all_push_up():
    """The stage itself, seen through ``Simulator.contacts``: every step of a box sliding at 3 m/s over
    two flush static boxes, each of its contacts with either box is pushed along the floor's normal
    (+z to 1e-6 in cos). Before the stage, the box ahead's speculative manifold had the normal
    (-1, 0, 0) (the audit's seam_normals.py) in the steps before the trip."""
    world = tb.World(gravity=(0, 0, -G))
    world.sleeping = False
    material = tb.Material(friction=0.1)
    _floor(world, "boxes", material)
    body = world.add_body(tb.Box((0.2, 0.2, 0.2)), mass=1.0, position=(-0.5, 0, 0.1), velocity=(3, 0, 0),
                          material=material)
    sim = tb.Simulator(world, dt=DT)
    seen_right = 0
    for _ in range(80):
        sim.step(1)
        c = sim.contacts()
        mine = (c.body_a == body.index) | (c.body_b == body.index)
        # the normal from the floor to the box: +normal when the floor is a, -normal when it is b
        up = np.where((c.body_b == body.index)[:, None], c.normal, -c.normal)[mine]
        assert np.all(up[:, 2] >= 1.0 - 1e-6), up
        seen_right += int(np.count_nonzero(((c.body_a == 1) | (c.body_b == 1)) & mine))
    assert seen_right > 0  # the box ahead was met (its contacts were checked)
