"""Camera images by ray casting (``tb.Camera``): checked against the geometry they measure.

A pixel is one exact ray, so its depth is compared with closed forms (a sphere's and a plane's
distance along the ray; the pinhole projection of the points back onto their pixels) to
round-off (1e-12 m at metres); the set of pixels that see a sphere with the closed-form ray-sphere
test, every ray but those within 1e-9 of grazing it. Where it is the image of a mounted camera,
against a world camera put at the same pose.
"""

import math

import numpy as np
import pytest

import tumble as tb
from tumble.camera import SKY
from tumble.visual import FIXED_COLOR, PALETTE


def _scene():
    world = tb.World(gravity=(0, 0, -9.81))
    world.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    ball = world.add_body(tb.Sphere(radius=0.5), mass=1.0, position=(0.1, -0.2, 0.5))
    world.add_body(tb.Box(size=(0.4, 0.4, 0.4)), mass=1.0, position=(0.8, 0.6, 0.2), euler_deg=(0, 0, 30))
    return world, ball


def test_a_sphere_seen_exactly():
    world, ball = _scene()
    centre, r = np.array([0.1, -0.2, 0.5]), 0.5
    cam = tb.Camera(position=(3.0, 0.5, 1.5), target=centre, width=81, height=61, fov_deg=40)
    img = cam.capture(world)
    c, axes, d = cam.rays(world)
    # the closed form: the ray o + t d meets the sphere where |o + t d - centre| = r
    oc = c - centre
    b = d @ oc
    disc = b * b - (oc @ oc - r * r)
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    hits_ball = img.body == ball.index
    clear = np.abs(disc) > 1e-9
    np.testing.assert_array_equal(hits_ball[clear], (disc > 0)[clear])
    np.testing.assert_allclose(img.distance[hits_ball], t[hits_ball], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(img.point[hits_ball] - centre, axis=1), r, atol=1e-12)
    # the middle pixel looks straight at the centre (odd sizes): depth = |c - centre| - r
    assert img.depth[30, 40] == pytest.approx(np.linalg.norm(c - centre) - r, abs=1e-12)
    np.testing.assert_allclose(img.normal[hits_ball], (img.point[hits_ball] - centre) / r, atol=1e-12)


def test_depth_is_z_in_the_camera_frame_and_points_project_back_onto_their_pixels():
    """Looking straight down at the ground from 5 m: every pixel's depth is 5 and its range
    5 / cos(angle off the axis); the points, taken into the camera frame and through K, land on
    their pixels' centres."""
    world = tb.World()
    world.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    cam = tb.Camera(position=(0.3, -0.2, 5.0), target=(0.3, -0.2, 0.0), up=(0, 1, 0), width=64, height=48,
                    fov_deg=70)
    img = cam.capture(world)
    assert (img.body == 0).all()
    np.testing.assert_allclose(img.depth, 5.0, atol=1e-12)
    _, axes, d = cam.rays(world)
    np.testing.assert_allclose(img.distance, 5.0 / (d @ axes[:, 2]), atol=1e-12)
    local = img.point_cloud("camera")
    uvw = local @ img.intrinsics.T
    u, v = uvw[:, 0] / uvw[:, 2], uvw[:, 1] / uvw[:, 2]
    cols, rows = np.meshgrid(np.arange(64) + 0.5, np.arange(48) + 0.5)
    np.testing.assert_allclose(u, cols.ravel(), atol=1e-9)
    np.testing.assert_allclose(v, rows.ravel(), atol=1e-9)
    # image up is world +y: the top row sees larger y than the bottom row; x grows to the right
    assert img.point[0, 0, 1] > img.point[-1, 0, 1] and img.point[0, -1, 0] > img.point[0, 0, 0]


def test_segmentation_and_colours():
    world, ball = _scene()
    img = tb.Camera(position=(3.0, 0.0, 1.5), target=(0.0, 0.0, 0.5), width=80, height=60).capture(world)
    assert set(np.unique(img.body)) == {-1, 0, 1, 2}
    np.testing.assert_array_equal(img.rgb[img.body == -1], np.broadcast_to(SKY, img.rgb[img.body == -1].shape))
    assert np.isinf(img.depth[img.body == -1]).all() and np.isnan(img.point[img.body == -1]).all()
    # shaded body colours: the ball (body 1, after the fixed ground) has body 1's colour in every
    # view (visual.body_color: the palette by body index), the ground grey
    lit = img.rgb[img.body == ball.index].astype(float)
    ratio = lit / np.array(PALETTE[ball.index], dtype=float)
    assert np.allclose(ratio, ratio[:, :1], atol=0.02) and (ratio <= 1.0 + 1e-9).all()
    grey = img.rgb[img.body == 0].astype(float) / np.array(FIXED_COLOR, dtype=float)
    assert np.allclose(grey, grey[:, :1], atol=0.02)
    assert len(img.point_cloud()) == int((img.body >= 0).sum())


