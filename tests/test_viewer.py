"""The browser viewer (tumble.viewer): driven headless in Debian's Chromium through playwright.

Chromium comes from ``.ci/setup.d/chromium.sh`` (``apt-get install chromium``);
playwright's own browser download is never used (``executable_path``). Without
/usr/bin/chromium the browser tests fail when ``CI`` is set and are skipped
otherwise.

Headless WebGL: ``--headless=new`` with ``--use-angle=swiftshader
--enable-unsafe-swiftshader`` gives three.js a software WebGL2 context (ANGLE
on SwiftShader's Vulkan); ``--disable-gpu`` keeps Chromium off any real GPU.

Console messages: every message of type "error" and every page error fails
the test, except the known-benign ones in ``BENIGN_CONSOLE_ERRORS``: a missing
favicon, and the driver's performance notes of software WebGL ("GL Driver
Message ... Performance", "GPU stall due to ReadPixels"), which Chromium logs
as warnings today and could log as errors in other versions.
"""

from __future__ import annotations

import io
import json
import os
import signal
import socket
import subprocess
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from tumble.cli import main
from tumble.shapes import Box, Cone, Plane, Sphere, shape_to_dict
from tumble.trajectory import Trajectory

viser = pytest.importorskip("viser")

from tumble.viewer import load_input, view
from tumble.viewer.app import SELECTED_COLOR, linear_colors
from tumble.viewer.contacts import contacts_at
from tumble.viewer.meshes import body_mesh, mesh_key, shape_mesh

from tests.browser import BENIGN_CONSOLE_ERRORS, CHROMIUM, CHROMIUM_ARGS, browser_session  # noqa: F401  (re-exported)
from tests.ctrl_c import cli_under_ctrl_c
VIEWPORT = {"width": 960, "height": 640}
# Hide every DOM element but the three.js canvas (the GUI panel and notices, and the energy plot's
# own canvas inside the panel: uPlot draws on a <canvas> too), so that the pixels measured are the
# rendered scene's only and clicks reach it.
CANVAS_ONLY_CSS = ("body * { visibility: hidden !important; } canvas { visibility: visible !important; } "
                   ".uplot, .uplot * { visibility: hidden !important; }")
SRC = Path(__file__).resolve().parents[1] / "src"

FRAMES = 24
BOX_COLOR = np.array([66, 135, 245])  # body 0's colour in tumble.viewer.app.PALETTE


def make_trajectory(frames: int = FRAMES) -> Trajectory:
    """A box sliding 3 m along x while spinning about z, a ball and a cone at rest, a ground plane,
    and a second box like the first (so both are drawn by one batched mesh: rows 0 and 1) creeping
    10 cm along x, out of the first box's way."""
    t = np.arange(frames) / 24.0
    n = 5
    pos = np.zeros((frames, n, 3))
    ori = np.zeros((frames, n, 4))
    ori[..., 0] = 1.0
    s = t / t[-1]
    pos[:, 0] = np.stack([-1.5 + 3.0 * s, 0.0 * s, 0.6 + 0.0 * s], axis=1)
    angle = 1.5 * s
    ori[:, 0] = np.stack([np.cos(angle / 2), 0 * s, 0 * s, np.sin(angle / 2)], axis=1)
    pos[:, 1] = [0.0, 1.2, 0.4]
    pos[:, 3] = [0.0, -1.2, 0.125]  # cone: centre of mass a quarter of the height above its base
    pos[:, 4] = np.stack([-1.2 + 0.1 * s, 1.5 + 0.0 * s, 0.15 + 0.0 * s], axis=1)
    vel = np.zeros((frames, n, 3))
    vel[:, 0, 0] = 3.0 / t[-1]
    w = np.zeros((frames, n, 3))
    w[:, 0, 2] = 1.5 / t[-1]
    shapes = [Box((0.6, 0.4, 0.3)), Sphere(0.3), Plane(), Cone(0.3, 0.5), Box((0.6, 0.4, 0.3))]
    com = np.zeros((n, 3))
    com[3] = [0.0, 0.0, 0.125]
    mass = np.array([2.0, 1.0, 0.0, 1.0, 2.0])
    L = w * 0.05
    ke = 0.5 * np.sum(mass[None, :, None] * vel**2, axis=(1, 2)) + 0.5 * np.sum(w * L, axis=(1, 2))
    zero = np.zeros(frames)
    return Trajectory(
        time=t, names=np.array(["box", "ball", "ground", "cone", "box2"]), position=pos, orientation=ori,
        velocity=vel, angular_velocity=w, linear_momentum=mass[None, :, None] * vel, angular_momentum=L,
        kinetic_energy=ke, potential_energy=zero, total_linear_momentum=np.zeros((frames, 3)),
        total_angular_momentum=np.zeros((frames, 3)), orthonormality_error=zero, com_offset=com,
        shapes=np.array([json.dumps(shape_to_dict(sh)) for sh in shapes]),
        fixed=np.array([False, False, True, False, False]),
    )


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def wait_for(predicate, timeout: float, interval: float = 0.1):
    end = time.monotonic() + timeout
    while True:
        value = predicate()
        if isinstance(value, np.ndarray) or value:
            return value
        if time.monotonic() > end:
            return value
        time.sleep(interval)


