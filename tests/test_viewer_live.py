"""The live viewer (tumble.viewer.live_viewer, ``tumble view SCENE --live``): a scene simulated as it is shown.

What each test compares with:
* the steps: a plain ``Simulator`` of the same scene file stepped the same number of steps
  (the viewer must add nothing to the physics: equal bits);
* Reset: the first start (equal bits, then equal bits again after the same steps);
* a push: the impulse's definition, dP = J and dL = (p - x) x J, to round-off (1e-12
  relative: one addition each);
* a grab: the static equilibrium of a mass on a spring of stiffness m omega^2 under gravity,
  the centre of mass g / omega^2 below the handle (to 1e-9 m after 4 s: the critically damped
  error decays as (1 + omega t) e^(-omega t), 1e-20 at 4 s; the integrator is exact on a
  constant force); without the grab's drag a sideways start would keep swinging (checked);
* the browser test: a click in headless Chromium (the same setup as tests/test_viewer.py)
  reaches the viewer as a push of the body under the mouse.
"""

from __future__ import annotations

import argparse
import math
import time
import urllib.request

import numpy as np
import pytest

from tumble.cli import main
from tumble.errors import InputError

viser = pytest.importorskip("viser")

from tests.test_viewer import (  # noqa: E402  (after importorskip: these import viser's users)
    BENIGN_CONSOLE_ERRORS, CANVAS_ONLY_CSS, VIEWPORT, browser, camera_settled, free_port, project, wait_for)
from tumble.viewer import live  # noqa: E402
from tumble.viewer.commands import cmd_view  # noqa: E402
from tumble.viewer.live_viewer import GRAB_HERTZ, MAX_LAG_S  # noqa: E402
import tumble as tb  # noqa: E402

__all__ = ["browser"]  # the fixture, shared

SCENE = """
[simulation]
duration = 2.0
frame_rate = 24
gravity = [0, 0, -9.81]
record_contacts = true

[[bodies]]
name = "ground"
shape = { type = "plane", normal = [0, 0, 1] }
fixed = true

[[bodies]]
name = "box"
shape = { type = "box", size = [0.4, 0.4, 0.4] }
mass = 2.0
position = [0, 0, 0.6]
euler_deg = [20, 10, 0]

[[bodies]]
name = "ball"
shape = { type = "sphere", radius = 0.2 }
mass = 1.0
position = [0.8, 0, 0.5]
velocity = [-1, 0, 0]
"""


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    return path


@pytest.fixture
def paused(scene_file):
    v = live(scene_file, port=free_port(), play=False)
    try:
        yield v
    finally:
        v.stop()


def plain_state(path, steps: int) -> np.ndarray:
    sim = tb.load_scene(path).simulator()
    sim.step(steps)
    return sim.world.pack()


def test_live_steps_have_the_bits_of_a_plain_run(paused, scene_file):
    v = paused
    assert v.steps_per_frame == 10  # 1/24 s at the scene's dt = 1/240 s
    v.step_frame(3)
    v.advance(17)
    assert v.sim.step_index == 47
    assert np.array_equal(v.world.pack(), plain_state(scene_file, 47))
    # what the browser was sent is the world's state (float32 on the wire), and the body panel reads it
    for i in (1, 2):
        x, q = v.body_pose(i)
        np.testing.assert_allclose(x, v.world.x[i], rtol=0, atol=1e-6)
        np.testing.assert_allclose(q, v.world.q[i], rtol=0, atol=1e-6)
    v.select(1)
    info = v.body_info(1)
    assert np.array_equal(info["v"], v.world.v[1]) and np.array_equal(info["L"], v.world.L[1])
    assert "**box**" in v.info.content and "t = 0.196 s (step 47)" in v.info.content
    assert v.time_text.content.startswith("t = 0.196 s, step 47")