def test_a_mounted_camera_moves_with_its_body_and_does_not_see_it():
    """A camera on the box (its position and target in the box's frame) after the box is moved and
    turned gives the image of a world camera put at the same pose; the box itself is not seen
    unless asked."""
    world, ball = _scene()
    box = world.body(2)
    mounted = tb.Camera(body=box, position=(0.0, 0.0, 0.1), target=(-1.0, 0.0, 0.2), up=(0, 0, 1), width=40,
                        height=30)
    box.x = (1.5, 0.4, 0.7)
    turn = math.radians(25)  # its -x (the camera's line of sight) towards the ball
    box.q = (math.cos(turn / 2), 0.0, 0.0, math.sin(turn / 2))
    world.update_derived()
    R = np.asarray(box.R)
    origin = np.asarray(box.x) - R @ np.asarray(box.com_offset)
    fixed = tb.Camera(position=origin + R @ np.array([0.0, 0.0, 0.1]), target=origin + R @ np.array([-1.0, 0.0, 0.2]),
                      up=R @ np.array([0.0, 0.0, 1.0]), width=40, height=30)
    a = mounted.capture(world)
    b = fixed.capture(world)
    assert box.index not in set(np.unique(a.body))
    np.testing.assert_array_equal(a.body[b.body != box.index], b.body[b.body != box.index])
    seen = (a.body >= 0) & (b.body != box.index)
    np.testing.assert_allclose(a.depth[seen], b.depth[seen], atol=1e-12)
    assert ball.index in set(np.unique(a.body))
    inside = tb.Camera(body=box, exclude_body=False, position=(0.0, 0.0, 0.5), target=(0.0, 0.0, 0.0),
                       up=(1, 0, 0), width=8, height=6).capture(world)
    # looking down at its own top face (0.2 m above the box's centre) from 0.5 m above the centre
    assert (inside.body[1:5, 2:6] == box.index).all()
    np.testing.assert_allclose(inside.depth[1:5, 2:6], 0.3, atol=1e-12)


@pytest.mark.parametrize("kwargs, key", [
    ({"width": 0}, "width"),
    ({"height": 2.5}, "height"),
    ({"fov_deg": 180}, "fov_deg"),
    ({"position": (0, 0, float("nan"))}, "position"),
    ({"target": (3.0, 0.0, 1.5)}, "target"),
    ({"up": (-3.0, 0.0, -1.0)}, "up"),
    ({"max_distance": 0}, "max_distance"),
])
def test_bad_cameras_are_one_line(kwargs, key):
    with pytest.raises(tb.InputError) as err:
        tb.Camera(**kwargs)
    assert err.value.key == key and "\n" not in str(err.value)


CAMERA_SCENE = """
[simulation]
duration = 0.5
frame_rate = 10

[[bodies]]
name = "ground"
shape = { type = "plane" }
fixed = true

[[bodies]]
name = "ball"
shape = { type = "sphere", radius = 0.3 }
mass = 1.0
position = [0.2, -0.1, 2.0]

[[cameras]]
name = "top"
position = [0, 0, 5]
target = [0, 0, 0]
up = [1, 0, 0]
fov_deg = 50
width = 40
height = 30
"""


def _ray_depths(cam, world, center, radius):
    """Closed-form depth (z in the camera frame) of each pixel's ray against a ball at ``center`` and
    the ground plane z = 0, written without World.ray_cast: (H, W) depth, (H, W) which (1 ball, 0 ground)."""
    c, axes, d = cam.rays(world)
    oc = np.asarray(center) - c
    b = d @ oc
    disc = b**2 - (oc @ oc - radius**2)
    t_ball = np.where(disc >= 0, b - np.sqrt(np.maximum(disc, 0.0)), np.inf)
    t_ground = np.where(d[..., 2] < 0, -c[2] / d[..., 2], np.inf)
    t = np.minimum(t_ball, t_ground)
    return t * (d @ axes[:, 2]), (t_ball < t_ground).astype(int)