def quat_matrix(q) -> np.ndarray:
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def project(camera, point, width, height) -> tuple[float, float]:
    """Pixel (u, v) of a world point, from the client's camera (viser: OpenCV convention, +z forward, y down)."""
    R = quat_matrix(camera.wxyz)  # camera to world
    p = R.T @ (np.asarray(point, float) - np.asarray(camera.position, float))
    f = 0.5 * height / np.tan(0.5 * camera.fov)
    return width / 2 + f * p[0] / p[2], height / 2 + f * p[1] / p[2]


def camera_settled(camera, timeout: float) -> bool:
    """True once the client's reported camera (pose and field of view) is the same over 1 s.
    NOTE: why: the client's first report can come before the viewer's initial camera reaches it;
    a box projected from that report was looked for 200 px from where it was drawn (seen once, on
    a loaded machine)."""
    last = None

    def same():
        nonlocal last
        now = (tuple(camera.position), tuple(camera.wxyz), float(camera.fov))
        ok = now == last
        last = now
        return ok

    return bool(wait_for(same, timeout, interval=1.0))


def png_pixels(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def gold_pixels(img: np.ndarray) -> np.ndarray:
    """Mask of the selection's gold (255, 215, 0), shaded: red and green well above blue, and close
    (the ball's orange has green at half its red)."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (r - b > 80) & (g - b > 60) & (g > 0.72 * r) & (g <= r)


def box_pixels(img: np.ndarray) -> np.ndarray:
    """Mask of the box's blue (shaded): blue well above red and above green."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (b - r > 60) & (b - g > 25)


def count_near(mask: np.ndarray, uv, radius: int) -> int:
    u, v = round(float(uv[0])), round(float(uv[1]))
    h, w = mask.shape
    return int(mask[max(v - radius, 0):min(v + radius, h), max(u - radius, 0):min(u + radius, w)].sum())


def settled_screenshot(page, predicate, timeout: float):
    """The page's pixels once ``predicate`` holds and two screenshots in a row agree (rendering done), or None."""
    previous = None

    def take():
        nonlocal previous
        img = png_pixels(page.screenshot())
        ok = predicate(img) and previous is not None and np.mean(np.any(img != previous, axis=-1)) < 1e-3
        previous = img
        return img if ok else None

    return wait_for(take, timeout, interval=0.3)


# ---- browser ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def browser():
    yield from browser_session()


@pytest.fixture
def viewer():
    port = free_port()
    v = view(make_trajectory(), host="127.0.0.1", port=port, play=False)
    try:
        assert v.port == port and v.url == f"http://127.0.0.1:{port}/"
        yield v
    finally:
        v.stop()


def test_page_loads_renders_and_scrubs(browser, viewer, tmp_path):
    page = browser.new_page(viewport=VIEWPORT)
    problems = []
    page.on("console", lambda m: problems.append(f"console {m.type}: {m.text} {m.location}") if m.type == "error" else None)
    page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
    try:
        # A blank page: the baseline for "not blank".
        page.set_content("<html><body style='margin:0;background:#fff'></body></html>")
        blank = png_pixels(page.screenshot())

        page.goto(viewer.url)
        page.wait_for_selector("canvas", timeout=30_000)
        client = wait_for(lambda: next(iter(viewer.server.get_clients().values()), None), 30)
        assert client is not None, "the page never connected to the viewer"
        assert wait_for(lambda: client.camera.update_timestamp != 0.0, 30), "the client never reported its camera"
        page.add_style_tag(content=CANVAS_ONLY_CSS)

        cam = client.camera
        assert camera_settled(cam, 30), "the client's camera never settled"
        height, width = blank.shape[:2]
        start = project(cam, viewer.traj.position[0, 0], width, height)
        end = project(cam, viewer.traj.position[-1, 0], width, height)
        assert np.hypot(end[0] - start[0], end[1] - start[1]) > 100, "the test scene's box should cross the view"
        radius = 20

        # Frame 0: rendered, not blank, the box where the camera projects its centre of mass.
        a = settled_screenshot(page, lambda img: count_near(box_pixels(img), start, radius) > 200, 30)
        if a is None:
            page.screenshot(path=str(tmp_path / "frame0.png"))
        assert a is not None, f"no box at its projected place {start} in frame 0 (see {tmp_path / 'frame0.png'})"
        blank_var, canvas_var = float(blank.var()), float(a.var())
        assert canvas_var > max(20.0 * blank_var, 100.0), (canvas_var, blank_var)
        assert count_near(box_pixels(a), end, radius) == 0

        # Scrub (server-side slider, as a user's drag arrives): the box moves to its last place.
        viewer.frame_slider.value = FRAMES - 1
        assert viewer.frame == FRAMES - 1

        b = settled_screenshot(page, lambda img: count_near(box_pixels(img), end, radius) > 200, 20)
        if b is None:
            page.screenshot(path=str(tmp_path / "last.png"))
        assert b is not None, f"no box at its projected place {end} after scrubbing (see {tmp_path / 'last.png'})"
        assert count_near(box_pixels(b), start, radius) == 0, "the box is still at its first place"
        changed = np.any(np.abs(a - b) > 30, axis=-1)
        assert count_near(changed, start, radius) > 200 and count_near(changed, end, radius) > 200
        # What does not move stays put: the ball (body 1) and the cone (body 3), where the box passes not.
        checked = 0
        for i in (1, 3):
            uv = project(cam, viewer.traj.position[0, i], width, height)
            if min(np.hypot(*np.subtract(uv, start)), np.hypot(*np.subtract(uv, end))) > 80:
                assert count_near(changed, uv, 10) < 20, f"body {i} changed"
                checked += 1
        assert checked, "no resting body to compare"

        # Picking: a click on the box selects it and shows its quantities.
        page.mouse.click(*end)
        assert wait_for(lambda: viewer.selected == 0 and "**box**" in viewer.info.content, 10), \
            f"clicking the box did not pick it (selected {viewer.selected})"
        info = viewer.info.content
        assert "**box**" in info and "ω (rad/s)" in info and "Kinetic energy" in info
        assert f"frame {FRAMES - 1}" in info

        # The second box is row 1 of the same batched mesh: the click's instance index picks it,
        # and its row of the colours turns gold in the browser (the first box's row back to blue).
        box2 = project(cam, viewer.traj.position[-1, 4], width, height)
        assert min(np.hypot(*np.subtract(box2, start)), np.hypot(*np.subtract(box2, end))) > 60
        page.mouse.click(*box2)
        assert wait_for(lambda: viewer.selected == 4 and "**box2**" in viewer.info.content, 10), \
            f"clicking the second box did not pick it (selected {viewer.selected})"
        page.mouse.move(2, 2)  # off the box: viser outlines the hovered object in yellow
        c = settled_screenshot(page, lambda img: count_near(gold_pixels(img), box2, radius) > 100
                               and count_near(box_pixels(img), end, radius) > 200, 20)
        if c is None:
            page.screenshot(path=str(tmp_path / "picked.png"))
        assert c is not None, f"the picked box is not highlighted at {box2} (see {tmp_path / 'picked.png'})"
    finally:
        page.close()
    assert not [p for p in problems if not any(b in p for b in BENIGN_CONSOLE_ERRORS)], problems


def test_server_listens_on_loopback_only(viewer):
    assert viewer.host == "127.0.0.1"
    tables = [Path("/proc/net/tcp"), Path("/proc/net/tcp6")]
    if not tables[0].exists():
        pytest.skip("no /proc/net/tcp")
    listening = []
    for table in tables:
        if not table.exists():
            continue
        for line in table.read_text().splitlines()[1:]:
            fields = line.split()
            local, state = fields[1], fields[3]
            address, port = local.rsplit(":", 1)
            if state == "0A" and int(port, 16) == viewer.port:  # 0A: LISTEN
                listening.append(address)
    assert listening, f"nothing listens on port {viewer.port}"
    assert all(a == "0100007F" for a in listening), f"listening on {listening}, not 127.0.0.1 only"
    # And from another address of this machine, if it has one, nobody answers.
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("10.255.255.255", 1))
            other = s.getsockname()[0]
    except OSError:
        other = None
    if other and not other.startswith("127."):
        with pytest.raises(OSError), socket.create_connection((other, viewer.port), timeout=2):
            pass


