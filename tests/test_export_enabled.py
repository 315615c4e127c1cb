"""A body out of the simulation (``World.set_enabled``) is hidden wherever a trajectory is drawn
or exported, at the frames it is disabled (``Trajectory.enabled`` False), and only there.

The run (module fixture ``example``): a ground, a fixed shelf that is disabled at t = 0.5 s, a
box on it that falls when it goes, and a ball added disabled that is enabled at t = 1 s; 21
frames at 10 fps. Its enabled flags are checked first (shelf absent from frame 6 on, ball absent
up to frame 10), then each view against them:

* glTF: the shelf's and the ball's scale channel, read back with pygltflib (not our writer), is
  (0, 0, 0) exactly at the disabled frames and (1, 1, 1) at the others, STEP; no other body has
  one, and a run with no disabled body gives the same bytes as before (its file with
  ``enabled_changes`` None and with an empty change list are equal, and hold no scale at all);
  the Khronos validator accepts the file.
* USD: the body Xforms' ``visibility`` at every time code (pxr, and USD's own
  ``ComputeVisibility`` of the mesh) is ``invisible`` exactly at the disabled frames;
  ``save_usd`` of a world with a disabled body writes it hidden and says so.
* video: a frame where the shelf is disabled has none of its colour, the same frame drawn as if
  it were enabled has it, and a frame where it is enabled is the same image either way.
* framing (web page, video, viewer): moving a body far off at its disabled frames changes none.
* the replay viewer and the live viewer: a disabled body's row is scaled to 0 (``body_shown``)
  and back to 1 when it is enabled again.
"""

from __future__ import annotations

import dataclasses
import json
import struct

import numpy as np
import pytest

import tumble as tb
from tumble.export import export_gltf, export_usd
from tumble.export.gltf import glb_bytes, gltf_document

from tests.test_export import gltf_validator  # the fixture: the Khronos validator, installed if need be
from tests.test_export import load_glb, read_accessor

__all__ = ["gltf_validator"]  # the fixture, shared

SHELF, BALL, BOX, GROUND = 1, 3, 2, 0
SHELF_GONE, BALL_BACK = 6, 11  # the first frame the shelf is absent, the first the ball is present


def make_example():
    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    w.add_body(tb.Box(size=(1, 1, 0.1)), fixed=True, position=(0, 0, 1), name="shelf", mass=5.0)
    w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 1.15), name="box")
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(3, 0, 2), name="ball", enabled=False)

    def ctrl(sim):
        if abs(sim.world.t - 0.5) < 1e-9:
            sim.world.body("shelf").enabled = False
        if abs(sim.world.t - 1.0) < 1e-9:
            sim.world.body("ball").enabled = True

    return tb.Simulator(w, controller=ctrl).run(2.0, frame_rate=10)


@pytest.fixture(scope="module")
def example():
    traj = make_example()
    frames = np.arange(len(traj.time))
    expected = np.ones((21, 4), dtype=bool)
    expected[:, SHELF] = frames < SHELF_GONE
    expected[:, BALL] = frames >= BALL_BACK
    np.testing.assert_array_equal(traj.enabled, expected)  # the run the tests below are about
    return traj


@pytest.fixture(scope="module")
def plain():
    """The same bodies, none ever disabled."""
    w = tb.World()
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    w.add_body(tb.Box(size=(1, 1, 0.1)), fixed=True, position=(0, 0, 1), name="shelf", mass=5.0)
    w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 1.15), name="box")
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(3, 0, 2), name="ball")
    traj = tb.Simulator(w).run(1.0, frame_rate=10)
    assert traj.enabled_changes is None
    return traj


def far_while_disabled(traj):
    """``traj`` with every body moved 100 m off along x at the frames it is disabled (hidden there)."""
    position = np.array(traj.position, copy=True)
    position[~traj.enabled] += (100.0, 0.0, 0.0)
    return dataclasses.replace(traj, position=position)