def test_scene_cameras_capture_every_frame_of_a_run(tmp_path):
    # tumble run --images: each [[cameras]] entry at every recorded frame, posed from the trajectory.
    # Compared with the closed form of each pixel's ray against the falling ball (its centre from the
    # trajectory) and the ground: the depth to 1e-5 m (the file keeps float32, whose rounding is
    # under 3e-7 m at 5 m) and the segmentation exactly, at every frame.
    import imageio.v3 as iio

    from tumble.cli import main

    scene_file = tmp_path / "fall.toml"
    scene_file.write_text(CAMERA_SCENE)
    out = tmp_path / "out"
    assert main(["run", str(scene_file), "--out", str(out), "--images", "--no-progress"]) == 0
    data = np.load(out / "images" / "top.npz")
    traj = tb.load_trajectory(out / "trajectory.npz")
    frames = traj.position.shape[0]
    assert frames == 6 and data["depth"].shape == (6, 30, 40) and data["body"].dtype == np.int32
    assert sorted(p.name for p in (out / "images" / "top").iterdir()) == [f"rgb_{f:05d}.png" for f in range(6)]
    assert iio.imread(out / "images" / "top" / "rgb_00003.png").shape == (30, 40, 3)
    scene = tb.load_scene(scene_file)
    cam = scene.cameras["top"]
    ball = scene.world.index_of("ball")
    assert traj.position[-1, ball, 2] < 1.0  # it fell during the run
    for f in range(frames):
        depth, which = _ray_depths(cam, scene.world, traj.position[f, ball], 0.3)
        np.testing.assert_allclose(data["depth"][f], depth, rtol=0, atol=1e-5)
        np.testing.assert_array_equal(data["body"][f], np.where(which == 1, ball, scene.world.index_of("ground")))
    np.testing.assert_allclose(data["intrinsics"], cam.intrinsics)
    np.testing.assert_allclose(data["time"], traj.time)
    # run again shorter over the same folder (--force): only the new run's frames are left
    assert main(["run", str(scene_file), "--out", str(out), "--images", "--no-progress", "--force",
                 "--duration", "0.2"]) == 0
    assert sorted(p.name for p in (out / "images" / "top").iterdir()) == [f"rgb_{f:05d}.png" for f in range(3)]
    assert np.load(out / "images" / "top.npz")["depth"].shape[0] == 3


@pytest.mark.parametrize("old, new, problem", [
    ('width = 40', 'width = 4.5', "cameras[0].width: expected a whole number of pixels"),
    ('name = "top"', 'name = "top"\nbody = "nope"', "cameras[0].body: unknown body 'nope'"),
    ('name = "top"', 'name = "top"\nzoom = 2', "cameras[0].zoom: unknown key"),
    ('name = "top"\n', '', "cameras[0]: missing key 'name'"),
    ('up = [1, 0, 0]', 'up = [0, 0, 1]', "cameras[0].up: up is along the line of sight"),
    ('fov_deg = 50', 'fov_deg = 190', "cameras[0].fov_deg: must be a number of degrees between 0 and 180"),
    ('name = "top"', 'name = "top"\ntrack = "point"', "cameras[0].track: a tracking camera needs the body"),
])
def test_bad_scene_cameras_exit_2_with_one_line(tmp_path, capsys, old, new, problem):
    from tumble.cli import main

    scene_file = tmp_path / "bad.toml"
    assert old in CAMERA_SCENE
    scene_file.write_text(CAMERA_SCENE.replace(old, new, 1))
    assert main(["validate", str(scene_file)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and problem in err[0] and "bad.toml" in err[0], err


def test_images_without_cameras_is_one_line(tmp_path, capsys):
    from tumble.cli import main

    scene_file = tmp_path / "nocam.toml"
    scene_file.write_text(CAMERA_SCENE.split("[[cameras]]")[0])
    assert main(["run", str(scene_file), "--out", str(tmp_path / "o"), "--images", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--images: the scene has no [[cameras]] to capture" in err[0]
    assert not (tmp_path / "o" / "trajectory.npz").exists()


def test_an_mjcf_model_s_cameras_are_its_scene_s(tmp_path):
    # tumble run MODEL.xml --images: the model's <camera>s (robot.cameras) are the scene's cameras,
    # named "MODEL/CAMERA", captured as [[cameras]] ones: a fixed camera 2 m above a box on the
    # floor sees the box's top at depth 2 - 0.2 (the box is 0.2 m high, resting on z = 0) at the
    # image's centre (measured 4.4e-6 m off: its settling into the contact and float32; bound
    # 1e-4 m), and the floor at 2 m in the corners.
    from tumble.cli import main

    model = tmp_path / "box.xml"
    model.write_text("""
<mujoco model="boxcam">
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <camera name="top" pos="0 0 2" xyaxes="1 0 0 0 1 0" fovy="40" resolution="32 24"/>
    <body name="box" pos="0 0 0.1"><freejoint/><geom type="box" size="0.1 0.1 0.1" mass="1"/></body>
  </worldbody>
</mujoco>
""")
    scene = tb.load_scene(model)
    assert list(scene.cameras) == ["boxcam/top"]
    out = tmp_path / "out"
    assert main(["run", str(model), "--out", str(out), "--images", "--duration", "0.25", "--no-progress"]) == 0
    data = np.load(out / "images" / "boxcam" / "top.npz")
    assert data["depth"].shape[1:] == (24, 32)
    assert (out / "images" / "boxcam" / "top" / "rgb_00000.png").exists()
    np.testing.assert_allclose(data["depth"][:, 11:13, 15:17], 1.8, atol=1e-4)
    np.testing.assert_allclose(data["depth"][:, 0, 0], 2.0, atol=1e-9)