# ---- viewer state without a browser ---------------------------------------------------------------


def test_gui_scrub_select_toggles_and_no_contacts(viewer):
    assert viewer.frame == 0 and not viewer.playing
    viewer.set_frame(12)
    assert viewer.frame == 12
    # What the browser was sent (float32 rows of the batched arrays): body 0 where the trajectory says.
    position, wxyz = viewer.body_pose(0)
    np.testing.assert_allclose(position, viewer.traj.position[12, 0], rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(wxyz, viewer.traj.orientation[12, 0], rtol=1e-6, atol=1e-6)
    for i in (1, 2, 3, 4):
        np.testing.assert_allclose(viewer.body_pose(i)[0], viewer.traj.position[12, i], rtol=1e-6, atol=1e-6)
    # Instanced drawing: the two equal boxes share one batched mesh; the ball and the cone, which
    # never move, have groups that are posed once; the plane is not a mesh.
    groups = {tuple(int(b) for b in g.bodies): g.static for g in viewer.mesh_groups}
    assert groups == {(0, 4): False, (1,): True, (3,): True}
    assert "frame 12" in viewer.time_text.content

    assert viewer.body_color(0) == (66, 135, 245) and viewer.body_color(2) is None
    viewer.body_dropdown.value = "0: box"
    assert viewer.selected == 0
    assert viewer.body_color(0) == (255, 215, 0) and viewer.body_color(4) == viewer.colors[4]
    d = viewer.body_info(0)
    np.testing.assert_allclose(d["x"], viewer.traj.position[12, 0])
    assert d["kinetic_energy"] == pytest.approx(0.5 * (d["v"] @ d["P"] + d["omega"] @ d["L"]))
    assert "**box**" in viewer.info.content

    viewer.select(4)  # the highlight moves within the group: body 0's own colour is back
    assert viewer.body_color(0) == (66, 135, 245) and viewer.body_color(4) == (255, 215, 0)
    group = viewer.mesh_groups[0]  # what was sent: linear values of those sRGB colours
    np.testing.assert_array_equal(group.handle.batched_colors, linear_colors([viewer.colors[0], SELECTED_COLOR]))
    viewer.select(0)

    assert not viewer.axes_node.visible
    viewer.axes_checkbox.value = True
    assert viewer.axes_node.visible
    np.testing.assert_allclose(viewer.axes_node.batched_positions, viewer.traj.position[12], atol=1e-6)
    viewer.set_frame(13)  # shown axes follow the frames
    np.testing.assert_allclose(viewer.axes_node.batched_wxyzs, viewer.traj.orientation[13], atol=1e-6)
    viewer.set_frame(12)
    # No contact data: the toggles exist and draw nothing.
    viewer.contact_points_checkbox.value = True
    viewer.contact_forces_checkbox.value = True
    assert viewer.contacts == {}
    assert viewer.contact_points_node is None and viewer.contact_forces_node is None

    viewer.play()
    assert wait_for(lambda: viewer.frame != 12, 5), "playback did not advance"
    viewer.pause()


def test_body_colours_are_the_exporters():
    """Every drawn body has ``visual.body_color(i, fixed)``, the glTF's, USD's, HTML's and video's
    colour: a fixed box is grey, and bodies after a fixed one keep their index's colour (before,
    the viewer drew a fixed body as a lightened palette colour)."""
    from dataclasses import replace

    from tumble import visual

    traj = make_trajectory()
    fixed = np.array([True, False, True, False, False])  # box 0 fixed too, ground (a plane) fixed
    v = view(replace(traj, fixed=fixed), host="127.0.0.1", port=free_port(), play=False)
    try:
        for i in (0, 1, 3, 4):  # body 2 is the plane, drawn as a grid
            assert v.body_color(i) == visual.body_color(i, bool(fixed[i])), i
        assert v.body_color(0) == visual.FIXED_COLOR and v.body_color(3) == visual.PALETTE[3]
    finally:
        v.stop()


def test_contacts_are_drawn_when_the_trajectory_has_them(tmp_path):
    traj = make_trajectory(6)
    points = np.full((6, 3, 3), np.nan)
    forces = np.full((6, 3, 3), np.nan)
    points[:, 0] = [0.0, 1.2, 0.1]
    forces[:, 0] = [0.0, 0.0, 9.81]
    points[3:, 1] = [0.0, -1.2, 0.0]
    forces[3:, 1] = [0.0, 0.0, 5.0]
    path = tmp_path / "with_contacts.npz"
    traj.save(path)
    with np.load(path) as data:
        arrays = dict(data)
    np.savez(path, **arrays, contact_point=points, contact_force=forces)

    _, extras = load_input(path)
    assert set(extras) == {"contact_point", "contact_force"}
    v = view(path, port=0, play=False)
    try:
        assert v.contact_points_checkbox.value and v.contact_forces_checkbox.value
        assert len(contacts_at(v.contacts, 0)[0]) == 1 and len(contacts_at(v.contacts, 4)[0]) == 2
        assert v.contact_points_node is not None and v.contact_forces_node is not None
        v.set_frame(4)
        assert np.asarray(v.contact_points_node.points).shape == (2, 3)
        v.contact_forces_checkbox.value = False
        assert v.contact_forces_node is None
    finally:
        v.stop()


def test_meshes_keep_the_users_placement():
    cone = Cone(0.3, 0.5)
    mesh = shape_mesh(cone)
    assert mesh.is_watertight
    np.testing.assert_allclose(mesh.bounds, [[-0.3, -0.3, 0.0], [0.3, 0.3, 0.5]], atol=1e-12)
    vertices, _ = body_mesh(cone, [0.0, 0.0, 0.125])
    np.testing.assert_allclose(vertices.min(axis=0)[2], -0.125)  # the base, seen from the centre of mass
    assert shape_mesh(Plane()) is None
    np.testing.assert_allclose(shape_mesh(Box((1, 2, 3))).extents, [1, 2, 3])
    # Instancing's key: the same drawn arrays (even as other dtypes) share it; another offset does not.
    v, f = body_mesh(Box((1, 2, 3)), [0.0, 0.0, 0.0])
    assert mesh_key(v, f) == mesh_key(v.astype(np.float64).copy(), f.astype(np.int32))
    assert mesh_key(v, f) != mesh_key(*body_mesh(Box((1, 2, 3)), [0.0, 0.0, 0.1]))
    assert mesh_key(v, f) != mesh_key(*body_mesh(Box((1, 2, 4)), [0.0, 0.0, 0.0]))


# ---- CLI --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", ["missing", "suffix", "bad_scene", "bad_npz", "bad_host"])
def test_cli_bad_input_is_one_line_exit_2(case, tmp_path, capsys):
    args = {
        "missing": [str(tmp_path / "nope.npz")],
        "suffix": [str(tmp_path / "run.txt")],
        "bad_scene": [str(tmp_path / "bad.toml")],
        "bad_npz": [str(tmp_path / "junk.npz")],
        "bad_host": [str(tmp_path / "t.npz"), "--host", "no-such-host.invalid"],
    }[case]
    (tmp_path / "run.txt").write_text("hello\n")
    (tmp_path / "bad.toml").write_text("[simulation]\nduration = -1\n[[bodies]]\nname = 'a'\nshape = { type = 'sphere', radius = 1 }\nmass = 1\n")
    (tmp_path / "junk.npz").write_bytes(b"not a zip file")
    make_trajectory(3).save(tmp_path / "t.npz")
    status = main(["view", *args, "--no-browser", "--port", "0"])
    err = capsys.readouterr().err
    assert status == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tumble: error: "), err
    assert "Traceback" not in err
    expected = {"missing": "nope.npz", "suffix": "run.txt", "bad_scene": "duration", "bad_npz": "junk.npz", "bad_host": "--host"}[case]
    assert expected in lines[0]


def test_the_energy_plot_shows_the_runs_energy(viewer):
    """The "Energy" folder plots each frame's kinetic, potential and total energy as the trajectory
    has them; a run of more than 10 000 frames is plotted every k-th frame, its last one kept."""
    t, kinetic, potential, total = viewer.energy_plot.data
    traj = viewer.traj
    assert np.array_equal(t, traj.time) and np.array_equal(kinetic, traj.kinetic_energy)
    assert np.array_equal(potential, traj.potential_energy) and np.array_equal(total, kinetic + potential)
    long = make_trajectory(25_001)
    v = view(long, port=free_port(), play=False)
    try:
        t = v.energy_plot.data[0]
        assert len(t) <= 10_001 and t[0] == long.time[0] and t[-1] == long.time[-1]
        assert np.all(np.diff(t) > 0) and np.isin(t, long.time).all()
    finally:
        v.stop()


def test_load_input_runs_a_mujoco_model_as_a_scene():
    """``tumble view model.xml`` runs the model as ``tumble run`` does (a scene of its own): the
    frames of ``load_scene(model).run()``."""
    import tumble as tb

    path = Path(__file__).resolve().parents[1] / "examples" / "robots" / "pendulum.xml"
    traj, extras = load_input(path, progress=False)
    plain = tb.load_scene(path).run(progress=False)
    assert extras == {} and np.array_equal(traj.position, plain.position) and len(traj.time) == len(plain.time) > 1


def test_cli_serves_a_trajectory_until_ctrl_c(tmp_path):
    path = tmp_path / "run.npz"
    make_trajectory(6).save(path)
    port = free_port()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.Popen(
        cli_under_ctrl_c("view", path, "--port", port, "--no-browser"),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )
    killer = threading.Timer(60.0, proc.kill)  # never hang the suite
    killer.start()
    try:
        seen = []
        for line in proc.stdout:  # the ready line comes once the viewer is built and serving
            seen.append(line)
            if "Ctrl-C" in line:
                break
        assert proc.poll() is None, "".join(seen) + proc.stderr.read()
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=5) as r:
            assert r.status == 200
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=20)
        out = "".join(seen) + out
    finally:
        killer.cancel()
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    assert f"http://127.0.0.1:{port}/" in out and "Traceback" not in err