# ---------------------------------------------------------------------- glTF


def channels_of(gltf, blob, node):
    """{path: (interpolation, times, values)} of the animation channels of ``node``."""
    out = {}
    for anim in gltf.animations:
        for ch in anim.channels:
            if ch.target.node == node:
                s = anim.samplers[ch.sampler]
                out[ch.target.path] = (s.interpolation, read_accessor(gltf, blob, s.input), read_accessor(gltf, blob, s.output))
    return out


def test_glb_scale_is_zero_exactly_at_the_disabled_frames(example, tmp_path):
    gltf, blob = load_glb(export_gltf(example, tmp_path / "example.glb"))
    root = gltf.nodes[gltf.scenes[gltf.scene].nodes[0]]
    frames = np.arange(len(example.time))
    for i, present in ((SHELF, frames < SHELF_GONE), (BALL, frames >= BALL_BACK)):
        node = gltf.nodes[root.children[i]]
        assert node.name == str(example.names[i]) and node.extras["hidden_frames"] is True
        channels = channels_of(gltf, blob, root.children[i])
        how, t, scale = channels["scale"]
        assert how == "STEP"  # pops in and out, never grows between two frames
        np.testing.assert_array_equal(t, example.time.astype(np.float32))
        np.testing.assert_array_equal(scale, np.repeat(present.astype(np.float32)[:, None], 3, axis=1))
        # the static pose (what a reader that plays nothing shows) is frame 0's: the ball hidden
        assert (node.scale == [0.0, 0.0, 0.0]) if i == BALL else node.scale in (None, [1.0, 1.0, 1.0])
    # the shelf stays fixed: no translation or rotation track; the ball moves once it is back
    assert set(channels_of(gltf, blob, root.children[SHELF])) == {"scale"}
    assert set(channels_of(gltf, blob, root.children[BALL])) == {"translation", "rotation", "scale"}
    for i in (GROUND, BOX):  # present throughout: no scale
        assert "scale" not in channels_of(gltf, blob, root.children[i])
        assert gltf.nodes[root.children[i]].scale in (None, [1.0, 1.0, 1.0])


def test_glb_without_disabled_bodies_is_byte_identical_and_has_no_scale(plain, example):
    data = glb_bytes(*gltf_document(plain))
    # an empty change list (no body ever disabled) is the same file as none at all
    empty = dataclasses.replace(plain, enabled_changes=np.zeros((0, 3), dtype=np.int64))
    assert glb_bytes(*gltf_document(empty)) == data
    text = json.loads(data[20:20 + struct.unpack_from("<I", data, 12)[0]])
    assert all(ch["target"]["path"] != "scale" for a in text["animations"] for ch in a["channels"])
    assert not any("scale" in node or "hidden_frames" in node.get("extras", {}) for node in text["nodes"])
    # the run with disabled bodies, its changes taken away: the same tracks and no scale
    doc, _ = gltf_document(dataclasses.replace(example, enabled_changes=None))
    assert [ch["target"]["path"] for ch in doc["animations"][0]["channels"]] == ["translation", "rotation"] * 2
    doc_hidden, _ = gltf_document(example)
    paths = [(ch["target"]["node"] - 1, ch["target"]["path"]) for ch in doc_hidden["animations"][0]["channels"]]
    assert paths == [(SHELF, "scale"), (BOX, "translation"), (BOX, "rotation"),
                     (BALL, "translation"), (BALL, "rotation"), (BALL, "scale")]


def test_glb_with_hidden_bodies_passes_the_khronos_validator(example, tmp_path, gltf_validator):
    import subprocess

    path = export_gltf(example, tmp_path / "example.glb")
    done = subprocess.run(gltf_validator + [str(path)], capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    issues = json.loads(done.stdout)["reports"][str(path)]["issues"]
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]


# ---------------------------------------------------------------------- USD


