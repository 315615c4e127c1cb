"""tumble.render: headless frames and videos, plots, and the ``render`` / ``plot`` commands.

The known scene: no gravity, a pure red 0.3 m cube ("mover") sliding along +x
at 1 m/s while it turns about z, and a pure blue ball ("other") at rest beside
its path. Frames are small (320 x 240) and runs short, to keep the file fast.
"""

from __future__ import annotations

import re
import subprocess

import numpy as np
import pytest

pytest.importorskip("pyvista")
pytest.importorskip("imageio_ffmpeg")

import imageio.v3 as iio
import imageio_ffmpeg

import tumble as tb
from tumble.cli import main
from tumble.render import Camera, body_colors, camera_at, plot_trajectory, render_frame, render_video
from tumble.render.plots import DPI, FIGSIZE, PLOT_NAMES

W, H = 320, 240
COLORS = {"mover": (255, 0, 0), "other": (0, 0, 255)}


@pytest.fixture(scope="module")
def traj():
    world = tb.World(gravity=(0, 0, 0))
    world.add_body(tb.Box(size=(0.3, 0.3, 0.3)), mass=1.0, position=(-1.0, 0.0, 0.5), velocity=(1.0, 0.0, 0.0),
                   angular_velocity=(0.0, 0.0, 1.0), name="mover")
    world.add_body(tb.Sphere(radius=0.2), mass=1.0, position=(0.0, 1.0, 0.3), name="other")
    return tb.Simulator(world, dt=1 / 240).run(duration=2.0, frame_rate=6)  # 13 frames, 1/6 s apart


@pytest.fixture(scope="module")
def traj_file(traj, tmp_path_factory):
    return traj.save(tmp_path_factory.mktemp("run") / "trajectory.npz")


def read_mp4(path):
    """All frames (n, H, W, 3) of an .mp4, checked to be H.264 in yuv420p.

    Decoded with imageio-ffmpeg's ffmpeg through subprocess.run, which closes its
    pipes: imageio's own reader leaves them to the garbage collector, and the
    ResourceWarning that gives is an error under this project's pytest settings.
    """
    exe = imageio_ffmpeg.get_ffmpeg_exe()
    header = subprocess.run([exe, "-hide_banner", "-i", str(path)], check=False, capture_output=True, text=True).stderr
    found = re.search(r"Video: h264 .*?yuv420p.*?, (\d+)x(\d+)", header)
    assert found, header
    w, h = map(int, found.groups())
    raw = subprocess.run([exe, "-v", "error", "-i", str(path), "-f", "rawvideo", "-pix_fmt", "rgb24", "-"],
                         capture_output=True, check=True).stdout
    assert len(raw) % (w * h * 3) == 0
    return np.frombuffer(raw, np.uint8).reshape(-1, h, w, 3)


def red_mask(img):
    """Pixels whose colour is the mover's: lit or shaded, pure red stays red-dominated.

    Shading scales all channels together (ambient 0.15 keeps the darkest face
    above ~40 of 255) and the specular highlight adds at most ~0.3 white, so
    "red at least twice green and blue plus a margin" holds on every face and
    never on the grey ground, the sky gradient, the blue ball or the text.
    """
    r, g, b = (img[..., c].astype(int) for c in range(3))
    return (r > 40) & (r > 2 * g + 20) & (r > 2 * b + 20)


@pytest.mark.parametrize("k", [0, 6, 12])
def test_body_pixels_are_where_the_trajectory_projects(traj, k):
    img = render_frame(traj, k, W, H, colors=COLORS)
    assert img.shape == (H, W, 3) and img.dtype == np.uint8
    cam = camera_at(traj, k, W, H)
    u, v = cam.project(traj.position[k, 0], W, H)[0]
    # The projected centre of mass lies inside the cube's silhouette: its pixel is the body's colour.
    assert red_mask(img)[int(v), int(u)], f"pixel at the projected centre ({u:.1f}, {v:.1f}) is {img[int(v), int(u)]}"
    # The centroid of the body's pixels is the projection of its centre within 2 px. Not exactly:
    # perspective and the faces that happen to face the camera shift the silhouette's centroid
    # off the projected centre by a fraction of the cube's ~35 px width (measured <= 0.7 px);
    # a wrong camera model, pose or offset moves it by tens of pixels.
    rows, cols = np.nonzero(red_mask(img))
    assert len(rows) > 200  # the cube is ~35 x 40 px; far fewer would mean it is mostly hidden or clipped
    centroid = np.array([cols.mean() + 0.5, rows.mean() + 0.5])  # pixel centres, as project() counts
    assert np.hypot(*(centroid - (u, v))) < 2.0, f"centroid {centroid} vs projection {(u, v)}"
    # The ball: the same check on its own colour (blue dominated), its centre projected with the same camera.
    r, g, b = (img[..., c].astype(int) for c in range(3))
    blue = (b > 40) & (b > 2 * r + 20) & (b > 2 * g + 20)
    bu, bv = cam.project(traj.position[k, 1], W, H)[0]
    assert blue[int(bv), int(bu)]


