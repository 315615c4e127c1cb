"""A run as one self-contained web page (``tumble.export.html``): ``export_html``, ``tumble export
RUN -o run.html`` and ``Trajectory.show()`` (a notebook's iframe), opened in headless Chromium
(``tests/browser.py``). The page's glTF is ``export_gltf``'s own bytes (validated by the Khronos
validator in tests/test_export.py), so these tests check what the page adds: it carries those
bytes, plays them from a file with no network, and its controls drive the animation.
"""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

import numpy as np
import pytest

from tests.browser import BENIGN_CONSOLE_ERRORS, browser_session
from tumble.cli import main
from tumble.export.gltf import glb_bytes, gltf_document
from tumble.export.html import HtmlView, html_document
from tumble.scene import load_scene

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
VIEWPORT = {"width": 800, "height": 560}


@pytest.fixture(scope="module")
def traj():
    scene = load_scene(EXAMPLES / "eggs.toml")
    scene.duration = 1.5
    scene.check()
    return scene.run(progress=False)


@pytest.fixture(scope="module")
def browser():
    yield from browser_session()


def embedded_glb(page_text: str) -> bytes:
    found = re.search(r'<script id="tumble-glb" type="application/octet-stream">([^<]*)</script>', page_text)
    assert found
    return base64.b64decode(found.group(1))


def test_the_page_carries_the_runs_gltf_and_its_viewer(traj):
    """The page holds exactly the bytes export_gltf writes for the run (base64), the vendored
    model-viewer script inline (no <script src>, no link to fetch), the run's duration as the
    slider's end, and a camera aimed at the moving bodies' box (glTF's y up: tumble's z)."""
    page = html_document(traj)
    assert embedded_glb(page) == glb_bytes(*gltf_document(traj))
    assert "customElements.define(\"model-viewer\"" in page
    assert "<script src" not in page and "<link" not in page
    duration = float(traj.time[-1] - traj.time[0])
    assert f'max="{duration!r}"' in page or f'max="{duration}"' in page
    moving = ~np.asarray(traj.fixed)
    centre = 0.5 * (traj.position[:, moving].min(axis=(0, 1)) + traj.position[:, moving].max(axis=(0, 1)))
    target = re.search(r'camera-target="([^"]*)"', page).group(1).replace("m", "").split()
    np.testing.assert_allclose([float(v) for v in target], [centre[0], centre[2], -centre[1]], rtol=1e-5, atol=1e-6)
    assert "<title>tumble: 10 bodies" in page


def open_page(browser, url):
    page = browser.new_page(viewport=VIEWPORT)
    requests, errors = [], []
    page.on("request", lambda r: requests.append(r.url))
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" and not any(
        b in m.text for b in BENIGN_CONSOLE_ERRORS) else None)
    page.goto(url)
    return page, requests, errors


def test_the_exported_page_plays_from_a_file_with_no_network(traj, browser, tmp_path, capsys):
    """``tumble export RUN -o run.html``, opened from the file: the model loads (one animation,
    the run's duration to 1e-6 s), the page asks for nothing but the file itself and the blob it
    makes of its own bytes, it plays (time advances), Pause stops it, the slider sets the time,
    and the bodies are drawn (the eggs' colours in the picture)."""
    run = tmp_path / "run"
    traj.save(run / "trajectory.npz")
    out = tmp_path / "eggs.html"
    assert main(["export", str(run), "-o", str(out)]) == 0
    assert "web page with its viewer" in capsys.readouterr().out
    page, requests, errors = open_page(browser, out.as_uri())
    try:
        page.wait_for_selector("body[data-ready='1']", timeout=60_000)
        state = page.evaluate("() => { const m = document.getElementById('model');"
                              " return {d: m.duration, a: m.availableAnimations, p: m.paused}; }")
        assert state["a"] == ["trajectory"] and state["p"] is False
        assert state["d"] == pytest.approx(float(traj.time[-1] - traj.time[0]), abs=1e-6)
        t0 = page.evaluate("() => document.getElementById('model').currentTime")
        page.wait_for_timeout(400)
        assert page.evaluate("() => document.getElementById('model').currentTime") != t0
        page.click("#play")
        assert page.evaluate("() => document.getElementById('model').paused") is True
        assert page.inner_text("#play") == "Play"
        page.evaluate("() => { const s = document.getElementById('time'); s.value = 0.75;"
                      " s.dispatchEvent(new Event('input')); }")
        assert page.evaluate("() => document.getElementById('model').currentTime") == pytest.approx(0.75, abs=1e-9)
        page.wait_for_timeout(300)
        assert page.inner_text("#clock") == "0.750 s"
        shot = tmp_path / "shot.png"
        page.locator("#model").screenshot(path=str(shot))
        from PIL import Image

        pixels = np.asarray(Image.open(shot).convert("RGB")).reshape(-1, 3).astype(int)
        colourful = (pixels.max(axis=1) - pixels.min(axis=1)) > 60  # the background and the ramp are grey
        assert colourful.sum() > 200, colourful.sum()
        assert {u.split(":")[0] for u in requests} <= {"file", "blob", "data"}, requests
        assert errors == []
    finally:
        page.close()


def test_show_is_the_page_in_a_notebook_iframe(traj, browser):
    """``Trajectory.show()``: Jupyter's ``_repr_html_`` is an <iframe> whose srcdoc is the page
    itself (escaped), scripts allowed in the frame alone; set into a page, the frame loads the
    model as the file does."""
    view = traj.show(height=400)
    assert isinstance(view, HtmlView)
    cell = view._repr_html_()
    assert cell.startswith("<iframe srcdoc=\"") and 'sandbox="allow-scripts"' in cell and "height: 400px" in cell
    srcdoc = re.search(r'srcdoc="([^"]*)"', cell).group(1)
    assert html.unescape(srcdoc) == view.page
    page = browser.new_page(viewport=VIEWPORT)
    try:
        page.set_content(cell)
        frame = page.frame_locator("iframe")
        frame.locator("body[data-ready='1']").wait_for(timeout=60_000)
        assert frame.locator("#info").inner_text() == f"10 bodies, {len(traj.time)} frames, 1.500 s"
    finally:
        page.close()


def test_cli_html_bad_input_and_overwrite(traj, tmp_path, capsys):
    """The .html output follows the export command's rules: an existing file is kept without
    --force (one line, status 2), replaced with it; an unknown suffix's line names .html too."""
    run = tmp_path / "run"
    traj.save(run / "trajectory.npz")
    out = tmp_path / "page.html"
    out.write_text("precious")
    assert main(["export", str(run), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--force" in err and out.read_text() == "precious"
    assert main(["export", str(run), "-o", str(out), "--force"]) == 0
    assert out.read_text().startswith("<!doctype html>")
    assert main(["export", str(run), "-o", str(tmp_path / "x.pdf")]) == 2
    assert ".html" in capsys.readouterr().err