def test_usd_visibility_is_invisible_exactly_at_the_disabled_frames(example, tmp_path):
    pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(export_usd(example, tmp_path / "example.usda")))
    bodies = stage.GetDefaultPrim().GetChildren()
    for i, prim in enumerate(bodies):
        assert prim.GetCustomDataByKey("tumble:name") == str(example.names[i])
        visibility = UsdGeom.Imageable(prim).GetVisibilityAttr()
        if example.enabled[:, i].all():
            assert not visibility.HasAuthoredValue()  # no opinion: as before bodies could be disabled
            continue
        assert visibility.GetNumTimeSamples() > 0
        mesh = UsdGeom.Imageable(prim.GetChild("mesh"))
        for f, present in enumerate(example.enabled[:, i]):
            want = UsdGeom.Tokens.inherited if present else UsdGeom.Tokens.invisible
            assert visibility.Get(f) == want, (i, f)
            assert visibility.Get(f + 0.5) == want  # held until the next frame: no fading
            assert mesh.ComputeVisibility(Usd.TimeCode(f)) == (UsdGeom.Tokens.inherited if present else UsdGeom.Tokens.invisible)


def test_save_usd_writes_a_disabled_body_hidden_and_names_it(tmp_path):
    pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom

    w = tb.World()
    w.add_body(tb.Box(size=(1, 1, 0.1)), fixed=True, name="shelf")
    w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(0, 0, 1), name="ball", enabled=False)
    with pytest.warns(tb.TumbleWarning, match="disabled bodies"):
        tb.save_usd(w, tmp_path / "world.usda")
    stage = Usd.Stage.Open(str(tmp_path / "world.usda"))
    assert UsdGeom.Imageable(stage.GetPrimAtPath("/World/ball")).ComputeVisibility() == UsdGeom.Tokens.invisible
    assert UsdGeom.Imageable(stage.GetPrimAtPath("/World/shelf")).ComputeVisibility() == UsdGeom.Tokens.inherited
    w.add_force(tb.Switch("ball", enabled=True, time=1.0))  # a time the schema has no place for
    with pytest.warns(tb.TumbleWarning, match=r"switched in or out of the simulation \(Switch records\)") as seen:
        tb.save_usd(w, tmp_path / "switched.usda")
    assert "forces other than gravity" not in str(seen[0].message)


# ---------------------------------------------------------------------- framing


def test_disabled_frames_are_left_out_of_the_framing(example):
    from tumble.export.html import camera_view

    far = far_while_disabled(example)
    assert camera_view(far) == camera_view(example)
    # and they are the only ones left out: a body far off where it is enabled is framed
    moved = dataclasses.replace(example, position=example.position + np.where(example.enabled, 100.0, 0.0)[..., None])
    assert camera_view(moved) != camera_view(example)
    pytest.importorskip("pyvista")
    from tumble.render import camera_at

    for k in (0, 15):
        a, b = camera_at(far, k, 64, 48), camera_at(example, k, 64, 48)
        np.testing.assert_array_equal(a.position, b.position)
        np.testing.assert_array_equal(a.focal_point, b.focal_point)


# ---------------------------------------------------------------------- video


def test_a_frame_where_a_body_is_disabled_does_not_draw_it(example):
    pytest.importorskip("pyvista")
    from tumble.render import render_frame

    def red(img):  # the shelf's colour, lit or shaded (as tests/test_render.py's red_mask)
        r, g, b = (img[..., c].astype(int) for c in range(3))
        return (r > 40) & (r > 2 * g + 20) & (r > 2 * b + 20)

    # the same run with the shelf never disabled (the ball's changes kept: the framing, ground and
    # grid included, is the same, the shelf being fixed)
    changes = example.enabled_changes[example.enabled_changes[:, 1] != SHELF]
    shown = dataclasses.replace(example, enabled_changes=changes)
    kw = dict(width=96, height=72, camera="follow:shelf", colors={"shelf": (255, 0, 0)}, antialias=False)
    gone, there = render_frame(example, 12, **kw), render_frame(shown, 12, **kw)
    assert red(there).sum() > 100  # the shelf fills much of this view...
    assert red(gone).sum() == 0  # ...and is not drawn where it is disabled
    assert (gone != there).any()
    # a frame where it is enabled: the same image either way
    np.testing.assert_array_equal(render_frame(example, 3, **kw), render_frame(shown, 3, **kw))


