"""The contact examples of examples/ (dominoes, tower, pyramid, pile, bowling, dice, marbles, eggs...), each
loaded from its scene file, run, and checked for the physics its header comment promises.

Every example is also validated by ``tumble validate`` in tests/test_examples.py. The figures
quoted in the docstrings were measured at tumble git 85900ce (default step: dt 1/240 s with 4
contact substeps, unless the scene sets its own).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import tumble as tb
from tumble.cli import main as cli_main
from tumble.math3d import quat_to_matrix
from tumble.scene import load_scene

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def run(name, **settings):
    """Load examples/NAME.toml, change Scene settings (duration, frame_rate, ...), run it."""
    scene = load_scene(EXAMPLES / f"{name}.toml")
    for key, value in settings.items():
        setattr(scene, key, value)
    scene.check()
    return scene, scene.run(progress=False)


def rotations(q):
    """(..., 3, 3) rotation matrices (body to world) of unit quaternions (..., 4)."""
    q = np.asarray(q)
    return np.array([quat_to_matrix(x) for x in q.reshape(-1, 4)]).reshape(q.shape[:-1] + (3, 3))


def tilt_deg(q):
    """Angle (degrees) between the body's z axis and the world's z axis, for quaternions (..., 4)."""
    return np.degrees(np.arccos(np.clip(rotations(q)[..., 2, 2], -1.0, 1.0)))


def indices(traj, prefix):
    return [i for i, n in enumerate(traj.names) if str(n).startswith(prefix)]


def speeds(traj, frame=-1):
    return np.linalg.norm(traj.velocity[frame], axis=1)


# ---------------------------------------------------------------------- dominoes


def test_dominoes_all_fall_in_order():
    """A push at t = 0.25 s on the first of 20 dominoes. Checks: every domino stands until the push
    (tilt < 1 degree at t = 0.25 s); at the end every one is down, its tilt > 45 degrees (upright is
    0, leaning on the next one ~75, flat 90: 45 is halfway, which a domino only passes when it has
    been knocked over); and they went down in order, the time each first passes 45 degrees strictly
    increasing along the run, as a toppling wave must. Frames at 120 Hz resolve the ~0.08 s between
    neighbours. Measured: end tilts 75.4-90 degrees, fall times 0.58 s to 2.27 s, 0.05-0.13 s apart."""
    _, traj = run("dominoes", frame_rate=120.0)
    ids = indices(traj, "domino")
    assert len(ids) == 20
    tilt = tilt_deg(traj.orientation[:, ids])  # (F, 20)
    before = np.searchsorted(traj.time, 0.25)
    assert tilt[: before + 1].max() < 1.0, "a domino moved before the push"
    assert np.all(tilt[-1] > 45.0), tilt[-1]
    fall_time = np.array([traj.time[np.argmax(tilt[:, k] > 45.0)] for k in range(len(ids))])
    assert np.all(np.diff(fall_time) > 0), fall_time
    assert np.all(speeds(traj)[ids] < 0.01), "the dominoes are still moving at the end"


# ---------------------------------------------------------------------- tower


def test_tower_stands():
    """The 10-cube tower (1 m cubes of 1000 kg) for its full 30 s. Checks: the top cube's centre
    moves under 1 cm from where it started (the issue's tower figure: the soft contacts sag
    ~0.16 mm per contact under load, 1.6 mm in all, so 1 cm leaves room for the sag but not for a
    lean or a slide) and every cube is still at the end (under 1 mm/s). Cheap despite the 30 s:
    the tower falls asleep once settled. Measured: top moved 1.6 mm, speeds 0."""
    _, traj = run("tower", frame_rate=4.0)
    ids = indices(traj, "box")
    top = ids[-1]
    assert traj.names[top] == "box9"
    drift = np.linalg.norm(traj.position[:, top] - traj.position[0, top], axis=1).max()
    assert drift < 0.01, drift
    assert speeds(traj)[ids].max() < 1e-3


# ---------------------------------------------------------------------- cairn


def test_cairn_is_laid_by_drop_and_stands():
    """Six stones with ``drop = true``, each written somewhere above the last: the scene lays them
    down in order (World.drop) before the run. Checks: at the start each stone touches the one
    below it, neither apart nor inside (closest-points distance within 1e-9 m: the casts stop
    within CAST_TOLERANCE = 1e-9 m and boxes and hulls are measured exactly), and each was moved
    straight down from where the file put it; then the cairn stands for its 5 s, no stone moving
    more than 1 mm (the soft contacts' sag under the stones above, measured 0.28 mm, and no
    slide or fall). Measured: gaps 0 to 1e-16 m."""
    scene = load_scene(EXAMPLES / "cairn.toml")
    w = scene.world
    stones = ["stone1", "stone2", "stone3", "stone4", "stone5", "top"]
    written = {"stone1": (0, 0), "stone2": (0.04, -0.02), "stone3": (-0.03, 0.03), "stone4": (0.02, 0.02),
               "stone5": (0.0, -0.03), "top": (0.01, 0.0)}
    for below, stone in zip(["ground", *stones], stones):
        assert abs(w.closest_points(stone, below).distance[0]) <= 1e-9, stone
        origin = w.body(stone).x - w.body(stone).R @ w.body(stone).com_offset
        np.testing.assert_allclose(origin[:2], written[stone], atol=1e-12)  # moved along z alone
    scene.check()
    traj = scene.run(progress=False)
    ids = [list(traj.names).index(n) for n in stones]
    moved = np.linalg.norm(traj.position[:, ids] - traj.position[0, ids], axis=2).max()
    assert moved < 1e-3, moved


# ---------------------------------------------------------------------- pyramid


@pytest.mark.slow
def test_pyramid_stands():
    """The 20-row pyramid (210 unit cubes) for its full 10 s. Checks: no box ever moves more than
    1 cm from where it started (a box that slips or a row that spreads moves by many cm; the soft
    contacts' sag is a few mm at the bottom of 20 rows), and every box is slower than 1 cm/s at the
    end (the issue's resting speed). Measured: largest drift 1.8 mm, speeds 0 (asleep)."""
    _, traj = run("pyramid", frame_rate=2.0)
    ids = indices(traj, "box")
    assert len(ids) == 210
    drift = np.linalg.norm(traj.position[:, ids] - traj.position[0, ids], axis=2).max()
    assert drift < 0.01, drift
    assert speeds(traj)[ids].max() < 0.01


# ---------------------------------------------------------------------- pile

@pytest.mark.slow
def test_pile_only_loses_energy_and_nothing_sinks():
    """1000 boxes for the scene's 4 s (dt 1/60 s, 4 contact substeps), 30 frames a second.
    Checks: (1) the total energy (kinetic + gravity's potential) never rises from one frame to the
    next: with restitution 0, Coulomb friction and over-damped soft contacts every impact and slide
    only dissipates, and a rise would be a contact pushing energy in (the classic pile explosion);
    the bound 1e-9 of the start's 22 563 J is round-off in summing 1000 bodies' energies
    (measured: no rise at all, 22 563 J -> 3 209 J); (2) no box centre below 0.1 m - 5 mm (a cube
    of half-size 0.1 m sits no lower unless it sinks into the ground; 5 mm is the issue's
    penetration bound; measured 0.0991 m). Whether the pile is at rest and within its region at
    4 s is issue 3's acceptance item, tested (strict xfail, with the figures of every engine) in
    tests/physics/test_contact.py::test_pile_of_1000_boxes_is_at_rest_within_its_region_at_4_s."""
    _, traj = run("pile")
    ids = indices(traj, "box")
    assert len(ids) == 1000
    energy = traj.total_energy
    assert np.diff(energy).max() <= 1e-9 * energy[0], np.diff(energy).max()
    assert energy[-1] < 0.2 * energy[0]  # it fell: most of the potential energy is gone
    x = traj.position[-1, ids]
    assert np.all(np.isfinite(x))
    assert x[:, 2].min() > 0.1 - 0.005, x[:, 2].min()


# ---------------------------------------------------------------------- safe


def test_safe_on_crates_gives_way_as_the_stiffened_springs_say():
    """examples/safe.toml: a 400 kg safe on three 8 kg cubic crates (0.5 m) at dt 1/60 s with the
    loaded contacts stiffened. Each contact between two moving bodies holds 51-104 times its rows'
    own weight, so its rows are at the cap, omega = 2 pi 0.1875 / h (h = 1/240 s), and at rest its
    overlap is its spring's, F / (sum of its four corner rows' m_eff x omega^2) with F the weight
    above it (tests/physics/test_contact_load.py: the fixed point is exact; tolerance 1.5 %, the
    shortfall under 1 % at these 6-13 mm). A corner row's 1 / m_eff is 1/m + 3/m for a cube
    (its arm's turn), and for the safe on the crate's top face 1/M + 2 (0.25 m)^2 / I_safe. The
    same file with the [contact] table's default: each gives way more than twice as far (2.25 at
    the fixed point, less that shortfall, 2 % at the default's 29 mm). The crate on the ground, whose
    rows against a fixed body are at 0.25 / h either way, sinks its spring's 424 g / (8 kg omega^2)
    in both (1.5 %; measured -0.3 % and +0.1 %). All at rest after the 4 s."""
    from tumble.solver.contact import SoftStepSettings

    def overlaps(default):
        scene = load_scene(EXAMPLES / "safe.toml")
        if default:
            scene.contact = SoftStepSettings()
        else:
            assert scene.contact.load_hertz_cap_per_substep == 0.1875
        w = scene.world
        scene.simulator().step(int(round(scene.duration / scene.dt)))
        z = [w.x[w.names.index(n), 2] for n in ("crate1", "crate2", "crate3", "safe")]
        assert np.abs(w.v).max() < 1e-3
        return 0.25 - z[0], np.array([z[0] + 0.5 - z[1], z[1] + 0.5 - z[2], z[2] + 0.65 - z[3]])

    g, m, M = 9.81, 8.0, 400.0
    omega = 2.0 * math.pi * 0.1875 * 240.0
    i_safe = M * (0.6 ** 2 + 0.8 ** 2) / 12.0
    crate_row = 4.0 / m  # 1/m + 3/m
    rows = np.array([4.0 / (2 * crate_row), 4.0 / (2 * crate_row), 4.0 / (crate_row + 1.0 / M + 2 * 0.25 ** 2 / i_safe)])
    load = g * np.array([M + 2 * m, M + m, M])
    ground_on, on = overlaps(False)
    ground_off, off = overlaps(True)
    np.testing.assert_allclose(on, load / (rows * omega ** 2), rtol=0.015)
    assert np.all(off > 2.0 * on)
    ground = (M + 3 * m) * g / (4.0 / crate_row * (2.0 * math.pi * 0.25 * 240.0) ** 2)
    assert ground_on == pytest.approx(ground, rel=0.015)
    assert ground_off == pytest.approx(ground, rel=0.015)


# ---------------------------------------------------------------------- bowling


def test_bowling_is_a_strike():
    """The ball rolled at 8 m/s into the pocket. Checks: all ten pins stand at the start (tilt under
    1 degree in the first frames, before the ball arrives at t ~ 0.23 s) and are down at the end of
    the 3 s, each tilted more than 45 degrees (a pin that wobbles and stands again stays under ~10;
    a fallen one lies at ~90). Measured: all ten at 90 degrees, the last down at 0.63 s."""
    _, traj = run("bowling")
    pins = indices(traj, "pin")
    assert len(pins) == 10
    tilt = tilt_deg(traj.orientation[:, pins])
    assert tilt[: np.searchsorted(traj.time, 0.15)].max() < 1.0
    assert np.all(tilt[-1] > 45.0), dict(zip(np.array(traj.names)[pins], tilt[-1].round(1)))


def test_bowling_runs_from_the_command_line(tmp_path, capsys):
    """``tumble run`` on the compound-pin scene writes its trajectory (0.5 s): the CLI path of a
    scene with compound bodies and contacts."""
    out = tmp_path / "bowling"
    assert cli_main(["run", str(EXAMPLES / "bowling.toml"), "--out", str(out), "--duration", "0.5", "--no-progress"]) == 0
    assert "12 bodies" in capsys.readouterr().out
    with np.load(out / "trajectory.npz", allow_pickle=False) as data:
        assert data["position"].shape == (31, 12, 3)


# ---------------------------------------------------------------------- dice

TABLE_TOP = 0.75  # m
DIE_HALF = 0.008  # m: both kinds of die are 16 mm across their faces


def test_dice_come_to_rest_on_a_face():
    """Four dice (two boxes, two rounded convex hulls) thrown onto the table, 3 s. Checks, for each:
    it rests on a face: one of its body axes within 2 degrees of the vertical (a die leaning on an
    edge or a corner is tilted 45 degrees or more; 2 degrees allows for a slightly soft contact
    under a 5 g die, which is far less), its centre 8 mm +- 1 mm above the table top (on the table,
    on a face, not sunk in), inside the table's 1.2 x 0.8 m, and slower than 1 cm/s. Measured:
    axes within 1e-6 degrees of vertical, centres at 0.758 m, speeds 0 (asleep)."""
    _, traj = run("dice")
    dice = indices(traj, "die")
    assert len(dice) == 4
    R = rotations(traj.orientation[-1, dice])  # columns: the body axes in world coordinates
    off_vertical = np.degrees(np.arccos(np.clip(np.abs(R[:, 2, :]).max(axis=1), -1.0, 1.0)))
    assert np.all(off_vertical < 2.0), off_vertical
    x = traj.position[-1, dice]
    assert np.all(np.abs(x[:, 2] - (TABLE_TOP + DIE_HALF)) < 0.001), x[:, 2]
    assert np.all(np.abs(x[:, 0]) < 0.6) and np.all(np.abs(x[:, 1]) < 0.4)
    assert speeds(traj)[dice].max() < 0.01
    # they were thrown: each bounced or tumbled on the way (turned by more than 45 degrees)
    assert np.all(tilt_deg(traj.orientation[:, dice]).max(axis=0) > 45.0)


# ---------------------------------------------------------------------- eggs

EGG_SHORT, EGG_LONG, PEBBLE_THIN = 0.022, 0.03, 0.012  # m: semi-axes


def egg_hold_tilt(c=0.1, a=EGG_LONG, b=EGG_SHORT):
    """The largest tilt (degrees) of an egg's long axis at which rolling resistance c holds it on a
    floor (docs/contact.md, "Rolling resistance": a torque of at most c rho N, rho the radius of
    curvature along the rolling). Tilted by t, the ellipse (semi-axes a, b) touches the floor at a
    horizontal distance d(t) = (a^2 - b^2) sin t cos t / sqrt(a^2 sin^2 t + b^2 cos^2 t) from its
    centre, where its radius of curvature is rho(t) = a^2 b^2 / (a^2 sin^2 t + b^2 cos^2 t)^(3/2):
    gravity's torque m g d(t) is held while d(t) <= c rho(t). Bisection on [0, 45] degrees."""
    def excess(t):
        s2, c2 = np.sin(t) ** 2, np.cos(t) ** 2
        q = a * a * s2 + b * b * c2
        return (a * a - b * b) * np.sin(t) * np.cos(t) / np.sqrt(q) - c * a * a * b * b / q ** 1.5
    lo, hi = 0.0, np.radians(45.0)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if excess(mid) <= 0.0 else (lo, mid)
    return np.degrees(lo)


def test_eggs_roll_down_and_settle_on_their_sides_and_pebbles_flat():
    """examples/eggs.toml (ellipsoids), 4 s. Checks: every egg rolled down the ramp and off it
    (x past the ramp's foot, 0.39 m), and rests on its side: centre EGG_SHORT above the floor
    within 1 mm and its long axis within the tilt its rolling resistance (0.1, the max of the egg's
    and the floor's 0) can hold it at, 12.3 degrees (``egg_hold_tilt``; measured up to 10.3; before
    session 45, whose rotation update changed where they stop, up to 8.4 with an observed bound of
    10 degrees in this test); the egg laid straight across the ramp rolled
    straight (y kept within 1 cm); the pebbles rest flat, centre PEBBLE_THIN up within 1 mm, short
    axis within 6 degrees of vertical (measured 5.3); all slower than 1 mm/s (measured: asleep
    from about 3 s)."""
    _, traj = run("eggs")
    eggs, pebbles = indices(traj, "egg"), indices(traj, "pebble")
    assert len(eggs) == 5 and len(pebbles) == 3
    x = traj.position[-1]
    assert np.all(x[eggs, 0] > 0.39), x[eggs, 0]
    assert np.all(np.abs(x[eggs, 2] - EGG_SHORT) < 1e-3), x[eggs, 2]
    assert abs(x[indices(traj, "egg1")[0], 1] + 0.15) < 0.01
    R = rotations(traj.orientation[-1])
    for i in eggs:
        k = int(np.argmax(traj.shape(i).radii))  # the long axis (y, or z for the one stood on end)
        assert np.degrees(np.arcsin(abs(R[i, 2, k]))) < egg_hold_tilt(), traj.names[i]
    assert np.all(np.abs(x[pebbles, 2] - PEBBLE_THIN) < 1e-3), x[pebbles, 2]
    assert np.all(np.degrees(np.arccos(np.abs(R[pebbles, 2, 2]))) < 6.0)
    assert speeds(traj)[eggs + pebbles].max() < 1e-3


# ---------------------------------------------------------------------- sieve

def test_sieve_sorts_by_collision_filter():
    """examples/sieve.toml, 4 s with contacts recorded. Checks: every box ends on the ground
    (its centre at its half size, 0.15 m, within 2 mm: it fell through the shelf and the balls),
    every ball but the ghost on the shelf (top at 1.05 m + radius 0.12), the ghost on the ground
    (excluded from the shelf alone); all at rest; and no frame holds a contact between a box and
    a ball, a box and the shelf, or the ghost and the shelf. Measured: exactly those heights to
    0.1 mm; contacts only ground-box, box-box, ball-shelf, ball-ghost, ground-ghost."""
    scene = load_scene(EXAMPLES / "sieve.toml")
    sim = tb.Simulator(scene.world, dt=scene.dt, integrator=scene.integrator, record_contacts=True)
    traj = sim.run(scene.duration, frame_rate=scene.frame_rate)
    w = scene.world
    names = np.array(w.names)
    boxes = indices(traj, "box")
    balls = indices(traj, "ball")
    ghost = w.index_of("ghost")
    assert len(boxes) == 6 and len(balls) == 5
    np.testing.assert_allclose(w.x[boxes, 2], 0.15, atol=2e-3)
    np.testing.assert_allclose(w.x[balls, 2], 1.05 + 0.12, atol=2e-3)
    assert abs(w.x[ghost, 2] - 0.12) < 2e-3
    assert speeds(traj)[boxes + balls + [ghost]].max() < 0.01
    a, b = traj.contact_body_a, traj.contact_body_b
    touched = a >= 0
    kinds = {tuple(sorted((names[i].rstrip("0123456789"), names[j].rstrip("0123456789"))))
             for i, j in zip(a[touched], b[touched])}
    assert {("box", "ground"), ("ball", "shelf"), ("ghost", "ground")} <= kinds
    assert not kinds & {("ball", "box"), ("box", "shelf"), ("ghost", "shelf"), ("box", "ghost")}


# ---------------------------------------------------------------------- marbles

BOWL_RIM_RADIUS = 0.28  # m, inner rim (examples/tools/make_examples.py)
BOWL_RIM_TOP = 0.015 + 0.32 - np.sqrt(0.32**2 - 0.28**2)  # m: thickness + depth of the inner cap
MARBLE_RADIUS = 0.015


def test_marbles_end_in_the_bowl():
    """Six marbles let go in the chute, 8 s. Checks: at the end every marble is inside the bowl
    (horizontal distance from its axis under the rim radius less a marble radius, 0.265 m, and below
    the rim: so each ran down the whole chute and dropped in), at rest (slower than 1 cm/s) from 6 s
    on, braked by their rolling resistance and spinning friction alone (no drag: rigid balls would
    roll round the bowl for ever); and none ever went through the bowl's wall: no marble centre
    below the inner bottom + radius by more than 2 mm (0.03 m - 2 mm; the soft contact lets a
    falling marble in by about 1 mm).
    Measured: all within 4.4 cm of the axis, slower than 1 cm/s from 4.45 s, speeds 0 (asleep) at
    the end, lowest centre 0.0300 m."""
    scene, traj = run("marbles")
    marbles = indices(traj, "marble")
    assert len(marbles) == 6
    x = traj.position[-1, marbles]
    r = np.linalg.norm(x[:, :2], axis=1)
    assert np.all(r < BOWL_RIM_RADIUS - MARBLE_RADIUS), r
    assert np.all(x[:, 2] < BOWL_RIM_TOP), x[:, 2]
    assert speeds(traj)[marbles].max() < 0.01
    late = traj.time >= 6.0
    assert np.linalg.norm(traj.velocity[late][:, marbles], axis=2).max() < 0.01
    assert not scene.world.forces and all(scene.world.materials[i].rolling_resistance > 0 for i in marbles)
    assert traj.position[:, marbles, 2].min() > 0.015 + MARBLE_RADIUS - 0.002


# ---------------------------------------------------------------------- platforms (kinematic bodies)

def test_platforms_carry_turn_and_push():
    """examples/platforms.toml, 4 s with contacts recorded. Checks: each kinematic body is where
    its velocity puts it (to round-off: 1e-12 m, the turntable's turn 4 rad to 1e-12); the four
    riders went round with the turntable, 4 rad, to 2 mm of their radius 0.8 m (they creep out at
    r omega^2 h / 2: 2.1 mm in 4 s, tests/physics/test_kinematic.py) and 2e-3 rad of their angle;
    the stack on the lift rose 1 m with it without sliding (1 mm); the pusher drives the row of
    three blocks ahead of it at its speed, closed up (each 0.3 m from the next, 2 mm); the shuttle
    (a keyframed path) is at its keys at 2 and 4 s and its parcel rides it; and no frame holds a
    contact between a kinematic body and the ground.
    Measured: riders 1.7 mm out, angles within 1.2e-4 rad; stack within 0.22 mm; row 0.3 m apart
    to 0.02 mm, at 0.8 m/s to 5e-6 (the soft contacts' give against the ground's friction)."""
    scene = load_scene(EXAMPLES / "platforms.toml")
    sim = tb.Simulator(scene.world, dt=scene.dt, integrator=scene.integrator, record_contacts=True)
    traj = sim.run(scene.duration, frame_rate=scene.frame_rate)
    w = scene.world
    T = traj.time[-1]
    assert T == 4.0
    i = w.index_of
    np.testing.assert_allclose(w.x[i("lift")], (0, 0, 0.3 + 0.25 * T), rtol=0, atol=1e-12)
    np.testing.assert_allclose(w.x[i("pusher")], (2.0 + 0.8 * T, 0, 0.25), rtol=0, atol=1e-12)
    np.testing.assert_allclose(w.x[i("turntable")], (-3.0, 0, 0.3), rtol=0, atol=0)
    q, q_exact = w.q[i("turntable")], np.array([np.cos(T / 2), 0, 0, np.sin(T / 2)])
    np.testing.assert_allclose(q * np.sign(q[0]), q_exact * np.sign(q_exact[0]), rtol=0, atol=1e-12)
    for k in range(4):
        start = traj.position[0, i(f"rider{k}"), :2] - (-3.0, 0)
        end = w.x[i(f"rider{k}"), :2] - (-3.0, 0)
        assert abs(np.linalg.norm(end) - 0.8) < 2e-3
        turned = np.angle(complex(*end) / complex(*start))
        assert abs(turned - (T - 2 * np.pi)) < 2e-3  # 4 rad = 4 - 2 pi the short way
    for name, z0 in (("crate0", 0.55), ("crate1", 0.9), ("ball", 1.15)):
        np.testing.assert_allclose(w.x[i(name)], (0, 0, z0 + 0.25 * T), rtol=0, atol=1e-3)
    blocks = [i(f"block{k}") for k in range(3)]
    np.testing.assert_allclose(np.diff(w.x[blocks, 0]), 0.3, atol=2e-3)
    assert abs(w.x[blocks[0], 0] - (w.x[i("pusher"), 0] + 0.25)) < 2e-3
    np.testing.assert_allclose(w.v[blocks], np.broadcast_to((0.8, 0, 0), (3, 3)), rtol=0, atol=1e-4)
    # the shuttle on its path: at its keys at 2 s and 4 s to round-off; the parcel rides on it
    # (on its top, 0.15 m above its centre, 1 mm; within 0.2 m of its middle: it slips where the
    # path's velocity turns, 3 cm for each jump of 0.75 m/s, measured 0.14 m at most)
    k2 = int(round(2.0 * scene.frame_rate))
    np.testing.assert_allclose(traj.position[k2, i("shuttle")], (0.0, 3.0, 0.3), rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.orientation[k2, i("shuttle")], (np.sqrt(0.5), 0, 0, np.sqrt(0.5)), rtol=0, atol=1e-12)
    np.testing.assert_allclose(w.x[i("shuttle")], (-1.5, 3.0, 0.3), rtol=0, atol=1e-12)
    rel = traj.position[:, i("parcel")] - traj.position[:, i("shuttle")]
    np.testing.assert_allclose(rel[:, 2], 0.15, atol=1e-3)
    assert np.abs(rel[:, :2]).max() < 0.2
    a, b = traj.contact_body_a, traj.contact_body_b
    kinematic = np.flatnonzero(w.kinematic)
    ground = i("ground")
    touched = a >= 0
    pairs = {tuple(sorted((int(x), int(y)))) for x, y in zip(a[touched], b[touched])}
    assert not any(ground in p and (p[0] in kinematic or p[1] in kinematic) for p in pairs)
    assert any(i("pusher") in p for p in pairs) and any(i("lift") in p for p in pairs)


# ---------------------------------------------------------------------- conveyor (surface velocity, sensor)

def test_conveyor_fills_the_bin_and_its_sensor_counts_six():
    """examples/conveyor.toml, 10 s. Checks: the bin's sensor reports six parcels, each one begin
    event and no end, front parcel first, one every 0.45 m / 0.8 m/s = 0.5625 s (within 0.05 s:
    each parcel's slip at the start and its fall differ a little); every parcel ends at rest inside
    the bin's walls; a parcel riding the belt at 2 s moves at the belt's 0.8 m/s (1e-4: the fixed
    side's anchor lag of a sliding box, docs/contact.md).
    Measured: begins 4.633, 5.175, 5.721, 6.246, 6.783, 7.308 s (0.525-0.546 s apart)."""
    scene = load_scene(EXAMPLES / "conveyor.toml")
    sim = scene.simulator()
    traj = sim.run(scene.duration, frame_rate=scene.frame_rate)
    w = scene.world
    parcels = [w.index_of(f"parcel{k}") for k in range(6)]
    ev = sim.sensor_events()
    assert ev.begin_visitor.tolist() == parcels[::-1] and len(ev.end_visitor) == 0
    assert set(ev.begin_sensor.tolist()) == {w.index_of("bin_sensor")}
    np.testing.assert_allclose(np.diff(ev.begin_time), 0.45 / 0.8, atol=0.05)
    assert sim.sensor_overlaps("bin_sensor").tolist() == sorted(parcels)
    x = w.x[parcels]
    assert np.all((x[:, 0] > 3.1) & (x[:, 0] < 4.6) & (np.abs(x[:, 1]) < 0.65))
    assert np.all(np.linalg.norm(w.v[parcels], axis=1) < 1e-3)
    k = int(round(2.0 * scene.frame_rate))
    np.testing.assert_allclose(traj.velocity[k, parcels[0]], (0.8, 0, 0), atol=1e-4)


def test_conveyor_run_from_the_command_line_counts_the_parcels(tmp_path, capsys):
    """``tumble run examples/conveyor.toml``: it says the bin holds 6 at the end, and the
    trajectory file's ``sensor_visitors`` counts 0 parcels in the bin at first and 6 at the end,
    one more at a time (never down)."""
    assert cli_main(["run", str(EXAMPLES / "conveyor.toml"), "--out", str(tmp_path / "run")]) == 0
    assert "sensors (bodies inside at the end): bin_sensor 6" in capsys.readouterr().out
    traj = tb.load_trajectory(tmp_path / "run" / "trajectory.npz")
    counts = traj.sensor_visitors[:, 0]
    assert counts[0] == 0 and counts[-1] == 6
    assert set(np.diff(counts).tolist()) <= {0.0, 1.0}


# ---------------------------------------------------------------------- terrain


def test_terrain_balls_gather_in_the_basin_and_never_sink():
    """examples/terrain.toml: 12 balls and 2 capsules dropped round the rim of a rippled heightfield
    basin. At 20 s: every body within 1 m of the middle (they start 1.6 and 2.2 m out) and at rest
    (issue 3's 1 cm/s; measured: all asleep from 17 s; until session 45 the scene ran 16 s and all slept
    from 15 s: ghost contacts with the basin's edges ahead of a fast ball braked it, and one ball
    woke with a 0.25 mJ rise of the energy at 16.1 s, collision/speculative.py); at every frame none is more than 1 mm into
    the surface beneath it (a ray cast down from its centre: the surface is at least its radius
    below the centre, less 1 mm; the capsules lie on their sides, so their radius too). Before
    session 14 (one normal per mesh manifold) one ball still rocked in a pit 1.4 m out at 12 s."""
    scene, traj = run("terrain")
    world = scene.world
    bodies = range(1, len(traj.names))
    radius = {i: (0.1 if str(traj.names[i]).startswith("ball") else 0.08) for i in bodies}
    for f in range(0, len(traj.time), 12):
        for i in bodies:
            x = traj.position[f, i]
            hit = world.ray_cast(origin=x, direction=(0, 0, -1), exclude=i)
            if hit.body == 0:  # the basin beneath (not a ball that rolled under it)
                assert hit.distance > radius[i] - 1e-3, (traj.time[f], traj.names[i])
    end = traj.position[-1, 1:, :2]
    assert np.all(np.linalg.norm(end, axis=1) < 1.0)
    assert np.all(np.linalg.norm(traj.velocity[-1, 1:], axis=1) < 1e-2)


def test_gripper_lifts_the_box_squeezed_as_virtual_work_says():
    # examples/gripper.toml: the first finger's motor (at most 10 N) and the gear (q2 = -q1) close
    # both fingers on the box. Virtual work with the gear: the motor's 10 N on dq1 against the two
    # contacts' 2 N dq1 (each finger moves by dq1 inwards) leaves N = 5 N on each side at rest;
    # measured 5.000 N on each to 1e-15, bound 1e-6 (until session 35, 4.96 and 4.93 N: the contacts,
    # solved with each finger's own mass, and the gear solved one after the other in each substep
    # left 1.4 % of the squeeze unbalanced; the contacts are now solved through the joint tree). The
    # box rises with the hand: it slips 2.1 mm when the hand's keyframed path jumps from rest to
    # 0.3 m/s at 0.5 s (friction accelerates it over a few steps), bound 3 mm; then it is held at
    # rest: from 2 s to 3 s every step under 1e-9 m/s (measured 2.2e-12; until session 35 it
    # jittered at 0.03-1.5 mm/s, and this test checked the last step under 1 mm/s), and the gear
    # keeps the fingers mirrored to 2.7e-5 m (its row beside the contacts' rows), bound 1e-4 m.
    scene = load_scene(EXAMPLES / "gripper.toml")
    w = scene.world
    sim = scene.simulator()
    assert sim.joint_settings.method == "tree"  # a gear's default
    hand, box = w.index_of("hand"), w.index_of("box")
    slip = gear = held = 0.0
    for k in range(round(3.0 / scene.dt)):
        sim.step()
        gear = max(gear, abs(sim.joint_readings()["position"][2]))
        slip = max(slip, abs((w.x[hand, 2] - 0.16) - (w.x[box, 2] - 0.03)))
        if k * scene.dt > 2.0:
            held = max(held, np.linalg.norm(w.v[box]))
    assert w.x[hand, 2] == pytest.approx(0.46)
    assert slip < 3e-3 and w.x[box, 2] > 0.33 - 3e-3
    assert held < 1e-9
    assert gear < 1e-4
    c = sim.contacts()
    for finger in ("finger1", "finger2"):
        i = w.index_of(finger)
        touching = ((c.body_a == i) & (c.body_b == box)) | ((c.body_a == box) & (c.body_b == i))
        assert c.normal_impulse[touching].sum() / scene.dt == pytest.approx(5.0, rel=1e-6)


# ---------------------------------------------------------------------- ring toss (moving concave bodies)
RING_MAJOR, RING_TUBE = 0.15, 0.025  # m (examples/tools/make_examples.py: ring.obj)
PEG_RADIUS, PEG_TOP = 0.03, 0.3  # m
CLEARANCE = RING_MAJOR - RING_TUBE - PEG_RADIUS  # 0.095 m: how far a ring's centre can be from the axis of a peg through it


def flat_deg(q):
    """Angle (degrees) between a ring's axis and the vertical, either way up (a torus is flat both ways)."""
    t = tilt_deg(q)
    return min(t, 180.0 - t)


def test_ring_toss_rings_land_round_their_pegs_and_one_misses():
    """Five torus rings (moving concave bodies, `decompose = true`) dropped over three pegs, 3 s.
    Checks against the geometry: rings 0-2 end round their pegs (centre within the 0.095 m
    clearance of the peg's axis: the peg is through the hole), lying flat on the ground (tilt under
    1 degree either way up, centre at the tube's radius 0.025 m to 1 mm), at rest (1 mm/s); ring 3 ends round the
    middle peg on top of ring 1: flat (its centre at three tube radii, 0.075 m, to 1 mm), or leaning on
    the peg (its centre at the clearance from the peg's axis to 3 mm, tilted under 10 degrees, between
    two and three tube radii up: where it lands is sensitive to its drop, 1-2 cm away it leans,
    4-7 degrees, measured when the friction's direction changed in session 41); ring 4 ends
    flat on the ground with no peg through it (farther than 0.155 m from every peg's axis). With
    the rings' convex hulls every ring would stop on a peg's top (tests/physics/test_decompose.py).
    Measured: rings 0-2 at 1.2, 4.3 and 1.6 cm from their pegs, ring 3 3.5 cm from its peg at z
    0.0749 m, ring 4 0.54 m past the right peg; every ring slower than 1 mm/s from 2.3 s on (figures
    of session 40; session 41, the friction's direction changed and ring 3 dropped 1 cm farther along
    x: rings 0-2 at 2.0, 3.7 and 1.0 cm, ring 3 1.5 cm from its peg at z 0.07496 m, flat to 0.02
    degrees, ring 4 0.49 m past the right peg, every ring slower than 1 mm/s from 1.7 s on)."""
    scene, traj = run("ring_toss")
    pegs = [np.asarray(traj.position[-1, traj.names.tolist().index(f"peg{k}")]) for k in range(3)]
    x = {k: traj.position[-1, traj.names.tolist().index(f"ring{k}")] for k in range(5)}
    q = {k: traj.orientation[-1, traj.names.tolist().index(f"ring{k}")] for k in range(5)}
    for k, peg in ((0, 0), (1, 1), (2, 2)):
        assert np.hypot(*(x[k][:2] - pegs[peg][:2])) < CLEARANCE, k
        assert flat_deg(q[k]) < 1.0, k
        assert x[k][2] == pytest.approx(RING_TUBE, abs=1e-3), k
    rings = indices(traj, "ring")
    assert speeds(traj)[rings].max() < 1e-3
    assert np.hypot(*(x[3][:2] - pegs[1][:2])) < CLEARANCE
    # on ring 1: flat (three tube radii up), or leaning on the peg (its hole's edge on it) and tilted
    assert x[3][2] == pytest.approx(3 * RING_TUBE, abs=1e-3) and flat_deg(q[3]) < 1.0 or (
        2 * RING_TUBE < x[3][2] < 3 * RING_TUBE and flat_deg(q[3]) < 10.0
        and np.hypot(*(x[3][:2] - pegs[1][:2])) > CLEARANCE - 3e-3), (x[3], flat_deg(q[3]))
    assert min(np.hypot(*(x[4][:2] - p[:2])) for p in pegs) > RING_MAJOR - RING_TUBE + PEG_RADIUS
    assert flat_deg(q[4]) < 1.0 and x[4][2] == pytest.approx(RING_TUBE, abs=1e-3)
    # the body takes the torus's own mass properties: I_zz = m (R^2 + 3/4 r^2) (a torus's closed form, to
    # the 32 x 12 mesh's faceting: 2 %), not the pieces' (they over-fill it)
    w = scene.world
    assert len({id(w.shapes[i]) for i in rings}) == 1  # one decomposition, shared by the five rings
    i = rings[0]
    Izz = float(np.max(np.linalg.eigvalsh(w.inertia_body[i])))
    assert Izz == pytest.approx(0.05 * (RING_MAJOR**2 + 0.75 * RING_TUBE**2), rel=0.02)


# ---------------------------------------------------------------------- demolition

def test_demolition_wall_stands_then_bursts_outwards_and_the_far_tower_stays():
    """examples/demolition.toml (``tb.Explosion`` at 1 s; the blast's arithmetic is checked in
    tests/physics/test_explosion.py). Checks: before the blast no brick has moved 1 mm (measured
    0.6 mm: the soft contacts' sag under eight courses); just after it every brick moves away from
    the charge (velocity . (x - charge) > 0) and the fastest brick lies within the full-strength
    radius (0.5 m), the slowest near the reach (1.5 m): speed falls with distance; at the end the
    bricks have left the wall's line (mean 2.7 m measured, asked > 1 m), no corner sinks 5 mm into
    the ground, and the crate tower 3 m behind the blast has not moved 1 mm (measured 0.1 mm)."""
    from tumble.scenes.contact import box_corners

    _, traj = run("demolition")
    bricks, crates = indices(traj, "brick"), indices(traj, "crate")
    assert len(bricks) == 44 and len(crates) == 3
    x, t = traj.position, traj.time
    before = int(np.searchsorted(t, 1.0 - 1e-9)) - 1  # the last frame before the blast
    after = before + 2  # 1/30 s after it
    assert np.abs(x[before, bricks] - x[0, bricks]).max() < 1e-3
    charge = np.array([-0.6, 0.0, 0.5])
    away = x[after, bricks] - charge
    v = traj.velocity[after, bricks]
    assert np.all(np.einsum("ij,ij->i", v, away) > 0)
    dist = np.linalg.norm(x[before, bricks] - charge, axis=1)
    speed = np.linalg.norm(v, axis=1)
    assert dist[np.argmax(speed)] < 0.5 + 0.25  # a brick's centre is up to half its length from its closest point
    assert dist[np.argmin(speed)] > 1.0
    assert np.mean(x[-1, bricks, 0] - x[0, bricks, 0]) > 1.0
    R = rotations(traj.orientation[-1])
    corners = box_corners(x[-1, bricks], R[bricks], np.array([0.1, 0.2, 0.1]))
    assert corners[..., 2].min() > -0.005
    assert np.abs(x[-1, crates] - x[0, crates]).max() < 1e-3


# ---------------------------------------------------------------------- wrecking ball

def test_wrecking_ball_breaks_the_fractured_wall_into_chunks():
    """examples/wrecking_ball.toml (``fracture = {...}``: 40 Voronoi cells glued by breakable fixed
    joints; tests/physics/test_fracture.py checks the cutting and the glue). Checks: before the
    ball arrives (0.7 s) no cell has moved 2 mm (measured 1.15 mm: the soft contacts and joints
    settling); after it, the ball passes through the wall's plane,
    between a fifth and nine tenths of the glue breaks (61 of 100 measured), the unbroken glue
    leaves the wall in at least 3 chunks, the largest of at least 5 cells (7 chunks, the largest
    21 cells, measured), and no cell sinks 5 mm into the ground."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    scene, traj = run("wrecking_ball")
    w = scene.world
    cells = indices(traj, "wall/")
    glue = [j for j in w.joints if (j.name or "").startswith("wall/")]
    assert len(cells) == 40
    t = traj.time
    before = int(np.searchsorted(t, 0.7))
    assert np.abs(traj.position[before, cells] - traj.position[0, cells]).max() < 2e-3
    ball = list(traj.names).index("ball")
    assert traj.position[:, ball, 1].min() < -0.35  # its far side past the wall's (y = -0.1)
    broken = np.array([j.broken for j in glue])
    assert 0.2 * len(glue) < broken.sum() < 0.9 * len(glue)
    row = {c: k for k, c in enumerate(cells)}
    held = [(row[j.bound.body_a], row[j.bound.body_b]) for j in glue if not j.broken]
    graph = sp.coo_matrix((np.ones(len(held)), tuple(np.array(held).T)), shape=(len(cells), len(cells)))
    chunks, label = connected_components(graph, directed=False)
    assert chunks >= 3 and np.bincount(label).max() >= 5
    ground = w.index_of("ground")
    assert w.closest_points(cells, ground).distance.min() > -0.005


# ---------------------------------------------------------------------- skatepark (an open sheet)

def test_skatepark_bodies_run_across_the_open_half_pipe_and_none_falls_through():
    """examples/skatepark.toml, 8 s: a half-pipe of one open sheet of no thickness, its triangles all
    facing down (checked), loaded with closed = false. Checks: no body's centre ever gets nearer the
    sheet than its own reach (a ball's radius, the die's and the board's half thickness) less 1 mm,
    measured straight up from the sheet's profile (exact over the flat, an underestimate on the
    walls): nothing went through or into it from its back side; the three balls and the rolling
    pin ran across the pipe and back, crossing its middle at least 3 times; the ball dropped on the
    deck rests on it (its centre 0.1 m above the deck's 1.5 m, 1 mm).
    Measured: nearest 0.1199 / 0.0499 / 0.1099 / 0.0398 / 0.05 / 0.01 m; 3-4 crossings each."""
    import sys

    sys.path.insert(0, str(EXAMPLES / "tools"))
    try:
        from make_examples import pipe_height
    finally:
        sys.path.pop(0)
    scene, traj = run("skatepark")
    names = list(traj.names)
    sheet = scene.world.shapes[names.index("halfpipe")]
    assert isinstance(sheet, tb.Mesh) and not sheet.closed
    tri = sheet.vertices[sheet.faces]
    assert np.all(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2] <= 1e-12)  # all facing down
    reach = {"ball": 0.12, "small_ball": 0.05, "heavy_ball": 0.11, "rolling_pin": 0.04, "die": 0.05, "board": 0.01}
    for name, r in reach.items():
        p = traj.position[:, names.index(name)]
        assert (p[:, 2] - pipe_height(p[:, 1])).min() > r - 1e-3, name
    for name in ("ball", "small_ball", "heavy_ball", "rolling_pin"):
        y = traj.position[:, names.index(name), 1]
        assert np.count_nonzero(np.sign(y[1:]) != np.sign(y[:-1])) >= 3, name
    assert traj.position[-1, names.index("deck_ball"), 2] == pytest.approx(1.6, abs=1e-3)


# ---------------------------------------------------------------------- harbour (buoyancy)

def test_harbour_floats_what_is_lighter_than_sea_water_at_its_archimedes_draft():
    """examples/harbour.toml, 12 s in sea water (1025 kg/m^3) flowing at 0.2 m/s. Checks at the end:
    each floating body has under the surface the fraction of its volume that its density is of the
    water's (Archimedes; within 0.01: the barrel still rocks a little); the log that started on end
    floats on its side (its long axis within 5 degrees of level: upright its metacentre is below its
    centre of mass); every floater drifts with the current (0.2 m/s along x, 1 mm/s); the anchor lies
    on the sea bed (its centre 0.15 m above z = -2, 1 mm), at rest.
    Measured: the barrel 0.007 off, the crate 0.002 (both still bobbing a little), the others within
    2e-4; every drift 0.200 m/s."""
    from tumble.buoyancy import submerged_volume, surface_volume

    scene, traj = run("harbour")
    w = scene.world
    names = list(traj.names)
    floaters = ("crate", "barrel", "beach_ball", "plank", "ice", "log")
    V = submerged_volume(w)
    for name in floaters:
        i = names.index(name)
        whole = surface_volume(w, i)
        assert V[i] / whole == pytest.approx(w.mass[i] / whole / 1025.0, abs=0.01), name
        assert w.v[i] == pytest.approx((0.2, 0.0, 0.0), abs=2e-2), name
        assert w.v[i][0] == pytest.approx(0.2, abs=1e-3), name
    log = names.index("log")
    assert abs(w.R[log][2, 2]) < math.sin(math.radians(5.0))
    anchor = names.index("anchor")
    assert w.x[anchor, 2] == pytest.approx(-2.0 + 0.15, abs=1e-3)
    assert np.linalg.norm(w.v[anchor]) < 1e-3


# ---------------------------------------------------------------------- toss (paths that let go)

def test_toss_throws_the_ball_into_the_stack_and_drops_the_crate_on_the_pallet(tmp_path):
    """examples/toss.toml, 3 s: bodies on keyframed paths with ``release = true``. Checks: until
    its last key (0.8 s) the ball is on its path (at 0.75 s on the straight line between its last
    two keys, 1e-12 m) and kinematic; from its release it flies x1 + u t + g t^2 / 2 with u the
    path's last velocity (4, 0, 2) m/s (1e-9 m up to 1.25 s, well before it nears the stack: rk4
    is exact on a parabola); struck at its top, the stack topples away from the throw (every box
    down on the ground at the end, 0.15 m up to 1 cm, laid out in order beyond where it stood and
    the top one farthest) and the ball bounces back; the crate is on its path at 1.5 s (1e-12 m) and rests on the pallet at
    the end (its centre 0.2 m above the pallet's top, 1 mm), both dynamic then. The trajectory
    file written by ``tumble run`` marks neither as fixed (its exports animate them).
    Measured: boxes at x = 0.32, 0.66, 1.11, 1.63 m; crate 0.4 m up to 0.2 mm."""
    scene, traj = run("toss")
    w = scene.world
    i = w.index_of
    ball, crate = i("ball"), i("crate")
    assert w.body_type(ball) == w.body_type(crate) == "dynamic" and not w.paths
    frame = lambda t: int(round(t * scene.frame_rate))  # noqa: E731
    t = traj.time
    np.testing.assert_allclose(traj.position[frame(0.75), ball], [-2.8, 0, 1.5], atol=1e-12)
    x1, u, g = np.array([-2.6, 0, 1.6]), np.array([4.0, 0, 2.0]), np.array([0, 0, -9.81])
    flight = (t > 0.8) & (t <= 1.25)
    s = (t[flight] - 0.8)[:, None]
    np.testing.assert_allclose(traj.position[flight, ball], x1 + u * s + 0.5 * g * s ** 2, rtol=0, atol=1e-9)
    boxes = [i(f"box{k}") for k in range(4)]
    np.testing.assert_allclose(w.x[boxes, 2], 0.15, atol=0.01)
    assert np.all(np.diff(w.x[boxes, 0]) > 0.2) and w.x[boxes[0], 0] > 0.2
    assert traj.position[:, ball, 0].max() > -0.35 and w.x[ball, 0] < -1.0  # at the stack's face, then back
    np.testing.assert_allclose(traj.position[frame(1.5), crate], [2.5, 0, 1.4], atol=1e-12)
    assert abs(w.x[crate, 2] - (w.x[i("pallet"), 2] + 0.1 + 0.2)) < 1e-3
    assert abs(w.x[i("pallet"), 2] - 0.1) < 1e-3
    out = tmp_path / "toss"
    assert cli_main(["run", str(EXAMPLES / "toss.toml"), "--out", str(out), "--no-progress"]) == 0
    fixed = tb.load_trajectory(out / "trajectory.npz").fixed
    assert fixed.tolist() == [True] + [False] * (w.body_count - 1)


# ---------------------------------------------------------------------- trapdoor (bodies that come and go)

def test_trapdoor_crates_appear_in_turn_and_fall_when_the_floor_vanishes(tmp_path):
    """examples/trapdoor.toml, 4 s: bodies switched in and out (``enable_at``, ``disable_at``).
    Checks: each crate is absent (``Trajectory.enabled``) and held where it waits, to the bit,
    until the frame at its time (0.25 k s: shown there, where it starts from), then falls freely
    (z0 - g t^2 / 2, 1e-9 m over its first 0.2 s: nothing else is there yet) and lands on the
    trapdoor (its centre 0.125 m above the door's top at 1.9 s, 1 mm); the door is absent from
    the frame at 2 s (before session 41, from the frame after: each switch drawn a frame late) and
    every crate rests on the ground at the end (0.125 m, 1 mm) where it stood over the door (1 cm);
    the marker is absent from 3 s on and held where it rested. The file ``tumble run`` writes
    carries the same ``enabled_changes``."""
    scene, traj = run("trapdoor")
    w = scene.world
    i = w.index_of
    on = traj.enabled
    t = traj.time
    for k in range(6):
        c = i(f"crate{k}")
        first = int(np.argmax(t >= 0.25 * (k + 1) - 1e-9))  # the frame at its switch: shown there
        assert not on[:first, c].any() and on[first:, c].all()
        assert np.all(traj.position[:first + 1, c] == traj.position[0, c])  # it starts from there
        fall = (t >= 0.25 * (k + 1)) & (t <= 0.25 * (k + 1) + 0.2)
        s = t[fall] - 0.25 * (k + 1)
        np.testing.assert_allclose(traj.position[fall, c, 2], 1.8 - 0.5 * 9.81 * s ** 2, rtol=0, atol=1e-9)
        assert abs(traj.position[int(round(1.9 * 24)), c, 2] - (1.05 + 0.125)) < 1e-3
        assert abs(w.x[c, 2] - 0.125) < 1e-3 and abs(w.x[c, 0] - (-0.9 + 0.36 * k)) < 0.01
    door, marker = i("trapdoor"), i("marker")
    assert on[t < 2.0 - 1e-9, door].all() and not on[t >= 2.0 - 1e-9, door].any()
    assert on[t < 3.0 - 1e-9, marker].all() and not on[t >= 3.0 - 1e-9, marker].any()
    assert np.all(traj.position[t > 3.0, marker] == traj.position[-1, marker])
    out = tmp_path / "trapdoor"
    assert cli_main(["run", str(EXAMPLES / "trapdoor.toml"), "--out", str(out), "--no-progress"]) == 0
    assert np.array_equal(tb.load_trajectory(out / "trajectory.npz").enabled_changes, traj.enabled_changes)


# ---------------------------------------------------------------------- balloons (gravity scale, damping)

def test_balloons_stand_over_their_weights_and_the_feather_sinks_at_its_terminal_speed():
    """examples/balloons.toml, 8 s: gravity scales and damping rates. The feather (s = 0.2, c = 3
    1/s, dropped from rest) sinks at v_z = -(s g / c)(1 - e^(-c t)) until it nears the ground (1e-9
    m/s over its first 2 s: the closed form of dv/dt = s g - c v); each balloon ends over its weight
    (within 5 mm sideways: the last swing dies slowly and the island falls asleep) at the height its
    lift stretches its string to: weight top + L0 + |s| m g / k + r (1 mm); the weights stay on the
    ground (1 mm). Measured: 0.05 mm off in height, 2.1, 1.4 and 0.3 mm sideways."""
    scene, traj = run("balloons")
    w = scene.world
    i = w.index_of
    t = traj.time
    feather = i("feather")
    early = t <= 2.0
    s, c, g = 0.2, 3.0, 9.81
    np.testing.assert_allclose(traj.velocity[early, feather, 2], -(s * g / c) * (1 - np.exp(-c * t[early])), rtol=0, atol=1e-9)
    assert abs(w.x[feather, 2]) < 0.05  # landed
    for k, lift in enumerate((2, 4, 6)):
        b, wt = i(f"balloon{k}"), i(f"weight{k}")
        assert abs(w.x[wt, 2] - 0.1) < 1e-3
        assert np.linalg.norm(w.x[b, :2] - w.x[wt, :2]) < 5e-3
        assert abs(w.x[b, 2] - (0.2 + 1.0 + lift * 0.05 * g / 40.0 + 0.15)) < 1e-3


# ---------------------------------------------------------------------- billiards


def test_billiards_break_runs_through_the_touching_rack():
    """examples/billiards.toml: the cue ball rolled at 6 m/s into a touching rack of 15 balls (e =
    0.95). Just after the strike (0.25 s; it lands at 0.21 s) the impact has run through the rack
    in waves of pairwise impacts (docs/contact.md, "Impacts through touching chains"): a rack ball
    flies out faster than 2 m/s, more than 60 % of the cue ball's energy is still in the balls,
    the cue ball is left at under 1 m/s along the table, and the two back corners, struck
    alike, leave within 5 % of each other's speed. Measured: 3.00 m/s, 67 %, -0.57 m/s, the
    corners 3.00 and 2.97 m/s. With the restitution pass alone (``impact_chains = false``: Box2D's,
    and PyBullet's and MuJoCo's outcome on a touching row, docs/benchmarks.md "Touching cradle")
    1.24 m/s, 40 % and -2.13 m/s: the rack pushed on as one lump; with the impacts taken a
    manifold at a time in the contacts' order (before the waves), the corners left at 4.44 and
    1.50 m/s. The bounds lie between. At the end every ball is still on the table, inside the
    cushions and on the cloth."""
    scene = load_scene(EXAMPLES / "billiards.toml")
    w = scene.world
    sim = scene.simulator()
    balls = indices_of(w, ("cue", "ball"))
    rack = indices_of(w, ("ball",))
    cue = w.names.index("cue")
    ke0 = w.kinetic_energy()
    sim.step(int(round(0.25 / sim.dt)))
    speed = np.linalg.norm(w.v, axis=1)
    assert speed[rack].max() > 2.0
    assert w.kinetic_energy() > 0.6 * ke0
    assert abs(w.v[cue, 0]) < 1.0
    corners = speed[[w.names.index("ball11"), w.names.index("ball15")]]
    assert abs(corners[0] - corners[1]) < 0.05 * corners.max(), corners
    sim.step(int(round((scene.duration - 0.25) / sim.dt)))
    r = 0.028575
    assert np.all(np.abs(w.x[balls, 0]) < 1.27 - r + 1e-3) and np.all(np.abs(w.x[balls, 1]) < 0.635 - r + 1e-3)
    assert np.all(np.abs(w.x[balls, 2] - r) < 1e-3)


def indices_of(world, prefixes) -> list[int]:
    """The bodies of ``world`` whose names start with one of ``prefixes``."""
    return [i for i, n in enumerate(world.names) if n.startswith(tuple(prefixes))]