def test_reset_starts_again_bit_identically(paused, scene_file):
    v = paused
    start = v.world.pack()
    v.step_frame(2)
    v.push("box", None, (1, 0, 0), speed=3.0)
    v.grab("ball")
    v.move_grab((0, 1, 2))
    v.advance(30)
    assert not np.array_equal(v.world.pack(), plain_state(scene_file, 50))
    v.reset()
    assert v.grabbed is None and v.grab_handle is None and not v.playing
    assert v.sim.step_index == 0 and v.world.t == 0.0
    assert np.array_equal(v.world.pack(), start)
    assert not any(isinstance(f, (tb.Spring, tb.Drag)) for f in v.world.forces)
    v.advance(50)
    assert np.array_equal(v.world.pack(), plain_state(scene_file, 50))


def test_the_recording_is_the_trajectory_of_a_plain_run(paused, scene_file):
    """Frames at the frame rate from the start, as ``Simulator.run`` records them: every array
    (contacts too: the scene records them) equal to a plain run's, bit for bit; a part frame's steps
    are not a frame."""
    v = paused
    v.step_frame(69)
    v.advance(25)  # 2.5 frames: frames 70 and 71 recorded, half of the 72nd stepped
    traj = v.trajectory()  # 72 frames: past the recorder's first 64 (it grows)
    plain = tb.load_scene(scene_file).simulator().run(71 / 24)
    assert len(traj.time) == 72 and traj.contact_count is not None and traj.contact_count[-1] > 0
    for field in ("time", "position", "orientation", "velocity", "angular_velocity", "linear_momentum",
                  "angular_momentum", "kinetic_energy", "potential_energy", "contact_count", "contact_point",
                  "contact_force", "names", "shapes", "fixed", "com_offset"):
        assert np.array_equal(getattr(traj, field), getattr(plain, field), equal_nan=field.startswith("contact")), field
    assert "recorded 72 frames" in v.time_text.content


def test_save_writes_each_run_to_a_new_folder_and_reset_starts_a_new_recording(paused, tmp_path):
    from tumble.trajectory import load_trajectory

    v = paused
    v.out = tmp_path / "live"
    v.step_frame(3)
    v.push("ball", None, (0, 0, 1), speed=2.0)
    v.step_frame(2)
    first = v.save()
    second = v.save()
    assert (first.name, second.name) == ("run-001", "run-002")
    for folder in (first, second):
        assert (folder / "trajectory.glb").stat().st_size > 1000
        saved = load_trajectory(folder / "trajectory.npz")
        assert np.array_equal(saved.position, v.trajectory().position) and len(saved.time) == 6
    # the push is in the recording: the ball's vertical momentum jumps by m * 2 m/s between frames 3 and 4
    saved = load_trajectory(first / "trajectory.npz")
    assert saved.linear_momentum[4, 2, 2] - saved.linear_momentum[3, 2, 2] > 1.5
    assert f"saved {second}" in v.time_text.content
    v.reset()
    assert len(v.trajectory().time) == 1 and v.trajectory().time[0] == 0.0


def test_the_recording_stops_at_the_memory_limit(scene_file, monkeypatch):
    monkeypatch.setenv("TUMBLE_MAX_MEMORY", "20000")  # bytes: 2 x (3 bodies x 152 + 80) a frame -> 18 frames
    v = live(scene_file, port=free_port(), play=False)
    try:
        v.step_frame(20)
        assert len(v.trajectory().time) == 18 and v.sim.step_index == 200
        assert "(full: the memory limit)" in v.time_text.content
    finally:
        v.stop()


def test_dragging_the_handle_moves_the_grab_anchor(paused):
    """The handle's drag reaches the grab spring: viser calls the handle's update callbacks with a
    TransformControlsEvent whose target has the new pose (called here as viser's message handler
    does; the browser's own drag gesture is not driven by these tests)."""
    from viser._scene_handles import TransformControlsEvent

    v = paused
    v.click_ray(v.world.x[2] + np.array([0.0, 0.0, 3.0]), (0, 0, -1), "grab")
    assert v.grabbed is not None and v.grabbed[0] == 2
    np.testing.assert_allclose(v.grab_handle.position, v.world.x[2] + [0, 0, 0.2], atol=1e-6)  # the ball's top
    handle = v.grab_handle
    handle.position = (0.8, 0.3, 1.2)
    for phase in ("start", "update", "end"):
        for callback in handle._impl_aux.update_cb:
            callback(TransformControlsEvent(client=None, client_id=None, target=handle, phase=phase))
    assert v.grabbed[1].anchor_b == (0.8, 0.3, 1.2)
    # a click on nothing in grab mode lets go
    v.click_ray((0, 0, 5), (0, 0, 1), "grab")
    assert v.grabbed is None and v.grab_handle is None and not v.release_button.visible


