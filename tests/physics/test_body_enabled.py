"""Bodies taken out of the simulation and put back (``World.set_enabled``, ``body.enabled``,
``tb.Switch`` records, the scene file's ``enabled`` / ``enable_at`` / ``disable_at``): Box2D's
``b2Body_Disable`` / ``b2Body_Enable``, what PyBullet's ``removeBody`` and a game's despawn and
spawn are for. Before, a body could not leave a world once added.

Compared with closed forms on the bodies concerned: free fall z0 - g t^2 / 2 once what held a
body is gone, and a body put back on the parabola of the velocity it left with (the rk4 step is
exact on a parabola: 1e-9 m, round-off over a few hundred steps); a disabled body's state equal
to the bit while it is out; rest heights the shapes give (1 mm: the contact tests' rest
tolerance); bit-for-bit repeats through snapshots and checkpoints (state hash)."""

import math

import numpy as np
import pytest

import tumble as tb
from tumble.checks import state_hash

from .test_body_type import failing_force
from .test_contact import G, ground_world

DT = 1.0 / 240.0


def shelf_world():
    """A box resting on a fixed shelf 1 m up (its top at 1.05 m) above the ground."""
    w = ground_world()
    w.add_body(tb.Box(size=(1, 1, 0.1)), fixed=True, mass=5.0, position=(0, 0, 1.0), name="shelf")
    w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 1.15), name="box")
    return w


def test_a_box_asleep_on_a_shelf_that_is_disabled_falls_freely_to_the_ground():
    """The box falls asleep on the shelf (2 s); the shelf disabled, the box wakes (Box2D wakes the
    bodies a disabled body touched) and falls z0 - g t^2 / 2 (1e-9 m over 0.3 s: no contact left
    with the shelf, which stays where it was, to the bit) and rests on the ground (1 mm). Without
    the wake the box stayed asleep in the air; without the shelf's filter it stayed on the shelf."""
    w = shelf_world()
    sim = tb.Simulator(w, dt=DT)
    sim.step(480)
    assert not sim.sleep.awake[2]
    shelf_x = w.x[1].copy()
    z0 = float(w.x[2, 2])
    w.set_enabled("shelf", False)
    assert not w.body("shelf").enabled and w.body_type("shelf") == "fixed"
    sim.step(72)
    assert w.x[2, 2] == pytest.approx(z0 - 0.5 * G * 0.3 ** 2, abs=1e-9)
    sim.step(480)
    assert abs(float(w.x[2, 2]) - 0.1) < 1e-3
    assert np.array_equal(w.x[1], shelf_x)
    c = sim.contacts()
    assert 1 not in c.body_a and 1 not in c.body_b
    assert c.force[:, 2].sum() == pytest.approx(G, rel=1e-3)


def test_a_body_disabled_in_flight_waits_and_comes_back_on_the_parabola_of_its_velocity():
    """A ball thrown at (2, 0, 5) m/s, disabled at 0.25 s: for 0.5 s its state is the same to the
    bit (gravity does not pull it, nothing touches it) and a box dropped through where it is falls
    freely past it (then the box is disabled in its turn). Enabled again, it flies on from where it waited with the velocity it left with:
    x_d + v_d t + g t^2 / 2 (1e-9 m after 0.4 s). Its kinetic energy is out of the world's total
    while it is disabled."""
    w = tb.World(gravity=(0, 0, -G))
    ball = w.add_body(tb.Sphere(radius=0.2), mass=1.0, velocity=(2, 0, 5), name="ball")
    sim = tb.Simulator(w, dt=DT)
    sim.step(60)
    x_d, v_d = ball.x.copy(), ball.v.copy()
    ball.enabled = False
    assert w.kinetic_energy() == 0.0 and np.all(ball.v == 0.0)
    box = w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=x_d + (0, 0, 1.0), name="box")
    sim.step(120)
    assert np.array_equal(ball.x, x_d)
    assert box.x[2] == pytest.approx(x_d[2] + 1.0 - 0.5 * G * 0.5 ** 2, abs=1e-9)  # through the ball
    assert ball.type == "dynamic"
    box.enabled = False  # it would be inside the ball again as it rises
    ball.enabled = True
    np.testing.assert_allclose(ball.v, v_d, rtol=1e-15)
    sim.step(96)
    t = 0.4
    np.testing.assert_allclose(ball.x, x_d + v_d * t + 0.5 * np.array([0, 0, -G]) * t * t, atol=1e-9)