def test_projection_of_a_known_camera():
    # Independent of the renderer: a camera 10 m back on -y looking at the origin, 90 degree view angle.
    cam = Camera(np.array([0.0, -10.0, 0.0]), np.zeros(3), np.array([0.0, 0.0, 1.0]), 90.0)
    uv = cam.project([[0, 0, 0], [10, 10, 0], [0, 10, 10], [0, -20, 0]], 200, 100)
    # focal length = (H / 2) / tan(45 deg) = 50 px; +x is right, +z is up (row numbers grow downwards).
    np.testing.assert_allclose(uv[:3], [[100, 50], [125, 50], [100, 25]], atol=1e-9)
    assert np.all(np.isnan(uv[3]))  # behind the camera


def test_consecutive_frames_of_a_moving_body_differ(traj):
    a, b = (render_frame(traj, k, W, H) for k in (3, 4))
    changed = np.any(a != b, axis=2)
    # The cube moves 1/6 m, about 5 px: a band of pixels changes, not just the time label (upper left).
    assert changed[H // 8:, :].sum() > 100
    # And the same frame renders the same picture (the off-screen renderer is deterministic).
    np.testing.assert_array_equal(render_frame(traj, 3, W, H), a)


def test_follow_camera_keeps_the_body_in_the_middle(traj):
    for k in (0, 12):
        u, v = camera_at(traj, k, W, H, camera="follow:mover").project(traj.position[k, 0], W, H)[0]
        np.testing.assert_allclose((u, v), (W / 2, H / 2), atol=1e-6)
    img = render_frame(traj, 12, W, H, camera="follow:mover", colors=COLORS)
    assert red_mask(img)[H // 2, W // 2]


def test_video_files_read_back(traj, tmp_path):
    mp4 = render_video(traj, tmp_path / "run.mp4", width=W, height=H, progress=False)
    frames = read_mp4(mp4)
    assert frames.shape == (traj.frame_count, H, W, 3)
    gif = render_video(traj, tmp_path / "run.gif", width=160, height=120, fps=3, progress=False)
    frames = iio.imread(gif, index=None)
    # Another frame rate resamples in time (the video plays in real time): 2 s at 3 fps is 7 frames.
    assert frames.shape[:3] == (7, 120, 160)


def test_antialiasing_softens_the_edges(traj, tmp_path):
    """Super-sampled frames (the default) blend the colours across the box's and sphere's edges:
    fewer hard steps between neighbouring pixels (sum of |RGB differences| above 150) and more
    distinct colours than the same frame rendered with ``antialias=False``; the video option
    reaches the frames (the CLI's --no-antialias file differs from the default one)."""
    steps, colours = {}, {}
    for aa in (True, False):
        img = render_frame(traj, 6, 320, 240, antialias=aa).astype(int)
        d = np.abs(np.diff(img, axis=1)).sum(-1)
        steps[aa] = int((d > 150).sum())
        colours[aa] = len(np.unique(img.reshape(-1, 3), axis=0))
    assert steps[True] < 0.8 * steps[False], steps
    assert colours[True] > 1.5 * colours[False], colours
    sharp, smooth = tmp_path / "sharp.gif", tmp_path / "smooth.gif"
    assert main(["render", str(tmp_path / "t.npz"), "-o", str(sharp)]) == 2  # no trajectory: one-line error
    path = traj.save(tmp_path / "t.npz")
    assert main(["render", str(path), "-o", str(sharp), "--width", "96", "--height", "64", "--fps", "3",
                 "--no-antialias", "--no-progress"]) == 0
    assert main(["render", str(path), "-o", str(smooth), "--width", "96", "--height", "64", "--fps", "3",
                 "--no-progress"]) == 0
    assert not np.array_equal(iio.imread(sharp, index=None), iio.imread(smooth, index=None))


def test_gif_plays_at_24_fps_on_average(traj, tmp_path):
    """A GIF's delays are hundredths of a second: 24 fps (4.17 cs) is written as delays of 4 and
    5 cs whose running sum stays within 5 ms of k / 24 s (a single rounded delay, 4 cs, would play
    at 25 fps: 100 frames end 167 ms early). Read back with Pillow, frame by frame."""
    from PIL import Image

    from tumble.render.video import gif_durations_ms

    durations = gif_durations_ms(100, 24.0)
    assert set(durations) == {40, 50}
    assert np.all(np.abs(np.cumsum(durations) - 1000.0 * np.arange(1, 101) / 24.0) <= 5.0 + 1e-9)
    gif = render_video(traj, tmp_path / "run24.gif", width=64, height=48, fps=24, progress=False)
    with Image.open(gif) as im:
        read = []
        for k in range(im.n_frames):
            im.seek(k)
            read.append(im.info["duration"])
    assert len(read) == 49  # 2 s resampled at 24 fps, as 3 fps gives 7 frames above
    assert set(read) == {40, 50}
    assert sum(read) == pytest.approx(1000.0 * len(read) / 24.0, abs=5.0)


def test_cli_render_and_plot(traj_file, tmp_path, capsys):
    mp4, gif = tmp_path / "out.mp4", tmp_path / "out.gif"
    assert main(["render", str(traj_file), "-o", str(mp4), "--width", "160", "--height", "120", "--no-progress"]) == 0
    assert main(["render", str(traj_file.parent), "-o", str(gif), "--width", "96", "--height", "64", "--fps", "6",
                 "--camera", "follow:other", "--no-progress"]) == 0
    assert read_mp4(mp4).shape == (13, 120, 160, 3)
    assert iio.imread(gif, index=None).shape[:3] == (13, 64, 96)
    plots = tmp_path / "plots"
    assert main(["plot", str(traj_file), "-o", str(plots)]) == 0
    for name in PLOT_NAMES:
        png = iio.imread(plots / name)
        assert png.shape[:2] == (round(FIGSIZE[1] * DPI), round(FIGSIZE[0] * DPI))
        assert png[..., :3].std() > 10  # lines and text, not a blank page
    assert "wrote" in capsys.readouterr().out
    # Nothing is overwritten without --force; with it, it is.
    assert main(["render", str(traj_file), "-o", str(mp4)]) == 2
    assert main(["plot", str(traj_file), "-o", str(plots)]) == 2
    assert main(["plot", str(traj_file), "-o", str(plots), "--force"]) == 0


def test_plot_trajectory_writes_pngs(traj, tmp_path):
    paths = plot_trajectory(traj, tmp_path / "p")
    assert [p.name for p in paths] == list(PLOT_NAMES)
    assert all(p.stat().st_size > 10_000 for p in paths)


@pytest.mark.parametrize("argv, expected", [
    (["render", "{dir}/missing.npz", "-o", "{dir}/a.mp4"], "trajectory file not found"),
    (["render", "{traj}", "-o", "{dir}/a.avi"], "must end in .mp4 or .gif"),
    (["render", "{traj}", "-o", "{dir}/a.mp4", "--camera", "follow:nobody"], "no body called 'nobody'"),
    (["render", "{traj}", "-o", "{dir}/a.mp4", "--camera", "sideways"], "expected 'frame' or 'follow:"),
    (["render", "{traj}", "-o", "{dir}/a.mp4", "--width", "0"], "--width: must be between 1"),
    (["render", "{traj}", "-o", "{dir}/a.mp4", "--height", "-4"], "--height: must be between 1"),
    (["render", "{traj}", "-o", "{dir}/a.mp4", "--width", "161"], "must be even"),
    (["render", "{traj}", "-o", "{dir}/a.mp4", "--fps", "0"], "--fps: must be a positive"),
    (["render", "{traj}", "-o", "{dir}/a.mp4", "--width", "wide"], "invalid int value"),
    (["render", "{bad}", "-o", "{dir}/a.mp4"], "not a readable trajectory file"),
    (["plot", "{dir}/missing.npz", "-o", "{dir}/p"], "trajectory file not found"),
    (["plot", "{traj}", "-o", "{bad}"], "exists and is not a folder"),
])
def test_bad_input_is_one_line_and_exit_2(argv, expected, traj_file, tmp_path, capsys):
    bad = tmp_path / "bad.npz"
    bad.write_text("not a zip file")
    argv = [a.format(dir=tmp_path, traj=traj_file, bad=bad) for a in argv]
    assert main(argv) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert expected in err and "\n" not in err and "Traceback" not in err, err
    assert not (tmp_path / "a.mp4").exists()
    assert not list(tmp_path.glob(".*tmp*"))  # no temporary file left behind


def test_python_api_rejects_bad_arguments(traj, tmp_path):
    with pytest.raises(tb.InputError, match="frame_index"):
        render_frame(traj, traj.frame_count, W, H)
    with pytest.raises(tb.InputError, match="colors"):
        render_frame(traj, 0, W, H, colors={"nobody": "red"})
    with pytest.raises(tb.InputError, match="width"):
        render_video(traj, tmp_path / "v.mp4", width=2.5, progress=False)


def test_a_body_inside_a_sensor_shows_through_it():
    # a red ball inside a large sensor box, seen from outside: drawn translucent, the sensor lets
    # the ball's red through; the same trajectory with its sensor flags dropped (an opaque box)
    # hides it. The pixels are counted with red_mask, as for the mover above.
    world = tb.World(gravity=(0, 0, 0))
    world.add_body(tb.Box(size=(2.0, 2.0, 2.0)), fixed=True, sensor=True, position=(0, 0, 1), name="zone")
    world.add_body(tb.Sphere(radius=0.4), mass=1.0, position=(0, 0, 1), name="ball")
    traj = tb.Simulator(world, dt=1 / 240).run(duration=0.5, frame_rate=6)
    assert traj.sensor is not None and traj.sensor.tolist() == [True, False]
    colors = {"zone": (200, 200, 200), "ball": (230, 0, 0)}
    seen = red_mask(render_frame(traj, 0, W, H, colors=colors)).sum()
    traj.sensor = None
    hidden = red_mask(render_frame(traj, 0, W, H, colors=colors)).sum()
    assert hidden == 0 and seen > 100


def test_video_colours_are_the_exporters_with_a_fixed_ground_first(tmp_path):
    """The video's colour rule is the glTF's, USD's and HTML's (``visual.body_color`` by body index,
    fixed bodies grey): a fixed ground first does not shift the moving bodies' colours. Before,
    the video went round the palette over the moving bodies only, so the first moving body was
    blue in the video and orange in Blender. Compared with the .glb's own materials too."""
    import json as _json
    import struct

    from tumble import visual
    from tumble.export import export
    from tumble.export.meshes import srgb_to_linear

    world = tb.World(gravity=(0, 0, 0))
    world.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True, name="ground")
    world.add_body(tb.Box(size=(0.3, 0.3, 0.3)), mass=1.0, position=(0, 0, 1), name="crate")
    world.add_body(tb.Sphere(radius=0.2), mass=1.0, position=(1, 0, 1), name="ball")
    world.add_body(tb.Box(size=(0.5, 0.5, 0.1)), fixed=True, position=(2, 0, 0.05), name="slab")
    world.add_body(tb.Sphere(radius=0.1), mass=1.0, position=(3, 0, 1), name="pebble")
    traj = tb.Simulator(world, dt=1 / 240).run(duration=0.25, frame_rate=4)
    fixed = np.asarray(traj.fixed, bool)
    assert fixed.tolist() == [True, False, False, True, False]
    got = body_colors(traj)
    expected = np.array([visual.body_color(i, bool(fixed[i])) for i in range(len(fixed))], dtype=np.uint8)
    np.testing.assert_array_equal(got, expected)
    assert tuple(got[1]) == visual.PALETTE[1] and tuple(got[0]) == visual.FIXED_COLOR
    # the .glb's material of each body (its node is child i + 1 of the root) holds the same colour
    data = export(traj, tmp_path / "t.glb").read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    gltf = _json.loads(data[20:20 + length])
    for i in range(len(fixed)):
        node = gltf["nodes"][i + 1]
        material = gltf["materials"][gltf["meshes"][node["mesh"]]["primitives"][0]["material"]]
        np.testing.assert_allclose(material["pbrMetallicRoughness"]["baseColorFactor"][:3],
                                   srgb_to_linear(got[i] / 255.0), atol=1e-6)