def test_push_changes_the_momenta_by_the_impulse(paused):
    v = paused
    w = v.world
    i = w.index_of("box")
    P0, L0, x = w.P[i].copy(), w.L[i].copy(), w.x[i].copy()
    point = x + np.array([0.1, -0.2, 0.15])
    direction = np.array([1.0, 2.0, -0.5])
    v.push("box", point, direction, speed=4.0)
    J = 2.0 * 4.0 * direction / np.linalg.norm(direction)
    np.testing.assert_allclose(w.P[i] - P0, J, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(w.L[i] - L0, np.cross(point - x, J), rtol=1e-12, atol=1e-12)
    with pytest.raises(InputError, match="push"):
        v.push("box", None, (0, 0, 0))
    with pytest.raises(InputError, match="dynamic"):
        v.push("ground", None, (0, 0, 1))
    with pytest.raises(InputError, match="not dynamic"):
        v.grab("ground")


def test_a_click_in_push_mode_pushes_the_body_the_ray_hits_where_it_hits(paused):
    v = paused
    w = v.world
    i = w.index_of("ball")
    P0, L0 = w.P[i].copy(), w.L[i].copy()
    centre = w.x[i].copy()
    origin = centre + np.array([3.0, 0.05, 0.0])  # a ray along -x, 5 cm off the ball's centre line
    body = v.click_ray(origin, (-1, 0, 0), "push")
    assert body == i and v.selected == i
    # the ray enters the sphere of radius 0.2 at x = cx + sqrt(0.2^2 - 0.05^2)
    hit = centre + np.array([math.sqrt(0.04 - 0.0025), 0.05, 0.0])
    J = np.array([-1.0 * v.push_speed_slider.value, 0, 0])
    np.testing.assert_allclose(w.P[i] - P0, J, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(w.L[i] - L0, np.cross(hit - centre, J), rtol=0, atol=1e-9)
    # the ground is hit but does not move: selected only; a ray into the sky hits nothing
    assert v.click_ray((0, 3, 1), (0, 0, -1), "push") is None and v.selected == w.index_of("ground")
    assert v.click_ray((0, 3, 1), (0, 0, 1), "push") is None
    with pytest.raises(InputError, match="mode"):
        v.click_ray(origin, (-1, 0, 0), "throw")



def test_a_click_in_blast_mode_sets_off_the_explosion_the_world_would_at_the_hit(paused):
    """A click on the ground beside the box and the ball, in blast mode: the momenta change by
    exactly the impulses of the explosion at the ray's hit point (``collision.explosion.blast``,
    whose arithmetic tests/physics/test_explosion.py checks) with the sliders' radius and strength
    and as much falloff as radius; both bodies are reached; the ground is blasted from, not
    moved. A click on nothing sets nothing off."""
    v = paused
    w = v.world
    v.blast_radius_slider.value, v.blast_strength_slider.value = 0.6, 150.0
    origin, direction = np.array([0.3, 0.2, 3.0]), np.array([0.0, 0.0, -1.0])  # straight down onto the ground
    hit = w.ray_cast(origin, direction)
    assert hit.body[0] == w.index_of("ground")
    P0, L0 = w.P.copy(), w.L.copy()
    from tumble.collision.explosion import blast

    expected = blast(w, tb.Explosion(position=hit.point[0], radius=0.6, falloff=0.6, impulse_per_area=150.0))
    assert sorted(expected.body.tolist()) == [w.index_of("box"), w.index_of("ball")]
    assert v.click_ray(origin, direction, "blast") is None  # the ground: blasted from, not moved
    dP = np.zeros_like(P0)
    dL = np.zeros_like(L0)
    for k, i in enumerate(expected.body):
        dP[i] += expected.impulse[k]
        dL[i] += np.cross(expected.point[k] - w.x[i], expected.impulse[k])
    np.testing.assert_array_equal(w.P, P0 + dP)
    np.testing.assert_allclose(w.L, L0 + dL, rtol=0, atol=1e-15)
    assert np.any(dP != 0)
    P1 = w.P.copy()
    assert v.click_ray((0, 3, 1), (0, 0, 1), "blast") is None  # into the sky
    np.testing.assert_array_equal(w.P, P1)



def test_the_shaded_blast_checkbox_shades_the_click_blast(paused):
    """With "Shaded blast" ticked, a click's blast is ``World.explode(..., shaded=True)``'s: a
    click on the box's far side from the ball sets it off there, the box hides (part of) the ball,
    and the momenta change by the shaded blast's impulses, which differ from the unshaded ones."""
    v = paused
    w = v.world
    v.blast_radius_slider.value, v.blast_strength_slider.value = 0.6, 150.0
    v.blast_shaded_checkbox.value = True
    origin, direction = np.array([-3.0, 0.0, 0.55]), np.array([1.0, 0.0, 0.0])  # onto the box, the ball behind it
    hit = w.ray_cast(origin, direction)
    assert hit.body[0] == w.index_of("box")
    from tumble.collision.explosion import blast

    record = dict(position=hit.point[0], radius=0.6, falloff=0.6, impulse_per_area=150.0)
    expected = blast(w, tb.Explosion(**record, shaded=True))
    plain = blast(w, tb.Explosion(**record))
    assert not np.array_equal(expected.impulse, plain.impulse)
    P0 = w.P.copy()
    v.click_ray(origin, direction, "blast")
    dP = np.zeros_like(P0)
    for k, i in enumerate(expected.body):
        dP[i] += expected.impulse[k]
    np.testing.assert_array_equal(w.P, P0 + dP)

def test_back_to_mark_returns_to_the_snapshot_and_cuts_the_take_back(paused, scene_file):
    """Mark after two frames, push the box, grab the ball, run on, Back to mark: the state is the
    mark's, bit for bit, the grab let go, the recording cut back to the mark's frames; running on
    from there gives a plain run's bits and frames (the push and grab gone from history). A Reset
    forgets the mark."""
    v = paused
    v.step_frame(2)
    assert v.back_button.disabled
    at_mark = v.world.pack()
    v.mark()
    assert not v.back_button.disabled and "mark at t = 0.083 s" in v.time_text.content
    v.push("box", None, (1, 0, 0), speed=3.0)
    v.grab("ball")
    v.move_grab((0, 1, 2))
    v.advance(30)
    assert v._recorder.count == 6 and not np.array_equal(v.world.pack(), plain_state(scene_file, 50))
    v.back_to_mark()
    assert np.array_equal(v.world.pack(), at_mark) and v.sim.step_index == 20
    assert v.grabbed is None and v.grab_handle is None and not v.playing
    assert v._recorder.count == 3
    v.advance(30)
    assert np.array_equal(v.world.pack(), plain_state(scene_file, 50))
    traj = v.trajectory()
    plain = tb.load_scene(scene_file)
    plain.duration = 50 / 240
    expected = plain.run(progress=False)
    assert traj.frame_count == expected.frame_count == 6
    np.testing.assert_array_equal(traj.position, expected.position)
    v.back_to_mark()  # the mark stays: back again
    assert np.array_equal(v.world.pack(), at_mark)
    v.reset()
    assert v.back_button.disabled
    with pytest.raises(InputError, match="no mark"):
        v.back_to_mark()

def grab_world():
    world = tb.World(gravity=(0, 0, -9.81))
    world.add_body(tb.Box(size=(0.3, 0.2, 0.1)), mass=3.0, position=(0, 0, 1), velocity=(1.0, -0.5, 0.0),
                   angular_velocity=(0.0, 0.0, 2.0))
    return tb.Simulator(world, dt=1 / 240)


def test_a_grabbed_body_hangs_g_over_omega_squared_below_the_handle_and_falls_when_let_go():
    v = live(grab_world, port=free_port(), play=False)
    try:
        w = v.world
        forces_before = list(w.forces)
        v.grab(0)  # by its centre of mass
        handle = np.array([0.5, 0.2, 1.5])
        v.move_grab(handle)
        v.advance(4 * 240)
        omega = 2 * math.pi * GRAB_HERTZ
        expected = handle - np.array([0, 0, 9.81 / omega**2])
        np.testing.assert_allclose(w.x[0], expected, rtol=0, atol=1e-9)
        assert np.linalg.norm(w.v[0]) < 1e-8 and np.linalg.norm(w.omega[0]) < 1e-6
        v.release()
        assert w.forces == forces_before and v.grabbed is None
        v.advance(24)
        np.testing.assert_allclose(w.v[0], [0, 0, -9.81 * 0.1], rtol=0, atol=1e-8)  # free fall again
    finally:
        v.stop()


def test_without_the_grabs_drag_the_body_would_swing(monkeypatch):
    """The check above can fail: a grab spring alone (no drag) leaves a sideways start swinging."""
    import tumble.viewer.live_viewer as live_module

    monkeypatch.setattr(live_module, "Drag", lambda **kw: tb.Drag(bodies=kw["bodies"]))
    v = live(grab_world, port=free_port(), play=False)
    try:
        v.grab(0)
        v.move_grab((0.5, 0.2, 1.5))
        v.advance(4 * 240)
        omega = 2 * math.pi * GRAB_HERTZ
        assert np.linalg.norm(v.world.x[0] - np.array([0.5, 0.2, 1.5 - 9.81 / omega**2])) > 1e-3
    finally:
        v.stop()


def test_reset_takes_the_integrator_and_dt_chosen(paused, scene_file):
    """The "Integration" choices apply at Reset: the run then has the bits of the scene run with
    that integrator and dt; the dt offered are those that divide a frame into whole steps."""
    v = paused
    assert list(v._dt_choices.values()) == [1 / 120, 1 / 240, 1 / 480, 1 / 960, 1 / 2400]  # not 1/60: 2.5 a frame
    assert v.integrator_dropdown.value == "rk4" and "(the scene's)" in v.dt_dropdown.value
    v.integrator_dropdown.value = "explicit-euler"
    v.dt_dropdown.value = next(label for label, dt in v._dt_choices.items() if dt == 1 / 480)
    v.advance(5)
    assert v.sim.integrator == "rk4"  # not before the Reset
    v.reset()
    assert (v.sim.integrator, v.sim.dt, v.steps_per_frame) == ("explicit-euler", 1 / 480, 20)
    v.step_frame(2)
    scene = tb.load_scene(scene_file)
    scene.integrator, scene.dt = "explicit-euler", 1 / 480
    sim = scene.simulator()
    sim.step(40)
    assert np.array_equal(v.world.pack(), sim.world.pack())


def test_the_energy_plot_shows_the_recorded_frames(paused):
    v = paused
    v.step_frame(6)
    t, kinetic, potential, total = v.energy_plot.data
    traj = v.trajectory()
    assert np.array_equal(t, traj.time) and len(t) == 7
    assert np.array_equal(kinetic, traj.kinetic_energy) and np.array_equal(potential, traj.potential_energy)
    assert np.array_equal(total, traj.kinetic_energy + traj.potential_energy)
    assert kinetic[-1] > kinetic[0]  # the bodies fall: potential turns into kinetic energy


def test_actuator_sliders_set_the_controls_a_plain_run_would(tmp_path):
    """An MJCF model's actuators get a slider each (MuJoCo's viewer: over its ctrlrange); moving
    one is ``Robot.set_controls`` from the next step: the bits of a plain run given the same
    control at the same step. Reset puts the sliders back at the scene's own controls."""
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "mjcf_turntable.toml"
    v = live(path, port=free_port(), play=False)
    try:
        slider = v.control_sliders[("turntable", "spin")]
        assert (slider.min, slider.max, slider.value) == (-3.0, 3.0, 1.2)  # ctrlrange; the scene's controls
        v.advance(10)
        v.set_control("turntable", "spin", 2.5)
        v.advance(38)
        scene = tb.load_scene(path)
        sim = scene.simulator()
        sim.step(10)
        scene.robots["turntable"].set_controls(sim, {"spin": 2.5})
        sim.step(38)
        assert np.array_equal(v.world.pack(), sim.world.pack())
        v.set_control("turntable", "spin", 9.0)  # past the range: the slider and MuJoCo clip it
        assert v.robots["turntable"].actuators["spin"].ctrl == 3.0
        v.reset()
        assert slider.value == 1.2 and v.robots["turntable"].actuators["spin"].ctrl == 1.2
        with pytest.raises(InputError, match="no actuator or driven joint"):
            v.set_control("turntable", "lift", 1.0)
    finally:
        v.stop()


def test_drive_sliders_set_a_urdf_robots_motor_and_targets_as_a_plain_run_would():
    """A URDF robot's driven joints get a slider each (PyBullet's debug parameters feeding
    setJointMotorControl2): the motor's speed, the PD drives' targets (over the joints' limits),
    with the scene's gains and force limits: the bits of a plain run given the same commands."""
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "robot_arm.toml"
    v = live(path, port=free_port(), play=False)
    try:
        sliders = {name: (s.label, s.min, s.max, s.value) for (_robot, name), s in v.control_sliders.items()}
        assert sliders == {"yaw": ("yaw speed (rad/s)", -3.0, 3.0, 1.5),  # twice the speed given
                           "shoulder": ("shoulder target (rad)", -2.0, 2.0, 1.2),  # the URDF's limits
                           "elbow": ("elbow target (rad)", -2.5, 2.5, 0.9)}
        v.advance(10)
        v.set_control("arm", "shoulder", 0.5)
        v.set_control("arm", "yaw", -1.0)
        v.advance(30)
        scene = tb.load_scene(path)
        sim = scene.simulator()
        sim.step(10)
        scene.robots["arm"].set_position_target(sim, "shoulder", 0.5, 400.0, 40.0)
        scene.robots["arm"].set_motor(sim, "yaw", -1.0, max_force=20.0)
        sim.step(30)
        assert np.array_equal(v.world.pack(), sim.world.pack())
        v.reset()
        assert {name: s.value for (_r, name), s in v.control_sliders.items()} == {"yaw": 1.5, "shoulder": 1.2, "elbow": 0.9}
    finally:
        v.stop()


def test_the_camera_folder_shows_the_scenes_camera_image():
    """A scene's camera (examples/gripper.toml's "side") is shown as ``Camera.capture`` makes it at
    the current state: the colour image itself; the depth as grey, nearer brighter (255 the
    nearest, 55 the farthest seen), nothing seen black."""
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "gripper.toml"
    v = live(path, port=free_port(), play=False)
    try:
        assert list(v.cameras) == ["side"] and v.camera_frame() is None and not v.camera_image.visible
        v.camera_dropdown.value = "side"
        v.step_frame(3)
        image = v.cameras["side"].capture(v.world)
        assert v.camera_image.visible and np.array_equal(v.camera_image.image, image.rgb)
        v.camera_kind.value = "depth"
        grey = v.camera_image.image[..., 0]
        seen = np.isfinite(image.depth)
        assert seen.any() and (~seen).any() and np.all(grey[~seen] == 0)
        d, g = image.depth[seen], grey[seen].astype(int)
        assert g[np.argmin(d)] == 255 and g[np.argmax(d)] == 55
        order = np.argsort(d, kind="stable")
        assert np.all(np.diff(g[order]) <= 0)  # farther never brighter
    finally:
        v.stop()


def test_playing_never_runs_ahead_of_real_time(scene_file):
    v = live(scene_file, port=free_port(), play=False)
    try:
        v.speed_slider.value = 0.5
        started = time.monotonic()
        v.play()
        time.sleep(1.0)
        v.pause()
        wall = time.monotonic() - started
        t = v.world.t
        assert 0.0 < t <= 0.5 * wall + MAX_LAG_S + v.sim.dt, (t, wall)
        assert np.array_equal(v.world.pack(), plain_state(scene_file, v.sim.step_index))
        stopped_at = v.sim.step_index
        time.sleep(0.2)
        assert v.sim.step_index == stopped_at  # paused: no steps
    finally:
        v.stop()


def blowing_up():
    world = tb.World(gravity=(0, 0, 0))
    world.add_body(tb.Sphere(0.1), mass=1.0)
    world.add_force(tb.CustomForce(lambda t, body: ((1e308 if t > 0.05 else 0.0, 0, 0), (0, 0, 0))))
    return tb.Simulator(world, dt=1 / 240)


def test_a_blow_up_pauses_the_run_with_its_line():
    v = live(blowing_up, port=free_port(), play=False)
    try:
        v.advance(240)
        assert v.error is not None and v.error.startswith("body 'body0': non-finite"), v.error
        assert not v.playing and v.world.t < 0.06 and np.all(np.isfinite(v.world.pack()))
        assert "**Stopped:**" in v.time_text.content
        v.play()
        assert not v.playing  # stays paused until Reset
        v.reset()
        assert v.error is None and v.world.t == 0.0
    finally:
        v.stop()


def test_bad_input_is_one_input_error(tmp_path):
    (tmp_path / "run.npz").write_bytes(b"")
    with pytest.raises(InputError, match="without --live"):
        live(tmp_path / "run.npz", port=0)
    with pytest.raises(InputError, match="file not found"):
        live(tmp_path / "none.toml", port=0)
    with pytest.raises(InputError, match="Simulator or a Scene"):
        live(lambda: 42, port=0)
    with pytest.raises(InputError, match="scene file or a function"):
        live(42, port=0)


@pytest.mark.parametrize("case", ["npz", "missing", "bad_scene", "out_without_live"])
def test_cli_live_bad_input_is_one_line_exit_2(case, tmp_path, capsys):
    (tmp_path / "t.npz").write_bytes(b"")
    (tmp_path / "bad.toml").write_text("[[bodies]]\nname = 'a'\nshape = { type = 'sphere', radius = -1 }\nmass = 1\n")
    target = {"npz": "t.npz", "missing": "nope.toml", "bad_scene": "bad.toml", "out_without_live": "t.npz"}[case]
    flags = ["--out", str(tmp_path / "o")] if case == "out_without_live" else ["--live"]
    status = main(["view", str(tmp_path / target), *flags, "--no-browser", "--port", "0"])
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert status == 2 and len(lines) == 1 and lines[0].startswith("tumble: error: "), err
    assert (target if case != "out_without_live" else "--out") in lines[0] and "Traceback" not in err
    if case == "bad_scene":
        assert "radius" in lines[0]


def test_cli_live_serves_and_runs(scene_file, capsys):
    port = free_port()
    seen = {}

    def wait():
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=5) as r:
            seen["status"] = r.status

    args = argparse.Namespace(target=str(scene_file), host="127.0.0.1", port=port, no_browser=True, live=True, out=None)
    assert cmd_view(args, wait=wait) == 0
    out = capsys.readouterr().out
    assert seen["status"] == 200
    assert f"scene.toml: 3 bodies, live, 0.00416667 s steps at http://127.0.0.1:{port}/" in out


def test_a_click_in_the_browser_pushes_the_body_under_the_mouse(browser, scene_file):
    v = live(scene_file, port=free_port(), play=False)
    page = browser.new_page(viewport=VIEWPORT)
    problems = []
    page.on("console", lambda m: problems.append(f"console {m.type}: {m.text}") if m.type == "error" else None)
    page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
    try:
        page.goto(v.url)
        page.wait_for_selector("canvas", timeout=30_000)
        client = wait_for(lambda: next(iter(v.server.get_clients().values()), None), 30)
        assert client is not None, "the page never connected to the viewer"
        assert wait_for(lambda: client.camera.update_timestamp != 0.0, 30), "the client never reported its camera"
        page.add_style_tag(content=CANVAS_ONLY_CSS)
        assert camera_settled(client.camera, 30), "the client's camera never settled"
        i = v.world.index_of("box")
        u, w_ = project(client.camera, v.world.x[i], VIEWPORT["width"], VIEWPORT["height"])
        v.click_dropdown.value = "push"
        P0 = v.world.P[i].copy()
        page.mouse.click(u, w_)
        assert wait_for(lambda: not np.array_equal(v.world.P[i], P0), 10), "the click did not push the box"
        dP = v.world.P[i] - P0
        # the push is m * speed along the click's ray, which runs from the camera through the box
        assert abs(np.linalg.norm(dP) - 2.0 * v.push_speed_slider.value) < 1e-9
        ray = v.world.x[i] - np.asarray(client.camera.position)
        assert dP @ ray / (np.linalg.norm(dP) * np.linalg.norm(ray)) > 0.99
        assert v.selected == i
        # grab mode: a click on the ball holds it by the point clicked, with a handle to drag
        ball = v.world.index_of("ball")
        v.click_dropdown.value = "grab"
        page.mouse.click(*project(client.camera, v.world.x[ball], VIEWPORT["width"], VIEWPORT["height"]))
        assert wait_for(lambda: v.grabbed is not None and v.grab_handle is not None, 10), "the click did not grab the ball"
        assert v.grabbed[0] == ball and v.grab_handle is not None and v.release_button.visible
        anchor = np.asarray(v.grabbed[1].anchor_b)
        assert abs(np.linalg.norm(anchor - v.world.x[ball]) - 0.2) < 1e-9  # on the ball's surface
    finally:
        page.close()
        v.stop()
    assert not [p for p in problems if not any(b in p for b in BENIGN_CONSOLE_ERRORS)], problems


def test_a_pinned_body_holds_where_it_is_and_unpinned_falls_again(paused, scene_file):
    """Pin mode (``pin``, a click in "pin" mode): the box pinned in mid-fall is made fixed
    (``World.set_body_type``) and stays where it was to the bit; a second click lets it go, at rest,
    with its 2 kg, and it falls again (its height drops). The ground (fixed from the start) is not
    pinnable: a click on it does nothing, a call is one InputError. "Back to mark" from a moment
    before the pin gives the plain run's bits again (the snapshot puts the box's type back), and
    the saved take does not count the box as fixed (it moved)."""
    v = paused
    w = v.world
    box = w.index_of("box")
    v.mark()
    v.step_frame(1)
    assert v.click_ray(w.x[box] + np.array([0.0, 0.0, 3.0]), (0, 0, -1), "pin") == box
    assert w.body_type(box) == "fixed"
    held = w.x[box].copy()
    v.step_frame(3)
    assert np.array_equal(w.x[box], held)
    assert v.click_ray(w.x[box] + np.array([0.0, 0.0, 3.0]), (0, 0, -1), "pin") == box
    assert w.body_type(box) == "dynamic" and w.mass[box] == 2.0
    v.step_frame(3)
    assert w.x[box, 2] < held[2]
    assert v.click_ray((0, 3, 1), (0, 0, -1), "pin") is None and w.body_type("ground") == "fixed"
    with pytest.raises(InputError, match="not dynamic when the scene started"):
        v.pin("ground")
    assert v.trajectory().fixed[box] == np.False_
    v.back_to_mark()
    v.advance(30)
    assert np.array_equal(v.world.pack(), plain_state(scene_file, 30))


def test_a_removed_body_is_hidden_and_passed_through_and_back_to_mark_puts_it_back(paused, scene_file):
    """Remove mode (``remove``, a click in "remove" mode): the box clicked is taken out
    (``World.set_enabled``): hidden (``body_shown``), held where it was to the bit, and no longer hit
    by a second click's ray (it reaches the ground: nothing is removed); the take records it out
    from the next frame (``enabled_changes``). The ground is not removable (a click does nothing, a
    call is one InputError). "Back to mark" from before the removal gives the plain run's bits."""
    v = paused
    w = v.world
    box = w.index_of("box")
    v.mark()
    v.step_frame(1)
    assert v.click_ray(w.x[box] + np.array([0.0, 0.0, 3.0]), (0, 0, -1), "remove") == box
    assert not w.body("box").enabled and not v.body_shown(box)
    held = w.x[box].copy()
    v.step_frame(3)
    assert np.array_equal(w.x[box], held)
    assert v.click_ray(held + np.array([0.0, 0.0, 3.0]), (0, 0, -1), "remove") is None
    with pytest.raises(InputError, match="a plane cannot be disabled"):
        v.remove("ground")
    changes = v.trajectory().enabled_changes
    assert changes.tolist() == [[2, box, 0]]
    v.back_to_mark()
    assert w.body("box").enabled and v.body_shown(box)
    v.advance(30)
    assert np.array_equal(v.world.pack(), plain_state(scene_file, 30))