def test_a_velocity_set_while_disabled_is_the_one_it_comes_back_with():
    """Respawned elsewhere: a ball disabled, moved and given a new velocity (``Body.x``,
    ``Body.v``, ``Body.omega`` while disabled), enabled: it starts there at that velocity
    (P = m v, L = I omega to 1e-12) and the state while it waited did not move."""
    w = tb.World(gravity=(0, 0, -G))
    ball = w.add_body(tb.Sphere(radius=0.1), mass=2.0, velocity=(1, 0, 0), name="ball")
    ball.enabled = False
    ball.x = (5.0, 0.0, 3.0)
    ball.v = (0.0, 3.0, 0.0)
    ball.omega = (0.0, 0.0, 4.0)
    tb.Simulator(w, dt=DT).step(10)
    assert np.array_equal(ball.x, [5.0, 0.0, 3.0])
    ball.enabled = True
    np.testing.assert_allclose(ball.P, [0.0, 6.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(ball.L, ball.inertia_body @ [0.0, 0.0, 4.0], atol=1e-12)


def test_a_disabled_body_is_seen_by_no_ray_query_or_sensor():
    """A box in a sensor's region and under a ray: disabled, the ray passes on to the ground and
    the sensor counts no visitor; enabled, the ray hits the box's top and the sensor counts it."""
    w = ground_world()
    w.add_body(tb.Box(size=(2, 2, 2)), fixed=True, sensor=True, position=(0, 0, 1.0), name="zone")
    box = w.add_body(tb.Box(size=(0.4, 0.4, 0.4)), mass=1.0, position=(0, 0, 0.2), name="box")
    sim = tb.Simulator(w, dt=DT)
    box.enabled = False
    sim.step(2)
    hit = w.ray_cast((0, 0, 5), (0, 0, -1))
    assert hit.body[0] == 0 and hit.point[0, 2] == pytest.approx(0.0, abs=1e-9)
    assert len(sim.sensor_overlaps("zone")) == 0
    box.enabled = True
    sim.step(2)
    hit = w.ray_cast((0, 0, 5), (0, 0, -1))
    assert hit.body[0] == 2 and hit.point[0, 2] == pytest.approx(0.4, abs=1e-3)
    assert sim.sensor_overlaps("zone").tolist() == [2]


def chain():
    """Two 1 m rods hinged end to end about x, the first hinged to the world at the origin, both
    hanging still, and a 1 kg ball on a spring (k = 200 N/m) to the lower rod's end."""
    w = tb.World(gravity=(0, 0, -G))
    w.collisions = False
    rod = tb.Box(size=(0.1, 0.1, 1.0))
    a = w.add_body(rod, mass=1.0, position=(0, 0, -0.5), name="a")
    b = w.add_body(rod, mass=1.0, position=(0, 0, -1.5), name="b")
    ball = w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(0, 0, -2.5), name="ball")
    w.add_joint(tb.HingeJoint(body_a=None, body_b=a, anchor=(0, 0, 0), axis=(1, 0, 0), name="top"))
    w.add_joint(tb.HingeJoint(body_a=a, body_b=b, anchor=(0, 0, -1.0), axis=(1, 0, 0), name="mid"))
    spring = tb.Spring(body_a=b, anchor_a=(0, 0, -0.5), body_b=ball, anchor_b=(0, 0, 0), stiffness=200.0)
    w.add_force(spring)
    return w, a, b, ball


def test_disabling_a_link_switches_off_its_joints_and_springs_and_enabling_it_switches_them_back(tmp_path):
    """A hanging chain with a ball on a spring: the lower rod disabled, its two joints are switched
    off (``broken``, ``joint_readings`` enabled 0) and its spring pulls nothing: the ball falls
    freely (z0 + v0 t - g t^2 / 2 to 1e-9 m over 0.2 s, which a spring still pulling would not give:
    it is stretched by about m g / k = 4.9 cm) and the rod stays put to the bit. The ball hung back
    and the rod enabled again, the joints act again (the rod's end on its hinge within 1 mm after
    1 s, where it would have fallen 4.9 m) but not one its user had broken before. A checkpoint
    saved while the rod is out loads with the rod out and its joint switched off by it.
    The spring's potential is out of the world's energy while its end is disabled."""
    w, a, b, ball = chain()
    sim = tb.Simulator(w, dt=DT)
    sim.step(240)  # settles: the spring stretched by m g / k
    top, mid = w.joints
    e_spring = w.potential_energy() - G * float(w.mass[:3] @ w.x[:3, 2])  # the spring's part: k d^2 / 2
    assert e_spring == pytest.approx(0.5 * 200.0 * (G / 200.0) ** 2, rel=0.05)
    b_x = b.x.copy()
    z0, vz0 = float(ball.x[2]), float(ball.v[2])  # (it bobs on the spring: no damping)
    b.enabled = False
    assert mid.broken and not top.broken and w.joints_switched_off == {1}
    assert w.potential_energy() == pytest.approx(G * float(w.mass[[0, 2]] @ w.x[[0, 2], 2]), rel=1e-12)
    sim.step(48)
    assert ball.x[2] == pytest.approx(z0 + vz0 * 0.2 - 0.5 * G * 0.2 ** 2, abs=1e-9)
    assert np.array_equal(b.x, b_x)
    assert sim.joint_readings()["enabled"].tolist() == [1.0, 0.0]
    sim.save_checkpoint(tmp_path / "out.npz")  # the rod out, its joint switched off by it
    loaded = tb.Simulator.load_checkpoint(tmp_path / "out.npz").world
    assert not loaded.body("b").enabled and loaded.joints_switched_off == {1} and loaded.joints[1].broken
    loaded.body("b").enabled = True
    assert not loaded.joints[1].broken and loaded.body("b").mass == 1.0
    ball.x, ball.v = (0.0, 0.0, z0), (0.0, 0.0, 0.0)  # hung back where it was
    b.enabled = True
    assert not mid.broken and not w.joints_switched_off
    sim.step(240)
    pivot = a.x + a.R @ np.array([0, 0, -0.5])
    assert np.linalg.norm(b.x + b.R @ np.array([0, 0, 0.5]) - pivot) < 1e-3
    # a joint its user broke stays broken through a disable and an enable
    mid.broken = True
    b.enabled = False
    b.enabled = True
    assert mid.broken and not w.joints_switched_off


def test_a_kinematic_body_disabled_leaves_its_path_and_comes_back_kinematic_at_rest():
    """A platform on a keyframed path: disabled, its path ends (as with a type change) and it
    stays where it was; enabled, it is kinematic again, at the velocity it left with."""
    w = tb.World(gravity=(0, 0, -G))
    plat = w.add_body(tb.Box(size=(1, 1, 0.1)), kinematic=True, name="platform")
    w.add_path(tb.KeyframePath(plat, times=[0.0, 1.0], positions=[[0, 0, 0], [1, 0, 0]]))
    sim = tb.Simulator(w, dt=DT)
    sim.step(60)
    v = plat.v.copy()
    plat.enabled = False
    assert not w.paths and plat.type == "kinematic" and w.body_types().tolist() == ["kinematic"]
    x = plat.x.copy()
    sim.step(60)
    assert np.array_equal(plat.x, x)
    plat.enabled = True
    assert plat.kinematic and np.array_equal(plat.v, v)
    sim.step(24)
    np.testing.assert_allclose(plat.x, x + v * 0.1, atol=1e-12)


@pytest.mark.parametrize("case", ["not a flag", "plane", "type", "mass", "momentum", "impulse", "switch plane"])
def test_a_bad_enable_call_is_refused_with_one_line_and_nothing_changes(case):
    w = shelf_world()
    box = w.body("box")
    before = state_hash(w)
    with pytest.raises(tb.InputError) as err:
        if case == "not a flag":
            w.set_enabled(box, "no")
        elif case == "plane":
            w.set_enabled("ground", False)
        elif case == "switch plane":
            w.add_force(tb.Switch("ground", enabled=False, time=1.0))
        else:
            box.enabled = False
            before = state_hash(w)
            if case == "type":
                box.type = "fixed"
            elif case == "mass":
                box.mass = 3.0
            elif case == "momentum":
                box.P = (1.0, 0.0, 0.0)
            else:
                box.apply_impulse((1.0, 0.0, 0.0))
    message = str(err.value)
    assert "\n" not in message
    assert {"not a flag": "expected True or False", "plane": "a plane cannot be disabled",
            "switch plane": "a plane cannot be disabled", "type": "is disabled: enable it",
            "mass": "is disabled: enable it", "momentum": "is disabled: set v or omega",
            "impulse": "is disabled"}[case] in message
    assert state_hash(w) == before


def switched_world():
    """The shelf world with a ball that appears at 0.5 s above the box and the shelf that vanishes
    at 1.25 s (``Switch`` records), and a box that vanishes at 1.75 s."""
    w = shelf_world()
    ball = w.add_body(tb.Sphere(radius=0.1), mass=0.5, position=(0.05, 0, 1.8), name="ball", enabled=False)
    w.add_force(tb.Switch(ball, enabled=True, time=0.5))
    w.add_force(tb.Switch("shelf", enabled=False, time=1.25))
    w.add_force(tb.Switch("box", enabled=False, time=1.75))
    return w


def test_switches_take_their_bodies_out_and_back_at_their_times():
    """A ball added disabled appears at 0.5 s (the first step from then: held until then to the
    bit) and lands on the box; the shelf vanishes at 1.25 s and both fall; the box vanishes at
    1.75 s. The recorded trajectory says so frame by frame (``enabled``, 24 frames a second:
    frames 12, 30, 42, at 0.5, 1.25 and 1.75 s, are the first of the changes: a frame at a
    switch's time shows it done, as the step from there starts with it. Before session 41 each
    came a frame late: 13, 31, 43, the ball drawn hidden at 0.5 s)."""
    sim = tb.Simulator(switched_world(), dt=DT)
    traj = sim.run(2.5)
    assert traj.enabled_changes.tolist() == [[0, 3, 0], [12, 3, 1], [30, 1, 0], [42, 2, 0]]
    on = traj.enabled
    assert on[:12, 3].sum() == 0 and on[12:, 3].all() and not on[30:, 1].any() and not on[42:, 2].any()
    assert on[29, 1] and on[41, 2]
    assert np.all(traj.position[:13, 3] == traj.position[0, 3])
    assert traj.position[30, 3, 2] > 1.2 and traj.position[-1, 3, 2] < 0.2  # on the box, then on the ground
    assert abs(float(traj.position[-1, 3, 2]) - 0.1) < 1e-3


@pytest.mark.parametrize("save_at", [1.0, 2.0])
def test_a_run_through_switches_resumes_and_restores_bit_for_bit(tmp_path, save_at):
    """Streamed to a file, checkpointed at 1 s (the ball's switch applied, the shelf's and box's to
    come) or 2 s (the shelf and the box out), resumed to 2.5 s: the same state hash and trajectory
    (enabled_changes included: the rows before the checkpoint come from its run record) as the run
    kept in memory. A snapshot at 0.25 s restored after the run repeats it to the bit, the ball
    disabled again."""
    straight = tb.Simulator(switched_world(), dt=DT)
    traj = straight.run(2.5)
    sim = tb.Simulator(switched_world(), dt=DT)
    sim.run_to_file(tmp_path / "run", save_at, progress=False)
    resumed = tb.Simulator.load_checkpoint(tmp_path / "run" / "checkpoint.npz")
    resumed.run_to_file(tmp_path / "run", 2.5, progress=False, resume=True)
    assert state_hash(resumed.world) == state_hash(straight.world)
    streamed = tb.load_trajectory(tmp_path / "run" / "trajectory.npz")
    assert np.array_equal(streamed.enabled_changes, traj.enabled_changes)
    assert np.array_equal(streamed.position, traj.position)

    again = tb.Simulator(switched_world(), dt=DT)
    again.step(60)
    saved = again.save_state()
    again.step(540)
    assert state_hash(again.world) == state_hash(straight.world)
    again.restore_state(saved)
    assert not again.world.body("ball").enabled and again.world.body("shelf").enabled
    again.step(540)
    assert state_hash(again.world) == state_hash(straight.world)


def test_a_call_that_fails_after_a_switch_puts_the_body_back_as_it_was():
    """A ``step`` call that passes a switch (a ball appears at 0.5 s) and then fails (a user force
    on a falling box raising at 0.6 s): the world is back where the call began, the ball disabled
    again; mended, the same call gives the bits of a run that never failed. (Without contacts: a
    failed call puts back the state, not the contact solver's warm start.)"""
    fail = [True]

    def world():
        w = tb.World(gravity=(0, 0, -G))
        ball = w.add_body(tb.Sphere(radius=0.1), mass=0.5, position=(0, 0, 2), name="ball", enabled=False,
                          velocity=(1, 0, 0))
        w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(3, 0, 0), name="box")
        w.add_force(tb.Switch(ball, enabled=True, time=0.5))
        w.add_force(failing_force(fail, "box"))
        return w

    sim = tb.Simulator(world(), dt=DT)
    start = state_hash(sim.world)
    with pytest.raises(tb.InputError, match="the force failed"):
        sim.step(240)
    assert not sim.world.body("ball").enabled and state_hash(sim.world) == start and not sim.world.applied_impulses
    fail[0] = False
    sim.step(240)
    straight = tb.Simulator(world(), dt=DT)
    straight.step(240)
    assert sim.world.body("ball").enabled and state_hash(sim.world) == state_hash(straight.world)
    assert sim.world.x[0, 0] == pytest.approx(0.5, abs=1e-12)  # moved at 1 m/s for the 0.5 s it was in