# ---------------------------------------------------------------------- viewers


def test_the_replay_viewer_hides_a_body_at_its_disabled_frames(example):
    pytest.importorskip("viser")
    from tumble.viewer import view

    v = view(example, port=0, play=False)
    try:
        for k in range(len(example.time)):
            v.set_frame(k)
            assert [v.body_shown(i) for i in range(4)] == list(example.enabled[k]), k
        v.set_frame(3)
        assert not v.body_shown(BALL) and v.body_shown(SHELF)
        assert v.axes_node.batched_scales[BALL] == 0 and v.axes_node.batched_scales[SHELF] > 0
        center, extent = v.center, v.extent
    finally:
        v.stop()
    far = view(far_while_disabled(example), port=0, play=False)  # framed as before (test above)
    try:
        np.testing.assert_array_equal(far.center, center)
        assert far.extent == extent
    finally:
        far.stop()


def test_the_live_viewer_hides_a_disabled_body_and_shows_it_again():
    pytest.importorskip("viser")
    from tumble.viewer import live

    def make():
        w = tb.World()
        w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
        w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), mass=1.0, position=(0, 0, 0.5), name="box")
        w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(1, 0, 0.5), name="ball", enabled=False)
        return tb.Simulator(w)

    v = live(make, port=0, play=False)
    try:
        box, ball = v.world.index_of("box"), v.world.index_of("ball")
        assert v.body_shown(box) and not v.body_shown(ball)  # added disabled: hidden from the start
        v.world.set_enabled("box", False)
        v.world.set_enabled("ball", True)
        v.step_frame()
        assert not v.body_shown(box) and v.body_shown(ball)
        g = v._group_of[box]
        assert v.mesh_groups[g].handle.batched_scales[v._row_of[box]] == 0.0
        # the ball, back as the dynamic body it was added as, is drawn where it falls
        before = v.body_pose(ball)[0]
        v.step_frame(3)
        after = v.body_pose(ball)[0]
        assert after[2] < before[2] - 0.01
        np.testing.assert_allclose(after, v.world.x[ball], atol=1e-6)
        v.world.set_enabled("box", True)
        v.step_frame()
        assert v.body_shown(box) and v.body_shown(ball)
        v.reset()  # the scene again: the ball hidden again
        assert v.body_shown(box) and not v.body_shown(ball)
    finally:
        v.stop()



def test_the_live_viewer_shows_a_switch_at_a_frames_time_as_the_take_does():
    """A ball put in at t = 0.125 s (frame 3 at 24 per second) by a ``Switch``: the live view at
    that frame shows it, as the recorded run's frame 3 does (``Trajectory.enabled``: the frame at
    a switch's time shows it done). Before, the live view read ``World.disabled``, which the
    switch changes only in the next step: the ball appeared a frame late."""
    pytest.importorskip("viser")
    from tumble.viewer import live

    def make():
        w = tb.World()
        w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
        w.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(1, 0, 0.5), name="ball", enabled=False)
        w.add_force(tb.Switch("ball", enabled=True, time=0.125))
        return tb.Simulator(w, dt=1 / 240)

    take = make().run(duration=0.25, frame_rate=24)
    ball = 1
    assert list(take.enabled[:, ball][:5]) == [False, False, False, True, True]
    v = live(make, port=0, play=False)
    try:
        shown = [v.body_shown(ball)]
        for _ in range(4):
            v.step_frame()
            shown.append(v.body_shown(ball))
        assert shown == list(take.enabled[:5, ball])
    finally:
        v.stop()