SCENE = """
[simulation]
duration = 1.0
[[bodies]]
name = "ground"
shape = {{ type = "plane", normal = [0, 0, 1] }}
fixed = true
[[bodies]]
name = "ball"
shape = {{ type = "sphere", radius = 0.1 }}
mass = 1.0
position = [0, 0, 1]
{extra}
"""


def test_a_scene_files_switches_become_switch_records(tmp_path):
    """``enable_at`` / ``disable_at`` (a time or a list): Switch records in time order; a body
    whose first switch is an enable starts disabled unless ``enabled`` says otherwise."""
    from tumble.scene import load_scene

    path = tmp_path / "s.toml"
    path.write_text(SCENE.format(extra="enable_at = [0.5, 0.9]\ndisable_at = 0.7"))
    w = load_scene(path).world
    assert not w.body("ball").enabled
    assert [(f.enabled, f.time) for f in w.forces] == [(True, 0.5), (False, 0.7), (True, 0.9)]
    path.write_text(SCENE.format(extra="disable_at = 0.5"))
    assert load_scene(path).world.body("ball").enabled
    path.write_text(SCENE.format(extra="enabled = false"))
    assert not load_scene(path).world.body("ball").enabled


@pytest.mark.parametrize("extra, problem", [
    ('enabled = "no"', "bodies[1].enabled: expected true or false"),
    ("enable_at = -1.0", "bodies[1].enable_at"),
    ("enable_at = []", "bodies[1].enable_at: expected a time"),
    ("enable_at = 0.5\ndisable_at = 0.5", "two switches at t = 0.5 s"),
])
def test_a_bad_switch_in_a_scene_file_is_one_line_and_exit_2(tmp_path, capsys, extra, problem):
    from tumble.cli import main as cli_main

    path = tmp_path / "bad.toml"
    path.write_text(SCENE.format(extra=extra))
    assert cli_main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(path) in err and problem in err, err


def test_a_plane_switched_in_a_scene_file_is_one_line_and_exit_2(tmp_path, capsys):
    from tumble.cli import main as cli_main

    path = tmp_path / "bad.toml"
    path.write_text(SCENE.format(extra="").replace('fixed = true\n', 'fixed = true\ndisable_at = 1.0\n', 1))
    assert cli_main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "bodies[0].disable_at" in err and "a plane cannot be disabled" in err, err


def test_bodies_added_disabled_are_passed_through_by_what_falls_onto_them():
    """Twenty boxes added disabled inside one another on the ground (spawn slots at one place):
    a ball dropped onto them from 2 m falls freely through them (z0 - g t^2 / 2 to 1e-9 m for
    0.55 s, down to 0.52 m, inside the slots) and rests on the ground under them (1 mm), with no
    contact but its own; the slots keep their masses for later (``dynamic_mass``)."""
    w = ground_world()
    for k in range(20):
        w.add_body(tb.Box(size=(1.0, 1.0, 1.0)), mass=1.0, position=(0, 0, 0.5), name=f"slot{k}", enabled=False)
    ball = w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(0, 0, 2), name="ball")
    sim = tb.Simulator(w, dt=DT)
    sim.step(132)
    assert ball.x[2] == pytest.approx(2 - 0.5 * G * 0.55 ** 2, abs=1e-9)
    sim.step(240)
    assert abs(float(ball.x[2]) - 0.1) < 1e-3
    c = sim.contacts()
    assert set(c.body_a.tolist()) | set(c.body_b.tolist()) == {0, 21}
    assert math.isinf(w.mass[1]) and w.dynamic_mass[1] == 1.0
